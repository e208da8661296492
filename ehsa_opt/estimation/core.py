"""The estimation core: one collocation NLP for every fit of a bench model.

A :class:`~ehsa_opt.physics.bench_model.BenchModel` (any components), prescribed
motions and measured signals become one NLP in scaled parameters ``z = p / scale``
and scaled states ``X = offset + s ⊙ Z``, solved by IPOPT.  Two objectives share it:

``minimax``
    The paper's Eq 5 in epigraph form (identification):
    ``min c·(t + w·mean_k e_k)`` s.t. ``e_k = J_k``, ``e_k ≤ t``, J_k the mean
    squared normalised residual of signal k of each test (the channel values e_k
    are variables so that the objective is linear and J is evaluated once per point).
``likelihood``
    Gaussian likelihood (discrepancy fits): ``min Σ((y − y_m)/σ)² / n + ρ‖z − z_ref‖²``.

and three transcriptions of each test's dynamics:

``radau``
    Radau collocation of degree d on (decimated) sample nodes; observations
    anywhere in the intervals through the collocation polynomials.
``theta``
    One-step rule on the sample grid (``substeps`` sub-intervals per sample):
    backward Euler for the stiff winding current, trapezoidal for the rest.
``given``
    States integrated beforehand (they do not depend on any varied parameter,
    see :func:`states_depend_on`): the NLP has the parameters only.

**Built once per structure**: everything measured (motions, node spacings,
interpolation weights, measured signals, loads, weights, state scales) is an NLP
*parameter* (``p`` of ``nlpsol``), so one solver serves every test (or group of
tests) of the same structure — same model, transcription, objective, node and
observation counts.  Solvers are cached per process (:func:`build`); they are not
picklable, so a process pool builds one per worker.  :data:`BUILD_COUNT` counts
the builds.

The Gauss–Newton sensitivities of the outputs with the states eliminated through
the collocation equations (:meth:`NLP.sensitivities`) serve both the Fisher
identifiability analysis and the discrepancy covariance.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import casadi as ca
import numpy as np

from ..physics.bench_model import BenchModel
from .hessians import given_hessian as _given_hessian
from .hessians import theta_hessian as _theta_hessian
from .collocation import (
    Block,
    build_block_symbols,
    model_key,
    states_depend_on,
)

__all__ = ["ParamSpace", "Objective", "NLP", "build", "solve_starts", "BUILD_COUNT",
           "build_count", "model_key", "states_depend_on", "SolveRecord"]

#: ``theta`` NLPs get their Lagrangian Hessian assembled node by node
#: (:func:`_theta_hessian`), minimax ``given`` NLPs sample by sample
#: (:func:`_given_hessian`); False: CasADi differentiates the whole NLP graph (the
#: reference, quadratic in the samples: kept for the build-speed benchmark and the
#: tests that compare the two).
STRUCTURED_HESSIAN = True

#: Number of NLPs (IPOPT solvers) built in this process, by transcription kind.
BUILD_COUNT: dict[str, int] = {}


def build_count() -> int:
    """Total number of NLP solvers built in this process."""
    return sum(BUILD_COUNT.values())


# ====================================================================== parameters
@dataclass(frozen=True)
class ParamSpace:
    """Which model parameters vary, their bounds and scales, ties and order constraints.

    Attributes
    ----------
    names : tuple of str
        The model's parameter names (``BenchModel.param_names``).
    free : tuple of str
        Decision parameters, in the order of ``z``.
    lower, upper, scale : tuple of float
        Bounds and scales of the free parameters (physical units); ``z = p / scale``.
    ties : tuple of (str, str)
        ``(name, other)``: parameter ``name`` equals parameter ``other``.
    order : tuple of (str, str)
        ``(a, b)``: constraint ``a ≥ b`` (e.g. breakaway ≥ Coulomb), added when
        ``a`` or ``b`` varies.
    """

    names: tuple[str, ...]
    free: tuple[str, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    scale: tuple[float, ...]
    ties: tuple[tuple[str, str], ...] = ()
    order: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        unknown = [n for n in self.free if n not in self.names]
        if unknown:
            raise ValueError(f"ParamSpace: cannot vary unknown parameter(s) "
                             f"{', '.join(unknown)} (known: {', '.join(self.names)})")
        for n, other in self.ties:
            if n not in self.names or other not in self.names:
                raise ValueError(f"ParamSpace: tie '{n}' = '{other}' names an unknown "
                                 "parameter")
            if n in self.free:
                raise ValueError(f"ParamSpace: '{n}' is both free and tied")
        if not (len(self.lower) == len(self.upper) == len(self.scale) == len(self.free)):
            raise ValueError("ParamSpace: lower/upper/scale need one entry per free name")

    @property
    def nv(self) -> int:
        return len(self.free)

    @property
    def active_order(self) -> tuple[tuple[str, str], ...]:
        return tuple((a, b) for a, b in self.order if a in self.free or b in self.free)

    def expression(self, z: Any, pbase: Any) -> Any:
        """Model parameter vector: free entries ``scale·z``, tied entries their
        target's, the rest from ``pbase`` (a per-test NLP parameter)."""
        ex: dict[str, Any] = {n: pbase[k] for k, n in enumerate(self.names)}
        for k, n in enumerate(self.free):
            ex[n] = self.scale[k] * z[k]
        for n, other in self.ties:
            ex[n] = ex[other]
        return ca.vertcat(*[ex[n] for n in self.names]), ex

    def z_of(self, values: Mapping[str, float]) -> np.ndarray:
        z = np.array([float(values[n]) / s for n, s in zip(self.free, self.scale)])
        return np.clip(z, self.lbz, self.ubz)

    @property
    def lbz(self) -> np.ndarray:
        return np.array(self.lower) / np.array(self.scale)

    @property
    def ubz(self) -> np.ndarray:
        return np.array(self.upper) / np.array(self.scale)

    def values_of(self, z: np.ndarray, pbase: np.ndarray) -> dict[str, float]:
        """All model parameters (physical) from ``z`` (clipped to the bounds: IPOPT may
        sit 1e-12 outside) and a base vector."""
        z = np.clip(np.asarray(z, float)[:self.nv], self.lbz, self.ubz)
        vals = {n: float(v) for n, v in zip(self.names, pbase)}
        for k, n in enumerate(self.free):
            vals[n] = float(z[k] * self.scale[k])
        for n, other in self.ties:
            vals[n] = vals[other]
        return vals


