"""The quarter car under the LuGre friction law: the static law as its limit, the energy
balance with the bristle spring, the time step against an accurate integrator."""

import numpy as np
import pytest

from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
from ehsa_opt.physics.params import FrictionParams, HarvesterParams, RoadParams, VehicleParams
from ehsa_opt.physics.quarter_car_model import QuarterCarModel, param_vector
from ehsa_opt.vehicle.road import synthesize_road
from ehsa_opt.vehicle.simulate import simulate_quarter_car

TRUE_FRICTION = FrictionParams(**load_truth(embedded_data_dir())["friction"])


def lugre(sigma0: float, sigma1: float, base: FrictionParams = TRUE_FRICTION) -> FrictionParams:
    return base.with_law("lugre", presliding_stiffness_N_per_m=sigma0,
                         presliding_damping_Ns_per_m=sigma1)


@pytest.fixture(scope="module")
def limit_run():
    road = RoadParams(iso_class="C", speed_km_per_h=80, length_m=400.0, seed=1)
    frictions = [TRUE_FRICTION, lugre(1e10, 0.0), lugre(1e10, 1000.0), lugre(1e5, 300.0)]
    return simulate_quarter_car(VehicleParams(), HarvesterParams(load_ohm=47.0), frictions,
                                road, warn=False)


def test_stiff_bristle_reproduces_the_static_law(limit_run):
    sim = limit_run
    assert sim.success
    for key in ("comfort", "road_holding", "power_W", "dissipated_power_W", "efficiency"):
        static = sim.metrics[key][0]
        for b in (1, 2):  # sigma_0 = 1e10 N/m (the declared upper bound), with and without damping
            assert sim.metrics[key][b] == pytest.approx(static, rel=1e-4), (key, b)
    # a soft bristle is a different law: its power differs by more than the limit's error
    assert abs(sim.metrics["power_W"][3] / sim.metrics["power_W"][0] - 1) > 1e-3


def test_energy_balance_and_dissipation_invariant_with_the_bristle(limit_run):
    sim = limit_run
    m = sim.metrics
    assert np.all(np.abs(m["energy_residual"]) < 0.005)
    h = HarvesterParams(load_ohm=47.0)
    eta_max = h.load_ohm / (h.load_ohm + h.internal_resistance_ohm)
    assert np.all(m["efficiency"] < eta_max)
    # P / eta = dissipated power: design-invariant (the road's input), so the same under
    # either law, and below the bound of the road's input
    p_over_eta = m["power_W"] / m["efficiency"]
    assert np.allclose(p_over_eta, m["dissipated_power_W"], rtol=1e-9)
    assert np.allclose(m["dissipated_power_W"], m["dissipated_power_W"][0], rtol=0.01)
    assert np.all(m["power_W"] < m["dissipation_bound_W"])


def test_bristle_storage_is_stored_energy_and_a_soft_bristle_closes_the_balance():
    """The bristle spring stores ½ F_b²/σ₀ (in the stored energy, not the dissipation);
    with a soft bristle (2e4 N/m: millimetres of presliding) the balance still closes."""
    p = param_vector(VehicleParams(), HarvesterParams(load_ohm=47.0), lugre(2e4, 0.0))
    z = np.zeros((6, 1))
    z[5, 0] = 30.0
    assert QuarterCarModel.stored_energy(z, np.zeros(1), p)[0] == pytest.approx(
        0.5 * 30.0 ** 2 / 2e4)
    p_static = param_vector(VehicleParams(), HarvesterParams(load_ohm=47.0), TRUE_FRICTION)
    assert QuarterCarModel.stored_energy(z, np.zeros(1), p_static)[0] == 0.0
    road = RoadParams(iso_class="C", speed_km_per_h=80, length_m=200.0, seed=4)
    sim = simulate_quarter_car(VehicleParams(), HarvesterParams(load_ohm=47.0),
                               [lugre(2e4, 0.0), lugre(2e4, 200.0)], road, warn=False,
                               keep_series=("bristle_force_N",))
    assert sim.success and np.all(np.abs(sim.metrics["energy_residual"]) < 0.005)
    fb = sim.series["bristle_force_N"]
    assert np.max(np.abs(fb)) > 20.0  # the bristle carries the friction


def test_lugre_step_agrees_with_an_accurate_reference_integrator():
    from scipy.integrate import solve_ivp
    vehicle, h = VehicleParams(), HarvesterParams(load_ohm=47.0)
    fr = lugre(1e6, 500.0)
    road = RoadParams(iso_class="C", speed_km_per_h=100, length_m=25.0, seed=2)
    sim = simulate_quarter_car(vehicle, h, fr, road, settle_s=0.0, warn=False,
                               keep_series=("bristle_force_N",))
    prof = synthesize_road(road, 1000.0)
    x0 = np.concatenate([prof.elevation_m, prof.elevation_m[:1]])
    t = np.arange(x0.size) / 1000.0
    p = param_vector(vehicle, h, fr)
    model = QuarterCarModel()
    jac = model.ode.factory("ode_jacobian", ["z", "x0", "p"], ["jac:zdot:z"])

    def rhs(tt, z):
        return np.asarray(model.ode(z, np.interp(tt, t, x0), p)).ravel()

    def jrhs(tt, z):
        return np.asarray(jac(z, np.interp(tt, t, x0), p))

    sol = solve_ivp(rhs, (0, t[-1]), [x0[0], x0[0], 0, 0, 0, 0], method="Radau", t_eval=t,
                    jac=jrhs, rtol=1e-7, atol=1e-9)
    assert sol.success
    ref = 47.0 * np.mean(sol.y[4][1:] ** 2)
    assert float(sim.metrics["power_W"][0]) == pytest.approx(ref, rel=5e-3)
    fb_ref = sol.y[5][1:]
    fb = sim.series["bristle_force_N"][0]
    assert np.sqrt(np.mean((fb - fb_ref) ** 2)) < 0.05 * np.sqrt(np.mean(fb_ref ** 2))


def test_a_batch_mixing_the_laws_gives_each_design_its_own_result():
    """Static and LuGre designs run on their own graphs (the static step as cheap as
    before); in one batch each gets what it gets alone (to round-off: the metrics'
    reductions run over arrays of another layout)."""
    road = RoadParams(iso_class="C", speed_km_per_h=100, length_m=120.0, seed=6)
    frs = [lugre(1e6, 300.0), TRUE_FRICTION, lugre(3e5, 0.0), FrictionParams()]
    hs = [HarvesterParams(load_ohm=r) for r in (15.0, 47.0, 109.0, 47.0)]
    both = simulate_quarter_car(VehicleParams(), hs, frs, road, warn=False)
    for b, (h, f) in enumerate(zip(hs, frs)):
        alone = simulate_quarter_car(VehicleParams(), h, f, road, warn=False)
        for key in ("power_W", "comfort", "road_holding", "energy_residual"):
            assert alone.metrics[key][0] == pytest.approx(both.metrics[key][b], rel=1e-9,
                                                          abs=1e-15), (key, b)
