"""The run's budget: work counted in member fits, and a wall-time safety cap.

A discrepancy answer must not depend on the machine's load, so the budget that decides
where a search stops is counted in *work*: the member fits the search asks for
(:func:`charge_fits`), charged in the order the search asks for them — a round's
members in rank order, then its nested, widened and look-ahead fits — whatever the
number of worker processes, whichever of them finished first, and whether a fit was
made ahead on an idle worker or when asked (a fit found made ahead is charged as one
made then).  Each member fit's own work is bounded by its settings (starts, iterations,
simulations), so the same data and settings give the same answer and the same numbers
under any ``jobs`` and any load.

The wall time is a *safety cap* only (``DiscrepancySettings.wall_cap_s``): when it
binds, the screening of starts, the refinements on the simulation and the impact-aware
search stop at the best point reached, no further fit starts, and the answer says that
it depends on the machine's speed and load (:func:`cut_reason`).  The cap is a
monotonic-clock instant, the same in forked pool workers, which inherit it; the work
counter lives in the process that runs the search.

Where the cap stopped a stage of a fit is recorded (:func:`note_cut`, collected by
:func:`recording_cuts` around one member fit): a member whose fit was cut before its
effect's parameters left their start is *not fitted* (:func:`~.candidate_fit.not_fitted`)
and takes no decision of the search.
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager

__all__ = ["budget_set", "past_deadline", "elapsed_s", "time_left_s", "note_cut",
           "recording_cuts", "charge_fits", "work_spent", "budget_reached", "cut_reason",
           "fits_charged", "MAX_MEMBER_FITS"]

#: The default work budget of a run, in member fits.  A round re-identifies its ``top``
#: (3) members and, widened, every other applicable one (up to 9 in all); its look-ahead
#: tries up to 4 paths each way (8 fits); three rounds of the widest search then take 51
#: fits.  60 covers that with the nested members' fits; set before the benchmark runs
#: that report the fits each case used.
MAX_MEMBER_FITS = 60

_DEADLINE = [math.inf]
_START = [time.monotonic()]
#: [member fits the run may still start (inf: no work budget), the budget, fits charged]
_WORK = [math.inf, math.inf, 0]
_CAP = [None]
#: the cut records of the member fits in progress (one list per :func:`recording_cuts`)
_RECORDERS: list[list[dict]] = []


def past_deadline() -> bool:
    """True once the wall-time safety cap of the run in progress has passed."""
    return time.monotonic() > _DEADLINE[0]


def elapsed_s() -> float:
    """Seconds since the run's budget was set (:func:`budget_set`)."""
    return time.monotonic() - _START[0]


def time_left_s() -> float:
    """Seconds left before the safety cap (inf without one; negative once past it)."""
    return _DEADLINE[0] - time.monotonic()


def charge_fits(n: int) -> int:
    """Charge up to ``n`` member fits to the work budget; returns how many of them may
    start (the first ones, in the order asked for)."""
    allowed = int(min(max(n, 0), _WORK[0]))
    _WORK[0] -= allowed
    _WORK[2] += allowed
    return allowed


def fits_charged() -> int:
    """Member fits charged so far in the run in progress."""
    return int(_WORK[2])


def work_spent() -> bool:
    """True once the work budget (member fits) is used up."""
    return _WORK[0] <= 0


def budget_reached() -> bool:
    """True once the work budget is used up or the safety cap has passed: the search
    starts no further member fit."""
    return work_spent() or past_deadline()


def cut_reason() -> str:
    """Why the search stopped starting fits ("" while it may go on): the work budget
    (deterministic) or the wall-time safety cap (load-dependent, said so)."""
    if past_deadline():
        return (f"wall-time safety cap of {_CAP[0]:g} s reached (this partial answer depends "
                f"on the machine's speed and load; raise the cap, or set a work budget)")
    if work_spent():
        return f"work budget of {_WORK[1]:g} member fits spent"
    return ""


@contextmanager
def budget_set(max_member_fits: int | None, wall_cap_s: float | None = None):
    """Set the run's work budget (``max_member_fits``; None: none) and its wall-time
    safety cap (``wall_cap_s`` from now; None: none) for the ``with`` block."""
    old = (_DEADLINE[0], _START[0], list(_WORK), _CAP[0])
    _START[0] = time.monotonic()
    _DEADLINE[0] = math.inf if not wall_cap_s else _START[0] + float(wall_cap_s)
    budget = math.inf if max_member_fits is None else int(max_member_fits)
    _WORK[:] = [budget, budget, 0]
    _CAP[0] = wall_cap_s
    try:
        yield
    finally:
        _DEADLINE[0], _START[0], _WORK[:], _CAP[0] = old[0], old[1], old[2], old[3]


def note_cut(stage: str, simulations: int, moved: bool) -> None:
    """Record that the safety cap stopped ``stage`` of the fit in progress after
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
