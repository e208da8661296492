"""Figures of the friction identification (paper Figs 8–12, identifiability, joint fit)."""

from __future__ import annotations

from typing import TYPE_CHECKING
from collections.abc import Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np

from . import axes_or_new, bench_fit

if TYPE_CHECKING:  # types only: plotting draws results it is given, it runs nothing
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..datasets.bench_format import BenchTest
    from ..estimation.bounds import FrictionBounds
    from ..estimation.fit_result import FitResult
    from ..estimation.identify_result import IdentificationReport, Prediction
    from ..physics.params import FrictionParams

__all__ = [
    "bounds_figure",
    "fit_result",
    "friction_bounds",
    "identifiability_figure",
    "iterations_objective",
    "iterations_parameters",
    "objective_vs_parameter",
    "report_figures",
]


def iterations_objective(result: FitResult, title: str = "", ax: Axes | None = None) -> Figure:
    """Fig 8: objective and normalised rms errors per IPOPT iteration (best start)."""
    h = result.history
    fig, ax = axes_or_new(ax, (6.5, 3.4))
    it = np.arange(len(h["objective"]))
    ax.semilogy(it, h["rms_F"], "o-", ms=3, label="force: normalised rms error")
    if h.get("rms_V") is not None:
        ax.semilogy(it, h["rms_V"], "s-", ms=3, label="voltage: normalised rms error")
    ax.semilogy(it, h["objective"], "k--", lw=1, label="objective t + w·mean J (scaled)")
    ax.set_xlabel("IPOPT iteration")
    ax.set_ylabel("value")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title(title or "Objective values per iteration (paper Fig 8)", fontsize=10)
    fig.tight_layout()
    return fig


def iterations_parameters(result: FitResult, title: str = "") -> Figure:
    """Fig 9: each free parameter per IPOPT iteration (best start)."""
    pars = result.history["parameters"]
    n = len(pars)
    cols = 4 if n > 4 else n
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 2.2 * rows), squeeze=False)
    for ax, (name, vals) in zip(axes.ravel(), pars.items()):
        ax.plot(vals, "o-", ms=2.5, color="C2")
        ax.set_title(name, fontsize=7)
        ax.set_xlabel("IPOPT iteration", fontsize=7)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    fig.suptitle(title or "Parameter values per iteration (paper Fig 9)", fontsize=10)
    fig.tight_layout()
    return fig


def objective_vs_parameter(report: IdentificationReport,
                           name: str = "bearing_viscous_Nms_per_rad",
                           ax: Axes | None = None) -> Figure:
    """Fig 10: final objective of every start against one parameter, across tests."""
    fig, ax = axes_or_new(ax, (6.5, 3.6))
    cmap = plt.get_cmap("viridis")
    n = max(len(report.fits), 1)
    for k, (t, f) in enumerate(zip(report.data.tests, report.fits)):
        xs = [s["final"].get(name, np.nan) for s in f.starts if s["success"]]
        ys = [s["objective"] for s in f.starts if s["success"]]
        ax.scatter(xs, ys, s=12, color=cmap(k / n), alpha=0.7)
        if f.success:
            ax.scatter([f.parameters[name]], [f.objective], s=40, marker="*", color=cmap(k / n),
                       edgecolor="k", lw=0.4)
    ax.set_xlabel(name)
    ax.set_ylabel("final objective (scaled)")
    ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(f"Objective against {name} across tests (paper Fig 10); star = kept start",
                 fontsize=9)
    fig.tight_layout()
    return fig


