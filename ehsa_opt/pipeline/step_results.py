"""Typed results of the report steps that later steps read.

A step hands its results to the step cache as a dict (:meth:`to_dict`, standard JSON)
and a later step reads them back through :meth:`from_dict`, so the keys are written and
parsed in one place and a consumer sees named, typed fields.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Mapping

from ..datasets.friction_source import FrictionSets
from ..physics.params import HarvesterParams

__all__ = ["IdentificationStepResult", "DesignStepResult"]


@dataclass(frozen=True)
class IdentificationStepResult:
    """What the identification step (``identification``) gives the later steps.

    Attributes
    ----------
    converged, tests : int
        Tests whose fit converged, and all tests.
    seconds : float
        Wall time of the identification (s).
    lead_m_per_rad : float
        r of the bench's harvester, to convert bearing torque to rod force.
    has_generator : bool
        Whether the rig has a generator (a voltage channel).
    rod_friction_mean_N : dict[str, float]
        Mean rod friction over the tests (N) at a few velocities (m/s, as text keys).
    identified_range_m_per_s : float or None
        The campaign's largest stroke velocity: the friction sets are extrapolated above.
    friction_sets : FrictionSets or None
        The identified ``min`` / ``best`` / ``max`` sets (and the paper's per-parameter
        ones); None when the bounds could not be built.
    """

    converged: int
    tests: int
    seconds: float = math.nan
    lead_m_per_rad: float = math.nan
    has_generator: bool = True
    rod_friction_mean_N: dict[str, float] = field(default_factory=dict)
    identified_range_m_per_s: float | None = None
    friction_sets: FrictionSets | None = None

    def to_dict(self) -> dict:
        """The dict the step cache stores (standard-JSON types)."""
        return {"converged": self.converged, "tests": self.tests, "seconds": self.seconds,
                "lead_m_per_rad": self.lead_m_per_rad, "has_generator": self.has_generator,
                "rod_friction_mean_N": dict(self.rod_friction_mean_N),
                "identified_range_m_per_s": self.identified_range_m_per_s,
                "friction_sets": (None if self.friction_sets is None
                                  else self.friction_sets.to_dict())}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | None) -> "IdentificationStepResult | None":
        """Inverse of :meth:`to_dict`; None for None or an empty dict (no identification
        step in the run)."""
        if not d:
            return None
        sets = d.get("friction_sets")
        rng = d.get("identified_range_m_per_s")
        return cls(int(d["converged"]), int(d["tests"]),
                   _float(d.get("seconds")), _float(d.get("lead_m_per_rad")),
                   bool(d.get("has_generator", True)),
                   {str(k): float(v) for k, v in (d.get("rod_friction_mean_N") or {}).items()},
                   None if rng is None else float(rng),
                   None if sets is None else FrictionSets.from_dict(
                       sets, "identification step friction_sets"))


@dataclass(frozen=True)
class DesignStepResult:
    """What the goal-attainment design step (``design``) gives the later steps.

    Attributes
    ----------
    design : dict[str, float]
        The optimum's design variables: ``total_inertia_gcm2``, ``lead_mm_per_rev``,
        ``speed_constant_rpm_per_V``, ``load_ohm``.
    optimum_harvester : HarvesterParams
        The harvester of that design (the prototype's other fields).
    gamma : float
        Goal attainment factor at the optimum (dimensionless; < 0: every goal beaten).
    success : bool
        Whether the goal attainment converged.
    objectives, metrics : dict
        The optimum's objectives (by name) and its metrics (W, m/s², …, by name).
    prototype : dict
        The prototype's ``objectives`` and ``metrics``.
    at_lower_bound : dict[str, bool]
        Which design variables sit on their lower bound.
    binding : list[str]
        The objectives whose goals bind at the optimum.
    paper_design_in_our_model : dict[str, float]
        The paper's reported design evaluated by our model (objectives by name).
    """

    design: dict[str, float]
    optimum_harvester: HarvesterParams
    gamma: float
    success: bool
    objectives: dict = field(default_factory=dict)
    metrics: dict = field(default_factory=dict)
    prototype: dict = field(default_factory=dict)
    at_lower_bound: dict[str, bool] = field(default_factory=dict)
    binding: list[str] = field(default_factory=list)
    paper_design_in_our_model: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The dict the step cache stores (standard-JSON types)."""
        return {"design": dict(self.design), "objectives": self.objectives,
                "metrics": self.metrics, "gamma": self.gamma,
                "optimum_harvester": asdict(self.optimum_harvester),
                "prototype": self.prototype, "success": self.success,
                "at_lower_bound": dict(self.at_lower_bound), "binding": list(self.binding),
                "paper_design_in_our_model": self.paper_design_in_our_model}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | None) -> "DesignStepResult | None":
        """Inverse of :meth:`to_dict`; None when the run has no design (no step, or a rig
        without generator: ``{"applicable": false}``)."""
        if not d or "design" not in d:
            return None
        return cls(dict(d["design"]),
                   HarvesterParams(**d["optimum_harvester"]), _float(d.get("gamma")),
                   bool(d.get("success", False)), dict(d.get("objectives") or {}),
                   dict(d.get("metrics") or {}), dict(d.get("prototype") or {}),
                   {k: bool(v) for k, v in (d.get("at_lower_bound") or {}).items()},
                   list(d.get("binding") or []), dict(d.get("paper_design_in_our_model") or {}))


def _float(x: Any) -> float:
    return math.nan if x is None else float(x)
