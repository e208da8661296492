"""Friction bounds the bench data determine: envelope of the identifiable rod
friction and the ``min`` / ``best`` / ``max`` friction sets of every vehicle study.

A rigid bench determines only the friction *at the rod*,
F_rod(v) = F_ns(v) + T_b(v/r)/r (the nut/bearing split is not identifiable), and only at the velocities a
test actually reaches.  For every successful per-test fit the rod friction is evaluated on
a velocity grid from the lowest speed any test covers by its protocol (a sine from 10 % of
its peak velocity, where the Fisher analysis starts; a constant-velocity stroke or another
recorded motion from its lowest resolved speed) up to each test's peak velocity; the **envelope** is the pointwise minimum and
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

import json
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from scipy import stats

from ..physics.params import (FRICTION_LAW_NAMES, FRICTION_NAMES, PRESLIDING_PARAMETER_NAMES,
                              FrictionParams, ParameterError)
from ..utils.io import json_safe
from .ordered_sets import ENVELOPE_PARAMETERS, fit_envelope, friction_set, ordered_set, rod_curve_N
from .test_velocity import test_peak_velocity_m_per_s, test_velocity_range_m_per_s

__all__ = ["FrictionBounds", "friction_bounds", "paper_friction_sets", "velocity_grid",
           "test_peak_velocity_m_per_s", "test_velocity_range_m_per_s",
           "covered_low_m_per_s", "campaign_low_m_per_s", "SINE_LOW_FRACTION",
           "identification_dict", "identification_json", "DATA_METHOD", "PAPER_METHOD",
           "fit_envelope", "ordered_set", "ENVELOPE_PARAMETERS", "V_MAX_M_PER_S", "envelope_lines"]

#: Velocity up to which the sets are ordered and banded (the vehicle studies' largest).
V_MAX_M_PER_S = 3.0

DATA_METHOD = ("data-supported: envelope of the identifiable rod friction "
               "F_ns(v) + T_b(v/r)/r over the per-test fits, each used only up to the "
               "test's peak velocity (grid from the lowest speed a test covers: 10 % of a "
               "sine's peak velocity, a recorded motion's lowest resolved speed), "
               "united with the best law's 95 % sandwich band (Newey-West / cluster-robust: "
               "effective sample size), which alone continues beyond the data to 3 m/s; "
               "min/max = the best set minus/plus non-negative amounts of its own Coulomb, "
               "Stribeck and viscous shapes (linear programme), so min <= best <= max at "
               "every velocity")
PAPER_METHOD = ("paper's method: per-parameter minimum/maximum over the per-test fits "
                "(over-states the spread: the nut/bearing split is not determined by the "
                "data, and the largest breakaway velocity makes a spurious Stribeck hump)")

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
        out[case] = friction_set(vals, has_generator)
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
                               "otherwise); the campaign from the lowest speed a test covers by its "
                               "protocol (a sine from 10 % of its peak, a recorded motion such "
                               "as constant-velocity strokes from its lowest resolved speed, "
                               "the 1st percentile outside the reversals) to the fastest "
                               "test's peak; "
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
                out[f"{name}{case}_N"] = float(rod_curve_N(np.array([v_m_per_s]), fr,
                                                    self.lead_m_per_rad)[0])
        return out

    def to_dict(self) -> dict:
        """``friction_sets``, ``friction_envelope`` and ``velocity_range`` tables of
        identification.json (standard-JSON types; :meth:`from_dict` reloads them)."""
        def arr(a: np.ndarray) -> list:
            return [None if not np.isfinite(x) else float(x) for x in np.asarray(a).ravel()]
        sets = {c: {**fr.as_dict(), **fr.law_dict()} for c, fr in self.sets.items()}
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
                   "law": self.law, "level": self.level},
               "paper_method": {"description": PAPER_METHOD,
                                **{c: fr.as_dict() for c, fr in self.paper_sets.items()},
                                "rod_N": {c: arr(a) for c, a in self.paper_rod_N.items()}}}
        return {"friction_sets": sets, "friction_envelope": env,
                "velocity_range": self.velocity_range_json()}

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON text (reloaded by :meth:`from_json`)."""
        return json.dumps(json_safe(self.to_dict()), indent=1, allow_nan=False)

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], where: str = "friction bounds"
                  ) -> "FrictionBounds":
        """Reload the bounds from :meth:`to_dict`, or from an identification.json as
        ``ehsa-opt identify`` writes it (its ``friction_sets`` / ``friction_envelope`` /
        ``velocity_range`` tables), to inspect or plot them.  Validated as received data
        first (:func:`~ehsa_opt.datasets.identification_file.check_identification`: sets
        physical and ordered, curves finite and as long as the grid, ranges ordered,
        covariances positive semi-definite); a bad document raises
        :class:`~ehsa_opt.physics.params.ParameterError` naming ``where`` and the key."""
        from ..datasets.identification_file import RERUN, check_identification
        doc = check_identification(doc, where)
        if "friction_envelope" not in doc or "friction_sets" not in doc:
            note = doc.get("friction_sets_note")
            raise ParameterError(f"{where}: no friction_sets / friction_envelope tables"
                                 + (f" ({str(note)[:200]})" if note else
                                    "; identify the data first"))
        env = doc["friction_envelope"]
        for key in ("velocity_m_per_s", "lower_N", "upper_N", "mean_N", "mean_ci95_low_N",
                    "mean_ci95_high_N", "sets_rod_N", "lead_m_per_rad"):
            if not isinstance(env, Mapping) or env.get(key) is None:
                raise ParameterError(f"{where}: friction_envelope has no '{key}'; {RERUN}")
        try:
            return cls._build(doc)
        except (KeyError, TypeError, AttributeError, IndexError, ValueError) as exc:
            raise ParameterError(f"{where}: a table does not hold what the bounds need "
                                 f"({type(exc).__name__}: {str(exc)[:200]}); {RERUN}") from None

    @classmethod
    def _build(cls, doc: Mapping[str, Any]) -> "FrictionBounds":
        env, sets = doc["friction_envelope"], doc["friction_sets"]
        band = env.get("extrapolation_band") or {}
        paper = env.get("paper_method") or {}

        def arr(x: Any) -> np.ndarray:
            return np.array([math.nan if v is None else v for v in x], dtype=float)

        def pair(lo: Any, hi: Any) -> np.ndarray | None:
            return None if lo is None or hi is None else np.vstack([arr(lo), arr(hi)])

        def params(d: Mapping[str, Any]) -> FrictionParams:
            law = {n: d[n] for n in FRICTION_LAW_NAMES if n in d}
            return FrictionParams(**{n: float(d[n]) for n in FRICTION_NAMES}, **law)

        cases = [c for c in sets if c != "method"]
        per = env.get("per_test_N") or {}
        v = arr(env["velocity_m_per_s"])
        peaks = (doc.get("velocity_range") or {}).get("tests_peak_m_per_s") or {}
        return cls(v, np.array([arr(r) for r in per.values()]).reshape(len(per), v.size),
                   arr(env["lower_N"]), arr(env["upper_N"]), arr(env["mean_N"]),
                   pair(env["mean_ci95_low_N"], env["mean_ci95_high_N"]),
                   {c: params(sets[c]) for c in cases},
                   {c: arr(x) for c, x in env["sets_rod_N"].items()},
                   {c: params(paper[c]) for c in ("min", "max") if c in paper},
                   {c: arr(x) for c, x in (paper.get("rod_N") or {}).items()},
                   float(env["lead_m_per_rad"]), list(per), env.get("band", ""),
                   sets.get("method", DATA_METHOD),
                   pair(band.get("law_low_N"), band.get("law_high_N")),
                   pair(band.get("margin_low_N"), band.get("margin_high_N")),
                   tuple(math.nan if x is None else float(x)
                         for x in env.get("identified_range_m_per_s") or (None, None)),
                   {k: float(x) for k, x in peaks.items()}, dict(band.get("law") or {}),
                   float(band.get("level", 0.95)))

    @classmethod
    def from_json(cls, text: str | bytes, where: str = "friction bounds") -> "FrictionBounds":
        """Reload bounds written by :meth:`to_json` (or an identification.json's text),
        through the shared JSON limits (nesting, standard constants)."""
        from ..utils.limits import parse_json
        return cls.from_dict(parse_json(text, where, ParameterError), where)

    def plot(self, ax: Any = None, **kw: Any) -> Any:
        """Envelope, sets and paper bounds against velocity (two panels, ``ax`` not used;
        :mod:`ehsa_opt.plots.identify`); writes nothing."""
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
    good, vrange = _usable_fits(report)
    vpeak, vlow = vrange[:, 1], vrange[:, 0]
    v, v_lo, v_data = _bounds_grid(vrange, v_max_m_per_s, n_grid)
    frs = [friction_set(f.parameters, gen) for _, f in good]
    joint = getattr(report, "joint", None)
    joint_ok = joint is not None and joint.success
    # friction samples: the frictionless model force depends on no fitted parameter on a
    # bench with generator; without one, on each fit's inertia and offset
    ref_params = joint.parameters if joint_ok else good[0][1].parameters
    samples_all = friction_samples(data, ref_params, tests=[t for t, _ in good]) if gen else None
    half = (_per_test_half_widths(data, good, frs, samples_all, v, lead, level)
            if per_test_bands else np.zeros((len(frs), v.size)))
    env = _envelope(v, np.array([rod_curve_N(v, fr, lead) for fr in frs]), half, vlow, vpeak)
    band = ((f"per-test {100 * level:g} % sandwich band of the rod friction (the larger of "
             "Newey-West and cluster-robust; effective sample size of the autocorrelated "
             "residuals)") if per_test_bands else
            (f"envelope of the per-test fits, united with the best law's {100 * level:g} % "
             "sandwich band (the larger of Newey-West and cluster-robust over the tests: the "
             "effective sample size of autocorrelated residuals)"))
    best, best_source = _best_set(env, v, good, frs, joint if joint_ok else None, gen, lead)
    # the best law's band over the whole grid: every successful test's samples
    if samples_all is None:
        samples_all = friction_samples(data, ref_params, tests=[t for t, _ in good])
    law = rod_law_fit(samples_all, best.as_dict(), lead, has_generator=gen, refit=True)
    rod_best = rod_curve_N(v, best, lead)
    stat = law.half_width_N(v, level) + np.abs(rod_best - law.rod_N(v))
    lo_m, hi_m = _set_margins(v, env, v_data, rod_best, stat)
    sets = {"min": ordered_set(best, v, lo_m, lead, "below", gen), "best": best,
            "max": ordered_set(best, v, hi_m, lead, "above", gen)}
    bristle = presliding_law(report, good)
    if bristle:  # the sets bound the steady state; the bristle is the identified one
        sets = {c: fr.with_law("lugre", **bristle) for c, fr in sets.items()}
    paper = (paper_friction_sets(report.bounds, gen, fill=good[0][1].parameters)
             if report.bounds else {})
    return FrictionBounds(v, env.per_test, env.lower, env.upper, env.mean, env.ci, sets,
                          {c: rod_curve_N(v, fr, lead) for c, fr in sets.items()}, paper,
                          {c: rod_curve_N(v, fr, lead) for c, fr in paper.items()}, lead,
                          [t.file for t, _ in good], band,
                          DATA_METHOD + f"; best = {best_source}",
                          np.vstack([rod_best - stat, rod_best + stat]),
                          np.vstack([rod_best - lo_m, rod_best + hi_m]),
                          (v_lo, v_data), dict(zip([t.file for t, _ in good], vpeak.tolist())),
                          law.to_dict(), level)


