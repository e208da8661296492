"""The entry points of the commands beyond design and identification — ``bench
generate``, ``bench check``, ``bench convert-emps``, ``plan-tests``, ``discrepancy``,
``reproduce``: each returns its result in memory and writes nothing, its ``save`` writes
what the command writes, byte for byte on the same inputs, and ``load`` reads it back."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

import ehsa_opt
from ehsa_opt.cli import main
from tests.paths import ROOT


def _tree(folder) -> dict[str, bytes]:
    """Every file under ``folder`` but the command line's lock and manifest."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and not p.name.startswith(".")}


def _nothing_written(tmp_path, keep=()) -> None:
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(keep)


def test_generate_bench_api_equals_cli(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    ticks = []
    bench = ehsa_opt.generate_bench(effects=["backlash"], effect_params={"backlash_gap_m": 2e-4},
                                    frequencies_hz=(1.0, 2.0), loads_ohm=(15.0,), cycles=1.0,
                                    seed=4, progress=lambda k, n: ticks.append((k, n)))
    _nothing_written(tmp_path)
    assert ticks == [(1, 2), (2, 2)] and len(bench.tests) == 2
    truth = tomllib.loads(bench.files["truth.toml"])
    assert truth["effects"]["backlash"]["backlash_gap_m"] == 2e-4 and truth["generator"]["seed"] == 4
    table = bench.table()
    np.testing.assert_array_equal(np.asarray(table["frequency_hz"]), [1.0, 2.0])
    assert bench.save(tmp_path / "api") == tmp_path / "api"
    assert main(["bench", "generate", str(tmp_path / "cli"), "--effect", "backlash",
                 "--effect-param", "backlash_gap_m=2e-4", "--frequencies-hz", "1,2",
                 "--loads-ohm", "15", "--cycles", "1", "--seed", "4"]) == 0
    assert "wrote 2 tests" in capsys.readouterr().out
    api, cli = _tree(tmp_path / "api"), _tree(tmp_path / "cli")
    assert sorted(api) == sorted(cli)
    for name in api:  # README and truth name the command that regenerates the data
        if name not in ("README.md", "truth.toml"):
            assert api[name] == cli[name], name
    t_api, t_cli = (tomllib.loads(d["truth.toml"].decode()) for d in (api, cli))
    t_api["generator"].pop("command"), t_cli["generator"].pop("command")
    assert t_api == t_cli
    with pytest.raises(ValueError, match="--effect-param: width_m belong to no chosen"):
        ehsa_opt.generate_bench(effect_params={"width_m": 1.0})
    with pytest.raises(FileExistsError, match="overwrite=True"):
        bench.save(tmp_path / "api")
    bench.save(tmp_path / "api", overwrite=True)  # ehsa-opt wrote it: replaced
    assert _tree(tmp_path / "api") == api


def test_check_bench_api_equals_cli(tmp_path, capsys) -> None:
    data = ROOT / "data" / "bench_prototype"
    checked = ehsa_opt.check_bench(data)
    assert main(["bench", "check", str(data)]) == 0
    assert capsys.readouterr().out.strip() == checked.summary()
    assert checked.summary().endswith(": OK") and checked.path == data
    assert len(checked.tests) == 21 and checked.data.tests == checked.tests
    # a saved copy is the same data, checked again
    checked.save(tmp_path / "copy")
    again = ehsa_opt.BenchSet.load(tmp_path / "copy")
    assert [t.file for t in again.tests] == [t.file for t in checked.tests]
    for a, b in zip(again.tests, checked.tests):
        np.testing.assert_array_equal(a.force_N, b.force_N)
    assert again.harvester == checked.harvester


def _emps_source(d, n=400):
    d.mkdir(parents=True)
    t = np.arange(n) * 1e-3
    x = 0.01 * np.sin(2 * np.pi * 2 * t)
    u = 0.5 * np.cos(2 * np.pi * 2 * t)
    np.savetxt(d / "emps_estimation.csv", np.column_stack([t, x, x, u]), delimiter=",",
               header="time_s,position_m,reference_position_m,control_voltage_V",
               comments="")
    pulse = 5.0 * (np.floor(t / 0.1) % 2)
    np.savetxt(d / "emps_validation_pulses.csv", np.column_stack([t, x, x, u, pulse]),
               delimiter=",", comments="",
               header="time_s,position_m,reference_position_m,control_voltage_V,pulse_N")
    return d


def test_convert_emps_api_equals_cli(tmp_path, capsys) -> None:
    src = _emps_source(tmp_path / "src")
    bench = ehsa_opt.convert_emps(src)
    _nothing_written(tmp_path, keep=["src"])
    from ehsa_opt.datasets.emps import GAIN_N_PER_V
    np.testing.assert_allclose(bench.tests[0].force_N,
                               GAIN_N_PER_V * 0.5 * np.cos(2 * np.pi * 2 * np.arange(400) * 1e-3))
    assert bench.validation is not None and "pulses.csv" in bench.validation.files
    bench.save(tmp_path / "api")
    assert main(["bench", "convert-emps", str(src), str(tmp_path / "cli")]) == 0
    assert "wrote EMPS bench data" in capsys.readouterr().out
    assert _tree(tmp_path / "api") == _tree(tmp_path / "cli")
    assert "validation/pulses.csv" in _tree(tmp_path / "api")
    # the folder's README is kept when the conversion replaces it
    (tmp_path / "api" / "README.md").write_text("EMPS, converted\n")
    from ehsa_opt.datasets.bench_format import write_marker
    write_marker(tmp_path / "api")  # as if ehsa-opt wrote it
    bench.save(tmp_path / "api", overwrite=True)
    assert (tmp_path / "api" / "README.md").read_text() == "EMPS, converted\n"


def test_plan_tests_api_equals_cli(tmp_path, monkeypatch, capsys) -> None:
    doc = json.loads((ROOT / "results" / "reference" / "identify_prototype.json").read_text())
    doc["data_dir"] = str(ROOT / "data" / "bench_prototype")  # the data it was identified on
    (tmp_path / "in").mkdir()
    ident = tmp_path / "in" / "identification.json"
    ident.write_text(json.dumps(doc))
    monkeypatch.chdir(tmp_path)
    rig = ROOT / "docs" / "guide" / "plan_tests_rig.toml"
    result = ehsa_opt.plan_tests(ident, "quarter_car_class_c", rig, n_tests=2)
    _nothing_written(tmp_path, keep=["in"])
    assert result.success and len(result.plan.proposed) == 2
    table = result.table()
    assert len(table["peak_force_N"]) == 2 and np.all(np.asarray(table["peak_force_N"]) > 0)
    written = result.save(tmp_path / "api")
    assert [p.name for p in written] == ["bench.toml", "plan.json"]
    assert main(["plan-tests", str(ident), "--vehicle", "quarter_car_class_c", "--rig", str(rig),
                 "--n", "2", "--out", str(tmp_path / "cli")]) == 0
    out = capsys.readouterr().out
    assert result.summary() in out and "skeleton for the rig operator" in out
    assert _tree(tmp_path / "api") == _tree(tmp_path / "cli")
    back = ehsa_opt.TestPlanResult.load(tmp_path / "api")
    assert back.plan.to_dict() == result.plan.to_dict()


def _without_timing(obj):
    if isinstance(obj, dict):
        return {k: _without_timing(v) for k, v in obj.items()
                if not k.endswith(("seconds", "wall_s"))}
    if isinstance(obj, list):
        return [_without_timing(v) for v in obj]
    return obj


def test_discrepancy_report_api_equals_cli(tmp_path, monkeypatch, capsys) -> None:
    """In this process (no safety cap) from the API, in the command's worker process
    (the default cap): the same report, figures and answer under the same work budget."""
    data = ehsa_opt.generate_bench(frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(15.0, 109.0),
                                   cycles=1.0, seed=2, effects=["backlash"])
    data.save(tmp_path / "data")
    monkeypatch.chdir(tmp_path)
    said: list[str] = []
    report = ehsa_opt.discrepancy_report(tmp_path / "data", max_member_fits=1,
                                         on_message=said.append)
    _nothing_written(tmp_path, keep=["data"])
    assert report.result is not None and report.record["effect"] == report.result.effect
    assert report.partial and not report.success  # the work budget of one member fit
    assert report.record["error_true_parameters"] is not None
    assert said[-1].startswith("true parameters (truth.toml)")
    paths = report.save(tmp_path / "api")
    assert [p.name for p in paths[:2]] == ["discrepancy.json", "report.md"]
    rc = main(["discrepancy", str(tmp_path / "data"), "--out", str(tmp_path / "cli"),
               "--max-fits", "1"])
    assert rc == 1  # a partial answer (work budget spent)
    assert "wrote " in capsys.readouterr().out
    api, cli = _tree(tmp_path / "api"), _tree(tmp_path / "cli")
    assert sorted(api) == sorted(cli)
    assert _without_timing(json.loads(api["discrepancy.json"])) == \
        _without_timing(json.loads(cli["discrepancy.json"]))
    for name in api:
        if name.startswith("figures/"):
            assert api[name] == cli[name], name
    back = ehsa_opt.DiscrepancyReport.load(tmp_path / "cli")
    assert back.summary() == report.summary() and back.partial
    t_mem, t_back = report.table(), back.table()  # the loaded record's table is the result's
    assert list(t_mem) == list(t_back) and list(t_mem["effect"]) == list(t_back["effect"])
    np.testing.assert_allclose(np.asarray(t_mem["error_after_pct"], float),
                               np.asarray(t_back["error_after_pct"], float))
    assert sorted(back.figures) == sorted(n.split("/", 1)[1] for n in cli if
                                          n.startswith("figures/"))


def test_reproduce_api_equals_cli(tmp_path, monkeypatch, capsys) -> None:
    """The report job (two of its steps here) from the API in a temporary folder and from
    the command in its output folder: the same report and tables."""
    import ehsa_opt.pipeline.reproduce as job
    keep = ("data", "harvester")
    monkeypatch.setattr(job, "STEPS", [s for s in job.STEPS if s.key in keep])
    monkeypatch.chdir(tmp_path)
    result = ehsa_opt.reproduce(quick=True, jobs=1, on_message=lambda m: None)
    _nothing_written(tmp_path)
    assert result.workdir is None and "REPORT.md" in result.files
    assert list(result.table()["step"]) == [s.title for s in job.STEPS]
    result.save(tmp_path / "api")
    assert main(["reproduce", "--quick", "--jobs", "1", "--out", str(tmp_path / "cli")]) == 0
    assert f"report: {tmp_path / 'cli' / 'REPORT.md'}" in capsys.readouterr().out
    api, cli = _tree(tmp_path / "api"), _tree(tmp_path / "cli")
    cli = {k: v for k, v in cli.items() if not k.startswith("cache/")}
    assert sorted(api) == sorted(cli)

    def without_run_log(text: bytes) -> str:
        return text.decode().split("## Run log")[0]
    assert without_run_log(api["REPORT.md"]) == without_run_log(cli["REPORT.md"])
    for name in api:
        if name != "REPORT.md":
            assert api[name] == cli[name], name
    back = ehsa_opt.ReproduceResult.load(tmp_path / "cli")
    assert back.report == cli_text(tmp_path)


def cli_text(tmp_path) -> str:
    return (tmp_path / "cli" / "REPORT.md").read_text(encoding="utf-8")
