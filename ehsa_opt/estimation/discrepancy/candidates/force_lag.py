"""Catalogue member ``force_lag``: a measurement-channel delay of the force.

A delay of the force channel relative to the displacement is not a component of
the bench model (it acts on the record, not on the physics): the delay τ is found
by a time-shift search on the baseline residual (:func:`~ehsa_opt.estimation.discrepancy.terms.shift_lag`), the
measured force is re-aligned by it (F(t + τ), the ends cropped) and the baseline is
refitted; the delay is named when it earns by the decision rule (:func:`~ehsa_opt.estimation.discrepancy.judge.earns`),
compared on the re-aligned held-out tests against the baseline on the same samples.

Two checks before the refits (each refit is a collocation fit of the baseline, tens of
seconds on a 15-test campaign), each on the check's own evidence: the delay must be one
delay for every test (:func:`~ehsa_opt.estimation.discrepancy.terms.per_test_delays`) and
inside the searched delays (not at the edge of
:data:`~ehsa_opt.estimation.discrepancy.terms.LAG_GRID_S`: the residual then asks for a
shift the search does not locate — an impact-ridden residual, not a record's delay), and
the baseline's own force moved by it, *without* a refit, must already remove
:data:`SCREEN_SHARE` of the share of the evaluation error's excess that earning asks for
(the criterion's ``min_excess_reduction``).  A delay of the
record is what the shift itself undoes; the refit only re-balances the friction on the
re-aligned samples.
"""

from __future__ import annotations

import math
from dataclasses import replace as _replace
from typing import Sequence

import numpy as np

from ..criterion import DEFAULT_CRITERION, DEFAULT_POLICY, Criterion
from ..evidence import delta_bic, force_error_percent, normalised_sse
from ..judge import excess_reduction
from ..fit import fit_group
from ..prepared import PreparedTest, decimated, prepare_tests
from ..rig import predict
from .record_change import RecordChange
from ..record_shift import LAG_GRID_S, per_test_delays, shifted_force, shift_lag

__all__ = ["try_lag", "per_test_delays", "screen_lag", "SCREEN_SHARE"]

#: The shift alone (no refit) must remove this share of the criterion's
#: ``min_excess_reduction`` of the evaluation
#: error's excess over the noise floor before the baseline is refitted on the re-aligned
#: record (a margin of two for what the refit adds).
SCREEN_SHARE = DEFAULT_POLICY.lag_screen_share


def screen_lag(tau: float, eval_pts, eval_pred, floor: float,
               criterion: Criterion = DEFAULT_CRITERION) -> tuple[float, float, float]:
    """The evaluation force error (%) of the baseline as it is and with its force moved
    by ``tau`` (no refit), and the share of the excess over ``floor`` the move removes."""
    e0 = force_error_percent(eval_pts, eval_pred)
    moved = [np.atleast_2d(shifted_force(pt, yp, tau)) for pt, yp in zip(eval_pts, eval_pred)]
    e1 = force_error_percent(eval_pts, moved)
    return e0, e1, excess_reduction(e0, e1, floor, criterion)


def _lag_tests(pts: Sequence[PreparedTest], tau: float, has_generator: bool
               ) -> list[PreparedTest]:
    """The tests with the force channel moved back by ``tau`` (F(t + τ)), the ends
    that the shift leaves without data cropped."""
    out = []
    for pt in pts:
        t = pt.test
        keep = (t.time_s + tau >= t.time_s[0]) & (t.time_s + tau <= t.time_s[-1])
        F = np.interp(t.time_s + tau, t.time_s, t.force_N)
        nt = _replace(t, time_s=t.time_s[keep], displacement_m=t.displacement_m[keep],
                      force_N=F[keep],
                      voltage_V=t.voltage_V[keep] if t.voltage_V is not None else None)
        out += prepare_tests([nt], has_generator, mass_kg=pt.mass_kg)
    return out


