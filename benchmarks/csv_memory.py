"""Peak memory of the bench CSV loader against the previous one (issue 15).

The previous loader read the whole text, split it into lines and every line into a
list of strings before converting (≈ 14× the file size).  The new one parses with
``numpy.loadtxt`` straight into one float array and only re-scans a bad file line by
line.  Each loader runs in its own child process on the same generated file (a valid
sine test, 4 columns); the extra peak RSS over a process that only imported the
package is printed with the ratio to the file size.

    PYTHONPATH=. python benchmarks/csv_memory.py --rows 1500000
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

_CHILD = r"""
import resource, sys, time
from pathlib import Path
import numpy as np
from ehsa_opt.datasets import bench_format as bf

def previous(path, need_voltage=True):  # the loader before issue 15, verbatim in substance
    text = path.read_text(encoding="utf-8", errors="replace")
    lines = text.splitlines()
    header = [h.strip() for h in lines[0].split(",")]
    body = [ln for ln in lines[1:]]
    while body and not body[-1].strip():
        body.pop()
    rows = []
    for ln in body:
        parts = ln.split(",")
        if len(parts) != len(header):
            raise ValueError("row")
        rows.append(parts)
    arr = np.array(rows, dtype=float)
    return {h: arr[:, j] for j, h in enumerate(header)}

which, path = sys.argv[1], Path(sys.argv[2])
r0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
if which == "previous":
    cols = previous(path)
elif which == "current":
    cols = bf._read_csv(path, need_voltage=True)
else:
    cols = {}
dt = time.perf_counter() - t0
r1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(r0 * 1024, r1 * 1024, dt, sum(c.size for c in cols.values()))
"""


def measure(which: str, path: Path) -> tuple[float, float, float]:
    r = subprocess.run([sys.executable, "-c", _CHILD, which, str(path)], capture_output=True,
                       text=True, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
                       check=True)
    r0, r1, dt, _ = (float(v) for v in r.stdout.split())
    return r0, r1, dt


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=1_500_000)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.csv"
        t = np.arange(args.rows) / 1000.0
        x = 0.015 * np.sin(2 * np.pi * t)
        data = np.column_stack([t, x, 1000 * x + 50 * np.sign(np.cos(2 * np.pi * t)), 300 * x])
        np.savetxt(path, data, delimiter=",", fmt="%.9g",
                   header="time_s,displacement_m,force_N,voltage_V", comments="")
        size = path.stat().st_size
        print(f"file: {args.rows} rows, {size / 2**20:.1f} MiB")
        base = measure("none", path)[1]
        for which in ("previous", "current"):
            _, peak, dt = measure(which, path)
            extra = peak - base
            print(f"  {which:8s}: peak RSS +{extra / 2**20:7.1f} MiB = {extra / size:5.2f} x file, "
                  f"{dt:5.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
