"""Fixed-step discrete map of the bench: the 3-stage Radau IIA rule (order 5, L-stable,
stiffly accurate) on sub-steps aligned with the sample grid, compiled once per model.

:func:`~ehsa_opt.physics.bench_sim.simulate_bench` (CVODES, variable order and step) is
the reference.  Its step control pays for the kinks that a recorded motion's
interpolated derivatives have at every sample (about ten steps and one error-test
failure per sample on a multisine), and each call re-enters the interpreter of an MX
graph.  Here every sub-step lies inside one sample interval (the motion is smooth there),
the stage equations are solved by a fixed number of Newton iterations written out
symbolically (SX, so the map can be compiled to C when a compiler is present and is
differentiable exactly), and one ``mapaccum`` call runs the whole record.

* The electrical state (L/R ≈ 0.15 ms against a 1 ms sample step) is stiff: the rule is
  L-stable, so it needs no sub-steps.
* With an elastic transmission the rotor speed is a state that crosses zero through the
  bearing friction's steep transition: at least :data:`TRANSMISSION_MIN_SUBSTEPS`.
* An oscillatory mode (a stiff mount spring on the rotor inertia) must be resolved:
  :func:`substeps_for` chooses sub-steps so that the largest imaginary part of the
  ODE Jacobian's eigenvalues (at the rest-consistent states along the record) times the
  sub-step is at most :data:`OSCILLATION_STEP`.
* Not for non-smooth contacts (a gap closed by a stiff contact): events inside a step
  break the order of any fixed-step rule; those stay on CVODES.

Accuracy (tested in ``tests/physics/test_bench_map.py`` against CVODES at rtol 1e-10 on
recorded and sine motions: the rigid rig, a 5e5 and a 1e9 N/m mount compliance, cogging):
the noise-normalised rms difference is below 0.02 (0.1 on the 1e9 N/m mount, where CVODES
at rtol 1e-7, the discrepancy fits' default, is itself 0.5 off).
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from ..utils.jit_cache import compiled
from .bench_model import BenchModel
from .motion import FilteredMotion, SampledMotion, SineMotion

__all__ = ["RADAU_A", "RADAU_C", "NEWTON_ITERATIONS", "OSCILLATION_STEP", "MAX_SUBSTEPS",
           "TRANSMISSION_MIN_SUBSTEPS", "FOLD_SUBSTEPS",
           "simulate_map", "simulate_map_sensitivity", "substeps_for", "stage_inputs"]

_S6 = math.sqrt(6.0)
#: Radau IIA (3 stages) nodes and coefficients.
RADAU_C = np.array([(4 - _S6) / 10, (4 + _S6) / 10, 1.0])
RADAU_A = np.array([[(88 - 7 * _S6) / 360, (296 - 169 * _S6) / 1800, (-2 + 3 * _S6) / 225],
                    [(296 + 169 * _S6) / 1800, (88 + 7 * _S6) / 360, (-2 - 3 * _S6) / 225],
                    [(16 - _S6) / 36, (16 + _S6) / 36, 1.0 / 9.0]])
#: Newton iterations on the stage equations, from the explicit guess (3 and 5 give the
#: same samples to 1e-9 of the noise on the tuning campaign; *simplified* Newton, the
#: Jacobian kept from the guess, halves the instructions but moved the compliance fit's
#: damping by 7 % on the tuning campaign: not used).
NEWTON_ITERATIONS = 3
#: Largest |Im λ| × sub-step (rad) for an oscillatory mode: 0.3 keeps the order-5 rule's
#: error on a 700 Hz mount mode below 0.01 of the noise.
OSCILLATION_STEP = 0.3
#: At least this many sub-steps with an elastic transmission: the rotor speed then
#: crosses zero through the bearing friction's steep transition on its own time (one
#: sub-step: 0.09 of the voltage noise on the prototype rig at a reversal; two: 0.005).
TRANSMISSION_MIN_SUBSTEPS = 2
#: At most this many sub-steps per sample interval.
MAX_SUBSTEPS = 64
#: False: one accumulation over every sub-step of the record, the states at the
#: samples picked from it afterwards (the reference path, for benchmarks; the same
#: numbers, m times the states leaving the compiled loop).
FOLD_SUBSTEPS = True


def _compiled(F: ca.Function, level: str = "-O2") -> ca.Function:
    """``F`` compiled to C when a compiler is on the PATH (about 2 s once per model, then
    loaded from the per-user cache, :mod:`ehsa_opt.utils.jit_cache`; ten to fifty times
    faster than the SX interpreter); else ``F`` itself, interpreted.  ``level``: the C
    compiler's optimisation flag (the sensitivity sub-step of the compliance rig: about
    1.4 s to compile at -O0, 4 s at -O2, but one sensitivity run of 8 tests, 10 198
    samples, 1.05 s against 0.39 s: -O2 for both)."""
    return compiled(F, (level,)) or F


def _substep_function(model: BenchModel) -> ca.Function:
    """(x, U (3 × 3: the inputs at the three stage times), p, h) → x after one Radau IIA
    sub-step of length h (cached on the model)."""
    cache: dict = model.__dict__.setdefault("_map_cache", {})
    if "substep" in cache:
        return cache["substep"]
    nx, npar = model.n_states, len(model.param_names)
    x, p, h = ca.SX.sym("x", nx), ca.SX.sym("p", npar), ca.SX.sym("h")
    U = ca.SX.sym("U", 3, 3)
    K = ca.SX.sym("K", nx, 3)

    def residual(Kv: Any) -> Any:
        Km = ca.reshape(Kv, nx, 3)
        rows = [Km[:, i] - model.ode(x + h * sum(RADAU_A[i, j] * Km[:, j] for j in range(3)),
                                     U[:, i], p) for i in range(3)]
        return ca.vertcat(*rows)

    res = ca.Function("radau_res", [ca.vec(K), x, p, h, U], [residual(ca.vec(K))])
    jac = ca.Function("radau_jac", [ca.vec(K), x, p, h, U],
                      [ca.jacobian(residual(ca.vec(K)), ca.vec(K))])
    Kv = ca.vertcat(*[model.ode(x, U[:, i], p) for i in range(3)])  # explicit guess
    for _ in range(NEWTON_ITERATIONS):
        Kv = Kv - ca.solve(jac(Kv, x, p, h, U), res(Kv, x, p, h, U))
    xn = x + h * (ca.reshape(Kv, nx, 3) @ ca.DM(RADAU_A[2, :]))  # stiffly accurate
    cache["substep_expr"] = (x, U, p, h, K, residual(ca.vec(K)), Kv, xn)
    xn = ca.cse(xn)  # common subexpressions evaluated once
    F = _compiled(ca.Function("radau_substep", [x, U, p, h], [xn]))
    cache["substep"] = F
    return F


def _sensitivity_substep_function(model: BenchModel) -> ca.Function:
    """([x; vec S], U, p, h) → [x⁺; vec S⁺] with S = ∂x/∂p (n_states × n_params): the
    sub-step of :func:`_substep_function` and its derivative, the stage derivatives
    by the implicit function theorem at the Newton iterate (exact for the converged
    stages; the map's three Newton iterations converge to far below the noise).
    Cached on the model."""
    cache: dict = model.__dict__.setdefault("_map_cache", {})
    if "sens_substep" in cache:
        return cache["sens_substep"]
    _substep_function(model)
    x, U, p, h, K, R, Kv, xn = cache["substep_expr"]
    nx, npar = model.n_states, len(model.param_names)
    S = ca.SX.sym("S", nx, npar)
    # implicit function theorem on the stage equations R(K, x, p) = 0 at the Newton
    # iterate: dK = -(∂R/∂K)⁻¹ (∂R/∂x S + ∂R/∂p); one factorisation for all columns
    # (differentiating through the three written-out Newton solves gives the same to
    # the Newton residual but an expression too large to compile in reasonable time)
    sens = ca.Function("radau_stage_sens", [ca.vec(K), x, p, h, U, S],
                       [-ca.solve(ca.jacobian(R, ca.vec(K)),
                                  ca.jacobian(R, x) @ S + ca.jacobian(R, p))])
    dK = sens(Kv, x, p, h, U, S)                       # (3 nx) × n_params
    Sn = S + h * sum(RADAU_A[2, j] * dK[j * nx:(j + 1) * nx, :] for j in range(3))
    zn = ca.cse(ca.vertcat(xn, ca.vec(Sn)))
    z = ca.vertcat(x, ca.vec(S))
    F = _compiled(ca.Function("radau_substep_sens", [z, U, p, h], [zn]))
    cache["sens_substep"] = F
    return F


def _output_jacobians(model: BenchModel) -> ca.Function:
    """(x, u, p) → (∂y/∂x, ∂y/∂p) of the model's outputs (cached on the model)."""
    cache: dict = model.__dict__.setdefault("_map_cache", {})
    if "out_jac" not in cache:
        x = ca.SX.sym("x", model.n_states)
        u, p = ca.SX.sym("u", 3), ca.SX.sym("p", len(model.param_names))
        y = model.outputs(x, u, p)
        cache["out_jac"] = ca.Function("bench_out_jac", [x, u, p],
                                       [ca.jacobian(y, x), ca.jacobian(y, p)])
    return cache["out_jac"]


def stage_inputs(motion: Any, grid: np.ndarray, substeps: int) -> np.ndarray:
    """The motion (x, v, a) at the three stage times of every sub-step: (3, 3 m (N − 1)),
    the columns in time order.  A sampled motion is its samples' smoothing spline, as in the CVODES simulation (its own x, v = dx/dt, a,
    never linear interpolants: those bend x at every sample, which a stiff mount or
    contact turns into a spurious force); a closed-form motion is evaluated exactly."""
    m = int(substeps)
    frac = ((np.arange(m)[:, None] + RADAU_C[None, :]) / m).ravel()
    ts = (grid[:-1, None] + np.diff(grid)[:, None] * frac[None, :]).ravel()
    if isinstance(motion, FilteredMotion):
        motion = motion.sampled()
    return motion.evaluate(ts)


def substeps_for(model: BenchModel, u: np.ndarray, p: np.ndarray, h: float) -> int:
    """Sub-steps per sample interval ``h`` (s) that resolve the model's oscillatory modes:
    the largest |Im λ| of the ODE Jacobian at the rest-consistent states of the samples
    ``u`` (3 × N; at most 64 of them, spread), times the sub-step, is at most
    :data:`OSCILLATION_STEP`; at most :data:`MAX_SUBSTEPS`."""
    if model.n_states == 0:
        return 1
    cache: dict = model.__dict__.setdefault("_map_cache", {})
    if "jac_x" not in cache:
        x = ca.SX.sym("x", model.n_states)
        uu, pp = ca.SX.sym("u", 3), ca.SX.sym("p", len(model.param_names))
        cache["jac_x"] = ca.Function("ode_jac_x", [x, uu, pp],
                                     [ca.jacobian(model.ode(x, uu, pp), x)])
    jf = cache["jac_x"]
    idx = np.unique(np.linspace(0, u.shape[1] - 1, min(u.shape[1], 64)).astype(int))
    xs = np.column_stack([model.initial_state(u[:, k], p) for k in idx])
    nx = model.n_states
    J = np.array(jf.map(idx.size)(xs, u[:, idx], p))  # nx × (nx · K), blocks side by side
    J = J.reshape(nx, idx.size, nx).transpose(1, 0, 2)
    J = J[np.all(np.isfinite(J), axis=(1, 2))]
    im = float(np.max(np.abs(np.linalg.eigvals(J).imag))) if J.size else 0.0
    lo = TRANSMISSION_MIN_SUBSTEPS if model.transmission is not None else 1
    return int(min(MAX_SUBSTEPS, max(lo, math.ceil(im * h / OSCILLATION_STEP))))


def _record_map(model: BenchModel, kind: str, intervals: int, substeps: int) -> ca.Function:
    """The whole record's map (cached on the model by its size): ``substeps`` sub-steps
    folded into one sample interval (only the state at each sample leaves the compiled
    loop), accumulated over ``intervals`` sample intervals; ``kind`` "state" (the
    sub-step of :func:`_substep_function`) or "sens" (with the sensitivities,
    :func:`_sensitivity_substep_function`).  The same sub-step calls on the same inputs
    in the same order as one accumulation over every sub-step: the same numbers."""
    cache: dict = model.__dict__.setdefault("_map_cache", {})
    key = ("record", kind, intervals, substeps)
    if key not in cache:
        fold_key = ("interval", kind, substeps)
        if fold_key not in cache:
            step = _substep_function(model) if kind == "state" else \
                _sensitivity_substep_function(model)
            cache[fold_key] = step if substeps == 1 else step.fold(substeps)
        cache[key] = cache[fold_key].mapaccum(intervals)
    return cache[key]


def _run_record(model: BenchModel, kind: str, z0: np.ndarray, U: np.ndarray, p: np.ndarray,
                h: float, substeps: int) -> np.ndarray:
    """The states (``kind`` "state") or states and sensitivities ("sens") at the samples
    after the first, from ``z0``: the stage inputs ``U`` (:func:`stage_inputs`),
    ``substeps`` sub-steps of ``h`` (s) per sample interval (:func:`_record_map`, or
    every sub-step accumulated when :data:`FOLD_SUBSTEPS` is False)."""
    intervals = U.shape[1] // (3 * substeps)
    if FOLD_SUBSTEPS:
        return np.array(_record_map(model, kind, intervals, substeps)(z0, U, p, h))
    cache: dict = model.__dict__.setdefault("_map_cache", {})
    key = ("every", kind, intervals * substeps)
    if key not in cache:
        step = _substep_function(model) if kind == "state" else \
            _sensitivity_substep_function(model)
        cache[key] = step.mapaccum(intervals * substeps)
    return np.array(cache[key](z0, U, p, h))[:, substeps - 1::substeps]


def _sample_map(model: BenchModel, kind: str, n: int) -> ca.Function:
    """The model's outputs (``kind`` "outputs") or their Jacobians ("out_jac",
    :func:`_output_jacobians`) mapped over ``n`` samples (cached on the model)."""
    cache: dict = model.__dict__.setdefault("_map_cache", {})
    key = ("samples", kind, n)
    if key not in cache:
        f = model.outputs if kind == "outputs" else _output_jacobians(model)
        cache[key] = f.map(n)
    return cache[key]


def _check_grid(grid: Any) -> tuple[np.ndarray, float]:
    grid = np.asarray(grid, dtype=float)
    if grid.ndim != 1 or grid.size < 2 or np.any(np.diff(grid) <= 0):
        raise ValueError("simulate_map: grid must be 1-D, strictly increasing, >= 2 samples")
    dt = np.diff(grid)
    h = float(np.median(dt))
    if np.max(np.abs(dt - h)) > 1e-6 * h:
        raise ValueError("simulate_map: the grid must be uniform (one sample step)")
    return grid, h


def _samples(motion: Any, grid: np.ndarray) -> tuple[Any, np.ndarray]:
    """The motion as the simulation sees it and its (x, v, a) on the samples."""
    if isinstance(motion, FilteredMotion):
        motion = motion.sampled()
    if isinstance(motion, SampledMotion):  # as the CVODES simulation sees it
        return motion, np.vstack([np.interp(grid, motion.time_s, r)
                                  for r in motion.evaluate(motion.time_s)])
    return motion, motion.evaluate(grid)


def simulate_map_sensitivity(model: BenchModel, motion: Any, p: Any, grid: np.ndarray,
                             substeps: int | None = None
                             ) -> tuple[np.ndarray, np.ndarray]:
    """Outputs (2 × N) on ``grid`` by the Radau IIA map, as :func:`simulate_map`, and
    their exact derivatives with respect to every model parameter (2 × N × n_params,
    in the order of ``model.param_names``): forward sensitivities S = ∂x/∂p carried
    through every sub-step (the derivative of the map itself, differentiated through
    its Newton iterations, so it agrees with finite differences of
    :func:`simulate_map` to their truncation error), from the rest-consistent start,
    whose own dependence on ``p`` is differenced (it is algebraic)."""
    grid, h = _check_grid(grid)
    p = np.asarray(p, dtype=float).ravel()
    motion, uu = _samples(motion, grid)
    npar, nx, N = p.size, model.n_states, grid.size
    if nx == 0:
        y = np.array(model.outputs.map(N)(np.zeros((0, N)), uu, p))
        _, dyp = _output_jacobians(model).map(N)(np.zeros((0, N)), uu, p)
        return y, np.array(dyp).reshape(2, N, npar)
    x0 = model.initial_state(uu[:, 0], p)
    S0 = np.zeros((nx, npar))
    for j in range(npar):  # the rest-consistent start (algebraic in p)
        dp = 1e-7 * max(abs(p[j]), 1.0)
        pj = p.copy()
        pj[j] += dp
        S0[:, j] = (model.initial_state(uu[:, 0], pj) - x0) / dp
    m = int(substeps) if substeps else substeps_for(model, uu, p, h)
    z0 = np.concatenate([x0, S0.ravel(order="F")])
    Zs = _run_record(model, "sens", z0, stage_inputs(motion, grid, m), p, h / m, m)
    Z = np.hstack([z0[:, None], Zs])
    X = Z[:nx]
    S = Z[nx:].reshape(nx, npar, N, order="F")  # S[:, :, k] = ∂x_k/∂p
    y = np.array(_sample_map(model, "outputs", N)(X, uu, p))
    dyx, dyp = _sample_map(model, "out_jac", N)(X, uu, p)
    dyx = np.array(dyx).reshape(2, N, nx).transpose(0, 2, 1)   # 2 × nx × N
    dyp = np.array(dyp).reshape(2, N, npar)                     # 2 × N × np
    dy = dyp + np.einsum("ikn,kjn->inj", dyx, S)
    return y, dy


def simulate_map(model: BenchModel, motion: Any, p: Any, grid: np.ndarray,
                 substeps: int | None = None, x0: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Outputs (2 × N: force N, voltage V) and states (n_states × N) on ``grid`` (s,
    uniform) by the Radau IIA map, ``substeps`` per sample (default :func:`substeps_for`).
    """
    grid, h = _check_grid(grid)
    p = np.asarray(p, dtype=float).ravel()
    motion, uu = _samples(motion, grid)
    if x0 is None:
        x0 = model.initial_state(uu[:, 0], p)
    if model.n_states == 0:
        X = np.zeros((0, grid.size))
    else:
        m = int(substeps) if substeps else substeps_for(model, uu, p, h)
        Xs = _run_record(model, "state", np.asarray(x0, float), stage_inputs(motion, grid, m),
                         p, h / m, m)
        X = np.hstack([np.reshape(x0, (-1, 1)), Xs])
    y = np.array(_sample_map(model, "outputs", grid.size)(X, uu, p))
    return y, X
