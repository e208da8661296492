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
   rounds (after the channel members below) the base model's friction law is offered
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
:func:`prepare_search_tests` (1), :func:`fit_baseline` (2–3), :func:`name_force_lag`
(the ``force_lag`` member, before the rounds), :func:`adopt_base_presliding` (the
presliding transition), :func:`~.search.run_rounds` (4–7),
:func:`~.terms.propose_term` (8) and :func:`assemble_result`.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...datasets.bench_format import BenchData, BenchDataWarning, load_bench
from ...utils.process import single_threaded_blas
from ..identify_options import MIN_RESOLVED_SAMPLES
from .candidates import CANDIDATES, try_drive_lag, try_lag
from .budget import budget_reached, budget_set, cut_reason, fits_charged
from .executor import cluster_set
from .evidence import effective_samples, force_error_percent, force_noise_floor_percent
from ..fit_result import FitResult
from .fit import fit_group
from .prepared import prepare_tests
from .rig import Rig, linear_baseline, predict
from .localise import Localisation, localise
from .prepared import decimated, decimation_factor
from .results import (
    NONE_OF_CATALOGUE,
    UNDECIDED,
    CandidateResult,
    DiscrepancyResult,
    DiscrepancySettings,
)
from .lag_rival import lag_rival
from .search import SearchState, SearchTests, run_rounds
from .split import crop_test, load_split, spread_within
from .presliding import PreslidingLaw, adopt_presliding
from .terms import TermProposal, names_an_effect, propose_term
from .voltage_skew import VoltageSkew, find_voltage_skew, realign_voltage
from .criterion import DEFAULT_CRITERION, Criterion
from .judge import withdraw

__all__ = ["run_discrepancy", "load_data", "prepare_search_tests", "fit_baseline", "Baseline",
           "name_force_lag", "name_drive_lag", "assemble_result", "BASELINE_MAX_SAMPLES",
           "CANDIDATE_MAX_SAMPLES", "baseline_decimation", "check_voltage_skew",
           "adopt_base_presliding"]


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
    with single_threaded_blas(), budget_set(settings.max_member_fits, settings.wall_cap_s), \
            cluster_set(settings.scheduler):
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
    skew = None
    if tests.rig.has_generator:
        state, skew = check_voltage_skew(tests, base, state, say, notes, settings.criterion)
    if "drive_lag" in settings.candidates and not tests.rig.has_generator:
        state = name_drive_lag(tests, base, state, settings, say, all_cands, notes)
    if "drive_lag" in state.effects and "force_lag" in settings.candidates:
        # a channel delay would describe the same lead of the recorded force again
        note = ("force_lag not searched: the drive lag already describes the recorded "
                "force's lead")
        say(note)
        notes.append(note)
    elif settings.discover and "force_lag" in settings.candidates:
        state = name_force_lag(tests, base, state, settings, say, all_cands, notes)
    law = None
    if settings.presliding:
        law = adopt_base_presliding(tests, base, state, say, notes, settings.criterion)
    state = run_rounds(tests, state, settings, say, notes, all_cands)
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
                          time.perf_counter() - t_start, raw, skew)
    res.baseline_presliding = law.as_dict() if law is not None else None
    res.criterion = settings.criterion
    res.member_fits = fits_charged()
    if law is not None and law.adopted:
        res.message += (f"; the base model's friction has a presliding transition "
                        f"({tests.evaluation} error without it {law.error_before:.3f} %)")
    return res


