"""CVODES cost of a recorded (sampled) test: the motion as linear interpolants of the
sampled x, v, a (the representation before) against the smoothing spline itself (the
current one), in the same run, beside a sine test of the same length.

A multisine record (3 001 samples at 1 kHz, 0.5 um displacement noise, differentiated
by the recorded motion's own smoothing spline at 60 Hz, as the workflow does) drives
the rigid rig, a backlash (0.15 mm, contact 1e8 and 1e9 N/m) and a mount compliance.
For each rig and representation: wall time of one simulation (best of ``--repeat``,
the integrator built each call as the fits do), CVODES steps and error-test failures,
and the noise-normalised rms difference of the outputs (force 1.5 N, voltage 20 mV)
to the same representation at rtol 1e-10 and between the two representations.

    PYTHONPATH=. flock /tmp/ehsa-heavy.lock python benchmarks/recorded_motion_cvodes.py
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ehsa_opt import BenchModel, HarvesterParams, SineMotion  # noqa: E402
from ehsa_opt.datasets.synthetic import PROTOTYPE_FRICTION  # noqa: E402
from ehsa_opt.physics import bench_sim  # noqa: E402
from ehsa_opt.physics.components import make_component  # noqa: E402
from ehsa_opt.physics.motion import MultisineMotion, SampledMotion  # noqa: E402

SIGMA = np.array([1.5, 0.02])


class LinearInterpolated:
    """The representation before: CasADi linear interpolants of the spline's x, v, a
    on the sample grid (a corner in every quantity at every sample)."""

    def __init__(self, motion: SampledMotion) -> None:
        self.motion = motion
        self.time_s = motion.time_s
        self.max_step_s = motion.max_step_s

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        return self.motion.evaluate(t)

    def expressions(self, t):
        xva = self.motion.evaluate(self.time_s)
        grid = [self.time_s.tolist()]
        return tuple(ca.interpolant(f"motion_{k}", "linear", grid, xva[k].tolist())(t)
                     for k in range(3))


def run(model: BenchModel, motion, p: np.ndarray, t: np.ndarray, rtol: float = 1e-7,
        repeat: int = 3) -> tuple[float, dict, np.ndarray]:
    """Best wall time of ``repeat`` simulations, CVODES statistics, outputs (2, N)."""
    best, sim = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        sim = bench_sim.simulate_bench(model, motion, p, t, rtol=rtol, atol=rtol * 1e-2)
        best = min(best, time.perf_counter() - t0)
    F = bench_sim._integrator(model, motion, t, rtol, rtol * 1e-2)
    pall = np.concatenate([p, [motion.amplitude_m, motion.frequency_hz, motion.phase_rad]]) \
        if isinstance(motion, SineMotion) else p
    F(x0=model.initial_state(motion.evaluate(t[:1])[:, 0], p), p=pall)
    st = F.stats()
    return best, {"steps": int(st.get("nsteps", -1)), "fails": int(st.get("netfails", -1))}, \
        np.vstack([sim.force_N, sim.voltage_V])


def rms_sigma(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.sqrt(np.mean(((a - b) / SIGMA[:, None]) ** 2, axis=1))))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=3001)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(7)
    n = args.samples
    t = np.arange(n) * 1e-3
    f = 0.5 * np.arange(1, 9)
    exact = MultisineMotion(0.012 / f / f.size ** 0.5 / 2, f, rng.uniform(0, 2 * np.pi, f.size))
    x = exact.evaluate(t)[0] + rng.normal(0.0, 0.5e-6, n)
    recorded = SampledMotion.with_cutoff(t, x, 60.0)
    old = LinearInterpolated(recorded)
    sine = SineMotion(0.01, 1.5)
    h = HarvesterParams()
    rigs = [("rigid", (), {}),
            ("backlash 0.15 mm, 1e8 N/m", (make_component("backlash"),),
             {"backlash_gap_m": 1.5e-4, "backlash_contact_stiffness_N_per_m": 1e8,
              "backlash_contact_damping_Ns_per_m": 3e3}),
            ("backlash 0.15 mm, 1e9 N/m", (make_component("backlash"),),
             {"backlash_gap_m": 1.5e-4, "backlash_contact_stiffness_N_per_m": 1e9,
              "backlash_contact_damping_Ns_per_m": 3e3}),
            ("compliance 5e5 N/m", (make_component("compliance"),),
             {"compliance_stiffness_N_per_m": 5e5, "compliance_damping_Ns_per_m": 400.0})]
    print(f"recorded multisine, {n} samples at 1 kHz (8 components 0.5-4 Hz, 0.5 um noise, "
          f"spline at 60 Hz); one CVODES simulation at rtol 1e-7, best of {args.repeat}")
    print(f"{'rig':28s} {'sine':>16s} {'linear interpolants':>26s} {'smoothing spline':>26s} "
          f"{'ratio':>6s} {'old-new':>8s} {'err old':>8s} {'err new':>8s}")
    for name, comps, vals in rigs:
        model = BenchModel(h, comps)
        p = model.param_vector(10.0, PROTOTYPE_FRICTION, vals)
        ts, ss, _ = run(model, sine, p, t, repeat=args.repeat)
        to, so, yo = run(model, old, p, t, repeat=args.repeat)
        tn, sn, yn = run(model, recorded, p, t, repeat=args.repeat)
        _, _, yo_ref = run(model, old, p, t, rtol=1e-10, repeat=1)
        _, _, yn_ref = run(model, recorded, p, t, rtol=1e-10, repeat=1)
        print(f"{name:28s} {ts:6.2f} s {ss['steps']:6d} st "
              f"{to:6.2f} s {so['steps']:6d} st {so['fails']:5d} fl "
              f"{tn:6.2f} s {sn['steps']:6d} st {sn['fails']:5d} fl "
              f"{to / tn:5.1f}x {rms_sigma(yo_ref, yn_ref):8.3f} {rms_sigma(yo, yo_ref):8.3f} "
              f"{rms_sigma(yn, yn_ref):8.3f}")
    print("st: CVODES steps, fl: error-test failures; old-new: rms difference of the two "
          "representations at rtol 1e-10; err: rms difference at rtol 1e-7 to the same "
          "representation at rtol 1e-10 (in noise std: force 1.5 N, voltage 20 mV)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
