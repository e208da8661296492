"""Members ``force_sensor`` and ``voltage_sensor``: a measurement channel's own dynamics,
a second-order low-pass (bandwidth f_c, damping ζ) between the quantity and its record;
:mod:`..candidates.sensor_dynamics` fits them and measures their evidence.

``force_sensor`` is the rival of ``force_lag`` on the force record (a delay is its limit
at a bandwidth far above the tests'): when both earn, the judge keeps the delay unless
the filter's held-out ΔBIC is lower by the criterion's ``nested_evidence``
(:func:`~..judge.choose_rival`).  Like the delay, it is not adopted when a catalogue
member fitted on the record as it is accounts for the force better (a mount spring with
the reflected mass is a second-order low-pass too, but it also delays the rotor and thus
the voltage).  ``voltage_sensor`` is the rival of ``voltage_skew`` on the voltage record
and is judged on the voltage channel's SSE, the force kept (:func:`~..judge.earns`); it
too is not adopted when a catalogue member accounts for the voltage record better —
removes at least the share of the voltage's SSE excess the filter removes (a mount
spring delays the rotor, and so the voltage: on a campaign with a mount compliance and
a load cell the voltage's "filter" had been named before the compliance was tried)."""

from __future__ import annotations

from ..baseline import baseline_decimation
from ..candidates.sensor_dynamics import try_sensor
from .force_lag import confirm_record_member, no_force_channel_member
from .protocol import Attempt, Context, Member
from .record_change import adopt_record_change, attempt_from_change

__all__ = ["ForceSensorMember", "VoltageSensorMember"]


class ForceSensorMember(Member):
    """The force sensor's dynamics (see the module docstring)."""

    name = "force_sensor"
    kind = "record"
    channel = "force record"
    setting = "force_sensor"
    ch = 0

    def applicable(self, ctx: Context) -> str:
        return no_force_channel_member(ctx, self.name)

    def fit(self, ctx: Context) -> Attempt | None:
        t, s, b = ctx.tests, ctx.state, ctx.base
        change = try_sensor(t.fit_pts, t.held_pts, t.rig, b.fit, s.fit_pred, s.held_pred,
                            t.floor, s.n_eff_fit, s.n_eff_held, ctx.settings,
                            decimation=baseline_decimation(t.fit_pts, t.rig), ch=self.ch,
                            start_pred=b.static_fit_pred)
        if change is None:
            ctx.say(f"{self.name}: the refit on the adjusted record failed")
            return None
        att = attempt_from_change(self.name, change, 2)
        att.sse_excess_reduction = change.fields.get("sse_reduction")
        att.n_force = sum(pt.y.shape[1] for pt in (t.held_pts or t.fit_pts))
        return att

    def confirm(self, attempt: Attempt, ctx: Context) -> bool:
        return confirm_record_member(self.name, attempt, ctx, self.ch)

    def adopt(self, attempt: Attempt, ctx: Context) -> None:
        adopt_record_change(attempt, ctx)


class VoltageSensorMember(ForceSensorMember):
    """The voltage record's conditioning dynamics (see the module docstring)."""

    name = "voltage_sensor"
    channel = "voltage record"
    setting = "voltage_sensor"
    ch = 1

    def applicable(self, ctx: Context) -> str:
        if not ctx.tests.rig.has_generator:
            return "-"
        return Member.applicable(self, ctx)
