"""Ctrl-C in a terminal on a node's console script: SIGINT to its whole process group.

The console script (``.venv/bin/identifier``, what ``ros2 run`` starts) runs in a process
group of its own, as a shell's foreground job; the test sends SIGINT to the group
(``os.killpg``), as the terminal does. The identifier must exit 0 without a traceback, and
its learner processes (the ``lm`` trainer's, prestarted before the stream) must be gone when
it has exited: none printing ``KeyboardInterrupt``, none left a zombie or running. Stopped
while still importing, a node prints one line.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

IDENTIFIER = str(Path(sys.executable).with_name('identifier'))
START_TIMEOUT = 60.0  # s for the node to start on a busy machine
STOP_TIMEOUT = 20.0  # s for it to exit after SIGINT
GONE_AFTER = 0.5  # s after the exit by which no learner may be left


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid``."""
    found = []
    for entry in Path('/proc').iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / 'stat').read_text()
            except OSError:
                continue
            if int(stat.rsplit(')', 1)[1].split()[1]) == pid:
                found.append(int(entry.name))
    return found


def _exists(pid: int) -> bool:
    """Whether process ``pid`` exists, a zombie included."""
    return Path(f'/proc/{pid}').exists()


def _start(err: object) -> subprocess.Popen[bytes]:
    return subprocess.Popen([IDENTIFIER], process_group=0, stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=err,
                            env={**os.environ, 'PYTHONUNBUFFERED': '1'})


def _stop(process: subprocess.Popen[bytes]) -> tuple[int, float]:
    """SIGINT to the process group; the exit status and how long the exit took (s)."""
    started = time.monotonic()
    os.killpg(process.pid, signal.SIGINT)
    try:
        status = process.wait(STOP_TIMEOUT)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
        raise AssertionError(f'still running {STOP_TIMEOUT} s after SIGINT') from None
    return status, time.monotonic() - started


def test_ctrl_c_ends_the_identifier_and_its_learners_without_a_traceback(domain: int) -> None:
    with tempfile.TemporaryFile() as err:
        process = _start(err)
        try:
            deadline = time.monotonic() + START_TIMEOUT
            learners: list[int] = []
            while time.monotonic() < deadline:
                err.seek(0)
                started = b' identifier on ' in err.read()
                learners = _children(process.pid)
                if started and learners:
                    break
                assert process.poll() is None, 'the identifier exited by itself'
                time.sleep(0.05)
            assert learners, f'no learner process after {START_TIMEOUT} s'
            status, _ = _stop(process)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
        time.sleep(GONE_AFTER)
        err.seek(0)
        stderr = err.read().decode(errors='replace')
    assert status == 0, stderr
    assert 'Traceback' not in stderr and 'KeyboardInterrupt' not in stderr, stderr
    assert not [pid for pid in learners if _exists(pid)], (learners, stderr)


def test_ctrl_c_while_importing_prints_one_line(domain: int) -> None:
    with tempfile.TemporaryFile() as err:
        process = _start(err)
        try:
            # past the interpreter's own start: the node's modules are being imported
            maps = Path(f'/proc/{process.pid}/maps')
            deadline = time.monotonic() + START_TIMEOUT
            while b'numpy' not in maps.read_bytes():
                assert time.monotonic() < deadline and process.poll() is None
                time.sleep(0.002)
            status, _ = _stop(process)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
        err.seek(0)
        stderr = err.read().decode(errors='replace')
    assert status == 0, stderr
    assert stderr == 'identifier: stopped while starting\n', stderr
