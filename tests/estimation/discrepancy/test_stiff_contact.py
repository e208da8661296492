"""Stiff contacts: whether a fit on the forward simulation can determine them at all."""

import pytest

from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests
from ehsa_opt.estimation.discrepancy.fit import Rig, prepare_tests
from ehsa_opt.estimation.discrepancy.candidate_fit import reproducibility
from ehsa_opt.physics import make_component


@pytest.mark.parametrize("stiffness,gap,rattles", [(5e6, 1e-4, False), (3e8, 3e-4, True)])
def test_reproducibility_flags_a_rattling_steel_contact(stiffness, gap, rattles):
    """A steel-like contact (3e8 N/m, 0.3 mm gap, impacts ~2 kN ringing at ~400 Hz) on a
    lightly loaded generator rattles: at the TRUE parameters the simulated force moves by
    many noise levels between integration tolerances 1e-7 and 1e-9, so no sample-wise fit
    can recover its stiffness; the prototype's 5e6 N/m contact is reproducible to 1e-3 σ."""
    truth = {"backlash_gap_m": gap, "backlash_contact_stiffness_N_per_m": stiffness,
             "backlash_contact_damping_Ns_per_m": 8e3}
    spec = SyntheticSpec(effects={"backlash": truth}, frequencies_hz=(2.5,),
                         loads_ohm=(109.0,), seed=2)
    pts = prepare_tests(generate_bench_tests(spec), True)
    rig = Rig(spec.harvester, True, (make_component("backlash"),))
    change = reproducibility(pts, rig, {**spec.friction.as_dict(), **truth})
    assert (change > 3.0) if rattles else (change < 0.01)
