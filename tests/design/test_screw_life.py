"""The ball screw's fatigue life as a design limit: the L10 formula, the revolution-weighted
cubic mean load (analytic answers on constructed signals and a constructed road), the
Gaussian bound of the frequency path, and the limit in results and problem files."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ehsa_opt.design.config import load_design_config
from ehsa_opt.design.limit_check import limits_on_roads
from ehsa_opt.design.limits import (GAUSSIAN_CUBIC_MEAN_FACTOR, LimitSettings,
                                    explain_violations, revolution_weighted_mean_load)
from ehsa_opt.design.selection import SelectionObjectives
from ehsa_opt.physics.ball_screw import (BallScrew, allowable_mean_load, l10_revolutions,
                                         load_screws)
from ehsa_opt.physics.motor import CatalogueMotor, RatedLimits
from ehsa_opt.physics.params import HarvesterParams, ParameterError, VehicleParams
from ehsa_opt.vehicle.frequency_path import linear_frequency_response
from tests.design.test_hardware_limits import _sine_road
from tests.paths import ROOT

VEHICLE = VehicleParams.preset("passenger_car")


def test_l10_life_and_its_inverse():
    # (C / F)^3 x 10^6: a tenth of the rating lasts 10^9 revolutions
    assert l10_revolutions(6500.0, 650.0) == pytest.approx(1e9)
    assert allowable_mean_load(6500.0, 1e9) == pytest.approx(650.0)
    f = np.array([100.0, 900.0, 4000.0])
    assert allowable_mean_load(9100.0, l10_revolutions(9100.0, f)) == pytest.approx(f)
    assert all(s.dynamic_load_rating_N > 0 for s in load_screws())


def test_revolution_weighted_mean_load_of_a_sine():
    """F = A sin θ with the speed ∝ |sin θ|: F_m³ = A³ E|sin|⁴ / E|sin| = A³ 3π/16."""
    th = np.linspace(0.0, 2 * np.pi, 400_001)[:-1]
    got = revolution_weighted_mean_load(300.0 * np.sin(th)[None, :], 50.0 * np.sin(th))
    assert got[0] == pytest.approx(300.0 * (3 * np.pi / 16) ** (1 / 3), rel=1e-6)
    # a load constant in magnitude is its own mean, whatever the speed
    w = np.abs(np.sin(3 * th)) + 0.1
    assert revolution_weighted_mean_load(np.full(th.size, -70.0), w) == pytest.approx(70.0)


def test_gaussian_bound_is_exact_in_phase_and_conservative_otherwise():
    rng = np.random.default_rng(7)
    v = rng.standard_normal(2_000_000)
    # the generator's damping: F in phase with v, the bound is reached
    assert revolution_weighted_mean_load(2.5 * v, v) == pytest.approx(
        GAUSSIAN_CUBIC_MEAN_FACTOR * 2.5, rel=0.01)
    # an inertial force independent of v: (E|F|³)^(1/3) = (2 √(2/π))^(1/3) σ, below the bound
    f = 2.5 * rng.standard_normal(v.size)
    indep = revolution_weighted_mean_load(f, v)
    assert indep == pytest.approx((2 * math.sqrt(2 / math.pi)) ** (1 / 3) * 2.5, rel=0.01)
    assert indep < GAUSSIAN_CUBIC_MEAN_FACTOR * 2.5


def _sine_case(tmp_path, rating_N: float):
    f_hz, amp = 1.6, 0.02
    road = _sine_road(tmp_path, amp, 20.0 / f_hz)
    motor = CatalogueMotor("m", 0.1227, 0.365, 0.161e-3, 1340.0,
                           RatedLimits(480.0, 68.0, None), source="test",
                           max_speed_rpm=1e6, peak_current_A=1e3)
    screw = BallScrew("s", 16.0, 16.0, 13.3, 1e9, 250.0, "fixed-free", "test", rating_N)
    ev = SelectionObjectives(VEHICLE, road, HarvesterParams(), (motor,), (screw,),
                             stroke_limit_m=1.0)
    return ev, {"total_inertia_gcm2": np.array([1600.0]), "load_ohm": np.array([3.0])}, f_hz


def test_screw_life_on_a_constructed_road(tmp_path):
    """A sine road: the axial force m_eq a + (k_t / r) i and the screw speed are sines of
    the exact frequency response; their revolution-weighted cubic mean follows from the
    phase between them."""
    ev, design, f_hz = _sine_case(tmp_path, 5000.0)
    h = ev.harvesters(design)[0]
    r = h.lead_m_per_rad
    fr = linear_frequency_response(VEHICLE, h, [f_hz])
    v, i = fr["stroke_velocity"][0] * 0.02, fr["current"][0] * 0.02
    force = h.total_inertia_gcm2 * 1e-7 / r ** 2 * (2j * np.pi * f_hz) * v \
        + h.torque_constant_Nm_per_A / r * i
    th = np.linspace(0.0, 2 * np.pi, 200_001)[:-1]
    f_t = np.abs(force) * np.cos(th + np.angle(force))
    v_t = np.abs(v) * np.cos(th + np.angle(v))
    want = revolution_weighted_mean_load(f_t, v_t)
    chk = limits_on_roads(ev, design, [0], settle_s=8.0)
    assert chk["screw_mean_load_N"][0][0] == pytest.approx(want, rel=0.01)
    # the required revolutions: mean |speed| over the required distance at the road speed
    rev = np.mean(np.abs(v_t)) / (2 * np.pi * r) * 160e6 / 20.0
    allowed = allowable_mean_load(5000.0, rev)
    assert chk["worst_screw_load_over_allowed"] == pytest.approx(want / allowed, rel=0.01)
    # a rating below the load of the required life: the design is not within its limits
    low = float(5000.0 * 0.9 * want / allowed)       # allowed load 0.9 × the mean load
    ev_low = dataclasses.replace(ev, screws=(dataclasses.replace(
        ev.screws[0], dynamic_load_rating_N=low),))
    assert limits_on_roads(ev_low, design, [0], settle_s=8.0)["within"] == [False]


def test_frequency_path_bound_covers_the_time_domain_and_explains_itself(tmp_path):
    ev, design, _ = _sine_case(tmp_path, 5000.0)
    ev = dataclasses.replace(ev, road=dataclasses.replace(
        load_design_config(ROOT / "problems" / "paper_design.toml").road, seed=0))
    out = ev(design)
    assert "screw_life" in ev.constraint_names
    assert out["limit_screw_life"][0] > 0 and out["screw_mean_load_N"][0] > 0
    tight = dataclasses.replace(ev, screws=(dataclasses.replace(
        ev.screws[0], dynamic_load_rating_N=50.0),))
    o2 = tight(design)
    assert o2["constraint_screw_life"][0] > 0
    text = explain_violations(o2, tight.constraint_names)
    line = [t for t in text if t.startswith("screw_life")]
    assert line and "N against" in line[0] and "of the time" not in line[0]
    # a screw without a rating: no life limit
    unrated = dataclasses.replace(ev, screws=(dataclasses.replace(
        ev.screws[0], dynamic_load_rating_N=None),))
    assert "screw_life" not in unrated.constraint_names


def test_required_life_is_a_stated_setting(tmp_path):
    assert LimitSettings().screw_life_km == 160000.0
    with pytest.raises(ParameterError, match="screw_life_km"):
        LimitSettings(screw_life_km=0.0)
    text = (ROOT / "problems" / "paper_design.toml").read_text()
    prob = tmp_path / "p.toml"
    assert "screw_life_km = 160000.0" in text
    prob.write_text(text.replace("screw_life_km = 160000.0", "screw_life_km = -5.0"))
    with pytest.raises(ParameterError, match=r"p\.toml.*screw_life_km"):
        load_design_config(prob)
    prob.write_text(text.replace("screw_life_km = 160000.0", "screw_life_km = 50000.0"))
    assert load_design_config(prob).limit_settings.screw_life_km == 50000.0


def test_catalogue_selection_with_friction(tmp_path, capsys):
    """``[motor] model = "select"`` with a friction set: the friction-aware fast path for
    the objectives, every limit from the damped car, the held-out roads simulated with the
    same friction."""
    from ehsa_opt.cli import main
    from ehsa_opt.design.optimize import build_problem
    from ehsa_opt.design.selection import FrictionSelectionObjectives
    from ehsa_opt.physics.params import FrictionParams
    text = (ROOT / "problems" / "paper_design.toml").read_text()
    prob = tmp_path / "p.toml"
    prob.write_text(text.replace("length_m = 1000.0", "length_m = 300.0")
                    + "\n[friction]\nnut_coulomb_N = 20.0\nnut_breakaway_N = 25.0\n")
    cfg = load_design_config(prob)
    ev = build_problem(cfg).evaluator
    assert isinstance(ev, FrictionSelectionObjectives) and ev.mode == "at"
    plain = build_problem(cfg, frictions=()).evaluator
    design = {"total_inertia_gcm2": np.array([1500.0]), "load_ohm": np.array([2.0]),
              "motor": np.array([6.0]), "screw": np.array([1.0]), "winding": np.array([0.5])}
    a, b = ev(design), plain(design)
    # friction takes part of the road's dissipation: less current, less power, the same
    # hardware and every limit evaluated
    assert a["current_rms_A"][0] < b["current_rms_A"][0]
    assert a["power_W"][0] < b["power_W"][0]
    assert a["motor_index"][0] == b["motor_index"][0]
    assert all(np.isfinite(a[f"constraint_{c}"][0]) for c in ev.constraint_names)
    with pytest.raises(ParameterError, match="friction-mode"):
        dataclasses.replace(ev, frictions=(FrictionParams(),) * 2, mode="at")
    assert main(["optimize", str(prob), "--method", "nsga2", "--pop", "12", "--gens", "2",
                 "--out", str(tmp_path / "o")]) in (0, 1)
    res = __import__("json").loads((tmp_path / "o" / "result.json").read_text())
    assert res["friction"]["sets"][0]["nut_coulomb_N"] == 20.0
    assert res["constraints"] and "screw_life" in res["constraints"]
    roads = res["time_domain_check"]["held_out_roads"]
    assert roads["n_designs"] >= 1 and 0 not in roads["seeds"]
