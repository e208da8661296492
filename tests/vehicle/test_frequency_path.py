"""Frequency path: W_k, ISO 8608 PSD and bound, exact linear metrics (vectorised)."""

import math

import numpy as np
import pytest
import scipy.linalg as sl

from ehsa_opt.vehicle.iso2631 import (ISO2631_WK_TABLE, wk_abs2, wk_exact, wk_exact_tf, wk_fit_error,
                              wk_state_space)
from ehsa_opt.vehicle.frequency_path import METRIC_KEYS, linear_metrics
from ehsa_opt.physics.params import HarvesterParams, ParameterError, RoadParams, VehicleParams
from ehsa_opt.vehicle.road import dissipation_bound_W, road_psd_m3, road_velocity_psd


# ----------------------------------------------------------------------------- W_k
def test_wk_matches_iso2631_table_within_2_percent():
    f = np.array(list(ISO2631_WK_TABLE))
    table = np.array(list(ISO2631_WK_TABLE.values()))
    got = np.abs(wk_exact(f))
    assert np.max(np.abs(got / table - 1.0)) < 0.02
    assert abs(abs(wk_exact(1.0)) - 0.482) < 0.002
    assert abs(abs(wk_exact(6.3)) - 1.054) < 0.002
    assert np.allclose(wk_abs2(f), got ** 2, rtol=1e-12)


def test_wk_tf_polynomials_equal_the_product_form():
    num, den = wk_exact_tf()
    f = np.logspace(-1, 2.5, 40)
    s = 2j * np.pi * f
    assert np.allclose(np.polyval(num, s) / np.polyval(den, s), wk_exact(f), rtol=1e-9)


def test_wk_state_space_fit_is_stable_and_reports_its_error():
    for order, tol in ((6, 0.05), (8, 1e-6)):
        fit = wk_state_space(order)
        assert np.all(np.linalg.eigvals(fit.A).real < 0.0)
        err = wk_fit_error(order)
        assert err["max_rel_error"] < tol
        f = np.logspace(np.log10(0.5), np.log10(80.0), 300)
        rel = np.abs(np.abs(fit.response(f)) / np.abs(wk_exact(f)) - 1.0)
        assert rel.max() == pytest.approx(err["max_rel_error"], rel=1e-6)
    # a coarse fit honestly reports a larger error
    assert wk_fit_error(4)["max_rel_error"] > wk_fit_error(6)["max_rel_error"]


def test_time_domain_wk_filter_matches_exact_weighting_within_fit_error():
    from ehsa_opt.vehicle.iso2631 import weighted_rms_fft, wk_filter
    rng = np.random.default_rng(0)
    fs = 1000.0
    x = rng.normal(size=60000)
    # band-limit to 0.5–80 Hz (the fit's band) so the comparison is about the band
    spec = np.fft.rfft(x)
    f = np.fft.rfftfreq(x.size, 1 / fs)
    spec[(f < 0.5) | (f > 80.0)] = 0.0
    x = np.fft.irfft(spec, x.size)
    exact = weighted_rms_fft(x, fs)
    for order in (6, 8):
        y = wk_filter(x, fs, order)[5000:]
        tol = wk_fit_error(order)["max_rel_error"] + 0.02  # + Tustin warping and window
        assert np.sqrt(np.mean(y ** 2)) == pytest.approx(exact, rel=tol)


# ----------------------------------------------------------------------------- road PSD
def test_road_psd_and_bound():
    assert road_psd_m3(0.1, "C") == pytest.approx(256e-6)
    assert road_psd_m3(0.2, "C") == pytest.approx(64e-6)
    assert road_psd_m3(0.1, 1e-6) == pytest.approx(1e-6)
    bound = dissipation_bound_W(VehicleParams(), RoadParams(iso_class="C", speed_km_per_h=100))
    assert bound == pytest.approx(140.37, abs=0.05)  # the dissipation bound: 140 W
    assert dissipation_bound_W(VehicleParams(), RoadParams(profile_csv="x.csv")) is None
    with pytest.raises(ParameterError, match="ISO 8608"):
        road_psd_m3(0.1, "Z")


