"""Re-identifying a candidate: one catalogue member added to a rig that may already
hold earlier effects, fitted and simulated on every test.

* :func:`fit_candidate`: the staged re-identification — starts screened by forward
  simulation (:func:`screen_starts`, with the linear friction correction of
  :func:`screen_sse`), an effect-only stage, the nut/bearing friction split for
  transmission effects (:func:`split_friction`), the full refit (collocation, or
  Gauss–Newton on the simulation for stiff contacts) and the match of the fit to
  its forward simulation;
* :func:`fit_member` / :func:`fit_members`: a catalogue member fitted on the
  fit-test subset by its own recipe and simulated on all tests (in parallel
  processes when asked);
* :func:`reproducibility`: whether the fitted simulation depends on the
  integration error itself.

Inside a fit (screening, friction split, Gauss–Newton on the simulation, the
comparisons between stages) a smooth rig is simulated by the compiled Radau IIA map
(:func:`~.rig.predict_map`, :func:`~.rig.fit_predictor`), a rig with a contact by CVODES;
the outputs :func:`fit_member` returns for the decision are CVODES simulations.
"""

from __future__ import annotations

import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from typing import Sequence

import numpy as np

from .candidates import CANDIDATES, absorbed_columns, signature_scores
from .criterion import DEFAULT_CRITERION, DEFAULT_POLICY
from .executor import fit_on_cluster, remote
from .budget import note_cut, past_deadline, recording_cuts, time_left_s
from .candidate_evidence import measure_candidate
from .evidence import normalised_sse
from .judge import judge_candidate, withdraw
from ..fit_result import FitResult
from .fit import fit_group
from .prepared import PreparedTest
from .rig import Rig, fit_predictor, map_suits, predict, uniform_grid
from .polish import polish
from .spread import spread_simulations

__all__ = ["fit_candidate", "not_fitted", "judge_fit", "CUT_RECORD", "screen_starts", "screen_sse", "split_friction",
           "best_friction_share", "reproducibility", "fit_member", "fit_members", "signature_scores_in",
           "rig_on_simulation", "simulation_recipe", "SIMULATION_RECIPE_MIN_SAMPLES",
           "FRICTION_SHARES", "MISMATCH_RATIO", "REFINE_SUBSTEPS",
           "SIMULATION_REFIT_ITER"]


def screen_sse(prepared: Sequence[PreparedTest], rig: Rig, preds: Sequence[np.ndarray],
                baseline: dict[str, float]) -> float:
    """SSE left after a linear friction correction (what a refit of F_C, f_v and the
    Stribeck amplitude would absorb anyway) — a fair screen of effect starts
    simulated with the baseline friction, which absorbed part of the effect."""
    u_brk = float(baseline.get("nut_breakaway_velocity_m_per_s", 0.01))
    r = np.concatenate([((pt.y - yp) * pt.wnorm).ravel()
                        for pt, yp in zip(prepared, preds)])
    B = np.vstack([absorbed_columns(pt, rig, u_brk) for pt in prepared])
    coef, *_ = np.linalg.lstsq(B, r, rcond=None)
    return float(np.sum((r - B @ coef) ** 2))




#: Bearing shares of the lumped rod friction screened for transmission effects.
FRICTION_SHARES: tuple[float, ...] = tuple(np.round(np.arange(0.0, 0.61, 0.05), 2))


def split_friction(params: dict[str, float], share: float, lead_m_per_rad: float
                   ) -> dict[str, float]:
    """Move a ``share`` (0–1) of the rod-equivalent friction to the bearing.

    The rod-equivalent levels F_brk + T_brk/r, F_C + T_C/r and f_v + b_v/r² are
    kept; the nut keeps ``1 − share`` of each, the bearing gets ``share`` (the
    breakaway velocities are kept).
    """
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"split_friction: share must be in [0, 1], got {share}")
    r = lead_m_per_rad
    out = dict(params)
    for nut, bear, s in (("nut_breakaway_N", "bearing_breakaway_Nm", r),
                         ("nut_coulomb_N", "bearing_coulomb_Nm", r),
                         ("nut_viscous_Ns_per_m", "bearing_viscous_Nms_per_rad", r * r)):
        total = params[nut] + params[bear] / s
        out[nut], out[bear] = (1.0 - share) * total, share * total * s
    return out


