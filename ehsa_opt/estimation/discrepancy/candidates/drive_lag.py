"""Catalogue member ``drive_lag`` of a rig without generator: the drive between the
recorded force and the force on the mechanism.

On a rig without generator the recorded force is the controller's command (EMPS:
g_τ × the controller output).  A digital controller holds its output over each
sample (a zero-order hold: on average half a sample, T/2, late) and the drive's
current loop follows the command with a first-order lag of time constant τ:

    F_applied(s) = e^(−s T/2) / (1 + τ s) · F_recorded(s)

The rigid model predicts F_applied; the recorded force it implies is

    F_recorded(t) = (1 + τ d/dt) F_model(t + T/2)            (:func:`recorded_from_applied`)

which is linear in the rigid model's parameters for a given τ.  So τ is found by
variable projection: for each τ the current model's force plus the columns a rigid
refit absorbs (:func:`~.catalogue.absorbed_columns`) are passed through the
operator and fitted by linear least squares on the fit tests; τ ≥ 0 (a negative
time constant is no lag) is searched on a log grid and refined by Brent's method.
The interval of τ is the Newey–West (HAC) one of the linearised problem.

When the lag is named, the tests' force becomes the applied force
(:func:`applied_force`) and every later effect is judged on what remains.  The lag
itself is judged on the *recorded* force (the model's force passed through the
inverse operator), by the workflow's rule — and, because the held-out record can
hold excitation the fit record lacks, by blocked cross-validation within the
held-out record too (:func:`blocked_cross_validation`): τ fitted on alternate
blocks, judged on the others.
"""

from __future__ import annotations

import math
from dataclasses import replace as _replace
from typing import Sequence

import numpy as np
from scipy.optimize import minimize, minimize_scalar
from scipy.signal import bilinear, lfilter, lfilter_zi

from ...covariance import hac_covariance
from ..evidence import (change_evidence, force_error_percent, force_noise_floor_percent,
                        normalised_sse)
from ..judge import excess_reduction
from ..fit import fit_group
from ..prepared import PreparedTest, prepare_tests
from ..rig import Rig, predict
from .catalogue import absorbed_columns
from .record_change import RecordChange

__all__ = ["applied_force", "recorded_from_applied", "fit_drive_lag", "try_drive_lag",
           "blocked_cross_validation", "effective_mass", "frequency_evidence", "MAX_TIME_CONSTANT_S",
           "CV_BLOCKS", "HOLD_SAMPLES", "hold_delay_s", "hold_and_lag"]

#: Largest drive time constant searched, s (a current loop slower than this would
#: show at the trajectory's own frequencies as a phase lag of the whole force).
MAX_TIME_CONSTANT_S = 0.01
#: Largest transport delay searched, s.
MAX_DELAY_S = 0.005
#: The delay the catalogue member holds, in samples: the DAC's zero-order hold, half a
#: sample late on average (:func:`hold_delay_s`).  The lag's τ is fitted on top, so it
#: is what remains of the lead beyond the hold; the open-loop simulation
#: (:mod:`..openloop`) holds the force over each step itself and adds only τ, so the
#: hold is counted once in both.  (A free delay beside the lag is not resolved by the
#: records: on the EMPS estimation record δ and τ trade at a fixed lead δ + τ.)
HOLD_SAMPLES = 0.5
#: Blocks each held-out test is cut into for :func:`blocked_cross_validation`.
CV_BLOCKS = 8


def _dt(time_s: np.ndarray) -> float:
    return float(np.median(np.diff(time_s)))


def hold_delay_s(time_s: np.ndarray) -> float:
    """The zero-order hold's mean delay, :data:`HOLD_SAMPLES` of the record's median
    sample interval, s."""
    return HOLD_SAMPLES * _dt(np.asarray(time_s, float))


def applied_force(time_s: np.ndarray, force_N: np.ndarray, tau_s: float,
                  delay_s: float) -> np.ndarray:
    """The force on the mechanism: the recorded force delayed by ``delay_s`` and
    passed through 1/(1 + τ s) (Tustin discretisation, from the first sample at rest
    of the lag), N."""
    t = np.asarray(time_s, float)
    F = np.interp(t - delay_s, t, np.asarray(force_N, float))
    if tau_s <= 0:
        return F
    b, a = bilinear([1.0], [tau_s, 1.0], fs=1.0 / _dt(t))
    y, _ = lfilter(b, a, F, zi=lfilter_zi(b, a) * F[0])  # the lag starts settled at F[0]
    return y


