"""Simscape friction law: one implementation for floats, numpy and CasADi.

For a velocity u::

    F(u) = √(2e) (F_brk − F_C) exp(−(u/u_St)²) (u/u_St) + F_C tanh(u/u_Coul) + f_v u
    u_St = √2 · u_brk,   u_Coul = u_brk / 10

The law is smooth, so it enters IPOPT as it is.  Every argument may be a float,
a numpy array or a CasADi SX/MX/DM expression (parameters can be symbolic too).

Dynamic (presliding) friction: the LuGre law (Canudas de Wit et al. 1995) with the
Simscape curve as its steady state.  A bristle deflection z (m) carries the force::

    s(u)  = F(u) − f_v u                      (the static law without its viscous part)
    φ(u)  = s(u) / u  > 0                     (N s/m; finite at u = 0)
    dz/dt = u − σ₀ z / φ(u)                   (= u − σ₀ |u| z / |s(u)|, LuGre's g = |s|)
    F     = σ₀ z + σ₁ dz/dt + f_v u

At steady sliding dz/dt = 0, z = s(u)/σ₀ and F = F(u): the static law is the limit
σ₀ → ∞ of the dynamic one.  At a reversal the force follows the bristle spring σ₀
(N/m) over the presliding displacement s/σ₀ instead of jumping.

The state carried is the bristle force F_b = σ₀ z (N), not z: its size (the friction
level) does not depend on σ₀, so one absolute tolerance (an integrator's, the
collocation's scaling) fits every σ₀ from 1e4 to 1e10 N/m — z itself spans 1e-9 to
1e-2 m over that range::

    dF_b/dt = σ₀ (u − F_b / φ(u)),     F = F_b + (σ₁/σ₀) dF_b/dt + f_v u

Generalised Stribeck LuGre (``"lugre_stribeck"``): the same bristle, with the steady
state of Canudas de Wit et al. (1995) and Armstrong-Hélouvry et al. (1994) — a level
that falls from the static friction F_S to the Coulomb friction F_C with a free
exponent δ — and the micro-damping of Olsson et al. (1998), which fades with speed::

    g(u)  = F_C + (F_S − F_C) exp(−ρ(u)^δ),   ρ(u) = √(u² + u_c²) / u_S
    s(u)  = g(u) tanh(u/u_c),   u_c = u_S / 10
    F     = F_b + σ₁ exp(−(u/u_S)²) / σ₀ · dF_b/dt + f_v u

F_S, F_C, u_S and f_v are the nut's breakaway, Coulomb, breakaway-velocity and
viscous parameters (the breakaway velocity read as the Stribeck velocity u_S), δ the
parameter ``stribeck_exponent``.  ρ is |u|/u_S smoothed over u_c, the Simscape law's
own smoothing velocity (its u_Coul = u_brk/10), so the curve is smooth for IPOPT for
every δ (|u|^δ is not at 0 for δ ≤ 1); above a few u_c it is the textbook curve with
the textbook F_S, and at rest its level is F_C + (F_S − F_C) exp(−10^−δ) (the bristle
carries the force there: the presliding regime).  The static limit σ₀ → ∞ is the generalised Stribeck map
:func:`stribeck_friction`.
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from .params import FrictionParams

__all__ = ["simscape_friction", "nut_friction_N", "bearing_friction_Nm", "rod_friction_N",
           "FRICTION_LAWS", "PRESLIDING_NAMES", "static_slope", "bristle_force_rate",
           "presliding_force", "nut_static_slope", "bearing_static_slope",
           "BENCH_FRICTION_LAWS", "DYNAMIC_LAWS", "STRIBECK_EXPONENT", "LAW_PARAMETER_NAMES", "stribeck_level",
           "stribeck_friction", "stribeck_slope", "micro_damping_decay",
           "SMOOTHING_FRACTION"]

#: Friction laws of the models: ``"static"`` (the Simscape map of the velocity) and
#: ``"lugre"`` (the same map as the steady state of a LuGre bristle state).
FRICTION_LAWS: tuple[str, ...] = ("static", "lugre")
#: Friction laws of the bench model (:class:`~ehsa_opt.physics.bench_model.BenchModel`,
#: the discrepancy engine's base law): those of :data:`FRICTION_LAWS` and
#: ``"lugre_stribeck"`` (a bristle whose steady state is the generalised Stribeck curve,
#: with Olsson's micro-damping).  Friction sets and the vehicle carry the first two.
BENCH_FRICTION_LAWS: tuple[str, ...] = (*FRICTION_LAWS, "lugre_stribeck")
#: The laws with a bristle state.
DYNAMIC_LAWS: tuple[str, ...] = ("lugre", "lugre_stribeck")
#: Parameters of the LuGre friction at the rod (declared in
#: :data:`~ehsa_opt.physics.base_parameters.PARAMETERS`): bristle stiffness σ₀ (N/m) and
#: bristle damping σ₁ (N s/m).
PRESLIDING_NAMES: tuple[str, ...] = ("presliding_stiffness_N_per_m",
                                     "presliding_damping_Ns_per_m")
#: The exponent δ of the generalised Stribeck curve (dimensionless, declared in
#: :data:`~ehsa_opt.physics.base_parameters.PARAMETERS`).
STRIBECK_EXPONENT = "stribeck_exponent"
#: The parameters each law adds to the eight friction parameters.
LAW_PARAMETER_NAMES: dict[str, tuple[str, ...]] = {
    "static": (), "lugre": PRESLIDING_NAMES,
    "lugre_stribeck": (*PRESLIDING_NAMES, STRIBECK_EXPONENT)}
#: u_c / u_S of the generalised curve: the smoothing velocity of its sign and of |u|,
#: the Simscape law's ratio u_Coul / u_brk (its ``tanh(u/u_Coul)``).
SMOOTHING_FRACTION = 0.1
#: Below this |u/u_Coul| the ratio tanh(x)/x takes its Taylor series (exact to 1e-19).
_TAYLOR_BELOW = 1e-3
#: Floor added to φ(u), N s/m: keeps the bristle rate finite for a frictionless law
#: (adds a viscous 1e-9 N s/m to the steady state, far below any identified f_v).
SLOPE_FLOOR_NS_PER_M = 1e-9

_SQRT_2E = math.sqrt(2.0 * math.e)
_CASADI_TYPES = (ca.SX, ca.MX, ca.DM)


def _is_casadi(*args: Any) -> bool:
    return any(isinstance(a, _CASADI_TYPES) for a in args)


def simscape_friction(u: Any, breakaway: Any, coulomb: Any, breakaway_velocity: Any,
                      viscous: Any) -> Any:
    """Friction force (or torque) at velocity ``u`` by the Simscape law.

    Parameters
    ----------
    u : float, ndarray or casadi expression
        Sliding velocity (m/s or rad/s).
    breakaway, coulomb : same kind
        Breakaway and Coulomb levels (N or N m), breakaway ≥ Coulomb ≥ 0.
    breakaway_velocity : same kind
        u_brk (> 0), same unit as ``u``.
    viscous : same kind
        Viscous coefficient (N s/m or N m s/rad).

    Returns
    -------
    Same kind as the inputs: the friction opposing positive ``u`` is positive.
    """
    if _is_casadi(u, breakaway, coulomb, breakaway_velocity, viscous):
        exp, tanh = ca.exp, ca.tanh
    else:
        exp, tanh = np.exp, np.tanh
        u = np.asarray(u, dtype=float) if not np.isscalar(u) else float(u)
    u_st = math.sqrt(2.0) * breakaway_velocity
    u_coul = breakaway_velocity / 10.0
    z = u / u_st
    return (_SQRT_2E * (breakaway - coulomb) * exp(-z * z) * z
            + coulomb * tanh(u / u_coul) + viscous * u)


def nut_friction_N(v_m_s: Any, friction: FrictionParams | Any) -> Any:
    """Nut–screw friction force F_ns(v), N, at stroke velocity v (m/s).

    ``friction`` is a :class:`FrictionParams` or a length-8 sequence/vector in
    :data:`~ehsa_opt.physics.params.FRICTION_NAMES` order (may be symbolic).
    """
    p = friction.as_array() if isinstance(friction, FrictionParams) else friction
    return simscape_friction(v_m_s, p[0], p[1], p[2], p[3])


def bearing_friction_Nm(omega_rad_s: Any, friction: FrictionParams | Any) -> Any:
    """Generator bearing friction torque T_b(ω), N m, at rotor speed ω (rad/s)."""
    p = friction.as_array() if isinstance(friction, FrictionParams) else friction
    return simscape_friction(omega_rad_s, p[4], p[5], p[6], p[7])


def rod_friction_N(v_m_s: Any, friction: FrictionParams | Any, lead_m_per_rad: float) -> Any:
    """Total friction seen at the rod on a rigid transmission: F_ns(v) + T_b(v/r)/r, N.

    This is the combination a rigid bench identifies (see the identifiability analysis).
    """
    r = lead_m_per_rad
    return nut_friction_N(v_m_s, friction) + bearing_friction_Nm(v_m_s / r, friction) / r


def _tanh_ratio(x: Any, symbolic: bool) -> Any:
    """tanh(x)/x, smooth and finite at x = 0 (both branches finite everywhere)."""
    if symbolic:
        small = x * x < _TAYLOR_BELOW ** 2
        xs = ca.if_else(small, 1.0, x)
        return ca.if_else(small, 1.0 - x * x / 3.0 + 2.0 * x ** 4 / 15.0, ca.tanh(xs) / xs)
    x = np.asarray(x, dtype=float)
    small = x * x < _TAYLOR_BELOW ** 2
    xs = np.where(small, 1.0, x)
    return np.where(small, 1.0 - x * x / 3.0 + 2.0 * x ** 4 / 15.0, np.tanh(xs) / xs)


def static_slope(u: Any, breakaway: Any, coulomb: Any, breakaway_velocity: Any) -> Any:
    """φ(u) = (F(u) − f_v u)/u of the Simscape law (N s/m or N m s/rad), finite at u = 0.

    Positive for breakaway ≥ 0, Coulomb ≥ 0: the LuGre relaxation rate is σ₀/φ(u).
    """
    symbolic = _is_casadi(u, breakaway, coulomb, breakaway_velocity)
    exp = ca.exp if symbolic else np.exp
    u_st = math.sqrt(2.0) * breakaway_velocity
    u_coul = breakaway_velocity / 10.0
    z = u / u_st
    return (_SQRT_2E * (breakaway - coulomb) * exp(-z * z) / u_st
            + coulomb * _tanh_ratio(u / u_coul, symbolic) / u_coul)


def bristle_force_rate(force: Any, u: Any, slope: Any, stiffness: Any) -> Any:
    """dF_b/dt = σ₀ (u − F_b / (φ(u) + floor)) of the LuGre bristle force F_b = σ₀ z (N/s).

    Parameters
    ----------
    force : float or casadi expression
        Bristle force F_b, N.
    u : float or casadi expression
        Sliding velocity, m/s.
    slope : float or casadi expression
        φ(u) from :func:`static_slope`, N s/m.
    stiffness : float or casadi expression
        σ₀, N/m.
    """
    return stiffness * (u - force / (slope + SLOPE_FLOOR_NS_PER_M))


def presliding_force(force: Any, force_rate: Any, u: Any, stiffness: Any, damping: Any,
                     viscous: Any) -> Any:
    """LuGre friction force σ₀ z + σ₁ dz/dt + f_v u = F_b + (σ₁/σ₀) dF_b/dt + f_v u, N."""
    return force + damping / stiffness * force_rate + viscous * u


def nut_static_slope(v_m_s: Any, friction: FrictionParams | Any) -> Any:
    """φ(v) of the nut–screw law (N s/m), see :func:`static_slope`."""
    p = friction.as_array() if isinstance(friction, FrictionParams) else friction
    return static_slope(v_m_s, p[0], p[1], p[2])


def bearing_static_slope(omega_rad_s: Any, friction: FrictionParams | Any) -> Any:
    """φ(ω) of the bearing law (N m s/rad), see :func:`static_slope`."""
    p = friction.as_array() if isinstance(friction, FrictionParams) else friction
    return static_slope(omega_rad_s, p[4], p[5], p[6])


def _smooth_ratio(u: Any, stribeck_velocity: Any, symbolic: bool) -> Any:
    """ρ(u) = √(u² + u_c²)/u_S of the generalised curve (|u|/u_S, smooth at 0)."""
    sqrt = ca.sqrt if symbolic else np.sqrt
    u_c = SMOOTHING_FRACTION * stribeck_velocity
    return sqrt(u * u + u_c * u_c) / stribeck_velocity


def stribeck_level(u: Any, static: Any, coulomb: Any, stribeck_velocity: Any,
                   exponent: Any) -> Any:
    """g(u) = F_C + (F_S − F_C) exp(−ρ(u)^δ), N: the generalised Stribeck level.

    Parameters
    ----------
    u : float, ndarray or casadi expression
        Sliding velocity, m/s.
    static, coulomb : same kind
        Static friction F_S and Coulomb friction F_C, N.
    stribeck_velocity : same kind
        u_S (> 0), m/s.
    exponent : same kind
        δ (> 0), dimensionless.
    """
    symbolic = _is_casadi(u, static, coulomb, stribeck_velocity, exponent)
    exp = ca.exp if symbolic else np.exp
    if not symbolic and not np.isscalar(u):
        u = np.asarray(u, dtype=float)
    rho = _smooth_ratio(u, stribeck_velocity, symbolic)
    return coulomb + (static - coulomb) * exp(-rho ** exponent)


def stribeck_friction(u: Any, static: Any, coulomb: Any, stribeck_velocity: Any,
                      exponent: Any, viscous: Any) -> Any:
    """The generalised Stribeck map g(u) tanh(u/u_c) + f_v u, N (static limit of
    ``"lugre_stribeck"``); arguments as :func:`stribeck_level`, ``viscous`` f_v in N s/m."""
    symbolic = _is_casadi(u, static, coulomb, stribeck_velocity, exponent, viscous)
    tanh = ca.tanh if symbolic else np.tanh
    u_c = SMOOTHING_FRACTION * stribeck_velocity
    return (stribeck_level(u, static, coulomb, stribeck_velocity, exponent) * tanh(u / u_c)
            + viscous * u)


def stribeck_slope(u: Any, static: Any, coulomb: Any, stribeck_velocity: Any,
                   exponent: Any) -> Any:
    """φ(u) = g(u) tanh(u/u_c)/u of the generalised curve (N s/m), finite at u = 0."""
    symbolic = _is_casadi(u, static, coulomb, stribeck_velocity, exponent)
    u_c = SMOOTHING_FRACTION * stribeck_velocity
    return (stribeck_level(u, static, coulomb, stribeck_velocity, exponent)
            * _tanh_ratio(u / u_c, symbolic) / u_c)


def micro_damping_decay(u: Any, stribeck_velocity: Any) -> Any:
    """exp(−(u/u_S)²): Olsson's fading of the micro-damping σ₁ with speed (1 at rest)."""
    exp = ca.exp if _is_casadi(u, stribeck_velocity) else np.exp
    x = u / stribeck_velocity
    return exp(-x * x)
