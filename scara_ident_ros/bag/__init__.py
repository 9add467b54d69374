"""Bags: read any rosbag2 bag or MCAP file (pure Python on rosbags and numpy, no rclpy).

- :func:`open_bag` / :class:`BagSource`: raw messages of a bag in log-time order.
- :func:`read_joint_states` / :class:`JointStateSeries`: a JointState topic as arrays.
- :class:`BagError`: the one exception, with a one-line message naming the file.
"""
from __future__ import annotations

from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.joint_states import (JointStateSeries, find_joint_state_topic,
                                              read_joint_states)
from scara_ident_ros.bag.reader import BagMessage, BagSource, TopicInfo, open_bag

__all__ = ['BagError', 'BagMessage', 'BagSource', 'JointStateSeries', 'TopicInfo',
           'find_joint_state_topic', 'open_bag', 'read_joint_states']
