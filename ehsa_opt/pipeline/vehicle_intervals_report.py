"""Report helpers: the vehicle studies' intervals, per-sample limits and figure captions.

Every vehicle metric of the report is given with its 95 % interval over road realisations
(:mod:`ehsa_opt.vehicle.uncertainty`), a comparison with the paper is judged on the
interval (a paper value inside it is reproduced, outside it is not), and every row states
the share of the time it spends beyond the per-sample limits
(:func:`~ehsa_opt.vehicle.validity.exceedance_fractions`).  Figures carry a caption written
from the same numbers (:func:`caption`).
"""

from __future__ import annotations

import warnings
from typing import Any, Mapping, Sequence

import numpy as np

from ..vehicle.uncertainty import DEFAULT_SEEDS, Interval
from ..vehicle.validity import (EXCEEDANCE_FRACTION_LIMIT, TYRE_LIFT_FRACTION_LIMIT,
                                SampleLimits)

__all__ = ["report_seeds", "LIMITS_HEADER", "limits_cell", "limits_note", "intervals_note",
           "versus_paper", "caption", "QUICK_SEEDS", "stroke_cell", "fig13_caption",
           "road_caption", "fig21_caption", "table4_intervals", "speed_intervals"]

#: Road realisations per interval in a quick run (the full run uses
#: :data:`~ehsa_opt.vehicle.uncertainty.DEFAULT_SEEDS`).
QUICK_SEEDS = 4

#: Column header of the per-sample shares.
LIMITS_HEADER = "time beyond limits: tyre lift / stroke / screw speed / voltage"


def report_seeds(ctx: Any) -> int:
    """Realisations per interval: :data:`QUICK_SEEDS` quick, else the default."""
    return QUICK_SEEDS if ctx.quick else DEFAULT_SEEDS


def _share(x: Any) -> str:
    v = float(x)
    if not np.isfinite(v):
        return "–"
    return "0" if v == 0.0 else (f"{100 * v:.2g} %" if v < 0.1 else f"{100 * v:.0f} %")


def limits_cell(metrics: Mapping[str, np.ndarray], i: int) -> str:
    """``"0 / 0 / 31 % / 12 %"``: design ``i``'s shares of the time beyond each limit."""
    keys = ("tyre_lift_fraction", "stroke_beyond_limit_fraction",
            "screw_speed_beyond_limit_fraction", "voltage_beyond_limit_fraction")
    return " / ".join(_share(metrics[k][i]) if k in metrics else "–" for k in keys)


def limits_note(limits: SampleLimits | None, stroke_limit_m: float) -> str:
    """The sentence stating the per-sample limits, their tolerated shares and origins."""
    hw = ("" if limits is None else
          f", screw speed {limits.screw_speed_rpm:.0f} rpm and generator voltage "
          f"{limits.voltage_V:.0f} V ({limits.source})")
    return (f"Column *{LIMITS_HEADER}*: share of the time the tyre lifts (dynamic load above "
            f"the static one), and the stroke (±{1e3 * stroke_limit_m:g} mm){hw} are "
            f"exceeded. A row is valid when the tyre lifts at most "
            f"{100 * TYRE_LIFT_FRACTION_LIMIT:.3g} % of the time (the 3σ road-holding "
            f"criterion) and each limit is exceeded at most "
            f"{100 * EXCEEDANCE_FRACTION_LIMIT:.2g} % of the time (a Gaussian response's "
            f"share beyond its 3.5σ peak); INVALID marks the model outside its domain (tyre "
            f"lift, bump stops), NOT REALISABLE a damper beyond its hardware limits (the "
            f"model's numbers hold for a damper that could run there).")


def intervals_note(n_seeds: int, design_seed: int) -> str:
    """The sentence saying what the ± are."""
    return (f"± are 95 % intervals over {n_seeds} Gaussian realisations of the road "
            f"(same class, speed and length; Student t; changes paired on the same roads; "
            f"digits follow the interval); the design road itself (seed {design_seed}, "
            f"deterministic line amplitudes) sets the loads, the figures and the peak stroke.")


def versus_paper(ours: Interval, paper: float | tuple[float, float], unit: str = "") -> str:
    """Judge a paper value (or range) against our interval: inside, above or below."""
    lo, hi = (paper, paper) if not isinstance(paper, tuple) else paper
    p = f"{lo:g}{unit}" if lo == hi else f"{lo:g}–{hi:g}{unit}"
    if ours.high < lo:
        return f"below the paper's {p}"
    if ours.low > hi:
        return f"above the paper's {p}"
    return f"consistent with the paper's {p}"


def caption(label: str, text: str) -> str:
    """A figure caption (Markdown, italic) placed under the figure."""
    return f"\n*{label}. {text}*\n"


