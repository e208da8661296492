"""Reproduce-pipeline steps of the quarter car (paper §4.1 and Fig 21).

Each function is ``(ctx: Context) -> StepOutput``; the steps are appended to
:data:`ehsa_opt.pipeline.reproduce.STEPS`.  ``ctx.quick`` shortens the roads and the
frequency sweep (all five steps together take well under two minutes quick).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import plots
from ..physics.params import HarvesterParams, RoadParams, VehicleParams
from ..plots import quarter_car as qplots
from ..vehicle.frequency_path import (METRIC_KEYS, linear_frequency_response, linear_metrics)
from ..vehicle.iso2631 import ISO2631_WK_TABLE, wk_exact, wk_fit_error, wk_state_space
from ..vehicle.simulate import simulate_quarter_car
from ..vehicle.studies import (force_velocity_loops, friction_cases, paper_optimum_harvester,
                               road_study, stepped_sine_response)
from ..vehicle.validity import check_validity, study_sample_limits
from .base import Context, StepOutput
from .step_results import DesignStepResult
from .coverage_report import RANGE_HEADER, identified_range, range_cell, range_flag
from .paper_reference import (EXPECTED_DISSIPATION_BOUND_W, PAPER_FIG14_RANGES, PAPER_FIG21,
                              PAPER_OPTIMUM, PAPER_ROAD_STUDY)
from .vehicle_intervals_report import (LIMITS_HEADER, caption, fig13_caption, fig21_caption,
                                       intervals_note, limits_cell, limits_note, report_seeds,
                                       road_caption, stroke_cell, versus_paper)

__all__ = ["step_quarter_car_paths", "step_fig13", "step_fig14", "step_fig15_16", "step_fig21",
           "friction_inputs", "road_study_conclusions", "COMFORT_SAME_PERCENT"]


def friction_inputs(ctx: Context) -> Any:
    """What the friction cases depend on (for the step cache)."""
    sets = ctx.friction_sets()
    return {"quick": ctx.quick,
            "friction_min": sets and {**sets.min.as_dict(), **sets.min.law_dict()},
            "friction_max": sets and {**sets.max.as_dict(), **sets.max.law_dict()},
            "context": ctx.inputs()}


def _not_applicable(ctx: Context) -> StepOutput | None:
    """The §4 studies need a harvester with a generator."""
    if ctx.has_generator:
        return None
    return StepOutput("Not applicable: the bench data come from a rig without a generator "
                      "(no voltage), so neither the harvester's electrical side nor its "
                      "friction at the generator bearings is known; the quarter-car studies "
                      "of a harvester need both.\n", [], {"applicable": False})


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def step_quarter_car_paths(ctx: Context) -> StepOutput:
    """W_k check, frequency vs time domain on the frictionless default design, bound."""
    f_tab = np.array(list(ISO2631_WK_TABLE))
    ours = np.abs(wk_exact(f_tab))
    dev = 100 * np.max(np.abs(ours / np.array(list(ISO2631_WK_TABLE.values())) - 1))
    rows = ["| f (Hz) | ISO 2631-1 table | exact W_k (ours) |", "|---|---|---|"]
    for f in (0.5, 1.0, 2.0, 4.0, 6.3, 8.0, 16.0, 31.5, 63.0):
        rows.append(f"| {f:g} | {ISO2631_WK_TABLE[f]:.3f} | {abs(wk_exact(f)):.3f} |")
    fit_rows = ["| fit order | max error 0.5–80 Hz | rms error |", "|---|---|---|"]
    for order in (4, 6, 8):
        e = wk_fit_error(order)
        fit_rows.append(f"| {order} | {100 * e['max_rel_error']:.2f} % | "
                        f"{100 * e['rms_rel_error']:.2f} % |")
    ff = np.logspace(-1, 2.3, 400)
    fig = qplots.wk_figure(ff, np.abs(wk_exact(ff)), np.abs(wk_state_space(6).response(ff)),
                           ISO2631_WK_TABLE, "6-state fit")
    rel_wk = "figures/qc_wk.png"
    plots.save(fig, ctx.out_dir / rel_wk)

    vehicle = ctx.vehicle()[0]
    length = 500.0 if ctx.quick else 2000.0
    road = RoadParams(iso_class="C", speed_km_per_h=100.0, length_m=length, seed=0)
    loads = [10.0, 47.0, 100.0]
    sim = simulate_quarter_car(vehicle, [HarvesterParams(load_ohm=r) for r in loads], None,
                               road, warn=False, keep_series=True)  # series: sim.plot
    freq = linear_metrics(vehicle, road, {"load_ohm": np.array(loads)})
    cmp_rows = ["| metric | " + " | ".join(f"R_e = {r:g} Ω: time / freq" for r in loads) + " |",
                "|---|" + "---|" * len(loads)]
    worst = 0.0
    for key in METRIC_KEYS:
        cells = []
        for i in range(len(loads)):
            a, b = float(sim.metrics[key][i]), float(freq[key][i])
            worst = max(worst, abs(a / b - 1))
            cells.append(f"{_fmt(a)} / {_fmt(b)}")
        cmp_rows.append(f"| {key} | " + " | ".join(cells) + " |")
    fig = sim.plot(k=1)
    rel_sim = "figures/qc_overview.png"
    plots.save(fig, ctx.out_dir / rel_sim)
    md = (
        "**ISO 2631-1 W_k** (exact product of the four filters) against the standard's "
        f"table: max deviation {dev:.2f} % over 0.5–80 Hz.\n\n" + "\n".join(rows) + "\n\n"
        "Low-order state-space fits of |W_k| for time-domain filtering (stable, minimum-phase; "
        "metrics use the exact W_k):\n\n" + "\n".join(fit_rows) + f"\n\n![W_k]({rel_wk})\n"
        + caption("W_k", f"|W_k| of ISO 2631-1: the exact product of its four filters, a "
                  f"6-state fit (max error {100 * wk_fit_error(6)['max_rel_error']:.2f} % over "
                  f"0.5–80 Hz) and the standard's table (max deviation {dev:.2f} %)") + "\n"
        f"**Two evaluation paths**, frictionless passenger car, Table 1 prototype, class C, "
        f"100 km/h, {length:g} m road (time domain: compiled batch; frequency domain: exact "
        f"Eqs 2–3 with the full electrical impedance on the ISO 8608 PSD). Largest relative "
        f"difference: **{100 * worst:.2f} %**. Dissipation bound π² k1 G_d(n0) n0² V = "
        f"{float(freq['dissipation_bound_W'][0]):.1f} W (expected ≈ "
        f"{EXPECTED_DISSIPATION_BOUND_W:g} W for this road and speed).\n\n"
        + "\n".join(cmp_rows) + f"\n\n![overview]({rel_sim})\n"
        + caption("Overview", f"The frictionless prototype at R_e = {loads[1]:g} Ω on the "
                  f"{length:g} m class C road at 100 km/h: road and sprung displacement, load "
                  f"power (mean {float(sim.metrics['power_W'][1]):.1f} W on this road), sprung "
                  f"acceleration and damper force against stroke velocity (no friction: "
                  f"the road study below shades the friction's identified range)"))
    return StepOutput(md, [rel_wk, rel_sim],
                      {"wk_max_dev_percent": dev, "paths_max_rel_diff": worst,
                       "comfort_default": float(freq["comfort_weighted_rms_m_s2"][1])})


def step_fig13(ctx: Context) -> StepOutput:
    if (na := _not_applicable(ctx)) is not None:
        return na
    fc = friction_cases(ctx.friction_sets(), ctx.friction_bounds)
    loads = [15.0, 47.0, 109.0]
    v_road = 2.0 * np.pi * 0.01  # 10 mm at 1 Hz, falling as 1/f
    # log grid plus the exact frictionless peaks of x2 and V_g per load, plus points around the body (~1.1 Hz) and wheel-hop (~8 Hz) modes, so the
    # resonances are resolved in quick mode too
    freqs = np.unique(np.round(np.concatenate([
        np.geomspace(0.5, 20.0, 12 if ctx.quick else 30),
        np.linspace(0.8, 1.6, 5 if ctx.quick else 9),
        np.linspace(6.5, 10.0, 5 if ctx.quick else 9),
        _exact_peaks(ctx.vehicle()[0], ctx.harvester(), loads)]), 4))
    v_ident, v_source = identified_range(ctx)
    study = stepped_sine_response(ctx.vehicle()[0], ctx.harvester(), fc, loads,
                                  freqs, velocity_amplitude_m_per_s=v_road,
                                  max_time_s=20.0 if ctx.quick else 60.0,
                                  identified_range_m_per_s=v_ident)
    rel = "figures/fig13_frequency_response.png"
    plots.save(study.plot(), ctx.out_dir / rel)
    i_none, i_max = study.cases.index("none"), study.cases.index("max")
    ratio = 100 * study.voltage_amplitude_V[i_max, 1] / study.voltage_amplitude_V[i_none, 1]
    ratio_lo, ratio_hi = float(ratio[0]), float(ratio[-1])
    rows = ["| friction | R_e (Ω) | peak x2/x0 | at (Hz) | max V_g amplitude (V) | at (Hz) | "
            f"steady | largest stroke (mm) | {RANGE_HEADER} (worst frequency) |",
            "|---|---|---|---|---|---|---|---|---|"]
    beyond = study.beyond_stroke_limit()
    lim_mm = 1e3 * study.stroke_limit_m
    oor_t, oor_e = [], []
    for i, c in enumerate(study.cases):
        for j, r in enumerate(study.loads_ohm):
            k = int(np.argmax(study.sprung_transmissibility[i, j]))
            kv = int(np.argmax(study.voltage_amplitude_V[i, j]))
            ok = bool(study.settled[i, j].all())
            t_ij = study.out_of_range_time_fraction[i, j]
            e_ij = study.out_of_range_friction_energy_fraction[i, j]
            kw = int(np.nanargmax(np.fmax(t_ij, np.nan_to_num(e_ij))))
            e_cell = None if c == "none" else float(e_ij[kw])
            oor_t.append(float(t_ij[kw]))
            oor_e.append(e_cell)
            rows.append(f"| {c} | {r:g} | {study.sprung_transmissibility[i, j, k]:.2f} | "
                        f"{study.frequencies_hz[k]:.2f} | "
                        f"{study.voltage_amplitude_V[i, j, kv]:.1f} | "
                        f"{study.frequencies_hz[kv]:.2f} | "
                        + ("yes" if ok else "**NO** at " + ", ".join(
                            f"{study.frequencies_hz[q]:.2f} Hz (change "
                            f"{100 * study.amplitude_change[i, j, q]:.1f} %)"
                            for q in np.flatnonzero(~study.settled[i, j])))
                        + f" | {stroke_cell(study, i, j)}"
                        + f" | {range_cell(t_ij[kw], e_cell)} (at "
                        f"{study.frequencies_hz[kw]:.2f} Hz) |")
    for j, r in enumerate(study.loads_ohm):
        k = int(np.argmax(study.linear_transmissibility[j]))
        kv = int(np.argmax(study.linear_voltage_amplitude_V[j]))
        rows.append(f"| none, exact linear | {r:g} | {study.linear_transmissibility[j, k]:.2f} | "
                    f"{study.frequencies_hz[k]:.2f} | "
                    f"{study.linear_voltage_amplitude_V[j, kv]:.1f} | "
                    f"{study.frequencies_hz[kv]:.2f} | exact | | |")
    # conclusions from the numbers: settled points only
    ok_none, ok_max = study.settled[i_none], study.settled[i_max]
    peak = lambda i, j: float(np.nanmax(np.where(study.settled[i, j],  # noqa: E731
                                              study.sprung_transmissibility[i, j], np.nan)))
    flat = [(r, 100 * (1 - peak(i_max, j) / peak(i_none, j)))
            for j, r in enumerate(study.loads_ohm)
            if study.settled[[i_max, i_none], j, :][:, (study.frequencies_hz > 0.7)
                                                    & (study.frequencies_hz < 1.7)].all()]
    flat_text = ("lowers the body-resonance peak of x2/x0 by "
                 + ", ".join(f"{v:.0f} % (R_e = {r:g} Ω)" for r, v in flat)
                 if flat else "changes the body-resonance peak by an amount not stated "
                 "(points near it did not settle)")
    n_bad = int(np.size(study.settled) - np.count_nonzero(study.settled))
    n_stroke = int(np.count_nonzero(beyond.any(axis=-1)))
    stroke_text = (f" **{n_stroke} curve(s) need a stroke beyond the ±{lim_mm:g} mm limit** at "
                   "some frequency (bold in the table, □ in the figure): the suspension would "
                   "hit its bump stops there, which the model does not have, so those points "
                   "are not valid." if n_stroke else
                   f" Every point keeps the stroke within the ±{lim_mm:g} mm limit.")
    unsettled = ("" if n_bad == 0 else
                 f" **{n_bad} points did not settle** within the time limit; they are marked "
                 "in the table and left out of the sentences below.")
    volt_text = (f"with the 'max' friction the voltage at R_e = {study.loads_ohm[1]:g} Ω is "
                 f"{ratio_lo:.0f} % of the frictionless value at {study.frequencies_hz[0]:g} Hz "
                 f"and {ratio_hi:.0f} % at {study.frequencies_hz[-1]:g} Hz"
                 if ok_none[1, [0, -1]].all() and ok_max[1, [0, -1]].all() else
                 "the voltage ratio at the band's ends is not stated (a point did not settle)")
    md = (f"Stepped-sine simulation at steady state (nonlinear: friction), passenger car, "
          f"Table 1 prototype, road sine of constant velocity amplitude {1e3 * v_road:.1f} mm/s "
          f"(10 mm at 1 Hz, displacement falling as 1/f like a road's, so the voltages stay "
          f"physical) **(assumption: the paper's road input is not in the text)**, "
          f"{len(freqs)} frequencies 0.5–20 Hz, loads 15/47/109 Ω. Friction: {fc.source}.\n\n"
          "Steady state by construction: each point starts from the exact frictionless steady "
          "state and runs in windows of whole cycles (≥ 1 s) until the fundamental amplitudes "
          f"of x2 and V_g change by less than {100 * study.tolerance:g} % from one window to "
          f"the next (at most {20 if ctx.quick else 60} s). Check: without friction the "
          "simulation equals the exact linear response "
          f"within **{100 * study.frictionless_deviation():.2f} %** at every frequency and "
          "load (rows 'exact linear')." + unsettled + stroke_text + "\n\n" + "\n".join(rows) +
          range_flag(oor_t, oor_e, v_ident, v_source) + " In the figure, ○ marks the points "
          "above the limit." +
          "\n\nThe paper (text of its Fig 13): the generator voltage varies with the friction "
          f"magnitude and falls as the sprung-mass displacement falls. Ours: {volt_text} "
          "(friction matters most at low frequency, where the stroke velocity is small), and "
          f"the 'max' friction {flat_text}. Paper values are only graphical, so no numbers "
          f"are compared.\n\n![Fig 13]({rel})\n" + caption("Fig 13", fig13_caption(study)))
    return StepOutput(md, [rel], {"voltage_amplitude_V": study.voltage_amplitude_V.tolist(),
                                  "frequencies_hz": study.frequencies_hz.tolist(),
                                  "settled": study.settled.tolist(),
                                  "peak_stroke_m": study.peak_stroke_m.tolist(),
                                  "frictionless_deviation": study.frictionless_deviation(),
                                  "identified_range_m_per_s": v_ident,
                                  "out_of_range_time_fraction":
                                      study.out_of_range_time_fraction.tolist(),
                                  "out_of_range_friction_energy_fraction": np.where(
                                      np.isfinite(study.out_of_range_friction_energy_fraction),
                                      study.out_of_range_friction_energy_fraction,
                                      -1.0).tolist()})


def _exact_peaks(vehicle: VehicleParams, harvester: HarvesterParams,
                 loads: list[float]) -> np.ndarray:
    """Frequencies of the exact frictionless maxima of x2/x0 and of V_g (constant-velocity
    road) per load, on a dense grid (so the stepped sine samples the true peaks)."""
    f = np.geomspace(0.5, 20.0, 4000)
    out = []
    for r in loads:
        lin = linear_frequency_response(vehicle, harvester.replace(load_ohm=r), f)
        out += [f[np.argmax(np.abs(lin["x2"]))], f[np.argmax(np.abs(lin["voltage"]) / f)]]
    return np.array(out)


def step_fig14(ctx: Context) -> StepOutput:
    if (na := _not_applicable(ctx)) is not None:
        return na
    fc = friction_cases(ctx.friction_sets(), ctx.friction_bounds)
    v_ident, v_source = identified_range(ctx)
    study = force_velocity_loops(ctx.harvester(), fc, identified_range_m_per_s=v_ident)
    rel = "figures/fig14_force_velocity.png"
    plots.save(study.plot(), ctx.out_dir / rel)
    rows = ["| circuit | ours: min friction | ours: max friction | paper (min–max) | "
            f"{RANGE_HEADER}: min / max friction |", "|---|---|---|---|---|"]
    res, oor_t, oor_e = {}, [], []
    for circuit in ("open circuit", "short circuit"):
        lo = study.equivalent_damping_Ns_per_m[(circuit, "min")]
        hi = study.equivalent_damping_Ns_per_m[(circuit, "max")]
        p = PAPER_FIG14_RANGES[circuit]
        cells = []
        for case in ("min", "max"):
            t, e = study.out_of_range[(circuit, case)]
            oor_t.append(t)
            oor_e.append(e)
            cells.append(range_cell(t, e))
        rows.append(f"| {circuit} | {lo:.0f} N s/m | {hi:.0f} N s/m | {p[0]:.0f}–{p[1]:.0f} N s/m "
                    f"| {' ; '.join(cells)} |")
        res[circuit] = [lo, hi]
    md = ("Equivalent damping coefficient c_eq = ∮F dx / (π ω A²) of the harvester on a sine "
          f"stroke of {1e3 * study.amplitude_m:g} mm at {study.frequency_hz:g} Hz **(assumption: "
          "the paper's stroke for Fig 14 is not in the text)**, open circuit (friction only) and "
          f"short circuit (R_e = 0). Friction: {fc.source}.\n\n" + "\n".join(rows) +
          range_flag(oor_t, oor_e, v_ident, v_source) + " In the figure the velocities "
          "beyond the identified range are shaded." +
          "\n\nShort circuit adds the electrical damping K_t K_e/(r² R_i) ≈ "
          f"{ctx.harvester().equivalent_damping_Ns_per_m(0.0, 0.0):.0f} N s/m to the friction. "
          + _compare_ranges(res) + "\n\n"
          f"![Fig 14]({rel})\n"
          + caption("Fig 14", f"Force against velocity over one steady cycle of a "
                    f"{1e3 * study.amplitude_m:g} mm, {study.frequency_hz:g} Hz sine stroke, "
                    f"open circuit (c_eq {res['open circuit'][0]:.0f}–"
                    f"{res['open circuit'][1]:.0f} N s/m, min–max friction) and short "
                    f"circuit ({res['short circuit'][0]:.0f}–{res['short circuit'][1]:.0f} "
                    f"N s/m); velocities beyond the identified ±{v_ident:.2f} m/s shaded"))
    res["out_of_range"] = {f"{c} / {k}": list(x) for (c, k), x in study.out_of_range.items()}
    return StepOutput(md, [rel], res)


def _compare_ranges(res: dict) -> str:
    """Plain-language comparison of our c_eq ranges with the paper's."""
    out = []
    for circuit, (lo, hi) in res.items():
        p_lo, p_hi = PAPER_FIG14_RANGES[circuit]
        if p_lo <= lo and hi <= p_hi:
            out.append(f"{circuit}: ours lies inside the paper's range")
        elif hi < p_lo or lo > p_hi:
            out.append(f"{circuit}: ours lies outside the paper's range")
        else:
            out.append(f"{circuit}: ours overlaps the paper's range "
                       f"({'narrower' if hi - lo < p_hi - p_lo else 'wider'})")
    return ("; ".join(out) + ". Open circuit measures friction alone, so the paper's "
            "293–2306 N s/m implies friction bounds several times wider and higher than ours "
            "(the paper's Table 2 values are not in its text; ours are the data set's or the "
            "identified ones).")


