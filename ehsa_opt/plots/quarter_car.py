"""Quarter-car figures: simulation overview, paper Figs 13, 14, 15/16, 21, W_k."""

from __future__ import annotations

from typing import TYPE_CHECKING
from collections.abc import Mapping

import numpy as np

from . import axes_or_new, plt

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..vehicle.simulate import QuarterCarSimulation
    from ..vehicle.studies import ForceVelocityStudy, FrequencyResponseStudy, RoadStudy

__all__ = [
    "fig13_frequency_response",
    "fig14_force_velocity",
    "fig15_road_study",
    "fig21_power_history",
    "short_source",
    "simulation_overview",
    "wk_figure",
]

_CASE_COLOURS = {"none": "C0", "min": "C2", "max": "C3"}


def short_source(source: str) -> str:
    """A friction source as a figure shows it: the part before its explanation (the
    report's text carries the rest)."""
    for sep in (":", " ("):
        if sep in source:
            source = source.split(sep, 1)[0]
    return source.strip()


def _shade_identified(ax: Axes, v_id: float | None, v: np.ndarray) -> None:
    """Shade the stroke velocities beyond the friction's identified range ±v_id."""
    if v_id is None or v.size == 0:
        return
    vmax = float(np.max(np.abs(v)))
    if vmax > v_id:
        for sgn in (-1, 1):
            ax.axvspan(sgn * v_id, sgn * vmax, color="0.88", zorder=0,
                       label=(f"beyond the identified ±{v_id:.2f} m/s" if sgn > 0 else None))


def simulation_overview(sim: QuarterCarSimulation, k: int = 0,
                        identified_range_m_per_s: float | None = None) -> Figure:
    """Road, sprung displacement, load power and force–velocity of design ``k`` (stroke
    velocities beyond the friction's identified range shaded when given)."""
    s = sim.series
    fig, ax = plt.subplots(2, 2, figsize=(10, 6))
    t = sim.time_s
    ax[0, 0].plot(t, 1e3 * sim.road_m, lw=0.6, color="0.4", label="road x0")
    ax[0, 0].plot(t, 1e3 * s["x2_m"][k], lw=0.8, color="C0", label="sprung x2")
    ax[0, 0].set_ylabel("displacement (mm)")
    ax[0, 0].legend(fontsize=8)
    ax[0, 1].plot(t, s["load_power_W"][k], lw=0.6, color="C1")
    ax[0, 1].set_ylabel("power in R_e (W)")
    ax[1, 0].plot(t, s["sprung_acc_m_s2"][k], lw=0.5, color="C4")
    ax[1, 0].set_ylabel("sprung acceleration (m/s²)")
    for a in (ax[0, 0], ax[0, 1], ax[1, 0]):
        a.set_xlabel("time (s)")
    _shade_identified(ax[1, 1], identified_range_m_per_s, np.asarray(s["stroke_velocity_m_s"][k]))
    ax[1, 1].plot(s["stroke_velocity_m_s"][k], s["damper_force_N"][k], ".", ms=1, color="C3")
    if identified_range_m_per_s is not None:
        ax[1, 1].legend(fontsize=7, loc="upper left")
    ax[1, 1].set_xlabel("stroke velocity (m/s)")
    ax[1, 1].set_ylabel("damper force w/o inertia (N)")
    fig.suptitle(f"{sim.road_source}: design {k}")
    fig.tight_layout()
    return fig


