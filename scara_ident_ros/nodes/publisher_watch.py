"""Report a second publisher on a stream: a publisher count above one, interleaved stamps.

Two simulators (or two ``scara-ident run``) on one ROS domain both publish
``/joint_states``: every identifier and recorder then gets both streams mixed, skips
or records samples of two robots as one, and nothing said so. A :class:`PublisherWatch`
looks every :data:`CHECK_PERIOD` at the topic's publisher count and at how often its
stamps went back in time, and warns with one line naming what it found, again every
:data:`REPEAT_PERIOD` while it lasts.

One publisher's stamps only go forward (a restarted simulator or a looping player goes
back once). Two publishers on one topic interleave two timelines, and the stream goes back
in time about every other sample: :class:`StampOrder` counts the backward steps, and
:data:`INTERLEAVED_STEPS` or more within one look mean a second publisher.
"""
from __future__ import annotations

import os
import time

from rclpy.node import Node

__all__ = ['CHECK_PERIOD', 'INTERLEAVED_STEPS', 'PublisherWatch', 'StampOrder']

CHECK_PERIOD = 1.0  # s between two looks
REPEAT_PERIOD = 10.0  # s between two warnings while a second publisher lasts
INTERLEAVED_STEPS = 3  # backward steps within one look that mean interleaved publishers


class StampOrder:
    """Count the samples whose stamp is earlier than the one before.

    Attributes
    ----------
    backward : int
        Backward steps since the start.
    """

    def __init__(self) -> None:
        self.backward = 0
        self._last: int | None = None
        self._seen = 0  # backward steps at the last look

    def observe(self, stamp_ns: int) -> None:
        """Take the stamp of the next sample, in ns."""
        if self._last is not None and stamp_ns < self._last:
            self.backward += 1
        self._last = stamp_ns

    def since_last_look(self) -> int:
        """Backward steps since the previous call."""
        steps, self._seen = self.backward - self._seen, self.backward
        return steps


class PublisherWatch:
    """Watch one topic of ``node`` for a second publisher; see the module docstring.

    Parameters
    ----------
    node : Node
        The subscribing node (its timer and logger are used).
    topic : str
        The topic, as the node names it (resolved here).

    Attributes
    ----------
    stamps : StampOrder
        Feed it every sample's stamp (:meth:`StampOrder.observe`).
    most_publishers : int
        The largest publisher count seen.
    """

    def __init__(self, node: Node, topic: str) -> None:
        self.node = node
        self.topic = node.resolve_topic_name(topic)
        self.stamps = StampOrder()
        self.most_publishers = 0
        self._last_warning = -REPEAT_PERIOD
        node.create_timer(CHECK_PERIOD, self.check)

    def check(self) -> None:
        """Count the publishers and the backward stamps; warn if there is a second one."""
        publishers = self.node.count_publishers(self.topic)
        self.most_publishers = max(self.most_publishers, publishers)
        backward = self.stamps.since_last_look()
        problems = []
        if publishers > 1:
            problems.append(f'{publishers} publishers on {self.topic}')
        if backward >= INTERLEAVED_STEPS:
            problems.append(f'its stamps went back in time {backward} times in '
                            f'{CHECK_PERIOD:g} s')
        now = time.monotonic()
        if problems and now - self._last_warning >= REPEAT_PERIOD:
            self._last_warning = now
            domain = os.environ.get('ROS_DOMAIN_ID', '0')
            self.node.get_logger().warning(
                f"{' and '.join(problems)}: another graph (a second simulator or player) "
                f'on ROS domain {domain}? Its samples mix with these; stop it or move '
                'one graph to another ROS_DOMAIN_ID')
