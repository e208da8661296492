"""``ehsa-opt optimize``: a design problem file → goal attainment or NSGA-II →
``OUT/result.json`` (+ ``OUT/pareto.csv`` for NSGA-II), written atomically.

``result.json`` holds ``design`` (total_inertia_gcm2, lead_mm_per_rev,
speed_constant_rpm_per_V, load_ohm) and ``objectives`` (comfort, road_holding,
inverse_power, inverse_efficiency) of the goal-attainment optimum or of the NSGA-II
knee / preference pick, plus the prototype, goals, the attainment factor and the
dimensional metrics (W, %, m/s²).

With friction (``frictions``: ``--friction ID.json:CASE``, repeatable, or the problem
file's ``[friction]`` table) the objectives come from the friction-aware fast path
(:class:`~ehsa_opt.design.robust.FrictionObjectives`, mode ``at`` / ``worst`` /
``mean``), and the optimum (goal attainment) or the whole front (NSGA-II) is
re-simulated in the time domain with the same friction: ``time_domain_check`` in
result.json and ``front_check.csv`` (fast-path vs time-domain objectives).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..physics.params import FrictionParams, ParameterError
from .checkpoint import load_state
from .config import DesignConfig, check_method
from .goal import GoalAttainmentResult, solve_goal_attainment
from .nsga2 import ParetoResult, run_nsga2
from .problem import OBJECTIVE_NAMES, DesignProblem, QuarterCarObjectives

__all__ = ["build_problem", "config_frictions", "front_check", "goals_and_weights", "optimize", "OptimizeOutcome",
           "objectives_at", "design_record"]


def config_frictions(cfg: DesignConfig) -> tuple[FrictionParams, ...]:
    """The problem file's ``[friction]`` set, if any and not frictionless."""
    f = getattr(cfg.physical, "friction", None)
    return () if f is None or f.is_frictionless else (f,)


def build_problem(cfg: DesignConfig, mapper: Any = None,
                  frictions: Sequence[FrictionParams] | None = None,
                  friction_mode: str | None = None) -> DesignProblem:
    """The pymoo design problem of a config: the frictionless exact linear path, or
    with ``frictions`` (default: the file's ``[friction]``) the friction-aware fast
    path combined by ``friction_mode`` (``at`` for one set, else ``worst`` by default)."""
    frictions = tuple(config_frictions(cfg) if frictions is None else frictions)
    if frictions:
        from .robust import FrictionObjectives
        mode = friction_mode or ("at" if len(frictions) == 1 else "worst")
        ev: Any = FrictionObjectives(cfg.vehicle, cfg.road, cfg.harvester,
                                     (("n_freq", cfg.n_freq),), frictions=frictions,
                                     mode=mode)
    else:
        if friction_mode not in (None, "at"):
            raise ParameterError(f"--friction-mode {friction_mode} needs friction sets: give "
                                 "--friction FILE:CASE (repeatable) or a [friction] table")
        ev = QuarterCarObjectives(cfg.vehicle, cfg.road, cfg.harvester,
                                  (("n_freq", cfg.n_freq),))
    problem = DesignProblem(cfg.space, ev)
    problem.mapper = mapper
    return problem


def objectives_at(problem: DesignProblem, design: Mapping[str, float]) -> dict[str, float]:
    """All evaluator outputs at one physical design, as floats."""
    res = problem.evaluate_design({k: np.array([float(v)]) for k, v in design.items()})
    return {k: float(np.ravel(v)[0]) for k, v in res.items()}


def goals_and_weights(cfg: DesignConfig, problem: DesignProblem
                      ) -> tuple[np.ndarray, np.ndarray | None, dict[str, float]]:
    """Goals (explicit, else relative_to_prototype × prototype objectives), weights
    (explicit, else None = |goal|) and the prototype's outputs."""
    proto = objectives_at(problem, cfg.prototype_design)
    explicit = dict(cfg.goals.goals)
    goals = np.array([explicit.get(k, cfg.goals.relative_to_prototype * proto[k])
                      for k in OBJECTIVE_NAMES])
    weights = (np.array([dict(cfg.goals.weights)[k] for k in OBJECTIVE_NAMES])
               if cfg.goals.weights else None)
    return goals, weights, proto