def best_friction_share(prepared: Sequence[PreparedTest], rig: Rig,
                         params: dict[str, float]) -> float:
    """The bearing share of :data:`FRICTION_SHARES` whose forward simulation fits best."""
    r = rig.harvester.lead_m_per_rad
    sim = fit_predictor(rig)
    sses = [normalised_sse(prepared, sim(prepared, rig, split_friction(params, sh, r)))
            for sh in FRICTION_SHARES]
    return float(FRICTION_SHARES[int(np.nanargmin(sses))])




def screen_starts(fit_pts: Sequence[PreparedTest], rig: Rig, crig: Rig, starts: Sequence[dict],
            shares: Sequence[float], refine: Sequence[dict]) -> dict:
    """The start whose forward simulation fits best (after the linear friction
    correction of :func:`screen_sse`).

    Each start is simulated at every bearing share of the friction in ``shares``
    (a transmission effect such as a gap separates the rotor from the rod: how much
    friction acts on the rotor side decides how far it coasts through the gap, and
    the rigid baseline lumped it all into the nut).  The best one is then varied by
    each override of ``refine`` (e.g. the contact stiffness over its decades), and
    the best of those is returned.
    """
    r = rig.harvester.lead_m_per_rad
    sim = fit_predictor(crig)

    def cost(st: dict) -> float:
        return screen_sse(fit_pts, rig, sim(fit_pts, crig, st), st)

    pool = [split_friction(st, sh, r) if sh > 0 else dict(st) for st in starts for sh in shares]
    sses = []
    for st in pool:  # at the run's deadline: the best of those simulated so far
        sses.append(cost(st))
        if past_deadline():
            if len(sses) < len(pool) or refine:
                note_cut("screening of starts", len(sses), True)
            break
    best, sbest = pool[int(np.nanargmin(sses))], float(np.nanmin(sses))
    for k, over in enumerate(refine):
        if past_deadline():
            if k:  # (the cut of the pool was noted already when k == 0)
                note_cut("screening of starts", len(sses) + k, True)
            break
        st = {**best, **over}
        c = cost(st)
        if c < sbest:
            best, sbest = st, c
    return best


#: Where a fit's :attr:`FitResult.records` hold the stages the run's safety cap cut
#: (:func:`fit_candidate`, :func:`not_fitted`).
CUT_RECORD = "cut_at_deadline"


def not_fitted(res: FitResult | None) -> str:
    """Why the fit ``res`` is *not fitted* — the run's deadline cut it before its
    effect's parameters left their (screened) start point, i.e. before one Gauss–Newton
    step of any stage that frees them was accepted (:func:`fit_candidate`) — or ``""``
    when it is fitted (or was not cut).  Such a member is judged at its start point,
    which says nothing about the effect: it cannot earn, cannot open or complete a
    look-ahead path and is reported as work left at the budget."""
    for rec in ([res.records] if res is not None else ()):
        cut = rec.get(CUT_RECORD) if isinstance(rec, dict) else None
        if cut and not cut.get("moved", True):
            stages = "; ".join(f"{c['stage']} after {c['simulations']} simulation"
                               + ("s" if c["simulations"] != 1 else "")
                               for c in cut.get("stages", ()))
            return (f"its fit was cut by the time budget at its start point ({stages}): "
                    f"not fitted")
    return ""


