"""Friction bounds the bench data determine (issue 13): envelope of the identifiable rod
friction and the ``min`` / ``best`` / ``max`` friction sets of every vehicle study.

A rigid bench determines only the friction *at the rod*,
F_rod(v) = F_ns(v) + T_b(v/r)/r (SPEC §2, identifiability), and only at the velocities a
test actually reaches.  For every successful per-test fit the rod friction is evaluated on
a velocity grid (from 10 % of the slowest test's peak velocity, where the Fisher
analysis starts) up to the test's peak velocity, widened by that fit's 95 % Gauss–Newton
(Fisher) confidence half-width of the rod friction (the per-test
``identifiability["combinations"]`` at four velocities, interpolated linearly in v); the
**envelope** is the pointwise minimum of the lower and maximum of the upper curves over
the tests that reach that velocity.  The across-test mean with its Student-t 95 %
interval is reported beside it.

Friction sets (admissible :class:`~ehsa_opt.physics.params.FrictionParams`):

``best``
    the joint fit (one parameter set for the training tests) when its rod friction lies
    in the envelope (2 % tolerance); otherwise a least-squares fit to the across-test mean
    with the joint fit's split; without a joint fit, the per-test fit whose rod friction
    is closest to the across-test mean.
``min`` / ``max``
    rod friction realising the lower / upper envelope: the bearing torques of ``best``
    times one factor (the *shape* of the split is the joint fit's, which the data do not
    determine), that factor and the four nut parameters fitted by least squares on the
    grid, subject to staying at or below (``min``) / at or above (``max``) the
    envelope at every grid velocity, so the sets bracket everything the data support.

The paper's method — per-parameter minimum and maximum over the tests
(:func:`paper_friction_sets`) — is kept as an option.  It over-states the spread: the
nut/bearing split is not determined by the data, so each raw parameter wanders from test
to test although the rod total does not, and combining all minima (maxima) adds up
spreads that cancel in every single fit; taking the largest breakaway velocity with the
largest breakaway force makes a Stribeck hump no test shows.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from scipy import optimize, stats

from ..physics.friction import bearing_friction_Nm, rod_friction_N, simscape_friction
from ..physics.params import FRICTION_NAMES, FrictionParams

__all__ = ["FrictionBounds", "friction_bounds", "paper_friction_sets", "velocity_grid",
           "test_peak_velocity_m_per_s", "test_velocity_range_m_per_s", "identification_json", "DATA_METHOD", "PAPER_METHOD",
           "fit_envelope"]

DATA_METHOD = ("data-supported: envelope of the identifiable rod friction "
               "F_ns(v) + T_b(v/r)/r over the per-test fits, each widened by its 95 % "
               "Gauss-Newton (Fisher) confidence band and used only up to the test's peak "
               "velocity, grid from 10 % of the slowest test's peak velocity; min/max = the best set's bearing torques times a fitted factor, nut "
               "parameters fitted by constrained least squares below/above the envelope")
PAPER_METHOD = ("paper's method: per-parameter minimum/maximum over the per-test fits "
                "(over-states the spread: the nut/bearing split is not determined by the "
                "data, and the largest breakaway velocity makes a spurious Stribeck hump)")

_NUT = FRICTION_NAMES[:4]
_BEARING = FRICTION_NAMES[4:]
_COMBO = re.compile(r"^rod_friction_N_at_([0-9.eE+-]+)_m_per_s$")
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


def test_peak_velocity_m_per_s(test: Any) -> float:
    """Peak rod velocity of a bench test: 2π f A for a sine test, else the 99th
    percentile of |v| of a smoothing spline through the measured displacement."""
    if getattr(test, "excitation", "sine") == "sine" and test.frequency_hz and test.amplitude_m:
        return 2.0 * math.pi * float(test.frequency_hz) * float(test.amplitude_m)
    from ..physics.motion import SampledMotion
    t, x = np.asarray(test.time_s), np.asarray(test.displacement_m)
    step = max(1, t.size // 2000)
    motion = SampledMotion(t[::step], x[::step])
    v = motion.evaluate(t[::step])[1]
    return float(np.percentile(np.abs(v), 99.0))


def test_velocity_range_m_per_s(test: Any, mass_kg: float | None = None
                                ) -> tuple[float, float]:
    """Rod speeds at which a test's data determine the friction, m/s: (0, peak) for a
    sine test; for a recorded test the 1st–99th percentile of |v| over the samples the
    fit used (outside the corner and dwell windows of
    :func:`~ehsa_opt.estimation.identify_options.estimate_motion`) — a constant-velocity
    stroke says nothing about the friction between its plateau speed and zero, which it
    crosses only inside the reversal windows."""
    if getattr(test, "excitation", "sine") == "sine" and test.frequency_hz and test.amplitude_m:
        return 0.0, test_peak_velocity_m_per_s(test)
    from .identify_options import estimate_motion
    est = estimate_motion(test, None, mass_kg)
    v = np.abs(est.motion.evaluate(test.time_s)[1])[est.resolved]
    if v.size < 10:
        return math.nan, math.nan  # nothing resolved: the test bounds nothing
    return float(np.percentile(v, 1.0)), float(np.percentile(v, 99.0))


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


def _fisher_half_width(ident: Mapping[str, Any] | None, v: np.ndarray) -> np.ndarray | None:
    """95 % half-width of the rod friction of one fit, interpolated on ``v``."""
    if not ident:
        return None
    pts = []
    for name, c in (ident.get("combinations") or {}).items():
        m = _COMBO.match(name)
        if m and c.get("ci95") is not None and None not in c["ci95"]:
            lo, hi = c["ci95"]
            pts.append((float(m.group(1)), 0.5 * abs(float(hi) - float(lo))))
    if not pts:
        return None
    pts.sort()
    xs, hw = np.array([p[0] for p in pts]), np.array([p[1] for p in pts])
    return np.interp(v, xs, hw)


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
               "paper_method": {"description": PAPER_METHOD,
                                **{c: fr.as_dict() for c, fr in self.paper_sets.items()},
                                "rod_N": {c: arr(a) for c, a in self.paper_rod_N.items()}}}
        return {"friction_sets": sets, "friction_envelope": env}

    def plot(self, **kw: Any) -> Any:
        """Envelope, sets and paper bounds against velocity (:mod:`ehsa_opt.plots.identify`)."""
        from ..plots import identify as P
        return P.friction_bounds(self, **kw)


def friction_bounds(report: Any, n_grid: int = 48) -> FrictionBounds:
    """Data-supported friction bounds and sets of an
    :class:`~ehsa_opt.estimation.identify.IdentificationReport` (see the module docstring).

    Raises
    ------
    ValueError
        No successful per-test fit.
    """
    data = report.data
    gen = bool(data.has_generator)
    lead = float(data.harvester.lead_m_per_rad)
    good = [(t, f) for t, f in zip(data.tests, report.fits) if f.success]
    if not good:
        raise ValueError("friction_bounds: no successful per-test fit; nothing bounds the "
                         "friction")
    mass = data.harvester.equivalent_mass_kg() if gen else None
    vrange = np.array([test_velocity_range_m_per_s(t, mass) for t, _ in good])
    good = [g for g, r in zip(good, vrange) if np.all(np.isfinite(r))]
    vrange = vrange[np.all(np.isfinite(vrange), axis=1)]
    if not good:
        raise ValueError("friction_bounds: no per-test fit resolves any velocity")
    vpeak, vlow = vrange[:, 1], vrange[:, 0]
    # from 10 % of the slowest test's peak velocity (the lowest velocity at which the
    # Fisher analysis evaluates the rod friction): below it a sine test spends too little
    # time for the data to determine the friction, and one test's Stribeck spike there
    # would set the bounds of every set
    v = velocity_grid(float(vpeak.max()), n_grid, max(1e-3, 0.1 * float(vpeak.min())))
    # every recorded test's own speeds on the grid (a plateau speed between grid points
    # would otherwise reach no grid point)
    v = np.unique(np.concatenate([v, vrange[vlow > 0].ravel()]))
    frs = [_friction(f.parameters, gen) for _, f in good]
    curves = np.array([_rod(v, fr, lead) for fr in frs])
    half = []
    fisher = True
    for (_, f), c in zip(good, curves):
        hw = _fisher_half_width(f.identifiability, v)
        fisher &= hw is not None
        half.append(hw if hw is not None else np.zeros_like(v))
    half = np.array(half)
    reach = (v[None, :] <= vpeak[:, None] * (1.0 + 1e-9)) & (v[None, :] >= vlow[:, None])
    per_test = np.where(reach, curves, np.nan)
    lower = np.nanmin(np.where(reach, curves - half, np.nan), axis=0)
    upper = np.nanmax(np.where(reach, curves + half, np.nan), axis=0)
    n = reach.sum(axis=0)
    mean = np.nanmean(per_test, axis=0)
    dev2 = np.nansum((per_test - mean) ** 2, axis=0)
    sd = np.where(n > 1, np.sqrt(dev2 / np.maximum(n - 1, 1)), 0.0)
    tq = np.where(n > 1, stats.t.ppf(0.975, np.maximum(n - 1, 1)), 0.0)
    ci = np.vstack([mean - tq * sd / np.sqrt(n), mean + tq * sd / np.sqrt(n)])
    band = ("per-test 95 % Gauss-Newton (Fisher) confidence half-width of the rod friction"
            if fisher else "none (no Fisher information in the fits): envelope of the fits")
    joint = getattr(report, "joint", None)
    best, best_source = None, ""
    if joint is not None and joint.success:
        cand = _friction(joint.parameters, gen)
        rod = _rod(v, cand, lead)
        tol = 0.02 * np.maximum(np.abs(upper), 1.0)
        if np.all((rod >= lower - tol) & (rod <= upper + tol)):
            best, best_source = cand, "joint fit"
        else:
            best_source = ("fit to the across-test mean with the joint fit's split (the joint "
                           "fit's rod friction leaves the envelope)")
            best = fit_envelope(mean, v, cand, lead, "fit")
    if best is None:
        k = int(np.argmin(np.nanmean(np.abs(per_test - mean) / np.maximum(mean, 1e-9), axis=1)))
        best, best_source = frs[k], f"per-test fit closest to the mean ({good[k][0].file})"
    sets = {"min": fit_envelope(lower, v, best, lead, "below"), "best": best,
            "max": fit_envelope(upper, v, best, lead, "above")}
    paper = (paper_friction_sets(report.bounds, gen, fill=good[0][1].parameters)
             if report.bounds else {})
    return FrictionBounds(v, per_test, lower, upper, mean, ci, sets,
                          {c: _rod(v, fr, lead) for c, fr in sets.items()}, paper,
                          {c: _rod(v, fr, lead) for c, fr in paper.items()}, lead,
                          [t.file for t, _ in good], band,
                          DATA_METHOD + f"; best = {best_source}")


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
