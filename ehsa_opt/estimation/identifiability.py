"""Identifiability at an identification optimum: the Gauss–Newton Fisher
information of the free parameters (states eliminated by the collocation
sensitivities of :meth:`ehsa_opt.estimation.core.NLP.sensitivities`, initial states
marginalised), its eigen-decomposition in scaled coordinates, and identifiable
combinations with 95 % intervals."""

from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np

from ..physics.bench_model import RIG_PARAM_NAMES
from ..physics.friction import rod_friction_N
from ..physics.params import FRICTION_NAMES

__all__ = ["fisher_identifiability"]


def fisher_identifiability(dy: np.ndarray, y: np.ndarray, y_meas: Sequence[np.ndarray],
                           params: Mapping[str, float], free: Sequence[str],
                           scales: Sequence[float], lead_m_per_rad: float,
                           peak_velocity_m_per_s: float, rtol: float,
                           velocities_m_per_s: Sequence[float] | None = None,
                           method: str = "") -> dict:
    """Gauss–Newton Fisher information of the free parameters at an optimum.

    Parameters
    ----------
    dy : ndarray
        d(outputs)/d(free [physical], nuisance initial states) (rows as ``y``).
    y : ndarray
        Outputs at the optimum: per test, per channel, per observation.
    y_meas : list of ndarray
        Per test the measured channels (ny × n_obs).
    params : dict
        Parameter values at the optimum.
    free, scales :
        Free (fitted) names and their scales (z = p / scale).
    lead_m_per_rad, peak_velocity_m_per_s : float
        For the rod-friction combinations (at 0.1, 0.25, 0.5, 1 × peak velocity
        unless ``velocities_m_per_s``).
    rtol : float
        Relative eigenvalue below which a direction is not determined.

    Residuals are weighted by the noise level estimated from the fit residual of
    each signal; the initial states are marginalised (Schur complement).
    Returns eigenvalues, directions, the names of the poorly determined
    directions, the covariance-based 95 % intervals of the parameters and of
    identifiable combinations.
    """
    free = list(free)
    nv = len(free)
    scales = np.asarray(scales, float)
    Jw, resid, sizes = _weighted_jacobian(dy, y, y_meas)
    Fz = _marginal_information(Jw, nv, scales)
    ev, directions = _directions(Fz, free, rtol)
    # intervals: the Newey-West sandwich (the residuals of a time series are
    # autocorrelated: the independent-samples covariance pinv(Fz) is too narrow by
    # about their correlation time), initial states profiled out
    from .covariance import hac_covariance
    colscale = np.concatenate([scales, np.ones(Jw.shape[1] - nv)])
    hac = hac_covariance(Jw * colscale[None, :], np.concatenate(resid), groups=sizes,
                         n_nuisance=Jw.shape[1] - nv, rcond=rtol)
    cov = hac.cov * np.outer(scales, scales)
    cov_iid = np.linalg.pinv(Fz, rcond=rtol) * np.outer(scales, scales)
    params = dict(params)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    ci = {n: [params[n] - 1.96 * sd[j], params[n] + 1.96 * sd[j]] for j, n in enumerate(free)}
    combos = _combinations(params, free, scales, cov, lead_m_per_rad, peak_velocity_m_per_s,
                           velocities_m_per_s)
    weak = [d for d in directions if not d["identifiable"]]
    return {"method": method or ("Gauss-Newton Fisher information, states eliminated by collocation "
                      "sensitivities, initial states marginalised; scaled coordinates"),
            "parameters": free, "relative_eigenvalues": [d["relative_eigenvalue"]
                                                            for d in directions],
            "directions": directions,
            "non_identifiable": [d["main"] for d in weak],
            "condition_number": float(ev[-1] / max(ev[0], 1e-300)), "threshold": rtol,
            "parameter_ci95": ci, "combinations": combos,
            "interval_method": hac.method, "effective_samples": hac.n_eff,
            "samples": hac.n, "hac_bandwidth_samples": hac.bandwidth,
            "parameter_ci95_iid": {n: [params[n] - 1.96 * float(np.sqrt(max(cov_iid[j, j], 0))),
                                       params[n] + 1.96 * float(np.sqrt(max(cov_iid[j, j], 0)))]
                                   for j, n in enumerate(free)}}


def _weighted_jacobian(dy: np.ndarray, y: np.ndarray, y_meas: Sequence[np.ndarray]
                       ) -> tuple[np.ndarray, list[np.ndarray], list[int]]:
    """The Jacobian with every signal's rows divided by the noise level of its fit residual,
    the weighted residuals per signal and their lengths."""
    rows, weights, pos, resid, sizes = [], [], 0, [], []
    for ym in y_meas:
        npts = ym.shape[1]
        for k in range(ym.shape[0]):
            block = slice(pos, pos + npts)
            r = y[block] - ym[k]
            sigma = max(float(np.std(r)), 1e-12)
            rows.append(np.arange(block.start, block.stop))
            weights.append(np.full(npts, 1.0 / sigma))
            resid.append(r / sigma)
            sizes.append(npts)
            pos += npts
    rows_i = np.concatenate(rows)
    Wt = np.concatenate(weights)
    return dy[rows_i] * Wt[:, None], resid, sizes


