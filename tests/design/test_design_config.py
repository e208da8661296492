"""Design problem files and the parallel machinery (local pool and Dask)."""

from __future__ import annotations


import numpy as np
import pytest

from ehsa_opt.cli import main
from ehsa_opt.design.config import load_design_config, parse_design_config
from ehsa_opt.physics.params import ParameterError
from ehsa_opt.design.sweep import executor
from tests.paths import PAPER_DESIGN

PAPER = PAPER_DESIGN


def test_paper_problem_file_is_table_3():
    cfg = load_design_config(PAPER)
    assert cfg.space.names == ("total_inertia_gcm2", "lead_mm_per_rev",
                               "speed_constant_rpm_per_V", "load_ohm")
    assert cfg.space.lower == (250.0, 5.0, 29.8, 1.0)
    assert cfg.space.upper == (10000.0, 20.0, 11900.0, 10000.0)
    assert cfg.road.iso_class == "C" and cfg.road.speed_km_per_h == 70.0
    assert cfg.vehicle.sprung_mass_kg == 375.0
    # the prototype as design variables: K_e = 0.137 V s/rad ↔ k_n = 60/(2π·0.137) rpm/V
    assert cfg.prototype_design["speed_constant_rpm_per_V"] == pytest.approx(69.7029, rel=1e-5)
    assert cfg.prototype_design["total_inertia_gcm2"] == pytest.approx(301.0)


@pytest.mark.parametrize("doc,match", [
    ({"design": {"bounds": {"load_ohm": [100.0, 1.0]}}}, "lower bound 100 > upper bound 1"),
    ({"design": {"method": "simplex"}}, "unknown method 'simplex'"),
    ({"design": {"bounds": {"lead_mm_per_revolution": [5.0, 20.0]}}}, "did you mean 'lead_mm_per_rev'"),
    ({"goals": {"weights": {"comfort": 1.0}}}, "give all four weights"),
    ({"goals": {"comfrt": 1.0}}, "did you mean 'comfort'"),
    ({"nsga2": {"pop": 2}}, "pop must be an integer >= 4"),
    ({"nsga2": {"pick": "preference"}}, "needs pick_weights"),
    ({"preset": "truck"}, "unknown preset .truck."),
    ({"optimise": {}}, "did you mean 'optimize'|unknown key 'optimise'"),
])
def test_bad_problem_files(doc, match):
    with pytest.raises(ParameterError, match=match):
        parse_design_config(doc, "p.toml")


def test_cli_bad_input_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[design.bounds]\nload_ohm = [100.0, 1.0]\n')
    assert main(["optimize", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "lower bound 100 > upper bound 1" in capsys.readouterr().err
    assert main(["optimize", str(PAPER), "--method", "newton", "--out",
                 str(tmp_path / "o")]) == 2
    assert "unknown method 'newton'" in capsys.readouterr().err
    zero = tmp_path / "zero.toml"
    zero.write_text('[goals]\ncomfort = 0.0\n')
    assert main(["optimize", str(zero), "--out", str(tmp_path / "o")]) == 2
    assert "goal 0 and weight 0" in capsys.readouterr().err
    assert main(["optimize", str(PAPER), "--method", "goal-attainment", "--resume", "x",
                 "--out", str(tmp_path / "o")]) == 2
    assert "only apply to --method nsga2" in capsys.readouterr().err
    assert not (tmp_path / "o" / "result.json").exists()


def _square(x):
    return np.asarray(x) ** 2


def test_executor_local_and_dask_agree():
    from distributed import Client, LocalCluster
    items = [np.arange(3.0) + k for k in range(5)]
    with executor(1) as m:
        serial = m(_square, items)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        with executor(scheduler=client) as m:
            dask = m(_square, items)
        with executor(scheduler=cluster.scheduler_address) as m:
            by_address = m(_square, items)
    for a, b, c in zip(serial, dask, by_address):
        assert np.array_equal(a, b) and np.array_equal(a, c)
    with pytest.raises(ParameterError, match="--jobs must be >= 1"):
        with executor(0):
            pass
