"""Member ``voltage_skew``: a delay of the voltage record against force and displacement
(a skew of the acquisition), on a rig that measures the generator's voltage.

Fitted and measured by :func:`~..voltage_skew.find_voltage_skew`; decided by the judge on
its own statistics (:func:`~..judge.skew_found`: the force is not what changes); once
it earns, every test's voltage is re-aligned before the rounds and no catalogue member
is named for it."""

from __future__ import annotations

import math

from ..evidence import effective_samples
from ..voltage_skew import realign_voltage, find_voltage_skew
from .protocol import Attempt, Context, Member

__all__ = ["VoltageSkewMember"]


class VoltageSkewMember(Member):
    """A skew of the voltage record (see the module docstring)."""

    name = "voltage_skew"
    kind = "record"
    channel = "voltage record"
    refits = False

    def applicable(self, ctx: Context) -> str:
        return "" if ctx.tests.rig.has_generator else "-"

    def fit(self, ctx: Context) -> Attempt | None:
        t, s = ctx.tests, ctx.state
        skew = find_voltage_skew(t.fit_pts, s.fit_pred, t.held_pts, s.held_pred, s.n_eff_fit,
                                 s.n_eff_held, t.rig.harvester, ctx.settings.criterion)
        ctx.skew = skew
        if skew is None:
            return None
        ctx.notes.append(skew.message)
        return Attempt(self.name, delta_bic_fit=skew.dbic_fit, delta_bic_heldout=skew.dbic_held,
                       change=skew, message=skew.message, decided_by="voltage skew",
                       evidence=dict(skew.evidence))

    def adopt(self, attempt: Attempt, ctx: Context) -> None:
        """Every test's voltage re-aligned from here on (the model's outputs are the same
        samples; the effective sample sizes are recomputed)."""
        t, s, skew = ctx.tests, ctx.state, attempt.change
        fit_ids = {id(pt): k for k, pt in enumerate(t.fit_pts)}
        sub_idx = [fit_ids[id(pt)] for pt in t.sub_pts]
        t.fit_pts = realign_voltage(t.fit_pts, skew.delay_s)
        t.held_pts = realign_voltage(t.held_pts, skew.delay_s)
        t.sub_pts = [t.fit_pts[k] for k in sub_idx]
        s.n_eff_fit = effective_samples(t.fit_pts, s.fit_pred)
        s.n_eff_held = effective_samples(t.held_pts, s.held_pred) if t.held_pts else math.nan
