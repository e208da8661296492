"""The pipeline's contract: a :class:`Step` gets a :class:`Context` and returns a
:class:`StepOutput`; steps are cached under :func:`hash_json` of their inputs, the data
(:func:`data_digest`) and the package sources (:func:`code_digest`)."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

__all__ = ["Step", "StepOutput", "Context", "hash_json", "code_digest", "data_digest",
           "markdown_tables", "FRICTION_BOUNDS", "dependency_versions", "NUMERICAL_DEPENDENCIES"]

#: Values of :attr:`Context.friction_bounds` (``reproduce --friction-bounds``).
FRICTION_BOUNDS = ("data", "paper")


@dataclass
class StepOutput:
    """What a step produced.

    Attributes
    ----------
    markdown : str
        The step's report section (without its title).
    figures : list[str]
        Figure paths relative to the output folder.
    results : dict
        JSON-able results for later steps.
    """

    markdown: str
    figures: list[str] = field(default_factory=list)
    results: dict = field(default_factory=dict)


@dataclass
class Context:
    """What a step sees: settings and the results of earlier steps.

    Attributes
    ----------
    data_dir : Path or None
        The user's bench data directory (``reproduce --data``); None = the embedded
        ``bench_prototype`` data (and the EMPS steps run too).
    vehicle_file : Path or None
        A problem file whose ``preset`` / ``[vehicle]`` is the vehicle of the §4 studies
        and of the design (``reproduce --vehicle``); None = the paper's passenger car.
    friction_bounds : {"data", "paper"}
        Which identified min/max friction sets drive the §4 studies and the design
        (``reproduce --friction-bounds``): "data" = the data-supported envelope of the rod
        friction (default), "paper" = the paper's per-parameter min/max over the tests.
    """

    out_dir: Path
    quick: bool
    jobs: int
    results: dict[str, dict] = field(default_factory=dict)
    data_dir: Path | None = None
    vehicle_file: Path | None = None
    friction_bounds: str = "data"
    _bench: Any = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.friction_bounds not in FRICTION_BOUNDS:
            raise ValueError(f"friction_bounds must be one of {', '.join(FRICTION_BOUNDS)}, "
                             f"got {self.friction_bounds!r}")

    @property
    def custom_data(self) -> bool:
        """True when the run is on a user's data directory."""
        return self.data_dir is not None

    @property
    def bench_dir(self) -> Path:
        """The bench data directory of the run."""
        if self.data_dir is not None:
            return Path(self.data_dir)
        from ..datasets.embedded import embedded_data_dir
        return embedded_data_dir("bench_prototype")

    def bench(self) -> Any:
        """The loaded bench data (:class:`~ehsa_opt.datasets.bench_format.BenchData`)."""
        if self._bench is None:
            from ..datasets.bench_format import load_bench
            self._bench = load_bench(self.bench_dir)
        return self._bench

    @property
    def has_generator(self) -> bool:
        from ..physics.params import load_toml
        rig = load_toml(self.bench_dir / "bench.toml").get("rig", {})
        return bool(rig.get("has_generator", True)) if isinstance(rig, dict) else True

    def vehicle(self) -> tuple[Any, str]:
        """(VehicleParams, name) of the studies: the problem file's, else passenger car."""
        from ..physics.params import VehicleParams
        if self.vehicle_file is None:
            return VehicleParams.preset("passenger_car"), "passenger_car"
        from ..datasets.problem_file import problem_from_mapping
        from ..physics.params import load_toml
        doc = load_toml(self.vehicle_file)
        phys = {k: doc[k] for k in ("preset", "vehicle") if k in doc}
        prob = problem_from_mapping({**phys, "road": {}}, str(self.vehicle_file))
        name = doc.get("preset") if isinstance(doc.get("preset"), str) else \
            f"vehicle of {Path(self.vehicle_file).name}"
        return prob.vehicle, name

    def identification(self) -> Any:
        """The identification step's typed result
        (:class:`~ehsa_opt.pipeline.step_results.IdentificationStepResult`), or None when
        the run has none yet."""
        from .step_results import IdentificationStepResult
        return IdentificationStepResult.from_dict(self.results.get("identification"))

    def friction_sets(self) -> Any:
        """The identified :class:`~ehsa_opt.datasets.friction_source.FrictionSets` of the
        run, or None (no identification step, or no bounds from it)."""
        ident = self.identification()
        return None if ident is None else ident.friction_sets

    def harvester(self, **changes: Any) -> Any:
        """The harvester of the bench data (its bench.toml ``[harvester]``), with changes."""
        import dataclasses
        return dataclasses.replace(self.bench().harvester, **changes)

    def inputs(self) -> dict:
        """Cache inputs of the data and vehicle choice."""
        out: dict[str, Any] = {"data": data_digest(self.bench_dir) if self.custom_data
                               else None}
        if self.vehicle_file is not None:
            out["vehicle"] = Path(self.vehicle_file).read_text(encoding="utf-8")
        return out

    @property
    def figure_dir(self) -> Path:
        d = self.out_dir / "figures"
        d.mkdir(parents=True, exist_ok=True)
        return d


