"""Members ``force_sensor`` and ``voltage_sensor``: a measurement channel's own dynamics,
a second-order low-pass between the quantity and its record — the load cell between the
force the rod transmits and the force recorded, the conditioning (an isolation
amplifier, an anti-alias filter) between the generator's load voltage and the voltage
recorded.  Written below for the force; the voltage's is the same with V for F, judged
on the voltage channel's SSE (the force kept).

A load cell (with its amplifier and the acquisition's anti-alias filter) is a
mass–spring system: the recorded force is F_m = H(s) F with

    H(s) = ω_c² / (s² + 2 ζ ω_c s + ω_c²),   ω_c = 2π f_c,

whose group delay depends on the frequency — a sine at 2 Hz and a stroke's reversal see
different delays, so the per-test delays of the force record differ (what refuses
:mod:`.force_lag`'s one delay).  A pure delay is the limit of H at a bandwidth far
above the tests' frequencies (its low-frequency group delay 2ζ/ω_c).

Fit (:func:`fit_sensor`): f_c and ζ by least squares of the recorded force against
H applied to the current model's force on the fit tests (the model fixed: a linear
filter of a known signal, two parameters; log f_c so that the bandwidth is fitted over
its decades), started from a grid.  The base model is then refitted on the record
with the filter's action on the model's own force taken out,

    F_adj = F_m − (H[F̂] − F̂),

so that F_adj − F̂ = F_m − H[F̂] is the recorded-force residual of the filtered model
(exact at the model the record is adjusted with, to first order for a model close to
it); the filter and the refit are iterated once.  Its evidence is measured on the
recorded force of the evaluation tests (:func:`try_sensor`) and the judge decides;
once adopted, the search judges every later model on the adjusted record.

Its own statistics: the ~95 % interval of f_c and ζ from the Gauss–Newton
covariance with the residual's autocorrelation (effective samples), and the
size resolved only when the interval of f_c stays below the highest bandwidth the
sampling resolves (:data:`~..sensor_filter.MAX_BANDWIDTH_SHARE` of the sample rate) — a filter whose
bandwidth cannot be told from infinite is no sensor dynamics.
"""

from __future__ import annotations

import math
from dataclasses import replace as _replace

import numpy as np

from ..evidence import change_evidence, force_error_percent, normalised_sse
from ..fit import fit_group
from ..channels import channel_sse
from ..judge import channel_sse_excess_reduction, excess_reduction
from ..prepared import PreparedTest, decimated
from ..sensor_filter import filtered_channel as _filtered, filtered_force, fit_sensor
from ..rig import Rig, predict
from .record_change import RecordChange

__all__ = ["NAMES", "try_sensor"]

#: The member's name and its parameters' prefix, by channel (0 force, 1 voltage).
NAMES = {0: "force_sensor", 1: "voltage_sensor"}


def _with_channel(pt: PreparedTest, ch: int, values: np.ndarray) -> PreparedTest:
    y = pt.y.copy()
    y[ch] = values
    test = (_replace(pt.test, force_N=values.copy()) if ch == 0 else
            _replace(pt.test, voltage_V=values.copy()))
    return _replace(pt, test=test, y=y)


def _adjusted(pts, preds, f_c, zeta, ch: int = 0) -> list[PreparedTest]:
    """The tests with the filter's action on the model's output taken out of the record."""
    return [_with_channel(pt, ch, pt.y[ch] - (filtered_force(pt, yp[ch], f_c, zeta) - yp[ch]))
            for pt, yp in zip(pts, preds)]


