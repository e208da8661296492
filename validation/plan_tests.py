"""Bench tests planned for the road against more tests of the paper's grid.

For the embedded data (the generator's truth: prototype friction with hidden backlash) and
four other friction truths on the same grid, hidden effects and noise:

1. identify the paper's 21-test campaign and build the sets (the friction band at 1 m/s
   is the band ``friction_bounds`` states: the best set ± the least-squares law's 95 %
   half-width plus the best set's distance to that law);
2. ``plan_tests`` for the passenger car on class C at 100 km/h (problem
   ``quarter_car_class_c``) on an MTS 835-like rig (stroke 100 mm, 1.5 m/s, 10 kN,
   6 kW, the paper's three loads, reversals of 50 ms): sines and constant-velocity
   triangle strokes (``sines`` on the command line: sines only), each weighted by the
   residual level the campaign's tests show at its stroke acceleration;
3. arm PLANNED: the 3 proposed tests simulated with the truth (generator, same hidden
   effects and noise, fresh seed; triangle strokes as recorded motions with the rig's
   reversal) added to the campaign; arm GRID: 3 more tests of the
   paper's grid added instead — its fastest tests (3.5 Hz x 15 mm at the three loads,
   fresh noise), the grid tests that carry most about high velocities;
4. identify each augmented campaign again and print the band at 1 m/s before and after,
   its narrowing, the ratio of the narrowings (acceptance: >= 2 on every truth), and
   whether the truth lies inside the band.

TUNING truths (the embedded data, T1, T2, T3: the planner and band were revised after
looking at them) and HELD-OUT truths (T4, T5, T6: fixed before the revised code first ran,
never used to choose anything) are printed and judged separately.

    python validation/plan_tests.py [tuning] [held-out] [sines]
"""

from __future__ import annotations

import dataclasses
import tempfile

import numpy as np
import time
from pathlib import Path

from ehsa_opt.datasets.bench_format import load_bench, write_bench
from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
from ehsa_opt.datasets.problem_file import load_problem
from ehsa_opt.datasets.protocols import Protocol
from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.design.test_plan import RigLimits, plan_tests, road_velocity_sigma
from ehsa_opt.estimation.bounds import friction_bounds
from ehsa_opt.estimation.identify import identify
from ehsa_opt.estimation.rod_law import RodLawFit
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.params import FrictionParams

#: Seen truths: the planner and band were revised after looking at their results.
#: name -> (friction truth, noise seed of its campaign)
TUNING = {"tuning T1 (heavier viscous)": (FrictionParams(40.0, 25.0, 0.015, 260.0,
                                                         0.03, 0.02, 2.0, 6e-5), 1036),
          "tuning T2 (Coulomb-heavy, light viscous)": (FrictionParams(90.0, 70.0, 0.005,
                                                                      60.0, 0.01, 0.008,
                                                                      0.5, 1e-5), 355),
          # seen: held out until the slow-sine failure, then the candidates' information
          # was revised after looking at it
          "tuning T3 (bearing-heavy)": (FrictionParams(30.0, 20.0, 0.01, 120.0,
                                                       0.06, 0.04, 1.0, 3e-5), 834)}
#: Fixed before any run of the revised planner (T4 before the previous revision, T5 and T6
#: before the effective-sample revision); never used to choose anything.
HELD_OUT = {"held-out T4 (strong Stribeck, medium viscous)": (FrictionParams(
                110.0, 60.0, 0.03, 150.0, 0.02, 0.015, 3.0, 2e-5), 658),
            "held-out T5 (light Coulomb, heavy viscous)": (FrictionParams(
                20.0, 12.0, 0.02, 320.0, 0.012, 0.008, 1.5, 8e-5), 2291),
            "held-out T6 (strong narrow Stribeck)": (FrictionParams(
                150.0, 50.0, 0.004, 180.0, 0.025, 0.02, 0.4, 2.5e-5), 4417)}
