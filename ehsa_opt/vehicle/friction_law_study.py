"""The friction law's effect on the vehicle metrics: LuGre sets against static sets.

Two identifications of the same bench data, one under the static (Simscape) law and one
under the LuGre law, give two triples of friction sets.  :func:`friction_law_effect`
simulates, on the *same* Gaussian road realisations (:func:`~ehsa_opt.vehicle.uncertainty.road_intervals`),
the harvester without friction, with each static set, with each LuGre set and with each
LuGre set's static limit (its steady-state map under the static law, σ₀ → ∞).  Every
change is paired on the same roads, so the road's common part cancels:

* ``law`` — LuGre set against the static set of the same case (what changes when the
  vehicle studies use the LuGre identification instead of the static one);
* ``bristle`` — LuGre set against its own static limit (the bristle's dynamics alone, the
  map being the same);
* ``map`` — the LuGre set's static limit against the static set (the steady-state map the
  LuGre identification found, without the bristle).

``law`` = ``bristle`` + ``map`` to first order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from ..physics.params import FrictionParams, HarvesterParams, ParameterError, RoadParams, \
    VehicleParams
from .uncertainty import DEFAULT_SEEDS, Interval, RoadIntervals, road_intervals

__all__ = ["FrictionLawEffect", "friction_law_effect", "LAW_METRICS"]

#: The metrics compared and how their change is expressed: comfort and road holding as the
#: paper's improvement (positive = lower α or η_rh), power as a relative change.
LAW_METRICS: dict[str, str] = {"comfort": "improvement", "road_holding": "improvement",
                               "power_W": "relative"}


@dataclass(frozen=True)
class FrictionLawEffect:
    """Result of :func:`friction_law_effect`.

    Attributes
    ----------
    cases : tuple of str
        The friction cases compared (``min``, ``best``, ``max``).
    intervals : RoadIntervals
        Every metric per design and realisation; designs in :attr:`designs` order.
    designs : tuple of str
        ``"none"``, then ``"static CASE"``, ``"lugre CASE"``, ``"limit CASE"`` per case.
    """

    cases: tuple[str, ...]
    intervals: RoadIntervals
    designs: tuple[str, ...]

    def index(self, design: str) -> int:
        return self.designs.index(design)

    def value(self, metric: str, design: str) -> Interval:
        """The metric's interval of one design over the realisations."""
        return self.intervals.interval(metric, self.index(design))

    def change(self, metric: str, case: str, what: str = "law") -> Interval:
        """Paired change of ``metric`` for ``case``: ``what`` = ``"law"``, ``"bristle"`` or
        ``"map"`` (module docstring), in per cent (kind of :data:`LAW_METRICS`)."""
        pairs = {"law": ("lugre", "static"), "bristle": ("lugre", "limit"),
                 "map": ("limit", "static")}
        if what not in pairs:
            raise ValueError(f"FrictionLawEffect.change: what must be one of {', '.join(pairs)}"
                             f", got {what!r}")
        b, ref = (self.index(f"{p} {case}") for p in pairs[what])
        return self.intervals.change(metric, b, ref, LAW_METRICS.get(metric, "relative"))

    def table(self) -> str:
        """Markdown: each case's metrics under both laws and the paired changes (comfort
        and road holding as improvements: positive = lower α or η_rh under LuGre; power
        relative: positive = more power under LuGre)."""
        head = ("| case | metric | static set | LuGre set | change LuGre vs static (%) | "
                "of it: bristle (%) | of it: map (%) |")
        rows = [head, "|---|---|---|---|---|---|---|"]
        for c in self.cases:
            for m in LAW_METRICS:
                rows.append(f"| {c} | {m} | {self.value(m, f'static {c}').text()} | "
                            f"{self.value(m, f'lugre {c}').text()} | "
                            f"{self.change(m, c).text()} | "
                            f"{self.change(m, c, 'bristle').text()} | "
                            f"{self.change(m, c, 'map').text()} |")
        return "\n".join(rows)

    def as_dict(self) -> dict[str, Any]:
        """Plain data: the changes per case and metric, the seeds."""
        return {"seeds": list(self.intervals.seeds), "road": str(self.intervals.road),
                "changes": {c: {m: {w: self.change(m, c, w).as_dict()
                                    for w in ("law", "bristle", "map")}
                                for m in LAW_METRICS} for c in self.cases},
                "values": {d: {m: self.value(m, d).as_dict() for m in LAW_METRICS}
                           for d in self.designs}}


def friction_law_effect(vehicle: VehicleParams, harvester: HarvesterParams, road: RoadParams,
                        static_sets: Mapping[str, FrictionParams],
                        lugre_sets: Mapping[str, FrictionParams], *,
                        n_seeds: int = DEFAULT_SEEDS, sample_rate_hz: float = 1000.0,
                        threads: int | None = None) -> FrictionLawEffect:
    """Simulate the static and the LuGre friction sets on the same road realisations.

    Parameters
    ----------
    vehicle, harvester, road
        The study's quarter car, harvester and road (ISO 8608 class, speed, length).
    static_sets, lugre_sets : mapping case -> FrictionParams
        The same cases (e.g. ``min``/``best``/``max``), the first under the static law,
        the second under the LuGre law.
    n_seeds : int
        Gaussian road realisations (≥ 2).

    Raises
    ------
    ParameterError
        The cases differ, or a set is not under the law its side needs.
    """
    if list(static_sets) != list(lugre_sets):
        raise ParameterError(f"friction law effect: the static sets' cases {list(static_sets)} "
                             f"are not the LuGre sets' {list(lugre_sets)}")
    for side, sets, law in (("static", static_sets, "static"), ("LuGre", lugre_sets, "lugre")):
        bad = [c for c, f in sets.items() if f.friction_law != law]
        if bad:
            raise ParameterError(f"friction law effect: the {side} sets {', '.join(bad)} are "
                                 f"not under the {law} law; give the identification made "
                                 f"with --friction-law {law}")
    cases = tuple(static_sets)
    designs, frictions = ["none"], [None]
    for c in cases:
        designs += [f"static {c}", f"lugre {c}", f"limit {c}"]
        frictions += [static_sets[c], lugre_sets[c], lugre_sets[c].with_law("static")]
    iv = road_intervals(vehicle, [harvester] * len(designs), frictions, road, n_seeds=n_seeds,
                        sample_rate_hz=sample_rate_hz, threads=threads)
    return FrictionLawEffect(cases, iv, tuple(designs))
