"""Friction identification from bench tests (paper §2–3; also the real EMPS data).

The bench model (:class:`~ehsa_opt.physics.bench_model.BenchModel`, any state vector,
with or without transmission components) is discretised by **direct
collocation** (Radau, degree ``d``) on a decimated grid of each test's samples;
the rod motion is prescribed from the measured displacement through a
smoothing spline (:class:`~ehsa_opt.physics.motion.SampledMotion`) evaluated at the
collocation points; the states are initialised from the measurements and the
parameters are scaled.  **IPOPT** solves

    min  t + w · mean_k J_k      s.t.  J_k ≤ t  for every signal k of every test,
         collocation equations, bounds, F_brk ≥ F_C, T_brk ≥ T_C,

with J = mean(((S_s − S_e)/max|S_e|)²) the smooth (squared, normalised)
counterpart of the paper's Eq 5.  ``t`` is the epigraph of the minimax
max(δ_V, δ_F) of the paper; the small weight ``w`` on the mean
(:attr:`IdentifyOptions.sum_weight`) keeps the optimum unique when the
maximum is decided by a signal the parameters cannot change: on a rigid bench
the winding current obeys L di/dt = K_e v/r − R i with v prescribed, so δ_V does
not depend on friction at all.  The reported errors are Eq 5 *as printed*,
δ = sqrt(mean(|S_s − S_e| / max|S_e|)), on each test's full time grid, and the
force relative error ‖F_s − F_e‖/‖F_e‖ (EMPS reference).

Two paths (chosen automatically, :attr:`IdentifyOptions.path`): when no state
of the model depends on a free parameter (rigid bench: the winding current is
fixed by the prescribed motion and the load), the **rigid path** integrates the
states once per test (:func:`~ehsa_opt.estimation.collocation.integrate_states`)
and IPOPT solves the same epigraph problem in the parameters only; otherwise
(backlash, compliance, …) the states are Radau collocation unknowns.  Both run on
:mod:`ehsa_opt.estimation.core`, whose NLPs are built once per structure and
reused for every test of the same size.

Multistart: ``starts`` initial points drawn uniformly (seeded) in the declared
start ranges (:data:`~ehsa_opt.physics.base_parameters.PARAMETERS`; components: in
their ParamSpec bounds), or given start points (:mod:`ehsa_opt.estimation.starts`), run
in parallel processes; the best successful start is kept, every start recorded.

Identifiability: at the optimum the Gauss–Newton Fisher information of the
free parameters (the collocation states eliminated through the sensitivity
of the collocation equations, the initial states treated as nuisance
parameters and marginalised) is eigen-decomposed in scaled coordinates;
directions with relative eigenvalue below :attr:`IdentifyOptions.identifiable_rtol`
are reported as not determined by the data, together with identifiable
combinations (rod friction at given speeds, total viscous, …) and their
95 % confidence intervals.
"""


from __future__ import annotations

import dataclasses
import math
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..datasets.bench_format import BenchData, BenchTest, load_bench
from ..physics.bench_model import BenchModel
from ..physics.components import Component
from ..physics.friction import FRICTION_LAWS, PRESLIDING_NAMES
from ..physics.motion import SampledMotion
from ..physics.params import (
    FRICTION_NAMES,
    HarvesterParams,
)
from . import core
from .collocation import (
    PRESLIDING_WINDOW_M,
    given_block,
    reversal_indices,
    integrate_states,
    node_indices,
    radau_block,
    states_depend_on,
)
from .identifiability import fisher_identifiability
from .identify_options import (
    MIN_RESOLVED_SAMPLES,
    PARAMETER_BOUNDS,
    START_RANGES,
    IdentifyOptions,
    estimate_motion,
    test_motion,
    unresolved_tests,
)
from .lugre_continuation import continued_fit
from .starts import Starts, draw_starts
from .fit_result import FitResult
from .identify_result import (
    IdentificationReport,
    Prediction,
    eq5_delta,
    force_relative_error_percent,
    summarise_identifiability,
    test_errors,
)
from .test_simulation import model_defaults, model_mass, outputs_on_grid, simulate_tests

