"""Members nested in one another: a backlash with no gap is a compliance.

A member that contains a simpler one at a limit of its parameters
(:attr:`~.candidates.Candidate.nests`) can earn on what the simpler one explains as well;
the choice between them (:func:`~.evidence.choose_winner`, the lower held-out ΔBIC with
a ln N_eff charge per parameter) is only fair when both were fitted.  The simpler
member's linearised signature may rank it out of the round (a mount spring of 3e5 N/m
scored 0 on its rotor channel while a 6 µm "backlash" with a 3e5 N/m contact earned),
so :func:`nested_to_fit` names the ones a round must re-identify too.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from .candidates import CANDIDATES, compatible
from .impact_verdict import impact_record

__all__ = ["nested_to_fit"]


def nested_to_fit(cands: Mapping[str, Any], scores: Mapping[str, dict],
                  comps: Mapping[str, Any], rig: Any, remaining: Sequence[str]) -> list[str]:
    """The simpler members nested in an earning candidate of ``cands`` (name →
    :class:`~.results.CandidateResult`) that are not fitted yet, applicable
    (``scores``), still ``remaining`` and able to join ``rig`` with their configured
    component (``comps``).  A candidate judged on its impacts is left out: a rattling
    contact is not a series spring, and its sample-wise ΔBIC, which the choice between
    nested members reads, measures chaos."""
    out: list[str] = []
    for name, c in cands.items():
        if not c.earns or impact_record(c.fit) is not None:
            continue
        for m in getattr(CANDIDATES.get(name), "nests", ()):
            cm = cands.get(m)
            if (cm is None or cm.fitted or m in out or m not in remaining
                    or not scores[m]["applicable"] or not compatible(rig, comps[m])):
                continue
            out.append(m)
    return out
