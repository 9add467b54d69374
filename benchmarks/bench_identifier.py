"""Throughput and latency of the ``identifier`` node (FFS 12-40-4 learning), over real DDS.

a. **Throughput.** The identifier runs as its own process; this script is the publisher:
   ``--samples`` (default 20000) ``JointState`` samples precomputed from the simulator core
   (stamps 1 ms apart), serialised once and published as fast as the identifier takes them,
   in ``--rounds`` (default 3) rounds. No sample may be lost: the publisher keeps at most
   :data:`IN_FLIGHT` samples unanswered (the node's subscription keeps the last 5000), counting
   the answers on ``identified_torque`` (a raw subscription, nothing deserialised). Rate of a
   round = samples / (first publish → last answer). At the end the node's ``stats_file``
   must show processed == sent and nothing skipped but the warm-up sample.
b. **Latency at 1 kHz.** ``scara_sim`` (real time, 1 kHz) → identifier; this script is a
   probe subscribing to ``joint_states`` and ``identified_torque`` (raw) and recording the
   receive time of each. Latency of a sample = receive time of its prediction − receive time
   of the joint state with the same stamp; p50 / p99 / max over ``--seconds`` (default 20)
   after ``--warmup`` (default 2) seconds.

Both report the identifier's CPU (% of one core: utime + stime from ``/proc/<pid>/stat`` over
the measured window). Run from the repository root::

    .venv/bin/python benchmarks/bench_identifier.py [--samples 20000] [--seconds 20]
        [--only throughput|latency] [--profile identifier.prof]

DDS stays on this machine (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``); the run uses a
domain of its own unless ``ROS_DOMAIN_ID`` is set. Prints Markdown tables with the targets.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import numpy as np

from processes import STOP_TIMEOUT, cpu_seconds, kill, stop  # benchmarks/: the script's own folder
from ros_env import ros_env

IDENTIFIER = 'scara_ident_ros.nodes.identifier'
SCARA_SIM = 'scara_ident_ros.nodes.scara_sim'
JOINT_STATES_TOPIC = '/joint_states'
TORQUE_TOPIC = '/identified_torque'
NAMES = ('joint1', 'joint2', 'joint3', 'joint4')
PERIOD_NS = 1_000_000  # 1 kHz
T0_NS = 1_000_000_000_000  # stamp of the first sample of the throughput run (1000 s)
IN_FLIGHT = 2000  # samples published but not yet answered, at most (node queue: 5000)
BURST = 100  # samples published between two looks at the answers
TARGET_RATE = 5000.0  # samples/s processed, at least
#: latency p99, at most: the zero-phase q'' waits LAG samples (10 ms) by design; issue 18's
#: bound on a prediction's lag
TARGET_P99_MS = 50.0
START_TIMEOUT = 60.0  # s for discovery, the machine is shared
STALL_TIMEOUT = 30.0  # s without an answer before a run is declared stuck
LAG = 21 // 2  # samples by which the default centred q'' (window 21) answers a sample


# -- processes -------------------------------------------------------------------------------

def node_env() -> dict[str, str]:
    env = {**os.environ, 'PYTHONUNBUFFERED': '1', 'RCUTILS_LOGGING_BUFFERED_STREAM': '0'}
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = env.get('ROS_AUTOMATIC_DISCOVERY_RANGE',
                                                   'LOCALHOST')
    return env


def start(module: str, params: list[str], log: IO[str],
          profile: Path | None = None) -> subprocess.Popen[str]:
    """``python -m module --ros-args -p ...``, output to ``log``; under cProfile if asked."""
    python = [sys.executable] + (['-m', 'cProfile', '-o', str(profile)] if profile else [])
    args = [*python, '-m', module, '--ros-args']
    for param in params:
        args += ['-p', param]
    return subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=log,
                            stderr=subprocess.STDOUT, env=node_env(), text=True)


def tail(path: str | Path, lines: int = 20) -> str:
    """The last ``lines`` lines of a log file."""
    return '\n'.join(Path(path).read_text(errors='replace').splitlines()[-lines:])


def stamp_of(data: bytes) -> int:
    """header.stamp (ns) of a serialised message that starts with a std_msgs/Header."""
    sec, nanosec = struct.unpack_from('<iI', data, 4)  # after the 4-byte CDR header
    return sec * 1_000_000_000 + nanosec


class Probe:
    """This process's rclpy: a fresh Context, one node, an EventsExecutor."""

    def __init__(self, name: str) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.experimental import EventsExecutor
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = EventsExecutor(context=self.context)
        self.executor.add_node(self.node)

    def spin_until(self, done: Callable[[], bool], timeout: float, what: str) -> None:
        deadline = time.monotonic() + timeout
        while not done():
            if time.monotonic() > deadline:
                raise RuntimeError(f'{what}: not within {timeout} s')
            self.executor.spin_once(timeout_sec=0.01)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()