def design_record(design: Mapping[str, float], outputs: Mapping[str, float]) -> dict[str, Any]:
    """The ``design`` / ``objectives`` / ``metrics`` blocks of result.json."""
    return {"design": {k: float(design[k]) for k in design},
            "objectives": {k: float(outputs[k]) for k in OBJECTIVE_NAMES},
            "metrics": {k: float(v) for k, v in outputs.items() if k not in OBJECTIVE_NAMES}}


class OptimizeOutcome(dict):
    """result.json content, with the solver result under ``.result`` (not serialised)."""

    result: GoalAttainmentResult | ParetoResult | None = None
    goal_attainment: GoalAttainmentResult | None = None


def _changes(proto: Mapping[str, float], opt: Mapping[str, float]) -> dict[str, float]:
    """Improvements in % the paper's way: comfort/road holding lower is better."""
    return {"comfort_improvement_pct": 100 * (1 - opt["comfort"] / proto["comfort"]),
            "road_holding_improvement_pct": 100 * (1 - opt["road_holding"]
                                                   / proto["road_holding"]),
            "power_W": [proto.get("power_W", float("nan")), opt.get("power_W", float("nan"))],
            "efficiency_pct": [100 / proto["inverse_efficiency"],
                               100 / opt["inverse_efficiency"]]}