def recorded_from_applied(time_s: np.ndarray, y: np.ndarray, tau_s: float,
                          delay_s: float) -> np.ndarray:
    """The recorded force that an applied force ``y`` implies: (1 + τ d/dt) y(t + δ)
    (central differences), along the last axis."""
    t = np.asarray(time_s, float)
    y = np.asarray(y, float)
    if y.ndim == 1:
        ys = np.interp(t + delay_s, t, y)
    else:
        ys = np.vstack([np.interp(t + delay_s, t, row) for row in y.reshape(-1, t.size)]
                       ).reshape(y.shape)
    return ys + tau_s * np.gradient(ys, t, axis=-1) if tau_s > 0 else ys


def _design(pts: Sequence[PreparedTest], preds: Sequence[np.ndarray], rig: Rig, u_brk: float,
            tau: float, delay: float, rows: Sequence[np.ndarray] | None = None
            ) -> tuple[np.ndarray, np.ndarray]:
    """(σ-normalised residual of the recorded force after the operator, operator
    applied to the absorbed columns), stacked over the tests (``rows``: per test the
    sample indices used, default all)."""
    rr, XX = [], []
    for k, (pt, yp) in enumerate(zip(pts, preds)):
        n = pt.time_s.size
        B = absorbed_columns(pt, rig, u_brk)[:n] * float(pt.sigma[0])  # N per unit
        lead_pred = recorded_from_applied(pt.time_s, yp[0], tau, delay)
        lead_B = recorded_from_applied(pt.time_s, B.T, tau, delay).T
        w = pt.weight / float(pt.sigma[0])
        r = (pt.y[0] - lead_pred) * w
        X = lead_B * w[:, None]
        idx = rows[k] if rows is not None else slice(None)
        rr.append(r[idx])
        XX.append(X[idx])
    return np.concatenate(rr), np.vstack(XX)


def _vp(pts, preds, rig, u_brk, tau, delay, rows=None) -> tuple[float, np.ndarray]:
    r, X = _design(pts, preds, rig, u_brk, tau, delay, rows)
    c, *_ = np.linalg.lstsq(X, r, rcond=None)
    return float(np.sum((r - X @ c) ** 2)), c


def _best(pts, preds, rig, u_brk, rows=None, delay_s: float | None = None
          ) -> tuple[float, float, float, float]:
    """(δ, τ, SSE at (δ, τ), SSE at (0, 0)): a coarse grid, then Powell's method inside
    the bounds 0 ≤ δ ≤ :data:`MAX_DELAY_S`, 0 ≤ τ ≤ :data:`MAX_TIME_CONSTANT_S`
    (``delay_s`` given: δ held there)."""
    def sse(d, g):
        return _vp(pts, preds, rig, u_brk, float(g), float(d), rows)[0]

    sse00 = sse(0.0, 0.0)
    deltas = [delay_s] if delay_s is not None else [0.0, 2.5e-4, 5e-4, 1e-3, 2e-3]
    taus = [0.0, 1e-4, 3e-4, 1e-3, 3e-3]
    best = min(((sse(d, g) if (d, g) != (0.0, 0.0) else sse00, d, g)
                for d in deltas for g in taus))
    if delay_s is not None:
        opt = minimize_scalar(lambda g: sse(delay_s, g), bounds=(0.0, MAX_TIME_CONSTANT_S),
                              method="bounded", options={"xatol": 1e-7})
        cand = (float(opt.fun), delay_s, float(opt.x))
    else:
        opt = minimize(lambda q: sse(1e-3 * q[0], 1e-3 * q[1]), [1e3 * best[1], 1e3 * best[2]],
                       method="Powell", bounds=[(0.0, 1e3 * MAX_DELAY_S),
                                                (0.0, 1e3 * MAX_TIME_CONSTANT_S)],
                       options={"xtol": 1e-3, "ftol": 1e-10})
        cand = (float(opt.fun), 1e-3 * float(opt.x[0]), 1e-3 * float(opt.x[1]))
    if cand[0] < best[0]:
        best = cand
    return best[1], best[2], best[0], sse00


