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

import sys
import types
from typing import TYPE_CHECKING

from ..utils.lazy import lazy_exports

if TYPE_CHECKING:  # at run time each name is imported on first use (:func:`__getattr__`)
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

#: The module of each entry point: ``identify`` does not load the design's pymoo nor the
#: discrepancy engine.
_HOMES = {
    **dict.fromkeys(("BenchSet", "check_bench", "convert_emps", "generate_bench"), ".bench"),
    **dict.fromkeys(("load_problem", "optimize"), ".design"),
    **dict.fromkeys(("DiscrepancyReport", "discrepancy", "discrepancy_report"), ".discrepancy"),
    **dict.fromkeys(("IdentificationResult", "identify"), ".identification"),
    **dict.fromkeys(("TestPlanResult", "plan_tests"), ".planning"),
    **dict.fromkeys(("ReproduceResult", "reproduce"), ".reproduction"),
    **dict.fromkeys(("SimulationResult", "simulate"), ".simulation"),
    **dict.fromkeys(("SweepResult", "sweep"), ".sweep"),
}


#: ``__getattr__`` and ``__dir__`` (PEP 562): each public name imported from its module on
#: first use (:func:`~ehsa_opt.utils.lazy.lazy_exports`).
__getattr__, __dir__ = lazy_exports(__name__, _HOMES)


class _EntryPoints(types.ModuleType):
    """This package: importing a submodule named like its entry point (``sweep``,
    ``discrepancy``) binds the entry point, not the submodule, as the eager
    ``from .sweep import sweep`` did."""

    def __setattr__(self, name: str, value: object) -> None:
        if name in _HOMES and isinstance(value, types.ModuleType) and hasattr(value, name):
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _EntryPoints
