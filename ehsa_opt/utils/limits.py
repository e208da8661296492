"""Limits on what a received file may make us do: one error path for every parser.

Every loader (bench.toml, problem files, identification.json, cache entries, checkpoint
headers, truth.toml, CSVs) reads through these helpers, so a file nested 500 levels deep,
a CSV field of megabytes or a compressed archive that inflates a thousandfold gives the
loader's own error (file, what, fix) instead of a ``RecursionError``, a ``_csv.Error``
or gigabytes of memory.
"""

from __future__ import annotations

import json
import math
from typing import Any, Callable

__all__ = ["MAX_NESTING", "MAX_CSV_FIELD_CHARS", "MAX_TEXT_FILE_BYTES", "nesting_depth",
           "parse_json", "check_nesting", "nesting_error", "usable_cores", "read_input_bytes",
           "decode_text", "read_input_text", "MAX_CSV_BYTES", "max_csv_bytes", "scan_csv"]

#: Deepest nesting of tables/arrays accepted in a TOML or JSON input (ours use < 10).
MAX_NESTING = 64
#: Longest CSV field accepted (a number needs < 40 characters).
MAX_CSV_FIELD_CHARS = 1024
#: Largest TOML or JSON input read, bytes (checked before reading).  Ours are far smaller:
#: a problem file or bench.toml holds a few kB, an identification.json about 35 kB per
#: test (a thousand tests: 35 MB); a parsed JSON document takes ~10x its size in memory.
MAX_TEXT_FILE_BYTES = 64 * 2 ** 20
#: Largest numeric CSV read (a bench test, an EMPS source), bytes, unless the environment
#: variable ``EHSA_OPT_MAX_CSV_MB`` says otherwise: 256 MiB hold ~6 million rows of four
#: columns (1.7 h at 1 kHz), parsed into ~200 MB of floats; the identification's
#: collocation handles far fewer samples.
MAX_CSV_BYTES = 256 * 2 ** 20


def nesting_depth(obj: Any) -> int:
    """Depth of nested dicts/lists (iterative: safe on any depth)."""
    deepest, stack = 0, [(obj, 1)]
    while stack:
        node, d = stack.pop()
        if isinstance(node, dict):
            deepest = max(deepest, d)
            stack.extend((v, d + 1) for v in node.values())
        elif isinstance(node, list):
            deepest = max(deepest, d)
            stack.extend((v, d + 1) for v in node)
    return deepest


def nesting_error(where: str, error: Callable[[str], Exception]) -> Exception:
    return error(f"{where}: nested more than {MAX_NESTING} levels deep (tables or arrays "
                 f"inside each other); this is not a file ehsa-opt writes or reads — check "
                 f"that it is the right file")


def check_nesting(obj: Any, where: str, error: Callable[[str], Exception] = ValueError) -> Any:
    """``obj`` itself, or ``error`` when it is nested deeper than :data:`MAX_NESTING`."""
    if nesting_depth(obj) > MAX_NESTING:
        raise nesting_error(where, error)
    return obj


def parse_json(text: str | bytes, where: str, error: Callable[[str], Exception] = ValueError,
               standard: bool = True, **kw: Any) -> Any:
    """``json.loads`` with a nesting limit; every failure is ``error(message)``.

    With ``standard`` (default) the non-standard constants ``NaN`` and ``Infinity`` are
    refused: the JSON we write is standard.
    """
    def constant(name: str) -> Any:
        raise ValueError(f"non-standard JSON constant {name}")
    if standard:
        kw["parse_constant"] = constant
    try:
        obj = json.loads(text, **kw)
    except RecursionError:
        raise nesting_error(where, error) from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise error(f"{where}: not valid JSON ({exc})") from None
    return check_nesting(obj, where, error)


def read_input_bytes(path: Any, what: str, error: Callable[[str], Exception] = ValueError,
                     limit: int = MAX_TEXT_FILE_BYTES) -> bytes:
    """The bytes of a received file, its size checked before reading.

    Every failure is ``error(message)`` naming the file: not found, a folder, larger than
    ``limit`` (with the size), unreadable (the OS's reason).
    """
    import os
    from pathlib import Path
    path = Path(path)
    try:
        st = os.stat(path)
    except OSError as exc:
        raise error(f"{path}: {what} not found or not accessible ({exc.strerror}); check "
                    f"the path") from None
    import stat
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{path}: {what} is not a regular file (a folder or a device); give the "
                    f"path of the file")
    if st.st_size > limit:
        raise error(f"{path}: {what} is {st.st_size / 2 ** 20:.1f} MiB, more than the "
                    f"{limit / 2 ** 20:g} MiB any such file needs; check that it is the right "
                    f"file")
    try:
        with open(path, "rb") as fh:
            raw = fh.read(limit + 1)
    except OSError as exc:
        raise error(f"{path}: {what} cannot be read ({exc.strerror}); check the path and its "
                    f"permissions") from None
    if len(raw) > limit:  # grew while read (or a special file)
        raise error(f"{path}: {what} is larger than {limit / 2 ** 20:g} MiB; check that it "
                    f"is the right file")
    return raw


