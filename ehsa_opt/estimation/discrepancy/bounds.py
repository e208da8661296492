"""Physical parameters of a fitted member: whether an effect parameter ended on the
edge of the member's physical range (:func:`at_bound`), and the rule that such a fit
does not earn (:func:`refuse_at_bound`)."""

from __future__ import annotations

import math
from typing import Any, Sequence

__all__ = ["AT_BOUND_REL", "at_bound", "refuse_at_bound"]


#: A fitted effect parameter within this share of a bound's magnitude of that bound is
#: "at bound" (:func:`at_bound`).
AT_BOUND_REL = 0.05


def at_bound(parameters: dict[str, float], specs: Sequence[Any],
             limits: Sequence[tuple[str, str]] = (), rel: float = AT_BOUND_REL) -> list[str]:
    """The effect parameters fitted at (or within ``rel`` of) a bound of their search
    range that is not a physical limit of the effect.

    A member's search range (:class:`~ehsa_opt.physics.components.ParamSpec` lower,
    upper) is the range over which its law describes a physical rig: a mount softer
    than 1e4 N/m would deflect by more than the stroke under the friction alone, a
    cogging above 0.1 N m would stall the screw.  A fit that ends on such an edge says
    the data want the member outside its physics: it is used as a surrogate for
    something else (on a Shockley-diode campaign a 1e4 N/m compliance "won" a round
    against the 0.54 V voltage drop that had earned).  Such a member does not earn;
    the range is not widened (beyond it the law stops describing the rig).  Two kinds
    of bound are physical limits and are not counted: a zero lower bound (the quantity
    vanishes: no damping, no drop) and the bounds listed in ``limits`` (a contact's
    stiffness at its upper bound is the rigid contact: "at least this stiff").

    Parameters
    ----------
    parameters : dict
        Fitted effect parameters (name → value, the parameter's units).
    specs : sequence of ParamSpec
        The member's parameter specifications (``name``, ``lower``, ``upper``).
    limits : sequence of (name, "lower" | "upper")
        Bounds that are the effect's physical limits.
    rel : float
        Relative distance to the bound counted as at the bound, ``|v − b| ≤ rel |b|``.

    Returns
    -------
    list of str
        Names of the parameters at such a bound (empty: every parameter is inside).
    """
    if not 0.0 <= rel < 1.0:
        raise ValueError(f"at_bound: rel must be in [0, 1), got {rel!r}")
    free = set(map(tuple, limits))
    out = []
    for q in specs:
        v = parameters.get(q.name)
        if v is None or not math.isfinite(v):
            continue
        for side, b in (("lower", q.lower), ("upper", q.upper)):
            if b == 0.0 or (q.name, side) in free or not math.isfinite(b):
                continue
            if abs(v - b) <= rel * abs(b):
                out.append(q.name)
                break
    return out


def refuse_at_bound(c: Any, specs: Sequence[Any], member: Any, say: Any = None) -> bool:
    """Set ``c.at_bound`` (:func:`at_bound` of its fitted ``parameters`` with the
    member's physical ``limits``) and withdraw its ``earns`` when it is not empty: an
    unphysical fit does not earn.  Returns whether it was at a bound."""
    c.at_bound = at_bound(c.parameters, specs, getattr(member, "limits", ()))
    if c.at_bound and c.earns:
        c.earns, c.earns_by = False, ""
        if say is not None:
            say(f"{c.effect}: at bound ({', '.join(c.at_bound)} on the edge of its "
                f"physical range): an unphysical fit, not earned")
    return bool(c.at_bound)
