"""Fault injection (issue 15): ``kill -9`` at random points, resume, compare byte for byte.

* ``reproduce``: a reduced but real step list (embedded data, harvester, bench model
  against the data, quarter-car paths) runs in a child process that is killed with
  SIGKILL after a random delay drawn over the length of an uninterrupted run (so kills
  land in step computations, figure writes and cache writes); the same command is then
  run to the end.  ``REPORT.md`` without its run-log section (which says what was
  cached) and every figure must equal the uninterrupted run's bytes.
* ``optimize --checkpoint``: the CLI's NSGA-II run killed at a random point, resumed
  with ``--resume`` (or started again when the kill came before the first
  checkpoint); ``pareto.csv`` must be byte-identical and ``result.json`` equal apart
  from its wall-time ``stats``.

    PYTHONPATH=. python tools/fault_injection.py --points 20 --seed 0

prints one line per kill point and exits 1 on any difference.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
#: The reduced reproduce configuration (real steps, no fakes; ~6 s of computation).
STEP_KEYS = ("data", "harvester", "bench_truth", "qc_paths")
OPTIMIZE_ARGS = ("--method", "nsga2", "--pop", "8", "--gens", "4")

_REPRODUCE = (
    "import sys\n"
    "from ehsa_opt.pipeline.reproduce import STEPS, reproduce\n"
    "keys = sys.argv[2].split(',')\n"
    "reproduce(sys.argv[1], quick=True, jobs=1, steps=[s for s in STEPS if s.key in keys],\n"
    "          log=lambda m: print(m, flush=True))\n")


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT), "EHSA_OPT_QUIET": "1"}


def reproduce_cmd(out: Path, keys: tuple[str, ...] = STEP_KEYS) -> list[str]:
    return [sys.executable, "-c", _REPRODUCE, str(out), ",".join(keys)]


def optimize_cmd(out: Path, ck: Path, resume: bool) -> list[str]:
    cmd = [sys.executable, "-m", "ehsa_opt", "optimize", str(ROOT / "problems/paper_design.toml"),
           *OPTIMIZE_ARGS, "--checkpoint", str(ck), "--out", str(out)]
    return cmd + (["--resume", str(ck)] if resume else [])


def run(cmd: list[str]) -> subprocess.CompletedProcess:
    r = subprocess.run(cmd, capture_output=True, text=True, env=_env())
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({r.returncode}):\n{r.stderr[-2000:]}")
    return r


def kill_after(cmd: list[str], delay_s: float) -> bool:
    """Start ``cmd``, SIGKILL it after ``delay_s``; True when it was still running."""
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=_env())
    try:
        p.wait(timeout=delay_s)
        return False
    except subprocess.TimeoutExpired:
        os.kill(p.pid, signal.SIGKILL)
        p.wait()
        return True


def report_body(out: Path) -> bytes:
    text = (out / "REPORT.md").read_bytes()
    return text.split(b"\n## Run log")[0]


def outputs(out: Path) -> dict[str, bytes]:
    """What must not change: the report without its run log, and every figure."""
    files = {"REPORT.md": report_body(out)}
    for f in sorted((out / "figures").glob("*.png")):
        files[f"figures/{f.name}"] = f.read_bytes()
    return files


def _strip_stats(obj):
    if isinstance(obj, dict):
        return {k: _strip_stats(v) for k, v in obj.items() if k != "stats"}
    if isinstance(obj, list):
        return [_strip_stats(v) for v in obj]
    return obj


def optimize_outputs(out: Path) -> dict[str, object]:
    return {"pareto.csv": (out / "pareto.csv").read_bytes(),
            "result.json": _strip_stats(json.loads((out / "result.json").read_text()))}


def baseline_reproduce(work: Path) -> tuple[dict[str, bytes], float]:
    t0 = time.perf_counter()
    run(reproduce_cmd(work / "baseline"))
    return outputs(work / "baseline"), time.perf_counter() - t0


def baseline_optimize(work: Path) -> tuple[dict[str, object], float]:
    t0 = time.perf_counter()
    run(optimize_cmd(work / "opt_base", work / "opt_base_ck", resume=False))
    return optimize_outputs(work / "opt_base"), time.perf_counter() - t0


def reproduce_point(work: Path, k: int, delay_s: float, base: dict[str, bytes]) -> tuple[bool, bool]:
    """Kill after ``delay_s``, resume; (killed while running, outputs equal)."""
    out = work / f"rep_{k}"
    killed = kill_after(reproduce_cmd(out), delay_s)
    run(reproduce_cmd(out))
    return killed, outputs(out) == base


def optimize_point(work: Path, k: int, delay_s: float, base: dict[str, object]) -> tuple[bool, bool]:
    out, ck = work / f"opt_{k}", work / f"opt_{k}_ck"
    killed = kill_after(optimize_cmd(out, ck, resume=False), delay_s)
    # a checkpoint to resume from (the folder alone may hold only the run's lock file)
    has_ck = (ck / "nsga2_checkpoint.npz").is_file()
    run(optimize_cmd(out, ck, resume=has_ck))
    return killed, optimize_outputs(out) == base



def kill_points(what, run_point, work, base, t_base, n, rng) -> int:
    """Kill ``what`` at ``n`` random instants in (0.3 s, its uninterrupted time), resume,
    compare with ``base``; returns the number of runs that differ."""
    bad = 0
    for k in range(n):
        delay = float(rng.uniform(0.3, t_base))
        killed, same = run_point(work, k, delay, base)
        bad += not same
        print(f"  {what} kill at {delay:5.2f} s ({'killed' if killed else 'had finished'}): "
              f"{'identical' if same else 'DIFFERENT'}", flush=True)
    return bad

def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=20, help="reproduce kill points (default 20)")
    ap.add_argument("--optimize-points", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    work = Path(tempfile.mkdtemp(prefix="ehsa_fault_"))
    bad = 0
    base, t_base = baseline_reproduce(work)
    print(f"reproduce baseline: {t_base:.1f} s, {len(base)} files compared")
    bad += kill_points("reproduce", reproduce_point, work, base, t_base, args.points, rng)
    obase, t_obase = baseline_optimize(work)
    print(f"optimize baseline: {t_obase:.1f} s")
    bad += kill_points("optimize", optimize_point, work, obase, t_obase, args.optimize_points, rng)
    print(f"{args.points + args.optimize_points} kill points, {bad} differences (expected 0); "
          f"work folder {work}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
