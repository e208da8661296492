"""Symbolic CasADi quarter car with the ball-screw harvester (paper §4).

States z = (x2, x1, v2, v1, i, F_b): sprung and unsprung displacement (m) and
velocity (m/s), generator current (A), the LuGre bristle force (N; at rest under the static
law).  Input: road elevation x0 (m).  With v = v2 − v1 (stroke velocity), r = lead/2π,
m_eq = J_t/r², R = R_e + R_i::

    f_d = m_eq (a2 − a1) + K_t i / r + F_f,      F_f = F_ns(v) + T_b(v/r)/r   (static law)
    m2 a2 = −k2 (x2 − x1) − f_d
    m1 a1 =  k2 (x2 − x1) + f_d − k1 (x1 − x0)
    L di/dt = K_e v / r − R i

Under the LuGre law (parameter ``friction_law_lugre`` = 1) the rod's whole friction is
carried by a bristle whose steady state is the static map, as on the rigid bench
(:class:`~ehsa_opt.physics.bench_model.BenchModel`, one friction module for both,
:mod:`~ehsa_opt.physics.friction`)::

    φ(v)   = φ_ns(v) + φ_b(v/r)/r²,      f_v,rod = f_v + t_v/r²
    dF_b/dt = σ₀ (v − F_b/φ(v)),          F_f = F_b + (σ₁/σ₀) dF_b/dt + f_v,rod v

The bristle spring stores ½ F_b²/σ₀ (counted in :meth:`QuarterCarModel.stored_energy`;
``friction_power_W`` is the power dissipated, F_f v less that storage's rate).

The inerter puts m_eq in a mass matrix M = [[m2 + m_eq, −m_eq], [−m_eq, m1 + m_eq]],
solved symbolically (2×2).

Time stepping (:meth:`QuarterCarModel.step_function`): the mechanical part by
the trapezoidal rule (A-stable, second order, energy-conserving on the linear
part), the electrical state by its exact exponential update with the stroke
velocity linear over the step (L/R is 15–260 µs, far below any useful step:
the exponential update is exact for that linear sub-system, stable for any
step, and becomes the quasi-static i = K_e v/(r R) when L → 0).  Everything at
the new time is affine in the new stroke velocity except the friction, so each
step reduces to one monotone scalar equation
G(v) = v − α + β (c0 + c1 v + F_f(v)) = 0, solved by bracketed Newton with a
fixed number of iterations (a pure SX graph: it can be mapped and compiled).
The bristle force (LuGre) is updated by the backward Euler rule, L-stable for its
relaxation rate σ₀/φ (up to 1e5 1/s and more)::

    F_b,k+1 = (F_b,k + h σ₀ v_k+1) φ(v_k+1) / (φ(v_k+1) + h σ₀)

explicit in the new stroke velocity, so the step stays one scalar equation; as σ₀ → ∞ it
gives F_b = φ(v) v, the static law, which the static branch evaluates exactly.

Parameters: a flat vector in :data:`PARAM_NAMES` order (see
:func:`param_vector`).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from .base_parameters import PARAMETERS
from .friction import (
    SLOPE_FLOOR_NS_PER_M,
    bearing_friction_Nm,
    bearing_static_slope,
    bristle_force_rate,
    nut_friction_N,
    nut_static_slope,
    presliding_force,
)
from .params import (FRICTION_NAMES, PRESLIDING_PARAMETER_NAMES, FrictionParams,
                     HarvesterParams, VehicleParams)

__all__ = ["PARAM_NAMES", "STATE_NAMES", "STEP_OUTPUT_NAMES", "OPEN_CIRCUIT_OHM",
           "param_vector", "QuarterCarModel"]

#: Names of the parameter vector entries.
PARAM_NAMES: tuple[str, ...] = (
    "sprung_mass_kg", "unsprung_mass_kg", "suspension_stiffness_N_per_m",
    "tyre_stiffness_N_per_m", "equivalent_mass_kg", "lead_m_per_rad",
    "voltage_constant_Vs_per_rad", "torque_constant_Nm_per_A", "total_resistance_ohm",
    "load_ohm", "inductance_H") + FRICTION_NAMES + (
    "friction_law_lugre",) + PRESLIDING_PARAMETER_NAMES

STATE_NAMES: tuple[str, ...] = ("x2_m", "x1_m", "v2_m_per_s", "v1_m_per_s", "current_A",
                                "bristle_force_N")

#: Per-step outputs of the step function (values at the end of the step except
#: the *_J entries, which are energies over the step).
STEP_OUTPUT_NAMES: tuple[str, ...] = (
    "sprung_acc_m_s2", "tyre_deflection_m", "load_power_W", "damper_power_W",
    "friction_power_W", "stroke_velocity_m_s", "damper_force_N", "voltage_V",
    "road_work_J")

#: A load this large stands for open circuit (R_e = ∞) in the numeric vector.
OPEN_CIRCUIT_OHM = 1e15

_NEWTON_ITERATIONS = 10


def param_vector(vehicle: VehicleParams, harvester: HarvesterParams,
                 friction: FrictionParams | None = None) -> np.ndarray:
    """Numeric parameter vector in :data:`PARAM_NAMES` order (under the static law the
    presliding entries hold the declared typical σ₀ and σ₁ = 0, which no branch uses)."""
    friction = friction or FrictionParams()
    if friction.is_static:
        law = [0.0, PARAMETERS["presliding_stiffness_N_per_m"].typical, 0.0]
    else:
        law = [1.0, *(getattr(friction, n) for n in PRESLIDING_PARAMETER_NAMES)]
    re = harvester.load_ohm if math.isfinite(harvester.load_ohm) else OPEN_CIRCUIT_OHM
    return np.array([
        vehicle.sprung_mass_kg, vehicle.unsprung_mass_kg, vehicle.suspension_stiffness_N_per_m,
        vehicle.tyre_stiffness_N_per_m, harvester.equivalent_mass_kg(), harvester.lead_m_per_rad,
        harvester.voltage_constant_Vs_per_rad, harvester.torque_constant_Nm_per_A,
        re + harvester.internal_resistance_ohm, re, harvester.inductance_H,
        *friction.as_array(), *law], dtype=float)


def _unpack(p: ca.SX) -> dict[str, ca.SX]:
    return {name: p[i] for i, name in enumerate(PARAM_NAMES)}


def _rod_friction(v: ca.SX, q: dict[str, ca.SX]) -> ca.SX:
    fr = [q[n] for n in FRICTION_NAMES]
    r = q["lead_m_per_rad"]
    return nut_friction_N(v, fr) + bearing_friction_Nm(v / r, fr) / r


def _rod_slope_viscous(v: ca.SX, q: dict[str, ca.SX]) -> tuple[ca.SX, ca.SX]:
    """φ(v) of the rod's whole friction (N s/m) and its viscous coefficient f_v + t_v/r²."""
    fr = [q[n] for n in FRICTION_NAMES]
    r = q["lead_m_per_rad"]
    return (nut_static_slope(v, fr) + bearing_static_slope(v / r, fr) / r ** 2,
            q["nut_viscous_Ns_per_m"] + q["bearing_viscous_Nms_per_rad"] / r ** 2)


