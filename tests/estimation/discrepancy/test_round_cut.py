"""The time budget's cut is stated only when skipped work could change the answer, and the
workflow's deadline leaves a measured reserve for what runs after it."""

from types import SimpleNamespace as NS

import math

from ehsa_opt.estimation.discrepancy.search import _ranked_above
from ehsa_opt.pipeline.discrepancy_report import (INNER_BUDGET_SHARE, RESERVE_S,
                                                  inner_budget_s)


def _rk(values, fitted):
    """A round's ranking: rank values on the force channel; fitted members with their
    held-out ΔBIC."""
    scores = {n: {"applicable": True, "score": v, "chi2": 0.0} for n, v in values.items()}
    cands = {n: NS(fitted=n in fitted, delta_bic_heldout=fitted.get(n, math.nan))
             for n in values}
    return NS(scores=scores, cands=cands)


def test_a_member_fitted_without_held_out_evidence_is_not_work_left():
    rk = _rk({"cogging": 0.032, "backlash": 0.024, "voltage_drop": 0.001},
             {"cogging": 12.5, "backlash": 12.9})
    assert _ranked_above(rk, NS(remaining=["cogging", "backlash", "voltage_drop"])) == []


def test_an_unfitted_or_masked_member_is_work_left():
    rk = _rk({"cogging": 0.032, "backlash": 0.024, "voltage_drop": 0.001},
             {"cogging": -30.0})
    left = _ranked_above(rk, NS(remaining=["cogging", "backlash", "voltage_drop"]))
    assert left == ["cogging", "backlash"]  # masked by the winner; ranked, never fitted


def test_inner_deadline_keeps_the_reserve():
    assert inner_budget_s(170.0) == 170.0 - RESERVE_S
    assert inner_budget_s(60.0) == INNER_BUDGET_SHARE * 60.0  # small budgets: the share
    assert inner_budget_s(170.0) > INNER_BUDGET_SHARE * 170.0
