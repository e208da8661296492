"""Quarter-car simulation from a script: :func:`simulate` and :class:`SimulationResult`.

One problem file's quarter car with the harvester (and its friction) on an ISO 8608 or
measured road, in the time domain; its metrics checked (the energy balance must close,
rated current and voltage) and kept in memory; ``save(folder)`` writes
``simulation.json``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from ..utils.io import atomic_write_text
from ..utils.log import logger
from ..utils.process import one_blas_thread
from ..vehicle.problem_simulation import ProblemSimulation, simulate_problem

__all__ = ["SimulationResult", "simulate"]

#: The file :meth:`SimulationResult.save` writes.
SIMULATION_FILE = "simulation.json"


@dataclass(frozen=True)
class SimulationResult:
    """The metrics of one quarter-car simulation.

    Attributes
    ----------
    record : mapping
        The metrics (``comfort``, ``comfort_weighted_rms_m_s2``, ``road_holding``,
        ``power_W``, ``efficiency``, ``peak_current_A`` …), ``road``, ``frictionless``,
        ``friction_law`` and ``wall_s``: the object ``ehsa-opt simulate --json`` prints.
    run : ProblemSimulation or None
        The simulation itself (series when kept, the problem); None when loaded.
    """

    record: Mapping[str, Any]
    run: ProblemSimulation | None = None

    @property
    def metrics(self) -> dict[str, Any]:
        """The metrics alone."""
        return {k: v for k, v in self.record.items()
                if k not in ("road", "frictionless", "friction_law", "wall_s")}

    @property
    def warnings(self) -> list[str]:
        """The warning lines of the run (rated limits, identified range …)."""
        return [] if self.run is None else list(self.run.warnings)

    def table(self) -> Any:
        """The metrics as a one-row tidy table."""
        from ..utils.tables import tidy_table
        return tidy_table({k: [float("nan") if v is None else v]
                           for k, v in self.metrics.items()},
                          {"efficiency": "-", "energy_residual": "-"})

    def summary(self) -> str:
        """The head line and the table ``ehsa-opt simulate`` prints."""
        if self.run is None:
            return "\n".join(f"  {k:<40s} {v}" for k, v in self.metrics.items())
        return self.run.summary()

    def to_json(self) -> str:
        """The record as one standard-JSON line."""
        return self.run.to_json() if self.run is not None else json.dumps(
            dict(self.record), allow_nan=False)

    def plot(self, ax: Any = None) -> Any:
        """Road, sprung displacement, power and force–velocity (four panels; ``ax`` is
        not used); needs the series (``simulate(..., keep_series=True)``, the default)."""
        if self.run is None:
            raise ValueError("nothing to plot: a loaded result has no time series")
        return self.run.simulation.plot()

    def save(self, out_dir: str | Path) -> list[Path]:
        """Write ``simulation.json`` into ``out_dir``."""
        path = Path(out_dir) / SIMULATION_FILE
        atomic_write_text(path, json.dumps(json.loads(self.to_json()), indent=1))
        return [path]

    @classmethod
    def load(cls, out_dir: str | Path) -> SimulationResult:
        """Read ``simulation.json`` back (the folder or the file)."""
        from ..utils.limits import parse_json
        p = Path(out_dir)
        path = p / SIMULATION_FILE if p.is_dir() else p
        doc = parse_json(path.read_text(encoding="utf-8"), str(path))
        if not isinstance(doc, dict) or "power_W" not in doc:
            raise ValueError(f"{path}: not a simulation result (no power_W); write it with "
                             f"SimulationResult.save")
        return cls(doc)


@one_blas_thread
def simulate(problem: str | Path, *, friction: str | None = None,
             keep_series: bool = True) -> SimulationResult:
    """Simulate a quarter-car problem file; nothing written.

    Parameters
    ----------
    problem : path
        A quarter-car problem file (``preset`` or ``[vehicle]``, ``[harvester]``,
        ``[road]``, optional ``[friction]`` and ``[simulation]``), or a shipped
        problem's name (``"quarter_car_class_c"``).
    friction : str, optional
        ``FILE[:CASE]``: an identification result's friction set (``min|best|max``,
        default ``best``) instead of the file's ``[friction]``.
    keep_series : bool
        Keep the time series (for :meth:`SimulationResult.plot`; the metrics do not
        depend on it).

    Returns
    -------
    SimulationResult

    Raises
    ------
    ValueError
        The simulation failed or its energy balance does not close (its metrics would
        not be trustworthy); the message names the file and the fix.
    """
    run = simulate_problem(problem, friction, on_warning=lambda line: logger.warning("%s", line),
                           keep_series=keep_series)
    return SimulationResult(json.loads(run.to_json()), run)
