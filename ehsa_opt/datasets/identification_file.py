"""An ``identification.json`` as received: read once through the shared limits, then
validated whole, so that every reader — the CLI's ``--friction`` and ``[friction] from``,
``plan-tests``, the library's ``IdentificationReport.from_json`` /
``FrictionBounds.from_json`` / ``RodLawFit.from_dict`` — refuses the same files with the
same message (file, key, fix) and accepts nothing forged or damaged as a result.

What is checked (each table when present; files of earlier versions lack some):

* the file: size (:data:`~ehsa_opt.utils.limits.MAX_TEXT_FILE_BYTES`), encoding
  (UTF-8; UTF-16/32 decoded; another refused naming the byte), nesting, standard JSON;
* ``friction_sets``: the three cases complete and physical
  (:func:`friction_set`) and **ordered**: the rod
  friction of ``min`` ≤ ``best`` ≤ ``max`` at every velocity up to
  :data:`ORDER_CHECK_MAX_M_PER_S` (:data:`ORDER_TOLERANCE_N`); swapped sets are refused;
* ``velocity_range``: finite, ordered, physical (≤ :data:`MAX_STROKE_VELOCITY_M_PER_S`),
  and the campaign's top equal to the fastest test's peak;
* ``friction_envelope``: a finite increasing grid, every curve as long as the grid, a
  physical lead, the law (:func:`check_law`);
* the law: its eight parameters physical, ``free`` known names, every covariance a finite
  symmetric positive semi-definite matrix over ``free``, ≥ 1 sample and effective samples
  ≥ 1 and ≤ samples;
* ``tests``, ``bounds``, ``joint_fit``: the types the reload needs (names checked with the
  nearest valid one).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..physics.base_parameters import PARAMETERS
from ..physics.friction import FRICTION_LAWS
from ..physics.friction import rod_friction_N
from ..physics.params import (
    FRICTION_NAMES,
    ParameterError,
    check_keys,
    from_mapping,
    nearest_name,
)
from .friction_sets import FRICTION_CASES, FrictionSets, friction_set
from ..utils.limits import parse_json, read_input_text

__all__ = ["read_identification", "check_identification", "check_law", "check_velocity_range",
           "campaign_range_m_per_s", "MAX_STROKE_VELOCITY_M_PER_S", "ORDER_CHECK_MAX_M_PER_S",
           "ORDER_TOLERANCE_N", "PSD_TOLERANCE", "RERUN", "identified_lead_m_per_rad",
           "bench_harvester", "FRICTION_CASES", "FrictionSets", "friction_set"]


#: Largest stroke velocity a bench test or an identified range may state, m/s: the fastest
#: servo-hydraulic damper rigs reach about 5 m/s; twice that is no measurement.
MAX_STROKE_VELOCITY_M_PER_S = 10.0
#: Velocity up to which ``min <= best <= max`` is checked, m/s: the vehicle studies'
#: largest stroke velocity, up to which the identification builds the sets ordered.
ORDER_CHECK_MAX_M_PER_S = 3.0
#: Rod-friction slack of the order check, N (the sets are ordered by construction to
#: 1e-9 N; JSON keeps the floats exactly).
ORDER_TOLERANCE_N = 1e-6
#: Smallest eigenvalue of a covariance accepted, relative to its largest: round-off of a
#: sandwich product reaches ~1e-12; −1e-8 still is round-off, anything below is forged.
PSD_TOLERANCE = 1e-8
#: The fix for a damaged result.
RERUN = "re-run `ehsa-opt identify` (or restore the file it wrote)"


def _fail(where: str, what: str) -> ParameterError:
    return ParameterError(f"{where}: {what}; {RERUN}")


def _number(v: Any, where: str, *, lo: float | None = None, lo_open: bool = False,
            hi: float | None = None, none: bool = False) -> float | None:
    """A finite JSON number in [lo, hi] (or None when ``none``)."""
    if v is None and none:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise _fail(where, f"{_shown(v)} is not a finite number")
    if lo is not None and (v <= lo if lo_open else v < lo):
        raise _fail(where, f"{v!r} must be {'>' if lo_open else '>='} {lo:g}")
    if hi is not None and v > hi:
        raise _fail(where, f"{v!r} must be <= {hi:g}")
    return float(v)


def _shown(v: Any) -> str:
    text = "null" if v is None else repr(v)
    return text if len(text) <= 40 else text[:40] + "..."


def _kind(v: Any) -> str:
    """The JSON name of a value's type."""
    return ("null" if v is None else "true/false" if isinstance(v, bool) else
            "a number" if isinstance(v, (int, float)) else "text" if isinstance(v, str) else
            "a list" if isinstance(v, list) else "a table" if isinstance(v, Mapping) else
            type(v).__name__)


