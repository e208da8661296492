"""Member ``friction_drift``: a friction level that drifts over the campaign as the rig
runs in (grease warming, running-in of the contacts).

The Coulomb level of a ball screw falls as its grease warms: the heat is the friction's
work, and for a Coulomb friction that work is F_C times the distance slid.  The drift
coordinate is therefore the rod's *cumulative sliding distance* over the campaign, in the
order the tests were run (the bench format's ``run_order``): s(t) = Σ over the tests run
before of their travel + the travel of this test up to t.  A first-order run-in is

    ΔF(t) = a (1 − exp(−s(t)/s₀)) tanh(v/u),

a level change a (N) reached over a sliding distance s₀ (m).  The current model's
Coulomb level is the campaign's average, so the column is fitted beside a free Coulomb
column tanh(v/u) (the base law's own level, re-estimated): the drift is what differs
between the tests run early and late.  Fitted by variable projection: for each s₀ on a
grid spanning the campaign's total travel S (:data:`SPAN_SHARES` × S) the two
amplitudes by weighted least squares on the fit tests' force residual of the model
judged; the s₀ with the least SSE is refined by a bounded search between its grid
neighbours.  Every model the search judges after it is
adopted carries its own such term (:meth:`FrictionDrift.correct`), fitted on its own
fit-test residual and applied to its held-out tests — the held-out tests, run at other
times of the campaign, judge the law.

Not applicable when a test of the campaign does not state its run order (without it a
drift cannot be told from the tests' order along the stroke or the load).

A run-in is not the only drift: the grease also *warms* with the friction's power and
cools in the pauses between tests (a first-order thermal mass, as the joint temperature
of Simoni, Beschi, Legnani & Visioli 2017, Robotica, doi:10.1017/S0263574717000509), and
a warmer grease carries a lower friction.  The second law of the member is therefore

    ΔF(t) = a h_τ(t)/max h_τ tanh(v/u),

h_τ the heating coordinate (:func:`~..campaign_travel.heating_coordinates`: the sliding
distance forgotten with time constant τ, cooled over the pauses the tests' ``started_at``
stamps give), a the level change at the campaign's hottest point.  Both laws have two
parameters (a and s₀ or τ); each is fitted over its grid (s₀: :data:`SPAN_SHARES` of the
total travel, τ: the same shares of the campaign's duration) and refined, and the one
with the lower fit-test SSE is the member's law (:data:`DRIFT_LAWS`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from ..channels import channel_effective_samples
from ..evidence import delta_bic, force_error_percent, normalised_sse
from ..campaign_travel import (campaign_duration_s, campaign_travel_m, heating_coordinates,
                               pauses_known, run_order_known, travel_coordinates)
from ..prepared import PreparedTest

__all__ = ["FrictionDrift", "run_order_known", "travel_coordinates", "fit_drift",
           "drift_shape", "SPAN_SHARES", "SMOOTHING_M_PER_S", "DRIFT_LAWS"]

#: Run-in distances s₀ tried, as shares of the campaign's total sliding distance: from a
#: run-in within the first tenth of the campaign to one that is still linear at its end
#: (s₀ three times the campaign's travel).
SPAN_SHARES: tuple[float, ...] = (0.1, 0.3, 1.0, 3.0)
#: Velocity scale of the Coulomb column tanh(v/u), m/s (the static map's smoothing, a
#: tenth of a breakaway velocity of a few mm/s).
SMOOTHING_M_PER_S = 1e-3
#: The member's two drift laws: ``run_in`` over the sliding distance (scale s₀, m) and
#: ``thermal`` over the heating coordinate (scale τ, s).
DRIFT_LAWS: tuple[str, ...] = ("run_in", "thermal")


def drift_shape(law: str, pts, scale: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The drift's shape g in [0, 1] by test file, (time stamps, g): ``run_in``
    1 − exp(−s/s₀) with s₀ = ``scale`` (m); ``thermal`` h_τ/max h_τ with τ = ``scale`` (s)."""
    if law == "run_in":
        return {f: (t, 1.0 - np.exp(-s / scale))
                for f, (t, s) in travel_coordinates(pts).items()}
    if law == "thermal":
        h = heating_coordinates(pts, scale)
        top = max(max(float(np.max(v)) for _, v in h.values()), 1e-300)
        return {f: (t, v / top) for f, (t, v) in h.items()}
    raise ValueError(f"drift_shape: law {law!r} is not one of {', '.join(DRIFT_LAWS)}")


