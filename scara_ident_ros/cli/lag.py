"""``scara-ident lag``: how late each sample reaches a subscriber, measured from outside.

``scara-ident lag --topics /joint_states /ffs/identified_torque --duration 30`` joins the
running graph as a separate subscriber would (``ros2 topic echo``, a controller) and notes,
for every message, its receipt (wall clock) minus its ``header.stamp``. For
``identified_torque`` that stamp is the predicted sample's, so the figure is the whole
path: the simulator or driver, DDS, the identifier's q'' window and message path.

What it takes for this figure to be the graph's rather than its own: subscriptions are raw
(``raw=True``: nothing is deserialized; the stamp is read from the CDR bytes,
:func:`~scara_ident_ros.bag.cdr.header_stamp_ns`), on an ``EventsExecutor`` in a process of
its own, with the garbage collector off (its pauses would be counted as the graph's).
A topic is subscribed once it has a publisher, reliable when every publisher offers
reliable.

It prints, per topic, the lag's p50 / p99 / p99.9 / max (ms) after the first ``--skip``
seconds of that topic (start-up), and where in time the slow ones fall: the samples above
the p99 in each ``--window`` (s) from the topic's first sample and the worst windows.
``--json`` writes the same figures for a benchmark. The duration counts from the first
sample received; Ctrl-C ends it early, with the report of what came.
"""
from __future__ import annotations

import argparse
import gc
import json
import signal
import threading
import time
from array import array
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.bag.cdr import header_stamp_ns
from scara_ident_ros.cli import CliError

__all__ = ['LagFigures', 'add_parser', 'lag_figures', 'run']

WINDOW = 5.0  # s: the windows in which the slow samples are counted
SKIP = 1.0  # s of each topic's first samples left out of the figures (start-up)
DEPTH = 5000  # messages a subscription may queue (5 s at 1 kHz)
WORST = 3  # windows listed as the worst
POLL = 0.1  # s: the longest a stop or a new publisher waits to be seen


@dataclass(frozen=True)
class LagFigures:
    """One topic's lag: receipt minus ``header.stamp``, after its first ``skip_s`` s.

    Attributes
    ----------
    topic : str
    received : int
        Messages received in all (the skipped ones included).
    counted : int
        Messages in the figures.
    p50_ms, p99_ms, p999_ms, max_ms : float
        Percentiles and maximum of the lag (ms); NaN when none was counted.
    window_s : float
        Length of the windows (s).
    above_p99 : list of int, one per window
        Messages above ``p99_ms`` in each window from the topic's first message.
    worst : list of (float, int, float)
        The windows with most messages above the p99: (start in s from the first message,
        how many, the window's max lag in ms), worst first.
    """

    topic: str
    received: int
    counted: int
    p50_ms: float
    p99_ms: float
    p999_ms: float
    max_ms: float
    window_s: float
    above_p99: list[int]
    worst: list[tuple[float, int, float]]


