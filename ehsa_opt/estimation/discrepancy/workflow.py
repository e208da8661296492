"""The model-discrepancy workflow: localise, rank, re-identify, decide —
round after round, then propose a data-driven term for what no catalogue effect explains.

1. **Split** the tests into fit and held-out tests (every third test of the
   (load, frequency) grid, offset drawn from the seed).  A data directory with a
   ``validation/`` sub-directory (EMPS) is held out as a whole instead.  With
   fewer than 3 tests and no validation set nothing is held out and the decision
   uses all data — the result says so.
2. **Baseline**: identify the base model (friction; inertia and offset without
   generator) on the fit tests, started from a linear least-squares solution.
   With ``DiscrepancySettings.presliding`` (opt-in, ``--presliding``), before the
   rounds (after the record members below) the base model's friction law is offered
   a presliding transition (:func:`~.presliding.adopt_presliding`:
   a force term sign(v) exp(−s/ℓ) after each reversal, adopted when it earns by the
   rule of step 6); once adopted every model judged has its own such term
   (:meth:`~.presliding.PreslidingLaw.correct`), so no member earns for it.
3. **Localise** the residual (:func:`~.localise.localise`) and read initial
   values off it (the cogging period from the residual's spectrum in rotor angle,
   :func:`~.localise.best_rotor_period`).
4. **Rank** the candidates by their signature score (:func:`~.candidates.catalogue.signature_scores`).
5. **Re-identify** the top candidates (:func:`~.candidate_fit.fit_candidate`: multistart
   screened by forward simulation over the realistic ranges, effect-only stage,
   nut/bearing friction split for transmission effects, full refit, refinement
   on the simulation).
6. **Decide** (:func:`~.judge.earns`): a candidate *earns* when its refit removes
   at least the criterion's ``min_excess_reduction`` of the held-out relative force
   error above the noise floor (the error the measurement noise alone gives) and
   ΔBIC = N_eff ln(SSE_new/SSE_old) + k ln N_eff < 0 on the fit tests and on the
   held-out tests (N_eff = Σ N/τ, τ the residual autocorrelation time); for an
   effect seen in the voltage channel the same share of that channel's SSE excess,
   the force error not growing by more than the data resolve (e_n/√(2N)).  Among
   the earning candidates the one with the lowest held-out ΔBIC is added
   (:func:`~.judge.choose_winner`; between nested effects the simpler unless the
   richer's ΔBIC is lower by the criterion's ``nested_evidence``,
   :func:`~.nested.prefer_nested`).  When the best earning candidate removes less than
   :data:`~.widen.WIDEN_BELOW` of the excess, the remaining lower-ranked
   candidates are re-identified too before deciding (:func:`~.widen.should_widen`;
   fitted ahead on the workers the round's own fits leave idle, :mod:`.idle_fits`),
   and a candidate that explains the fit tests best of all but fails on the held-out
   ones (it absorbed another effect's residual) is re-identified on top of the others, or
   they on top of it: a two-step path that earns as a whole and ends below the
   default winner decides which is added first (:func:`~.lookahead.lookahead_winner`,
   :func:`~.lookahead.confounded_first`).
7. **Repeat** from 3 with the effect in the model (the remaining candidates are
   added on top of it) until nothing earns or ``max_effects`` are named.
8. **Outside the catalogue**: the remaining force residual is regressed on a
   library of physical features (:func:`~.terms.discover_term`); the term is
   reported when it earns by the same rule (a time shift only when one delay fits
   every test).  No catalogue effect earned but the term does → ``effect = "none of
   the catalogue"`` with the term in words — unless the term is a friction law of
   another shape (:func:`~.terms.names_an_effect`): then ``none``, the shape said.

:func:`run_discrepancy` runs these as named phases: :func:`load_data`,
:func:`prepare_search_tests` (1), :func:`~.baseline.fit_baseline` (2–3), the record and
law members (:func:`~.members.run_members` over :data:`~.members.RECORD_MEMBERS`: the
base friction law's dynamics when offered, the voltage record's skew, the drive's lag, the force record's delay or sensor dynamics, the
friction law's presliding transition — each fitted, judged by the criterion, and
adopted when it earns), :func:`~.search.run_rounds` (4–7),
:func:`~.terms.propose_term` (8) and :func:`assemble_result`.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import Any

from ...datasets.bench_format import BenchData, BenchDataWarning, load_bench
from ...utils.process import single_threaded_blas
from ..identify_options import MIN_RESOLVED_SAMPLES
from .baseline import CANDIDATE_MAX_SAMPLES, Baseline, fit_baseline
from .budget import budget_set, fits_charged
from .evidence import force_noise_floor_percent
from .executor import cluster_set
from .localise import localise
from .members import RECORD_MEMBERS, Context, run_members
from .prepared import prepare_tests
from .criterion import DEFAULT_CRITERION, Criterion
from .results import (
    BASE_INADEQUATE,
    NONE_OF_CATALOGUE,
    UNDECIDED,
    CandidateResult,
    DiscrepancyResult,
    DiscrepancySettings,
)
from .rig import Rig
from .search import SearchState, SearchTests, run_rounds
from .split import crop_test, load_split, spread_within
from .terms import TermProposal, names_an_effect, propose_term
from .voltage_skew import VoltageSkew

__all__ = ["run_discrepancy", "load_data", "prepare_search_tests", "fit_baseline", "Baseline",
           "assemble_result"]


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
    # process-level parallelism only (see the utility); the budget is counted in member
    # fits, the wall time a safety cap (:mod:`.budget`)
    settings = settings or DiscrepancySettings()
    with (single_threaded_blas(),
          budget_set(settings.max_member_fits, settings.wall_cap_s),
          cluster_set(settings.scheduler)):
        return _run_discrepancy(data, settings, log)


def _run_discrepancy(data: BenchData | str | Path, settings: DiscrepancySettings | None,
                     log: Any) -> DiscrepancyResult:
    t_start = time.perf_counter()
    settings = settings or DiscrepancySettings()
    say = log or (lambda msg: None)
    notes: list[str] = []
    data = load_data(data, say, notes)
    tests = prepare_search_tests(data, settings, say, notes)
    base = fit_baseline(tests, settings, say)
    state = base.state(settings)
    all_cands: list[CandidateResult] = []
    # the recorded tests (the open-loop metric's input, whatever the members change)
    raw = ([pt.test for pt in tests.fit_pts], [pt.test for pt in tests.held_pts])
    ctx = Context(tests, base, state, settings, say, notes, all_cands)
    run_members(RECORD_MEMBERS, ctx)  # the base law's dynamics first: it may replace the state
    notes.append(base.law_note)
    state = run_rounds(tests, ctx.state, settings, say, notes, all_cands)
    state = _late_laws(ctx, state)
    skew, law = ctx.skew, ctx.law  # as the record and law members left them
    term = None
    if settings.discover:
        term = propose_term(tests.fit_pts, state.fit_pred, tests.eval_pts, state.eval_pred(),
                            tests.lead_m_per_rad, settings.seed, tests.floor,
                            state.n_eff_held if tests.held_pts else state.n_eff_fit,
                            settings.criterion)
        if term.columns:
            say(f"term: {term.description}; {tests.evaluation} error "
                f"{term.error_before:.3f} -> {term.error_after:.3f} % "
                f"({'earns' if term.earns else 'does not earn'})")
    res = assemble_result(data, tests, base, state, all_cands, term, notes,
                          time.perf_counter() - t_start, raw, skew, settings.criterion)
    res.baseline_presliding = law.as_dict() if law is not None else None
    res.criterion = settings.criterion
    res.member_fits = fits_charged()
    if law is not None and law.adopted:
        res.message += (f"; the base model's friction has a presliding transition "
                        f"({tests.evaluation} error without it {law.error_before:.3f} %)")
    return res


def _late_laws(ctx: Context, state):
    """The members that say so (``offered_after_rounds``: the friction drift) and were not
    adopted before the rounds, offered once more on the model the rounds reached: a drift of the friction level hidden under an effect's larger misfit
    (a cogging's ripple) is judged on the residual that effect leaves.  The model they
    adopt is the search's last step."""
    late = [m for m in RECORD_MEMBERS
            if m.offered_after_rounds and m.name not in state.effects]
    if not late or not state.effects:
        return state
    ctx.state = state
    run_members(late, ctx)
    return ctx.state


def load_data(data: BenchData | str | Path, say, notes: list[str]) -> BenchData:
    """The bench data, loaded leniently from a directory: the bench checks compare the
    signals with the rigid model (e.g. the voltage the motion implies); data that
    disagree with it are what this workflow diagnoses, so those checks are reported
    (said and noted), not fatal (syntax and layout errors still are)."""
    if isinstance(data, BenchData):
        return data
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BenchDataWarning)
        data = load_bench(data, lenient=True)
    for w in caught:
        if issubclass(w.category, BenchDataWarning):
            note = (f"bench check (the data are used anyway — a disagreement with the "
                    f"rigid model is what this workflow diagnoses): {w.message}")
            say(note)
            notes.append(note)
    return data


