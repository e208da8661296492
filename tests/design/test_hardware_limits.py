"""Real hardware in the design space: per-sample limits (analytic answers on constructed
roads), the catalogue variables, the power/efficiency invariant on feasible designs, and
results that name what makes them infeasible."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from scipy.stats import norm

from ehsa_opt.design.config import load_design_config
from ehsa_opt.design.limit_check import limits_on_roads
from ehsa_opt.design.limits import (LimitSettings, active_bounds, explain_violations,
                                    gaussian_fraction_beyond, rice_peak_quantile,
                                    sample_fractions)
from ehsa_opt.design.optimize import build_problem
from ehsa_opt.design.problem import DesignSpace
from ehsa_opt.design.selection import SelectionObjectives, realisable_winding
from ehsa_opt.physics.ball_screw import BallScrew, load_screws
from ehsa_opt.physics.motor import CatalogueMotor, RatedLimits, load_catalogue
from ehsa_opt.physics.params import HarvesterParams, RoadParams, VehicleParams
from ehsa_opt.vehicle.frequency_path import linear_frequency_response
from tests.paths import ROOT

PAPER = ROOT / "problems" / "paper_design.toml"
VEHICLE = VehicleParams.preset("passenger_car")


def test_fractions_of_a_sine_and_the_gaussian_level():
    t = np.linspace(0.0, 1.0, 200_001)[:-1]
    x = 2.0 * np.sin(2 * np.pi * 5 * t)
    got = sample_fractions({"a": x[None, :]}, {"a": [1.5]})["a"][0]
    assert got == pytest.approx(1 - 2 / np.pi * np.arcsin(0.75), abs=1e-4)   # |x| > 1.5
    st = LimitSettings(time_fraction=2e-3)
    # a Gaussian response at exactly the level the constraint allows is beyond it
    # time_fraction of the time
    assert gaussian_fraction_beyond(st.z_two_sided, 1.0) == pytest.approx(2e-3)
    assert gaussian_fraction_beyond(1.0, 1.0 / st.z_tyre_lift, False) == pytest.approx(
        st.tyre_lift_fraction)
    with pytest.raises(Exception, match="time_fraction"):
        LimitSettings(time_fraction=0.7)


def test_rice_peak_of_a_gaussian_process_matches_simulated_maxima():
    """Band-limited Gaussian noise (1-3 Hz, random phases): the median of max|x| over
    T = 60 s across realisations against Rice's formula."""
    rng = np.random.default_rng(4)
    fs, T = 50.0, 60.0
    n = int(fs * T)
    f = np.fft.rfftfreq(n, 1 / fs)
    band = (f >= 1.0) & (f <= 3.0)
    maxima = []
    for _ in range(300):
        spec = np.zeros(f.size, complex)
        spec[band] = np.exp(1j * rng.uniform(0, 2 * np.pi, band.sum()))
        x = np.fft.irfft(spec, n)
        maxima.append(np.max(np.abs(x)) / np.std(x))
    f = f[band]
    sigma_rate = 2 * np.pi * np.sqrt(np.mean(f ** 2))  # rms derivative of unit process
    med = rice_peak_quantile(1.0, sigma_rate, T, 0.5)
    q90 = rice_peak_quantile(1.0, sigma_rate, T, 0.9)
    assert np.median(maxima) == pytest.approx(float(med), rel=0.04)
    assert np.quantile(maxima, 0.9) == pytest.approx(float(q90), rel=0.06)


def _sine_road(tmp_path, amplitude_m, wavelength_m, length_m=500.0):
    d = np.arange(0.0, length_m + 0.05, 0.05)
    csv = tmp_path / "sine.csv"
    csv.write_text("distance_m,elevation_m\n" + "\n".join(
        f"{a:.4f},{amplitude_m * math.sin(2 * math.pi * a / wavelength_m):.9f}" for a in d))
    return RoadParams(profile_csv=str(csv), speed_km_per_h=72.0, length_m=length_m)