def judge_fit(c, out: tuple, **judge) -> None:
    """The evidence on the member fit ``out`` (:func:`fit_member`,
    :func:`~.candidate_evidence.measure_candidate`) into the candidate result ``c`` and its
    verdict (:func:`~.judge.judge_candidate`; ``judge``: the current model's measures,
    :func:`~.search.judge_context`), then the deadline's verdict: a fit :func:`not_fitted`
    (cut at its start point) keeps its measures for the report but does not earn
    (``c.cut_at_deadline`` says why; the search counts it as work left at the budget)."""
    ev = measure_candidate(c, out, **judge)
    if ev is not None:
        judge_candidate(c, ev, cur_err=judge["cur_err"], floor=judge["floor"],
                        say=judge["say"], criterion=judge.get("criterion", DEFAULT_CRITERION))
    why = not_fitted(out[1])
    if why:
        c.cut_at_deadline = why
        withdraw(c, f"{out[0]}: {why} — it cannot earn; work left at the budget", judge["say"])


def fit_candidate(name: str, component, starts: Sequence[dict], fit_pts: Sequence[PreparedTest],
                  held_pts: Sequence[PreparedTest], rig: Rig, baseline: dict[str, float],
                  max_iter: int, *, shares: Sequence[float] = (0.0,),
                  refine: Sequence[dict] = (), full_refit: str = "collocation",
                  effect_fit: str = "collocation", log_names: Sequence[str] = (),
                  impact_fit: bool = False
                  ) -> tuple[str, FitResult, list[np.ndarray], list[np.ndarray]]:
    """Add ``component`` to ``rig`` (which may hold earlier effects) and re-identify
    (:func:`_fit_stages`).  Where the run's deadline cut a stage, the fit's ``starts``
    gain a :data:`CUT_RECORD` entry (the stages cut, with their simulations, and
    whether the effect's parameters left their screened start: ``moved``) and its
    message says so; :func:`not_fitted` reads it."""
    seen: dict = {}
    with recording_cuts() as cuts:
        name, res, pf, ph = _fit_stages(name, component, starts, fit_pts, held_pts, rig,
                                        baseline, max_iter, shares=shares, refine=refine,
                                        full_refit=full_refit, effect_fit=effect_fit,
                                        log_names=log_names, impact_fit=impact_fit, seen=seen)
    if "stopped at the run's deadline" in res.message:  # the impact-aware search
        from .impact_verdict import impact_record
        cuts.append({"stage": "impact-aware Nelder-Mead", "moved": True,
                     "simulations": int((impact_record(res) or {}).get("simulations", 0))})
    if not cuts:
        return name, res, pf, ph
    # moved: the effect's parameters left the screened start (a collocation stage, or one
    # accepted Gauss-Newton step: a cut refinement that did not move returns its start)
    start = seen.get("start")
    moved = bool(res.parameters) and (start is None or any(
        res.parameters.get(q.name) != start.get(q.name) for q in component.parameters))
    res = replace(res, records={**res.records, CUT_RECORD: {"stages": cuts, "moved": moved}},
                  message=res.message + ("; cut by the time budget" if moved else
                                         "; cut by the time budget at its start point"))
    return name, res, pf, ph


