"""The rod-friction regression and its sandwich covariance (estimation/rod_law.py): the
Newey-West interval keeps its coverage on autocorrelated residuals where the i.i.d. one
does not; the ordered sets of estimation/bounds.py."""

from __future__ import annotations

import numpy as np
import pytest

from ehsa_opt.estimation.bounds import ordered_set
from ehsa_opt.estimation.rod_law import (
    FrictionSamples,
    RodLawFit,
    andrews_bandwidth,
    hac_covariance,
    rod_law_fit,
)
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.params import FRICTION_NAMES, FrictionParams

TRUTH = FrictionParams(60.0, 40.0, 0.01, 150.0, 0.02, 0.015, 1.0, 3e-5)
LEAD = 5e-3 / (2 * np.pi)


def _ar1(rng: np.random.Generator, n: int, rho: float, sd: float) -> np.ndarray:
    e = np.empty(n)
    e[0] = rng.normal(0, sd)
    w = rng.normal(0, sd * np.sqrt(1 - rho ** 2), n)
    for k in range(1, n):
        e[k] = rho * e[k - 1] + w[k]
    return e


def test_newey_west_covers_where_iid_does_not() -> None:
    """Slope of y = a + b sin(t) + AR(1) noise (rho 0.95), 4 blocks of 500 samples: the
    95 % interval of b from the HAC covariance covers the truth in >= 88 % of 300
    repetitions, the i.i.d. one in < 60 %."""
    rng = np.random.default_rng(3)
    t = np.linspace(0, 6 * np.pi, 500)
    X = np.column_stack([np.ones_like(t), np.sin(t)])
    hits_hac = hits_iid = 0
    reps = 300
    for _ in range(reps):
        Js, es = [], []
        XtX, Xty = np.zeros((2, 2)), np.zeros(2)
        ys = []
        for _b in range(4):
            y = 1.0 + 2.0 * np.sin(t) + _ar1(rng, t.size, 0.95, 1.0)
            ys.append(y)
            XtX += X.T @ X
            Xty += X.T @ y
        beta = np.linalg.solve(XtX, Xty)
        for y in ys:
            Js.append(X)
            es.append(y - X @ beta)
        cov, cov_iid, L, neff = hac_covariance(Js, es)
        hits_hac += abs(beta[1] - 2.0) <= 1.96 * np.sqrt(cov[1, 1])
        hits_iid += abs(beta[1] - 2.0) <= 1.96 * np.sqrt(cov_iid[1, 1])
        assert sum(neff) < 0.3 * 4 * t.size   # effective sample size well below n
    assert hits_hac / reps >= 0.88
    assert hits_iid / reps < 0.6


def test_andrews_bandwidth_grows_with_autocorrelation() -> None:
    rng = np.random.default_rng(0)
    white = rng.normal(size=2000)
    assert andrews_bandwidth(white) <= 3
    assert andrews_bandwidth(_ar1(rng, 2000, 0.95, 1.0)) > 20


def test_rod_law_refit_recovers_the_rod_friction_and_bands_widen_beyond_the_data() -> None:
    rng = np.random.default_rng(5)
    vs, ys = [], []
    for f in (0.5, 1.5, 3.0):
        tt = np.arange(0, 2 / f, 1e-3)
        v = 2 * np.pi * f * 0.015 * np.cos(2 * np.pi * f * tt)
        vs.append(v)
        ys.append(np.asarray(rod_friction_N(v, TRUTH, LEAD)) + _ar1(rng, v.size, 0.9, 3.0))
    smp = FrictionSamples(["a", "b", "c"], vs, ys)
    start = FrictionParams(40.0, 30.0, 0.02, 100.0, 0.01, 0.01, 2.0, 1e-5).as_dict()
    fit = rod_law_fit(smp, start, LEAD, refit=True)
    v = np.array([0.05, 0.2, 0.28])
    assert np.allclose(fit.rod_N(v), rod_friction_N(v, TRUTH, LEAD), rtol=0.03)
    hw = fit.half_width_N(np.array([0.2, 0.6, 1.5]))
    assert hw[0] < hw[1] < hw[2]
    assert np.all(fit.std_N(v, "hac") > fit.std_N(v, "iid"))
    assert fit.covariance_cluster is None  # three tests: too few clusters
    # saved as text and reloaded: the same law and band; files that say "varied" still load
    back = RodLawFit.from_json(fit.to_json())
    assert back.free == fit.free and np.allclose(back.half_width_N(v), fit.half_width_N(v))
    older = fit.to_dict()
    older["varied"] = older.pop("free")
    assert RodLawFit.from_dict(older).free == fit.free
    assert "nut_coulomb_N = " in fit.summary()


@pytest.mark.parametrize("side", ["below", "above"])
def test_ordered_set_keeps_its_margin_and_its_order(side: str) -> None:
    v = np.concatenate([np.geomspace(0.005, 0.02, 8), np.linspace(0.02, 3.0, 60)])
    best = np.asarray(rod_friction_N(v, TRUTH, LEAD))
    margin = 0.05 * best + 2.0 + 5.0 * np.maximum(v - 0.3, 0.0)
    fr = ordered_set(TRUTH, v, margin, LEAD, side)
    got = np.asarray(rod_friction_N(v, fr, LEAD))
    if side == "below":
        assert np.all(got <= best - margin + 1e-6)
    else:
        assert np.all(got >= best + margin - 1e-6)
    vv = np.linspace(0.0, 5.0, 2001)   # off the grid, beyond it too
    b2 = np.asarray(rod_friction_N(vv, TRUTH, LEAD))
    g2 = np.asarray(rod_friction_N(vv, fr, LEAD))
    assert np.all(g2 <= b2 + 1e-9) if side == "below" else np.all(g2 >= b2 - 1e-9)
    with pytest.raises(ValueError, match="side"):
        ordered_set(TRUTH, v, margin, LEAD, "sideways")


