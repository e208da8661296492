"""Intervals over road realisations, batch means, digits, and the per-sample shares of
time beyond the validity limits."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ehsa_opt.physics.params import HarvesterParams, RoadParams, VehicleParams
from ehsa_opt.vehicle.frequency_path import linear_metrics
from ehsa_opt.vehicle.uncertainty import (batch_means_interval, format_interval,
                                          realisation_seeds, road_intervals, seed_interval)
from ehsa_opt.vehicle.validity import (EXCEEDANCE_FRACTION_LIMIT, TYRE_LIFT_FRACTION_LIMIT,
                                       SampleLimits, check_validity, exceedance_fractions)


def test_seed_interval_covers_a_known_mean_95_percent_of_the_time():
    rng = np.random.default_rng(1)
    hits = [seed_interval(rng.normal(3.0, 2.0, 6)).contains(3.0) for _ in range(2000)]
    assert 0.935 < np.mean(hits) < 0.965  # binomial sd 0.5 %
    with pytest.raises(ValueError, match="two finite"):
        seed_interval([1.0])


def test_batch_means_on_an_autocorrelated_record_cover_its_mean_and_count_its_samples():
    """AR(1) x_t = φ x_{t-1} + e_t: mean 0, effective samples N (1 − φ)/(1 + φ)."""
    from scipy.signal import lfilter
    rng = np.random.default_rng(2)
    phi, n = 0.9, 20_000
    hits, neff = [], []
    for _ in range(300):
        x = lfilter([1.0], [1.0, -phi], rng.standard_normal(n))
        iv = batch_means_interval(x, n_batches=20)
        hits.append(iv.contains(0.0))
        neff.append(iv.n_effective)
        naive = seed_interval(x)  # treats every sample as independent: far too narrow
    assert 0.91 < np.mean(hits) < 0.985
    assert np.median(neff) == pytest.approx(n * (1 - phi) / (1 + phi), rel=0.25)
    assert naive.half_width < 0.3 * iv.half_width
    with pytest.raises(ValueError, match="batches"):
        batch_means_interval(np.ones(10), n_batches=20)


def test_digits_follow_the_interval():
    assert format_interval(136.8412, 2.137, "W") == "136.8 ± 2.1 W"
    assert format_interval(1354.2, 451.0) == "1350 ± 450"
    assert format_interval(0.18641, 0.0043) == "0.1864 ± 0.0043"
    assert format_interval(97.49, 0.0) == "97.49 ± 0"


def test_road_intervals_cover_the_exact_linear_answer():
    """Frictionless quarter car: over Gaussian road realisations the expected power,
    comfort and road holding are the exact frequency path's; the 95 % intervals of five
    seeds cover them in (about) 95 % of repeated experiments (100 of them: 0.95/0.94/0.94
    measured; 20 here)."""
    vehicle, h = VehicleParams(), HarvesterParams(load_ohm=47.0)
    road = RoadParams(length_m=100.0, speed_km_per_h=100.0)
    exact = linear_metrics(vehicle, road, {"load_ohm": 47.0}, n_freq=2048)
    hits = {"power_W": 0, "comfort": 0, "road_holding": 0}
    for s in range(20):
        ri = road_intervals(vehicle, [h], None, replace(road, seed=s), n_seeds=5)
        for k in hits:
            hits[k] += ri.interval(k).contains(float(np.ravel(exact[k])[0]))
    assert all(v >= 16 for v in hits.values()), hits  # P(<= 15 of 20 | 95 %) = 0.3 %
    # the realisations differ (Gaussian amplitudes), are reproducible, and paired changes
    # of one design against itself are exactly zero
    assert np.ptp(ri.samples["power_W"]) > 0
    assert realisation_seeds(road, 3) == realisation_seeds(road, 3)
    assert realisation_seeds(road, 3) != realisation_seeds(replace(road, seed=1), 3)
    two = road_intervals(vehicle, [h, h.replace(load_ohm=20.0)], None, road, n_seeds=3)
    assert two.change("power_W", 0, 0).half_width == 0.0
    assert two.interval("power_W", 0).mean == pytest.approx(
        float(np.mean(two.samples["power_W"][:, 0])))


def test_tyre_lift_and_limit_shares_on_constructed_signals():
    """A sine tyre extension of amplitude A lifts the tyre (extension above the static
    compression δ) arccos(δ/A)/π of the time; a stroke, speed and voltage beyond their
    limits likewise."""
    t = np.linspace(0.0, 1.0, 100_000, endpoint=False)
    s = np.sin(2 * np.pi * 5 * t)[None]
    delta, amp = 0.02, 0.025
    lead = np.array([0.005 / (2 * np.pi)])  # 5 mm/rev
    v_amp = 0.6  # m/s: 7200 rpm on a 5 mm lead
    out = exceedance_fractions(0.12 * s, amp * s, v_amp * s, 60.0 * s, 3.0 * s,
                               static_deflection_m=delta, stroke_limit_m=0.1,
                               lead_m_per_rad=lead,
                               limits=SampleLimits(6000.0, 48.0, None))
    assert out["tyre_lift_fraction"][0] == pytest.approx(math.acos(delta / amp) / math.pi,
                                                         abs=1e-4)
    assert out["stroke_beyond_limit_fraction"][0] == pytest.approx(
        2 * math.acos(0.1 / 0.12) / math.pi, abs=1e-4)
    assert out["peak_screw_speed_rpm"][0] == pytest.approx(7200.0, rel=1e-6)
    assert out["screw_speed_beyond_limit_fraction"][0] == pytest.approx(
        2 * math.acos(6000 / 7200) / math.pi, abs=1e-4)
    assert out["voltage_beyond_limit_fraction"][0] == pytest.approx(
        2 * math.acos(48 / 60) / math.pi, abs=1e-4)
    assert np.isnan(out["current_beyond_limit_fraction"][0])
    # the table's validity: flagged by share of the time, with the numbers
    m = {"road_holding": [0.1], **out}
    v = check_validity(m, stroke_limit_m=0.1, sample_limits=SampleLimits(6000.0, 48.0))
    assert v.codes(0) == ["tyre_lift", "stroke_limit", "screw_speed", "voltage"]
    assert "tyre leaves the ground 20 % of the time" in v.cell(0)
    assert "screw speed beyond 6000 rpm" in v.cell(0)
    # below the stated shares: valid
    small = {k: np.array([0.5 * (TYRE_LIFT_FRACTION_LIMIT if k == "tyre_lift_fraction"
                                 else EXCEEDANCE_FRACTION_LIMIT)]) for k in out}
    assert check_validity({"road_holding": [0.1], **small}, stroke_limit_m=0.1).all_valid
    # the frequency path (rms only): the Gaussian share Q(1/η_rh) against the same limit
    g = check_validity({"road_holding": [0.30, 0.36]})
    assert g.valid.tolist() == [True, False] and "if Gaussian" in g.cell(1)


def test_fig13_flags_strokes_beyond_the_limit_and_road_psds_state_their_segments():
    """At 109 Ω the body mode needs a stroke of ~102 mm on the Fig 13 road (constant
    velocity amplitude 62.8 mm/s): beyond the ±100 mm limit, flagged; the exact linear
    stroke amplitude is the check."""
    from ehsa_opt.vehicle.frequency_path import linear_frequency_response
    from ehsa_opt.vehicle.studies import (WELCH_SEGMENTS, FrictionCases, road_study,
                                          stepped_sine_response)
    vehicle, h = VehicleParams(), HarvesterParams(load_ohm=109.0)
    none = FrictionCases({"none": None}, "frictionless")
    v_road = 2 * np.pi * 0.01
    f = np.array([1.1, 5.0])
    study = stepped_sine_response(vehicle, h, none, [109.0], f,
                                  velocity_amplitude_m_per_s=v_road, max_time_s=4.0)
    lin = linear_frequency_response(vehicle, h, f)
    exact = np.abs(lin["x2"] - lin["x1"]) * v_road / (2 * np.pi * f)
    assert study.peak_stroke_m[0, 0] == pytest.approx(exact, rel=0.01)
    assert exact[0] > 0.1 > exact[1]
    assert study.beyond_stroke_limit()[0, 0].tolist() == [True, False]
    road = road_study(vehicle, h, none, RoadParams(length_m=200.0), retune=False)
    assert road.road_psd["segments"] == WELCH_SEGMENTS
    assert road.stroke_velocity_psd["segments"] == WELCH_SEGMENTS