def _fit_stages(name: str, component, starts: Sequence[dict], fit_pts: Sequence[PreparedTest],
                held_pts: Sequence[PreparedTest], rig: Rig, baseline: dict[str, float],
                max_iter: int, *, shares: Sequence[float] = (0.0,),
                refine: Sequence[dict] = (), full_refit: str = "collocation",
                effect_fit: str = "collocation", log_names: Sequence[str] = (),
                impact_fit: bool = False, seen: dict | None = None
                ) -> tuple[str, FitResult, list[np.ndarray], list[np.ndarray]]:
    """The stages of :func:`fit_candidate` (``seen["start"]``: the screened start).

    Starts (effect parameters) are screened by forward simulation (each at every
    bearing share of the friction in ``shares``, the best then varied by the
    overrides in ``refine``; :func:`screen_starts`), IPOPT starts from the best; stage 1
    fits the effect parameters alone (everything else at the screened start),
    stage 2 everything (see :mod:`.workflow`): by collocation + IPOPT
    (``full_refit="collocation"``) or, for a contact effect whose full collocation
    NLP factorises slowly, on the forward simulation itself from the stage-1 point
    (``"simulation"``, :func:`_refit_on_simulation`).  Stage 1 too can run on the
    simulation (``effect_fit="simulation"``, :func:`_effect_fit_on_simulation`): for
    an elastic transmission on data it does not describe, the effect-only
    collocation NLP is degenerate (IPOPT's Hessian regularisation climbs to 1e9 and
    MUMPS re-allocates its factor for tens of minutes), while a few Gauss–Newton
    steps on two parameters from the screened start cost seconds.  ``log_names``
    are refined in log10 on the simulation (parameters spanning decades).
    ``impact_fit``: a contact effect is fitted on chaos-robust features instead when
    the data hold impacts the current model has not
    (:func:`~.impacts.fit_candidate_on_impacts`).  Returns
    the name, the fit and the simulated outputs of the fit and held-out tests
    (empty lists when the fit failed).
    """
    for what, v in (("full_refit", full_refit), ("effect_fit", effect_fit)):
        if v not in ("collocation", "simulation"):
            raise ValueError(f"fit_candidate: {what} must be 'collocation' or 'simulation', "
                             f"got {v!r}")
    crig = rig.with_components([*rig.components, component])
    defaults = component.defaults()
    if impact_fit:
        from .impacts import fit_candidate_on_impacts
        routed = fit_candidate_on_impacts(name, fit_pts, held_pts, rig, crig,
                                          {**defaults, **baseline}, split_friction)
        if routed is not None:
            return routed
    starts = [{**defaults, **baseline, **s} for s in starts] or [{**defaults, **baseline}]
    if len(starts) > 1 or len(shares) > 1 or refine:
        starts = [screen_starts(fit_pts, rig, crig, starts, shares, refine)]
    if seen is not None:
        seen["start"] = dict(starts[0])
    eff = [q.name for q in component.parameters]

    def stage1(start: dict) -> FitResult:
        if effect_fit == "simulation":
            return _effect_fit_on_simulation(fit_pts, crig, start, eff, log_names)
        return fit_group(fit_pts, crig, [start], free=eff, fixed=start, max_iter=max_iter)

    first = stage1(starts[0])
    if first.parameters and rig.has_generator and component.transmission:
        # an elastic transmission separates the rotor from the rod, so the nut/bearing
        # split of the friction (irrelevant on the rigid baseline, which lumps it all
        # into the nut) becomes identifiable - and a local optimum: screen the split by
        # forward simulation, then refit the effect at the best split
        share = best_friction_share(fit_pts, crig, first.parameters)
        if share > 0.0:
            split = split_friction(first.parameters, share, rig.harvester.lead_m_per_rad)
            again = stage1(split)
            if again.parameters:
                first = again
    earlier = [q.name for c in rig.components for q in c.parameters]
    free = rig.base_names + earlier + eff
    if rig.has_generator and any(c.transmission for c in crig.components):
        # the bearing's Stribeck velocity is poorly determined at the sample rate (the
        # rotor speed crosses it within a sample) and lets the collocation cheat
        # between samples: it stays at the baseline value - also for every candidate
        # added on top of a transmission effect, so that its refit frees only its own
        # parameters beyond the current model's (nested models: otherwise cogging was
        # named on a 0.1 mm gap for what freeing that velocity gave)
        free = [n for n in free if n != "bearing_breakaway_velocity_rad_per_s"]
    if full_refit == "simulation" and first.parameters:
        return _refit_on_simulation(name, fit_pts, held_pts, crig, first, free, log_names)
    res = fit_group(fit_pts, crig, [first.parameters] if first.parameters else starts,
                    free=free, fixed=first.parameters or starts[0], max_iter=max_iter)
    if not res.parameters and first.parameters:
        res = first  # the effect-only fit is still a valid (smaller) model
    if not res.parameters:
        return name, res, [], []
    sim = fit_predictor(crig)
    pf = sim(fit_pts, crig, res.parameters)
    if first.parameters and res is not first:
        # keep the effect-only fit when the full refit simulates worse (a collocation
        # optimum that does not reproduce under simulation)
        pf1 = sim(fit_pts, crig, first.parameters)
        if normalised_sse(fit_pts, pf1) < normalised_sse(fit_pts, pf):
            res, pf = first, pf1
    res, pf = _match_simulation(fit_pts, crig, res, pf, res.free, max_iter)
    return (name, res, pf, predict(held_pts, crig, res.parameters) if held_pts else [])


