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
a smaller run; ``--only 5 7`` for chosen rows). ``--compare A B`` runs each chosen row
with the recorder of checkout A, then of B, ``--repeat`` times (default 5), and prints
median [min-max]; ``--compare A B --writer`` measures the writer alone instead (no DDS;
see :func:`writer_cost`): CPU per message at 4 x 1 kHz and 1 x 50 kHz, and how many
messages a kill would lose. DDS stays on this machine
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) in a domain of its own (``ros_env.py``).

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
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from processes import cpu_seconds, kill  # benchmarks/: the script's own folder
from ros_env import ros_env

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


def _env(domain: int, repo: Path = REPO) -> dict[str, str]:
    env = dict(os.environ)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['ROS_DOMAIN_ID'] = str(domain)
    env['PYTHONPATH'] = str(repo) + os.pathsep + env.get('PYTHONPATH', '')
    return env


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


def run_scenario(scenario: Scenario, workdir: Path, domain: int, repo: Path = REPO) -> Result:
    """Run recorder (from the checkout ``repo``) + publisher for ``scenario``; read the bag."""
    from scara_ident_ros.bag import open_bag

    bag = workdir / f'bag_{domain}_{time.monotonic_ns()}'
    env = _env(domain, repo)
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
        cpu_before = cpu_seconds(recorder.pid)
        out, _ = publisher.communicate(timeout=START_TIMEOUT + scenario.count / 2000 + 60)
        if publisher.returncode != 0 or not out.startswith('published'):
            raise RuntimeError(f'publisher failed ({publisher.returncode}): {out}')
        published_rate = float(out.split()[1])
        time.sleep(0.5)
        cpu = cpu_seconds(recorder.pid) - cpu_before
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
        kill(publisher, recorder)
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


# -- the writer alone (no DDS) -----------------------------------------------------------


def _readable(path: Path) -> int:
    """Messages a reader gets from the file as it is on disk now (up to where it is cut).

    Counted from the message index records that follow each complete chunk (chunks are
    not decompressed: this runs every simulated second on files of tens of MB).
    """
    from mcap.records import MessageIndex
    from mcap.stream_reader import StreamReader

    count = 0
    with path.open('rb') as stream:
        try:
            for record in StreamReader(stream, emit_chunks=True).records:
                if isinstance(record, MessageIndex):
                    count += len(record.records)
        except Exception:  # noqa: BLE001 - the cut: everything before it was counted
            pass
    return count


def writer_cost(topics: int, rate: float, seconds: float, compression: str) -> dict[str, float]:
    """CPU per message of :class:`BagWriter` fed as the recorder feeds it, and what a kill loses.

    ``topics`` topics at ``rate`` messages/s each, 268-byte payloads, in the recorder's
    batches (``GATHER_PERIOD`` of messages below ``SPARSE_RATE``, else ``BATCH_SIZE``),
    ``poll()`` every ``CHUNK_POLL_PERIOD``, on a simulated clock. Every simulated second
    the file is read as it is on disk: ``unflushed`` is the most messages written but not
    yet readable there, ``lost_on_kill`` what is not readable when the writer is dropped
    (SIGKILL) at the end.
    """
    from scara_ident_ros.bag import BagWriter
    from scara_ident_ros.nodes import recorder

    now = [0]
    payload = bytes(268)
    total_rate = topics * rate
    batch_s = (recorder.GATHER_PERIOD if total_rate < recorder.SPARSE_RATE
               else recorder.BATCH_SIZE / total_rate)
    per_batch = max(1, round(rate * batch_s))
    cpu = 0.0
    written = 0
    unflushed = 0
    with tempfile.TemporaryDirectory(prefix='bench_writer_') as tmp:
        writer = BagWriter(Path(tmp) / 'bag', compression=compression,
                           clock=lambda: now[0]).open()
        ids = [writer.add_connection(f'/robot{i}/joint_states', 'sensor_msgs/msg/JointState').id
               for i in range(topics)]
        file = Path(tmp) / 'bag' / writer.file_names[0]
        next_poll = next_check = 0
        for b in range(round(seconds / batch_s)):
            now[0] = round(b * batch_s * 1e9)
            batch = [(i, now[0] + k, payload) for k in range(per_batch) for i in ids]
            started = time.process_time()
            writer.write_batch(batch)
            if now[0] >= next_poll:
                writer.poll()
                next_poll += round(recorder.CHUNK_POLL_PERIOD * 1e9)
            cpu += time.process_time() - started
            written += len(batch)
            if now[0] >= next_check:
                unflushed = max(unflushed, written - _readable(file))
                next_check += 1_000_000_000
        writer.abort()
        lost = written - _readable(file)
    return {'cpu_us_per_msg': cpu / written * 1e6, 'unflushed': unflushed,
            'lost_on_kill': lost}


