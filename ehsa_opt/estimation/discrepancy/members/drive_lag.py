"""Member ``drive_lag``: the drive's sample-and-hold and a first-order lag beyond it, on a
rig without generator whose force is the drive's command (EMPS).

Fitted by :func:`~..candidates.drive_lag.try_drive_lag`; once it earns, the search judges
on the applied force (the recorded force through the inverse of the drive's lag)."""

from __future__ import annotations

from ..candidates.drive_lag import try_drive_lag
from .protocol import Attempt, Context, Member
from .record_change import adopt_record_change, attempt_from_change

__all__ = ["DriveLagMember"]


class DriveLagMember(Member):
    """The drive's hold and lag (see the module docstring)."""

    name = "drive_lag"
    kind = "record"
    channel = "drive"
    setting = "drive_lag"

    def applicable(self, ctx: Context) -> str:
        if ctx.tests.rig.has_generator:
            return "-"
        return super().applicable(ctx)

    def fit(self, ctx: Context) -> Attempt | None:
        t, s, b = ctx.tests, ctx.state, ctx.base
        change = try_drive_lag(t.fit_pts, t.held_pts, t.rig, b.fit, s.fit_pred, s.held_pred,
                               t.floor, s.n_eff_fit, s.n_eff_held, b.error, ctx.settings,
                               ctx.say)
        return None if change is None else attempt_from_change(self.name, change, 1)

    def adopt(self, attempt: Attempt, ctx: Context) -> None:
        f = attempt.fields
        adopt_record_change(attempt, ctx, {
            "effect": self.name, "error_after": f["error_after"],
            "error_after_on_applied_force": attempt.change.error,
            "excess_reduction": f["excess_reduction"], "parameters": f["parameters"]})
