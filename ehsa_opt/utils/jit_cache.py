"""CasADi functions compiled to C once and kept in a private per-user cache.

:func:`compiled` generates the C code of a ``casadi.Function`` (``CodeGenerator``),
names the shared library after the SHA-256 of that code, the compiler, its flags and the
CasADi version, compiles it (``casadi.Importer``, the ``shell`` plugin: the system's C
compiler) only when the cache does not hold it yet, and loads it
(``casadi.external``).  A later run — or another process of the same run — that
generates the same code loads the library without compiling.  Nothing is written in the
current directory.

The cache folder (:func:`cache_dir`): ``$EHSA_OPT_CACHE_DIR/jit`` when set, else
``$XDG_CACHE_HOME/ehsa_opt/jit``, else ``~/.cache/ehsa_opt/jit``; created private
(0700).  A folder that is a symlink, another user's, or writable by others is not used;
then (or when it cannot be created) a private temporary folder serves this process and
is removed at exit.  Deleting the cache folder is always safe (the libraries are
compiled again).  ``EHSA_OPT_NO_JIT`` set (or no C compiler) → no compilation: the
callers evaluate the same function in CasADi's virtual machine.
"""

from __future__ import annotations

import atexit
import hashlib
import os
import platform
import shutil
import stat
import tempfile
import threading
from pathlib import Path

import casadi as ca

__all__ = ["cache_dir", "compiled", "compiler"]

_FALLBACK: Path | None = None


def compiler() -> str | None:
    """The C compiler on the PATH (``gcc`` or ``cc``), or None (or when ``EHSA_OPT_NO_JIT``
    is set)."""
    if os.environ.get("EHSA_OPT_NO_JIT"):
        return None
    return shutil.which("gcc") or shutil.which("cc")


def _private(d: Path) -> bool:
    """``d`` is a real folder of this user that nobody else can write."""
    try:
        st = d.lstat()
    except OSError:
        return False
    return (stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid()
            and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH))


def cache_dir() -> Path:
    """The folder of the compiled libraries (see the module's description)."""
    global _FALLBACK
    base = os.environ.get("EHSA_OPT_CACHE_DIR")
    if base:
        d = Path(base).expanduser() / "jit"
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        root = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".cache"
        d = root / "ehsa_opt" / "jit"
    try:
        d.mkdir(parents=True, exist_ok=True, mode=0o700)
        if _private(d) and os.access(d, os.W_OK | os.X_OK):
            return d
    except OSError:
        pass
    if _FALLBACK is None:
        _FALLBACK = Path(tempfile.mkdtemp(prefix="ehsa_opt_jit_"))
        atexit.register(shutil.rmtree, _FALLBACK, True)
    return _FALLBACK


def _key(code: str, cc: str, flags: tuple[str, ...]) -> str:
    h = hashlib.sha256()
    for part in (code, cc, " ".join(flags), ca.__version__, platform.machine()):
        h.update(part.encode("utf-8"))
        h.update(b"\0")
    return h.hexdigest()[:32]


def compiled(f: ca.Function, flags: tuple[str, ...] = ("-O2",)) -> ca.Function | None:
    """``f`` compiled to C with ``flags`` and loaded from the cache, or None when no C
    compiler can be used (the caller then evaluates ``f`` itself).

    The result computes the same numbers as ``f`` (the code CasADi's ``jit`` option would
    compile) and can be mapped, folded and called through buffers like ``f``; it has no
    derivatives (differentiate ``f``'s expressions instead).
    """
    cc = compiler()
    if cc is None:
        return None
    gen = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False})
    gen.add(f)
    code = gen.dump()
    d = cache_dir()
    lib = d / f"{f.name()}_{_key(code, cc, tuple(flags))}.so"
    if not (lib.is_file() and not lib.is_symlink()):
        stem = f".{lib.stem}.{os.getpid()}.{threading.get_ident()}"  # this thread's files
        src = d / f"{stem}.c"
        try:
            src.write_text(code, encoding="utf-8")
            imp = ca.Importer(str(src), "shell", {
                "compiler": cc, "flags": list(flags), "directory": f"{d}{os.sep}",
                "name": stem, "cleanup": False})
            os.replace(imp.library(), lib)  # atomic: a concurrent run finds all or nothing
        except (RuntimeError, OSError):
            return None
        finally:
            for leftover in d.glob(f"{stem}*"):  # the source and the object files
                leftover.unlink(missing_ok=True)
    try:
        return ca.external(f.name(), str(lib))
    except RuntimeError:
        return None
