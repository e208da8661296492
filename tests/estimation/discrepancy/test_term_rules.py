"""The data-driven term judged like a catalogue effect: a time shift of the force is a
delay of the record only when one delay fits every test; a term that is a friction law
of another shape names no effect."""

import math

import numpy as np
import pytest

from ehsa_opt.estimation.discrepancy.terms import (
    discover_term,
    names_an_effect,
    propose_term,
    travel_since_reversal_m,
)
from tests.estimation.discrepancy.residual_cases import residual_case

LEAD = 0.01 / (2 * math.pi)


def _delayed_case(delay_of, seed=3):
    """Clean tests whose measured force is the noise-free model delayed by
    ``delay_of(test)`` plus 2 N white noise; the 'model' is the noise-free simulation."""
    pts, preds = residual_case(lambda pt: 0.0, seed, delay_of=delay_of)
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
    the speed: a different shift per test frequency, which neither a delay of the record
    nor a sensor's low-pass (whose lag at these frequencies is its own) is.  Without the
    check the shift or the low-pass is proposed (and earns); with it, what is left is a
    friction law of another shape, which names no effect."""
    delays = {0.8: 0.006, 2.0: 0.004, 3.2: 0.002}
    fp, fpr, hp, hpr = _delayed_case(lambda t: delays[round(t.frequency_hz, 1)])
    first = discover_term(fp, fpr, hp, hpr, lead_m_per_rad=LEAD)
    # a lag of the record (a shift, or a sensor's low-pass) is the best single support ...
    assert first.group in ("lag", "sensor")
    term = propose_term(fp, fpr, hp, hpr, LEAD, 0, 0.5, 2000.0)
    # ... but refused: the delay left differs from test to test
    assert ("not a delay of the record" in term.refused
            or "not a sensor's lag" in term.refused), term.message
    assert term.group not in ("lag", "sensor") and "lag_ms" not in term.quantity
    assert not names_an_effect(term)


def test_travel_since_reversal():
    t = np.linspace(0.0, 2.0, 2001)
    x, v = 0.01 * np.sin(2 * np.pi * t), np.cos(2 * np.pi * t)
    s = travel_since_reversal_m(x, v)
    assert np.all(np.isinf(s[:251]))  # no reversal yet
    assert s[500] == pytest.approx(0.01, rel=1e-3)  # from x = +10 mm back to 0
    assert s[1000] == pytest.approx(0.01, rel=1e-3)  # from the bottom (t = 0.75 s) to 0
    assert s[1240] == pytest.approx(0.02, rel=1e-2)  # bottom to just before the top
    assert s[1252] < 1e-5  # just after the reversal at the top


def _residual_case(extra, seed=5):
    pts, preds = residual_case(extra, seed)
    return pts[:4], preds[:4], pts[4:], preds[4:]


def test_a_friction_transition_over_a_distance_is_a_friction_law_not_an_effect():
    """Friction that reaches its level only 50 µm after each reversal (presliding) is
    found by the presliding columns and names no effect; a rough spot (a force at one
    place of the stroke) still does."""
    def presliding(pt):
        x, v, _ = pt.u
        return -30.0 * np.sign(v) * np.exp(-travel_since_reversal_m(x, v) / 5e-5)
    term = propose_term(*_residual_case(presliding), LEAD, 0, 0.5, 2000.0)
    assert term.group == "presliding" and term.earns, term.description
    assert not names_an_effect(term)

    def rough(pt):
        x, v, _ = pt.u
        return 20.0 * np.tanh(v / 1e-3) * ((x > 0.004) & (x < 0.010))
    term = propose_term(*_residual_case(rough), LEAD, 0, 0.5, 2000.0)
    assert term.group == "stroke" and term.earns, term.description
    assert names_an_effect(term)


@pytest.mark.parametrize("group, extra", [
    ("rotor_angle", lambda pt: 5.0 * np.sin(12 * pt.u[0] / LEAD + 0.3)),  # a detent
    ("rotor_angle", lambda pt: 0.05 * pt.y[0] * np.sin(pt.u[0] / LEAD)),  # a lead error
    ("velocity", lambda pt: 200.0 * pt.u[1]),  # more viscous friction: no effect
])
def test_the_support_is_chosen_by_bic_and_only_friction_laws_name_nothing(group, extra):
    term = propose_term(*_residual_case(extra), LEAD, 0, 0.5, 2000.0)
    assert term.group == group and term.earns, term.description
    assert names_an_effect(term) == (group != "velocity")
