"""Optimal design from a script: :func:`load_problem` and :func:`optimize`.

``load_problem`` reads a design problem file into a pymoo
:class:`~pymoo.core.problem.Problem` (:class:`~ehsa_opt.design.problem.DesignProblem`)
that carries the file's settings; ``optimize`` solves it with any pymoo algorithm
(NSGA-II by default) or by goal attainment and returns a
:class:`~ehsa_opt.design.outcome.DesignResult` in memory — pymoo's ``X``, ``F``, ``G``,
a named table, a summary, a figure — writing nothing until ``result.save(folder)``.

Example
-------
>>> import ehsa_opt
>>> problem = ehsa_opt.load_problem("paper_design")
>>> result = ehsa_opt.optimize(problem, termination=("n_gen", 10), seed=1)
>>> result.F.shape[1]
4
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Sequence

from ..design.optimize import build_problem
from ..design.optimize import optimize as _study
from ..design.outcome import DesignResult
from ..design.problem import DesignProblem
from ..physics.params import ParameterError
from ..utils.log import logger

__all__ = ["load_problem", "optimize"]


def load_problem(path: str | Path, *, friction: str | Sequence[str] | None = None,
                 friction_mode: str | None = None) -> DesignProblem:
    """The design problem of a problem file, as a pymoo ``Problem``.

    Parameters
    ----------
    path : str or Path
        A design problem file (``[design]``, ``[design.bounds]``, optional ``[motor]``,
        ``[goals]``, ``[nsga2]``; see the problem-file format), or the name of one
        shipped with the package (``"paper_design"``, ``"catalogue_design"``).
    friction : str or sequence of str, optional
        Identified friction ``FILE:CASE`` (an ``identification.json``, case
        ``min|best|max``), one or several; default: the file's ``[friction]``, else
        none (the exact frictionless path).
    friction_mode : {"at", "worst", "mean"}, optional
        How several friction sets combine (default ``worst``; ``at`` for one set).

    Returns
    -------
    DesignProblem
        Unit-cube variables of the file's box; objectives ``comfort``,
        ``road_holding``, ``inverse_power`` (1 / dimensionless power, i.e. power
        maximised) and ``inverse_efficiency`` (1 / efficiency), all minimised; the
        motor's rated limits and the stroke as constraints (≤ 0 feasible).  Extend it
        with :meth:`~ehsa_opt.design.problem.DesignProblem.with_objective` and
        :meth:`~ehsa_opt.design.problem.DesignProblem.with_constraint`.
    """
    from ..datasets.friction_source import load_friction
    from ..design.config import load_design_config
    labels = (friction,) if isinstance(friction, (str, Path)) else tuple(friction or ())
    cfg = load_design_config(path)
    frictions = [load_friction(spec) for spec in labels] or None
    problem = build_problem(cfg, None, frictions, friction_mode)
    problem.friction_labels = tuple(str(x) for x in labels)
    return problem


def optimize(problem: DesignProblem | str | Path, algorithm: Any = None,
             termination: Any = None, seed: int | None = None, *,
             method: str | None = None, pop_size: int | None = None,
             goal_attainment: bool = True, time_domain_check: bool = True,
             checkpoint: str | Path | None = None, resume: str | Path | None = None,
             stop_after: int | None = None, scheduler: Any = None,
             progress: Callable[[int, int | None], None] | None = None) -> DesignResult:
    """Solve a design problem; the result in memory, nothing written.

    Parameters
    ----------
    problem : DesignProblem or path
        From :func:`load_problem` (possibly extended), or a problem file's path.
    algorithm : pymoo algorithm, optional
        Any pymoo multi-objective algorithm instance (NSGA-III, SMS-EMOA, AGE-MOEA …);
        default NSGA-II with the file's ``[nsga2]`` population.  When it keeps pymoo's
        default random sampling, its first population starts with the problem's feasible
        seed (:meth:`~ehsa_opt.design.problem.DesignProblem.seed_population`).
    termination : pymoo termination or tuple, optional
        pymoo's forms, e.g. ``("n_gen", 25)`` or ``("n_eval", 2000)``; default the
        file's ``[nsga2] gens`` generations.
    seed : int, optional
        Seed of the run (default the file's ``[nsga2] seed``); same seed, same front.
    method : {"nsga2", "goal-attainment"}, optional
        ``nsga2`` (default: a front, with ``algorithm``) or ``goal-attainment`` (one
        optimum, MATLAB ``fgoalattain`` semantics, the four built-in objectives).
    pop_size : int, optional
        Population of the default NSGA-II.
    goal_attainment : bool
        Also solve goal attainment beside a front (the four built-in objectives only),
        to compare the front with it.
    time_domain_check : bool
        Re-simulate the result in the time domain when the objectives come from the
        friction fast path or the problem has rated limits.
    checkpoint, resume, stop_after
        Checkpoints of the default NSGA-II (see :func:`ehsa_opt.design.nsga2.run_nsga2`).
    scheduler : str or distributed.Client, optional
        Evaluate populations on a Dask cluster.
    progress : callable, optional
        ``progress(generation, total)`` after every generation (total None when the
        termination is not a number of generations).

    Returns
    -------
    DesignResult
        ``X``, ``F``, ``G``, :meth:`~ehsa_opt.design.outcome.DesignResult.table`,
        ``design`` (the preferred design), ``summary()``, ``plot()``, ``save(dir)``.
        ``success`` is False, with a message saying so, when no design meets the
        constraints (a warning is logged too).
    """
    if isinstance(problem, (str, Path)):
        problem = load_problem(problem)
    if not isinstance(problem, DesignProblem):
        raise TypeError(f"optimize: problem must be a DesignProblem (ehsa_opt.load_problem)"
                        f" or a problem file's path, got {type(problem).__name__}")
    if problem.config is None:
        raise ParameterError("optimize: this problem has no problem file behind it (no "
                             "prototype, goals or road); build it with "
                             "ehsa_opt.load_problem(path) and extend it with "
                             "with_objective / with_constraint")
    method = method or "nsga2"
    gens = None
    if isinstance(termination, tuple) and len(termination) == 2 and termination[0] == "n_gen" \
            and algorithm is None:
        gens, termination = int(termination[1]), None  # the built-in NSGA-II's own form
    from ..design.sweep import executor
    with executor(1, scheduler) as mapper:
        result = _study(problem.config, method, problem=problem, pop=pop_size, gens=gens,
                        seed=seed, checkpoint=checkpoint, resume=resume, stop_after=stop_after,
                        mapper=mapper if scheduler else None,
                        with_goal_attainment=goal_attainment, progress=progress,
                        friction_labels=problem.friction_labels,
                        check_time_domain=time_domain_check, algorithm=algorithm,
                        termination=termination)
    logger.info("%s", result.summary())
    if not result.success and not stop_after:
        logger.warning("warning: %s: %s", result.method, result.message)
    for line in result.warnings():
        logger.warning("%s", line)
    return result
