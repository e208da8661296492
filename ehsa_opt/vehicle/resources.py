"""Resource estimate of a time-domain simulation, checked before anything is allocated.

Measured on the compiled batch (``/tmp``-free, 2-core machine): peak memory
≈ N · (600 + 830 · B) bytes for N steps and B designs simulated together (1341 B/step
for B = 1, 7168 B/step for B = 8), wall time ≈ 5–10 µs per step and design.  The
simulation is refused when the memory estimate exceeds the limit (80 % of the
available memory, or ``EHSA_OPT_MEMORY_LIMIT_GB``), with the figure and the fix.
"""

from __future__ import annotations

import math
import os

from ..physics.params import ParameterError, RoadParams

__all__ = ["SimulationEstimate", "estimate_simulation", "check_simulation_resources",
           "memory_limit_bytes", "BYTES_PER_STEP", "BYTES_PER_STEP_DESIGN",
           "SECONDS_PER_STEP_DESIGN"]

#: Fixed and per-design memory per time step, bytes (measured; see module docstring).
BYTES_PER_STEP = 600.0
BYTES_PER_STEP_DESIGN = 830.0
#: Pessimistic wall time per step and design, s.
SECONDS_PER_STEP_DESIGN = 1e-5


class SimulationEstimate(tuple):
    """``(steps, memory_bytes, seconds)`` of a planned simulation."""

    __slots__ = ()

    def __new__(cls, steps: int, memory_bytes: float, seconds: float) -> "SimulationEstimate":
        return super().__new__(cls, (steps, memory_bytes, seconds))

    steps = property(lambda self: self[0])
    memory_bytes = property(lambda self: self[1])
    seconds = property(lambda self: self[2])


def memory_limit_bytes() -> float:
    """``EHSA_OPT_MEMORY_LIMIT_GB`` if set, else 80 % of MemAvailable (Linux), else 8 GiB."""
    env = os.environ.get("EHSA_OPT_MEMORY_LIMIT_GB")
    if env:
        try:
            return float(env) * 2 ** 30
        except ValueError:
            raise ParameterError(f"EHSA_OPT_MEMORY_LIMIT_GB = {env!r} is not a number; set it "
                                 f"to the memory budget in GiB, e.g. 4") from None
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return 0.8 * float(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 8.0 * 2 ** 30


def estimate_simulation(duration_s: float, settle_s: float, sample_rate_hz: float,
                        n_designs: int, designs_at_once: int) -> SimulationEstimate:
    """Steps, peak memory (bytes) and wall time (s) of a simulation."""
    steps = int(math.ceil((duration_s + settle_s) * sample_rate_hz))
    mem = steps * (BYTES_PER_STEP + BYTES_PER_STEP_DESIGN * max(1, designs_at_once))
    return SimulationEstimate(steps, mem, steps * n_designs * SECONDS_PER_STEP_DESIGN)


def check_simulation_resources(road: RoadParams | None, sample_rate_hz: float, settle_s: float,
                               n_designs: int, designs_at_once: int,
                               duration_s: float | None = None) -> SimulationEstimate:
    """Refuse a simulation whose settle time exceeds the road or whose memory does not fit.

    Parameters
    ----------
    road : RoadParams or None
        A synthesised road gives the duration length_m / speed; otherwise pass
        ``duration_s``.
    sample_rate_hz, settle_s : float
    n_designs, designs_at_once : int
        Designs in total and simulated together (memory).
    duration_s : float, optional

    Raises
    ------
    ParameterError
        With the estimate and the fix (shorter road, lower rate, fewer designs at once).
    """
    if duration_s is None:
        if road is None or road.profile_csv is not None:
            raise ValueError("check_simulation_resources: give duration_s for a measured road")
        duration_s = road.length_m / road.speed_m_per_s
        if settle_s >= duration_s:
            raise ParameterError(
                f"simulation: settle_s = {settle_s:g} s is not shorter than the road "
                f"({road.length_m:g} m at {road.speed_km_per_h:g} km/h = {duration_s:.3g} s); "
                f"shorten [simulation] settle_s or lengthen [road] length_m")
    est = estimate_simulation(duration_s, settle_s, sample_rate_hz, n_designs, designs_at_once)
    limit = memory_limit_bytes()
    if est.memory_bytes > limit:
        need = est.memory_bytes / 2 ** 30
        fit = limit / (BYTES_PER_STEP + BYTES_PER_STEP_DESIGN * max(1, designs_at_once))
        fit_m = duration_s * fit / est.steps * road.speed_m_per_s if road is not None else 0.0
        fix = (f"shorten [road] length_m to about {fit_m:.3g} m"
               if road is not None and road.profile_csv is None else "use a shorter road profile")
        raise ParameterError(
            f"simulation: {est.steps:.3g} steps ({duration_s + settle_s:.3g} s at "
            f"{sample_rate_hz:g} Hz) x {designs_at_once} design(s) at once need about "
            f"{need:.3g} GiB of memory (limit {limit / 2 ** 30:.3g} GiB) and ~{est.seconds:.3g} s; "
            f"{fix}, lower [simulation] sample_rate_hz (1000 Hz resolves the ride band), or "
            f"simulate fewer designs at once (keep_series=False); the limit can be raised with "
            f"EHSA_OPT_MEMORY_LIMIT_GB")
    return est
