"""Peak memory of the bench CSV loader against the previous one (issue 15).

The previous loader read the whole text, split it into lines and every line into a
list of strings before converting (≈ 14× the file size).  The new one parses with
``numpy.loadtxt`` straight into one float array and only re-scans a bad file line by
line.  Each loader runs in its own child process on the same generated file (a valid
sine test, 4 columns); the extra peak RSS over a process that only imported the
package is printed with the ratio to the file size.

    PYTHONPATH=. python benchmarks/csv_memory.py --rows 1500000

``--hostile`` measures instead the files a careless or hostile user hands over: a sparse
1 GiB CSV (a valid head, then a hole of zero bytes) and a CSV with a 300 MB field, each
read by the current loader with the default size limit (refused before reading) and with
``EHSA_OPT_MAX_CSV_MB`` raised above the file (streamed scan: refused at the first NUL
byte or over-long row, memory of one chunk).  The previous loader (before the scan) peaked
at 5.3 GB on the sparse file and 1.9 GB on the long field.
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
import sys, time
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
def status(key):  # this process's own figures (ru_maxrss carries the parent's over exec)
    return next(int(ln.split()[1]) for ln in open("/proc/self/status") if ln.startswith(key))
r0 = status("VmHWM")
t0 = time.perf_counter()
if which == "previous":
    cols = previous(path)
elif which == "current":
    cols = bf._read_csv(path, need_voltage=True)
else:
    cols = {}
dt = time.perf_counter() - t0
r1 = status("VmHWM")
print(r0 * 1024, r1 * 1024, dt, sum(c.size for c in cols.values()))
"""


def measure(which: str, path: Path, env: dict | None = None) -> tuple[float, float, float]:
    r = subprocess.run([sys.executable, "-c", _CHILD, which, str(path)], capture_output=True,
                       text=True, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin",
                                       **(env or {})}, check=True)
    r0, r1, dt, _ = (float(v) for v in r.stdout.split())
    return r0, r1, dt


_HOSTILE = r"""
import sys, time
from pathlib import Path
from ehsa_opt.datasets import bench_format as bf
t0 = time.perf_counter()
try:
    bf._read_csv(Path(sys.argv[1]), need_voltage=True)
    verdict = "read"
except bf.BenchDataError as exc:
    verdict = "refused: " + str(exc)[:90]
dt = time.perf_counter() - t0
# VmHWM: this process's own peak (ru_maxrss would carry the parent's across fork/exec)
hwm = next(int(ln.split()[1]) for ln in open("/proc/self/status") if ln.startswith("VmHWM"))
print(hwm * 1024, dt, verdict)
"""


def hostile() -> int:
    """Peak RSS of the loader on a sparse 1 GiB CSV and on a 300 MB field."""
    with tempfile.TemporaryDirectory() as tmp:
        head = b"time_s,displacement_m,force_N,voltage_V\n" + b"".join(
            f"{k / 1000:.3f},0.001,1.0,0.5\n".encode() for k in range(1000))
        sparse, field = Path(tmp) / "sparse.csv", Path(tmp) / "field.csv"
        sparse.write_bytes(head)
        with sparse.open("r+b") as fh:
            fh.truncate(2 ** 30)
        with field.open("wb") as fh:
            fh.write(head)
            for _ in range(300):  # 300 MB in 1 MB writes: this process stays small
                fh.write(b"1" * 1_000_000)
            fh.write(b",1,1,1\n")
        for path, what in ((sparse, "sparse 1 GiB CSV"), (field, "300 MB field")):
            for env in ({}, {"EHSA_OPT_MAX_CSV_MB": "4096"}):
                r = subprocess.run([sys.executable, "-c", _HOSTILE, str(path)],
                                   capture_output=True, text=True, check=True,
                                   env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin",
                                        **env})
                rss, dt, verdict = r.stdout.split(maxsplit=2)
                limit = "limit raised" if env else "default limit"
                print(f"  {what:17s} ({limit:13s}): peak RSS {float(rss) / 2 ** 20:6.1f} MiB, "
                      f"{float(dt):5.2f} s — {verdict.strip()}")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=1_500_000)
    ap.add_argument("--hostile", action="store_true", help="sparse file and long field")
    args = ap.parse_args()
    if args.hostile:
        return hostile()
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