def fig13_frequency_response(study: FrequencyResponseStudy) -> Figure:
    """Paper Fig 13: generator voltage and sprung-mass transmissibility vs frequency."""
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    styles = ["-", "--", ":", "-."]
    for i, case in enumerate(study.cases):
        for j, load in enumerate(study.loads_ohm):
            kw = dict(color=_CASE_COLOURS.get(case, f"C{i}"), ls=styles[j % 4], lw=1.2,
                      label=f"{case} friction, R_e = {load:g} Ω")
            ax[0].loglog(study.frequencies_hz, study.voltage_amplitude_V[i, j], **kw)
            ax[1].loglog(study.frequencies_hz, study.sprung_transmissibility[i, j], **kw)
            bad = (~study.settled[i, j] if getattr(study, "settled", None) is not None
                   else np.zeros(study.frequencies_hz.size, bool))
            if bad.any():  # not at steady state: marked, never silently drawn as a result
                for a, y in ((ax[0], study.voltage_amplitude_V), (ax[1],
                                                                   study.sprung_transmissibility)):
                    a.plot(study.frequencies_hz[bad], y[i, j][bad], "x", color=kw["color"],
                           ms=7, mew=1.5)
            beyond = (study.beyond_stroke_limit()[i, j]
                      if hasattr(study, "beyond_stroke_limit") else np.zeros(0, bool))
            if beyond.any():  # the stroke would hit the bump stops: marked
                for a, y in ((ax[0], study.voltage_amplitude_V), (ax[1],
                                                                   study.sprung_transmissibility)):
                    a.plot(study.frequencies_hz[beyond], y[i, j][beyond], "s", mfc="none",
                           color=kw["color"], ms=9, mew=1.2)
            over = _over_limit(study, i, j)
            if over.any():  # friction there mostly extrapolated: marked
                for a, y in ((ax[0], study.voltage_amplitude_V), (ax[1],
                                                                   study.sprung_transmissibility)):
                    a.plot(study.frequencies_hz[over], y[i, j][over], "o", mfc="none",
                           color=kw["color"], ms=8, mew=1.2)
    ax[0].set_ylabel("generator voltage amplitude (V)")
    ax[1].set_ylabel("sprung displacement / road amplitude (–)")
    for a in ax:
        a.set_xlabel("road frequency (Hz)")
        a.grid(True, which="both", alpha=0.3)
    handles, labels = ax[1].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, ncol=len(study.cases), loc="lower center",
               frameon=False, bbox_to_anchor=(0.5, 0.035))
    va = getattr(study, "velocity_amplitude_m_per_s", None)
    road = (f"road sine of constant velocity amplitude {1e3 * va:.1f} mm/s (displacement "
            f"{1e3 * study.amplitude_m:.3g} mm at 1 Hz, falling as 1/f)" if va else
            f"road sine amplitude {1e3 * study.amplitude_m:g} mm")
    unsettled = getattr(study, "settled", None) is not None and not np.all(study.settled)
    any_over = any(_over_limit(study, i, j).any() for i in range(len(study.cases))
                   for j in range(len(study.loads_ohm)))
    any_stroke = hasattr(study, "beyond_stroke_limit") and study.beyond_stroke_limit().any()
    marks = (["× not steady"] if unsettled else []) + (
        [f"□ stroke beyond ±{1e3 * study.stroke_limit_m:.0f} mm"] if any_stroke else []) + (
        [f"○ friction > {100 * study.out_of_range_limit:g} % beyond the identified "
         f"{study.identified_range_m_per_s:.2f} m/s"] if any_over else [])
    ax[0].set_title("generator voltage", fontsize=9)
    ax[1].set_title("sprung-mass transmissibility", fontsize=9)
    fig.suptitle(f"Stepped sine at steady state, {road}; friction: "
                 f"{short_source(study.friction_source)}", fontsize=9)
    if marks:
        fig.text(0.5, 0.005, "   ".join(marks), ha="center", va="bottom", fontsize=7)
    fig.tight_layout(rect=(0, 0.17 if len(labels) > 6 else 0.12, 1, 0.97))
    return fig


def _over_limit(study: FrequencyResponseStudy, i: int, j: int) -> np.ndarray:
    """Frequencies of case i, load j whose out-of-range share exceeds the limit."""
    t = getattr(study, "out_of_range_time_fraction", None)
    e = getattr(study, "out_of_range_friction_energy_fraction", None)
    if t is None or e is None or study.cases[i] == "none":
        return np.zeros(study.frequencies_hz.size, bool)
    return np.fmax(t[i, j], np.nan_to_num(e[i, j])) > study.out_of_range_limit