def _lugre_friction(fb: ca.SX, v: ca.SX, q: dict[str, ca.SX]) -> tuple[ca.SX, ca.SX]:
    """(friction force F_f, N; bristle-force rate, N/s) of bristle force ``fb`` at ``v``."""
    slope, visc = _rod_slope_viscous(v, q)
    sig0 = q["presliding_stiffness_N_per_m"]
    rate = bristle_force_rate(fb, v, slope, sig0)
    return presliding_force(fb, rate, v, sig0, q["presliding_damping_Ns_per_m"], visc), rate


def _bristle_step(fb0: ca.SX, v1: ca.SX, h: float, q: dict[str, ca.SX]) -> ca.SX:
    """Backward Euler bristle force at the new stroke velocity ``v1`` (module docstring)."""
    slope = _rod_slope_viscous(v1, q)[0] + SLOPE_FLOOR_NS_PER_M
    hs = h * q["presliding_stiffness_N_per_m"]
    return (fb0 + hs * v1) * slope / (slope + hs)


def _friction_bound(q: dict[str, ca.SX]) -> ca.SX:
    """Bound on |F_f(v) − viscous part|: F_brk + T_brk / r (Simscape law)."""
    return q["nut_breakaway_N"] + q["bearing_breakaway_Nm"] / q["lead_m_per_rad"]