def test_limits_per_sample_on_a_constructed_road(tmp_path):
    """A sine road: every response is a sine of the amplitude the exact frequency response
    gives, so the fraction of time beyond a limit L is 1 − (2/π) arcsin(L/A)."""
    f_hz, amp = 1.6, 0.02
    road = _sine_road(tmp_path, amp, 20.0 / f_hz)            # 72 km/h = 20 m/s
    motor = CatalogueMotor("m", 0.1227, 0.365, 0.161e-3, 1340.0,
                           RatedLimits(48.0, 6.8, None), source="test",
                           max_speed_rpm=1.0, peak_current_A=1.0)
    screw = BallScrew("s", 16.0, 16.0, 13.3, 1.0, 250.0, "fixed-free", "test")
    ev = SelectionObjectives(VEHICLE, road, HarvesterParams(), (motor,), (screw,),
                             stroke_limit_m=1.0)
    design = {"total_inertia_gcm2": np.array([1600.0]), "load_ohm": np.array([3.0])}
    h = ev.harvesters(design)[0]
    fr = {k: abs(v[0]) * amp for k, v in
          linear_frequency_response(VEHICLE, h, [f_hz]).items()}
    rpm_amp = fr["stroke_velocity"] / (h.lead_mm_per_rev * 1e-3) * 60.0
    stroke_amp = abs(linear_frequency_response(VEHICLE, h, [f_hz])["x2"][0]
                     - linear_frequency_response(VEHICLE, h, [f_hz])["x1"][0]) * amp
    share = {"motor_speed": 0.8, "screw_speed": 0.6, "peak_current": 0.7, "stroke": 0.5}
    motor = dataclasses.replace(motor, max_speed_rpm=share["motor_speed"] * rpm_amp,
                                peak_current_A=share["peak_current"] * fr["current"],
                                max_voltage_V=10 * fr["voltage"])
    screw = dataclasses.replace(screw, dn_limit=share["screw_speed"] * rpm_amp * 16.0)
    ev = dataclasses.replace(ev, motors=(motor,), screws=(screw,),
                             stroke_limit_m=share["stroke"] * stroke_amp)
    chk = limits_on_roads(ev, design, [0], settle_s=8.0)
    for name, s in share.items():
        assert chk["fractions"][name][0][0] == pytest.approx(
            1 - 2 / np.pi * np.arcsin(s), abs=0.01), name
    assert chk["current_rms_A"][0][0] == pytest.approx(fr["current"] / math.sqrt(2), rel=0.01)
    assert chk["peak_voltage_V"][0][0] == pytest.approx(fr["voltage"], rel=0.01)
    assert chk["fractions"]["rated_voltage"][0][0] == 0.0  # limit at 10 × the amplitude
    assert chk["n_within"] == 0                                # every hard limit exceeded


def _paper_select(**over):
    cfg = load_design_config(PAPER)
    return dataclasses.replace(cfg, **over) if over else cfg


def test_catalogue_variables_and_the_power_efficiency_invariant():
    """Random designs of the selection problem: motors and screws as integer variables;
    on the feasible ones (frictionless) power / efficiency is the road's dissipation bound
    P_diss for every design (all the damper absorbs is electrical)."""
    p = build_problem(_paper_select())
    sp = p.space
    assert {"motor", "screw", "winding"} <= set(sp.names)
    assert "speed_constant_rpm_per_V" not in sp.names and "lead_mm_per_rev" not in sp.names
    U = np.random.default_rng(0).random((4000, sp.n))
    # J_t 1.4e3–2.4e3 g cm², R_e 1.5–15 Ω: where the frames that can absorb the road's
    # ~100 W (the RE 65) are within their limits; every motor and screw still drawn
    U[:, sp.names.index("total_inertia_gcm2")] = 0.467 + 0.146 * U[:, 0]
    U[:, sp.names.index("load_ohm")] = 0.044 + 0.25 * U[:, 1]
    d = sp.from_unit(U)
    assert set(np.unique(d["motor"])) == set(range(len(load_catalogue())))
    out = p.evaluate_design(d)
    G = np.column_stack([out[f"constraint_{c}"] for c in p.constraint_names])
    ok = np.all(G <= 0, axis=1)
    assert ok.sum() >= 10
    inv = out["power_W"][ok] / out["efficiency"][ok]
    assert np.allclose(inv, out["dissipation_bound_W"][ok], rtol=2e-3)
    # the lead is the chosen screw's; k_n within the chosen motor's winding range
    screws, motors = load_screws(), load_catalogue()
    lead = np.array([screws[int(i)].lead_mm_per_rev for i in d["screw"]])
    assert np.array_equal(out["lead_mm_per_rev"], lead)
    for i in np.flatnonzero(ok)[:20]:
        m = motors[int(d["motor"][i])]
        lo, hi = m.speed_constant_range_rpm_per_V or (m.speed_constant_rpm_per_V,) * 2
        assert lo * (1 - 1e-9) <= out["speed_constant_rpm_per_V"][i] <= hi * (1 + 1e-9)


def test_goal_attainment_selects_hardware_within_its_limits():
    from ehsa_opt.design.optimize import optimize
    cfg = _paper_select()
    cfg = dataclasses.replace(cfg, goal_attainment=dataclasses.replace(
        cfg.goal_attainment, n_starts=2))
    rec = optimize(cfg, "goal-attainment", check_time_domain=False).record
    assert rec["success"] and rec["feasible"] and not rec["violations"]
    assert rec["hardware"]["motor"] in [m.name for m in load_catalogue()]
    # not the prototype: its motor is in no catalogue, and its lead is not a screw's
    assert rec["hardware"]["lead_mm_per_rev"] != cfg.harvester.lead_mm_per_rev
    assert set(rec["limits"]) == set(rec["constraints"])


