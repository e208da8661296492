"""``ehsa-opt simulate``: one quarter-car problem file simulated in the time domain, its
metrics checked (energy balance, rated current and voltage) and shown.

The checks belong to the simulation, not to the command line: a run whose energy
balance does not close beyond :data:`ENERGY_TOLERANCE` is refused (its metrics are not
trustworthy; the message says which sample rate the wheel-hop mode needs), and a peak
current or terminal voltage beyond the ``[simulation]`` rated values is a warning.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..datasets.friction_source import identified_range_for, load_friction
from ..datasets.problem_file import QuarterCarProblem, load_problem
from ..physics.params import ParameterError
from ..utils.io import json_safe
from .coverage import coverage_rows
from .simulate import QuarterCarSimulation, simulate_quarter_car

__all__ = ["ENERGY_TOLERANCE", "ProblemSimulation", "peak_electrical", "simulate_problem"]

#: |energy residual| above which a simulation's metrics are refused (the balance closes
#: to < 1 % when the time step resolves the vehicle's modes).
ENERGY_TOLERANCE = 0.05


def peak_electrical(peak_power_W: float, load_ohm: float) -> tuple[float | None, float | None]:
    """Peak current (A) and peak terminal voltage i R_e (V) from the peak load power: the
    load power R_e i² is instantaneous, so its peak gives both exactly (None at R_e = 0)."""
    if not load_ohm > 0:
        return None, None
    return math.sqrt(peak_power_W / load_ohm), math.sqrt(peak_power_W * load_ohm)


@dataclass(frozen=True)
class ProblemSimulation:
    """The metrics of one problem file's simulation, with what they rest on.

    ``metrics``: the simulation's metrics plus ``peak_current_A`` and
    ``peak_terminal_voltage_V``; ``warnings``: lines for the user (simulation warnings,
    rated limits exceeded); ``identified_range_m_per_s``: the friction's identified range
    the coverage rows refer to."""

    problem_path: str
    problem: QuarterCarProblem
    simulation: QuarterCarSimulation
    metrics: dict[str, Any]
    identified_range_m_per_s: float
    warnings: list[str] = field(default_factory=list)

    @property
    def success(self) -> bool:
        return bool(self.simulation.success)

    @property
    def message(self) -> str:
        return str(self.simulation.message)

    def to_json(self) -> str:
        """One standard-JSON object: the metrics, the road, whether frictionless, wall time."""
        out = dict(self.metrics)
        out["road"] = self.simulation.road_source
        fr = self.problem.friction
        out["frictionless"] = fr is None or fr.is_frictionless
        out["friction_law"] = "static" if fr is None else fr.friction_law
        out["wall_s"] = round(self.simulation.stats["wall_s"], 4)
        return json.dumps(json_safe(out), allow_nan=False)  # inf/NaN -> null

    def rows(self) -> list[tuple[str, float | None]]:
        """(label, value) rows of the printed table."""
        m = self.metrics
        return [("comfort alpha (-)", m["comfort"]),
                ("W_k-weighted rms acceleration (m/s^2)", m["comfort_weighted_rms_m_s2"]),
                ("road holding (-)", m["road_holding"]),
                ("power in R_e (W)", m["power_W"]),
                ("power, dimensionless (-)", m["power_dimensionless"]),
                ("efficiency (%)", 100.0 * m["efficiency"]),
                ("power absorbed by the damper (W)", m["dissipated_power_W"]),
                ("dissipation bound (W)", m["dissipation_bound_W"]),
                ("peak power (W)", m["peak_power_W"]),
                ("peak terminal voltage i R_e (V)", m["peak_terminal_voltage_V"]),
                ("peak current (A)", m["peak_current_A"]),
                ("energy balance residual (%)", 100.0 * m["energy_residual"]),
                *coverage_rows(m, self.identified_range_m_per_s)]

    def summary(self) -> str:
        """The head line and the table ``ehsa-opt simulate`` prints."""
        sim = self.simulation
        fr = self.problem.friction
        law = ("" if fr is None or fr.is_static else
               f" (LuGre law: sigma_0 {fr.presliding_stiffness_N_per_m:.3g} N/m, sigma_1 "
               f"{fr.presliding_damping_Ns_per_m:.3g} N s/m)")
        lines = [f"{self.problem_path}: {sim.road_source}, "
                 f"{'frictionless' if fr is None else 'with friction' + law}, "
                 f"{sim.stats['steps']} steps in {sim.stats['wall_s']:.2f} s"]
        lines += [f"  {label:<40s} {'n/a' if value is None else format(value, '.4g')}"
                  for label, value in self.rows()]
        return "\n".join(lines)


def simulate_problem(problem_path: str | Path, friction: str | None = None,
                     on_warning: Callable[[str], None] | None = None,
                     keep_series: bool = False) -> ProblemSimulation:
    """Simulate the quarter-car problem file ``problem_path`` (``friction``: a
    ``FILE[:CASE]`` identification result replacing the file's ``[friction]``).

    Every warning line is kept in ``.warnings`` and, as it arises, passed to
    ``on_warning`` (so a caller sees the simulation's warnings even when the run is then
    refused).  ``keep_series``: keep the time series (for plots; the metrics do not
    depend on it).

    Raises ``ValueError`` (naming the file and the fix) when the simulation fails or its
    energy balance does not close within :data:`ENERGY_TOLERANCE`."""
    path = str(problem_path)
    prob = load_problem(path)
    if friction:
        prob = dataclasses.replace(prob, friction=load_friction(friction))
    v_range = identified_range_for(friction or (), path)[0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            sim = simulate_quarter_car(
                prob.vehicle, prob.harvester, prob.friction, prob.road,
                settle_s=prob.simulation.settle_s, sample_rate_hz=prob.simulation.sample_rate_hz,
                base_dir=prob.base_dir, keep_series=keep_series, identified_range_m_per_s=v_range)
        except ParameterError as exc:  # name the file the bad value came from
            if path in str(exc):
                raise
            raise ParameterError(f"{path}: {exc}") from None
    notes: list[str] = []

    def note(line: str) -> None:
        notes.append(line)
        if on_warning is not None:
            on_warning(line)
    for w in caught:
        note(f"warning: {w.message}")
    m = dict(sim.metrics_of(0))
    if not sim.success:
        raise ValueError(f"{path}: simulation failed: {sim.message}")
    residual = float(m.get("energy_residual", 0.0))
    if not abs(residual) <= ENERGY_TOLERANCE:
        v = prob.vehicle
        hop_hz = math.sqrt((v.tyre_stiffness_N_per_m + v.suspension_stiffness_N_per_m)
                           / v.unsprung_mass_kg) / (2 * math.pi)
        raise ValueError(
            f"{path}: the energy balance of the simulation does not close (residual "
            f"{100 * residual:.3g} %, tolerance {100 * ENERGY_TOLERANCE:g} %), so its metrics "
            f"are not trustworthy; the vehicle's wheel-hop mode ({hop_hz:.3g} Hz) needs "
            f"[simulation] sample_rate_hz of at least {20 * hop_hz:.3g} Hz (now "
            f"{prob.simulation.sample_rate_hz:g}); check the [vehicle] masses and stiffnesses")
    m["peak_current_A"], m["peak_terminal_voltage_V"] = peak_electrical(
        float(m["peak_power_W"]), prob.harvester.load_ohm)
    for key, limit, unit, name in (
            ("peak_terminal_voltage_V", prob.simulation.rated_voltage_V, "V", "voltage_V"),
            ("peak_current_A", prob.simulation.rated_current_A, "A", "current_A")):
        if limit is not None and m[key] is not None and m[key] > limit:
            what = "terminal voltage" if unit == "V" else "current"
            note(f"warning: peak {what} {m[key]:.3g} {unit} exceeds the rated {limit:g} "
                         f"{unit} ([simulation] rated_{name} of {path})")
    return ProblemSimulation(path, prob, sim, m, v_range, notes)
