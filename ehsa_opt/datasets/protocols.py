"""Non-sine bench protocols in closed form, for the synthetic generator: constant-velocity
(triangle) strokes, trapezoids, periodic multisines and road-like records.

Each :class:`Protocol` gives an exact motion (:class:`~ehsa_opt.physics.motion.PiecewiseMotion`
or :class:`~ehsa_opt.physics.motion.MultisineMotion`) that is already running when the
record starts (an unrecorded lead-in of ``lead_in_s``): a recorded test starts mid-stroke,
at whatever velocity the protocol has there, as a real rig's record does.

Corners of strokes are blended with a constant acceleration over ``corner_s`` (a real
actuator cannot reverse in zero time; ``corner_s`` of one sample interval is the
sharpest corner a sampled record can describe).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..physics.motion import MultisineMotion, PiecewiseMotion

__all__ = ["Protocol", "PROTOCOL_KINDS", "parse_protocol"]

PROTOCOL_KINDS = ("triangle", "trapezoid", "multisine", "road")


@dataclass(frozen=True)
class Protocol:
    """One non-sine bench test.

    Attributes
    ----------
    kind : {"triangle", "trapezoid", "multisine", "road"}
        ``triangle``: strokes between −A and +A at constant speed ``velocity_m_per_s``,
        blended corners; ``trapezoid``: the same strokes with a dwell of ``hold_s`` at
        rest at each end; ``multisine``: ``components`` harmonics of ``frequency_hz``
        (velocity amplitudes equal, Schroeder phases), periodic, whole periods recorded;
        ``road``: ``components`` incommensurate frequencies log-spaced in
        [``frequency_hz``, 12 ``frequency_hz``] with a 1/f displacement spectrum and
        random phases (seeded) — not periodic.
    load_ohm : float
        External load, Ω.
    amplitude_m : float
        Half stroke A (triangle, trapezoid) or peak displacement (multisine, road), m.
    velocity_m_per_s : float
        Stroke speed (triangle, trapezoid), m/s.
    frequency_hz : float
        Fundamental (multisine) or lowest frequency (road), Hz.
    corner_s : float
        Corner blend, s: the acceleration is ±velocity_m_per_s / corner_s, so a triangle's
        reversal lasts 2 corner_s and a trapezoid's stop or start corner_s.
    hold_s : float
        Dwell at each end (trapezoid), s.
    duration_s : float or None
        Recorded duration (default: two cycles; road: 4 / frequency_hz).
    components : int
        Sine components (multisine, road).
    lead_in_s : float
        Unrecorded time the protocol runs before the record starts (default an eighth
        of a cycle: the record starts mid-stroke, at full speed).
    seed : int
        Phases of ``road``.
    """

    kind: str
    load_ohm: float
    amplitude_m: float = 0.02
    velocity_m_per_s: float = 0.1
    frequency_hz: float = 0.5
    corner_s: float = 0.02
    hold_s: float = 0.2
    duration_s: float | None = None
    components: int = 6
    lead_in_s: float | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in PROTOCOL_KINDS:
            raise ValueError(f"Protocol: kind {self.kind!r} unknown (one of "
                             f"{', '.join(PROTOCOL_KINDS)})")
        for name in ("load_ohm", "amplitude_m", "velocity_m_per_s", "frequency_hz", "corner_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"Protocol: {name} must be > 0, got {v!r}")
        if not (isinstance(self.hold_s, (int, float)) and self.hold_s >= 0):
            raise ValueError(f"Protocol: hold_s must be >= 0, got {self.hold_s!r}")
        if not (isinstance(self.components, int) and self.components >= 1):
            raise ValueError(f"Protocol: components must be an integer >= 1, got "
                             f"{self.components!r}")
        for name in ("duration_s", "lead_in_s"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v >= 0):
                raise ValueError(f"Protocol: {name} must be None or >= 0, got {v!r}")
        if self.kind in ("triangle", "trapezoid"):
            stroke_s = 2 * self.amplitude_m / self.velocity_m_per_s
            if self.corner_s >= stroke_s:
                raise ValueError(f"Protocol: corner_s = {self.corner_s:g} s must be shorter "
                                 f"than a stroke (2 A / v = {stroke_s:g} s)")

    @property
    def cycle_s(self) -> float:
        """Duration of one cycle, s (road: 1 / frequency_hz)."""
        if self.kind == "triangle":
            return 2 * (2 * self.amplitude_m / self.velocity_m_per_s + self.corner_s)
        if self.kind == "trapezoid":
            return 2 * (2 * self.amplitude_m / self.velocity_m_per_s + self.corner_s
                        + self.hold_s)
        return 1.0 / self.frequency_hz

    @property
    def record_s(self) -> float:
        if self.duration_s is not None:
            return float(self.duration_s)
        return (4.0 if self.kind == "road" else 2.0) * self.cycle_s

    @property
    def lead_s(self) -> float:
        return 0.125 * self.cycle_s if self.lead_in_s is None else float(self.lead_in_s)

    @property
    def periodic(self) -> bool:
        return self.kind != "road"

    def file_name(self) -> str:
        if self.kind in ("triangle", "trapezoid"):
            tag = f"{self.kind}_v{self.velocity_m_per_s:g}"
        else:
            tag = f"{self.kind}_f{self.frequency_hz:g}"
        return f"{tag}_A{1e3 * self.amplitude_m:g}mm_Re{self.load_ohm:g}.csv"

    def describe(self) -> str:
        if self.kind == "triangle":
            return (f"triangle strokes ±{1e3 * self.amplitude_m:g} mm at "
                    f"{self.velocity_m_per_s:g} m/s, reversals blended over "
                    f"{2e3 * self.corner_s:g} ms")
        if self.kind == "trapezoid":
            return (f"trapezoid ±{1e3 * self.amplitude_m:g} mm at {self.velocity_m_per_s:g} m/s, "
                    f"{1e3 * self.hold_s:g} ms dwell, corners {1e3 * self.corner_s:g} ms")
        if self.kind == "multisine":
            return (f"multisine, {self.components} harmonics of {self.frequency_hz:g} Hz, "
                    f"peak {1e3 * self.amplitude_m:g} mm")
        return (f"road-like record, {self.components} components "
                f"{self.frequency_hz:g}-{12 * self.frequency_hz:g} Hz, peak "
                f"{1e3 * self.amplitude_m:g} mm (seed {self.seed})")

    # ------------------------------------------------------------------ motions
    def motion(self) -> Any:
        """The exact motion; the record is t ∈ [0, record_s], the lead-in starts at
        −lead_s."""
        t0, t1 = -self.lead_s, self.record_s
        if self.kind in ("triangle", "trapezoid"):
            return self._strokes(t0, t1)
        if self.kind == "multisine":
            k = np.arange(1, self.components + 1)
            f = self.frequency_hz * k
            ph = -math.pi * k * (k - 1) / self.components  # Schroeder: low crest factor
            amp = 1.0 / k  # equal velocity amplitudes
        else:
            rng = np.random.default_rng(self.seed)
            f = self.frequency_hz * np.geomspace(1.0, 12.0, self.components)
            f = f * np.exp(rng.uniform(-0.05, 0.05, f.size))  # incommensurate
            ph = rng.uniform(0.0, 2 * math.pi, f.size)
            amp = 1.0 / np.sqrt(f / self.frequency_hz)  # 1/f PSD on a log-spaced grid
        unit = MultisineMotion(amp, f, ph)
        t = np.linspace(t0, t1, max(2000, int(200 * (t1 - t0) * f.max())))
        peak = float(np.max(np.abs(unit.evaluate(t)[0])))
        return MultisineMotion(amp * self.amplitude_m / peak, f, ph)

    def _strokes(self, t0: float, t1: float) -> PiecewiseMotion:
        """Strokes from t0, where the rod is at x = 0 moving up at +v0 (reversals blended
        over 2 corner_s for the triangle; stop and start over corner_s each for the
        trapezoid)."""
        v0, tc = self.velocity_m_per_s, self.corner_s
        a = v0 / tc
        knots: list[float] = []
        acc: list[float] = []
        t = t0
        plateau = 2 * self.amplitude_m / v0 - tc
        if self.kind == "triangle":
            cycle = [(2 * tc, -a), (plateau, 0.0), (2 * tc, a), (plateau, 0.0)]
        else:
            cycle = [(tc, -a), (self.hold_s, 0.0), (tc, -a), (plateau, 0.0),
                     (tc, a), (self.hold_s, 0.0), (tc, a), (plateau, 0.0)]
        pattern = [(plateau / 2, 0.0)]
        while t < t1 + self.cycle_s:
            for dur, aa in pattern:
                knots.append(t)
                acc.append(aa)
                t += dur
            pattern = cycle
        knots.append(t)
        kn, ac = np.asarray(knots), np.asarray(acc)
        keep = np.diff(kn) > 0
        kn = np.concatenate([kn[:-1][keep], [kn[-1]]])
        return PiecewiseMotion(kn, ac[keep], 0.0, v0)


def parse_protocol(text: str) -> Protocol:
    """A protocol from ``KIND:NAME=VALUE,...``, e.g.
    ``triangle:load_ohm=10,velocity_m_per_s=0.06,amplitude_m=0.02`` (the command line's
    form; ValueError names the bad part and the valid names)."""
    kind, _, rest = text.partition(":")
    kind = kind.strip()
    if kind not in PROTOCOL_KINDS:
        raise ValueError(f"protocol {text!r}: kind {kind!r} unknown (one of "
                         f"{', '.join(PROTOCOL_KINDS)}), e.g. "
                         f"triangle:load_ohm=10,velocity_m_per_s=0.06")
    fields = {f.name: f.type for f in dataclasses.fields(Protocol) if f.name != "kind"}
    vals: dict[str, Any] = {}
    for item in filter(None, (p.strip() for p in rest.split(","))):
        name, eq, value = item.partition("=")
        name = name.strip()
        if not eq or name not in fields:
            raise ValueError(f"protocol {text!r}: {item!r} is not NAME=VALUE with NAME one of "
                             f"{', '.join(fields)}")
        try:
            num = float(value)
        except ValueError:
            raise ValueError(f"protocol {text!r}: {name} = {value!r} is not a number") from None
        vals[name] = int(num) if name in ("components", "seed") else num
    if "load_ohm" not in vals:
        raise ValueError(f"protocol {text!r}: load_ohm is required (e.g. load_ohm=10)")
    return Protocol(kind, **vals)
