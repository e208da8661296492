"""Friction-aware fast path (stochastic equivalent linearisation) and robust design."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import integrate

from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
from ehsa_opt.physics.friction import simscape_friction
from ehsa_opt.physics.params import FrictionParams, ParameterError, RoadParams, VehicleParams
from ehsa_opt.vehicle.fast_path.linearisation import (
    friction_equivalent_damping_Ns_per_m,
    friction_metrics,
    law_equivalent_damping,
)
from ehsa_opt.vehicle.frequency_path import METRIC_KEYS, linear_metrics
from tests.paths import PAPER_DESIGN, paper_model_design

VEHICLE = VehicleParams()
DESIGNS = {"load_ohm": np.array([3.0, 47.0, 900.0]), "lead_mm_per_rev": np.array([5.0, 12.0,
                                                                                   20.0])}


def _truth(scale: float = 1.0) -> FrictionParams:
    t = load_truth(embedded_data_dir("bench_prototype"))["friction"]
    return FrictionParams(**{k: v * scale if "velocity" not in k else v for k, v in t.items()})


def test_zero_friction_equals_linear_path():
    # method="quadrature" is linear_metrics' own grid; the default integrates exactly
    # (residues), which linear_metrics approaches as its grid is refined (its error
    # at 256 points is up to 1e-3 for the weakly damped R_e = 900 ohm design)
    road = RoadParams("C", 70.0)
    lin = linear_metrics(VEHICLE, road, DESIGNS)
    fine = linear_metrics(VEHICLE, road, DESIGNS, n_freq=16384)
    for fr in (None, FrictionParams()):
        quad = friction_metrics(VEHICLE, road, DESIGNS, fr, method="quadrature")
        fast = friction_metrics(VEHICLE, road, DESIGNS, fr)
        for key in METRIC_KEYS:
            np.testing.assert_allclose(quad[key], lin[key], rtol=1e-9, atol=0.0)
            np.testing.assert_allclose(fast[key], fine[key], rtol=2e-4, atol=0.0)
        assert np.all(fast["friction_power_W"] == 0.0)
    zero = linear_metrics(VEHICLE, road, DESIGNS, friction_damping_Ns_per_m=0.0)
    for key in METRIC_KEYS:
        np.testing.assert_allclose(zero[key], lin[key], rtol=1e-12)


@pytest.mark.parametrize("sigma", [1e-3, 0.05, 0.4, 3.0])
def test_pure_coulomb_closed_form(sigma):
    fc = 37.0
    got = law_equivalent_damping(sigma, fc, fc, 1e-7, 0.0)  # u_Coul = 1e-8 m/s
    assert got == pytest.approx(fc * math.sqrt(2.0 / math.pi) / sigma, rel=1e-9)


@pytest.mark.parametrize("sigma", [2e-4, 3e-3, 0.02, 0.3, 2.0])
def test_full_law_matches_adaptive_quadrature(sigma):
    # E[F(u) u]/σ² by scipy's adaptive quadrature of the Simscape law itself
    p = (60.0, 40.0, 0.01, 150.0)

    def integrand(u: float) -> float:
        return (simscape_friction(u, *p) * u * math.exp(-0.5 * (u / sigma) ** 2)
                / (sigma * math.sqrt(2.0 * math.pi)))

    ref = 2.0 * integrate.quad(integrand, 0.0, 12.0 * sigma, points=[1e-3, 1e-2],
                               limit=400, epsabs=0.0, epsrel=1e-11)[0] / sigma ** 2
    assert law_equivalent_damping(sigma, *p) == pytest.approx(ref, rel=1e-6)


def test_viscous_friction_is_exact_damping():
    # a purely viscous nut law is linear: the fast path must equal the linear path
    # with that damping, with no approximation
    road = RoadParams("C", 100.0)
    fr = FrictionParams(nut_viscous_Ns_per_m=400.0, bearing_viscous_Nms_per_rad=2e-5)
    r = DESIGNS["lead_mm_per_rev"] * 1e-3 / (2 * math.pi)
    c = 400.0 + 2e-5 / r ** 2
    ref = linear_metrics(VEHICLE, road, DESIGNS, friction_damping_Ns_per_m=c)
    quad = friction_metrics(VEHICLE, road, DESIGNS, fr, method="quadrature")
    for key in METRIC_KEYS:
        np.testing.assert_allclose(quad[key], ref[key], rtol=1e-9)
    np.testing.assert_allclose(quad["friction_power_W"],
                               c * ref["stroke_velocity_rms_m_s"] ** 2, rtol=1e-9)
    fast = friction_metrics(VEHICLE, road, DESIGNS, fr)   # exact integration
    np.testing.assert_allclose(fast["friction_damping_Ns_per_m"], c, rtol=1e-12)
    fine = linear_metrics(VEHICLE, road, DESIGNS, friction_damping_Ns_per_m=c, n_freq=16384)
    for key in METRIC_KEYS:
        np.testing.assert_allclose(fast[key], fine[key], rtol=2e-4)
    np.testing.assert_allclose(fast["friction_power_W"],
                               c * fast["stroke_velocity_rms_m_s"] ** 2, rtol=1e-12)


def test_fixed_point_and_energy_balance():
    road = RoadParams("C", 70.0)
    fr = _truth(2.0)
    # the Gaussian fixed point (non_gaussian=False; the averaged one: test_averaging.py),
    # without the residual force (which adds to σ_v after the fixed point)
    fast = friction_metrics(VEHICLE, road, DESIGNS, fr, non_gaussian=False, residual=False)
    assert np.all(fast["converged"] == 1.0)
    r = DESIGNS["lead_mm_per_rev"] * 1e-3 / (2 * math.pi)
    sig = fast["stroke_velocity_rms_m_s"]
    cf = friction_equivalent_damping_Ns_per_m(sig, fr, r)
    again = linear_metrics(VEHICLE, road, DESIGNS, friction_damping_Ns_per_m=cf)
    # the fixed point holds to the accuracy of the iteration's coarser grid
    np.testing.assert_allclose(again["stroke_velocity_rms_m_s"], sig, rtol=1e-2)
    fine = friction_metrics(VEHICLE, road, DESIGNS, fr, iteration_n_freq=1024, n_freq=1024,
                            non_gaussian=False, residual=False)
    cf = friction_equivalent_damping_Ns_per_m(fine["stroke_velocity_rms_m_s"], fr, r)
    again = linear_metrics(VEHICLE, road, DESIGNS, friction_damping_Ns_per_m=cf, n_freq=1024)
    np.testing.assert_allclose(again["stroke_velocity_rms_m_s"],
                               fine["stroke_velocity_rms_m_s"], rtol=2e-3)
    # friction lowers the harvested power and the efficiency
    lin = linear_metrics(VEHICLE, road, DESIGNS)
    assert np.all(fast["power_W"] < lin["power_W"])
    assert np.all(fast["efficiency"] < lin["efficiency"])
    assert np.all(fast["dissipated_power_W"] > fast["friction_power_W"])


def test_fast_path_close_to_time_domain():
    from ehsa_opt.physics.params import HarvesterParams
    from ehsa_opt.vehicle.simulate import simulate_quarter_car
    road = RoadParams("C", 70.0, length_m=300.0, seed=3)
    h = HarvesterParams()
    fr = _truth(1.0)
    sim = simulate_quarter_car(VEHICLE, h, fr, road, keep_series=False)
    fast = friction_metrics(VEHICLE, road, {"load_ohm": h.load_ohm}, fr)
    for key in ("comfort", "road_holding", "power_W", "efficiency"):
        assert float(fast[key]) == pytest.approx(sim.metrics[key][0], rel=0.03), key


def test_robust_evaluator_modes_and_refusals():
    from ehsa_opt.design.robust import FrictionObjectives
    road = RoadParams("C", 70.0)
    lo, hi = _truth(0.5), _truth(2.0)
    design = {"load_ohm": np.array([10.0, 100.0])}
    at_lo = FrictionObjectives(VEHICLE, road, frictions=(lo,))(design)
    at_hi = FrictionObjectives(VEHICLE, road, frictions=(hi,))(design)
    worst = FrictionObjectives(VEHICLE, road, frictions=(lo, hi), mode="worst")(design)
    mean = FrictionObjectives(VEHICLE, road, frictions=(lo, hi), mode="mean")(design)
    for k in ("comfort", "road_holding", "inverse_power", "inverse_efficiency"):
        np.testing.assert_allclose(worst[k], np.maximum(at_lo[k], at_hi[k]))
        np.testing.assert_allclose(mean[k], 0.5 * (at_lo[k] + at_hi[k]))
    with pytest.raises(ParameterError, match="exactly one"):
        FrictionObjectives(VEHICLE, road, frictions=(lo, hi), mode="at")
    with pytest.raises(ParameterError, match="unknown mode"):
        FrictionObjectives(VEHICLE, road, frictions=(lo,), mode="median")
    with pytest.raises(ParameterError, match="at least one"):
        FrictionObjectives(VEHICLE, road)


def test_robust_optimum_no_worse_with_friction_in_time_domain(tmp_path):
    """The goal-attainment optimum designed with (max) friction beats, or ties, the
    frictionless optimum when both are simulated with that friction (time domain)."""
    from ehsa_opt.design.config import GoalAttainmentSettings, load_design_config
    from ehsa_opt.design.goal import solve_goal_attainment
    from ehsa_opt.design.optimize import build_problem, goals_and_weights
    from ehsa_opt.design.problem import OBJECTIVE_NAMES
    from ehsa_opt.design.robust import time_domain_objectives
    from ehsa_opt.design.sweep import harvesters_from

    cfg = load_design_config(PAPER_DESIGN)
    # the paper's space: the catalogue-variable model takes no friction sets
    cfg = dataclasses.replace(cfg, goal_attainment=GoalAttainmentSettings(n_starts=2),
                              n_freq=256, motor_model="paper")
    fr = _truth(2.0)
    robust = build_problem(cfg, frictions=(fr,))
    plain = build_problem(cfg)
    goals, weights, _ = goals_and_weights(cfg, robust)  # goals: the prototype with friction
    start = cfg.prototype_design
    ga_r = solve_goal_attainment(robust, goals, weights, start, n_starts=2, seed=0)
    ga_p = solve_goal_attainment(plain, goals, weights, start, n_starts=2, seed=0)
    assert ga_r.success
    designs = {k: np.array([ga_r.design[k], ga_p.design[k]]) for k in ga_r.design}
    road = dataclasses.replace(cfg.road, length_m=300.0, seed=5)
    td = time_domain_objectives(cfg.vehicle, road, harvesters_from(cfg.harvester, designs),
                                [fr], "at")
    w = np.abs(goals) if weights is None else weights
    gamma = np.max((np.stack([td[k] for k in OBJECTIVE_NAMES]) - goals[:, None])
                   / w[:, None], axis=0)
    print("time-domain attainment robust vs frictionless:", gamma)
    assert gamma[0] <= gamma[1] + 1e-3, gamma


def test_iso_class_level_upper_doubles_the_roughness(tmp_path):
    from ehsa_opt.datasets.problem_file import load_problem
    from ehsa_opt.vehicle.road import road_profile
    mean, upper = RoadParams("C", 70.0), RoadParams("C", 70.0, iso_class_level="upper")
    assert upper.roughness_m3 == pytest.approx(512e-6) and mean.roughness_m3 == 256e-6
    lm, lu = linear_metrics(VEHICLE, mean), linear_metrics(VEHICLE, upper)
    assert float(lu["power_W"]) == pytest.approx(2.0 * float(lm["power_W"]), rel=1e-12)
    zm = road_profile(dataclasses.replace(mean, length_m=200.0)).elevation_m
    zu = road_profile(dataclasses.replace(upper, length_m=200.0)).elevation_m
    np.testing.assert_allclose(zu, math.sqrt(2.0) * zm, rtol=1e-12, atol=1e-15)
    with pytest.raises(ParameterError, match="iso_class_level"):
        RoadParams(iso_class_level="median")
    f = tmp_path / "p.toml"
    f.write_text('[road]\niso_class = "C"\nspeed_km_per_h = 70.0\niso_class_level = "upper"\n')
    assert load_problem(f).road.roughness_m3 == pytest.approx(512e-6)


def _identification(tmp_path):
    import json
    t = load_truth(embedded_data_dir("bench_prototype"))["friction"]
    sets = {case: {k: v * s if "velocity" not in k else v for k, v in t.items()}
            for case, s in (("min", 0.5), ("best", 1.0), ("max", 2.0))}
    path = tmp_path / "identification.json"
    path.write_text(json.dumps({"friction_sets": sets}))
    return path


def test_cli_optimize_with_friction_checks_time_domain(tmp_path, capsys):
    import json

    from ehsa_opt.cli import main
    ident = _identification(tmp_path)
    problem = tmp_path / "p.toml"
    text = paper_model_design(tmp_path).read_text()
    problem.write_text(text.replace("length_m = 1000.0", "length_m = 300.0")
                       .replace("n_starts = 6", "n_starts = 1"))
    rc = main(["optimize", str(problem), "--method", "goal-attainment", "--friction",
               f"{ident}:min", "--friction", f"{ident}:max", "--friction-mode", "worst",
               "--out", str(tmp_path / "out")])
    assert rc == 0
    res = json.loads((tmp_path / "out" / "result.json").read_text())
    assert res["friction"]["mode"] == "worst" and len(res["friction"]["sets"]) == 2
    chk = res["time_domain_check"]
    assert chk["n_designs"] == 1 and chk["within_5pct"], chk
    assert (tmp_path / "out" / "front_check.csv").is_file()
    assert "time-domain check with friction" in capsys.readouterr().out
    # refusals: a mode without friction; 'at' with two sets
    assert main(["optimize", str(problem), "--method", "goal-attainment", "--friction-mode",
                 "worst", "--out", str(tmp_path / "o2")]) != 0
    assert "needs friction sets" in capsys.readouterr().err
    assert main(["optimize", str(problem), "--method", "goal-attainment", "--friction",
                 f"{ident}:min", "--friction", f"{ident}:max", "--friction-mode", "at",
                 "--out", str(tmp_path / "o3")]) != 0
    assert "exactly one" in capsys.readouterr().err


def test_weakly_damped_designs_grid_converged():
    # designs with almost no electrical damping (R_e = 10 kΩ, k_n high): friction is
    # their only damping; the fixed point is solved again on the final grid refined
    # around the damped poles, so the default grid agrees with a 2048-point one
    road = RoadParams("B", 30.0)
    design = {"load_ohm": np.array([1e4, 3e3, 47.0]),
              "speed_constant_rpm_per_V": np.array([11900.0, 3000.0, 69.7]),
              "total_inertia_gcm2": np.array([9000.0, 300.0, 301.0]),
              "lead_mm_per_rev": np.array([5.3, 20.0, 5.0])}
    fr = _truth(0.5)
    # (method="quadrature": the default "exact" integration has no grid at all)
    ref = friction_metrics(VEHICLE, road, design, fr, iteration_n_freq=2048, n_freq=2048,
                           method="quadrature")
    got = friction_metrics(VEHICLE, road, design, fr, method="quadrature")
    # (the residual force is the exact path's alone: compare the linearised parts)
    exact = friction_metrics(VEHICLE, road, design, fr, residual=False)
    for key in ("power_W", "comfort", "road_holding", "stroke_velocity_rms_m_s"):
        np.testing.assert_allclose(got[key], ref[key], rtol=1e-2, err_msg=key)
        np.testing.assert_allclose(exact[key], ref[key], rtol=1e-2, err_msg=key)
    old = friction_metrics(VEHICLE, road, design, fr, resolve_on_final_grid=False,
                           method="quadrature")
    assert np.max(np.abs(old["power_W"] / ref["power_W"] - 1.0)) > 0.05  # the failure fixed
