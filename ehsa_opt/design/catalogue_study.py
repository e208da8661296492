"""A design study over a motor catalogue: one study per motor (each motor fixes k_n, R_i,
L_i and its rotor inertia and brings its rated limits), the best motor chosen (goal
attainment: the lowest attainment factor among the feasible motors; NSGA-II: the most
feasible front designs), and the catalogue's front: the feasible designs of every motor,
non-dominated across motors, with the motor of each."""

from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np

from ..physics.params import ParameterError
from ..utils.io import display_path
from ..utils.tables import table_to_csv
from .config import DesignConfig, check_method
from .outcome import DesignResult
from .problem import OBJECTIVE_NAMES, DesignProblem

__all__ = ["catalogue_study"]


def catalogue_study(cfg: DesignConfig, method: str | None, kw: dict[str, Any],
                    run_one: Callable[..., DesignResult],
                    problem_for: Callable[[Any], DesignProblem]) -> DesignResult:
    """One study per motor of the catalogue (``run_one(cfg, method, motor=..., problem=...,
    **kw)``, the single-motor study, on ``problem_for(motor)``); the best motor's record
    with the table of all, and (NSGA-II) the front non-dominated across motors."""
    if kw["checkpoint"] is not None or kw["resume"] is not None:
        raise ParameterError("--checkpoint/--resume: not available with a motor catalogue "
                             "(one run per motor); run one motor's problem instead")
    results = []
    files: dict[str, str] = {}
    for k, motor in enumerate(cfg.catalogue_motors()):
        one = problem_for(motor)
        res = run_one(cfg, method, motor=motor, problem=one, **kw)
        results.append((motor, res))
        files.update({f"motor_{k}/{name}": text for name, text in res.files.items()})
        files[f"motor_{k}/result.json"] = res.to_json()
        if res.front is not None:
            files[f"motor_{k}/front.csv"] = table_to_csv(res.front)
    table = [{"motor": m.name, "source": m.source, "success": bool(r.record["success"]),
              # no limits evaluated: nothing makes the motor infeasible
              "feasible": bool(r.record.get("feasible", not r.record.get("constraints"))),
              "gamma": r.record.get("gamma"), "design": r.design, "objectives": r.objectives,
              "metrics": r.metrics,
              "active_constraints": r.record.get("active_constraints", []),
              "violations": r.record.get("violations", []),
              "constraints": r.record.get("constraints", {})} for m, r in results]
    feasible = [i for i, row in enumerate(table) if row["feasible"]]
    method = check_method(method or cfg.method)
    if method == "goal-attainment":
        pool = feasible or list(range(len(table)))
        best = min(pool, key=lambda i: (table[i]["gamma"] if table[i]["gamma"] is not None
                                        else math.inf))
    else:
        best = max(feasible or list(range(len(table))),
                   key=lambda i: results[i][1].record.get("n_feasible_front", 0))
    chosen = results[best][1]
    rec = dict(chosen.record)
    rec.update({"motor": {"model": "catalogue", "catalogue": (None if cfg.catalogue is None
                                                                else display_path(cfg.catalogue)),
                          "chosen": table[best]["motor"],
                          "source": table[best]["source"]},
                "catalogue": table,
                "catalogue_note": ("no motor of the catalogue has a feasible design"
                                   if not feasible else
                                   f"{len(feasible)} of {len(table)} motors feasible")})
    front = None
    if method == "nsga2":
        files["pareto.csv"], front = _catalogue_front(rec, results)
    return DesignResult(rec, chosen.result, chosen.goal_attainment_result, files, front)


def _catalogue_front(rec: dict[str, Any], results: Sequence[tuple[Any, DesignResult]]
                     ) -> tuple[str, dict[str, Any] | None]:
    """The catalogue's front (feasible points of every motor, non-dominated across motors)
    as ``pareto.csv`` text and as columns (with ``motor``); sets ``n_front`` and
    ``front_note`` in ``rec``."""
    from .pareto import non_dominated
    pts = []
    rows: list[dict[str, Any]] = []
    names_obj: Sequence[str] = OBJECTIVE_NAMES
    for m, r in results:
        pr = r.result
        names_obj = pr.objective_names
        ok = np.ones(pr.F.shape[0], bool)
        if r.record.get("feasible_front") is not None:
            ok = np.asarray(r.record["feasible_front"], bool)
        for i in np.flatnonzero(ok):
            pts.append((m.name, {k: float(v[i]) for k, v in pr.designs.items()}, pr.F[i]))
            rows.append({"motor": m.name, **{k: v[i] for k, v in (r.front or {}).items()}})
    keep = (np.flatnonzero(non_dominated(np.array([p[2] for p in pts]))) if pts
            else np.zeros(0, int))
    names = list(pts[0][1]) if pts else []
    lines = [",".join(["motor"] + names + list(names_obj))]
    lines += [",".join([f'"{pts[i][0]}"'] + [repr(pts[i][1][n]) for n in names]
                       + [repr(float(v)) for v in pts[i][2]]) for i in keep]
    rec["n_front"] = len(lines) - 1
    rec["front_note"] = ("feasible points of every motor, non-dominated across motors"
                         if pts else "no motor has a feasible design")
    kept = [rows[i] for i in keep]
    cols = ({k: np.array([r.get(k, np.nan) for r in kept],
                         dtype=object if k == "motor" else float) for k in kept[0]}
            if kept else None)
    return "\n".join(lines) + "\n", cols
