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
from ..lag_rival import lag_rival
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


def confirm_record_member(name: str, attempt: Attempt, ctx: Context) -> bool:
    """Not adopted when a catalogue member the first round would add, fitted on the
    record as it is, earns and leaves a lower error (:func:`~..lag_rival.lag_rival`);
    the withdrawn attempt is kept in the results with the reason noted."""
    rival = lag_rival(ctx.tests, ctx.state, ctx.settings, attempt.change.error, ctx.say,
                      ctx.notes)
    if rival is None:
        return True
    cand = CandidateResult(**attempt.fields)
    withdraw(cand, "")
    ctx.results.append(cand)
    note = (f"{name}: not named — {rival.effect}, fitted on the record as it is, "
            f"earns and leaves {rival.error_after:.3f} % against {name}'s "
            f"{attempt.change.error:.3f} %: the member's physics accounts for the force "
            f"without changing the record")
    ctx.say(note)
    ctx.notes.append(note)
    return False
