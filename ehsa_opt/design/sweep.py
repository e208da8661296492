"""Design-space studies: full-factorial sweeps over any harvester/design parameters ×
speed × road class × vehicle preset × friction case, evaluated in parallel —
locally (process pool, default) or on a Dask distributed cluster
(``distributed.Client(address)``) — into a tidy table (one row per case).

Frictionless cases go through the exact frequency-domain path, vectorised over
all design points of a (vehicle, road, speed) group; friction cases go through
the time-domain quarter car with friction (:mod:`ehsa_opt.vehicle.simulate`), one
task per group as well.  Tasks are pure functions of their inputs, so the local
and the Dask run give identical numbers.

Problem-file table::

    [sweep]
    speed_km_per_h = [30.0, 70.0, 100.0, 130.0]
    iso_class = ["C", "D"]
    vehicle = ["passenger_car", "single_seater"]
    friction = ["none", "min", "max"]
    friction_from = "out/identification.json"  # optional: min/best/max identified sets
    [sweep.design]            # any HarvesterParams field or design variable, lists
    load_ohm = [20.0, 75.0, 200.0]
    lead_mm_per_rev = [5.0, 7.0]
    [sweep.friction_sets.max] # optional; FrictionParams fields (defaults: see
                              # default_friction_sets)
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence

import numpy as np

from ..datasets.friction_source import FrictionSets
from ..physics.params import (
    FrictionParams,
    HarvesterParams,
    ParameterError,
    RoadParams,
    VehicleParams,
    from_mapping,
    nearest_name,
)
from ..utils.cluster import check_cluster_imports, connect_client

__all__ = ["SweepSpec", "SweepTask", "run_sweep", "parse_sweep", "executor", "harvesters_from",
           "road_holding_warning", "sweep_warnings", "write_sweep",
           "default_friction_sets", "rows_to_csv", "sweep_axes", "METRIC_COLUMNS", "DESIGN_KEYS",
           "out_of_range_warning"]

#: Output columns of every case.
METRIC_COLUMNS: tuple[str, ...] = (
    "comfort", "comfort_weighted_rms_m_s2", "road_holding", "power_W", "power_dimensionless",
    "efficiency", "dissipated_power_W", "dissipation_bound_W", "peak_power_W",
    "out_of_range_time_fraction", "out_of_range_friction_energy_fraction")

#: Keys a sweep may vary in [sweep.design].
DESIGN_KEYS: tuple[str, ...] = tuple(
    [f.name for f in dataclasses.fields(HarvesterParams)]
    + ["total_inertia_gcm2", "speed_constant_rpm_per_V"])

_CASE_KEYS = ("vehicle", "iso_class", "speed_km_per_h", "friction")


def default_friction_sets(identification: FrictionSets | None = None,
                          method: str = "data") -> tuple[dict[str, FrictionParams], str]:
    """Friction sets 'min' and 'max' and a note on where they come from
    (:func:`ehsa_opt.vehicle.studies.friction_cases`: the identification step's bounds
    when given — ``method`` "data" (data-supported) or "paper" (per-parameter) — else
    the embedded data set's true friction as 'max' and a scaled copy as 'min',
    labelled)."""
    from ..vehicle.studies import friction_cases
    fc = friction_cases(identification, method)
    return {k: v for k, v in fc.cases.items() if v is not None}, fc.source


@dataclass(frozen=True)
class SweepSpec:
    """A full-factorial sweep.

    Attributes
    ----------
    base : HarvesterParams
        Fixed harvester fields (design values override).
    vehicles : tuple of (name, VehicleParams)
    iso_classes : tuple[str, ...]
    speeds_km_per_h : tuple[float, ...]
    frictions : tuple of (name, FrictionParams or None)
        None = frictionless (exact frequency path).
    design : tuple of (key, values)
        Swept harvester/design parameters (full grid).
    road_length_m, seed : float, int
        Road of the time-domain cases.
    """

    base: HarvesterParams = field(default_factory=HarvesterParams)
    vehicles: tuple[tuple[str, VehicleParams], ...] = (
        ("passenger_car", VehicleParams.preset("passenger_car")),)
    iso_classes: tuple[str, ...] = ("C",)
    speeds_km_per_h: tuple[float, ...] = (70.0,)
    frictions: tuple[tuple[str, FrictionParams | None], ...] = (("none", None),)
    design: tuple[tuple[str, tuple[float, ...]], ...] = ()
    road_length_m: float = 1000.0
    seed: int = 0
    settle_s: float = 2.0
    sample_rate_hz: float = 1000.0
    identified_range_m_per_s: float | None = None
    identified_range_source: str = ""

    def __post_init__(self) -> None:
        for k, vals in self.design:
            if k not in DESIGN_KEYS:
                near = nearest_name(k, DESIGN_KEYS)
                raise ParameterError(f"[sweep.design]: unknown parameter '{k}'"
                                     + (f"; did you mean '{near}'?" if near else ""))
            if len(vals) == 0:
                raise ParameterError(f"[sweep.design] {k}: empty list")
        for c in self.iso_classes:
            RoadParams(iso_class=c)  # validates
        for v in self.speeds_km_per_h:
            RoadParams(speed_km_per_h=v)

    def design_grid(self) -> dict[str, np.ndarray]:
        """Flattened full grid of the swept design parameters."""
        if not self.design:
            return {}
        keys = [k for k, _ in self.design]
        mesh = np.meshgrid(*[np.asarray(v, float) for _, v in self.design], indexing="ij")
        return {k: m.ravel() for k, m in zip(keys, mesh)}

    def tasks(self) -> list["SweepTask"]:
        """One task per (vehicle, class, speed, friction) group, all designs inside."""
        grid = self.design_grid()
        out = []
        for (vn, veh), cls, v, (fn, fr) in itertools.product(
                self.vehicles, self.iso_classes, self.speeds_km_per_h, self.frictions):
            road = RoadParams(iso_class=cls, speed_km_per_h=float(v),
                              length_m=self.road_length_m, seed=self.seed)
            out.append(SweepTask(vn, veh, road, fn, fr, self.base,
                                 tuple((k, tuple(a.tolist())) for k, a in grid.items()),
                                 self.settle_s, self.sample_rate_hz,
                                 self.identified_range_m_per_s))
        return out

    @property
    def n_cases(self) -> int:
        n = math.prod(len(v) for _, v in self.design) if self.design else 1
        return n * len(self.vehicles) * len(self.iso_classes) * len(self.speeds_km_per_h) \
            * len(self.frictions)


@dataclass(frozen=True)
class SweepTask:
    """One group of cases; calling it returns the group's rows (pure function)."""

    vehicle_name: str
    vehicle: VehicleParams
    road: RoadParams
    friction_name: str
    friction: FrictionParams | None
    base: HarvesterParams
    design: tuple[tuple[str, tuple[float, ...]], ...]
    settle_s: float = 2.0
    sample_rate_hz: float = 1000.0
    identified_range_m_per_s: float | None = None

    def designs(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v, float) for k, v in self.design}

    def __call__(self) -> list[dict[str, Any]]:
        d = self.designs()
        n = len(next(iter(d.values()))) if d else 1
        if self.friction is None:
            from .problem import QuarterCarObjectives
            ev = QuarterCarObjectives(self.vehicle, self.road, self.base)
            from ..vehicle.frequency_path import linear_metrics
            m = linear_metrics(self.vehicle, self.road, ev.design_mapping(d))
            if self.identified_range_m_per_s is not None:
                from ..vehicle.coverage import gaussian_coverage
                cov = gaussian_coverage(m["stroke_velocity_rms_m_s"],
                                        self.identified_range_m_per_s)
                m = dict(m, out_of_range_time_fraction=cov["time_fraction"])
        else:
            m = _time_domain_metrics(self.vehicle, self.road, self.base, d, self.friction,
                                     self.settle_s, self.sample_rate_hz,
                                     self.identified_range_m_per_s)
        rows = []
        for i in range(n):
            row: dict[str, Any] = {"vehicle": self.vehicle_name, "iso_class": self.road.iso_class,
                                   "speed_km_per_h": self.road.speed_km_per_h,
                                   "friction": self.friction_name}
            row.update({k: float(v[i]) for k, v in d.items()})
            for c in METRIC_COLUMNS:
                if c in m:
                    row[c] = float(np.broadcast_to(np.asarray(m[c], float), (n,))[i])
            rows.append(row)
        return rows


