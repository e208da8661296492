"""What the bench can do: the rig file's ``[rig]`` table (stroke, velocity, force, power,
loads, recording) for :mod:`ehsa_opt.design.test_plan`.

Values are refused before anything is allocated: a planned record longer than
:data:`MAX_PLANNED_SAMPLES` samples (the longest record a candidate test of the rig would
need: the slowest sine's cycles, or the slowest triangle stroke's) or more than
:data:`MAX_LOADS` load resistors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

from ..physics.params import ParameterError, load_toml, nearest_name

__all__ = ["RigLimits", "load_rig", "MAX_PLANNED_SAMPLES", "MAX_LOADS",
           "SLOWEST_TRIANGLE_M_PER_S", "planned_samples"]

#: Most samples of one planned record: 10 million (an hour at 2.8 kHz; ~80 MB per signal
#: in memory and ~400 MB of CSV for the operator).
MAX_PLANNED_SAMPLES = 10_000_000
#: Most load resistors of a rig (each multiplies the candidate tests: 168 per load).
MAX_LOADS = 100
#: Slowest constant-velocity triangle stroke a plan proposes, m/s.
SLOWEST_TRIANGLE_M_PER_S = 0.02


@dataclass(frozen=True)
class RigLimits:
    """What the bench can do (the ``[rig]`` table of a rig file).

    Attributes
    ----------
    stroke_m : float
        Usable stroke, peak to peak (a sine's amplitude ≤ stroke/2).
    peak_velocity_m_per_s : float
        Largest actuator velocity.
    force_N : float
        Largest actuator force (the damper's peak force must stay below).
    actuator_power_W : float
        Largest peak mechanical power F·v.
    loads_ohm : tuple of float
        Load resistors available.
    sample_rate_hz, cycles : float
        Recording of a planned test: its sample rate and its fewest cycles.
    reversal_s : float
        Time a triangle stroke takes to reverse from +v to −v (its acceleration is
        2 v / reversal_s, the protocol's corners of reversal_s / 2).
    min_frequency_hz, max_frequency_hz : float
        Sine frequencies the controller runs.
    stroke_margin_m : float
        Travel kept free at each end of the stroke (controller overshoot, end stops): a
        test's peak |x| is at most stroke_m / 2 − stroke_margin_m.  Default 5 mm (5 % of
        the default stroke; an assumption the operator sets for the rig).
    min_plateau_s : float
        Least time of usable friction samples per test: a triangle's constant-velocity
        plateaus (its reversals are left out of the fit), a sine's whole record; a test
        runs ``cycles`` or as many more as this needs.  Default 2 s: 2000 samples at
        1 kHz, about a record of the embedded bench campaign (21 tests, 1480 samples each).
    max_screw_speed_rpm, max_generator_voltage_V, max_generator_current_A : float or None
        The damper's own limits (screw critical speed or DN limit, the generator's rated
        voltage and peak current); None: not checked (every proposed test still states
        its peak screw speed, voltage and current).
    """

    stroke_m: float = 0.1
    peak_velocity_m_per_s: float = 1.0
    force_N: float = 10_000.0
    actuator_power_W: float = 5_000.0
    loads_ohm: tuple[float, ...] = (15.0, 47.0, 109.0)
    sample_rate_hz: float = 1000.0
    cycles: float = 2.0
    reversal_s: float = 0.05
    min_frequency_hz: float = 0.1
    max_frequency_hz: float = 20.0
    stroke_margin_m: float = 0.005
    min_plateau_s: float = 2.0
    max_screw_speed_rpm: float | None = None
    max_generator_voltage_V: float | None = None
    max_generator_current_A: float | None = None

    @property
    def usable_amplitude_m(self) -> float:
        """Largest peak |x| a test may reach: stroke_m / 2 − stroke_margin_m."""
        return 0.5 * self.stroke_m - self.stroke_margin_m

    def __post_init__(self) -> None:
        for name in ("stroke_m", "peak_velocity_m_per_s", "force_N", "actuator_power_W",
                     "sample_rate_hz", "cycles", "reversal_s", "min_frequency_hz",
                     "max_frequency_hz", "min_plateau_s", "max_screw_speed_rpm",
                     "max_generator_voltage_V", "max_generator_current_A"):
            v = getattr(self, name)
            if v is None and name.startswith("max_") and name != "max_frequency_hz":
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (
                    math.isfinite(v) and v > 0):
                raise ParameterError(f"[rig] {name} = {v!r}: give a positive number (e.g. "
                                     f"{getattr(RigLimits, name)!r})")
        m = self.stroke_margin_m
        if isinstance(m, bool) or not isinstance(m, (int, float)) or not (
                math.isfinite(m) and 0.0 <= m < 0.5 * self.stroke_m):
            raise ParameterError(f"[rig] stroke_margin_m = {m!r}: give the travel kept free "
                                 f"at each end, >= 0 and below stroke_m / 2 = "
                                 f"{0.5 * self.stroke_m:g} m (e.g. 0.005)")
        if self.stroke_m > 2.0:
            raise ParameterError(f"[rig] stroke_m = {self.stroke_m:g} m: strokes are metres "
                                 f"(e.g. 0.1 for ±50 mm); did you give millimetres?")
        if self.max_frequency_hz <= self.min_frequency_hz:
            raise ParameterError("[rig] max_frequency_hz must be above min_frequency_hz")
        loads = tuple(self.loads_ohm)
        if not loads or any(isinstance(r, bool) or not isinstance(r, (int, float))
                            or not (math.isfinite(r) and r > 0) for r in loads):
            raise ParameterError(f"[rig] loads_ohm = {self.loads_ohm!r}: give a list of "
                                 f"positive resistances in ohm, e.g. [15.0, 47.0, 109.0]")
        if len(loads) > MAX_LOADS:
            raise ParameterError(f"[rig] loads_ohm: {len(loads)} resistors, at most "
                                 f"{MAX_LOADS}; list the resistors the rig has")
        n = planned_samples(self)
        if n > MAX_PLANNED_SAMPLES:
            raise ParameterError(
                f"[rig] a planned test would record {n:.3g} samples (sample_rate_hz = "
                f"{self.sample_rate_hz:g} x cycles = {self.cycles:g} x the slowest cycle: "
                f"{1 / self.min_frequency_hz:.3g} s of a sine at min_frequency_hz, or a "
                f"triangle stroke at {SLOWEST_TRIANGLE_M_PER_S:g} m/s over stroke_m), more "
                f"than {MAX_PLANNED_SAMPLES:.0e}; lower sample_rate_hz or cycles, or raise "
                f"min_frequency_hz")


def planned_samples(rig: RigLimits) -> float:
    """Samples of the longest record a candidate test of ``rig`` needs (before any is
    made): ``cycles`` of the slowest sine, or of the slowest triangle stroke over the full
    stroke (4 A / v plus two reversals per cycle)."""
    sine_s = 1.0 / rig.min_frequency_hz
    tri_s = 2.0 * rig.stroke_m / SLOWEST_TRIANGLE_M_PER_S + 2.0 * rig.reversal_s
    return rig.sample_rate_hz * max(rig.cycles * max(sine_s, tri_s),
                                    rig.min_plateau_s + sine_s)


def load_rig(path: str | Path) -> RigLimits:
    """A rig file's ``[rig]`` table (unknown keys and bad values refused with the fix)."""
    doc = load_toml(path)
    tab = doc.get("rig")
    if not isinstance(tab, Mapping):
        raise ParameterError(f"{path}: no [rig] table; add one, e.g.\n[rig]\nstroke_m = 0.1\n"
                             f"peak_velocity_m_per_s = 1.0\nforce_N = 10000.0\n"
                             f"actuator_power_W = 5000.0\nloads_ohm = [15.0, 47.0, 109.0]")
    valid = [f for f in RigLimits.__dataclass_fields__]
    for k in tab:
        if k not in valid:
            near = nearest_name(k, valid)
            raise ParameterError(f"{path}: [rig] unknown key '{k}'"
                                 + (f"; did you mean '{near}'?" if near else "")
                                 + f" (valid: {', '.join(valid)})")
    vals = dict(tab)
    if "loads_ohm" in vals:
        if not isinstance(vals["loads_ohm"], list):
            raise ParameterError(f"{path}: [rig] loads_ohm must be a list, e.g. [15.0, 47.0]")
        vals["loads_ohm"] = tuple(vals["loads_ohm"])
    try:
        return RigLimits(**vals)
    except ParameterError as exc:
        raise ParameterError(f"{path}: {exc}") from None


