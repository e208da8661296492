"""Nested members: when a backlash earns, its gap-less limit (a compliance) is
re-identified in the same round whatever its rank, unless the backlash earned on its
impacts or the compliance is fitted, named or cannot join the model."""

from ehsa_opt.estimation.discrepancy import nested as nested_mod
from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES
from ehsa_opt.estimation.discrepancy.nested import nested_to_fit
from ehsa_opt.estimation.discrepancy.results import CandidateResult


class _Fit:
    def __init__(self, starts=()):
        self.starts = list(starts)


def _cands(backlash_earns=True, compliance_fitted=False, impacts=False):
    b = CandidateResult("backlash", True, 0.03, 1.0, 1)
    b.earns, b.fitted = backlash_earns, True
    b.fit = _Fit([{"impact_fit": {"contact_exponent": 1.5}}] if impacts else [])
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
