"""A round ranked and fitted before it started (the delay's rival check) is reused by
the first round, which is decided on those fits even after the deadline."""

import time

from ehsa_opt.datasets.bench_format import write_bench
from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import DiscrepancySettings
from ehsa_opt.estimation.discrepancy.budget import budget_set
from ehsa_opt.estimation.discrepancy.search import (judge_context, judge_round, rank_round,
                                                    ranked_ahead, run_rounds)
from ehsa_opt.estimation.discrepancy.workflow import (fit_baseline, load_data,
                                                      prepare_search_tests)


def _diode_campaign(tmp_path):
    spec = SyntheticSpec(effects={"voltage_drop": {"voltage_drop_V": 0.6}},
                         frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(22.0, 100.0),
                         cycles=1.0, seed=21)
    write_bench(tmp_path / "diode", generate_bench_tests(spec), harvester=spec.harvester,
                rig={"name": "diode", "has_generator": True})
    settings = DiscrepancySettings(candidates=("voltage_drop", "cogging"), max_effects=1,
                                   jobs=1, wall_cap_s=100.0)
    say, notes = (lambda m: None), []
    tests = prepare_search_tests(load_data(tmp_path / "diode", say, notes), settings, say,
                                 notes)
    return tests, fit_baseline(tests, settings, say), settings


def test_a_round_fitted_ahead_is_decided_on_those_fits_after_the_deadline(tmp_path):
    tests, base, settings = _diode_campaign(tmp_path)
    said: list[str] = []
    state = base.state(settings)
    rk = rank_round(tests, state, settings)
    assert "voltage_drop" in rk.chosen
    judge = judge_context(1, tests, state, rk, said.append, [], settings.criterion)
    judge_round(rk, ["voltage_drop"], tests, state, settings, judge, keep=True)
    assert rk.cands["voltage_drop"].earns and len(state.fitted) == 1
    state.ranking = (state.rig, list(state.remaining), rk)
    assert ranked_ahead(state) is rk
    # made on another model (another rig, or other members remaining): not reused
    other = base.state(settings)
    other.ranking = (base.rig.with_components([]), list(other.remaining), rk)
    assert ranked_ahead(other) is None
    other.ranking = (other.rig, ["voltage_drop"], rk)
    assert ranked_ahead(other) is None

    with budget_set(None, 1e-9):
        time.sleep(0.01)
        # without fits made ahead, no round runs after the deadline: undecided
        bare = base.state(settings)
        run_rounds(tests, bare, settings, said.append, [], [])
        assert bare.effects == [] and "before round 1" in bare.cut
        # with them, the round is decided on the fit made before the deadline
        all_cands: list = []
        out = run_rounds(tests, state, settings, said.append, [], all_cands)
    assert out.effects == ["voltage_drop"], said
    assert "before round 1" not in out.cut
    assert state.ranking is None  # used once
    assert any("judged, not repeated" in m for m in said)
    # a member ranked in but not fitted before the deadline is a stated cut
    if "cogging" in rk.chosen:
        assert "cogging not re-identified" in out.cut
