"""Bench campaigns of the second generator: rigs, protocols, noise, and the writer of the
bench directory format (``bench.toml`` + one CSV per test) with a truth file.

The truth is written to ``generator_truth.toml`` (not ``truth.toml``: that name is the
product's own generator's, whose friction law this generator does not share).

Run order
---------
A campaign's tests are run one after the other in a stated order that is *not* the
order of the list (which is sorted by kind, speed and load): :func:`run_order` draws a
permutation from the seed and keeps the first one whose rank correlation with the list
position, the load and the peak speed are all below :data:`MAX_ORDER_CORRELATION`, so
that a drift over the campaign is not confounded with a test's load, speed or stroke.
Each test starts ``pause_s`` after the previous one ended (its unrecorded settling
cycles included).  The order and the start time of each record (its first sample) are
written to ``bench.toml`` as ``run_order`` and ``started_at``; a state of the whole
campaign (the grease temperature of the drift, :mod:`.model`) is carried across the
tests in that order.
"""

from __future__ import annotations

import datetime as dt
import math
import os
import shutil
import tempfile
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import tomli_w

from .model import Effects, Harvester, LuGre, RigModel
from .motions import Sine, multisine, road_like, trapezoid, triangle

__all__ = ["Rig", "RIGS", "PROTOCOL_SETS", "Noise", "Campaign", "TestSpec", "test_specs",
           "generate", "write_campaign", "run_order", "MAX_ORDER_CORRELATION",
           "CAMPAIGN_START"]

#: Largest |Spearman rank correlation| allowed between the run order and the list
#: position, the load and the peak speed of the tests (a run order "not sorted").
MAX_ORDER_CORRELATION = 0.3
#: When the first test of every generated campaign starts (the record's first sample).
CAMPAIGN_START = dt.datetime(2026, 3, 2, 9, 0, 0, tzinfo=dt.timezone.utc)


@dataclass(frozen=True)
class Rig:
    """A harvester on a bench, with its true friction and the test grid it runs."""

    name: str
    harvester: Harvester
    nut: LuGre
    bearing: LuGre
    loads_ohm: tuple[float, ...]
    amplitude_m: float
    description: str


def _nut(fc, fs, vs, alpha, sigma0, sigma1, visc, asym_coulomb=0.0, asym_visc=0.0):
    return LuGre(coulomb_pos=fc + asym_coulomb / 2, coulomb_neg=fc - asym_coulomb / 2, static=fs,
                 stribeck_velocity=vs, exponent=alpha, stiffness=sigma0, micro_damping=sigma1,
                 viscous_pos=visc + asym_visc / 2, viscous_neg=visc - asym_visc / 2)


RIGS: dict[str, Rig] = {
    # lead 10 mm, R_i 2.4 ohm, K_e 0.085 V s/rad: a lower-voltage, higher-current harvester
    "rig_b": Rig("rig_b",
                 Harvester(rotor_inertia_kgm2=9.0e-6, screw_inertia_kgm2=2.6e-5, lead_m=0.010,
                           winding_resistance_ohm=2.4, emf_constant_Vs_per_rad=0.085,
                           torque_constant_Nm_per_A=0.085, inductance_H=0.9e-3,
                           nut_mass_kg=0.35),
                 _nut(32.0, 46.0, 0.008, 0.7, 3e6, 2500.0, 160.0),
                 LuGre(0.018, 0.018, 0.026, 1.5, 0.6, 400.0, 0.05, 3e-5, 3e-5),
                 (3.3, 10.0, 33.0), 0.010,
                 "servo-hydraulic bench, lead 10 mm ball screw, 2.4 ohm generator"),
    # lead 6 mm, R_i 5.1 ohm, K_e 0.12 V s/rad
    "rig_c": Rig("rig_c",
                 Harvester(rotor_inertia_kgm2=1.4e-5, screw_inertia_kgm2=1.5e-5, lead_m=0.006,
                           winding_resistance_ohm=5.1, emf_constant_Vs_per_rad=0.12,
                           torque_constant_Nm_per_A=0.12, inductance_H=2.2e-3,
                           nut_mass_kg=0.25),
                 _nut(24.0, 38.0, 0.004, 0.5, 5e6, 3000.0, 110.0),
                 LuGre(0.012, 0.012, 0.02, 2.0, 1.5, 200.0, 0.02, 1.5e-5, 1.5e-5),
                 (10.0, 33.0, 100.0), 0.008,
                 "electromechanical bench, lead 6 mm ball screw, 5.1 ohm generator"),
}


