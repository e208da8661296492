"""Goal attainment (paper §4.2): MATLAB ``fgoalattain`` semantics as a smooth NLP
solved by SLSQP from several starts in the unit cube of a :class:`~.problem.DesignProblem`."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..physics.params import ParameterError
from .problem import DesignProblem

__all__ = ["default_goals", "GoalAttainmentResult", "solve_goal_attainment"]


def default_goals(problem: DesignProblem, reference: Mapping[str, float], scale: float = 1.0
                  ) -> np.ndarray:
    """Goals = objectives of the reference (prototype) design × ``scale``."""
    F0 = problem.objectives_unit(problem.space.to_unit(reference))[0]
    return F0 * float(scale)


def _check_goals(goals: np.ndarray, weights: np.ndarray, names: Sequence[str],
                 where: str) -> None:
    if goals.shape != (len(names),) or weights.shape != (len(names),):
        raise ParameterError(f"{where}: need {len(names)} goals and weights "
                             f"({', '.join(names)}), got {goals.size} and {weights.size}")
    for name, g, w in zip(names, goals, weights):
        if not (math.isfinite(g) and math.isfinite(w)):
            raise ParameterError(f"{where}: goal and weight of '{name}' must be finite")
        if w < 0:
            raise ParameterError(f"{where}: weight of '{name}' is {w:g} < 0; weights must be "
                                 f">= 0 (0 makes the goal a hard constraint)")
        if g == 0.0 and w == 0.0:
            raise ParameterError(
                f"{where}: '{name}' has goal 0 and weight 0, i.e. the hard constraint "
                f"{name} <= 0, which no design meets (the objectives are positive); give a "
                f"nonzero goal or a positive weight")
    if np.all(weights == 0.0):
        raise ParameterError(f"{where}: all weights are 0, so gamma is undetermined; give at "
                             f"least one positive weight (default |goal|)")


@dataclass
class GoalAttainmentResult:
    """Outcome of :func:`solve_goal_attainment` (mirrors ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    success : bool
        The chosen start converged (SLSQP exit 0) and meets every constraint.
    message : str
    gamma : float
        Attainment factor γ: F_i ≤ goal_i + w_i γ for all i. With w = |goal|,
        γ < 0 means every objective beats its goal by at least |γ| (relative).
    design : dict[str, float]
        Optimum in physical units.
    objectives : dict[str, float]
        Objectives (and evaluator extras) at the optimum.
    goals, weights : ndarray
    history : list[dict]
        Per SLSQP iteration of the chosen start: ``design``, ``objectives``, ``gamma``.
    starts : list[dict]
        Per start: start point, final γ, status, iterations.
    stats : dict
        ``nfev`` (designs evaluated), ``seconds``, ``n_starts``.
    """

    success: bool
    message: str
    gamma: float
    design: dict[str, float]
    objectives: dict[str, float]
    goals: np.ndarray
    weights: np.ndarray
    objective_names: tuple[str, ...]
    history: list[dict]
    starts: list[dict]
    stats: dict
    x: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def summary(self) -> str:
        """Status, attainment factor γ, the optimum and its objectives."""
        return "\n".join([
            f"goal attainment: {'converged' if self.success else 'FAILED'} ({self.message}); "
            f"gamma = {self.gamma:+.4f}",
            "design: " + ", ".join(f"{k} = {v:.4g}" for k, v in self.design.items()),
            "objectives: " + ", ".join(f"{k} = {self.objectives[k]:.4g}"
                                       for k in self.objective_names)])

    def plot(self, ax: Any = None, which: str = "design") -> Any:
        """Paper Fig 17 (``which="design"``), 18 (``"mass"``, into ``ax`` when given) or 19
        (``"objectives"``); writes nothing."""
        from ..plots.design import goal_attainment_history
        return goal_attainment_history(self, which, ax=ax)


def _fd_objectives(problem: DesignProblem, u: np.ndarray, h: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Objectives and their Jacobian (n_obj, n_var) at u by central differences,
    all stencil points evaluated in one vectorised call (one-sided at bounds)."""
    n = u.size
    up = np.repeat(u[None, :], n, axis=0) + h * np.eye(n)
    dn = np.repeat(u[None, :], n, axis=0) - h * np.eye(n)
    up = np.clip(up, 0.0, 1.0)
    dn = np.clip(dn, 0.0, 1.0)
    F = problem.evaluate_unit(np.vstack([u[None, :], up, dn]))  # objectives, constraints
    f0, fu, fd = F[0], F[1:n + 1], F[n + 1:]
    step = np.diag(up) - np.diag(dn)
    J = ((fu - fd) / step[:, None]).T
    return f0, J


class _MemoObjectives:
    """``u -> (F, J)`` by :func:`_fd_objectives` on the clipped unit point, memoised
    (SLSQP asks for the same point for the objective and the constraints); ``nfev``
    counts designs evaluated (2n + 1 per new point)."""

    def __init__(self, problem: DesignProblem, fd_step: float) -> None:
        self.problem, self.fd_step, self.nfev = problem, fd_step, 0
        self._cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def __call__(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = np.asarray(u, float).tobytes()
        if key not in self._cache:
            u = np.asarray(u, float)
            self._cache[key] = _fd_objectives(self.problem, np.clip(u, 0.0, 1.0), self.fd_step)
            self.nfev += 2 * u.size + 1
        return self._cache[key]


def solve_goal_attainment(problem: DesignProblem, goals: Sequence[float],
                          weights: Sequence[float] | None = None,
                          start: Mapping[str, float] | None = None, *, n_starts: int = 6,
                          seed: int = 0, max_iter: int = 300, tol: float = 1e-10,
                          fd_step: float = 1e-6, refine: bool = True,
                          where: str = "goal attainment") -> GoalAttainmentResult:
    """Goal attainment (MATLAB ``fgoalattain``): min γ s.t. F_i(x) − w_i γ ≤ goal_i.

    Solved as a smooth NLP in (unit-cube x, γ) by SLSQP with vectorised
    central-difference gradients, from ``start`` (the prototype) and
    ``n_starts − 1`` seeded random points; the best feasible end point wins.
    Constraint rows are divided by max(|goal_i|, w_i, 1e-12) for conditioning
    (the feasible set is unchanged).

    Parameters
    ----------
    problem : DesignProblem
    goals : sequence of float
        One goal per objective (``problem.objective_names`` order).
    weights : sequence of float, optional
        Default |goal|. Weight 0 makes the goal a hard constraint.
    start : dict, optional
        Physical start design (default: centre of the unit cube).
    n_starts : int
        Total number of starts (≥ 1).
    seed : int
        Seed of the random starts.
    refine : bool
        Tie-break (an extension of ``fgoalattain``): the min-γ set is often not a
        single point (objectives whose constraints are slack leave directions
        free), so a second SLSQP stage keeps every F_i ≤ goal_i + w_i γ* and
        minimises Σ_i (F_i − goal_i)/scale_i, i.e. improves the slack objectives
        as far as the optimal γ* allows. γ is unchanged; the design becomes
        Pareto-optimal and reproducible. Its iterations are appended to
        ``history`` (``phase`` 2).
    """
    names = problem.objective_names
    g = np.asarray(goals, dtype=float).ravel()
    w = np.abs(g) if weights is None else np.asarray(weights, dtype=float).ravel()
    _check_goals(g, w, names, where)
    if n_starts < 1:
        raise ParameterError(f"{where}: n_starts must be >= 1, got {n_starts}")
    scale = np.maximum(np.maximum(np.abs(g), w), 1e-12)
    # the problem's constraints (rated limits, stroke; normalised, ≤ 0 feasible) join as
    # hard goals: goal 0, weight 0 (fgoalattain's hard constraints)
    n_obj, n_con = len(names), len(getattr(problem, "constraint_names", ()))
    g = np.concatenate([g, np.zeros(n_con)])
    w = np.concatenate([w, np.zeros(n_con)])
    scale = np.concatenate([scale, np.ones(n_con)])
    obj = slice(0, n_obj)
    n = problem.space.n
    rng = np.random.default_rng(seed)
    u_start = (problem.space.to_unit(start) if start is not None
               else np.full(n, 0.5)).astype(float)
    starts_u = [np.clip(u_start, 0.0, 1.0)] + [rng.random(n) for _ in range(n_starts - 1)]
    t0 = time.perf_counter()
    runs_fj: list[_MemoObjectives] = []  # their evaluation counts make nfev
    runs = []
    for u0 in starts_u:
        fj = _MemoObjectives(problem, fd_step)
        runs_fj.append(fj)
        runs.append(_attain_from(problem, fj, u0, g, w, scale, max_iter, tol))
    ok = [r for r in runs if r["feasible"]]
    pool = [k for k, r in enumerate(runs) if r["feasible"] or not ok]
    g_min = min(runs[k]["gamma"] for k in pool)
    # ties (to 1e-9) go to the earliest start, i.e. the given start point
    best_k = next(k for k in pool if runs[k]["gamma"] <= g_min + 1e-9 * max(1.0, abs(g_min)))
    best = runs[best_k]
    refined = None
    if refine and best["feasible"] and np.any(w > 0):
        fj2 = _MemoObjectives(problem, fd_step)
        runs_fj.append(fj2)
        refined = _refine(fj2, best, g, w, scale, obj, max_iter, tol)
        if refined is not None:
            best = {**best, "u": refined["u"], "gamma": refined["gamma"]}
    d = {k: float(v) for k, v in problem.space.from_unit(best["u"]).items()}
    full = problem.evaluate_design({k: np.array([v]) for k, v in d.items()})
    objectives = {k: float(np.ravel(v)[0]) for k, v in full.items()}
    success = bool(best["feasible"] and best["status"] == 0)
    msg = (f"start {best_k + 1}/{len(runs)}: {best['message']}"
           + ("" if best["feasible"] else " (constraints violated: no feasible end point)"))
    starts = [{"start": {k: float(v) for k, v in r["start"].items()}, "gamma": r["gamma"],
               "status": r["status"], "message": r["message"], "nit": r["nit"],
               "feasible": r["feasible"]} for r in runs]
    return GoalAttainmentResult(
        success=success, message=msg, gamma=float(best["gamma"]), design=d,
        objectives=objectives, goals=g[obj], weights=w[obj], objective_names=tuple(names),
        history=_history(problem, best, refined), starts=starts,
        stats={"nfev": sum(f.nfev for f in runs_fj), "seconds": time.perf_counter() - t0,
               "n_starts": len(runs), "chosen_start": best_k,
               "refinement": None if refined is None else
               {k: refined[k] for k in ("status", "message", "nit")}},
        x=best["u"])


def _attain_from(problem: DesignProblem, fj: "_MemoObjectives", u0: np.ndarray, g: np.ndarray,
                 w: np.ndarray, scale: np.ndarray, max_iter: int, tol: float) -> dict:
    """One SLSQP run of min γ s.t. F_i(x) − w_i γ ≤ goal_i from the unit-cube point ``u0``:
    its end point, attained γ, status, feasibility and iterates."""
    from scipy.optimize import minimize

    n = problem.space.n
    F0 = fj(u0)[0]
    gamma0 = float(np.max(np.where(w > 0, (F0 - g) / np.where(w > 0, w, 1.0), -np.inf)))
    z0 = np.append(u0, gamma0)
    hist: list[tuple[np.ndarray, float]] = [(u0.copy(), gamma0)]

    def cons(z: np.ndarray) -> np.ndarray:
        return (g + w * z[-1] - fj(z[:-1])[0]) / scale

    def cons_jac(z: np.ndarray) -> np.ndarray:
        J = fj(z[:-1])[1]
        return np.hstack([-J, w[:, None]]) / scale[:, None]

    res = minimize(lambda z: z[-1], z0, jac=lambda z: np.eye(n + 1)[-1], method="SLSQP",
                   bounds=[(0.0, 1.0)] * n + [(None, None)],
                   constraints=[{"type": "ineq", "fun": cons, "jac": cons_jac}],
                   callback=lambda zk: hist.append((np.clip(zk[:-1], 0, 1).copy(),
                                                    float(zk[-1]))),
                   options={"maxiter": max_iter, "ftol": tol})
    u_end = np.clip(res.x[:-1], 0.0, 1.0)
    F_end = fj(u_end)[0]
    viol = float(np.max((F_end - g - w * res.x[-1]) / scale))
    # the attained γ of the end point (tightest γ for that x)
    pos = w > 0
    gamma_end = float(np.max((F_end[pos] - g[pos]) / w[pos]))
    hard_ok = bool(np.all(F_end[~pos] <= g[~pos] + 1e-9 * scale[~pos]))
    return {"u": u_end, "gamma": gamma_end, "status": int(res.status),
            "message": str(res.message), "nit": int(res.nit),
            "feasible": hard_ok and viol <= 1e-6, "history": hist,
            "start": problem.space.from_unit(u0)}


def _refine(fj2: "_MemoObjectives", best: dict, g: np.ndarray, w: np.ndarray,
            scale: np.ndarray, obj: slice, max_iter: int, tol: float) -> dict | None:
    """The tie-break stage (see ``refine``): keep every F_i ≤ goal_i + w_i γ* and minimise
    Σ (F_i − goal_i)/scale_i over the objectives; None when it does not improve."""
    from scipy.optimize import minimize

    n = best["u"].size
    gstar = best["gamma"]
    cap = g + w * gstar + 1e-9 * scale
    hist2: list[tuple[np.ndarray, float]] = []
    res2 = minimize(lambda u: float(np.sum(((fj2(u)[0] - g) / scale)[obj])), best["u"],
                    jac=lambda u: np.sum((fj2(u)[1] / scale[:, None])[obj], axis=0),
                    method="SLSQP", bounds=[(0.0, 1.0)] * n,
                    constraints=[{"type": "ineq", "fun": lambda u: (cap - fj2(u)[0]) / scale,
                                  "jac": lambda u: -fj2(u)[1] / scale[:, None]}],
                    callback=lambda uk: hist2.append((np.clip(uk, 0, 1).copy(), gstar)),
                    options={"maxiter": max_iter, "ftol": tol})
    u2 = np.clip(res2.x, 0.0, 1.0)
    F2 = fj2(u2)[0]
    if np.all(F2 <= cap + 1e-8 * scale) and float(np.sum(((F2 - g) / scale)[obj])) <= float(
            np.sum(((fj2(best["u"])[0] - g) / scale)[obj])):
        return {"u": u2, "status": int(res2.status), "message": str(res2.message),
                "nit": int(res2.nit), "history": hist2,
                "gamma": float(np.max((F2[w > 0] - g[w > 0]) / w[w > 0]))}
    return None


def _history(problem: DesignProblem, best: dict, refined: dict | None) -> list[dict]:
    """The iterates of the chosen start (phase 1) and of the refinement (phase 2), each
    with its design, objectives and γ."""
    history = []
    phases = [(1, u, gam) for u, gam in best["history"]]
    if refined is not None:
        phases += [(2, u, gam) for u, gam in refined["history"]]
    for phase, u, gam in phases:
        dd = {k: float(v) for k, v in problem.space.from_unit(u).items()}
        ff = problem.evaluate_design({k: np.array([v]) for k, v in dd.items()})
        history.append({"phase": phase, "design": dd,
                        "objectives": {k: float(np.ravel(v)[0]) for k, v in ff.items()},
                        "gamma": gam})
    return history
