"""A member fit that the time budget cut at its start point is not fitted: it cannot
earn, cannot open or complete a look-ahead path, and it is work left at the budget."""

import math
import time
from types import SimpleNamespace as NS

import numpy as np

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import CANDIDATES, Rig, predict, prepare_tests
from ehsa_opt.estimation.discrepancy.candidate_fit import CUT_RECORD, not_fitted
from ehsa_opt.estimation.discrepancy.budget import (budget_set, elapsed_s, note_cut,
                                                      recording_cuts, time_left_s)
from ehsa_opt.estimation.discrepancy.evidence import force_noise_floor_percent
from ehsa_opt.estimation.discrepancy.lookahead import (confounded, confounded_first,
                                                       fit_on_top, lookahead_winner,
                                                       supported)
from ehsa_opt.estimation.discrepancy.results import CandidateResult
from ehsa_opt.estimation.discrepancy.search import _ranked_above
from ehsa_opt.estimation.fit_result import FitResult
from ehsa_opt.physics.params import HarvesterParams

H = HarvesterParams()


def _cut_fit(moved: bool) -> FitResult:
    return FitResult(success=True, message="m", parameters={"voltage_drop_V": 0.05},
                     records={CUT_RECORD: {"stages": [{"stage": "Gauss-Newton on the "
                                                       "simulation", "simulations": 1,
                                                       "moved": moved}],
                                           "moved": moved}})


def test_not_fitted_reads_the_cut_record():
    assert "not fitted" in not_fitted(_cut_fit(moved=False))
    assert "after 1 simulation)" in not_fitted(_cut_fit(moved=False))
    assert not_fitted(_cut_fit(moved=True)) == ""  # cut after it moved: a (partial) fit
    assert not_fitted(FitResult(success=True, message="m")) == "" and not_fitted(None) == ""


def test_cut_records_are_collected_per_fit_and_the_clock_is_the_runs():
    note_cut("outside", 1, False)  # no fit in progress: not recorded anywhere
    with recording_cuts() as outer:
        with recording_cuts() as inner:
            note_cut("screening of starts", 3, True)
        note_cut("Gauss-Newton on the simulation", 1, False)
    assert [c["stage"] for c in inner] == ["screening of starts"]
    assert [c["simulations"] for c in outer] == [3, 1]
    assert math.isinf(time_left_s())
    with budget_set(None, 100.0):
        assert 0.0 <= elapsed_s() < 5.0 and 95.0 < time_left_s() <= 100.0


def _stub(effect, **kw):
    fields = dict(fitted=True, predictions=[np.zeros((2, 3))], delta_bic_fit=-50.0,
                  delta_bic_heldout=-20.0)
    fields.update(kw)
    return CandidateResult(effect, True, 0.1, 1.0, **fields)


def test_a_cut_member_is_neither_confounded_nor_a_first_step():
    cut = _stub("compliance", delta_bic_fit=-900.0, cut_at_deadline="cut at its start")
    other = _stub("cogging", delta_bic_fit=-30.0)
    assert confounded([cut, other]) is other
    assert not supported(cut) and supported(other)


def test_a_cut_member_is_work_left_at_the_budget():
    """Fitted with held-out ΔBIC ≥ 0 is no work left; the same member cut at its start
    point is (it was never fitted)."""
    names = ["cogging", "backlash"]
    rk = NS(scores={n: {"applicable": True, "score": 0.03, "chi2": 0.0} for n in names},
            comps={n: CANDIDATES[n].component() for n in names},
            cands={"cogging": NS(fitted=True, delta_bic_heldout=12.0, cut_at_deadline=""),
                   "backlash": NS(fitted=True, delta_bic_heldout=12.0,
                                  cut_at_deadline="cut at its start point")})
    state = NS(remaining=list(names), rig=Rig(H, True, ()))
    assert _ranked_above(rk, state) == ["backlash"]