__all__ = ["IdentifyOptions", "FitResult", "Prediction", "IdentificationReport", "fit_tests",
           "simulate_tests", "eq5_delta", "force_relative_error_percent", "identify",
           "PARAMETER_BOUNDS", "START_RANGES", "fisher_identifiability", "test_motion",
           "MIN_RESOLVED_SAMPLES"]

_BEARING = FRICTION_NAMES[4:]
_TIES = {"nut_breakaway_N": "nut_coulomb_N", "bearing_breakaway_Nm": "bearing_coulomb_Nm"}


def _bounds(model: BenchModel, name: str) -> tuple[float, float, float]:
    if name in PARAMETER_BOUNDS:
        return PARAMETER_BOUNDS[name]
    q = model.param_specs[name]
    scale = abs(q.default) if q.default != 0 else max(abs(q.upper), abs(q.lower), 1e-12)
    return q.lower, q.upper, scale


# ====================================================================== fit
def _default_free(model: BenchModel, has_generator: bool, fixed: Mapping[str, Any]) -> list[str]:
    names = [n for n in model.param_names if n != "load_ohm"]
    if not has_generator or model.friction_law != "static":  # rod friction: the nut_* names
        names = [n for n in names if n not in _BEARING]
    return [n for n in names if n not in fixed]


@dataclass
class _Setup:
    """Everything of one fit that does not depend on the start."""

    model: BenchModel
    space: core.ParamSpace
    tests: list[BenchTest]
    motions: list[SampledMotion]
    blocks: list
    y_meas: list[np.ndarray]
    pbases: list[np.ndarray]
    path: str
    full_states: list[np.ndarray | None]
    options: IdentifyOptions
    resolved: list[np.ndarray]

    def nlp(self) -> core.NLP:
        opt = self.options
        return core.build(self.model, self.space,
                          core.Objective("minimax", opt.sum_weight, opt.objective_scale),
                          core.SolverSettings(opt.tol, opt.max_iter, record_iterations=True),
                          self.blocks)


def _setup(tests: list[BenchTest], model: BenchModel, has_generator: bool, free_names: list[str],
           fixed: Mapping[str, Any], options: IdentifyOptions) -> _Setup:
    names = list(model.param_names)
    defaults = model_defaults(model)
    ties = tuple((n, v) for n, v in fixed.items() if isinstance(v, str))
    bnd = [_bounds(model, n) for n in free_names]
    space = core.ParamSpace(tuple(names), tuple(free_names), tuple(b[0] for b in bnd),
                            tuple(b[1] for b in bnd), tuple(b[2] for b in bnd), ties,
                            tuple(_TIES.items()))
    driven = states_depend_on(model, list(free_names) + [o for _, o in ties])
    if options.path == "rigid" and driven:
        raise ValueError("fit_tests: path='rigid' needs states that no free parameter "
                         "drives (rigid bench); use path='auto' or 'collocation'")
    path = "collocation" if (options.path == "collocation" or driven) else "rigid"
    if model.n_states == 0:
        path = "rigid"
    opt = options
    motions, blocks, y_meas, pbases, full, resolved = [], [], [], [], [], []
    for test in tests:
        load = test.load_ohm if (test.load_ohm is not None and has_generator) else 1.0
        pb = np.array([load] + [float(fixed[n]) if (n in fixed and not isinstance(fixed[n], str))
                                else defaults[n] for n in names[1:]])
        est = estimate_motion(test, opt, model_mass(model))
        motion = est.motion
        ntrim = int(round(opt.trim_fraction * test.n_samples))
        obs = np.arange(ntrim, test.n_samples - ntrim)
        obs = obs[est.resolved[obs]]  # corners the spline cannot follow stay out
        resolved.append(est.resolved)
        nodes = node_indices(test.n_samples, opt.max_intervals)
        obs = obs[node_indices(obs.size, opt.max_samples - 1)]
        if model.friction_law != "static":  # the bristle's fast transients at reversals
            xv = motion.evaluate(test.time_s)
            near = reversal_indices(xv[0], xv[1], PRESLIDING_WINDOW_M, opt.max_intervals)
            nodes = np.union1d(nodes, near)
            keep = np.zeros(test.n_samples, bool)
            keep[ntrim:test.n_samples - ntrim] = True
            obs = np.union1d(obs, near[keep[near] & est.resolved[near]])
        sig = [test.force_N] + ([test.voltage_V] if (test.voltage_V is not None
                                                     and has_generator) else [])
        ym = np.array([s[obs] for s in sig])
        wy = np.array([1.0 / np.max(np.abs(s)) for s in sig])
        if path == "rigid":
            X = integrate_states(model, motion, test.time_s, pb)
            blk = given_block(model, X[:, obs], motion.evaluate(test.time_s[obs]), ym, wy, pb)
            full.append(X)
        else:
            blk = radau_block(model, test.time_s, motion, nodes, obs, ym, wy, pb, opt.degree)
            full.append(None)
        motions.append(motion)
        blocks.append(blk)
        y_meas.append(ym)
        pbases.append(pb)
    return _Setup(model, space, tests, motions, blocks, y_meas, pbases, path, full, options,
                  resolved)


