"""Look-ahead through a confounded candidate: when one effect hides another.

A candidate that fits the fit tests best but fails on the held-out ones
(:func:`confounded`) has absorbed another effect's residual (a gap taking up a
12-per-rev cogging ripple).  It is re-identified on top of each earning or
:func:`supported` candidate (:func:`fit_on_top`, :func:`lookahead_winner`), or they
on top of it (:func:`confounded_first`); a two-step path that earns as a whole and
ends below the round's default winner decides which effect is added first.
"""

from __future__ import annotations

import math
import time
from typing import Any, Sequence

from .candidate_fit import (fit_member, fit_members, judge_fit, not_fitted,
                            signature_scores_in)
from .budget import charge_fits, time_left_s, work_spent
from .candidates import (
    CANDIDATES,
    MIN_RANK_VALUE,
    compatible,
    components_for,
    rank_value,
)
from .criterion import DEFAULT_CRITERION, Criterion
from .evidence import channel_sse, effective_samples, normalised_sse, significant
from .judge import choose_winner, earns
from .spread import spread_simulations

__all__ = ["confounded", "supported", "fit_on_top", "lookahead_winner", "confounded_first",
           "not_judged",
           "second_steps", "member_key", "on_top_args", "first_step_pool", "prefetch_on_top", "too_late",
           "estimated_seconds"]


def confounded(cands: Sequence[Any]) -> Any | None:
    """The fitted candidate that explains the fit tests best (lowest ΔBIC there, < 0)
    but does not earn on the held-out tests — a sign that its refit absorbed another
    effect's residual on the fit tests (a gap taking up a 12-per-rev cogging ripple:
    fit ΔBIC −1005, held-out error 14.28 → 15.41 %); None when there is none.

    "Best" is over every fitted candidate, the earning ones included: a candidate that
    fails on the held-out tests while an earning one explains the fit tests better
    (a mount spring at fit ΔBIC −197 beside a winding heating at −355) shows nothing
    that the earning one does not account for — no sign of an absorbed effect, and no
    look-ahead through it (each of whose fits costs what that member's own fit did)."""
    pool = [c for c in cands if c.fitted and not c.earns and c.predictions is not None
            and not getattr(c, "at_bound", ())  # refused as unphysical, not confounded
            and not getattr(c, "cut_at_deadline", "")  # cut at its start: not fitted
            and math.isfinite(c.delta_bic_fit) and c.delta_bic_fit < 0]
    if not pool:
        return None
    best = min(pool, key=lambda c: c.delta_bic_fit)
    earned = [c.delta_bic_fit for c in cands if c.fitted and c.earns
              and math.isfinite(c.delta_bic_fit)]
    return best if not earned or best.delta_bic_fit < min(earned) else None


def supported(c: Any) -> bool:
    """Whether a fitted candidate may be the first step of a look-ahead path
    (:func:`lookahead_winner`) without earning by itself: it explains something on
    the fit tests (ΔBIC < 0 there) and its size is resolved (``c.resolved``,
    :func:`significant`).  Its held-out gain is not required: beside a 0.1 mm gap
    a 12-per-rev cogging fitted alone stays small (the gap dominates the residual);
    the path is judged as a whole."""
    return bool(c.fitted and c.predictions is not None and getattr(c, "resolved", True)
                and not getattr(c, "at_bound", ())  # an unphysical fit is no first step
                and not getattr(c, "cut_at_deadline", "")  # cut at its start: not fitted
                and math.isfinite(c.delta_bic_fit) and c.delta_bic_fit < 0)


