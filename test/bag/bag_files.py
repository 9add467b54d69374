"""Bags for the bag tests, written by independent writers (rosbags, mcap-ros2-support).

Messages are serialized with rosbags' Jazzy type store, so nothing here depends on the
code under test. :class:`Robot` holds the joint states of an n-joint robot as arrays,
the shape :func:`~scara_ident_ros.bag.read_joint_states` returns.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

JOINT_STATE = 'sensor_msgs/msg/JointState'
FLOAT64_ARRAY = 'std_msgs/msg/Float64MultiArray'
STORE = get_typestore(Stores.ROS2_JAZZY)
START_NS = 1_700_000_000_000_000_000


@dataclass(frozen=True)
class Robot:
    """Joint states: stamps (N,) int64 ns, joint names (n,), arrays (N, n)."""

    stamp_ns: NDArray[np.int64]
    names: tuple[str, ...]
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    effort: NDArray[np.float64]


def robot(n_joints: int, count: int, *, seed: int = 0, rate_hz: float = 1000.0) -> Robot:
    """Random joint states of an ``n_joints`` robot sampled at ``rate_hz``."""
    rng = np.random.default_rng(seed)
    stamps = START_NS + np.round(np.arange(count) / rate_hz * 1e9).astype(np.int64)
    names = tuple(f'joint{i + 1}' for i in range(n_joints))
    return Robot(stamps, names, *(rng.normal(size=(count, n_joints)) for _ in range(3)))


def joint_state(stamp_ns: int, names: Sequence[str], position: Any = (), velocity: Any = (),
                effort: Any = (), frame_id: str = '') -> bytes:
    """A serialized JointState (little-endian CDR, rosbags)."""
    types = STORE.types
    stamp = types['builtin_interfaces/msg/Time'](sec=int(stamp_ns // 1_000_000_000),
                                                 nanosec=int(stamp_ns % 1_000_000_000))
    msg = types[JOINT_STATE](
        header=types['std_msgs/msg/Header'](stamp=stamp, frame_id=frame_id),
        name=list(names), position=np.asarray(position, np.float64),
        velocity=np.asarray(velocity, np.float64), effort=np.asarray(effort, np.float64))
    return bytes(STORE.serialize_cdr(msg, JOINT_STATE))


def float_array(values: Sequence[float]) -> bytes:
    """A serialized std_msgs/Float64MultiArray."""
    types = STORE.types
    layout = types['std_msgs/msg/MultiArrayLayout'](dim=[], data_offset=0)
    msg = types[FLOAT64_ARRAY](layout=layout, data=np.asarray(values, np.float64))
    return bytes(STORE.serialize_cdr(msg, FLOAT64_ARRAY))


def robot_messages(states: Robot, *, order: Sequence[int] | None = None) -> list[bytes]:
    """One serialized JointState per row; ``order`` permutes the joints in each message.

    An array of width 0 (no values of that kind) gives empty fields.
    """
    perm = list(range(len(states.names))) if order is None else list(order)
    names = [states.names[j] for j in perm]
    arrays = [np.ascontiguousarray(a[:, perm]) if a.shape[1] else a
              for a in (states.position, states.velocity, states.effort)]
    return [joint_state(int(states.stamp_ns[i]), names, *(a[i] for a in arrays))
            for i in range(states.stamp_ns.shape[0])]


def write_rosbags_bag(path: Path, topics: dict[str, tuple[str, list[tuple[int, bytes]]]], *,
                      storage: str = 'sqlite3', version: int = 9) -> Path:
    """Write a rosbag2 bag with rosbags' Writer: ``{topic: (msgtype, [(log_ns, cdr)])}``."""
    plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
    entries = []
    with Writer(path, version=version, storage_plugin=plugin) as writer:  # type: ignore[arg-type]
        for rank, (topic, (msgtype, messages)) in enumerate(topics.items()):
            connection = writer.add_connection(topic, msgtype, typestore=STORE)
            entries.extend((log_ns, rank, connection, data) for log_ns, data in messages)
        for log_ns, _, connection, data in sorted(entries, key=lambda e: e[:2]):
            writer.write(connection, log_ns, data)
    return path


