"""Simscape friction law: one implementation for floats, numpy and CasADi.

For a velocity u::

    F(u) = √(2e) (F_brk − F_C) exp(−(u/u_St)²) (u/u_St) + F_C tanh(u/u_Coul) + f_v u
    u_St = √2 · u_brk,   u_Coul = u_brk / 10

The law is smooth, so it enters IPOPT as it is.  Every argument may be a float,
a numpy array or a CasADi SX/MX/DM expression (parameters can be symbolic too).
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from .params import FrictionParams

__all__ = ["simscape_friction", "nut_friction_N", "bearing_friction_Nm", "rod_friction_N"]

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
