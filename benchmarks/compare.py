"""Speed of this checkout against an earlier commit, A/B interleaved, ratios from one run.

    python benchmarks/compare.py --base ad745e2 [--cases identify,nsga2_per_eval,reproduce_quick]
        [--pairs 3] [--cpu-factor 1.15] [--wall-factor 2.0]
        [--history benchmarks/history/compare.jsonl]

The base commit is checked out in a temporary ``git worktree`` (removed at the end; or
``--base-dir DIR``, an existing checkout).  Every case is a whole ``python -m ehsa_opt``
command run in each checkout (its own source imported: ``PYTHONPATH`` and working
directory are the checkout), the two in turn — base, head, head, base, base, head … —
so a drift of the machine's speed during the run falls on both.  Each run is one
process; its CPU time (user + sys, including the processes it waited for:
``os.wait4``) and wall time are recorded, and per pair the ratio head / base.  The
median ratio over the pairs is the case's figure.

A case **fails** when its median CPU ratio exceeds ``--cpu-factor`` (default 1.15) or its
median wall ratio exceeds ``--wall-factor`` (default 2.0); the exit status is then 1.
Why those factors: on the shared 2-core machine the figures were measured on (load 13–16,
other jobs' test suites beside it), this checkout against itself (``--base-dir .``, 3
pairs) gave CPU ratios of single pairs 0.985–1.046 (identification, NSGA-II per
evaluation) but wall ratios 0.96–1.47 — the wall time moves with the other jobs' load, the
CPU time much less.  So 1.15 on the median CPU ratio is three times the noise of a single
pair and well below the regressions this gate exists for (the 2x of an identification,
the 3x of ``reproduce --quick``); the wall factor only catches what the CPU time cannot see
(a process waiting: a sleep, a lock, a subprocess run serially) and sits above the noise.

``nsga2_per_eval`` is the CPU per design evaluation of NSGA-II (``run_nsga2`` in one
process, timed from inside): (CPU of 100 × 100 − CPU of 100 × 20) / 8000 evaluations, per
pair — the fixed cost cancels (the whole ``optimize`` command's difference would also
hold its time-domain check of the front, whose size grows with the generations);
``nsga2_per_eval_paper_motor`` the same with the paper's fixed winding (the share of the
motor model and its rated-limit constraints); ``nsga2_100x20`` the whole ``optimize
--method nsga2 --pop 100 --gens 20`` command (fixed costs included).  The cases'
bench data (a 21-test rigid campaign, ``bench generate --seed 7``) are generated once
by the head checkout and used by both.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

ROOT = Path(__file__).resolve().parents[1]

#: Median CPU ratio head / base above which a case fails (see the module docstring).
CPU_FACTOR = 1.15
#: Median wall ratio head / base above which a case fails.
WALL_FACTOR = 2.0


@dataclass(frozen=True)
class Side:
    """One checkout: its folder and extra environment (``PYTHONPATH`` entries first)."""

    root: Path
    label: str
    pythonpath: tuple[str, ...] = ()

    def env(self) -> dict[str, str]:
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([*self.pythonpath, str(self.root)])
        env.setdefault("MPLBACKEND", "Agg")
        env["PYTHONHASHSEED"] = "0"
        return env


@dataclass(frozen=True)
class Run:
    """One finished process: CPU (user + sys) and wall seconds, exit status."""

    cpu_s: float
    wall_s: float
    returncode: int


@dataclass
class Case:
    """A benchmark case: ``commands(work)`` gives the argument lists run one after the
    other as one measurement (``work``: a scratch folder of the side); ``combine`` turns
    the runs' figures into the case's figure (default: their sum)."""

    name: str
    commands: Callable[[Path], list[list[str]]]
    combine: Callable[[list[float]], float] = sum
    unit: str = "s"
    note: str = ""
    #: the command prints its own figures as its last stdout line, JSON
    #: ``{"cpu_s": .., "wall_s": ..}`` (a part of the process timed from inside)
    reports: bool = False


@dataclass
class CaseResult:
    name: str
    unit: str
    base_cpu: list[float] = field(default_factory=list)
    head_cpu: list[float] = field(default_factory=list)
    base_wall: list[float] = field(default_factory=list)
    head_wall: list[float] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)

    @staticmethod
    def _ratios(a: list[float], b: list[float]) -> list[float]:
        return [h / x if x > 0 else float("inf") for x, h in zip(a, b)]

    @property
    def cpu_ratios(self) -> list[float]:
        return self._ratios(self.base_cpu, self.head_cpu)

    @property
    def wall_ratios(self) -> list[float]:
        return self._ratios(self.base_wall, self.head_wall)

    def verdict(self, cpu_factor: float, wall_factor: float) -> list[str]:
        """Reasons the case fails (empty: it passes)."""
        why = list(self.failures)
        if self.cpu_ratios and statistics.median(self.cpu_ratios) > cpu_factor:
            why.append(f"CPU {statistics.median(self.cpu_ratios):.2f}x > {cpu_factor}x")
        if self.wall_ratios and statistics.median(self.wall_ratios) > wall_factor:
            why.append(f"wall {statistics.median(self.wall_ratios):.2f}x > {wall_factor}x")
        return why


def run_process(cmd: Sequence[str], side: Side, timeout_s: float = 3600.0,
                reports: bool = False) -> Run:
    """Run ``cmd`` in ``side``'s checkout; CPU of the process and its waited children
    (``reports``: the figures the command prints itself)."""
    errfile = tempfile.TemporaryFile()  # a pipe would fill up and block the child
    outfile = tempfile.TemporaryFile()
    t0 = time.perf_counter()
    proc = subprocess.Popen(list(cmd), cwd=side.root, env=side.env(),
                            stdout=outfile, stderr=errfile)
    deadline = t0 + timeout_s
    while True:
        pid, status, ru = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if time.perf_counter() > deadline:
            proc.kill()
            pid, status, ru = os.wait4(proc.pid, 0)
            break
        time.sleep(0.01)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    errfile.seek(0)
    err = errfile.read().decode(errors="replace")
    errfile.close()
    outfile.seek(0)
    out = outfile.read().decode(errors="replace").strip().splitlines()
    outfile.close()
    if proc.returncode != 0:
        raise RuntimeError(f"{side.label}: {' '.join(cmd)} exited {proc.returncode}:\n"
                           f"{err[-2000:]}")
    if reports:
        fig = json.loads(out[-1])
        return Run(float(fig["cpu_s"]), float(fig["wall_s"]), 0)
    return Run(ru.ru_utime + ru.ru_stime, wall, proc.returncode)


def measure(case: Case, side: Side, work: Path) -> tuple[float, float]:
    """(CPU, wall) figure of one measurement of ``case`` on ``side``."""
    cpu, wall = [], []
    for cmd in case.commands(work):
        r = run_process(cmd, side, reports=case.reports)
        cpu.append(r.cpu_s)
        wall.append(r.wall_s)
    return case.combine(cpu), case.combine(wall)


def compare_case(case: Case, base: Side, head: Side, pairs: int = 3, warmup: bool = True,
                 log: Callable[[str], None] = print) -> CaseResult:
    """Interleaved pairs of ``case`` (base, head; then head, base; …)."""
    res = CaseResult(case.name, case.unit)
    sides = {"base": base, "head": head}  # keyed by role: a checkout against itself works
    with tempfile.TemporaryDirectory(prefix=f"compare-{case.name}-") as tmp:
        work = {role: Path(tmp) / role for role in sides}
        for w in work.values():
            w.mkdir()
        if warmup:  # byte-compile both checkouts, fill the file cache
            for role, s in sides.items():
                measure(case, s, work[role])
        for k in range(pairs):
            order = ("base", "head") if k % 2 == 0 else ("head", "base")
            got = {}
            for role in order:
                shutil.rmtree(work[role])
                work[role].mkdir()
                got[role] = measure(case, sides[role], work[role])
            res.base_cpu.append(got["base"][0])
            res.base_wall.append(got["base"][1])
            res.head_cpu.append(got["head"][0])
            res.head_wall.append(got["head"][1])
            log(f"  {case.name} pair {k + 1}: CPU {got['base'][0]:.4g} / "
                f"{got['head'][0]:.4g} {case.unit} (base / head), ratio "
                f"{res.cpu_ratios[-1]:.3f}; wall ratio {res.wall_ratios[-1]:.3f}")
    return res


def _py(*args: str) -> list[str]:
    return [sys.executable, "-m", "ehsa_opt", *args]


#: NSGA-II alone, in one process (the API both commits have): CPU per design evaluation of
#: ``run_nsga2`` 100 x 100 minus 100 x 20 on the paper's problem, BLAS on one thread;
#: argv[1] "paper" sets the paper's fixed winding (no motor model, no rated limits).
NSGA2_SNIPPET = """
import json, sys, time, dataclasses
import numpy as np
from threadpoolctl import threadpool_limits
from ehsa_opt.design import OBJECTIVE_NAMES, run_nsga2
from ehsa_opt.design.config import load_design_config
from ehsa_opt.design.optimize import build_problem, goals_and_weights
with threadpool_limits(limits=1, user_api="blas"):
    cfg = load_design_config("problems/paper_design.toml")
    if sys.argv[1] == "paper" and hasattr(cfg, "motor_model"):
        cfg = dataclasses.replace(cfg, motor_model="paper")
    problem = build_problem(cfg)
    _, _, proto = goals_and_weights(cfg, problem)
    kw = dict(pop_size=100, seed=1, hv_scale=np.array([proto[k] for k in OBJECTIVE_NAMES]),
              hv_reference=np.full(len(OBJECTIVE_NAMES), 2.0))
    fig = {}
    for gens in (20, 100):
        c, w = time.process_time(), time.perf_counter()
        run_nsga2(problem, n_gen=gens, **kw)
        fig[gens] = (time.process_time() - c, time.perf_counter() - w)
