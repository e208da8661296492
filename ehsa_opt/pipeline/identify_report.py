"""Reproduce-pipeline steps of the friction identification (paper §3; the real EMPS data beside it).

``step_identify_prototype``: the paper's procedure on the embedded
``bench_prototype`` data (Table 2 bounds, Figs 8–12, identifiability, joint fit
with held-out error).  ``step_identify_emps``: the real EMPS data beside the
published reference.  Both return :class:`~ehsa_opt.pipeline.reproduce.StepOutput`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..estimation.identify import IdentifyOptions, identify, simulate_tests
from ..physics.friction import rod_friction_N
from ..physics.params import FRICTION_NAMES, FrictionParams
from .step_results import IdentificationStepResult

__all__ = ["step_identify_prototype", "step_identify_emps"]


def _rel(ctx, paths: list[Path]) -> list[str]:
    return [str(Path(p).resolve().relative_to(ctx.out_dir.resolve())) for p in paths]


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def _prototype_table2_lines(data, opts, starts: int, rep, truth: dict) -> list[str]:
    """Markdown of the per-test setting and the paper-method bounds (Table 2)."""
    ok = [f for f in rep.fits if f.success]
    lines = [f"Each of the {len(data)} test(s) identified separately by direct collocation "
             f"(Radau, degree {opts.degree}, ≤ {opts.max_intervals} intervals) and IPOPT, "
             f"{starts} seeded starts each drawn in the friction parameters' distributor ranges, "
             f"{len(ok)}/{len(data)} converged (wall times: the run log at the end). "
             f"The objective is the epigraph of max(δ_V, δ_F) with the smooth "
             f"squared errors, plus 0.1 × their mean; δ below are Eq 5 as printed.\n",
             "**Friction bounds by the paper's method (paper Table 2):** per-parameter "
             "minimum and maximum over the tests. The paper's Table 2 values are not in the "
             "text we have (paper values not in the text).\n",
             "| parameter | paper method: lower bound | paper method: upper bound | "
             "truth of the synthetic data | paper |",
             "|---|---|---|---|---|"]
    for n in FRICTION_NAMES:
        lo, hi = rep.bounds.get(n, [float("nan")] * 2)
        lines.append(f"| `{n}` | {_fmt(lo)} | {_fmt(hi)} | {_fmt(truth.get(n, float('nan')))} "
                     f"| not in the text |")
    return lines


def _fit_quality_lines(ctx, ok: list, path) -> list[str]:
    """Markdown of Eq 5 and the force error over the converged tests, with the hidden effects."""
    from ..datasets.embedded import load_truth
    dF = [f.delta_F for f in ok]
    dV = [f.delta_V for f in ok if f.delta_V is not None]
    rel = [f.force_relative_error_percent for f in ok]
    dv_txt = f", δ_V {min(dV):.3f}–{max(dV):.3f}" if dV else " (no voltage)"
    hidden = ", ".join((load_truth(path) or {}).get("effects", {}))
    if "backlash" in hidden and not ctx.custom_data:
        tail = ("The data hide backlash, which the rigid model cannot follow: the residual "
                "peaks after each reversal (Fig 11) are the paper's finding.")
    else:
        tail = (f"Hidden effects in the data (truth.toml): {hidden}; the discrepancy step "
                "below looks for them." if hidden else "")
    return ["", f"Eq 5 over the tests: δ_F {min(dF):.3f}–{max(dF):.3f}{dv_txt}; force "
            f"relative error {min(rel):.2f}–{max(rel):.2f} %. {tail}\n"]


def _identifiability_lines(ctx, rep, ok: list, opts) -> list[str]:
    """Markdown of identifiability, spread across tests, voltage and the joint fit."""
    lines: list[str] = []
    ident = rep.identifiable
    spread = ident.get("relative_spread_of_parameters", {})
    rod = ident.get("rod_friction_spread_by_velocity_m_per_s", {})
    weak = ident.get("non_identifiable_directions", {})
    lines += ["**Identifiability (beyond the paper).** At each optimum the Fisher information "
              "of the 8 parameters (collocation states eliminated, initial state marginalised) "
              "was eigen-decomposed. Directions the data do not determine (relative eigenvalue "
              f"< {opts.identifiable_rtol:g}), counted over the tests:\n",
              "| direction (main components) | tests |", "|---|---|"]
    for k, v in sorted(weak.items(), key=lambda kv: (-kv[1], kv[0])):  # ties by name
        lines.append(f"| {k} | {v} |")
    lines += ["", "Spread across tests (std / mean) of the raw parameters against the spread "
              "of the identifiable combination, the total friction at the rod "
              "F_ns(v) + T_b(v/r)/r:\n", "| quantity | relative spread |", "|---|---|"]
    for n, v in spread.items():
        lines.append(f"| `{n}` | {v:.2f} |")
    for v, d in rod.items():
        lines.append(f"| rod friction at {v} m/s ({d['mean_N']:.1f} N) | "
                     f"{d['relative_spread']:.3f} |")
    raw = [v for v in spread.values()]
    rods = [d["relative_spread"] for d in rod.values()]
    if len(ok) < 2:
        lines += ["", "One test only: there is no spread across tests to compare (the "
                  "confidence band of the bounds below is this test's own). Figs 10 and 12 compare "
                  "the tests (objective against a parameter across tests, per-test values "
                  "and their min/max) and are not drawn for a single test.\n"]
    elif raw and rods:
        lines += ["", f"The raw parameters spread by {100 * min(raw):.0f}–{100 * max(raw):.0f} % "
                  f"across the tests, the rod total by {100 * min(rods):.1f}–"
                  f"{100 * max(rods):.1f} %. Most of the per-test spread of Table 2 is therefore "
                  "**non-identifiability**: the nut/bearing split (viscous exactly — only "
                  "f_v + t_v/r² is determined —, Coulomb and breakaway nearly, since both tanh "
                  "laws saturate within a few mm/s) wanders from test to test. The rest, the "
                  "spread of the rod total itself, is **real variation** of the best rigid-model "
                  "fit: " + ("the hidden backlash, whose contact peaks the friction absorbs "
                  "differently at each frequency and load." if not ctx.custom_data else
                  "whatever the rigid model misses (see the discrepancy step), which the "
                  "friction absorbs differently at each frequency and load.") + " On clean synthetic data (no hidden "
                  "effect) the same procedure recovers the rod total of every test within about "
                  "1 % of the truth: `python benchmarks/identify_speed.py` prints the "
                  "median and worst over the 21 tests of held-out synthetic data.\n"]
    if ident.get("voltage_independent_of_friction"):
        lines += ["**The voltage does not constrain the friction.** "
                  + ident["voltage_independent_of_friction"] + "\n"]
    if rep.joint is not None and rep.joint.success:
        he = rep.holdout_errors
        tr = rep.joint.per_test
        lines += [f"**Joint fit.** One parameter set for {len(tr)} tests, validated on "
                  f"{len(he)} held-out tests ({', '.join(rep.holdout_files)}): training "
                  f"force error {np.mean([x['force_relative_error_percent'] for x in tr]):.2f} "
                  f"% (mean), held-out "
                  f"{np.mean([x['force_relative_error_percent'] for x in he]):.2f} "
                  f"% (mean), held-out δ_F {min(x['delta_F'] for x in he):.3f}–"
                  f"{max(x['delta_F'] for x in he):.3f}.\n"]
    return lines


def _prototype_results(data, rep, ok: list, fb) -> dict:
    """Results of the prototype identification (:class:`IdentificationStepResult`):
    convergence, rod friction, the friction sets of the §4 studies and the design."""
    from ..datasets.friction_source import FrictionSets
    rod = rep.identifiable.get("rod_friction_spread_by_velocity_m_per_s", {})
    sets = None
    if fb is not None:
        paper = fb.paper_sets or {}
        sets = FrictionSets(fb.sets["min"], fb.sets["best"], fb.sets["max"], fb.method,
                            paper.get("min"), paper.get("max"))
    return IdentificationStepResult(
        len(ok), len(data), rep.seconds, data.harvester.lead_m_per_rad, data.has_generator,
        {v: d["mean_N"] for v, d in rod.items()},
        None if fb is None else float(fb.data_range_m_per_s[1]), sets).to_dict()


def step_identify_prototype(ctx):
    """Per-test identification of the embedded prototype data, bounds, identifiability."""
    from ..datasets.bench_format import load_bench
    from ..datasets.embedded import load_truth
    from ..estimation.bounds import friction_bounds
    from ..utils.io import atomic_write_json
    from .base import StepOutput

    path = ctx.bench_dir
    data = load_bench(path)
    truth = (load_truth(path) or {}).get("friction", {})
    starts = 2 if ctx.quick else 4
    opts = IdentifyOptions(max_samples=500, max_intervals=100) if ctx.quick else IdentifyOptions()
    if not data.has_generator:
        opts = IdentifyOptions.for_rig(False)
    rep = identify(data, starts=starts, jobs=ctx.jobs, seed=0, options=opts)
    figdir = ctx.figure_dir / "identify_prototype"
    figs = _rel(ctx, rep.write(figdir))
    try:
        fb = friction_bounds(rep)
    except ValueError:
        fb = None
    doc = rep.to_dict()
    if fb is not None:
        doc.update(fb.to_dict())
        from .. import plots
        rel_b = "figures/identify_prototype/friction_bounds.png"
        plots.save(fb.plot(truth=_truth_params(truth)), ctx.out_dir / rel_b)
        figs.append(rel_b)
    atomic_write_json(ctx.out_dir / "identify_prototype.json", _portable(doc, ctx.out_dir))
    ok = [f for f in rep.fits if f.success]
    lines = _prototype_table2_lines(data, opts, starts, rep, truth)
    if not ok:
        return StepOutput("\n".join(lines[:1]) + "\nNo test converged: no bounds.\n", figs,
                          IdentificationStepResult(0, len(data)).to_dict())
    lines += _fit_quality_lines(ctx, ok, path)
    lines += _identifiability_lines(ctx, rep, ok, opts)
    if fb is not None:
        lines += _bounds_markdown(fb, truth)
    for f in figs:
        lines.append(f"![{Path(f).stem}]({f})")
    lines.append(f"\n*Figs 8–12. Identification of the {len(data)}-test campaign ({len(ok)} "
                 f"fits converged): objective and parameters over the iterations, objective "
                 f"against the total variation, measured against simulated force, per-test "
                 f"values with their min/max, identifiability, the joint fit on held-out tests"
                 + (", and the friction sets min ≤ best ≤ max over stroke velocity"
                    if fb is not None else "") + ".*")
    return StepOutput("\n".join(lines) + "\n", figs, _prototype_results(data, rep, ok, fb))


def _truth_params(truth: dict) -> "FrictionParams | None":
    from ..physics.params import FrictionParams
    return FrictionParams(**truth) if truth else None


def _bounds_markdown(fb, truth: dict) -> list[str]:
    """The data-supported and the paper's bounds side by side, at the rod."""
    from ..estimation.bounds import PAPER_METHOD
    tp = _truth_params(truth)
    vmax = float(fb.velocity_m_per_s.max())
    v_hi = float(fb.data_range_m_per_s[1])
    vs = [v for v in (0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 1.5, 2.0, 3.0)
          if v <= vmax * (1 + 1e-9)]
    head = ("| velocity (m/s) | data: min set | data: lower envelope | data: best | "
            "data: upper envelope | data: max set | paper method: min | paper method: max |"
            + (" truth |" if tp else ""))
    out = ["", "**Friction bounds the data support (beyond the paper).** A rigid bench "
           "determines only the total friction at the rod, F_rod(v) = F_ns(v) + T_b(v/r)/r, "
           "and only up to each test's peak velocity. The envelope below is the lowest and "
           "highest per-test rod friction, each widened by its own confidence band "
           f"({fb.band}); `min`/`max` are admissible friction sets fitted at or below / at "
           "or above it (nut/bearing split: the best set's bearing torques times one fitted "
           "factor — the data do not determine the split), `best` = "
           + fb.method.split("best = ")[-1] + ". The §4 studies below use these "
           "**data-supported** sets. Beside them the " + PAPER_METHOD + ". Rod friction (N):\n",
           head, "|" + "---|" * (head.count("|") - 1)]
    def f1(x: float) -> str:
        return "—" if not np.isfinite(x) else f"{x:.1f}"
    for v in vs:
        a = fb.at(v)
        lab = f"{v:g}" + (" (extrapolated)" if v > v_hi * (1 + 1e-9) else "")
        row = (f"| {lab} | {f1(a['min_N'])} | {f1(a['lower_N'])} | {f1(a['best_N'])} | "
               f"{f1(a['upper_N'])} | {f1(a['max_N'])} | {f1(a.get('paper_min_N', np.nan))} | "
               f"{f1(a.get('paper_max_N', np.nan))} |")
        if tp:
            row += f" {float(rod_friction_N(v, tp, fb.lead_m_per_rad)):.1f} |"
        out.append(row)
    law = fb.law or {}
    hw1 = 0.5 * (fb.at(1.0)["max_N"] - fb.at(1.0)["min_N"]) if vmax >= 1.0 else float("nan")
    out += ["", f"**Where the sets hold.** The bench campaign reaches {v_hi:.2f} m/s "
            f"(`velocity_range` in the identification result: every test's peak and the "
            f"campaign's); every vehicle table below states how much of its time and friction "
            f"energy lies above it. Up to {v_hi:.2f} m/s the sets enclose the tests' envelope; "
            f"above it they are **extrapolations** of the best law, with a band that widens as "
            f"the uncertainty of the law's high-velocity part (viscous coefficient, Coulomb "
            f"level) does: the best law's 95 % band from its sandwich covariance over "
            f"{law.get('n_samples', 0)} friction samples of {law.get('n_tests', 0)} tests — "
            f"effective sample size {law.get('n_effective', float('nan')):.0f} (Newey–West "
            f"on the autocorrelated residuals), and the cluster-robust band (tests as "
            f"clusters) where it is wider. **min ≤ best ≤ max at every velocity up to "
            f"{vmax:g} m/s by construction** (the best set minus / plus non-negative amounts "
            f"of its own Coulomb, Stribeck and viscous shapes). At 1 m/s the sets span "
            f"±{hw1:.0f} N around the best law.\n",
            "**What changed against the earlier sets, and why.** The earlier `min`/`max` sets "
            "were fitted freely below / above the envelope *inside* the data only; nothing "
            "held their shapes beyond it, and on this campaign they crossed at about 0.45 m/s "
            "(at 1 m/s the `min` set gave 333 N and the `max` set 246 N, the truth 256 N: "
            "`min` had a viscous coefficient of 268 N s/m, `max` 80). So every study that "
            "reaches road velocities (Figs 15/16/20/21, Table 4, the robust design's worst "
            "case) compared two sets in the wrong order there — 'min friction' gave *less* "
            "power than 'max'. Now the order holds everywhere and the spread at road "
            "velocities is the honest extrapolation band, not the accident of a free fit.\n"]
    out += ["", "Data-supported friction sets (parameter names as in the design card; also `friction_sets` in "
            "`identify_prototype.json`, usable as `--friction identify_prototype.json:CASE`):\n",
            "| parameter | min | best | max | paper method: min | paper method: max |",
            "|---|---|---|---|---|---|"]
    for n in FRICTION_NAMES:
        pm = [fb.paper_sets[c].as_dict()[n] if fb.paper_sets else float("nan")
              for c in ("min", "max")]
        out.append(f"| `{n}` | " + " | ".join(_fmt(fb.sets[c].as_dict()[n])
                                              for c in ("min", "best", "max"))
                   + f" | {_fmt(pm[0])} | {_fmt(pm[1])} |")
    out.append("")
    return out


