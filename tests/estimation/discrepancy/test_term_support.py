"""The data-driven term tells physics apart: a force record low-passed by a sensor, a
friction level drifting over the campaign and a presliding transition each get their
own support (feature group) and words."""

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import signal

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.presliding import travel_since_reversal_m
from ehsa_opt.estimation.discrepancy.terms import discover_term

RUN_ORDER = (4, 1, 6, 2, 5, 3)


def _campaign(measured):
    """The model's outputs (the generator's noiseless-ish record) and a record whose
    force is ``measured(pt, model force)`` plus 0.5 N of noise, tests in a stated run
    order; fit tests and held-out tests alternate."""
    spec = SyntheticSpec(effects={}, frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(22.0, 100.0),
                         cycles=2.0, seed=8, noise_force_N=0.0)
    tests = [replace(t, run_order=k) for t, k in zip(generate_bench_tests(spec), RUN_ORDER)]
    model = prepare_tests(tests, True)
    rng = np.random.default_rng(1)
    rec = [replace(t, force_N=measured(pt, pt.y[0]) + rng.normal(0.0, 0.5, t.time_s.size))
           for t, pt in zip(tests, model)]
    pts = prepare_tests(rec, True)
    preds = [np.array(pt.y, copy=True) for pt in model]
    return pts[::2], preds[::2], pts[1::2], preds[1::2]


def _term(measured):
    fp, fpr, hp, hpr = _campaign(measured)
    return discover_term(fp, fpr, hp, hpr, lead_m_per_rad=0.01 / (2 * math.pi), seed=0)


def _lowpass(f_c, zeta):
    w = 2 * math.pi * f_c

    def f(pt, force):
        _, y, _ = signal.lsim(signal.lti([w * w], [1, 2 * zeta * w, w * w]),
                              force - force[0], pt.time_s)
        return y + force[0]
    return f


def test_a_sensor_low_pass_is_described_as_the_force_records_dynamics():
    """A 50 Hz, ζ 0.3 load cell (off the term's grid of sensors): the ``sensor`` group,
    its bandwidth refined from the grid's nearest within 10 %, most of the error
    explained."""
    term = _term(_lowpass(50.0, 0.3))
    assert term.group == "sensor", term.description
    assert term.quantity["bandwidth_hz"] == pytest.approx(50.0, rel=0.1)
    assert term.error_after < 0.2 * term.error_before


def test_a_drift_over_the_campaign_is_described_as_a_drift():
    def drift(pt, force):
        k = pt.test.run_order
        return force + (-2.0 * k) * np.tanh(pt.u[1] / 1e-3)
    term = _term(drift)
    assert term.group == "drift", term.description


def test_a_presliding_transition_is_described_as_presliding():
    def pres(pt, force):
        s = travel_since_reversal_m(pt.u[0], pt.u[1])
        return force - 30.0 * np.sign(pt.u[1]) * np.exp(-s / 2e-5)
    term = _term(pres)
    assert term.group == "presliding", term.description


def test_a_sensor_is_proposed_and_not_refused_by_its_consistency_checks():
    """The same load cell through :func:`propose_term`: one sensor for every test (its
    delay and weight do not differ from test to test), so it is not refused."""
    from ehsa_opt.estimation.discrepancy.terms import propose_term
    fp, fpr, hp, hpr = _campaign(_lowpass(50.0, 0.3))
    term = propose_term(fp, fpr, hp, hpr, 0.01 / (2 * math.pi), 0, 0.05, 2000.0)
    assert term.group == "sensor" and not term.refused, term.refused