def bounds_figure(report: IdentificationReport,
                  truth: Mapping[str, float] | None = None) -> Figure:
    """Fig 12: per-test identified values (x: each test's frequency and load) and the
    per-parameter min/max bounds (the paper's method); ``truth``: a mapping of the true
    values of synthetic data, drawn as a dashed line."""
    names = list(report.bounds)
    n = len(names)
    cols = 4 if n > 4 else max(n, 1)
    rows = int(np.ceil(n / cols)) or 1
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 2.4 * rows), squeeze=False)
    good = [(t, f) for t, f in zip(report.data.tests, report.fits) if f.success]
    for ax, name in zip(axes.ravel(), names):
        vals = [f.parameters[name] for _, f in good]
        xs = np.arange(len(vals))
        ax.plot(xs, vals, "o", ms=3, color="C0", label="per-test fit")
        lo, hi = report.bounds[name]
        ax.axhline(lo, color="C3", lw=1, label="min / max over the tests")
        ax.axhline(hi, color="C3", lw=1)
        if truth and name in truth:
            ax.axhline(float(truth[name]), color="k", ls="--", lw=1, label="truth")
        ax.set_title(name, fontsize=7)
        ax.set_xticks(xs)
        ax.set_xticklabels([t.label.replace(" ohm", " Ω") for t, _ in good], rotation=90,
                           fontsize=5)
        ax.tick_params(axis="y", labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, ncol=3, loc="lower center", frameon=False,
               bbox_to_anchor=(0.5, -0.02))
    fig.suptitle("Identified friction per test (x: test frequency, load) and the "
                 "per-parameter bounds, paper's method (paper Fig 12, Table 2)", fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return fig


def identifiability_figure(report: IdentificationReport,
                           peak_velocity_m_per_s: Sequence[float]) -> Figure:
    """Relative Fisher eigenvalues per test, and the rod friction against its split, each
    test drawn up to its own peak rod velocity (``peak_velocity_m_per_s``, per test in
    file order)."""
    from ..physics.friction import bearing_friction_Nm, nut_friction_N, rod_friction_N
    from ..physics.params import FRICTION_NAMES

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 3.8))
    good = [(t, f, vp) for t, f, vp in zip(report.data.tests, report.fits,
                                             peak_velocity_m_per_s)
            if f.success and f.identifiability and "directions" in f.identifiability]
    for k, (_, f, _vp) in enumerate(good):
        ev = np.clip(f.identifiability["relative_eigenvalues"], 1e-20, None)
        a1.semilogy(np.full(len(ev), k), ev, "o", ms=3, color="C0")
    if good:
        rtol = good[0][1].identifiability.get("threshold", 1e-6)
        a1.axhline(rtol, color="C3", ls="--", lw=1, label="identifiability threshold")
        a1.legend(fontsize=8)
    a1.set_xlabel("test number (file order)")
    a1.set_ylabel("Fisher eigenvalue / largest (–)")
    a1.set_title("Fisher information spectrum per test (scaled parameters)", fontsize=9)
    a1.grid(alpha=0.3, which="both")
    r = report.data.harvester.lead_m_per_rad
    if good and "nut_coulomb_N" in good[0][1].parameters:
        for k, (_t, f, vp) in enumerate(good):
            # each test only up to its own peak velocity: beyond it the curve is an
            # extrapolation no measurement supports
            v = np.linspace(0.002, max(float(vp), 0.003), 200)
            p = [f.parameters[n] for n in FRICTION_NAMES]
            lab = k == 0
            a2.plot(v, rod_friction_N(v, p, r), color="k", lw=0.8, alpha=0.6,
                    label="rod total F_ns + T_b/r" if lab else None)
            a2.plot(v, nut_friction_N(v, p), color="C0", lw=0.6, alpha=0.5,
                    label="nut F_ns" if lab else None)
            a2.plot(v, bearing_friction_Nm(v / r, p) / r, color="C1", lw=0.6, alpha=0.5,
                    label="bearings T_b/r" if lab else None)
        a2.set_xlabel("rod velocity (m/s)")
        a2.set_ylabel("friction force at the rod (N)")
        a2.legend(fontsize=8, loc="upper left", framealpha=0.9)
        a2.grid(alpha=0.3)
        a2.set_title("Each test up to its own peak velocity: the total agrees, the split "
                     "does not", fontsize=9)
    fig.tight_layout()
    return fig


def fit_result(result: FitResult, test: BenchTest | None = None,
               prediction: Prediction | None = None) -> list[Figure]:
    """Figures of one :class:`~ehsa_opt.estimation.fit_result.FitResult`: Figs 8, 9,
    and 11 when a ``test`` and the model's ``prediction`` of it are given."""
    figs = [iterations_objective(result), iterations_parameters(result)]
    if test is not None and prediction is not None:
        figs.append(bench_fit(test, prediction, title="Measured vs simulated (paper Fig 11)"))
    return figs


