"""The design study of ``ehsa-opt optimize`` and :func:`ehsa_opt.optimize`: a design
problem → goal attainment or NSGA-II (or any pymoo algorithm) → a
:class:`~.outcome.DesignResult` in memory, whose ``save(folder)`` writes
``result.json`` (+ ``pareto.csv``, ``front.csv`` for a front) atomically.

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

import math
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..physics.params import FrictionParams, ParameterError
from ..utils.io import display_path
from .checkpoint import load_state
from .config import DesignConfig, check_method
from .goal import solve_goal_attainment
from .nsga2 import run_nsga2
from .outcome import OptimizeOutcome, motor_summary, time_domain_summary
from .problem import OBJECTIVE_NAMES, DesignProblem, QuarterCarObjectives
from .time_check import front_check, harvesters_of

__all__ = ["build_problem", "extended_like", "config_frictions", "front_check", "goals_and_weights", "optimize",
           "OptimizeOutcome", "objectives_at", "design_record", "constraint_record",
           "harvesters_of", "motor_summary", "time_domain_summary"]


def config_frictions(cfg: DesignConfig) -> tuple[FrictionParams, ...]:
    """The problem file's ``[friction]`` set, if any and not frictionless."""
    f = getattr(cfg.physical, "friction", None)
    return () if f is None or f.is_frictionless else (f,)


def build_problem(cfg: DesignConfig, mapper: Any = None,
                  frictions: Sequence[FrictionParams] | None = None,
                  friction_mode: str | None = None, motor: Any = None) -> DesignProblem:
    """The pymoo design problem of a config: the frictionless exact linear path, or
    with ``frictions`` (default: the file's ``[friction]``) the friction-aware fast
    path combined by ``friction_mode`` (``at`` for one set, else ``worst`` by default).
    ``motor``: the generator model (default the config's, :meth:`DesignConfig.motor`;
    a catalogue motor for one run of a catalogue study)."""
    frictions = tuple(config_frictions(cfg) if frictions is None else frictions)
    if cfg.motor_model == "select":
        return _selection_problem(cfg, mapper, frictions, friction_mode)
    if frictions:
        from .robust import FrictionObjectives
        mode = friction_mode or ("at" if len(frictions) == 1 else "worst")
        ev: Any = FrictionObjectives(cfg.vehicle, cfg.road, cfg.harvester,
                                     (("n_freq", cfg.n_freq),), motor if motor is not None
                                     else cfg.motor(), cfg.stroke_limit_m,
                                     cfg.limit_settings, frictions=frictions, mode=mode)
    else:
        if friction_mode not in (None, "at"):
            raise ParameterError(f"--friction-mode {friction_mode} needs friction sets: give "
                                 "--friction FILE:CASE (repeatable) or a [friction] table")
        ev = QuarterCarObjectives(cfg.vehicle, cfg.road, cfg.harvester,
                                  (("n_freq", cfg.n_freq),), motor if motor is not None
                                  else cfg.motor(), cfg.stroke_limit_m, cfg.limit_settings)
    problem = DesignProblem(cfg.space, ev)
    problem.mapper, problem.config = mapper, cfg
    if problem.constraint_names and motor is None:
        # the prototype as a seed: feasible or not, pymoo ranks it by its violation
        problem.initial = cfg.space.to_unit(cfg.prototype_design)[None, :]
    return problem


def _selection_problem(cfg: DesignConfig, mapper: Any, frictions: Sequence[Any],
                       friction_mode: str | None = None) -> DesignProblem:
    """The design problem of a ``select`` model: motor, winding and screw chosen from the
    catalogues, every hardware limit a constraint (:mod:`.selection`); with friction sets
    the friction-aware fast path (combined by ``friction_mode``: ``at`` for one set, else
    ``worst`` by default)."""
    from .selection import FrictionSelectionObjectives, SelectionObjectives
    args = (cfg.vehicle, cfg.road, cfg.harvester, tuple(cfg.catalogue_motors()),
            tuple(cfg.screws()), cfg.limit_settings, cfg.vehicle.stroke_limit_m,
            (("n_freq", cfg.n_freq),))
    if frictions:
        mode = friction_mode or ("at" if len(frictions) == 1 else "worst")
        ev: Any = FrictionSelectionObjectives(*args, frictions=tuple(frictions), mode=mode)
    else:
        if friction_mode not in (None, "at"):
            raise ParameterError(f"--friction-mode {friction_mode} needs friction sets: give "
                                 "--friction FILE:CASE (repeatable) or a [friction] table")
        ev = SelectionObjectives(*args)
    problem = DesignProblem(cfg.design_space, ev)
    problem.mapper, problem.config = mapper, cfg
    # the feasible region of a catalogue space is narrow: the first population holds the
    # feasible designs of a seeded screening (one per motor/screw combination first)
    from .mixed_goal import screened_seeds
    problem.initial = screened_seeds(problem)
    return problem


