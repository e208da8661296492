"""Optimal design of the harvester: design space, the pymoo design problem, goal
attainment (paper §4.2) and NSGA-II Pareto fronts with checkpoint/resume.

The design problem **is** a :class:`pymoo.core.problem.Problem`
(:class:`DesignProblem`) whose ``_evaluate`` is vectorised over the population.
Its decision variables live in the unit cube: variable ``k`` maps to its physical
value linearly, or logarithmically when its box spans decades (paper Table 3:
J_t, k_n and R_e), so every optimiser sees well-scaled variables.

The objectives come from an *evaluator*: a picklable callable mapping a dict of
physical design arrays to a dict of objective arrays (and extra quantities for
reporting).  :class:`QuarterCarObjectives` is the paper's one, built on the exact
frequency-domain path of the frictionless quarter car (:func:`ehsa_opt.metrics.
linear_metrics`); tests plug in analytic functions with known answers.

Classes and functions
---------------------
DesignSpace, PAPER_BOX
    Named box with linear/log scaling (paper Table 3 by default).
QuarterCarObjectives
    [α, η_rh, 1/ρ_g, 1/η_g] of a design on a vehicle/road (SPEC §5).
DesignProblem
    The pymoo problem.
solve_goal_attainment, GoalAttainmentResult
    MATLAB ``fgoalattain`` semantics as a smooth NLP (SLSQP, multistart).
run_nsga2, ParetoResult
    Seeded NSGA-II with per-generation hypervolume, atomic checkpoints and
    exact resume; knee / preference pick.
"""

from __future__ import annotations

import hashlib
import json
import math
import pickle
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from pymoo.core.problem import Problem

from .params import HarvesterParams, ParameterError, RoadParams, VehicleParams

__all__ = [
    "DESIGN_VARIABLES", "OBJECTIVE_NAMES", "PAPER_BOX", "DesignSpace", "QuarterCarObjectives",
    "DesignProblem", "GoalAttainmentResult", "solve_goal_attainment", "default_goals",
    "ParetoResult", "run_nsga2", "pick_preferred", "hypervolume", "non_dominated",
    "dominates_by",
]

#: The paper's design variables (Table 3), in this order.
DESIGN_VARIABLES: tuple[str, ...] = ("total_inertia_gcm2", "lead_mm_per_rev",
                                     "speed_constant_rpm_per_V", "load_ohm")
#: The paper's objectives (Eq 10), all minimised.
OBJECTIVE_NAMES: tuple[str, ...] = ("comfort", "road_holding", "inverse_power",
                                    "inverse_efficiency")


