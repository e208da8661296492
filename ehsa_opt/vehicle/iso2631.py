"""ISO 2631-1 frequency weighting W_k (vertical whole-body vibration).

The exact weighting is the product of four analogue filters (ISO 2631-1:1997,
Annex A), with s = j 2π f::

    H_h(s) = s² / (s² + s ω1/Q1 + ω1²)                       band-limiting high-pass
    H_l(s) = ω2² / (s² + s ω2/Q2 + ω2²)                      band-limiting low-pass
    H_t(s) = (1 + s/ω3) / (1 + s/(Q4 ω4) + s²/ω4²)           acceleration–velocity transition
    H_s(s) = (s² + s ω5/Q5 + ω5²) / (s² + s ω6/Q6 + ω6²)     upward step

f1 = 0.4 Hz, f2 = 100 Hz, f3 = f4 = 12.5 Hz, f5 = 2.37 Hz, f6 = 3.35 Hz,
Q1 = Q2 = 1/√2, Q4 = 0.63, Q5 = Q6 = 0.91.  (H_s has gain (f5/f6)² ≈ 0.5 at low
frequency and 1 at high frequency; this gives the standard's 0.482 at 1 Hz.)

For time-domain filtering (e.g. a causal comfort signal inside a simulation or an
optimal-control problem) :func:`wk_state_space` returns a low-order fit; its
error against the exact W_k is reported by :func:`wk_fit_error`.  Metrics in this
package are computed with the exact weighting (in the frequency domain, or by
FFT of the simulated acceleration, :func:`weighted_rms_fft`).
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy import optimize, signal

__all__ = ["WK_PARAMETERS", "ISO2631_WK_TABLE", "wk_exact", "wk_abs2", "wk_exact_tf", "WkFit",
           "wk_state_space", "wk_fit_error", "wk_filter", "weighted_rms_fft"]

#: Filter parameters of W_k (ISO 2631-1 Table A.2), frequencies in Hz.
WK_PARAMETERS: dict[str, float] = {
    "f1": 0.4, "f2": 100.0, "f3": 12.5, "f4": 12.5, "f5": 2.37, "f6": 3.35,
    "Q1": 1.0 / math.sqrt(2.0), "Q2": 1.0 / math.sqrt(2.0), "Q4": 0.63, "Q5": 0.91, "Q6": 0.91,
}

#: W_k factors tabulated in ISO 2631-1 Table 3 (nominal one-third-octave centre
#: frequency in Hz → factor).  The standard computes them at the exact band
#: centres 10^(k/10) Hz; :func:`wk_exact` is checked against them in the tests.
ISO2631_WK_TABLE: dict[float, float] = {
    0.5: 0.418, 0.63: 0.459, 0.8: 0.477, 1.0: 0.482, 1.25: 0.484, 1.6: 0.494, 2.0: 0.531,
    2.5: 0.631, 3.15: 0.804, 4.0: 0.967, 5.0: 1.039, 6.3: 1.054, 8.0: 1.036, 10.0: 0.988,
    12.5: 0.902, 16.0: 0.768, 20.0: 0.636, 25.0: 0.513, 31.5: 0.405, 40.0: 0.314, 50.0: 0.246,
    63.0: 0.186, 80.0: 0.132,
}


def wk_exact_tf() -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator polynomials (in s, highest power first) of W_k.

    Returns
    -------
    num, den : ndarray
        Coefficients of the 8th-order rational W_k(s) (s in rad/s).
    """
    p = WK_PARAMETERS
    w1, w2, w3, w4, w5, w6 = (2.0 * math.pi * p[k] for k in ("f1", "f2", "f3", "f4", "f5", "f6"))
    num_h, den_h = [1.0, 0.0, 0.0], [1.0, w1 / p["Q1"], w1 ** 2]
    num_l, den_l = [w2 ** 2], [1.0, w2 / p["Q2"], w2 ** 2]
    num_t, den_t = [1.0 / w3, 1.0], [1.0 / w4 ** 2, 1.0 / (p["Q4"] * w4), 1.0]
    num_s, den_s = [1.0, w5 / p["Q5"], w5 ** 2], [1.0, w6 / p["Q6"], w6 ** 2]
    num = np.polymul(np.polymul(num_h, num_l), np.polymul(num_t, num_s))
    den = np.polymul(np.polymul(den_h, den_l), np.polymul(den_t, den_s))
    return np.asarray(num, float), np.asarray(den, float)


