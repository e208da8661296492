"""The workflow's wall-time deadline, seen by the long loops inside a candidate fit.

:func:`~.workflow.run_discrepancy` sets it from ``DiscrepancySettings.budget_s``; the
screening of starts (:func:`~.refit._screen`) and the Gauss–Newton refinements on the
simulation (:func:`~.polish.polish`) stop at it and keep the best point reached, so a
single candidate fit cannot carry a run far past its budget.  The deadline is a
monotonic-clock instant (the same in forked pool workers, which inherit it).
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager

__all__ = ["deadline_set", "past_deadline"]

_DEADLINE = [math.inf]


def past_deadline() -> bool:
    """True once the deadline of the run in progress has passed."""
    return time.monotonic() > _DEADLINE[0]


@contextmanager
def deadline_set(seconds: float | None):
    """Set the deadline ``seconds`` from now (None: none) for the ``with`` block."""
    old = _DEADLINE[0]
    _DEADLINE[0] = math.inf if not seconds else time.monotonic() + float(seconds)
    try:
        yield
    finally:
        _DEADLINE[0] = old