def prototype_problem(cfg: DesignConfig) -> DesignProblem:
    """The problem the prototype's own objectives (the goals' reference) come from: the
    config's, or for a ``select`` model the paper's space (the prototype's own motor,
    whose ratings are unknown, is in no catalogue)."""
    import dataclasses
    if cfg.motor_model == "select":
        return build_problem(dataclasses.replace(cfg, motor_model="paper"), None, ())
    return build_problem(cfg)


def extended_like(problem: DesignProblem, model: DesignProblem | None) -> DesignProblem:
    """``problem`` with the user objectives and constraints of ``model`` (if any)."""
    ev = getattr(model, "evaluator", None)
    if ev is None or not hasattr(ev, "user_constraints"):
        return problem
    return problem.extended(ev.objectives, ev.user_constraints)


def objectives_at(problem: DesignProblem, design: Mapping[str, float]) -> dict[str, float]:
    """All evaluator outputs at one physical design, as floats."""
    res = problem.evaluate_design({k: np.array([float(v)]) for k, v in design.items()})
    return {k: float(np.ravel(v)[0]) for k, v in res.items()}


def goals_and_weights(cfg: DesignConfig, problem: DesignProblem
                      ) -> tuple[np.ndarray, np.ndarray | None, dict[str, float]]:
    """Goals (explicit, else relative_to_prototype × prototype objectives), weights
    (explicit, else None = |goal|) and the prototype's outputs (of a selection problem:
    the prototype with its own motor, :func:`prototype_problem`)."""
    if getattr(getattr(problem, "evaluator", None), "kind", None) == "select" or getattr(
            getattr(getattr(problem, "evaluator", None), "inner", None), "kind", None) \
            == "select":
        problem = extended_like(prototype_problem(cfg), problem)
    proto = objectives_at(problem, cfg.prototype_design)
    explicit = dict(cfg.goals.goals)
    goals = np.array([explicit.get(k, cfg.goals.relative_to_prototype * proto[k])
                      for k in OBJECTIVE_NAMES])
    weights = (np.array([dict(cfg.goals.weights)[k] for k in OBJECTIVE_NAMES])
               if cfg.goals.weights else None)
    return goals, weights, proto


def design_record(design: Mapping[str, float], outputs: Mapping[str, float],
                  names: Sequence[str] = OBJECTIVE_NAMES) -> dict[str, Any]:
    """The ``design`` / ``objectives`` / ``metrics`` blocks of result.json (objectives
    ``names``, default the paper's four)."""
    return {"design": {k: float(design[k]) for k in design},
            "objectives": {k: float(outputs[k]) for k in names},
            "metrics": {k: float(v) for k, v in outputs.items() if k not in names}}


def _changes(proto: Mapping[str, float], opt: Mapping[str, float]) -> dict[str, float]:
    """Improvements in % the paper's way: comfort/road holding lower is better."""
    return {"comfort_improvement_pct": 100 * (1 - opt["comfort"] / proto["comfort"]),
            "road_holding_improvement_pct": 100 * (1 - opt["road_holding"]
                                                   / proto["road_holding"]),
            "power_W": [proto.get("power_W", float("nan")), opt.get("power_W", float("nan"))],
            "efficiency_pct": [100 / proto["inverse_efficiency"],
                               100 / opt["inverse_efficiency"]]}


