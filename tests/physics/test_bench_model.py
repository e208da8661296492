import math

import numpy as np
import pytest

from ehsa_opt import (BenchModel, FrictionParams, HarvesterParams, SineMotion, simulate_bench)
from ehsa_opt.physics.friction import nut_friction_N
from ehsa_opt.physics import Backlash, Compliance
from ehsa_opt.datasets.synthetic import PROTOTYPE_FRICTION

H = HarvesterParams()


def test_equivalent_quantities_by_hand():
    r = 5e-3 / (2 * math.pi)
    assert math.isclose(H.equivalent_mass_kg(), 301e-7 / r ** 2, rel_tol=1e-12)
    assert math.isclose(H.equivalent_mass_kg(), 47.532, rel_tol=1e-4)
    # c_eq(ω=0, R_e=15) = K_t K_e / (r² (R_e + R_i))
    assert math.isclose(H.equivalent_damping_Ns_per_m(0.0, 15.0), 0.137 ** 2 / (r ** 2 * 21.6),
                        rel_tol=1e-12)
    assert math.isclose(H.equivalent_damping_Ns_per_m(0.0, 15.0), 1372.17, rel_tol=1e-5)
    w, R = 2 * math.pi * 100, 6.6 + 47
    L = 1.7e-3
    assert math.isclose(H.equivalent_stiffness_N_per_m(w, 47.0),
                        0.137 ** 2 * L * w ** 2 / (r ** 2 * (R ** 2 + L ** 2 * w ** 2)))
    assert H.equivalent_damping_Ns_per_m(1.0, math.inf) == 0.0


