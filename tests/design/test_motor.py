"""Motor models of the design space, rated limits as constraints, the motor catalogue."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from ehsa_opt.design.config import load_design_config
from ehsa_opt.design.optimize import build_problem, goals_and_weights
from ehsa_opt.design.problem import QuarterCarObjectives
from ehsa_opt.physics.motor import (CatalogueMotor, FixedWindingMotor, RatedLimits, ScalingMotor,
                                    load_catalogue)
from ehsa_opt.physics.params import HarvesterParams, ParameterError, RoadParams, VehicleParams
from tests.paths import ROOT

PAPER = ROOT / "problems" / "paper_design.toml"
ROAD = RoadParams(iso_class="C", speed_km_per_h=70.0)
#: a frame's datasheet ratings for the scaling model (rms current, peak voltage), loose
#: enough that the prototype (1.35 A rms, 64 V rms) is within them
FRAME = RatedLimits(400.0, 2.0, None)


def _paper_text() -> str:
    """paper_design.toml without its hardware tables ([motor], [screw], [limits])."""
    out, skip = [], False
    for line in PAPER.read_text().splitlines():
        if line.startswith("["):
            skip = line.split("]")[0].strip("[ ") in ("motor", "screw", "limits")
        if not skip:
            out.append(line)
    return "\n".join(out) + "\n"


def _ev(motor, stroke=None):
    return QuarterCarObjectives(VehicleParams(), ROAD, HarvesterParams(), (("n_freq", 512),),
                                motor, stroke)


def test_scaling_law_winding_and_the_redundancy_it_implies():
    h = HarvesterParams()
    m = ScalingMotor(h, RatedLimits(200.0, 2.0, 100.0))
    w = m.winding(np.array([h.voltage_constant_Vs_per_rad, 2 * h.voltage_constant_Vs_per_rad]))
    assert w["internal_resistance_ohm"] == pytest.approx([6.6, 4 * 6.6])
    assert w["inductance_H"] == pytest.approx([1.7e-3, 4 * 1.7e-3])
    assert w["rated_current_A"] == pytest.approx([2.0, 1.0])      # same current density
    assert w["rated_voltage_V"] == pytest.approx([200.0, 400.0])  # same top speed
    # one frame rewound: doubling K_e and quadrupling R_e changes nothing mechanical
    # (damping K²/(r²(R_e + R_i)), inductance time constant, efficiency R_e/(R_e + R_i))
    a = {"total_inertia_gcm2": np.array([400.0, 400.0]), "lead_mm_per_rev": np.array([6.0, 6.0]),
         "speed_constant_rpm_per_V": np.array([60.0, 30.0]), "load_ohm": np.array([20.0, 80.0])}
    s = _ev(m)(a)
    for k in ("comfort", "road_holding", "inverse_power", "inverse_efficiency"):
        assert s[k][0] == pytest.approx(s[k][1], rel=1e-9)
    # the paper's fixed winding makes the stronger motor look better (higher efficiency)
    p = _ev(FixedWindingMotor(h))(a)
    assert p["inverse_efficiency"][1] < p["inverse_efficiency"][0] - 0.05
    # constraints: normalised and signed; the current scales back exactly
    assert s["constraint_rated_current"][0] == pytest.approx(
        s["current_rms_A"][0] / s["rated_current_A"][0] - 1)
    assert s["current_rms_A"][1] == pytest.approx(0.5 * s["current_rms_A"][0], rel=1e-9)


def test_goal_attainment_and_nsga2_respect_the_rated_limits():
    from ehsa_opt.design import solve_goal_attainment
    from ehsa_opt.design.nsga2 import run_nsga2
    cfg = dataclasses.replace(load_design_config(PAPER), motor_model="scaling",
                              motor_rating=FRAME)
    paper = dataclasses.replace(cfg, motor_model="paper")
    pp = build_problem(paper)
    goals, weights, _ = goals_and_weights(paper, pp)
    free = solve_goal_attainment(pp, goals, weights, cfg.prototype_design, n_starts=2)
    # the same frame rewound for the paper's optimum k_n (29.8 rpm/V) has R_i = 6.6 Ω ×
    # (69.7/29.8)² ≈ 36 Ω, so its efficiency is far below the paper's R_e/(R_e + 6.6 Ω)
    sp = build_problem(cfg)
    at_free = sp.evaluate_design({k: np.array([v]) for k, v in free.design.items()})
    assert at_free["internal_resistance_ohm"][0] == pytest.approx(
        6.6 * (cfg.harvester.speed_constant_rpm_per_V / free.design["speed_constant_rpm_per_V"])
        ** 2, rel=1e-6)
    assert at_free["efficiency"][0] < free.objectives["efficiency"] - 0.05
    limited = solve_goal_attainment(sp, goals, weights, cfg.prototype_design, n_starts=2)
    assert limited.success
    for c in sp.constraint_names:
        assert limited.objectives[f"constraint_{c}"] <= 1e-6
    assert limited.gamma > free.gamma  # the limits cost attainment
    # NSGA-II: feasibility first; every front point within the limits
    pr = run_nsga2(sp, pop_size=16, n_gen=8, seed=3,
                   initial=sp.space.to_unit(cfg.prototype_design)[None, :])
    assert pr.success, pr.message
    out = sp.evaluate_design(pr.designs)
    G = np.column_stack([out[f"constraint_{c}"] for c in sp.constraint_names])
    assert np.all(G <= 1e-9)


def test_catalogue_file_is_read_and_bad_entries_are_refused(tmp_path):
    motors = load_catalogue()
    assert len(motors) >= 2 and all(m.source for m in motors)
    maxon = next(m for m in motors if m.name.startswith("maxon RE 65 353297"))
    assert maxon.speed_constant_rpm_per_V == pytest.approx(77.8)
    assert maxon.rating.current_A == 6.8
    # the 50–1000 W class, each with its limits; a series' winding range rewinds the frame
    assert len(motors) >= 10 and all(m.rating.current_A and m.max_speed_rpm for m in motors)
    w = maxon.winding(2 * maxon.voltage_constant_Vs_per_rad)  # k_n 38.9: the 70 V winding
    assert w["internal_resistance_ohm"] == pytest.approx(4 * 0.365)
    assert w["rated_current_A"] == pytest.approx(3.4) and w["max_speed_rpm"] == 5500.0
    re65_70 = next(m for m in motors if m.name == "maxon RE 65 (70 V)")
    assert re65_70.internal_resistance_ohm == pytest.approx(1.41)  # the real 70 V winding
    bad = tmp_path / "c.toml"
    bad.write_text('[[motor]]\nname = "x"\nspeed_constant_rpm_per_V = 100.0\n'
                   'internal_resistance_ohm = 1.0\ninductance_H = 1e-4\n'
                   'motor_inertia_gcm2 = 10.0\n')
    with pytest.raises(ParameterError, match=r"c.toml \[\[motor\]\] #1 \(x\): 'source'"):
        load_catalogue(bad)
    bad.write_text('[[motor]]\nname = "x"\nspeed_constant_rpm_per_V = 100.0\n'
                   'voltage_constant_Vs_per_rad = 0.1\ninternal_resistance_ohm = 1.0\n'
                   'inductance_H = 1e-4\nmotor_inertia_gcm2 = 10.0\nsource = "s"\n')
    with pytest.raises(ParameterError, match="exactly one of"):
        load_catalogue(bad)
    bad.write_text('[[motor]]\nname = "x"\nspeed_constant_rpm_per_V = -1\nsource = "s"\n')
    with pytest.raises(ParameterError, match="speed_constant_rpm_per_V.*positive"):
        load_catalogue(bad)


def test_problem_file_motor_table_is_validated(tmp_path):
    text = _paper_text()
    p = tmp_path / "p.toml"
    p.write_text(text + '\n[motor]\nmodel = "scaling"\nrated_current_A = 2.0\n'
                 'rated_voltage_V = 300.0\n')
    cfg = load_design_config(p)
    assert cfg.motor().rating.current_A == 2.0 and cfg.motor().rating.voltage_V == 300.0
    # a frame's ratings come from its data, never from the prototype's demand
    p.write_text(text + '\n[motor]\nmodel = "scaling"\nrated_current_A = 2.0\n')
    with pytest.raises(ParameterError, match="needs that frame's ratings.*rated_voltage_V"):
        load_design_config(p).motor()
    assert load_design_config_text(tmp_path, text).motor_model == "paper"  # no [motor]
    p.write_text(text + '\n[motor]\nmodel = "scalin"\n')
    with pytest.raises(ParameterError, match="did you mean 'scaling'"):
        load_design_config(p)
    p.write_text(text + '\n[motor]\nmodel = "catalogue"\n')
    with pytest.raises(ParameterError, match="remove speed_constant_rpm_per_V"):
        load_design_config(p)
    p.write_text(text + '\n[motor]\nmodel = "paper"\nrated_current_A = 2.0\n')
    with pytest.raises(ParameterError, match="takes none"):
        load_design_config(p)


def load_design_config_text(tmp_path, text):
    p = tmp_path / "plain.toml"
    p.write_text(text)
    return load_design_config(p)


def test_cli_catalogue_run_checks_limits_in_the_time_domain(tmp_path, capsys):
    from ehsa_opt.cli import main
    cat = tmp_path / "motors.toml"
    maxon = next(m for m in load_catalogue() if m.name.startswith("maxon RE 65 353297"))
    cat.write_text(
        f'[[motor]]\nname = "{maxon.name}"\nvoltage_constant_Vs_per_rad = '
        f'{maxon.voltage_constant_Vs_per_rad!r}\ninternal_resistance_ohm = '
        f'{maxon.internal_resistance_ohm}\ninductance_H = {maxon.inductance_H}\n'
        f'motor_inertia_gcm2 = {maxon.motor_inertia_gcm2}\nrated_voltage_V = 48.0\n'
        f'rated_current_A = 6.8\nsource = "test copy"\n')
    text = (ROOT / "problems" / "catalogue_design.toml").read_text()
    prob = tmp_path / "p.toml"
    prob.write_text(text.replace('catalogue = "dc_generators"', f'catalogue = "{cat}"')
                    .replace("length_m = 1000.0", "length_m = 400.0")
                    .replace("n_starts = 6", "n_starts = 2"))
    assert main(["optimize", str(prob), "--out", str(tmp_path / "o")]) == 0
    res = json.loads((tmp_path / "o" / "result.json").read_text())
    assert res["motor"]["chosen"] == maxon.name and res["feasible"]
    assert set(res["constraints"]) == {"rated_current", "rated_voltage", "stroke",
                                       "motor_inertia"}
    lim = res["time_domain_check"]["rated_limits"]
    assert res["time_domain_check"]["within_5pct"]
    assert all(v <= 0.05 for v in lim["time_domain_worst_constraint"].values())
    assert "active:" in capsys.readouterr().out


def test_catalogue_motor_sets_the_harvester():
    m = CatalogueMotor("m", 0.1, 1.0, 2e-4, 100.0, RatedLimits(24.0, 3.0, None), source="s")
    h = m.harvester(HarvesterParams())
    assert (h.voltage_constant_Vs_per_rad, h.torque_constant_Nm_per_A,
            h.internal_resistance_ohm, h.inductance_H, h.motor_inertia_gcm2) == (
        0.1, 0.1, 1.0, 2e-4, 100.0)
    ev = _ev(m, 0.1)
    assert ev.constraint_names == ("rated_current", "rated_voltage", "stroke", "motor_inertia")
    out = ev({"total_inertia_gcm2": np.array([50.0, 400.0]),
              "lead_mm_per_rev": np.array([10.0, 10.0]), "load_ohm": np.array([5.0, 5.0])})
    assert out["constraint_motor_inertia"] == pytest.approx([1.0, -0.75])


def test_reproduce_data_designs_from_the_users_harvester(tmp_path):
    """bench.toml's R_i = 2.4 Ω (and L_i, J_m) start the design space, not Table 1's."""
    from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
    from ehsa_opt.pipeline.base import Context
    from ehsa_opt.pipeline.design_problem import design_config as _cfg
    user = HarvesterParams(internal_resistance_ohm=2.4, inductance_H=0.9e-3,
                           motor_inertia_gcm2=90.0)
    d = write_synthetic(tmp_path / "d", SyntheticSpec(frequencies_hz=(1.0,), loads_ohm=(47.0,),
                                                      seed=3, harvester=user))
    ctx = Context(tmp_path / "out", True, 1, data_dir=d)
    for model in ("paper", "scaling"):
        cfg = dataclasses.replace(_cfg(ctx, model), motor_rating=FRAME)
        h = cfg.harvester
        assert (h.internal_resistance_ohm, h.inductance_H, h.motor_inertia_gcm2) == (
            2.4, 0.9e-3, 90.0)
        out = build_problem(cfg).evaluate_design(
            {k: np.array([v]) for k, v in cfg.prototype_design.items()})
        # frictionless efficiency = R_e / (R_e + R_i) with the user's R_i
        assert out["efficiency"][0] == pytest.approx(47.0 / (47.0 + 2.4), rel=2e-3)
        assert cfg.motor().reference.internal_resistance_ohm == 2.4


@pytest.mark.slow
def test_catalogue_nsga2_front_keeps_feasible_points_only(tmp_path):
    from ehsa_opt.cli import main
    text = (ROOT / "problems" / "catalogue_design.toml").read_text()
    prob = tmp_path / "p.toml"
    prob.write_text(text.replace("length_m = 1000.0", "length_m = 300.0"))
    assert main(["optimize", str(prob), "--method", "nsga2", "--pop", "12", "--gens", "4",
                 "--out", str(tmp_path / "o")]) == 0
    res = json.loads((tmp_path / "o" / "result.json").read_text())
    infeasible = {r["motor"] for r in res["catalogue"] if not r["feasible"]}
    assert infeasible and any(name.startswith("maxon RE 30") for name in infeasible)
    assert all(r["violations"] for r in res["catalogue"] if not r["feasible"])
    rows = (tmp_path / "o" / "pareto.csv").read_text().splitlines()[1:]
    assert rows and all(not any(name in r for name in infeasible) for r in rows)
