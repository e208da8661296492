"""The paper's numbers through the invariants (P/η, P ∝ V, short-circuit damping)."""

import pytest

from ehsa_opt.physics.params import HarvesterParams, RoadParams, VehicleParams
from ehsa_opt.pipeline.paper_reference import PAPER_OPTIMUM, PAPER_TABLE4
from ehsa_opt.pipeline.invariants_report import paper_invariants
from ehsa_opt.vehicle.road import dissipation_bound_W


def test_paper_invariants_arithmetic():
    inv = paper_invariants(VehicleParams(), RoadParams("C", 70.0), HarvesterParams(),
                           PAPER_TABLE4, PAPER_OPTIMUM)
    assert [round(v) for v in inv["p_over_eta_W"]] == [216, 220, 222]
    assert inv["fig19_scaled_to_100_W"] == pytest.approx(231.4, abs=0.1)
    assert inv["short_circuit_electrical_Ns_per_m"] == pytest.approx(4491, abs=1)
    assert inv["implied_internal_resistance_ohm"] == pytest.approx(75 * (1 / 0.81 - 1))
    # the implied level reproduces the paper's P/η through the bound's formula
    bound = dissipation_bound_W(VehicleParams(), RoadParams("C", 100.0))
    assert bound == pytest.approx(140.0, rel=0.01)
    assert inv["implied_k1_gd_ratio"] * bound == pytest.approx(inv["p_over_eta_mean_W"])
    assert inv["implied_gd_at_our_k1_m3"] == pytest.approx(
        256e-6 * inv["p_over_eta_mean_W"] / bound)
