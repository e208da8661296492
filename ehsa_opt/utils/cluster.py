"""Connecting to a Dask cluster (``--scheduler ADDRESS``) without hanging — for the design
sweeps and optimisations and for the discrepancy search's member fits.

:func:`connect_client` checks the address's scheme, asks the scheduler who it is (Dask's
``identity`` message, one connection, a hard time limit: a server that is not a Dask
scheduler never answers it), waits a bounded time for at least one worker, and only
then opens a ``distributed.Client``; every failure is a :class:`ClusterError` naming
the address and the fix.  :func:`check_cluster_imports` then refuses a cluster that
cannot import ehsa_opt.
"""

from __future__ import annotations

import asyncio
import time
from typing import Any

__all__ = ["ClusterError", "CONNECT_TIMEOUT_S", "WORKER_WAIT_S", "SCHEMES", "connect_client",
           "check_scheduler", "check_cluster_imports"]


class ClusterError(ValueError):
    """A Dask scheduler address that cannot be used; the message names the address and
    the fix."""


#: Seconds for the connection and the scheduler's answer (a scheduler answers in
#: milliseconds on a local network; a few seconds cover a slow link).
CONNECT_TIMEOUT_S = 5.0
#: Seconds to wait for the first worker (workers started with the scheduler register
#: within about a second).
WORKER_WAIT_S = 5.0
#: Address schemes of Dask's comm backends that ehsa-opt supports (an address without a
#: scheme is TCP, as in Dask; ``inproc`` is a cluster inside this process).
SCHEMES = ("tcp", "tls", "ws", "wss", "inproc")
#: Share of the time limit given to Dask's own connection attempts (it retries a refused
#: connection until then): a refused connection is reported as such before the hard limit,
#: which then only catches a server that accepts and never answers.
_CONNECT_SHARE = 0.8
_FIX = "give the address of a running Dask scheduler, e.g. tcp://127.0.0.1:8786"


async def _identity(address: str, timeout: float) -> dict:
    from distributed.comm import connect
    comm = await connect(address, timeout=_CONNECT_SHARE * timeout)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        await comm.close()


def _ask(address: str, timeout: float) -> dict:
    """The scheduler's identity, or ClusterError (address, what went wrong, the fix)."""
    from concurrent.futures import ThreadPoolExecutor
    try:  # in a thread of its own: a caller's running event loop is not disturbed
        with ThreadPoolExecutor(1) as pool:
            answer = pool.submit(asyncio.run, asyncio.wait_for(
                _identity(address, timeout), timeout)).result()
    except (asyncio.TimeoutError, TimeoutError):
        raise ClusterError(f"--scheduler {address}: no Dask scheduler answered within "
                             f"{timeout:g} s (a server that is not a Dask scheduler, or "
                             f"none); {_FIX}") from None
    except Exception as exc:  # noqa: BLE001 - any comm failure is a bad address
        raise ClusterError(f"--scheduler {address}: cannot connect ({type(exc).__name__}: "
                             f"{exc}); {_FIX}") from None
    if not isinstance(answer, dict) or answer.get("type") != "Scheduler":
        raise ClusterError(f"--scheduler {address}: the server there is not a Dask "
                             f"scheduler; {_FIX}")
    return answer


def connect_client(address: str) -> Any:
    """A ``distributed.Client`` of the scheduler at ``address`` with at least one worker
    (:func:`check_scheduler` first).

    Raises
    ------
    ClusterError
        Unsupported scheme; no Dask scheduler answering within :data:`CONNECT_TIMEOUT_S`;
        no worker within :data:`WORKER_WAIT_S`.
    """
    address = check_scheduler(address)
    from distributed import Client
    try:
        return Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ClusterError(f"--scheduler {address}: cannot connect ({exc}); {_FIX}") from None


def check_scheduler(address: str) -> str:
    """Check that a Dask scheduler with at least one worker answers at ``address``
    (a supported scheme, its identity within :data:`CONNECT_TIMEOUT_S`, a worker within
    :data:`WORKER_WAIT_S`) without opening a client; returns the address.

    Raises
    ------
    ClusterError
        Naming the address, what went wrong and the fix.
    """
    address = str(address)
    scheme = address.split("://", 1)[0].lower() if "://" in address else "tcp"
    if scheme not in SCHEMES:
        raise ClusterError(f"--scheduler {address}: the scheme '{scheme}://' is not "
                             f"supported (use {', '.join(s + '://' for s in SCHEMES)}); "
                             f"{_FIX}")
    deadline = time.monotonic() + WORKER_WAIT_S
    while not _ask(address, CONNECT_TIMEOUT_S).get("workers"):
        if time.monotonic() >= deadline:
            raise ClusterError(f"--scheduler {address}: the scheduler has no worker "
                                 f"(waited {WORKER_WAIT_S:g} s); start workers with "
                                 f"'dask worker {address}' or drop --scheduler to run "
                                 f"locally")
        time.sleep(0.25)
    return address


def check_cluster_imports(client: Any, where: Any) -> None:
    """Refuse a cluster whose scheduler or workers cannot import ehsa_opt (the tasks are
    pickled by reference; Dask's scheduler unpickles the graph)."""
    import importlib.util

    def found(spec: Any) -> bool:
        return spec is not None
    try:
        on_sched = found(client.run_on_scheduler(importlib.util.find_spec, "ehsa_opt"))
        on_workers = {w: found(s) for w, s in client.run(importlib.util.find_spec,
                                                         "ehsa_opt").items()}
    except Exception as exc:  # pragma: no cover - cluster-specific failures
        raise ClusterError(f"--scheduler {where}: cannot query the cluster ({exc})") from None
    missing = ([] if on_sched else ["scheduler"]) + [w for w, ok in on_workers.items() if not ok]
    if missing:
        raise ClusterError(
            f"--scheduler {where}: ehsa_opt is not importable on {', '.join(missing)}; install "
            f"it there (pip install .) or start the scheduler and workers with "
            f"PYTHONPATH=<repository root>")
