"""Friction bounds the bench data determine: envelope of the identifiable rod
friction and the ``min`` / ``best`` / ``max`` friction sets of every vehicle study.

A rigid bench determines only the friction *at the rod*,
F_rod(v) = F_ns(v) + T_b(v/r)/r (the nut/bearing split is not identifiable), and only at the velocities a
test actually reaches.  For every successful per-test fit the rod friction is evaluated on
a velocity grid (from 10 % of the slowest test's peak velocity, where the Fisher analysis
starts) up to the test's peak velocity; the **envelope** is the pointwise minimum and
maximum over the tests that reach that velocity (the spread of per-test estimates holds
their own estimation noise; ``per_test_bands=True`` widens each by its own band first).
The across-test mean with its Student-t 95 % interval is reported beside it.  Beyond the
fastest test the grid goes on to 3 m/s (:data:`V_MAX_M_PER_S`), the largest stroke
velocity the vehicle studies meet, where nothing was measured.

The **band of the best law** (:mod:`ehsa_opt.estimation.rod_law`): the rod friction of
the best set ± the 95 % half-width of the sandwich covariance of the least-squares rod law
on every test's friction samples (refitted from the best set: a sandwich is the variance
of the estimator at its own root, where the scores sum to zero; evaluated at another
point its "meat" holds the squared misfit of that point instead) — the larger of
Newey–West (autocorrelated residuals: the effective sample size, not the number of
samples) and cluster-robust (tests as clusters: an error repeated in every cycle of a
test) — plus the distance between the best set and that least-squares law.  It widens
beyond the data as the uncertainty of the law's high-velocity part (viscous coefficient,
Coulomb level) does.

Friction sets (admissible :class:`~ehsa_opt.physics.params.FrictionParams`):

``best``
    the joint fit (one parameter set for the training tests) when its rod friction lies
    in the envelope (2 % tolerance); otherwise a least-squares fit to the across-test mean
    with the joint fit's split; without a joint fit, the per-test fit whose rod friction
    is closest to the across-test mean.
``min`` / ``max``
    the best set with non-negative amounts of its own shapes taken away / added (per
    pair: Coulomb level, Stribeck excess, viscous coefficient; :func:`ordered_set`, a
    linear programme): the smallest change that puts the set below / above the best set
    by the *margin* at every grid velocity.  Inside the data the margin is the wider of
    the envelope and the best law's band; beyond the data it is the band plus the
    envelope's excess over the band at the data's edge, carried in proportion to the
    friction.  Every shape is ≥ 0 at v ≥ 0, so **min ≤ best ≤ max at every velocity**
    by construction, and the sets widen beyond the data with the band.

The paper's method — per-parameter minimum and maximum over the tests
(:func:`paper_friction_sets`) — is kept as an option.  It over-states the spread: the
nut/bearing split is not determined by the data, so each raw parameter wanders from test
to test although the rod total does not, and combining all minima (maxima) adds up
spreads that cancel in every single fit; taking the largest breakaway velocity with the
largest breakaway force makes a Stribeck hump no test shows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from scipy import optimize, stats

from ..physics.friction import bearing_friction_Nm, rod_friction_N, simscape_friction
from ..physics.params import FRICTION_NAMES, FrictionParams
from .test_velocity import test_peak_velocity_m_per_s, test_velocity_range_m_per_s

__all__ = ["FrictionBounds", "friction_bounds", "paper_friction_sets", "velocity_grid",
           "test_peak_velocity_m_per_s", "test_velocity_range_m_per_s",
           "identification_json", "DATA_METHOD", "PAPER_METHOD",
           "fit_envelope", "ordered_set", "V_MAX_M_PER_S", "envelope_lines"]

#: Velocity up to which the sets are ordered and banded (the vehicle studies' largest).
V_MAX_M_PER_S = 3.0

DATA_METHOD = ("data-supported: envelope of the identifiable rod friction "
               "F_ns(v) + T_b(v/r)/r over the per-test fits, each used only up to the "
               "test's peak velocity (grid from 10 % of the slowest test's peak velocity), "
               "united with the best law's 95 % sandwich band (Newey-West / cluster-robust: "
               "effective sample size), which alone continues beyond the data to 3 m/s; "
               "min/max = the best set minus/plus non-negative amounts of its own Coulomb, "
               "Stribeck and viscous shapes (linear programme), so min <= best <= max at "
               "every velocity")
PAPER_METHOD = ("paper's method: per-parameter minimum/maximum over the per-test fits "
                "(over-states the spread: the nut/bearing split is not determined by the "
                "data, and the largest breakaway velocity makes a spurious Stribeck hump)")

_NUT = FRICTION_NAMES[:4]
_BEARING = FRICTION_NAMES[4:]
#: Admissible ranges of the fitted nut parameters (as identification's bounds).
_NUT_BOUNDS = {"nut_coulomb_N": (0.0, 1e4), "nut_excess_N": (0.0, 1e4),
               "nut_breakaway_velocity_m_per_s": (1e-3, 5e-2),
               "nut_viscous_Ns_per_m": (0.0, 1e5)}


def velocity_grid(v_max_m_per_s: float, n: int = 48, v_min_m_per_s: float = 1e-3
                  ) -> np.ndarray:
    """Rod velocities (m/s) for the envelope: log-spaced from ``v_min_m_per_s`` to 2 cm/s
    (the Stribeck region), linear above, up to ``v_max_m_per_s``."""
    v_max = float(v_max_m_per_s)
    if not (v_max > 0 and math.isfinite(v_max)):
        raise ValueError(f"velocity_grid: v_max_m_per_s must be > 0, got {v_max_m_per_s!r}")
    v_min = min(float(v_min_m_per_s), 0.5 * min(0.02, v_max))
    low = np.geomspace(v_min, min(0.02, v_max), 12)
    high = np.linspace(min(0.02, v_max), v_max, max(n - 12, 2))
    return np.unique(np.round(np.concatenate([low, high]), 12))


def _friction(params: Mapping[str, float], has_generator: bool) -> FrictionParams:
    """FrictionParams of an identified parameter dict (no bearings without generator)."""
    vals = {n: float(params[n]) for n in FRICTION_NAMES if n in params}
    if not has_generator:
        vals = {n: v for n, v in vals.items() if n in _NUT}
    if vals.get("nut_breakaway_N", 0.0) < vals.get("nut_coulomb_N", 0.0):
        vals["nut_breakaway_N"] = vals["nut_coulomb_N"]
    if vals.get("bearing_breakaway_Nm", 0.0) < vals.get("bearing_coulomb_Nm", 0.0):
        vals["bearing_breakaway_Nm"] = vals["bearing_coulomb_Nm"]
    return FrictionParams(**vals)


def _rod(v: np.ndarray, fr: FrictionParams, lead: float) -> np.ndarray:
    return np.asarray(rod_friction_N(v, fr, lead), dtype=float)


def _basis(v: np.ndarray, best: FrictionParams, lead: float, gen: bool
           ) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Non-negative shapes (v ≥ 0) whose non-negative multiples are added to (``max``) or
    taken from (``min``) the best set: per pair the Coulomb level, the Stribeck excess
    over it (at the best set's breakaway velocity) and the viscous coefficient.  Returns
    the names, the shapes (grid × k, N per unit) and how much of each the best set has."""
    u = best.nut_breakaway_velocity_m_per_s
    sq = math.sqrt(2.0 * math.e)
    z = v / (math.sqrt(2.0) * u)
    cols = {"nut_coulomb": np.tanh(v / (u / 10.0)), "nut_excess": sq * np.exp(-z * z) * z,
            "nut_viscous": v}
    have = {"nut_coulomb": best.nut_coulomb_N,
            "nut_excess": best.nut_breakaway_N - best.nut_coulomb_N,
            "nut_viscous": best.nut_viscous_Ns_per_m}
    if gen:
        w = best.bearing_breakaway_velocity_rad_per_s
        om = v / lead
        zb = om / (math.sqrt(2.0) * w)
        cols.update({"bearing_coulomb": np.tanh(om / (w / 10.0)) / lead,
                     "bearing_excess": sq * np.exp(-zb * zb) * zb / lead,
                     "bearing_viscous": om / lead})
        have.update({"bearing_coulomb": best.bearing_coulomb_Nm,
                     "bearing_excess": best.bearing_breakaway_Nm - best.bearing_coulomb_Nm,
                     "bearing_viscous": best.bearing_viscous_Nms_per_rad})
    names = list(cols)
    return names, np.column_stack([cols[n] for n in names]), np.array([have[n] for n in names])


