"""Why the simulator's samples are late: its thread's run-queue wait, normal against SCHED_FIFO.

Each run starts the demo's graph by hand (recorder; one identifier serving FFMW, FFW and FFS
with their learner processes; ``scara_sim`` waiting for both) for ``--seconds`` at 1 kHz,
with the simulator traced: for every sample, the wall clock before ``publish()`` against the
sample's stamp (how late the simulator itself is) and its thread's
``/proc/thread-self/schedstat`` (time running, time runnable but waiting for a CPU) before
and after ``publish()``. Runs alternate between normal scheduling and the nodes'
``realtime_priority`` (simulator 30, identifier 20, recorder 10, as ``scara-ident run``).
From the second second on, it reports per run: the simulator late before publishing p50 /
p99 / max, and of its thread's time: waiting for a CPU (in all, and the longest single
wait between two samples or within one ``publish()``), running, and blocked in
``publish()`` (neither running nor waiting).

Usage: ``python benchmarks/bench_sim_wait.py [--seconds 30] [--runs 1]``; appends a section
to ``benchmarks/sim_wait.md`` (``--no-write``: print only).
"""
from __future__ import annotations

import argparse
import datetime
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from processes import kill, stop  # benchmarks/: the script's own folder
from ros_env import ros_env

from scara_ident_ros.nodes.realtime import GRAPH_PRIORITIES

HERE = Path(__file__).resolve().parent
OUTPUT = HERE / 'sim_wait.md'
PRIORITIES = {'scara_sim': GRAPH_PRIORITIES['simulator'],  # as scara-ident run's
              'identifier': GRAPH_PRIORITIES['identifier'],
              'recorder': GRAPH_PRIORITIES['recorder']}
SKIP_NS = 1_000_000_000  # the first second (start-up) is left out

# scara_sim with each sample's stamp, wall clock around publish() and its thread's
# schedstat (ns running, ns waiting on the run queue) around it, saved at exit
TRACED_SIM = r"""
import atexit, os, sys, time
import numpy as np
from scara_ident_ros.nodes import sim_node
from scara_ident_ros.nodes.scara_sim import main
trace, fd = [], []
def sched():
    if not fd:
        fd.append(os.open('/proc/thread-self/schedstat', os.O_RDONLY))
    os.lseek(fd[0], 0, 0)
    run, wait, _ = os.read(fd[0], 100).split()
    return int(run), int(wait)
publish_next = sim_node.SimulatorNode.publish_next
def traced(self):
    r0, w0 = sched()
    t0 = time.time_ns()
    publish_next(self)
    t1 = time.time_ns()
    r1, w1 = sched()
    stamp = self.msg.header.stamp
    trace.append((stamp.sec * 1_000_000_000 + stamp.nanosec, t0, t1, r0, w0, r1, w1))
sim_node.SimulatorNode.publish_next = traced
path = sys.argv.pop(1)
atexit.register(lambda: np.save(path, np.array(trace, np.int64)))
main()
"""


def one_run(seconds: float, fifo: bool, env: dict[str, str]) -> dict[str, Any]:
    """The graph once; the simulator's figures."""
    out = Path(tempfile.mkdtemp(prefix='bench_sim_wait_'))
    trace = out / 'trace.npy'

    def params(node: str, *values: str) -> list[str]:
        prio = [f'realtime_priority:={PRIORITIES[node]}'] if fifo else []
        return ['--ros-args', *(a for v in (*values, *prio) for a in ('-p', v))]

    py = sys.executable
    commands = {
        'recorder': [py, '-m', 'scara_ident_ros.nodes.recorder',
                     *params('recorder', f'output:={out / "bag"}')],
        'identifier': [py, '-m', 'scara_ident_ros.nodes.identifier',
                       *params('identifier', 'methods:=[ffmw,ffw,ffs]',
                               'external_torque:=false')],
        'scara_sim': [py, '-c', TRACED_SIM, str(trace),
                      *params('scara_sim', f'duration:={seconds:g}', 'wait_for_subscribers:=2',
                              'wait_timeout:=60.0')]}
    procs = {name: subprocess.Popen(cmd, env=env, start_new_session=True,
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
             for name, cmd in commands.items()}
    try:
        procs['scara_sim'].wait(seconds + 180)
        time.sleep(1.0)
        for proc in procs.values():
            stop(proc)
    finally:
        kill(*procs.values())
    a = np.load(trace)
    stamp, t0, t1, r0, w0, r1, w1 = a[a[:, 0] >= a[0, 0] + SKIP_NS].T
    late = (t0 - stamp) / 1e6
    waits = np.concatenate([w1 - w0, w0[1:] - w1[:-1]]) / 1e9
    running = ((r1 - r0).sum() + (r0[1:] - r1[:-1]).sum()) / 1e9
    blocked = ((t1 - t0) - (r1 - r0) - (w1 - w0)).sum() / 1e9
    return {'mode': 'SCHED_FIFO' if fifo else 'normal', 'load': os.getloadavg()[0],
            'wall': (t1[-1] - t0[0]) / 1e9, 'late': np.percentile(late, [50, 99, 100]),
            'waiting': waits.sum(), 'longest': waits.max(), 'running': running,
            'blocked': blocked}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=30.0)
    parser.add_argument('--runs', type=int, default=1, help='pairs (normal, SCHED_FIFO)')
    parser.add_argument('--no-write', action='store_true', help='print only')
    args = parser.parse_args()
    env = ros_env()
    load_before = os.getloadavg()[0]
    runs = [one_run(args.seconds, fifo, env) for _ in range(args.runs) for fifo in (False, True)]
    commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=HERE,
                            capture_output=True, text=True).stdout.strip() or '?'
    lines = [f'## {args.seconds:g} s ({datetime.date.today().isoformat()}, commit {commit})',
             '', f'`python benchmarks/bench_sim_wait.py --seconds {args.seconds:g} --runs '
             f'{args.runs}`; load average {load_before:.2f} before.', '',
             '| run | scheduling | load after | simulator late before publish() p50 / p99 / '
             'max (ms) | its thread waiting for a CPU (s), longest wait (ms) | running (s) '
             '| blocked in publish() (s) | of (s) |', '|---|---|---:|---:|---:|---:|---:|---:|']
    for i, r in enumerate(runs, 1):
        late = ' / '.join(f'{v:.2f}' for v in r['late'])
        lines.append(f'| {i} | {r["mode"]} | {r["load"]:.2f} | {late} | {r["waiting"]:.2f}, '
                     f'{1e3 * r["longest"]:.0f} | {r["running"]:.2f} | {r["blocked"]:.2f} | '
                     f'{r["wall"]:.1f} |')
    text = '\n'.join(lines) + '\n'
    print(text)
    if not args.no_write:
        head = '' if OUTPUT.exists() else (
            '# Why the simulator is late\n\nWritten by `benchmarks/bench_sim_wait.py` (its '
            'docstring says what it measures).\n\n')
        with OUTPUT.open('a') as f:
            f.write(head + text + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