def reliable(depth: int) -> Any:
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    return QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)


# -- a. throughput ---------------------------------------------------------------------------

def serialised_samples(n: int) -> list[bytes]:
    """``n`` simulated samples as serialised JointState, stamps T0 + k ms."""
    from rclpy.serialization import serialize_message

    from scara_ident_ros.dynamics import ScaraParams
    from scara_ident_ros.nodes.messages import joint_state
    from scara_ident_ros.resources import config_path
    from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory

    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    record = Simulator(params, make_trajectory('standard', params, seed=0),
                       SimConfig()).simulate(n)
    return [serialize_message(joint_state(T0_NS + k * PERIOD_NS, NAMES, position=record.q[k],
                                          velocity=record.qd[k], effort=record.effort[k]))
            for k in range(n)]


def throughput(samples: int, rounds: int, workdir: Path,
               profile: Path | None = None) -> dict[str, Any]:
    """Publish ``rounds`` × ``samples`` samples without loss; return the rates and checks."""
    from sensor_msgs.msg import JointState

    data = serialised_samples(samples * rounds)
    stats_file = workdir / 'throughput_stats.json'
    answered = 0

    def on_torque(msg: bytes) -> None:
        nonlocal answered
        answered += 1

    probe = Probe('bench_identifier_publisher')
    publisher = probe.node.create_publisher(JointState, JOINT_STATES_TOPIC, reliable(5000))
    subscription = probe.node.create_subscription(JointState, TORQUE_TOPIC, on_torque,
                                                  reliable(5000), raw=True)
    log = open(workdir / 'throughput_identifier.log', 'w')
    node = start(IDENTIFIER, [f'stats_file:={stats_file}'], log, profile)
    rates, cpus, cpu_per_sample, own_cpus = [], [], [], []
    try:
        probe.spin_until(lambda: (publisher.get_subscription_count() >= 1
                                  and subscription.get_publisher_count() >= 1),
                         START_TIMEOUT, 'identifier discovered')
        spin_for(probe, 0.5)  # let the node's side of discovery settle too
        sent = 0
        for _ in range(rounds):
            end = sent + samples
            first_answer = answered
            t0, cpu0, own0 = time.monotonic(), cpu_seconds(node.pid), time.process_time()
            last_progress, last_answered = t0, answered
            # the zero-phase q'' answers a sample LAG samples later: the last LAG of a round
            # come with the next round's first samples, or on stop
            while answered < end - LAG:
                while sent < end and sent - answered <= IN_FLIGHT - BURST:
                    for blob in data[sent:sent + BURST]:
                        publisher.publish(blob)
                    sent = min(sent + BURST, end)
                probe.executor.spin_once(timeout_sec=0.001)
                now = time.monotonic()
                if answered != last_answered:
                    last_progress, last_answered = now, answered
                elif now - last_progress > STALL_TIMEOUT or node.poll() is not None:
                    log.flush()
                    raise RuntimeError(f'stuck at {answered} answers of {end - 1} sent; '
                                       f'identifier log:\n{tail(log.name)}')
            t1, cpu1, own1 = time.monotonic(), cpu_seconds(node.pid), time.process_time()
            rates.append((answered - first_answer) / (t1 - t0))
            cpus.append(100.0 * (cpu1 - cpu0) / (t1 - t0))
            cpu_per_sample.append(1e6 * (cpu1 - cpu0) / (answered - first_answer))
            own_cpus.append(100.0 * (own1 - own0) / (t1 - t0))
        # the last LAG predictions come on stop: take them while the node ends
        node.send_signal(signal.SIGINT)
        deadline = time.monotonic() + STOP_TIMEOUT
        while node.poll() is None and time.monotonic() < deadline:
            probe.executor.spin_once(timeout_sec=0.01)
        spin_for(probe, 0.2)
        status = stop(node)
    finally:
        kill(node)
        log.close()
        probe.close()
    info = json.loads(stats_file.read_text()) if stats_file.exists() else {}
    return {'rates': rates, 'cpus': cpus, 'cpu_per_sample': cpu_per_sample, 'own': own_cpus,
            'sent': samples * rounds, 'status': status,
            'processed': info.get('processed'), 'skipped': info.get('skipped'),
            'learnt': info.get('learnt'), 'answered': answered,
            'updates': info.get('updates'),
            'validation_nmse_total': info.get('validation_nmse_total')}


# -- b. latency at 1 kHz ---------------------------------------------------------------------