def lag_figures(topic: str, stamps_ns: NDArray[np.int64], receipts_ns: NDArray[np.int64],
                *, skip_s: float = SKIP, window_s: float = WINDOW) -> LagFigures:
    """The lag figures of one topic.

    Parameters
    ----------
    topic : str
    stamps_ns, receipts_ns : ndarray of shape (N,)
        Each message's ``header.stamp`` and its receipt (wall clock, ns), in the order
        received.
    skip_s : float
        Seconds (of receipt time, from the first message) left out.
    window_s : float
        Length (s) of the windows the samples above the p99 are counted in.
    """
    stamps = np.asarray(stamps_ns, np.int64)
    receipts = np.asarray(receipts_ns, np.int64)
    if stamps.shape != receipts.shape:
        raise ValueError(f'{topic}: {stamps.size} stamps for {receipts.size} receipts')
    if receipts.size == 0:
        nan = float('nan')
        return LagFigures(topic, 0, 0, nan, nan, nan, nan, window_s, [], [])
    since = (receipts - receipts[0]) / 1e9  # s from the first message
    kept = since >= skip_s
    lag_ms = (receipts - stamps)[kept] / 1e6
    since = since[kept]
    if lag_ms.size == 0:
        nan = float('nan')
        return LagFigures(topic, int(receipts.size), 0, nan, nan, nan, nan, window_s, [], [])
    p50, p99, p999 = (float(v) for v in np.percentile(lag_ms, [50, 99, 99.9]))
    window = (since // window_s).astype(np.int64)
    slow = lag_ms > p99
    above = np.bincount(window[slow], minlength=int(window[-1]) + 1)
    worst_max = np.full(above.size, -np.inf)
    np.maximum.at(worst_max, window, lag_ms)
    order = [int(i) for i in np.argsort(-above, kind='stable')[:WORST] if above[i]]
    worst = [(i * window_s, int(above[i]), float(worst_max[i])) for i in order]
    return LagFigures(topic, int(receipts.size), int(lag_ms.size), p50, p99, p999,
                      float(lag_ms.max()), window_s, [int(n) for n in above], worst)


def format_figures(figures: Sequence[LagFigures], skip_s: float) -> str:
    """The figures as Markdown: a table of the lags, then the slow samples in time."""
    lines = [f'| topic | messages (counted after the first {skip_s:g} s) | '
             'lag p50 / p99 / p99.9 / max (ms) |', '|---|---:|---:|']
    for f in figures:
        lines.append(f'| {f.topic} | {f.received} ({f.counted}) | {f.p50_ms:.1f} / '
                     f'{f.p99_ms:.1f} / {f.p999_ms:.1f} / {f.max_ms:.1f} |')
    for f in figures:
        if not f.counted:
            continue
        worst = ', '.join(f'{start:g}-{start + f.window_s:g} s: {n} (max {top:.0f} ms)'
                          for start, n, top in f.worst)
        lines += ['', f'{f.topic}: messages above its p99 per {f.window_s:g} s window: '
                  + ' '.join(str(n) for n in f.above_p99), f'worst windows: {worst}']
    return '\n'.join(lines)


def add_parser(subparsers: Any) -> None:
    """Register ``lag`` and its options."""
    parser = subparsers.add_parser(
        'lag', help="how late each topic's samples reach a separate subscriber",
        description=__doc__.split('\n\n')[0].replace('``', ''))
    parser.add_argument('--topics', nargs='+', required=True, metavar='TOPIC',
                        help='topics whose messages start with a std_msgs/Header')
    parser.add_argument('--duration', type=float, default=30.0, metavar='S',
                        help='seconds from the first message (default 30)')
    parser.add_argument('--skip', type=float, default=SKIP, metavar='S',
                        help=f"seconds of each topic's first messages left out (default "
                             f'{SKIP:g})')
    parser.add_argument('--window', type=float, default=WINDOW, metavar='S',
                        help=f'windows in which the slow samples are counted (default '
                             f'{WINDOW:g})')
    parser.add_argument('--wait', type=float, default=30.0, metavar='S',
                        help='longest wait for a first message (default 30)')
    parser.add_argument('--json', type=Path, default=None, metavar='FILE',
                        help='also write the figures as JSON')
    parser.set_defaults(func=run)


class _Received:
    """One topic's stamps and receipts, appended by its subscription's callback."""

    def __init__(self) -> None:
        self.stamps = array('q')
        self.receipts = array('q')

    def callback(self) -> Callable[[bytes], None]:
        """The raw subscription's callback: the receipt first, then the stamp."""
        now, add_receipt, add_stamp = time.time_ns, self.receipts.append, self.stamps.append

        def received(raw: bytes) -> None:
            add_receipt(now())
            add_stamp(header_stamp_ns(raw) or 0)
        return received


def run(args: argparse.Namespace) -> int:
    """Subscribe, collect for ``--duration`` s from the first message, print the figures."""
    if args.duration <= 0 or args.window <= 0 or args.skip < 0 or args.wait < 0:
        raise CliError('--duration and --window must be > 0, --skip and --wait >= 0')
    received = _listen(args.topics, args.duration, args.wait)
    figures = [lag_figures(topic, np.frombuffer(r.stamps, np.int64),
                           np.frombuffer(r.receipts, np.int64),
                           skip_s=args.skip, window_s=args.window)
               for topic, r in received.items()]
    print(format_figures(figures, args.skip))
    if args.json is not None:
        args.json.write_text(json.dumps([asdict(f) for f in figures], indent=1))
    return 0 if any(f.received for f in figures) else 1


def _listen(topics: Sequence[str], duration: float, wait: float) -> dict[str, _Received]:
    """Subscribe each of ``topics`` raw once it has a publisher; collect until ``duration``
    s after the first message (or ``wait`` s without any, or SIGINT/SIGTERM)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.experimental import EventsExecutor
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions

    from scara_ident_ros.bag.message_class import message_class

    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    received = {topic: _Received() for topic in topics}
    try:
        node = rclpy.create_node('scara_ident_lag', context=context, enable_rosout=False,
                                 start_parameter_services=False)
        executor = EventsExecutor(context=context)
        executor.add_node(node)
        waiting = {node.resolve_topic_name(topic): topic for topic in topics}
        gc.collect()
        gc.freeze()  # what is built so far stays; nothing allocated from now on is collected
        gc.disable()
        started = time.monotonic()
        first: float | None = None
        while not stop.is_set():
            if waiting:
                for name, topic in list(waiting.items()):
                    offers = node.get_publishers_info_by_topic(name)
                    if not offers:
                        continue
                    cls = message_class(offers[0].topic_type)
                    fields = {} if cls is None else cls.get_fields_and_field_types()
                    if fields.get('header') != 'std_msgs/Header':
                        raise CliError(f'{topic} ({offers[0].topic_type}) has no header stamp')
                    reliable = all(o.qos_profile.reliability == ReliabilityPolicy.RELIABLE
                                   for o in offers)
                    qos = QoSProfile(depth=DEPTH, history=HistoryPolicy.KEEP_LAST,
                                     reliability=ReliabilityPolicy.RELIABLE if reliable
                                     else ReliabilityPolicy.BEST_EFFORT)
                    node.create_subscription(cls, name, received[topic].callback(), qos,
                                             raw=True)
                    del waiting[name]
            executor.spin_once(timeout_sec=POLL)
            now = time.monotonic()
            if first is None:
                if any(len(r.receipts) for r in received.values()):
                    first = now
                elif now - started > wait:
                    raise CliError(f'no message on {", ".join(topics)} in {wait:g} s')
            elif now - first >= duration:
                break
        node.destroy_node()
    finally:
        gc.enable()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        context.try_shutdown()
    return received
