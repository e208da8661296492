"""The evidence on one re-identified catalogue member: everything the judge
(:func:`~.judge.judge_candidate`) decides on, measured once and decided nowhere here.

A member's refit (:func:`~.candidate_fit.fit_member`) gives its predictions on the fit and
evaluation tests; :func:`measure_candidate` turns them into the member's statistics — its
parameters with their intervals and whether their size is resolved, the force error,
ΔBIC on the fit and evaluation tests (overall and per channel), the per-channel SSE the
other-channel routes use, the per-block excess reductions of its own evidence, the
transient-energy record of an impact-fitted contact and the parameters at an active bound
— written on the :class:`~.results.CandidateResult` where the report shows them, and
returned as a :class:`CandidateEvidence` for the verdict.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..identify_result import force_relative_error_percent
from .bounds import at_bound_names, unconstrained_step
from .channels import channel_delta_bic, channel_effective_samples, channel_sse
from .criterion import DEFAULT_CRITERION, Criterion
from .evidence import (acts_on_generator, block_excess_reductions, delta_bic,
                       force_error_percent, normalised_sse, significant)
from .impact_verdict import impact_record, impact_verdict_record

__all__ = ["CandidateEvidence", "measure_candidate"]


@dataclass(frozen=True)
class CandidateEvidence:
    """The statistics of one member refit the verdict needs beyond those the
    :class:`~.results.CandidateResult` reports.

    Attributes
    ----------
    k : int
        The member's parameters (each charged ln N_eff in ΔBIC).
    delta_bic_heldout : float
        ΔBIC of the evaluation tests' samples (the reported
        ``CandidateResult.delta_bic_heldout`` of an impact-fitted contact is the smaller of
        this and its transient-feature ΔBIC).
    n_eff : float
        Effective samples of the evaluation tests' residual (held-out tests, else fit).
    n_force : int
        Force samples of the evaluation tests (the force error's resolution).
    channels : list of int
        The channels the member can change (its rigid channels, or all of them when the
        rig has a transmission member).
    sse_before, sse_after, n : ndarray, shape (ny,)
        Per-channel noise-normalised SSE of the current model and of the refit on the
        evaluation tests, and the samples per channel.
    own_channels : list of int
        The member's own channels when the own-channel route is offered (a generator
        member on a rig with a voltage channel and no generator member before it), else
        empty.
    own_dbic : float
        Held-out ΔBIC with a variance per channel (:func:`~.channels.channel_delta_bic`),
        NaN when the own-channel route is not offered.
    force_n_eff : float
        Effective samples of the force channel's residual (NaN when not measured).
    block_reductions : ndarray or None
        Per-block excess reductions of the evaluation tests
        (:func:`~.evidence.block_excess_reductions`), None without the current model's
        predictions.
    transmission : bool
        The member is a transmission effect (the rotor may move otherwise than the rod).
    impact : dict or None
        The transient-energy record of an impact-fitted contact
        (:func:`~.impact_verdict.impact_verdict_record`), None otherwise.
    """

    k: int
    delta_bic_heldout: float
    n_eff: float
    n_force: int
    channels: list[int]
    sse_before: np.ndarray
    sse_after: np.ndarray
    n: np.ndarray
    own_channels: list[int]
    own_dbic: float
    force_n_eff: float
    block_reductions: np.ndarray | None
    transmission: bool
    impact: dict | None


def measure_candidate(c: Any, out: tuple, *, member, comps, fit_pts, held_pts, sse_fit,
                      sse_held, n_eff_fit, n_eff_held, ch_sse0, ch_n, say,
                      cur_ev_pred=None, masks=None, laws=None,
                      criterion: Criterion = DEFAULT_CRITERION,
                      **_judge: Any) -> CandidateEvidence | None:
    """Measure the re-identification ``out`` (``(name, FitResult, fit outputs, held-out
    outputs, rig)``, :func:`~.candidate_fit.fit_member`) of the catalogue entry
    ``member`` (:class:`~.candidates.Candidate`: the channels it can change, its
    amplitudes, its own channels) against the current model (``sse_fit``, ``sse_held``,
    ``n_eff_fit``, ``n_eff_held``, per-channel ``ch_sse0``/``ch_n`` and its evaluation
    predictions ``cur_ev_pred``); ``laws``: the friction-law terms every model carries
    (:meth:`~.search.SearchTests.correct`), applied to the refit's predictions before
    anything is measured.  Fills the reported statistics of ``c`` and returns the rest;
    None when the refit failed (said).  ``criterion`` gives the block layout of the own
    evidence and the bound tolerance; the verdict's keywords (``cur_err``, ``floor``) are
    accepted and left to :func:`~.judge.judge_candidate`."""
    name, res, pf, ph, crig = out
    c.fitted, c.fit, c.rig = True, res, crig
    if not pf:
        say(f"{name}: re-identification failed ({res.message})")
        return None
    if laws is not None:
        pf, ph = laws.correct(fit_pts, pf, held_pts, ph)
    comp_params = [q.name for q in comps[name].parameters]
    k = len(comp_params)
    c.parameters = {n: res.parameters[n] for n in comp_params}
    c.intervals = {n: res.interval(n) for n in c.parameters}
    c.resolved = significant(c.intervals, member.amplitudes)
    c.delta_bic_fit = delta_bic(normalised_sse(fit_pts, pf), sse_fit, k, n_eff_fit)
    ev_pts, ev_pred = (held_pts, ph) if held_pts else (fit_pts, pf)
    n_eff = n_eff_held if held_pts else n_eff_fit
    c.sse_heldout = normalised_sse(ev_pts, ev_pred)
    c.delta_bic_heldout = (delta_bic(c.sse_heldout, sse_held, k, n_eff_held) if held_pts
                           else c.delta_bic_fit)
    c.error_after = force_error_percent(ev_pts, ev_pred)
    ch = member.rigid_channels if member is not None else None
    if ch is None or any(q.transmission for q in crig.components):
        ch = tuple(range(len(ch_n)))
    ch_sse1 = channel_sse(ev_pts, ev_pred)[0]
    c.channel_dbic = [delta_bic(s1, s0, k, n_eff) for s0, s1 in zip(ch_sse0, ch_sse1)]
    # the own-channel route: a generator member on a rig with a voltage channel and no
    # generator member before it
    own = [q for q in (getattr(member, "own_channels", None) or ()) if q < len(ch_n)]
    if not (own and len(ch_n) > 1 and not any(
            acts_on_generator(q) for q in list(getattr(crig, "components", ()))[:-1])):
        own = []
    own_dbic, force_n_eff = np.nan, np.nan
    if own:
        neff = channel_effective_samples(
            ev_pts, cur_ev_pred if cur_ev_pred is not None else ev_pred)
        own_dbic, force_n_eff = channel_delta_bic(ch_sse0, ch_sse1, neff, k), float(neff[0])
    dbic_samples = c.delta_bic_heldout
    blocks = None
    if cur_ev_pred is not None:
        blocks = block_excess_reductions(ev_pts, cur_ev_pred, ev_pred,
                                         masks if held_pts else None, criterion.blocks_per_test,
                                         criterion.min_excess_over_floor ** 2)
    impact = None
    if impact_record(res) is not None and cur_ev_pred is not None:
        impact = impact_verdict_record(c, res, ev_pts, cur_ev_pred, ev_pred, crig, say)
        c.channel_dbic = []  # judged on impacts: its sample-wise channels are not evidence
    # a bound counts where it is active: the unconstrained step from the fit crosses it
    step = (None if impact_record(res) is not None or not hasattr(crig, "model") else
            (lambda: unconstrained_step(fit_pts, crig, res.parameters, comp_params)))
    at_bound_names(c, comps[name].parameters, member, say, step, criterion.at_bound_rel)
    c.predictions = pf + ph
    c.per_test_after = [force_relative_error_percent(y[0][pt.weight > 0], pt.y[0][pt.weight > 0])
                        for y, pt in zip(c.predictions, fit_pts + held_pts)]
    return CandidateEvidence(
        k=k, delta_bic_heldout=dbic_samples, n_eff=n_eff, n_force=sum(pt.y.shape[1] for pt in ev_pts),
        channels=[q for q in ch if q < len(ch_n)], sse_before=np.asarray(ch_sse0, float),
        sse_after=np.asarray(ch_sse1, float), n=np.asarray(ch_n, float), own_channels=own,
        own_dbic=float(own_dbic), force_n_eff=force_n_eff, block_reductions=blocks,
        transmission=bool(comps[name].transmission), impact=impact)
