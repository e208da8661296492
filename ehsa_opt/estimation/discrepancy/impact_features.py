"""Features of the impact-aware contact fit (:mod:`.impacts`): the sampled transient
energies and the kinematic gap of each test, their mismatch between a simulation and the
data, and what an uncertain friction does to them.  Method: docs/theory/stiff_contacts.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from .prepared import PreparedTest

__all__ = ["transient_energies", "kinematic_gap", "impact_objective", "impact_energy_ratio",
           "ENERGY_LOG_SPREAD", "GAP_SPREAD", "FeatureData", "data_features", "Mismatch",
           "mismatch", "score", "standardised_terms", "quiet_noise_levels", "friction_widening", "gap_step", "moved_friction",
           "NUT_LEVELS", "BEARING_LEVELS", "GAP_REST_SHARE", "IMPACT_FRICTION_SPREAD", "IMPACT_FRICTION_DOMINATED"]


def transient_energies(y: np.ndarray, sigma: np.ndarray | None = None,
                       weight: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Sampled transient energies of each channel and their noise spread.

    Parameters
    ----------
    y : ndarray (ny, N)
        Signals (force N, voltage V).
    sigma : ndarray (ny,), optional
        Noise levels; their expectation is removed (None: a noise-free simulation).
    weight : ndarray (N,), optional
        1 where a sample is resolved; differences that touch an unresolved sample
        are left out.

    Returns
    -------
    energies : ndarray (ny, 2)
        e₁ = Σ (Δy)² and e₂ = Σ (Δ²y)², less their noise expectation 2σ² and 6σ² per term.
    spread : ndarray (ny, 2)
        The noise's standard deviation of each energy (√(8 n) σ², √(72 n) σ²), used
        as the floor of the log-ratio.
    """
    y = np.atleast_2d(np.asarray(y, dtype=float))
    ny, N = y.shape
    w = np.ones(N) if weight is None else np.asarray(weight, dtype=float)
    m1 = (w[1:] > 0) & (w[:-1] > 0)
    m2 = m1[1:] & m1[:-1]
    sig = np.zeros(ny) if sigma is None else np.asarray(sigma, dtype=float)
    e = np.empty((ny, 2))
    s = np.empty((ny, 2))
    for ch in range(ny):
        d1 = np.diff(y[ch])[m1]
        d2 = np.diff(y[ch], 2)[m2]
        v2 = sig[ch] ** 2
        e[ch] = (float(d1 @ d1) - 2.0 * d1.size * v2, float(d2 @ d2) - 6.0 * d2.size * v2)
        s[ch] = (math.sqrt(8.0 * max(d1.size, 1)) * v2, math.sqrt(72.0 * max(d2.size, 1)) * v2)
    return e, s


#: A test's kinematic gap is a measurement of the gap only when the rotor rests on a face
#: in the fast windows: the travel D's standard deviation within a window, averaged over
#: the windows, must stay below this share of the gap it gives (a rotor rattling
#: uniformly across a gap b has b/√12 = 0.29 b; resting, the deflection's change only).
#: On a second generator's Hertzian contact the fast triangle strokes gave 0.3-1.2, every
#: other test 0.02-0.10.
GAP_REST_SHARE = 0.25


