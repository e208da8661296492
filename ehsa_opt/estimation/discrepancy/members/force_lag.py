"""Member ``force_lag``: one delay of the force record against the displacement (the
limit of the force sensor's dynamics, :mod:`.force_sensor`, at a bandwidth far above the
tests' frequencies).

Fitted by :func:`~..candidates.force_lag.try_lag`; before it is adopted, the members the
first round would re-identify are fitted on the record as it is
(:func:`~..lag_rival.lag_rival`): a member whose physics delays the force (a mount
spring) and leaves a lower error is the simpler account."""

from __future__ import annotations

from ..baseline import baseline_decimation
from ..candidates.force_lag import try_lag
from ..judge import withdraw
from ..lag_rival import channel_excess_reduction, lag_rival
from ..results import CandidateResult
from .protocol import Attempt, Context, Member
from .record_change import adopt_record_change, attempt_from_change

__all__ = ["ForceLagMember", "no_force_channel_member"]


def no_force_channel_member(ctx: Context, name: str) -> str:
    """Why a force-record member is not tried ("" when it is): the data-driven stage
    is off, or the drive's lag already describes the recorded force's lead."""
    if name not in ctx.settings.candidates or not ctx.settings.discover:
        return "-"
    if "drive_lag" in ctx.state.effects:
        return (f"{name} not searched: the drive lag already describes the recorded "
                f"force's lead")
    return ""


class ForceLagMember(Member):
    """A delay of the force record (see the module docstring)."""

    name = "force_lag"
    kind = "record"
    channel = "force record"
    setting = "force_lag"

    def applicable(self, ctx: Context) -> str:
        return no_force_channel_member(ctx, self.name)

    def fit(self, ctx: Context) -> Attempt | None:
        t, s, b = ctx.tests, ctx.state, ctx.base
        change = try_lag(t.fit_pts, t.held_pts, t.rig, b.fit, s.fit_pred, s.held_pred,
                         t.floor, s.n_eff_fit, s.n_eff_held, b.error, ctx.settings, ctx.say,
                         decimation=baseline_decimation(t.fit_pts, t.rig))
        return None if change is None else attempt_from_change(self.name, change, 1)

    def confirm(self, attempt: Attempt, ctx: Context) -> bool:
        return confirm_record_member(self.name, attempt, ctx)

    def adopt(self, attempt: Attempt, ctx: Context) -> None:
        adopt_record_change(attempt, ctx)


def confirm_record_member(name: str, attempt: Attempt, ctx: Context, ch: int = 0) -> bool:
    """Not adopted when a catalogue member the first round would add, fitted on the
    record as it is, earns and accounts for the member's channel ``ch`` better
    (:func:`~..lag_rival.lag_rival`: on the force a lower held-out force error, on the
    voltage at least the member's share of the voltage's SSE excess removed); the
    withdrawn attempt is kept in the results with the reason noted."""
    if ch == 0:
        def beats(c) -> bool:
            return c.error_after < attempt.change.error
    else:
        own = attempt.sse_excess_reduction if attempt.sse_excess_reduction is not None else 0.0

        def beats(c) -> bool:
            return channel_excess_reduction(ctx.tests, ctx.state, c, ch) >= own
    rival = lag_rival(ctx.tests, ctx.state, ctx.settings, beats, ctx.say, ctx.notes, name)
    if rival is None:
        return True
    cand = CandidateResult(**attempt.fields)
    withdraw(cand, "")
    ctx.results.append(cand)
    if ch == 0:
        how = (f"earns and leaves {rival.error_after:.3f} % against {name}'s "
               f"{attempt.change.error:.3f} %: the member's physics accounts for the force "
               f"without changing the record")
    else:
        how = (f"earns and removes {100 * channel_excess_reduction(ctx.tests, ctx.state, rival, ch):.0f} % "
               f"of the voltage's SSE excess against {name}'s "
               f"{100 * (attempt.sse_excess_reduction or 0.0):.0f} %: the member's physics "
               f"accounts for the voltage without changing the record")
    note = f"{name}: not named — {rival.effect}, fitted on the record as it is, {how}"
    ctx.say(note)
    ctx.notes.append(note)
    return False
