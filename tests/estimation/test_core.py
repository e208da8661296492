"""The estimation core: one NLP per structure, rigid fast path and
collocation agree, backlash through collocation, IPOPT failure reported."""

import math

import numpy as np
import pytest

from ehsa_opt.datasets.synthetic import PROTOTYPE_FRICTION, SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation import core
from ehsa_opt.estimation.collocation import integrate_states, states_depend_on
from ehsa_opt.estimation.identify import IdentifyOptions, fit_tests
from ehsa_opt.estimation.identify import test_motion as motion_of
from ehsa_opt.physics import BenchModel
from ehsa_opt.physics.bench_sim import simulate_bench
from ehsa_opt.physics.components import Backlash
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.params import FRICTION_NAMES, HarvesterParams


@pytest.fixture(scope="module")
def rigid_tests():
    """Clean rigid synthetic tests: three loads at 2 Hz (equal length), one at 3 Hz."""
    spec = SyntheticSpec(effects={}, frequencies_hz=(2.0, 3.0), loads_ohm=(15.0, 47.0, 109.0),
                         seed=11)
    return generate_bench_tests(spec)


def _rod_error(params, test):
    r = HarvesterParams().lead_m_per_rad
    v = np.linspace(0.1, 1.0, 40) * 2 * np.pi * test.frequency_hz * test.amplitude_m
    true = rod_friction_N(v, PROTOTYPE_FRICTION, r)
    est = rod_friction_N(v, [params[n] for n in FRICTION_NAMES], r)
    return float(np.max(np.abs(est / true - 1)))


def test_rigid_bench_states_do_not_depend_on_friction():
    h = HarvesterParams()
    assert not states_depend_on(BenchModel(h), FRICTION_NAMES)
    assert states_depend_on(BenchModel(h, [Backlash()]), ["backlash_gap_m"])


def test_compiled_radau_integration_matches_cvodes(rigid_tests):
    model = BenchModel(HarvesterParams())
    t = rigid_tests[0]
    m = motion_of(t)
    p = model.param_vector(t.load_ohm)
    X = integrate_states(model, m, t.time_s, p)
    ref = simulate_bench(model, m, p, t.time_s, rtol=1e-9, atol=1e-11).states
    assert np.max(np.abs(X - ref)) < 1e-4 * np.max(np.abs(ref))


def test_fast_path_and_collocation_recover_the_same_friction(rigid_tests):
    h = HarvesterParams()
    t = rigid_tests[0]
    fast = fit_tests([t], h, starts=2, seed=1, identifiability=False)
    coll = fit_tests([t], h, starts=2, seed=1, identifiability=False,
                     options=IdentifyOptions(path="collocation"))
    assert fast.success and coll.success
    assert fast.path == "rigid" and coll.path == "collocation"
    assert _rod_error(fast.parameters, t) < 0.03
    assert _rod_error(coll.parameters, t) < 0.03
    r = h.lead_m_per_rad
    v = np.linspace(0.1, 1.0, 20) * 2 * np.pi * t.frequency_hz * t.amplitude_m
    a = rod_friction_N(v, [fast.parameters[n] for n in FRICTION_NAMES], r)
    b = rod_friction_N(v, [coll.parameters[n] for n in FRICTION_NAMES], r)
    assert np.max(np.abs(a / b - 1)) < 0.005
    assert fast.force_relative_error_percent == pytest.approx(coll.force_relative_error_percent,
                                                              rel=1e-3)


def test_one_solver_serves_tests_of_equal_structure(rigid_tests):
    h = HarvesterParams()
    same = [t for t in rigid_tests if t.frequency_hz == 2.0]  # equal length, other loads
    assert len(same) == 3
    opt = IdentifyOptions(path="collocation", max_iter=300, tol=1e-7)  # a structure of its own
    n0 = core.build_count()
    fits = [fit_tests([t], h, starts=2, seed=k, options=opt, identifiability=False)
            for k, t in enumerate(same)]
    assert core.build_count() - n0 == 1
    assert all(f.success for f in fits)
    assert all(_rod_error(f.parameters, t) < 0.03 for f, t in zip(fits, same))
    # a test of another length needs its own NLP
    other = next(t for t in rigid_tests if t.frequency_hz == 3.0)
    fit_tests([other], h, starts=1, options=opt, identifiability=False)
    assert core.build_count() - n0 == 2


@pytest.fixture(scope="module")
def backlash_tests():
    spec = SyntheticSpec(effects={"backlash": {}}, frequencies_hz=(3.5,), loads_ohm=(47.0,),
                         cycles=1.0, seed=5)
    return generate_bench_tests(spec)


