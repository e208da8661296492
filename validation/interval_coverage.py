"""Coverage of the parameter intervals under coloured (autocorrelated) noise.

Synthetic EMPS-like records: the rig without generator (M a + offset + the friction
law), driven by a stretch of the measured EMPS position (its own bang-bang
trajectory), the force simulated with known parameters (the EMPS fit) plus AR(1)
noise, e_k = ρ e_{k−1} + w_k (the EMPS residual's correlation time is ≈ 240
samples).  Each data set is identified by the discrepancy workflow's baseline fit
(:func:`~ehsa_opt.estimation.discrepancy.fit.fit_group`) and its ≈95 % intervals
are checked against the truth: the Newey–West sandwich (what is reported) and, for
contrast, the independent-samples Gauss–Newton covariance.

The acceptance: with ≥ 50 data sets the 95 % intervals contain the truth 90–98 %
of the time (pooled over the four parameters; per parameter printed too, with
its binomial standard error).

    PYTHONPATH=. python validation/interval_coverage.py [--sets 60] [--rho 0.98]
        [--samples 8000] [--sigma-N 3]
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace

import numpy as np
from scipy.signal import lfilter

from ehsa_opt.datasets.bench_format import load_bench
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.estimation.discrepancy.fit import fit_group
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.rig import Rig, linear_baseline, predict

NAMES = ("inertia_kg", "nut_viscous_Ns_per_m", "nut_coulomb_N", "offset_N")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=60)
    ap.add_argument("--rho", type=float, default=0.98, help="AR(1) coefficient of the noise")
    ap.add_argument("--samples", type=int, default=8000)
    ap.add_argument("--sigma-N", type=float, default=3.0,
                    help="marginal standard deviation of the noise, N")
    ap.add_argument("--seed", type=int, default=2026)
    a = ap.parse_args()
    if a.sets < 1 or not 0 <= a.rho < 1 or a.samples < 500:
        raise SystemExit("interval_coverage: --sets >= 1, 0 <= --rho < 1, --samples >= 500")

    data = load_bench(embedded_data_dir("emps"))
    t0 = data.tests[0]
    k = slice(2000, 2000 + a.samples)  # a stretch of the measured trajectory
    test = replace(t0, time_s=t0.time_s[k], displacement_m=t0.displacement_m[k],
                   force_N=t0.force_N[k])
    rig = Rig(data.harvester, False, ())
    pt = prepare_tests([test], False)[0]
    truth_fit = fit_group([pt], rig, [linear_baseline([pt], rig)])
    truth = dict(truth_fit.parameters)
    clean = predict([pt], rig, truth)[0][0]
    rng = np.random.default_rng(a.seed)
    innov = a.sigma_N * math.sqrt(1 - a.rho ** 2)
    tau = (1 + a.rho) / (1 - a.rho)
    print(f"{a.sets} data sets: {a.samples} samples of the EMPS trajectory, AR(1) noise "
          f"rho {a.rho} (correlation time {tau:.0f} samples, N/tau = {a.samples / tau:.0f}), "
          f"marginal sigma {a.sigma_N} N; truth = the EMPS fit on that stretch")
    print("truth: " + ", ".join(f"{n} {truth[n]:.4g}" for n in NAMES))
    hit = {n: 0 for n in NAMES}
    hit_iid = {n: 0 for n in NAMES}
    infl, neff, bw, done = [], [], [], 0
    t_start = time.perf_counter()
    for s in range(a.sets):
        e = lfilter([1.0], [1.0, -a.rho], rng.normal(0.0, innov, a.samples + 2000))[2000:]
        noisy = replace(pt, y=np.vstack([clean + e]))
        fit = fit_group([noisy], rig, [truth])
        if not fit.parameters or fit.covariance is None or fit.covariance_info is None:
            print(f"set {s}: fit failed ({fit.message})")
            continue
        done += 1
        info = fit.covariance_info
        neff.append(info["n_eff"])
        bw.append(info["bandwidth_samples"])
        infl.append(np.median(info["inflation_over_iid"]))
        for n in NAMES:
            lo, hi = fit.interval(n)
            hit[n] += lo <= truth[n] <= hi
        # the independent-samples covariance, for contrast: s² (SᵀS)⁻¹ from the sandwich's
        # own inflation factors (HAC sd / iid sd per free parameter)
        for j, n in enumerate(fit.free):
            if n in NAMES:
                sd = math.sqrt(fit.covariance[j, j]) / info["inflation_over_iid"][j]
                hit_iid[n] += abs(fit.parameters[n] - truth[n]) <= 1.96 * sd
    secs = time.perf_counter() - t_start
    if not done:
        raise SystemExit("no data set was fitted")
    print(f"{done} data sets fitted in {secs:.0f} s; N_eff median {np.median(neff):.0f}, "
          f"bandwidth median {np.median(bw):.0f} samples, HAC/iid standard-error ratio median "
          f"{np.median(infl):.1f}")
    print("| parameter | Newey-West coverage | independent-samples coverage |")
    print("|---|---|---|")
    for n in NAMES:
        c, c0 = hit[n] / done, hit_iid[n] / done
        print(f"| {n} | {100 * c:.0f} % (± {100 * math.sqrt(c * (1 - c) / done):.0f}) | "
              f"{100 * c0:.0f} % |")
    pooled = sum(hit.values()) / (done * len(NAMES))
    pooled0 = sum(hit_iid.values()) / (done * len(NAMES))
    ok = 0.90 <= pooled <= 0.98
    print(f"pooled coverage of the 95 % intervals: Newey-West {100 * pooled:.1f} %, "
          f"independent samples {100 * pooled0:.1f} % -> "
          f"{'within' if ok else 'OUTSIDE'} the 90-98 % acceptance band")


if __name__ == "__main__":
    main()