def _table(v: Any, where: str) -> Mapping[str, Any]:
    if not isinstance(v, Mapping):
        raise _fail(where, f"must be a table (JSON object), got {_kind(v)}")
    return v


def _list(v: Any, where: str, n: int | None = None) -> list:
    if not isinstance(v, list):
        raise _fail(where, f"must be a list, got {_kind(v)}")
    if n is not None and len(v) != n:
        raise _fail(where, f"has {len(v)} values, expected {n}")
    return v


def _curve(v: Any, where: str, n: int) -> None:
    """A list of ``n`` finite numbers or nulls (NaN is written as null)."""
    for k, x in enumerate(_list(v, where, n)):
        _number(x, f"{where}[{k}]", none=True)


def read_identification(path: str | Path) -> dict[str, Any]:
    """The validated document of an ``identification.json`` (:func:`check_identification`).

    Raises
    ------
    ParameterError
        Naming the file, the key and the fix.
    """
    path = Path(path)
    if not path.is_file():
        raise ParameterError(f"{path}: identification result not found; make one with "
                             f"`ehsa-opt identify DATA_DIR --out DIR` (DIR/identification.json)")
    text = read_input_text(path, "identification result", ParameterError)
    try:
        doc = parse_json(text, str(path), ParameterError)
    except ParameterError as exc:
        raise ParameterError(f"{exc}; pass the identification.json written by "
                             f"`ehsa-opt identify`") from None
    return check_identification(doc, str(path))


def check_identification(doc: Any, where: str = "identification result") -> dict[str, Any]:
    """``doc`` itself when every table present is valid (module docstring)."""
    if not isinstance(doc, Mapping):
        raise ParameterError(f"{where}: not an identification result (a JSON object with "
                             f"'friction_sets', 'tests', ...); pass the identification.json "
                             f"written by `ehsa-opt identify`")
    lead = None
    env = doc.get("friction_envelope")
    if env is not None:
        lead = _check_envelope(_table(env, f"{where} friction_envelope"),
                               f"{where} friction_envelope")
    if doc.get("velocity_range") is not None:
        check_velocity_range(doc["velocity_range"], f"{where} velocity_range")
    if doc.get("friction_sets") is not None:
        _check_sets(doc["friction_sets"], f"{where} friction_sets", lead)
    _check_report_tables(doc, where)
    return dict(doc)


def campaign_range_m_per_s(rng: Any, where: str) -> tuple[float, float]:
    """A velocity range ``[low, high]``: finite, 0 <= low < high <= the physical limit."""
    pair = _list(rng, where, 2)
    lo = _number(pair[0], f"{where}[0]", lo=0.0)
    hi = _number(pair[1], f"{where}[1]", lo=0.0, lo_open=True, hi=MAX_STROKE_VELOCITY_M_PER_S)
    assert lo is not None and hi is not None
    if not lo < hi:
        raise _fail(where, f"[{lo:g}, {hi:g}] is not ordered (low < high)")
    return lo, hi


def check_velocity_range(table: Any, where: str) -> tuple[float, float] | None:
    """The ``velocity_range`` table: the campaign's range (``campaign_range_m_per_s``),
    the tests' peaks (positive, ≤ the physical limit), the campaign's top = the fastest
    peak.  Returns the campaign's range (None when the table has none)."""
    table = _table(table, where)
    check_keys(table, ("description", "campaign_m_per_s", "tests_peak_m_per_s"), where)
    peaks = table.get("tests_peak_m_per_s")
    top = None
    if peaks is not None:
        vals = [_number(v, f"{where}.tests_peak_m_per_s.{k}", lo=0.0, lo_open=True,
                        hi=MAX_STROKE_VELOCITY_M_PER_S)
                for k, v in _table(peaks, f"{where}.tests_peak_m_per_s").items()]
        top = max((v for v in vals if v is not None), default=None)
    if table.get("campaign_m_per_s") is None:
        return None
    lo, hi = campaign_range_m_per_s(table["campaign_m_per_s"], f"{where}.campaign_m_per_s")
    if top is not None and not math.isclose(hi, top, rel_tol=1e-9):
        raise _fail(f"{where}.campaign_m_per_s", f"its top {hi:g} m/s is not the fastest "
                    f"test's peak ({top:g} m/s in tests_peak_m_per_s)")
    return lo, hi


