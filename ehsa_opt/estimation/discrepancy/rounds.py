"""Re-identifying and judging the candidates of one round (kept apart from
:mod:`.workflow` to keep each module small).

* :func:`_fit_one` / :func:`_run_fits`: one candidate's staged re-identification
  (:func:`~.refit.fit_candidate`) on the fit-test subset, simulated on all tests;
* :func:`_judge`: its errors, ΔBIC and the decision (:func:`~.refit.earns` with the
  per-channel SSE alternative and the resolved-size check of :mod:`.decide`);
* :func:`_on_top`: the look-ahead re-identification of a confounded candidate on the
  model with an earning one (:func:`~.decide.lookahead_winner`).
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from .candidates import CANDIDATES, components_for
from .decide import channel_sse, channel_sse_excess_reduction, significant
from .evidence import block_excess_reductions, own_evidence
from .impacts import impact_record, impact_verdict
from .fit import Rig, force_relative_error_percent, predict
from .refit import (
    _dbic,
    _force_error,
    _sse,
    can_earn,
    MIN_EXCESS_REDUCTION,
    compatible,
    earns,
    effective_samples,
    excess_reduction,
    fit_candidate,
)

__all__: list[str] = []


def _judge(c: Any, out: tuple, *, comps, fit_pts, held_pts, sse_fit, sse_held,
           n_eff_fit, n_eff_held, cur_err, floor, ch_sse0, ch_n, say,
           cur_ev_pred=None, masks=None) -> None:
    """Fill ``c`` from one re-identification ``out`` (:func:`_fit_one`) and judge it by
    :func:`~.refit.earns` (force error, ΔBIC on the fit and held-out tests, SSE
    alternative per channel, :func:`~.decide.channel_sse_excess_reduction`)."""
    name, res, pf, ph, crig = out
    c.fitted, c.fit, c.rig = True, res, crig
    if not pf:
        say(f"{name}: re-identification failed ({res.message})")
        return
    comp_params = [q.name for q in comps[name].parameters]
    k = len(comp_params)
    c.parameters = {n: res.parameters[n] for n in comp_params}
    c.intervals = {n: res.interval(n) for n in c.parameters}
    c.delta_bic_fit = _dbic(_sse(fit_pts, pf), sse_fit, k, n_eff_fit)
    ev_pts, ev_pred = (held_pts, ph) if held_pts else (fit_pts, pf)
    c.sse_heldout = _sse(ev_pts, ev_pred)
    c.delta_bic_heldout = (_dbic(c.sse_heldout, sse_held, k, n_eff_held) if held_pts
                           else c.delta_bic_fit)
    c.error_after = _force_error(ev_pts, ev_pred)
    c.excess_reduction = excess_reduction(cur_err, c.error_after, floor)
    ch = CANDIDATES[name].rigid_channels if name in CANDIDATES else None
    if ch is None or any(q.transmission for q in crig.components):
        ch = tuple(range(len(ch_n)))
    ch = [k for k in ch if k < len(ch_n)]
    c.sse_reduction = channel_sse_excess_reduction(
        ch_sse0[ch], channel_sse(ev_pts, ev_pred)[0][ch], ch_n[ch])
    c.resolved = significant(c.intervals, CANDIDATES[name].amplitudes)
    # the SSE (other-channel) route is for effects seen mainly in another channel: it is
    # offered where the force error has no excess beyond noise left, or where another
    # channel's excess over its noise expectation (SSE/N − 1) exceeds the force's;
    # where the force's excess dominates (a gap at 11 %), the force decides
    exc = [s0 / n0 - 1.0 if n0 > 0 else -math.inf for s0, n0 in zip(ch_sse0, ch_n)]
    c.sse_route = (not can_earn(cur_err, floor, 0.0, 1.0)
                   or (len(exc) > 1 and max(exc[1:]) > exc[0]))
    by_total = bool(earns(cur_err, c.error_after, floor, c.delta_bic_fit, c.delta_bic_heldout,
                          c.sse_reduction if c.sse_route else None,
                          n_force=sum(pt.y.shape[1] for pt in ev_pts)))
    # the effect's own evidence: the same likelihood evidence, and its practical size
    # judged per block of the held-out records (documented disturbances masked), so
    # that an effect another one dominates in a few blocks is not vetoed
    by_own = False
    if cur_ev_pred is not None:
        red = block_excess_reductions(ev_pts, cur_ev_pred, ev_pred,
                                      masks if held_pts else None)
        by_own, c.block_reduction, c.blocks_judged = own_evidence(red, MIN_EXCESS_REDUCTION)
        by_own = (by_own and c.delta_bic_fit < 0 and c.delta_bic_heldout < 0
                  and c.error_after <= cur_err)
    c.earns_by = ("total excess" if by_total else "own evidence") if (by_total or by_own) \
        else ""
    c.earns = bool((by_total or by_own) and c.resolved)
    imp = impact_record(res)
    if imp is not None and cur_ev_pred is not None:
        # a rattling contact: judged on the features it was fitted on (.impacts)
        imp.update(impact_verdict(ev_pts, cur_ev_pred, ev_pred, crig.harvester, k))
        c.earns = bool(imp["earns"] and c.resolved)
        c.earns_by = "transient energies and kinematic gaps" if c.earns else ""
        c.delta_bic_heldout = min(c.delta_bic_heldout, imp["feature_delta_bic"])
        say(f"{name}: held-out feature objective {imp['heldout_objective_before']:.3g} -> "
            f"{imp['heldout_objective_after']:.3g}")
    c.predictions = pf + ph
    c.per_test_after = [force_relative_error_percent(y[0][pt.weight > 0], pt.y[0][pt.weight > 0])
                        for y, pt in zip(c.predictions, fit_pts + held_pts)]
    pars = ", ".join(f"{n} {v:.3g}" + (f" [{iv[0]:.3g}, {iv[1]:.3g}]" if iv else "")
                     for (n, v), iv in zip(c.parameters.items(), c.intervals.values()))
    sse_txt = f", SSE excess reduced {100 * c.sse_reduction:.0f} %" \
        if c.sse_reduction is not None else ""
    blk = (f", median block excess reduced {100 * c.block_reduction:.0f} % over "
           f"{c.blocks_judged} blocks" if math.isfinite(c.block_reduction) else "")
    say(f"{name}: {res.message}, dBIC fit {c.delta_bic_fit:.1f}, held-out "
        f"{c.delta_bic_heldout:.1f}, error {c.error_before:.3f} -> {c.error_after:.3f} % "
        f"(excess reduced {100 * c.excess_reduction:.0f} %{sse_txt}{blk}; {res.seconds:.1f} s)"
        f"{' EARNS (' + c.earns_by + ')' if c.earns else ''}; {pars}")


def _on_top(c: Any, blocked: Any, judge: dict, sub_pts: list, max_iter: int, rnd: int
            ) -> Any:
    """``blocked`` re-identified on the model with ``c`` and judged against it (the
    look-ahead of :func:`~.decide.lookahead_winner`); None when incompatible."""
    comp = judge["comps"][blocked.effect]
    if c.rig is None or c.fit is None or not compatible(c.rig, comp):
        return None
    fit_pts, held_pts = judge["fit_pts"], judge["held_pts"]
    pf, ph = c.predictions[:len(fit_pts)], c.predictions[len(fit_pts):]
    # configured from the residual of the model with c (the cogging period: the
    # baseline's residual was dominated by what c explains)
    comp = components_for([blocked.effect], fit_pts, pf, c.rig.harvester.lead_m_per_rad
                          )[blocked.effect]
    ev_pts, ev_pred = (held_pts, ph) if held_pts else (fit_pts, pf)
    sse_fit = _sse(fit_pts, pf)
    n_eff_fit = effective_samples(fit_pts, pf)
    ch_sse0, ch_n = channel_sse(ev_pts, ev_pred)
    step = type(blocked)(blocked.effect, True, blocked.score, blocked.chi2, rnd + 1,
                           error_before=c.error_after)
    out = _fit_one((blocked.effect, comp, CANDIDATES[blocked.effect].starts, sub_pts, fit_pts,
                    held_pts, c.rig, dict(c.fit.parameters), max_iter))
    _judge(step, out, **{**judge, "sse_fit": sse_fit, "n_eff_fit": n_eff_fit,
                         "cur_ev_pred": ev_pred,
                         "sse_held": _sse(held_pts, ph) if held_pts else math.nan,
                         "n_eff_held": effective_samples(held_pts, ph) if held_pts else math.nan,
                         "cur_err": c.error_after, "ch_sse0": ch_sse0, "ch_n": ch_n})
    if step.predictions is None:
        return None
    amp = CANDIDATES[c.effect].amplitudes if c.effect in CANDIDATES else ()
    step.first_resolved = significant({n: step.fit.interval(n) for n in amp}, amp)
    return step


def _rig_on_simulation(rig: Rig) -> bool:
    """Whether ``rig`` holds an effect fitted on the simulation (a stiff contact or an
    elastic mount): every later candidate is then fitted on the simulation too — the
    collocation NLP with those states factorises for minutes (a 0.8 mm gap: > 15 min)."""
    return any(CANDIDATES[c.name].full_refit == "simulation"
               for c in rig.components if c.name in CANDIDATES)


def _fit_one(a: tuple) -> tuple:
    name, comp, starts, sub_pts, fit_pts, held_pts, rig, params, max_iter = a
    cand = CANDIDATES[name]
    on_sim = _rig_on_simulation(rig)
    _, res, _, _ = fit_candidate(name, comp, starts, sub_pts, [], rig, params, max_iter,
                                 shares=cand.shares, refine=cand.refine,
                                 full_refit="simulation" if on_sim else cand.full_refit,
                                 effect_fit="simulation" if on_sim else cand.effect_fit,
                                 log_names=cand.log_names, impact_fit=cand.impact_fit)
    crig = rig.with_components([*rig.components, comp])
    if not res.parameters:
        return name, res, [], [], crig
    pf = predict(fit_pts, crig, res.parameters)
    ph = predict(held_pts, crig, res.parameters) if held_pts else []
    return name, res, pf, ph, crig


def _run_fits(args: list[tuple], jobs: int) -> list[tuple]:
    if jobs > 1 and len(args) > 1:
        import multiprocessing as mp
        with ProcessPoolExecutor(max_workers=min(jobs, len(args)),
                                 mp_context=mp.get_context("fork")) as ex:
            return list(ex.map(_fit_one, args))
    return [_fit_one(a) for a in args]
