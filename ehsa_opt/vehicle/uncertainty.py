"""Vehicle metrics with their 95 % interval over road realisations.

A time-domain metric (comfort, road holding, power, efficiency, a peak, a share of the time)
comes from one finite road; another stretch of the same ISO 8608 class gives another value.
The interval says how far that goes.

**Method: independent road realisations.**  :func:`road_intervals` simulates the designs on
``n_seeds`` roads of the study's length, each a *Gaussian* sample of the ISO 8608 road
(:func:`~ehsa_opt.vehicle.road.synthesize_road` with ``amplitudes="gaussian"``: circular
Gaussian line coefficients, so the road is a stationary Gaussian process; the default
deterministic-amplitude synthesis would make every linear mean square the same on every
seed and hide the spread of a real road).  The realisations are independent, so a metric's
mean over them has the Student-t interval x̄ ± t₀.₉₇₅,ₖ₋₁ s/√K (:func:`seed_interval`); no
autocorrelation enters, because each realisation contributes one number.  Comparisons
(friction against none, one design against another) are *paired*: the same seeds for every
design, the interval taken on the per-seed change (:meth:`RoadIntervals.change`), which
removes the road's common part.

**Within one record: batch means.**  A single long series (a measured road, a per-sample
share of time) is autocorrelated, so its samples are not independent.
:func:`batch_means_interval` splits it into ``n_batches`` consecutive batches, uses the
batch means as (nearly) independent samples and reports the effective number of samples
N_eff = N s²/(b s_b²) the record is worth (s² the samples' variance, s_b² the variance of
the b batch means times the batch length).

**Digits follow the interval** (:func:`format_interval`): the half-width to two significant
digits, the mean to the same decimal place.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

import numpy as np
from scipy import stats

from ..physics.params import (FrictionParams, HarvesterParams, ParameterError, RoadParams,
                              VehicleParams)

__all__ = ["CONFIDENCE", "DEFAULT_SEEDS", "Interval", "seed_interval", "batch_means_interval",
           "format_interval", "realisation_seeds", "RoadIntervals", "road_intervals"]

#: Confidence level of every interval.
CONFIDENCE = 0.95
#: Road realisations per interval by default: with 8 the t quantile is 2.36 (1.21 × the
#: normal's 1.96), so an interval is within ~20 % of the width infinitely many would give,
#: at 8 × the cost of one road.
DEFAULT_SEEDS = 8


@dataclass(frozen=True)
class Interval:
    """A mean and its ``confidence`` interval.

    Attributes
    ----------
    mean, half_width : float
        Estimate and half-width (same unit as the metric).
    n : int
        Independent samples (seeds or batches).
    std : float
        Standard deviation of those samples.
    method : str
        ``"seeds"`` or ``"batch means"``.
    n_effective : float
        Effective number of independent samples of the underlying record (batch means);
        ``n`` for seeds.
    """

    mean: float
    half_width: float
    n: int
    std: float
    method: str = "seeds"
    n_effective: float = math.nan
    confidence: float = CONFIDENCE

    @property
    def low(self) -> float:
        return self.mean - self.half_width

    @property
    def high(self) -> float:
        return self.mean + self.half_width

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies in the interval (ends included)."""
        return bool(self.low <= value <= self.high)

    def overlaps(self, other: "Interval") -> bool:
        """Whether two intervals share a point (a difference not resolved by either)."""
        return bool(self.low <= other.high and other.low <= self.high)

    def scaled(self, factor: float) -> "Interval":
        """The interval of ``factor`` × the metric (e.g. 100 for per cent)."""
        return replace(self, mean=factor * self.mean, half_width=abs(factor) * self.half_width,
                       std=abs(factor) * self.std)

    def text(self, unit: str = "") -> str:
        """``mean ± half-width`` with the digits the interval supports."""
        return format_interval(self.mean, self.half_width, unit)

    def as_dict(self) -> dict[str, float]:
        return {"mean": self.mean, "half_width": self.half_width, "n": self.n, "std": self.std,
                "method": self.method, "n_effective": self.n_effective,
                "confidence": self.confidence}


