"""A skew of the voltage record: the voltage sampled late (or early) against the force
and the displacement — an effect of the acquisition, not of the rig.

A voltage channel sampled τ late shows, against the rigid model, a residual
V(t) − V̂(t) ≈ −τ dV̂/dt: a phase shift of the rotor's channel.  A transmission member
(a mount spring, a gap, a flexible load) also moves the rotor against the rod and
fits part of that phase — a skewed record was answered ``compliance`` before this
check.  The check (:func:`find_voltage_skew`), before the rounds, on the baseline:

1. the delay τ of the voltage on :data:`~.terms.LAG_GRID_S` minimising the fit tests'
   voltage SSE of (V − V̂(t − τ))/σ (the same search as the force's,
   :func:`~.terms.shift_lag`, on the voltage);
2. **one delay of the record** — the per-test delays (one per test) add little to what
   the one delay explains: ln(SSE_one/SSE_per-test) ≤ ``criterion.skew_spread`` ×
   ln(SSE_0/SSE_one) on the fit tests.  (The force's check,
   :func:`~.terms.per_test_delays`, refuses at ΔBIC < −10; the voltage residual of the
   rigid baseline is never at its noise — SSE/N ≈ 3.4 on a clean campaign — and per-test
   delays pick up some of it on every campaign, ΔBIC −96 to −564 on the tuning cases,
   −176 on the skewed record, where they add 12 % of the one delay's log-gain against
   96–140 % on a gap and a mount spring);
3. **against no delay**: ΔBIC = N_eff ln(SSE_τ/SSE_0) + ln N_eff < ``criterion.skew_bic``
   on the fit tests *and* on the held-out tests (the same τ);
4. **the delay explains the voltage residual**: on the held-out tests it removes at
   least ``criterion.skew_explains`` of the voltage SSE's excess over its noise
   expectation, (SSE₀ − SSE_τ)/(SSE₀ − N).  A mount spring's rotor lags the rod by
   F/k — a force-shaped deviation, largest at the friction's reversals — which one
   time shift of the whole record explains only in part.

5. **the force does not follow the voltage**: a rotor that really lags the rod (a
   mount, a gap) lags in the force too — the generator's force on the rod,
   K_t V/(R_load r), comes from the rotor's current — while a late voltage record leaves
   the force on time.  The model's force with its generator part moved by the same τ,
   F̂ + c (V̂(t − τ) − V̂(t)) with c = K_t/(R_load r), must not fit the force of the
   held-out tests significantly better than F̂ (N_eff ln(SSE_moved/SSE_on) < ``criterion.skew_bic``
   refuses the skew; skipped without ``harvester``).

When all of them hold, every test's voltage is re-aligned, V(t + τ) on the same samples
(:func:`realign_voltage`; the last |τ| of a record extrapolated linearly from its last
two samples), so the rounds see a record without the skew; the answer states the skew
and names no catalogue member for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace as _replace
from typing import Sequence

import numpy as np

from .judge import skew_found
from .criterion import DEFAULT_CRITERION, Criterion
from .evidence import delta_bic
from .prepared import PreparedTest
from .record_shift import LAG_GRID_S

__all__ = ["VoltageSkew", "find_voltage_skew", "em_force_per_volt", "realign_voltage",
           "voltage_shift_curves"]



@dataclass
class VoltageSkew:
    """The outcome of :func:`find_voltage_skew`.

    Attributes
    ----------
    found : bool
        One delay of the voltage record explains the voltage residual.
    delay_s : float
        The voltage's delay against force and displacement (s; > 0: sampled late).
    dbic_fit, dbic_held : float
        ΔBIC of the delay against no delay on the fit and held-out tests.
    spread : float
        ln(SSE_one/SSE_per-test) / ln(SSE_0/SSE_one) on the fit tests: what per-test
        delays add, as a share of the one delay's log-gain.
    explained : float
        Share of the held-out voltage SSE's excess over noise the delay removes.
    message : str
        The check in words (said, and noted in the result).
    evidence : dict
        The statistics the judge decides on (:func:`~.judge.skew_found`).
    """

    found: bool
    delay_s: float
    dbic_fit: float
    dbic_held: float
    spread: float
    explained: float
    message: str
    evidence: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        """The check as plain JSON values (the result file's ``voltage_skew``)."""
        return {"found": bool(self.found), "delay_s": float(self.delay_s),
                "dbic_fit": float(self.dbic_fit), "dbic_heldout": float(self.dbic_held),
                "spread": float(self.spread), "explained": float(self.explained),
                "message": self.message}


def _voltage_at(pt: PreparedTest, tau: float) -> np.ndarray:
    """The measured voltage at t + τ on the test's samples (linear interpolation; linear
    extrapolation from the two end samples beyond the record)."""
    t, v = pt.time_s, pt.y[1]
    q = t + tau
    out = np.interp(q, t, v)
    hi, lo = q > t[-1], q < t[0]
    if hi.any():
        out[hi] = v[-1] + (q[hi] - t[-1]) * (v[-1] - v[-2]) / (t[-1] - t[-2])
    if lo.any():
        out[lo] = v[0] + (q[lo] - t[0]) * (v[1] - v[0]) / (t[1] - t[0])
    return out


def voltage_shift_curves(pts: Sequence[PreparedTest], preds: Sequence[np.ndarray]
                         ) -> np.ndarray:
    """(tests, :data:`~.terms.LAG_GRID_S`) noise-normalised SSE of the voltage residual
    V(t + τ) − V̂(t) of each test at each delay τ."""
    rows = []
    for pt, yp in zip(pts, preds):
        w = pt.wnorm[1]
        rows.append([float(np.sum(((_voltage_at(pt, tau) - yp[1]) * w) ** 2))
                     for tau in LAG_GRID_S])
    return np.array(rows)


def em_force_per_volt(pt: PreparedTest, harvester) -> float:
    """c = K_t/(R_load r): the generator's force on the rod per volt across the load
    (N/V); 0 without a load."""
    load = getattr(pt.test, "load_ohm", None)
    if not load:
        return 0.0
    return harvester.torque_constant_Nm_per_A / (load * harvester.lead_m_per_rad)


def find_voltage_skew(fit_pts: Sequence[PreparedTest], fit_pred: Sequence[np.ndarray],
                      held_pts: Sequence[PreparedTest], held_pred: Sequence[np.ndarray],
                      n_eff_fit: float, n_eff_held: float, harvester=None,
                      criterion: Criterion = DEFAULT_CRITERION) -> VoltageSkew | None:
    """The voltage-skew check of the module docstring on the baseline's outputs; None
    when the tests have no voltage channel or no delay is better than none.
    ``harvester`` (:class:`~ehsa_opt.physics.params.HarvesterParams`): for check 5."""
    if not fit_pts or any(pt.y.shape[0] < 2 for pt in fit_pts):
        return None
    curves = voltage_shift_curves(fit_pts, fit_pred)
    total = curves.sum(axis=0)
    k = int(np.argmin(total))
    k0 = int(np.argmin(np.abs(LAG_GRID_S)))
    tau = float(LAG_GRID_S[k])
    if k == k0:
        return None
    sse_pt, sse_one, sse_0 = float(curves.min(axis=1).sum()), float(total[k]), float(total[k0])
    spread = math.log(sse_one / max(sse_pt, 1e-300)) / max(math.log(sse_0 / sse_one), 1e-300)
    d_fit = delta_bic(float(total[k]), float(total[k0]), 1, n_eff_fit)
    ev, evp, n_eff = (held_pts, held_pred, n_eff_held) if held_pts else (fit_pts, fit_pred,
                                                                         n_eff_fit)
    s0 = s1 = n = 0.0
    for pt, yp in zip(ev, evp):
        w = pt.wnorm[1]
        s0 += float(np.sum(((pt.y[1] - yp[1]) * w) ** 2))
        s1 += float(np.sum(((_voltage_at(pt, tau) - yp[1]) * w) ** 2))
        n += float(np.count_nonzero(pt.weight > 0))
    d_held = delta_bic(s1, s0, 1, n_eff)
    explained = (s0 - s1) / (s0 - n) if s0 > n else 0.0
    # 5: the generator's force moved with the voltage (a rotor that lags) against on time
    f_on = f_moved = 0.0
    if harvester is not None:
        for pt, yp in zip(ev, evp):
            c, w = em_force_per_volt(pt, harvester), pt.wnorm[0]
            dv = np.interp(pt.time_s - tau, pt.time_s, yp[1]) - yp[1]
            f_on += float(np.sum(((pt.y[0] - yp[0]) * w) ** 2))
            f_moved += float(np.sum(((pt.y[0] - yp[0] - c * dv) * w) ** 2))
    follows = f_on > 0 and delta_bic(f_moved, f_on, 0, n_eff) < criterion.skew_bic
    edge = abs(abs(tau) - float(np.max(np.abs(LAG_GRID_S)))) < 1e-9
    evidence = {"edge": edge, "spread": spread, "delta_bic_fit": d_fit,
                "delta_bic_heldout": d_held, "explained": explained, "follows": follows}
    found = skew_found(evidence, criterion)
    word = "late" if tau > 0 else "early"
    why = ("one delay of the voltage record explains its residual" if found else
           "at the edge of the searched delays" if edge else
           f"the best delay differs from test to test (per-test delays add "
           f"{100 * spread:.0f} % of its log-gain, > {100 * criterion.skew_spread:.0f} %)"
           if spread > criterion.skew_spread else
           f"not significant (ΔBIC fit {d_fit:.3g}, held-out {d_held:.3g}; needs < "
           f"{criterion.skew_bic:g})" if not (d_fit < criterion.skew_bic and d_held < criterion.skew_bic) else
           f"it explains only {100 * explained:.0f} % of the voltage residual's excess "
           f"over noise (needs {100 * criterion.skew_explains:.0f} %): the rotor's channel differs "
           f"from the model otherwise than by a delay of the record"
           if explained < criterion.skew_explains else
           f"the force follows: its generator part moved by the same delay fits the "
           f"force significantly better (SSE {f_on:.4g} -> {f_moved:.4g}) — the rotor "
           f"lags, not the record")
    msg = (f"voltage skew: the voltage {1e3 * abs(tau):.1f} ms {word} against force and "
           f"displacement removes {100 * explained:.0f} % of the voltage residual's excess "
           f"(ΔBIC against no delay: fit {d_fit:.3g}, held-out {d_held:.3g}; per-test "
           f"delays add {100 * spread:.0f} % of its log-gain) — {why}")
    if found:
        msg += ("; the voltage record is re-aligned by it before the rounds (a skew of the "
                "acquisition, not an effect of the rig: no catalogue member is named for it)")
    return VoltageSkew(found, tau, d_fit, d_held, spread, explained, msg, evidence)


def realign_voltage(pts: Sequence[PreparedTest], tau: float) -> list[PreparedTest]:
    """The tests with the voltage record moved back by ``tau`` (V(t + τ)) on the same
    samples; the force, the motion and the weights unchanged."""
    out = []
    for pt in pts:
        y = pt.y.copy()
        y[1] = _voltage_at(pt, tau)
        t = pt.test
        nt = _replace(t, voltage_V=y[1].copy()) if t.voltage_V is not None else t
        out.append(_replace(pt, test=nt, y=y))
    return out
