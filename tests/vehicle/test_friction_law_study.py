"""The friction law's effect on the vehicle metrics (vehicle/friction_law_study.py)."""

import pytest

from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
from ehsa_opt.physics.params import (FrictionParams, HarvesterParams, ParameterError,
                                     RoadParams, VehicleParams)
from ehsa_opt.vehicle.friction_law_study import friction_law_effect

TRUTH = FrictionParams(**load_truth(embedded_data_dir())["friction"])
ROAD = RoadParams(iso_class="C", speed_km_per_h=100.0, length_m=150.0, seed=5)


def _lugre(fr: FrictionParams, sigma0: float) -> FrictionParams:
    return fr.with_law("lugre", presliding_stiffness_N_per_m=sigma0,
                       presliding_damping_Ns_per_m=300.0)


def test_same_map_splits_the_change_into_bristle_only():
    static = {"best": TRUTH}
    eff = friction_law_effect(VehicleParams(), HarvesterParams(), ROAD, static,
                              {"best": _lugre(TRUTH, 5e4)}, n_seeds=3)
    assert eff.designs == ("none", "static best", "lugre best", "limit best")
    for m in ("comfort", "road_holding", "power_W"):
        assert eff.change(m, "best", "map").mean == 0.0  # same map: nothing from the map
        assert eff.change(m, "best").mean == pytest.approx(eff.change(m, "best", "bristle").mean)
    assert eff.change("power_W", "best").half_width >= 0.0
    assert "| best | power_W |" in eff.table()
    d = eff.as_dict()
    assert set(d["changes"]["best"]) == {"comfort", "road_holding", "power_W"}
    # a stiff bristle is the static law: no change beyond 1e-3 %
    stiff = friction_law_effect(VehicleParams(), HarvesterParams(), ROAD, static,
                                {"best": _lugre(TRUTH, 1e10)}, n_seeds=2)
    for m in ("comfort", "road_holding", "power_W"):
        assert abs(stiff.change(m, "best").mean) < 1e-3


def test_a_larger_map_lowers_the_power_through_the_map():
    more = FrictionParams(**{k: (2 * v if "velocity" not in k else v)
                             for k, v in TRUTH.as_dict().items()})
    eff = friction_law_effect(VehicleParams(), HarvesterParams(), ROAD, {"best": TRUTH},
                              {"best": _lugre(more, 1e10)}, n_seeds=2)
    assert eff.change("power_W", "best", "map").mean < -1.0
    assert abs(eff.change("power_W", "best", "bristle").mean) < 1e-3


def test_refusals_name_the_side_and_the_fix():
    with pytest.raises(ParameterError, match="LuGre sets best are not under the lugre law"):
        friction_law_effect(VehicleParams(), HarvesterParams(), ROAD, {"best": TRUTH},
                            {"best": TRUTH}, n_seeds=2)
    with pytest.raises(ParameterError, match="cases"):
        friction_law_effect(VehicleParams(), HarvesterParams(), ROAD, {"best": TRUTH},
                            {"max": _lugre(TRUTH, 1e6)}, n_seeds=2)
    with pytest.raises(ValueError, match="what must be"):
        friction_law_effect(VehicleParams(), HarvesterParams(), ROAD, {"best": TRUTH},
                            {"best": _lugre(TRUTH, 1e6)}, n_seeds=2).change("power_W", "best",
                                                                            "bogus")
