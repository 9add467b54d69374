"""Soak: the whole graph at 1 kHz for 30 minutes; each node's CPU and memory, and losses.

Runs ``scara-ident run --duration SECONDS --no-report --out DIR`` (recorder, FFMW/FFW/FFS
identifiers and the simulator, each its own process, started and stopped as the command
does) on a ROS domain of its own: ``--domain``, else ``ROS_DOMAIN_ID``, else the first one
free by the lock of ``test/ros_domains.py`` (``ros_env.py``: no test run and no other
benchmark shares it). Every ``--interval`` seconds it reads, for each node process (a child of
the run), the CPU time from ``/proc/<pid>/stat`` and the resident memory (``VmRSS``)
from ``/proc/<pid>/status``. At the end it reports per node:

* CPU in % of one core, median [min–max] over the sampling intervals of the run;
* RSS one minute after the start and at the end, and its slope in MiB per 10 minutes,
  a least-squares line through the samples after the first ``--settle`` seconds (the
  networks, queues and bag chunks fill in the first minutes; a leak shows as a slope
  that stays above zero);

and the run's ``/joint_states`` published / recorded / lost / late counts from its
``summary.json``, and each identifier's processed, skipped and lost samples (gaps in the
stamps: samples that fell out of the simulator's history while it was behind) and its
largest lag, from its ``stats/<method>.json``. The Markdown report (date, machine, load
average at the start and the end) goes to ``--report``; the samples themselves to
``samples.json`` beside the run's output directory.

Usage::

    .venv/bin/python benchmarks/bench_soak.py                 # 30 min, benchmarks/soak.md
    .venv/bin/python benchmarks/bench_soak.py --duration 60 --report /tmp/soak.md

Target (issue 11): 0 lost, CPU and memory flat. The machines are 2 shared cores: read
the load average beside the figures.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from bench_graph import children

from ros_env import ros_env  # benchmarks/: the script's own folder

HERE = Path(__file__).resolve().parent

TICKS = os.sysconf('SC_CLK_TCK')  # clock ticks per second of /proc/<pid>/stat times
RSS_AT = 60.0  # s after the start: the "RSS at 1 min" column
SLOPE_PER = 600.0  # s: the slope is given in MiB per 10 min
NODE_ORDER = ('scara_sim', 'ffmw', 'ffw', 'ffs', 'recorder')


@dataclass
class NodeSamples:
    """What one node process looked like at each sampling time.

    Attributes
    ----------
    times : list of float
        Seconds since the run started, one per sample.
    cpu : list of float
        CPU time used so far (user + system), seconds.
    rss : list of float
        Resident memory, MiB.
    """

    times: list[float] = field(default_factory=list)
    cpu: list[float] = field(default_factory=list)
    rss: list[float] = field(default_factory=list)

    def cpu_percent(self) -> list[float]:
        """CPU in % of one core over each interval between two samples."""
        return [100 * (c1 - c0) / (t1 - t0) for t0, t1, c0, c1
                in zip(self.times, self.times[1:], self.cpu, self.cpu[1:]) if t1 > t0]

    def rss_near(self, when: float) -> float | None:
        """RSS of the sample nearest to ``when`` seconds after the start (MiB)."""
        if not self.times:
            return None
        i = min(range(len(self.times)), key=lambda k: abs(self.times[k] - when))
        return self.rss[i]

    def rss_slope(self, settle: float) -> float | None:
        """Least-squares RSS slope after ``settle`` s, MiB per 10 min (None: < 3 samples)."""
        kept = [(t, r) for t, r in zip(self.times, self.rss) if t >= settle]
        if len(kept) < 3:
            return None
        slope, _ = statistics.linear_regression([t for t, _ in kept], [r for _, r in kept])
        return slope * SLOPE_PER


def read_process(pid: int) -> tuple[float, float] | None:
    """CPU seconds (user + system) and VmRSS in MiB of ``pid``; None once it has gone."""
    try:
        fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
        status = Path(f'/proc/{pid}/status').read_text()
    except OSError:
        return None
    rss_kib = next((int(line.split()[1]) for line in status.splitlines()
                    if line.startswith('VmRSS:')), None)
    if rss_kib is None:  # a zombie: exited, not yet reaped
        return None
    return (int(fields[11]) + int(fields[12])) / TICKS, rss_kib / 1024


def soak(duration: float, interval: float, out: Path, env: dict[str, str],
         log: IO[str]) -> tuple[int, dict[str, NodeSamples], float]:
    """Run the graph for ``duration`` s, sampling its nodes every ``interval`` s.

    Returns
    -------
    tuple
        The run's exit status, the samples by node name, and the run's wall time (s).
    """
    exe = Path(sys.executable).with_name('scara-ident')
    started = time.monotonic()
    run = subprocess.Popen([str(exe), 'run', '--duration', f'{duration:g}', '--no-report',
                            '--out', str(out)], env=env, stdout=log,
                           stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    names: dict[int, str] = {}
    nodes: dict[str, NodeSamples] = {}
    tick = 0
    try:
        while run.poll() is None:
            names.update(children(run.pid))
            now = time.monotonic() - started
            for pid, name in names.items():
                reading = read_process(pid)
                if reading is not None:
                    node = nodes.setdefault(name, NodeSamples())
                    node.times.append(now)
                    node.cpu.append(reading[0])
                    node.rss.append(reading[1])
            tick += 1
            # sleep to the next multiple of the interval, or until the run ends
            try:
                run.wait(timeout=max(0.0, started + tick * interval - time.monotonic()))
            except subprocess.TimeoutExpired:
                pass
    except KeyboardInterrupt:  # the run got the terminal's SIGINT too: it stops in order
        print('bench_soak: interrupted; waiting for the run to stop', flush=True)
        run.send_signal(signal.SIGINT)
    status = run.wait()
    return status, nodes, time.monotonic() - started


def _read_json(path: Path) -> dict[str, Any]:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def _fmt(value: Any, spec: str = '') -> str:
    return '–' if value is None else format(value, spec)


def report(args: argparse.Namespace, *, domain: int, status: int,
           nodes: dict[str, NodeSamples], wall: float, summary: dict[str, Any],
           date: str, loads: tuple[tuple[float, ...], tuple[float, ...]]) -> str:
    """The Markdown report of one soak run."""
    load_start, load_end = (' / '.join(f'{x:.2f}' for x in load) for load in loads)
    lines = [
        f'# Soak: the whole graph at 1 kHz for {args.duration:g} s',
        '',
        f'`benchmarks/bench_soak.py --duration {args.duration:g} --interval '
        f'{args.interval:g}` on {date}: `scara-ident run` (recorder, FFMW, FFW, FFS, '
        f'scara_sim; defaults) on ROS domain {domain}, {wall:.0f} s of wall time, '
        f'exit status {status}. {os.cpu_count()} cores ({platform.machine()}), shared with '
        f'other work: load average (1 / 5 / 15 min) {load_start} at the start, '
        f'{load_end} at the end.',
        '',
        f'CPU in % of one core over each {args.interval:g} s interval of the run, median '
        f'[min–max]; RSS (`VmRSS`) in MiB; slope: least squares over the samples after '
        f'the first {args.settle:g} s, MiB per 10 min.',
        '',
        '| node | samples | CPU % median [min–max] | RSS at 1 min | RSS at the end '
        '| RSS slope (MiB / 10 min) |',
        '|---|---:|---:|---:|---:|---:|',
    ]
    order = [n for n in NODE_ORDER if n in nodes] + sorted(set(nodes) - set(NODE_ORDER))
    for name in order:
        node = nodes[name]
        cpu = node.cpu_percent()
        cpu_text = (f'{statistics.median(cpu):.1f} [{min(cpu):.1f}–{max(cpu):.1f}]'
                    if cpu else '–')
        lines.append(f'| {name} | {len(node.times)} | {cpu_text} | '
                     f'{_fmt(node.rss_near(RSS_AT), ".1f")} | {_fmt(node.rss[-1], ".1f")} | '
                     f'{_fmt(node.rss_slope(args.settle), "+.2f")} |')
    js = summary.get('joint_states', {})
    lines += ['', '| /joint_states | published | recorded | lost (recorder) | late (sim) |',
              '|---|---:|---:|---:|---:|',
              f"| | {_fmt(js.get('published'))} | {_fmt(js.get('recorded'))} | "
              f"{_fmt(js.get('lost'))} | {_fmt(js.get('late'))} |",
              '', '| identifier | processed | skipped | lost (gaps) | worst lag (s) '
              '| predictions published | recorded | final NMSE (windowed) |',
              '|---|---:|---:|---:|---:|---:|---:|---:|']
    for name, row in summary.get('methods', {}).items():
        skipped = sum((row.get('skipped') or {}).values())  # per reason
        stats = _read_json(args.out / 'stats' / f'{name}.json')
        lag = stats.get('worst_lag_ms')
        lines.append(f"| {name.upper()} | {_fmt(row.get('processed'))} | {_fmt(skipped)} | "
                     f"{_fmt(stats.get('lost'))} | {_fmt(lag and lag / 1000, '.1f')} | "
                     f"{_fmt(row.get('published'))} | {_fmt(row.get('recorded'))} | "
                     f"{_fmt(row.get('nmse_total'), '.3g')} |")
    lines += ['', f'Run output (bag, logs, stats, summary.json): `{args.out}` (not kept in '
              'the repository).', '']
    return '\n'.join(lines)


def main() -> int:
    """Run the soak, write the report; non-zero if the run failed or lost samples."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--duration', type=float, default=1800.0,
                        help='seconds of samples at 1 kHz (default: 1800)')
    parser.add_argument('--interval', type=float, default=10.0,
                        help='seconds between two samples of the processes (default: 10)')
    parser.add_argument('--settle', type=float, default=120.0,
                        help='seconds left out of the RSS slope (default: 120)')
    parser.add_argument('--domain', type=int, default=None,
                        help='ROS domain (default: the first free one by the test lock)')
    parser.add_argument('--out', type=Path, default=None,
                        help='run output directory, must not exist (default: a new one '
                             'in the temporary directory)')
    parser.add_argument('--report', type=Path, default=HERE / 'soak.md',
                        help='Markdown report (default: benchmarks/soak.md)')
    args = parser.parse_args()
    if args.duration <= 0 or args.interval <= 0:
        parser.error('--duration and --interval must be > 0')
    args.out = args.out or Path(tempfile.mkdtemp(prefix='bench_soak_')) / 'run'
    env = ros_env({**os.environ, **({} if args.domain is None
                                   else {'ROS_DOMAIN_ID': str(args.domain)})})
    domain = int(env['ROS_DOMAIN_ID'])
    date = datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%d %H:%M UTC')
    load_start = os.getloadavg()
    print(f'bench_soak: {args.duration:g} s on ROS domain {domain}, output in {args.out}, '
          f'load average {load_start[0]:.2f}', flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out.parent / 'run.log', 'w') as log:
        status, nodes, wall = soak(args.duration, args.interval, args.out, env, log)
    load_end = os.getloadavg()
    summary = _read_json(args.out / 'summary.json')
    (args.out.parent / 'samples.json').write_text(json.dumps(
        {name: vars(node) for name, node in nodes.items()}))
    text = report(args, domain=domain, status=status, nodes=nodes, wall=wall,
                  summary=summary, date=date, loads=(load_start, load_end))
    args.report.write_text(text)
    print(text)
    js = summary.get('joint_states', {})
    complete = js.get('published') is not None and js.get('recorded') == js.get('published')
    processed = all(row.get('processed') == js.get('published')
                    for row in summary.get('methods', {}).values())
    return 0 if status == 0 and complete and processed and not js.get('lost') else 1


if __name__ == '__main__':
    sys.exit(main())
