"""Member ``dynamic_friction``: the base model's friction law made dynamic (LuGre, its
bristle's stiffness σ₀ and damping σ₁; :mod:`..dynamic_law`), offered first, before the
record members, when :attr:`~..results.DiscrepancySettings.dynamic_friction` is on.

Fitted from the static optimum by the continuation in σ₀ (:func:`~..dynamic_law.fit_dynamic`)
and judged like every member, its two bristle parameters charged.  A bristle delays the
friction after each reversal, so the dynamic law also absorbs a delay of the force record
(a 3 ms acquisition lag on static friction: held-out 17.1 → 12.9 %): before it is
adopted, the ``force_lag`` member's own fit on the static model is its rival
(:meth:`DynamicLawMember.confirm`) — when the delay leaves an error no higher than the
dynamic law's, the delay is the simpler account and the record members judge it.  Once
adopted, every model the search judges carries the dynamic law (``tests.rig``)."""

from __future__ import annotations

import math
from dataclasses import replace

from ...fit_result import FitResult
from ....physics.friction import LAW_PARAMETER_NAMES, PRESLIDING_NAMES, STRIBECK_EXPONENT
from ..baseline import baseline_decimation, simulate_base
from ..candidates.force_lag import try_lag
from ..dynamic_law import fit_dynamic, parameter_intervals
from ..evidence import change_evidence, force_error_percent
from ..localise import localise
from ..prepared import decimated
from .protocol import Attempt, Context, Member

__all__ = ["DynamicLawMember"]


class DynamicLawMember(Member):
    """The base friction law's dynamics (see the module docstring)."""

    name = "dynamic_friction"
    kind = "law"
    channel = "base friction law"

    def applicable(self, ctx: Context) -> str:
        if not ctx.settings.dynamic_friction or ctx.tests.rig.friction_law != "static":
            return "-"
        return ""

    def fit(self, ctx: Context) -> Attempt | None:
        t, b = ctx.tests, ctx.base
        k = baseline_decimation(t.fit_pts, t.rig)
        dyn_rig = replace(t.rig, friction_law=ctx.settings.dynamic_law)
        dyn = fit_dynamic([decimated(pt, k) for pt in t.fit_pts], dyn_rig, b.fit.parameters,
                          ctx.settings.max_iter, full_pts=t.fit_pts if k > 1 else None)
        ctx.say(f"friction law: {dyn.message}")
        b.law_note = f"friction law: static ({dyn.message})"
        if dyn.fit is None or not dyn.fit.success:
            return None
        static = (b.fit_pred, b.held_pred, b.n_eff_fit, b.n_eff_held)
        cand = simulate_base(t, dyn_rig, dyn.fit)
        n_law = len(LAW_PARAMETER_NAMES[dyn_rig.friction_law])
        _, _, _, e0, e1, d_fit, d_held = change_evidence(
            t.fit_pts, static[0], cand[0], t.held_pts, static[1], cand[1], n_law,
            static[2], static[3])
        msg = (f"friction law: {dyn_rig.friction_law} ({_bristle(dyn.fit)}) against static: "
               f"{t.evaluation} error {e0:.3f} -> {e1:.3f} % (floor {t.floor:.3f} %), "
               f"dBIC fit {d_fit:.1f}, {t.evaluation} {d_held:.1f}")
        b.law_note = msg + " — not adopted (does not earn by the decision rule)"
        return Attempt(self.name, error_before=e0, error_after=e1, delta_bic_fit=d_fit,
                       delta_bic_heldout=d_held, n_parameters=n_law,
                       change=(dyn.fit, dyn_rig, cand, k), message=msg)

    def confirm(self, attempt: Attempt, ctx: Context) -> bool:
        """Not adopted when one delay of the force record, fitted on the static model
        (:func:`~..candidates.force_lag.try_lag`), leaves an error no higher than the
        dynamic law's."""
        t, b = ctx.tests, ctx.base
        k = attempt.change[3]
        change = try_lag(t.fit_pts, t.held_pts, t.rig, b.fit, b.fit_pred, b.held_pred,
                         t.floor, b.n_eff_fit, b.n_eff_held, math.nan, ctx.settings,
                         lambda msg: None, decimation=k)
        if change is None or change.error > attempt.error_after:
            return True
        b.law_note = (f"{attempt.message} — not adopted: a delay of the force record by "
                      f"{1e3 * change.fields['parameters']['force_lag_s']:.1f} ms leaves "
                      f"{change.error:.3f} %, no more than the dynamic law (the delay is the "
                      f"simpler account; the record members judge it)")
        ctx.say(b.law_note)
        return False

    def adopt(self, attempt: Attempt, ctx: Context) -> None:
        """The dynamic law becomes the base law: the base model, the search's state and
        ``tests.rig`` (every member and candidate is fitted on it); the static law's
        outputs are kept as a record member's start (its own lag not yet taken by the
        bristles)."""
        fit, rig, cand, _ = attempt.change
        t, b = ctx.tests, ctx.base
        b.law_note = f"{attempt.message} — adopted as the base law"
        ctx.say(b.law_note)
        b.static_fit_pred = b.fit_pred
        b.fit, b.rig = fit, rig
        b.fit_pred, b.held_pred, b.n_eff_fit, b.n_eff_held = cand
        b.localisation = localise(t.fit_pts + t.held_pts, b.fit_pred + b.held_pred,
                                  lead_m_per_rad=t.lead_m_per_rad)
        b.error = force_error_percent(t.eval_pts, b.held_pred or b.fit_pred)
        t.rig = rig
        ctx.state = b.state(ctx.settings)


def _bristle(fit: FitResult) -> str:
    """σ₀, σ₁ (and δ) with the half-widths of their ≈95 % intervals, in words."""
    ci = parameter_intervals(fit)
    out = []
    for n, sym, unit in ((PRESLIDING_NAMES[0], "sigma0", "N/m"),
                         (PRESLIDING_NAMES[1], "sigma1", "N s/m"),
                         (STRIBECK_EXPONENT, "Stribeck exponent", "")):
        if n not in fit.parameters:
            continue
        lo, hi = ci.get(n, (math.nan, math.nan))
        out.append(f"{sym} {fit.parameters[n]:.4g} ± {(hi - lo) / 2:.2g} {unit}".rstrip())
    return "bristle " + ", ".join(out)
