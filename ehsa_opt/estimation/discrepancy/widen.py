"""Widening a round and looking ahead through a confounded candidate.

When the best earning candidate of a round explains little of the excess
(:func:`should_widen`), the round re-identifies the remaining applicable members too
and looks ahead through the confounded one (:mod:`.lookahead`) before deciding
(:func:`widen_round`, called by :func:`~.search.run_rounds` for each round).
"""

from __future__ import annotations

import math
import time
from typing import Any, Callable, Sequence

from .candidates import MIN_RANK_VALUE, compatible, rank_value
from .budget import cut_reason, elapsed_s
from .criterion import DEFAULT_POLICY, Criterion
from .judge import can_earn, choose_winner
from .impacts import impact_record
from .lookahead import (confounded, confounded_first, first_step_pool, fit_on_top,
                        lookahead_winner, not_judged, on_top_args, prefetch_on_top,
                        second_steps, supported)
from .results import CandidateResult

__all__ = ["widen_round", "widen_candidates", "should_widen", "WIDEN_BELOW"]


#: When the best earning candidate of a round removes less than this share of the
#: held-out force error's excess over the noise floor, the round re-identifies every
#: remaining applicable candidate before deciding (see :func:`should_widen`).
WIDEN_BELOW = DEFAULT_POLICY.widen_below


def should_widen(earning: Sequence[Any], force_excess: bool = True,
                 min_excess_reduction: float = 0.0) -> bool:
    """Whether to re-identify the remaining lower-ranked candidates before deciding.

    True when some candidate earns but the best earning one removes less than
    :data:`WIDEN_BELOW` of the held-out force error's excess over the noise floor
    (when the force has no excess beyond noise, ``force_excess`` False: of the SSE
    alternative's excess — a voltage-seen effect): most of what the model
    misses is then unexplained by the top-ranked candidates, and the ranking (a
    linearised score on the fit tests) may have put the effect that explains it
    below ``top`` — a 12-per-rev cogging beside a 0.1 mm gap ranked 5th, the gap's
    refit absorbed the ripple on the fit tests and failed on the held-out ones, and
    a compliance earning 11 % of the excess took the only transmission slot.

    Parameters
    ----------
    earning : sequence of CandidateResult
        The earning candidates of the round (``excess_reduction`` set; an optional
        ``sse_reduction`` attribute holds the SSE alternative's share).
    force_excess : bool
        Whether the force error's excess over the noise floor is beyond noise
        (:func:`~.judge.can_earn` on the force alone).  Then the force gain decides
        alone: a compliance beside a gap plus a cogging removed 11 % of the force
        excess but more than half of the voltage channel's, and the round was not
        widened.
    """
    if not earning:
        return False
    gains = []
    for c in earning:
        g = c.excess_reduction if math.isfinite(c.excess_reduction) else -math.inf
        s = getattr(c, "sse_reduction", None)
        use_sse = not force_excess and s is not None and math.isfinite(s)
        gains.append(max(g, s) if use_sse else g)
    return max(gains) < max(WIDEN_BELOW, min_excess_reduction)


def widen_candidates(rk: Any, state: Any) -> list[str]:
    """The members a widened round re-identifies besides its chosen ones (``rk``, a
    :class:`~.search.RoundRanking` of ``state``'s model): the other applicable ones
    ranked at or above :data:`~.candidates.MIN_RANK_VALUE` that can join its rig, in
    rank order."""
    return [n for n in rk.order if n not in rk.chosen and rk.scores[n]["applicable"]
            and n != "flexibility" and compatible(state.rig, rk.comps[n])
            and rank_value(rk.scores[n]) >= MIN_RANK_VALUE]


