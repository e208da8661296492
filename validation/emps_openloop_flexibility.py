"""Can a two-mass flexibility show in the EMPS benchmark's own metric?

The open-loop metric simulates the position from the measured force.  A flexibility
(the driven side, whose position the motor encoder measures, joined to a load by a
spring and damper) acts at its resonance; the pulses of the validation record excite
it.  This script asks two questions on the EMPS records, with the rigid port of
:mod:`ehsa_opt.estimation.discrepancy.openloop` as the reference:

1. *Sensitivity.*  With the published IDIM-LS parameters, how much does a flexibility
   (resonance f, load mass m₂ of the total M, damping ratio ζ) change the simulated
   driven-side position on the validation record (RMS, mm), and its acceleration
   (RMS, % of the measured one)?
2. *Output-error refit.*  With the load mass free beside the port's M, F_v, F_C and
   offset, fitted on the estimation record's simulated position at a few resonances:
   does the fit error fall, and what does the validation record say?

The two-mass model (friction on the driven side, where the force acts):

    (M − m₂) ẅ₁ = F − F_v ẋ₁ − F_C sign ẋ₁ − offset − k (x₁ − x₂) − c (ẋ₁ − ẋ₂)
          m₂ ẅ₂ = k (x₁ − x₂) + c (ẋ₁ − ẋ₂),   k = m₂ ω², c = 2 ζ m₂ ω

integrated like the port (RK4 on the sample grid, the force held over each step),
under the benchmark's protocol: both masses start at the position and velocity a
quadratic fit of the first 20 measured positions gives
(:func:`~ehsa_opt.estimation.discrepancy.initial_state.initial_state`), and the
error is scored from sample 20 on.

    PYTHONPATH=. python validation/emps_openloop_flexibility.py
"""

from __future__ import annotations

import math
import os
import time

import casadi as ca
import numpy as np
from scipy.optimize import least_squares

from ehsa_opt.datasets.bench_format import load_bench
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.estimation.discrepancy.initial_state import initial_state
from ehsa_opt.estimation.discrepancy.openloop import (
    BEST_PUBLISHED_MM,
    EMPS_REFERENCE_PARAMETERS,
    SKIP_SAMPLES,
)

#: parameter vector: M, F_v, F_C, offset, m₂, f (Hz), ζ
NAMES = ("inertia_kg", "nut_viscous_Ns_per_m", "nut_coulomb_N", "offset_N", "load_mass_kg",
         "frequency_hz", "damping_ratio")


def simulator(n: int) -> tuple[ca.Function, ca.Function]:
    """(F[1×n−1], Δt[1×n−1], (q0, v0), p[7]) → the driven side's trajectory (2 × n:
    x₁, ẋ₁), both masses started at (q0, v0), and the Jacobian of x₁ in p."""
    x = ca.SX.sym("x", 4)
    u, dt = ca.SX.sym("u"), ca.SX.sym("dt")
    p = ca.SX.sym("p", len(NAMES))
    M, fv, fc, off, m2, f, z = (p[i] for i in range(7))
    w = 2 * math.pi * f
    k, c = m2 * w * w, 2 * z * m2 * w

    def rhs(s):
        q1, v1, q2, v2 = s[0], s[1], s[2], s[3]
        fs = k * (q1 - q2) + c * (v1 - v2)
        a1 = (u - fv * v1 - fc * ca.sign(v1) - off - fs) / (M - m2)
        a2 = fs / m2
        return ca.vertcat(v1, a1, v2, a2)

    k1 = rhs(x)
    k2 = rhs(x + 0.5 * dt * k1)
    k3 = rhs(x + 0.5 * dt * k2)
    k4 = rhs(x + dt * k3)
    step = ca.Function("step", [x, u, dt, p], [x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])
    sim = step.mapaccum("sim", n - 1)
    U, D = ca.MX.sym("U", 1, n - 1), ca.MX.sym("D", 1, n - 1)
    q0, P = ca.MX.sym("q0", 2), ca.MX.sym("P", len(NAMES))
    X = sim(ca.vertcat(q0[0], q0[1], q0[0], q0[1]), U, D, ca.repmat(P, 1, n - 1))
    traj = ca.horzcat(q0, X[0:2, :])
    return (ca.Function("q", [U, D, q0, P], [traj]),
            ca.Function("dq", [U, D, q0, P], [ca.jacobian(traj[0, :], P)]))


def start(test) -> tuple[int, list[float]]:
    """The simulation's first sample and state (q0, v0) from the first 20 positions."""
    st = initial_state(test.time_s, test.displacement_m)
    return st.index, [st.position_m, st.velocity_m_per_s]


def rms_mm(q_sim: np.ndarray, q: np.ndarray) -> float:
    """RMS error from sample 20 of a simulation started at the state's sample."""
    e = q_sim[SKIP_SAMPLES - (q.size - q_sim.size):] - q[SKIP_SAMPLES:]
    return 1e3 * float(np.sqrt(np.mean(e ** 2)))


