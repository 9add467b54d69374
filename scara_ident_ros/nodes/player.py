"""``player`` node: publish the messages of a bag again, timed as they were recorded.

``ros2 run scara_ident_ros player --ros-args -p bag:=run1 [-p rate:=2.0] [-p loop:=true]
[-p clock:=true] [-p topics:="['/joint_states']"] [-p remap:="['/joint_states:=/replay']"]``
(or ``scara-ident play run1 --rate 2 --loop --clock ...``).

- The bag is anything :func:`~scara_ident_ros.bag.open_bag` reads; a missing, corrupt
  or truncated one ends the node at once with one error line (exit 2; exit 1 if the
  damage only shows half-way through). A ROS 1 bag or a table (``.npz``, CSV, a
  /joint_states CSV export, ``FILE.npz:SPLIT``) is played as its joint states on
  ``/joint_states``, one JointState per sample at the sample's stamp
  (:mod:`scara_ident_ros.bag.series_source`).
- Messages are published as the bytes that were recorded (``Publisher.publish(bytes)``,
  nothing is deserialized), each when its log time comes, scaled by ``rate``
  (0 = as fast as possible); the timing is :func:`~scara_ident_ros.bag.schedule`. A
  JointState goes out at its exact CDR length: bags of earlier versions hold
  ``identified_torque`` messages with 8 bytes past their data, which rosbags refuses
  (:func:`~scara_ident_ros.bag.exact_cdr.exact_joint_state`).
- Publishers are reliable with a history of ``qos_depth`` (1 s at 1 kHz by default) and
  transient-local when every recorded publisher was; each needs the message package of
  its type (topics without one are skipped with a warning).
- Nothing is lost to a slow subscriber: after every ``qos_depth`` messages the player
  waits until every subscriber has acknowledged them, so ``rate`` 0 goes as fast as the
  slowest keep-all subscriber reads (a keep-last one drops unread messages itself); the
  timing of rate > 0 slips while it waits and catches up. Its writers send heartbeats
  every 20 ms (``config/fastdds.xml``, as every node's) instead of Fast DDS's 3 s, so a
  dropped message is resent at once.
- Before the first message it waits (at most ``wait_timeout``) until every topic it
  plays has a subscriber.
- With ``clock`` it publishes ``/clock`` (rosgraph_msgs/Clock) at ``clock_rate`` with the
  recorded time, for nodes that run with ``use_sim_time``.
- When the bag is done (never with ``loop``) it waits for the subscribers to acknowledge
  everything (reliable topics) and exits 0; it reports how many messages it published
  and how many every subscriber acknowledged, and exits 1 if those differ.
"""
from __future__ import annotations

import sys
import threading
import time
from typing import Any

from rclpy.duration import Duration
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.exact_cdr import JOINT_STATE, exact_joint_state
from scara_ident_ros.bag.message_class import message_class
from scara_ident_ros.bag.playback import Scheduled, Timeline, parse_remaps, schedule
from scara_ident_ros.bag.qos import adapt_to_offers
from scara_ident_ros.bag.reader import BagSource
from scara_ident_ros.bag.series_source import SeriesSource, open_recording_source
from scara_ident_ros.bag.topic_filter import TopicFilter
from scara_ident_ros.errors import ConfigError
from scara_ident_ros.nodes.parameters import ParamSpec, declare_parameters
from scara_ident_ros.nodes.runtime import POLL_PERIOD, run_node
from scara_ident_ros.topics import CLOCK

__all__ = ['PARAMETERS', 'PlayerNode', 'main']

ACK_TIMEOUT = 10.0  # s to wait at the end for subscribers to acknowledge everything
ACK_POLL = 0.1  # s: one wait for acknowledgements between two looks at the stop flag
ACK_WARN = 10.0  # s a window may wait for acknowledgements before the player says so
SPIN_PERIOD_NS = 100_000_000  # ns between two spin_once calls while publishing flat out
SLEEP_SLACK_NS = 2_000_000  # ns: shorter waits are slept, longer ones spent spinning

PARAMETERS = (
    ParamSpec('bag', '', 'Recording to play (required): bag directory, .mcap, .db3 or ROS 1 '
              '.bag file, or an .npz/CSV table of joint states'),
    ParamSpec('rate', 1.0, 'Playback speed: 1 = as recorded, 2 = twice as fast; '
              '0 = as fast as possible', min=0.0),
    ParamSpec('loop', False, 'Start over after the last message, until stopped'),
    ParamSpec('clock', False, 'Also publish /clock (rosgraph_msgs/Clock) with the recorded '
              'time'),
    ParamSpec('clock_rate', 100.0, 'Rate of /clock when clock is true', 'Hz',
              min=1.0, max=10000.0),
    ParamSpec('topics', [], 'Topics (names or glob patterns) to play; empty = all',
              items=str),
    ParamSpec('remap', [], "Topic renames, each 'old:=new'", items=str),
    ParamSpec('qos_depth', 1000, 'History depth of the publishers', 'messages', min=1),
    ParamSpec('wait_timeout', 5.0, 'Longest wait, before the first message, for '
              'every played topic to have a subscriber (a first discovery can take one 3 s '
              'Fast DDS announcement period); 0 = no wait', 's', min=0.0),
)


