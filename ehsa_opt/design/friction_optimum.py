"""Friction on the optimised design (paper Fig 20, Table 4).

The design found without friction is simulated in the time domain
(:func:`ehsa_opt.vehicle.simulate.simulate_quarter_car`) with no, minimum and maximum
friction over a range of speeds; one task per speed (the three friction cases
in one batch on the same road), spread over a local pool or a Dask cluster by
:func:`ehsa_opt.design.sweep.executor`.  Changes are in the paper's sign convention:
positive = better than the frictionless design (lower α or η_rh).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from ..physics.params import (
    FrictionParams,
    HarvesterParams,
    ParameterError,
    RoadParams,
    VehicleParams,
)

__all__ = ["FrictionSpeedTask", "friction_on_optimum"]


@dataclass(frozen=True)
class FrictionSpeedTask:
    """The optimum at one speed with every friction case (a pure function)."""

    vehicle: VehicleParams
    harvester: HarvesterParams
    frictions: tuple[tuple[str, FrictionParams | None], ...]
    road: RoadParams
    settle_s: float = 2.0
    sample_rate_hz: float = 1000.0
    identified_range_m_per_s: float | None = None

    def __call__(self) -> list[dict[str, Any]]:
        from ..vehicle.frequency_path import linear_metrics
        from ..vehicle.simulate import simulate_quarter_car
        names = [n for n, _ in self.frictions]
        fr = [f if f is not None else FrictionParams() for _, f in self.frictions]
        sim = simulate_quarter_car(self.vehicle, [self.harvester] * len(fr), fr, self.road,
                                   settle_s=self.settle_s, sample_rate_hz=self.sample_rate_hz,
                                   keep_series=False, warn=False,
                                   identified_range_m_per_s=self.identified_range_m_per_s)
        if not sim.success:
            raise RuntimeError(f"friction on the optimum at {self.road.speed_km_per_h} km/h: "
                               f"{sim.message}")
        m = sim.metrics
        lin = linear_metrics(self.vehicle, self.road, {"load_ohm": self.harvester.load_ohm},
                             base=self.harvester, n_freq=1024)
        from ..vehicle.validity import check_validity
        validity = check_validity(m, stroke_limit_m=self.vehicle.stroke_limit_m)
        ref = names.index("none") if "none" in names else None
        rows = []
        for b, name in enumerate(names):
            row = {"speed_km_per_h": self.road.speed_km_per_h, "friction": name,
                   "power_W": float(m["power_W"][b]),
                   "efficiency_pct": 100.0 * float(m["efficiency"][b]),
                   "comfort": float(m["comfort"][b]),
                   "comfort_weighted_rms_m_s2": float(m["comfort_weighted_rms_m_s2"][b]),
                   "road_holding": float(m["road_holding"][b]),
                   "peak_power_W": float(m["peak_power_W"][b]),
                   "dissipated_power_W": float(m["dissipated_power_W"][b]),
                   "energy_residual": float(m["energy_residual"][b]),
                   "linear_power_W": float(np.ravel(lin["power_W"])[0]),
                   "linear_comfort": float(np.ravel(lin["comfort"])[0]),
                   **{k: float(m[k][b]) for k in ("peak_stroke_m", "peak_voltage_V",
                                                  "peak_current_A", "voltage_rms_V",
                                                  "current_rms_A")},
                   "validity": [f.message for f in validity.flags[b]]}
            for k in ("out_of_range_time_fraction", "out_of_range_friction_energy_fraction"):
                if k in m:
                    row[k] = float(m[k][b])
            if ref is not None:
                row["comfort_change_pct"] = 100.0 * (1.0 - m["comfort"][b] / m["comfort"][ref])
                row["road_holding_change_pct"] = 100.0 * (1.0 - m["road_holding"][b]
                                                          / m["road_holding"][ref])
                row["power_change_pct"] = 100.0 * (m["power_W"][b] / m["power_W"][ref] - 1.0)
            rows.append({k: float(v) if isinstance(v, (float, np.floating)) else v
                         for k, v in row.items()})
        return rows


def _call(task: Any) -> Any:
    return task()


def friction_on_optimum(cfg: Any, design: Mapping[str, float],
                        friction_sets: Mapping[str, FrictionParams],
                        speeds_km_per_h: Sequence[float], *, road_length_m: float | None = None,
                        jobs: int = 1, scheduler: Any = None,
                        identified_range_m_per_s: float | None = None
                        ) -> list[dict[str, Any]]:
    """Rows (speed × {none, min, max, …}) of the optimum with friction.

    Parameters
    ----------
    cfg : DesignConfig
        Vehicle, road class/seed, base harvester and simulation settings.
    design : mapping
        The optimum: total_inertia_gcm2, lead_mm_per_rev, speed_constant_rpm_per_V,
        load_ohm.
    friction_sets : mapping
        Named friction sets (e.g. 'min', 'max'); 'none' is added first.
    speeds_km_per_h : sequence of float
    road_length_m : float, optional
        Default the problem file's ``[road] length_m``.
    identified_range_m_per_s : float, optional
        The friction's identified range: rows then hold ``out_of_range_time_fraction`` and
        ``out_of_range_friction_energy_fraction`` (:mod:`ehsa_opt.vehicle.coverage`).
    """
    from .sweep import executor

    if not speeds_km_per_h:
        raise ParameterError("friction on the optimum: give at least one speed")
    h = HarvesterParams.from_design(float(design["total_inertia_gcm2"]),
                                    float(design["lead_mm_per_rev"]),
                                    float(design["speed_constant_rpm_per_V"]),
                                    float(design["load_ohm"]), base=cfg.harvester)
    cases = (("none", None),) + tuple((n, f) for n, f in friction_sets.items())
    sim = cfg.physical.simulation if cfg.physical is not None else None
    length = cfg.road.length_m if road_length_m is None else float(road_length_m)
    tasks = [FrictionSpeedTask(cfg.vehicle, h, cases,
                               RoadParams(iso_class=cfg.road.iso_class, speed_km_per_h=float(v),
                                          length_m=length, seed=cfg.road.seed),
                               sim.settle_s if sim else 2.0,
                               sim.sample_rate_hz if sim else 1000.0, identified_range_m_per_s)
             for v in speeds_km_per_h]
    with executor(jobs, scheduler) as mapper:
        parts = mapper(_call, tasks)
    return [r for part in parts for r in part]
