"""Building the discrepancy fits' collocation NLP (``theta`` transcription of the
estimation core), CasADi's whole-graph Hessian against the Hessian assembled node by
node, in the same run.

On a campaign of the second generator's *tuning* set (never a benchmark case; written
when missing), the likelihood fit of the discrepancy workflow (``fit_group``: one
start from the linear least-squares baseline, IPOPT to convergence, covariance) is run
on the first fit tests holding about N samples, for each N of ``--sizes``, with the
NLP's Hessian differentiated by CasADi over the whole graph
(``core.STRUCTURED_HESSIAN = False``, the reference) and assembled node by node (the
default).  Prints, per size and path: the build time of the NLP (``core.build``), the
IPOPT time and iterations, the whole fit, and the largest relative difference of the
fitted parameters and of the objective between the paths.

    PYTHONPATH=. flock /tmp/ehsa-heavy.lock python benchmarks/collocation_build_speed.py \\
        [--case t-cogging] [--sizes 2500,5000,10000,15000] [--rig base|cogging] \\
        [--paths old,new]
    PYTHONPATH=. flock /tmp/ehsa-heavy.lock python benchmarks/collocation_build_speed.py \
        --member cogging [--case t-cogging]

With ``--member NAME``: instead of the sizes, the baseline is identified once and the
member re-identified by ``fit_member`` (the workflow's own call) with each path; prints
the wall time of each, the time in ``core.build`` and the fitted effect parameters.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from candidate_fit_speed import campaign  # noqa: E402

from ehsa_opt.estimation import core  # noqa: E402
from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES  # noqa: E402
from ehsa_opt.estimation.discrepancy.fit import fit_group  # noqa: E402
from ehsa_opt.estimation.discrepancy.results import DiscrepancySettings  # noqa: E402
from ehsa_opt.estimation.discrepancy.rig import linear_baseline  # noqa: E402
from ehsa_opt.estimation.discrepancy.workflow import (  # noqa: E402
    load_data, prepare_search_tests)
from ehsa_opt.utils.process import single_threaded_blas  # noqa: E402


class _Timer:
    """Wall time spent in ``core.build`` and ``core.solve_starts`` (wrapped)."""

    def __init__(self) -> None:
        self.build = self.solve = 0.0
        self._b, self._s = core.build, core.solve_starts

    def _timed(self, fn, total: str):
        def wrapped(*a, **k):
            t = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                setattr(self, total, getattr(self, total) + time.perf_counter() - t)
        return wrapped

    def __enter__(self) -> "_Timer":
        core.build = self._timed(self._b, "build")
        core.solve_starts = self._timed(self._s, "solve")
        return self

    def __exit__(self, *exc) -> None:
        core.build, core.solve_starts = self._b, self._s


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="t-cogging")
    ap.add_argument("--sizes", default="2500,5000,10000,15000")
    ap.add_argument("--rig", choices=("base", "cogging"), default="base",
                    help="the baseline's rigid rig, or with the cogging member (8 periods "
                         "per revolution)")
    ap.add_argument("--paths", default="old,new")
    ap.add_argument("--member", default=None,
                    help="one candidate fit (fit_member) with each path instead of the sizes")
    ap.add_argument("--data-root", default="/tmp/ehsa_collocation_build_speed")
    args = ap.parse_args(argv)
    sys.stdout.reconfigure(line_buffering=True)
    data_dir = campaign(args.case, Path(args.data_root))
    quiet = lambda msg: None  # noqa: E731
    paths = [p.strip() for p in args.paths.split(",") if p.strip()]
    with single_threaded_blas():
        data = load_data(str(data_dir), quiet, [])
        tests = prepare_search_tests(data, DiscrepancySettings(), quiet, [])
        rig = tests.rig
        if args.rig == "cogging":
            rig = rig.with_components([*rig.components,
                                       CANDIDATES["cogging"].component(periods_per_rev=8)])
        if args.member:
            return _member(args.member, tests, paths)
        pool = tests.fit_pts + tests.held_pts
        print(f"case {args.case}, rig {args.rig} ({len(rig.model().param_specs)} component "
              f"parameters, states {', '.join(rig.model().state_names)})")
        summary = []
        for target in [int(s) for s in args.sizes.split(",")]:
            sel, n = [], 0
            for pt in pool:
                if n >= target:
                    break
                sel.append(pt)
                n += pt.time_s.size
            start = linear_baseline(sel, rig)
            out = {}
            for path in paths:
                core.STRUCTURED_HESSIAN = path == "new"
                core._CACHE.clear()  # noqa: SLF001 - every run builds its NLP
                t = time.perf_counter()
                with _Timer() as tm:
                    res = fit_group(sel, rig, [start], max_iter=300)
                sec = time.perf_counter() - t
                out[path] = (tm.build, tm.solve, sec, res)
                print(f"  {n:6d} samples ({len(sel):2d} tests) {path}: build {tm.build:6.2f} s, "
                      f"IPOPT {tm.solve:6.2f} s ({res.nit} it), fit {sec:6.2f} s; "
                      f"{res.message}, chi2/N {res.objective:.10g}")
            core.STRUCTURED_HESSIAN = True
            if "old" in out and "new" in out:
                r0, r1 = out["old"][3], out["new"][3]
                dp = max((abs(r1.parameters[k] - r0.parameters[k])
                          / max(abs(r0.parameters[k]), 1e-12) for k in r0.free), default=0.0)
                dobj = abs(r1.objective - r0.objective) / abs(r0.objective)
                print(f"  {n:6d} samples: build old/new {out['old'][0] / out['new'][0]:6.1f}x, "
                      f"fit old/new {out['old'][2] / out['new'][2]:5.1f}x; largest relative "
                      f"parameter difference {dp:.1e}, objective {dobj:.1e}")
                summary.append(f"{n} samples: build {out['old'][0]:.1f} -> "
                               f"{out['new'][0]:.2f} s, fit {out['old'][2]:.1f} -> "
                               f"{out['new'][2]:.1f} s")
        if summary:
            print("summary: " + "; ".join(summary))
    return 0


def _member(name: str, tests, paths) -> int:
    from ehsa_opt.estimation.discrepancy.candidate_fit import fit_member
    from ehsa_opt.estimation.discrepancy.candidates import components_for
    from ehsa_opt.estimation.discrepancy.evidence import normalised_sse
    from ehsa_opt.estimation.discrepancy.workflow import fit_baseline
    settings = DiscrepancySettings()
    t = time.perf_counter()
    base = fit_baseline(tests, settings, lambda msg: None)
    print(f"{len(tests.fit_pts)} fit tests ({len(tests.sub_pts)} for candidate fits, "
          f"{sum(p.time_s.size for p in tests.sub_pts)} samples), {len(tests.held_pts)} held "
          f"out; baseline {time.perf_counter() - t:.1f} s")
    comp = components_for([name], tests.fit_pts, base.fit_pred, tests.lead_m_per_rad)[name]
    a = (name, comp, CANDIDATES[name].starts, tests.sub_pts, tests.fit_pts, tests.held_pts,
         tests.rig, base.fit.parameters, settings.max_iter)
    out = {}
    for path in paths:
        core.STRUCTURED_HESSIAN = path == "new"
        core._CACHE.clear()  # noqa: SLF001 - every run builds its NLPs
        t = time.perf_counter()
        with _Timer() as tm:
            _, res, pf, ph, _ = fit_member(a)
        sec = time.perf_counter() - t
        out[path] = sec
        eff = ", ".join(f"{q.name} {res.parameters.get(q.name, float('nan')):.6g}"
                        for q in comp.parameters)
        print(f"  {name} {path}: {sec:6.1f} s (core.build {tm.build:5.1f} s, IPOPT "
              f"{tm.solve:5.1f} s); {eff}; fit SSE "
              f"{normalised_sse(tests.fit_pts, pf) if pf else float('nan'):.8g}, held-out SSE "
              f"{normalised_sse(tests.held_pts, ph) if ph else float('nan'):.8g}; "
              f"{res.message[:80]}")
    core.STRUCTURED_HESSIAN = True
    if "old" in out and "new" in out:
        print(f"summary: {name} {out['old']:.1f} s -> {out['new']:.1f} s "
              f"({out['old'] / out['new']:.1f}x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
