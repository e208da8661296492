"""Equations of motion of the second generator, written from physics (independent of the
product's models and of its candidate library).

The rig
-------
The rod motion x(t) is prescribed by the bench actuator; the load cell sits between the
actuator and the damper, so the measured force is the force the rod transmits.  The
chain is::

    rod x(t) --[mount spring k_m, c_m]--> nut/carriage (mass m_n) --[axial play, contact]-->
    ball screw (angle theta; screw + rotor inertia J) --> DC generator (K_e, K_t, R_i, L_i)
    --[diodes]--> load R_e

Without compliance the mount is rigid (nut = rod); without backlash the nut is geared
rigidly to the screw (x_n = r theta, r = lead / 2 pi) and its mass is reflected into the
screw inertia.  The states present are chosen by the effects that are switched on.

Friction (not the product's law)
--------------------------------
Both friction pairs are LuGre models (Canudas de Wit et al. 1995) with a Stribeck curve
of exponent ``alpha`` and Olsson's velocity-decaying micro-damping::

    g(u)  = F_C,dir + (F_S - F_C,dir) exp(-|u / u_S|^alpha)
    dz/dt = u - sigma0 |u| z / g(u)
    F     = sigma0 z + sigma1 exp(-(u / u_S)^2) dz/dt + sigma2,dir u

for the nut (u = r omega, N) and the bearings (u = omega, N m).  ``dir`` makes the
nut's Coulomb level and viscous slope direction-dependent (the catalogue effect
"asymmetric friction" with another law).  The nut-friction level can be modulated by a
screw-angle ripple (ball recirculation) and a position-dependent preload (lead error).

Electrical side
---------------
L_i di/dt = K_e phi(i) omega - (R_i(T) + R_e) i - V_D(i), load voltage V = R_e i,
generator torque K_t phi(i) i.  phi(i) = 1 / sqrt(1 + (i / i_sat)^2) is a flux
saturation, V_D(i) = 2 n V_T asinh(i / (2 I_S)) two Shockley diodes in the current path,
R_i(T) = R_i0 (1 + alpha_Cu (T - T_amb)) with the copper energy balance
C_th dT/dt = R_i(T) i^2 - (T - T_amb) / R_th.

Contacts and other effects
--------------------------
* axial play of total width b closed by a Hunt-Crossley contact
  F_c = k_c p^n (1 + chi dp/dt) (clamped >= 0), p the penetration, n = 1.5 (Hertz);
* cogging: a non-sinusoidal detent torque T_cog = T_0 sum_j c_j sin(j N theta + psi_j)
  (three harmonics of N detents per revolution);
* eddy-current damping (a conducting sleeve on the rotor): T_e = c_e omega / (1 +
  (omega / omega_c)^2), the Wouterse law, linear at low speed, falling above omega_c.

Sensors
-------
Both measured channels can have their own dynamics, a second-order low-pass with unity
gain at DC (natural frequency f_c, damping ratio zeta, omega_c = 2 pi f_c)::

    y'' + 2 zeta omega_c y' + omega_c^2 y = omega_c^2 u

* force channel: u the force the rod transmits, y the load-cell reading (a piezo or
  strain-gauge cell with its seismic mass and its amplifier: ``load_cell_hz``,
  ``load_cell_damping``);
* voltage channel: u = R_e i, y the recorded voltage (the acquisition's anti-alias filter
  or an isolation amplifier, a 2nd-order Butterworth has zeta = 0.707:
  ``voltage_sensor_hz``, ``voltage_sensor_damping``).

At f_c the gain is 1 / (2 zeta) and the phase -90 deg; well below f_c the filter is a
delay of zeta / (pi f_c) (its group delay at DC) -- a pure delay is its limit.

Drift over a campaign (thermal run-in of the grease)
----------------------------------------------------
The grease of the nut warms with the power its friction dissipates and cools to the
ambient through a thermal resistance, a first-order lumped model (as the joint
temperature of Simoni, Beschi, Legnani & Visioli 2017, "Modelling the temperature in
joint friction of industrial manipulators", Robotica, doi:10.1017/S0263574717000509)::

    C_g d(theta)/dt = P_nut - theta / R_g,     P_nut = F_n u - sigma0 z dz/dt >= 0

with theta the temperature rise over the ambient (K).  Friction falls with temperature
(Bittencourt, Wernholt, Sander-Tavallaey & Brogardh 2010, "An extended friction model
to capture load and temperature effects in robot joints", IROS, found a robot joint's
friction to depend on its temperature strongly enough to need it in the friction model);
the law here is Reynolds' exponential fall of a lubricant's viscosity with temperature,
of about 3 %/K near room temperature for a mineral oil (an ISO VG 68 oil of viscosity
index 100 goes from 68 mm^2/s at 40 C to about 8.7 mm^2/s at 100 C), with a smaller
coefficient for the boundary-lubricated Coulomb level::

    F_C,dir, F_S  x exp(-beta_C theta),      sigma2,dir  x exp(-beta_v theta)

(``drift_coulomb_per_K`` = beta_C, ``drift_viscous_per_K`` = beta_v, ``grease_capacity_J_per_K``
= C_g, ``grease_resistance_K_per_W`` = R_g).  theta is a state of the whole campaign: the
campaign (:mod:`.campaign`) runs its tests in a stated order and carries theta from one
test to the next, cooling it over the pause between them (theta x exp(-pause / (R_g C_g))).
C_g is the capacity of the fast thermal mode (grease and the raceway surface that heat
first), not of the whole nut.

Energy bookkeeping: with ``audit=True`` three quadrature states integrate the input
work of the rod, the dissipated energy (friction, contact and mount damping, eddy
currents, copper and diode losses) and the electrical energy delivered to the load;
:meth:`RigModel.stored_energy` gives kinetic + magnetic + elastic + bristle + detent
potential energy, so the balance can be checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["Harvester", "LuGre", "Effects", "RigModel", "THERMAL_VOLTAGE_V"]

THERMAL_VOLTAGE_V = 0.025852  # k T / q at 300 K
_COG_SHAPE = ((1.0, 0.0), (0.45, 0.7), (0.2, 1.9))  # (c_j, psi_j) of the detent harmonics


@dataclass(frozen=True)
class Harvester:
    """The harvester of a rig (SI units).  ``nut_mass_kg`` is the nut + carriage mass."""

    rotor_inertia_kgm2: float = 9.0e-6
    screw_inertia_kgm2: float = 2.6e-5
    lead_m: float = 0.010
    winding_resistance_ohm: float = 2.4
    emf_constant_Vs_per_rad: float = 0.085
    torque_constant_Nm_per_A: float = 0.085
    inductance_H: float = 0.9e-3
    nut_mass_kg: float = 0.35

    @property
    def r(self) -> float:
        return self.lead_m / (2 * math.pi)

    @property
    def inertia_kgm2(self) -> float:
        return self.rotor_inertia_kgm2 + self.screw_inertia_kgm2


@dataclass(frozen=True)
class LuGre:
    """LuGre friction with a Stribeck exponent and direction-dependent Coulomb/viscous terms.

    Units: force-like quantities in N (nut) or N m (bearings); ``stiffness`` per m or per
    rad; velocities in m/s or rad/s."""

    coulomb_pos: float
    coulomb_neg: float
    static: float
    stribeck_velocity: float
    exponent: float
    stiffness: float
    micro_damping: float
    viscous_pos: float
    viscous_neg: float

    def level(self, u: float) -> float:
        fc = self.coulomb_pos if u >= 0 else self.coulomb_neg
        return fc + (self.static - fc) * math.exp(-abs(u / self.stribeck_velocity) ** self.exponent)

    def steady(self, u):
        """Steady-state (sliding) friction curve, vectorised."""
        u = np.asarray(u, dtype=float)
        fc = np.where(u >= 0, self.coulomb_pos, self.coulomb_neg)
        g = fc + (self.static - fc) * np.exp(-np.abs(u / self.stribeck_velocity) ** self.exponent)
        return np.sign(u) * g + np.where(u >= 0, self.viscous_pos, self.viscous_neg) * u


@dataclass(frozen=True)
class Effects:
    """Effects switched on (0 / None = off).  See the module docstring for the laws."""

    # catalogue effects, other laws
    play_m: float = 0.0                       # total axial play b
    contact_stiffness: float = 2e9            # k_c, N / m^1.5
    contact_exponent: float = 1.5
    contact_damping_s_per_m: float = 0.3      # chi (Hunt-Crossley)
    mount_stiffness_N_per_m: float = 0.0      # k_m (0: rigid mount)
    mount_damping_Ns_per_m: float = 200.0
    cogging_Nm: float = 0.0
    cogging_detents: int = 6
    diode_saturation_A: float = 0.0           # I_S (0: no diodes)
    diode_ideality: float = 1.05
    thermal_capacity_J_per_K: float = 0.0     # C_th (0: isothermal)
    thermal_resistance_K_per_W: float = 5.0
    copper_coefficient_per_K: float = 0.00393
    saturation_current_A: float = 0.0         # i_sat (0: linear magnetics)
    # not in the catalogue
    ripple_depth: float = 0.0                 # nut friction x (1 + eps sin(N_b theta + ...))
    ripple_per_rev: float = 7.3
    preload_gain: float = 0.0                 # nut friction x (1 + kappa (x_n / preload_span)^2)
    preload_span_m: float = 0.01
    eddy_Nms_per_rad: float = 0.0             # c_e
    eddy_corner_rad_per_s: float = 60.0       # omega_c
    voltage_delay_s: float = 0.0              # sampling skew of the voltage channel
    # sensor dynamics (2nd-order low-pass, unity DC gain)
    load_cell_hz: float = 0.0                 # force channel f_c, Hz (0: ideal)
    load_cell_damping: float = 0.05           # force channel zeta
    voltage_sensor_hz: float = 0.0            # voltage channel f_c, Hz (0: ideal)
    voltage_sensor_damping: float = 0.707     # voltage channel zeta (Butterworth)
    # drift over the campaign: grease temperature rise theta, friction falling with it
    grease_capacity_J_per_K: float = 0.0      # C_g (0: no drift)
    grease_resistance_K_per_W: float = 20.0   # R_g
    drift_coulomb_per_K: float = 0.0          # beta_C: F_C, F_S x exp(-beta_C theta)
    drift_viscous_per_K: float = 0.0          # beta_v: sigma2 x exp(-beta_v theta)


@dataclass(frozen=True)
class RigModel:
    """One rig: harvester, friction of the nut and bearings, effects."""

    harvester: Harvester
    nut: LuGre
    bearing: LuGre
    effects: Effects = field(default_factory=Effects)
    #: solve_ivp method; "auto": Radau on a rig with play, LSODA otherwise.  With a stiff
    #: contact the sampled force k p^n amplifies any error of the interpolated states
    #: at the sample times: LSODA's dense output put 3.5 MN bursts (at 0.05 m/s) into a
    #: multisine record of a 2e10 contact whose integrated states were right; Radau's
    #: collocation polynomial samples it within 0.01 % of a 20 µs-step reference.
    method: str = "auto"

    # -- layout ------------------------------------------------------------------------
    @property
    def solver(self) -> str:
        """The solve_ivp method used (see :attr:`method`)."""
        if self.method == "auto":
            return "Radau" if self.play else "LSODA"
        return self.method

    @property
    def compliant(self) -> bool:
        return self.effects.mount_stiffness_N_per_m > 0

    @property
    def play(self) -> bool:
        return self.effects.play_m > 0

    @property
    def drifts(self) -> bool:
        return self.effects.grease_capacity_J_per_K > 0

    def drift_scales(self, theta):
        """(Coulomb/static factor, viscous factor) of the nut friction at a grease
        temperature rise ``theta`` (K)."""
        e = self.effects
        return (np.exp(-e.drift_coulomb_per_K * np.asarray(theta)),
                np.exp(-e.drift_viscous_per_K * np.asarray(theta)))

    def layout(self, audit: bool = False) -> dict[str, int]:
        names = []
        if self.compliant:
            names += ["xn", "vn"]
        if self.play:
            names += ["th", "om"]
        names += ["i", "zn", "zb"]
        if self.effects.thermal_capacity_J_per_K > 0:
            names.append("T")
        if self.drifts:
            names.append("Tg")
        if self.effects.load_cell_hz > 0:
            names += ["fc", "dfc"]
        if self.effects.voltage_sensor_hz > 0:
            names += ["vm", "dvm"]
        if audit:
            names += ["Ein", "Ediss", "Eload"]
        return {n: k for k, n in enumerate(names)}

    # -- pieces ------------------------------------------------------------------------
    def _lugre(self, fr: LuGre, u: float, z: float, scale: float = 1.0,
               visc_scale: float = 1.0):
        g = scale * fr.level(u)
        dz = u - fr.stiffness * abs(u) * z / g
        visc = (fr.viscous_pos if u >= 0 else fr.viscous_neg) * scale * visc_scale
        f = fr.stiffness * z + fr.micro_damping * math.exp(-(u / fr.stribeck_velocity) ** 2) * dz \
            + visc * u
        return f, dz

    def _nut_scale(self, theta: float, xn: float) -> float:
        e = self.effects
        s = 1.0
        if e.ripple_depth:
            s += e.ripple_depth * math.sin(e.ripple_per_rev * theta)
        if e.preload_gain:
            s += e.preload_gain * (xn / e.preload_span_m) ** 2
        return s

    def _cogging(self, theta: float) -> float:
        e = self.effects
        if not e.cogging_Nm:
            return 0.0
        N = e.cogging_detents
        return e.cogging_Nm * sum(c * math.sin(j * N * theta + p)
                                  for j, (c, p) in enumerate(_COG_SHAPE, start=1))

    def _cogging_potential(self, theta):
        e = self.effects
        if not e.cogging_Nm:
            return np.zeros_like(np.asarray(theta, dtype=float))
        N = e.cogging_detents
        return e.cogging_Nm * sum(-c / (j * N) * np.cos(j * N * np.asarray(theta) + p)
                                  for j, (c, p) in enumerate(_COG_SHAPE, start=1))

    def _contact(self, d: float, dd: float):
        """Force pushing the screw side along +x, its power split: (F, p, stored-rate, F*pdot)."""
        e = self.effects
        half = 0.5 * e.play_m
        if abs(d) <= half:
            return 0.0, 0.0
        sgn = 1.0 if d > 0 else -1.0
        p, pd = abs(d) - half, sgn * dd
        kp = e.contact_stiffness * p ** e.contact_exponent
        f = max(0.0, kp * (1.0 + e.contact_damping_s_per_m * pd))
        # dissipated power in the contact: (F - k p^n) pdot >= 0
        return sgn * f, (f - kp) * pd

    def _electrical(self, i: float, omega: float, T: float, load_ohm: float):
        h, e = self.harvester, self.effects
        phi = 1.0 / math.sqrt(1.0 + (i / e.saturation_current_A) ** 2) \
            if e.saturation_current_A else 1.0
        Ri = h.winding_resistance_ohm * (1.0 + e.copper_coefficient_per_K * T) \
            if e.thermal_capacity_J_per_K else h.winding_resistance_ohm
        vd = 0.0
        if e.diode_saturation_A:
            vd = 2 * e.diode_ideality * THERMAL_VOLTAGE_V * math.asinh(
                i / (2 * e.diode_saturation_A))
        emf = h.emf_constant_Vs_per_rad * phi * omega
        di = (emf - (Ri + load_ohm) * i - vd) / h.inductance_H
        torque = h.torque_constant_Nm_per_A * phi * i
        return di, torque, Ri, vd

    # -- right-hand side ---------------------------------------------------------------
    def rhs(self, t: float, y: np.ndarray, motion, load_ohm: float, lay: dict[str, int]):
        """Time derivative of the state; also returns the measured force and powers."""
        h, e = self.harvester, self.effects
        r, J = h.r, h.inertia_kgm2
        x, v, a = (float(q) for q in motion.kinematics(t))
        dy = np.zeros(len(lay))
        T = y[lay["T"]] if "T" in lay else 0.0
        # mechanical configuration
        if self.compliant:
            xn, vn = y[lay["xn"]], y[lay["vn"]]
            fm = e.mount_stiffness_N_per_m * (x - xn) + e.mount_damping_Ns_per_m * (v - vn)
            p_mount = e.mount_damping_Ns_per_m * (v - vn) ** 2
        else:
            xn, vn, fm, p_mount = x, v, None, 0.0
        if self.play:
            th, om = y[lay["th"]], y[lay["om"]]
        else:
            th, om = xn / r, vn / r
        i = y[lay["i"]]
        di, tq_gen, Ri, vd = self._electrical(i, om, T, load_ohm)
        sc, sv = (math.exp(-e.drift_coulomb_per_K * y[lay["Tg"]]),
                  math.exp(-e.drift_viscous_per_K * y[lay["Tg"]])) if "Tg" in lay else (1., 1.)
        fn, dzn = self._lugre(self.nut, r * om, y[lay["zn"]], self._nut_scale(th, xn) * sc,
                              sv / sc)
        tb, dzb = self._lugre(self.bearing, om, y[lay["zb"]])
        t_eddy = e.eddy_Nms_per_rad * om / (1.0 + (om / e.eddy_corner_rad_per_s) ** 2) \
            if e.eddy_Nms_per_rad else 0.0
        load_torque = r * fn + tb + tq_gen + self._cogging(th) + t_eddy
        p_contact = 0.0
        if self.play:
            fc, p_contact = self._contact(xn - r * th, vn - r * om)
            # without a compliant mount the nut mass rides on the screw side of the play
            J_eff = J if self.compliant else J + h.nut_mass_kg * r ** 2
            dy[lay["th"]] = om
            dy[lay["om"]] = (r * fc - load_torque) / J_eff
            if self.compliant:
                dy[lay["xn"]] = vn
                dy[lay["vn"]] = (fm - fc) / h.nut_mass_kg
                force = fm
            else:
                force = fc          # nut mass is on the screw side of the play
        elif self.compliant:
            m = h.nut_mass_kg + J / r ** 2
            dy[lay["xn"]] = vn
            dy[lay["vn"]] = (fm - load_torque / r) / m
            force = fm
        else:
            force = (J / r ** 2 + h.nut_mass_kg) * a + load_torque / r
        dy[lay["i"]] = di
        dy[lay["zn"]] = dzn
        dy[lay["zb"]] = dzb
        if "T" in lay:
            dy[lay["T"]] = (Ri * i * i - T / e.thermal_resistance_K_per_W) \
                / e.thermal_capacity_J_per_K
        if "Tg" in lay:
            p_nut = fn * r * om - self.nut.stiffness * y[lay["zn"]] * dzn
            dy[lay["Tg"]] = (p_nut - y[lay["Tg"]] / e.grease_resistance_K_per_W) \
                / e.grease_capacity_J_per_K
        for name, fc_hz, zeta, u in (("fc", e.load_cell_hz, e.load_cell_damping, force),
                                     ("vm", e.voltage_sensor_hz, e.voltage_sensor_damping,
                                      load_ohm * i)):
            if name in lay:   # y'' + 2 zeta wc y' + wc^2 y = wc^2 u
                wc, k = 2 * math.pi * fc_hz, lay[name]
                dy[k] = y[k + 1]
                dy[k + 1] = wc * wc * (u - y[k]) - 2 * zeta * wc * y[k + 1]
        if "Ein" in lay:
            fr_n, fr_b = self.nut, self.bearing
            u = r * om
            zn, zb = y[lay["zn"]], y[lay["zb"]]
            # friction dissipation = F u - d/dt(sigma0 z^2 / 2)
            p_fric = (fn * u - fr_n.stiffness * zn * dzn) + (tb * om - fr_b.stiffness * zb * dzb)
            dy[lay["Ein"]] = force * v
            dy[lay["Ediss"]] = p_fric + p_mount + p_contact + t_eddy * om + Ri * i * i + vd * i
            dy[lay["Eload"]] = load_ohm * i * i
        return dy, force

    # -- simulation --------------------------------------------------------------------
    def initial_state(self, motion, t0: float, lay: dict[str, int],
                      grease_K: float = 0.0) -> np.ndarray:
        """State at ``t0``: the rig on the motion, bristles relaxed, no current, the
        sensors reading the force and voltage at ``t0``, the grease ``grease_K`` above
        the ambient."""
        x, v, _ = (float(q) for q in motion.kinematics(t0))
        y = np.zeros(len(lay))
        r = self.harvester.r
        if "xn" in lay:
            y[lay["xn"]], y[lay["vn"]] = x, v
        if "th" in lay:
            y[lay["th"]], y[lay["om"]] = x / r, v / r
        if "Tg" in lay:
            y[lay["Tg"]] = grease_K
        if "fc" in lay:
            y[lay["fc"]] = self.rhs(t0, y, motion, 1.0, lay)[1]
        return y

    def stored_energy(self, t, Y, motion, lay) -> np.ndarray:
        """Kinetic + magnetic + elastic + bristle + detent energy along a trajectory."""
        h, e = self.harvester, self.effects
        r, J = h.r, h.inertia_kgm2
        x, v, _ = motion.kinematics(t)
        xn = Y[lay["xn"]] if "xn" in lay else x
        vn = Y[lay["vn"]] if "vn" in lay else v
        th = Y[lay["th"]] if "th" in lay else xn / r
        om = Y[lay["om"]] if "om" in lay else vn / r
        E = 0.5 * J * om ** 2 + 0.5 * h.inductance_H * Y[lay["i"]] ** 2
        # (the saturation factor phi acts on the motional terms K phi(i) omega and
        # K phi(i) i alike, so it converts power without storing any: magnetic energy
        # stays L i^2 / 2)
        E = E + 0.5 * h.nut_mass_kg * (vn ** 2 if ("xn" in lay or "th" in lay) else v ** 2)
        if "xn" in lay:
            E = E + 0.5 * e.mount_stiffness_N_per_m * (x - xn) ** 2
        if "th" in lay:
            if "xn" not in lay:  # nut mass rides with the screw when the mount is rigid
                E = E - 0.5 * h.nut_mass_kg * v ** 2 + 0.5 * h.nut_mass_kg * (r * om) ** 2
            d = np.abs(xn - r * th) - 0.5 * e.play_m
            p = np.clip(d, 0.0, None)
            E = E + e.contact_stiffness * p ** (e.contact_exponent + 1) / (e.contact_exponent + 1)
        E = E + 0.5 * self.nut.stiffness * Y[lay["zn"]] ** 2 \
            + 0.5 * self.bearing.stiffness * Y[lay["zb"]] ** 2
        E = E + self._cogging_potential(th)
        return E

    def simulate(self, motion, load_ohm: float, sample_rate_hz: float, *, audit: bool = False,
                 rtol: float = 1e-6, max_step_s: float | None = None, grease_K: float = 0.0):
        """Integrate (Radau, piecewise between the motion's acceleration jumps) and sample
        the record.  Returns ``(t, x, force, voltage, Y, lay)``; ``t`` starts at 0 at the
        record's start, ``Y`` are the states at the samples.  ``grease_K``: the grease
        temperature rise when the test starts (with drift; ``Y[lay["Tg"], -1]`` is its
        value at the end)."""
        lay = self.layout(audit)
        t0, t1 = -motion.preroll_s, motion.duration_s
        n = int(math.floor(motion.duration_s * sample_rate_hz + 1e-9)) + 1
        ts = np.arange(n) / sample_rate_hz
        breaks = sorted({t0, t1, *[b for b in motion.breaks_s if t0 < b < t1]})
        scale = self._atol(lay)
        dt = max_step_s or np.inf
        y = self.initial_state(motion, t0, lay, grease_K)
        Ys = np.empty((len(lay), n))

        def fun(t, yy):
            return self.rhs(t, yy, motion, load_ohm, lay)[0]

        for a, b in zip(breaks[:-1], breaks[1:]):
            sel = np.nonzero((ts >= a) & (ts < b) | ((ts == b) & (b == t1)))[0]
            te = np.concatenate([ts[sel], [b]]) if not sel.size or ts[sel[-1]] < b else ts[sel]
            sol = solve_ivp(fun, (a, b), y, method=self.solver, rtol=rtol, atol=scale,
                            max_step=dt, t_eval=te)
            if not sol.success:
                raise RuntimeError(f"second generator: integration failed at t = "
                                   f"{sol.t[-1]:.4f} s ({sol.message})")
            Ys[:, sel] = sol.y[:, :sel.size]
            y = sol.y[:, -1]
        x = motion.kinematics(ts)[0]
        F = np.array([self.rhs(t, Ys[:, k], motion, load_ohm, lay)[1] for k, t in enumerate(ts)])
        if "fc" in lay:
            F = Ys[lay["fc"]]
        V = Ys[lay["vm"]] if "vm" in lay else load_ohm * Ys[lay["i"]]
        return ts, np.asarray(x, dtype=float), F, V, Ys, lay

    def _atol(self, lay: dict[str, int]) -> np.ndarray:
        r = self.harvester.r
        ref = {"xn": 1e-9, "vn": 1e-6, "th": 1e-9 / r, "om": 1e-6 / r, "i": 1e-6,
               "zn": 1e-11, "zb": 1e-9, "T": 1e-6, "Tg": 1e-6, "fc": 1e-4, "dfc": 1e-1,
               "vm": 1e-6, "dvm": 1e-3,
               "Ein": 1e-7, "Ediss": 1e-7, "Eload": 1e-7}
        return np.array([ref[k] for k in lay])