def fig14_force_velocity(study: ForceVelocityStudy) -> Figure:
    """Paper Fig 14: force–velocity loops, open and short circuit, min/max friction;
    velocities beyond the friction's identified range shaded."""
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    v_id = getattr(study, "identified_range_m_per_s", None)
    oor = getattr(study, "out_of_range", {}) or {}
    for i, circuit in enumerate(("open circuit", "short circuit")):
        if v_id is not None:
            vmax = max(float(np.max(np.abs(study.loops[(circuit, c)][0]))) for c in ("min", "max"))
            if vmax > v_id:
                for sgn in (-1, 1):
                    ax[i].axvspan(sgn * v_id, sgn * vmax, color="0.85", zorder=0)
            for c in ("min", "max"):
                t, e = oor.get((circuit, c), (0.0, 0.0))
                if max(t, e) > study.out_of_range_limit:
                    ax[i].text(0.02, 0.95 - 0.07 * (c == "max"), f"⚠ {c}: {100 * t:.0f} % time "
                               f"/ {100 * e:.0f} % friction energy beyond {v_id:.2f} m/s",
                               transform=ax[i].transAxes, fontsize=7, va="top")
        for case in ("min", "max"):
            v, f = study.loops[(circuit, case)]
            c = study.equivalent_damping_Ns_per_m[(circuit, case)]
            ax[i].plot(v, f, color=_CASE_COLOURS[case], lw=1.2,
                       label=f"{case} friction: c_eq = {c:.0f} N s/m")
        ax[i].set_title(circuit)
        ax[i].set_xlabel("velocity (m/s)")
        ax[i].set_ylabel("force (N)")
        ax[i].grid(True, alpha=0.3)
        ax[i].legend(fontsize=8)
    fig.suptitle(f"Sine stroke {1e3 * study.amplitude_m:g} mm at {study.frequency_hz:g} Hz "
                 f"(friction: {short_source(study.friction_source)})"
                 + (f"\nidentified friction range |v| <= {v_id:.2f} m/s (beyond: shaded)"
                    if v_id is not None else ""), fontsize=9)
    fig.tight_layout()
    return fig


def fig15_road_study(study: RoadStudy) -> Figure:
    """Paper Figs 15/16: road PSD, sprung displacement, power, stroke-velocity PSD, F–v."""
    sim = study.sim
    fig, ax = plt.subplots(3, 2, figsize=(11, 9.5))
    rp = study.road_psd
    band = (rp["n_cycles_per_m"] >= 0.01) & (rp["n_cycles_per_m"] <= 10.0)
    ax[0, 0].loglog(rp["n_cycles_per_m"][band], rp["synth_m3"][band], lw=0.8, color="0.4",
                    label=(f"synthesised (Welch, {rp['segments']} segments)"
                           if "segments" in rp else "synthesised (Welch)"))
    ax[0, 0].loglog(rp["n_cycles_per_m"][band], rp["target_m3"][band], lw=1.5, color="k",
                    ls="--", label="ISO 8608 target")
    ax[0, 0].set_xlabel("spatial frequency (cycles/m)")
    ax[0, 0].set_ylabel("G_d (m³)")
    ax[0, 0].legend(fontsize=8)
    t = sim.time_s
    n_show = min(t.size, int(5.0 * sim.stats["sample_rate_hz"]))
    _shade_identified(ax[2, 0], getattr(study, "identified_range_m_per_s", None),
                      np.asarray(sim.series["stroke_velocity_m_s"]))
    for i, case in enumerate(study.cases):
        col = _CASE_COLOURS.get(case, f"C{i}")
        lab = f"{case} (R_e = {study.loads_ohm[i]:.3g} Ω)"
        ax[0, 1].plot(t[:n_show], 1e3 * sim.series["x2_m"][i, :n_show], color=col, lw=0.8,
                      label=lab)
        ax[1, 0].plot(t[:n_show], sim.series["load_power_W"][i, :n_show], color=col, lw=0.7,
                      label=f"{case}: mean {sim.metrics['power_W'][i]:.1f} W")
        fsel = (study.stroke_velocity_psd["f_hz"] > 0) & (study.stroke_velocity_psd["f_hz"] <= 100)
        ax[1, 1].loglog(study.stroke_velocity_psd["f_hz"][fsel],
                        study.stroke_velocity_psd["psd"][i][fsel], color=col, lw=0.8, label=case)
        ax[2, 0].plot(sim.series["stroke_velocity_m_s"][i], sim.series["damper_force_N"][i],
                      ".", ms=0.8, color=col, alpha=0.5)
        vv = np.linspace(sim.series["stroke_velocity_m_s"][i].min(),
                         sim.series["stroke_velocity_m_s"][i].max(), 2)
        ax[2, 0].plot(vv, study.slopes_Ns_per_m[i] * vv, color=col, lw=1.2,
                      label=f"{case}: slope {study.slopes_Ns_per_m[i]:.0f} N s/m")
    ax[0, 1].set_ylabel("sprung displacement (mm)")
    ax[0, 1].set_xlabel("time (s)")
    ax[0, 1].legend(fontsize=7)
    ax[1, 0].set_ylabel("instantaneous power in R_e (W)")
    ax[1, 0].set_xlabel("time (s)")
    ax[1, 0].legend(fontsize=7)
    ax[1, 1].set_xlabel("frequency (Hz)")
    ax[1, 1].set_ylabel("stroke velocity PSD ((m/s)²/Hz)")
    ax[1, 1].legend(fontsize=7)
    ax[2, 0].set_xlabel("stroke velocity (m/s)")
    ax[2, 0].set_ylabel("damper force w/o inertia (N)")
    ax[2, 0].legend(fontsize=7)
    ax[2, 1].axis("off")
    ax[2, 1].text(0.0, 0.95, _road_summary(study), va="top", fontsize=7.5, family="monospace")
    fig.suptitle(f"{study.title} — {sim.road_source} (friction: "
                 f"{short_source(study.friction_source)})", fontsize=9)
    fig.tight_layout()
    return fig


