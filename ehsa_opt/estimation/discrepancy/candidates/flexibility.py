"""The flexibility candidate of a rig without generator, fitted by variable projection.

The two-mass model (:class:`~ehsa_opt.physics.components.Flexibility`) adds to the
measured force F_extra = −m · s²/(s² + 2ζωs + ω²) applied to the measured
acceleration — linear in the load mass m for a given resonance (f, ζ).  The rigid
model of a rig without generator is linear in M, F_0 and the friction levels at
fixed velocities too, so the refit of the current model with a flexibility is a
linear least-squares problem for each (f, ζ): the columns a rigid refit absorbs
(:func:`~.catalogue.absorbed_columns`) plus the flexibility column, on the fit
tests.  The resonance is searched on a grid (log-spaced frequencies around the
fit residual's spectral peak, a few damping ratios), m ≥ 0 (a negative mass is no
flexibility).  This costs milliseconds per grid point where the forward simulation
of the state model costs ~10 s per EMPS record; the two agree to the
discretisation (zero-order hold of the sampled acceleration).

The result is judged by the same rule as every candidate (held-out ΔBIC with N_eff,
the excess removed in total or per block, a resolved mass with its Newey–West
interval).
"""

from __future__ import annotations

import math
import time
from typing import Sequence

import numpy as np
from scipy.signal import cont2discrete, lfilter

from ...covariance import hac_covariance
from ...fit_result import FitResult
from ..prepared import PreparedTest
from ..rig import Rig
from .catalogue import absorbed_columns, compatible

__all__ = ["flexibility_column", "fit_flexibility", "fit_flexibility_member",
           "flexibility_refusal", "FREQUENCIES_HZ", "DAMPING_RATIOS"]

#: Coarse resonance grid (Hz) and damping ratios searched; the best coarse point (and
#: the residual's spectral peak) are then refined on a finer local grid
#: (:data:`FINE_STEPS`, :data:`FINE_DAMPING_STEPS`) and by Nelder–Mead.
FREQUENCIES_HZ = tuple(float(f) for f in np.geomspace(5.0, 450.0, 13))
DAMPING_RATIOS = (0.03, 0.1, 0.3, 1.0)
#: Local refinement: frequency factors and damping factors around a coarse point.
FINE_STEPS = tuple(float(x) for x in np.geomspace(0.75, 1.33, 5))
FINE_DAMPING_STEPS = (0.5, 1.0, 2.0)


def flexibility_column(pt: PreparedTest, frequency_hz: float, damping_ratio: float
                       ) -> np.ndarray:
    """F_extra per kg of load mass: −s²/(s² + 2ζωs + ω²) of the test's acceleration
    (zero-order hold on the sample grid, from rest; through the measurement's parallel
    low-pass, as every model output), N/kg."""
    dt = float(np.median(np.diff(pt.time_s)))
    w = 2 * math.pi * frequency_hz
    num, den = [1.0, 0.0, 0.0], [1.0, 2 * damping_ratio * w, w * w]
    b, a, _ = cont2discrete((num, den), dt, method="zoh")
    return -pt.filter_output(lfilter(np.ravel(b), a, pt.u[2]))