def _check_envelope(env: Mapping[str, Any], where: str) -> float | None:
    """The envelope's grid, curves, lead and law; returns the lead (m/rad; None when
    the table gives none)."""
    n = 0
    if env.get("velocity_m_per_s") is not None:
        grid = _list(env["velocity_m_per_s"], f"{where}.velocity_m_per_s")
        if not grid:
            raise _fail(f"{where}.velocity_m_per_s", "is empty")
        v = np.array([_number(x, f"{where}.velocity_m_per_s[{k}]", lo=0.0, lo_open=True,
                              hi=MAX_STROKE_VELOCITY_M_PER_S) for k, x in enumerate(grid)])
        if np.any(np.diff(v) <= 0):
            k = int(np.argmax(np.diff(v) <= 0)) + 1
            raise _fail(f"{where}.velocity_m_per_s[{k}]", f"{v[k]:g} does not increase")
        n = v.size
    for key in ("lower_N", "upper_N", "mean_N", "mean_ci95_low_N", "mean_ci95_high_N"):
        if env.get(key) is not None:
            _curve(env[key], f"{where}.{key}", n)
    for key in ("sets_rod_N", "per_test_N"):
        for name, c in _table(env.get(key) or {}, f"{where}.{key}").items():
            _curve(c, f"{where}.{key}.{name}", n)
    lead = _number(env.get("lead_m_per_rad"), f"{where}.lead_m_per_rad", lo=0.0, lo_open=True,
                   hi=_MAX_LEAD_M_PER_RAD, none=True)
    rng = env.get("identified_range_m_per_s")
    if rng is not None and rng != [None, None]:  # [null, null]: no range (NaN)
        campaign_range_m_per_s(env["identified_range_m_per_s"],
                               f"{where}.identified_range_m_per_s")
    band = env.get("extrapolation_band")
    if band is not None:
        band = _table(band, f"{where}.extrapolation_band")
        for key in ("law_low_N", "law_high_N", "margin_low_N", "margin_high_N"):
            if band.get(key) is not None:
                _curve(band[key], f"{where}.extrapolation_band.{key}", n)
        if band.get("level") is not None:
            level = _number(band["level"], f"{where}.extrapolation_band.level", lo=0.0,
                            lo_open=True)
            if not level < 1.0:  # type: ignore[operator]
                raise _fail(f"{where}.extrapolation_band.level", f"{level} must be < 1")
        if band.get("law") is not None:
            law = check_law(band["law"], f"{where}.extrapolation_band.law")
            if lead is None:
                lead = float(law["lead_m_per_rad"])
            elif not math.isclose(float(law["lead_m_per_rad"]), float(lead), rel_tol=1e-9):
                raise _fail(f"{where}.extrapolation_band.law.lead_m_per_rad",
                            f"{law['lead_m_per_rad']} is not the envelope's lead_m_per_rad "
                            f"({lead})")
    paper = env.get("paper_method")
    if paper is not None:
        paper = _table(paper, f"{where}.paper_method")
        for c in ("min", "max"):
            if paper.get(c) is not None:
                friction_set(_table(paper[c], f"{where}.paper_method.{c}"),
                             f"{where}.paper_method.{c}")
        for name, c in _table(paper.get("rod_N") or {}, f"{where}.paper_method.rod_N").items():
            _curve(c, f"{where}.paper_method.rod_N.{name}", n)
    return lead


#: The largest lead a harvester may have (200 mm/rev, :class:`HarvesterParams`), m/rad.
_MAX_LEAD_M_PER_RAD = 0.2 / (2 * math.pi)