def latency(seconds: float, warmup: float, workdir: Path) -> dict[str, Any]:
    """scara_sim at 1 kHz → identifier; the probe's receive times → latency figures."""
    from sensor_msgs.msg import JointState

    capacity = int((seconds + warmup + START_TIMEOUT) * 1000 * 1.2)
    received = {name: (np.zeros(capacity, np.int64), np.zeros(capacity, np.int64))
                for name in ('states', 'torques')}
    counts = {'states': 0, 'torques': 0}

    def recorder(name: str) -> Callable[[bytes], None]:
        times, stamps = received[name]

        def on_message(data: bytes) -> None:
            i = counts[name]
            if i < capacity:
                times[i] = time.time_ns()  # the wall clock, like scara_sim's stamps
                stamps[i] = stamp_of(data)
            counts[name] = i + 1
        return on_message

    probe = Probe('bench_identifier_probe')
    probe.node.create_subscription(JointState, JOINT_STATES_TOPIC, recorder('states'),
                                   reliable(1000), raw=True)
    torque_sub = probe.node.create_subscription(JointState, TORQUE_TOPIC, recorder('torques'),
                                                reliable(1000), raw=True)
    stats_file = workdir / 'latency_stats.json'
    id_log = open(workdir / 'latency_identifier.log', 'w')
    sim_log = open(workdir / 'latency_sim.log', 'w')
    node = start(IDENTIFIER, [f'stats_file:={stats_file}'], id_log)
    sim = None
    try:
        probe.spin_until(lambda: torque_sub.get_publisher_count() >= 1, START_TIMEOUT,
                         'identifier discovered')
        sim = start(SCARA_SIM, ['rate_hz:=1000.0', 'wait_for_subscribers:=2',
                                f'wait_timeout:={START_TIMEOUT}'], sim_log)
        probe.spin_until(lambda: counts['torques'] > 0, START_TIMEOUT, 'first prediction')
        spin_for(probe, warmup)
        t0, cpu0 = time.time_ns(), cpu_seconds(node.pid)
        spin_for(probe, seconds)
        t1, cpu1 = time.time_ns(), cpu_seconds(node.pid)
        spin_for(probe, 0.5)  # the window's last predictions, received as they come
        sim_status = stop(sim)
        status = stop(node)
    except RuntimeError as exc:
        id_log.flush()
        sim_log.flush()
        raise RuntimeError(f'{exc}\nidentifier log:\n{tail(id_log.name)}\nsim log:\n'
                           f'{tail(sim_log.name)}') from None
    finally:
        kill(sim, node)
        id_log.close()
        sim_log.close()
        probe.close()
    if counts['states'] > capacity:
        raise RuntimeError('probe capacity exceeded')
    s_times, s_stamps = (a[:counts['states']] for a in received['states'])
    t_times, t_stamps = (a[:counts['torques']] for a in received['torques'])
    window = (s_times >= t0) & (s_times <= t1)
    state_at = dict(zip(s_stamps[window].tolist(), s_times[window].tolist()))
    torque_at = dict(zip(t_stamps.tolist(), t_times.tolist()))
    matched = [torque_at[stamp] - time_ for stamp, time_ in state_at.items()
               if stamp in torque_at]
    lat_ms = np.array(matched) / 1e6
    # How late the samples themselves came: the sim's pacing and DDS, not the identifier.
    arrival_ms = (s_times[window] - s_stamps[window]) / 1e6
    sim_lines = [line.split(']: ', 1)[-1] for line in Path(sim_log.name).read_text(
        errors='replace').splitlines() if 'late by' in line]
    info = json.loads(stats_file.read_text()) if stats_file.exists() else {}
    return {
        'window_s': (t1 - t0) / 1e9, 'states': len(state_at), 'matched': len(matched),
        'p50': float(np.percentile(lat_ms, 50)), 'p99': float(np.percentile(lat_ms, 99)),
        'max': float(lat_ms.max()), 'cpu': 100.0 * (cpu1 - cpu0) / ((t1 - t0) / 1e9),
        'status': status, 'sim_status': sim_status, 'skipped': info.get('skipped'),
        'worst_lag_ms': info.get('worst_lag_ms'),
        'arrival_p99': float(np.percentile(arrival_ms, 99)), 'arrival_max': float(
            arrival_ms.max()), 'sim_line': sim_lines[-1] if sim_lines else '(none)',
    }


def spin_for(probe: Probe, seconds: float) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        probe.executor.spin_once(timeout_sec=0.01)


# -- report ----------------------------------------------------------------------------------

def verdict(ok: bool) -> str:
    return 'yes' if ok else '**no**'


