"""Least squares on blocks whose states are given: models without a fitted state.

When no state of the model depends on a fitted parameter (a rig without generator,
such as EMPS: force = M a + friction(v) + offset), every block of a fit is a
``given`` block (:func:`~.collocation.given_block`) and the likelihood objective of
the core,

    f(z) = Σ_k Σ_i (w_k (y_k,i(z) − ŷ_k,i))² / N + ρ ‖z − z_ref‖²,

is an ordinary nonlinear least-squares problem in the few scaled parameters z.
It is solved here with :func:`scipy.optimize.least_squares` (trust-region
reflective, bounds on z) on CasADi residual and Jacobian functions built once per
block structure — no ``nlpsol`` (whose symbolic Hessian of a 25 000-sample record
takes ≈ 2 s to build, more than the whole fit here).

A block may carry a linear filter of the model's output (``block.info["output_filter"]``:
a function applying it along the sample axis, rows = samples).  The measured output
of such a block is already filtered (the parallel filtering of a rig without
generator); the model's output is then passed through the same filter, so that the
residual compares consistently filtered sides — the benchmark's IDIM filters every
column of its observation matrix, i.e. the model.  The filter is linear, so the
residual and its Jacobian are filtered in place: with r = w (y − ŷ),
r_H = w (H y − ŷ) = w H(r / w) + w (H ŷ − ŷ).

The core's order constraints (breakaway ≥ Coulomb friction) become bounds by a
linear change of variables (the excess of the breakaway over the Coulomb level,
≥ 0), so the constrained optimum is the one found — on EMPS the constraint is
active (breakaway = Coulomb, no Stribeck hump).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Sequence

import casadi as ca
import numpy as np

from ..physics.bench_model import BenchModel
from .collocation import Block, model_key
from .core import ParamSpace, SolveRecord

__all__ = ["GivenFit", "fit_given"]

_FUNS: dict[tuple, tuple[ca.Function, ca.Function]] = {}
_FUNS_MAX = 32


@dataclass
class GivenFit(SolveRecord):
    """One start of :func:`fit_given`: the core's :class:`~.core.SolveRecord` (success:
    ``least_squares`` met a tolerance at a finite point; status: its message prefixed
    ``least_squares:``; w: the scaled parameters z; objective: f(z) above; iterations:
    residual evaluations; seconds) plus the residuals' statistics.

    Attributes
    ----------
    sse : float
        Σ (w_k (y − ŷ))² without the 1/N and the regularisation.
    jacobian : ndarray (N_res, nv)
        d(weighted residuals)/dz at ``w``.
    residual : ndarray (N_res,)
        The weighted residuals at ``w`` (channel-major per block), for a covariance
        that respects their autocorrelation.
    """

    sse: float = float("nan")
    jacobian: np.ndarray | None = None
    residual: np.ndarray | None = None


def _functions(model: BenchModel, space: ParamSpace, ny: int
               ) -> tuple[ca.Function, ca.Function]:
    """Weighted residuals of one sample, alone and with their z-gradients, in SX (built
    once per model, space and channel count): (z, x, u, pbase, ŷ, w) → r (ny) and
    (z, x, u, pbase, ŷ, w) → (r, dr/dz (ny × nv))."""
    ck = (model_key(model), space, ny)
    fun = _FUNS.get(ck)
    if fun is None:
        z = ca.SX.sym("z", space.nv)
        x = ca.SX.sym("x", model.n_states)
        u = ca.SX.sym("u", 3)
        pbase = ca.SX.sym("pbase", len(space.names))
        ym = ca.SX.sym("ym", ny)
        wy = ca.SX.sym("wy", ny)
        P, _ = space.expression(z, pbase)
        y = model.outputs(x, u, P)[:ny]
        r = wy * (y - ym)
        args = [z, x, u, pbase, ym, wy]
        fun = (ca.Function("given_residual", args, [r]),
               ca.Function("given_residual_jac", args, [r, ca.jacobian(r, z)]))
        if len(_FUNS) >= _FUNS_MAX:
            _FUNS.pop(next(iter(_FUNS)))
        _FUNS[ck] = fun
    return fun


def _unpack(model: BenchModel, space: ParamSpace, block: Block) -> tuple:
    """(X, u, pbase, ŷ, w) of a ``given`` block's data (the layout of ``given_block``)."""
    n, ny, nx, npar = block.n_obs, block.ny, model.n_states, len(space.names)
    d, k = block.data, 0
    X = d[k:k + nx * n].reshape((nx, n), order="F"); k += nx * n
    u = d[k:k + 3 * n].reshape((3, n), order="F"); k += 3 * n
    pb = d[k:k + npar]; k += npar
    ym = d[k:k + ny * n].reshape((ny, n), order="F"); k += ny * n
    return X, u, pb, ym, d[k:k + ny * n].reshape((ny, n), order="F")