def _check_sets(table: Any, where: str, lead: float | None) -> None:
    """The three cases physical (``FrictionSets.from_dict``) and ordered in rod friction."""
    from ..physics.params import HarvesterParams
    check_keys(table, ("min", "best", "max", "method", "paper_min", "paper_max"), where)
    sets = FrictionSets.from_dict(table, where)
    r = lead if lead is not None else HarvesterParams().lead_m_per_rad
    v = np.concatenate([np.geomspace(1e-6, 1e-2, 60), np.linspace(1e-2, ORDER_CHECK_MAX_M_PER_S,
                                                                  150)])
    rod = {c: np.asarray(rod_friction_N(v, getattr(sets, c), r), dtype=float)
           for c in ("min", "best", "max")}
    for lo, hi in (("min", "best"), ("best", "max")):
        bad = rod[lo] > rod[hi] + ORDER_TOLERANCE_N
        if bad.any():
            k = int(np.argmax(bad))
            raise _fail(where, f"the rod friction of '{lo}' is above that of '{hi}' at "
                        f"{v[k]:.3g} m/s ({rod[lo][k]:.4g} N > {rod[hi][k]:.4g} N): the sets "
                        f"must be ordered min <= best <= max at every velocity (were they "
                        f"swapped or edited?)")
    if sets.paper_min is not None and sets.paper_max is not None:
        for n in FRICTION_NAMES:
            if getattr(sets.paper_min, n) > getattr(sets.paper_max, n):
                raise _fail(f"{where}.paper_min", f"{n} is above paper_max's (the paper's "
                            f"per-parameter minimum must not exceed its maximum)")


def check_law(d: Any, where: str) -> Mapping[str, Any]:
    """The rod-friction law of ``extrapolation_band.law`` (module docstring); ``d``."""
    d = _table(d, where)
    if "free" not in d and "varied" not in d:
        raise _fail(where, "no 'free' list of the law's parameters")
    for key in ("parameters", "covariance", "covariance_iid", "lead_m_per_rad", "n_samples",
                "n_effective"):
        if key not in d:
            raise _fail(where, f"no '{key}'")
    friction_set(_table(d["parameters"], f"{where}.parameters"), f"{where}.parameters")
    free = _list(d.get("free", d.get("varied")), f"{where}.free")
    for k, name in enumerate(free):
        if name not in FRICTION_NAMES:
            near = nearest_name(str(name), FRICTION_NAMES) if isinstance(name, str) else None
            raise _fail(f"{where}.free[{k}]", f"unknown parameter {_shown(name)}"
                        + (f"; did you mean '{near}'?" if near else "")
                        + f" (valid: {', '.join(FRICTION_NAMES)})")
    if not free or len(set(free)) != len(free):
        raise _fail(f"{where}.free", "must name each free parameter once (at least one)")
    for key in ("covariance", "covariance_iid", "covariance_cluster"):
        if key == "covariance_cluster" and d.get(key) is None:
            continue
        _covariance(d.get(key), f"{where}.{key}", free)
    _number(d["lead_m_per_rad"], f"{where}.lead_m_per_rad", lo=0.0, lo_open=True,
            hi=_MAX_LEAD_M_PER_RAD)
    ns = d["n_samples"]
    if isinstance(ns, bool) or not isinstance(ns, int) or ns < 1:
        raise _fail(f"{where}.n_samples", f"{_shown(ns)} must be a whole number >= 1")
    _number(d["n_effective"], f"{where}.n_effective", lo=1.0, hi=float(ns))
    nt = d.get("n_tests", 1)
    if isinstance(nt, bool) or not isinstance(nt, int) or nt < 1:
        raise _fail(f"{where}.n_tests", f"{_shown(nt)} must be a whole number >= 1")
    if d.get("velocity_range_m_per_s") is not None:
        campaign_range_m_per_s(d["velocity_range_m_per_s"], f"{where}.velocity_range_m_per_s")
    # a least-squares law on measured samples leaves a residual: zero is no fit of data
    _number(d.get("residual_rms_N"), f"{where}.residual_rms_N", lo=0.0, lo_open=True,
            none=True)
    for key in ("test_residual_rms_N", "test_peak_acceleration_m_per_s2"):
        for k, x in enumerate(_list(d.get(key, []), f"{where}.{key}")):
            _number(x, f"{where}.{key}[{k}]", lo=0.0, none=True)
    n_k = _list(d.get("test_n_samples", []), f"{where}.test_n_samples")
    neff_k = _list(d.get("test_n_effective", []), f"{where}.test_n_effective", len(n_k))
    for k, (x, e) in enumerate(zip(n_k, neff_k)):  # each test: 1 <= effective <= samples
        hi = _number(x, f"{where}.test_n_samples[{k}]", lo=1.0)
        _number(e, f"{where}.test_n_effective[{k}]", lo=1.0, hi=hi)
    for k, x in enumerate(_list(d.get("bandwidths", []), f"{where}.bandwidths")):
        if isinstance(x, bool) or not isinstance(x, int) or x < 0:
            raise _fail(f"{where}.bandwidths[{k}]", f"{_shown(x)} must be a whole number >= 0")
    for k, a in enumerate(_list(d.get("alternatives", []), f"{where}.alternatives")):
        friction_set(_table(a, f"{where}.alternatives[{k}]"), f"{where}.alternatives[{k}]")
    if d.get("weighted") is not None:
        friction_set(_table(d["weighted"], f"{where}.weighted"), f"{where}.weighted")
    return d


