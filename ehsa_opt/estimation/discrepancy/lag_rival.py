"""A delay of the force record against the members whose physics delays the force.

A mount spring with the rig's reflected mass (a second-order lag well above the test
frequencies) delays the measured force by a group delay that is nearly the same on
every test, so the ``force_lag`` member (:mod:`.candidates.force_lag`, tried before the
rounds) can earn on a compliance campaign: on a mixed campaign of the second generator
with a 3e5 N/m mount, an 11 ms delay removed 20 % of the excess, was named, and the
re-aligned record no longer showed the compliance (a 6 µm backlash was named next).

A delay of the record is a property of the acquisition, not of the physics; a member
that explains the same residual better *without* re-aligning anything is the simpler
account.  So before the delay is named, the members the first round would re-identify
(:func:`~.search.rank_round`, the same ranking and settings) are fitted on the record
as it is and judged by the same rule (:func:`~.search.judge_round`); when one of
them earns and leaves a lower held-out force error than the delay's, the delay is not
named and the rounds start from the baseline.  Those fits are kept in
:attr:`~.search.SearchState.fitted` and the ranking in
:attr:`~.search.SearchState.ranking`, so the first round reuses them instead of
repeating them — and is decided on them even when the deadline has passed before it
starts (what it could not fit is then its stated cut).
"""

from __future__ import annotations

from typing import Callable

from .budget import budget_reached
from .judge import choose_winner
from .results import CandidateResult, DiscrepancySettings
from .nested import nested_to_fit
from .search import (SearchState, SearchTests, fitted_ahead, judge_context, judge_round,
                     rank_round)

__all__ = ["lag_rival"]


def lag_rival(tests: SearchTests, state: SearchState, settings: DiscrepancySettings,
              lag_error: float, say: Callable[[str], None], notes: list[str]
              ) -> CandidateResult | None:
    """The member the first round would add (:func:`~.judge.choose_winner` among the
    earning ones of its re-identification on the record as it is, the simpler members
    nested in them included: :func:`~.nested.nested_to_fit`), when it leaves a lower
    held-out force error (%) than ``lag_error`` (the delay's); else None.  ``state`` is
    the baseline's (not changed, except that the member fits are stored in
    ``state.fitted`` for the first round to reuse, and ``state.cut`` says so when the
    time budget cut them)."""
    if budget_reached():
        return None
    rk = rank_round(tests, state, settings)
    if not rk.chosen:
        return None
    say("force_lag: the members the first round would re-identify ("
        + ", ".join(rk.chosen) + ") fitted on the record as it is, against the delay")
    judge = judge_context(1, tests, state, rk, say, notes, settings.criterion)
    if judge is None:
        return None
    cut = state.cut
    judge_round(rk, rk.chosen, tests, state, settings, judge, keep=True,
                spare=fitted_ahead(rk, state))
    nested = nested_to_fit(rk.cands, rk.scores, rk.comps, state.rig, state.remaining)
    if nested:  # a compliance when a gap-less backlash earns (a cut when past the deadline)
        judge_round(rk, nested, tests, state, settings, judge, keep=True)
    earning = [c for c in rk.cands.values() if c.earns]
    best = choose_winner(earning) if earning else None
    if best is None or not best.error_after < lag_error:
        return None  # the delay is named on this check (a cut of it stays stated)
    # the first round starts from this model: it reuses this ranking and these fits,
    # fits what was left and states its own cut, if any
    state.ranking, state.cut = (state.rig, list(state.remaining), rk), cut
    return best
