"""Confusion matrix of the model-discrepancy workflow on hidden-effect bench data.

For every candidate effect, synthetic 6-test directories (1, 2, 3 Hz × 15, 109 Ω, one
recorded cycle, noise 2 N / 0.05 V) are generated with the effect hidden at three
magnitudes (the last near the detection limit), plus clean data with two seeds; each
is diagnosed by ``run_discrepancy``.  Prints the confusion matrix, the held-out error
before/after of every case and the run time per case.

    python validation/discrepancy_confusion.py [--jobs J] [--out results/discrepancy_confusion.json]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from ehsa_opt.estimation.discrepancy import DiscrepancySettings, run_discrepancy
from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic

CASES: list[tuple[str, dict, int]] = [
    ("backlash", {"backlash_gap_m": 1e-4}, 1),
    ("backlash", {"backlash_gap_m": 4e-5}, 2),
    ("backlash", {"backlash_gap_m": 1.5e-5}, 3),
    ("asymmetric_friction", {"asym_coulomb_N": 8.0, "asym_viscous_Ns_per_m": 40.0}, 1),
    ("asymmetric_friction", {"asym_coulomb_N": 3.0, "asym_viscous_Ns_per_m": 15.0}, 2),
    ("asymmetric_friction", {"asym_coulomb_N": 1.0, "asym_viscous_Ns_per_m": 5.0}, 3),
    ("cogging", {"cogging_sin_Nm": 0.01}, 1),
    ("cogging", {"cogging_sin_Nm": 0.004, "cogging_cos_Nm": 0.002}, 2),
    ("cogging", {"cogging_cos_Nm": 0.0015}, 3),
    ("compliance", {"compliance_stiffness_N_per_m": 2e6}, 1),
    ("compliance", {"compliance_stiffness_N_per_m": 1e7}, 2),
    ("compliance", {"compliance_stiffness_N_per_m": 5e7}, 3),
    ("voltage_drop", {"voltage_drop_V": 0.7}, 1),
    ("voltage_drop", {"voltage_drop_V": 0.3}, 2),
    ("voltage_drop", {"voltage_drop_V": 0.1}, 3),
    ("winding_heating", {"winding_heating_K_per_J": 4.0}, 1),
    ("winding_heating", {"winding_heating_K_per_J": 1.5}, 2),
    ("winding_heating", {"winding_heating_K_per_J": 0.6}, 3),
    ("none", {}, 1),
    ("none", {}, 2),
]
LABELS = ["backlash", "asymmetric_friction", "cogging", "compliance", "voltage_drop",
          "winding_heating", "none"]


def small_spec(effect: str, params: dict, seed: int) -> SyntheticSpec:
    return SyntheticSpec(effects={} if effect == "none" else {effect: params},
                         frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(15.0, 109.0), cycles=1.0,
                         seed=seed)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default=None, help="also write the cases as JSON")
    ap.add_argument("--only", default=None, help="run only the cases of this hidden effect")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, (effect, params, seed) in enumerate(CASES):
            if args.only and effect != args.only:
                continue
            d = Path(tmp) / f"case{k}"
            write_synthetic(d, small_spec(effect, params, seed))
            t0 = time.perf_counter()
            res = run_discrepancy(d, DiscrepancySettings(jobs=args.jobs, seed=seed))
            dt = time.perf_counter() - t0
            rows.append({"truth": effect, "params": params, "seed": seed,
                         "diagnosed": res.effect, "error_before": res.error_before,
                         "error_after": res.error_after, "evaluation": res.evaluation,
                         "ranking": [c.effect for c in res.candidates], "seconds": dt})
            print(f"{effect:20s} {json.dumps(params):62s} -> {res.effect:20s} held-out error "
                  f"{res.error_before:7.3f} % -> {res.error_after:7.3f} %  ({dt:5.1f} s)",
                  flush=True)
    print("\nconfusion matrix (rows: hidden effect, columns: diagnosis)")
    print(" " * 20 + "".join(f"{c[:11]:>12s}" for c in LABELS))
    for t in LABELS:
        counts = [sum(1 for r in rows if r["truth"] == t and r["diagnosed"] == c) for c in LABELS]
        print(f"{t:20s}" + "".join(f"{n:12d}" for n in counts))
    ok = sum(r["truth"] == r["diagnosed"] for r in rows)
    print(f"\n{ok}/{len(rows)} correct; mean run {sum(r['seconds'] for r in rows) / len(rows):.1f} s "
          f"per 6-test directory (jobs={args.jobs})")
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