def adopt_base_presliding(tests: SearchTests, base: Baseline, state: SearchState, say,
                          notes: list[str], criterion: Criterion = DEFAULT_CRITERION
                          ) -> PreslidingLaw:
    """The presliding transition of the base model's friction law
    (:func:`~.presliding.adopt_presliding`), tried on the model that enters the rounds.
    When adopted, the state's and the baseline's predictions get their presliding term
    (``state`` and ``base`` changed in place: the error, the effective sample sizes and
    the localisation are of the corrected model) and ``tests.presliding`` carries the
    law to every model the search judges."""
    law = adopt_presliding(tests.fit_pts, state.fit_pred, tests.held_pts, state.held_pred,
                           tests.floor, state.n_eff_fit, state.n_eff_held,
                           criterion=criterion)
    say(law.message)
    notes.append(law.message)
    if not law.adopted:
        return law
    tests.presliding = law
    fit_pts, held_pts = tests.fit_pts, tests.held_pts
    state.fit_pred, state.held_pred = law.correct(fit_pts, state.fit_pred, held_pts,
                                                  state.held_pred)
    state.error = force_error_percent(tests.eval_pts, state.eval_pred())
    state.n_eff_fit = effective_samples(fit_pts, state.fit_pred)
    state.n_eff_held = effective_samples(held_pts, state.held_pred) if held_pts else math.nan
    if not state.effects:
        base.error = state.error
    base.fit_pred, base.held_pred = law.correct(fit_pts, base.fit_pred, held_pts,
                                                base.held_pred)
    base.localisation = localise(fit_pts + held_pts, base.fit_pred + base.held_pred,
                                 lead_m_per_rad=tests.lead_m_per_rad)
    return law


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


@dataclass
class Baseline:
    """The identified base model: its fit, simulated outputs on the fit and held-out
    tests, effective sample sizes, the localisation of its residual and its
    relative force error on the evaluation tests (%)."""

    fit: FitResult
    rig: Rig
    fit_pred: list
    held_pred: list
    n_eff_fit: float
    n_eff_held: float
    localisation: Localisation
    error: float

    def state(self, settings: DiscrepancySettings) -> SearchState:
        """The search's start: the base model, every catalogue candidate remaining."""
        return SearchState(self.rig, dict(self.fit.parameters), self.fit_pred, self.held_pred,
                           self.n_eff_fit, self.n_eff_held, self.error, [], [],
                           [n for n in settings.candidates if n in CANDIDATES])


def fit_baseline(tests: SearchTests, settings: DiscrepancySettings, say) -> Baseline:
    """Identify the base model on the fit tests from a linear least-squares start,
    simulate it on every test and localise its residual."""
    rig, fit_pts, held_pts = tests.rig, tests.fit_pts, tests.held_pts
    lb = linear_baseline(fit_pts, rig)
    k = baseline_decimation(fit_pts, rig)
    base = fit_group([decimated(pt, k) for pt in fit_pts], rig, [lb], max_iter=settings.max_iter)
    if not base.parameters:
        raise RuntimeError(f"baseline identification failed: {base.message}")
    say(f"baseline: {base.message}, chi2/N {base.objective:.3g} ({base.seconds:.1f} s"
        + (f"; collocation on every {k}th sample of the fit tests" if k > 1 else "") + ")")
    fit_pred = predict(fit_pts, rig, base.parameters)
    held_pred = predict(held_pts, rig, base.parameters) if held_pts else []
    loc0 = localise(fit_pts + held_pts, fit_pred + held_pred,
                    lead_m_per_rad=tests.lead_m_per_rad)
    n_eff_fit = effective_samples(fit_pts, fit_pred)
    n_eff_held = effective_samples(held_pts, held_pred) if held_pts else math.nan
    err0 = force_error_percent(tests.eval_pts, held_pred or fit_pred)
    return Baseline(base, rig, fit_pred, held_pred, n_eff_fit, n_eff_held, loc0, err0)


#: The baseline's collocation fit uses at most this many samples of the fit tests (every
#: k-th sample, :func:`~.prepared.decimated`).  The cost of building the collocation NLP
#: grows with the square of its samples (≈ 50 s for 15 000, 7 s for 5 000 on the 2-core
#: machine), while the rigid model's only state, the winding current, is quasi-static
#: at any such step (L/R ≈ 0.2 ms): the decimated fit differs from the full one by the
#: sampling error of fewer samples (held-out error 11.75 % full, 11.79 % on every 4th
#: sample, on a 16-test mixed campaign).  Every prediction, error and statistic the
#: decision uses is a simulation on every sample.
BASELINE_MAX_SAMPLES = 4000