def test_a_look_ahead_fit_cut_at_its_start_opens_and_completes_no_path():
    """The confounded member (a mount spring) with a generator member fitted on top of
    it after the deadline: the fit stops at its screened start after one simulation per
    stage, is judged not earning whatever its start point explains, the path is not
    decided (recorded as cut) and the reverse look-ahead does not add the spring."""
    spec = SyntheticSpec(effects={"voltage_drop": {"voltage_drop_V": 0.5}},
                         frequencies_hz=(1.5, 3.0), loads_ohm=(15.0, 109.0), cycles=1.0,
                         seed=5)
    pts = prepare_tests(generate_bench_tests(spec))
    fit_pts, held_pts = pts[:3], pts[3:]
    spring = CANDIDATES["compliance"].component()
    rig = Rig(H, True, (spring,))
    params = {**spec.friction.as_dict(), **spring.defaults(),
              "compliance_stiffness_N_per_m": 3e7, "compliance_damping_Ns_per_m": 1e3}
    pred = predict(pts, rig, params)
    from ehsa_opt.estimation.discrepancy.evidence import force_error_percent
    err = force_error_percent(held_pts, pred[3:])
    blocked = CandidateResult("compliance", True, 0.4, 1.0, fitted=True, rig=rig,
                              fit=FitResult(success=True, message="m", parameters=params),
                              predictions=pred, error_before=err + 1.0, error_after=err,
                              delta_bic_fit=-100.0, delta_bic_heldout=5.0)
    second = CandidateResult("voltage_drop", True, 0.9, 1.0, error_before=err)
    said, cuts = [], []
    judge = dict(comps={"voltage_drop": CANDIDATES["voltage_drop"].component()},
                 fit_pts=fit_pts, held_pts=held_pts, floor=force_noise_floor_percent(held_pts),
                 say=said.append, masks=None)
    with budget_set(None, 1e-9):
        time.sleep(0.01)
        step = fit_on_top(blocked, second, judge, fit_pts, 50, 1, {}, cuts)
        assert step is not None and step.cut_at_deadline and not step.earns
        assert cuts == ["voltage_drop on top of compliance"]
        # the fit stayed at its screened start (one of the member's starts)
        assert step.parameters["voltage_drop_V"] in [s["voltage_drop_V"] for s in
                                                     CANDIDATES["voltage_drop"].starts]
        added = confounded_first(blocked, [second], lambda c: step, err + 1.0,
                                 judge["floor"], math.inf, said.append)
    assert not added
    assert any("not decided" in m for m in said), said
    # nor does a cut second step make its first step the round's winner
    first = _stub("cogging", earns=True, error_before=err + 1.0, error_after=err,
                  sse_heldout=10.0, rig=rig)
    assert lookahead_winner([first], blocked, lambda c: step, said.append) is None


def test_no_member_fit_starts_after_the_deadline():
    from ehsa_opt.estimation.discrepancy.candidate_fit import fit_members
    with budget_set(None, 1e-9):
        time.sleep(0.01)
        # (the argument tuples are never opened: nothing is started)
        assert fit_members([("cogging",), ("backlash",)], 2, until_deadline=True) == []
        assert fit_members([("cogging",)], 1, until_deadline=True) == []


def test_the_ranking_one_member_per_process_gives_the_same_scores():
    from ehsa_opt.estimation.discrepancy import fit_group, signature_scores
    from ehsa_opt.estimation.discrepancy.candidate_fit import signature_scores_in
    from ehsa_opt.estimation.discrepancy.candidates import components_for
    from ehsa_opt.estimation.discrepancy.rig import linear_baseline
    spec = SyntheticSpec(effects={"cogging": {"cogging_sin_Nm": 0.02}},
                         frequencies_hz=(1.5,), loads_ohm=(15.0, 109.0), cycles=1.0, seed=3)
    pts = prepare_tests(generate_bench_tests(spec))
    rig = Rig(H, True, ())
    base = fit_group(pts, rig, [linear_baseline(pts, rig)])
    pred = predict(pts, rig, base.parameters)
    names = ["cogging", "voltage_drop", "magnetic_saturation"]
    comps = components_for(names, pts, pred, H.lead_m_per_rad)
    one = signature_scores(pts, rig, base.parameters, pred, names, comps)
    two = signature_scores_in(2, pts, rig, base.parameters, pred, names, comps)
    assert list(two) == names
    for n in names:
        assert two[n]["score"] == one[n]["score"] and two[n]["chi2"] == one[n]["chi2"], n
