"""Friction from an identification result: one meaning of ``min`` / ``best`` / ``max``
everywhere (``simulate``, ``sweep``, ``optimize``, ``reproduce``).

An ``identification.json`` written by ``ehsa-opt identify`` carries a table
``friction_sets`` with one :class:`~ehsa_opt.physics.params.FrictionParams` per case
(the friction parameters' field names, and under the LuGre law ``friction_law`` with
the presliding parameters)::

    "friction_sets": {"min": {"nut_coulomb_N": ..., ...}, "best": {...}, "max": {...},
                      "method": "..."}

A problem file refers to it with ``[friction] from = "out/identification.json"`` and
``case = "min" | "best" | "max"`` (path relative to the problem file); the CLI with
``--friction FILE[:CASE]`` (case ``best`` by default).  The file is read and validated by
:mod:`ehsa_opt.datasets.identification_file`; :class:`FrictionSets` and
:func:`friction_set` live in :mod:`ehsa_opt.datasets.friction_sets` (re-exported here).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

from ..physics.params import FrictionParams, ParameterError, from_mapping
from .friction_sets import FRICTION_CASES, FrictionSets, friction_set
from .identification_file import campaign_range_m_per_s, read_identification

__all__ = ["FRICTION_CASES", "FrictionSets", "parse_friction_spec", "load_friction_sets", "load_friction",
           "friction_from_table", "load_velocity_range", "identified_range_for",
           "embedded_range_m_per_s", "RANGE_SOURCE_EMBEDDED", "identified_range_kw",
           "friction_set", "resolve_reference"]


def parse_friction_spec(spec: str | Path) -> tuple[Path, str]:
    """Split ``FILE[:CASE]`` into the file and the case (default ``best``)."""
    text = str(spec)
    path, sep, case = text.rpartition(":")
    if not sep or case not in FRICTION_CASES:
        if sep and not Path(text).exists() and "/" not in case:
            raise ParameterError(f"--friction {text}: unknown case '{case}'; use "
                                 f"FILE:{'|'.join(FRICTION_CASES)}")
        return Path(text), "best"
    return Path(path), case


def load_friction_sets(path: str | Path) -> dict[str, FrictionParams]:
    """The ``min``/``best``/``max`` friction sets of an ``identification.json``.

    Raises
    ------
    ParameterError
        File missing or unreadable, not JSON, or without ``friction_sets`` (with the
        command that makes one).
    """
    path = Path(path)
    doc = read_identification(path)
    sets = doc.get("friction_sets")
    if not isinstance(sets, Mapping):
        note = doc.get("friction_sets_note")
        raise ParameterError(f"{path}: no 'friction_sets' table "
                             + (f"({note}) " if isinstance(note, str) else
                                "(written by an older ehsa_opt or not an identification "
                                "result)")
                             + "; re-run `ehsa-opt identify`")
    fs = FrictionSets.from_dict(sets, f"{path} friction_sets")
    return {case: getattr(fs, case) for case in FRICTION_CASES}


def load_friction(spec: str | Path, case: str | None = None) -> FrictionParams:
    """One friction set from ``FILE[:CASE]`` (or ``FILE`` and ``case``)."""
    path, parsed = parse_friction_spec(spec)
    case = case or parsed
    if case not in FRICTION_CASES:
        raise ParameterError(f"{path}: unknown friction case '{case}'; use one of "
                             f"{', '.join(FRICTION_CASES)}")
    return load_friction_sets(path)[case]


def friction_from_table(table: Mapping[str, Any], where: str,
                        base_dir: str | Path = ".") -> FrictionParams:
    """A problem file's ``[friction]`` table: either the eight values, or ``from`` (an
    identification.json, relative to ``base_dir``) with an optional ``case``."""
    if not isinstance(table, Mapping):
        raise ParameterError(f"{where}: [friction] must be a table")
    if "from" not in table:
        return from_mapping(FrictionParams, table, where)
    extra = sorted(set(table) - {"from", "case"})
    if extra:
        raise ParameterError(f"{where}: with 'from', only 'case' may be given (found "
                             f"{', '.join(extra)}); put the values in [friction] or use 'from'")
    src, case = table["from"], table.get("case", "best")
    if not isinstance(src, str) or not isinstance(case, str):
        raise ParameterError(f"{where}: 'from' and 'case' must be strings, e.g. from = "
                             f"\"out/identification.json\", case = \"max\"")
    path = resolve_reference(src, base_dir, f"{where} from")
    try:
        return load_friction(path, case)
    except ParameterError as exc:
        raise ParameterError(f"{where}: {exc}") from None


def load_velocity_range(path: str | Path) -> float | None:
    """Upper end (m/s) of the stroke velocities an ``identification.json``'s data cover
    (``velocity_range.campaign_m_per_s``; for files written before it, the envelope's
    largest velocity), or None when the file has neither."""
    path = Path(path)
    doc = read_identification(path)  # every table validated: the range is finite, ordered
    rng = doc.get("velocity_range")
    if isinstance(rng, Mapping) and rng.get("campaign_m_per_s") is not None:
        return campaign_range_m_per_s(rng["campaign_m_per_s"],
                                      f"{path} velocity_range.campaign_m_per_s")[1]
    env = doc.get("friction_envelope")
    if isinstance(env, Mapping) and env.get("velocity_m_per_s"):
        return float(env["velocity_m_per_s"][-1])  # validated: increasing
    return None


def identified_range_for(friction_specs: Any = (), problem_path: str | Path | None = None
                         ) -> tuple[float, str]:
    """The identified range (m/s) that a vehicle result's friction rests on, and where it
    comes from: the smallest of the ``--friction FILE[:CASE]`` files' ranges, else the
    problem file's ``[friction] from``, else the embedded bench campaign's."""
    specs = [friction_specs] if isinstance(friction_specs, (str, Path)) else \
        list(friction_specs or ())
    found = []
    for spec in specs:
        file, _ = parse_friction_spec(spec)
        v = load_velocity_range(file)
        if v is not None:
            found.append((v, f"identified range of {file}"))
    if not found and problem_path is not None:
        from ..physics.params import load_toml
        try:
            doc = load_toml(problem_path)
        except (OSError, ParameterError, ValueError):
            doc = {}
        tab = doc.get("friction") if isinstance(doc, Mapping) else None
        if isinstance(tab, Mapping) and isinstance(tab.get("from"), str):
            src = Path(tab["from"])
            src = src if src.is_absolute() else Path(problem_path).parent / src
            v = load_velocity_range(src)
            if v is not None:
                found.append((v, f"identified range of {src}"))
    if found:
        return min(found)
    return embedded_range_m_per_s(), RANGE_SOURCE_EMBEDDED


RANGE_SOURCE_EMBEDDED = ("the embedded bench campaign's range (friction not from an "
                         "identification: typed values are assumed to rest on data like it)")


def embedded_range_m_per_s() -> float:
    """Peak stroke velocity of the embedded bench campaign (largest 2π f A of its sine
    tests), m/s."""
    import math

    from ..physics.params import load_toml
    # the package's own data folder (not through .embedded, which imports this module)
    doc = load_toml(Path(__file__).resolve().parent.parent / "data" / "bench_prototype"
                    / "bench.toml")
    return max(2.0 * math.pi * float(t["frequency_hz"]) * float(t["amplitude_m"])
               for t in doc["test"] if "frequency_hz" in t and "amplitude_m" in t)


def identified_range_kw(friction_specs: Any, problem_path: str | Path) -> dict[str, Any]:
    """``identified_range_m_per_s`` / ``identified_range_source`` keywords of
    :func:`identified_range_for` (for ``optimize``)."""
    v, src = identified_range_for(friction_specs or (), problem_path)
    return {"identified_range_m_per_s": v, "identified_range_source": src}


def resolve_reference(ref: str, base_dir: str | Path, where: str) -> Path:
    """A path named inside a file, resolved against that file's folder ``base_dir`` and
    confined: it must lead (after symlinks) into ``base_dir`` or the working directory.

    Raises
    ------
    ParameterError
        A control character in the name, or a path that leads elsewhere (absolute or
        ``../..``), with the fix.
    """
    if not ref or not ref.isprintable():
        raise ParameterError(f"{where}: {ref!r} is not a file name (empty or a control "
                             f"character such as a NUL); give the path of the file")
    p = Path(ref)
    target = (p if p.is_absolute() else Path(base_dir) / p).resolve()
    roots = [Path(base_dir).resolve(), Path.cwd().resolve()]
    if not any(target.is_relative_to(r) for r in roots):
        raise ParameterError(f"{where}: {ref!r} leads outside the problem file's folder "
                             f"{roots[0]} and the working directory (to {target}); copy the "
                             f"file next to the problem file (or below it) and give its "
                             f"relative path")
    return target
