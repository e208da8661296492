"""The friction's non-linear residual force under Gaussian closure (issue 14).

Why: equivalent linearisation (:mod:`ehsa_opt.vehicle.equivalent`) keeps the part
of the friction force F_f(v) that is correlated with the stroke velocity (c v) and
drops the rest, r = F_f(v) − c v.  Where Coulomb friction dominates the damper
(slow, smooth roads, high friction) F_f is nearly a square wave of v and r is large
(on the prototype at class B, 30 km/h, friction × 2: rms 89 N against a c_f σ_v of
120 N) and broadband — its odd harmonics of the 1–8 Hz stroke motion fall where
the ISO 2631 weighting W_k is highest.  Added to the linear system as a force
between body and wheel, the *exact* time-domain residual reproduces the time
domain's weighted body acceleration to 1e-4; dropping it under-predicts comfort by
7 % there.

Method (Gaussian closure; Kazakov, Atalik & Utku 1976; Roberts & Spanos): for a
stationary Gaussian v with correlation ρ(τ) = R_v(τ)/σ_v², the autocovariance of
the friction force F(v) depends on ρ alone, and for the Simscape law (Coulomb as a
sign, viscous, the Stribeck hump x e^{−x²}) it is a sum of closed-form Gaussian
integrals: the arcsine law (2/π) arcsin ρ of the Coulomb part and algebraic terms
for the others (:func:`residual_autocovariance`).  The residual left by the
linearisation (β_1 = E[F(σX) X] = c σ, the Gaussian c) has

    R_r(ρ) = R_F(ρ) − β_1² ρ       (no ρ¹ term: r is uncorrelated with v).

By Bussgang's theorem r is uncorrelated with v and with the road at every lag, so
its response adds to the linear one: for each output y (weighted body
acceleration, tyre deflection, current, stroke velocity)

    Δvar_y = ∫ R_r(τ) k_y(τ) dτ,   k_y(τ) = Σ_k res_k[H_y(s) H_y(−s)] e^{λ_k |τ|},

with H_y = N_y/Q the linearised quarter car's response to a force pair between
body and wheel (added to the damper's force; same Q(s) and poles λ_k as
:mod:`ehsa_opt.vehicle.residues`, plus W_k's poles for comfort), and
ρ(τ) = R_v(τ)/R_v(0), R_v(τ) = Σ_k res_k[...] e^{λ_k|τ|} of the road-to-v response
(white road velocity).  So only the Laplace transforms L_k = ∫₀^∞ R_r(τ) e^{λ_k τ} dτ
are needed: R_r piecewise linear on a nearly geometric lag grid (:data:`TAU_S`), the
exponential integrated exactly (any damping, no frequency grid).  The residual's
own dissipation is E[r v] = Σ_k Res[H_v]_k L_k (negative: a force uncorrelated with
v feeds the motion it drives), so the friction's mean power is c_f σ_v² + E[r v].

Checked: at class B, 30 km/h, friction × 2 (prototype, 2000 m) the closure adds
0.0111 (m/s²)² of weighted body acceleration (comfort against the time domain
−7.2 % → −5.2 %), σ_v 0.0675 → 0.0690 m/s (time domain 0.0697), power 2.209 →
2.308 W (2.354 W), the friction's power c_f σ_v² + E[r v] 8.01 → 7.89 W (time domain
E[F v] 7.90 W), and the total dissipation stays the linear system's (the
dissipation bound of SPEC §4: the road's input power does not depend on an internal
force).  What it does not
capture: the non-Gaussian part (long stick phases), ``benchmarks/friction_fast_path.py``
measures the rest.  Cost: about a third of the fast path's (4000 designs: ~0.05 s).
"""

from __future__ import annotations

import math

import numpy as np

from .residues import (_WK_DEN, _WK_INV_DDEN, _WK_INV_DEN_NEG, _WK_NUM, _WK_POLES,
                       QuarterCarPolynomials, _peval, _pder, _pmul)

__all__ = ["residual_autocovariance", "residual_variances", "TAU_S"]

