"""The friction's non-linear residual force under Gaussian closure (issue 14)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.params import FrictionParams, HarvesterParams, RoadParams, VehicleParams
from ehsa_opt.vehicle.equivalent import friction_array, friction_metrics
from ehsa_opt.vehicle.fast_path_check import scaled_friction
from ehsa_opt.vehicle.iso2631 import wk_abs2
from ehsa_opt.vehicle.metrics import design_arrays
from ehsa_opt.vehicle.residual_force import residual_autocovariance
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
    # SPEC §4); the residual feeds the motion it drives: E[r v] < 0
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
