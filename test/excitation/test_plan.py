"""The plan: from rest at the arm's position, the approach, then the sequence; all of it
continuous and within the limits with margins."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.excitation import ExcitationPlan

sys.path.insert(0, str(Path(__file__).parent))  # --import-mode=importlib
from smoothness import assert_consistent  # noqa: E402

DT = 0.001  # s


@pytest.mark.parametrize('start', [
    [0.0, 0.0, 0.1, 0.0],          # mid-range
    [-2.2, 2.4, 0.195, 6.0],       # in the margins, near the limits
])
def test_the_plan_starts_at_rest_and_keeps_to_the_limits(start: list[float],
                                                         margined: JointLimits) -> None:
    plan = ExcitationPlan(margined, np.array(start), seed=2)
    t = np.arange(0.0, plan.approach_duration + 12.0, DT)
    q, qd, qdd = plan.evaluate(t)
    np.testing.assert_allclose(q[0], start, atol=1e-15)
    assert np.all(qd[0] == 0.0) and np.all(qdd[0] == 0.0)
    assert margined.violations(q, qd, qdd, position_hull=np.array(start)) == []
    assert_consistent(t, q, qd, qdd)
    # after the approach, the plan is the sequence (its t = 0 is the end of the approach)
    after = t >= plan.approach_duration
    for ours, sequence in zip((q, qd, qdd),
                              plan.sequence.evaluate(t[after] - plan.approach_duration)):
        np.testing.assert_allclose(ours[after], sequence, rtol=0, atol=1e-12)


def test_the_approach_ends_in_the_sequences_state(margined: JointLimits) -> None:
    plan = ExcitationPlan(margined, np.array([1.5, -1.8, 0.05, -4.0]), seed=0)
    t_a = plan.approach_duration
    assert t_a > 1.0  # a far start needs a longer approach
    before = plan.evaluate(np.array([t_a - 1e-7]))
    after = plan.sequence.evaluate(np.array([0.0]))
    for x, y in zip(before, after):
        np.testing.assert_allclose(x, y, atol=1e-4)
