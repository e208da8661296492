"""Benchmark: pymoo's many-objective algorithms against NSGA-II on the four-objective
design problem, at equal evaluations.

Cases (fixed before the first run, not tuned afterwards):
  paper     problems/paper_design.toml in the paper's design space (R_i, L_i fixed,
            no constraints): the problem on which NSGA-II's population front was seen
            to lose hypervolume after ~400 evaluations.
  default   the same file with the product's default motor model ("select": motor,
            winding and screw from the shipped catalogues, every hardware limit a
            constraint; feasible designs only).

Algorithms: NSGA-II (the design card's named baseline), NSGA-III (Das-Dennis reference
directions, 4 objectives, 5 partitions: 56 directions), SMS-EMOA, AGE-MOEA (needs numba;
skipped with a message without it).  Each runs --evals evaluations (default 1000 = the
design card's 40 × 25), population 56 for NSGA-III (one per direction) and --pop for
the others, on --seeds seeds (default 5).  Every run's evaluated designs are kept.

Metrics, on objectives normalised by the prototype's (F / F(prototype)):
  HV    hypervolume against the reference point [2, 2, 2, 2] (the design card's), of
        the final population's non-dominated feasible set ("front") and of every
        feasible design evaluated ("archive");
  IGD   inverted generational distance of the final front to a reference front: the
        non-dominated union of long runs (NSGA-II and NSGA-III, --ref-evals each,
        seeds 100/101) and of every run of the benchmark (so no algorithm is measured
        against a front it could not reach).
Printed: median [min–max] over seeds per case and algorithm (no timings: this compares
quality at equal evaluations, and the machine is shared).

Run from the repository root:  python validation/many_objective.py [--seeds 5] [--quick]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ehsa_opt.design import OBJECTIVE_NAMES  # noqa: E402
from ehsa_opt.design.config import load_design_config  # noqa: E402
from ehsa_opt.design.optimize import (build_problem, objectives_at,  # noqa: E402
                                      prototype_problem)
from ehsa_opt.design.pareto import hypervolume, non_dominated  # noqa: E402

REF = np.full(4, 2.0)


def algorithms(pop: int) -> dict:
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.algorithms.moo.nsga3 import NSGA3
    from pymoo.algorithms.moo.sms import SMSEMOA
    from pymoo.util.ref_dirs import get_reference_directions
    dirs = get_reference_directions("das-dennis", 4, n_partitions=5)
    out = {"NSGA-II": lambda **kw: NSGA2(pop_size=pop, eliminate_duplicates=True, **kw),
           "NSGA-III": lambda **kw: NSGA3(ref_dirs=dirs, pop_size=len(dirs),
                                          eliminate_duplicates=True, **kw),
           "SMS-EMOA": lambda **kw: SMSEMOA(pop_size=pop, eliminate_duplicates=True, **kw)}
    try:
        from pymoo.algorithms.moo.age import AGEMOEA
        out["AGE-MOEA"] = lambda **kw: AGEMOEA(pop_size=pop, eliminate_duplicates=True, **kw)
    except Exception as exc:  # noqa: BLE001 - numba missing
        print(f"AGE-MOEA skipped: {exc}")
    return out


POP_OF = {"NSGA-III": 56}


def run(problem, make, evals: int, seed: int, start=None, pop: int = 40):
    """One run; returns (final front F, every feasible evaluated F), normalised later.
    ``start``: unit-cube points put in the first population (the product does so with
    the prototype when the problem has constraints), the rest uniform with ``seed``."""
    from pymoo.core.callback import Callback
    from pymoo.optimize import minimize

    seen: list[np.ndarray] = []

    class Keep(Callback):
        def notify(self, algorithm):
            off = algorithm.off if algorithm.off is not None else algorithm.pop
            F, G = off.get("F"), off.get("G")
            ok = np.ones(len(F), bool) if G is None or G.size == 0 else np.all(G <= 0, axis=1)
            seen.append(F[ok])

    kw = {}
    if start is not None:
        rest = np.random.default_rng(seed).random((pop - len(start), problem.n_var))
        kw["sampling"] = np.vstack([start, rest])
    res = minimize(problem, make(**kw), ("n_eval", evals), seed=seed, callback=Keep(),
                   verbose=False)
    pop = res.pop
    F, G = pop.get("F"), pop.get("G")
    ok = np.ones(len(F), bool) if G is None or G.size == 0 else np.all(G <= 0, axis=1)
    front = F[ok][non_dominated(F[ok])] if ok.any() else np.zeros((0, 4))
    every = np.vstack(seen) if seen else np.zeros((0, 4))
    return front, every, int(res.algorithm.evaluator.n_eval)


def igd(front: np.ndarray, ref_front: np.ndarray) -> float:
    if front.size == 0:
        return float("inf")
    d = np.linalg.norm(ref_front[:, None, :] - front[None, :, :], axis=2)
    return float(np.mean(np.min(d, axis=1)))


def summary(v: list[float]) -> str:
    a = np.asarray(v, float)
    return f"{np.median(a):.4g} [{a.min():.4g}-{a.max():.4g}]"


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--evals", type=int, default=1000)
    ap.add_argument("--pop", type=int, default=40)
    ap.add_argument("--ref-evals", type=int, default=10000)
    ap.add_argument("--quick", action="store_true", help="2 seeds, 400 evaluations")
    args = ap.parse_args()
    if args.quick:
        args.seeds, args.evals, args.ref_evals = 2, 400, 2000
    cfg0 = load_design_config(ROOT / "problems" / "paper_design.toml")
    cases = {"paper": dataclasses.replace(cfg0, motor_model="paper"), "default": cfg0}
    algos = algorithms(args.pop)
    for case, cfg in cases.items():
        problem = build_problem(cfg)
        # the goals' reference: the prototype in its own (the paper's) space
        proto = objectives_at(prototype_problem(cfg), cfg.prototype_design)
        scale = np.array([proto[k] for k in OBJECTIVE_NAMES])
        # the product's first population: a catalogue space's screened feasible seeds,
        # else the prototype when the problem has constraints
        start = (problem.initial if getattr(problem, "initial", None) is not None
                 else problem.space.to_unit(cfg.prototype_design)[None, :]
                 if problem.constraint_names else None)
        print(f"\n=== case {case}: {len(problem.constraint_names)} constraints "
              f"({', '.join(problem.constraint_names) or 'none'}), {args.evals} evaluations, "
              f"{args.seeds} seeds ===")
        results: dict[str, list] = {a: [] for a in algos}
        t_alg: dict[str, float] = {a: 0.0 for a in algos}
        pool = []
        for name, make in algos.items():
            for s in range(args.seeds):
                t0 = time.perf_counter()
                front, every, n = run(problem, make, args.evals, s, start,
                                      POP_OF.get(name, args.pop))
                t_alg[name] += time.perf_counter() - t0
                results[name].append((front / scale, every / scale, n))
                pool += [front / scale, every / scale]
        t0 = time.perf_counter()
        for name, seed in (("NSGA-II", 100), ("NSGA-III", 101)):
            front, every, _ = run(problem, algos[name], args.ref_evals, seed, start,
                                  POP_OF.get(name, args.pop))
            pool += [front / scale, every / scale]
        allF = np.vstack([p for p in pool if p.size])
        ref_front = allF[non_dominated(allF)]
        ref_front = ref_front[np.all(ref_front < REF, axis=1)]
        print(f"reference front: {ref_front.shape[0]} points (long runs {args.ref_evals} "
              f"evaluations each + every benchmark run), HV {hypervolume(ref_front, REF):.4g}")
        print(f"{'algorithm':10s} | {'HV front':24s} | {'HV archive':24s} | "
              f"{'IGD front':26s} | evals")
        for name, runs in results.items():
            hv_f = [hypervolume(f, REF) if f.size else 0.0 for f, _, _ in runs]
            hv_a = [hypervolume(e[non_dominated(e)], REF) if e.size else 0.0
                    for _, e, _ in runs]
            ig = [igd(f[np.all(f < REF, axis=1)] if f.size else f, ref_front)
                  for f, _, _ in runs]
            ne = sorted({n for _, _, n in runs})
            print(f"{name:10s} | {summary(hv_f):24s} | {summary(hv_a):24s} | "
                  f"{summary(ig):26s} | {ne}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
