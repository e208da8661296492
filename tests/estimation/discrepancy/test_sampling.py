"""The cheaper pre-round work of the discrepancy workflow: collocation on every k-th
sample, candidate fits on a bounded number of samples, and the force-lag member tried
only when one delay fits every test."""

from types import SimpleNamespace

import numpy as np
import pytest

from ehsa_opt.estimation.discrepancy.candidates.force_lag import per_test_delays
from ehsa_opt.estimation.discrepancy.prepared import (
    PreparedTest,
    decimated,
    decimation_factor,
)
from ehsa_opt.estimation.discrepancy.split import spread_within
from ehsa_opt.datasets.bench_format import BenchTest


def _sine_pt(f_hz: float, n: int, rng, delay_s: float = 0.0, sigma: float = 1.0):
    t = np.arange(n) * 1e-3
    model = 100.0 * np.sin(2 * np.pi * f_hz * t) + 20.0 * np.sign(np.cos(2 * np.pi * f_hz * t))
    meas = np.interp(t - delay_s, t, model) + sigma * rng.standard_normal(n)
    pt = SimpleNamespace(time_s=t, y=meas[None, :], wnorm=np.full((1, n), 1.0 / sigma))
    return pt, model[None, :]


def test_one_channel_delay_is_one_delay_for_every_test():
    rng = np.random.default_rng(3)
    pts, preds = zip(*[_sine_pt(f, 1500, rng, delay_s=0.004) for f in (0.7, 1.5, 2.5, 4.0)])
    n = sum(p.time_s.size for p in pts)
    assert per_test_delays(pts, preds, n) > 0


def test_a_lead_that_depends_on_the_motion_is_not_a_channel_delay():
    rng = np.random.default_rng(4)
    # the lead of a transition over a fixed distance: distance over speed, per test
    pts, preds = zip(*[_sine_pt(f, 1500, rng, delay_s=d)
                       for f, d in ((0.7, 0.009), (1.5, 0.004), (2.5, 0.002), (4.0, -0.002))])
    n = sum(p.time_s.size for p in pts)
    assert per_test_delays(pts, preds, n) < 0


def _prepared(n: int) -> PreparedTest:
    t = np.arange(n) * 1e-3
    x = 0.01 * np.sin(2 * np.pi * t)
    test = BenchTest(file=f"t{n}.csv", time_s=t, displacement_m=x, force_N=np.cos(t),
                     voltage_V=np.sin(t), load_ohm=10.0, frequency_hz=1.0, amplitude_m=0.01,
                     excitation="sine")
    u = np.vstack([x, np.gradient(x, t), np.zeros(n)])
    return PreparedTest(test, None, t, u, np.vstack([test.force_N, test.voltage_V]),
                        np.array([1.0, 0.1]), {"load_ohm": 10.0}, np.ones(n))


def test_decimation_keeps_every_kth_measured_sample():
    pts = [_prepared(1000), _prepared(3001)]
    assert decimation_factor(pts, None) == 1
    assert decimation_factor(pts, 5000) == 1
    k = decimation_factor(pts, 1500)
    assert k == 3 and sum((pt.time_s.size + k - 1) // k for pt in pts) <= 1500 + len(pts)
    d = decimated(pts[1], k)
    np.testing.assert_array_equal(d.time_s, pts[1].time_s[::3])
    np.testing.assert_array_equal(d.y, pts[1].y[:, ::3])
    np.testing.assert_array_equal(d.test.force_N, pts[1].test.force_N[::3])
    assert d.u.shape == (3, d.time_s.size) and d.weight.size == d.time_s.size
    np.testing.assert_array_equal(d.sigma, pts[1].sigma)
    assert decimated(pts[0], 1) is pts[0]


@pytest.mark.parametrize("cap, n_expected", [(None, 4), (100_000, 4), (3000, 2), (10, 1)])
def test_candidate_tests_spread_within_a_sample_budget(cap, n_expected):
    pts = [_prepared(n) for n in (1500, 800, 1400, 1500, 700, 1200)]
    sub = spread_within(pts, 4, cap)
    assert len(sub) == n_expected
    assert cap is None or len(sub) == 1 or sum(p.time_s.size for p in sub) <= cap
