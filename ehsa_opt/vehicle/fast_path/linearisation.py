"""Friction-aware fast path: stochastic equivalent linearisation (paper Eqs 6–9).

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
c_b/r².  c_f joins the harvester's damping in the linear quarter car, whose σ_v
depends on c_f: the fixed point σ_v = σ_lin(c_f(σ_v)) is solved per design.

Default (``method="exact"``): the linear quarter car's variances over the road band
are integrated in closed form by residues (:mod:`ehsa_opt.vehicle.fast_path.band_variances`: five
poles per design, no frequency grid, exact to rounding), the poles being tracked by
Newton steps as c_f changes.  The fixed point is found by secants of the one-mode
model 1/σ_v² = α + β c (exact for one lightly damped mode under white excitation,
nearly so for the quarter car): each step fits α, β through the two latest exact
points (c, 1/σ_lin²(c)), solves the model's fixed point (only the friction law is
evaluated) and evaluates σ_lin exactly at its c_f, until |ln σ_lin(c_f(σ)) − ln σ| <
rtol — typically 2 exact evaluations.  The Coulomb expectation is a univariate
function of u_c/σ, tabulated once (cubic spline, relative error < 1e-10).  4000
designs: about 0.1 s with the averaging correction (the time-domain path needs
20–40 ms per design; ``validation/friction_fast_path.py``).

``method="quadrature"`` keeps the frequency grid of
:func:`ehsa_opt.vehicle.frequency_path.linear_metrics`: a vectorised Illinois (regula
falsi) iteration on log σ_v, bracketed by the frictionless σ_v (c_f ≥ 0 only lowers
σ_v) and 10⁻⁴ of it, runs inside ``linear_metrics`` on each block's prepared
(coarser) grid (only |det|² depends on c_f), then again on the final grid refined
around the poles with that c_f (``resolve_on_final_grid``); the metrics are one
linear evaluation with c_f.  Its grid error is up to ~1e-3 on lightly damped
designs (the exact path is the limit of its refinement).  Friction then
dissipates E[F_f v] = c_f σ_v², included in ``dissipated_power_W`` so the
efficiency is the generator's share, as in the time-domain path.

Sticking: with a strong Coulomb friction v is not Gaussian (excess mass near
v = 0), E[F_C sgn(v) v] = F_C E|v| falls below F_C σ√(2/π) and the Gaussian c_f
is too high.  By default the Gaussian fixed point is then corrected by the
energy-envelope (stochastic-averaging) density of the strut's amplitude
(:mod:`ehsa_opt.vehicle.fast_path.sticking`), whose two modal constants come from the
linear path's σ_v(0) and σ_v(c_f) (secant), iterated; it equals the Gaussian value
for weak or viscous friction.

Residual force: what the linearisation drops, r = F_f(v) − c_f v, is added back as
a random force between body and wheel whose autocovariance follows from the
Gaussian closure (:mod:`ehsa_opt.vehicle.fast_path.residual_force`; ``residual=True``).

Validity: the linearisation assumes a Gaussian v; where Coulomb friction makes
the strut stick for long stretches (slow, smooth roads, high F_C) the true v is
far from Gaussian and errors grow — ``validation/friction_fast_path.py``
measures them against :func:`ehsa_opt.vehicle.simulate.simulate_quarter_car`.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import CubicSpline

from ...physics.params import (FRICTION_NAMES, FrictionParams, HarvesterParams, ParameterError,
                               RoadParams, VehicleParams)
from ..frequency_path import G, design_arrays, dimensionless_power, linear_metrics
from ..road import ROAD_BAND_CYCLES_PER_M, dissipation_bound_W, road_velocity_psd
from .band_variances import QuarterCarPolynomials
from .fixed_point import illinois_update, model_fixed_point
from .residual_force import residual_variances
from .sticking import amplitude_terms, averaged_damping

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


def _coulomb_term_quadrature(sigma: np.ndarray, u_c: np.ndarray) -> np.ndarray:
    """E[u tanh(u/u_c)] / σ² for u ~ N(0, σ²) by quadrature (arrays broadcast together)."""
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


# E[u tanh(u/u_c)]/σ² = G(ρ)/σ with ρ = u_c/σ and G(ρ) = E[t tanh(t/ρ)], t ~ N(0, 1):
# a cubic spline of G in ln ρ on [−10, 10] (step 0.01: relative error < 1e-10 against the
# quadrature), and its series outside: G = √(2/π) − κ ρ² (κ = 0.328117, fitted on the
# quadrature at ρ = e^-10: the next term is O(ρ⁴)) and G = 1/ρ − 1/ρ³ (tanh x = x − x³/3).
_LN_RHO = np.arange(-10.0, 10.0 + 1e-9, 0.01)
_G_SPLINE = CubicSpline(_LN_RHO, _coulomb_term_quadrature(np.ones(_LN_RHO.size),
                                                          np.exp(_LN_RHO)))
_KAPPA = (_SQRT_2_PI - float(_G_SPLINE(-10.0))) * math.exp(20.0)
_G_PIECES = np.ascontiguousarray(_G_SPLINE.c.T)   # (pieces, 4) cubic coefficients
_G_STEP = 0.01


def _g_of_ln_rho(lr: np.ndarray) -> np.ndarray:
    """The spline at ``lr`` in [−10, 10] (uniform knots: the piece index is computed)."""
    u = (lr - _LN_RHO[0]) / _G_STEP
    i = np.clip(u.astype(np.intp), 0, _G_PIECES.shape[0] - 1)
    t = lr - _LN_RHO[i]
    c = _G_PIECES[i]
    return ((c[..., 0] * t + c[..., 1]) * t + c[..., 2]) * t + c[..., 3]


def _coulomb_term(sigma: np.ndarray, u_c: np.ndarray) -> np.ndarray:
    """E[u tanh(u/u_c)] / σ² for u ~ N(0, σ²) (arrays broadcast together)."""
    sigma, u_c = np.broadcast_arrays(np.maximum(sigma, 1e-300), u_c)
    with np.errstate(divide="ignore"):
        lr = np.log(u_c / sigma)
    g = _g_of_ln_rho(np.clip(lr, _LN_RHO[0], _LN_RHO[-1]))
    lo, hi = lr < _LN_RHO[0], lr > _LN_RHO[-1]
    if np.any(lo):
        g = np.where(lo, _SQRT_2_PI - _KAPPA * np.exp(2.0 * np.minimum(lr, 0.0)), g)
    if np.any(hi):
        inv = np.exp(-np.maximum(lr, 0.0))
        g = np.where(hi, inv - inv ** 3, g)
    return g / sigma


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


class _LawTerms:
    """:func:`friction_equivalent_damping_Ns_per_m` with the per-design constants of
    both laws precomputed (the same formulas; for the many calls of the fixed point).

    Parameters
    ----------
    fr : ndarray (n, 8)
        Friction sets in :data:`FRICTION_NAMES` order.
    r : ndarray (n,)
        r = lead/2π, m/rad.
    """

    def __init__(self, fr: np.ndarray, r: np.ndarray) -> None:
        self.r = r
        self.laws = []
        for k, scale in ((0, 1.0), (4, r ** -2)):   # nut at v; bearing at v/r, seen as /r²
            brk, cou, ubrk, fv = (fr[:, k + j] for j in range(4))
            u_st = math.sqrt(2.0) * ubrk
            with np.errstate(divide="ignore", invalid="ignore"):
                self.laws.append((fv * scale, _SQRT_2E * (brk - cou) / u_st * scale,
                                  2.0 / u_st ** 2, cou * scale, ubrk / 10.0))

    def __call__(self, sigma: np.ndarray, rows: np.ndarray) -> np.ndarray:
        out = np.zeros(rows.size)
        for i, (fv, strib, inv_st2, cou, u_c) in enumerate(self.laws):
            s = sigma if i == 0 else sigma / self.r[rows]
            c = cou[rows]
            out += fv[rows] + strib[rows] * (1.0 + inv_st2[rows] * s * s) ** -1.5
            out += np.where(c > 0.0, c * _coulomb_term(s, u_c[rows]), 0.0)
        return out


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


def _energy_envelope(s0: np.ndarray, sc: np.ndarray, c: np.ndarray, fr: np.ndarray,
                     r: np.ndarray, terms: tuple, sigma_v_of: Any, rows: np.ndarray,
                     n_iter: int, tol: float) -> np.ndarray:
    """The energy-envelope correction of the friction damping ``c`` (per design row,
    updated in place and returned): secant (c, σ_c) of the linear path, iterated until
    c moves by less than 10·``tol`` (relative) or ``n_iter`` times.  ``sc`` (σ_v at c)
    is updated in place; ``sigma_v_of(c, rows)`` is the linear path."""
    vt, dt, pt = terms
    todo = np.arange(c.size)
    for _ in range(n_iter):
        cn = averaged_damping(s0[todo], sc[todo], c[todo], fr[todo], r[todo],
                              terms=(vt[todo], dt[todo], pt[todo]))
        moved = np.abs(cn - c[todo]) > 10.0 * tol * np.abs(c[todo])
        c[todo] = cn
        todo = todo[moved]
        if todo.size == 0:
            break
        sc[todo] = sigma_v_of(c[todo], rows[todo])
    return c


def friction_metrics(vehicle: VehicleParams, road: RoadParams,
                     design: Mapping[str, ArrayLike] | None = None,
                     friction: Any = None, *, n_freq: int = 256,
                     base: HarvesterParams | None = None, rtol: float = 1e-6,
                     max_iter: int = 60, iteration_n_freq: int = 64,
                     non_gaussian: bool = True, averaging_iter: int = 8,
                     residual: bool = True,
                     resolve_on_final_grid: bool = True, method: str = "exact"
                     ) -> dict[str, np.ndarray]:
    """Metrics of the quarter car with friction by equivalent linearisation.

    Parameters
    ----------
    vehicle, road, design, n_freq, base
        As :func:`ehsa_opt.vehicle.frequency_path.linear_metrics`.
    friction : FrictionParams, sequence of them, or array (..., 8), optional
        Broadcast against the design's shape (the last axis holds the eight
        values); None is frictionless (the linear path exactly).
    rtol : float
        Tolerance on log σ_v of the fixed point.
    max_iter : int
        Iteration limit (model-secant steps of the "exact" method, Illinois steps of
        the "quadrature" one).
    iteration_n_freq : int
        Shared grid points while iterating (the fixed point c_f is then evaluated
        exactly by ``linear_metrics`` at ``n_freq`` on a grid refined around the
        poles with c_f).
    non_gaussian : bool
        Correct the Gaussian c_f for the non-Gaussian (sticking) velocity by the
        energy-envelope density of :mod:`ehsa_opt.vehicle.fast_path.sticking` (default);
        False gives the plain Gaussian equivalent linearisation.
    resolve_on_final_grid : bool
        Solve the fixed point a second time on the final grid (default), refined
        around the poles with the first c_f, and report the metrics there; False: one
        fixed point on the coarse grid refined around the frictionless poles, which
        is not grid-converged for weakly damped designs (tens of % on power).
    residual : bool
        Add the response to the friction's non-linear residual force r = F_f(v) − c_f v
        under Gaussian closure (:mod:`ehsa_opt.vehicle.fast_path.residual_force`; default): it
        raises comfort, road holding and power where Coulomb friction dominates the
        damper (class B at 30 km/h with the friction × 2: comfort −6.6 % → −4.4 % against
        the time domain) and adds about a third to the cost.  ``method="exact"`` only (the
        quadrature path, also the fallback for designs with repeated poles, omits it).
    averaging_iter : int
        Iteration limit of that correction (secant update of the mode's linear
        damping; stops when c_f changes by < 10·rtol).
    method : {"exact", "quadrature"}
        How the variances of the linearised quarter car are integrated over the
        road band: "exact" (default) in closed form by residues
        (:mod:`ehsa_opt.vehicle.fast_path.band_variances`; no frequency grid, so ``n_freq``,
        ``iteration_n_freq`` and ``resolve_on_final_grid`` play no part; designs
        whose poles are not simple fall back to "quadrature"), or "quadrature"
        (the frequency grid of ``linear_metrics``, as before).

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
    if method not in ("exact", "quadrature"):
        raise ParameterError(f"friction_metrics: method must be 'exact' or 'quadrature', got "
                             f"{method!r}")
    exact = method == "exact"
    tol = [max(rtol, 1e-3) if resolve_on_final_grid and not exact else rtol]

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
                xn = (a[todo] * gb[todo] - b[todo] * ga[todo]) / (gb[todo] - ga[todo])
                gn = g(todo, xn)
                it[todo] += 1
                x[todo] = xn
                illinois_update(a, b, ga, gb, side, todo, xn, gn)
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
            # amplitude nodes and cycle averages once, on the Gaussian σ_v's scale
            vt, dt, pt = amplitude_terms(np.minimum(sc, s0), fr[gi], r[gi])
            prev = np.flatnonzero(np.isfinite(hint_c[gi]))
            if prev.size:  # second pass: start from the first pass's corrected c_f
                c[prev] = hint_c[gi[prev]]
                sc[prev] = sigma_v_of(c[prev], act[prev])
            c = _energy_envelope(s0, sc, c, fr[gi], r[gi], (vt, dt, pt), sigma_v_of, act,
                                 averaging_iter, tol[0])
            cf[act] = c
            hint_c[gi] = c
        return cf

    if exact:
        m, cf, bad = _exact_pass(vehicle, road, d, shape, fr, r, has_f, rtol, max_iter,
                                 non_gaussian, averaging_iter, (c_gauss, iters, conv),
                                 residual)
        if bad.size:  # poles not simple (or not polished): these designs by quadrature
            sub = {k: np.broadcast_to(v, shape).reshape(-1)[bad] for k, v in full.items()}
            q = friction_metrics(vehicle, road, sub, fr[bad], n_freq=n_freq, base=base,
                                 rtol=rtol, max_iter=max_iter,
                                 iteration_n_freq=iteration_n_freq, non_gaussian=non_gaussian,
                                 averaging_iter=averaging_iter,
                                 resolve_on_final_grid=resolve_on_final_grid,
                                 method="quadrature")
            for k in m:   # (the quadrature path has no residual force)
                m[k][bad] = q.get(k, 0.0)
            cf[bad] = q["friction_damping_Ns_per_m"]
            c_gauss[bad] = q["friction_damping_gaussian_Ns_per_m"]
            iters[bad] = q["iterations"]
            conv[bad] = q["converged"] == 1.0
        return _finish(m, cf, c_gauss, iters, conv, shape)
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
    return _finish(m, cf, c_gauss, iters, conv, shape)


