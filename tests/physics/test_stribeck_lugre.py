"""The generalised Stribeck LuGre law (``friction_law="lugre_stribeck"``): its steady state
is the textbook curve F_C + (F_S − F_C) exp(−|u/u_S|^δ) above the smoothing velocity, its
static limit (σ₀ → ∞) is that map, its energy balance closes, bad inputs are refused."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from ehsa_opt.datasets.synthetic import SyntheticSpec
from ehsa_opt.physics.bench_model import BRISTLE_STATE, BenchModel
from ehsa_opt.physics.bench_sim import simulate_bench
from ehsa_opt.physics.friction import (
    SMOOTHING_FRACTION,
    micro_damping_decay,
    stribeck_friction,
    stribeck_level,
    stribeck_slope,
)
from ehsa_opt.physics.motion import SineMotion
from ehsa_opt.physics.params import FrictionParams, HarvesterParams

FS, FC, US, DELTA, FV = 46.0, 32.0, 0.008, 0.7, 160.0
FR = FrictionParams(nut_breakaway_N=FS, nut_coulomb_N=FC, nut_breakaway_velocity_m_per_s=US,
                    nut_viscous_Ns_per_m=FV, bearing_breakaway_Nm=0.0, bearing_coulomb_Nm=0.0,
                    bearing_breakaway_velocity_rad_per_s=1.0, bearing_viscous_Nms_per_rad=0.0)


def _p(model: BenchModel, sigma0: float, sigma1: float = 500.0) -> np.ndarray:
    return model.param_vector(1.0, FR, {"presliding_stiffness_N_per_m": sigma0,
                                        "presliding_damping_Ns_per_m": sigma1,
                                        "stribeck_exponent": DELTA})


def test_the_level_is_the_textbook_curve_above_the_smoothing_velocity() -> None:
    u = np.array([0.05, 0.1, 0.3, 1.0]) * 1.0  # m/s, ≥ 6 u_S ≫ u_c = 0.8 mm/s
    textbook = FC + (FS - FC) * np.exp(-np.abs(u / US) ** DELTA)
    np.testing.assert_allclose(stribeck_level(u, FS, FC, US, DELTA), textbook, rtol=2e-4)
    np.testing.assert_allclose(stribeck_level(-u, FS, FC, US, DELTA), textbook, rtol=2e-4)
    # the map is odd, its slope φ = s(u)/u positive and finite at rest
    v = np.array([-0.3, -1e-3, -1e-8, 0.0, 1e-9, 4e-4, 0.02, 1.0])
    s = stribeck_friction(v, FS, FC, US, DELTA, 0.0)
    phi = stribeck_slope(v, FS, FC, US, DELTA)
    assert np.all(np.isfinite(phi)) and np.all(phi > 0)
    np.testing.assert_allclose(phi * v, s, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(s, -stribeck_friction(-v, FS, FC, US, DELTA, 0.0), atol=1e-12)
    # at rest the level is F_C + (F_S − F_C) exp(−(u_c/u_S)^δ)
    assert float(stribeck_level(0.0, FS, FC, US, DELTA)) == pytest.approx(
        FC + (FS - FC) * np.exp(-SMOOTHING_FRACTION ** DELTA), rel=1e-12)


@pytest.mark.parametrize("delta", [0.5, 1.0, 2.0])
def test_symbolic_and_numeric_agree_and_are_smooth_at_rest(delta: float) -> None:
    x, d = ca.SX.sym("x"), ca.SX.sym("d")
    f = ca.Function("f", [x, d], [stribeck_slope(x, FS, FC, US, d),
                                  ca.jacobian(stribeck_slope(x, FS, FC, US, d), ca.vertcat(x, d))])
    for v in (0.0, 1e-12, 1e-4, 0.02):
        val, jac = f(v, delta)
        assert float(val) == pytest.approx(float(stribeck_slope(v, FS, FC, US, delta)),
                                           rel=1e-12)
        assert np.all(np.isfinite(np.array(jac)))
    assert float(micro_damping_decay(0.0, US)) == 1.0
    assert float(micro_damping_decay(3 * US, US)) == pytest.approx(np.exp(-9.0))


def test_the_generalised_map_is_the_limit_of_large_bristle_stiffness() -> None:
    """On a 2 Hz, 10 mm sine the rms gap to the map falls as σ₀ grows, ~1/σ₀ at large σ₀
    (0.022 N at 1e10 N/m: the transient after each reversal lasts a travel s(v)/σ₀)."""
    model = BenchModel(HarvesterParams(), generator=False, friction_law="lugre_stribeck")
    t = np.linspace(0.0, 1.0, 2001)
    gaps = []
    for s0 in (1e6, 1e8, 1e10):
        sim = simulate_bench(model, SineMotion(0.01, 2.0), _p(model, s0), t, rtol=1e-7,
                             atol=1e-9)
        law = stribeck_friction(sim.velocity_m_per_s, FS, FC, US, DELTA, FV)
        gaps.append(float(np.sqrt(np.mean((sim.force_N - law) ** 2))))
    assert gaps[0] > 5 * gaps[1] > 50 * gaps[2]
    assert gaps[1] / gaps[2] == pytest.approx(100.0, rel=0.5)
    assert gaps[2] < 0.03  # N, against 32–46 N of friction


def test_energy_balance_closes_with_the_bristle_spring() -> None:
    model = BenchModel(HarvesterParams(), friction_law="lugre_stribeck")
    assert model.law_names == ["presliding_stiffness_N_per_m", "presliding_damping_Ns_per_m",
                               "stribeck_exponent"]
    assert BRISTLE_STATE in model.state_names
    sim = simulate_bench(model, SineMotion(0.01, 1.5), _p(model, 3e6), np.linspace(0, 1.4, 1401))
    assert abs(sim.energy_residual()) < 1e-6


def test_a_synthetic_spec_with_an_exponent_uses_the_generalised_law_and_refuses_unknown_keys(
) -> None:
    spec = SyntheticSpec(friction=FR, presliding={"presliding_stiffness_N_per_m": 2e6,
                                                  "stribeck_exponent": DELTA})
    assert spec.model().friction_law == "lugre_stribeck"
    with pytest.raises(ValueError, match="presliding has unknown parameter.*stribeck_exponent"):
        SyntheticSpec(friction=FR, presliding={"stribeck_exp": 1.0})
