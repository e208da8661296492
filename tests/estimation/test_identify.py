"""Friction identification: metrics, recovery from synthetic data, EMPS,
failure handling, components, CLI."""

import json
import math

import numpy as np
import pytest

from ehsa_opt.cli import main
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.datasets.emps import EMPS_REFERENCE
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.estimation.identify import (IdentifyOptions, eq5_delta, fit_tests,
                               force_relative_error_percent, identify, simulate_tests)
from ehsa_opt.physics import BenchModel
from ehsa_opt.physics.components import Backlash
from ehsa_opt.physics.params import FRICTION_NAMES, HarvesterParams
from ehsa_opt.datasets.synthetic import (PROTOTYPE_FRICTION, SyntheticSpec, generate_bench_tests,
                                write_synthetic)


@pytest.fixture(scope="module")
def clean_tests():
    """Clean synthetic tests (no hidden effect, noise on): 0.5 and 3.5 Hz at 47 ohm."""
    spec = SyntheticSpec(effects={}, frequencies_hz=(0.5, 3.5), loads_ohm=(47.0,), seed=3)
    return generate_bench_tests(spec)


def test_eq5_as_printed_and_relative_error():
    meas = np.array([1.0, -2.0, 4.0, 0.0])
    sim = meas + np.array([0.4, 0.0, -0.4, 0.8])
    # sqrt(mean(|diff| / max|meas|)) = sqrt(mean([0.1, 0, 0.1, 0.2])) = sqrt(0.1)
    assert eq5_delta(sim, meas) == pytest.approx(math.sqrt(0.1))
    assert force_relative_error_percent(sim, meas) == pytest.approx(
        100 * math.sqrt(0.16 + 0.16 + 0.64) / math.sqrt(21.0))
    with pytest.raises(ValueError, match="shapes"):
        eq5_delta(sim[:3], meas)


def test_options_validated():
    with pytest.raises(ValueError, match="degree"):
        IdentifyOptions(degree=0)
    with pytest.raises(ValueError, match="max_intervals"):
        IdentifyOptions(max_intervals=2)
    with pytest.raises(ValueError, match="sum_weight"):
        IdentifyOptions(sum_weight=-1.0)
    assert IdentifyOptions.for_rig(False).smoothing_cutoff_hz == 60.0


def test_generator_false_model_is_inertia_offset_friction():
    m = BenchModel(HarvesterParams(), generator=False)
    assert m.n_states == 0 and m.param_names[9:11] == ["inertia_kg", "offset_N"]
    p = m.param_vector(1.0, PROTOTYPE_FRICTION, {"inertia_kg": 90.0, "offset_N": -3.0})
    v, a = 0.05, 2.0
    F, V = np.array(m.outputs(np.zeros(0), [0.0, v, a], p)).ravel()
    r = HarvesterParams().lead_m_per_rad
    assert V == 0.0
    assert F == pytest.approx(90.0 * a - 3.0 + float(rod_friction_N(v, PROTOTYPE_FRICTION, r)))


def test_recovers_rod_friction_and_flags_split(clean_tests):
    h = HarvesterParams()
    r = h.lead_m_per_rad
    for test in clean_tests:
        res = fit_tests([test], h, starts=2, seed=1)
        assert res.success, res.message
        assert len(res.starts) == 2 and all("iterations" in s for s in res.starts)
        vpk = 2 * np.pi * test.frequency_hz * test.amplitude_m
        v = np.linspace(0.1, 1.0, 40) * vpk
        true = rod_friction_N(v, PROTOTYPE_FRICTION, r)
        est = rod_friction_N(v, [res.parameters[n] for n in FRICTION_NAMES], r)
        assert np.max(np.abs(est / true - 1)) < 0.03, test.file
        # the nut/bearing split of the viscous term is not determined by the data
        weak = res.identifiability["non_identifiable"]
        assert any(set(d) == {"bearing_viscous_Nms_per_rad", "nut_viscous_Ns_per_m"} for d in weak)
        combo = res.identifiability["combinations"]["total_viscous_Ns_per_m"]
        assert combo["ci95"][0] < combo["value"] < combo["ci95"][1]
        assert res.delta_V is not None and 0 < res.delta_F < 0.5
        assert len(res.history["objective"]) == res.nit + 1 or len(res.history["objective"]) > 1


def test_same_seed_same_result_and_parallel_starts(clean_tests):
    h = HarvesterParams()
    a = fit_tests(clean_tests[1:], h, starts=2, seed=7, identifiability=False)
    b = fit_tests(clean_tests[1:], h, starts=2, seed=7, jobs=2, identifiability=False)
    assert [s["initial"] for s in a.starts] == [s["initial"] for s in b.starts]
    for n in FRICTION_NAMES:
        assert a.parameters[n] == pytest.approx(b.parameters[n], rel=1e-6, abs=1e-9)


def test_failed_ipopt_start_is_recorded_not_reported(clean_tests):
    res = fit_tests(clean_tests[1:], HarvesterParams(), starts=2,
                    options=IdentifyOptions(max_iter=2))
    assert not res.success
    assert all(not s["success"] and s["status"] == "Maximum_Iterations_Exceeded"
               for s in res.starts)
    assert all(math.isnan(v) for v in res.parameters.values())
    assert res.delta_F is None