def _shifted(best: FrictionParams, names: Sequence[str], delta: np.ndarray, sign: float
             ) -> FrictionParams:
    d = dict(zip(names, sign * np.asarray(delta, dtype=float)))
    b = best.as_dict()
    nc, ne = d.get("nut_coulomb", 0.0), d.get("nut_excess", 0.0)
    bc, be = d.get("bearing_coulomb", 0.0), d.get("bearing_excess", 0.0)
    vals = dict(b, nut_coulomb_N=b["nut_coulomb_N"] + nc,
                nut_breakaway_N=b["nut_breakaway_N"] + nc + ne,
                nut_viscous_Ns_per_m=b["nut_viscous_Ns_per_m"] + d.get("nut_viscous", 0.0),
                bearing_coulomb_Nm=b["bearing_coulomb_Nm"] + bc,
                bearing_breakaway_Nm=b["bearing_breakaway_Nm"] + bc + be,
                bearing_viscous_Nms_per_rad=(b["bearing_viscous_Nms_per_rad"]
                                             + d.get("bearing_viscous", 0.0)))
    vals = {k: max(float(x), 0.0) for k, x in vals.items()}
    vals["nut_breakaway_N"] = max(vals["nut_breakaway_N"], vals["nut_coulomb_N"])
    vals["bearing_breakaway_Nm"] = max(vals["bearing_breakaway_Nm"], vals["bearing_coulomb_Nm"])
    return FrictionParams(**vals)