def harvesters_from(base: HarvesterParams, designs: Mapping[str, np.ndarray]
                    ) -> list[HarvesterParams]:
    """One :class:`HarvesterParams` per design point: ``base`` with the design's
    fields replaced (``total_inertia_gcm2`` split in the base's motor/screw ratio,
    ``speed_constant_rpm_per_V`` → K_e = K_t = 60/(2π k_n))."""
    n = len(next(iter(designs.values()))) if designs else 1
    out = []
    for i in range(n):
        d = {k: float(np.asarray(v)[i]) for k, v in designs.items()}
        changes: dict[str, float] = {}
        if "total_inertia_gcm2" in d:
            jt = d.pop("total_inertia_gcm2")
            share = base.motor_inertia_gcm2 / base.total_inertia_gcm2
            changes.update(motor_inertia_gcm2=jt * share, screw_inertia_gcm2=jt * (1 - share))
        if "speed_constant_rpm_per_V" in d:
            ke = 60.0 / (2.0 * math.pi * d.pop("speed_constant_rpm_per_V"))
            changes.update(voltage_constant_Vs_per_rad=ke, torque_constant_Nm_per_A=ke)
        changes.update(d)
        out.append(base.replace(**changes))
    return out


def _time_domain_metrics(vehicle: VehicleParams, road: RoadParams, base: HarvesterParams,
                         designs: Mapping[str, np.ndarray], friction: FrictionParams,
                         settle_s: float = 2.0, sample_rate_hz: float = 1000.0,
                         identified_range_m_per_s: float | None = None
                         ) -> dict[str, np.ndarray]:
    """Metrics of designs with friction: one batched time-domain simulation
    (:func:`ehsa_opt.vehicle.simulate.simulate_quarter_car`) on the task's road."""
    from ..vehicle.simulate import simulate_quarter_car
    hs = harvesters_from(base, designs)
    sim = simulate_quarter_car(vehicle, hs, [friction] * len(hs), road, settle_s=settle_s,
                               sample_rate_hz=sample_rate_hz, keep_series=False, warn=False,
                               identified_range_m_per_s=identified_range_m_per_s)
    if not sim.success:
        raise RuntimeError(f"time-domain simulation failed ({sim.message}) for {road}")
    return sim.metrics


