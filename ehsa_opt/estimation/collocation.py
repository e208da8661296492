"""Transcriptions of the estimation core (:mod:`ehsa_opt.estimation.core`).

Each test of a fit is a :class:`Block`: a structure key (what the NLP's shape
depends on) and a flat data vector (what only its numbers depend on: motions,
node spacings, interpolation weights, measured signals, weights, base parameters,
state scales).  :func:`build_block_symbols` makes the symbolic counterpart of a
key, so one built NLP takes the data of any block with the same key.

Transcriptions: ``radau`` (Radau collocation of degree d on decimated sample
nodes), ``theta`` (one-step rule on the sample grid), ``given`` (states
integrated beforehand by :func:`integrate_states`, when no state depends on a
varied parameter).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import casadi as ca
import numpy as np

from ..physics.bench_model import BRISTLE_STATE, BenchModel

__all__ = ["Block", "radau_block", "theta_block", "given_block", "build_block_symbols",
           "model_key", "states_depend_on", "integrate_states", "state_map", "radau_tableau",
           "node_indices", "reversal_indices", "PRESLIDING_SCALE_N", "PRESLIDING_WINDOW_M"]


#: Scale of the LuGre bristle force in the NLP, N: a ball screw's Coulomb level (tens of N),
#: so the scaled state is O(1) whatever σ₀.
PRESLIDING_SCALE_N = 30.0


def model_key(model: BenchModel) -> tuple:
    """Hashable identity of a bench model by value (harvester, components, rig kind)."""
    comps = tuple((type(c).__name__, tuple(sorted((k, repr(v)) for k, v in vars(c).items())))
                  for c in model.components)
    return (model.generator, model.harvester, comps, model.friction_law)


def states_depend_on(model: BenchModel, names: Sequence[str]) -> bool:
    """True if the state equations depend on any of the parameters ``names`` (e.g. a
    state driven by friction: backlash, compliance).  False on a rigid bench, where
    the winding current depends only on the prescribed motion and the load."""
    if model.n_states == 0:
        return False
    x = ca.SX.sym("x", model.n_states)
    u = ca.SX.sym("u", 3)
    p = ca.SX.sym("p", len(model.param_names))
    f = model.ode(x, u, p)
    idx = [model.param_names.index(n) for n in names]
    return any(ca.depends_on(f, p[i]) for i in idx)


#: Rod travel on each side of a velocity reversal (m) over which a model with a bristle
#: state gets a collocation node (and an observation) at every sample: three presliding
#: lengths F_C/σ₀ of a 100 N contact at 1e6 N/m.  Between reversals the bristle sits on
#: its slow manifold z = s(v)/σ₀, which the L-stable Radau polynomials follow on the
#: coarse grid; the fast transient after a reversal needs the samples themselves.
PRESLIDING_WINDOW_M = 3e-4


def reversal_indices(x: np.ndarray, v: np.ndarray, window_m: float, at_most: int) -> np.ndarray:
    """Sample indices within ``window_m`` of rod travel of a velocity reversal (before or
    after it), at most ``at_most`` of them (uniformly thinned beyond).

    Parameters
    ----------
    x, v : ndarray
        Rod displacement (m) and velocity (m/s) on the samples.
    window_m : float
        Travel on each side of a reversal, m.
    at_most : int
        Largest number of indices returned.
    """
    x, v = np.asarray(x, float), np.asarray(v, float)
    rev = np.flatnonzero(np.signbit(v[1:]) != np.signbit(v[:-1])) + 1
    if rev.size == 0 or at_most < 1:
        return np.zeros(0, dtype=int)
    k = np.arange(x.size)
    after = np.searchsorted(rev, k, side="right") - 1     # last reversal at or before k
    before = np.minimum(after + 1, rev.size - 1)          # next reversal after k
    d_prev = np.where(after >= 0, np.abs(x - x[rev[np.maximum(after, 0)]]), np.inf)
    d_next = np.where(rev[before] > k, np.abs(x - x[rev[before]]), np.inf)
    idx = np.flatnonzero(np.minimum(d_prev, d_next) < window_m)
    if idx.size > at_most:
        idx = idx[np.unique(np.round(np.linspace(0, idx.size - 1, at_most)).astype(int))]
    return idx


def node_indices(n: int, max_intervals: int) -> np.ndarray:
    """At most ``max_intervals + 1`` uniformly spread indices of ``n`` samples."""
    if n - 1 <= max_intervals:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_intervals + 1)).astype(int))


def radau_tableau(d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
    """Radau points τ (with 0), derivative matrix C, end weights D, Lagrange basis
    (computed once per degree; copies of the arrays are returned)."""
    tau, C, D, basis = _radau_tableau(int(d))
    return tau.copy(), C.copy(), D.copy(), list(basis)


@functools.lru_cache(maxsize=16)
def _radau_tableau(d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
    tau = np.append(0.0, ca.collocation_points(d, "radau"))
    C = np.zeros((d + 1, d + 1))
    D = np.zeros(d + 1)
    basis = []
    for j in range(d + 1):
        p = np.poly1d([1.0])
        for r in range(d + 1):
            if r != j:
                p *= np.poly1d([1.0, -tau[r]]) / (tau[j] - tau[r])
        D[j] = p(1.0)
        basis.append(p)
        dp = np.polyder(p)
        for r in range(d + 1):
            C[j, r] = dp(tau[r])
    return tau, C, D, basis


def state_map(model: BenchModel, u: np.ndarray, load_ohm: float) -> tuple[np.ndarray, np.ndarray]:
    """Affine scaling X = offset + s ⊙ Z of the states along a motion ``u`` (3 × n).

    Current: its quasi-static amplitude; rotor angle and speed through the
    transmission deflection δ = x − rθ and its rate (θ = x/r − δ/r: δ is
    micrometres while θ is tens of radians, which keeps a stiff contact well
    scaled); the bristle force :data:`PRESLIDING_SCALE_N`; other states 1.
    """
    h = model.harvester
    r = h.lead_m_per_rad
    vmax = float(np.max(np.abs(u[1]))) or 1.0
    s = np.ones(model.n_states)
    off = np.zeros((model.n_states, u.shape[1]))
    for k, n in enumerate(model.state_names):
        if n == "current_A":
            s[k] = h.voltage_constant_Vs_per_rad * vmax / r / (load_ohm
                                                               + h.internal_resistance_ohm)
        elif n == "rotor_angle_rad":
            s[k], off[k] = -1e-4 / r, u[0] / r
        elif n == "rotor_speed_rad_per_s":
            s[k], off[k] = -1e-2 / r, u[1] / r
        elif n == BRISTLE_STATE:
            s[k] = PRESLIDING_SCALE_N
    return s, off


@dataclass
class Block:
    """One test of a fit: structure ``key`` and numbers ``data`` (see module doc)."""

    key: tuple
    data: np.ndarray
    z_guess: np.ndarray
    n_obs: int
    ny: int
    info: dict = field(default_factory=dict)


def _flat(*arrays: Any) -> np.ndarray:
    return np.concatenate([np.atleast_1d(np.asarray(a, float)).ravel(order="F")
                           for a in arrays])


def _quasi_static(model: BenchModel, u: np.ndarray, pbase: np.ndarray) -> np.ndarray:
    if not model.n_states:
        return np.zeros((0, u.shape[1]))
    return np.array([model.initial_state(u[:, k], pbase) for k in range(u.shape[1])]).T


def _radau_pattern(N: int, n_obs: int, d: int, intervals: bytes) -> ca.Sparsity:
    """Interpolation pattern: observation m may read the polynomials of its candidate
    intervals (``intervals``: n_obs × w int64, row m the candidates of m)."""
    cand = np.frombuffer(intervals, dtype=np.int64).reshape(n_obs, -1)
    rows, cols = [], []
    for m, ks in enumerate(cand):
        for k in ks:
            rows += [int(k)] + [(N + 1) + int(k) * d + j for j in range(d)]
            cols += [m] * (d + 1)
    return ca.Sparsity.triplet((N + 1) + d * N, n_obs, rows, cols)


def _candidate_intervals(t_nodes: np.ndarray, t_obs: np.ndarray, k_obs: np.ndarray) -> np.ndarray:
    """Candidate intervals of each observation (n_obs × w), shared by records of any
    length when possible: observations spread uniformly between the fractions f0 and
    f1 (rounded to 1e-3) of the node span lie in interval c_m = ⌊N (f0 + (f1 − f0)
    m/(n_obs − 1))⌋ or the next one, so the pattern {c_m, c_m + 1} depends only on
    (N, n_obs, f0, f1) and one NLP serves tests of different lengths (the unused
    interpolation weights are zero).  Otherwise the exact intervals (w = 1)."""
    N, n_obs = t_nodes.size - 1, t_obs.size
    if N >= 2 and n_obs >= 2:
        span = t_nodes[-1] - t_nodes[0]
        f0 = round(float(t_obs[0] - t_nodes[0]) / span, 3)
        f1 = round(float(t_obs[-1] - t_nodes[0]) / span, 3)
        m = np.arange(n_obs)
        c = np.clip(np.floor(N * (f0 + (f1 - f0) * m / (n_obs - 1))).astype(np.int64), 0, N - 2)
        if np.all((k_obs == c) | (k_obs == c + 1)):
            return np.stack([c, c + 1], axis=1)
    return k_obs.astype(np.int64)[:, None]


def radau_block(model: BenchModel, time_s: np.ndarray, motion: Any, node_idx: np.ndarray,
                obs_idx: np.ndarray, y_obs: np.ndarray, weights: np.ndarray,
                pbase: np.ndarray, degree: int,
                x_guess: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> Block:
    """Radau block: nodes at ``time_s[node_idx]``, observations at ``time_s[obs_idx]``.

    ``x_guess(t, u)`` gives initial states (nx × len(t)); default quasi-static.
    """
    d = degree
    tau, _, _, basis = radau_tableau(d)
    t_nodes = time_s[node_idx]
    N = t_nodes.size - 1
    h = np.diff(t_nodes)
    t_col = (t_nodes[:-1, None] + h[:, None] * tau[None, 1:]).ravel()
    t_obs = time_s[obs_idx]
    n_obs = t_obs.size
    k_obs = np.clip(np.searchsorted(t_nodes, t_obs, side="right") - 1, 0, N - 1)
    intervals = _candidate_intervals(t_nodes, t_obs, k_obs).tobytes()
    sp = _radau_pattern(N, n_obs, d, intervals)
    frac = (t_obs - t_nodes[k_obs]) / h[k_obs]
    dense = np.zeros(((N + 1) + d * N, n_obs))
    for j in range(d + 1):
        rows = k_obs if j == 0 else (N + 1) + k_obs * d + (j - 1)
        dense[rows, np.arange(n_obs)] = basis[j](frac)
    r, c = sp.get_triplet()
    mvals = dense[np.array(r, int), np.array(c, int)]
    u_all = motion.evaluate(np.concatenate([t_nodes, t_col]))
    u_col, u_obs = u_all[:, N + 1:], motion.evaluate(t_obs)
    sx, off = state_map(model, u_all, float(pbase[0]))
    t_all = np.concatenate([t_nodes, t_col])
    X0 = x_guess(t_all, u_all) if x_guess is not None else _quasi_static(model, u_all, pbase)
    Z0 = (X0 - off) / sx[:, None] if model.n_states else np.zeros((0, t_all.size))
    ny = y_obs.shape[0]
    key = ("radau", d, N, n_obs, intervals, ny)
    data = _flat(h, u_col, u_obs, mvals, pbase, y_obs, weights, sx, off)
    return Block(key, data, Z0.ravel(order="F"), n_obs, ny,
                 {"t_nodes": t_nodes, "t_col": t_col, "t_obs": t_obs, "sx": sx, "off": off,
                  "weights": np.asarray(weights, float)})


def theta_block(model: BenchModel, t_fine: np.ndarray, u_fine: np.ndarray, every: int,
                y_obs: np.ndarray, weights: np.ndarray, pbase: np.ndarray,
                x_guess: np.ndarray | None = None) -> Block:
    """One-step block on the grid ``t_fine``; observations at every ``every``-th node."""
    Nf = t_fine.size
    sx, off = state_map(model, u_fine, float(pbase[0]))
    X0 = x_guess if x_guess is not None else _quasi_static(model, u_fine, pbase)
    Z0 = (X0 - off) / sx[:, None] if model.n_states else np.zeros((0, Nf))
    ny, n_obs = y_obs.shape
    if (Nf - 1) % every or (Nf - 1) // every + 1 != n_obs:
        raise ValueError("theta_block: the fine grid must hold every observation")
    key = ("theta", Nf, every, ny)
    W = _weight_matrix(weights, ny, n_obs)
    data = _flat(np.diff(t_fine), u_fine, pbase, y_obs, W, sx, off)
    return Block(key, data, Z0.ravel(order="F"), n_obs, ny,
                 {"sx": sx, "off": off, "weights": W.max(axis=1), "weight_matrix": W})


def _weight_matrix(weights: np.ndarray, ny: int, n_obs: int) -> np.ndarray:
    """Per-sample weights (ny × n_obs) from per-channel (ny,) or per-sample weights (a
    zero leaves a sample out: e.g. a corner the motion's derivatives do not resolve)."""
    w = np.asarray(weights, float)
    if w.ndim == 1:
        w = w[:, None]
    return np.broadcast_to(w, (ny, n_obs)).copy()


def given_block(model: BenchModel, X_obs: np.ndarray, u_obs: np.ndarray, y_obs: np.ndarray,
                weights: np.ndarray, pbase: np.ndarray) -> Block:
    """Block whose states are data (integrated beforehand)."""
    ny, n_obs = y_obs.shape
    key = ("given", n_obs, ny)
    W = _weight_matrix(weights, ny, n_obs)
    return Block(key, _flat(X_obs, u_obs, pbase, y_obs, W), np.zeros(0), n_obs, ny,
                 {"weights": W.max(axis=1), "weight_matrix": W})


def build_block_symbols(model: BenchModel, space: Any, key: tuple, z: Any, sym: Any,
                        sfx: str) -> dict:
    """Symbolic block of ``key``: decision states ``w``, data ``p`` (same layout as the
    block's ``data``), equality defects ``g``, per-channel SSE list, outputs ``y``,
    the positions of the initial states in ``w``."""
    nx, npar = model.n_states, len(space.names)
    kind = key[0]
    parts: list[Any] = []

    def data(name: str, r: int, c: int) -> Any:
        s = sym.sym(name + sfx, r, c)
        parts.append(ca.vec(s))
        return s

    g: list[Any] = []
    x0_cols: list[int] = []
    if kind == "radau":
        _, d, N, n_obs, intervals, ny = key
        ncol = (N + 1) + d * N
        h = data("h", 1, N)
        ucol = data("ucol", 3, d * N)
        uobs = data("uobs", 3, n_obs)
        sp = _radau_pattern(N, n_obs, d, intervals)
        msym = data("m", sp.nnz(), 1)
        pbase = data("pbase", npar, 1)
        ym = data("ym", ny, n_obs)
        wy = data("wy", ny, 1)
        sx = data("sx", nx, 1)
        off = data("off", nx, ncol)
        P, _ = space.expression(z, pbase)
        Z = sym.sym("Z" + sfx, nx, ncol)
        X = off + ca.repmat(sx, 1, ncol) * Z
        _, C, D, _ = radau_tableau(d)
        xk, xc = ca.SX.sym("xk", nx), ca.SX.sym("xc", nx, d)
        uc, ps, hs = ca.SX.sym("uc", 3, d), ca.SX.sym("p", npar), ca.SX.sym("h")
        eqs, xend = [], D[0] * xk
        for j in range(1, d + 1):
            xp = C[0, j] * xk
            for r in range(1, d + 1):
                xp = xp + C[r, j] * xc[:, r - 1]
            eqs.append(hs * model.ode(xc[:, j - 1], uc[:, j - 1], ps) - xp)
            xend = xend + D[j] * xc[:, j - 1]
        interval = ca.Function("interval", [xk, xc, uc, ps, hs], [ca.vertcat(*eqs), xend])
        Xn, Xc = X[:, :N + 1], X[:, N + 1:]
        eq, xe = interval.map(N)(Xn[:, :-1], Xc, ucol, P, h)
        g += [ca.vec(eq / ca.repmat(sx, d, N)), ca.vec((Xn[:, 1:] - xe) / ca.repmat(sx, 1, N))]
        # observed states are unknowns tied to the collocation polynomials by linear
        # equations: the interpolation weights (data) then add no Hessian fill
        X_obs = ca.mtimes(X, sym(sp, msym))
        y = model.outputs.map(n_obs)(X_obs, uobs, P)
        w = ca.vec(Z)
        x0_cols = list(range(nx))
    elif kind == "theta":
        _, Nf, every, ny = key
        n_obs = (Nf - 1) // every + 1
        dt = data("dt", 1, Nf - 1)
        U = data("u", 3, Nf)
        pbase = data("pbase", npar, 1)
        ym = data("ym", ny, n_obs)
        wy = data("wy", ny, n_obs)
        sx = data("sx", nx, 1)
        off = data("off", nx, Nf)
        P, _ = space.expression(z, pbase)
        Z = sym.sym("Z" + sfx, nx, Nf)
        X = off + ca.repmat(sx, 1, Nf) * Z
        f = model.ode.map(Nf)(X, U, P)
        # backward Euler for the stiff states (the winding current, L/R ≪ the step; the
        # bristle force, whose rate σ₀/φ(v) reaches 1e5/s while sliding): it damps their
        # fast mode in one step (the trapezoidal rule rings at a step far beyond their
        # time constant), so the bristle sits on its steady state s(v) after a transient,
        # exactly as the static law in the limit σ₀ → ∞
        wbe = np.array([1.0 if n in ("current_A", BRISTLE_STATE) else 0.5
                        for n in model.state_names])
        Wbe = ca.DM(np.tile(wbe[:, None], (1, Nf - 1)))
        incr = (Wbe * f[:, 1:] + (1 - Wbe) * f[:, :-1]) * ca.repmat(dt, nx, 1)
        g.append(ca.vec((X[:, 1:] - X[:, :-1] - incr) / ca.repmat(sx, 1, Nf - 1)))
        sel = list(range(0, Nf, every))
        y = model.outputs.map(n_obs)(X[:, sel], U[:, sel], P)
        w = ca.vec(Z)
        x0_cols = list(range(nx))
    elif kind == "given":
        _, n_obs, ny = key
        Xg = data("X", nx, n_obs)
        uobs = data("uobs", 3, n_obs)
        pbase = data("pbase", npar, 1)
        ym = data("ym", ny, n_obs)
        wy = data("wy", ny, n_obs)
        P, _ = space.expression(z, pbase)
        y = model.outputs.map(n_obs)(Xg, uobs, P)
        w = sym(0, 1)
    else:
        raise ValueError(f"unknown transcription {kind!r}")
    y = y[:ny, :]
    sse = [ca.sumsqr(wy[k, :] * (y[k, :] - ym[k, :])) for k in range(ny)]
    return {"w": w, "p": ca.vertcat(*parts), "g": ca.vertcat(*g) if g else sym(0, 1),
            "sse": sse, "n_obs": n_obs, "y": y, "x0_cols": x0_cols}


# ====================================================================== integration
_STEPPERS: dict[tuple, ca.Function] = {}


def _stepper(model: BenchModel, n_steps: int, d: int = 3, newton: int = 4) -> ca.Function:
    key = (model_key(model), n_steps, d, newton)
    if key in _STEPPERS:
        return _STEPPERS[key]
    F = _step(model, d, newton).mapaccum(n_steps)
    if len(_STEPPERS) > 64:
        _STEPPERS.pop(next(iter(_STEPPERS)))
    _STEPPERS[key] = F
    return F


def _step(model: BenchModel, d: int, newton: int) -> ca.Function:
    """One Radau IIA step (Newton on the stage equations), built once per model."""
    key = (model_key(model), "step", d, newton)
    if key in _STEPPERS:
        return _STEPPERS[key]
    nx, npar = model.n_states, len(model.param_names)
    _, C, D, _ = radau_tableau(d)
    xk, uc, p, h = ca.SX.sym("xk", nx), ca.SX.sym("uc", 3, d), ca.SX.sym("p", npar), \
        ca.SX.sym("h")
    xc = ca.SX.sym("xc", nx, d)
    res = []
    for j in range(1, d + 1):
        xp = C[0, j] * xk
        for r in range(1, d + 1):
            xp = xp + C[r, j] * xc[:, r - 1]
        res.append(h * model.ode(xc[:, j - 1], uc[:, j - 1], p) - xp)
    G = ca.vertcat(*res)
    newton_step = ca.Function("newton", [ca.vec(xc), xk, uc, p, h],
                              [ca.vec(xc) - ca.solve(ca.jacobian(G, ca.vec(xc)), G)])
    v = ca.repmat(xk, d, 1)
    for _ in range(newton):
        v = newton_step(v, xk, uc, p, h)
    xend = D[0] * xk + sum(D[j] * v[(j - 1) * nx: j * nx] for j in range(1, d + 1))
    step = ca.Function("radau_step", [xk, uc, p, h], [xend])
    if len(_STEPPERS) > 64:
        _STEPPERS.pop(next(iter(_STEPPERS)))
    _STEPPERS[key] = step
    return step


def integrate_states(model: BenchModel, motion: Any, time_s: np.ndarray, pbase: np.ndarray,
                     x0: np.ndarray | None = None) -> np.ndarray:
    """States (nx × n) on ``time_s`` by fixed-step Radau IIA (order 5, L-stable: the
    stiff winding current stays on its slow manifold) with the sample steps,
    Newton on each step's stage equations; one compiled function per model and
    record length.  Meant for smooth state equations (rigid bench: the current)."""
    n, nx = time_s.size, model.n_states
    if nx == 0:
        return np.zeros((0, n))
    tau = radau_tableau(3)[0]
    hs = np.diff(time_s)
    t_col = (time_s[:-1, None] + hs[:, None] * tau[None, 1:]).ravel()
    uc = motion.evaluate(t_col)
    if x0 is None:
        x0 = model.initial_state(motion.evaluate(time_s[:1])[:, 0], pbase)
    F = _stepper(model, n - 1)
    xs = np.array(F(x0, uc, np.tile(np.asarray(pbase, float)[:, None], (1, n - 1)), hs[None, :]))
    return np.hstack([np.reshape(x0, (nx, 1)), xs.reshape(nx, n - 1)])
