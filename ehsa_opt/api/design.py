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

from ..design.nsga2 import run_nsga2
from ..design.optimize import build_problem, constraint_record, design_record, objectives_at
from ..design.optimize import optimize as _study
from ..design.outcome import DesignResult
from ..design.problem import DesignProblem
from ..physics.params import ParameterError
from ..utils.log import logger
from ..utils.process import one_blas_thread

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


@one_blas_thread
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
        From :func:`load_problem` (possibly extended), or a problem file's path; or a
        :class:`~ehsa_opt.design.problem.DesignProblem` built in Python from a
        :class:`~ehsa_opt.design.problem.DesignSpace` and an evaluator (a callable
        mapping a dict of design arrays to a dict of output arrays, with an attribute
        ``objective_names`` and optionally ``constraint_names`` returned as
        ``constraint_<name>``): then only its front is computed (no prototype, goals
        or time-domain check; NSGA-II with 40 × 25 by default).
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
    if problem.config is None:  # built in Python: a space and an evaluator
        if method not in (None, "nsga2"):
            raise ParameterError(f"optimize: method {method!r} needs a problem file (its "
                                 f"prototype and goals); this problem has none: use nsga2")
        return _front_only(problem, algorithm, termination, seed, pop_size, progress)
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


#: Population and generations of the default NSGA-II on a problem without a file.
DEFAULT_POP, DEFAULT_GENS, DEFAULT_SEED = 40, 25, 1


def _front_only(problem: DesignProblem, algorithm: Any, termination: Any, seed: int | None,
                pop_size: int | None, progress: Any) -> DesignResult:
    """The front of a problem built in Python (a :class:`DesignProblem` of a space and an
    evaluator, no problem file): no prototype, goals or time-domain check; hypervolume
    of the raw objectives against the default reference."""
    import numpy as np
    n_gen = DEFAULT_GENS
    if isinstance(termination, tuple) and len(termination) == 2 and termination[0] == "n_gen" \
            and algorithm is None:
        n_gen, termination = int(termination[1]), None
    pr = run_nsga2(problem, pop_size=pop_size or DEFAULT_POP, n_gen=n_gen,
                   seed=DEFAULT_SEED if seed is None else seed, progress=progress,
                   algorithm=algorithm, termination=termination)
    names = problem.objective_names
    rec: dict[str, Any] = {"problem_file": None, "method": "nsga2",
                           "box": problem.space.as_dict()}
    outputs = objectives_at(problem, pr.preferred_design)
    rec.update(design_record(pr.preferred_design, outputs, names))
    rec.update(constraint_record(problem, outputs))
    rec.update({"success": pr.success, "message": pr.message, "pick": pr.pick,
                "n_front": int(pr.F.shape[0]),
                "hypervolume": {"normalisation": "none", "reference_point":
                                pr.hv_reference.tolist(), "history": pr.history},
                "stats": pr.stats})
    if pr.algorithm != "NSGA2":
        rec["algorithm"] = pr.algorithm
    if problem.constraint_names:
        rec["constraint_names"] = list(problem.constraint_names)
    if problem.units:
        rec["units"] = dict(problem.units)
    out = problem.evaluate_design(pr.designs)
    front: dict[str, Any] = {k: np.asarray(v, float) for k, v in pr.designs.items()}
    front.update({k: pr.F[:, j] for j, k in enumerate(names)})
    front.update({k: np.broadcast_to(v, (pr.F.shape[0],)) for k, v in out.items()
                  if k not in front})
    front["feasible"] = (np.all(pr.G <= 0.0, axis=1) if pr.G is not None
                         else np.ones(pr.F.shape[0], bool))
    result = DesignResult(rec, pr, None, {"pareto.csv": pr.to_csv_text()}, front)
    if not result.success:
        logger.warning("warning: %s: %s", result.method, result.message)
    return result
