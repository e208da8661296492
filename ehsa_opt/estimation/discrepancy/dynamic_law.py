"""The base model's dynamic friction law (LuGre, :mod:`ehsa_opt.physics.friction`) fitted
from the static optimum by a continuation in the bristle stiffness σ₀.

The dynamic law's steady state is the static Simscape curve and the static law is its
limit σ₀ → ∞, so the static optimum is a point of the dynamic problem in that limit.  A
direct solve from there meets a landscape with several local optima in σ₀ (a bristle
that absorbs the Stribeck hump, a breakaway velocity at its bound), and from a poor
start IPOPT spends its iterations between them.  The continuation (a homotopy in the
one parameter that carries the dynamics; Allgower & Georg 1990, ch. 1; used for stiff
friction identification e.g. by Bittencourt & Gunnarsson 2012):

1. **Static limit**: the rod's friction as one Simscape curve (the static fit's nut and
   bearing curves lumped at the rod: breakaway and Coulomb levels add, F + T/r; the
   viscous coefficients add, f_v + t_v/r²; the nut's breakaway velocity), σ₀ fixed at
   the stiffest rung of :data:`STIFFNESS_LADDER_N_PER_M`, the friction curve and σ₁
   free.  The bristle states start on their steady state (forward simulation of each
   start, :func:`~.fit.fit_group`), so the collocation starts feasible.
2. **Softening**: σ₀ fixed at each next rung, started from the previous rung's optimum
   (a profile of the likelihood in σ₀ over the ball-screw range).
3. **Free**: σ₀ free, started from the rung of lowest objective.
4. **Every sample** (when the stages above saw a decimated record, ``full_pts``): σ₀
   free on every sample of the fit tests, from the free stage's optimum.  The bristle's
   transient after a reversal lasts a few µm of travel — one or two samples at 1 kHz —
   so the collocation on every k-th sample does not see it and its optimum is biased:
   on the second generator's clean-sines campaign the held-out error of the LuGre fit
   is 3.27 % from every 4th sample and 2.76 % after this stage (the static law's
   decimation is harmless: its only state, the winding current, is quasi-static).  Off
   with :data:`REFINE_ON_EVERY_SAMPLE`.

The generalised Stribeck law (``"lugre_stribeck"``) takes the same path: its curve
starts from the lumped Simscape curve's levels and breakaway velocity (read as the
Stribeck velocity) with the exponent at its declared typical value (1).  Each stage's
IPOPT iterations are bounded by ``max_iter`` (``DiscrepancySettings.max_iter``): a
stage that reaches it is reported ``Maximum_Iterations_Exceeded`` in the stages and
the account, and the free stage must converge for the fit to count.

Every IPOPT status is kept in :attr:`DynamicFit.stages`; the dynamic fit is
``success`` only if the free solve converged (``Solve_Succeeded`` or acceptable), and
the message says which stage failed otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from ...physics.base_parameters import PARAMETERS
from ...physics.friction import LAW_PARAMETER_NAMES, PRESLIDING_NAMES
from ..fit_result import FitResult
from ..lugre_continuation import STIFFNESS_LADDER_N_PER_M
from .fit import fit_group
from .prepared import PreparedTest
from .rig import NUT_NAMES, Rig

__all__ = ["DYNAMIC_LAW", "STIFFNESS_LADDER_N_PER_M", "DynamicFit", "fit_dynamic",
           "lumped_rod_friction", "parameter_intervals"]

#: The dynamic friction law the base model is offered.
DYNAMIC_LAW = "lugre"
#: Whether the continuation ends with a free stage on every sample of the fit tests when
#: its stages saw a decimated record (stage 4 of the module docstring).
REFINE_ON_EVERY_SAMPLE = True
#: IPOPT statuses of a converged solve.
CONVERGED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
_SIGMA0, _SIGMA1 = "presliding_stiffness_N_per_m", "presliding_damping_Ns_per_m"


@dataclass
class DynamicFit:
    """The dynamic law's fit (None when no stage converged), each stage's σ₀ (None: free),
    IPOPT status, objective (χ²/N) and iterations, and a one-line account."""

    fit: FitResult | None
    stages: list[dict] = field(default_factory=list)
    message: str = ""
    seconds: float = 0.0


def lumped_rod_friction(params: Mapping[str, float], lead_m_per_rad: float
                        ) -> dict[str, float]:
    """The static fit's nut and bearing curves as one curve at the rod (the nut's names):
    levels F + T/r (N), viscous f_v + t_v/r² (N s/m), the nut's breakaway velocity."""
    r = lead_m_per_rad
    b = {n: float(params.get(n, 0.0)) for n in ("bearing_breakaway_Nm", "bearing_coulomb_Nm",
                                                 "bearing_viscous_Nms_per_rad")}
    return {"nut_breakaway_N": float(params["nut_breakaway_N"]) + b["bearing_breakaway_Nm"] / r,
            "nut_coulomb_N": float(params["nut_coulomb_N"]) + b["bearing_coulomb_Nm"] / r,
            "nut_breakaway_velocity_m_per_s": float(params["nut_breakaway_velocity_m_per_s"]),
            "nut_viscous_Ns_per_m": float(params["nut_viscous_Ns_per_m"])
            + b["bearing_viscous_Nms_per_rad"] / r ** 2}