def report_throughput(r: dict[str, Any]) -> str:
    median = statistics.median(r['rates'])
    cpu_us = statistics.median(r['cpu_per_sample'])
    lost = r['sent'] - (r['processed'] or 0)
    clean = not r['skipped']  # the centred q'' predicts every sample, the first too
    rows = [
        ('samples/s processed, median of rounds', f'{median:,.0f}', f'>= {TARGET_RATE:,.0f}',
         verdict(median >= TARGET_RATE)),
        ('samples/s per round', ', '.join(f'{x:,.0f}' for x in r['rates']), '', ''),
        ('identifier CPU per round (% of one core)',
         ', '.join(f'{x:.0f}' for x in r['cpus']), '', ''),
        ('identifier CPU per sample (µs), median', f'{cpu_us:.0f}',
         f'<= {1e6 / TARGET_RATE:.0f} (the target on a free core)',
         verdict(cpu_us <= 1e6 / TARGET_RATE)),
        ('publisher (this process) CPU per round (% of one core)',
         ', '.join(f'{x:.0f}' for x in r['own']), '', ''),
        ('sent / processed (stats_file)', f"{r['sent']} / {r['processed']}", 'equal',
         verdict(lost == 0)),
        ('skipped (stats_file)', f"{r['skipped']}", '{}', verdict(clean)),
        ('answers (predictions received)', f"{r['answered']}", f"{r['sent']}",
         verdict(r['answered'] == r['sent'])),
        ('lm updates taken beside the stream (stats_file)', f"{r['updates']}", '', ''),
        ('validation NMSE at the end', f"{r['validation_nmse_total']}", '', ''),
        ('exit status on SIGINT', f"{r['status']}", '0', verdict(r['status'] == 0)),
    ]
    return table(f"a. Throughput, FFS 12-40-4 learning (lm beside the stream), "
                 f"{len(r['rates'])} rounds of "
                 f"{r['sent'] // len(r['rates'])} samples", rows)


def report_latency(r: dict[str, Any]) -> str:
    rows = [
        ('latency p50 (ms)', f"{r['p50']:.3f}", '', ''),
        ('latency p99 (ms)', f"{r['p99']:.3f}", f'<= {TARGET_P99_MS:g}',
         verdict(r['p99'] <= TARGET_P99_MS)),
        ('latency max (ms)', f"{r['max']:.3f}", '', ''),
        ('joint states in window / answered', f"{r['states']} / {r['matched']}", 'equal',
         verdict(r['states'] == r['matched'])),
        ('identifier CPU (% of one core)', f"{r['cpu']:.1f}", '', ''),
        ('skipped (stats_file)', f"{r['skipped']}", '{}', verdict(not r['skipped'])),
        ("node's own worst lag, wall clock − stamp (ms)", f"{r['worst_lag_ms']:.2f}", '', ''),
        ('joint states at the probe, arrival − stamp p99 / max (ms)',
         f"{r['arrival_p99']:.3f} / {r['arrival_max']:.3f}", '', ''),
        ('exit status sim / identifier', f"{r['sim_status']} / {r['status']}", '0 / 0',
         verdict(r['sim_status'] == 0 and r['status'] == 0)),
    ]
    return (table(f"b. Latency at 1 kHz, scara_sim → identifier, {r['window_s']:.1f} s window",
                  rows) + f"\n\nscara_sim's own statistics: {r['sim_line']}")


def table(title: str, rows: list[tuple[str, str, str, str]]) -> str:
    lines = [title, '', '| figure | measured | target | met |', '| --- | ---: | --- | --- |']
    lines += [f'| {a} | {b} | {c} | {d} |' for a, b, c, d in rows]
    return '\n'.join(lines)


def load() -> str:
    return ' '.join(f'{x:.2f}' for x in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--samples', type=int, default=20_000, help='samples per round (a)')
    parser.add_argument('--rounds', type=int, default=3, help='rounds of the throughput run')
    parser.add_argument('--seconds', type=float, default=20.0, help='latency window (s) (b)')
    parser.add_argument('--warmup', type=float, default=2.0,
                        help='seconds of 1 kHz before the latency window opens')
    parser.add_argument('--only', choices=('throughput', 'latency'), help='run one part')
    parser.add_argument('--profile', type=Path, metavar='FILE',
                        help='run the throughput identifier under cProfile, stats to FILE')
    args = parser.parse_args()
    os.environ.update(ros_env())
    print(f'{os.cpu_count()} CPUs; load average {load()} at start\n')
    with tempfile.TemporaryDirectory() as workdir:
        if args.only != 'latency':
            result = throughput(args.samples, args.rounds, Path(workdir), args.profile)
            print(report_throughput(result), f'\nload average {load()}\n', sep='\n',
                  flush=True)
        if args.only != 'throughput':
            result = latency(args.seconds, args.warmup, Path(workdir))
            print(report_latency(result), f'\nload average {load()}', sep='\n', flush=True)


if __name__ == '__main__':
    main()