RIG = RigLimits(stroke_m=0.1, peak_velocity_m_per_s=1.5, force_N=10_000.0,
                actuator_power_W=6_000.0, loads_ohm=(15.0, 47.0, 109.0))
#: Test kinds the planner may propose (``sines`` on the command line: sines only)
KINDS = ("sine", "triangle")


def _tests(truth: dict, friction: FrictionParams, harvester, items, seed: int, prefix: str):
    """Simulate tests with the truth: (frequency, amplitude, load) of a sine, or
    ("triangle", velocity, amplitude, load) of constant-velocity strokes (reversal as the
    rig's)."""
    out = []
    for k, item in enumerate(items):
        common = dict(harvester=harvester, friction=friction,
                      effects=truth.get("effects", {}),
                      noise_force_N=truth["noise"]["force_N"],
                      noise_voltage_V=truth["noise"]["voltage_V"],
                      noise_displacement_m=truth["noise"]["displacement_m"], seed=seed + k)
        if item[0] == "triangle":
            _, v, a, r = item
            proto = Protocol("triangle", r, amplitude_m=a, velocity_m_per_s=v,
                             corner_s=0.5 * RIG.reversal_s)
            spec = SyntheticSpec(frequencies_hz=(), protocols=(proto,), **common)
        else:
            f, a, r = item
            spec = SyntheticSpec(frequencies_hz=(f,), loads_ohm=(r,), amplitude_m=a, **common)
        t = generate_bench_tests(spec)[0]
        out.append(dataclasses.replace(t, file=f"{prefix}{k}_{t.file}"))
    return out


def _band(data, truth_1: float) -> tuple[float, float, RodLawFit, object, dict]:
    """The band at 1 m/s as identification.json states it (the best set ± the law's
    half-width plus the best set's distance to the least-squares law), the sets' width
    there, the law, the bounds, and where the truth lies."""
    rep = identify(data, starts=2, seed=0)
    fb = friction_bounds(rep)
    law = RodLawFit.from_dict(fb.law)
    a = fb.at(1.0)
    lo = float(np.interp(1.0, fb.velocity_m_per_s, fb.law_band_N[0]))
    hi = float(np.interp(1.0, fb.velocity_m_per_s, fb.law_band_N[1]))
    info = {"best_N": a["best_N"], "law_N": float(law.rod_N(1.0)), "truth_N": truth_1,
            "inside": lo <= truth_1 <= hi,
            "statistical_N": float(law.half_width_N(1.0)[0]),
            "model_error_N": float(law.model_error_N(1.0)[0])}
    return 0.5 * (hi - lo), a["max_N"] - a["min_N"], law, fb, info


def run_truth(name: str, friction: FrictionParams | None, seed: int, root: Path) -> dict:
    emb = embedded_data_dir()
    truth = load_truth(emb)
    base = load_bench(emb)
    fr = friction or FrictionParams(**truth["friction"])
    if friction is not None:
        spec = SyntheticSpec(harvester=base.harvester, friction=fr, effects=truth["effects"],
                             noise_force_N=truth["noise"]["force_N"],
                             noise_voltage_V=truth["noise"]["voltage_V"],
                             noise_displacement_m=truth["noise"]["displacement_m"],
                             seed=seed)
        d = write_bench(root / "base", generate_bench_tests(spec), harvester=base.harvester,
                        rig={"name": name, "has_generator": True})
        # lenient as the augmented campaigns: a friction-dominated truth (T6) fails the
        # loader's plausibility check of the force against the harvester's inertia
        base = load_bench(d, lenient=True)
    t0 = time.perf_counter()
    truth_1 = float(rod_friction_N(1.0, fr.as_array(), base.harvester.lead_m_per_rad))
    hw0, sets0, law, fb, info0 = _band(base, truth_1)
    prob = load_problem("quarter_car_class_c")
    sigma = road_velocity_sigma(prob, fb.sets["best"])
    plan = plan_tests(law, RIG, base.harvester, sigma, n_tests=3, kinds=KINDS)
    planned = [(c.frequency_hz, c.amplitude_m, c.load_ohm) if c.kind == "sine" else
               ("triangle", c.velocity_m_per_s, c.amplitude_m, c.load_ohm)
               for c in plan.proposed]
    grid = [(3.5, 0.015, r) for r in (15.0, 47.0, 109.0)]
    out = {"name": name, "band0": hw0, "sets0": sets0, "plan": plan, "sigma": sigma,
           "info0": info0}
    for arm, items, seed in (("planned", planned, 7000), ("grid", grid, 8000)):
        extra = _tests(truth, fr, base.harvester, items, seed, f"{arm}_")
        d = write_bench(root / arm, list(base.tests) + extra, harvester=base.harvester,
                        rig={"name": f"{name} + {arm}", "has_generator": True})
        hw, sets, _, _, info = _band(load_bench(d, lenient=True), truth_1)
        out[arm] = (hw, sets, info)
    out["seconds"] = time.perf_counter() - t0
    return out


