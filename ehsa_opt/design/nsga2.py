"""Seeded NSGA-II (pymoo) on a :class:`~.problem.DesignProblem` with per-generation
hypervolume, an archive of every non-dominated design evaluated, atomic checkpoints
and exact resume; the result mirrors ``scipy.optimize.OptimizeResult``.

Bookkeeping stays at pymoo's speed: the archive is updated with the new infills only
(:func:`~.pareto.update_archive`), hypervolumes are recomputed only for sets that
changed, and checkpoints are data (:mod:`.checkpoint`, no pickle)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ..physics.params import ParameterError
from ..utils.log import logger
from .checkpoint import capture, load_state, restore, save_state, verify_designs
from .pareto import hypervolume, non_dominated, pick_preferred, update_archive
from .problem import DesignProblem

__all__ = ["ParetoResult", "run_nsga2"]


@dataclass
class ParetoResult:
    """Outcome of :func:`run_nsga2` (mirrors ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    success : bool
    message : str
    X : ndarray (n, n_var)
        Non-dominated designs, unit-cube coordinates, sorted by objectives.
    designs : dict[str, ndarray]
        The same in physical units.
    F : ndarray (n, n_obj)
        Their objectives.
    objective_names : tuple[str, ...]
    preferred : int
        Index of the knee / preference pick.
    history : list[dict]
        Per generation: ``gen``, ``n_eval``, ``hv`` (normalised hypervolume of the
        population's non-dominated set; NSGA-II's crowding truncation can lower
        it), ``n_front``, ``hv_archive`` / ``n_archive`` (of every non-dominated
        design evaluated so far: non-decreasing).
    hv_scale, hv_reference : ndarray
        Normalisation (F / hv_scale) and reference point of the hypervolume.
    stats : dict
        ``n_eval``, ``seconds`` (this process), ``resumed_from`` generation.
    G : ndarray (n, n_constr) or None
        Their constraint values (≤ 0 feasible), None without constraints.
    algorithm : str
        The pymoo algorithm's class name.
    """

    success: bool
    message: str
    X: np.ndarray
    designs: dict[str, np.ndarray]
    F: np.ndarray
    objective_names: tuple[str, ...]
    preferred: int
    pick: str
    history: list[dict]
    hv_scale: np.ndarray
    hv_reference: np.ndarray
    stats: dict
    G: np.ndarray | None = None
    algorithm: str = "NSGA2"

    @property
    def preferred_design(self) -> dict[str, float]:
        """The preferred (knee / preference pick) design, physical units."""
        return {k: float(v[self.preferred]) for k, v in self.designs.items()}

    def rows(self) -> list[dict[str, float]]:
        """One dict per front point: design variables then objectives."""
        out = []
        for i in range(self.F.shape[0]):
            row = {k: float(v[i]) for k, v in self.designs.items()}
            row.update({k: float(self.F[i, j]) for j, k in enumerate(self.objective_names)})
            out.append(row)
        return out

    def summary(self) -> str:
        """Status, front size, the preferred design and the last hypervolume."""
        i = self.preferred
        hv = self.history[-1] if self.history else {}
        return "\n".join([
            f"{self._label}: {'converged' if self.success else 'FAILED'} ({self.message})",
            f"front: {self.F.shape[0]} designs" + (f", hypervolume {hv['hv']:.4g} after "
                                                   f"{hv['n_eval']} evaluations" if hv else ""),
            f"preferred ({self.pick}): " + ", ".join(
                f"{k} = {float(v[i]):.4g}" for k, v in self.designs.items()),
            "objectives: " + ", ".join(f"{k} = {float(self.F[i, j]):.4g}"
                                       for j, k in enumerate(self.objective_names))])

    @property
    def _label(self) -> str:
        return "NSGA-II" if self.algorithm == "NSGA2" else self.algorithm

    def to_csv_text(self) -> str:
        """``pareto.csv`` text: one row per non-dominated design, full precision."""
        rows = self.rows()
        cols = list(rows[0]) if rows else list(self.designs) + list(self.objective_names)
        lines = [",".join(cols)]
        lines += [",".join(repr(r[c]) for c in cols) for r in rows]
        return "\n".join(lines) + "\n"

    def plot(self, ax: Any = None, **kw: Any) -> Any:
        """The front's 2-D projections (several panels; ``ax`` not used; ``kw``: the
        goal-attainment and prototype points); writes nothing."""
        from ..plots.design import pareto_projections
        return pareto_projections(self, **kw)


def _front(algorithm: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    opt = algorithm.opt
    X, F = opt.get("X"), opt.get("F")
    G = opt.get("G") if algorithm.problem.n_ieq_constr else None
    keep = non_dominated(F)
    X, F = X[keep], F[keep]
    order = np.lexsort(F.T[::-1])
    return X[order], F[order], (None if G is None else G[keep][order])


def run_nsga2(problem: DesignProblem, *, pop_size: int = 40, n_gen: int = 25, seed: int = 1,
              checkpoint: str | Path | None = None, resume: str | Path | None = None,
              stop_after: int | None = None, hv_scale: Sequence[float] | None = None,
              hv_reference: Sequence[float] | None = None, pick: str = "knee",
              pick_weights: Sequence[float] | None = None,
              progress: Callable[[int, int], None] | None = None,
              initial: Any = None, algorithm: Any = None,
              termination: Any = None) -> ParetoResult:
    """Seeded NSGA-II on ``problem`` with per-generation hypervolume and checkpoints.

    Parameters
    ----------
    pop_size, n_gen, seed : int
        Population, total generations, seed (same seed → same front).
    checkpoint : path, optional
        Directory; after every generation the run's state (population, archive,
        history, generation counter, random generator) is written atomically to
        ``nsga2_checkpoint.npz`` (data with a SHA-256, see :mod:`.checkpoint`).
    resume : path, optional
        Continue from the checkpoint in this directory up to ``n_gen``, exactly as
        an uninterrupted run (the problem, ``pop_size`` and ``seed`` must match; a
        truncated, altered or foreign file is refused). Checkpoints go on to
        ``checkpoint`` or, if not given, back into ``resume``.
    stop_after : int, optional
        Stop after this many generations (as if interrupted), checkpoint kept.
    hv_scale, hv_reference : sequences, optional
        Hypervolume of F / hv_scale against hv_reference (defaults 1 and 2).
    pick : str
        'knee', 'compromise' or 'preference' (see :func:`pick_preferred`), made
        among the front points inside the hypervolume box (all if none is).
    initial : array (k, n_var) or False, optional
        Unit-cube points put in the first population (default the problem's feasible
        seed :attr:`~.problem.DesignProblem.initial`, e.g. the prototype, feasible by
        construction when the limits are its own demands; ``False``: none); the rest is
        drawn uniformly with ``seed``.
    algorithm : pymoo algorithm, optional
        Run this algorithm instead of NSGA-II (NSGA-III, SMS-EMOA, AGE-MOEA …;
        ``pop_size`` is then its own); when it keeps pymoo's default random sampling,
        its first population is ``initial`` first and the rest uniform (as NSGA-II's).
        No checkpoints.
    termination : pymoo termination or tuple, optional
        Instead of ``n_gen`` generations, e.g. ``("n_eval", 2000)``.

    Notes
    -----
    With constraints (``problem.constraint_names``) pymoo ranks feasibility first; the
    archive keeps feasible designs only, and a run that found none says so: its
    ``success`` is False.
    """
    from pymoo.termination import get_termination

    for name, v in (("pop", pop_size), ("gens", n_gen)):
        if not isinstance(v, (int, np.integer)) or v < 1:
            raise ParameterError(f"nsga2: {name} must be a positive integer, got {v!r}")
    if pop_size < 4:
        raise ParameterError(f"nsga2: pop must be >= 4, got {pop_size}")
    m = problem.n_obj
    scale = np.ones(m) if hv_scale is None else np.asarray(hv_scale, dtype=float)
    ref = np.full(m, 2.0) if hv_reference is None else np.asarray(hv_reference, dtype=float)
    if scale.shape != (m,) or ref.shape != (m,) or np.any(scale <= 0):
        raise ParameterError(f"nsga2: hv_scale (> 0) and hv_reference need {m} values")
    fp = problem.fingerprint()
    t0 = time.perf_counter()
    if algorithm is not None or termination is not None:
        return _run_other(problem, algorithm, termination, pop_size, n_gen, seed,
                          _initial(problem, initial),
                          scale, ref, pick, pick_weights, progress, (checkpoint, resume,
                                                                     stop_after))
    if resume is not None:
        algorithm, history, archive = _resumed(problem, Path(resume), fp, pop_size, seed, n_gen)
        ck = Path(checkpoint) if checkpoint is not None else Path(resume)
    else:
        algorithm, history, archive = _started(problem, pop_size, seed, n_gen,
                                               _initial(problem, initial))
        ck = Path(checkpoint) if checkpoint is not None else None
    resumed_from = len(history)
    algorithm.termination = get_termination("n_gen", n_gen)
    interrupted = _evolve(problem, algorithm, history, archive, n_gen, scale, ref,
                          lambda arc: None if ck is None else save_state(
                              ck, capture(algorithm, history, arc, fp, pop_size, seed)),
                          progress, stop_after)
    return _result(problem, algorithm, history, interrupted, n_gen, scale, ref, pick,
                   pick_weights, t0, resumed_from)


def _result(problem: DesignProblem, algorithm: Any, history: list[dict], interrupted: bool,
            n_gen: int | None, scale: np.ndarray, ref: np.ndarray, pick: str,
            pick_weights: Sequence[float] | None, t0: float, resumed_from: int) -> ParetoResult:
    """The :class:`ParetoResult` of a finished (or stopped) run."""
    X, F, G = _front(algorithm)
    # pick among the points inside the hypervolume box (F/scale < reference): the
    # front's far tails (e.g. 1/ρ_g in the thousands) would otherwise set the
    # normalisation; all points when none is inside
    inside = np.all(F / scale < ref, axis=1)
    cand = np.flatnonzero(inside) if inside.any() else np.arange(F.shape[0])
    idx = int(cand[pick_preferred(F[cand] / scale, pick, pick_weights)])
    msg = (f"stopped after {len(history)} of {n_gen} generations (resume with --resume)"
           if interrupted else f"{len(history)} generations, {F.shape[0]} non-dominated designs")
    if n_gen is None and not interrupted:
        msg = (f"{type(algorithm.termination).__name__} ended the run after {len(history)} "
               f"generations, {F.shape[0]} non-dominated designs")
    feasible = True
    if problem.n_ieq_constr:
        feasible = bool(np.all(algorithm.opt.get("feas")))
        if not feasible:
            msg += ("; NO design within the constraints was found (the front shows the "
                    "least infeasible)")
    return ParetoResult(
        success=not interrupted and feasible, message=msg, X=X,
        designs=problem.space.from_unit(X), F=F,
        objective_names=problem.objective_names, preferred=idx, pick=pick, history=history,
        hv_scale=scale, hv_reference=ref, G=G, algorithm=type(algorithm).__name__,
        stats={"n_eval": int(algorithm.evaluator.n_eval), "seconds": time.perf_counter() - t0,
               "resumed_from": resumed_from, "generations": len(history)})


def _run_other(problem: DesignProblem, algorithm: Any, termination: Any, pop_size: int,
               n_gen: int, seed: int, initial: Any, scale: np.ndarray, ref: np.ndarray,
               pick: str, pick_weights: Sequence[float] | None,
               progress: Callable[[int, int], None] | None,
               state_args: tuple[Any, Any, Any]) -> ParetoResult:
    """:func:`run_nsga2` with a given pymoo ``algorithm`` and/or ``termination``: the same
    seeding, history and archive; no checkpoints."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.operators.sampling.rnd import FloatRandomSampling

    checkpoint, resume, stop_after = state_args
    if checkpoint is not None or resume is not None:
        raise ParameterError("checkpoints and --resume are available with the built-in "
                             "NSGA-II only (no algorithm=, no termination=)")
    t0 = time.perf_counter()
    if algorithm is None:
        algorithm = NSGA2(pop_size=pop_size, eliminate_duplicates=True)
    size = int(getattr(algorithm, "pop_size", None) or pop_size)
    init = getattr(algorithm, "initialization", None)
    if init is not None and initial is not None and type(init.sampling) is FloatRandomSampling:
        init.sampling = problem.seed_population(size, seed, initial)
    algorithm.setup(problem, termination=termination if termination is not None
                    else ("n_gen", n_gen), seed=seed, verbose=False)
    total = _generations(algorithm.termination)
    history: list[dict] = []
    interrupted = _evolve(problem, algorithm, history, np.zeros((0, problem.n_obj)), total,
                          scale, ref, lambda arc: None, progress, stop_after)
    return _result(problem, algorithm, history, interrupted, total, scale, ref, pick,
                   pick_weights, t0, 0)


def _initial(problem: DesignProblem, initial: Any) -> Any:
    """The seed designs: ``initial`` when given (``False``: none), else the problem's own
    feasible seed (:attr:`DesignProblem.initial`, e.g. the prototype)."""
    if initial is False:
        return None
    return problem.initial if initial is None else initial


def _generations(termination: Any) -> int | None:
    """The number of generations of an ``n_gen`` termination, else None."""
    from pymoo.termination.max_gen import MaximumGenerationTermination
    if isinstance(termination, MaximumGenerationTermination):
        return int(termination.n_max_gen)
    return None


def _resumed(problem: DesignProblem, rdir: Path, fp: str, pop_size: int, seed: int,
             n_gen: int) -> tuple[Any, list[dict], np.ndarray]:
    """The algorithm, history and archive of the checkpoint in ``rdir``, after checking that
    it belongs to this problem, population and seed and was not altered."""
    m = problem.n_obj
    state = load_state(rdir)
    if state.fingerprint != fp:
        raise ParameterError(f"--resume {rdir}: the checkpoint belongs to a different "
                             f"problem (box, vehicle, road or objectives changed); start "
                             f"a new run")
    if state.pop_size != pop_size or state.seed != seed:
        raise ParameterError(
            f"--resume {rdir}: checkpoint was made with pop {state.pop_size} and "
            f"seed {state.seed}; pass the same --pop and --seed")
    if state.arrays["pop_X"].shape[1] != problem.n_var or \
            state.arrays["pop_F"].shape[1] != m:
        raise ParameterError(f"--resume {rdir}: the checkpoint's designs do not fit this "
                             f"problem's {problem.n_var} variables and {m} objectives; "
                             f"start a new run")
    verify_designs(rdir, state, problem)  # a re-signed file cannot steer the run
    history = state.history
    if len(history) > n_gen:
        raise ParameterError(f"--resume {rdir}: checkpoint already has {len(history)} "
                             f"generations > --gens {n_gen}")
    return restore(state, problem, n_gen), history, state.arrays["archive_F"]


def _started(problem: DesignProblem, pop_size: int, seed: int, n_gen: int,
             initial: Any) -> tuple[Any, list[dict], np.ndarray]:
    """A new NSGA-II run (``initial`` points first in the population), empty history and
    archive."""
    from pymoo.algorithms.moo.nsga2 import NSGA2

    kw: dict[str, Any] = {}
    if initial is not None:
        kw["sampling"] = problem.seed_population(pop_size, seed, initial)
    algorithm = NSGA2(pop_size=pop_size, seed=seed, eliminate_duplicates=True, **kw)
    algorithm.setup(problem, termination=("n_gen", n_gen), verbose=False)
    return algorithm, [], np.zeros((0, problem.n_obj))


def _evolve(problem: DesignProblem, algorithm: Any, history: list[dict], archive: np.ndarray,
            n_gen: int, scale: np.ndarray, ref: np.ndarray,
            save: Callable[[np.ndarray], None], progress: Callable[[int, int], None] | None,
            stop_after: int | None) -> bool:
    """Generations until ``n_gen`` (or ``stop_after``): each appends its hypervolumes to
    ``history`` and is saved by ``save(archive)``.  Returns whether the run stopped early."""
    hv_front: tuple[np.ndarray, float] | None = None  # last front and its hypervolume
    hv_archive = None if not history else float(history[-1]["hv_archive"])
    while algorithm.has_next() if n_gen is None else len(history) < n_gen:
        # Algorithm.next() spelled out, to see the evaluated infills (archive)
        infills = algorithm.infill()
        changed = False
        if infills is not None:
            algorithm.evaluator.eval(algorithm.problem, infills, algorithm=algorithm)
            algorithm.advance(infills=infills)
            F_new = infills.get("F")
            if problem.n_ieq_constr:  # the archive holds feasible designs only
                F_new = F_new[np.all(infills.get("G") <= 0.0, axis=1)]
            archive, changed = update_archive(archive, F_new)
        else:
            algorithm.advance()
        _, F, _ = _front(algorithm)
        if hv_front is None or not np.array_equal(hv_front[0], F):
            hv_front = (F, hypervolume(F / scale, ref))
        if changed or hv_archive is None:
            hv_archive = hypervolume(archive / scale, ref)
        history.append({"gen": len(history) + 1, "n_eval": int(algorithm.evaluator.n_eval),
                        "hv": hv_front[1], "n_front": int(F.shape[0]),
                        "hv_archive": hv_archive, "n_archive": int(archive.shape[0])})
        save(archive)
        logger.info("generation %d%s: %d evaluations, hypervolume %.4g, %d non-dominated",
                    len(history), "" if n_gen is None else f"/{n_gen}",
                    history[-1]["n_eval"], history[-1]["hv"], history[-1]["n_front"])
        if progress is not None:
            progress(len(history), n_gen)
        if stop_after is not None and len(history) >= stop_after and (
                n_gen is None or len(history) < n_gen):
            return True
    return False
