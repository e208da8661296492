"""The speed suite: identification, NSGA-II per evaluation, a quarter-car time-domain run,
a discrepancy member fit and the quick reproduction, each timed by pytest-benchmark
(``benchmarks/conftest.py`` says how to run it and keep the history).  Each benchmark
also checks its result, so a fast wrong answer does not pass."""

from __future__ import annotations

import numpy as np
import pytest


def test_identify(benchmark, rigid_campaign):
    """``identify`` on the 21-test rigid campaign, 4 starts, one process."""
    from ehsa_opt.estimation.identify import identify
    rep = benchmark.pedantic(lambda: identify(rigid_campaign, starts=4, jobs=1, seed=0),
                             rounds=3, iterations=1, warmup_rounds=1)
    assert sum(f.success for f in rep.fits) == len(rigid_campaign)


def test_nsga2_evaluations(benchmark, design_problem):
    """One NSGA-II generation's evaluations: 100 designs of the paper's problem
    (motor model and rated-limit constraints), vectorised as ``run_nsga2`` calls them;
    ``extra_info['per_evaluation_ms']``."""
    U = np.random.default_rng(0).random((100, design_problem.n_var))
    out = benchmark.pedantic(lambda: design_problem.evaluate_unit(U), rounds=10,
                             iterations=1, warmup_rounds=1)
    assert out.shape[0] == 100 and np.all(np.isfinite(out))
    benchmark.extra_info["per_evaluation_ms"] = 1e3 * benchmark.stats.stats.median / 100


def test_quarter_car_time_domain(benchmark):
    """A time-domain quarter-car run: the prototype harvester with the embedded bench's
    true friction on a 300 m class-C road at 100 km/h (1 kHz)."""
    from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
    from ehsa_opt.physics.params import FrictionParams, HarvesterParams, RoadParams, VehicleParams
    from ehsa_opt.vehicle.simulate import simulate_quarter_car
    fr = FrictionParams(**load_truth(embedded_data_dir())["friction"])
    road = RoadParams(length_m=300.0, speed_km_per_h=100.0, seed=0)
    sim = benchmark.pedantic(lambda: simulate_quarter_car(VehicleParams(), HarvesterParams(),
                                                          fr, road, warn=False),
                             rounds=3, iterations=1, warmup_rounds=1)
    assert sim.success and float(np.ravel(sim.metrics["power_W"])[0]) > 0


@pytest.fixture(scope="module")
def backlash_member():
    """The discrepancy workflow's state on the embedded bench data (6 tests, as
    ``reproduce --quick``) up to its candidate fits: the arguments of the backlash
    member's fit."""
    from ehsa_opt.datasets.embedded import embedded_data_dir
    from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES, components_for
    from ehsa_opt.estimation.discrepancy.results import DiscrepancySettings
    from ehsa_opt.estimation.discrepancy.workflow import (fit_baseline, load_data,
                                                          prepare_search_tests)
    settings = DiscrepancySettings(max_tests=6, top=1)
    quiet = lambda msg: None  # noqa: E731
    data = load_data(embedded_data_dir("bench_prototype"), quiet, [])
    tests = prepare_search_tests(data, settings, quiet, [])
    base = fit_baseline(tests, settings, quiet)
    comp = components_for(["backlash"], tests.fit_pts, base.fit_pred,
                          tests.lead_m_per_rad)["backlash"]
    return ("backlash", comp, CANDIDATES["backlash"].starts, tests.sub_pts, tests.fit_pts,
            tests.held_pts, tests.rig, base.fit.parameters, settings.max_iter)


def test_discrepancy_member_fit(benchmark, backlash_member):
    """One member fit of the discrepancy workflow: the backlash candidate re-identified
    on the embedded bench data's fit tests (the workflow's ``fit_member``)."""
    from ehsa_opt.estimation.discrepancy.candidate_fit import fit_member
    name, res, pf, ph, _ = benchmark.pedantic(lambda: fit_member(backlash_member), rounds=2,
                                              iterations=1, warmup_rounds=1)
    assert name == "backlash" and res.success and pf and ph


def test_reproduce_quick(benchmark, tmp_path):
    """``reproduce --quick`` into a fresh folder, two jobs, as a new user runs it; one
    round.  The benchmark's timer sees this process only: ``extra_info`` holds the wall
    time and the CPU time of this process and its forked steps."""
    import resource
    import time

    from ehsa_opt.pipeline.reproduce import reproduce
    out = {}

    def cpu() -> float:
        return sum(r.ru_utime + r.ru_stime for r in (
            resource.getrusage(resource.RUSAGE_SELF),
            resource.getrusage(resource.RUSAGE_CHILDREN)))

    def run():
        c0, t0 = cpu(), time.perf_counter()
        out["report"] = reproduce(tmp_path / "quick", quick=True, jobs=2, log=lambda m: None)
        out["wall_s"], out["cpu_s"] = time.perf_counter() - t0, cpu() - c0

    benchmark.pedantic(run, rounds=1, iterations=1)
    benchmark.extra_info.update({"wall_s": out["wall_s"], "cpu_s": out["cpu_s"]})
    assert "## Run log" in out["report"].read_text(encoding="utf-8")