def _print(r: dict) -> bool:
    p = r["plan"]
    print(f"{r['name']}: road sigma_v {r['sigma']:.3f} m/s; proposed: "
          + "; ".join(f"{c.label()} [expected residual {st['predicted_residual_rms_N']:.0f} N"
                      f" on {st['effective_samples']:.0f} effective samples]"
                      for c, st in zip(p.proposed, p.steps)) + f" ({r['seconds']:.0f} s)")
    print(f"  statistical half-width at 1 m/s, predicted -> realised: before "
          f"+-{p.band_before_N[1]:.1f} -> +-{r['info0']['statistical_N']:.1f} N; after the "
          f"planned tests +-{p.band_after_N[1]:.1f} -> +-{r['planned'][2]['statistical_N']:.1f}"
          f" N")
    n_p = r["band0"] - r["planned"][0]
    n_g = r["band0"] - r["grid"][0]
    met = n_p > 0 and n_p >= 2 * n_g
    print(f"  band at 1 m/s (95 %): before +-{r['band0']:.1f} N; + 3 planned "
          f"+-{r['planned'][0]:.1f} N (narrowed {n_p:.1f}); + 3 grid "
          f"+-{r['grid'][0]:.1f} N (narrowed {n_g:.1f}); ratio "
          f"{(n_p / n_g) if n_g > 0 else float('inf'):.1f}"
          f" -> {'MET' if met else 'NOT met'} (>= 2)")
    for tag, info in (("before", r["info0"]), ("planned", r["planned"][2]),
                      ("grid", r["grid"][2])):
        print(f"    {tag:8s}: best {info['best_N']:.1f}, least-squares law {info['law_N']:.1f}"
              f" (+-{info['statistical_N']:.1f}; the weighted law's distance "
              f"{info['model_error_N']:.1f}), truth {info['truth_N']:.1f} N "
              f"-> truth {'inside' if info['inside'] else 'OUTSIDE'} the band")
    print(f"  min-max sets at 1 m/s: {r['sets0']:.1f} -> planned {r['planned'][1]:.1f}"
          f", grid {r['grid'][1]:.1f} N")
    return met


def main() -> None:
    import sys
    global KINDS
    only = [a for a in sys.argv[1:] if a != "sines"]
    if "sines" in sys.argv[1:]:
        KINDS = ("sine",)
    groups = {"TUNING": [("embedded data (generator's truth)", None, 0),
                         *((n, f, sd) for n, (f, sd) in TUNING.items())],
              "HELD-OUT": [(n, f, sd) for n, (f, sd) in HELD_OUT.items()]}
    with tempfile.TemporaryDirectory() as tmp:
        for g, cases in groups.items():
            if only and g.lower() not in [o.lower() for o in only]:
                continue
            print(f"== {g} truths ==")
            ok = True
            for k, (name, fr, seed) in enumerate(cases):
                r = run_truth(name, fr, seed, Path(tmp) / f"{g}{k}")
                ok &= _print(r)
            print(f"acceptance ({g.lower()} truths): {'MET' if ok else 'NOT met'}")


if __name__ == "__main__":
    main()
