"""A lone member fit's simulations spread over the run's idle workers.

A round that re-identifies one member (a rattling contact judged on its impacts: 98
simulations of the eight fit tests, the only fit of its round) runs it in the calling
process while the run's other ``jobs − 1`` workers have nothing to do.  Every simulation
of such a fit is a set of independent per-test simulations (:func:`~.rig.predict`,
:func:`~.rig.predict_map`, :func:`~.rig.predict_map_jacobian`), so
:func:`spread_simulations` opens, for the fit's duration, ``jobs`` forked processes that
simulate the tests of each call side by side; the caller gets the outputs in the order
of its tests.

The numbers do not change: each test is simulated by the same code on the same inputs
(the forked workers hold the same models and tests), whichever process runs it, and the
caller takes the outputs from the raw arrays by the same views as without spreading
(:func:`~.rig.simulated`: a copy in another memory layout would be summed in another
order downstream, and a fit's numbers would move in their last digits) — tests check
the outputs and a run's answer bit for bit.  Only the wall time does: on an idle machine the fit
takes about half as long; beside another CPU-bound process its share of the two cores
is two processes' instead of one.  Calls on tests the workers do not hold (tests made
after the fork) and nested calls inside a worker are simulated in the calling process,
as without spreading.
"""

from __future__ import annotations

import multiprocessing as mp
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from typing import Any, Callable, Sequence

import numpy as np

__all__ = ["spread_simulations", "spread", "MIN_TESTS"]

#: A call spreads only when it simulates at least this many tests: below it the
#: hand-over to the workers costs more than it saves.
MIN_TESTS = 2

#: (the pool, the tests it holds by identity -> index) while a fit spreads; None else
_POOL: list[Any] = [None]
#: the tests of the spreading fit, inherited by the forked workers (by index)
_TESTS: list[Any] = []


def _in_worker(fn: Callable, kind: str, i: int, rig: Any, values: Any, opts: dict) -> Any:
    """``fn(kind, test, rig, values, **opts)`` in a worker (the test by its index), its
    arrays packed to travel in their memory layout (:func:`_pack`)."""
    out = fn(kind, _TESTS[i], rig, values, **opts)
    return tuple(map(_pack, out)) if isinstance(out, tuple) else _pack(out)


def _pack(a: Any) -> Any:
    """An array as (its axes permuted to a C-contiguous block, the permutation back):
    pickling copies any other layout into C order, and a sum over the copy would add in
    another order than over the original.  Anything else as it is."""
    if not isinstance(a, np.ndarray) or a.ndim < 2:
        return a
    perm = sorted(range(a.ndim), key=lambda k: -a.strides[k])
    t = a.transpose(perm)
    if not t.flags.c_contiguous:
        return a
    return _Packed(t, tuple(int(k) for k in np.argsort(perm)))


class _Packed:
    """An array travelling as a C-contiguous block and the axis order it is seen in."""

    def __init__(self, block: np.ndarray, back: tuple[int, ...]) -> None:
        self.block, self.back = block, back

    def unpack(self) -> np.ndarray:
        return self.block.transpose(self.back)


def _unpack(out: Any) -> Any:
    if isinstance(out, tuple):
        return tuple(_unpack(a) for a in out)
    return out.unpack() if isinstance(out, _Packed) else out


@contextmanager
def spread_simulations(jobs: int, tests: Sequence[Any]):
    """For the ``with`` block, the simulations of ``tests`` (a fit's fit-test subset, fit
    and held-out tests) run in ``jobs`` forked workers (:func:`spread`); nothing when
    ``jobs`` < 2 or when a block is already open (one level).  The workers inherit the
    run's single-threaded BLAS from the calling process."""
    if jobs < 2 or _POOL[0] is not None:
        yield
        return
    unique: dict[int, int] = {}
    held: list[Any] = []
    for pt in tests:
        if id(pt) not in unique:
            unique[id(pt)] = len(held)
            held.append(pt)
    _TESTS[:] = held
    ex = ProcessPoolExecutor(max_workers=jobs, mp_context=mp.get_context("fork"),
                             initializer=_worker_start)
    _POOL[0] = (ex, unique)
    try:
        yield
    finally:
        _POOL[0] = None
        ex.shutdown(wait=True, cancel_futures=True)
        _TESTS.clear()


def _worker_start() -> None:
    """A worker never spreads its own calls (its copy of the pool is not its own)."""
    _POOL[0] = None


def spread(fn: Callable, kind: str, prepared: Sequence[Any], rig: Any, values: Any,
           **opts: Any) -> list | None:
    """The per-test simulations ``fn(kind, test, rig, values, **opts)`` (a module-level
    function, :func:`~.rig.simulate_raw`) of the tests ``prepared`` on the open pool, in
    the order of ``prepared``; None when no pool is open, the call
    has fewer than :data:`MIN_TESTS` tests or a test is not one the workers hold (the
    caller then simulates them itself, one after the other)."""
    got = _POOL[0]
    if got is None or len(prepared) < MIN_TESTS:
        return None
    ex, unique = got
    idx = [unique.get(id(pt)) for pt in prepared]
    if any(i is None for i in idx):
        return None
    futures = [ex.submit(_in_worker, fn, kind, i, rig, values, opts) for i in idx]
    return [_unpack(f.result()) for f in futures]
