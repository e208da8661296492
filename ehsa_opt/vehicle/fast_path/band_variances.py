"""Exact band-limited variances of the linear quarter car by residues.

Why: the friction-aware fast path (:mod:`ehsa_opt.vehicle.fast_path.linearisation`) needs the
stroke-velocity variance σ_v²(c) many times while it iterates on the friction's
equivalent damping c, then the metrics at the fixed point.  A quadrature over a
few hundred frequencies per design costs far more than the 2-DOF system's five
poles carry; this module integrates the rational spectra in closed form.

Method.  With the harvester's impedance (paper Eqs 1–3, as in
:func:`ehsa_opt.vehicle.frequency_path.linear_metrics`) and an extra viscous damping c
between the masses, every output y (stroke velocity, sprung acceleration, tyre
deflection, current) is y/V0 = H(s) = N(s)/Q(s) with the road velocity V0 as
input and the degree-5 polynomial (D̃ = (k2 + c s + m_eq s²)(R + L s) + s K_t K_e/r²)::

    Q(s) = D̃(s) ((m1 + m2) s² + k1) + (R + L s) m2 s² (m1 s² + k1)

(poles: body, wheel, electrical).  Numerators: v: k1 m2 s² (R + L s); ẍ2:
k1 s D̃; i: (K_e/r) k1 m2 s²; x1 − x0: [k1 (D̃ + m2 s² (R + L s)) − Q]/s; the
comfort output is ẍ2 times the exact rational W_k(s) (order 8, ISO 2631-1,
:func:`ehsa_opt.vehicle.iso2631.wk_exact_tf`).  For a strictly proper H with simple
poles λ_k and residues r_k, H(s) H(−s) = Σ_k r_k H(−λ_k) [1/(s − λ_k) + 1/(−s − λ_k)],
so on s = jω, with μ_k = −λ_k (Re μ_k > 0)::

    ∫_{ωa}^{ωb} |H(jω)|² dω = Σ_k r_k H(−λ_k) · 2 [atan(ωb/μ_k) − atan(ωa/μ_k)]

(the complex arctangent is analytic along ω > 0 because Re μ_k > 0).  The
one-sided variance over the road band [f_lo, f_hi] of a white road velocity of
one-sided PSD Φ is then Φ/(2π) times that: exact (no frequency grid), for any
damping, O(poles) per design.  The poles come in closed form: the electrical
root (far out, near −R/L) by Newton steps from the roots' sum −q4/q5, deflated,
the two modes' quartic by Ferrari's formula, all polished by a Newton step on Q
(a batched companion eigenvalue computation only where that fails Vieta's
checks).  When c changes during the fixed-point iteration they are tracked: a
first-order prediction dλ/dc = −(∂Q/∂c)/Q'(λ), then Newton steps.

Validity: the residue formula needs simple poles.  Rows whose poles (with the
W_k poles) nearly coincide (relative gap < 1e-7) or whose polished roots do not
satisfy Q(λ) ≈ 0 are flagged (``ok`` False) so the caller can evaluate them by
quadrature instead.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ...physics.params import VehicleParams
from .polynomials import (WK_AT_POLES, WK_DEN2, WK_NUM2, WK_POLES, at_wk, even_square, padd, pder,
                          peval, peval_d, pmul, rmax, rsum)

__all__ = ["QuarterCarPolynomials"]



# Newton on a simple root converges quadratically: after a relative step s the error is
# about C s² (C = |Q''/2Q'| |λ|, moderate for the simple, separated poles ``check``
# accepts), so a last step below 1e-9 leaves ~1e-18 and the confirming step is skipped
_NEWTON_TOL = 1e-9
_PAIRS = np.triu_indices(5, 1)     # the ten pairs of the five poles



def _band_weights(lam: np.ndarray, wa: float, wb: float) -> np.ndarray:
    """2 [atan(ωb/μ) − atan(ωa/μ)], μ = −λ: ∫_{ωa}^{ωb} |H(jω)|² dω = Σ_k r_k H(−λ_k) × this.

    2 atan(ω/μ) = −j [Log(μ + jω) − Log(μ − jω)] for Re μ > 0 (both in the right
    half-plane, no branch cut), so with μ = x + jy (x > 0) the bracket is, in real
    arithmetic (four real arctangents and one logarithm, no complex one)::

        atan((y+ωb)/x) − atan((y−ωb)/x) − atan((y+ωa)/x) + atan((y−ωa)/x)
        − (j/2) ln(|μ + jωb|² |μ − jωa|² / (|μ − jωb|² |μ + jωa|²))
    """
    x, y = -lam.real, -lam.imag
    ix = 1.0 / x
    ang = (np.arctan((y + wb) * ix) - np.arctan((y - wb) * ix)
           - np.arctan((y + wa) * ix) + np.arctan((y - wa) * ix))
    x2 = x * x
    mag = np.log(((x2 + (y + wb) ** 2) * (x2 + (y - wa) ** 2))
                 / ((x2 + (y - wb) ** 2) * (x2 + (y + wa) ** 2)))
    return ang - 0.5j * mag


def _band_integral(res_h: np.ndarray, lam: np.ndarray, wa: float, wb: float) -> np.ndarray:
    """Σ_k r_k H(−λ_k) · 2 [atan(ωb/μ_k) − atan(ωa/μ_k)]: ∫ |H(jω)|² dω."""
    return np.real(rsum(res_h * _band_weights(lam, wa, wb)))


def _ferrari_roots(qc: np.ndarray, guess: np.ndarray) -> np.ndarray:
    """Approximate roots (m, 5) of the quintics qc (m, 6): a real root by Newton from
    ``guess`` (m,), deflated, then the quartic's four roots by Ferrari's method."""
    x = guess.astype(float).copy()
    dq = pder(qc)
    for _ in range(30):
        step = peval(qc, x[:, None]).real[:, 0] / peval(dq, x[:, None]).real[:, 0]
        x -= step
        if not np.max(np.abs(step) / np.abs(x)) > 1e-15:
            break
    # deflate Q = (s − x) B from the constant term up (b0 = −q0/x, b_k = (b_{k−1} − q_k)/x):
    # stable for the largest root, which the electrical one is
    b = np.empty((qc.shape[0], 5))
    b[:, 0] = -qc[:, 0] / x
    for j in range(1, 5):
        b[:, j] = (b[:, j - 1] - qc[:, j]) / x
    a3, a2, a1, a0 = (b[:, j] / b[:, 4] for j in (3, 2, 1, 0))
    p = a2 - 3.0 * a3 ** 2 / 8.0
    q = a1 - a3 * a2 / 2.0 + a3 ** 3 / 8.0
    r = a0 - a3 * a1 / 4.0 + a3 ** 2 * a2 / 16.0 - 3.0 * a3 ** 4 / 256.0
    # resolvent cubic m³ + p m² + (p²/4 − r) m − q²/8 = 0, its largest root (Cardano)
    c1, c0 = p ** 2 / 4.0 - r, -q ** 2 / 8.0
    pp = (c1 - p ** 2 / 3.0).astype(complex)
    qq = (2.0 * p ** 3 / 27.0 - p * c1 / 3.0 + c0).astype(complex)
    disc = np.sqrt(qq ** 2 / 4.0 + pp ** 3 / 27.0)
    u = np.where(np.abs(-qq / 2.0 + disc) >= np.abs(-qq / 2.0 - disc), -qq / 2.0 + disc,
                 -qq / 2.0 - disc)
    cc = u ** (1.0 / 3.0)
    best = np.zeros(qc.shape[0], dtype=complex)
    for k in range(3):
        ck = cc * np.exp(2j * math.pi * k / 3.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(ck != 0.0, ck - pp / (3.0 * ck), 0.0)
        mk = t - p / 3.0
        best = np.where(np.abs(mk) > np.abs(best), mk, best)
    sq = np.sqrt(2.0 * best)
    with np.errstate(divide="ignore", invalid="ignore"):
        qm = np.where(best != 0.0, q / best, 0.0)
    out = np.empty((qc.shape[0], 5), dtype=complex)
    out[:, 0] = x
    for i, sg in enumerate((1.0, -1.0)):
        root = np.sqrt(-2.0 * best - 2.0 * p - sg * sq * qm)
        out[:, 1 + 2 * i] = (sg * sq + root) / 2.0 - a3 / 4.0
        out[:, 2 + 2 * i] = (sg * sq - root) / 2.0 - a3 / 4.0
    return out



class QuarterCarPolynomials:
    """The quarter car's transfer functions as polynomials, vectorised over designs.

    Parameters
    ----------
    vehicle : VehicleParams
    design : mapping of 1-D arrays
        Flat SI arrays of :func:`ehsa_opt.vehicle.frequency_path.design_arrays`
        (``J_kgm2, r_m_per_rad, Ke, Kt, L_H, Ri_ohm, Re_ohm``), one entry per design.
    f_lo, f_hi : float
        Integration band, Hz.
    psd : float
        One-sided road-velocity PSD Φ, (m/s)²/Hz.
    """

    def __init__(self, vehicle: VehicleParams, design: Mapping[str, np.ndarray], f_lo: float,
                 f_hi: float, psd: float) -> None:
        m2, m1 = vehicle.sprung_mass_kg, vehicle.unsprung_mass_kg
        k2, k1 = vehicle.suspension_stiffness_N_per_m, vehicle.tyre_stiffness_N_per_m
        self.k1, self.m1, self.m2 = k1, m1, m2
        r, ke, kt = design["r_m_per_rad"], design["Ke"], design["Kt"]
        self.r_m_per_rad = r
        R = design["Ri_ohm"] + design["Re_ohm"]
        self.open = np.isinf(R)
        self.R = np.where(self.open, 1.0, R)
        self.Re = np.where(self.open, 0.0, design["Re_ohm"])
        # L = 0 is allowed: a pole far out of any band stands for it (as in metrics._mode_grid)
        L = np.maximum(design["L_H"], 1e-7)
        self.kt_over_ke = kt / ke
        kk = np.where(self.open, 0.0, kt * ke / r ** 2)
        meq = design["J_kgm2"] / r ** 2
        n = r.size
        self.n = n
        self.wa, self.wb = 2.0 * math.pi * f_lo, 2.0 * math.pi * f_hi
        self.scale = psd / (2.0 * math.pi)
        z = np.zeros(n)
        rl = np.stack([self.R, L], axis=1)                                  # R + L s
        d0 = padd(pmul(np.stack([np.full(n, k2), z, meq], axis=1), rl),
                   np.stack([z, kk], axis=1))                                 # D̃ at c = 0
        d1 = pmul(np.stack([z, np.ones(n)], axis=1), rl)                     # ∂D̃/∂c = s (R + L s)
        p2 = np.array([k1, 0.0, m1 + m2])
        tail = pmul(rl, np.array([0.0, 0.0, m2 * k1, 0.0, m2 * m1]))
        self.q0 = padd(pmul(d0, p2), tail)                                  # Q at c = 0, (n, 6)
        self.q1 = padd(pmul(d1, p2), np.zeros((n, 6)))                     # ∂Q/∂c, (n, 6)
        self.d0, self.d1 = d0, padd(d1, np.zeros((n, 4)))
        self.rl = rl
        self.cur_gain = np.where(self.open, 0.0, ke / r * k1 * m2)
        # s-scale for the companion matrix
        self.w0 = math.sqrt(k1 / m1)

    # ------------------------------------------------------------------ poles
    def q(self, c: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Coefficients of Q for damping ``c`` (N s/m) on ``rows``, (m, 6)."""
        return self.q0[rows] + c[:, None] * self.q1[rows]

    def roots(self, qc: np.ndarray, return_dq: bool = False
              ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The five roots of Q (m, 6), polished by Newton steps (and Q' there, with
        ``return_dq``).

        The electrical root is far out (near −R/L): found by real Newton steps from
        −R/L and deflated; the remaining quartic (body and wheel modes) is solved in
        closed form (Ferrari); all five are then polished on Q itself.  Rows where that
        does not converge to five distinct roots (checked by Vieta's relations) fall
        back to a batched companion eigenvalue computation.
        """
        m = qc.shape[0]
        lam = np.empty((m, 5), dtype=complex)
        dq = np.empty((m, 5), dtype=complex)
        ok = np.zeros(m, dtype=bool)
        if m:
            # the roots' sum −q4/q5 is about the electrical root (the modes' real
            # parts are small beside it)
            lam, ok, dq = self.track(qc, _ferrari_roots(qc, -qc[:, 4] / qc[:, 5]), steps=4)
        bad = np.flatnonzero(~ok)
        if bad.size:
            lam[bad] = self._eig_roots(qc[bad])
            dq[bad] = peval_d(qc[bad], lam[bad])[1]
        return (lam, dq) if return_dq else lam

    def _eig_roots(self, qc: np.ndarray) -> np.ndarray:
        m = qc.shape[0]
        sc = self.w0 ** np.arange(6)
        a = qc * sc
        a = a[:, :5] / a[:, 5:6]
        comp = np.zeros((m, 5, 5))
        comp[:, 1:, :4] = np.eye(4)
        comp[:, :, 4] = -a
        lam = np.linalg.eigvals(comp).astype(complex) * self.w0
        new, done, _ = self.track(qc, lam, steps=1)
        return np.where(done[:, None], new, lam)

    @staticmethod
    def track(qc: np.ndarray, lam: np.ndarray, steps: int = 8
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Newton steps on each root of Q (m, 6) from ``lam`` (m, 5).

        Returns the roots, whether each row converged to five distinct roots (last step
        < ``_NEWTON_TOL`` relative, and the roots' sum and product equal −q4/q5 and
        −q0/q5 (Vieta) to 1e-9, so no root was lost to a neighbour's basin), and Q'
        at the roots (from the last step: relative error about that step's size).
        """
        lam = lam.copy()
        step = np.zeros(lam.shape)
        dq = np.empty(lam.shape, dtype=complex)
        todo = None                     # all rows, then only those still moving
        for _ in range(steps):
            if todo is None:
                p, dq = peval_d(qc, lam)
                corr = p / dq
                lam -= corr
                step = np.abs(corr) / np.maximum(np.abs(lam), 1e-300)
                moving = rmax(step) > _NEWTON_TOL
            else:
                z = lam[todo]
                p, dp = peval_d(qc[todo], z)
                dq[todo] = dp
                corr = p / dp
                lam[todo] = z - corr
                step[todo] = np.abs(corr) / np.maximum(np.abs(lam[todo]), 1e-300)
                moving = np.zeros(lam.shape[0], dtype=bool)
                moving[todo] = rmax(step[todo]) > _NEWTON_TOL
            if not np.any(moving):
                break
            todo = np.flatnonzero(moving)
        lead = qc[:, 5]
        s_ok = np.abs(rsum(lam) + qc[:, 4] / lead) <= 1e-9 * rsum(np.abs(lam))
        with np.errstate(divide="ignore", invalid="ignore"):
            prod = lam[:, 0] * lam[:, 1] * lam[:, 2] * lam[:, 3] * lam[:, 4]
            p_ok = np.abs(prod * lead / -qc[:, 0] - 1.0) <= 1e-9
        return lam, (rmax(step) <= _NEWTON_TOL) & s_ok & p_ok, dq

    def follow(self, c: np.ndarray, rows: np.ndarray, lam: np.ndarray,
               c_old: np.ndarray, dq_old: np.ndarray | None = None,
               return_dq: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Poles for damping ``c`` on ``rows`` tracked from the poles ``lam`` of damping
        ``c_old``: first-order prediction dλ/dc = −∂Q/∂c / Q'(λ), then Newton steps
        (:meth:`roots` afresh where tracking does not converge).

        ``dq_old``: Q'(λ) at the old poles if known (as returned with ``return_dq``,
        which also returns Q' at the new poles, to the last Newton step's accuracy)."""
        qc = self.q(c, rows)
        if dq_old is None:
            dq_old = peval_d(self.q(c_old, rows), lam)[1]
        lam = lam - (c - c_old)[:, None] * (peval(self.q1[rows, :5], lam) / dq_old)
        new, done, dq = self.track(qc, lam, steps=8)
        if not np.all(done):
            bad = np.flatnonzero(~done)
            new[bad] = self.roots(qc[bad])
            dq[bad] = peval_d(qc[bad], new[bad])[1]
        return (new, dq) if return_dq else new

    def check(self, qc: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """Rows whose poles are simple, stable and accurate (the residue formula holds)."""
        mag = np.abs(lam)
        i, j = _PAIRS
        own = np.abs(lam[:, i] - lam[:, j]) / np.maximum(mag[:, i], mag[:, j])   # (m, 10)
        wk = (np.abs(lam[:, :, None] - WK_POLES) / np.maximum(mag[:, :, None],
                                                               np.abs(WK_POLES)))
        gaps = (np.min(own, axis=1), np.min(wk.reshape(lam.shape[0], -1), axis=1))
        absq = peval(np.abs(qc), mag).real
        resid = rmax(np.abs(peval(qc, lam)) / absq)
        return (np.minimum(*gaps) > 1e-7) & (resid < 1e-9) & (rmax(lam.real) < 0.0)

    # ------------------------------------------------------------------ variances
    def var_v(self, c: np.ndarray, rows: np.ndarray, lam: np.ndarray,
              dq: np.ndarray | None = None) -> np.ndarray:
        """Stroke-velocity variance σ_v² ((m/s)²) for damping c on ``rows`` with poles lam
        (``dq``: Q'(λ) if known)."""
        qc = self.q(c, rows)
        # N_v(λ) N_v(−λ) = (k1 m2)² λ⁴ (R² − L² λ²); Q'(λ) by Horner; Q(−λ) = −2 Q_odd(λ)
        # (Q(λ) = 0: Q_even(λ) = −Q_odd(λ)), three coefficients in λ²
        l2 = lam * lam
        rr, ll = self.rl[rows, :1], self.rl[rows, 1:]
        nn = (self.k1 * self.m2) ** 2 * (l2 * l2) * (rr * rr - (ll * ll) * l2)
        q_odd = lam * (qc[:, 1:2] + l2 * (qc[:, 3:4] + l2 * qc[:, 5:6]))
        if dq is None:
            dq = peval(pder(qc), lam)
        h = nn / (dq * (-2.0 * q_odd))
        return self.scale * _band_integral(h, lam, self.wa, self.wb)

    def _var(self, num: np.ndarray, qc: np.ndarray, lam: np.ndarray) -> np.ndarray:
        res = peval(num, lam) / peval(pder(qc), lam)
        h_neg = peval(num, -lam) / peval(qc, -lam)
        return _band_integral(res * h_neg, lam, self.wa, self.wb)

    def variances(self, c: np.ndarray, rows: np.ndarray, lam: np.ndarray
                  ) -> dict[str, np.ndarray]:
        """All variances on ``rows`` for damping ``c`` and poles ``lam`` (m, 5).

        Returns
        -------
        dict
            ``var_v`` ((m/s)²), ``var_acc_w`` (W_k-weighted ẍ2, (m/s²)²), ``var_tyre``
            (m²), ``p_load`` (W), ``p_diss`` (W: electrical + c σ_v²).
        """
        qc = self.q(c, rows)
        k1, m2 = self.k1, self.m2
        rl = self.rl[rows]
        s2 = np.array([0.0, 0.0, 1.0])
        # shared by every output: 1/(Q'(λ) Q(−λ)) × the band weights of the poles; each
        # output's N(λ) N(−λ) is an even polynomial, evaluated once at λ²
        u = lam * lam
        w = self.scale * _band_weights(lam, self.wa, self.wb) / (peval(pder(qc), lam)
                                                                 * peval(qc, -lam))

        def var(num: np.ndarray) -> np.ndarray:
            return np.real(rsum(peval(even_square(num), u) * w))

        out = {"var_v": var(k1 * m2 * pmul(rl, s2))}
        var_i = var(self.cur_gain[rows, None] * s2)
        out["p_load"] = self.Re[rows] * var_i
        out["p_diss"] = (self.kt_over_ke[rows] * np.where(self.open[rows], 0.0, self.R[rows])
                         * var_i + c * out["var_v"])
        dc = self.d0[rows] + c[:, None] * self.d1[rows]                     # D̃ (m, 4)
        num_t = padd(k1 * padd(dc, m2 * pmul(rl, s2)), -qc)              # zero at s = 0
        out["var_tyre"] = var(num_t[:, 1:])
        # comfort: ẍ2 = k1 s D̃ / Q times W_k = Wn/Wd; poles of Q and of Wd
        na = k1 * np.concatenate([np.zeros((dc.shape[0], 1)), dc], axis=1)  # k1 s D̃
        hp = peval(even_square(na), u) * (peval(WK_NUM2, u) / peval(WK_DEN2, u))
        hw = (at_wk(na) * at_wk(na, -1.0) / (at_wk(qc) * at_wk(qc, -1.0))
              * WK_AT_POLES)
        out["var_acc_w"] = (np.real(rsum(hp * w))
                            + self.scale * np.real(hw @ _band_weights(WK_POLES, self.wa,
                                                                      self.wb)))
        return out