def ordered_set(best: FrictionParams, v: np.ndarray, margin_N: np.ndarray, lead: float,
                side: str, has_generator: bool = True) -> FrictionParams:
    """The ``min`` (``side="below"``) or ``max`` (``"above"``) set: the best set with
    non-negative amounts of its own shapes (Coulomb level, Stribeck excess, viscous
    coefficient of each pair) taken away / added, the smallest total change (a linear
    programme, HiGHS) that keeps the set at least ``margin_N`` below / above the best set
    at every grid velocity.  Every shape is ≥ 0 for v ≥ 0, so ``min ≤ best ≤ max`` at
    every velocity — on the grid and beyond it, by construction; ``min`` takes away at
    most what the best set has (a margin larger than the best set's friction is clipped:
    zero friction is the floor)."""
    if side not in ("below", "above"):
        raise ValueError(f"ordered_set: side must be 'below' or 'above', got {side!r}")
    v = np.asarray(v, dtype=float)
    margin = np.asarray(margin_N, dtype=float)
    ok = np.isfinite(margin) & (v > 0)
    v, margin = v[ok], np.maximum(margin[ok], 0.0)
    names, Phi, have = _basis(v, best, lead, has_generator)
    # a Coulomb level or a Stribeck hump (peak = its amount) never larger than the
    # largest margin: without it a tall narrow hump below the grid's first velocity would
    # meet a low-velocity margin "cheaply" (its tail) with an absurd breakaway force
    cap = float(np.max(margin)) if margin.size else 0.0
    ub = np.array([np.inf if "viscous" in n else cap * (lead if n.startswith("bearing") else 1.0)
                   for n in names])
    if side == "below":
        margin = np.minimum(margin, np.asarray(rod_friction_N(v, best, lead), dtype=float))
        ub = np.minimum(ub, np.maximum(have, 0.0))
    # columns scaled to unit maximum on the grid (conditioning)
    colmax = np.maximum(Phi.max(axis=0), 1e-300)
    A = Phi / colmax
    w = np.full(v.size, 1.0 / v.size)
    res = optimize.linprog(c=w @ A, A_ub=-A, b_ub=-margin,
                           bounds=list(zip(np.zeros(have.size), ub * colmax)), method="highs")
    if not res.success:   # cannot happen for "below" (all of it) nor "above" (viscous grows)
        raise RuntimeError(f"ordered_set ({side}): linear programme failed: {res.message}")
    delta = res.x / colmax
    return _shifted(best, names, delta, -1.0 if side == "below" else 1.0)