@dataclass(frozen=True)
class Objective:
    """Objective on the core NLP.

    Attributes
    ----------
    kind : {"minimax", "likelihood"}
    sum_weight : float
        w of the minimax objective ``t + w·mean(J)``.
    scale : float
        Constant factor (minimax; conditioning only).
    regularisation : float
        ρ of the likelihood's pull ``ρ‖z − z_ref‖²``.
    """

    kind: str = "minimax"
    sum_weight: float = 0.1
    scale: float = 100.0
    regularisation: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("minimax", "likelihood"):
            raise ValueError(f"Objective: kind must be 'minimax' or 'likelihood', got "
                             f"{self.kind!r}")


@dataclass(frozen=True)
class SolverSettings:
    """IPOPT settings (iteration limits only: results never depend on CPU speed)."""

    tol: float = 1e-8
    max_iter: int = 500
    acceptable_tol: float | None = None
    record_iterations: bool = False


# ====================================================================== the NLP
class _Recorder(ca.Callback):
    """IPOPT iteration callback storing the decision vector and the constraint values
    of each iteration (the minimax rows J − e give J = g + e without re-evaluation)."""

    def __init__(self, nx: int, ng: int) -> None:
        ca.Callback.__init__(self)
        self.nx, self.ng = nx, ng
        self.rows: list[np.ndarray] = []
        self.g_rows: list[np.ndarray] = []
        self.construct("recorder", {})

    def get_n_in(self) -> int:
        return ca.nlpsol_n_out()

    def get_n_out(self) -> int:
        return 1

    def get_name_in(self, i: int) -> str:
        return ca.nlpsol_out(i)

    def get_name_out(self, i: int) -> str:
        return "ret"

    def get_sparsity_in(self, i: int) -> Any:
        n = ca.nlpsol_out(i)
        if n == "f":
            return ca.Sparsity.scalar()
        if n in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if n in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        return ca.Sparsity(0, 0)

    def eval(self, arg: Any) -> list:
        self.rows.append(np.array(arg[0]).ravel())
        self.g_rows.append(np.array(arg[2]).ravel())
        return [0]


