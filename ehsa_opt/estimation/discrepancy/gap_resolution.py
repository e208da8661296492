"""Whether a fitted backlash is a gap at all, or a series spring in disguise.

A backlash of gap b and contact stiffness k lets the rotor lag the rod, at each
reversal, by the gap plus the contact's deflection under the force it carries: a
force-free coast over b, then an elastic travel of F/k on each face.  Only the coast
is what a gap adds to a series spring (a compliance, or friction's presliding — a
spring-like force over a transition length after each reversal).  When the fitted
gap is shorter than the contact's deflection under the mean force it transmits,

    b < d(F) = F / k            (F: the mean |force| through the contact while the
                                 rod drives the rotor, the measured force less the
                                 nut's friction in the fast part of the strokes),

the fit's lag is mostly elastic: the data do not resolve a gap from the spring
(e.g. a 12.6 µm "gap" at a 5e6 N/m contact carrying ~100 N deflects 20 µm, and the
pair mimics a friction's presliding; the prototype's 0.1 mm play at 5e6 N/m carrying
~150 N deflects 30 µm and is resolved).  Such a fit is not named a backlash
(:func:`refuse_unresolved_gap`); the compliance member, which is the spring without the
gap, speaks for the elastic part.

An impact-fitted contact (stiff, the force's transient energy hundreds of times the
rigid model's) has d ≪ b by construction and passes.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .prepared import PreparedTest

__all__ = ["GAP", "STIFFNESS", "transmitted_force_N", "contact_deflection_m",
           "gap_resolved", "refuse_unresolved_gap"]

GAP = "backlash_gap_m"
STIFFNESS = "backlash_contact_stiffness_N_per_m"

#: Share of the peak rod speed above which a sample is in the "fast part" of a stroke
#: (the rod then drives the rotor through one contact face).
FAST_FRACTION = 0.8


def transmitted_force_N(prepared: Sequence[PreparedTest], parameters: Mapping[str, float]
                        ) -> float:
    """Mean |force| through the contact (N): the measured force less the nut's friction
    at ``parameters``, over the resolved samples where |v| exceeds
    :data:`FAST_FRACTION` of the test's peak speed, averaged over the tests (nan when no
    test has such samples)."""
    from ...physics.friction import nut_friction_N
    from ...physics.params import FRICTION_NAMES
    fr = [float(parameters[n]) for n in FRICTION_NAMES]
    forces = []
    for pt in prepared:
        v = pt.u[1]
        fast = (np.abs(v) > FAST_FRACTION * np.max(np.abs(v))) & (pt.weight > 0)
        if fast.any():
            forces.append(float(np.mean(np.abs(pt.y[0][fast] - nut_friction_N(v[fast], fr)))))
    return float(np.mean(forces)) if forces else math.nan


def contact_deflection_m(force_N: float, stiffness_N_per_m: float, exponent: float = 1.0,
                         reference_m: float = 1e-5) -> float:
    """Deflection (m) of a contact carrying ``force_N``: F/k for the linear law; for a
    power law F = k p_ref (p/p_ref)^n (k the secant stiffness at the reference
    penetration p_ref), p = p_ref (F / (k p_ref))^(1/n)."""
    if not (stiffness_N_per_m > 0 and math.isfinite(force_N)):
        return math.nan
    if exponent == 1.0:
        return abs(force_N) / stiffness_N_per_m
    return reference_m * (abs(force_N) / (stiffness_N_per_m * reference_m)) ** (1.0 / exponent)


def gap_resolved(gap_m: float, deflection_m: float) -> bool:
    """A gap is resolved from the contact's spring when it exceeds its deflection
    (module docstring); an undetermined deflection (no fast samples) does not refuse."""
    return not (math.isfinite(deflection_m) and gap_m < deflection_m)


def refuse_unresolved_gap(c: Any, prepared: Sequence[PreparedTest],
                          parameters: Mapping[str, float], say: Callable | None = None,
                          rig: Any = None) -> bool:
    """Withdraw a backlash candidate's ``earns`` when its gap is not resolved from its
    contact's spring (:func:`gap_resolved` at the deflection under
    :func:`transmitted_force_N` of the fit tests).  ``c`` is a
    :class:`~.results.CandidateResult`; ``rig`` (optional) holds the backlash component
    whose contact law sets the deflection; returns whether it was refused."""
    if c.effect != "backlash" or GAP not in parameters or STIFFNESS not in parameters:
        return False
    force = transmitted_force_N(prepared, parameters)
    comp = next((q for q in reversed(getattr(rig, "components", ()))
                 if getattr(q, "name", "") == "backlash"), None)
    d = contact_deflection_m(force, float(parameters[STIFFNESS]),
                             getattr(comp, "contact_exponent", 1.0),
                             getattr(comp, "reference_m", 1e-5))
    if gap_resolved(float(parameters[GAP]), d):
        return False
    if c.earns:
        c.earns, c.earns_by = False, ""
        if say is not None:
            say(f"backlash: gap {1e6 * float(parameters[GAP]):.3g} um is shorter than its "
                f"contact's deflection {1e6 * d:.3g} um under the {force:.3g} N it carries: "
                f"a series spring (presliding or compliance), not a resolved gap; not earned")
    return True
