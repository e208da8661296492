"""The ``force_lag`` catalogue member end to end: a force channel recorded late is
named, and the delay reported is the one the workflow applied."""

from dataclasses import replace

import numpy as np

from ehsa_opt.datasets.bench_format import write_bench
from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy import DiscrepancySettings, run_discrepancy


def test_a_late_force_channel_is_named_force_lag_with_its_delay(tmp_path):
    lag_s = 0.004
    spec = SyntheticSpec(effects={}, frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(22.0, 100.0),
                         cycles=1.0, seed=21)
    tests = [replace(t, force_N=np.interp(t.time_s - lag_s, t.time_s, t.force_N))
             for t in generate_bench_tests(spec)]
    write_bench(tmp_path / "lagged", tests, harvester=spec.harvester,
                rig={"name": "late force channel", "has_generator": True})
    res = run_discrepancy(tmp_path / "lagged",
                          DiscrepancySettings(candidates=("force_lag",), max_effects=1))
    assert res.effect == "force_lag", res.message
    tau = res.steps[0]["parameters"]["force_lag_s"]
    # the delay applied (and reported) within a sample period (1 ms) of the truth
    assert abs(tau - lag_s) <= 1e-3, tau
    assert res.error_after < 0.5 * res.error_before