def _road_step(ctx: Context, preset: str, fig: str, load: float) -> tuple[str, list[str], dict]:
    fc = friction_cases(ctx.friction_sets(), ctx.friction_bounds)
    vehicle, preset = ((VehicleParams.preset(preset), preset) if preset != "user"
                       else ctx.vehicle())
    preset = preset.replace(" ", "_").replace(".", "_")
    road = RoadParams(iso_class="C", speed_km_per_h=100.0,
                      length_m=300.0 if ctx.quick else 1000.0, seed=0)
    v_id, v_src = identified_range(ctx)
    harvester = ctx.harvester(load_ohm=load)
    limits = study_sample_limits(harvester.voltage_constant_Vs_per_rad)
    study = road_study(vehicle, harvester, fc, road, n_loads=12 if ctx.quick else 24,
                       title=f"{fig}: {preset}", identified_range_m_per_s=v_id,
                       n_seeds=report_seeds(ctx), sample_limits=limits)
    rel = f"figures/{fig.lower().replace(' ', '')}_{preset}.png"
    plots.save(study.plot(), ctx.out_dir / rel)
    m, iv = study.sim.metrics, study.intervals
    validity = check_validity(m, stroke_limit_m=vehicle.stroke_limit_m, sample_limits=limits)
    i0 = study.cases.index("none")
    rows = ["| friction | R_e (Ω) | slope (N s/m) | power (W) | change (paired) | efficiency (%) "
            f"| comfort α | road holding | peak stroke (mm) | {LIMITS_HEADER} | {RANGE_HEADER} "
            "| validity |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    t_out, e_out = _range_fractions(m, study.cases, fc)
    for i, c in enumerate(study.cases):
        note = "" if study.reachable[i] else " (target not reachable)"
        change = "–" if i == i0 else iv.change("power_W", i, i0).text("%")
        rows.append(f"| {c} | {study.loads_ohm[i]:.3g}{note} | {study.slopes_Ns_per_m[i]:.0f} | "
                    f"{iv.interval('power_W', i).text()} | {change} | "
                    f"{iv.interval('efficiency', i).scaled(100).text()} | "
                    f"{iv.interval('comfort', i).text()} | "
                    f"{iv.interval('road_holding', i).text()} | "
                    f"{1e3 * m['peak_stroke_m'][i]:.0f} | {limits_cell(m, i)} | "
                    f"{range_cell(t_out[i], e_out[i])} | {validity.cell(i)} |")
    md = (f"{preset}, class C at 100 km/h, {road.length_m:g} m; the frictionless case uses "
          f"R_e = {load:g} Ω and each friction case is re-tuned (one batch of loads, "
          "interpolated) so that the three damping slopes (least squares of the non-inertial "
          f"damper force on stroke velocity) match. Friction: {fc.source}. "
          + intervals_note(len(iv.seeds), iv.road.seed) + "\n\n" + "\n".join(rows) + "\n\n"
          + limits_note(limits, vehicle.stroke_limit_m) + "\n\n"
          + road_study_conclusions(study, validity)
          + range_flag(t_out, e_out, v_id, v_src) + f"\n\n![{fig}]({rel})\n"
          + caption(fig, road_caption(study, preset)))
    res = {"loads_ohm": study.loads_ohm, "power_W": m["power_W"].tolist(),
           "power_change_percent": study.power_drop_percent(),
           "slopes": study.slopes_Ns_per_m.tolist(), "validity": validity.as_list(),
           "intervals": iv.as_dict(["power_W", "efficiency", "comfort", "road_holding",
                                    "tyre_lift_fraction", "peak_power_W"]),
           "power_change_interval": {c: iv.change("power_W", i, i0).as_dict()
                                     for i, c in enumerate(study.cases) if i != i0},
           "out_of_range_time_fraction": list(t_out),
           "out_of_range_friction_energy_fraction": list(e_out)}
    return md, [rel], res


#: Spread of the weighted rms acceleration (max/min − 1) below which comfort "hardly
#: changes" between friction cases.
COMFORT_SAME_PERCENT = 5.0


def road_study_conclusions(study: Any, validity: Any) -> str:
    """The Figs 15/16 conclusion sentences, generated from the rows whose model is valid
    (rows beyond hardware limits only are used and said so) and judged on the 95 %
    intervals over road realisations when the study has them."""
    lo, hi = PAPER_ROAD_STUDY["power_loss_pct"]
    acc_paper = PAPER_ROAD_STUDY["acceleration_m_s2"]
    cases = study.cases
    i0 = cases.index("none")
    ok_model = validity.model_valid
    if not ok_model[i0]:
        return ("**No conclusion is drawn from this vehicle:** the frictionless reference is "
                f"invalid ({'; '.join(f.message for f in validity.flags[i0])}), so neither "
                f"the power loss nor the comfort at equal slopes can be compared with the "
                f"paper's ({lo:g}–{hi:g} % loss, average acceleration {acc_paper:g} m/s² in "
                "all three cases).")
    iv = getattr(study, "intervals", None)
    ok = [i for i, c in enumerate(cases) if ok_model[i] and c != "none"]
    bad = [c for i, c in enumerate(cases) if not ok_model[i]]
    out = [f"Paper: average power fell **{lo:g}–{hi:g} %** with friction at equal damping "
           "slopes."]
    if ok:
        if iv is not None:
            ch = {i: iv.change("power_W", i, i0) for i in ok}
            loss = " and ".join(f"{ch[i].scaled(-1).text('%')} ({cases[i]})" for i in ok)
            verdict = [versus_paper(ch[i].scaled(-1), (lo, hi), " %") for i in ok]
            out.append(f"Ours falls {loss} (95 %): the share of the damping taken by friction "
                       f"sets the loss; ours is " + ", ".join(sorted(set(verdict))) + ".")
        else:
            drops = study.power_drop_percent()
            out.append("Ours falls " + " and ".join(f"{-drops[cases[i]]:.0f} % ({cases[i]})"
                                                  for i in ok) + ".")
        out.append(_comfort_sentence(study, [i0] + ok, acc_paper))
    if not validity.valid[[i0] + ok].all():
        out.append("The damper of these rows exceeds its hardware limits (NOT REALISABLE in "
                   "the table): the comparison holds for the model, not for a damper built "
                   "to these limits.")
    if bad:
        out.append("Left out of these sentences (invalid, flagged in the table): "
                   + ", ".join(bad) + ".")
    return " ".join(out)


def _comfort_sentence(study: Any, rows: list[int], acc_paper: float) -> str:
    """Whether comfort changes at equal slopes: each friction case's paired change of the
    weighted rms acceleration within ±COMFORT_SAME_PERCENT (the whole interval)."""
    m, iv, cases = study.sim.metrics, getattr(study, "intervals", None), study.cases
    i0 = rows[0]
    if iv is None:
        acc = [float(m["comfort_weighted_rms_m_s2"][i]) for i in rows]
        same = 100 * (max(acc) / min(acc) - 1) < COMFORT_SAME_PERCENT
        vals = ", ".join(f"{a:.2f}" for a in acc) + " m/s²"
    else:
        ch = [iv.change("comfort_weighted_rms_m_s2", i, i0) for i in rows[1:]]
        same = all(-COMFORT_SAME_PERCENT < c.low and c.high < COMFORT_SAME_PERCENT for c in ch)
        vals = (iv.interval("comfort_weighted_rms_m_s2", i0).text("m/s²") + " without friction, "
                + ", ".join(f"{c.text('%')} ({cases[i]})" for c, i in zip(ch, rows[1:])))
    return (("As in the paper, comfort hardly changes at equal slopes" if same else
             "Unlike the paper (or not resolved by the intervals), comfort changes at equal "
             "slopes") + f" (weighted rms acceleration {vals}; within "
            f"±{COMFORT_SAME_PERCENT:g} % counts as unchanged; paper: {acc_paper:g} m/s² in all "
            "three cases).")


def _range_fractions(m: dict, cases: list, fc: Any) -> tuple[list, list]:
    """Per case the fractions above the identified range (energy None without friction)."""
    t = [float(x) for x in m["out_of_range_time_fraction"]]
    e = [None if fc.cases.get(c) is None else float(x)
         for c, x in zip(cases, m["out_of_range_friction_energy_fraction"])]
    return t, e


def step_fig15_16(ctx: Context) -> StepOutput:
    if (na := _not_applicable(ctx)) is not None:
        return na
    if ctx.vehicle_file is not None:
        md1, f1, r1 = _road_step(ctx, "user", "Fig 15", 10.0)
        return StepOutput(f"### Fig 15 — {ctx.vehicle()[1]}\n\n" + md1, f1, {"vehicle": r1})
    md1, f1, r1 = _road_step(ctx, "passenger_car", "Fig 15", 10.0)
    md2, f2, r2 = _road_step(ctx, "single_seater", "Fig 16", 10.0)
    md = "### Fig 15 — passenger car\n\n" + md1 + "\n### Fig 16 — single seater\n\n" + md2
    return StepOutput(md, f1 + f2, {"passenger_car": r1, "single_seater": r2})


def fig21_ordering(metrics: Any, valid: bool, intervals: Any = None) -> str:
    """The Fig 21 sentence on the paper's ordering none > min > max friction in power and
    efficiency, stated only when every row's model is valid and as the numbers say; with
    ``intervals`` (rows none, min, max) each step of the ordering is judged on its paired
    95 % interval: it holds when every interval is above zero."""
    if not valid:
        return "No ordering is stated: a row is invalid (flagged in the table)."
    if intervals is not None:
        steps = [(key, a, b, intervals.change(key, a, b, "difference"))
                 for key in ("power_W", "efficiency") for a, b in ((0, 1), (1, 2))]
        if all(d.low > 0 for *_, d in steps):
            p = steps[0][3], steps[1][3]
            return ("The paper's ordering none > min > max friction holds here in power and "
                    f"efficiency, every step beyond its 95 % interval (power none − min "
                    f"{p[0].text('W')}, min − max {p[1].text('W')}).")
        if any(d.high < 0 for *_, d in steps):
            return "The paper's ordering none > min > max friction is NOT reproduced here."
        return ("The paper's ordering none > min > max friction is not resolved here: a "
                "step's 95 % interval includes zero.")
    p, e = metrics["power_W"], metrics["efficiency"]
    if p[0] > p[1] > p[2] and e[0] > e[1] > e[2]:
        return ("The paper's ordering none > min > max friction holds here in power "
                f"({p[0]:.1f} > {p[1]:.1f} > {p[2]:.1f} W) and efficiency "
                f"({100 * e[0]:.1f} > {100 * e[1]:.1f} > {100 * e[2]:.1f} %).")
    return "The paper's ordering none > min > max friction is NOT reproduced here."


def render_fig21(source: str, road: RoadParams, friction_source: str, rows: list[str],
                 bound_W: float, ordering: str, flag: str, rel: str, note: str = "") -> str:
    """The Fig 21 section's Markdown from its computed parts (``note``: what the ± are)."""
    paper_none = PAPER_FIG21["none"][0]
    return (f"Design: {source}. Passenger car, class C at 100 km/h, {road.length_m:g} m. "
            f"Friction: {friction_source}." + (f" {note}" if note else "") + "\n\n"
            + "\n".join(rows) +
            "\n\nThe paper's vehicle parameters and friction values are not in its text, so "
            f"absolute powers differ (our bound at 100 km/h is {bound_W:.0f} W, "
            + (f"below the paper's {paper_none:g} W frictionless power, so its car or road must "
               "have been different). " if bound_W < paper_none else
               f"above the paper's {paper_none:g} W frictionless power). ")
            + ordering + flag + "\n\n" f"![Fig 21]({rel})\n")


def step_fig21(ctx: Context) -> StepOutput:
    if (na := _not_applicable(ctx)) is not None:
        return na
    fc = friction_cases(ctx.friction_sets(), ctx.friction_bounds)
    design = DesignStepResult.from_dict(ctx.results.get("design"))
    if design is not None:
        h = design.optimum_harvester
        src = "the design step's optimum"
    else:
        h = paper_optimum_harvester()
        P = PAPER_OPTIMUM
        src = (f"the paper's reported optimum (J_t = {P['total_inertia_gcm2']:g} g cm², k_n = "
               f"{P['speed_constant_rpm_per_V']:g} rpm/V, p = {P['lead_mm_per_rev']:g} mm/rev, "
               f"R_e = {P['load_ohm']:g} Ω) — the design step's optimum is not available")
    road = RoadParams(iso_class="C", speed_km_per_h=100.0,
                      length_m=300.0 if ctx.quick else 1000.0, seed=0)
    v_id, v_src = identified_range(ctx)
    limits = study_sample_limits(h.voltage_constant_Vs_per_rad)
    study = road_study(ctx.vehicle()[0], h, fc, road, retune=False, title="Fig 21",
                       identified_range_m_per_s=v_id, n_seeds=report_seeds(ctx),
                       sample_limits=limits)
    rel = "figures/fig21_power_history.png"
    plots.save(study.plot_power(), ctx.out_dir / rel)
    m, iv = study.sim.metrics, study.intervals
    validity = check_validity(m, stroke_limit_m=ctx.vehicle()[0].stroke_limit_m,
                              sample_limits=limits)
    rows = ["| friction | power (W) ours / paper | efficiency (%) ours / paper | peak power (W) "
            f"ours / paper | peak screw speed (rpm) | {LIMITS_HEADER} | {RANGE_HEADER} | "
            "validity |", "|---|---|---|---|---|---|---|---|"]
    t_out, e_out = _range_fractions(m, study.cases, fc)
    for i, c in enumerate(study.cases):
        pp, pe, pk = PAPER_FIG21[c]
        p_iv, e_iv = iv.interval("power_W", i), iv.interval("efficiency", i).scaled(100)
        rows.append(f"| {c} | {p_iv.text()} / {pp} ({versus_paper(p_iv, pp)}) | "
                    f"{e_iv.text()} / {pe} ({versus_paper(e_iv, pe)}) | "
                    f"{iv.interval('peak_power_W', i).text()} / {pk if pk else '–'} | "
                    f"{iv.interval('peak_screw_speed_rpm', i).text()} | {limits_cell(m, i)} | "
                    f"{range_cell(t_out[i], e_out[i])} | {validity.cell(i)} |")
    order = fig21_ordering(m, bool(validity.model_valid.all()), iv)
    flag = (" " + limits_note(limits, ctx.vehicle()[0].stroke_limit_m)
            + range_flag(t_out, e_out, v_id, v_src))
    md = (render_fig21(src, road, fc.source, rows, float(m["dissipation_bound_W"][0]), order,
                       flag, rel, intervals_note(len(iv.seeds), iv.road.seed))
          + caption("Fig 21", fig21_caption(study)))
    return StepOutput(md, [rel], {"power_W": m["power_W"].tolist(),
                                  "efficiency": m["efficiency"].tolist(),
                                  "validity": validity.as_list(),
                                  "peak_power_W": m["peak_power_W"].tolist(),
                                  "intervals": iv.as_dict(["power_W", "efficiency",
                                                           "peak_power_W",
                                                           "peak_screw_speed_rpm"])})