def test_infeasible_result_names_each_limit_with_value_and_margin(tmp_path, capsys):
    """A user's small generator with identified friction: each violated limit is named
    with its value, limit and margin (no empty constraint table), and a variable at a
    bound of the box is reported."""
    from ehsa_opt.cli import main
    cat = tmp_path / "motors.toml"
    cat.write_text('[[motor]]\nname = "My 24 V generator"\nspeed_constant_rpm_per_V = 300.0\n'
                   'internal_resistance_ohm = 1.0\ninductance_H = 2e-4\n'
                   'motor_inertia_gcm2 = 50.0\nrated_voltage_V = 24.0\n'
                   'rated_current_A = 1.0\nmax_speed_rpm = 6000.0\nsource = "test"\n')
    text = (ROOT / "problems" / "catalogue_design.toml").read_text()
    prob = tmp_path / "p.toml"
    prob.write_text(text.replace('catalogue = "dc_generators"', f'catalogue = "{cat}"')
                    .replace("n_starts = 6", "n_starts = 1")
                    .replace("length_m = 1000.0", "length_m = 300.0")
                    + "\n[friction]\nnut_coulomb_N = 20.0\nnut_breakaway_N = 25.0\n")
    assert main(["optimize", str(prob), "--out", str(tmp_path / "o")]) in (0, 1)
    out = capsys.readouterr().out
    res = json.loads((tmp_path / "o" / "result.json").read_text())
    row = res["catalogue"][0]
    assert not row["feasible"] and row["constraints"]          # limits were evaluated
    bad = [c for c, v in row["constraints"].items() if v > 1e-6]
    assert bad and len(row["violations"]) == len(bad)
    for c, text_ in zip(bad, row["violations"]):
        assert text_.startswith(f"{c}: ") and " against " in text_ and "%" in text_
    assert "INFEASIBLE: " in out and bad[0] in out


def test_active_bounds_and_explanations():
    sp = DesignSpace(("a", "b", "k"), (1.0, 0.0, 0.0), (10.0, 1.0, 3.0), (True, False, False),
                     "box", (False, False, True))
    assert active_bounds(sp, {"a": 1.0, "b": 0.5, "k": 0.0}) == ["a at its lower bound 1"]
    assert active_bounds(sp, {"a": 5.0, "b": 1.0, "k": 3.0}) == ["b at its upper bound 1"]
    out = {"constraint_stroke": np.array([0.25]), "value_stroke": np.array([0.125]),
           "limit_stroke": np.array([0.1]), "fraction_stroke": np.array([0.004]),
           "constraint_rated_current": np.array([-0.5])}
    msg = explain_violations(out, ("stroke", "rated_current"))
    assert msg == ["stroke: stroke |x2 − x1| vs the suspension's stroke limit: 0.125 m "
                   "against 0.1 m (+25.0 %), beyond it 0.4 % of the time"]


def test_screw_limits_and_the_realisable_winding():
    s = load_screws()[0]
    # n_c = 3.4 × 12.9 / 250² × 1e7 (fixed-free); DN / d0 = 70 000 / 16
    assert s.critical_speed_rpm == pytest.approx(3.4 * 12.9 / 250 ** 2 * 1e7)
    assert s.max_speed_rpm == pytest.approx(min(70000 / 16, 0.8 * s.critical_speed_rpm))
    w = realisable_winding(29.8, load_catalogue())  # the paper's lowest k_n
    assert w["motor"].startswith("maxon RE 65")
    assert w["speed_constant_rpm_per_V"] == pytest.approx(38.9)   # the series' lowest
    assert w["internal_resistance_ohm"] == pytest.approx(0.365 * (77.8 / 38.9) ** 2)


def test_rice_quantile_is_monotone_and_scales_with_sigma():
    q = rice_peak_quantile(np.array([1.0, 2.0]), np.array([10.0, 20.0]), 50.0, 0.95)
    assert q[1] == pytest.approx(2 * q[0])
    assert rice_peak_quantile(1.0, 10.0, 50.0, 0.5) < q[0]
    # the design's hard limits and the vehicle studies' validity use one standard: a
    # Gaussian response within ±3.5 σ, the tyre lifting Q(3) of the time
    from ehsa_opt.vehicle.validity import GAUSSIAN_PEAK_FACTOR
    assert LimitSettings().z_two_sided == pytest.approx(GAUSSIAN_PEAK_FACTOR)
    assert LimitSettings().z_tyre_lift == pytest.approx(3.0)


@pytest.mark.slow
def test_paper_design_front_spans_hardware_and_holds_on_held_out_roads(tmp_path):
    """The acceptance run: NSGA-II 40 × 25 on paper_design.toml."""
    from ehsa_opt.cli import main
    assert main(["optimize", str(PAPER), "--method", "nsga2", "--pop", "40", "--gens", "25",
                 "--out", str(tmp_path / "o")]) == 0
    res = json.loads((tmp_path / "o" / "result.json").read_text())
    assert res["n_feasible_front"] >= 30
    roads = res["time_domain_check"]["held_out_roads"]
    assert roads["seeds"] and res["road"] and 0 not in roads["seeds"]
    assert roads["n_within"] == roads["n_designs"]
    hv = res["hypervolume"]["held_out_roads"]
    assert hv["interval"][0] <= hv["mean"] <= hv["interval"][1]
