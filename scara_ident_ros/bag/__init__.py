"""Bags: read any rosbag2 bag or MCAP file, record rosbag2 MCAP bags, recover, replay.

Pure Python on rosbags, mcap and numpy (no rclpy), shared by the ``recorder`` and
``player`` nodes and by offline training:

- :func:`open_bag` / :class:`BagSource`: raw messages of a bag in log-time order.
- :func:`read_joint_states` / :class:`JointStateSeries`: a JointState topic as arrays.
- :class:`BagWriter`: a new rosbag2 bag directory with MCAP storage, split by size or
  duration, every chunk flushed as soon as it is complete.
- :func:`recover_bag`: make the bag of a killed recorder readable again.
- :func:`trim_bag`: a copy of a bag with every message cut to its exact CDR length (old
  bags whose identified_torque rosbags refuses).
- :func:`schedule` / :class:`Timeline`: when the player publishes what.
- :class:`BagError`: the one exception, with a one-line message naming the file.
"""
from __future__ import annotations

from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.exact_cdr import TopicTrim, TrimReport, trim_bag
from scara_ident_ros.bag.joint_states import (JointStateSeries, find_joint_state_topic,
                                              read_joint_states)
from scara_ident_ros.bag.playback import Scheduled, Timeline, parse_rate, parse_remaps, schedule
from scara_ident_ros.bag.reader import BagMessage, BagSource, TopicInfo, open_bag
from scara_ident_ros.bag.recovery import FileRecovery, RecoveryReport, recover_bag
from scara_ident_ros.bag.topic_filter import TopicFilter
from scara_ident_ros.bag.writer import BagWriter, Connection

__all__ = [
    'BagError', 'BagMessage', 'BagSource', 'BagWriter', 'Connection', 'FileRecovery',
    'JointStateSeries', 'RecoveryReport', 'Scheduled', 'Timeline', 'TopicFilter', 'TopicInfo',
    'TopicTrim', 'TrimReport',
    'find_joint_state_topic', 'open_bag', 'parse_rate', 'parse_remaps', 'read_joint_states',
    'recover_bag', 'schedule', 'trim_bag',
]