class NLP:
    """A built collocation NLP (one structure); data enter through ``p``.

    Use :func:`build` (cached) rather than the constructor.
    """

    def __init__(self, model: BenchModel, space: ParamSpace, objective: Objective,
                 settings: SolverSettings, kind: str, keys: tuple) -> None:
        self.model, self.space, self.objective, self.settings = model, space, objective, settings
        self.kind, self.keys = kind, keys
        # SX (inlined, fastest to evaluate) for decimated problems; MX (mapped calls,
        # compact) for long sample grids, where inlined Hessians get too large
        n_obs = sum(k[3] if k[0] == "radau" else k[1] for k in keys if k[0] != "theta")
        sym = ca.MX if (kind == "theta" or n_obs > 5000) else ca.SX
        nv = space.nv
        z = sym.sym("z", nv)
        zref = sym.sym("zref", nv)
        w_parts, p_parts, g_eq, sse, nobs, y_all = [z], [zref], [], [], [], []
        self.var_slices: list[tuple[int, int]] = []
        self.x0_cols: list[list[int]] = []
        self.data_sizes: list[int] = []
        offset = nv
        for k, key in enumerate(keys):
            s = build_block_symbols(model, space, key, z, sym, f"_{k}")
            nz = int(s["w"].numel())
            w_parts.append(s["w"])
            p_parts.append(s["p"])
            self.data_sizes.append(int(s["p"].numel()))
            self.var_slices.append((offset, offset + nz))
            self.x0_cols.append([offset + c for c in s["x0_cols"]])
            offset += nz
            g_eq.append(s["g"])
            sse += s["sse"]
            nobs += [s["n_obs"]] * len(s["sse"])
            y_all.append(ca.vec(s["y"].T))
        self.n_vars_no_t = offset
        self.n_eq = sum(int(g.numel()) for g in g_eq)
        g_parts = list(g_eq)
        lbg = [np.zeros(self.n_eq)]
        ubg = [np.zeros(self.n_eq)]
        self.n_channels = len(sse)
        self.channel_obs = np.array(nobs, dtype=float)
        J = ca.vertcat(*[s_ / n for s_, n in zip(sse, nobs)])
        if objective.kind == "minimax":
            # channel values e_k are variables (e_k = J_k, e_k ≤ t): the objective is
            # linear, so IPOPT evaluates the J_k and their gradients once per point
            # (constraints), not again for f and ∇f
            tvar = sym.sym("t")
            evar = sym.sym("e", len(sse))
            w_parts += [tvar, evar]
            self.t_index: int | None = offset
            g_parts += [J - evar, evar - tvar]
            lbg += [np.zeros(len(sse)), np.full(len(sse), -np.inf)]
            ubg += [np.zeros(len(sse)), np.zeros(len(sse))]
            f = objective.scale * (tvar + objective.sum_weight * ca.sum1(evar) / len(sse))
        else:
            self.t_index = None
            f = ca.sum1(ca.vertcat(*sse)) / float(sum(nobs)) \
                + objective.regularisation * ca.sumsqr(z - zref)
        pvec, ex = space.expression(z, ca.DM(np.zeros(len(space.names))))
        for a, b in space.active_order:
            sc = space.scale[space.free.index(a)] if a in space.free else 1.0
            g_parts.append((ex[a] - ex[b]) / sc)
            lbg.append(np.zeros(1))
            ubg.append(np.full(1, np.inf))
        W = ca.vertcat(*w_parts)
        P = ca.vertcat(*p_parts)
        G = ca.vertcat(*g_parts) if g_parts else sym(0, 1)
        self.nw = int(W.numel())
        self.np = int(P.numel())
        self.lbg, self.ubg = np.concatenate(lbg), np.concatenate(ubg)
        self.W, self.P, self.G, self.Geq = W, P, G, ca.vertcat(*g_eq) if g_eq else sym(0, 1)
        self.Y = ca.vertcat(*y_all)
        self.Jfun = ca.Function("J", [W, P], [J])
        self.yfun = ca.Function("y", [W, P], [self.Y])
        self.ssefun = ca.Function("sse", [W, P], [ca.sum1(ca.vertcat(*sse))])
        opts: dict[str, Any] = {"print_time": False}
        ipopt = {"tol": settings.tol, "max_iter": settings.max_iter, "print_level": 0,
                 "sb": "yes", "mu_strategy": "adaptive"}
        if settings.acceptable_tol is not None:
            ipopt["acceptable_tol"] = settings.acceptable_tol
        opts["ipopt"] = ipopt
        self.recorder = _Recorder(self.nw, int(G.numel())) if settings.record_iterations else None
        if self.recorder is not None:
            opts["iteration_callback"] = self.recorder
        if (kind == "given" and objective.kind == "minimax" and sym is ca.SX
                and STRUCTURED_HESSIAN):
            opts["hess_lag"] = _given_hessian(model, space, keys, W, P, self.data_sizes,
                                              self.n_eq, int(G.numel()))
        if kind == "theta" and STRUCTURED_HESSIAN and model.n_states:
            opts["hess_lag"] = _theta_hessian(model, space, objective, keys, W, P,
                                              self.data_sizes, self.n_eq, int(G.numel()),
                                              float(sum(nobs)))
        self.solver = ca.nlpsol(f"core_{kind}", "ipopt", {"x": W, "f": f, "g": G, "p": P}, opts)
        lbw, ubw = np.full(self.nw, -np.inf), np.full(self.nw, np.inf)
        lbw[:nv], ubw[:nv] = space.lbz, space.ubz
        if self.t_index is not None:
            lbw[self.t_index] = 0.0
        self.lbw, self.ubw = lbw, ubw
        self._sens: ca.Function | None = None
        BUILD_COUNT[kind] = BUILD_COUNT.get(kind, 0) + 1

    # -------------------------------------------------------------- data
    def data(self, blocks: Sequence[Block], zref: np.ndarray | None = None) -> np.ndarray:
        """The NLP parameter vector of ``blocks`` (checked against the structure)."""
        if tuple(b.key for b in blocks) != self.keys:
            raise ValueError("NLP.data: blocks do not match the structure this NLP was built for")
        zr = np.zeros(self.space.nv) if zref is None else np.asarray(zref, float)
        return np.concatenate([zr, *[b.data for b in blocks]])

    def initial(self, z0: np.ndarray, blocks: Sequence[Block], p: np.ndarray,
                states: Sequence[np.ndarray] | None = None) -> np.ndarray:
        w0 = np.zeros(self.nw)
        w0[:self.space.nv] = z0
        for k, ((a, b), blk) in enumerate(zip(self.var_slices, blocks)):
            w0[a:b] = blk.z_guess if states is None else states[k]
        if self.t_index is not None:
            J0 = np.array(self.Jfun(w0, p)).ravel()
            w0[self.t_index] = float(np.max(J0))
            w0[self.t_index + 1:self.t_index + 1 + J0.size] = J0
        return w0

    def J_rows(self, rows: Sequence[np.ndarray], p: np.ndarray,
               g_rows: Sequence[np.ndarray] | None = None) -> np.ndarray:
        """Per-channel J at each of ``rows`` (decision vectors), one batched call per 64;
        with the constraint values ``g_rows`` of a minimax NLP (the recorder's), read
        off the epigraph rows J − t instead (no evaluation)."""
        if g_rows is not None and self.t_index is not None and len(g_rows) == len(rows):
            G = np.array(g_rows, float)[:, self.n_eq:self.n_eq + self.n_channels]
            e = np.array(rows, float)[:, self.t_index + 1:self.t_index + 1 + self.n_channels]
            return G + e
        if not hasattr(self, "_Jmap"):
            self._Jmap = self.Jfun.map(64)
        W = np.array(rows, float).T
        n = W.shape[1]
        out = []
        for a in range(0, n, 64):
            blk = W[:, a:a + 64]
            pad = np.hstack([blk, np.repeat(blk[:, -1:], 64 - blk.shape[1], axis=1)])
            out.append(np.array(self._Jmap(pad, p))[:, :blk.shape[1]])
        return np.hstack(out).T

    def states_of(self, w: np.ndarray) -> list[np.ndarray]:
        return [np.array(w[a:b]) for a, b in self.var_slices]

    # -------------------------------------------------------------- solve
    def solve(self, w0: np.ndarray, p: np.ndarray) -> "SolveRecord":
        if self.recorder is not None:
            self.recorder.rows, self.recorder.g_rows = [], []
        t0 = time.perf_counter()
        try:
            sol = self.solver(x0=w0, p=p, lbx=self.lbw, ubx=self.ubw, lbg=self.lbg,
                              ubg=self.ubg)
            st = self.solver.stats()
            ok, status = bool(st.get("success", False)), str(st.get("return_status", "?"))
            w = np.array(sol["x"]).ravel()
            f = float(sol["f"])
            nit = int(st.get("iter_count", -1))
        except RuntimeError as exc:  # evaluation errors
            ok, status, w, f, nit = False, f"error: {exc}", w0.copy(), math.nan, 0
        if not (np.all(np.isfinite(w)) and math.isfinite(f)):
            ok = False
        rows = list(self.recorder.rows) if self.recorder is not None else []
        g_rows = list(self.recorder.g_rows) if rows else None
        return SolveRecord(ok, status, w, f, nit, time.perf_counter() - t0, rows or [w],
                           g_rows)

    # -------------------------------------------------------------- sensitivities
    def sensitivities(self, w: np.ndarray, p: np.ndarray) -> np.ndarray:
        """d(outputs)/d(free parameters [physical units], initial states).

        The states are eliminated through the collocation equations (their
        sensitivity solves the linearised defects); the initial states of each test
        are extra columns after the parameters (nuisance parameters).  Rows: per
        test, per channel, per observation (the order of ``yfun``).
        """
        import scipy.sparse.linalg as spla
        if self._sens is None:
            self._sens = ca.Function("sens", [self.W, self.P],
                                     [ca.jacobian(self.Y, self.W), ca.jacobian(self.Geq, self.W)])
        jy, jg = self._sens(w, p)
        Jy = _csc(jy)
        nv = self.space.nv
        x0 = [c for cols in self.x0_cols for c in cols]
        theta = list(range(nv)) + x0
        states = sorted(set(range(nv, self.n_vars_no_t)) - set(x0))
        if self.n_eq and states:
            Jg = _csc(jg)
            S = spla.splu(Jg[:, states].tocsc()).solve(-Jg[:, theta].toarray())
            dy = Jy[:, theta].toarray() + Jy[:, states] @ S
        else:
            dy = Jy[:, theta].toarray()
        dy[:, :nv] /= np.array(self.space.scale)
        return dy


