"""Real-time behaviour of a simulator node at 1 kHz, seen from another process.

The simulator (``scara_sim``, or ``robot_sim`` with ``--node robot_sim --robot panda``)
runs as its own process (``python -m scara_ident_ros.nodes.<node>``,
``wait_for_subscribers:=1`` so nothing is lost at start) and a lean subscriber runs in a
second process (this script with ``--subscriber``: an EventsExecutor driven by
``spin_once``, a raw subscription whose CDR bytes are not deserialised, receive times
and stamps written into preallocated numpy arrays). Over a window of ``--seconds``
(default 30) that starts ``--warmup`` seconds after the first message, it reports:

- messages per second received;
- inter-arrival p50 / p99 / max (ms), from the subscriber's receive times;
- stamps missing or duplicated (a gap or a repeat in the 1 ms sequence);
- the simulator's CPU as % of one core, from utime + stime in ``/proc/<pid>/stat`` read at
  both ends of the window (start-up excluded).

Run from the repository root::

    .venv/bin/python benchmarks/bench_sim.py [--seconds 30] [--node robot_sim --robot panda]

DDS stays on this machine (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) and the run uses
a domain of its own unless ``ROS_DOMAIN_ID`` is set. Prints a Markdown table.
"""
from __future__ import annotations

import argparse
import os
import select
import signal
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from processes import cpu_seconds, kill, stop  # benchmarks/: the script's own folder
from ros_env import ros_env

NODES = ('scara_sim', 'robot_sim')
JOINT_STATES_TOPIC = '/joint_states'
RATE_HZ = 1000.0
TARGET_RATE = 999.0  # messages/s, at least
TARGET_P99_MS = 1.5  # inter-arrival p99, at most
TARGET_CPU = 25.0  # % of one core for the simulator, at most
START_TIMEOUT = 60.0  # s until the first message


# -- the subscriber process ------------------------------------------------------------------

def subscribe(out: Path, capacity: int) -> None:
    """Record (receive time, stamp) of every joint state until SIGINT/SIGTERM; save to out."""
    import rclpy
    from rclpy.experimental import EventsExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions
    from sensor_msgs.msg import JointState

    received_ns = np.zeros(capacity, dtype=np.int64)  # time.monotonic_ns() at the callback
    stamp_ns = np.zeros(capacity, dtype=np.int64)  # header.stamp
    count = 0
    stop = False

    def on_signal(signum: int, frame: object) -> None:
        nonlocal stop
        stop = True

    def on_message(data: bytes) -> None:
        nonlocal count
        if count < capacity:
            received_ns[count] = time.monotonic_ns()
            # CDR: 4-byte encapsulation header, then header.stamp (int32 sec, uint32 nanosec).
            sec, nanosec = struct.unpack_from('<iI', data, 4)
            stamp_ns[count] = sec * 1_000_000_000 + nanosec
        if count == 0:
            print('first', flush=True)
        count += 1

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    node = rclpy.create_node('bench_sim_subscriber')
    node.create_subscription(JointState, JOINT_STATES_TOPIC, on_message,
                             QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE),
                             raw=True)
    executor = EventsExecutor()
    executor.add_node(node)
    print('ready', flush=True)
    while not stop:
        executor.spin_once(timeout_sec=0.1)
    kept = min(count, capacity)
    np.savez(out, received_ns=received_ns[:kept], stamp_ns=stamp_ns[:kept], count=count)
    node.destroy_node()
    rclpy.try_shutdown()


# -- the driver ------------------------------------------------------------------------------

