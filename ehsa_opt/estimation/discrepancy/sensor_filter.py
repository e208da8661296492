"""A second-order sensor low-pass H(s) = ω_c²/(s² + 2ζω_c s + ω_c²) applied to a sampled
signal: the force sensor's own dynamics (:mod:`.candidates.sensor_dynamics`, the data-driven
term's ``sensor`` group)."""

from __future__ import annotations

import math

from typing import Sequence

import numpy as np
from scipy import signal
from scipy.optimize import least_squares

from .channels import channel_effective_samples
from .prepared import PreparedTest

__all__ = ["sensor_filter", "filtered_force", "filtered_channel", "fit_sensor", "sample_step_s",
           "MAX_BANDWIDTH_SHARE", "MIN_BANDWIDTH_HZ", "DAMPING_RANGE"]


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


#: The highest bandwidth fitted, as a share of the sample rate: 0.4 f_s (below the
#: Nyquist frequency, where the discrete filter still follows the continuous one).
MAX_BANDWIDTH_SHARE = 0.4
#: The lowest bandwidth fitted, Hz: a force sensor slower than this would not pass the
#: test frequencies of a damper bench (0.5–20 Hz).
MIN_BANDWIDTH_HZ = 5.0
#: Damping ratios fitted: from a lightly damped load cell (0.05) to an overdamped
#: conditioning filter (2).
DAMPING_RANGE = (0.05, 2.0)
#: The grid the least-squares fit starts from (f_c as a share of the highest bandwidth;
#: ζ): the bandwidth over its decades, damping light to critical.
_START_SHARES = (0.05, 0.15, 0.4, 1.0)
_START_DAMPING = (0.2, 0.7, 1.0)


def filtered_channel(pts, preds, f_c, zeta, ch: int = 0) -> list[np.ndarray]:
    """Copies of ``preds`` with channel ``ch`` through the sensor (f_c Hz, ζ)."""
    out = []
    for pt, yp in zip(pts, preds):
        q = np.array(yp, float, copy=True)
        q[ch] = filtered_force(pt, yp[ch], f_c, zeta)
        out.append(q)
    return out


def _residuals(theta: np.ndarray, pts, preds, ch: int = 0) -> np.ndarray:
    f_c, zeta = 10.0 ** theta[0], theta[1]
    return np.concatenate([(pt.y[ch] - filtered_force(pt, yp[ch], f_c, zeta)) * pt.wnorm[ch]
                           for pt, yp in zip(pts, preds)])


def fit_sensor(pts: Sequence[PreparedTest], preds: Sequence[np.ndarray], ch: int = 0,
               start: tuple[float, float] | None = None) -> dict:
    """f_c (Hz) and ζ of the sensor that best explain the record of channel ``ch`` (0
    force, 1 voltage) of ``pts`` from the model's ``preds`` (see the module docstring),
    with ~95 % intervals (Gauss–Newton covariance, the residual variance per effective
    sample of the channel's residual, :func:`~.channels.channel_effective_samples`);
    started from ``start`` (f_c Hz, ζ) or from the best of a grid.

    Returns
    -------
    dict
        ``f_c_hz``, ``zeta``, ``intervals`` (name → (low, high)), ``sse`` and
        ``f_max_hz`` (the highest bandwidth fitted).
    """
    f_max = MAX_BANDWIDTH_SHARE / sample_step_s(pts[0])
    lo = np.array([math.log10(MIN_BANDWIDTH_HZ), DAMPING_RANGE[0]])
    hi = np.array([math.log10(f_max), DAMPING_RANGE[1]])
    starts = ([np.array([math.log10(start[0]), start[1]])] if start is not None else
              [np.array([math.log10(max(s * f_max, MIN_BANDWIDTH_HZ)), z])
               for s in _START_SHARES for z in _START_DAMPING])
    cost = [float(np.sum(_residuals(th, pts, preds, ch) ** 2)) for th in starts]
    th0 = np.clip(starts[int(np.argmin(cost))], lo, hi)
    sol = least_squares(_residuals, th0, bounds=(lo, hi), args=(pts, preds, ch),
                        x_scale=np.array([0.3, 0.2]))
    r, J = sol.fun, sol.jac
    lf, z = float(sol.x[0]), float(sol.x[1])
    # residual variance per effective sample of the force residual (autocorrelated)
    n_eff = float(channel_effective_samples(pts, filtered_channel(pts, preds, 10.0 ** lf, z, ch))[ch])
    try:
        cov = np.linalg.inv(J.T @ J) * float(r @ r) / max(n_eff - 2.0, 1.0)
    except np.linalg.LinAlgError:
        cov = np.full((2, 2), np.inf)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, np.inf))
    return {"f_c_hz": 10.0 ** lf, "zeta": z,
            "intervals": {"sensor_bandwidth_hz": (10.0 ** (lf - 1.96 * sd[0]),
                                                  10.0 ** (lf + 1.96 * sd[0])),
                          "sensor_damping": (z - 1.96 * sd[1], z + 1.96 * sd[1])},
            "sse": float(r @ r), "f_max_hz": f_max}
