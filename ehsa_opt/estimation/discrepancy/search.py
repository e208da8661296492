"""The forward-selection search: round after round, rank the catalogue on the
current residual, re-identify the top candidates, judge them by the decision rule
and add the winner; look ahead where one effect hides another.

* :func:`run_rounds`: the rounds, on a :class:`SearchState` (the current model) over
  the :class:`SearchTests`; a round is ranked (:func:`rank_round`), its candidates
  fitted and judged (:func:`judge_round`), widened and looked ahead when the best
  explains little (:func:`widen_round`), and its winner added (:func:`add_winner`);
* :func:`~.widen.should_widen`, :func:`~.widen.widen_round` (in :mod:`.widen`): whether
  the round re-identifies the lower-ranked candidates too before deciding, and the
  widened round's look-ahead.

The statistics, the rule each candidate is judged by and the choice of the winner
(:func:`~.judge.choose_winner`) are in :mod:`.evidence`; the look-ahead through a
confounded candidate in :mod:`.lookahead`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .candidate_fit import judge_fit, not_fitted, signature_scores_in
from .idle_fits import fit_with_spares
from .budget import budget_reached, charge_fits, cut_reason, elapsed_s, past_deadline, time_left_s
from .candidates import (
    CANDIDATES,
    MIN_RANK_VALUE,
    compatible,
    components_for,
    fit_flexibility_member,
    flexibility_refusal,
    rank_value,
)
from .evidence import channel_sse, disturbance_masks, effective_samples, normalised_sse
from .judge import can_earn, choose_winner, excess_reduction, record_verdict, sse_can_earn, withdraw
from .criterion import Criterion
from .prepared import PreparedTest
from .rig import Rig
from .impacts import impact_record
from .nested import nested_ahead, nested_to_fit, prefer_nested
from .lookahead import member_key
from .widen import should_widen, widen_candidates, widen_round
from .results import CandidateResult, DiscrepancySettings
from .terms import FRICTION_LAW_GROUPS, propose_term

__all__ = ["SearchTests", "SearchState", "RoundRanking", "run_rounds", "rank_round",
           "judge_round", "judge_context", "widen_round", "add_winner", "should_widen",
           "ranked_ahead", "fitted_ahead"]


@dataclass
class SearchTests:
    """What the search is judged on, fixed over its rounds.

    Attributes
    ----------
    rig : Rig
        The baseline rig (no effects).
    fit_pts, held_pts : list of PreparedTest
        Fit and held-out tests (``held_pts`` empty: the decision uses the fit tests).
    sub_pts : list of PreparedTest
        The fit tests the candidates are re-identified on (a spread subset).
    floor : float
        Noise floor of the relative force error on the evaluation tests, %.
    evaluation : str
        ``"held-out"``, ``"validation set"`` or ``"all data"``.
    validation_dir : Path or None
        The validation set's directory (its documented disturbances are masked).
    """

    rig: Rig
    fit_pts: list[PreparedTest]
    held_pts: list[PreparedTest]
    sub_pts: list[PreparedTest]
    floor: float
    evaluation: str
    validation_dir: Path | None = None
    #: the base model's presliding law (:class:`~.presliding.PreslidingLaw`; None: none)
    presliding: Any = None
    #: the friction-law terms every model judged carries (the presliding transition, the
    #: campaign's drift), in the order they were adopted; each has ``correct``
    laws: list = field(default_factory=list)

    def correct(self, fit_pts, fit_pred, held_pts, held_pred) -> tuple[list, list]:
        """A model's fit and held-out predictions with each adopted law's own term."""
        fit_pred, held_pred = list(fit_pred), list(held_pred)
        for law in self.laws:
            fit_pred, held_pred = law.correct(fit_pts, fit_pred, held_pts, held_pred)
        return fit_pred, held_pred

    @property
    def eval_pts(self) -> list[PreparedTest]:
        """The tests the decision is judged on."""
        return self.held_pts or self.fit_pts

    @property
    def lead_m_per_rad(self) -> float:
        return self.rig.harvester.lead_m_per_rad


@dataclass
class SearchState:
    """The current model of the search: its rig, parameters, simulated outputs,
    effective sample sizes, held-out force error (%) and the effects named so far."""

    rig: Rig
    params: dict[str, float]
    fit_pred: list[np.ndarray]
    held_pred: list[np.ndarray]
    n_eff_fit: float
    n_eff_held: float
    error: float
    effects: list[str] = field(default_factory=list)
    steps: list[dict] = field(default_factory=list)
    remaining: list[str] = field(default_factory=list)
    #: where the run's time budget cut the search ("" while it was not reached)
    cut: str = ""
    #: member fits made by the look-ahead, by :func:`~.lookahead.member_key`, with the
    #: rig they were made on: reused when a round fits the same member on that model
    fitted: dict = field(default_factory=dict)
    #: wall time of each member's last fit, s, by name (what a look-ahead fit is
    #: estimated to cost, :func:`widen_round`)
    seconds: dict = field(default_factory=dict)
    #: the next round's ranking, made (and its members fitted into ``fitted``) before
    #: the round started — the delay's rival check (:func:`~.lag_rival.lag_rival`) —
    #: with the rig and remaining members it was made on; the round reuses it
    #: (:func:`ranked_ahead`) and is decided on those fits even after the deadline
    ranking: tuple | None = None

    def snapshot(self) -> SearchState:
        """A copy that later rounds do not change."""
        return replace(self, effects=list(self.effects), steps=list(self.steps),
                       remaining=list(self.remaining))

    def eval_pred(self) -> list[np.ndarray]:
        return self.held_pred or self.fit_pred


@dataclass
class RoundRanking:
    """One round's ranking: the configured components, signature scores, the
    flexibility member's fit (or None), the rank order, a result per candidate and
    the candidates chosen for re-identification."""

    comps: dict
    scores: dict
    flex_out: tuple | None
    order: list[str]
    cands: dict[str, CandidateResult]
    chosen: list[str]
    seconds: float = math.nan  # wall time of the ranking, s


def run_rounds(tests: SearchTests, state: SearchState, settings: DiscrepancySettings,
               say: Callable[[str], None], notes: list[str], all_cands: list
               ) -> SearchState:
    """Add effects round after round until nothing earns or ``max_effects`` are named.

    Every candidate judged is appended to ``all_cands``, every note to ``notes``.
    A look-ahead first step (no gain alone) is named only together with the effect
    that completes its path; when no round is left to complete it, the state before
    it is returned."""
    # (state before the look-ahead first step, its error before) until it is completed
    joint: tuple | None = None
    for rnd in range(1, settings.max_effects + 1):
        if budget_reached() and ranked_ahead(state) is None:
            state.cut = state.cut or (f"{cut_reason()} before round {rnd}: no further round "
                                      f"run")
            say(state.cut)
            break
        go_on, joint = _round(rnd, tests, state, joint, settings, say, notes, all_cands)
        if not go_on:
            break
    if joint is not None:  # the path was not completed: its first step is not named
        cut, state = state.cut, joint[0]
        state.cut = cut
        note = (f"the look-ahead path was not completed: its first step is not named "
                f"(error back to {state.error:.3f} %)")
        say(note)
        notes.append(note)
    return state


def _round(rnd: int, tests: SearchTests, state: SearchState, joint: tuple | None,
           settings: DiscrepancySettings, say, notes: list[str], all_cands: list
           ) -> tuple[bool, tuple | None]:
    """One round on ``state`` (changed in place when a winner is added).  Returns
    whether to go on and the look-ahead path's start (see :func:`run_rounds`)."""
    rk = ranked_ahead(state, pop=True) or rank_round(tests, state, settings)
    judge = judge_context(rnd, tests, state, rk, say, notes, settings.criterion)
    if judge is None:  # nothing can earn: the round is not re-identified
        all_cands += [rk.cands[n] for n in rk.order]
        return False, joint
    if not rk.chosen:
        note = (f"round {rnd}: no member's signature explains {100 * MIN_RANK_VALUE:g} % of "
                f"the residual on the channel it is ranked on (or it would end at a bound "
                f"of its range, or worsens the rotor's channel): none re-identified")
        say(note)
        notes.append(note)
    judge_round(rk, rk.chosen, tests, state, settings, judge, with_flexibility=True,
                spare=fitted_ahead(rk, state))
    nested = nested_to_fit(rk.cands, rk.scores, rk.comps, state.rig, state.remaining)
    if nested:  # after the deadline: fits made ahead are reused, the others are a cut
        judge["say"](f"round {rnd}: " + ", ".join(nested) + " re-identified too (nested in "
                     "an earning member: the choice is made on fits)")
        judge_round(rk, nested, tests, state, settings, judge)
    if rk.flex_out is not None and not rk.cands["flexibility"].earns:
        note = flexibility_refusal(rk.cands["flexibility"], rk.flex_out[1], rnd)
        say(note)
        notes.append(note)
    earning, first, blocked = widen_round(
        rnd, rk, tests, state, settings, judge, say,
        lambda names: judge_round(rk, names, tests, state, settings, judge))
    all_cands += [rk.cands[n] for n in rk.order]
    if first is not None and not first.earns and (rnd == settings.max_effects
                                                  or len(state.remaining) < 2
                                                  or joint is not None):
        say(f"round {rnd}: no round left to complete a path through {first.effect}")
        first = None
    if first is not None and not first.earns:
        joint = (state.snapshot(), state.error)
        note = (f"round {rnd}: {first.effect} is added first (it removes "
                f"{100 * first.excess_reduction:.0f} % of the excess alone, and "
                + (f"lets {blocked.effect} earn on top of it)" if first is not blocked
                   else "a candidate fitted on top of it completes a path that earns)"))
        say(note)
        notes.append(note)
        record_verdict(first, True, "look-ahead path")
    if not earning and first is None:
        return False, joint
    win = first or prefer_nested(choose_winner(earning), rk.cands, say,
                                 settings.criterion.nested_evidence)
    if settings.discover and _term_preferred(rnd, win, tests, state, settings, say):
        withdraw(win, "")
        return False, joint
    joint = add_winner(rnd, win, first, joint, tests, state, say, settings.criterion)
    stop = None
    if impact_record(win.fit) is not None and state.remaining:
        stop = (f"round {rnd}: {win.effect} was fitted and judged on transient energies and "
                f"kinematic gaps (a rattling contact): the model's sample-wise residual is "
                f"not reproducible, so no further effect is searched on it")
    elif state.remaining and budget_reached() and joint is None and not _ranked_above(rk, state):
        # the next round would start after the budget; nothing it could re-identify
        # ranked here: it is not work skipped (no cut)
        stop = (f"round {rnd}: {win.effect} named at the budget ({cut_reason()}); no other member "
                f"ranked at {100 * MIN_RANK_VALUE:g} % of this round's residual and able "
                f"to join the model is left unfitted or with held-out evidence (ΔBIC < 0): "
                f"no further round (not a cut)")
    if stop is not None:
        say(stop)
        notes.append(stop)
        return False, joint
    return bool(state.remaining), joint