def reproducibility(fit_pts: Sequence[PreparedTest], rig: Rig, parameters: dict,
                    preds: Sequence[np.ndarray] | None = None) -> float:
    """RMS change of the noise-normalised simulated outputs between the relative
    tolerances 1e-7 (every fit's) and 1e-9: ≪ 1 for a well-posed simulation; ≫ 1 when
    the trajectory depends on the integration error itself (a stiff contact rattling
    in its gap: impacts whose timing a 1e-6 change moves by a sample), where a
    sample-wise likelihood cannot determine the contact's parameters."""
    pa = preds if preds is not None else predict(fit_pts, rig, parameters)
    pb = predict(fit_pts, rig, parameters, rtol=1e-9)
    d = np.concatenate([((ya - yb) * pt.wnorm).ravel() for pt, ya, yb in zip(fit_pts, pa, pb)])
    return float(np.sqrt(np.mean(d ** 2)))


#: Gauss-Newton iterations of the simulation refit (each costs ``len(free) + 1``
#: simulations of the fit tests).
SIMULATION_REFIT_ITER = 8


def _effect_fit_on_simulation(fit_pts: Sequence[PreparedTest], crig: Rig, start: dict,
                              eff: Sequence[str], log_names: Sequence[str] = ()
                              ) -> FitResult:
    """Stage 1 on the forward simulation: the effect parameters ``eff`` refined from
    the screened ``start`` by :func:`polish` (everything else fixed at the start),
    returned as a :class:`FitResult` (covariance from the final Jacobian)."""
    t0 = time.perf_counter()
    po = polish(fit_pts, crig, start, list(eff), max_iter=SIMULATION_REFIT_ITER,
                log_names=[n for n in log_names if n in eff], predictor=fit_predictor(crig))
    n_obs = sum(pt.y.size for pt in fit_pts)
    return FitResult(success=po.success, message=f"effect fitted on simulation: {po.message}",
                     status=po.message, parameters=dict(po.parameters), free=list(eff),
                     objective=po.sse_after / n_obs,
                     records={"simulation_fit": {"sse_before": po.sse_before,
                                                 "sse_after": po.sse_after,
                                                 "simulations": po.nfev}},
                     seconds=time.perf_counter() - t0, path="simulation", sse=po.sse_after,
                     n_obs=n_obs, covariance=po.covariance)