class QuarterCarModel:
    """CasADi functions of the quarter car with harvester and friction.

    Attributes
    ----------
    ode : casadi.Function
        (z[6], x0, p) → ż (continuous time; for reference integrators).
    outputs : casadi.Function
        (z[6], x0, p) → (sprung acceleration, damper force without the
        inertial part, friction force, load power).
    """

    n_states = len(STATE_NAMES)
    n_params = len(PARAM_NAMES)

    def __init__(self) -> None:
        z = ca.SX.sym("z", self.n_states)
        x0 = ca.SX.sym("x0")
        p = ca.SX.sym("p", self.n_params)
        q = _unpack(p)
        acc, fd_ni, ff, dfb = self._accelerations(z, x0, q)
        r = q["lead_m_per_rad"]
        v = z[2] - z[3]
        L = q["inductance_H"]
        di = (q["voltage_constant_Vs_per_rad"] * v / r - q["total_resistance_ohm"] * z[4]) / L
        self.ode = ca.Function("quarter_car_ode", [z, x0, p],
                               [ca.vertcat(z[2], z[3], acc[0], acc[1], di, dfb)],
                               ["z", "x0", "p"], ["zdot"])
        self.outputs = ca.Function(
            "quarter_car_outputs", [z, x0, p],
            [acc[0], fd_ni, ff, q["load_ohm"] * z[4] ** 2],
            ["z", "x0", "p"], ["sprung_acc", "damper_force_noninertial", "friction", "p_load"])

    # ------------------------------------------------------------------ physics
    @staticmethod
    def _mass(q: dict[str, ca.SX]) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
        meq = q["equivalent_mass_kg"]
        return (q["sprung_mass_kg"] + meq, -meq, -meq, q["unsprung_mass_kg"] + meq)

    def _accelerations(self, z: ca.SX, x0: ca.SX, q: dict[str, ca.SX]):
        m11, m12, m21, m22 = self._mass(q)
        k2, k1 = q["suspension_stiffness_N_per_m"], q["tyre_stiffness_N_per_m"]
        v = z[2] - z[3]
        lugre = q["friction_law_lugre"] > 0.5
        f_lu, rate = _lugre_friction(z[5], v, q)
        ff = ca.if_else(lugre, f_lu, _rod_friction(v, q))
        dfb = ca.if_else(lugre, rate, 0.0)
        fd_ni = q["torque_constant_Nm_per_A"] * z[4] / q["lead_m_per_rad"] + ff
        f2 = -k2 * (z[0] - z[1]) - fd_ni
        f1 = k2 * (z[0] - z[1]) + fd_ni - k1 * (z[1] - x0)
        det = m11 * m22 - m12 * m21
        a2 = (m22 * f2 - m12 * f1) / det
        a1 = (-m21 * f2 + m11 * f1) / det
        return (a2, a1), fd_ni, ff, dfb

    # ------------------------------------------------------------------ stepping
    def step_function(self, h: float, opts: dict | None = None,
                      law: str = "static") -> ca.Function:
        """One time step of length ``h`` (s): (z_k, x0_k, x0_k1, p) → (z_k1, y_k1).

        ``y`` holds :data:`STEP_OUTPUT_NAMES`.  ``law`` is the friction law the graph is
        built for (``"static"``: the bristle force stays 0; ``"lugre"``); the parameter
        ``friction_law_lugre`` of each design must say the same (one graph per law keeps
        the static step as cheap as it was).
        """
        if law not in ("static", "lugre"):
            raise ValueError(f"step_function: law must be 'static' or 'lugre', got {law!r}")
        z = ca.SX.sym("z", self.n_states)
        x0a, x0b = ca.SX.sym("x0_k"), ca.SX.sym("x0_k1")
        p = ca.SX.sym("p", self.n_params)
        q = _unpack(p)
        m11, m12, m21, m22 = self._mass(q)
        k2, k1 = q["suspension_stiffness_N_per_m"], q["tyre_stiffness_N_per_m"]
        r, ke, kt = q["lead_m_per_rad"], q["voltage_constant_Vs_per_rad"], \
            q["torque_constant_Nm_per_A"]
        R, L = q["total_resistance_ohm"], q["inductance_H"]
        x2, x1, v2, v1, i0, fb0 = z[0], z[1], z[2], z[3], z[4], z[5]
        v0 = v2 - v1
        lugre = law == "lugre"
        sig0, sig1 = q["presliding_stiffness_N_per_m"], q["presliding_damping_Ns_per_m"]

        def friction_at(v_new: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
            """(F_f, F_b, dF_b/dt) at the end of the step for stroke velocity v_new."""
            if not lugre:
                return _rod_friction(v_new, q), ca.SX(0.0), ca.SX(0.0)
            fb1 = _bristle_step(fb0, v_new, h, q)
            f_lu, rate = _lugre_friction(fb1, v_new, q)
            return f_lu, fb1, rate
        # electrical: i1 = e i0 + g (a v0 + b v1n)
        lam = h * R / L
        e = ca.exp(-lam)
        phi = (1.0 - e) / lam
        ca_, cb_ = phi - e, 1.0 - phi
        g = ke / (r * R)
        ff0 = _lugre_friction(fb0, v0, q)[0] if lugre else _rod_friction(v0, q)
        fd0 = kt * i0 / r + ff0
        # forces at k (without the tyre's road term handled separately)
        f2k = -k2 * (x2 - x1) - fd0
        f1k = k2 * (x2 - x1) + fd0 - k1 * (x1 - x0a)
        # S p1 = M p0 + h/2 F_k + h/2 [ -K (q0 + h/2 p0) + k1 x0b e1 - b_d fd1 ]
        hh = 0.5 * h
        y2, y1 = x2 + hh * v2, x1 + hh * v1
        rhs2 = m11 * v2 + m12 * v1 + hh * f2k + hh * (-k2 * (y2 - y1))
        rhs1 = m21 * v2 + m22 * v1 + hh * f1k + hh * (k2 * (y2 - y1) - k1 * (y1 - x0b))
        s11 = m11 + hh * hh * k2
        s12 = m12 - hh * hh * k2
        s21 = m21 - hh * hh * k2
        s22 = m22 + hh * hh * (k2 + k1)
        sdet = s11 * s22 - s12 * s21
        p2a = (s22 * rhs2 - s12 * rhs1) / sdet
        p1a = (-s21 * rhs2 + s11 * rhs1) / sdet
        # S⁻¹ b_d with b_d = (1, −1): damper force pushes m2 down, m1 up
        u2 = (s22 * 1.0 - s12 * (-1.0)) / sdet
        u1 = (-s21 * 1.0 + s11 * (-1.0)) / sdet
        alpha = p2a - p1a
        beta = hh * (u2 - u1)
        c0 = kt / r * (e * i0 + g * ca_ * v0)
        c1 = kt / r * g * cb_
        rhs = alpha - beta * c0
        slope = 1.0 + beta * c1 + beta * (q["nut_viscous_Ns_per_m"]
                                           + q["bearing_viscous_Nms_per_rad"] / r ** 2)
        # |F_f − viscous part| is below the static bound B; under LuGre below
        # max(B, |F_b,k|) plus the damping term σ₁ (s(v) − F_b,k)/(φ + h σ₀)
        fbound = _friction_bound(q)
        if lugre:
            fbound = ca.fmax(fbound, ca.fabs(fb0)) + sig1 * (fbound + ca.fabs(fb0)) / (h * sig0)
        bound = beta * fbound / slope
        lo, hi = rhs / slope - bound - 1e-12, rhs / slope + bound + 1e-12
        vs = ca.SX.sym("vs")
        gfun = vs - rhs + beta * (c1 * vs + friction_at(vs)[0])
        gval = ca.Function("g", [vs, p, z, x0a, x0b], [gfun, ca.jacobian(gfun, vs)])
        vn = ca.fmin(ca.fmax(v0, lo), hi)
        for _ in range(_NEWTON_ITERATIONS):
            gv, dg = gval(vn, p, z, x0a, x0b)
            lo = ca.if_else(gv < 0, vn, lo)
            hi = ca.if_else(gv > 0, vn, hi)
            cand = vn - gv / dg
            inside = ca.logic_and(cand > lo, cand < hi)
            vn = ca.if_else(inside, cand, 0.5 * (lo + hi))
        ff1, fb1, rate1 = friction_at(vn)
        i1 = e * i0 + g * (ca_ * v0 + cb_ * vn)
        fd1 = kt * i1 / r + ff1
        v2n = p2a - hh * u2 * fd1
        v1n = p1a - hh * u1 * fd1
        x2n, x1n = x2 + hh * (v2 + v2n), x1 + hh * (v1 + v1n)
        # accelerations at k+1 from the forces (consistent with the ODE)
        f2n = -k2 * (x2n - x1n) - fd1
        f1n = k2 * (x2n - x1n) + fd1 - k1 * (x1n - x0b)
        det = m11 * m22 - m12 * m21
        a2n = (m22 * f2n - m12 * f1n) / det
        # road work over the step: tyre force times road displacement (trapezoid)
        work = 0.5 * (k1 * (x0a - x1) + k1 * (x0b - x1n)) * (x0b - x0a)
        vrel = v2n - v1n
        # dissipated by the friction: F_f v less the bristle spring's storage rate
        diss = ff1 * vrel - fb1 * rate1 / sig0 if lugre else ff1 * vrel
        y = ca.vertcat(a2n, x1n - x0b, q["load_ohm"] * i1 ** 2, (kt * i1 / r + ff1) * vrel,
                       diss, vrel, fd1, q["load_ohm"] * i1, work)
        return ca.Function("quarter_car_step", [z, x0a, x0b, p],
                           [ca.vertcat(x2n, x1n, v2n, v1n, i1, fb1), y],
                           ["z", "x0_k", "x0_k1", "p"], ["z_next", "y"], opts or {})

    @staticmethod
    def stored_energy(z: np.ndarray, x0: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Mechanical + magnetic + bristle energy (J) of states ``z`` (6, …) at road
        ``x0``."""
        q = dict(zip(PARAM_NAMES, p))
        meq = q["equivalent_mass_kg"]
        v2, v1 = z[2], z[3]
        kin = 0.5 * (q["sprung_mass_kg"] * v2 ** 2 + q["unsprung_mass_kg"] * v1 ** 2
                     + meq * (v2 - v1) ** 2)
        pot = 0.5 * (q["suspension_stiffness_N_per_m"] * (z[0] - z[1]) ** 2
                     + q["tyre_stiffness_N_per_m"] * (z[1] - x0) ** 2)
        bristle = (q["friction_law_lugre"] * 0.5 * z[5] ** 2
                   / q["presliding_stiffness_N_per_m"])
        return kin + pot + 0.5 * q["inductance_H"] * z[4] ** 2 + bristle
