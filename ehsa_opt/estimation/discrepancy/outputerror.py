"""Output-error refit for the EMPS benchmark's own metric: the parameters of the
physics model (and of its named effects) chosen so that the position *simulated*
from the force matches the measured position on the fit record.

The inverse model (force error, the workflow's fits) weights every sample's force
equally; the benchmark's figure of merit is the open-loop position error, which
integrates every force bias twice.  An output-error refit on the estimation record
is the grey-box counterpart of how the black-box results are trained (simulation
error on the estimation record); it is judged once on the validation record.

The simulation is the one of :func:`~.openloop.open_loop_position` (RK4 on the
sample grid, the force held over each step, from rest at the measured initial
position; a named drive lag passes the force through :func:`~.candidates.drive_lag.applied_force`
first), written as a CasADi map over the record so that the trajectory's Jacobian
with respect to the parameters is exact (forward mode) and costs about one
simulation per parameter.  The parameters are scaled by their starting values and
fitted by ``scipy.optimize.least_squares`` (trust-region reflective) on the
position error in mm.

The offset and a direction-dependent Coulomb level differ only at rest, where the
simulation hardly dwells: they are not separately identifiable from the simulated
position, so the Coulomb asymmetry is held at its inverse-model value.
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np

from ...utils.jit_cache import compiled as _compiled_or_none
from .openloop import SKIP_SAMPLES, open_loop_error

__all__ = ["output_error_refit", "output_error_multistart", "output_error_rows", "OE_PARAMETERS",
           "OpenLoopRecord", "refit_record"]

#: The port's parameters in the order of the simulator's parameter vector.
OE_PARAMETERS = ("inertia_kg", "nut_viscous_Ns_per_m", "nut_coulomb_N", "offset_N",
                 "asym_viscous_Ns_per_m", "asym_coulomb_N")


def _simulator(n: int):
    """CasADi functions (q0, w0, F[1×n−1], Δt[1×n−1], p[6]) → q[1×n] and → ∂q/∂p: RK4
    with the force held over each step, from position q0 and velocity w0."""
    import casadi as ca
    x = ca.SX.sym("x", 2)
    u = ca.SX.sym("u")
    dt = ca.SX.sym("dt")
    p = ca.SX.sym("p", len(OE_PARAMETERS))

    def acc(w):
        s = ca.sign(w)
        fv = p[1] + s * p[4]
        fc = p[2] + s * p[5]
        return (u - fv * w - fc * s - p[3]) / p[0]

    q, w = x[0], x[1]
    a1 = acc(w)
    a2 = acc(w + 0.5 * dt * a1)
    a3 = acc(w + 0.5 * dt * a2)
    a4 = acc(w + dt * a3)
    qn = q + dt / 6 * (w + 2 * (w + 0.5 * dt * a1) + 2 * (w + 0.5 * dt * a2) + (w + dt * a3))
    wn = w + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    step = ca.Function("step", [x, u, dt, p], [ca.vertcat(qn, wn)])
    sim = step.mapaccum("sim", n - 1)
    q0 = ca.MX.sym("q0")
    w0 = ca.MX.sym("w0")
    U = ca.MX.sym("U", 1, n - 1)
    D = ca.MX.sym("D", 1, n - 1)
    P = ca.MX.sym("P", len(OE_PARAMETERS))
    X = sim(ca.vertcat(q0, w0), U, D, ca.repmat(P, 1, n - 1))
    qtraj = ca.horzcat(q0, X[0, :])
    # compiled to C: the same numbers as CasADi's virtual machine, about 4x faster
    q = ca.Function("q", [q0, w0, U, D, P], [qtraj])
    dq = ca.Function("dq", [q0, w0, U, D, P], [ca.jacobian(qtraj, P)])
    # compiled once into the per-user cache; the virtual machine where no compiler works
    return _compiled_or_none(q) or q, _compiled_or_none(dq) or dq


#: simulators by record length (built once: every start, fold and model reuses them; a
#: fold that stops early takes the first samples of the whole record's simulation — the
#: simulation runs forward in time, so they are the same numbers)
_SIMULATORS: dict[int, tuple] = {}


class OpenLoopRecord:
    """A record's force (through a named drive lag) and measured position, simulated
    open loop from the measured position at rest (the benchmark's convention, its
    first :data:`SKIP_SAMPLES` left out of every error), up to ``stop`` samples."""

    def __init__(self, test, params: Mapping[str, float]) -> None:
        from .candidates.drive_lag import applied_force
        t = np.asarray(test.time_s, float)
        tau = float(params.get("drive_lag_time_constant_s", 0.0))
        delay = float(params.get("drive_delay_s", 0.0))
        self.F = applied_force(t, test.force_N, tau, delay) if (tau or delay) else \
            np.asarray(test.force_N, float)
        self.t, self.q = t, np.asarray(test.displacement_m, float)

    @staticmethod
    def _sim(n: int):
        if n not in _SIMULATORS:
            if len(_SIMULATORS) >= 8:
                _SIMULATORS.pop(next(iter(_SIMULATORS)))
            _SIMULATORS[n] = _simulator(n)
        return _SIMULATORS[n]

    def _args(self, p: np.ndarray) -> tuple:
        return (float(self.q[0]), 0.0, self.F[:-1][None, :], np.diff(self.t)[None, :], p)

    def residual(self, p: np.ndarray, stop: int | None = None, start: int = SKIP_SAMPLES
                 ) -> np.ndarray:
        """Position error (mm) of samples ``start`` … ``stop`` − 1 of the simulation
        from the record's start."""
        n = self.t.size if stop is None else int(stop)
        qs = np.asarray(self._sim(self.t.size)[0](*self._args(p))).ravel()[:n]
        return 1e3 * (qs - self.q[:n])[max(start, SKIP_SAMPLES):]

    def jacobian(self, p: np.ndarray, stop: int | None = None) -> np.ndarray:
        """∂(position error, mm)/∂p of samples :data:`SKIP_SAMPLES` … ``stop`` − 1."""
        n = self.t.size if stop is None else int(stop)
        return 1e3 * np.asarray(self._sim(self.t.size)[1](*self._args(p)))[SKIP_SAMPLES:n]


