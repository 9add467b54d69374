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

from bag_files import Robot  # test/bag, beside this file

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


def _typestore():  # type: ignore[no-untyped-def]
    from rosbags.typesys import Stores, get_typestore
    return get_typestore(Stores.ROS2_HUMBLE)


def _joint_state(store, stamp_ns: int, names: Sequence[str], position: NDArray[np.float64],
                 velocity: NDArray[np.float64], effort: NDArray[np.float64]):  # type: ignore
    types = store.types
    stamp = types['builtin_interfaces/msg/Time'](sec=int(stamp_ns // 1_000_000_000),
                                                 nanosec=int(stamp_ns % 1_000_000_000))
    header = types['std_msgs/msg/Header'](stamp=stamp, frame_id='')
    return types['sensor_msgs/msg/JointState'](
        header=header, name=list(names), position=np.asarray(position, np.float64),
        velocity=np.asarray(velocity, np.float64), effort=np.asarray(effort, np.float64))


def write_rosbag(path: Path, states: States, *, storage: str = 'sqlite3',
                 topic: str = '/joint_states', order: Sequence[int] | None = None,
                 extra_topics: dict[str, States] | None = None,
                 mse_topics: dict[str, tuple[NDArray[np.int64], NDArray[np.float64]]]
                 | None = None) -> Path:
    """Write a rosbag2 bag (``storage`` 'sqlite3' or 'mcap') with rosbags' Writer.

    ``order`` permutes the joints inside each message (names travel with the values);
    ``extra_topics`` adds more JointState topics; ``mse_topics`` adds Float64MultiArray
    topics as (log times (M,), data (M, k)).
    """
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = _typestore()
    plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
    perm = np.arange(len(states.names)) if order is None else np.asarray(order)
    topics = {topic: states, **(extra_topics or {})}
    entries: list[tuple[int, int, str, bytes]] = []  # (time, rank, topic, cdr)
    with Writer(path, version=8, storage_plugin=plugin) as writer:
        connections = {name: writer.add_connection(name, 'sensor_msgs/msg/JointState',
                                                   typestore=store) for name in topics}
        for rank, (name, st) in enumerate(topics.items()):
            names = [st.names[j] for j in perm]
            for i in range(st.stamp_ns.shape[0]):
                row = [a[i, perm] if a.shape[1] else a[i]
                       for a in (st.position, st.velocity, st.effort)]
                msg = _joint_state(store, int(st.stamp_ns[i]), names, *row)
                entries.append((int(st.stamp_ns[i]), rank, name,
                                store.serialize_cdr(msg, 'sensor_msgs/msg/JointState')))
        for name, (times, data) in (mse_topics or {}).items():
            connections[name] = writer.add_connection(name, 'std_msgs/msg/Float64MultiArray',
                                                      typestore=store)
            cls = store.types['std_msgs/msg/Float64MultiArray']
            layout = store.types['std_msgs/msg/MultiArrayLayout'](dim=[], data_offset=0)
            for time_ns, row in zip(times.tolist(), data):
                msg = cls(layout=layout, data=np.asarray(row, np.float64))
                entries.append((time_ns, 99, name,
                                store.serialize_cdr(msg, 'std_msgs/msg/Float64MultiArray')))
        entries.sort(key=lambda e: (e[0], e[1]))
        for time_ns, _, name, raw in entries:
            writer.write(connections[name], time_ns, raw)
    return path


def write_bare_mcap(path: Path, states: States, *, topic: str = '/joint_states') -> Path:
    """Write a plain ``.mcap`` file (no bag directory) with mcap-ros2-support."""
    from mcap_ros2.writer import Writer

    msgdef, _ = _typestore().generate_msgdef('sensor_msgs/msg/JointState', ros_version=2)
    with path.open('wb') as stream:
        writer = Writer(stream)
        schema = writer.register_msgdef('sensor_msgs/msg/JointState', msgdef)
        for i in range(states.stamp_ns.shape[0]):
            stamp = int(states.stamp_ns[i])
            writer.write_message(topic, schema, {
                'header': {'stamp': {'sec': stamp // 1_000_000_000,
                                     'nanosec': stamp % 1_000_000_000}, 'frame_id': ''},
                'name': list(states.names), 'position': states.position[i].tolist(),
                'velocity': states.velocity[i].tolist(), 'effort': states.effort[i].tolist()},
                log_time=stamp, publish_time=stamp)
        writer.finish()
    return path


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
