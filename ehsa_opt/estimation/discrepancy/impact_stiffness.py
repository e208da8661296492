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
point is consistent with the best when n (f − f_best)/f_best ≤ χ²₁(0.95) = 3.84.

That scale alone claims too much: it ignores the model's own error (the friction law
and the contact law are not the rig's, so the tests disagree on the best stiffness)
and the objective's roughness (the best point is the minimum of a rough function, its
mean square an underestimate).  On a Hertzian rig-B campaign the rule alone stated
2.4e8-3.9e8 N/m as identified for a 6.3e7 N/m contact.  So the tests' spread is a second
scale (the sandwich of the quasi-likelihood): with d_t the per-test excess of a point's
objective over the best's, as a log ratio (:func:`per_test_objectives`,
:func:`_within_test_spread`), the point is also consistent when d̄ ≤ t_{n−1}(0.975) s_d/√n,
i.e. when the tests do not agree it is worse.  Where the tests agree (a contact the
data fix) this adds nothing.

The interval is the hull of the consistent points' stiffnesses, widened to the nearest
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
from scipy.stats import t as student_t

from .impact_features import Mismatch, standardised_terms

__all__ = ["stiffness_interval", "stiffness_bracket", "per_test_objectives", "stiffness_note",
           "law_constant", "peak_force_ratios", "STIFFNESS_IDENTIFIED_RATIO", "PROFILE_CHI2",
           "PAIRED_COVERAGE"]

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
                       bounds: tuple[float, float] = (0.0, math.inf),
                       per_test: Sequence[np.ndarray] | None = None) -> dict:
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
    per_test : list of ndarray, optional
        Aligned with ``history``: each point's objective split by test (the same tests
        for every point, their mean the objective).  With it a point is also consistent
        when its per-test log excess over the best is within :func:`_paired_limit` of
        that excess's test-to-test standard error (:func:`_within_test_spread`; module
        docstring: the tests' spread, not only the best point's mean square, is the
        scale).

    Returns
    -------
    dict
        ``lower_N_per_m``, ``upper_N_per_m`` (the bracket), ``open_below``,
        ``open_above`` (no inconsistent evaluated stiffness on that side),
        ``consistent_points``, ``by_test_spread`` (of them, the points only the tests'
        spread makes consistent) and ``identified`` (a closed bracket within
        :data:`STIFFNESS_IDENTIFIED_RATIO`).
    """
    if n_features <= 0:
        raise ValueError(f"stiffness_interval: n_features must be > 0, got {n_features}")
    if per_test is not None and len(per_test) != len(history):
        raise ValueError(f"stiffness_interval: per_test has {len(per_test)} rows, "
                         f"history {len(history)}")
    idx = [i for i, r in enumerate(history) if r.get("contact_exponent", 1.0) == exponent
           and math.isfinite(r["objective"])]
    if not idx:
        raise ValueError(f"stiffness_interval: no evaluated point of exponent {exponent:g}")
    i_best = min(idx, key=lambda i: history[i]["objective"])
    f_best = history[i_best]["objective"]
    limit = f_best * (1.0 + PROFILE_CHI2 / n_features)
    by_profile = {i: history[i]["objective"] <= limit for i in idx}
    by_spread = ({i: _within_test_spread(per_test[i], per_test[i_best], f_best) for i in idx}
                 if per_test is not None else dict.fromkeys(idx, False))
    consistent = {i: by_profile[i] or by_spread[i] for i in idx}
    ok = [float(history[i][stiffness_key]) for i in idx if consistent[i]]
    bad = [float(history[i][stiffness_key]) for i in idx if not consistent[i]]
    lo, hi = min(ok), max(ok)
    below = [k for k in bad if k < lo]
    above = [k for k in bad if k > hi]
    lower = max(below) if below else float(bounds[0])
    upper = min(above) if above else float(bounds[1])
    identified = bool(below and above and upper / max(lower, 1e-300)
                      <= STIFFNESS_IDENTIFIED_RATIO)
    return {"lower_N_per_m": lower, "upper_N_per_m": upper, "open_below": not below,
            "open_above": not above, "consistent_points": len(ok),
            "by_test_spread": sum(1 for i in idx if by_spread[i] and not by_profile[i]),
            "identified": identified}


#: Two-sided coverage of the paired test-level comparison (:func:`_within_test_spread`).
PAIRED_COVERAGE = 0.95


def _paired_limit(n_tests: int) -> float:
    """Student's t quantile of :data:`PAIRED_COVERAGE` with ``n_tests`` − 1 degrees of
    freedom (inf below two tests: no spread to measure)."""
    if n_tests < 2:
        return math.inf
    return float(student_t.ppf(0.5 + 0.5 * PAIRED_COVERAGE, n_tests - 1))


def _within_test_spread(point: np.ndarray, best: np.ndarray, floor: float) -> bool:
    """Whether a point's per-test objectives exceed the best point's by no more than
    their test-to-test spread allows: mean excess d̄ ≤ t s_d/√n (a paired comparison,
    the sandwich scale of the profile), d_t = ln((u_t + floor)/(u_best,t + floor)) the
    per-test log excesses (a test's objective grows with its own scale, so the excesses
    are compared as ratios; ``floor``, the best objective, keeps a test the best point
    matches exactly from dominating).  Tests left out (non-finite in either) are not
    used; fewer than two tests never pass."""
    fl = max(float(floor), 1e-12)
    d = (np.log(np.asarray(point, dtype=float) + fl)
         - np.log(np.asarray(best, dtype=float) + fl))
    d = d[np.isfinite(d)]
    if d.size < 2:
        return False
    return bool(d.mean() <= _paired_limit(d.size) * d.std(ddof=1) / math.sqrt(d.size))


def stiffness_bracket(history: Sequence[Mapping[str, float]], mismatches: Sequence[Mismatch],
                      widen: Sequence[tuple[np.ndarray, float]] | None, law: float,
                      stiffness_key: str, box: tuple[np.ndarray, np.ndarray]) -> dict:
    """:func:`stiffness_interval` of a search ``history`` (``mismatches`` aligned with
    it, ``widen`` as the objective used them) with n the number of tests the objective
    uses at its best point (tests left out not counted): a test's features move together
    (its impacts set all four energies and the gap), so the test, not the feature, is
    the unit of independent information — with the features' count the bracket of a
    Hertzian contact on the second generator was 1.25 wide and missed the truth by 34 %.
    Each point's objective split by test (:func:`per_test_objectives`) lets the tests'
    own spread set the scale as well.  ``box``: the search's (lower, upper) bounds of
    (gap, log10 k, log10 c)."""
    if len(mismatches) != len(history):
        raise ValueError(f"stiffness_bracket: {len(mismatches)} mismatches for "
                         f"{len(history)} history rows")
    split = [per_test_objectives(m, widen) for m in mismatches]
    rows = [i for i, r in enumerate(history) if r.get("contact_exponent", 1.0) == law
            and math.isfinite(r["objective"])]
    best = min(rows, key=lambda i: history[i]["objective"]) if rows else 0
    n_tests = int(np.sum(np.isfinite(split[best]))) if split else 0
    bounds = (10.0 ** float(box[0][1]), 10.0 ** float(box[1][1]))
    return stiffness_interval(history, law, max(n_tests, 1), stiffness_key, bounds, split)


def per_test_objectives(m: Mismatch, widen: Sequence[tuple[np.ndarray, float]] | None = None
                        ) -> np.ndarray:
    """Per test, its sum of squared standardised mismatches
    (:func:`~.impact_features.standardised_terms`) over the mean number of terms per
    test: their mean is the objective (:func:`~.impact_features.score`); NaN for a test
    left out."""
    z = standardised_terms(m, widen)
    sizes = [t.size for t in z if t is not None]
    per = max(float(np.mean(sizes)), 1.0) if sizes else 1.0
    return np.array([float(np.sum(t ** 2)) / per if t is not None else math.nan for t in z])


def stiffness_note(kint: Mapping, law: float) -> str:
    """The stiffness bracket in words (and in the law's own units for a power law)."""
    lo_s = "open" if kint["open_below"] else f"{kint['lower_N_per_m']:.3g}"
    hi_s = "open" if kint["open_above"] else f"{kint['upper_N_per_m']:.3g}"
    own = ("" if law == 1.0 else f" (law constant {law_constant(kint['lower_N_per_m'], law):.3g}"
           f"-{law_constant(kint['upper_N_per_m'], law):.3g} N/m^{law:g})")
    return (f"; stiffness bracket {lo_s} to {hi_s} N/m{own} from "
            f"{kint['consistent_points']} consistent points"
            + (f" ({kint['by_test_spread']} of them by the tests' spread)"
               if kint.get("by_test_spread") else "") + ": "
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