def fit_drive_lag(fit_pts: Sequence[PreparedTest], fit_pred: Sequence[np.ndarray],
                  rig: Rig, params: dict[str, float], delay_s: float | None = None) -> dict:
    """The drive's transport delay δ and time constant τ on the fit tests by variable
    projection.

    Parameters
    ----------
    fit_pts, fit_pred :
        Fit tests and the current model's outputs (the force row is used).
    rig : Rig
        The current rig (without generator).
    params : dict
        Current parameters (the breakaway velocity of the absorbed columns).
    delay_s : float, optional
        Hold the delay there (e.g. the zero-order hold's half sample) and fit τ only.

    Returns
    -------
    dict with ``parameters`` (drive_delay_s, drive_lag_time_constant_s,
    drive_lead_s = δ + τ — the recorded force's lead at low frequency —,
    drive_bandwidth_hz = 1/(2πτ)), ``intervals`` (≈95 % Newey–West of δ, τ and δ + τ),
    ``sse`` and ``sse_rigid`` (σ-normalised), ``covariance_info``.
    """
    if rig.has_generator:
        raise ValueError("fit_drive_lag: for a rig without generator (a generator bench "
                         "measures the force on the mechanism, not a drive command)")
    u_brk = float(params.get("nut_breakaway_velocity_m_per_s", 0.01))
    delay, tau, sse, sse0 = _best(fit_pts, fit_pred, rig, u_brk, delay_s=delay_s)
    # linearised problem at (δ, τ): the absorbed columns, ∂/∂τ and ∂/∂δ of the
    # recorded force y_a(t + δ) + τ ẏ_a(t + δ): ∂τ = ẏ_a, ∂δ = ẏ_a + τ ÿ_a
    r, X = _design(fit_pts, fit_pred, rig, u_brk, tau, delay)
    c, *_ = np.linalg.lstsq(X, r, rcond=None)
    d_delay, d_tau = [], []
    for pt, yp in zip(fit_pts, fit_pred):
        n = pt.time_s.size
        B = absorbed_columns(pt, rig, u_brk)[:n] * float(pt.sigma[0])
        ya = np.interp(pt.time_s + delay, pt.time_s, yp[0] + B @ c)
        w = pt.weight / float(pt.sigma[0])
        y1 = np.gradient(ya, pt.time_s)
        d_tau.append(y1 * w)
        d_delay.append((y1 + tau * np.gradient(y1, pt.time_s)) * w)
    cols = [X, np.concatenate(d_tau)[:, None]]
    if delay_s is None:
        cols.append(np.concatenate(d_delay)[:, None])
    res = r - X @ c
    h = hac_covariance(np.hstack(cols), res, groups=[pt.time_s.size for pt in fit_pts])
    k = X.shape[1]
    v_tau = max(float(h.cov[k, k]), 0.0)
    v_del = max(float(h.cov[k + 1, k + 1]), 0.0) if delay_s is None else 0.0
    c_td = float(h.cov[k, k + 1]) if delay_s is None else 0.0
    sd_tau, sd_del = math.sqrt(v_tau), math.sqrt(v_del)
    sd_lead = math.sqrt(max(v_tau + v_del + 2 * c_td, 0.0))

    def ci(x: float, sd: float) -> tuple[float, float]:
        return (x - 1.96 * sd, x + 1.96 * sd)

    bw = 1.0 / (2 * math.pi * tau) if tau > 0 else math.inf
    return {"parameters": {"drive_delay_s": delay, "drive_lag_time_constant_s": tau,
                           "drive_lead_s": delay + tau, "drive_bandwidth_hz": bw},
            "intervals": {"drive_delay_s": ci(delay, sd_del) if delay_s is None else None,
                          "drive_lag_time_constant_s": ci(tau, sd_tau),
                          "drive_lead_s": ci(delay + tau, sd_lead)},
            "sse": sse, "sse_rigid": sse0,
            "covariance_info": {"method": h.method, "n_eff": h.n_eff, "n": h.n,
                                "bandwidth_samples": h.bandwidth}}


