"""The campaign's cumulative sliding distance: how far the rod has slid since the
campaign began, at every sample, the tests taken in the order they were run (the bench
format's ``run_order``) — the coordinate of a friction that drifts as the rig runs in
(:mod:`.candidates.friction_drift`, the data-driven term's ``drift`` group)."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .prepared import PreparedTest

__all__ = ["run_order_known", "travel_coordinates", "campaign_travel_m"]


def run_order_known(pts: Sequence[PreparedTest]) -> bool:
    """Every test states its place in the campaign (``run_order``)."""
    return bool(pts) and all(getattr(pt.test, "run_order", None) is not None for pt in pts)


def travel_coordinates(pts: Sequence[PreparedTest]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The cumulative sliding distance of the campaign, by test file: (time stamps, s in
    m at them), the tests taken in run order.  A test cropped to its last samples counts
    its cropped head at its mean speed (the time stamps are the record's own)."""
    order = sorted(pts, key=lambda pt: pt.test.run_order)
    out, before = {}, 0.0
    for pt in order:
        t, v = pt.time_s, np.abs(pt.u[1])
        inside = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
        head = float(np.mean(v)) * max(float(t[0]), 0.0)
        out[pt.test.file] = (np.array(t, float), before + head + inside)
        before += head + float(inside[-1])
    return out


def _travel(pt: PreparedTest, coords: dict) -> np.ndarray:
    """s (m) on this test's samples (a record member may have cropped its ends)."""
    t, s = coords[pt.test.file]
    return np.interp(pt.time_s, t, s)


def campaign_travel_m(pt: PreparedTest, coords: dict) -> np.ndarray:
    """s (m) on this test's samples (a record member may have cropped its ends)."""
    t, s = coords[pt.test.file]
    return np.interp(pt.time_s, t, s)
