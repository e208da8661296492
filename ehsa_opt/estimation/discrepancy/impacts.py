"""Impact-aware fit of a stiff contact (a backlash whose contact is steel-like).

Why a sample-wise fit cannot work there.  A contact of stiffness k on the
rotor-equivalent mass m = J/r² (47.5 kg on the prototype) rings at
f = √(k/m)/2π and an impact lasts T_c ≈ π √(m/k): 231 Hz and 2.2 ms at 1e8 N/m,
730 Hz and 0.7 ms at 1e9 N/m — one sample or none at 1 kHz.  On a lightly loaded
generator the rotor rattles through the gap (a coefficient of restitution near
0.9 at a damping ratio of 0.02–0.03), and *which* sample an impact lands on
depends on the integration error itself: at the true parameters the simulated
force moves by many noise levels between tolerances 1e-7 and 1e-9
(:func:`~.candidate_fit.reproducibility`).  The sample-wise likelihood is then a rough,
chaotic function of the contact parameters; its fits stall at their starts.

What does not depend on the chaos.  The sampling clock is independent of the
impact times, so over the many impacts of a test the sampling phase is uniformly
distributed, and *how much* transient each test holds is a stable quantity even
when *when* it happens is not.  Per test and channel (force, voltage) this module
uses the sampled transient energies

    e₁ = Σ (Δy)² − 2(N−1)σ²,      e₂ = Σ (Δ²y)² − 6(N−2)σ²

(first and second differences over the resolved samples, less their noise
expectation, σ the channel's noise level).  Differencing removes the slow
(inertia, generator, friction) part; what is left is the impacts and the
contact ringing.  Their physics:

* an impact of relative velocity u puts the energy ½ m u² into the contact; its
  force peak is u √(k m) and lasts π √(m/k) — the force energy Σ F² a test holds
  grows like √k for separate impacts and like k for a ringing contact;
* the difference operators weigh a ring of frequency f by 4 sin²(π f/f_s) (e₁)
  and 16 sin⁴(π f/f_s) (e₂) — the sampled ringing frequency (aliased above the
  Nyquist frequency) is in their ratio, its amplitude in their size;
* the rotor speed (voltage channel) jumps by (1 + e) u at each impact, e the
  coefficient of restitution that the contact damping sets — so the voltage
  energies carry the damping, and the gap (how long the rotor coasts, how fast it
  arrives) sets u itself.

A second feature pins the gap without a force model: the voltage gives the rotor speed,
so the rotor's travel relative to the rod between the fast parts of consecutive strokes
is the gap plus the contact deflection (:func:`kinematic_gap`); the same statistic is
computed on the simulated voltage, so a rotor still bouncing on its face at mid-stroke
is matched rather than mistaken for a smaller gap.

The objective (:func:`impact_objective`) is the mean squared standardised mismatch of
these features between the forward simulation and the data — never sample by sample.
:func:`fit_impacts` minimises it over (gap, log k, log c): a screen of the bearing share
of the friction (a rigid baseline lumps it into the nut, but the bearing brakes the
coasting rotor) and of its breakaway bump (:mod:`.impact_friction`), a grid of stiffnesses 1e6–3e9 N/m in half decades (the aliasing makes
the objective multimodal in k) and two dampings at the kinematic gap, then
Nelder–Mead, within a fixed budget of simulations (a stated stop, never an open-ended
search).  From a rigid baseline's friction (the workflow) the features are widened by
what ±5 % friction levels do to them, tests that this dominates are left out, and each
grid stiffness gets one step on the gap (``friction_spread``).  The workflow uses it for a backlash when the data's force transient energy
exceeds the current model's by :data:`IMPACT_ENERGY_RATIO`
(:func:`fit_candidate_on_impacts`) and judges that candidate on the held-out features
(:func:`impact_verdict`).  Method and numbers: docs/theory/stiff_contacts.md.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from scipy.optimize import minimize

from .budget import past_deadline
from .prepared import PreparedTest
from .rig import Rig, predict
from .impact_verdict import impact_record, impact_verdict
from .impact_features import (
    IMPACT_FRICTION_DOMINATED,
    IMPACT_FRICTION_SPREAD,
    FeatureData,
    Mismatch,
    data_features,
    gap_step,
    impact_energy_ratio,
    impact_objective,
    kinematic_gap,
    mismatch,
    score,
    transient_energies,
)
from .impact_friction import (
    DAMPING,
    GAP,
    IMPACT_SHARES,
    STIFFNESS,
    SimulationBudget,
    confirm_friction,
    friction_variants,
    screen_friction,
    widen_by_friction,
)
from .impact_stiffness import peak_force_ratios, stiffness_bracket, stiffness_note

__all__ = ["ImpactFit", "transient_energies", "kinematic_gap", "impact_objective",
           "impact_energy_ratio", "fit_impacts", "fit_candidate_on_impacts", "IMPACT_SHARES", "impact_record",
           "impact_verdict",
           "IMPACT_EVALUATIONS_WITH_SHARES", "IMPACT_FRICTION_SPREAD",
           "IMPACT_FRICTION_DOMINATED",
           "IMPACT_EVALUATIONS", "IMPACT_ENERGY_RATIO", "IMPACT_LAWS", "with_contact_law", "GAP", "STIFFNESS",
           "DAMPING"]


#: Simulations of the fit tests one impact-aware fit may use (grid + Nelder–Mead).
IMPACT_EVALUATIONS = 48
#: ... and with a screen of friction shares (5 shares x 3 stiffnesses more; a second
#: friction variant's screen, :func:`~.impact_friction.friction_variants`, comes on top).
IMPACT_EVALUATIONS_WITH_SHARES = 75
#: The data's sampled force transient energy must exceed the current model's by this
#: factor for the impact-aware fit to be used: impacts the model has not (a 0.3 mm gap
#: with a 1e8-1e9 N/m contact: 700-2200; the prototype's soft 0.1 mm / 5e6 N/m one: 2;
#: a 5e7 N/m compliance: 2.3).
IMPACT_ENERGY_RATIO = 30.0
#: Contact laws the workflow's impact-aware fit compares (exponents: linear, Hertz).
IMPACT_LAWS = (1.0, 1.5)
#: Contact stiffnesses (log10 N/m) and dampings (log10 N s/m) of the starting grid.
_GRID_LOG_K = (6.0, 6.5, 7.0, 7.5, 8.0, 8.5, 9.0, 9.5)
_GRID_LOG_C = (3.0, 4.0)
#: The grid stiffnesses (the best at the last damping) at which the other dampings are
#: also simulated: far from the best stiffness the damping does not decide anything.
_DAMPED_STIFFNESSES = 3
#: Contact stiffnesses (log10 N/m) at which the friction shares are compared.
_SHARE_GRID_LOG_K = (7.0, 8.0, 9.0)
#: Nelder–Mead unit of the bearing share (then a fourth search direction).
_SHARE_STEP = 0.05
#: Nelder–Mead units: 10 % of the gap, a quarter decade of stiffness, 0.4 of damping.
_STEP = (0.1, 0.25, 0.4)
#: Nelder–Mead stops when the simplex is within this many units (2 % of the gap, 0.05
#: decade of stiffness) and its objectives within this share of the best: the objective
#: is rough at the 5-20 % level (a rattling contact's energies move that much between
#: integration tolerances), so a tighter tolerance only spends the budget on that noise.
_XATOL, _FATOL = 0.2, 0.02


@dataclass
class ImpactFit:
    """Result of :func:`fit_impacts` (mirrors ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    success : bool
        The search converged within its budget (or stopped at it with the best point
        kept: ``success`` False, the point still usable).
    message : str
    parameters : dict[str, float]
        The start with gap, stiffness and damping replaced by the best point.
    objective, objective_start : float
        :func:`impact_objective` at the best point and at the start.
    evaluations : int
        Simulations of the fit tests used.
    seconds : float
    history : list of dict
        Every evaluated (gap, stiffness, damping, objective).
    """

    success: bool
    message: str
    parameters: dict[str, float]
    objective: float
    objective_start: float
    evaluations: int
    seconds: float
    history: list[dict] = field(default_factory=list)
    contact_exponent: float = 1.0
    #: The stiffness bracket the evaluated points support and whether it identifies the
    #: stiffness (:func:`~.impact_stiffness.stiffness_interval`).
    stiffness: dict = field(default_factory=dict)


def with_contact_law(rig: Rig, exponent: float) -> Rig:
    """``rig`` with its backlash (the last component of that name) on the contact law of
    ``exponent`` (:class:`~ehsa_opt.physics.components.Backlash`)."""
    from ...physics.components import Backlash
    comps = list(rig.components)
    for i in range(len(comps) - 1, -1, -1):
        c = comps[i]
        if isinstance(c, Backlash):
            if c.contact_exponent != float(exponent):
                comps[i] = Backlash(c.smoothing_m, float(exponent), c.reference_m)
            return rig.with_components(comps)
    return rig


#: Hunt and Crossley's χ (s/m) at which a power-law contact enters the grid: the geometric
#: middle of steel impacts' 0.1-1.5 s/m (χ ≈ 3 (1 − e) / (2 u) for a restitution e of
#: 0.8-0.95 at impact speeds u of 0.1-1 m/s); Nelder-Mead moves it.
_HUNT_CROSSLEY_CHI = 0.4


def _best(history: Sequence[dict], law: float) -> dict:
    """The best evaluated point of the contact law ``law``."""
    return min((r for r in history if r["contact_exponent"] == law),
               key=lambda r: r["objective"])


def _choose_law(history: list[dict], others: Sequence[float], law: list[float],
                cost: Callable[[np.ndarray], float], grid_point: Callable, share: float,
                say: Callable[[str], None]) -> float:
    """Each other contact law (exponent; 1.5: Hertz's ball-on-race law with Hunt and
    Crossley's damping, :class:`~ehsa_opt.physics.components.Backlash`) at every grid
    stiffness, with the damping that was better there under the linear law or, for a
    power law, that of :data:`_HUNT_CROSSLEY_CHI`; returns the law of the best grid
    point."""
    first = law[0]
    rows = [r for r in history if r["contact_exponent"] == first
            and abs(r["bearing_share"] - share) < 1e-12]
    for n in others:
        law[0] = float(n)
        for lk in _GRID_LOG_K:
            at = [r for r in rows if abs(math.log10(r[STIFFNESS]) - lk) < 1e-9]
            lc = math.log10(min(at, key=lambda r: r["objective"])[DAMPING]) if at else 4.0
            if n != 1.0:  # Hunt-Crossley: c_c = k_c p_ref chi
                lc = lk + math.log10(1e-5 * _HUNT_CROSSLEY_CHI)
            try:
                cost(grid_point(lk, lc, share))
            except _Budget:
                break
    best = {n: min((r["objective"] for r in history if r["contact_exponent"] == n),
                   default=math.inf) for n in (first, *map(float, others))}
    chosen = min(best, key=best.get)
    say("impact-aware fit: contact law " + ", ".join(
        f"exponent {n:g} grid best {v:.3g}" for n, v in best.items())
        + f"; continues with exponent {chosen:g}")
    return chosen


def fit_impacts(prepared: Sequence[PreparedTest], rig: Rig, start: Mapping[str, float], *,
                max_evaluations: int = IMPACT_EVALUATIONS, shares: Sequence[float] = (),
                split: Callable | None = None, friction_spread: float = 0.0,
                laws: Sequence[float] = (1.0,), log: object = None) -> ImpactFit:
    """Fit the gap, contact stiffness and damping of a backlash on chaos-robust features
    of the forward simulation (transient energies and kinematic gaps, module docstring).

    Parameters
    ----------
    prepared : list of PreparedTest
        The fit tests (with a generator: the voltage carries the rotor speed).
    rig : Rig
        Holds the backlash component.
    start : dict
        All model parameters; friction and other effects stay at these values.  The
        gap search starts from the data's kinematic gap (:func:`kinematic_gap`, less
        the contact deflection at each grid stiffness), not from ``start``'s gap.
    max_evaluations : int
        Simulations allowed (grid, shares, Nelder–Mead); the search stops there, says so.
    shares : sequence of float
        Bearing shares of the start's rod-equivalent friction screened first (with 0, at
        1e7-1e9 N/m; e.g. :data:`IMPACT_SHARES` for a rigid baseline, which lumped it all
        into the nut), then refined by Nelder–Mead (a fourth direction).
    split : callable
        ``split(parameters, share, lead_m_per_rad)`` moving that share of the friction to
        the bearing (:func:`~.candidate_fit.split_friction`); needed with ``shares``.
    friction_spread : float
        Relative uncertainty of the start's friction levels (0: known).  When > 0 the
        features are widened by what it does to them, tests it dominates are left out
        (:func:`~.impact_friction.widen_by_friction`), each grid stiffness gets a gap step (:func:`_gap_steps`).
    laws : sequence of float
        Contact exponents (1 linear, 1.5 Hertz; :func:`_choose_law`), the best goes on.
    log : callable, optional
        Progress messages.

    Returns
    -------
    ImpactFit
    """
    lo, hi = _search_box(prepared, rig, max_evaluations, shares, split)
    t0 = time.perf_counter()
    say = log or (lambda msg: None)
    h = rig.harvester
    data = data_features(prepared, h)
    g_kin, f_push = _kinematic_start(prepared, data, h, start)
    g_kin = g_kin if math.isfinite(g_kin) else float(start[GAP])
    history, cache, mism = [], {}, {}  # evaluated points; objectives, mismatches by key
    widen: list[tuple[np.ndarray, float]] | None = None
    extra, left_out = 0, []
    with_share = bool(shares)
    lo4, hi4 = np.append(lo, 0.0), np.append(hi, 1.0)
    rigs = {float(n): with_contact_law(rig, n) for n in laws}
    law, var, dropped = [float(laws[0])], [0], []  # law, friction variant; points dropped
    variants = friction_variants(start, prepared, h.lead_m_per_rad)[:2 if with_share else 1]

    def friction(share: float) -> dict[str, float]:
        f0 = dict(variants[var[0]][1])
        return f0 if share <= 0.0 else split(f0, share, h.lead_m_per_rad)

    def cost(q: np.ndarray) -> float:
        q = np.clip(np.asarray(q, dtype=float), lo4, hi4)
        key = (*np.round(q, 12), law[0], var[0])
        if key in cache:
            return cache[key]
        if len(history) + sum("screen" not in r for r in dropped) >= max_evaluations:
            raise _Budget  # (the other friction variant's screen comes on top)
        p = {**friction(float(q[3])), GAP: float(q[0]), STIFFNESS: float(10 ** q[1]),
             DAMPING: float(10 ** q[2])}
        mism[key] = mismatch(prepared, predict(prepared, rigs[law[0]], p), h, data)
        c = score(mism[key], widen)
        c = c if math.isfinite(c) else 1e6
        cache[key] = c
        history.append({GAP: p[GAP], STIFFNESS: p[STIFFNESS], DAMPING: p[DAMPING],
                        "bearing_share": float(q[3]), "objective": c, "_key": key,
                        "contact_exponent": law[0]})
        return c

    def grid_point(lk: float, lc: float, share: float) -> np.ndarray:
        # each stiffness with the gap its contact deflection leaves of the kinematic gap
        return np.array([max(g_kin - 2.0 * f_push / 10 ** lk, 0.2 * g_kin), lk, lc, share])

    shares_of: dict[int, float] = {}  # each friction variant's screened share
    share_best = screen_friction(cost, grid_point, history, dropped, variants, var, shares,
                                 say, shares_of, _SHARE_GRID_LOG_K) if with_share else 0.0
    _grid(cost, grid_point, history, share_best)
    if len(rigs) > 1:
        law[0] = _choose_law(history, laws[1:], law, cost, grid_point, share_best, say)
    if friction_spread > 0.0:
        centres = []
        for lk in _SPREAD_LOG_K:
            q = grid_point(lk, 4.0, share_best)
            cost(q)
            centres.append((mism[(*np.round(np.clip(q, lo4, hi4), 12), law[0], var[0])],
                            {**friction(share_best), GAP: float(q[0]),
                             STIFFNESS: 10 ** float(q[1]), DAMPING: 10 ** float(q[2])}))
        widen, left_out, extra = widen_by_friction(prepared, rigs[law[0]], data, centres,
                                                    friction_spread, say)
        for r in history:  # every objective so far re-scored with the widened spreads
            r["objective"] = cache[r["_key"]] = score(mism[r["_key"]], widen)
        _gap_steps(history, mism, widen, share_best, g_kin, cost, law[0])
    if confirm_friction(history, dropped, var, shares_of, cost, law[0], variants, say):
        _gap_steps(history, mism, widen, shares_of[var[0]], g_kin, cost, law[0])
    best = _best(history, law[0])
    f_grid = best["objective"]
    say(f"impact-aware fit: kinematic gap {1e3 * g_kin:.4g} mm; grid best k "
        f"{best[STIFFNESS]:.3g} N/m, c {best[DAMPING]:.3g} N s/m (objective {f_grid:.3g})")
    converged, stop = _nelder_mead(cost, best, 4 if with_share else 3, max_evaluations)
    best = _best(history, law[0])
    share_best = best["bearing_share"]
    params = {**friction(share_best), GAP: best[GAP], STIFFNESS: best[STIFFNESS],
              DAMPING: best[DAMPING]}
    kint = stiffness_bracket(history, [mism[r["_key"]] for r in history], widen, law[0], STIFFNESS, (lo, hi))
    say(msg := _fit_message(stop, len(history) + len(dropped) + extra, best, f_grid,
                            friction_spread, extra, left_out) + stiffness_note(kint, law[0])
        + ("" if var[0] == 0 else f"; friction: {variants[var[0]][0]}"))
    for r in history:
        r.pop("_key", None)
    return ImpactFit(converged, msg, params, best["objective"], f_grid,
                     len(history) + len(dropped) + extra,
                     time.perf_counter() - t0, history, law[0], kint)


#: Contact stiffnesses (log10 N/m) at which the friction's effect on the features is taken.
_SPREAD_LOG_K = (8.0, 9.0)


def _grid(cost: Callable[[np.ndarray], float], grid_point: Callable, history: Sequence[dict],
          share: float) -> None:
    """The stiffness grid at the last damping of :data:`_GRID_LOG_C`, then the other
    dampings at the :data:`_DAMPED_STIFFNESSES` best grid stiffnesses (far from the best
    stiffness the damping decides nothing: five simulations saved for Nelder-Mead)."""
    for lk in _GRID_LOG_K:
        cost(grid_point(lk, _GRID_LOG_C[-1], share))
    best: dict[float, float] = {}
    for r in history:
        lk = round(math.log10(r[STIFFNESS]), 9)
        if abs(r["bearing_share"] - share) < 1e-12 and lk in _GRID_LOG_K:
            best[lk] = min(best.get(lk, math.inf), r["objective"])
    for lk in sorted(best, key=best.get)[:_DAMPED_STIFFNESSES]:
        for lc in _GRID_LOG_C[:-1]:
            cost(grid_point(lk, lc, share))


def _fit_message(stop: str, sims: int, best: Mapping[str, float], f_grid: float,
                 spread: float, spread_sims: int, left_out: Sequence[str]) -> str:
    """The message of :func:`fit_impacts`."""
    note = (f", features widened by the spread of ±{100 * spread:g} % friction levels "
            f"({spread_sims} simulations)" if spread_sims else "") + (
        f"; left out as friction-dominated (transient energy moved by more than a factor e "
        f"by the friction's uncertainty): {', '.join(left_out)}" if left_out else "")
    return (f"impact-aware fit ({stop}, {sims} simulations, bearing share of the friction "
            f"{best['bearing_share']:g}{note}): gap {1e3 * best[GAP]:.4g} mm, contact "
            + ("" if best.get("contact_exponent", 1.0) == 1.0 else
               f"law exponent {best['contact_exponent']:g} (secant at 10 um) ")
            + f"stiffness {best[STIFFNESS]:.3g} N/m, damping {best[DAMPING]:.3g} N s/m; "
            f"feature objective {f_grid:.3g} (grid) -> {best['objective']:.3g}")


def _nelder_mead(cost: Callable[[np.ndarray], float], best: Mapping[str, float], dim: int,
                 max_evaluations: int) -> tuple[bool, str]:
    """Nelder–Mead from ``best`` in units of :data:`_STEP` (and :data:`_SHARE_STEP` for
    the bearing share when ``dim`` is 4) until the simulation budget; (converged, why it
    stopped)."""
    q_best = np.array([best[GAP], math.log10(best[STIFFNESS]), math.log10(best[DAMPING]),
                       best["bearing_share"]])
    unit = np.array([_STEP[0] * best[GAP], _STEP[1], _STEP[2], _SHARE_STEP])

    def f(z: np.ndarray) -> float:
        if past_deadline():  # the run's time budget: keep the best point reached
            raise _Deadline
        return cost(q_best + np.append(z, np.zeros(4 - dim)) * unit)

    try:
        res = minimize(f,
                       np.zeros(dim), method="Nelder-Mead",
                       options={"initial_simplex": np.vstack([np.zeros(dim), np.eye(dim)]),
                                "xatol": _XATOL, "fatol": max(_FATOL * best["objective"], 1e-2),
                                "maxfev": max_evaluations})
    except _Budget:
        return False, "stopped at the simulation budget"
    except _Deadline:
        return False, "stopped at the run's deadline"
    return bool(res.success), ("converged" if res.success else str(res.message))


#: Grid stiffnesses (the best) that get a gap step.
_GAP_STEPS = 3


def _gap_steps(history: list[dict], mism: Mapping[tuple, Mismatch],
               widen: Sequence[tuple[np.ndarray, float]] | None, share: float, g_kin: float,
               cost: Callable[[np.ndarray], float], law: float = 1.0) -> None:
    """Each grid stiffness at the gap whose simulated kinematic gap matches the data's
    (one step from its better damping's point, :func:`~.impact_features.gap_step`): a
    rotor bouncing on its face at mid-stroke biases the kinematic gap low (by up to 10 %
    at 1e9 N/m) in the data and in the simulation alike, so the grid's gap (the data's
    kinematic gap less the contact deflection) is short there and the stiff end of the
    grid was judged at the wrong gap.  Used with an uncertain friction only: with the
    true friction the steps moved a 0.3 mm / 3e8 N/m case into a worse basin of the
    rough objective (0.19 against 0.06 without them, stiffness +57 % against +12 %).
    Only the :data:`_GAP_STEPS` best grid stiffnesses get a step (the others are far from
    the optimum; their simulations go to the Nelder-Mead stage instead)."""
    best_rows = []
    for lk in _GRID_LOG_K:
        rows = [r for r in history if abs(math.log10(r[STIFFNESS]) - lk) < 1e-9
                and abs(r["bearing_share"] - share) < 1e-12 and r["contact_exponent"] == law]
        if rows:
            best_rows.append((lk, min(rows, key=lambda r: r["objective"])))
    best_rows.sort(key=lambda kr: kr[1]["objective"])
    for lk, r0 in best_rows[:_GAP_STEPS]:
        step = gap_step(mism[r0["_key"]], widen)
        if math.isfinite(step) and step != 0.0:
            try:
                cost(np.array([max(r0[GAP] + step, 0.2 * g_kin), lk,
                               math.log10(r0[DAMPING]), share]))
            except _Budget:
                return


def _search_box(prepared: Sequence[PreparedTest], rig: Rig, max_evaluations: int,
                shares: Sequence[float] = (), split: Callable | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Checks of :func:`fit_impacts`' arguments; the bounds of (gap, log10 k, log10 c)."""
    if shares and split is None:
        raise ValueError("fit_impacts: shares need split (e.g. candidate_fit.split_friction)")
    n_grid = len(_GRID_LOG_K) + _DAMPED_STIFFNESSES * (len(_GRID_LOG_C) - 1)
    if max_evaluations < n_grid + 4:
        raise ValueError(f"fit_impacts: max_evaluations must be >= {n_grid + 4}, "
                         f"got {max_evaluations}")
    specs = rig.model().param_specs
    for n in (GAP, STIFFNESS, DAMPING):
        if n not in specs:
            raise ValueError(f"fit_impacts: the rig has no backlash ({n} is not a parameter)")
    if not rig.has_generator or any(pt.y.shape[0] < 2 for pt in prepared):
        raise ValueError("fit_impacts: needs the generator voltage of every test (the rotor "
                         "speed); a rig without generator has no rotor to rattle")
    lo = np.array([max(specs[GAP].lower, 1e-7), math.log10(specs[STIFFNESS].lower),
                   math.log10(max(specs[DAMPING].lower, 1.0))])
    hi = np.array([specs[GAP].upper, math.log10(specs[STIFFNESS].upper),
                   math.log10(specs[DAMPING].upper)])
    return lo, hi


