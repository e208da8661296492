"""Friction sets built against a target rod-friction curve: the ordered ``min``/``max``
sets around a best set (:func:`ordered_set`, a linear programme on the set's own shapes)
and the admissible set that follows an envelope (:func:`fit_envelope`, SLSQP), with the
envelope fit's named parameter override (:data:`ENVELOPE_PARAMETERS`).  Used by
:func:`ehsa_opt.estimation.bounds.friction_bounds`."""

from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np
from scipy import optimize

from ..physics.base_parameters import Parameter, override
from ..physics.friction import bearing_friction_Nm, rod_friction_N, simscape_friction
from ..physics.params import FRICTION_NAMES, FrictionParams
from .identify_options import IDENTIFY_PARAMETERS

__all__ = ["ENVELOPE_PARAMETERS", "friction_set", "rod_curve_N", "ordered_set", "fit_envelope"]

_NUT = FRICTION_NAMES[:4]
_BEARING = FRICTION_NAMES[4:]
#: The envelope fit's nut parameters: a named override of the declared base parameters.
#: The breakaway velocity keeps the identification's range; the levels are wider than the
#: identification's nut bounds because the target is the rod friction (nut plus bearing
#: torque over the lead) with its confidence half-width.
ENVELOPE_PARAMETERS: dict[str, Parameter] = override(
    "friction envelope",
    "the target is the rod friction with its confidence half-width, which may exceed the "
    "identification's nut bounds; the bounds only keep SLSQP finite",
    {"nut_coulomb_N": (0.0, 1e4), "nut_viscous_Ns_per_m": (0.0, 1e5),
     "nut_breakaway_velocity_m_per_s":
         IDENTIFY_PARAMETERS["nut_breakaway_velocity_m_per_s"].bounds})
#: Admissible ranges of the fitted nut parameters, in the fit's order; ``nut_excess_N`` is
#: breakaway − Coulomb (>= 0 keeps the breakaway >= Coulomb order), bounded like the levels.
_NUT_BOUNDS = {"nut_coulomb_N": ENVELOPE_PARAMETERS["nut_coulomb_N"].bounds,
               "nut_excess_N": ENVELOPE_PARAMETERS["nut_coulomb_N"].bounds,
               "nut_breakaway_velocity_m_per_s":
                   ENVELOPE_PARAMETERS["nut_breakaway_velocity_m_per_s"].bounds,
               "nut_viscous_Ns_per_m": ENVELOPE_PARAMETERS["nut_viscous_Ns_per_m"].bounds}


def friction_set(params: Mapping[str, float], has_generator: bool) -> FrictionParams:
    """FrictionParams of an identified parameter dict (no bearings without generator)."""
    vals = {n: float(params[n]) for n in FRICTION_NAMES if n in params}
    if not has_generator:
        vals = {n: v for n, v in vals.items() if n in _NUT}
    if vals.get("nut_breakaway_N", 0.0) < vals.get("nut_coulomb_N", 0.0):
        vals["nut_breakaway_N"] = vals["nut_coulomb_N"]
    if vals.get("bearing_breakaway_Nm", 0.0) < vals.get("bearing_coulomb_Nm", 0.0):
        vals["bearing_breakaway_Nm"] = vals["bearing_coulomb_Nm"]
    return FrictionParams(**vals)


def rod_curve_N(v: np.ndarray, fr: FrictionParams, lead: float) -> np.ndarray:
    """The rod friction of ``fr`` at the velocities ``v`` (m/s), N, as a float array."""
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
    if side == "below":
        # take away at most what the best set has (zero friction is the floor); all of it
        # meets every margin, since the margin is clipped to the best set's friction
        margin = np.minimum(margin, np.asarray(rod_friction_N(v, best, lead), dtype=float))
        ub = np.maximum(have, 0.0)
    else:
        # an added Coulomb level or Stribeck hump (peak = its amount) never larger than
        # the largest margin: without it a tall narrow hump below the grid's first
        # velocity would meet a low-velocity margin "cheaply" (its tail) with an absurd
        # breakaway force.  (Not on the side below: there the clipped margin can be the
        # whole of the best set's friction at a velocity where a shape is far from its
        # peak, which only the whole amount it has meets.)
        cap = float(np.max(margin)) if margin.size else 0.0
        ub = np.array([np.inf if "viscous" in n else
                       cap * (lead if n.startswith("bearing") else 1.0) for n in names])
    # columns scaled to unit maximum on the grid (conditioning)
    colmax = np.maximum(Phi.max(axis=0), 1e-300)
    A = Phi / colmax
    w = np.full(v.size, 1.0 / v.size)
    res = optimize.linprog(c=w @ A, A_ub=-A, b_ub=-margin,
                           bounds=list(zip(np.zeros(have.size), ub * colmax)), method="highs")
    if not res.success:   # cannot happen: "below" is met by all of it, "above" by viscous
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
    base = rod_curve_N(v, split, lead)
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