print(json.dumps({"cpu_s": 1e3 * (fig[100][0] - fig[20][0]) / 8000,
                  "wall_s": 1e3 * (fig[100][1] - fig[20][1]) / 8000}))
"""


#: A quarter-car time-domain run in one process (the API both commits have): the
#: prototype harvester with the embedded bench's true friction on a 300 m class-C road at
#: 100 km/h, 1 kHz: the mean of ten runs on ten roads (seeds 0-9), after a first run (seed
#: 100) that builds or loads the compiled functions; BLAS on one thread.
QUARTER_CAR_SNIPPET = """
import json, time
from threadpoolctl import threadpool_limits
from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
from ehsa_opt.physics.params import FrictionParams, HarvesterParams, RoadParams, VehicleParams
from ehsa_opt.vehicle.simulate import simulate_quarter_car
with threadpool_limits(limits=1, user_api="blas"):
    fr = FrictionParams(**load_truth(embedded_data_dir())["friction"])
    run = lambda seed: simulate_quarter_car(
        VehicleParams(), HarvesterParams(), fr,
        RoadParams(length_m=300.0, speed_km_per_h=100.0, seed=seed), warn=False)
    run(100)
    c, w = time.process_time(), time.perf_counter()
    sims = [run(seed) for seed in range(10)]
    cpu, wall = (time.process_time() - c) / 10, (time.perf_counter() - w) / 10
