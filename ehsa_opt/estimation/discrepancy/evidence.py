"""The evidence for an effect and the decision rule: every statistic the
discrepancy search judges a model by, and the rule that names an effect.

* residual size: :func:`normalised_sse`, :func:`force_error_percent`, per channel
  :func:`channel_sse`; the effective sample size :func:`effective_samples`
  (N/τ, τ the integrated autocorrelation time) and :func:`delta_bic`;
* the noise floor of the relative force error (:func:`force_noise_floor_percent`)
  and the share of the error above it that a model removes
  (:func:`excess_reduction`);
* the decision rule :func:`earns` (and :func:`can_earn`, whether any refit could
  earn from a state), its SSE alternative per output channel
  (:func:`channel_sse_excess_reduction`, :func:`sse_can_earn`) and the resolved-size
  check :func:`significant`;
* the effect's own evidence: :func:`disturbance_masks` (samples of a held-out record
  where the data set documents a disturbance, EMPS: the pulse edges marked by
  ``pulses.csv``) and :func:`block_excess_reductions` / :func:`own_evidence` — the
  practical size judged where it can be seen: the held-out records cut into
  contiguous blocks, the share of each block's error above the noise floor that the
  effect removes, and its median over the blocks.  A dominant effect localised in a
  few blocks (pulses, a rough spot) then holds most of the *total* excess without
  vetoing an effect that acts everywhere (a direction-dependent friction); the
  likelihood evidence (held-out ΔBIC with the effective sample size) and a resolved
  size are required as before;
* :func:`earns_on_own_channel`: a generator member (voltage drop, heating, saturation)
  judged on its own channel, the voltage, whatever the force's excess — per-channel
  statistics in :mod:`.channels`, the physical-range rule (:func:`at_bound`, a bound
  counts where it is active) in :mod:`.bounds`;
* :func:`ljung_box` / :func:`residual_is_white`: the portmanteau test of a residual's
  autocorrelation (Ljung & Box 1978), applied before a data-driven term is proposed
  — a term fitted to a white residual is a term fitted to noise;
* :func:`judge_candidate`: one re-identified candidate measured and judged by all
  of the above.
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
from .impacts import impact_record, judge_on_impacts
from .bounds import AT_BOUND_REL, at_bound, refuse_at_bound, unconstrained_step
from .channels import (autocorrelation_time, channel_delta_bic, channel_effective_samples,
                       channel_sse, refuted_by_channel)

__all__ = ["normalised_sse", "force_error_percent", "autocorrelation_time",
           "effective_samples", "channel_effective_samples", "delta_bic", "channel_delta_bic",
           "earns_on_own_channel", "refuted_by_channel", "acts_on_generator", "floor_noise_std",
           "force_noise_floor_percent",
           "excess_reduction", "force_resolution", "earns", "can_earn", "channel_sse",
           "channel_sse_excess_reduction", "sse_can_earn", "significant", "ljung_box",
           "residual_is_white", "disturbance_masks", "block_excess_reductions",
           "own_evidence", "judge_candidate", "choose_winner", "MIN_EXCESS_REDUCTION",
           "MIN_EXCESS_OVER_FLOOR", "MIN_SSE_EXCESS", "BLOCKS_PER_TEST", "WHITE_P",
           "MASK_BEFORE_S", "MASK_AFTER_S", "refuted_by_rotor_channel", "at_bound",
           "refuse_at_bound", "own_channel_dbic",
           "AT_BOUND_REL"]


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


# ------------------------------------------------------------------ the decision rule
#: A named effect (or a discovered term) must remove at least this share of the
#: held-out relative force error *above the noise floor* (see :func:`excess_reduction`).
MIN_EXCESS_REDUCTION = 0.10


#: ... and that excess must itself stand out of the noise: at least this share of the
#: noise floor (the floor is estimated, so a residual at the floor has a small excess).
MIN_EXCESS_OVER_FLOOR = 0.3


#: The all-channel SSE alternative needs an excess over noise of this share of N.
MIN_SSE_EXCESS = 0.25


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


def excess_reduction(err_before: float, err_after: float, floor: float) -> float:
    """Share of the error above the noise floor removed:
    1 − √(e₁² − e_n²)/√(e₀² − e_n²) (negative when the error grows)."""
    ex0 = math.sqrt(max(err_before ** 2 - floor ** 2, 0.0))
    ex1 = math.sqrt(max(err_after ** 2 - floor ** 2, 0.0))
    if ex0 <= MIN_EXCESS_OVER_FLOOR * floor:  # nothing beyond noise left to explain
        return 0.0 if err_after <= err_before else -math.inf
    if err_after > err_before:
        return -(err_after - err_before) / ex0
    return 1.0 - ex1 / ex0


def force_resolution(floor: float, n_force: int | None) -> float:
    """The smallest change of the relative force error (%) the data resolve: the noise
    floor's own standard error, floor/√(2 N) for N force samples (an rms estimated from
    N Gaussian residuals is uncertain by 1/√(2N) of itself); 0 when N is not given."""
    return floor / math.sqrt(2.0 * n_force) if n_force else 0.0


def earns(err_before: float, err_after: float, floor: float, dbic_fit: float,
          dbic_heldout: float, sse_excess_reduction: float | None = None,
          n_force: int | None = None) -> bool:
    """The decision rule: the held-out force error does not grow and falls by at least
    :data:`MIN_EXCESS_REDUCTION` of its excess over the noise floor — or, for an
    effect seen mainly in another channel (voltage), the held-out SSE of all
    noise-normalised channels falls by that share of its excess over noise
    (``sse_excess_reduction`` = 1 − (SSE₁ − N)/(SSE₀ − N)) while the force error does
    not grow by more than the data resolve (:func:`force_resolution` of the ``n_force``
    held-out force samples: a voltage drop can leave the force error unchanged up to
    rounding) — and ΔBIC < 0 on the fit tests and on the held-out tests (beyond what
    noise explains)."""
    gain = excess_reduction(err_before, err_after, floor)
    if (sse_excess_reduction is not None
            and err_after <= err_before + force_resolution(floor, n_force)):
        gain = max(gain, sse_excess_reduction)
    return gain >= MIN_EXCESS_REDUCTION and dbic_fit < 0 and dbic_heldout < 0


def earns_on_own_channel(own_reduction: float | None, dbic_fit: float, dbic_heldout: float,
                         force_kept: bool) -> bool:
    """The decision rule for a member whose own channel is not the force (a generator
    effect, seen in the voltage: :attr:`~.candidates.Candidate.own_channels`), whatever
    the force's excess over its noise floor.

    Earns when the held-out SSE of its own channel(s) falls by at least
    :data:`MIN_EXCESS_REDUCTION` of its excess over noise (``own_reduction``,
    :func:`channel_sse_excess_reduction` on those channels; None when no own channel
    has an excess, and then it does not earn here), ΔBIC < 0 on the fit tests and on
    the held-out tests (the held-out one with a variance per channel,
    :func:`channel_delta_bic`), and the force is kept (``force_kept``: its held-out
    error grows by no more than :func:`force_resolution`, or its SSE by no more than
    the member's parameters are charged, :func:`refuted_by_channel`).

    The force's excess does not close this route: where the force carries a misfit no
    member describes (presliding friction, 13 % against a 0.6 % floor), a flux
    saturation that removed 78 % of the voltage's excess was otherwise judged by the
    force alone and not named.  Ranking and the winner already use the member's own
    channel (:func:`choose_winner`)."""
    return (own_reduction is not None and own_reduction >= MIN_EXCESS_REDUCTION
            and dbic_fit < 0 and dbic_heldout < 0 and bool(force_kept))


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


def can_earn(err_before: float, floor: float, sse_before: float, n_obs: float) -> bool:
    """Whether *any* refit could earn by :func:`earns` from this state — False when
    the force error's excess over the noise floor is within
    :data:`MIN_EXCESS_OVER_FLOOR` of the floor (no force gain is possible) and the
    all-channel SSE is within :data:`MIN_SSE_EXCESS` of its noise expectation N (the
    SSE alternative is not offered).  Exact: a round started from such a state
    cannot name anything, so it is not run."""
    ex0 = math.sqrt(max(err_before ** 2 - floor ** 2, 0.0))
    return ex0 > MIN_EXCESS_OVER_FLOOR * floor or sse_before > (1 + MIN_SSE_EXCESS) * n_obs


def channel_sse_excess_reduction(sse_before: np.ndarray, sse_after: np.ndarray,
                                 n: np.ndarray) -> float | None:
    """The SSE alternative of the decision rule, per channel.

    For each channel whose SSE before exceeds its noise expectation by more than
    :data:`MIN_SSE_EXCESS` (a share of N), the share of that excess removed,
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
    noise expectation exceeds :data:`MIN_SSE_EXCESS`)."""
    return bool(np.any((n > 0) & (sse_before > (1 + MIN_SSE_EXCESS) * n)))


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


def own_channel_dbic(c: Any) -> float:
    """The candidate's held-out ΔBIC on its own channel (``c.channel_dbic`` at
    ``c.own_channel``), NaN when either is unknown."""
    ch, d = getattr(c, "own_channel", None), getattr(c, "channel_dbic", None)
    if ch is None or not d or ch >= len(d):
        return math.nan
    return float(d[ch])


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
    physical = [c for c in earning if not getattr(c, "at_bound", ())] or list(earning)
    own = [own_channel_dbic(c) for c in physical]
    if len(physical) > 1 and all(map(math.isfinite, own)):
        # each on the channel that sees it best: the all-channel ΔBIC let a mount
        # compliance that trades the force's presliding misfit for the voltage win over
        # the diode drop that removed 96 % of the voltage excess
        return min(zip(own, physical), key=lambda t: (t[0], t[1].delta_bic_heldout,
                                                      t[1].sse_heldout))[1]
    return min(physical, key=lambda c: (c.delta_bic_heldout, c.sse_heldout))


# ------------------------------------------------------------------ the effect's own evidence
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


# ------------------------------------------------------------------ judging a candidate
def refuted_by_rotor_channel(sse_before: float, sse_after: float, k: int, n_eff: float
                             ) -> bool:
    """Whether a transmission effect is refuted by the channel that measures the rotor.

    A transmission effect (a gap, a mount spring) lets the rotor move otherwise than
    the rod; the generator's voltage measures the rotor's speed.  Such an effect present
    in the rig explains the voltage too; a refit that trades the voltage for the force
    is another force law in disguise (friction presliding fitted as a mount spring: the
    force misfit at reversals falls, the model's rotor then lags a rotor that does not).
    Refuted when the held-out voltage SSE grows by more than the evidence the member's
    ``k`` parameters are charged: N_eff ln(SSE_after/SSE_before) > k ln N_eff
    (:func:`refuted_by_channel`)."""
    return refuted_by_channel(sse_before, sse_after, k, n_eff)


def judge_candidate(c: Any, out: tuple, *, member, comps, fit_pts, held_pts, sse_fit,
                    sse_held,
                    n_eff_fit, n_eff_held, cur_err, floor, ch_sse0, ch_n, say,
                    cur_ev_pred=None, masks=None, presliding=None) -> None:
    """Fill the :class:`~.results.CandidateResult` ``c`` from one re-identification
    ``out`` (``(name, FitResult, fit outputs, held-out outputs, rig)``,
    :func:`~.candidate_fit.fit_member`) and judge it by :func:`earns` (force error,
    ΔBIC on the fit and held-out tests, SSE alternative per channel,
    :func:`channel_sse_excess_reduction`) or by its own evidence per block.
    ``member`` is the catalogue entry (:class:`~.candidates.Candidate`: the channels
    a rigid-rig effect can change, its amplitudes).  ``presliding``: the base model's
    presliding law (:class:`~.presliding.PreslidingLaw`); when adopted, the candidate's
    predictions get their own presliding term before anything here measures them
    (the current model's measures were taken on its corrected predictions)."""
    name, res, pf, ph, crig = out
    c.fitted, c.fit, c.rig = True, res, crig
    if not pf:
        say(f"{name}: re-identification failed ({res.message})")
        return
    if presliding is not None:
        pf, ph = presliding.correct(fit_pts, pf, held_pts, ph)
    comp_params = [q.name for q in comps[name].parameters]
    k = len(comp_params)
    c.parameters = {n: res.parameters[n] for n in comp_params}
    c.intervals = {n: res.interval(n) for n in c.parameters}
    c.delta_bic_fit = delta_bic(normalised_sse(fit_pts, pf), sse_fit, k, n_eff_fit)
    ev_pts, ev_pred = (held_pts, ph) if held_pts else (fit_pts, pf)
    c.sse_heldout = normalised_sse(ev_pts, ev_pred)
    c.delta_bic_heldout = (delta_bic(c.sse_heldout, sse_held, k, n_eff_held) if held_pts
                           else c.delta_bic_fit)
    c.error_after = force_error_percent(ev_pts, ev_pred)
    c.excess_reduction = excess_reduction(cur_err, c.error_after, floor)
    ch = member.rigid_channels if member is not None else None
    if ch is None or any(q.transmission for q in crig.components):
        ch = tuple(range(len(ch_n)))
    ch = [k for k in ch if k < len(ch_n)]
    ch_sse1 = channel_sse(ev_pts, ev_pred)[0]
    c.sse_reduction = channel_sse_excess_reduction(ch_sse0[ch], ch_sse1[ch], ch_n[ch])
    c.resolved = significant(c.intervals, member.amplitudes)
    c.channel_dbic = [delta_bic(s1, s0, k, n_eff_held if held_pts else n_eff_fit)
                      for s0, s1 in zip(ch_sse0, ch_sse1)]
    # the SSE (other-channel) route is for effects seen mainly in another channel: it is
    # offered where the force error has no excess beyond noise left, or where another
    # channel's excess over its noise expectation (SSE/N − 1) exceeds the force's;
    # where the force's excess dominates (a gap at 11 %), the force decides
    exc = [s0 / n0 - 1.0 if n0 > 0 else -math.inf for s0, n0 in zip(ch_sse0, ch_n)]
    c.sse_route = (not can_earn(cur_err, floor, 0.0, 1.0)
                   or (len(exc) > 1 and max(exc[1:]) > exc[0]))
    n_force = sum(pt.y.shape[1] for pt in ev_pts)
    by_total = bool(earns(cur_err, c.error_after, floor, c.delta_bic_fit, c.delta_bic_heldout,
                          c.sse_reduction if c.sse_route else None, n_force=n_force))
    # a generator effect earns on its own channel (the voltage) whatever the force's
    # excess: the held-out ΔBIC with a variance per channel, the force kept
    by_channel, own_txt = False, ""
    own_ch = [q for q in (getattr(member, "own_channels", None) or ()) if q < len(ch_n)]
    if own_ch and len(ch_n) > 1 and not by_total and not any(
            acts_on_generator(q) for q in list(getattr(crig, "components", ()))[:-1]):
        neff = channel_effective_samples(
            ev_pts, cur_ev_pred if cur_ev_pred is not None else ev_pred)
        own_red = channel_sse_excess_reduction(ch_sse0[own_ch], ch_sse1[own_ch], ch_n[own_ch])
        dbic_ch = channel_delta_bic(ch_sse0, ch_sse1, neff, k)
        force_kept = (c.error_after <= cur_err + force_resolution(floor, n_force)
                      or not refuted_by_channel(ch_sse0[0], ch_sse1[0], k, neff[0]))
        by_channel = earns_on_own_channel(own_red, c.delta_bic_fit, dbic_ch, force_kept)
        own_txt = (f", own channel{'s' if len(own_ch) > 1 else ''} "
                   f"{','.join(map(str, own_ch))}: SSE excess reduced "
                   + (f"{100 * own_red:.0f} %" if own_red is not None else "n/a")
                   + f", held-out dBIC per channel {dbic_ch:.1f}, force "
                   + ("kept" if force_kept else "refuted"))
    # the effect's own evidence: the same likelihood evidence, and its practical size
    # judged per block of the held-out records (documented disturbances masked), so
    # that an effect another one dominates in a few blocks is not vetoed
    by_own = False
    if cur_ev_pred is not None:
        red = block_excess_reductions(ev_pts, cur_ev_pred, ev_pred,
                                      masks if held_pts else None)
        by_own, c.block_reduction, c.blocks_judged = own_evidence(red, MIN_EXCESS_REDUCTION)
        by_own = (by_own and c.delta_bic_fit < 0 and c.delta_bic_heldout < 0
                  and c.error_after <= cur_err)
    c.earns_by = ("total excess" if by_total else "own channel" if by_channel
                  else "own evidence") if (by_total or by_channel or by_own) else ""
    c.earns = bool((by_total or by_channel or by_own) and c.resolved)
    if (c.earns and impact_record(res) is None and comps[name].transmission
            and len(ch_n) > 1 and refuted_by_rotor_channel(
                ch_sse0[1], ch_sse1[1], k, n_eff_held if held_pts else n_eff_fit)):
        c.earns, c.earns_by = False, ""
        say(f"{name}: refuted by the voltage (the rotor's speed): its held-out voltage SSE "
            f"grows {ch_sse0[1] / ch_n[1]:.3g} -> "
            f"{ch_sse1[1] / ch_n[1]:.3g} per sample")
    if impact_record(res) is not None and cur_ev_pred is not None:
        judge_on_impacts(c, res, ev_pts, cur_ev_pred, ev_pred, crig, say)
        c.channel_dbic = []  # judged on impacts: its sample-wise channels are not evidence
    # a bound counts where it is active: the unconstrained step from the fit crosses it
    step = (None if impact_record(res) is not None or not hasattr(crig, "model") else
            (lambda: unconstrained_step(fit_pts, crig, res.parameters, comp_params)))
    refuse_at_bound(c, comps[name].parameters, member, say, step)
    c.predictions = pf + ph
    c.per_test_after = [force_relative_error_percent(y[0][pt.weight > 0], pt.y[0][pt.weight > 0])
                        for y, pt in zip(c.predictions, fit_pts + held_pts)]
    pars = ", ".join(f"{n} {v:.3g}" + (f" [{iv[0]:.3g}, {iv[1]:.3g}]" if iv else "")
                     for (n, v), iv in zip(c.parameters.items(), c.intervals.values()))
    sse_txt = f", SSE excess reduced {100 * c.sse_reduction:.0f} %" \
        if c.sse_reduction is not None else ""
    blk = (f", median block excess reduced {100 * c.block_reduction:.0f} % over "
           f"{c.blocks_judged} blocks" if math.isfinite(c.block_reduction) else "")
    say(f"{name}: {res.message}, dBIC fit {c.delta_bic_fit:.1f}, held-out "
        f"{c.delta_bic_heldout:.1f}, error {c.error_before:.3f} -> {c.error_after:.3f} % "
        f"(excess reduced {100 * c.excess_reduction:.0f} %{sse_txt}{blk}{own_txt}; "
        f"{res.seconds:.1f} s)"
        f"{' EARNS (' + c.earns_by + ')' if c.earns else ''}"
        f"{' AT BOUND' if c.at_bound else ''}; {pars}")

