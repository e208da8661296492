"""Bench data format: ``bench.toml`` plus one CSV per test.

Layout of a data directory::

    bench.toml          # [rig] (optional), [harvester] (optional), [[test]] (one per test)
    f1.5Hz_Re47.csv     # time_s,displacement_m,force_N[,voltage_V]

``bench.toml``::

    [rig]                       # optional
    name = "prototype"
    has_generator = true        # false: no voltage column, no load (e.g. EMPS)
    description = "..."
    [harvester]                 # optional; any HarvesterParams field by its name
    lead_mm_per_rev = 5.0
    [[test]]
    file = "f1.5Hz_Re47.csv"
    frequency_hz = 1.5          # sine tests (excitation = "sine", the default)
    amplitude_m = 0.015
    load_ohm = 47.0             # required when the rig has a generator
    # excitation = "recorded"   # arbitrary motion: frequency/amplitude not required
    # run_order = 3             # optional: the test's place in the campaign (formats page)
    # started_at = 2026-03-02T09:15:30Z   # optional: when its first sample was taken

The loader is strict: every problem is a :class:`BenchDataError` that names the
file (or ``bench.toml``), the row or key, and the fix.  The writer writes into a
temporary directory and renames it into place, so nothing is half-written.
"""

from __future__ import annotations

import datetime
import io
import math
import os
import shutil
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

import numpy as np
import tomli_w

from ..physics.params import (
    HarvesterParams,
    ParameterError,
    from_mapping,
    load_toml,
    nearest_name,
    unknown_name_message,
)
from ..utils.output_folder import unlisted_content, write_listing
from ..utils.limits import scan_csv
from .checks import check_test_signals
from .run_order import RUN_KEYS, check_run_sequence, parse_run_keys

__all__ = ["BenchDataError", "BenchDataWarning", "BenchTest", "BenchData", "load_bench",
           "write_bench", "check_bench", "load_bench_checked", "check_summary",
           "COLUMNS", "MARKER_NAME", "foreign_content",
           "write_marker", "read_number_table"]

#: Required CSV columns, in order; ``voltage_V`` only for rigs with a generator.
COLUMNS = ("time_s", "displacement_m", "force_N", "voltage_V")

_TEST_KEYS = ("file", "frequency_hz", "amplitude_m", "load_ohm", "excitation", "description",
              *RUN_KEYS)
_RIG_KEYS = ("name", "has_generator", "description")
_TOP_KEYS = ("rig", "harvester", "test")
_EXCITATIONS = ("sine", "recorded")

# plausible ranges to catch unit slips (value, unit, hint)
_RANGES = {
    "frequency_hz": (0.0, 200.0, "frequency is in Hz"),
    "amplitude_m": (0.0, 0.5, "amplitude is in metres: 15 mm is 0.015"),
    "load_ohm": (0.0, 1e7, "load is in ohm"),
}
_MAX_DISPLACEMENT_M = 1.0  # |x| above this is almost surely millimetres


class BenchDataError(ValueError):
    """Invalid bench data; the message names the file, row or key, and the fix."""


class BenchDataWarning(UserWarning):
    """A physics check that failed under ``lenient=True`` (the data are used anyway)."""


@dataclass(frozen=True)
class BenchTest:
    """One bench test: metadata from ``bench.toml`` and its samples.

    Attributes
    ----------
    file : str
        CSV file name, relative to the data directory.
    frequency_hz, amplitude_m : float or None
        Sine excitation (None for ``excitation = "recorded"`` without them).
    load_ohm : float or None
        External load, Ω (None for a rig without generator).
    excitation : str
        ``"sine"`` or ``"recorded"``.
    time_s, displacement_m, force_N : ndarray
    voltage_V : ndarray or None
    run_order : int or None
        The test's place in the campaign (1 = run first), if stated.
    started_at : datetime or None
        When its first sample was taken, if stated.
    """

    file: str
    frequency_hz: float | None
    amplitude_m: float | None
    load_ohm: float | None
    excitation: str
    time_s: np.ndarray = field(repr=False)
    displacement_m: np.ndarray = field(repr=False)
    force_N: np.ndarray = field(repr=False)
    voltage_V: np.ndarray | None = field(repr=False, default=None)
    description: str = ""
    run_order: int | None = None
    started_at: datetime.datetime | None = None

    @property
    def n_samples(self) -> int:
        return int(self.time_s.size)

    @property
    def has_voltage(self) -> bool:
        return self.voltage_V is not None

    @property
    def label(self) -> str:
        if self.frequency_hz is not None and self.load_ohm is not None:
            return f"{self.frequency_hz:g} Hz, {self.load_ohm:g} ohm"
        return Path(self.file).stem