def _call(task: Callable[[], Any]) -> Any:
    return task()


@contextlib.contextmanager
def executor(jobs: int = 1, scheduler: Any = None
             ) -> Iterator[Callable[[Callable[..., Any], Sequence[Any]], list]]:
    """A ``mapper(fn, items) -> list`` (order kept).

    Parameters
    ----------
    jobs : int
        Local worker processes (1 = in this process).
    scheduler : str or distributed.Client, optional
        Dask scheduler address (``tcp://host:8786``; checked with bounded waits by
        :func:`~ehsa_opt.utils.cluster.connect_client`) or an existing client; then the
        work goes to that cluster.
    """
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:  # pragma: no cover
            raise ParameterError("--scheduler needs the 'distributed' package "
                                 "(pip install 'dask[distributed]')") from None
        own = not isinstance(scheduler, Client)
        client = connect_client(scheduler) if own else scheduler  # no hang: bounded waits
        try:
            check_cluster_imports(client, scheduler)
        except BaseException:
            if own:
                client.close()
            raise

        def dask_map(fn: Callable[..., Any], items: Sequence[Any]) -> list:
            futures = client.map(fn, list(items), pure=False)
            return client.gather(futures)
        try:
            yield dask_map
        finally:
            if own:
                client.close()
        return
    if jobs < 1:
        raise ParameterError(f"--jobs must be >= 1, got {jobs}")
    if jobs == 1:
        yield lambda fn, items: [fn(x) for x in items]
        return
    from concurrent.futures import ProcessPoolExecutor
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        yield lambda fn, items: list(pool.map(fn, list(items)))


def run_sweep(spec: SweepSpec, jobs: int = 1, scheduler: Any = None,
              progress: Callable[[int, int], None] | None = None) -> list[dict[str, Any]]:
    """Evaluate every case of ``spec``; rows in grid order (vehicle, class, speed,
    friction, then the design grid)."""
    tasks = spec.tasks()
    jobs = max(1, min(jobs, len(tasks)))  # no idle workers: at most one per case
    with executor(jobs, scheduler) as mapper:
        parts = mapper(_call, tasks)
    if progress is not None:
        progress(len(tasks), len(tasks))
    return [row for part in parts for row in part]


