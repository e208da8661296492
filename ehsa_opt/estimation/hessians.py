"""Exact Hessians of the Lagrangian of estimation-core NLPs, assembled from small pieces.

CasADi can differentiate a whole NLP graph, but for long sample grids its sparsity
detection and star colouring of the Hessian (whose rows of the parameters are dense)
grow with the square of the samples.  The Lagrangians of the ``given`` and ``theta``
blocks are sums of per-sample (per-node) terms: their Hessians are one small SX Hessian
differentiated once and ``map``-ped over the samples, then assembled.  Used by
:mod:`ehsa_opt.estimation.core` as IPOPT's ``hess_lag``.
"""

from __future__ import annotations

from typing import Any, Sequence

import casadi as ca
import numpy as np

from ..physics.bench_model import BenchModel
from ..utils.jit_cache import compiled

__all__ = ["given_hessian", "theta_hessian", "node_hessian"]


def given_hessian(model: BenchModel, space: Any, keys: Sequence[tuple], W: Any, P: Any,
                   data_sizes: Sequence[int], n_eq: int, ng: int) -> ca.Function:
    """Exact Hessian of the minimax Lagrangian on ``given`` blocks, built per sample.

    The objective is linear and the order constraints are linear, so
    ∇²L = Σ_k λ_k ∇²J_k over the rows J_k − e_k; J_k is a sum over samples, so its
    Hessian is the sum of one small per-sample Hessian (differentiated once,
    mapped over the samples) instead of the differentiation of the whole NLP
    graph: the same values, a fraction of the build time.

    The result is an MX function of its own symbols (shaped as ``W`` and ``P``, which
    may be SX): the mapped per-sample function is called, not inlined, so the build
    does not grow with the samples; the per-sample function is compiled to C through
    the per-user cache (:func:`~ehsa_opt.utils.jit_cache.compiled`; CasADi's virtual
    machine without a C compiler) — the same operations in the same order, the same
    numbers.
    """
    nv, nx, npar = space.nv, model.n_states, len(space.names)
    W, P = ca.MX.sym("x", W.sparsity()), ca.MX.sym("p", P.sparsity())
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", ng)
    z, x, u = ca.SX.sym("z", nv), ca.SX.sym("x", nx), ca.SX.sym("u", 3)
    pb = ca.SX.sym("pb", npar)
    funs: dict[tuple[int, int], ca.Function] = {}
    Hz = ca.MX(nv, nv)
    pos, ch = nv, 0  # P = [zref, block data...]
    for key, size in zip(keys, data_sizes):
        _, n, ny = key
        if (ny, n) not in funs:
            ym, wy, mu = ca.SX.sym("ym", ny), ca.SX.sym("wy", ny), ca.SX.sym("mu", ny)
            Pz, _ = space.expression(z, pb)
            y = model.outputs(x, u, Pz)[:ny]
            # ∇²(μ (w (y − y_m))²) = 2 μ w² (∇y ∇yᵀ + (y − y_m) ∇²y), upper triangle
            h = ca.SX(nv, nv)
            for k in range(ny):
                if ca.depends_on(y[k], z):
                    g = ca.jacobian(y[k], z)
                    hy, _ = ca.hessian(y[k], z)
                    h += 2 * mu[k] * wy[k] ** 2 * (ca.mtimes(g.T, g) + (y[k] - ym[k]) * hy)
            h_fun = ca.Function("given_hess", [z, x, u, pb, ym, wy, mu], [ca.triu(h)],
                                {"cse": True})
            funs[(ny, n)] = (compiled(h_fun) or h_fun).map("hmap", "serial", n, [0, 3, 6],
                                                           [0])
        d = P[pos:pos + size]
        a = 0
        Xg = ca.reshape(d[a:a + nx * n], nx, n)
        a += nx * n
        ug = ca.reshape(d[a:a + 3 * n], 3, n)
        a += 3 * n
        pbase = d[a:a + npar]
        a += npar
        ymg = ca.reshape(d[a:a + ny * n], ny, n)
        a += ny * n
        wyg = ca.reshape(d[a:a + ny * n], ny, n)  # per-sample weights
        mu = lam_g[n_eq + ch:n_eq + ch + ny] / n
        Hz = Hz + funs[(ny, n)](W[:nv], Xg, ug, pbase, ymg, wyg, mu)
        pos += size
        ch += ny
    nw = int(W.numel())
    H = ca.diagcat(Hz, ca.MX(nw - nv, nw - nv))
    return ca.Function("nlp_hess_l", [W, P, lam_f, lam_g], [H],
                       ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])


