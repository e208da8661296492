"""A lone fit's simulations spread over the run's workers give the same numbers, bit for
bit, as the same simulations one after the other in the calling process."""

import os

import numpy as np
import pytest

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import spread as spread_mod
from ehsa_opt.physics import make_component
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.rig import (Rig, predict, predict_map,
                                                 predict_map_jacobian, simulate_raw)
from ehsa_opt.estimation.discrepancy.spread import spread_simulations


def _campaign(effect, values):
    spec = SyntheticSpec(effects={effect: values}, frequencies_hz=(1.0, 2.0),
                         loads_ohm=(47.0, 109.0), seed=3)
    pts = prepare_tests(generate_bench_tests(spec), True)
    rig = Rig(spec.harvester, True, (make_component(effect),))
    return pts, rig, {**make_component(effect).defaults(), **spec.friction.as_dict(), **values}


def _same(a, b):
    """The same numbers in the same memory layout (a later sum adds in the same order)."""
    assert len(a) == len(b)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
        assert x.strides == y.strides


def test_a_rattling_contact_simulated_on_two_workers_is_the_same_to_the_last_bit():
    pts, rig, p = _campaign("backlash", {"backlash_gap_m": 3e-4,
                                         "backlash_contact_stiffness_N_per_m": 1e8,
                                         "backlash_contact_damping_Ns_per_m": 8e3})
    alone = predict(pts, rig, p)
    with spread_simulations(2, pts):
        pool = spread_mod._POOL[0][0]
        assert pool.submit(os.getpid).result() != os.getpid()  # worker processes
        got = spread_mod.spread(simulate_raw, "cvodes", pts, rig, p, rtol=1e-7)
        together = predict(pts, rig, p)
    assert got is not None
    _same([raw[0][:2] for raw in got], alone)
    _same(together, alone)
    assert spread_mod._POOL[0] is None  # closed with the block


def test_the_map_and_its_sensitivities_spread_give_the_same_numbers():
    pts, rig, p = _campaign("compliance", {"compliance_stiffness_N_per_m": 2e6,
                                           "compliance_damping_Ns_per_m": 1e3})
    names = ["compliance_stiffness_N_per_m", "nut_coulomb_N"]
    y0, (y1, j1) = predict_map(pts, rig, p), predict_map_jacobian(pts, rig, p, names)
    with spread_simulations(2, pts):
        _same(predict_map(pts, rig, p), y0)
        y2, j2 = predict_map_jacobian(pts, rig, p, names)
    _same(y2, y1)
    _same(j2, j1)


def test_tests_the_workers_do_not_hold_are_simulated_by_the_caller():
    pts, rig, p = _campaign("compliance", {"compliance_stiffness_N_per_m": 2e6,
                                           "compliance_damping_Ns_per_m": 1e3})
    with spread_simulations(2, pts[:1]):
        assert spread_mod.spread(simulate_raw, "map", pts, rig, p) is None  # one test is not held
        assert spread_mod.spread(simulate_raw, "map", pts[:1], rig, p) is None  # fewer than MIN_TESTS
    with spread_simulations(1, pts):  # one job: nothing to spread on
        assert spread_mod._POOL[0] is None
    with pytest.raises(IndexError):  # the registry is cleared with the block
        spread_mod._TESTS[0]


def test_a_run_whose_lone_fits_spread_gives_the_answer_of_one_job(tmp_path, monkeypatch):
    """One member re-identified per round (``top`` 1: the fit runs alone in the calling
    process): with two jobs its simulations go to the workers, and the verdict and every
    number are those of the run with one job."""
    import json

    from ehsa_opt.datasets.synthetic import write_synthetic
    from ehsa_opt.estimation.discrepancy import rig as rig_mod
    from ehsa_opt.estimation.discrepancy import search as search_mod
    from ehsa_opt.estimation.discrepancy import run_discrepancy
    from ehsa_opt.estimation.discrepancy.results import DiscrepancySettings

    write_synthetic(tmp_path, SyntheticSpec(
        effects={"compliance": {"compliance_stiffness_N_per_m": 2e5,
                                "compliance_damping_Ns_per_m": 300.0}},
        frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(15.0, 109.0), cycles=1.0, seed=4))

    def answer(res):
        doc = json.loads(json.dumps(res.as_dict(), default=str))
        return (res.effect, res.error_before, res.error_after,
                [{k: c.get(k) for k in ("effect", "earns", "parameters", "error_after",
                                        "delta_bic_heldout")} for c in doc["candidates"]])

    spread_calls = []
    real = rig_mod.spread

    def counted(*a, **k):
        got = real(*a, **k)
        spread_calls.append(got is not None)
        return got

    monkeypatch.setattr(rig_mod, "spread", counted)
    # no member fitted ahead on an idle worker (that would run the lone fit in the pool
    # beside it; fits made ahead never change the answer either)
    monkeypatch.setattr(search_mod, "fitted_ahead", lambda rk, state: [])
    settings = dict(top=1, max_effects=1, discover=False)
    one = run_discrepancy(tmp_path, DiscrepancySettings(jobs=1, **settings))
    assert not any(spread_calls)
    two = run_discrepancy(tmp_path, DiscrepancySettings(jobs=2, **settings))
    assert sum(spread_calls) > 10  # the lone fit's simulations went to the workers
    assert one.effect == "compliance"
    assert answer(two) == answer(one)


def test_arrays_come_back_from_the_workers_in_their_memory_layout():
    """A sensitivity block laid out with the samples innermost (as the map's einsum gives
    it) is not C-contiguous; pickled as it is, it would come back in C order and be
    summed in another order downstream.  Packed, it comes back with its own strides."""
    import pickle

    a = np.ascontiguousarray(np.arange(2 * 7 * 3, dtype=float).reshape(2, 3, 7)
                             ).transpose(0, 2, 1)  # (2, 7, 3), samples innermost
    assert not a.flags.c_contiguous and not a.flags.f_contiguous
    assert pickle.loads(pickle.dumps(a)).strides != a.strides  # what packing avoids
    back = spread_mod._unpack(pickle.loads(pickle.dumps(spread_mod._pack(a))))
    np.testing.assert_array_equal(back, a)
    assert back.strides == a.strides
    y = np.arange(10.0).reshape(2, 5)
    got = spread_mod._unpack(pickle.loads(pickle.dumps(tuple(map(spread_mod._pack, (y, 3))))))
    assert got[1] == 3 and got[0].strides == y.strides
