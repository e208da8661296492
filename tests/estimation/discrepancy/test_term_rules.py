"""The data-driven term judged like a catalogue effect: a time shift of the force is a
delay of the record only when one delay fits every test."""

import math

import numpy as np

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.terms import propose_term

LEAD = 0.01 / (2 * math.pi)


def _delayed_case(delay_of, seed=3):
    """Clean tests whose measured force is the noise-free model delayed by
    ``delay_of(test)`` plus 2 N white noise; the 'model' is the noise-free simulation."""
    tests = generate_bench_tests(SyntheticSpec(frequencies_hz=(0.8, 2.0, 3.2),
                                               loads_ohm=(22.0, 100.0), cycles=1.0, seed=seed,
                                               noise_force_N=0.0, noise_voltage_V=0.0))
    pts = prepare_tests(tests)
    rng = np.random.default_rng(seed)
    preds = [pt.y.copy() for pt in pts]
    for pt in pts:
        d = delay_of(pt.test)
        pt.y = pt.y.copy()
        pt.y[0] = np.interp(pt.time_s - d, pt.time_s, pt.y[0]) + rng.normal(0, 2.0, pt.y.shape[1])
        pt.sigma = np.array([2.0, 0.05])
    fit = [0, 2, 4, 5]  # every frequency in the fit set, the held-out tests beside them
    held = [1, 3]
    return [pts[k] for k in fit], [preds[k] for k in fit], [pts[k] for k in held], \
        [preds[k] for k in held]


def test_one_delay_for_every_test_is_proposed_and_earns():
    fp, fpr, hp, hpr = _delayed_case(lambda t: 0.004)
    term = propose_term(fp, fpr, hp, hpr, LEAD, 0, 0.5, 2000.0)
    assert term.group == "lag" and not term.refused
    assert abs(term.quantity["lag_ms"] - 4.0) < 0.4, term.description
    assert term.earns and term.error_after < 0.5 * term.error_before
    assert term.sse_fit_after < term.sse_fit_before


def test_a_shift_that_differs_from_test_to_test_is_refused_as_a_delay():
    """The lead of a transition over a fixed distance (presliding) is that distance over
    the speed: a different shift per test frequency, which a delay of the record is not."""
    delays = {0.8: 0.012, 2.0: 0.004, 3.2: -0.004}
    fp, fpr, hp, hpr = _delayed_case(lambda t: delays[round(t.frequency_hz, 1)])
    term = propose_term(fp, fpr, hp, hpr, LEAD, 0, 0.5, 2000.0)
    assert "not a delay of the record" in term.refused, term.message
    assert term.group != "lag"
    assert "lag_ms" not in term.quantity
