"""The product's output folders: a manifest of the files ehsa-opt wrote in a folder, so a
run never replaces a file it did not write.

A command that writes a folder *claims* it (:func:`claim`) before any work: an empty or
new folder, or one holding the manifest :data:`MANIFEST_NAME`, is ours; a non-empty
folder without it may hold the user's files and is refused unless ``overwrite`` — and
even then a file the manifest does not list is never replaced.  Every atomic write
(:mod:`ehsa_opt.utils.io`) *admits* its target first (:func:`admit`): inside a claimed
folder the relative path is appended to the manifest before the file is written, or the
write is refused when the file exists and the manifest does not list it.

The manifest is an append-only text file (one relative path per line after a header),
appended under ``fcntl.flock``: the worker processes a run forks add their files to the
same manifest without losing any.  Temporary files of atomic writes carry a name only
the product makes (:func:`temp_prefix`, :data:`TEMP_SUFFIX`); the clean-up of an
interrupted run (:func:`stale_temp_files`) deletes only those, and only for targets the
manifest lists.
"""

from __future__ import annotations

import contextlib
import os
import re
from pathlib import Path
from typing import Iterable, Iterator

from .lock import LOCK_NAME

__all__ = ["MANIFEST_NAME", "TEMP_SUFFIX", "ForeignFolderError", "claim", "claimed", "release", "admit",
           "read_manifest", "temp_prefix", "stale_temp_files", "write_listing", "unlisted_content"]

#: The manifest ehsa-opt keeps in every folder it writes.
MANIFEST_NAME = ".ehsa_opt_manifest.txt"
_HEADER = "ehsa-opt manifest 1: the files ehsa-opt wrote in this folder, one relative path a line"
#: A manifest larger than this is not ours (a full reproduce run lists ~300 paths, 20 KB).
_MAX_MANIFEST_BYTES = 16 << 20
#: Temporary files of atomic writes: ``.NAME.ehsa_opt-XXXXXXXX.tmp`` (``mkstemp``'s 8
#: random characters in the middle).
TEMP_SUFFIX = ".tmp"
_TEMP = re.compile(r"^\.(?P<name>.+)\.ehsa_opt-[A-Za-z0-9_]{8}\.tmp$")
#: Folders claimed by this process: resolved root -> the relative paths the manifest lists.
_claimed: dict[Path, set[str]] = {}


class ForeignFolderError(FileExistsError):
    """An output folder or file that ehsa-opt did not write (never replaced)."""


def temp_prefix(target: Path) -> str:
    """The ``mkstemp`` prefix of an atomic write of ``target``."""
    return f".{target.name}.ehsa_opt-"


def read_manifest(folder: str | Path) -> set[str] | None:
    """The relative paths the manifest of ``folder`` lists (None: no readable manifest —
    the folder is not known to be ours)."""
    path = Path(folder) / MANIFEST_NAME
    try:
        if path.is_symlink() or not path.is_file() or path.stat().st_size > _MAX_MANIFEST_BYTES:
            return None
        lines = path.read_bytes().decode("utf-8").split("\n")
    except (OSError, UnicodeDecodeError):
        return None
    if lines[0] != _HEADER:
        return None
    return {line for line in lines[1:] if line}


def _content(folder: Path) -> list[str]:
    """The names in ``folder`` other than the lock, the manifest and empty sub-folders (a
    run interrupted before its first write leaves those; they hold nothing of anyone's)."""
    if not folder.is_dir() or folder.is_symlink():
        return []
    return sorted(f.name for f in folder.iterdir() if f.name not in (LOCK_NAME, MANIFEST_NAME)
                  and (f.is_symlink() or not f.is_dir() or any(f.iterdir())))


def claim(folder: str | Path, *, overwrite: bool = False, option: str = "--out",
          produces: Iterable[str] = ()) -> Path:
    """Make ``folder`` an output folder of this process, before any work is done (a folder
    this process already claimed is returned as it is).

    Parameters
    ----------
    folder : path
        The output folder (created later, by the first write).
    overwrite : bool
        Write into a non-empty folder ehsa-opt did not write (a file it did not write is
        still never replaced).
    option : str
        How the user named the folder (for the messages), e.g. ``--out``.
    produces : iterable of str
        Relative paths the command always writes: one that exists and is not in the
        manifest is refused now rather than after the work.

    Raises
    ------
    ForeignFolderError
        The folder is not empty and not ours (without ``overwrite``), or it holds a file
        of ``produces`` that ehsa-opt did not write.
    """
    out = Path(folder)
    if out.resolve() in _claimed:  # already claimed by this run (the CLI, then the library)
        return out
    listed = read_manifest(out)
    content = _content(out)
    if content and listed is None and not overwrite:
        why = (f"has an unreadable {MANIFEST_NAME}" if (out / MANIFEST_NAME).exists() else
               f"has no {MANIFEST_NAME}, the list of the files ehsa-opt wrote there")
        shown = ", ".join(content[:3]) + (", ..." if len(content) > 3 else "")
        raise ForeignFolderError(
            f"{option} {out}: the folder is not empty ({shown}) and {why}, so it may hold "
            f"your own files; nothing was changed. Choose a new or empty folder, or pass "
            f"--overwrite to write into it (ehsa-opt then replaces only files its manifest "
            f"lists, never yours)")
    listed = listed or set()
    clashes = [n for n in produces if os.path.lexists(out / n) and n not in listed]
    if clashes:
        raise ForeignFolderError(
            f"{option} {out}: {', '.join(clashes)} was not written by ehsa-opt (not listed "
            f"in {out / MANIFEST_NAME}) and is never replaced; nothing was changed. Move "
            f"that file away or choose another folder")
    _claimed[out.resolve()] = set(listed)
    return out


