"""The chunks as the node sends them: every sample within the limits with margins, each
continuous and ending at rest, any two agreeing where they overlap."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.excitation import ExcitationPlan, make_chunk

sys.path.insert(0, str(Path(__file__).parent))  # --import-mode=importlib
from smoothness import assert_consistent  # noqa: E402

STEP = 0.01           # s, point period
CHUNK_PERIOD = 0.25   # s
HORIZON = 1.0         # s


def test_chunks_are_continuous_within_limits_and_agree(margined: JointLimits) -> None:
    start = np.array([-1.0, 1.2, 0.15, 3.0])
    plan = ExcitationPlan(margined, start, seed=1)
    chunks = [make_chunk(plan, t - STEP, t + HORIZON, STEP, margined)
              for t in np.arange(0.0, 20.0, CHUNK_PERIOD)]
    for chunk in chunks:
        assert margined.violations(chunk.q, chunk.qd, chunk.qdd, position_hull=start) == []
        assert np.all(np.diff(chunk.times) > 0.999 * STEP)
        assert_consistent(chunk.times, chunk.q, chunk.qd, chunk.qdd, rtol=0.02)
        assert chunk.times[-1] == chunk.rest_time
        assert np.all(chunk.qd[-1] == 0.0) and np.all(np.abs(chunk.qdd[-1]) < 1e-9)
        # on the plan up to its stop
        on_plan = chunk.times <= chunk.stop_time
        np.testing.assert_allclose(chunk.q[on_plan], plan.evaluate(chunk.times[on_plan])[0],
                                   rtol=0, atol=1e-12)
    for old, new in zip(chunks, chunks[1:]):
        # the new chunk starts before the old one's stop: the arm switches on the plan
        assert new.times[0] < old.stop_time
        shared = np.isin(np.round(old.times / STEP), np.round(new.times / STEP))
        mine = np.isin(np.round(new.times / STEP), np.round(old.times / STEP))
        both = shared & (old.times <= min(old.stop_time, new.stop_time))
        np.testing.assert_allclose(
            old.q[both], new.q[mine & (new.times <= min(old.stop_time, new.stop_time))],
            rtol=0, atol=1e-12)