def decode_text(raw: bytes, where: str, error: Callable[[str], Exception] = ValueError) -> str:
    """Text of a received file: UTF-8 (a byte-order mark accepted), or UTF-16 / UTF-32
    when its byte-order mark or its zero bytes say so (``json.detect_encoding``); another
    encoding (Latin-1, Windows-1252) is refused naming the byte and the fix."""
    enc = json.detect_encoding(raw)
    if raw.startswith(b"\xef\xbb\xbf"):
        enc = "utf-8-sig"
    try:
        text = raw.decode(enc)
    except UnicodeDecodeError as exc:
        byte = raw[exc.start:exc.start + 1].hex()
        name = "UTF-8" if enc.startswith("utf-8") else enc.upper()
        guess = (" (it looks like Latin-1 / Windows-1252)"
                 if name == "UTF-8" and raw[exc.start] >= 0x80 else "")
        raise error(f"{where}: byte {exc.start} (0x{byte}) is not {name}{guess}; re-save it "
                    f"as UTF-8 (e.g. iconv -f latin1 -t utf-8 FILE > NEW)") from None
    if text.startswith("\ufeff"):
        text = text[1:]  # the byte-order mark of UTF-16 / UTF-32
    return text


def read_input_text(path: Any, what: str, error: Callable[[str], Exception] = ValueError,
                    limit: int = MAX_TEXT_FILE_BYTES) -> str:
    """:func:`read_input_bytes` decoded by :func:`decode_text`."""
    return decode_text(read_input_bytes(path, what, error, limit), str(path), error)


def max_csv_bytes() -> int:
    """:data:`MAX_CSV_BYTES`, or ``EHSA_OPT_MAX_CSV_MB`` (MiB) when set."""
    import os
    env = os.environ.get("EHSA_OPT_MAX_CSV_MB")
    if not env:
        return MAX_CSV_BYTES
    try:
        mb = float(env)
    except ValueError:
        mb = math.nan
    if not (math.isfinite(mb) and mb > 0):
        raise ValueError(f"EHSA_OPT_MAX_CSV_MB = {env!r} is not a positive number; set it to "
                         f"the largest CSV to read in MiB, e.g. 512")
    return int(mb * 2 ** 20)


def scan_csv(path: Any, columns: int, name: str,
             error: Callable[[str], Exception] = ValueError, chunk: int = 1 << 20) -> None:
    """Refuse a CSV before it is parsed: larger than :func:`max_csv_bytes` (checked before
    reading), or holding a NUL byte (binary data, a sparse or unfinished file) or a row
    longer than ``columns`` fields of :data:`MAX_CSV_FIELD_CHARS` — streamed in ``chunk``
    bytes, so the memory stays that of one chunk whatever the file."""
    import os

    import numpy as np
    size, limit = os.stat(path).st_size, max_csv_bytes()
    if size > limit:
        raise error(f"{name}: {size / 2 ** 20:.0f} MiB, more than the {limit / 2 ** 20:g} MiB "
                    f"a CSV may have (EHSA_OPT_MAX_CSV_MB); split the recording into several "
                    f"tests, or raise the limit if the memory allows (~1 GB per 1 GiB of CSV)")
    longest = columns * (MAX_CSV_FIELD_CHARS + 1) + 1
    row, run = 1, 0  # 1-based row of the line being read, its length so far
    with open(path, "rb") as fh:
        sep = 10  # the line end: \n, or \r in a file that has no \n (classic Mac)
        while block := fh.read(chunk):
            if row == 1 and run == 0 and b"\n" not in block and b"\r" in block:
                sep = 13
            nul = block.find(b"\0")
            if nul >= 0:
                at = row + block.count(bytes([sep]), 0, nul)
                raise error(f"{name}: row {at} holds a NUL byte "
                            f"(binary data: a sparse, unfinished or corrupt file); re-export "
                            f"the test as a comma-separated text file")
            nl = np.flatnonzero(np.frombuffer(block, np.uint8) == sep)
            ends = np.concatenate([[-1], nl])
            lengths = np.diff(ends) - 1
            if lengths.size:
                lengths[0] += run
                run = len(block) - int(nl[-1]) - 1
            else:
                run += len(block)
            over = np.flatnonzero(lengths > longest)
            if over.size or run > longest:
                k = int(over[0]) if over.size else int(nl.size)
                raise error(f"{name}: row {row + k} is longer than {longest} characters "
                            f"({columns} fields of at most {MAX_CSV_FIELD_CHARS}); it is not "
                            f"a row of numbers — repair the file or re-export it")
            row += int(nl.size)


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS tells)."""
    import os
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)
