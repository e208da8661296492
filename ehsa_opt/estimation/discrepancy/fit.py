"""The likelihood fit of one parameter set to a group of tests (:func:`fit_group`), generic
over the rig's components (:mod:`.rig`), by direct collocation + IPOPT.

The fit is the likelihood objective on the estimation core
(:mod:`ehsa_opt.estimation.core`; the NLP is built once per structure and reused).
Transcription (on each test's own sample grid, ``theta`` in the core): the states of
every sample are decision variables; defects use the trapezoidal rule for mechanical states and
backward Euler for the stiff winding current (L/R ≪ the sample step; backward
Euler tracks its slow manifold with the right first-order lag).  The objective is
the Gaussian log-likelihood of force (and voltage) residuals, each channel
scaled by its noise level estimated from the measured signal itself
(:func:`~ehsa_opt.estimation.discrepancy.prepared.noise_std`).  Parameters are scaled by
typical magnitudes; bounds come from :data:`~ehsa_opt.estimation.discrepancy.rig.BASE_SPECS`
(the discrepancy's override of the declared base parameters) and each component's
``ParamSpec``; IPOPT's return status is checked and reported.  A model without state is
fitted by least squares instead (:mod:`ehsa_opt.estimation.given_fit`).  The result is
the room's :class:`~ehsa_opt.estimation.fit_result.FitResult`.
"""

from __future__ import annotations

from functools import partial

import math
import time
from typing import Any, Mapping, Sequence

import numpy as np

from ...physics import BenchModel
from .. import core
from ..collocation import given_block, theta_block
from ..fit_result import FitResult
from ..given_fit import GivenFit, fit_given
from ..starts import Starts, draw_starts
from .prepared import PreparedTest
from .rig import BASE_SPECS, Rig, param_scale, simulate_test

__all__ = ["fit_group", "WINDOW_WEIGHT"]


