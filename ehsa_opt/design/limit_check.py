"""Designs re-simulated on roads they were not optimised on: every hardware limit counted
per sample in the time domain, with the spread over the road realisations, and the
hypervolume of a front with its 95 % interval over those roads.

The optimiser sees the design road through the exact frequency path (a power spectrum:
no realisation).  A check draws ``n_roads`` new realisations of the same ISO 8608 class
and speed (seeds ``seed + 1 …``, never the design road's ``seed``) and simulates every
design on each.  Per design and road it counts
the fraction of samples beyond each hard limit, the rms current against the thermal rating,
the largest |V| against the voltage limit and the screw's cubic mean axial load (weighted
by revolutions, summed over the samples) against the load of its required life.  A finite road estimates these with an
error, so a design on its limit is beyond it on about half the roads; a design is
*within* a limit unless the roads show it beyond at 95 % (one-sided): the mean over the
roads less its Student-t half-width is above the tolerance (``time_fraction``,
``tyre_lift_fraction``) or the rating (rms current, the screw's mean load), or the voltage's peak is above the
limit on more roads than a binomial share 1 − ``peak_quantile`` explains at 5 %.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any, Mapping, Sequence

import numpy as np
from scipy import stats

from ..physics.ball_screw import allowable_mean_load
from .limits import LimitSettings, revolution_weighted_mean_load

__all__ = ["limits_on_roads", "hypervolume_interval", "held_out_seeds", "HELD_OUT_ROADS"]

#: Road realisations of a check: five give a Student-t interval with 4 degrees of freedom
#: at a cost of five time-domain runs of the front.
HELD_OUT_ROADS = 5

_SERIES = ("stroke_velocity_m_s", "voltage_V", "current_A", "x2_m", "x1_m",
           "tyre_deflection_m")


def held_out_seeds(seed: int, n_roads: int) -> list[int]:
    """Road seeds a check uses: the ``n_roads`` after the design road's ``seed``."""
    return [int(seed) + 1 + k for k in range(int(n_roads))]


def _simulate(vehicle: Any, road: Any, hs: Sequence[Any], friction: Any, settle_s: float,
              sample_rate_hz: float) -> Any:
    from ..vehicle.simulate import RoadHoldingWarning, simulate_quarter_car
    fr = None if friction is None else [friction] * len(hs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RoadHoldingWarning)
        return simulate_quarter_car(vehicle, list(hs), fr, road, settle_s=settle_s,
                                    sample_rate_hz=sample_rate_hz, keep_series=_SERIES)


def _one_road(ev: Any, sim: Any, hs: Sequence[Any], flat: Mapping[str, np.ndarray],
              names: Sequence[str], sample_rate_hz: float) -> dict[str, np.ndarray]:
    """Per design on one simulated road: the fraction of samples beyond each hard limit
    (``fraction_<name>``), the rms current, the largest |V| and the screw's
    revolution-weighted mean load over the load of its required life."""
    s, veh, n = sim.series, ev.vehicle, len(hs)
    r = np.array([h.lead_m_per_rad for h in hs])
    rpm = np.abs(s["stroke_velocity_m_s"]) / r[:, None] * 30.0 / math.pi
    sig = {"peak_current": (np.abs(s["current_A"]), flat["peak_current_A"]),
           "rated_voltage": (np.abs(s["voltage_V"]), flat["max_voltage_V"]),
           "motor_speed": (rpm, flat["max_speed_rpm"]),
           "stroke": (np.abs(s["x2_m"] - s["x1_m"]), np.full(n, ev.stroke_limit_m or np.inf)),
           "tyre_lift": (veh.tyre_stiffness_N_per_m * s["tyre_deflection_m"]
                         / (veh.total_mass_kg * 9.81), np.ones(n))}
    if "screw_speed" in names:
        sig["screw_speed"] = (rpm, flat["screw_max_speed_rpm"])
    out = {f"fraction_{k}": np.mean(x > lim[:, None], axis=1)
           for k, (x, lim) in sig.items() if k in names}
    if "screw_life" in names:
        jt = np.array([h.total_inertia_gcm2 for h in hs]) * 1e-7
        kt = np.array([h.torque_constant_Nm_per_A for h in hs])
        acc = np.gradient(s["stroke_velocity_m_s"], 1.0 / sample_rate_hz, axis=1)
        force = (jt / r ** 2)[:, None] * acc + (kt / r)[:, None] * s["current_A"]
        out["screw_load_N"] = revolution_weighted_mean_load(force, rpm)
        allow = allowable_mean_load(flat["screw_dynamic_load_N"],
                                    ev.life_revolutions(np.mean(rpm, axis=1) / 60.0))
        out["screw_load_ratio"] = out["screw_load_N"] / allow
        out["fraction_screw_life"] = (out["screw_load_ratio"] > 1.0).astype(float)
    out["current_rms_A"] = np.sqrt(np.mean(s["current_A"] ** 2, axis=1))
    out["fraction_rated_current"] = (out["current_rms_A"] > flat["rated_current_A"]
                                     ).astype(float)
    out["peak_voltage_V"] = np.max(np.abs(s["voltage_V"]), axis=1)
    return out


