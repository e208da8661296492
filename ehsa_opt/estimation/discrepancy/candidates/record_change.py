"""What a member that acts on the record (a delay of the force channel, the drive's lag)
hands back when fitted (the judge then decides): the tests as the search uses them from then on and the
baseline refitted on them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...fit_result import FitResult
from ..prepared import PreparedTest

__all__ = ["RecordChange"]


@dataclass
class RecordChange:
    """The record as changed by an earning member.

    Attributes
    ----------
    fit_pts, held_pts : list of PreparedTest
        The fit and held-out tests from here on (re-aligned, or with the applied force).
    baseline : FitResult
        The base model refitted on them.
    fit_pred, held_pred : list of ndarray
        Its simulated outputs on them.
    error : float
        Its relative force error on the evaluation tests, %.
    fields : dict
        The member's :class:`~..results.CandidateResult` fields (verdict included).
    floor : float
        The noise floor of the changed force, % (NaN: unchanged).
    notes : list of str
        What the report says about the member.
    message : str
        The member's evidence in words (said with the verdict).
    """

    fit_pts: list[PreparedTest]
    held_pts: list[PreparedTest]
    baseline: FitResult
    fit_pred: list[np.ndarray]
    held_pred: list[np.ndarray]
    error: float
    fields: dict
    floor: float = math.nan
    notes: list[str] = field(default_factory=list)
    message: str = ""