@dataclass(frozen=True)
class BenchData:
    """A loaded data directory.

    Attributes
    ----------
    path : Path
    tests : list[BenchTest]
    harvester : HarvesterParams
        From ``[harvester]``, Table 1 defaults otherwise.
    rig_name, description : str
    has_generator : bool
    """

    path: Path
    tests: list[BenchTest]
    harvester: HarvesterParams
    rig_name: str = ""
    description: str = ""
    has_generator: bool = True

    def __len__(self) -> int:
        return len(self.tests)

    def __iter__(self):
        return iter(self.tests)


# ------------------------------------------------------------------ loading
def _check_number(value: Any, key: str, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BenchDataError(f"{where}: '{key}' must be a number, got {value!r}")
    value = float(value)
    lo, hi, hint = _RANGES[key]
    if not math.isfinite(value) or value <= lo:
        raise BenchDataError(f"{where}: '{key}' = {value:g} must be positive and finite "
                             f"({hint}); fix it in bench.toml")
    if value > hi:
        raise BenchDataError(f"{where}: '{key}' = {value:g} is out of range (<= {hi:g}); "
                             f"{hint} — is it in the wrong unit?")
    return value


def _unknown_key(key: str, valid: Iterable[str], where: str) -> BenchDataError:
    return BenchDataError(unknown_name_message(key, valid, where))


def _shown(value: str, limit: int = 40) -> str:
    """A field for a message: at most ``limit`` characters, control characters escaped."""
    text = value.strip()
    text = text if len(text) <= limit else text[:limit] + f"... ({len(text)} characters)"
    return repr(text)[1:-1]


def _diagnose_rows(path: Path, header: list[str]) -> BenchDataError:
    """Stream the data rows to find the first bad one (nothing is kept in memory)."""
    name, ncol = path.name, len(header)
    bad: tuple[int, int] | None = None  # (row, fields) of a short/long row
    with path.open(encoding="utf-8-sig", errors="replace", newline="") as fh:
        fh.readline()
        for k, ln in enumerate(fh, start=2):
            if bad is not None:
                if ln.strip():  # a later non-blank row: the bad one was not the last
                    break
                continue
            if not ln.strip():
                continue
            parts = ln.rstrip("\r\n").split(",")
            if len(parts) != ncol:
                bad = (k, len(parts))
                continue
            for j, v in enumerate(parts):
                try:
                    float(v)
                except ValueError:
                    return BenchDataError(f"{name}: row {k}, column '{header[j]}': "
                                          f"'{_shown(v)}' is not a number")
        else:
            if bad is not None:
                return BenchDataError(
                    f"{name}: last row {bad[0]} has {bad[1]} fields, expected {ncol} "
                    f"({','.join(header)}); the file may be truncated — complete or delete "
                    f"that row")
    if bad is not None:
        return BenchDataError(f"{name}: row {bad[0]} has {bad[1]} fields, expected {ncol} "
                              f"({','.join(header)}); repair or delete that row")
    return BenchDataError(f"{name}: could not be read as a CSV of numbers; check the "
                          f"delimiter (a comma) and the rows")


def read_number_table(path: Path, min_columns: int = 1,
                      check_header: Any = None) -> tuple[np.ndarray, list[str]]:
    """A CSV of numbers with one header row, strictly: (rows x columns array, header).

    One error path for every numeric CSV we read: a :class:`BenchDataError` naming
    the file and the row (1-based, header = 1) — a missing or empty file, another
    delimiter than the comma (named), too few columns, a field that is not a number,
    NaN/inf.  A UTF-8 byte-order mark is accepted.  ``check_header(header)`` may refuse
    the header before the rows are parsed.  Valid files are parsed by
    :func:`numpy.loadtxt` straight into one float array (memory ≈ the array); only a
    bad file is scanned a second time, line by line, to name its first bad row.
    """
    name = path.name
    if not path.is_file():
        raise BenchDataError(f"{name}: file not found ({path}); check the path")
    with path.open(encoding="utf-8-sig", errors="replace", newline="") as fh:
        first = fh.readline(1 << 16)
        if not first.strip():
            raise BenchDataError(f"{name}: file is empty; it needs a header row and data rows")
        header = [h.strip() for h in first.split(",")]
        if len(header) == 1:
            for delim, what in ((";", "semicolon"), ("\t", "tab"), ("|", "vertical bar"),
                                (" ", "space")):
                if delim in first.strip():
                    raise BenchDataError(
                        f"{name}: row 1 (header) is separated by '{delim}' ({what}); the "
                        f"format uses a comma (',') between columns and a point as the "
                        f"decimal mark — re-export the file as comma-separated CSV")
        if len(header) < min_columns:
            raise BenchDataError(f"{name}: row 1 (header) has {len(header)} column(s), "
                                 f"at least {min_columns} are needed")
        if any(not h.isprintable() for h in header):
            h = next(h for h in header if not h.isprintable())
            raise BenchDataError(f"{name}: row 1 (header): column name '{_shown(h)}' holds a "
                                 f"control character; rename the column")
        if check_header is not None:
            check_header(header)
        scan_csv(path, len(header), name, BenchDataError)  # size, NUL, row length: bounded
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # "input contained no data"
                arr = np.loadtxt(fh, delimiter=",", dtype=float, comments=None, ndmin=2)
        except ValueError:
            arr = None
    if arr is not None and arr.size == 0:
        raise BenchDataError(f"{name}: no data rows after the header")
    if arr is None or arr.shape[1] != len(header):
        raise _diagnose_rows(path, header)
    bad = ~np.isfinite(arr)
    if bad.any():
        k, j = map(int, np.argwhere(bad)[0])
        raise BenchDataError(f"{name}: row {k + 2}, column '{header[j]}': value {arr[k, j]} is "
                             f"not finite (NaN/inf); remove or repair the sample")
    return arr, header


def _read_csv(path: Path, need_voltage: bool) -> dict[str, np.ndarray]:
    """Strictly read one test CSV; errors name the file and the row (1-based, header = 1)."""
    name = path.name
    if not path.is_file():
        raise BenchDataError(f"{name}: file listed in bench.toml does not exist "
                             f"({path}); add it or remove its [[test]] entry")
    required = list(COLUMNS[:4] if need_voltage else COLUMNS[:3])

    def check_header(header: list[str]) -> None:
        for col in required:
            if col not in header:
                near = nearest_name(col, header)
                hint = f" (found '{near}': rename it to '{col}')" if near else ""
                raise BenchDataError(f"{name}: row 1 (header): missing column '{col}'{hint}; "
                                     f"the header must be {','.join(required)}")
        for col in header:
            if col not in COLUMNS:
                raise BenchDataError(unknown_name_message(col, COLUMNS,
                                                          f"{name}: row 1 (header)", "column"))
        if len(set(header)) != len(header):
            raise BenchDataError(f"{name}: row 1 (header): duplicate column names {header}")

    arr, header = read_number_table(path, 1, check_header)
    cols = {h: np.ascontiguousarray(arr[:, j]) for j, h in enumerate(header) if h in required}
    del arr
    t = cols["time_s"]
    if t.size < 5:
        raise BenchDataError(f"{name}: only {t.size} data rows; at least 5 are needed")
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0))
        raise BenchDataError(f"{name}: row {k + 3}: time_s = {t[k + 1]:g} does not increase "
                             f"(previous row {t[k]:g}); time must be strictly increasing")
    xmax = float(np.max(np.abs(cols["displacement_m"])))
    if xmax > _MAX_DISPLACEMENT_M:
        k = int(np.argmax(np.abs(cols["displacement_m"])))
        raise BenchDataError(f"{name}: row {k + 2}, column 'displacement_m': |x| = {xmax:g} m "
                             f"is implausible for a damper; is it in mm? Convert to metres")
    return cols


