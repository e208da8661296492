"""Members nested in one another: a backlash with no gap is a compliance.

A member that contains a simpler one at a limit of its parameters
(:attr:`~.candidates.Candidate.nests`) can earn on what the simpler one explains as well;
the choice between them (:func:`~.judge.choose_winner`, the lower held-out ΔBIC with
a ln N_eff charge per parameter) is only fair when both were fitted.  The simpler
member's linearised signature may rank it out of the round (a mount spring of 3e5 N/m
scored 0 on its rotor channel while a 6 µm "backlash" with a 3e5 N/m contact earned),
so :func:`nested_to_fit` names the ones a round must re-identify too.

When both earn, the richer member is added only when its extra parameters show
evidence of their own (:func:`prefer_nested`): a 1 µm "gap" with a 3e5 N/m contact beat
the 3e5 N/m mount spring it stands for by 0.5 in held-out ΔBIC (−1902.9 against
−1902.4), less than the criterion's ``nested_evidence``, and the simpler member is named.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

from .candidates import CANDIDATES, compatible
from .criterion import DEFAULT_CRITERION
from .impact_verdict import impact_record

__all__ = ["nested_to_fit", "nested_in", "nested_ahead", "prefer_nested"]



def nested_to_fit(cands: Mapping[str, Any], scores: Mapping[str, dict],
                  comps: Mapping[str, Any], rig: Any, remaining: Sequence[str]) -> list[str]:
    """The simpler members nested in an earning candidate of ``cands`` (name →
    :class:`~.results.CandidateResult`) that are not fitted yet, applicable
    (``scores``), still ``remaining`` and able to join ``rig`` with their configured
    component (``comps``).  A candidate judged on its impacts is left out: a rattling
    contact is not a series spring, and its sample-wise ΔBIC, which the choice between
    nested members reads, measures chaos."""
    return nested_in([name for name, c in cands.items()
                      if c.earns and impact_record(c.fit) is None],
                     scores, comps, rig, remaining,
                     fitted=[name for name, c in cands.items() if c.fitted])


def nested_in(names: Sequence[str], scores: Mapping[str, dict], comps: Mapping[str, Any],
              rig: Any, remaining: Sequence[str], fitted: Sequence[str] = ()) -> list[str]:
    """The simpler members nested in the members ``names`` (in their order), other than
    ``names`` and ``fitted``, applicable (``scores``), still ``remaining`` and able to
    join ``rig`` with their configured component (``comps``): what a round asks for
    when one of ``names`` earns (:func:`nested_to_fit`), and so what it may fit ahead
    (:mod:`.idle_fits`)."""
    out: list[str] = []
    for name in names:
        for m in getattr(CANDIDATES.get(name), "nests", ()):
            if (m in out or m in names or m in fitted or m not in remaining
                    or m not in scores or not scores[m]["applicable"]
                    or m not in comps or not compatible(rig, comps[m])):
                continue
            out.append(m)
    return out


def nested_ahead(names: Sequence[str], scores: Mapping[str, dict], comps: Mapping[str, Any],
                 rig: Any, remaining: Sequence[str]) -> list[str]:
    """The simpler members nested in the members ``names`` that a round may still ask
    for (:func:`nested_to_fit`), for fitting ahead on an idle worker (:mod:`.idle_fits`):
    :func:`nested_in` of those ``names`` that the ranking does not send to the
    impact-aware fit (``scores[name]["impacts"]``: the data's transient energy exceeds
    the current model's by the ratio that routes a contact to its impacts).  A member
    judged on its impacts never has its nested members fitted (a rattling contact is
    not a series spring; :func:`nested_to_fit`), so such a fit made ahead would only
    take a core from the contact's own fit — on a loaded machine, a third of it.  The
    answer does not depend on it: a member asked for and not fitted ahead is fitted
    when asked."""
    return nested_in([n for n in names if not (scores.get(n) or {}).get("impacts")],
                     scores, comps, rig, remaining)


def prefer_nested(win: Any, cands: Mapping[str, Any], say: Any = None,
                  nested_evidence: float = DEFAULT_CRITERION.nested_evidence) -> Any:
    """The round's winner, or the simpler member nested in it (name →
    :class:`~.results.CandidateResult` in ``cands``) when that one earns too and the
    winner's held-out ΔBIC is not lower than its by the criterion's ``nested_evidence`` — its extra
    parameters (a gap beside the contact's stiffness) are then not shown by the data.
    Of several such nested members, the one with the lowest held-out ΔBIC.

    The two are compared on every channel (``delta_bic_heldout``), not each on its own
    channel as :func:`~.judge.choose_winner` compares different effects: they are one
    physics, the simpler the richer at a limit, and a channel told apart by each one's
    linearised signature (the gap's force, the spring's voltage) would compare
    −1951.5 on the one against −1863.4 on the other for fits alike on both."""
    simpler = [cands[m] for m in getattr(CANDIDATES.get(win.effect), "nests", ())
               if m in cands and cands[m].earns and not getattr(cands[m], "at_bound", ())]
    close = []
    for c in simpler:
        d_simple, d_win = float(c.delta_bic_heldout), float(win.delta_bic_heldout)
        if math.isfinite(d_simple) and math.isfinite(d_win) \
                and d_simple - d_win < nested_evidence:
            close.append(c)
    if not close:
        return win
    best = min(close, key=lambda c: c.delta_bic_heldout)
    if say is not None:
        w, b = best.delta_bic_heldout, win.delta_bic_heldout
        say(f"{best.effect} is nested in {win.effect} and earns too: {win.effect}'s held-out "
            f"ΔBIC {b:.1f} against {w:.1f} is not lower by {nested_evidence:g} — no evidence "
            f"for its extra parameters; {best.effect} is added")
    return best
