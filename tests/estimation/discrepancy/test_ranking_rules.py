"""The rules that keep a surrogate member from being named: a member fitted on the edge
of its physical range does not earn; the ranking and the winner follow the channel that
sees the effect."""

import math
from types import SimpleNamespace as NS

import pytest

from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES
from ehsa_opt.estimation.discrepancy.evidence import at_bound
from ehsa_opt.physics import make_component


def _specs(name):
    return make_component(name).parameters


def test_a_parameter_on_its_search_bound_is_at_bound():
    specs = _specs("compliance")
    lim = CANDIDATES["compliance"].limits
    # the Shockley-diode campaign's compliance: stiffness on the lower bound 1e4 N/m
    assert at_bound({"compliance_stiffness_N_per_m": 1.0e4,
                     "compliance_damping_Ns_per_m": 300.0}, specs, lim) == [
        "compliance_stiffness_N_per_m"]
    # within 5 % of it, too; at 1.2e4 N/m it is inside the range
    assert at_bound({"compliance_stiffness_N_per_m": 1.04e4}, specs, lim)
    assert not at_bound({"compliance_stiffness_N_per_m": 1.2e4}, specs, lim)
    # the damping on its upper edge (1e5 N s/m) is at bound; zero damping is physical
    assert at_bound({"compliance_stiffness_N_per_m": 1.3e7,
                     "compliance_damping_Ns_per_m": 1e5}, specs, lim) == [
        "compliance_damping_Ns_per_m"]
    assert not at_bound({"compliance_stiffness_N_per_m": 1.3e7,
                         "compliance_damping_Ns_per_m": 0.0}, specs, lim)
    # the stiffness's upper bound is the rigid limit, a physical one
    assert not at_bound({"compliance_stiffness_N_per_m": 1e9}, specs, lim)
    assert at_bound({"compliance_stiffness_N_per_m": 1e9}, specs, ())


def test_zero_bounds_and_declared_limits_are_physical():
    # a voltage drop of 0 V is the absent effect (its significance decides), not a bound
    assert not at_bound({"voltage_drop_V": 0.0}, _specs("voltage_drop"), ())
    assert at_bound({"voltage_drop_V": 5.0}, _specs("voltage_drop"), ()) == ["voltage_drop_V"]
    # a cogging of 0.1 N m (its range's edge, either sign)
    cog = _specs("cogging")
    assert at_bound({"cogging_sin_Nm": -0.099, "cogging_cos_Nm": 0.0}, cog, ())
    assert not at_bound({"cogging_sin_Nm": 0.012, "cogging_cos_Nm": -0.004}, cog, ())
    # a backlash with a rigid, rebound-free contact is physical; a gap of 2 mm is not
    bl, lim = _specs("backlash"), CANDIDATES["backlash"].limits
    assert not at_bound({"backlash_gap_m": 2e-4, "backlash_contact_stiffness_N_per_m": 1e10,
                         "backlash_contact_damping_Ns_per_m": 1e5}, bl, lim)
    assert at_bound({"backlash_gap_m": 2e-3}, bl, lim) == ["backlash_gap_m"]
    # non-finite values are ignored; a bad tolerance is refused
    assert not at_bound({"voltage_drop_V": math.nan}, _specs("voltage_drop"), ())
    with pytest.raises(ValueError, match="rel"):
        at_bound({}, cog, (), rel=1.5)


def test_a_member_at_its_bound_does_not_earn():
    from ehsa_opt.estimation.discrepancy.evidence import refuse_at_bound
    from ehsa_opt.estimation.discrepancy.results import CandidateResult
    said = []
    c = CandidateResult("compliance", True, 0.4, 10.0)
    c.earns, c.earns_by = True, "total excess"
    c.parameters = {"compliance_stiffness_N_per_m": 1e4, "compliance_damping_Ns_per_m": 2e3}
    assert refuse_at_bound(c, _specs("compliance"), CANDIDATES["compliance"], said.append)
    assert not c.earns and c.earns_by == "" and c.at_bound == ["compliance_stiffness_N_per_m"]
    assert "at bound" in said[0] and c.as_dict()["at_bound"] == c.at_bound
    # inside its range it keeps what it earned
    c.earns, c.parameters["compliance_stiffness_N_per_m"] = True, 5e5
    assert not refuse_at_bound(c, _specs("compliance"), CANDIDATES["compliance"])
    assert c.earns and c.at_bound == []
