"""Benchmark: identification speed and accuracy (issue 16.3), fair baselines.

Part 1 — rigid bench (held-out data: ``ehsa-opt bench generate DIR --seed 7``, no
hidden effect, noise on; not the default data's seed 2019).  21 tests × 4 starts:

* **ours** — :func:`ehsa_opt.estimation.identify.identify` (``joint=False``, one
  process): the automatic rigid path (current integrated once per test by a
  compiled Radau stepper, Eq 5 epigraph NLP in the 8 friction parameters on the
  estimation core, one NLP per objective-sample count), plus everything the report needs
  (per-test Eq 5 errors on the full grid, Fisher identifiability);
* **baseline** — what a competent user writes: the same smoothing-spline motion,
  the winding current integrated once per test (``scipy.integrate.solve_ivp``,
  Radau, on L di/dt = K_e v/r − R i), then ``scipy.optimize.least_squares`` (trf,
  2-point Jacobian, bounds) on the 8 scaled friction parameters from the same 4
  seeded starts, residuals (F_s − F_e)/max|F_e| on the same objective samples.
  For one test this is the same optimum as Eq 5's minimax: δ_V does not depend
  on friction on a rigid bench, so argmin of t + w·mean(J) is argmin J_F.

Printed: CPU seconds of both, the ratio, and the rod-friction error against the
truth over 0.1–1 × each test's peak velocity (median and worst over the tests).

Part 2 — embedded data (``data/bench_prototype``, hidden backlash, rigid model):
``identify`` with the collocation path forced against the pre-refactor code
(``--baseline-src``, run in a subprocess), and the automatic (rigid) path; CPU
seconds, ratios, and the largest per-test differences in force relative error
(percentage points) and rod friction (relative) against the pre-refactor numbers.

    PYTHONPATH=. python benchmarks/identify_speed.py [--tests 21] [--starts 4]
        [--embedded-tests 21] [--baseline-src /tmp/baseline/src] [--skip-embedded]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from scipy.integrate import solve_ivp  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from ehsa_opt.datasets.bench_format import load_bench  # noqa: E402
from ehsa_opt.datasets.synthetic import PROTOTYPE_FRICTION  # noqa: E402
from ehsa_opt.estimation.collocation import node_indices  # noqa: E402
from ehsa_opt.estimation.identify import IdentifyOptions, identify  # noqa: E402
from ehsa_opt.estimation.starts import draw_start  # noqa: E402
from ehsa_opt.estimation.identify_options import PARAMETER_BOUNDS, test_motion  # noqa: E402
from ehsa_opt.physics import BenchModel  # noqa: E402
from ehsa_opt.physics.friction import bearing_friction_Nm, nut_friction_N, rod_friction_N  # noqa: E402
from ehsa_opt.physics.params import FRICTION_NAMES  # noqa: E402


def rod_errors(tests, params_list, lead):
    errs = []
    for t, p in zip(tests, params_list):
        v = np.linspace(0.1, 1.0, 50) * 2 * np.pi * t.frequency_hz * t.amplitude_m
        true = rod_friction_N(v, PROTOTYPE_FRICTION, lead)
        est = rod_friction_N(v, [p[n] for n in FRICTION_NAMES], lead)
        errs.append(float(np.max(np.abs(est / true - 1))))
    return np.array(errs)


def baseline_fit(test, h, starts, seed, opt):
    """Integrate the current once; least_squares on the 8 friction parameters."""
    r, J = h.lead_m_per_rad, h.total_inertia_kgm2
    Ke, Kt, L, Ri = (h.voltage_constant_Vs_per_rad, h.torque_constant_Nm_per_A,
                     h.inductance_H, h.internal_resistance_ohm)
    R = test.load_ohm + Ri
    motion = test_motion(test, opt)
    vel = motion._spline.derivative(1)
    t = test.time_s
    sol = solve_ivp(lambda tt, i: (Ke * vel(tt) / r - R * i) / L, (t[0], t[-1]),
                    [Ke * vel(t[0]) / r / R], method="Radau", t_eval=t, rtol=1e-7, atol=1e-9,
                    jac=lambda tt, i: [[-R / L]])
    i_all = sol.y[0]
    n = test.n_samples
    ntrim = int(round(opt.trim_fraction * n))
    obs = np.arange(ntrim, n - ntrim)
    obs = obs[node_indices(obs.size, opt.max_samples - 1)]
    _, v, a = motion.evaluate(t[obs])
    known = J * a / r ** 2 + Kt * i_all[obs] / r
    Fm = test.force_N[obs]
    Fmax = np.max(np.abs(test.force_N))
    scale = np.array([PARAMETER_BOUNDS[k][2] for k in FRICTION_NAMES])
    lo = np.array([PARAMETER_BOUNDS[k][0] for k in FRICTION_NAMES]) / scale
    hi = np.array([PARAMETER_BOUNDS[k][1] for k in FRICTION_NAMES]) / scale

    def resid(z):
        p = z * scale
        F = known + nut_friction_N(v, p) + bearing_friction_Nm(v / r, p) / r
        return (F - Fm) / Fmax

    model = BenchModel(h)
    rng = np.random.default_rng(seed)
    best = None
    for k in range(starts):
        s = draw_start(model, list(FRICTION_NAMES), rng, k)
        z0 = np.clip(np.array([s[n] for n in FRICTION_NAMES]) / scale, lo, hi)
        res = least_squares(resid, z0, bounds=(lo, hi), method="trf", x_scale="jac")
        if best is None or res.cost < best.cost:
            best = res
    return dict(zip(FRICTION_NAMES, best.x * scale))


def part_rigid(args):
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp) / "rigid_seed7"
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        subprocess.run([sys.executable, "-m", "ehsa_opt", "bench", "generate", str(d),
                        "--seed", "7"], check=True, env=env, capture_output=True)
        data = load_bench(d)
    data = replace(data, tests=data.tests[:args.tests])
    lead = data.harvester.lead_m_per_rad
    t0 = time.process_time()
    rep = identify(data, starts=args.starts, seed=0, joint=False)
    ours_s = time.process_time() - t0
    assert all(f.success for f in rep.fits), [f.message for f in rep.fits]
    opt = IdentifyOptions.for_rig(True)
    t0 = time.process_time()
    base = [baseline_fit(t, data.harvester, args.starts, k, opt)
            for k, t in enumerate(data.tests)]
    base_s = time.process_time() - t0
    e_ours = rod_errors(data.tests, [f.parameters for f in rep.fits], lead)
    e_base = rod_errors(data.tests, base, lead)
    paths = sorted({f.path for f in rep.fits})
    print(f"== rigid bench, held-out data (seed 7): {len(data.tests)} tests x {args.starts} starts")
    print(f"ours (identify, {'/'.join(paths)} path, incl. report + identifiability): "
          f"{ours_s:7.2f} s CPU   rod-friction error median {np.median(e_ours):.2%} "
          f"worst {e_ours.max():.2%}")
    print(f"baseline (solve_ivp once + least_squares):                "
          f"{base_s:7.2f} s CPU   rod-friction error median {np.median(e_base):.2%} "
          f"worst {e_base.max():.2%}")
    print(f"speed-up ours vs baseline: {base_s / ours_s:.2f}x")


def _embedded_run(mode, n, src):
    code = f"""