def stroke_cell(study: Any, i: int, j: int) -> str:
    """Largest steady stroke of case i, load j over the frequencies; bold with the
    frequencies beyond the limit."""
    st, over = study.peak_stroke_m[i, j], study.beyond_stroke_limit()[i, j]
    k = int(np.nanargmax(st))
    cell = f"{1e3 * st[k]:.0f} (at {study.frequencies_hz[k]:.2f} Hz)"
    if not over.any():
        return cell
    return (f"**{cell}: beyond ±{1e3 * study.stroke_limit_m:g} mm at "
            + ", ".join(f"{f:.2f}" for f in study.frequencies_hz[over]) + " Hz**")


def fig13_caption(study: Any) -> str:
    """Fig 13's caption from the study's numbers."""
    i0 = study.cases.index("none")
    peaks = ", ".join(f"{r:g} Ω {np.nanmax(study.sprung_transmissibility[i0, j]):.1f}"
                      for j, r in enumerate(study.loads_ohm))
    n_over = int(np.count_nonzero(study.beyond_stroke_limit()))
    return (f"Steady-state generator voltage amplitude (left) and sprung-mass transmissibility "
            f"(right) at {study.frequencies_hz.size} road frequencies "
            f"{study.frequencies_hz[0]:g}–{study.frequencies_hz[-1]:g} Hz, cases "
            f"{'/'.join(study.cases)} × loads; frictionless body-mode peaks of x2/x0: {peaks}; "
            + (f"{n_over} point(s) need a stroke beyond ±{1e3 * study.stroke_limit_m:g} mm (□)"
               if n_over else f"no point beyond the ±{1e3 * study.stroke_limit_m:g} mm stroke"))


def road_caption(study: Any, preset: str) -> str:
    """Figs 15/16's caption from the study's numbers."""
    iv = study.intervals
    i0 = study.cases.index("none")
    drops = ", ".join(f"{c} {iv.change('power_W', i, i0).text('%')}"
                      for i, c in enumerate(study.cases) if i != i0)
    rp, sv = study.road_psd, study.stroke_velocity_psd
    v_id = study.identified_range_m_per_s
    return (f"{preset} on the class C design road at 100 km/h: road PSD against ISO 8608 and "
            f"stroke-velocity PSDs (Welch, {rp['segments']} Hann segments overlapping by half, "
            f"resolution {rp['resolution']:.3g} cycles/m and {sv['resolution_hz']:.3g} Hz), "
            f"sprung displacement and load power over the first 5 s, damper force against "
            f"stroke velocity with each case's damping slope "
            f"({', '.join(f'{x:.0f}' for x in study.slopes_Ns_per_m)} N s/m)"
            + (f"; velocities beyond the friction's identified ±{v_id:.2f} m/s shaded"
               if v_id is not None else "")
            + f". Power change against no friction at equal slopes: {drops} (95 %, "
            f"{len(iv.seeds)} road realisations)")


def fig21_caption(study: Any) -> str:
    """Fig 21's caption from the study's numbers."""
    iv = study.intervals
    return ("Instantaneous power in the load on the design road (10 s around the largest "
            "peak), no/min/max friction; mean power "
            + ", ".join(f"{c} {iv.interval('power_W', i).text('W')}"
                        for i, c in enumerate(study.cases))
            + f" (95 %, {len(iv.seeds)} road realisations)")