def fit_dynamic(fit_pts: Sequence[PreparedTest], rig: Rig, static: Mapping[str, float],
                max_iter: int, ladder: Sequence[float] = STIFFNESS_LADDER_N_PER_M,
                full_pts: Sequence[PreparedTest] | None = None) -> DynamicFit:
    """Fit the dynamic law of ``rig`` (``friction_law`` not static) on ``fit_pts`` by the
    continuation of the module docstring, from the static optimum ``static``.

    Parameters
    ----------
    fit_pts : list of PreparedTest
        The fit tests (as the static fit saw them, e.g. decimated).
    rig : Rig
        The rig with the dynamic law.
    static : mapping
        The static law's fitted parameters (its rig terms are kept as the start).
    max_iter : int
        IPOPT iteration limit of each stage.
    ladder : sequence of float
        σ₀ of the fixed stages, N/m, stiff to soft.
    full_pts : list of PreparedTest, optional
        The fit tests on every sample, when ``fit_pts`` are decimated: the last stage's
        data (:data:`REFINE_ON_EVERY_SAMPLE`).
    """
    import time
    t0 = time.perf_counter()
    law_names = LAW_PARAMETER_NAMES[rig.friction_law]
    rest = [n for n in rig.base_names if n not in NUT_NAMES and n not in law_names]
    start = {**{n: float(static[n]) for n in rest},
             **lumped_rod_friction(static, rig.harvester.lead_m_per_rad),
             **{n: PARAMETERS[n].typical for n in law_names if n != _SIGMA0}}
    free_fixed = [n for n in rig.base_names if n != _SIGMA0]
    stages, fits = [], []
    for sigma0 in ladder:
        f = fit_group(fit_pts, rig, [start], free=free_fixed, fixed={_SIGMA0: float(sigma0)},
                      max_iter=max_iter)
        stages.append(_stage(sigma0, f))
        if f.parameters and math.isfinite(f.objective):
            fits.append((f.objective, sigma0, f))
            start = {n: f.parameters[n] for n in free_fixed}
    if not fits:
        return DynamicFit(None, stages, "dynamic fit failed at every fixed stiffness (" + "; ".join(s["status"] for s in stages) + ")",
                          time.perf_counter() - t0)
    _, sigma0, best = min(fits, key=lambda x: x[0])
    start = {**{n: best.parameters[n] for n in free_fixed}, _SIGMA0: float(sigma0)}
    f = fit_group(fit_pts, rig, [start], free=rig.base_names, max_iter=max_iter)
    stages.append(_stage(None, f))
    ok = f.status in CONVERGED and bool(f.parameters) and math.isfinite(f.objective)
    if ok and full_pts is not None and REFINE_ON_EVERY_SAMPLE:
        f = fit_group(full_pts, rig, [dict(f.parameters)], free=rig.base_names,
                      max_iter=max_iter)
        stages.append({**_stage(None, f), "samples": "every"})
        ok = f.status in CONVERGED and bool(f.parameters) and math.isfinite(f.objective)
    f.success = ok
    seconds = time.perf_counter() - t0
    path = ", ".join(f"{_fmt(s)}: {s['status']} chi2/N {s['objective']:.4g}"
                     for s in stages)
    if not ok:
        return DynamicFit(None, stages, f"dynamic fit did not converge from the static "
                          f"optimum ({path})", seconds)
    return DynamicFit(f, stages, f"dynamic fit converged ({path}; {seconds:.1f} s)", seconds)


def parameter_intervals(fit: FitResult, z: float = 1.96) -> dict[str, tuple[float, float]]:
    """Wald intervals value ± z·σ of the free parameters from the fit's (Newey–West)
    covariance; empty when it has none."""
    cov = getattr(fit, "covariance", None)
    if cov is None:
        return {}
    sd = np.sqrt(np.maximum(np.diag(np.asarray(cov, float)), 0.0))
    return {n: (fit.parameters[n] - z * s, fit.parameters[n] + z * s)
            for n, s in zip(fit.free, sd)}


def _stage(sigma0: float | None, f: FitResult) -> dict:
    return {"sigma0": sigma0, "status": f.status or f.message, "objective": float(f.objective),
            "iterations": f.nit, "seconds": f.seconds}


def _fmt(stage: dict) -> str:
    if stage["sigma0"] is not None:
        return f"sigma0 {stage['sigma0']:.0e}"
    return "free, every sample" if stage.get("samples") == "every" else "free"