def ranked_ahead(state: SearchState, pop: bool = False) -> RoundRanking | None:
    """The ranking of the next round made before it started (``state.ranking``) when it
    was made on the current model (the same rig, the same remaining members), else None;
    ``pop``: it is taken (a round uses it once)."""
    got = state.ranking
    if pop:
        state.ranking = None
    if got is None or got[0] is not state.rig or list(got[1]) != list(state.remaining):
        return None
    return got[2]


def _ranked_above(rk: RoundRanking, state: SearchState) -> list[str]:
    """The remaining members a next round could still name: ranked at or above
    :data:`MIN_RANK_VALUE` in this round and either not re-identified in it, or
    re-identified with some held-out evidence (ΔBIC < 0) that did not suffice to earn
    (an effect the winner may have masked), or cut by the time budget at its start point
    (not fitted, :func:`~.candidate_fit.not_fitted`).  A member re-identified here whose held-out
    ΔBIC was ≥ 0 had no held-out evidence at all and is not counted, nor one that
    cannot join the current rig (a gap once a mount spring is named: one transmission
    at most), which no next round could name."""
    out = []
    for n in state.remaining:
        if n not in rk.scores or not rk.scores[n]["applicable"] \
                or not rank_value(rk.scores[n]) >= MIN_RANK_VALUE:
            continue
        if n in rk.comps and not compatible(state.rig, rk.comps[n]):
            continue
        c = rk.cands.get(n)
        if c is not None and c.fitted and not getattr(c, "cut_at_deadline", "") \
                and not (c.delta_bic_heldout < 0):
            continue
        out.append(n)
    return out


