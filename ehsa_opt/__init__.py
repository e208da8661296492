"""ehsa_opt — identify, simulate and optimally design ball-screw energy-harvesting
shock absorbers (Bowen, Viñolas & Olazagoitia 2019, and beyond).

Entry points (each returns a result in memory and writes nothing; a result has
``summary()``, ``table()``, ``plot(ax=None)``, ``save(folder)`` and ``load(folder)``):

load_problem(path, friction=None)
    A design problem file as a pymoo ``Problem`` (:class:`DesignProblem`), extensible
    with ``with_objective(name, func, unit)`` and ``with_constraint(...)``.
optimize(problem, algorithm=None, termination=None, seed=None)
    Its Pareto front with any pymoo algorithm (NSGA-II by default) or goal attainment
    (``method="goal-attainment"``): a :class:`DesignResult` (``X``, ``F``, ``G``).
sweep(problem, design=None, speed_km_per_h=None, ...)
    A design-space study: a :class:`SweepResult` (one row per case).
simulate(problem, friction=None)
    A quarter car with the harvester on a road: a :class:`SimulationResult`.
identify(data_dir, starts=4, jobs=1, seed=0)
    The friction of every bench test: an :class:`IdentificationResult` (the data read
    and checked by ``load_bench(data_dir)`` first, or given as its :class:`BenchData`).
discrepancy(data_dir, settings=None, **options)
    The effects the model misses, named, identified and judged on held-out data by one
    criterion (``DiscrepancySettings``: jobs, a Dask scheduler, the work budget …): a
    ``DiscrepancyResult`` (``effect``, ``effects``, ``summary()``, ``table()``).
discrepancy_report(data_dir, settings=None, wall_cap_s=None, **options)
    The same with its report (``report.md``, figures, the true parameters' error of
    synthetic data) and a wall-time safety cap: a :class:`DiscrepancyReport`.
plan_tests(identification, vehicle, rig, n_tests=3)
    The next bench tests that narrow the friction band the road needs: a
    :class:`TestPlanResult` (``save`` writes the ``bench.toml`` skeleton).
generate_bench(spec=None, **options), check_bench(data_dir), convert_emps(source_dir)
    Bench data in memory (synthetic with hidden effects, a checked directory, the EMPS
    benchmark): a :class:`BenchSet` (``save`` writes a bench data directory).
reproduce(quick=False, data=None, vehicle=None)
    The paper end to end: a :class:`ReproduceResult` (``REPORT.md``, tables, figures).

Messages go to the ``ehsa_opt`` logger (``logging.getLogger("ehsa_opt")``); the
physics (:class:`BenchModel`, :class:`HarvesterParams`, friction laws …) is below.
"""

from typing import TYPE_CHECKING

from .utils.lazy import lazy_exports
from .utils.version import __version__

if TYPE_CHECKING:  # the names below, for static tools; at run time each is imported
    # on first use (:func:`__getattr__`), so that a command loads only what it runs
    from .api import (
                      BenchSet,
                      DiscrepancyReport,
                      IdentificationResult,
                      ReproduceResult,
                      SimulationResult,
                      SweepResult,
                      TestPlanResult,
                      check_bench,
                      convert_emps,
                      discrepancy,
                      discrepancy_report,
                      generate_bench,
                      identify,
                      load_problem,
                      optimize,
                      plan_tests,
                      reproduce,
                      simulate,
                      sweep,
    )
    from .datasets.bench_format import BenchData, BenchDataError, load_bench
    from .datasets.synthetic import SyntheticSpec
    from .design.outcome import DesignResult
    from .estimation.discrepancy import Criterion, DiscrepancyResult, DiscrepancySettings
    from .design.problem import DesignProblem, DesignSpace
    from .physics import COMPONENTS, BenchModel
    from .physics.bench_sim import BenchSimulation, simulate_bench
    from .physics.friction import (
                         FRICTION_LAWS,
                         bearing_friction_Nm,
                         nut_friction_N,
                         rod_friction_N,
                         simscape_friction,
    )
    from .physics.motion import SampledMotion, SineMotion
    from .physics.params import (
                         FRICTION_NAMES,
                         FRICTION_RANGES,
                         FrictionParams,
                         HarvesterParams,
                         ParameterError,
                         RoadParams,
                         VehicleParams,
    )


#: The scripting entry points, first in ``help(ehsa_opt)`` and in the API reference.
ENTRY_POINTS = ("load_problem", "optimize", "sweep", "simulate", "identify", "discrepancy",
                "discrepancy_report", "plan_tests", "generate_bench", "check_bench",
                "convert_emps", "reproduce")

__all__ = [*ENTRY_POINTS, "DesignProblem", "DesignSpace", "DesignResult", "SweepResult",
           "SimulationResult", "IdentificationResult", "DiscrepancySettings",
           "DiscrepancyResult", "DiscrepancyReport", "Criterion", "TestPlanResult",
           "BenchSet", "SyntheticSpec", "COMPONENTS", "ReproduceResult", "load_bench",
           "BenchData",
           "BenchDataError", "ParameterError",
           "BenchModel", "BenchSimulation", "simulate_bench", "SineMotion", "SampledMotion",
           "HarvesterParams", "FrictionParams", "VehicleParams", "RoadParams",
           "FRICTION_NAMES", "FRICTION_RANGES", "FRICTION_LAWS", "simscape_friction", "nut_friction_N",
           "bearing_friction_Nm", "rod_friction_N", "__version__"]

#: Where each public name lives (imported on first use: ``import ehsa_opt`` stays light,
#: a command imports the discrepancy engine, pymoo or scipy.stats only when it runs them).
_HOMES = {
    **dict.fromkeys((*ENTRY_POINTS, "SweepResult", "SimulationResult", "IdentificationResult",
                     "DiscrepancyReport", "TestPlanResult", "BenchSet", "ReproduceResult"),
                    ".api"),
    **dict.fromkeys(("BenchData", "BenchDataError", "load_bench"), ".datasets.bench_format"),
    "SyntheticSpec": ".datasets.synthetic",
    "DesignResult": ".design.outcome",
    **dict.fromkeys(("Criterion", "DiscrepancyResult", "DiscrepancySettings"),
                    ".estimation.discrepancy"),
    **dict.fromkeys(("DesignProblem", "DesignSpace"), ".design.problem"),
    **dict.fromkeys(("BenchModel", "COMPONENTS"), ".physics"),
    **dict.fromkeys(("BenchSimulation", "simulate_bench"), ".physics.bench_sim"),
    **dict.fromkeys(("FRICTION_LAWS", "bearing_friction_Nm", "nut_friction_N",
                     "rod_friction_N", "simscape_friction"), ".physics.friction"),
    **dict.fromkeys(("SampledMotion", "SineMotion"), ".physics.motion"),
    **dict.fromkeys(("FRICTION_NAMES", "FRICTION_RANGES", "FrictionParams", "HarvesterParams",
                     "ParameterError", "RoadParams", "VehicleParams"), ".physics.params"),
}


#: ``__getattr__`` and ``__dir__`` (PEP 562): each public name imported from its module on
#: first use (:func:`~ehsa_opt.utils.lazy.lazy_exports`).
__getattr__, __dir__ = lazy_exports(__name__, _HOMES)
