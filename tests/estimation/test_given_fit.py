"""The least-squares path for models without a fitted state (``estimation/given_fit``):
it recovers known parameters and finds the optimum of the IPOPT NLP it replaces."""

import numpy as np
import pytest

from ehsa_opt.datasets.bench_format import BenchTest
from ehsa_opt.estimation.discrepancy import fit as fitmod
from ehsa_opt.estimation.discrepancy.fit import fit_group
from ehsa_opt.estimation.discrepancy.prepared import prepare_tests
from ehsa_opt.estimation.discrepancy.rig import Rig, predict
from ehsa_opt.physics.params import HarvesterParams

FREE = ["inertia_kg", "offset_N", "nut_breakaway_N", "nut_coulomb_N",
        "nut_breakaway_velocity_m_per_s", "nut_viscous_Ns_per_m"]


def _tests(truth: dict, seed: int, raw: bool = True) -> tuple[list, Rig]:
    """Two recorded no-generator records (a chirp-like and a two-tone motion) with the
    force of ``truth`` plus 0.5 N of white noise; ``raw``: the force not low-passed
    (else the parallel filtering of a rig without generator, both sides)."""
    rig = Rig(HarvesterParams(), has_generator=False)
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 4.0, 1e-3)
    motions = [0.02 * np.sin(2 * np.pi * (0.5 * t + 0.3 * t ** 2)),
               0.015 * np.sin(2 * np.pi * 1.3 * t) + 0.01 * np.sin(2 * np.pi * 3.1 * t + 1.0)]
    out = []
    for k, x in enumerate(motions):
        bare = BenchTest(f"r{k}.csv", None, None, None, "recorded", t, x, np.zeros_like(t))
        force = predict(prepare_tests([bare], False), rig, truth, filtered=False)[0][0]
        out.append(BenchTest(f"r{k}.csv", None, None, None, "recorded", t, x,
                             force + 0.5 * rng.standard_normal(t.size)))
    pts = prepare_tests(out, False)
    if raw:  # the path under test on the recorded force itself, neither side filtered
        for pt in pts:
            pt.y, pt.output_filter_hz = pt.raw_force_N[None, :].copy(), None
    return pts, rig


def _start() -> dict:
    return {"inertia_kg": 30.0, "offset_N": 0.0, "nut_breakaway_N": 40.0, "nut_coulomb_N": 25.0,
            "nut_breakaway_velocity_m_per_s": 0.02, "nut_viscous_Ns_per_m": 120.0}


def _nlp_fit(pts, rig, monkeypatch):
    with monkeypatch.context() as m:
        m.setattr(fitmod, "_fit_given", lambda *a, **k: None)
        return fit_group(pts, rig, [_start()], free=FREE)


@pytest.mark.parametrize("breakaway", [30.0, 20.0])  # a Stribeck hump; none (order active)
def test_least_squares_recovers_parameters_and_matches_the_nlp(breakaway, monkeypatch):
    truth = {"inertia_kg": 50.0, "offset_N": 2.0, "nut_breakaway_N": breakaway,
             "nut_coulomb_N": 20.0, "nut_breakaway_velocity_m_per_s": 0.01,
             "nut_viscous_Ns_per_m": 200.0}
    pts, rig = _tests(truth, seed=3)
    ls = fit_group(pts, rig, [_start()], free=FREE)
    assert ls.message.startswith("least_squares"), ls.message  # the path under test ran
    assert ls.success
    p = ls.parameters
    assert p["nut_breakaway_N"] >= p["nut_coulomb_N"] - 1e-9  # the order as a bound
    for name, tol in [("inertia_kg", 0.01), ("offset_N", 0.05), ("nut_coulomb_N", 0.02),
                      ("nut_viscous_Ns_per_m", 0.02), ("nut_breakaway_N", 0.05)]:
        assert p[name] == pytest.approx(truth[name], rel=tol), name
    nlp = _nlp_fit(pts, rig, monkeypatch)
    assert not nlp.message.startswith("least_squares")
    assert ls.sse <= nlp.sse * (1 + 1e-6)  # the same optimum (or a better one)
    sd_ls = np.sqrt(np.diag(ls.covariance))
    sd_nlp = np.sqrt(np.diag(nlp.covariance))
    for k, name in enumerate(FREE):
        assert ls.parameters[name] == pytest.approx(nlp.parameters[name], rel=2e-3, abs=1e-6)
        if np.isfinite(sd_nlp[k]) and sd_nlp[k] > 0:
            assert sd_ls[k] == pytest.approx(sd_nlp[k], rel=0.05), name


def test_a_number_of_starts_is_drawn_and_reaches_the_given_starts_optimum():
    truth = {"inertia_kg": 50.0, "offset_N": 2.0, "nut_breakaway_N": 30.0,
             "nut_coulomb_N": 20.0, "nut_breakaway_velocity_m_per_s": 0.01,
             "nut_viscous_Ns_per_m": 200.0}
    pts, rig = _tests(truth, seed=5)
    given = fit_group(pts, rig, [_start()], free=FREE)
    drawn = fit_group(pts, rig, 2, free=FREE, seed=1)
    assert drawn.success and len(drawn.starts) == 2
    assert drawn.sse <= given.sse * (1 + 1e-6)
    assert drawn.parameters["nut_coulomb_N"] == pytest.approx(truth["nut_coulomb_N"], rel=0.02)


def test_parallel_filtering_of_both_sides_recovers_a_narrow_stribeck_hump():
    """The measured force through the parallel low-pass and the model's output through
    the same filter: a hump narrower than the filter's time scale (breakaway velocity
    0.01 m/s, crossed in a few ms) is recovered.  Filtering only the measured side
    smears it: the breakaway comes out low."""
    truth = {"inertia_kg": 50.0, "offset_N": 2.0, "nut_breakaway_N": 30.0,
             "nut_coulomb_N": 20.0, "nut_breakaway_velocity_m_per_s": 0.01,
             "nut_viscous_Ns_per_m": 200.0}
    pts, rig = _tests(truth, seed=3, raw=False)
    assert all(pt.output_filter_hz is not None for pt in pts)
    both = fit_group(pts, rig, [_start()], free=FREE)
    assert both.success, both.message
    p = both.parameters
    assert p["nut_breakaway_N"] == pytest.approx(30.0, rel=0.03)
    assert p["nut_coulomb_N"] == pytest.approx(20.0, rel=0.02)
    assert p["nut_viscous_Ns_per_m"] == pytest.approx(200.0, rel=0.02)
    for pt in pts:  # the model's side unfiltered: the smeared measurement biases the hump
        pt.output_filter_hz = None
    one = fit_group(pts, rig, [_start()], free=FREE)
    assert one.parameters["nut_breakaway_N"] < 0.95 * 30.0
