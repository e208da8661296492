"""One candidate fit of the discrepancy workflow, the CVODES path against the Radau IIA
map path, in the same run.

On a campaign of the second generator's *tuning* set (never a benchmark case), the
baseline is identified once; then each named member is re-identified by
``fit_member`` (the workflow's own call: screening, effect-only Gauss–Newton, friction
split, joint refit, CVODES outputs on every fit and held-out test) with the fits'
simulations on CVODES (``rig.USE_MAP = False``, the reference) and on the compiled map
(the default).  Prints the wall time of each, the ratio, the largest relative difference
of the fitted parameters and the fit/held-out SSE of both (CVODES outputs).

``--paths map-fd,map`` compares instead the Gauss–Newton on the map with
finite-difference Jacobians (``rig.EXACT_JACOBIAN = False``, the reference) against the
map's exact sensitivities (the default); ``--paths colloc,map`` a collocation member
fitted by its collocation recipe whatever the campaign's size
(``candidate_fit.SIMULATION_RECIPE_MIN_SAMPLES`` infinite) against the default (on a
large campaign: the simulation recipe on the map).

    PYTHONPATH=. flock /tmp/ehsa-heavy.lock python benchmarks/candidate_fit_speed.py \\
        [--case t-compliance] [--members compliance,cogging] [--data-root DIR] \\
        [--paths cvodes,map | map-fd,map | colloc,map]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ehsa_opt.estimation.discrepancy import rig as rig_module  # noqa: E402
from ehsa_opt.estimation.discrepancy.candidate_fit import fit_member  # noqa: E402
from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES, components_for  # noqa: E402
from ehsa_opt.estimation.discrepancy.evidence import normalised_sse  # noqa: E402
from ehsa_opt.estimation.discrepancy.results import DiscrepancySettings  # noqa: E402
from ehsa_opt.estimation.discrepancy.workflow import (  # noqa: E402
    fit_baseline, load_data, prepare_search_tests)
from ehsa_opt.utils.process import single_threaded_blas  # noqa: E402
from validation.second_generator_cases import TUNING  # noqa: E402


def campaign(case_id: str, root: Path) -> Path:
    """The tuning campaign's directory (written by the second generator when missing)."""
    case = next((c for c in TUNING if c[0] == case_id), None)
    if case is None:
        raise SystemExit(f"--case {case_id!r} is not in the tuning set "
                         f"({', '.join(c[0] for c in TUNING)})")
    out = root / case_id
    if (out / "bench.toml").exists():
        return out
    _, _, rig, protocol, kw, seed = case
    cmd = [sys.executable, "-m", "validation.second_generator", str(out), "--rig", rig,
           "--protocol", protocol, "--seed", str(seed), "--overwrite"]
    effects = kw.get("effects")
    if effects is not None:
        for k, v in vars(effects).items():
            if v is not None and v != 0:
                cmd += ["--effect", f"{k}={v}"]
    for k in ("asym_coulomb_N", "asym_viscous_Ns_per_m"):
        if k in kw:
            cmd += [f"--{k.replace('_', '-')}", str(kw[k])]
    subprocess.run(cmd, check=True, cwd=ROOT)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="t-compliance")
    ap.add_argument("--members", default="compliance,cogging")
    ap.add_argument("--data-root", default="/tmp/ehsa_candidate_fit_speed")
    ap.add_argument("--paths", default="cvodes,map",
                    help="reference,new: cvodes,map (default), map-fd,map or colloc,map")
    args = ap.parse_args(argv)
    paths = [p.strip() for p in args.paths.split(",")]
    from ehsa_opt.estimation.discrepancy import candidate_fit
    threshold = candidate_fit.SIMULATION_RECIPE_MIN_SAMPLES
    # (use the map, exact Jacobians, sample threshold of the simulation recipe)
    flags = {"cvodes": (False, True, threshold), "map": (True, True, threshold),
             "map-fd": (True, False, threshold), "colloc": (True, True, float("inf"))}
    if len(paths) != 2 or any(p not in flags for p in paths):
        raise SystemExit("--paths: two of cvodes, map-fd, colloc, map (reference first)")
    sys.stdout.reconfigure(line_buffering=True)
    data_dir = campaign(args.case, Path(args.data_root))
    settings = DiscrepancySettings()
    quiet = lambda msg: None  # noqa: E731
    with single_threaded_blas():
        data = load_data(str(data_dir), quiet, [])
        tests = prepare_search_tests(data, settings, quiet, [])
        t0 = time.perf_counter()
        base = fit_baseline(tests, settings, quiet)
        print(f"case {args.case}: {len(tests.fit_pts)} fit tests ({len(tests.sub_pts)} for "
              f"candidate fits, {sum(p.time_s.size for p in tests.sub_pts)} samples), "
              f"{len(tests.held_pts)} held out; baseline {time.perf_counter() - t0:.1f} s")
        names = [n.strip() for n in args.members.split(",") if n.strip()]
        comps = components_for(names, tests.fit_pts, base.fit_pred, tests.lead_m_per_rad)
        rows = []
        for name in names:
            a = (name, comps[name], CANDIDATES[name].starts, tests.sub_pts, tests.fit_pts,
                 tests.held_pts, tests.rig, base.fit.parameters, settings.max_iter)
            out = {}
            for path in paths:
                (rig_module.USE_MAP, rig_module.EXACT_JACOBIAN,
                 candidate_fit.SIMULATION_RECIPE_MIN_SAMPLES) = flags[path]
                t = time.perf_counter()
                _, res, pf, ph, _ = fit_member(a)
                sec = time.perf_counter() - t
                out[path] = (sec, res, normalised_sse(tests.fit_pts, pf) if pf else np.nan,
                             normalised_sse(tests.held_pts, ph) if ph else np.nan)
                print(f"  {name:<12} {path:<6} {sec:7.1f} s  fit SSE {out[path][2]:.6g}  "
                      f"held-out SSE {out[path][3]:.6g}  {res.message[:90]}")
            rig_module.USE_MAP = rig_module.EXACT_JACOBIAN = True
            candidate_fit.SIMULATION_RECIPE_MIN_SAMPLES = threshold
            (s0, r0, f0, h0), (s1, r1, f1, h1) = out[paths[0]], out[paths[1]]
            eff = [q.name for q in comps[name].parameters]
            specs = {**rig_module.BASE_SPECS, **{q.name: q for q in comps[name].parameters}}
            # relative to the larger of the value and its typical scale (a friction level
            # fitted to ~0 would otherwise give a meaningless ratio)
            diffs = {n: abs(r1.parameters[n] - r0.parameters[n]) /
                     max(abs(r0.parameters[n]), rig_module.param_scale(specs[n]))
                     for n in r0.free if n in r1.parameters and n in specs}
            worst = max(diffs, key=diffs.get) if diffs else "-"
            print(f"  {name:<12} ratio {paths[0]}/{paths[1]} {s0 / s1:5.1f}x; effect "
                  + ", ".join(f"{n} {r0.parameters[n]:.4g} -> {r1.parameters[n]:.4g}"
                              for n in eff)
                  + f"; largest parameter change (relative to value or scale) {diffs.get(worst, 0):.2e} "
                  f"({worst}); fit SSE change {(f1 - f0) / f0:+.2e}, held-out "
                  f"{(h1 - h0) / h0:+.2e}")
            rows.append((name, s0, s1))
        print("summary: " + "; ".join(f"{n} {a:.1f} s -> {b:.1f} s ({a / b:.1f}x)"
                                      for n, a, b in rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
