"""The discrepancy search with its member fits on a Dask cluster of 1, 2 and 4 worker
processes, against the local run, in one run.

On a campaign directory (default: a synthetic campaign with a hidden mount compliance,
generated into a temporary folder), the search runs once locally (``--jobs 1``) and once
per cluster size on a ``distributed.LocalCluster`` (worker processes, one thread each).
Each row prints the wall time, the speed-up over the local run, and whether the answer —
the named effects, every candidate's verdict and parameters, the errors — is identical
to the local one (it must be: the same fits are made in the same order).

    PYTHONPATH=. python benchmarks/discrepancy_cluster_speed.py [--data DIR] [--workers 1,2,4]

A cluster of more workers than the machine has cores cannot be faster than one per core;
the row says how many cores the machine has.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic  # noqa: E402
from ehsa_opt.estimation.discrepancy import run_discrepancy  # noqa: E402
from ehsa_opt.estimation.discrepancy.results import DiscrepancySettings  # noqa: E402


def answer(res) -> tuple:
    return (res.effect, res.error_after, res.cut,
            tuple((c.effect, c.round, c.earns, tuple(sorted(c.parameters.items())))
                  for c in res.candidates))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=None, help="campaign directory (default: synthetic)")
    ap.add_argument("--workers", default="1,2,4")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data = args.data
        if data is None:
            data = Path(tmp) / "compliance"
            write_synthetic(data, SyntheticSpec(
                effects={"compliance": {"compliance_stiffness_N_per_m": 2e5,
                                        "compliance_damping_Ns_per_m": 300.0}},
                frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(15.0, 109.0), cycles=1.0,
                seed=4))
        kw = dict(discover=False)
        t0 = time.perf_counter()
        ref = run_discrepancy(data, DiscrepancySettings(jobs=1, **kw))
        t_ref = time.perf_counter() - t0
        print(f"{os.cpu_count()} cores; answer {ref.effect}, {ref.member_fits} member fits")
        print(f"{'run':>14} {'wall s':>8} {'speed-up':>9}  identical")
        print(f"{'local, 1 job':>14} {t_ref:8.1f} {1.0:9.2f}  -")
        from distributed import Client, LocalCluster
        for n in (int(x) for x in args.workers.split(",")):
            with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                              dashboard_address=None) as cluster, Client(cluster) as client:
                t0 = time.perf_counter()
                res = run_discrepancy(data, DiscrepancySettings(scheduler=client, **kw))
                t = time.perf_counter() - t0
            print(f"{f'{n} workers':>14} {t:8.1f} {t_ref / t:9.2f}  "
                  f"{'yes' if answer(res) == answer(ref) else 'NO'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
