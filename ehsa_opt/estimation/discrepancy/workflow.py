"""The model-discrepancy workflow (SPEC §7–9): localise, rank, re-identify, decide —
round after round, then propose a data-driven term for what no catalogue effect explains.

1. **Split** the tests into fit and held-out tests (every third test of the
   (load, frequency) grid, offset drawn from the seed).  A data directory with a
   ``validation/`` sub-directory (EMPS) is held out as a whole instead.  With
   fewer than 3 tests and no validation set nothing is held out and the decision
   uses all data — the result says so.
2. **Baseline**: identify the base model (friction; inertia and offset without
   generator) on the fit tests, started from a linear least-squares solution.
3. **Localise** the residual (:func:`~.localise.localise`) and read initial
   values off it (the cogging period from the residual's spectrum in rotor angle,
   :func:`~.localise.best_rotor_period`).
4. **Rank** the candidates by their signature score (:func:`~.candidates.signature_scores`).
5. **Re-identify** the top candidates (:func:`~.refit.fit_candidate`: multistart
   screened by forward simulation over the realistic ranges, effect-only stage,
   nut/bearing friction split for transmission effects, full refit, refinement
   on the simulation).
6. **Decide** (:func:`~.refit.earns`): a candidate *earns* when its refit removes
   at least :data:`~.refit.MIN_EXCESS_REDUCTION` of the held-out relative force
   error above the noise floor (the error the measurement noise alone gives) and
   ΔBIC = N_eff ln(SSE_new/SSE_old) + k ln N_eff < 0 on the fit tests and on the
   held-out tests (N_eff = Σ N/τ, τ the residual autocorrelation time); for an
   effect seen in the voltage channel the same share of that channel's SSE excess,
   the force error not growing by more than the data resolve (e_n/√(2N)).  Among
   the earning candidates the one with the lowest held-out ΔBIC is added
   (:func:`~.decide.choose_winner`: between nested effects that fit equally well,
   the simpler).  When the best earning candidate removes less than
   :data:`~.decide.WIDEN_BELOW` of the excess, the remaining lower-ranked
   candidates are re-identified too before deciding (:func:`~.decide.should_widen`),
   and a candidate that fits the fit tests but fails on the held-out ones (it
   absorbed another effect's residual) is re-identified on top of the others, or
   they on top of it: a two-step path that earns as a whole and ends below the
   default winner decides which is added first (:func:`~.decide.lookahead_winner`,
   :func:`~.decide.confounded_first`).
7. **Repeat** from 3 with the effect in the model (the remaining candidates are
   added on top of it) until nothing earns or ``max_effects`` are named.
8. **Outside the catalogue**: the remaining force residual is regressed on a
   library of physical features (:func:`~.terms.discover_term`); the term is
   reported when it earns by the same rule.  No catalogue effect earned but the
   term does → ``effect = "none of the catalogue"`` with the term in words.
"""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ...datasets.bench_format import BenchData, BenchDataWarning, load_bench
from ...utils.process import single_threaded_blas
from ..identify_options import MIN_RESOLVED_SAMPLES
from .candidates import CANDIDATES, components_for, signature_scores
from .deadline import deadline_set
from .evidence import WHITE_P, disturbance_masks, residual_is_white
from .fit import (
    Rig,
    fit_group,
    linear_baseline,
    predict,
    prepare_tests,
)
from .localise import localise
from .refit import (
    MIN_EXCESS_OVER_FLOOR,
    MIN_SSE_EXCESS,
    _crop,
    _dbic,
    _force_error,
    _sse,
    can_earn,
    compatible,
    earns,
    effective_samples,
    excess_reduction,
    force_noise_floor_percent,
    split_tests,
)
from .refit import _load_split, _spread
from .decide import (
    WIDEN_BELOW,
    channel_sse,
    choose_winner,
    confounded,
    confounded_first,
    lookahead_winner,
    should_widen,
    sse_can_earn,
    supported,
)
from .lag import try_lag
from .results import (NONE_OF_CATALOGUE, UNDECIDED, CandidateResult, DiscrepancyResult,
                      DiscrepancySettings)
