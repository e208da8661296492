"""Limits on what a received file may make us do: one error path for every parser.

Every loader (bench.toml, problem files, identification.json, cache entries, checkpoint
headers, truth.toml, CSVs) reads through these helpers, so a file nested 500 levels deep,
a CSV field of megabytes or a compressed archive that inflates a thousandfold gives the
loader's own error (file, what, fix) instead of a ``RecursionError``, a ``_csv.Error``
or gigabytes of memory.
"""

from __future__ import annotations

import json
from typing import Any, Callable

__all__ = ["MAX_NESTING", "MAX_CSV_FIELD_CHARS", "nesting_depth", "parse_json",
           "check_nesting", "nesting_error", "usable_cores"]

#: Deepest nesting of tables/arrays accepted in a TOML or JSON input (ours use < 10).
MAX_NESTING = 64
#: Longest CSV field accepted (a number needs < 40 characters).
MAX_CSV_FIELD_CHARS = 1024


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


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS tells)."""
    import os
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)