def lookahead_winner(earning: Sequence[Any], blocked: Any, try_on_top: Any,
                     say: Any = None, max_paths: int = 2, first_steps: Sequence[Any] = (),
                     judged: list | None = None) -> Any | None:
    """A first step C that lets the confounded candidate ``blocked`` earn on top of
    it, preferred to the round's default winner.

    The first steps are the earning candidates (by held-out ΔBIC), then the
    ``first_steps`` (candidates that are :func:`supported` without earning alone, by
    fit ΔBIC: a 12-per-rev cogging fitted alone beside a 0.1 mm gap stays small).
    For the (at most ``max_paths``) first of them with which ``blocked`` is
    compatible, ``try_on_top(C)`` re-identifies ``blocked`` on the model with C (C's
    parameters free again) and returns it judged against C (a CandidateResult, or
    None when incompatible or failed; its ``first_resolved`` says whether C's size is
    resolved in the joint fit).  A path earns when ``blocked`` earns on top of C, the
    held-out error ends below the current model's and C's size is resolved in the
    joint fit (C is no passenger).  The C of the earning path with the lowest
    held-out SSE is returned — and only when that SSE is below the default winner's
    (:func:`choose_winner`; the two-step path must explain more than the one step
    it replaces).  None otherwise (the default winner stands).

    Parameters
    ----------
    earning : sequence of CandidateResult
        The round's earning candidates.
    blocked : CandidateResult
        The confounded candidate (:func:`confounded`).
    try_on_top : callable
        ``try_on_top(c) -> CandidateResult | None``.
    say : callable, optional
        Progress messages.
    max_paths : int
        At most this many first steps are tried.
    first_steps : sequence of CandidateResult
        Further first steps (:func:`supported`), besides the earning candidates.
    judged : list, optional
        Receives the effect of every earning first step C whose path was decided (its
        joint fit with ``blocked`` made, not cut by the budget): the model with both is
        then judged, and the reverse look-ahead need not re-identify it from
        ``blocked``'s side (:func:`not_judged`).
    """
    best, best_sse = None, choose_winner(earning).sse_heldout if earning else math.inf
    for c, step in _paths(first_step_pool(earning, first_steps), blocked, try_on_top,
                          max_paths):
        ok = (step.earns and step.error_after < c.error_before
              and getattr(step, "first_resolved", True))
        if judged is not None and c in earning and not getattr(step, "cut_at_deadline", ""):
            judged.append(c.effect)
        if say:
            say(f"look-ahead: {blocked.effect} on top of {c.effect}: held-out error "
                f"{c.error_before:.3f} -> {c.error_after:.3f} -> {step.error_after:.3f} %"
                f"{_verdict(ok, step)}")
        if ok and step.sse_heldout < best_sse:
            best, best_sse = c, step.sse_heldout
    return best


def not_judged(others: Sequence[Any], judged: Sequence[str], blocked: Any,
               say: Any = None) -> list:
    """The second steps ``others`` of the reverse look-ahead (:func:`confounded_first`)
    whose model with ``blocked`` was not already judged by the forward look-ahead
    (``judged``, :func:`lookahead_winner`).

    The two paths re-identify the same model — both members added, all their
    parameters free — from two starts: C's own fit, or ``blocked``'s.  The reverse
    start exists for an effect that cannot be fitted alone (a cogging beside a gap
    finds nothing alone, or too little to start from); for a C that earned alone, whose
    own fit already led the joint fit and whose path was judged against the round's
    default winner, a second joint fit of the same model (50 s each for a mount spring
    with a generator member) would decide nothing new."""
    left = [c for c in others if c.effect not in judged]
    same = [c.effect for c in others if c.effect in judged]
    if same and say:
        say(f"look-ahead: {', '.join(same)} not re-identified on top of {blocked.effect}: "
            f"the model with both was re-identified from {'their' if len(same) > 1 else 'its'}"
            f" own fit and judged above")
    return left


def first_step_pool(earning: Sequence[Any], first_steps: Sequence[Any] = ()) -> list:
    """The first steps :func:`lookahead_winner` tries, in order: the earning candidates
    by held-out ΔBIC (then SSE), then the other ``first_steps`` by fit ΔBIC."""
    return sorted(earning, key=lambda c: (c.delta_bic_heldout, c.sse_heldout)) + sorted(
        (c for c in first_steps if c not in earning), key=lambda c: c.delta_bic_fit)


def _verdict(ok: bool, step: Any) -> str:
    """How a look-ahead path ended, for the progress message."""
    if getattr(step, "cut_at_deadline", ""):
        return " (the path is not decided: its second step was not fitted before the budget)"
    return " (the path earns)" if ok else " (the path does not earn)"


