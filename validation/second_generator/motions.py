"""Prescribed rod motions of the second generator: position, velocity and acceleration
in closed form, plus the instants where the acceleration jumps (for the integrator).

Every motion is an object with ``kinematics(t) -> (x_m, v_m_per_s, a_m_per_s2)``
(vectorised over ``t``), ``duration_s`` (the length of the record), ``preroll_s`` (time
simulated before the record starts, to settle the states) and ``breaks_s`` (instants in
``[-preroll_s, duration_s]`` where the acceleration is discontinuous).

* :class:`Sine` -- the classic damper test, recorded after whole settling cycles;
  declared ``excitation = "sine"``.
* :class:`VelocityProfile` -- piecewise-linear velocity (piecewise-constant
  acceleration), exactly integrated: :func:`triangle` (constant-velocity strokes with
  short constant-acceleration reversals, the usual friction test) and :func:`trapezoid`
  (ramps at constant velocity with dwells at both ends).  Starts and ends at rest.
* :class:`WindowedSines` -- a sum of sines under a smooth start/stop window (raised
  cosine ramps, so position, velocity and acceleration are continuous and start at 0):
  :func:`multisine` (flat velocity spectrum, random phases) and :func:`road_like`
  (many log-spaced components with the displacement amplitude falling as 1/f, the
  ISO 8608 slope of a road seen at a constant speed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Sine", "VelocityProfile", "WindowedSines", "triangle", "trapezoid", "multisine",
           "road_like"]


@dataclass(frozen=True)
class Sine:
    """x = A sin(2 pi f t); ``cycles`` recorded after ``settle_cycles`` simulated ones."""

    amplitude_m: float
    frequency_hz: float
    cycles: float = 1.0
    settle_cycles: int = 1
    kind: str = "sine"

    @property
    def duration_s(self) -> float:
        return self.cycles / self.frequency_hz

    @property
    def preroll_s(self) -> float:
        return self.settle_cycles / self.frequency_hz

    @property
    def breaks_s(self) -> tuple[float, ...]:
        return ()

    def kinematics(self, t):
        w = 2.0 * math.pi * self.frequency_hz
        t = np.asarray(t, dtype=float)
        s, c = np.sin(w * t), np.cos(w * t)
        return self.amplitude_m * s, self.amplitude_m * w * c, -self.amplitude_m * w * w * s


@dataclass(frozen=True)
class VelocityProfile:
    """Piecewise-linear velocity through the knots ``(t_s, v_m_per_s)``, from rest at x = 0.

    Position is the exact integral (quadratic between knots); acceleration is constant
    between knots.  The record is the whole profile (no preroll: it starts at rest)."""

    knots_t_s: tuple[float, ...]
    knots_v_m_per_s: tuple[float, ...]
    kind: str = "profile"
    _x0: tuple[float, ...] = field(init=False, repr=False, default=())

    def __post_init__(self) -> None:
        t, v = np.asarray(self.knots_t_s), np.asarray(self.knots_v_m_per_s)
        if t.size < 2 or np.any(np.diff(t) <= 0) or t[0] != 0.0:
            raise ValueError("VelocityProfile: knots must start at t = 0 and increase")
        x0 = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
        object.__setattr__(self, "_x0", tuple(x0))

    @property
    def duration_s(self) -> float:
        return float(self.knots_t_s[-1])

    @property
    def preroll_s(self) -> float:
        return 0.0

    @property
    def breaks_s(self) -> tuple[float, ...]:
        return tuple(self.knots_t_s[1:-1])

    def kinematics(self, t):
        tk, vk, xk = (np.asarray(a) for a in (self.knots_t_s, self.knots_v_m_per_s, self._x0))
        t = np.clip(np.asarray(t, dtype=float), tk[0], tk[-1])
        j = np.clip(np.searchsorted(tk, t, side="right") - 1, 0, tk.size - 2)
        acc = (vk[j + 1] - vk[j]) / (tk[j + 1] - tk[j])
        dt = t - tk[j]
        return xk[j] + vk[j] * dt + 0.5 * acc * dt * dt, vk[j] + acc * dt, acc


def triangle(amplitude_m: float, speed_m_per_s: float, cycles: int = 1,
             reversal_s: float = 0.04) -> VelocityProfile:
    """Constant-velocity strokes between about +-A: from rest at 0, accelerate to +V,
    cruise, reverse in ``reversal_s`` (constant acceleration 2V/reversal_s), ...,
    end at rest at 0.  Peak positions are exactly +-A."""
    V, tr, A = speed_m_per_s, reversal_s, amplitude_m
    if A <= V * tr / 2:
        raise ValueError("triangle: amplitude too small for the reversal time")
    t, v = [0.0, tr / 2], [0.0, V]
    t.append(t[-1] + (A - V * tr / 2) / V)
    v.append(V)
    sign = 1.0
    for k in range(2 * cycles):
        t.append(t[-1] + tr)
        v.append(-sign * V)
        last = k == 2 * cycles - 1
        cruise = (A - V * tr / 2) / V if last else (2 * A - V * tr / 2) / V
        t.append(t[-1] + cruise)
        v.append(-sign * V)
        sign = -sign
    t.append(t[-1] + tr / 2)
    v.append(0.0)
    return VelocityProfile(tuple(t), tuple(v), kind="triangle")


def trapezoid(amplitude_m: float, speed_m_per_s: float, dwell_s: float = 0.25,
              ramp_s: float = 0.03) -> VelocityProfile:
    """Displacement trapezoid: 0 -> +A, dwell, +A -> -A, dwell, -A -> 0, each move at a
    constant speed with constant-acceleration ramps of ``ramp_s``."""
    V, tr, A = speed_m_per_s, ramp_s, amplitude_m
    t, v = [0.0], [0.0]

    def move(dist: float, sgn: float) -> None:
        cruise = (dist - V * tr) / V
        if cruise <= 0:
            raise ValueError("trapezoid: amplitude too small for the ramps")
        t.extend([t[-1] + tr, t[-1] + tr + cruise, t[-1] + 2 * tr + cruise])
        v.extend([sgn * V, sgn * V, 0.0])

    move(A, 1.0)
    t.append(t[-1] + dwell_s)
    v.append(0.0)
    move(2 * A, -1.0)
    t.append(t[-1] + dwell_s)
    v.append(0.0)
    move(A, 1.0)
    return VelocityProfile(tuple(t), tuple(v), kind="trapezoid")


@dataclass(frozen=True)
class WindowedSines:
    """x = w(t) sum_k a_k sin(2 pi f_k t + phi_k), w a raised-cosine ramp of ``ramp_s``
    at both ends (C1 window, so x, v, a are continuous and start from rest)."""

    amplitudes_m: tuple[float, ...]
    frequencies_hz: tuple[float, ...]
    phases_rad: tuple[float, ...]
    record_s: float
    ramp_s: float = 0.4
    kind: str = "multisine"

    @property
    def duration_s(self) -> float:
        return self.record_s

    @property
    def preroll_s(self) -> float:
        return 0.0

    @property
    def breaks_s(self) -> tuple[float, ...]:
        return (self.ramp_s, self.record_s - self.ramp_s)

    def _window(self, t):
        T, r = self.record_s, self.ramp_s
        w, dw, ddw = np.ones_like(t), np.zeros_like(t), np.zeros_like(t)
        k = math.pi / r
        for mask, tau, sgn in ((t < r, t, 1.0), (t > T - r, T - t, -1.0)):
            tt = np.clip(tau[mask], 0.0, r)
            w[mask] = 0.5 * (1 - np.cos(k * tt))
            dw[mask] = sgn * 0.5 * k * np.sin(k * tt)
            ddw[mask] = 0.5 * k * k * np.cos(k * tt)
        return w, dw, ddw

    def kinematics(self, t):
        t = np.clip(np.asarray(t, dtype=float), 0.0, self.record_s)
        tt = np.atleast_1d(t)
        a = np.asarray(self.amplitudes_m)
        w = 2 * math.pi * np.asarray(self.frequencies_hz)
        arg = np.outer(tt, w) + np.asarray(self.phases_rad)
        sn, cs = np.sin(arg), np.cos(arg)
        s, ds, dds = sn @ a, cs @ (a * w), -(sn @ (a * w * w))
        win, dwin, ddwin = self._window(tt)
        x = win * s
        v = dwin * s + win * ds
        acc = ddwin * s + 2 * dwin * ds + win * dds
        if np.ndim(t) == 0:
            return float(x[0]), float(v[0]), float(acc[0])
        return x, v, acc


def _scaled(amps, freqs, rng, record_s, peak_m, kind) -> WindowedSines:
    phases = rng.uniform(0, 2 * math.pi, len(freqs))
    m = WindowedSines(tuple(amps), tuple(freqs), tuple(phases), record_s, kind=kind)
    x = m.kinematics(np.linspace(0, record_s, 4001))[0]
    g = peak_m / np.max(np.abs(x))
    return WindowedSines(tuple(g * np.asarray(amps)), tuple(freqs), tuple(phases), record_s,
                         kind=kind)


def multisine(peak_m: float, f_min_hz: float, f_max_hz: float, record_s: float,
              rng: np.random.Generator, n: int = 6) -> WindowedSines:
    """Multisine of ``n`` components spread over [f_min, f_max] with equal velocity
    amplitudes (displacement ~ 1/f) and random phases, scaled to the peak."""
    f = np.geomspace(f_min_hz, f_max_hz, n)
    return _scaled(1.0 / f, f, rng, record_s, peak_m, "multisine")


def road_like(peak_m: float, record_s: float, rng: np.random.Generator,
              f_min_hz: float = 0.3, f_max_hz: float = 6.0, n: int = 40) -> WindowedSines:
    """Road-like record: displacement PSD ~ f^-2 (amplitude ~ 1/f), many components
    with random phases and a random amplitude spread (Rayleigh), scaled to the peak."""
    f = np.geomspace(f_min_hz, f_max_hz, n)
    a = rng.rayleigh(1.0, n) / f * np.sqrt(np.gradient(f))
    return _scaled(a, f, rng, record_s, peak_m, "road")