def wk_exact(f_hz: ArrayLike) -> np.ndarray:
    """Exact ISO 2631-1 W_k = H_h·H_l·H_t·H_s at frequencies ``f_hz`` (Hz).

    Parameters
    ----------
    f_hz : array_like
        Frequencies in Hz (any shape; negative values give the conjugate).

    Returns
    -------
    ndarray of complex
        W_k(j 2π f), dimensionless, same shape as ``f_hz``.
    """
    p = WK_PARAMETERS
    s = 2j * math.pi * np.asarray(f_hz, dtype=float)
    w1, w2, w3, w4, w5, w6 = (2.0 * math.pi * p[k] for k in ("f1", "f2", "f3", "f4", "f5", "f6"))
    hh = s * s / (s * s + s * w1 / p["Q1"] + w1 ** 2)
    hl = w2 ** 2 / (s * s + s * w2 / p["Q2"] + w2 ** 2)
    ht = (1.0 + s / w3) / (1.0 + s / (p["Q4"] * w4) + (s / w4) ** 2)
    hs = (s * s + s * w5 / p["Q5"] + w5 ** 2) / (s * s + s * w6 / p["Q6"] + w6 ** 2)
    return hh * hl * ht * hs


def wk_abs2(f_hz: ArrayLike) -> np.ndarray:
    """|W_k(j 2π f)|², computed section by section in real arithmetic (fast path)."""
    p = WK_PARAMETERS
    w2 = (2.0 * math.pi * np.asarray(f_hz, dtype=float)) ** 2
    w1, wl, w3, w4, w5, w6 = (2.0 * math.pi * p[k] for k in ("f1", "f2", "f3", "f4", "f5", "f6"))

    def quad(w0: float, q: float) -> np.ndarray:  # |s² + s w0/q + w0²|²
        return (w0 * w0 - w2) ** 2 + w2 * (w0 / q) ** 2

    hh = w2 * w2 / quad(w1, p["Q1"])
    hl = wl ** 4 / quad(wl, p["Q2"])
    ht = (1.0 + w2 / w3 ** 2) * w4 ** 4 / quad(w4, p["Q4"])
    hs = quad(w5, p["Q5"]) / quad(w6, p["Q6"])
    return hh * hl * ht * hs


# --------------------------------------------------------------------------- low-order fit
@dataclass(frozen=True)
class WkFit:
    """A low-order continuous-time fit of W_k.

    Attributes
    ----------
    order : int
        Number of states.
    num, den : ndarray
        Transfer-function coefficients in s (rad/s), highest power first.
    A, B, C, D : ndarray
        Controllable-canonical state-space realisation (x' = A x + B u, y = C x + D u).
    max_rel_error : float
        max |(|H| − |W_k|)| / |W_k| over the fit band.
    rms_rel_error : float
        rms of the same relative error over log-spaced frequencies of the band.
    band_hz : tuple of float
        The band the errors refer to.
    """

    order: int
    num: np.ndarray
    den: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    max_rel_error: float
    rms_rel_error: float
    band_hz: tuple[float, float]

    def response(self, f_hz: ArrayLike) -> np.ndarray:
        """Complex response of the fit at ``f_hz`` (Hz)."""
        s = 2j * math.pi * np.asarray(f_hz, dtype=float)
        return np.polyval(self.num, s) / np.polyval(self.den, s)


def _reflect_lhp(poly: np.ndarray) -> np.ndarray:
    """Same |p(jω)| with every root moved into the closed left half-plane."""
    roots = np.roots(poly)
    roots = np.where(roots.real > 0.0, -roots.conj(), roots)
    return np.real(np.poly(roots)) * poly[0]


