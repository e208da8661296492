"""Forward simulation of bench tests at given parameters: the signals a model predicts
on each test's own time grid, with the rod motion prescribed from the measured
displacement (:func:`~ehsa_opt.estimation.identify_options.test_motion`).

A rigid bench has one smooth state, the winding current, integrated by the compiled
fixed-step Radau IIA stepper of the fit
(:func:`~ehsa_opt.estimation.collocation.integrate_states`); a bench with transmission
components (backlash, compliance, …) by CVODES
(:func:`~ehsa_opt.physics.bench_sim.simulate_bench`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from ..datasets.bench_format import BenchTest
from ..physics.base_parameters import PARAMETERS
from ..physics.bench_model import BenchModel
from ..physics.bench_sim import simulate_bench
from ..physics.components import Component
from ..physics.motion import SampledMotion
from ..physics.params import FrictionParams, HarvesterParams
from .collocation import integrate_states
from .identify_options import IdentifyOptions, test_motion

__all__ = ["Prediction", "simulate_tests", "outputs_on_grid", "model_defaults", "model_mass"]


@dataclass
class Prediction:
    """Simulated signals of one test on its own time grid."""

    file: str
    time_s: np.ndarray
    force_N: np.ndarray
    voltage_V: np.ndarray | None


def model_defaults(model: BenchModel) -> dict[str, float]:
    """Every parameter of ``model`` at its default: frictionless, the components'
    defaults, M = F_0 = 0 on a rig without generator, σ₀ and σ₁ of a LuGre law at their
    declared typical values."""
    d = FrictionParams().as_dict()
    if not model.generator:
        d.update({"inertia_kg": 0.0, "offset_N": 0.0})
    d.update({n: PARAMETERS[n].typical for n in model.law_names})
    d.update({q.name: q.default for q in model.param_specs.values()})
    return d


def model_mass(model: BenchModel) -> float | None:
    """Rod-equivalent inertia (kg) that turns acceleration noise into force noise (None
    without generator: the inertia is fitted)."""
    return model.harvester.equivalent_mass_kg() if model.generator else None


def simulate_tests(tests: Sequence[BenchTest], harvester: HarvesterParams,
                   parameters: Mapping[str, float], *, has_generator: bool = True,
                   components: Sequence[Component] = (),
                   options: IdentifyOptions | None = None,
                   motions: Sequence[SampledMotion] | None = None,
                   friction_law: str = "static") -> list[Prediction]:
    """Simulate each test with given parameters on its own time grid.

    The rod motion is the smoothing spline of the measured displacement
    (:func:`test_motion`, or ``motions`` when given); missing parameters take
    their defaults (frictionless, component defaults, M = F_0 = 0).  Without
    components the current is integrated by the compiled Radau IIA stepper
    (:func:`~.collocation.integrate_states`), with components or a bristle state
    (``friction_law="lugre"``, stiff: σ₀/φ(v) up to 1e5–1e7 /s) by CVODES (BDF).
    """
    model = BenchModel(harvester, components, generator=has_generator,
                       friction_law=friction_law)
    base = model_defaults(model)
    unknown = [k for k in parameters if k not in base and k != "load_ohm"]
    if unknown:
        raise ValueError(f"simulate_tests: unknown parameter(s) {', '.join(unknown)} "
                         f"(known: {', '.join(base)})")
    base.update({k: float(v) for k, v in parameters.items() if k != "load_ohm"})
    out = []
    for k, test in enumerate(tests):
        load = test.load_ohm if (test.load_ohm is not None and has_generator) else 1.0
        p = np.array([load, *[base[n] for n in model.param_names[1:]]])
        motion = motions[k] if motions is not None else test_motion(test, options,
                                                                    model_mass(model))
        if model.n_states == 0:
            uu = motion.evaluate(test.time_s)
            y = np.array(model.outputs.map(test.n_samples)(np.zeros((0, test.n_samples)), uu, p))
            F, V = y[0], y[1]
        elif not components and model.friction_law == "static":
            # rigid bench: only the winding current, a smooth state — the compiled
            # fixed-step Radau IIA of the fit's rigid path (within 2e-5 of the peak of
            # CVODES at rtol 1e-7 on the embedded tests, 30x faster: a spline motion
            # makes every CVODES right-hand side evaluation costly)
            F, V = outputs_on_grid(model, motion, test.time_s, p)[:2]
        else:
            sim = simulate_bench(model, motion, p, test.time_s, rtol=1e-7, atol=1e-9,
                                 energy=False)  # the outputs alone
            F, V = sim.force_N, sim.voltage_V
        out.append(Prediction(test.file, test.time_s, F,
                              V if (has_generator and test.voltage_V is not None) else None))
    return out


def outputs_on_grid(model: BenchModel, motion: Any, time_s: np.ndarray, p: np.ndarray,
                     X: np.ndarray | None = None) -> np.ndarray:
    """Model outputs (force, voltage, …) on ``time_s`` from the states ``X`` (default:
    integrated once by the compiled Radau stepper — states no parameter drives)."""
    if X is None:
        X = integrate_states(model, motion, time_s, p)
    return np.array(model.outputs.map(time_s.size)(X, motion.evaluate(time_s), p))
