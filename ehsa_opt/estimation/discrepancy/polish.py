"""Gauss–Newton polish of a fit on the forward (CVODES) simulation itself, and the
Gauss–Newton covariance it reports (directions the data do not determine get an
infinite variance)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np

from .budget import note_cut, past_deadline
from .prepared import PreparedTest
from . import rig as _rig
from .rig import BASE_SPECS, Rig, param_scale, predict, uniform_grid

__all__ = ["PolishOutcome", "polish", "gauss_newton_covariance", "REUSE_SENSITIVITIES"]

#: False: with exact sensitivities, residuals come from the plain predictor and each
#: Jacobian from a sensitivity run of its own (the reference path, for benchmarks and
#: tests; the same iterates, about one run more per accepted step).
REUSE_SENSITIVITIES = True


@dataclass
class PolishOutcome:
    """Result of :func:`polish` (mirrors ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    success : bool
        The simulated SSE did not increase (always true of the returned point).
    message : str
    parameters : dict[str, float]
    sse_before, sse_after : float
        Sum of squared noise-normalised simulation residuals on the fitted tests.
    nfev : int
        Simulations of the test group (including finite differences and sensitivity
        runs).
    seconds : float
    free : list[str]
        The refined names.
    covariance : ndarray or None
        Gauss–Newton covariance of the refined parameters at the returned point,
        s² (JᵀJ)⁺ with s² = SSE/(N − k), in physical units (None when not refined).
    cut_at_deadline : bool
        The run's deadline stopped the refinement (the best point simulated so far is
        returned, no covariance).
    moved : bool
        The returned point left the start by at least one accepted Gauss–Newton step
        (a point that only a difference quotient's perturbation made better does not
        count: the start is returned then).
    """

    success: bool
    message: str
    parameters: dict[str, float]
    sse_before: float
    sse_after: float
    nfev: int
    seconds: float
    free: list[str] = field(default_factory=list)
    covariance: np.ndarray | None = None
    cut_at_deadline: bool = False
    moved: bool = True


class _Stop(Exception):
    """The run's deadline was reached inside a polish."""