def compare_writers(repos: list[Path], repeat: int, seconds: float) -> str:
    """:func:`writer_cost` for each checkout, interleaved ``repeat`` times: median [range]."""
    cases = [(4, 1000.0, 'none'), (4, 1000.0, 'zstd'), (1, 50_000.0, 'none'),
             (1, 50_000.0, 'lz4')]
    runs: dict[tuple[int, int], list[dict[str, float]]] = {}
    for _ in range(repeat):
        for c, case in enumerate(cases):
            for r, repo in enumerate(repos):
                out = subprocess.run(
                    [sys.executable, __file__, '--writer-cost', *map(str, case), str(seconds)],
                    env=_env(0, repo), check=True, capture_output=True, text=True).stdout
                runs.setdefault((c, r), []).append(json.loads(out))
    lines = ['| topics x rate | compression | checkout | writer CPU/msg | '
             'most unflushed msgs | lost on kill |', '|---|---|---|---|---|---|']
    for c, (topics, rate, compression) in enumerate(cases):
        for r, repo in enumerate(repos):
            got = runs[(c, r)]
            lines.append(f'| {topics} x {rate:.0f}/s | {compression} | {repo.name} | '
                         + ' | '.join(_spread([g[k] for g in got], fmt)
                                      for k, fmt in (('cpu_us_per_msg', '{:.2f} µs'),
                                                     ('unflushed', '{:.0f}'),
                                                     ('lost_on_kill', '{:.0f}'))) + ' |')
    return '\n'.join(lines)


def _spread(values: list[float], fmt: str) -> str:
    """Median and range: ``1.2 µs [1.1-1.4]``."""
    low, high = min(values), max(values)
    text = fmt.format(statistics.median(values))
    return text if low == high else f'{text} [{fmt.format(low).split()[0]}-{fmt.format(high)}]'


def compare_recorders(repos: list[Path], chosen: list[Scenario], repeat: int,
                      workdir: Path, domain: int) -> str:
    """Each scenario with the recorder of each checkout, interleaved: median [range]."""
    runs: dict[tuple[int, int], list[Result]] = {}
    for _ in range(repeat):
        for s, scenario in enumerate(chosen):
            for r, repo in enumerate(repos):
                result = run_scenario(scenario, workdir, domain, repo)
                runs.setdefault((s, r), []).append(result)
                print(f'{repo.name}: {table([result]).splitlines()[-1]}', file=sys.stderr,
                      flush=True)
    lines = ['| N | pub rate (target) | compression | checkout | missing | recorder rate | '
             'recorder CPU/msg |', '|---|---|---|---|---|---|---|']
    for s, scenario in enumerate(chosen):
        for r, repo in enumerate(repos):
            got = runs[(s, r)]
            rate = 'burst' if not scenario.rate else f'{scenario.rate:.0f}/s'
            lines.append(
                f'| {scenario.count} | {rate} | {scenario.compression} | {repo.name} | '
                f'{_spread([g.missing for g in got], "{:.0f}")} | '
                f'{_spread([g.recorded_rate for g in got], "{:.0f}/s")} | '
                f'{_spread([g.cpu_us_per_msg for g in got], "{:.1f} µs")} |')
    return '\n'.join(lines)


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
    parser.add_argument('--compare', type=Path, nargs='+', metavar='CHECKOUT',
                        help='run the recorder of each of these checkouts in turn '
                             '(e.g. this one and a `git worktree` of the base)')
    parser.add_argument('--repeat', type=int, default=5, help='runs per checkout (--compare)')
    parser.add_argument('--writer', action='store_true',
                        help='with --compare: the writer alone, no DDS (writer_cost)')
    parser.add_argument('--publisher', nargs=3, metavar=('COUNT', 'RATE', 'DEPTH'),
                        help=argparse.SUPPRESS)
    parser.add_argument('--writer-cost', nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.publisher:
        run_publisher(int(args.publisher[0]), float(args.publisher[1]),
                      int(args.publisher[2]))
        return 0
    if args.writer_cost:
        topics, rate, compression, seconds = args.writer_cost
        print(json.dumps(writer_cost(int(topics), float(rate), float(seconds), compression)))
        return 0
    if args.compare and args.writer:
        print(compare_writers([p.resolve() for p in args.compare], args.repeat, 10.0))
        return 0
    domain = int(ros_env()['ROS_DOMAIN_ID'])
    results = []
    with tempfile.TemporaryDirectory(prefix='bench_recorder_') as tmp:
        chosen = scenarios(args.quick)
        if args.only:
            chosen = [chosen[i] for i in args.only]
        if args.compare:
            print(compare_recorders([p.resolve() for p in args.compare], chosen, args.repeat,
                                    Path(tmp), domain))
            return 0
        for scenario in chosen:
            result = run_scenario(scenario, Path(tmp), domain)
            results.append(result)
            print(table([result]).splitlines()[-1], file=sys.stderr, flush=True)  # progress
    print(table(results))
    return 0


if __name__ == '__main__':
    sys.exit(main())
