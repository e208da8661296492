"""The initial state of an open-loop simulation, estimated from the first samples of
the record the way the nonlinear system identification benchmarks allow.

The EMPS benchmark's official loader (``nonlinear_benchmarks.EMPS``, version 1.0.1)
sets ``state_initialization_window_length = 20`` on the test record, and its metric
(``nonlinear_benchmarks.error_metrics.RMSE``) leaves those samples out: a model may use
the first 20 measured samples (and the input) to set its state, and is judged on the
rest.  The carriage is already moving at the first sample (≈ 6 mm/s on both EMPS
records), so a simulation started from rest carries a permanent position offset of
about v₀ M / F_v that the fitted parameters would otherwise absorb.

The estimate here uses the measured position only: a polynomial of low order fitted
by least squares to the window's samples (``numpy.polynomial.Polynomial.fit``),
evaluated with its derivative at the window's centre, where the derivative of a
least-squares polynomial is best determined.  The force changes little over 20 ms,
so the acceleration is nearly constant there and a quadratic
(:data:`POLYNOMIAL_ORDER`) is the natural choice.  The simulation then runs from the
centre sample with the measured force; the samples before it are not scored.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.polynomial import Polynomial

__all__ = ["InitialState", "initial_state", "STATE_WINDOW_SAMPLES", "POLYNOMIAL_ORDER"]

#: Samples a model may use to set its state (the benchmark's
#: ``state_initialization_window_length``), and that the metric leaves out.
STATE_WINDOW_SAMPLES = 20
#: Order of the polynomial fitted to the window's positions: 2, a constant
#: acceleration over the window (the force changes little over 20 ms at 1 kHz).
POLYNOMIAL_ORDER = 2


@dataclass(frozen=True)
class InitialState:
    """The state at sample ``index`` of a record.

    Attributes
    ----------
    index : int
        Sample the simulation starts at (the window's centre).
    position_m : float
        Position there, m.
    velocity_m_per_s : float
        Velocity there, m/s.
    fitted_m : numpy.ndarray
        The polynomial's positions over the window (what the samples before ``index``
        are given in a simulated record; they are not scored), m.
    """

    index: int
    position_m: float
    velocity_m_per_s: float
    fitted_m: np.ndarray


def initial_state(time_s: np.ndarray, position_m: np.ndarray, start: int = 0,
                  window: int = STATE_WINDOW_SAMPLES, order: int = POLYNOMIAL_ORDER
                  ) -> InitialState:
    """Position and velocity at the centre of samples ``start`` … ``start + window − 1``
    from a least-squares polynomial of the measured position there.

    Parameters
    ----------
    time_s, position_m : numpy.ndarray
        The record's time (s) and measured position (m).
    start : int
        First sample of the window.
    window : int
        Samples in the window (at least ``order + 2``).
    order : int
        Polynomial order.

    Returns
    -------
    InitialState
        At sample ``start + window // 2``.
    """
    t = np.asarray(time_s, float)
    q = np.asarray(position_m, float)
    if window < order + 2 or start < 0 or start + window > t.size:
        raise ValueError(f"initial_state: a window of {window} samples from sample {start} "
                         f"does not fit a record of {t.size} samples with a polynomial of "
                         f"order {order}; use order + 2 ≤ window ≤ the record's length")
    sl = slice(start, start + window)
    poly = Polynomial.fit(t[sl], q[sl], order)
    k = start + window // 2
    return InitialState(k, float(poly(t[k])), float(poly.deriv()(t[k])), poly(t[sl]))
