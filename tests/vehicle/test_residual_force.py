"""The friction's non-linear residual force under Gaussian closure."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.params import FrictionParams, HarvesterParams, RoadParams, VehicleParams
from ehsa_opt.vehicle.fast_path.linearisation import friction_array, friction_metrics
from ehsa_opt.vehicle.fast_path.validation import scaled_friction
from ehsa_opt.vehicle.iso2631 import wk_abs2
from ehsa_opt.vehicle.frequency_path import design_arrays
from ehsa_opt.vehicle.fast_path import linearisation as equivalent_module
from ehsa_opt.vehicle.fast_path.residual_force import (LagGrid, _power_laplace, hermite_coefficients,
                                             residual_autocovariance, residual_variances)
from ehsa_opt.vehicle.road import ROAD_BAND_CYCLES_PER_M

VEHICLE = VehicleParams()
FRICTION_X2 = scaled_friction(load_truth(embedded_data_dir("bench_prototype"))["friction"], 2.0)
LEAD = HarvesterParams().lead_mm_per_rev * 1e-3 / (2.0 * math.pi)


def _dense_autocovariance(rho: float, sigma: float, fr: FrictionParams) -> float:
    """E[F(v1) F(v2)] − β_1² ρ for Gaussian (v1, v2) with correlation ρ, by a dense
    two-dimensional trapezoid on x1, x2 ∈ [−8, 8] (v = σ x)."""
    x = np.linspace(-8.0, 8.0, 3201)
    w = np.exp(-0.5 * x * x) * (x[1] - x[0]) / math.sqrt(2.0 * math.pi)
    g1 = np.asarray(rod_friction_N(sigma * x, fr, LEAD))
    beta1 = float(np.sum(w * g1 * x))
    inner = np.asarray(rod_friction_N(
        sigma * (rho * x[:, None] + math.sqrt(1.0 - rho * rho) * x[None, :]), fr, LEAD))
    return float(np.sum(w * g1 * (inner @ w))) - beta1 ** 2 * rho


@pytest.mark.parametrize("rho", [0.3, 0.7, 0.95])
def test_closure_matches_a_dense_double_integral(rho):
    # Stribeck hump, Coulomb, viscous, nut and bearing: the Hermite closure with the
    # arcsine law and the closed-form η_n against brute force
    sigma = 0.06
    got = residual_autocovariance(np.array([[rho]]), np.array([sigma]),
                                  friction_array([FRICTION_X2]), np.array([LEAD]))[0, 0]
    assert got == pytest.approx(_dense_autocovariance(rho, sigma, FRICTION_X2), rel=3e-3)


def test_pure_coulomb_is_the_arcsine_law():
    # F = A sgn(v): R_r(ρ) = A² (2/π)(arcsin ρ − ρ) (van Vleck), whatever σ
    fr = FrictionParams(nut_breakaway_N=50.0, nut_coulomb_N=50.0,
                        nut_breakaway_velocity_m_per_s=1e-9)
    rho = np.linspace(-1.0, 1.0, 41)[None, :]
    for sigma in (0.01, 0.3):
        got = residual_autocovariance(rho, np.array([sigma]), friction_array([fr]),
                                      np.array([LEAD]))
        want = 50.0 ** 2 * (2.0 / math.pi) * (np.arcsin(rho) - rho)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


def _grid_added_variances(road: RoadParams, c_f: float, sigma: float) -> dict[str, float]:
    """The residual's response by a fine frequency grid (an independent reference):
    ρ(τ) from the stroke-velocity spectrum by FFT, R_r(ρ(τ)), its spectrum by FFT, then
    ∫ |H_y|² S_r df for each output."""
    d = {k: float(v) for k, v in design_arrays(None).items()}
    m2, m1 = VEHICLE.sprung_mass_kg, VEHICLE.unsprung_mass_kg
    k2, k1 = VEHICLE.suspension_stiffness_N_per_m, VEHICLE.tyre_stiffness_N_per_m
    df, nb = 1.0 / 64.0, 12801                                     # 0 … 200 Hz
    f = np.arange(nb) * df
    s = 2j * math.pi * f
    r = d["r_m_per_rad"]
    zl = d["Ri_ohm"] + d["Re_ohm"] + s * d["L_H"]
    meq = d["J_kgm2"] / r ** 2
    C = d["Kt"] * d["Ke"] / r ** 2 / zl + c_f
    z11 = (m2 + meq) * s * s + k2 + C * s
    z12 = -meq * s * s - k2 - C * s
    z22 = (m1 + meq) * s * s + k2 + k1 + C * s
    det = z11 * z22 - z12 * z12
    det[0] = 1.0
    v_road = np.abs(k1 * (z12 + z11) / det) ** 2          # per road velocity (white)
    v_road[0] = 0.0
    band = (f >= ROAD_BAND_CYCLES_PER_M[0] * road.speed_m_per_s)
    acf = np.fft.irfft(v_road * band)
    rr = residual_autocovariance((acf / acf[0])[None, :], np.array([sigma]),
                                 friction_array([FRICTION_X2]), np.array([r]))[0]
    sr = np.maximum(2.0 / (acf.size * df) * np.fft.rfft(rr).real, 0.0)
    sr[0] = 0.0
    x2, x1 = (-z22 - z12) / det, (z11 + z12) / det
    v = s * (x2 - x1)
    return {"var_acc_w": float(np.sum(np.abs(s * s * x2) ** 2 * wk_abs2(f) * sr) * df),
            "var_tyre": float(np.sum(np.abs(x1) ** 2 * sr) * df),
            "var_v": float(np.sum(np.abs(v[1:]) ** 2 * sr[1:]) * df),
            "var_i": float(np.sum(np.abs(d["Ke"] / r * v / zl) ** 2 * sr) * df)}


def test_added_variances_match_a_frequency_grid():
    # prototype, class B at 30 km/h, friction x2: the strut sticks, the residual is large
    road = RoadParams("B", 30.0)
    with_r = friction_metrics(VEHICLE, road, None, FRICTION_X2)
    without = friction_metrics(VEHICLE, road, None, FRICTION_X2, residual=False)
    c_f = float(without["friction_damping_Ns_per_m"])
    sigma = float(without["stroke_velocity_rms_m_s"])
    ref = _grid_added_variances(road, c_f, sigma)
    got = {"var_acc_w": float(with_r["comfort_weighted_rms_m_s2"] ** 2
                              - without["comfort_weighted_rms_m_s2"] ** 2),
           "var_v": float(with_r["stroke_velocity_rms_m_s"] ** 2 - sigma ** 2),
           "var_i": float((with_r["power_W"] - without["power_W"])
                          / HarvesterParams().load_ohm)}
    g = 9.80665 * VEHICLE.total_mass_kg / VEHICLE.tyre_stiffness_N_per_m
    got["var_tyre"] = float((with_r["road_holding"] ** 2 - without["road_holding"] ** 2) * g * g)
    for key, want in ref.items():
        assert want > 0.0
        assert got[key] == pytest.approx(want, rel=0.03), key
    # the correction is not small here: comfort up by more than 1 %
    assert float(with_r["comfort"] / without["comfort"]) > 1.01


def test_residual_keeps_the_dissipation_and_lowers_the_friction_power():
    # an internal force does not change what the road puts in (the dissipation bound,
    # the road input power); the residual feeds the motion it drives: E[r v] < 0
    road = RoadParams("C", 50.0)
    design = {"load_ohm": np.array([10.0, 47.0, 300.0]),
              "lead_mm_per_rev": np.array([8.0, 12.0, 16.0])}
    with_r = friction_metrics(VEHICLE, road, design, FRICTION_X2)
    without = friction_metrics(VEHICLE, road, design, FRICTION_X2, residual=False)
    np.testing.assert_allclose(with_r["dissipated_power_W"], without["dissipated_power_W"],
                               rtol=2e-3)
    np.testing.assert_allclose(with_r["dissipated_power_W"], without["dissipation_bound_W"],
                               rtol=5e-3)
    assert np.all(with_r["friction_power_W"] < without["friction_power_W"])
    for key in ("comfort", "road_holding", "power_W", "stroke_velocity_rms_m_s"):
        assert np.all(with_r[key] > without[key]), key


@pytest.mark.parametrize("scale, sigma", [(2.0, 0.02), (2.0, 0.1), (0.5, 0.003)])
def test_hermite_coefficients_are_the_small_rho_expansion(scale, sigma):
    # R_r(ρ) = c₃ρ³ + c₅ρ⁵ + O(ρ⁷): no ρ¹ term (r is uncorrelated with v), from a strut
    # almost at rest (σ = 3 mm/s, the Stribeck humps dominate) to a fast one
    fr = friction_array([scaled_friction(load_truth(embedded_data_dir("bench_prototype"))
                                         ["friction"], scale)])
    s, r = np.array([sigma]), np.array([LEAD])
    c3, c5 = hermite_coefficients(s, fr, r)[0]
    rho = np.array([[1e-3, 0.02, 0.05]])
    got = residual_autocovariance(rho, s, fr, r)[0]
    assert got[0] == pytest.approx(c3 * 1e-9, rel=1e-4)     # no ρ¹ term at ρ = 0.001
    np.testing.assert_allclose(got, c3 * rho[0] ** 3 + c5 * rho[0] ** 5, rtol=5e-4)


def test_power_laplace_matches_quadrature():
    # ∫₀^∞ (c₃ρ̃³ + c₅ρ̃⁵) e^{μτ} dτ in closed form against scipy's quad, ρ̃ a sum of two
    # damped oscillations (conjugate pairs, real ρ̃), μ one of the poles
    from scipy import integrate
    lam = np.array([[-0.6 + 25.0j, -0.6 - 25.0j, -1.6 + 3.8j, -1.6 - 3.8j]])
    alpha = np.array([[0.2 - 0.1j, 0.2 + 0.1j, 0.3 + 0.05j, 0.3 - 0.05j]])
    coef = np.array([[7.0, 3.0]])
    mu = lam[:, [0, 2]]
    got = _power_laplace(alpha, lam, coef, mu)[0]

    def rho(t):
        return float(np.real(np.sum(alpha[0] * np.exp(lam[0] * t))))
    for k, m in enumerate(mu[0]):
        def f(t, part, m=m):
            p = 7.0 * rho(t) ** 3 + 3.0 * rho(t) ** 5
            z = p * np.exp(m * t)
            return z.real if part == 0 else z.imag
        want = [integrate.quad(f, 0.0, 40.0, args=(part,), limit=4000, epsabs=1e-12)[0]
                for part in (0, 1)]
        assert got[k] == pytest.approx(complex(*want), rel=1e-7, abs=1e-10)


def test_lag_grid_exponentials_and_validation():
    grid = LagGrid()
    lam = np.array([[-1.0 + 25.0j, -3.0 + 5.0j], [-0.5 + 60.0j, -100.0 + 1.0j]])
    want = np.exp(grid.tau_s[:, None, None] * lam[None])
    np.testing.assert_allclose(grid.exponentials(lam), want, rtol=1e-9, atol=1e-12)
    with pytest.raises(ValueError, match="sub >= 1"):
        LagGrid(sub=0)


def test_lightly_damped_design_is_resolved(monkeypatch):
    # heavy inertia, weak electrical damping, friction × 2 on a smooth slow road: the
    # strut nearly locks and the whole car bounces on the tyre at 4 Hz with ζ ≈ 0.02 —
    # the residual's autocovariance oscillates for seconds.  Integrating R_r itself on
    # the geometric lags aliased this (power −1.5 %, comfort −0.9 % against a converged
    # grid); with c₃ρ̃³ + c₅ρ̃⁵ exact, the default lags agree with 1440 lags to 0.4 %
    design = {"total_inertia_gcm2": np.array([8450.0]), "lead_mm_per_rev": np.array([6.14]),
              "speed_constant_rpm_per_V": np.array([42.2]), "load_ohm": np.array([1350.0])}
    road = RoadParams("B", 30.0)
    lin = friction_metrics(VEHICLE, road, design, FRICTION_X2, residual=False)
    got = friction_metrics(VEHICLE, road, design, FRICTION_X2)
    fine = LagGrid(t0_s=1e-7, octaves=30, sub=48)
    monkeypatch.setattr(equivalent_module, "residual_variances",
                        lambda *a: residual_variances(*a, lags=fine))
    ref = friction_metrics(VEHICLE, road, design, FRICTION_X2)
    assert ref["power_W"][0] / lin["power_W"][0] > 1.02       # the residual matters here
    for key in ("comfort", "road_holding", "power_W", "stroke_velocity_rms_m_s"):
        assert got[key][0] == pytest.approx(ref[key][0], rel=4e-3), key