def _columns(pt: PreparedTest, shape: dict) -> np.ndarray:
    c = np.tanh(pt.u[1] / SMOOTHING_M_PER_S)
    return np.column_stack([campaign_travel_m(pt, shape) * c, c])


def fit_drift(pts, preds, shape: dict) -> tuple[np.ndarray, float, np.ndarray]:
    """The amplitudes (drift a, N; Coulomb shift, N) of the drift ``shape``
    (:func:`drift_shape`) on the force residual of ``preds``, the weighted SSE and the
    amplitudes' covariance (per effective sample of the residual)."""
    Xs, rs = [], []
    for pt, yp in zip(pts, preds):
        w = pt.wnorm[0]
        Xs.append(_columns(pt, shape) * w[:, None])
        rs.append((pt.y[0] - yp[0]) * w)
    X, r = np.vstack(Xs), np.concatenate(rs)
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    res = r - X @ coef
    sse = float(res @ res)
    try:
        cov = np.linalg.inv(X.T @ X) * sse / max(_n_eff(pts, preds, shape, coef) - 2, 1.0)
    except np.linalg.LinAlgError:
        cov = np.full((2, 2), np.inf)
    return coef, sse, cov


def _n_eff(pts, preds, shape, coef) -> float:
    return float(channel_effective_samples(pts, _apply(pts, preds, shape, coef))[0])


def _apply(pts, preds, shape, coef) -> list[np.ndarray]:
    out = []
    for pt, yp in zip(pts, preds):
        y = np.array(yp, dtype=float, copy=True)
        y[0] = y[0] + _columns(pt, shape) @ coef
        out.append(y)
    return out