def _run_starts(su: _Setup, draws: list[dict[str, float]], ident: bool = True) -> list[dict]:
    """Solve every start on the (cached) NLP; Fisher analysis at the chunk's best."""
    nlp = su.nlp()
    p = nlp.data(su.blocks)
    recs = core.solve_starts(nlp, su.blocks, [su.space.z_of(s) for s in draws])
    out = []
    for s, r in zip(draws, recs):
        out.append({"initial": dict(s), "final": su.space.values_of(r.w, su.pbases[0]),
                    "objective": r.objective, "success": r.success, "status": r.status,
                    "iterations": r.iterations, "seconds": r.seconds, "w": r.w,
                    "history": _history(su, nlp, p, r.rows, r.g_rows)})
    ok = [r for r in out if r["success"]]
    if ident and ok:
        best = min(ok, key=lambda r: r["objective"])
        try:
            best["ident"] = _fisher(su, nlp, p, best["w"])
        except (RuntimeError, np.linalg.LinAlgError, ValueError) as exc:
            best["ident"] = {"error": str(exc)}
    return out


def _history(su: _Setup, nlp: core.NLP, p: np.ndarray, rows: list[np.ndarray],
             g_rows: list[np.ndarray] | None = None) -> dict:
    J = nlp.J_rows(rows, p, g_rows)
    isF = np.array([k == 0 for ym in su.y_meas for k in range(ym.shape[0])])
    opt = su.options
    obj = opt.objective_scale * (np.max(J, axis=1) + opt.sum_weight * J.mean(axis=1))
    pars = [su.space.values_of(r, su.pbases[0]) for r in rows]
    return {"objective": obj.tolist(),
            "rms_F": np.sqrt(J[:, isF].max(axis=1)).tolist(),
            "rms_V": (np.sqrt(J[:, ~isF].max(axis=1)).tolist() if (~isF).any() else None),
            "parameters": {n: [q[n] for q in pars] for n in su.space.free}}


def _fisher(su: _Setup, nlp: core.NLP, p: np.ndarray, w: np.ndarray) -> dict:
    dy = nlp.sensitivities(w, p)
    y = np.array(nlp.yfun(w, p)).ravel()
    vmax = max(float(np.max(np.abs(m.evaluate(m.time_s)[1]))) for m in su.motions)
    method = None
    if su.path == "rigid":
        method = ("Gauss-Newton Fisher information; states fixed by the prescribed motion "
                  "(rigid path: no state depends on a free parameter); scaled coordinates")
    return fisher_identifiability(dy, y, su.y_meas, su.space.values_of(w, su.pbases[0]),
                                  su.space.free, su.space.scale,
                                  su.model.harvester.lead_m_per_rad, vmax,
                                  su.options.identifiable_rtol, method=method or "")


