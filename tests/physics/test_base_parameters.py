"""One declaration of the base parameters: every procedure's bounds are a named override
of it, inside its physical bounds; ``FrictionParams`` validates against it; one start
concept for ``fit_tests`` and ``fit_group``."""

import dataclasses

import numpy as np
import pytest

from ehsa_opt.estimation.bounds import ENVELOPE_PARAMETERS
from ehsa_opt.estimation.discrepancy.rig import BASE_SPECS, DISCREPANCY_PARAMETERS
from ehsa_opt.estimation.identify_options import IDENTIFY_PARAMETERS, PARAMETER_BOUNDS, START_RANGES
from ehsa_opt.estimation.starts import draw_starts
from ehsa_opt.physics.base_parameters import PARAMETERS, override
from ehsa_opt.physics.bench_model import BenchModel
from ehsa_opt.physics.params import FRICTION_NAMES, FRICTION_RANGES, FrictionParams, \
    HarvesterParams, ParameterError


def test_every_friction_parameter_is_declared_once_with_its_unit():
    assert set(FRICTION_NAMES) <= set(PARAMETERS)
    fields = {f.name: f for f in dataclasses.fields(FrictionParams)}
    for n in FRICTION_NAMES:
        q = PARAMETERS[n]
        assert fields[n].metadata["unit"] == q.unit
        assert q.lower <= q.start[0] <= q.start[1] <= q.upper
        assert FRICTION_RANGES[n] == q.start


@pytest.mark.parametrize("name", FRICTION_NAMES)
def test_friction_params_refuse_values_outside_the_declared_bounds(name):
    q = PARAMETERS[name]
    with pytest.raises(ParameterError, match=name):
        FrictionParams(**{name: q.upper * 1.5})
    FrictionParams(**{name: q.upper, **({"nut_breakaway_N": q.upper}
                                        if name == "nut_coulomb_N" else {}),
                      **({"bearing_breakaway_Nm": q.upper}
                         if name == "bearing_coulomb_Nm" else {})})


@pytest.mark.parametrize("table", [IDENTIFY_PARAMETERS, ENVELOPE_PARAMETERS,
                                   DISCREPANCY_PARAMETERS])
def test_overrides_name_their_procedure_and_stay_inside_the_physical_bounds(table):
    for n, q in table.items():
        base = PARAMETERS[n]
        assert q.unit == base.unit and q.start == base.start
        if q.bounds != base.bounds or q.scale != base.scale:
            assert q.procedure and q.why, n
        assert base.lower <= q.lower < q.upper <= base.upper, n


def test_each_procedure_keeps_its_named_nut_breakaway_range():
    assert IDENTIFY_PARAMETERS["nut_breakaway_N"].bounds == (0.0, 200.0)
    assert IDENTIFY_PARAMETERS["nut_breakaway_N"].procedure == "identification"
    assert PARAMETER_BOUNDS["nut_breakaway_N"] == (0.0, 200.0, 100.0)
    assert (BASE_SPECS["nut_breakaway_N"].lower, BASE_SPECS["nut_breakaway_N"].upper) \
        == (0.0, 2000.0)
    for n, spec in BASE_SPECS.items():  # the discrepancy's override, inside the physics
        assert PARAMETERS[n].lower <= spec.lower < spec.upper <= PARAMETERS[n].upper, n
        assert spec.unit == PARAMETERS[n].unit
    # the identification's friction starts lie inside its bounds
    for n in FRICTION_NAMES:
        lo, hi, _ = PARAMETER_BOUNDS[n]
        assert lo <= START_RANGES[n][0] <= START_RANGES[n][1] <= hi, n


def test_an_override_must_say_why_and_name_known_parameters():
    with pytest.raises(ValueError, match="names its procedure"):
        PARAMETERS["nut_coulomb_N"].with_bounds(0.0, 10.0, procedure="x", why="")
    with pytest.raises(KeyError, match="nut_colomb_N"):
        override("x", "typo", {"nut_colomb_N": (0.0, 1.0)})
    with pytest.raises(ValueError, match="lower < upper"):
        PARAMETERS["nut_coulomb_N"].with_bounds(5.0, 1.0, procedure="x", why="y")


def test_starts_a_number_draws_seeded_points_in_the_declared_ranges_a_list_is_kept():
    model = BenchModel(HarvesterParams())
    names = list(FRICTION_NAMES)
    a = draw_starts(model, names, 5, seed=3)
    assert a == draw_starts(model, names, 5, seed=3) != draw_starts(model, names, 5, seed=4)
    for s in a:
        assert s["nut_breakaway_N"] >= s["nut_coulomb_N"]
        for n in names:
            lo, hi = PARAMETERS[n].start
            assert lo <= s[n] <= hi, n
    given = [{"nut_coulomb_N": np.float64(12.0)}]
    assert draw_starts(model, names, given) == [{"nut_coulomb_N": 12.0}]
    for bad in (0, True, [], ["nut_coulomb_N"], 2.5):
        with pytest.raises(ValueError, match="starts must be"):
            draw_starts(model, names, bad, where="fit_x")