# --------------------------------------------------------------------------- design space
@dataclass(frozen=True)
class DesignSpace:
    """A named box of design variables with linear or logarithmic scaling.

    Attributes
    ----------
    names : tuple[str, ...]
        Variable names (with units, e.g. ``load_ohm``).
    lower, upper : tuple[float, ...]
        Bounds in the variables' units; ``lower < upper``.
    log : tuple[bool, ...]
        Map the unit interval logarithmically (needs ``lower > 0``).
    where : str
        Origin used in error messages (e.g. ``"paper_design.toml [design.bounds]"``).
    """

    names: tuple[str, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    log: tuple[bool, ...]
    where: str = "design space"

    def __post_init__(self) -> None:
        n = len(self.names)
        if n == 0:
            raise ParameterError(f"{self.where}: no design variables; give at least one bound")
        if not (len(self.lower) == len(self.upper) == len(self.log) == n):
            raise ParameterError(f"{self.where}: names, lower, upper and log differ in length")
        if len(set(self.names)) != n:
            raise ParameterError(f"{self.where}: duplicate design variable names")
        for name, lo, hi, lg in zip(self.names, self.lower, self.upper, self.log):
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise ParameterError(f"{self.where}: bounds of '{name}' must be finite, got "
                                     f"[{lo}, {hi}]")
            if lo > hi:
                raise ParameterError(
                    f"{self.where}: '{name}' has lower bound {lo:g} > upper bound {hi:g}; "
                    f"write it as [lower, upper], e.g. {name} = [{hi:g}, {lo:g}]")
            if lo == hi:
                raise ParameterError(
                    f"{self.where}: '{name}' has lower bound = upper bound = {lo:g}; to fix "
                    f"the variable remove it from the box and set it in [harvester]")
            if lg and lo <= 0.0:
                raise ParameterError(f"{self.where}: '{name}' is log-scaled, so its lower bound "
                                     f"must be > 0 (got {lo:g})")

    @classmethod
    def from_bounds(cls, bounds: Mapping[str, Sequence[float]], log: Sequence[str] | None = None,
                    where: str = "design space") -> "DesignSpace":
        """Build from ``{name: [lower, upper]}``; ``log`` names log-scaled variables
        (default: those whose upper/lower ratio exceeds 20)."""
        names, lo, hi, lg = [], [], [], []
        for name, b in bounds.items():
            if (not isinstance(b, (list, tuple)) or len(b) != 2
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                               for v in b)):
                raise ParameterError(f"{where}: '{name}' must be [lower, upper] (two numbers), "
                                     f"got {b!r}")
            names.append(str(name))
            lo.append(float(b[0]))
            hi.append(float(b[1]))
        for name, a, b in zip(names, lo, hi):
            if log is None:
                lg.append(a > 0 and b > 0 and b / a > 20.0)
            else:
                lg.append(name in log)
        if log is not None:
            unknown = set(log) - set(names)
            if unknown:
                raise ParameterError(f"{where}: log-scaled {sorted(unknown)} not in the box "
                                     f"({', '.join(names)})")
        return cls(tuple(names), tuple(lo), tuple(hi), tuple(lg), where)

    @property
    def n(self) -> int:
        return len(self.names)

    def from_unit(self, U: Any) -> dict[str, np.ndarray]:
        """Physical values of unit-cube points ``U`` (shape (..., n)) as a dict."""
        U = np.clip(np.asarray(U, dtype=float), 0.0, 1.0)
        out = {}
        for k, (name, lo, hi, lg) in enumerate(zip(self.names, self.lower, self.upper,
                                                   self.log)):
            u = U[..., k]
            out[name] = lo * (hi / lo) ** u if lg else lo + (hi - lo) * u
        return out

    def to_unit(self, design: Mapping[str, Any]) -> np.ndarray:
        """Unit-cube coordinates of a physical design (dict of scalars/arrays)."""
        cols = []
        for name, lo, hi, lg in zip(self.names, self.lower, self.upper, self.log):
            if name not in design:
                raise ParameterError(f"{self.where}: design lacks '{name}'")
            v = np.asarray(design[name], dtype=float)
            cols.append(np.log(v / lo) / np.log(hi / lo) if lg else (v - lo) / (hi - lo))
        return np.stack(cols, axis=-1)

    def as_dict(self) -> dict[str, Any]:
        return {n: {"lower": lo, "upper": hi, "log": lg}
                for n, lo, hi, lg in zip(self.names, self.lower, self.upper, self.log)}


#: Paper Table 3 (R_e lower bound 1 Ω is our assumption, SPEC §6.2).
PAPER_BOX = DesignSpace(
    DESIGN_VARIABLES, (250.0, 5.0, 29.8, 1.0), (10_000.0, 20.0, 11_900.0, 10_000.0),
    (True, False, True, True), "paper Table 3")