def _estimate(state: SearchState, name: str) -> float:
    """A member fit's expected wall time, s: its own last fit in this run, else the
    median of the fits timed so far (0 before any: round 1 starts every fit)."""
    if name in state.seconds:
        return float(state.seconds[name])
    return float(np.median(list(state.seconds.values()))) if state.seconds else 0.0


def fitted_ahead(rk: RoundRanking, state: SearchState) -> list[str]:
    """The members a round may ask for after its chosen ones, fitted ahead on idle
    workers (:mod:`.idle_fits`): the simpler members nested in a chosen one that a round
    may still ask for (:func:`~.nested.nested_ahead`), then those a widened round re-identifies
    (:func:`~.widen.widen_candidates`)."""
    nested = nested_ahead(rk.chosen, rk.scores, rk.comps, state.rig, state.remaining)
    return nested + [n for n in widen_candidates(rk, state) if n not in nested]


def _member_args(name: str, rk: RoundRanking, tests: SearchTests, state: SearchState,
                 settings: DiscrepancySettings) -> tuple:
    """The :func:`~.candidate_fit.fit_member` arguments of ``name`` on the current model."""
    return (name, rk.comps[name], CANDIDATES[name].starts, tests.sub_pts, tests.fit_pts,
            tests.held_pts, state.rig, state.params, settings.max_iter)


