"""The whole graph at 1 kHz for a long run: lost samples, CPU and memory of each process.

Runs ``scara-ident run --duration SECONDS --no-report`` (simulator, FFMW/FFW/FFS
identifiers, recorder, each its own process) and samples every child process's CPU
time and resident memory from /proc every ``--interval`` seconds. Prints, per process,
the mean CPU (% of one core) and RSS at the start of the steady state (after the
first minute, or a sixth of the run) and at the end; memory is flat when those agree.
Losses come from the run's summary: published vs processed vs recorded.

Usage: ``python benchmarks/bench_graph.py [--seconds 600] [--interval 10]``
(target: zero lost samples, memory flat).
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

from ros_env import ros_env  # benchmarks/: the script's own folder

TICKS = os.sysconf('SC_CLK_TCK')
PAGE = os.sysconf('SC_PAGE_SIZE')


def children(pid: int) -> dict[int, str]:
    """Direct child processes of ``pid``: pid -> node module name."""
    found = {}
    for entry in Path('/proc').iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / 'stat').read_text()
            cmdline = (entry / 'cmdline').read_bytes().split(b'\0')
        except OSError:
            continue
        if int(stat.rsplit(')', 1)[1].split()[1]) == pid and b'-m' in cmdline:
            module = cmdline[cmdline.index(b'-m') + 1].decode()
            args = b' '.join(cmdline).decode()
            name = module.rsplit('.', 1)[-1]
            if name == 'identifier':
                name = args.split('method:=')[1].split()[0]
            found[int(entry.name)] = name
    return found


def sample(pid: int) -> tuple[float, float] | None:
    """CPU seconds (user + system) and RSS in MiB of ``pid``."""
    try:
        fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
        rss_pages = int(Path(f'/proc/{pid}/statm').read_text().split()[1])
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / TICKS, rss_pages * PAGE / 2**20


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=600.0)
    parser.add_argument('--interval', type=float, default=10.0)
    args = parser.parse_args()
    env = ros_env()
    out = Path(tempfile.mkdtemp(prefix='bench_graph_'))
    exe = Path(sys.executable).with_name('scara-ident')
    run = subprocess.Popen([str(exe), 'run', '--duration', str(args.seconds), '--no-report',
                            '--out', str(out)], env=env, stdout=subprocess.PIPE, text=True)
    samples: dict[str, list[tuple[float, float, float]]] = {}
    names: dict[int, str] = {}
    while run.poll() is None:
        time.sleep(args.interval)
        names.update(children(run.pid))
        now = time.monotonic()
        for pid, name in names.items():
            reading = sample(pid)
            if reading is not None and reading[1] > 0:  # 0: exited, not yet reaped
                samples.setdefault(name, []).append((now, *reading))
    run.communicate()
    summary = json.loads((out / 'summary.json').read_text())
    steady = min(60.0, args.seconds / 6)
    print(f'## Whole graph, {args.seconds:g} s at 1 kHz (load average '
          f'{os.getloadavg()[0]:.2f} at the end)\n')
    print('| process | CPU (% of one core, steady) | RSS start (MiB) | RSS end (MiB) |')
    print('|---|---:|---:|---:|')
    for name, rows in sorted(samples.items()):
        t0 = rows[0][0]
        kept = [row for row in rows if row[0] - t0 >= steady] or rows
        first, last = kept[0], rows[-1]
        cpu = 100 * (last[1] - first[1]) / max(last[0] - first[0], 1e-9)
        print(f'| {name} | {cpu:.1f} | {first[2]:.1f} | {last[2]:.1f} |')
    js = summary['joint_states']
    print(f"\n/joint_states published {js['published']}, recorded {js['recorded']}, "
          f"sim late {js['late']}")
    lost = js['published'] - (js['recorded'] or 0)
    for name, row in summary['methods'].items():
        print(f"{name}: processed {row['processed']}, predictions published "
              f"{row['published']}, recorded {row['recorded']}, skipped {row['skipped']}")
        lost += js['published'] - (row['processed'] or 0)
    print(f'\nlost samples (all consumers): {lost} (target 0); output in {out}')
    return 0 if lost == 0 else 1


if __name__ == '__main__':
    sys.exit(main())
