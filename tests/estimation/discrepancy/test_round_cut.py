"""The time budget's cut is stated only when skipped work could change the answer, and the
workflow's deadline leaves a measured reserve for what runs after it."""

from types import SimpleNamespace as NS

import math

from ehsa_opt.estimation.discrepancy import CANDIDATES, Rig
from ehsa_opt.estimation.discrepancy.search import _ranked_above
from ehsa_opt.physics.params import HarvesterParams
from ehsa_opt.pipeline.discrepancy_report import (INNER_BUDGET_SHARE, RESERVE_S,
                                                  inner_budget_s)


def _rk(values, fitted):
    """A round's ranking: rank values on the force channel; fitted members with their
    held-out ΔBIC."""
    scores = {n: {"applicable": True, "score": v, "chi2": 0.0} for n, v in values.items()}
    cands = {n: NS(fitted=n in fitted, delta_bic_heldout=fitted.get(n, math.nan))
             for n in values}
    return NS(scores=scores, cands=cands, comps={n: CANDIDATES[n].component() for n in values})


def _state(remaining, effects=()):
    """The search state after the round's winner: the remaining members, its rig."""
    rig = Rig(HarvesterParams(), True, tuple(CANDIDATES[n].component() for n in effects))
    return NS(remaining=list(remaining), rig=rig)


def test_a_member_fitted_without_held_out_evidence_is_not_work_left():
    rk = _rk({"cogging": 0.032, "backlash": 0.024, "voltage_drop": 0.001},
             {"cogging": 12.5, "backlash": 12.9})
    assert _ranked_above(rk, _state(["cogging", "backlash", "voltage_drop"])) == []


def test_an_unfitted_or_masked_member_is_work_left():
    rk = _rk({"cogging": 0.032, "backlash": 0.024, "voltage_drop": 0.001},
             {"cogging": -30.0})
    left = _ranked_above(rk, _state(["cogging", "backlash", "voltage_drop"]))
    assert left == ["cogging", "backlash"]  # masked by the winner; ranked, never fitted


def test_a_member_that_cannot_join_the_named_rig_is_not_work_left():
    """A mount spring named: a gap ranked and fitted with held-out evidence in the same
    round (cut at the deadline) cannot be added on top of it (one transmission)."""
    rk = _rk({"cogging": 0.032, "backlash": 0.024, "winding_heating": 0.006},
             {"cogging": 12.4, "backlash": -839.4})
    assert _ranked_above(rk, _state(["cogging", "backlash", "winding_heating"])) == [
        "backlash"]
    assert _ranked_above(rk, _state(["cogging", "backlash", "winding_heating"],
                                    effects=["compliance"])) == []


def test_inner_deadline_keeps_the_reserve():
    assert inner_budget_s(170.0) == 170.0 - RESERVE_S
    assert inner_budget_s(60.0) == INNER_BUDGET_SHARE * 60.0  # small budgets: the share
    assert inner_budget_s(170.0) > INNER_BUDGET_SHARE * 170.0