def try_sensor(fit_pts, held_pts, rig: Rig, base, fit_pred, held_pred, floor: float,
               n_eff_fit: float, n_eff_held: float, settings, decimation: int = 1,
               ch: int = 0, start_pred=None) -> RecordChange | None:
    """Member ``force_sensor`` (``ch`` 0) or ``voltage_sensor`` (``ch`` 1): the filter
    fitted on the current model's output, the base model refitted on the adjusted record
    (collocation on every ``decimation``-th sample, as the baseline), the filter refitted
    once on the refit, and the evidence on the record (the refitted model through the
    filter against the model before it): the relative force error, ΔBIC on every
    channel, and for the voltage its channel's SSE excess removed.  None when the refit
    failed.  ``start_pred``: the outputs the filter is first fitted on when they are not
    the current model's — the static law's when the base law is the dynamic one, whose
    bristles would otherwise already carry the sensor's lag (on a campaign with an 80 Hz
    load cell the bristles took it and the filter was left at its highest bandwidth); the
    refits are of the current (dynamic) model, so the bristles keep only what the filter
    leaves."""
    name = NAMES[ch]
    f_c = zeta = math.nan
    preds_f, params, est = (start_pred or fit_pred), base.parameters, None
    b2 = None
    for _ in range(2):
        est = fit_sensor(fit_pts, preds_f, ch)
        f_c, zeta = est["f_c_hz"], est["zeta"]
        adj = _adjusted(fit_pts, preds_f, f_c, zeta, ch)
        b2 = fit_group([decimated(pt, decimation) for pt in adj], rig, [params],
                       max_iter=settings.max_iter)
        if not b2.parameters:
            return None
        params = b2.parameters
        preds_f = predict(fit_pts, rig, params)
    est = fit_sensor(fit_pts, preds_f, ch)
    f_c, zeta = est["f_c_hz"], est["zeta"]
    pf = preds_f
    ph = predict(held_pts, rig, params) if held_pts else []
    mf, mh = _filtered(fit_pts, pf, f_c, zeta, ch), _filtered(held_pts, ph, f_c, zeta, ch)
    ev, pe, pe0, e_before, e_after, d_fit, d_held = change_evidence(
        fit_pts, fit_pred, mf, held_pts, held_pred, mh, 2, n_eff_fit, n_eff_held)
    sse_red = None
    if ch > 0:
        s0, n = channel_sse(ev, pe0)
        s1, _ = channel_sse(ev, pe)
        sse_red = float(channel_sse_excess_reduction(s0[[ch]], s1[[ch]], n[[ch]],
                                                     settings.criterion))
    iv = est["intervals"]
    resolved = iv["sensor_bandwidth_hz"][1] < est["f_max_hz"]
    # from here on: the record with the filter's action on this model's output taken out
    f2, h2 = _adjusted(fit_pts, pf, f_c, zeta, ch), _adjusted(held_pts, ph, f_c, zeta, ch)
    prefix = "sensor" if ch == 0 else "voltage_sensor"
    params_out = {f"{prefix}_bandwidth_hz": f_c, f"{prefix}_damping": zeta,
                  f"{prefix}_group_delay_s": 2.0 * zeta / (2.0 * math.pi * f_c)}
    c = dict(effect=name, applicable=True, score=math.nan, chi2=math.nan, round=1,
             fitted=True, fit=b2, error_before=e_before, error_after=e_after,
             excess_reduction=excess_reduction(e_before, e_after, floor, settings.criterion),
             delta_bic_fit=d_fit, delta_bic_heldout=d_held, sse_heldout=normalised_sse(ev, pe),
             sse_reduction=sse_red, sse_route=sse_red is not None, resolved=resolved,
             parameters=params_out,
             intervals={k.replace("sensor", prefix, 1): tuple(v) for k, v in iv.items()},
             predictions=pf + ph, rig=rig)
    lo, hi = iv["sensor_bandwidth_hz"]
    what = "recorded-force error" if ch == 0 else "force error"
    msg = (f"{name}: bandwidth {f_c:.1f} Hz [{lo:.1f}, {hi:.1f}], damping {zeta:.2f} "
           f"(group delay at low frequency {1e3 * params_out[f'{prefix}_group_delay_s']:.2f} ms); "
           f"{what} {e_before:.3f} -> {e_after:.3f} %"
           + (f", voltage SSE excess removed {100 * sse_red:.0f} %" if sse_red is not None
              else "")
           + f", ΔBIC fit {d_fit:.1f}, held-out {d_held:.1f}"
           + ("" if resolved else f"; the bandwidth is not resolved below "
                                  f"{est['f_max_hz']:.0f} Hz"))
    err = force_error_percent(h2 or f2, ph or pf)
    return RecordChange(f2, h2, b2, pf, ph, err, c, message=msg)