def _paths(pool: Sequence[Any], blocked: Any, attempt: Any, max_paths: int):
    """(C, step) for the candidates C of ``pool`` other than ``blocked`` in order, with
    ``step = attempt(C)`` not None, at most ``max_paths`` of them (the look-ahead's
    two-step paths, either order)."""
    tried = 0
    for c in pool:
        if tried >= max_paths:
            return
        if c is blocked:
            continue
        step = attempt(c)
        if step is None:
            continue
        tried += 1
        yield c, step

def member_key(args: tuple) -> tuple:
    """What a :func:`~.candidate_fit.fit_member` call's result depends on, from its
    argument tuple: the member, its configured component (e.g. the cogging period),
    the rig (by identity), the current parameters, the tests (by identity), the starts
    and the iteration limit.  Two calls with the same key give the same fit: the
    look-ahead's fit of a member on top of C is the next round's fit of it once C is
    added (:func:`fit_on_top`, :func:`~.search.judge_round`)."""
    name, comp, starts, sub_pts, fit_pts, held_pts, rig, params, max_iter = args
    return (name, type(comp).__name__,
            tuple(sorted((k, repr(v)) for k, v in vars(comp).items())), id(rig),
            tuple(sorted((k, repr(v)) for k, v in params.items())),
            tuple(map(id, sub_pts)), tuple(map(id, fit_pts)), tuple(map(id, held_pts)),
            repr(starts), int(max_iter))


def on_top_args(c: Any, blocked: Any, judge: dict, sub_pts: list, max_iter: int
                ) -> tuple | None:
    """The :func:`~.candidate_fit.fit_member` arguments of ``blocked`` re-identified on
    the model with ``c`` (its component configured from the residual of that model: the
    cogging period — the baseline's residual was dominated by what c explains); None
    when incompatible."""
    comp = judge["comps"][blocked.effect]
    if c.rig is None or c.fit is None or not compatible(c.rig, comp):
        return None
    fit_pts, held_pts = judge["fit_pts"], judge["held_pts"]
    comp = components_for([blocked.effect], fit_pts, c.predictions[:len(fit_pts)],
                          c.rig.harvester.lead_m_per_rad)[blocked.effect]
    return (blocked.effect, comp, CANDIDATES[blocked.effect].starts, sub_pts, fit_pts,
            held_pts, c.rig, dict(c.fit.parameters), max_iter)


def estimated_seconds(seconds: dict | None, *names: str) -> float:
    """What a fit of one of ``names`` on top of the other is estimated to cost, s: the
    longest of their own fits timed in the round (``seconds`` by name; 0 when none was
    timed) — the member refits the same parameters and more, on the same tests."""
    return max([seconds[n] for n in names if seconds and n in seconds], default=0.0)


def too_late(c: Any, blocked: Any, seconds: dict | None, cuts: list | None) -> bool:
    """Whether the fit of ``blocked`` on top of ``c`` would not finish before the run's
    safety cap (:func:`estimated_seconds` > :func:`~.budget.time_left_s`); then it is
    not started and, with ``cuts`` given, the path is appended there as work left."""
    need, left = estimated_seconds(seconds, c.effect, blocked.effect), time_left_s()
    if seconds is None or need <= left:
        return False
    if cuts is not None:
        cuts.append(f"{blocked.effect} on top of {c.effect} (not started: about {need:.0f} s "
                    f"of fitting, {max(left, 0.0):.0f} s left)")
    return True


def prefetch_on_top(pairs: Sequence[tuple], judge: dict, sub_pts: list, max_iter: int,
                    fitted: dict, jobs: int, seconds: dict | None = None,
                    cuts: list | None = None) -> None:
    """Fit the look-ahead's members ``pairs`` = [(c, blocked), …] (``blocked`` on top of
    ``c``) in ``jobs`` processes at once, into ``fitted`` (by :func:`member_key`, with the
    rig), where :func:`fit_on_top` finds them; a pair that cannot finish before the
    deadline (:func:`too_late`) is not started."""
    todo = []
    if work_spent():
        return  # fit_on_top would not be allowed to use them
    for c, blocked in pairs:
        args = on_top_args(c, blocked, judge, sub_pts, max_iter)
        if args is None or member_key(args) in fitted or too_late(c, blocked, seconds, None):
            continue
        todo.append(args)
    if len(todo) < 2:
        return  # nothing to run side by side: fit_on_top fits it when asked
    for args, out in zip(todo, fit_members(todo, jobs, until_deadline=True, seconds=seconds)):
        fitted[member_key(args)] = (args[6], out)