@dataclass(frozen=True)
class TestSpec:
    """One test of a campaign: file name, motion, load, the bench.toml entry."""

    file: str
    motion: object
    load_ohm: float

    @property
    def excitation(self) -> str:
        return "sine" if isinstance(self.motion, Sine) else "recorded"


def _sine(rig: Rig, f: float, load: float, amp: float | None = None) -> TestSpec:
    a = amp if amp is not None else rig.amplitude_m
    return TestSpec(f"sine_A{a * 1e3:g}mm_f{f:g}Hz_Re{load:g}.csv",
                    Sine(a, f, cycles=1.0 if f < 1.2 else 2.0), load)


def _tri(rig: Rig, v: float, load: float) -> TestSpec:
    A = rig.amplitude_m
    period = 4 * A / v
    cycles = max(1, int(round(1.2 / period)))
    return TestSpec(f"triangle_v{v:g}_Re{load:g}.csv", triangle(A, v, cycles=cycles), load)


def _trap(rig: Rig, v: float, load: float) -> TestSpec:
    return TestSpec(f"trapezoid_v{v:g}_Re{load:g}.csv", trapezoid(rig.amplitude_m, v), load)


def _multi(rig: Rig, load: float, band: tuple[float, float], k: int, seed: int) -> TestSpec:
    rng = np.random.default_rng([seed, 101, k])
    return TestSpec(f"multisine{k}_Re{load:g}.csv",
                    multisine(rig.amplitude_m, band[0], band[1], 3.0, rng), load)


def _road(rig: Rig, load: float, k: int, seed: int) -> TestSpec:
    rng = np.random.default_rng([seed, 202, k])
    return TestSpec(f"road{k}_Re{load:g}.csv", road_like(1.2 * rig.amplitude_m, 3.0, rng), load)


def test_specs(rig: Rig, protocol: str, seed: int) -> list[TestSpec]:
    """The tests of one protocol set on a rig (see :data:`PROTOCOL_SETS`)."""
    L = rig.loads_ohm
    if protocol == "sines":          # 6 frequencies x 3 loads = 18
        return [_sine(rig, f, R) for f in (0.5, 1.0, 1.5, 2.0, 2.5, 3.0) for R in L]
    if protocol == "strokes":        # 4 speeds x 3 loads triangles + 3 trapezoids = 15
        return ([_tri(rig, v, R) for v in (0.02, 0.05, 0.1, 0.15) for R in L]
                + [_trap(rig, 0.08, R) for R in L])
    if protocol == "multi":          # 6 multisines + 9 road records = 15
        return ([_multi(rig, R, b, k, seed) for k, b in enumerate(((0.5, 3.0), (1.0, 5.0)))
                 for R in L]
                + [_road(rig, R, k, seed) for k in range(3) for R in L])
    if protocol == "mixed":          # 6 sines, 6 triangles, 1 trapezoid, 2 multisines, 1 road
        return ([_sine(rig, f, R) for f in (0.7, 2.5) for R in L]
                + [_tri(rig, v, R) for v in (0.03, 0.12) for R in L]
                + [_trap(rig, 0.08, L[1]), _multi(rig, L[0], (0.5, 4.0), 0, seed),
                   _multi(rig, L[2], (0.5, 4.0), 1, seed), _road(rig, L[1], 0, seed)])
    if protocol == "campaign27":     # 18 sines (2 amplitudes), 6 triangles, 3 recorded
        return ([_sine(rig, f, R, a) for a in (0.6 * rig.amplitude_m, rig.amplitude_m)
                 for f in (0.7, 1.5, 2.5) for R in L]
                + [_tri(rig, v, R) for v in (0.03, 0.12) for R in L]
                + [_trap(rig, 0.08, L[1]), _multi(rig, L[0], (0.5, 4.0), 0, seed),
                   _road(rig, L[2], 0, seed)])
    if protocol == "smoke":          # 3 short tests, one of each kind (tests of the generator)
        rng = np.random.default_rng([seed, 303])
        return [_sine(rig, 2.5, L[1]),
                TestSpec(f"triangle_short_Re{L[0]:g}.csv", triangle(rig.amplitude_m, 0.12), L[0]),
                TestSpec(f"road_short_Re{L[2]:g}.csv",
                         road_like(rig.amplitude_m, 1.2, rng, n=12), L[2])]
    raise ValueError(f"unknown protocol set {protocol!r}; choose one of {PROTOCOL_SETS}")