from .rounds import _judge, _on_top, _run_fits
from .terms import TermProposal, discover_term

__all__ = ["DiscrepancySettings", "CandidateResult", "DiscrepancyResult", "run_discrepancy",
           "split_tests", "effective_samples", "NONE_OF_CATALOGUE"]

def run_discrepancy(data: BenchData | str | Path, settings: DiscrepancySettings | None = None,
                    log: Any = None) -> DiscrepancyResult:
    """Run the workflow on a bench data directory (see module docstring).

    Parameters
    ----------
    data : BenchData or path
    settings : DiscrepancySettings
    log : callable, optional
        Progress messages (e.g. ``print``).
    """
    # process-level parallelism only (see the utility); the deadline reaches into the
    # candidate fits (their screening and simulation refinements stop at it)
    with single_threaded_blas(), deadline_set(settings.budget_s if settings else None):
        return _run_discrepancy(data, settings, log)


def _run_discrepancy(data: BenchData | str | Path, settings: DiscrepancySettings | None,
                     log: Any) -> DiscrepancyResult:
    t_start = time.perf_counter()
    settings = settings or DiscrepancySettings()
    deadline = t_start + settings.budget_s if settings.budget_s else math.inf
    cut = ""
    say = log or (lambda msg: None)
    notes: list[str] = []
    if not isinstance(data, BenchData):
        # the bench checks compare the signals with the rigid model (e.g. the voltage the
        # motion implies); data that disagree with it are what this workflow diagnoses, so
        # those checks are reported, not fatal (syntax and layout errors still are)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", BenchDataWarning)
            data = load_bench(data, lenient=True)
        for w in caught:
            if issubclass(w.category, BenchDataWarning):
                note = (f"bench check (the data are used anyway — a disagreement with the "
                        f"rigid model is what this workflow diagnoses): {w.message}")
                say(note)
                notes.append(note)
    rig = Rig(data.harvester, data.has_generator, ())
    lead = data.harvester.lead_m_per_rad
    fit_t, held_t, evaluation = _load_split(data, settings)
    if settings.max_samples is not None:
        fit_t = [_crop(t, settings.max_samples) for t in fit_t]
        held_t = [_crop(t, settings.max_samples) for t in held_t]
    mass = data.harvester.equivalent_mass_kg() if data.has_generator else None
    fit_pts = prepare_tests(fit_t, data.has_generator, mass_kg=mass)
    held_pts = prepare_tests(held_t, data.has_generator, mass_kg=mass) if held_t else []
    # a recorded test whose samples are all corners, dwells or ends says nothing
    bare = [pt.test.file for pt in fit_pts + held_pts if pt.n_resolved < MIN_RESOLVED_SAMPLES]
    if bare:
        note = (f"left out (fewer than {MIN_RESOLVED_SAMPLES} samples outside the windows "
                f"where the motion's derivatives are not resolved): {', '.join(bare)}")
        say(note)
        notes.append(note)
        fit_pts = [pt for pt in fit_pts if pt.test.file not in bare]
        held_pts = [pt for pt in held_pts if pt.test.file not in bare]
    sub_pts = _spread(fit_pts, settings.max_fit_tests)
    say(f"{len(fit_pts)} fit tests ({len(sub_pts)} for candidate fits), "
        f"{len(held_pts)} {evaluation} tests")

    lb = linear_baseline(fit_pts, rig)
    base = fit_group(fit_pts, rig, [lb], max_iter=settings.max_iter)
    if not base.parameters:
        raise RuntimeError(f"baseline identification failed: {base.message}")
    say(f"baseline: {base.message}, chi2/N {base.objective:.3g} ({base.seconds:.1f} s)")
    base_fit_pred = predict(fit_pts, rig, base.parameters)
    base_held_pred = predict(held_pts, rig, base.parameters) if held_pts else []
    loc0 = localise(fit_pts + held_pts, base_fit_pred + base_held_pred, lead_m_per_rad=lead)
    n_eff_fit = effective_samples(fit_pts, base_fit_pred)
    n_eff_held = effective_samples(held_pts, base_held_pred) if held_pts else math.nan
    eval_pts = held_pts or fit_pts
    floor = force_noise_floor_percent(eval_pts)
    err0 = _force_error(eval_pts, base_held_pred or base_fit_pred)

    cur_rig, cur_params = rig, dict(base.parameters)
    cur_fit, cur_held = base_fit_pred, base_held_pred
    cur_err, effects, steps, all_cands = err0, [], [], []
    if settings.discover and "force_lag" in settings.candidates:
        lagged = try_lag(fit_pts, held_pts, rig, base, cur_fit, cur_held, floor, n_eff_fit,
                          n_eff_held, err0, settings, say)
        if lagged is not None:
            fit_pts, held_pts, base_l, cur_fit, cur_held, cur_err, fields = lagged
            cand = CandidateResult(**fields)
            all_cands.append(cand)
            eval_pts = held_pts or fit_pts
            cur_params = dict(base_l.parameters)
            effects.append("force_lag")
            steps.append({"effect": "force_lag", "error_after": cur_err,
                          "excess_reduction": cand.excess_reduction,
                          "parameters": cand.parameters})
            n_eff_fit = effective_samples(fit_pts, cur_fit)
            n_eff_held = effective_samples(held_pts, cur_held) if held_pts else math.nan
            # the report compares on the re-aligned tests from here on
            sub_pts = _spread(fit_pts, settings.max_fit_tests)
            base_fit_pred = predict(fit_pts, rig, base.parameters)
            base_held_pred = predict(held_pts, rig, base.parameters) if held_pts else []
    remaining = [n for n in settings.candidates if n in CANDIDATES]
    # a look-ahead first step (no gain alone) is named only together with the effect
    # that completes its path: (state before it, its error before) until then
    joint: tuple | None = None
    for rnd in range(1, settings.max_effects + 1):
        if time.perf_counter() > deadline:
            cut = cut or (f"time budget {settings.budget_s:g} s reached before round {rnd}: "
                          f"no further round run")
            say(cut)
            break
        comps = components_for(remaining, fit_pts, cur_fit, lead)
        sub_pred = [cur_fit[next(k for k, q in enumerate(fit_pts) if q is p)] for p in sub_pts]
        flex = "flexibility" in remaining and not rig.has_generator
        scores = signature_scores(sub_pts, cur_rig, cur_params, sub_pred,
                                  [n for n in remaining if n != "flexibility"], comps)
        flex_out = None
        if "flexibility" in remaining:
            flex_out = _flexibility_round(fit_pts, cur_fit, held_pts, cur_held, cur_rig,
                                          cur_params, comps, scores) if flex else None
            if flex_out is None:
                scores["flexibility"] = {"score": math.nan, "chi2": math.nan, "columns": 0,
                                         "applicable": False}
        order = sorted(remaining, key=lambda n: (not scores[n]["applicable"],
                                                 -np.nan_to_num(scores[n]["score"])))
        cands = {n: CandidateResult(n, scores[n]["applicable"], scores[n]["score"],
                                    scores[n]["chi2"], len(effects) + 1,
                                    error_before=cur_err) for n in order}
        chosen = [n for n in order if scores[n]["applicable"] and n != "flexibility"
                  and compatible(cur_rig, comps[n])][:settings.top]
        sse_fit, sse_held = _sse(fit_pts, cur_fit), (_sse(held_pts, cur_held) if held_pts
                                                      else math.nan)
        n_obs = sum(pt.y.size for pt in eval_pts)
        sse0 = sse_held if held_pts else sse_fit
        ch_sse0, ch_n = channel_sse(eval_pts, cur_held or cur_fit)
        say(f"round {rnd} (error {cur_err:.3f} %, floor {floor:.3f} %, SSE/N {sse0 / n_obs:.3f}"
            f" [per channel " + ", ".join(f"{a / b:.3f}" for a, b in zip(ch_sse0, ch_n))
            + "]) ranking: " + ", ".join(f"{n} {scores[n]['score']:.3g}" for n in order))
        force_can_earn = can_earn(cur_err, floor, 0.0, 1.0)  # the force path alone
        if not (force_can_earn or sse_can_earn(ch_sse0, ch_n)):
            excess = math.sqrt(max(cur_err ** 2 - floor ** 2, 0.0))
            note = (f"round {rnd}: candidates not re-identified — the {evaluation} force "
                    f"error {cur_err:.3f} % exceeds the noise floor {floor:.3f} % by "
                    f"{excess:.3f} % (≤ {MIN_EXCESS_OVER_FLOOR:g} × floor) and the SSE of "
                    f"every channel is within {1 + MIN_SSE_EXCESS:g} × its noise expectation "
                    f"(all channels {sse0 / n_obs:.3f}): no refit can earn by the decision rule")
            say(note)
            notes.append(note)
            all_cands += [cands[n] for n in order]
            break
        masks, mask_note = disturbance_masks(
            held_pts, Path(str(getattr(data, "path", "") or ".")) / "validation"
            if evaluation == "validation set" else None)
        if mask_note and mask_note not in notes:
            say(mask_note)
            notes.append(mask_note)
        judge = dict(comps=comps, fit_pts=fit_pts, held_pts=held_pts, sse_fit=sse_fit,
                     sse_held=sse_held, n_eff_fit=n_eff_fit, n_eff_held=n_eff_held,
                     cur_err=cur_err, floor=floor, ch_sse0=ch_sse0, ch_n=ch_n, say=say,
                     cur_ev_pred=cur_held or cur_fit, masks=masks)

        def fit_and_judge(names: list[str]) -> None:
            nonlocal cut
            # with a budget, the fits go in batches of `jobs` and stop at the deadline
            step = len(names) if math.isinf(deadline) else settings.jobs
            for a in range(0, len(names), max(step, 1)):
                if time.perf_counter() > deadline:
                    cut = (f"time budget {settings.budget_s:g} s reached in round {rnd}: "
                           f"{', '.join(names[a:])} not re-identified; the round is decided "
                           f"on the candidates fitted before the cut")
                    say(cut)
                    return
                args = [(n, comps[n], CANDIDATES[n].starts, sub_pts, fit_pts, held_pts,
                         cur_rig, cur_params, settings.max_iter) for n in names[a:a + step]]
                for out in _run_fits(args, settings.jobs):
                    _judge(cands[out[0]], out, **judge)

        fit_and_judge(chosen)
        if flex_out is not None:  # judged by the same rule, fitted by variable projection
            _judge(cands["flexibility"], flex_out, **judge)
            cf = cands["flexibility"]
            if cf.parameters:  # the stiffness k = m (2π f)² and its interval, for the report
                w2 = (2 * math.pi * cf.parameters["flex_frequency_hz"]) ** 2
                cf.parameters["flex_stiffness_N_per_m"] = cf.parameters["flex_load_mass_kg"] * w2
                iv = cf.intervals.get("flex_load_mass_kg")
                cf.intervals["flex_stiffness_N_per_m"] = (iv[0] * w2, iv[1] * w2) if iv else None
        earning = [c for c in cands.values() if c.earns]
        first = None
        if not cut and should_widen(earning, force_can_earn):
            more = [n for n in order if n not in chosen and scores[n]["applicable"]
                    and n != "flexibility"
                    and compatible(cur_rig, comps[n])]
            if more:
                best = max(earning, key=lambda c: c.excess_reduction)
                say(f"round {rnd}: the best earning candidate ({best.effect}) removes only "
                    f"{100 * best.excess_reduction:.0f} % of the excess (< "
                    f"{100 * WIDEN_BELOW:.0f} %): also re-identifying {', '.join(more)}")
                fit_and_judge(more)
                earning = [c for c in cands.values() if c.earns]
                blocked = confounded(list(cands.values()))
                if blocked is not None and not cut:
                    first = lookahead_winner(
                        earning, blocked, lambda c: _on_top(c, blocked, judge, sub_pts,
                                                            settings.max_iter, rnd), say,
                        first_steps=[c for c in cands.values() if supported(c)])
                    others = [cands[n] for n in order if cands[n].fitted
                              and cands[n].predictions is not None and cands[n] is not blocked]
                    if first is None and confounded_first(
                            blocked, others,
                            lambda c: _on_top(blocked, c, judge, sub_pts, settings.max_iter,
                                              rnd),
                            cur_err, floor,
                            choose_winner(earning).sse_heldout if earning else math.inf, say):
                        first = blocked
        all_cands += [cands[n] for n in order]
        if first is not None and not first.earns and (rnd == settings.max_effects
                                                      or len(remaining) < 2
                                                      or joint is not None):
            say(f"round {rnd}: no round left to complete a path through {first.effect}")
            first = None
        if first is not None and not first.earns:
            joint = ((cur_rig, cur_params, cur_fit, cur_held, n_eff_fit, n_eff_held, cur_err,
                      list(effects), list(steps), list(remaining)), cur_err)
            note = (f"round {rnd}: {first.effect} is added first (it removes "
                    f"{100 * first.excess_reduction:.0f} % of the excess alone, and "
                    + (f"lets {blocked.effect} earn on top of it)" if first is not blocked
                       else "a candidate fitted on top of it completes a path that earns)"))
            say(note)
            notes.append(note)
            first.earns = True
        if not earning and first is None:
            break
        win = first or choose_winner(earning)
        if settings.discover:
            rival = _term(fit_pts, cur_fit, eval_pts, cur_held or cur_fit, lead, settings.seed,
                          floor, n_eff_held if held_pts else n_eff_fit)
            ex_win = math.sqrt(max(win.error_after ** 2 - floor ** 2, 0.0))
            ex_term = math.sqrt(max(rival.error_after ** 2 - floor ** 2, 0.0))
            if (rival.earns and rival.group != "velocity"
                    and ex_term < TERM_PREFERENCE * ex_win):
                say(f"round {rnd}: {win.effect} earns ({win.error_after:.3f} %) but a data-driven "
                    f"term explains the residual far better ({rival.error_after:.3f} %): "
                    f"{rival.description}")
                win.earns = False
                break
        effects.append(win.effect)
        remaining.remove(win.effect)
        cur_rig, cur_params = win.rig, dict(win.fit.parameters)
        cur_fit = win.predictions[:len(fit_pts)]
        cur_held = win.predictions[len(fit_pts):]
        n_eff_fit = effective_samples(fit_pts, cur_fit)
        n_eff_held = effective_samples(held_pts, cur_held) if held_pts else math.nan
        cur_err = win.error_after
        steps.append({"effect": win.effect, "error_after": cur_err,
                      "excess_reduction": win.excess_reduction,
                      "sse_excess_reduction": win.sse_reduction,
                      "parameters": win.parameters})
        if joint is not None and win is not first:  # the path is complete: one step
            prev = steps.pop(-2)
            steps[-1] = {"effect": f"{prev['effect']} + {win.effect}", "error_after": cur_err,
                         "excess_reduction": excess_reduction(joint[1], cur_err, floor),
                         "parameters": {**prev["parameters"], **win.parameters},
                         "joint": True}
            joint = None
        say(f"round {rnd}: added {win.effect}, {evaluation} error {cur_err:.3f} %")
        if not remaining:
            break
    if joint is not None:  # the path was not completed: its first step is not named
        (cur_rig, cur_params, cur_fit, cur_held, n_eff_fit, n_eff_held, cur_err, effects,
         steps, remaining) = joint[0]
        note = (f"the look-ahead path was not completed: its first step is not named "
                f"(error back to {cur_err:.3f} %)")
        say(note)
        notes.append(note)
    term = None
    if settings.discover:
        term = _term(fit_pts, cur_fit, eval_pts, cur_held or cur_fit, lead, settings.seed,
                     floor, n_eff_held if held_pts else n_eff_fit)
        if term.columns:
            say(f"term: {term.description}; {evaluation} error {term.error_before:.3f} -> "
                f"{term.error_after:.3f} % ({'earns' if term.earns else 'does not earn'})")
    if effects:
        effect = " + ".join(effects)
    elif cut:  # nothing named before the cut: the completed work does not say "none"
        effect = UNDECIDED
    else:
        effect = NONE_OF_CATALOGUE if term is not None and term.earns else "none"
    loc1 = localise(fit_pts + held_pts, cur_fit + cur_held, lead_m_per_rad=lead) \
        if effects else None
    ok = base.success and not cut and all(c.fit is not None and c.fit.parameters
                                          for c in all_cands if c.fitted)
    msg = (f"effect {effect}: relative force error on {evaluation} "
           f"{err0:.3f} % -> {cur_err:.3f} % (noise floor {floor:.3f} %)")
    if cut:
        msg += f"; partial answer — {cut}"
        notes.append(cut)
    if effect == NONE_OF_CATALOGUE:
        msg += f"; proposed term: {term.description}"
    validation = None
    if evaluation == "validation set" and not rig.has_generator:
        from .openloop import validation_summary
        from .openloop import BEST_PUBLISHED_MM, direction_dependent
        fitted = {c.effect: c.fit.parameters for c in all_cands
                  if c.fitted and c.fit is not None and c.fit.parameters and c.round == 1}
        validation = validation_summary(held_pts[0].test, base.parameters, cur_params, err0,
                                        cur_err, fitted)
        asym = [c for c in all_cands if c.effect == "asymmetric_friction" and c.fitted
                and c.fit is not None and c.fit.parameters]
        if asym:
            validation["direction_dependent"] = direction_dependent(asym[-1].fit)
        msg += (f"; open-loop position error on the validation record (the benchmark's "
                f"metric) {validation['open_loop_final']['rms_mm']:.2f} mm "
                f"(reference IDIM-LS parameters "
                f"{validation['open_loop_reference_parameters']['rms_mm']:.2f} mm, best "
                f"published {BEST_PUBLISHED_MM} mm)")
    return DiscrepancyResult(
        ok, msg, effect, err0, cur_err, evaluation, all_cands, base, rig, fit_pts, held_pts,
        base_fit_pred + base_held_pred, loc0, loc1, {"fit": n_eff_fit, "heldout": n_eff_held},
        time.perf_counter() - t_start, str(getattr(data, "path", "")), effects, steps, term,
        floor, validation, notes, cut)


