"""A second-order sensor low-pass H(s) = ω_c²/(s² + 2ζω_c s + ω_c²) applied to a sampled
signal: the force sensor's own dynamics (:mod:`.candidates.sensor_dynamics`, the data-driven
term's ``sensor`` group)."""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from .prepared import PreparedTest

__all__ = ["sensor_filter", "filtered_force", "sample_step_s"]


def sample_step_s(pt: PreparedTest) -> float:
    """The test's sample step, s (the median of its time steps)."""
    return float(np.median(np.diff(pt.time_s)))


def sensor_filter(f_c_hz: float, zeta: float, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The discrete (b, a) of H(s) = ω²/(s² + 2ζωs + ω²) at the step ``dt_s``: first-order
    hold (the recorded signal between samples is linear), exact for such a signal."""
    w = 2.0 * math.pi * f_c_hz
    b, a, _ = signal.cont2discrete(([w * w], [1.0, 2.0 * zeta * w, w * w]), dt_s,
                                   method="foh")
    b = np.atleast_1d(np.squeeze(b))
    return b / a[0], a / a[0]


def filtered_force(pt: PreparedTest, force: np.ndarray, f_c_hz: float, zeta: float
                   ) -> np.ndarray:
    """``force`` (N, on the test's samples) through the sensor, started at rest at its
    first value (the record starts in a steady state of the sensor)."""
    b, a = sensor_filter(f_c_hz, zeta, sample_step_s(pt))
    zi = signal.lfilter_zi(b, a) * force[0]
    return signal.lfilter(b, a, force, zi=zi)[0]