def fit_on_top(c: Any, blocked: Any, judge: dict, sub_pts: list, max_iter: int, rnd: int,
               fitted: dict | None = None, cuts: list | None = None,
               seconds: dict | None = None, jobs: int = 1) -> Any:
    """``blocked`` re-identified on the model with ``c`` and judged against it (the
    look-ahead of :func:`lookahead_winner`); None when incompatible or, with ``seconds``
    (the round's fit times by name), when it would not finish before the run's deadline
    (:func:`too_late`).  ``fitted`` (optional) holds member fits by :func:`member_key`
    (with the rig they were made on): one found there (:func:`prefetch_on_top`) is
    judged, not repeated; a new one is kept for the next round to reuse once ``c`` is
    added.  A fit cut by the time budget at its start point
    (:func:`~.candidate_fit.not_fitted`) is judged not earning and, with ``cuts`` given,
    its path ("blocked on top of c") is appended there.  A fit made here (the only one
    running) simulates its tests on ``jobs`` workers (:func:`~.spread.spread_simulations`:
    the same numbers)."""
    args = on_top_args(c, blocked, judge, sub_pts, max_iter)
    if args is None:
        return None
    key = member_key(args)
    hit = (fitted or {}).get(key)
    if not charge_fits(1):  # the work budget: charged whether made now or ahead
        if cuts is not None:
            cuts.append(f"{blocked.effect} on top of {c.effect} (not started: work budget "
                        f"spent)")
        return None
    if hit is not None and hit[0] is c.rig:
        out = hit[1]
    elif too_late(c, blocked, seconds, cuts):
        return None
    else:
        t0 = time.perf_counter()
        with spread_simulations(jobs, [*args[3], *args[4], *args[5]]):
            out = fit_member(args)
        if seconds is not None:
            seconds[blocked.effect] = time.perf_counter() - t0
    if fitted is not None:
        if not_fitted(out[1]):
            fitted.pop(key, None)
        else:
            fitted[key] = (c.rig, out)
    fit_pts, held_pts = judge["fit_pts"], judge["held_pts"]
    pf, ph = c.predictions[:len(fit_pts)], c.predictions[len(fit_pts):]
    ev_pts, ev_pred = (held_pts, ph) if held_pts else (fit_pts, pf)
    ch_sse0, ch_n = channel_sse(ev_pts, ev_pred)
    step = type(blocked)(blocked.effect, True, blocked.score, blocked.chi2, rnd + 1,
                         error_before=c.error_after)
    judge_fit(step, out, member=CANDIDATES.get(blocked.effect),
              **{**judge, "sse_fit": normalised_sse(fit_pts, pf),
                 "n_eff_fit": effective_samples(fit_pts, pf), "cur_ev_pred": ev_pred,
                 "sse_held": normalised_sse(held_pts, ph) if held_pts else math.nan,
                 "n_eff_held": effective_samples(held_pts, ph) if held_pts else math.nan,
                 "cur_err": c.error_after, "ch_sse0": ch_sse0, "ch_n": ch_n})
    if step.cut_at_deadline and cuts is not None:
        cuts.append(f"{blocked.effect} on top of {c.effect}")
    if step.predictions is None:
        return None
    amp = CANDIDATES[c.effect].amplitudes if c.effect in CANDIDATES else ()
    step.first_resolved = significant({n: step.fit.interval(n) for n in amp}, amp)
    return step


