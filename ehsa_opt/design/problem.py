"""The design problem of the harvester: design space and the pymoo design problem.
Goal attainment is in :mod:`.goal`, NSGA-II in :mod:`.nsga2`, Pareto tools in
:mod:`.pareto`.

The design problem **is** a :class:`pymoo.core.problem.Problem`
(:class:`DesignProblem`) whose ``_evaluate`` is vectorised over the population.
Its decision variables live in the unit cube: variable ``k`` maps to its physical
value linearly, or logarithmically when its box spans decades (paper Table 3:
J_t, k_n and R_e), so every optimiser sees well-scaled variables.

The objectives come from an *evaluator*: a picklable callable mapping a dict of
physical design arrays to a dict of objective arrays (and extra quantities for
reporting).  :class:`QuarterCarObjectives` is the paper's one, built on the exact
frequency-domain path of the frictionless quarter car (:func:`ehsa_opt.vehicle.frequency_path
linear_metrics`); tests plug in analytic functions with known answers.

Classes and functions
---------------------
DesignSpace, PAPER_BOX
    Named box with linear/log scaling (paper Table 3 by default).
QuarterCarObjectives
    [α, η_rh, 1/ρ_g, 1/η_g] of a design on a vehicle/road (paper Eqs 6–9).
DesignProblem
    The pymoo problem.
solve_goal_attainment, GoalAttainmentResult
    MATLAB ``fgoalattain`` semantics as a smooth NLP (SLSQP, multistart).
run_nsga2, ParetoResult
    Seeded NSGA-II with per-generation hypervolume, atomic checkpoints and
    exact resume; knee / preference pick.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from pymoo.core.problem import Problem

from ..physics.params import HarvesterParams, ParameterError, RoadParams, VehicleParams

__all__ = ["DESIGN_VARIABLES", "OBJECTIVE_NAMES", "OBJECTIVE_MEANINGS", "PAPER_BOX",
           "DesignSpace", "QuarterCarObjectives", "DesignProblem"]

#: The paper's design variables (Table 3), in this order.
DESIGN_VARIABLES: tuple[str, ...] = ("total_inertia_gcm2", "lead_mm_per_rev",
                                     "speed_constant_rpm_per_V", "load_ohm")
#: The paper's objectives (Eq 10), all minimised.
OBJECTIVE_NAMES: tuple[str, ...] = ("comfort", "road_holding", "inverse_power",
                                    "inverse_efficiency")
#: What each objective is and the quantity it is the minimised form of.
OBJECTIVE_MEANINGS: dict[str, str] = {
    "comfort": "comfort alpha (-): ISO 2631 W_k-weighted rms body acceleration / its "
               "passive reference; minimised as it is",
    "road_holding": "road holding eta_rh (-): rms dynamic tyre load / static load; "
                    "minimised as it is",
    "inverse_power": "1 / harvested power (dimensionless rho_g); minimised, i.e. power_W "
                     "(W) maximised",
    "inverse_efficiency": "1 / harvesting efficiency eta_g; minimised, i.e. efficiency (-) "
                          "maximised"}


# --------------------------------------------------------------------------- design space
@dataclass(frozen=True)
class DesignSpace:
    """A named box of design variables with linear or logarithmic scaling.

    Attributes
    ----------
    names : tuple[str, ...]
        Variable names (with units, e.g. ``load_ohm``).
    lower, upper : tuple[float, ...]
        Bounds in the variables' units; ``lower < upper``.
    log : tuple[bool, ...]
        Map the unit interval logarithmically (needs ``lower > 0``).
    where : str
        Origin used in error messages (e.g. ``"paper_design.toml [design.bounds]"``).
    """

    names: tuple[str, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    log: tuple[bool, ...]
    where: str = "design space"
    #: integer variables (a catalogue index): value lo + ⌊u (hi − lo + 1)⌋ of the unit
    #: coordinate u, the rounding pymoo applies to integer variables of a real-coded genome
    integer: tuple[bool, ...] = ()

    def __post_init__(self) -> None:
        n = len(self.names)
        if self.integer and len(self.integer) != n:
            raise ParameterError(f"{self.where}: integer flags differ in length from names")
        if n == 0:
            raise ParameterError(f"{self.where}: no design variables; give at least one bound")
        if not (len(self.lower) == len(self.upper) == len(self.log) == n):
            raise ParameterError(f"{self.where}: names, lower, upper and log differ in length")
        if len(set(self.names)) != n:
            raise ParameterError(f"{self.where}: duplicate design variable names")
        for name, lo, hi, lg in zip(self.names, self.lower, self.upper, self.log):
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise ParameterError(f"{self.where}: bounds of '{name}' must be finite, got "
                                     f"[{lo}, {hi}]")
            if lo > hi:
                raise ParameterError(
                    f"{self.where}: '{name}' has lower bound {lo:g} > upper bound {hi:g}; "
                    f"write it as [lower, upper], e.g. {name} = [{hi:g}, {lo:g}]")
            if lo == hi:
                raise ParameterError(
                    f"{self.where}: '{name}' has lower bound = upper bound = {lo:g}; to fix "
                    f"the variable remove it from the box and set it in [harvester]")
            if lg and lo <= 0.0:
                raise ParameterError(f"{self.where}: '{name}' is log-scaled, so its lower bound "
                                     f"must be > 0 (got {lo:g})")

    @classmethod
    def from_bounds(cls, bounds: Mapping[str, Sequence[float]], log: Sequence[str] | None = None,
                    where: str = "design space") -> "DesignSpace":
        """Build from ``{name: [lower, upper]}``; ``log`` names log-scaled variables
        (default: those whose upper/lower ratio exceeds 20)."""
        names, lo, hi, lg = [], [], [], []
        for name, b in bounds.items():
            if (not isinstance(b, (list, tuple)) or len(b) != 2
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                               for v in b)):
                raise ParameterError(f"{where}: '{name}' must be [lower, upper] (two numbers), "
                                     f"got {b!r}")
            names.append(str(name))
            lo.append(float(b[0]))
            hi.append(float(b[1]))
        for name, a, b in zip(names, lo, hi):
            if log is None:
                lg.append(a > 0 and b > 0 and b / a > 20.0)
            else:
                lg.append(name in log)
        if log is not None:
            unknown = set(log) - set(names)
            if unknown:
                raise ParameterError(f"{where}: log-scaled {sorted(unknown)} not in the box "
                                     f"({', '.join(names)})")
        return cls(tuple(names), tuple(lo), tuple(hi), tuple(lg), where)

    @property
    def n(self) -> int:
        return len(self.names)

    def from_unit(self, U: Any) -> dict[str, np.ndarray]:
        """Physical values of unit-cube points ``U`` (shape (..., n)) as a dict."""
        U = np.clip(np.asarray(U, dtype=float), 0.0, 1.0)
        out = {}
        for k, (name, lo, hi, lg) in enumerate(zip(self.names, self.lower, self.upper,
                                                   self.log)):
            u = U[..., k]
            if self.integer and self.integer[k]:
                out[name] = lo + np.minimum(np.floor(u * (hi - lo + 1.0)), hi - lo)
            else:
                out[name] = lo * (hi / lo) ** u if lg else lo + (hi - lo) * u
        return out

    def to_unit(self, design: Mapping[str, Any]) -> np.ndarray:
        """Unit-cube coordinates of a physical design (dict of scalars/arrays)."""
        cols = []
        for k, (name, lo, hi, lg) in enumerate(zip(self.names, self.lower, self.upper,
                                                   self.log)):
            if name not in design:
                raise ParameterError(f"{self.where}: design lacks '{name}'")
            v = np.asarray(design[name], dtype=float)
            if self.integer and self.integer[k]:  # the middle of the value's interval
                cols.append((np.round(v) - lo + 0.5) / (hi - lo + 1.0))
            else:
                cols.append(np.log(v / lo) / np.log(hi / lo) if lg else (v - lo) / (hi - lo))
        return np.stack(cols, axis=-1)

    def as_dict(self) -> dict[str, Any]:
        integer = self.integer or (False,) * self.n
        return {n: {"lower": lo, "upper": hi, "log": lg, **({"integer": True} if it else {})}
                for n, lo, hi, lg, it in zip(self.names, self.lower, self.upper, self.log,
                                             integer)}


#: Paper Table 3 (R_e lower bound 1 Ω is our assumption).
PAPER_BOX = DesignSpace(
    DESIGN_VARIABLES, (250.0, 5.0, 29.8, 1.0), (10_000.0, 20.0, 11_900.0, 10_000.0),
    (True, False, True, True), "paper Table 3")


# --------------------------------------------------------------------------- evaluator
@dataclass(frozen=True)
class QuarterCarObjectives:
    """Paper objectives [α, η_rh, 1/ρ_g, 1/η_g] of the frictionless quarter car.

    Evaluated exactly in the frequency domain by
    :func:`ehsa_opt.vehicle.frequency_path.linear_metrics`, vectorised over designs.

    Attributes
    ----------
    vehicle, road : VehicleParams, RoadParams
        Quarter car and road (class, speed).
    base : HarvesterParams
        Fixed harvester fields (R_i, L_i, …); design variables override it.
    metric_options : tuple of (key, value)
        Extra keyword arguments of ``linear_metrics`` (e.g. ``n_freq``).
    """

    vehicle: VehicleParams
    road: RoadParams
    base: HarvesterParams = field(default_factory=HarvesterParams)
    metric_options: tuple[tuple[str, Any], ...] = ()
    motor: Any = None
    stroke_limit_m: float | None = None
    #: tolerances of the limits (:class:`~.limits.LimitSettings`; None: the defaults)
    limits: Any = None

    objective_names = OBJECTIVE_NAMES

    @property
    def constraint_names(self) -> tuple[str, ...]:
        """Inequality constraints (value ≤ 0 feasible, each normalised by its limit):
        the motor's rated limits that it states (rms current, short-term current, peak
        voltage, power, speed), the stroke, and a catalogue motor's rotor inertia within
        J_t (:mod:`.limits`)."""
        out = []
        rating = getattr(self.motor, "rating", None)
        if rating is not None:
            for name, key in (("rated_current", "current_A"), ("peak_current", None),
                              ("rated_voltage", "voltage_V"), ("rated_power", "power_W")):
                if key is None:
                    if getattr(self.motor, "peak_current_A", None) is not None:
                        out.append(name)
                elif getattr(rating, key) is not None:
                    out.append(name)
        if getattr(self.motor, "max_speed_rpm", None) is not None:
            out.append("motor_speed")
        if self.stroke_limit_m is not None:
            out.append("stroke")
        if getattr(self.motor, "kind", None) == "catalogue":
            out.append("motor_inertia")
        return tuple(out)

    def _voltage_constant(self, design: Mapping[str, Any]) -> np.ndarray:
        if getattr(self.motor, "kind", None) == "catalogue":
            return np.asarray(self.motor.voltage_constant_Vs_per_rad, dtype=float)
        if "speed_constant_rpm_per_V" in design:
            return 60.0 / (2.0 * math.pi * np.asarray(design["speed_constant_rpm_per_V"],
                                                      dtype=float))
        if "voltage_constant_Vs_per_rad" in design:
            return np.asarray(design["voltage_constant_Vs_per_rad"], dtype=float)
        return np.asarray(self.base.voltage_constant_Vs_per_rad, dtype=float)

    def design_mapping(self, design: Mapping[str, Any]) -> dict[str, Any]:
        """The ``linear_metrics`` design mapping: base fields + design variables, with the
        motor model's winding (R_i, L_i) at the design's voltage constant."""
        fixed: dict[str, Any] = {"internal_resistance_ohm": self.base.internal_resistance_ohm,
                                 "inductance_H": self.base.inductance_H}
        if "total_inertia_gcm2" not in design:
            fixed["total_inertia_gcm2"] = self.base.total_inertia_gcm2
        if "speed_constant_rpm_per_V" not in design and "voltage_constant_Vs_per_rad" not in design:
            fixed["voltage_constant_Vs_per_rad"] = self.base.voltage_constant_Vs_per_rad
            fixed["torque_constant_Nm_per_A"] = self.base.torque_constant_Nm_per_A
        for key in ("lead_mm_per_rev", "load_ohm"):
            if key not in design:
                fixed[key] = getattr(self.base, key)
        fixed.update({k: np.asarray(v, dtype=float) for k, v in design.items()})
        if self.motor is not None:
            ke = self._voltage_constant(design)
            if getattr(self.motor, "kind", None) == "catalogue":
                fixed.pop("speed_constant_rpm_per_V", None)
                fixed["voltage_constant_Vs_per_rad"] = ke
                fixed["torque_constant_Nm_per_A"] = ke
            w = self.motor.winding(ke)
            fixed["internal_resistance_ohm"] = w["internal_resistance_ohm"]
            fixed["inductance_H"] = w["inductance_H"]
        return fixed

    def __call__(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        from ..vehicle.frequency_path import linear_metrics
        mapping = self.design_mapping(design)
        m = linear_metrics(self.vehicle, self.road, mapping, **dict(self.metric_options))
        out = {"comfort": m["comfort"], "road_holding": m["road_holding"],
               "inverse_power": 1.0 / m["power_dimensionless"],
               "inverse_efficiency": 1.0 / m["efficiency"]}
        for key in ("comfort_weighted_rms_m_s2", "power_W", "efficiency", "power_dimensionless",
                    "dissipated_power_W", "dissipation_bound_W", "current_rms_A",
                    "voltage_rms_V", "stroke_rms_m", "stroke_velocity_rms_m_s"):
            if key in m:
                out[key] = m[key]
        out.update(self.constraints(mapping, m))
        return out

    def constraints(self, mapping: Mapping[str, Any], m: Mapping[str, np.ndarray]
                    ) -> dict[str, np.ndarray]:
        """Every limit as value, limit, fraction of time beyond and ``constraint_<name>`` =
        value / limit − 1 (≤ 0 feasible; :mod:`.limits`), and the winding used."""
        from .limits import LimitSettings, gaussian_fraction_beyond, limit_entry, \
            rice_peak_quantile
        names = self.constraint_names
        if not names and self.motor is None:
            return {}
        st = self.limits or LimitSettings()
        z2 = st.z_two_sided
        shape = np.shape(m["comfort"])
        ri = np.broadcast_to(np.asarray(mapping["internal_resistance_ohm"], float), shape)
        out = {"internal_resistance_ohm": ri}
        w = self.motor.winding(self._voltage_constant(mapping)) if self.motor is not None \
            else {}
        lim = {k: np.broadcast_to(np.asarray(v, float), shape) for k, v in w.items()
               if k.startswith(("rated_", "peak_", "max_"))}
        si = m["current_rms_A"]
        if "rated_current" in names:
            out.update(limit_entry("rated_current", si, lim["rated_current_A"],
                                   gaussian_fraction_beyond(lim["rated_current_A"], si)))
        if "peak_current" in names:
            out.update(limit_entry("peak_current", z2 * si, lim["peak_current_A"],
                                   gaussian_fraction_beyond(lim["peak_current_A"], si)))
        if "rated_voltage" in names:
            v_lim = lim.get("max_voltage_V", lim["rated_voltage_V"])
            re = np.broadcast_to(np.asarray(mapping.get("load_ohm", self.base.load_ohm),
                                            float), shape)
            rate = m.get("current_rate_rms_A_per_s")
            v_peak = (rice_peak_quantile(m["voltage_rms_V"], re * rate,
                                         self.road.length_m / self.road.speed_m_per_s,
                                         st.peak_quantile)
                      if rate is not None else z2 * m["voltage_rms_V"])
            out["peak_voltage_V"] = v_peak
            if rate is not None:  # the 95 % interval of the road's peak (2.5 %, 97.5 %)
                for key, q in (("peak_voltage_low_V", 0.025), ("peak_voltage_high_V", 0.975)):
                    out[key] = rice_peak_quantile(m["voltage_rms_V"], re * rate,
                                                  self.road.length_m / self.road.speed_m_per_s,
                                                  q)
            out.update(limit_entry("rated_voltage", v_peak, v_lim,
                                   gaussian_fraction_beyond(v_lim, m["voltage_rms_V"])))
        if "rated_power" in names:
            p_el = m["power_W"] + ri * si ** 2
            out.update(limit_entry("rated_power", p_el, lim["rated_power_W"], np.nan))
        if "motor_speed" in names:
            lead = np.asarray(mapping.get("lead_mm_per_rev", self.base.lead_mm_per_rev), float)
            rpm = m["stroke_velocity_rms_m_s"] / (lead * 1e-3) * 60.0
            out.update(limit_entry("motor_speed", z2 * rpm, lim["max_speed_rpm"],
                                   gaussian_fraction_beyond(lim["max_speed_rpm"], rpm)))
        if "stroke" in names:
            out.update(limit_entry("stroke", z2 * m["stroke_rms_m"], self.stroke_limit_m,
                                   gaussian_fraction_beyond(self.stroke_limit_m,
                                                            m["stroke_rms_m"])))
        if "motor_inertia" in names:
            jt = np.broadcast_to(np.asarray(mapping.get("total_inertia_gcm2",
                                                        self.base.total_inertia_gcm2), float),
                                 shape)
            out.update(limit_entry("motor_inertia", self.motor.motor_inertia_gcm2, jt,
                                   np.zeros(shape)))
        for k in ("rated_current_A", "rated_voltage_V", "rated_power_W"):
            if k in lim:
                out[k] = lim[k]
        return {k: np.broadcast_to(v, shape) for k, v in out.items()}

    def fingerprint(self) -> dict[str, Any]:
        from dataclasses import asdict
        fp = {"kind": "quarter_car_linear", "vehicle": asdict(self.vehicle),
              "road": asdict(self.road), "base": asdict(self.base),
              "options": dict(self.metric_options)}
        if self.motor is not None or self.stroke_limit_m is not None:
            fp["motor"] = None if self.motor is None else self.motor.fingerprint()
            fp["stroke_limit_m"] = self.stroke_limit_m
        return fp


# --------------------------------------------------------------------------- pymoo problem
@dataclass(frozen=True)
class _ObjectiveChunk:
    """Picklable task: objective (and constraint) matrix of a block of unit-cube points."""

    space: DesignSpace
    evaluator: Any
    names: tuple[str, ...]

    def __call__(self, U: np.ndarray) -> np.ndarray:
        res = self.evaluator(self.space.from_unit(U))
        return np.column_stack([np.broadcast_to(np.asarray(res[k], float), (U.shape[0],))
                                for k in self.names])


class DesignProblem(Problem):
    """The design problem as a pymoo :class:`~pymoo.core.problem.Problem`.

    Decision variables are unit-cube coordinates of ``space`` (see
    :meth:`DesignSpace.from_unit`); objectives are ``evaluator.objective_names``,
    all minimised.  ``_evaluate`` is vectorised: the whole population goes to the
    evaluator in one call.

    Parameters
    ----------
    space : DesignSpace
    evaluator : callable
        ``evaluator(design: dict[str, ndarray]) -> dict[str, ndarray]`` with an
        attribute ``objective_names``; must be picklable (process pools, Dask).
    """

    #: designs per evaluation block (see :meth:`objectives_unit`)
    CHUNK = 64

    def __init__(self, space: DesignSpace, evaluator: Callable[..., Mapping[str, Any]]) -> None:
        self.space = space
        self.evaluator = evaluator
        self.objective_names = tuple(evaluator.objective_names)
        #: inequality constraints (≤ 0 feasible) the evaluator returns as
        #: ``constraint_<name>``; pymoo ranks feasibility first
        self.constraint_names = tuple(getattr(evaluator, "constraint_names", ()))
        #: optional ``mapper(fn, list_of_chunks) -> list`` (local pool or Dask, see
        #: :mod:`ehsa_opt.design.sweep`) to spread a population over workers; not pickled
        self.mapper: Any = None
        #: feasible designs to seed a population with (unit cube, shape (k, n_var)), e.g.
        #: the prototype when the limits are its own demands; see :meth:`seed_population`
        self.initial: np.ndarray | None = None
        #: the :class:`ehsa_opt.design.config.DesignConfig` of a problem read from a file
        self.config: Any = None
        #: where the friction sets came from (``FILE:CASE``), for the record
        self.friction_labels: tuple[str, ...] = ()
        super().__init__(n_var=space.n, n_obj=len(self.objective_names),
                         n_ieq_constr=len(self.constraint_names), xl=0.0, xu=1.0, vtype=float)

    def with_objective(self, name: str, func: Callable[[Mapping[str, np.ndarray]], Any],
                       unit: str = "-") -> "DesignProblem":
        """A copy of this problem with one more objective (minimised).

        Parameters
        ----------
        name : str
            Its column name, with its unit (e.g. ``"peak_current_A"``).
        func : callable
            ``func(outputs) -> array``: ``outputs`` maps every evaluator output (the
            objectives, ``power_W``, ``efficiency``, ``current_rms_A``, ``voltage_rms_V``,
            ``stroke_rms_m`` …) and design variable to an array over the designs.
        unit : str
            Its unit, shown in tables.

        Returns
        -------
        DesignProblem
            The extended problem; this one is unchanged.  Goal attainment needs the four
            built-in objectives; NSGA-II and any other pymoo algorithm take the new one.
        """
        from .extension import UserQuantity
        return self.extended(objectives=(UserQuantity(name, func, unit),))

    def with_constraint(self, name: str, func: Callable[[Mapping[str, np.ndarray]], Any],
                        upper: float, unit: str = "-") -> "DesignProblem":
        """A copy of this problem with one more inequality constraint ``func ≤ upper``.

        ``func`` is as in :meth:`with_objective`; pymoo sees
        ``(func − upper) / |upper| ≤ 0`` (normalised by its limit, as the built-in rated
        limits), named
        ``constraint_<name>`` in the outputs and ``<name>`` in :attr:`constraint_names`.
        """
        from .extension import UserQuantity
        return self.extended(constraints=(UserQuantity(name, func, unit, float(upper)),))

    def extended(self, objectives: tuple = (), constraints: tuple = ()) -> "DesignProblem":
        from .extension import ExtendedObjectives
        ev = self.evaluator
        if isinstance(ev, ExtendedObjectives):
            objectives, constraints = ev.objectives + objectives, ev.user_constraints + constraints
            ev = ev.inner
        new = DesignProblem(self.space, ExtendedObjectives(ev, objectives, constraints))
        new.mapper, new.initial, new.config = self.mapper, self.initial, self.config
        new.friction_labels = self.friction_labels
        return new

    @property
    def units(self) -> dict[str, str]:
        """Unit of each user objective and constraint (built-in names carry theirs)."""
        ev = self.evaluator
        return {q.name: q.unit for q in getattr(ev, "objectives", ()) + getattr(
            ev, "user_constraints", ()) if hasattr(q, "unit")}

    def seed_population(self, pop_size: int, seed: int, initial: Any = None
                        ) -> np.ndarray | None:
        """The first population the problem asks for (unit cube): its feasible
        :attr:`initial` designs (or ``initial``) first, the rest drawn uniformly with
        ``seed``; None when there is no seed design (any sampling will do).

        The built-in NSGA-II uses it, and so does :func:`ehsa_opt.optimize` for any
        pymoo algorithm that keeps pymoo's default random sampling: with rated-limit
        constraints most of the box is infeasible, and a population without one
        feasible design can end the run with none."""
        initial = self.initial if initial is None else initial
        if initial is None:
            return None
        first = np.atleast_2d(np.asarray(initial, dtype=float))[:pop_size]
        rest = np.random.default_rng(seed).random((pop_size - first.shape[0], self.n_var))
        return np.clip(np.vstack([first, rest]), 0.0, 1.0)

    def evaluate_design(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """All evaluator outputs (objectives and extras) of physical designs."""
        return {k: np.asarray(v, dtype=float) for k, v in self.evaluator(design).items()}

    def objectives_unit(self, U: Any) -> np.ndarray:
        """Objective matrix (n, n_obj) of unit-cube points ``U`` (n, n_var)."""
        return self.evaluate_unit(U)[:, :len(self.objective_names)]

    def evaluate_unit(self, U: Any) -> np.ndarray:
        """Objectives then constraints, (n, n_obj + n_constr), of unit-cube points."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        # fixed blocks of CHUNK designs, locally and on a mapper alike: vectorised
        # evaluators may round differently with the batch size, and the blocks make
        # local and distributed runs bit-identical
        blocks = np.array_split(U, max(1, -(-U.shape[0] // self.CHUNK)))
        task = _ObjectiveChunk(self.space, self.evaluator, self.objective_names
                               + tuple(f"constraint_{c}" for c in self.constraint_names))
        if self.mapper is not None and len(blocks) > 1:
            return np.vstack(self.mapper(task, blocks))
        return np.vstack([task(b) for b in blocks])

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["mapper"] = None  # executors/clients are not part of the problem's state
        return state

    def _evaluate(self, X: np.ndarray, out: dict, *args: Any, **kwargs: Any) -> None:
        FG = self.evaluate_unit(X)
        # a non-finite objective (numerically broken design) must not poison sorting
        FG = np.where(np.isfinite(FG), FG, 1e30)
        n_obj = len(self.objective_names)
        out["F"] = FG[:, :n_obj]
        if self.constraint_names:
            out["G"] = FG[:, n_obj:]

    def fingerprint(self) -> str:
        """Hash of the box and the evaluator settings (guards resumes)."""
        ev = self.evaluator
        desc = ev.fingerprint() if hasattr(ev, "fingerprint") else repr(ev)
        blob = json.dumps({"space": self.space.as_dict(), "evaluator": desc,
                           "objectives": self.objective_names}, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]
