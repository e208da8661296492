"""Member fits made ahead on the workers a round's own fits leave idle.

A round re-identifies its chosen members side by side (:func:`~.candidate_fit.fit_members`,
as workers free up); the slowest of them decides when the round goes on, and the other
workers wait.  On a mixed campaign a mount spring's fit took 70–89 s beside a winding
heating's 8 s and a saturation's 5 s: one of the two workers idled for more than a
minute, and the round's next step (the members it widens to, 2.5 s each) then found
fewer seconds left before the deadline than its estimate and was cut.

:func:`fit_with_spares` fits the chosen members as before and, only on a worker none of
them needs any more (every chosen fit started, one still running), the ``spare``
members the round may ask for next: the simpler members nested in a chosen one
(:func:`~.nested.nested_to_fit`, needed when it earns) and the lower-ranked ones a
widened round re-identifies (:func:`~.widen.widen_round`).  A spare still running
when the chosen fits are done is stopped (its process terminated): spares use idle
time only and never delay the round.  Their fits are kept, not judged — the round
reuses one when its rules ask for that member on the same model, exactly as if it had
fitted it then (:func:`~.lookahead.member_key`, :func:`~.search.judge_round`).
"""

from __future__ import annotations

import multiprocessing as mp
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Callable, Sequence

from .candidate_fit import fit_member, fit_members
from .budget import past_deadline, time_left_s
from .executor import remote

__all__ = ["fit_with_spares", "POLL_S"]

#: How often the chosen fits' wait looks at the spare processes, s.
POLL_S = 0.2


def _spare_child(conn, a: tuple) -> None:  # pragma: no cover - runs in a forked process
    try:
        conn.send(fit_member(a))
    except Exception:  # a failed spare is no fit: the round fits the member if it asks
        conn.send(None)
    finally:
        conn.close()


def fit_with_spares(args: list[tuple], spare: Sequence[tuple], jobs: int, *,
                    until_deadline: bool = False, seconds: dict | None = None,
                    estimate: Callable[[str], float] | None = None
                    ) -> tuple[list[tuple], list[tuple]]:
    """The fits of ``args`` (:func:`~.candidate_fit.fit_members`, the same scheduling and
    deadline rules) and of those ``spare`` argument tuples that finished on a worker the
    fits of ``args`` left idle before they were all done.

    Spares start in order, only once every fit of ``args`` has started and while one of
    them is still running, only with ``jobs`` > 1 and, with ``until_deadline``, only
    before the deadline and when their estimate (``estimate(name)``, s) fits in the time
    left.  Returns (the results of ``args`` started, a prefix in their order; the
    spare results that finished, in ``spare`` order).  ``seconds`` receives the wall
    time of every fit that finished, s, by name."""
    spare = list(spare)
    if jobs <= 1 or not spare or not args or remote() is not None:
        return fit_members(args, jobs, until_deadline=until_deadline, seconds=seconds,
                           estimate=estimate), []
    ctx = mp.get_context("fork")
    t0: dict[int, float] = {}
    out: dict[int, tuple] = {}
    extra: dict[int, tuple] = {}
    pending, sp_pending = list(range(len(args))), list(range(len(spare)))
    procs: dict[int, tuple] = {}  # spare index -> (process, connection, start time)

    def fits_in_time(name: str) -> bool:
        if not until_deadline:
            return True
        need = estimate(name) if estimate is not None else 0.0
        return not past_deadline() and need <= time_left_s()

    def collect(j: int, block: bool) -> None:
        proc, conn, start = procs[j]
        if block or conn.poll():
            try:
                res = conn.recv()
            except EOFError:  # the process ended without a result
                res = None
            if res is not None:
                extra[j] = res
                if seconds is not None:
                    seconds[spare[j][0]] = time.perf_counter() - start
            proc.join()
            del procs[j]

    with ProcessPoolExecutor(max_workers=min(jobs, len(args)), mp_context=ctx) as ex:
        running: dict = {}
        while pending or running:
            while pending and len(running) + len(procs) < jobs \
                    and fits_in_time(args[pending[0]][0]):
                k = pending.pop(0)
                t0[k] = time.perf_counter()
                running[ex.submit(fit_member, args[k])] = k
            while (not pending and running and sp_pending
                   and len(running) + len(procs) < jobs
                   and fits_in_time(spare[sp_pending[0]][0])):
                j = sp_pending.pop(0)
                recv, send = ctx.Pipe(duplex=False)
                proc = ctx.Process(target=_spare_child, args=(send, spare[j]), daemon=True)
                proc.start()
                send.close()
                procs[j] = (proc, recv, time.perf_counter())
            if not running:  # spares start only beside a running fit of ``args``
                break
            finished, _ = wait(list(running), timeout=POLL_S, return_when=FIRST_COMPLETED)
            for f in finished:
                k = running.pop(f)
                out[k] = f.result()
                if seconds is not None:
                    seconds[args[k][0]] = time.perf_counter() - t0[k]
            for j in list(procs):
                collect(j, block=False)
    for j in list(procs):  # the round's own fits are done: idle time is over
        proc, conn, _ = procs[j]
        if conn.poll():
            collect(j, block=True)
            continue
        proc.terminate()
        proc.join()
        conn.close()
        del procs[j]
    return [out[k] for k in sorted(out)], [extra[j] for j in sorted(extra)]