def step_identify_emps(ctx):
    """EMPS identification beside the published reference (Janot et al. 2019)."""
    from ..datasets.bench_format import load_bench
    from ..datasets.embedded import embedded_data_dir
    from .paper_reference import EMPS_REFERENCE
    from ..estimation.identify import force_relative_error_percent
    from ..utils.io import atomic_write_json
    from .base import StepOutput

    data = load_bench(embedded_data_dir("emps"))
    rep = identify(data, starts=2 if ctx.quick else 4, jobs=1, seed=0)
    f = rep.fits[0]
    figs = _rel(ctx, rep.write(ctx.figure_dir / "identify_emps"))
    atomic_write_json(ctx.out_dir / "identify_emps.json", _portable(rep.to_dict(), ctx.out_dir))
    if not f.success:
        return StepOutput(f"EMPS identification failed: {f.message}\n", figs, {"success": False})
    p = f.parameters
    ci = f.identifiability["combinations"] if f.identifiability else {}
    val = load_bench(embedded_data_dir("emps/validation"))
    pv = simulate_tests(val.tests, val.harvester, p, has_generator=False,
                        options=IdentifyOptions.for_rig(False))[0]
    val_err = force_relative_error_percent(pv.force_N, val.tests[0].force_N)

    def c(name: str) -> str:
        if name in ci:
            lo, hi = ci[name]["ci95"]
            return f" (95 % CI {lo:.4g}–{hi:.4g})"
        return ""
    ref = EMPS_REFERENCE
    rows = [("M (kg)", p["inertia_kg"], ref["inertia_kg"], c("inertia_kg")),
            ("F_v (N s/m)", p["nut_viscous_Ns_per_m"], ref["viscous_Ns_per_m"],
             c("total_viscous_Ns_per_m")),
            ("F_C (N)", p["nut_coulomb_N"], ref["coulomb_N"], c("total_coulomb_N")),
            ("offset (N)", p["offset_N"], ref["offset_N"], c("offset_N")),
            ("force relative error (%)", f.force_relative_error_percent,
             ref["force_relative_error_percent"], "")]
    lines = ["The real EMPS ball-screw record (Janot et al. 2019; 24 841 samples at 1 kHz) is "
             "identified by the same command as the bench tests (`ehsa-opt identify data/emps`): "
             "a rig without generator, so the model is M a + F_0 + F_ns(v) with the "
             "Simscape law. To compare with the reference model M a + F_v v + F_C sign(v) + "
             "offset, the Stribeck part is removed: F_brk is tied to F_C and the breakaway "
             "velocity fixed at 1 mm/s (so tanh(v/0.1 mm/s) ≈ sign v). The displacement is "
             "differentiated by a smoothing spline with a 60 Hz equivalent cut-off (GCV "
             "over-smooths: M +7 %).\n",
             "| quantity | ours | published reference |", "|---|---|---|"]
    for name, ours, pub, extra in rows:
        lines.append(f"| {name} | {ours:.4g}{extra} | {pub:g} |")
    lines += ["", f"Eq 5 as printed: δ_F = {f.delta_F:.4f}. On the validation record with "
              f"pulses (5 V steps of the controller output, 176 N each, contained in the recorded "
              f"force; their sharp edges excite what the rigid model lacks) the identified "
              f"model gives a force "
              f"relative error of {val_err:.2f} %. Our error is a little above the reference's "
              f"{ref['force_relative_error_percent']} % because the reference fits filtered, "
              f"decimated data with sign(v); we fit the raw 1 kHz force.\n"]
    lines.append("One record only: Figs 10 and 12 compare tests (objective against a "
                 "parameter across tests, per-test values and their min/max), so they are not "
                 "drawn for EMPS.\n")
    for fig in figs:
        lines.append(f"![{Path(fig).stem}]({fig})")
    lines.append(f"\n*EMPS identification: objective and parameters over the iterations, "
                 f"measured against simulated force (relative error "
                 f"{f.force_relative_error_percent:.2f} % on the identification record, "
                 f"{val_err:.2f} % on the validation record) and identifiability.*")
    res = {"inertia_kg": p["inertia_kg"], "viscous_Ns_per_m": p["nut_viscous_Ns_per_m"],
           "coulomb_N": p["nut_coulomb_N"], "offset_N": p["offset_N"],
           "force_relative_error_percent": f.force_relative_error_percent,
           "validation_force_relative_error_percent": val_err}
    return StepOutput("\n".join(lines) + "\n", figs, res)


def _portable(doc: dict, folder: Path) -> dict:
    """An identification document whose ``data_dir`` is relative to the folder it is
    written to (it is resolved against that folder when read back): no absolute path of
    this machine in a committed result."""
    from ..utils.io import relative_path
    if doc.get("data_dir"):
        return {**doc, "data_dir": relative_path(doc["data_dir"], folder)}
    return doc