def out_of_range_warning(rows: Sequence[Mapping[str, Any]], spec: "SweepSpec") -> str | None:
    """A warning naming how many cases put more than the limit of their time or friction
    energy above the identified range, and the worst one (None when none does; the
    frictionless cases count by time only when some case has friction)."""
    from ..vehicle.coverage import OUT_OF_RANGE_LIMIT

    def frac(r: Mapping[str, Any], k: str) -> float:
        x = r.get(k)
        return 0.0 if x is None or x == "" or x != x else float(x)
    if not any(r.get("friction") != "none" for r in rows):
        return None
    far = [r for r in rows if max(frac(r, "out_of_range_time_fraction"),
                                  frac(r, "out_of_range_friction_energy_fraction"))
           > OUT_OF_RANGE_LIMIT]
    if not far:
        return None
    w = max(far, key=lambda r: frac(r, "out_of_range_time_fraction"))
    case = ", ".join(f"{k} = {w[k]}" for k in _CASE_KEYS if k in w)
    return (f"in {len(far)} of {len(rows)} cases more than {100 * OUT_OF_RANGE_LIMIT:g} % of "
            f"the time or of the friction's dissipated energy is at stroke velocities above "
            f"the friction's identified range ({spec.identified_range_m_per_s:.3g} m/s, "
            f"{spec.identified_range_source}); worst "
            f"{100 * frac(w, 'out_of_range_time_fraction'):.0f} % of the time ({case}): "
            f"columns out_of_range_* of sweep.csv")


def road_holding_warning(rows: Sequence[Mapping[str, Any]]) -> str | None:
    """A warning naming how many cases have road holding η_rh > 1 (the tyre would leave the
    ground: the linear tyre model is invalid there) and the worst one; None when none."""
    bad = [r for r in rows if float(r.get("road_holding", 0.0)) > 1.0]
    if not bad:
        return None
    worst = max(bad, key=lambda r: float(r["road_holding"]))
    return (f"road holding > 1 in {len(bad)} of {len(rows)} cases (worst "
            f"{float(worst['road_holding']):.2f}: " + ", ".join(
                f"{k} = {worst[k]}" for k in ("vehicle", "iso_class", "speed_km_per_h",
                                              "friction") if k in worst)
            + "): the tyre would leave the ground and the linear tyre model is invalid there")


def sweep_warnings(rows: Sequence[Mapping[str, Any]], spec: SweepSpec) -> list[str]:
    """The warnings of a sweep's rows: road holding beyond 1, friction beyond its range."""
    return [f"warning: {w}" for w in (road_holding_warning(rows), out_of_range_warning(rows, spec))
            if w]


def write_sweep(out_dir: str | Path, rows: Sequence[Mapping[str, Any]],
                spec: SweepSpec) -> list[Path]:
    """The sweep's folder: ``sweep.csv`` and, when something varies, ``sweep.png`` (the
    metrics against speed, else against the first design variable, one line per
    combination of what else varies).  Returns the paths written."""
    from .. import plots
    from ..plots.design import sweep_lines
    from ..utils.io import atomic_write_text
    out = Path(out_dir)
    atomic_write_text(out / "sweep.csv", rows_to_csv(rows))
    paths = [out / "sweep.csv"]
    axes = sweep_axes(rows, [k for k, _ in spec.design])
    if axes is not None:
        paths.append(plots.save(sweep_lines(rows, *axes), out / "sweep.png"))
    return paths


def sweep_axes(rows: Sequence[Mapping[str, Any]], design_keys: Sequence[str]
               ) -> tuple[str, list[str], list[str]] | None:
    """What a sweep's figure shows: the metrics (y) against speed when it varies, else
    against the first swept design parameter, one line per combination of what else
    varies (hue); None when nothing varies."""
    hue = [k for k in ("vehicle", "iso_class", "friction") if
           len({r[k] for r in rows}) > 1] + list(design_keys)
    ys = ["power_W", "efficiency", "comfort_weighted_rms_m_s2", "road_holding"]
    if len({r["speed_km_per_h"] for r in rows}) > 1:
        return "speed_km_per_h", ys, hue
    if design_keys:
        x = design_keys[0]
        return x, ys, [h for h in hue if h != x] or ["vehicle"]
    return None


def rows_to_csv(rows: Sequence[Mapping[str, Any]]) -> str:
    """Tidy CSV text (full float precision)."""
    if not rows:
        return ""
    cols = list(rows[0])
    for r in rows[1:]:
        cols += [c for c in r if c not in cols]

    def fmt(v: Any) -> str:
        return repr(float(v)) if isinstance(v, (float, np.floating)) else str(v)
    lines = [",".join(cols)] + [",".join(fmt(r.get(c, "")) for c in cols) for r in rows]
    return "\n".join(lines) + "\n"


def _list(table: Mapping[str, Any], key: str, default: list, where: str) -> list:
    v = table.get(key, default)
    if not isinstance(v, list):
        v = [v]
    if not v:
        raise ParameterError(f"{where} {key}: empty list")
    return v


