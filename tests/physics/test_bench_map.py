"""The Radau IIA discrete map against the CVODES reference simulation."""

import numpy as np
import pytest

from ehsa_opt import BenchModel, HarvesterParams, SineMotion, simulate_bench
from ehsa_opt.datasets.synthetic import PROTOTYPE_FRICTION
from ehsa_opt.physics import Compliance
from ehsa_opt.physics.bench_map import simulate_map, substeps_for
from ehsa_opt.physics.components import make_component
from ehsa_opt.physics.motion import SampledMotion

#: noise levels the differences are measured in (force N, voltage V): the bench's
SIGMA = np.array([1.5, 0.02])


def _triangle(n: int = 700, dt: float = 1e-3) -> SampledMotion:
    """A constant-velocity stroke with blended reversals (a recorded motion)."""
    t = np.arange(n) * dt
    v = 0.12 * np.tanh(np.sin(2 * np.pi * 2.0 * t) / 0.15)
    x = np.cumsum(v) * dt
    return SampledMotion(t, x - x.mean(), smoothing=1e-12)


def _rms_sigma(a, b) -> float:
    return float(np.max(np.sqrt(np.mean(((a - b) / SIGMA[:, None]) ** 2, axis=1))))


@pytest.mark.parametrize("components, values, tol", [
    ((), {}, 0.02),
    ((Compliance(),), {"compliance_stiffness_N_per_m": 5e5, "compliance_damping_Ns_per_m": 400},
     0.02),
    # a 700 Hz mount mode: CVODES at the fits' rtol 1e-7 is itself 0.5 noise sd off
    ((Compliance(),), {"compliance_stiffness_N_per_m": 1e9, "compliance_damping_Ns_per_m": 300},
     0.1),
    ((make_component("cogging", periods_per_rev=8),),
     {"cogging_sin_Nm": 0.01, "cogging_cos_Nm": -0.005}, 0.02),
])
@pytest.mark.parametrize("motion", ["sine", "recorded"])
def test_map_matches_cvodes_within_a_fraction_of_the_noise(components, values, tol, motion):
    """Noise-normalised rms difference to CVODES at rtol 1e-10: below ``tol`` and below
    that of CVODES at rtol 1e-7 (the fits' own tolerance) whenever that is above 0.01."""
    model = BenchModel(HarvesterParams(), components)
    p = model.param_vector(10.0, PROTOTYPE_FRICTION, values)
    if motion == "sine":
        mo, t = SineMotion(0.008, 2.5), np.arange(500) * 1e-3
    else:
        mo = _triangle()
        t = mo.time_s
    ref = simulate_bench(model, mo, p, t, rtol=1e-10, atol=1e-12)
    y, X = simulate_map(model, mo, p, t)
    yr = np.vstack([ref.force_N, ref.voltage_V])
    assert _rms_sigma(y, yr) < tol
    cv = simulate_bench(model, mo, p, t, rtol=1e-7, atol=1e-9)
    e_cv = _rms_sigma(np.vstack([cv.force_N, cv.voltage_V]), yr)
    assert e_cv < 0.01 or _rms_sigma(y, yr) < e_cv
    assert np.allclose(X[:, 0], ref.states[:, 0])


def test_substeps_resolve_a_stiff_mount_and_not_the_rigid_rig():
    """The rule chooses one sub-step where only the stiff current is (L-stable), several
    for a 1e9 N/m mount on the rotor inertia; one sub-step there would miss the ringing."""
    mo = _triangle()
    t, u = mo.time_s, mo.evaluate(mo.time_s)
    rigid = BenchModel(HarvesterParams())
    assert substeps_for(rigid, u, rigid.param_vector(10.0, PROTOTYPE_FRICTION), 1e-3) == 1
    model = BenchModel(HarvesterParams(), (Compliance(),))
    p = model.param_vector(10.0, PROTOTYPE_FRICTION, {"compliance_stiffness_N_per_m": 1e9,
                                                      "compliance_damping_Ns_per_m": 300})
    m = substeps_for(model, u, p, 1e-3)
    assert m > 4
    ref = simulate_bench(model, mo, p, t, rtol=1e-10, atol=1e-12)
    yr = np.vstack([ref.force_N, ref.voltage_V])
    coarse, _ = simulate_map(model, mo, p, t, substeps=1)
    fine, _ = simulate_map(model, mo, p, t, substeps=m)
    assert _rms_sigma(fine, yr) < 0.1 < _rms_sigma(coarse, yr)


