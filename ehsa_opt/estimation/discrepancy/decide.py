"""Choices of a round of the discrepancy search beyond the per-candidate rule
:func:`~.refit.earns` (kept apart from :mod:`.workflow` to keep each module small).

* :func:`channel_sse_excess_reduction`: the SSE alternative of the rule, judged per
  output channel (an effect seen mainly in the voltage must gain *in the voltage*);
* :func:`choose_winner`: which of the earning candidates is added (held-out ΔBIC,
  i.e. the SSE drop with the parameter count's penalty — parsimony between nested
  effects such as a zero gap and a compliance);
* :func:`should_widen`: whether the round re-identifies the lower-ranked candidates
  too before deciding (the best earning candidate explains little of the excess).
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from .fit import PreparedTest
from .refit import MIN_EXCESS_REDUCTION, MIN_SSE_EXCESS

__all__ = ["channel_sse", "channel_sse_excess_reduction", "sse_can_earn", "choose_winner",
           "should_widen", "WIDEN_BELOW"]

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
            sse[ch] += float(np.sum(((pt.y[ch] - yp[ch]) / pt.sigma[ch]) ** 2))
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


def should_widen(earning: Sequence[Any]) -> bool:
    """Whether to re-identify the remaining lower-ranked candidates before deciding.

    True when some candidate earns but the best earning one removes less than
    :data:`WIDEN_BELOW` of the held-out force error's excess over the noise floor
    (and the SSE alternative, when offered, says the same): most of what the model
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
    """
    if not earning:
        return False
    gains = []
    for c in earning:
        g = c.excess_reduction if math.isfinite(c.excess_reduction) else -math.inf
        s = getattr(c, "sse_reduction", None)
        gains.append(max(g, s) if s is not None and math.isfinite(s) else g)
    return max(gains) < max(WIDEN_BELOW, MIN_EXCESS_REDUCTION)
