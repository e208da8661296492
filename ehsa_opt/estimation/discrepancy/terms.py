"""Data-driven discovery of a missing force term when no catalogue effect earns.

The force residual r = F_measured − F_model of the fit tests is regressed on a
library of physically meaningful features (:func:`feature_library`), grouped by
what they would mean:

``stroke``
    Gaussian bumps in stroke position x, alone (a force that depends on where the
    rod is, both directions) and times tanh(v/u) (friction-like, opposing the motion
    over part of the stroke: a rough spot, a dent, a worn section).
``rotor_angle``
    sin/cos(k θ), θ = x/r, k = 1 … 24 (a force periodic in the rotor angle: cogging
    of another period, a periodic lead error, an eccentric rotor).
``lag``
    dF̂/dt of the model force: F(t − τ) ≈ F(t) − τ dF/dt, so a coefficient −τ is a
    force channel delayed by τ relative to the displacement.  A pure time shift of
    the model force (searched on ±20 ms) competes with the sparse term: when it
    explains the fit set better, the lag is proposed as the exact shift.
``current``
    i|i| and i³ of the model current (i ≈ V̂/R_load): a generator constant
    falling with current (magnetic saturation).
``velocity``
    tanh(v/u), v, v|v|, a, 1: a friction or inertia law of another shape.
``sensor``
    H[F̂] − F̂ for second-order low-passes H = ω²/(s² + 2ζωs + ω²) on
    :data:`SENSOR_GRID` (bandwidths below 0.4 × the sample rate): a record through a
    sensor whose lag depends on the frequency (the force sensor's own dynamics).  Not
    a Taylor series in the derivatives of F̂: the model's friction turns over in a few
    ms at a reversal, where a low-pass's transient is what the record shows.
``drift``
    (s_c/S) tanh(v/u) and (s_c/S) v, s_c the campaign's cumulative sliding distance in
    the tests' run order and S its total (:mod:`.campaign_travel`): a friction level
    that changes over the campaign (a rig running in); only when the tests state their
    run order.
``presliding``
    sign(v) exp(−s/ℓ), s the rod's travel since the last reversal, ℓ on
    :data:`PRESLIDING_LENGTHS_M`: friction that changes over a *distance* after each
    reversal (presliding, a transition length) rather than over a velocity — a
    friction law of another shape too.

A term of the ``velocity`` or ``presliding`` group (:data:`FRICTION_LAW_GROUPS`) is a
friction law the baseline's does not follow, not an effect the rig lacks: it is
reported (the residual's shape, in words) but does not make the answer "none of the
catalogue" (:func:`names_an_effect`).

The sparse regression is scikit-learn's :class:`~sklearn.linear_model.LassoCV`
(contiguous folds, so neighbouring samples do not leak between folds) on
standardised columns, followed by a least-squares refit on the selected columns
(removes the lasso's shrinkage).  The group carrying most of the fitted term's
energy names it, in words.  The term's *held-out gain* is measured like a
catalogue effect's: the held-out force prediction plus the term, against the
held-out measurement; :func:`propose_term` judges it by the decision rule
(:func:`~.judge.earns`), and proposes none when the residual is white.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from .criterion import DEFAULT_CRITERION, Criterion
from .evidence import autocorrelation_time, delta_bic, effective_samples, residual_is_white
from .judge import judge_change
from ..identify_result import force_relative_error_percent
from .prepared import PreparedTest
from .presliding import travel_since_reversal_m
from .campaign_travel import campaign_travel_m, run_order_known, travel_coordinates
from .record_shift import LAG_GRID_S, per_test_delays, shift_lag, shift_sse_curves, shifted_force
from .sensor_filter import filtered_force, sample_step_s
from .sensor_term import (per_test_delays_left, per_test_sensor, refined_sensor, sensor_of,
                          with_sensor_term)

__all__ = ["TermProposal", "shifted_force", "names_an_effect", "travel_since_reversal_m",
           "FRICTION_LAW_GROUPS",
           "PRESLIDING_LENGTHS_M", "feature_library", "discover_term", "propose_term", "shift_lag",
           "shift_sse_curves", "per_test_delays", "per_test_sensor", "per_test_delays_left",
           "GROUPS", "LAG_GRID_S",
           "SENSOR_GRID"]

#: Feature groups of the library, in the order they are described.
GROUPS: tuple[str, ...] = ("stroke", "rotor_angle", "lag", "sensor", "current", "velocity",
                           "drift", "presliding")
#: Second-order sensors whose action H[F̂] − F̂ on the model force is a ``sensor``
#: column: (bandwidth Hz, damping ratio) — bandwidths half an octave apart over the load
#: cells and conditioning filters of damper benches (10–160 Hz), dampings from light to
#: critical.
SENSOR_GRID: tuple[tuple[float, float], ...] = tuple(
    (round(10.0 * 2 ** (k / 2), 1), z) for k in range(9) for z in (0.2, 0.45, 0.7, 1.0))
#: Groups whose term is one of their columns (a sensor is one low-pass): when the sparse
#: regression selects any of them, the group's term is its best column alone (BIC).
SINGLE_COLUMN_GROUPS: tuple[str, ...] = ("sensor",)
#: Groups that describe the friction (or inertia) law itself: a term of these is a
#: friction law of another shape, not an effect outside the catalogue.
FRICTION_LAW_GROUPS: tuple[str, ...] = ("velocity", "presliding")
#: Transition lengths ℓ of the presliding columns sign(v) exp(−s/ℓ), m of rod travel
#: (ball-screw presliding displacements are tens of µm; the grid spans 10 µm – 0.3 mm).
PRESLIDING_LENGTHS_M: tuple[float, ...] = (1e-5, 3e-5, 1e-4, 3e-4)
#: Gaussian bumps over the stroke.
N_STROKE_BUMPS = 16
#: Highest rotor-angle harmonic, periods per revolution.
MAX_ROTOR_PERIODS = 24
#: Highest rotor-angle harmonic of the current-modulated columns i·sin/cos(k θ).
MAX_CURRENT_PERIODS = 4


@dataclass
class TermProposal:
    """A data-driven force term (mirrors ``OptimizeResult``: ``success``, ``message``).

    Attributes
    ----------
    description : str
        The term in words, e.g. "force term localised at stroke 4–10 mm, both
        directions".
    group : str
        The feature group carrying most of the term (see module docstring).
    group_shares : dict
        Share of the fitted term's energy per group.
    columns : dict
        Selected feature → coefficient (N per unit feature).
    error_before, error_after : float
        Held-out relative force error (%) of the model without / with the term.
    sse_before, sse_after : float
        Held-out SSE of the noise-normalised force residual.
    quantity : dict
        The named quantity (e.g. ``{"lag_ms": 3.1}``, ``{"stroke_mm": [4, 10]}``).
    sse_fit_before, sse_fit_after : float
        The same SSE on the fit tests (where the term was fitted).
    earns : bool
        Whether the term earns by the decision rule (:func:`propose_term`).
    refused : str
        Why a term that would earn by its size is not a term of the record ("" when
        it is not refused; :func:`propose_term`).
    """

    success: bool
    message: str
    description: str = ""
    group: str = ""
    group_shares: dict[str, float] = field(default_factory=dict)
    columns: dict[str, float] = field(default_factory=dict)
    error_before: float = math.nan
    error_after: float = math.nan
    sse_before: float = math.nan
    sse_after: float = math.nan
    quantity: dict = field(default_factory=dict)
    sse_fit_before: float = math.nan
    sse_fit_after: float = math.nan
    earns: bool = False
    refused: str = ""

    def as_dict(self) -> dict:
        return {"description": self.description, "group": self.group,
                "group_shares": self.group_shares, "columns": self.columns,
                "error_before": self.error_before, "error_after": self.error_after,
                "sse_before": self.sse_before, "sse_after": self.sse_after,
                "quantity": self.quantity, "earns_on_heldout": self.earns,
                "sse_fit_before": self.sse_fit_before, "sse_fit_after": self.sse_fit_after,
                "refused": self.refused, "message": self.message}


def _stroke_centres(pts: Sequence[PreparedTest]) -> tuple[np.ndarray, float]:
    x = np.concatenate([pt.u[0] for pt in pts])
    lo, hi = np.percentile(x, [0.5, 99.5])
    c = np.linspace(lo, hi, N_STROKE_BUMPS)
    return c, float(c[1] - c[0])


def feature_library(pt: PreparedTest, pred: np.ndarray, *, lead_m_per_rad: float,
                    centres: np.ndarray, width_m: float, u_s: float = 2e-3,
                    travel: dict | None = None
                    ) -> tuple[np.ndarray, list[str], list[str]]:
    """Feature columns of one test (N samples × features), their names and groups.
    ``travel``: the campaign's sliding distance by test (:mod:`.campaign_travel`; None:
    the run order is not known, no ``drift`` columns)."""
    x, v, a = pt.u
    sg = np.tanh(v / u_s)
    cols, names, groups = [], [], []

    def add(col: np.ndarray, name: str, group: str) -> None:
        cols.append(col)
        names.append(name)
        groups.append(group)

    for c in centres:
        bump = np.exp(-0.5 * ((x - c) / width_m) ** 2)
        add(bump, f"bump(x={1e3 * c:.1f} mm)", "stroke")
        add(bump * sg, f"bump(x={1e3 * c:.1f} mm)*sign(v)", "stroke")
    th = x / lead_m_per_rad
    for k in range(1, MAX_ROTOR_PERIODS + 1):
        add(np.sin(k * th), f"sin({k} theta)", "rotor_angle")
        add(np.cos(k * th), f"cos({k} theta)", "rotor_angle")
    if pred.shape[0] > 1 and "load_ohm" in pt.fixed:
        i = pred[1] / pt.fixed["load_ohm"]
        for k in range(1, MAX_CURRENT_PERIODS + 1):
            add(i * np.sin(k * th), f"i*sin({k} theta)", "rotor_angle")
            add(i * np.cos(k * th), f"i*cos({k} theta)", "rotor_angle")
    add(np.gradient(pred[0], pt.time_s), "dF/dt", "lag")
    f_max = 0.4 / sample_step_s(pt)
    for f_c, zeta in SENSOR_GRID:
        if f_c < f_max:
            add(filtered_force(pt, pred[0], f_c, zeta) - pred[0],
                f"H({f_c:g} Hz, {zeta:g})[F]-F", "sensor")
    if pred.shape[0] > 1 and "load_ohm" in pt.fixed:
        add(i * np.abs(i), "i|i|", "current")
        add(i ** 3, "i^3", "current")
    add(sg, "sign(v)", "velocity")
    add(v, "v", "velocity")
    add(v * np.abs(v), "v|v|", "velocity")
    add(a, "a", "velocity")
    add(np.ones_like(v), "1", "velocity")
    if travel is not None:
        total = max(float(max(c[1][-1] for c in travel.values())), 1e-12)
        sc = campaign_travel_m(pt, travel) / total
        add(sc * sg, "s_c/S*sign(v)", "drift")
        add(sc * v, "s_c/S*v", "drift")
    s = travel_since_reversal_m(x, v)
    for ell in PRESLIDING_LENGTHS_M:
        add(np.sign(v) * np.exp(-s / ell), f"sign(v)*exp(-s/{1e6 * ell:.0f} um)", "presliding")
    return np.column_stack(cols), names, groups


def _stack(pts, preds, lead, centres, width, travel=None):
    Xs, ys, ws = [], [], []
    names = groups = None
    for pt, yp in zip(pts, preds):
        X, names, groups = feature_library(pt, yp, lead_m_per_rad=lead, centres=centres,
                                           width_m=width, travel=travel)
        w = pt.wnorm[0]  # noise-weighted (resolved samples), like the fits
        Xs.append(X * w[:, None])
        ys.append((pt.y[0] - yp[0]) * w)
        ws.append(w)
    return np.vstack(Xs), np.concatenate(ys), np.concatenate(ws), names, groups


def _lasso_support(Xs: np.ndarray, y: np.ndarray, seed: int) -> np.ndarray:
    """Columns of ``Xs`` (standardised) that scikit-learn's LassoCV selects (contiguous
    folds: neighbouring samples do not leak between folds)."""
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.linear_model import LassoCV
    with warnings.catch_warnings():  # a path point short of convergence is harmless:
        warnings.simplefilter("ignore", ConvergenceWarning)  # the support is refitted
        # precompute: coordinate descent on the Gram matrix (features ≪ samples;
        # same alpha and support, EMPS 24 841 × 86: 4 s → 0.4 s)
        lasso = LassoCV(cv=5, alphas=30, max_iter=3000, tol=1e-3, fit_intercept=False,
                        precompute=True, random_state=seed).fit(Xs, y)
    return np.flatnonzero(np.abs(lasso.coef_) > 1e-10)


def _describe(group: str, sel: dict[str, float], centres: np.ndarray, width: float,
              coef_full: np.ndarray, names: list[str]) -> tuple[str, dict]:
    if group == "lag":
        tau_ms = -1e3 * sel.get("dF/dt", 0.0)
        word = "delayed" if tau_ms > 0 else "ahead"
        return (f"force channel {word} by ≈ {abs(tau_ms):.1f} ms relative to displacement",
                {"lag_ms": tau_ms})
    if group == "stroke":
        xs = np.linspace(centres[0] - width, centres[-1] + width, 400)
        even = np.zeros_like(xs)
        odd = np.zeros_like(xs)
        for n, b in zip(names, coef_full):
            if not n.startswith("bump(") or b == 0.0:
                continue
            c = 1e-3 * float(n[len("bump(x="):].split(" mm")[0])
            prof = b * np.exp(-0.5 * ((xs - c) / width) ** 2)
            if n.endswith("*sign(v)"):
                odd += prof
            else:
                even += prof
        prof = odd if np.max(np.abs(odd)) >= np.max(np.abs(even)) else even
        peak = float(np.max(np.abs(prof)))
        k = np.flatnonzero(np.abs(prof) >= 0.5 * peak)
        lo, hi = 1e3 * xs[k[0]], 1e3 * xs[k[-1]]
        kind = ("opposing the motion (friction-like), both directions" if prof is odd and
                prof[np.argmax(np.abs(prof))] > 0 else "same sign in both directions"
                if prof is even else "direction-dependent")
        return (f"force term localised at stroke {lo:.1f} to {hi:.1f} mm (displacement), "
                f"{kind}, peak ≈ {peak:.1f} N", {"stroke_mm": [lo, hi], "peak_N": peak})
    if group == "rotor_angle":
        amp: dict[tuple[bool, int], float] = {}
        for n, b in sel.items():
            if "theta" in n:
                key = (n.startswith("i*"), int(n.split("(")[1].split(" ")[0]))
                amp[key] = math.hypot(amp.get(key, 0.0), b)
        (cur, k) = max(amp, key=amp.get)
        if cur:
            return (f"force term periodic in rotor angle, {k} per revolution, proportional to "
                    f"the current (a transmission ratio varying with angle: lead error, "
                    f"eccentricity), ≈ {amp[(cur, k)]:.2f} N/A",
                    {"periods_per_rev": k, "amplitude_N_per_A": amp[(cur, k)]})
        return (f"force term periodic in rotor angle, {k} per revolution, amplitude ≈ "
                f"{amp[(cur, k)]:.2f} N", {"periods_per_rev": k, "amplitude_N": amp[(cur, k)]})
    if group == "current":
        return ("force term in the current (i|i|, i³): a generator constant changing with "
                "current (e.g. magnetic saturation)", {k: v for k, v in sel.items()})
    if group == "sensor":
        (name, c) = max(((n, c) for n, c in sel.items() if n.startswith("H(")),
                        key=lambda t: abs(t[1]))
        f_c, zeta = sensor_of(name)
        return (f"the force record low-passed by a sensor (a lag that depends on the "
                f"frequency: the force sensor's own dynamics), a second-order low-pass of "
                f"≈ {f_c:.0f} Hz, damping {zeta:.2f}",
                {"bandwidth_hz": f_c, "damping": zeta, **sel})
    if group == "drift":
        level = sel.get("s_c/S*sign(v)", 0.0)
        return (f"friction changing over the campaign in the order the tests were run "
                f"(a rig running in): the Coulomb level {level:+.1f} N from the first "
                f"test's start to the last test's end",
                {"coulomb_change_N": level, **sel})
    if group == "presliding":
        return ("friction changing over a distance after each reversal (presliding, a "
                "transition length)",
                {k: v for k, v in sel.items()})
    return ("velocity/acceleration-dependent force of another shape (friction or inertia "
            "law)", {k: v for k, v in sel.items()})


def discover_term(fit_pts: Sequence[PreparedTest], fit_preds: Sequence[np.ndarray],
                  eval_pts: Sequence[PreparedTest], eval_preds: Sequence[np.ndarray], *,
                  lead_m_per_rad: float, seed: int = 0,
                  exclude: tuple[str, ...] = ()) -> TermProposal:
    """Sparse regression of the fit tests' force residual on :func:`feature_library`;
    the term's gain is measured on ``eval_pts`` (the held-out tests).  ``exclude``:
    feature groups left out of the library (``"lag"``: also no time-shift proposal).

    Returns a :class:`TermProposal` (``earns`` is left to the caller's decision rule).
    """
    centres, width = _stroke_centres(list(fit_pts) + list(eval_pts))
    every = list(fit_pts) + list(eval_pts)
    travel = travel_coordinates(every) if run_order_known(every) else None
    X, y, _, names, groups = _stack(fit_pts, fit_preds, lead_m_per_rad, centres, width,
                                    travel)
    use = np.array([g not in exclude for g in groups])
    X = X[:, use]
    names = [n for n, u in zip(names, use) if u]
    groups = [g for g, u in zip(groups, use) if u]
    scale = np.sqrt(np.mean(X ** 2, axis=0))
    scale[scale == 0] = 1.0
    Xs = X / scale
    try:
        support = _lasso_support(Xs, y, seed)
    except ValueError as exc:
        return TermProposal(False, f"sparse regression failed: {exc}")
    if support.size == 0:
        return TermProposal(True, "the sparse regression selects no feature (residual is noise)")
    # least-squares refit on the support (debiased): the groups' shares of the term
    b, *_ = np.linalg.lstsq(X[:, support], y, rcond=None)
    coef = np.zeros(X.shape[1])
    coef[support] = b
    shares = {}
    for g in GROUPS:
        idx = [k for k in support if groups[k] == g]
        if idx:
            part = X[:, idx] @ coef[idx]
            shares[g] = float(part @ part)
    tot = sum(shares.values()) or 1.0
    shares = {g: v / tot for g, v in shares.items()}
    # the proposed term has one physical support: one group's columns (what the words
    # name), each group's selected columns refitted alone, the group chosen by BIC
    # on the fit tests with the force residual's effective sample size.  (Not the
    # group with most of the joint term's energy: collinear groups — bumps in stroke
    # and harmonics in rotor angle — cancel each other with large coefficients.)
    n_eff = sum(pt.n_resolved / autocorrelation_time(((pt.y[0] - yp[0]) * pt.wnorm[0])
                                                     [pt.weight > 0])
                for pt, yp in zip(fit_pts, fit_preds))
    pen = math.log(max(n_eff, 2.0))
    best = None
    for g in GROUPS:
        sup = np.array([k for k in support if groups[k] == g], dtype=int)
        if not sup.size:
            continue
        # a sensor is one low-pass (one column), not a mixture of them: free mixtures
        # of filters mimic any lag, a per-test one included
        if g in SINGLE_COLUMN_GROUPS:  # every column of the group, each alone
            subs = [np.array([k]) for k in range(len(groups)) if groups[k] == g]
        else:
            subs = [sup]
        for sub in subs:
            bg, *_ = np.linalg.lstsq(X[:, sub], y, rcond=None)
            res = y - X[:, sub] @ bg
            bic = n_eff * math.log(max(float(res @ res), 1e-300)) + sub.size * pen
            if best is None or bic < best[0]:
                best = (bic, g, sub, bg)
    if best is None:
        return TermProposal(True, "the sparse regression selects no feature (residual is noise)")
    _, group, support, b = best
    coef = np.zeros(X.shape[1])
    coef[support] = b
    term_fit = X[:, support] @ b
    sel = {names[k]: float(coef[k]) for k in support}
    if group == "sensor":  # the grid's nearest sensor refined: one low-pass, weight 1
        sel = refined_sensor(fit_pts, fit_preds, next(iter(sel)))
        term_fit = np.concatenate([(q[0] - yp[0]) * pt.wnorm[0] for pt, yp, q in zip(
            fit_pts, fit_preds, with_sensor_term(fit_pts, fit_preds, sel))])
    desc, qty = _describe(group, sel, centres, width, coef, names)
    lag = None if "lag" in exclude else shift_lag(fit_pts, fit_preds)
    if lag is not None and (n_eff * math.log(max(lag[1], 1e-300)) + pen < best[0]):
        # a pure time shift of the model force (one parameter) explains the fit set
        # better than the sparse term: propose the lag (exact shift, not its Taylor term)
        return _lag_proposal(lag, eval_pts, eval_preds, shares, float(y @ y))
    # the held-out gain of the whole selected term
    sse_b = sse_a = 0.0
    pb, pa, ym = [], [], []
    for pt, yp in zip(eval_pts, eval_preds):
        if group == "sensor":
            corr = with_sensor_term([pt], [yp], sel)[0][0] - yp[0]
        else:
            Xe, _, _ = feature_library(pt, yp, lead_m_per_rad=lead_m_per_rad,
                                       centres=centres, width_m=width, travel=travel)
            corr = Xe[:, use] @ coef
        r0 = (pt.y[0] - yp[0]) * pt.wnorm[0]
        r1 = (pt.y[0] - yp[0] - corr) * pt.wnorm[0]
        sse_b += float(r0 @ r0)
        sse_a += float(r1 @ r1)
        k = pt.weight > 0
        pb.append(yp[0][k])
        pa.append((yp[0] + corr)[k])
        ym.append(pt.y[0][k])
    m = np.concatenate(ym)
    e0 = force_relative_error_percent(np.concatenate(pb), m)
    e1 = force_relative_error_percent(np.concatenate(pa), m)
    return TermProposal(True, f"{support.size} of {X.shape[1]} features selected "
                              f"(fit-set SSE {float(y @ y):.4g} -> "
                              f"{float((y - term_fit) @ (y - term_fit)):.4g})",
                        desc, group, shares, dict(sel),
                        e0, e1, sse_b, sse_a, qty, float(y @ y),
                        float((y - term_fit) @ (y - term_fit)))


def names_an_effect(term: "TermProposal | None") -> bool:
    """Whether a data-driven term makes the answer "none of the catalogue": it earns and
    is not a friction law of another shape (:data:`FRICTION_LAW_GROUPS`).  The
    catalogue's friction effects and the baseline's friction law describe the force as
    a function of the motion alone; a term that is such a function is that law refined
    — a misspecified friction curve, not an effect the rig lacks."""
    return term is not None and term.earns and term.group not in FRICTION_LAW_GROUPS


def _lag_proposal(lag, eval_pts, eval_preds, shares, sse_fit0) -> TermProposal:
    tau = lag[0]
    pb, pa, ym = [], [], []
    sse_b = sse_a = 0.0
    for pt, yp in zip(eval_pts, eval_preds):
        sh = shifted_force(pt, yp, tau)
        sse_b += float(np.sum(((pt.y[0] - yp[0]) * pt.wnorm[0]) ** 2))
        sse_a += float(np.sum(((pt.y[0] - sh) * pt.wnorm[0]) ** 2))
        k = pt.weight > 0
        pb.append(yp[0][k])
        pa.append(sh[k])
        ym.append(pt.y[0][k])
    m = np.concatenate(ym)
    word = "delayed" if tau > 0 else "ahead"
    return TermProposal(True, f"time shift of the model force (fit-set SSE {sse_fit0:.4g} -> "
                              f"{lag[1]:.4g})",
                        f"force channel {word} by ≈ {1e3 * abs(tau):.1f} ms relative to "
                        f"displacement", "lag", shares, {"lag_s": tau},
                        force_relative_error_percent(np.concatenate(pb), m),
                        force_relative_error_percent(np.concatenate(pa), m), sse_b, sse_a,
                        {"lag_ms": 1e3 * tau}, sse_fit0, lag[1])




def propose_term(fit_pts, fit_pred, eval_pts, eval_pred, lead, seed, floor, n_eff,
                 criterion: Criterion = DEFAULT_CRITERION) -> TermProposal:
    """The data-driven term of the current residual, judged like a catalogue effect.

    * None when the residual of the fit tests is white (Ljung–Box,
      :func:`~.evidence.residual_is_white`): a term fitted to a white residual is
      fitted to noise.
    * A term of the ``lag`` group (a time shift of the force) is a delay of the record
      only when one delay fits every fit test (:func:`per_test_delays`, the check the
      ``force_lag`` member makes): otherwise the shift stands for a lead that depends
      on the motion (friction presliding), it is refused (``refused`` says why) and the
      term is sought again without the lag features.
    * A term of the ``sensor`` group (the force through a low-pass) is a sensor only when
      it is one sensor for every test: the lag it leaves is one delay for every test, and
      its weight is one for every test (:func:`~.sensor_term.per_test_sensor`,
      :func:`~.sensor_term.per_test_delays_left`:
      per-test values refuse it when their ΔBIC is below the delays' threshold *and* they
      remove the criterion's ``min_excess_reduction`` of the excess left — with little
      noise a sensor's discretisation alone is significant, not practical).  A transition that depends on the motion (presliding after a
      reversal) asks for different delays or weights per test; the term is then refused
      and sought again without the lag and sensor features.
    * The term earns by :func:`~.judge.earns` with ``criterion``: its share of the
      held-out error above the noise floor, ΔBIC on the fit tests (``N_eff`` of the fit
      residual) and on the held-out tests (``n_eff``), one parameter per selected column.
    """
    white, p = residual_is_white(fit_pts, fit_pred, criterion.white_p)
    if white:
        return TermProposal(True, f"the residual is white (Ljung-Box p = {p:.2g} > "
                                  f"{criterion.white_p:g} on every fit test): no term proposed",
                            description="none (white residual)")
    term = discover_term(fit_pts, fit_pred, eval_pts, eval_pred, lead_m_per_rad=lead, seed=seed)
    n_eff_fit = effective_samples(fit_pts, fit_pred)
    refused = ""
    if term.group == "lag" and len(fit_pts) > 1:
        spread = per_test_delays(fit_pts, fit_pred, n_eff_fit)
        if spread < criterion.delay_spread_bic:
            refused = (f"{term.description}: refused — not a delay of the record, the best "
                       f"delay differs from test to test (per-test delays against one: "
                       f"ΔBIC {spread:.3g} < {criterion.delay_spread_bic:g})")
            term = discover_term(fit_pts, fit_pred, eval_pts, eval_pred, lead_m_per_rad=lead,
                                 seed=seed, exclude=("lag",))
    if term.group == "sensor" and len(fit_pts) > 1:
        # refused when per-test values are both significant and of a practical size (they
        # remove the share of the remaining excess a member must remove to earn)
        (d_delay, s_delay) = per_test_delays_left(
            fit_pts, with_sensor_term(fit_pts, fit_pred, term.columns), n_eff_fit)
        (d_weight, s_weight) = per_test_sensor(fit_pts, fit_pred, term.columns, n_eff_fit)
        lim, size = criterion.delay_spread_bic, criterion.min_excess_reduction
        why = (f"the best delay left after the low-pass still differs from test to test "
               f"(per-test delays against one: ΔBIC {d_delay:.3g} < {lim:g}, removing "
               f"{100 * s_delay:.0f} % of the excess left)"
               if d_delay < lim and s_delay >= size else
               f"the low-pass's weight differs from test to test (per-test weights against "
               f"one: ΔBIC {d_weight:.3g} < {lim:g}, removing {100 * s_weight:.0f} % of the "
               f"excess left), which one sensor's is not"
               if d_weight < lim and s_weight >= size else "")
        if why:
            refused = ((refused + "; ") if refused else "") + (
                f"{term.description}: refused — not a sensor's lag, {why}")
            term = discover_term(fit_pts, fit_pred, eval_pts, eval_pred, lead_m_per_rad=lead,
                                 seed=seed, exclude=("lag", "sensor"))
    term.refused = refused
    if term.columns:
        k = len(term.columns)
        d_fit = delta_bic(term.sse_fit_after, term.sse_fit_before, k, n_eff_fit)
        d_held = delta_bic(term.sse_after, term.sse_before, k, n_eff)
        judge_change(term, term.error_before, term.error_after, floor, d_fit, d_held, criterion)
    return term