def _covariance(c: Any, where: str, free: list[str]) -> None:
    """A finite symmetric positive semi-definite matrix over ``free`` whose standard
    deviations stay within each parameter's physical range (a larger one says nothing
    and overflows the planning's products)."""
    n = len(free)
    rows = _list(c, where, n)
    for i, row in enumerate(rows):
        for j, x in enumerate(_list(row, f"{where}[{i}]", n)):
            _number(x, f"{where}[{i}][{j}]")
    a = np.array(rows, dtype=float)
    for i, name in enumerate(free):
        top = PARAMETERS[name].bounds[1]
        if not a[i, i] <= top * top:
            raise _fail(f"{where}[{i}][{i}]", f"the standard deviation of {name} "
                        f"({math.sqrt(max(a[i, i], 0.0)):.3g}) exceeds its physical range "
                        f"(<= {top:g})")
    scale = float(np.max(np.abs(a)))
    if scale == 0.0:
        raise _fail(where, "is zero: a law fitted on noisy samples has an uncertainty")
    a = a / scale
    if not np.allclose(a, a.T, rtol=1e-9, atol=1e-12):
        raise _fail(where, "is not symmetric")
    try:
        ev = np.linalg.eigvalsh(a)
    except np.linalg.LinAlgError:
        raise _fail(where, "has no eigenvalues (not a covariance)") from None
    if ev.min() < -PSD_TOLERANCE * max(ev.max(), 0.0) or ev.max() <= 0.0:
        raise _fail(where, f"is not positive semi-definite (eigenvalue {ev.min() * scale:.3g} "
                    f"< 0): a variance cannot be negative")


def _check_report_tables(doc: Mapping[str, Any], where: str) -> None:
    """``tests``, ``bounds``, ``joint_fit``, ``data_dir`` as the report's reload needs."""
    if "data_dir" in doc and not isinstance(doc["data_dir"], str):
        raise _fail(f"{where} data_dir", "must be the path of the bench data (text)")
    names = tuple(PARAMETERS)
    for k, t in enumerate(_list(doc.get("tests", []), f"{where} tests")):
        w = f"{where} tests[{k}]"
        t = _table(t, w)
        if not isinstance(t.get("file"), str):
            raise _fail(w, "no 'file' (the test's CSV name)")
        if not isinstance(t.get("success"), bool):
            raise _fail(w, "'success' must be true or false")
        _check_fit_fields(t, w, names)
    for name, pair in _table(doc.get("bounds", {}), f"{where} bounds").items():
        if name not in names:
            check_keys({name: 0}, names, f"{where} bounds")
        lo, hi = (_number(x, f"{where} bounds.{name}[{j}]")
                  for j, x in enumerate(_list(pair, f"{where} bounds.{name}", 2)))
        if lo > hi:  # type: ignore[operator]
            raise _fail(f"{where} bounds.{name}", f"[{lo:g}, {hi:g}] is not ordered (min <= "
                        f"max)")
    j = doc.get("joint_fit")
    if j is not None:
        j = _table(j, f"{where} joint_fit")
        if not isinstance(j.get("success"), bool):
            raise _fail(f"{where} joint_fit", "'success' must be true or false")
        _check_fit_fields(j, f"{where} joint_fit", names)
        for key in ("train", "holdout"):
            for k, r in enumerate(_list(j.get(key, []), f"{where} joint_fit.{key}")):
                _table(r, f"{where} joint_fit.{key}[{k}]")
        for k, f in enumerate(_list(j.get("holdout_files", []),
                                    f"{where} joint_fit.holdout_files")):
            if not isinstance(f, str):
                raise _fail(f"{where} joint_fit.holdout_files[{k}]", "must be a file name")
    if doc.get("identifiable") is not None:
        _table(doc["identifiable"], f"{where} identifiable")
    for key in ("seconds", "starts_per_test"):
        _number(doc.get(key), f"{where} {key}", lo=0.0, none=True)
    law = doc.get("friction_law")
    if law is not None and law not in FRICTION_LAWS:
        raise _fail(f"{where} friction_law", f"{_shown(law)} is not a friction law (one of "
                    f"{', '.join(FRICTION_LAWS)})")


