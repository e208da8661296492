"""The optimisation outcome: a frozen record with one way to save, read back and show it."""

import dataclasses
import json
import math

import pytest

from ehsa_opt.design.outcome import OptimizeOutcome

RECORD = {"method": "goal-attainment", "success": True, "message": "converged",
          "design": {"lead_mm_per_rev": 8.0, "load_ohm": 40.0},
          "objectives": {"comfort": 0.9, "road_holding": 0.8, "inverse_power": 0.01,
                         "inverse_efficiency": 1.5},
          "metrics": {"power_W": 120.0, "efficiency": 0.66, "comfort_weighted_rms_m_s2": 2.5},
          "gamma": -0.125, "nan_value": math.nan}


def test_outcome_is_a_frozen_dataclass_not_a_dict() -> None:
    out = OptimizeOutcome(RECORD)
    assert not isinstance(out, dict)
    with pytest.raises(dataclasses.FrozenInstanceError):
        out.result = None  # type: ignore[misc]
    with pytest.raises(TypeError):
        out["design"]  # type: ignore[index]  # noqa: B018
    assert out.success and out.design == RECORD["design"] and out.method == "goal-attainment"


def test_json_round_trip_is_standard_json(tmp_path) -> None:
    text = OptimizeOutcome(RECORD).to_json()
    assert json.loads(text)["nan_value"] is None  # standard JSON: NaN -> null
    (tmp_path / "result.json").write_text(text)
    back = OptimizeOutcome.from_json(tmp_path / "result.json")
    assert back.objectives == RECORD["objectives"] and back.result is None
    assert OptimizeOutcome.from_json(text).record == back.record


def test_from_json_refuses_what_is_not_a_result(tmp_path) -> None:
    bad = tmp_path / "x.json"
    bad.write_text('{"design": {}}')
    with pytest.raises(ValueError, match="x.json: not an optimisation result"):
        OptimizeOutcome.from_json(bad)


def test_summary_states_the_numbers_and_plot_needs_the_solver() -> None:
    out = OptimizeOutcome(RECORD)
    text = out.summary()
    assert "goal-attainment: converged" in text
    assert "lead_mm_per_rev = 8" in text and "gamma = -0.1250" in text
    assert "power 120.0 W, efficiency 66.0 %" in text
    with pytest.raises(ValueError, match="no solver results"):
        out.plot()


def test_every_result_summarises_itself() -> None:
    import numpy as np

    from ehsa_opt.design.goal import GoalAttainmentResult
    from ehsa_opt.design.nsga2 import ParetoResult
    from ehsa_opt.estimation.fit_result import FitResult
    names = ("comfort", "road_holding")
    ga = GoalAttainmentResult(True, "ok", -0.25, {"load_ohm": 40.0},
                              {"comfort": 0.5, "road_holding": 0.75}, np.ones(2), np.ones(2),
                              names, [], [], {})
    assert "gamma = -0.2500" in ga.summary() and "road_holding = 0.75" in ga.summary()
    pr = ParetoResult(True, "done", np.zeros((2, 1)), {"load_ohm": np.array([10.0, 20.0])},
                      np.array([[1.0, 2.0], [2.0, 1.0]]), names, 1, "knee",
                      [{"n_eval": 40, "hv": 0.5}], np.ones(2), np.ones(2), {})
    text = pr.summary()
    assert "front: 2 designs, hypervolume 0.5 after 40" in text and "load_ohm = 20" in text
    fit = FitResult(success=True, message="ok", status="Solve_Succeeded",
                    parameters={"nut_coulomb_N": 40.0}, nit=12, delta_F=0.1,
                    force_relative_error_percent=2.5)
    assert "δ_V —" in fit.summary() and "nut_coulomb_N = 40" in fit.summary()
    failed = FitResult(success=False, message="no start converged", status="Infeasible")
    assert failed.summary() == "fit FAILED (Infeasible): no start converged"