def kinematic_gap(pt: PreparedTest, harvester, voltage_V: np.ndarray | None = None,
                  fraction: float = 0.8, require_rest: bool = True
                  ) -> tuple[float, float, int]:
    """The play the rotor takes up between strokes, from kinematics alone (m).

    The rotor-equivalent speed is w = r ω with ω = (R i + L di/dt)/K_e, i = V/R_e, so the
    rotor's travel relative to the rod, D(t) = ∫ (w − v) dt, needs no force model.  In
    the fast part of a stroke (|v| above ``fraction`` of its maximum) the rod drives the
    generator through the contact face ahead of it; in the next stroke through the face
    behind it, so the mean of D changes by the gap b plus the contact deflection
    (|f_a| + |f_b|)/k between consecutive fast windows of opposite direction.  Returns
    the mean of that change over the test's window pairs (signed by the direction, m),
    its standard error and the number of pairs (nan, nan, 0 when there is no pair, or,
    with ``require_rest``, when the rotor does not rest on a face in the fast windows:
    :data:`GAP_REST_SHARE`; the data decide whether a test has the feature, a simulation
    of it is then measured as it is).  ``voltage_V`` replaces the measured voltage (e.g.
    by a simulated one).
    """
    h = harvester
    V = pt.y[1] if voltage_V is None else np.asarray(voltage_V, dtype=float)
    t, v = pt.time_s, pt.u[1]
    load = float(pt.fixed["load_ohm"])
    R = load + h.internal_resistance_ohm
    i = V / load
    w = h.lead_m_per_rad * (R * i) / h.voltage_constant_Vs_per_rad
    rel = w - v
    D = np.concatenate([[0.0], np.cumsum(0.5 * (rel[1:] + rel[:-1]) * np.diff(t))])
    D = D + h.lead_m_per_rad * h.inductance_H * (i - i[0]) / h.voltage_constant_Vs_per_rad
    fast = (np.abs(v) > fraction * np.max(np.abs(v))) & (pt.weight > 0)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], fast.astype(int), [0]])))
    wins = [(a, b) for a, b in zip(edges[::2], edges[1::2]) if b - a >= 3]
    vals = []
    for (a0, b0), (a1, b1) in zip(wins[:-1], wins[1:]):
        s0, s1 = np.sign(np.mean(v[a0:b0])), np.sign(np.mean(v[a1:b1]))
        if s0 == s1 or s0 == 0:
            continue
        vals.append(s0 * (np.mean(D[a1:b1]) - np.mean(D[a0:b0])))
    if not vals:
        return math.nan, math.nan, 0
    vals_a = np.asarray(vals)
    within = float(np.mean([np.std(D[a:b]) for a, b in wins]))
    if require_rest and within > GAP_REST_SHARE * abs(float(vals_a.mean())):
        return math.nan, math.nan, 0
    se = float(np.std(vals_a, ddof=1) / math.sqrt(vals_a.size)) if vals_a.size > 1 else math.nan
    return float(vals_a.mean()), se, int(vals_a.size)


#: Relative uncertainty of a rigid baseline's friction levels when the data hold impacts
#: it does not model (each of the nut's and the bearing's levels moved by ± this share to
#: see what it does to each test's features; :func:`~.impacts.fit_impacts` and the
#: held-out verdict, :mod:`.impact_verdict`).
IMPACT_FRICTION_SPREAD = 0.05
#: A test whose log transient energy that uncertainty alone moves by more than this is
#: left out of the contact fit and verdict (it says more about the friction than about
#: the contact).
IMPACT_FRICTION_DOMINATED = 1.0
#: Spread allowed to a log transient energy between model and data (the chaotic
#: redistribution of impacts changes a test's energies by ~5-20 % between tolerances).
ENERGY_LOG_SPREAD = 0.2
#: Relative spread allowed to a kinematic gap feature beyond its standard error.
GAP_SPREAD = 0.02


@dataclass
class FeatureData:
    """The measured features of the tests (:func:`data_features`)."""

    energies: list[np.ndarray]
    spreads: list[np.ndarray]
    gaps: list[tuple[float, float, int]]


#: Samples per block of :func:`quiet_noise_levels`, the quantile of the blocks' noise
#: levels it takes and that quantile's expectation for pure Gaussian noise (white or
#: AR(1) up to 0.9: 0.71 of the level, simulated), which it is divided by.  Where impacts
#: fill a share c of the blocks the quantile is the noise's 0.05/(1 − c) one: 15 % high
#: at c = 0.7, 40 % at c = 0.9.
QUIET_BLOCK, QUIET_QUANTILE, QUIET_BIAS = 50, 0.05, 0.71


