"""Worker processes: they die with their parent, and BLAS stays on one thread where the
parallelism is by processes (:func:`single_threaded_blas`).

:func:`die_with_parent` installs a fork hook: every child forked afterwards (the
``fork``-context process pools of identify, discrepancy and sweep) asks the Linux kernel
to send it SIGKILL when its parent dies (``prctl(PR_SET_PDEATHSIG)``), so a ``kill -9``
of ``ehsa-opt`` leaves no orphaned workers.  Elsewhere a daemon thread in the child
polls ``os.getppid()`` and exits when the parent has gone.
"""

from __future__ import annotations

import ctypes
import json
from contextlib import contextmanager
from dataclasses import dataclass, field
import os
import signal
import sys
import threading
import time

__all__ = ["die_with_parent", "single_threaded_blas", "one_blas_thread", "DeadlineOutcome",
           "run_with_deadline"]

_PR_SET_PDEATHSIG = 1
_installed = False
_forker = 0  # pid of the process that is forking (set just before each fork)


def _watch(parent: int) -> None:
    while True:
        if os.getppid() != parent:
            os._exit(1)
        time.sleep(0.5)


def _in_child(parent: int) -> None:
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):
            threading.Thread(target=_watch, args=(parent,), daemon=True).start()
    else:
        threading.Thread(target=_watch, args=(parent,), daemon=True).start()
    if os.getppid() != parent:  # the parent died before the prctl took effect
        os._exit(1)


def die_with_parent() -> None:
    """Make every process forked from now on die when this process dies (idempotent)."""
    global _installed
    if _installed or not hasattr(os, "register_at_fork"):
        return
    _installed = True

    def before() -> None:
        global _forker
        _forker = os.getpid()

    os.register_at_fork(before=before, after_in_child=lambda: _in_child(_forker))


@contextmanager
def single_threaded_blas():
    """numpy/scipy's BLAS (OpenBLAS) on one thread inside the block
    (``threadpoolctl.threadpool_limits``; forked workers inherit it).

    Our parallelism is by processes (``jobs``) and our matrices are small; a
    multi-threaded OpenBLAS next to busy worker processes spins its threads against
    them: the discrepancy workflow's term discovery (``LassoCV`` on 25 000 samples)
    took 154 s instead of 6 s on EMPS after the candidate pool had run with two jobs.
    """
    from threadpoolctl import threadpool_limits
    with threadpool_limits(limits=1, user_api="blas"):
        yield


def one_blas_thread(fn):
    """Decorator: ``fn`` runs inside :func:`single_threaded_blas` — the library's entry
    points give the numbers the command line gives (whose every command runs so), however
    many BLAS threads the caller's process would use: a multithreaded BLAS sums in another
    order, and an optimiser's iterates then drift apart."""
    import functools

    @functools.wraps(fn)
    def run(*args, **kwargs):
        with single_threaded_blas():
            return fn(*args, **kwargs)
    return run


@dataclass
class DeadlineOutcome:
    """What :func:`run_with_deadline` saw.

    Attributes
    ----------
    finished : bool
        The target returned before the deadline.
    error : tuple of (str, str) or None
        ``(exception class name, message)`` when the target raised.
    messages : list of str
        Every message the target sent, in order.
    seconds : float
        Wall time until the target returned or was killed.
    """

    finished: bool
    error: tuple[str, str] | None = None
    messages: list[str] = field(default_factory=list)
    seconds: float = 0.0


def _deadline_child(conn, target) -> None:
    def send(msg) -> None:
        conn.send_bytes(json.dumps(["log", str(msg)]).encode())

    try:
        target(send)
        conn.send_bytes(json.dumps(["done"]).encode())
    except BaseException as exc:  # reported to the parent, which decides
        conn.send_bytes(json.dumps(["error", type(exc).__name__, str(exc)]).encode())
    finally:
        conn.close()


def run_with_deadline(target, seconds: float, on_message=None) -> DeadlineOutcome:
    """Run ``target(send)`` in a forked child and kill it (and, through
    :func:`die_with_parent`, its own workers) when ``seconds`` have passed.

    ``send(message)`` passes a progress message (text) to the parent, which relays it to
    ``on_message`` at once and keeps it, so that a run cut at the deadline still says how
    far it got.  Messages travel as JSON over a pipe (nothing is unpickled).  The target
    must leave its results in files (the child's memory is lost).

    Parameters
    ----------
    target : callable
        ``target(send) -> None``.
    seconds : float
        Wall-time budget, s.
    on_message : callable, optional
        Called with each message as it arrives (e.g. ``print``).
    """
    import multiprocessing as mp

    die_with_parent()
    ctx = mp.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    t0 = time.monotonic()
    proc = ctx.Process(target=_deadline_child, args=(send, target), daemon=False)
    proc.start()
    send.close()
    out = DeadlineOutcome(finished=False)
    deadline = t0 + seconds
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            proc.kill()
            break
        if not recv.poll(min(left, 0.5)):
            if not proc.is_alive() and not recv.poll(0):
                break
            continue
        try:
            msg = json.loads(recv.recv_bytes())
        except EOFError:
            break
        if msg[0] == "log":
            out.messages.append(msg[1])
            if on_message is not None:
                on_message(msg[1])
        elif msg[0] == "done":
            out.finished = True
            break
        else:
            out.error = (msg[1], msg[2])
            break
    proc.join()
    recv.close()
    out.seconds = time.monotonic() - t0
    if not out.finished and out.error is None and proc.exitcode not in (None, -9) \
            and left > 0:
        out.error = ("ChildProcessError", f"the worker process ended with exit code "
                                          f"{proc.exitcode} before finishing")
    return out