def fit_envelope(target_N: np.ndarray, v: np.ndarray, split: FrictionParams, lead: float,
                 side: str) -> FrictionParams:
    """An admissible friction set whose rod friction follows ``target_N`` on ``v``.

    The bearing torques are those of ``split`` times one factor (its breakaway velocity
    kept; weakly pulled towards the mean ratio target / rod friction of ``split``); that
    factor and the nut's four parameters are fitted by least squares (SLSQP) subject to the rod friction staying
    ``<=`` (``side="below"``), ``>=`` (``"above"``) the target at every grid velocity,
    or unconstrained (``"fit"``).
    """
    if side not in ("below", "above", "fit"):
        raise ValueError(f"fit_envelope: side must be 'below', 'above' or 'fit', got {side!r}")
    target = np.asarray(target_N, dtype=float)
    ok = np.isfinite(target)
    v, target = np.asarray(v, dtype=float)[ok], target[ok]
    if v.size < 4:
        raise ValueError("fit_envelope: fewer than 4 finite envelope points")
    base = _rod(v, split, lead)
    k0 = float(np.clip(np.mean(target / np.maximum(base, 1e-9)), 0.0, 1e3))
    unit_bear = {n: getattr(split, n) for n in _BEARING}
    b_unit = np.asarray(bearing_friction_Nm(v / lead, FrictionParams(**unit_bear)) / lead,
                        dtype=float)
    scale = max(float(np.max(np.abs(target))), 1.0)
    x_scale = np.array([scale, scale, 0.01, scale / max(float(v.max()), 1e-6), 1.0])

    def params(z: np.ndarray) -> FrictionParams:
        x = z * x_scale
        bear = {n: unit_bear[n] * (1.0 if "velocity" in n else x[4]) for n in _BEARING}
        return FrictionParams(nut_breakaway_N=x[0] + x[1], nut_coulomb_N=x[0],
                              nut_breakaway_velocity_m_per_s=x[2],
                              nut_viscous_Ns_per_m=x[3], **bear)

    def model(z: np.ndarray) -> np.ndarray:
        x = z * x_scale
        return (np.asarray(simscape_friction(v, x[0] + x[1], x[0], x[2], x[3]), dtype=float)
                + x[4] * b_unit)

    def obj(z: np.ndarray) -> float:
        # a weak pull of the bearing factor towards the mean ratio keeps the split close
        # to the joint fit's where the envelope allows it
        return float(np.mean(((model(z) - target) / scale) ** 2)
                     + 1e-3 * ((z[4] - k0) / max(k0, 0.1)) ** 2)

    cons = []
    if side == "below":
        cons = [{"type": "ineq", "fun": lambda z: (target - model(z)) / scale}]
    elif side == "above":
        cons = [{"type": "ineq", "fun": lambda z: (model(z) - target) / scale}]
    bounds = [(lo / s, hi / s) for (lo, hi), s in
              zip([*_NUT_BOUNDS.values(), (0.0, 1e3)], x_scale)]
    lo_b, hi_b = np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds])
    starts = []
    for u_brk in (0.003, 0.01, 0.03):
        # feasible-ish starts: nothing (below) or a Coulomb level at the target's max (above)
        c0 = {"below": 0.0, "above": 1.0, "fit": 0.5}[side]
        starts.append(np.array([c0, 0.05, u_brk / 0.01, 0.0, 0.0 if side == "above" else
                                0.5 * k0]))
        starts.append(np.array([0.5, 0.1, u_brk / 0.01, 0.2, k0]))
    # the split set itself scaled to touch the target (feasible for below/above)
    ratio = target / np.maximum(base, 1e-9)
    kf = float(np.clip({"below": ratio.min(), "above": ratio.max(), "fit": k0}[side], 0, 1e3))
    starts.insert(0, np.array([split.nut_coulomb_N * kf, (split.nut_breakaway_N
                               - split.nut_coulomb_N) * kf, split.nut_breakaway_velocity_m_per_s,
                               split.nut_viscous_Ns_per_m * kf, kf]) / x_scale)
    best = None
    for z0 in starts:
        res = optimize.minimize(obj, np.clip(z0, lo_b, hi_b), method="SLSQP", bounds=bounds,
                                constraints=cons, options={"maxiter": 500, "ftol": 1e-12})
        viol = 0.0 if not cons else float(max(0.0, -np.min(cons[0]["fun"](res.x))))
        score = (viol > 1e-6, viol if viol > 1e-6 else 0.0, res.fun)
        if best is None or score < best[0]:
            best = (score, res.x)
    return params(best[1])


