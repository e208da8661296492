"""Held-out check of the bench physics checks.

The tolerances of ``ehsa_opt.datasets.checks`` were set on the embedded prototype data
(seed 2019, backlash, the paper's 7 x 3 grid).  Here they are run on data they were not
tuned on: every hidden effect, other seeds, another grid (0.7-6 Hz, 8-300 ohm), another
amplitude, sample rate, noise level and harvester; plus the real EMPS data.  Prints the
estimated gains and whether each set passes; then breaks one held-out set in each way the
checks must catch and prints whether it is refused.

    PYTHONPATH=. python validation/bench_checks_heldout.py
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np

from ehsa_opt.datasets.bench_format import BenchDataError, load_bench, write_bench
from ehsa_opt.datasets.checks import estimate_sine
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.physics import COMPONENTS
from ehsa_opt.physics.params import HarvesterParams


def gains(data):
    h = data.harvester
    out = []
    for t in data.tests:
        if t.frequency_hz is None:
            continue
        est = estimate_sine(t.time_s, t.displacement_m)
        tt = t.time_s - t.time_s[0]
        v, a = est.velocity(tt), est.acceleration(tt)
        w = 2 * math.pi * est.frequency_hz
        c = h.equivalent_damping_Ns_per_m(w, t.load_ohm)
        basis = np.column_stack([h.equivalent_mass_kg() * a + c * v,
                                 np.tanh(v / (1e-3 * np.abs(v).max())), np.ones_like(v)])
        gf = np.linalg.lstsq(basis, t.force_N, rcond=None)[0][0]
        pred = h.voltage_constant_Vs_per_rad * v / h.lead_m_per_rad * t.load_ohm / (
            t.load_ohm + h.internal_resistance_ohm)
        gv = float(pred @ t.voltage_V) / float(pred @ pred)
        out.append((est.frequency_hz / t.frequency_hz - 1, est.amplitude_m / t.amplitude_m - 1,
                    gf, gv))
    return np.array(out)


def main() -> int:
    tmp = Path(tempfile.mkdtemp())
    grid = dict(frequencies_hz=(0.7, 2.2, 6.0), loads_ohm=(8.0, 300.0))
    cases = [(f"{e}, seed {11 + k}", SyntheticSpec(effects={e: {}}, seed=11 + k, **grid))
             for k, e in enumerate(COMPONENTS)]
    cases += [("no effect, 10 mm, 2 kHz, 1.5 cycles, noise x3",
               SyntheticSpec(amplitude_m=0.01, sample_rate_hz=2000.0, cycles=1.5,
                             noise_force_N=6.0, noise_voltage_V=0.15, seed=5, **grid)),
              ("other harvester (lead 10 mm, K_e 0.2)",
               SyntheticSpec(harvester=HarvesterParams(lead_mm_per_rev=10.0,
                                                       voltage_constant_Vs_per_rad=0.2,
                                                       torque_constant_Nm_per_A=0.2),
                             seed=6, **grid))]
    failures = 0
    print(f"{'held-out case':48s} {'max|df|%':>8s} {'max|dA|%':>8s} {'F gain':>13s} "
          f"{'V gain':>13s}  verdict")
    for label, spec in cases:
        d = write_bench(tmp / label.split(",")[0].replace(" ", "_"), generate_bench_tests(spec),
                        harvester=spec.harvester, rig={"name": "held-out"}, overwrite=True)
        try:
            data = load_bench(d)
            verdict = "pass"
        except BenchDataError as exc:
            failures += 1
            verdict = f"REFUSED: {str(exc).splitlines()[0]}"
            data = load_bench(d, lenient=True)
        g = gains(data)
        print(f"{label:48s} {100 * np.abs(g[:, 0]).max():8.3f} {100 * np.abs(g[:, 1]).max():8.2f} "
              f"{g[:, 2].min():6.2f}-{g[:, 2].max():<6.2f} {g[:, 3].min():6.3f}-{g[:, 3].max():<6.3f}"
              f"  {verdict}")
    for name in ("emps", "emps/validation"):
        load_bench(embedded_data_dir(name))
        print(f"{'EMPS ' + name:48s} {'':8s} {'':8s} {'':13s} {'':13s}  pass")
    print(f"\n{failures} held-out valid data sets refused (expected 0)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
