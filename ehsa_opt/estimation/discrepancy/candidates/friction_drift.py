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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from ..channels import channel_effective_samples
from ..evidence import delta_bic, force_error_percent, normalised_sse
from ..campaign_travel import campaign_travel_m, run_order_known, travel_coordinates
from ..prepared import PreparedTest

__all__ = ["FrictionDrift", "run_order_known", "travel_coordinates", "fit_drift",
           "SPAN_SHARES", "SMOOTHING_M_PER_S"]

#: Run-in distances s₀ tried, as shares of the campaign's total sliding distance: from a
#: run-in within the first tenth of the campaign to one that is still linear at its end
#: (s₀ three times the campaign's travel).
SPAN_SHARES: tuple[float, ...] = (0.1, 0.3, 1.0, 3.0)
#: Velocity scale of the Coulomb column tanh(v/u), m/s (the static map's smoothing, a
#: tenth of a breakaway velocity of a few mm/s).
SMOOTHING_M_PER_S = 1e-3


def _columns(pt: PreparedTest, coords: dict, s0: float) -> np.ndarray:
    c = np.tanh(pt.u[1] / SMOOTHING_M_PER_S)
    return np.column_stack([(1.0 - np.exp(-campaign_travel_m(pt, coords) / s0)) * c, c])


def fit_drift(pts, preds, coords: dict, s0: float) -> tuple[np.ndarray, float, np.ndarray]:
    """The amplitudes (drift a, N; Coulomb shift, N) at run-in distance ``s0`` (m) on the
    force residual of ``preds``, the weighted SSE and the amplitudes' covariance (per
    effective sample of the residual)."""
    Xs, rs = [], []
    for pt, yp in zip(pts, preds):
        w = pt.wnorm[0]
        Xs.append(_columns(pt, coords, s0) * w[:, None])
        rs.append((pt.y[0] - yp[0]) * w)
    X, r = np.vstack(Xs), np.concatenate(rs)
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    res = r - X @ coef
    sse = float(res @ res)
    try:
        cov = np.linalg.inv(X.T @ X) * sse / max(_n_eff(pts, preds, coords, s0, coef) - 2, 1.0)
    except np.linalg.LinAlgError:
        cov = np.full((2, 2), np.inf)
    return coef, sse, cov


def _n_eff(pts, preds, coords, s0, coef) -> float:
    return float(channel_effective_samples(pts, _apply(pts, preds, coords, s0, coef))[0])


def _apply(pts, preds, coords, s0, coef) -> list[np.ndarray]:
    out = []
    for pt, yp in zip(pts, preds):
        y = np.array(yp, dtype=float, copy=True)
        y[0] = y[0] + _columns(pt, coords, s0) @ coef
        out.append(y)
    return out


@dataclass
class FrictionDrift:
    """The campaign's friction drift (see the module docstring).

    Attributes
    ----------
    run_in_m : float
        The run-in distance s₀, m.
    amplitude_N : float
        The level change a at the end of the run-in, N (negative: the friction falls).
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

    run_in_m: float = math.nan
    amplitude_N: float = math.nan
    interval_N: tuple[float, float] = (math.nan, math.nan)
    total_travel_m: float = math.nan
    error_before: float = math.nan
    error_after: float = math.nan
    delta_bic_fit: float = math.nan
    delta_bic_heldout: float = math.nan
    adopted: bool = False
    _coords: dict = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def fit(cls, fit_pts, fit_pred, held_pts, held_pred, n_eff_fit: float,
            n_eff_held: float) -> FrictionDrift:
        """The drift fitted on the baseline's fit-test residual and its evidence."""
        coords = travel_coordinates(list(fit_pts) + list(held_pts))
        total = max(float(max(c[1][-1] for c in coords.values())), 1e-9)
        best = None
        for share in SPAN_SHARES:
            coef, sse, cov = fit_drift(fit_pts, fit_pred, coords, share * total)
            if best is None or sse < best[1]:
                best = (share * total, sse, coef, cov)
        # the run-in distance refined between the grid's neighbours (a bounded scalar
        # search of the variable-projection SSE over log s₀)
        lo, hi = math.log(best[0] / 3.0), math.log(best[0] * 3.0)
        opt = minimize_scalar(lambda ls: fit_drift(fit_pts, fit_pred, coords, math.exp(ls))[1],
                              bounds=(lo, hi), method="bounded",
                              options={"xatol": 0.01})
        if opt.success and opt.fun < best[1]:
            s0 = math.exp(float(opt.x))
            coef, sse, cov = fit_drift(fit_pts, fit_pred, coords, s0)
            best = (s0, sse, coef, cov)
        s0, _, coef, cov = best
        sd = math.sqrt(max(float(cov[0, 0]), 0.0))
        law = cls(run_in_m=s0, amplitude_N=float(coef[0]),
                  interval_N=(float(coef[0]) - 1.96 * sd, float(coef[0]) + 1.96 * sd),
                  total_travel_m=total, _coords=coords)
        pf = _apply(fit_pts, fit_pred, coords, s0, coef)
        law.delta_bic_fit = delta_bic(normalised_sse(fit_pts, pf),
                                      normalised_sse(fit_pts, fit_pred), 2, n_eff_fit)
        if held_pts:
            ph = _apply(held_pts, held_pred, coords, s0, coef)
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
    def change_over_campaign_N(self) -> float:
        """The level change from the campaign's first to its last sample, a (1 − exp(−S/s₀)),
        N (better determined than a and s₀ apart, which trade against each other)."""
        return self.amplitude_N * (1.0 - math.exp(-self.total_travel_m / self.run_in_m))

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
        coords = self._coords
        coef, _, _ = fit_drift(fit_pts, fit_pred, coords, self.run_in_m)
        return (_apply(fit_pts, fit_pred, coords, self.run_in_m, coef),
                _apply(held_pts, held_pred, coords, self.run_in_m, coef) if held_pred else [])

    def as_dict(self) -> dict:
        return {"run_in_m": self.run_in_m, "amplitude_N": self.amplitude_N,
                "change_over_campaign_N": self.change_over_campaign_N,
                "interval_N": list(self.interval_N), "total_travel_m": self.total_travel_m,
                "error_before": self.error_before, "error_after": self.error_after,
                "delta_bic_fit": self.delta_bic_fit,
                "delta_bic_heldout": self.delta_bic_heldout, "adopted": self.adopted}