PROTOCOL_SETS = ("sines", "strokes", "multi", "mixed", "campaign27", "smoke")


@dataclass(frozen=True)
class Noise:
    """Measurement noise: AR(1) (coloured) on force and voltage, white on displacement."""

    force_N: float = 1.5
    force_ar: float = 0.9
    voltage_V: float = 0.02
    voltage_ar: float = 0.7
    displacement_m: float = 5e-7

    def __post_init__(self) -> None:
        for k in ("force_ar", "voltage_ar"):
            if not 0.0 <= getattr(self, k) < 1.0:
                raise ValueError(f"Noise: {k} must be in [0, 1), got {getattr(self, k)}")


@dataclass(frozen=True)
class Campaign:
    """A campaign: rig, protocol set, effects, noise, seed, sample rate."""

    rig: str = "rig_b"
    protocol: str = "mixed"
    effects: Effects = field(default_factory=Effects)
    asym_coulomb_N: float = 0.0       # nut F_C(+) - F_C(-)
    asym_viscous_Ns_per_m: float = 0.0
    noise: Noise = field(default_factory=Noise)
    seed: int = 0
    sample_rate_hz: float = 1000.0
    pause_s: float = 20.0             # rig at rest between two tests

    def __post_init__(self) -> None:
        if not (math.isfinite(self.pause_s) and self.pause_s >= 0):
            raise ValueError(f"Campaign: pause_s must be >= 0, got {self.pause_s}")
        if self.rig not in RIGS:
            raise ValueError(f"Campaign: unknown rig {self.rig!r}; choose one of {sorted(RIGS)}")
        if self.protocol not in PROTOCOL_SETS:
            raise ValueError(f"Campaign: unknown protocol {self.protocol!r}; choose one of "
                             f"{PROTOCOL_SETS}")

    def model(self) -> RigModel:
        rig = RIGS[self.rig]
        nut = rig.nut
        if self.asym_coulomb_N or self.asym_viscous_Ns_per_m:
            nut = replace(nut, coulomb_pos=nut.coulomb_pos + self.asym_coulomb_N / 2,
                          coulomb_neg=nut.coulomb_neg - self.asym_coulomb_N / 2,
                          viscous_pos=nut.viscous_pos + self.asym_viscous_Ns_per_m / 2,
                          viscous_neg=nut.viscous_neg - self.asym_viscous_Ns_per_m / 2)
        return RigModel(rig.harvester, nut, rig.bearing, self.effects)


def _ar1(rng: np.random.Generator, n: int, sigma: float, phi: float) -> np.ndarray:
    w = rng.standard_normal(n) * sigma * math.sqrt(1 - phi * phi)
    e = np.empty(n)
    e[0] = rng.standard_normal() * sigma
    for k in range(1, n):
        e[k] = phi * e[k - 1] + w[k]
    return e