_SQRT_2_PI = math.sqrt(2.0 / math.pi)
# Lags of the closure's integrals: 0, then octaves [T_k, 2 T_k), T_k = 10 µs · 2^k, each
# cut into _SUB equal steps (nearly geometric: ≤ 25 % per step), up to 10 µs · 2^22 = 42 s.
# Equal steps within an octave and doubling octaves make e^{λτ} a chain of products:
# e^{λ(T_k + i h_k)} = e^{λ T_k} w_k^i with w_k = e^{λ h_k}, w_{k+1} = w_k² (no exp per lag).
_T0, _OCTAVES, _SUB = 1e-5, 22, 4
#: The lags, s.
TAU_S = np.concatenate([[0.0], (_T0 * 2.0 ** np.arange(_OCTAVES)[:, None]
                                * (1.0 + np.arange(_SUB)[None, :] / _SUB)).ravel(),
                        [_T0 * 2.0 ** _OCTAVES]])
_H_TAU = np.diff(TAU_S)
_E_WK = np.exp(_WK_POLES[:, None] * TAU_S[None, :]).T    # W_k's poles, shared, (M+1, 6)


def _law_terms(sigma: np.ndarray, fr: np.ndarray, r: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The rod friction at v = σX as A sgn X + V X + Σ_i S_i X e^{−a_i X²}.

    Returns A (N: Coulomb levels, nut + bearing/r), V (N: viscous f_v σ), S (N, (n, 2):
    Stribeck amplitudes √(2e) ΔF σ/u_St) and a ((n, 2): σ²/u_St²), u_St = √2 u_brk, for
    nut and bearing (seen at the rod: torque/r at ω = v/r)."""
    nut = tuple(fr[:, j] for j in range(4))
    brg = (fr[:, 4] / r, fr[:, 5] / r, fr[:, 6] * r, fr[:, 7] / r ** 2)
    A, V = nut[1] + brg[1], (nut[3] + brg[3]) * sigma
    S, a = np.zeros((sigma.size, 2)), np.zeros((sigma.size, 2))
    for i, (brk, cou, ubrk, _) in enumerate((nut, brg)):
        u_st = math.sqrt(2.0) * ubrk
        x = np.divide(sigma, u_st, out=np.zeros(sigma.size), where=u_st > 0.0)
        S[:, i] = math.sqrt(2.0 * math.e) * (brk - cou) * x
        a[:, i] = x * x
    return A, V, S, a


def residual_autocovariance(rho: np.ndarray, sigma: np.ndarray, fr: np.ndarray,
                            r: np.ndarray) -> np.ndarray:
    """R_r(ρ) = E[F(v₁) F(v₂)] − β_1² ρ, N², of the rod friction for Gaussian v₁, v₂ of
    rms σ and correlation ρ (β_1 = E[F(σX) X], so R_r has no ρ¹ term).

    Closed form for F(σX) = A sgn X + V X + Σ_i S_i X e^{−a_i X²} (the Simscape law
    with its tanh smoothing u_brk/10 taken as a sign: an O((u_brk/10σ)²) error)::

        E[sgn X₁ sgn X₂]                   = (2/π) arcsin ρ
        E[sgn X₁ X₂ e^{−b X₂²}]           = √(2/π) ρ / ((1+2b) √((1+2b)(1−ρ²) + ρ²))
        E[X₁ e^{−a X₁²} X₂ e^{−b X₂²}]   = ρ / (1 + 2(a+b) + 4ab(1−ρ²))^{3/2}

    (Gaussian integrals; b = 0 gives the viscous terms).

    Parameters
    ----------
    rho : ndarray (n, m)
        Correlation coefficients of v at the lags of interest, in [−1, 1].
    sigma : ndarray (n,)
        rms stroke velocity, m/s.
    fr : ndarray (n, 8)
        Friction sets (:data:`~ehsa_opt.physics.params.FRICTION_NAMES` order).
    r : ndarray (n,)
        Lead / 2π, m/rad.
    """
    sigma = np.asarray(sigma, dtype=float)
    A, V, S, a = _law_terms(sigma, fr, r)
    rho = np.clip(rho, -1.0, 1.0)
    rho2 = rho * rho
    one = 1.0 - rho2
    b = 1.0 + 2.0 * a
    strib = np.sum(S / (b * np.sqrt(b)), axis=1)          # E[Σ S_i X² e^{−a_i X²}]
    beta1 = A * _SQRT_2_PI + V + strib
    lin = 2.0 * A * V * _SQRT_2_PI + V * V + 2.0 * V * strib
    # the Stribeck terms with their largest value (at ρ = 1); a term below 1e-3 of the
    # Coulomb part's for every design is dropped (e.g. the bearing's narrow hump squared)
    terms = []
    for i in range(2):     # Coulomb × Stribeck_i, both orders
        c = 2.0 * S[:, i] * A * _SQRT_2_PI / b[:, i]
        terms.append((np.abs(c), c, b[:, i], None))
    for i in range(2):     # Stribeck_i × Stribeck_j
        for j in range(i, 2):
            w = (1.0 if i == j else 2.0) * S[:, i] * S[:, j]
            q0 = 1.0 + 2.0 * (a[:, i] + a[:, j])
            terms.append((np.abs(w) / q0 ** 1.5, w, q0, 4.0 * a[:, i] * a[:, j]))
    scale = A * A + V * V + sum(t[0] for t in terms)
    inner = np.broadcast_to((lin - beta1 * beta1)[:, None], rho.shape).copy()
    for size, coef, b0, b1 in terms:
        if np.all(size <= 1e-3 * scale):
            continue
        if b1 is None:      # c / √(b (1 − ρ²) + ρ²)
            inner += coef[:, None] / np.sqrt(b0[:, None] * one + rho2)
        else:               # w / q^{3/2}, q = q0 + 4 a_i a_j (1 − ρ²)
            q = b0[:, None] + b1[:, None] * one
            inner += coef[:, None] / (q * np.sqrt(q))
    return (A * A * (2.0 / math.pi))[:, None] * np.arcsin(rho) + inner * rho


def _slope_jumps(R: np.ndarray) -> np.ndarray:
    """d_j of R piecewise linear on TAU_S: −s_0, s_{j−1} − s_j, s_{M−1} (s the slopes)."""
    s = np.diff(R, axis=1) / _H_TAU
    d = np.empty_like(R)
    d[:, 0] = -s[:, 0]
    d[:, 1:-1] = s[:, :-1] - s[:, 1:]
    d[:, -1] = s[:, -1]
    return d


def _laplace(R: np.ndarray, d: np.ndarray, dE: np.ndarray, e_end: np.ndarray,
             lam: np.ndarray) -> np.ndarray:
    """∫_0^τmax R(τ) e^{λτ} dτ for R piecewise linear on TAU_S, exact in the exponential:
    per cell the integral of (R_j + s_j (τ − τ_j)) e^{λτ} telescopes to
    (R_M E_M − R_0)/λ − Σ_j d_j E_j / λ² (``dE`` = Σ_j d_j E_j, ``e_end`` = E_M)."""
    return (R[:, -1:] * e_end - R[:, :1]) / lam - dE / (lam * lam)


def _chain(lam: np.ndarray):
    """e^{λ τ_j} for the lags j = 1 … M of :data:`TAU_S`, one (n, k) array at a time, by
    products (see ``_OCTAVES``): nothing of size lags × designs × poles is stored."""
    e = np.exp(lam * _T0)
    w = np.exp(lam * (_T0 / _SUB))
    with np.errstate(under="ignore"):
        for _ in range(_OCTAVES):
            for _ in range(_SUB):
                yield e
                e = e * w
            w = w * w
    yield e


def residual_variances(qp: QuarterCarPolynomials, rows: np.ndarray, lam: np.ndarray,
                       c_f: np.ndarray, sigma_v: np.ndarray, fr: np.ndarray
                       ) -> dict[str, np.ndarray]:
    """Variances the residual force adds to the linearised quarter car's outputs.

    Parameters
    ----------
    qp : QuarterCarPolynomials
        The linear quarter car (its Q(s), masses, stiffnesses, electrical constants).
    rows : ndarray (n,)
        The designs of ``qp`` to evaluate.
    lam : ndarray (n, 5)
        Their poles with damping ``c_f`` (simple, left half-plane).
    c_f : ndarray (n,)
        The friction's equivalent damping in the linear system, N s/m.
    sigma_v : ndarray (n,)
        rms stroke velocity of that linear system, m/s (the closure's scale).
    fr : ndarray (n, 8)
        Friction sets.

    Returns
    -------
    dict of ndarray (n,)
        ``var_acc_w`` ((m/s²)², W_k-weighted body acceleration), ``var_tyre`` (m²),
        ``var_i`` (A²), ``var_v`` ((m/s)²), ``p_residual`` (W: E[r v], the residual's
        share of the friction's dissipation; negative — a force uncorrelated with v
        feeds the motion it drives).
    """
    m1, m2, k1 = qp.m1, qp.m2, qp.k1
    qc = qp.q(c_f, rows)
    rl = qp.rl[rows]
    n = rows.size
    inv_dq = 1.0 / _peval(_pder(qc), lam)
    inv_qn = 1.0 / _peval(qc, -lam)
    # numerators for a force pair r between body and wheel (r adds to the damper force)
    nv0 = np.broadcast_to(np.array([0.0, -k1, 0.0, -(m1 + m2)]), (n, 4))
    n_v = _pmul(nv0, rl)                                          # stroke velocity
    n_a = _pmul(np.broadcast_to(np.array([0.0, 0.0, -k1, 0.0, -m1]), (n, 5)), rl)
    n_x1 = _pmul(np.broadcast_to(np.array([0.0, 0.0, m2]), (n, 3)), rl)   # tyre deflection
    n_i = nv0 * np.where(qp.open[rows], 0.0, qp.cur_gain[rows] / (k1 * m2))[:, None]
    n_road = _pmul(np.broadcast_to(np.array([0.0, 0.0, k1 * m2]), (n, 3)), rl)

    def kernel(num: np.ndarray) -> np.ndarray:  # residues of N(s)N(−s)/(Q(s)Q(−s))
        return _peval(num, lam) * _peval(num, -lam) * inv_dq * inv_qn

    a = kernel(n_road)
    rv = np.empty((TAU_S.size, n))                 # R_v(τ_j) ∝ Re Σ_k a_k e^{λ_k τ_j}
    lam_t, a_t = np.ascontiguousarray(lam.T), np.ascontiguousarray(a.T)   # (poles, n)
    rv[0] = np.real(np.sum(a_t, axis=0))
    for j, e in enumerate(_chain(lam_t), start=1):
        np.sum((a_t * e).real, axis=0, out=rv[j])
    rv = rv.T
    rho = rv / np.where(rv[:, :1] > 0.0, rv[:, :1], 1.0)
    R = residual_autocovariance(rho, sigma_v, fr, qp.r_m_per_rad[rows])
    d = _slope_jumps(R)
    dT = np.ascontiguousarray(d.T)
    dE = dT[0] + np.zeros(lam_t.shape, dtype=complex)
    for j, e in enumerate(_chain(lam_t), start=1):
        dE += dT[j] * e
    dE, e = dE.T, e.T
    L = _laplace(R, d, dE, e, lam)
    out = {"var_v": kernel(n_v), "var_tyre": kernel(n_x1), "var_i": kernel(n_i)}
    out = {k: 2.0 * np.real(np.sum(h * L, axis=1)) for k, h in out.items()}
    # comfort: (W_k ẍ2)(s) = N_a(s) Wn(s) / (Q(s) Wd(s)): poles of Q and of W_k
    wn_l, wd_l = _peval(_WK_NUM, lam), _peval(_WK_DEN, lam)
    wn_n, wd_n = _peval(_WK_NUM, -lam), _peval(_WK_DEN, -lam)
    h_q = kernel(n_a) * wn_l * wn_n / (wd_l * wd_n)
    wp = np.broadcast_to(_WK_POLES, (n, _WK_POLES.size))
    h_w = (_peval(n_a, wp) * _peval(n_a, -wp) / (_peval(qc, wp) * _peval(qc, -wp))
           * _peval(_WK_NUM, wp) * _peval(_WK_NUM, -wp) * _WK_INV_DDEN * _WK_INV_DEN_NEG)
    L_w = _laplace(R, d, d @ _E_WK, _E_WK[-1], _WK_POLES)
    out["var_acc_w"] = 2.0 * np.real(np.sum(h_q * L, axis=1) + np.sum(h_w * L_w, axis=1))
    out["p_residual"] = np.real(np.sum(_peval(n_v, lam) * inv_dq * L, axis=1))
    return out