def refit_record(rec: OpenLoopRecord, params: Mapping[str, float], free: Sequence[str],
           stop: int | None, max_nfev: int):
    """Least-squares refit of ``free`` on the record's samples before ``stop`` (all:
    None): (full parameter vector, scipy result, scale, indices of ``free``)."""
    from scipy.optimize import least_squares
    p0 = np.array([float(params.get(k, 0.0)) for k in OE_PARAMETERS])
    idx = [OE_PARAMETERS.index(k) for k in free]
    scale = np.maximum(np.abs(p0[idx]), 1.0)

    def full(z):
        p = p0.copy()
        p[idx] = z * scale
        return p

    # tolerances: a relative change of 1e-6 in the parameters is far below their
    # intervals, and each iteration costs a simulation and its Jacobian
    out = least_squares(lambda z: rec.residual(full(z), stop),
                        p0[idx] / scale,
                        jac=lambda z: rec.jacobian(full(z), stop)[:, idx] * scale[None, :],
                        method="trf", max_nfev=max_nfev, x_scale="jac", ftol=1e-6, xtol=1e-6)
    return full(out.x), out, scale, idx


def output_error_refit(fit_test, params: Mapping[str, float], free: Sequence[str],
                       eval_tests: Sequence = (), max_nfev: int = 60) -> dict:
    """Refit ``free`` parameters of the open-loop port on ``fit_test``'s simulated
    position, the others held at ``params``.

    Parameters
    ----------
    fit_test : BenchTest
        The record the parameters are fitted on (its recorded force drives the
        simulation; a ``drive_lag_time_constant_s`` in ``params`` is applied to it).
    params : mapping
        Starting values (the workflow's inverse-model parameters); names not in
        :data:`OE_PARAMETERS` other than the drive's are ignored.
    free : sequence of str
        Names from :data:`OE_PARAMETERS` to fit.
    eval_tests : sequence of BenchTest
        Records the result is judged on (:func:`~.openloop.open_loop_error`).

    Returns
    -------
    dict with ``success``, ``message``, ``parameters`` (all of the port's and the
    drive's), ``fit_rms_mm`` (on ``fit_test``) and ``eval`` (per evaluation test,
    :func:`~.openloop.open_loop_error`).
    """
    unknown = [k for k in free if k not in OE_PARAMETERS]
    if unknown:
        raise ValueError(f"output_error_refit: unknown free parameters {unknown} "
                         f"(choose from {', '.join(OE_PARAMETERS)})")
    rec = OpenLoopRecord(fit_test, params)
    p, out, _, _ = refit_record(rec, params, free, None, max_nfev)
    fitted = {**{k: float(v) for k, v in params.items()},
              **{k: float(v) for k, v in zip(OE_PARAMETERS, p)}}
    rms = float(np.sqrt(np.mean(out.fun ** 2)))
    ok = bool(out.success and np.all(np.isfinite(out.x)) and p[0] > 0)
    return {"success": ok, "message": str(out.message), "parameters": fitted, "nfev": out.nfev,
            "free": list(free), "fit_rms_mm": rms,
            "eval": [open_loop_error(e.time_s, e.force_N, e.displacement_m, fitted)
                     for e in eval_tests]}


