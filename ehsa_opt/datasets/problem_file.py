"""Quarter-car problem files (``ehsa-opt simulate PROBLEM.toml``).

```toml
preset = "passenger_car"          # or a [vehicle] table (not both)
[harvester]                       # any HarvesterParams field; defaults otherwise
load_ohm = 47.0
[friction]                        # optional; absent = frictionless
nut_coulomb_N = 40.0
[road]                            # iso_class, speed_km_per_h, length_m, seed | profile_csv
iso_class = "C"
speed_km_per_h = 100.0
[simulation]                      # optional
settle_s = 2.0
sample_rate_hz = 1000.0
```

Names as the parameters' field names.  Unknown keys are refused with the nearest valid name;
``profile_csv`` is relative to the problem file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from .friction_source import friction_from_table, resolve_reference
from ..physics.params import (
    FrictionParams,
    HarvesterParams,
    ParameterError,
    RoadParams,
    VehicleParams,
    check_keys,
    from_mapping,
    load_toml,
    nearest_name,
)

__all__ = ["SimulationSettings", "QuarterCarProblem", "load_problem", "problem_from_mapping",
           "resolve_problem_path", "resolve_reference"]

_TOP_KEYS = ("preset", "vehicle", "harvester", "friction", "road", "simulation")


@dataclass(frozen=True)
class SimulationSettings:
    """Time-domain settings.

    Attributes
    ----------
    settle_s : float
        Start excluded from the metrics, s (default 2.0).
    sample_rate_hz : float
        Samples per second (default 1000).
    rated_voltage_V, rated_current_A : float, optional
        The generator's rated terminal voltage / current: ``simulate`` warns when the
        peak terminal voltage i·R_e (current i) exceeds it.
    """

    settle_s: float = 2.0
    sample_rate_hz: float = 1000.0
    rated_voltage_V: float | None = None
    rated_current_A: float | None = None

    def __post_init__(self) -> None:
        for name in ("rated_voltage_V", "rated_current_A"):
            value = getattr(self, name)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value) or value <= 0:
                raise ParameterError(f"simulation: '{name}' must be a number > 0, got "
                                     f"{value!r} (the generator's rated terminal limit)")
            object.__setattr__(self, name, float(value))
        for name in ("settle_s", "sample_rate_hz"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                raise ParameterError(f"simulation: '{name}' must be a finite number, got "
                                     f"{value!r}")
            object.__setattr__(self, name, float(value))
        if self.settle_s < 0.0:
            raise ParameterError(f"simulation: 'settle_s' = {self.settle_s:g} must be >= 0 s")
        if self.sample_rate_hz <= 0.0:
            raise ParameterError(f"simulation: 'sample_rate_hz' = {self.sample_rate_hz:g} must "
                                 "be > 0 Hz, e.g. 1000")


@dataclass(frozen=True)
class QuarterCarProblem:
    """A parsed problem file."""

    vehicle: VehicleParams
    harvester: HarvesterParams
    friction: FrictionParams | None
    road: RoadParams
    simulation: SimulationSettings = field(default_factory=SimulationSettings)
    base_dir: Path = Path(".")


def problem_from_mapping(data: Mapping[str, Any], where: str = "problem",
                         base_dir: str | Path = ".") -> QuarterCarProblem:
    """Build a :class:`QuarterCarProblem` from a parsed TOML mapping."""
    check_keys(data, _TOP_KEYS, where)
    if "preset" in data and "vehicle" in data:
        raise ParameterError(f"{where}: give either preset = \"...\" or a [vehicle] table, "
                             "not both")
    if "preset" in data:
        if not isinstance(data["preset"], str):
            raise ParameterError(f"{where}: preset must be a string, e.g. preset = "
                                 "\"passenger_car\"")
        try:
            vehicle = VehicleParams.preset(data["preset"])
        except ParameterError as exc:
            raise ParameterError(f"{where}: {exc}") from None
    else:
        vehicle = from_mapping(VehicleParams, data.get("vehicle", {}), f"{where} [vehicle]")
    harvester = from_mapping(HarvesterParams, data.get("harvester", {}), f"{where} [harvester]")
    friction = (friction_from_table(data["friction"], f"{where} [friction]", base_dir)
                if "friction" in data else None)
    if "road" not in data:
        raise ParameterError(f"{where}: missing [road] table (iso_class, speed_km_per_h, "
                             "length_m, seed, or profile_csv)")
    road_doc = data["road"]
    if isinstance(road_doc, Mapping) and "profile_csv" in road_doc:
        synth = [k for k in ("iso_class", "length_m", "seed", "iso_class_level")
                 if k in road_doc]
        if synth:
            raise ParameterError(f"{where} [road]: give either profile_csv (a measured road) or "
                                 f"the synthesised road's {', '.join(synth)}, not both: the "
                                 f"profile would replace the ISO class silently")
        ref = road_doc["profile_csv"]
        if isinstance(ref, str):
            road_doc = {**road_doc, "profile_csv": str(resolve_reference(
                ref, base_dir, f"{where} [road] profile_csv"))}
    road = from_mapping(RoadParams, road_doc, f"{where} [road]")
    sim = data.get("simulation", {})
    if not isinstance(sim, Mapping):
        raise ParameterError(f"{where}: [simulation] must be a table")
    sim_keys = ("settle_s", "sample_rate_hz", "rated_voltage_V", "rated_current_A")
    for key in sim:
        if key not in sim_keys:
            near = nearest_name(key, sim_keys)
            hint = f"; did you mean '{near}'?" if near else ""
            raise ParameterError(f"{where} [simulation]: unknown key '{key}'{hint}")
    try:
        settings = SimulationSettings(**sim)
    except ParameterError as exc:
        raise ParameterError(f"{where}: {exc}") from None
    return QuarterCarProblem(vehicle, harvester, friction, road, settings, Path(base_dir))


def resolve_problem_path(path: str | Path) -> Path:
    """``path`` itself, or for a bare name (``"paper_design"``) that is not a file the
    problem file shipped with the package (``ehsa_opt/problems/NAME.toml``)."""
    p = Path(path)
    if p.is_file() or len(p.parts) > 1:
        return p
    shipped = Path(__file__).resolve().parent.parent / "problems" / (
        p.name if p.suffix == ".toml" else p.name + ".toml")
    if shipped.is_file():
        return shipped
    known = sorted(f.stem for f in shipped.parent.glob("*.toml"))
    raise ParameterError(f"{path}: no such problem file (and no shipped problem of that name; "
                         f"shipped: {', '.join(known)})")


def load_problem(path: str | Path) -> QuarterCarProblem:
    """Read and validate a quarter-car problem file (a path, or the name of a problem
    shipped with the package, e.g. ``"quarter_car_class_c"``)."""
    path = resolve_problem_path(path)
    return problem_from_mapping(load_toml(path), str(path), path.parent)
