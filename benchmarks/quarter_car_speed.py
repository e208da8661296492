"""Speed of the quarter-car evaluation paths against fair baselines (issues 4 and 16).

1. Time domain with friction: a batch of designs on a class C road (compiled CasADi
   step, cached block graph, chunks of designs on 1 or 2 threads) against what a
   competent user writes with ``scipy.integrate.solve_ivp`` on the same model and road
   (road by linear interpolation, rtol 1e-6, atol 1e-9), one design each:

   * LSODA on the numpy right-hand side (stiffness switching, no Jacobian needed);
   * Radau with the analytic Jacobian of the same right-hand side from CasADi.

   Ratios are CPU seconds per design of the baseline ÷ CPU seconds per design of the
   batch (single-thread batch: no credit for threads), all measured in this run.
   Accuracy: mean generator power of each against the others (the ODE solvers are
   references of their own tolerance; the batch is second order at 1 kHz).
2. Memory: peak RSS of a fresh process simulating 100 designs on a 600 m road at
   100 km/h (default ``keep_series=False``; and with ``keep_series=True``).
3. Frequency domain (frictionless, exact): designs per second of
   :func:`ehsa_opt.vehicle.frequency_path.linear_metrics` on random designs in the paper's box.

Run from the repository root::

    python benchmarks/quarter_car_speed.py [--road-s 60] [--batch 64]
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth  # noqa: E402
from ehsa_opt.physics.friction import rod_friction_N  # noqa: E402
from ehsa_opt.physics.params import FrictionParams, HarvesterParams, RoadParams, VehicleParams  # noqa: E402
from ehsa_opt.physics.quarter_car_model import QuarterCarModel, param_vector  # noqa: E402
from ehsa_opt.vehicle.frequency_path import linear_metrics  # noqa: E402
from ehsa_opt.vehicle.road import synthesize_road  # noqa: E402
from ehsa_opt.vehicle.simulate import compiled_step, simulate_quarter_car  # noqa: E402


def numpy_rhs(vehicle, harvester, friction, t, x0):
    """The model's right-hand side in numpy, road by linear interpolation."""
    m2, m1 = vehicle.sprung_mass_kg, vehicle.unsprung_mass_kg
    k2, k1 = vehicle.suspension_stiffness_N_per_m, vehicle.tyre_stiffness_N_per_m
    meq, r = harvester.equivalent_mass_kg(), harvester.lead_m_per_rad
    ke, kt = harvester.voltage_constant_Vs_per_rad, harvester.torque_constant_Nm_per_A
    R, L = harvester.load_ohm + harvester.internal_resistance_ohm, harvester.inductance_H
    minv = np.linalg.inv(np.array([[m2 + meq, -meq], [-meq, m1 + meq]]))

    def rhs(tt, z):
        x2, x1, v2, v1, i = z
        road = np.interp(tt, t, x0)
        v = v2 - v1
        fd = kt * i / r + rod_friction_N(v, friction, r)
        f2 = -k2 * (x2 - x1) - fd
        f1 = k2 * (x2 - x1) + fd - k1 * (x1 - road)
        a2, a1 = minv @ np.array([f2, f1])
        return [v2, v1, a2, a1, (ke * v / r - R * i) / L]

    return rhs


def casadi_jacobian(vehicle, harvester, friction):
    """Analytic ∂f/∂z of the same model (CasADi), as a numpy-returning callable."""
    model = QuarterCarModel()
    z, x0 = ca.SX.sym("z", 5), ca.SX.sym("x0")
    p = param_vector(vehicle, harvester, friction)
    jac = ca.Function("dfdz", [z], [ca.jacobian(model.ode(z, x0, p), z)])
    return lambda tt, zz: jac(zz).full()


def run_baseline(method, vehicle, harvester, friction, t, x0, z0):
    rhs = numpy_rhs(vehicle, harvester, friction, t, x0)
    kw = {"jac": casadi_jacobian(vehicle, harvester, friction)} if method == "Radau" else {}
    c0 = time.process_time()
    sol = solve_ivp(rhs, (t[0], t[-1]), z0, method=method, t_eval=t, rtol=1e-6, atol=1e-9,
                    **kw)
    return time.process_time() - c0, sol


_MEMORY_CHILD = """
import json, resource, sys, time
def peak_MB():  # this process's high-water mark (ru_maxrss would include the parent's)
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
sys.path.insert(0, {root!r})
import numpy as np
from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
from ehsa_opt.physics.params import FrictionParams, HarvesterParams, RoadParams, VehicleParams
from ehsa_opt.vehicle.simulate import simulate_quarter_car
fr = FrictionParams(**load_truth(embedded_data_dir())["friction"])
hs = [HarvesterParams(load_ohm=float(r)) for r in np.geomspace(5, 500, 100)]
base = peak_MB()
t0 = time.perf_counter()
sim = simulate_quarter_car(VehicleParams(), hs, fr, RoadParams(length_m=600.0,
                           speed_km_per_h=100.0, seed=0), warn=False{extra})
print(json.dumps({{"peak_MB": peak_MB(), "before_MB": base,
                  "wall_s": time.perf_counter() - t0,
                  "ok": bool(sim.success)}}))
"""


