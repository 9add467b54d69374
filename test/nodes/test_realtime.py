"""use_realtime_priority: every thread under SCHED_FIFO or none, later processes normal."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from scara_ident_ros.nodes.realtime import use_realtime_priority

# In a child: a second thread, the priority asked for, then each thread's policy and
# priority and those of a process started afterwards (this test's process stays as it is).
CHILD = r"""
import json, os, subprocess, sys, threading
from scara_ident_ros.nodes.realtime import use_realtime_priority
ready, done = threading.Event(), threading.Event()
def worker():
    ready.set()
    done.wait()
threading.Thread(target=worker).start()
ready.wait()
problem = use_realtime_priority(7)
threads = [(os.sched_getscheduler(int(t)), os.sched_getparam(int(t)).sched_priority)
           for t in os.listdir('/proc/self/task')]
child = subprocess.run([sys.executable, '-c', 'import os; print(os.sched_getscheduler(0))'],
                       capture_output=True, text=True, check=True).stdout
done.set()
print(json.dumps({'problem': problem, 'threads': threads, 'child': int(child)}))
"""


def test_every_thread_runs_fifo_and_a_process_started_later_normally() -> None:
    out = subprocess.run([sys.executable, '-c', CHILD], capture_output=True, text=True,
                         check=True, timeout=60).stdout
    result = json.loads(out)
    assert len(result['threads']) >= 2
    if result['problem']:  # no CAP_SYS_NICE nor ulimit -r: all threads left normal
        assert 'refused' in result['problem']
        assert all(policy == os.SCHED_OTHER for policy, _ in result['threads'])
    else:
        fifo = os.SCHED_FIFO | os.SCHED_RESET_ON_FORK
        assert result['threads'] == [[fifo, 7]] * len(result['threads'])
    assert result['child'] == os.SCHED_OTHER


def test_a_refusal_puts_back_the_threads_already_changed(
        monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[int, int]] = []

    def setscheduler(tid: int, policy: int, param: os.sched_param) -> None:
        calls.append((tid, policy))
        if tid == 13 and policy != os.SCHED_OTHER:
            raise PermissionError('not permitted')

    monkeypatch.setattr(os, 'listdir', lambda path: ['11', '12', '13'])
    monkeypatch.setattr(os, 'sched_setscheduler', setscheduler)
    problem = use_realtime_priority(5)
    assert problem.startswith('SCHED_FIFO priority 5 refused')
    assert calls[-2:] == [(11, os.SCHED_OTHER), (12, os.SCHED_OTHER)]


@pytest.mark.parametrize('priority', [0, 100])
def test_a_priority_out_of_range_is_refused(priority: int) -> None:
    with pytest.raises(ValueError, match='1-99'):
        use_realtime_priority(priority)
