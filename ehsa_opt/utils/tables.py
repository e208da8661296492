"""Tidy tables of results: named columns with units, as a pandas ``DataFrame`` when pandas
is installed, else a ``dict`` of numpy arrays; CSV text in and out.

Column names carry their unit as a suffix (``power_W``, ``load_ohm``,
``lead_mm_per_rev``); :func:`unit_of` reads it back, and a table's ``units`` (the
DataFrame's ``attrs["units"]``) maps every column to its unit (``"-"`` when
dimensionless, ``""`` for a label).
"""

from __future__ import annotations

import csv
import io
from typing import Any, Mapping, Sequence

import numpy as np

__all__ = ["SUFFIX_UNITS", "unit_of", "tidy_table", "table_to_csv", "csv_to_columns"]

#: Column-name suffixes and the unit they mean, longest first.
SUFFIX_UNITS: tuple[tuple[str, str], ...] = (
    ("_Vs_per_rad", "V s/rad"), ("_Nm_per_A", "N m/A"), ("_rpm_per_V", "rpm/V"),
    ("_mm_per_rev", "mm/rev"), ("_Ns_per_m", "N s/m"), ("_N_per_m", "N/m"),
    ("_km_per_h", "km/h"), ("_m_per_s", "m/s"), ("_m_s2", "m/s^2"), ("_gcm2", "g cm^2"),
    ("_ohm", "ohm"), ("_pct", "%"), ("_Hz", "Hz"), ("_Nm", "N m"), ("_kg", "kg"),
    ("_W", "W"), ("_A", "A"), ("_V", "V"), ("_H", "H"), ("_N", "N"), ("_m", "m"),
    ("_s", "s"))


def unit_of(name: str, labels: Sequence[str] = ()) -> str:
    """The unit of column ``name`` from its suffix; ``""`` for a label column (in
    ``labels``), ``"-"`` when dimensionless."""
    if name in labels:
        return ""
    for suffix, unit in SUFFIX_UNITS:
        if name.endswith(suffix):
            return unit
    return "-"


def tidy_table(columns: Mapping[str, Any], units: Mapping[str, str] | None = None) -> Any:
    """A table of equal-length ``columns``: a ``pandas.DataFrame`` (``attrs["units"]``
    the units) when pandas is installed, else a ``dict`` of numpy arrays.

    ``units`` overrides :func:`unit_of` for the columns it names."""
    cols = {k: np.asarray(v) for k, v in columns.items()}
    lengths = {len(v) for v in cols.values()}
    if len(lengths) > 1:
        raise ValueError(f"table columns of different lengths: "
                         f"{ {k: len(v) for k, v in cols.items()} }")
    labels = [k for k, v in cols.items() if v.dtype.kind in "OUS"]
    unit_map = {k: unit_of(k, labels) for k in cols}
    unit_map.update({k: u for k, u in (units or {}).items() if k in cols})
    try:
        import pandas as pd
    except ImportError:
        return cols
    frame = pd.DataFrame(cols)
    frame.attrs["units"] = unit_map
    return frame


def table_to_csv(columns: Mapping[str, Any]) -> str:
    """CSV text of a table (full float precision, ``repr``)."""
    cols = {k: np.asarray(v) for k, v in columns.items()}
    n = len(next(iter(cols.values()))) if cols else 0

    def fmt(v: Any) -> str:
        return repr(float(v)) if isinstance(v, (float, np.floating)) else str(v)
    lines = [",".join(cols)] + [",".join(fmt(cols[k][i]) for k in cols) for i in range(n)]
    return "\n".join(lines) + "\n"


def csv_to_columns(text: str, where: str) -> dict[str, np.ndarray]:
    """The columns of CSV ``text``: numbers as float arrays, the rest as strings.

    Raises ``ValueError`` naming ``where`` when a row's length differs from the
    header's."""
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        return {}
    head, body = rows[0], rows[1:]
    for i, r in enumerate(body, start=2):
        if len(r) != len(head):
            raise ValueError(f"{where} row {i}: {len(r)} fields, the header has {len(head)}")
    out: dict[str, np.ndarray] = {}
    for j, name in enumerate(head):
        vals = [r[j] for r in body]
        try:
            out[name] = np.array([float(v) if v != "" else np.nan for v in vals], dtype=float)
        except ValueError:
            out[name] = np.array(vals, dtype=object)
    return out
