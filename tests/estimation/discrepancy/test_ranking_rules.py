"""The rules that keep a surrogate member from being named: a member fitted on the edge
of its physical range does not earn; the ranking and the winner follow the channel that
sees the effect."""

import math
from types import SimpleNamespace as NS

import pytest

from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES
from ehsa_opt.estimation.discrepancy.bounds import at_bound
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
    from ehsa_opt.estimation.discrepancy.bounds import at_bound_names
    from ehsa_opt.estimation.discrepancy.judge import refuse_at_bound
    from ehsa_opt.estimation.discrepancy.results import CandidateResult
    said = []
    c = CandidateResult("compliance", True, 0.4, 10.0)
    c.earns, c.earns_by = True, "total excess"
    c.parameters = {"compliance_stiffness_N_per_m": 1e4, "compliance_damping_Ns_per_m": 2e3}
    at_bound_names(c, _specs("compliance"), CANDIDATES["compliance"], said.append)
    assert refuse_at_bound(c, said.append)
    assert not c.earns and c.earns_by == "" and c.at_bound == ["compliance_stiffness_N_per_m"]
    assert "at bound" in said[0] and c.as_dict()["at_bound"] == c.at_bound
    # inside its range it keeps what it earned
    c.earns, c.parameters["compliance_stiffness_N_per_m"] = True, 5e5
    at_bound_names(c, _specs("compliance"), CANDIDATES["compliance"])
    assert not refuse_at_bound(c)
    assert c.earns and c.at_bound == []


def _stacked(n=2000, seed=0):
    """A stacked, noise-normalised residual: a force misfit (a presliding-like hump at
    each reversal, 8 sigma, and a ripple no member explains) and a voltage offset with
    the current's sign (a diode drop, 2 sigma), each channel n samples, plus unit noise."""
    import numpy as np
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 4, n)
    v = np.sin(2 * np.pi * t)
    hump = 8 * np.sign(v) * np.exp(-np.abs(np.sin(2 * np.pi * t)) * 3)
    drop = -2 * np.sign(v)
    r = np.concatenate([hump + 6 * np.sin(14 * np.pi * t), drop]) + rng.normal(size=2 * n)
    chan = np.repeat([0, 1], n)
    return r, chan, hump, drop, v


def test_a_voltage_only_signature_ranks_above_a_force_member():
    import numpy as np

    from ehsa_opt.estimation.discrepancy.candidates.catalogue import (
        channel_parts,
        rank_value,
    )
    r, chan, hump, _drop, v = _stacked()
    n = hump.size
    # the voltage member: its signature is the drop on the voltage (and a trace on the force)
    s_v = np.concatenate([0.05 * np.sign(v), -np.sign(v)])[:, None]
    fit_v = s_v @ np.linalg.lstsq(s_v, r, rcond=None)[0]
    # a force member whose columns follow the hump (and move the voltage a little)
    s_f = np.concatenate([hump / 8, 0.1 * np.cos(2 * np.pi * np.linspace(0, 4, n))])[:, None]
    fit_f = s_f @ np.linalg.lstsq(s_f, r, rcond=None)[0]
    total = float(r @ r)
    sc_v = {"score": float(fit_v @ fit_v) / total, **channel_parts(r, fit_v, s_v, chan, 2)}
    sc_f = {"score": float(fit_f @ fit_f) / total, **channel_parts(r, fit_f, s_f, chan, 2)}
    assert sc_v["channel"] == 1 and sc_f["channel"] == 0
    # on the stacked residual the force member scores higher (the hump dominates) ...
    assert sc_f["score"] > sc_v["score"]
    # ... ranked on the channel that sees it, the voltage member comes first
    assert sc_v["channel_shares"][1] > 0.7 and sc_v["channel_excess"][1] > 3
    assert rank_value(sc_v) > rank_value(sc_f) == sc_f["score"]
    # a voltage residual at the noise expectation gives no such lift
    sc_v["channel_excess"] = [sc_v["channel_excess"][0], 0.1]
    assert rank_value(sc_v) == sc_v["score"]


def test_family_probes_are_combined_with_non_negative_weights():
    import numpy as np

    from ehsa_opt.estimation.discrepancy.candidates.catalogue import nnls_weights
    assert CANDIDATES["compliance"].family_probes and CANDIDATES["backlash"].family_probes
    assert not CANDIDATES["cogging"].family_probes
    t = np.linspace(0, 1, 500)
    a, b = np.exp(-t / 0.1), np.exp(-t / 0.12)  # two neighbouring members of a family
    r = a - b  # their difference: no member of the family looks like it
    S = np.column_stack([a, b])
    w_free = np.linalg.lstsq(S, r, rcond=None)[0]
    assert np.allclose(S @ w_free, r)  # unconstrained, the difference is "explained"
    w = nnls_weights(S, r)
    assert np.all(w >= 0)
    explained = 1 - np.sum((r - S @ w) ** 2) / np.sum(r ** 2)
    assert explained < 0.5
    # a member between the probes is still explained by them
    w = nnls_weights(S, 0.4 * a + 0.7 * b)
    assert np.allclose(w, [0.4, 0.7], atol=1e-6)


