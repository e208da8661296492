"""Where the member fits of a discrepancy run are made: forked local processes
(``DiscrepancySettings.jobs``) or a Dask cluster (``DiscrepancySettings.scheduler``, the
engine the design sweeps use).

:func:`cluster_set` opens the run's client (an address is checked and connected by
:func:`~ehsa_opt.utils.cluster.connect_client`; a ``distributed.Client`` is used as
given) for the ``with`` block; :func:`remote` returns it (None: local).  On a cluster the
fits of one request are mapped in the order asked and gathered in that order
(:func:`fit_on_cluster`); each runs with single-threaded BLAS, as the local workers do,
so a fit gives the same numbers wherever it runs and the answer is the local run's.
What the search asks for, and what it is charged, is decided before the executor is
called (:mod:`.budget`).
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Callable, Sequence

__all__ = ["cluster_set", "remote", "fit_on_cluster"]

_CLIENT: list[Any] = [None]


def remote() -> Any:
    """The run's Dask client, or None for local processes."""
    return _CLIENT[0]


@contextmanager
def cluster_set(scheduler: Any):
    """The run's Dask client for the ``with`` block: None (local processes), a scheduler
    address (connected, checked and closed here) or a ``distributed.Client`` (used as
    given, left open)."""
    if scheduler is None:
        yield None
        return
    from ...utils.cluster import check_cluster_imports, connect_client
    own = isinstance(scheduler, str)
    client = connect_client(scheduler) if own else scheduler
    old = _CLIENT[0]
    _CLIENT[0] = client
    try:
        if own:
            check_cluster_imports(client, scheduler)
        yield client
    finally:
        _CLIENT[0] = old
        if own:
            client.close()


def _one_thread(fn: Callable[[tuple], Any], args: tuple) -> Any:
    from ...utils.process import single_threaded_blas
    with single_threaded_blas():
        return fn(args)


def fit_on_cluster(fn: Callable[[tuple], Any], args: Sequence[tuple]) -> list:
    """``fn`` of every argument tuple on the run's cluster, results in the order of
    ``args`` (each task with single-threaded BLAS; ``pure=False``: every request runs)."""
    client = remote()
    futures = [client.submit(_one_thread, fn, a, pure=False) for a in args]
    return client.gather(futures)
