"""Friction-aware fast path: stochastic equivalent linearisation (SPEC §5, issue 14).

Under the Gaussian road response the stroke velocity v is (nearly) zero-mean
Gaussian with rms σ_v.  Statistical linearisation (Kazakov; Atalik & Utku 1976)
replaces the friction force F_f(v) = F_ns(v) + T_b(v/r)/r
(:mod:`ehsa_opt.physics.friction`) by the viscous damping that minimises the
mean-square error::

    c_f(σ_v) = E[F_f(v) v] / σ_v²  ( = E[F_f'(v)] for Gaussian v )

The Gaussian expectations are closed forms or fixed Gauss–Legendre rules,
vectorised over designs:

* viscous f_v u  →  f_v;
* Stribeck √(2e) ΔF e^{−z²} z, z = u/u_St  →  √(2e) ΔF / u_St · (1 + 2σ²/u_St²)^{−3/2};
* Coulomb F_C tanh(u/u_c)  →  F_C E[u tanh(u/u_c)] / σ², computed as
  F_C (σ√(2/π) − 2 u_c² ∫₀^∞ x (1 − tanh x) φ_σ(u_c x) dx) / σ² when u_c ≪ σ (the
  pure-Coulomb limit F_C √(2/π)/σ plus a smooth correction), and by direct
  quadrature of E[u tanh(u/u_c)] otherwise.

The bearing law is linearised in ω = v/r (σ_ω = σ_v/r) and seen at the rod as
c_b/r².  c_f joins the harvester's damping in the exact linear frequency path
(:func:`ehsa_opt.vehicle.metrics.linear_metrics`, ``friction_damping_Ns_per_m``),
whose σ_v depends on c_f: the fixed point σ_v = σ_lin(c_f(σ_v)) is found per
design by a vectorised Illinois (regula falsi) iteration on log σ_v, bracketed by
the frictionless σ_v (c_f ≥ 0 only lowers σ_v) and 10⁻⁴ of it.  The iteration
runs inside ``linear_metrics`` on each block's prepared (coarser) frequency grid
(only |det|² depends on c_f, so one iteration costs a small fraction of a full
evaluation); the metrics at the fixed point are then one exact linear evaluation
with c_f: the friction-aware evaluation costs 2–3 linear ones (measured: 4000
designs 0.54 s Gaussian, 0.67 s with the averaging correction, linear path 0.24 s;
76 designs 7.0 / 8.2 / 2.5 ms).  Friction then
dissipates E[F_f v] = c_f σ_v², included in ``dissipated_power_W`` so the
efficiency is the generator's share, as in the time-domain path.

Sticking: with a strong Coulomb friction v is not Gaussian (excess mass near
v = 0), E[F_C sgn(v) v] = F_C E|v| falls below F_C σ√(2/π) and the Gaussian c_f
is too high.  By default the Gaussian fixed point is then corrected by the
energy-envelope (stochastic-averaging) density of the strut's amplitude
(:mod:`ehsa_opt.vehicle.averaging`), whose two modal constants come from the
linear path's σ_v(0) and σ_v(c_f) (secant), iterated; it equals the Gaussian value
for weak or viscous friction.

Validity: the linearisation assumes a Gaussian v; where Coulomb friction makes
the strut stick for long stretches (slow, smooth roads, high F_C) the true v is
far from Gaussian and errors grow — ``benchmarks/friction_fast_path.py``
measures them against :func:`ehsa_opt.vehicle.simulate.simulate_quarter_car`.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..physics.params import FRICTION_NAMES, FrictionParams, HarvesterParams, ParameterError, \
    RoadParams, VehicleParams
from .averaging import amplitude_terms, averaged_damping
from .metrics import design_arrays, linear_metrics

__all__ = ["law_equivalent_damping", "friction_equivalent_damping_Ns_per_m", "friction_array",
           "friction_metrics"]

_SQRT_2E = math.sqrt(2.0 * math.e)
_SQRT_2_PI = math.sqrt(2.0 / math.pi)
_N_GL = 64
_GL_X, _GL_W = np.polynomial.legendre.leggauss(_N_GL)


def _gl(a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [a, b]."""
    return 0.5 * (b - a) * (_GL_X + 1.0) + a, 0.5 * (b - a) * _GL_W


_X_CORR, _W_CORR = _gl(0.0, 20.0)    # x = u/u_c, 1 − tanh x < 1e-17 beyond 20
_T_DIRECT, _W_DIRECT = _gl(0.0, 9.0)  # t = u/σ, Gaussian tail < 1e-18 beyond 9


