"""Start, spin and stop a node the same way in every executable of the package.

Every node runs in its own process on an :class:`rclpy.experimental.EventsExecutor`
driven by ``spin_once`` in a loop: in the Jazzy wheels it costs a fraction of the CPU
of the default executor at 1 kHz, while its ``spin()`` does not fire a 1 ms timer
reliably and ignores Ctrl-C (``benchmarks/bench_executor.py``).

SIGINT and SIGTERM set a stop flag, checked at least every :data:`POLL_PERIOD`. A node
with ``handled()`` then drains what is queued (:func:`drain`: until it waits for messages
more than it takes them, or nothing comes for :data:`DRAIN_QUIET`; at most
:data:`DRAIN_TIMEOUT`), so no acknowledged sample is dropped, while a publisher that goes
on does not hold the stop up;
it is then closed (``close()``), destroyed, and the process exits 0. A stop longer than
:data:`STOP_TIMEOUT` ends the process with exit 1 and every thread's traceback: a node
must not outlive its run and publish into the next graph. A
:class:`~scara_ident_ros.errors.ScaraIdentError` (e.g. ``ConfigError``) raised while the
node is built ends it with one line and exit 2. Once built, the node and everything
imported are frozen out of the garbage collector's sight (``gc.freeze``), and its threads
run under ``SCHED_FIFO`` if its ``realtime_priority`` parameter asks
(:mod:`~scara_ident_ros.nodes.realtime`). The optional
hooks are the protocols `PacedNode`, `DrainingNode` and `ClosingNode`.
"""
from __future__ import annotations

import faulthandler
import gc
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from types import FrameType
from typing import Protocol, runtime_checkable

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from scara_ident_ros.errors import ScaraIdentError
from scara_ident_ros.nodes.parameters import ParamSpec
from scara_ident_ros.nodes.realtime import REALTIME_PRIORITY, use_realtime_priority
from scara_ident_ros.nodes.rosenv import ensure_local_dds

__all__ = ['ClosingNode', 'DrainingNode', 'PacedNode', 'drain', 'help_text', 'run_node',
           'POLL_PERIOD']

POLL_PERIOD = 0.1  # seconds: the longest a stop request waits to be seen
DRAIN_TIMEOUT = 10.0  # seconds a stopping node may spend on the messages already queued
DRAIN_QUIET = 0.05  # seconds without a new message that end the drain
DRAIN_WINDOW = 0.1  # seconds over which a drain tells a backlog from a live publisher
IDLE_SHARE = 0.5  # share of a window spent waiting for messages: the backlog is taken
#: Seconds from the first stop signal to the process's end at the latest: the drain
#: (DRAIN_TIMEOUT), the outputs' acknowledgements (2-5 s) and close(), with room to spare.
STOP_TIMEOUT = 45.0


@runtime_checkable
class PacedNode(Protocol):
    """A node that paces itself (scara_sim, player, recorder): `run_node` calls its loop
    instead of spinning."""

    def loop(self, executor: Executor, stop: threading.Event) -> None:
        """Spin ``executor`` and do the node's work until ``stop`` is set."""


@runtime_checkable
class DrainingNode(Protocol):
    """A node whose queued messages are taken on stop (`drain`) before it closes."""

    def handled(self) -> int:
        """Messages taken so far."""


@runtime_checkable
class ClosingNode(Protocol):
    """A node with outputs to finish (flush files, save models) before it is destroyed."""

    def close(self) -> None:
        """Finish the node's outputs; called once, after the drain."""


def _install_stop_handlers(stop: threading.Event, timeout: float = STOP_TIMEOUT) -> None:
    """SIGINT and SIGTERM set ``stop``; the first also starts a watchdog that ends the
    process (exit 1, tracebacks on stderr) if it is still there ``timeout`` s later."""
    def handler(signum: int, frame: FrameType | None) -> None:
        if not stop.is_set():
            faulthandler.dump_traceback_later(timeout, exit=True)
        stop.set()

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)


