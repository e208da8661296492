"""Data-supported friction bounds (ehsa_opt.estimation.bounds) against the paper's
per-parameter bounds, on synthetic data with known friction (no hidden effect).

For each case: generate the bench data, identify every test (1 start), and report over
0.02-0.3 m/s whether the min/max sets' rod friction brackets the truth and their worst
deviation from it, for the data-supported sets and for the paper's method.

The method's choices (grid, 2 % tolerance on the joint fit, the weak pull of the bearing
factor) were set on the TUNING case; the HELD-OUT cases change seed, noise, friction
magnitude and nut/bearing split, and the test grid.  Quote the held-out figures.

    python validation/friction_bounds.py [--quick]
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from ehsa_opt.datasets.synthetic import PROTOTYPE_FRICTION, SyntheticSpec, write_synthetic
from ehsa_opt.estimation.bounds import friction_bounds
from ehsa_opt.estimation.identify import identify
from ehsa_opt.physics.friction import rod_friction_N

P = PROTOTYPE_FRICTION
TUNING = {"tuning: seed 11, prototype friction, 21 tests": SyntheticSpec(seed=11)}
HELD_OUT = {
    "held-out: seed 5, noise 4 N, friction x0.5": SyntheticSpec(
        seed=5, noise_force_N=4.0, friction=dataclasses.replace(
            P, nut_breakaway_N=0.5 * P.nut_breakaway_N, nut_coulomb_N=0.5 * P.nut_coulomb_N,
            nut_viscous_Ns_per_m=0.5 * P.nut_viscous_Ns_per_m,
            bearing_breakaway_Nm=0.5 * P.bearing_breakaway_Nm,
            bearing_coulomb_Nm=0.5 * P.bearing_coulomb_Nm,
            bearing_viscous_Nms_per_rad=0.5 * P.bearing_viscous_Nms_per_rad)),
    "held-out: seed 7, bearing-heavy split, 2 loads x 7 freqs": SyntheticSpec(
        seed=7, loads_ohm=(15.0, 109.0), friction=dataclasses.replace(
            P, nut_breakaway_N=25.0, nut_coulomb_N=15.0, nut_viscous_Ns_per_m=80.0,
            bearing_breakaway_Nm=0.04, bearing_coulomb_Nm=0.035,
            bearing_viscous_Nms_per_rad=6e-5, nut_breakaway_velocity_m_per_s=0.02)),
    # added after the grid's lower end was changed on the evidence of the first held-out
    # case (which is therefore no longer strictly held out): fresh seed, larger friction
    "held-out (fresh): seed 31, noise 1 N, friction x1.5, 3 loads x 4 freqs": SyntheticSpec(
        seed=31, noise_force_N=1.0, frequencies_hz=(0.75, 1.25, 2.25, 3.25),
        friction=dataclasses.replace(
            P, nut_breakaway_N=1.5 * P.nut_breakaway_N, nut_coulomb_N=1.5 * P.nut_coulomb_N,
            nut_viscous_Ns_per_m=1.5 * P.nut_viscous_Ns_per_m,
            bearing_breakaway_Nm=1.5 * P.bearing_breakaway_Nm,
            bearing_coulomb_Nm=1.5 * P.bearing_coulomb_Nm,
            bearing_viscous_Nms_per_rad=1.5 * P.bearing_viscous_Nms_per_rad)),
}


def evaluate(name: str, spec: SyntheticSpec, root: Path, quick: bool) -> None:
    if quick:
        spec = dataclasses.replace(spec, loads_ohm=spec.loads_ohm[:1])
    d = write_synthetic(root / name.split(":")[0].replace(" ", "_") / str(spec.seed), spec)
    t0 = time.perf_counter()
    rep = identify(d, starts=1, seed=0)
    fb = friction_bounds(rep)
    dt = time.perf_counter() - t0
    r = fb.lead_m_per_rad
    v = np.linspace(0.02, min(0.3, float(fb.velocity_m_per_s.max())), 57)
    truth = np.asarray(rod_friction_N(v, spec.friction, r))
    print(f"{name} ({len(rep.data.tests)} tests, identify + bounds {dt:.0f} s)")
    for label, sets in (("data-supported", fb.sets), ("paper's method", fb.paper_sets)):
        lo = np.asarray(rod_friction_N(v, sets["min"], r)) / truth
        hi = np.asarray(rod_friction_N(v, sets["max"], r)) / truth
        ok = bool(np.all(lo <= 1.0) and np.all(hi >= 1.0))
        print(f"  {label:<15s} brackets truth: {'yes' if ok else 'NO '}  min/truth "
              f"{lo.min():.3f}-{lo.max():.3f}  max/truth {hi.min():.3f}-{hi.max():.3f}  "
              f"worst deviation {100 * max(abs(lo - 1).max(), abs(hi - 1).max()):.1f} %")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one load per case (7 tests)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for group in (TUNING, HELD_OUT):
            for name, spec in group.items():
                evaluate(name, spec, Path(tmp), args.quick)


if __name__ == "__main__":
    main()
