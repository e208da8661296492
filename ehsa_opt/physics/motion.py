"""Prescribed rod motions for bench simulation: a sine, protocols given in closed form
(piecewise-constant acceleration: triangle / constant-velocity strokes, trapezoids;
sums of sines: multisines, road-like records), or measured samples.

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

__all__ = ["SineMotion", "PiecewiseMotion", "MultisineMotion", "SampledMotion",
           "FilteredMotion"]


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


def _is_symbolic(t: Any) -> bool:
    return isinstance(t, (ca.SX, ca.MX))


@dataclass(frozen=True)
class PiecewiseMotion:
    """A motion of piecewise-constant acceleration (exact, in closed form).

    On ``[knots_s[k], knots_s[k+1])`` the acceleration is ``acceleration_m_per_s2[k]``;
    before the first knot it is 0 (the motion continues at its initial velocity), after
    the last knot it keeps the last value.  Velocity is continuous and piecewise linear,
    displacement continuous and piecewise quadratic: constant-velocity strokes with
    blended corners (the acceleration steps at the corners are the only non-smooth
    points).  Written as a sum of ramps so CasADi can evaluate it::

        a(t) = Σ Δa_k H(t − t_k),   v(t) = v_0 + Σ Δa_k (t − t_k)₊,
        x(t) = x_0 + v_0 (t − t_0) + Σ Δa_k (t − t_k)₊² / 2

    Attributes
    ----------
    knots_s : ndarray (K + 1,)
        Strictly increasing knot times, s.
    acceleration_m_per_s2 : ndarray (K,)
        Acceleration on each segment, m/s².
    x0_m, v0_m_per_s : float
        Displacement and velocity at ``knots_s[0]``.
    """

    knots_s: np.ndarray
    acceleration_m_per_s2: np.ndarray
    x0_m: float = 0.0
    v0_m_per_s: float = 0.0

    def __post_init__(self) -> None:
        t = np.asarray(self.knots_s, dtype=float)
        a = np.asarray(self.acceleration_m_per_s2, dtype=float)
        if t.ndim != 1 or a.ndim != 1 or t.size != a.size + 1 or a.size < 1:
            raise ValueError("PiecewiseMotion: knots_s needs one more entry than "
                             "acceleration_m_per_s2 (>= 1 segment)")
        if np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)) or not np.all(np.isfinite(a)):
            raise ValueError("PiecewiseMotion: knots_s must be finite and strictly increasing, "
                             "accelerations finite")
        object.__setattr__(self, "knots_s", t)
        object.__setattr__(self, "acceleration_m_per_s2", a)

    @property
    def max_step_s(self) -> float:
        """Half the shortest segment, s: an integrator step never jumps over a corner."""
        return 0.5 * float(np.min(np.diff(self.knots_s)))

    @property
    def corners_s(self) -> np.ndarray:
        """Times where the acceleration steps (the motion's non-smooth points), s."""
        jumps = np.diff(np.concatenate([[0.0], self.acceleration_m_per_s2]))
        return self.knots_s[:-1][jumps != 0.0]

    def expressions(self, t: Any) -> tuple[Any, Any, Any]:
        tk = self.knots_s[:-1]
        da = np.diff(np.concatenate([[0.0], self.acceleration_m_per_s2]))
        t0, x0, v0 = float(self.knots_s[0]), float(self.x0_m), float(self.v0_m_per_s)
        if _is_symbolic(t):
            x, v, a = x0 + v0 * (t - t0), v0 + 0.0 * t, 0.0 * t
            for tj, dj in zip(tk.tolist(), da.tolist()):
                if dj == 0.0:
                    continue
                s = ca.fmax(t - tj, 0.0)
                x, v, a = x + 0.5 * dj * s * s, v + dj * s, a + dj * ca.if_else(t >= tj, 1, 0)
            return x, v, a
        t = np.asarray(t, dtype=float)
        # exact per segment (no cancellation of large ramps)
        k = np.clip(np.searchsorted(self.knots_s, t, side="right") - 1, -1, tk.size - 1)
        acc = self.acceleration_m_per_s2
        h = np.diff(self.knots_s)
        vk = v0 + np.concatenate([[0.0], np.cumsum(acc * h)])
        xk = x0 + np.concatenate([[0.0], np.cumsum(vk[:-1] * h + 0.5 * acc * h * h)])
        kk = np.maximum(k, 0)
        ak = np.where(k >= 0, acc[kk], 0.0)
        tb = np.where(k >= 0, self.knots_s[kk], t0)
        xb = np.where(k >= 0, xk[kk], x0)
        vb = np.where(k >= 0, vk[kk], v0)
        s = t - tb
        return xb + vb * s + 0.5 * ak * s * s, vb + ak * s, ak + 0.0 * s

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Array (3, len(t)) of x, v, a."""
        return np.vstack(self.expressions(np.asarray(t, dtype=float)))


@dataclass(frozen=True)
class MultisineMotion:
    """x(t) = Σ_k A_k sin(2π f_k t + φ_k) (exact, in closed form).

    Attributes
    ----------
    amplitudes_m, frequencies_hz, phases_rad : ndarray
        One entry per component (amplitudes > 0 m, frequencies > 0 Hz).
    """

    amplitudes_m: np.ndarray
    frequencies_hz: np.ndarray
    phases_rad: np.ndarray

    def __post_init__(self) -> None:
        A, f, ph = (np.atleast_1d(np.asarray(v, dtype=float)) for v in
                    (self.amplitudes_m, self.frequencies_hz, self.phases_rad))
        if not (A.shape == f.shape == ph.shape and A.ndim == 1 and A.size >= 1):
            raise ValueError("MultisineMotion: amplitudes_m, frequencies_hz, phases_rad must be "
                             "1-D of the same length >= 1")
        if np.any(~(A > 0)) or np.any(~(f > 0)) or not np.all(np.isfinite(ph)):
            raise ValueError("MultisineMotion: amplitudes_m and frequencies_hz must be > 0, "
                             "phases finite")
        for name, v in (("amplitudes_m", A), ("frequencies_hz", f), ("phases_rad", ph)):
            object.__setattr__(self, name, v)

    @property
    def max_step_s(self) -> float:
        """A twentieth of the shortest period, s."""
        return 0.05 / float(np.max(self.frequencies_hz))

    def expressions(self, t: Any) -> tuple[Any, Any, Any]:
        sym = _is_symbolic(t)
        x = v = a = 0.0 * t
        for A, f, ph in zip(self.amplitudes_m.tolist(), self.frequencies_hz.tolist(),
                            self.phases_rad.tolist()):
            w = 2.0 * math.pi * f
            s = ca.sin(w * t + ph) if sym else np.sin(w * t + ph)
            c = ca.cos(w * t + ph) if sym else np.cos(w * t + ph)
            x, v, a = x + A * s, v + A * w * c, a - A * w * w * s
        return x, v, a

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Array (3, len(t)) of x, v, a."""
        return np.vstack(self.expressions(np.asarray(t, dtype=float)))


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

    @property
    def max_step_s(self) -> float:
        """The shortest sample step, s (a simulation step never spans two sample
        intervals; the spline's acceleration has a corner at every sample)."""
        return float(np.min(np.diff(self.time_s)))

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Array (3, len(t)) of x, v, a from the smoothing spline."""
        t = np.asarray(t, dtype=float)
        sp = self._spline
        return np.vstack([sp(t), sp.derivative(1)(t), sp.derivative(2)(t)])

    def expressions(self, t: Any) -> tuple[Any, Any, Any]:
        """CasADi (MX) expressions of x, v, a: the smoothing spline itself (a cubic
        B-spline on the samples, as :meth:`evaluate`) and its first two derivatives,
        so v is exactly dx/dt, x is C², v C¹ and a C⁰ (piecewise linear).

        Linear interpolants of the sampled x, v, a (the representation before) put a
        corner into v and a jump into dv/dt at every sample: a variable-order
        integrator then fails its error test and restarts at low order sample after
        sample (a 3 001-sample multisine: ten times a sine test's CVODES cost), and a
        stiff contact is struck by a small acceleration step at every sample."""
        sp = self._spline
        out = []
        for d in (sp, sp.derivative(1), sp.derivative(2)):
            knots = np.asarray(d.t, dtype=float)
            coef = np.asarray(d.c, dtype=float)[:knots.size - d.k - 1]  # scipy may pad
            out.append(ca.bspline(t, ca.DM(coef), [knots.tolist()], [int(d.k)], 1, {}))
        return tuple(out)


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