def test_simulate_tests_with_truth_matches_data_to_noise(clean_tests):
    pred = simulate_tests(clean_tests, HarvesterParams(), PROTOTYPE_FRICTION.as_dict())
    for t, p in zip(clean_tests, pred):
        k = t.n_samples // 50  # the spline's derivatives are poorest at the record ends
        rms = np.sqrt(np.mean((p.force_N - t.force_N)[k:-k] ** 2))
        assert rms < 3.0  # force noise is 2 N
        assert np.sqrt(np.mean((p.voltage_V - t.voltage_V)[k:-k] ** 2)) < 0.08  # noise 0.05 V


def test_emps_matches_published_reference():
    rep = identify(embedded_data_dir("emps"), starts=2)
    f = rep.fits[0]
    assert f.success
    p = f.parameters
    assert p["inertia_kg"] == pytest.approx(EMPS_REFERENCE["inertia_kg"], rel=0.02)
    assert p["nut_viscous_Ns_per_m"] == pytest.approx(EMPS_REFERENCE["viscous_Ns_per_m"],
                                                      rel=0.10)
    assert p["nut_coulomb_N"] == pytest.approx(EMPS_REFERENCE["coulomb_N"], rel=0.15)
    assert 3.0 < f.force_relative_error_percent < 6.0
    js = rep.to_dict()
    assert set(js["tests"][0]["parameters"]) == {
        "nut_breakaway_N", "nut_coulomb_N", "nut_breakaway_velocity_m_per_s",
        "nut_viscous_Ns_per_m", "inertia_kg", "offset_N"}


def test_fit_with_backlash_component_runs_generic_states():
    spec = SyntheticSpec(effects={"backlash": {}}, frequencies_hz=(3.5,), loads_ohm=(47.0,),
                         cycles=1.0)
    tests = generate_bench_tests(spec)
    res = fit_tests(tests, HarvesterParams(), components=(Backlash(),),
                    free=["nut_coulomb_N", "nut_viscous_Ns_per_m", "backlash_gap_m"],
                    fixed={"nut_breakaway_N": "nut_coulomb_N"}, starts=1, identifiability=False,
                    options=IdentifyOptions(max_intervals=40, max_samples=150, max_iter=100))
    assert res.starts[0]["status"]
    assert "backlash_gap_m" in res.parameters
    if res.success:
        assert 0.0 <= res.parameters["backlash_gap_m"] <= 2e-3
        assert res.force_relative_error_percent < 20


def test_cli_identify_contract_and_bad_data(tmp_path, capsys):
    data = tmp_path / "d"
    write_synthetic(data, SyntheticSpec(effects={}, frequencies_hz=(1.0, 2.0, 3.0),
                                        loads_ohm=(47.0,)))
    out = tmp_path / "out"
    assert main(["identify", str(data), "--out", str(out), "--starts", "2", "--seed", "1"]) == 0
    js = json.loads((out / "identification.json").read_text())
    assert len(js["tests"]) == 3 and set(js) >= {"tests", "bounds", "identifiable"}
    # joint fit on two tests, validated on the held-out one
    hold = js["joint_fit"]["holdout"]
    assert [h["file"] for h in hold] == ["f2Hz_Re47.csv"]
    assert hold[0]["force_relative_error_percent"] < 5.0
    assert (out / "joint_fit_holdout.png").is_file()
    t0 = js["tests"][0]
    assert set(t0) >= {"file", "frequency_hz", "load_ohm", "parameters", "delta_F", "delta_V",
                       "force_relative_error_percent", "success", "starts"}
    assert set(FRICTION_NAMES) <= set(t0["parameters"])
    assert all(lo <= hi for lo, hi in js["bounds"].values())
    for fig in ("fig08_objective_iterations.png", "fig09_parameter_iterations.png",
                "fig10_objective_vs_tv.png", "fig11_measured_vs_simulated.png",
                "fig12_bounds.png", "identifiability.png"):
        assert (out / fig).is_file(), fig
    # bad input is refused before any solve, nothing written
    (data / "f3Hz_Re47.csv").write_text("time_s,displacement_m,force_N,voltage_V\n0,0,nan,0\n")
    out2 = tmp_path / "out2"
    assert main(["identify", str(data), "--out", str(out2)]) == 2
    assert "f3Hz_Re47.csv" in capsys.readouterr().err
    assert not out2.exists()


@pytest.mark.slow
def test_full_matrix_acceptance(tmp_path):
    """Acceptance: 21 clean tests, 4 starts; rod friction within 3 % (median) and
    10 % (worst) over 0.1–1 × peak velocity; the nut/bearing split flagged."""
    write_synthetic(tmp_path / "d", SyntheticSpec(effects={}))
    rep = identify(tmp_path / "d", starts=4, jobs=2, joint=False)
    r = rep.data.harvester.lead_m_per_rad
    errs = []
    for t, f in zip(rep.data.tests, rep.fits):
        assert f.success, f.message
        v = np.linspace(0.1, 1.0, 50) * 2 * np.pi * t.frequency_hz * t.amplitude_m
        true = rod_friction_N(v, PROTOTYPE_FRICTION, r)
        est = rod_friction_N(v, [f.parameters[n] for n in FRICTION_NAMES], r)
        errs.append(float(np.max(np.abs(est / true - 1))))
    assert np.median(errs) < 0.03 and max(errs) < 0.10
    weak = rep.identifiable["non_identifiable_directions"]
    assert weak.get("bearing_viscous_Nms_per_rad / nut_viscous_Ns_per_m", 0) == len(rep.fits)
