"""Design with friction in the loop: the paper's objectives by the friction-aware
fast path (:func:`ehsa_opt.vehicle.fast_path.friction_metrics`), at one friction
set, or the worst case / mean over several (e.g. the identified ``min`` and ``max``).

:class:`FrictionObjectives` is an evaluator of :class:`~ehsa_opt.design.problem.DesignProblem`
like :class:`~ehsa_opt.design.problem.QuarterCarObjectives` (same objective names,
vectorised, picklable), so goal attainment and NSGA-II run on it unchanged.

Modes
-----
``at``
    The objectives at the single friction set.
``worst``
    Per objective, the worst (largest, all are minimised) over the sets.
``mean``
    Per objective, the mean over the sets.

:func:`time_domain_objectives` re-simulates designs in the time domain with the
same friction and mode (the reference check of every optimum).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from ..physics.params import (FrictionParams, HarvesterParams, ParameterError, RoadParams,
                              VehicleParams)
from .problem import OBJECTIVE_NAMES, QuarterCarObjectives

__all__ = ["FRICTION_MODES", "FrictionObjectives", "combine", "time_domain_objectives",
           "objectives_from_metrics"]

#: How several friction sets combine into one objective vector.
FRICTION_MODES: tuple[str, ...] = ("at", "worst", "mean")

_EXTRA = ("comfort_weighted_rms_m_s2", "power_W", "efficiency", "power_dimensionless",
          "dissipated_power_W", "dissipation_bound_W", "friction_power_W")


def objectives_from_metrics(m: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """[α, η_rh, 1/ρ_g, 1/η_g] and the extras from a metrics dict."""
    with np.errstate(divide="ignore"):
        out = {"comfort": np.asarray(m["comfort"], float),
               "road_holding": np.asarray(m["road_holding"], float),
               "inverse_power": 1.0 / np.asarray(m["power_dimensionless"], float),
               "inverse_efficiency": 1.0 / np.asarray(m["efficiency"], float)}
    for key in _EXTRA:
        if key in m:
            out[key] = np.asarray(m[key], float)
    return out


def combine(per_set: Sequence[Mapping[str, np.ndarray]], mode: str) -> dict[str, np.ndarray]:
    """Combine per-friction-set outputs: objectives by ``mode``; extras (W, %) follow
    the objective they belong to (worst power for ``worst``, mean for ``mean``)."""
    if mode not in FRICTION_MODES:
        raise ParameterError(f"--friction-mode: unknown mode '{mode}' (valid: "
                             f"{', '.join(FRICTION_MODES)})")
    if mode == "at" and len(per_set) != 1:
        raise ParameterError(f"--friction-mode at needs exactly one friction set, got "
                             f"{len(per_set)}; use worst or mean for several")
    if len(per_set) == 1:
        return dict(per_set[0])
    keys = [k for k in per_set[0] if all(k in p for p in per_set)]
    stack = {k: np.stack([np.asarray(p[k], float) for p in per_set]) for k in keys}
    worst = ("constraint_", "value_", "fraction_")  # limits: the worst set, in any mode
    if mode == "mean":
        return {k: v.max(axis=0) if k.startswith(worst) else v.mean(axis=0)
                for k, v in stack.items()}
    out = {k: stack[k].max(axis=0) for k in OBJECTIVE_NAMES}
    follow = {"power_W": "inverse_power", "power_dimensionless": "inverse_power",
              "efficiency": "inverse_efficiency", "comfort_weighted_rms_m_s2": "comfort"}
    for k in keys:
        if k in out:
            continue
        ref = follow.get(k)
        if ref is not None:
            idx = np.argmax(stack[ref], axis=0)
            out[k] = np.take_along_axis(stack[k], idx[None], axis=0)[0]
        else:
            out[k] = stack[k].max(axis=0)
    return out


@dataclass(frozen=True)
class FrictionObjectives(QuarterCarObjectives):
    """Paper objectives with friction, by stochastic equivalent linearisation.

    Attributes
    ----------
    frictions : tuple of FrictionParams
        One (mode ``at``) or several friction sets.
    mode : str
        ``at``, ``worst`` or ``mean`` (:data:`FRICTION_MODES`).
    labels : tuple of str
        Names of the sets (reports only).
    """

    frictions: tuple[FrictionParams, ...] = ()
    mode: str = "at"
    labels: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.frictions:
            raise ParameterError("FrictionObjectives: give at least one friction set "
                                 "(--friction FILE[:CASE] or a [friction] table)")
        if self.mode not in FRICTION_MODES:
            raise ParameterError(f"--friction-mode: unknown mode '{self.mode}' (valid: "
                                 f"{', '.join(FRICTION_MODES)})")
        if self.mode == "at" and len(self.frictions) != 1:
            raise ParameterError(f"--friction-mode at needs exactly one friction set, got "
                                 f"{len(self.frictions)}; use worst or mean for several")

    def per_set(self, design: Mapping[str, Any]) -> list[dict[str, np.ndarray]]:
        """Objectives and extras at each friction set; with constraints, the limits from
        the linear path with the friction's equivalent damping c_f (its rms current,
        voltage, stroke and their rates)."""
        from ..vehicle.fast_path import friction_metrics
        from ..vehicle.frequency_path import linear_metrics
        mapping = self.design_mapping(design)
        opts = dict(self.metric_options)
        out = []
        for f in self.frictions:
            fm = friction_metrics(self.vehicle, self.road, mapping, f, **opts)
            o = objectives_from_metrics(fm)
            if self.constraint_names:
                lm = linear_metrics(self.vehicle, self.road, mapping,
                                    friction_damping_Ns_per_m=fm["friction_damping_Ns_per_m"],
                                    **{k: v for k, v in opts.items() if k == "n_freq"})
                o.update(self.constraints(mapping, lm))
            out.append(o)
        return out

    def __call__(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        return combine(self.per_set(design), self.mode)

    def fingerprint(self) -> dict[str, Any]:
        fp = super().fingerprint()
        fp.update({"kind": "quarter_car_friction_equivalent", "mode": self.mode,
                   "frictions": [{**f.as_dict(), **f.law_dict()} for f in self.frictions]})
        return fp


def time_domain_objectives(vehicle: VehicleParams, road: RoadParams,
                           harvesters: Sequence[HarvesterParams],
                           frictions: Sequence[FrictionParams | None], mode: str, *,
                           settle_s: float = 2.0, sample_rate_hz: float = 1000.0
                           ) -> dict[str, np.ndarray]:
    """Objectives of designs re-simulated in the time domain (one batch per set)."""
    import warnings

    from ..vehicle.simulate import RoadHoldingWarning, simulate_quarter_car
    per = []
    for f in frictions:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RoadHoldingWarning)
            sim = simulate_quarter_car(vehicle, list(harvesters), [f or FrictionParams()]
                                       * len(harvesters), road, settle_s=settle_s,
                                       sample_rate_hz=sample_rate_hz, keep_series=False)
        per.append(objectives_from_metrics(sim.metrics))
    return combine(per, mode if len(per) > 1 else "at")
