"""Why a joint-state sample produced no prediction.

Every reason is counted separately by :class:`~scara_ident_ros.identification.OnlineIdentifier`,
so a bad driver, a misconfigured joint list and a clock problem show up as different counters.
"""
from __future__ import annotations

from enum import Enum

__all__ = ['SkipReason']


class SkipReason(str, Enum):
    """Reason a sample was rejected or could not yet be used.

    Rejections (the sample changes no state at all):

    - ``NON_FINITE``: a position, velocity or effort is NaN or infinite.
    - ``NO_POSITION``, ``NO_VELOCITY``: the array is empty.
    - ``NO_EFFORT``: the effort array is empty, or NaN for some joint, where every sample
      must have one (offline training). The online identifier does not refuse such a
      sample: it predicts it and counts it (``Counts.no_effort``), without learning it.
    - ``LENGTH_MISMATCH``: a non-empty array whose length differs from that of ``names``.
    - ``UNKNOWN_JOINT``: a name that is not one of the configured joints.
    - ``MISSING_JOINT``: a configured joint absent from the message.
    - ``DUPLICATE_JOINT``: a name that appears twice.
    - ``JOINT_COUNT``: no joint set is configured yet and the message's joint count differs
      from the model's.
    - ``STAMP_REPEATED``: the stamp equals that of the last accepted sample.
    - ``REPEATED``: the same positions, velocities and efforts as the last accepted sample,
      under a new stamp: a driver that sends its last state again (it would be learnt twice,
      and its stamp is not that of the state). Only samples with effort are compared: a
      robot at rest without effort sensors still gets its predictions.
    - ``STAMP_BACKWARDS``: the stamp is earlier than that of the last accepted sample (by at
      most the maximum gap; a larger jump is a ``GAP``).
    - ``OUT_OF_LIMITS``: a finite position, velocity or effort that the robot cannot have:
      beyond its limits by more than the configured margin (a sensor glitch, a unit or
      joint-order error). Learnt, such a sample would poison the model.

    Valid samples that cannot yet be used:

    - ``GAP``: the clock jumped by more than the maximum gap since the last accepted sample
      (forwards: samples lost; backwards: a simulator or bag replay restarted). The
      differentiator restarts from this sample.
    - ``WARMING_UP``: the differentiator does not have enough history for an acceleration.
    """

    NON_FINITE = 'non_finite'
    NO_POSITION = 'no_position'
    NO_VELOCITY = 'no_velocity'
    NO_EFFORT = 'no_effort'
    LENGTH_MISMATCH = 'length_mismatch'
    UNKNOWN_JOINT = 'unknown_joint'
    MISSING_JOINT = 'missing_joint'
    DUPLICATE_JOINT = 'duplicate_joint'
    JOINT_COUNT = 'joint_count'
    STAMP_REPEATED = 'stamp_repeated'
    REPEATED = 'repeated'
    STAMP_BACKWARDS = 'stamp_backwards'
    OUT_OF_LIMITS = 'out_of_limits'
    GAP = 'gap'
    WARMING_UP = 'warming_up'
