"""Figures (matplotlib, Agg backend). Computation modules never import plotting.

Each function returns a :class:`matplotlib.figure.Figure`; :func:`save` writes it
atomically as PNG.  Topic modules live beside this one (``plots.identify``,
``plots.quarter_car``, ``plots.design``, ``plots.discrepancy``).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from ..utils.io import current_umask  # noqa: E402

__all__ = ["save", "bench_fit"]


def save(fig: Any, path: str | Path, dpi: int = 110) -> Path:
    """Save ``fig`` as PNG via a temporary file + rename, then close it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=dpi, bbox_inches="tight", format="png")
        os.chmod(tmp, 0o666 & ~current_umask())  # mkstemp made it 0600
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)
        plt.close(fig)
    return path


def bench_fit(test: Any, sim: Any, title: str = "") -> Any:
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
