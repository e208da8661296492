"""The workflow's wall-time deadline, seen by the long loops inside a candidate fit.

:func:`~.workflow.run_discrepancy` sets it from ``DiscrepancySettings.budget_s``; the
screening of starts (:func:`~.candidate_fit.screen_starts`) and the Gauss–Newton
refinements on the simulation (:func:`~.polish.polish`) stop at it and keep the best
point reached, so a single candidate fit cannot carry a run far past its budget.  The
deadline is a monotonic-clock instant (the same in forked pool workers, which inherit it).

Where the deadline stopped a stage of a fit is recorded (:func:`note_cut`, collected by
:func:`recording_cuts` around one member fit): a member whose fit was cut before its
effect's parameters left their start is *not fitted* (:func:`~.candidate_fit.not_fitted`)
and takes no decision of the search.  :func:`elapsed_s` and :func:`time_left_s` let the
search say when each phase ran and leave out work that cannot finish before the deadline.
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager

__all__ = ["deadline_set", "past_deadline", "elapsed_s", "time_left_s", "note_cut",
           "recording_cuts"]

_DEADLINE = [math.inf]
_START = [time.monotonic()]
#: the cut records of the member fits in progress (one list per :func:`recording_cuts`)
_RECORDERS: list[list[dict]] = []


def past_deadline() -> bool:
    """True once the deadline of the run in progress has passed."""
    return time.monotonic() > _DEADLINE[0]


def elapsed_s() -> float:
    """Seconds since the deadline of the run in progress was set (:func:`deadline_set`)."""
    return time.monotonic() - _START[0]


def time_left_s() -> float:
    """Seconds left before the deadline (inf without one; negative once past it)."""
    return _DEADLINE[0] - time.monotonic()


@contextmanager
def deadline_set(seconds: float | None):
    """Set the deadline ``seconds`` from now (None: none) for the ``with`` block."""
    old, old_start = _DEADLINE[0], _START[0]
    _START[0] = time.monotonic()
    _DEADLINE[0] = math.inf if not seconds else _START[0] + float(seconds)
    try:
        yield
    finally:
        _DEADLINE[0], _START[0] = old, old_start


def note_cut(stage: str, simulations: int, moved: bool) -> None:
    """Record that the deadline stopped ``stage`` of the fit in progress after
    ``simulations`` simulations; ``moved``: whether it had left its start point (at
    least one accepted step)."""
    for rec in _RECORDERS:
        rec.append({"stage": stage, "simulations": int(simulations), "moved": bool(moved)})


@contextmanager
def recording_cuts():
    """Collect the :func:`note_cut` records of the ``with`` block (a list, filled in
    place)."""
    rec: list[dict] = []
    _RECORDERS.append(rec)
    try:
        yield rec
    finally:
        del _RECORDERS[next(k for k, r in enumerate(_RECORDERS) if r is rec)]