def rank_round(tests: SearchTests, state: SearchState, settings: DiscrepancySettings
               ) -> RoundRanking:
    """Rank the remaining candidates by their signature score on the current residual
    (the flexibility member by its variable-projection fit) and choose the ``top``
    applicable ones that can join the current rig."""
    t0 = time.perf_counter()
    fit_pts, sub_pts, remaining = tests.fit_pts, tests.sub_pts, state.remaining
    comps = components_for(remaining, fit_pts, state.fit_pred, tests.lead_m_per_rad)
    sub_pred = [state.fit_pred[next(k for k, q in enumerate(fit_pts) if q is p)]
                for p in sub_pts]
    flex = "flexibility" in remaining and not tests.rig.has_generator
    scores = signature_scores_in(settings.jobs, sub_pts, state.rig, state.params, sub_pred,
                                 [n for n in remaining if n != "flexibility"], comps)
    flex_out = None
    if "flexibility" in remaining:
        flex_out = fit_flexibility_member(fit_pts, state.fit_pred, tests.held_pts,
                                          state.held_pred, state.rig, state.params, comps,
                                          scores) if flex else None
        if flex_out is None:
            scores["flexibility"] = {"score": math.nan, "chi2": math.nan, "columns": 0,
                                     "applicable": False}
    # each member ranked on the channel that sees it best (rank_value)
    order = sorted(remaining, key=lambda n: (not scores[n]["applicable"],
                                             -rank_value(scores[n])))
    cands = {n: CandidateResult(n, scores[n]["applicable"], scores[n]["score"],
                                scores[n]["chi2"], len(state.effects) + 1,
                                error_before=state.error,
                                own_channel=scores[n].get("channel")) for n in order}
    chosen = [n for n in order if scores[n]["applicable"] and n != "flexibility"
              and compatible(state.rig, comps[n])
              and rank_value(scores[n]) >= MIN_RANK_VALUE][:settings.top]
    return RoundRanking(comps, scores, flex_out, order, cands, chosen,
                        time.perf_counter() - t0)


