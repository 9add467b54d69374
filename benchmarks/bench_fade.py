"""The hybrid's correction with and without its fade, on motion it was not learnt from.

A UR5 of ``robot_sim`` (Pinocchio's dynamics, the simulator's friction and rotor inertia)
tracks one ``standard`` excitation for ``--seconds``; ``fit_hybrid`` (the physical model of
the URDF plus an FFS network of its residual, LM early-stopped on 1 s validation blocks,
gated on them) learns 4 of its 5 blocks, with ``fade`` on and off. Both are scored on the
validation blocks (interpolation) and on ``held_out_set`` (five other excitations and a
``sequence``: motion never learnt), NMSE per joint, beside the physical part alone.
Appends a dated section to ``benchmarks/fade.md``.

    nice .venv/bin/python benchmarks/bench_fade.py [--robot ur5] [--seconds 60] [--seeds 0 1]
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path


from scara_ident_ros.blas_threads import single_blas_thread
from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.identification.split import block_index, block_split
from scara_ident_ros.learners.hybrid_model import fit_hybrid
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.paper.datasets import dataset_from_record, simulate_record
from scara_ident_ros.paper.learning_curves import (held_out_set, physical_model_of,
                                                   robot_by_name)

HERE = Path(__file__).resolve().parent


def worst(model: object, data: Dataset) -> float:
    """The worst joint's NMSE of ``model``'s predictions of ``data``."""
    return float(effort_errors(data.Y, model.predict(data.X)).nmse.max())  # type: ignore[attr-defined]


def main() -> int:
    """Fit, score, print and append the table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--robot', default='ur5')
    parser.add_argument('--seconds', type=float, default=60.0)
    parser.add_argument('--seeds', type=int, nargs='+', default=[0, 1])
    parser.add_argument('--out', type=Path, default=HERE / 'fade.md')
    args = parser.parse_args()
    params = robot_by_name(args.robot)
    data = dataset_from_record(simulate_record(params, seconds=args.seconds, seed=1),
                               acceleration='estimated')
    train, validation = block_split(data, 0.2, block_s=1.0)
    held_out = held_out_set(params)
    groups = block_index(validation.stamp_ns, block_s=1.0, start_ns=int(data.stamp_ns[0]))
    commit = subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], capture_output=True,
                            text=True, cwd=HERE).stdout.strip()
    lines = [f'\n## {time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}, commit {commit}\n',
             f'{args.robot}, {args.seconds:g} s of one `standard` excitation learnt; worst '
             'joint\'s NMSE on the validation blocks and on other motion (`held_out_set`).\n',
             '| seed | model | validation blocks | other motion | mean fade weight there |',
             '|---|---|---|---|---|']
    for seed in args.seeds:
        for fade in (False, True):
            with single_blas_thread():
                hybrid, _ = fit_hybrid(physical_model_of(args.robot),
                                       make_network('ffs', data.n_joints, seed=seed),
                                       (train.X, train.Y),
                                       validation=(validation.X, validation.Y),
                                       gate_groups=groups, network_samples=4000, seed=seed,
                                       iterations=100, fade=fade)
            weight = (float(hybrid.region.weight(held_out.X).mean())
                      if hybrid.region is not None else 1.0)
            lines.append(f'| {seed} | hybrid, {"fade" if fade else "no fade"} | '
                         f'{worst(hybrid, validation):.3g} | {worst(hybrid, held_out):.3g} | '
                         f'{weight:.2f} |')
            print(lines[-1], flush=True)
        lines.append(f'| {seed} | its physical part | {worst(hybrid.base, validation):.3g} | '
                     f'{worst(hybrid.base, held_out):.3g} | |')
    lines.append(f'\nload average {os.getloadavg()[0]:.1f}\n')
    text = '\n'.join(lines) + '\n'
    print(text)
    with args.out.open('a', encoding='utf-8') as stream:
        stream.write(text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