def presliding_law(report: Any, good: Sequence[tuple[Any, Any]]) -> dict[str, float]:
    """The presliding parameters the friction sets carry under the LuGre law (``{}`` under
    the static law): the joint fit's when it converged, else the median over the
    successful per-test fits (N/m, N s/m).  The three sets share them: the sets bound the
    steady-state friction, the bristle is the identified one."""
    if getattr(report, "friction_law", "static") != "lugre":
        return {}
    joint = getattr(report, "joint", None)
    if joint is not None and joint.success and all(
            joint.parameters.get(n) is not None for n in PRESLIDING_PARAMETER_NAMES):
        return {n: float(joint.parameters[n]) for n in PRESLIDING_PARAMETER_NAMES}
    return {n: float(np.median([f.parameters[n] for _, f in good]))
            for n in PRESLIDING_PARAMETER_NAMES}


def _usable_fits(report: Any) -> tuple[list, np.ndarray]:
    """The (test, fit) pairs whose fit succeeded and resolves a velocity range, and those
    ranges (tests × [lowest, peak] rod velocity, m/s)."""
    data = report.data
    good = [(t, f) for t, f in zip(data.tests, report.fits) if f.success]
    if not good:
        raise ValueError("friction_bounds: no successful per-test fit; nothing bounds the "
                         "friction")
    mass = data.harvester.equivalent_mass_kg() if data.has_generator else None
    vrange = np.array([test_velocity_range_m_per_s(t, mass) for t, _ in good])
    good = [g for g, rr in zip(good, vrange) if np.all(np.isfinite(rr))]
    vrange = vrange[np.all(np.isfinite(vrange), axis=1)]
    if not good:
        raise ValueError("friction_bounds: no per-test fit resolves any velocity")
    return good, vrange