def _pool(jobs: int) -> ProcessPoolExecutor:
    import multiprocessing as mp
    return ProcessPoolExecutor(max_workers=jobs, mp_context=mp.get_context("fork"))


def fit_tests(tests: Sequence[BenchTest], harvester: HarvesterParams, *,
              has_generator: bool = True, components: Sequence[Component] = (),
              free: Sequence[str] | None = None, fixed: Mapping[str, Any] | None = None,
              starts: Starts = 4, seed: int = 0, jobs: int = 1,
              options: IdentifyOptions | None = None, identifiability: bool = True,
              friction_law: str = "static") -> FitResult:
    """Identify ONE parameter set for all the given tests (per-test fit: one test).

    Parameters
    ----------
    tests : sequence of BenchTest
    harvester : HarvesterParams
    has_generator : bool
        False for rigs without generator: ``inertia_kg`` and ``offset_N`` are
        identified beside the nut friction; the bearing friction is fixed at 0.
    components : sequence of Component
        Extra effects; their parameters vary in their ParamSpec bounds by default.
    free : sequence of str, optional
        Names to fit (default: every parameter but ``load_ohm``; without
        generator, not the bearing names).
    fixed : mapping, optional
        Name → value; a string value ties the parameter to another one
        (e.g. ``{"nut_breakaway_N": "nut_coulomb_N"}`` removes the Stribeck bump).
    starts : int or list of dict
        Number of start points drawn (seeded by ``seed``) in the declared start ranges, or
        the start points themselves, each naming every free parameter
        (:mod:`ehsa_opt.estimation.starts`).
    seed, jobs : int
        Seed of the draws, parallel processes.
    options : IdentifyOptions
        ``options.path`` picks the rigid or collocation path (default automatic).
    identifiability : bool
        Compute the Fisher-information analysis at the optimum.
    friction_law : {"static", "lugre"}
        The friction law (:class:`~ehsa_opt.physics.bench_model.BenchModel`); with
        ``"lugre"`` the bristle stiffness σ₀ and damping σ₁ are fitted too, the bristle
        deflection is a collocation state, and the collocation nodes sit on every sample
        near the velocity reversals (:data:`~.collocation.PRESLIDING_WINDOW_M`).  With
        drawn starts (``starts`` a number), the default ``free`` and σ₀ not fixed, the
        fit is the continuation of :mod:`~.lugre_continuation` (static fit from the
        drawn starts, σ₀ fixed stiff to soft, then free).

    Returns
    -------
    FitResult
        ``path`` says which path was used.
    """
    tests = list(tests)
    if not tests:
        raise ValueError("fit_tests: no tests given")
    if not (isinstance(jobs, int) and jobs >= 1):
        raise ValueError(f"fit_tests: jobs must be an integer >= 1, got {jobs!r}")
    if has_generator and any(t.voltage_V is None for t in tests):
        bad = next(t.file for t in tests if t.voltage_V is None)
        raise ValueError(f"fit_tests: {bad} has no voltage_V but has_generator=True; pass "
                         f"has_generator=False for a rig without generator")
    options = options or IdentifyOptions()
    fixed = dict(fixed or {})
    if friction_law != "static" and free is None and isinstance(starts, int) \
            and PRESLIDING_NAMES[0] not in fixed:
        def fit(**kw: Any) -> FitResult:
            return fit_tests(tests, harvester, has_generator=has_generator,
                             components=components, seed=seed, jobs=jobs, options=options,
                             **kw)
        return continued_fit(fit, friction_law, fixed, starts, identifiability)
    model = BenchModel(harvester, components, generator=has_generator,
                       friction_law=friction_law)
    known = [n for n in model.param_names if n != "load_ohm"]
    for n, v in fixed.items():
        if n not in known:
            raise ValueError(f"fit_tests: fixed parameter '{n}' is unknown (known: "
                             f"{', '.join(known)})")
        if isinstance(v, str) and v not in known:
            raise ValueError(f"fit_tests: '{n}' tied to unknown parameter '{v}'")
    if not has_generator or friction_law != "static":
        # without generator there are no bearings; under a bristle law one Simscape curve
        # (the nut's names) carries the rod's friction: the nut/bearing split is not
        # identifiable on a rigid bench, and with both free a fit moves the friction
        # between them until the bristle's rate σ₀/φ(v) diverges
        for n in _BEARING:
            fixed.setdefault(n, 1.0 if "velocity" in n else 0.0)
    free_names = list(free) if free is not None else _default_free(model, has_generator, fixed)
    unknown = [n for n in free_names if n not in known]
    if unknown:
        raise ValueError(f"fit_tests: cannot fit unknown free parameter '{unknown[0]}' "
                         f"(known: {', '.join(known)})")
    clash = [n for n in free_names if n in fixed]
    if clash:
        raise ValueError(f"fit_tests: {', '.join(clash)} both free and fixed")
    draws = draw_starts(model, free_names, starts, seed, where="fit_tests")
    missing = sorted({n for d in draws for n in free_names if n not in d})
    if missing:
        raise ValueError(f"fit_tests: a start point leaves out {', '.join(missing)}; give every "
                         f"free parameter a start value, or pass starts as a number to draw")
    starts = len(draws)
    t0 = time.perf_counter()
    short = unresolved_tests(tests, options, model_mass(model))
    if short:
        names = [n for n in model.param_names if n != "load_ohm"]
        msg = ("no fit: " + "; ".join(short) + " — the motion's derivatives are not resolved "
               "there (corners, dwells, ends); record longer strokes or slower reversals")
        return FitResult(success=False, message=msg, status="not_resolved",
                         parameters={n: math.nan for n in names}, free=list(free_names),
                         seconds=time.perf_counter() - t0, path="none")
    su = _setup(tests, model, has_generator, free_names, fixed, options)
    if jobs == 1 or starts == 1:
        records = _run_starts(su, draws, identifiability)
    else:
        chunks = [draws[k::jobs] for k in range(min(jobs, starts))]
        order = [k for j in range(len(chunks)) for k in range(j, starts, jobs)]
        with _pool(len(chunks)) as ex:
            parts = list(ex.map(_run_starts, [su] * len(chunks), chunks,
                                [identifiability] * len(chunks)))
        flat = [r for part in parts for r in part]
        records = [None] * starts
        for k, r in zip(order, flat):
            records[k] = r
    return _finish(su, records, time.perf_counter() - t0, identifiability)


