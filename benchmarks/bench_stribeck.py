"""What the physical model of a ``robot_sim`` arm misses: the q'' estimate or the friction law.

Least squares of the arm's :class:`~scara_ident_ros.dynamics.physical_model.PhysicalModel`
(base parameters, rotor inertias, viscous and tanh(q'/ε) Coulomb friction, ε the
simulator's ``stick_velocity``) on ``--seconds`` of ``sequence`` (seed 0), scored on the
learning curves' held-out set (5 ``standard`` excitations and a ``sequence``, q''
estimated), with:

- q'' estimated by the identifier's input stage (as online) or the simulator's true q'';
- no Stribeck column, or columns exp(−(q'/v_s)²) tanh(q'/ε) per joint for each v_s of
  ``--stribeck`` (the simulator's friction falls from its breakaway level to its Coulomb
  level over v_s = 0.1 rad/s: docs/nodes.md); ``0.05,0.2`` gives two columns.

Prints the held-out NMSE per joint and on the training data.

    .venv/bin/python benchmarks/bench_stribeck.py [--robot panda] [--seconds 60]
        [--stribeck 0.05 0.1 0.2 0.05,0.2] [--true-qdd]
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.paper.datasets import dataset_from_record, simulate_record
from scara_ident_ros.paper.learning_curves import held_out_set, physical_model_of, robot_by_name

FloatArray = NDArray[np.float64]


def regressor(model: PhysicalModel, X: FloatArray, velocities: list[float]) -> FloatArray:
    """The model's regressor (N, n, p) with a Stribeck column per joint and v_s."""
    n = model.n_joints
    q, qd, qdd = X[:, :n], X[:, n:2 * n], X[:, 2 * n:]
    parts = [model.regressor(q, qd, qdd)]
    joints = np.arange(n)
    for vs in velocities:
        extra = np.zeros((X.shape[0], n, n))
        extra[:, joints, joints] = np.exp(-(qd / vs) ** 2) * model.coulomb_shape(qd)
        parts.append(extra)
    return np.concatenate(parts, axis=2)


def nmse(Y: FloatArray, predicted: FloatArray) -> FloatArray:
    """Per joint: MSE / variance of Y (the package's one NMSE)."""
    return effort_errors(Y, predicted).nmse


def main() -> int:
    """Fit each variant, print a table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--robot', default='panda')
    parser.add_argument('--seconds', type=float, default=60.0)
    parser.add_argument('--stribeck', nargs='*', default=['0.05', '0.1', '0.2', '0.05,0.2'])
    parser.add_argument('--true-qdd', action='store_true',
                        help="also fit on the simulator's true q''")
    parser.add_argument('--held-out', type=float, nargs=2, default=(3.0, 15.0),
                        metavar=('EXCITATION_S', 'SEQUENCE_S'))
    args = parser.parse_args()
    robot = robot_by_name(args.robot)
    record = simulate_record(robot, seconds=args.seconds, seed=0, preset='sequence')
    held = held_out_set(robot, excitation_s=args.held_out[0], sequence_s=args.held_out[1])
    model = physical_model_of(args.robot)
    sources = ['estimated'] + (['true'] if args.true_qdd else [])
    variants = [[]] + [[float(v) for v in text.split(',')] for text in args.stribeck]
    held_rows = {tuple(v): regressor(model, held.X, v) for v in map(tuple, variants)}
    print(f'### Physical model of {args.robot}: {args.seconds:g} s of `sequence`, held out '
          f'{args.held_out[0]:g} s × 5 standard + {args.held_out[1]:g} s sequence '
          f'(load average {os.getloadavg()[0]:.1f})\n')
    print("| q'' | Stribeck v_s (rad/s) | held-out NMSE per joint | worst | training NMSE, "
          'worst |')
    print('|---|---|---|---|---|')
    for source in sources:
        train = dataset_from_record(record, acceleration=source)
        for velocities in variants:
            rows = regressor(model, train.X, velocities)
            theta, *_ = np.linalg.lstsq(rows.reshape(-1, rows.shape[2]),
                                        train.Y.reshape(-1), rcond=None)
            held_nmse = nmse(held.Y, held_rows[tuple(velocities)] @ theta)
            train_nmse = nmse(train.Y, rows @ theta)
            label = ', '.join(f'{v:g}' for v in velocities) or 'none'
            print(f'| {source} | {label} | {", ".join(f"{v:.2g}" for v in held_nmse)} | '
                  f'{held_nmse.max():.2g} | {train_nmse.max():.2g} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
