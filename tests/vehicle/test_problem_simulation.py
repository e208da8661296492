"""``ehsa-opt simulate`` as a function of the vehicle room: the checks that belong to the
simulation (energy balance, rated limits) live with its result."""

import json
import math

import pytest

from ehsa_opt.vehicle.problem_simulation import (ENERGY_TOLERANCE, peak_electrical,
                                                 simulate_problem)
from tests.paths import ROOT

PROBLEM = ROOT / "problems" / "quarter_car_class_c.toml"


def test_peak_current_and_voltage_from_the_peak_load_power() -> None:
    i, u = peak_electrical(200.0, 50.0)
    assert i == pytest.approx(2.0) and u == pytest.approx(100.0)  # P = R i² = u²/R
    assert u == pytest.approx(i * 50.0)
    assert peak_electrical(200.0, 0.0) == (None, None)


def test_rated_limits_warn_and_the_result_summarises(tmp_path) -> None:
    text = PROBLEM.read_text()
    assert "[simulation]" in text
    limited = tmp_path / "p.toml"
    limited.write_text(text.replace("[simulation]", "[simulation]\nrated_current_A = 0.01", 1))
    seen: list[str] = []
    run = simulate_problem(limited, on_warning=seen.append)
    assert run.success and abs(run.metrics["energy_residual"]) <= ENERGY_TOLERANCE
    assert any("peak current" in w and "rated_current_A" in w and str(limited) in w
               for w in seen)
    assert seen == run.warnings
    m = run.metrics
    assert m["peak_terminal_voltage_V"] == pytest.approx(
        m["peak_current_A"] * run.problem.harvester.load_ohm)
    assert run.summary().splitlines()[0].startswith(f"{limited}:")
    doc = json.loads(run.to_json())
    assert math.isclose(doc["power_W"], m["power_W"]) and doc["frictionless"] is False
