"""Figures of the model-discrepancy workflow (residual maps before/after, zooms where
the effect lives, per-test errors, candidate ranking)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import axes_or_new, plt, save

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..estimation.discrepancy import DiscrepancyResult

__all__ = ["residual_maps", "zoom", "per_test_errors", "ranking", "figures", "all_figures"]

_COORD_LABEL = {"cycle_phase": "cycle phase (rad)", "displacement": "displacement (mm)",
                "velocity": "velocity (m/s)", "direction": "direction sign(v)",
                "time_since_reversal": "time since velocity reversal (s)",
                "rotor_angle": "rotor angle mod 2π (rad)", "test": "test index"}


def residual_maps(result: DiscrepancyResult) -> Figure:
    """Binned mean normalised residual against each coordinate, before and after."""
    chans = list(result.loc_before.channels)
    coords = ["cycle_phase", "velocity", "time_since_reversal", "rotor_angle", "displacement",
              "test"]
    coords = [c for c in coords if c in result.loc_before.channels[chans[0]].coordinates]
    fig, axes = plt.subplots(len(chans), len(coords), figsize=(2.6 * len(coords),
                                                               2.3 * len(chans)),
                             squeeze=False)
    for i, ch in enumerate(chans):
        for j, c in enumerate(coords):
            ax = axes[i, j]
            for loc, lab, col in ((result.loc_before, "baseline", "C3"),
                                  (result.loc_after, f"+ {result.effect}", "C0")):
                if loc is None or c not in loc.channels[ch].coordinates:
                    continue
                st = loc.channels[ch].coordinates[c]
                x = st.centres * (1e3 if c == "displacement" else 1.0)
                ax.plot(x, st.means, "o-", ms=2.5, lw=1, color=col,
                        label=f"{lab} R²={st.r2:.2f}")
            if c == "time_since_reversal":
                ax.set_xscale("log")
            ax.axhline(0, color="0.6", lw=0.6)
            ax.set_xlabel(_COORD_LABEL[c], fontsize=7)
            if j == 0:
                ax.set_ylabel(f"{ch} residual / σ", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.legend(fontsize=6, loc="best")
    fig.suptitle("Residual maps (binned mean of (measured − simulated)/noise)", fontsize=10)
    fig.tight_layout()
    return fig


def zoom(result: DiscrepancyResult, n_tests: int = 2) -> Figure:
    """Measured vs simulated force (and voltage) zoomed where the baseline misses most
    (e.g. velocity reversals for backlash), baseline and with the named effect."""
    allp = result.fit_tests + result.heldout_tests
    w = result.winner
    order = sorted(range(len(allp)), key=lambda k: -np.max(np.abs(
        (allp[k].y[0] - result.baseline_pred[k][0]) * allp[k].wnorm[0])))[:n_tests]
    ny = allp[0].y.shape[0]
    fig, axes = plt.subplots(ny, len(order), figsize=(5 * len(order), 2.6 * ny), squeeze=False)
    for j, k in enumerate(order):
        pt = allp[k]
        r = np.abs(pt.y[0] - result.baseline_pred[k][0]) * (pt.weight > 0)
        i0 = int(np.argmax(r))
        t = pt.time_s
        span = 0.12 / (pt.motion.frequency_hz if hasattr(pt.motion, "frequency_hz") else 1.0)
        span = max(span, 40 * float(np.median(np.diff(t))))
        sel = (t >= t[i0] - span) & (t <= t[i0] + span)
        for ch in range(ny):
            ax = axes[ch, j]
            ax.plot(t[sel], pt.y[ch][sel], ".", ms=2, color="0.4", label="measured")
            ax.plot(t[sel], result.baseline_pred[k][ch][sel], "-", lw=1.2, color="C3",
                    label="baseline")
            if w is not None and w.predictions is not None:
                ax.plot(t[sel], w.predictions[k][ch][sel], "-", lw=1.2, color="C0",
                        label=f"+ {w.effect}")
            out = sel & (pt.weight == 0)  # corner / dwell windows, not fitted
            if out.any():
                ax.fill_between(t[sel], 0, 1, where=out[sel], color="0.85", lw=0,
                                transform=ax.get_xaxis_transform(),
                                label="not resolved (left out)")
            ax.set_ylabel(["force (N)", "voltage (V)"][ch], fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
            if ch == 0:
                ax.set_title(f"{pt.test.label} ({'fit' if k < len(result.fit_tests) else 'held-out'})",
                             fontsize=9)
                ax.legend(fontsize=7)
        axes[-1, j].set_xlabel("time (s)", fontsize=8)
    fig.tight_layout()
    return fig


def per_test_errors(result: DiscrepancyResult, ax: Axes | None = None) -> Figure:
    """Relative force error per test before/after, fit and held-out tests marked."""
    rows = result.per_test_errors()
    fig, ax = axes_or_new(ax, (max(5, 0.5 * len(rows) + 2), 3))
    x = np.arange(len(rows))
    ax.bar(x - 0.2, [r["error_before"] for r in rows], 0.4, color="C3", label="baseline")
    ax.bar(x + 0.2, [r["error_after"] for r in rows], 0.4, color="C0",
           label=f"+ {result.effect}" if result.effect != "none" else "(no effect added)")
    ax.set_xticks(x)
    ax.set_xticklabels([("* " if r["set"] == "held-out" else "") + r["test"] for r in rows],
                       rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("relative force error (%)")
    ax.set_title("Error per test (* = held out, not used to fit)", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def ranking(result: DiscrepancyResult) -> Figure:
    """Signature score and ΔBIC of every candidate."""
    cs = [c for c in result.candidates if c.applicable]
    fig, axes = plt.subplots(1, 2, figsize=(9, 2.8))
    names = [c.effect for c in cs]
    axes[0].barh(names, [max(c.score, 1e-8) for c in cs], color="C2")
    axes[0].set_xscale("log")
    axes[0].set_xlabel("signature score (share of residual explained)", fontsize=8)
    fitted = [c for c in cs if c.fitted and np.isfinite(c.delta_bic_fit)]
    axes[1].barh([c.effect for c in fitted], [c.delta_bic_fit for c in fitted], 0.4,
                 align="edge", color="C1", label="ΔBIC fit tests")
    axes[1].barh([c.effect for c in fitted], [np.nan_to_num(c.delta_bic_heldout)
                                              for c in fitted], -0.4, align="edge", color="C4",
                 label="ΔBIC held-out")
    axes[1].axvline(0, color="k", lw=0.8)
    axes[1].set_xscale("symlog")
    axes[1].set_xlabel("ΔBIC (< 0 on both is necessary, not sufficient: the effect must\n"
                       "also reduce the error by the rule's practical size; earns: see the table)",
                       fontsize=7)
    axes[1].legend(fontsize=7)
    for a in axes:
        a.tick_params(labelsize=7)
    fig.tight_layout()
    return fig


def figures(result: DiscrepancyResult) -> dict[str, Figure]:
    """Every figure of the report, keyed by file name (nothing written)."""
    return {f"discrepancy_{name}.png": fn(result)
            for name, fn in (("residual_maps", residual_maps), ("zoom", zoom),
                             ("per_test_errors", per_test_errors), ("ranking", ranking))}


def all_figures(result: DiscrepancyResult, out_dir: Path) -> list[Path]:
    """Write :func:`figures` into ``out_dir`` (PNG, atomically, through :func:`save`);
    returns their paths.  The writer behind the discrepancy result's folder."""
    return [save(fig, Path(out_dir) / name) for name, fig in figures(result).items()]