# ----------------------------------------------------------------------------- metrics
def _lyapunov_reference(vehicle, road, h):
    """Independent check: exact variances by a Lyapunov equation (full band).

    States (x2, x1 − x0, v2, v1, i, W_k filter states); input road velocity,
    white with one-sided PSD Φ, i.e. intensity Φ/2.
    """
    m2, m1 = vehicle.sprung_mass_kg, vehicle.unsprung_mass_kg
    k2, k1 = vehicle.suspension_stiffness_N_per_m, vehicle.tyre_stiffness_N_per_m
    r, meq = h.lead_m_per_rad, h.equivalent_mass_kg()
    ke, kt, L, R = (h.voltage_constant_Vs_per_rad, h.torque_constant_Nm_per_A, h.inductance_H,
                    h.load_ohm + h.internal_resistance_ohm)
    mm = np.array([[m2 + meq, -meq], [-meq, m1 + meq]])
    minv = np.linalg.inv(mm)
    # forces on (m2, m1) from x2, δ = x1 − x0 (x1 = δ + x0; x0 drops out of k2 via x2 − x1)
    # spring k2: −k2 (x2 − x1) on m2, +k2 (x2 − x1) on m1; tyre −k1 δ on m1; electric ∓ kt i / r.
    # Use states z = (x2 − x1 =: y, δ, v2, v1, i): ẏ = v2 − v1, δ̇ = v1 − v0.
    a = np.zeros((5, 5))
    b = np.zeros(5)
    a[0, 2], a[0, 3] = 1.0, -1.0
    a[1, 3], b[1] = 1.0, -1.0
    force = np.array([[-k2, 0.0, 0.0, 0.0, -kt / r], [k2, -k1, 0.0, 0.0, kt / r]])
    a[2:4, :] = minv @ force
    a[4, 2], a[4, 3], a[4, 4] = ke / (r * L), -ke / (r * L), -R / L
    num, den = wk_exact_tf()
    from scipy import signal
    fa, fb, fc, fd = signal.tf2ss(num, den)
    nf = fa.shape[0]
    big = np.zeros((5 + nf, 5 + nf))
    big[:5, :5] = a
    big[5:, :5] = fb @ a[2:3, :]          # W_k filter driven by ẍ2 = a[2] z
    big[5:, 5:] = fa
    bb = np.concatenate([b, np.zeros(nf)])[:, None]
    q = road_velocity_psd(road) / 2.0
    p = sl.solve_continuous_lyapunov(big, -q * bb @ bb.T)
    c_acc = np.concatenate([fd[0, 0] * a[2, :], fc[0]])
    var_acc = c_acc @ p @ c_acc
    var_tyre = p[1, 1]
    var_i = p[4, 4]
    g = 9.80665
    return {"comfort_weighted_rms_m_s2": math.sqrt(var_acc),
            "road_holding": k1 * math.sqrt(var_tyre) / (g * vehicle.total_mass_kg),
            "power_W": h.load_ohm * var_i}


@pytest.mark.parametrize("preset", ["passenger_car", "single_seater"])
def test_linear_metrics_match_an_independent_lyapunov_solution(preset):
    vehicle, road = VehicleParams.preset(preset), RoadParams(iso_class="C", speed_km_per_h=70)
    for h in (HarvesterParams(), HarvesterParams(load_ohm=300.0, lead_mm_per_rev=12.0),
              HarvesterParams(load_ohm=5.0, motor_inertia_gcm2=2000.0)):
        ref = _lyapunov_reference(vehicle, road, h)
        got = linear_metrics(vehicle, road, {k: getattr(h, k) for k in
                                             ("load_ohm", "lead_mm_per_rev",
                                              "motor_inertia_gcm2")},
                             f_min_hz=1e-3, f_max_hz=1e4)
        for key, value in ref.items():
            assert float(got[key]) == pytest.approx(value, rel=5e-3), (preset, h, key)