def paper_friction_sets(bounds: Mapping[str, Sequence[float]], has_generator: bool = True,
                        fill: Mapping[str, float] | None = None) -> dict[str, FrictionParams]:
    """The paper's method: ``min`` / ``max`` = per-parameter minimum / maximum over the
    per-test fits (``IdentificationReport.bounds``); see the module docstring for why it
    over-states the spread.  Parameters not varied (fixed or tied in the fits) are taken
    from ``fill`` (e.g. one fit's parameters)."""
    out = {}
    for j, case in enumerate(("min", "max")):
        vals = {n: float(v) for n, v in (fill or {}).items() if n in FRICTION_NAMES}
        vals.update({n: float(bounds[n][j]) for n in FRICTION_NAMES if n in bounds})
        out[case] = _friction(vals, has_generator)
    return out


@dataclass
class FrictionBounds:
    """Friction bounds on a velocity grid and the friction sets realising them.

    Attributes
    ----------
    velocity_m_per_s : ndarray
        The grid.
    per_test_N : ndarray
        (tests, grid) rod friction of each successful per-test fit, NaN above the test's
        peak velocity.
    lower_N, upper_N : ndarray
        The envelope (per-test curves widened by their 95 % Fisher half-width).
    mean_N, mean_ci95_N : ndarray
        Across-test mean and its Student-t 95 % interval (2, grid).
    sets : dict[str, FrictionParams]
        ``min``, ``best``, ``max`` (data-supported).
    sets_rod_N : dict[str, ndarray]
        Their rod friction on the grid.
    paper_sets, paper_rod_N : dict
        The paper's per-parameter sets and their rod friction.
    files : list[str]
        The tests of ``per_test_N``.
    band : str
        Which confidence band was used.
    """

    velocity_m_per_s: np.ndarray
    per_test_N: np.ndarray
    lower_N: np.ndarray
    upper_N: np.ndarray
    mean_N: np.ndarray
    mean_ci95_N: np.ndarray
    sets: dict[str, FrictionParams]
    sets_rod_N: dict[str, np.ndarray]
    paper_sets: dict[str, FrictionParams]
    paper_rod_N: dict[str, np.ndarray]
    lead_m_per_rad: float
    files: list[str] = field(default_factory=list)
    band: str = ""
    method: str = DATA_METHOD
    law_band_N: np.ndarray | None = None
    margin_band_N: np.ndarray | None = None
    data_range_m_per_s: tuple[float, float] = (math.nan, math.nan)
    test_peak_m_per_s: dict[str, float] = field(default_factory=dict)
    law: dict = field(default_factory=dict)
    level: float = 0.95

    def ordered(self, tol_N: float = 1e-9) -> bool:
        """``min ≤ best ≤ max`` at every grid velocity."""
        r = self.sets_rod_N
        return bool(np.all(r["min"] <= r["best"] + tol_N) and np.all(r["best"] <= r["max"] + tol_N))

    def velocity_range_json(self) -> dict:
        """The velocities the data cover: every test's and the campaign's."""
        lo, hi = self.data_range_m_per_s
        return {"description": "stroke velocities the bench data cover: each test up to its "
                               "peak |v| (2 pi f A for a sine, the 99th percentile of |v| "
                               "otherwise); the campaign from the envelope grid's lower end "
                               "(10 % of the slowest test's peak) to the fastest test's peak; "
                               "friction above the campaign's peak is extrapolated",
                "campaign_m_per_s": [float(lo), float(hi)],
                "tests_peak_m_per_s": {k: float(x) for k, x in self.test_peak_m_per_s.items()}}

    def at(self, v_m_per_s: float) -> dict[str, float]:
        """Envelope, mean and every set's rod friction (N) at one velocity."""
        out = {"lower_N": float(np.interp(v_m_per_s, self.velocity_m_per_s, self.lower_N)),
               "upper_N": float(np.interp(v_m_per_s, self.velocity_m_per_s, self.upper_N)),
               "mean_N": float(np.interp(v_m_per_s, self.velocity_m_per_s, self.mean_N))}
        for name, group in (("", self.sets), ("paper_", self.paper_sets)):
            for case, fr in group.items():
                out[f"{name}{case}_N"] = float(_rod(np.array([v_m_per_s]), fr,
                                                    self.lead_m_per_rad)[0])
        return out

    def to_json(self) -> dict:
        """``friction_sets`` and ``friction_envelope`` tables of identification.json."""
        def arr(a: np.ndarray) -> list:
            return [None if not np.isfinite(x) else float(x) for x in np.asarray(a).ravel()]
        sets = {c: fr.as_dict() for c, fr in self.sets.items()}
        sets["method"] = self.method
        env = {"velocity_m_per_s": arr(self.velocity_m_per_s), "lower_N": arr(self.lower_N),
               "upper_N": arr(self.upper_N), "mean_N": arr(self.mean_N),
               "mean_ci95_low_N": arr(self.mean_ci95_N[0]),
               "mean_ci95_high_N": arr(self.mean_ci95_N[1]), "band": self.band,
               "sets_rod_N": {c: arr(a) for c, a in self.sets_rod_N.items()},
               "per_test_N": {f: arr(row) for f, row in zip(self.files, self.per_test_N)},
               "lead_m_per_rad": self.lead_m_per_rad,
               "identified_range_m_per_s": [float(x) for x in self.data_range_m_per_s],
               "extrapolation_band": {
                   "description": (f"{100 * self.level:g} % band of the best law's rod "
                                   "friction (sandwich covariance, see law); margin_*: the "
                                   "band the min/max sets are built to enclose (inside the "
                                   "data also the per-test envelope)"),
                   "law_low_N": arr(self.law_band_N[0]) if self.law_band_N is not None else None,
                   "law_high_N": arr(self.law_band_N[1]) if self.law_band_N is not None else None,
                   "margin_low_N": (arr(self.margin_band_N[0])
                                    if self.margin_band_N is not None else None),
                   "margin_high_N": (arr(self.margin_band_N[1])
                                     if self.margin_band_N is not None else None),
                   "law": self.law},
               "paper_method": {"description": PAPER_METHOD,
                                **{c: fr.as_dict() for c, fr in self.paper_sets.items()},
                                "rod_N": {c: arr(a) for c, a in self.paper_rod_N.items()}}}
        return {"friction_sets": sets, "friction_envelope": env,
                "velocity_range": self.velocity_range_json()}

    def plot(self, **kw: Any) -> Any:
        """Envelope, sets and paper bounds against velocity (:mod:`ehsa_opt.plots.identify`)."""
        from ..plots import identify as P
        return P.friction_bounds(self, **kw)


