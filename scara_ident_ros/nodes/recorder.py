"""``recorder`` node: record topics into a rosbag2 bag directory with MCAP storage.

``ros2 run scara_ident_ros recorder --ros-args --params-file config/recorder.yaml
-p output:=run1`` records, until SIGINT/SIGTERM, the topics matching ``topics`` (names
or glob patterns; the joint states and the identifiers' outputs by default, ``all``
for everything) into ``output`` (``metadata.yaml`` + ``<name>_0.mcap``, ``_1.mcap`` ...
after splits), written by :class:`~scara_ident_ros.bag.BagWriter`.

- Topics and types come from the graph, rediscovered every ``discovery_period``, so
  publishers that start late are recorded too. A topic is subscribed once it has a
  publisher; its publishers' offered QoS profiles are recorded, and the subscription
  adapts to them as rosbag2 does (reliable unless one is best effort, transient-local if
  all are), with a history of ``qos_depth`` (0 = keep all).
- Subscriptions are raw: the serialized bytes are stamped with the reception time (as
  rosbag2 does) and handed to the writer in batches, never deserialized. They are stored
  as DDS delivered them, as rosbag2 stores them: Fast DDS sends a message it serializes
  at its exact CDR length, which every reader takes; bytes a publisher sends raw come as
  sent (the identifier's are cut to the exact length, ``nodes/joint_state_cdr.py``).
- Chunks are written and flushed at ``max_chunk_size`` bytes or ``max_chunk_duration``
  seconds, so a SIGKILL loses at most that (:func:`~scara_ident_ros.bag.recover_bag`).
  On SIGINT/SIGTERM the bag is closed properly.
- Counters are logged every ``report_period`` and on shutdown, and saved to
  ``stats_file``. DDS's own lost-message count is not used (with these wheels'
  EventsExecutor a ``message_lost`` callback hangs ``spin_once``); samples of a
  ``sensor_msgs/JointState`` topic lost before the recorder are counted from the gaps in
  their stamps (``lost``), and a second publisher from stamps going back (``publishers``).
- Services (``std_srvs/Trigger``), as rosbag2's recorder has them: ``~/split`` closes the
  current ``.mcap`` file and continues in the next one; ``~/pause`` stops writing (what
  arrives meanwhile is counted as ``paused``, not written) until ``~/resume``.
- ``/diagnostics`` (1 Hz): write rate, written, received and paused messages; WARN while
  paused (:mod:`scara_ident_ros.nodes.health`).
"""
from __future__ import annotations

import json
import sys
import threading
import time
from collections.abc import Callable
from datetime import datetime
from pathlib import Path
from typing import Any

from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from scara_ident_ros.bag.cdr import header_stamp_ns
from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.message_class import message_class
from scara_ident_ros.bag.qos import adapt_to_offers, qos_from_profile
from scara_ident_ros.bag.topic_filter import TopicFilter
from scara_ident_ros.bag.writer import BagWriter
from scara_ident_ros.errors import ConfigError
from scara_ident_ros.nodes.health import (Deltas, Health, LossCounter,
                                                    recorder_health)
from scara_ident_ros.nodes.diagnostics import Diagnostics
from scara_ident_ros.nodes.parameters import ParamSpec, declare_parameters
from scara_ident_ros.nodes.publisher_watch import PublisherWatch
from scara_ident_ros.nodes.realtime import REALTIME_PRIORITY
from scara_ident_ros.nodes.runtime import POLL_PERIOD, run_node
from scara_ident_ros.topics import IDENTIFIER_OUTPUTS, JOINT_STATES, in_namespace

__all__ = ['DEFAULT_TOPICS', 'PARAMETERS', 'RecorderNode', 'default_output', 'main']

DEFAULT_TOPICS = [in_namespace(JOINT_STATES), *(in_namespace(topic, namespace)
                                                 for namespace in ('', '*')
                                                 for topic in IDENTIFIER_OUTPUTS)]
CHUNK_POLL_PERIOD = 0.1  # s between checks of the open chunk's age when idle
BATCH_SIZE = 512  # most messages handed to the writer at once
GATHER_PERIOD = 0.005  # s to let messages queue up after a quiet spell (one wake-up, not N)
SPARSE_RATE = 20_000  # messages/s below which the loop gathers before taking
JOINT_STATE_TYPE = 'sensor_msgs/msg/JointState'  # watched for a second publisher and losses
LOST_SPAN = 60.0  # s: the longest gap in a JointState stream's stamps counted as lost samples
WRITER = 'the storage files are opened with it'  # why a writer option is fixed at start