def wait_for_line(proc: subprocess.Popen[str], expected: str, timeout: float) -> None:
    """Read the child's stdout until the line ``expected``; raise after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    assert proc.stdout is not None
    while time.monotonic() < deadline:
        ready, _, _ = select.select([proc.stdout], [], [], 0.2)
        if ready:
            line = proc.stdout.readline()
            if line.strip() == expected:
                return
            if not line and proc.poll() is not None:
                break
    raise RuntimeError(f'subscriber did not print {expected!r} within {timeout} s')


def measure(seconds: float, warmup: float, workdir: Path, node: str = 'scara_sim',
            robot: str = 'panda') -> dict[str, Any]:
    """Run the simulator node and the subscriber; return the figures of the window.

    ``robot`` is robot_sim's ``robot`` parameter (ignored for scara_sim).
    """
    env = ros_env({**os.environ, 'PYTHONUNBUFFERED': '1',
                   'RCUTILS_LOGGING_BUFFERED_STREAM': '0'})
    capacity = int((seconds + warmup + 30) * RATE_HZ * 1.2)
    record = workdir / 'received.npz'
    sim_log = workdir / 'sim.log'
    subscriber = subprocess.Popen(
        [sys.executable, __file__, '--subscriber', '--out', str(record),
         '--capacity', str(capacity)],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, text=True, env=env)
    sim = None
    try:
        wait_for_line(subscriber, 'ready', START_TIMEOUT)
        with open(sim_log, 'w') as log:
            robot_args = ['-p', f'robot:={robot}'] if node == 'robot_sim' else []
            sim = subprocess.Popen(
                [sys.executable, '-m', f'scara_ident_ros.nodes.{node}', '--ros-args',
                 '-p', f'rate_hz:={RATE_HZ}', '-p', 'wait_for_subscribers:=1', *robot_args],
                stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT, env=env)
        wait_for_line(subscriber, 'first', START_TIMEOUT)
        time.sleep(warmup)
        t0, cpu0, sub0 = time.monotonic_ns(), cpu_seconds(sim.pid), cpu_seconds(subscriber.pid)
        time.sleep(seconds)
        t1, cpu1, sub1 = time.monotonic_ns(), cpu_seconds(sim.pid), cpu_seconds(subscriber.pid)
        subscriber_status = stop(subscriber)
        sim_status = stop(sim)
    finally:
        kill(subscriber, sim)
    if subscriber_status != 0 or sim_status != 0:
        raise RuntimeError(f'exit status subscriber {subscriber_status}, sim {sim_status}; '
                           f'sim log:\n{sim_log.read_text()}')
    data = np.load(record)
    received, stamps = data['received_ns'], data['stamp_ns']
    in_window = (received >= t0) & (received <= t1)
    gaps_ms = np.diff(received[in_window]) / 1e6
    steps = np.diff(stamps)
    period_ns = round(1e9 / RATE_HZ)
    late = [line for line in sim_log.read_text().splitlines() if 'late by' in line]
    return {
        'window_s': (t1 - t0) / 1e9,
        'rate': in_window.sum() / ((t1 - t0) / 1e9),
        'p50': float(np.percentile(gaps_ms, 50)),
        'p99': float(np.percentile(gaps_ms, 99)),
        'max': float(gaps_ms.max()),
        'received': int(data['count']),
        'missing': int(np.sum(np.maximum(steps // period_ns - 1, 0))),
        'duplicated': int(np.sum(steps <= 0)),
        'sim_cpu': 100.0 * (cpu1 - cpu0) / ((t1 - t0) / 1e9),
        'subscriber_cpu': 100.0 * (sub1 - sub0) / ((t1 - t0) / 1e9),
        'late_line': late[-1].split(']: ', 1)[-1] if late else '(no statistics line)',
    }


def report(r: dict[str, Any]) -> str:
    """The Markdown table of the figures and their targets."""
    def verdict(ok: bool) -> str:
        return 'yes' if ok else '**no**'

    rows = [
        ('messages per second', f"{r['rate']:.1f}", f'>= {TARGET_RATE:g}',
         verdict(r['rate'] >= TARGET_RATE)),
        ('inter-arrival p50 (ms)', f"{r['p50']:.3f}", '', ''),
        ('inter-arrival p99 (ms)', f"{r['p99']:.3f}", f'<= {TARGET_P99_MS:g}',
         verdict(r['p99'] <= TARGET_P99_MS)),
        ('inter-arrival max (ms)', f"{r['max']:.3f}", '', ''),
        ('stamps missing', f"{r['missing']}", '0', verdict(r['missing'] == 0)),
        ('stamps duplicated', f"{r['duplicated']}", '0', verdict(r['duplicated'] == 0)),
        ('sim CPU (% of one core)', f"{r['sim_cpu']:.1f}", f'<= {TARGET_CPU:g}',
         verdict(r['sim_cpu'] <= TARGET_CPU)),
        ('subscriber CPU (% of one core)', f"{r['subscriber_cpu']:.1f}", '', ''),
    ]
    lines = [f"{r['what']} at {RATE_HZ:g} Hz, {r['window_s']:.1f} s window "
             f"({r['received']} messages received in all); load average "
             f"{r['load_before']} before, {r['load_after']} after; {os.cpu_count()} CPUs",
             '', '| figure | measured | target | met |', '| --- | ---: | --- | --- |']
    lines += [f'| {a} | {b} | {c} | {d} |' for a, b, c, d in rows]
    lines += ['', f"sim's own statistics: {r['late_line']}"]
    return '\n'.join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seconds', type=float, default=30.0, help='window length (s)')
    parser.add_argument('--warmup', type=float, default=2.0,
                        help='seconds after the first message before the window opens')
    parser.add_argument('--node', choices=NODES, default='scara_sim',
                        help='simulator node to measure')
    parser.add_argument('--robot', default='panda',
                        help="robot_sim's robot (an example-robot-data arm)")
    parser.add_argument('--subscriber', action='store_true', help=argparse.SUPPRESS)
    parser.add_argument('--out', type=Path, help=argparse.SUPPRESS)
    parser.add_argument('--capacity', type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.subscriber:
        subscribe(args.out, args.capacity)
        return
    load_before = ' '.join(f'{x:.2f}' for x in os.getloadavg())
    with tempfile.TemporaryDirectory() as workdir:
        result = measure(args.seconds, args.warmup, Path(workdir), args.node, args.robot)
    result['what'] = (f'robot_sim (robot {args.robot})' if args.node == 'robot_sim'
                      else args.node)
    result['load_before'] = load_before
    result['load_after'] = ' '.join(f'{x:.2f}' for x in os.getloadavg())
    print(report(result))


if __name__ == '__main__':
    main()