def optimize(cfg: DesignConfig, method: str | None = None, *,
             out_dir: str | Path | None = None,
             pop: int | None = None, gens: int | None = None, seed: int | None = None,
             checkpoint: str | Path | None = None, resume: str | Path | None = None,
             stop_after: int | None = None, mapper: Any = None,
             with_goal_attainment: bool = True,
             progress: Callable[[int, int], None] | None = None,
             frictions: Sequence[FrictionParams] | None = None,
             friction_mode: str | None = None, friction_labels: Sequence[str] = (),
             check_time_domain: bool = True,
             identified_range_m_per_s: float | None = None,
             identified_range_source: str = "", problem: DesignProblem | None = None,
             algorithm: Any = None, termination: Any = None) -> OptimizeOutcome:
    """Run the design study of ``cfg``; with ``out_dir`` write its files there
    (``result.json``, ``pareto.csv``, ``ga_history.json``, ``front_check.csv``; see
    :meth:`OptimizeOutcome.save`), else write nothing.

    For NSGA-II the goal-attainment point is computed too (``with_goal_attainment``)
    so the front can be drawn against it and checked for dominance.  ``frictions`` /
    ``friction_mode``: see :func:`build_problem`; the result is re-simulated in the time
    domain (``check_time_domain``) with friction, and without friction whenever the
    problem has rated-limit constraints.  With a motor catalogue (``[motor] model =
    "catalogue"``) the study runs once per motor (``out_dir/motor_<k>/``) and
    result.json holds the best motor's result and a ``catalogue`` table of all.
    ``identified_range_m_per_s``: the friction's identified range (default: that of the
    ``friction_labels`` files, of the problem file's ``[friction] from``, else the
    embedded campaign's); ``result.json`` states the fractions of time and friction
    energy the chosen design spends above it (``out_of_range``, fast path).
    ``problem``: the design problem to solve (default :func:`build_problem` of ``cfg``;
    one with user objectives or constraints, see
    :meth:`~.problem.DesignProblem.with_objective`); ``algorithm`` / ``termination``: a
    pymoo algorithm and termination instead of the built-in NSGA-II (see
    :func:`~.nsga2.run_nsga2`).
    """
    kw = dict(pop=pop, gens=gens, seed=seed, checkpoint=checkpoint, resume=resume,
              stop_after=stop_after, mapper=mapper, with_goal_attainment=with_goal_attainment,
              progress=progress, frictions=frictions, friction_mode=friction_mode,
              friction_labels=friction_labels, check_time_domain=check_time_domain,
              identified_range_m_per_s=identified_range_m_per_s,
              identified_range_source=identified_range_source, algorithm=algorithm,
              termination=termination)
    if cfg.motor_model != "catalogue":
        outcome = _optimize_one(cfg, method, problem=problem, **kw)
    else:
        from .catalogue_study import catalogue_study
        outcome = catalogue_study(cfg, method, kw, _optimize_one, lambda motor: _motor_problem(
            cfg, problem, motor, frictions, friction_mode))
    if out_dir is not None:
        outcome.save(out_dir)
    return outcome


def _motor_problem(cfg: DesignConfig, problem: DesignProblem | None, motor: Any,
                   frictions: Any, friction_mode: str | None) -> DesignProblem:
    """The design problem with one catalogue motor, with ``problem``'s friction and user
    objectives and constraints."""
    if problem is not None:
        ev = problem.evaluator
        if frictions is None and hasattr(ev, "frictions"):
            frictions, friction_mode = ev.frictions, ev.mode
    return extended_like(build_problem(cfg, None, frictions, friction_mode, motor), problem)