def polish(prepared: Sequence[PreparedTest], rig: Rig, parameters: Mapping[str, float],
           free: Sequence[str], *, max_iter: int = 8, diff_step: float = 1e-3,
           log_names: Sequence[str] = (), ftol: float = 1e-8,
           predictor: Callable[..., list[np.ndarray]] = predict) -> PolishOutcome:
    """Refine a collocation fit on the forward simulation itself.

    The collocation defects are a one-step rule on the sample grid; a stiff
    transmission (e.g. a 5e7 N/m compliance on the 47.5 kg rotor-equivalent mass:
    165 Hz against 1 kHz sampling) makes its optimum differ from what CVODES
    simulates with the same parameters.  A few trust-region Gauss–Newton steps
    (``scipy.optimize.least_squares``, method ``trf``) on the noise-normalised
    residuals of :func:`predict`, with forward-difference sensitivities in the
    scaled parameters and the fit bounds, close that gap.

    Parameters
    ----------
    prepared : list of PreparedTest
    rig : Rig
    parameters : dict
        Start (all model parameters, e.g. ``FitResult.parameters``).
    free : list of str
        Names refined (the rest stay fixed).
    max_iter : int
        Gauss–Newton iterations (each costs ``len(free) + 1`` simulations of the group).
    diff_step : float
        Forward-difference step in the scaled parameters.
    log_names : list of str
        Free parameters refined in log10 (those spanning decades, e.g. a stiffness;
        their lower bound must be > 0).
    ftol : float
        Stop when an iteration lowers the SSE by less than this share
        (``scipy.optimize.least_squares``' ``ftol``).
    predictor : callable
        The forward simulation, ``(prepared, rig, parameters) -> outputs``:
        :func:`~.rig.predict` (CVODES, default) or :func:`~.rig.predict_map` (the
        compiled Radau IIA map, for a smooth rig).  A predictor with a ``jacobian``
        attribute (``predict_map``: :func:`~.rig.predict_map_jacobian`) gives the
        Gauss–Newton exact sensitivities (one sensitivity run per iteration instead
        of ``len(free)`` differenced simulations; chain rule for the log10 names):
        every point is then simulated once, by a sensitivity run whose Jacobian serves
        the step if it is accepted (:class:`_Residuals`); otherwise, or on a
        non-uniform grid, forward differences.
    """
    from scipy.optimize import least_squares
    t0 = time.perf_counter()
    model = rig.model()
    specs = {**BASE_SPECS, **model.param_specs}
    free = list(free)
    is_log = np.array([n in log_names for n in free])
    for n in log_names:
        if n in free and not specs[n].lower > 0:
            raise ValueError(f"polish: {n} cannot be refined in log10 (lower bound "
                             f"{specs[n].lower} is not > 0)")
    scales = np.array([param_scale(specs[n]) for n in free])
    lo = np.array([specs[n].lower for n in free], dtype=float)
    hi = np.array([specs[n].upper for n in free], dtype=float)
    lb = np.where(is_log, np.log10(np.maximum(lo, 1e-300)), lo / scales)
    ub = np.where(is_log, np.log10(np.maximum(hi, 1e-300)), hi / scales)
    base = dict(parameters)

    def values(z: np.ndarray) -> np.ndarray:
        out = np.asarray(z, dtype=float) * scales   # 10**z only where refined in log10
        out[is_log] = 10.0 ** np.asarray(z, dtype=float)[is_log]
        return out

    exact = _exact_sensitivities(predictor, prepared)
    res = _Residuals(prepared, rig, base, free, values, is_log, scales, predictor, exact)
    resid, jac, best = res.resid, res.jac, res.best
    x0 = np.array([base[n] for n in free], dtype=float)
    z0 = np.clip(np.where(is_log, np.log10(np.maximum(x0, 1e-300)), x0 / scales), lb, ub)
    r0 = resid(z0)
    sse0 = float(r0 @ r0)
    try:
        sol = least_squares(resid, z0, bounds=(lb, ub), method="trf", x_scale="jac",
                            diff_step=diff_step, max_nfev=max_iter,
                            jac=jac if exact is not None else "2-point", ftol=ftol)
    except _Stop:  # the run's deadline: the best point simulated so far, no covariance
        return _cut_outcome(base, free, z0, best, sse0, res.runs, diff_step, values, t0)
    except Exception as exc:  # noqa: BLE001 - a failed polish keeps the collocation fit
        return PolishOutcome(False, f"polish failed: {exc}", base, sse0, sse0, res.runs,
                             time.perf_counter() - t0, free)
    sse1 = float(2.0 * sol.cost)
    if not sse1 < sse0:
        return PolishOutcome(True, "no improvement", base, sse0, sse0, res.runs,
                             time.perf_counter() - t0, free)
    x1 = values(sol.x)
    out = {**base, **{n: float(v) for n, v in zip(free, x1)}}
    cov = _final_covariance(sol, x1, is_log, scales, prepared, r0.size)
    return PolishOutcome(True, sol.message + (f" (exact Jacobian, {res.jacobians} "
                                              f"sensitivity runs)" if exact else ""),
                         out, sse0, sse1, res.runs,
                         time.perf_counter() - t0, free, cov)


