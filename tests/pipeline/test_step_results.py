"""Typed step results (pipeline/step_results.py): what the step cache stores reloads
into the same typed result, and the later steps read the friction sets through it."""

from __future__ import annotations

import json

import pytest

from ehsa_opt.datasets.friction_source import FrictionSets
from ehsa_opt.physics.params import FrictionParams, ParameterError
from ehsa_opt.pipeline.base import Context
from ehsa_opt.pipeline.step_results import IdentificationStepResult


def _sets() -> FrictionSets:
    lo = FrictionParams(nut_breakaway_N=5.0, nut_coulomb_N=1.0)
    mid = FrictionParams(nut_breakaway_N=20.0, nut_coulomb_N=4.0)
    hi = FrictionParams(nut_breakaway_N=50.0, nut_coulomb_N=10.0)
    return FrictionSets(lo, mid, hi, "data-supported", paper_min=lo, paper_max=hi)


def test_identification_result_survives_the_cache_and_feeds_later_steps(tmp_path) -> None:
    res = IdentificationStepResult(3, 4, 12.5, 7.96e-4, True, {"0.05": 61.2}, 0.33, _sets())
    stored = json.loads(json.dumps(res.to_dict(), allow_nan=False))  # as the cache keeps it
    assert IdentificationStepResult.from_dict(stored) == res
    # the friction_sets table has the layout of identification.json's
    assert set(stored["friction_sets"]) == {"min", "best", "max", "method", "paper_min",
                                            "paper_max"}
    ctx = Context(tmp_path, quick=True, jobs=1, results={"identification": stored})
    assert ctx.friction_sets() == res.friction_sets
    assert ctx.friction_sets().bounds("paper") == (res.friction_sets.paper_min,
                                                   res.friction_sets.paper_max)
    # no identification step, or one without bounds: nothing to read
    assert Context(tmp_path, quick=True, jobs=1).friction_sets() is None
    failed = IdentificationStepResult(0, 4)
    assert IdentificationStepResult.from_dict(failed.to_dict()).friction_sets is None


def test_friction_sets_from_the_cache_are_validated_as_received_data() -> None:
    table = _sets().to_dict()
    del table["best"]
    with pytest.raises(ParameterError, match="no 'best' case"):
        FrictionSets.from_dict(table)
    table = _sets().to_dict()
    table["max"]["nut_coulomb_N"] = float("nan")
    with pytest.raises(ParameterError, match="max: nut_coulomb_N"):
        FrictionSets.from_dict(table)
    no_paper = FrictionSets(*(FrictionParams(),) * 3)
    with pytest.raises(ValueError, match="no paper's per-parameter sets"):
        no_paper.bounds("paper")


def test_design_result_survives_the_cache_and_says_when_there_is_none() -> None:
    from ehsa_opt.physics.params import HarvesterParams
    from ehsa_opt.pipeline.step_results import DesignStepResult
    d = {"total_inertia_gcm2": 250.0, "lead_mm_per_rev": 7.0,
         "speed_constant_rpm_per_V": 29.8, "load_ohm": 75.0}
    h = HarvesterParams.from_design(250.0, 7.0, 29.8, 75.0)
    res = DesignStepResult(d, h, -0.12, True, {"comfort": 0.9}, {"power_W": 12.0},
                           binding=["comfort"])
    stored = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    back = DesignStepResult.from_dict(stored)
    assert back == res and back.optimum_harvester.load_ohm == pytest.approx(75.0)
    assert DesignStepResult.from_dict({"applicable": False}) is None   # rig without generator
    assert DesignStepResult.from_dict(None) is None
