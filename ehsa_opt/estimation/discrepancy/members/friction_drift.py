"""Member ``friction_drift``: the friction level drifting over the campaign as the rig
runs in or warms (:mod:`..candidates.friction_drift`: a first-order run-in over the
cumulative sliding distance, or a first-order thermal mass heated by the friction and
cooling in the pauses, in the tests' run order).  A law member: once it earns, every
model the search judges carries its own drift term.  Tried only on a campaign whose tests
state their run order (``run_order`` or ``started_at`` in ``bench.toml``)."""

from __future__ import annotations

import math

from ..candidates.friction_drift import FrictionDrift, run_order_known
from ..evidence import effective_samples, force_error_percent
from ..judge import excess_reduction
from ..localise import localise
from ..results import CandidateResult
from .protocol import Attempt, Context, Member

__all__ = ["FrictionDriftMember"]


class FrictionDriftMember(Member):
    """The campaign's friction drift (see the module docstring)."""

    name = "friction_drift"
    kind = "law"
    channel = "friction level"
    setting = "friction_drift"
    refits = False
    offered_after_rounds = True

    def applicable(self, ctx: Context) -> str:
        why = super().applicable(ctx)
        if why:
            return why
        t = ctx.tests
        if not run_order_known(t.fit_pts + t.held_pts):
            return "-"  # nothing to say on a campaign without run order: the usual case
        return ""

    def fit(self, ctx: Context) -> Attempt | None:
        t, s = ctx.tests, ctx.state
        law = FrictionDrift.fit(t.fit_pts, s.fit_pred, t.held_pts, s.held_pred, s.n_eff_fit,
                                s.n_eff_held)
        lo, hi = law.interval_N
        how = (f"over a run-in of {law.run_in_m:.3g} m of sliding (the campaign slides "
               f"{law.total_travel_m:.3g} m" if law.law == "run_in" else
               f"at the campaign's hottest point, a thermal mass heated by the friction with "
               f"a time constant of {law.time_constant_s:.3g} s (pauses between tests "
               + ("from their started_at stamps" if law.pauses_known else
                  "unknown: tests taken back to back"))
        msg = (f"friction_drift: the Coulomb level changes by {law.amplitude_N:+.3g} N "
               f"[{lo:+.3g}, {hi:+.3g}] {how}, tests in run order: "
               f"{law.change_over_campaign_N:+.3g} N from its first to its last sample); "
               f"error {law.error_before:.3f} -> {law.error_after:.3f} %, ΔBIC fit "
               f"{law.delta_bic_fit:.1f}, held-out {law.delta_bic_heldout:.1f}")
        params = {"drift_amplitude_N": law.amplitude_N,
                  **({"drift_run_in_m": law.run_in_m} if law.law == "run_in" else
                     {"drift_time_constant_s": law.time_constant_s}),
                  "drift_over_campaign_N": law.change_over_campaign_N}
        fields = dict(effect=self.name, applicable=True, score=math.nan, chi2=math.nan,
                      round=1, fitted=True, fit=ctx.base.fit, error_before=law.error_before,
                      excess_reduction=excess_reduction(law.error_before, law.error_after,
                                                        t.floor, ctx.settings.criterion),
                      error_after=law.error_after, delta_bic_fit=law.delta_bic_fit,
                      delta_bic_heldout=law.delta_bic_heldout, resolved=law.resolved,
                      parameters=params, intervals={"drift_amplitude_N": law.interval_N},
                      rig=t.rig)
        return Attempt(self.name, error_before=law.error_before, error_after=law.error_after,
                       delta_bic_fit=law.delta_bic_fit, delta_bic_heldout=law.delta_bic_heldout,
                       n_parameters=2, resolved=law.resolved, fields=fields, change=law,
                       message=msg)

    def adopt(self, attempt: Attempt, ctx: Context) -> None:
        """Every model judged from here on carries its own drift term; the state's and
        the base model's predictions get theirs now."""
        law = attempt.change
        law.adopted = True
        t, s, base = ctx.tests, ctx.state, ctx.base
        t.laws.append(law)
        ctx.results.append(CandidateResult(**attempt.fields))
        s.fit_pred, s.held_pred = law.correct(t.fit_pts, s.fit_pred, t.held_pts, s.held_pred)
        s.error = force_error_percent(t.eval_pts, s.eval_pred())
        s.n_eff_fit = effective_samples(t.fit_pts, s.fit_pred)
        s.n_eff_held = effective_samples(t.held_pts, s.held_pred) if t.held_pts else math.nan
        s.effects.append(self.name)
        s.steps.append({"effect": self.name, "error_after": s.error,
                        "excess_reduction": attempt.fields["excess_reduction"],
                        "parameters": attempt.fields["parameters"]})
        base.fit_pred, base.held_pred = law.correct(t.fit_pts, base.fit_pred, t.held_pts,
                                                    base.held_pred)
        base.localisation = localise(t.fit_pts + t.held_pts, base.fit_pred + base.held_pred,
                                     lead_m_per_rad=t.lead_m_per_rad)
