"""Re-identification of candidate effects and the statistics of the decision
(moved out of :mod:`.workflow` to keep each module small).

* test split (:func:`split_tests`), cropping, effective sample size, SSE/ΔBIC;
* :func:`fit_candidate`: one candidate added to a rig that may already hold
  earlier effects (starts screened by forward simulation, effect-only stage,
  friction split for transmission effects, full refit, simulation matching).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...datasets.bench_format import BenchData, BenchTest, load_bench
from .fit import (
    FitOutcome,
    PreparedTest,
    Rig,
    fit_group,
    force_relative_error_percent,
    predict,
)
from .deadline import past_deadline
from .polish import polish

__all__ = ["split_tests", "effective_samples", "split_friction", "fit_candidate", "compatible",
           "earns", "can_earn", "excess_reduction", "force_noise_floor_percent",
           "force_resolution", "MIN_EXCESS_REDUCTION", "reproducibility",
           "FRICTION_SHARES", "MISMATCH_RATIO", "REFINE_SUBSTEPS"]


# ------------------------------------------------------------------ helpers
def _grid_key(t: BenchTest) -> tuple:
    return (t.load_ohm or 0.0, t.frequency_hz or 0.0, t.file)


def split_tests(tests: Sequence[BenchTest], seed: int = 0, max_tests: int | None = None
                ) -> tuple[list[BenchTest], list[BenchTest]]:
    """Fit and held-out tests: every third test of the sorted (load, frequency) grid
    is held out (offset from ``seed``); fewer than 3 tests: nothing held out."""
    ts = sorted(tests, key=_grid_key)
    if max_tests is not None and len(ts) > max_tests:
        idx = np.unique(np.round(np.linspace(0, len(ts) - 1, max_tests)).astype(int))
        ts = [ts[i] for i in idx]
    if len(ts) < 3:
        return list(ts), []
    off = int(np.random.default_rng(seed).integers(3))
    held = [t for k, t in enumerate(ts) if k % 3 == off]
    fit = [t for k, t in enumerate(ts) if k % 3 != off]
    return fit, held


def _crop(t: BenchTest, n: int) -> BenchTest:
    """The last ``n`` samples of a sine test (recorded tests are returned whole)."""
    if t.excitation != "sine" or t.n_samples <= n:
        return t
    k = slice(t.n_samples - n, None)
    return replace(t, time_s=t.time_s[k], displacement_m=t.displacement_m[k],
                   force_N=t.force_N[k],
                   voltage_V=t.voltage_V[k] if t.voltage_V is not None else None)


def _tau(r: np.ndarray) -> float:
    """Integrated autocorrelation time (initial positive sequence), ≥ 1."""
    r = r - r.mean()
    n = r.size
    if n < 8 or not np.any(r):
        return 1.0
    f = np.fft.rfft(r, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[:n]
    ac = ac / ac[0]
    tau = 1.0
    for k in range(1, n // 2):
        if ac[k] <= 0:
            break
        tau += 2 * ac[k]
    return float(max(tau, 1.0))


def effective_samples(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray]) -> float:
    """N_eff = Σ over tests and channels of N / τ of the normalised residual."""
    total = 0.0
    for pt, yp in zip(prepared, preds):
        for ch in range(pt.y.shape[0]):
            r = (pt.y[ch] - yp[ch]) * pt.wnorm[ch]
            total += pt.n_resolved / _tau(r[pt.weight > 0])
    return total


def _sse(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray]) -> float:
    return float(sum(np.sum(((pt.y - yp) * pt.wnorm) ** 2)
                     for pt, yp in zip(prepared, preds)))


def _force_error(prepared: Sequence[PreparedTest], preds: Sequence[np.ndarray]) -> float:
    return force_relative_error_percent(
        np.concatenate([p[0][pt.weight > 0] for pt, p in zip(prepared, preds)]),
        np.concatenate([pt.y[0][pt.weight > 0] for pt in prepared]))


def _screen_sse(prepared: Sequence[PreparedTest], rig: Rig, preds: Sequence[np.ndarray],
                baseline: dict[str, float]) -> float:
    """SSE left after a linear friction correction (what a refit of F_C, f_v and the
    Stribeck amplitude would absorb anyway) — a fair screen of effect starts
    simulated with the baseline friction, which absorbed part of the effect."""
    from .candidates import _absorbed_columns
    u_brk = float(baseline.get("nut_breakaway_velocity_m_per_s", 0.01))
    r = np.concatenate([((pt.y - yp) * pt.wnorm).ravel()
                        for pt, yp in zip(prepared, preds)])
    B = np.vstack([_absorbed_columns(pt, rig, u_brk) for pt in prepared])
    coef, *_ = np.linalg.lstsq(B, r, rcond=None)
    return float(np.sum((r - B @ coef) ** 2))


def _dbic(sse_new: float, sse_old: float, k: int, n_eff: float) -> float:
    return n_eff * math.log(max(sse_new, 1e-300) / sse_old) + k * math.log(max(n_eff, 2.0))


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


def _best_friction_share(prepared: Sequence[PreparedTest], rig: Rig,
                         params: dict[str, float]) -> float:
    """The bearing share of :data:`FRICTION_SHARES` whose forward simulation fits best."""
    r = rig.harvester.lead_m_per_rad
    sses = [_sse(prepared, predict(prepared, rig, split_friction(params, sh, r)))
            for sh in FRICTION_SHARES]
    return float(FRICTION_SHARES[int(np.nanargmin(sses))])


def compatible(rig: Rig, component) -> bool:
    """Whether ``component`` can join the rig's components (one transmission at most,
    no duplicate name)."""
    names = {c.name for c in rig.components}
    if component.name in names:
        return False
    return not (component.transmission and any(c.transmission for c in rig.components))


def _screen(fit_pts: Sequence[PreparedTest], rig: Rig, crig: Rig, starts: Sequence[dict],
            shares: Sequence[float], refine: Sequence[dict]) -> dict:
    """The start whose forward simulation fits best (after the linear friction
    correction of :func:`_screen_sse`).

    Each start is simulated at every bearing share of the friction in ``shares``
    (a transmission effect such as a gap separates the rotor from the rod: how much
    friction acts on the rotor side decides how far it coasts through the gap, and
    the rigid baseline lumped it all into the nut).  The best one is then varied by
    each override of ``refine`` (e.g. the contact stiffness over its decades), and
    the best of those is returned.
    """
    r = rig.harvester.lead_m_per_rad

    def cost(st: dict) -> float:
        return _screen_sse(fit_pts, rig, predict(fit_pts, crig, st), st)

    pool = [split_friction(st, sh, r) if sh > 0 else dict(st) for st in starts for sh in shares]
    sses = []
    for st in pool:  # at the run's deadline: the best of those simulated so far
        sses.append(cost(st))
        if past_deadline():
            break
    best, sbest = pool[int(np.nanargmin(sses))], float(np.nanmin(sses))
    for over in refine:
        if past_deadline():
            break
        st = {**best, **over}
        c = cost(st)
        if c < sbest:
            best, sbest = st, c
    return best


def fit_candidate(name: str, component, starts: Sequence[dict], fit_pts: Sequence[PreparedTest],
                  held_pts: Sequence[PreparedTest], rig: Rig, baseline: dict[str, float],
                  max_iter: int, *, shares: Sequence[float] = (0.0,),
                  refine: Sequence[dict] = (), full_refit: str = "collocation",
                  effect_fit: str = "collocation", log_names: Sequence[str] = ()
                  ) -> tuple[str, FitOutcome, list[np.ndarray], list[np.ndarray]]:
    """Add ``component`` to ``rig`` (which may hold earlier effects) and re-identify.

    Starts (effect parameters) are screened by forward simulation (each at every
    bearing share of the friction in ``shares``, the best then varied by the
    overrides in ``refine``; :func:`_screen`), IPOPT starts from the best; stage 1
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
    are refined in log10 on the simulation (parameters spanning decades).  Returns
    the name, the fit and the simulated outputs of the fit and held-out tests
    (empty lists when the fit failed).
    """
    for what, v in (("full_refit", full_refit), ("effect_fit", effect_fit)):
        if v not in ("collocation", "simulation"):
            raise ValueError(f"fit_candidate: {what} must be 'collocation' or 'simulation', "
                             f"got {v!r}")
    crig = rig.with_components([*rig.components, component])
    defaults = component.defaults()
    starts = [{**defaults, **baseline, **s} for s in starts] or [{**defaults, **baseline}]
    if len(starts) > 1 or len(shares) > 1 or refine:
        starts = [_screen(fit_pts, rig, crig, starts, shares, refine)]
    eff = [q.name for q in component.parameters]

    def stage1(start: dict) -> FitOutcome:
        if effect_fit == "simulation":
            return _effect_fit_on_simulation(fit_pts, crig, start, eff, log_names)
        return fit_group(fit_pts, crig, [start], free=eff, fixed=start, max_iter=max_iter)

    first = stage1(starts[0])
    if first.parameters and rig.has_generator and component.transmission:
        # an elastic transmission separates the rotor from the rod, so the nut/bearing
        # split of the friction (irrelevant on the rigid baseline, which lumps it all
        # into the nut) becomes identifiable - and a local optimum: screen the split by
        # forward simulation, then refit the effect at the best split
        share = _best_friction_share(fit_pts, crig, first.parameters)
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
    pf = predict(fit_pts, crig, res.parameters)
    if first.parameters and res is not first:
        # keep the effect-only fit when the full refit simulates worse (a collocation
        # optimum that does not reproduce under simulation)
        pf1 = predict(fit_pts, crig, first.parameters)
        if _sse(fit_pts, pf1) < _sse(fit_pts, pf):
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
                              ) -> FitOutcome:
    """Stage 1 on the forward simulation: the effect parameters ``eff`` refined from
    the screened ``start`` by :func:`polish` (everything else fixed at the start),
    returned as a :class:`FitOutcome` (covariance from the final Jacobian)."""
    t0 = time.perf_counter()
    po = polish(fit_pts, crig, start, list(eff), max_iter=SIMULATION_REFIT_ITER,
                log_names=[n for n in log_names if n in eff])
    n_obs = sum(pt.y.size for pt in fit_pts)
    return FitOutcome(po.success, f"effect fitted on simulation: {po.message}",
                      dict(po.parameters), list(eff), po.sse_after / n_obs, po.sse_after, n_obs,
                      [{"simulation_fit": {"sse_before": po.sse_before,
                                           "sse_after": po.sse_after, "simulations": po.nfev}}],
                      time.perf_counter() - t0, po.covariance)


def _refit_on_simulation(name: str, fit_pts: Sequence[PreparedTest],
                         held_pts: Sequence[PreparedTest], crig: Rig, first: FitOutcome,
                         free: Sequence[str], log_names: Sequence[str] = ()
                         ) -> tuple[str, FitOutcome, list[np.ndarray], list[np.ndarray]]:
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
    po = polish(fit_pts, crig, first.parameters, list(free), max_iter=SIMULATION_REFIT_ITER,
                log_names=[n for n in log_names if n in free])
    pf = predict(fit_pts, crig, po.parameters)
    sse = _sse(fit_pts, pf)
    chaos = reproducibility(fit_pts, crig, po.parameters, pf)
    note = ""
    if chaos > 1.0:
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
                  starts=[*first.starts, {"simulation_refit": {
                      "sse_before": po.sse_before, "sse_after": po.sse_after,
                      "simulations": po.nfev, "free": list(free),
                      "tolerance_change_rms_sigma": chaos}}],
                  seconds=first.seconds + time.perf_counter() - t0)
    return name, res, pf, (predict(held_pts, crig, res.parameters) if held_pts else [])


#: A collocation fit whose simulated SSE exceeds its collocation SSE by more than
#: this factor is refined (finer collocation grid, then :func:`polish`).
MISMATCH_RATIO = 1.15
#: Collocation sub-intervals per sample interval for the refinement.
REFINE_SUBSTEPS = 3


def _match_simulation(fit_pts: Sequence[PreparedTest], crig: Rig, res: FitOutcome,
                      pf: list[np.ndarray], free: Sequence[str], max_iter: int
                      ) -> tuple[FitOutcome, list[np.ndarray]]:
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
    sse = _sse(fit_pts, pf)
    if not sse > MISMATCH_RATIO * res.sse:
        return res, pf
    notes = [f"simulated SSE {sse:.4g} vs collocation {res.sse:.4g}"]
    if past_deadline():
        notes.append("not refined: the run's time budget was reached")
        return replace(res, starts=[*res.starts, {"refinement": notes}]), pf
    fine = fit_group(fit_pts, crig, [res.parameters], free=list(free), fixed=res.parameters,
                     max_iter=max_iter, substeps=REFINE_SUBSTEPS)
    if fine.parameters:
        pf_fine = predict(fit_pts, crig, fine.parameters)
        sse_fine = _sse(fit_pts, pf_fine)
        notes.append(f"{REFINE_SUBSTEPS} sub-steps: {fine.message}, simulated SSE {sse_fine:.4g}")
        if sse_fine < sse:
            res, pf, sse = fine, pf_fine, sse_fine
    if sse > MISMATCH_RATIO * res.sse:
        po = polish(fit_pts, crig, res.parameters, list(free))
        notes.append(f"polish on simulation: SSE {po.sse_before:.4g} -> {po.sse_after:.4g} "
                     f"({po.nfev} simulations)")
        if po.sse_after < sse:
            res = replace(res, parameters=po.parameters)
            pf = predict(fit_pts, crig, res.parameters)
    return replace(res, message=f"{res.message}, refined on simulation",
                   starts=[*res.starts, {"refinement": notes}],
                   seconds=time.perf_counter() - t0 + seconds0), pf




# ------------------------------------------------------------------ the decision rule
#: A named effect (or a discovered term) must remove at least this share of the
#: held-out relative force error *above the noise floor* (see :func:`excess_reduction`).
MIN_EXCESS_REDUCTION = 0.10
#: ... and that excess must itself stand out of the noise: at least this share of the
#: noise floor (the floor is estimated, so a residual at the floor has a small excess).
MIN_EXCESS_OVER_FLOOR = 0.3
#: The all-channel SSE alternative needs an excess over noise of this share of N.
MIN_SSE_EXCESS = 0.25


def floor_noise_std(y: np.ndarray) -> float:
    """Noise level of a sampled signal from its *fourth* differences (median absolute
    deviation; Δ⁴ of white noise of std σ has std √70 σ).  The second differences of
    the fit's weights are biased high where the signal curves fast (a 3 Hz bench
    test: 2.34 N for a true 2.0 N, so the noise floor sat above the true parameters'
    error, 0.658 vs 0.588 %); the fourth differences cancel that curvature (2.07 N;
    floor 0.596 % against 0.596 % from the true σ)."""
    d4 = np.diff(np.asarray(y, dtype=float), 4)
    mad = np.median(np.abs(d4 - np.median(d4)))
    return float(max(1.4826 * mad / math.sqrt(70.0), 1e-12))


def force_noise_floor_percent(prepared: Sequence[PreparedTest]) -> float:
    """Relative force error (%) that the measurement noise alone gives:
    100 √(Σ σ_i² N_i) / ‖F‖ over the resolved samples (σ_i the noise level of test i's
    force from its fourth differences, :func:`floor_noise_std`)."""
    num = sum(floor_noise_std(pt.y[0]) ** 2 * pt.n_resolved for pt in prepared)
    den = float(np.sum(np.concatenate([pt.y[0][pt.weight > 0] for pt in prepared]) ** 2))
    return 100.0 * math.sqrt(num / den) if den > 0 else 0.0


def excess_reduction(err_before: float, err_after: float, floor: float) -> float:
    """Share of the error above the noise floor removed:
    1 − √(e₁² − e_n²)/√(e₀² − e_n²) (negative when the error grows)."""
    ex0 = math.sqrt(max(err_before ** 2 - floor ** 2, 0.0))
    ex1 = math.sqrt(max(err_after ** 2 - floor ** 2, 0.0))
    if ex0 <= MIN_EXCESS_OVER_FLOOR * floor:  # nothing beyond noise left to explain
        return 0.0 if err_after <= err_before else -math.inf
    if err_after > err_before:
        return -(err_after - err_before) / ex0
    return 1.0 - ex1 / ex0


def force_resolution(floor: float, n_force: int | None) -> float:
    """The smallest change of the relative force error (%) the data resolve: the noise
    floor's own standard error, floor/√(2 N) for N force samples (an rms estimated from
    N Gaussian residuals is uncertain by 1/√(2N) of itself); 0 when N is not given."""
    return floor / math.sqrt(2.0 * n_force) if n_force else 0.0


def earns(err_before: float, err_after: float, floor: float, dbic_fit: float,
          dbic_heldout: float, sse_excess_reduction: float | None = None,
          n_force: int | None = None) -> bool:
    """The decision rule: the held-out force error does not grow and falls by at least
    :data:`MIN_EXCESS_REDUCTION` of its excess over the noise floor — or, for an
    effect seen mainly in another channel (voltage), the held-out SSE of all
    noise-normalised channels falls by that share of its excess over noise
    (``sse_excess_reduction`` = 1 − (SSE₁ − N)/(SSE₀ − N)) while the force error does
    not grow by more than the data resolve (:func:`force_resolution` of the ``n_force``
    held-out force samples: a voltage drop can leave the force error unchanged up to
    rounding) — and ΔBIC < 0 on the fit tests and on the held-out tests (beyond what
    noise explains)."""
    gain = excess_reduction(err_before, err_after, floor)
    if (sse_excess_reduction is not None
            and err_after <= err_before + force_resolution(floor, n_force)):
        gain = max(gain, sse_excess_reduction)
    return gain >= MIN_EXCESS_REDUCTION and dbic_fit < 0 and dbic_heldout < 0


def can_earn(err_before: float, floor: float, sse_before: float, n_obs: float) -> bool:
    """Whether *any* refit could earn by :func:`earns` from this state — False when
    the force error's excess over the noise floor is within
    :data:`MIN_EXCESS_OVER_FLOOR` of the floor (no force gain is possible) and the
    all-channel SSE is within :data:`MIN_SSE_EXCESS` of its noise expectation N (the
    SSE alternative is not offered).  Exact: a round started from such a state
    cannot name anything, so it is not run."""
    ex0 = math.sqrt(max(err_before ** 2 - floor ** 2, 0.0))
    return ex0 > MIN_EXCESS_OVER_FLOOR * floor or sse_before > (1 + MIN_SSE_EXCESS) * n_obs


def _spread(items: Sequence[Any], n: int | None) -> list[Any]:
    if n is None or len(items) <= n:
        return list(items)
    idx = np.unique(np.round(np.linspace(0, len(items) - 1, n)).astype(int))
    return [items[i] for i in idx]


def _load_split(data: BenchData, settings: Any) -> tuple[list, list, str]:
    """Fit and held-out tests: a ``validation/`` sub-directory when there is one."""
    path = Path(str(getattr(data, "path", "") or ""))
    vdir = path / "validation"
    if path.name and (vdir / "bench.toml").is_file():
        val = load_bench(vdir)
        return (_spread(sorted(data.tests, key=lambda t: t.file), settings.max_tests),
                list(val.tests), "validation set")
    fit_t, held_t = split_tests(data.tests, settings.seed, settings.max_tests)
    return fit_t, held_t, "held-out" if held_t else "all data"