def quiet_noise_levels(prepared: Sequence[PreparedTest]) -> np.ndarray:
    """Each channel's noise level (the white-equivalent σ of its second differences) from
    the quietest blocks of the campaign's tests.

    A test's own robust level (the median absolute second difference, ``pt.sigma``) is
    inflated by impacts where the rotor rattles through most of the record (4-30 x the
    sensor's on a second generator's Hertzian contact), and subtracting that inflated
    noise expectation from the data's transient energies, but not from a simulation's,
    biased the data's second-difference energies low by up to 95 % on a slow test.  The
    sensor is the same in every test of a campaign, so its level is taken where the
    record is quiet: the :data:`QUIET_QUANTILE` quantile over all tests' blocks of
    :data:`QUIET_BLOCK` resolved samples of the blocks' robust levels, divided by that
    quantile's expectation for pure noise (:data:`QUIET_BIAS`).  Falls back to the tests'
    smallest own level when there are fewer than twenty blocks."""
    ny = min(pt.y.shape[0] for pt in prepared)
    levels: list[list[float]] = [[] for _ in range(ny)]
    for pt in prepared:
        d2 = np.diff(pt.y[:ny], 2, axis=1)
        ok = (pt.weight[2:] > 0) & (pt.weight[1:-1] > 0) & (pt.weight[:-2] > 0)
        for a in range(0, d2.shape[1] - QUIET_BLOCK + 1, QUIET_BLOCK):
            if not ok[a:a + QUIET_BLOCK].all():
                continue
            blk = d2[:, a:a + QUIET_BLOCK]
            mad = np.median(np.abs(blk - np.median(blk, axis=1, keepdims=True)), axis=1)
            for ch in range(ny):
                levels[ch].append(1.4826 * float(mad[ch]) / math.sqrt(6.0))
    own = np.min([pt.sigma[:ny] for pt in prepared], axis=0)
    if min(len(lv) for lv in levels) < 20:
        return own
    return np.array([float(np.quantile(lv, QUIET_QUANTILE)) / QUIET_BIAS for lv in levels])


def data_features(prepared: Sequence[PreparedTest], harvester) -> FeatureData:
    """The measured features of each test: transient energies (less the noise expectation
    of the campaign's quietest blocks, :func:`quiet_noise_levels`, or the test's own level
    where that is lower), their noise spreads and the kinematic gap."""
    quiet = quiet_noise_levels(prepared) if prepared else np.zeros(0)
    out = [transient_energies(pt.y, np.minimum(pt.sigma[:quiet.size], quiet), pt.weight)
           for pt in prepared]
    gaps = [kinematic_gap(pt, harvester) if pt.y.shape[0] > 1 else (math.nan, math.nan, 0)
            for pt in prepared]
    return FeatureData([e for e, _ in out], [s for _, s in out], gaps)


@dataclass
class Mismatch:
    """Per test: the log-ratios of the simulated to the measured transient energies
    (ny*2,) and the kinematic gap's difference and standard deviation (m; None when the
    test has no window pair)."""

    log_ratios: list[np.ndarray]
    gaps: list[tuple[float, float] | None]


def mismatch(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray], harvester,
             data: FeatureData) -> Mismatch:
    """The simulated features of each test against the data's (:class:`Mismatch`)."""
    lrs: list[np.ndarray] = []
    gaps: list[tuple[float, float] | None] = []
    for pt, yp, e, s, g in zip(prepared, preds, data.energies, data.spreads, data.gaps):
        yp = np.asarray(yp)[: pt.y.shape[0]]
        es, _ = transient_energies(yp, None, pt.weight)
        floor = np.maximum(s, 1e-300)
        lrs.append(np.log((np.maximum(es, 0.0) + floor) / (np.maximum(e, 0.0) + floor)).ravel())
        if g[2] > 0 and yp.shape[0] > 1:
            gs = kinematic_gap(pt, harvester, yp[1], require_rest=False)[0]
            se = g[1] if math.isfinite(g[1]) else 0.0
            sd = math.hypot(se, GAP_SPREAD * abs(g[0])) or 1e-9
            gaps.append((gs - g[0] if math.isfinite(gs) else math.inf, sd))
        else:
            gaps.append(None)
    return Mismatch(lrs, gaps)


def score(m: Mismatch, widen: Sequence[tuple[np.ndarray, float]] | None = None) -> float:
    """Mean squared standardised mismatch; ``widen`` adds, per test, a spread to each log
    energy (in quadrature with :data:`ENERGY_LOG_SPREAD`) and to the gap (m)."""
    terms = []
    for i, (lr, g) in enumerate(zip(m.log_ratios, m.gaps)):
        we, wg = widen[i] if widen is not None else (0.0, 0.0)
        if not np.all(np.isfinite(we)):
            continue  # a test left out (dominated by the friction's uncertainty)
        terms.append(lr / np.hypot(ENERGY_LOG_SPREAD, we))
        if g is not None:
            terms.append(np.array([g[0] / math.hypot(g[1], wg) if math.isfinite(g[0])
                                   else 1e3]))
    t = np.concatenate(terms) if terms else np.zeros(0)
    return float(np.mean(t ** 2)) if t.size else math.nan


