"""A generator member earns on its own channel (the voltage) whatever the force's
excess; the per-channel statistics that rule uses."""

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.signal import lfilter

from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES
from ehsa_opt.estimation.discrepancy.channels import channel_delta_bic, channel_effective_samples
from ehsa_opt.estimation.discrepancy.evidence import channel_sse, delta_bic, effective_samples, force_error_percent, force_noise_floor_percent, normalised_sse
from ehsa_opt.estimation.discrepancy.candidate_evidence import measure_candidate
from ehsa_opt.estimation.discrepancy.judge import earns_on_own_channel, judge_candidate, refuted_by_channel
from ehsa_opt.estimation.discrepancy.prepared import PreparedTest
from ehsa_opt.estimation.discrepancy.results import CandidateResult
from ehsa_opt.physics import make_component


def test_channel_delta_bic_is_the_sum_of_the_per_channel_likelihoods():
    s0, s1, ne = [300.0, 4.0], [301.5, 3.2], [400.0, 3000.0]
    want = 400 * math.log(301.5 / 300) + 3000 * math.log(3.2 / 4.0) + 2 * math.log(3400)
    assert channel_delta_bic(s0, s1, ne, 2) == pytest.approx(want)
    # the pooled ΔBIC sees the force's 0.5 % growth only and prefers the smaller model
    assert delta_bic(sum(s1), sum(s0), 2, sum(ne)) > 0 > channel_delta_bic(s0, s1, ne, 2)
    # a channel without samples is left out
    assert channel_delta_bic([300.0, 0.0], [290.0, 0.0], [400.0, 0.0], 1) == pytest.approx(
        400 * math.log(290 / 300) + math.log(400))


def _pt(y, sigma):
    n = y.shape[1]
    return PreparedTest(test=None, motion=None, time_s=np.arange(n) * 1e-3, u=None, y=y,
                        sigma=np.asarray(sigma, float), fixed={})


def test_channel_effective_samples_discount_autocorrelation():
    rng = np.random.default_rng(1)
    n = 20000
    white = rng.normal(size=n)
    red = lfilter([1.0], [1.0, -0.8], rng.normal(size=n))
    pt = _pt(np.vstack([white, red]), [1.0, 1.0])
    ne = channel_effective_samples([pt], [np.zeros((2, n))])
    assert ne[0] == pytest.approx(n, rel=0.1)
    # AR(1) with ρ = 0.8: τ = (1 + ρ)/(1 − ρ) = 9
    assert ne[1] == pytest.approx(n / 9, rel=0.25)
    assert effective_samples([pt], [np.zeros((2, n))]) == pytest.approx(ne.sum())


def test_refuted_by_channel_charges_the_parameters():
    assert not refuted_by_channel(300.0, 301.0, 2, 400.0)   # 400 ln(301/300) = 1.3 < 12
    assert refuted_by_channel(300.0, 330.0, 2, 400.0)       # 38 > 12


@pytest.mark.parametrize("red, dbf, dbh, kept, ok", [
    (0.28, -12.0, -900.0, True, True),
    (0.05, -12.0, -900.0, True, False),   # too small a share of the channel's excess
    (None, -12.0, -900.0, True, False),   # no own channel with an excess
    (0.28, 3.0, -900.0, True, False),     # the fit tests do not support it
    (0.28, -12.0, 5.0, True, False),      # the held-out tests do not
    (0.28, -12.0, -900.0, False, False),  # the force refutes it
])
def test_earns_on_own_channel(red, dbf, dbh, kept, ok):
    assert earns_on_own_channel(red, dbf, dbh, kept) is ok


def _campaign(seed, force_change):
    """Force with a large unmodelled misfit (a presliding-like 8 N wave) and a voltage
    whose gain drifts by 2 % (a heating); the current model has neither, the candidate
    the voltage drift and a force changed by ``force_change`` (N, a smooth wave)."""
    rng = np.random.default_rng(seed)
    n = 4000
    t = np.arange(n) * 1e-3
    pts, cur, cand = [], [], []
    for k in range(4):
        s = np.sin(2 * np.pi * (0.7 + 0.3 * k) * t)
        f_model = 100 * s
        misfit = 8 * np.tanh(30 * np.cos(2 * np.pi * (0.7 + 0.3 * k) * t))
        v_model = 5 * s
        drift = 1.0 - 0.02 * (1 - np.exp(-t / 1.5))
        y = np.vstack([f_model + misfit + rng.normal(0, 1.0, n),
                       v_model * drift + rng.normal(0, 0.01, n)])
        pts.append(_pt(y, [1.0, 0.01]))
        cur.append(np.vstack([f_model, v_model]))
        cand.append(np.vstack([f_model + force_change * np.sin(2 * np.pi * 0.2 * t),
                               v_model * drift]))
    return pts[:2], pts[2:], cur[:2], cur[2:], cand[:2], cand[2:]