# --------------------------------------------------------------------------- evaluator
@dataclass(frozen=True)
class QuarterCarObjectives:
    """Paper objectives [α, η_rh, 1/ρ_g, 1/η_g] of the frictionless quarter car.

    Evaluated exactly in the frequency domain by
    :func:`ehsa_opt.metrics.linear_metrics`, vectorised over designs.

    Attributes
    ----------
    vehicle, road : VehicleParams, RoadParams
        Quarter car and road (class, speed).
    base : HarvesterParams
        Fixed harvester fields (R_i, L_i, …); design variables override it.
    metric_options : tuple of (key, value)
        Extra keyword arguments of ``linear_metrics`` (e.g. ``n_freq``).
    """

    vehicle: VehicleParams
    road: RoadParams
    base: HarvesterParams = field(default_factory=HarvesterParams)
    metric_options: tuple[tuple[str, Any], ...] = ()

    objective_names = OBJECTIVE_NAMES

    def design_mapping(self, design: Mapping[str, Any]) -> dict[str, Any]:
        """The ``linear_metrics`` design mapping: base fields + design variables."""
        fixed = {"internal_resistance_ohm": self.base.internal_resistance_ohm,
                 "inductance_H": self.base.inductance_H}
        if "total_inertia_gcm2" not in design:
            fixed["total_inertia_gcm2"] = self.base.total_inertia_gcm2
        if "speed_constant_rpm_per_V" not in design and "voltage_constant_Vs_per_rad" not in design:
            fixed["voltage_constant_Vs_per_rad"] = self.base.voltage_constant_Vs_per_rad
            fixed["torque_constant_Nm_per_A"] = self.base.torque_constant_Nm_per_A
        for key in ("lead_mm_per_rev", "load_ohm"):
            if key not in design:
                fixed[key] = getattr(self.base, key)
        fixed.update({k: np.asarray(v, dtype=float) for k, v in design.items()})
        return fixed

    def __call__(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        from .metrics import linear_metrics
        m = linear_metrics(self.vehicle, self.road, self.design_mapping(design),
                           **dict(self.metric_options))
        out = {"comfort": m["comfort"], "road_holding": m["road_holding"],
               "inverse_power": 1.0 / m["power_dimensionless"],
               "inverse_efficiency": 1.0 / m["efficiency"]}
        for key in ("comfort_weighted_rms_m_s2", "power_W", "efficiency", "power_dimensionless",
                    "dissipated_power_W", "dissipation_bound_W"):
            if key in m:
                out[key] = m[key]
        return out

    def fingerprint(self) -> dict[str, Any]:
        from dataclasses import asdict
        return {"kind": "quarter_car_linear", "vehicle": asdict(self.vehicle),
                "road": asdict(self.road), "base": asdict(self.base),
                "options": dict(self.metric_options)}


# --------------------------------------------------------------------------- pymoo problem
@dataclass(frozen=True)
class _ObjectiveChunk:
    """Picklable task: objective matrix of a block of unit-cube points."""

    space: DesignSpace
    evaluator: Any
    names: tuple[str, ...]

    def __call__(self, U: np.ndarray) -> np.ndarray:
        res = self.evaluator(self.space.from_unit(U))
        return np.column_stack([np.broadcast_to(np.asarray(res[k], float), (U.shape[0],))
                                for k in self.names])


class DesignProblem(Problem):
    """The design problem as a pymoo :class:`~pymoo.core.problem.Problem`.

    Decision variables are unit-cube coordinates of ``space`` (see
    :meth:`DesignSpace.from_unit`); objectives are ``evaluator.objective_names``,
    all minimised.  ``_evaluate`` is vectorised: the whole population goes to the
    evaluator in one call.

    Parameters
    ----------
    space : DesignSpace
    evaluator : callable
        ``evaluator(design: dict[str, ndarray]) -> dict[str, ndarray]`` with an
        attribute ``objective_names``; must be picklable (checkpoints, Dask).
    """

    #: designs per evaluation block (see :meth:`objectives_unit`)
    CHUNK = 64

    def __init__(self, space: DesignSpace, evaluator: Callable[..., Mapping[str, Any]]) -> None:
        self.space = space
        self.evaluator = evaluator
        self.objective_names = tuple(evaluator.objective_names)
        #: optional ``mapper(fn, list_of_chunks) -> list`` (local pool or Dask, see
        #: :mod:`ehsa_opt.sweep`) to spread a population over workers; not pickled
        self.mapper: Any = None
        super().__init__(n_var=space.n, n_obj=len(self.objective_names), xl=0.0, xu=1.0,
                         vtype=float)

    def evaluate_design(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """All evaluator outputs (objectives and extras) of physical designs."""
        return {k: np.asarray(v, dtype=float) for k, v in self.evaluator(design).items()}

    def objectives_unit(self, U: Any) -> np.ndarray:
        """Objective matrix (n, n_obj) of unit-cube points ``U`` (n, n_var)."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        # fixed blocks of CHUNK designs, locally and on a mapper alike: vectorised
        # evaluators may round differently with the batch size, and the blocks make
        # local and distributed runs bit-identical
        blocks = np.array_split(U, max(1, -(-U.shape[0] // self.CHUNK)))
        task = _ObjectiveChunk(self.space, self.evaluator, self.objective_names)
        if self.mapper is not None and len(blocks) > 1:
            return np.vstack(self.mapper(task, blocks))
        return np.vstack([task(b) for b in blocks])

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["mapper"] = None  # executors/clients are not part of the problem's state
        return state

    def _evaluate(self, X: np.ndarray, out: dict, *args: Any, **kwargs: Any) -> None:
        F = self.objectives_unit(X)
        # a non-finite objective (numerically broken design) must not poison sorting
        out["F"] = np.where(np.isfinite(F), F, 1e30)

    def fingerprint(self) -> str:
        """Hash of the box and the evaluator settings (guards resumes)."""
        ev = self.evaluator
        desc = ev.fingerprint() if hasattr(ev, "fingerprint") else repr(ev)
        blob = json.dumps({"space": self.space.as_dict(), "evaluator": desc,
                           "objectives": self.objective_names}, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]


# --------------------------------------------------------------------------- goal attainment
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

    def plot(self, **kw: Any) -> Any:
        from .plots.design import goal_attainment_history
        return goal_attainment_history(self, **kw)


def _fd_objectives(problem: DesignProblem, u: np.ndarray, h: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Objectives and their Jacobian (n_obj, n_var) at u by central differences,
    all stencil points evaluated in one vectorised call (one-sided at bounds)."""
    n = u.size
    up = np.repeat(u[None, :], n, axis=0) + h * np.eye(n)
    dn = np.repeat(u[None, :], n, axis=0) - h * np.eye(n)
    up = np.clip(up, 0.0, 1.0)
    dn = np.clip(dn, 0.0, 1.0)
    F = problem.objectives_unit(np.vstack([u[None, :], up, dn]))
    f0, fu, fd = F[0], F[1:n + 1], F[n + 1:]
    step = np.diag(up) - np.diag(dn)
    J = ((fu - fd) / step[:, None]).T
    return f0, J


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
    from scipy.optimize import minimize

    names = problem.objective_names
    g = np.asarray(goals, dtype=float).ravel()
    w = np.abs(g) if weights is None else np.asarray(weights, dtype=float).ravel()
    _check_goals(g, w, names, where)
    if n_starts < 1:
        raise ParameterError(f"{where}: n_starts must be >= 1, got {n_starts}")
    scale = np.maximum(np.maximum(np.abs(g), w), 1e-12)
    n = problem.space.n
    rng = np.random.default_rng(seed)
    u_start = (problem.space.to_unit(start) if start is not None
               else np.full(n, 0.5)).astype(float)
    starts_u = [np.clip(u_start, 0.0, 1.0)] + [rng.random(n) for _ in range(n_starts - 1)]
    t0 = time.perf_counter()
    nfev = 0
    runs = []
    for k, u0 in enumerate(starts_u):
        cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

        def fj(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            nonlocal nfev
            key = np.asarray(u, float).tobytes()
            if key not in cache:
                cache[key] = _fd_objectives(problem, np.clip(u, 0.0, 1.0), fd_step)
                nfev += 2 * n + 1
            return cache[key]

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
        runs.append({"u": u_end, "gamma": gamma_end, "status": int(res.status),
                     "message": str(res.message), "nit": int(res.nit),
                     "feasible": hard_ok and viol <= 1e-6, "history": hist,
                     "start": problem.space.from_unit(u0)})
    ok = [r for r in runs if r["feasible"]]
    pool = [k for k, r in enumerate(runs) if r["feasible"] or not ok]
    g_min = min(runs[k]["gamma"] for k in pool)
    # ties (to 1e-9) go to the earliest start, i.e. the given start point
    best_k = next(k for k in pool if runs[k]["gamma"] <= g_min + 1e-9 * max(1.0, abs(g_min)))
    best = runs[best_k]
    refined = None
    if refine and best["feasible"] and np.any(w > 0):
        gstar = best["gamma"]
        cache2: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

        def fj2(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            nonlocal nfev
            key = np.asarray(u, float).tobytes()
            if key not in cache2:
                cache2[key] = _fd_objectives(problem, np.clip(u, 0.0, 1.0), fd_step)
                nfev += 2 * n + 1
            return cache2[key]

        cap = g + w * gstar + 1e-9 * scale
        hist2: list[tuple[np.ndarray, float]] = []
        res2 = minimize(lambda u: float(np.sum((fj2(u)[0] - g) / scale)), best["u"],
                        jac=lambda u: np.sum(fj2(u)[1] / scale[:, None], axis=0),
                        method="SLSQP", bounds=[(0.0, 1.0)] * n,
                        constraints=[{"type": "ineq", "fun": lambda u: (cap - fj2(u)[0]) / scale,
                                      "jac": lambda u: -fj2(u)[1] / scale[:, None]}],
                        callback=lambda uk: hist2.append((np.clip(uk, 0, 1).copy(), gstar)),
                        options={"maxiter": max_iter, "ftol": tol})
        u2 = np.clip(res2.x, 0.0, 1.0)
        F2 = fj2(u2)[0]
        if np.all(F2 <= cap + 1e-8 * scale) and float(np.sum((F2 - g) / scale)) <= float(
                np.sum((fj2(best["u"])[0] - g) / scale)):
            refined = {"u": u2, "status": int(res2.status), "message": str(res2.message),
                       "nit": int(res2.nit), "history": hist2}
            best = {**best, "u": u2,
                    "gamma": float(np.max((F2[w > 0] - g[w > 0]) / w[w > 0]))}
    d = {k: float(v) for k, v in problem.space.from_unit(best["u"]).items()}
    full = problem.evaluate_design({k: np.array([v]) for k, v in d.items()})
    objectives = {k: float(np.ravel(v)[0]) for k, v in full.items()}
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
    success = bool(best["feasible"] and best["status"] == 0)
    msg = (f"start {best_k + 1}/{len(runs)}: {best['message']}"
           + ("" if best["feasible"] else " (constraints violated: no feasible end point)"))
    starts = [{"start": {k: float(v) for k, v in r["start"].items()}, "gamma": r["gamma"],
               "status": r["status"], "message": r["message"], "nit": r["nit"],
               "feasible": r["feasible"]} for r in runs]
    return GoalAttainmentResult(
        success=success, message=msg, gamma=float(best["gamma"]), design=d,
        objectives=objectives, goals=g, weights=w, objective_names=tuple(names),
        history=history, starts=starts,
        stats={"nfev": nfev, "seconds": time.perf_counter() - t0, "n_starts": len(runs),
               "chosen_start": best_k,
               "refinement": None if refined is None else
               {k: refined[k] for k in ("status", "message", "nit")}},
        x=best["u"])


# --------------------------------------------------------------------------- Pareto tools
def non_dominated(F: np.ndarray) -> np.ndarray:
    """Boolean mask of the non-dominated rows of F (minimisation); duplicates keep
    their first occurrence."""
    F = np.asarray(F, dtype=float)
    n = F.shape[0]
    keep = np.ones(n, dtype=bool)
    for i in range(n):
        if not keep[i]:
            continue
        dom = np.all(F <= F[i], axis=1) & np.any(F < F[i], axis=1)
        if dom.any():
            keep[i] = False
            continue
        same = np.all(F == F[i], axis=1)
        same[: i + 1] = False
        keep[same] = False
    return keep


def dominates_by(F: np.ndarray, f_ref: np.ndarray, margin: float) -> np.ndarray:
    """Rows of F better than ``f_ref`` by more than ``margin`` (relative) in *every*
    objective: F_ij < f_ref_j (1 − margin) for all j (positive objectives)."""
    F = np.asarray(F, dtype=float)
    return np.all(F < np.asarray(f_ref, float) * (1.0 - margin), axis=1)


def hypervolume(F: np.ndarray, reference: np.ndarray) -> float:
    """Hypervolume (exact, pymoo) of points F w.r.t. a reference point; points not
    strictly better than the reference in every objective contribute nothing."""
    from pymoo.indicators.hv import HV
    F = np.asarray(F, dtype=float)
    ref = np.asarray(reference, dtype=float)
    inside = np.all(F < ref, axis=1)
    if not inside.any():
        return 0.0
    return float(HV(ref_point=ref)(F[inside]))


def pick_preferred(F: np.ndarray, method: str = "knee",
                   weights: Sequence[float] | None = None) -> int:
    """Index of the preferred point of a front (minimisation).

    The front is first normalised to [0, 1] per objective (its own ideal and nadir).

    ``knee``
        The point farthest below the hyperplane through the front's extreme points
        (Das 1999 / Deb & Gupta 2011); when that plane is degenerate, the
        compromise point.
    ``compromise``
        The point nearest (Euclidean) to the ideal point.
    ``preference``
        The point minimising the weighted Chebyshev distance max_j w_j f̃_j
        (``weights`` required, one per objective).
    """
    F = np.asarray(F, dtype=float)
    if F.ndim != 2 or F.shape[0] == 0:
        raise ValueError("pick_preferred: empty front")
    lo, hi = F.min(axis=0), F.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    Fn = (F - lo) / span
    if method == "compromise":
        return int(np.argmin(np.linalg.norm(Fn, axis=1)))
    if method == "preference":
        if weights is None or len(weights) != F.shape[1]:
            raise ValueError(f"pick_preferred: 'preference' needs {F.shape[1]} weights")
        wv = np.asarray(weights, dtype=float)
        if np.any(wv < 0) or not np.any(wv > 0):
            raise ValueError("pick_preferred: weights must be >= 0 and not all 0")
        return int(np.argmin(np.max(Fn * wv, axis=1)))
    if method == "knee":
        m = F.shape[1]
        ext = np.array([np.argmin(F[:, j]) for j in range(m)])
        E = Fn[ext]
        try:
            # hyperplane a·f = 1 through the extreme points
            a = np.linalg.solve(E, np.ones(m))
            if not np.all(np.isfinite(a)) or np.linalg.cond(E) > 1e10:
                raise np.linalg.LinAlgError
        except np.linalg.LinAlgError:
            return int(np.argmin(np.linalg.norm(Fn, axis=1)))
        dist = (1.0 - Fn @ a) / np.linalg.norm(a)
        return int(np.argmax(dist))
    raise ValueError(f"pick_preferred: unknown method '{method}' (valid: knee, compromise, "
                     f"preference)")


# --------------------------------------------------------------------------- NSGA-II
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

    def rows(self) -> list[dict[str, float]]:
        """One dict per front point: design variables then objectives."""
        out = []
        for i in range(self.F.shape[0]):
            row = {k: float(v[i]) for k, v in self.designs.items()}
            row.update({k: float(self.F[i, j]) for j, k in enumerate(self.objective_names)})
            out.append(row)
        return out

    def to_csv_text(self) -> str:
        """``pareto.csv`` text: one row per non-dominated design, full precision."""
        rows = self.rows()
        cols = list(rows[0]) if rows else list(self.designs) + list(self.objective_names)
        lines = [",".join(cols)]
        lines += [",".join(repr(r[c]) for c in cols) for r in rows]
        return "\n".join(lines) + "\n"

    def plot(self, **kw: Any) -> Any:
        from .plots.design import pareto_projections
        return pareto_projections(self, **kw)


def _atomic_write_bytes(path: Path, data: bytes) -> None:
    from .reproduce import atomic_write_bytes
    atomic_write_bytes(path, data)


def _front(algorithm: Any) -> tuple[np.ndarray, np.ndarray]:
    opt = algorithm.opt
    X, F = opt.get("X"), opt.get("F")
    keep = non_dominated(F)
    X, F = X[keep], F[keep]
    order = np.lexsort(F.T[::-1])
    return X[order], F[order]


def run_nsga2(problem: DesignProblem, *, pop_size: int = 40, n_gen: int = 25, seed: int = 1,
              checkpoint: str | Path | None = None, resume: str | Path | None = None,
              stop_after: int | None = None, hv_scale: Sequence[float] | None = None,
              hv_reference: Sequence[float] | None = None, pick: str = "knee",
              pick_weights: Sequence[float] | None = None,
              progress: Callable[[int, int], None] | None = None) -> ParetoResult:
    """Seeded NSGA-II on ``problem`` with per-generation hypervolume and checkpoints.

    Parameters
    ----------
    pop_size, n_gen, seed : int
        Population, total generations, seed (same seed → same front).
    checkpoint : path, optional
        Directory; after every generation the whole algorithm (population,
        random generator, history) is pickled to ``algorithm.pkl`` atomically.
    resume : path, optional
        Continue from the checkpoint in this directory up to ``n_gen`` (the
        problem must match; its fingerprint is checked). Checkpoints go on to
        ``checkpoint`` or, if not given, back into ``resume``.
    stop_after : int, optional
        Stop after this many generations (as if interrupted), checkpoint kept.
    hv_scale, hv_reference : sequences, optional
        Hypervolume of F / hv_scale against hv_reference (defaults 1 and 2).
    pick : str
        'knee', 'compromise' or 'preference' (see :func:`pick_preferred`), made
        among the front points inside the hypervolume box (all if none is).
    """
    from pymoo.algorithms.moo.nsga2 import NSGA2
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
    resumed_from = 0
    if resume is not None:
        rdir = Path(resume)
        f = rdir / "algorithm.pkl"
        if not f.is_file():
            raise ParameterError(f"--resume {rdir}: no checkpoint (algorithm.pkl) there; "
                                 f"run with --checkpoint {rdir} first")
        state = pickle.loads(f.read_bytes())
        if state.get("fingerprint") != fp:
            raise ParameterError(f"--resume {rdir}: the checkpoint belongs to a different "
                                 f"problem (box, vehicle, road or objectives changed); start "
                                 f"a new run")
        if state.get("pop_size") != pop_size or state.get("seed") != seed:
            raise ParameterError(
                f"--resume {rdir}: checkpoint was made with pop {state.get('pop_size')} and "
                f"seed {state.get('seed')}; pass the same --pop and --seed")
        algorithm = state["algorithm"]
        algorithm.problem = problem  # same fingerprint; use this process's evaluator
        history = state["history"]
        archive = state["archive"]
        resumed_from = len(history)
        if resumed_from > n_gen:
            raise ParameterError(f"--resume {rdir}: checkpoint already has {resumed_from} "
                                 f"generations > --gens {n_gen}")
        ck = Path(checkpoint) if checkpoint is not None else rdir
    else:
        algorithm = NSGA2(pop_size=pop_size, seed=seed, eliminate_duplicates=True)
        algorithm.setup(problem, termination=("n_gen", n_gen), verbose=False)
        history = []
        archive = np.zeros((0, m))
        ck = Path(checkpoint) if checkpoint is not None else None
    algorithm.termination = get_termination("n_gen", n_gen)
    interrupted = False
    while len(history) < n_gen:
        # Algorithm.next() spelled out, to see the evaluated infills (archive)
        infills = algorithm.infill()
        if infills is not None:
            algorithm.evaluator.eval(algorithm.problem, infills, algorithm=algorithm)
            algorithm.advance(infills=infills)
            Fa = np.vstack([archive, infills.get("F")]) if archive.size else infills.get("F")
            archive = Fa[non_dominated(Fa)]
        else:
            algorithm.advance()
        _, F = _front(algorithm)
        history.append({"gen": len(history) + 1, "n_eval": int(algorithm.evaluator.n_eval),
                        "hv": hypervolume(F / scale, ref), "n_front": int(F.shape[0]),
                        "hv_archive": hypervolume(archive / scale, ref),
                        "n_archive": int(archive.shape[0])})
        if ck is not None:
            blob = pickle.dumps({"algorithm": algorithm, "history": history, "fingerprint": fp,
                                 "pop_size": pop_size, "seed": seed, "archive": archive})
            _atomic_write_bytes(ck / "algorithm.pkl", blob)
        if progress is not None:
            progress(len(history), n_gen)
        if stop_after is not None and len(history) >= stop_after and len(history) < n_gen:
            interrupted = True
            break
    X, F = _front(algorithm)
    # pick among the points inside the hypervolume box (F/scale < reference): the
    # front's far tails (e.g. 1/ρ_g in the thousands) would otherwise set the
    # normalisation; all points when none is inside
    inside = np.all(F / scale < ref, axis=1)
    cand = np.flatnonzero(inside) if inside.any() else np.arange(F.shape[0])
    idx = int(cand[pick_preferred(F[cand] / scale, pick, pick_weights)])
    msg = (f"stopped after {len(history)} of {n_gen} generations (resume with --resume)"
           if interrupted else f"{len(history)} generations, {F.shape[0]} non-dominated designs")
    return ParetoResult(
        success=not interrupted, message=msg, X=X, designs=problem.space.from_unit(X), F=F,
        objective_names=problem.objective_names, preferred=idx, pick=pick, history=history,
        hv_scale=scale, hv_reference=ref,
        stats={"n_eval": int(algorithm.evaluator.n_eval), "seconds": time.perf_counter() - t0,
               "resumed_from": resumed_from, "generations": len(history)})
