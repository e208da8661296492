"""A lightly damped mode above the band the drive lag explains, judged on a record's
apparent mass after the hold and the lag.

The apparent mass M(f) = S_aF / S_aa (the recorded force over the measured
acceleration, Welch cross-spectra; :func:`~.drive_lag.frequency_evidence`) of a rigid
carriage is its mass.  The hold and a drive lag τ multiply it by e^(iωT/2)(1 + iωτ);
divided out, what remains of a rigid carriage is a real constant.  A flexibility shows
as a frequency dependence of its own:

* *collocated* (the force and the measured motion on the same mass m₁, a load m₂
  behind a spring k and damper c):  M = m₁ + m₂ (k + iωc) / (k + iωc − m₂ω²), rising
  towards an antiresonance at f_a = √(k/m₂)/2π with a phase *lag*;
* *non-collocated* (the motion measured on the load):  M = m (1 − ω² / (ω_r² + 2iζω_rω)),
  m = m₁ + m₂, falling towards a resonance f_r.

Each form is fitted on the coherent frequencies by weighted least squares on the
complex ratio (weights γ²/((1 − γ²)|M|²), the inverse relative variance of a Welch
estimate): linear in the masses, the mode's frequency (a grid over
:data:`MODE_BAND_HZ`) and damping ratio refined by ``scipy.optimize.least_squares``.
The mode is *found* when its best form has positive masses, its frequency inside
the band and among the coherent frequencies (a mode fitted beyond them is an
extrapolation of a flank), and beats the rigid constant by :data:`MODE_DELTA_BIC` (BIC with the
coherent frequencies as the samples, two real numbers each).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from .drive_lag import effective_mass, hold_delay_s

__all__ = ["apparent_mass", "fit_mode", "MODE_BAND_HZ", "MODE_DELTA_BIC", "ZETA_GRID"]

#: Where the mode is looked for, Hz: above the ≈ 150 Hz up to which the hold and a
#: drive lag explain the EMPS phase, below the 500 Hz Nyquist frequency of 1 kHz data.
MODE_BAND_HZ = (150.0, 450.0)
#: ΔBIC a mode must reach against the rigid constant ("very strong" evidence on the
#: Kass & Raftery scale, 2 ln B > 10).
MODE_DELTA_BIC = -10.0
#: Damping ratios of the starting grid.
ZETA_GRID = (0.01, 0.03, 0.1, 0.3)


def apparent_mass(test, tau_s: float = 0.0, nperseg: int = 1024, hold: bool = True
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(f Hz, M(f) kg complex with the hold and the lag divided out, coherence γ²).

    With ``hold`` the force is taken as held over each sample (the DAC), and the exact
    response of a mass through the hold and the central second difference,
    e^(iωT/2) / cos(ωT/2), is divided out; without it only the difference's gain."""
    t = np.asarray(test.time_s, float)
    f, M, coh = effective_mass(test, nperseg)
    w = 2 * math.pi * f
    dt = 1.0 / (1.0 / float(np.median(np.diff(t))))  # as 1/fs of the spectra
    if hold:
        # a mass driven through the hold and seen through the central second
        # difference: u / a = M e^(iωT/2) / cos(ωT/2) exactly; divide both out
        M = M * np.exp(-1j * w * hold_delay_s(t)) * np.cos(w * dt / 2)
    else:
        # the central second difference alone: a gain (sin(ωT/2) / (ωT/2))²
        with np.errstate(divide="ignore", invalid="ignore"):
            M = M * np.where(w > 0, (np.sin(w * dt / 2) / (w * dt / 2)) ** 2, 1.0)
    return f, M / (1 + 1j * w * tau_s), coh


def _collocated(w, fa, z):
    """Columns of M in (m₁, m₂) for an antiresonance fa (Hz) and damping ratio z."""
    wa = 2 * math.pi * fa
    num = wa * wa + 2j * z * wa * w
    return np.column_stack([np.ones_like(w, dtype=complex), num / (num - w * w)])


def _noncollocated(w, fr, z):
    wr = 2 * math.pi * fr
    return (1 - w * w / (wr * wr + 2j * z * wr * w))[:, None]


def _wls(X: np.ndarray, y: np.ndarray, sw: np.ndarray) -> tuple[np.ndarray, float]:
    """Real coefficients of the complex model X c ≈ y, weighted by ``sw``²: (c, SSE)."""
    A = np.vstack([(X * sw[:, None]).real, (X * sw[:, None]).imag])
    b = np.concatenate([(y * sw).real, (y * sw).imag])
    c, *_ = np.linalg.lstsq(A, b, rcond=None)
    return c, float(np.sum((A @ c - b) ** 2))


