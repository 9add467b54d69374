"""What ``scara-ident train`` gives on motion recorded after its training motion.

Runs the commands as a user would (subprocesses of the venv's ``scara-ident``) on the real
recordings of ``../shared/realdata``: ``train RECORDING --span 0:0.7`` (the first 70 % of the
recording's time) with each ``--method``, then ``evaluate MODEL RECORDING --span 0.7:1`` (the
last 30 %, never seen), and tabulates each joint's NMSE (MSE over the variance of the
joint's effort in the scored part). The default (no ``--method``, ``auto``) is compared
per joint with the physical model (with a URDF) and with the best of linear, GP and FFS;
with a URDF, ``physical --weighted`` is the physical model fitted by least squares weighted
per joint by 1/its residual RMS.

Cases: the TX40 with its URDF (positions and torques as recorded, q' and q'' derived; 0.5 s
blocks); TIAGo's torso and arm_1-4 with example-robot-data's ``tiago.urdf`` and without a
URDF. Each figure in the tables is what the printed command prints. Appends a dated section
to ``benchmarks/later_motion.md``.

    nice .venv/bin/python benchmarks/bench_later_motion.py [--cases tx40 tiago tiago_nourdf]
        [--seeds 0]
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
TIAGO_JOINTS = ['torso_lift_joint', 'arm_1_joint', 'arm_2_joint', 'arm_3_joint',
                'arm_4_joint']
LEARNERS = ('linear', 'gp', 'ffs')
WEIGHTED = 'physical --weighted'  # a method and its flag: least squares weighted per joint


def tiago_urdf() -> str:
    """example-robot-data's TIAGo, as installed in the venv."""
    from scara_ident_ros.sim.example_robots import robot_roots

    return str(robot_roots()[0] / 'tiago_description' / 'robots' / 'tiago.urdf')


def cases() -> dict[str, tuple[str, list[str], tuple[str, ...]]]:
    """name: (recording, train and evaluate options, methods besides auto)."""
    return {
        'tx40': (f'{REALDATA}/tx40/tx40_joint.npz',
                 ['--urdf', f'{REALDATA}/tx40/tx40.urdf', '--validation-block', '0.5'],
                 ('physical', WEIGHTED, 'hybrid', 'linear', 'gp')),
        'tiago': (f'{REALDATA}/tiago', ['--urdf', tiago_urdf(), '--joints', *TIAGO_JOINTS],
                  ('physical', WEIGHTED, 'hybrid', *LEARNERS)),
        'tiago_nourdf': (f'{REALDATA}/tiago', ['--joints', *TIAGO_JOINTS], LEARNERS),
    }


