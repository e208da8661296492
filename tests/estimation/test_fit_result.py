"""The one fit result both fitting procedures return (estimation/fit_result.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ehsa_opt.estimation.fit_result import FitResult


def _group_fit() -> FitResult:
    return FitResult(success=True, message="Solve_Succeeded", status="Solve_Succeeded",
                     parameters={"nut_coulomb_N": 40.0, "offset_N": -1.5},
                     free=["nut_coulomb_N"], objective=1.02, nit=17,
                     starts=[{"status": "Solve_Succeeded", "success": True, "objective": 1.02,
                              "iterations": 17}], seconds=0.4, sse=2040.0, n_obs=2000,
                     covariance=np.array([[0.25]]), covariance_info={"n_eff": 180.0})


def test_interval_reads_the_covariance_of_the_free_names_only() -> None:
    fit = _group_fit()
    assert fit.interval("nut_coulomb_N") == pytest.approx((40.0 - 1.96 * 0.5, 40.0 + 1.96 * 0.5))
    assert fit.interval("offset_N") is None          # fixed, not fitted
    undetermined = FitResult(success=True, message="", parameters={"a": 1.0}, free=["a"],
                             covariance=np.array([[math.inf]]))
    assert undetermined.interval("a") is None
    assert "95 %: 39.02" in fit.summary() and "over 2000 observations" in fit.summary()


def test_json_round_trip_keeps_every_field_and_refuses_unknown_keys() -> None:
    fit = _group_fit()
    back = FitResult.from_json(fit.to_json())
    assert back.to_dict() == fit.to_dict()
    assert np.array_equal(back.covariance, fit.covariance) and back["nit"] == 17
    failed = FitResult(success=False, message="all starts failed", status="Infeasible",
                       parameters={"nut_coulomb_N": math.nan}, objective=math.inf)
    again = FitResult.from_json(failed.to_json())   # NaN / inf are stored as null
    assert not again.success and math.isnan(again.parameters["nut_coulomb_N"])
    assert again.summary() == "fit FAILED (Infeasible): all starts failed"
    with pytest.raises(ValueError, match="unknown key.*varied"):
        FitResult.from_dict({**fit.to_dict(), "varied": ["nut_coulomb_N"]})
    with pytest.raises(ValueError, match="no iteration history"):
        fit.plot()
