"""Speed of the quarter-car evaluation paths (issue 4 acceptance).

1. Time domain with friction: a batch of 64 designs on a 60 s class C road
   (compiled CasADi step, mapaccum over time, map over designs) against a plain
   ``scipy.integrate.solve_ivp`` (Radau, numpy right-hand side, the same model)
   of one design on the same road.  Ratio = baseline s/design ÷ batch s/design.
2. Frequency domain (frictionless, exact): designs per second of
   :func:`ehsa_opt.metrics.linear_metrics` on random designs in the paper's box.

Run from the repository root::

    python benchmarks/quarter_car_speed.py [--baseline-designs 1] [--road-s 60]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ehsa_opt.datasets import embedded_data_dir, load_truth  # noqa: E402
from ehsa_opt.friction import rod_friction_N  # noqa: E402
from ehsa_opt.metrics import linear_metrics  # noqa: E402
from ehsa_opt.params import FrictionParams, HarvesterParams, RoadParams, VehicleParams  # noqa: E402
from ehsa_opt.quarter_car import compiled_step, simulate_quarter_car  # noqa: E402
from ehsa_opt.road import synthesize_road  # noqa: E402


def baseline_solve_ivp(vehicle, harvester, friction, t, x0, z0, method="Radau"):
    """Plain solve_ivp of the same model: numpy RHS, road by linear interpolation."""
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

    return solve_ivp(rhs, (t[0], t[-1]), z0, method=method, t_eval=t, rtol=1e-6,
                     atol=1e-9)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--road-s", type=float, default=60.0, help="road duration, s (default 60)")
    ap.add_argument("--batch", type=int, default=64, help="designs per batch (default 64)")
    ap.add_argument("--baseline-designs", type=int, default=1,
                    help="designs run by the solve_ivp baseline (default 1)")
    ap.add_argument("--freq-designs", type=int, default=20000)
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

    t0 = time.perf_counter()
    compiled_step(1.0 / fs)
    t_compile = time.perf_counter() - t0
    t0 = time.perf_counter()
    sim = simulate_quarter_car(vehicle, designs, friction, road, settle_s=0.0,
                               sample_rate_hz=fs, keep_series=False, warn=False)
    t_batch = time.perf_counter() - t0
    per_design = t_batch / args.batch
    print(f"road: class C, {speed:g} km/h, {args.road_s:g} s, {sim.stats['steps']} steps at "
          f"{fs:g} Hz; friction = embedded data set's truth; compiled: {sim.stats['compiled']}")
    print(f"batch ({args.batch} designs, with friction): {t_batch:.2f} s "
          f"({per_design * 1e3:.1f} ms/design), one-off compile {t_compile:.2f} s")

    # Same signal as the batch (settle 0 on a periodic road: the road plus its first
    # sample again, starting at rest on the road's first elevation).
    prof = synthesize_road(road, fs)
    x0 = np.concatenate([prof.elevation_m, prof.elevation_m[:1]])
    t = np.arange(x0.size) / fs
    z0 = np.array([x0[0], x0[0], 0.0, 0.0, 0.0])
    times = []
    for k in range(args.baseline_designs):
        t0 = time.perf_counter()
        sol = baseline_solve_ivp(vehicle, designs[k], friction, t, x0, z0)
        times.append(time.perf_counter() - t0)
        p_base = float(np.mean(designs[k].load_ohm * sol.y[4][1:] ** 2))
        p_fast = float(sim.metrics["power_W"][k])
        print(f"solve_ivp Radau, design {k}: {times[-1]:.1f} s, nfev {sol.nfev}, "
              f"status {sol.status}; mean power {p_base:.2f} W vs batch {p_fast:.2f} W "
              f"({100 * (p_fast / p_base - 1):+.2f} %)")
    base = float(np.mean(times))
    print(f"time-domain speed-up per design: {base / per_design:.0f}x "
          f"(baseline {base:.1f} s/design, batch {per_design * 1e3:.1f} ms/design; "
          "target >= 100x)")

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
