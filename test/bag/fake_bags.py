"""Synthetic joint states of an n-joint robot and bags holding them, for the offline tests.

The robot is a simple analytic one: each joint follows a sum of two sinusoids and its effort
is a smooth function of (q, q', q'') with inertia coupled to the next joint, viscous
friction and a gravity-like term, so a network can learn it in a few iterations.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from bag_files import (FLOAT64_ARRAY, JOINT_STATE, Robot,  # test/bag, beside this file
                       float_array, robot_messages, write_rosbags_bag)

METHODS = ('ffmw', 'ffw', 'ffs')


#: Joint states as arrays (the bag reader's shape), as the bag tests' ``Robot``.
States = Robot


def synthetic_states(n_joints: int, seconds: float, *, rate_hz: float = 1000.0,
                     seed: int = 0, start_ns: int = 1_700_000_000_000_000_000,
                     prefix: str = 'joint') -> States:
    """Smooth motion and the efforts of a simple analytic robot, sampled at ``rate_hz``."""
    rng = np.random.default_rng(seed)
    count = round(seconds * rate_hz)
    t = np.arange(count) / rate_hz
    stamps = start_ns + np.round(t * 1e9).astype(np.int64)
    amp = rng.uniform(0.3, 1.0, (2, n_joints))
    freq = rng.uniform(0.3, 1.5, (2, n_joints)) * 2 * np.pi  # rad/s
    phase = rng.uniform(0.0, 2 * np.pi, (2, n_joints))
    arg = freq[:, None, :] * t[None, :, None] + phase[:, None, :]  # (2, N, n)
    q = (amp[:, None, :] * np.sin(arg)).sum(axis=0)
    qd = (amp[:, None, :] * freq[:, None, :] * np.cos(arg)).sum(axis=0)
    qdd = -(amp[:, None, :] * freq[:, None, :] ** 2 * np.sin(arg)).sum(axis=0)
    coupling = np.cos(np.roll(q, -1, axis=1))
    effort = (1.0 + 0.3 * coupling) * qdd + 0.5 * qd + 2.0 * np.sin(q)
    names = tuple(f'{prefix}{i + 1}' for i in range(n_joints))
    return States(stamps, names, q, qd, effort)


def write_rosbag(path: Path, states: States, *, storage: str = 'sqlite3',
                 topic: str = '/joint_states', order: Sequence[int] | None = None,
                 extra_topics: dict[str, States] | None = None,
                 mse_topics: dict[str, tuple[NDArray[np.int64], NDArray[np.float64]]]
                 | None = None) -> Path:
    """Write a rosbag2 bag (``storage`` 'sqlite3' or 'mcap', version 8) with rosbags' Writer.

    ``order`` permutes the joints inside each message (names travel with the values);
    ``extra_topics`` adds more JointState topics; ``mse_topics`` adds Float64MultiArray
    topics as (log times (M,), data (M, k)).
    """
    topics = {name: (JOINT_STATE, list(zip(st.stamp_ns.tolist(),
                                           robot_messages(st, order=order))))
              for name, st in {topic: states, **(extra_topics or {})}.items()}
    for name, (times, data) in (mse_topics or {}).items():
        topics[name] = (FLOAT64_ARRAY, [(time_ns, float_array(row))
                                        for time_ns, row in zip(times.tolist(), data)])
    return write_rosbags_bag(path, topics, storage=storage, version=8)


def write_run_bag(path: Path, states: States, *, methods: Sequence[str] = METHODS,
                  errors: dict[str, float] | None = None, seed: int = 0) -> Path:
    """A fake recording of ``scara-ident run``: joint_states, and per method the
    a-priori predictions on ``/<m>/identified_torque`` (one per sample after the first
    two, stamped like the input, with a decaying error of relative size ``errors[m]``) and
    ``/<m>/identification_mse`` at 10 Hz."""
    rng = np.random.default_rng(seed)
    errors = errors or {'ffmw': 0.02, 'ffw': 0.1, 'ffs': 0.05}
    extra: dict[str, States] = {}
    mse: dict[str, tuple[NDArray[np.int64], NDArray[np.float64]]] = {}
    n = len(states.names)
    count = states.stamp_ns.shape[0]
    decay = 1.0 + 4.0 * np.exp(-np.arange(count - 2) / (count / 4))
    for m in methods:
        scale = errors.get(m, 0.05) * states.effort.std(axis=0)
        noise = rng.normal(0.0, 1.0, (count - 2, n)) * scale * decay[:, None]
        predicted = states.effort[2:] + noise
        extra[f'/{m}/identified_torque'] = States(
            states.stamp_ns[2:], states.names, np.zeros((count - 2, 0)),
            np.zeros((count - 2, 0)), predicted)
        times = states.stamp_ns[2::100]
        data = np.tile(np.r_[(scale ** 2), (scale ** 2).mean(), np.full(n + 1, 0.01)],
                       (times.shape[0], 1))
        mse[f'/{m}/identification_mse'] = (times, data)
    return write_rosbag(path, states, storage='mcap', extra_topics=extra, mse_topics=mse)
