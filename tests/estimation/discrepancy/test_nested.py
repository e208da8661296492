"""Nested members: when a backlash earns, its gap-less limit (a compliance) is
re-identified in the same round whatever its rank, unless the backlash earned on its
impacts or the compliance is fitted, named or cannot join the model."""

from ehsa_opt.estimation.discrepancy import nested as nested_mod
from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES
from ehsa_opt.estimation.discrepancy.nested import nested_to_fit
from ehsa_opt.estimation.discrepancy.results import CandidateResult


class _Fit:
    def __init__(self, records=None):
        self.records = dict(records or {})


def _cands(backlash_earns=True, compliance_fitted=False, impacts=False):
    b = CandidateResult("backlash", True, 0.03, 1.0, 1)
    b.earns, b.fitted = backlash_earns, True
    b.fit = _Fit({"impact_fit": {"contact_exponent": 1.5}} if impacts else None)
    c = CandidateResult("compliance", True, 0.0, 0.0, 1)
    c.fitted = compliance_fitted
    cog = CandidateResult("cogging", True, 0.02, 1.0, 1)
    cog.earns, cog.fitted, cog.fit = True, True, _Fit()
    return {"backlash": b, "compliance": c, "cogging": cog}


def test_compliance_is_fitted_when_a_backlash_earns(monkeypatch):
    assert CANDIDATES["backlash"].nests == ("compliance",)
    scores = {n: {"applicable": True} for n in ("backlash", "compliance", "cogging")}
    comps = {n: CANDIDATES[n].component() for n in scores}
    remaining = ["backlash", "compliance", "cogging"]
    monkeypatch.setattr(nested_mod, "compatible", lambda rig, comp: True)
    assert nested_to_fit(_cands(), scores, comps, None, remaining) == ["compliance"]
    assert nested_to_fit(_cands(backlash_earns=False), scores, comps, None, remaining) == []
    assert nested_to_fit(_cands(impacts=True), scores, comps, None, remaining) == []
    assert nested_to_fit(_cands(compliance_fitted=True), scores, comps, None, remaining) == []
    assert nested_to_fit(_cands(), scores, comps, None, ["backlash", "cogging"]) == []
    monkeypatch.setattr(nested_mod, "compatible", lambda rig, comp: False)
    assert nested_to_fit(_cands(), scores, comps, None, remaining) == []


def test_the_simpler_nested_member_is_added_when_the_richer_shows_no_evidence_more():
    """A 1 µm gap with a 3e5 N/m contact beat the mount spring it stands for by 0.5 in
    held-out ΔBIC: the spring is added.  By 2 or more (the gap's parameters shown by the
    data) the backlash stays; a spring that does not earn, or another member, is no
    alternative."""
    from types import SimpleNamespace as NS

    from ehsa_opt.estimation.discrepancy.criterion import DEFAULT_CRITERION
    from ehsa_opt.estimation.discrepancy.nested import prefer_nested
    NESTED_EVIDENCE = DEFAULT_CRITERION.nested_evidence

    def cand(effect, dbic, earns=True):
        return NS(effect=effect, earns=earns, delta_bic_heldout=dbic, at_bound=[],
                  own_channel=None, channel_dbic=None)
    gap, spring = cand("backlash", -1902.9), cand("compliance", -1902.4)
    said = []
    assert prefer_nested(gap, {"backlash": gap, "compliance": spring}, said.append) is spring
    assert said and "compliance is added" in said[0]
    gap.delta_bic_heldout = spring.delta_bic_heldout - NESTED_EVIDENCE - 0.1
    assert prefer_nested(gap, {"backlash": gap, "compliance": spring}) is gap
    gap.delta_bic_heldout = -1902.9
    spring.earns = False
    assert prefer_nested(gap, {"backlash": gap, "compliance": spring}) is gap
    cog = cand("cogging", -1902.0)  # nests nothing
    assert prefer_nested(cog, {"cogging": cog, "compliance": cand("compliance", -1902.4)}) is cog
    # compared on every channel, not each on its own (the gap's force channel against
    # the spring's voltage channel would favour the gap by 88)
    spring.earns = True
    gap.own_channel, spring.own_channel = 0, 1
    gap.channel_dbic = [-1951.5, -1863.4]
    spring.channel_dbic = [-1950.2, -1863.4]
    assert prefer_nested(gap, {"backlash": gap, "compliance": spring}) is spring


def test_members_nested_in_the_chosen_ones_are_what_a_round_may_fit_ahead():
    from ehsa_opt.estimation.discrepancy import CANDIDATES, Rig
    from ehsa_opt.estimation.discrepancy.nested import nested_in
    from ehsa_opt.physics.params import HarvesterParams

    names = ["backlash", "cogging", "compliance"]
    scores = {n: {"applicable": True} for n in names}
    comps = {n: CANDIDATES[n].component() for n in names}
    rig = Rig(HarvesterParams(), True, ())
    assert nested_in(["backlash", "cogging"], scores, comps, rig, names) == ["compliance"]
    assert nested_in(["cogging"], scores, comps, rig, names) == []
    assert nested_in(["backlash"], scores, comps, rig, names, fitted=["compliance"]) == []
    assert nested_in(["backlash", "compliance"], scores, comps, rig, names) == []  # chosen
    assert nested_in(["backlash"], scores, comps, rig, ["backlash"]) == []  # not remaining
    # a spring cannot join a rig that already has a transmission member
    with_gap = Rig(HarvesterParams(), True, (comps["backlash"],))
    assert nested_in(["backlash"], scores, comps, with_gap, names) == []


def test_a_contact_ranked_on_its_impacts_has_no_nested_member_fitted_ahead():
    """The ranking that routes a backlash to the impact-aware fit (its ``impacts`` ratio)
    says its nested spring will never be asked for (``nested_to_fit`` leaves out a
    member judged on impacts): it is not fitted ahead beside the contact's own fit."""
    from ehsa_opt.estimation.discrepancy import CANDIDATES, Rig
    from ehsa_opt.estimation.discrepancy.nested import nested_ahead
    from ehsa_opt.physics.params import HarvesterParams

    names = ["backlash", "cogging", "compliance"]
    comps = {n: CANDIDATES[n].component() for n in names}
    rig = Rig(HarvesterParams(), True, ())
    scores = {n: {"applicable": True, "impacts": None} for n in names}
    assert nested_ahead(["backlash"], scores, comps, rig, names) == ["compliance"]
    scores["backlash"]["impacts"] = 523.0
    assert nested_ahead(["backlash"], scores, comps, rig, names) == []
    assert nested_ahead(["backlash", "cogging"], scores, comps, rig, names) == []
    # and the round's own rule agrees: a backlash judged on impacts asks for no spring
    cands = _cands(impacts=True)
    assert nested_to_fit(cands, {n: {"applicable": True} for n in names}, comps, rig,
                         names) == []