def _predictions(su: _Setup, params: Mapping[str, float]) -> list[Prediction]:
    """Simulated signals on each test's full grid with the fitted parameters: the rigid
    path's states (or one compiled Radau integration when no state depends on the
    parameters); CVODES otherwise."""
    model = su.model
    if su.path == "collocation" and states_depend_on(
            model, list(su.space.free) + [o for _, o in su.space.ties]):
        return simulate_tests(su.tests, model.harvester, params,
                              has_generator=model.generator, components=model.components,
                              motions=su.motions, friction_law=model.friction_law)
    out = []
    for test, motion, pb, X in zip(su.tests, su.motions, su.pbases, su.full_states):
        p = np.array([pb[0]] + [params[n] for n in model.param_names[1:]])
        y = outputs_on_grid(model, motion, test.time_s, p, X if X is not None else
                             integrate_states(model, motion, test.time_s, pb))
        V = y[1] if (model.generator and test.voltage_V is not None) else None
        out.append(Prediction(test.file, test.time_s, y[0], V))
    return out


def _finish(su: _Setup, records: list[dict], seconds: float,
            identifiability: bool) -> FitResult:
    ok = [r for r in records if r["success"]]
    starts_out = [{k: v for k, v in r.items() if k not in ("w", "history", "ident")}
                  for r in records]
    names = [n for n in su.model.param_names if n != "load_ohm"]
    if not ok:
        best = min(records, key=lambda r: r["objective"] if math.isfinite(r["objective"])
                   else math.inf)
        return FitResult(success=False, message=f"all {len(records)} IPOPT starts failed "
                         f"(statuses: {sorted({r['status'] for r in records})})",
                         status=best["status"], parameters={n: math.nan for n in names},
                         free=list(su.space.free), nit=best["iterations"], starts=starts_out,
                         seconds=seconds, history=best["history"], path=su.path)
    best = min(ok, key=lambda r: r["objective"])
    params = {n: best["final"][n] for n in names}
    preds = _predictions(su, params)
    per = test_errors(su.tests, preds, su.resolved)
    dF = max(r["delta_F"] for r in per)
    dV = max(r["delta_V"] for r in per) if all(r["delta_V"] is not None for r in per) else None
    Fs = np.concatenate([p.force_N[m] for p, m in zip(preds, su.resolved)])
    Fe = np.concatenate([t.force_N[m] for t, m in zip(su.tests, su.resolved)])
    rel = force_relative_error_percent(Fs, Fe)
    ident = best.get("ident") if identifiability else None
    msg = (f"{len(ok)}/{len(records)} starts converged; best objective {best['objective']:.6g} "
           f"({best['status']}; {su.path} path)")
    return FitResult(success=True, message=msg, status=best["status"], parameters=params,
                     free=list(su.space.free), objective=best["objective"],
                     nit=best["iterations"], starts=starts_out, seconds=seconds, delta_F=dF,
                     delta_V=dV, force_relative_error_percent=rel, per_test=per,
                     history=best["history"], identifiability=ident, path=su.path)


