"""The ``force_sensor`` member: the sensor's second-order low-pass against its analytic
response, its bandwidth and damping recovered from a filtered record, and end to end
against its limit, a delay of the record."""

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import signal

from ehsa_opt.datasets.bench_format import write_bench
from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import DiscrepancySettings, run_discrepancy
from ehsa_opt.estimation.discrepancy.sensor_filter import fit_sensor
from ehsa_opt.estimation.discrepancy.sensor_filter import filtered_force
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests


def _load_cell(t, force, f_c, zeta):
    """The force through a continuous second-order sensor (scipy's lsim, started at rest
    at the first value: an independent discretisation of the same law)."""
    w = 2 * math.pi * f_c
    sys = signal.lti([w * w], [1.0, 2 * zeta * w, w * w])
    _, y, _ = signal.lsim(sys, force - force[0], t)
    return y + force[0]


@pytest.mark.parametrize("zeta", [0.3, 0.7])
def test_the_sensor_filter_has_the_analytic_gain_and_phase_at_its_bandwidth(zeta):
    """|H(jω_c)| = 1/(2ζ), phase −90°, on a sine at f_c after the start-up decays."""
    f_c, dt = 40.0, 1e-3
    spec = SyntheticSpec(effects={}, frequencies_hz=(1.0,), loads_ohm=(22.0,), cycles=1.0,
                         seed=1)
    pt = prepare_tests(generate_bench_tests(spec)[:1], True)[0]
    t = np.arange(0.0, 2.0, dt)
    pt = replace(pt, time_s=t)
    x = np.sin(2 * math.pi * f_c * t)
    y = filtered_force(pt, x, f_c, zeta)
    k = t > 1.0
    basis = np.column_stack([np.sin(2 * math.pi * f_c * t[k]), np.cos(2 * math.pi * f_c * t[k])])
    (a, b), *_ = np.linalg.lstsq(basis, y[k], rcond=None)
    assert math.hypot(a, b) == pytest.approx(1 / (2 * zeta), rel=0.01)
    assert math.degrees(math.atan2(b, a)) == pytest.approx(-90.0, abs=1.0)


def test_bandwidth_and_damping_are_recovered_from_a_filtered_record():
    """The recorded force is the model's force through an 80 Hz, ζ 0.7 sensor plus
    noise: f_c and ζ within 10 %, and their intervals cover the truth."""
    spec = SyntheticSpec(effects={}, frequencies_hz=(2.0, 5.0), loads_ohm=(22.0,),
                         cycles=1.0, seed=3)
    tests = generate_bench_tests(spec)
    rng = np.random.default_rng(0)
    rec = [replace(t, force_N=_load_cell(t.time_s, t.force_N, 80.0, 0.7)
                   + rng.normal(0.0, 0.5, t.time_s.size)) for t in tests]
    pts = prepare_tests(rec, True)
    preds = [np.array(q.y, copy=True) for q in prepare_tests(tests, True)]
    assert all(q.shape == pt.y.shape for q, pt in zip(preds, pts))
    est = fit_sensor(pts, preds)
    assert est["f_c_hz"] == pytest.approx(80.0, rel=0.1)
    assert est["zeta"] == pytest.approx(0.7, rel=0.1)
    lo, hi = est["intervals"]["sensor_bandwidth_hz"]
    assert lo < 80.0 < hi or est["f_c_hz"] == pytest.approx(80.0, rel=0.02)


def _campaign(tmp_path, name, transform):
    spec = SyntheticSpec(effects={}, frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(22.0, 100.0),
                         cycles=1.0, seed=21)
    tests = [replace(t, force_N=transform(t)) for t in generate_bench_tests(spec)]
    write_bench(tmp_path / name, tests, harvester=spec.harvester,
                rig={"name": name, "has_generator": True})
    return tmp_path / name


@pytest.mark.slow
def test_a_load_cell_is_named_force_sensor_with_its_bandwidth(tmp_path):
    """A campaign recorded through a 60 Hz, ζ 0.5 load cell: ``force_sensor`` earns over
    the delay (whose best one differs from test to test), f_c within 30 %."""
    path = _campaign(tmp_path, "load cell",
                     lambda t: _load_cell(t.time_s, t.force_N, 60.0, 0.5))
    res = run_discrepancy(path, DiscrepancySettings(candidates=("force_lag", "force_sensor"),
                                                    max_effects=1))
    assert res.effect == "force_sensor", res.message
    p = res.steps[0]["parameters"]
    assert p["sensor_bandwidth_hz"] == pytest.approx(60.0, rel=0.3)
    assert res.error_after < 0.5 * res.error_before


@pytest.mark.slow
def test_a_pure_delay_stays_force_lag_when_the_sensor_is_offered_too(tmp_path):
    """A delay is the sensor's limit: with both offered, the simpler member is named."""
    lag_s = 0.004
    path = _campaign(tmp_path, "late",
                     lambda t: np.interp(t.time_s - lag_s, t.time_s, t.force_N))
    res = run_discrepancy(path, DiscrepancySettings(candidates=("force_lag", "force_sensor"),
                                                    max_effects=1))
    assert res.effect == "force_lag", res.message


@pytest.mark.slow
def test_a_residual_no_member_explains_is_not_answered_none(tmp_path):
    """The load-cell campaign searched with a member that cannot explain it: no member
    earns, and the answer names what is missing — the data-driven term's sensor support,
    its bandwidth near the truth — instead of 'none'."""
    from ehsa_opt.estimation.discrepancy.results import NONE_OF_CATALOGUE
    path = _campaign(tmp_path, "load cell",
                     lambda t: _load_cell(t.time_s, t.force_N, 60.0, 0.5))
    res = run_discrepancy(path, DiscrepancySettings(candidates=("cogging",), max_effects=1))
    assert res.effect == NONE_OF_CATALOGUE and res.effects == [], res.message
    assert res.term.group == "sensor" and res.term.earns
    assert res.term.quantity["bandwidth_hz"] == pytest.approx(60.0, rel=0.1)


def test_the_member_names_match_the_settings():
    """Every record or law member the settings may list is a member of the engine."""
    from ehsa_opt.estimation.discrepancy.members import RECORD_MEMBER_NAMES
    from ehsa_opt.estimation.discrepancy.results import CHANNEL_MEMBERS
    assert set(RECORD_MEMBER_NAMES) == set(CHANNEL_MEMBERS)


@pytest.mark.slow
def test_a_voltage_records_conditioning_is_named_voltage_sensor(tmp_path):
    """The voltage recorded through a 30 Hz, ζ 0.5 conditioning filter: named
    ``voltage_sensor`` on the voltage channel (the force kept), bandwidth within 30 %."""
    spec = SyntheticSpec(effects={}, frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(22.0, 100.0),
                         cycles=1.0, seed=21)
    tests = [replace(t, voltage_V=_load_cell(t.time_s, t.voltage_V, 30.0, 0.5))
             for t in generate_bench_tests(spec)]
    write_bench(tmp_path / "v", tests, harvester=spec.harvester,
                rig={"name": "filtered voltage", "has_generator": True})
    res = run_discrepancy(tmp_path / "v", DiscrepancySettings(
        candidates=("voltage_sensor",), max_effects=1))
    assert res.effect == "voltage_sensor", res.message
    p = res.steps[0]["parameters"]
    assert p["voltage_sensor_bandwidth_hz"] == pytest.approx(30.0, rel=0.3)