def optimize(cfg: DesignConfig, method: str | None = None, *, out_dir: str | Path,
             pop: int | None = None, gens: int | None = None, seed: int | None = None,
             checkpoint: str | Path | None = None, resume: str | Path | None = None,
             stop_after: int | None = None, mapper: Any = None,
             with_goal_attainment: bool = True,
             progress: Callable[[int, int], None] | None = None,
             frictions: Sequence[FrictionParams] | None = None,
             friction_mode: str | None = None, friction_labels: Sequence[str] = (),
             check_time_domain: bool = True,
             identified_range_m_per_s: float | None = None,
             identified_range_source: str = "") -> OptimizeOutcome:
    """Run the design study of ``cfg`` and write ``out_dir/result.json`` (and
    ``pareto.csv``, ``history.json``).

    For NSGA-II the goal-attainment point is computed too (``with_goal_attainment``)
    so the front can be drawn against it and checked for dominance.  ``frictions`` /
    ``friction_mode``: see :func:`build_problem`; with friction the result is checked in
    the time domain (``check_time_domain``).  ``identified_range_m_per_s``: the friction's
    identified range (default: that of the ``friction_labels`` files, of the problem file's
    ``[friction] from``, else the embedded campaign's); ``result.json`` states the
    fractions of time and friction energy the chosen design spends above it
    (``out_of_range``, fast path).
    """
    from ..utils.io import atomic_write_json, atomic_write_text

    method = check_method(method or cfg.method)
    if method != "nsga2":
        given = [n for n, v in (("--checkpoint", checkpoint), ("--resume", resume),
                                ("--stop-after", stop_after), ("--pop", pop), ("--gens", gens))
                 if v is not None]
        if given:
            raise ParameterError(f"{', '.join(given)} only apply to --method nsga2 (goal "
                                 f"attainment takes a second or less and has no generations)")
    out = Path(out_dir)
    if resume is not None:
        load_state(resume)  # a bad checkpoint is refused before any work
    problem = build_problem(cfg, mapper, frictions, friction_mode)
    ev = problem.evaluator
    goals, weights, proto = goals_and_weights(cfg, problem)
    ga_settings = cfg.goal_attainment
    outcome = OptimizeOutcome()
    outcome.update({"problem_file": cfg.path, "method": method,
                    "vehicle": cfg.vehicle_name, "road": {"iso_class": cfg.road.iso_class,
                                                          "speed_km_per_h": cfg.road.speed_km_per_h},
                    "box": cfg.space.as_dict(),
                    "friction": _friction_block(ev, friction_labels),
                    "prototype": design_record(cfg.prototype_design, proto)})
    ga = None
    if method == "goal-attainment" or with_goal_attainment:
        ga = solve_goal_attainment(problem, goals, weights, cfg.prototype_design,
                                   n_starts=ga_settings.n_starts, seed=ga_settings.seed,
                                   max_iter=ga_settings.max_iter, where=f"{cfg.path} [goals]")
        ga_block = {**design_record(ga.design, ga.objectives), "gamma": ga.gamma,
                    "goals": dict(zip(OBJECTIVE_NAMES, ga.goals.tolist())),
                    "weights": dict(zip(OBJECTIVE_NAMES, ga.weights.tolist())),
                    "success": ga.success, "message": ga.message, "stats": ga.stats,
                    "starts": ga.starts, "changes": _changes(proto, ga.objectives)}
        outcome["goal_attainment"] = ga_block
        outcome.goal_attainment = ga
        atomic_write_json(out / "ga_history.json", ga.history)
    if method == "goal-attainment":
        assert ga is not None
        outcome.update(design_record(ga.design, ga.objectives))
        outcome.update({"success": ga.success, "message": ga.message, "gamma": ga.gamma})
        outcome.result = ga
    else:
        ns = cfg.nsga2
        F_proto = np.array([proto[k] for k in OBJECTIVE_NAMES])
        ref = np.full(len(OBJECTIVE_NAMES), ns.hv_reference)
        pr = run_nsga2(problem, pop_size=pop or ns.pop, n_gen=gens or ns.gens,
                       seed=ns.seed if seed is None else seed, checkpoint=checkpoint,
                       resume=resume, stop_after=stop_after, hv_scale=F_proto,
                       hv_reference=ref, pick=ns.pick, pick_weights=ns.pick_weights,
                       progress=progress)
        i = pr.preferred
        d = {k: float(v[i]) for k, v in pr.designs.items()}
        outputs = objectives_at(problem, d)
        outcome.update(design_record(d, outputs))
        outcome.update({"success": pr.success, "message": pr.message, "pick": pr.pick,
                        "n_front": int(pr.F.shape[0]),
                        "hypervolume": {"normalisation": "F / F(prototype)",
                                        "reference_point": ref.tolist(),
                                        "history": pr.history},
                        "stats": pr.stats})
        if ga is not None:
            f_ga = np.array([ga.objectives[k] for k in OBJECTIVE_NAMES])
            better = np.all(pr.F < f_ga * (1 - 0.01), axis=1)
            outcome["front_vs_goal_attainment"] = {
                "n_dominating_by_1pct": int(better.sum()),
                "best_ratio_per_point_min": float(np.min(np.max(pr.F / f_ga, axis=1)))}
        atomic_write_text(out / "pareto.csv", pr.to_csv_text())
        outcome.result = pr
    outcome["out_of_range"] = _out_of_range(cfg, ev, outcome["design"],
                                            identified_range_m_per_s, identified_range_source,
                                            friction_labels)
    if check_time_domain and hasattr(ev, "frictions"):
        if method == "nsga2":
            designs = {k: np.asarray(v, float) for k, v in outcome.result.designs.items()}
        else:
            designs = {k: np.array([float(v)]) for k, v in outcome["design"].items()}
        check, csv_text = front_check(cfg, ev, designs)
        outcome["time_domain_check"] = check
        atomic_write_text(out / "front_check.csv", csv_text)
    atomic_write_json(out / "result.json", dict(outcome), indent=2)
    return outcome


