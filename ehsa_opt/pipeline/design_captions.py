"""Captions of the design fronts' figures, written from the run's numbers: the front's
size, feasibility, motors and active bounds, the objectives' ranges and the hypervolume
with its interval over held-out roads."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

__all__ = ["front_caption", "parallel_caption", "hypervolume_caption"]

_NAMES = {"comfort": "comfort α", "road_holding": "road holding η_rh",
          "inverse_power": "1/ρ_g", "inverse_efficiency": "1/η_g"}


def _marks_text(pr: Any, rec: Mapping[str, Any]) -> str:
    n = pr.F.shape[0]
    feas = rec.get("feasible_front")
    n_feas = int(np.sum(feas)) if feas is not None and len(feas) == n else n
    text = f"{n} non-dominated designs, {n_feas} feasible"
    if n_feas < n:
        text += f" ({n - n_feas} with a limit exceeded: red crosses)"
    motors = rec.get("front_motors") or []
    if motors:
        text += f"; motors {', '.join(map(str, motors))}"
    bounds = rec.get("active_bounds") or []
    text += (f"; the {pr.pick} pick at a bound: {', '.join(bounds)}" if bounds
             else f"; the {pr.pick} pick at no bound of the box")
    return text


def front_caption(pr: Any, rec: Mapping[str, Any],
                  prototype: Mapping[str, float] | None = None) -> str:
    """The projections' caption: the marks and each objective's range over the front
    (with the prototype's value)."""
    parts = []
    for k, name in enumerate(pr.objective_names):
        lo, hi = float(np.min(pr.F[:, k])), float(np.max(pr.F[:, k]))
        p = "" if prototype is None or name not in prototype else \
            f" (prototype {float(prototype[name]):.4g})"
        parts.append(f"{_NAMES.get(name, name)} {lo:.4g}–{hi:.4g}{p}")
    return (f"2-D projections of the front: {_marks_text(pr, rec)}. Objectives over the "
            f"front: " + "; ".join(parts))


def parallel_caption(pr: Any, rec: Mapping[str, Any]) -> str:
    """The parallel coordinates' caption: the variables' ranges over the front."""
    parts = [f"{k} {float(np.min(v)):.4g}–{float(np.max(v)):.4g}"
             for k, v in pr.designs.items()]
    return (f"Design variables and objectives of every front point, each axis scaled to the "
            f"front's range: {_marks_text(pr, rec)}. Variables over the front: "
            + "; ".join(parts))


def hypervolume_caption(pr: Any, rec: Mapping[str, Any]) -> str:
    """The hypervolume history's caption: first and last values, the archive's and the
    held-out roads' interval."""
    h = pr.history
    if not h:
        return "No hypervolume history."
    text = (f"Hypervolume of F/F(prototype) against the reference point "
            f"{', '.join(f'{x:g}' for x in np.ravel(pr.hv_reference))}: {h[0]['hv']:.4g} after "
            f"{h[0]['n_eval']} evaluations, {h[-1]['hv']:.4g} after {h[-1]['n_eval']}")
    if "hv_archive" in h[-1]:
        text += f" (archive {h[-1]['hv_archive']:.4g})"
    held = (rec.get("hypervolume") or {}).get("held_out_roads")
    if held:
        text += (f"; the feasible front re-simulated on {held['n_roads']} held-out roads: "
                 f"{held['mean']:.4g} [{held['interval'][0]:.4g}, {held['interval'][1]:.4g}] "
                 f"(95 %)")
    return text
