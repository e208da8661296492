"""The member protocol: what every member of the discrepancy engine provides, and the
one loop that offers the members that act on the record or on the friction law.

A *member* is anything the engine can name: an effect of the rig (a component of the
bench model: backlash, compliance, cogging …), a transform of a measurement channel
(a delay or the dynamics of the force sensor, a skew of the voltage record, the
drive's lag) or a variant of the friction law (a presliding transition).  Every member
answers the same questions:

* :meth:`Member.applicable` — can it be tried on this campaign and model (its rig has
  the channel, the setting lists it, a rival has not already taken its place)?  The
  answer is a reason when it is not, said in the report.
* rank — how much of the current residual its signature explains before any fit: the
  catalogue effects' signature scores (:mod:`..candidates.catalogue`), which order the
  rounds; a record or law member has no rank — it is offered in the declared order and
  screens itself inside its fit (a delay's shift alone, a filter on the model's force).
* :meth:`Member.fit` — its parameters, fitted on the fit tests, and its *evidence*:
  the error before and after on the evaluation tests, ΔBIC on the fit and
  evaluation tests, whether its size is resolved, its own statistics.  A member never
  decides: :func:`~..judge.judge_attempt` does, by the run's
  :class:`~..criterion.Criterion`.
* :meth:`Member.adopt` — the model (and, for a record member, the record) from then on,
  once it earned.

The catalogue effects are ranked together by their signature scores and fitted in the
forward-selection rounds (:mod:`..search`); the record and law members here are offered
before the rounds, in the order of :data:`~.RECORD_MEMBERS`, grouped by the channel
they describe: the members of one channel are rivals — each is fitted and judged, and
of those that earn the judge keeps one (:func:`~..judge.choose_rival`: the simpler
unless the richer's held-out ΔBIC is lower by the criterion's ``nested_evidence``; a
delay is the limit of a sensor's dynamics).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Sequence

from ..baseline import Baseline
from ..budget import budget_reached, cut_reason
from ..judge import choose_rival, judge_attempt
from ..results import DiscrepancySettings
from ..search import SearchState, SearchTests

__all__ = ["Member", "Attempt", "Context", "run_members"]


@dataclass
class Context:
    """What a member sees and changes: the tests of the search (changed in place by a
    record member), the base model, the search's current state, the run's settings,
    the progress messages (``say``), the report's notes, every member result so far
    (``results``: :class:`~..results.CandidateResult` objects) and what the record and
    law members found."""

    tests: SearchTests
    base: Baseline
    state: SearchState
    settings: DiscrepancySettings
    say: Callable[[str], None]
    notes: list[str]
    results: list
    #: the voltage record's skew check (:class:`~..voltage_skew.VoltageSkew`), once made
    skew: Any = None
    #: the base friction law's presliding transition (:class:`~..presliding.PreslidingLaw`)
    law: Any = None


@dataclass
class Attempt:
    """One member's fit and its evidence, before and after the judge's verdict.

    Attributes
    ----------
    member : str
        The member's name.
    error_before, error_after : float
        Relative force error on the evaluation tests without / with the member, %.
    delta_bic_fit, delta_bic_heldout : float
        ΔBIC of the member (its parameters charged) on the fit and evaluation tests.
    n_parameters : int
        Its number of parameters (the nesting order between rivals).
    resolved : bool
        Its size is resolved (an interval excludes the member's absence).
    fields : dict
        Its :class:`~..results.CandidateResult` fields (None: the member is reported
        in the notes only).
    change : object
        What :meth:`Member.adopt` applies (the changed record, a law).
    message : str
        The evidence in words.
    earns : bool
        The verdict (written by :func:`~..judge.judge_attempt` alone).
    decided_by : str
        ``"earns"`` (the decision rule on the force) or the name of the member's own
        criterion the judge applies (the voltage skew's).
    evidence : dict
        The member's own statistics (e.g. the voltage skew's spread and share).
    sse_excess_reduction : float or None
        For a member seen in the voltage: the share of that channel's SSE excess over
        noise it removes (the decision rule's other-channel route), with ``n_force`` the
        evaluation tests' force samples (the force must not grow beyond what they
        resolve).
    """

    member: str
    error_before: float = math.nan
    error_after: float = math.nan
    delta_bic_fit: float = math.nan
    delta_bic_heldout: float = math.nan
    n_parameters: int = 1
    resolved: bool = True
    fields: dict | None = None
    change: Any = None
    message: str = ""
    earns: bool = False
    earns_by: str = ""
    decided_by: str = "earns"
    evidence: dict = field(default_factory=dict)
    sse_excess_reduction: float | None = None
    n_force: int | None = None


class Member(ABC):
    """A member of the discrepancy engine (see the module docstring).

    Class attributes
    ----------------
    name : str
        The name the answer uses.
    kind : str
        ``"record"`` (it changes the record the search judges on), ``"law"`` (every
        model judged carries it) or ``"effect"`` (a component of the bench model).
    channel : str
        What it describes (``"force record"``, ``"voltage record"``, ``"drive"``,
        ``"friction law"``): the members of one channel are rivals.
    setting : str or None
        The :attr:`~..results.DiscrepancySettings.candidates` name that lists it (None:
        it has its own switch).
    refits : bool
        Its fit refits the base model (a collocation fit): not started once the work
        budget is spent.  False for a member measured on the current model's outputs
        alone (a linear or shift search).
    offered_after_rounds : bool
        Not adopted before the rounds, it is offered once more on the model the rounds
        reached (its evidence can be hidden under an effect's larger misfit: a friction
        drift under a cogging's ripple).  False for a member judged on the base model by
        its definition (the base law's presliding transition).
    """

    name: ClassVar[str]
    kind: ClassVar[str]
    channel: ClassVar[str]
    setting: ClassVar[str | None] = None
    refits: ClassVar[bool] = True
    offered_after_rounds: ClassVar[bool] = False

    def applicable(self, ctx: Context) -> str:
        """"" when the member can be tried; else the reason it is not (said when it is
        not only that the setting leaves it out)."""
        if self.setting is not None and self.setting not in ctx.settings.candidates:
            return "-"
        return ""

    @abstractmethod
    def fit(self, ctx: Context) -> Attempt | None:
        """The member fitted and its evidence (None: nothing to judge, said why)."""

    @abstractmethod
    def adopt(self, attempt: Attempt, ctx: Context) -> None:
        """Apply an earning attempt to ``ctx`` (state, tests, base model)."""

    def confirm(self, attempt: Attempt, ctx: Context) -> bool:
        """A last check before adoption (a rival account by the catalogue); True: adopt."""
        return True


def _channels(members: Sequence[Member]) -> list[list[Member]]:
    groups: dict[str, list[Member]] = {}
    for m in members:
        groups.setdefault(m.channel, []).append(m)
    return list(groups.values())


def run_members(members: Sequence[Member], ctx: Context) -> None:
    """Offer ``members`` (record and law members, in order, rivals by channel): each
    applicable one is fitted, the judge decides, and of the earning rivals of a
    channel the one :func:`~..judge.choose_rival` keeps is adopted.  Stops, with the
    cut stated, when the work budget is spent."""
    for group in _channels(members):
        attempts: list[tuple[Member, Attempt]] = []
        for m in group:
            why = m.applicable(ctx)
            if why:
                if why != "-":
                    ctx.say(why)
                    ctx.notes.append(why)
                continue
            if m.refits and budget_reached():
                ctx.state.cut = f"{cut_reason()} before the {m.name} member was tried: " \
                                f"it was not tried"
                ctx.say(ctx.state.cut)
                return
            att = m.fit(ctx)
            if att is None:
                continue
            judge_attempt(att, ctx.tests.floor, ctx.settings.criterion)
            ctx.say(f"{att.message} ({'earns' if att.earns else 'does not earn'})")
            attempts.append((m, att))
        earning = [(m, a) for m, a in attempts if a.earns]
        if not earning:
            continue
        best = choose_rival([a for _, a in earning], ctx.settings.criterion)
        m = next(m for m, a in earning if a is best)
        for other, a in earning:
            if a is not best:
                note = (f"{other.name}: earns, but {m.name} describes the "
                        f"{m.channel} as well with "
                        + ("fewer parameters" if best.n_parameters < a.n_parameters else
                           f"a held-out ΔBIC lower by {a.delta_bic_heldout - best.delta_bic_heldout:.1f}"))
                ctx.say(note)
                ctx.notes.append(note)
        if m.confirm(best, ctx):
            m.adopt(best, ctx)
