"""Exact band-limited variances by residues (ehsa_opt.vehicle.fast_path.band_variances)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from ehsa_opt.physics.params import ParameterError, RoadParams, VehicleParams
from ehsa_opt.vehicle.fast_path.linearisation import friction_metrics
from ehsa_opt.vehicle.iso2631 import wk_exact
from ehsa_opt.vehicle.frequency_path import design_arrays
from ehsa_opt.vehicle.fast_path.band_variances import QuarterCarPolynomials
from ehsa_opt.vehicle.road import ROAD_BAND_CYCLES_PER_M, road_velocity_psd

VEHICLE = VehicleParams()
# well damped, lightly damped (R_e = 10 kΩ, k_n high), heavy inertia, open circuit,
# a locked strut (c = 1e7 N s/m: one pole far below, one far above the band)
DESIGN = {"load_ohm": np.array([47.0, 1e4, 3.0, math.inf, 47.0]),
          "speed_constant_rpm_per_V": np.array([69.7, 11900.0, 300.0, 69.7, 69.7]),
          "total_inertia_gcm2": np.array([301.0, 9000.0, 5000.0, 301.0, 301.0]),
          "lead_mm_per_rev": np.array([5.0, 5.3, 20.0, 10.0, 5.0])}
C_F = np.array([0.0, 30.0, 500.0, 200.0, 1e7])


def _adaptive(road: RoadParams, j: int, d: dict, c: float) -> dict:
    """The same variances by scipy's adaptive quadrature of the complex transfer functions."""
    m2, m1 = VEHICLE.sprung_mass_kg, VEHICLE.unsprung_mass_kg
    k2, k1 = VEHICLE.suspension_stiffness_N_per_m, VEHICLE.tyre_stiffness_N_per_m
    r, ke, kt, L = d["r_m_per_rad"][j], d["Ke"][j], d["Kt"][j], d["L_H"][j]
    R = d["Ri_ohm"][j] + d["Re_ohm"][j]
    meq = d["J_kgm2"][j] / r ** 2

    def tf(f: float) -> tuple:
        s = 2j * math.pi * f
        y_el = 0.0 if math.isinf(R) else kt * ke / (r ** 2 * (R + s * L))
        dd = k2 + s * (s * meq + y_el + c)
        a11 = dd + m2 * s * s
        det = a11 * (dd + m1 * s * s + k1) - dd * dd
        v = k1 * m2 * s * s / det
        cur = 0.0 if math.isinf(R) else ke / r * v / (R + s * L)
        return v, k1 * s * dd / det * wk_exact(f), (k1 * a11 - det) / (s * det), cur

    v = road.speed_m_per_s
    f_lo, f_hi = ROAD_BAND_CYCLES_PER_M[0] * v, ROAD_BAND_CYCLES_PER_M[1] * v
    out = {}
    for i, key in enumerate(("var_v", "var_acc_w", "var_tyre", "var_i")):
        val = integrate.quad(lambda f, i=i: abs(tf(f)[i]) ** 2, f_lo, f_hi, points=[1.0, 10.0],
                             limit=4000, epsabs=0.0, epsrel=1e-11)[0]
        out[key] = val * road_velocity_psd(road)
    return out