def _optimize_one(cfg: DesignConfig, method: str | None = None, *,
                  pop: int | None = None, gens: int | None = None, seed: int | None = None,
                  checkpoint: str | Path | None = None, resume: str | Path | None = None,
                  stop_after: int | None = None, mapper: Any = None,
                  with_goal_attainment: bool = True,
                  progress: Callable[[int, int], None] | None = None,
                  frictions: Sequence[FrictionParams] | None = None,
                  friction_mode: str | None = None, friction_labels: Sequence[str] = (),
                  check_time_domain: bool = True, motor: Any = None,
                  identified_range_m_per_s: float | None = None,
                  identified_range_source: str = "", problem: DesignProblem | None = None,
                  algorithm: Any = None, termination: Any = None) -> OptimizeOutcome:
    """One design study (one motor model) of :func:`optimize`; writes nothing."""
    import json

    from ..utils.io import json_safe
    method = check_method(method or cfg.method)
    if method != "nsga2":
        given = [n for n, v in (("--checkpoint", checkpoint), ("--resume", resume),
                                ("--stop-after", stop_after), ("--pop", pop), ("--gens", gens),
                                ("algorithm", algorithm), ("termination", termination))
                 if v is not None]
        if given:
            raise ParameterError(f"{', '.join(given)} only apply to --method nsga2 (goal "
                                 f"attainment takes a second or less and has no generations)")
    if resume is not None:
        load_state(resume)  # a bad checkpoint is refused before any work
    if problem is None:
        problem = build_problem(cfg, mapper, frictions, friction_mode, motor)
    elif mapper is not None:
        problem.mapper = mapper
    own = tuple(problem.objective_names) == OBJECTIVE_NAMES
    if method == "goal-attainment" and not own:
        raise ParameterError(f"goal attainment needs the objectives {OBJECTIVE_NAMES}; this "
                             f"problem has {problem.objective_names}: use method 'nsga2' "
                             f"(or any pymoo algorithm)")
    ev = problem.evaluator
    # goals: the prototype's own objectives (its own motor), whatever motor is designed
    if cfg.motor_model == "select":
        goals, weights, proto = goals_and_weights(cfg, problem)
    else:
        goals, weights, proto = goals_and_weights(
            cfg, problem if motor is None else extended_like(
                build_problem(cfg, None, frictions, friction_mode), problem))
    rec: dict[str, Any] = {}
    files: dict[str, str] = {}
    front: dict[str, Any] = {}
    rec.update({"problem_file": display_path(cfg.path), "method": method,
                "vehicle": cfg.vehicle_name, "road": {"iso_class": cfg.road.iso_class,
                                                      "speed_km_per_h": cfg.road.speed_km_per_h},
                "box": problem.space.as_dict(),
                "friction": _friction_block(ev, friction_labels),
                "motor": _motor_block(ev, cfg),
                "prototype": design_record(cfg.prototype_design, proto,
                                           problem.objective_names)})
    ga = None
    if method == "goal-attainment" or (with_goal_attainment and own):
        ga_settings = cfg.goal_attainment
        if any(problem.space.integer):
            from .mixed_goal import solve_goal_attainment_mixed
            ga = solve_goal_attainment_mixed(problem, goals, weights,
                                             n_starts=ga_settings.n_starts,
                                             seed=ga_settings.seed,
                                             max_iter=ga_settings.max_iter,
                                             where=f"{cfg.path} [goals]")
        else:
            ga = solve_goal_attainment(problem, goals, weights, cfg.prototype_design,
                                       n_starts=ga_settings.n_starts, seed=ga_settings.seed,
                                       max_iter=ga_settings.max_iter,
                                       where=f"{cfg.path} [goals]")
        ga_block = {**design_record(ga.design, ga.objectives), "gamma": ga.gamma,
                    "goals": dict(zip(OBJECTIVE_NAMES, ga.goals.tolist())),
                    "weights": dict(zip(OBJECTIVE_NAMES, ga.weights.tolist())),
                    "success": ga.success, "message": ga.message, "stats": ga.stats,
                    "starts": ga.starts, "changes": _changes(proto, ga.objectives)}
        rec["goal_attainment"] = ga_block
        files["ga_history.json"] = json.dumps(json_safe(ga.history), indent=1,
                                              allow_nan=False)
    if method == "goal-attainment":
        assert ga is not None
        rec.update(design_record(ga.design, ga.objectives))
        rec.update({"success": ga.success, "message": ga.message, "gamma": ga.gamma})
        rec.update(constraint_record(problem, ga.objectives))
        result: Any = ga
    else:
        result = _front_study(cfg, problem, proto, rec, ga, motor is None,
                              dict(pop=pop, gens=gens, seed=seed, checkpoint=checkpoint,
                                   resume=resume, stop_after=stop_after, progress=progress,
                                   algorithm=algorithm, termination=termination), front)
        files["pareto.csv"] = result.to_csv_text()
    rec["out_of_range"] = _out_of_range(cfg, ev, rec["design"],
                                        identified_range_m_per_s, identified_range_source,
                                        friction_labels)
    if check_time_domain and (hasattr(ev, "frictions") or problem.constraint_names):
        if method == "nsga2":
            designs = {k: np.asarray(v, float) for k, v in result.designs.items()}
        else:
            designs = {k: np.array([float(v)]) for k, v in rec["design"].items()}
        check, csv_text = front_check(cfg, ev, designs)
        rec["time_domain_check"] = check
        files["front_check.csv"] = csv_text
    _explain(cfg, problem, rec, method, proto, front)
    if problem.units:
        rec["units"] = dict(problem.units)
    if problem.constraint_names:
        rec["constraint_names"] = list(problem.constraint_names)
    return OptimizeOutcome(rec, result, ga, files, front or None)