def _perturbed_starts(anchors: Sequence[tuple[str, Mapping[str, float]]], free: Sequence[str],
                      perturbations: int, spread: float, seed: int
                      ) -> list[tuple[str, dict[str, float]]]:
    """The anchors and, per anchor, ``perturbations`` draws with each free parameter
    multiplied by 1 + ``spread`` · N(0, 1) (inertia and viscous levels kept positive)."""
    rng = np.random.default_rng(seed)
    out = [(label, dict(p)) for label, p in anchors]
    for label, p in anchors:
        for j in range(perturbations):
            q = dict(p)
            for k in free:
                v = float(p.get(k, 0.0)) * (1.0 + spread * float(rng.standard_normal()))
                if k in ("inertia_kg", "nut_viscous_Ns_per_m", "nut_coulomb_N"):
                    v = max(v, 0.2 * abs(float(p.get(k, 1.0))))
                q[k] = v
            out.append((f"{label}, perturbed {j + 1}", q))
    return out


def output_error_multistart(fit_test, eval_test, anchors: Sequence[tuple[str, Mapping[str, float]]],
                            free: Sequence[str], *, blocks: int = 6,
                            min_train_fraction: float = 0.5, perturbations: int = 2,
                            spread: float = 0.15, seed: int = 0, max_nfev: int = 60) -> dict:
    """Output-error refit from several starts, the start *chosen by blocked
    cross-validation within the fit record*; the evaluation record only judges.

    Each start (the ``anchors`` — e.g. the inverse-model fit and the published
    reference — and seeded perturbations of each) is scored by blocked
    cross-validation on ``fit_test`` in its forward-chaining form (rolling origin): the
    record is cut into ``blocks`` contiguous blocks; for each block k that starts
    after ``min_train_fraction`` of the record the free
    parameters are refitted from the start on the blocks before block k, the open-loop
    simulation from the record's start is carried on through block k and its
    position error there collected.  Each block is thus judged by a simulation that
    has never seen it, run from the state the past left — the benchmark's own
    situation, and without the initial-state estimate a block simulated on its own
    would need.  The start with the smallest cross-validated RMS error is then
    refitted on the whole record (one open-loop simulation) and judged on
    ``eval_test``.

    Parameters
    ----------
    fit_test, eval_test : BenchTest
        The record the parameters are fitted and chosen on; the record judged.
    anchors : sequence of (label, params)
        Starting points (parameters outside ``free`` held at their values there; a
        drive lag applied to the force).
    free : sequence of str
        Names from :data:`OE_PARAMETERS` refitted.
    blocks : int
        Cross-validation blocks of the fit record (≥ 2).
    min_train_fraction : float
        The first judged block starts at this share of the record or later (a
        record's first seconds may not reverse the motion: what is learnt there does
        not extrapolate).
    perturbations, spread, seed :
        Perturbed starts per anchor, their relative spread (1 σ) and the seed.

    Returns
    -------
    dict with ``starts`` (per start: ``label``, ``cv_rms_mm``, ``cv_fold_rms_mm``,
    ``fit_rms_mm`` of the whole-record refit, ``eval_rms_mm`` — shown, never used
    for the choice —, ``parameters``, ``success``), ``chosen`` (index), ``result``
    (the chosen start's whole-record refit: ``parameters``, ``fit_rms_mm``,
    ``eval`` = :func:`~.openloop.open_loop_error` on ``eval_test``), ``intervals``
    (≈95 % Newey–West of the free parameters on the fit record's position error),
    ``covariance_info`` (N_eff, bandwidth) and ``blocks``.
    """
    from ..covariance import hac_covariance
    if int(blocks) < 2:
        raise ValueError(f"output_error_multistart: blocks={blocks}; use at least 2 "
                         "cross-validation blocks")
    unknown = [k for k in free if k not in OE_PARAMETERS]
    if unknown or not anchors:
        raise ValueError(f"output_error_multistart: unknown free parameters {unknown} "
                         f"(choose from {', '.join(OE_PARAMETERS)}) or no anchors")
    starts = _perturbed_starts(anchors, free, perturbations, spread, seed)
    # the drive lag (held) is the same for every start: one record
    rec = OpenLoopRecord(fit_test, starts[0][1])
    edges = [int(c[0]) for c in np.array_split(np.arange(rec.t.size), int(blocks))] + [rec.t.size]
    # the first fold trains on at least ``min_train_fraction`` of the record: a short
    # start of a record may not reverse, and nothing learnt there extrapolates
    first = max(1, int(math.ceil(min_train_fraction * int(blocks) - 1e-9)))
    rows = []
    for label, p0 in starts:
        sq, n, folds = 0.0, 0, []
        for k in range(first, int(blocks)):
            # forward chaining: fitted on the blocks before block k, the simulation
            # carried on through block k and judged there
            pk, _, _, _ = refit_record(rec, p0, free, edges[k], max_nfev)
            e = rec.residual(pk, edges[k + 1], edges[k]) if pk[0] > 0 else np.full(1, np.inf)
            folds.append(float(np.sqrt(np.mean(e ** 2))))
            sq += float(np.sum(e ** 2))
            n += e.size
        p, out, _, idx = refit_record(rec, p0, free, None, max_nfev)
        fitted = {**{k: float(v) for k, v in p0.items()},
                  **{k: float(v) for k, v in zip(OE_PARAMETERS, p)}}
        ok = bool(out.success and np.all(np.isfinite(out.x)) and p[0] > 0)
        ev = open_loop_error(eval_test.time_s, eval_test.force_N, eval_test.displacement_m,
                             fitted)
        rows.append({"label": label, "cv_rms_mm": float(np.sqrt(sq / max(n, 1))),
                     "cv_fold_rms_mm": folds,
                     "fit_rms_mm": float(np.sqrt(np.mean(out.fun ** 2))),
                     "eval_rms_mm": ev["rms_mm"], "eval": ev, "success": ok,
                     "parameters": fitted, "_p": p, "_res": out.fun})
    finite = [i for i, r in enumerate(rows) if np.isfinite(r["cv_rms_mm"])]
    chosen = min(finite or range(len(rows)), key=lambda i: rows[i]["cv_rms_mm"])
    best = rows[chosen]
    idx = [OE_PARAMETERS.index(k) for k in free]
    J = rec.jacobian(best["_p"])[:, idx]
    h = hac_covariance(J, best["_res"])
    sd = np.sqrt(np.clip(np.diag(h.cov), 0.0, None))
    intervals = {k: [float(best["_p"][i] - 1.96 * s), float(best["_p"][i] + 1.96 * s)]
                 for k, i, s in zip(free, idx, sd)}
    cov = {a: {b: float(h.cov[i, j]) for j, b in enumerate(free)} for i, a in enumerate(free)}
    for r in rows:
        del r["_p"], r["_res"]
    return {"starts": rows, "chosen": int(chosen), "blocks": int(blocks), "free": list(free),
            "result": {"parameters": best["parameters"], "fit_rms_mm": best["fit_rms_mm"],
                       "eval": best["eval"], "success": best["success"]},
            "intervals": intervals, "covariance": cov,
            "covariance_info": {"method": h.method, "n_eff": float(h.n_eff), "n": int(h.n),
                                "bandwidth_samples": int(h.bandwidth)}}


