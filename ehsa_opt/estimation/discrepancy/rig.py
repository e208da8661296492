"""The rig the discrepancy workflow fits: what is fitted (:class:`Rig`: harvester constants,
rig kind and the model's components, one cached :class:`~ehsa_opt.physics.bench_model.BenchModel`
per distinct rig), the base parameters' bounds in this workflow
(:data:`DISCREPANCY_PARAMETERS`, a named override of the declared base parameters, and
:func:`param_scale`), a quick linear least-squares friction (:func:`linear_baseline`) and
the forward simulation of the tests (:func:`predict`, :func:`simulate_test`).

The model is the bench model (``generator=False`` for rigs without generator, e.g. EMPS:
``M a + friction(v) + offset``), so any registered
:class:`~ehsa_opt.physics.components.Component` plugs in without a copy of the model.
Without a generator the bearing friction is fixed at zero (it is indistinguishable from
the nut friction at the rod).

Forward predictions for held-out tests are true simulations (CVODES, one unrecorded
warm-up cycle for sine tests), never collocation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from ...physics import BenchModel
from ...physics.base_parameters import Parameter, override
from ...physics.bench_map import simulate_map, simulate_map_sensitivity
from ...physics.bench_sim import simulate_bench
from ...physics.components import Component, ParamSpec
from ...physics.motion import FilteredMotion, SineMotion
from ...physics.friction import LAW_PARAMETER_NAMES
from ...physics.params import FRICTION_NAMES, HarvesterParams
from .prepared import NO_GENERATOR_FIXED, PreparedTest
from .spread import spread

__all__ = ["Rig", "RigSimulation", "linear_baseline", "param_scale", "predict", "simulate_test",
           "simulated", "simulate_raw", "outputs_of",
           "predict_map", "predict_map_jacobian", "EXACT_JACOBIAN", "map_suits", "uniform_grid", "parameter_vector", "warmup_grid", "fit_predictor", "NON_SMOOTH", "USE_MAP",
           "BASE_SPECS", "DISCREPANCY_PARAMETERS", "NUT_NAMES", "LUGRE_FIXED"]

NUT_NAMES = FRICTION_NAMES[:4]


#: The base parameters in the discrepancy fit: a named override of
#: :data:`~ehsa_opt.physics.base_parameters.PARAMETERS`.
DISCREPANCY_PARAMETERS: dict[str, Parameter] = override(
    "discrepancy",
    "the likelihood fit also serves rigs other than the prototype (EMPS, other generators), so "
    "its bounds are wider than the identification's distributor ends, yet finite and well "
    "inside the physical ones so the scaled NLP stays well conditioned",
    {"nut_breakaway_N": (0.0, 2000.0), "nut_coulomb_N": (0.0, 2000.0),
     "nut_breakaway_velocity_m_per_s": (2e-4, 0.5), "nut_viscous_Ns_per_m": (0.0, 1e4),
     "bearing_breakaway_Nm": (0.0, 1.0), "bearing_coulomb_Nm": (0.0, 1.0),
     "bearing_breakaway_velocity_rad_per_s": (0.01, 50.0),
     "bearing_viscous_Nms_per_rad": (0.0, 1e-2), "offset_N": (-1e3, 1e3),
     # the bristle's rate σ₀/φ(v) and the force σ₁/σ₀ dF_b/dt need σ₀ > 0: from a
     # presliding displacement of 10 mm at 100 N (far softer than any ball screw) to the
     # static limit (a 1e10 N/m bristle relaxes within a 1 kHz sample at any speed)
     "presliding_stiffness_N_per_m": (1e4, 1e10)})
#: The bearing curve under the dynamic law on a rigid rig: one Simscape curve (the nut's
#: names) is the steady state of one bristle carrying the rod's whole friction (the
#: nut/bearing split is not identifiable at the rod, and with both free a fit moves the
#: friction to the bearing until the bristle's rate σ₀/φ diverges).
LUGRE_FIXED: dict[str, float] = {"bearing_breakaway_Nm": 0.0, "bearing_coulomb_Nm": 0.0,
                                 "bearing_breakaway_velocity_rad_per_s": 1.0,
                                 "bearing_viscous_Nms_per_rad": 0.0}
#: The same as ``ParamSpec`` (default: the typical value, which also sets :func:`param_scale`).
BASE_SPECS: dict[str, ParamSpec] = {n: ParamSpec(n, q.unit, q.typical, q.lower, q.upper, q.doc)
                                    for n, q in DISCREPANCY_PARAMETERS.items()}


def param_scale(spec: ParamSpec) -> float:
    """Typical magnitude of a parameter (its default, else a twentieth of its bound):
    the scale the decision variables are divided by."""
    if spec.default != 0.0:
        return abs(spec.default)
    return max(abs(spec.lower), abs(spec.upper)) / 20.0 or 1.0


_MODELS: dict[tuple, Any] = {}


@dataclass(frozen=True)
class Rig:
    """What is fitted: harvester constants, rig kind, the model's components and its
    friction law (``"static"``: the Simscape map; ``"lugre"``: that map as the steady
    state of a bristle; ``"lugre_stribeck"``: the generalised Stribeck curve as the
    bristle's steady state, :class:`~ehsa_opt.physics.bench_model.BenchModel`)."""

    harvester: HarvesterParams
    has_generator: bool = True
    components: tuple[Component, ...] = ()
    friction_law: str = "static"

    def model(self) -> BenchModel:
        """The rig's model (cached: one model object per distinct rig, kept alive —
        :func:`~ehsa_opt.physics.bench_sim.simulate_bench` caches integrators by model identity)."""
        key = (self.has_generator, self.harvester, self.friction_law,
               tuple((type(c).__name__, tuple(sorted((k, v) for k, v in vars(c).items()
                                                     if k not in c.start_attributes)))
                     for c in self.components))
        if key not in _MODELS:
            _MODELS[key] = BenchModel(self.harvester, self.components,
                                      generator=self.has_generator,
                                      friction_law=self.friction_law)
        return _MODELS[key]

    def with_components(self, components: Sequence[Component]) -> "Rig":
        return Rig(self.harvester, self.has_generator, tuple(components), self.friction_law)

    @property
    def base_names(self) -> list[str]:
        """The base model's fitted names: the friction (one curve at the rod, the nut's
        names, under the dynamic law — :data:`LUGRE_FIXED`), the rig terms without
        generator, the bristle's σ₀ and σ₁ under the dynamic law."""
        if self.friction_law == "static":
            return list(FRICTION_NAMES) if self.has_generator else ["inertia_kg", "offset_N",
                                                                     *NUT_NAMES]
        return ([] if self.has_generator else ["inertia_kg", "offset_N"]) + list(NUT_NAMES) \
            + list(LAW_PARAMETER_NAMES[self.friction_law])

    @property
    def fixed_base(self) -> dict[str, float]:
        """Base parameters this rig does not fit, and their values."""
        fixed = {} if self.has_generator else dict(NO_GENERATOR_FIXED)
        if self.friction_law != "static":
            fixed.update(LUGRE_FIXED)
        return fixed


# ------------------------------------------------------------------ linear baseline
def linear_baseline(prepared: Sequence[PreparedTest], rig: Rig,
                    breakaway_velocities: Sequence[float] = (0.003, 0.01, 0.03)
                    ) -> dict[str, float]:
    """Quick least-squares friction (rigid, quasi-static current): the force is linear
    in (F_C, F_brk − F_C, f_v[, M, offset]) for a fixed breakaway velocity, tried on
    a small grid.  Used as the IPOPT initial point; bearing friction starts at zero
    (its split from the nut friction is not identifiable on a rigid bench)."""
    h = rig.harvester
    r = h.lead_m_per_rad
    best: tuple[float, dict[str, float]] | None = None
    for ub in breakaway_velocities:
        rows, rhs = [], []
        for pt in prepared:
            x, v, a = pt.u
            F = pt.y[0]
            ust, uc = math.sqrt(2) * ub, ub / 10
            cols = [np.tanh(v / uc), math.sqrt(2 * math.e) * np.exp(-(v / ust) ** 2) * v / ust, v]
            if rig.has_generator:
                R = pt.fixed["load_ohm"] + h.internal_resistance_ohm
                known = h.equivalent_mass_kg() * a + h.torque_constant_Nm_per_A * \
                    h.voltage_constant_Vs_per_rad * v / (r * r * R)
            else:
                known = 0.0 * v
                cols += [a, np.ones_like(v)]
            w = pt.wnorm[0][:, None]
            rows.append(np.column_stack(cols) * w)
            rhs.append((F - known) * w[:, 0])
        A, b = np.vstack(rows), np.concatenate(rhs)
        coef, *_ = np.linalg.lstsq(A, b, rcond=None)
        sse = float(np.sum((A @ coef - b) ** 2))
        Fc, dF, fv = max(coef[0], 0.0), max(coef[1], 0.0), max(coef[2], 0.0)
        vals = {"nut_coulomb_N": Fc, "nut_breakaway_N": Fc + dF,
                "nut_breakaway_velocity_m_per_s": ub, "nut_viscous_Ns_per_m": fv}
        if rig.has_generator:
            vals.update({"bearing_breakaway_Nm": 1e-3, "bearing_coulomb_Nm": 1e-3,
                         "bearing_breakaway_velocity_rad_per_s": 1.0,
                         "bearing_viscous_Nms_per_rad": 1e-6})
        else:
            vals.update({"inertia_kg": float(coef[3]), "offset_N": float(coef[4])})
        if best is None or sse < best[0]:
            best = (sse, vals)
    assert best is not None
    return best[1]


# ------------------------------------------------------------------ predictions
def parameter_vector(model: BenchModel, pt: PreparedTest,
                     values: Mapping[str, float]) -> np.ndarray:
    """The model's parameter vector for test ``pt``: its fixed values (load, rig)
    overridden by ``values``, in the order of ``model.param_names``."""
    vals = {**pt.fixed, **values}
    return np.array([float(vals[n]) for n in model.param_names])


def warmup_grid(pt: PreparedTest, t: np.ndarray) -> tuple[np.ndarray, int]:
    """The grid ``t`` (s) with one unrecorded warm-up cycle before it for a sine test,
    and the number of warm-up samples (0 for other motions)."""
    if not isinstance(pt.motion, SineMotion):
        return t, 0
    dt = float(np.median(np.diff(t)))
    nw = int(round(1.0 / pt.motion.frequency_hz / dt))
    return np.concatenate([t[0] - dt * np.arange(nw, 0, -1), t]), nw


def predict(prepared: Sequence[PreparedTest], rig: Rig, parameters: Mapping[str, float],
            rtol: float = 1e-7, filtered: bool = True) -> list[np.ndarray]:
    """Simulated outputs (ny, N) of each test with the given parameters.

    Models with states are integrated by CVODES (relative tolerance ``rtol``) from
    rest-consistent initial states, one unrecorded warm-up cycle before the record for
    sine tests.  A test whose measured output went through the parallel low-pass of a
    rig without generator gets its outputs through the same filter (``filtered``;
    False: the model's own output, e.g. to synthesise a record).
    """
    return simulated("cvodes", prepared, rig, parameters, rtol=rtol, filtered=filtered)


def simulated(kind: str, prepared: Sequence[PreparedTest], rig: Rig,
              parameters: Mapping[str, float], rtol: float = 1e-7, filtered: bool = True,
              names: Sequence[str] = ()) -> list:
    """Each test's outputs (ny, N) of ``kind``: "cvodes" (:func:`predict`), "map"
    (:func:`predict_map`) or "sens" (:func:`predict_map_jacobian`: the outputs and their
    derivatives with respect to ``names``, a pair).  Each test is simulated by
    :func:`simulate_raw` — side by side on the workers of a lone fit (:mod:`.spread`),
    else one after the other — and its outputs taken from the raw arrays here
    (:func:`outputs_of`): the same views of the same arrays either way, so every later
    sum adds in the same order (a copy with another memory layout would not)."""
    raws = spread(simulate_raw, kind, prepared, rig, parameters, rtol=rtol) \
        if kind != "cvodes" or rig.model().n_states else None
    if raws is None:
        raws = [simulate_raw(kind, pt, rig, parameters, rtol=rtol) for pt in prepared]
    return [outputs_of(kind, pt, raw, filtered, rig.model(), names)
            for pt, raw in zip(prepared, raws)]


def simulate_raw(kind: str, pt: PreparedTest, rig: Rig, parameters: Mapping[str, float],
                 rtol: float = 1e-7) -> tuple:
    """One test's simulation of ``kind`` (:func:`simulated`) as computed: the outputs on
    the whole grid (the warm-up cycle of a sine test included; with "sens" their
    derivatives with respect to every parameter) and the warm-up samples."""
    model = rig.model()
    p = parameter_vector(model, pt, parameters)
    if kind in ("map", "sens"):
        t, nw = warmup_grid(pt, pt.time_s)
        if kind == "map":
            return simulate_map(model, pt.motion, p, t)[0], nw
        return (*simulate_map_sensitivity(model, pt.motion, p, t), nw)
    if model.n_states == 0:  # algebraic model: evaluate on the samples
        return np.array(model.outputs.map(pt.time_s.size)(np.zeros((0, pt.time_s.size)),
                                                         pt.u, p)), 0
    sim = simulate_test(model, pt, parameters, rtol=rtol)
    return np.vstack([sim.force_N, sim.voltage_V]), 0


def outputs_of(kind: str, pt: PreparedTest, raw: tuple, filtered: bool, model: BenchModel,
               names: Sequence[str] = ()):
    """The outputs (ny, N) of ``pt`` from its raw simulation (:func:`simulate_raw`): the
    recorded channels after the warm-up, through the record's filter (``filtered``); with
    "sens" also the derivatives with respect to ``names``."""
    ny = pt.y.shape[0]
    if kind == "sens":
        y, dy, nw = raw
        cols = [model.param_names.index(n) for n in names]
        y, dy = y[:ny, nw:], dy[:ny, nw:][:, :, cols]
        if filtered:
            y, dy = pt.filter_output(y), pt.filter_output(dy, axis=1)
        return y, dy
    y, nw = raw
    y = y[:ny, nw:]
    return pt.filter_output(y) if filtered else y


@dataclass
class RigSimulation:
    """One test simulated on its grid: the force (N), the voltage (V) and the states
    (rows: the model's states, columns: the samples)."""

    force_N: np.ndarray
    voltage_V: np.ndarray
    states: np.ndarray


def simulate_test(model: BenchModel, pt: PreparedTest, values: Mapping[str, float],
              grid: np.ndarray | None = None, rtol: float = 1e-7) -> RigSimulation:
    """CVODES simulation on the test's grid (or ``grid``; one warm-up cycle before
    sine records)."""
    p = parameter_vector(model, pt, values)
    t = pt.time_s if grid is None else grid
    if isinstance(pt.motion, SineMotion):
        grid, nw = warmup_grid(pt, t)
        sim = simulate_bench(model, pt.motion, p, grid, rtol=rtol, atol=rtol * 1e-2,
                             energy=False)
        keep = slice(nw, None)
    else:
        motion = pt.motion.sampled() if isinstance(pt.motion, FilteredMotion) else pt.motion
        sim = simulate_bench(model, motion, p, t, rtol=rtol, atol=rtol * 1e-2, energy=False)
        keep = slice(None)
    return RigSimulation(sim.force_N[keep], sim.voltage_V[keep], sim.states[:, keep])


# ------------------------------------------------------------------ the fits' simulation
#: Components whose law is not smooth (a gap closed by a stiff contact): a fixed-step
#: rule loses its order at the impacts, so their rigs are simulated by CVODES throughout.
NON_SMOOTH: frozenset[str] = frozenset({"backlash"})


#: False: the fits simulate every rig by CVODES (the reference path, for benchmarks).
USE_MAP = True


def map_suits(rig: Rig) -> bool:
    """Whether the fits may simulate ``rig`` by the Radau IIA map
    (:func:`~ehsa_opt.physics.bench_map.simulate_map`): every component smooth (and
    :data:`USE_MAP`)."""
    return USE_MAP and not any(c.name in NON_SMOOTH for c in rig.components)


def uniform_grid(time_s: np.ndarray, rel_tol: float = 1e-6) -> bool:
    """Whether the sample instants ``time_s`` (s) are one step apart to ``rel_tol`` of
    the step: the map's condition; a record with jittered or rounded time stamps (EMPS:
    ±3e-5 of the step) is simulated by CVODES instead."""
    dt = np.diff(np.asarray(time_s, dtype=float))
    if dt.size == 0:
        return False
    h = float(np.median(dt))
    return h > 0 and float(np.max(np.abs(dt - h))) <= rel_tol * h


def predict_map(prepared: Sequence[PreparedTest], rig: Rig, parameters: Mapping[str, float],
                filtered: bool = True) -> list[np.ndarray]:
    """:func:`predict` by the compiled Radau IIA map instead of CVODES (the same
    rest-consistent start and warm-up cycle for sine tests; the same motion between
    samples).  On a 16-test campaign it agrees with CVODES at rtol 1e-10 to < 0.02 of
    the noise, closer than CVODES at the default rtol 1e-7 does (see
    :mod:`~ehsa_opt.physics.bench_map`); five to ten times cheaper on recorded motions."""
    if not all(uniform_grid(pt.time_s) for pt in prepared):
        return predict(prepared, rig, parameters, filtered=filtered)  # e.g. rounded stamps
    return simulated("map", prepared, rig, parameters, filtered=filtered)


#: False: the Gauss–Newton on the map differences the map (the reference path, for
#: benchmarks) instead of using :func:`predict_map_jacobian`.
EXACT_JACOBIAN = True


def predict_map_jacobian(prepared: Sequence[PreparedTest], rig: Rig,
                         parameters: Mapping[str, float], names: Sequence[str],
                         filtered: bool = True
                         ) -> tuple[list[np.ndarray], list[np.ndarray]] | None:
    """:func:`predict_map`'s outputs (ny, N) of each test and their derivatives with
    respect to the parameters ``names`` (ny, N, len(names)), from the map's forward
    sensitivities (:func:`~ehsa_opt.physics.bench_map.simulate_map_sensitivity`).
    None when the map does not apply (a non-uniform grid: CVODES has no such
    derivatives here, the caller differences instead)."""
    if not all(uniform_grid(pt.time_s) for pt in prepared):
        return None
    got = simulated("sens", prepared, rig, parameters, filtered=filtered, names=list(names))
    return [y for y, _ in got], [dy for _, dy in got]


predict_map.jacobian = predict_map_jacobian  # what polish looks for on a predictor


def fit_predictor(rig: Rig):
    """The simulation a candidate fit searches with: :func:`predict_map` on a smooth rig
    (:func:`map_suits`), else CVODES (:func:`predict`)."""
    return predict_map if map_suits(rig) else predict
