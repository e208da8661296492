"""Synthetic bench data for the paper's test matrix (SPEC §3), with seeded noise and
optionally hidden physical effects (backlash, SPEC §8, and any registered component).

The embedded default data set ``data/bench_prototype`` is made by
:func:`write_synthetic` with :data:`PROTOTYPE_FRICTION` and backlash; its true
parameters are written next to it in ``truth.toml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import tomli_w

from ..physics import BenchModel, make_component
from ..physics.bench_sim import simulate_bench
from ..physics.motion import SineMotion
from ..physics.params import FrictionParams, HarvesterParams
from .bench_format import BenchTest, write_bench

__all__ = ["SyntheticSpec", "generate_bench_tests", "write_synthetic", "PROTOTYPE_FRICTION",
           "TEST_FREQUENCIES_HZ", "TEST_LOADS_OHM", "TEST_AMPLITUDE_M", "test_file_name"]

#: Paper §3 test matrix (SPEC §3; 0.5 Hz steps and ohms are assumptions).
TEST_FREQUENCIES_HZ: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5)
TEST_LOADS_OHM: tuple[float, ...] = (15.0, 47.0, 109.0)
TEST_AMPLITUDE_M: float = 0.015

#: Friction of the embedded prototype data (our choice, inside the SPEC §2 ranges).
PROTOTYPE_FRICTION = FrictionParams(
    nut_breakaway_N=60.0, nut_coulomb_N=40.0, nut_breakaway_velocity_m_per_s=0.01,
    nut_viscous_Ns_per_m=150.0, bearing_breakaway_Nm=0.02, bearing_coulomb_Nm=0.015,
    bearing_breakaway_velocity_rad_per_s=1.0, bearing_viscous_Nms_per_rad=3e-5)


def test_file_name(frequency_hz: float, load_ohm: float) -> str:
    """CSV name of a matrix test, e.g. ``f1.5Hz_Re47.csv``."""
    return f"f{frequency_hz:g}Hz_Re{load_ohm:g}.csv"


@dataclass(frozen=True)
class SyntheticSpec:
    """What to generate.

    Attributes
    ----------
    harvester : HarvesterParams
    friction : FrictionParams
    effects : mapping
        Hidden effects: component name → {parameter name: value} (missing
        parameters take the component's defaults).
    frequencies_hz, loads_ohm : sequences
        The test matrix (all combinations).
    amplitude_m : float
    cycles : float
        Recorded cycles per test (after one cycle of warm-up, not recorded).
    sample_rate_hz : float
    noise_force_N, noise_voltage_V, noise_displacement_m : float
        Standard deviations of white Gaussian measurement noise.
    seed : int
    """

    harvester: HarvesterParams = field(default_factory=HarvesterParams)
    friction: FrictionParams = PROTOTYPE_FRICTION
    effects: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    frequencies_hz: Sequence[float] = TEST_FREQUENCIES_HZ
    loads_ohm: Sequence[float] = TEST_LOADS_OHM
    amplitude_m: float = TEST_AMPLITUDE_M
    cycles: float = 2.0
    sample_rate_hz: float = 1000.0
    noise_force_N: float = 2.0
    noise_voltage_V: float = 0.05
    noise_displacement_m: float = 2e-6
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("amplitude_m", "cycles", "sample_rate_hz"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"SyntheticSpec: {name} must be > 0, got {v!r}")
        for name in ("noise_force_N", "noise_voltage_V", "noise_displacement_m"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"SyntheticSpec: {name} must be >= 0, got {v!r}")
        if not self.frequencies_hz or any(f <= 0 for f in self.frequencies_hz):
            raise ValueError("SyntheticSpec: frequencies_hz must be positive")
        if not self.loads_ohm or any(r <= 0 for r in self.loads_ohm):
            raise ValueError("SyntheticSpec: loads_ohm must be positive")

    def model(self) -> BenchModel:
        comps = [make_component(name) for name in self.effects]
        return BenchModel(self.harvester, comps)


def generate_bench_tests(spec: SyntheticSpec, progress: Any = None) -> list[BenchTest]:
    """Simulate the test matrix and add seeded noise.

    Parameters
    ----------
    spec : SyntheticSpec
    progress : callable, optional
        Called with the number of finished tests (for progress bars).
    """
    model = spec.model()
    effect_values = {k: v for params in spec.effects.values() for k, v in params.items()}
    rng = np.random.default_rng(spec.seed)
    tests = []
    for load in spec.loads_ohm:
        for f in spec.frequencies_hz:
            period = 1.0 / f
            dt = 1.0 / spec.sample_rate_hz
            n = int(round(spec.cycles * period / dt)) + 1
            n_warm = int(round(period / dt))
            grid = (np.arange(-n_warm, n) * dt)
            motion = SineMotion(spec.amplitude_m, f)
            p = model.param_vector(load, spec.friction, effect_values)
            sim = simulate_bench(model, motion, p, grid)
            keep = slice(n_warm, None)
            t = grid[keep] - grid[n_warm]
            x = sim.displacement_m[keep] + rng.normal(0.0, spec.noise_displacement_m, t.size)
            F = sim.force_N[keep] + rng.normal(0.0, spec.noise_force_N, t.size)
            V = sim.voltage_V[keep] + rng.normal(0.0, spec.noise_voltage_V, t.size)
            tests.append(BenchTest(file=test_file_name(f, load), frequency_hz=float(f),
                                   amplitude_m=spec.amplitude_m, load_ohm=float(load),
                                   excitation="sine", time_s=t, displacement_m=x, force_N=F,
                                   voltage_V=V))
            if progress is not None:
                progress(len(tests))
    return tests


def _truth_toml(spec: SyntheticSpec, command: str) -> str:
    model = spec.model()
    effects = {}
    for name, params in spec.effects.items():
        comp = make_component(name)
        values = comp.defaults()
        values.update(params)
        effects[name] = values
    doc = {
        "generator": {"command": command, "seed": spec.seed, "cycles": spec.cycles,
                      "sample_rate_hz": spec.sample_rate_hz, "warm_up_cycles": 1},
        "friction": spec.friction.as_dict(),
        "effects": effects,
        "noise": {"force_N": spec.noise_force_N, "voltage_V": spec.noise_voltage_V,
                  "displacement_m": spec.noise_displacement_m},
        "model": {"states": model.state_names},
    }
    return tomli_w.dumps(doc)


def _readme(spec: SyntheticSpec, command: str) -> str:
    """README.md of a generated data directory: what it holds and how to regenerate it."""
    if spec.effects:
        lines = []
        for name, params in spec.effects.items():
            values = make_component(name).defaults()
            values.update(params)
            lines.append(f"**{name}** (" + ", ".join(f"{k} = {v:g}" for k, v in values.items())
                         + ")")
        effects = "; ".join(lines)
    else:
        effects = "none"
    freqs = ", ".join(f"{f:g}" for f in spec.frequencies_hz)
    loads = ", ".join(f"{r:g}" for r in spec.loads_ohm)
    return f"""# Synthetic bench data (generated by ehsa_opt)

Test matrix (SPEC §3): frequencies {freqs} Hz × loads {loads} Ω, sine displacement of amplitude
{spec.amplitude_m * 1e3:g} mm, {spec.cycles:g} recorded cycles per test after one unrecorded
warm-up cycle, sampled at {spec.sample_rate_hz:g} Hz. Harvester: the `[harvester]` table of
`bench.toml` (paper Table 1 where absent). Friction: `[friction]` of `truth.toml`.

Hidden effects: {effects}.
Backlash makes the short force peaks after each velocity reversal that the paper's model
missed (paper Fig 11, SPEC §8).

Gaussian measurement noise (seed {spec.seed}): force {spec.noise_force_N:g} N, voltage
{spec.noise_voltage_V:g} V, displacement {spec.noise_displacement_m:g} m.

The true parameters are in `truth.toml`. Regenerate exactly (same seed, same files):

```bash
{command or "ehsa-opt bench generate OUT_DIR"} --overwrite
```
"""


def write_synthetic(out_dir: str | Path, spec: SyntheticSpec, *, command: str = "",
                    overwrite: bool = False, progress: Any = None) -> Path:
    """Generate the test matrix and write it (atomically) with ``truth.toml`` and a
    README.md that says how to regenerate it."""
    tests = generate_bench_tests(spec, progress=progress)
    effects = ", ".join(spec.effects) or "none"
    rig = {"name": "synthetic BS-EHSA prototype", "has_generator": True,
           "description": f"generated by ehsa_opt (seed {spec.seed}); hidden effects: {effects}; "
                          f"true parameters in truth.toml"}
    extra = {"truth.toml": _truth_toml(spec, command), "README.md": _readme(spec, command)}
    return write_bench(out_dir, tests, harvester=spec.harvester, rig=rig, extra_files=extra,
                       overwrite=overwrite)