def run_node(name: str, factory: Callable[[], Node], args: list[str] | None = None, *,
             description: str = '', parameters: Sequence[ParamSpec] = ()) -> int:
    """Build the node with ``factory`` and spin it until SIGINT/SIGTERM.

    ``factory`` is called after ``rclpy.init``; ``args`` default to ``sys.argv``;
    ``--help`` shows the first paragraph of ``description`` (the module docstring) and the
    ``parameters``. Return the exit status (module docstring).
    """
    argv = sys.argv if args is None else args
    user = argv[:argv.index('--ros-args')] if '--ros-args' in argv else argv
    if '-h' in user or '--help' in user:  # before rclpy: --help starts nothing
        print(help_text(name, description, parameters))
        return 0
    ensure_local_dds()
    stop = threading.Event()
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    except RuntimeError as exc:  # rcl rejected the command line (e.g. a malformed -p)
        print(f'{name}: error: {" ".join(str(exc).split())}', file=sys.stderr)
        return 2
    _install_stop_handlers(stop)
    node: Node | None = None
    try:
        try:
            node = factory()
        except (ScaraIdentError, ParameterException, ValueError) as exc:
            message = ' '.join(str(exc).split())  # one line, even for a YAML parser's report
            print(f'{name}: error: {message}', file=sys.stderr)
            return 2
        # What is built so far (modules, ROS handles, the node) lives as long as the
        # process: out of the collector's sight, a full collection does not walk it all
        # while samples wait (tens of ms each, in every node). Then its threads become
        # real-time if it asks (scara_ident_ros.nodes.realtime).
        gc.collect()
        gc.freeze()
        executor = EventsExecutor()
        executor.add_node(node)
        _schedule(node)  # after the executor: its timers' thread too
        if isinstance(node, PacedNode):
            node.loop(executor, stop)
        else:
            while not stop.is_set():
                executor.spin_once(timeout_sec=POLL_PERIOD)
        if isinstance(node, DrainingNode):
            taken = drain(executor, node.handled)
            if taken:
                node.get_logger().info(f'took the {taken} message(s) still queued on stop')
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            if isinstance(node, ClosingNode):
                node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def _schedule(node: Node) -> None:
    """Run the node's threads under SCHED_FIFO if it has a ``realtime_priority`` > 0."""
    name = REALTIME_PRIORITY.name
    priority = node.get_parameter(name).value if node.has_parameter(name) else 0
    if priority:
        problem = use_realtime_priority(priority)
        if problem:
            node.get_logger().warning(problem)
        else:
            node.get_logger().info(f'threads under SCHED_FIFO, priority {priority}')


class Spinner(Protocol):
    """What :func:`drain` needs of an executor."""

    def spin_once(self, timeout_sec: float | None = None) -> None:
        """Execute one ready callback, waiting at most ``timeout_sec``."""


def drain(executor: Spinner, handled: Callable[[], int], *,
          timeout: float = DRAIN_TIMEOUT, quiet: float = DRAIN_QUIET,
          window: float = DRAIN_WINDOW) -> int:
    """Take what is queued: ``spin_once`` with zero timeout until it is taken.

    A backlog gives a message at nearly every call; a publisher that goes on (a robot's
    driver, a second graph) gives one now and then, and the drain waits between them. So
    the drain ends once, over ``window`` seconds, it has waited for messages more than
    half of the time (:data:`IDLE_SHARE`): the queue the stop found is taken, and such a
    publisher does not hold the stop up for ``timeout``. A few ms without a message inside
    a backlog (seen: 3-5 ms within 4000 queued samples) do not end it. It also ends once
    ``handled()`` has not grown for ``quiet`` seconds (what is in flight has come), and
    after ``timeout`` seconds at the latest. Return how many messages it took.
    """
    start = handled()
    last = start
    now = time.monotonic()
    deadline, quiet_until = now + timeout, now + quiet
    window_start, idle = now, 0.0
    missed = 0  # calls in a row that took no message
    while now < min(deadline, quiet_until):
        executor.spin_once(timeout_sec=0.0)
        count = handled()
        now = time.monotonic()
        if count != last:
            last, quiet_until, missed = count, now + quiet, 0
        else:
            missed += 1
        if missed >= 2:  # not a timer's event between two messages: nothing is ready
            time.sleep(0.001)  # do not spin the CPU while waiting
            idle += time.monotonic() - now
            now = time.monotonic()
        if now - window_start >= window:
            if idle > IDLE_SHARE * (now - window_start):
                break  # keeping pace with a live publisher: the backlog is taken
            window_start, idle = now, 0.0
    return last - start


def help_text(name: str, description: str, parameters: Sequence[ParamSpec]) -> str:
    """``--help`` of a node: usage, what it does, and each parameter with its default."""
    lines = [f'usage: ros2 run scara_ident_ros {name} [--ros-args -p NAME:=VALUE ...]', '']
    if description.strip():
        lines += [description.strip().split('\n\n')[0], '']
    lines.append('parameters (name, default, description):')
    for spec in parameters:
        limits = []
        if spec.min is not None:
            limits.append(f'>= {spec.min:g}')
        if spec.max is not None:
            limits.append(f'<= {spec.max:g}')
        text = spec.description + (f' [{spec.unit}]' if spec.unit else '')
        if spec.choices:
            text += f" (one of: {', '.join(spec.choices)})"
        if limits:
            text += f" ({', '.join(limits)})"
        lines.append(f'  {spec.name} = {spec.default!r}')
        lines.append(f'      {text}')
    return '\n'.join(lines)