def _refit_on_simulation(name: str, fit_pts: Sequence[PreparedTest],
                         held_pts: Sequence[PreparedTest], crig: Rig, first: FitResult,
                         free: Sequence[str], log_names: Sequence[str] = ()
                         ) -> tuple[str, FitResult, list[np.ndarray], list[np.ndarray]]:
    """Stage 2 on the forward simulation: all ``free`` parameters refined from the
    effect-only collocation fit ``first`` by :func:`polish` (trust-region
    Gauss-Newton on the CVODES residuals, :data:`SIMULATION_REFIT_ITER` iterations).

    Used for backlash: with the friction free, the collocation NLP of a stiff
    contact factorises slowly in MUMPS (minutes and GB per case on the held-out
    grid), while the stage-1 point is already in the right basin (gap and
    stiffness screened by simulation), so a few simulated Gauss-Newton steps reach
    the optimum in seconds.  The reported intervals are the Gauss–Newton ones of
    this joint refit (all ``free`` parameters) when it improved the fit, else those
    of stage 1 (conditional on the friction at its stage-1 value).
    """
    t0 = time.perf_counter()
    sim = fit_predictor(crig)
    po = polish(fit_pts, crig, first.parameters, list(free), max_iter=SIMULATION_REFIT_ITER,
                log_names=[n for n in log_names if n in free], predictor=sim)
    pf = sim(fit_pts, crig, po.parameters)
    sse = normalised_sse(fit_pts, pf)
    # a rattling contact's impact sequence may depend on the integration error; a smooth
    # rig (simulated by the fixed-step map) cannot rattle: not checked there
    chaos = None if map_suits(crig) else reproducibility(fit_pts, crig, po.parameters, pf)
    note = ""
    if chaos is not None and chaos > 1.0:
        note = (f"; NOT REPRODUCIBLE: the simulated response changes by {chaos:.3g} noise "
                f"standard deviations (rms) between integration tolerances 1e-7 and 1e-9 - "
                f"a rattling stiff contact whose impact sequence no sample-wise fit can "
                f"follow; its stiffness and damping are not determined by this fit")
    n_obs = first.n_obs
    joint = {"free": list(po.free), "covariance": po.covariance} \
        if po.covariance is not None else {}
    res = replace(first, parameters=po.parameters, sse=sse, objective=sse / n_obs, **joint,
                  message=f"{first.message} (effect only), refined on simulation: "
                          f"{po.message}{note}",
                  records={**first.records, "simulation_refit": {
                      "sse_before": po.sse_before, "sse_after": po.sse_after,
                      "simulations": po.nfev, "free": list(free),
                      **({"tolerance_change_rms_sigma": chaos} if chaos is not None else {})}},
                  seconds=first.seconds + time.perf_counter() - t0)
    return name, res, pf, (predict(held_pts, crig, res.parameters) if held_pts else [])


#: A collocation fit whose simulated SSE exceeds its collocation SSE by more than
#: this factor is refined (finer collocation grid, then :func:`polish`).
MISMATCH_RATIO = DEFAULT_POLICY.mismatch_ratio
#: Collocation sub-intervals per sample interval for the refinement.
REFINE_SUBSTEPS = 3


def _match_simulation(fit_pts: Sequence[PreparedTest], crig: Rig, res: FitResult,
                      pf: list[np.ndarray], free: Sequence[str], max_iter: int
                      ) -> tuple[FitResult, list[np.ndarray]]:
    """Make the reported fit one whose *forward simulation* fits.

    The one-step collocation rule on the 1 kHz sample grid is accurate for a soft
    or contact-type transmission but not for a stiff continuous one (a 5e7 N/m
    compliance rings at ≈ 165 Hz on the 47.5 kg rotor-equivalent mass): its optimum
    then simulates far worse than the collocation says (held-out error 3.3 →
    4.3 % instead of → 0.7 %).  When the simulated SSE exceeds the collocation SSE
    by :data:`MISMATCH_RATIO`, the fit is repeated on a grid with
    :data:`REFINE_SUBSTEPS` sub-intervals per sample, and if the mismatch remains
    the parameters are polished on the CVODES simulation (:func:`polish`).
    """
    t0, seconds0 = time.perf_counter(), res.seconds
    sim = fit_predictor(crig)
    sse = normalised_sse(fit_pts, pf)
    if not sse > MISMATCH_RATIO * res.sse:
        return res, pf
    notes = [f"simulated SSE {sse:.4g} vs collocation {res.sse:.4g}"]
    if past_deadline():
        notes.append("not refined: the run's time budget was reached")
        note_cut("refinement of the collocation fit", 0, True)
        return replace(res, records={**res.records, "refinement": notes}), pf
    fine = fit_group(fit_pts, crig, [res.parameters], free=list(free), fixed=res.parameters,
                     max_iter=max_iter, substeps=REFINE_SUBSTEPS)
    if fine.parameters:
        pf_fine = sim(fit_pts, crig, fine.parameters)
        sse_fine = normalised_sse(fit_pts, pf_fine)
        notes.append(f"{REFINE_SUBSTEPS} sub-steps: {fine.message}, simulated SSE {sse_fine:.4g}")
        if sse_fine < sse:
            res, pf, sse = fine, pf_fine, sse_fine
    if sse > MISMATCH_RATIO * res.sse:
        po = polish(fit_pts, crig, res.parameters, list(free), predictor=sim)
        # (a polish cut at the deadline noted itself; the collocation fit stands)
        notes.append(f"polish on simulation: SSE {po.sse_before:.4g} -> {po.sse_after:.4g} "
                     f"({po.nfev} simulations)")
        if po.sse_after < sse:
            res = replace(res, parameters=po.parameters)
            pf = sim(fit_pts, crig, res.parameters)
    return replace(res, message=f"{res.message}, refined on simulation",
                   records={**res.records, "refinement": notes},
                   seconds=time.perf_counter() - t0 + seconds0), pf




