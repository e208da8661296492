"""Physical effects that plug into the bench model (SPEC §7–8).

A :class:`Component` adds named parameters (with units and bounds) and
contributes to one or more of the model's hooks:

``coupling_force``  (transmission components only)
    The axial force through the nut–screw transmission as a function of the
    relative displacement δ = x − rθ and velocity δ̇ = v − rω.  A transmission
    component turns the rigid screw into a two-body system (rod, rotor).
``rod_force``
    An extra force at the rod (measured by the load cell), e.g. direction-
    dependent friction.
``rotor_torque``
    An extra load torque on the rotor, e.g. cogging.
``emf``
    A transformation of the generator emf, e.g. a rectifier/brush drop.
``stored_energy`` / ``dissipated_power``
    So that the energy balance of the model still closes.

The bench model never needs rewriting to add an effect: write a subclass, list
it in ``BenchModel(components=[...])``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import casadi as ca

__all__ = ["ParamSpec", "Component", "Backlash", "Compliance", "smooth_ramp", "smooth_step",
           "COMPONENTS", "make_component"]


@dataclass(frozen=True)
class ParamSpec:
    """A named model parameter with unit, default and admissible bounds."""

    name: str
    unit: str
    default: float
    lower: float
    upper: float
    doc: str = ""


def smooth_ramp(z: Any, eps: float) -> Any:
    """max(z, 0) smoothed over a width ``eps``: ½ (z + √(z² + eps²))."""
    return 0.5 * (z + ca.sqrt(z * z + eps * eps))


def smooth_step(z: Any, eps: float) -> Any:
    """Heaviside(z) smoothed over ``eps`` (derivative of :func:`smooth_ramp`)."""
    return 0.5 * (1.0 + z / ca.sqrt(z * z + eps * eps))


def _ramp_energy(z: Any, eps: float) -> Any:
    """∫ smooth_ramp dz, zero at z → −∞ up to a constant (used for stored energy)."""
    s = ca.sqrt(z * z + eps * eps)
    return 0.25 * (z * z + z * s + eps * eps * ca.asinh(z / eps))


class Component:
    """Base class of a model component (see module docstring for the hooks).

    Subclasses set ``name`` and ``parameters`` and override the hooks they need.
    Hook arguments: ``s`` a dict of signals (``t, x, v, a`` of the rod;
    ``theta, omega`` of the rotor; ``i`` the current; ``delta, delta_dot`` the
    transmission deflection when elastic) and ``p`` a dict of this component's
    parameters by name (symbolic).
    """

    name: ClassVar[str] = "component"
    parameters: ClassVar[tuple[ParamSpec, ...]] = ()
    transmission: ClassVar[bool] = False

    def coupling_force(self, s: dict, p: dict) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError

    def rod_force(self, s: dict, p: dict) -> Any:
        return 0.0

    def rotor_torque(self, s: dict, p: dict) -> Any:
        return 0.0

    def emf(self, e: Any, s: dict, p: dict) -> Any:
        return e

    def stored_energy(self, s: dict, p: dict) -> Any:
        return 0.0

    def dissipated_power(self, s: dict, p: dict) -> Any:
        return 0.0

    def defaults(self) -> dict[str, float]:
        return {q.name: q.default for q in self.parameters}

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class Backlash(Component):
    """Axial play between nut and screw with a stiff, damped contact (SPEC §8).

    With δ = x − rθ and h = b/2 (half the gap)::

        pen(δ)   = ramp(δ − h) − ramp(−δ − h)
        f_c      = k_c pen(δ) + c_c δ̇ [step(δ − h) + step(−δ − h)]

    ramp/step are smoothed over ``smoothing_m`` so the model stays smooth for IPOPT.
    At each reversal the rotor coasts through the gap, then the contact closes
    with a short force peak.
    """

    name = "backlash"
    transmission = True
    parameters = (
        ParamSpec("backlash_gap_m", "m", 1e-4, 0.0, 2e-3, "total axial play b"),
        ParamSpec("backlash_contact_stiffness_N_per_m", "N/m", 5e6, 1e4, 1e9,
                  "contact stiffness k_c"),
        ParamSpec("backlash_contact_damping_Ns_per_m", "N s/m", 8e3, 0.0, 1e5,
                  "contact damping c_c"),
    )

    def __init__(self, smoothing_m: float = 2e-6) -> None:
        if not smoothing_m > 0:
            raise ValueError("Backlash: smoothing_m must be > 0 (m)")
        self.smoothing_m = smoothing_m

    def _parts(self, s: dict, p: dict) -> tuple[Any, Any, Any]:
        h = 0.5 * p["backlash_gap_m"]
        d, e = s["delta"], self.smoothing_m
        pen = smooth_ramp(d - h, e) - smooth_ramp(-d - h, e)
        ind = smooth_step(d - h, e) + smooth_step(-d - h, e)
        return h, pen, ind

    def coupling_force(self, s: dict, p: dict) -> Any:
        _, pen, ind = self._parts(s, p)
        return (p["backlash_contact_stiffness_N_per_m"] * pen
                + p["backlash_contact_damping_Ns_per_m"] * s["delta_dot"] * ind)

    def stored_energy(self, s: dict, p: dict) -> Any:
        h, e, d = 0.5 * p["backlash_gap_m"], self.smoothing_m, s["delta"]
        return p["backlash_contact_stiffness_N_per_m"] * (
            _ramp_energy(d - h, e) + _ramp_energy(-d - h, e))

    def dissipated_power(self, s: dict, p: dict) -> Any:
        _, _, ind = self._parts(s, p)
        return p["backlash_contact_damping_Ns_per_m"] * s["delta_dot"] ** 2 * ind


class Compliance(Component):
    """Axial compliance of screw and mounts in series with the transmission.

    f_c = k_s δ + c_s δ̇ with δ = x − rθ.
    """

    name = "compliance"
    transmission = True
    parameters = (
        ParamSpec("compliance_stiffness_N_per_m", "N/m", 2e6, 1e4, 1e9, "axial stiffness k_s"),
        ParamSpec("compliance_damping_Ns_per_m", "N s/m", 1e3, 0.0, 1e5, "axial damping c_s"),
    )

    def coupling_force(self, s: dict, p: dict) -> Any:
        return (p["compliance_stiffness_N_per_m"] * s["delta"]
                + p["compliance_damping_Ns_per_m"] * s["delta_dot"])

    def stored_energy(self, s: dict, p: dict) -> Any:
        return 0.5 * p["compliance_stiffness_N_per_m"] * s["delta"] ** 2

    def dissipated_power(self, s: dict, p: dict) -> Any:
        return p["compliance_damping_Ns_per_m"] * s["delta_dot"] ** 2


#: Registry of components by name (later effects register here too).
COMPONENTS: dict[str, type[Component]] = {"backlash": Backlash, "compliance": Compliance}


def make_component(name: str, **kwargs: Any) -> Component:
    """Instantiate a registered component by name, with a helpful error."""
    if name not in COMPONENTS:
        from ..params import nearest_name
        near = nearest_name(name, tuple(COMPONENTS))
        hint = f"; did you mean '{near}'?" if near else ""
        raise ValueError(f"unknown effect '{name}'{hint} (known: {', '.join(COMPONENTS)})")
    return COMPONENTS[name](**kwargs)