def _check_fit_fields(t: Mapping[str, Any], w: str, names: tuple[str, ...]) -> None:
    """One fit's parameters (known names, numbers or null) and its numeric fields."""
    params = t.get("parameters")
    if params is not None:
        params = _table(params, f"{w}.parameters")
        check_keys(params, names, f"{w}.parameters")
        for n, x in params.items():
            _number(x, f"{w}.parameters.{n}", none=True)
    for key in ("delta_F", "delta_V", "force_relative_error_percent", "objective", "seconds"):
        _number(t.get(key), f"{w}.{key}", none=True)
    nit = t.get("nit")
    if nit is not None and (isinstance(nit, bool) or not isinstance(nit, int)):
        raise _fail(f"{w}.nit", f"{_shown(nit)} must be a whole number")
    for key in ("message", "status", "path"):
        if t.get(key) is not None and not isinstance(t[key], str):
            raise _fail(f"{w}.{key}", "must be text")
    for key in ("history", "identifiability"):
        if t.get(key) is not None:
            _table(t[key], f"{w}.{key}")
    for key in ("starts", "per_test", "free"):
        if t.get(key) is not None:
            _list(t[key], f"{w}.{key}")
    if t.get("free") is not None:
        for k, n in enumerate(t["free"]):
            if n not in names:
                check_keys({str(n): 0}, names, f"{w}.free")


def identified_lead_m_per_rad(doc: Mapping[str, Any]) -> float | None:
    """The screw lead (m/rad) the identification used (the envelope's, else the law's)."""
    env = doc.get("friction_envelope")
    if isinstance(env, Mapping):
        law = (env.get("extrapolation_band") or {}).get("law")
        for src in (env, law if isinstance(law, Mapping) else {}):
            if src.get("lead_m_per_rad") is not None:
                return float(src["lead_m_per_rad"])
    return None


def bench_harvester(doc: Mapping[str, Any], path: str | Path) -> tuple[Any, dict[str, Any]]:
    """The harvester of the bench data an identification was made on, and its
    ``[harvester]`` table (empty: the Table 1 defaults, as the identification used).

    ``data_dir`` is resolved against the identification file's folder (absolute paths as
    they are); the folder and its ``bench.toml`` must exist, and the harvester's lead must
    be the one stored in the identification (the data of another rig are refused).

    Raises
    ------
    ParameterError
        Naming the file, ``data_dir`` and the fix.
    """
    from ..physics.params import HarvesterParams, from_mapping, load_toml
    path = Path(path)
    ref = doc.get("data_dir")
    if not isinstance(ref, str) or not ref or not ref.isprintable():
        raise _fail(f"{path} data_dir", "no path of the bench data it was identified on")
    data = Path(ref) if Path(ref).is_absolute() else path.parent / ref
    fix = (f"point data_dir in {path} at the bench data folder it was identified on "
           f"(absolute, or relative to {path.parent.resolve()}), or re-run `ehsa-opt identify`")
    if not (data / "bench.toml").is_file():
        raise ParameterError(f"{path} data_dir: {ref!r} ({data.resolve()}) holds no "
                             f"bench.toml — the bench data moved or were deleted; the "
                             f"harvester of the bench is needed; {fix}")
    bench = data / "bench.toml"
    table = load_toml(bench, "bench file").get("harvester") or {}
    if not isinstance(table, Mapping):
        raise ParameterError(f"{bench}: [harvester] must be a table of key = value pairs")
    harvester = from_mapping(HarvesterParams, table, f"{bench} [harvester]")
    lead = identified_lead_m_per_rad(doc)
    if lead is not None and not math.isclose(lead, harvester.lead_m_per_rad, rel_tol=1e-9):
        raise ParameterError(f"{path} data_dir: the lead of {bench} "
                             f"({harvester.lead_mm_per_rev:g} mm/rev = "
                             f"{harvester.lead_m_per_rad:.6g} m/rad) is not the lead the "
                             f"identification used ({lead:.6g} m/rad): these are not the "
                             f"bench data it was identified on; {fix}")
    return harvester, dict(table)
