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

Messages go to the ``ehsa_opt`` logger (``logging.getLogger("ehsa_opt")``); the
physics (:class:`BenchModel`, :class:`HarvesterParams`, friction laws …) is below.
"""

from .api import (
                  IdentificationResult,
                  SimulationResult,
                  SweepResult,
                  discrepancy,
                  identify,
                  load_problem,
                  optimize,
                  simulate,
                  sweep,
)
from .datasets.bench_format import BenchData, BenchDataError, load_bench
from .design.outcome import DesignResult
from .estimation.discrepancy import Criterion, DiscrepancyResult, DiscrepancySettings
from .design.problem import DesignProblem, DesignSpace
from .physics import BenchModel
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
from .utils.version import __version__

#: The scripting entry points, first in ``help(ehsa_opt)`` and in the API reference.
ENTRY_POINTS = ("load_problem", "optimize", "sweep", "simulate", "identify", "discrepancy")

__all__ = [*ENTRY_POINTS, "DesignProblem", "DesignSpace", "DesignResult", "SweepResult",
           "SimulationResult", "IdentificationResult", "DiscrepancySettings",
           "DiscrepancyResult", "Criterion", "load_bench", "BenchData",
           "BenchDataError", "ParameterError",
           "BenchModel", "BenchSimulation", "simulate_bench", "SineMotion", "SampledMotion",
           "HarvesterParams", "FrictionParams", "VehicleParams", "RoadParams",
           "FRICTION_NAMES", "FRICTION_RANGES", "FRICTION_LAWS", "simscape_friction", "nut_friction_N",
           "bearing_friction_Nm", "rod_friction_N", "__version__"]
