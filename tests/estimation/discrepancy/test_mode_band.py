"""A lightly damped mode above the drive's band: a 300 Hz mode in synthetic two-mass
data is found in its form and frequency, a rigid carriage gives none."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.signal import cont2discrete, dlsim

from ehsa_opt.estimation.discrepancy.candidates.mode_band import fit_mode


def _record(m1: float, m2: float, f_mode: float, zeta: float, seed: int = 0,
            n: int = 30000):
    """Force through the hold into a carriage m₁ with a load m₂ behind a spring
    (antiresonance ``f_mode``; m₂ = 0: rigid) and a little viscous friction; the
    carriage's position sampled at 1 kHz with 0.1 µm noise."""
    dt = 1e-3
    rng = np.random.default_rng(seed)
    F = 50 * rng.standard_normal(n)
    cv = 5.0  # N s/m to ground: the position does not wander off
    if m2 > 0:
        wa = 2 * np.pi * f_mode
        k, c = m2 * wa * wa, 2 * zeta * m2 * wa
        A = np.array([[0, 1, 0, 0], [-k / m1, -(c + cv) / m1, k / m1, c / m1],
                      [0, 0, 0, 1], [k / m2, c / m2, -k / m2, -c / m2]])
        B = np.array([[0], [1 / m1], [0], [0]])
        C = np.array([[1.0, 0, 0, 0]])
    else:
        A = np.array([[0, 1], [0, -cv / m1]])
        B = np.array([[0], [1 / m1]])
        C = np.array([[1.0, 0]])
    sys = cont2discrete((A, B, C, np.zeros((1, 1))), dt, method="zoh")
    _, y, _ = dlsim(sys, F)
    x = y.ravel() + 1e-7 * rng.standard_normal(n)
    return SimpleNamespace(time_s=np.arange(n) * dt, force_N=F, displacement_m=x)


def test_a_300_hz_mode_is_found_and_a_rigid_carriage_gives_none():
    out = fit_mode(_record(80.0, 15.0, 300.0, 0.05))
    assert out["found"], out["reason"]
    assert out["form"] == "collocated"
    assert out["frequency_hz"] == pytest.approx(300.0, rel=0.03)
    # the continuous-time form near the Nyquist frequency (ωT/2 ≈ 0.9 at 300 Hz) and the
    # coherence lost at the antiresonance leave the split of the mass loose, its sum not
    m1, m2 = out["masses_kg"]
    assert m1 + m2 == pytest.approx(95.0, rel=0.02) and 0.3 * 15.0 < m2 < 2 * 15.0
    rigid = fit_mode(_record(95.0, 0.0, 0.0, 0.0, seed=1))
    assert not rigid["found"], rigid["reason"]
    assert rigid["rigid_mass_kg"] == pytest.approx(95.0, rel=0.02)
