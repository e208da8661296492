"""The data-driven term's ``sensor`` support (:mod:`.terms`): a sensor column's low-pass,
refined from the grid's nearest, and whether it is one sensor for every test — the
delay it leaves and its weight must not differ from test to test by a significant and
practical amount."""

from __future__ import annotations

import numpy as np

from .evidence import delta_bic
from .record_shift import shift_sse_curves
from .sensor_filter import filtered_force, fit_sensor

__all__ = ["sensor_of", "refined_sensor", "with_sensor_term", "per_test_sensor",
           "per_test_delays_left"]


def sensor_of(name: str) -> tuple[float, float]:
    """(f_c Hz, ζ) of a sensor column's name ``H(f Hz, ζ)[F]-F``."""
    return float(name[2:].split(" Hz")[0]), float(name.split(", ")[1].split(")")[0])


def refined_sensor(pts, preds, name: str) -> dict[str, float]:
    """The sensor of the grid column ``name`` refined by least squares of the fit tests'
    force against the model's force through it (:func:`~.sensor_filter.fit_sensor`,
    bandwidth and damping free, weight 1: a sensor passes the force it measures)."""
    est = fit_sensor(pts, preds, 0, start=sensor_of(name))
    return {f"H({est['f_c_hz']:.1f} Hz, {est['zeta']:.2f})[F]-F": 1.0}


def with_sensor_term(pts, preds, columns: dict) -> list[np.ndarray]:
    """``preds`` with the term's sensor column(s) c (H[F̂] − F̂) added to the force."""
    out = []
    for pt, yp in zip(pts, preds):
        q = np.array(yp, float, copy=True)
        for name, c in columns.items():
            if name.startswith("H("):
                f_c, zeta = sensor_of(name)
                q[0] = q[0] + c * (filtered_force(pt, yp[0], f_c, zeta) - yp[0])
        out.append(q)
    return out


def _spread(sse_each: float, sse_one: float, k: int, n_eff: float, n: float
            ) -> tuple[float, float]:
    """ΔBIC of ``k`` more parameters (per-test values against one) and the share of the
    one-value residual's SSE excess over its noise expectation ``n`` they remove (0 when
    that residual is at the noise)."""
    excess = sse_one - n
    share = (sse_one - sse_each) / excess if excess > 0 else 0.0
    return delta_bic(sse_each, sse_one, k, n_eff), share


def per_test_sensor(pts, preds, columns: dict, n_eff: float) -> tuple[float, float]:
    """One weight per test of the term's sensor column against one weight for all: ΔBIC
    (< 0: the tests want different low-passes) and the share of the residual's excess
    over noise the per-test weights remove.  One sensor filters every test alike; a
    transition that depends on the motion (presliding after a reversal, whose duration
    in time follows each test's reversal) asks for a different weight on each test."""
    sse_each, n = 0.0, 0.0
    xs, rs = [], []
    for pt, yp, yq in zip(pts, preds, with_sensor_term(pts, preds, columns)):
        col = (yq[0] - yp[0]) * pt.wnorm[0]
        r = (pt.y[0] - yp[0]) * pt.wnorm[0]
        den = float(col @ col)
        c = float(col @ r) / den if den > 0 else 0.0
        sse_each += float((r - c * col) @ (r - c * col))
        n += pt.n_resolved
        xs.append(col)
        rs.append(r)
    x, r = np.concatenate(xs), np.concatenate(rs)
    den = float(x @ x)
    c = float(x @ r) / den if den > 0 else 0.0
    sse_one = float((r - c * x) @ (r - c * x))
    return _spread(sse_each, sse_one, len(pts) - 1, n_eff, n)


def per_test_delays_left(pts, preds, n_eff: float) -> tuple[float, float]:
    """One delay per test against one for all on ``preds``: ΔBIC and the share of the
    one-delay residual's excess over noise the per-test delays remove."""
    curves = shift_sse_curves(pts, preds)
    n = float(sum(pt.n_resolved for pt in pts))
    return _spread(float(curves.min(axis=1).sum()), float(curves.sum(axis=0).min()),
                   len(pts) - 1, n_eff, n)