def _kinematic_start(prepared: Sequence[PreparedTest], data: FeatureData, harvester,
                     start: Mapping[str, float]) -> tuple[float, float]:
    """The tests' mean kinematic gap (m) and mean contact force in the fast windows (N,
    the measured force less the start's nut friction), for the grid's gaps."""
    from ...physics.friction import nut_friction_N
    from ...physics.params import FRICTION_NAMES
    fr = [float(start[n]) for n in FRICTION_NAMES]
    gaps = [g[0] for g in data.gaps if g[2] > 0 and math.isfinite(g[0])]
    forces = []
    for pt in prepared:
        v = pt.u[1]
        fast = (np.abs(v) > 0.8 * np.max(np.abs(v))) & (pt.weight > 0)
        if fast.any():
            forces.append(float(np.mean(np.abs(pt.y[0][fast] - nut_friction_N(v[fast], fr)))))
    g = float(np.mean(gaps)) if gaps else math.nan
    return g, (float(np.mean(forces)) if forces else 0.0)


def fit_candidate_on_impacts(name: str, fit_pts: Sequence[PreparedTest],
                             held_pts: Sequence[PreparedTest], rig: Rig, crig: Rig,
                             start: Mapping[str, float], split: Callable, log: object = None
                             ) -> tuple[str, Any, list[np.ndarray], list[np.ndarray]] | None:
    """The candidate fit of a backlash by :func:`fit_impacts` when the data hold impacts
    the current model has not (:func:`impact_energy_ratio` of the current model ``rig``
    at ``start`` above :data:`IMPACT_ENERGY_RATIO`); None otherwise (the sample-wise fit
    then applies).  Returns what :func:`~.candidate_fit.fit_candidate` returns: the name, a
    :class:`~.fit.FitResult` (free: gap, stiffness, damping; friction and earlier
    effects at ``start``, its friction split by ``split`` at the best of
    :data:`IMPACT_SHARES`; no covariance) and the simulated outputs of the fit and
    held-out tests.  The message states the features' objective and how reproducible
    the sample-wise response is (:func:`~.candidate_fit.reproducibility`)."""
    from ..fit_result import FitResult
    if not rig.has_generator or any(pt.y.shape[0] < 2 for pt in fit_pts):
        return None
    ratio = impact_energy_ratio(fit_pts, predict(fit_pts, rig, start))
    if not ratio > IMPACT_ENERGY_RATIO:
        return None
    t0 = time.perf_counter()
    res = fit_impacts(fit_pts, crig, start, shares=IMPACT_SHARES, split=split,
                      max_evaluations=IMPACT_EVALUATIONS_WITH_SHARES,
                      friction_spread=IMPACT_FRICTION_SPREAD, laws=IMPACT_LAWS, log=log)
    crig = with_contact_law(crig, res.contact_exponent)
    pf = predict(fit_pts, crig, res.parameters)
    sse = float(sum(np.sum(((pt.y - yp) * pt.wnorm) ** 2) for pt, yp in zip(fit_pts, pf)))
    n_obs = sum(pt.y.size for pt in fit_pts)
    # how far the sample-wise response depends on the integration error itself (the
    # same measure as the sample-wise refit reports)
    fine = predict(fit_pts, crig, res.parameters, rtol=1e-9)
    d = np.concatenate([((ya - yb) * pt.wnorm).ravel() for pt, ya, yb in zip(fit_pts, pf, fine)])
    chaos = float(np.sqrt(np.mean(d ** 2)))
    peaks = peak_force_ratios(fit_pts, pf)
    note = (f"the force's transient energy is {ratio:.3g} x the current model's (impacts): "
            f"{res.message}; peak forces simulated/measured {np.nanmedian(peaks):.2f} (median; "
            f"{np.nanmin(peaks):.2f}-{np.nanmax(peaks):.2f} over the fit tests); sample-wise response reproducible to {chaos:.3g} noise std "
            f"between tolerances 1e-7 and 1e-9"
            + (" (a rattling contact: fitted on transient energies and kinematic gaps, not "
               "sample by sample)" if chaos > 1.0 else ""))
    out = FitResult(success=True, message=note, parameters=dict(res.parameters),
                    free=[GAP, STIFFNESS, DAMPING], objective=sse / n_obs,
                    records={"impact_fit": {"energy_ratio": ratio,
                                            "objective": res.objective,
                                            "objective_grid": res.objective_start,
                                            "simulations": res.evaluations,
                                            "converged": res.success,
                                            "contact_exponent": res.contact_exponent,
                                            "stiffness": res.stiffness,
                                            "peak_force_ratios": peaks.tolist(),
                                            "tolerance_change_rms_sigma": chaos}},
                    seconds=time.perf_counter() - t0, path="impacts", sse=sse, n_obs=n_obs)
    return name, out, pf, (predict(held_pts, crig, res.parameters) if held_pts else [])


_Budget = SimulationBudget  # raised inside the search when the budget is used up


class _Deadline(Exception):
    """Raised inside Nelder–Mead when the run's deadline (:mod:`.deadline`) has passed."""
