"""Choices of a round of the discrepancy search beyond the per-candidate rule
:func:`~.refit.earns` (kept apart from :mod:`.workflow` to keep each module small).

* :func:`channel_sse_excess_reduction`: the SSE alternative of the rule, judged per
  output channel (an effect seen mainly in the voltage must gain *in the voltage*);
* :func:`significant`: an effect earns only when its size is resolved (the interval
  of one of its amplitudes excludes zero) — not for what re-identifying the current
  model alongside it gives;
* :func:`choose_winner`: which of the earning candidates is added (held-out ΔBIC,
  i.e. the SSE drop with the parameter count's penalty — parsimony between nested
  effects such as a zero gap and a compliance);
* :func:`should_widen`: whether the round re-identifies the lower-ranked candidates
  too before deciding (the best earning candidate explains little of the excess);
* :func:`confounded` / :func:`lookahead_winner`: a candidate that fits the fit tests
  but fails on the held-out ones is tried on top of each earning candidate, and the
  one that lets it earn is added first (it absorbed that candidate's residual);
  :func:`confounded_first`: or, when nothing fitted alone does, the others are
  fitted on top of it, and a path over it that earns as a whole adds it first.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from .fit import PreparedTest
from .refit import MIN_EXCESS_REDUCTION, MIN_SSE_EXCESS

__all__ = ["channel_sse", "channel_sse_excess_reduction", "sse_can_earn", "choose_winner",
           "should_widen", "confounded", "supported", "lookahead_winner", "confounded_first", "significant", "WIDEN_BELOW"]

#: When the best earning candidate of a round removes less than this share of the
#: held-out force error's excess over the noise floor, the round re-identifies every
#: remaining applicable candidate before deciding (see :func:`should_widen`).
WIDEN_BELOW = 0.5


def channel_sse(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray]
                ) -> tuple[np.ndarray, np.ndarray]:
    """Noise-normalised SSE per output channel and its noise expectation.

    Returns
    -------
    sse : ndarray, shape (ny,)
        Σ over tests of Σ ((y − ŷ)/σ)² of each channel (force [, voltage]),
        dimensionless.
    n : ndarray, shape (ny,)
        Number of samples of each channel (the SSE pure noise gives).
    """
    ny = max(pt.y.shape[0] for pt in prepared)
    sse, n = np.zeros(ny), np.zeros(ny)
    for pt, yp in zip(prepared, preds):
        for ch in range(pt.y.shape[0]):
            sse[ch] += float(np.sum(((pt.y[ch] - yp[ch]) * pt.wnorm[ch]) ** 2))
            n[ch] += pt.y.shape[1]
    return sse, n


def channel_sse_excess_reduction(sse_before: np.ndarray, sse_after: np.ndarray,
                                 n: np.ndarray) -> float | None:
    """The SSE alternative of the decision rule, per channel.

    For each channel whose SSE before exceeds its noise expectation by more than
    :data:`~.refit.MIN_SSE_EXCESS` (a share of N), the share of that excess removed,
    1 − (SSE₁ − N)/(SSE₀ − N); the largest of these, or None when no channel has such
    an excess.  Judged per channel because the alternative is for effects seen mainly
    in another channel than the force: pooled with the force, a channel's small
    leftover excess (e.g. of a fitted heating's voltage) let a second effect earn by
    removing force noise (a cogging named at a force error 0.57 → 0.56 % with the
    noise floor at 0.57 %).

    Parameters
    ----------
    sse_before, sse_after : ndarray, shape (ny,)
        Per-channel noise-normalised SSE (dimensionless) of the current model and of
        the candidate on the same tests (:func:`channel_sse`).
    n : ndarray, shape (ny,)
        Samples per channel.
    """
    best = None
    for s0, s1, nc in zip(sse_before, sse_after, n):
        if nc > 0 and s0 > (1 + MIN_SSE_EXCESS) * nc:
            red = 1.0 - (s1 - nc) / (s0 - nc)
            best = red if best is None else max(best, red)
    return best


def sse_can_earn(sse_before: np.ndarray, n: np.ndarray) -> bool:
    """Whether the SSE alternative is offered at all (some channel's excess over its
    noise expectation exceeds :data:`~.refit.MIN_SSE_EXCESS`)."""
    return bool(np.any((n > 0) & (sse_before > (1 + MIN_SSE_EXCESS) * n)))


def choose_winner(earning: Sequence[Any]) -> Any:
    """The earning candidate to add: the lowest held-out ΔBIC.

    ΔBIC = N_eff ln(SSE_new/SSE_old) + k ln N_eff with the same N_eff and SSE_old for
    every candidate of the round, so this is the largest held-out SSE drop net of a
    ln N_eff penalty per effect parameter.  Between nested effects that fit equally
    well — a backlash whose gap tends to zero *is* a compliance (3 vs 2 parameters) —
    the simpler one is chosen; a compliance of 3e6 N/m had been answered ``backlash``
    by the raw SSE (held-out error 0.925 % for both).  Ties (equal ΔBIC) fall back
    to the lower held-out SSE.

    Parameters
    ----------
    earning : sequence of CandidateResult
        Candidates of the round that earn (``delta_bic_heldout`` and ``sse_heldout``
        set).
    """
    if not earning:
        raise ValueError("choose_winner: no earning candidate")
    return min(earning, key=lambda c: (c.delta_bic_heldout, c.sse_heldout))


def should_widen(earning: Sequence[Any], force_excess: bool = True) -> bool:
    """Whether to re-identify the remaining lower-ranked candidates before deciding.

    True when some candidate earns but the best earning one removes less than
    :data:`WIDEN_BELOW` of the held-out force error's excess over the noise floor
    (when the force has no excess beyond noise, ``force_excess`` False: of the SSE
    alternative's excess — a voltage-seen effect): most of what the model
    misses is then unexplained by the top-ranked candidates, and the ranking (a
    linearised score on the fit tests) may have put the effect that explains it
    below ``top`` — a 12-per-rev cogging beside a 0.1 mm gap ranked 5th, the gap's
    refit absorbed the ripple on the fit tests and failed on the held-out ones, and
    a compliance earning 11 % of the excess took the only transmission slot.

    Parameters
    ----------
    earning : sequence of CandidateResult
        The earning candidates of the round (``excess_reduction`` set; an optional
        ``sse_reduction`` attribute holds the SSE alternative's share).
    force_excess : bool
        Whether the force error's excess over the noise floor is beyond noise
        (:func:`~.refit.can_earn` on the force alone).  Then the force gain decides
        alone: a compliance beside a gap plus a cogging removed 11 % of the force
        excess but more than half of the voltage channel's, and the round was not
        widened.
    """
    if not earning:
        return False
    gains = []
    for c in earning:
        g = c.excess_reduction if math.isfinite(c.excess_reduction) else -math.inf
        s = getattr(c, "sse_reduction", None)
        use_sse = not force_excess and s is not None and math.isfinite(s)
        gains.append(max(g, s) if use_sse else g)
    return max(gains) < max(WIDEN_BELOW, MIN_EXCESS_REDUCTION)


def confounded(cands: Sequence[Any]) -> Any | None:
    """The fitted candidate that explains the fit tests best (lowest ΔBIC there, < 0)
    but does not earn on the held-out tests — a sign that its refit absorbed another
    effect's residual on the fit tests (a gap taking up a 12-per-rev cogging ripple:
    fit ΔBIC −1005, held-out error 14.28 → 15.41 %); None when there is none."""
    pool = [c for c in cands if c.fitted and not c.earns and c.predictions is not None
            and math.isfinite(c.delta_bic_fit) and c.delta_bic_fit < 0]
    return min(pool, key=lambda c: c.delta_bic_fit) if pool else None


def supported(c: Any) -> bool:
    """Whether a fitted candidate may be the first step of a look-ahead path
    (:func:`lookahead_winner`) without earning by itself: it explains something on
    the fit tests (ΔBIC < 0 there) and its size is resolved (``c.resolved``,
    :func:`significant`).  Its held-out gain is not required: beside a 0.1 mm gap
    a 12-per-rev cogging fitted alone stays small (the gap dominates the residual);
    the path is judged as a whole."""
    return bool(c.fitted and c.predictions is not None and getattr(c, "resolved", True)
                and math.isfinite(c.delta_bic_fit) and c.delta_bic_fit < 0)


def lookahead_winner(earning: Sequence[Any], blocked: Any, try_on_top: Any,
                     say: Any = None, max_paths: int = 2, first_steps: Sequence[Any] = ()
                     ) -> Any | None:
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
    """
    best, best_sse = None, choose_winner(earning).sse_heldout if earning else math.inf
    pool = sorted(earning, key=lambda c: (c.delta_bic_heldout, c.sse_heldout)) + sorted(
        (c for c in first_steps if c not in earning), key=lambda c: c.delta_bic_fit)
    for c, step in _paths(pool, blocked, try_on_top, max_paths):
        ok = (step.earns and step.error_after < c.error_before
              and getattr(step, "first_resolved", True))
        if say:
            say(f"look-ahead: {blocked.effect} on top of {c.effect}: held-out error "
                f"{c.error_before:.3f} -> {c.error_after:.3f} -> {step.error_after:.3f} %"
                f"{' (the path earns)' if ok else ' (the path does not earn)'}")
        if ok and step.sse_heldout < best_sse:
            best, best_sse = c, step.sse_heldout
    return best


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


def significant(intervals: dict, amplitudes: Sequence[str]) -> bool:
    """Whether the effect's size is resolved: the ~95 % interval of at least one of its
    ``amplitudes`` (parameters that are all zero when the effect is absent) excludes
    zero.

    The refit of a candidate frees the current model's parameters too, so part of
    its gain can be what re-identifying the current model gives: a voltage drop of
    1.5e-8 V (interval ±0.005 V) "removed 39 % of the voltage channel's excess"
    after a fitted winding heating by re-fitting the heating.  True when there are
    no amplitudes (a transmission effect: absent is a limit, not a zero) or no
    interval could be computed (no evidence either way).

    Parameters
    ----------
    intervals : dict
        Parameter name → (low, high) or None (:meth:`FitOutcome.interval`), in the
        parameter's units.
    amplitudes : sequence of str
        The effect's amplitude parameters (:attr:`~.candidates.Candidate.amplitudes`).
    """
    ivs = [intervals.get(n) for n in amplitudes]
    known = [iv for iv in ivs if iv is not None and all(map(math.isfinite, iv))]
    if not amplitudes or not known:
        return True
    return any(lo > 0 or hi < 0 for lo, hi in known)


def confounded_first(blocked: Any, others: Sequence[Any], try_on_blocked: Any,
                     err_before: float, floor: float, best_sse: float, say: Any = None,
                     max_paths: int = 4) -> bool:
    """Whether the confounded candidate ``blocked`` should be added first: some other
    candidate C, re-identified on top of it (C's own and ``blocked``'s parameters
    free), completes a path ``blocked`` → C that earns as a whole.

    The reverse of :func:`lookahead_winner`: when the effect that ``blocked``
    absorbed on the fit tests cannot be fitted alone (a 12-per-rev cogging beside a
    0.1 mm gap: fitted alone on the baseline it finds nothing, fit ΔBIC > 0), the
    joint refit on top of ``blocked`` can still separate them.  A path earns when C
    earns on top of ``blocked`` (``step.earns``, its size resolved), the path as a
    whole earns against the current model by :func:`~.refit.earns` (held-out force
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
    """
    from .refit import earns
    for c, step in _paths(others, blocked, try_on_blocked, max_paths):
        whole = earns(err_before, step.error_after, floor,
                      blocked.delta_bic_fit + step.delta_bic_fit,
                      blocked.delta_bic_heldout + step.delta_bic_heldout)
        ok = step.earns and whole and step.sse_heldout < best_sse
        if say:
            say(f"look-ahead: {c.effect} on top of {blocked.effect}: held-out error "
                f"{err_before:.3f} -> {blocked.error_after:.3f} -> {step.error_after:.3f} %"
                f"{' (the path earns)' if ok else ' (the path does not earn)'}")
        if ok:
            return True
    return False