# ------------------------------------------------------------------ the NLP
def _fine_grid(t: np.ndarray, M: int) -> np.ndarray:
    """``M`` equal sub-intervals in every sample interval (samples at every M-th node)."""
    if M == 1:
        return t
    frac = np.arange(M) / M
    tf = (t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel()
    return np.append(tf, t[-1])


_ORDER = (("nut_breakaway_N", "nut_coulomb_N"), ("bearing_breakaway_Nm", "bearing_coulomb_Nm"))
#: Weight of a left-out sample (relative to a resolved one) in the collocation objective
#: only: at zero the initial current of a record whose first samples are left out is free
#: and IPOPT diverges along it (docs/recorded_motions.md); errors use resolved samples.
WINDOW_WEIGHT = 1e-3
#: IPOPT statuses whose point is kept (an iteration cap still leaves an improved point).
_USABLE = ("Solve_Succeeded", "Solved_To_Acceptable_Level", "Maximum_Iterations_Exceeded")


def fit_group(prepared: Sequence[PreparedTest], rig: Rig, starts: Starts,
              *, free: Sequence[str] | None = None, fixed: Mapping[str, float] | None = None,
              max_iter: int = 300, regularisation: float = 1e-6,
              max_cpu_s: float | None = None, substeps: int | None = None,
              seed: int = 0) -> FitResult:
    """Fit one parameter set to all ``prepared`` tests: the likelihood objective on the
    estimation core (:mod:`ehsa_opt.estimation.core`, ``theta`` transcription).

    Parameters
    ----------
    prepared : list of PreparedTest
    rig : Rig
    starts : int or list of dict
        Start points (missing names: ParamSpec defaults), or a number of points drawn
        (seeded by ``seed``) in the declared start ranges (:mod:`ehsa_opt.estimation.starts`);
        the best converged start is kept.
    free : list of str, optional
        Names to fit (default: all base names and all component parameters).
    fixed : dict, optional
        Values of non-fitted parameters.
    max_iter : int
        IPOPT iteration limit per start (the point reached is kept and its status
        reported).  Iterations, not CPU time, so results do not depend on the machine.
    regularisation : float
        Weight of a tiny pull of the scaled parameters toward the first start, so
        non-identifiable directions (nut vs bearing friction split) stay put.
    max_cpu_s : None
        Removed (results must not depend on CPU speed); passing a value warns.
    substeps : int, optional
        Collocation sub-intervals per sample interval (default 1: at 1 kHz the
        collocation objective at the true backlash parameters matches the CVODES
        simulation's within 1 %).
    seed : int
        Seed of the drawn start points (when ``starts`` is a number).
    """
    if max_cpu_s is not None:
        import warnings
        warnings.warn("fit_group: max_cpu_s is ignored (iteration limits only: results must "
                      "not depend on the machine's speed); use max_iter", DeprecationWarning,
                      stacklevel=2)
    t0 = time.perf_counter()
    model = rig.model()
    M = int(substeps or 1)
    specs = {**BASE_SPECS, **model.param_specs}
    names = [n for n in model.param_names if n != "load_ohm"]
    free = list(free) if free is not None else rig.base_names + list(model.param_specs)
    fixed = dict(fixed or {})
    fixed = {**rig.fixed_base, **fixed}
    starts = draw_starts(model, free, starts, seed, where="fit_group")
    space = core.ParamSpace(tuple(model.param_names), tuple(free),
                            tuple(specs[n].lower for n in free),
                            tuple(specs[n].upper for n in free),
                            tuple(param_scale(specs[n]) for n in free), (), _ORDER)

    def default_of(n: str) -> float:
        return float(fixed.get(n, specs[n].default))

    blocks, grids = _blocks(prepared, model, M, default_of)
    z0s = []
    for st in starts:
        vals = {n: float(st.get(n, fixed.get(n, specs[n].default))) for n in free}
        z0s.append(space.z_of(vals))
    # states of each start from a forward simulation with its parameters, so the
    # collocation starts (nearly) feasible — important for stiff contacts
    guesses = None
    if model.n_states:
        guesses = []
        for z0 in z0s:
            zvals = space.values_of(z0, np.zeros(len(model.param_names)))
            pstart = {n: (zvals[n] if n in free else default_of(n)) for n in names}
            guesses.append([((simulate_test(model, pt, pstart, tf).states - b.info["off"])
                             / b.info["sx"][:, None]).ravel(order="F")
                            for pt, b, tf in zip(prepared, blocks, grids)])
    n_obs = sum(b.n_obs * b.ny for b in blocks)
    if not model.n_states:  # no state: ordinary least squares, no NLP to build
        given = _fit_given(model, space, blocks, z0s, regularisation, max_iter)
        if given is not None:
            return _outcome_given(given, space, blocks, free, names, default_of, n_obs, t0)
    nlp = core.build(model, space, core.Objective("likelihood", regularisation=regularisation),
                     core.SolverSettings(1e-8, int(max_iter), acceptable_tol=1e-5), blocks)
    recs = core.solve_starts(nlp, blocks, z0s, zref=z0s[0], state_guesses=guesses)
    records = [{"status": r.status, "success": r.success, "objective": r.objective,
                "iterations": r.iterations} for r in recs]
    usable = [r for r in recs if (r.success or r.status in _USABLE) and np.isfinite(r.objective)]
    if not usable:  # one restart from where the failed solves stopped
        extra = _restart(nlp, blocks, grids, recs, space, model, prepared, z0s[0],
                         lambda v: {n: (v[n] if n in free else default_of(n)) for n in names})
        records += [{"status": r.status, "success": r.success, "objective": r.objective,
                     "iterations": r.iterations, "restart": True} for r in extra]
        usable = [r for r in extra if (r.success or r.status in _USABLE)
                  and np.isfinite(r.objective)]
    if not usable:
        return FitResult(success=False, message="IPOPT failed from every start (" + "; ".join(
            r["status"] for r in records) + ")", free=free, objective=math.inf,
            starts=records, seconds=time.perf_counter() - t0, path="collocation",
            sse=math.inf, n_obs=n_obs)
    best = min(usable, key=lambda r: r.objective)
    p = nlp.data(blocks, z0s[0])
    params = {n: default_of(n) for n in names}
    vals = space.values_of(best.w, np.zeros(len(model.param_names)))
    params.update({n: vals[n] for n in free})
    sse = float(nlp.ssefun(best.w, p))
    cov, hac = _covariance(nlp, best.w, p, blocks, len(free), prepared,
                           equilibrate=model.friction_law != "static")
    return FitResult(success=best.success, message=best.status, status=best.status,
                     parameters=params, free=free, objective=sse / n_obs, nit=best.iterations,
                     starts=records, seconds=time.perf_counter() - t0, path="collocation",
                     sse=sse, n_obs=n_obs, covariance=cov, covariance_info=hac)


def _blocks(prepared: Sequence[PreparedTest], model: BenchModel, substeps: int,
            default_of: Any) -> tuple[list[Any], list[np.ndarray]]:
    """One estimation-core block per test (``theta`` collocation on the test's grid refined
    ``substeps`` times for models with states, the algebraic block otherwise) and the
    collocation grids."""
    blocks, grids = [], []
    for pt in prepared:
        pbase = np.array([pt.fixed[n] if n in pt.fixed else default_of(n)
                          for n in model.param_names])
        w = _nlp_weights(pt) if model.n_states else pt.wnorm
        if model.n_states:
            tf = _fine_grid(pt.time_s, substeps)
            uf = pt.motion.evaluate(tf) if substeps > 1 else pt.u
            blocks.append(theta_block(model, tf, uf, substeps, pt.y, w, pbase))
            grids.append(tf)
        else:
            blocks.append(given_block(model, np.zeros((0, pt.time_s.size)), pt.u, pt.y, w,
                                      pbase))
            if pt.output_filter_hz is not None:  # the model through the measurement's filter
                blocks[-1].info["output_filter"] = partial(pt.filter_output, axis=0)
    return blocks, grids


def _nlp_weights(pt: PreparedTest) -> np.ndarray:
    """(ny, N) collocation residual weights (left-out samples at :data:`WINDOW_WEIGHT`)."""
    return np.maximum(pt.weight, WINDOW_WEIGHT)[None, :] / pt.sigma[:, None]


def _restart(nlp: core.NLP, blocks: Sequence[Any], grids: Sequence[np.ndarray],
             recs: Sequence[Any], space: core.ParamSpace, model: BenchModel,
             prepared: Sequence[PreparedTest], zref: np.ndarray, values: Any) -> list:
    """One more IPOPT solve after every start failed, from the failed point
    (:func:`_restart_point`) with states re-simulated; [] when there is none."""
    z_r = _restart_point(recs, space)
    if z_r is None:
        return []
    pr = values(space.values_of(z_r, np.zeros(len(model.param_names))))
    try:
        g_r = [((simulate_test(model, pt, pr, tf).states - b.info["off"])
                / b.info["sx"][:, None]).ravel(order="F")
               for pt, b, tf in zip(prepared, blocks, grids)]
    except Exception:  # noqa: BLE001 - a start the simulator refuses: no restart
        return []
    return core.solve_starts(nlp, blocks, [z_r], zref=zref, state_guesses=[g_r])


def _restart_point(recs: Sequence[Any], space: core.ParamSpace) -> np.ndarray | None:
    """The finite failed point of lowest objective, clipped into the bounds, or None."""
    pts = [r for r in recs if np.all(np.isfinite(r.w[:space.nv])) and np.isfinite(r.objective)]
    if not pts:
        return None
    r = min(pts, key=lambda q: q.objective)
    return np.clip(r.w[:space.nv], space.lbz, space.ubz)


def _fit_given(model: BenchModel, space: core.ParamSpace, blocks: Sequence[Any],
               z0s: Sequence[np.ndarray], regularisation: float, max_iter: int
               ) -> list[GivenFit] | None:
    """Every start by least squares (:func:`~ehsa_opt.estimation.given_fit.fit_given`);
    None when that cannot pose the problem or reaches no finite point: the caller
    then solves the NLP."""
    fits = fit_given(model, space, blocks, z0s, zref=z0s[0], regularisation=regularisation,
                     max_nfev=10 * int(max_iter))
    if fits is None or not any(np.isfinite(f.objective) for f in fits):
        return None
    return fits


def _outcome_given(fits: list[GivenFit], space: core.ParamSpace, blocks: Sequence[Any],
                   free: list[str], names: list[str], default_of: Any, n_obs: int,
                   t0: float) -> FitResult:
    records = [{"status": f.status, "success": f.success, "objective": f.objective,
                "iterations": f.iterations} for f in fits]
    best = min((f for f in fits if np.isfinite(f.objective)), key=lambda f: f.objective)
    params = {n: default_of(n) for n in names}
    vals = space.values_of(best.w, np.zeros(len(space.names)))
    params.update({n: vals[n] for n in free})
    S = best.jacobian / np.array(space.scale)  # d(weighted residuals)/d(physical values)
    cov, hac = _hac(S, best.residual, [b.n_obs for b in blocks for _ in range(b.ny)])
    return FitResult(success=best.success, message=best.status, status=best.status,
                     parameters=params, free=free, objective=best.sse / n_obs,
                     nit=best.iterations, starts=records, seconds=time.perf_counter() - t0,
                     path="rigid", sse=best.sse, n_obs=n_obs, covariance=cov,
                     covariance_info=hac)


def _hac(S: np.ndarray, r: np.ndarray | None, groups: list[int], n_nuisance: int = 0,
         equilibrate: bool = False) -> tuple[np.ndarray | None, dict | None]:
    """Newey–West covariance of the free parameters (:func:`~ehsa_opt.estimation.
    covariance.hac_covariance`, one segment per test and channel) and its summary."""
    from ..covariance import hac_covariance
    if r is None or S.shape[0] != np.size(r):
        return None, None
    try:
        h = hac_covariance(S, r, groups=groups, n_nuisance=n_nuisance,
                           equilibrate=equilibrate)
    except (ValueError, np.linalg.LinAlgError) as exc:
        import warnings
        warnings.warn(f"parameter covariance unavailable: {exc}")
        return None, None
    return h.cov, {"method": h.method, "n_eff": h.n_eff, "n": h.n,
                   "bandwidth_samples": h.bandwidth,
                   "inflation_over_iid": [float(x) for x in h.inflation]}


def _covariance(nlp: core.NLP, w: np.ndarray, p: np.ndarray, blocks: Sequence[Any], nz: int,
                prepared: Sequence[PreparedTest], equilibrate: bool = False
                ) -> tuple[np.ndarray | None, dict | None]:
    """Newey–West covariance of the free parameters (:func:`_hac`) with S the total
    sensitivity of the noise-normalised residuals (states eliminated through the
    collocation constraints by the core; initial states profiled out)."""
    try:
        dy = nlp.sensitivities(w, p)
        wt = np.concatenate([b.info["weight_matrix"].ravel() for b in blocks])
        S = dy * wt[:, None]
        ym = np.concatenate([pt.y.ravel() for pt in prepared])  # per test, channel, sample
        r = (ym - np.asarray(nlp.yfun(w, p)).ravel()) * wt
    except Exception as exc:  # noqa: BLE001 - intervals are a report extra, never fatal
        import warnings
        warnings.warn(f"parameter covariance unavailable: {exc}")
        return None, None
    return _hac(S, r, [b.n_obs for b in blocks for _ in range(b.ny)],
                n_nuisance=S.shape[1] - nz, equilibrate=equilibrate)