def _explain(cfg: DesignConfig, problem: DesignProblem, rec: dict[str, Any], method: str,
             proto: Mapping[str, float], front: dict[str, Any]) -> None:
    """What makes the result what it is: the variables at a bound of the box, the motor and
    screw chosen (a selection), and the front's hypervolume over the held-out roads."""
    from .limits import active_bounds
    ev = problem.evaluator
    rec["active_bounds"] = active_bounds(problem.space, rec["design"])
    if getattr(ev, "kind", None) != "select":
        return
    rec["hardware"] = ev.describe({k: np.array([v]) for k, v in rec["design"].items()})
    if method == "nsga2" and front:
        from .selection import motor_names
        designs = {k: np.asarray(front[k], float) for k in problem.space.names}
        front["motor_name"] = np.array(motor_names(ev, designs), dtype=object)
        rec["front_motors"] = sorted(set(front["motor_name"][np.asarray(front["feasible"],
                                                                        bool)]))
        if ev.screws:
            idx = np.ravel(ev.hardware(designs)["screw_index"])
            front["screw_name"] = np.array([ev.screws[int(i)].name for i in idx],
                                           dtype=object)
        roads = rec.get("time_domain_check", {}).get("held_out_roads", {})
        if roads.get("objectives"):
            from .limit_check import hypervolume_interval
            names = problem.objective_names
            F = np.stack([np.array(roads["objectives"][k]) for k in names], axis=-1)
            ok = np.asarray(front["feasible"], bool)
            scale = np.array([proto[k] for k in names])
            ref = np.full(len(names), cfg.nsga2.hv_reference)
            rec["hypervolume"]["held_out_roads"] = hypervolume_interval(F[:, ok], scale, ref)


