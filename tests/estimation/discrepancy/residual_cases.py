"""Sine tests whose measured force is the noise-free simulation plus a known term and
noise: the 'model' is the noise-free simulation, so the residual is the term plus noise
(shared by the term, presliding and discrepancy tests)."""

from __future__ import annotations

import numpy as np

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests


def residual_case(extra, seed: int, sigma_N: float = 2.0, voltage_noise_V: float = 0.0,
                  delay_of=None):
    """Prepared tests (6: 0.8, 2.0, 3.2 Hz × 22, 100 Ω, one cycle) with ``extra(pt)`` (N)
    and white noise of ``sigma_N`` added to the force (and of ``voltage_noise_V`` to the
    voltage), the force first delayed by ``delay_of(test)`` s when given, and their
    noise-free outputs.  Returns (tests, outputs)."""
    tests = generate_bench_tests(SyntheticSpec(frequencies_hz=(0.8, 2.0, 3.2),
                                               loads_ohm=(22.0, 100.0), cycles=1.0, seed=seed,
                                               noise_force_N=0.0, noise_voltage_V=0.0))
    pts = prepare_tests(tests)
    rng = np.random.default_rng(seed)
    preds = [pt.y.copy() for pt in pts]
    for pt in pts:
        d = delay_of(pt.test) if delay_of is not None else 0.0
        pt.y = pt.y.copy()
        force = np.interp(pt.time_s - d, pt.time_s, pt.y[0]) if d else pt.y[0]
        pt.y[0] = force + extra(pt) + rng.normal(0, sigma_N, pt.y.shape[1])
        if voltage_noise_V:
            pt.y[1] = pt.y[1] + rng.normal(0, voltage_noise_V, pt.y.shape[1])
        pt.sigma = np.array([sigma_N, 0.05])
    return pts, preds