def release(folder: str | Path) -> None:
    """Forget the claim of ``folder`` (the run into it is over)."""
    _claimed.pop(Path(folder).resolve(), None)


@contextlib.contextmanager
def claimed(folder: str | Path, *, overwrite: bool = False, option: str = "--out",
            produces: Iterable[str] = ()) -> Iterator[Path]:
    """:func:`claim` ``folder`` for the ``with`` block; released at its end unless it was
    already claimed before (a library call inside a command's claim)."""
    before = Path(folder).resolve() in _claimed
    out = claim(folder, overwrite=overwrite, option=option, produces=produces)
    try:
        yield out
    finally:
        if not before:
            release(folder)


def _append(root: Path, rel: str) -> None:
    """Append ``rel`` to the manifest of ``root`` (header first), under an exclusive lock."""
    import fcntl
    fd = os.open(root / MANIFEST_NAME,
                 os.O_WRONLY | os.O_APPEND | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        head = _HEADER + "\n" if os.fstat(fd).st_size == 0 else ""
        os.write(fd, (head + rel + "\n").encode("utf-8"))
    finally:
        os.close(fd)


def admit(path: str | Path) -> None:
    """Before writing ``path``: inside a claimed folder, list it in the manifest, or refuse
    it when it exists and the manifest does not list it (a file of the user's).  Outside
    every claimed folder nothing is checked.  Called before the parent folder is made, so
    a run killed at any point leaves no unlisted file.

    Raises
    ------
    ForeignFolderError
        ``path`` exists and ehsa-opt did not write it.
    """
    if not _claimed:
        return
    p = Path(path)
    full = p.parent.resolve() / p.name
    root = max((r for r in _claimed if full.is_relative_to(r) and full != r),
               key=lambda r: len(r.parts), default=None)
    if root is None:
        return
    listed = _claimed[root]
    rel = full.relative_to(root).as_posix()
    if rel in listed:
        return
    if "\n" in rel or "\r" in rel:
        raise ValueError(f"{p}: a file name with a line break is not written")
    if os.path.lexists(full):
        listed |= read_manifest(root) or set()  # another process of the run wrote it
        if rel not in listed:
            raise ForeignFolderError(
                f"{p}: exists and was not written by ehsa-opt (not listed in "
                f"{root / MANIFEST_NAME}), so it is not replaced; move it away or choose "
                f"another output folder")
        return
    root.mkdir(parents=True, exist_ok=True)  # the manifest goes in first
    _append(root, rel)
    listed.add(rel)


def stale_temp_files(root: str | Path, folders: Iterable[str | Path]) -> list[Path]:
    """Temporary files an interrupted run left in ``folders`` (inside ``root``): only names
    of the form ``.NAME.ehsa_opt-XXXXXXXX.tmp`` whose target ``NAME`` the manifest of
    ``root`` lists; never a symlink, never inside a symlinked folder."""
    root = Path(root)
    listed = read_manifest(root) or set()
    found = []
    for d in map(Path, folders):
        if not d.is_dir() or (d != root and d.is_symlink()):
            continue
        prefix = "" if d == root else d.relative_to(root).as_posix() + "/"
        for f in sorted(d.iterdir()):
            m = _TEMP.match(f.name)
            if m and prefix + m["name"] in listed and not f.is_symlink() and f.is_file():
                found.append(f)
    return found


# ------------------------------------------------------------------ whole folders
def write_listing(d: Path, marker: str, fmt: str) -> None:
    """Write ``d/marker`` listing every name in ``d``: a folder written whole (in a temporary
    folder, then renamed), such as bench data, so that ``--overwrite`` replaces it only
    while nobody has added to it (:func:`unlisted_content`)."""
    import json
    names = sorted(f.name for f in d.iterdir())
    (d / marker).write_text(json.dumps({"format": fmt, "files": names}), encoding="utf-8")


def unlisted_content(d: Path, marker: str, fmt: str, depth: int = 0) -> str | None:
    """Why folder ``d`` may not be replaced (None: ehsa-opt wrote all of it): ``d`` must
    hold ``marker`` (:func:`write_listing`, format ``fmt``) and nothing else than the names
    listed there (a listed sub-folder must itself be such a folder).  Symlinks are never
    followed."""
    import json

    from .limits import parse_json
    path = d / marker
    if path.is_symlink() or not path.is_file():
        return (f"was not written by ehsa-opt (no {marker}); it may hold your own "
                f"files, so it is never replaced or deleted")
    try:
        doc = parse_json(path.read_bytes()[:1 << 20], str(path))
        listed = set(doc["files"]) if doc.get("format") == fmt else None
    except (ValueError, KeyError, TypeError, AttributeError, OSError, json.JSONDecodeError):
        listed = None
    if listed is None:
        return f"has an unreadable {marker}, so it is never replaced or deleted"
    added = []
    for f in sorted(d.iterdir(), key=lambda f: f.name):
        if f.name == marker:
            continue
        if f.name not in listed or f.is_symlink():
            added.append(f.name)
        elif f.is_dir() and (depth > 4 or unlisted_content(f, marker, fmt, depth + 1)):
            added.append(f.name + "/")
    if added:
        return (f"holds files ehsa-opt did not write ({', '.join(added[:5])}"
                + (", ..." if len(added) > 5 else "") + "), so it is never replaced or deleted")
    return None
