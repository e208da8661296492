"""Validation of the friction-aware fast path against the time-domain simulation.

The set: designs × friction sets × roads.  Each road case (class, speed,
seed) runs every design–friction pair in one batched time-domain call
(:func:`~ehsa_opt.vehicle.simulate.simulate_quarter_car`, the reference) and in one
vectorised fast-path call (:func:`~ehsa_opt.vehicle.fast_path.friction_metrics`);
the relative errors of comfort, road holding, power and efficiency are tabulated.
Used by ``validation/friction_fast_path.py`` and the robust-design report step.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ...physics.params import FrictionParams, HarvesterParams, RoadParams, VehicleParams
from ..simulate import RoadHoldingWarning, simulate_quarter_car
from .linearisation import friction_metrics

__all__ = ["CHECK_METRICS", "MIN_RECORD_S", "RoadCase", "scaled_friction", "check_case",
           "summarise"]

#: Metrics compared (fast path vs time domain).
CHECK_METRICS: tuple[str, ...] = ("power_W", "efficiency", "comfort", "road_holding")

#: Shortest record (s) of a validation road whose length is not given.  The road's
#: line amplitudes are deterministic, so a *linear* quarter car's variances do not
#: depend on the seed; with friction they do: the prototype at ×2 friction on class B
#: at 110 km/h has time-domain power 11.98–12.94 W over four seeds on 400 m (13 s;
#: the fast path's 12.25 W is −5.3 % to +2.3 % from them) and 12.24–12.39 W on 2000 m
#: (65 s; −1.1 % to +0.1 %).  A reference with a ±4 % scatter of its own cannot check
#: a 5 % goal, so validation roads last at least this long (and at least 400 m).
MIN_RECORD_S = 60.0


@dataclass(frozen=True)
class RoadCase:
    """One road of the validation set.

    ``length_m`` None: max(400 m, the distance covered in :data:`MIN_RECORD_S`)."""

    iso_class: str
    speed_km_per_h: float
    seed: int
    length_m: float | None = None

    @property
    def length(self) -> float:
        """Road length (m)."""
        if self.length_m is not None:
            return float(self.length_m)
        return max(400.0, self.speed_km_per_h / 3.6 * MIN_RECORD_S)

    def road(self) -> RoadParams:
        return RoadParams(self.iso_class, self.speed_km_per_h, length_m=self.length,
                          seed=self.seed)


def scaled_friction(friction: FrictionParams | Mapping[str, float], scale: float
                    ) -> FrictionParams:
    """``friction`` with its force/torque levels and viscous terms × ``scale``
    (breakaway velocities unchanged)."""
    values = friction.as_dict() if isinstance(friction, FrictionParams) else dict(friction)
    return FrictionParams(**{k: (v * scale if "velocity" not in k else v)
                             for k, v in values.items()})


def check_case(vehicle: VehicleParams, case: RoadCase, harvesters: Sequence[HarvesterParams],
               frictions: Sequence[FrictionParams], *, n_freq: int = 256,
               fast_repeats: int = 1, non_gaussian: bool = True, residual: bool = True,
               threads: int | None = None) -> dict[str, np.ndarray | float]:
    """Fast path vs time domain for every (harvester, friction) pair on one road.

    Parameters
    ----------
    fast_repeats : int
        Times the (millisecond) fast-path call is repeated: ``fast_wall_s`` is the
        first call, ``fast_wall_median_s`` the median (robust to a shared machine's
        load, which a single call of a few ms is not; the time-domain call lasts
        seconds and is timed once).
    non_gaussian : bool
        Passed to :func:`~ehsa_opt.vehicle.fast_path.friction_metrics` (False: the
        plain Gaussian equivalent linearisation, for comparison).
    residual : bool
        Passed to :func:`~ehsa_opt.vehicle.fast_path.friction_metrics` (False:
        without the friction's non-linear residual force).
    threads : int, optional
        Threads of the time-domain simulation (default: two on a machine with two or
        more CPUs; the fast path runs on one).

    Returns
    -------
    dict
        ``fast_<metric>``, ``time_<metric>``, ``error_<metric>`` (relative, signed)
        arrays over the pairs (harvester-major), ``sticking_correction`` (the
        energy-envelope correction's size c_gauss/c_f − 1: 0 for Gaussian stroke
        velocity, growing as the strut sticks), ``harvester_index``,
        ``friction_index``, and ``fast_wall_s`` / ``fast_wall_median_s`` /
        ``time_wall_s`` (s).
    """
    hs = [h for h in harvesters for _ in frictions]
    fs = [f for _ in harvesters for f in frictions]
    road = case.road()
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RoadHoldingWarning)
        sim = simulate_quarter_car(vehicle, hs, fs, road, keep_series=False, threads=threads)
    t_time = time.perf_counter() - t0
    fields = ("motor_inertia_gcm2", "screw_inertia_gcm2", "lead_mm_per_rev",
              "internal_resistance_ohm", "voltage_constant_Vs_per_rad",
              "torque_constant_Nm_per_A", "inductance_H", "load_ohm")
    design = {k: np.array([getattr(h, k) for h in hs]) for k in fields}
    walls = []
    for _ in range(max(1, int(fast_repeats))):
        t0 = time.perf_counter()
        fast = friction_metrics(vehicle, road, design, fs, n_freq=n_freq,
                                non_gaussian=non_gaussian, residual=residual)
        walls.append(time.perf_counter() - t0)
    t_fast = walls[0]
    out: dict[str, np.ndarray | float] = {
        "harvester_index": np.repeat(np.arange(len(harvesters)), len(frictions)),
        "friction_index": np.tile(np.arange(len(frictions)), len(harvesters)),
        "fast_wall_s": t_fast, "fast_wall_median_s": float(np.median(walls)),
        "time_wall_s": t_time, "n_pairs": float(len(hs))}
    with np.errstate(invalid="ignore", divide="ignore"):
        cf = np.asarray(fast["friction_damping_Ns_per_m"], float)
        out["sticking_correction"] = np.where(
            cf > 0.0, np.asarray(fast["friction_damping_gaussian_Ns_per_m"], float) / cf - 1.0,
            0.0)
    for k in CHECK_METRICS:
        td = np.asarray(sim.metrics[k], float)
        fp = np.asarray(fast[k], float)
        out[f"fast_{k}"], out[f"time_{k}"] = fp, td
        with np.errstate(invalid="ignore", divide="ignore"):
            out[f"error_{k}"] = np.where(td != 0.0, fp / td - 1.0, fp - td)
    return out


def summarise(results: Sequence[Mapping[str, np.ndarray | float]]) -> dict[str, dict]:
    """Worst and median |relative error| per metric over a list of :func:`check_case`
    results."""
    summary = {}
    for k in CHECK_METRICS:
        e = np.abs(np.concatenate([np.asarray(r[f"error_{k}"]) for r in results]))
        summary[k] = {"worst": float(np.max(e)), "median": float(np.median(e)),
                      "n": int(e.size)}
    return summary