def _ranks(a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    r = np.empty(a.size)
    r[np.argsort(a, kind="stable")] = np.arange(a.size)
    for v in np.unique(a):  # ties share their mean rank
        r[a == v] = r[a == v].mean()
    return r


def _spearman(a, b) -> float:
    ra, rb = _ranks(a), _ranks(b)
    if np.ptp(ra) == 0 or np.ptp(rb) == 0:
        return 0.0
    return float(np.corrcoef(ra, rb)[0, 1])


def _peak_speed(motion) -> float:
    t = np.linspace(0.0, motion.duration_s, 2001)
    return float(np.max(np.abs(motion.kinematics(t)[1])))


def run_order(specs: list[TestSpec], seed: int) -> list[int]:
    """The order the tests are run in: ``order[k]`` is the list index of the k-th test
    run.  The first permutation drawn from ``seed`` whose rank correlation with the
    list position, the load and the peak speed is within :data:`MAX_ORDER_CORRELATION`."""
    n = len(specs)
    if n < 4:
        return list(range(n))
    rng = np.random.default_rng([seed, 505])
    keys = (np.arange(n), [s.load_ohm for s in specs], [_peak_speed(s.motion) for s in specs])
    for _ in range(10000):
        order = rng.permutation(n)
        position = np.empty(n)
        position[order] = np.arange(n)           # when each listed test is run
        if all(abs(_spearman(position, k)) <= MAX_ORDER_CORRELATION for k in keys):
            return [int(k) for k in order]
    raise RuntimeError(f"run_order: no permutation of {n} tests within the correlation limit")


def generate(c: Campaign, only: tuple[int, ...] | None = None) -> list[dict]:
    """Simulate the tests of the campaign (all, or the list indices ``only``) in their run
    order (:func:`run_order`), carrying the grease temperature from test to test; returns
    dicts in list order with the spec, the signals, ``run_order`` (1 = first run),
    ``start_s`` (the record's first sample, from the campaign's start) and ``grease_K``
    (the grease temperature rise at the record's start and end).  Test k's noise is seeded
    by ``(seed, k)``."""
    model = c.model()
    specs = test_specs(RIGS[c.rig], c.protocol, c.seed)
    order = run_order(specs, c.seed)
    wanted = set(range(len(specs)) if only is None else only)
    last = max(p for p, k in enumerate(order) if k in wanted) if wanted else -1
    tau = c.effects.grease_capacity_J_per_K * c.effects.grease_resistance_K_per_W
    out, clock, grease = {}, 0.0, 0.0
    for pos, k in enumerate(order[:last + 1]):
        spec = specs[k]
        if pos:
            clock += c.pause_s
            grease *= math.exp(-c.pause_s / tau) if tau > 0 else 0.0
        start_s = clock + spec.motion.preroll_s
        clock = start_s + spec.motion.duration_s
        if k not in wanted and not model.drifts:
            continue
        t, x, F, V, Y, lay = model.simulate(spec.motion, spec.load_ohm, c.sample_rate_hz,
                                            grease_K=grease)
        g0 = grease
        if model.drifts:
            g0 = float(Y[lay["Tg"], 0])
            grease = float(Y[lay["Tg"], -1])
        if k not in wanted:
            continue
        if c.effects.voltage_delay_s:
            V = np.interp(t - c.effects.voltage_delay_s, t, V)
        rng = np.random.default_rng([c.seed, k])
        n = t.size
        out[k] = {"spec": spec, "time_s": t, "run_order": pos + 1, "start_s": start_s,
                  "grease_K": (g0, grease),
                  "displacement_m": x + rng.standard_normal(n) * c.noise.displacement_m,
                  "force_N": F + _ar1(rng, n, c.noise.force_N, c.noise.force_ar),
                  "voltage_V": V + _ar1(rng, n, c.noise.voltage_V, c.noise.voltage_ar)}
    return [out[k] for k in sorted(out)]


def _declared_harvester(h: Harvester) -> dict[str, float]:
    """What the rig's data sheet says, in the bench format's names: the nut + carriage
    mass is reflected into the screw inertia (J_s + m_n r^2)."""
    return {"motor_inertia_gcm2": h.rotor_inertia_kgm2 * 1e7,
            "screw_inertia_gcm2": (h.screw_inertia_kgm2 + h.nut_mass_kg * h.r ** 2) * 1e7,
            "lead_mm_per_rev": h.lead_m * 1e3,
            "internal_resistance_ohm": h.winding_resistance_ohm,
            "voltage_constant_Vs_per_rad": h.emf_constant_Vs_per_rad,
            "torque_constant_Nm_per_A": h.torque_constant_Nm_per_A,
            "inductance_H": h.inductance_H}


def _runs(model: RigModel, tests: list[dict]) -> list[dict]:
    """Per test, in run order: when it ran, the grease temperature rise and the nut's
    friction factors (Coulomb, viscous) at the record's start and end."""
    rows = []
    for tt in sorted(tests, key=lambda d: d["run_order"]):
        row = {"file": tt["spec"].file, "run_order": tt["run_order"],
               "start_s": float(tt["start_s"])}
        if model.drifts:
            (c0, v0), (c1, v1) = (model.drift_scales(g) for g in tt["grease_K"])
            row.update(grease_rise_start_K=tt["grease_K"][0], grease_rise_end_K=tt["grease_K"][1],
                       coulomb_factor_start=float(c0), coulomb_factor_end=float(c1),
                       viscous_factor_start=float(v0), viscous_factor_end=float(v1))
        rows.append(row)
    return rows


def _truth(c: Campaign, model: RigModel, tests: list[dict]) -> dict:
    return {"generator": "validation/second_generator (LuGre friction, own ODEs)",
            "campaign": {"rig": c.rig, "protocol": c.protocol, "seed": c.seed,
                         "sample_rate_hz": c.sample_rate_hz, "pause_s": c.pause_s,
                         "start": CAMPAIGN_START},
            "run": _runs(model, tests),
            "harvester": asdict(model.harvester), "nut_friction": asdict(model.nut),
            "bearing_friction": asdict(model.bearing),
            "changed_from_default": sorted(k for k, v in asdict(c.effects).items()
                                           if v != getattr(Effects(), k))
            + (["asym_coulomb_N", "asym_viscous_Ns_per_m"]
               if c.asym_coulomb_N or c.asym_viscous_Ns_per_m else []),
            "effects": asdict(c.effects), "noise": asdict(c.noise)}


def write_campaign(path: str | Path, c: Campaign, *, overwrite: bool = False) -> Path:
    """Generate and write the campaign atomically (temporary directory + rename)."""
    path = Path(path)
    if path.exists() and any(path.iterdir()) and not overwrite:
        raise FileExistsError(f"{path}: exists and is not empty")
    tests = generate(c)
    rig = RIGS[c.rig]
    doc = {"rig": {"name": rig.name, "has_generator": True,
                   "description": f"{rig.description} (second generator, seed {c.seed})"},
           "harvester": _declared_harvester(rig.harvester), "test": []}
    for tt in tests:
        s = tt["spec"]
        e = {"file": s.file, "load_ohm": float(s.load_ohm), "run_order": tt["run_order"],
             "started_at": CAMPAIGN_START + dt.timedelta(seconds=round(tt["start_s"], 3))}
        if s.excitation == "sine":
            e.update(frequency_hz=float(s.motion.frequency_hz),
                     amplitude_m=float(s.motion.amplitude_m))
        else:
            e.update(excitation="recorded", description=s.motion.kind)
        doc["test"].append(e)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
    try:
        tmp.chmod(0o755)
        (tmp / "bench.toml").write_text(tomli_w.dumps(doc), encoding="utf-8")
        (tmp / "generator_truth.toml").write_text(tomli_w.dumps(_truth(c, c.model(), tests)),
                                                  encoding="utf-8")
        for tt in tests:
            cols = np.column_stack([tt["time_s"], tt["displacement_m"], tt["force_N"],
                                    tt["voltage_V"]])
            np.savetxt(tmp / tt["spec"].file, cols, fmt="%.9g", delimiter=",", comments="",
                       header="time_s,displacement_m,force_N,voltage_V")
        if path.exists():
            old = path.with_name(f".{path.name}.old-{os.getpid()}")
            os.replace(path, old)
            os.replace(tmp, path)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return path
