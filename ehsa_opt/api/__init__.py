"""The scripting API: the entry points ``import ehsa_opt`` exposes.

:func:`load_problem` / :func:`optimize` (optimal design, any pymoo algorithm),
:func:`sweep` (design-space studies), :func:`simulate` (a quarter car on a road) and
:func:`identify` (friction from bench tests) and :func:`discrepancy` (the effects the
model misses, named and judged on held-out data).  Each returns a result object in memory and
writes nothing; every result has ``summary()``, ``table()``, ``plot(ax=None)``,
``save(folder)`` and ``load(folder)`` (JSON and CSV).  Messages go to the ``ehsa_opt``
logger.  This room sits above design and plots, below the pipeline and the CLI."""

from .design import load_problem, optimize
from .discrepancy import discrepancy
from .identification import IdentificationResult, identify
from .simulation import SimulationResult, simulate
from .sweep import SweepResult, sweep

__all__ = ["load_problem", "optimize", "sweep", "simulate", "identify", "discrepancy",
           "SweepResult",
           "SimulationResult", "IdentificationResult"]
