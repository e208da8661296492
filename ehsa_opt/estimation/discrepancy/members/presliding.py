"""Member ``presliding``: a presliding transition of the base model's friction law,
sign(v) exp(−s/ℓ) after every reversal (:mod:`..presliding`), offered when
:attr:`~..results.DiscrepancySettings.presliding` is on; once it earns, every model the
search judges carries its own such term (:meth:`~..presliding.PreslidingLaw.correct`)."""

from __future__ import annotations

import math

from ..evidence import effective_samples, force_error_percent
from ..localise import localise
from ..presliding import adopt_presliding
from .protocol import Attempt, Context, Member

__all__ = ["PreslidingMember"]


class PreslidingMember(Member):
    """The friction law's presliding transition (see the module docstring)."""

    name = "presliding"
    kind = "law"
    channel = "friction law"
    refits = False

    def applicable(self, ctx: Context) -> str:
        return "" if ctx.settings.presliding else "-"

    def fit(self, ctx: Context) -> Attempt | None:
        t, s = ctx.tests, ctx.state
        law = adopt_presliding(t.fit_pts, s.fit_pred, t.held_pts, s.held_pred, t.floor,
                               s.n_eff_fit, s.n_eff_held, criterion=ctx.settings.criterion)
        ctx.law = law
        ctx.notes.append(law.message)
        return Attempt(self.name, error_before=law.error_before, error_after=law.error_after,
                       delta_bic_fit=law.delta_bic_fit,
                       delta_bic_heldout=law.delta_bic_heldout,
                       n_parameters=len(law.lengths_m), change=law, message=law.message)

    def adopt(self, attempt: Attempt, ctx: Context) -> None:
        """The state's and the base model's predictions get their presliding term (the
        error, the effective sample sizes and the localisation are of the corrected
        model) and ``tests.laws`` carries the law to every model judged."""
        law = attempt.change
        law.adopted = True
        t, s, base = ctx.tests, ctx.state, ctx.base
        t.presliding = law
        t.laws.append(law)
        fit_pts, held_pts = t.fit_pts, t.held_pts
        s.fit_pred, s.held_pred = law.correct(fit_pts, s.fit_pred, held_pts, s.held_pred)
        s.error = force_error_percent(t.eval_pts, s.eval_pred())
        s.n_eff_fit = effective_samples(fit_pts, s.fit_pred)
        s.n_eff_held = effective_samples(held_pts, s.held_pred) if held_pts else math.nan
        if not s.effects:
            base.error = s.error
        base.fit_pred, base.held_pred = law.correct(fit_pts, base.fit_pred, held_pts,
                                                    base.held_pred)
        base.localisation = localise(fit_pts + held_pts, base.fit_pred + base.held_pred,
                                     lead_m_per_rad=t.lead_m_per_rad)
