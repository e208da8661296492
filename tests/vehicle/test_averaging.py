"""Energy-envelope (stochastic averaging) correction of the friction damping."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from ehsa_opt.physics.friction import simscape_friction
from ehsa_opt.physics.params import FrictionParams, RoadParams, VehicleParams
from ehsa_opt.vehicle.fast_path.sticking import averaged_damping, harmonic_terms
from ehsa_opt.vehicle.fast_path.linearisation import (
    friction_equivalent_damping_Ns_per_m,
    friction_metrics,
    law_equivalent_damping,
)

LAW = (60.0, 40.0, 0.01, 150.0)
FR = np.array([[120.0, 80.0, 0.01, 300.0, 0.04, 0.03, 1.0, 6e-5]])
R = np.array([5e-3 / (2.0 * math.pi)])


@pytest.mark.parametrize("amp", [1e-4, 2e-3, 0.014, 0.05, 1.5])
def test_harmonic_terms_match_quadrature(amp):
    # ⟨F v⟩ over a cycle, and Φ(V) = ∫₀^V 2⟨F v⟩(u)/u du, by adaptive quadrature
    def cyc(u: float) -> float:
        return 2.0 / math.pi * integrate.quad(
            lambda p: simscape_friction(u * math.cos(p), *LAW) * u * math.cos(p),
            0.0, 0.5 * math.pi, limit=400, epsabs=0.0, epsrel=1e-11)[0]

    d, phi = harmonic_terms(amp, *LAW)
    assert d == pytest.approx(cyc(amp), rel=1e-5)
    ref = integrate.quad(lambda u: 2.0 * cyc(u) / u, 0.0, amp, limit=200,
                         points=[x for x in (1e-3, 1e-2) if x < amp], epsrel=1e-9)[0]
    assert phi == pytest.approx(ref, rel=1e-4)


def test_gaussian_limit_and_viscous_law():
    # no secant gap (weak friction): the Rayleigh amplitude = Gaussian velocity
    for s in (0.005, 0.07, 0.4):
        got = averaged_damping([s], [s], [0.0], FR, R)
        ref = friction_equivalent_damping_Ns_per_m(np.array([s]), FR, R)
        # (24 Gauss–Legendre amplitude nodes: quadrature errors up to 6e-6)
        np.testing.assert_allclose(got, ref, rtol=1e-5)
    # a viscous law stays exactly viscous whatever the secant
    visc = np.array([[0.0, 0.0, 0.01, 420.0, 0.0, 0.0, 1.0, 0.0]])
    np.testing.assert_allclose(averaged_damping([0.3], [0.1], [420.0], visc, R), 420.0,
                               rtol=1e-12)


def _sdof_fixed_point(law: tuple, c_lin: float, pis0: float) -> tuple[float, float]:
    """Gaussian and averaged fixed points of a unit-mass SDOF, σ_v² = πS₀/(c_lin + c)."""
    sig0 = math.sqrt(pis0 / c_lin)
    sig = lambda c: math.sqrt(pis0 / (c_lin + c))  # noqa: E731
    s = sig0
    for _ in range(300):
        cg = float(law_equivalent_damping(s, *law))
        s = sig(cg)
    c = cg
    fr = np.array([[*law, 0.0, 0.0, 1.0, 0.0]])
    for _ in range(200):
        c = float(averaged_damping([sig0], [sig(c)], [c], fr, [1.0])[0])
    return cg, c


def test_pure_coulomb_dominated_limit():
    # c_lin → 0: V ~ Gamma(2), c = (2/√π)(E V/√E V²) = 2√2/√(3π) of the Gaussian value
    law = (5.0, 5.0, 1e-9, 0.0)
    c_lin, pis0 = 1e-3, 1.0
    _, c = _sdof_fixed_point(law, c_lin, pis0)
    sv = math.sqrt(pis0 / (c_lin + c))
    ratio = c / (5.0 * math.sqrt(2.0 / math.pi) / sv)
    assert ratio == pytest.approx(2.0 * math.sqrt(2.0) / math.sqrt(3.0 * math.pi), rel=2e-3)


def test_sdof_monte_carlo_strong_friction():
    # Monte-Carlo of a lightly damped oscillator with the Simscape law under white
    # noise: the averaged damping is close, the Gaussian one is ~10 % high
    rng = np.random.default_rng(7)
    w0 = 2.0 * math.pi * 2.0
    c_lin, pis0 = 0.1 * w0, 0.5
    sig0 = math.sqrt(pis0 / c_lin)
    law = (3.0 * c_lin * sig0, 2.0 * c_lin * sig0, 0.05 * sig0, 0.0)
    n, dt, steps, burn = 600, 5e-4, 36000, 8000
    x, v = np.zeros(n), np.zeros(n)
    fv = v2 = 0.0
    for k in range(steps):
        f = simscape_friction(v, *law)
        if k >= burn:
            fv += float(np.mean(f * v))
            v2 += float(np.mean(v * v))
        v = v + (-c_lin * v - f - w0 * w0 * x) * dt + rng.standard_normal(n) * math.sqrt(
            2.0 * pis0 * dt)
        x = x + v * dt
    c_mc = fv / v2
    cg, ca = _sdof_fixed_point(law, c_lin, pis0)
    assert cg / c_mc - 1.0 > 0.06           # the Gaussian closure's known bias
    assert abs(ca / c_mc - 1.0) < 0.03


def test_friction_metrics_correction_lowers_damping_and_gaussian_option():
    veh, road = VehicleParams(), RoadParams("B", 30.0)
    fr = FrictionParams(nut_breakaway_N=120.0, nut_coulomb_N=80.0,
                        nut_breakaway_velocity_m_per_s=0.01, nut_viscous_Ns_per_m=300.0)
    ng = friction_metrics(veh, road, None, fr)
    g = friction_metrics(veh, road, None, fr, non_gaussian=False)
    # (the final grid is refined around each run's own c_f: equal to grid accuracy)
    assert g["friction_damping_Ns_per_m"] == pytest.approx(
        float(ng["friction_damping_gaussian_Ns_per_m"]), rel=1e-5)
    assert 0.9 * g["friction_damping_Ns_per_m"] < ng["friction_damping_Ns_per_m"] \
        < g["friction_damping_Ns_per_m"]
    assert ng["stroke_velocity_rms_m_s"] > g["stroke_velocity_rms_m_s"]


def test_averaged_fixed_point_holds_on_the_linear_path():
    # c_f returned is a fixed point of the averaged map evaluated with the linear
    # path's own σ_v(0) and σ_v(c_f) (fine grids)
    from ehsa_opt.vehicle.frequency_path import linear_metrics
    veh, road = VehicleParams(), RoadParams("C", 70.0)
    design = {"load_ohm": np.array([3.0, 47.0, 900.0]),
              "lead_mm_per_rev": np.array([5.0, 12.0, 20.0])}
    fr = FR[0]
    fast = friction_metrics(veh, road, design, fr, iteration_n_freq=1024, n_freq=1024)
    cf = fast["friction_damping_Ns_per_m"]
    s0 = linear_metrics(veh, road, design, n_freq=1024)["stroke_velocity_rms_m_s"]
    sc = fast["stroke_velocity_rms_m_s"]
    r = design["lead_mm_per_rev"] * 1e-3 / (2.0 * math.pi)
    again = averaged_damping(s0, sc, cf, np.broadcast_to(fr, (3, 8)), r)
    np.testing.assert_allclose(again, cf, rtol=2e-3)
    assert np.all(fast["dissipated_power_W"] > fast["friction_power_W"])


def test_tabulated_cycle_averages_match_scipy_and_their_limits():
    # the Bessel terms of the Stribeck hump from cubic tables in ln h (series beyond 200):
    # against scipy's i0e/i1e; 0, ∞ and NaN arguments give their limits / NaN, no error
    from scipy.special import i0e, i1e

    from ehsa_opt.vehicle.fast_path.sticking import _bessel_terms, _t_l
    h = np.concatenate([[0.0, 1e-12, 1e-8, 199.99, 200.0, 1e4],
                        np.exp(np.random.default_rng(3).uniform(-20.0, 8.0, 2000))])
    i0, d = _bessel_terms(h)
    np.testing.assert_allclose(i0, i0e(h), rtol=1e-9)
    np.testing.assert_allclose(d, i0e(h) - i1e(h), rtol=1e-8)
    i0, d = _bessel_terms(np.array([np.nan, np.inf]))
    assert np.isnan(i0[0]) and np.isnan(d[0]) and i0[1] == 0.0 and d[1] == 0.0
    t, l_ = _t_l(np.array([np.nan, 0.0, np.inf]))
    assert np.isnan(t[0]) and np.isnan(l_[0])
    assert t[1] == 0.0 and l_[1] == 0.0 and t[2] == pytest.approx(2.0 / np.pi)
