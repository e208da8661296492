"""Figures that explain themselves: the discrepancy and front figures carry captions
written from the run's numbers, and every figure of a front marks the motor, the
infeasible points and the active bounds."""

from __future__ import annotations

import numpy as np
import pytest

import ehsa_opt
from ehsa_opt.design.nsga2 import ParetoResult
from ehsa_opt.pipeline.design_captions import front_caption, hypervolume_caption
from ehsa_opt.pipeline.discrepancy_captions import (per_test_caption, ranking_caption,
                                                    residual_caption)
from ehsa_opt.pipeline.discrepancy_report import report_markdown
from ehsa_opt.plots.design import parallel_coordinates, pareto_projections


@pytest.fixture(scope="module")
def discrepancy_result(tmp_path_factory):
    d = tmp_path_factory.mktemp("disc")
    data = ehsa_opt.generate_bench(frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(15.0, 109.0),
                                   cycles=1.0, seed=2, effects=["backlash"])
    data.save(d / "data")
    return ehsa_opt.discrepancy_report(d / "data", max_member_fits=1).result


def test_discrepancy_figures_carry_captions_from_the_numbers(discrepancy_result):
    res = discrepancy_result
    md = report_markdown(res)
    for label in ("Residual maps", "Ranking", "Error per test", "Zoom"):
        assert f"\n*{label}. " in md, label
    rows = res.per_test_errors()
    text = per_test_caption(res, rows)
    med = np.median([r["error_before"] for r in rows])
    assert f"median {med:.3f} %" in text and f"each of {len(rows)} tests" in text
    worst = max(rows, key=lambda r: r["error_before"])
    assert worst["test"] in text
    ch = max(res.loc_before.channels.values(), key=lambda c: c.structured_fraction)
    assert f"The {ch.channel} residual is {ch.rms_normalised:.2f} × the noise" in \
        residual_caption(res)
    n_app = sum(1 for c in res.candidates if c.applicable)
    assert f"of the {n_app} applicable candidate evaluations" in ranking_caption(res)


def _front() -> ParetoResult:
    F = np.array([[1.0, 4.0], [2.0, 2.0], [4.0, 1.0], [3.0, 3.0]])
    designs = {"load_ohm": np.array([1.0, 5.0, 9.0, 3.0]), "motor": np.array([0, 1, 1, 0.0])}
    return ParetoResult(True, "", np.zeros((4, 2)), designs, F, ("comfort", "road_holding"),
                        1, "knee", [{"n_eval": 10, "hv": 1.0, "hv_archive": 1.2,
                                     "n_archive": 4}, {"n_eval": 20, "hv": 1.5,
                                                      "hv_archive": 1.6, "n_archive": 5}],
                        np.ones(2), np.array([5.0, 5.0]), {}, None, "NSGA2")


def test_front_figures_mark_motor_infeasible_and_bounds():
    import matplotlib.pyplot as plt
    pr = _front()
    marks = {"feasible": np.array([True, True, True, False]),
             "motor": ["A", "B", "B", "A"], "motor_label": "selected from A, B",
             "active_bounds": ["load_ohm at its lower bound 1"]}
    for fig in (pareto_projections(pr, None, None, marks), parallel_coordinates(pr, None,
                                                                                 marks=marks)):
        texts = " ".join(t.get_text() for t in fig.findobj(
            lambda o: hasattr(o, "get_text")) if t.get_text())
        assert "1 of 4 points infeasible" in texts
        assert "selected from A, B" in texts and "load_ohm at its lower bound 1" in texts
        labels = [t.get_text() for ax in fig.axes for t in
                  (ax.get_legend().get_texts() if ax.get_legend() else [])]
        labels += [t.get_text() for leg in fig.legends for t in leg.get_texts()]
        assert any("infeasible" in s for s in labels) and "A" in labels and "B" in labels
        plt.close(fig)


def test_front_captions_from_the_numbers():
    pr = _front()
    rec = {"feasible_front": [True, True, True, False], "front_motors": ["A", "B"],
           "active_bounds": ["load_ohm at its lower bound 1"],
           "hypervolume": {"held_out_roads": {"mean": 1.49, "interval": [1.45, 1.53],
                                              "n_roads": 5}}}
    text = front_caption(pr, rec, {"comfort": 2.0, "road_holding": 2.0})
    assert "4 non-dominated designs, 3 feasible" in text
    assert "motors A, B" in text and "load_ohm at its lower bound 1" in text
    assert "comfort α 1–4 (prototype 2)" in text               # the front's range
    hv = hypervolume_caption(pr, rec)
    assert "1.5 after 20 (archive 1.6)" in hv and "1 after 10 evaluations" in hv
    assert "1.49 [1.45, 1.53]" in hv


def test_intervals_at_every_speed_follow_their_digits():
    """Fig 20's metrics at several speeds: each cell is the interval of the realisations'
    values, printed with the digits the interval supports."""
    from ehsa_opt.physics.params import FrictionParams, HarvesterParams, RoadParams, \
        VehicleParams
    from ehsa_opt.pipeline.vehicle_intervals_report import speed_intervals
    from ehsa_opt.vehicle.uncertainty import format_interval, seed_interval
    veh = VehicleParams.preset("passenger_car")
    road = RoadParams(iso_class="C", speed_km_per_h=70.0, length_m=150.0, seed=0)
    md, res = speed_intervals(veh, road, HarvesterParams(),
                              {"none": None, "max": FrictionParams(nut_coulomb_N=30.0,
                                                                   nut_breakaway_N=35.0)},
                              (40.0, 110.0), 3)
    rows = [r for r in md.splitlines() if r.startswith("| 40 ") or r.startswith("| 110 ")]
    assert len(rows) == 2 and set(res) == {"40", "110"}
    for v, row in zip(("40", "110"), rows):
        p = res[v]["intervals"]["power_W"]
        assert len(res[v]["seeds"]) == 3 and 0 not in res[v]["seeds"]
        assert all(format_interval(d["mean"], d["half_width"]) in row for d in p)
    # more power at the higher speed, as the dissipation bound (∝ speed) says
    assert res["110"]["intervals"]["power_W"][0]["mean"] > \
        res["40"]["intervals"]["power_W"][0]["mean"]
    iv = seed_interval([1.0, 2.0, 3.0])
    assert format_interval(iv.mean, iv.half_width) == iv.text()
