"""The tests as the discrepancy fits see them: each bench test with its motion on the
sample grid (the sine fitted to a sine test, the recorded motion's derivatives with their
resolved samples, or the measured motion through a zero-phase low-pass on a rig without
generator, whose force then goes through the same filter), its channels and noise levels.

:func:`prepare_tests` builds :class:`PreparedTest` records; :func:`noise_std` measures a
channel's noise; :func:`parallel_filter` and :func:`filtered_noise_gain` are the filter a
rig without generator shares between model and measurement, and its white-noise gain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Sequence

import numpy as np

from ...datasets.bench_format import BenchTest
from ...physics.motion import FilteredMotion, SineMotion
from ..identify_options import IdentifyOptions, estimate_motion

__all__ = ["NO_GENERATOR_FIXED", "PreparedTest", "prepare_tests", "noise_std",
           "parallel_filter", "filtered_noise_gain", "decimated", "decimation_factor"]

#: Values fixed on a rig without generator: no load, no (separable) bearing friction.
NO_GENERATOR_FIXED: dict[str, float] = {
    "load_ohm": 1.0, "bearing_breakaway_Nm": 0.0, "bearing_coulomb_Nm": 0.0,
    "bearing_breakaway_velocity_rad_per_s": 1.0, "bearing_viscous_Nms_per_rad": 0.0}


def parallel_filter(time_s: np.ndarray, y: np.ndarray, cutoff_hz: float, axis: int = -1
                    ) -> np.ndarray:
    """``y`` through the zero-phase 4th-order Butterworth low-pass that
    :class:`~ehsa_opt.physics.motion.FilteredMotion` applies to the displacement
    (along ``axis``)."""
    from scipy.signal import butter, filtfilt
    dt = float(np.median(np.diff(np.asarray(time_s, float))))
    b, a = butter(4, min(2.0 * cutoff_hz * dt, 0.99))
    return filtfilt(b, a, np.asarray(y, float), axis=axis)


def filtered_noise_gain(time_s: np.ndarray, cutoff_hz: float) -> float:
    """White-noise gain of :func:`parallel_filter` (std out / std in): the root sum of
    squares of its impulse response. The noise left in a filtered record is smooth, so it
    must be measured on the raw record and scaled by this gain."""
    n = 4001
    impulse = np.zeros(n)
    impulse[n // 2] = 1.0
    dt = float(np.median(np.diff(np.asarray(time_s, float))))
    h = parallel_filter(np.arange(n) * dt, impulse, cutoff_hz)
    return float(np.sqrt(np.sum(h ** 2)))


def noise_std(y: np.ndarray) -> float:
    """Noise level of a sampled signal from its second differences (robust, model-free).

    For white noise of std σ on a smooth signal, Δ²y has std √6 σ; the median
    absolute deviation makes it insensitive to short peaks.
    """
    d2 = np.diff(np.asarray(y, dtype=float), 2)
    mad = np.median(np.abs(d2 - np.median(d2)))
    return float(max(1.4826 * mad / math.sqrt(6.0), 1e-12))


@dataclass
class PreparedTest:
    """A test with its motion on the sample grid (``u`` = x, v, a) and noise levels."""

    test: BenchTest
    motion: Any
    time_s: np.ndarray
    u: np.ndarray
    y: np.ndarray  # (ny, N) measured force [, voltage]
    sigma: np.ndarray  # (ny,)
    fixed: dict[str, float]
    #: (N,) 1 where the motion's derivatives are resolved, 0 in windows around corners
    #: and dwells of recorded tests (left out of every objective and statistic)
    weight: np.ndarray | None = None
    #: rod-equivalent inertia the recorded motion's cut-off was chosen with (kg)
    mass_kg: float | None = None
    #: the measured force before parallel filtering (None when ``y`` is not filtered)
    raw_force_N: np.ndarray | None = None
    #: the filter's white-noise gain (std out / std in; 1 when ``y`` is not filtered)
    force_noise_gain: float = 1.0
    #: cut-off (Hz) of the parallel low-pass ``y`` went through, which the model's
    #: output goes through too (:meth:`filter_output`); None when ``y`` is not filtered
    output_filter_hz: float | None = None

    def __post_init__(self) -> None:
        if self.weight is None:
            self.weight = np.ones(self.time_s.size)

    @property
    def wnorm(self) -> np.ndarray:
        """(ny, N) weights of the residuals: resolved samples over the noise level."""
        return self.weight[None, :] / self.sigma[:, None]

    def filter_output(self, y: np.ndarray, axis: int = -1) -> np.ndarray:
        """A model output (or columns of one) through the parallel low-pass the measured
        ``y`` went through (unchanged when ``y`` is not filtered), along ``axis``: so
        model and measurement are compared consistently filtered."""
        if self.output_filter_hz is None:
            return np.asarray(y, float)
        return parallel_filter(self.time_s, y, self.output_filter_hz, axis=axis)

    @property
    def n_resolved(self) -> int:
        return int(np.count_nonzero(self.weight))


def _sine_motion(test: BenchTest) -> SineMotion:
    """The sine of the test's frequency fitted (amplitude, phase) to the measured x."""
    w = 2 * math.pi * float(test.frequency_hz)
    t = test.time_s
    A = np.column_stack([np.sin(w * t), np.cos(w * t)])
    (a, b), *_ = np.linalg.lstsq(A, test.displacement_m, rcond=None)
    return SineMotion(float(math.hypot(a, b)), float(test.frequency_hz), float(math.atan2(b, a)))


