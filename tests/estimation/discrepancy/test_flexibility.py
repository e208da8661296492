"""The flexibility candidate: the two-mass component closes its energy balance and is
recovered from synthetic two-mass data by the variable-projection fit."""

from dataclasses import replace

import numpy as np
import pytest

from ehsa_opt.estimation.discrepancy.candidates import CANDIDATES
from ehsa_opt.estimation.discrepancy.rig import Rig, predict
from ehsa_opt.estimation.discrepancy.candidates.flexibility import fit_flexibility
from ehsa_opt.physics import BenchModel, Flexibility
from ehsa_opt.physics.params import HarvesterParams
from tests.estimation.discrepancy.emps_piece import emps_piece


def test_two_mass_energy_balance_closes():
    m = BenchModel(HarvesterParams(), [Flexibility()], generator=False)
    vals = {n: 0.0 for n in m.param_names}
    vals.update({"inertia_kg": 95.0, "offset_N": -3.0, "nut_coulomb_N": 20.0,
                 "nut_breakaway_N": 20.0, "nut_breakaway_velocity_m_per_s": 1e-3,
                 "nut_viscous_Ns_per_m": 200.0, "bearing_breakaway_velocity_rad_per_s": 1.0,
                 "flex_load_mass_kg": 30.0, "flex_frequency_hz": 115.0,
                 "flex_damping_ratio": 0.05, "load_ohm": 1.0})
    p = np.array([vals[n] for n in m.param_names])
    x, u = np.array([1e-4, -2e-3]), np.array([0.05, 0.2, 3.0])
    xd = np.array(m.ode(x, u, p)).ravel()
    e = np.array(m.energy(x, u, p)).ravel()
    h = 1e-7
    ds = (float(np.array(m.energy(x + h * xd, u + h * np.array([u[1], u[2], 0.0]), p)).ravel()[5])
          - e[5]) / h
    assert e[0] == pytest.approx(e[1] + e[2] + e[3] + e[4] + ds, rel=1e-4)
    assert not CANDIDATES["flexibility"].applicable(Rig(HarvesterParams(), True, ()))
    with pytest.raises(ValueError, match="outside"):
        Flexibility(frequency_hz=1e5)


@pytest.mark.slow  # ~15 s alone (a forward simulation of the two-mass data, the grid)
def test_flexibility_recovered_on_synthetic_two_mass_data():
    pt, rig, base = emps_piece(3000, 9000)
    truth = {"flex_load_mass_kg": 30.0, "flex_frequency_hz": 40.0, "flex_damping_ratio": 0.1}
    comp = Flexibility()
    y = predict([pt], rig.with_components([comp]), {**comp.defaults(), **base, **truth})[0]
    rng = np.random.default_rng(0)
    noisy = replace(pt, y=y + rng.normal(0.0, 1.0, y.shape), sigma=np.array([1.0]))
    out = fit_flexibility([noisy], predict([noisy], rig, base), [], [], rig, base)
    p = out["parameters"]
    assert p["flex_frequency_hz"] == pytest.approx(40.0, rel=0.05)
    assert p["flex_load_mass_kg"] == pytest.approx(30.0, rel=0.1)
    lo, hi = out["intervals"]["flex_load_mass_kg"]
    assert lo > 0  # resolved
    assert p["flex_stiffness_N_per_m"] == pytest.approx(30.0 * (2 * np.pi * 40.0) ** 2, rel=0.2)
    # the rigid data give no flexibility of any size (mass interval reaches zero or none)
    rigid = replace(pt, y=predict([pt], rig, base)[0] + rng.normal(0.0, 1.0, y.shape),
                    sigma=np.array([1.0]))
    o2 = fit_flexibility([rigid], predict([rigid], rig, base), [], [], rig, base)
    assert not o2["parameters"] or o2["intervals"]["flex_load_mass_kg"][1] < 3.0