def standardised_terms(m: Mismatch, widen: Sequence[tuple[np.ndarray, float]] | None = None
                       ) -> list[np.ndarray | None]:
    """Per test, the standardised mismatches :func:`score` averages (the log energies
    force e₁, e₂, voltage e₁, e₂, then the gap when the test has one); None for a test
    left out.  Shows which tests and features a large objective comes from."""
    out: list[np.ndarray | None] = []
    for i, (lr, g) in enumerate(zip(m.log_ratios, m.gaps)):
        we, wg = widen[i] if widen is not None else (0.0, 0.0)
        if not np.all(np.isfinite(we)):
            out.append(None)
            continue
        z = list(lr / np.hypot(ENERGY_LOG_SPREAD, we))
        if g is not None:
            z.append(g[0] / math.hypot(g[1], wg) if math.isfinite(g[0]) else 1e3)
        out.append(np.asarray(z, dtype=float))
    return out


def impact_objective(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray],
                     harvester, data: FeatureData | None = None) -> float:
    """Mean squared standardised feature mismatch of a simulation (module docstring):
    log-ratios of the transient energies over :data:`ENERGY_LOG_SPREAD`, kinematic gaps
    over their standard error and :data:`GAP_SPREAD`; ≈ 1 or below where the model
    matches the data within the features' own spread."""
    d = data if data is not None else data_features(prepared, harvester)
    return score(mismatch(prepared, preds, harvester, d))


def impact_energy_ratio(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray]) -> float:
    """Measured over simulated force transient energy e₁ summed over the tests: ≫ 1 when
    the data hold impacts that the simulated model (e.g. the rigid baseline) has not."""
    num = den = 0.0
    for pt, yp in zip(prepared, preds):
        e, s = transient_energies(pt.y[:1], pt.sigma[:1], pt.weight)
        es, _ = transient_energies(np.asarray(yp)[:1], None, pt.weight)
        num += max(e[0, 0], 0.0) + s[0, 0]
        den += max(es[0, 0], 0.0) + s[0, 0]
    return float(num / den) if den > 0 else math.inf


def gap_step(m: Mismatch, widen: Sequence[tuple[np.ndarray, float]] | None) -> float:
    """The gap change (m) that brings the simulated kinematic gaps onto the data's: minus
    their mean difference, weighted by the inverse variances (tests left out excluded)."""
    num = den = 0.0
    for i, g in enumerate(m.gaps):
        if g is None or not math.isfinite(g[0]):
            continue
        wg = widen[i][1] if widen is not None else 0.0
        if not math.isfinite(wg):
            continue
        var = g[1] ** 2 + wg ** 2
        num += g[0] / var
        den += 1.0 / var
    return -num / den if den > 0 else math.nan


#: Friction levels of the nut and of the bearing (moved by ``friction_spread``).
NUT_LEVELS = ("nut_breakaway_N", "nut_coulomb_N", "nut_viscous_Ns_per_m")
BEARING_LEVELS = ("bearing_breakaway_Nm", "bearing_coulomb_Nm", "bearing_viscous_Nms_per_rad")


def moved_friction(p: Mapping[str, float], names: Sequence[str], factor: float
                   ) -> dict[str, float]:
    """``p`` with the friction levels ``names`` multiplied by ``factor``."""
    out = dict(p)
    for n in names:
        out[n] = factor * float(p[n])
    return out


def friction_widening(centre: Mismatch, moved: Sequence[Mismatch]
                       ) -> list[tuple[np.ndarray, float]]:
    """Per test: the largest change of each log energy and of the gap (m) between the
    centre and the moved-friction simulations (the range, not an rms: near a threshold
    the response to the friction is not Gaussian, and four members undersample it)."""
    out = []
    for i, lr0 in enumerate(centre.log_ratios):
        d = np.array([m.log_ratios[i] - lr0 for m in moved])
        we = np.max(np.abs(d), axis=0)
        g0 = centre.gaps[i]
        dg = [m.gaps[i][0] - g0[0] for m in moved if g0 is not None and m.gaps[i] is not None
              and math.isfinite(m.gaps[i][0]) and math.isfinite(g0[0])]
        wg = float(np.max(np.abs(dg))) if dg else 0.0
        out.append((we, wg))
    return out
