"""The output-error refit of the open-loop port: parameters that generated a simulated
position are recovered from a perturbed start, and bad names are refused."""

from dataclasses import replace

import pytest

from ehsa_opt.datasets.bench_format import load_bench
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.estimation.discrepancy.openloop import open_loop_position
from ehsa_opt.estimation.discrepancy.outputerror import output_error_multistart, output_error_refit


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


def test_multistart_chooses_on_the_fit_record_alone_and_recovers_the_truth():
    """The start is chosen by blocked cross-validation on the fit record: a start far
    from the truth loses to one near it, the chosen refit recovers the simulating
    parameters with intervals that contain them, and the evaluation record plays no
    part in the choice (another evaluation record, the same choice and parameters)."""
    import numpy as np

    t0 = load_bench(embedded_data_dir("emps")).tests[0]
    k = slice(0, 8000)  # the first 4 s hold a reversal
    truth = {"inertia_kg": 95.0, "nut_viscous_Ns_per_m": 200.0, "nut_coulomb_N": 20.0,
             "offset_N": -3.0}
    q = open_loop_position(t0.time_s[k], t0.force_N[k], float(t0.displacement_m[0]), truth)
    rng = np.random.default_rng(0)
    # coloured measurement noise (AR(1), 0.05 mm): the intervals must respect it
    e = np.zeros(q.size)
    for i in range(1, q.size):
        e[i] = 0.98 * e[i - 1] + 1e-5 * rng.standard_normal()
    test = replace(t0, time_s=t0.time_s[k], force_N=t0.force_N[k], displacement_m=q + e)
    free = list(truth)
    near = {**truth, "inertia_kg": 90.0, "nut_viscous_Ns_per_m": 190.0}
    far = {**truth, "inertia_kg": 400.0, "nut_viscous_Ns_per_m": 20.0, "nut_coulomb_N": 80.0}
    runs = []
    for other in (test, replace(test, displacement_m=q[::-1].copy())):
        runs.append(output_error_multistart(test, other, [("far", far), ("near", near)], free,
                                            blocks=2, perturbations=0, max_nfev=15))
    a, b = runs
    assert a["starts"][a["chosen"]]["label"] == "near"
    assert a["starts"][a["chosen"]]["cv_rms_mm"] < a["starts"][0]["cv_rms_mm"]
    assert b["chosen"] == a["chosen"]
    assert b["result"]["parameters"] == a["result"]["parameters"]
    for name in free:
        lo, hi = a["intervals"][name]
        assert lo <= truth[name] <= hi, name
    assert 0 < a["covariance_info"]["n_eff"] < 8000
    with pytest.raises(ValueError, match="at least 2"):
        output_error_multistart(test, test, [("near", near)], free, blocks=1)