class PlayerNode(Node):
    """Publish a bag's messages on their recorded schedule; see the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('player', **kwargs)
        self.settings = p = declare_parameters(self, PARAMETERS)
        if not p['bag']:
            raise ConfigError("parameter 'bag' is required: the bag to play")
        # A bad remapping, topic pattern or bag is reported by run_node in one line.
        self._remap = parse_remaps(p['remap'])
        selection = TopicFilter(p['topics'] or ['/**'])
        self._timeline = Timeline(p['rate'])
        self.bag: BagSource | SeriesSource = open_recording_source(p['bag'])
        try:
            self._outputs = self._create_publishers(selection)
        except ConfigError:
            self.bag.close()
            raise
        self._clock_publisher = (self.create_publisher(Clock, CLOCK, QoSProfile(
            depth=10, reliability=ReliabilityPolicy.RELIABLE)) if p['clock'] else None)
        self.published = 0
        self.acknowledged = 0  # messages every subscriber had acknowledged at the last look
        self.passes = 0

    def _create_publishers(self, selection: TopicFilter) -> dict[str, Publisher]:
        topics = self.bag.topics
        chosen = selection.select(topics)
        if not chosen:
            raise ConfigError(f'{self.bag.path}: no topic matches {list(selection.patterns)} '
                              f'(the bag has {self.bag.describe_topics()})')
        publishers: dict[str, Publisher] = {}
        depth = self.settings['qos_depth']
        for topic in chosen:
            info = topics[topic]
            cls = message_class(info.msgtype)
            if cls is None:
                self.get_logger().warning(f'not playing {topic}: no Python message package '
                                          f'for {info.msgtype}')
                continue
            adapted = adapt_to_offers(self.bag.offered_qos(topic))
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                             reliability=ReliabilityPolicy.RELIABLE,
                             durability=(DurabilityPolicy.TRANSIENT_LOCAL
                                         if adapted.transient_local
                                         else DurabilityPolicy.VOLATILE))
            publishers[topic] = self.create_publisher(cls, self._remap.get(topic, topic), qos)
        if not publishers:
            raise ConfigError(f'{self.bag.path}: none of the selected topics can be played')
        unused = set(self._remap) - set(publishers)
        if unused:
            self.get_logger().warning(f'remapped topic(s) not played: {", ".join(sorted(unused))}')
        names = ', '.join(f'{t} -> {self._remap[t]}' if t in self._remap else t
                          for t in publishers)
        rate = 'as fast as possible' if self._timeline.as_fast_as_possible else \
            f'at {self._timeline.rate:g}x'
        self.get_logger().info(f'playing {self.bag.path} {rate}'
                               f'{" in a loop" if self.settings["loop"] else ""}: {names}')
        return publishers

    # -- the loop ------------------------------------------------------------------------

    def loop(self, executor: Executor, stop: threading.Event) -> None:
        """Wait for subscribers, then publish every message on time; return when done."""
        if not self._wait_for_subscribers(executor, stop):
            return
        try:
            self._play(executor, stop)
        except BagError as exc:
            print(f'player: error: {exc}', file=sys.stderr)
            raise SystemExit(1) from None
        if not stop.is_set() and not self._wait_for_acks():
            raise SystemExit(1)

    def _wait_for_subscribers(self, executor: Executor, stop: threading.Event) -> bool:
        timeout = self.settings['wait_timeout']
        deadline = time.monotonic() + timeout
        waiting = list(self._outputs.values())
        while timeout > 0 and waiting and time.monotonic() < deadline:
            if stop.is_set():
                return False
            executor.spin_once(timeout_sec=0.02)
            waiting = [p for p in waiting if p.get_subscription_count() == 0]
        if timeout > 0 and waiting:
            self.get_logger().info(
                f'no subscriber after {timeout:g} s on {", ".join(p.topic_name for p in waiting)};'
                ' playing anyway')
        return not stop.is_set()

    def _play(self, executor: Executor, stop: threading.Event) -> None:
        publishers = self._outputs
        clock = self._clock_publisher
        clock_period = round(1e9 / self.settings['clock_rate'])
        rate = self._timeline.rate
        start = time.monotonic_ns()
        next_spin = start + SPIN_PERIOD_NS
        next_clock_wall = start  # wall time of the next /clock while waiting
        last_clock = None  # recorded time last published on /clock
        current_pass = 0
        window = self.settings['qos_depth']  # unacknowledged messages the history can hold
        unacknowledged = 0
        last_item: Scheduled | None = None
        items = schedule(lambda: self.bag.messages(publishers), timeline=self._timeline,
                         loop=self.settings['loop'])
        for item in items:
            if stop.is_set():
                break
            if item.loop_pass != current_pass:
                current_pass = item.loop_pass
                self.passes = current_pass
            due = start + item.due_ns
            now = time.monotonic_ns()
            while now < due:  # wait, serving the executor and /clock meanwhile
                if stop.is_set():
                    return
                wake = due
                if clock is not None:
                    if now >= next_clock_wall:
                        last_clock = item.clock_ns - round((due - now) * rate)
                        self._publish_clock(last_clock)
                        next_clock_wall = now + round(clock_period / rate)
                    wake = min(wake, next_clock_wall)
                if wake - now > SLEEP_SLACK_NS:
                    executor.spin_once(timeout_sec=min((wake - now - SLEEP_SLACK_NS) / 1e9,
                                                       POLL_PERIOD))
                    next_spin = time.monotonic_ns() + SPIN_PERIOD_NS
                else:
                    time.sleep((wake - now) / 1e9)
                now = time.monotonic_ns()
            if clock is not None and (last_clock is None
                                      or item.clock_ns - last_clock >= clock_period):
                last_clock = item.clock_ns
                self._publish_clock(last_clock)
                next_clock_wall = now + round(clock_period / rate) if rate else now
            data = item.message.data
            if item.message.msgtype == JOINT_STATE:
                data = exact_joint_state(data)
            publishers[item.message.topic].publish(data)
            self.published += 1
            last_item = item
            unacknowledged += 1
            if unacknowledged >= window:
                if not self._acknowledged(stop):
                    return
                unacknowledged = 0
            if now >= next_spin:
                executor.spin_once(timeout_sec=0.0)
                next_spin = now + SPIN_PERIOD_NS
        else:
            if clock is not None and last_item is not None and last_clock != last_item.clock_ns:
                self._publish_clock(last_item.clock_ns)  # the clock ends where the bag ends
        self.passes = current_pass + 1

    def _publish_clock(self, recorded_ns: int) -> None:
        assert self._clock_publisher is not None
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(recorded_ns, 1_000_000_000)
        self._clock_publisher.publish(msg)

    def _acknowledged(self, stop: threading.Event) -> bool:
        """Wait until every subscriber has acknowledged all published; False if stopped."""
        started = time.monotonic()
        warned = False
        poll = Duration(nanoseconds=round(ACK_POLL * 1e9))
        for publisher in self._outputs.values():
            while not publisher.wait_for_all_acked(poll):
                if stop.is_set():
                    return False
                if not warned and time.monotonic() - started > ACK_WARN:
                    warned = True
                    self.get_logger().warning(
                        f'{publisher.topic_name}: a subscriber has acknowledged nothing for '
                        f'{ACK_WARN:g} s; waiting for it (nothing is dropped)')
        self.acknowledged = self.published
        return True

    def _wait_for_acks(self) -> bool:
        """At the end: wait at most ACK_TIMEOUT for every acknowledgement; False if one of the
        played topics misses some. The final /clock, published just before, is waited for too,
        so that a subscriber gets the bag's end time before the player exits."""
        deadline = time.monotonic() + ACK_TIMEOUT
        complete = True
        for publisher in self._outputs.values():
            left = max(deadline - time.monotonic(), 0.0)
            if not publisher.wait_for_all_acked(Duration(nanoseconds=round(left * 1e9))):
                complete = False
                self.get_logger().warning(f'{publisher.topic_name}: not every message was '
                                          f'acknowledged within {ACK_TIMEOUT:g} s')
        if self._clock_publisher is not None:  # /clock is a side channel: waited for, not failed
            left = max(deadline - time.monotonic(), 0.0)
            self._clock_publisher.wait_for_all_acked(Duration(nanoseconds=round(left * 1e9)))
        if complete:
            self.acknowledged = self.published
        return complete

    def close(self) -> None:
        """Close the bag and log what was played."""
        self.bag.close()
        acknowledged = ('every one acknowledged' if self.acknowledged == self.published else
                        f'{self.acknowledged} acknowledged by every subscriber')
        self.get_logger().info(f'played {self.published} messages from {self.bag.path}'
                               f'{f" ({self.passes} passes)" if self.settings["loop"] else ""}'
                               f', {acknowledged}')


def main(args: list[str] | None = None) -> None:
    """Entry point of the ``player`` executable."""
    sys.exit(run_node('player', PlayerNode, args,
                      description=__doc__ or '', parameters=PARAMETERS))


if __name__ == '__main__':
    main()