def _flexibility_round(fit_pts, cur_fit, held_pts, cur_held, cur_rig, cur_params, comps,
                       scores) -> tuple | None:
    """The flexibility of a rig without generator fitted by variable projection
    (:mod:`.flexibility`), as the ``(name, FitOutcome, fit outputs, held-out outputs,
    rig)`` a generic re-identification returns; its score (share of the fit residual
    explained) set in ``scores``.  None when it cannot join the rig."""
    from .fit import FitOutcome
    from .flexibility import fit_flexibility
    comp = comps["flexibility"]
    if not compatible(cur_rig, comp):
        return None
    t0 = time.perf_counter()
    out = fit_flexibility(fit_pts, cur_fit, held_pts, cur_held, cur_rig, cur_params,
                          start_hz=comp.frequency_hz)
    r0 = sum(float(np.sum(((pt.y[0] - yp[0]) / pt.sigma[0]) ** 2))
             for pt, yp in zip(fit_pts, cur_fit))
    crig = cur_rig.with_components([*cur_rig.components, comp])
    n_obs = sum(pt.y.shape[1] for pt in fit_pts)
    if not out["parameters"]:
        neg = out.get("best_negative") or {}
        scores["flexibility"] = {"score": 0.0, "chi2": 0.0, "columns": 1, "applicable": True}
        res = FitOutcome(False, "variable projection: every resonance asks for a negative load "
                         f"mass (best {neg.get('flex_load_mass_kg', math.nan):.3g} kg at "
                         f"{neg.get('flex_frequency_hz', math.nan):.3g} Hz): no flexibility",
                         {}, [], math.inf, math.inf, n_obs, [], time.perf_counter() - t0)
        return ("flexibility", res, [], [], crig)
    r1 = sum(float(np.sum(((pt.y[0] - yp[0]) / pt.sigma[0]) ** 2))
             for pt, yp in zip(fit_pts, out["fit_pred"]))
    scores["flexibility"] = {"score": max(0.0, 1.0 - r1 / r0) if r0 > 0 else 0.0,
                             "chi2": max(r0 - r1, 0.0), "columns": 1, "applicable": True}
    fp = out["parameters"]
    lo, hi = out["intervals"]["flex_load_mass_kg"]
    sd = (hi - lo) / (2 * 1.96)
    params = {**cur_params, **{k: fp[k] for k in ("flex_load_mass_kg", "flex_frequency_hz",
                                                  "flex_damping_ratio")}}
    note = (f"variable projection: resonance {fp['flex_frequency_hz']:.3g} Hz, damping ratio "
            f"{fp['flex_damping_ratio']:.2g}, stiffness {fp['flex_stiffness_N_per_m']:.3g} N/m"
            + ("; the unconstrained best asks for a negative load mass "
               f"({out['best_negative']['flex_load_mass_kg']:.3g} kg at "
               f"{out['best_negative']['flex_frequency_hz']:.3g} Hz)"
               if out.get("negative_mass") else ""))
    res = FitOutcome(True, note, params, ["flex_load_mass_kg"], r1 / n_obs, r1, n_obs,
                     [{"flexibility": {k: v for k, v in out.items()
                                       if k not in ("fit_pred", "eval_pred")}}],
                     time.perf_counter() - t0, np.array([[sd * sd]]),
                     out.get("covariance_info"))
    return ("flexibility", res, out["fit_pred"], out["eval_pred"], crig)


