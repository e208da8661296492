"""The LuGre law's fit from the static optimum by a continuation in the bristle stiffness.

The dynamic law's steady state is the static Simscape curve and the static law is its
limit σ₀ → ∞, so the static optimum is a point of the dynamic problem in that limit.  A
solve from drawn starts meets a landscape with several local optima in σ₀ (a bristle
that absorbs the Stribeck hump, a breakaway velocity at its bound), and IPOPT may spend
its iterations between them.  The continuation (a homotopy in the one parameter that
carries the dynamics; Allgower & Georg 1990, *Numerical Continuation Methods*, ch. 1):

1. **Static** fit of the rod's friction as one Simscape curve (the bearing's fixed at
   zero, as the LuGre law carries it), from the fit's own starts;
2. **Softening**: σ₀ fixed at each rung of :data:`STIFFNESS_LADDER_N_PER_M`, stiff to
   soft, each started from the previous optimum (the first from the static one, σ₁ at its
   declared typical value): a profile of the likelihood in σ₀ over a ball screw's range;
3. **Free**: σ₀ free, from the rung of lowest objective.

The stages' IPOPT statuses are kept (``records["continuation"]`` of the result, in words
in its message, :func:`continuation_stages`); the result is the free solve's,
``success`` only when IPOPT converged there.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

from ..physics.base_parameters import PARAMETERS
from ..physics.friction import PRESLIDING_NAMES
from ..physics.params import FRICTION_NAMES
from .fit_result import FitResult

__all__ = ["STIFFNESS_LADDER_N_PER_M", "continued_fit", "continuation_stages",
           "BEARING_AT_ZERO"]

#: Bristle stiffnesses σ₀ (N/m) of the continuation, stiff to soft: one per decade over a
#: ball screw's presliding stiffness (1e5–1e8 N/m, the declared range of
#: ``presliding_stiffness_N_per_m``); the first is the static limit at a 1 kHz sample
#: rate (a 45 N friction sliding at 0.1 m/s relaxes in φ/σ₀ ≈ 5 µs).
STIFFNESS_LADDER_N_PER_M: tuple[float, ...] = (1e8, 1e7, 1e6, 1e5)
#: The bearing curve at zero: under the LuGre law on a rigid bench one curve (the nut's
#: names) carries the rod's friction.
BEARING_AT_ZERO: dict[str, float] = {n: (1.0 if "velocity" in n else 0.0)
                                     for n in FRICTION_NAMES[4:]}
_SIGMA0 = PRESLIDING_NAMES[0]


def continued_fit(fit: Callable[..., FitResult], law: str, fixed: Mapping[str, Any],
                  starts: Any, identifiability: bool,
                  ladder: Sequence[float] = STIFFNESS_LADDER_N_PER_M) -> FitResult:
    """Fit the dynamic law ``law`` by the continuation of the module docstring.

    Parameters
    ----------
    fit : callable
        ``fit(friction_law=..., fixed=..., starts=..., identifiability=...)`` → FitResult:
        the fit of the caller's tests with everything else bound
        (:func:`~ehsa_opt.estimation.identify.fit_tests`).
    law : str
        The dynamic law (``"lugre"``).
    fixed : mapping
        The caller's fixed or tied parameters (σ₀ not among them).
    starts : int or list of dict
        The static stage's starts.
    identifiability : bool
        Fisher-information analysis at the final optimum.
    ladder : sequence of float
        σ₀ of the fixed stages, N/m.
    """
    fixed = {**BEARING_AT_ZERO, **dict(fixed)}
    static = fit(friction_law="static", fixed=fixed, starts=starts, identifiability=False)
    stages = [{"sigma0": math.inf, "status": static.status, "objective": static.objective,
               "success": static.success}]
    if not static.success:
        static.message = f"continuation: the static fit failed ({static.message})"
        static.records["continuation"] = stages
        return static
    start = {n: v for n, v in static.parameters.items() if n in static.free}
    start.update({n: PARAMETERS[n].typical for n in PRESLIDING_NAMES if n != _SIGMA0})
    best: tuple[float, float, dict] | None = None
    for sigma0 in ladder:
        f = fit(friction_law=law, fixed={**fixed, _SIGMA0: float(sigma0)}, starts=[start],
                identifiability=False)
        stages.append({"sigma0": float(sigma0), "status": f.status, "objective": f.objective,
                       "success": f.success})
        if f.success and math.isfinite(f.objective):
            start = {n: f.parameters[n] for n in f.free}
            if best is None or f.objective < best[0]:
                best = (f.objective, float(sigma0), dict(start))
    if best is None:
        static.success = False
        static.message = ("continuation: no fixed-stiffness stage converged ("
                          + "; ".join(str(s["status"]) for s in stages[1:]) + ")")
        static.records["continuation"] = stages
        return static
    final = fit(friction_law=law, fixed=fixed, starts=[{**best[2], _SIGMA0: best[1]}],
                identifiability=identifiability)
    stages.append({"sigma0": None, "status": final.status, "objective": final.objective,
                   "success": final.success})
    final.records["continuation"] = stages
    final.message = f"{final.message}; continuation: {continuation_stages(stages)}"
    return final


def continuation_stages(stages: Sequence[Mapping[str, Any]]) -> str:
    """The stages in words: σ₀ (static, a value, free), IPOPT status and objective."""
    def name(s: Mapping[str, Any]) -> str:
        if s["sigma0"] is None:
            return "free"
        return "static" if math.isinf(s["sigma0"]) else f"sigma0 {s['sigma0']:.0e}"
    return ", ".join(f"{name(s)}: {s['status']} {s['objective']:.4g}" for s in stages)
