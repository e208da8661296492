"""Test planning from a script: :func:`plan_tests` and :class:`TestPlanResult`.

The next bench tests that narrow the rod-friction band where a road drives the damper
most (:mod:`ehsa_opt.design.test_plan`), proposed from an identification result, a
quarter-car problem and the rig's limits; in memory.  ``save(folder)`` writes the
``bench.toml`` skeleton for the rig operator and ``plan.json``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from ..design.test_plan import TestPlan

__all__ = ["TestPlanResult", "plan_tests"]

#: The files :meth:`TestPlanResult.save` writes.
PLAN_FILE, SKELETON_FILE = "plan.json", "bench.toml"


@dataclass(frozen=True)
class TestPlanResult:
    """A proposed test plan.

    Attributes
    ----------
    plan : TestPlan
        The proposed tests, the criterion and the predicted 95 % bands of the rod
        friction before and after them (``success`` / ``message`` as scipy's results).
    harvester : mapping
        The bench's ``[harvester]`` table (written into the skeleton).
    """

    __test__ = False  # not a pytest test class

    plan: TestPlan
    harvester: Mapping[str, Any] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """A test was proposed."""
        return bool(self.plan.success)

    def summary(self) -> str:
        """The report ``ehsa-opt plan-tests`` prints (tests, peak force and power, the
        band before → after)."""
        return self.plan.summary()

    def table(self) -> Any:
        """One row per proposed test: label, kind, frequency (Hz) or velocity (m/s),
        amplitude (m), load (ohm), peak force (N) and power (W), and the road-weighted
        band after it (N)."""
        from ..utils.tables import tidy_table

        def num(v: Any) -> float:
            return float("nan") if v is None else float(v)
        p = self.plan
        return tidy_table({
            "test": [c.label() for c in p.proposed], "kind": [c.kind for c in p.proposed],
            "frequency_hz": [num(getattr(c, "frequency_hz", None)) for c in p.proposed],
            "velocity_m_per_s": [num(getattr(c, "velocity_m_per_s", None))
                                 for c in p.proposed],
            "amplitude_m": [num(c.amplitude_m) for c in p.proposed],
            "load_ohm": [num(c.load_ohm) for c in p.proposed],
            "peak_force_N": [num(c.peak_force_N) for c in p.proposed],
            "peak_power_W": [num(c.peak_power_W) for c in p.proposed],
            "road_band_N": [num(st.get("road_band_N")) for st in p.steps]},
            {"frequency_hz": "Hz", "test": "", "kind": ""})

    def plot(self, ax: Any = None) -> Any:
        """The predicted 95 % band of the rod friction (± N) against velocity, before
        and after the proposed tests (one axes; drawn into ``ax`` when given)."""
        import matplotlib.pyplot as plt
        if ax is None:
            _, ax = plt.subplots(figsize=(6.0, 4.0))
        p = self.plan
        ax.plot(p.velocities_m_per_s, p.band_before_N, "o-", label="before")
        ax.plot(p.velocities_m_per_s, p.band_after_N, "s-", label="after the proposed tests")
        ax.set_xlabel("stroke velocity (m/s)")
        ax.set_ylabel("95 % band of the rod friction (± N)")
        ax.legend()
        return ax

    def save(self, out_dir: str | Path) -> list[Path]:
        """Write ``bench.toml`` (the skeleton) and ``plan.json`` into ``out_dir``,
        atomically; nothing when no test was proposed.  Returns the paths written."""
        if not self.success:
            return []
        self.plan.write(out_dir, dict(self.harvester) or None)
        return [Path(out_dir) / SKELETON_FILE, Path(out_dir) / PLAN_FILE]

    @classmethod
    def load(cls, out_dir: str | Path) -> TestPlanResult:
        """Read ``plan.json`` back (the folder or the file)."""
        from ..utils.limits import parse_json
        p = Path(out_dir)
        path = p / PLAN_FILE if p.is_dir() else p
        doc = parse_json(path.read_text(encoding="utf-8"), str(path))
        if not isinstance(doc, dict) or "proposed" not in doc:
            raise ValueError(f"{path}: not a test plan (no 'proposed'); write it with "
                             f"TestPlanResult.save")
        return cls(TestPlan.from_dict(doc))


def plan_tests(identification: str | Path, vehicle: str | Path, rig: str | Path, *,
               n_tests: int = 3, weight: str = "energy", **options: Any) -> TestPlanResult:
    """Propose the next bench tests; nothing written.

    Parameters
    ----------
    identification : path
        An ``identification.json`` (``ehsa-opt identify`` or
        :meth:`IdentificationResult.save`).
    vehicle : path
        A quarter-car problem file (or a shipped problem's name): its road sets the
        velocities that matter.
    rig : path
        The rig's limits (a ``bench.toml`` with a ``[rig]`` table, or a rig file).
    n_tests : int
        Tests to propose.
    weight : {"energy", "time"}
        Road weight of a velocity: the friction energy dissipated there, or the time.
    **options
        Further settings of :func:`ehsa_opt.design.test_plan.plan_from_files`
        (``criterion``, ``kinds``).

    Returns
    -------
    TestPlanResult
    """
    from ..design.test_plan import plan_from_files
    plan, harvester = plan_from_files(identification, vehicle, rig, n_tests=n_tests,
                                      weight=weight, **options)
    return TestPlanResult(plan, harvester)
