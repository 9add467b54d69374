"""The child processes of a benchmark: their CPU time, and how they are stopped.

A node's CPU is utime + stime of all its threads from ``/proc/<pid>/stat``; a node stops on
SIGINT, as under ``ros2 run``, and is killed only if it does not exit in time.
"""
from __future__ import annotations

import os
import signal
import subprocess
from pathlib import Path

__all__ = ['STOP_TIMEOUT', 'cpu_seconds', 'kill', 'stop']

CLK_TCK = os.sysconf('SC_CLK_TCK')  # clock ticks per second of /proc/<pid>/stat times
STOP_TIMEOUT = 20.0  # s for a node to exit after SIGINT


def cpu_seconds(pid: int) -> float:
    """utime + stime of process ``pid`` (all its threads), seconds."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK  # fields 14 and 15 of stat(5)


def stop(proc: subprocess.Popen[str], timeout: float = STOP_TIMEOUT) -> int:
    """SIGINT, then SIGKILL after ``timeout`` s; return the exit status."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            return proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
    return proc.wait()


def kill(*procs: subprocess.Popen[str] | None) -> None:
    """Kill and reap those of ``procs`` still running (a benchmark's ``finally``)."""
    for proc in procs:
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait()