class _Residuals:
    """The noise-normalised residuals of :func:`polish` (``resid``) and, with the
    predictor's exact sensitivities ``exact``, their Jacobian (``jac``) in the scaled
    parameters z (``values(z)``: the physical values of ``free``).

    With exact sensitivities (and :data:`REUSE_SENSITIVITIES`) every residual comes from
    a sensitivity run — the same outputs as the plain predictor's, bit for bit — whose
    Jacobian is kept for its point: least_squares asks for the Jacobian where it
    accepted a step, i.e. at the point just simulated, and for the residual at the
    start that :func:`polish` simulated itself.  ``runs``: simulations of the group;
    ``jacobians``: Jacobians handed out; ``best``: the lowest SSE simulated and its z.
    """

    def __init__(self, prepared, rig, base, free, values, is_log, scales, predictor,
                 exact):
        self.prepared, self.rig, self.base, self.free = prepared, rig, base, free
        self.values, self.is_log, self.scales = values, is_log, scales
        self.predictor, self.exact = predictor, exact
        self.runs, self.jacobians = 0, 0
        self.best: list = [np.inf, None]
        self.last: dict = {}

    def seen(self, z: np.ndarray, r: np.ndarray) -> None:  # keep the lowest SSE simulated
        if np.all(np.isfinite(r)) and float(r @ r) < self.best[0]:
            self.best[0], self.best[1] = float(r @ r), np.array(z, dtype=float)

    def _sensitivity_run(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _exact_residual_jacobian(self.prepared, self.rig, self.base, self.free,
                                        self.values(z), self.is_log, self.scales,
                                        self.exact)

    def resid(self, z: np.ndarray) -> np.ndarray:
        key = np.asarray(z, dtype=float).tobytes()
        if self.last.get("key") == key:
            return self.last["r"].copy()
        if self.runs and past_deadline():
            raise _Stop
        self.runs += 1
        if self.exact is not None and REUSE_SENSITIVITIES:
            raw, J = self._sensitivity_run(z)
            r = np.nan_to_num(raw, nan=1e6, posinf=1e6, neginf=-1e6)
            self.last = {"key": key, "r": r, "J": J}
            self.seen(z, r)
            return r.copy()
        vals = {**self.base, **{n: float(v) for n, v in zip(self.free, self.values(z))}}
        preds = self.predictor(self.prepared, self.rig, vals)
        r = np.concatenate([((pt.y - yp) * pt.wnorm).ravel()
                            for pt, yp in zip(self.prepared, preds)])
        r = np.nan_to_num(r, nan=1e6, posinf=1e6, neginf=-1e6)
        self.seen(z, r)
        return r

    def jac(self, z: np.ndarray) -> np.ndarray:
        if past_deadline():
            raise _Stop
        self.jacobians += 1
        if "J" in self.last and self.last["key"] == np.asarray(z, dtype=float).tobytes():
            return self.last.pop("J")  # (itself, not a copy: the same array as a fresh run)
        self.runs += 1
        raw, J = self._sensitivity_run(z)
        self.seen(z, raw)
        return J


def _cut_outcome(base: dict, free: list[str], z0: np.ndarray, best: list, sse0: float,
                 sims: int, diff_step: float, values: Callable, t0: float) -> PolishOutcome:
    """What :func:`polish` returns when the run's deadline stopped it: the best point
    simulated when it is one accepted step from the start (``moved``), else the start;
    the cut is noted (:func:`~.deadline.note_cut`)."""
    moved = bool(best[0] < sse0) and not _perturbation(best[1] - z0, z0, diff_step)
    msg = (f"stopped at the time budget after {sims} simulations"
           + ("" if moved else ", still at its start point"))
    note_cut("Gauss-Newton on the simulation", sims, moved)
    out = {**base, **{n: float(v) for n, v in zip(free, values(best[1]))}} if moved else base
    return PolishOutcome(True, msg, out, sse0, best[0] if moved else sse0, sims,
                         time.perf_counter() - t0, free, cut_at_deadline=True, moved=moved)


def _perturbation(dz: np.ndarray, z0: np.ndarray, diff_step: float) -> bool:
    """Whether ``z0 + dz`` is one of the forward-difference points around ``z0`` (one
    coordinate moved by at most the difference step ``diff_step``·max(1, |z₀|)), not a
    Gauss–Newton step."""
    moved = np.flatnonzero(np.asarray(dz) != 0.0)
    if moved.size == 0:
        return True
    i = int(moved[0])
    return moved.size == 1 and abs(dz[i]) <= 1.01 * diff_step * max(1.0, abs(z0[i]))


def _exact_sensitivities(predictor: Callable, prepared: Sequence[PreparedTest]
                         ) -> Callable | None:
    """The predictor's exact sensitivities when it has them (the compiled map on
    uniform grids), else None: forward differences (CVODES, e.g. a rig with a contact)."""
    exact = getattr(predictor, "jacobian", None) if _rig.EXACT_JACOBIAN else None
    if exact is not None and not all(uniform_grid(pt.time_s) for pt in prepared):
        return None
    return exact


def _exact_residual_jacobian(prepared: Sequence[PreparedTest], rig: Rig,
                             base: Mapping[str, float], free: Sequence[str], x: np.ndarray,
                             is_log: np.ndarray, scales: np.ndarray, exact: Callable
                             ) -> tuple[np.ndarray, np.ndarray]:
    """The noise-normalised residuals and their Jacobian with respect to the scaled (or
    log10) parameters at the physical values ``x`` of ``free``, from one run of the
    predictor's exact sensitivities ``exact`` (chain rule: ∂x/∂z = scale, or x ln 10
    for a log10 name)."""
    vals = {**base, **{n: float(v) for n, v in zip(free, x)}}
    preds, dpreds = exact(prepared, rig, vals, free)
    r = np.concatenate([((pt.y - yp) * pt.wnorm).ravel() for pt, yp in zip(prepared, preds)])
    dxdz = np.where(is_log, np.log(10.0) * x, scales)
    J = np.concatenate([-(dy * pt.wnorm[:, :, None]).reshape(-1, len(free))
                        for pt, dy in zip(prepared, dpreds)])
    return r, np.nan_to_num(J * dxdz[None, :], nan=0.0, posinf=0.0, neginf=0.0)


def _final_covariance(sol, x1: np.ndarray, is_log: np.ndarray, scales: np.ndarray,
                      prepared: Sequence[PreparedTest], n_resid: int) -> np.ndarray:
    """Gauss–Newton covariance (physical units) from the final Jacobian of
    ``least_squares``' solution ``sol``; the Newey–West sandwich where the data
    determine the parameters (autocorrelated residuals)."""
    sse1 = float(2.0 * sol.cost)
    dxdz = np.where(is_log, np.log(10.0) * x1, scales)
    Jx = np.asarray(sol.jac, dtype=float) / dxdz[None, :]
    cov = gauss_newton_covariance(Jx, sse1 / max(n_resid - x1.size, 1))
    try:
        from ..covariance import hac_covariance
        h = hac_covariance(Jx, np.asarray(sol.fun, dtype=float),
                           groups=[pt.y.shape[1] for pt in prepared for _ in pt.y])
        known = np.isfinite(cov)
        cov = np.where(known, h.cov, cov)
    except (ValueError, np.linalg.LinAlgError):
        pass  # the Gauss-Newton covariance stays
    return cov


def gauss_newton_covariance(J: np.ndarray, s2: float, rcond: float = 1e-9) -> np.ndarray:
    """s² (JᵀJ)⁻¹ from a residual Jacobian ``J`` (N × k), by SVD of the
    column-normalised Jacobian.  Directions the data do not determine (singular
    values below ``rcond`` × the largest) get an *infinite* variance — a
    pseudo-inverse would report them as perfectly known (zero width)."""
    norms = np.linalg.norm(J, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    _, S, Vt = np.linalg.svd(J / norms, full_matrices=False)
    good = S > rcond * max(S.max(initial=0.0), 1e-300)
    Vg = Vt[good]
    cov = (Vg.T / S[good] ** 2) @ Vg
    loose = np.sum(Vt[~good] ** 2, axis=0) > 1e-6 if (~good).any() else np.zeros(J.shape[1], bool)
    cov = s2 * cov / np.outer(norms, norms)
    cov[loose, :] = np.nan
    cov[:, loose] = np.nan
    cov[loose, loose] = np.inf
    return cov