def limits_on_roads(ev: Any, designs: Mapping[str, np.ndarray], seeds: Sequence[int], *,
                    settle_s: float = 2.0, sample_rate_hz: float = 1000.0,
                    objective_names: Sequence[str] = ()) -> dict[str, Any]:
    """Every limit of a selection evaluator's designs on the roads ``seeds`` (see module);
    with the evaluator's friction sets (``ev.frictions``) each road is simulated with each
    set and a limit takes the worst set, the objectives the evaluator's ``mode``.

    Returns
    -------
    dict
        ``seeds``; per limit ``fractions[name]`` (roads × designs), ``current_rms_A`` and
        ``peak_voltage_V`` (roads × designs); ``within`` per design; the worst fraction of
        each limit; with ``objective_names`` the time-domain objectives per road
        (``objectives``: name → roads × designs).
    """
    from .robust import combine
    st: LimitSettings = ev.limits
    hw = ev.hardware(designs)
    hs = ev.harvesters(designs)
    n = len(hs)
    flat = {k: np.ravel(np.broadcast_to(np.asarray(v, float), (n,))) for k, v in hw.items()}
    names = [k for k in ev.constraint_names if k != "motor_inertia"]
    frictions = tuple(getattr(ev, "frictions", ())) or (None,)
    per_road: list[dict[str, np.ndarray]] = []
    objs: dict[str, list] = {k: [] for k in objective_names}
    for sd in seeds:
        road = dataclasses.replace(ev.road, seed=int(sd))
        sims = [_simulate(ev.vehicle, road, hs, f, settle_s, sample_rate_hz) for f in frictions]
        sets = [_one_road(ev, sim, hs, flat, names, sample_rate_hz) for sim in sims]
        per_road.append({k: np.max([m[k] for m in sets], axis=0) for k in sets[0]})
        if objective_names:
            comb = combine([{k: _objective(sim.metrics, k) for k in objective_names}
                            for sim in sims], getattr(ev, "mode", "at") if len(sims) > 1
                           else "at")
            for k in objective_names:
                objs[k].append(comb[k])
    fr = {k: [m[f"fraction_{k}"] for m in per_road] for k in names}
    cur = [m["current_rms_A"] for m in per_road]
    vpk = [m["peak_voltage_V"] for m in per_road]
    fm = [m["screw_load_N"] for m in per_road if "screw_load_N" in m]
    ratio = [m["screw_load_ratio"] for m in per_road if "screw_load_ratio" in m]
    F = {k: np.array(v) for k, v in fr.items()}
    cur_a, vpk_a = np.array(cur), np.array(vpk)
    k_roads = len(seeds)
    tq = float(stats.t.ppf(0.95, k_roads - 1)) if k_roads > 1 else 0.0

    def lower(x: np.ndarray) -> np.ndarray:  # one-sided 95 % lower bound over the roads
        sd = np.std(x, axis=0, ddof=1) if k_roads > 1 else np.zeros(x.shape[1])
        return np.mean(x, axis=0) - tq * sd / math.sqrt(k_roads)
    # most roads with a peak above the limit a share 1 − q explains (binomial, 5 %)
    n_peak = int(stats.binom.ppf(0.95, k_roads, 1.0 - st.peak_quantile))
    ok = np.ones(n, bool)
    for k, v in F.items():
        if k == "rated_current":
            ok &= lower(cur_a) <= flat["rated_current_A"]
        elif k == "screw_life":
            ok &= lower(np.array(ratio)) <= 1.0
        elif k == "rated_voltage":
            ok &= np.sum(vpk_a > flat["max_voltage_V"][None, :], axis=0) <= n_peak
        elif k == "tyre_lift":
            ok &= lower(v) <= st.tyre_lift_fraction
        else:
            ok &= lower(v) <= st.time_fraction
    not_time = ("rated_current", "rated_voltage", "screw_life")
    out = {"seeds": [int(x) for x in seeds], "fractions": {k: v.tolist() for k, v in F.items()},
           "worst_fraction": {k: float(np.max(v)) for k, v in F.items() if k not in not_time},
           "current_rms_A": cur_a.tolist(), "peak_voltage_V": vpk_a.tolist(),
           "worst_current_over_rating": float(np.max(cur_a / flat["rated_current_A"])),
           "peak_voltage_share_over_limit": float(np.max(np.mean(
               vpk_a > flat["max_voltage_V"][None, :], axis=0))),
           "mean_fraction": {k: np.mean(v, axis=0).max().item() for k, v in F.items()
                             if k not in not_time},
           "within": ok.tolist(), "n_within": int(np.sum(ok)), "n_designs": n,
           "peak_roads_allowed": n_peak,
           "settings": st.as_dict()}
    if fm:
        out["screw_mean_load_N"] = np.array(fm).tolist()
        out["worst_screw_load_over_allowed"] = float(np.max(np.array(ratio)))
    if objective_names:
        out["objectives"] = {k: np.array(v).tolist() for k, v in objs.items()}
    return out


def _objective(m: Mapping[str, np.ndarray], name: str) -> np.ndarray:
    if name == "inverse_power":
        return 1.0 / m["power_dimensionless"]
    if name == "inverse_efficiency":
        return 1.0 / m["efficiency"]
    return np.asarray(m[name], float)


def hypervolume_interval(F_per_road: np.ndarray, scale: np.ndarray, reference: np.ndarray,
                         level: float = 0.95) -> dict[str, Any]:
    """Hypervolume of a front evaluated on each road (``F_per_road``: roads × designs ×
    objectives, normalised by ``scale``, reference point ``reference``), its mean and
    Student-t ``level`` interval over the roads."""
    from pymoo.indicators.hv import HV
    hv = HV(ref_point=np.asarray(reference, float))
    vals = np.array([float(hv(np.asarray(F, float) / scale)) for F in F_per_road])
    k = vals.size
    mean = float(np.mean(vals))
    half = (float(stats.t.ppf(0.5 + level / 2, k - 1) * np.std(vals, ddof=1) / math.sqrt(k))
            if k > 1 else float("nan"))
    return {"per_road": vals.tolist(), "mean": mean, "interval": [mean - half, mean + half],
            "level": level, "n_roads": k}