import json, sys, time, dataclasses
import numpy as np
mode, n = {mode!r}, {n}
if mode == "old":
    from ehsa_opt.identify import identify
    from ehsa_opt.data import load_bench
    from ehsa_opt.friction import rod_friction_N
    from ehsa_opt.params import FRICTION_NAMES
    kw = {{}}
else:
    from ehsa_opt.estimation.identify import identify, IdentifyOptions
    from ehsa_opt.datasets.bench_format import load_bench
    from ehsa_opt.physics.friction import rod_friction_N
    from ehsa_opt.physics.params import FRICTION_NAMES
    kw = {{"options": IdentifyOptions(path=mode)}}
d = load_bench({str(ROOT / "data" / "bench_prototype")!r})
d = dataclasses.replace(d, tests=d.tests[:n])
t0 = time.process_time()
rep = identify(d, starts=4, seed=0, joint=False, **kw)
cpu = time.process_time() - t0
r = d.harvester.lead_m_per_rad
out = {{"cpu_s": cpu, "tests": {{}}}}
for t, f in zip(d.tests, rep.fits):
    v = np.linspace(0.1, 1.0, 50) * 2 * np.pi * t.frequency_hz * t.amplitude_m
    out["tests"][t.file] = {{"rel": f.force_relative_error_percent,
        "rod": rod_friction_N(v, [f.parameters[k] for k in FRICTION_NAMES], r).tolist()}}
print(json.dumps(out))
"""
    env = {**os.environ, "PYTHONPATH": src}
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         cwd=tempfile.gettempdir(),
                         check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def part_embedded(args):
    n = args.embedded_tests
    old = _embedded_run("old", n, args.baseline_src)
    print(f"\n== embedded data (data/bench_prototype, hidden backlash), {n} tests x 4 starts")
    print(f"pre-refactor code ({args.baseline_src}):      {old['cpu_s']:7.2f} s CPU")
    for mode in ("collocation", "auto"):
        new = _embedded_run(mode, n, str(ROOT))
        drel = max(abs(new["tests"][f]["rel"] - old["tests"][f]["rel"]) for f in old["tests"])
        drod = max(float(np.max(np.abs(np.array(new["tests"][f]["rod"])
                                       / np.array(old["tests"][f]["rod"]) - 1)))
                   for f in old["tests"])
        label = "collocation path (forced)" if mode == "collocation" else "auto (rigid path)  "
        print(f"ours, {label}:          {new['cpu_s']:7.2f} s CPU   speed-up "
              f"{old['cpu_s'] / new['cpu_s']:.2f}x   max |d force rel. error| {drel:.2e} pct-pt"
              f"   max rel. d rod friction {drod:.2e}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tests", type=int, default=21)
    ap.add_argument("--starts", type=int, default=4)
    ap.add_argument("--embedded-tests", type=int, default=21)
    ap.add_argument("--baseline-src", default="/tmp/baseline/src")
    ap.add_argument("--skip-embedded", action="store_true")
    args = ap.parse_args()
    from ehsa_opt.utils.process import single_threaded_blas
    with single_threaded_blas():  # both sides as the command line runs them
        part_rigid(args)
    if not args.skip_embedded:
        if Path(args.baseline_src, "ehsa_opt", "identify.py").is_file():
            part_embedded(args)
        else:
            print(f"\n(embedded comparison skipped: no pre-refactor tree at {args.baseline_src})")


if __name__ == "__main__":
    main()
