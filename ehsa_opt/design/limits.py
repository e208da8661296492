"""Hardware limits of a design, per sample: the fraction of time each limit is exceeded,
the constraint the optimiser sees, and the sentence that explains a violation.

A limit is either

* **hard** (a maximum the hardware must not pass: motor speed, screw speed, peak current,
  stroke, tyre lift), met when the fraction of time beyond it is at most
  :attr:`LimitSettings.time_fraction`;
* **thermal** (the winding's continuous current): the rms current at most the rated
  continuous current (heating follows the mean square, not the peaks);
* **peak** (the terminal voltage): the largest |V| over the simulated road, an
  extreme-value statistic, at most the motor's maximum voltage with probability
  :attr:`LimitSettings.peak_quantile`;
* **fatigue** (the ball screw's nominal life, ISO 3408-5): the cubic mean axial load F_m
  at most the load whose L10 life equals the revolutions the screw turns over
  :attr:`LimitSettings.screw_life_km` driven on the design road
  (:func:`~ehsa_opt.physics.ball_screw.allowable_mean_load`).

The screw's axial load is the whole damper force through the nut, the inertia's and the
generator's: F = m_eq a + (k_t / r) i (m_eq = J_t / r², a the stroke acceleration).  On the
frequency path F_m³ = E[|F|³ |v|] / E|v| is bounded by Hölder's inequality with Gaussian
moments, E[|F|³ |v|] ≤ (E F⁴)^¾ (E v⁴)^¼ = 3 σ_F³ σ_v and E|v| = √(2/π) σ_v, so
F_m ≤ (3 / √(2/π))^⅓ σ_F = 1.555 σ_F, with σ_F ≤ m_eq σ_a + (k_t / r) σ_i (the two
parts' correlation unknown there); the bound is exact for a force in phase with the
velocity (the generator's damping) and at most 33 % high (a force independent of it,
F_m = 1.168 σ_F), i.e. conservative.  A time-domain check sums the samples instead.

On the frequency path every response is a stationary Gaussian process (linear model,
Gaussian road), so the fraction of time |x| > L is erfc(L / (σ √2)) exactly, and the
maximum of |x| over a road of duration T follows Rice's formula: level ±u is crossed
upwards 2 ν₀ e^{−u²/2σ²} times per second (ν₀ = σ_ẋ / (2π σ)), so
P(max ≤ u) = exp(−2 ν₀ T e^{−u²/2σ²}) and its q-quantile is
u_q = σ √(2 ln(2 ν₀ T / (−ln q))).  A time-domain check counts samples instead.

Every constraint is reported as ``constraint_<name>`` = value / limit − 1 (≤ 0 feasible),
with ``value_<name>`` (the statistic compared, in the limit's unit), ``limit_<name>`` and
``fraction_<name>`` (fraction of time beyond the limit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.special import erfc
from scipy.stats import norm

from ..physics.params import ParameterError
from ..vehicle.validity import EXCEEDANCE_FRACTION_LIMIT, TYRE_LIFT_FRACTION_LIMIT

__all__ = ["LimitSettings", "LIMIT_MEANINGS", "gaussian_fraction_beyond", "rice_peak_quantile",
           "limit_entry", "explain_violations", "active_bounds", "sample_fractions",
           "GAUSSIAN_CUBIC_MEAN_FACTOR", "revolution_weighted_mean_load"]

#: F_m ≤ this × σ_F for a Gaussian axial load (see module): (3 / √(2/π))^(1/3).
GAUSSIAN_CUBIC_MEAN_FACTOR = (3.0 / math.sqrt(2.0 / math.pi)) ** (1.0 / 3.0)

#: What each limit is, its unit and how it is compared (for reports and messages).
LIMIT_MEANINGS: dict[str, tuple[str, str, str]] = {
    "rated_current": ("rms current vs the rated continuous (thermal) current", "A", "thermal"),
    "peak_current": ("current vs the motor's short-term current", "A", "hard"),
    "rated_voltage": ("peak terminal voltage on the road vs the motor's maximum voltage", "V",
                      "peak"),
    "rated_power": ("mean electrical power (load + winding) vs the rated power", "W", "thermal"),
    "motor_speed": ("motor speed vs its maximum permissible speed", "rpm", "hard"),
    "screw_speed": ("screw speed vs min(DN / d0, 0.8 critical speed)", "rpm", "hard"),
    "stroke": ("stroke |x2 − x1| vs the suspension's stroke limit", "m", "hard"),
    "tyre_lift": ("dynamic tyre load vs the static load (tyre leaves the road)", "-", "hard"),
    "screw_life": ("cubic mean axial load on the screw vs the load of an L10 life of the "
                   "required distance", "N", "fatigue"),
    "motor_inertia": ("rotor + screw inertia vs the design's total inertia J_t", "g cm²",
                      "geometric"),
}


@dataclass(frozen=True)
class LimitSettings:
    """The stated tolerances of the hardware limits (``[limits]`` of a problem file).

    Attributes
    ----------
    time_fraction : float
        Largest fraction of time a hard limit may be exceeded.  Default
        :data:`~ehsa_opt.vehicle.validity.EXCEEDANCE_FRACTION_LIMIT` (4.65e-4, the share a
        Gaussian response spends beyond ±3.5 σ): the standard the vehicle studies' validity
        holds every hardware limit to, so a design and a study row are judged alike.
    peak_quantile : float
        Probability with which the largest terminal voltage over the road stays below the
        motor's maximum voltage.  Default 0.95 **(assumption)**: the one-sided 95 % of a
        design check.
    tyre_lift_fraction : float
        Largest fraction of time the dynamic tyre load may exceed the static load (the
        tyre leaves the road).  Default
        :data:`~ehsa_opt.vehicle.validity.TYRE_LIFT_FRACTION_LIMIT` (0.135 %: the classic
        road-holding criterion, rms dynamic load ≤ 1/3 of the static load, for a Gaussian
        wheel load), the same standard as the vehicle studies' validity.  The prototype
        does not meet it on the design road (η_rh = 0.44: lift about 1.2 % of the time).
    screw_life_km : float
        Distance driven on the design road the ball screw must survive (its L10 nominal
        life, 90 % of screws).  Default 160 000 km **(assumption)**: a common automotive
        durability target (100 000 miles); driven entirely on the design road, which is
        rougher than most roads, so conservative.
    """

    time_fraction: float = EXCEEDANCE_FRACTION_LIMIT
    peak_quantile: float = 0.95
    tyre_lift_fraction: float = TYRE_LIFT_FRACTION_LIMIT
    screw_life_km: float = 160000.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.screw_life_km) and self.screw_life_km > 0.0):
            raise ParameterError(f"[limits] screw_life_km = {self.screw_life_km!r} must be a "
                                 "positive distance in km, e.g. 160000")
        if not (0.0 < self.time_fraction < 0.5):
            raise ParameterError(f"[limits] time_fraction = {self.time_fraction!r} must be in "
                                 "(0, 0.5), e.g. 0.001 (0.1 % of the time)")
        if not (0.0 < self.tyre_lift_fraction < 0.5):
            raise ParameterError(f"[limits] tyre_lift_fraction = {self.tyre_lift_fraction!r} "
                                 "must be in (0, 0.5), e.g. 0.01")
        if not (0.5 <= self.peak_quantile < 1.0):
            raise ParameterError(f"[limits] peak_quantile = {self.peak_quantile!r} must be in "
                                 "[0.5, 1), e.g. 0.95")

    @property
    def z_two_sided(self) -> float:
        """|x| > z σ for ``time_fraction`` of the time (Gaussian)."""
        return float(norm.isf(0.5 * self.time_fraction))

    @property
    def z_tyre_lift(self) -> float:
        """x > z σ for ``tyre_lift_fraction`` of the time (Gaussian, one-sided)."""
        return float(norm.isf(self.tyre_lift_fraction))

    def as_dict(self) -> dict[str, float]:
        return {"time_fraction": self.time_fraction, "peak_quantile": self.peak_quantile,
                "tyre_lift_fraction": self.tyre_lift_fraction,
                "screw_life_km": self.screw_life_km}


def gaussian_fraction_beyond(limit: Any, sigma: Any, two_sided: bool = True) -> np.ndarray:
    """Fraction of time a zero-mean Gaussian process of rms ``sigma`` spends beyond
    ``limit`` (|x| > limit, or x > limit one-sided)."""
    limit, sigma = np.asarray(limit, float), np.asarray(sigma, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(sigma > 0, limit / np.where(sigma > 0, sigma, 1.0), np.inf)
    f = erfc(r / math.sqrt(2.0))
    return f if two_sided else 0.5 * f


def rice_peak_quantile(sigma: Any, sigma_rate: Any, duration_s: float, q: Any) -> np.ndarray:
    """q-quantile of max |x| over ``duration_s`` of a stationary Gaussian process with rms
    ``sigma`` and rms derivative ``sigma_rate`` (Rice's upcrossing rate; see module).  Where
    fewer than one crossing of ±σ is expected the quantile is taken as σ √(2 ln 2)."""
    sigma, rate = np.asarray(sigma, float), np.asarray(sigma_rate, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        nu0 = np.where(sigma > 0, rate / (2.0 * math.pi * np.where(sigma > 0, sigma, 1.0)), 0.0)
    n = 2.0 * nu0 * float(duration_s) / (-np.log(np.asarray(q, float)))
    return sigma * np.sqrt(2.0 * np.log(np.maximum(n, 2.0)))


def limit_entry(name: str, value: Any, limit: Any, fraction: Any) -> dict[str, np.ndarray]:
    """The four outputs of one limit (see module): value, limit, fraction, constraint."""
    value, limit = np.asarray(value, float), np.asarray(limit, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        con = np.where(np.isfinite(limit), value / limit - 1.0, -1.0)
    return {f"value_{name}": value, f"limit_{name}": limit,
            f"fraction_{name}": np.asarray(fraction, float), f"constraint_{name}": con}


def sample_fractions(series: Mapping[str, np.ndarray], limits: Mapping[str, Any]
                     ) -> dict[str, np.ndarray]:
    """Fractions of samples beyond each limit from time series (rows = designs): ``series``
    maps a limit name to |signal| samples (the tyre lift's to the dynamic/static load
    ratio, one-sided), ``limits`` to the per-design limit."""
    out = {}
    for name, sig in series.items():
        lim = np.asarray(limits[name], float).reshape(-1, 1)
        out[name] = np.mean(np.abs(sig) > lim, axis=1)
    return out


def revolution_weighted_mean_load(force: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """Cubic mean load weighted by revolutions, (Σ |F|³ |ω| / Σ |ω|)^(1/3), per row of
    sampled axial force ``force`` and screw speed ``speed`` (same shape)."""
    w = np.abs(np.asarray(speed, float))
    num = np.sum(np.abs(np.asarray(force, float)) ** 3 * w, axis=-1)
    den = np.sum(w, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.cbrt(np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0))


def explain_violations(outputs: Mapping[str, Any], names: Sequence[str], index: int = 0,
                       tol: float = 1e-6) -> list[str]:
    """One sentence per violated limit of design ``index``: what, value, limit, margin and
    the fraction of time beyond it."""
    out = []
    for c in names:
        con = np.ravel(outputs.get(f"constraint_{c}", [np.nan]))
        g = float(con[index if con.size > 1 else 0])
        if not g > tol:
            continue
        what, unit, kind = LIMIT_MEANINGS.get(c, (c, "", "hard"))

        def at(key: str) -> float:
            a = np.ravel(outputs.get(key, [np.nan]))
            return float(a[index if a.size > 1 else 0])
        v, lim, frac = at(f"value_{c}"), at(f"limit_{c}"), at(f"fraction_{c}")
        if math.isfinite(v) and math.isfinite(lim):
            text = f"{c}: {what}: {v:.4g} {unit} against {lim:.4g} {unit} ({100 * g:+.1f} %)"
        else:
            text = f"{c}: {what}: {100 * g:+.1f} % beyond the limit"
        if math.isfinite(frac) and kind not in ("geometric", "fatigue"):
            text += f", beyond it {100 * frac:.3g} % of the time"
        out.append(text)
    return out


def active_bounds(space: Any, design: Mapping[str, float], tol: float = 1e-3) -> list[str]:
    """The design variables at (within ``tol`` of the unit interval) a bound of ``space``,
    as ``"name at lower bound 1"``; integer (catalogue) variables are never at a bound."""
    u = np.ravel(space.to_unit({k: np.asarray(design[k], float) for k in space.names}))
    integer = getattr(space, "integer", ()) or (False,) * space.n
    out = []
    for k, (name, lo, hi) in enumerate(zip(space.names, space.lower, space.upper)):
        if integer[k]:
            continue
        if u[k] <= tol:
            out.append(f"{name} at its lower bound {lo:g}")
        elif u[k] >= 1.0 - tol:
            out.append(f"{name} at its upper bound {hi:g}")
    return out
