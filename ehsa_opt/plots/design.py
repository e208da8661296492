"""Figures of design studies: goal-attainment histories (paper Figs 17–19), Pareto
fronts (2-D projections, parallel coordinates, hypervolume), friction on the
optimum (paper Fig 20) and sweeps."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np

from . import axes_or_new

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..design.goal import GoalAttainmentResult
    from ..design.nsga2 import ParetoResult

__all__ = ["goal_attainment_history", "pareto_projections", "parallel_coordinates",
           "hypervolume_history", "friction_on_optimum", "sweep_lines"]

_LABELS = {
    "total_inertia_gcm2": "total inertia J_t (g cm²)", "lead_mm_per_rev": "screw lead (mm/rev)",
    "speed_constant_rpm_per_V": "generator speed constant k_n (rpm/V)",
    "load_ohm": "load resistance R_e (Ω)",
    "comfort": "comfort α = W_k rms / g (–)", "road_holding": "road holding η_rh (–)",
    "inverse_power": "inverse dimensionless power 1/ρ_g (–)",
    "inverse_efficiency": "inverse efficiency 1/η_g (–)",
    "power_W": "power (W)", "efficiency": "efficiency (–)",
    "comfort_weighted_rms_m_s2": "W_k rms accel. (m/s²)",
}


def _label(k: str) -> str:
    return _LABELS.get(k, k)


def _equivalent_mass(d: Mapping[str, float]) -> float:
    r = d["lead_mm_per_rev"] * 1e-3 / (2 * math.pi)
    return d["total_inertia_gcm2"] * 1e-7 / r ** 2


def goal_attainment_history(res: GoalAttainmentResult, which: str = "design",
                            ax: Axes | None = None) -> Figure:
    """Per SLSQP iteration: ``which='design'`` the design variables (paper Fig 17),
    ``'mass'`` the equivalent mass m_eq (Fig 18), ``'objectives'`` comfort, road
    holding, power and efficiency (Fig 19)."""
    hist = res.history
    it = np.arange(len(hist))
    if which == "mass":
        fig, ax = axes_or_new(ax, (5.5, 3.2))
        if "total_inertia_gcm2" in hist[0]["design"] and "lead_mm_per_rev" in hist[0]["design"]:
            ax.plot(it, [_equivalent_mass(h["design"]) for h in hist], "o-", ms=3)
        ax.set_xlabel("iteration")
        ax.set_ylabel("m_eq = J_t / r² (kg)")
        ax.grid(alpha=0.3)
        ax.set_title("Equivalent mass per iteration (cf. paper Fig 18)", fontsize=9)
        fig.tight_layout()
        return fig
    if which == "design":
        keys = list(hist[0]["design"])
        series = {k: [h["design"][k] for h in hist] for k in keys}
        title = "Design variables per iteration (cf. paper Fig 17)"
    elif which == "objectives":
        o = hist[0]["objectives"]
        keys = [k for k in ("comfort", "road_holding", "power_W", "efficiency") if k in o] \
            or list(res.objective_names)
        series = {k: [h["objectives"][k] for h in hist] for k in keys}
        if "efficiency" in series:
            series["efficiency"] = [100 * v for v in series["efficiency"]]
        title = "Objectives per iteration (cf. paper Fig 19)"
    else:
        raise ValueError(f"goal_attainment_history: which='{which}' unknown (design, mass, "
                         f"objectives)")
    n = len(keys)
    cols = 2 if n > 1 else 1
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(8, 2.4 * rows), squeeze=False)
    for ax, k in zip(axes.ravel(), keys):
        ax.plot(it, series[k], "o-", ms=3)
        ax.set_ylabel("efficiency (%)" if k == "efficiency" else _label(k), fontsize=8)
        ax.grid(alpha=0.3)
        if k in ("total_inertia_gcm2", "speed_constant_rpm_per_V", "load_ohm"):
            ax.set_yscale("log")
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("iteration")
    start = res.stats.get("chosen_start", 0)
    fig.suptitle(f"{title}; γ = {res.gamma:+.4f} (start {'prototype' if start == 0 else start + 1})",
                 fontsize=10)
    fig.tight_layout()
    return fig


def pareto_projections(pr: ParetoResult, ga: Mapping[str, float] | None = None,
                       prototype: Mapping[str, float] | None = None,
                       marks: Mapping[str, Any] | None = None) -> Figure:
    """All 2-D projections of the front, with the pick, the goal-attainment point
    and the prototype.  ``marks`` (optional): ``feasible`` (bool per front point: the
    infeasible ones are drawn as red crosses), ``motor`` (a label per point: one colour per
    motor), ``motor_label`` (the motor model, in the title) and ``active_bounds`` (the
    chosen design's variables at a bound of the box, in the title)."""
    marks = marks or {}
    names = list(pr.objective_names)
    pairs = [(i, j) for i in range(len(names)) for j in range(i + 1, len(names))]
    cols = 3 if len(pairs) > 2 else len(pairs)
    rows = math.ceil(len(pairs) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.3 * rows), squeeze=False)
    n = pr.F.shape[0]
    feas = np.asarray(marks.get("feasible", np.ones(n, bool)), bool)
    motor = marks.get("motor")
    groups = ([(str(m), (np.asarray(motor) == m) & feas) for m in sorted(set(map(str, motor)))]
              if motor is not None and len(motor) == n else [("NSGA-II front", feas)])
    for ax, (i, j) in zip(axes.ravel(), pairs):
        for g, (label, sel) in enumerate(groups):
            if np.any(sel):
                ax.scatter(pr.F[sel, i], pr.F[sel, j], s=12,
                           c="0.5" if len(groups) == 1 else f"C{(g + 4) % 10}", label=label)
        if np.any(~feas):
            ax.scatter(pr.F[~feas, i], pr.F[~feas, j], s=22, marker="x", c="red",
                       label="infeasible (a limit exceeded)")
        k = pr.preferred
        ax.scatter(pr.F[k, i], pr.F[k, j], s=60, marker="D", c="C2", label=f"{pr.pick} pick")
        if ga is not None:
            ax.scatter(ga[names[i]], ga[names[j]], s=90, marker="*", c="C3",
                       label="goal attainment")
        if prototype is not None:
            ax.scatter(prototype[names[i]], prototype[names[j]], s=40, marker="s", c="C0",
                       label="prototype")
        ax.set_xlabel(_label(names[i]), fontsize=8)
        ax.set_ylabel(_label(names[j]), fontsize=8)
        # log axes where the front spans more than a decade: the knee, the goal-attainment
        # point and the prototype sit near the minima and would otherwise overlap
        from matplotlib.ticker import NullFormatter
        for col, setter, axis in ((i, ax.set_xscale, ax.xaxis), (j, ax.set_yscale, ax.yaxis)):
            vals = pr.F[:, col]
            if np.all(vals > 0) and vals.max() > 3 * vals.min():
                setter("log")
                axis.set_minor_formatter(NullFormatter())
        ax.grid(alpha=0.3, which="both")
    for ax in axes.ravel()[len(pairs):]:
        ax.set_visible(False)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, ncol=len(labels), loc="lower center",
               frameon=False, bbox_to_anchor=(0.5, -0.01))
    extra = _front_marks(marks, feas, n)
    fig.suptitle("Pareto front, 2-D projections (all objectives minimised; log axes where "
                 "the front spans more than a factor 3)"
                 + ("\n" + "; ".join(extra) if extra else ""), fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return fig


def parallel_coordinates(pr: ParetoResult, ga: Mapping[str, float] | None = None,
                         ax: Axes | None = None, marks: Mapping[str, Any] | None = None
                         ) -> Figure:
    """Design variables and objectives of every front point, each axis scaled to
    the front's range (log axes for log-scaled spans).  ``marks`` as
    :func:`pareto_projections`: infeasible points dashed red, one colour per motor (else
    colour by comfort), the motor model and the pick's active bounds in the title."""
    marks = marks or {}
    keys = list(pr.designs) + list(pr.objective_names)
    data = np.column_stack([np.asarray(pr.designs[k], float) for k in pr.designs] + [pr.F])
    lo, hi = data.min(axis=0), data.max(axis=0)
    if ga is not None:
        g = np.array([ga[k] for k in keys], float)
        lo, hi = np.minimum(lo, g), np.maximum(hi, g)
    logs = (lo > 0) & (hi / np.where(lo > 0, lo, 1) > 20)

    def norm(v: np.ndarray) -> np.ndarray:
        a = np.where(logs, np.log(np.maximum(v, 1e-300)), v)
        l0 = np.where(logs, np.log(np.maximum(lo, 1e-300)), lo)
        h0 = np.where(logs, np.log(np.maximum(hi, 1e-300)), hi)
        return (a - l0) / np.where(h0 > l0, h0 - l0, 1.0)
    fig, ax = axes_or_new(ax, (9, 4))
    x = np.arange(len(keys))
    n = data.shape[0]
    feas = np.asarray(marks.get("feasible", np.ones(n, bool)), bool)
    motor = marks.get("motor")
    if motor is not None and len(motor) == n:
        names = sorted(set(map(str, motor)))
        colours = [f"C{(names.index(str(m)) + 4) % 10}" for m in motor]
        for i, m in enumerate(names):
            ax.plot([], [], color=f"C{(i + 4) % 10}", lw=1.5, label=m)
    else:
        cmap = plt.get_cmap("viridis")
        c = pr.F[:, 0]
        colours = [cmap(v) for v in (c - c.min()) / (np.ptp(c) or 1.0)]
    for row, col, ok in zip(data, colours, feas):
        ax.plot(x, norm(row), color=col if ok else "red", alpha=0.5 if ok else 0.9,
                lw=0.9, ls="-" if ok else "--")
    if np.any(~feas):
        ax.plot([], [], color="red", ls="--", lw=1.2, label="infeasible (a limit exceeded)")
    ax.plot(x, norm(data[pr.preferred]), color="C2", lw=2.5, label=f"{pr.pick} pick")
    if ga is not None:
        ax.plot(x, norm(g), color="C3", lw=2.5, ls="--", label="goal attainment")
    ax.set_xticks(x, [_label(k) for k in keys], rotation=30, ha="right", fontsize=8)
    for xi, l0, h0, lg in zip(x, lo, hi, logs):
        ax.annotate(f"{h0:.3g}", (xi, 1.02), ha="center", fontsize=6)
        ax.annotate(f"{l0:.3g}", (xi, -0.06), ha="center", fontsize=6)
    ax.set_yticks([])
    ax.set_ylim(-0.1, 1.08)
    ax.legend(fontsize=7, loc="upper right")
    extra = _front_marks(marks, feas, n)
    ax.set_title("Parallel coordinates of the front (colour: "
                 + ("motor" if motor is not None and len(motor) == n else "comfort") + ")"
                 + ("\n" + "; ".join(extra) if extra else ""), fontsize=9)
    fig.tight_layout()
    return fig


def hypervolume_history(histories: Mapping[str, Sequence[Mapping[str, float]]],
                        reference: Sequence[float] | None = None,
                        ax: Axes | None = None) -> Figure:
    """Hypervolume against evaluations, one line per run."""
    fig, ax = axes_or_new(ax, (5.5, 3.4))
    for name, h in histories.items():
        line, = ax.plot([r["n_eval"] for r in h], [r["hv"] for r in h], "o-", ms=3,
                        label=f"{name}: population front")
        if "hv_archive" in h[0]:
            ax.plot([r["n_eval"] for r in h], [r["hv_archive"] for r in h], "--",
                    color=line.get_color(), label=f"{name}: all evaluated (archive)")
    ax.set_xlabel("objective evaluations (designs simulated)")
    ax.set_ylabel("hypervolume of the normalised front (–)")
    ref = ("" if reference is None else
           ", reference point (" + ", ".join(f"{float(x):g}" for x in np.ravel(reference)) + ")")
    ax.set_title(f"Hypervolume of F/F(prototype){ref}", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def friction_on_optimum(rows: Sequence[Mapping[str, float | str]]) -> Figure:
    """Paper Fig 20: power, comfort change, efficiency and road-holding change
    against speed for each friction case."""
    cases = list(dict.fromkeys(r["friction"] for r in rows))
    fig, axes = plt.subplots(2, 2, figsize=(9, 6))
    panels = [("power_W", "power (W)", axes[0, 0]),
              ("comfort_change_pct", "comfort vs frictionless (%)", axes[0, 1]),
              ("efficiency_pct", "efficiency (%)", axes[1, 0]),
              ("road_holding_change_pct", "road holding vs frictionless (%)", axes[1, 1])]
    for key, lab, ax in panels:
        for c in cases:
            rr = sorted((r for r in rows if r["friction"] == c), key=lambda r: r["speed_km_per_h"])
            ax.plot([r["speed_km_per_h"] for r in rr], [r[key] for r in rr], "o-", ms=4, label=c)
        ax.set_xlabel("speed (km/h)")
        ax.set_ylabel(lab, fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Friction on the optimised design (cf. paper Fig 20); positive comfort/road "
                 "holding change = better", fontsize=9)
    fig.tight_layout()
    return fig


def sweep_lines(rows: Sequence[Mapping[str, float | str]], x: str, ys: Sequence[str],
                hue: Sequence[str]) -> Figure:
    """Metrics ``ys`` against ``x``, one line per combination of the ``hue`` columns."""
    groups: dict[tuple, list] = {}
    for r in rows:
        groups.setdefault(tuple(r[h] for h in hue), []).append(r)
    n = len(ys)
    cols = 2 if n > 1 else 1
    nrows = math.ceil(n / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(8.5, 2.8 * nrows), squeeze=False)
    for ax, y in zip(axes.ravel(), ys):
        for key, rr in groups.items():
            rr = sorted(rr, key=lambda r: r[x])
            ax.plot([r[x] for r in rr], [r[y] for r in rr], "o-", ms=3,
                    label=", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in key))
        ax.set_xlabel(_label(x), fontsize=8)
        ax.set_ylabel(_label(y), fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    if len(groups) <= 12:
        axes[0, 0].legend(fontsize=6, title=", ".join(hue), title_fontsize=6)
    fig.tight_layout()
    return fig


def _front_marks(marks: dict, feas: np.ndarray, n: int) -> list[str]:
    """The words a front figure's title carries: the motor, how many points are
    infeasible, and the pick's active bounds."""
    extra = []
    if marks.get("motor_label"):
        extra.append(f"motor: {marks['motor_label']}")
    if np.any(~feas):
        extra.append(f"{int(np.sum(~feas))} of {n} points infeasible")
    if marks.get("active_bounds"):
        extra.append("pick at a bound: " + ", ".join(marks["active_bounds"]))
    return extra