def judge_context(rnd: int, tests: SearchTests, state: SearchState, rk: RoundRanking,
                  say, notes: list[str], criterion: Criterion) -> dict | None:
    """The current model's measures every candidate of the round is judged against
    (keyword arguments of :func:`~.judge.judge_candidate`, ``criterion`` among them);
    None when no refit can earn by the decision rule (said and noted)."""
    fit_pts, held_pts, eval_pts, floor = tests.fit_pts, tests.held_pts, tests.eval_pts, \
        tests.floor
    cur_err = state.error
    sse_fit, sse_held = normalised_sse(fit_pts, state.fit_pred), (
        normalised_sse(held_pts, state.held_pred) if held_pts else math.nan)
    n_obs = sum(pt.y.size for pt in eval_pts)
    sse0 = sse_held if held_pts else sse_fit
    ch_sse0, ch_n = channel_sse(eval_pts, state.eval_pred())
    say(f"round {rnd} (error {cur_err:.3f} %, floor {floor:.3f} %, SSE/N {sse0 / n_obs:.3f}"
        f" [per channel " + ", ".join(f"{a / b:.3f}" for a, b in zip(ch_sse0, ch_n))
        + "]) ranking: " + ", ".join(f"{n} {rk.scores[n]['score']:.3g}"
                                     + (f" (channel {rk.scores[n]['channel']}: "
                                        f"{rank_value(rk.scores[n]):.3g})"
                                        if rank_value(rk.scores[n])
                                        > np.nan_to_num(rk.scores[n]['score']) else "")
                                     for n in rk.order)
        + f" (ranked in {rk.seconds:.1f} s, {elapsed_s():.0f} s into the run)")
    if not (can_earn(cur_err, floor, 0.0, 1.0, criterion)
            or sse_can_earn(ch_sse0, ch_n, criterion)):
        excess = math.sqrt(max(cur_err ** 2 - floor ** 2, 0.0))
        note = (f"round {rnd}: candidates not re-identified — the {tests.evaluation} force "
                f"error {cur_err:.3f} % exceeds the noise floor {floor:.3f} % by "
                f"{excess:.3f} % (≤ {criterion.min_excess_over_floor:g} × floor) and the SSE "
                f"of every channel is within {1 + criterion.min_sse_excess:g} × its noise "
                f"expectation "
                f"(all channels {sse0 / n_obs:.3f}): no refit can earn by the decision rule")
        say(note)
        notes.append(note)
        return None
    masks, mask_note = disturbance_masks(held_pts, tests.validation_dir)
    if mask_note and mask_note not in notes:
        say(mask_note)
        notes.append(mask_note)
    return dict(comps=rk.comps, fit_pts=fit_pts, held_pts=held_pts, sse_fit=sse_fit,
                sse_held=sse_held, n_eff_fit=state.n_eff_fit, n_eff_held=state.n_eff_held,
                cur_err=cur_err, floor=floor, ch_sse0=ch_sse0, ch_n=ch_n, say=say,
                cur_ev_pred=state.eval_pred(), masks=masks, laws=tests if tests.laws else None,
                criterion=criterion)


