"""Which way to drive a 1 kHz publisher in rclpy: the measurement behind ``nodes/runtime.py``.

Three ways of publishing a ``sensor_msgs/JointState`` (4 joints, built each time as the
simulator does) every millisecond for ``--seconds`` (default 10), each in a fresh
subprocess, repeated ``--repeats`` times (default 3) in interleaved order:

a. ``timer-spin``: SingleThreadedExecutor, a 1 ms timer, ``executor.spin()``;
b. ``events-timer``: EventsExecutor, a 1 ms timer, a ``spin_once`` loop;
c. ``events-deadline``: a DeadlinePacer loop publishing on absolute deadlines, with
   ``EventsExecutor.spin_once(timeout_sec=0)`` between samples (``scara_sim`` paces the
   same way but spins only every 10 ms: it has no subscription to serve).

Reported per way: the medians of the publisher's CPU (% of one core, process time of all
its threads over the publishing window, start-up excluded) and of the messages published
per second. Nothing subscribes: this is the cost of driving the loop and publishing.

Also checked, each in a subprocess with a time limit (nothing can hang the run): does
``spin()`` of an executor fire a 1 ms timer more than once in 1 s, and does SIGINT stop
it (with rclpy's default signal handling)?

Run from the repository root::

    .venv/bin/python benchmarks/bench_executor.py [--seconds 10] [--repeats 3]

Prints Markdown tables. DDS stays on this machine; the run uses a domain of its own
unless ``ROS_DOMAIN_ID`` is set.
"""
from __future__ import annotations

import argparse
import json
import os
import select
import signal
import statistics
import subprocess
import sys
import threading
import time
from typing import Any

from ros_env import ros_env  # benchmarks/: the script's own folder

WAYS = {
    'timer-spin': 'a. SingleThreadedExecutor + 1 ms timer + spin()',
    'events-timer': 'b. EventsExecutor + 1 ms timer + spin_once loop',
    'events-deadline': 'c. DeadlinePacer loop + EventsExecutor.spin_once(0)',
}
SPIN_CHECKS = ('EventsExecutor', 'SingleThreadedExecutor')
PERIOD = 0.001  # s
TOPIC = 'bench_joint_states'
NAMES = ('joint1', 'joint2', 'joint3', 'joint4')
CHILD_TIMEOUT = 120.0  # s beyond the publishing time before a child is killed


# -- children --------------------------------------------------------------------------------

def publish(way: str, seconds: float) -> None:
    """Publish JointState at 1 kHz the given way for ``seconds``; print a JSON result."""
    import numpy as np
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.experimental import EventsExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from scara_ident_ros.nodes.messages import joint_state
    from scara_ident_ros.nodes.pacer import DeadlinePacer

    rclpy.init()
    node = rclpy.create_node('bench_executor')
    publisher = node.create_publisher(
        JointState, TOPIC, QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
    q = np.array([0.1, -0.2, 0.05, 1.0])
    published = 0

    def publish_one() -> None:
        nonlocal published
        publisher.publish(joint_state(published * 1_000_000, NAMES, position=q, velocity=q,
                                      effort=q))
        published += 1

    class Done(Exception):
        pass

    def finish() -> None:
        raise Done

    executor = SingleThreadedExecutor() if way == 'timer-spin' else EventsExecutor()
    executor.add_node(node)
    t0, cpu0 = time.monotonic(), time.process_time()
    end = t0 + seconds
    if way == 'timer-spin':
        node.create_timer(PERIOD, publish_one)
        node.create_timer(seconds, finish)
        try:
            executor.spin()
        except Done:
            pass
    elif way == 'events-timer':
        node.create_timer(PERIOD, publish_one)
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.1)
    else:
        pacer = DeadlinePacer(round(PERIOD * 1e9))
        while time.monotonic() < end:
            for _ in range(pacer.wait(0.1)):
                publish_one()
            executor.spin_once(timeout_sec=0)
    elapsed, cpu = time.monotonic() - t0, time.process_time() - cpu0
    print(json.dumps({'cpu': 100.0 * cpu / elapsed, 'rate': published / elapsed}), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


def spin_check(executor_name: str) -> None:
    """Spin a 1 ms timer with ``executor.spin()``; a thread prints the fires after 1 s."""
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.experimental import EventsExecutor

    rclpy.init()  # rclpy's default SIGINT handling
    node = rclpy.create_node('spin_check')
    fires = 0

    def on_timer() -> None:
        nonlocal fires
        fires += 1

    def report() -> None:
        time.sleep(1.0)
        print(f'fires {fires}', flush=True)

    node.create_timer(PERIOD, on_timer)
    executor = EventsExecutor() if executor_name == 'EventsExecutor' else SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=report, daemon=True).start()
    try:
        executor.spin()
        print('spin returned', flush=True)
    except (KeyboardInterrupt, ExternalShutdownException) as exc:
        print(f'spin raised {type(exc).__name__}', flush=True)


