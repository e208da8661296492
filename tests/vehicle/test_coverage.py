"""Vehicle results and the friction's identified range (vehicle/coverage.py): the
analytic Gaussian fractions against sampling, and the warnings of simulate and sweep."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ehsa_opt.cli import main
from ehsa_opt.datasets.friction_source import identified_range_for, load_velocity_range
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.params import FrictionParams
from ehsa_opt.vehicle.coverage import (
    coverage_warning,
    gaussian_coverage,
    series_coverage,
)

FR = FrictionParams(60.0, 40.0, 0.01, 150.0, 0.02, 0.015, 1.0, 3e-5)
LEAD = 5e-3 / (2 * math.pi)


def test_gaussian_fractions_match_sampling_and_erfc() -> None:
    rng = np.random.default_rng(1)
    for sigma in (0.1, 0.48, 1.2):
        v = rng.normal(0.0, sigma, (1, 400_000))
        mc = series_coverage(v, 0.33, np.asarray(rod_friction_N(v, FR, LEAD)) * v)
        an = gaussian_coverage(np.array([sigma]), 0.33, FR, LEAD)
        assert an["time_fraction"][0] == pytest.approx(math.erfc(0.33 / sigma / math.sqrt(2)))
        assert an["time_fraction"][0] == pytest.approx(mc["time_fraction"][0], abs=3e-3)
        assert an["energy_fraction"][0] == pytest.approx(mc["energy_fraction"][0], abs=5e-3)
    # vectorised over designs with their own friction rows and leads
    many = gaussian_coverage(np.array([0.1, 0.48]), 0.33, np.array([FR.as_array()] * 2),
                             np.array([LEAD, LEAD]))
    assert many["energy_fraction"][1] == pytest.approx(
        gaussian_coverage(np.array([0.48]), 0.33, FR, LEAD)["energy_fraction"][0])


def test_warning_only_above_the_limit_and_only_with_friction() -> None:
    assert coverage_warning({"time_fraction": 0.05, "energy_fraction": 0.08}, 0.33) is None
    w = coverage_warning({"time_fraction": 0.05, "energy_fraction": 0.3}, 0.33)
    assert w and "30.0 % of the friction's dissipated energy" in w and "10 % limit" in w
    assert coverage_warning({"time_fraction": 0.5, "energy_fraction": np.nan}, 0.33) is None


def test_identified_range_from_file_problem_or_embedded(tmp_path) -> None:
    ident = tmp_path / "identification.json"
    ident.write_text(json.dumps({"velocity_range": {"campaign_m_per_s": [0.01, 0.8]}}))
    assert load_velocity_range(ident) == 0.8
    assert identified_range_for([f"{ident}:max"])[0] == 0.8
    prob = tmp_path / "p.toml"
    prob.write_text('[friction]\nfrom = "identification.json"\ncase = "min"\n')
    assert identified_range_for((), prob) == (0.8, f"identified range of {ident}")
    v, src = identified_range_for((), None)
    assert v == pytest.approx(2 * math.pi * 3.5 * 0.015) and "embedded" in src


def test_simulate_reports_and_warns(tmp_path, capsys) -> None:
    p = tmp_path / "car.toml"
    p.write_text('preset = "passenger_car"\n[harvester]\nload_ohm = 47.0\n[friction]\n'
                 + "".join(f"{k} = {v!r}\n" for k, v in FR.as_dict().items())
                 + '[road]\niso_class = "C"\nspeed_km_per_h = 100.0\nlength_m = 80.0\n')
    assert main(["simulate", str(p), "--json"]) == 0
    cap = capsys.readouterr()
    m = json.loads(cap.out.strip().splitlines()[-1])
    assert 0.2 < m["out_of_range_time_fraction"] < 0.8
    assert m["out_of_range_friction_energy_fraction"] > m["out_of_range_time_fraction"]
    assert "above the 10 % limit" in cap.err
    # a slow road stays inside: no warning
    p.write_text(p.read_text().replace('"C"', '"A"').replace("100.0", "20.0"))
    assert main(["simulate", str(p)]) == 0
    cap = capsys.readouterr()
    assert "friction energy at |v| > identified" in cap.out and "10 % limit" not in cap.err


def test_sweep_columns_and_warning(tmp_path, capsys) -> None:
    p = tmp_path / "sw.toml"
    p.write_text('preset = "passenger_car"\n[harvester]\nload_ohm = 47.0\n[road]\n'
                 'iso_class = "C"\nlength_m = 60.0\nseed = 3\n[sweep]\n'
                 'speed_km_per_h = [20.0, 100.0]\nfriction = ["none", "max"]\n')
    assert main(["sweep", str(p), "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    rows = (tmp_path / "o" / "sweep.csv").read_text().splitlines()
    head = rows[0].split(",")
    i_t = head.index("out_of_range_time_fraction")
    i_e = head.index("out_of_range_friction_energy_fraction")
    vals = [r.split(",") for r in rows[1:]]
    fast = [v for v in vals if v[head.index("speed_km_per_h")] == "100.0"]
    assert all(float(v[i_t]) > 0.1 for v in fast)
    assert [v[i_e] for v in vals if v[head.index("friction")] == "none"] == ["", ""]
    assert "above the friction's identified range" in err and "speed_km_per_h = 100.0" in err