#: A cap on the samples of the candidate fits (collocation on every sample: an effect may
#: ring or ripple at hundreds of Hz): ``max_fit_tests`` spread over the fit tests, fewer
#: while they hold more (:func:`~.split.spread_within`); None: no cap.  Off: a cap of 6000
#: samples left the embedded data's full configuration with two fit tests, and its backlash
#: fit then depended on the platform's floating point (gap +0.1 % on one build of the same
#: package versions, +12.8 % on another).  The candidates are judged, as always, by
#: simulation on every fit and held-out test.
CANDIDATE_MAX_SAMPLES: int | None = None


def baseline_decimation(fit_pts, rig: Rig) -> int:
    """The step k of :data:`BASELINE_MAX_SAMPLES` for a model with states (collocation);
    1 for a model without (a least-squares fit, whose cost is linear)."""
    return decimation_factor(fit_pts, BASELINE_MAX_SAMPLES) if rig.model().n_states else 1


def check_voltage_skew(tests: SearchTests, base: Baseline, state: SearchState, say,
                       notes: list[str], criterion: Criterion = DEFAULT_CRITERION
                       ) -> tuple[SearchState, VoltageSkew | None]:
    """The voltage-skew check (:func:`~.voltage_skew.find_voltage_skew`) on the baseline;
    when one delay of the voltage record explains the voltage residual, every test's
    voltage is re-aligned from here on (``tests`` changed in place; the model's outputs
    are unchanged — the same samples — and the effective sample sizes are recomputed).
    Returns the state and the check (None: no voltage channel, or no delay is better
    than none)."""
    skew = find_voltage_skew(tests.fit_pts, state.fit_pred, tests.held_pts, state.held_pred,
                             state.n_eff_fit, state.n_eff_held, tests.rig.harvester,
                             criterion)
    if skew is None:
        return state, None
    say(skew.message)
    notes.append(skew.message)
    if not skew.found:
        return state, skew
    fit_ids = {id(pt): k for k, pt in enumerate(tests.fit_pts)}
    sub_idx = [fit_ids[id(pt)] for pt in tests.sub_pts]
    tests.fit_pts = realign_voltage(tests.fit_pts, skew.delay_s)
    tests.held_pts = realign_voltage(tests.held_pts, skew.delay_s)
    tests.sub_pts = [tests.fit_pts[k] for k in sub_idx]
    state.n_eff_fit = effective_samples(tests.fit_pts, state.fit_pred)
    state.n_eff_held = (effective_samples(tests.held_pts, state.held_pred)
                        if tests.held_pts else math.nan)
    return state, skew


def name_force_lag(tests: SearchTests, base: Baseline, state: SearchState,
                   settings: DiscrepancySettings, say, all_cands: list,
                   notes: list[str] | None = None) -> SearchState:
    """The ``force_lag`` member (:func:`~.candidates.force_lag.try_lag`) tried on the
    baseline; when it earns, the tests are re-aligned from here on (``tests`` and
    ``base``'s outputs changed in place: the report compares on the re-aligned tests)
    and the state starts from the refitted baseline.  The delay is not named when a
    member the first round would re-identify, fitted on the record as it is, earns and
    leaves a lower held-out error (:func:`~.lag_rival.lag_rival`)."""
    if budget_reached():
        state.cut = (f"{cut_reason()} before the force_lag "
                     f"member was tried: it was not tried")
        say(state.cut)
        return state
    lagged = try_lag(tests.fit_pts, tests.held_pts, tests.rig, base.fit, state.fit_pred,
                     state.held_pred, tests.floor, state.n_eff_fit, state.n_eff_held,
                     base.error, settings, say,
                     decimation=baseline_decimation(tests.fit_pts, tests.rig))
    if lagged is None:
        return state
    fit_pts, held_pts, base_l = lagged.fit_pts, lagged.held_pts, lagged.baseline
    cur_fit, cur_held, cur_err = lagged.fit_pred, lagged.held_pred, lagged.error
    cand = CandidateResult(**lagged.fields)
    all_cands.append(cand)
    rival = lag_rival(tests, state, settings, cur_err, say, notes if notes is not None else [])
    if rival is not None:
        withdraw(cand, "")
        note = (f"force_lag: not named — {rival.effect}, fitted on the record as it is, "
                f"earns and leaves {rival.error_after:.3f} % against the delay's "
                f"{cur_err:.3f} %: the member's physics accounts for the lead without "
                f"re-aligning the record")
        say(note)
        if notes is not None:
            notes.append(note)
        return state
    tests.fit_pts, tests.held_pts = fit_pts, held_pts
    state.params = dict(base_l.parameters)
    state.fit_pred, state.held_pred, state.error = cur_fit, cur_held, cur_err
    state.effects.append("force_lag")
    state.steps.append({"effect": "force_lag", "error_after": cur_err,
                        "excess_reduction": cand.excess_reduction,
                        "parameters": cand.parameters})
    state.n_eff_fit = effective_samples(fit_pts, cur_fit)
    state.n_eff_held = effective_samples(held_pts, cur_held) if held_pts else math.nan
    tests.sub_pts = spread_within(fit_pts, settings.max_fit_tests, CANDIDATE_MAX_SAMPLES)
    base.fit_pred = predict(fit_pts, tests.rig, base.fit.parameters)
    base.held_pred = predict(held_pts, tests.rig, base.fit.parameters) if held_pts else []
    return state