@pytest.mark.parametrize("road", [RoadParams("C", 70.0), RoadParams("B", 30.0)])
def test_residue_variances_match_adaptive_quadrature(road):
    d = {k: a.reshape(-1) for k, a in design_arrays(DESIGN).items()}
    v = road.speed_m_per_s
    qp = QuarterCarPolynomials(VEHICLE, d, ROAD_BAND_CYCLES_PER_M[0] * v,
                               ROAD_BAND_CYCLES_PER_M[1] * v, road_velocity_psd(road))
    rows = np.arange(C_F.size)
    lam = qp.roots(qp.q(C_F, rows))
    assert np.all(qp.check(qp.q(C_F, rows), lam))
    got = qp.variances(C_F, rows, lam)
    # the fixed point's cheaper σ_v² (Q(−λ) = −2 Q_odd(λ)) is the same number
    np.testing.assert_allclose(qp.var_v(C_F, rows, lam), got["var_v"], rtol=1e-8)
    for j in rows:
        ref = _adaptive(road, j, d, C_F[j])
        assert got["var_v"][j] == pytest.approx(ref["var_v"], rel=1e-8)
        assert got["var_acc_w"][j] == pytest.approx(ref["var_acc_w"], rel=1e-8)
        assert got["var_tyre"][j] == pytest.approx(ref["var_tyre"], rel=1e-8)
        p_load = d["Re_ohm"][j] * ref["var_i"] if np.isfinite(d["Re_ohm"][j]) else 0.0
        assert got["p_load"][j] == pytest.approx(p_load, rel=1e-8, abs=1e-300)
    # poles tracked from c = 0 are the poles computed afresh
    lam0 = qp.roots(qp.q0)
    tracked = qp.follow(C_F, rows, lam0, np.zeros(C_F.size))
    dist = np.min(np.abs(lam[:, :, None] - tracked[:, None, :]), axis=2) / np.abs(lam)
    assert np.max(dist) < 1e-10
    # and the closed-form roots (Ferrari) are the companion matrix's eigenvalues
    eig = qp._eig_roots(qp.q0)
    assert np.max(np.min(np.abs(eig[:, :, None] - lam0[:, None, :]), axis=2)
                  / np.abs(eig)) < 1e-10


def test_method_is_checked():
    with pytest.raises(ParameterError, match="method"):
        friction_metrics(VEHICLE, RoadParams("C", 70.0), None, None, method="fast")


def test_undamped_frictionless_design_falls_back_to_quadrature():
    # open circuit: no damping without friction, σ_v(0) is unbounded; such designs are
    # evaluated by the quadrature path, the others exactly in the same call
    from ehsa_opt.physics.params import FrictionParams
    road = RoadParams("B", 30.0)
    fr = FrictionParams(nut_breakaway_N=120.0, nut_coulomb_N=80.0,
                        nut_breakaway_velocity_m_per_s=0.01, nut_viscous_Ns_per_m=300.0)
    design = {"load_ohm": np.array([math.inf, 47.0])}
    # (the residual force is added on the exact path only: compared without it)
    got = friction_metrics(VEHICLE, road, design, fr, residual=False)
    quad = friction_metrics(VEHICLE, road, design, fr, method="quadrature")
    assert got["power_W"][0] == 0.0 and np.all(got["converged"] == 1.0)
    for key in ("comfort", "road_holding", "friction_damping_Ns_per_m"):
        assert got[key][0] == pytest.approx(quad[key][0], rel=1e-12)
        assert got[key][1] == pytest.approx(quad[key][1], rel=1e-3)


def test_almost_undamped_design_that_friction_alone_damps():
    # R_e = 23 kΩ, L = 0, k_n = 5500 rpm/V: σ_v(0) of kilometres per second; the fixed
    # point (friction ×34) lies ~1e-6 below it, not a locked strut
    from ehsa_opt.datasets.embedded import embedded_data_dir, load_truth
    from ehsa_opt.vehicle.fast_path.validation import scaled_friction
    truth = load_truth(embedded_data_dir("bench_prototype"))["friction"]
    design = {"total_inertia_gcm2": 17.507, "lead_mm_per_rev": 94.51,
              "speed_constant_rpm_per_V": 5501.5, "load_ohm": 23061.7, "inductance_H": 0.0,
              "internal_resistance_ohm": 7.197}
    fr = scaled_friction(truth, 34.1)
    road = RoadParams("B", 30.0)
    got = friction_metrics(VEHICLE, road, design, fr, non_gaussian=False, residual=False)
    quad = friction_metrics(VEHICLE, road, design, fr, non_gaussian=False, method="quadrature")
    assert float(got["converged"]) == 1.0
    assert float(got["stroke_velocity_rms_m_s"]) == pytest.approx(
        float(quad["stroke_velocity_rms_m_s"]), rel=1e-2)