def main() -> None:
    t0 = time.perf_counter()
    est = load_bench(embedded_data_dir("emps")).tests[0]
    val = load_bench(os.path.join(embedded_data_dir("emps"), "validation")).tests[0]
    R = EMPS_REFERENCE_PARAMETERS
    rigid_like = [R["inertia_kg"], R["nut_viscous_Ns_per_m"], R["nut_coulomb_N"], R["offset_N"]]
    kv, x0v = start(val)
    sim_v, _ = simulator(val.time_s.size - kv)
    U, D = val.force_N[kv:-1][None, :], np.diff(val.time_s[kv:])[None, :]
    q_v = np.asarray(val.displacement_m, float)
    fs = 1.0 / float(np.median(np.diff(val.time_s)))

    def acc(x):
        a = np.zeros_like(x)
        a[1:-1] = (x[2:] - 2 * x[1:-1] + x[:-2]) * fs * fs
        return a

    a_meas = acc(q_v[kv:])
    # the rigid port: a vanishing load (1e-6 kg) on a stiff spring
    base = np.array(sim_v(U, D, x0v, rigid_like + [1e-6, 100.0, 0.1]))
    print(f"rigid port, published IDIM-LS parameters: {rms_mm(base[0], q_v):.2f} mm on the "
          f"validation record (best published {BEST_PUBLISHED_MM} mm)")
    print("\n1. sensitivity (published parameters, ζ = 0.05): the flexibility's change of the "
          "simulated driven-side position and acceleration on the validation record")
    print("| f (Hz) | m₂ (kg) | Δ position RMS (mm) | metric (mm) | Δ acceleration RMS "
          "(% of measured) |\n|---|---|---|---|---|")
    for f in (50.0, 115.0, 200.0):
        for m2 in (5.0, 20.0, 45.0):
            tr = np.array(sim_v(U, D, x0v, rigid_like + [m2, f, 0.05]))
            dq = 1e3 * float(np.sqrt(np.mean((tr[0] - base[0])[SKIP_SAMPLES - kv:] ** 2)))
            da = float(np.linalg.norm(acc(tr[0]) - acc(base[0])) / np.linalg.norm(a_meas))
            print(f"| {f:.0f} | {m2:.0f} | {dq:.3f} | {rms_mm(tr[0], q_v):.2f} | "
                  f"{100 * da:.1f} |")

    print("\n2. output-error refit on the estimation record (M, F_v, F_C, offset and m₂ free, "
          "ζ = 0.1, from the published values and m₂ = 10 kg), judged on the validation record")
    ke, x0e = start(est)
    sim_e, dsim_e = simulator(est.time_s.size - ke)
    Ue, De = est.force_N[ke:-1][None, :], np.diff(est.time_s[ke:])[None, :]
    q_e = np.asarray(est.displacement_m, float)[ke:]
    print("| model | fit error, estimation (mm) | validation (mm) | M | m₂ (kg) |\n"
          "|---|---|---|---|---|")
    for f in (None, 50.0, 115.0, 200.0):
        p0 = np.array(rigid_like + [10.0 if f else 1e-6, f or 100.0, 0.1])
        idx = [0, 1, 2, 3, 4] if f else [0, 1, 2, 3]
        sc = np.maximum(np.abs(p0[idx]), 1.0)

        def full(zz, p0=p0, idx=idx, sc=sc):
            p = p0.copy()
            p[idx] = zz * sc
            return p

        def res(zz):
            tr = np.asarray(sim_e(Ue, De, x0e, full(zz)))[0]
            return 1e3 * (tr - q_e)[SKIP_SAMPLES - ke:]

        def jac(zz):
            J = np.asarray(dsim_e(Ue, De, x0e, full(zz)))
            return 1e3 * J[SKIP_SAMPLES - ke:][:, idx] * sc[None, :]

        lb = np.full(len(idx), -np.inf)
        ub = np.full(len(idx), np.inf)
        if f:  # 0 < m₂ < M / 2
            lb[4], ub[4] = 1e-3 / sc[4], 0.5 * R["inertia_kg"] / sc[4]
        out = least_squares(res, p0[idx] / sc, jac=jac, bounds=(lb, ub), method="trf",
                            x_scale="jac", ftol=1e-6, xtol=1e-6, max_nfev=60)
        p = full(out.x)
        tr = np.array(sim_v(U, D, x0v, p))
        label = "rigid" if f is None else f"two-mass, {f:.0f} Hz"
        print(f"| {label} | {float(np.sqrt(np.mean(out.fun ** 2))):.3f} | "
              f"{rms_mm(tr[0], q_v):.2f} | {p[0]:.2f} | {p[4] if f else 0.0:.3g} |")
    print(f"\n{time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