def test_backlash_model_refuses_the_rigid_path(backlash_tests):
    with pytest.raises(ValueError, match="rigid"):
        fit_tests(backlash_tests, HarvesterParams(), components=(Backlash(),),
                  free=["backlash_gap_m"], options=IdentifyOptions(path="rigid"))


@pytest.mark.slow
def test_backlash_model_goes_through_collocation(backlash_tests):
    """Bearing friction drives the rotor states of the elastic transmission: collocation."""
    res = fit_tests(backlash_tests, HarvesterParams(), components=(Backlash(),),
                    free=["nut_coulomb_N", "nut_viscous_Ns_per_m", "bearing_coulomb_Nm"],
                    fixed={"nut_breakaway_N": "nut_coulomb_N",
                           "bearing_breakaway_Nm": "bearing_coulomb_Nm"},
                    starts=1, identifiability=False,
                    options=IdentifyOptions(max_intervals=100, max_samples=300, max_iter=300))
    assert res.path == "collocation"
    assert res.success, res.message
    assert 10.0 < res.parameters["nut_coulomb_N"] < 60.0
    assert res.force_relative_error_percent < 20


@pytest.mark.parametrize("path", ["rigid", "collocation"])
def test_ipopt_failure_is_reported_without_numbers(rigid_tests, path):
    res = fit_tests(rigid_tests[:1], HarvesterParams(), starts=2,
                    options=IdentifyOptions(max_iter=1, path=path))
    assert not res.success
    assert all(not s["success"] for s in res.starts)
    assert all(s["status"] == "Maximum_Iterations_Exceeded" for s in res.starts)
    assert all(math.isnan(v) for v in res.parameters.values())
    assert res.delta_F is None and res.identifiability is None


def _theta_problem(test, every):
    """A compliance model on the first 100 samples of ``test`` (theta transcription,
    ``every`` sub-intervals per sample): model, parameter space, blocks."""
    from ehsa_opt.estimation.collocation import theta_block
    from ehsa_opt.physics.components import Compliance
    model = BenchModel(HarvesterParams(), [Compliance()])
    free = ["nut_coulomb_N", "nut_viscous_Ns_per_m", "bearing_coulomb_Nm",
            "compliance_stiffness_N_per_m", "compliance_damping_Ns_per_m"]
    specs = dict(model.param_specs)
    lower = [0.0, 0.0, 0.0, specs[free[3]].lower, specs[free[4]].lower]
    upper = [500.0, 5e3, 1.0, specs[free[3]].upper, specs[free[4]].upper]
    scale = [50.0, 500.0, 0.05, 2e6, 1e3]
    space = core.ParamSpace(tuple(model.param_names), tuple(free), tuple(lower), tuple(upper),
                            tuple(scale), order=(("nut_breakaway_N", "nut_coulomb_N"),))
    n = 100
    t, m = test.time_s[:n], motion_of(test)
    tf = np.append((t[:-1, None] + np.diff(t)[:, None] * (np.arange(every) / every)).ravel(),
                   t[-1])
    y = np.vstack([test.force_N[:n], test.voltage_V[:n]])
    w = np.vstack([np.full(n, 1 / 2.0), np.full(n, 1 / 0.02)])
    pbase = np.asarray(model.param_vector(test.load_ohm), float)
    return model, space, [theta_block(model, tf, m.evaluate(tf), every, y, w, pbase)]


@pytest.mark.parametrize("objective, every, solve", [
    (core.Objective("likelihood", regularisation=1e-6), 2, True),
    (core.Objective("minimax"), 1, False)])
def test_node_by_node_hessian_is_the_whole_graph_hessian(rigid_tests, objective, every, solve):
    """The theta NLP's Hessian assembled node by node has CasADi's whole-graph pattern
    and values (likelihood and minimax, observations at every node or every other),
    and IPOPT ends at the same point with either."""
    model, space, blocks = _theta_problem(rigid_tests[0], every)
    settings = core.SolverSettings(1e-8, 200)
    nlps = []
    try:
        for flag in (False, True):
            core.STRUCTURED_HESSIAN = flag
            nlps.append(core.build(model, space, objective, settings, blocks))
    finally:
        core.STRUCTURED_HESSIAN = True
    z0 = space.z_of({"nut_coulomb_N": 30.0, "nut_viscous_Ns_per_m": 200.0,
                     "bearing_coulomb_Nm": 0.01, "compliance_stiffness_N_per_m": 2e6,
                     "compliance_damping_Ns_per_m": 1e3})
    p = nlps[0].data(blocks, z0)
    rng = np.random.default_rng(3)
    w = nlps[0].initial(z0, blocks, p) + 0.1 * rng.standard_normal(nlps[0].nw)
    lam_g = rng.standard_normal(nlps[0].lbg.size)
    H = [n.solver.get_function("nlp_hess_l")(w, p, 0.7, lam_g) for n in nlps]
    assert H[0].sparsity() == H[1].sparsity()
    a, b = np.array(H[0].nonzeros()), np.array(H[1].nonzeros())
    assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))
    if not solve:
        return
    recs = [core.solve_starts(n, blocks, [z0], zref=z0)[0] for n in nlps]
    assert all(r.success for r in recs), [r.status for r in recs]
    assert np.allclose(recs[1].w[:space.nv], recs[0].w[:space.nv], rtol=1e-6, atol=1e-9)
    assert recs[1].objective == pytest.approx(recs[0].objective, rel=1e-9)