def seed_interval(samples: Sequence[float], confidence: float = CONFIDENCE) -> Interval:
    """Student-t interval of the mean of independent samples (one per road realisation).

    Parameters
    ----------
    samples : sequence of float
        One value per realisation (at least two, finite).
    confidence : float
    """
    x = np.asarray(samples, dtype=float).ravel()
    if x.size < 2 or not np.all(np.isfinite(x)):
        raise ValueError(f"seed_interval: need at least two finite samples, got {x.tolist()}")
    s = float(np.std(x, ddof=1))
    t = float(stats.t.ppf(0.5 + 0.5 * confidence, x.size - 1))
    return Interval(float(x.mean()), t * s / math.sqrt(x.size), int(x.size), s, "seeds",
                    float(x.size), confidence)


def batch_means_interval(series: Sequence[float], n_batches: int = 20,
                         confidence: float = CONFIDENCE) -> Interval:
    """Interval of the mean of one autocorrelated record by batch means.

    The record is cut into ``n_batches`` consecutive batches of equal length (the last
    ``N mod n_batches`` samples dropped); their means are treated as independent, which
    holds when a batch is much longer than the record's correlation time (20 batches of a
    1000 m road at 100 km/h are 1.8 s each, against the body mode's ~1 s period).

    Returns
    -------
    Interval
        ``n_effective`` = N s²/(b s_b² L): the number of independent samples the record is
        worth (N when uncorrelated, fewer when correlated).
    """
    x = np.asarray(series, dtype=float).ravel()
    if n_batches < 2 or x.size < 2 * n_batches:
        raise ValueError(f"batch_means_interval: {x.size} samples cannot make {n_batches} "
                         "batches of two or more")
    L = x.size // n_batches
    means = x[:L * n_batches].reshape(n_batches, L).mean(axis=1)
    base = seed_interval(means, confidence)
    var_x = float(np.var(x[:L * n_batches], ddof=1))
    var_mean = base.std ** 2 / n_batches
    n_eff = var_x / var_mean if var_mean > 0.0 else float(x.size)
    return replace(base, mean=float(x[:L * n_batches].mean()), method="batch means",
                   n_effective=float(min(n_eff, x.size)))


def format_interval(mean: float, half_width: float, unit: str = "") -> str:
    """``mean ± half-width`` rounded as the interval allows: the half-width to two
    significant digits, the mean to the same decimal place (a zero half-width: the mean
    to four significant digits and ``± 0``)."""
    u = f" {unit}" if unit else ""
    if not (math.isfinite(mean) and math.isfinite(half_width)):
        return f"{mean:g} ± {half_width:g}{u}"
    if half_width <= 0.0:
        return f"{mean:.4g} ± 0{u}"
    decimals = 1 - int(math.floor(math.log10(half_width)))
    if decimals <= 0:
        q = 10.0 ** (-decimals)
        return f"{round(mean / q) * q:.0f} ± {round(half_width / q) * q:.0f}{u}"
    return f"{mean:.{decimals}f} ± {half_width:.{decimals}f}{u}"


def realisation_seeds(road: RoadParams, n_seeds: int) -> list[int]:
    """Seeds of the realisations: independent streams spawned from the road's own seed
    (``numpy.random.SeedSequence(seed).spawn``), so the same road gives the same
    realisations and another seed other ones."""
    if not (isinstance(n_seeds, int) and n_seeds >= 2):
        raise ParameterError(f"road intervals: n_seeds = {n_seeds!r} must be an integer >= 2")
    kids = np.random.SeedSequence(int(road.seed)).spawn(n_seeds)
    return [int(k.generate_state(1, dtype=np.uint32)[0]) for k in kids]


