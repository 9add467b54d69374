"""Start a graph of node processes and stop them cleanly, in order.

What ``ros2 launch`` does for a user with a full ROS 2 install, for machines with
only the rclpy wheels: each node runs as ``python -m <module> --ros-args ...`` in
its own process, its output goes to a log file, and stopping sends SIGINT in the
given order (escalating to SIGTERM, then SIGKILL, after a grace period) so that
every node closes its files and saves its models.

Each node runs in a session of its own, so a Ctrl-C reaches only the program that started
the graph (:class:`StopSignals`), which stops the nodes in order, each with one SIGINT (in
the terminal's process group they would all get it at once, the recorder possibly before
the last samples). Should the program die, the kernel SIGTERMs each node
(``PR_SET_PDEATHSIG``).

:func:`publishers_on` looks, before a graph starts, for another graph already
publishing its topics on the same ROS domain (whose samples would mix with its own).
"""
from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType, TracebackType
from typing import IO

__all__ = ['NodeProcess', 'ProcessGraph', 'StopSignals', 'publishers_on']

PR_SET_PDEATHSIG = 1  # prctl option: signal this process when its parent dies (Linux)
#: s of discovery before concluding that no other graph publishes: longer than Fast DDS's
#: participant announcement period (3 s), so that a participant whose answer to the probe's
#: first announcements is missed (a loaded machine) is still heard at its next announcement
PROBE_TIME = 4.0
PROBE_SETTLE = 2.0  # s of looking on after the last new publisher, for its graph's others
PROBE_POLL = 0.1  # s between two looks at the publisher counts


@dataclass
class NodeProcess:
    """One node process of the graph.

    Parameters
    ----------
    name : str
        Label used for the log file (``<log_dir>/<name>.log``).
    module : str
        Python module with a ``main()`` run as ``python -m module``.
    ros_args : list of str
        Arguments after ``--ros-args`` (``-p name:=value``, ``-r from:=to``, ...).
    """

    name: str
    module: str
    ros_args: list[str] = field(default_factory=list)
    process: subprocess.Popen[bytes] | None = None
    log: IO[bytes] | None = None

    @property
    def returncode(self) -> int | None:
        """Exit status, None while running or before start."""
        return None if self.process is None else self.process.poll()


class ProcessGraph:
    """Start node processes, watch them, stop them in order.

    Parameters
    ----------
    log_dir : Path
        Where each process writes ``<name>.log`` (stdout and stderr).
    env : dict, optional
        Extra environment for the children (the DDS-local defaults are always set).
    """

    def __init__(self, log_dir: Path, env: dict[str, str] | None = None) -> None:
        self.log_dir = log_dir
        self.env = {**os.environ, **(env or {})}
        self.env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
        self.env.setdefault('PYTHONUNBUFFERED', '1')
        # One BLAS thread per process: the nodes' arrays are tiny, and competing BLAS
        # thread pools on 2 cores cost far more than they give.
        self.env.setdefault('OPENBLAS_NUM_THREADS', '1')
        self.env.setdefault('RCUTILS_LOGGING_BUFFERED_STREAM', '0')
        self.nodes: list[NodeProcess] = []

    def start(self, node: NodeProcess) -> NodeProcess:
        """Start ``node`` and return it."""
        self.log_dir.mkdir(parents=True, exist_ok=True)
        node.log = open(self.log_dir / f'{node.name}.log', 'wb')  # noqa: SIM115 closed in stop
        node.process = subprocess.Popen(
            [sys.executable, '-m', node.module, '--ros-args', *node.ros_args],
            stdout=node.log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
            env=self.env, start_new_session=True, preexec_fn=_terminate_with_parent)
        self.nodes.append(node)
        return node

    def failed(self) -> list[NodeProcess]:
        """Return the nodes that have exited with a non-zero status."""
        return [node for node in self.nodes if node.returncode not in (None, 0)]

    def stop(self, node: NodeProcess, *, grace: float = 20.0) -> int:
        """Stop one node: SIGINT, then SIGTERM and SIGKILL after ``grace`` seconds each.

        Returns
        -------
        int
            The node's exit status (negative: killed by that signal).
        """
        proc = node.process
        if proc is None:
            return 0
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            if proc.poll() is not None:
                break
            proc.send_signal(sig)
            try:
                proc.wait(timeout=grace)
            except subprocess.TimeoutExpired:
                continue
        if node.log is not None:
            node.log.close()
        return proc.wait()

    def stop_all(self, *, grace: float = 20.0) -> dict[str, int]:
        """Stop every node in reverse start order; return the exit status by name.

        Sources are started last and stopped first, so that consumers (identifiers,
        the recorder) see every message that was published.
        """
        return {node.name: self.stop(node, grace=grace) for node in reversed(self.nodes)}

    def log_text(self, node: NodeProcess) -> str:
        """Return what ``node`` has written to its log so far."""
        return (self.log_dir / f'{node.name}.log').read_text(errors='replace')


def _find_prctl() -> Callable[..., int] | None:
    """libc's ``prctl``, looked up in the parent (a child of a threaded parent must not
    load libraries between fork and exec); None where there is none (not Linux)."""
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


_PRCTL = _find_prctl()


def _terminate_with_parent() -> None:
    """In the child, before ``exec``: get SIGTERM when the parent dies (Linux only)."""
    if _PRCTL is not None:
        _PRCTL(PR_SET_PDEATHSIG, signal.SIGTERM)


class StopSignals:
    """Within ``with``: SIGINT and SIGTERM set :attr:`received` (the first signal, else
    None) instead of interrupting; the previous handlers come back on the way out."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.received: int | None = None
        self._previous: dict[int, object] = {}

    def _handler(self, signum: int, frame: FrameType | None) -> None:
        if self.received is None:
            self.received = signum

    def __enter__(self) -> StopSignals:
        for sig in self.SIGNALS:
            self._previous[sig] = signal.signal(sig, self._handler)
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 traceback: TracebackType | None) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)  # type: ignore[arg-type]


def publishers_on(topics: Sequence[str], *, wait: float = PROBE_TIME) -> dict[str, int]:
    """Publishers already on the ROS domain of each topic that has some.

    A node of its own (in its own rclpy Context, shut down before returning) looks at the
    graph for up to ``wait`` seconds (discovery takes a moment); once one of ``topics`` has
    a publisher, it goes on looking until no count has grown for ``PROBE_SETTLE`` seconds,
    so that the rest of that graph is discovered too, and gives each topic's largest count.
    On a loaded machine a publisher discovered later is missing from the counts.
    """
    import rclpy
    from rclpy.context import Context
    from rclpy.signals import SignalHandlerOptions

    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('scara_ident_graph_probe', context=context,
                                 enable_rosout=False, start_parameter_services=False)
        deadline = time.monotonic() + wait
        found = dict.fromkeys(topics, 0)
        while True:
            grew = False
            for topic in topics:
                count = node.count_publishers(topic)
                grew = grew or count > found[topic]
                found[topic] = max(found[topic], count)
            now = time.monotonic()
            if grew:  # a publisher appeared: look on for the rest of its graph
                deadline = now + PROBE_SETTLE
            if now >= deadline:
                break
            time.sleep(PROBE_POLL)
        node.destroy_node()
    finally:
        context.try_shutdown()
    return {topic: count for topic, count in found.items() if count}
