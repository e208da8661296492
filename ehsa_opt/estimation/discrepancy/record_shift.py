"""Time shifts of a record against the model: the shift of the force that best explains
the residual, one per test or one for all — the evidence of a delay of the record
(:mod:`.candidates.force_lag`, the voltage's skew, the data-driven term's ``lag``
group)."""

from __future__ import annotations

import numpy as np

from .evidence import delta_bic
from .prepared import PreparedTest

__all__ = ["LAG_GRID_S", "shifted_force", "shift_sse_curves", "shift_lag", "per_test_delays"]


#: Lags searched by :func:`shift_lag`, s.
LAG_GRID_S = np.arange(-0.02, 0.02001, 0.0002)


def shifted_force(pt: PreparedTest, pred: np.ndarray, tau: float) -> np.ndarray:
    """The model force delayed by ``tau`` (linear interpolation)."""
    return np.interp(pt.time_s - tau, pt.time_s, pred[0])



def shift_sse_curves(pts, preds) -> np.ndarray:
    """(tests, :data:`LAG_GRID_S`) SSE of (F − F̂(t − τ))/σ of each test at each delay τ."""
    return np.array([[float(np.sum(((pt.y[0] - shifted_force(pt, yp, tau)) * pt.wnorm[0]) ** 2))
                      for tau in LAG_GRID_S] for pt, yp in zip(pts, preds)])


def shift_lag(pts, preds) -> tuple[float, float] | None:
    """The delay τ of the force channel (on :data:`LAG_GRID_S`) minimising the fit-set
    SSE of (F − F̂(t − τ))/σ, and that SSE; None when τ = 0 is best."""
    sses = shift_sse_curves(pts, preds).sum(axis=0)
    k = int(np.argmin(sses))
    if abs(LAG_GRID_S[k]) < 1e-9:
        return None
    return float(LAG_GRID_S[k]), float(sses[k])


def per_test_delays(pts, preds, n_eff: float) -> float:
    """ΔBIC of one delay per test against one delay for all (< 0: the tests' own delays
    fit significantly better).

    A delay of the force channel is one number for the whole record: the same at every
    frequency of a sine, every speed of a stroke, every protocol.  A residual that a
    time shift reduces for another reason — friction whose transition at a reversal
    takes a distance (presliding), so that the lead it looks like is that distance over
    the speed — asks for a different shift on each test.  Per-test delays then reduce
    the SSE beyond what their ``len(pts) - 1`` extra parameters explain (ΔBIC with the
    effective sample size ``n_eff`` of the fit tests)."""
    curves = shift_sse_curves(pts, preds)
    return delta_bic(float(curves.min(axis=1).sum()), float(curves.sum(axis=0).min()),
                     len(pts) - 1, n_eff)
