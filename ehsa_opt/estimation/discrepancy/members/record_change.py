"""Adopting a member that changed the record (a delay of the force record, the force
sensor's dynamics, the drive's lag): the search's tests, the state and the base model's
outputs from then on."""

from __future__ import annotations

import math

from ...fit_result import FitResult
from ..baseline import CANDIDATE_MAX_SAMPLES
from ..candidates.record_change import RecordChange
from ..evidence import effective_samples
from ..results import CandidateResult
from ..rig import predict
from ..split import spread_within
from .protocol import Attempt, Context

__all__ = ["attempt_from_change", "adopt_record_change"]


def attempt_from_change(name: str, change: RecordChange, n_parameters: int) -> Attempt:
    """The :class:`~.protocol.Attempt` of a member that hands back a changed record."""
    f = change.fields
    return Attempt(name, error_before=f["error_before"], error_after=f["error_after"],
                   delta_bic_fit=f["delta_bic_fit"], delta_bic_heldout=f["delta_bic_heldout"],
                   n_parameters=n_parameters, resolved=bool(f.get("resolved", True)),
                   fields=f, change=change, message=change.message)


def adopt_record_change(attempt: Attempt, ctx: Context, step: dict | None = None) -> None:
    """The tests (and their noise floor, when the member changed it), the state and the
    base model's outputs after an earning record member; its result recorded."""
    ch: RecordChange = attempt.change
    t, s, base = ctx.tests, ctx.state, ctx.base
    ctx.results.append(CandidateResult(**attempt.fields))
    ctx.notes += ch.notes
    t.fit_pts, t.held_pts = ch.fit_pts, ch.held_pts
    if not math.isnan(ch.floor):
        t.floor = ch.floor
    s.params = dict(ch.baseline.parameters)
    s.fit_pred, s.held_pred, s.error = ch.fit_pred, ch.held_pred, ch.error
    s.effects.append(attempt.member)
    s.steps.append(step or {"effect": attempt.member, "error_after": ch.error,
                            "excess_reduction": attempt.fields["excess_reduction"],
                            "parameters": attempt.fields["parameters"]})
    s.n_eff_fit = effective_samples(t.fit_pts, s.fit_pred)
    s.n_eff_held = effective_samples(t.held_pts, s.held_pred) if t.held_pts else math.nan
    t.sub_pts = spread_within(t.fit_pts, ctx.settings.max_fit_tests, CANDIDATE_MAX_SAMPLES)
    fit: FitResult = base.fit
    base.fit_pred = predict(t.fit_pts, t.rig, fit.parameters)
    base.held_pred = predict(t.held_pts, t.rig, fit.parameters) if t.held_pts else []