# ------------------------------------------------------------------ the decision rule


def rig_on_simulation(rig: Rig) -> bool:
    """Whether ``rig`` holds an effect fitted on the simulation (a stiff contact or an
    elastic mount): every later candidate is then fitted on the simulation too — the
    collocation NLP with those states factorises for minutes (a 0.8 mm gap: > 15 min)."""
    return any(CANDIDATES[c.name].full_refit == "simulation"
               for c in rig.components if c.name in CANDIDATES)


#: A member whose recipe is collocation is fitted by the simulation recipe (screened
#: starts, effect-only and joint Gauss–Newton on the compiled map with its exact
#: sensitivities) when its candidate-fit tests hold more samples than this and the rig
#: suits the map.  On such a campaign the map is the cheaper path (one cogging fit on
#: 8 tests, about 10 800 samples: 12.6 s on the map, 17.1 s by collocation with the
#: node-by-node Hessian, 51 s before it).  Our own held-out benchmark campaigns (4 fit
#: tests of at most 1 250 samples) stay on collocation.
SIMULATION_RECIPE_MIN_SAMPLES = 6000


def simulation_recipe(crig: Rig, sub_pts: Sequence[PreparedTest]) -> bool:
    """Whether a collocation member added to the rig ``crig`` is fitted on the map
    instead (:data:`SIMULATION_RECIPE_MIN_SAMPLES`): a smooth rig, uniform sample
    grids, a large campaign."""
    return (map_suits(crig) and all(uniform_grid(pt.time_s) for pt in sub_pts)
            and sum(pt.time_s.size for pt in sub_pts) > SIMULATION_RECIPE_MIN_SAMPLES)


def fit_member(a: tuple) -> tuple:
    """One catalogue member re-identified by its recipe (:class:`~.candidates.Candidate`:
    screening shares, refinements, collocation or simulation stages) on the fit-test
    subset and simulated on all tests.

    ``a`` = (name, component, starts, fit-test subset, fit tests, held-out tests, rig,
    current parameters, IPOPT iterations).  Returns (name, FitResult, fit outputs,
    held-out outputs, rig with the member); empty outputs when the fit failed.
    """
    name, comp, starts, sub_pts, fit_pts, held_pts, rig, params, max_iter = a
    cand = CANDIDATES[name]
    on_sim = rig_on_simulation(rig) or simulation_recipe(
        rig.with_components([*rig.components, comp]), sub_pts)
    if on_sim and cand.simulation_starts:
        starts = [*starts, *cand.simulation_starts]
    _, res, _, _ = fit_candidate(name, comp, starts, sub_pts, [], rig, params, max_iter,
                                 shares=cand.shares, refine=cand.refine,
                                 full_refit="simulation" if on_sim else cand.full_refit,
                                 effect_fit="simulation" if on_sim else cand.effect_fit,
                                 log_names=cand.log_names, impact_fit=cand.impact_fit)
    crig = rig.with_components([*rig.components, comp])
    if cand.impact_fit:  # the contact law the impact-aware fit chose
        from .impacts import impact_record, with_contact_law
        rec = impact_record(res) or {}
        crig = with_contact_law(crig, rec.get("contact_exponent", 1.0))
    if not res.parameters:
        return name, res, [], [], crig
    pf = predict(fit_pts, crig, res.parameters)
    ph = predict(held_pts, crig, res.parameters) if held_pts else []
    return name, res, pf, ph, crig