def blocked_cross_validation(pts: Sequence[PreparedTest], preds: Sequence[np.ndarray],
                             rig: Rig, params: dict[str, float], delay_s: float | None = 0.0,
                             blocks: int = CV_BLOCKS) -> list[dict]:
    """Blocked cross-validation of the lag *within* records: each test cut into
    ``blocks`` contiguous blocks; τ and the absorbed rigid refit fitted on the even
    blocks, judged on the odd ones, and the other way round.  Per fold: ``delay_s``,
    ``tau_s`` and the relative recorded-force error of the test blocks without (τ = 0, the
    rigid refit on the same training blocks) and with the lag, %."""
    u_brk = float(params.get("nut_breakaway_velocity_m_per_s", 0.01))
    split = [np.array_split(np.arange(pt.time_s.size), blocks) for pt in pts]
    out = []
    for train_parity in (0, 1):
        tr = [np.concatenate(s[train_parity::2]) for s in split]
        te = [np.concatenate(s[1 - train_parity::2]) for s in split]
        delay, tau, _, _ = _best(pts, preds, rig, u_brk, tr, delay_s=delay_s)
        errs = []
        for d, g in ((0.0, 0.0), (delay, tau)):
            r_tr, X_tr = _design(pts, preds, rig, u_brk, g, d, tr)
            c, *_ = np.linalg.lstsq(X_tr, r_tr, rcond=None)
            r_te, X_te = _design(pts, preds, rig, u_brk, g, d, te)
            e = r_te - X_te @ c
            Fte = np.concatenate([pt.y[0][i] / float(pt.sigma[0]) for pt, i in zip(pts, te)])
            errs.append(100 * float(np.linalg.norm(e) / np.linalg.norm(Fte)))
        out.append({"train": "even blocks" if train_parity == 0 else "odd blocks",
                    "delay_s": delay, "tau_s": tau, "error_without": errs[0], "error_with": errs[1]})
    return out


