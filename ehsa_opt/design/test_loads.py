"""What a planned bench test asks of the rig and of the damper.

The rig must deliver the damper's force F = m_eq ẍ + c_eq ẋ + F_rod(ẋ) (inerter, electrical
damping, rod friction) and its power F ẋ at every instant of the test's own motion; the
damper's screw turns at |ẋ|/r, and its generator runs at the back-EMF K_e |ẋ|/r with the
current K_e |ẋ|/(r (R_e + R_i)) and the terminal voltage R_e times that.

* **Sine** x = A sin ωt: F(θ) = −m_eq ω² A sin θ + c_eq(ω) ω A cos θ + F_rod(ω A cos θ);
  the peak of |F| and of F ẋ over the phase θ are taken on a fine phase grid.
* **Triangle** (the protocol of :class:`~ehsa_opt.datasets.protocols.Protocol` with corners
  of ``reversal_s / 2``): the stroke reverses from +v to −v at the constant acceleration
  2 v / t_rev, so just before a reversal ends the inerter's force adds to the damping and
  the friction of the returning stroke::

      F_peak = m_eq 2 v / t_rev + c_eq v + F_rod(v),      P_peak = F_peak v.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

__all__ = ["triangle_peak_force_N", "sine_peak_force_power", "damper_loads"]

#: Phase points of one sine cycle on which the peak force and power are taken (the error
#: of a grid maximum of a smooth periodic function is below 1e-6 relative at this density).
_PHASES = 4096


def triangle_peak_force_N(equivalent_mass_kg: float, damping_Ns_per_m: float,
                          velocity_m_per_s: float, reversal_s: float,
                          rod_N: Callable[[float], float]) -> float:
    """Peak force (N) of a triangle stroke at ±v reversing in ``reversal_s`` (acceleration
    2 v / t_rev): m_eq 2v/t_rev + c_eq v + F_rod(v)."""
    v = float(velocity_m_per_s)
    return (equivalent_mass_kg * 2.0 * v / reversal_s + damping_Ns_per_m * v
            + float(rod_N(v)))


def sine_peak_force_power(equivalent_mass_kg: float, damping_Ns_per_m: float,
                          amplitude_m: float, frequency_hz: float,
                          rod_N: Callable[[np.ndarray], np.ndarray]) -> tuple[float, float]:
    """Peak |F| (N) and peak F ẋ (W) of a sine stroke over its cycle."""
    w = 2.0 * math.pi * frequency_hz
    th = np.linspace(0.0, 2.0 * math.pi, _PHASES, endpoint=False)
    v = w * amplitude_m * np.cos(th)
    f = (-equivalent_mass_kg * w * w * amplitude_m * np.sin(th) + damping_Ns_per_m * v
         + np.asarray(rod_N(v), dtype=float))
    return float(np.max(np.abs(f))), float(np.max(f * v))


def damper_loads(peak_velocity_m_per_s: float, lead_m_per_rad: float,
                 voltage_constant_Vs_per_rad: float, load_ohm: float,
                 internal_resistance_ohm: float) -> dict[str, float]:
    """Peak screw speed (rpm), generator terminal voltage (V) and current (A) at the
    test's peak stroke velocity (quasi-static electrical side: L/R ≪ the test's periods)."""
    omega = abs(peak_velocity_m_per_s) / lead_m_per_rad
    emf = voltage_constant_Vs_per_rad * omega
    current = emf / (load_ohm + internal_resistance_ohm)
    return {"screw_speed_rpm": omega * 60.0 / (2.0 * math.pi),
            "voltage_V": load_ohm * current, "current_A": current}