def _finish(m: dict[str, np.ndarray], cf: np.ndarray, c_gauss: np.ndarray, iters: np.ndarray,
            conv: np.ndarray, shape: tuple[int, ...]) -> dict[str, np.ndarray]:
    m = dict(m)
    m["friction_power_W"] = (cf * m["stroke_velocity_rms_m_s"] ** 2
                             + m.pop("friction_residual_power_W", 0.0))
    m["friction_damping_gaussian_Ns_per_m"] = c_gauss
    m["iterations"] = iters
    m["converged"] = conv.astype(float)
    return {k: np.asarray(v).reshape(shape) for k, v in m.items()}


def _exact_pass(vehicle: VehicleParams, road: RoadParams, d: Mapping[str, np.ndarray],
                shape: tuple[int, ...], fr: np.ndarray, r: np.ndarray, has_f: np.ndarray,
                rtol: float, max_iter: int, non_gaussian: bool, averaging_iter: int,
                record: tuple[np.ndarray, np.ndarray, np.ndarray], residual: bool = True
                ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """The fixed point and the metrics with exact (residue) variances.

    ``record`` = (c_gauss, iterations, converged) flat arrays, filled in place.
    Returns the flat metrics (keys of ``linear_metrics``), c_f (N s/m) and the flat
    indices of the designs the residue formula does not cover (to redo by quadrature).
    """
    if road.profile_csv is not None:
        raise ValueError("friction_metrics needs an ISO 8608 road (a PSD); a measured "
                         "profile has none: use the time-domain simulation")
    v = road.speed_m_per_s
    flat = {k: np.broadcast_to(a, shape).reshape(-1) for k, a in d.items()}
    qp = QuarterCarPolynomials(vehicle, flat, ROAD_BAND_CYCLES_PER_M[0] * v,
                               ROAD_BAND_CYCLES_PER_M[1] * v, road_velocity_psd(road))
    n = qp.n
    every = np.arange(n)
    # frictionless poles, tracked as c_f changes, and Q'(λ) there, carried along
    lam, dq = qp.roots(qp.q0, return_dq=True)
    c_lam = np.zeros(n)             # the damping of the poles in lam
    sigma0 = np.sqrt(np.maximum(qp.var_v(c_lam, every, lam, dq), 0.0))

    def sigma_v_of(c: np.ndarray, rows: np.ndarray) -> np.ndarray:
        c = np.asarray(c, dtype=float)
        lam[rows], dq[rows] = qp.follow(c, rows, lam[rows], c_lam[rows], dq[rows],
                                        return_dq=True)
        c_lam[rows] = c
        return np.sqrt(np.maximum(qp.var_v(c, rows, lam[rows], dq[rows]), 0.0))

    laws = _LawTerms(fr, r)

    def cf_of(sigma: np.ndarray, rows: np.ndarray) -> np.ndarray:
        return laws(sigma, rows)

    # an undamped frictionless design (open circuit: poles on the imaginary axis) has no
    # finite σ_v(0) to start from: left to the quadrature path
    ok0 = np.isfinite(sigma0) & (sigma0 > 0.0) & np.all(lam.real < 0.0, axis=1)
    c_gauss, iters, conv = record
    cf = np.zeros(n)
    act = np.flatnonzero(has_f & ok0)
    if act.size:
        x, c, it, ok = model_fixed_point(np.log(sigma0[act]), act, sigma_v_of, cf_of, rtol,
                                          max_iter)
        cf[act], c_gauss[act], iters[act], conv[act] = c, c, it, ok
        if non_gaussian:  # energy-envelope correction: secant (c, σ_c) of the linear path
            s0, sc = sigma0[act], np.exp(x)
            terms = amplitude_terms(np.minimum(sc, s0), fr[act], r[act])
            cf[act] = _energy_envelope(s0, sc, c, fr[act], r[act], terms, sigma_v_of, act,
                                       averaging_iter, rtol)
    # metrics at the damping the tracked poles belong to where that is within the
    # correction's own stopping tolerance of c_f (its last step moved c_f by less):
    # c_f is then that damping, consistent with the poles; the others are tracked to c_f
    near = np.abs(cf - c_lam) <= 10.0 * rtol * np.abs(cf)
    cf = np.where(near, c_lam, cf)
    far = np.flatnonzero(~near)
    if far.size:
        lam[far] = qp.follow(cf[far], far, lam[far], c_lam[far], dq[far])
    ok = qp.check(qp.q(cf, every), lam)
    var = qp.variances(cf, every, lam)
    p_res = np.zeros(n)
    if residual and act.size:  # the non-linear residual force, Gaussian closure
        rows = act[np.isfinite(var["var_v"][act]) & (var["var_v"][act] > 0.0) & ok[act]]
        add = residual_variances(qp, rows, lam[rows], cf[rows], np.sqrt(var["var_v"][rows]),
                                 fr[rows])
        var["var_acc_w"][rows] += add["var_acc_w"]
        var["var_tyre"][rows] += add["var_tyre"]
        var["var_v"][rows] += add["var_v"]
        var["p_load"][rows] += qp.Re[rows] * add["var_i"]
        p_res[rows] = add["p_residual"]      # E[r v]: the residual's share of the friction's
        var["p_diss"][rows] += (qp.kt_over_ke[rows] * np.where(qp.open[rows], 0.0, qp.R[rows])
                                * add["var_i"] + cf[rows] * add["var_v"] + p_res[rows])
    g = G
    acc = np.sqrt(np.maximum(var["var_acc_w"], 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        eff = np.where(var["p_diss"] > 0.0, var["p_load"] / var["p_diss"], 0.0)
    m = {"comfort": acc / g, "comfort_weighted_rms_m_s2": acc,
         "road_holding": vehicle.tyre_stiffness_N_per_m * np.sqrt(np.maximum(var["var_tyre"], 0.0))
         / (g * vehicle.total_mass_kg),
         "power_W": var["p_load"],
         "power_dimensionless": dimensionless_power(var["p_load"], vehicle, v),
         "efficiency": eff, "dissipated_power_W": var["p_diss"],
         "dissipation_bound_W": np.full(n, dissipation_bound_W(vehicle, road)),
         "stroke_velocity_rms_m_s": np.sqrt(np.maximum(var["var_v"], 0.0)),
         "friction_damping_Ns_per_m": cf, "friction_residual_power_W": p_res}
    bad = np.flatnonzero(~(ok & ok0 & np.all([np.isfinite(a) for a in m.values()], axis=0)))
    return m, cf, bad