def _design(pts: Sequence[PreparedTest], rig: Rig, u_brk: float, f: float, z: float,
            B: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(absorbed columns, flexibility column) of the force channel, σ-normalised
    (``B``: the absorbed columns when already built — they do not depend on f, ζ)."""
    if B is None:
        B = np.vstack([absorbed_columns(pt, rig, u_brk)[:pt.y.shape[1]] for pt in pts])
    g = np.concatenate([flexibility_column(pt, f, z) / pt.sigma[0] for pt in pts])
    return B, g


def _grid_search(fit_pts: Sequence[PreparedTest], B0: np.ndarray, r: np.ndarray,
                 start_hz: float | None) -> tuple[tuple | None, tuple | None]:
    """The best physical (m ≥ 0) and the best unconstrained (m < 0) resonance as
    (SSE, f, ζ, m): a coarse grid and the residual's spectral peak, then a finer grid
    around each of the two."""
    # the absorbed columns projected out once: each (f, ζ) is then a one-column fit
    Qb, _ = np.linalg.qr(B0)
    r_perp = r - Qb @ (Qb.T @ r)
    sse_b = float(r_perp @ r_perp)
    best, best_neg, seen = None, None, set()

    def visit(f: float, z: float) -> None:
        nonlocal best, best_neg
        key = (round(f, 6), round(z, 6))
        if key in seen or not (1.0 <= f <= 2000.0 and 1e-3 <= z <= 5.0):
            return
        seen.add(key)
        g = np.concatenate([flexibility_column(pt, f, z) / pt.sigma[0] for pt in fit_pts])
        g_perp = g - Qb @ (Qb.T @ g)
        gg = float(g_perp @ g_perp)
        if gg <= 0:
            return
        m = float(g_perp @ r_perp) / gg
        sse = sse_b - m * m * gg
        if m < 0:
            if best_neg is None or sse < best_neg[0]:
                best_neg = (sse, f, z, m)
            return
        if best is None or sse < best[0]:
            best = (sse, f, z, m)

    starts = list(FREQUENCIES_HZ)
    if start_hz is not None and math.isfinite(start_hz):
        starts.append(float(start_hz))
    for f in starts:
        for z in DAMPING_RATIOS:
            visit(f, z)
    for anchor in [b for b in (best, best_neg) if b is not None]:
        for k in FINE_STEPS:
            for q in FINE_DAMPING_STEPS:
                visit(anchor[1] * k, anchor[2] * q)
    return best, best_neg


def fit_flexibility(fit_pts: Sequence[PreparedTest], fit_pred: Sequence[np.ndarray],
                    eval_pts: Sequence[PreparedTest], eval_pred: Sequence[np.ndarray],
                    rig: Rig, params: dict[str, float], start_hz: float | None = None
                    ) -> dict:
    """The best flexibility on the fit tests and its predictions everywhere.

    Parameters
    ----------
    fit_pts, fit_pred, eval_pts, eval_pred :
        Tests and the current model's outputs (force channel used).
    rig : Rig
        The current rig (without generator).
    params : dict
        The current parameters (the breakaway velocity of the absorbed columns).
    start_hz : float, optional
        The residual's spectral peak: the grid is refined around it.

    Returns
    -------
    dict with ``parameters`` (flex_load_mass_kg, flex_frequency_hz,
    flex_damping_ratio, and the derived stiffness and damping), ``intervals``
    (Newey–West ≈95 % of the mass and of the stiffness), ``fit_pred`` and
    ``eval_pred`` (outputs of the model with the flexibility, same layout as the
    inputs), ``negative_mass`` (the unconstrained best mass was < 0: the data
    ask for the opposite of a flexibility), ``covariance_info``.
    """
    if rig.has_generator:
        raise ValueError("fit_flexibility: for a rig without generator (a generator bench's "
                         "elastic transmission is the compliance candidate)")
    u_brk = float(params.get("nut_breakaway_velocity_m_per_s", 0.01))
    r = np.concatenate([(pt.y[0] - yp[0]) / pt.sigma[0] for pt, yp in zip(fit_pts, fit_pred)])
    B0 = np.vstack([absorbed_columns(pt, rig, u_brk)[:pt.y.shape[1]] for pt in fit_pts])
    best, best_neg = _grid_search(fit_pts, B0, r, start_hz)
    if best is not None:
        B, g = _design(fit_pts, rig, u_brk, best[1], best[2], B0)
        coef, *_ = np.linalg.lstsq(np.column_stack([B, g]), r, rcond=None)
        best = (best[0], best[1], best[2], coef)
    if best is None:  # every resonance asks for a negative mass
        return {"parameters": {}, "negative_mass": True,
                "best_negative": {"flex_frequency_hz": best_neg[1],
                                  "flex_damping_ratio": best_neg[2],
                                  "flex_load_mass_kg": best_neg[3]} if best_neg else None}
    # refine the resonance continuously from the best grid point (variable projection:
    # the mass and the rigid refit are the linear solution at each (f, ζ))
    from scipy.optimize import minimize

    def vp(q: np.ndarray) -> float:
        f_, z_ = float(np.exp(q[0])), float(np.exp(q[1]))
        B_, g_ = _design(fit_pts, rig, u_brk, f_, z_, B0)
        X_ = np.column_stack([B_, g_])
        c_, *_ = np.linalg.lstsq(X_, r, rcond=None)
        if c_[-1] < 0:
            return best[0] * (1 + 1e-9) + 1.0  # outside the physical set
        return float(np.sum((r - X_ @ c_) ** 2))

    opt = minimize(vp, np.log([best[1], best[2]]), method="Nelder-Mead",
                   options={"xatol": 1e-3, "fatol": 1e-9 * best[0], "maxfev": 40})
    f, z = best[1], best[2]
    if opt.fun < best[0]:
        f = float(np.clip(np.exp(opt.x[0]), 1.0, 2000.0))
        z = float(np.clip(np.exp(opt.x[1]), 1e-3, 5.0))
    B, g = _design(fit_pts, rig, u_brk, f, z, B0)
    X = np.column_stack([B, g])
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    res = r - X @ coef
    h = hac_covariance(X, res, groups=[pt.y.shape[1] for pt in fit_pts])
    m = float(coef[-1])
    sd = math.sqrt(max(h.cov[-1, -1], 0.0))
    w = 2 * math.pi * f

    def outputs(pts, preds):
        Bp, gp = _design(pts, rig, u_brk, f, z)
        corr = (Bp @ coef[:-1] + gp * m)
        out, pos = [], 0
        for pt, yp in zip(pts, preds):
            n = pt.y.shape[1]
            y = np.array(yp, dtype=float, copy=True)
            y[0] = y[0] + corr[pos:pos + n] * pt.sigma[0]
            out.append(y)
            pos += n
        return out

    k = m * w * w
    return {"parameters": {"flex_load_mass_kg": m, "flex_frequency_hz": f,
                           "flex_damping_ratio": z, "flex_stiffness_N_per_m": k,
                           "flex_damping_Ns_per_m": 2 * z * m * w},
            "intervals": {"flex_load_mass_kg": (m - 1.96 * sd, m + 1.96 * sd),
                          "flex_stiffness_N_per_m": ((m - 1.96 * sd) * w * w,
                                                     (m + 1.96 * sd) * w * w)},
            "fit_pred": outputs(fit_pts, fit_pred),
            "eval_pred": outputs(eval_pts, eval_pred) if eval_pts else [],
            "negative_mass": bool(best_neg is not None and best_neg[0] < best[0]),
            "best_negative": ({"flex_frequency_hz": best_neg[1], "flex_damping_ratio": best_neg[2],
                               "flex_load_mass_kg": best_neg[3]} if best_neg else None),
            "covariance_info": {"method": h.method, "n_eff": h.n_eff, "n": h.n,
                                "bandwidth_samples": h.bandwidth}}


def fit_flexibility_member(fit_pts, cur_fit, held_pts, cur_held, cur_rig, cur_params, comps,
                           scores) -> tuple | None:
    """The flexibility of a rig without generator fitted by variable projection
    (:func:`fit_flexibility`), as the ``(name, FitResult, fit outputs, held-out outputs,
    rig)`` a generic re-identification returns; its score (share of the fit residual
    explained) set in ``scores``.  None when it cannot join the rig."""
    comp = comps["flexibility"]
    if not compatible(cur_rig, comp):
        return None
    t0 = time.perf_counter()
    out = fit_flexibility(fit_pts, cur_fit, held_pts, cur_held, cur_rig, cur_params,
                          start_hz=comp.frequency_hz)
    r0 = sum(float(np.sum(((pt.y[0] - yp[0]) / pt.sigma[0]) ** 2))
             for pt, yp in zip(fit_pts, cur_fit))
    crig = cur_rig.with_components([*cur_rig.components, comp])
    n_obs = sum(pt.y.shape[1] for pt in fit_pts)
    if not out["parameters"]:
        neg = out.get("best_negative") or {}
        scores["flexibility"] = {"score": 0.0, "chi2": 0.0, "columns": 1, "applicable": True}
        res = FitResult(success=False, message="variable projection: every resonance asks "
                        f"for a negative load mass (best "
                        f"{neg.get('flex_load_mass_kg', math.nan):.3g} kg at "
                        f"{neg.get('flex_frequency_hz', math.nan):.3g} Hz): no flexibility",
                        objective=math.inf, seconds=time.perf_counter() - t0,
                        path="variable_projection", sse=math.inf, n_obs=n_obs)
        return ("flexibility", res, [], [], crig)
    r1 = sum(float(np.sum(((pt.y[0] - yp[0]) / pt.sigma[0]) ** 2))
             for pt, yp in zip(fit_pts, out["fit_pred"]))
    scores["flexibility"] = {"score": max(0.0, 1.0 - r1 / r0) if r0 > 0 else 0.0,
                             "chi2": max(r0 - r1, 0.0), "columns": 1, "applicable": True}
    fp = out["parameters"]
    lo, hi = out["intervals"]["flex_load_mass_kg"]
    sd = (hi - lo) / (2 * 1.96)
    params = {**cur_params, **{k: fp[k] for k in ("flex_load_mass_kg", "flex_frequency_hz",
                                                  "flex_damping_ratio")}}
    note = (f"variable projection: resonance {fp['flex_frequency_hz']:.3g} Hz, damping ratio "
            f"{fp['flex_damping_ratio']:.2g}, stiffness {fp['flex_stiffness_N_per_m']:.3g} N/m"
            + ("; the unconstrained best asks for a negative load mass "
               f"({out['best_negative']['flex_load_mass_kg']:.3g} kg at "
               f"{out['best_negative']['flex_frequency_hz']:.3g} Hz)"
               if out.get("negative_mass") else ""))
    res = FitResult(success=True, message=note, parameters=params,
                    free=["flex_load_mass_kg"], objective=r1 / n_obs,
                    records={"flexibility": {k: v for k, v in out.items()
                                             if k not in ("fit_pred", "eval_pred")}},
                    seconds=time.perf_counter() - t0, path="variable_projection", sse=r1,
                    n_obs=n_obs, covariance=np.array([[sd * sd]]),
                    covariance_info=out.get("covariance_info"))
    return ("flexibility", res, out["fit_pred"], out["eval_pred"], crig)



def flexibility_refusal(cand, fit, rnd: int) -> str:
    """Why the two-mass flexibility (``cand``, its variable-projection ``fit``) is not
    named, in words."""
    info = fit.records.get("flexibility", {}) if fit is not None else {}
    neg = info.get("best_negative") or {}
    p = cand.parameters
    msg = (f"round {rnd}: the two-mass flexibility is not named — its physical best "
           + (f"(load mass {p['flex_load_mass_kg']:.3g} kg ≥ 0 at {p['flex_frequency_hz']:.3g} "
              f"Hz, stiffness {p.get('flex_stiffness_N_per_m', math.nan):.3g} N/m) takes "
              f"the error {cand.error_before:.3f} -> {cand.error_after:.3f} %"
              if p else f"does not exist ({fit.message if fit is not None else ''})"))
    if info.get("negative_mass"):
        msg += (f"; the unconstrained best asks for a negative load mass "
                f"({neg.get('flex_load_mass_kg', math.nan):.3g} kg at "
                f"{neg.get('flex_frequency_hz', math.nan):.3g} Hz): the recorded force leads the "
                f"measured motion, whereas a load behind a spring, with the position measured "
                f"on the driven side, makes it lag")
    return msg
