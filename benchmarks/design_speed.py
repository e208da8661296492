"""Benchmark of the design machinery (issues: optimal design; 16 item 4).

Prints
  1. NSGA-II against plain pymoo on the same Problem (problems/paper_design.toml in the
     paper's space, ``[motor] model = "paper"``: continuous variables plain pymoo takes;
     the shipped file chooses catalogue hardware, discrete variables ``run_nsga2`` handles):
     ``pymoo.optimize.minimize(problem, NSGA2(pop_size=100), ("n_gen", 100), seed=1)``
     against ``run_nsga2`` 100 x 100 (archive, hypervolume per generation) and
     ``run_nsga2`` 100 x 20; CPU time (``time.process_time``), median of 3 runs, both
     ratios from this one run (acceptance: ours / pymoo <= 1.3, 100 x 100 / 100 x 20
     <= 5.5), plus the cost of a checkpoint every generation and the vectorised
     evaluation against one design per call;
  2. hypervolume against evaluations (normalised F / F(prototype), reference 2);
  3. checkpoint/resume after 12 of 25 generations: pareto.csv identical?;
  4. a frequency-path sweep and 5. a time-domain friction sweep on 1 local job,
     2 local processes and a Dask LocalCluster: times, speed-up against the single
     job, and whether the tidy CSVs are identical.

Run from the repository root:  python benchmarks/design_speed.py [--only-nsga2]
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ehsa_opt.design import run_nsga2  # noqa: E402
from ehsa_opt.design.config import load_design_config  # noqa: E402
from ehsa_opt.design.optimize import build_problem, goals_and_weights  # noqa: E402
from ehsa_opt.design import OBJECTIVE_NAMES  # noqa: E402
from ehsa_opt.design.sweep import parse_sweep, rows_to_csv, run_sweep  # noqa: E402


def cpu_median(fn, repeats: int = 3) -> tuple[float, object]:
    """Median CPU time of ``fn()`` over ``repeats`` runs, and the last result."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return statistics.median(times), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only-nsga2", action="store_true", help="sections 1-3 only")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    cfg = dataclasses.replace(load_design_config(ROOT / "problems" / "paper_design.toml"),
                              motor_model="paper")
    problem = build_problem(cfg)
    _, _, proto = goals_and_weights(cfg, problem)
    scale = np.array([proto[k] for k in OBJECTIVE_NAMES])
    ref = np.full(4, 2.0)

    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.optimize import minimize
    rep = args.repeats
    t_pymoo, _ = cpu_median(lambda: minimize(problem, NSGA2(pop_size=100), ("n_gen", 100),
                                             seed=1), rep)
    t_pymoo20, _ = cpu_median(lambda: minimize(problem, NSGA2(pop_size=100), ("n_gen", 20),
                                               seed=1), rep)
    kw = {"pop_size": 100, "seed": 1, "hv_scale": scale, "hv_reference": ref}
    t_100, big = cpu_median(lambda: run_nsga2(problem, n_gen=100, **kw), rep)
    t_20, _ = cpu_median(lambda: run_nsga2(problem, n_gen=20, **kw), rep)
    with tempfile.TemporaryDirectory() as tmp:
        t_ck, _ = cpu_median(lambda: run_nsga2(problem, n_gen=100, checkpoint=tmp, **kw), rep)
    print(f"1. NSGA-II on problems/paper_design.toml, CPU time, median of {rep}:")
    print(f"   plain pymoo minimize(NSGA2(pop_size=100), n_gen 100, seed 1): {t_pymoo:.2f} s")
    print(f"   run_nsga2 100 x 100 (archive {big.history[-1]['n_archive']} pts, HV each "
          f"generation): {t_100:.2f} s -> ratio to pymoo {t_100 / t_pymoo:.2f} "
          f"(acceptance <= 1.3)")
    print(f"   run_nsga2 100 x 20: {t_20:.2f} s -> 100 x 100 / 100 x 20 = {t_100 / t_20:.2f} "
          f"(acceptance <= 5.5; 5 = linear in evaluations; plain pymoo itself: "
          f"{t_pymoo / t_pymoo20:.2f})")
    print(f"   run_nsga2 100 x 100 with a checkpoint every generation: {t_ck:.2f} s "
          f"(x{t_ck / t_100:.2f} of without)")
    res = run_nsga2(problem, pop_size=40, n_gen=25, seed=1, hv_scale=scale, hv_reference=ref)
    n_eval = res.stats["n_eval"]
    # plain baseline: the same number of designs, one design per call
    U = np.random.default_rng(0).random((200, 4))
    t0 = time.perf_counter()
    for u in U:
        problem.objectives_unit(u[None, :])
    t_single = (time.perf_counter() - t0) / len(U)
    t0 = time.perf_counter()
    problem.objectives_unit(np.random.default_rng(1).random((n_eval, 4)))
    t_vec = time.perf_counter() - t0
    print(f"   the {n_eval} designs of a 40 x 25 run vectorised {t_vec:.3f} s vs one per "
          f"call {t_single * n_eval:.2f} s (x{t_single * n_eval / t_vec:.0f})")
    print("2. hypervolume vs evaluations (F / F(prototype), reference [2, 2, 2, 2]):")
    for h in res.history:
        if h["gen"] in (1, 2, 5, 10, 15, 20, 25):
            print(f"   {h['n_eval']:5d} evaluations: HV population front = {h['hv']:.4f} "
                  f"({h['n_front']} pts), archive of all evaluated = {h['hv_archive']:.4f} "
                  f"({h['n_archive']} pts)")

    with tempfile.TemporaryDirectory() as tmp:
        ck = Path(tmp) / "ck"
        straight = res.to_csv_text()
        part = run_nsga2(problem, pop_size=40, n_gen=25, seed=1, hv_scale=scale,
                         hv_reference=ref, checkpoint=ck, stop_after=12)
        t0 = time.perf_counter()
        resumed = run_nsga2(build_problem(cfg), pop_size=40, n_gen=25, seed=1,
                            hv_scale=scale, hv_reference=ref, resume=ck)
        dt = time.perf_counter() - t0
        size = (ck / "nsga2_checkpoint.npz").stat().st_size
        print(f"3. resume after {part.stats['generations']} of 25 generations "
              f"({dt:.2f} s for the remaining 13, checkpoint {size / 1024:.0f} KiB): "
              f"pareto.csv identical to the straight run: {resumed.to_csv_text() == straight}")
    if args.only_nsga2:
        return

    doc = {"harvester": {"load_ohm": 47.0},
           "sweep": {"speed_km_per_h": [30.0, 50.0, 70.0, 100.0, 130.0],
                     "iso_class": ["B", "C", "D"],
                     "vehicle": ["passenger_car", "single_seater"],
                     "design": {"load_ohm": list(np.geomspace(5, 2000, 12)),
                                "lead_mm_per_rev": [5.0, 7.0, 10.0, 15.0, 20.0]}}}
    spec = parse_sweep(doc, "benchmark")
    out = {}
    for name, kw in (("1 local job", {"jobs": 1}), ("2 local processes", {"jobs": 2})):
        t0 = time.perf_counter()
        out[name] = rows_to_csv(run_sweep(spec, **kw))
        print(f"4. sweep {spec.n_cases} cases ({len(spec.tasks())} tasks), {name}: "
              f"{time.perf_counter() - t0:.2f} s")
    from distributed import LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        t0 = time.perf_counter()
        out["dask"] = rows_to_csv(run_sweep(spec, scheduler=cluster.scheduler_address))
        print(f"   Dask LocalCluster (2 workers, {cluster.scheduler_address}): "
              f"{time.perf_counter() - t0:.2f} s")
    same = len(set(out.values())) == 1
    print(f"   identical tidy CSV on local, 2 processes and Dask: {same}")

    # time-domain (friction) sweep: real work per task, so parallelism pays
    doc = {"harvester": {"load_ohm": 47.0}, "road": {"length_m": 300.0},
           "sweep": {"speed_km_per_h": [30.0, 70.0, 100.0, 130.0],
                     "friction": ["min", "max"], "design": {"load_ohm": [20.0, 75.0, 250.0]}}}
    spec = parse_sweep(doc, "benchmark-friction")
    out = {}
    times = {}
    for name, kw in (("1 local job", {"jobs": 1}), ("2 local processes", {"jobs": 2})):
        t0 = time.perf_counter()
        out[name] = rows_to_csv(run_sweep(spec, **kw))
        times[name] = time.perf_counter() - t0
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        t0 = time.perf_counter()
        out["dask"] = rows_to_csv(run_sweep(spec, scheduler=cluster.scheduler_address))
        times["Dask LocalCluster, 2 workers"] = time.perf_counter() - t0
    base = times["1 local job"]
    print(f"5. time-domain friction sweep, {spec.n_cases} cases ({len(spec.tasks())} tasks, "
          f"300 m roads): " + ", ".join(f"{k} {v:.2f} s (x{base / v:.2f})"
                                        for k, v in times.items()))
    print(f"   identical tidy CSV: {len(set(out.values())) == 1}")


if __name__ == "__main__":
    from ehsa_opt.utils.process import single_threaded_blas
    with single_threaded_blas():  # both sides as the command line runs them
        main()