def widen_round(rnd: int, rk: Any, tests: Any, state: Any, settings: Any, judge: dict,
                say, refit: Callable[[list], None]
                ) -> tuple[list, CandidateResult | None, CandidateResult | None]:
    """When the best earning candidate explains little (:func:`should_widen`),
    re-identify the remaining applicable ones too, and look ahead through the
    confounded candidate (:func:`lookahead_winner`, :func:`confounded_first`).
    Returns the earning candidates, the first step of a look-ahead path (or None)
    and the confounded candidate (or None).  ``rk``, ``tests``, ``state``: the round's
    :class:`~.search.RoundRanking`, :class:`~.search.SearchTests` and
    :class:`~.search.SearchState`; ``refit(names)`` re-identifies and judges members
    in the round (:func:`~.search.judge_round`)."""
    cands, order = rk.cands, rk.order
    earning = [c for c in cands.values() if c.earns]
    first = blocked = None
    crit: Criterion = settings.criterion
    if state.cut or not should_widen(earning, can_earn(state.error, tests.floor, 0.0, 1.0, crit),
                                     crit.min_excess_reduction):
        return earning, first, blocked
    if any(impact_record(c.fit) is not None for c in earning):
        # a rattling contact earned on its impacts: the sample-wise share of the excess
        # it removes measures the chaos, not what is left unexplained
        return earning, first, blocked
    more = widen_candidates(rk, state)
    if not more:
        return earning, first, blocked
    best = max(earning, key=lambda c: c.excess_reduction)
    say(f"round {rnd}: the best earning candidate ({best.effect}) removes only "
        f"{100 * best.excess_reduction:.0f} % of the excess (< "
        f"{100 * WIDEN_BELOW:.0f} %): also re-identifying {', '.join(more)}")
    refit(more)
    earning = [c for c in cands.values() if c.earns]
    blocked = confounded(list(cands.values()))
    if blocked is None or state.cut:  # no look-ahead path after the time budget
        blocked = None
        return earning, first, blocked
    cuts: list[str] = []  # look-ahead fits cut by the time budget, or not started
    t0 = time.perf_counter()
    steps1 = [c for c in cands.values() if supported(c)]
    if settings.jobs > 1:  # the (at most two) first steps' fits side by side
        pairs = [(c, blocked) for c in first_step_pool(earning, steps1) if c is not blocked]
        prefetch_on_top([p for p in pairs if on_top_args(*p, judge, tests.sub_pts,
                                                            settings.max_iter)][:2],
                        judge, tests.sub_pts, settings.max_iter, state.fitted, settings.jobs,
                        state.seconds)
    judged: list[str] = []  # first steps whose joint model with `blocked` was judged
    first = lookahead_winner(
        earning, blocked, lambda c: fit_on_top(c, blocked, judge, tests.sub_pts,
                                               settings.max_iter, rnd, state.fitted, cuts,
                                               state.seconds, settings.jobs),
        say, first_steps=steps1, judged=judged)
    # the second steps: what a round after `blocked` would re-identify, ranked on the
    # residual of the model with it (not among the members this round happened to fit),
    # less those whose model with it the forward paths already judged
    others = [] if first is not None else not_judged(second_steps(
        blocked, [n for n in state.remaining if n != "flexibility"], tests.fit_pts,
        tests.sub_pts, tests.lead_m_per_rad, say, settings.jobs), judged, blocked, say)
    if first is None and settings.jobs > 1:
        prefetch_on_top([(blocked, c) for c in others[:settings.jobs]], judge, tests.sub_pts,
                        settings.max_iter, state.fitted, settings.jobs, state.seconds)
    if first is None and confounded_first(
            blocked, others,
            lambda c: fit_on_top(blocked, c, judge, tests.sub_pts, settings.max_iter, rnd,
                                 state.fitted, cuts, state.seconds, settings.jobs),
            state.error, tests.floor,
            choose_winner(earning).sse_heldout if earning else math.inf, say,
            criterion=settings.criterion):
        first = blocked
    say(f"round {rnd}: look-ahead through {blocked.effect} in "
        f"{time.perf_counter() - t0:.1f} s ({elapsed_s():.0f} s into the run)")
    if cuts:
        state.cut = (f"{cut_reason()} in the look-ahead of "
                     f"round {rnd}: {'; '.join(cuts)} not fitted (the path is work left); "
                     f"the round is decided without those paths")
        say(state.cut)
    return earning, first, blocked
