"""The second generator's sensor dynamics and friction drift against analytic answers,
and the run order it carries across a campaign and writes to the bench format."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from validation.second_generator import Campaign, Effects, Sine, run_order
from validation.second_generator import campaign as cm
from validation.second_generator.campaign import MAX_ORDER_CORRELATION, RIGS, generate, write_campaign
from validation.second_generator.motions import VelocityProfile
from ehsa_opt.datasets.bench_format import load_bench
from ehsa_opt.datasets.run_order import run_sequence, start_offsets_s


def _fundamental(t, y, f):
    """Complex amplitude of the component at ``f`` (whole cycles, least squares)."""
    w = 2 * math.pi * f
    A = np.column_stack([np.cos(w * t), np.sin(w * t), np.ones_like(t)])
    a, b, _ = np.linalg.lstsq(A, y, rcond=None)[0]
    return a - 1j * b


@pytest.mark.parametrize("channel, effects", [
    ("force", dict(load_cell_hz=40.0, load_cell_damping=0.7)),
    ("force", dict(load_cell_hz=40.0, load_cell_damping=0.3)),
    ("voltage", dict(voltage_sensor_hz=40.0, voltage_sensor_damping=0.707)),
], ids=["load-cell-0.7", "load-cell-0.3", "voltage-filter"])
def test_sensor_is_a_second_order_low_pass(channel, effects):
    """Driven by a sine at f_c, the sensor's reading against the quantity it measures
    (the same rig without the sensor): gain 1 / (2 zeta), phase -90 deg."""
    bare = replace(Campaign().model(), effects=Effects())
    model = replace(bare, effects=Effects(**effects))
    fc = next(v for k, v in effects.items() if k.endswith("_hz"))
    zeta = next(v for k, v in effects.items() if k.endswith("_damping"))
    motion = Sine(2e-4, fc, cycles=6.0, settle_cycles=6)
    col = 2 if channel == "force" else 3
    t, *ys = model.simulate(motion, 10.0, 4000.0)[:4]
    ref = bare.simulate(motion, 10.0, 4000.0)[col]
    h = _fundamental(t, ys[col - 1], fc) / _fundamental(t, ref, fc)
    assert abs(abs(h) - 1 / (2 * zeta)) < 0.01 / (2 * zeta)
    assert abs(math.degrees(np.angle(h)) + 90.0) < 1.0


def test_sensor_is_a_delay_well_below_its_corner():
    """At f << f_c the voltage filter delays by its group delay zeta / (pi f_c)."""
    fc, zeta, f = 60.0, 0.707, 2.0
    bare = replace(Campaign().model(), effects=Effects())
    model = replace(bare, effects=Effects(voltage_sensor_hz=fc, voltage_sensor_damping=zeta))
    motion = Sine(0.01, f, cycles=2.0)
    t, _, _, v = model.simulate(motion, 10.0, 2000.0)[:4]
    h = _fundamental(t, v, f) / _fundamental(t, bare.simulate(motion, 10.0, 2000.0)[3], f)
    delay = -np.angle(h) / (2 * math.pi * f)
    assert abs(delay - zeta / (math.pi * fc)) < 0.02 * zeta / (math.pi * fc)
    assert abs(abs(h) - 1.0) < 1e-3


def test_friction_falls_with_the_energy_dissipated():
    """Constant speed, no cooling, equal temperature coefficients: the nut friction is
    F_0 exp(-beta theta) and C theta is the energy it dissipated, so
    theta(t) = ln(1 + beta F_0 v t / C) / beta, and the force is lower than without the
    drift by F_0 (1 - exp(-beta theta))."""
    C, beta, v = 2.0, 0.03, 0.1
    bare = replace(Campaign().model(), effects=Effects())
    model = replace(bare, effects=Effects(grease_capacity_J_per_K=C,
                                          grease_resistance_K_per_W=1e12,
                                          drift_coulomb_per_K=beta, drift_viscous_per_K=beta))
    motion = VelocityProfile((0.0, 3.0), (v, v))
    t, _, F, _, Y, lay = model.simulate(motion, 10.0, 1000.0, grease_K=0.5)
    F0 = float(bare.nut.steady(v))
    theta = np.log(math.exp(beta * 0.5) + beta * F0 * v * t / C) / beta
    late = t > 0.05
    np.testing.assert_allclose(Y[lay["Tg"]][late], theta[late], rtol=2e-3)
    dF = F - bare.simulate(motion, 10.0, 1000.0)[2]
    np.testing.assert_allclose(dF[late], -F0 * (1 - np.exp(-beta * theta[late])), rtol=5e-3)
    assert theta[-1] > 5.0  # a real drift: friction down by more than 14 %


@pytest.fixture(scope="module")
def drifting():
    return Campaign(rig="rig_b", protocol="mixed", seed=7, pause_s=15.0,
                    effects=Effects(grease_capacity_J_per_K=3.0, grease_resistance_K_per_W=80.0,
                                    drift_coulomb_per_K=0.015, drift_viscous_per_K=0.03))


@pytest.fixture(scope="module")
def made(drifting):
    return generate(drifting)


def test_run_order_is_stated_and_not_sorted():
    specs = cm.test_specs(RIGS["rig_c"], "campaign27", 3)
    order = run_order(specs, 3)
    assert sorted(order) == list(range(len(specs))) and order != list(range(len(specs)))
    assert order == run_order(specs, 3) and order != run_order(specs, 4)
    when = np.argsort(order)
    loads = [s.load_ohm for s in specs]
    rank = lambda a: np.argsort(np.argsort(a, kind="stable"))  # noqa: E731
    assert abs(np.corrcoef(when, rank(loads))[0, 1]) <= MAX_ORDER_CORRELATION + 0.1
    assert abs(np.corrcoef(when, np.arange(len(specs)))[0, 1]) <= MAX_ORDER_CORRELATION


def test_grease_temperature_is_carried_across_tests_in_run_order(drifting, made):
    tests = sorted(made, key=lambda d: d["run_order"])
    tau = 3.0 * 80.0
    carried = 0
    for a, b in zip(tests[:-1], tests[1:]):
        gap = b["start_s"] - a["start_s"] - a["spec"].motion.duration_s
        assert gap == pytest.approx(15.0 + b["spec"].motion.preroll_s)
        if b["spec"].motion.preroll_s == 0:   # no settling cycles: nothing heats in between
            assert b["grease_K"][0] == pytest.approx(a["grease_K"][1] * math.exp(-15.0 / tau),
                                                     rel=1e-9)
            carried += 1
    assert carried >= 5
    assert tests[-1]["grease_K"][1] > 5.0  # the campaign warmed the grease
    # one test alone is the same record as in the whole campaign (its history is simulated)
    k = next(i for i, d in enumerate(made) if d["run_order"] == 4)
    alone = generate(drifting, only=(k,))
    assert len(alone) == 1 and alone[0]["grease_K"][0] > 0.5
    np.testing.assert_array_equal(alone[0]["force_N"], made[k]["force_N"])


def test_written_campaign_states_its_run_order(drifting, made, tmp_path):
    d = write_campaign(tmp_path / "c", drifting)
    data = load_bench(d)
    made = {t["spec"].file: t for t in made}
    assert [made[t.file]["run_order"] for t in data.tests] == [t.run_order for t in data.tests]
    seq = run_sequence(data.tests)
    assert [made[data.tests[k].file]["run_order"] for k in seq] == list(range(1, 17))
    offsets = start_offsets_s(data.tests)
    first = min(m["start_s"] for m in made.values())
    for t, off in zip(data.tests, offsets):
        assert off == pytest.approx(made[t.file]["start_s"] - first, abs=1e-3)
