"""The friction an impact-aware contact fit (:mod:`.impacts`) simulates with.

A rigid baseline identified on data that hold impacts is not a friction law the rotor
can coast through a gap with:

* **Where the friction acts.**  The rigid model sees the rod-equivalent friction only;
  which part of it brakes the rotor while the gap is open (the bearing's, and a nut
  whose balls ride on the screw side of the play) it cannot tell.  The fit screens
  that share (:data:`IMPACT_SHARES`, up to all of it: a nut whose friction acts on the
  screw side of the play).
* **Its breakaway level.**  A static map's breakaway bump is the one term of the rigid
  model that can follow a force peak at a given speed, and the impact peaks are such
  peaks: on a campaign with a Hertzian 0.12 mm backlash the baseline's nut breakaway
  was 762 N at 68 mm/s against a Coulomb level of 38 N (a twentyfold bump; ball screws
  and their bearings have static-over-Coulomb ratios of 1.2-2).  Split across the play
  that bump brakes the coasting rotor with hundreds of newtons, and no contact
  reproduces the impacts: at the true contact the held-out feature objective
  (:mod:`.impact_verdict`, unwidened) was 26 with the start's friction, 33 with a tenth
  of it on the rotor; with the bump reshaped to :data:`BREAKAWAY_RATIO` times the Coulomb
  level (the map's mean friction over the fit tests' speeds kept), 3.1 with all of it on
  the rotor (4.1 with the breakaway merely capped, the Coulomb level unchanged).  The fit therefore screens
  the start's friction and, where its bump exceeds that ratio, the reshaped one
  (:func:`friction_variants`); the better one goes on.

What the friction's remaining uncertainty does to each test's features widens them
(:func:`widen_by_friction`).  Method: docs/theory/stiff_contacts.md.
"""

from __future__ import annotations

import math
from typing import Callable, Mapping, Sequence

import numpy as np

from .impact_features import (
    BEARING_LEVELS,
    IMPACT_FRICTION_DOMINATED,
    NUT_LEVELS,
    FeatureData,
    Mismatch,
    friction_widening,
    mismatch,
    moved_friction,
)
from ...physics.friction import simscape_friction
from .prepared import PreparedTest
from .rig import Rig, predict

__all__ = ["GAP", "STIFFNESS", "DAMPING", "SimulationBudget", "screen_friction",
           "confirm_friction", "IMPACT_SHARES", "BREAKAWAY_RATIO", "capped_breakaway", "friction_variants",
           "widen_by_friction"]

GAP = "backlash_gap_m"
STIFFNESS = "backlash_contact_stiffness_N_per_m"
DAMPING = "backlash_contact_damping_Ns_per_m"


class SimulationBudget(Exception):
    """Raised inside the impact-aware search when its simulation budget is used up."""


#: Bearing shares of the start's rod-equivalent friction screened first (with the
#: start's own split as share 0): a rigid baseline lumps the friction into the nut, but
#: the part that acts behind the play (the bearing's; a nut's whose balls ride on the
#: screw side of the play: share 1) brakes the rotor while it coasts through the gap,
#: which sets the impact speeds.
IMPACT_SHARES = (0.15, 0.3, 0.45, 1.0)

#: Breakaway over Coulomb level of the capped friction variant (:func:`friction_variants`):
#: the upper end of steel ball screws' and rolling bearings' static-over-Coulomb ratios
#: (1.2-2).  Provenance: chosen after seeing the second generator's LuGre pairs
#: (static over Coulomb 1.6-1.7) on the campaign above; not tuned further.
BREAKAWAY_RATIO = 1.5

#: (breakaway, Coulomb, breakaway velocity, the speed's scale from the rod velocity: the
#: nut's at the rod velocity, the bearing's at the rotor speed v/r on a rigid transmission)
_PAIRS = (("nut_breakaway_N", "nut_coulomb_N", "nut_breakaway_velocity_m_per_s", False),
          ("bearing_breakaway_Nm", "bearing_coulomb_Nm", "bearing_breakaway_velocity_rad_per_s",
           True))