def judge_round(rk: RoundRanking, names: Sequence[str], tests: SearchTests,
                state: SearchState, settings: DiscrepancySettings, judge: dict,
                with_flexibility: bool = False, keep: bool = False,
                spare: Sequence[str] = ()) -> None:
    """Re-identify the candidates ``names`` on the current model
    (:func:`~.candidate_fit.fit_members`) and judge each
    (:func:`~.judge.judge_candidate`); ``with_flexibility``: the flexibility
    member's fit is judged by the same rule too; ``keep``: the new fits are kept in
    ``state.fitted`` for a later round on the same model to reuse.  ``spare``: members
    the round may ask for next, fitted only on workers the fits of ``names`` leave idle
    (:func:`~.idle_fits.fit_with_spares`) and kept in ``state.fitted``, not judged."""
    names = list(names)
    if names:
        args = [_member_args(n, rk, tests, state, settings) for n in names]
        # the work budget: charged for every member asked for, in rank order, whether
        # its fit is made now or was made ahead (the answer does not depend on which)
        args = args[:charge_fits(len(args))]
        # a member fitted ahead on this model (same inputs: by the look-ahead, on an
        # idle worker, or by the delay's rival check): reused
        done = [state.fitted.pop(member_key(x), (None, None)) for x in args]
        done = [out for rig, out in done if rig is state.rig and out is not None]
        for out in done:
            judge["say"](f"{out[0]}: the fit made ahead on this model (the same inputs) "
                         f"is judged, not repeated")
        new = [x for x in args if x[0] not in {out[0] for out in done}]
        ahead = [_member_args(n, rk, tests, state, settings) for n in spare
                 if n not in names and n in rk.comps]
        ahead = [x for x in ahead if member_key(x) not in state.fitted]
        t0 = time.perf_counter()
        # scheduled as workers free up, in rank order; none started after the safety
        # cap (fits made before it, reused above, are judged all the same)
        fits, extra = ([], []) if new and past_deadline() else fit_with_spares(
            new, ahead, settings.jobs, until_deadline=settings.wall_cap_s is not None,
            seconds=state.seconds, estimate=lambda n: _estimate(state, n))
        for x in ahead:
            out = next((o for o in extra if o[0] == x[0]), None)
            if out is not None and not not_fitted(out[1]):
                state.fitted[member_key(x)] = (state.rig, out)
        if extra:
            judge["say"]("fitted ahead on an idle worker: " + ", ".join(
                f"{o[0]} {state.seconds[o[0]]:.1f} s" for o in extra))
        if fits:
            judge["say"](f"re-identified {len(fits)} member"
                         f"{'s' if len(fits) > 1 else ''} in {time.perf_counter() - t0:.1f} s "
                         f"wall (" + ", ".join(f"{o[0]} {state.seconds[o[0]]:.1f} s"
                                               for o in fits)
                         + f"; {elapsed_s():.0f} s into the run)")
        for x, out in zip(new, fits) if keep else ():
            state.fitted[member_key(x)] = (state.rig, out)
        for out in sorted(done + fits, key=lambda o: names.index(o[0])):  # rank order
            judge_fit(rk.cands[out[0]], out, member=CANDIDATES.get(out[0]), **judge)
        started = {o[0] for o in done + fits}
        cut = [n for n in names if n in started and rk.cands[n].cut_at_deadline]
        unstarted = [n for n in names if n not in started]
        if cut or unstarted:
            state.cut = (f"{cut_reason()} in the round in progress: "
                         + "; ".join(([f"{', '.join(cut)} cut at the start point (not "
                                       f"fitted)"] if cut else [])
                                     + ([f"{', '.join(unstarted)} not re-identified (not "
                                         + ("started: the fits timed in this run take "
                                            f"longer than the {max(time_left_s(), 0.0):.0f} s "
                                            "left)" if past_deadline() else "started)")]
                                        if unstarted else []))
                         + "; the round is decided on the candidates fitted before the cut")
            judge["say"](state.cut)
            return
    if not with_flexibility or rk.flex_out is None:
        return
    # judged by the same rule, fitted by variable projection
    judge_fit(rk.cands["flexibility"], rk.flex_out, member=CANDIDATES.get("flexibility"),
              **judge)
    cf = rk.cands["flexibility"]
    if cf.parameters:  # the stiffness k = m (2π f)² and its interval, for the report
        w2 = (2 * math.pi * cf.parameters["flex_frequency_hz"]) ** 2
        cf.parameters["flex_stiffness_N_per_m"] = cf.parameters["flex_load_mass_kg"] * w2
        iv = cf.intervals.get("flex_load_mass_kg")
        cf.intervals["flex_stiffness_N_per_m"] = (iv[0] * w2, iv[1] * w2) if iv else None