def prepare_search_tests(data: BenchData, settings: DiscrepancySettings, say,
                         notes: list[str]) -> SearchTests:
    """Split, crop and prepare the tests (:mod:`.split`), leave out the tests with too
    few resolved samples (noted), and the noise floor of the evaluation tests."""
    rig = Rig(data.harvester, data.has_generator, ())
    fit_t, held_t, evaluation = load_split(data, settings)
    if settings.max_samples is not None:
        fit_t = [crop_test(t, settings.max_samples) for t in fit_t]
        held_t = [crop_test(t, settings.max_samples) for t in held_t]
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
    sub_pts = spread_within(fit_pts, settings.max_fit_tests, CANDIDATE_MAX_SAMPLES)
    say(f"{len(fit_pts)} fit tests ({len(sub_pts)} for candidate fits), "
        f"{len(held_pts)} {evaluation} tests")
    vdir = (Path(str(getattr(data, "path", "") or ".")) / "validation"
            if evaluation == "validation set" else None)
    return SearchTests(rig, fit_pts, held_pts, sub_pts,
                       force_noise_floor_percent(held_pts or fit_pts), evaluation, vdir)


def assemble_result(data: BenchData, tests: SearchTests, base: Baseline, state: SearchState,
                    all_cands: list, term: TermProposal | None, notes: list[str],
                    seconds: float, raw: tuple | None = None,
                    skew: VoltageSkew | None = None,
                    criterion: Criterion = DEFAULT_CRITERION) -> DiscrepancyResult:
    """The named effect(s), the message, the localisation of the final residual and,
    on a validation set of a rig without generator, the open-loop validation
    (``raw``: the recorded fit and held-out tests, before any member changed them)."""
    fit_pts, held_pts, evaluation, floor = (tests.fit_pts, tests.held_pts, tests.evaluation,
                                            tests.floor)
    effects, err0, cur_err = state.effects, base.error, state.error
    if effects:
        effect = " + ".join(effects)
    elif state.cut:  # nothing named before the time budget: the work done does not say "none"
        effect = UNDECIDED
    else:
        skewed = skew is not None and skew.found
        effect = NONE_OF_CATALOGUE if names_an_effect(term) or skewed else "none"
        # "none" claims the model is adequate to the noise: not when the error stays far
        # above it (a term that names what is missing answers "none of the catalogue")
        if effect == "none" and cur_err > criterion.inadequate_ratio * floor:
            effect = BASE_INADEQUATE
    loc1 = localise(fit_pts + held_pts, state.fit_pred + state.held_pred,
                    lead_m_per_rad=tests.lead_m_per_rad) if effects else None
    ok = base.fit.success and not state.cut and all(c.fit is not None and c.fit.parameters
                                                    for c in all_cands if c.fitted)
    msg = (f"effect {effect}: relative force error on {evaluation} "
           f"{err0:.3f} % -> {cur_err:.3f} % (noise floor {floor:.3f} %)")
    if state.cut:
        msg += f"; partial answer — {state.cut}"
        notes.append(state.cut)
    if skew is not None and skew.found:
        word = "late" if skew.delay_s > 0 else "early"
        msg += (f"; the voltage record is {1e3 * abs(skew.delay_s):.1f} ms {word} against "
                f"force and displacement (a skew of the acquisition, one delay for every "
                f"test; re-aligned before the rounds, no catalogue member named for it)")
    if effect == NONE_OF_CATALOGUE and names_an_effect(term):
        msg += f"; proposed term: {term.description}"
    if effect == BASE_INADEQUATE:
        how = (f"the residual's physical support: {term.description} ({evaluation} error "
               f"{term.error_before:.3f} -> {term.error_after:.3f} % with that term"
               f"{'' if term.earns else ', which does not earn'})"
               if term is not None and term.columns else
               "no feature of the term library describes the residual")
        note = (f"no member earns, yet the {evaluation} error stays "
                f"{cur_err / floor:.1f} × the noise floor (above "
                f"{criterion.inadequate_ratio:g} ×): the base model cannot represent the rig "
                f"there; {how}")
        msg += f"; {note}"
        notes.append(note)
    if (not effects and not state.cut and term is not None and term.earns
            and not names_an_effect(term)):
        # a friction law of another shape: said, but it is not an effect the rig lacks
        note = (f"no effect named: the term that explains the residual is a friction law "
                f"of another shape than the baseline's — {term.description} ({evaluation} "
                f"error {term.error_before:.3f} -> {term.error_after:.3f} % with that term)")
        msg += f"; {note}"
        notes.append(note)
    if term is not None and term.refused:
        notes.append(term.refused)
    validation = None
    if evaluation == "validation set" and not tests.rig.has_generator:
        raw = raw or ([pt.test for pt in fit_pts], [pt.test for pt in held_pts])
        validation, extra = _open_loop_validation(raw, base, state, all_cands)
        msg += extra
    return DiscrepancyResult(
        ok, msg, effect, err0, cur_err, evaluation, all_cands, base.fit, tests.rig, fit_pts,
        held_pts, base.fit_pred + base.held_pred, base.localisation, loc1,
        {"fit": state.n_eff_fit, "heldout": state.n_eff_held}, seconds,
        str(getattr(data, "path", "")), effects, state.steps, term, floor, validation, notes,
        state.cut, skew.as_dict() if skew is not None else None)


