"""The command line's argument types and up-front checks (used by ``ehsa_opt.cli``):
integers with bounds, output folders usable before any work, ``--jobs`` capped at the
usable cores, and the message of an ``OSError`` (file, what went wrong, the fix)."""

from __future__ import annotations

import argparse
import errno
import os
import sys
from pathlib import Path
from typing import Callable

__all__ = ["UsageError", "count", "bounded", "POSITIVE", "NON_NEGATIVE", "check_output_dir", "non_negative_float",
           "check_outputs", "cap_jobs", "os_error_message"]


class UsageError(Exception):
    """A CLI-level input error (printed without a traceback)."""


def count(minimum: int) -> Callable[[str], int]:
    """argparse type: an integer >= ``minimum`` (0 or a negative is refused, never replaced)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not an integer") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{value} must be >= {minimum}")
        return value
    return parse


POSITIVE, NON_NEGATIVE = count(1), count(0)


def non_negative_float(text: str) -> float:
    """argparse type: a finite number >= 0 (e.g. a time budget in s)."""
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0.0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"'{text}' must be a finite number >= 0")
    return value


def check_output_dir(path: str, option: str) -> None:
    """Refuse an output folder that cannot be used, before any work is done."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise UsageError(f"{option} {p}: exists and is not a directory; give a folder "
                          f"(a new one is created)")
    probe = p
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise UsageError(f"{option} {p}: {probe} is a file, so the folder cannot be created; "
                          f"choose another path")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise UsageError(f"{option} {p}: {probe} is not writable; choose a folder you can "
                          f"write to or fix its permissions")


def check_outputs(args: argparse.Namespace) -> None:
    """``--out`` and ``--checkpoint`` are checked before any computation starts."""
    for attr, option in (("out", "--out"), ("checkpoint", "--checkpoint")):
        value = getattr(args, attr, None)
        if isinstance(value, str) and value:
            check_output_dir(value, option)


def bounded(minimum: int, maximum: int, what: str) -> Callable[[str], int]:
    """argparse type: an integer in [minimum, maximum]."""
    base = count(minimum)

    def parse(text: str) -> int:
        value = base(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(f"{value} must be <= {maximum} ({what})")
        return value
    return parse


def cap_jobs(args: argparse.Namespace) -> None:
    """``--jobs`` beyond the usable cores only slows the run down: capped, with a note."""
    from .limits import usable_cores
    jobs = getattr(args, "jobs", None)
    if isinstance(jobs, int) and jobs > usable_cores():
        print(f"note: --jobs {jobs} capped to {usable_cores()} (the usable CPU cores)",
              file=sys.stderr)
        args.jobs = usable_cores()


def os_error_message(exc: OSError) -> str:
    """What went wrong with which file, and the fix."""
    name = exc.filename or "(file)"
    if exc.filename2:
        name = f"{name} -> {exc.filename2}"
    code = exc.errno
    if code in (errno.ENOSPC, getattr(errno, "EDQUOT", -1)):
        fix = ("no space left on the device; free some space or choose --out on another disk, "
               "then run the same command again (finished steps and checkpoints are kept)")
    elif code in (errno.EACCES, errno.EPERM, errno.EROFS):
        fix = (f"{exc.strerror or 'permission denied'}; choose a folder you can write to "
               f"(--out) or fix its permissions")
    elif code == errno.EFBIG:
        fix = ("file too large: the size limit of a file was reached (`ulimit -f`, or the file "
               "system's); raise the limit or choose --out on another file system, then run "
               "the same command again")
    elif code == errno.ENOENT:
        fix = "not found; check the path"
    elif code in (errno.EISDIR, errno.ENOTDIR):
        fix = f"{exc.strerror}; a file and a folder have the same name — check the path"
    else:
        fix = f"{exc.strerror or exc}; check the path, its permissions and free space"
    return f"{name}: {fix}"
