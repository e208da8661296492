"""Member fits on a Dask cluster (``DiscrepancySettings.scheduler``): the same fits in the
same order as the local run, so the same verdicts and numbers."""

from __future__ import annotations

import pytest

from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
from ehsa_opt.estimation.discrepancy import run_discrepancy
from ehsa_opt.estimation.discrepancy.results import DiscrepancySettings

distributed = pytest.importorskip("distributed")


def _answer(res) -> dict:
    return {"effect": res.effect, "success": res.success, "error_after": res.error_after,
            "cut": res.cut, "member_fits": res.member_fits,
            "candidates": [(c.effect, c.round, c.earns, c.parameters, c.error_after)
                           for c in res.candidates]}


def test_cluster_fits_give_the_local_answer(tmp_path):
    d = tmp_path / "data"
    write_synthetic(d, SyntheticSpec(effects={"voltage_drop": {"voltage_drop_V": 0.5}},
                                     frequencies_hz=(1.5, 3.0), loads_ohm=(15.0, 109.0),
                                     cycles=1.0, seed=5))
    kw = dict(discover=False, max_effects=1, top=2)
    local = run_discrepancy(d, DiscrepancySettings(jobs=2, **kw))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        on_cluster = run_discrepancy(d, DiscrepancySettings(scheduler=client, **kw))
        by_address = run_discrepancy(d, DiscrepancySettings(scheduler=cluster.scheduler_address,
                                                            **kw))
    assert _answer(local) == _answer(on_cluster) == _answer(by_address)
    assert local.member_fits == 2 and local.effect == "voltage_drop", local.message


def test_a_bad_scheduler_setting_is_refused():
    for bad in (3, "", object()):
        with pytest.raises(ValueError, match="scheduler"):
            DiscrepancySettings(scheduler=bad)


def test_cli_refuses_a_scheduler_address_before_any_work(tmp_path, capsys):
    from ehsa_opt.cli import main
    from ehsa_opt.datasets.embedded import embedded_data_dir
    out = tmp_path / "out"
    rc = main(["discrepancy", str(embedded_data_dir("emps")), "--out", str(out),
               "--scheduler", "ucx://127.0.0.1:1"])
    err = capsys.readouterr().err
    assert rc == 2 and "ucx://127.0.0.1:1" in err and "tcp://" in err
    assert not (out / "discrepancy.json").exists()
