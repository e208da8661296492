"""Exact sensitivities of the compiled map in the Gauss–Newton on the simulation:
they agree with finite differences of the map, and a polish with them recovers known
parameters from synthetic data."""

import numpy as np
import pytest

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import Rig
from ehsa_opt.estimation.discrepancy.polish import polish
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.rig import predict_map, predict_map_jacobian
from ehsa_opt.physics import make_component
from ehsa_opt.physics.params import FrictionParams, HarvesterParams

H = HarvesterParams()
FR = FrictionParams(nut_breakaway_N=75.0, nut_coulomb_N=50.0,
                    nut_breakaway_velocity_m_per_s=0.006, nut_viscous_Ns_per_m=220.0,
                    bearing_breakaway_Nm=0.03, bearing_coulomb_Nm=0.02,
                    bearing_breakaway_velocity_rad_per_s=2.0,
                    bearing_viscous_Nms_per_rad=5e-5)


def _campaign(effects, seed):
    tests = generate_bench_tests(SyntheticSpec(friction=FR, effects=effects,
                                               frequencies_hz=(0.8, 3.2), loads_ohm=(22.0,),
                                               cycles=1.0, seed=seed))
    return prepare_tests(tests)


@pytest.mark.parametrize("name, values", [
    ("compliance", {"compliance_stiffness_N_per_m": 2e6, "compliance_damping_Ns_per_m": 300.0}),
    ("cogging", {"cogging_sin_Nm": 0.01, "cogging_cos_Nm": -0.004}),
])
def test_map_jacobian_matches_finite_differences(name, values):
    pts = _campaign({}, 3)[:2]
    comp = make_component(name)
    rig = Rig(H, True, (comp,))
    vals = {**FR.as_dict(), **comp.defaults(), **values}
    names = ["nut_coulomb_N", "bearing_coulomb_Nm", *values]
    ys, jacs = predict_map_jacobian(pts, rig, vals, names)
    for k, n in enumerate(names):
        d = 1e-6 * max(abs(vals[n]), 1e-3)
        up = predict_map(pts, rig, {**vals, n: vals[n] + d})
        dn = predict_map(pts, rig, {**vals, n: vals[n] - d})
        fd = np.concatenate([((a - b) / (2 * d)).ravel() for a, b in zip(up, dn)])
        ex = np.concatenate([j[:, :, k].ravel() for j in jacs])
        assert np.linalg.norm(ex - fd) < 1e-4 * np.linalg.norm(fd), n
    y0 = predict_map(pts, rig, vals)
    assert all(np.allclose(a, b) for a, b in zip(ys, y0))


def test_polish_with_exact_jacobian_recovers_compliance():
    """From a start 3x off in stiffness (log10) and 2x in damping, the Gauss–Newton
    with the map's exact sensitivities recovers the synthetic truth."""
    truth = {"compliance_stiffness_N_per_m": 2e6, "compliance_damping_Ns_per_m": 300.0}
    pts = _campaign({"compliance": truth}, 21)
    comp = make_component("compliance")
    rig = Rig(H, True, (comp,))
    start = {**FR.as_dict(), **comp.defaults(),
             "compliance_stiffness_N_per_m": 6e6, "compliance_damping_Ns_per_m": 600.0}
    po = polish(pts, rig, start, list(truth), max_iter=12, predictor=predict_map,
                log_names=["compliance_stiffness_N_per_m"])
    assert "exact Jacobian" in po.message
    assert po.sse_after < po.sse_before
    assert po.parameters["compliance_stiffness_N_per_m"] == pytest.approx(2e6, rel=0.05)
    assert po.parameters["compliance_damping_Ns_per_m"] == pytest.approx(300.0, rel=0.25)
    assert po.covariance is not None and np.all(np.isfinite(np.diag(po.covariance)))


def test_cogging_by_the_simulation_recipe_recovers_amplitude_and_phase(monkeypatch):
    """A collocation member on a campaign above the sample threshold is fitted on the
    map (screened phase grid, effect-only and joint Gauss–Newton with exact
    sensitivities): a cogging at a phase far from the collocation starts is recovered."""
    from ehsa_opt.estimation.discrepancy import candidate_fit
    from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES
    from ehsa_opt.estimation.discrepancy.fit import fit_group
    from ehsa_opt.estimation.discrepancy.rig import linear_baseline
    truth = {"cogging_sin_Nm": -0.012, "cogging_cos_Nm": -0.006}
    pts = _campaign({"cogging": truth}, 5)
    rig = Rig(H, True, ())
    comp = make_component("cogging")
    assert not candidate_fit.simulation_recipe(rig.with_components([comp]), pts)
    monkeypatch.setattr(candidate_fit, "SIMULATION_RECIPE_MIN_SAMPLES", 0)
    assert candidate_fit.simulation_recipe(rig.with_components([comp]), pts)
    base = fit_group(pts, rig, [linear_baseline(pts, rig)])
    _, res, pf, _, _ = candidate_fit.fit_member(
        ("cogging", comp, CANDIDATES["cogging"].starts, pts, pts, [], rig, base.parameters,
         100))
    assert res.path == "simulation"
    for n, v in truth.items():
        assert res.parameters[n] == pytest.approx(v, abs=0.15 * abs(truth["cogging_sin_Nm"]))


def test_polish_reuses_the_sensitivity_run_of_the_accepted_point(monkeypatch):
    """With exact sensitivities every residual comes from a sensitivity run whose
    Jacobian serves the point least_squares accepted: the iterates are those of the
    reference path (residuals from the plain map, each Jacobian from a run of its own),
    bit for bit, with one run per distinct point and fewer runs in all."""
    import ehsa_opt.estimation.discrepancy.polish as pol
    truth = {"cogging_sin_Nm": 0.01, "cogging_cos_Nm": -0.004}
    pts = _campaign({"cogging": truth}, 5)[:2]
    comp = make_component("cogging")
    rig = Rig(H, True, (comp,))
    start = {**FR.as_dict(), **comp.defaults(), "cogging_sin_Nm": 0.004,
             "cogging_cos_Nm": 0.0}
    free = list(truth)
    runs = {True: [], False: []}
    out = {}
    for reuse in (True, False):
        def predictor(prepared, r, vals, **kw):
            runs[reuse].append(("plain", tuple(vals[n] for n in free)))
            return predict_map(prepared, r, vals, **kw)

        def sensitivities(prepared, r, vals, names, **kw):
            runs[reuse].append(("sens", tuple(vals[n] for n in free)))
            return predict_map_jacobian(prepared, r, vals, names, **kw)
        predictor.jacobian = sensitivities
        monkeypatch.setattr(pol, "REUSE_SENSITIVITIES", reuse)
        out[reuse] = polish(pts, rig, start, free, predictor=predictor)
    a, b = out[True], out[False]
    assert a.parameters == b.parameters and a.sse_after == b.sse_after
    assert a.message == b.message
    assert abs(a.parameters["cogging_sin_Nm"] - 0.01) < 1e-3
    points = [p for kind, p in runs[True]]
    assert {kind for kind, _ in runs[True]} == {"sens"}
    assert len(points) == len(set(points)) == a.nfev  # one run per distinct point
    assert len(runs[False]) > len(runs[True])
