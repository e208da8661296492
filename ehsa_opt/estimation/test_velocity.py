"""The rod velocities a bench test covers: where its data determine the friction.

A sine test x = A sin(2π f t) reaches every speed from 0 to its peak 2π f A.  A recorded
motion (constant-velocity strokes, trapezoids, multisines, road-like records) reaches the
speeds of its resolved samples only: a constant-velocity stroke says nothing about the
friction between its plateau speed and zero, which it crosses only inside the reversal
windows that the fits weight out.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["test_peak_velocity_m_per_s", "test_velocity_range_m_per_s"]


def test_peak_velocity_m_per_s(test: Any) -> float:
    """Peak rod velocity of a bench test: 2π f A for a sine test, else the 99th
    percentile of |v| of a smoothing spline through the measured displacement."""
    if getattr(test, "excitation", "sine") == "sine" and test.frequency_hz and test.amplitude_m:
        return 2.0 * math.pi * float(test.frequency_hz) * float(test.amplitude_m)
    import hashlib
    t = np.ascontiguousarray(test.time_s, dtype=float)
    x = np.ascontiguousarray(test.displacement_m, dtype=float)
    h = hashlib.blake2b(digest_size=16)
    for a in (t, x):
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    key = h.hexdigest()
    if key not in _PEAKS:
        from ..physics.motion import SampledMotion
        step = max(1, t.size // 2000)
        motion = SampledMotion(t[::step], x[::step])
        v = motion.evaluate(t[::step])[1]
        _PEAKS[key] = float(np.percentile(np.abs(v), 99.0))
        while len(_PEAKS) > PEAK_CACHE_SIZE:
            _PEAKS.pop(next(iter(_PEAKS)))
    return _PEAKS[key]


#: Peak velocities of recorded tests kept in this process, by a digest of the samples
#: (the report and the friction bounds ask for the same record's again; its smoothing
#: spline costs 0.6 s on a 25 000-sample record).
PEAK_CACHE_SIZE = 64
_PEAKS: dict[str, float] = {}


def test_velocity_range_m_per_s(test: Any, mass_kg: float | None = None
                                ) -> tuple[float, float]:
    """Rod speeds at which a test's data determine the friction, m/s: (0, peak) for a
    sine test; for a recorded test the 1st–99th percentile of |v| over the samples the
    fit used (outside the corner and dwell windows of
    :func:`~ehsa_opt.estimation.identify_options.estimate_motion`) — a constant-velocity
    stroke says nothing about the friction between its plateau speed and zero, which it
    crosses only inside the reversal windows."""
    if getattr(test, "excitation", "sine") == "sine" and test.frequency_hz and test.amplitude_m:
        return 0.0, test_peak_velocity_m_per_s(test)
    from .identify_options import estimate_motion
    est = estimate_motion(test, None, mass_kg)
    v = np.abs(est.motion.evaluate(test.time_s)[1])[est.resolved]
    if v.size < 10:
        return math.nan, math.nan  # nothing resolved: the test bounds nothing
    return float(np.percentile(v, 1.0)), float(np.percentile(v, 99.0))
