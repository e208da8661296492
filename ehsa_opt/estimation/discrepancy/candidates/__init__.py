"""The catalogue of candidate effects: every member the discrepancy search can name.

* :mod:`.catalogue`: the members that are components of the bench model
  (:data:`CANDIDATES`: signature probes, fit starts and recipe of each), their
  signature scores and the columns a baseline refit absorbs;
* :mod:`.force_lag`: the member ``force_lag``, a delay of the force channel (it acts
  on the record, not on the physics: found by a time-shift search, the force
  re-aligned and the baseline refitted);
* :mod:`.flexibility`: the member ``flexibility`` of a rig without generator, fitted
  by variable projection;
* :mod:`.drive_lag`: the member ``drive_lag`` (the DAC's hold and a lag beyond it);
* :mod:`.mode_band`: a mode above the drive's band, judged on a record's apparent mass
  after the hold and the lag (reported beside the open-loop validation).
"""

from .catalogue import (
    CANDIDATES,
    Candidate,
    absorbed_columns,
    candidate_names,
    compatible,
    components_for,
    rank_value,
    MIN_RANK_VALUE,
    signature_scores,
)
from .drive_lag import try_drive_lag
from .flexibility import fit_flexibility, fit_flexibility_member, flexibility_refusal
from .force_lag import try_lag

__all__ = ["CANDIDATES", "Candidate", "absorbed_columns", "candidate_names", "compatible",
           "components_for", "rank_value", "MIN_RANK_VALUE", "signature_scores",
           "fit_flexibility", "fit_flexibility_member",
           "flexibility_refusal", "try_lag", "try_drive_lag"]