PARAMETERS = (
    ParamSpec('output', '', "Bag directory to create; '' = rosbag2_<date>-<time> in the "
              'working directory; an existing one is never overwritten',
              fixed='the bag is created at start'),
    ParamSpec('topics', DEFAULT_TOPICS, 'Topic names or glob patterns to record '
              '(* = within one name component, ** = across)', items=str,
              fixed='a recorded topic stays recorded'),
    ParamSpec('all', False, 'Record every topic except hidden ones; topics is then ignored',
              fixed='a recorded topic stays recorded'),
    ParamSpec('compression', 'none', 'MCAP chunk compression',
              choices=('none', 'zstd', 'lz4'), fixed=WRITER),
    ParamSpec('max_bag_size', 0, 'Continue in a new .mcap file once one is this big; '
              '0 = never split', 'bytes', min=0, read_only=False),
    ParamSpec('max_bag_duration', 0.0, 'Continue in a new .mcap file once one spans this '
              'long; 0 = never split', 's', min=0.0, read_only=False),
    ParamSpec('max_chunk_size', 1048576, 'Write a chunk once it holds this much',
              'bytes', min=4096, fixed=WRITER),
    ParamSpec('max_chunk_duration', 1.0, 'Write a chunk once its first message is this old; '
              'bounds what a SIGKILL loses; 0 = size only', 's', min=0.0, fixed=WRITER),
    ParamSpec('qos_depth', 0, 'History depth of the subscriptions; 0 = keep all (fewest '
              'losses when publishers outrun the recorder)', 'messages', min=0,
              fixed='subscriptions keep the QoS they were made with'),
    ParamSpec('discovery_period', 1.0, 'Period of the search for new topics', 's',
              min=0.05, max=60.0, fixed='a timer made at start'),
    ParamSpec('report_period', 10.0, 'Period of the progress log line; 0 = none', 's',
              min=0.0, fixed='a timer made at start'),
    ParamSpec('stats_file', '', "Write the final counters here as JSON; '' = no file",
              fixed='used at shutdown as given at start'),
    REALTIME_PRIORITY,
)


def default_output(now: datetime | None = None) -> Path:
    """rosbag2's default bag name in the working directory: ``rosbag2_YYYY_MM_DD-HH_MM_SS``."""
    return Path.cwd() / (now or datetime.now()).strftime('rosbag2_%Y_%m_%d-%H_%M_%S')


