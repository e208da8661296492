"""Goal attainment over a design space with integer (catalogue) variables.

SLSQP needs smooth functions, and a catalogue index is not one: its finite-difference
gradient is zero or a jump.  So the integer variables are fixed per start: a seeded
screening of the mixed space ranks the catalogue combinations by their attainment
factor (infeasible ones after every feasible one), the best ``n_starts`` distinct
combinations each start SLSQP on the continuous variables from their best screened point,
and the lowest feasible γ wins.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from .goal import GoalAttainmentResult, solve_goal_attainment
from .problem import DesignProblem, DesignSpace

__all__ = ["FixedVariables", "solve_goal_attainment_mixed", "SCREEN_SIZE", "screened_seeds"]

#: Designs drawn (seeded, uniform in the continuous variables, the same number for every
#: catalogue combination) to rank the combinations.  The feasible share of the shipped
#: catalogue space is about 3e-4 of its box (6 of 20 000 uniform draws: the rotor's inertia
#: sets J_t, a ~100 W motor needs a few ohms of load), so 16 384 draws give about five
#: feasible seeds; evaluating them takes about a second.
SCREEN_SIZE = 16384


@dataclass(frozen=True)
class FixedVariables:
    """An evaluator with some design variables held at fixed values (picklable)."""

    inner: Any
    fixed: tuple[tuple[str, float], ...]

    @property
    def objective_names(self) -> tuple[str, ...]:
        return tuple(self.inner.objective_names)

    @property
    def constraint_names(self) -> tuple[str, ...]:
        return tuple(getattr(self.inner, "constraint_names", ()))

    def __call__(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        shape = np.broadcast_shapes(*(np.shape(v) for v in design.values()))
        full = dict(design)
        full.update({k: np.full(shape, v) for k, v in self.fixed})
        return self.inner(full)

    def fingerprint(self) -> dict[str, Any]:
        fp = self.inner.fingerprint() if hasattr(self.inner, "fingerprint") else repr(self.inner)
        return {"inner": fp, "fixed": dict(self.fixed)}


def screened_seeds(problem: DesignProblem, n_seeds: int = 8, seed: int = 0,
                   size: int = SCREEN_SIZE) -> np.ndarray:
    """Unit-cube designs to seed a population with: of ``size`` seeded uniform draws, the
    feasible ones (the least infeasible when none is), one per catalogue combination first
    (lowest violation, then lowest summed normalised objectives), at most ``n_seeds``.  A
    narrow feasible region of a catalogue space is then in the first population."""
    U = _stratified(problem.space, size, seed)
    FG = problem.evaluate_unit(U)
    n_obj = len(problem.objective_names)
    viol = (np.max(np.maximum(FG[:, n_obj:], 0.0), axis=1) if FG.shape[1] > n_obj
            else np.zeros(size))
    F = FG[:, :n_obj]
    score = np.sum(F / np.maximum(np.median(np.abs(F), axis=0), 1e-300), axis=1)
    order = np.lexsort((score, viol))
    if viol[order[0]] > 0:  # none feasible: the least infeasible
        return U[order[:n_seeds]]
    order = order[viol[order] <= 0]
    ints = [k for k in range(problem.space.n) if problem.space.integer
            and problem.space.integer[k]]
    phys = problem.space.from_unit(U[order])
    combo = [tuple(float(phys[problem.space.names[k]][j]) for k in ints)
             for j in range(len(order))]
    first, seen = [], set()
    for j, c in enumerate(combo):
        if c not in seen:
            seen.add(c)
            first.append(j)
    rest = [j for j in range(len(order)) if j not in set(first)]
    return U[order[(first + rest)[:n_seeds]]]


def _stratified(space: DesignSpace, size: int, seed: int) -> np.ndarray:
    """``size`` seeded unit-cube draws whose integer (catalogue) variables cycle through
    every combination equally (each value at the middle of its interval); the continuous
    variables uniform."""
    U = np.random.default_rng(seed).random((size, space.n))
    ints = [k for k in range(space.n) if space.integer and space.integer[k]]
    if not ints:
        return U
    counts = [int(round(space.upper[k] - space.lower[k])) + 1 for k in ints]
    idx = np.arange(size)
    for k, c in zip(ints, counts):
        U[:, k] = (idx % c + 0.5) / c
        idx = idx // c
    return U


def _sub_space(space: DesignSpace) -> DesignSpace:
    keep = [k for k in range(space.n) if not space.integer[k]]
    return DesignSpace(tuple(space.names[k] for k in keep), tuple(space.lower[k] for k in keep),
                       tuple(space.upper[k] for k in keep), tuple(space.log[k] for k in keep),
                       space.where)


def solve_goal_attainment_mixed(problem: DesignProblem, goals: Sequence[float],
                                weights: Sequence[float] | None = None, *, n_starts: int = 6,
                                seed: int = 0, max_iter: int = 300,
                                where: str = "goal attainment") -> GoalAttainmentResult:
    """Goal attainment (see :func:`~.goal.solve_goal_attainment`) on a problem whose space
    has integer variables: the catalogue combination fixed per start (see module)."""
    space = problem.space
    if not any(space.integer):
        return solve_goal_attainment(problem, goals, weights, None, n_starts=n_starts,
                                     seed=seed, max_iter=max_iter, where=where)
    g = np.asarray(goals, float)
    w = np.abs(g) if weights is None else np.asarray(weights, float)
    U = np.random.default_rng(seed).random((SCREEN_SIZE, space.n))
    FG = problem.evaluate_unit(U)
    n_obj = len(problem.objective_names)
    with np.errstate(divide="ignore", invalid="ignore"):
        gamma = np.max(np.where(w > 0, (FG[:, :n_obj] - g) / np.where(w > 0, w, 1.0),
                                np.where(FG[:, :n_obj] <= g, -np.inf, np.inf)), axis=1)
    viol = np.max(np.maximum(FG[:, n_obj:], 0.0), axis=1) if FG.shape[1] > n_obj \
        else np.zeros(len(U))
    order = np.lexsort((gamma, viol))  # feasible (viol 0) first, then by γ
    phys = space.from_unit(U)
    ints = [k for k in range(space.n) if space.integer[k]]
    combos: list[tuple[float, ...]] = []
    firsts: list[int] = []
    for i in order:
        key = tuple(float(phys[space.names[k]][i]) for k in ints)
        if key not in combos:
            combos.append(key)
            firsts.append(int(i))
        if len(combos) == n_starts:
            break
    sub = _sub_space(space)
    runs = []
    for key, i in zip(combos, firsts):
        fixed = tuple((space.names[k], v) for k, v in zip(ints, key))
        p = DesignProblem(sub, FixedVariables(problem.evaluator, fixed))
        start = {n: float(phys[n][i]) for n in sub.names}
        res = solve_goal_attainment(p, g, w, start, n_starts=1, seed=seed, max_iter=max_iter,
                                    where=where)
        runs.append((res, dict(fixed)))
    ok = [k for k, (r, _) in enumerate(runs) if r.success]
    pool = ok or list(range(len(runs)))
    best = min(pool, key=lambda k: runs[k][0].gamma)
    res, fixed = runs[best]
    for h in res.history:
        h["design"].update(fixed)
    design = {n: (fixed[n] if n in fixed else res.design[n]) for n in space.names}
    full = problem.evaluate_design({k: np.array([v]) for k, v in design.items()})
    objectives = {k: float(np.ravel(v)[0]) for k, v in full.items()}
    starts = [{"fixed": f, "gamma": r.gamma, "success": r.success, "message": r.message}
              for r, f in runs]
    stats = {**res.stats, "screened": SCREEN_SIZE, "n_starts": len(runs),
             "chosen_start": best, "nfev": SCREEN_SIZE + sum(r.stats["nfev"] for r, _ in runs)}
    return dataclasses.replace(res, design=design, objectives=objectives, starts=starts,
                               stats=stats, x=space.to_unit(design),
                               message=f"catalogue combination {best + 1}/{len(runs)} "
                                       f"{fixed}: {res.message}")