def test_grid_must_be_uniform():
    model = BenchModel(HarvesterParams())
    with pytest.raises(ValueError, match="uniform"):
        simulate_map(model, SineMotion(0.01, 1.0), model.param_vector(10.0),
                     np.array([0.0, 1e-3, 3e-3, 4e-3]))


def test_a_jittered_grid_is_left_to_cvodes():
    """Time stamps rounded to 1e-8 s (EMPS: ±3e-5 of the step) are not a uniform grid
    for the map; an exact grid is."""
    from ehsa_opt.estimation.discrepancy.rig import uniform_grid
    t = np.arange(1000) * 1e-3
    assert uniform_grid(t)
    jittered = t + np.where(np.arange(1000) % 7 == 0, 3e-8, 0.0)
    assert not uniform_grid(jittered)
    assert not uniform_grid(t[:1])


def _every_substep(model, mo, p, t, m):
    """The reference the folded record map must equal: one accumulation over every
    sub-step of the record, the state kept at each sample (the map before folding)."""
    from ehsa_opt.physics.bench_map import _samples, _substep_function, stage_inputs
    h = float(np.median(np.diff(t)))
    motion, uu = _samples(mo, t)
    x0 = model.initial_state(uu[:, 0], p)
    acc = _substep_function(model).mapaccum((t.size - 1) * m)
    Xs = np.array(acc(x0, stage_inputs(motion, t, m), p, h / m))
    return np.hstack([x0[:, None], Xs[:, m - 1::m]])


def test_folded_record_map_equals_every_substep_bit_for_bit():
    """The record map (sub-steps folded per sample interval, cached on the model) gives
    the same states as accumulating every sub-step, bit for bit; the sensitivity run's
    outputs equal the plain run's; a second record length or sub-step count on the
    same model does not reuse the first one's map."""
    from ehsa_opt.physics.bench_map import simulate_map_sensitivity
    model = BenchModel(HarvesterParams(), (Compliance(),))
    p = model.param_vector(10.0, PROTOTYPE_FRICTION, {"compliance_stiffness_N_per_m": 1e9,
                                                      "compliance_damping_Ns_per_m": 300})
    mo = _triangle()
    for n, m in ((700, 3), (400, 3), (400, 1), (700, 3)):
        t = mo.time_s[:n]
        y, X = simulate_map(model, mo, p, t, substeps=m)
        assert X.shape == (3, n)
        assert np.array_equal(X, _every_substep(model, mo, p, t, m))
        ys, dy = simulate_map_sensitivity(model, mo, p, t, substeps=m)
        assert np.array_equal(ys, y) and dy.shape == (2, n, len(model.param_names))
    # a different parameter vector on the cached map: its own trajectory
    q = p.copy()
    q[model.param_names.index("compliance_damping_Ns_per_m")] = 3000.0
    t = mo.time_s
    assert np.array_equal(simulate_map(model, mo, q, t, substeps=3)[1],
                          _every_substep(model, mo, q, t, 3))
    assert not np.allclose(simulate_map(model, mo, q, t, substeps=3)[0],
                           simulate_map(model, mo, p, t, substeps=3)[0])
    # another rig (no compliance) never sees this model's cached maps
    rigid = BenchModel(HarvesterParams())
    pr = rigid.param_vector(10.0, PROTOTYPE_FRICTION)
    assert np.array_equal(simulate_map(rigid, mo, pr, t, substeps=1)[1],
                          _every_substep(rigid, mo, pr, t, 1))