def report_figures(report: IdentificationReport, representative: int,
                   prediction: Prediction, peak_velocity_m_per_s: Sequence[float],
                   holdout_prediction: Prediction | None = None,
                   truth: Mapping[str, float] | None = None) -> dict[str, Figure]:
    """All identification figures of a report, keyed by file name (nothing written).

    ``representative``: index of the test of Figs 8, 9 and 11 and ``prediction`` the
    model's signals on it at its fit; ``holdout_prediction``: the joint fit's signals on
    the first held-out test; ``truth``: the true friction of synthetic data (Fig 12)."""
    figs: dict[str, Figure] = {}
    tests = report.data.tests
    good = [k for k, f in enumerate(report.fits) if f.success]
    if not good:
        return figs
    f, t = report.fits[representative], tests[representative]
    figs["fig08_objective_iterations.png"] = iterations_objective(
        f, f"Objective per iteration, {t.label} (paper Fig 8)")
    figs["fig09_parameter_iterations.png"] = iterations_parameters(
        f, f"Parameters per iteration, {t.label} (paper Fig 9)")
    name = ("bearing_viscous_Nms_per_rad" if report.data.has_generator
            else "nut_viscous_Ns_per_m")
    several = len(good) >= 2  # Figs 10 and 12 compare tests: not drawn for a single test
    if several:
        figs["fig10_objective_vs_tv.png"] = objective_vs_parameter(report, name)
    figs["fig11_measured_vs_simulated.png"] = bench_fit(
        t, prediction, title=f"Measured vs simulated, {t.label} (paper Fig 11); "
                             f"δ_F = {f.delta_F:.3f}"
        + (f", δ_V = {f.delta_V:.3f}" if f.delta_V is not None else "")
        + f", rel. error {f.force_relative_error_percent:.2f} %")
    if several:
        figs["fig12_bounds.png"] = bounds_figure(report, truth)
    figs["identifiability.png"] = identifiability_figure(report, peak_velocity_m_per_s)
    if holdout_prediction is not None:
        held = [x for x in tests if x.file == report.holdout_files[0]]
        err = report.holdout_errors[0]
        figs["joint_fit_holdout.png"] = bench_fit(
            held[0], holdout_prediction,
            title=f"Joint fit on held-out test {held[0].label}: δ_F = {err['delta_F']:.3f}, "
                  f"rel. error {err['force_relative_error_percent']:.2f} %")
    return figs


def friction_bounds(fb: FrictionBounds, truth: FrictionParams | None = None,
                    title: str = "") -> Figure:
    """Rod friction F_ns(v) + T_b(v/r)/r against velocity.  Left: the sets and the best
    law's band over the whole range (0–3 m/s) with the identified range shaded; right:
    the identified range — per-test fits, the envelope, the sets and the paper's
    per-parameter sets (and the truth of synthetic data)."""
    from ..physics.friction import rod_friction_N
    v = np.asarray(fb.velocity_m_per_s)
    lo, hi = getattr(fb, "data_range_m_per_s", (v.min(), v.max()))
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.0))
    tr = (np.asarray(rod_friction_N(v, truth, fb.lead_m_per_rad), dtype=float)
          if truth is not None else None)
    ax.axvspan(lo, hi, color="0.85", alpha=0.6, lw=0,
               label=f"identified range ({lo:.3g}–{hi:.2f} m/s)")
    if getattr(fb, "law_band_N", None) is not None:
        ax.fill_between(v, fb.law_band_N[0], fb.law_band_N[1], color="C2", alpha=0.25,
                        label="best law's 95 % band (sandwich)")
    for a in (ax, ax2):
        a.plot(v, fb.sets_rod_N["min"], "C0--", lw=1.3, label="min set")
        a.plot(v, fb.sets_rod_N["best"], "C2-", lw=1.5, label="best set")
        a.plot(v, fb.sets_rod_N["max"], "C3--", lw=1.3, label="max set")
        if tr is not None:
            a.plot(v, tr, "k-", lw=0.9, label="truth (synthetic data)")
        a.set_xlabel("rod velocity (m/s)")
        a.set_ylabel("friction force at the rod (N)")
        a.grid(alpha=0.3)
    ax.set_xlim(0.0, float(v.max()))
    ax.set_ylim(bottom=0.0)
    for k, row in enumerate(fb.per_test_N):
        ax2.plot(v, row, color="0.7", lw=0.7,
                 label="per-test fits (up to each test's peak velocity)" if k == 0 else None)
    ax2.fill_between(v, fb.lower_N, fb.upper_N, color="C0", alpha=0.15,
                     label="envelope of the tests")
    if fb.paper_rod_N:
        ax2.plot(v, fb.paper_rod_N["min"], "C4:", lw=1.6, label="paper's method: min")
        ax2.plot(v, fb.paper_rod_N["max"], "C1:", lw=1.6, label="paper's method: max")
    inside = v <= hi * (1 + 1e-9)
    ax2.set_xlim(0.0, hi)
    top = [np.nanmax(fb.upper_N[inside])] + [float(np.max(c[inside]))
                                              for c in fb.sets_rod_N.values()]
    ax2.set_ylim(0.0, 1.15 * max(top))
    handles, labels = [], []
    for a in (ax, ax2):
        for h, lab in zip(*a.get_legend_handles_labels()):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=4, frameon=False,
               bbox_to_anchor=(0.5, -0.02))
    ax.set_title("Sets over 0–3 m/s: measured (shaded) and extrapolated", fontsize=10)
    ax2.set_title("The identified range: tests, envelope, paper's bounds", fontsize=10)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.14, 1, 1))
    return fig
