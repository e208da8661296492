"""Is a committed reproduction report still what the code computes?

:func:`report_differences` compares two ``REPORT.md`` texts — the committed reference and a
fresh run of the same mode — on what a reader takes from them: the section and subsection
headings (a named model such as the chosen discrepancy effect appears there) and every table
cell, text exactly and numbers to within :data:`REFERENCE_RTOL` or one unit of the last digit
printed (whichever is larger).  Timings are left out (the run log, cells of columns about
time or speed of the computation), since they are the machine's, not the code's.
"""

from __future__ import annotations

import re
from typing import Iterator

from .base import markdown_tables

__all__ = ["REFERENCE_RTOL", "report_cells", "report_differences"]

#: Relative tolerance of a number in a table of the reference report: 0.1 %, far above the
#: run-to-run differences of a deterministic pipeline (none) and of BLAS builds (~1e-12),
#: far below any change of a model or study that a reader would notice.
REFERENCE_RTOL = 1e-3

_NUMBER = re.compile(r"[-+−]?\d+(?:[.,]\d+)*(?:\.\d+)?(?:e[-+]?\d+)?", re.IGNORECASE)
#: Column headers (lower case) whose cells are the machine's, not the code's.
_MACHINE_COLUMNS = ("compute time", "wall", "seconds", "time (s)", "speed-up", "this run")


def _sections(markdown: str) -> Iterator[tuple[str, str]]:
    """(title without its number, body) of each ``## `` section, the run log left out."""
    parts = re.split(r"^## ", markdown, flags=re.MULTILINE)
    for part in parts[1:]:
        title, _, body = part.partition("\n")
        title = re.sub(r"^\d+\.\s*", "", title.strip())
        if title.lower().startswith("run log"):
            continue
        yield title, body


def report_cells(markdown: str) -> dict[str, str]:
    """Every heading and table cell of a report: key ``section / table k / row / column``
    (or ``section / heading k``) to its text."""
    out: dict[str, str] = {}
    for title, body in _sections(markdown):
        heads = re.findall(r"^#{3,} (.+)$", body, flags=re.MULTILINE)
        for k, h in enumerate(heads):
            out[f"{title} / heading {k}"] = h.strip()
        for t, table in enumerate(markdown_tables(body)):
            header = table[0]
            for row in table[1:]:
                for j, cell in enumerate(row[1:], start=1):
                    col = header[j] if j < len(header) else f"column {j}"
                    if any(m in col.lower() for m in _MACHINE_COLUMNS):
                        continue
                    out[f"{title} / table {t} / {row[0]} / {col}"] = cell
    return out


def _numbers(text: str) -> tuple[list[float], list[int], str]:
    """Numbers of a cell, their printed decimals, and the text with them masked."""
    vals, decs = [], []
    for m in _NUMBER.finditer(text):
        s = m.group(0).replace("−", "-").replace(",", "")
        try:
            vals.append(float(s))
        except ValueError:
            continue
        mant = s.lower().split("e")[0]
        decs.append(len(mant.split(".")[1]) if "." in mant else 0)
    return vals, decs, _NUMBER.sub("#", text)


def _same(a: str, b: str, rtol: float) -> bool:
    va, da, ta = _numbers(a)
    vb, db, tb = _numbers(b)
    if ta != tb or len(va) != len(vb):
        return False
    for x, y, d in zip(va, vb, da):
        unit = 10.0 ** (-d)
        if abs(x - y) > max(rtol * max(abs(x), abs(y)), 1.01 * unit):
            return False
    return True


def report_differences(reference: str, current: str, rtol: float = REFERENCE_RTOL
                       ) -> list[str]:
    """What differs between two reports (empty: the reference is current).

    Parameters
    ----------
    reference, current : str
        ``REPORT.md`` texts of the same mode.
    rtol : float
        Relative tolerance of numbers (besides one unit of the last printed digit).

    Returns
    -------
    list of str
        One line per missing, extra or changed heading or cell:
        ``key: reference 'x' -> current 'y'``.
    """
    ref, cur = report_cells(reference), report_cells(current)
    out = [f"{k}: only in the reference ({ref[k]!r})" for k in ref if k not in cur]
    out += [f"{k}: only in the current report ({cur[k]!r})" for k in cur if k not in ref]
    out += [f"{k}: reference {ref[k]!r} -> current {cur[k]!r}" for k in ref
            if k in cur and not _same(ref[k], cur[k], rtol)]
    return out