def _open_loop_validation(raw: tuple, base: Baseline, state: SearchState,
                          all_cands: list) -> tuple[dict, str]:
    """The open-loop validation of the EMPS benchmark (:mod:`.openloop`) on the
    recorded tests ``raw`` = (fit tests, held-out tests), with the metric after an
    output-error refit (:mod:`.outputerror`) of the baseline and of the model after
    each named effect, and the sentence the message gains."""
    from .openloop import BEST_PUBLISHED_MM, direction_dependent, validation_summary
    from .candidates.drive_lag import hold_and_lag
    from .candidates.mode_band import fit_mode
    from .outputerror import output_error_rows
    fit_raw, held_raw = raw
    # a named drive lag acts on the force of every model simulated after it
    drive = next((dict(c.parameters) for c in all_cands
                  if c.effect == "drive_lag" and c.earns), {})
    fitted: dict = {}  # each effect's first fit (on the model before the rounds)
    for c in all_cands:
        if c.fitted and c.fit is not None and c.fit.parameters:
            fitted.setdefault(c.effect, {**drive, **c.fit.parameters})
    validation = validation_summary(held_raw[0], base.fit.parameters, {**state.params, **drive},
                                    base.error, state.error, fitted)
    # the benchmark table: the models of the ladder fitted by output error on the fit
    # record, started from the final inverse model (and the published values)
    if len(fit_raw) == 1:
        validation["output_error"] = output_error_rows(fit_raw[0], held_raw[0],
                                                       {**state.params, **drive})
    validation["hold_and_lag"] = [hold_and_lag(t) for t in (*fit_raw, *held_raw)]
    # a mode above the drive's band, on the held-out record after its hold and lag
    validation["mode_above_drive"] = fit_mode(
        held_raw[0], tau_s=validation["hold_and_lag"][-1]["tau_beyond_hold_s"])
    asym = [c for c in all_cands if c.effect == "asymmetric_friction" and c.fitted
            and c.fit is not None and c.fit.parameters]
    if asym:
        validation["direction_dependent"] = direction_dependent(asym[-1].fit)
    oe = validation.get("output_error") or []
    return validation, (
        f"; open-loop position error on the validation record (the benchmark's "
        f"metric) {validation['open_loop_final']['rms_mm']:.2f} mm "
        f"(reference IDIM-LS parameters "
        f"{validation['open_loop_reference_parameters']['rms_mm']:.2f} mm, best "
        f"published {BEST_PUBLISHED_MM} mm)"
        + (f"; {oe[-1]['rms_mm']:.2f} mm with the parameters fitted by output error on the "
           f"fit record, the start chosen there ({oe[-1]['model']}; "
           f"{oe[0]['model']} so fitted {oe[0]['rms_mm']:.2f} mm)"
           if oe else ""))