def effective_mass(test, nperseg: int = 1024) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(f Hz, M(f) = S_aF / S_aa kg complex, coherence γ²) of a recorded test: Welch
    cross-spectra of the force and the acceleration from central second differences of
    the displacement (``nperseg`` samples per segment, at most the record)."""
    from scipy.signal import csd, welch
    t = np.asarray(test.time_s, float)
    x = np.asarray(test.displacement_m, float)
    F = np.asarray(test.force_N, float)
    fs = 1.0 / _dt(t)
    a = np.zeros_like(x)
    a[1:-1] = (x[2:] - 2 * x[1:-1] + x[:-2]) * fs * fs
    n = min(nperseg, x.size)
    f, Saf = csd(a, F, fs=fs, nperseg=n)
    _, Saa = welch(a, fs=fs, nperseg=n)
    _, Sff = welch(F, fs=fs, nperseg=n)
    with np.errstate(divide="ignore", invalid="ignore"):
        return f, Saf / Saa, np.abs(Saf) ** 2 / (Saa * Sff)


def frequency_evidence(test, nperseg: int = 1024, min_coherence: float = 0.8,
                       band_hz: tuple[float, float] = (15.0, 200.0),
                       hold_s: float = 0.0) -> dict:
    """The recorded force against the measured acceleration in the frequency domain:
    the effective mass M(f) = S_aF / S_aa (Welch cross-spectra; the acceleration from
    central second differences of the displacement), its phase and coherence, and
    the time constant of a first-order lag fitted to the phase, arg M = atan(2πfτ),
    over the coherent part of ``band_hz``.  A load behind a spring (motion measured
    on the driven side) gives a phase *lag* and a rising |M| towards its resonance;
    a drive lag gives a phase *lead* and a gently rising |M|.

    Returns
    -------
    dict with ``frequency_hz``, ``mass_kg`` (|M|), ``phase_deg``, ``coherence``
    (arrays), ``band`` (the frequencies used), ``tau_s`` (NaN when fewer than 3
    coherent frequencies), ``mass_low_kg`` (median |M| in the coherent band below
    50 Hz).
    """
    f, M, coh = effective_mass(test, nperseg)
    ph = np.angle(M)
    use = (f >= band_hz[0]) & (f <= band_hz[1]) & (coh >= min_coherence) & np.isfinite(ph)
    tau = math.nan
    if np.count_nonzero(use) >= 3:
        w = 2 * math.pi * f[use]
        opt = minimize_scalar(lambda g: float(np.sum(coh[use] * (ph[use] - w * hold_s
                                                                 - np.arctan(w * g)) ** 2)),
                              bounds=(0.0, MAX_TIME_CONSTANT_S), method="bounded")
        tau = float(opt.x)
    low = use & (f < 50.0)
    return {"frequency_hz": f, "mass_kg": np.abs(M), "phase_deg": np.degrees(ph),
            "coherence": coh, "band": f[use], "tau_s": tau,
            "mass_low_kg": float(np.median(np.abs(M[low]))) if low.any() else math.nan}


def hold_and_lag(test, picks_hz: Sequence[float] = (20.0, 50.0, 100.0, 150.0)) -> dict:
    """How much of the recorded force's phase lead over the measured acceleration is
    the zero-order hold and how much a lag beyond it (:func:`frequency_evidence`).

    Returns
    -------
    dict with ``hold_s`` (:func:`hold_delay_s`), ``apparent_tau_s`` (a first-order
    lag fitted to the whole phase, the hold not counted), ``tau_beyond_hold_s`` (the
    lag fitted to the phase less the hold's ω T/2) and ``picks`` (per frequency near
    ``picks_hz`` in the coherent band: ``frequency_hz``, ``mass_kg``, ``phase_deg``,
    ``hold_deg``, ``excess_deg`` = phase − hold).
    """
    hold = hold_delay_s(test.time_s)
    ev = frequency_evidence(test)
    beyond = frequency_evidence(test, hold_s=hold)
    f, rows = ev["frequency_hz"], []
    for fi in picks_hz:
        if not (ev["band"].size and ev["band"].min() - 1 <= fi <= ev["band"].max() + 1):
            continue
        i = int(np.argmin(np.abs(f - fi)))
        hd = math.degrees(2 * math.pi * f[i] * hold)
        rows.append({"frequency_hz": float(f[i]), "mass_kg": float(ev["mass_kg"][i]),
                     "phase_deg": float(ev["phase_deg"][i]), "hold_deg": hd,
                     "excess_deg": float(ev["phase_deg"][i]) - hd})
    return {"record": str(getattr(test, "file", "")), "hold_s": hold,
            "apparent_tau_s": ev["tau_s"], "tau_beyond_hold_s": beyond["tau_s"], "picks": rows}


def _frequency_sentence(test) -> str:
    ev = frequency_evidence(test)
    if not math.isfinite(ev["tau_s"]):
        return ""
    f = ev["frequency_hz"]
    picks = [fi for fi in (20.0, 50.0, 100.0, 150.0) if ev["band"].size
             and ev["band"].min() - 1 <= fi <= ev["band"].max() + 1]
    rows = []
    for fi in picks:
        i = int(np.argmin(np.abs(f - fi)))
        rows.append(f"{f[i]:.0f} Hz: {ev['mass_kg'][i]:.0f} kg, {ev['phase_deg'][i]:+.0f}°")
    return (f"Frequency response of {test.file} (recorded force over measured acceleration, "
            f"coherence ≥ 0.8 at {ev['band'].size} frequencies in {ev['band'].min():.0f}–"
            f"{ev['band'].max():.0f} Hz): " + "; ".join(rows)
            + f" — a phase lead, not the lag and resonance of a load behind a spring; a "
              f"first-order lag fitted to the phase: τ = {1e3 * ev['tau_s']:.2f} ms")


def _applied_tests(pts: Sequence[PreparedTest], tau: float, delay: float
                   ) -> list[PreparedTest]:
    """The tests with the force replaced by the applied force."""
    out = []
    for pt in pts:
        t = pt.test
        nt = _replace(t, force_N=applied_force(t.time_s, t.force_N, tau, delay))
        out += prepare_tests([nt], False, mass_kg=pt.mass_kg)
    return out


def _recorded(pts: Sequence[PreparedTest], preds: Sequence[np.ndarray], tau: float,
              delay: float) -> list[np.ndarray]:
    return [recorded_from_applied(pt.time_s, yp, tau, delay) for pt, yp in zip(pts, preds)]


def try_drive_lag(fit_pts, held_pts, rig, base, fit_pred, held_pred, floor, n_eff_fit,
                  n_eff_held, err0, settings, say):
    """Catalogue member ``drive_lag`` (rig without generator): τ by variable projection
    on the fit tests (:func:`fit_drive_lag`), the tests' force replaced by the applied
    force and the baseline refitted; judged on the recorded force of the held-out
    tests by the decision rule, with a resolved lead δ + τ (its interval excludes 0); the
    blocked cross-validation within the held-out records is reported beside it.

    Returns None when the refit failed, else the :class:`~.record_change.RecordChange`
    (the tests with the applied force, the refitted baseline, its predictions, the
    evaluation error on the applied force, the member's fields, the new noise floor and
    the report's notes); the judge decides (:func:`~..judge.judge_attempt`).
    """
    if rig.has_generator:
        return None
    hold = hold_delay_s(fit_pts[0].time_s)
    out = fit_drive_lag(fit_pts, fit_pred, rig, base.parameters, delay_s=hold)
    p = out["parameters"]
    tau, delay = p["drive_lag_time_constant_s"], p["drive_delay_s"]
    iv = out["intervals"]["drive_lead_s"]
    f2 = _applied_tests(fit_pts, tau, delay)
    h2 = _applied_tests(held_pts, tau, delay) if held_pts else []
    b2 = fit_group(f2, rig, [base.parameters], max_iter=settings.max_iter)
    if not b2.parameters:
        say(f"drive_lag: the refit on the applied force failed ({b2.message})")
        return None
    pf = predict(f2, rig, b2.parameters)
    ph = predict(h2, rig, b2.parameters) if h2 else []
    # judged on the recorded force: the model's force through the inverse operator
    mf = _recorded(fit_pts, pf, tau, delay)
    mh = _recorded(held_pts, ph, tau, delay) if held_pts else []
    ev, pe, pe0, e_before, e_after, d_fit, d_held = change_evidence(
        fit_pts, fit_pred, mf, held_pts, held_pred, mh, 1, n_eff_fit, n_eff_held)
    cv = blocked_cross_validation(held_pts, held_pred, rig, base.parameters, hold) \
        if held_pts else []
    # the lead δ + τ (the hold's half sample and the lag beyond it) resolved: with the
    # hold held the member is judged by what hold and lag together do to the error
    resolved = iv[0] > 0
    # the candidate's fit record: the rigid refit on the applied force, with the
    # covariance facts of the lag's own (variable-projection) interval
    rec = _replace(b2, covariance_info=out["covariance_info"])
    c = dict(effect="drive_lag", applicable=True, score=math.nan, chi2=math.nan, round=1,
             fitted=True, fit=rec, error_before=e_before, error_after=e_after,
             excess_reduction=excess_reduction(e_before, e_after, floor, settings.criterion),
             delta_bic_fit=d_fit, delta_bic_heldout=d_held, sse_heldout=normalised_sse(ev, pe),
             resolved=resolved, parameters=dict(p),
             intervals={k: v for k, v in out["intervals"].items()},
             predictions=pf + ph, rig=rig)
    it = out["intervals"]["drive_lag_time_constant_s"]
    msg = (f"drive_lag: time constant {1e3 * tau:.3f} ms [{1e3 * it[0]:.3f}, {1e3 * it[1]:.3f}] "
           f"(bandwidth {p['drive_bandwidth_hz']:.0f} Hz)"
           + (f", delay {1e3 * delay:.3f} ms" if delay else "") + "; "
           f"recorded-force error {e_before:.3f} -> {e_after:.3f} %, "
           f"ΔBIC fit {d_fit:.1f}, held-out {d_held:.1f}")
    for fold in cv:
        say(f"drive_lag, blocked cross-validation within the held-out record (trained on the "
            f"{fold['train']}): τ {1e3 * fold['tau_s']:.3f} ms, "
            f"error of the other blocks "
            f"{fold['error_without']:.2f} -> {fold['error_with']:.2f} %")
    e_applied = force_error_percent(h2 or f2, ph or pf)
    notes = [f"The drive lag (`drive_lag`) is judged on the recorded force of the held-out record and, because the "
             f"fit record hardly excites the drive, by blocked cross-validation within the "
             f"held-out record ({CV_BLOCKS} blocks, τ fitted on alternate blocks with the "
             f"rigid refit): "
             + "; ".join(f"trained on the {f['train']} τ {1e3 * f['tau_s']:.3f} ms, error "
                         f"{f['error_without']:.2f} -> {f['error_with']:.2f} %" for f in cv)
             + ". " + "; ".join(filter(None, (_frequency_sentence(pt.test) for pt in held_pts)))
             + ". From here on the force is the applied force (the recorded force through "
               "the drive): later effects and the per-test errors are judged on it"]
    return RecordChange(f2, h2, b2, pf, ph, e_applied, c, force_noise_floor_percent(h2 or f2),
                        notes, msg)
