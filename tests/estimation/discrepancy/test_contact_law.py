"""The backlash's contact law (linear or Hertzian) and the rule that a gap shorter than
its contact's deflection is not a resolved gap."""

import math

import numpy as np

import pytest

from ehsa_opt.physics import make_component
from ehsa_opt.physics.components import Backlash

GAP, K, C = ("backlash_gap_m", "backlash_contact_stiffness_N_per_m",
             "backlash_contact_damping_Ns_per_m")


def _force(comp, delta, p):
    return float(comp.coupling_force({"delta": delta, "delta_dot": 0.0}, p))


def _energy(comp, delta, p):
    return float(comp.stored_energy({"delta": delta, "delta_dot": 0.0}, p))


@pytest.mark.parametrize("pen_m", [2e-5, 1e-4])
def test_hertz_contact_force_grows_as_penetration_to_the_1_5(pen_m):
    """k_c is the secant stiffness at 10 um: F = k_c 1e-5 (p/1e-5)^1.5 (within the 2 um
    smoothing's share), on both faces, and its stored energy's derivative is the force."""
    p = {GAP: 2e-4, K: 1e7, C: 0.0}
    comp = Backlash(contact_exponent=1.5)
    d = 1e-4 + pen_m
    expected = 1e7 * 1e-5 * (pen_m / 1e-5) ** 1.5
    assert math.isclose(_force(comp, d, p), expected, rel_tol=1e-2)
    assert math.isclose(_force(comp, -d, p), -expected, rel_tol=1e-2)
    h = 1e-9
    dE = (_energy(comp, d + h, p) - _energy(comp, d - h, p)) / (2 * h)
    assert math.isclose(dE, _force(comp, d, p), rel_tol=1e-4)
    # inside the gap no force; the linear law is unchanged (k p)
    assert abs(_force(comp, 0.0, p)) < 1e-6
    assert math.isclose(_force(make_component("backlash"), d, p), 1e7 * pen_m, rel_tol=1e-2)


def test_contact_law_option_is_checked():
    with pytest.raises(ValueError, match="contact_exponent"):
        Backlash(contact_exponent=3.0)


def test_with_contact_law_replaces_only_the_backlash():
    from ehsa_opt.datasets.synthetic import SyntheticSpec
    from ehsa_opt.estimation.discrepancy.impacts import with_contact_law
    from ehsa_opt.estimation.discrepancy.rig import Rig
    rig = Rig(SyntheticSpec().harvester, True,
              (make_component("cogging"), make_component("backlash")))
    hz = with_contact_law(rig, 1.5)
    assert type(hz.components[0]).__name__ == "Cogging"
    assert hz.components[1].contact_exponent == 1.5
    assert hz.model() is not rig.model()  # another law, another model
    assert with_contact_law(hz, 1.0).model() is rig.model()


def test_hertz_contact_damping_is_hunt_crossley():
    """With the power law the damping force is c_c (p/p_ref)^1.5 dp/dt: zero at first
    touch, c_c dp/dt at the reference penetration; its dissipated power is force x rate."""
    p = {GAP: 2e-4, K: 1e7, C: 50.0}
    comp = Backlash(contact_exponent=1.5)
    s = {"delta": 1e-4 + 1e-5, "delta_dot": 0.3}
    damping = float(comp.coupling_force(s, p)) - _force(comp, s["delta"], p)
    assert math.isclose(damping, 50.0 * 0.3, rel_tol=2e-2)
    s0 = {"delta": 1e-4, "delta_dot": 0.3}
    at_touch = float(comp.coupling_force(s0, p)) - _force(comp, s0["delta"], p)
    assert abs(at_touch) < 0.05 * 15.0  # the linear law's: half of 50 x 0.3 there
    assert math.isclose(float(comp.dissipated_power(s, p)), damping * 0.3, rel_tol=1e-9)


