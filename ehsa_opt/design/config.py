"""Problem files for design studies: the ``[design]``, ``[goals]``,
``[goal_attainment]``, ``[nsga2]`` and ``[sweep]`` tables.

The physical part (``preset`` or ``[vehicle]``, ``[harvester]``, ``[road]``,
``[friction]``, ``[simulation]``) is a quarter-car problem file parsed by
:func:`ehsa_opt.datasets.problem_file.problem_from_mapping` (``[road]`` defaults to class C
at 70 km/h here).  Example
(``problems/paper_design.toml``)::

    preset = "passenger_car"    # or a [vehicle] table (ehsa_opt.datasets.problem_file format)
    [harvester]                 # the prototype: start point and goal reference
    load_ohm = 47.0
    [road]
    iso_class = "C"
    speed_km_per_h = 70.0
    [design]
    method = "goal-attainment"  # or "nsga2"
    n_freq = 1024               # frequency points of the exact linear evaluation
    log_scaled = ["total_inertia_gcm2", "speed_constant_rpm_per_V", "load_ohm"]
    [design.bounds]             # paper Table 3
    total_inertia_gcm2 = [250.0, 10000.0]
    lead_mm_per_rev = [5.0, 20.0]
    speed_constant_rpm_per_V = [29.8, 11900.0]
    load_ohm = [1.0, 10000.0]
    [goals]
    relative_to_prototype = 1.0 # goal_i = 1.0 × F_i(prototype); or give values:
    # comfort = 0.1
    [goals.weights]             # default |goal_i|
    [goal_attainment]
    n_starts = 6
    seed = 0
    [nsga2]
    pop = 40
    gens = 25
    seed = 1
    pick = "knee"
    hv_reference = 2.0          # reference point, in units of the prototype's objectives
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from ..physics.params import (
    HarvesterParams,
    ParameterError,
    RoadParams,
    VehicleParams,
    check_keys,
    load_toml,
    nearest_name,
)
from .problem import DESIGN_VARIABLES, OBJECTIVE_NAMES, DesignSpace

__all__ = ["METHODS", "GoalSpec", "NSGA2Settings", "GoalAttainmentSettings", "DesignConfig",
           "load_design_config", "parse_design_config"]

#: Optimisation methods of ``ehsa-opt optimize``.
METHODS: tuple[str, ...] = ("goal-attainment", "nsga2")

#: Physical tables, parsed by :func:`ehsa_opt.datasets.problem_file.problem_from_mapping`.
_PHYSICAL = ("preset", "vehicle", "harvester", "friction", "road", "simulation")
_TOP = _PHYSICAL + ("design", "goals", "goal_attainment", "nsga2", "sweep", "title",
                    "description", "motor", "screw", "limits")


def _check_keys(table: Mapping[str, Any], valid: tuple[str, ...], where: str) -> None:
    check_keys(table, valid, where)


def _int(value: Any, where: str, minimum: int = 0, maximum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ParameterError(f"{where} must be an integer >= {minimum}, got {value!r}")
    if maximum is not None and value > maximum:
        raise ParameterError(f"{where} = {value} is too large: it must be <= {maximum}")
    return int(value)


def _float(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not math.isfinite(value):
        raise ParameterError(f"{where} must be a finite number, got {value!r}")
    return float(value)


#: Bounds of the size settings: beyond them a study would not finish or not fit in memory.
MAX_N_FREQ = 65_536
MAX_POP = 10_000
MAX_GENS = 100_000
MAX_STARTS = 1_000


def check_method(method: str, where: str = "--method") -> str:
    """Validate an optimisation method name."""
    if method not in METHODS:
        near = nearest_name(method, METHODS)
        hint = f"; did you mean '{near}'?" if near else ""
        raise ParameterError(f"{where}: unknown method '{method}'{hint} (valid: "
                             f"{', '.join(METHODS)})")
    return method


@dataclass(frozen=True)
class GoalSpec:
    """Goals and weights of goal attainment.

    ``goals[name]`` given explicitly, else ``relative_to_prototype × F(prototype)``;
    ``weights[name]`` given explicitly, else |goal|.
    """

    relative_to_prototype: float = 1.0
    goals: tuple[tuple[str, float], ...] = ()
    weights: tuple[tuple[str, float], ...] = ()


@dataclass(frozen=True)
class GoalAttainmentSettings:
    """SLSQP multistart settings (see :func:`ehsa_opt.design.problem.solve_goal_attainment`)."""

    n_starts: int = 6
    seed: int = 0
    max_iter: int = 300


@dataclass(frozen=True)
class NSGA2Settings:
    """NSGA-II settings; ``hv_reference`` is in units of the prototype objectives."""

    pop: int = 40
    gens: int = 25
    seed: int = 1
    pick: str = "knee"
    pick_weights: tuple[float, ...] | None = None
    hv_reference: float = 2.0

    def __post_init__(self) -> None:
        if self.pop < 4:
            raise ParameterError(f"[nsga2] pop must be >= 4, got {self.pop}")
        if self.gens < 1:
            raise ParameterError(f"[nsga2] gens must be >= 1, got {self.gens}")
        if self.pick not in ("knee", "compromise", "preference"):
            raise ParameterError(f"[nsga2] pick '{self.pick}' unknown (valid: knee, compromise, "
                                 f"preference)")
        if self.pick == "preference" and (self.pick_weights is None
                                          or len(self.pick_weights) != len(OBJECTIVE_NAMES)):
            raise ParameterError("[nsga2] pick = 'preference' needs pick_weights with "
                                 f"{len(OBJECTIVE_NAMES)} values ({', '.join(OBJECTIVE_NAMES)})")
        if not (self.hv_reference > 0 and math.isfinite(self.hv_reference)):
            raise ParameterError(f"[nsga2] hv_reference = {self.hv_reference!r} must be a "
                                 f"finite number > 0 (in units of the prototype's objectives, "
                                 f"e.g. 2.0)")


@dataclass(frozen=True)
class DesignConfig:
    """Everything a design study needs, parsed and validated from a problem file."""

    path: str
    vehicle: VehicleParams
    vehicle_name: str
    road: RoadParams
    harvester: HarvesterParams
    space: DesignSpace
    method: str = "goal-attainment"
    goals: GoalSpec = field(default_factory=GoalSpec)
    goal_attainment: GoalAttainmentSettings = field(default_factory=GoalAttainmentSettings)
    nsga2: NSGA2Settings = field(default_factory=NSGA2Settings)
    raw: Mapping[str, Any] = field(default_factory=dict)
    n_freq: int = 1024
    physical: Any = None  #: the :class:`ehsa_opt.datasets.problem_file.QuarterCarProblem` of the file
    #: generator model of the design space: "select" (motor, winding and screw chosen from
    #: catalogues, every hardware limit a constraint), "scaling" (the [harvester]'s frame
    #: rewound, R_i, L_i ∝ K_e², with the ratings [motor] gives), "catalogue" (one run per
    #: motor of ``catalogue``) or "paper" (R_i, L_i fixed, no limits: the paper's
    #: assumption; the default without a [motor] table)
    motor_model: str = "paper"
    motor_rating: Any = None  #: RatedLimits of the scaling frame (None: the default)
    catalogue: str | None = None
    #: screw catalogue of a "select" model (None: the lead stays a continuous variable)
    screw_catalogue: str | None = None
    #: tolerances of the hardware limits (``[limits]``)
    limits: Any = None

    @property
    def limit_settings(self) -> Any:
        """The :class:`~.limits.LimitSettings` of ``[limits]`` (defaults when absent)."""
        from .limits import LimitSettings
        return self.limits if self.limits is not None else LimitSettings()

    @property
    def design_space(self) -> DesignSpace:
        """The box the optimiser searches: the file's box, or for a "select" model that box
        without k_n (and the lead, with screws) plus the catalogue variables ``motor``,
        ``winding`` and ``screw`` (:func:`~.selection.selection_space`)."""
        if self.motor_model != "select":
            return self.space
        from .selection import selection_space
        motors = self.catalogue_motors()
        screws = self.screws()
        return selection_space(self.space, len(motors), len(screws),
                               any(m.rewindable for m in motors))

    def screws(self) -> list:
        """The screws of the screw catalogue (empty without one)."""
        if self.screw_catalogue is None:
            return []
        from ..physics.ball_screw import load_screws
        return load_screws(self.screw_catalogue)

    def motor(self) -> Any:
        """The motor model object at the current [harvester] (None for a catalogue or a
        selection: see :meth:`catalogue_motors`).  The scaling frame's ratings come from
        ``[motor]`` (the motor's data), never from the prototype's demand."""
        from ..physics.motor import FixedWindingMotor, ScalingMotor
        if self.motor_model == "scaling":
            if self.motor_rating is None or self.motor_rating.current_A is None \
                    or self.motor_rating.voltage_V is None:
                raise ParameterError(
                    f"{self.path} [motor]: model 'scaling' rewinds one frame and needs that "
                    "frame's ratings from its datasheet: give rated_current_A (continuous) "
                    "and rated_voltage_V (largest terminal voltage), or use model 'select' "
                    "(motors from a catalogue) or 'paper' (the paper's space, no limits)")
            return ScalingMotor(self.harvester, self.motor_rating)
        if self.motor_model == "paper":
            return FixedWindingMotor(self.harvester)
        return None

    def catalogue_motors(self) -> list:
        from ..physics.motor import load_catalogue
        return load_catalogue(self.catalogue or "dc_generators")

    @property
    def stroke_limit_m(self) -> float | None:
        """The stroke constraint (the vehicle's limit); none in the paper's problem."""
        return None if self.motor_model == "paper" else self.vehicle.stroke_limit_m

    @property
    def prototype_design(self) -> dict[str, float]:
        """The [harvester] (prototype) expressed in the box's design variables."""
        h = self.harvester
        values = {"total_inertia_gcm2": h.total_inertia_gcm2,
                  "lead_mm_per_rev": h.lead_mm_per_rev,
                  "speed_constant_rpm_per_V": h.speed_constant_rpm_per_V,
                  "load_ohm": h.load_ohm}
        for n in self.space.names:
            if n not in values:
                values[n] = getattr(h, n)
        return {n: float(values[n]) for n in self.space.names}


def parse_design_config(doc: Mapping[str, Any], path: str = "problem") -> DesignConfig:
    """Build a :class:`DesignConfig` from a parsed TOML document."""
    from ..datasets.problem_file import problem_from_mapping

    _check_keys(doc, _TOP, path)
    phys_doc = {k: doc[k] for k in _PHYSICAL if k in doc}
    phys_doc.setdefault("road", {"iso_class": "C", "speed_km_per_h": 70.0})
    phys = problem_from_mapping(phys_doc, path, Path(path).parent if path else ".")
    vehicle, road, harvester = phys.vehicle, phys.road, phys.harvester
    vname = str(doc["preset"]) if "preset" in doc else "custom"

    dt = doc.get("design", {})
    _check_keys(dt, ("method", "bounds", "log_scaled", "n_freq"), f"{path} [design]")
    n_freq = _int(dt.get("n_freq", 1024), f"{path} [design] n_freq", 16, MAX_N_FREQ)
    method = check_method(str(dt.get("method", "goal-attainment")), f"{path} [design] method")
    bounds = dt.get("bounds", {
        "total_inertia_gcm2": [250.0, 10000.0], "lead_mm_per_rev": [5.0, 20.0],
        "speed_constant_rpm_per_V": [29.8, 11900.0], "load_ohm": [1.0, 10000.0]})
    valid_vars = DESIGN_VARIABLES + ("internal_resistance_ohm", "inductance_H")
    _check_keys(bounds, valid_vars, f"{path} [design.bounds]")
    log = dt.get("log_scaled")
    space = DesignSpace.from_bounds(bounds, log=log, where=f"{path} [design.bounds]")

    gt = doc.get("goals", {})
    _check_keys(gt, ("relative_to_prototype", "weights") + OBJECTIVE_NAMES, f"{path} [goals]")
    rel = _float(gt.get("relative_to_prototype", 1.0), f"{path} [goals] relative_to_prototype")
    goals = tuple((k, _float(gt[k], f"{path} [goals] {k}")) for k in OBJECTIVE_NAMES if k in gt)
    wt = gt.get("weights", {})
    _check_keys(wt, OBJECTIVE_NAMES, f"{path} [goals.weights]")
    weights = tuple((k, _float(wt[k], f"{path} [goals.weights] {k}")) for k in OBJECTIVE_NAMES
                    if k in wt)
    if weights and len(weights) != len(OBJECTIVE_NAMES):
        missing = [k for k in OBJECTIVE_NAMES if k not in wt]
        raise ParameterError(f"{path} [goals.weights]: give all four weights or none "
                             f"(missing: {', '.join(missing)})")

    ga = doc.get("goal_attainment", {})
    _check_keys(ga, ("n_starts", "seed", "max_iter"), f"{path} [goal_attainment]")
    gas = GoalAttainmentSettings(
        n_starts=_int(ga.get("n_starts", 6), f"{path} [goal_attainment] n_starts", 1,
                      MAX_STARTS),
        seed=_int(ga.get("seed", 0), f"{path} [goal_attainment] seed"),
        max_iter=_int(ga.get("max_iter", 300), f"{path} [goal_attainment] max_iter", 1))

    nt = doc.get("nsga2", {})
    _check_keys(nt, ("pop", "gens", "seed", "pick", "pick_weights", "hv_reference"),
                f"{path} [nsga2]")
    pw = nt.get("pick_weights")
    ns = NSGA2Settings(
        pop=_int(nt.get("pop", 40), f"{path} [nsga2] pop", 4, MAX_POP),
        gens=_int(nt.get("gens", 25), f"{path} [nsga2] gens", 1, MAX_GENS),
        seed=_int(nt.get("seed", 1), f"{path} [nsga2] seed"),
        pick=str(nt.get("pick", "knee")),
        pick_weights=None if pw is None else tuple(_float(v, f"{path} [nsga2] pick_weights")
                                                   for v in pw),
        hv_reference=_float(nt.get("hv_reference", 2.0), f"{path} [nsga2] hv_reference"))
    model, rating, catalogue = _parse_motor(doc.get("motor", {}), path, space)
    screws = _parse_screw(doc.get("screw"), path, model)
    return DesignConfig(path=path, vehicle=vehicle, vehicle_name=vname, road=road,
                        harvester=harvester, space=space, method=method,
                        goals=GoalSpec(rel, goals, weights), goal_attainment=gas, nsga2=ns,
                        raw=doc, n_freq=n_freq, physical=phys, motor_model=model,
                        motor_rating=rating, catalogue=catalogue, screw_catalogue=screws,
                        limits=_parse_limits(doc.get("limits", {}), path))


def _parse_limits(lt: Mapping[str, Any], path: str) -> Any:
    """The ``[limits]`` table: the tolerances of the hardware limits."""
    from .limits import LimitSettings
    where = f"{path} [limits]"
    keys = ("time_fraction", "peak_quantile", "tyre_lift_fraction", "screw_life_km")
    _check_keys(lt, keys, where)
    try:
        return LimitSettings(**{k: _float(lt[k], f"{where} {k}") for k in keys if k in lt})
    except ParameterError as exc:
        raise ParameterError(f"{path} {exc}") from None


def _parse_screw(st: Any, path: str, model: str) -> str | None:
    """The ``[screw]`` table (``catalogue = "ball_screws"`` or a path): the screws a
    "select" model chooses from; absent, the lead stays a continuous variable."""
    if st is None:
        return None
    where = f"{path} [screw]"
    if not isinstance(st, Mapping):
        raise ParameterError(f"{where}: must be a table with catalogue = \"ball_screws\"")
    _check_keys(st, ("catalogue",), where)
    if model != "select":
        raise ParameterError(f"{where}: a screw catalogue needs [motor] model = 'select' (the "
                             f"optimiser chooses motor and screw); remove [screw] for '{model}'")
    name = st.get("catalogue", "ball_screws")
    if not isinstance(name, str):
        raise ParameterError(f"{where} catalogue: give 'ball_screws' or a path as text")
    from ..physics.ball_screw import load_screws, screw_catalogue_path
    base = Path(path).parent if path else Path(".")
    if name.endswith(".toml") or len(Path(name).parts) > 1:
        from ..datasets.friction_source import resolve_reference
        resolve_reference(name, base, f"{where} catalogue")
    try:
        p = str(screw_catalogue_path(name, base))
        load_screws(p)
    except ParameterError as exc:
        raise ParameterError(f"{where} {exc}") from None
    return p


def _parse_motor(mt: Mapping[str, Any], path: str, space: DesignSpace
                 ) -> tuple[str, Any, str | None]:
    """The ``[motor]`` table: model, the scaling frame's ratings, the catalogue file."""
    from ..physics.motor import MOTOR_MODELS, RatedLimits, catalogue_path
    where = f"{path} [motor]"
    _check_keys(mt, ("model", "catalogue", "rated_voltage_V", "rated_current_A",
                     "rated_power_W"), where)
    # default: a catalogue when one is named, the scaling frame when its ratings are given,
    # else the paper's space (no hardware data, no limits: labelled as the paper's)
    model = str(mt.get("model", "catalogue" if "catalogue" in mt else "scaling" if any(
        k.startswith("rated_") for k in mt) else "paper"))
    if model not in MOTOR_MODELS:
        near = nearest_name(model, MOTOR_MODELS)
        raise ParameterError(f"{where} model: unknown '{model}'"
                             + (f"; did you mean '{near}'?" if near else "")
                             + f" (valid: {', '.join(MOTOR_MODELS)})")
    ratings = {k: _float(mt[k], f"{where} {k}") for k in ("rated_voltage_V", "rated_current_A",
                                                          "rated_power_W") if k in mt}
    if ratings and model != "scaling":
        raise ParameterError(f"{where}: rated_* values set the scaling frame's ratings; a "
                             f"'{model}' model takes none (catalogue motors carry their own)")
    rating = RatedLimits(ratings.get("rated_voltage_V"), ratings.get("rated_current_A"),
                         ratings.get("rated_power_W")) if ratings else None
    catalogue = None
    if model in ("catalogue", "select"):
        name = mt.get("catalogue", "dc_generators")
        if not isinstance(name, str):
            raise ParameterError(f"{where} catalogue: give the path of a catalogue file "
                                 f"(relative to the problem file) or 'dc_generators' as text")
        base = Path(path).parent if path else Path(".")
        if name.endswith(".toml") or len(Path(name).parts) > 1:  # a file: confined, must exist
            from ..datasets.friction_source import resolve_reference
            resolve_reference(name, base, f"{where} catalogue")
        try:
            catalogue = str(catalogue_path(name, base))
        except ParameterError as exc:
            raise ParameterError(f"{where} {exc}") from None
        from ..physics.motor import load_catalogue
        load_catalogue(catalogue)  # refused now, before any work, naming the file and key
        if "speed_constant_rpm_per_V" in space.names and model == "catalogue":
            raise ParameterError(f"{path} [design.bounds]: a catalogue motor fixes k_n; remove "
                                 "speed_constant_rpm_per_V from the box with [motor] model = "
                                 "'catalogue'")
    elif "catalogue" in mt:
        raise ParameterError(f"{where}: 'catalogue' needs model = 'catalogue' or 'select'")
    return model, rating, catalogue


def load_design_config(path: str | Path) -> DesignConfig:
    """Read and validate a design problem file (see module docstring): a path, or the
    name of a problem shipped with the package (``"paper_design"``)."""
    from ..datasets.problem_file import resolve_problem_path
    path = resolve_problem_path(path)
    return parse_design_config(load_toml(path), str(path))
