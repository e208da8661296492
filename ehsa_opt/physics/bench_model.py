"""Symbolic CasADi model of the harvester on a displacement-controlled bench.

Prescribed rod motion x(t), v = ẋ, a = ẍ (inputs); measured force and generator
voltage (outputs).  With r = lead/2π, J = J_m + J_s, R = R_e + R_i:

Rigid transmission (default; rotor θ = x/r, ω = v/r, α = a/r)::

    L di/dt = e − R i,          e = K_e g ω  (possibly transformed by components)
    f_t     = (J α + K_t g i + T_b(ω) + Σ τ_extra) / r

g = Π generator_factor (1 without such a component, e.g. magnetic saturation)
scales both generator constants, so the conversion K_t g i ω = e i stays lossless.
    F       = f_t + F_ns(v) + Σ f_extra,       V = R_e i

Elastic transmission (a component with ``transmission = True``, e.g. backlash;
states θ, ω)::

    δ = x − rθ,  δ̇ = v − rω,   f_t = coupling_force(δ, δ̇)
    J ω̇ = r f_t − K_t g i − T_b(ω) − Σ τ_extra
    F   = f_t + F_ns(v) + Σ f_extra

Rig without a generator (``generator=False``, e.g. EMPS): no winding, i ≡ 0 and
V ≡ 0; two more parameters ``inertia_kg`` (M) and ``offset_N`` (F_0) enter the
rod force, and on a rigid transmission the rotor inertia is lumped into M::

    F = M a + F_0 + (T_b(ω) + Σ τ_extra) / r + F_ns(v) + Σ f_extra      (rigid)
    F = f_t + M a + F_0 + F_ns(v) + Σ f_extra                           (elastic; J kept)

Nut–screw friction F_ns acts at the rod velocity; bearing friction T_b on the
rotor speed.  With L_i = 0 the current is algebraic, i = e/R (the
exact quasi-static limit).  The equivalent rigid-model force is
F = m_eq a + K_t i/r + F_ns(v) + T_b(v/r)/r (paper Eq 4).

Friction law (``friction_law``): ``"static"`` (default) F_ns(v) is the Simscape map;
``"lugre"`` gives the friction a bristle state whose steady state is that map
(:mod:`~ehsa_opt.physics.friction`), carried as the bristle force ``bristle_force_N``
(F_b = σ₀ z, N; z the bristle deflection)::

    ż = v − σ₀ z / φ(v),     F_fr = σ₀ z + σ₁ ż + f_v v

with σ₀, σ₁ the parameters ``presliding_stiffness_N_per_m`` and
``presliding_damping_Ns_per_m``.  ``"lugre_stribeck"`` is the same bristle with the
generalised Stribeck curve as its steady state (one more parameter, the exponent
``stribeck_exponent``) and Olsson's micro-damping σ₁ exp(−(v/u_S)²)
(:mod:`~ehsa_opt.physics.friction`).  On a rigid transmission the bristle carries the rod's
whole friction, F_ns(v) + T_b(v/r)/r: φ = φ_ns(v) + φ_b(v/r)/r², f_v + t_v/r² (the
nut/bearing split is not identifiable there, and a bristle on the nut alone lets a fit
move the friction to the bearing until the bristle's rate σ₀/φ diverges).  With a
transmission component the bristle is the nut's and the bearing keeps its static map on
the rotor speed.

Parameters are a flat vector ``p`` in :attr:`BenchModel.param_names` order:
``load_ohm``, the eight friction parameter names, then (``generator=False``
only) ``inertia_kg`` and ``offset_N``, then (dynamic laws only) σ₀ and
σ₁ (and δ under ``"lugre_stribeck"``), then each component's parameters.  States are named in :attr:`BenchModel.state_names`.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import casadi as ca
import numpy as np

from .components import Component, ParamSpec
from .base_parameters import PARAMETERS
from .friction import (
    BENCH_FRICTION_LAWS,
    LAW_PARAMETER_NAMES,
    STRIBECK_EXPONENT,
    micro_damping_decay,
    stribeck_slope,
    bearing_friction_Nm,
    bearing_static_slope,
    bristle_force_rate,
    nut_friction_N,
    nut_static_slope,
    presliding_force,
)
from .params import FRICTION_NAMES, FrictionParams, HarvesterParams

__all__ = ["BenchModel", "RIG_PARAM_NAMES", "BRISTLE_STATE"]

#: Name of the LuGre bristle state: the bristle force F_b = σ₀ z (N).
BRISTLE_STATE = "bristle_force_N"

#: Extra parameters of a rig without generator: rod inertia M (kg) and force offset F_0 (N).
RIG_PARAM_NAMES: tuple[str, ...] = ("inertia_kg", "offset_N")


class BenchModel:
    """Harvester on the bench as CasADi functions of (state, input, parameters).

    Parameters
    ----------
    harvester : HarvesterParams
        Mechanical and electrical constants (``load_ohm`` is ignored here: the
        load is the parameter ``load_ohm`` of each simulation).
    components : sequence of Component
        Extra physical effects; at most one may be a transmission component.
    generator : bool
        False for a rig without generator (no winding, no voltage; adds the
        parameters ``inertia_kg`` and ``offset_N``, see the module docstring).
    friction_law : {"static", "lugre", "lugre_stribeck"}
        The nut–screw friction law (see the module docstring).

    Attributes
    ----------
    state_names : list[str]
        Names of the differential states (``current_A``, ``rotor_angle_rad``,
        ``rotor_speed_rad_per_s``, ...).
    param_names : list[str]
        Names of the entries of the parameter vector.
    param_specs : dict[str, ParamSpec]
        Units, defaults and bounds of the component parameters.
    ode : casadi.Function
        ``(x, u, p) -> xdot`` with u = [x_rod_m, v_rod_m_s, a_rod_m_s2].
    outputs : casadi.Function
        ``(x, u, p) -> [force_N, voltage_V]``.
    energy : casadi.Function
        ``(x, u, p) -> [power_in_W, load_power_W, winding_power_W, friction_power_W,
        component_dissipation_W, stored_energy_J]``.
    """

    def __init__(self, harvester: HarvesterParams | None = None,
                 components: Sequence[Component] = (), generator: bool = True,
                 friction_law: str = "static") -> None:
        if friction_law not in BENCH_FRICTION_LAWS:
            raise ValueError(f"BenchModel: friction_law must be one of {BENCH_FRICTION_LAWS}, got "
                             f"{friction_law!r}")
        self.friction_law = friction_law
        self.harvester = harvester or HarvesterParams()
        self.generator = bool(generator)
        self.components = list(components)
        trans = [c for c in self.components if c.transmission]
        if len(trans) > 1:
            raise ValueError("BenchModel: at most one transmission component "
                             f"(got {[c.name for c in trans]}); combine them into one")
        self.transmission = trans[0] if trans else None
        names = [c.name for c in self.components]
        if len(set(names)) != len(names):
            raise ValueError(f"BenchModel: duplicate components {names}")
        self.param_specs: dict[str, ParamSpec] = {}
        for c in self.components:
            for q in c.parameters:
                self.param_specs[q.name] = q
        self.rig_names = [] if self.generator else list(RIG_PARAM_NAMES)
        self.law_names = list(LAW_PARAMETER_NAMES[friction_law])
        self.param_names = ["load_ohm", *FRICTION_NAMES, *self.rig_names, *self.law_names,
                            *self.param_specs]
        self._build()

    # ------------------------------------------------------------------ construction
    @property
    def has_inductance(self) -> bool:
        return self.generator and self.harvester.inductance_H > 0.0

    def _build(self) -> None:
        h = self.harvester
        r, J = h.lead_m_per_rad, h.total_inertia_kgm2
        Ke, Kt, L, Ri = (h.voltage_constant_Vs_per_rad, h.torque_constant_Nm_per_A,
                         h.inductance_H, h.internal_resistance_ohm)
        u = ca.SX.sym("u", 3)
        p = ca.SX.sym("p", len(self.param_names))
        xr, vr, ar = u[0], u[1], u[2]
        Re = p[0]
        fr = [p[1 + k] for k in range(8)]
        nrig = len(self.rig_names)
        prig = {n: p[9 + k] for k, n in enumerate(self.rig_names)}
        nlaw = len(self.law_names)
        plaw = {n: p[9 + nrig + k] for k, n in enumerate(self.law_names)}
        pc = {n: p[9 + nrig + nlaw + k] for k, n in enumerate(self.param_specs)}

        states: list[tuple[str, Any]] = []
        if self.transmission is not None:
            theta = ca.SX.sym("rotor_angle_rad")
            omega = ca.SX.sym("rotor_speed_rad_per_s")
            states += [("rotor_angle_rad", theta), ("rotor_speed_rad_per_s", omega)]
        else:
            theta, omega = xr / r, vr / r
        i_sym = ca.SX.sym("current_A") if self.has_inductance else None
        if i_sym is not None:
            states.insert(0, ("current_A", i_sym))
        z_sym = ca.SX.sym(BRISTLE_STATE) if self.law_names else None
        if z_sym is not None:
            states.append((BRISTLE_STATE, z_sym))

        s: dict[str, Any] = {"x": xr, "v": vr, "a": ar, "theta": theta, "omega": omega,
                             "internal_resistance_ohm": Ri}
        comp_states = [(c, n, ca.SX.sym(n)) for c in self.components for n in c.states]
        for _, n, sym in comp_states:
            if n in s or any(n == m for m, _ in states):
                raise ValueError(f"BenchModel: component state name '{n}' is taken")
            s[n] = sym
            states.append((n, sym))
        if self.transmission is not None:
            s["delta"] = xr - r * theta
            s["delta_dot"] = vr - r * omega
        # generator factor g (e.g. saturation): on the emf and the torque alike
        s["load_ohm"], s["unsaturated_emf_V"] = Re, Ke * omega
        if i_sym is not None:
            s["current_A"] = i_sym
        g = ca.SX(1)
        if self.generator:
            for c in self.components:
                g = g * c.generator_factor(s, pc)
        e = Ke * g * omega
        for c in self.components:
            e = c.emf(e, s, pc)
        R = Re + Ri + sum((c.extra_resistance_ohm(s, pc) for c in self.components), ca.SX(0))
        if not self.generator:
            i = ca.SX(0)
        else:
            i = i_sym if i_sym is not None else e / R
        s["i"] = i
        F_ns, T_b, z_rate = self._friction(vr, omega, fr, plaw, z_sym)
        tau_extra = sum((c.rotor_torque(s, pc) for c in self.components), ca.SX(0))
        f_extra = sum((c.rod_force(s, pc) for c in self.components), ca.SX(0))
        rates: dict[str, Any] = {}
        for c in self.components:
            rc = c.state_rates(s, pc)
            if len(rc) != len(c.states):
                raise ValueError(f"BenchModel: {c.name}.state_rates returned {len(rc)} rates "
                                 f"for {len(c.states)} states")
            rates.update(zip(c.states, rc))
        if i_sym is not None:
            rates["current_A"] = (e - R * i_sym) / L
        if z_rate is not None:
            rates[BRISTLE_STATE] = z_rate
        if self.transmission is not None:
            f_t = self.transmission.coupling_force(s, pc)
            rates["rotor_angle_rad"] = omega
            rates["rotor_speed_rad_per_s"] = (r * f_t - Kt * g * i - T_b - tau_extra) / J
        elif self.generator:
            f_t = (J * ar / r + Kt * g * i + T_b + tau_extra) / r
        else:  # rotor inertia lumped into inertia_kg
            f_t = (T_b + tau_extra) / r
        f_rig = prig["inertia_kg"] * ar + prig["offset_N"] if not self.generator else 0.0
        force = f_t + F_ns + f_extra + f_rig
        volt = Re * i

        # energy bookkeeping: power in = load + winding + friction + dissipation + d(stored)/dt
        # The emf transformation is lossless only if identity; components that change
        # the emf report their own dissipation (e.g. a voltage drop dissipates (Ke ω − e) i).
        stored = 0.5 * J * omega ** 2 if (self.generator or self.transmission is not None) \
            else 0.5 * prig["inertia_kg"] * vr ** 2
        if not self.generator and self.transmission is not None:
            stored += 0.5 * prig["inertia_kg"] * vr ** 2
        comp_offset = prig["offset_N"] * vr if not self.generator else 0.0
        if i_sym is not None:
            stored += 0.5 * L * i_sym ** 2
        friction_power = F_ns * vr + T_b * omega
        if z_sym is not None:  # the bristle spring stores ½ σ₀ z² = ½ F_b²/σ₀, not dissipated
            stored += 0.5 * z_sym ** 2 / plaw["presliding_stiffness_N_per_m"]
            friction_power -= z_sym * z_rate / plaw["presliding_stiffness_N_per_m"]
        for c in self.components:
            stored += c.stored_energy(s, pc)
        comp_diss = sum((c.dissipated_power(s, pc) for c in self.components), ca.SX(0))
        comp_diss += tau_extra * omega + f_extra * vr + comp_offset
        energy = ca.vertcat(force * vr, Re * i ** 2, Ri * i ** 2, friction_power,
                            comp_diss, stored)

        self.state_names = [n for n, _ in states]
        xs = ca.vertcat(*[sym for _, sym in states]) if states else ca.SX(0, 1)
        xdot = ca.vertcat(*[rates[n] for n in self.state_names]) if states else ca.SX(0, 1)
        args, names = [xs, u, p], ["x", "u", "p"]
        self.ode = ca.Function("bench_ode", args, [xdot], names, ["xdot"])
        self.outputs = ca.Function("bench_out", args, [ca.vertcat(force, volt)], names, ["y"])
        self.energy = ca.Function("bench_energy", args, [energy], names, ["e"])

    def _friction(self, vr: Any, omega: Any, fr: list, plaw: dict,
                  z_sym: Any) -> tuple[Any, Any, Any]:
        """Nut force F_ns (N), bearing torque T_b (N m) and the bristle-force rate (N/s,
        None under the static law).  On a rigid transmission the bristle carries the
        rod's whole friction and T_b is 0."""
        T_b = bearing_friction_Nm(omega, fr)
        if z_sym is None:
            return nut_friction_N(vr, fr), T_b, None
        r = self.harvester.lead_m_per_rad
        slope, viscous = self._rod_slope(vr, omega, fr, plaw), fr[3]
        damping = plaw["presliding_damping_Ns_per_m"]
        if self.friction_law == "lugre_stribeck":
            damping = damping * micro_damping_decay(vr, fr[2])
        if self.transmission is None:
            viscous = viscous + fr[7] / r ** 2
            T_b = ca.SX(0)
        sig0 = plaw["presliding_stiffness_N_per_m"]
        z_rate = bristle_force_rate(z_sym, vr, slope, sig0)
        F_ns = presliding_force(z_sym, z_rate, vr, sig0, damping, viscous)
        return F_ns, T_b, z_rate

    def _rod_slope(self, vr: Any, omega: Any, fr: Any, plaw: Mapping[str, Any]) -> Any:
        """φ of the bristle (N s/m): the nut's curve, plus the bearing's at the rod on a
        rigid transmission."""
        if self.friction_law == "lugre_stribeck":
            slope = stribeck_slope(vr, fr[0], fr[1], fr[2], plaw[STRIBECK_EXPONENT])
        else:
            slope = nut_static_slope(vr, fr)
        if self.transmission is None:
            r = self.harvester.lead_m_per_rad
            slope = slope + bearing_static_slope(omega, fr) / r ** 2
        return slope

    # ------------------------------------------------------------------ helpers
    @property
    def n_states(self) -> int:
        return len(self.state_names)

    def param_vector(self, load_ohm: float, friction: FrictionParams | None = None,
                     effects: Mapping[str, float] | None = None) -> np.ndarray:
        """Assemble ``p``; component parameters default to their ParamSpec defaults.

        For ``generator=False`` ``effects`` may also set ``inertia_kg`` and
        ``offset_N`` (defaults 0); with ``friction_law="lugre"`` σ₀ and σ₁ (defaults
        their declared typical values)."""
        friction = friction or FrictionParams()
        values = {n: 0.0 for n in self.rig_names}
        values.update({n: PARAMETERS[n].typical for n in self.law_names})
        values.update({q.name: q.default for q in self.param_specs.values()})
        for k, v in (effects or {}).items():
            if k not in values:
                from .params import nearest_name
                near = nearest_name(k, tuple(values))
                hint = f"; did you mean '{near}'?" if near else ""
                raise ValueError(f"unknown effect parameter '{k}'{hint}")
            values[k] = float(v)
        return np.array([float(load_ohm), *friction.as_array(), *values.values()])

    def initial_state(self, u0: Sequence[float], p: Sequence[float]) -> np.ndarray:
        """A consistent initial state: rotor following the rod, current at its
        quasi-static value e/R, bristle force at its steady state s(v)."""
        h = self.harvester
        r = h.lead_m_per_rad
        out = []
        for n in self.state_names:
            if n == "current_A":
                out.append(h.voltage_constant_Vs_per_rad * u0[1] / r
                           / (p[0] + h.internal_resistance_ohm))
            elif n == "rotor_angle_rad":
                out.append(u0[0] / r)
            elif n == "rotor_speed_rad_per_s":
                out.append(u0[1] / r)
            elif n == BRISTLE_STATE:
                nrig = len(self.rig_names)
                plaw = {n: float(p[9 + nrig + k]) for k, n in enumerate(self.law_names)}
                v0 = float(u0[1])
                slope = float(self._rod_slope(v0, v0 / r, [float(x) for x in p[1:9]], plaw))
                out.append(slope * u0[1])
            else:  # component states start at rest
                out.append(0.0)
        return np.array(out, dtype=float)

    def __repr__(self) -> str:
        gen = "" if self.generator else ", generator=False"
        gen += "" if self.friction_law == "static" else f", friction_law={self.friction_law!r}"
        return f"BenchModel(components={self.components!r}, states={self.state_names}{gen})"

