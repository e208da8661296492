"""A lone fit's simulations spread over the run's workers give the same numbers, bit for
bit, as the same simulations one after the other in the calling process."""

import os

import numpy as np
import pytest

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import spread as spread_mod
from ehsa_opt.physics import make_component
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.rig import (Rig, predict, predict_map,
                                                 predict_map_jacobian, simulate_one)
from ehsa_opt.estimation.discrepancy.spread import spread_simulations


def _campaign(effect, values):
    spec = SyntheticSpec(effects={effect: values}, frequencies_hz=(1.0, 2.0),
                         loads_ohm=(47.0, 109.0), seed=3)
    pts = prepare_tests(generate_bench_tests(spec), True)
    rig = Rig(spec.harvester, True, (make_component(effect),))
    return pts, rig, {**make_component(effect).defaults(), **spec.friction.as_dict(), **values}


def _same(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)


def test_a_rattling_contact_simulated_on_two_workers_is_the_same_to_the_last_bit():
    pts, rig, p = _campaign("backlash", {"backlash_gap_m": 3e-4,
                                         "backlash_contact_stiffness_N_per_m": 1e8,
                                         "backlash_contact_damping_Ns_per_m": 8e3})
    alone = predict(pts, rig, p)
    with spread_simulations(2, pts):
        pool = spread_mod._POOL[0][0]
        assert pool.submit(os.getpid).result() != os.getpid()  # worker processes
        got = spread_mod.spread(simulate_one, "cvodes", pts, rig, p, rtol=1e-7, filtered=True)
        together = predict(pts, rig, p)
    assert got is not None
    _same(got, alone)
    _same(together, alone)
    assert spread_mod._POOL[0] is None  # closed with the block


def test_the_map_and_its_sensitivities_spread_give_the_same_numbers():
    pts, rig, p = _campaign("compliance", {"compliance_stiffness_N_per_m": 2e6,
                                           "compliance_damping_Ns_per_m": 1e3})
    names = ["compliance_stiffness_N_per_m", "nut_coulomb_N"]
    y0, (y1, j1) = predict_map(pts, rig, p), predict_map_jacobian(pts, rig, p, names)
    with spread_simulations(2, pts):
        _same(predict_map(pts, rig, p), y0)
        y2, j2 = predict_map_jacobian(pts, rig, p, names)
    _same(y2, y1)
    _same(j2, j1)


def test_tests_the_workers_do_not_hold_are_simulated_by_the_caller():
    pts, rig, p = _campaign("compliance", {"compliance_stiffness_N_per_m": 2e6,
                                           "compliance_damping_Ns_per_m": 1e3})
    with spread_simulations(2, pts[:1]):
        assert spread_mod.spread(simulate_one, "map", pts, rig, p) is None  # one test is not held
        assert spread_mod.spread(simulate_one, "map", pts[:1], rig, p) is None  # fewer than MIN_TESTS
    with spread_simulations(1, pts):  # one job: nothing to spread on
        assert spread_mod._POOL[0] is None
    with pytest.raises(IndexError):  # the registry is cleared with the block
        spread_mod._TESTS[0]
