"""A bound of a member's range counts only where it is active: the unconstrained
Gauss–Newton step from the fit crosses it."""

import dataclasses
import math

import pytest

from ehsa_opt.datasets.synthetic import PROTOTYPE_FRICTION, SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import Rig
from ehsa_opt.estimation.discrepancy.bounds import at_bound, at_bound_names, unconstrained_step
from ehsa_opt.estimation.discrepancy.judge import refuse_at_bound
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.physics import make_component
from ehsa_opt.physics.params import HarvesterParams

COMP = make_component("winding_heating")
NAMES = ["winding_heating_K_per_J", "winding_cooling_time_s"]


def _step(h_true, h_fit):
    """Data with a winding heating of ``h_true`` K/J (τ 3 s, noise-free beyond the
    generator's own), the step from a fit at ``h_fit`` K/J (the rest at the truth)."""
    eff = {"winding_heating_K_per_J": h_true, "winding_cooling_time_s": 3.0}
    tests = generate_bench_tests(SyntheticSpec(effects={"winding_heating": eff},
                                               frequencies_hz=(2.5, 3.5), loads_ohm=(3.0, 15.0),
                                               cycles=2.0, seed=3))
    p = {**dataclasses.asdict(PROTOTYPE_FRICTION), **eff, "winding_heating_K_per_J": h_fit}
    return p, unconstrained_step(prepare_tests(tests), Rig(HarvesterParams(), True, (COMP,)),
                                 p, NAMES)


def test_the_step_is_zero_at_the_optimum_and_points_to_it_elsewhere():
    p, st = _step(8.0, 8.0)
    assert abs(st["winding_heating_K_per_J"]) < 0.05
    # 9.9 K/J is within 5 % of the 10 K/J edge; the optimum (8) is inside: not active
    p, st = _step(8.0, 9.9)
    assert st["winding_heating_K_per_J"] == pytest.approx(-1.9, abs=0.4)
    assert at_bound(p, COMP.parameters) == ["winding_heating_K_per_J"]  # the proxy
    assert at_bound(p, COMP.parameters, step=st) == []
    # data wanting 14 K/J, the fit stopped at the edge: the step crosses it
    p, st = _step(14.0, 9.9)
    assert st["winding_heating_K_per_J"] > 0.1 + 2.0
    assert at_bound(p, COMP.parameters, step=st) == ["winding_heating_K_per_J"]


def test_an_undetermined_parameter_near_its_edge_stays_at_bound():
    p = {"winding_heating_K_per_J": 9.9, "winding_cooling_time_s": 1e4}
    st = {"winding_heating_K_per_J": -1.0, "winding_cooling_time_s": math.nan}
    assert at_bound(p, COMP.parameters, step=st) == ["winding_cooling_time_s"]
    # a step that leaves the range on its other side is no evidence of an inside optimum
    p = {"winding_heating_K_per_J": 10.0, "winding_cooling_time_s": 1e4}
    st = {"winding_heating_K_per_J": -16.7, "winding_cooling_time_s": -7e8}
    assert at_bound(p, COMP.parameters, step=st) == NAMES


def _refused(c, specs, member, say=None, step=None):
    """The bound check as the search makes it: measured, then judged."""
    at_bound_names(c, specs, member, say, step)
    return refuse_at_bound(c, say)


class _C:
    def __init__(self, parameters):
        self.parameters, self.earns, self.earns_by, self.effect = parameters, True, "x", "w"


def test_refuse_at_bound_asks_for_the_step_only_near_an_edge():
    calls = []

    def step():
        calls.append(1)
        return {"winding_heating_K_per_J": -2.0, "winding_cooling_time_s": 0.0}

    c = _C({"winding_heating_K_per_J": 3.0, "winding_cooling_time_s": 5.0})
    assert not _refused(c, COMP.parameters, None, step=step) and not calls
    c = _C({"winding_heating_K_per_J": 9.8, "winding_cooling_time_s": 5.0})
    said = []
    assert not _refused(c, COMP.parameters, None, said.append, step) and c.earns
    assert calls and "not active" in said[0]
    c = _C({"winding_heating_K_per_J": 9.8, "winding_cooling_time_s": 5.0})
    assert _refused(c, COMP.parameters, None, step=lambda: {
        "winding_heating_K_per_J": 0.5}) and not c.earns