@dataclass
class RoadIntervals:
    """Metrics of a batch of designs on ``K`` road realisations.

    Attributes
    ----------
    samples : dict of ndarray (K, B)
        Every metric of :class:`~ehsa_opt.vehicle.simulate.QuarterCarSimulation` per
        realisation and design.
    seeds : list of int
    road : RoadParams
    stats : dict
        ``wall_s`` (all realisations), ``designs``, ``seeds``.
    """

    samples: dict[str, np.ndarray]
    seeds: list[int]
    road: RoadParams
    stats: dict[str, Any] = field(default_factory=dict)
    confidence: float = CONFIDENCE

    @property
    def n_designs(self) -> int:
        return int(next(iter(self.samples.values())).shape[1])

    def interval(self, key: str, b: int = 0) -> Interval:
        """Interval of metric ``key`` of design ``b`` over the realisations."""
        if key not in self.samples:
            raise KeyError(f"road intervals: no metric {key!r}; have {sorted(self.samples)}")
        return seed_interval(self.samples[key][:, b], self.confidence)

    def change(self, key: str, b: int, ref: int, kind: str = "relative") -> Interval:
        """Paired interval of design ``b`` against design ``ref`` on the same roads:
        ``"relative"`` 100 (x_b/x_ref − 1) %, ``"improvement"`` 100 (1 − x_b/x_ref) % (the
        paper's sign: positive = lower α or η_rh), ``"difference"`` x_b − x_ref."""
        x, r = self.samples[key][:, b], self.samples[key][:, ref]
        d = {"relative": lambda: 100.0 * (x / r - 1.0),
             "improvement": lambda: 100.0 * (1.0 - x / r),
             "difference": lambda: x - r}
        if kind not in d:
            raise ValueError(f"RoadIntervals.change: kind {kind!r}; use {', '.join(d)}")
        return seed_interval(d[kind](), self.confidence)

    def as_dict(self, keys: Sequence[str] | None = None) -> dict[str, list[dict]]:
        """Intervals per metric and design as plain data (for JSON results)."""
        keys = list(keys) if keys is not None else sorted(self.samples)
        out = {}
        for k in keys:
            rows = []
            for b in range(self.n_designs):
                col = self.samples[k][:, b]
                rows.append(self.interval(k, b).as_dict() if np.all(np.isfinite(col))
                            else None)
            out[k] = rows
        return out


def road_intervals(vehicle: VehicleParams,
                   harvesters: HarvesterParams | Sequence[HarvesterParams],
                   frictions: FrictionParams | Sequence[FrictionParams | None] | None,
                   road: RoadParams, *, n_seeds: int = DEFAULT_SEEDS, settle_s: float = 2.0,
                   sample_rate_hz: float = 1000.0,
                   identified_range_m_per_s: float | None = None,
                   sample_limits: Any = None, confidence: float = CONFIDENCE,
                   threads: int | None = None) -> RoadIntervals:
    """Simulate designs on ``n_seeds`` Gaussian realisations of ``road`` (see the module
    docstring) and keep every metric per realisation.

    Parameters
    ----------
    vehicle : VehicleParams
    harvesters, frictions
        As :func:`~ehsa_opt.vehicle.simulate.simulate_quarter_car` (None in a friction
        sequence: frictionless).
    road : RoadParams
        A synthesised ISO 8608 road (class, speed, length, seed); a measured profile has
        one realisation only: use :func:`batch_means_interval` on its series.
    n_seeds : int
        Realisations (≥ 2); the cost is ``n_seeds`` simulations of the batch.
    settle_s, sample_rate_hz, identified_range_m_per_s, sample_limits, threads
        Passed to the simulation.
    """
    from .road import dissipation_bound_W, synthesize_road
    from .simulate import simulate_quarter_car
    if road.profile_csv is not None:
        raise ParameterError("road intervals: the road is a measured profile (one realisation); "
                             "use batch_means_interval on its series, or give an ISO class")
    if isinstance(frictions, Sequence):
        frictions = [f if f is not None else FrictionParams() for f in frictions]
    seeds = realisation_seeds(road, n_seeds)
    t0 = time.perf_counter()
    per_seed: list[Mapping[str, np.ndarray]] = []
    for s in seeds:
        profile = synthesize_road(replace(road, seed=s), sample_rate_hz, amplitudes="gaussian")
        sim = simulate_quarter_car(vehicle, harvesters, frictions, profile, settle_s=settle_s,
                                   sample_rate_hz=sample_rate_hz, warn=False, threads=threads,
                                   identified_range_m_per_s=identified_range_m_per_s,
                                   sample_limits=sample_limits)
        if not sim.success:
            raise RuntimeError(f"road intervals: realisation seed {s}: {sim.message}")
        per_seed.append(sim.metrics)
    samples = {k: np.stack([np.asarray(m[k], dtype=float) for m in per_seed])
               for k in per_seed[0]}
    bound = dissipation_bound_W(vehicle, road)
    samples["dissipation_bound_W"] = np.full_like(samples["power_W"], bound)
    return RoadIntervals(samples, seeds, road,
                         {"wall_s": time.perf_counter() - t0,
                          "designs": int(samples["power_W"].shape[1]), "seeds": len(seeds)},
                         confidence)
