"""reproduce on a user's bench directory: Context threading, CSV tables."""

from __future__ import annotations

import csv

import pytest

from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
from ehsa_opt.physics.params import HarvesterParams, ParameterError, VehicleParams
from ehsa_opt.pipeline.base import Context, markdown_tables
from ehsa_opt.pipeline.reproduce import STEPS, reproduce


def test_context_defaults_to_the_embedded_data(tmp_path) -> None:
    ctx = Context(tmp_path, True, 1)
    assert not ctx.custom_data
    assert ctx.bench_dir == embedded_data_dir("bench_prototype")
    assert ctx.vehicle() == (VehicleParams.preset("passenger_car"), "passenger_car")
    assert ctx.inputs() == {"data": None}


def test_context_threads_data_harvester_and_vehicle(tmp_path) -> None:
    spec = SyntheticSpec(frequencies_hz=(1.0,), loads_ohm=(47.0,), seed=3,
                         harvester=HarvesterParams(lead_mm_per_rev=7.0))
    d = write_synthetic(tmp_path / "d", spec)
    veh = tmp_path / "car.toml"
    veh.write_text('[vehicle]\nsprung_mass_kg = 500.0\n[road]\niso_class = "B"\n')
    ctx = Context(tmp_path / "out", True, 1, data_dir=d, vehicle_file=veh)
    assert ctx.custom_data and ctx.bench_dir == d
    assert ctx.harvester(load_ohm=10.0).lead_mm_per_rev == pytest.approx(7.0)
    assert ctx.vehicle()[0].sprung_mass_kg == 500.0
    before = ctx.inputs()
    veh.write_text('[vehicle]\nsprung_mass_kg = 510.0\n')
    assert ctx.inputs() != before  # a changed vehicle invalidates the cached steps
    veh.write_text('[vehicle]\nsprung_mas_kg = 510.0\n')
    with pytest.raises(ParameterError, match="sprung_mass_kg"):
        ctx.vehicle()


def test_markdown_tables_parse() -> None:
    md = "text\n\n| a | **b** |\n|---|---|\n| 1 | `x` |\n\nmore\n| c |\n|:-:|\n| 2 |\n"
    assert markdown_tables(md) == [[["a", "b"], ["1", "x"]], [["c"], ["2"]]]


def test_reproduce_on_user_data_writes_tables(tmp_path) -> None:
    d = write_synthetic(tmp_path / "d", SyntheticSpec(frequencies_hz=(1.0, 2.0),
                                                       loads_ohm=(15.0,), seed=4))
    steps = [s for s in STEPS if s.key in ("data", "harvester", "bench_truth")]
    rep = reproduce(tmp_path / "out", quick=True, jobs=1, steps=steps, data_dir=d,
                    log=lambda m: None)
    text = rep.read_text()
    assert str(d) in text and "passes the strict loader" in text
    rows = list(csv.reader((tmp_path / "out" / "tables" / "harvester_1.csv").open()))
    assert rows[0][0] == "R_e (Ω)" and [r[0] for r in rows[1:]] == ["15"]
    with pytest.raises(Exception, match="bench.toml"):
        reproduce(tmp_path / "bad", quick=True, steps=steps, data_dir=tmp_path / "nowhere",
                  log=lambda m: None)


@pytest.mark.slow
def test_reproduce_quick_on_generated_data_with_hidden_effect(tmp_path) -> None:
    from ehsa_opt.cli import main
    d = tmp_path / "comp"
    assert main(["bench", "generate", str(d), "--seed", "23", "--effect", "compliance"]) == 0
    out = tmp_path / "out"
    assert main(["reproduce", "--data", str(d), "--quick", "--out", str(out),
                 "--jobs", "1"]) == 0
    text = (out / "REPORT.md").read_text()
    for key in ("Friction bounds the data support", "paper method: max", "compliance",
                "Fig 20", "Fig 21"):
        assert key in text
    assert "Not applicable" not in text
    tables = {p.name for p in (out / "tables").glob("*.csv")}
    assert {"identification_1.csv", "qc_fig21_1.csv", "design_friction_1.csv"} <= tables
    assert "identify_emps" not in text


@pytest.mark.slow
def test_reproduce_quick_on_emps_runs_the_parts_that_apply(tmp_path) -> None:
    out = tmp_path / "out"
    rep = reproduce(out, quick=True, jobs=1, data_dir=embedded_data_dir("emps"),
                    log=lambda m: None)
    text = rep.read_text()
    assert "no generator" in text and text.count("Not applicable") >= 5
    assert "Eq 5 over the tests" in text and (out / "tables" / "identification_1.csv").is_file()
