"""Newey-West (HAC) covariance: agrees with the independent-samples one on white
residuals, widens with autocorrelation and covers the truth; EMPS's published
parameters fall inside our intervals."""

import numpy as np
import pytest
from scipy.signal import lfilter

from ehsa_opt.estimation.covariance import (
    _bartlett_sum,
    fixed_b_critical_value,
    hac_covariance,
)


def _design(n):
    t = np.arange(n) / 1000.0
    s = np.sin(2 * np.pi * 0.7 * t)
    return np.column_stack([3 * s, np.sign(s), np.ones(n)])


def test_white_residuals_give_the_independent_samples_covariance():
    rng = np.random.default_rng(0)
    X = _design(4000)
    r = rng.normal(size=4000)
    h = hac_covariance(X, r)
    assert h.bandwidth <= 5
    assert h.n_eff == pytest.approx(4000, rel=0.1)
    np.testing.assert_allclose(np.sqrt(np.diag(h.cov)), np.sqrt(np.diag(h.cov_iid)), rtol=0.1)


def test_ar1_residuals_cover_the_truth_where_iid_intervals_do_not():
    rng = np.random.default_rng(1)
    n, rho, beta = 3000, 0.95, np.array([2.0, 1.0, 0.5])
    X = _design(n)
    hit = hit_iid = 0
    reps = 40
    for _ in range(reps):
        e = lfilter([1.0], [1.0, -rho], rng.normal(size=n + 1000))[1000:]
        y = X @ beta + e
        b = np.linalg.lstsq(X, y, rcond=None)[0]
        h = hac_covariance(X, y - X @ b)
        hit += np.sum(np.abs(b - beta) <= 1.96 * np.sqrt(np.diag(h.cov)))
        hit_iid += np.sum(np.abs(b - beta) <= 1.96 * np.sqrt(np.diag(h.cov_iid)))
    cover, cover_iid = hit / (3 * reps), hit_iid / (3 * reps)
    assert cover >= 0.85, cover
    assert cover_iid < 0.6, cover_iid
    # N_eff near N (1 - rho)/(1 + rho) = 77
    assert 30 < h.n_eff < 200


def test_fft_lag_sum_matches_the_direct_sum_and_groups_are_checked():
    rng = np.random.default_rng(2)
    U = rng.normal(size=(600, 3)).cumsum(axis=0)
    L = 100
    S = U.T @ U
    for lag in range(1, L + 1):
        G = U[lag:].T @ U[:-lag]
        S += (1 - lag / (L + 1)) * (G + G.T)
    np.testing.assert_allclose(_bartlett_sum(U, L), S, rtol=1e-9)
    with pytest.raises(ValueError, match="sum to"):
        hac_covariance(U, U[:, 0], groups=[100, 100])
    assert fixed_b_critical_value(0.0) == 1.96
    assert fixed_b_critical_value(0.1) > 2.2


def test_nuisance_columns_are_profiled_out():
    rng = np.random.default_rng(3)
    X = _design(2000)
    r = rng.normal(size=2000)
    full = hac_covariance(X, r, bandwidth=0, fixed_b=False)
    prof = hac_covariance(X, r, bandwidth=0, fixed_b=False, n_nuisance=1)
    # profiling the last column = the first two rows/columns of the full sandwich
    np.testing.assert_allclose(prof.cov, full.cov[:2, :2], rtol=1e-6)


def test_emps_published_parameters_inside_our_intervals():
    from ehsa_opt.datasets.embedded import embedded_data_dir
    from ehsa_opt.datasets.emps import EMPS_REFERENCE
    from ehsa_opt.estimation.identify import identify
    f = identify(embedded_data_dir("emps"), starts=2).fits[0]
    ia = f.identifiability
    assert ia["effective_samples"] < ia["samples"] / 5  # strongly autocorrelated residual
    for ours, ref in (("total_coulomb_N", "coulomb_N"), ("total_viscous_Ns_per_m",
                                                          "viscous_Ns_per_m"),
                      ("inertia_kg", "inertia_kg"), ("offset_N", "offset_N")):
        lo, hi = ia["combinations"][ours]["ci95"]
        assert lo <= EMPS_REFERENCE[ref] <= hi, (ours, lo, hi)
