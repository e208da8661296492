"""The contact stiffness's bracket: its coverage when the tests disagree."""

import math

import numpy as np
import pytest

from ehsa_opt.estimation.discrepancy.impact_features import Mismatch, score
from ehsa_opt.estimation.discrepancy.impact_stiffness import (
    per_test_objectives,
    stiffness_bracket,
    stiffness_interval,
)

K = "backlash_contact_stiffness_N_per_m"


def _profile(k_true, offsets_dec, width_dec, rough, seed=3):
    """History rows and per-test objectives of seven tests whose own best stiffnesses sit
    ``offsets_dec`` decades from ``k_true`` (a model whose error moves each test's
    optimum), each quadratic in log k of ``width_dec`` and rough by ``rough``
    (multiplicative, seeded); a grid of quarter decades plus a search crowding the
    region above the truth."""
    rng = np.random.default_rng(seed)
    ks = [10 ** (6 + 0.25 * i) for i in range(17)]
    ks += [k_true * 10 ** o for o in np.linspace(0.3, 0.9, 12)]
    rows, split = [], []
    for k in ks:
        u = np.array([0.3 + (math.log10(k / (k_true * 10 ** o)) / width_dec) ** 2
                      for o in offsets_dec])
        u = u * (1.0 + rough * rng.standard_normal(u.size))
        rows.append({K: k, "objective": float(u.mean()), "contact_exponent": 1.5})
        split.append(u)
    return rows, split


def test_disagreeing_tests_widen_a_bracket_that_missed_the_truth():
    """Two tests favour the truth, five a stiffness 4-8 x higher, objective rough by
    15 %: the profile alone (the best point's mean square as the scale) states a
    3.5 x bracket identified and excluding the truth; with the tests' spread as the
    scale the bracket covers the truth and is not called identified."""
    k_true = 6.3e7
    rows, split = _profile(k_true, [0.0, 0.1, 0.6, 0.7, 0.7, 0.8, 0.9], 0.3, 0.15)
    old = stiffness_interval(rows, 1.5, 7, K, (1e4, 1e10))
    assert old["identified"] and not old["lower_N_per_m"] <= k_true <= old["upper_N_per_m"]
    new = stiffness_interval(rows, 1.5, 7, K, (1e4, 1e10), split)
    assert new["lower_N_per_m"] <= k_true <= new["upper_N_per_m"]
    assert not new["identified"] and new["by_test_spread"] > 0
    assert new["consistent_points"] > old["consistent_points"]


def test_agreeing_tests_keep_a_sharp_bracket_identified():
    """Seven tests with the same optimum (5 % roughness): the tests' spread adds no
    point, the bracket stays within 4 x around the truth and identified."""
    k_true = 6.3e7
    rows, split = _profile(k_true, [0.0] * 7, 0.5, 0.05)
    new = stiffness_interval(rows, 1.5, 7, K, (1e4, 1e10), split)
    assert new["identified"] and new["by_test_spread"] == 0
    assert new["lower_N_per_m"] <= k_true <= new["upper_N_per_m"]
    assert new["upper_N_per_m"] / new["lower_N_per_m"] < 4.0
    with pytest.raises(ValueError, match="per_test"):
        stiffness_interval(rows, 1.5, 7, K, (1e4, 1e10), split[:-1])


def test_per_test_objectives_average_to_the_objective_and_feed_the_bracket():
    """Per-test objectives of mismatches average to :func:`score` (a test left out by
    the widening is NaN and not counted); :func:`stiffness_bracket` counts the tests
    used at the best point and returns a bracket containing it."""
    m = Mismatch([np.full(4, 0.3), np.full(4, 2.4), np.full(4, 0.1)],
                 [(2e-5, 1e-5), None, (1e-5, 2e-5)])
    widen = [(np.zeros(4), 0.0), (np.full(4, math.inf), 0.0), (np.zeros(4), 0.0)]
    per = per_test_objectives(m, widen)
    assert math.isnan(per[1])
    assert np.nanmean(per) == pytest.approx(score(m, widen))
    assert np.mean(per_test_objectives(m)) == pytest.approx(score(m))
    ms, hist = [], []
    for lk in np.arange(6.0, 10.01, 0.25):
        e = abs(lk - 8.0) + 0.1
        mm = Mismatch([np.full(4, e), np.full(4, e + 0.1), np.full(4, e)],
                      [(0.0, 1e-5), None, (0.0, 1e-5)])
        ms.append(mm)
        hist.append({K: 10 ** lk, "objective": score(mm, widen), "contact_exponent": 1.0})
    box = (np.array([0.0, 6.0, 0.0]), np.array([1e-3, 10.0, 5.0]))
    kint = stiffness_bracket(hist, ms, widen, 1.0, K, box)
    assert kint["lower_N_per_m"] < 1e8 < kint["upper_N_per_m"] and kint["identified"]
    with pytest.raises(ValueError, match="mismatches"):
        stiffness_bracket(hist, ms[:-1], widen, 1.0, K, box)
