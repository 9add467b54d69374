"""A table or a ROS 1 bag played as a bag: one JointState per sample, at its stamp."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.bag import BagError, schedule, Timeline
from scara_ident_ros.bag.cdr import decode_names, split_joint_state
from scara_ident_ros.bag.reader import BagSource
from scara_ident_ros.bag.series_source import SeriesSource, open_recording_source


def test_an_npz_without_velocity_is_played_with_the_derived_one(tmp_path: Path) -> None:
    t = np.cumsum(np.r_[0.0, np.random.default_rng(0).uniform(0.8e-3, 1.2e-3, 99)])
    q = np.column_stack([np.sin(t), np.cos(t)])
    np.savez(tmp_path / 'arm.npz', t=t, q=q, tau=2 * q, names=np.array(['a', 'b']))
    with open_recording_source(tmp_path / 'arm.npz') as source:
        assert isinstance(source, SeriesSource)
        assert source.topics == {'/joint_states': ('sensor_msgs/msg/JointState', 100)}
        messages = list(source.messages(['/joint_states']))
        with pytest.raises(BagError, match='no topic /other'):
            list(source.messages(['/other']))
    assert [m.log_time_ns for m in messages] == np.round(t * 1e9).astype(np.int64).tolist()
    raw = messages[40].data
    spans = split_joint_state(raw)
    assert spans.stamp_ns == round(t[40] * 1e9) and decode_names(spans.names) == ('a', 'b')
    fields = {}
    for name, (offset, count) in zip(('q', 'qd', 'tau'),
                                     (spans.position, spans.velocity, spans.effort)):
        fields[name] = np.frombuffer(raw[offset:offset + 8 * count], dtype='<f8')
    np.testing.assert_array_equal(fields['q'], q[40])
    np.testing.assert_allclose(fields['qd'], [np.cos(t[40]), -np.sin(t[40])], atol=1e-6)
    np.testing.assert_array_equal(fields['tau'], 2 * q[40])
    # the player's timing: as stamped, from the first sample
    due = [item.due_ns for item in schedule(lambda: iter(messages), timeline=Timeline(1.0))]
    assert due == (np.round(t * 1e9).astype(np.int64) - round(t[0] * 1e9)).tolist()


def test_a_rosbag2_bag_is_opened_as_a_bag(tmp_path: Path) -> None:
    from scara_ident_ros.bag import BagWriter

    with BagWriter(tmp_path / 'run') as writer:
        writer.add_connection('/chatter', 'std_msgs/msg/String')
    with open_recording_source(tmp_path / 'run') as source:
        assert isinstance(source, BagSource)