def _coulomb_term(sigma: np.ndarray, u_c: np.ndarray) -> np.ndarray:
    """E[u tanh(u/u_c)] / σ² for u ~ N(0, σ²) (arrays broadcast together)."""
    sigma, u_c = np.broadcast_arrays(np.maximum(sigma, 1e-300), u_c)
    ratio = u_c / sigma
    out = np.empty(ratio.shape)
    lo = ratio < 0.2
    if np.any(lo):  # u_c ≪ σ: σ√(2/π) minus the smooth correction near u = 0
        s, uc = sigma[lo][:, None], u_c[lo][:, None]
        phi = np.exp(-0.5 * (uc * _X_CORR / s) ** 2) / (s * math.sqrt(2.0 * math.pi))
        corr = 2.0 * uc[:, 0] ** 2 * np.sum(_W_CORR * _X_CORR * (1.0 - np.tanh(_X_CORR)) * phi,
                                            axis=-1)
        out[lo] = (s[:, 0] * _SQRT_2_PI - corr) / s[:, 0] ** 2
    hi = ~lo
    if np.any(hi):  # E[u tanh(u/u_c)] = 2 ∫₀^∞ σt tanh(σt/u_c) φ(t) dt, t = u/σ
        t = _T_DIRECT
        dens = np.exp(-0.5 * t * t) / math.sqrt(2.0 * math.pi)
        out[hi] = 2.0 * np.sum(_W_DIRECT * t * np.tanh(t / ratio[hi][:, None]) * dens,
                               axis=-1) / sigma[hi]
    return out


def law_equivalent_damping(sigma: ArrayLike, breakaway: ArrayLike, coulomb: ArrayLike,
                           breakaway_velocity: ArrayLike, viscous: ArrayLike) -> np.ndarray:
    """Equivalent damping E[F(u) u]/σ² of the Simscape law for u ~ N(0, σ²).

    Parameters
    ----------
    sigma : array_like
        rms of the sliding velocity (m/s or rad/s), > 0.
    breakaway, coulomb, breakaway_velocity, viscous : array_like
        The law's parameters (see :func:`ehsa_opt.physics.friction.simscape_friction`).

    Returns
    -------
    ndarray
        Damping in N s/m (or N m s/rad), broadcast shape.
    """
    sigma, brk, cou, ubrk, fv = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (sigma, breakaway, coulomb, breakaway_velocity,
                                               viscous)))
    u_st = math.sqrt(2.0) * ubrk
    stribeck = _SQRT_2E * (brk - cou) / u_st * (1.0 + 2.0 * (sigma / u_st) ** 2) ** -1.5
    coul = np.where(cou > 0.0, cou * _coulomb_term(sigma, ubrk / 10.0), 0.0)
    return fv + stribeck + coul


def friction_array(friction: FrictionParams | Sequence[FrictionParams] | ArrayLike | None
                   ) -> np.ndarray:
    """Friction sets as an array (..., 8) in :data:`FRICTION_NAMES` order."""
    if friction is None:
        return np.asarray(FrictionParams().as_array(), dtype=float)
    if isinstance(friction, FrictionParams):
        return np.asarray(friction.as_array(), dtype=float)
    if isinstance(friction, (list, tuple)) and friction and isinstance(friction[0],
                                                                        FrictionParams):
        return np.array([f.as_array() for f in friction], dtype=float)
    arr = np.asarray(friction, dtype=float)
    if arr.shape[-1:] != (len(FRICTION_NAMES),):
        raise ParameterError(f"friction: expected FrictionParams or an array (..., "
                             f"{len(FRICTION_NAMES)}) in {', '.join(FRICTION_NAMES)} order, "
                             f"got shape {arr.shape}")
    return arr


def friction_equivalent_damping_Ns_per_m(sigma_v_m_s: ArrayLike, friction: Any,
                                         lead_m_per_rad: ArrayLike) -> np.ndarray:
    """Equivalent damping at the rod of nut (at v) + bearing (at v/r, seen as T/r).

    Parameters
    ----------
    sigma_v_m_s : array_like
        rms stroke velocity, m/s.
    friction : FrictionParams or array (..., 8)
    lead_m_per_rad : array_like
        r = lead/2π, m/rad.
    """
    p = friction_array(friction)
    p = np.moveaxis(p, -1, 0)
    r = np.asarray(lead_m_per_rad, dtype=float)
    sv = np.asarray(sigma_v_m_s, dtype=float)
    nut = law_equivalent_damping(sv, p[0], p[1], p[2], p[3])
    bearing = law_equivalent_damping(sv / r, p[4], p[5], p[6], p[7]) / r ** 2
    return nut + bearing


