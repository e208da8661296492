"""The members of the discrepancy engine behind one protocol (:mod:`.protocol`).

The record and law members, in the order they are offered before the rounds
(:data:`RECORD_MEMBERS`; the members of one channel are rivals):

* :mod:`.dynamic_law` — the base friction law's dynamics (LuGre bristles; opt-in), first:
  once adopted every other member is fitted on it;
* :mod:`.voltage_skew` and :mod:`.sensor_dynamics` (``voltage_sensor``) — a delay of the
  voltage record and its conditioning's second-order dynamics (a rig with a generator);
* :mod:`.drive_lag` — the drive's hold and lag (a rig without generator);
* :mod:`.force_lag` and :mod:`.sensor_dynamics` (``force_sensor``) — a delay of the
  force record, and the force sensor's second-order dynamics whose limit the delay is;
* :mod:`.presliding` — a presliding transition of the friction law (opt-in);
* :mod:`.friction_drift` — the friction level drifting over the campaign (a campaign
  whose tests state their run order).

The catalogue effects (components of the bench model) are members too: ranked by their
signature scores and fitted in the forward-selection rounds
(:mod:`..candidates.catalogue`, :mod:`..search`).
"""

from .drive_lag import DriveLagMember
from .dynamic_law import DynamicLawMember
from .force_lag import ForceLagMember
from .sensor_dynamics import ForceSensorMember, VoltageSensorMember
from .friction_drift import FrictionDriftMember
from .presliding import PreslidingMember
from .protocol import Attempt, Context, Member, run_members
from .voltage_skew import VoltageSkewMember

__all__ = ["Member", "Attempt", "Context", "run_members", "RECORD_MEMBERS", "RECORD_MEMBER_NAMES",
           "DynamicLawMember", "VoltageSkewMember", "VoltageSensorMember", "DriveLagMember", "ForceLagMember",
           "ForceSensorMember",
           "PreslidingMember", "FrictionDriftMember"]

#: The record and law members, in the order they are offered before the rounds.
RECORD_MEMBERS: tuple[Member, ...] = (DynamicLawMember(), VoltageSkewMember(),
                                      VoltageSensorMember(),
                                      DriveLagMember(), ForceLagMember(),
                                      ForceSensorMember(), PreslidingMember(),
                                      FrictionDriftMember())

#: The names :attr:`~..results.DiscrepancySettings.candidates` may list beside the
#: catalogue's (the others have their own switches).
RECORD_MEMBER_NAMES: tuple[str, ...] = tuple(m.setting for m in RECORD_MEMBERS
                                             if m.setting is not None)