# ====================================================================== identify
#: A test whose displacement spans less than this (m) did not move: nothing to identify.
MIN_STROKE_M = 1e-5
#: A fit whose force error (%) is at least this did not reach the data.
MAX_FORCE_ERROR_PERCENT = 90.0


def _fit_one(args: tuple) -> FitResult:
    test, harvester, has_gen, components, starts, seed, options, fixed, law = args
    stroke = float(np.ptp(test.displacement_m))
    fit = fit_tests([test], harvester, has_generator=has_gen, components=components,
                    starts=starts, seed=seed, jobs=1, options=options, fixed=fixed,
                    friction_law=law)
    # IPOPT may converge on data that carry no information; such a fit is a failure
    # (and so stays out of the bounds and friction sets), --lenient or not
    err = fit.force_relative_error_percent
    if stroke < MIN_STROKE_M:
        fit.success = False
        fit.message = (f"the displacement is constant (range {stroke:.3g} m < "
                       f"{MIN_STROKE_M:g} m): the rod did not move, so the test carries no "
                       f"friction to identify; remove it or check the displacement column")
    elif fit.success and (err is None or not err < MAX_FORCE_ERROR_PERCENT):
        fit.success = False
        fit.message = (f"the fit did not reach the data (force error {err} % >= "
                       f"{MAX_FORCE_ERROR_PERCENT:g} %, IPOPT {fit.status}); check the test's "
                       f"signals and units")
    return fit


def _default_holdout(data: BenchData) -> list[str]:
    """Every third test in file order (a spread over frequency and load)."""
    if len(data.tests) < 3:
        return []
    return [t.file for k, t in enumerate(data.tests) if k % 3 == 1]


