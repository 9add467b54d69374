"""The whole graph at 1 kHz for a long run: samples used, CPU, memory and learning.

Runs ``scara-ident run --duration SECONDS --no-report`` (simulator, one identifier serving
FFMW, FFW and FFS with a learner process per method, recorder) and samples the CPU time and
resident memory of every process of the graph from /proc every ``--interval`` seconds.
With ``--hogs N``, N ``yes > /dev/null`` processes run beside the graph the whole time (a
machine whose CPU is short: the stream must still be whole, learning slower).

Prints, side by side from the one run:

- per process, the mean CPU (% of one core) over the steady state (after the first
  minute, or a sixth of the run) and the RSS at its start and at the end (memory is flat
  when those agree); the stream's work (simulator, identifier's message path, recorder)
  apart from learning (the learners), as the issue's budget puts it;
- per method, from the run's summary: samples predicted, skipped, lost before the
  identifier, not drained, predictions recorded, weight updates (and per second), the lag
  (prediction's publication against its sample's stamp: includes any lateness of the
  simulator) and the message path's delay (from the sample's arrival at the identifier),
  as p50 / p99 (upper edges of 1 ms bins) and max, the contact decision's delay from the
  sample's stamp (p50 / p99: when its external torque was checked against the thresholds),
  and the validation NMSE at the end.

Usage: ``python benchmarks/bench_graph.py [--seconds 600] [--interval 10] [--hogs 0]``
(targets: 0 lost, every sample predicted and recorded, memory flat, the stream's work
at most 75 % of a core in all and the simulator at most 25 %). Exit status 0 when nothing
was lost or left unpredicted.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from ros_env import ros_env  # benchmarks/: the script's own folder

TICKS = os.sysconf('SC_CLK_TCK')
PAGE = os.sysconf('SC_PAGE_SIZE')
LEARNER_MODULE = b'scara_ident_ros.identification.background_lm'


def _processes() -> dict[int, tuple[int, list[bytes]]]:
    """Every process: pid -> (parent pid, command line)."""
    found = {}
    for entry in Path('/proc').iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / 'stat').read_text()
            cmdline = (entry / 'cmdline').read_bytes().split(b'\0')
        except OSError:
            continue
        found[int(entry.name)] = (int(stat.rsplit(')', 1)[1].split()[1]), cmdline)
    return found


def graph_processes(root: int) -> dict[int, str]:
    """The graph's processes under ``root``: pid -> name (the node, or ``learner lm-M``)."""
    table = _processes()
    found: dict[int, str] = {}
    frontier = [root]
    while frontier:
        parent = frontier.pop()
        for pid, (ppid, cmdline) in table.items():
            if ppid != parent:
                continue
            frontier.append(pid)
            if any(LEARNER_MODULE in part for part in cmdline):
                try:  # the learner names itself after its method (its comm)
                    found[pid] = Path(f'/proc/{pid}/comm').read_text().strip()
                except OSError:
                    found[pid] = 'learner'
            elif b'-m' in cmdline:
                found[pid] = cmdline[cmdline.index(b'-m') + 1].decode().rsplit('.', 1)[-1]
    return found


def sample(pid: int) -> tuple[float, float] | None:
    """CPU seconds (user + system) and RSS in MiB of ``pid``."""
    try:
        fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
        rss_pages = int(Path(f'/proc/{pid}/statm').read_text().split()[1])
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / TICKS, rss_pages * PAGE / 2**20


def steady_cpu(rows: list[tuple[float, float, float]], steady: float
               ) -> tuple[float, float, float]:
    """Mean CPU (% of one core) over the steady state, RSS at its start and at the end."""
    t0 = rows[0][0]
    kept = [row for row in rows if row[0] - t0 >= steady] or rows
    first, last = kept[0], rows[-1]
    return (100 * (last[1] - first[1]) / max(last[0] - first[0], 1e-9), first[2], last[2])