def _csc(m: Any) -> Any:
    import scipy.sparse as sp
    m = ca.DM(m)
    r, c = m.sparsity().get_triplet()
    return sp.csc_matrix((np.array(m.nonzeros()), (r, c)), shape=m.shape)


@dataclass
class SolveRecord:
    """One IPOPT solve: success (IPOPT success and finite numbers), status, point."""

    success: bool
    status: str
    w: np.ndarray
    objective: float
    iterations: int
    seconds: float
    rows: list = field(default_factory=list)
    g_rows: list | None = None


_CACHE: dict[tuple, NLP] = {}
_CACHE_MAX = 32


def build(model: BenchModel, space: ParamSpace, objective: Objective,
          settings: SolverSettings, blocks: Sequence[Block]) -> NLP:
    """The NLP for ``blocks``' structure (built on first use, then cached per process)."""
    kinds = {b.key[0] for b in blocks}
    if len(kinds) != 1:
        raise ValueError(f"core.build: one transcription per NLP, got {sorted(kinds)}")
    keys = tuple(b.key for b in blocks)
    ck = (model_key(model), space, objective, settings, keys, STRUCTURED_HESSIAN)
    nlp = _CACHE.get(ck)
    if nlp is None:
        if len(_CACHE) >= _CACHE_MAX:
            _CACHE.pop(next(iter(_CACHE)))
        nlp = _CACHE[ck] = NLP(model, space, objective, settings, kinds.pop(), keys)
    return nlp


def solve_starts(nlp: NLP, blocks: Sequence[Block], starts: Sequence[np.ndarray], *,
                 zref: np.ndarray | None = None, warm: bool = False,
                 state_guesses: Sequence[Sequence[np.ndarray]] | None = None
                 ) -> list[SolveRecord]:
    """Solve from every start ``z0`` (scaled parameters).

    ``warm``: the states of the next start begin at the last converged start's
    states (else at each block's guess, or ``state_guesses[k]`` for start k).
    """
    p = nlp.data(blocks, zref)
    out: list[SolveRecord] = []
    last: list[np.ndarray] | None = None
    for k, z0 in enumerate(starts):
        guess = state_guesses[k] if state_guesses is not None else (last if warm else None)
        rec = nlp.solve(nlp.initial(np.asarray(z0, float), blocks, p, guess), p)
        if rec.success:
            last = nlp.states_of(rec.w)
        out.append(rec)
    return out
