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

from typing import Mapping, Sequence

import numpy as np

from .openloop import SKIP_SAMPLES, open_loop_error

__all__ = ["output_error_refit", "output_error_rows", "OE_PARAMETERS"]

#: The port's parameters in the order of the simulator's parameter vector.
OE_PARAMETERS = ("inertia_kg", "nut_viscous_Ns_per_m", "nut_coulomb_N", "offset_N",
                 "asym_viscous_Ns_per_m", "asym_coulomb_N")


def _simulator(n: int):
    """CasADi functions (q0, F[1×n−1], Δt[1×n−1], p[6]) → q[1×n] and → ∂q/∂p: RK4
    with the force held over each step."""
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
    U = ca.MX.sym("U", 1, n - 1)
    D = ca.MX.sym("D", 1, n - 1)
    P = ca.MX.sym("P", len(OE_PARAMETERS))
    X = sim(ca.vertcat(q0, 0.0), U, D, ca.repmat(P, 1, n - 1))
    qtraj = ca.horzcat(q0, X[0, :])
    return (ca.Function("q", [q0, U, D, P], [qtraj]),
            ca.Function("dq", [q0, U, D, P], [ca.jacobian(qtraj, P)]))


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
    from scipy.optimize import least_squares

    from .candidates.drive_lag import applied_force

    unknown = [k for k in free if k not in OE_PARAMETERS]
    if unknown:
        raise ValueError(f"output_error_refit: unknown free parameters {unknown} "
                         f"(choose from {', '.join(OE_PARAMETERS)})")
    t = np.asarray(fit_test.time_s, float)
    tau = float(params.get("drive_lag_time_constant_s", 0.0))
    delay = float(params.get("drive_delay_s", 0.0))
    F = applied_force(t, fit_test.force_N, tau, delay) if (tau or delay) else \
        np.asarray(fit_test.force_N, float)
    q = np.asarray(fit_test.displacement_m, float)
    p0 = np.array([float(params.get(k, 0.0)) for k in OE_PARAMETERS])
    idx = [OE_PARAMETERS.index(k) for k in free]
    scale = np.maximum(np.abs(p0[idx]), 1.0)
    sim, dsim = _simulator(t.size)
    U, D = F[:-1][None, :], np.diff(t)[None, :]

    def full(z):
        p = p0.copy()
        p[idx] = z * scale
        return p

    def res(z):
        qs = np.asarray(sim(float(q[0]), U, D, full(z))).ravel()
        return 1e3 * (qs - q)[SKIP_SAMPLES:]

    def jac(z):
        J = np.asarray(dsim(float(q[0]), U, D, full(z)))
        return 1e3 * J[SKIP_SAMPLES:, idx] * scale[None, :]

    z0 = p0[idx] / scale
    # tolerances: a relative change of 1e-6 in the parameters is far below their
    # intervals, and each iteration costs a simulation and its Jacobian
    out = least_squares(res, z0, jac=jac, method="trf", max_nfev=max_nfev, x_scale="jac",
                        ftol=1e-6, xtol=1e-6)
    p = full(out.x)
    fitted = {**{k: float(v) for k, v in params.items()},
              **{k: float(v) for k, v in zip(OE_PARAMETERS, p)}}
    rms = float(np.sqrt(np.mean(out.fun ** 2)))
    ok = bool(out.success and np.all(np.isfinite(out.x)) and p[0] > 0)
    return {"success": ok, "message": str(out.message), "parameters": fitted, "nfev": out.nfev,
            "free": list(free), "fit_rms_mm": rms,
            "eval": [open_loop_error(e.time_s, e.force_N, e.displacement_m, fitted)
                     for e in eval_tests]}


def output_error_rows(fit_test, eval_test, models: Sequence[tuple[str, Mapping[str, float]]]
                      ) -> list[dict]:
    """The benchmark's metric after an output-error refit of each model in ``models``
    ((label, inverse-model parameters) pairs, e.g. the baseline and the model after
    each named effect): the port's inertia, viscous and Coulomb levels and offset
    are refitted on ``fit_test``'s simulated position — and the viscous asymmetry
    when the model has one —, a drive lag held at its value; judged on
    ``eval_test``.  One row per model: ``model``, ``success``, ``fit_rms_mm``,
    ``rms_mm``, ``percent_of_norm_q``, ``parameters``."""
    rows = []
    for label, params in models:
        free = ["inertia_kg", "nut_viscous_Ns_per_m", "nut_coulomb_N", "offset_N"]
        if "asym_viscous_Ns_per_m" in params:
            free.append("asym_viscous_Ns_per_m")
        r = output_error_refit(fit_test, params, free, [eval_test])
        e = r["eval"][0]
        rows.append({"model": label, "success": r["success"], "message": r["message"],
                     "fit_rms_mm": r["fit_rms_mm"], "rms_mm": e["rms_mm"],
                     "percent_of_norm_q": e["percent_of_norm_q"],
                     "parameters": {k: r["parameters"][k] for k in (*OE_PARAMETERS,
                                    "drive_lag_time_constant_s") if k in r["parameters"]}})
    return rows
