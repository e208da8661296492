"""Friction on the optimum (paper Fig 20 / Table 4) and time-domain sweep cases."""

from __future__ import annotations


import pytest

from ehsa_opt.design.config import load_design_config
from ehsa_opt.design.friction_optimum import friction_on_optimum
from ehsa_opt.datasets.friction_source import FrictionSets
from ehsa_opt.physics.params import FrictionParams
from ehsa_opt.design.sweep import default_friction_sets, parse_sweep, rows_to_csv, run_sweep
from tests.paths import PAPER_DESIGN

PAPER = PAPER_DESIGN
OPT = {"total_inertia_gcm2": 250.0, "lead_mm_per_rev": 5.0, "speed_constant_rpm_per_V": 29.8,
       "load_ohm": 250.0}


def test_friction_lowers_power_and_efficiency_and_frictionless_matches_linear():
    cfg = load_design_config(PAPER)
    sets, source = default_friction_sets()
    assert "embedded" in source
    rows = friction_on_optimum(cfg, OPT, sets, (50.0, 100.0), road_length_m=150.0)
    assert len(rows) == 6
    for v in (50.0, 100.0):
        r = {x["friction"]: x for x in rows if x["speed_km_per_h"] == v}
        assert r["none"]["power_W"] > r["min"]["power_W"] > r["max"]["power_W"] > 0
        assert r["none"]["efficiency_pct"] > r["min"]["efficiency_pct"] > r["max"]["efficiency_pct"]
        # frictionless: η = R_e/(R_e + R_i) and the time domain meets the exact path
        assert r["none"]["efficiency_pct"] == pytest.approx(100 * 250 / 256.6, rel=2e-3)
        assert r["none"]["power_W"] == pytest.approx(r["none"]["linear_power_W"], rel=0.02)
        assert r["none"]["comfort_change_pct"] == 0.0
        assert all(abs(x["energy_residual"]) < 5e-3 for x in r.values())


def test_identified_bounds_take_precedence():
    lo = FrictionParams(nut_breakaway_N=5.0, nut_coulomb_N=1.0)
    ident = FrictionSets(lo, lo, FrictionParams(nut_breakaway_N=50.0, nut_coulomb_N=10.0))
    sets, source = default_friction_sets(ident)
    assert source.startswith("identified")
    assert sets["max"].nut_breakaway_N == 50.0


def test_sweep_with_friction_local_equals_dask():
    from distributed import LocalCluster
    doc = {"harvester": {"load_ohm": 47.0}, "road": {"length_m": 100.0},
           "sweep": {"speed_km_per_h": [60.0], "friction": ["none", "max"],
                     "design": {"load_ohm": [20.0, 100.0]}}}
    spec = parse_sweep(doc, "t.toml")
    local = run_sweep(spec)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster:
        dask = run_sweep(spec, scheduler=cluster.scheduler_address)
    assert rows_to_csv(local) == rows_to_csv(dask)
    by = {(r["friction"], r["load_ohm"]): r for r in local}
    for re_ in (20.0, 100.0):
        assert by[("max", re_)]["power_W"] < by[("none", re_)]["power_W"]