def _bounds_grid(vrange: np.ndarray, v_max_m_per_s: float, n_grid: int
                 ) -> tuple[np.ndarray, float, float]:
    """The velocity grid of the bounds, its lower end and the data's largest velocity."""
    vpeak, vlow = vrange[:, 1], vrange[:, 0]
    v_data = float(vpeak.max())
    v_lo = campaign_low_m_per_s(vrange)
    v = _campaign_grid(v_lo, v_data, max(float(v_max_m_per_s), v_data), n_grid)
    # every recorded test's own speeds on the grid (a plateau speed between grid points
    # would otherwise reach no grid point)
    v = np.unique(np.concatenate([v, vrange[vlow > 0].ravel()]))
    return v, v_lo, v_data


#: A sine test covers its speeds from this fraction of its peak velocity (below it, the
#: lowest velocity at which the Fisher analysis evaluates the rod friction, a sine spends
#: too little time for its data to determine the friction).
SINE_LOW_FRACTION = 0.1


def covered_low_m_per_s(v_low_m_per_s: float, v_peak_m_per_s: float) -> float:
    """The lowest speed a test covers, by its protocol: a sine (lowest resolved speed 0)
    from :data:`SINE_LOW_FRACTION` of its peak; a recorded motion (constant-velocity
    strokes, trapezoids, ...) from its lowest resolved speed — a constant-velocity stroke
    holds its plateau speed and crosses the lower speeds only inside its reversals."""
    if v_low_m_per_s > 0:
        return float(v_low_m_per_s)
    return SINE_LOW_FRACTION * float(v_peak_m_per_s)


