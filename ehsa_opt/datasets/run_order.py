"""The order a campaign's tests were run in: the optional ``run_order`` and ``started_at``
keys of a ``[[test]]`` entry of ``bench.toml``, checked across the campaign.

A friction that drifts over a campaign (the grease warming, a run-in) can only be told
apart from a friction that depends on the stroke, the speed or the load when the tests'
order in time is known; the list order of ``bench.toml`` is not that order (campaigns
are usually listed sorted by kind, speed and load).

``run_order``
    A whole number >= 1: the test's place in the campaign (1 = run first).  Given to
    every test or to none; no two tests share a place (gaps are allowed: a test that
    was run but not kept).
``started_at``
    A TOML date-time (``2026-03-02T09:00:00Z``, or a local date-time without the
    offset): when the test's first sample was taken.  Given to every test or to none,
    all with an offset or all without; no two tests start at the same instant.  With
    ``run_order`` as well, the time stamps increase with the run order.

Either key alone gives the order; ``started_at`` also gives the time between tests.
"""

from __future__ import annotations

import datetime as _dt
from typing import Any, Callable, Sequence

__all__ = ["RUN_KEYS", "parse_run_keys", "check_run_sequence", "run_sequence",
           "start_offsets_s"]

#: The optional keys of a ``[[test]]`` entry that place it in time.
RUN_KEYS = ("run_order", "started_at")


def parse_run_keys(entry: dict[str, Any], where: str,
                   error: Callable[[str], Exception]) -> tuple[int | None, _dt.datetime | None]:
    """``(run_order, started_at)`` of one ``[[test]]`` entry (None when absent).

    ``where`` names the entry in messages; ``error`` builds the exception raised
    (the loader's :class:`~ehsa_opt.datasets.bench_format.BenchDataError`)."""
    order = entry.get("run_order")
    if order is not None and (isinstance(order, bool) or not isinstance(order, int)
                              or order < 1):
        raise error(f"{where}: 'run_order' = {order!r} must be a whole number >= 1 (1 = the "
                    f"test run first); fix it in bench.toml")
    started = entry.get("started_at")
    if started is not None and not isinstance(started, _dt.datetime):
        hint = (" (write it without quotes: started_at = 2026-03-02T09:15:30Z)"
                if isinstance(started, str) else
                " (a date and a time of day: 2026-03-02T09:15:30Z)")
        raise error(f"{where}: 'started_at' = {started!r} must be a TOML date-time{hint}")
    return order, started


def _name(test: Any) -> str:
    return f"bench.toml [[test]] ({test.file})"


def check_run_sequence(tests: Sequence[Any], error: Callable[[str], Exception]) -> None:
    """Refuse a run order or time stamps that do not describe one campaign in time.

    ``tests`` have ``file``, ``run_order`` and ``started_at``; every message names
    ``bench.toml``, the test's file and the key."""
    for key in RUN_KEYS:
        given = [t for t in tests if getattr(t, key) is not None]
        if given and len(given) < len(tests):
            missing = next(t for t in tests if getattr(t, key) is None)
            raise error(f"{_name(missing)}: no '{key}' while {len(given)} other test(s) have "
                        f"one (e.g. {given[0].file}); give every test its '{key}' or none")
    if tests and tests[0].run_order is not None:
        seen: dict[int, str] = {}
        for t in tests:
            if t.run_order in seen:
                raise error(f"{_name(t)}: 'run_order' = {t.run_order} is also that of "
                            f"{seen[t.run_order]}; each test has its own place in the run "
                            f"order")
            seen[t.run_order] = t.file
    if not tests or tests[0].started_at is None:
        return
    aware = {t.started_at.tzinfo is not None for t in tests}
    if len(aware) > 1:
        t = next(t for t in tests if (t.started_at.tzinfo is not None)
                 != (tests[0].started_at.tzinfo is not None))
        raise error(f"{_name(t)}: 'started_at' = {t.started_at.isoformat()} mixes a time "
                    f"stamp {'with' if t.started_at.tzinfo else 'without'} an offset with "
                    f"{tests[0].file}'s; write all with an offset (…Z) or all without")
    key = (lambda t: (t.run_order,)) if tests[0].run_order is not None else \
        (lambda t: (t.started_at,))
    ranked = sorted(tests, key=key)
    for a, b in zip(ranked[:-1], ranked[1:]):
        if b.started_at <= a.started_at:
            why = (f"run_order {b.run_order} comes after {a.run_order}: the time stamps must "
                   f"increase with the run order" if a.run_order is not None else
                   "two tests cannot start at the same instant")
            raise error(f"{_name(b)}: 'started_at' = {b.started_at.isoformat()} is not after "
                        f"{a.file}'s {a.started_at.isoformat()} ({why}); fix the time stamps "
                        f"or the run order")


def run_sequence(tests: Sequence[Any]) -> list[int] | None:
    """Indices of ``tests`` in the order they were run (by ``run_order``, else by
    ``started_at``), or None when the campaign states neither."""
    if not tests:
        return None
    if tests[0].run_order is not None:
        return sorted(range(len(tests)), key=lambda k: tests[k].run_order)
    if tests[0].started_at is not None:
        return sorted(range(len(tests)), key=lambda k: tests[k].started_at)
    return None


def start_offsets_s(tests: Sequence[Any]) -> list[float] | None:
    """Each test's start, s after the campaign's first test started (list order), or
    None without ``started_at``."""
    if not tests or tests[0].started_at is None:
        return None
    first = min(t.started_at for t in tests)
    return [(t.started_at - first).total_seconds() for t in tests]