def test_the_winner_is_chosen_on_its_own_channel_among_physical_members():
    from ehsa_opt.estimation.discrepancy.judge import choose_winner
    # the diode campaign: the drop removes the voltage excess; a compliance trading the
    # force's presliding misfit for the voltage has the lower all-channel ΔBIC
    drop = NS(effect="voltage_drop", delta_bic_heldout=-900.0, sse_heldout=50.0, at_bound=[],
              own_channel=1, channel_dbic=[-10.0, -890.0])
    comp = NS(effect="compliance", delta_bic_heldout=-1500.0, sse_heldout=40.0, at_bound=[],
              own_channel=0, channel_dbic=[-700.0, -800.0])
    assert choose_winner([comp, drop]) is drop
    # without the channels known, the all-channel ΔBIC decides (as before)
    assert choose_winner([NS(**{**comp.__dict__, "own_channel": None}), drop]).effect == \
        "compliance"
    # a member at bound is never preferred to a physical one
    comp.channel_dbic = [-5000.0, -800.0]
    assert choose_winner([comp, drop]) is comp
    comp.at_bound = ["compliance_stiffness_N_per_m"]
    assert choose_winner([comp, drop]) is drop


def test_a_transmission_member_that_worsens_the_voltage_ranks_last():
    from ehsa_opt.estimation.discrepancy.candidates.catalogue import (
        ROTOR_WORSE_SHARE,
        rank_value,
    )
    # the winding-heating campaign: a compliance explains 53 % of the force residual
    # and makes the voltage residual 3.3-fold; the heating explains 27 % of the voltage
    comp = {"score": 0.46, "transmission": True, "channel": 1,
            "channel_shares": [0.53, -2.31], "channel_excess": [205.0, 3.9]}
    heat = {"score": 0.006, "transmission": False, "channel": 1,
            "channel_shares": [0.0, 0.27], "channel_excess": [205.0, 3.9]}
    assert rank_value(comp) == 0.0 < rank_value(heat) == 0.27
    # a gap that explains both channels keeps its score
    gap = {**comp, "channel_shares": [0.53, 0.2], "channel": 0}
    assert rank_value(gap) == 0.46
    # the same voltage loss is no reason to demote a member that is not a transmission
    assert rank_value({**comp, "transmission": False}) == 0.46
    comp["channel_shares"] = [0.53, -0.5 * ROTOR_WORSE_SHARE]
    assert rank_value(comp) == 0.46


def test_impacts_rank_the_contact_member_first():
    import numpy as np

    from ehsa_opt.estimation.discrepancy.candidates.catalogue import rank_value
    from ehsa_opt.estimation.discrepancy.impact_features import impact_energy_ratio
    from ehsa_opt.estimation.discrepancy.impacts import IMPACT_ENERGY_RATIO

    class _PT:  # what the transient energies read
        def __init__(self, y):
            self.y, self.sigma, self.weight = y, np.array([1.0, 0.02]), np.ones(y.shape[1])
    t = np.arange(4000) * 1e-3
    smooth = np.vstack([100 * np.sin(2 * np.pi * t), 3 * np.sin(2 * np.pi * t)])
    hits = smooth.copy()
    for k in range(250, 4000, 500):  # a decaying 300 Hz ringing at each reversal
        j = np.arange(k, min(k + 60, 4000))
        hits[0, j] += 800 * np.exp(-(j - k) / 10) * np.sin(2 * np.pi * 300 * t[j - k])
    assert impact_energy_ratio([_PT(hits)], [smooth]) > IMPACT_ENERGY_RATIO
    assert impact_energy_ratio([_PT(smooth + 0.0)], [smooth]) < 3
    gap = {"score": 0.003, "impacts": 523.0, "transmission": True,
           "channel_shares": [0.0, -0.5], "channel": 0, "channel_excess": [1900, 420]}
    comp = {"score": 0.019, "transmission": True, "channel": 1,
            "channel_shares": [0.001, 0.03], "channel_excess": [1900, 420]}
    assert rank_value(gap) > 1.0 > rank_value(comp)


def test_a_family_fitted_on_its_edge_probe_ranks_as_at_bound():
    from ehsa_opt.estimation.discrepancy.candidates.catalogue import (
        MIN_RANK_VALUE,
        edge_dominated,
        rank_value,
    )
    comp = CANDIDATES["compliance"]
    edges = [bool(at_bound(p, _specs("compliance"), comp.limits)) for p in comp.probes]
    assert edges == [True, False, False, False, False]  # the 1e4 N/m probe
    # the diode campaign: 90 % of the fitted signature from the 1e4 N/m probe
    assert edge_dominated([3487.0, 0.0, 101.0, 283.0, 19.0], edges)
    # a 5e5 N/m mount spreads over the decades
    assert not edge_dominated([639.0, 889.0, 0.0, 566.0, 809.0], edges)
    assert not edge_dominated([0.0] * 5, edges)
    sc = {"score": 0.42, "at_bound": True, "transmission": True, "channel": 1,
          "channel_shares": [0.07, 0.45], "channel_excess": [160.0, 2670.0]}
    assert rank_value(sc) == 0.0 < MIN_RANK_VALUE  # not re-identified
    assert rank_value({**sc, "at_bound": False}) == 0.45
