"""CasADi functions compiled to C (``jit``, the system's C compiler) in a private
temporary folder: one per process, removed at exit, never the user's working directory.

A compiled function evaluates the same expression graph as CasADi's virtual machine, in
the same order and in IEEE double precision (``-O2``, no fast-math), so its results are
the same numbers; where no compiler works the caller keeps the uncompiled function.
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

__all__ = ["jit_directory", "jit_options", "compiled"]

_JIT_DIR: str | None = None


def jit_directory() -> str:
    """A private temporary folder for CasADi's generated C and shared objects, so runs
    never litter the user's working directory."""
    global _JIT_DIR
    if _JIT_DIR is None:
        _remove_orphaned_jit_directories()
        _JIT_DIR = tempfile.mkdtemp(prefix=f"ehsa_opt_jit_{os.getpid()}_")
        atexit.register(_remove_jit_directory, _JIT_DIR, os.getpid())
    return _JIT_DIR


def _remove_orphaned_jit_directories() -> None:
    """JIT folders of our processes that died without cleaning up (``kill -9``)."""
    for d in Path(tempfile.gettempdir()).glob("ehsa_opt_jit_*_*"):
        try:
            pid = int(d.name.split("_")[3])
            if d.is_symlink() or not d.is_dir() or d.stat().st_uid != os.getuid():
                continue
            os.kill(pid, 0)  # alive: its folder stays
        except ProcessLookupError:
            shutil.rmtree(d, ignore_errors=True)
        except (ValueError, IndexError, OSError):
            continue


def _remove_jit_directory(path: str, owner: int) -> None:
    """Remove the JIT folder at exit (only in the process that made it: forked workers
    share it while their parent runs)."""
    if os.getpid() == owner:
        shutil.rmtree(path, ignore_errors=True)


def jit_options() -> dict[str, Any]:
    """CasADi ``Function`` options that compile it (``-O2``) in :func:`jit_directory`."""
    # the folder is ours and removed at exit; CasADi leaves its files to us
    return {"jit": True, "compiler": "shell", "jit_cleanup": False,
            "jit_options": {"flags": ["-O2"], "verbose": False, "cleanup": False,
                            "directory": jit_directory()}}


def compiled(fun: Any) -> Any:
    """``fun`` (a ``casadi.Function``) compiled to C, or ``fun`` itself when no C compiler
    works."""
    import casadi as ca
    try:
        args = [fun.mx_in(i) for i in range(fun.n_in())]
        return ca.Function(fun.name(), args, fun.call(args), fun.name_in(), fun.name_out(),
                           jit_options())
    except Exception:  # noqa: BLE001 - no compiler: the VM evaluates the same graph
        return fun
