import math

import casadi as ca
import numpy as np

from ehsa_opt.physics.friction import rod_friction_N, simscape_friction
from ehsa_opt.physics.params import FrictionParams, HarvesterParams

P = (60.0, 40.0, 0.01, 150.0)


def test_float_numpy_casadi_agree():
    u = np.linspace(-0.3, 0.3, 41)
    ref = simscape_friction(u, *P)
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [simscape_friction(x, *P)])
    sym = np.array([float(f(v)) for v in u])
    flt = np.array([simscape_friction(float(v), *P) for v in u])
    np.testing.assert_allclose(sym, ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(flt, ref, rtol=1e-12, atol=1e-12)


def test_symbolic_parameters():
    p = ca.SX.sym("p", 4)
    f = ca.Function("f", [p], [simscape_friction(0.05, p[0], p[1], p[2], p[3])])
    assert math.isclose(float(f(P)), simscape_friction(0.05, *P), rel_tol=1e-12)


def test_analytic_values():
    # odd, zero at rest, breakaway peak at u_brk: F = F_brk + f_v u_brk (tanh(10) ~ 1)
    assert simscape_friction(0.0, *P) == 0.0
    assert math.isclose(simscape_friction(-0.1, *P), -simscape_friction(0.1, *P))
    expected = P[0] + P[3] * P[2] - P[1] * (1 - math.tanh(10.0))
    assert math.isclose(simscape_friction(P[2], *P), expected, rel_tol=1e-12)
    # far from zero: Coulomb + viscous
    assert math.isclose(simscape_friction(1.0, *P), P[1] + P[3] * 1.0, rel_tol=1e-9)


def test_rod_friction_combines_nut_and_bearing():
    fr = FrictionParams(60, 40, 0.01, 150, 0.02, 0.015, 1.0, 3e-5)
    r = HarvesterParams().lead_m_per_rad
    v = 0.2
    expected = simscape_friction(v, 60, 40, 0.01, 150) + \
        simscape_friction(v / r, 0.02, 0.015, 1.0, 3e-5) / r
    assert math.isclose(rod_friction_N(v, fr, r), expected)
