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

__all__ = ["SineMotion", "SampledMotion"]


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
