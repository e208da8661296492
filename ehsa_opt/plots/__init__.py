"""Figures (matplotlib, Agg backend). Computation modules never import plotting.

Each function takes data (results, arrays), draws and returns a
:class:`matplotlib.figure.Figure`; one-panel figures take ``ax=None`` (draw into that
axes instead of a new figure).  Nothing here runs a computation of a lower room, and
only :func:`save` writes a file (atomically, as PNG).  Topic modules live beside this one (``plots.identify``,
``plots.quarter_car``, ``plots.design``, ``plots.discrepancy``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from ..utils.io import atomic_write_with  # noqa: E402

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..datasets.bench_format import BenchTest
    from ..estimation.test_simulation import Prediction

__all__ = ["save", "bench_fit", "axes_or_new"]


def axes_or_new(ax: Axes | None, figsize: tuple[float, float]) -> tuple[Figure, Axes]:
    """``ax`` and its figure, or a new figure of ``figsize`` with one axes."""
    if ax is not None:
        return ax.get_figure(), ax  # type: ignore[return-value]
    fig, new = plt.subplots(figsize=figsize)
    return fig, new


def save(fig: Figure, path: str | Path, dpi: int = 110) -> Path:
    """Save ``fig`` as PNG via a temporary file + rename, then close it."""
    try:
        return atomic_write_with(
            path, lambda tmp: fig.savefig(tmp, dpi=dpi, bbox_inches="tight", format="png"))
    finally:
        plt.close(fig)


def bench_fit(test: BenchTest, sim: Prediction, title: str = "") -> Figure:
    """Measured vs simulated force (and voltage when recorded) of one bench test."""
    rows = 2 if test.voltage_V is not None else 1
    fig, axes = plt.subplots(rows, 1, figsize=(8, 2.6 * rows), sharex=True, squeeze=False)
    ax = axes[0, 0]
    ax.plot(test.time_s, test.force_N, lw=0.8, color="0.35", label="measured")
    ax.plot(sim.time_s, sim.force_N, lw=1.2, color="C3", label="simulated")
    ax.set_ylabel("force (N)")
    ax.legend(loc="upper right", fontsize=8)
    if rows == 2:
        ax = axes[1, 0]
        ax.plot(test.time_s, test.voltage_V, lw=0.8, color="0.35", label="measured")
        ax.plot(sim.time_s, sim.voltage_V, lw=1.2, color="C0", label="simulated")
        ax.set_ylabel("voltage (V)")
    axes[-1, 0].set_xlabel("time (s)")
    for a in axes[:, 0]:
        a.grid(alpha=0.3)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig
