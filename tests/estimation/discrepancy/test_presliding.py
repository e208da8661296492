"""The presliding transition of the base model's friction law: its amplitudes recovered
from a residual, adopted only when it earns, and a member that only explains presliding
no longer earns once the law is in every model judged."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES
from ehsa_opt.estimation.discrepancy.evidence import channel_sse, effective_samples, force_error_percent, force_noise_floor_percent, normalised_sse
from ehsa_opt.estimation.discrepancy.judge import judge_candidate
from ehsa_opt.estimation.discrepancy.candidate_evidence import measure_candidate
from ehsa_opt.estimation.discrepancy.presliding import (
    PRESLIDING_LENGTHS_M,
    adopt_presliding,
    fit_amplitudes,
    presliding_columns,
    travel_since_reversal_m,
)
from ehsa_opt.estimation.discrepancy.results import CandidateResult
from ehsa_opt.physics import make_component

from tests.estimation.discrepancy.residual_cases import residual_case


def _presliding(a10, a30):
    def extra(pt):
        x, v, _ = pt.u
        s = travel_since_reversal_m(x, v)
        return np.sign(v) * (a10 * np.exp(-s / 1e-5) + a30 * np.exp(-s / 3e-5))
    return extra


def _case(extra, seed=5, sigma=2.0):
    """Fit tests, their model outputs, held-out tests, theirs (every other test)."""
    pts, preds = residual_case(extra, seed, sigma, voltage_noise_V=0.05)
    return pts[::2], preds[::2], pts[1::2], preds[1::2]


def _adopt(fp, fpr, hp, hpr):
    return adopt_presliding(fp, fpr, hp, hpr, force_noise_floor_percent(hp),
                            effective_samples(fp, fpr), effective_samples(hp, hpr))


def test_columns_are_the_transition_after_each_reversal():
    fp, *_ = _case(lambda pt: 0.0)
    pt = fp[0]
    X = presliding_columns(pt)
    assert X.shape == (pt.time_s.size, len(PRESLIDING_LENGTHS_M))
    s = travel_since_reversal_m(pt.u[0], pt.u[1])
    after = np.flatnonzero(s < 1e-6)
    assert after.size and np.allclose(np.abs(X[after, 0]), 1.0, atol=0.1)
    assert np.all(X[np.isinf(s)] == 0.0)  # before the first reversal: no transition


def test_known_presliding_amplitudes_are_recovered_and_adopted():
    fp, fpr, hp, hpr = _case(_presliding(-34.0, -15.0))
    coef = fit_amplitudes(fp, fpr)
    assert coef == pytest.approx([-34.0, -15.0], rel=0.1, abs=1.5)
    law = _adopt(fp, fpr, hp, hpr)
    assert law.adopted, law.message
    assert law.amplitudes_N == pytest.approx(list(coef))
    assert law.error_after < 0.5 * law.error_before
    assert law.delta_bic_fit < 0 and law.delta_bic_heldout < 0
    # every model judged gets its own term: the held-out residual left is the noise
    pf, ph = law.correct(fp, fpr, hp, hpr)
    assert force_error_percent(hp, ph) == pytest.approx(law.error_after, rel=0.02)
    assert force_error_percent(hp, ph) < 1.2 * force_noise_floor_percent(hp)
    d = law.as_dict()
    assert d["adopted"] and d["lengths_m"] == list(PRESLIDING_LENGTHS_M)


def test_a_white_residual_does_not_adopt_it():
    fp, fpr, hp, hpr = _case(lambda pt: 0.0)
    law = _adopt(fp, fpr, hp, hpr)
    assert not law.adopted, law.message
    assert "not adopted" in law.message
    pf, ph = law.correct(fp, fpr, hp, hpr)  # not adopted: predictions unchanged
    assert all(a is b or np.array_equal(a, b) for a, b in zip(pf + ph, fpr + hpr))


def test_a_friction_of_another_shape_over_the_stroke_does_not_adopt_it():
    """A rough spot (friction-like force over 6 mm of the stroke) is not a transition
    after each reversal: the columns do not explain it."""
    def rough(pt):
        x, v, _ = pt.u
        return 20.0 * np.tanh(v / 1e-3) * ((x > 0.004) & (x < 0.010))
    law = _adopt(*_case(rough))
    assert not law.adopted, law.message


def _judge(fp, fpr, hp, hpr, cand_f, cand_h, presliding):
    """A compliance refit whose outputs are ``cand_f``/``cand_h`` judged against the
    current model ``fpr``/``hpr`` (corrected by ``presliding`` when adopted, as the
    search does)."""
    if presliding is not None:
        fpr, hpr = presliding.correct(fp, fpr, hp, hpr)
    comp = make_component("compliance")
    pars = {"compliance_stiffness_N_per_m": 5.5e6, "compliance_damping_Ns_per_m": 300.0}
    res = SimpleNamespace(parameters=pars, interval=lambda n: None, message="synthetic",
                          seconds=0.0, starts=[])
    ch_sse0, ch_n = channel_sse(hp, hpr)
    cur_err = force_error_percent(hp, hpr)
    c = CandidateResult("compliance", True, 0.5, 0.5, 1, error_before=cur_err)
    said = []
    ev_floor = force_noise_floor_percent(hp)
    ev = measure_candidate(c, ("compliance", res, cand_f, cand_h, SimpleNamespace(components=[comp])),
                    member=CANDIDATES["compliance"], comps={"compliance": comp}, fit_pts=fp,
                    held_pts=hp, sse_fit=normalised_sse(fp, fpr),
                    sse_held=normalised_sse(hp, hpr), n_eff_fit=effective_samples(fp, fpr),
                    n_eff_held=effective_samples(hp, hpr), cur_err=cur_err,
                    floor=ev_floor, ch_sse0=ch_sse0, ch_n=ch_n,
                    say=said.append, cur_ev_pred=hpr, laws=presliding)
    judge_candidate(c, ev, cur_err=cur_err, floor=ev_floor, say=said.append)
    return c, said


def _absorbing(pts, preds, extra, share):
    """Outputs of a member that absorbs ``share`` of the force term ``extra``."""
    out = []
    for pt, yp in zip(pts, preds):
        y = yp.copy()
        y[0] = y[0] + share * extra(pt)
        out.append(y)
    return out


def test_a_member_that_only_explains_presliding_no_longer_earns():
    extra = _presliding(-34.0, -15.0)
    fp, fpr, hp, hpr = _case(extra)
    # a series spring bends the force at reversals: 70 % of the presliding misfit
    cf, chh = _absorbing(fp, fpr, extra, 0.7), _absorbing(hp, hpr, extra, 0.7)
    c0, said0 = _judge(fp, fpr, hp, hpr, cf, chh, None)
    assert c0.earns, said0  # without the law in the base model it earns for presliding
    law = _adopt(fp, fpr, hp, hpr)
    assert law.adopted
    c1, said1 = _judge(fp, fpr, hp, hpr, cf, chh, law)
    assert not c1.earns, said1
    assert c1.error_after >= c1.error_before - 0.01 * c1.error_before


def test_a_member_with_an_effect_of_its_own_still_earns_beside_the_law():
    pres = _presliding(-34.0, -15.0)

    def own(pt):  # a smooth force of the member's own, not a reversal transition
        return 6.0 * np.sin(2 * np.pi * pt.u[0] / 0.02)
    fp, fpr, hp, hpr = _case(lambda pt: pres(pt) + own(pt))
    law = _adopt(fp, fpr, hp, hpr)
    assert law.adopted
    cf, chh = _absorbing(fp, fpr, own, 1.0), _absorbing(hp, hpr, own, 1.0)
    c, said = _judge(fp, fpr, hp, hpr, cf, chh, law)
    assert c.earns, said
    assert math.isfinite(c.error_after) and c.error_after < 0.6 * c.error_before


def test_a_force_above_the_static_map_after_reversals_is_not_presliding():
    """Presliding builds the friction up after a reversal (amplitudes ≤ 0); a force
    that overshoots there (a spring's ringing) is not fitted by the law."""
    fp, fpr, hp, hpr = _case(_presliding(+30.0, 0.0))
    coef = fit_amplitudes(fp, fpr)
    assert np.all(coef <= 0.0) and np.all(np.abs(coef) < 3.0), coef
    assert not _adopt(fp, fpr, hp, hpr).adopted