def _order_map(space: ParamSpace, pbase: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """z = T q with bounds on q that encode the order pairs (a ≥ b) of ``space``.

    Both varied: q_a = z_a − (s_b/s_a) z_b ∈ [0, ub_a − (s_b/s_a) lb_b] (a's own
    upper bound is then not imposed: friction bounds are far above any fit); one
    member fixed: the other's bound is tightened.  None when a parameter is in
    two pairs (the caller solves the NLP instead).
    """
    nv = space.nv
    T = np.eye(nv)
    lo, hi = space.lbz.copy(), space.ubz.copy()
    idx = {n: k for k, n in enumerate(space.free)}
    vals = {n: float(v) for n, v in zip(space.names, pbase)}
    seen: set[str] = set()
    for a, b in space.active_order:
        if a in seen or b in seen:
            return None
        seen |= {a, b}
        if a in idx and b in idx:
            ia, ib = idx[a], idx[b]
            ratio = space.scale[ib] / space.scale[ia]
            T[ia, ib] = ratio
            lo[ia], hi[ia] = 0.0, space.ubz[ia] - ratio * space.lbz[ib]
        elif a in idx:
            lo[idx[a]] = max(lo[idx[a]], vals[b] / space.scale[idx[a]])
        else:
            hi[idx[b]] = min(hi[idx[b]], vals[a] / space.scale[idx[b]])
    if np.any(lo > hi):
        return None
    return T, lo, hi


def _output_filter(model: BenchModel, space: ParamSpace, block: Block) -> tuple | None:
    """(H, w, w (H ŷ − ŷ)) of a block with ``info["output_filter"]`` (H along axis 0),
    None without; a filter needs every weight > 0 (r / w recovers the model's output)."""
    H = block.info.get("output_filter")
    if H is None:
        return None
    _, _, _, ym, wy = _unpack(model, space, block)
    if not np.all(wy > 0):
        raise ValueError("fit_given: a block with an output filter needs every sample's "
                         "weight > 0 (weighted-out samples cannot be filtered consistently)")
    return H, wy, wy * (H(ym.T).T - ym)


def fit_given(model: BenchModel, space: ParamSpace, blocks: Sequence[Block],
              starts: Sequence[np.ndarray], *, zref: np.ndarray, regularisation: float,
              max_nfev: int = 300) -> list[GivenFit] | None:
    """Fit the scaled parameters z to ``blocks`` (all ``given``) from every start.

    Parameters
    ----------
    model : BenchModel
    space : ParamSpace
        Varied names, bounds and scales (z = value / scale).
    blocks : list of Block
        ``given`` blocks (:func:`~.collocation.given_block`).
    starts : list of ndarray (nv,)
        Scaled start points.
    zref : ndarray (nv,)
        Centre of the regularisation ρ ‖z − z_ref‖².
    regularisation : float
        ρ.
    max_nfev : int
        Residual evaluations per start (an iteration limit, not a time limit).

    Returns
    -------
    list of GivenFit, one per start; None when the space's order pairs cannot be
    posed as bounds (a parameter in two pairs): solve the NLP instead.
    """
    if any(b.key[0] != "given" for b in blocks):
        raise ValueError("fit_given: every block must be a 'given' block (states are data)")
    from scipy.optimize import least_squares
    order = _order_map(space, _unpack(model, space, blocks[0])[2])
    if order is None:
        return None
    T, qlo, qhi = order
    nv = space.nv
    mapped = [([f.map(b.n_obs) for f in _functions(model, space, b.ny)],
               [ca.DM(a) for a in _unpack(model, space, b)]) for b in blocks]  # DM once
    filters = [_output_filter(model, space, b) for b in blocks]
    n_tot = float(sum(b.n_obs * b.ny for b in blocks))
    root_n, root_rho = np.sqrt(n_tot), np.sqrt(regularisation)
    zref = np.asarray(zref, float)
    lb, ub = space.lbz, space.ubz
    cache: dict[bytes, tuple[np.ndarray, np.ndarray | None]] = {}

    def evaluate(z: np.ndarray, with_jac: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residuals (channel-major per block) and, when asked, their
        Jacobian in z (a trial point the trust region rejects needs no Jacobian)."""
        k = z.tobytes()
        if k not in cache or (with_jac and cache[k][1] is None):
            cache.clear()
            rs, js = [], []
            for ((f_r, f_rj), (X, u, pb, ym, wy)), filt in zip(mapped, filters):
                ny, n = ym.shape
                if with_jac:
                    r, j = f_rj(z, X, u, pb, ym, wy)
                    # j: (ny, n·nv), sample i's (ny × nv) block in columns i·nv … i·nv + nv − 1
                    j = np.asarray(j).reshape(ny, n, nv)
                    if filt is not None:
                        H, w, _ = filt
                        j = np.stack([w[c][:, None] * H(j[c] / w[c][:, None])
                                      for c in range(ny)])
                    js.append(j.reshape(-1, nv))
                else:
                    r = f_r(z, X, u, pb, ym, wy)
                r = np.asarray(r).reshape(ny, n)
                if filt is not None:
                    H, w, c0 = filt
                    r = w * H((r / w).T).T + c0
                rs.append(r.ravel())  # (ny, n) row-major: channel by channel
            cache[k] = (np.concatenate(rs), np.vstack(js) if with_jac else None)
        return cache[k]

    def resid(q: np.ndarray) -> np.ndarray:
        z = T @ q
        return np.concatenate([evaluate(z, with_jac=False)[0] / root_n, root_rho * (z - zref)])

    def jac(q: np.ndarray) -> np.ndarray:
        return np.vstack([evaluate(T @ q)[1] @ T / root_n, root_rho * T])

    out = []
    for z0 in starts:
        t0 = time.perf_counter()
        q0 = np.clip(np.linalg.solve(T, np.clip(np.asarray(z0, float), lb, ub)), qlo, qhi)
        sol = least_squares(resid, q0, jac=jac, bounds=(qlo, qhi), method="trf",
                            x_scale=1.0, ftol=1e-12, xtol=1e-12, gtol=1e-10,
                            max_nfev=max_nfev)
        z = np.clip(T @ sol.x, lb, ub)
        r, J = evaluate(z)
        finite = bool(np.all(np.isfinite(z)) and np.isfinite(sol.cost))
        out.append(GivenFit(bool(sol.status > 0 and finite), f"least_squares: {sol.message}",
                            z, float(r @ r / n_tot + regularisation * np.sum((z - zref) ** 2)),
                            int(sol.nfev), time.perf_counter() - t0, sse=float(r @ r),
                            jacobian=J.copy(), residual=np.array(r, copy=True)))
    return out
