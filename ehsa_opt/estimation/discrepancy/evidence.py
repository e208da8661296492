"""Evidence for one effect on its own, and whether a residual is still structured.

* :func:`ljung_box` / :func:`residual_is_white`: the portmanteau test of a residual's
  autocorrelation (Ljung & Box 1978), applied before a data-driven term is proposed
  — a term fitted to a white residual is a term fitted to noise;
* :func:`disturbance_masks`: samples of a held-out record where the data set
  documents a disturbance (EMPS: the pulse edges marked by ``pulses.csv``); they are
  left out of the per-block judgement below, and the report says so;
* :func:`block_excess_reductions` / :func:`own_evidence`: the practical size of an
  effect judged where it can be seen — the held-out records cut into contiguous
  blocks, the share of each block's error above the noise floor that the effect
  removes, and its median over the blocks.  A dominant effect localised in a few
  blocks (pulses, a rough spot) then holds most of the *total* excess without
  vetoing an effect that acts everywhere (a direction-dependent friction); the
  likelihood evidence (held-out ΔBIC with the effective sample size) and a resolved
  size are required as before.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.stats import chi2

from .fit import PreparedTest

__all__ = ["ljung_box", "residual_is_white", "disturbance_masks", "block_excess_reductions",
           "own_evidence", "BLOCKS_PER_TEST", "WHITE_P", "MASK_BEFORE_S", "MASK_AFTER_S"]

#: Contiguous blocks each held-out test is cut into for :func:`block_excess_reductions`.
BLOCKS_PER_TEST = 8
#: A residual whose Ljung–Box p-value exceeds this is white: no term is proposed.
WHITE_P = 0.01
#: Window masked around each documented disturbance edge, s (before, after): the
#: derivative filter is non-causal (a few ms before the edge) and the closed loop's
#: answer to a 176 N step dies out within ≈ 0.1 s on the EMPS record.
MASK_BEFORE_S, MASK_AFTER_S = 0.02, 0.10


def ljung_box(r: np.ndarray, lags: int | None = None) -> tuple[float, float, int]:
    """Ljung–Box statistic Q = n(n+2) Σ_{k≤m} ρ̂_k²/(n−k) of ``r`` and its p-value
    against χ²(m); m = ``lags`` (default min(20, n/5)).  Returns (Q, p, m)."""
    r = np.asarray(r, float)
    r = r[np.isfinite(r)]
    n = r.size
    if n < 10:
        raise ValueError(f"ljung_box: need at least 10 samples, got {n}")
    m = int(lags) if lags is not None else int(min(20, n // 5))
    x = r - r.mean()
    den = float(x @ x)
    if den <= 0:
        return 0.0, 1.0, m
    rho = np.array([float(x[k:] @ x[:-k]) / den for k in range(1, m + 1)])
    q = float(n * (n + 2) * np.sum(rho ** 2 / (n - np.arange(1, m + 1))))
    return q, float(chi2.sf(q, m)), m


def residual_is_white(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray],
                      alpha: float = WHITE_P) -> tuple[bool, float]:
    """Whether every test's noise-normalised force residual passes the Ljung–Box test
    at level ``alpha`` (Bonferroni over the tests).  Returns (white, smallest p)."""
    ps = [ljung_box(pt.y[0] - yp[0])[1] for pt, yp in zip(prepared, preds)]
    pmin = min(ps) if ps else 1.0
    return bool(pmin * max(len(ps), 1) > alpha), float(pmin)


def disturbance_masks(prepared: Sequence[PreparedTest], directory: str | Path | None
                      ) -> tuple[list[np.ndarray], str]:
    """Per test, True where a sample is kept: False within [−MASK_BEFORE_S,
    +MASK_AFTER_S] of every edge of a documented disturbance marker.

    The marker is ``pulses.csv`` (columns time_s and one signal) beside the tests in
    ``directory`` (the EMPS validation record); without it every sample is kept.
    Returns the masks and a sentence saying what was masked ("" when nothing)."""
    masks = [np.ones(pt.time_s.size, bool) for pt in prepared]
    if directory is None:
        return masks, ""
    f = Path(directory) / "pulses.csv"
    if not f.is_file():
        return masks, ""
    try:
        tab = np.loadtxt(f, delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{f}: cannot read the disturbance marker ({exc}); expected two "
                         "numeric columns time_s,signal") from exc
    t_edge = tab[1:, 0][np.diff(tab[:, 1]) != 0]
    masked = 0.0
    for pt, m in zip(prepared, masks):
        t = pt.time_s
        for te in t_edge:
            m[(t >= te - MASK_BEFORE_S) & (t <= te + MASK_AFTER_S)] = False
        masked = 1.0 - m.mean()
    if not t_edge.size:
        return masks, ""
    return masks, (f"{t_edge.size} edges of the documented pulses ({f.name}) masked "
                   f"({1000 * MASK_BEFORE_S:.0f} ms before to {1000 * MASK_AFTER_S:.0f} ms after "
                   f"each, {100 * masked:.0f} % of the record) in the per-block judgement")


def block_excess_reductions(prepared: Sequence[PreparedTest], before: Sequence[np.ndarray],
                            after: Sequence[np.ndarray], masks: Sequence[np.ndarray] | None = None,
                            blocks: int = BLOCKS_PER_TEST) -> np.ndarray:
    """Per contiguous block of every test (masked samples left out), the share of the
    block's force error above its noise level removed:
    1 − √(SSE₁ − N σ²)/√(SSE₀ − N σ²) (negative when the error grows; NaN for a block
    with no excess beyond noise or too few samples)."""
    out = []
    for k, (pt, y0, y1) in enumerate(zip(prepared, before, after)):
        keep = masks[k] if masks is not None else np.ones(pt.time_s.size, bool)
        s2 = float(pt.sigma[0]) ** 2
        for idx in np.array_split(np.arange(pt.time_s.size), blocks):
            idx = idx[keep[idx]]
            if idx.size < 20:
                out.append(math.nan)
                continue
            e0 = float(np.sum((pt.y[0, idx] - y0[0, idx]) ** 2)) - idx.size * s2
            e1 = float(np.sum((pt.y[0, idx] - y1[0, idx]) ** 2)) - idx.size * s2
            if e0 <= 0.09 * idx.size * s2:  # the block's excess is within noise
                out.append(math.nan)
                continue
            out.append(1.0 - math.sqrt(max(e1, 0.0) / e0) if e1 <= e0
                       else -(math.sqrt(e1) - math.sqrt(e0)) / math.sqrt(e0))
    return np.array(out)


def own_evidence(reductions: np.ndarray, min_reduction: float) -> tuple[bool, float, int]:
    """The practical size on the effect's own evidence: the median over blocks with an
    excess of :func:`block_excess_reductions` reaches ``min_reduction``.  Returns
    (passes, median, blocks judged)."""
    r = np.asarray(reductions, float)
    r = r[np.isfinite(r)]
    if r.size < 3:
        return False, math.nan, int(r.size)
    med = float(np.median(r))
    return bool(med >= min_reduction), med, int(r.size)