def peak_rss(extra: str = "") -> dict:
    code = _MEMORY_CHILD.format(root=str(ROOT), extra=extra)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--road-s", type=float, default=60.0, help="road duration, s (default 60)")
    ap.add_argument("--batch", type=int, default=64, help="designs per batch (default 64)")
    ap.add_argument("--freq-designs", type=int, default=20000)
    ap.add_argument("--skip-memory", action="store_true")
    args = ap.parse_args()

    vehicle = VehicleParams()
    friction = FrictionParams(**load_truth(embedded_data_dir())["friction"])
    speed = 100.0
    road = RoadParams(iso_class="C", speed_km_per_h=speed, length_m=args.road_s * speed / 3.6,
                      seed=0)
    fs = 1000.0
    rng = np.random.default_rng(0)
    loads = rng.uniform(5.0, 200.0, args.batch)
    designs = [HarvesterParams(load_ohm=float(x)) for x in loads]

    w0 = time.perf_counter()
    compiled_step(1.0 / fs)
    t_compile = time.perf_counter() - w0  # gcc runs in a child process: wall time
    batch = {}
    for threads in (1, 2):
        warm = RoadParams(iso_class="C", speed_km_per_h=speed, length_m=50.0, seed=0)
        simulate_quarter_car(vehicle, designs, friction, warm, settle_s=0.0, sample_rate_hz=fs,
                             warn=False, threads=threads)  # builds the (cached) graphs
        c0, w0 = time.process_time(), time.perf_counter()
        sim = simulate_quarter_car(vehicle, designs, friction, road, settle_s=0.0,
                                   sample_rate_hz=fs, warn=False, threads=threads)
        batch[threads] = (time.process_time() - c0, time.perf_counter() - w0, sim)
    cpu1, wall1, sim = batch[1]
    cpu2, wall2, sim2 = batch[2]
    same = all(np.array_equal(sim.metrics[k], sim2.metrics[k], equal_nan=True)
               for k in sim.metrics)
    per_design = cpu1 / args.batch
    print(f"road: class C, {speed:g} km/h, {args.road_s:g} s, {sim.stats['steps']} steps at "
          f"{fs:g} Hz; friction = embedded data set's truth; compiled: {sim.stats['compiled']}"
          f" (one-off C compile {t_compile:.2f} s wall)")
    print(f"batch of {args.batch} designs with friction: 1 thread {cpu1:.2f} s CPU / "
          f"{wall1:.2f} s wall ({per_design * 1e3:.1f} ms CPU per design); 2 threads "
          f"{cpu2:.2f} s CPU / {wall2:.2f} s wall (wall x{wall1 / wall2:.2f}); identical "
          f"metrics: {same}")

    # Same signal as the batch (settle 0 on a periodic road: the road plus its first
    # sample again, starting at rest on the road's first elevation).
    prof = synthesize_road(road, fs)
    x0 = np.concatenate([prof.elevation_m, prof.elevation_m[:1]])
    t = np.arange(x0.size) / fs
    z0 = np.array([x0[0], x0[0], 0.0, 0.0, 0.0])
    h0 = designs[0]
    p_fast = float(sim.metrics["power_W"][0])
    powers = {"batch (1 kHz)": p_fast}
    ratios = {}
    for method, label in (("LSODA", "LSODA, numpy RHS"),
                          ("Radau", "Radau, numpy RHS + CasADi analytic Jacobian")):
        dt, sol = run_baseline(method, vehicle, h0, friction, t, x0, z0)
        p = float(np.mean(h0.load_ohm * sol.y[4][1:] ** 2))
        powers[method] = p
        ratios[method] = dt / per_design
        print(f"solve_ivp {label}: {dt:.1f} s CPU, nfev {sol.nfev}, njev {sol.njev}, "
              f"status {sol.status}; mean power {p:.4f} W, batch {p_fast:.4f} W "
              f"({100 * (p_fast / p - 1):+.3f} %)")
    print(f"LSODA vs Radau+Jacobian mean power: "
          f"{100 * (powers['LSODA'] / powers['Radau'] - 1):+.3f} %")
    print("time-domain speed-up per design (CPU, batch on 1 thread): "
          + ", ".join(f"x{r:.0f} vs {m}" for m, r in ratios.items())
          + f"; batch on 2 threads, wall time: x{ratios['LSODA'] * cpu1 / wall2:.0f} vs LSODA")

    if not args.skip_memory:
        d = peak_rss()
        s = peak_rss(", keep_series=True")
        print(f"memory, 100 designs on a 600 m road at 100 km/h: peak RSS {d['peak_MB']:.0f} MB "
              f"with the default keep_series=False (process before the batch "
              f"{d['before_MB']:.0f} MB; {d['wall_s']:.1f} s wall; acceptance < 600 MB); "
              f"{s['peak_MB']:.0f} MB with keep_series=True")

    n = args.freq_designs
    design = {"total_inertia_gcm2": rng.uniform(250, 1e4, n),
              "lead_mm_per_rev": rng.uniform(5, 20, n),
              "speed_constant_rpm_per_V": 10 ** rng.uniform(math.log10(29.8),
                                                            math.log10(11900), n),
              "load_ohm": 10 ** rng.uniform(0, 4, n)}
    road70 = RoadParams(iso_class="C", speed_km_per_h=70)
    linear_metrics(vehicle, road70, {k: v[:100] for k, v in design.items()})  # warm-up
    t0 = time.perf_counter()
    m = linear_metrics(vehicle, road70, design)
    dt = time.perf_counter() - t0
    dev = np.max(np.abs(m["dissipated_power_W"] / m["dissipation_bound_W"] - 1))
    print(f"frequency domain: {n} designs in {dt:.2f} s = {n / dt:,.0f} designs/s "
          f"(target >= 10,000); max |P_diss/bound - 1| = {100 * dev:.2f} %")


if __name__ == "__main__":
    main()
