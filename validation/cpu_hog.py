"""A CPU-bound job beside a benchmark: the condition of the discrepancy engine's time goal
("every case < 3 min at ``--jobs 2`` with another CPU-bound job running")."""

from __future__ import annotations

import multiprocessing as mp
from contextlib import contextmanager

__all__ = ["cpu_hog"]


def _busy_loop() -> None:  # one core, until terminated
    x = 0
    while True:
        x = (x * 1103515245 + 12345) % 2147483648


@contextmanager
def cpu_hog(on: bool = True):
    """A CPU-bound process (a busy loop, one core) running for the ``with`` block;
    nothing when ``on`` is False."""
    if not on:
        yield
        return
    proc = mp.get_context("spawn").Process(target=_busy_loop, daemon=True)
    proc.start()
    try:
        yield
    finally:
        proc.terminate()
        proc.join(10)
