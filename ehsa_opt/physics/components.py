"""Physical effects that plug into the bench model (the discrepancy candidates).

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
``extra_resistance_ohm``
    A resistance in series with the winding, e.g. its temperature rise.
``generator_factor``
    A factor g on the generator constant, applied to the emf K_e ω g *and* the
    torque K_t g i alike (so the energy balance closes without further booking),
    e.g. magnetic saturation; it may depend on the current (``s["current_A"]``
    when the winding has inductance, else see :class:`MagneticSaturation`).
``states`` / ``state_rates``
    Own differential states of a component (named, start at 0), e.g. a
    winding temperature; the rates may use every signal including ``i``.
``stored_energy`` / ``dissipated_power``
    So that the energy balance of the model still closes.

The bench model never needs rewriting to add an effect: write a subclass, list
it in ``BenchModel(components=[...])``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import casadi as ca

__all__ = ["ParamSpec", "Component", "Backlash", "Compliance", "AsymmetricFriction", "Cogging",
           "VoltageDrop", "WindingHeating", "PositionFriction", "MagneticSaturation", "Flexibility",
           "smooth_ramp", "smooth_step", "smooth_abs", "COMPONENTS",
           "make_component"]


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


def smooth_abs(z: Any, eps: float) -> Any:
    """|z| smoothed over ``eps``: √(z² + eps²) − eps (exactly 0 at z = 0)."""
    return ca.sqrt(z * z + eps * eps) - eps


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
    states: ClassVar[tuple[str, ...]] = ()
    #: Attributes that only set :meth:`defaults` (fit starts), not the equations.
    start_attributes: ClassVar[tuple[str, ...]] = ()

    def coupling_force(self, s: dict, p: dict) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError

    def rod_force(self, s: dict, p: dict) -> Any:
        return 0.0

    def rotor_torque(self, s: dict, p: dict) -> Any:
        return 0.0

    def emf(self, e: Any, s: dict, p: dict) -> Any:
        return e

    def extra_resistance_ohm(self, s: dict, p: dict) -> Any:
        return 0.0

    def generator_factor(self, s: dict, p: dict) -> Any:
        """Factor on both generator constants (emf and torque), dimensionless."""
        return 1.0

    def state_rates(self, s: dict, p: dict) -> list[Any]:
        """Time derivatives of :attr:`states` (same order)."""
        return []

    def stored_energy(self, s: dict, p: dict) -> Any:
        return 0.0

    def dissipated_power(self, s: dict, p: dict) -> Any:
        return 0.0

    def defaults(self) -> dict[str, float]:
        return {q.name: q.default for q in self.parameters}

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class Backlash(Component):
    """Axial play between nut and screw with a stiff, damped contact (the effect the paper names).

    With δ = x − rθ and h = b/2 (half the gap)::

        pen(δ)   = ramp(δ − h) − ramp(−δ − h)
        f_c      = k_c pen(δ) + c_c δ̇ [step(δ − h) + step(−δ − h)]

    ramp/step are smoothed over ``smoothing_m`` so the model stays smooth for IPOPT.
    At each reversal the rotor coasts through the gap, then the contact closes
    with a short force peak.

    ``contact_exponent`` n ≠ 1 gives a power-law (Hertzian) contact,
    k_c pen → k_c p_ref (pen/p_ref)^n, with k_c still in N/m: the secant stiffness at the
    reference penetration p_ref = ``reference_m`` (10 µm).  n = 1.5 is Hertz's law for
    a ball on a race (point contact; the stiffness grows with the load, a ball screw's
    balls and an angular-contact bearing's are such contacts); n = 1 (default) is the
    linear law of a lumped, preloaded or line contact.  With the power law the damping is
    Hunt and Crossley's, c_c (pen/p_ref)^n δ̇: it vanishes at first touch (no pull at
    separation) and the coefficient of restitution falls with the impact speed;
    c_c = k_c p_ref χ for their χ (s/m).  Stored energy for n ≠ 1:
    k_c p_ref^(1−n) ramp^(n+1)/(n+1), whose derivative is the elastic force (ramp^n times
    the smoothed step).
    """

    name = "backlash"
    transmission = True
    parameters = (
        ParamSpec("backlash_gap_m", "m", 1e-4, 0.0, 2e-3, "total axial play b"),
        ParamSpec("backlash_contact_stiffness_N_per_m", "N/m", 5e6, 1e4, 1e10,
                  "contact stiffness k_c (steel on steel: 1e8-1e10)"),
        ParamSpec("backlash_contact_damping_Ns_per_m", "N s/m", 8e3, 0.0, 1e5,
                  "contact damping c_c"),
    )

    def __init__(self, smoothing_m: float = 2e-6, contact_exponent: float = 1.0,
                 reference_m: float = 1e-5) -> None:
        if not smoothing_m > 0:
            raise ValueError("Backlash: smoothing_m must be > 0 (m)")
        if not 1.0 <= contact_exponent <= 2.0:
            raise ValueError(f"Backlash: contact_exponent must be in [1, 2] (1 linear, 1.5 "
                             f"Hertz), got {contact_exponent!r}")
        if not reference_m > 0:
            raise ValueError("Backlash: reference_m must be > 0 (m)")
        self.smoothing_m = smoothing_m
        self.contact_exponent = float(contact_exponent)
        self.reference_m = float(reference_m)

    def _law(self, z: Any) -> Any:
        """The contact's elastic force per unit stiffness (m) at an overlap ``z`` (m): the
        smoothed ramp; for n ≠ 1 the derivative of p_ref^(1−n) ramp^(n+1)/(n+1), so the
        stored energy is exact."""
        n, r, e = self.contact_exponent, self.reference_m, self.smoothing_m
        if n == 1.0:
            return smooth_ramp(z, e)
        return r * (smooth_ramp(z, e) / r) ** n * smooth_step(z, e)

    def _parts(self, s: dict, p: dict) -> tuple[Any, Any, Any]:
        h = 0.5 * p["backlash_gap_m"]
        d, e = s["delta"], self.smoothing_m
        pen = self._law(d - h) - self._law(-d - h)
        if self.contact_exponent == 1.0:
            ind = smooth_step(d - h, e) + smooth_step(-d - h, e)
        else:  # Hunt-Crossley: the damping grows with the penetration as the force does
            r = self.reference_m
            ind = (self._law(d - h) + self._law(-d - h)) / r
        return h, pen, ind

    def coupling_force(self, s: dict, p: dict) -> Any:
        _, pen, ind = self._parts(s, p)
        return (p["backlash_contact_stiffness_N_per_m"] * pen
                + p["backlash_contact_damping_Ns_per_m"] * s["delta_dot"] * ind)

    def stored_energy(self, s: dict, p: dict) -> Any:
        h, e, d = 0.5 * p["backlash_gap_m"], self.smoothing_m, s["delta"]
        n, r = self.contact_exponent, self.reference_m
        if n != 1.0:
            return p["backlash_contact_stiffness_N_per_m"] * r ** (1.0 - n) / (n + 1.0) * (
                smooth_ramp(d - h, e) ** (n + 1.0) + smooth_ramp(-d - h, e) ** (n + 1.0))
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


class AsymmetricFriction(Component):
    """Direction-dependent Coulomb and viscous friction at the rod (as on the EMPS rig).

    Adds ``ΔF_C tanh²(v/u_s) + Δf_v |v|`` (|·| smoothed) to the rod force, so that
    the Coulomb level is F_C + ΔF_C for v > 0 and F_C − ΔF_C for v < 0 (likewise
    f_v ± Δf_v) — the EMPS finding (Janot et al. 2019), traced to screw fatigue.
    Its power ``f v`` is booked by the model as component dissipation.

    Parameters
    ----------
    smoothing_m_per_s : float
        u_s of the smoothed sign/absolute value, m/s.
    """

    name = "asymmetric_friction"
    parameters = (
        ParamSpec("asym_coulomb_N", "N", 0.0, -100.0, 100.0,
                  "ΔF_C: Coulomb level is F_C ± ΔF_C for v ≷ 0"),
        ParamSpec("asym_viscous_Ns_per_m", "N s/m", 0.0, -300.0, 300.0,
                  "Δf_v: viscous coefficient is f_v ± Δf_v for v ≷ 0"),
    )

    def __init__(self, smoothing_m_per_s: float = 1e-3) -> None:
        if not smoothing_m_per_s > 0:
            raise ValueError("AsymmetricFriction: smoothing_m_per_s must be > 0 (m/s)")
        self.smoothing_m_per_s = smoothing_m_per_s

    def rod_force(self, s: dict, p: dict) -> Any:
        v, e = s["v"], self.smoothing_m_per_s
        sgn = ca.tanh(v / e)
        return (p["asym_coulomb_N"] * sgn * sgn
                + p["asym_viscous_Ns_per_m"] * smooth_abs(v, e))


class Cogging(Component):
    """Position-periodic (cogging/detent) torque of the generator rotor.

    τ = T_s sin(n θ) + T_c cos(n θ) = T_cog sin(n θ + φ) with
    T_cog = √(T_s² + T_c²), φ = atan2(T_c, T_s); on a rigid bench θ = x/r.
    The sine/cosine form keeps the fit linear in the amplitudes.  The torque is
    conservative on average; its power τ ω is booked as component power.

    Parameters
    ----------
    periods_per_rev : int
        n, cogging periods per rotor revolution (slots/poles), fixed.
    """

    name = "cogging"
    parameters = (
        ParamSpec("cogging_sin_Nm", "N m", 0.0, -0.1, 0.1, "T_s, sine part of the cogging torque"),
        ParamSpec("cogging_cos_Nm", "N m", 0.0, -0.1, 0.1,
                  "T_c, cosine part of the cogging torque"),
    )

    def __init__(self, periods_per_rev: int = 4) -> None:
        if int(periods_per_rev) != periods_per_rev or periods_per_rev < 1:
            raise ValueError("Cogging: periods_per_rev must be a positive integer")
        self.periods_per_rev = int(periods_per_rev)

    def rotor_torque(self, s: dict, p: dict) -> Any:
        nth = self.periods_per_rev * s["theta"]
        return p["cogging_sin_Nm"] * ca.sin(nth) + p["cogging_cos_Nm"] * ca.cos(nth)


class VoltageDrop(Component):
    """Brush or rectifier drop: a smooth dead zone of width ±V_d in the generator emf.

    e' = ramp(e − V_d) − ramp(−e − V_d) (ramp smoothed over ``smoothing_V``); with
    V_d = 0 this is exactly e.  The drop dissipates (e − e') i.
    """

    name = "voltage_drop"
    parameters = (
        ParamSpec("voltage_drop_V", "V", 0.0, 0.0, 5.0, "V_d, brush/diode forward drop"),
    )

    def __init__(self, smoothing_V: float = 0.05) -> None:
        if not smoothing_V > 0:
            raise ValueError("VoltageDrop: smoothing_V must be > 0 (V)")
        self.smoothing_V = smoothing_V

    def emf(self, e: Any, s: dict, p: dict) -> Any:
        vd, eps = p["voltage_drop_V"], self.smoothing_V
        out = smooth_ramp(e - vd, eps) - smooth_ramp(-e - vd, eps)
        s["voltage_drop_lost_V"] = e - out  # read back by dissipated_power
        return out

    def dissipated_power(self, s: dict, p: dict) -> Any:
        return s["voltage_drop_lost_V"] * s["i"]


class WindingHeating(Component):
    """Temperature-dependent winding resistance with a first-order thermal state.

    The winding warms by its own copper loss and cools toward ambient::

        R_i(ΔT) = R_i (1 + α ΔT)
        dΔT/dt  = h R_i(ΔT) i² − ΔT / τ

    with h = 1/C_th the heating rate per joule (K/J; h = 0 is exactly inert) and
    τ = R_th C_th the cooling time (s).  The extra resistance α R_i ΔT is a series
    resistance of the winding; its loss α R_i ΔT i² is booked as component
    dissipation (the heat leaves the mechanical/electrical energy balance, so the
    thermal state stores none of it).  ΔT starts at 0 (winding at ambient).

    Parameters
    ----------
    temperature_coefficient_per_K : float
        α of the winding, 1/K (copper 3.93e-3), fixed.
    """

    name = "winding_heating"
    states = ("winding_temperature_rise_K",)
    parameters = (
        ParamSpec("winding_heating_K_per_J", "K/J", 0.05, 0.0, 10.0,
                  "h = 1/C_th, temperature rise per joule of copper loss"),
        ParamSpec("winding_cooling_time_s", "s", 30.0, 0.1, 1e4,
                  "τ = R_th C_th, thermal time constant of the winding"),
    )

    def __init__(self, temperature_coefficient_per_K: float = 3.93e-3) -> None:
        if not temperature_coefficient_per_K > 0:
            raise ValueError("WindingHeating: temperature_coefficient_per_K must be > 0 (1/K)")
        self.temperature_coefficient_per_K = temperature_coefficient_per_K

    def extra_resistance_ohm(self, s: dict, p: dict) -> Any:
        return (self.temperature_coefficient_per_K * s["internal_resistance_ohm"]
                * s["winding_temperature_rise_K"])

    def state_rates(self, s: dict, p: dict) -> list[Any]:
        dT = s["winding_temperature_rise_K"]
        loss = (s["internal_resistance_ohm"] + self.extra_resistance_ohm(s, p)) * s["i"] ** 2
        return [p["winding_heating_K_per_J"] * loss - dT / p["winding_cooling_time_s"]]

    def dissipated_power(self, s: dict, p: dict) -> Any:
        return self.extra_resistance_ohm(s, p) * s["i"] ** 2


class PositionFriction(Component):
    """Extra Coulomb friction over a window of the stroke (a rough spot, a damaged track).

    With z = (x − x_c)/(L/2) and a smooth window of unit height::

        w(x) = ½ [tanh(k (z + 1)) − tanh(k (z − 1))]     (≈ 1 for |x − x_c| < L/2)
        F    = A w(x) tanh(v/u_s)

    A is the extra friction level inside the window (N; A = 0 is exactly inert,
    A < 0 a smoother stretch), x_c its centre on the stroke (m), L its width (m).
    The force always opposes the motion when A > 0; its power F v is booked by the
    model as component dissipation.  k = 8 makes the edges ~L/16 wide (the
    window stays smooth for IPOPT).

    Parameters
    ----------
    centre_m, width_m : float or None
        Starting values of x_c and L (m) returned by :meth:`defaults` (the
        discrepancy workflow sets them from where the residual lives on the
        stroke); None: the ParamSpec defaults.
    smoothing_m_per_s : float
        u_s of the smoothed sign, m/s.
    edge_sharpness : float
        k of the window edges (dimensionless), fixed.
    """

    name = "position_friction"
    start_attributes = ("centre_m", "width_m")
    parameters = (
        ParamSpec("position_friction_N", "N", 0.0, -100.0, 500.0,
                  "A, extra Coulomb friction inside the stroke window"),
        ParamSpec("position_friction_centre_m", "m", 0.0, -0.05, 0.05,
                  "x_c, centre of the window on the rod stroke"),
        ParamSpec("position_friction_width_m", "m", 0.01, 5e-4, 0.1,
                  "L, width of the window"),
    )

    def __init__(self, centre_m: float | None = None, width_m: float | None = None,
                 smoothing_m_per_s: float = 1e-3, edge_sharpness: float = 8.0) -> None:
        if not smoothing_m_per_s > 0:
            raise ValueError("PositionFriction: smoothing_m_per_s must be > 0 (m/s)")
        if not edge_sharpness > 0:
            raise ValueError("PositionFriction: edge_sharpness must be > 0")
        spec = {q.name: q for q in self.parameters}
        for what, v in (("centre", centre_m), ("width", width_m)):
            q = spec[f"position_friction_{what}_m"]
            if v is not None and not q.lower <= v <= q.upper:
                raise ValueError(f"PositionFriction: {what}_m = {v} outside "
                                 f"[{q.lower}, {q.upper}] m")
        self.centre_m = None if centre_m is None else float(centre_m)
        self.width_m = None if width_m is None else float(width_m)
        self.smoothing_m_per_s = smoothing_m_per_s
        self.edge_sharpness = edge_sharpness

    def defaults(self) -> dict[str, float]:
        out = super().defaults()
        if self.centre_m is not None:
            out["position_friction_centre_m"] = self.centre_m
        if self.width_m is not None:
            out["position_friction_width_m"] = self.width_m
        return out

    def window(self, x: Any, p: dict) -> Any:
        """w(x) of the stroke window (works on floats, numpy arrays and CasADi)."""
        z = (x - p["position_friction_centre_m"]) / (0.5 * p["position_friction_width_m"])
        k = self.edge_sharpness
        return 0.5 * (ca.tanh(k * (z + 1)) - ca.tanh(k * (z - 1)))

    def rod_force(self, s: dict, p: dict) -> Any:
        return (p["position_friction_N"] * self.window(s["x"], p)
                * ca.tanh(s["v"] / self.smoothing_m_per_s))


class MagneticSaturation(Component):
    """Generator constant falling with the current (magnetic saturation of the iron).

    Both constants fall by the same factor (one flux linkage)::

        g(i) = 1 / (1 + β i²),    e = K_e ω g(i),    τ_gen = K_t g(i) i

    β ≥ 0 (1/A²; β = 0 is exactly inert; 1/√β is the current at which the
    constant has halved).  Because g multiplies emf and torque alike the generator
    still converts K_t g i ω = e i (K_e = K_t in SI): the energy balance closes
    with no extra booking, the loss appears as less current, not as heat.

    With winding inductance the current is a state and g uses it.  Without
    inductance (quasi-static i = e/R) i solves the cubic i R (1 + β i²) = K_e ω,
    R = R_e + R_i, in closed form (Cardano; the one real root) — exact when the
    winding carries no other emf or resistance effect; otherwise g is evaluated
    at that current while the rest of the model still uses its own (energy still
    closes, as g is applied to emf and torque alike).  The closed form is
    i = 2/√(3β) · sinh(⅓ asinh(3 e0 √(3β) / (2R))), which tends to e0/R as β → 0.
    """

    name = "magnetic_saturation"
    parameters = (
        ParamSpec("saturation_per_A2", "1/A^2", 0.0, 0.0, 100.0,
                  "β of g(i) = 1/(1 + β i²)"),
    )

    def generator_factor(self, s: dict, p: dict) -> Any:
        beta = p["saturation_per_A2"]
        i = s.get("current_A")
        if i is None:  # quasi-static: the real root of R β i³ + R i − e0 = 0 (sinh form
            # of Cardano's root, accurate down to β → 0 where it tends to e0/R)
            R = s["load_ohm"] + s["internal_resistance_ohm"]
            e0 = s["unsaturated_emf_V"]
            sb = ca.sqrt(3.0 * ca.fmax(beta, 1e-30))
            root = 2.0 / sb * ca.sinh(ca.asinh(1.5 * e0 / R * sb) / 3.0)
            i = ca.if_else(beta > 0, root, e0 / R)
        return 1.0 / (1.0 + beta * i * i)


class Flexibility(Component):
    """A flexibility of the mechanism: the load as a second mass on a spring and damper.

    Two masses joined by a spring k and damper c: the driven side (where the force
    acts and the position is measured) and the load side, whose position is a state.
    With the load mass m, ω = 2π f = √(k/m) and ζ = c/(2 m ω), the deflection
    d = x − x_load obeys::

        d̈ = a − ω² d − 2ζω ḋ          (the load is pulled through the spring)
        F_extra = m (ω² d + 2ζω ḋ − a)  (= −m d̈: the load's inertia seen through it)

    so the measured force is (M − m) a + k d + c ḋ + friction + offset, M the total
    inertia of the rig (``inertia_kg``).  Rigid (ω → ∞, or m = 0: exactly inert)
    it is the one-mass model.  The state starts at rest (d = ḋ = 0).  Written for a
    rig without generator (EMPS: motor side measured, load side a state); on a
    generator bench the elastic transmission is :class:`Compliance`.

    Parameters
    ----------
    frequency_hz : float or None
        Starting value of f returned by :meth:`defaults` (the discrepancy workflow
        sets it from the residual's spectral peak); None: the ParamSpec default.
    """

    name = "flexibility"
    states = ("flex_deflection_m", "flex_deflection_rate_m_per_s")
    start_attributes = ("frequency_hz",)
    parameters = (
        ParamSpec("flex_load_mass_kg", "kg", 0.0, 0.0, 1e4,
                  "m, the load-side mass beyond the spring"),
        ParamSpec("flex_frequency_hz", "Hz", 100.0, 1.0, 2000.0,
                  "f = √(k/m)/2π, the load's resonance with the driven side held"),
        ParamSpec("flex_damping_ratio", "1", 0.1, 1e-3, 5.0, "ζ = c/(2 m ω)"),
    )

    def __init__(self, frequency_hz: float | None = None) -> None:
        q = self.parameters[1]
        if frequency_hz is not None and not q.lower <= frequency_hz <= q.upper:
            raise ValueError(f"Flexibility: frequency_hz = {frequency_hz} outside "
                             f"[{q.lower}, {q.upper}] Hz")
        self.frequency_hz = None if frequency_hz is None else float(frequency_hz)

    def defaults(self) -> dict[str, float]:
        out = super().defaults()
        if self.frequency_hz is not None:
            out["flex_frequency_hz"] = self.frequency_hz
        return out

    @staticmethod
    def _w(p: dict) -> Any:
        return 2 * ca.pi * p["flex_frequency_hz"]

    def _spring(self, s: dict, p: dict) -> Any:
        """(k d + c ḋ)/m."""
        w = self._w(p)
        return (w * w * s["flex_deflection_m"]
                + 2 * p["flex_damping_ratio"] * w * s["flex_deflection_rate_m_per_s"])

    def state_rates(self, s: dict, p: dict) -> list[Any]:
        return [s["flex_deflection_rate_m_per_s"], s["a"] - self._spring(s, p)]

    def rod_force(self, s: dict, p: dict) -> Any:
        return p["flex_load_mass_kg"] * (self._spring(s, p) - s["a"])

    @staticmethod
    def stiffness_N_per_m(p: dict) -> float:
        """k = m ω² of a parameter set (N/m)."""
        return float(p["flex_load_mass_kg"] * (2 * 3.141592653589793
                                               * p["flex_frequency_hz"]) ** 2)

    def stored_energy(self, s: dict, p: dict) -> Any:
        # the model books ½ M v² for the whole rig: the load moves at v − ḋ, and
        # the spring holds ½ k d²
        m, w = p["flex_load_mass_kg"], self._w(p)
        v, dd, d = s["v"], s["flex_deflection_rate_m_per_s"], s["flex_deflection_m"]
        return 0.5 * m * ((v - dd) ** 2 - v ** 2 + (w * d) ** 2)

    def dissipated_power(self, s: dict, p: dict) -> Any:
        # only the damper dissipates; the model books the power of rod_force as
        # dissipation, so that booking is taken back here
        m, w = p["flex_load_mass_kg"], self._w(p)
        dd = s["flex_deflection_rate_m_per_s"]
        return 2 * p["flex_damping_ratio"] * w * m * dd ** 2 - self.rod_force(s, p) * s["v"]


#: Registry of components by name (later effects register here too).
COMPONENTS: dict[str, type[Component]] = {
    "backlash": Backlash, "compliance": Compliance, "asymmetric_friction": AsymmetricFriction,
    "cogging": Cogging, "voltage_drop": VoltageDrop, "winding_heating": WindingHeating,
    "position_friction": PositionFriction, "magnetic_saturation": MagneticSaturation,
    "flexibility": Flexibility}


def make_component(name: str, **kwargs: Any) -> Component:
    """Instantiate a registered component by name, with a helpful error."""
    if name not in COMPONENTS:
        from .params import nearest_name
        near = nearest_name(name, tuple(COMPONENTS))
        hint = f"; did you mean '{near}'?" if near else ""
        raise ValueError(f"unknown effect '{name}'{hint} (known: {', '.join(COMPONENTS)})")
    return COMPONENTS[name](**kwargs)