def _given_problem(tests):
    """The rigid model on 300 samples of each of ``tests`` (given transcription: the
    current integrated beforehand): model, parameter space, blocks."""
    from ehsa_opt.estimation.collocation import given_block
    model = BenchModel(HarvesterParams())
    free = ("nut_breakaway_N", "nut_coulomb_N", "nut_breakaway_velocity_m_per_s",
            "nut_viscous_Ns_per_m", "bearing_coulomb_Nm", "bearing_viscous_Nms_per_rad")
    space = core.ParamSpace(tuple(model.param_names), free, (0.0, 0.0, 1e-4, 0.0, 0.0, 0.0),
                            (500.0, 500.0, 0.5, 5e3, 1.0, 1e-2),
                            (50.0, 50.0, 0.01, 500.0, 0.05, 1e-4),
                            order=(("nut_breakaway_N", "nut_coulomb_N"),))
    blocks = []
    for test in tests:
        m, pb = motion_of(test), np.asarray(model.param_vector(test.load_ohm), float)
        X = integrate_states(model, m, test.time_s, pb)
        obs = np.arange(50, 350)
        y = np.vstack([test.force_N[obs], test.voltage_V[obs]])
        w = np.array([1 / np.max(np.abs(test.force_N)), 1 / np.max(np.abs(test.voltage_V))])
        blocks.append(given_block(model, X[:, obs], m.evaluate(test.time_s[obs]), y, w, pb))
    return model, space, blocks


def test_sample_by_sample_hessian_is_the_whole_graph_hessian(rigid_tests, monkeypatch):
    """The minimax given NLP's Hessian summed sample by sample (a mapped, compiled
    per-sample function) has CasADi's whole-graph pattern and values, the same numbers
    without a C compiler, and IPOPT ends at the same point with either."""
    from ehsa_opt.estimation.hessians import given_hessian
    model, space, blocks = _given_problem(rigid_tests[:3])
    objective, settings = core.Objective("minimax"), core.SolverSettings(1e-8, 200)
    nlps = []
    try:
        for flag in (False, True):
            core.STRUCTURED_HESSIAN = flag
            nlps.append(core.build(model, space, objective, settings, blocks))
    finally:
        core.STRUCTURED_HESSIAN = True
    z0 = space.z_of({"nut_breakaway_N": 40.0, "nut_coulomb_N": 30.0,
                     "nut_breakaway_velocity_m_per_s": 0.02, "nut_viscous_Ns_per_m": 200.0,
                     "bearing_coulomb_Nm": 0.01, "bearing_viscous_Nms_per_rad": 1e-4})
    p = nlps[0].data(blocks, z0)
    rng = np.random.default_rng(5)
    w = nlps[0].initial(z0, blocks, p) + 0.1 * rng.standard_normal(nlps[0].nw)
    lam_g = rng.standard_normal(nlps[0].lbg.size)
    H = [n.solver.get_function("nlp_hess_l")(w, p, 0.7, lam_g) for n in nlps]
    assert H[0].sparsity() == H[1].sparsity()
    a, b = np.array(H[0].nonzeros()), np.array(H[1].nonzeros())
    assert np.max(np.abs(a)) > 0
    assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))
    monkeypatch.setenv("EHSA_OPT_NO_JIT", "1")  # CasADi's virtual machine: the same numbers
    nlp = nlps[1]
    vm = given_hessian(model, space, nlp.keys, nlp.W, nlp.P, nlp.data_sizes, nlp.n_eq,
                       nlp.lbg.size)(w, p, 0.7, lam_g)
    assert np.array_equal(np.array(vm.nonzeros()), b)
    recs = [core.solve_starts(n, blocks, [z0])[0] for n in nlps]
    assert all(r.success for r in recs), [r.status for r in recs]
    assert np.allclose(recs[1].w[:space.nv], recs[0].w[:space.nv], rtol=1e-6, atol=1e-9)
    assert recs[1].objective == pytest.approx(recs[0].objective, rel=1e-9)