#: A catalogue effect that earns is still not named when the data-driven term leaves
#: less than this share of the effect's remaining error above the noise floor (the
#: catalogue name would point at the wrong part: e.g. backlash for a lagging force
#: channel).  Not applied to a term of the ``velocity`` group: a friction law of another
#: shape is what the catalogue's friction effects are (its constant column *is* a
#: direction-dependent Coulomb level, collinear with the offset).
TERM_PREFERENCE = 0.5


def _term(fit_pts, fit_pred, eval_pts, eval_pred, lead, seed, floor, n_eff) -> TermProposal:
    """The data-driven term of the current residual, judged by the decision rule —
    none when the residual of the fit tests is white (Ljung–Box, :mod:`.evidence`):
    a term fitted to a white residual is fitted to noise."""
    white, p = residual_is_white(fit_pts, fit_pred)
    if white:
        return TermProposal(True, f"the residual is white (Ljung-Box p = {p:.2g} > "
                                  f"{WHITE_P:g} on every fit test): no term proposed",
                            description="none (white residual)")
    term = discover_term(fit_pts, fit_pred, eval_pts, eval_pred, lead_m_per_rad=lead, seed=seed)
    if term.columns:
        d_b = _dbic(term.sse_after, term.sse_before, len(term.columns), n_eff)
        term.earns = earns(term.error_before, term.error_after, floor, d_b, d_b)
    return term

