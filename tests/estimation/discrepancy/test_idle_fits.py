"""Member fits made ahead on idle workers: a spare runs only beside the round's own
fits, finishes with the same fit as when asked for later, and never delays the round."""

import time

import pytest

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import CANDIDATES, Rig, prepare_tests
from ehsa_opt.estimation.discrepancy.candidate_fit import fit_member
from ehsa_opt.estimation.discrepancy.idle_fits import fit_with_spares
from ehsa_opt.estimation.discrepancy.rig import linear_baseline
from ehsa_opt.estimation.discrepancy import fit_group
from ehsa_opt.physics.params import HarvesterParams


def _args():
    spec = SyntheticSpec(effects={"voltage_drop": {"voltage_drop_V": 0.5}},
                         frequencies_hz=(1.5, 3.0), loads_ohm=(15.0, 109.0), cycles=1.0,
                         seed=5)
    pts = prepare_tests(generate_bench_tests(spec))
    fit_pts, held_pts = pts[:3], pts[3:]
    rig = Rig(HarvesterParams(), True, ())
    params = fit_group(fit_pts, rig, [linear_baseline(fit_pts, rig)], max_iter=50).parameters

    def args(name):
        return (name, CANDIDATES[name].component(), CANDIDATES[name].starts, fit_pts,
                fit_pts, held_pts, rig, params, 50)
    return args


def test_one_job_fits_no_spare():
    args = _args()
    fits, extra = fit_with_spares([args("voltage_drop")], [args("cogging")], 1)
    assert [f[0] for f in fits] == ["voltage_drop"] and extra == []


@pytest.mark.slow
def test_a_spare_fits_beside_a_longer_fit_and_is_stopped_beside_a_shorter_one():
    args = _args()
    t0 = time.perf_counter()
    alone = fit_member(args("voltage_drop"))
    t_short = time.perf_counter() - t0
    t0 = time.perf_counter()
    fit_member(args("compliance"))
    t_long = time.perf_counter() - t0
    assert t_long > 2 * t_short  # the premise: a spring's fit outlasts a diode's
    # beside the longer fit: the spare finishes, the same fit as asked for alone
    seconds: dict = {}
    fits, extra = fit_with_spares([args("compliance")], [args("voltage_drop")], 2,
                                  seconds=seconds)
    assert [f[0] for f in fits] == ["compliance"]
    assert [e[0] for e in extra] == ["voltage_drop"] and "voltage_drop" in seconds
    assert extra[0][1].parameters == pytest.approx(alone[1].parameters, rel=1e-9)
    # beside the shorter fit: the spare is stopped when it is done, no later
    t0 = time.perf_counter()
    fits, extra = fit_with_spares([args("voltage_drop")], [args("compliance")], 2)
    wall = time.perf_counter() - t0
    assert [f[0] for f in fits] == ["voltage_drop"] and extra == []
    assert wall < 0.5 * (t_short + t_long) + 1.0, (wall, t_short, t_long)
