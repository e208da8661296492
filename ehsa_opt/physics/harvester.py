"""Equivalent mechanical quantities of the harvester (paper Eqs 1–3).

Thin functional front-end over :class:`~ehsa_opt.physics.params.HarvesterParams` so that
frequency-domain code can call them on arrays of ω.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .params import HarvesterParams

__all__ = ["equivalent_mass_kg", "equivalent_damping_Ns_per_m", "equivalent_stiffness_N_per_m",
           "equivalent_impedance"]


def equivalent_mass_kg(h: HarvesterParams) -> float:
    """m_eq = (J_m + J_s) / r², kg (Eq 1)."""
    return h.equivalent_mass_kg()


def equivalent_damping_Ns_per_m(h: HarvesterParams, omega_rad_s: Any,
                                load_ohm: float | None = None) -> Any:
    """c_eq(ω) = K_t K_e R / (r² (R² + L² ω²)), N s/m (Eq 2)."""
    return h.equivalent_damping_Ns_per_m(np.asarray(omega_rad_s, dtype=float), load_ohm)


def equivalent_stiffness_N_per_m(h: HarvesterParams, omega_rad_s: Any,
                                 load_ohm: float | None = None) -> Any:
    """k_eq(ω) = K_t K_e L ω² / (r² (R² + L² ω²)), N/m (Eq 3)."""
    return h.equivalent_stiffness_N_per_m(np.asarray(omega_rad_s, dtype=float), load_ohm)


def equivalent_impedance(h: HarvesterParams, omega_rad_s: Any,
                         load_ohm: float | None = None) -> Any:
    """Complex mechanical impedance Z(jω) = F/V of the frictionless harvester, N s/m.

    Z = jω m_eq + K_t K_e / (r² (R + jω L)), i.e. m_eq (inerter) in parallel with
    c_eq(ω) + k_eq(ω)/(jω).
    """
    w = np.asarray(omega_rad_s, dtype=float)
    R = h.total_resistance_ohm(load_ohm)
    r2 = h.lead_m_per_rad ** 2
    kk = h.torque_constant_Nm_per_A * h.voltage_constant_Vs_per_rad
    elec = 0.0 if np.isinf(R) else kk / (r2 * (R + 1j * w * h.inductance_H))
    return 1j * w * h.equivalent_mass_kg() + elec
