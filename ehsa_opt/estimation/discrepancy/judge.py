"""The verdicts of the discrepancy search, by one :class:`~.criterion.Criterion`: the only
module that decides whether a model change *earns* (and writes it).

* the rule: :func:`excess_reduction` (the share of the error above the noise floor a
  change removes), :func:`earns` (that share reaches ``criterion.min_excess_reduction``
  and ΔBIC < ``criterion.dbic_max`` on the fit and the evaluation tests; for an effect
  seen in another channel, the same share of that channel's SSE excess), its routes
  :func:`earns_on_own_channel` (a generator member on the voltage) and
  :func:`own_evidence` (the median per-block excess reduction), and :func:`can_earn`
  (whether any refit could earn from a state), and the refutation of a refit by one
  channel (:func:`refuted_by_channel`);
* the verdict of one re-identified member, :func:`judge_candidate`, of an impact-fitted
  contact (:func:`judge_on_impacts`), of a channel member or term
  (:func:`judge_change`), and the withdrawals (:func:`withdraw`: at a bound, refuted by
  the rotor's channel, not fitted, a rival);
* the choice among earning members, :func:`choose_winner`.

Every verdict is written by :func:`record_verdict`; no other module sets ``earns``.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from .criterion import DEFAULT_CRITERION, Criterion
from .evidence import force_resolution

__all__ = ["excess_reduction", "earns", "earns_on_own_channel", "can_earn",
           "channel_sse_excess_reduction", "sse_can_earn", "own_channel_dbic", "choose_winner",
           "own_evidence", "refuted_by_channel", "refuted_by_rotor_channel", "judge_candidate", "judge_on_impacts",
           "judge_change", "record_verdict", "withdraw", "impact_earns", "refuse_at_bound",
           "judge_attempt", "skew_found", "choose_rival"]


def record_verdict(obj: Any, earns: bool, by: str = "") -> bool:
    """Write the verdict on ``obj`` (a :class:`~.results.CandidateResult`, a term, a
    friction-law proposal, or the field dict a channel member builds its result from):
    ``earns`` and, where it has one, ``earns_by`` (the route it earned by, "" when it
    does not).  Returns the verdict."""
    ok = bool(earns)
    if isinstance(obj, dict):
        obj["earns"], obj["earns_by"] = ok, (by if ok else "")
        return ok
    obj.earns = ok
    if hasattr(obj, "earns_by"):
        obj.earns_by = by if ok else ""
    return ok


def withdraw(c: Any, why: str, say: Any = None) -> None:
    """Withdraw the verdict of ``c`` (it does not earn) and say why."""
    record_verdict(c, False)
    if say is not None and why:
        say(why)


def judge_change(obj: Any, err_before: float, err_after: float, floor: float,
                 dbic_fit: float, dbic_heldout: float, criterion: Criterion = DEFAULT_CRITERION,
                 resolved: bool = True, by: str = "total excess") -> bool:
    """The verdict of a model change that is not a catalogue member's refit (a channel
    member such as a delay of the force record or the drive's lag, the data-driven
    term, a friction-law transition) by :func:`earns` on the force, written on ``obj``;
    ``resolved``: its size is resolved (:func:`~.evidence.significant`)."""
    ok = earns(err_before, err_after, floor, dbic_fit, dbic_heldout, criterion=criterion)
    return record_verdict(obj, ok and resolved, by)


def judge_attempt(att: Any, floor: float, criterion: Criterion = DEFAULT_CRITERION) -> bool:
    """The verdict on a record or law member's attempt
    (:class:`~.members.protocol.Attempt`), written on it and on its result fields: by
    :func:`earns` on the force with its size resolved, or — for the voltage record's
    skew, a change of the voltage channel that leaves the force alone — by
    :func:`skew_found` on its own statistics."""
    if att.decided_by == "voltage skew":
        ok, by = skew_found(att.evidence, criterion), "one delay of the voltage record"
    else:
        ok = earns(att.error_before, att.error_after, floor, att.delta_bic_fit,
                   att.delta_bic_heldout, att.sse_excess_reduction, n_force=att.n_force,
                   criterion=criterion) and bool(att.resolved)
        by = "total excess" if att.sse_excess_reduction is None else "channel SSE"
    if att.fields is not None:
        record_verdict(att.fields, ok, by)
    return record_verdict(att, ok, by)


def skew_found(ev: dict, criterion: Criterion = DEFAULT_CRITERION) -> bool:
    """A skew of the voltage record: one delay (not at the edge of the searched ones,
    per-test delays adding at most ``skew_spread`` of its log-gain) significant on the
    fit and held-out tests (ΔBIC < ``skew_bic``), explaining ``skew_explains`` of the
    voltage residual's excess over noise, while the generator's force does not follow
    it (a lagging rotor moves both; :mod:`.voltage_skew`)."""
    return (not ev["edge"] and ev["spread"] <= criterion.skew_spread
            and ev["delta_bic_fit"] < criterion.skew_bic
            and ev["delta_bic_heldout"] < criterion.skew_bic
            and ev["explained"] >= criterion.skew_explains and not ev["follows"])


def choose_rival(earning: Sequence[Any], criterion: Criterion = DEFAULT_CRITERION) -> Any:
    """Of earning rivals for one channel (a delay of the force record and the force
    sensor's dynamics, whose limit the delay is), the one with the fewest parameters
    unless a richer one's held-out ΔBIC is lower by the criterion's
    ``nested_evidence``; among those, the lowest held-out ΔBIC."""
    if not earning:
        raise ValueError("choose_rival: no earning attempt")
    by_size = sorted(earning, key=lambda a: (a.n_parameters, a.delta_bic_heldout))
    best = by_size[0]
    for a in by_size[1:]:
        if a.delta_bic_heldout < best.delta_bic_heldout - criterion.nested_evidence:
            best = a
    return best


def excess_reduction(err_before: float, err_after: float, floor: float,
                     criterion: Criterion = DEFAULT_CRITERION) -> float:
    """Share of the error above the noise floor removed:
    1 − √(e₁² − e_n²)/√(e₀² − e_n²) (negative when the error grows)."""
    ex0 = math.sqrt(max(err_before ** 2 - floor ** 2, 0.0))
    ex1 = math.sqrt(max(err_after ** 2 - floor ** 2, 0.0))
    if ex0 <= criterion.min_excess_over_floor * floor:  # nothing beyond noise left to explain
        return 0.0 if err_after <= err_before else -math.inf
    if err_after > err_before:
        return -(err_after - err_before) / ex0
    return 1.0 - ex1 / ex0


def earns(err_before: float, err_after: float, floor: float, dbic_fit: float,
          dbic_heldout: float, sse_excess_reduction: float | None = None,
          n_force: int | None = None, criterion: Criterion = DEFAULT_CRITERION) -> bool:
    """The decision rule: the held-out force error does not grow and falls by at least
    ``criterion.min_excess_reduction`` of its excess over the noise floor — or, for an
    effect seen mainly in another channel (voltage), the held-out SSE of all
    noise-normalised channels falls by that share of its excess over noise
    (``sse_excess_reduction`` = 1 − (SSE₁ − N)/(SSE₀ − N)) while the force error does
    not grow by more than the data resolve (:func:`force_resolution` of the ``n_force``
    held-out force samples: a voltage drop can leave the force error unchanged up to
    rounding) — and ΔBIC < 0 on the fit tests and on the held-out tests (beyond what
    noise explains)."""
    gain = excess_reduction(err_before, err_after, floor, criterion)
    if (sse_excess_reduction is not None
            and err_after <= err_before + force_resolution(floor, n_force)):
        gain = max(gain, sse_excess_reduction)
    return gain >= criterion.min_excess_reduction and dbic_fit < criterion.dbic_max and dbic_heldout < criterion.dbic_max


def earns_on_own_channel(own_reduction: float | None, dbic_fit: float, dbic_heldout: float,
                         force_kept: bool, criterion: Criterion = DEFAULT_CRITERION) -> bool:
    """The decision rule for a member whose own channel is not the force (a generator
    effect, seen in the voltage: :attr:`~.candidates.Candidate.own_channels`), whatever
    the force's excess over its noise floor.

    Earns when the held-out SSE of its own channel(s) falls by at least
    ``criterion.min_excess_reduction`` of its excess over noise (``own_reduction``,
    :func:`channel_sse_excess_reduction` on those channels; None when no own channel
    has an excess, and then it does not earn here), ΔBIC < 0 on the fit tests and on
    the held-out tests (the held-out one with a variance per channel,
    :func:`~.channels.channel_delta_bic`), and the force is kept (``force_kept``: its held-out
    error grows by no more than :func:`force_resolution`, or its SSE by no more than
    the member's parameters are charged, :func:`refuted_by_channel`).

    The force's excess does not close this route: where the force carries a misfit no
    member describes (presliding friction, 13 % against a 0.6 % floor), a flux
    saturation that removed 78 % of the voltage's excess was otherwise judged by the
    force alone and not named.  Ranking and the winner already use the member's own
    channel (:func:`choose_winner`)."""
    return (own_reduction is not None and own_reduction >= criterion.min_excess_reduction
            and dbic_fit < criterion.dbic_max and dbic_heldout < criterion.dbic_max and bool(force_kept))


def can_earn(err_before: float, floor: float, sse_before: float, n_obs: float,
             criterion: Criterion = DEFAULT_CRITERION) -> bool:
    """Whether *any* refit could earn by :func:`earns` from this state — False when
    the force error's excess over the noise floor is within
    ``criterion.min_excess_over_floor`` of the floor (no force gain is possible) and the
    all-channel SSE is within ``criterion.min_sse_excess`` of its noise expectation N (the
    SSE alternative is not offered).  Exact: a round started from such a state
    cannot name anything, so it is not run."""
    ex0 = math.sqrt(max(err_before ** 2 - floor ** 2, 0.0))
    return ex0 > criterion.min_excess_over_floor * floor or sse_before > (1 + criterion.min_sse_excess) * n_obs


def channel_sse_excess_reduction(sse_before: np.ndarray, sse_after: np.ndarray,
                                 n: np.ndarray, criterion: Criterion = DEFAULT_CRITERION) -> float | None:
    """The SSE alternative of the decision rule, per channel.

    For each channel whose SSE before exceeds its noise expectation by more than
    ``criterion.min_sse_excess`` (a share of N), the share of that excess removed,
    1 − (SSE₁ − N)/(SSE₀ − N); the largest of these, or None when no channel has such
    an excess.  Judged per channel because the alternative is for effects seen mainly
    in another channel than the force: pooled with the force, a channel's small
    leftover excess (e.g. of a fitted heating's voltage) let a second effect earn by
    removing force noise (a cogging named at a force error 0.57 → 0.56 % with the
    noise floor at 0.57 %).

    Parameters
    ----------
    sse_before, sse_after : ndarray, shape (ny,)
        Per-channel noise-normalised SSE (dimensionless) of the current model and of
        the candidate on the same tests (:func:`~.channels.channel_sse`).
    n : ndarray, shape (ny,)
        Samples per channel.
    """
    best = None
    for s0, s1, nc in zip(sse_before, sse_after, n):
        if nc > 0 and s0 > (1 + criterion.min_sse_excess) * nc:
            red = 1.0 - (s1 - nc) / (s0 - nc)
            best = red if best is None else max(best, red)
    return best


def sse_can_earn(sse_before: np.ndarray, n: np.ndarray, criterion: Criterion = DEFAULT_CRITERION) -> bool:
    """Whether the SSE alternative is offered at all (some channel's excess over its
    noise expectation exceeds ``criterion.min_sse_excess``)."""
    return bool(np.any((n > 0) & (sse_before > (1 + criterion.min_sse_excess) * n)))


def own_channel_dbic(c: Any) -> float:
    """The candidate's held-out ΔBIC on its own channel (``c.channel_dbic`` at
    ``c.own_channel``), NaN when either is unknown."""
    ch, d = getattr(c, "own_channel", None), getattr(c, "channel_dbic", None)
    if ch is None or not d or ch >= len(d):
        return math.nan
    return float(d[ch])


def choose_winner(earning: Sequence[Any]) -> Any:
    """The earning candidate to add: the lowest held-out ΔBIC.

    ΔBIC = N_eff ln(SSE_new/SSE_old) + k ln N_eff with the same N_eff and SSE_old for
    every candidate of the round, so this is the largest held-out SSE drop net of a
    ln N_eff penalty per effect parameter.  Between nested effects that fit equally
    well — a backlash whose gap tends to zero *is* a compliance (3 vs 2 parameters) —
    the simpler one is chosen; a compliance of 3e6 N/m had been answered ``backlash``
    by the raw SSE (held-out error 0.925 % for both).  Ties (equal ΔBIC) fall back
    to the lower held-out SSE.

    Parameters
    ----------
    earning : sequence of CandidateResult
        Candidates of the round that earn (``delta_bic_heldout`` and ``sse_heldout``
        set).
    """
    if not earning:
        raise ValueError("choose_winner: no earning candidate")
    physical = [c for c in earning if not getattr(c, "at_bound", ())] or list(earning)
    own = [own_channel_dbic(c) for c in physical]
    if len(physical) > 1 and all(map(math.isfinite, own)):
        # each on the channel that sees it best: the all-channel ΔBIC let a mount
        # compliance that trades the force's presliding misfit for the voltage win over
        # the diode drop that removed 96 % of the voltage excess
        return min(zip(own, physical), key=lambda t: (t[0], t[1].delta_bic_heldout,
                                                      t[1].sse_heldout))[1]
    return min(physical, key=lambda c: (c.delta_bic_heldout, c.sse_heldout))


def own_evidence(reductions: np.ndarray, min_reduction: float) -> tuple[bool, float, int]:
    """The practical size on the effect's own evidence: the median over blocks with an
    excess of :func:`block_excess_reductions` reaches ``min_reduction``.  Returns
    (passes, median, blocks judged)."""
    r = np.asarray(reductions, float)
    r = r[np.isfinite(r)]
    if r.size < 3:
        return False, math.nan, int(r.size)
    med = float(np.median(r))
    return bool(med >= min_reduction), med, int(r.size)


def refuted_by_channel(sse_before: float, sse_after: float, k: int, n_eff: float) -> bool:
    """Whether a refit is refuted by one output channel: that channel's held-out SSE
    grows by more than the evidence the member's ``k`` parameters are charged,
    N_eff ln(SSE_after/SSE_before) > k ln N_eff (``n_eff`` the channel's effective
    samples)."""
    return n_eff * math.log(max(sse_after, 1e-300) / max(sse_before, 1e-300)) \
        > k * math.log(max(n_eff, 2.0))


def refuted_by_rotor_channel(sse_before: float, sse_after: float, k: int, n_eff: float
                             ) -> bool:
    """Whether a transmission effect is refuted by the channel that measures the rotor.

    A transmission effect (a gap, a mount spring) lets the rotor move otherwise than
    the rod; the generator's voltage measures the rotor's speed.  Such an effect present
    in the rig explains the voltage too; a refit that trades the voltage for the force
    is another force law in disguise (friction presliding fitted as a mount spring: the
    force misfit at reversals falls, the model's rotor then lags a rotor that does not).
    Refuted when the held-out voltage SSE grows by more than the evidence the member's
    ``k`` parameters are charged: N_eff ln(SSE_after/SSE_before) > k ln N_eff
    (:func:`refuted_by_channel`)."""
    return refuted_by_channel(sse_before, sse_after, k, n_eff)


def judge_candidate(c: Any, ev: Any, *, cur_err: float, floor: float, say,
                    criterion: Criterion = DEFAULT_CRITERION) -> None:
    """The verdict of one re-identified catalogue member ``c`` (a
    :class:`~.results.CandidateResult`) from its evidence ``ev``
    (:func:`~.candidate_evidence.measure_candidate`, which filled the statistics of
    ``c``), against the current model's held-out force error ``cur_err`` and the noise
    ``floor`` (%).  It earns, its size resolved, by one of three routes:

    * *total excess*: :func:`earns` on the force error and ΔBIC, with the SSE of the
      member's channels as the alternative where the force has no excess left or another
      channel's excess exceeds the force's (:func:`channel_sse_excess_reduction`);
    * *own channel*: a generator member on its own channel (:func:`earns_on_own_channel`);
    * *own evidence*: the median per-block excess reduction (:func:`own_evidence`) with
      ΔBIC below the criterion's and the force error not grown.

    A transmission member refuted by the rotor's channel (:func:`refuted_by_rotor_channel`)
    is withdrawn; an impact-fitted contact is judged on its transient energies instead
    (:func:`judge_on_impacts`); a fit at an active bound does not earn
    (:func:`refuse_at_bound`).  Every threshold is ``criterion``'s."""
    c.excess_reduction = excess_reduction(cur_err, c.error_after, floor, criterion)
    ch = ev.channels
    c.sse_reduction = channel_sse_excess_reduction(ev.sse_before[ch], ev.sse_after[ch],
                                                   ev.n[ch], criterion)
    # the SSE (other-channel) route is for effects seen mainly in another channel: it is
    # offered where the force error has no excess beyond noise left, or where another
    # channel's excess over its noise expectation (SSE/N − 1) exceeds the force's;
    # where the force's excess dominates (a gap at 11 %), the force decides
    exc = [s0 / n0 - 1.0 if n0 > 0 else -math.inf for s0, n0 in zip(ev.sse_before, ev.n)]
    c.sse_route = (not can_earn(cur_err, floor, 0.0, 1.0, criterion)
                   or (len(exc) > 1 and max(exc[1:]) > exc[0]))
    dbic_held = ev.delta_bic_heldout
    by_total = bool(earns(cur_err, c.error_after, floor, c.delta_bic_fit, dbic_held,
                          c.sse_reduction if c.sse_route else None, n_force=ev.n_force,
                          criterion=criterion))
    # a generator effect earns on its own channel (the voltage) whatever the force's
    # excess: the held-out ΔBIC with a variance per channel, the force kept
    by_channel, own_txt = False, ""
    own = ev.own_channels
    if own and not by_total:
        own_red = channel_sse_excess_reduction(ev.sse_before[own], ev.sse_after[own],
                                               ev.n[own], criterion)
        force_kept = (c.error_after <= cur_err + force_resolution(floor, ev.n_force)
                      or not refuted_by_channel(ev.sse_before[0], ev.sse_after[0], ev.k,
                                                ev.force_n_eff))
        by_channel = earns_on_own_channel(own_red, c.delta_bic_fit, ev.own_dbic, force_kept,
                                          criterion)
        own_txt = (f", own channel{'s' if len(own) > 1 else ''} "
                   f"{','.join(map(str, own))}: SSE excess reduced "
                   + (f"{100 * own_red:.0f} %" if own_red is not None else "n/a")
                   + f", held-out dBIC per channel {ev.own_dbic:.1f}, force "
                   + ("kept" if force_kept else "refuted"))
    # the effect's own evidence: the same likelihood evidence, and its practical size
    # judged per block of the held-out records (documented disturbances masked), so
    # that an effect another one dominates in a few blocks is not vetoed
    by_own = False
    if ev.block_reductions is not None:
        by_own, c.block_reduction, c.blocks_judged = own_evidence(
            ev.block_reductions, criterion.min_excess_reduction)
        by_own = (by_own and c.delta_bic_fit < criterion.dbic_max
                  and dbic_held < criterion.dbic_max and c.error_after <= cur_err)
    record_verdict(c, (by_total or by_channel or by_own) and c.resolved,
                   "total excess" if by_total else "own channel" if by_channel
                   else "own evidence")
    if (c.earns and ev.impact is None and ev.transmission and len(ev.n) > 1
            and refuted_by_rotor_channel(ev.sse_before[1], ev.sse_after[1], ev.k, ev.n_eff)):
        withdraw(c, f"{c.effect}: refuted by the voltage (the rotor's speed): its held-out "
                    f"voltage SSE grows {ev.sse_before[1] / ev.n[1]:.3g} -> "
                    f"{ev.sse_after[1] / ev.n[1]:.3g} per sample", say)
    if ev.impact is not None:
        judge_on_impacts(c, ev.impact, say, criterion)
    refuse_at_bound(c, say)
    res = c.fit
    pars = ", ".join(f"{n} {v:.3g}" + (f" [{iv[0]:.3g}, {iv[1]:.3g}]" if iv else "")
                     for (n, v), iv in zip(c.parameters.items(), c.intervals.values()))
    sse_txt = f", SSE excess reduced {100 * c.sse_reduction:.0f} %" \
        if c.sse_reduction is not None else ""
    blk = (f", median block excess reduced {100 * c.block_reduction:.0f} % over "
           f"{c.blocks_judged} blocks" if math.isfinite(c.block_reduction) else "")
    say(f"{c.effect}: {res.message}, dBIC fit {c.delta_bic_fit:.1f}, held-out "
        f"{c.delta_bic_heldout:.1f}, error {c.error_before:.3f} -> {c.error_after:.3f} % "
        f"(excess reduced {100 * c.excess_reduction:.0f} %{sse_txt}{blk}{own_txt}; "
        f"{res.seconds:.1f} s)"
        f"{' EARNS (' + c.earns_by + ')' if c.earns else ''}"
        f"{' AT BOUND' if c.at_bound else ''}; {pars}")


def judge_on_impacts(c: Any, rec: dict, say, criterion: Criterion = DEFAULT_CRITERION) -> None:
    """The verdict of the impact-fitted contact ``c`` from its transient-energy record
    ``rec`` (:func:`~.impact_verdict.impact_verdict_record`: the evaluation tests'
    transient energies and kinematic gaps): earns when its held-out feature objective
    is at most ``criterion.impact_earn_objective`` and at most
    ``criterion.impact_earn_share`` of the current model's, and its size is resolved."""
    before, after = rec["heldout_objective_before"], rec["heldout_objective_after"]
    ok = impact_earns(before, after, criterion)
    rec["earns"] = ok
    record_verdict(c, ok and c.resolved, "transient energies and kinematic gaps")
    if c.earns:
        say(f"{c.effect}: EARNS on transient energies and kinematic gaps (held-out feature "
            f"objective {after:.3g} ≤ {criterion.impact_earn_objective:g} and ≤ "
            f"{criterion.impact_earn_share:g} × {before:.3g})")


def impact_earns(before: float, after: float, criterion: Criterion = DEFAULT_CRITERION) -> bool:
    """Whether an impact-fitted contact earns on its held-out feature objectives
    (``before``: the current model's, ``after``: the candidate's;
    :func:`~.impact_verdict.impact_verdict`): ``after`` at most
    ``criterion.impact_earn_objective`` and at most ``criterion.impact_earn_share`` of
    ``before``."""
    return bool(math.isfinite(after) and math.isfinite(before)
                and after <= criterion.impact_earn_objective
                and after <= criterion.impact_earn_share * before)


def refuse_at_bound(c: Any, say: Any = None) -> bool:
    """Withdraw the verdict of ``c`` when it is at an active bound (``c.at_bound``, set
    by :func:`~.bounds.at_bound_names` within ``criterion.at_bound_rel`` of a bound the
    unconstrained step says is active): an unphysical fit does not earn.  Returns
    whether it was at a bound."""
    names = list(getattr(c, "at_bound", ()))
    if names and c.earns:
        withdraw(c, f"{c.effect}: at bound ({', '.join(names)} on the edge of its physical "
                    f"range): an unphysical fit, not earned", say)
    return bool(names)