def _fmt(value: Any, digits: int = 3) -> str:
    if value is None:
        return '–'
    return f'{value:.{digits}g}' if isinstance(value, float) else str(value)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=600.0)
    parser.add_argument('--interval', type=float, default=10.0)
    parser.add_argument('--hogs', type=int, default=0,
                        help='CPU hogs (yes > /dev/null) running beside the graph')
    parser.add_argument('--lm-interval', type=int, default=0,
                        help="scara-ident run's --lm-interval (default: the identifier's)")
    args = parser.parse_args()
    env = ros_env()
    out = Path(tempfile.mkdtemp(prefix='bench_graph_'))
    exe = Path(sys.executable).with_name('scara-ident')
    hogs = [subprocess.Popen(['yes'], stdout=subprocess.DEVNULL) for _ in range(args.hogs)]
    command = [str(exe), 'run', '--duration', str(args.seconds), '--no-report',
               '--out', str(out)]
    if args.lm_interval:
        command += ['--lm-interval', str(args.lm_interval)]
    try:
        run = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, text=True)
        samples: dict[str, list[tuple[float, float, float]]] = {}
        names: dict[int, str] = {}
        while run.poll() is None:
            time.sleep(args.interval)
            names.update(graph_processes(run.pid))
            now = time.monotonic()
            for pid, name in names.items():
                reading = sample(pid)
                if reading is not None and reading[1] > 0:  # 0: exited, not yet reaped
                    samples.setdefault(name, []).append((now, *reading))
        printed, _ = run.communicate()
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    summary = json.loads((out / 'summary.json').read_text())
    steady = min(60.0, args.seconds / 6)
    print(f'## Whole graph, {args.seconds:g} s at 1 kHz, {args.hogs} CPU hog(s) beside it '
          f'(load average {os.getloadavg()[0]:.2f} at the end)\n')
    print('| process | CPU (% of one core, steady) | RSS start (MiB) | RSS end (MiB) |')
    print('|---|---:|---:|---:|')
    stream = learning = 0.0
    for name, rows in sorted(samples.items()):
        if len(rows) < 2:  # a process seen once (started or ended between two looks)
            continue
        cpu, rss0, rss1 = steady_cpu(rows, steady)
        if cpu < 0:  # its pid was taken by another process between two looks
            continue
        if name.startswith('learner'):
            learning += cpu
        else:
            stream += cpu
        print(f'| {name} | {cpu:.1f} | {rss0:.1f} | {rss1:.1f} |')
    print(f'| **stream (simulator, identifier, recorder)** | **{stream:.1f}** | | |')
    print(f'| **learning (the learners)** | **{learning:.1f}** | | |')
    js = summary['joint_states']
    print(f"\n/joint_states published {js['published']}, recorded {js['recorded']}, "
          f"sim late {js['late']}\n")
    print('| method | predicted | skipped | lost | not drained | recorded | updates | '
          'updates/s (last 10 s) | lag p50 / p99 / worst (ms) | message path p50 / p99 (ms) '
          '| contact decision p50 / p99 (ms) | validation NMSE |')
    print('|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|')
    short = js['published'] - (js['recorded'] or 0)
    for name, row in summary['methods'].items():
        stats = json.loads((out / 'stats' / f'{name}.json').read_text())
        print(f"| {name} | {_fmt(row['predicted'])} | {sum(row['skipped'].values())} | "
              f"{_fmt(row['lost'])} | {_fmt(row['not_drained'])} | {_fmt(row['recorded'])} | "
              f"{_fmt(row['updates'])} | {_fmt(row['updates_per_s'])} | "
              f"{_fmt(stats.get('lag_p50_ms'))} / {_fmt(stats.get('lag_p99_ms'))} / "
              f"{_fmt(stats.get('worst_lag_ms'))} | {_fmt(stats.get('path_delay_p50_ms'))} / "
              f"{_fmt(stats.get('path_delay_p99_ms'))} | "
              f"{_fmt(stats.get('contact_delay_p50_ms'))} / "
              f"{_fmt(stats.get('contact_delay_p99_ms'))} | "
              f"{_fmt(row['validation_nmse_total'])} |")
        short += (row['shortfall'] or 0) + js['published'] - (row['recorded'] or 0)
    print(f'\nsamples not predicted or not recorded (all consumers): {short} (target 0); '
          f'output in {out}')
    if short:
        print(printed)
    return 0 if short == 0 else 1


if __name__ == '__main__':
    sys.exit(main())