@pytest.mark.parametrize("gen", [False, True])
def test_min_set_takes_away_all_of_a_coulomb_level_above_the_largest_margin(gen) -> None:
    # A best set whose Coulomb level (40 N) exceeds the largest margin (30 N), on a grid
    # that starts far below its Coulomb velocity: at 1e-4 m/s the best set has 8-22 N, the
    # margin is clipped to that, and only taking away the whole level meets it (a cap at
    # the largest margin made this linear programme infeasible).
    best = FrictionParams(40.0, 40.0, 0.005, 100.0, *((0.012, 0.0, 0.1, 1e-5) if gen
                                                      else (0.0, 0.0, 1.0, 0.0)))
    v = np.concatenate([np.geomspace(1e-4, 0.01, 12), np.linspace(0.02, 1.0, 30)])
    margin = np.full(v.size, 30.0)
    rod = np.asarray(rod_friction_N(v, best, LEAD))
    assert rod[0] < margin[0] and best.nut_coulomb_N > margin.max()  # the condition
    fr = ordered_set(best, v, margin, LEAD, "below", gen)
    got = np.asarray(rod_friction_N(v, fr, LEAD))
    assert np.all(got <= rod - np.minimum(margin, rod) + 1e-6)
    assert np.all(got >= -1e-9)
    assert fr.nut_coulomb_N < best.nut_coulomb_N - 30.0  # more than the largest margin went


def test_cluster_covariance_corrects_for_a_test_that_owns_a_direction() -> None:
    """Two parameters: a level seen by every test and a slope seen by one test only.  The
    plain cluster-robust variance of the slope uses that test's residuals, which the fit
    has absorbed; the leverage-corrected (CR2) one scales them back up, so it is larger,
    and on i.i.d. blocks without a lone test both agree with the classical variance."""
    from ehsa_opt.estimation.rod_law import cluster_covariance
    rng = np.random.default_rng(5)
    J = [np.column_stack([np.ones(50), np.zeros(50)]) for _ in range(6)]
    J.append(np.column_stack([np.ones(50), np.linspace(-1, 1, 50)]))
    J.append(np.column_stack([np.ones(50), np.linspace(-1, 1, 50) ** 2]))  # shares the slope
    e = [rng.normal(0, 1, 50) for _ in J]
    plain = cluster_covariance(J, e, leverage=False)
    cr2 = cluster_covariance(J, e)
    assert cr2[1, 1] > plain[1, 1]
    Jb = [np.column_stack([np.ones(200), rng.normal(size=200)]) for _ in range(40)]
    eb = [rng.normal(0, 1, 200) for _ in Jb]
    classic = np.linalg.inv(sum(j.T @ j for j in Jb))
    for lev in (False, True):
        c = cluster_covariance(Jb, eb, leverage=lev)
        assert np.allclose(np.diag(c), np.diag(classic), rtol=0.35)


def test_weighted_law_shows_a_bias_the_hard_driven_tests_share() -> None:
    """Five tests fit alike: the weighted law differs from the law by noise, inside the
    statistical band, which stays as it was.  The two fastest carry an error repeated in
    every cycle that grows with the stroke (a hidden play): they fit worse, the weighted
    law trusts the others and lies near the truth, and the band at 1 m/s reaches it, where
    the spread-based band misses the truth by far."""
    def campaign(bias: bool):
        rng = np.random.default_rng(8)
        vs, ys = [], []
        for f in (0.5, 1.0, 2.0, 3.0, 3.5):
            tt = np.arange(0, 2 / f, 1e-3)
            v = 2 * np.pi * f * 0.015 * np.cos(2 * np.pi * f * tt)
            y = np.asarray(rod_friction_N(v, TRUTH, LEAD)) + _ar1(rng, v.size, 0.8, 2.0)
            if bias and f >= 3.0:
                y = y + 60.0 * v / 0.33 + 40.0 * np.sin(4 * np.pi * f * tt)
            vs.append(v)
            ys.append(y)
        return rod_law_fit(FrictionSamples(list("abcde"), vs, ys), TRUTH.as_dict(), LEAD,
                           refit=True)
    import dataclasses
    truth_1 = float(rod_friction_N(1.0, TRUTH, LEAD))
    clean = campaign(False)
    assert clean.weighted is not None
    spread = dataclasses.replace(clean, weighted=None).half_width_N(1.0)[0]
    assert clean.model_error_N(1.0)[0] < 0.5 * spread
    assert clean.half_width_N(1.0)[0] == pytest.approx(spread)  # noise: the band unchanged
    biased = campaign(True)
    spread = dataclasses.replace(biased, weighted=None).half_width_N(1.0)[0]
    assert abs(float(biased.rod_N(1.0)) - truth_1) > spread       # the spread misses it
    assert biased.model_error_N(1.0)[0] > spread
    # the weighted law, which trusts the tests that fit, is much nearer the truth; the
    # band reaches most of the way to it
    w = float(rod_friction_N(1.0, [biased.weighted[n] for n in FRICTION_NAMES], LEAD))
    bias = abs(float(biased.rod_N(1.0)) - truth_1)
    assert abs(w - truth_1) < 0.3 * bias
    assert biased.half_width_N(1.0)[0] > 0.7 * bias
