"""Figures of the robust-design step (design with friction in the loop)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["fronts_with_friction", "optimum_vs_friction_and_speed"]


def fronts_with_friction(fronts: Mapping[str, Mapping[str, np.ndarray]],
                         points: Mapping[str, Mapping[str, float]] | None = None) -> Figure:
    """Fronts (dict label → {power_W, comfort, road_holding}) on the same axes:
    power against comfort and against road holding; ``points`` marks single designs."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    styles = ["o", "s", "^", "v", "D"]
    for j, (label, fr) in enumerate(fronts.items()):
        for ax, key in zip(axes, ("comfort", "road_holding")):
            ax.scatter(fr[key], fr["power_W"], s=16, marker=styles[j % len(styles)],
                       alpha=0.7, label=label)
    for label, p in (points or {}).items():
        for ax, key in zip(axes, ("comfort", "road_holding")):
            ax.scatter([p[key]], [p["power_W"]], s=90, marker="*", edgecolor="k", zorder=5,
                       label=label)
    axes[0].set_xlabel("comfort α (–)")
    axes[1].set_xlabel("road holding η_rh (–)")
    for ax in axes:
        ax.set_ylabel("power (W)")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7, loc="best")
    fig.suptitle("Pareto fronts evaluated with friction (worst of min/max, fast path)",
                 fontsize=10)
    fig.tight_layout()
    return fig


def optimum_vs_friction_and_speed(rows: Sequence[Mapping[str, float | str]]) -> Figure:
    """Optimum lead and load against speed, one line per friction level
    (rows: friction, speed_km_per_h, lead_mm_per_rev, load_ohm)."""
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    levels = list(dict.fromkeys(r["friction"] for r in rows))
    for lev in levels:
        sub = sorted((r for r in rows if r["friction"] == lev),
                     key=lambda r: r["speed_km_per_h"])
        v = [r["speed_km_per_h"] for r in sub]
        axes[0].plot(v, [r["lead_mm_per_rev"] for r in sub], "o-", label=lev)
        axes[1].plot(v, [r["load_ohm"] for r in sub], "o-", label=lev)
    axes[0].set_ylabel("optimum lead (mm/rev)")
    axes[1].set_ylabel("optimum load R_e (Ω)")
    axes[1].set_yscale("log")
    for ax in axes:
        ax.set_xlabel("speed (km/h)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, title="friction")
    fig.tight_layout()
    return fig