def fit_members(args: list[tuple], jobs: int, *, until_deadline: bool = False,
                seconds: dict | None = None, estimate=None) -> list[tuple]:
    """:func:`fit_member` of each argument tuple, in ``jobs`` forked processes when
    ``jobs`` > 1 and there is more than one; results in the order of ``args``.

    The fits are scheduled one by one as workers free up (no batch waits for its
    slowest member); ``until_deadline``: none starts once the run's deadline has passed,
    nor one whose estimated wall time (``estimate(name)``, s, when given) exceeds the
    time left — it would be cut before it moved — so the results then hold only the fits
    started (a prefix of ``args``).  ``seconds`` (optional) receives each member's wall
    time, s, by name.  A fit made in the calling process while ``jobs`` > 1 (the only one
    asked for) simulates its tests on ``jobs`` workers (:func:`~.spread.spread_simulations`:
    the same numbers)."""
    if remote() is not None and args:  # on the run's Dask cluster, in the order asked
        if until_deadline and past_deadline():
            return []
        t_start = time.perf_counter()
        res = fit_on_cluster(fit_member, args)
        if seconds is not None:
            for a in args:
                seconds[a[0]] = time.perf_counter() - t_start
        return res
    t0: dict[int, float] = {}
    out: dict[int, tuple] = {}
    pending: list[int] = list(range(len(args)))

    def stop() -> bool:
        if not until_deadline:
            return False
        need = estimate(args[pending[0]][0]) if estimate is not None and pending else 0.0
        return past_deadline() or need > time_left_s()

    def done(k: int, res: tuple) -> None:
        out[k] = res
        if seconds is not None:
            seconds[args[k][0]] = time.perf_counter() - t0[k]

    if jobs > 1 and len(args) > 1:
        import multiprocessing as mp
        from concurrent.futures import FIRST_COMPLETED, wait
        with ProcessPoolExecutor(max_workers=min(jobs, len(args)),
                                 mp_context=mp.get_context("fork")) as ex:
            running: dict = {}
            while pending or running:
                while pending and len(running) < jobs and not stop():
                    k = pending.pop(0)
                    t0[k] = time.perf_counter()
                    running[ex.submit(fit_member, args[k])] = k
                if not running:
                    break
                finished, _ = wait(list(running), return_when=FIRST_COMPLETED)
                for f in finished:
                    done(running.pop(f), f.result())
        return [out[k] for k in sorted(out)]
    while pending and not stop():
        k = pending.pop(0)
        t0[k] = time.perf_counter()
        # a lone fit: its simulations side by side on the run's workers (:mod:`.spread`)
        with spread_simulations(jobs, [*args[k][3], *args[k][4], *args[k][5]]):
            done(k, fit_member(args[k]))
    return [out[k] for k in sorted(out)]


def _scores_of(a: tuple) -> dict:
    return signature_scores(*a)


def signature_scores_in(jobs: int, prepared: Sequence[PreparedTest], rig: Rig,
                        baseline: dict[str, float], baseline_pred: Sequence[np.ndarray],
                        names: Sequence[str], components: dict) -> dict[str, dict]:
    """:func:`~.candidates.signature_scores` of ``names``, one member per task in
    ``jobs`` forked processes (each member's score depends on the residual and its own
    probes only: the same numbers as one call; the probes' simulations are most of a
    round's ranking)."""
    names = list(names)
    if jobs <= 1 or len(names) <= 1:
        return signature_scores(prepared, rig, baseline, baseline_pred, names, components)
    import multiprocessing as mp
    tasks = [(prepared, rig, baseline, baseline_pred, [n], components) for n in names]
    with ProcessPoolExecutor(max_workers=min(jobs, len(names)),
                             mp_context=mp.get_context("fork")) as ex:
        parts = list(ex.map(_scores_of, tasks))
    return {n: part[n] for n, part in zip(names, parts)}
