"""A stopping node (`runtime`): it takes what is queued, no more than it may wait, and the
whole stop is bounded."""
from __future__ import annotations

import subprocess
import sys
import time

import pytest

from scara_ident_ros.nodes.runtime import drain

pytestmark = pytest.mark.ros


class QueueExecutor:
    """Stands for an executor whose subscription holds ``queued`` messages; each
    ``spin_once`` takes one (``arrive`` more come after ``delay`` seconds)."""

    def __init__(self, queued: int, *, arrive: int = 0, delay: float = 0.0) -> None:
        self.queued = queued
        self.taken = 0
        self.arrive_at = time.monotonic() + delay if arrive else None
        self.arrive = arrive

    def spin_once(self, timeout_sec: float) -> None:
        assert timeout_sec == 0.0
        if self.arrive_at is not None and time.monotonic() >= self.arrive_at:
            self.queued += self.arrive
            self.arrive_at = None
        if self.queued:
            self.queued -= 1
            self.taken += 1


def test_drain_takes_everything_queued_then_stops() -> None:
    executor = QueueExecutor(5000)
    assert drain(executor, lambda: executor.taken) == 5000
    assert executor.queued == 0


def test_drain_waits_for_messages_in_flight_for_the_quiet_time() -> None:
    executor = QueueExecutor(10, arrive=7, delay=0.02)
    assert drain(executor, lambda: executor.taken, quiet=0.1) == 17


def test_a_publisher_that_goes_on_does_not_hold_the_stop_up() -> None:
    """A backlog, with a timer's event after every second message and a 5 ms pause inside
    it (the executor had nothing for 3-5 ms within a real backlog), then a live stream of
    one message per 0.5 ms: the backlog is taken whole, the live stream briefly."""
    class Live(QueueExecutor):
        def __init__(self) -> None:
            super().__init__(3000)
            self.spins = 0
            self.next_live: float | None = None
            self.paused_until: float | None = None

        def spin_once(self, timeout_sec: float) -> None:
            self.spins += 1
            now = time.monotonic()
            if self.queued == 1500 and self.paused_until is None:
                self.paused_until = now + 0.005
            if self.paused_until is not None and now < self.paused_until:
                return  # nothing delivered for a moment, the backlog still there
            if self.queued and self.spins % 3 == 0:
                return  # a timer's callback: no message taken
            if not self.queued and self.next_live is None:
                self.next_live = now
            if self.next_live is not None and now >= self.next_live:
                self.queued += 1
                self.next_live += 0.0005
            super().spin_once(timeout_sec)

    executor = Live()
    started = time.monotonic()
    taken = drain(executor, lambda: executor.taken, timeout=5.0, quiet=0.05)
    assert time.monotonic() - started < 1.0
    assert taken >= 3000


def test_drain_is_bounded_in_time() -> None:
    class Endless(QueueExecutor):
        def spin_once(self, timeout_sec: float) -> None:
            self.taken += 1  # a publisher that goes on

    executor = Endless(0)
    started = time.monotonic()
    drain(executor, lambda: executor.taken, timeout=0.2)
    assert time.monotonic() - started < 1.0


def test_a_stop_that_hangs_ends_the_process_with_tracebacks() -> None:
    """After a stop signal, a node stuck in its close (here: a sleep) still ends, exit 1,
    naming where it hung: it must not outlive the run that stopped it."""
    program = """
import os, signal, threading, time
from scara_ident_ros.nodes import runtime
stop = threading.Event()
runtime._install_stop_handlers(stop, timeout=1.0)
os.kill(os.getpid(), signal.SIGTERM)
assert stop.is_set()
def stuck_in_close():
    time.sleep(30)
stuck_in_close()
"""
    started = time.monotonic()
    done = subprocess.run([sys.executable, '-c', program], capture_output=True, text=True,
                          timeout=25)
    assert done.returncode == 1, done.stderr  # the watchdog's exit, not SIGTERM's (-15)
    assert time.monotonic() - started < 20
    assert 'Timeout' in done.stderr and 'stuck_in_close' in done.stderr, done.stderr
