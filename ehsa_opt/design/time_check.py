"""Re-simulation of optimised designs in the time domain: the fast path's objectives
against the time domain with the same friction, the rated limits, and (a selection of
catalogue hardware) every limit per sample on held-out roads (:mod:`.limit_check`)."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from .config import DesignConfig
from .problem import OBJECTIVE_NAMES

__all__ = ["front_check", "harvesters_of"]


def front_check(cfg: DesignConfig, ev: Any, designs: Mapping[str, np.ndarray]
                ) -> tuple[dict[str, Any], str]:
    """Re-simulate designs in the time domain with the evaluator's friction and mode;
    relative errors of the fast path's objectives.  Returns the summary and a CSV."""
    from .robust import time_domain_objectives

    sim = getattr(cfg.physical, "simulation", None)
    kw = {}
    if sim is not None:
        kw = {k: getattr(sim, k) for k in ("settle_s", "sample_rate_hz") if hasattr(sim, k)}
    if getattr(ev, "kind", None) == "select":
        return _selection_check(cfg, ev, designs, **kw)
    fast = ev(designs)
    hs = harvesters_of(ev, designs)
    frictions = getattr(ev, "frictions", (None,))
    td = time_domain_objectives(cfg.vehicle, cfg.road, hs, frictions,
                                getattr(ev, "mode", "at"), **kw)
    err = {k: np.asarray(fast[k], float) / np.asarray(td[k], float) - 1.0
           for k in OBJECTIVE_NAMES}
    limits = _time_domain_limits(cfg, ev, hs, fast, **kw) if ev.constraint_names else {}
    worst = {k: float(np.max(np.abs(v))) for k, v in err.items()}
    names = list(designs)
    lines = [",".join(names + [f"{k}_fast" for k in OBJECTIVE_NAMES]
                      + [f"{k}_time_domain" for k in OBJECTIVE_NAMES]
                      + [f"{k}_rel_error" for k in OBJECTIVE_NAMES])]
    n = len(next(iter(designs.values())))
    for i in range(n):
        vals = ([float(designs[k][i]) for k in names]
                + [float(np.ravel(fast[k])[i]) for k in OBJECTIVE_NAMES]
                + [float(np.ravel(td[k])[i]) for k in OBJECTIVE_NAMES]
                + [float(err[k][i]) for k in OBJECTIVE_NAMES])
        lines.append(",".join(f"{v:.10g}" for v in vals))
    summary = {"n_designs": n, "road": {"iso_class": cfg.road.iso_class,
                                        "speed_km_per_h": cfg.road.speed_km_per_h,
                                        "length_m": cfg.road.length_m, "seed": cfg.road.seed},
               "worst_abs_rel_error": worst,
               "median_abs_rel_error": {k: float(np.median(np.abs(v))) for k, v in err.items()},
               "within_5pct": bool(max(worst.values()) <= 0.05)}
    if limits:
        summary["rated_limits"] = limits
        summary["within_5pct"] = bool(summary["within_5pct"] and limits["within_5pct"])
    return summary, "\n".join(lines) + "\n"


def _selection_check(cfg: DesignConfig, ev: Any, designs: Mapping[str, np.ndarray],
                     **kw: Any) -> tuple[dict[str, Any], str]:
    """A selection's designs on held-out roads (:mod:`.limit_check`): every limit per
    sample, and the frequency path's objectives against the mean over the roads."""
    from .limit_check import HELD_OUT_ROADS, held_out_seeds, limits_on_roads
    fast = ev(designs)
    seeds = held_out_seeds(cfg.road.seed, HELD_OUT_ROADS)
    chk = limits_on_roads(ev, designs, seeds, objective_names=OBJECTIVE_NAMES, **kw)
    td = {k: np.mean(np.array(v), axis=0) for k, v in chk["objectives"].items()}
    err = {k: np.asarray(fast[k], float) / td[k] - 1.0 for k in OBJECTIVE_NAMES}
    worst = {k: float(np.max(np.abs(v))) for k, v in err.items()}
    names = list(designs)
    lim = [k for k in chk["fractions"]]
    lines = [",".join(names + [f"{k}_fast" for k in OBJECTIVE_NAMES]
                      + [f"{k}_time_domain_mean" for k in OBJECTIVE_NAMES]
                      + [f"worst_fraction_{k}" for k in lim] + ["within_limits"])]
    n = len(hs := chk["within"])
    for i in range(n):
        vals = ([float(np.ravel(designs[k])[i]) for k in names]
                + [float(np.ravel(fast[k])[i]) for k in OBJECTIVE_NAMES]
                + [float(td[k][i]) for k in OBJECTIVE_NAMES]
                + [float(np.max(np.array(chk["fractions"][k])[:, i])) for k in lim])
        lines.append(",".join(f"{v:.10g}" for v in vals) + f",{bool(hs[i])}")
    summary = {"n_designs": n, "road": {"iso_class": cfg.road.iso_class,
                                        "speed_km_per_h": cfg.road.speed_km_per_h,
                                        "length_m": cfg.road.length_m, "seeds": seeds,
                                        "design_road_seed": cfg.road.seed},
               "worst_abs_rel_error": worst,
               "median_abs_rel_error": {k: float(np.median(np.abs(v))) for k, v in err.items()},
               "within_5pct": bool(max(worst.values()) <= 0.05),
               "held_out_roads": chk, "all_within_limits": bool(all(chk["within"]))}
    return summary, "\n".join(lines) + "\n"