def _judge(member, force_change=0.05, already=()):
    """A winding-heating refit judged by ``judge_candidate``; ``already``: names of the
    members in the current model before it."""
    fit_pts, held_pts, cf, ch, pf, ph = _campaign(0, force_change)
    comp = make_component("winding_heating")
    res = SimpleNamespace(parameters={"winding_heating_K_per_J": 3.0,
                                      "winding_cooling_time_s": 1.5},
                          interval=lambda n: (2.5, 3.5) if n.endswith("K_per_J") else (1, 2),
                          message="synthetic", seconds=0.0, starts=[])
    ch_sse0, ch_n = channel_sse(held_pts, ch)
    cur_err = force_error_percent(held_pts, ch)
    c = CandidateResult("winding_heating", True, 0.5, 0.5, 1 + len(already),
                        error_before=cur_err)
    said = []
    crig = SimpleNamespace(components=[make_component(n) for n in already] + [comp])
    ev_floor = force_noise_floor_percent(held_pts)
    ev = measure_candidate(c, ("winding_heating", res, pf, ph, crig),
                    member=member, comps={"winding_heating": comp}, fit_pts=fit_pts,
                    held_pts=held_pts, sse_fit=normalised_sse(fit_pts, cf),
                    sse_held=normalised_sse(held_pts, ch),
                    n_eff_fit=effective_samples(fit_pts, cf),
                    n_eff_held=effective_samples(held_pts, ch), cur_err=cur_err,
                    floor=ev_floor, ch_sse0=ch_sse0, ch_n=ch_n,
                    say=said.append, cur_ev_pred=ch)
    judge_candidate(c, ev, cur_err=cur_err, floor=ev_floor, say=said.append)
    return c, said


def test_a_generator_member_earns_on_its_voltage_where_the_force_excess_dominates():
    member = CANDIDATES["winding_heating"]
    assert member.own_channels == (1,)
    c, said = _judge(member)
    assert not c.sse_route  # the force's excess dominates: the old SSE route is closed
    assert c.earns and c.earns_by == "own channel", said
    # the same fit judged as a member without an own channel: the force decides
    c2, _ = _judge(dataclasses.replace(member, own_channels=None))
    assert not c2.earns
    # a refit that trades the force for the voltage is refuted by the force (its SSE
    # grows by more than the parameters are charged on its effective samples)
    c3, said3 = _judge(member, force_change=6.0)
    assert not c3.earns and "force refuted" in said3[-1]


def test_generator_members_own_the_voltage_and_mechanical_ones_do_not():
    for n in ("voltage_drop", "winding_heating", "magnetic_saturation"):
        assert CANDIDATES[n].own_channels == (1,)
    for n in ("backlash", "compliance", "cogging", "asymmetric_friction",
              "position_friction"):
        assert CANDIDATES[n].own_channels is None


def test_the_own_channel_route_is_for_the_first_generator_effect():
    from ehsa_opt.estimation.discrepancy.evidence import acts_on_generator
    assert all(acts_on_generator(make_component(n))
               for n in ("voltage_drop", "winding_heating", "magnetic_saturation"))
    assert not any(acts_on_generator(make_component(n))
                   for n in ("backlash", "compliance", "cogging", "asymmetric_friction"))
    # the same fit on top of a voltage drop already in the model: the force decides
    c, _ = _judge(CANDIDATES["winding_heating"], already=("voltage_drop",))
    assert not c.earns


def test_a_record_members_rival_is_compared_on_the_members_channel():
    """The voltage share a catalogue rival removes (:func:`channel_excess_reduction`):
    the whole excess for a candidate with the voltage right, none for one that only
    changes the force — whatever it does to the force error, which a voltage member
    leaves as it is."""
    from types import SimpleNamespace
    from ehsa_opt.estimation.discrepancy.lag_rival import channel_excess_reduction
    fit_pts, held_pts, cf, ch, pf, ph = _campaign(3, 0.0)
    tests = SimpleNamespace(fit_pts=fit_pts, held_pts=held_pts, eval_pts=held_pts)
    state = SimpleNamespace(eval_pred=lambda: ch)
    voltage_right = CandidateResult("winding_heating", True, 0.5, 0.5, 1)
    voltage_right.predictions = pf + ph
    assert channel_excess_reduction(tests, state, voltage_right, 1) == pytest.approx(1.0,
                                                                                     abs=0.05)
    # a force-only change (the force's misfit removed, the voltage as before)
    force_only = CandidateResult("backlash", True, 0.5, 0.5, 1)
    force_only.predictions = [np.vstack([pt.y[0], c[1]]) for pt, c in
                              zip(fit_pts + held_pts, cf + ch)]
    assert channel_excess_reduction(tests, state, force_only, 1) == pytest.approx(0.0,
                                                                                  abs=1e-9)
    assert channel_excess_reduction(tests, state, force_only, 0) > 0.9
