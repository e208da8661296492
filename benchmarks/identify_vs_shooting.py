"""Benchmark: collocation/IPOPT identification against a plain shooting baseline.

Both identify the 8 friction parameters of each of the 21 synthetic tests (clean
data: no hidden effect, noise on) with the same seeded starts, the same
objective samples and the same minimax (epigraph of max(J_F, J_V) plus 0.1 ×
their mean):

* **ours** — :func:`ehsa_opt.identify.identify` (direct collocation, IPOPT with
  exact CasADi derivatives), ``--jobs`` processes;
* **baseline** — what a user would write: single shooting, the model's ODE
  integrated by ``scipy.integrate.solve_ivp`` (LSODA with the exact Jacobian — the
  winding current is stiff; BDF is 4.6× slower here)
  at every evaluation, and ``scipy.optimize.minimize(method="SLSQP")`` with
  finite-difference gradients on the same epigraph (the ``fminimax`` analogue),
  same ``--jobs`` processes.

Printed: wall time, median/worst rod-friction error against the truth over
0.1–1 × each test's peak velocity, median Eq 5 δ_F, and the speed ratio.

The baseline needs ~0.25 s per simulation and ~10 simulations per SLSQP
iteration (finite differences), minutes per start: all 84 starts would take
hours.  By default it runs on ``--baseline-tests`` tests spread over the matrix
with ``--baseline-starts`` starts each, and the ratio is taken per start (both
methods on the same tests and starts) and extrapolated to the 21 × 4 matrix —
printed as such.  ``--baseline-tests 21 --baseline-starts 4`` runs it all.

    python benchmarks/identify_vs_shooting.py [--starts 4] [--jobs 2] [--tests 21]
        [--baseline-tests 2] [--baseline-starts 1]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ehsa_opt.data import BenchData, load_bench  # noqa: E402
from ehsa_opt.friction import bearing_friction_Nm, nut_friction_N, rod_friction_N  # noqa: E402
from ehsa_opt.identify import (PARAMETER_BOUNDS, IdentifyOptions, _draw_start,  # noqa: E402
                               _node_indices, eq5_delta, identify, simulate_tests, test_motion)
from ehsa_opt.models import BenchModel  # noqa: E402
from ehsa_opt.params import FRICTION_NAMES  # noqa: E402
from ehsa_opt.synthetic import PROTOTYPE_FRICTION, SyntheticSpec, write_synthetic  # noqa: E402


def _shooting_fit(args):
    """Baseline for one test: single shooting + SLSQP from each start."""
    test, harvester, starts, seed, opt = args
    h = harvester
    r, J = h.lead_m_per_rad, h.total_inertia_kgm2
    Ke, Kt, L, Ri = (h.voltage_constant_Vs_per_rad, h.torque_constant_Nm_per_A,
                     h.inductance_H, h.internal_resistance_ohm)
    Re = test.load_ohm
    R = Re + Ri
    motion = test_motion(test, opt)
    n = test.n_samples
    ntrim = int(round(opt.trim_fraction * n))
    obs = np.arange(ntrim, n - ntrim)
    obs = obs[_node_indices(obs.size, opt.max_samples - 1)]
    t_obs = test.time_s[obs]
    x, v, a = motion.evaluate(t_obs)
    Fm, Vm = test.force_N[obs], test.voltage_V[obs]
    Fmax, Vmax = np.max(np.abs(test.force_N)), np.max(np.abs(test.voltage_V))
    sp = motion._spline.derivative(1)
    scale = np.array([PARAMETER_BOUNDS[k][2] for k in FRICTION_NAMES])
    lo = np.array([PARAMETER_BOUNDS[k][0] for k in FRICTION_NAMES]) / scale
    hi = np.array([PARAMETER_BOUNDS[k][1] for k in FRICTION_NAMES]) / scale

    def simulate(z):
        p = z * scale
        i0 = Ke * sp(test.time_s[0]) / r / R
        sol = solve_ivp(lambda t, i: (Ke * sp(t) / r - R * i) / L, (test.time_s[0], t_obs[-1]),
                        [i0], method="LSODA", t_eval=t_obs, rtol=1e-6, atol=1e-9,
                        jac=lambda t, i: [[-R / L]])
        i = sol.y[0]
        F = J * a / r ** 2 + Kt * i / r + nut_friction_N(v, p) + bearing_friction_Nm(v / r, p) / r
        return F, Re * i

    cache: dict = {}

    def Js(z):  # memoised: objective and constraint share one simulation
        key = z.tobytes()
        if key not in cache:
            F, V = simulate(z)
            cache.clear()
            cache[key] = np.array([np.mean(((F - Fm) / Fmax) ** 2),
                                   np.mean(((V - Vm) / Vmax) ** 2)])
        return cache[key]

    model = BenchModel(h)
    rng = np.random.default_rng(seed)
    best = None
    for k in range(starts):
        s = _draw_start(model, list(FRICTION_NAMES), rng, k)
        z0 = np.array([s[n] for n in FRICTION_NAMES]) / scale
        t0 = float(np.max(Js(z0)))
        w = opt.sum_weight
        cons = [{"type": "ineq", "fun": lambda y: y[-1] - Js(y[:-1])},
                {"type": "ineq", "fun": lambda y: np.array([y[0] * scale[0] - y[1] * scale[1],
                                                            y[4] * scale[4] - y[5] * scale[5]])}]
        res = minimize(lambda y: opt.objective_scale * (y[-1] + w * np.mean(Js(y[:-1]))),
                       np.append(z0, t0), method="SLSQP", constraints=cons,
                       bounds=list(zip(np.append(lo, 0), np.append(hi, np.inf))),
                       options={"maxiter": 200, "ftol": 1e-10})
        if res.success and (best is None or res.fun < best[1]):
            best = (res.x[:-1] * scale, res.fun)
    return None if best is None else dict(zip(FRICTION_NAMES, best[0]))


def _rod_errors(data: BenchData, params: list[dict | None]) -> tuple[list[float], list[float]]:
    r = data.harvester.lead_m_per_rad
    errs, deltas = [], []
    for t, p in zip(data.tests, params):
        if p is None:
            errs.append(np.inf)
            deltas.append(np.inf)
            continue
        v = np.linspace(0.1, 1.0, 50) * 2 * np.pi * t.frequency_hz * t.amplitude_m
        true = rod_friction_N(v, PROTOTYPE_FRICTION, r)
        est = rod_friction_N(v, [p[n] for n in FRICTION_NAMES], r)
        errs.append(100 * float(np.max(np.abs(est / true - 1))))
        pr = simulate_tests([t], data.harvester, p)[0]
        deltas.append(eq5_delta(pr.force_N, t.force_N))
    return errs, deltas


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=4)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--tests", type=int, default=21, help="first N of the 21 tests")
    ap.add_argument("--baseline-tests", type=int, default=2)
    ap.add_argument("--baseline-starts", type=int, default=1)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        write_synthetic(Path(tmp) / "d", SyntheticSpec(effects={}))
        data = load_bench(Path(tmp) / "d")
    data = BenchData(data.path, data.tests[:args.tests], data.harvester, data.rig_name,
                     data.description, data.has_generator)
    opt = IdentifyOptions()
    print(f"{len(data)} tests, {args.starts} starts each, {args.jobs} processes, "
          f"{opt.max_samples} objective samples per test at most")

    t0 = time.perf_counter()
    rep = identify(data, starts=args.starts, jobs=args.jobs, seed=0, options=opt, joint=False)
    t_ours = time.perf_counter() - t0
    ours = [f.parameters if f.success else None for f in rep.fits]
    e_ours, d_ours = _rod_errors(data, ours)
    print(f"collocation + IPOPT : {t_ours:8.1f} s  rod-friction error median "
          f"{np.median(e_ours):.2f} % worst {np.max(e_ours):.2f} %  δ_F median "
          f"{np.median(d_ours):.4f}  converged {sum(p is not None for p in ours)}/{len(data)}",
          flush=True)

    nb = max(1, min(args.baseline_tests, len(data)))
    pick = sorted({int(round(k)) for k in np.linspace(0, len(data) - 1, nb)})
    sub = [data.tests[k] for k in pick]
    sub_data = BenchData(data.path, sub, data.harvester, data.rig_name, data.description,
                         data.has_generator)
    bs = args.baseline_starts
    t0 = time.perf_counter()
    rep_s = identify(sub_data, starts=bs, jobs=args.jobs, seed=0, options=opt, joint=False)
    t_ours_sub = time.perf_counter() - t0
    e_os, d_os = _rod_errors(sub_data, [f.parameters if f.success else None for f in rep_s.fits])
    t0 = time.perf_counter()
    jobs = [(t, data.harvester, bs, k, opt) for k, t in zip(pick, sub)]
    with ProcessPoolExecutor(max_workers=args.jobs) as ex:
        base = list(ex.map(_shooting_fit, jobs))
    t_base = time.perf_counter() - t0
    e_base, d_base = _rod_errors(sub_data, base)
    names = ", ".join(t.file for t in sub)
    print(f"subset for the baseline: {names}; {bs} start(s) each")
    print(f"  collocation + IPOPT : {t_ours_sub:8.1f} s  rod-friction error median "
          f"{np.median(e_os):.2f} % worst {np.max(e_os):.2f} %  δ_F median {np.median(d_os):.4f}")
    print(f"  shooting + SLSQP    : {t_base:8.1f} s  rod-friction error median "
          f"{np.median(e_base):.2f} % worst {np.max(e_base):.2f} %  δ_F median "
          f"{np.median(d_base):.4f}  converged {sum(p is not None for p in base)}/{len(sub)}")
    ratio = t_base / t_ours_sub
    per_start = t_base * args.jobs / (len(sub) * bs)
    full = per_start * len(data) * args.starts / args.jobs
    print(f"speed ratio on the subset (baseline / ours): {ratio:.1f}x")
    print(f"baseline extrapolated to {len(data)} tests x {args.starts} starts on {args.jobs} "
          f"processes: {full:.0f} s (ours measured: {t_ours:.1f} s) -> {full / t_ours:.0f}x")


if __name__ == "__main__":
    main()
