"""The evidence for an effect: every statistic the discrepancy search measures a
model by — nothing here decides (the verdicts are :mod:`.judge`'s, by the thresholds of
:class:`~.criterion.Criterion`).

* residual size: :func:`normalised_sse`, :func:`force_error_percent`, per channel
  :func:`channel_sse`; the effective sample size :func:`effective_samples`
  (N/τ, τ the integrated autocorrelation time) and :func:`delta_bic`;
* the noise floor of the relative force error (:func:`force_noise_floor_percent`),
  the smallest change the data resolve (:func:`force_resolution`) and whether an
  effect's size is resolved (:func:`significant`);
* :func:`ljung_box` / :func:`residual_is_white`: the portmanteau test of a residual's
  autocorrelation (Ljung & Box 1978), applied before a data-driven term is proposed;
* the effect's own evidence: :func:`disturbance_masks` (samples of a held-out record
  where the data set documents a disturbance, EMPS: the pulse edges marked by
  ``pulses.csv``) and :func:`block_excess_reductions` — the held-out records cut into
  contiguous blocks, the share of each block's error above the noise floor that a
  model change removes.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from scipy.stats import chi2

from ...physics.components import Component
from ..identify_result import force_relative_error_percent
from .prepared import PreparedTest
from .channels import (autocorrelation_time, channel_delta_bic, channel_effective_samples,
                       channel_sse)

__all__ = ["normalised_sse", "force_error_percent", "autocorrelation_time",
           "effective_samples", "channel_effective_samples", "delta_bic", "channel_delta_bic",
           "acts_on_generator", "floor_noise_std",
           "force_noise_floor_percent", "force_resolution", "channel_sse", "significant",
           "ljung_box", "residual_is_white", "disturbance_masks", "block_excess_reductions",
           "MASK_BEFORE_S", "MASK_AFTER_S", "change_evidence"]


# ------------------------------------------------------------------ residual size
def effective_samples(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray]) -> float:
    """N_eff = Σ over tests and channels of N / τ of the normalised residual."""
    return float(np.sum(channel_effective_samples(prepared, preds)))


def normalised_sse(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray]) -> float:
    """Noise-normalised SSE Σ ((y − ŷ)/σ)² over every test and channel (dimensionless)."""
    return float(sum(np.sum(((pt.y - yp) * pt.wnorm) ** 2)
                     for pt, yp in zip(prepared, preds)))


def force_error_percent(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray]) -> float:
    """Relative force error (%) of ``preds`` over the resolved samples of every test."""
    return force_relative_error_percent(
        np.concatenate([p[0][pt.weight > 0] for pt, p in zip(prepared, preds)]),
        np.concatenate([pt.y[0][pt.weight > 0] for pt in prepared]))


def delta_bic(sse_new: float, sse_old: float, k: int, n_eff: float) -> float:
    """ΔBIC = N_eff ln(SSE_new/SSE_old) + k ln N_eff of ``k`` added parameters (< 0: the
    larger model is preferred)."""
    return n_eff * math.log(max(sse_new, 1e-300) / sse_old) + k * math.log(max(n_eff, 2.0))


def change_evidence(fit_pts, fit_before, fit_after, held_pts, held_before, held_after,
                    k: int, n_eff_fit: float, n_eff_held: float) -> tuple:
    """The evidence of a model change on the record, ``k`` parameters charged: the
    evaluation tests (the held-out ones; the fit tests when none is held out), the
    relative force error (%) before and after on them, and ΔBIC on the fit and
    evaluation tests.

    Returns
    -------
    tuple
        (evaluation tests, their predictions after, before, error before, error after,
        ΔBIC fit, ΔBIC evaluation).
    """
    ev, pe, pe0 = ((held_pts, held_after, held_before) if held_pts else
                   (fit_pts, fit_after, fit_before))
    e0, e1 = force_error_percent(ev, pe0), force_error_percent(ev, pe)
    d_fit = delta_bic(normalised_sse(fit_pts, fit_after), normalised_sse(fit_pts, fit_before),
                      k, n_eff_fit)
    d_held = delta_bic(normalised_sse(ev, pe), normalised_sse(ev, pe0), k,
                       n_eff_held if held_pts else n_eff_fit)
    return ev, pe, pe0, e0, e1, d_fit, d_held


# ------------------------------------------------------------------ noise


def floor_noise_std(y: np.ndarray) -> float:
    """Noise level of a sampled signal from its *fourth* differences (median absolute
    deviation; Δ⁴ of white noise of std σ has std √70 σ).  The second differences of
    the fit's weights are biased high where the signal curves fast (a 3 Hz bench
    test: 2.34 N for a true 2.0 N, so the noise floor sat above the true parameters'
    error, 0.658 vs 0.588 %); the fourth differences cancel that curvature (2.07 N;
    floor 0.596 % against 0.596 % from the true σ)."""
    d4 = np.diff(np.asarray(y, dtype=float), 4)
    mad = np.median(np.abs(d4 - np.median(d4)))
    return float(max(1.4826 * mad / math.sqrt(70.0), 1e-12))


def force_noise_floor_percent(prepared: Sequence[PreparedTest]) -> float:
    """Relative force error (%) that the measurement noise alone gives:
    100 √(Σ σ_i² N_i) / ‖F‖ over the resolved samples (σ_i the noise level of test i's
    force from its fourth differences, :func:`floor_noise_std`; for a force through the
    parallel filter, the raw force's σ times the filter's white-noise gain — the fourth
    differences of a low-passed record see almost none of its noise)."""
    num = sum((floor_noise_std(pt.y[0] if pt.raw_force_N is None else pt.raw_force_N)
               * pt.force_noise_gain) ** 2 * pt.n_resolved for pt in prepared)
    den = float(np.sum(np.concatenate([pt.y[0][pt.weight > 0] for pt in prepared]) ** 2))
    return 100.0 * math.sqrt(num / den) if den > 0 else 0.0


def force_resolution(floor: float, n_force: int | None) -> float:
    """The smallest change of the relative force error (%) the data resolve: the noise
    floor's own standard error, floor/√(2 N) for N force samples (an rms estimated from
    N Gaussian residuals is uncertain by 1/√(2N) of itself); 0 when N is not given."""
    return floor / math.sqrt(2.0 * n_force) if n_force else 0.0


def acts_on_generator(component: Any) -> bool:
    """Whether a bench-model component changes the generator's electrics directly (its
    EMF, its winding resistance or its flux: a voltage drop, a heating, a saturation).

    The own-channel route (:func:`earns_on_own_channel`) is for the *first* such
    effect: once one is in the model, the voltage's leftover excess is that member's
    misfit of another law as much as a second effect (after a constant drop fitted to
    a Shockley diode, a flux saturation removed 15 % of the voltage's remaining
    excess), and the force decides where its excess dominates, as before."""
    return any(getattr(type(component), m, None) is not getattr(Component, m)
               for m in ("emf", "extra_resistance_ohm", "generator_factor"))


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
        Parameter name → (low, high) or None (:meth:`FitResult.interval`), in the
        parameter's units.
    amplitudes : sequence of str
        The effect's amplitude parameters (:attr:`~.candidates.Candidate.amplitudes`).
    """
    ivs = [intervals.get(n) for n in amplitudes]
    known = [iv for iv in ivs if iv is not None and all(map(math.isfinite, iv))]
    if not amplitudes or not known:
        return True
    return any(lo > 0 or hi < 0 for lo, hi in known)


# ------------------------------------------------------------------ the effect's own evidence
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
                      alpha: float) -> tuple[bool, float]:
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
                            after: Sequence[np.ndarray], masks: Sequence[np.ndarray] | None,
                            blocks: int, within_noise: float) -> np.ndarray:
    """Per contiguous block of every test (masked samples left out), the share of the
    block's force error above its noise level removed:
    1 − √(SSE₁ − N σ²)/√(SSE₀ − N σ²) (negative when the error grows; NaN for a block
    with too few samples, or whose excess SSE₀ − N σ² is within ``within_noise`` N σ²)."""
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
            if e0 <= within_noise * idx.size * s2:  # the block's excess is within noise
                out.append(math.nan)
                continue
            out.append(1.0 - math.sqrt(max(e1, 0.0) / e0) if e1 <= e0
                       else -(math.sqrt(e1) - math.sqrt(e0)) / math.sqrt(e0))
    return np.array(out)


# ------------------------------------------------------------------ judging a candidate
