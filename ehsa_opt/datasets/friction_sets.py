"""Friction sets as data: the ``min`` / ``best`` / ``max`` cases of an identification
(:class:`FrictionSets`) and one received set validated by name (:func:`friction_set`),
each with its friction law (static by default; LuGre with its presliding parameters).
Read and checked as part of an ``identification.json`` by
:mod:`ehsa_opt.datasets.identification_file`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from ..physics.friction import FRICTION_LAWS
from ..physics.params import (
    FRICTION_LAW_NAMES,
    FRICTION_NAMES,
    PRESLIDING_PARAMETER_NAMES,
    FrictionParams,
    ParameterError,
    check_keys,
    from_mapping,
)

__all__ = ["FRICTION_CASES", "FrictionSets", "friction_set"]

#: The friction cases an identification result provides.
FRICTION_CASES: tuple[str, ...] = ("min", "best", "max")


@dataclass(frozen=True)
class FrictionSets:
    """The identified friction cases, with the one meaning they have everywhere.

    ``min`` ≤ ``best`` ≤ ``max`` in rod friction at every velocity when ``method`` is the
    data-supported one of :mod:`ehsa_opt.estimation.bounds` (the envelope of the tests
    and, beyond them, the best law's band); ``best`` is the law the data support best.
    The paper's per-parameter minimum and maximum over the tests, which over-state the
    spread, are kept apart as ``paper_min`` / ``paper_max``.

    Attributes
    ----------
    min, best, max : FrictionParams
        The three cases (N, m/s, N s/m at the nut; N m, rad/s, N m s/rad at the bearings).
    method : str
        How they were built (identification.json ``friction_sets.method``).
    paper_min, paper_max : FrictionParams or None
        The paper's per-parameter sets, when the identification made them.
    """

    min: FrictionParams
    best: FrictionParams
    max: FrictionParams
    method: str = ""
    paper_min: FrictionParams | None = None
    paper_max: FrictionParams | None = None

    def bounds(self, method: str = "data") -> tuple[FrictionParams, FrictionParams]:
        """(min, max) of ``method``: ``"data"`` the data-supported sets, ``"paper"`` the
        paper's per-parameter ones (ValueError when they were not made)."""
        if method == "data":
            return self.min, self.max
        if method != "paper":
            raise ValueError(f"FrictionSets.bounds: method must be 'data' or 'paper', got "
                             f"{method!r}")
        if self.paper_min is None or self.paper_max is None:
            raise ValueError("FrictionSets.bounds: no paper's per-parameter sets (the "
                             "identification had fewer than two converged tests)")
        return self.paper_min, self.paper_max

    def to_dict(self) -> dict:
        """The ``friction_sets`` table of identification.json (``min``, ``best``, ``max``,
        ``method``), plus ``paper_min`` / ``paper_max`` when present."""
        out: dict[str, Any] = {c: _set_table(getattr(self, c)) for c in FRICTION_CASES}
        out["method"] = self.method
        for c in ("paper_min", "paper_max"):
            if getattr(self, c) is not None:
                out[c] = _set_table(getattr(self, c))
        return out

    @classmethod
    def from_dict(cls, table: Mapping[str, Any], where: str = "friction_sets"
                  ) -> "FrictionSets":
        """Inverse of :meth:`to_dict`; every set validated as received data
        (:func:`friction_set`), a missing case refused with the fix."""
        if not isinstance(table, Mapping):
            raise ParameterError(f"{where}: must be a table of the cases "
                                 f"{', '.join(FRICTION_CASES)}; re-run `ehsa-opt identify`")
        sets = {}
        for case in FRICTION_CASES:
            if not isinstance(table.get(case), Mapping):
                raise ParameterError(f"{where}: no '{case}' case; re-run `ehsa-opt identify`")
            sets[case] = friction_set(table[case], f"{where}.{case}")
        paper = {c: friction_set(table[c], f"{where}.{c}")
                 for c in ("paper_min", "paper_max") if isinstance(table.get(c), Mapping)}
        laws = {c: f.friction_law for c, f in sets.items()}
        if len(set(laws.values())) > 1:
            raise ParameterError(f"{where}: the cases name different friction laws ("
                                 + ", ".join(f"{c} {law}" for c, law in laws.items())
                                 + "); the three cases share one law — re-run `ehsa-opt "
                                 "identify` or give every case the same friction_law")
        return cls(**sets, method=str(table.get("method", "")), **paper)

    @property
    def friction_law(self) -> str:
        """The law the three cases share (``"static"`` or ``"lugre"``)."""
        return self.best.friction_law


def _set_table(fr: FrictionParams) -> dict[str, Any]:
    """One set as written: the eight parameters of the map, then (LuGre) the law and its
    parameters; a static set is written as before the law was stored."""
    return {**fr.as_dict(), **fr.law_dict()}


def friction_set(values: Mapping[str, Any], where: str) -> FrictionParams:
    """A received friction set, validated as data: every parameter by name (no default
    fills a missing one, a misspelled name is refused with the nearest valid one), finite
    numbers, physical (breakaway >= Coulomb >= 0, velocities > 0, viscous >= 0).

    A set without ``friction_law`` is the static law (files written before the law was
    stored); ``friction_law = "lugre"`` needs both presliding parameters
    (:data:`~ehsa_opt.physics.params.FRICTION_LAW_NAMES`), ``"static"`` refuses them."""
    check_keys(values, FRICTION_NAMES + FRICTION_LAW_NAMES, where)
    law = values.get("friction_law", "static")
    if law not in FRICTION_LAWS:
        raise ParameterError(f"{where}: friction_law = {_shown(law)} is not a friction law; "
                             f"use one of {', '.join(repr(x) for x in FRICTION_LAWS)}")
    for n in PRESLIDING_PARAMETER_NAMES:
        v = values.get(n)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))
                              or not math.isfinite(v)):
            raise ParameterError(f"{where}: {n} = {_shown(v)} is not a finite number; re-run "
                                 f"`ehsa-opt identify` or give a number")
    missing = [n for n in FRICTION_NAMES if n not in values]
    if missing:
        raise ParameterError(f"{where}: missing {', '.join(missing)}; a friction set needs all "
                             f"{len(FRICTION_NAMES)} parameters ({', '.join(FRICTION_NAMES)}) — "
                             f"re-run `ehsa-opt identify` or complete the set")
    for n in FRICTION_NAMES:
        v = values[n]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ParameterError(f"{where}: {n} = {v!r} is not a finite number; re-run "
                                 f"`ehsa-opt identify` or give a number")
    return from_mapping(FrictionParams, values, where)


def _shown(v: Any) -> str:
    text = "null" if v is None else repr(v)
    return text if len(text) <= 40 else text[:40] + "..."