@pytest.mark.parametrize("preset", ["passenger_car", "single_seater"])
def test_dissipated_power_matches_bound_and_efficiency_is_load_share(preset):
    vehicle = VehicleParams.preset(preset)
    road = RoadParams(iso_class="C", speed_km_per_h=100)
    rng = np.random.default_rng(1)
    n = 200
    design = {"total_inertia_gcm2": rng.uniform(250, 1e4, n),
              "lead_mm_per_rev": rng.uniform(5, 20, n),
              "speed_constant_rpm_per_V": 10 ** rng.uniform(math.log10(29.8), math.log10(11900), n),
              "load_ohm": 10 ** rng.uniform(0, 4, n)}
    m = linear_metrics(vehicle, road, design)
    bound = dissipation_bound_W(vehicle, road)
    assert np.all(m["dissipation_bound_W"] == bound)
    assert np.max(np.abs(m["dissipated_power_W"] / bound - 1.0)) < 0.03
    eff = design["load_ohm"] / (design["load_ohm"] + 6.6)
    assert np.allclose(m["efficiency"], eff, rtol=1e-9)
    assert np.all(m["power_W"] <= bound * 1.03)


def test_default_design_values_and_broadcasting():
    vehicle, road = VehicleParams(), RoadParams(iso_class="C", speed_km_per_h=100)
    m = linear_metrics(vehicle, road)
    assert set(METRIC_KEYS) <= set(m)
    assert all(np.shape(v) == () for v in m.values())
    # about 2.7 m/s² for the prototype on the passenger car
    assert 2.4 < float(m["comfort_weighted_rms_m_s2"]) < 3.0
    assert float(m["comfort"]) == pytest.approx(float(m["comfort_weighted_rms_m_s2"]) / 9.80665)
    assert float(m["power_dimensionless"]) == pytest.approx(
        float(m["power_W"]) / (9.80665 * 420.0 * 100 / 3.6))
    re = np.array([10.0, 47.0, 300.0])[:, None]
    lead = np.array([5.0, 10.0])[None, :]
    mb = linear_metrics(vehicle, road, {"load_ohm": re, "lead_mm_per_rev": lead})
    assert mb["power_W"].shape == (3, 2)
    single = linear_metrics(vehicle, road, {"load_ohm": 300.0, "lead_mm_per_rev": 10.0})
    assert float(single["comfort"]) == pytest.approx(mb["comfort"][2, 1], rel=1e-12)


def test_alternative_design_keys_are_equivalent():
    vehicle, road = VehicleParams(), RoadParams()
    kn = 60.0 / (2 * math.pi * 0.137)
    a = linear_metrics(vehicle, road, {"total_inertia_gcm2": 301.0,
                                       "speed_constant_rpm_per_V": kn})
    b = linear_metrics(vehicle, road, {})
    for key in METRIC_KEYS:
        assert float(a[key]) == pytest.approx(float(b[key]), rel=1e-9)


def test_open_circuit_has_no_power():
    m = linear_metrics(VehicleParams(), RoadParams(), {"load_ohm": [math.inf, 47.0]})
    assert m["power_W"][0] == 0.0 and m["efficiency"][0] == 0.0
    assert m["power_W"][1] > 0.0


def test_bad_design_input_is_refused():
    vehicle, road = VehicleParams(), RoadParams()
    with pytest.raises(ParameterError, match="did you mean 'load_ohm'"):
        linear_metrics(vehicle, road, {"load_ohms": 10.0})
    with pytest.raises(ParameterError, match="lead_mm_per_rev"):
        linear_metrics(vehicle, road, {"lead_mm_per_rev": [5.0, -1.0]})
    with pytest.raises(ParameterError, match="not both"):
        linear_metrics(vehicle, road, {"total_inertia_gcm2": 300.0, "motor_inertia_gcm2": 1.0})
    with pytest.raises(ValueError, match="measured profile"):
        linear_metrics(vehicle, RoadParams(profile_csv="road.csv"))