def test_heldout_verdict_is_widened_by_the_friction_uncertainty():
    """The held-out features of an impact-fitted contact get the spread ±5 % friction
    levels give them (as in the fit): the widened objective is never above the plain one,
    and a contact 30 % too soft is still told from the truth."""
    from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
    from ehsa_opt.estimation.discrepancy.impact_verdict import (
        friction_spread_of_features,
        impact_verdict,
    )
    from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
    from ehsa_opt.estimation.discrepancy.rig import Rig, predict
    truth = {GAP: 3e-4, K: 1e8, C: 8e3}
    spec = SyntheticSpec(effects={"backlash": truth}, frequencies_hz=(2.0,),
                         loads_ohm=(47.0, 109.0), seed=3)
    pts = prepare_tests(generate_bench_tests(spec), True)
    h = spec.harvester
    rigid, crig = Rig(h, True, ()), Rig(h, True, (make_component("backlash"),))
    p_true = {**spec.friction.as_dict(), **truth}
    cur = predict(pts, rigid, p_true)
    verdicts = {}
    for name, p in (("truth", p_true), ("soft", {**p_true, K: 3e7})):
        pred = predict(pts, crig, p)
        widen, _ = friction_spread_of_features(pts, crig, p, pred)
        assert all(np.all(w[0] >= 0) for w in widen)
        verdicts[name] = v = impact_verdict(pts, cur, pred, h, 3, widen)
        assert v["heldout_objective_after"] <= v["heldout_objective_after_unwidened"] + 1e-12
    from ehsa_opt.estimation.discrepancy.judge import impact_earns
    v = verdicts["truth"]
    assert impact_earns(v["heldout_objective_before"], v["heldout_objective_after"])
    assert verdicts["truth"]["heldout_objective_after"] < verdicts["soft"]["heldout_objective_after"]


def test_impact_fit_search_stops_at_the_runs_deadline():
    """Past the run's deadline the Nelder-Mead stage stops at once with the best grid
    point and says so (a budget that ends in a stated result)."""
    from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
    from ehsa_opt.estimation.discrepancy.budget import budget_set
    from ehsa_opt.estimation.discrepancy.impacts import fit_impacts
    from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
    from ehsa_opt.estimation.discrepancy.rig import Rig
    truth = {GAP: 3e-4, K: 1e8, C: 8e3}
    spec = SyntheticSpec(effects={"backlash": truth}, frequencies_hz=(2.0,),
                         loads_ohm=(47.0,), seed=1)
    pts = prepare_tests(generate_bench_tests(spec), True)
    rig = Rig(spec.harvester, True, (make_component("backlash"),))
    start = {**make_component("backlash").defaults(), **spec.friction.as_dict()}
    with budget_set(None, 1e-6):
        res = fit_impacts(pts, rig, start)
    assert "deadline" in res.message and not res.success
    assert res.evaluations == 11  # the grid only (8 stiffnesses, 3 of them at a second damping)
    assert res.objective == res.objective_start
    kint = res.stiffness  # a bracket around the best point, stated as such
    assert kint["lower_N_per_m"] <= res.parameters[K] <= kint["upper_N_per_m"]
    assert str(kint["identified"] and "identified" or "NOT identified") in res.message


def _profile(k_true, width_dec, ks, n=40):
    """History rows of a quadratic profile in log k (objective 2 at the truth)."""
    return [{K: k, "objective": 2.0 * (1.0 + (math.log10(k / k_true) / width_dec) ** 2),
             "contact_exponent": 1.5} for k in ks]


def test_stiffness_interval_brackets_a_sharp_profile_and_flags_a_flat_one():
    """A sharp profile in log k is bracketed by its grid neighbours and identified; a flat
    one (every stiffness within the spread of the best) is an open, unidentified bracket;
    the law's own constant of a Hertzian secant stiffness is K = k_c p_ref^-0.5."""
    from ehsa_opt.estimation.discrepancy.impact_stiffness import (
        law_constant,
        stiffness_interval,
    )
    ks = [10 ** (6 + 0.25 * i) for i in range(15)]  # 1e6 .. 3.2e9
    sharp = stiffness_interval(_profile(1e8, 0.1, ks), 1.5, 40, K, (1e4, 1e10))
    assert sharp["identified"] and not sharp["open_below"] and not sharp["open_above"]
    assert sharp["lower_N_per_m"] < 1e8 < sharp["upper_N_per_m"]
    assert sharp["upper_N_per_m"] / sharp["lower_N_per_m"] < 4.0
    flat = stiffness_interval(_profile(1e8, 30.0, ks), 1.5, 40, K, (1e4, 1e10))
    assert not flat["identified"] and flat["open_below"] and flat["open_above"]
    assert (flat["lower_N_per_m"], flat["upper_N_per_m"]) == (1e4, 1e10)
    # rows of another law are not used
    with pytest.raises(ValueError, match="exponent 1"):
        stiffness_interval(_profile(1e8, 0.1, ks), 1.0, 40, K)
    assert law_constant(1e7, 1.5) == pytest.approx(1e7 / math.sqrt(1e-5))
    assert law_constant(3e8, 1.0) == 3e8