def write_robot_bag(path: Path, states: Robot, *, storage: str = 'sqlite3',
                    topic: str = '/joint_states', order: Sequence[int] | None = None) -> Path:
    """A rosbag2 bag (rosbags' Writer) with the robot's joint states, logged at their stamps."""
    messages = list(zip(states.stamp_ns.tolist(), robot_messages(states, order=order)))
    return write_rosbags_bag(path, {topic: (JOINT_STATE, messages)}, storage=storage)


def write_bare_mcap(path: Path, states: Robot, *, topic: str = '/joint_states') -> Path:
    """A plain ``.mcap`` file written by mcap-ros2-support (definition embedded)."""
    from mcap_ros2.writer import Writer as McapRos2Writer

    msgdef, _ = STORE.generate_msgdef(JOINT_STATE, ros_version=2)
    with path.open('wb') as stream:
        writer = McapRos2Writer(stream)
        schema = writer.register_msgdef(JOINT_STATE, msgdef)
        for i, stamp in enumerate(states.stamp_ns.tolist()):
            writer.write_message(topic, schema, {
                'header': {'stamp': {'sec': stamp // 1_000_000_000,
                                     'nanosec': stamp % 1_000_000_000}, 'frame_id': ''},
                'name': list(states.names), 'position': states.position[i].tolist(),
                'velocity': states.velocity[i].tolist(), 'effort': states.effort[i].tolist()},
                log_time=stamp, publish_time=stamp)
        writer.finish()
    return path


#: What rclpy's ``serialize_message`` left after a JointState with empty position and
#: velocity (uninitialized memory, so any bytes): earlier versions of the identifier
#: published and recorded these.
OLD_SLACK = b'\x00\x00d\tS\x00\x00\xd8'


def write_old_identifier_bag(path: Path, states: Robot, *, methods: Sequence[str] = ('ffs',),
                             compression: str = 'zstd', offered_qos: Sequence[Any] = ()
                             ) -> dict[str, list[tuple[int, bytes]]]:
    """A run bag as earlier versions recorded it, written with the package's BagWriter:
    ``/joint_states`` (exact), and per method ``/<m>/identified_torque`` and
    ``/<m>/external_torque`` with efforts only and :data:`OLD_SLACK` after the data, and
    ``/<m>/identification_mse``; small chunks so there are several. Return the messages
    written per topic, ``[(log_ns, data)]``."""
    from scara_ident_ros.bag import BagWriter

    topics: dict[str, tuple[str, list[tuple[int, bytes]]]] = {
        '/joint_states': (JOINT_STATE, list(zip(states.stamp_ns.tolist(),
                                                robot_messages(states))))}
    for k, m in enumerate(methods):
        predicted = states.effort * (1.0 + 0.01 * (k + 1))
        for suffix, values in (('identified_torque', predicted),
                               ('external_torque', states.effort - predicted)):
            topics[f'/{m}/{suffix}'] = (JOINT_STATE, [
                (int(t) + 1000, joint_state(int(t), states.names, effort=row) + OLD_SLACK)
                for t, row in zip(states.stamp_ns.tolist(), values)])
        topics[f'/{m}/identification_mse'] = (FLOAT64_ARRAY, [
            (int(t) + 2000, float_array([0.1 * i, 0.2, 0.3]))
            for i, t in enumerate(states.stamp_ns[::10].tolist())])
    entries = []
    with BagWriter(path, compression=compression, chunk_size=4096) as writer:
        for rank, (topic, (msgtype, messages)) in enumerate(topics.items()):
            connection = writer.add_connection(topic, msgtype, offered_qos=offered_qos)
            entries.extend((log_ns, rank, connection.id, data) for log_ns, data in messages)
        writer.write_batch([(cid, log_ns, data)
                            for log_ns, _, cid, data in sorted(entries, key=lambda e: e[:2])])
    return {topic: messages for topic, (_, messages) in topics.items()}
