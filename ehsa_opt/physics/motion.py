"""Prescribed rod motions for bench simulation: a sine, or measured samples.

Each motion gives CasADi expressions of time for displacement (m), velocity
(m/s) and acceleration (m/s²), plus numpy evaluation for post-processing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from scipy.interpolate import make_smoothing_spline

__all__ = ["SineMotion", "SampledMotion", "FilteredMotion"]


@dataclass(frozen=True)
class SineMotion:
    """x(t) = A sin(2π f t + φ).

    Attributes
    ----------
    amplitude_m : float
        A, m (> 0).
    frequency_hz : float
        f, Hz (> 0).
    phase_rad : float
        φ, rad.
    """

    amplitude_m: float
    frequency_hz: float
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        if not (self.amplitude_m > 0 and math.isfinite(self.amplitude_m)):
            raise ValueError(f"SineMotion: amplitude_m must be > 0 m, got {self.amplitude_m}")
        if not (self.frequency_hz > 0 and math.isfinite(self.frequency_hz)):
            raise ValueError(f"SineMotion: frequency_hz must be > 0 Hz, got {self.frequency_hz}")

    @property
    def omega_rad_s(self) -> float:
        return 2.0 * math.pi * self.frequency_hz

    def expressions(self, t: Any) -> tuple[Any, Any, Any]:
        w, A, ph = self.omega_rad_s, self.amplitude_m, self.phase_rad
        sin_fn = ca.sin if isinstance(t, (ca.SX, ca.MX)) else np.sin
        cos_fn = ca.cos if isinstance(t, (ca.SX, ca.MX)) else np.cos
        return (A * sin_fn(w * t + ph), A * w * cos_fn(w * t + ph),
                -A * w * w * sin_fn(w * t + ph))

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Array (3, len(t)) of x, v, a."""
        t = np.asarray(t, dtype=float)
        return np.vstack(self.expressions(t))


@dataclass(frozen=True)
class SampledMotion:
    """Measured displacement samples, differentiated by a smoothing spline.

    Attributes
    ----------
    time_s, displacement_m : ndarray
        Samples (time strictly increasing).
    smoothing : float or None
        ``lam`` of :func:`scipy.interpolate.make_smoothing_spline`; None picks
        it by generalised cross-validation.
    """

    time_s: np.ndarray
    displacement_m: np.ndarray
    smoothing: float | None = None
    _spline: Any = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.time_s, dtype=float)
        x = np.asarray(self.displacement_m, dtype=float)
        if t.shape != x.shape or t.ndim != 1 or t.size < 5:
            raise ValueError("SampledMotion: time_s and displacement_m must be 1-D, same length "
                             ">= 5")
        if np.any(np.diff(t) <= 0):
            raise ValueError("SampledMotion: time_s must be strictly increasing")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "displacement_m", x)
        object.__setattr__(self, "_spline", make_smoothing_spline(t, x, lam=self.smoothing))

    @classmethod
    def with_cutoff(cls, time_s: np.ndarray, displacement_m: np.ndarray,
                    cutoff_hz: float) -> "SampledMotion":
        """Smoothing spline whose penalty acts like a low-pass at ``cutoff_hz`` (Hz):
        lam = 1 / (dt (2π f_c)⁴), dt the mean sample step (GCV tends to over-smooth
        the acceleration of long measured records)."""
        if not cutoff_hz > 0:
            raise ValueError(f"SampledMotion.with_cutoff: cutoff_hz must be > 0 Hz, got {cutoff_hz}")
        dt = float(np.mean(np.diff(np.asarray(time_s, dtype=float))))
        return cls(time_s, displacement_m, 1.0 / (dt * (2.0 * math.pi * cutoff_hz) ** 4))

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Array (3, len(t)) of x, v, a from the smoothing spline."""
        t = np.asarray(t, dtype=float)
        sp = self._spline
        return np.vstack([sp(t), sp.derivative(1)(t), sp.derivative(2)(t)])

    def expressions(self, t: Any) -> tuple[Any, Any, Any]:
        """CasADi (MX) linear interpolants of x, v, a on the sample grid."""
        xva = self.evaluate(self.time_s)
        grid = [self.time_s.tolist()]
        return tuple(ca.interpolant(f"motion_{k}", "linear", grid, xva[k].tolist())(t)
                     for k in range(3))


class FilteredMotion:
    """Recorded motion differentiated the way inverse-model identification does it
    (EMPS reference): zero-phase 4th-order Butterworth low-pass, then central
    differences.  A CVODES simulation needs a continuous motion: :meth:`sampled`
    gives a :class:`SampledMotion` through the filtered samples."""

    def __init__(self, time_s: np.ndarray, displacement_m: np.ndarray, cutoff_hz: float) -> None:
        from scipy.signal import butter, filtfilt
        t = np.asarray(time_s, float)
        dt = float(np.median(np.diff(t)))
        wn = min(2.0 * cutoff_hz * dt, 0.99)
        b, a = butter(4, wn)
        x = filtfilt(b, a, np.asarray(displacement_m, float))
        v = np.gradient(x, t)
        self.time_s, self.u = t, np.vstack([x, v, np.gradient(v, t)])
        self.cutoff_hz = cutoff_hz

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Array (3, len(t)) of x, v, a, linearly interpolated between samples."""
        return np.vstack([np.interp(t, self.time_s, row) for row in self.u])

    def sampled(self) -> SampledMotion:
        return SampledMotion(self.time_s, self.u[0], smoothing=1e-12)