@functools.lru_cache(maxsize=8)
def wk_state_space(order: int = 6, band_hz: tuple[float, float] = (0.5, 80.0)) -> WkFit:
    """A low-order, stable, minimum-phase continuous-time fit of W_k.

    Structure: the exact high-pass H_h (2 states) times a rational G(s) with
    ``order − 2`` poles and ``order − 3`` zeros (so the fit rolls off like W_k
    above 12.5 Hz).  G is fitted to W_k/H_h on 300 log-spaced points of
    ``band_hz`` by Sanathanan–Koerner iteration with relative weighting (linear
    least squares), then refined on the log-magnitude (Levenberg–Marquardt); the
    refinement is kept only if it lowers the maximum relative error.  Roots are
    reflected into the left half-plane (|H| unchanged) so the filter is stable
    and minimum-phase.  Deterministic; cached.

    Parameters
    ----------
    order : int
        Number of states, 4 … 8 (4: max error ≈ 17 %, 6: ≈ 3 % over 0.5–80 Hz).
    band_hz : tuple
        Fit and error band, Hz.

    Returns
    -------
    WkFit
    """
    order = int(order)
    if not 4 <= order <= 8:
        raise ValueError(f"wk_state_space: order must be 4..8, got {order}")
    f = np.logspace(math.log10(band_hz[0]), math.log10(band_hz[1]), 300)
    w_ref = 2.0 * math.pi * 5.0  # frequency scaling for conditioning
    s = 2j * math.pi * f / w_ref
    p = WK_PARAMETERS
    w1 = 2.0 * math.pi * p["f1"] / w_ref
    hh = s * s / (s * s + s * w1 / p["Q1"] + w1 ** 2)
    wk = wk_exact(f)
    g = wk / hh
    n, m = order - 2, order - 3
    weight = 1.0 / np.abs(g)
    den_val = np.ones_like(s)
    for _ in range(40):
        cols = [s ** k for k in range(m + 1)] + [-g * s ** k for k in range(n)]
        scale = weight / np.abs(den_val)
        mat = np.array(cols).T * scale[:, None]
        rhs = g * s ** n * scale
        x = np.linalg.lstsq(np.vstack([mat.real, mat.imag]),
                            np.concatenate([rhs.real, rhs.imag]), rcond=None)[0]
        b, a = x[: m + 1][::-1], np.concatenate([[1.0], x[m + 1:][::-1]])
        den_val = np.polyval(a, s)

    target = np.log(np.abs(wk))

    def rel_err(bb: np.ndarray, aa: np.ndarray) -> np.ndarray:
        return np.abs(np.abs(np.polyval(bb, s) / np.polyval(aa, s) * hh) / np.abs(wk) - 1.0)

    def resid(x: np.ndarray) -> np.ndarray:
        h = np.polyval(x[: m + 1], s) / np.polyval(np.concatenate([[1.0], x[m + 1:]]), s) * hh
        return np.log(np.abs(h)) - target

    sol = optimize.least_squares(resid, np.concatenate([b, a[1:]]), method="lm", max_nfev=4000)
    b2, a2 = sol.x[: m + 1], np.concatenate([[1.0], sol.x[m + 1:]])
    if rel_err(b2, a2).max() < rel_err(b, a).max():
        b, a = b2, a2
    b, a = _reflect_lhp(b), _reflect_lhp(a)
    # Back to physical s (rad/s): s_scaled = s / w_ref.
    num_g = b / w_ref ** np.arange(len(b) - 1, -1, -1)
    den_g = a / w_ref ** np.arange(len(a) - 1, -1, -1)
    w1p = 2.0 * math.pi * p["f1"]
    num = np.polymul([1.0, 0.0, 0.0], num_g)
    den = np.polymul([1.0, w1p / p["Q1"], w1p ** 2], den_g)
    num, den = num / den[0], den / den[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", signal.BadCoefficients)
        A, B, C, D = signal.tf2ss(num, den)
    sp = 2j * math.pi * f
    rel = np.abs(np.abs(np.polyval(num, sp) / np.polyval(den, sp)) / np.abs(wk) - 1.0)
    return WkFit(order=order, num=num, den=den, A=A, B=B, C=C, D=D,
                 max_rel_error=float(rel.max()), rms_rel_error=float(np.sqrt(np.mean(rel ** 2))),
                 band_hz=(float(band_hz[0]), float(band_hz[1])))


def wk_fit_error(order: int = 6, band_hz: tuple[float, float] = (0.5, 80.0)) -> dict[str, float]:
    """Error of :func:`wk_state_space` against the exact W_k.

    Returns
    -------
    dict
        ``max_rel_error`` and ``rms_rel_error`` of the magnitude over ``band_hz``,
        and ``order``.
    """
    fit = wk_state_space(order, tuple(band_hz))
    return {"order": fit.order, "max_rel_error": fit.max_rel_error,
            "rms_rel_error": fit.rms_rel_error}


def wk_filter(signal_: ArrayLike, sample_rate_hz: float, order: int = 6) -> np.ndarray:
    """Causal time-domain W_k weighting with the low-order fit (Tustin discretisation).

    Parameters
    ----------
    signal_ : array_like
        Uniformly sampled acceleration, m/s².
    sample_rate_hz : float
        Sample rate, Hz (well above 2 × 80 Hz for the fit's band to be faithful).
    order : int
        Order of :func:`wk_state_space` (its error is reported by :func:`wk_fit_error`).

    Returns
    -------
    ndarray
        The weighted signal, m/s² (starts from rest, so discard an initial transient).
    """
    fit = wk_state_space(order)
    b, a = signal.bilinear(fit.num, fit.den, fs=sample_rate_hz)
    return signal.lfilter(b, a, np.asarray(signal_, dtype=float))


def weighted_rms_fft(signal_: ArrayLike, sample_rate_hz: float) -> float:
    """rms of a sampled acceleration after exact W_k weighting (FFT, zero-phase).

    Parameters
    ----------
    signal_ : array_like
        Uniformly sampled acceleration, m/s².
    sample_rate_hz : float
        Sample rate, Hz.

    Returns
    -------
    float
        rms of the W_k-weighted signal, m/s² (Parseval over the one-sided spectrum).
    """
    x = np.asarray(signal_, dtype=float)
    x = x - x.mean()
    n = x.size
    spec = np.fft.rfft(x)
    f = np.fft.rfftfreq(n, 1.0 / sample_rate_hz)
    y = np.fft.irfft(spec * np.abs(wk_exact(f)), n)
    return float(np.sqrt(np.mean(y ** 2)))