def capped_breakaway(p: Mapping[str, float], speeds_m_per_s: np.ndarray,
                     lead_m_per_rad: float, ratio: float = BREAKAWAY_RATIO
                     ) -> dict[str, float]:
    """``p`` with each breakaway level above ``ratio`` times its Coulomb level reshaped to
    exactly that ratio, its Coulomb level chosen so that the map's mean friction (less
    the viscous part) over ``speeds_m_per_s`` (the fit tests' rod velocities, m/s) is
    kept: the friction the rigid model identified stays, only its bump goes.  The
    breakaway velocities and viscous terms are kept.

    Parameters
    ----------
    p : dict
        Model parameters with the eight friction levels.
    speeds_m_per_s : ndarray
        Rod velocities the mean is taken over (m/s; the bearing's at v / r).
    lead_m_per_rad : float
        r, m/rad.
    ratio : float
        Breakaway over Coulomb level of a reshaped pair (>= 1).
    """
    if not ratio >= 1.0:
        raise ValueError(f"capped_breakaway: ratio must be >= 1, got {ratio!r}")
    v = np.asarray(speeds_m_per_s, dtype=float)
    if v.size == 0 or not np.any(v != 0):
        raise ValueError("capped_breakaway: needs the rod velocities of the fit tests")
    out = dict(p)
    for brk, coul, vel, on_rotor in _PAIRS:
        fb, fc = float(p[brk]), max(float(p[coul]), 0.0)
        if fb <= ratio * fc:
            continue
        u = v / lead_m_per_rad if on_rotor else v
        now = np.mean(np.abs(simscape_friction(u, fb, fc, float(p[vel]), 0.0)))
        unit = np.mean(np.abs(simscape_friction(u, ratio, 1.0, float(p[vel]), 0.0)))
        out[coul] = float(now / unit)
        out[brk] = ratio * out[coul]
    return out


def friction_variants(start: Mapping[str, float], prepared: Sequence[PreparedTest],
                      lead_m_per_rad: float, ratio: float = BREAKAWAY_RATIO
                      ) -> list[tuple[str, dict[str, float]]]:
    """The frictions the impact-aware fit screens: the start's, and — when a breakaway
    level exceeds ``ratio`` times its Coulomb level — the start's reshaped to that ratio
    with its mean friction over the fit tests' resolved rod velocities kept
    (:func:`capped_breakaway`).  (label, parameters) pairs."""
    out = [("start's friction", dict(start))]
    if all(float(start[b]) <= ratio * max(float(start[c]), 0.0) for b, c, _, _ in _PAIRS):
        return out
    v = np.concatenate([pt.u[1][pt.weight > 0] for pt in prepared])
    out.append((f"breakaway reshaped to {ratio:g} x Coulomb (mean friction kept)",
                capped_breakaway(start, v, lead_m_per_rad, ratio)))
    return out


def widen_by_friction(prepared: Sequence[PreparedTest], rig: Rig, data: FeatureData,
                      centres: Sequence[tuple[Mismatch, dict]], spread: float,
                      say: Callable[[str], None]
                      ) -> tuple[list[tuple[np.ndarray, float]], list[str], int]:
    """What the friction's own uncertainty does to each test's features: at each centre
    (its mismatch and parameters, grid points across the stiff range — the sensitivity
    depends on the stiffness: whether the rotor leaves its face on a slow stroke is a
    balance of the friction against the rod's deceleration), the nut's and the bearing's
    levels are each moved by ± ``spread``; the largest change of each feature over the
    members and centres widens its allowed spread.  A test whose log transient energy
    that moves by more than :data:`IMPACT_FRICTION_DOMINATED` (a factor e) says more about
    the friction than about the contact and is left out (an infinite spread; all kept if
    fewer than two would remain).  Returns the widening per test, the files left out
    and the simulations used."""
    h = rig.harvester
    per_k, sims = [], 0
    for centre, p0 in centres:
        members = [moved_friction(p0, names, 1.0 + sgn * spread)
                   for names in (NUT_LEVELS, BEARING_LEVELS) for sgn in (-1.0, 1.0)]
        moved = [mismatch(prepared, predict(prepared, rig, pm), h, data) for pm in members]
        sims += len(members)
        per_k.append(friction_widening(centre, moved))
    widen = [(np.max([w[i][0] for w in per_k], axis=0), max(w[i][1] for w in per_k))
             for i in range(len(prepared))]
    shown = ", ".join(f"{float(np.max(w)):.2g}" for w, _ in widen)
    dominated = [i for i, (we, _) in enumerate(widen)
                 if float(np.max(we)) > IMPACT_FRICTION_DOMINATED]
    keep = len(prepared) - len(dominated) >= 2
    widen = [(np.full_like(w[0], np.inf), math.inf) if keep and i in dominated else w
             for i, w in enumerate(widen)]
    left_out = [prepared[i].test.file for i in dominated] if keep else []
    say(f"impact-aware fit: features' spread under ±{100 * spread:g} % friction levels "
        f"(log energy, per test): {shown}"
        + (f"; left out as friction-dominated: {', '.join(left_out)}" if left_out else ""))
    return widen, left_out, sims