@dataclass
class FrictionDrift:
    """The campaign's friction drift (see the module docstring).

    Attributes
    ----------
    law : str
        ``run_in`` or ``thermal`` (:data:`DRIFT_LAWS`).
    run_in_m : float
        The run-in distance s₀, m (``run_in``; NaN otherwise).
    time_constant_s : float
        The thermal time constant τ, s (``thermal``; NaN otherwise).
    pauses_known : bool
        The tests' ``started_at`` stamps gave the pauses between them (``thermal``;
        otherwise the tests were taken back to back).
    amplitude_N : float
        The level change a at the end of the run-in or at the campaign's hottest point, N
        (negative: the friction falls).
    change_over_campaign_N : float
        The level change from the campaign's first to its last sample, N (better
        determined than a and the scale apart, which trade against each other).
    interval_N : tuple of float
        Its ~95 % interval, N.
    total_travel_m : float
        The campaign's total sliding distance S, m.
    error_before, error_after : float
        Evaluation-test relative force error without / with the term, %.
    delta_bic_fit, delta_bic_heldout : float
        ΔBIC of the term (two parameters charged: a and s₀).
    adopted : bool
        Every model judged carries its own term.
    """

    law: str = "run_in"
    run_in_m: float = math.nan
    time_constant_s: float = math.nan
    pauses_known: bool = False
    amplitude_N: float = math.nan
    change_over_campaign_N: float = math.nan
    interval_N: tuple[float, float] = (math.nan, math.nan)
    total_travel_m: float = math.nan
    error_before: float = math.nan
    error_after: float = math.nan
    delta_bic_fit: float = math.nan
    delta_bic_heldout: float = math.nan
    adopted: bool = False
    _shape: dict = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def fit(cls, fit_pts, fit_pred, held_pts, held_pred, n_eff_fit: float,
            n_eff_held: float) -> FrictionDrift:
        """The drift fitted on the baseline's fit-test residual, the law of the lower SSE
        (:data:`DRIFT_LAWS`), and its evidence."""
        every = list(fit_pts) + list(held_pts)
        coords = travel_coordinates(every)
        total = max(float(max(c[1][-1] for c in coords.values())), 1e-9)
        spans = {"run_in": total, "thermal": max(campaign_duration_s(every), 1e-9)}
        best = None
        for law_name in DRIFT_LAWS:
            one = _fit_scale(law_name, every, fit_pts, fit_pred, spans[law_name])
            if best is None or one[2] < best[2]:
                best = one
        law_name, scale, _, coef, cov, shape = best
        sd = math.sqrt(max(float(cov[0, 0]), 0.0))
        last = _in_order_last(every)
        g_end = float(campaign_travel_m(last, shape)[-1])
        law = cls(law=law_name,
                  run_in_m=scale if law_name == "run_in" else math.nan,
                  time_constant_s=scale if law_name == "thermal" else math.nan,
                  pauses_known=pauses_known(every), amplitude_N=float(coef[0]),
                  change_over_campaign_N=float(coef[0]) * g_end,
                  interval_N=(float(coef[0]) - 1.96 * sd, float(coef[0]) + 1.96 * sd),
                  total_travel_m=total, _shape=shape)
        pf = _apply(fit_pts, fit_pred, shape, coef)
        law.delta_bic_fit = delta_bic(normalised_sse(fit_pts, pf),
                                      normalised_sse(fit_pts, fit_pred), 2, n_eff_fit)
        if held_pts:
            ph = _apply(held_pts, held_pred, shape, coef)
            ev, e0, e1 = held_pts, held_pred, ph
            law.delta_bic_heldout = delta_bic(normalised_sse(held_pts, ph),
                                              normalised_sse(held_pts, held_pred), 2,
                                              n_eff_held)
        else:
            ev, e0, e1 = fit_pts, fit_pred, pf
            law.delta_bic_heldout = law.delta_bic_fit
        law.error_before = force_error_percent(ev, e0)
        law.error_after = force_error_percent(ev, e1)
        return law

    @property
    def resolved(self) -> bool:
        """The level change's interval excludes zero."""
        lo, hi = self.interval_N
        return lo > 0 or hi < 0

    def correct(self, fit_pts, fit_pred, held_pts, held_pred
                ) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """A model's predictions with its own drift term (amplitudes fitted on its
        fit-test residual at the adopted run-in distance); unchanged when not adopted."""
        if not self.adopted or not fit_pred:
            return list(fit_pred), list(held_pred)
        shape = self._shape
        coef, _, _ = fit_drift(fit_pts, fit_pred, shape)
        return (_apply(fit_pts, fit_pred, shape, coef),
                _apply(held_pts, held_pred, shape, coef) if held_pred else [])

    def as_dict(self) -> dict:
        return {"law": self.law, "run_in_m": self.run_in_m,
                "time_constant_s": self.time_constant_s, "pauses_known": self.pauses_known,
                "amplitude_N": self.amplitude_N,
                "change_over_campaign_N": self.change_over_campaign_N,
                "interval_N": list(self.interval_N), "total_travel_m": self.total_travel_m,
                "error_before": self.error_before, "error_after": self.error_after,
                "delta_bic_fit": self.delta_bic_fit,
                "delta_bic_heldout": self.delta_bic_heldout, "adopted": self.adopted}


def _in_order_last(pts) -> PreparedTest:
    """The test run last (by ``run_order``, else ``started_at``)."""
    if all(getattr(pt.test, "run_order", None) is not None for pt in pts):
        return max(pts, key=lambda pt: pt.test.run_order)
    return max(pts, key=lambda pt: pt.test.started_at)


def _fit_scale(law: str, every, fit_pts, fit_pred, span: float) -> tuple:
    """One law fitted over its grid of scales (:data:`SPAN_SHARES` × ``span``) and refined
    between the best one's neighbours by a bounded search of the variable-projection
    SSE over log scale: (law, scale, sse, amplitudes, covariance, shape)."""
    best = None
    for share in SPAN_SHARES:
        shape = drift_shape(law, every, share * span)
        coef, sse, cov = fit_drift(fit_pts, fit_pred, shape)
        if best is None or sse < best[2]:
            best = (law, share * span, sse, coef, cov, shape)
    lo, hi = math.log(best[1] / 3.0), math.log(best[1] * 3.0)
    opt = minimize_scalar(
        lambda ls: fit_drift(fit_pts, fit_pred, drift_shape(law, every, math.exp(ls)))[1],
        bounds=(lo, hi), method="bounded", options={"xatol": 0.01})
    if opt.success and opt.fun < best[2]:
        scale = math.exp(float(opt.x))
        shape = drift_shape(law, every, scale)
        coef, sse, cov = fit_drift(fit_pts, fit_pred, shape)
        best = (law, scale, sse, coef, cov, shape)
    return best