def _front_study(cfg: DesignConfig, problem: DesignProblem, proto: Mapping[str, float],
                 rec: dict[str, Any], ga: Any, own_motor: bool,
                 run: dict[str, Any], front: dict[str, Any]) -> Any:
    """The NSGA-II (or given pymoo algorithm's) front of ``problem``, its record entries
    (preferred design, feasibility, validity, hypervolume) added to ``rec`` and its
    columns (designs, objectives, every evaluator output, ``feasible``) to ``front``."""
    ns = cfg.nsga2
    names = problem.objective_names
    F_proto = np.array([proto[k] for k in names])
    ref = np.full(len(names), ns.hv_reference)
    pr = run_nsga2(problem, pop_size=run["pop"] or ns.pop, n_gen=run["gens"] or ns.gens,
                   seed=ns.seed if run["seed"] is None else run["seed"],
                   checkpoint=run["checkpoint"], resume=run["resume"],
                   stop_after=run["stop_after"], hv_scale=F_proto, hv_reference=ref,
                   pick=ns.pick, pick_weights=ns.pick_weights, progress=run["progress"],
                   initial=None if own_motor else False,
                   algorithm=run["algorithm"], termination=run["termination"])
    d = pr.preferred_design
    outputs = objectives_at(problem, d)
    rec.update(design_record(d, outputs, names))
    rec.update(constraint_record(problem, outputs))
    front_out = problem.evaluate_design(pr.designs)
    feasible = np.ones(pr.F.shape[0], bool)
    if problem.constraint_names:
        G = np.column_stack([np.asarray(front_out[f"constraint_{c}"], float)
                             for c in problem.constraint_names])
        feasible = np.all(G <= 1e-9, axis=1)
        rec["n_feasible_front"] = int(np.sum(feasible))
        rec["feasible_front"] = feasible.tolist()
    front.update({k: np.asarray(v, float) for k, v in pr.designs.items()})
    front.update({k: pr.F[:, j] for j, k in enumerate(names)})
    front.update({k: np.broadcast_to(np.asarray(v, float), feasible.shape)
                  for k, v in front_out.items() if k not in front})
    front["feasible"] = feasible
    from ..vehicle.validity import FAST_PATH_REGION, check_validity
    ev = problem.evaluator
    region, design = None, dict(pr.designs)
    if hasattr(ev, "frictions"):  # the fast path: its validated region
        region = FAST_PATH_REGION
        design["electrical_damping_Ns_per_m"] = np.array(
            [h.equivalent_damping_Ns_per_m(0.0) for h in harvesters_of(ev, pr.designs)])
    validity = check_validity(front_out, stroke_limit_m=cfg.vehicle.stroke_limit_m,
                              design=design, fast_path_region=region)
    rec["front_validity"] = validity.as_list()  # per pareto.csv row
    rec["n_front_valid"] = int(np.sum(validity.valid))
    rec.update({"success": pr.success, "message": pr.message, "pick": pr.pick,
                "n_front": int(pr.F.shape[0]),
                "hypervolume": {"normalisation": "F / F(prototype)",
                                "reference_point": ref.tolist(),
                                "history": pr.history},
                "stats": pr.stats})
    if pr.algorithm != "NSGA2":
        rec["algorithm"] = pr.algorithm
    if ga is not None:
        f_ga = np.array([ga.objectives[k] for k in OBJECTIVE_NAMES])
        better = np.all(pr.F < f_ga * (1 - 0.01), axis=1)
        rec["front_vs_goal_attainment"] = {
            "n_dominating_by_1pct": int(better.sum()),
            "best_ratio_per_point_min": float(np.min(np.max(pr.F / f_ga, axis=1)))}
    return pr


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
    return {"mode": ev.mode, "labels": list(labels),
            "sets": [{**f.as_dict(), **f.law_dict()} for f in ev.frictions],
            "method": "stochastic equivalent linearisation (ehsa_opt.vehicle.fast_path.linearisation)"}


def constraint_record(problem: DesignProblem, outputs: Mapping[str, float],
                      active_tol: float = 1e-3) -> dict[str, Any]:
    """Constraint values (value / limit − 1, ≤ 0 feasible) at a design, which are active
    (within ``active_tol`` of their limit) and whether all hold."""
    names = problem.constraint_names
    if not names:
        return {}
    from .limits import explain_violations
    vals = {c: float(outputs[f"constraint_{c}"]) for c in names}
    rec: dict[str, Any] = {
        "constraints": vals,
        "active_constraints": [c for c, v in vals.items() if v > -active_tol],
        "feasible": bool(all(v <= 1e-6 for v in vals.values())),
        "violations": explain_violations(outputs, names)}
    detail = {c: {k: float(outputs[f"{k}_{c}"]) for k in ("value", "limit", "fraction")
                  if f"{k}_{c}" in outputs} for c in names}
    if any(detail.values()):
        rec["limits"] = detail
    return rec


def _motor_block(ev: Any, cfg: DesignConfig) -> dict[str, Any] | None:
    if getattr(ev, "kind", None) == "select":
        return {"model": "select",
                "catalogue": None if cfg.catalogue is None else display_path(cfg.catalogue),
                "motors": [m.name for m in ev.motors],
                "screw_catalogue": (None if cfg.screw_catalogue is None
                                    else display_path(cfg.screw_catalogue)),
                "screws": [s.as_dict() for s in ev.screws],
                "limit_settings": ev.limits.as_dict(),
                "stroke_limit_m": ev.stroke_limit_m,
                "constraints": list(ev.constraint_names)}
    motor = getattr(ev, "motor", None)
    if motor is None:
        return None
    block = {"model": motor.kind, "label": motor.label,
             "rating": motor.rating.as_dict(),
             "stroke_limit_m": getattr(ev, "stroke_limit_m", None),
             "constraints": list(getattr(ev, "constraint_names", ()))}
    if motor.kind == "catalogue":
        block.update({"name": motor.name, "source": motor.source,
                      "speed_constant_rpm_per_V": motor.speed_constant_rpm_per_V})
    return block