def _marginal_information(Jw: np.ndarray, nv: int, scales: np.ndarray) -> np.ndarray:
    """Fisher information of the first ``nv`` columns with the others (the initial states)
    marginalised (Schur complement), in scaled coordinates z = p / scale."""
    Fall = Jw.T @ Jw
    Fpp, Fpx, Fxx = Fall[:nv, :nv], Fall[:nv, nv:], Fall[nv:, nv:]
    Fp = Fpp - Fpx @ np.linalg.pinv(Fxx) @ Fpx.T if Fxx.size else Fpp
    Fp = 0.5 * (Fp + Fp.T)
    return Fp * np.outer(scales, scales)


def _directions(Fz: np.ndarray, free: list[str], rtol: float
                ) -> tuple[np.ndarray, list[dict]]:
    """Eigenvalues (ascending) of the scaled information and its directions: relative
    eigenvalue, vector, main components and whether the data determine it."""
    ev, V = np.linalg.eigh(Fz)
    order = np.argsort(ev)
    ev, V = ev[order], V[:, order]
    rel = ev / max(ev[-1], 1e-300)
    weak_idx = np.flatnonzero(rel < rtol)
    if weak_idx.size >= 2:
        # the poorly determined subspace is (near-)degenerate: its eigenvectors are any
        # basis of it; a varimax rotation gives the interpretable one (each direction
        # on as few parameters as possible), with Rayleigh quotients as eigenvalues
        Vw = _varimax(V[:, weak_idx])
        V[:, weak_idx] = Vw
        rel[weak_idx] = np.einsum("ij,ik,kj->j", Vw, Fz, Vw) / max(ev[-1], 1e-300)
    directions = []
    for k in range(len(free)):
        comp = {n: float(V[j, k]) for j, n in enumerate(free)}
        main = {n: c for n, c in sorted(comp.items(), key=lambda kv: -abs(kv[1]))
                if abs(c) > 0.1}
        directions.append({"relative_eigenvalue": float(max(rel[k], 0.0)), "vector": comp,
                           "main": main, "identifiable": bool(rel[k] >= rtol)})
    return ev, directions


def _combinations(params: dict, free: list[str], scales: np.ndarray, cov: np.ndarray,
                  lead_m_per_rad: float, peak_velocity_m_per_s: float,
                  velocities_m_per_s: Sequence[float] | None) -> dict:
    """Identifiable combinations (rod friction at given velocities, total viscous and
    Coulomb, the rig terms) with their 95 % intervals by the delta method on ``cov``."""
    combos = {}
    r = lead_m_per_rad
    nv = len(free)

    def grad(fun: Callable[[dict], float]) -> tuple[float, np.ndarray]:
        base = fun(params)
        g = np.zeros(nv)
        for j, n in enumerate(free):
            step = 1e-6 * scales[j]
            q = dict(params)
            q[n] += step
            g[j] = (fun(q) - base) / step
        return base, g

    def add(name: str, fun: Callable[[dict], float]) -> None:
        val, g = grad(fun)
        s = float(np.sqrt(max(g @ cov @ g, 0.0)))
        combos[name] = {"value": val, "ci95": [val - 1.96 * s, val + 1.96 * s]}

    fr_names = [n for n in FRICTION_NAMES if n in free]
    if fr_names:
        vmax = peak_velocity_m_per_s
        vel = velocities_m_per_s if velocities_m_per_s is not None else \
            [f * vmax for f in (0.1, 0.25, 0.5, 1.0)]

        def rod(v: float) -> Callable[[dict], float]:
            return lambda q: float(rod_friction_N(v, [q[n] for n in FRICTION_NAMES], r))
        for v in vel:
            add(f"rod_friction_N_at_{v:.4g}_m_per_s", rod(float(v)))
        add("total_viscous_Ns_per_m",
            lambda q: q["nut_viscous_Ns_per_m"] + q["bearing_viscous_Nms_per_rad"] / r ** 2)
        add("total_coulomb_N", lambda q: q["nut_coulomb_N"] + q["bearing_coulomb_Nm"] / r)
    for n in RIG_PARAM_NAMES:
        if n in free:
            add(n, lambda q, n=n: q[n])
    return combos


def _varimax(V: np.ndarray, iterations: int = 100, tol: float = 1e-10) -> np.ndarray:
    """Orthogonal varimax rotation of the columns of ``V`` (Kaiser 1958)."""
    n, k = V.shape
    R = np.eye(k)
    crit = 0.0
    for _ in range(iterations):
        L = V @ R
        u, s, vt = np.linalg.svd(V.T @ (L ** 3 - L @ np.diag(np.sum(L ** 2, axis=0)) / n))
        R = u @ vt
        if s.sum() < crit * (1 + tol):
            break
        crit = s.sum()
    return V @ R