def friction_metrics(vehicle: VehicleParams, road: RoadParams,
                     design: Mapping[str, ArrayLike] | None = None,
                     friction: Any = None, *, n_freq: int = 256,
                     base: HarvesterParams | None = None, rtol: float = 1e-6,
                     max_iter: int = 60, iteration_n_freq: int = 64,
                     non_gaussian: bool = True, averaging_iter: int = 8,
                     resolve_on_final_grid: bool = True) -> dict[str, np.ndarray]:
    """Metrics of the quarter car with friction by equivalent linearisation.

    Parameters
    ----------
    vehicle, road, design, n_freq, base
        As :func:`ehsa_opt.vehicle.metrics.linear_metrics`.
    friction : FrictionParams, sequence of them, or array (..., 8), optional
        Broadcast against the design's shape (the last axis holds the eight
        values); None is frictionless (the linear path exactly).
    rtol : float
        Tolerance on log σ_v of the fixed point.
    max_iter : int
        Iteration limit (Illinois steps).
    iteration_n_freq : int
        Shared grid points while iterating (the fixed point c_f is then evaluated
        exactly by ``linear_metrics`` at ``n_freq`` on a grid refined around the
        poles with c_f).
    non_gaussian : bool
        Correct the Gaussian c_f for the non-Gaussian (sticking) velocity by the
        energy-envelope density of :mod:`ehsa_opt.vehicle.averaging` (default);
        False gives the plain Gaussian equivalent linearisation.
    resolve_on_final_grid : bool
        Solve the fixed point a second time on the final grid (default), refined
        around the poles with the first c_f, and report the metrics there; False: one
        fixed point on the coarse grid refined around the frictionless poles, which
        is not grid-converged for weakly damped designs (tens of % on power).
    averaging_iter : int
        Iteration limit of that correction (secant update of the mode's linear
        damping; stops when c_f changes by < 10·rtol).

    Returns
    -------
    dict of ndarray
        The keys of ``linear_metrics`` (``dissipated_power_W`` includes the
        friction, ``efficiency`` is the generator's share) plus
        ``friction_damping_Ns_per_m`` (c_f), ``friction_damping_gaussian_Ns_per_m``
        (the Gaussian fixed point's c_f), ``friction_power_W`` (E[F_f v]),
        ``iterations`` and ``converged`` (1.0/0.0).
    """
    d = design_arrays(design, base)
    fr = friction_array(friction)
    shape = np.broadcast_shapes(d["Re_ohm"].shape, fr.shape[:-1])
    r = np.broadcast_to(d["r_m_per_rad"], shape).reshape(-1)
    fr = np.broadcast_to(fr, shape + fr.shape[-1:]).reshape(-1, fr.shape[-1])
    full = {k: np.broadcast_to(np.asarray(v, dtype=float), shape)
            for k, v in dict(design or {}).items()}
    if not full:  # the base design, repeated over the friction sets
        full = {"load_ohm": np.broadcast_to((base or HarvesterParams()).load_ohm, shape)}
    n = r.size
    # friction forces all zero (breakaway velocities alone do nothing): frictionless
    has_f = ~np.all(fr[:, [0, 1, 3, 4, 5, 7]] == 0.0, axis=1)
    iters = np.zeros(n)
    conv = np.ones(n, dtype=bool)
    c_gauss = np.zeros(n)
    hint_s = np.full(n, np.nan)   # the first pass's log σ_v (Gaussian) and corrected c_f
    hint_c = np.full(n, np.nan)
    # tolerance of the pass: loose on the coarse first pass when a second one follows
    tol = [max(rtol, 1e-3) if resolve_on_final_grid else rtol]

    def solver(index: np.ndarray, sigma_v_of: Any) -> np.ndarray:
        rows = np.arange(index.size)
        s_hi = np.log(sigma_v_of(np.zeros(index.size), rows))
        s_sol = s_hi.copy()
        act = np.flatnonzero(has_f[index])
        if act.size:
            gi = index[act]

            def g(sub: np.ndarray, s: np.ndarray) -> np.ndarray:
                cf = friction_equivalent_damping_Ns_per_m(np.exp(s), fr[gi[sub]], r[gi[sub]])
                return np.log(sigma_v_of(cf, act[sub])) - s

            every = np.arange(act.size)
            lo_full = s_hi[act] - math.log(1e4)
            a, b = lo_full.copy(), s_hi[act].copy()
            hint = hint_s[gi]
            near = np.isfinite(hint)
            # second pass: a ×e^{±0.5} bracket around the first pass's σ_v, else the full one
            a[near] = np.maximum(a[near], hint[near] - 0.5)
            b[near] = np.minimum(b[near], hint[near] + 0.5)
            ga, gb = g(every, a), g(every, b)
            wide = np.flatnonzero(near & ~((ga > 0.0) & (gb < 0.0)))
            if wide.size:
                a[wide], b[wide] = lo_full[wide], s_hi[act][wide]
                ga[wide], gb[wide] = g(wide, a[wide]), g(wide, b[wide])
            # locked strut: even σ = 1e-4 σ₀ is not small enough → report the lower end
            locked = ga <= 0.0
            x = np.where(locked, a, b)
            done = locked | (gb >= 0.0)
            side = np.zeros(act.size)
            it = np.zeros(act.size)
            for _ in range(max_iter):
                todo = np.flatnonzero(~done)
                if todo.size == 0:
                    break
                fa, fb = ga[todo], gb[todo]
                xn = (a[todo] * fb - b[todo] * fa) / (fb - fa)
                gn = g(todo, xn)
                it[todo] += 1
                x[todo] = xn
                pos = gn > 0.0
                # Illinois: halve the retained end's value when the same end is kept twice
                sd = side[todo]
                a[todo] = np.where(pos, xn, a[todo])
                ga[todo] = np.where(pos, gn, np.where(sd == -1, 0.5 * fa, fa))
                b[todo] = np.where(pos, b[todo], xn)
                gb[todo] = np.where(pos, np.where(sd == 1, 0.5 * fb, fb), gn)
                side[todo] = np.where(pos, 1, -1)
                done[todo] = (np.abs(gn) < tol[0]) | (np.abs(b[todo] - a[todo]) < tol[0])
            s_sol[act] = x
            hint_s[gi] = x
            iters[gi] = it
            conv[gi] = done & ~locked
        cf = friction_equivalent_damping_Ns_per_m(np.exp(s_sol), fr[index], r[index])
        cf = np.where(has_f[index], cf, 0.0)
        c_gauss[index] = cf
        if non_gaussian and act.size:
            # energy-envelope correction: secant (c, σ_c) of the linear path, iterated
            gi = index[act]
            s0, c, sc = np.exp(s_hi[act]), cf[act], np.exp(s_sol[act])
            todo = np.arange(act.size)
            # amplitude nodes and cycle averages once, on the Gaussian σ_v's scale
            vt, dt, pt = amplitude_terms(np.minimum(sc, s0), fr[gi], r[gi])
            prev = np.flatnonzero(np.isfinite(hint_c[gi]))
            if prev.size:  # second pass: start from the first pass's corrected c_f
                c[prev] = hint_c[gi[prev]]
                sc[prev] = sigma_v_of(c[prev], act[prev])
            for _ in range(averaging_iter):
                cn = averaged_damping(s0[todo], sc[todo], c[todo], fr[gi[todo]], r[gi[todo]],
                                      terms=(vt[todo], dt[todo], pt[todo]))
                moved = np.abs(cn - c[todo]) > 10.0 * tol[0] * np.abs(c[todo])
                c[todo] = cn
                todo = todo[moved]
                if todo.size == 0:
                    break
                sc[todo] = sigma_v_of(c[todo], act[todo])
            cf[act] = c
            hint_c[gi] = c
        return cf

    first = linear_metrics(vehicle, road, full, n_freq=min(n_freq, iteration_n_freq),
                           base=base, friction_damping_solver=solver)
    cf = np.broadcast_to(first["friction_damping_Ns_per_m"], shape).reshape(-1)
    if resolve_on_final_grid:
        tol[0] = rtol
        # the fixed point again on the final grid, refined around the poles with the
        # first c_f (the first grid is refined around the frictionless poles, far
        # too narrow for a weakly damped design that friction damps)
        m = linear_metrics(vehicle, road, full, n_freq=n_freq, base=base,
                           friction_damping_Ns_per_m=cf.reshape(shape),
                           friction_damping_solver=solver)
        cf = np.broadcast_to(m["friction_damping_Ns_per_m"], shape).reshape(-1)
    else:
        m = linear_metrics(vehicle, road, full, n_freq=n_freq, base=base,
                           friction_damping_Ns_per_m=cf.reshape(shape))
    m = {k: np.broadcast_to(np.asarray(v), shape).reshape(-1) for k, v in m.items()}
    m["friction_power_W"] = cf * m["stroke_velocity_rms_m_s"] ** 2
    m["friction_damping_gaussian_Ns_per_m"] = c_gauss
    m["iterations"] = iters
    m["converged"] = conv.astype(float)
    return {k: np.asarray(v).reshape(shape) for k, v in m.items()}
