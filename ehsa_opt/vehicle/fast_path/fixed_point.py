"""Per-design fixed point σ = σ_lin(c_f(σ)) by secants of a one-mode model.

Used by the friction-aware fast path (:mod:`ehsa_opt.vehicle.fast_path.linearisation`) with its
exact (residue) σ_lin, :mod:`ehsa_opt.vehicle.fast_path.band_variances`.  Why a model: an exact
σ_lin evaluation (pole tracking and residues for every design) costs much more
than the friction law c_f(σ); a lightly damped mode under white excitation has
1/σ² linear in an added damping c, and the quarter car's 1/σ_lin²(c) is nearly so.
Secants of that line through the latest exact points, each followed by the model's
own fixed point (friction law only), converge superlinearly: typically two exact
evaluations per design.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["model_fixed_point", "illinois_update"]

#: σ below σ₀/_LOCKED is reported as a locked strut (not converged).  Far below the
#: quadrature path's 1e4: an almost undamped design (σ₀ of metres per second) that
#: friction alone damps has its fixed point 1e5–1e6 below σ₀.
_LOCKED = 1e10


def model_fixed_point(x0: np.ndarray, rows: np.ndarray, sigma_v_of: Any, cf_of: Any,
                       tol: float, max_iter: int
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Gaussian fixed point σ = σ_lin(c_f(σ)) by secants of the one-mode model.

    A lightly damped mode under white excitation has 1/σ_v² linear in an added
    damping c (σ_v² = π S₀/(c_lin + c)); the quarter car's 1/σ_v²(c) is nearly so.
    Each step draws the line through the two latest exact points (c, 1/σ_lin²(c))
    (first (0, 1/σ₀²) and (c_f(σ₀), ·)), solves the model's fixed point
    1/σ² = α + β c_f(σ) — cheap: only the friction law — and evaluates σ_lin
    exactly at its c_f.  Stops when |ln σ_lin(c_f(σ)) − ln σ| < tol (the criterion
    of the Illinois iteration of the quadrature path); a secant method, so
    superlinear: typically 3–4 exact evaluations.

    Parameters
    ----------
    x0 : ndarray (m,)
        ln σ₀, the frictionless rms stroke velocity (m/s).
    rows : ndarray (m,)
        Flat indices passed to ``sigma_v_of(c, rows)`` and ``cf_of(σ, rows)``.

    Returns
    -------
    x, c, iterations, converged : ndarray (m,)
        ln σ of the fixed point, c_f there (N s/m), exact evaluations, and
        whether it converged (False also for a locked strut: σ < 10⁻¹⁰ σ₀).
    """
    m = x0.size
    lo = x0 - math.log(_LOCKED)
    ca, ya = np.zeros(m), np.exp(-2.0 * x0)
    cb = cf_of(np.exp(x0), rows)
    sb = sigma_v_of(cb, rows)
    yb = sb ** -2.0
    x, c = x0.copy(), cb.copy()
    it = np.ones(m)
    done = np.abs(np.log(sb) - x0) < tol
    conv = done.copy()
    for _ in range(max_iter):
        todo = np.flatnonzero(~done)
        if todo.size == 0:
            break
        dc = cb[todo] - ca[todo]
        with np.errstate(divide="ignore", invalid="ignore"):
            beta = np.where(dc != 0.0, (yb[todo] - ya[todo]) / dc, 0.0)
        beta = np.maximum(beta, 0.0)
        alpha = yb[todo] - beta * cb[todo]
        xm = _solve_model(alpha, beta, rows[todo], lo[todo], x0[todo], x[todo], cf_of)
        cn = cf_of(np.exp(xm), rows[todo])
        sn = sigma_v_of(cn, rows[todo])
        gn = np.log(sn) - xm
        it[todo] += 1
        x[todo], c[todo] = xm, cn
        fin = np.abs(gn) < tol
        locked = (xm <= lo[todo]) & (gn <= 0.0)
        conv[todo] = fin
        done[todo] = fin | locked
        ca[todo], ya[todo] = cb[todo], yb[todo]
        cb[todo], yb[todo] = cn, sn ** -2.0
    return x, c, it, conv


def _solve_model(alpha: np.ndarray, beta: np.ndarray, rows: np.ndarray, lo: np.ndarray,
                 hi: np.ndarray, guess: np.ndarray, cf_of: Any) -> np.ndarray:
    """Root of h(x) = −2x − ln(α + β c_f(eˣ)) on [lo, hi] (Illinois; lo if h(lo) ≤ 0,
    hi if h(hi) ≥ 0): the one-mode model's fixed point, ln σ.  Bracketed first by
    ``guess`` ± 0.25 (the previous iterate), else by [lo, hi]; to 1e-10 in x (the
    outer secant only needs its iterate well inside its own tolerance)."""
    def h(x: np.ndarray, sub: np.ndarray) -> np.ndarray:
        y = alpha[sub] + beta[sub] * cf_of(np.exp(x), rows[sub])
        return -2.0 * x - np.log(np.maximum(y, 1e-300))

    every = np.arange(alpha.size)
    a = np.clip(guess - 0.25, lo, hi)
    b = np.clip(guess + 0.25, lo, hi)
    ha, hb = h(a, every), h(b, every)
    # the root is not inside guess ± 0.25: widen that end to [lo, hi]'s
    for end, val, limit, outside in ((a, ha, lo, ha <= 0.0), (b, hb, hi, hb >= 0.0)):
        wide = np.flatnonzero(outside & (end != limit))
        if wide.size:
            end[wide] = limit[wide]
            val[wide] = h(end[wide], wide)
    x = np.where(ha <= 0.0, a, b)
    todo = np.flatnonzero((ha > 0.0) & (hb < 0.0))
    side = np.zeros(alpha.size)
    for _ in range(100):
        if todo.size == 0:
            break
        xn = (a[todo] * hb[todo] - b[todo] * ha[todo]) / (hb[todo] - ha[todo])
        hn = h(xn, todo)
        x[todo] = xn
        illinois_update(a, b, ha, hb, side, todo, xn, hn)
        todo = todo[(np.abs(hn) > 1e-10) & (b[todo] - a[todo] > 1e-10)]
    return x


def illinois_update(a: np.ndarray, b: np.ndarray, fa: np.ndarray, fb: np.ndarray,
                    side: np.ndarray, rows: np.ndarray, xn: np.ndarray, fn: np.ndarray
                    ) -> None:
    """One Illinois (modified regula falsi) update, in place, of the brackets [a, b]
    with values fa > 0 > fb on ``rows``, given the secant point ``xn`` and its value
    ``fn``: the end with the same sign is replaced, and the retained end's value is
    halved when the same end was kept twice in a row (``side`` remembers which)."""
    ka, kb = fa[rows], fb[rows]
    pos = fn > 0.0
    sd = side[rows]
    a[rows] = np.where(pos, xn, a[rows])
    fa[rows] = np.where(pos, fn, np.where(sd == -1, 0.5 * ka, ka))
    b[rows] = np.where(pos, b[rows], xn)
    fb[rows] = np.where(pos, np.where(sd == 1, 0.5 * kb, kb), fn)
    side[rows] = np.where(pos, 1, -1)
