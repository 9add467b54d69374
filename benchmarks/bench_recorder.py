"""How many JointState messages per second the recorder writes to its bag without losing any.

Each scenario runs the real ``recorder`` node (``python -m scara_ident_ros.nodes.recorder``)
and a publisher process (this file with ``--publisher``) that sends N pre-serialized
6-joint JointState messages (``Publisher.publish(bytes)``: publishing costs the publisher
as little as possible) either in a burst (as fast as it can) or paced at a given rate.
The publisher waits until the recorder's subscription is matched, publishes, waits until
every message is acknowledged (``wait_for_all_acked``), then the recorder is stopped with
SIGINT and the bag is read back: how many messages landed, whether any are missing or
out of order (each message carries its index in ``header.stamp``), the recorder's
throughput (messages / span of their reception times) and its CPU time per message.

Loss has two possible causes, told apart by the columns: the recorder not keeping up
(its DDS reader history overflows, or it is too slow to acknowledge), and the publisher's
own history: a KEEP_LAST writer of depth D drops a message it has not yet delivered as
soon as D newer ones are queued, whatever the reader does. ``pub depth`` = N (or 0, keep
all) removes the second cause: then every loss is the recorder's.

Run: ``.venv/bin/python benchmarks/bench_recorder.py`` (about 2 minutes; ``--quick`` for
a smaller run; ``--only 5 7`` for chosen rows). DDS stays on this machine
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) in a domain derived from the process id.

Measured on the shared 2-core machine of this project while it was otherwise quiet
(6-joint JointState, 268 bytes; recorder defaults unless stated)::

    N       publisher            pub depth  rec depth  recorded  missing  recorder rate  CPU/msg
    5000    1 kHz                1000       keep all   5000      0          1000/s       64 µs
    30000   10 kHz               1000       keep all   30000     0         10000/s       27 µs
    60000   20 kHz               1000       keep all   60000     0         20000/s       20 µs
    90000   30 kHz               1000       keep all   90000     0         30000/s       30 µs
    100000  40 kHz               1000       keep all   100000    0         40000/s       21 µs
    100000  50 kHz               1000       keep all   100000    0         50000/s       20 µs
    100000  50 kHz               1000       10000      88644     11356     44300/s       22 µs
    100000  burst (80k/s)        1000       keep all   96340     3660      76800/s       14 µs
    100000  burst (75k/s)        1000       10000      89750     10250     66100/s       16 µs
    100000  burst (18k/s)        100000     keep all   100000    0         16300/s       19 µs
    100000  burst (18k/s, zstd)  100000     keep all   100000    0         15600/s       19 µs

Zero loss up to 40 kHz every time; at 50 kHz zero loss in this run, 2-5 % lost in
other runs (and more when other work shares the cores): at that rate the publisher
and the recorder need a core each. A burst from a publisher with a 1000-message history
outruns the recorder (~70-77k/s taken) and loses the messages its writer drops; a
publisher whose history holds the burst loses nothing but then publishes only ~20k/s
(Fast DDS's reliability bookkeeping on a 100,000-sample history). Keep-all and a
10,000 history were within run-to-run noise of each other in other runs.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import struct
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TOPIC = '/joint_states'
JOINTS = 6
START_TIMEOUT = 30.0  # s for the recorder to come up and match


@dataclass(frozen=True)
class Scenario:
    """One run: N messages, burst (rate 0) or paced, publisher and recorder history depths."""

    count: int
    rate: float  # messages/s; 0 = burst
    pub_depth: int  # 0 = keep all
    rec_depth: int  # recorder qos_depth; 0 = keep all
    compression: str = 'none'


@dataclass(frozen=True)
class Result:
    scenario: Scenario
    published_rate: float  # msgs/s the publisher achieved
    recorded: int
    missing: int
    out_of_order: int
    recorded_rate: float  # msgs/s over the span of reception times
    cpu_us_per_msg: float  # recorder process CPU (all threads) per recorded message
    received: int  # what rclpy handed the recorder (its stats_file)


def _env(domain: int) -> dict[str, str]:
    env = dict(os.environ)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['ROS_DOMAIN_ID'] = str(domain)
    env['PYTHONPATH'] = str(REPO) + os.pathsep + env.get('PYTHONPATH', '')
    return env


def _cpu_seconds(pid: int) -> float:
    with open(f'/proc/{pid}/stat') as stat:
        fields = stat.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


# -- publisher process -----------------------------------------------------------------


def run_publisher(count: int, rate: float, depth: int) -> None:
    """Publish ``count`` JointStates (index in header.stamp), then wait for all acks."""
    import rclpy
    from rclpy.duration import Duration
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    rclpy.init()
    node = rclpy.create_node('bench_publisher')
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST if depth else HistoryPolicy.KEEP_ALL,
                     depth=depth or 1, reliability=ReliabilityPolicy.RELIABLE)
    publisher = node.create_publisher(JointState, TOPIC, qos)
    msg = JointState()
    msg.name = [f'joint{i + 1}' for i in range(JOINTS)]
    msg.position = [0.1] * JOINTS
    msg.velocity = [0.2] * JOINTS
    msg.effort = [0.3] * JOINTS
    payloads = []
    for i in range(count):
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(i, 1_000_000_000)
        payloads.append(bytes(serialize_message(msg)))
    deadline = time.monotonic() + START_TIMEOUT
    while publisher.get_subscription_count() == 0:
        if time.monotonic() > deadline:
            print('no subscriber', flush=True)
            sys.exit(3)
        time.sleep(0.01)
    time.sleep(0.5)  # let the reader side finish matching too
    period = 1.0 / rate if rate else 0.0
    started = time.perf_counter()
    for i, payload in enumerate(payloads):
        if period:  # sleep (never spin) until due: a late wake-up publishes a short burst
            left = started + i * period - time.perf_counter()
            if left > 0:
                time.sleep(left)
        while True:
            try:
                publisher.publish(payload)
                break
            except Exception:  # noqa: BLE001 - keep-all writer full: back off, retry
                time.sleep(0.0005)
    elapsed = time.perf_counter() - started
    publisher.wait_for_all_acked(Duration(seconds=30))
    print(f'published {count / elapsed:.0f}', flush=True)
    node.destroy_node()
    rclpy.shutdown()


# -- one scenario ----------------------------------------------------------------------


def run_scenario(scenario: Scenario, workdir: Path, domain: int) -> Result:
    """Run recorder + publisher for ``scenario`` and read the bag back."""
    from scara_ident_ros.bag import open_bag

    bag = workdir / f'bag_{domain}_{time.monotonic_ns()}'
    env = _env(domain)
    recorder = subprocess.Popen(
        [sys.executable, '-m', 'scara_ident_ros.nodes.recorder', '--ros-args',
         '-p', f'output:={bag}', '-p', f'qos_depth:={scenario.rec_depth}',
         '-p', f'compression:={scenario.compression}', '-p', 'discovery_period:=0.2',
         '-p', 'report_period:=0.0', '-p', f'stats_file:={bag}.json', '--log-level', 'warn'],
        env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE, text=True)
    publisher = None
    try:
        time.sleep(1.0)
        publisher = subprocess.Popen(
            [sys.executable, __file__, '--publisher', str(scenario.count), str(scenario.rate),
             str(scenario.pub_depth)], env=env, stdout=subprocess.PIPE, text=True)
        cpu_before = _cpu_seconds(recorder.pid)
        out, _ = publisher.communicate(timeout=START_TIMEOUT + scenario.count / 2000 + 60)
        if publisher.returncode != 0 or not out.startswith('published'):
            raise RuntimeError(f'publisher failed ({publisher.returncode}): {out}')
        published_rate = float(out.split()[1])
        time.sleep(0.5)
        cpu = _cpu_seconds(recorder.pid) - cpu_before
        recorder.send_signal(signal.SIGINT)
        try:
            _, err = recorder.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            recorder.send_signal(signal.SIGABRT)  # faulthandler prints every thread's stack
            _, err = recorder.communicate(timeout=30)
            raise RuntimeError(f'recorder did not stop on SIGINT: {err[-4000:]}') from None
        if recorder.returncode != 0:
            raise RuntimeError(f'recorder failed ({recorder.returncode}): {err}')
    finally:
        for process in (publisher, recorder):
            if process is not None and process.poll() is None:
                process.kill()
                process.wait()
    received = json.loads(Path(f'{bag}.json').read_text())['received']
    indices = []
    times = []
    with open_bag(bag) as source:
        for message in source.messages([TOPIC]) if TOPIC in source.topics else ():
            sec, nanosec = struct.unpack_from('<iI', message.data, 4)
            indices.append(sec * 1_000_000_000 + nanosec)
            times.append(message.log_time_ns)
    out_of_order = sum(1 for a, b in zip(indices, indices[1:]) if b < a)
    span = (times[-1] - times[0]) / 1e9 if len(times) > 1 else 0.0
    return Result(scenario, published_rate, len(indices), scenario.count - len(set(indices)),
                  out_of_order, len(times) / span if span else 0.0,
                  cpu / max(len(indices), 1) * 1e6, received)


def table(results: list[Result]) -> str:
    """The results as a Markdown table."""
    lines = ['| N | pub rate (target) | pub rate (reached) | pub depth | rec qos_depth | '
             'compression | recorded | missing | out of order | recorder rate | '
             'recorder CPU/msg | received by recorder |',
             '|---|---|---|---|---|---|---|---|---|---|---|---|']
    for r in results:
        s = r.scenario
        lines.append(
            f'| {s.count} | {"burst" if not s.rate else f"{s.rate:.0f}/s"} | '
            f'{r.published_rate:.0f}/s | {s.pub_depth or "keep all"} | '
            f'{s.rec_depth or "keep all"} | {s.compression} | {r.recorded} | {r.missing} | '
            f'{r.out_of_order} | {r.recorded_rate:.0f}/s | {r.cpu_us_per_msg:.1f} µs | '
            f'{r.received} |')
    return '\n'.join(lines)


def scenarios(quick: bool) -> list[Scenario]:
    """The default set: paced rates, then bursts with shallow and deep publisher history."""
    n = 20_000 if quick else 100_000
    result = [Scenario(5_000, 1_000, 1000, 0)]  # recorder defaults: keep all
    for rate in (10_000, 20_000, 30_000, 40_000, 50_000):
        result.append(Scenario(min(n, rate * 3), rate, 1000, 0))
    result.append(Scenario(n, 50_000, 1000, 10000))
    result += [Scenario(n, 0, 1000, 0), Scenario(n, 0, 1000, 10000),
               Scenario(n, 0, n, 0), Scenario(n, 0, n, 10000),
               Scenario(n, 0, n, 0, 'zstd'), Scenario(n, 0, n, 0, 'lz4')]
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='20,000-message bursts')
    parser.add_argument('--only', type=int, nargs='+', metavar='I',
                        help='run only these scenarios (0-based numbers)')
    parser.add_argument('--publisher', nargs=3, metavar=('COUNT', 'RATE', 'DEPTH'),
                        help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.publisher:
        run_publisher(int(args.publisher[0]), float(args.publisher[1]),
                      int(args.publisher[2]))
        return 0
    domain = 100 + os.getpid() % 100
    results = []
    with tempfile.TemporaryDirectory(prefix='bench_recorder_') as tmp:
        chosen = scenarios(args.quick)
        if args.only:
            chosen = [chosen[i] for i in args.only]
        for scenario in chosen:
            result = run_scenario(scenario, Path(tmp), domain)
            results.append(result)
            print(table([result]).splitlines()[-1], file=sys.stderr, flush=True)  # progress
    print(table(results))
    return 0


if __name__ == '__main__':
    sys.exit(main())
