"""The scripting API: the entry points ``import ehsa_opt`` exposes.

:func:`load_problem` / :func:`optimize` (optimal design, any pymoo algorithm),
:func:`sweep` (design-space studies), :func:`simulate` (a quarter car on a road),
:func:`identify` (friction from bench tests), :func:`discrepancy` and
:func:`discrepancy_report` (the effects the model misses, named and judged on held-out
data), :func:`plan_tests` (the next bench tests), :func:`generate_bench`,
:func:`check_bench` and :func:`convert_emps` (bench data) and :func:`reproduce` (the
paper end to end).  Each returns a result object in memory and writes nothing; every
result has ``summary()``, ``table()``, ``plot(ax=None)``, ``save(folder)`` and
``load(folder)``.  Messages go to the ``ehsa_opt`` logger.  This room sits above every
other room but the CLI, which only parses, calls it and prints."""

from .bench import BenchSet, check_bench, convert_emps, generate_bench
from .design import load_problem, optimize
from .discrepancy import DiscrepancyReport, discrepancy, discrepancy_report
from .identification import IdentificationResult, identify
from .planning import TestPlanResult, plan_tests
from .reproduction import ReproduceResult, reproduce
from .simulation import SimulationResult, simulate
from .sweep import SweepResult, sweep

__all__ = ["load_problem", "optimize", "sweep", "simulate", "identify", "discrepancy",
           "discrepancy_report", "plan_tests", "generate_bench", "check_bench",
           "convert_emps", "reproduce", "SweepResult", "SimulationResult",
           "IdentificationResult", "DiscrepancyReport", "TestPlanResult", "BenchSet",
           "ReproduceResult"]
