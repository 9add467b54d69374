"""What ``scara-ident train`` chooses with its default ``--method auto`` on real recordings.

Runs the command as a user would (a subprocess of the venv's ``scara-ident``), without a
URDF, on the recordings of ``../shared/realdata``: the WAM's training rows (the default 1 s
blocks of its time-less rows, and 50-row blocks), TIAGo's /joint_states export and the TX40's
positions and torques (q' and q'' derived by the input stage; 0.5 s blocks). For each seed
it records every candidate's score on the scoring half of the validation blocks (mean over
the joints of MSE / variance of all validation efforts), the choice, and for the WAM the
chosen model's SMSE on the published test rows (``scara-ident evaluate``). Appends a dated
section to ``benchmarks/train_auto.md``.

    nice .venv/bin/python benchmarks/bench_train_auto.py [--seeds 0 1] [--data wam tiago ...]
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REALDATA = HERE.parents[1] / 'shared' / 'realdata'
CLI = str(Path(sys.executable).with_name('scara-ident'))
#: name: (recording, extra train options, rows to evaluate the chosen model on or None)
DATA = {
    'wam': (f'{REALDATA}/barrett_wam.npz:train', [], f'{REALDATA}/barrett_wam.npz:test'),
    'wam50': (f'{REALDATA}/barrett_wam.npz:train', ['--validation-block', '0.05'],
              f'{REALDATA}/barrett_wam.npz:test'),
    'tiago': (f'{REALDATA}/tiago', [], None),
    'tx40': (f'{REALDATA}/tx40/tx40_joint.npz', ['--validation-block', '0.5'], None),
}


def run(*args: str) -> str:
    """The command's stdout; its stderr on failure."""
    done = subprocess.run([CLI, *args], capture_output=True, text=True,
                          env={**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE':
                               os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')})
    if done.returncode:
        raise RuntimeError(f'scara-ident {" ".join(args)}: {done.stderr.strip()}')
    return done.stdout


def mean_nmse(table_text: str) -> str:
    """The last column of the ``| mean`` row of the command's error table."""
    row = next(line for line in table_text.splitlines() if line.startswith('| mean'))
    return row.strip('|').split('|')[-1].strip()


def main() -> int:
    """Run every data set and seed, print and append the table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seeds', type=int, nargs='+', default=[0, 1])
    parser.add_argument('--data', nargs='+', default=list(DATA), choices=list(DATA))
    parser.add_argument('--out', type=Path, default=HERE / 'train_auto.md')
    args = parser.parse_args()
    commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], capture_output=True,
                            text=True, cwd=HERE).stdout.strip()
    lines = [f'\n## {time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}, commit {commit}\n',
             '| data | seed | linear | linear_hybrid | gp | ffs | chosen | its validation NMSE '
             '(all blocks, mean) | its test SMSE (published rows) | s | load |',
             '|---|---|---|---|---|---|---|---|---|---|---|']
    print('\n'.join(lines), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.data:
            recording, options, test = DATA[name]
            for seed in args.seeds:
                model = Path(tmp) / f'{name}-{seed}.npz'
                started = time.perf_counter()
                out = run('train', recording, *options, '--seed', str(seed), '--out',
                          str(model))
                scores = dict(re.findall(r'^auto: (\w+) mean NMSE (\S+) on ', out,
                                         flags=re.MULTILINE))
                chosen = re.search(r'^auto: (\w+), the lowest', out, flags=re.MULTILINE)
                tested = mean_nmse(run('evaluate', str(model), test)) if test else '–'
                row = (f'| {name} | {seed} | {scores.get("linear", "?")} | '
                       f'{scores.get("linear_hybrid", "?")} | '
                       f'{scores.get("gp", "?")} | {scores.get("ffs", "?")} | '
                       f'{chosen.group(1).lower() if chosen else "?"} | {mean_nmse(out)} | '
                       f'{tested} | {time.perf_counter() - started:.0f} | '
                       f'{os.getloadavg()[0]:.1f} |')
                print(row, flush=True)
                lines.append(row)
    with args.out.open('a', encoding='utf-8') as stream:
        stream.write('\n'.join(lines) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
