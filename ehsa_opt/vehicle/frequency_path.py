"""Quarter-car metrics (paper Eqs 6–9) and their exact frequency-domain evaluation.

Metrics (paper Eqs 6–9)::

    comfort         α    = rms(W_k ẍ2) / g
    road holding    η_rh = rms(k1 (x1 − x0)) / (g (m1 + m2))
    power           ρ_g  = mean(V_g² / R_e) / (g (m1 + m2) V)
    efficiency      η_g  = mean(V_g² / R_e) / mean(f_d v − reversible inertial power)

:func:`linear_metrics` evaluates them exactly for the linear (frictionless)
quarter car (paper §4) with the harvester's complex impedance (paper Eqs 1–3
without the ω-freezing: Z(jω) = jω m_eq + K_t K_e / (r² (R + jω L_i))) on the
ISO 8608 road PSD, vectorised over any number of designs at once.

Frequency grid.  Every output variance is ∫ |H(f)|² Φ df with Φ the (white)
road-velocity PSD.  Each design is integrated on a shared log-spaced grid plus
two per-design refinements around its lightly damped modes (points
f_d + σ tan φ, φ uniform, where f_d and σ are the damped frequency and decay of
each complex mode of the 2-DOF system, found by a batched 4×4 eigenvalue
computation), so narrow resonances of weakly damped designs (e.g. R_e → 10 kΩ)
are integrated accurately.  Trapezoidal rule on the sorted union.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable, Mapping

import numpy as np
from numpy.typing import ArrayLike

from ..physics.harvester import equivalent_impedance
from ..physics.params import (
    HarvesterParams,
    ParameterError,
    RoadParams,
    VehicleParams,
    check_keys,
)
from .iso2631 import wk_abs2
from .road import ROAD_BAND_CYCLES_PER_M, dissipation_bound_W, road_velocity_psd

__all__ = ["G", "METRIC_KEYS", "DESIGN_KEYS", "design_arrays", "linear_metrics",
           "dimensionless_power", "efficiency_bound", "linear_frequency_response"]

#: Standard gravity, m/s².
G = 9.80665

#: Keys returned by :func:`linear_metrics` (and by the time-domain path).
METRIC_KEYS: tuple[str, ...] = (
    "comfort", "comfort_weighted_rms_m_s2", "road_holding", "power_W", "power_dimensionless",
    "efficiency", "dissipated_power_W", "dissipation_bound_W")

_ALT_KEYS = ("total_inertia_gcm2", "speed_constant_rpm_per_V")
#: Keys accepted in a design mapping.
DESIGN_KEYS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(HarvesterParams)) \
    + _ALT_KEYS

_CHUNK = 2048
_N_PEAK = 41


def dimensionless_power(power_W: ArrayLike, vehicle: VehicleParams, speed_m_per_s: float) -> Any:
    """ρ_g = P / (g (m1 + m2) V)."""
    return np.asarray(power_W) / (G * vehicle.total_mass_kg * speed_m_per_s)


def efficiency_bound(harvester: HarvesterParams) -> float:
    """R_e / (R_e + R_i): the efficiency of a frictionless harvester (K_t = K_e)."""
    if math.isinf(harvester.load_ohm):
        return 0.0
    return harvester.load_ohm / (harvester.load_ohm + harvester.internal_resistance_ohm)


def linear_frequency_response(vehicle: VehicleParams, harvester: HarvesterParams,
                              frequencies_hz: ArrayLike) -> dict[str, np.ndarray]:
    """Exact complex steady-state response of the frictionless quarter car to a road
    sine x0 = Im(X0 e^{jωt}), per unit road amplitude X0.

    Solves the 2×2 complex system (m2 s² + D) X2 − D X1 = 0,
    −D X2 + (m1 s² + D + k1) X1 = k1 X0 with D = k2 + s Z(s) and Z the harvester's
    impedance (inerter + electrical branch with its inductance), s = jω.

    Returns
    -------
    dict of complex ndarray (F,)
        ``x2``, ``x1`` (m per m), ``stroke_velocity`` (m/s per m), ``current``
        (A per m, K_e s (X2 − X1) / (r (R + s L))), ``voltage`` (V per m, R_e × current).
    """
    f = np.asarray(frequencies_hz, dtype=float)
    w = 2.0 * math.pi * f
    s = 1j * w
    m2, m1 = vehicle.sprung_mass_kg, vehicle.unsprung_mass_kg
    k2, k1 = vehicle.suspension_stiffness_N_per_m, vehicle.tyre_stiffness_N_per_m
    dyn = k2 + s * equivalent_impedance(harvester, w)
    a11, a22 = m2 * s ** 2 + dyn, m1 * s ** 2 + dyn + k1
    det = a11 * a22 - dyn * dyn
    x2, x1 = k1 * dyn / det, k1 * a11 / det
    v = s * (x2 - x1)
    R = harvester.total_resistance_ohm()
    if math.isinf(R):
        cur = np.zeros_like(v)
    else:
        cur = harvester.voltage_constant_Vs_per_rad * v / (
            harvester.lead_m_per_rad * (R + s * harvester.inductance_H))
    volt = (np.zeros_like(cur) if math.isinf(harvester.load_ohm)
            else harvester.load_ohm * cur)
    return {"x2": x2, "x1": x1, "stroke_velocity": v, "current": cur, "voltage": volt}


def _check_range(name: str, value: np.ndarray, md: Mapping[str, Any]) -> None:
    bad = ~np.isfinite(value) if name != "load_ohm" else np.isnan(value)
    why = "is not finite"
    for key, op, text in (("gt", np.less_equal, ">"), ("ge", np.less, ">="),
                          ("lt", np.greater_equal, "<"), ("le", np.greater, "<=")):
        if md.get(key) is not None:
            viol = op(value, md[key])
            if np.any(viol & ~bad):
                bad = bad | viol
                why = f"must be {text} {md[key]:g} {md['unit']}"
    if np.any(bad):
        idx = np.argwhere(bad)[0]
        raise ParameterError(f"design: '{name}' = {value[tuple(idx)]:g} at index {tuple(idx)} "
                             f"{why}")


def design_arrays(design: Mapping[str, ArrayLike] | None,
                  base: HarvesterParams | None = None) -> dict[str, np.ndarray]:
    """Broadcast a design mapping to SI arrays.

    Parameters
    ----------
    design : mapping or None
        Keys: :class:`~ehsa_opt.physics.params.HarvesterParams` field names, or the
        alternatives ``total_inertia_gcm2`` (J_m + J_s) and
        ``speed_constant_rpm_per_V`` (K_e = K_t = 60/(2π k_n)); values scalars
        or arrays that broadcast together.  Missing keys take ``base`` values.
    base : HarvesterParams, optional
        Defaults for missing keys (``HarvesterParams()``).

    Returns
    -------
    dict
        ``J_kgm2, r_m_per_rad, Ke, Kt, L_H, Ri_ohm, Re_ohm`` as float arrays of
        the broadcast shape.
    """
    base = base or HarvesterParams()
    design = dict(design or {})
    check_keys(design, DESIGN_KEYS, "design")
    if "total_inertia_gcm2" in design and ({"motor_inertia_gcm2", "screw_inertia_gcm2"}
                                           & design.keys()):
        raise ParameterError("design: give either total_inertia_gcm2 or motor_inertia_gcm2/"
                             "screw_inertia_gcm2, not both")
    if "speed_constant_rpm_per_V" in design and ({"voltage_constant_Vs_per_rad",
                                                  "torque_constant_Nm_per_A"} & design.keys()):
        raise ParameterError("design: give either speed_constant_rpm_per_V or "
                             "voltage_constant_Vs_per_rad/torque_constant_Nm_per_A, not both")
    meta = {f.name: f.metadata for f in dataclasses.fields(HarvesterParams)}
    vals: dict[str, np.ndarray] = {}
    for key, v in design.items():
        arr = np.asarray(v, dtype=float)
        if key in meta:
            _check_range(key, arr, meta[key])
        elif not np.all(np.isfinite(arr) & (arr > 0.0)):
            raise ParameterError(f"design: '{key}' must be finite and > 0")
        vals[key] = arr
    get = lambda k: vals.get(k, np.asarray(getattr(base, k), dtype=float))  # noqa: E731
    if "total_inertia_gcm2" in vals:
        jt = vals["total_inertia_gcm2"]
    else:
        jt = get("motor_inertia_gcm2") + get("screw_inertia_gcm2")
    if np.any(jt <= 0.0):
        raise ParameterError("design: total inertia must be > 0 g cm^2")
    if "speed_constant_rpm_per_V" in vals:
        ke = 60.0 / (2.0 * math.pi * vals["speed_constant_rpm_per_V"])
        kt = ke
    else:
        ke, kt = get("voltage_constant_Vs_per_rad"), get("torque_constant_Nm_per_A")
    out = {"J_kgm2": jt * 1e-7, "r_m_per_rad": get("lead_mm_per_rev") * 1e-3 / (2.0 * math.pi),
           "Ke": ke, "Kt": kt, "L_H": get("inductance_H"), "Ri_ohm": get("internal_resistance_ohm"),
           "Re_ohm": get("load_ohm")}
    shapes = np.broadcast_shapes(*(a.shape for a in out.values()))
    return {k: np.broadcast_to(a, shapes).astype(float) for k, a in out.items()}


def _mode_grid(m2: float, m1: float, k2: float, k1: float, meq: np.ndarray, ke: np.ndarray,
               kt: np.ndarray, r: np.ndarray, R: np.ndarray, L: np.ndarray, open_c: np.ndarray,
               f_lo: float, f_hi: float, c_f: np.ndarray | None = None) -> np.ndarray:
    """Per-design refinement points (N, 2·_N_PEAK) around the two complex modes.

    Poles of the full linear model (x2, x1, ẋ2, ẋ1, i) from a batched 5×5
    eigenvalue computation, so the refinement sits exactly on each resonance even
    when it is extremely lightly damped.
    """
    n = meq.size
    mm = np.empty((n, 2, 2))
    mm[:, 0, 0], mm[:, 0, 1], mm[:, 1, 0], mm[:, 1, 1] = m2 + meq, -meq, -meq, m1 + meq
    minv = np.linalg.inv(mm)
    kk = np.array([[k2, -k2], [-k2, k2 + k1]])
    a = np.zeros((n, 5, 5))
    a[:, 0, 2] = a[:, 1, 3] = 1.0
    a[:, 2:4, :2] = -minv @ kk
    if c_f is not None:  # extra viscous damping between the masses (friction, linearised)
        cc = c_f[:, None, None] * np.array([[1.0, -1.0], [-1.0, 1.0]])
        a[:, 2:4, 2:4] = -minv @ cc
    coupling = np.where(open_c, 0.0, kt / r)
    a[:, 2:4, 4] = -(minv @ np.array([1.0, -1.0])) * coupling[:, None]
    l_eff = np.maximum(L, 1e-7)
    a[:, 4, 2] = np.where(open_c, 0.0, ke / (r * l_eff))
    a[:, 4, 3] = -a[:, 4, 2]
    a[:, 4, 4] = -np.where(open_c, 1.0, R) / l_eff
    lam = np.linalg.eigvals(a)
    # The two eigenvalues with the largest positive imaginary part (one per complex pair).
    idx = np.argsort(-lam.imag, axis=1)[:, :2]
    top = np.take_along_axis(lam, idx, axis=1)
    fd = np.maximum(top.imag, 0.0) / (2.0 * math.pi)
    sig = np.maximum(np.abs(top.real) / (2.0 * math.pi), 1e-12)
    # Points f_d + σ tan φ, φ uniform, spanning ±f_d/2 (one on the pole).
    phi = np.linspace(-1.0, 1.0, _N_PEAK)
    pts = []
    for j in range(2):
        fc, s = fd[:, j:j + 1], sig[:, j:j + 1]
        span = np.arctan(0.5 * np.maximum(fc, f_lo) / s)
        pts.append(fc + s * np.tan(span * phi[None, :]))
    grid = np.clip(np.concatenate(pts, axis=1), f_lo, f_hi)
    return grid, fd, sig


def _quadrature_weights(f: np.ndarray, fd: np.ndarray, sig: np.ndarray) -> np.ndarray:
    """Product-trapezoid weights on sorted grids ``f`` (N, M), exact for the density ρ.

    ρ(f) = 1/f + Σ_j (σ_j/π) / ((f − f_j)² + σ_j²) with antiderivative
    P(f) = ln f + Σ_j atan((f − f_j)/σ_j)/π; ∫ y df ≈ Σ ½ (y_a/ρ_a + y_b/ρ_b)(P_b − P_a).
    The integrand of a lightly damped mode is Lorentzian, so y/ρ stays smooth and
    the rule is accurate for any damping (ordinary trapezoids over tan-spaced
    points are not: they overestimate the tails).
    """
    rho = 1.0 / f
    prim = np.log(f)
    for j in range(fd.shape[1]):
        on = (fd[:, j] > 0.0)[:, None]
        fc, s = fd[:, j:j + 1], sig[:, j:j + 1]
        x = f - fc
        rho = rho + np.where(on, (s / math.pi) / (x * x + s * s), 0.0)
        prim = prim + np.where(on, np.arctan(x / s) / math.pi, 0.0)
    dp = np.diff(prim, axis=1)
    w = np.zeros_like(f)
    w[:, :-1] += 0.5 * dp
    w[:, 1:] += 0.5 * dp
    return w / rho


def linear_metrics(vehicle: VehicleParams, road: RoadParams,
                   design: Mapping[str, ArrayLike] | None = None, *,
                   f_min_hz: float | None = None, f_max_hz: float | None = None,
                   n_freq: int = 256, base: HarvesterParams | None = None,
                   friction_damping_Ns_per_m: ArrayLike | None = None,
                   friction_damping_solver: Callable[..., np.ndarray] | None = None,
                   ) -> dict[str, np.ndarray]:
    """Exact frequency-domain metrics of the linear (frictionless) quarter car.

    Parameters
    ----------
    vehicle : VehicleParams
        m2, m1, k2, k1.
    road : RoadParams
        ISO 8608 class and speed (a measured profile is refused: no PSD).
    design : mapping, optional
        Harvester fields (see :func:`design_arrays`), scalars or broadcastable
        arrays; missing keys take ``base`` (default ``HarvesterParams()``) values.
    f_min_hz, f_max_hz : float, optional
        Integration band, Hz; default the synthesised road band
        :data:`~ehsa_opt.vehicle.road.ROAD_BAND_CYCLES_PER_M` times the speed (so the
        time-domain path on a synthesised road sees the same band).
    n_freq : int
        Points of the shared log-spaced grid (plus 2×40 per-design points).
    friction_damping_Ns_per_m : array_like, optional
        Extra viscous damping c_f between the masses (N s/m), broadcast with the
        design: the equivalent damping of the friction
        (:mod:`ehsa_opt.vehicle.fast_path.linearisation`).  It joins the damper's force, so
        ``dissipated_power_W`` includes c_f σ_v² and ``efficiency`` is the
        generator's share; default 0 (frictionless).
    friction_damping_solver : callable, optional
        ``solver(index, sigma_v_of) -> c_f`` for amplitude-dependent damping
        (:func:`ehsa_opt.vehicle.fast_path.friction_metrics`): called once per
        block of designs with their flat ``index`` and a cheap function
        ``sigma_v_of(c_f, rows)`` giving σ_v of the block's ``rows`` for damping
        ``c_f`` on the block's prepared grid (only |det|² depends on c_f); returns
        the block's c_f, with which the metrics are then evaluated.  The grid is
        refined around the poles of the given ``friction_damping_Ns_per_m``
        (default 0).

    Returns
    -------
    dict of ndarray (broadcast shape of the design)
        ``comfort`` (α, –), ``comfort_weighted_rms_m_s2``, ``road_holding``
        (η_rh, –), ``power_W`` (mean power in R_e), ``power_dimensionless`` (ρ_g),
        ``efficiency`` (η_g, –), ``dissipated_power_W`` (mean power absorbed
        by the damper, inertial part excluded), ``dissipation_bound_W``,
        ``stroke_velocity_rms_m_s`` (σ_v), ``current_rms_A``, ``voltage_rms_V`` (R_e × rms
        current; 0 in open circuit), ``stroke_rms_m`` (rms of x2 − x1), and the rms of the
        derivatives ``current_rate_rms_A_per_s`` (di/dt) and
        ``stroke_acceleration_rms_m_s2`` (dv/dt), which set the rates of level crossings
        (the peak statistics of :mod:`ehsa_opt.design.limits`).
    """
    if road.profile_csv is not None:
        raise ValueError("linear_metrics needs an ISO 8608 road (a PSD); a measured profile "
                         "has none: use the time-domain simulation")
    v = road.speed_m_per_s
    f_lo = ROAD_BAND_CYCLES_PER_M[0] * v if f_min_hz is None else float(f_min_hz)
    f_hi = ROAD_BAND_CYCLES_PER_M[1] * v if f_max_hz is None else float(f_max_hz)
    if not 0.0 < f_lo < f_hi:
        raise ValueError(f"linear_metrics: need 0 < f_min_hz < f_max_hz, got {f_lo}, {f_hi}")
    d = design_arrays(design, base)
    if friction_damping_Ns_per_m is not None:
        cf = np.asarray(friction_damping_Ns_per_m, dtype=float)
        if not np.all(np.isfinite(cf) & (cf >= 0.0)):
            raise ParameterError("linear_metrics: friction_damping_Ns_per_m must be finite "
                                 "and >= 0 N s/m")
        shape = np.broadcast_shapes(d["Re_ohm"].shape, cf.shape)
        d = {k: np.broadcast_to(a, shape) for k, a in d.items()}
        d["c_f"] = np.broadcast_to(cf, shape).astype(float)
    else:
        d["c_f"] = np.zeros(d["Re_ohm"].shape)
    shape = d["Re_ohm"].shape
    flat = {k: a.reshape(-1) for k, a in d.items()}
    n = flat["Re_ohm"].size
    m2, m1 = vehicle.sprung_mass_kg, vehicle.unsprung_mass_kg
    k2, k1 = vehicle.suspension_stiffness_N_per_m, vehicle.tyre_stiffness_N_per_m
    phi_v = road_velocity_psd(road)
    base_grid = np.logspace(math.log10(f_lo), math.log10(f_hi), int(n_freq))
    out = {k: np.empty(n) for k in ("var_acc_w", "var_tyre", "p_load", "p_diss", "var_v",
                                    "c_f", "var_i", "var_stroke", "var_di", "var_dv")}
    for lo in range(0, n, _CHUNK):
        sl = slice(lo, min(lo + _CHUNK, n))
        J, r, ke, kt = flat["J_kgm2"][sl], flat["r_m_per_rad"][sl], flat["Ke"][sl], flat["Kt"][sl]
        L, Ri, Re = flat["L_H"][sl], flat["Ri_ohm"][sl], flat["Re_ohm"][sl]
        cf = flat["c_f"][sl]
        R = Ri + Re
        open_c = np.isinf(R)
        Rs = np.where(open_c, 1.0, R)
        meq = J / r ** 2
        kk_r2 = kt * ke / r ** 2
        fine, fd, sig = _mode_grid(m2, m1, k2, k1, meq, ke, kt, r, Rs, L, open_c, f_lo, f_hi,
                                   cf if np.any(cf > 0.0) else None)
        f = np.sort(np.concatenate([np.broadcast_to(base_grid, (fine.shape[0], base_grid.size)),
                                    fine], axis=1), axis=1)
        # Real arithmetic throughout (the complex algebra written out for speed).
        w = 2.0 * math.pi * f
        w2 = w * w
        col = lambda a: a[:, None]  # noqa: E731
        Rc, Lc = col(Rs), col(L)
        den_e = Rc * Rc + w2 * Lc * Lc
        gain = np.where(col(open_c), 0.0, col(kk_r2) / den_e)
        yr, yi = gain * Rc, -gain * w * Lc              # electrical F/v = kk/(r²(R + jωL))
        yd = yr + col(cf)                               # + friction's equivalent damping
        d_re = k2 - w2 * col(meq) - w * yi              # D = k2 + s (s m_eq + y_el)
        a_re = d_re - m2 * w2                           # a11 = D − m2 ω²
        b_re = d_re - m1 * w2 + k1                      # a22 = D − m1 ω² + k1
        # det = a11 a22 − D²: its real part does not depend on the damping, its
        # imaginary part is (k1 − (m1 + m2) ω²) ω (y_r + c_f)
        det_re = a_re * b_re - d_re * d_re
        q_im = (k1 - (m1 + m2) * w2) * w
        wq = _quadrature_weights(f, fd, sig) * phi_v
        num_v = (k1 * m2) ** 2 * w2 * w2
        if friction_damping_solver is not None:
            def sigma_v_of(c: np.ndarray, rows: np.ndarray) -> np.ndarray:
                dim = q_im[rows] * (yr[rows] + c[:, None])
                return np.sqrt(np.sum(num_v[rows] / (det_re[rows] ** 2 + dim * dim)
                                      * wq[rows], axis=1))
            cf = np.asarray(friction_damping_solver(np.arange(n)[sl], sigma_v_of), float)
            yd = yr + col(cf)
        out["c_f"][sl] = cf
        d_im = w * yd
        det_im = q_im * yd
        det2 = det_re * det_re + det_im * det_im
        acc2 = w2 * k1 * k1 * (d_re * d_re + d_im * d_im) / det2          # |ẍ2/V0|²
        vrel2 = num_v / det2                                               # |v/V0|²
        t_re, t_im = k1 * a_re - det_re, k1 * d_im - det_im
        tyre2 = (t_re * t_re + t_im * t_im) / (w2 * det2)                  # |(x1 − x0)/V0|²
        cur2 = np.where(col(open_c), 0.0, col(ke / r) ** 2 * vrel2 / den_e)
        wk2 = wk_abs2(f)

        def integ(y: np.ndarray) -> np.ndarray:
            return np.sum(y * wq, axis=1)

        out["var_acc_w"][sl] = integ(wk2 * acc2)
        out["var_tyre"][sl] = integ(tyre2)
        out["p_load"][sl] = np.where(open_c, 0.0, np.where(open_c, 0.0, Re) * integ(cur2))
        out["p_diss"][sl] = integ(yd * vrel2)
        out["var_v"][sl] = integ(vrel2)
        out["var_i"][sl] = integ(cur2)
        out["var_stroke"][sl] = integ(vrel2 / w2)
        out["var_di"][sl] = integ(w2 * cur2)
        out["var_dv"][sl] = integ(w2 * vrel2)
    acc_rms = np.sqrt(out["var_acc_w"])
    power = out["p_load"]
    with np.errstate(invalid="ignore", divide="ignore"):
        eff = np.where(out["p_diss"] > 0.0, power / out["p_diss"], 0.0)
    res = {
        "comfort": acc_rms / G,
        "comfort_weighted_rms_m_s2": acc_rms,
        "road_holding": k1 * np.sqrt(out["var_tyre"]) / (G * vehicle.total_mass_kg),
        "power_W": power,
        "power_dimensionless": dimensionless_power(power, vehicle, v),
        "efficiency": eff,
        "dissipated_power_W": out["p_diss"],
        "dissipation_bound_W": np.full(n, dissipation_bound_W(vehicle, road)),
        "stroke_velocity_rms_m_s": np.sqrt(out["var_v"]),
        "friction_damping_Ns_per_m": out["c_f"],
        "current_rms_A": np.sqrt(out["var_i"]),
        "voltage_rms_V": np.where(np.isinf(flat["Re_ohm"]), 0.0,
                                  np.where(np.isinf(flat["Re_ohm"]), 0.0, flat["Re_ohm"])
                                  * np.sqrt(out["var_i"])),
        "stroke_rms_m": np.sqrt(out["var_stroke"]),
        "current_rate_rms_A_per_s": np.sqrt(out["var_di"]),
        "stroke_acceleration_rms_m_s2": np.sqrt(out["var_dv"]),
    }
    return {k: a.reshape(shape) for k, a in res.items()}