def table4_intervals(vehicle: Any, road: Any, designs: Mapping[str, Any],
                     frictions: Mapping[str, Any], n_seeds: int,
                     paper: Mapping[str, Sequence[float | None]],
                     identified_range_m_per_s: float | None = None
                     ) -> tuple[str, dict[str, Any]]:
    """Table 4 (no/min/max friction at one speed) of each design with 95 % intervals over
    road realisations, judged against the paper's values, and each row's shares of time
    beyond the per-sample limits and its validity.

    Parameters
    ----------
    vehicle, road : VehicleParams, RoadParams
    designs : mapping label -> HarvesterParams
    frictions : mapping case -> FrictionParams or None (``"none"`` first)
    n_seeds : int
    paper : mapping key -> (none, min, max)
        The paper's ``power_W``, ``efficiency_pct``, ``comfort_change_pct``,
        ``road_holding_change_pct``.
    """
    from ..vehicle.uncertainty import road_intervals
    from ..vehicle.validity import check_validity, study_sample_limits
    cases = list(frictions)
    out_md, res = [], {}
    for label, h in designs.items():
        limits = study_sample_limits(h.voltage_constant_Vs_per_rad)
        iv = road_intervals(vehicle, [h] * len(cases), [frictions[c] for c in cases], road,
                            n_seeds=n_seeds, sample_limits=limits,
                            identified_range_m_per_s=identified_range_m_per_s)
        with warnings.catch_warnings():  # an all-NaN column (no friction energy) stays NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            mean = {k: np.nanmean(v, axis=0) for k, v in iv.samples.items()}
        validity = check_validity(mean, stroke_limit_m=vehicle.stroke_limit_m,
                                  sample_limits=limits)
        i0 = cases.index("none")
        lines = [f"| {label}, {road.speed_km_per_h:g} km/h (± 95 % over {n_seeds} roads) | "
                 + " | ".join("no friction" if c == "none" else f"{c} friction"
                              for c in cases) + " |",
                 "|---|" + "---|" * len(cases)]

        def row(name: str, get: Any, key: str) -> str:
            cells = []
            for j, c in enumerate(cases):
                ours = get(j)
                if ours is None:
                    cells.append("–")
                    continue
                p = paper.get(key, [None] * 3)[j] if j < 3 else None
                cells.append(ours.text() + ("" if p is None else
                                            f" / {p:g} ({versus_paper(ours, p)})"))
            return f"| {name} | " + " | ".join(cells) + " |"
        lines += [
            row("power (W) ours / paper", lambda j: iv.interval("power_W", j), "power_W"),
            row("efficiency (%) ours / paper",
                lambda j: iv.interval("efficiency", j).scaled(100), "efficiency_pct"),
            row("comfort change (%, paired) ours / paper",
                lambda j: None if j == i0 else iv.change("comfort", j, i0, "improvement"),
                "comfort_change_pct"),
            row("road holding change (%, paired) ours / paper",
                lambda j: None if j == i0 else iv.change("road_holding", j, i0, "improvement"),
                "road_holding_change_pct"),
            row("peak voltage (V)", lambda j: iv.interval("peak_voltage_V", j), ""),
            row("peak screw speed (rpm)", lambda j: iv.interval("peak_screw_speed_rpm", j), ""),
            f"| {LIMITS_HEADER} (mean over the roads) | "
            + " | ".join(limits_cell(mean, j) for j in range(len(cases))) + " |",
            "| validity | " + " | ".join(validity.cell(j) for j in range(len(cases))) + " |"]
        out_md.append("\n".join(lines))
        res[label] = {"intervals": iv.as_dict(["power_W", "efficiency", "comfort",
                                               "road_holding", "peak_voltage_V",
                                               "peak_screw_speed_rpm", "tyre_lift_fraction"]),
                      "validity": validity.as_list(), "seeds": iv.seeds}
        note = limits_note(limits, vehicle.stroke_limit_m)
    return "\n\n".join(out_md) + "\n\n" + note + "\n\n", res


def speed_intervals(vehicle: Any, road: Any, harvester: Any, frictions: Mapping[str, Any],
                    speeds: Sequence[float], n_seeds: int,
                    identified_range_m_per_s: float | None = None
                    ) -> tuple[str, dict[str, Any]]:
    """One design with each friction case at several speeds: power, efficiency and the
    paired comfort and road-holding changes against no friction with 95 % intervals over
    ``n_seeds`` road realisations per speed (digits follow the interval), and the share of
    the time the tyre lifts.

    Returns
    -------
    str, dict
        A Markdown table (a row per speed) and, per speed, the intervals as plain data.
    """
    import dataclasses

    from ..vehicle.uncertainty import road_intervals
    cases = list(frictions)
    i0 = cases.index("none")
    others = [j for j in range(len(cases)) if j != i0]
    head = ("| speed (km/h) | power (W): " + " / ".join(cases) + " | efficiency (%): "
            + " / ".join(cases) + " | comfort change (%, paired): "
            + " / ".join(cases[j] for j in others) + " | road holding change (%, paired): "
            + " / ".join(cases[j] for j in others) + " | tyre lift (share of the time) |\n"
            "|---|---|---|---|---|---|")
    lines, res = [head], {}
    for v in speeds:
        iv = road_intervals(vehicle, [harvester] * len(cases),
                            [frictions[c] for c in cases],
                            dataclasses.replace(road, speed_km_per_h=float(v)),
                            n_seeds=n_seeds, identified_range_m_per_s=identified_range_m_per_s)
        p = " / ".join(iv.interval("power_W", j).text() for j in range(len(cases)))
        e = " / ".join(iv.interval("efficiency", j).scaled(100).text()
                       for j in range(len(cases)))
        c = " / ".join(iv.change("comfort", j, i0, "improvement").text() for j in others)
        r = " / ".join(iv.change("road_holding", j, i0, "improvement").text() for j in others)
        lift = " / ".join(_share(np.mean(iv.samples["tyre_lift_fraction"][:, j]))
                          for j in range(len(cases)))
        lines.append(f"| {v:g} | {p} | {e} | {c} | {r} | {lift} |")
        res[f"{v:g}"] = {"intervals": iv.as_dict(["power_W", "efficiency", "comfort",
                                                  "road_holding", "tyre_lift_fraction"]),
                         "seeds": iv.seeds}
    return "\n".join(lines), res