def parse_sweep(doc: Mapping[str, Any], path: str = "problem",
                identification: FrictionSets | None = None,
                friction_from: str | None = None) -> SweepSpec:
    """The :class:`SweepSpec` of a problem file's ``[sweep]`` table (the
    ``[harvester]`` table is the base design, ``[road]`` gives length and seed).

    Friction cases other than "none" come from, in order: ``[sweep.friction_sets.NAME]``
    tables; ``friction_from`` (an identification.json, e.g. ``sweep --friction``) or
    ``[sweep] friction_from = "..."`` (relative to the problem file): its ``min`` /
    ``best`` / ``max`` data-supported sets; else :func:`default_friction_sets`."""
    where = f"{path} [sweep]"
    st = doc.get("sweep")
    if st is None:
        raise ParameterError(f"{path}: no [sweep] table; add one, e.g. [sweep] "
                             f"speed_km_per_h = [30.0, 70.0, 130.0]")
    valid = ("speed_km_per_h", "iso_class", "vehicle", "friction", "design", "friction_sets",
             "friction_from")
    for key in st:
        if key not in valid:
            near = nearest_name(key, valid)
            raise ParameterError(f"{where}: unknown key '{key}'"
                                 + (f"; did you mean '{near}'?" if near else "")
                                 + f" (valid: {', '.join(valid)})")
    from ..datasets.problem_file import problem_from_mapping
    phys_doc = {k: doc[k] for k in ("preset", "vehicle", "harvester", "friction", "road",
                                    "simulation") if k in doc}
    phys_doc.setdefault("road", {})
    phys = problem_from_mapping(phys_doc, path, Path(path).parent)
    base, road, sim = phys.harvester, phys.road, phys.simulation
    speeds = tuple(float(v) for v in _list(st, "speed_km_per_h", [road.speed_km_per_h], where))
    classes = tuple(str(c).upper() for c in _list(st, "iso_class", [road.iso_class], where))
    vnames = [str(v) for v in _list(st, "vehicle", ["passenger_car"], where)]
    vehicles = tuple((n, VehicleParams.preset(n)) for n in vnames)
    fnames = [str(f) for f in _list(st, "friction", ["none"], where)]
    sets_doc = st.get("friction_sets", {})
    src = friction_from if friction_from is not None else st.get("friction_from")
    if src is not None:
        from ..datasets.friction_source import load_friction_sets
        if not isinstance(src, str):
            raise ParameterError(f"{where} friction_from: give the path of an "
                                 f"identification.json as a string")
        p = Path(src)
        if friction_from is None:  # named in the file: relative to it, confined
            from ..datasets.problem_file import resolve_reference
            p = resolve_reference(src, Path(path).parent, f"{where} friction_from")
        try:
            sets = dict(load_friction_sets(p))
        except ParameterError as exc:
            raise ParameterError(f"{where} friction_from: {exc}") from None
    else:
        sets, _ = (default_friction_sets(identification) if any(f != "none" for f in fnames)
                   and not all(f in sets_doc for f in fnames if f != "none") else ({}, ""))
    for name, table in sets_doc.items():
        sets[name] = from_mapping(FrictionParams, table, f"{where} friction_sets.{name}")
    frictions = []
    for f in fnames:
        if f == "none":
            frictions.append(("none", None))
        elif f in sets:
            frictions.append((f, sets[f]))
        else:
            raise ParameterError(f"{where} friction: unknown case '{f}' (valid: none, "
                                 f"{', '.join(sets) or 'min, max'})")
    dt = st.get("design", {})
    design = []
    for k, v in dt.items():
        vals = v if isinstance(v, list) else [v]
        try:
            design.append((str(k), tuple(float(x) for x in vals)))
        except (TypeError, ValueError):
            raise ParameterError(f"{where}.design {k}: give a list of numbers, got {v!r}") \
                from None
    from ..datasets.friction_source import (
        RANGE_SOURCE_EMBEDDED,
        embedded_range_m_per_s,
        load_velocity_range,
    )
    v_range, v_src = None, ""
    if src is not None:
        v_range, v_src = load_velocity_range(p), f"identified range of {p}"
    if v_range is None:
        v_range, v_src = embedded_range_m_per_s(), RANGE_SOURCE_EMBEDDED
    return SweepSpec(base=base, vehicles=vehicles, iso_classes=classes, speeds_km_per_h=speeds,
                     frictions=tuple(frictions), design=tuple(design),
                     road_length_m=road.length_m, seed=road.seed, settle_s=sim.settle_s,
                     sample_rate_hz=sim.sample_rate_hz, identified_range_m_per_s=v_range,
                     identified_range_source=v_src)
