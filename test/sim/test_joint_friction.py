"""Stribeck friction: its levels, its symmetry, its checks and its RK4 step bound."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics.params import ParamError
from scara_ident_ros.sim.joint_friction import RK4_STABILITY, JointFriction

FRICTION = JointFriction(viscous=(2.0, 0.5), coulomb=(4.0, 1.0), static=(6.0, 1.0),
                         stribeck_velocity=(0.05, 0.1), stick_velocity=(0.002, 0.01))


def test_levels_sliding_breakaway_and_rest() -> None:
    np.testing.assert_array_equal(FRICTION(np.zeros(2)), [0.0, 0.0])
    fast = np.array([2.0, -3.0])                     # well above vs: Coulomb + viscous
    np.testing.assert_allclose(FRICTION(fast), [4.0 + 2.0 * 2.0, -1.0 - 0.5 * 3.0],
                               rtol=1e-12)
    # Just past the sticking band the level is near the static one, then falls (Stribeck).
    v = np.linspace(1e-4, 1.0, 20001)
    level = FRICTION(np.stack([v, v], axis=1))[:, 0] - 2.0 * v
    assert 5.8 < level.max() <= 6.0
    assert level[np.searchsorted(v, 0.2)] < 4.01      # down to Coulomb at 4 vs


def test_odd_in_velocity_and_batched() -> None:
    qd = np.random.default_rng(0).normal(size=(50, 2))
    np.testing.assert_array_equal(FRICTION(-qd), -FRICTION(qd))
    np.testing.assert_array_equal(FRICTION(qd)[7], FRICTION(qd[7]))


def test_scaled_defaults_and_checks() -> None:
    friction = JointFriction.scaled([100.0, 10.0], viscous=0.02, coulomb=0.03, static=0.04,
                                    stribeck_velocity=0.05, stick_velocity=0.02)
    assert friction.viscous == (2.0, 0.2) and friction.coulomb == (3.0, 0.3)
    assert friction.static == (4.0, 0.4) and friction.stick_velocity == (0.02, 0.02)
    with pytest.raises(ParamError, match=r'static\[0\] = 1.0 must be >= coulomb\[0\]'):
        JointFriction((0.0,), (2.0,), (1.0,), (0.1,), (0.01,))
    with pytest.raises(ParamError, match='coulomb must have 2 values'):
        JointFriction((0.0, 0.0), (2.0,), (3.0, 3.0), (0.1, 0.1), (0.01, 0.01))
    with pytest.raises(ParamError, match=r'stick_velocity\[1\] must be > 0'):
        JointFriction((0.0, 0.0), (1.0, 1.0), (1.0, 1.0), (0.1, 0.1), (0.01, 0.0))


def test_max_stable_step_is_the_rk4_bound_of_the_steepest_joint() -> None:
    slope = np.array([6.0 / 0.002 + 2.0, 1.0 / 0.01 + 0.5])   # N·m·s/rad at v = 0
    np.testing.assert_allclose(FRICTION.slope_max(), slope)
    inertia = [0.5, 0.001]
    assert FRICTION.max_stable_step(inertia) == pytest.approx(
        RK4_STABILITY / max(slope / inertia))
    none = JointFriction((0.0,), (0.0,), (0.0,), (0.1,), (0.01,))
    assert none.max_stable_step([0.1]) == float('inf')