def second_steps(blocked: Any, names: Sequence[str], fit_pts: Sequence[Any],
                 sub_pts: Sequence[Any], lead_m_per_rad: float, say: Any = None,
                 jobs: int = 1) -> list:
    """The members a round after ``blocked`` would re-identify, as second steps of the
    reverse look-ahead (:func:`confounded_first`): ``names`` (other than ``blocked``)
    ranked by their signature on the residual of the model *with* ``blocked``
    (:func:`~.candidates.signature_scores`, :func:`~.candidates.rank_value`), those
    applicable, able to join its rig and ranked at or above
    :data:`~.candidates.MIN_RANK_VALUE`, best first.

    The effect ``blocked`` absorbed on the fit tests is hidden on the current
    model's residual (a 12-per-rev cogging beside a 0.1 mm gap explains 0.5 % of the
    baseline's residual, under the 2 % a member needs to be re-identified in the
    round) and stands out on the residual of the model with ``blocked`` (75 %): the
    second steps are chosen on that residual — the data — not among the members the
    round happened to fit.  Returns candidate results (``type(blocked)``, unfitted)
    carrying the scores."""
    if blocked.rig is None or blocked.fit is None or blocked.predictions is None:
        return []
    names = [n for n in names if n != blocked.effect and n in CANDIDATES]
    if not names:
        return []
    pf = blocked.predictions[:len(fit_pts)]
    sub_pred = [pf[next(k for k, q in enumerate(fit_pts) if q is p)] for p in sub_pts]
    comps = components_for(names, fit_pts, pf, lead_m_per_rad)
    scores = signature_scores_in(jobs, sub_pts, blocked.rig, dict(blocked.fit.parameters),
                                 sub_pred, names, comps)
    ok = [n for n in names if scores[n]["applicable"] and compatible(blocked.rig, comps[n])
          and rank_value(scores[n]) >= MIN_RANK_VALUE]
    ok.sort(key=lambda n: -rank_value(scores[n]))
    if say:
        say(f"look-ahead: ranked on the residual of the model with {blocked.effect}: "
            + (", ".join(f"{n} {rank_value(scores[n]):.3g}" for n in ok) or
               f"no member at {100 * MIN_RANK_VALUE:g} % of it"))
    return [type(blocked)(n, True, scores[n]["score"], scores[n]["chi2"], blocked.round,
                          error_before=blocked.error_after,
                          own_channel=scores[n].get("channel")) for n in ok]


def confounded_first(blocked: Any, others: Sequence[Any], try_on_blocked: Any,
                     err_before: float, floor: float, best_sse: float, say: Any = None,
                     max_paths: int = 4, criterion: Criterion = DEFAULT_CRITERION) -> bool:
    """Whether the confounded candidate ``blocked`` should be added first: some other
    candidate C, re-identified on top of it (C's own and ``blocked``'s parameters
    free), completes a path ``blocked`` → C that earns as a whole.

    The reverse of :func:`lookahead_winner`: when the effect that ``blocked``
    absorbed on the fit tests cannot be fitted alone (a 12-per-rev cogging beside a
    0.1 mm gap: fitted alone on the baseline it finds nothing, fit ΔBIC > 0), the
    joint refit on top of ``blocked`` can still separate them.  A path earns when C
    earns on top of ``blocked`` (``step.earns``, its size resolved), the path as a
    whole earns against the current model by :func:`~.judge.earns` (held-out force
    error ``err_before`` → the path's, ΔBIC summed over the two steps) and its
    held-out SSE ends below ``best_sse`` (the default winner's, or ∞).

    Parameters
    ----------
    blocked : CandidateResult
        The confounded candidate (:func:`confounded`).
    others : sequence of CandidateResult
        Fitted candidates to try as the second step (rank order; at most
        ``max_paths`` are tried).
    try_on_blocked : callable
        ``try_on_blocked(c) -> CandidateResult | None``: C re-identified on the model
        with ``blocked``, judged against it.
    err_before : float
        Held-out relative force error of the current model, %.
    floor : float
        Noise floor of that error, %.
    best_sse : float
        Held-out SSE (noise-normalised) the path must end below.
    say : callable, optional
        Progress messages.
    max_paths : int
        At most this many second steps are tried.
    criterion : Criterion
        The thresholds of the verdict.
    """
    for c, step in _paths(others, blocked, try_on_blocked, max_paths):
        whole = earns(err_before, step.error_after, floor,
                      blocked.delta_bic_fit + step.delta_bic_fit,
                      blocked.delta_bic_heldout + step.delta_bic_heldout, criterion=criterion)
        ok = step.earns and whole and step.sse_heldout < best_sse
        if say:
            say(f"look-ahead: {c.effect} on top of {blocked.effect}: held-out error "
                f"{err_before:.3f} -> {blocked.error_after:.3f} -> {step.error_after:.3f} %"
                f"{_verdict(ok, step)}")
        if ok:
            return True
    return False

