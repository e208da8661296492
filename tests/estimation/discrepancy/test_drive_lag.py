"""The drive-lag member of a rig without generator: the operator and its inverse agree,
a known time constant is recovered from synthetic data, rigid data give none, and a
generator bench never gets one."""

from dataclasses import replace

import numpy as np
import pytest

from ehsa_opt.datasets.bench_format import load_bench
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.estimation.discrepancy.candidates.drive_lag import (
    applied_force,
    fit_drive_lag,
    recorded_from_applied,
    try_drive_lag,
)
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.rig import Rig, predict
from ehsa_opt.physics.params import HarvesterParams
from tests.estimation.discrepancy.emps_piece import emps_piece as piece_of_emps


def test_the_inverse_operator_undoes_the_drive():
    t = np.arange(4000) * 1e-3
    F = 50 * np.sin(2 * np.pi * 3 * t) + 20 * np.sin(2 * np.pi * 40 * t)
    Fa = applied_force(t, F, 8e-4, 0.0)
    back = recorded_from_applied(t, Fa, 8e-4, 0.0)
    k = slice(50, -50)
    assert np.max(np.abs(back[k] - F[k])) < 0.02 * np.max(np.abs(F))
    # a first-order lag: at 40 Hz the applied force's amplitude is 1/√(1 + (ωτ)²)
    w = 2 * np.pi * 40 * 8e-4
    assert np.std(applied_force(t, 20 * np.sin(2 * np.pi * 40 * t), 8e-4, 0.0)[500:]) \
        == pytest.approx(20 / np.sqrt(2) / np.sqrt(1 + w * w), rel=0.01)


@pytest.fixture(scope="module", name="emps_piece")
def emps_piece_for_lag():
    return piece_of_emps(3000, 11000)


@pytest.mark.slow  # ~15 s alone (the rigid fit of an 8 s EMPS piece, two variable projections)
def test_a_known_drive_lag_is_recovered(emps_piece):
    pt, rig, base = emps_piece
    applied = predict([pt], rig, base)[0]
    rng = np.random.default_rng(3)
    tau = 8e-4
    y = recorded_from_applied(pt.time_s, applied, tau, 0.0) + rng.normal(0.0, 1.0, applied.shape)
    lagged = replace(pt, y=y, sigma=np.array([1.0]))
    out = fit_drive_lag([lagged], predict([lagged], rig, base), rig, base, delay_s=0.0)
    p, iv = out["parameters"], out["intervals"]["drive_lag_time_constant_s"]
    assert p["drive_lag_time_constant_s"] == pytest.approx(tau, rel=0.05)
    assert iv[0] > 0  # resolved (the intervals' coverage is the coverage benchmark's job)
    assert p["drive_bandwidth_hz"] == pytest.approx(1 / (2 * np.pi * tau), rel=0.1)
    # the rigid data: no lag of any size (the interval reaches zero, or τ is tiny)
    rigid = replace(pt, y=applied + rng.normal(0.0, 1.0, applied.shape), sigma=np.array([1.0]))
    o2 = fit_drive_lag([rigid], predict([rigid], rig, base), rig, base, delay_s=0.0)
    t2, iv2 = o2["parameters"]["drive_lag_time_constant_s"], \
        o2["intervals"]["drive_lag_time_constant_s"]
    assert t2 < 5e-5 or iv2[0] <= 0


def test_a_generator_bench_gets_no_drive_lag():
    rig = Rig(HarvesterParams(), True, ())
    assert try_drive_lag([], [], rig, None, [], [], 0.0, 1.0, 1.0, 0.0, None, print) is None
    with pytest.raises(ValueError, match="without generator"):
        fit_drive_lag([], [], rig, {})


def test_parallel_filtering_only_on_a_rig_without_generator():
    """The force passes through the motion's own low-pass on a rig without generator
    (the inverse-model practice); a generator bench's force is untouched."""
    from ehsa_opt.estimation.discrepancy.prepared import parallel_filter
    t0 = load_bench(embedded_data_dir("emps")).tests[0]
    test = replace(t0, time_s=t0.time_s[:3000], displacement_m=t0.displacement_m[:3000],
                   force_N=t0.force_N[:3000])
    pt = prepare_tests([test], False)[0]
    assert np.allclose(pt.y[0], parallel_filter(test.time_s, test.force_N, pt.motion.cutoff_hz))
    assert not np.allclose(pt.y[0], test.force_N)
    # σ is the raw force's noise level, not the filtered one's
    from ehsa_opt.estimation.discrepancy.prepared import noise_std
    assert pt.sigma[0] == pytest.approx(noise_std(test.force_N))
    pg = prepare_tests([replace(test, load_ohm=10.0)], True, derivative_cutoff_hz=100.0)[0]
    assert np.array_equal(pg.y[0], test.force_N)