# -- the driver ------------------------------------------------------------------------------

def child_env() -> dict[str, str]:
    return ros_env()


def run_publisher(way: str, seconds: float) -> dict[str, float]:
    """One publishing run in a subprocess; its JSON result."""
    out = subprocess.run([sys.executable, __file__, '--child', way, '--seconds', str(seconds)],
                         stdin=subprocess.DEVNULL, capture_output=True, text=True,
                         env=child_env(), timeout=seconds + CHILD_TIMEOUT, check=False)
    lines = [line for line in out.stdout.splitlines() if line.startswith('{')]
    if out.returncode != 0 or not lines:
        raise RuntimeError(f'{way} failed ({out.returncode}): {out.stderr}')
    result: dict[str, float] = json.loads(lines[-1])
    return result


def read_line(proc: subprocess.Popen[str], timeout: float) -> str | None:
    """The child's next stdout line, or None if none comes within ``timeout`` s."""
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], timeout)
    return proc.stdout.readline().strip() if ready else None


def run_spin_check(executor_name: str) -> dict[str, Any]:
    """Fires in 1 s and the reaction to SIGINT of ``executor.spin()``, never hanging."""
    proc = subprocess.Popen([sys.executable, __file__, '--spin-check', executor_name],
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True, env=child_env())
    try:
        line = read_line(proc, 30.0)
        fires = int(line.split()[1]) if line and line.startswith('fires') else None
        proc.send_signal(signal.SIGINT)
        sent = time.monotonic()
        try:
            status: int | None = proc.wait(timeout=5.0)
            stop_s: float | None = time.monotonic() - sent
        except subprocess.TimeoutExpired:
            status, stop_s = None, None
        last = read_line(proc, 0.5) if status is not None else None
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
    return {'fires': fires, 'status': status, 'stop_s': stop_s, 'last': last}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seconds', type=float, default=10.0, help='publishing time per run')
    parser.add_argument('--repeats', type=int, default=3)
    parser.add_argument('--child', choices=WAYS, help=argparse.SUPPRESS)
    parser.add_argument('--spin-check', choices=SPIN_CHECKS, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        publish(args.child, args.seconds)
        return
    if args.spin_check:
        spin_check(args.spin_check)
        return

    load_before = ' '.join(f'{x:.2f}' for x in os.getloadavg())
    runs: dict[str, list[dict[str, float]]] = {way: [] for way in WAYS}
    for _ in range(args.repeats):
        for way in WAYS:
            runs[way].append(run_publisher(way, args.seconds))
    checks = {name: run_spin_check(name) for name in SPIN_CHECKS}
    load_after = ' '.join(f'{x:.2f}' for x in os.getloadavg())

    print(f'1 kHz JointState publisher, {args.seconds:g} s per run, medians of '
          f'{args.repeats} runs; load average {load_before} before, {load_after} after; '
          f'{os.cpu_count()} CPUs\n')
    print('| way | CPU (% of one core) | messages/s | CPU of each run |')
    print('| --- | ---: | ---: | --- |')
    for way, label in WAYS.items():
        cpu = [run['cpu'] for run in runs[way]]
        rate = [run['rate'] for run in runs[way]]
        print(f'| {label} | {statistics.median(cpu):.1f} | {statistics.median(rate):.1f} | '
              f'{", ".join(f"{c:.1f}" for c in cpu)} |')
    print('\n| spin() with a 1 ms timer | fires in 1 s | SIGINT stops it | after SIGINT |')
    print('| --- | ---: | --- | --- |')
    for name, check in checks.items():
        stopped = ('no (killed after 5 s)' if check['status'] is None
                   else f"yes, exit {check['status']} in {check['stop_s']:.2f} s")
        fires = 'no report (GIL held?)' if check['fires'] is None else check['fires']
        print(f"| {name}.spin() | {fires} | {stopped} | {check['last'] or '-'} |")


if __name__ == '__main__':
    main()
