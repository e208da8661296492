"""Atomic file writes (temporary file in the same folder, then rename): a reader never
sees a half-written result, and an interrupted write leaves the old file intact.

Inside an output folder a command claimed (:mod:`ehsa_opt.utils.output_folder`) the target
is first listed in the folder's manifest, or refused when it is a file ehsa-opt did not
write.  The temporary file is ``.NAME.ehsa_opt-XXXXXXXX.tmp``, a name only ehsa-opt makes.

Files get the user's umask (``tempfile.mkstemp`` creates them 0600; they are chmod-ed to
``0o666 & ~umask`` like any file ``open()`` creates).  :func:`atomic_write_json` writes
standard JSON: non-finite floats become ``null`` (never a bare ``NaN``).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, Callable

from .output_folder import TEMP_SUFFIX, admit, temp_prefix

__all__ = ["display_path", "relative_path", "atomic_write_text", "atomic_write_bytes", "atomic_write_json", "atomic_write_with",
           "json_safe", "current_umask"]


def current_umask() -> int:
    """The process umask, read without changing it where the OS allows."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


def atomic_write_with(path: str | Path, write: Callable[[str], None]) -> Path:
    """Write ``path`` atomically by ``write(temporary_path)`` (e.g. a figure's ``savefig``),
    then fsync and rename; the temporary file is removed on any failure."""
    path = Path(path)
    admit(path)  # inside an output folder: listed in its manifest before anything is made
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=temp_prefix(path), suffix=TEMP_SUFFIX, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~current_umask())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _write(path: str | Path, data: bytes) -> None:
    def put(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            fh.write(data)
    atomic_write_with(path, put)


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` via a temporary file, fsync and rename."""
    _write(path, text.encode("utf-8"))


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file, fsync and rename."""
    _write(path, bytes(data))


def json_safe(obj: Any) -> Any:
    """A copy of ``obj`` for standard JSON: non-finite floats → None, tuples → lists,
    numpy scalars/arrays → Python numbers/lists."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, (str, int, bool)) or obj is None:
        return obj
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if hasattr(obj, "tolist"):  # numpy arrays and scalars
        return json_safe(obj.tolist())
    try:
        return json_safe(float(obj))
    except (TypeError, ValueError):
        return str(obj)


def atomic_write_json(path: str | Path, obj: Any, indent: int | None = 1) -> None:
    """Write ``obj`` as standard JSON (no NaN/Infinity: they become ``null``)."""
    atomic_write_text(path, json.dumps(json_safe(obj), indent=indent, allow_nan=False))


def display_path(path: str | Path) -> str:
    """A recorded path that does not depend on the machine: a file of the installed
    package as ``ehsa_opt/<path in the package>`` (the same on every installation), any
    other path as given."""
    pkg = Path(__file__).resolve().parents[1]
    try:
        return (Path(pkg.name) / Path(path).resolve().relative_to(pkg)).as_posix()
    except (ValueError, OSError):
        return str(path)


def relative_path(path: str | Path, folder: str | Path) -> str:
    """``path`` relative to ``folder`` (POSIX separators), for a file in ``folder`` that
    records ``path`` and is read back from wherever the folder is moved with it."""
    import os
    return Path(os.path.relpath(Path(path).resolve(), Path(folder).resolve())).as_posix()