class RecorderNode(Node):
    """Record topics to an MCAP rosbag2 bag; see the module docstring."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('recorder', **kwargs)
        self.settings = p = declare_parameters(self, PARAMETERS, on_change=self._apply)
        try:
            self._filter = TopicFilter(p['topics'], all_topics=p['all'])
        except ValueError as exc:
            raise ConfigError(f"parameter 'topics': {exc}") from None
        if not p['all'] and not p['topics']:
            raise ConfigError("parameter 'topics' is empty and 'all' is false: nothing to record")
        output = Path(p['output']) if p['output'] else default_output()
        try:
            self.writer = BagWriter(
                output, compression=p['compression'], max_file_size=p['max_bag_size'],
                max_file_duration_ns=round(p['max_bag_duration'] * 1e9),
                chunk_size=p['max_chunk_size'],
                chunk_duration_ns=round(p['max_chunk_duration'] * 1e9)).open()
        except BagError as exc:
            raise ConfigError(str(exc)) from None
        self._pending: list[tuple[int, int, bytes]] = []
        self._received = 0
        self._topics: dict[str, int] = {}  # topic -> connection id
        # JointState topics: a second publisher, and samples lost (gaps in the stamps)
        self._watches: dict[str, tuple[PublisherWatch, LossCounter]] = {}
        self._ignored: set[str] = set()  # topics that cannot be recorded (warned once)
        self._started = time.monotonic()
        self._closed = False
        self._paused = False
        self._not_written = 0  # messages received while paused
        self._deltas = Deltas()
        self._last_report = (self._started, 0)
        self.create_timer(p['discovery_period'], self._discover)
        self.create_timer(CHUNK_POLL_PERIOD, self.writer.poll)
        if p['report_period'] > 0:
            self.create_timer(p['report_period'], self._report)
        self.create_service(Trigger, '~/split', self.on_split)
        self.create_service(Trigger, '~/pause', self.on_pause)
        self.create_service(Trigger, '~/resume', self.on_resume)
        self.diagnostics = Diagnostics(self, 'recording', self.health)
        selection = 'all topics' if p['all'] else ', '.join(self._filter.patterns)
        self.get_logger().info(f'recording {selection} into {output}')
        self._discover()

    # -- discovery -----------------------------------------------------------------------

    def _discover(self) -> None:
        """Subscribe to every selected topic that has a publisher and is not recorded yet."""
        for topic, types in self.get_topic_names_and_types():
            if topic in self._topics or topic in self._ignored or not self._filter.matches(topic):
                continue
            infos = self.get_publishers_info_by_topic(topic)
            if not infos:
                continue  # only subscribers so far: wait for a publisher (and its QoS)
            if len(types) != 1:
                self._ignore(topic, f'it has several types ({", ".join(types)})')
                continue
            msgtype = types[0]
            cls = message_class(msgtype)
            if cls is None:
                self._ignore(topic, f'no Python message package for {msgtype}')
                continue
            self._subscribe(topic, msgtype, cls, [qos_from_profile(i.qos_profile)
                                                  for i in infos])

    def _ignore(self, topic: str, reason: str) -> None:
        self._ignored.add(topic)
        self.get_logger().warning(f'not recording {topic}: {reason}')

    def _subscribe(self, topic: str, msgtype: str, cls: Any, offers: list[Any]) -> None:
        adapted = adapt_to_offers(offers)
        depth = self.settings['qos_depth']
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST if depth else HistoryPolicy.KEEP_ALL,
            depth=depth or 1,
            reliability=(ReliabilityPolicy.RELIABLE if adapted.reliable
                         else ReliabilityPolicy.BEST_EFFORT),
            durability=(DurabilityPolicy.TRANSIENT_LOCAL if adapted.transient_local
                        else DurabilityPolicy.VOLATILE))
        try:
            connection = self.writer.add_connection(topic, msgtype, offered_qos=offers)
        except BagError as exc:
            self._ignore(topic, str(exc))
            return
        self._topics[topic] = connection.id
        stamps = self._watch(topic) if msgtype == JOINT_STATE_TYPE else None
        self.create_subscription(cls, topic, self._on_message(connection.id, stamps), qos,
                                 raw=True)
        self.get_logger().info(
            f'recording {topic} ({msgtype}; {"reliable" if adapted.reliable else "best effort"}'
            f'{", transient local" if adapted.transient_local else ""}; '
            f'{len(offers)} publisher(s))')

    def _on_message(self, connection_id: int,
                    stamps: Callable[[bytes], None] | None = None) -> Callable[[bytes], None]:
        append = self._pending.append
        now = time.time_ns

        def callback(data: bytes) -> None:
            append((connection_id, now(), data))

        if stamps is None:
            return callback
        observe = stamps

        def watched(data: bytes) -> None:
            append((connection_id, now(), data))
            observe(data)

        return watched

    def _watch(self, topic: str) -> Callable[[bytes], None]:
        """Watch a JointState topic for a second publisher and for samples lost on the way
        (gaps in the stamps, read from the serialized header); return what takes each
        message."""
        watch, loss = PublisherWatch(self, topic), LossCounter(span_s=LOST_SPAN)
        self._watches[topic] = (watch, loss)
        order, lost = watch.stamps.observe, loss.observe

        def observe(data: bytes) -> None:
            stamp_ns = header_stamp_ns(data)
            if stamp_ns is not None:
                order(stamp_ns)
                lost(stamp_ns)

        return observe

    # -- the loop ------------------------------------------------------------------------

    def loop(self, executor: Executor, stop: threading.Event) -> None:
        """Spin, handing what arrived to the writer in batches, until ``stop`` is set.

        Below ``SPARSE_RATE`` messages/s it sleeps ``GATHER_PERIOD`` after the first
        message of a quiet spell and takes what queued meanwhile, instead of waking per
        message; faster traffic is taken without sleeping (docs/results.md).
        """
        pending = self._pending
        spin_once = executor.spin_once
        clock = time.monotonic
        sparse = True
        last = clock()
        while not stop.is_set():
            spin_once(timeout_sec=POLL_PERIOD)
            if not pending:
                continue
            if sparse:
                time.sleep(GATHER_PERIOD)
            count = -1
            while count != len(pending) and len(pending) < BATCH_SIZE:
                count = len(pending)
                spin_once(timeout_sec=0.0)
            now = clock()
            sparse = len(pending) < SPARSE_RATE * (now - last)
            last = now
            self._flush_pending()
        self._flush_pending()

    def _flush_pending(self) -> None:
        pending = self._pending
        if not pending:
            return
        self._received += len(pending)
        if self._paused:
            self._not_written += len(pending)
            pending.clear()
            return
        try:
            self.writer.write_batch(pending)
        except (BagError, OSError) as exc:
            self.get_logger().fatal(f'cannot write to {self.writer.path}: {exc}')
            pending.clear()
            raise SystemExit(1) from None
        pending.clear()

    # -- while running -------------------------------------------------------------------

    def _apply(self, changed: dict[str, Any]) -> None:
        """Parameters set while running: the split limits apply from the next message."""
        self.writer.max_file_size = self.settings['max_bag_size']
        self.writer.max_file_duration_ns = round(self.settings['max_bag_duration'] * 1e9)
        self.get_logger().info('set ' + ', '.join(f'{k} = {v!r}' for k, v in changed.items()))

    # -- services ------------------------------------------------------------------------

    def on_split(self, request: Trigger.Request, response: Trigger.Response
                 ) -> Trigger.Response:
        """``~/split``: write what arrived, close the storage file, continue in a new one."""
        try:
            self._flush_pending()
            self.writer.split()
        except (BagError, OSError) as exc:
            response.success, response.message = False, f'split failed: {exc}'
        else:
            response.success = True
            response.message = f'now writing {self.writer.file_names[-1]}'
        self.get_logger().info(f'~/split: {response.message}')
        return response

    def on_pause(self, request: Trigger.Request, response: Trigger.Response
                 ) -> Trigger.Response:
        """``~/pause``: write what arrived until now, then nothing until ``~/resume``."""
        return self._pause(True, response)

    def on_resume(self, request: Trigger.Request, response: Trigger.Response
                  ) -> Trigger.Response:
        """``~/resume``: write again (what arrived while paused is not written)."""
        return self._pause(False, response)

    def _pause(self, paused: bool, response: Trigger.Response) -> Trigger.Response:
        self._flush_pending()  # what arrived before the call: as the state was until now
        unchanged = self._paused == paused
        self._paused = paused
        response.success = True
        response.message = ({True: 'already paused', False: 'not paused'} if unchanged
                            else {True: 'paused', False: 'resumed'})[paused]
        self.get_logger().info(f'~/{"pause" if paused else "resume"}: {response.message} '
                               f'({self._not_written} messages not written while paused)')
        return response

    # -- reporting and closing -----------------------------------------------------------

    def health(self, period_s: float) -> Health:
        """The recorder's health over the last ``period_s`` s, for ``/diagnostics``."""
        counters = self.counters()
        recent = self._deltas(written=counters['written'])
        return recorder_health(
            period_s=period_s, written=counters['written'], received=counters['received'],
            paused=counters['paused'], recent_written=int(recent['written']),
            is_paused=self._paused, files=len(counters['files']), topics=len(self._topics))

    def handled(self) -> int:
        """Messages received so far (a stop drains the subscriptions until it stays put)."""
        return self._received + len(self._pending)

    def counters(self) -> dict[str, Any]:
        """Received and written messages, per topic and in total."""
        written = self.writer.counts_by_id()
        topics = {topic: written.get(cid, 0) for topic, cid in sorted(self._topics.items())}
        return {'bag': str(self.writer.path), 'received': self._received + len(self._pending),
                'written': sum(topics.values()), 'paused': self._not_written, 'topics': topics,
                'files': self.writer.file_names,
                'seconds': round(time.monotonic() - self._started, 3),
                'lost': {topic: loss.lost for topic, (_, loss) in self._watches.items()},
                'publishers': {topic: watch.most_publishers
                               for topic, (watch, _) in self._watches.items()}}

    def _report(self) -> None:
        counters = self.counters()
        now = time.monotonic()
        rate = ((counters['written'] - self._last_report[1])
                / max(now - self._last_report[0], 1e-9))
        self._last_report = (now, counters['written'])
        self.get_logger().info(
            f"{counters['written']} messages written ({rate:.0f}/s), {counters['received']} "
            f"received, on {len(self._topics)} topic(s), {len(counters['files'])} file(s)")

    def close(self) -> None:
        """Write what is pending, close the bag (``metadata.yaml``), log and save counters."""
        if self._closed:
            return
        self._closed = True
        try:
            self._flush_pending()
            self.writer.close()
        except (BagError, OSError, SystemExit) as exc:
            self.get_logger().error(f'closing {self.writer.path} failed: {exc}')
            self.writer.abort()
        for _, loss in self._watches.values():  # the stream ended: count what is pending
            loss.settle()
        counters = self.counters()
        per_topic = ', '.join(f'{t} {n}' for t, n in counters['topics'].items()) or 'no topics'
        self.get_logger().info(
            f"bag closed: {counters['bag']}: {counters['written']} of {counters['received']} "
            f"received messages written in {len(counters['files'])} file(s): {per_topic}")
        for topic, lost in counters['lost'].items():
            if lost:
                self.get_logger().warning(f'{topic}: {lost} samples lost before they reached '
                                          'the recorder (gaps in their stamps)')
        if self.settings['stats_file']:
            path = Path(self.settings['stats_file'])
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(counters, indent=1))


def main(args: list[str] | None = None) -> None:
    """Entry point of the ``recorder`` executable."""
    sys.exit(run_node('recorder', RecorderNode, args,
                      description=__doc__ or '', parameters=PARAMETERS))


if __name__ == '__main__':
    main()