def name_drive_lag(tests: SearchTests, base: Baseline, state: SearchState,
                   settings: DiscrepancySettings, say, all_cands: list,
                   notes: list[str]) -> SearchState:
    """The ``drive_lag`` member (:func:`~.candidates.drive_lag.try_drive_lag`, a rig
    without generator) tried on the baseline; when it earns, the tests' force is the
    applied force from here on (``tests`` — with its noise floor — and ``base``'s
    outputs changed in place: later effects are judged on what remains) and the state
    starts from the baseline refitted on it."""
    if budget_reached():
        state.cut = (f"{cut_reason()} before the drive_lag "
                     f"member was tried: it was not tried")
        say(state.cut)
        return state
    driven = try_drive_lag(tests.fit_pts, tests.held_pts, tests.rig, base.fit, state.fit_pred,
                           state.held_pred, tests.floor, state.n_eff_fit, state.n_eff_held,
                           base.error, settings, say)
    if driven is None:
        return state
    fit_pts, held_pts, base_d, floor = (driven.fit_pts, driven.held_pts, driven.baseline,
                                        driven.floor)
    cur_fit, cur_held, cur_err, fields = (driven.fit_pred, driven.held_pred, driven.error,
                                          driven.fields)
    all_cands.append(CandidateResult(**fields))
    notes += driven.notes
    tests.fit_pts, tests.held_pts, tests.floor = fit_pts, held_pts, floor
    state.params = dict(base_d.parameters)
    state.fit_pred, state.held_pred, state.error = cur_fit, cur_held, cur_err
    state.effects.append("drive_lag")
    state.steps.append({"effect": "drive_lag", "error_after": fields["error_after"],
                        "error_after_on_applied_force": cur_err,
                        "excess_reduction": fields["excess_reduction"],
                        "parameters": fields["parameters"]})
    state.n_eff_fit = effective_samples(fit_pts, cur_fit)
    state.n_eff_held = effective_samples(held_pts, cur_held) if held_pts else math.nan
    tests.sub_pts = spread_within(fit_pts, settings.max_fit_tests, CANDIDATE_MAX_SAMPLES)
    base.fit_pred = predict(fit_pts, tests.rig, base.fit.parameters)  # on the applied force
    base.held_pred = predict(held_pts, tests.rig, base.fit.parameters) if held_pts else []
    return state


def assemble_result(data: BenchData, tests: SearchTests, base: Baseline, state: SearchState,
                    all_cands: list, term: TermProposal | None, notes: list[str],
                    seconds: float, raw: tuple | None = None,
                    skew: VoltageSkew | None = None) -> DiscrepancyResult:
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
