"""The design space of real hardware: the motor and the ball screw chosen from catalogues,
the motor's winding within the range its series offers, and every limit of that hardware
checked per sample (:mod:`.limits`).

Design variables (``[motor] model = "select"``):

``motor`` (integer)
    Index into the motor catalogue (:func:`ehsa_opt.physics.motor.load_catalogue`).
``winding`` (0–1)
    The winding of a series with a winding range: k_n = lo (hi/lo)^winding; R_i, L_i, the
    currents and the voltage scale from the datasheet winding (one frame rewound).  A motor
    without a range ignores it.
``screw`` (integer)
    Index into the screw catalogue (:func:`ehsa_opt.physics.ball_screw.load_screws`); it
    sets the lead.  Without a screw catalogue the lead is a continuous variable as in the
    paper, with no screw speed limit.
``total_inertia_gcm2``, ``load_ohm``
    As in the paper (J_t includes the rotor and the screw: J_t ≥ J_m + J_s is a constraint).

The catalogue is a discrete variable of one NSGA-II run (not one run per motor): pymoo
evolves all motors together, so the front mixes motors and the population budget is the
one the user sets; pymoo's integer handling for a real-coded genome (SBX and polynomial
mutation, then rounding) is the floor mapping of
:meth:`~ehsa_opt.design.problem.DesignSpace.from_unit`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..physics.params import HarvesterParams, ParameterError, RoadParams, VehicleParams
from ..physics.ball_screw import allowable_mean_load
from .limits import (GAUSSIAN_CUBIC_MEAN_FACTOR, LimitSettings, gaussian_fraction_beyond,
                     limit_entry, rice_peak_quantile)
from .problem import OBJECTIVE_NAMES, DesignSpace

__all__ = ["SelectionObjectives", "FrictionSelectionObjectives", "selection_space",
           "SELECTION_EXTRAS", "motor_names", "realisable_winding"]

#: Evaluator outputs besides objectives and limits.
SELECTION_EXTRAS = ("comfort_weighted_rms_m_s2", "power_W", "efficiency", "power_dimensionless",
                    "dissipated_power_W", "dissipation_bound_W", "current_rms_A",
                    "voltage_rms_V", "stroke_rms_m", "stroke_velocity_rms_m_s")


def selection_space(box: DesignSpace, n_motors: int, n_screws: int,
                    rewindable: bool) -> DesignSpace:
    """The box of a selection problem: the file's box without k_n (and without the lead when
    screws are chosen), with ``motor``, ``winding`` and ``screw`` added."""
    drop = {"speed_constant_rpm_per_V", "voltage_constant_Vs_per_rad"}
    if n_screws:
        drop.add("lead_mm_per_rev")
    names, lo, hi, lg, it = [], [], [], [], []
    for n, a, b, g in zip(box.names, box.lower, box.upper, box.log):
        if n not in drop:
            names.append(n), lo.append(a), hi.append(b), lg.append(g), it.append(False)
    for name, count in (("motor", n_motors), ("screw", n_screws)):
        if count > 1:
            names.append(name), lo.append(0.0), hi.append(float(count - 1))
            lg.append(False), it.append(True)
    if rewindable:
        names.append("winding"), lo.append(0.0), hi.append(1.0), lg.append(False)
        it.append(False)
    return DesignSpace(tuple(names), tuple(lo), tuple(hi), tuple(lg), box.where, tuple(it))


@dataclass(frozen=True)
class SelectionObjectives:
    """Paper objectives and the hardware limits of catalogue motors and screws.

    Attributes
    ----------
    vehicle, road : VehicleParams, RoadParams
        Quarter car and road; the road's ``length_m`` sets the duration of the peak
        statistics.
    base : HarvesterParams
        Fields no variable sets (lead without screws, load, J_t when not in the box).
    motors : tuple of CatalogueMotor
    screws : tuple of BallScrew
        Empty: the lead is a design variable and the screw speed is not limited.
    limits : LimitSettings
    stroke_limit_m : float or None
    metric_options : tuple of (key, value)
        Extra keyword arguments of ``linear_metrics`` (``n_freq``).
    """

    vehicle: VehicleParams
    road: RoadParams
    base: HarvesterParams
    motors: tuple
    screws: tuple = ()
    limits: LimitSettings = field(default_factory=LimitSettings)
    stroke_limit_m: float | None = None
    metric_options: tuple[tuple[str, Any], ...] = ()

    objective_names = OBJECTIVE_NAMES
    kind = "select"

    @property
    def constraint_names(self) -> tuple[str, ...]:
        out = ["rated_current", "peak_current", "rated_voltage", "motor_speed"]
        if self.screws:
            out.append("screw_speed")
        if self.rated_screws:
            out.append("screw_life")
        if self.stroke_limit_m is not None:
            out.append("stroke")
        return tuple(out + ["tyre_lift", "motor_inertia"])

    @property
    def rated_screws(self) -> bool:
        """Every screw has a dynamic load rating (its fatigue life is a limit)."""
        return bool(self.screws) and all(s.dynamic_load_rating_N for s in self.screws)

    def life_revolutions(self, mean_speed_rev_s: Any) -> np.ndarray:
        """Revolutions a screw turning at mean |speed| ``mean_speed_rev_s`` (rev/s) runs
        over the required distance :attr:`LimitSettings.screw_life_km` on the design road."""
        hours_s = self.limits.screw_life_km * 1e3 / self.road.speed_m_per_s
        return np.asarray(mean_speed_rev_s, float) * hours_s

    @property
    def duration_s(self) -> float:
        """Duration of the road the peak statistics refer to, s."""
        return self.road.length_m / self.road.speed_m_per_s

    def _index(self, design: Mapping[str, Any], key: str, n: int, shape: tuple) -> np.ndarray:
        if key not in design or n <= 1:
            return np.zeros(shape, int)
        return np.clip(np.floor(np.asarray(design[key], float)).astype(int), 0, n - 1)

    def hardware(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Per design: the motor's constants at its winding, its limits, the screw's lead,
        speed limit and inertia (arrays of the design's shape)."""
        shape = np.broadcast_shapes(*(np.shape(v) for v in design.values()))
        im = self._index(design, "motor", len(self.motors), shape)
        wind = np.broadcast_to(np.asarray(design.get("winding", 1.0), float), shape)
        keys = ("speed_constant_rpm_per_V", "internal_resistance_ohm", "inductance_H",
                "rated_current_A", "peak_current_A", "max_voltage_V", "max_speed_rpm",
                "motor_inertia_gcm2")
        hw = {k: np.full(shape, np.nan) for k in keys}
        for k, m in enumerate(self.motors):
            sel = im == k
            if not np.any(sel):
                continue
            kn = m.speed_constant_at(wind[sel])
            w = m.winding(60.0 / (2.0 * math.pi * kn))
            hw["speed_constant_rpm_per_V"][sel] = kn
            for key in keys[1:7]:
                hw[key][sel] = w[key]
            hw["motor_inertia_gcm2"][sel] = m.motor_inertia_gcm2
        hw["motor_index"] = im
        if self.screws:
            is_ = self._index(design, "screw", len(self.screws), shape)
            pick = lambda f: np.array([f(s) for s in self.screws])[is_]  # noqa: E731
            hw["lead_mm_per_rev"] = pick(lambda s: s.lead_mm_per_rev)
            hw["screw_max_speed_rpm"] = pick(lambda s: s.max_speed_rpm)
            hw["screw_inertia_gcm2"] = pick(lambda s: s.inertia_gcm2)
            hw["screw_dynamic_load_N"] = pick(lambda s: s.dynamic_load_rating_N or np.nan)
            hw["screw_index"] = is_
        else:
            hw["lead_mm_per_rev"] = np.broadcast_to(np.asarray(
                design.get("lead_mm_per_rev", self.base.lead_mm_per_rev), float), shape).copy()
            hw["screw_inertia_gcm2"] = np.zeros(shape)
        return hw

    def design_mapping(self, design: Mapping[str, Any]) -> dict[str, Any]:
        """The ``linear_metrics`` mapping of the designs (harvester fields)."""
        hw = self.hardware(design)
        ke = 60.0 / (2.0 * math.pi * hw["speed_constant_rpm_per_V"])
        jt = design.get("total_inertia_gcm2", self.base.total_inertia_gcm2)
        return {"total_inertia_gcm2": np.asarray(jt, float),
                "lead_mm_per_rev": hw["lead_mm_per_rev"],
                "voltage_constant_Vs_per_rad": ke, "torque_constant_Nm_per_A": ke,
                "internal_resistance_ohm": hw["internal_resistance_ohm"],
                "inductance_H": hw["inductance_H"],
                "load_ohm": np.asarray(design.get("load_ohm", self.base.load_ohm), float)}

    def harvesters(self, designs: Mapping[str, Any]) -> list[HarvesterParams]:
        """One harvester per design (for the time domain): the motor's constants and rotor
        inertia, the screw's lead, the rest of J_t as screw (and flywheel) inertia."""
        hw = self.hardware(designs)
        mp = self.design_mapping(designs)
        n = int(np.size(hw["motor_index"]))
        b = {k: np.broadcast_to(np.asarray(v, float), (n,)) for k, v in mp.items()}
        jm = np.ravel(hw["motor_inertia_gcm2"])
        return [self.base.replace(
            motor_inertia_gcm2=float(jm[i]),
            screw_inertia_gcm2=max(float(b["total_inertia_gcm2"][i] - jm[i]), 0.0),
            lead_mm_per_rev=float(b["lead_mm_per_rev"][i]),
            voltage_constant_Vs_per_rad=float(b["voltage_constant_Vs_per_rad"][i]),
            torque_constant_Nm_per_A=float(b["torque_constant_Nm_per_A"][i]),
            internal_resistance_ohm=float(b["internal_resistance_ohm"][i]),
            inductance_H=float(b["inductance_H"][i]), load_ohm=float(b["load_ohm"][i]))
            for i in range(n)]

    def __call__(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        from ..vehicle.frequency_path import linear_metrics
        hw = self.hardware(design)
        mapping = self.design_mapping(design)
        m = linear_metrics(self.vehicle, self.road, mapping, **dict(self.metric_options))
        out = {"comfort": m["comfort"], "road_holding": m["road_holding"],
               "inverse_power": 1.0 / m["power_dimensionless"],
               "inverse_efficiency": 1.0 / m["efficiency"]}
        out.update({k: m[k] for k in SELECTION_EXTRAS if k in m})
        out.update(self.limit_outputs(m, mapping, hw))
        return self._with_hardware(out, hw)

    def _with_hardware(self, out: dict[str, np.ndarray], hw: Mapping[str, np.ndarray]
                       ) -> dict[str, np.ndarray]:
        out.update({"speed_constant_rpm_per_V": hw["speed_constant_rpm_per_V"],
                    "lead_mm_per_rev": hw["lead_mm_per_rev"],
                    "internal_resistance_ohm": hw["internal_resistance_ohm"],
                    "motor_index": hw["motor_index"].astype(float)})
        if "screw_index" in hw:
            out["screw_index"] = hw["screw_index"].astype(float)
        return out

    def limit_outputs(self, m: Mapping[str, np.ndarray], mapping: Mapping[str, Any],
                      hw: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Every limit (value, limit, fraction of time beyond, constraint) from the
        frequency path's rms values (Gaussian; see :mod:`.limits`)."""
        st = self.limits
        z2, z1 = st.z_two_sided, st.z_tyre_lift
        shape = np.shape(m["comfort"])
        re = np.broadcast_to(np.asarray(mapping["load_ohm"], float), shape)
        r = np.asarray(mapping["lead_mm_per_rev"], float) * 1e-3 / (2.0 * math.pi)
        rpm = m["stroke_velocity_rms_m_s"] / r * 60.0 / (2.0 * math.pi)    # rms speed, rpm
        si, sv = m["current_rms_A"], m["voltage_rms_V"]
        q = st.peak_quantile
        v_peak = rice_peak_quantile(sv, re * m["current_rate_rms_A_per_s"], self.duration_s, q)
        out: dict[str, np.ndarray] = {"motor_speed_rms_rpm": rpm, "peak_voltage_V": v_peak}
        for key, p in (("peak_voltage_low_V", 0.025), ("peak_voltage_high_V", 0.975)):
            out[key] = rice_peak_quantile(sv, re * m["current_rate_rms_A_per_s"],
                                          self.duration_s, p)   # its 95 % interval
        out.update(limit_entry("rated_current", si, hw["rated_current_A"],
                               gaussian_fraction_beyond(hw["rated_current_A"], si)))
        out.update(limit_entry("peak_current", z2 * si, hw["peak_current_A"],
                               gaussian_fraction_beyond(hw["peak_current_A"], si)))
        out.update(limit_entry("rated_voltage", v_peak, hw["max_voltage_V"],
                               gaussian_fraction_beyond(hw["max_voltage_V"], sv)))
        out.update(limit_entry("motor_speed", z2 * rpm, hw["max_speed_rpm"],
                               gaussian_fraction_beyond(hw["max_speed_rpm"], rpm)))
        if self.screws:
            out.update(limit_entry("screw_speed", z2 * rpm, hw["screw_max_speed_rpm"],
                                   gaussian_fraction_beyond(hw["screw_max_speed_rpm"], rpm)))
        if self.rated_screws:
            out.update(self._screw_life(m, mapping, hw, r))
        if self.stroke_limit_m is not None:
            out.update(limit_entry("stroke", z2 * m["stroke_rms_m"], self.stroke_limit_m,
                                   gaussian_fraction_beyond(self.stroke_limit_m,
                                                            m["stroke_rms_m"])))
        out.update(limit_entry("tyre_lift", z1 * m["road_holding"], 1.0,
                               gaussian_fraction_beyond(1.0, m["road_holding"], False)))
        j_min = hw["motor_inertia_gcm2"] + hw["screw_inertia_gcm2"]
        out.update(limit_entry("motor_inertia", j_min,
                               np.asarray(mapping["total_inertia_gcm2"], float),
                               np.zeros(shape)))
        return {k: np.broadcast_to(v, shape) if np.ndim(v) < len(shape) else v
                for k, v in out.items()}

    def _screw_life(self, m: Mapping[str, np.ndarray], mapping: Mapping[str, Any],
                    hw: Mapping[str, np.ndarray], r: np.ndarray) -> dict[str, np.ndarray]:
        """The screw's fatigue limit from rms values (the Gaussian bound of
        :mod:`.limits`): F_m ≤ 1.555 (m_eq σ_a + k_t σ_i / r) against the load of an L10
        life of the required distance."""
        jt = np.asarray(mapping["total_inertia_gcm2"], float) * 1e-7
        kt = np.asarray(mapping["torque_constant_Nm_per_A"], float)
        sigma_f = (jt / r ** 2 * m["stroke_acceleration_rms_m_s2"]
                   + kt / r * m["current_rms_A"])
        f_m = GAUSSIAN_CUBIC_MEAN_FACTOR * sigma_f
        mean_rev_s = math.sqrt(2.0 / math.pi) * m["stroke_velocity_rms_m_s"] / (2 * math.pi * r)
        allow = allowable_mean_load(hw["screw_dynamic_load_N"], self.life_revolutions(mean_rev_s))
        out = limit_entry("screw_life", f_m, allow, np.zeros(np.shape(f_m)))
        out["screw_mean_load_N"] = f_m
        return out

    def describe(self, design: Mapping[str, Any], index: int = 0) -> dict[str, Any]:
        """The motor (with its winding) and screw of one design, for reports."""
        hw = self.hardware(design)
        i = int(np.ravel(hw["motor_index"])[index])
        m = self.motors[i]
        out = {"motor": m.name, "motor_source": m.source,
               "speed_constant_rpm_per_V": float(np.ravel(hw["speed_constant_rpm_per_V"])[index]),
               "internal_resistance_ohm": float(np.ravel(hw["internal_resistance_ohm"])[index]),
               "rewound": bool(m.rewindable)}
        if self.screws:
            s = self.screws[int(np.ravel(hw["screw_index"])[index])]
            out.update({"screw": s.name, "screw_source": s.source,
                        "lead_mm_per_rev": s.lead_mm_per_rev})
        return out

    def fingerprint(self) -> dict[str, Any]:
        from dataclasses import asdict
        return {"kind": self.kind, "vehicle": asdict(self.vehicle), "road": asdict(self.road),
                "base": asdict(self.base), "motors": [asdict(m) for m in self.motors],
                "screws": [asdict(s) for s in self.screws], "limits": self.limits.as_dict(),
                "stroke_limit_m": self.stroke_limit_m, "options": dict(self.metric_options)}


@dataclass(frozen=True)
class FrictionSelectionObjectives(SelectionObjectives):
    """:class:`SelectionObjectives` with the strut's friction: the objectives by the
    friction-aware fast path (:func:`ehsa_opt.vehicle.fast_path.friction_metrics`) at each
    friction set, every hardware limit from the linear path with the friction's equivalent
    damping c_f (the rms current, voltage, stroke, speeds and their rates of the damped
    car), combined over the sets by ``mode`` (:func:`ehsa_opt.design.robust.combine`: a
    limit is always the worst set's).

    Attributes
    ----------
    frictions : tuple of FrictionParams
        One (mode ``at``) or several friction sets (e.g. an identification's).
    mode : str
        ``at``, ``worst`` or ``mean``.
    labels : tuple of str
        Names of the sets (reports only).
    """

    frictions: tuple = ()
    mode: str = "at"
    labels: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        from .robust import FRICTION_MODES
        if not self.frictions:
            raise ParameterError("FrictionSelectionObjectives: give at least one friction "
                                 "set (--friction FILE[:CASE] or a [friction] table)")
        if self.mode not in FRICTION_MODES or (self.mode == "at" and len(self.frictions) != 1):
            raise ParameterError(f"--friction-mode {self.mode}: with {len(self.frictions)} "
                                 f"friction set(s) use at (one set), worst or mean")

    def __call__(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        from ..vehicle.fast_path import friction_metrics
        from ..vehicle.frequency_path import linear_metrics
        from .robust import combine, objectives_from_metrics
        hw = self.hardware(design)
        mapping = self.design_mapping(design)
        opts = dict(self.metric_options)
        per = []
        for f in self.frictions:
            fm = friction_metrics(self.vehicle, self.road, mapping, f, **opts)
            lm = linear_metrics(self.vehicle, self.road, mapping,
                                friction_damping_Ns_per_m=fm["friction_damping_Ns_per_m"],
                                **opts)
            o = objectives_from_metrics(fm)
            o.update({k: lm[k] for k in SELECTION_EXTRAS if k in lm and k not in o})
            o.update(self.limit_outputs(lm, mapping, hw))
            per.append(o)
        return self._with_hardware(combine(per, self.mode), hw)

    def fingerprint(self) -> dict[str, Any]:
        from dataclasses import asdict
        return {**super().fingerprint(), "kind": "select_friction_equivalent",
                "mode": self.mode, "frictions": [asdict(f) for f in self.frictions]}


def motor_names(ev: Any, designs: Mapping[str, Any]) -> Sequence[str]:
    """The motor name of each design of a selection evaluator."""
    idx = np.ravel(ev.hardware(designs)["motor_index"])
    return [ev.motors[int(i)].name for i in idx]


def realisable_winding(speed_constant_rpm_per_V: float, motors: Sequence[Any]
                       ) -> dict[str, Any]:
    """The winding a real series offers nearest a wanted k_n (e.g. the paper's Table 4
    optimum, designed with R_i fixed): among the catalogue ``motors``, the one whose
    winding range holds k_n (or whose range comes nearest, in log k_n), rewound to the
    nearest k_n it offers.  Returns the motor's name and source and the harvester fields
    of that winding (``speed_constant_rpm_per_V``, ``voltage_constant_Vs_per_rad``,
    ``internal_resistance_ohm``, ``inductance_H``, ``motor_inertia_gcm2``) with its limits,
    so a table computed at the paper's assumption can be recomputed beside it."""
    want = math.log(float(speed_constant_rpm_per_V))

    def span(m: Any) -> tuple[float, float]:
        r = m.speed_constant_range_rpm_per_V if m.rewindable else (
            m.speed_constant_rpm_per_V, m.speed_constant_rpm_per_V)
        return math.log(r[0]), math.log(r[1])

    def gap(m: Any) -> float:
        lo, hi = span(m)
        return max(lo - want, want - hi, 0.0)
    best = min(motors, key=gap)
    lo, hi = span(best)
    kn = math.exp(min(max(want, lo), hi))
    ke = 60.0 / (2.0 * math.pi * kn)
    w = best.winding(ke)
    out = {"motor": best.name, "source": best.source, "speed_constant_rpm_per_V": kn,
           "voltage_constant_Vs_per_rad": ke, "motor_inertia_gcm2": best.motor_inertia_gcm2,
           "log_distance": gap(best)}
    out.update({k: float(np.ravel(v)[0]) for k, v in w.items()})
    return out