def campaign_low_m_per_s(vrange: np.ndarray) -> float:
    """Lower end of the campaign's bench range (m/s): the lowest speed any test covers
    (:func:`covered_low_m_per_s`), at least 1 mm/s."""
    lows = [covered_low_m_per_s(lo, hi) for lo, hi in np.asarray(vrange, dtype=float)]
    return max(1e-3, min(lows))


def _per_test_half_widths(data: Any, good: list, frs: list[FrictionParams], samples_all: Any,
                          v: np.ndarray, lead: float, level: float) -> np.ndarray:
    """Every per-test curve's own sandwich half-width on ``v`` (tests × grid, N)."""
    from .rod_law import friction_samples, rod_law_fit
    gen = bool(data.has_generator)
    half = np.zeros((len(frs), v.size))
    for k, ((t, f), fr) in enumerate(zip(good, frs)):
        smp = (friction_samples(data, f.parameters, tests=[t]) if not gen else
               type(samples_all)([t.file], [samples_all.velocity_m_per_s[k]],
                                 [samples_all.friction_N[k]]))
        half[k] = rod_law_fit(smp, fr.as_dict(), lead, has_generator=gen).half_width_N(v, level)
    return half


@dataclass
class _Envelope:
    """The per-test curves where each test reaches, their envelope and across-test mean."""

    per_test: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    mean: np.ndarray
    ci: np.ndarray
    inside: np.ndarray