def _resolve_inside(path: Path, file: str, where: str) -> Path:
    """``path / file``, refusing a name or symlink that leads out of the data directory."""
    root = path.resolve()
    target = (path / file).resolve()
    if Path(file).is_absolute() or not target.is_relative_to(root):
        how = ("a path that leads" if Path(file).is_absolute() or ".." in Path(file).parts
               else "a symlink that points")
        raise BenchDataError(f"{where}: 'file' = {file!r} is {how} outside the data directory "
                             f"{path} (to {target}); copy the CSV into the data directory and "
                             f"give its name")
    return target


def load_bench(path: str | Path, *, lenient: bool = False) -> BenchData:
    """Load and validate a bench data directory (strict).

    Parameters
    ----------
    path : path
        The data directory.
    lenient : bool
        Signals that contradict ``bench.toml`` by physics (:mod:`.checks`: frequency,
        amplitude, sample rate, units by range and consistency) give a
        :class:`BenchDataWarning` instead of an error.  Syntax errors, paths out of
        the directory and duplicates are refused either way.

    Raises
    ------
    BenchDataError
        Naming ``bench.toml`` or the CSV file, the key or row, and the fix.
    """
    path = Path(path)
    toml_path = path / "bench.toml"
    if not path.is_dir():
        raise BenchDataError(f"{path}: not a directory; give a data directory holding bench.toml")
    if not toml_path.is_file():
        raise BenchDataError(f"bench.toml: not found in {path}; a data directory needs a "
                             f"bench.toml listing its tests")
    try:
        doc = load_toml(toml_path)
    except ParameterError as exc:
        raise BenchDataError(f"bench.toml: {exc}") from None
    for key in doc:
        if key not in _TOP_KEYS:
            raise _unknown_key(key, _TOP_KEYS, "bench.toml")
    rig = doc.get("rig", {})
    if not isinstance(rig, dict):
        raise BenchDataError("bench.toml: [rig] must be a table")
    for key in rig:
        if key not in _RIG_KEYS:
            raise _unknown_key(key, _RIG_KEYS, "bench.toml [rig]")
    has_gen = rig.get("has_generator", True)
    if not isinstance(has_gen, bool):
        raise BenchDataError("bench.toml [rig]: 'has_generator' must be true or false")
    try:
        harvester = from_mapping(HarvesterParams, doc.get("harvester", {}),
                                 "bench.toml [harvester]")
    except ParameterError as exc:
        raise BenchDataError(str(exc)) from None
    entries = doc.get("test")
    if not entries:
        raise BenchDataError("bench.toml: no [[test]] entries; add one per CSV file")
    if not isinstance(entries, list):
        raise BenchDataError("bench.toml: 'test' must be an array of tables ([[test]])")
    tests: list[BenchTest] = []
    seen: dict[Path, str] = {}
    for n, entry in enumerate(entries, start=1):
        where = f"bench.toml [[test]] #{n}"
        if not isinstance(entry, dict):
            raise BenchDataError(f"{where}: must be a table")
        for key in entry:
            if key not in _TEST_KEYS:
                raise _unknown_key(key, _TEST_KEYS, where)
        file = entry.get("file")
        if not isinstance(file, str) or not file:
            raise BenchDataError(f"{where}: missing 'file' (the CSV name)")
        if not file.isprintable():
            raise BenchDataError(f"{where}: 'file' = {file!r} holds a control character (a NUL "
                                 f"or line break); give the plain CSV file name")
        where = f"bench.toml [[test]] #{n} ({file})"
        target = _resolve_inside(path, file, where)
        if target in seen:
            raise BenchDataError(f"{where}: file listed twice (as {seen[target]!r} before); "
                                 f"remove the duplicate [[test]] entry")
        seen[target] = file
        excitation = entry.get("excitation", "sine")
        if excitation not in _EXCITATIONS:
            raise BenchDataError(f"{where}: excitation '{excitation}' must be one of "
                                 f"{', '.join(_EXCITATIONS)}")
        values: dict[str, float | None] = {}
        for key in ("frequency_hz", "amplitude_m", "load_ohm"):
            needed = (key != "load_ohm" and excitation == "sine") or \
                (key == "load_ohm" and has_gen)
            if key in entry:
                values[key] = _check_number(entry[key], key, where)
            elif needed:
                raise BenchDataError(f"{where}: missing '{key}'"
                                     + (" (a rig with a generator needs the load of each test)"
                                        if key == "load_ohm" else
                                        " (sine tests need it; or set excitation = \"recorded\")"))
            else:
                values[key] = None
        run_order, started_at = parse_run_keys(entry, where, BenchDataError)
        cols = _read_csv(target, need_voltage=has_gen)
        tests.append(BenchTest(file=file, excitation=excitation,
                               frequency_hz=values["frequency_hz"],
                               amplitude_m=values["amplitude_m"], load_ohm=values["load_ohm"],
                               time_s=cols["time_s"], displacement_m=cols["displacement_m"],
                               force_N=cols["force_N"], voltage_V=cols.get("voltage_V"),
                               description=str(entry.get("description", "")),
                               run_order=run_order, started_at=started_at))
    check_run_sequence(tests, BenchDataError)
    problems = [m for t in tests for m in check_test_signals(
        t, harvester, has_generator=has_gen, harvester_given="harvester" in doc)]
    if problems and not lenient:
        shown = problems[:12] + ([f"... and {len(problems) - 12} more"] if len(problems) > 12
                                 else [])
        raise BenchDataError("\n".join(shown) + "\n(to use the data anyway, pass --lenient / "
                             "lenient=True: these become warnings)")
    for m in problems:
        warnings.warn(m, BenchDataWarning, stacklevel=2)
    return BenchData(path=path, tests=tests, harvester=harvester,
                     rig_name=str(rig.get("name", "")), description=str(rig.get("description", "")),
                     has_generator=has_gen)