def _road_summary(study: RoadStudy) -> str:
    """The text panel of Figs 15/16: each case's metrics with their 95 % intervals over
    road realisations when the study has them, else the design road's values."""
    m, iv = study.sim.metrics, getattr(study, "intervals", None)
    lines = []
    for i, c in enumerate(study.cases):
        if iv is None:
            lines.append(f"{c}: P = {m['power_W'][i]:.1f} W, η = {100 * m['efficiency'][i]:.1f} %,"
                         f" α = {m['comfort'][i]:.3f}, η_rh = {m['road_holding'][i]:.3f}")
            continue
        lines += [f"{c}:  P = {iv.interval('power_W', i).text('W')}",
                  f"   η = {iv.interval('efficiency', i).scaled(100).text('%')}",
                  f"   α = {iv.interval('comfort', i).text()}",
                  f"   η_rh = {iv.interval('road_holding', i).text()}"]
    if iv is not None:
        lines.append(f"95 % intervals over {len(iv.seeds)} road realisations")
    return "\n".join(lines)


def fig21_power_history(study: RoadStudy, seconds: float = 10.0,
                        ax: Axes | None = None) -> Figure:
    """Paper Fig 21: instantaneous power, no/min/max friction."""
    sim = study.sim
    fig, ax = axes_or_new(ax, (10, 3.8))
    p = np.asarray(sim.series["load_power_W"])
    t = np.asarray(sim.time_s)
    # the window contains the largest reported peak (metric window, after settling)
    peaks = np.asarray(sim.metrics["peak_power_W"], dtype=float)
    i_pk = int(np.argmax(peaks))
    k_pk = int(np.argmin(np.abs(p[i_pk] - peaks[i_pk])))
    n = min(t.size, int(seconds * sim.stats["sample_rate_hz"]))
    lo = int(np.clip(k_pk - n // 2, 0, max(t.size - n, 0)))
    sl = slice(lo, lo + n)
    for i, case in enumerate(study.cases):
        ax.plot(t[sl], p[i, sl], color=_CASE_COLOURS.get(case, f"C{i}"), lw=0.7,
                label=f"{case} friction: mean {sim.metrics['power_W'][i]:.1f} W, peak "
                      f"{sim.metrics['peak_power_W'][i]:.0f} W")
    ax.plot([t[k_pk]], [p[i_pk, k_pk]], "kv", ms=6, label="largest peak")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("instantaneous power in the load R_e (W)")
    ax.legend(fontsize=8, loc="upper left", framealpha=0.9)
    ax.set_title(f"{study.title} — {sim.road_source} (friction: "
                 f"{short_source(study.friction_source)})", fontsize=9)
    fig.tight_layout()
    return fig


def wk_figure(f_hz: np.ndarray, exact: np.ndarray, fit: np.ndarray,
              table: Mapping[float, float], label: str, ax: Axes | None = None) -> Figure:
    """|W_k| exact, its low-order fit, and the standard's table values."""
    fig, ax = axes_or_new(ax, (6.5, 3.8))
    ax.loglog(f_hz, exact, color="k", lw=1.5, label="exact W_k (H_h·H_l·H_t·H_s)")
    ax.loglog(f_hz, fit, color="C1", ls="--", lw=1.2, label=label)
    ax.loglog(list(table), list(table.values()), "o", ms=4, color="C0",
              label="ISO 2631-1 table")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("comfort weighting |W_k| (–)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
