"""One member fit of the discrepancy workflow, the reference simulation path against
the current one, in the same run.

On a campaign directory (a *tuning* campaign of the second generator, never a
benchmark case), the baseline is identified once; then each named member is
re-identified by ``fit_member`` (the workflow's own call) twice:

* reference: the compiled map accumulates every sub-step of a record and hands all
  of them back (``bench_map.FOLD_SUBSTEPS = False``), and the Gauss–Newton on the map
  simulates each trial point and again, with sensitivities, each accepted point
  (``polish.REUSE_SENSITIVITIES = False``);
* current (the defaults): the sub-steps of a sample interval folded inside the
  compiled loop, and one sensitivity run per point whose Jacobian serves the accepted
  point.

Both give the same numbers bit for bit; the script prints each wall time, the ratio,
the largest relative change of the fitted parameters and of the fit / held-out SSE
(CVODES outputs), which should all be 0.  The model's compiled functions are built
before either is timed (they are cached on the model and shared by both).

    PYTHONPATH=. flock /tmp/ehsa-heavy.lock python benchmarks/member_fit_speed.py \\
        --data /tmp/lead/data_tuning3/t3-heating-c [--members winding_heating,compliance,cogging]

``--only reference`` / ``--only current`` runs one path alone (whole-process timings).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ehsa_opt.estimation.discrepancy import polish as polish_module  # noqa: E402
from ehsa_opt.estimation.discrepancy.candidate_fit import fit_member  # noqa: E402
from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES, components_for  # noqa: E402
from ehsa_opt.estimation.discrepancy.evidence import normalised_sse  # noqa: E402
from ehsa_opt.estimation.discrepancy.results import DiscrepancySettings  # noqa: E402
from ehsa_opt.estimation.discrepancy.workflow import (  # noqa: E402
    fit_baseline, load_data, prepare_search_tests)
from ehsa_opt.physics import bench_map  # noqa: E402
from ehsa_opt.utils.process import single_threaded_blas  # noqa: E402

#: (fold the sub-steps, reuse the sensitivity run) of each path
PATHS = {"reference": (False, False), "current": (True, True)}


def _set(path: str) -> None:
    bench_map.FOLD_SUBSTEPS, polish_module.REUSE_SENSITIVITIES = PATHS[path]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="campaign directory (bench.toml, CSVs)")
    ap.add_argument("--members", default="winding_heating,compliance,cogging")
    ap.add_argument("--order", default="reference,current",
                    help="which path runs first for each member")
    ap.add_argument("--only", choices=sorted(PATHS),
                    help="run this path alone (to time whole processes against each other)")
    args = ap.parse_args(argv)
    order = [p.strip() for p in args.order.split(",")]
    if args.only:
        order = [args.only]
    elif sorted(order) != sorted(PATHS):
        raise SystemExit("--order: reference and current, in some order")
    sys.stdout.reconfigure(line_buffering=True)
    settings = DiscrepancySettings()
    quiet = lambda msg: None  # noqa: E731
    rows = []
    with single_threaded_blas():
        data = load_data(args.data, quiet, [])
        tests = prepare_search_tests(data, settings, quiet, [])
        base = fit_baseline(tests, settings, quiet)
        print(f"{args.data}: {len(tests.sub_pts)} tests for candidate fits "
              f"({sum(p.time_s.size for p in tests.sub_pts)} samples), "
              f"{len(tests.fit_pts)} fit, {len(tests.held_pts)} held out")
        names = [n.strip() for n in args.members.split(",") if n.strip()]
        comps = components_for(names, tests.fit_pts, base.fit_pred, tests.lead_m_per_rad)
        for name in names:
            model = tests.rig.with_components([*tests.rig.components, comps[name]]).model()
            if model.n_states:  # compile once, outside the timings (cached on the model)
                bench_map._sensitivity_substep_function(model)
            a = (name, comps[name], CANDIDATES[name].starts, tests.sub_pts, tests.fit_pts,
                 tests.held_pts, tests.rig, base.fit.parameters, settings.max_iter)
            out = {}
            for path in order:
                _set(path)
                t = time.perf_counter()
                _, res, pf, ph, _ = fit_member(a)
                sec = time.perf_counter() - t
                out[path] = (sec, res.parameters,
                             normalised_sse(tests.fit_pts, pf) if pf else np.nan,
                             normalised_sse(tests.held_pts, ph) if ph else np.nan)
                print(f"  {name:<18} {path:<9} {sec:7.1f} s  fit SSE {out[path][2]:.10g}  "
                      f"held-out SSE {out[path][3]:.10g}")
            _set("current")
            if args.only:
                continue
            (s0, p0, f0, h0), (s1, p1, f1, h1) = out["reference"], out["current"]
            dp = max((abs(p1[n] - v) / max(abs(v), 1e-300) for n, v in p0.items()), default=0.0)
            print(f"  {name:<18} ratio {s0 / s1:4.2f}x; largest relative parameter change "
                  f"{dp:.1e}; fit SSE {abs(f1 - f0) / f0:.1e}, held-out {abs(h1 - h0) / h0:.1e}")
            rows.append((name, s0, s1))
    if args.only:
        return 0
    print("summary: " + "; ".join(f"{n} {a:.1f} s -> {b:.1f} s ({a / b:.2f}x)"
                                  for n, a, b in rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
