"""The look-ahead through a confounded candidate: which second steps it tries, and the
reuse of its fits by the next round."""

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import (CANDIDATES, Rig, fit_group, predict,
                                             prepare_tests, signature_scores)
from ehsa_opt.estimation.discrepancy.candidates import (MIN_RANK_VALUE, components_for,
                                                        rank_value)
from ehsa_opt.estimation.discrepancy.lookahead import member_key, second_steps
from ehsa_opt.estimation.discrepancy.results import CandidateResult
from ehsa_opt.estimation.discrepancy.rig import linear_baseline
from ehsa_opt.physics.params import HarvesterParams

H = HarvesterParams()


def test_second_steps_are_ranked_on_the_residual_of_the_model_with_the_confounded_one():
    """A 0.1 mm gap beside a cogging: on the baseline's residual the cogging explains
    almost nothing (the gap dominates it), on the residual of the model with the gap it
    explains most — the look-ahead's second steps are ranked there."""
    spec = SyntheticSpec(effects={"backlash": {"backlash_gap_m": 1e-4},
                                  "cogging": {"cogging_sin_Nm": 0.02}},
                         frequencies_hz=(1.5, 3.5), loads_ohm=(15.0, 109.0), cycles=1.0,
                         seed=14)
    pts = prepare_tests(generate_bench_tests(spec))
    rig0 = Rig(H, True, ())
    base = fit_group(pts, rig0, [linear_baseline(pts, rig0)])
    assert base.success, base.message
    pred0 = predict(pts, rig0, base.parameters)
    names = ["cogging", "compliance", "voltage_drop", "winding_heating"]
    sc0 = signature_scores(pts, rig0, base.parameters, pred0, names,
                           components_for(names, pts, pred0, H.lead_m_per_rad))
    # the gap (true size, true friction): what the confounded gap's refit stands for
    gap = CANDIDATES["backlash"].component()
    rig = Rig(H, True, (gap,))
    params = {**spec.friction.as_dict(), **gap.defaults(), "backlash_gap_m": 1e-4}
    pred = predict(pts, rig, params)
    blocked = CandidateResult("backlash", True, 0.3, 1.0, fitted=True, error_after=15.0,
                              rig=rig, predictions=pred, fit=FitStub(params))
    said = []
    steps = second_steps(blocked, ["backlash", *names], pts, pts, H.lead_m_per_rad,
                         said.append)
    assert [c.effect for c in steps][:1] == ["cogging"], said
    hidden = rank_value(sc0["cogging"])
    assert hidden < MIN_RANK_VALUE  # not re-identified in the round on the baseline
    assert steps[0].score > 10 * hidden and not steps[0].fitted
    # one transmission at most: the mount spring cannot join the gap
    assert "compliance" not in [c.effect for c in steps]
    assert "ranked on the residual of the model with backlash: cogging" in said[0]


class FitStub:
    """The part of a FitResult the ranking reads (its parameters)."""

    def __init__(self, parameters):
        self.parameters = dict(parameters)


def test_member_key_tells_identical_fit_calls_from_different_ones():
    """The next round reuses the look-ahead's fit only for the same member, component
    configuration, rig object, parameters and tests."""
    comp12 = CANDIDATES["cogging"].component(periods_per_rev=12)
    rig = Rig(H, True, ())
    pts = [object(), object()]
    args = ("cogging", comp12, CANDIDATES["cogging"].starts, pts[:1], pts, [], rig,
            {"a": 1.0}, 150)
    same = ("cogging", CANDIDATES["cogging"].component(periods_per_rev=12),
            CANDIDATES["cogging"].starts, pts[:1], pts, [], rig, {"a": 1.0}, 150)
    assert member_key(args) == member_key(same)
    for i, other in ((1, CANDIDATES["cogging"].component(periods_per_rev=4)),
                     (6, Rig(H, True, ())), (7, {"a": 1.0 + 1e-12}), (3, pts[1:])):
        changed = list(args)
        changed[i] = other
        assert member_key(tuple(changed)) != member_key(args), i


def test_no_candidate_is_confounded_when_an_earning_one_explains_the_fit_tests_better():
    """A mount spring failing on the held-out tests beside an earning winding heating
    that explains the fit tests better (fit ΔBIC −197 against −355) is no sign of an
    absorbed effect: no look-ahead through it.  Once it explains the fit tests best of
    all (−400), it is the confounded candidate again."""
    from types import SimpleNamespace as NS

    from ehsa_opt.estimation.discrepancy.lookahead import confounded

    def cand(effect, earns, dbic_fit):
        return NS(effect=effect, fitted=True, earns=earns, predictions=[],
                  delta_bic_fit=dbic_fit, delta_bic_heldout=-10.0 if earns else 9.0)
    heat = cand("winding_heating", True, -355.0)
    sat = cand("magnetic_saturation", True, -294.0)
    spring = cand("compliance", False, -197.0)
    assert confounded([heat, sat, spring]) is None
    spring.delta_bic_fit = -400.0
    assert confounded([heat, sat, spring]) is spring
    # candidates that do not earn are not compared with: the best of them is confounded
    heat.earns = sat.earns = False
    spring.delta_bic_fit = -197.0
    assert confounded([heat, sat, spring]) is heat


def test_the_reverse_look_ahead_skips_a_model_the_forward_paths_judged():
    """A winding heating that earned alone was the first step of a forward path (the
    spring re-identified on top of it, judged): the reverse path (the heating on top of
    the spring) re-identifies the same model and is not tried; a supported first step
    that did not earn alone (too little to start the joint fit from) and a path cut by
    the budget are tried again from the spring's side."""
    from types import SimpleNamespace as NS

    from ehsa_opt.estimation.discrepancy.lookahead import lookahead_winner, not_judged

    def cand(effect, earns):
        return NS(effect=effect, earns=earns, fitted=True, predictions=[], resolved=True,
                  delta_bic_fit=-50.0, delta_bic_heldout=-20.0 if earns else 5.0,
                  sse_heldout=4000.0, error_before=11.3, error_after=11.2, at_bound=[],
                  cut_at_deadline="")
    heat, sat, cog = cand("winding_heating", True), cand("magnetic_saturation", True), \
        cand("cogging", False)
    spring = cand("compliance", False)

    def on_top(c):  # the spring on top of c: decided except on top of the saturation
        return NS(earns=False, sse_heldout=4100.0, error_after=11.25, first_resolved=True,
                  cut_at_deadline="not fitted" if c is sat else "")
    judged, said = [], []
    assert lookahead_winner([heat, sat], spring, on_top, first_steps=[cog], judged=judged,
                            max_paths=3) is None
    assert judged == ["winding_heating"]
    seconds = [cand(n, False) for n in ("winding_heating", "magnetic_saturation", "cogging")]
    left = not_judged(seconds, judged, spring, said.append)
    assert [c.effect for c in left] == ["magnetic_saturation", "cogging"]
    assert said and "winding_heating not re-identified on top of compliance" in said[0]