def _campaign_grid(v_lo: float, v_data: float, v_max: float, n: int) -> np.ndarray:
    """The envelope grid up to the data (:func:`velocity_grid`) and beyond it to
    ``v_max`` (linear), with the data's edge on it."""
    inside = velocity_grid(v_data, n, v_lo)
    if v_max <= v_data * (1 + 1e-9):
        return inside
    beyond = np.linspace(v_data, v_max, max(int(round(n * 0.75)), 8))[1:]
    return np.unique(np.concatenate([inside, beyond]))


def friction_bounds(report: Any, n_grid: int = 48, v_max_m_per_s: float = V_MAX_M_PER_S,
                    level: float = 0.95, per_test_bands: bool = False) -> FrictionBounds:
    """Data-supported friction bounds and sets of an
    :class:`~ehsa_opt.estimation.identify.IdentificationReport` (see the module docstring).

    Parameters
    ----------
    report : IdentificationReport
    n_grid : int
        Grid points up to the data's largest velocity (three quarters as many beyond).
    v_max_m_per_s : float
        The sets are ordered and banded up to this velocity (default 3 m/s, the largest
        stroke velocity the vehicle studies meet).
    level : float
        Confidence level of the bands.
    per_test_bands : bool
        Widen every per-test curve by its own band before taking the envelope (default
        False: the spread of the per-test estimates already holds their estimation noise,
        and a single test's band at low velocity, where one sine test has few samples and
        the Stribeck parameters trade off, is so wide that it says nothing).

    Raises
    ------
    ValueError
        No successful per-test fit.
    """
    from .rod_law import friction_samples, rod_law_fit
    data = report.data
    gen = bool(data.has_generator)
    lead = float(data.harvester.lead_m_per_rad)
    good = [(t, f) for t, f in zip(data.tests, report.fits) if f.success]
    if not good:
        raise ValueError("friction_bounds: no successful per-test fit; nothing bounds the "
                         "friction")
    mass = data.harvester.equivalent_mass_kg() if gen else None
    vrange = np.array([test_velocity_range_m_per_s(t, mass) for t, _ in good])
    good = [g for g, rr in zip(good, vrange) if np.all(np.isfinite(rr))]
    vrange = vrange[np.all(np.isfinite(vrange), axis=1)]
    if not good:
        raise ValueError("friction_bounds: no per-test fit resolves any velocity")
    vpeak, vlow = vrange[:, 1], vrange[:, 0]
    v_data = float(vpeak.max())
    # from 10 % of the slowest test's peak velocity (the lowest velocity at which the
    # Fisher analysis evaluates the rod friction): below it a sine test spends too little
    # time for the data to determine the friction, and one test's Stribeck spike there
    # would set the bounds of every set
    v_lo = max(1e-3, 0.1 * float(vpeak.min()))
    v = _campaign_grid(v_lo, v_data, max(float(v_max_m_per_s), v_data), n_grid)
    # every recorded test's own speeds on the grid (a plateau speed between grid points
    # would otherwise reach no grid point)
    v = np.unique(np.concatenate([v, vrange[vlow > 0].ravel()]))
    frs = [_friction(f.parameters, gen) for _, f in good]
    curves = np.array([_rod(v, fr, lead) for fr in frs])
    joint = getattr(report, "joint", None)
    joint_ok = joint is not None and joint.success
    # friction samples: the frictionless model force depends on no fitted parameter on a
    # bench with generator; without one, on each fit's inertia and offset
    ref_params = joint.parameters if joint_ok else good[0][1].parameters
    samples_all = friction_samples(data, ref_params, tests=[t for t, _ in good]) if gen else None
    half = np.zeros_like(curves)
    if per_test_bands:
        for k, ((t, f), fr) in enumerate(zip(good, frs)):
            smp = (friction_samples(data, f.parameters, tests=[t]) if not gen else
                   type(samples_all)([t.file], [samples_all.velocity_m_per_s[k]],
                                     [samples_all.friction_N[k]]))
            half[k] = rod_law_fit(smp, fr.as_dict(), lead, has_generator=gen).half_width_N(
                v, level)
    reach = (v[None, :] <= vpeak[:, None] * (1.0 + 1e-9)) & (v[None, :] >= vlow[:, None])
    per_test = np.where(reach, curves, np.nan)
    with np.errstate(all="ignore"):
        import warnings
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            lower = np.nanmin(np.where(reach, curves - half, np.nan), axis=0)
            upper = np.nanmax(np.where(reach, curves + half, np.nan), axis=0)
            n = reach.sum(axis=0)
            mean = np.nanmean(per_test, axis=0)
            dev2 = np.nansum((per_test - mean) ** 2, axis=0)
    sd = np.where(n > 1, np.sqrt(dev2 / np.maximum(n - 1, 1)), 0.0)
    tq = np.where(n > 1, stats.t.ppf(0.975, np.maximum(n - 1, 1)), 0.0)
    ci = np.vstack([mean - tq * sd / np.sqrt(np.maximum(n, 1)),
                    mean + tq * sd / np.sqrt(np.maximum(n, 1))])
    ci[:, n == 0] = np.nan
    inside = n > 0
    band = ((f"per-test {100 * level:g} % sandwich band of the rod friction (the larger of "
             "Newey-West and cluster-robust; effective sample size of the autocorrelated "
             "residuals)") if per_test_bands else
            (f"envelope of the per-test fits, united with the best law's {100 * level:g} % "
             "sandwich band (the larger of Newey-West and cluster-robust over the tests: the "
             "effective sample size of autocorrelated residuals)"))
    best, best_source = None, ""
    if joint_ok:
        cand = _friction(joint.parameters, gen)
        rod = _rod(v[inside], cand, lead)
        tol = 0.02 * np.maximum(np.abs(upper[inside]), 1.0)
        if np.all((rod >= lower[inside] - tol) & (rod <= upper[inside] + tol)):
            best, best_source = cand, "joint fit"
        else:
            best_source = ("fit to the across-test mean with the joint fit's split (the joint "
                           "fit's rod friction leaves the envelope)")
            best = fit_envelope(mean[inside], v[inside], cand, lead, "fit")
    if best is None:
        k = int(np.argmin(np.nanmean(np.abs(per_test - mean) / np.maximum(mean, 1e-9), axis=1)))
        best, best_source = frs[k], f"per-test fit closest to the mean ({good[k][0].file})"
    # the best law's band over the whole grid: every successful test's samples
    if samples_all is None:
        samples_all = friction_samples(data, ref_params, tests=[t for t, _ in good])
    law = rod_law_fit(samples_all, best.as_dict(), lead, has_generator=gen, refit=True)
    rod_best = _rod(v, best, lead)
    stat = law.half_width_N(v, level) + np.abs(rod_best - law.rod_N(v))
    # margins of the sets below / above the best set: inside the data the envelope of the
    # tests and the best law's band, whichever is wider; beyond it the band, plus the
    # envelope's excess over the band at the data's edge carried in proportion to the
    # friction (a spread between the tests that the statistics do not explain persists)
    lo_m = np.where(inside, np.fmax(rod_best - lower, stat), stat)
    hi_m = np.where(inside, np.fmax(upper - rod_best, stat), stat)
    edge = int(np.flatnonzero(inside)[-1])
    out = ~inside & (v > v_data)
    scale = rod_best / max(rod_best[edge], 1e-9)
    lo_m = np.where(out, stat + max(lo_m[edge] - stat[edge], 0.0) * scale, lo_m)
    hi_m = np.where(out, stat + max(hi_m[edge] - stat[edge], 0.0) * scale, hi_m)
    sets = {"min": ordered_set(best, v, lo_m, lead, "below", gen), "best": best,
            "max": ordered_set(best, v, hi_m, lead, "above", gen)}
    paper = (paper_friction_sets(report.bounds, gen, fill=good[0][1].parameters)
             if report.bounds else {})
    return FrictionBounds(v, per_test, lower, upper, mean, ci, sets,
                          {c: _rod(v, fr, lead) for c, fr in sets.items()}, paper,
                          {c: _rod(v, fr, lead) for c, fr in paper.items()}, lead,
                          [t.file for t, _ in good], band,
                          DATA_METHOD + f"; best = {best_source}",
                          np.vstack([rod_best - stat, rod_best + stat]),
                          np.vstack([rod_best - lo_m, rod_best + hi_m]),
                          (v_lo, v_data), dict(zip([t.file for t, _ in good], vpeak.tolist())),
                          law.summary(), level)