def output_error_rows(fit_test, eval_test, models: Sequence[tuple[str, Mapping[str, float]]],
                      *, blocks: int = 4, perturbations: int = 1, seed: int = 0
                      ) -> list[dict]:
    """The benchmark's metric after an output-error refit of each model in ``models``
    ((label, inverse-model parameters) pairs, e.g. the baseline and the model after
    each named effect): the port's inertia, viscous and Coulomb levels and offset
    are refitted on ``fit_test``'s simulated position — and the viscous asymmetry
    when the model has one —, a drive lag held at its value, by
    :func:`output_error_multistart` from the inverse-model parameters, the published
    IDIM-LS reference (:data:`~.openloop.EMPS_REFERENCE_PARAMETERS`; its
    direction-dependent values when the model has the asymmetry) and seeded
    perturbations of both, the start chosen by blocked cross-validation on
    ``fit_test``; judged once on ``eval_test``.

    One row per model: ``model``, ``success``, ``fit_rms_mm``, ``cv_rms_mm``,
    ``rms_mm``, ``percent_of_norm_q``, ``parameters``, ``chosen_start``, ``starts``
    (per start: ``label``, ``cv_rms_mm``, ``fit_rms_mm``, ``eval_rms_mm`` — the last
    shown, never used), ``intervals`` (≈95 % Newey–West), ``covariance_info`` and,
    with the asymmetry, ``direction_dependent`` (F_v± with intervals)."""
    from .openloop import EMPS_REFERENCE_DIRECTION_DEPENDENT, EMPS_REFERENCE_PARAMETERS
    rows = []
    for label, params in models:
        free = ["inertia_kg", "nut_viscous_Ns_per_m", "nut_coulomb_N", "offset_N"]
        ref = {**params, **EMPS_REFERENCE_PARAMETERS}
        if "asym_viscous_Ns_per_m" in params:
            free.append("asym_viscous_Ns_per_m")
            ref.update(EMPS_REFERENCE_DIRECTION_DEPENDENT)
        r = output_error_multistart(fit_test, eval_test,
                                    [("inverse model", dict(params)),
                                     ("published IDIM-LS", ref)], free, blocks=blocks,
                                    perturbations=perturbations, seed=seed)
        best = r["starts"][r["chosen"]]
        e = r["result"]["eval"]
        row = {"model": label, "success": r["result"]["success"],
               "fit_rms_mm": r["result"]["fit_rms_mm"], "cv_rms_mm": best["cv_rms_mm"],
               "rms_mm": e["rms_mm"], "percent_of_norm_q": e["percent_of_norm_q"],
               "chosen_start": best["label"], "blocks": r["blocks"],
               "starts": [{k: st[k] for k in ("label", "cv_rms_mm", "cv_fold_rms_mm",
                                              "fit_rms_mm", "eval_rms_mm", "success")}
                          for st in r["starts"]],
               "intervals": r["intervals"], "covariance_info": r["covariance_info"],
               "parameters": {k: r["result"]["parameters"][k] for k in (
                   *OE_PARAMETERS, "drive_lag_time_constant_s")
                   if k in r["result"]["parameters"]}}
        if "asym_viscous_Ns_per_m" in free:
            p, C = row["parameters"], r["covariance"]
            a, d = "nut_viscous_Ns_per_m", "asym_viscous_Ns_per_m"
            dd = {}
            for sign, tag in ((1.0, "pos"), (-1.0, "neg")):
                v = p[a] + sign * p[d]
                var = C[a][a] + C[d][d] + 2 * sign * C[a][d]
                sd = math.sqrt(var) if var >= 0 else math.nan
                dd[f"viscous_{tag}"] = v
                dd[f"viscous_{tag}_ci95"] = [v - 1.96 * sd, v + 1.96 * sd]
            row["direction_dependent"] = dd
        rows.append(row)
    return rows