def screen_friction(cost: Callable[[np.ndarray], float], grid_point: Callable,
                     history: list[dict], dropped: list[dict],
                     variants: Sequence[tuple[str, dict]], var: list[int],
                     shares: Sequence[float], say: Callable[[str], None],
                     shares_of: dict[int, float], grid_log_k: Sequence[float]) -> float:
    """The friction's screen of :func:`~.impacts.fit_impacts`: each variant
    (:func:`~.impact_friction.friction_variants`) at each bearing share (0 and
    ``shares``) at the stiffnesses ``grid_log_k`` (log10 N/m); sets ``var[0]`` to the
    best variant, moves the other variants' points from ``history`` to ``dropped`` (the
    search goes on with one friction; marked ``"screen"``: they do not count against the
    search's budget), notes each variant's best share in ``shares_of`` and returns the best
    share."""
    scores = {}
    for var[0] in range(len(variants)):
        for sh in (0.0, *shares):
            scores[var[0], sh] = min(cost(grid_point(lk, 4.0, sh)) for lk in grid_log_k)
    var[0], share_best = min(scores, key=scores.get)
    for v in range(len(variants)):
        shares_of[v] = float(min((k for k in scores if k[0] == v), key=scores.get)[1])
    dropped += [{**r, "screen": True} for r in history if r["_key"][-1] != var[0]]
    history[:] = [r for r in history if r["_key"][-1] == var[0]]
    say(f"impact-aware fit: bearing share of the friction {share_best:g}, "
        f"{variants[var[0]][0]} (screen" + (", objectives " + ", ".join(
            f"{variants[v][0]}: {min(c for (w, _), c in scores.items() if w == v):.3g}"
            for v in range(len(variants))) if len(variants) > 1 else "") + ")")
    return float(share_best)


#: Best points of the chosen friction at which the other friction variant is simulated
#: before Nelder-Mead (:func:`confirm_friction`).
_CONFIRM_POINTS = 3


def confirm_friction(history: list[dict], dropped: list[dict], var: list[int],
                      shares_of: Mapping[int, float], cost: Callable[[np.ndarray], float],
                      law: float, variants: Sequence[tuple[str, dict]],
                     say: Callable[[str], None]) -> bool:
    """The friction variant confirmed where it matters: the screen compares the variants
    on a coarse linear-law grid before the contact law, the widening and the gap steps;
    here the other variant (at its screened share) is simulated at the
    :data:`_CONFIRM_POINTS` best points of the chosen one (its law, gap, stiffness,
    damping), and the search goes on with the other variant when its best is lower
    (``history`` then holds only its points; the points dropped here still count against
    the budget; a rig-B campaign's 0.2 mm gap ended 18 % long with the variant the screen
    chose, 0.7 % with the other).  Returns whether it switched (the caller then gives
    the new variant's best grid points their gap steps)."""
    labels = [lbl for lbl, _ in variants]
    if len(labels) < 2 or not shares_of:
        return False
    mine, other = var[0], 1 - var[0]
    top = sorted((r for r in history if r["contact_exponent"] == law),
                 key=lambda r: r["objective"])[:_CONFIRM_POINTS]
    n0, var[0] = len(history), other
    try:
        for r in top:
            cost(np.array([r[GAP], math.log10(r[STIFFNESS]), math.log10(r[DAMPING]),
                           shares_of[other]]))
    except SimulationBudget:
        pass
    new, old = history[n0:], history[:n0]
    f_new = min((r["objective"] for r in new), default=math.inf)
    f_old = min(r["objective"] for r in top) if top else math.inf
    keep, drop = (new, old) if f_new < f_old else (old, new)
    var[0] = other if f_new < f_old else mine
    dropped += drop
    history[:] = keep
    say(f"impact-aware fit: friction confirmed at the {len(top)} best points: "
        f"{labels[mine]} {f_old:.3g}, {labels[other]} {f_new:.3g}; goes on with {labels[var[0]]}")
    return var[0] != mine