def test_frictionless_inductance_free_matches_equivalent_system():
    h = H.replace(inductance_H=0.0)
    model = BenchModel(h)
    assert model.state_names == []
    motion = SineMotion(0.015, 2.0)
    t = np.linspace(0, 1.0, 501)
    sim = simulate_bench(model, motion, model.param_vector(47.0), t)
    x, v, a = motion.evaluate(t)
    c = h.equivalent_damping_Ns_per_m(0.0, 47.0)
    f_expected = c * v + h.equivalent_mass_kg() * a
    np.testing.assert_allclose(sim.force_N, f_expected, rtol=1e-6, atol=1e-6 * np.abs(
        f_expected).max())
    theta_dot = v / h.lead_m_per_rad
    v_expected = 47.0 / (47.0 + 6.6) * 0.137 * theta_dot
    np.testing.assert_allclose(sim.voltage_V, v_expected, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("load", [15.0, 109.0])
def test_first_harmonic_damping_and_stiffness_with_inductance(load):
    # use a frequency where the inductance matters, so k_eq is measurable
    h = H.replace(inductance_H=0.05)
    model = BenchModel(h)
    f = 60.0
    motion = SineMotion(1e-4, f)
    w = 2 * math.pi * f
    n_per = 400
    t = np.arange(0, 20 * n_per + 1) / (n_per * f)
    sim = simulate_bench(model, motion, model.param_vector(load), t)
    keep = t >= 10 / f  # steady state
    x, v, a = motion.evaluate(t[keep])
    resid = sim.force_N[keep] - h.equivalent_mass_kg() * a
    # first harmonic: resid = c v + k x
    coef, *_ = np.linalg.lstsq(np.column_stack([v, x]), resid, rcond=None)
    c_ref = h.equivalent_damping_Ns_per_m(w, load)
    k_ref = h.equivalent_stiffness_N_per_m(w, load)
    assert abs(coef[0] / c_ref - 1) < 0.01
    assert abs(coef[1] / k_ref - 1) < 0.01
    assert k_ref > 0.05 * c_ref * w  # the stiffness is not negligible in this check


@pytest.mark.parametrize("components", [(), (Backlash(),), (Compliance(),)],
                         ids=["rigid", "backlash", "compliance"])
def test_energy_balance_closes(components):
    model = BenchModel(H, components)
    p = model.param_vector(15.0, PROTOTYPE_FRICTION)
    t = np.arange(0, 2.0 / 1.5, 1e-3)
    sim = simulate_bench(model, SineMotion(0.015, 1.5), p, t)
    e = sim.energy_J
    assert e["friction"][-1] > 0.1 * e["work_in_abs"][-1]  # friction really matters here
    assert abs(sim.energy_residual()) < 0.005


def test_backlash_makes_force_peaks_where_contact_force_reverses():
    rigid = BenchModel(H)
    bl = BenchModel(H, [Backlash()])
    t = np.arange(-1 / 1.5, 1 / 1.5, 5e-4)  # one warm-up cycle before t = 0
    m = SineMotion(0.015, 1.5)
    s0 = simulate_bench(rigid, m, rigid.param_vector(47.0, PROTOTYPE_FRICTION), t)
    s1 = simulate_bench(bl, m, bl.param_vector(47.0, PROTOTYPE_FRICTION), t)
    diff = np.abs(s1.force_N - s0.force_N) * (t >= 0)
    # the largest disagreement sits just after the transmitted force changes sign (the
    # contact crosses the gap), i.e. near a zero crossing of the rigid model's force
    t_peak = t[np.argmax(diff)]
    f_trans = s0.force_N - nut_friction_N(s0.velocity_m_per_s, PROTOTYPE_FRICTION)
    crossings = t[1:][(np.sign(f_trans[1:]) != np.sign(f_trans[:-1])) & (t[1:] > 0)]
    lag = t_peak - crossings
    assert np.any((lag > 0) & (lag < 0.05))  # within 50 ms after the crossing
    assert diff.max() > 50.0
    assert np.median(diff[t >= 0]) < 5.0  # elsewhere the two models agree


def test_bad_parameter_vector_length():
    model = BenchModel(H)
    with pytest.raises(ValueError, match="p has 3 entries"):
        simulate_bench(model, SineMotion(0.01, 1.0), [1, 2, 3], np.linspace(0, 1, 10))


def test_two_transmissions_refused():
    with pytest.raises(ValueError, match="at most one transmission"):
        BenchModel(H, [Backlash(), Compliance()])


def test_friction_params_in_vector_order():
    model = BenchModel(H, [Backlash()])
    p = model.param_vector(47.0, FrictionParams(nut_breakaway_N=5.0, nut_coulomb_N=3.0), {"backlash_gap_m": 2e-4})
    assert p[0] == 47.0 and p[2] == 3.0
    assert p[model.param_names.index("backlash_gap_m")] == 2e-4
    with pytest.raises(ValueError, match="did you mean 'backlash_gap_m'"):
        model.param_vector(47.0, None, {"backlash_gap": 1e-4})


def test_integrator_cache_is_per_model():
    """A new model never reuses another model's compiled integrator (even if the old
    model was garbage-collected and its id reused)."""
    t = np.arange(0, 0.5, 1e-3)
    m = SineMotion(0.015, 2.0)
    forces = []
    for comps in [(), (Compliance(),), (), (Compliance(),)]:
        model = BenchModel(H, comps)
        sim = simulate_bench(model, m, model.param_vector(47.0, PROTOTYPE_FRICTION), t)
        assert sim.states.shape[0] == model.n_states
        forces.append(sim.force_N)
        del model
    np.testing.assert_allclose(forces[0], forces[2])
    np.testing.assert_allclose(forces[1], forces[3])
@pytest.mark.parametrize("name,values", [
    ("asymmetric_friction", {"asym_coulomb_N": 15.0, "asym_viscous_Ns_per_m": 80.0}),
    ("cogging", {"cogging_sin_Nm": 0.02, "cogging_cos_Nm": -0.01}),
    ("voltage_drop", {"voltage_drop_V": 1.0}),
    ("winding_heating", {"winding_heating_K_per_J": 10.0}),
    ("position_friction", {"position_friction_N": 20.0}),
    ("magnetic_saturation", {"saturation_per_A2": 0.5}),
])
def test_energy_balance_closes_with_new_components(name, values):
    from ehsa_opt.physics import make_component
    model = BenchModel(H, [make_component(name)])
    p = model.param_vector(15.0, PROTOTYPE_FRICTION, values)
    t = np.arange(0, 2.0 / 1.5, 1e-3)
    sim = simulate_bench(model, SineMotion(0.015, 1.5), p, t)
    assert abs(sim.energy_residual()) < 0.005
    rigid = BenchModel(H)
    s0 = simulate_bench(rigid, SineMotion(0.015, 1.5), rigid.param_vector(15.0, PROTOTYPE_FRICTION),
                        t)
    assert np.max(np.abs(sim.force_N - s0.force_N)) > 5.0  # the effect is really there
    # with zero parameters the component is exactly inert
    p0 = model.param_vector(15.0, PROTOTYPE_FRICTION, {k: 0.0 for k in values})
    z = simulate_bench(model, SineMotion(0.015, 1.5), p0, t)
    np.testing.assert_allclose(z.force_N, s0.force_N, atol=1e-6)
    np.testing.assert_allclose(z.voltage_V, s0.voltage_V, atol=1e-8)


def test_asymmetric_friction_levels_by_direction():
    from ehsa_opt.physics import AsymmetricFriction
    comp = AsymmetricFriction()
    import casadi as ca
    v = ca.SX.sym("v")
    f = ca.Function("f", [v], [comp.rod_force({"v": v}, {"asym_coulomb_N": 3.0,
                                                          "asym_viscous_Ns_per_m": 10.0})])
    # F_C ± ΔF_C: the extra force is +ΔF_C + Δf_v |v| in both directions
    assert abs(float(f(0.1)) - (3.0 + 10.0 * 0.1)) < 0.02
    assert abs(float(f(-0.1)) - (3.0 + 10.0 * 0.1)) < 0.02


def test_winding_heating_raises_the_resistance_by_its_copper_loss():
    """Analytic check: with τ ≫ the run, ΔT(t) = h ∫ R_i(ΔT) i² dt, and the
    simulated temperature matches that integral of the simulated current."""
    from ehsa_opt.physics import WindingHeating
    model = BenchModel(H, [WindingHeating()])
    assert model.state_names == ["current_A", "winding_temperature_rise_K"]
    p = model.param_vector(15.0, PROTOTYPE_FRICTION, {"winding_heating_K_per_J": 2.0,
                                                      "winding_cooling_time_s": 1e4})
    t = np.arange(0, 1.0, 1e-4)
    sim = simulate_bench(model, SineMotion(0.015, 3.0), p, t)
    i, dT = sim.states
    loss = H.internal_resistance_ohm * (1 + 3.93e-3 * dT) * i ** 2
    integral = 2.0 * np.concatenate([[0.0], np.cumsum(0.5 * (loss[1:] + loss[:-1]) * np.diff(t))])
    np.testing.assert_allclose(dT, integral, rtol=2e-3, atol=1e-3)
    assert dT[-1] > 10.0
    with pytest.raises(ValueError, match="temperature_coefficient"):
        WindingHeating(temperature_coefficient_per_K=0.0)


def test_sampled_motion_cutoff_differentiates_a_sine():
    """The cut-off smoothing spline recovers v and a of a noisy sampled sine."""
    from ehsa_opt.physics.motion import FilteredMotion, SampledMotion
    rng = np.random.default_rng(0)
    m = SineMotion(0.015, 1.5)
    t = np.arange(0, 2.0, 1e-3)
    x = m.evaluate(t)[0] + rng.normal(0, 2e-6, t.size)
    inner = (t > 0.2) & (t < 1.8)
    for motion in (SampledMotion.with_cutoff(t, x, 30.0), FilteredMotion(t, x, 30.0)):
        est, ref = motion.evaluate(t), m.evaluate(t)
        for k in (1, 2):
            err = np.max(np.abs(est[k][inner] - ref[k][inner])) / np.max(np.abs(ref[k]))
            assert err < 0.05
    with pytest.raises(ValueError, match="cutoff_hz"):
        SampledMotion.with_cutoff(t, x, 0.0)


@pytest.mark.parametrize("sampled", [False, True], ids=["sine", "sampled"])
def test_simulation_without_energy_gives_the_same_outputs_bit_for_bit(sampled):
    """The fits' simulations skip the energy quadratures: they are not in CVODES' error
    test, so the states and outputs are the same to the last bit (a stiff, rattling
    contact included, whose trajectory would show any change in the steps)."""
    from ehsa_opt.physics.motion import SampledMotion
    model = BenchModel(H, [Backlash()])
    p = model.param_vector(15.0, PROTOTYPE_FRICTION)
    names = list(model.param_names)
    p[names.index("backlash_gap_m")] = 3e-4
    p[names.index("backlash_contact_stiffness_N_per_m")] = 1e8
    t = np.arange(0, 2.0 / 1.5, 1e-3)
    m = SineMotion(0.015, 1.5)
    if sampled:
        m = SampledMotion.with_cutoff(t, m.evaluate(t)[0], 30.0)
    full = simulate_bench(model, m, p, t, rtol=1e-7, atol=1e-9)
    bare = simulate_bench(model, m, p, t, rtol=1e-7, atol=1e-9, energy=False)
    assert bare.energy_J == {} and full.energy_J["work_in_abs"][-1] > 0
    np.testing.assert_array_equal(bare.force_N, full.force_N)
    np.testing.assert_array_equal(bare.voltage_V, full.voltage_V)
    np.testing.assert_array_equal(bare.states, full.states)
    assert np.ptp(np.diff(full.force_N)) > 100.0  # the contact really rattles here
