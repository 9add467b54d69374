"""The lag a separate subscriber sees: the demo's graph, and ``scara-ident lag`` beside it.

Each run starts ``scara-ident run --duration SECONDS --no-report`` (simulator at 1 kHz, one
identifier serving FFMW, FFW and FFS with a learner process each, recorder) and, once the
identifier has subscribed ``/joint_states`` (so that the simulator's wait for its two
subscribers is not met by this one), ``scara-ident lag`` on ``/joint_states`` and
``/ffs/identified_torque`` in a process of its own (raw subscriptions, garbage collector
off). When the graph has ended, the subscriber is stopped and reports, per topic, receipt
minus the sample's stamp after its first second: p50 / p99 / p99.9 / max, and the windows of
5 s with most samples above the p99. From the run's summary: samples lost before the
identifier and not recorded.

With ``--before DIR`` (a checkout of an earlier commit, e.g. ``git archive``), each run is
a pair side by side: that code's graph (its processes import the package from DIR), then
this commit's, measured by this commit's subscriber.

Usage: ``python benchmarks/bench_subscriber_lag.py [--seconds 60] [--runs 3] [--hogs 0]
[--before DIR] [--label TEXT]``; appends a section to ``benchmarks/subscriber_lag.md``
(``--no-write``: print only). Targets (issue 35): prediction p99 <= 50 ms and max <= 200 ms,
``/joint_states`` p99 <= 20 ms, 0 lost; beside two ``yes`` hogs p99 <= 100 ms.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from processes import cpu_seconds  # benchmarks/: the script's own folder
from ros_env import ros_env

HERE = Path(__file__).resolve().parent
OUTPUT = HERE / 'subscriber_lag.md'
TOPICS = ['/joint_states', '/ffs/identified_torque']
SUBSCRIBED = ' identifier on '  # the identifier's log line once it has subscribed
START_TIMEOUT = 120.0  # s for the graph to start


def _commit() -> str:
    try:
        return subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=HERE,
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return '?'


def one_run(seconds: float, env: dict[str, str], code: Path | None = None
            ) -> dict[str, Any]:
    """One graph with the subscriber beside it: its figures and the run's losses. With
    ``code``, the graph's processes import the package from that checkout."""
    out = Path(tempfile.mkdtemp(prefix='bench_subscriber_lag_'))
    exe = Path(sys.executable).with_name('scara-ident')
    graph_env = env if code is None else {**env, 'PYTHONPATH': str(code)}
    graph = subprocess.Popen([str(exe), 'run', '--duration', str(seconds), '--no-report',
                              '--out', str(out / 'run')], env=graph_env,
                             stdout=subprocess.DEVNULL)
    lag = None
    try:
        log = out / 'run' / 'logs' / 'identifier.log'
        deadline = time.monotonic() + START_TIMEOUT
        while graph.poll() is None and time.monotonic() < deadline:
            if log.exists() and SUBSCRIBED in log.read_text(errors='replace'):
                break
            time.sleep(0.05)
        lag = subprocess.Popen([str(exe), 'lag', '--topics', *TOPICS, '--duration',
                                str(seconds + 60), '--wait', '60', '--json',
                                str(out / 'lag.json')], env=env, stdout=subprocess.DEVNULL)
        started = time.monotonic()
        graph.wait()
        time.sleep(1.0)  # the last predictions on their way
        lag_cpu = 100 * cpu_seconds(lag.pid) / (time.monotonic() - started)
        lag.send_signal(signal.SIGINT)
        lag.wait(60)
    finally:
        for proc in (graph, lag):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait()
    figures = {f['topic']: f for f in json.loads((out / 'lag.json').read_text())}
    summary = json.loads((out / 'run' / 'summary.json').read_text())
    js = summary['joint_states']
    short = js['published'] - (js['recorded'] or 0)  # as bench_graph.py counts them
    for row in summary['methods'].values():
        short += (row['shortfall'] or 0) + js['published'] - (row['recorded'] or 0)
    updates = sum(row['updates'] or 0 for row in summary['methods'].values())
    return {'figures': figures, 'lost': short, 'load': os.getloadavg()[0], 'cpu': lag_cpu,
            'updates': updates,
            'code': 'before' if code is not None else 'this commit'}


def _ms(f: dict[str, Any]) -> str:
    return ' / '.join(f'{f[key]:.0f}' if f[key] >= 10 else f'{f[key]:.1f}'
                      for key in ('p50_ms', 'p99_ms', 'p999_ms', 'max_ms'))


def _worst(f: dict[str, Any]) -> str:
    return ', '.join(f'{start:g} s: {n} ({top:.0f} ms)' for start, n, top in f['worst'])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=60.0)
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--hogs', type=int, default=0,
                        help='CPU hogs (yes > /dev/null) running beside the graph')
    parser.add_argument('--label', default='', help='what the section measures')
    parser.add_argument('--before', type=Path, default=None, metavar='DIR',
                        help='a checkout of the code to compare with (e.g. git archive of '
                             'an earlier commit): each run then runs its graph, then this '
                             "commit's, alternately")
    parser.add_argument('--no-write', action='store_true', help='print only')
    args = parser.parse_args()
    env = ros_env()
    load_before = os.getloadavg()[0]
    hogs = [subprocess.Popen(['yes'], stdout=subprocess.DEVNULL) for _ in range(args.hogs)]
    try:
        runs = []
        for _ in range(args.runs):
            if args.before is not None:
                runs.append(one_run(args.seconds, env, args.before.resolve()))
            runs.append(one_run(args.seconds, env))
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    today = datetime.date.today().isoformat()
    lines = [f'## {args.seconds:g} s, {args.hogs} CPU hog(s) beside it ({today}, commit '
             f'{_commit()}{", " + args.label if args.label else ""})', '',
             f'`python benchmarks/bench_subscriber_lag.py --seconds {args.seconds:g} --runs '
             f'{args.runs} --hogs {args.hogs}'
             f'{" --before DIR" if args.before else ""}`; load average {load_before:.2f} before, '
             + ', '.join(f'{r["load"]:.2f}' for r in runs) + ' after each run.', '',
             '| run | code | /joint_states after its stamp p50 / p99 / p99.9 / max (ms) | '
             'prediction (/ffs/identified_torque) after its sample p50 / p99 / p99.9 / max '
             '(ms) | samples not predicted or not recorded | worst 5 s windows (samples '
             'above p99, max): /joint_states; prediction | subscriber CPU (% of a core, '
             'start-up included) | learners\' updates (3 methods) |',
             '|---|---|---:|---:|---:|---|---:|---:|']
    for i, r in enumerate(runs, 1):
        js, ffs = (r['figures'][topic] for topic in TOPICS)
        lines.append(f'| {i} | {r["code"]} | {_ms(js)} | {_ms(ffs)} | {r["lost"]} | {_worst(js)}; '
                     f'{_worst(ffs)} | {r["cpu"]:.0f} | {r["updates"]} |')
    text = '\n'.join(lines) + '\n'
    print(text)
    if not args.no_write:
        head = '' if OUTPUT.exists() else (
            '# What a separate subscriber sees\n\nWritten by '
            '`benchmarks/bench_subscriber_lag.py` (its docstring says what it measures).\n\n')
        with OUTPUT.open('a') as f:
            f.write(head + text + '\n')
    return 0 if all(r['lost'] == 0 for r in runs) else 1


if __name__ == '__main__':
    sys.exit(main())
