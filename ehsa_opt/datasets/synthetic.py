"""Synthetic bench data for the paper's test matrix (paper §2–3), with seeded noise and
optionally hidden physical effects (backlash and any registered component).

The embedded default data set ``data/bench_prototype`` is made by
:func:`write_synthetic` with :data:`PROTOTYPE_FRICTION` and backlash; its true
parameters are written next to it in ``truth.toml``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import tomli_w

from ..physics import BenchModel, make_component
from ..physics.bench_sim import simulate_bench
from ..physics.friction import LAW_PARAMETER_NAMES, STRIBECK_EXPONENT
from ..physics.motion import SineMotion
from ..physics.params import FrictionParams, HarvesterParams
from .bench_format import BenchTest, write_bench
from .protocols import Protocol

__all__ = ["SyntheticSpec", "spec_from_options", "generate_bench_tests", "write_synthetic", "synthetic_files",
           "PROTOTYPE_FRICTION",
           "TEST_FREQUENCIES_HZ", "TEST_LOADS_OHM", "TEST_AMPLITUDE_M", "test_file_name"]

#: Paper §3 test matrix (0.5 Hz steps and ohms are assumptions).
TEST_FREQUENCIES_HZ: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5)
TEST_LOADS_OHM: tuple[float, ...] = (15.0, 47.0, 109.0)
TEST_AMPLITUDE_M: float = 0.015

#: Friction of the embedded prototype data (our choice, inside the distributor ranges of the friction parameters).
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
    presliding : mapping
        Empty: the static friction law.  Otherwise the LuGre law
        (``friction_law="lugre"`` of :class:`~ehsa_opt.physics.bench_model.BenchModel`)
        with these values of ``presliding_stiffness_N_per_m`` (σ₀, N/m) and
        ``presliding_damping_Ns_per_m`` (σ₁, N s/m); one left out takes its declared
        typical value.  With ``stribeck_exponent`` (δ) too, the generalised Stribeck
        LuGre law (``friction_law="lugre_stribeck"``; the nut's breakaway velocity is
        then the Stribeck velocity).
    frequencies_hz, loads_ohm : sequences
        The test matrix (all combinations).
    amplitude_m : float
    amplitudes_m : sequence of float
        If given, sine tests at every one of these amplitudes (replaces ``amplitude_m``;
        file names then carry the amplitude).
    protocols : sequence of Protocol
        Non-sine tests (triangle / trapezoid strokes, multisines, road-like records),
        written as ``excitation = "recorded"``; each is simulated from its exact motion
        with an unrecorded lead-in (:class:`~ehsa_opt.datasets.protocols.Protocol`).
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
    presliding: Mapping[str, float] = field(default_factory=dict)
    frequencies_hz: Sequence[float] = TEST_FREQUENCIES_HZ
    loads_ohm: Sequence[float] = TEST_LOADS_OHM
    amplitude_m: float = TEST_AMPLITUDE_M
    amplitudes_m: Sequence[float] = ()
    protocols: Sequence[Protocol] = ()
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
        if any(f <= 0 for f in self.frequencies_hz):
            raise ValueError("SyntheticSpec: frequencies_hz must be positive")
        if not self.frequencies_hz and not self.protocols:
            raise ValueError("SyntheticSpec: no test: give frequencies_hz or protocols")
        if any(not (a > 0) for a in self.amplitudes_m):
            raise ValueError("SyntheticSpec: amplitudes_m must be > 0 (metres)")
        if any(not isinstance(p, Protocol) for p in self.protocols):
            raise ValueError("SyntheticSpec: protocols must be Protocol objects")
        if self.frequencies_hz and (not self.loads_ohm or any(r <= 0 for r in self.loads_ohm)):
            raise ValueError("SyntheticSpec: loads_ohm must be positive")
        known = LAW_PARAMETER_NAMES["lugre_stribeck"]
        bad = [k for k in self.presliding if k not in known]
        if bad:
            raise ValueError(f"SyntheticSpec: presliding has unknown parameter(s) "
                             f"{', '.join(bad)} (known: {', '.join(known)})")

    @property
    def sine_amplitudes_m(self) -> tuple[float, ...]:
        return tuple(self.amplitudes_m) or (self.amplitude_m,)

    @property
    def n_tests(self) -> int:
        return (len(self.frequencies_hz) * len(self.loads_ohm) * len(self.sine_amplitudes_m)
                + len(self.protocols))

    def model(self) -> BenchModel:
        comps = [make_component(name) for name in self.effects]
        law = ("static" if not self.presliding else "lugre_stribeck"
               if STRIBECK_EXPONENT in self.presliding else "lugre")
        return BenchModel(self.harvester, comps, friction_law=law)


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
    effect_values.update(spec.presliding)
    rng = np.random.default_rng(spec.seed)
    dt = 1.0 / spec.sample_rate_hz
    tests = []

    def record(motion: Any, load: float, n: int, n_lead: int) -> tuple[np.ndarray, ...]:
        grid = np.arange(-n_lead, n) * dt
        p = model.param_vector(load, spec.friction, effect_values)
        sim = simulate_bench(model, motion, p, grid)
        keep = slice(n_lead, None)
        t = grid[keep] - grid[n_lead]
        x = sim.displacement_m[keep] + rng.normal(0.0, spec.noise_displacement_m, t.size)
        F = sim.force_N[keep] + rng.normal(0.0, spec.noise_force_N, t.size)
        V = sim.voltage_V[keep] + rng.normal(0.0, spec.noise_voltage_V, t.size)
        return t, x, F, V

    amps = spec.sine_amplitudes_m
    for amp in amps:
        for load in spec.loads_ohm:
            for f in spec.frequencies_hz:
                period = 1.0 / f
                n = int(round(spec.cycles * period / dt)) + 1
                n_warm = int(round(period / dt))
                t, x, F, V = record(SineMotion(amp, f), load, n, n_warm)
                name = test_file_name(f, load)
                if len(amps) > 1:
                    name = name[:-4] + f"_A{1e3 * amp:g}mm.csv"
                tests.append(BenchTest(file=name, frequency_hz=float(f), amplitude_m=amp,
                                       load_ohm=float(load), excitation="sine", time_s=t,
                                       displacement_m=x, force_N=F, voltage_V=V))
                if progress is not None:
                    progress(len(tests))
    for proto in spec.protocols:
        n = int(round(proto.record_s / dt)) + 1
        n_lead = int(round(proto.lead_s / dt))
        t, x, F, V = record(proto.motion(), proto.load_ohm, n, n_lead)
        tests.append(BenchTest(file=proto.file_name(), frequency_hz=None, amplitude_m=None,
                               load_ohm=float(proto.load_ohm), excitation="recorded", time_s=t,
                               displacement_m=x, force_N=F, voltage_V=V,
                               description=proto.describe()))
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
        "friction_law": model.friction_law,
        "noise": {"force_N": spec.noise_force_N, "voltage_V": spec.noise_voltage_V,
                  "displacement_m": spec.noise_displacement_m},
        "model": {"states": model.state_names},
    }
    if spec.presliding:
        p = model.param_vector(1.0, spec.friction, spec.presliding)
        doc["presliding"] = {n: float(p[model.param_names.index(n)]) for n in model.law_names}
    if spec.amplitudes_m:
        doc["generator"]["sine_amplitudes_m"] = list(spec.sine_amplitudes_m)
    if spec.protocols:
        doc["protocols"] = [{"file": p.file_name(), "description": p.describe(),
                             "lead_in_s": p.lead_s, "periodic": p.periodic,
                             **{k: v for k, v in dataclasses.asdict(p).items()
                                if v is not None}} for p in spec.protocols]
    return tomli_w.dumps(doc)


def _protocol_lines(spec: SyntheticSpec) -> str:
    if not spec.protocols:
        return ""
    lines = "".join(f"- `{p.file_name()}`: {p.describe()}\n" for p in spec.protocols)
    return ("Non-sine tests (`excitation = \"recorded\"`; the motion runs for an unrecorded "
            "lead-in before the record starts):\n\n" + lines + "\n")


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
    amps = ", ".join(f"{1e3 * a:g}" for a in spec.sine_amplitudes_m)
    sines = (f"Sine tests (paper §3): frequencies {freqs} Hz × loads {loads} Ω × amplitudes "
             f"{amps} mm, {spec.cycles:g} recorded cycles per test after one unrecorded "
             f"warm-up cycle" if spec.frequencies_hz else "No sine tests")
    return f"""# Synthetic bench data (generated by ehsa_opt)

