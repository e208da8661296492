"""One run per output folder: an advisory ``fcntl.flock`` on ``OUT/.ehsa_opt.lock``.

The kernel drops the lock when the process dies (even by ``kill -9``), so a stale lock
file never blocks the next run; a second run into a folder that is in use is refused
with the pid of the holder.  Re-entrant within one process (the CLI takes the lock and
``reproduce`` may take it again).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Iterator

__all__ = ["OutputLockedError", "output_lock", "LOCK_NAME"]

LOCK_NAME = ".ehsa_opt.lock"
_held: dict[Path, int] = {}


class OutputLockedError(ValueError):
    """Another process is writing into the same output folder."""


@contextlib.contextmanager
def output_lock(out_dir: str | Path) -> Iterator[Path]:
    """Hold the lock of ``out_dir`` (created if needed) for the ``with`` block.

    Raises
    ------
    OutputLockedError
        When another process holds it.
    """
    out = Path(out_dir)
    created = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    key = out.resolve()
    if key in _held:
        _held[key] += 1
        try:
            yield out
        finally:
            _held[key] -= 1
        return
    import fcntl
    path = out / LOCK_NAME
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "?"
            raise OutputLockedError(
                f"{out}: another ehsa-opt run (pid {holder}) is writing into this folder "
                f"({path} is locked); wait for it to finish or choose another --out") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        _held[key] = 1
        try:
            yield out
        finally:
            del _held[key]
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)
        # a run refused before writing anything leaves no folder behind
        if created and [f.name for f in out.iterdir()] == [LOCK_NAME]:
            path.unlink(missing_ok=True)
            with contextlib.suppress(OSError):
                out.rmdir()
