"""The LuGre (presliding) nut friction: its static limit is the Simscape map, its small-
amplitude response is the bristle spring, its energy balance closes."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ehsa_opt.physics.bench_model import BRISTLE_STATE, BenchModel
from ehsa_opt.physics.bench_sim import simulate_bench
from ehsa_opt.physics.friction import (
    nut_friction_N,
    nut_static_slope,
    simscape_friction,
    static_slope,
)
from ehsa_opt.physics.motion import SineMotion
from ehsa_opt.physics.params import FrictionParams, HarvesterParams

FR = FrictionParams(nut_breakaway_N=46.0, nut_coulomb_N=32.0,
                    nut_breakaway_velocity_m_per_s=0.008, nut_viscous_Ns_per_m=160.0,
                    bearing_breakaway_Nm=0.0, bearing_coulomb_Nm=0.0,
                    bearing_breakaway_velocity_rad_per_s=1.0, bearing_viscous_Nms_per_rad=0.0)


def _rod_model() -> BenchModel:
    """Rod friction alone: no generator, no mass, no offset."""
    return BenchModel(HarvesterParams(), generator=False, friction_law="lugre")


def _p(model: BenchModel, sigma0: float, sigma1: float = 500.0) -> np.ndarray:
    return model.param_vector(1.0, FR, {"presliding_stiffness_N_per_m": sigma0,
                                        "presliding_damping_Ns_per_m": sigma1})


def test_static_slope_is_the_static_law_over_velocity_and_finite_at_rest() -> None:
    u = np.array([-0.3, -1e-3, -1e-7, 0.0, 1e-9, 4e-4, 0.02, 1.0])
    s = simscape_friction(u, 46.0, 32.0, 0.008, 0.0)
    phi = static_slope(u, 46.0, 32.0, 0.008)
    assert np.all(np.isfinite(phi)) and np.all(phi > 0)
    np.testing.assert_allclose(phi * u, s, rtol=1e-12, atol=1e-12)
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [ca.jacobian(static_slope(x, 46.0, 32.0, 0.008), x)])
    assert all(np.isfinite(float(f(v))) for v in (0.0, 1e-12, 1e-4))


def test_the_static_law_is_the_limit_of_large_bristle_stiffness() -> None:
    """On a 2 Hz, 10 mm sine the rms gap to the static map falls as σ₀ grows, ~1/σ₀ at large σ₀ (the presliding
    transient after each reversal lasts a travel s(v)/σ₀)."""
    model = _rod_model()
    t = np.linspace(0.0, 1.0, 2001)
    gaps = []
    for s0 in (1e6, 1e8, 1e10):
        sim = simulate_bench(model, SineMotion(0.01, 2.0), _p(model, s0), t, rtol=1e-7,
                             atol=1e-9)
        gaps.append(float(np.sqrt(np.mean((sim.force_N
                                           - nut_friction_N(sim.velocity_m_per_s, FR)) ** 2))))
    assert gaps[0] > 5 * gaps[1] > 50 * gaps[2]
    assert gaps[2] < 0.02  # N, against 32–46 N of friction


@pytest.mark.parametrize("freq_hz", [2.0, 20.0])
def test_small_amplitude_response_is_the_linearised_bristle(freq_hz: float) -> None:
    """Below the Coulomb smoothing velocity the law is linear:
    F/X = jω (σ₀ + jω σ₁) / (jω + σ₀/φ(0)) + jω f_v, which tends to the presliding
    stiffness σ₀ (+ jω σ₁) above the corner σ₀/φ(0)."""
    model = _rod_model()
    s0, s1, fv = 1e6, 500.0, FR.nut_viscous_Ns_per_m
    a = 1e-8  # m: peak speed ≪ u_Coul = 0.8 mm/s
    phi0 = float(nut_static_slope(0.0, FR))
    settle = 12 * phi0 / s0  # s: twelve time constants of the bristle relaxation
    w = 2 * np.pi * freq_hz
    t = np.linspace(0.0, settle + 4.0 / freq_hz, 6001)
    sim = simulate_bench(model, SineMotion(a, freq_hz), _p(model, s0, s1), t, rtol=1e-10,
                         atol=1e-13)
    k = t > settle
    c, *_ = np.linalg.lstsq(np.column_stack([np.sin(w * t[k]), np.cos(w * t[k])]),
                            sim.force_N[k], rcond=None)
    measured = (c[0] + 1j * c[1]) / a
    jw = 1j * w
    expected = jw * (s0 + jw * s1) / (jw + s0 / phi0) + jw * fv
    assert abs(measured - expected) < 1e-4 * abs(expected)
    if freq_hz == 20.0:  # well above the corner: the real part is the bristle stiffness
        assert measured.real == pytest.approx(s0, rel=0.1)


def test_energy_balance_closes_with_the_bristle_spring() -> None:
    model = BenchModel(HarvesterParams(), friction_law="lugre")
    assert BRISTLE_STATE in model.state_names
    sim = simulate_bench(model, SineMotion(0.01, 1.5), _p(model, 3e6), np.linspace(0, 1.4, 1401))
    assert abs(sim.energy_residual()) < 1e-6


def test_unknown_friction_law_is_refused() -> None:
    with pytest.raises(ValueError, match="friction_law must be one of"):
        BenchModel(HarvesterParams(), friction_law="dahl")