def check_out_dir(out_dir: str | Path) -> Path:
    """Refuse an output path that is an existing file."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {out}: exists and is not a directory")
    return out


def _out_of_range(cfg: DesignConfig, ev: Any, design: Mapping[str, float],
                  v_range: float | None, source: str, labels: Sequence[str] = ()
                  ) -> dict[str, Any]:
    """Fractions of time and friction energy the design spends above the identified
    range, per friction set (fast path: Gaussian stroke velocity)."""
    from ..datasets.friction_source import identified_range_for
    from ..vehicle.coverage import OUT_OF_RANGE_LIMIT, coverage_warning, design_coverage
    if v_range is None:
        v_range, source = identified_range_for(labels, cfg.path)
    frs = list(getattr(ev, "frictions", ()) or ())
    dm = ev.design_mapping({k: np.array([float(v)]) for k, v in design.items()})
    cov = design_coverage(cfg.vehicle, cfg.road, dm, frs, v_range, base=cfg.harvester)
    t = [float(x) for x in cov["time_fraction"][:, 0]]
    e = [None if not np.isfinite(x) else float(x) for x in cov["energy_fraction"][:, 0]]
    worst = {"time_fraction": np.array(t), "energy_fraction": np.array(
        [np.nan if x is None else x for x in e])}
    return {"identified_range_m_per_s": float(v_range), "source": source,
            "limit": OUT_OF_RANGE_LIMIT, "time_fraction": t, "energy_fraction": e,
            "warning": coverage_warning(worst, v_range)}


def _friction_block(ev: Any, labels: Sequence[str]) -> dict[str, Any] | None:
    if not hasattr(ev, "frictions"):
        return None
    from dataclasses import asdict
    return {"mode": ev.mode, "labels": list(labels),
            "sets": [asdict(f) for f in ev.frictions],
            "method": "stochastic equivalent linearisation (ehsa_opt.vehicle.equivalent)"}


def front_check(cfg: DesignConfig, ev: Any, designs: Mapping[str, np.ndarray]
                ) -> tuple[dict[str, Any], str]:
    """Re-simulate designs in the time domain with the evaluator's friction and mode;
    relative errors of the fast path's objectives.  Returns the summary and a CSV."""
    from .robust import time_domain_objectives
    from .sweep import harvesters_from

    sim = getattr(cfg.physical, "simulation", None)
    kw = {}
    if sim is not None:
        kw = {k: getattr(sim, k) for k in ("settle_s", "sample_rate_hz") if hasattr(sim, k)}
    fast = ev(designs)
    td = time_domain_objectives(cfg.vehicle, cfg.road, harvesters_from(cfg.harvester, designs),
                                ev.frictions, ev.mode, **kw)
    err = {k: np.asarray(fast[k], float) / np.asarray(td[k], float) - 1.0
           for k in OBJECTIVE_NAMES}
    worst = {k: float(np.max(np.abs(v))) for k, v in err.items()}
    names = list(designs)
    lines = [",".join(names + [f"{k}_fast" for k in OBJECTIVE_NAMES]
                      + [f"{k}_time_domain" for k in OBJECTIVE_NAMES]
                      + [f"{k}_rel_error" for k in OBJECTIVE_NAMES])]
    n = len(next(iter(designs.values())))
    for i in range(n):
        vals = ([float(designs[k][i]) for k in names]
                + [float(np.ravel(fast[k])[i]) for k in OBJECTIVE_NAMES]
                + [float(np.ravel(td[k])[i]) for k in OBJECTIVE_NAMES]
                + [float(err[k][i]) for k in OBJECTIVE_NAMES])
        lines.append(",".join(f"{v:.10g}" for v in vals))
    summary = {"n_designs": n, "road": {"iso_class": cfg.road.iso_class,
                                        "speed_km_per_h": cfg.road.speed_km_per_h,
                                        "length_m": cfg.road.length_m, "seed": cfg.road.seed},
               "worst_abs_rel_error": worst,
               "median_abs_rel_error": {k: float(np.median(np.abs(v))) for k, v in err.items()},
               "within_5pct": bool(max(worst.values()) <= 0.05)}
    return summary, "\n".join(lines) + "\n"