def _term_preferred(rnd: int, win: CandidateResult, tests: SearchTests, state: SearchState,
                    settings: DiscrepancySettings, say) -> bool:
    """Whether a data-driven term (:func:`~.terms.propose_term`) explains the residual
    far better than the winner (``criterion.term_preference``): the catalogue name
    would point at the wrong part, so the winner is not named."""
    floor = tests.floor
    rival = propose_term(tests.fit_pts, state.fit_pred, tests.eval_pts, state.eval_pred(),
                         tests.lead_m_per_rad, settings.seed, floor,
                         state.n_eff_held if tests.held_pts else state.n_eff_fit,
                         settings.criterion)
    ex_win = math.sqrt(max(win.error_after ** 2 - floor ** 2, 0.0))
    ex_term = math.sqrt(max(rival.error_after ** 2 - floor ** 2, 0.0))
    if rival.earns and rival.group not in FRICTION_LAW_GROUPS and ex_term < settings.criterion.term_preference * ex_win:
        say(f"round {rnd}: {win.effect} earns ({win.error_after:.3f} %) but a data-driven "
            f"term explains the residual far better ({rival.error_after:.3f} %): "
            f"{rival.description}")
        return True
    return False


def add_winner(rnd: int, win: CandidateResult, first: CandidateResult | None,
               joint: tuple | None, tests: SearchTests, state: SearchState, say,
               criterion: Criterion) -> tuple | None:
    """Add the round's winner to ``state`` (in place) and record the step; a winner
    that completes a look-ahead path started at ``joint`` is recorded with its first
    step as one joint step.  Returns the path's start still open (or None)."""
    fit_pts, held_pts = tests.fit_pts, tests.held_pts
    state.effects.append(win.effect)
    state.remaining.remove(win.effect)
    state.rig, state.params = win.rig, dict(win.fit.parameters)
    # the look-ahead's fits on top of the winner stay for the next round; others go
    state.fitted = {k: v for k, v in state.fitted.items() if v[0] is state.rig}
    state.fit_pred = win.predictions[:len(fit_pts)]
    state.held_pred = win.predictions[len(fit_pts):]
    state.n_eff_fit = effective_samples(fit_pts, state.fit_pred)
    state.n_eff_held = effective_samples(held_pts, state.held_pred) if held_pts else math.nan
    state.error = win.error_after
    steps = state.steps
    steps.append({"effect": win.effect, "error_after": state.error,
                  "excess_reduction": win.excess_reduction,
                  "sse_excess_reduction": win.sse_reduction,
                  "parameters": win.parameters})
    if joint is not None and win is not first:  # the path is complete: one step
        prev = steps.pop(-2)
        steps[-1] = {"effect": f"{prev['effect']} + {win.effect}", "error_after": state.error,
                     "excess_reduction": excess_reduction(joint[1], state.error, tests.floor,
                                                         criterion),
                     "parameters": {**prev["parameters"], **win.parameters},
                     "joint": True}
        joint = None
    say(f"round {rnd}: added {win.effect}, {tests.evaluation} error {state.error:.3f} %")
    return joint
