"""Bench tests planned for the road (design/test_plan.py, `ehsa-opt plan-tests`)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ehsa_opt.cli import main
from ehsa_opt.design import test_plan
from ehsa_opt.design.test_plan import (
    RigLimits,
    candidate_tests,
    load_rig,
    plan_tests,
    residual_model,
    triangle_resolved_velocity,
)
from ehsa_opt.estimation.rod_law import FrictionSamples, RodLawFit, rod_law_fit
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.params import FrictionParams, HarvesterParams, ParameterError

TRUTH = FrictionParams(60.0, 40.0, 0.01, 150.0, 0.02, 0.015, 1.0, 3e-5)
LEAD = 5e-3 / (2 * math.pi)


@pytest.fixture(scope="module")
def law():
    """A law fitted on five slow sines (peak <= 0.33 m/s) with AR(1) noise."""
    rng = np.random.default_rng(2)
    vs, ys = [], []
    for f in (0.5, 1.0, 2.0, 3.0, 3.5):
        t = np.arange(0, 2 / f, 1e-3)
        v = 2 * math.pi * f * 0.015 * np.cos(2 * math.pi * f * t)
        e = np.zeros(v.size)
        for k in range(1, v.size):
            e[k] = 0.8 * e[k - 1] + rng.normal(0, 2.0)
        vs.append(v)
        ys.append(np.asarray(rod_friction_N(v, TRUTH, LEAD)) + e)
    return rod_law_fit(FrictionSamples(list("abcde"), vs, ys), TRUTH.as_dict(), LEAD)


def test_rig_file_is_validated_with_the_fix(tmp_path) -> None:
    p = tmp_path / "rig.toml"
    p.write_text("[rig]\nstroke_m = 0.1\npeak_velocity = 1.0\n")
    with pytest.raises(ParameterError, match="did you mean 'peak_velocity_m_per_s'"):
        load_rig(p)
    p.write_text("[rig]\nstroke_m = 100\n")
    with pytest.raises(ParameterError, match="millimetres"):
        load_rig(p)
    p.write_text("[rig]\nforce_N = -5\n")
    with pytest.raises(ParameterError, match="force_N"):
        load_rig(p)
    p.write_text("[bench]\n")
    with pytest.raises(ParameterError, match=r"no \[rig\] table"):
        load_rig(p)
    p.write_text("[rig]\nloads_ohm = [10.0, 33.0]\nforce_N = 4000.0\n")
    assert load_rig(p).loads_ohm == (10.0, 33.0)


def test_candidates_respect_the_limits(law) -> None:
    rig = RigLimits(stroke_m=0.08, peak_velocity_m_per_s=0.8, force_N=3000.0,
                    actuator_power_W=1500.0)
    cands = candidate_tests(rig, HarvesterParams(), law)
    assert cands and {c.kind for c in cands} == {"sine", "triangle"}
    for c in cands:
        assert c.peak_velocity_m_per_s <= 0.8 + 1e-9 and c.peak_force_N <= 3000.0
        assert c.peak_power_W <= 1500.0 and c.amplitude_m <= 0.04 + 1e-12
    with pytest.raises(ParameterError, match="unknown test kind"):
        candidate_tests(rig, HarvesterParams(), law, kinds=("square",))


def test_planned_tests_reach_the_road_and_shrink_the_band(law) -> None:
    rig = RigLimits(peak_velocity_m_per_s=1.5)
    plan = plan_tests(law, rig, HarvesterParams(), 0.5, n_tests=3, kinds=("sine",))
    assert plan.success and len({c.file for c in plan.proposed}) == 3
    # the road is at sigma 0.5 m/s, the data end at 0.33: a proposed test goes beyond
    assert max(c.peak_velocity_m_per_s for c in plan.proposed) > 0.6
    assert plan.band_after_N[1] < 0.5 * plan.band_before_N[1]
    assert plan.road_band_after_N < plan.road_band_before_N
    # a slow road needs no fast test: the choice follows the road
    slow = plan_tests(law, rig, HarvesterParams(), 0.05, n_tests=1, kinds=("sine",))
    assert slow.proposed[0].peak_velocity_m_per_s < plan.proposed[0].peak_velocity_m_per_s
    text = plan.bench_toml({"lead_mm_per_rev": 5.0})
    assert text.count("[[test]]") == 3 and "[harvester]" in text
    tri = plan_tests(law, rig, HarvesterParams(), 0.5, n_tests=1, kinds=("triangle",))
    assert 'excitation = "recorded"' in tri.bench_toml()
    d = plan_tests(law, rig, HarvesterParams(), 0.5, n_tests=2, criterion="D")
    assert d.success and d.criterion == "D"


def test_cli_plan_tests_writes_the_skeleton(law, tmp_path, capsys) -> None:
    ident = tmp_path / "identification.json"
    sets = {c: TRUTH.as_dict() for c in ("min", "best", "max")}
    (tmp_path / "bench").mkdir()
    (tmp_path / "bench" / "bench.toml").write_text("[rig]\nname = 'r'\n")  # Table 1 lead
    ident.write_text(json.dumps({"data_dir": "bench", "friction_sets": sets,
                                 "friction_envelope": {"extrapolation_band": {
                                     "law": law.to_dict()}}}))
    rig = tmp_path / "rig.toml"
    rig.write_text("[rig]\nstroke_m = 0.1\npeak_velocity_m_per_s = 1.5\n")
    out = tmp_path / "plan"
    assert main(["plan-tests", str(ident), "--vehicle", "quarter_car_class_c", "--rig",
                 str(rig), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "before -> after" in text and "at 1.00 m/s" in text
    assert (out / "bench.toml").read_text().count("[[test]]") == 3
    saved = (out / "plan.json").read_text()
    assert json.loads(saved)["success"] is True
    # plan.json reloads into the plan the command printed; to_json / from_json round-trip
    plan = test_plan.TestPlan.from_json(saved)
    assert plan.summary() in text and len(plan.proposed) == 3
    assert test_plan.TestPlan.from_json(plan.to_json()).to_dict() == plan.to_dict()
    rig.write_text("[rig]\nstroke = 0.1\n")
    assert main(["plan-tests", str(ident), "--vehicle", "quarter_car_class_c", "--rig",
                 str(rig), "--out", str(tmp_path / "p2")]) == 2
    assert "unknown key 'stroke'" in capsys.readouterr().err


def test_road_weight_by_friction_energy_reaches_further_than_by_time(law) -> None:
    """The friction energy F|v| p(v) puts more weight on fast strokes than the time p(v):
    the energy-weighted plan's first test is at least as fast, its band at 1 m/s at least
    as narrow; an unknown weight is refused with the choices."""
    rig = RigLimits(peak_velocity_m_per_s=1.5)
    e = plan_tests(law, rig, HarvesterParams(), 0.4, n_tests=1, kinds=("sine",))
    t = plan_tests(law, rig, HarvesterParams(), 0.4, n_tests=1, kinds=("sine",),
                   weight="time")
    assert e.proposed[0].peak_velocity_m_per_s >= t.proposed[0].peak_velocity_m_per_s
    assert e.band_after_N[1] <= t.band_after_N[1] * (1 + 1e-9)
    with pytest.raises(ParameterError, match="'energy' or 'time'"):
        plan_tests(law, rig, HarvesterParams(), 0.4, weight="power")


def test_triangle_strokes_keep_only_their_plateaus() -> None:
    """A constant-velocity stroke gives friction samples at its speed, outside the reversal
    windows; a stroke too short for its speed gives none."""
    rig = RigLimits(stroke_m=0.1, peak_velocity_m_per_s=1.5, reversal_s=0.05)
    v = triangle_resolved_velocity(0.5, 0.05, rig)
    assert v.size > 100 and np.allclose(np.abs(v), 0.5, rtol=0.01)
    assert triangle_resolved_velocity(1.4, 0.05, rig).size == 0


def test_an_error_growing_with_acceleration_steers_the_plan_to_plateaus() -> None:
    """Five slow sines whose residuals carry an error growing as the acceleration squared
    (a hidden backlash or compliance does): the residual model finds the growth, and the
    planner prefers constant-velocity strokes (no acceleration on their plateaus) to the
    fast sines it proposes when every test is expected to fit alike."""
    import dataclasses
    rng = np.random.default_rng(2)
    vs, ys, acc = [], [], []
    for f in (0.5, 1.0, 2.0, 3.0, 3.5):
        w = 2 * math.pi * f
        t = np.arange(0, 2 / f, 1e-3)
        v, a = w * 0.015 * np.cos(w * t), -w * w * 0.015 * np.sin(w * t)
        e = np.zeros(v.size)
        for k in range(1, v.size):
            e[k] = 0.8 * e[k - 1] + rng.normal(0, 2.0)
        vs.append(v)
        acc.append(a)
        ys.append(np.asarray(rod_friction_N(v, TRUTH, LEAD)) + e + 3.0 * a * a)
    law = rod_law_fit(FrictionSamples(list("abcde"), vs, ys, acc), TRUTH.as_dict(), LEAD)
    s0, beta = residual_model(law)
    assert beta > 1.0 and s0 < 5.0 ** 2
    rig = RigLimits(peak_velocity_m_per_s=1.5)
    plan = plan_tests(law, rig, HarvesterParams(), 0.5, n_tests=2)
    assert all(c.kind == "triangle" for c in plan.proposed)
    assert all(st["predicted_residual_rms_N"] < 5.0 for st in plan.steps)
    flat = dataclasses.replace(law, test_residual_rms_N=[], test_peak_acceleration_m_per_s2=[])
    assert residual_model(flat)[1] == 0.0
    assert plan_tests(flat, rig, HarvesterParams(), 0.5, n_tests=1).proposed[0].kind == "sine"


def _cycle_correlated_record(f_hz: float, amp_m: float, rng) -> tuple[np.ndarray, np.ndarray]:
    """Two cycles at 1 kHz of a sine whose friction samples carry an error correlated over
    a twentieth of the period (AR(1), 3 N): a model error smooth in the cycle's phase, as
    the slow tests of a bench show."""
    dt, w = 1e-3, 2 * math.pi * f_hz
    t = np.arange(0, 2 / f_hz, dt)
    v = w * amp_m * np.cos(w * t)
    rho = math.exp(-dt * f_hz * 20.0)
    e = np.zeros(v.size)
    e[0] = rng.normal(0, 3.0)
    for k in range(1, v.size):
        e[k] = rho * e[k - 1] + rng.normal(0, 3.0 * math.sqrt(1 - rho * rho))
    return v, np.asarray(rod_friction_N(v, TRUTH, LEAD)) + e


def test_a_long_slow_test_is_credited_no_more_than_its_effective_samples() -> None:
    """A 20 s record of a 0.1 Hz sine has ten times the samples of a 0.5 Hz test but, with
    an error smooth over the cycle, no more independent ones: the planner credits it the
    effective samples the campaign's longest test shows — within 1.5x of what such a
    record really carries (measured by the same estimator) — where the campaign's mean
    inflation n/n_eff would credit it several times more; and it is credited no more
    Fisher information than a 0.5 Hz sine of the same peak velocity."""
    import dataclasses
    from ehsa_opt.design.test_plan import Candidate, _candidate_information, effective_samples
    rng = np.random.default_rng(5)
    vs, ys = [], []
    for f in (0.5, 1.0, 2.0, 3.0, 3.5):
        v, y = _cycle_correlated_record(f, 0.015, rng)
        vs.append(v)
        ys.append(y)
    law = rod_law_fit(FrictionSamples(list("abcde"), vs, ys), TRUTH.as_dict(), LEAD)
    assert len(law.test_n_effective) == 5 and law.test_n_samples[0] == vs[0].size
    back = RodLawFit.from_json(law.to_json())  # stored in identification.json
    assert back.test_n_effective == law.test_n_effective
    assert back.test_n_samples == law.test_n_samples
    n_long = 20_000
    real = np.mean([rod_law_fit(FrictionSamples(["x"], [v], [y]), TRUTH.as_dict(),
                                LEAD).test_n_effective[0]
                    for v, y in (_cycle_correlated_record(0.1, 0.075, rng) for _ in range(3))])
    credited = float(effective_samples(law, n_long))
    naive = n_long * law.n_effective / law.n_samples
    assert credited <= 1.5 * real and naive > 3.0 * real
    assert credited <= max(law.test_n_effective) + 1e-9
    # the same velocities (peak 47 mm/s) over 20 s or 4 s: no more information
    flat = dataclasses.replace(law, test_residual_rms_N=[], test_peak_acceleration_m_per_s2=[])
    rig = RigLimits(stroke_m=0.2)
    slow, short = (Candidate("sine", a, 47.0, f, None, 2 * math.pi * f * a)
                   for f, a in ((0.1, 0.075), (0.5, 0.015)))
    d = np.sqrt(np.diag(law.covariance))
    _, infos, _, neffs = _candidate_information([slow, short], rig, flat, d, 1.0)
    assert slow.velocity_samples(rig).size == n_long
    assert np.trace(infos[0]) <= np.trace(infos[1]) * (1 + 1e-6)
    assert neffs[0] == pytest.approx(credited)


def test_a_triangle_plans_the_exact_reversal_force_of_its_own_protocol(law) -> None:
    """The protocol reverses at 2 v / t_rev: the planned peak force is the largest
    m_eq a + c_eq v + F_rod(v) over the protocol's own motion, m_eq 2v/t_rev + c_eq v +
    F_rod(v) (not m_eq v / t_rev), and the power that force times v."""
    import dataclasses
    from ehsa_opt.datasets.protocols import Protocol
    from ehsa_opt.physics.harvester import equivalent_damping_Ns_per_m, equivalent_mass_kg
    rig = RigLimits(peak_velocity_m_per_s=1.0, reversal_s=0.05)
    h = HarvesterParams(load_ohm=47.0)
    tri = [c for c in candidate_tests(rig, h, law, kinds=("triangle",)) if c.load_ohm == 47.0]
    c = tri[-1]
    meq, ceq = equivalent_mass_kg(h), float(equivalent_damping_Ns_per_m(h, 0.0))
    v = c.velocity_m_per_s
    exact = meq * 2 * v / rig.reversal_s + ceq * v + float(law.rod_N(v))
    assert c.peak_force_N == pytest.approx(exact, rel=1e-12)
    assert c.peak_power_W == pytest.approx(exact * v, rel=1e-12)
    assert c.peak_force_N > meq * v / rig.reversal_s + ceq * v + float(law.rod_N(v)) + 100
    # the same peak from the protocol's sampled motion (its acceleration 2 v / t_rev)
    proto = Protocol("triangle", 47.0, amplitude_m=c.amplitude_m, velocity_m_per_s=v,
                     corner_s=0.5 * rig.reversal_s)
    proto = dataclasses.replace(proto, duration_s=2 * proto.cycle_s)
    t = np.arange(0.0, proto.record_s, 1e-5)
    x, vel, acc = proto.motion().evaluate(t)[:3]
    force = meq * acc + ceq * vel + np.asarray(law.rod_N(vel))
    assert np.max(np.abs(force)) == pytest.approx(exact, rel=2e-3)
    assert np.max(np.abs(x)) <= rig.usable_amplitude_m * (1 + 1e-9)


def test_plans_keep_a_stroke_margin_the_damper_limits_and_enough_plateau(law) -> None:
    h = HarvesterParams(load_ohm=47.0)
    free = RigLimits(stroke_m=0.1, stroke_margin_m=0.01, peak_velocity_m_per_s=1.0)
    cands = candidate_tests(free, h, law)
    assert max(c.amplitude_m for c in cands) == pytest.approx(0.04)
    # screw speed, voltage and current stated per test (5 mm lead: 1 m/s = 12 000 rpm)
    fast = max(cands, key=lambda c: c.peak_velocity_m_per_s)
    assert fast.peak_screw_speed_rpm == pytest.approx(
        60 * fast.peak_velocity_m_per_s / 5e-3, rel=1e-9)
    emf = h.voltage_constant_Vs_per_rad * fast.peak_velocity_m_per_s / h.lead_m_per_rad
    i = emf / (fast.load_ohm + h.internal_resistance_ohm)
    assert fast.peak_current_A == pytest.approx(i) and fast.peak_voltage_V == pytest.approx(
        fast.load_ohm * i)
    # the damper's limits, when the rig file gives them, remove the tests beyond them
    lim = dataclasses_replace(free, max_screw_speed_rpm=6000.0, max_generator_voltage_V=40.0,
                              max_generator_current_A=0.8)
    kept = candidate_tests(lim, h, law)
    assert kept and len(kept) < len(cands)
    assert all(c.peak_screw_speed_rpm <= 6000 * (1 + 1e-9) and c.peak_voltage_V <= 40.0
               and c.peak_current_A <= 0.8 for c in kept)
    # every triangle records at least min_plateau_s of plateau (two reversals per cycle)
    for c in cands:
        if c.kind == "triangle":
            plateau = 2 * (2 * c.amplitude_m / c.velocity_m_per_s - free.reversal_s)
            assert c.cycles * plateau >= free.min_plateau_s - 1e-9 and c.cycles >= free.cycles
        else:
            assert c.cycles / c.frequency_hz >= free.min_plateau_s - 1e-9
    one = dict(loads_ohm=(47.0,))
    plan = plan_tests(law, dataclasses_replace(lim, **one), h, 0.5, n_tests=1, kinds=("sine",))
    assert "NOT checked" not in plan.summary() and "damper limits checked" in plan.summary()
    assert "NOT checked (no limit in [rig]): screw speed" in plan_tests(
        law, dataclasses_replace(free, **one), h, 0.5, n_tests=1, kinds=("sine",)).summary()
    with pytest.raises(ParameterError, match="stroke_margin_m"):
        RigLimits(stroke_m=0.1, stroke_margin_m=0.06)


def dataclasses_replace(obj, **kw):
    import dataclasses
    return dataclasses.replace(obj, **kw)