def identification_json(report: Any) -> dict:
    """``report.to_json()`` plus ``friction_sets`` and ``friction_envelope`` (the file
    ``ehsa-opt identify`` writes; read back by
    :func:`ehsa_opt.datasets.friction_source.load_friction_sets`)."""
    doc = report.to_json()
    try:
        fb = friction_bounds(report)
    except ValueError as exc:
        doc["friction_sets_note"] = str(exc)
        return doc
    doc.update(fb.to_json())
    return doc


def envelope_lines(doc: Mapping[str, Any], path: Any) -> list[str]:
    """Printed summary of an identification.json's sets: rod friction of ``min`` /
    ``best`` / ``max`` and of the paper's sets inside the identified range and beyond it
    (marked as extrapolated)."""
    env = doc.get("friction_envelope")
    if not env:
        return []
    v = np.array(env["velocity_m_per_s"], dtype=float)
    hi = (env.get("identified_range_m_per_s") or [0.0, float(v.max())])[1]
    at = [x for x in (0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 3.0) if x <= v.max() + 1e-9]
    out = ["  rod friction (N) at " + ", ".join(f"{x:g}" for x in at) + " m/s "
           f"(identified up to {hi:.3g} m/s; * = extrapolated):",
           "          " + "  ".join(f"{x:6g}{'*' if x > hi else ' '}" for x in at)]
    for case in ("min", "best", "max"):
        vals = np.interp(at, v, np.array(env["sets_rod_N"][case], dtype=float))
        out.append(f"    {case:<5s} " + "  ".join(f"{x:7.1f}" for x in vals))
    for case in ("min", "max"):
        vals = np.interp(at, v, np.array(env["paper_method"]["rod_N"].get(case, [np.nan] * v.size),
                                         dtype=float))
        out.append(f"    paper {case} " + "  ".join(f"{x:7.1f}" for x in vals)
                   + "  (paper's per-parameter method)")
    out.append(f"  friction sets min/best/max: {path}:CASE (--friction, or [friction] from = "
               f"... in a problem file); min <= best <= max at every velocity up to "
               f"{float(v.max()):g} m/s")
    return out