def _refine(form, w, y, sw, f0, z0, band):
    def res(q):
        X = form(w, q[0], q[1])
        c, _ = _wls(X, y, sw)
        r = (X @ c - y) * sw
        return np.concatenate([r.real, r.imag])

    out = least_squares(res, [f0, z0], bounds=([band[0] * 0.5, 1e-3], [band[1] * 1.5, 2.0]))
    X = form(w, *out.x)
    c, sse = _wls(X, y, sw)
    return float(out.x[0]), float(out.x[1]), c, sse


def fit_mode(test, tau_s: float = 0.0, band_hz: tuple[float, float] = (15.0, 450.0),
             min_coherence: float = 0.8, hold: bool = True) -> dict:
    """The rigid constant and the two mode forms fitted to the apparent mass of
    ``test`` (after the hold and a lag ``tau_s``) on its coherent frequencies in
    ``band_hz``.

    Returns
    -------
    dict with ``found`` (bool), ``form`` (the better mode form), ``frequency_hz``,
    ``damping_ratio``, ``masses_kg`` (m₁, m₂ collocated; m non-collocated),
    ``delta_bic`` (the better form against the rigid constant), ``rigid_mass_kg``,
    ``frequencies`` (how many coherent frequencies, their range), ``reason``.
    """
    f, M, coh = apparent_mass(test, tau_s, hold=hold)
    use = (f >= band_hz[0]) & (f <= band_hz[1]) & (coh >= min_coherence) & np.isfinite(M)
    if np.count_nonzero(use) < 8:
        return {"found": False, "reason": f"{int(np.count_nonzero(use))} coherent frequencies "
                f"(γ² ≥ {min_coherence}) in {band_hz[0]:g}–{band_hz[1]:g} Hz: too few to judge"}
    w, y = 2 * math.pi * f[use], M[use]
    g = np.clip(coh[use], 0.0, 0.999)
    sw = np.sqrt(g / (1 - g)) / np.abs(y)
    c0, sse0 = _wls(np.ones((w.size, 1), complex), y, sw)
    n = 2 * w.size
    best = None
    for name, form, k in (("collocated", _collocated, 4), ("non-collocated", _noncollocated, 3)):
        grid = [(fm, z) for fm in np.arange(MODE_BAND_HZ[0], MODE_BAND_HZ[1] + 1, 10.0)
                for z in ZETA_GRID]
        f0, z0 = min(grid, key=lambda q: _wls(form(w, *q), y, sw)[1])
        fm, z, c, sse = _refine(form, w, y, sw, f0, z0, MODE_BAND_HZ)
        dbic = n * math.log(sse / sse0) + (k - 1) * math.log(n)
        # the mode where the data are coherent: one fitted beyond them is an extrapolation
        physical = (bool(np.all(c > 0)) and MODE_BAND_HZ[0] <= fm <= MODE_BAND_HZ[1]
                    and fm <= float(f[use].max()))
        row = {"form": name, "frequency_hz": fm, "damping_ratio": z,
               "masses_kg": [float(v) for v in c], "delta_bic": dbic, "physical": physical}
        if best is None or (physical, -dbic) > (best["physical"], -best["delta_bic"]):
            best = row
    found = best["physical"] and best["delta_bic"] < MODE_DELTA_BIC
    fr = f[use]
    reason = (f"{best['form']} mode at {best['frequency_hz']:.0f} Hz (ζ {best['damping_ratio']:.3f}, "
              f"masses {', '.join(f'{m:.1f}' for m in best['masses_kg'])} kg): ΔBIC "
              f"{best['delta_bic']:.1f} against a rigid {c0[0]:.1f} kg on {w.size} coherent "
              f"frequencies in {fr.min():.0f}–{fr.max():.0f} Hz"
              + ("" if best["physical"] else " — not resolved: a negative mass, or outside "
                 f"{MODE_BAND_HZ[0]:g}–{MODE_BAND_HZ[1]:g} Hz or the coherent frequencies"))
    return {**best, "found": bool(found), "rigid_mass_kg": float(c0[0]),
            "frequencies": [int(w.size), float(fr.min()), float(fr.max())], "reason": reason}