def try_lag(fit_pts, held_pts, rig, base, fit_pred, held_pred, floor, n_eff_fit, n_eff_held,
             err0, settings, say, decimation: int = 1):
    """Catalogue member ``force_lag`` (a measurement-channel delay of the force): the
    delay from a time-shift search on the baseline residual (:func:`~ehsa_opt.estimation.discrepancy.terms.shift_lag`),
    the force re-aligned by it and the baseline refitted (collocation on every
    ``decimation``-th sample, as the baseline); kept when it is one delay for every test
    (:func:`per_test_delays`); its evidence is measured on the re-aligned held-out tests,
    cropped alike (the judge decides, :func:`~..judge.judge_attempt`).  None: not tried
    (said why)."""
    lag = shift_lag(fit_pts, fit_pred)
    if lag is None:
        return None
    crit = settings.criterion
    spread_bic = per_test_delays(fit_pts, fit_pred, n_eff_fit)
    if spread_bic < crit.delay_spread_bic:
        say(f"force_lag: not a channel delay — the best delay differs from test to test "
            f"(per-test delays against one delay: ΔBIC {spread_bic:.3g} < "
            f"{crit.delay_spread_bic:g}): the force's "
            f"lead depends on the motion, which a delay of the record does not")
        return None
    tau = lag[0]
    if abs(abs(tau) - float(np.max(np.abs(LAG_GRID_S)))) < 1e-9:
        say(f"force_lag: not tried — the best shift of the force ({1e3 * tau:.1f} ms) is at "
            f"the edge of the searched delays (±{1e3 * float(np.max(LAG_GRID_S)):.0f} ms): "
            f"the residual is not a delay of the record the search locates")
        return None
    ev_pts, ev_pred = (held_pts, held_pred) if held_pts else (fit_pts, fit_pred)
    e0, e1, share = screen_lag(tau, ev_pts, ev_pred, floor, crit)
    if share < SCREEN_SHARE * crit.min_excess_reduction:
        say(f"force_lag: not tried — the baseline's force moved by {1e3 * tau:.2f} ms "
            f"(no refit) removes {100 * share:.1f} % of the error's excess ({e0:.3f} -> "
            f"{e1:.3f} %), less than {100 * SCREEN_SHARE * crit.min_excess_reduction:g} % "
            f"({SCREEN_SHARE:g} × the {100 * crit.min_excess_reduction:g} % earning asks for)")
        return None
    for it in range(2):  # re-estimate once on the re-aligned baseline
        f2 = _lag_tests(fit_pts, tau, rig.has_generator)
        h2 = _lag_tests(held_pts, tau, rig.has_generator) if held_pts else []
        b2 = fit_group([decimated(pt, decimation) for pt in f2], rig, [base.parameters],
                       max_iter=settings.max_iter)
        if not b2.parameters:
            return None
        pf = predict(f2, rig, b2.parameters)
        if it == 1:
            break  # f2, h2, b2 belong to the tau applied (reported below)
        again = shift_lag(f2, pf)
        if again is None:
            break
        tau += again[0]
    ph = predict(h2, rig, b2.parameters) if h2 else []
    # the "before" on the same (cropped) samples: the baseline on the un-shifted data
    f0 = _lag_tests(fit_pts, 0.0, rig.has_generator)
    h0 = [_crop_like(p, q) for p, q in zip(held_pts, h2)]
    b0h = predict(h0, rig, base.parameters) if h0 else []
    b0f = predict([_crop_like(p, q) for p, q in zip(fit_pts, f2)], rig, base.parameters)
    ev, ev0, pe, pe0 = (h2, h0, ph, b0h) if h2 else (f2, f0, pf, b0f)
    e_before, e_after = force_error_percent(ev0, pe0), force_error_percent(ev, pe)
    d_fit = delta_bic(normalised_sse(f2, pf), normalised_sse([_crop_like(p, q) for p, q in zip(fit_pts, f2)], b0f), 1,
                  n_eff_fit)
    d_held = delta_bic(normalised_sse(ev, pe), normalised_sse(ev0, pe0), 1, n_eff_held if h2 else n_eff_fit)
    c = dict(effect="force_lag", applicable=True, score=math.nan, chi2=math.nan, round=1,
             fitted=True, fit=b2, error_before=e_before, error_after=e_after,
             excess_reduction=excess_reduction(e_before, e_after, floor, crit),
             delta_bic_fit=d_fit, delta_bic_heldout=d_held, sse_heldout=normalised_sse(ev, pe),
             parameters={"force_lag_s": tau}, predictions=pf + ph, rig=rig)
    msg = f"force_lag: {1e3 * tau:.2f} ms, error {e_before:.3f} -> {e_after:.3f} %"
    return RecordChange(f2, h2, b2, pf, ph, e_after, c, message=msg)


def _crop_like(pt: PreparedTest, like: PreparedTest) -> PreparedTest:
    """``pt`` on the samples of ``like`` (same time stamps)."""
    keep = np.isin(pt.time_s, like.time_s)
    t = pt.test
    nt = _replace(t, time_s=t.time_s[keep], displacement_m=t.displacement_m[keep],
                  force_N=t.force_N[keep],
                  voltage_V=t.voltage_V[keep] if t.voltage_V is not None else None)
    return prepare_tests([nt], pt.y.shape[0] > 1, mass_kg=pt.mass_kg)[0]