def identify(data: BenchData | str | Path, *, starts: int = 4, jobs: int = 1, seed: int = 0,
             components: Sequence[Component] = (), holdout: Sequence[str] | None = None,
             progress: Callable[[int], None] | None = None,
             options: IdentifyOptions | None = None, fixed: Mapping[str, Any] | None = None,
             joint: bool = True, friction_law: str = "static") -> IdentificationReport:
    """The paper's identification procedure on a data directory.

    Per test: multistart collocation/IPOPT fit (the paper's steps 1–8); per
    parameter: min/max over the tests (Table 2 bounds); identifiability at each
    optimum; a joint fit on the tests not in ``holdout`` and its error on the
    held-out tests.

    Parameters
    ----------
    data : BenchData or path
        Loaded data, or a directory (validated by the strict loader first: bad
        data is refused before any solve).
    starts, jobs, seed : int
    components : sequence of Component
    holdout : sequence of str, optional
        Files held out of the joint fit (default: every third test; none when
        fewer than 3 tests).
    progress : callable, optional
        Called with the number of finished per-test fits.
    options : IdentifyOptions
        Default :meth:`IdentifyOptions.for_rig`.
    fixed : mapping, optional
        Fixed/tied parameters (see :func:`fit_tests`).  For rigs without
        generator the default ties the breakaway to the Coulomb force and fixes
        the breakaway velocity at 1 mm/s, so the law reduces to
        M a + f_v v + F_C tanh(v / 0.1 mm/s) + F_0, the EMPS reference model.
    joint : bool
        Run the joint fit (one parameter set, at most 300 objective samples and
        100 intervals per training test, ``min(starts, 2)`` starts).
    friction_law : {"static", "lugre"}
        The friction law of every fit (see :func:`fit_tests`).
    """
    if not isinstance(data, BenchData):
        data = load_bench(data)
    if not (isinstance(starts, int) and starts >= 1):
        raise ValueError(f"identify: starts must be an integer >= 1, got {starts!r}")
    if not (isinstance(jobs, int) and jobs >= 1):
        raise ValueError(f"identify: jobs must be an integer >= 1, got {jobs!r}")
    if friction_law not in FRICTION_LAWS:
        raise ValueError(f"identify: friction_law must be one of {', '.join(FRICTION_LAWS)}, "
                         f"got {friction_law!r}")
    options = options or IdentifyOptions.for_rig(data.has_generator)
    if fixed is None:
        fixed = {} if data.has_generator else {"nut_breakaway_N": "nut_coulomb_N",
                                               "nut_breakaway_velocity_m_per_s": 1e-3}
    t0 = time.perf_counter()
    args = [(t, data.harvester, data.has_generator, list(components), starts, seed + k,
             options, dict(fixed), friction_law) for k, t in enumerate(data.tests)]
    fits: list[FitResult] = []
    if jobs == 1 or len(args) == 1:
        for a in args:
            fits.append(_fit_one(a))
            if progress:
                progress(len(fits))
    else:
        with _pool(min(jobs, len(args))) as ex:
            for f in ex.map(_fit_one, args):
                fits.append(f)
                if progress:
                    progress(len(fits))
    good = [f for f in fits if f.success]
    bounds = {}
    if good:
        for n in good[0].free:
            vals = [f.parameters[n] for f in good]
            bounds[n] = [float(min(vals)), float(max(vals))]
    ident = summarise_identifiability(data, fits)
    jres, hold_files, hold_err = None, [], []
    if joint and len(data.tests) >= 2:
        hold_files = list(holdout) if holdout is not None else _default_holdout(data)
        unknown = [f for f in hold_files if f not in {t.file for t in data.tests}]
        if unknown:
            raise ValueError(f"identify: holdout file(s) {', '.join(unknown)} not in the data")
        # a recorded test whose samples are all corners, dwells or ends says nothing
        skip = {t.file for t, f in zip(data.tests, fits) if f.status == "not_resolved"}
        train = [t for t in data.tests if t.file not in hold_files and t.file not in skip]
        held = [t for t in data.tests if t.file in hold_files and t.file not in skip]
        if train:
            # the joint NLP holds every training test: fewer objective samples per test
            jopt = dataclasses.replace(options, max_samples=min(options.max_samples, 300),
                                       max_intervals=min(options.max_intervals, 100))
            jres = fit_tests(train, data.harvester, has_generator=data.has_generator,
                             components=components, starts=max(1, min(starts, 2)), seed=seed,
                             jobs=jobs, options=jopt, fixed=fixed, identifiability=False,
                             friction_law=friction_law)
            if jres.success and held:
                preds = simulate_tests(held, data.harvester, jres.parameters,
                                       has_generator=data.has_generator, components=components,
                                       options=options, friction_law=friction_law)
                mass = data.harvester.equivalent_mass_kg() if data.has_generator else None
                hold_err = test_errors(held, preds, [estimate_motion(t, options, mass).resolved
                                                     for t in held])
    return IdentificationReport(data, fits, bounds, jres, hold_files, hold_err, ident,
                                time.perf_counter() - t0, starts, friction_law)