assert all(sim.success for sim in sims)
print(json.dumps({"cpu_s": cpu, "wall_s": wall}))
"""

#: One member fit of the discrepancy workflow in one process: the backlash candidate
#: re-identified from the baseline on the embedded bench data (6 tests, as ``reproduce
#: --quick``); the setup (split, baseline fit) is not timed.  Each commit through its own
#: functions: the workflow's ``fit_member`` where it exists, else the ``_fit_one`` of the
#: earlier round loop (the same call: candidate fit, then the fit and held-out
#: predictions).
MEMBER_FIT_SNIPPET = """
import json, time
from threadpoolctl import threadpool_limits
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES, components_for
from ehsa_opt.estimation.discrepancy.results import DiscrepancySettings
settings = DiscrepancySettings(max_tests=6, top=1)
quiet = lambda msg: None
with threadpool_limits(limits=1, user_api="blas"):
    try:
        from ehsa_opt.estimation.discrepancy.candidate_fit import fit_member
        from ehsa_opt.estimation.discrepancy.workflow import (fit_baseline, load_data,
                                                              prepare_search_tests)
        data = load_data(embedded_data_dir("bench_prototype"), quiet, [])
        tests = prepare_search_tests(data, settings, quiet, [])
        base = fit_baseline(tests, settings, quiet)
        rig, sub, fit, held = tests.rig, tests.sub_pts, tests.fit_pts, tests.held_pts
        params, fit_pred, lead = base.fit.parameters, base.fit_pred, tests.lead_m_per_rad
    except ImportError:
        from ehsa_opt.datasets.bench_format import load_bench
        from ehsa_opt.estimation.discrepancy.fit import (Rig, fit_group, linear_baseline,
                                                         predict, prepare_tests)
        from ehsa_opt.estimation.discrepancy.refit import _crop, _load_split, _spread
        from ehsa_opt.estimation.discrepancy.rounds import _fit_one as fit_member
        data = load_bench(embedded_data_dir("bench_prototype"), lenient=True)
        rig = Rig(data.harvester, data.has_generator, ())
        fit_t, held_t, _ = _load_split(data, settings)
        fit = prepare_tests([_crop(t, settings.max_samples) for t in fit_t], data.has_generator)
        held = prepare_tests([_crop(t, settings.max_samples) for t in held_t],
                             data.has_generator) if held_t else []
        sub = _spread(fit, settings.max_fit_tests)
        base = fit_group(fit, rig, [linear_baseline(fit, rig)], max_iter=settings.max_iter)
        params, lead = base.parameters, data.harvester.lead_m_per_rad
        fit_pred = predict(fit, rig, params)
    comp = components_for(["backlash"], fit, fit_pred, lead)["backlash"]
    a = ("backlash", comp, CANDIDATES["backlash"].starts, sub, fit, held, rig, params,
         settings.max_iter)
    c, w = time.process_time(), time.perf_counter()
    name, res, pf, ph, _ = fit_member(a)
    cpu, wall = time.process_time() - c, time.perf_counter() - w
