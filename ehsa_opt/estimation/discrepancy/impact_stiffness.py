"""What an impact-aware contact fit (:mod:`.impacts`) says about the contact's stiffness:
an interval from the evaluated points rather than one number, the stiffness in the
units of the chosen law, and whether it is identified at all.

Why an interval.  The feature objective is a rough function of the stiffness (the
sampled ringing aliases; a rattling contact's energies move by 5-20 % between
tolerances), and on a rig whose contact law is not one of ours (a Hunt-Crossley contact
of another exponent, another damping law) a band of stiffnesses reproduces the impact
energies equally well.  The search history already holds that profile: every evaluated
(gap, k, c) and its objective.  The objective is a mean of squared standardised
mismatches over n tests whose features move together, so (as a quasi-likelihood whose
scale is the best point's mean square, with the test as the unit of information) a
point is consistent with the best when n (f − f_best)/f_best ≤ χ²₁(0.95) = 3.84.  The
interval is the hull of the consistent points' stiffnesses, widened to the nearest
evaluated inconsistent stiffness on each side (the profile is only sampled there; an
edge without an inconsistent neighbour is open).  The stiffness is called identified
when that bracket is within :data:`STIFFNESS_IDENTIFIED_RATIO`.

Units.  A power-law contact's ``backlash_contact_stiffness_N_per_m`` is its secant
stiffness at the reference penetration (10 µm); the law's own constant is
K = k_c p_ref^(1−n) (N/m^n), the number a Hertzian contact is usually quoted in.
Method: docs/theory/stiff_contacts.md.
"""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np

from .impact_features import Mismatch, standardised_terms

__all__ = ["stiffness_interval", "stiffness_bracket", "stiffness_note", "law_constant",
           "peak_force_ratios", "STIFFNESS_IDENTIFIED_RATIO",
           "PROFILE_CHI2"]

#: χ²₁ 95 % quantile: a point whose objective exceeds the best by n (f − f_best)/f_best
#: more than this is inconsistent with it.
PROFILE_CHI2 = 3.84
#: The stiffness is called identified when its bracket's upper/lower ratio is at most this
#: (half a decade either side of a point estimate is an order of magnitude, not a number).
STIFFNESS_IDENTIFIED_RATIO = 10.0


def law_constant(stiffness_N_per_m: float, exponent: float,
                 reference_m: float = 1e-5) -> float:
    """The contact law's constant K (N/m^n) of a secant stiffness at ``reference_m``:
    F = K pen^n = k_c p_ref (pen/p_ref)^n."""
    return float(stiffness_N_per_m) * float(reference_m) ** (1.0 - float(exponent))


def stiffness_interval(history: Sequence[Mapping[str, float]], exponent: float,
                       n_features: int, stiffness_key: str,
                       bounds: tuple[float, float] = (0.0, math.inf)) -> dict:
    """The stiffness bracket of the points of the law ``exponent`` in ``history`` that
    are consistent with the best one (module docstring).

    Parameters
    ----------
    history : list of dict
        Evaluated points with ``stiffness_key``, ``"objective"`` and ``"contact_exponent"``.
    exponent : float
        The contact law whose points are used.
    n_features : int
        Independent units of information the objective averages (> 0; the tests,
        :func:`stiffness_bracket`).
    stiffness_key : str
        The stiffness's key in the history rows (N/m).
    bounds : (float, float)
        The search box (N/m): an open side of the bracket ends there.

    Returns
    -------
    dict
        ``lower_N_per_m``, ``upper_N_per_m`` (the bracket), ``open_below``,
        ``open_above`` (no inconsistent evaluated stiffness on that side),
        ``consistent_points`` and ``identified`` (a closed bracket within
        :data:`STIFFNESS_IDENTIFIED_RATIO`).
    """
    if n_features <= 0:
        raise ValueError(f"stiffness_interval: n_features must be > 0, got {n_features}")
    rows = [r for r in history if r.get("contact_exponent", 1.0) == exponent
            and math.isfinite(r["objective"])]
    if not rows:
        raise ValueError(f"stiffness_interval: no evaluated point of exponent {exponent:g}")
    f_best = min(r["objective"] for r in rows)
    limit = f_best * (1.0 + PROFILE_CHI2 / n_features)
    ok = [float(r[stiffness_key]) for r in rows if r["objective"] <= limit]
    bad = [float(r[stiffness_key]) for r in rows if r["objective"] > limit]
    lo, hi = min(ok), max(ok)
    below = [k for k in bad if k < lo]
    above = [k for k in bad if k > hi]
    lower = max(below) if below else float(bounds[0])
    upper = min(above) if above else float(bounds[1])
    identified = bool(below and above and upper / max(lower, 1e-300)
                      <= STIFFNESS_IDENTIFIED_RATIO)
    return {"lower_N_per_m": lower, "upper_N_per_m": upper, "open_below": not below,
            "open_above": not above, "consistent_points": len(ok), "identified": identified}


def stiffness_bracket(history: Sequence[Mapping[str, float]], best_mismatch: Mismatch,
                      widen: Sequence[tuple[np.ndarray, float]] | None, law: float,
                      stiffness_key: str, box: tuple[np.ndarray, np.ndarray]) -> dict:
    """:func:`stiffness_interval` of a search ``history`` with n the number of tests the
    objective uses at its best point (``best_mismatch``, ``widen``; tests left out not
    counted): a test's features move together (its impacts set all four energies and the
    gap), so the test, not the feature, is the unit of independent information — with
    the features' count the bracket of a Hertzian contact on the second generator was
    1.25 wide and missed the truth by 34 %.  ``box``: the search's (lower, upper) bounds of
    (gap, log10 k, log10 c)."""
    n_tests = sum(1 for z in standardised_terms(best_mismatch, widen) if z is not None)
    bounds = (10.0 ** float(box[0][1]), 10.0 ** float(box[1][1]))
    return stiffness_interval(history, law, max(n_tests, 1), stiffness_key, bounds)


def stiffness_note(kint: Mapping, law: float) -> str:
    """The stiffness bracket in words (and in the law's own units for a power law)."""
    lo_s = "open" if kint["open_below"] else f"{kint['lower_N_per_m']:.3g}"
    hi_s = "open" if kint["open_above"] else f"{kint['upper_N_per_m']:.3g}"
    own = ("" if law == 1.0 else f" (law constant {law_constant(kint['lower_N_per_m'], law):.3g}"
           f"-{law_constant(kint['upper_N_per_m'], law):.3g} N/m^{law:g})")
    return (f"; stiffness bracket {lo_s} to {hi_s} N/m{own} from "
            f"{kint['consistent_points']} consistent points: "
            + ("identified" if kint["identified"] else
               "NOT identified (the impacts fix the gap and the impact energies, not this number)"))


def peak_force_ratios(prepared: Sequence, preds: Sequence[np.ndarray]) -> np.ndarray:
    """Per test, the simulated over the measured largest force (resolved samples; both
    sampled at the same clock, so both miss the true peak alike): what a contact whose
    stiffness is not identified still predicts about the impacts' size."""
    out = []
    for pt, yp in zip(prepared, preds):
        w = pt.weight > 0
        meas = float(np.max(np.abs(pt.y[0][w]))) if w.any() else 0.0
        sim = float(np.max(np.abs(np.asarray(yp)[0][w]))) if w.any() else 0.0
        out.append(sim / meas if meas > 0 else math.nan)
    return np.asarray(out, dtype=float)
