"""The output-error refit of the open-loop port: parameters that generated a simulated
position are recovered from a perturbed start, and bad names are refused."""

from dataclasses import replace

import pytest

from ehsa_opt.datasets.bench_format import load_bench
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.estimation.discrepancy.openloop import open_loop_position
from ehsa_opt.estimation.discrepancy.outputerror import output_error_refit


def test_output_error_refit_recovers_the_simulating_parameters():
    t0 = load_bench(embedded_data_dir("emps")).tests[0]
    k = slice(0, 6000)
    truth = {"inertia_kg": 95.0, "nut_viscous_Ns_per_m": 200.0, "nut_coulomb_N": 20.0,
             "offset_N": -3.0, "asym_viscous_Ns_per_m": -35.0, "asym_coulomb_N": 0.5}
    q = open_loop_position(t0.time_s[k], t0.force_N[k], float(t0.displacement_m[0]), truth)
    test = replace(t0, time_s=t0.time_s[k], force_N=t0.force_N[k], displacement_m=q)
    start = {**truth, "inertia_kg": 90.0, "nut_viscous_Ns_per_m": 185.0,
             "nut_coulomb_N": 22.0, "offset_N": -2.0, "asym_viscous_Ns_per_m": -25.0}
    free = ["inertia_kg", "nut_viscous_Ns_per_m", "nut_coulomb_N", "offset_N",
            "asym_viscous_Ns_per_m"]
    out = output_error_refit(test, start, free, [test])
    assert out["success"] and out["fit_rms_mm"] < 0.05
    for name in free:
        assert out["parameters"][name] == pytest.approx(truth[name], rel=0.02, abs=0.05)
    assert out["eval"][0]["rms_mm"] == pytest.approx(out["fit_rms_mm"], rel=0.2, abs=0.01)
    with pytest.raises(ValueError, match="unknown free parameters"):
        output_error_refit(test, start, ["gremlin_N"])