def harvesters_of(ev: Any, designs: Mapping[str, np.ndarray]) -> list[Any]:
    """One :class:`~ehsa_opt.physics.params.HarvesterParams` per design, with the
    evaluator's motor model (the winding R_i, L_i at the design's K_e; a catalogue
    motor's constants and rotor inertia)."""
    if hasattr(ev, "harvesters"):
        return ev.harvesters(designs)
    from .sweep import harvesters_from
    hs = harvesters_from(ev.base, designs)
    motor = getattr(ev, "motor", None)
    if motor is None:
        return hs
    n = len(hs)
    mapping = ev.design_mapping(designs)
    ri = np.broadcast_to(np.asarray(mapping["internal_resistance_ohm"], float), (n,))
    li = np.broadcast_to(np.asarray(mapping["inductance_H"], float), (n,))
    out = []
    for k, h in enumerate(hs):
        h = h.replace(internal_resistance_ohm=float(ri[k]), inductance_H=float(li[k]))
        if getattr(motor, "kind", None) == "catalogue":
            jt = h.total_inertia_gcm2
            h = motor.harvester(h).replace(
                screw_inertia_gcm2=max(jt - motor.motor_inertia_gcm2, 0.0))
        out.append(h)
    return out


def _time_domain_limits(cfg: DesignConfig, ev: Any, hs: Sequence[Any],
                        fast: Mapping[str, np.ndarray], *, settle_s: float = 2.0,
                        sample_rate_hz: float = 1000.0) -> dict[str, Any]:
    """The limit constraints re-evaluated from a frictionless time-domain simulation of the
    same designs: rms current, the measured peak voltage (the design's is the Rice 95 %
    quantile of the peak), the stroke and currents at the design's Gaussian level of the
    simulated rms; and the measured peaks.  ``within_5pct``: every constraint holds in the
    time domain within 5 % of its limit and agrees with the frequency path's within 5 % of
    the limit."""
    import warnings

    from ..vehicle.simulate import RoadHoldingWarning, simulate_quarter_car
    from .limits import LimitSettings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RoadHoldingWarning)
        sim = simulate_quarter_car(cfg.vehicle, list(hs), None, cfg.road, settle_s=settle_s,
                                   sample_rate_hz=sample_rate_hz, keep_series=False)
    m = sim.metrics
    z2 = (getattr(ev, "limits", None) or LimitSettings()).z_two_sided
    ri = np.array([h.internal_resistance_ohm for h in hs])
    lim = {c: np.asarray(fast[f"limit_{c}"], float) for c in ev.constraint_names
           if f"limit_{c}" in fast}
    td = {}
    for c in ev.constraint_names:
        if c == "rated_current":
            td[c] = m["current_rms_A"] / lim[c] - 1.0
        elif c == "peak_current":
            td[c] = z2 * m["current_rms_A"] / lim[c] - 1.0
        elif c == "rated_voltage":
            td[c] = m["peak_voltage_V"] / lim[c] - 1.0
        elif c == "rated_power":
            td[c] = (m["power_W"] + ri * m["current_rms_A"] ** 2) / lim[c] - 1.0
        elif c == "stroke":
            td[c] = z2 * m["stroke_rms_m"] / ev.stroke_limit_m - 1.0
        else:  # geometric (motor inertia), speed: the design's value
            td[c] = np.asarray(fast[f"constraint_{c}"], float)
    worst_td = {c: float(np.max(v)) for c, v in td.items()}
    # the peak voltage is a statistic of one road: compared with its interval, not its value
    diff = {c: float(np.max(np.abs(v - np.asarray(fast[f"constraint_{c}"], float))))
            for c, v in td.items() if c != "rated_voltage"}
    out: dict[str, Any] = {}
    if "peak_voltage_low_V" in fast:
        lo, hi = (np.asarray(fast[k], float) for k in ("peak_voltage_low_V",
                                                       "peak_voltage_high_V"))
        out["peak_voltage_interval_V"] = [float(np.min(lo)), float(np.max(hi))]
        out["peak_voltage_in_interval"] = bool(np.all((m["peak_voltage_V"] >= lo)
                                                      & (m["peak_voltage_V"] <= hi)))
    return {**out, "time_domain_worst_constraint": worst_td,
            "frequency_vs_time_worst_difference": diff,
            "measured_peak_voltage_V": float(np.max(m["peak_voltage_V"])),
            "measured_peak_current_A": float(np.max(m["peak_current_A"])),
            "measured_peak_stroke_m": float(np.max(m["peak_stroke_m"])),
            "within_5pct": bool(all(v <= 0.05 for v in worst_td.values())
                                and all(v <= 0.05 for v in diff.values()))}
