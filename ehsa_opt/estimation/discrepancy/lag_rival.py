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
them earns and accounts for the record member's own channel better, the record member
is not named and the rounds start from the baseline: on the force, a lower held-out
force error than the delay's or the force sensor's; on the voltage, at least the share
of the voltage's SSE excess over noise the voltage sensor removes (a voltage member
leaves the force as it is, so the force error cannot compare it with an effect that
also changes the force).  Those fits are kept in
:attr:`~.search.SearchState.fitted` and the ranking in
:attr:`~.search.SearchState.ranking`, so the first round reuses them instead of
repeating them — and is decided on them even when the deadline has passed before it
starts (what it could not fit is then its stated cut).
"""

from __future__ import annotations

from typing import Callable

from .budget import budget_reached
from .channels import channel_sse
from .judge import choose_winner
from .results import CandidateResult, DiscrepancySettings
from .nested import nested_to_fit
from .search import (SearchState, SearchTests, fitted_ahead, judge_context, judge_round,
                     rank_round)

__all__ = ["lag_rival", "channel_excess_reduction"]


def channel_excess_reduction(tests: SearchTests, state: SearchState,
                             c: CandidateResult, ch: int) -> float:
    """The share of channel ``ch``'s held-out SSE excess over its noise expectation that
    the candidate ``c`` removes against the model of ``state``: 1 − (SSE₁ − N)/(SSE₀ − N)
    (0 when the channel has no excess)."""
    nf = len(tests.fit_pts)
    pred = (c.predictions[nf:] if tests.held_pts else c.predictions[:nf]) \
        if c.predictions else None
    if not pred:
        return 0.0
    s0, n = channel_sse(tests.eval_pts, state.eval_pred())
    s1, _ = channel_sse(tests.eval_pts, pred)
    if ch >= len(n) or not s0[ch] > n[ch]:
        return 0.0
    return float(1.0 - (s1[ch] - n[ch]) / (s0[ch] - n[ch]))


def lag_rival(tests: SearchTests, state: SearchState, settings: DiscrepancySettings,
              beats: Callable[[CandidateResult], bool], say: Callable[[str], None],
              notes: list[str], name: str = "force_lag") -> CandidateResult | None:
    """The member the first round would add (:func:`~.judge.choose_winner` among the
    earning ones of its re-identification on the record as it is, the simpler members
    nested in them included: :func:`~.nested.nested_to_fit`), when it accounts for the
    record member's channel better (``beats``: the comparison on that channel, see the
    module docstring); else None.  ``state`` is the baseline's (not changed, except that
    the member fits are stored in ``state.fitted`` for the first round to reuse, and
    ``state.cut`` says so when the time budget cut them).  ``name``: the record member,
    for the messages."""
    if budget_reached():
        return None
    rk = rank_round(tests, state, settings)
    if not rk.chosen:
        return None
    say(f"{name}: the members the first round would re-identify ("
        + ", ".join(rk.chosen) + f") fitted on the record as it is, against {name}")
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
    if best is None or not beats(best):
        return None  # the record member is named on this check (a cut of it stays stated)
    # the first round starts from this model: it reuses this ranking and these fits,
    # fits what was left and states its own cut, if any
    state.ranking, state.cut = (state.rig, list(state.remaining), rk), cut
    return best