def theta_hessian(model: BenchModel, space: Any, objective: Any,
                   keys: Sequence[tuple], W: Any, P: Any, data_sizes: Sequence[int],
                   n_eq: int, ng: int, n_total: float) -> ca.Function:
    """Exact Hessian of the Lagrangian on ``theta`` blocks, assembled node by node.

    Up to terms linear in the variables, the Lagrangian of a ``theta`` block is a sum
    over its grid's nodes of one small function of (z, the node's states): the
    multipliers of the two defects that read node k weigh its state derivative, and
    an observed node adds its weighted squared residuals (the order constraints are
    linear).  Its Hessian is one per-node SX Hessian, differentiated once and
    ``map``-ped over the nodes (the z–z part summed by the map), whose nonzeros are
    the nonzeros of the NLP Hessian's columns of that node: the assembly is a
    concatenation.  The values are those of differentiating the whole NLP graph
    (rounding aside) and so is the sparsity; the build is linear in the samples,
    where CasADi's sparsity detection and star colouring of the whole Hessian (whose
    rows of z are dense) grow with their square.
    """
    nv, nx, npar = space.nv, model.n_states, len(space.names)
    nw = int(W.numel())
    lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", ng)
    wbe = np.array([1.0 if n == "current_A" else 0.5 for n in model.state_names])
    funs: dict[tuple[int, bool], tuple] = {}
    Hzz = ca.MX(nv, nv)
    nz_parts: list[Any] = []
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    # P = [zref, block data...]; W = [z, block states..., (t, e)]; g = [block defects...]
    pos, ch, col0, eq0 = nv, 0, nv, 0
    for key, size in zip(keys, data_sizes):
        _, Nf, every, ny = key
        n_obs = (Nf - 1) // every + 1
        for observed in ((True,) if every == 1 else (True, False)):
            if (ny, observed) not in funs:
                funs[(ny, observed)] = node_hessian(model, space, ny, observed)
        d = P[pos:pos + size]
        sizes = {"dt": (1, Nf - 1), "u": (3, Nf), "pbase": (npar, 1), "ym": (ny, n_obs),
                 "wy": (ny, n_obs), "sx": (nx, 1), "off": (nx, Nf)}
        dat, a = {}, 0
        for name, (n_r, n_c) in sizes.items():  # the layout of the block's data
            dat[name] = ca.reshape(d[a:a + n_r * n_c], n_r, n_c)
            a += n_r * n_c
        Z = ca.reshape(W[col0:col0 + nx * Nf], nx, Nf)
        lam = ca.reshape(lam_g[eq0:eq0 + nx * (Nf - 1)], nx, Nf - 1)
        coef = lam * ca.repmat(dat["dt"], nx, 1) / ca.repmat(dat["sx"], 1, Nf - 1)
        Wb = ca.DM(np.tile(wbe[:, None], (1, Nf - 1)))
        A = -(ca.horzcat(ca.MX(nx, 1), Wb * coef) + ca.horzcat((1 - Wb) * coef, ca.MX(nx, 1)))
        mu = (ca.repmat(lam_f / n_total, ny, 1) if objective.kind == "likelihood"
              else lam_g[n_eq + ch:n_eq + ch + ny] / n_obs)
        obs_nodes = np.arange(0, Nf, every)
        groups = [(True, obs_nodes, dat["ym"], dat["wy"])]
        if every > 1:  # nodes between observations: no residual term
            rest = np.setdiff1d(np.arange(Nf), obs_nodes)
            groups.append((False, rest, ca.MX(ny, rest.size), ca.MX(ny, rest.size)))
        for observed, nodes, ym, wy in groups:
            f, r, c = funs[(ny, observed)]
            sel = slice(None) if every == 1 else nodes.tolist()
            hzz, packs = f.map("node_hess_map", "serial", int(nodes.size), [0, 3, 4, 9], [0])(
                W[:nv], Z[:, sel], dat["u"][:, sel], dat["pbase"], dat["sx"],
                dat["off"][:, sel], A[:, sel], ym, wy, mu)
            Hzz = Hzz + hzz
            if r.size:
                k = nodes[:, None]
                rows.append(np.where(r[None, :] < nv, r[None, :],
                                     col0 + k * nx + (r[None, :] - nv)).ravel())
                cols.append((col0 - nv + k * nx + c[None, :]).ravel())
                nz_parts.append(ca.vec(packs))
        pos += size
        ch += ny
        col0 += nx * Nf
        eq0 += nx * (Nf - 1)
    if objective.kind == "likelihood" and objective.regularisation:
        Hzz = Hzz + 2.0 * objective.regularisation * lam_f * ca.MX.eye(nv)
    nz = ca.vertcat(*nz_parts) if nz_parts else ca.MX(0, 1)
    r_all = np.concatenate(rows) if rows else np.zeros(0, int)
    c_all = np.concatenate(cols) if cols else np.zeros(0, int)
    order = np.lexsort((r_all, c_all))  # the column-major order of the nonzeros
    if np.any(order != np.arange(order.size)):
        nz = nz[order.tolist()]
    sp = ca.Sparsity.triplet(nw, nw - nv, r_all[order].tolist(), c_all[order].tolist())
    H = ca.horzcat(ca.vertcat(ca.triu(Hzz), ca.MX(nw - nv, nv)), ca.MX(sp, nz))
    return ca.Function("nlp_hess_l", [W, P, lam_f, lam_g], [H],
                       ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])