def _envelope(v: np.ndarray, curves: np.ndarray, half: np.ndarray, vlow: np.ndarray,
              vpeak: np.ndarray) -> _Envelope:
    """Envelope (pointwise min/max of the curves ± their half-widths, each used only at the
    velocities its test reaches), mean and its 95 % t interval over the tests."""
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
    return _Envelope(per_test, lower, upper, mean, ci, n > 0)


def _best_set(env: _Envelope, v: np.ndarray, good: list, frs: list[FrictionParams],
              joint: Any, gen: bool, lead: float) -> tuple[FrictionParams, str]:
    """The best set and where it comes from: the joint fit when its rod friction stays in
    the envelope, else a fit to the across-test mean with its split; without a joint fit,
    the per-test fit closest to the mean."""
    inside = env.inside
    if joint is not None:
        cand = friction_set(joint.parameters, gen)
        rod = rod_curve_N(v[inside], cand, lead)
        tol = 0.02 * np.maximum(np.abs(env.upper[inside]), 1.0)
        if np.all((rod >= env.lower[inside] - tol) & (rod <= env.upper[inside] + tol)):
            return cand, "joint fit"
        return (fit_envelope(env.mean[inside], v[inside], cand, lead, "fit"),
                "fit to the across-test mean with the joint fit's split (the joint "
                "fit's rod friction leaves the envelope)")
    k = int(np.argmin(np.nanmean(np.abs(env.per_test - env.mean)
                                 / np.maximum(env.mean, 1e-9), axis=1)))
    return frs[k], f"per-test fit closest to the mean ({good[k][0].file})"


def _set_margins(v: np.ndarray, env: _Envelope, v_data: float, rod_best: np.ndarray,
                 stat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Margins of the min / max sets below / above the best set (N on the grid)."""
    # inside the data the envelope of the tests and the best law's band, whichever is
    # wider; beyond it the band, plus the envelope's excess over the band at the data's
    # edge carried in proportion to the friction (a spread between the tests that the
    # statistics do not explain persists)
    inside = env.inside
    lo_m = np.where(inside, np.fmax(rod_best - env.lower, stat), stat)
    hi_m = np.where(inside, np.fmax(env.upper - rod_best, stat), stat)
    edge = int(np.flatnonzero(inside)[-1])
    out = ~inside & (v > v_data)
    scale = rod_best / max(rod_best[edge], 1e-9)
    lo_m = np.where(out, stat + max(lo_m[edge] - stat[edge], 0.0) * scale, lo_m)
    hi_m = np.where(out, stat + max(hi_m[edge] - stat[edge], 0.0) * scale, hi_m)
    return lo_m, hi_m


def identification_dict(report: Any) -> dict:
    """``report.to_dict()`` plus ``friction_sets`` and ``friction_envelope`` (the file
    ``ehsa-opt identify`` writes; read back by
    :func:`ehsa_opt.datasets.friction_source.load_friction_sets`,
    :meth:`IdentificationReport.from_dict
    <ehsa_opt.estimation.identify_result.IdentificationReport.from_dict>` and
    :meth:`FrictionBounds.from_dict`)."""
    doc = report.to_dict()
    try:
        fb = friction_bounds(report)
    except ValueError as exc:
        doc["friction_sets_note"] = str(exc)
        return doc
    doc.update(fb.to_dict())
    return doc


def identification_json(report: Any) -> str:
    """:func:`identification_dict` as JSON text (the content of identification.json)."""
    return json.dumps(json_safe(identification_dict(report)), indent=1, allow_nan=False)


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
