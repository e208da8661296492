"""The campaign's coordinates of a friction that drifts as the rig runs in or warms
(:mod:`.candidates.friction_drift`, the data-driven term's ``drift`` group), at every
sample, the tests taken in the order they were run (the bench format's ``run_order``,
else ``started_at``):

* the cumulative sliding distance s(t): how far the rod has slid since the campaign began
  (:func:`travel_coordinates`);
* the heating coordinate h_τ(t) = ∫ |v(t')| e^{−(t−t')/τ} dt' over the campaign's time
  (:func:`heating_coordinates`): the temperature rise of a first-order thermal mass heated
  by the Coulomb friction's power F_C |v| and cooling with time constant τ, in metres of
  sliding (the rise is F_C R h_τ / τ for a thermal resistance R).  The pauses between
  tests come from their ``started_at`` stamps; without them the tests are taken back to
  back (no cooling between them).  With τ → ∞ it is the sliding distance."""

from __future__ import annotations

from typing import Sequence

import math

import numpy as np
from scipy.signal import lfilter

from .prepared import PreparedTest

__all__ = ["run_order_known", "travel_coordinates", "campaign_travel_m",
           "heating_coordinates", "pauses_known", "campaign_duration_s"]


def run_order_known(pts: Sequence[PreparedTest]) -> bool:
    """Every test states its place in the campaign (``run_order`` or ``started_at``)."""
    return bool(pts) and (all(getattr(pt.test, "run_order", None) is not None for pt in pts)
                          or pauses_known(pts))


def pauses_known(pts: Sequence[PreparedTest]) -> bool:
    """Every test states when it started (``started_at``): the pauses between tests are
    known."""
    return bool(pts) and all(getattr(pt.test, "started_at", None) is not None for pt in pts)


def _in_run_order(pts: Sequence[PreparedTest]) -> list[PreparedTest]:
    if all(getattr(pt.test, "run_order", None) is not None for pt in pts):
        return sorted(pts, key=lambda pt: pt.test.run_order)
    return sorted(pts, key=lambda pt: pt.test.started_at)


def _starts_s(order: Sequence[PreparedTest]) -> list[float]:
    """Each test's start on the campaign's clock (s): from ``started_at`` when every test
    has it, else back to back (a test starts when the one before ended)."""
    if pauses_known(order):
        t0 = order[0].test.started_at
        return [(pt.test.started_at - t0).total_seconds() for pt in order]
    out, clock = [], 0.0
    for pt in order:
        out.append(clock)
        clock += max(float(pt.time_s[-1]), 0.0)
    return out


def campaign_duration_s(pts: Sequence[PreparedTest]) -> float:
    """From the first test's start to the last one's end on the campaign's clock, s."""
    order = _in_run_order(pts)
    return _starts_s(order)[-1] + max(float(order[-1].time_s[-1]), 0.0)


def heating_coordinates(pts: Sequence[PreparedTest], tau_s: float
                        ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The heating coordinate h_τ (m; see the module docstring) by test file: (time
    stamps, h at them), the tests in run order, cooling over the pauses between them.  A
    test's unrecorded or cropped head (its first stamp after 0) heats at its mean speed;
    within a test the first-order recursion runs on its sample steps."""
    order = _in_run_order(pts)
    starts = _starts_s(order)
    out, h, end_prev = {}, 0.0, 0.0
    for pt, start in zip(order, starts):
        t, v = np.asarray(pt.time_s, float), np.abs(pt.u[1])
        h *= math.exp(-max(start - end_prev, 0.0) / tau_s)  # the pause: cooling only
        t0 = max(float(t[0]), 0.0)
        a0 = math.exp(-t0 / tau_s)
        h = h * a0 + float(np.mean(v)) * tau_s * (1.0 - a0)
        dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
        a = math.exp(-dt / tau_s)
        # h_k = a h_{k-1} + (1 − a) τ |v_k|: exact for |v| held over each step
        hk, _ = lfilter([(1.0 - a) * tau_s], [1.0, -a], v, zi=[a * h])
        out[pt.test.file] = (t, hk)
        h, end_prev = float(hk[-1]), start + max(float(t[-1]), 0.0)
    return out


def travel_coordinates(pts: Sequence[PreparedTest]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The cumulative sliding distance of the campaign, by test file: (time stamps, s in
    m at them), the tests taken in run order.  A test cropped to its last samples counts
    its cropped head at its mean speed (the time stamps are the record's own)."""
    order = _in_run_order(pts)
    out, before = {}, 0.0
    for pt in order:
        t, v = pt.time_s, np.abs(pt.u[1])
        inside = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
        head = float(np.mean(v)) * max(float(t[0]), 0.0)
        out[pt.test.file] = (np.array(t, float), before + head + inside)
        before += head + float(inside[-1])
    return out


def campaign_travel_m(pt: PreparedTest, coords: dict) -> np.ndarray:
    """A coordinate of ``coords`` (:func:`travel_coordinates`, :func:`heating_coordinates`)
    on this test's samples (a record member may have cropped its ends)."""
    t, s = coords[pt.test.file]
    return np.interp(pt.time_s, t, s)