def node_hessian(model: BenchModel, space: Any, ny: int,
                  observed: bool) -> tuple[ca.Function, np.ndarray, np.ndarray]:
    """Hessian of one node's Lagrangian terms in (z, the node's scaled states): its z–z
    block (upper triangle) and the nonzeros of its state columns (upper triangle,
    column-major) with their rows and columns."""
    nv, nx, npar = space.nv, model.n_states, len(space.names)
    z, zk = ca.SX.sym("z", nv), ca.SX.sym("zk", nx)
    uk, pb = ca.SX.sym("u", 3), ca.SX.sym("pb", npar)
    sx, ok, ak = ca.SX.sym("sx", nx), ca.SX.sym("off", nx), ca.SX.sym("a", nx)
    ym, wy, mu = ca.SX.sym("ym", ny), ca.SX.sym("wy", ny), ca.SX.sym("mu", ny)
    Pz, _ = space.expression(z, pb)
    xk = ok + sx * zk
    ell = ca.dot(ak, model.ode(xk, uk, Pz))
    if observed:
        y = model.outputs(xk, uk, Pz)[:ny]
        ell = ell + ca.sum1(mu * (wy * (y - ym)) ** 2)
    hv = ca.triu(ca.hessian(ell, ca.vertcat(z, zk))[0])
    hcol = hv[:, nv:]
    pack = ca.vertcat(*hcol.nonzeros()) if hcol.nnz() else ca.SX(0, 1)
    r, c = hcol.sparsity().get_triplet()
    f = ca.Function("node_hess", [z, zk, uk, pb, sx, ok, ak, ym, wy, mu],
                    [hv[:nv, :nv], pack], {"cse": True})
    return f, np.array(r, int), np.array(c, int)