def run(*args: str) -> str:
    """The command's stdout; its stderr on failure."""
    done = subprocess.run([CLI, *args], capture_output=True, text=True,
                          env={**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE':
                               os.environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')})
    if done.returncode:
        raise RuntimeError(f'scara-ident {" ".join(args)}: {done.stderr.strip()}')
    return done.stdout


def nmse_per_joint(text: str) -> list[float]:
    """The NMSE column of each joint row of ``evaluate``'s first table (the errors)."""
    values, inside = [], False
    for line in text.splitlines():
        if line.startswith('| joint |'):
            inside = True
        elif inside and line.startswith('| mean'):
            return values
        elif inside and line.startswith('| ') and not line.startswith('|---'):
            values.append(float(line.strip('|').split('|')[-1]))
    raise ValueError(f'no error table in {text[:200]!r}')


def main() -> int:
    """Run every case, method and seed; print and append the tables."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--cases', nargs='+', default=[*cases(), 'tx40_blocks'],
                        choices=[*cases(), 'tx40_blocks'])
    parser.add_argument('--seeds', type=int, nargs='+', default=[0])
    parser.add_argument('--out', type=Path, default=HERE / 'later_motion.md')
    args = parser.parse_args()
    commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], capture_output=True,
                            text=True, cwd=HERE).stdout.strip()
    lines = [f'\n## {time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}, commit {commit}\n',
             'NMSE per joint on the last 30 % of each recording after `train --span 0:0.7` '
             '(`evaluate --span 0.7:1`); `auto` is the default. Ratios: auto over the '
             'physical model, and over the best of linear, GP and FFS, per joint.\n']
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.cases:
            if name == 'tx40_blocks':
                lines += tx40_blocks(Path(tmp))
                continue
            recording, options, methods = cases()[name]
            for seed in args.seeds:
                scores: dict[str, list[float]] = {}
                seconds: dict[str, float] = {}
                for method in ('auto', *methods):
                    model = Path(tmp) / f'{name}-{method.replace(" ", "")}-{seed}.npz'
                    started = time.perf_counter()
                    chosen = ''
                    try:
                        out = run('train', recording, *options, '--span', '0:0.7', '--seed',
                                  str(seed), '--method', *method.split(), '--out',
                                  str(model))
                        found = re.search(r'^auto: per joint [^:]*: (.*)$', out,
                                          flags=re.MULTILINE)
                        chosen = found.group(1) if found else ''
                        scores[method] = nmse_per_joint(run(
                            'evaluate', str(model), recording, '--span', '0.7:1'))
                    except RuntimeError as exc:
                        print(f'{name} {method}: {exc}', flush=True)
                        continue
                    seconds[method] = time.perf_counter() - started
                    print(f'{name} seed {seed} {method}: {scores[method]} '
                          f'({seconds[method]:.0f} s) {chosen}', flush=True)
                lines += _table(name, seed, scores, seconds, os.getloadavg()[0])
                if 'auto' in scores:
                    lines.append(f'auto chose: {chosen_text(tmp, name, seed)}\n')
    text = '\n'.join(lines) + '\n'
    print(text)
    with args.out.open('a', encoding='utf-8') as stream:
        stream.write(text)
    return 0


def tx40_blocks(tmp: Path) -> list[str]:
    """The TX40's physical model as ``train`` fits it with no model flag, on 0.5 s blocks,
    1 in 5 held out over the whole recording (``--later-fraction 0``): the validation NMSE
    per joint it prints."""
    args = ['train', f'{REALDATA}/tx40/tx40_joint.npz', '--urdf', f'{REALDATA}/tx40/tx40.urdf',
            '--method', 'physical', '--validation-block', '0.5', '--later-fraction', '0',
            '--out', str(tmp / 'tx40-blocks.npz')]
    out = run(*args)
    values, inside = [], False
    for line in out.splitlines():
        if line.startswith('| joint |'):
            inside = True
        elif inside and line.startswith('| mean'):
            break
        elif inside and line.startswith('| ') and not line.startswith('|---'):
            values.append(line.strip('|').split('|')[4].strip())  # validation NMSE
    options = next((line for line in out.splitlines()
                    if line.startswith('physical model options:')), '').split(' (')[0]
    text = [f'### TX40, 0.5 s blocks, 1 in 5 held out (`scara-ident {" ".join(args[:-2])}`)\n',
            f'validation NMSE per joint: {", ".join(values)}; {options}\n']
    print(''.join(text), flush=True)
    return text


def chosen_text(tmp: str, name: str, seed: int) -> str:
    """What the saved auto model chose per joint (its ``joint_choice`` metadata)."""
    from scara_ident_ros.estimator import load_model

    model = load_model(Path(tmp) / f'{name}-auto-{seed}.npz')
    return ', '.join(str(v) for v in model.metadata['joint_choice'])


def _table(name: str, seed: int, scores: dict[str, list[float]], seconds: dict[str, float],
           load: float) -> list[str]:
    """A Markdown table: a row per method, a column per joint, then the ratios."""
    if not scores:
        return [f'{name} seed {seed}: nothing fitted\n']
    n = len(next(iter(scores.values())))
    out = [f'### {name}, seed {seed} (load {load:.1f})\n',
           '| method | ' + ' | '.join(f'joint {j + 1}' for j in range(n)) + ' | s |',
           '|---|' + '---|' * (n + 1)]
    for method, values in scores.items():
        out.append(f'| {method} | ' + ' | '.join(f'{v:.3g}' for v in values)
                   + f' | {seconds[method]:.0f} |')
    auto = scores.get('auto')
    if auto is not None and 'physical' in scores:
        out.append('| auto / physical | ' + ' | '.join(
            f'{a / p:.2f}' for a, p in zip(auto, scores['physical'])) + ' | |')
    learners = [scores[m] for m in LEARNERS if m in scores]
    if auto is not None and learners:
        best = [min(values) for values in zip(*learners)]
        out.append('| auto / best learner | ' + ' | '.join(
            f'{a / b:.2f}' for a, b in zip(auto, best)) + ' | |')
    return out + ['']


if __name__ == '__main__':
    sys.exit(main())