def check_bench(path: str | Path, *, lenient: bool = False) -> str:
    """Validate a data directory; return a one-paragraph summary or raise BenchDataError.

    With ``lenient``, physics problems are listed in the summary as warnings.
    """
    data, notes = load_bench_checked(path, lenient=lenient)
    return check_summary(data, notes)


def load_bench_checked(path: str | Path, *, lenient: bool = False
                       ) -> tuple[BenchData, list[str]]:
    """:func:`load_bench` and the warnings it gave (``lenient``: physics problems as
    warnings instead of errors), as text."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", BenchDataWarning)
        data = load_bench(path, lenient=lenient)
    return data, [str(w.message) for w in caught if issubclass(w.category, BenchDataWarning)]


def check_summary(data: BenchData, notes: Iterable[str] = ()) -> str:
    """The summary ``ehsa-opt bench check`` prints: tests, samples, rig, and ``OK`` or
    the warnings (``notes``)."""
    notes = list(notes)
    n = sum(t.n_samples for t in data.tests)
    kind = "with generator" if data.has_generator else "without generator (no voltage)"
    head = (f"{data.path}: {len(data.tests)} tests, {n} samples, rig "
            f"'{data.rig_name or 'unnamed'}' {kind}")
    if notes:
        return head + f": {len(notes)} warning(s) (--lenient)\n" + "\n".join(
            f"warning: {m}" for m in notes)
    return head + ": OK"


# ------------------------------------------------------------------ writing
#: Written last into every directory :func:`write_bench` makes: the names it wrote, so
#: ``--overwrite`` replaces only a directory ehsa-opt wrote and nobody has added to.
MARKER_NAME = ".ehsa_opt_bench.json"
_MARKER_FORMAT = "ehsa_opt bench directory"


def write_marker(d: Path) -> None:
    """List every name in ``d`` in its marker (:func:`~ehsa_opt.utils.output_folder.write_listing`)."""
    write_listing(d, MARKER_NAME, _MARKER_FORMAT)


def foreign_content(d: Path) -> str | None:
    """Why ``--overwrite`` may not replace directory ``d`` (None: ehsa-opt wrote all of it):
    :func:`~ehsa_opt.utils.output_folder.unlisted_content` of its marker."""
    return unlisted_content(d, MARKER_NAME, _MARKER_FORMAT)


def _harvester_table(h: HarvesterParams) -> dict[str, float]:
    default = HarvesterParams()
    return {k: getattr(h, k) for k in default.__dataclass_fields__
            if k != "load_ohm" and getattr(h, k) != getattr(default, k)}


def _csv_text(test: BenchTest, fmt: str = "%.9g") -> str:
    cols = [test.time_s, test.displacement_m, test.force_N]
    header = list(COLUMNS[:3])
    if test.voltage_V is not None:
        cols.append(test.voltage_V)
        header.append("voltage_V")
    buf = io.StringIO()
    np.savetxt(buf, np.column_stack(cols), delimiter=",", fmt=fmt, header=",".join(header),
               comments="")
    return buf.getvalue()


def write_bench(path: str | Path, tests: list[BenchTest], *,
                harvester: HarvesterParams | None = None, rig: dict[str, Any] | None = None,
                extra_files: dict[str, str] | None = None, overwrite: bool = False) -> Path:
    """Write a data directory atomically (temporary directory + rename).

    Parameters
    ----------
    path : path
        Target directory; must not exist or be empty unless ``overwrite``.
    tests : list of BenchTest
    harvester : HarvesterParams, optional
        Written to ``[harvester]`` (only the fields that differ from Table 1).
    rig : dict, optional
        ``[rig]`` table (name, has_generator, description).
    extra_files : dict, optional
        Additional text files (name → content), e.g. ``truth.toml``, ``README.md``.
    overwrite : bool
        Replace an existing non-empty directory.
    """
    path = Path(path)
    if path.is_symlink() or (path.exists() and not path.is_dir()):
        raise FileExistsError(f"{path}: exists and is not a directory (or is a symlink); "
                              f"choose a new directory")
    if path.exists() and any(path.iterdir()):
        problem = foreign_content(path)
        if problem:
            raise FileExistsError(f"{path}: directory exists, is not empty and {problem}; "
                                  f"nothing was "
                                  f"changed. Choose a new directory (or empty this one "
                                  f"yourself)")
        if not overwrite:
            raise FileExistsError(f"{path}: directory exists and is not empty (bench data "
                                  f"written by ehsa-opt); choose a new directory or pass overwrite=True "
                                  f"(--overwrite) to replace it")
    if not tests:
        raise ValueError("write_bench: no tests to write")
    check_run_sequence(tests, ValueError)
    doc: dict[str, Any] = {}
    if rig:
        doc["rig"] = dict(rig)
    if harvester is not None and _harvester_table(harvester):
        doc["harvester"] = _harvester_table(harvester)
    entries = []
    for t in tests:
        e: dict[str, Any] = {"file": t.file}
        if t.excitation != "sine":
            e["excitation"] = t.excitation
        for key in ("frequency_hz", "amplitude_m", "load_ohm"):
            if getattr(t, key) is not None:
                e[key] = float(getattr(t, key))
        if t.description:
            e["description"] = t.description
        for key in RUN_KEYS:
            if getattr(t, key) is not None:
                e[key] = getattr(t, key)
        entries.append(e)
    doc["test"] = entries
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    try:
        tmp.chmod(0o755)
        (tmp / "bench.toml").write_text(tomli_w.dumps(doc), encoding="utf-8")
        for t in tests:
            (tmp / t.file).write_text(_csv_text(t), encoding="utf-8")
        for name, content in (extra_files or {}).items():
            (tmp / name).write_text(content, encoding="utf-8")
        write_marker(tmp)
        if path.exists():
            old = path.with_name(f".{path.name}.old-{os.getpid()}")
            os.replace(path, old)
            os.replace(tmp, path)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return path