def prepare_tests(tests: Sequence[BenchTest], has_generator: bool = True,
                  derivative_cutoff_hz: float | None = None,
                  mass_kg: float | None = None) -> list[PreparedTest]:
    """Motion, measured outputs and noise levels of each test.

    Sine tests: the sine of the test frequency fitted to the measured
    displacement.  Recorded tests: the identification's motion estimate
    (:func:`~ehsa_opt.estimation.identify_options.estimate_motion`: smoothing spline,
    its cut-off from the noise and the rod-equivalent inertia ``mass_kg``, corner and dwell windows
    weighted out), or :class:`FilteredMotion` with cut-off ``derivative_cutoff_hz``
    when that is given or the rig has no generator (inverse-model practice, EMPS:
    a tenth of the sample rate by default).
    """
    out = []
    for t in tests:
        weight = None
        if t.excitation == "sine" and t.frequency_hz:
            motion: Any = _sine_motion(t)
        elif derivative_cutoff_hz is not None or not has_generator:
            fs = 1.0 / float(np.median(np.diff(t.time_s)))
            motion = FilteredMotion(t.time_s, t.displacement_m, derivative_cutoff_hz or fs / 10)
        else:
            est = estimate_motion(t, IdentifyOptions.for_rig(has_generator), mass_kg)
            motion, weight = est.motion, est.resolved.astype(float)
        u = motion.evaluate(t.time_s)
        ys = [t.force_N] + ([t.voltage_V] if has_generator and t.voltage_V is not None else [])
        y = np.vstack(ys)
        sig = np.array([noise_std(row) for row in y])
        if isinstance(motion, FilteredMotion) and not has_generator:
            # parallel filtering (the inverse-model practice the EMPS reference uses): the
            # force through the motion's own zero-phase low-pass, so that model and
            # measurement hold the same band; σ stays the raw force's noise level
            y = np.vstack([parallel_filter(t.time_s, row, motion.cutoff_hz) for row in y])
        raw, gain, fhz = None, 1.0, None
        if isinstance(motion, FilteredMotion) and not has_generator:
            raw, gain = ys[0], filtered_noise_gain(t.time_s, motion.cutoff_hz)
            fhz = float(motion.cutoff_hz)
        fixed = {"load_ohm": float(t.load_ohm)} if has_generator else dict(NO_GENERATOR_FIXED)
        out.append(PreparedTest(t, motion, t.time_s, u, y, sig, fixed, weight, mass_kg,
                                raw, gain, fhz))
    return out


def decimation_factor(prepared: Sequence[PreparedTest], max_samples: int | None) -> int:
    """The smallest integer step k that leaves at most ``max_samples`` samples in
    ``prepared`` when every k-th sample is kept (1: all; ``max_samples`` None: 1)."""
    n = sum(pt.time_s.size for pt in prepared)
    if max_samples is None or n <= max_samples:
        return 1
    return int(math.ceil(n / max_samples))


def decimated(pt: PreparedTest, k: int) -> PreparedTest:
    """``pt`` on every ``k``-th sample: the same motion (its derivatives are those of the
    full record, not re-estimated), the same noise levels and resolved-sample weights
    (the record itself is not filtered: the samples kept are measured samples)."""
    if k <= 1:
        return pt
    s = slice(None, None, k)
    t = pt.test
    nt = replace(t, time_s=t.time_s[s], displacement_m=t.displacement_m[s],
                 force_N=t.force_N[s],
                 voltage_V=t.voltage_V[s] if t.voltage_V is not None else None)
    return PreparedTest(nt, pt.motion, pt.time_s[s], pt.u[:, s], pt.y[:, s], pt.sigma,
                        pt.fixed, pt.weight[s], pt.mass_kg,
                        pt.raw_force_N[s] if pt.raw_force_N is not None else None,
                        pt.force_noise_gain)