{sines}, sampled at {spec.sample_rate_hz:g} Hz. Harvester: the `[harvester]` table of
`bench.toml` (paper Table 1 where absent). Friction: `[friction]` of `truth.toml`.

{_protocol_lines(spec)}Hidden effects: {effects}.
Backlash makes the short force peaks after each velocity reversal that the paper's model
missed (paper Fig 11).

Gaussian measurement noise (seed {spec.seed}): force {spec.noise_force_N:g} N, voltage
{spec.noise_voltage_V:g} V, displacement {spec.noise_displacement_m:g} m.

The true parameters are in `truth.toml`. Regenerate exactly (same seed, same files):

```bash
{command or "ehsa-opt bench generate OUT_DIR"} --overwrite
```
"""


def synthetic_files(spec: SyntheticSpec, command: str = "") -> tuple[dict[str, Any], dict[str, str]]:
    """The ``[rig]`` table and the text files (``truth.toml``, ``README.md``) written
    beside the tests of ``spec``; ``command`` regenerates the data (README, truth)."""
    effects = ", ".join(spec.effects) or "none"
    rig = {"name": "synthetic BS-EHSA prototype", "has_generator": True,
           "description": f"generated by ehsa_opt (seed {spec.seed}); hidden effects: {effects}; "
                          f"true parameters in truth.toml"}
    return rig, {"truth.toml": _truth_toml(spec, command), "README.md": _readme(spec, command)}


def write_synthetic(out_dir: str | Path, spec: SyntheticSpec, *, command: str = "",
                    overwrite: bool = False, progress: Any = None) -> Path:
    """Generate the test matrix and write it (atomically) with ``truth.toml`` and a
    README.md that says how to regenerate it."""
    tests = generate_bench_tests(spec, progress=progress)
    rig, extra = synthetic_files(spec, command)
    return write_bench(out_dir, tests, harvester=spec.harvester, rig=rig, extra_files=extra,
                       overwrite=overwrite)


def _pairs(items: Sequence[str] | Mapping[str, float], option: str,
           example: str) -> dict[str, float]:
    """``NAME=VALUE`` strings (or a mapping already) as a name → number dict."""
    if isinstance(items, Mapping):
        items = [f"{k}={v!r}" for k, v in items.items()]
    out = {}
    for item in items:
        name, eq, value = item.partition("=")
        if not eq:
            raise ValueError(f"{option} '{item}': write NAME=VALUE, e.g. {example}")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise ValueError(f"{option} '{item}': '{value}' is not a number") from None
    return out


def _float_list(text: str | Sequence[float], option: str) -> tuple[float, ...]:
    """``"0.5,1,2"`` (or a sequence of numbers) → (0.5, 1.0, 2.0); an empty string → ()
    (no sine tests)."""
    if not isinstance(text, str):
        text = ",".join(repr(float(v)) for v in text)
    try:
        return tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise ValueError(f"{option} {text!r}: give comma-separated numbers, e.g. "
                         f"'0.5,1,2' (or '' for none)") from None


def spec_from_options(*, effects: Sequence[str] = (),
                      effect_params: Sequence[str] | Mapping[str, float] = (),
                      harvester: Sequence[str] | Mapping[str, float] = (),
                      frequencies_hz: str | Sequence[float] | None = None,
                      loads_ohm: str | Sequence[float] | None = None,
                      amplitudes_m: Sequence[float] = (),
                      protocols: Sequence[str] = (), **fields: Any) -> SyntheticSpec:
    """A :class:`SyntheticSpec` from the command line's strings (``bench generate``):
    effect names, ``NAME=VALUE`` effect parameters and harvester constants, comma lists
    of frequencies and loads (or the same as mappings and number sequences),
    ``KIND:NAME=VALUE,...`` protocols
    (:func:`~ehsa_opt.datasets.protocols.parse_protocol`).  ValueError names the option
    and the fix."""
    from ..physics import COMPONENTS
    from .protocols import parse_protocol
    params = _pairs(effect_params, "--effect-param", "backlash_gap_m=1e-4")
    eff: dict[str, dict[str, float]] = {}
    for name in effects:
        comp = make_component(name)
        eff[name] = {k: v for k, v in params.items() if k in {q.name for q in comp.parameters}}
    known = {q.name for n in eff for q in COMPONENTS[n].parameters}
    unknown = set(params) - known
    if unknown:
        raise ValueError(f"--effect-param: {', '.join(sorted(unknown))} belong to no chosen "
                         f"--effect (chosen: {', '.join(eff) or 'none'})")
    try:
        protos = [p if isinstance(p, Protocol) else parse_protocol(p) for p in protocols]
    except ValueError as exc:
        raise ValueError(f"--protocol: {exc}") from None
    extra: dict[str, Any] = dict(fields)
    if frequencies_hz is not None:
        extra["frequencies_hz"] = _float_list(frequencies_hz, "--frequencies-hz")
    if loads_ohm is not None:
        extra["loads_ohm"] = _float_list(loads_ohm, "--loads-ohm")
    try:
        harv = HarvesterParams(**_pairs(harvester, "--harvester", "lead_mm_per_rev=10"))
    except TypeError as exc:
        raise ValueError(f"--harvester: {exc}") from None
    return SyntheticSpec(harvester=harv, effects=eff, amplitudes_m=tuple(amplitudes_m),
                         protocols=protos, **extra)
