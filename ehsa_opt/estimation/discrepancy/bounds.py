"""Physical parameters of a fitted member: whether an effect parameter ended on the
edge of the member's physical range with that edge *active* (:func:`at_bound`, the
unconstrained step :func:`unconstrained_step`), and the rule that such a fit does not
earn (:func:`at_bound_names`; the verdict is :mod:`.judge`'s)."""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .criterion import DEFAULT_CRITERION
from .prepared import PreparedTest
from .rig import Rig, fit_predictor, predict

__all__ = ["AT_BOUND_REL", "at_bound", "at_bound_names", "unconstrained_step",
           "STEP_RCOND"]


#: A fitted effect parameter within this share of a bound's magnitude of that bound is
#: "at bound" (:func:`at_bound`).
AT_BOUND_REL = DEFAULT_CRITERION.at_bound_rel


def at_bound(parameters: dict[str, float], specs: Sequence[Any],
             limits: Sequence[tuple[str, str]] = (), rel: float = AT_BOUND_REL,
             step: Mapping[str, float] | None = None) -> list[str]:
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

    A bound counts only where it is *active*: the fit ends within ``rel`` of it (the
    5 % of :data:`AT_BOUND_REL` only says where to look) and, when ``step`` is given,
    the unconstrained Gauss–Newton step from the fit (:func:`unconstrained_step`: the
    same refit with the bounds relaxed, to first order) would cross that bound, or the
    data do not determine the parameter (``step`` NaN, or a step that leaves the range
    on its other side — a linearisation far from valid, e.g. a cooling time at 1e4 s
    stepping by −7e8 s: nothing shows that the optimum is inside).  A fit at 9.6 K/J of a 10 K/J edge whose likelihood has its optimum
    there (step inside) is a physical fit of the member's range; a heating at
    10 K/J whose unconstrained step goes to 14 K/J is the member used outside its
    physics.  Without ``step`` the proxy alone decides (every fit within ``rel``).

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
    step : dict, optional
        Name → the unconstrained step of the parameter (its units; NaN: the data do
        not determine it); a parameter missing from it is judged by the proxy alone.

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
                d = (step or {}).get(q.name)
                if d is not None and math.isfinite(d) and q.lower <= v + d <= q.upper and (
                        v + d < b if side == "upper" else v + d > b):
                    continue  # the optimum is inside: the bound is not active
                out.append(q.name)
                break
    return out


def at_bound_names(c: Any, specs: Sequence[Any], member: Any, say: Any = None,
                   step: Callable[[], Mapping[str, float] | None] | None = None,
                   rel: float = AT_BOUND_REL) -> list[str]:
    """Set and return ``c.at_bound``: :func:`at_bound` (within ``rel`` of a bound) of its
    fitted ``parameters`` with the member's physical ``limits`` — an unphysical fit, which
    the judge (:mod:`.judge`) does not let earn.  ``step``: called only when a parameter
    is near a bound, it returns the unconstrained step (:func:`unconstrained_step`) that
    decides whether that bound is active."""
    limits = getattr(member, "limits", ())
    c.at_bound = at_bound(c.parameters, specs, limits, rel=rel)
    if c.at_bound and step is not None:
        d = step()
        if d is not None:
            inside = [n for n in c.at_bound if n not in at_bound(c.parameters, specs, limits,
                                                                  rel=rel, step=d)]
            c.at_bound = [n for n in c.at_bound if n not in inside]
            if inside and say is not None:
                say(f"{c.effect}: {', '.join(inside)} near the edge of its range, the "
                    f"unconstrained step stays inside (" + ", ".join(
                        f"{n} {c.parameters[n]:.3g} {d[n]:+.3g}" for n in inside)
                    + "): the bound is not active")
    return list(c.at_bound)


#: Singular values of the column-normalised Jacobian below this share of the largest
#: are directions the data do not determine (:func:`unconstrained_step`).
STEP_RCOND = 1e-6


def unconstrained_step(prepared: Sequence[PreparedTest], rig: Rig,
                       parameters: Mapping[str, float], names: Sequence[str],
                       rel_step: float = 1e-4) -> dict[str, float] | None:
    """One Gauss–Newton step of ``names`` from the fit ``parameters`` without bounds:
    δ = argmin ‖r − J δ‖ of the noise-normalised simulation residuals r on
    ``prepared`` (the rest fixed), J their sensitivities (the map's exact ones when the
    rig runs on it, else forward differences of ``rel_step``).

    At a fit stopped by a bound of its range the step points across that bound; at an
    optimum inside the range it is ≈ 0.  Returns name → δ (the parameter's units; NaN
    for a parameter along a direction the data do not determine, singular value below
    :data:`STEP_RCOND` of the largest), or None when the simulation fails.
    """
    names = list(names)
    pred = fit_predictor(rig)
    exact = getattr(pred, "jacobian", None)
    try:
        # the exact sensitivities return None where they do not apply (a non-uniform
        # grid): forward differences then
        out = exact(prepared, rig, parameters, names) if exact is not None else None
        if out is not None:
            preds, dpreds = out
        else:
            preds = predict(prepared, rig, parameters)
            dpreds = [np.zeros((*p.shape, len(names))) for p in preds]
            for j, n in enumerate(names):
                h = rel_step * max(abs(parameters[n]), 1e-12)
                moved = predict(prepared, rig, {**parameters, n: parameters[n] + h})
                for k, (p0, p1) in enumerate(zip(preds, moved)):
                    dpreds[k][:, :, j] = (p1 - p0) / h
    except (RuntimeError, ValueError, ArithmeticError):
        return None
    r = np.concatenate([((pt.y - yp) * pt.wnorm).ravel() for pt, yp in zip(prepared, preds)])
    J = np.concatenate([(dy * pt.wnorm[:, :, None]).reshape(-1, len(names))
                        for pt, dy in zip(prepared, dpreds)])
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
        return None
    norms = np.linalg.norm(J, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    U, S, Vt = np.linalg.svd(J / norms, full_matrices=False)
    good = S > STEP_RCOND * max(S.max(initial=0.0), 1e-300)
    delta = (Vt[good].T @ ((U[:, good].T @ r) / S[good])) / norms
    loose = np.sum(Vt[~good] ** 2, axis=0) > 1e-6 if (~good).any() else np.zeros(len(names), bool)
    return {n: (math.nan if lo else float(d)) for n, d, lo in zip(names, delta, loose)}