@dataclass(frozen=True)
class Step:
    """One pipeline step.

    Attributes
    ----------
    key : str
        Cache name.
    title : str
        Report section title.
    run : callable
        ``run(ctx) -> StepOutput``.
    inputs : callable
        ``inputs(ctx) -> JSON-able`` description of everything the step depends
        on besides earlier results (hashed for the cache).
    depends : tuple[str, ...]
        Keys of earlier steps whose results this step uses (their hashes enter
        this step's hash).
    background : bool
        May run beside the other steps (:mod:`~.background`) when it depends on no
        step and no step depends on it; its section keeps its place in the report.
    """

    key: str
    title: str
    run: Callable[[Context], StepOutput]
    inputs: Callable[[Context], Any] = lambda ctx: None
    depends: tuple[str, ...] = ()
    background: bool = False


def hash_json(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:16]


#: Numerical dependencies whose versions key the step cache (a new scipy may move a result).
NUMERICAL_DEPENDENCIES = ("numpy", "scipy", "casadi", "pymoo", "matplotlib")


def dependency_versions() -> dict[str, str]:
    """Versions of :data:`NUMERICAL_DEPENDENCIES` (from the imported modules)."""
    import importlib
    out = {}
    for name in NUMERICAL_DEPENDENCIES:
        try:
            out[name] = str(getattr(importlib.import_module(name), "__version__", "unknown"))
        except ImportError:
            out[name] = "missing"
    return out


def code_digest() -> str:
    """Hash of the package's Python sources and of the versions of the numerical
    dependencies: a changed model, study or library recomputes its steps instead of
    serving a stale cached result."""
    root = Path(__file__).resolve().parent.parent  # the ehsa_opt package
    h = hashlib.sha256()
    h.update(json.dumps(dependency_versions(), sort_keys=True).encode())
    for f in sorted(root.rglob("*.py")):
        h.update(str(f.relative_to(root)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:16]


def markdown_tables(markdown: str) -> list[list[list[str]]]:
    """The pipe tables of a Markdown text, each as rows of cells (separator row dropped,
    ``**`` and backticks removed)."""
    tables, cur = [], []
    for line in markdown.splitlines() + [""]:
        text = line.strip()
        if text.startswith("|") and text.endswith("|") and len(text) > 1:
            cells = [c.strip().replace("**", "").replace("`", "")
                     for c in text[1:-1].split("|")]
            if not all(set(c) <= set("-: ") for c in cells):
                cur.append(cells)
        elif cur:
            tables.append(cur)
            cur = []
    return tables


def data_digest(path: Path) -> str:
    """Hash of a data directory's files (names, sizes and contents)."""
    h = hashlib.sha256()
    for f in sorted(p for p in path.rglob("*") if p.is_file()):
        h.update(str(f.relative_to(path)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:16]
