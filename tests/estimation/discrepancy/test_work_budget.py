"""The discrepancy answer does not depend on the machine: the budget is counted in member
fits (charged in the order the search asks for them), the wall time is only a safety cap,
and the same data and settings give the same verdict and the same numbers for any
``jobs`` and beside a CPU-bound process."""

from __future__ import annotations

import json
import math
import multiprocessing as mp

import pytest

from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
from ehsa_opt.estimation.discrepancy import run_discrepancy
from ehsa_opt.estimation.discrepancy.budget import (budget_set, charge_fits, cut_reason,
                                                    fits_charged, work_spent)
from ehsa_opt.estimation.discrepancy.results import DiscrepancySettings


def test_member_fits_are_charged_in_the_order_asked_until_the_budget_is_spent():
    with budget_set(3):
        assert charge_fits(2) == 2 and not work_spent()
        assert charge_fits(5) == 1 and work_spent()
        assert charge_fits(1) == 0 and fits_charged() == 3
        assert cut_reason() == "work budget of 3 member fits spent"
    with budget_set(None):
        assert charge_fits(1000) == 1000 and not work_spent() and cut_reason() == ""


def _hog(stop) -> None:  # a CPU-bound process on the other core
    x = 0.0
    while not stop.is_set():
        for k in range(100_000):
            x += math.sin(k)


def _answer(res) -> dict:
    """What an engineer quotes: verdict, named effects, errors, every candidate's
    verdict and parameters, where the run was cut (timings left out)."""
    doc = json.loads(json.dumps(res.as_dict(), default=str))
    cands = [{k: c.get(k) for k in ("effect", "round", "earns", "earns_by", "parameters",
                                    "error_after", "delta_bic_heldout")}
             for c in doc["candidates"]]
    return {"effect": res.effect, "effects": list(res.effects), "success": res.success,
            "error_before": res.error_before, "error_after": res.error_after,
            "cut": res.cut, "candidates": cands}


@pytest.fixture(scope="module")
def compliance_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("compliance")
    write_synthetic(d, SyntheticSpec(
        effects={"compliance": {"compliance_stiffness_N_per_m": 2e5,
                                "compliance_damping_Ns_per_m": 300.0}},
        frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(15.0, 109.0), cycles=1.0, seed=4))
    return d


def test_a_work_budget_gives_the_same_partial_answer_for_any_jobs(compliance_dir):
    """A budget of one member fit: the run is cut in round 1 after its top member, the
    same way and with the same numbers with one worker and with two."""
    runs = [run_discrepancy(compliance_dir, DiscrepancySettings(
        max_member_fits=1, jobs=jobs, discover=False, max_effects=1)) for jobs in (1, 2)]
    a, b = (_answer(r) for r in runs)
    assert a == b
    assert not runs[0].success and "work budget of 1 member fits spent" in runs[0].cut
    assert sum(bool(c["round"] == 1 and c["parameters"]) for c in a["candidates"]) == 1


@pytest.mark.slow
def test_the_same_answer_with_two_jobs_and_beside_a_cpu_hog(compliance_dir):
    """One case run with ``jobs`` 1, then with ``jobs`` 2 while a CPU-bound process runs
    on the other core: identical verdicts and numbers."""
    settings = DiscrepancySettings(jobs=1, discover=False, max_effects=1, top=2)
    quiet = run_discrepancy(compliance_dir, settings)
    stop = mp.get_context("fork").Event()
    hog = mp.get_context("fork").Process(target=_hog, args=(stop,), daemon=True)
    hog.start()
    try:
        loaded = run_discrepancy(compliance_dir, DiscrepancySettings(
            jobs=2, discover=False, max_effects=1, top=2))
    finally:
        stop.set()
        hog.join(10)
    assert _answer(quiet) == _answer(loaded)
    assert quiet.success and quiet.effect == "compliance", quiet.message
