"""A pipeline step that runs beside the others, in a forked process.

A step that no other step reads (the model-discrepancy workflow: its inputs are the
data alone) need not hold up the rest of ``reproduce``: it is forked at the start of
the run and its output is collected, cached and put at its place in the report at
the end.  The child inherits the parent's memory (nothing is pickled on the way in);
only its :class:`~.base.StepOutput` — Markdown, figure paths, JSON-able results —
comes back through a pipe, between two processes of the same run (no file).  The
child dies with the parent (:func:`~ehsa_opt.utils.process.die_with_parent`); an
error in the child is raised in the parent with the child's traceback.
"""

from __future__ import annotations

import dataclasses
import multiprocessing as mp
import time
import traceback
from typing import Any

from ..utils.process import die_with_parent
from .base import Context, Step, StepOutput

__all__ = ["BackgroundStep", "runs_in_background", "shared_jobs"]


def runs_in_background(step: Step, steps: list[Step], ctx: Context) -> bool:
    """True when ``step`` is marked ``background``, needs no earlier result, no other
    step reads its results, and the run has at least two jobs."""
    return (step.background and not step.depends and ctx.jobs >= 2
            and not any(step.key in s.depends for s in steps))


def shared_jobs(jobs: int, beside: int) -> tuple[int, int]:
    """(jobs of each step running beside the others, jobs of the main process) when
    ``beside`` steps run beside it on ``jobs``: an equal share each, at least one, the
    main process what they leave — no more busy processes than jobs (a member fit made
    ahead on a spare worker would take a core from a step that has work now)."""
    if beside <= 0:
        return jobs, jobs
    each = max(1, jobs // (beside + 1))
    return each, max(1, jobs - beside * each)


def _child(step: Step, ctx: Context, conn: Any) -> None:
    t0 = time.perf_counter()
    try:
        out = step.run(ctx)
        conn.send(("ok", out.markdown, out.figures, out.results, time.perf_counter() - t0))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which raises
        conn.send(("error", f"{type(exc).__name__}: {exc}", traceback.format_exc()))
    finally:
        conn.close()


class BackgroundStep:
    """``step`` running in a forked child from construction on; :meth:`result` waits."""

    def __init__(self, step: Step, ctx: Context) -> None:
        die_with_parent()
        self.step = step
        fork = mp.get_context("fork")
        self._recv, send = fork.Pipe(duplex=False)
        # the child sees the settings, not the parent's later results
        child_ctx = dataclasses.replace(ctx, results={})
        self._proc = fork.Process(target=_child, args=(step, child_ctx, send),
                                  name=f"ehsa-opt step {step.key}")
        self._proc.start()
        send.close()

    def result(self) -> tuple[StepOutput, float]:
        """(output, compute seconds) of the step; raises RuntimeError if it failed."""
        try:
            msg = self._recv.recv()
        except EOFError:
            self._proc.join()
            raise RuntimeError(f"step '{self.step.key}' ended without a result (exit code "
                               f"{self._proc.exitcode}; killed, or out of memory?)") from None
        self._proc.join()
        if msg[0] != "ok":
            raise RuntimeError(f"step '{self.step.key}' failed: {msg[1]}\n{msg[2]}")
        _, markdown, figures, results, seconds = msg
        return StepOutput(markdown, figures, results), seconds

    def cancel(self) -> None:
        """Stop the child (an interrupted run)."""
        if self._proc.is_alive():
            self._proc.kill()
        self._proc.join()