assert name == "backlash" and res.success and pf
print(json.dumps({"cpu_s": cpu, "wall_s": wall}))
"""

def standard_cases(data_dir: Path) -> dict[str, Case]:
    """The cases of the comparison against the previous release (whole commands)."""
    problem = "problems/paper_design.toml"

    def nsga(gens: int) -> Callable[[Path], list[str]]:
        return lambda w: _py("optimize", problem, "--method", "nsga2", "--pop", "100",
                             "--gens", str(gens), "--out", str(w / f"nsga_{gens}"))

    return {
        "identify": Case("identify", lambda w: [_py("identify", str(data_dir), "--starts", "4",
                                                     "--out", str(w / "identify"))],
                         note="21-test rigid campaign, 4 starts, 1 job"),
        "nsga2_per_eval": Case(
            "nsga2_per_eval", lambda w: [[sys.executable, "-c", NSGA2_SNIPPET, "problem"]],
            unit="ms", reports=True,
            note="run_nsga2 in one process: (100 x 100 - 100 x 20) / 8000 evaluations, "
                 "paper_design.toml as it is (head: motor, winding and screw chosen from "
                 "catalogues, their limits as constraints)"),
        "nsga2_per_eval_paper_motor": Case(
            "nsga2_per_eval_paper_motor",
            lambda w: [[sys.executable, "-c", NSGA2_SNIPPET, "paper"]], unit="ms",
            reports=True, note="as nsga2_per_eval with [motor] model = 'paper' where the "
                               "commit has motor models (the paper's fixed winding)"),
        "quarter_car": Case(
            "quarter_car", lambda w: [[sys.executable, "-c", QUARTER_CAR_SNIPPET]],
            reports=True, note="simulate_quarter_car in one process: 300 m class-C road at "
                               "100 km/h, 1 kHz, the embedded bench's true friction (mean "
                               "of 10 roads)"),
        "member_fit": Case(
            "member_fit", lambda w: [[sys.executable, "-c", MEMBER_FIT_SNIPPET]],
            reports=True, note="the backlash member re-identified from the baseline on the "
                               "embedded bench data (6 tests), in one process"),
        "nsga2_100x20": Case("nsga2_100x20", lambda w: [nsga(20)(w)],
                             note="optimize --method nsga2 --pop 100 --gens 20 (whole command)"),
        "reproduce_quick": Case("reproduce_quick", lambda w: [_py(
            "reproduce", "--quick", "--out", str(w / "quick"))],
            note="reproduce --quick, fresh output folder, --jobs 2"),
    }


def table(results: Sequence[CaseResult], cpu_factor: float, wall_factor: float,
          notes: dict[str, str] | None = None) -> str:
    """Markdown table of the results (medians, ratio median [min–max], verdict)."""
    rows = ["| case | base CPU | head CPU | CPU ratio (median [min-max]) | wall ratio | "
            "verdict |", "|---|---|---|---|---|---|"]
    for r in results:
        why = r.verdict(cpu_factor, wall_factor)
        cr, wr = r.cpu_ratios, r.wall_ratios
        rows.append(
            f"| {r.name} | {statistics.median(r.base_cpu):.4g} {r.unit} | "
            f"{statistics.median(r.head_cpu):.4g} {r.unit} | {statistics.median(cr):.3f} "
            f"[{min(cr):.3f}-{max(cr):.3f}] | {statistics.median(wr):.3f} | "
            f"{'FAIL: ' + '; '.join(why) if why else 'ok'} |")
    if notes:
        rows.append("")
        rows += [f"- {k}: {v}" for k, v in notes.items()]
    return "\n".join(rows)


def exit_code(results: Sequence[CaseResult], cpu_factor: float, wall_factor: float) -> int:
    """1 when any case fails, else 0."""
    return int(any(r.verdict(cpu_factor, wall_factor) for r in results))


def _git(*args: str, cwd: Path = ROOT) -> str:
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True,
                          text=True).stdout.strip()


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="ad745e2", help="commit to compare against")
    ap.add_argument("--base-dir", help="an existing checkout of the base instead")
    ap.add_argument("--cases", default="identify,nsga2_per_eval,reproduce_quick",
                    help="comma-separated, from: identify, nsga2_per_eval, "
                         "nsga2_per_eval_paper_motor, quarter_car, member_fit, "
                         "nsga2_100x20, reproduce_quick")
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--no-warmup", action="store_true")
    ap.add_argument("--cpu-factor", type=float, default=CPU_FACTOR)
    ap.add_argument("--wall-factor", type=float, default=WALL_FACTOR)
    ap.add_argument("--history", help="append the result (JSON line) to this file")
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="ehsa-compare-"))
    worktree = None
    try:
        if args.base_dir:
            base_root = Path(args.base_dir).resolve()
            base_label = _git("rev-parse", "--short", "HEAD", cwd=base_root)
        else:
            worktree = tmp / "base"
            _git("worktree", "add", "--detach", str(worktree), args.base)
            base_root, base_label = worktree, _git("rev-parse", "--short", args.base)
        head_label = _git("rev-parse", "--short", "HEAD")
        base, head = Side(base_root, f"base-{base_label}"), Side(ROOT, f"head-{head_label}")
        data = tmp / "rigid7"
        run_process(_py("bench", "generate", str(data), "--seed", "7"), head)
        cases = standard_cases(data)
        unknown = [c for c in args.cases.split(",") if c not in cases]
        if unknown:
            ap.error(f"--cases: unknown {unknown} (known: {', '.join(cases)})")
        results = []
        for name in args.cases.split(","):
            print(f"{name}: {cases[name].note}", flush=True)
            results.append(compare_case(cases[name], base, head, args.pairs,
                                        not args.no_warmup))
        print(f"\n{head.label} against {base.label}, {args.pairs} interleaved pairs, "
              f"{os.cpu_count()} CPUs; fails above {args.cpu_factor}x CPU or "
              f"{args.wall_factor}x wall\n")
        print(table(results, args.cpu_factor, args.wall_factor,
                    {c: cases[c].note for c in args.cases.split(",")}))
        code = exit_code(results, args.cpu_factor, args.wall_factor)
        if args.history:
            rec = {"date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                   "head": head_label, "base": base_label, "pairs": args.pairs,
                   "cpu_factor": args.cpu_factor, "wall_factor": args.wall_factor,
                   "cases": {r.name: {"unit": r.unit, "base_cpu": r.base_cpu,
                                      "head_cpu": r.head_cpu, "base_wall": r.base_wall,
                                      "head_wall": r.head_wall} for r in results},
                   "failed": bool(code)}
            with open(args.history, "a", encoding="utf-8") as fh:
                fh.write(json.dumps(rec) + "\n")
        return code
    finally:
        if worktree is not None:
            subprocess.run(["git", "worktree", "remove", "--force", str(worktree)], cwd=ROOT,
                           capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
