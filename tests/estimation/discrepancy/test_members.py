"""The catalogue members ``position_friction`` and ``magnetic_saturation``:
energy closes with each, the quasi-static saturated current is exact, the stroke
window is found in the residual, and a synthetic data set with each effect is
named by the workflow with a lower held-out error."""

from dataclasses import replace

import numpy as np
import pytest

from ehsa_opt.datasets.synthetic import (PROTOTYPE_FRICTION, SyntheticSpec, generate_bench_tests,
                                         write_synthetic)
from ehsa_opt.estimation.discrepancy import (CANDIDATES, DiscrepancySettings, Rig, fit_group,
                                             run_discrepancy)
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.rig import linear_baseline, predict
from ehsa_opt.estimation.discrepancy.localise import stroke_window
from ehsa_opt.physics import COMPONENTS, BenchModel, make_component
from ehsa_opt.physics.bench_sim import simulate_bench
from ehsa_opt.physics.motion import SineMotion
from ehsa_opt.physics.params import HarvesterParams

H = HarvesterParams()
WINDOW = {"position_friction_N": 10.0, "position_friction_centre_m": 0.003,
          "position_friction_width_m": 0.008}
SATURATION = {"saturation_per_A2": 0.03}


def _spec(effects, seed=5):
    return SyntheticSpec(effects=effects, frequencies_hz=(1.5, 2.5, 3.5), loads_ohm=(15.0, 109.0),
                         cycles=1.0, seed=seed)


def test_members_are_registered_candidates():
    for name in ("position_friction", "magnetic_saturation"):
        assert name in CANDIDATES and name in COMPONENTS
    assert CANDIDATES["position_friction"].amplitudes == ("position_friction_N",)
    assert CANDIDATES["position_friction"].rigid_channels == (0,)
    assert CANDIDATES["magnetic_saturation"].needs_generator
    assert CANDIDATES["magnetic_saturation"].amplitudes == ("saturation_per_A2",)


@pytest.mark.parametrize("name,values", [("position_friction", WINDOW),
                                         ("magnetic_saturation", {"saturation_per_A2": 0.5})])
def test_energy_closes_and_zero_amplitude_is_inert(name, values):
    model = BenchModel(H, [make_component(name)])
    t = np.arange(0, 2.0 / 1.5, 1e-3)
    m = SineMotion(0.015, 1.5)
    sim = simulate_bench(model, m, model.param_vector(15.0, PROTOTYPE_FRICTION, values), t)
    assert abs(sim.energy_residual()) < 1e-4
    rigid = BenchModel(H)
    s0 = simulate_bench(rigid, m, rigid.param_vector(15.0, PROTOTYPE_FRICTION), t)
    assert np.max(np.abs(sim.force_N - s0.force_N)) > 5.0  # the effect is really there
    amp = CANDIDATES[name].amplitudes[0]
    z = simulate_bench(model, m, model.param_vector(15.0, PROTOTYPE_FRICTION,
                                                    {**values, amp: 0.0}), t)
    np.testing.assert_allclose(z.force_N, s0.force_N, atol=1e-6)
    np.testing.assert_allclose(z.voltage_V, s0.voltage_V, atol=1e-8)


def test_saturation_emf_and_torque_fall_alike_and_quasi_static_current_is_exact():
    h0 = replace(H, inductance_H=0.0)
    beta, load = 0.5, 15.0
    model = BenchModel(h0, [make_component("magnetic_saturation")])
    t = np.arange(0, 1.0, 1e-3)
    m = SineMotion(0.015, 2.0)
    sim = simulate_bench(model, m, model.param_vector(load, PROTOTYPE_FRICTION,
                                                      {"saturation_per_A2": beta}), t)
    i = sim.voltage_V / load
    e0 = h0.voltage_constant_Vs_per_rad * sim.velocity_m_per_s / h0.lead_m_per_rad
    R = load + h0.internal_resistance_ohm
    np.testing.assert_allclose(i * R * (1 + beta * i * i), e0, atol=1e-9)  # the cubic
    assert np.max(np.abs(i)) > 1.0  # deep in saturation here
    # the generator's share of the rod force is K_t g(i) i / r
    rigid = BenchModel(h0)
    s0 = simulate_bench(rigid, m, rigid.param_vector(load, PROTOTYPE_FRICTION), t)
    i0 = s0.voltage_V / load
    gen = h0.torque_constant_Nm_per_A / h0.lead_m_per_rad
    np.testing.assert_allclose(sim.force_N - s0.force_N,
                               gen * (i / (1 + beta * i * i) - i0), atol=1e-6)


def test_stroke_window_found_in_the_residual():
    tests = generate_bench_tests(_spec({"position_friction": WINDOW}))
    pts = prepare_tests(tests)
    rig = Rig(H, True, ())
    base = fit_group(pts, rig, [linear_baseline(pts, rig)])
    xc, width = stroke_window(pts, predict(pts, rig, base.parameters))
    assert abs(xc - 0.003) < 1e-3 and abs(width - 0.008) < 2e-3


@pytest.mark.parametrize("effect,params", [("position_friction", WINDOW),
                                           ("magnetic_saturation", SATURATION)])
def test_hidden_member_is_named_and_heldout_error_falls(effect, params, tmp_path):
    d = write_synthetic(tmp_path / "data", _spec({effect: params}))
    res = run_discrepancy(d, DiscrepancySettings(top=2, max_effects=1))
    assert res.effect == effect, res.message
    assert res.evaluation == "held-out"
    assert res.error_after < 0.5 * res.error_before
    fit = next(c for c in res.candidates if c.effect == effect)
    for k, v in params.items():
        assert abs(fit.parameters[k] / v - 1) < 0.25, (k, fit.parameters[k])
