"""A stop from any time brings the arm to rest along its path within the acceleration
limits: no jump in q, q', q''."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.excitation import ExcitationPlan, Stop, plan_stop

sys.path.insert(0, str(Path(__file__).parent))  # --import-mode=importlib
from smoothness import assert_consistent  # noqa: E402


@pytest.mark.parametrize('scales', [(0.5, 0.5), (1.0, 0.1)])
def test_stops_from_many_times_are_smooth_and_end_at_rest(scales: tuple[float, float],
                                                          limits: JointLimits) -> None:
    margined = limits.with_margins(0.1, *scales)
    plan = ExcitationPlan(margined, np.array([0.3, -0.2, 0.12, 1.0]), seed=5)
    too_hard = []
    for start in np.arange(0.0, 25.0, 0.37):
        stop = plan_stop(plan, start, margined, 0.01)
        assert stop.duration >= 0.5
        t = np.arange(start, stop.end + 0.2, 0.001)
        q, qd, qdd = stop.evaluate(t)
        # it begins as the plan goes on ...
        for ours, planned in zip(stop.evaluate(np.array([start])),
                                 plan.evaluate(np.array([start]))):
            np.testing.assert_allclose(ours, planned, rtol=0, atol=1e-12)
        # ... decelerates within the limits, without a jump, along the plan's path ...
        assert np.all(np.abs(qdd) <= margined.acceleration_max * (1 + 1e-3))
        assert np.all(np.abs(qd) <= margined.velocity_max * (1 + 1e-9))
        assert_consistent(t, q, qd, qdd)
        assert margined.violations(q, qd, qdd, position_hull=plan.start) == []
        # ... and is at rest, held, from its end on
        rest = t >= stop.end
        assert np.all(qd[rest] == 0.0) and np.all(np.abs(qdd[rest]) < 1e-9)
        assert np.ptp(q[rest], axis=0).max() == 0.0
        # a stop five times shorter would decelerate harder than the limits allow
        _, _, hard = Stop(plan, start, stop.duration / 5).evaluate(t)
        too_hard.append(bool(np.any(np.abs(hard) > margined.acceleration_max)))
    assert np.mean(too_hard) > 0.5, 'the limits must bind: the test would show nothing'

