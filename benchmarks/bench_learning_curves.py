"""Learning curves of online identification: frozen models on motions never seen.

For each seed, ``scara_sim``'s default stream (``trajectory: sequence``, 1 kHz) is simulated
for ``--seconds``; every method (FFMW, FFW, FFS) learns it online with every trainer (``lm``:
the identifier's default, Levenberg-Marquardt steps on a reservoir; ``bp``: the paper's
per-sample back-propagation) through the identifier's own pipeline, and at each checkpoint
its frozen model is scored on held-out excitations (5 ``standard`` ones and 30 s of another
``sequence``, never streamed). LS and RLS on the SCARA's physical regressor, fitted to the
same stream inputs, are the references. ``--noise`` adds the simulator's sensor noise
(position 1e-4, velocity 1e-3, effort 0.5 % of its limit) to the stream and the held-out
data, and reports the noise floor.

Prints a Markdown table (median [min-max] over seeds of the worst joint's NMSE) and writes a
figure. Runs the jobs in two worker processes, BLAS held to one thread each.

    .venv/bin/python benchmarks/bench_learning_curves.py [--seeds 5] [--seconds 120] [--noise]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')
os.environ.setdefault('OMP_NUM_THREADS', '1')

import numpy as np  # noqa: E402

from scara_ident_ros.dynamics import ScaraParams  # noqa: E402
from scara_ident_ros.experiments.datasets import simulate_record  # noqa: E402
from scara_ident_ros.experiments.learning_curves import (CHECKPOINTS_S, Curve,  # noqa: E402
                                                         curves_markdown, held_out_set,
                                                         network_curve, regressor_curves)
from scara_ident_ros.resources import config_path  # noqa: E402
from scara_ident_ros.sim import SimConfig  # noqa: E402

HERE = Path(__file__).resolve().parent
NOISE = {'position_noise': 1e-4, 'velocity_noise': 1e-3}  # rad or m, rad/s or m/s
EFFORT_NOISE_FRACTION = 0.005  # of each joint's effort limit


def _config(noise: bool, params: ScaraParams, seed: int) -> SimConfig:
    if not noise:
        return SimConfig(seed=seed)
    effort = tuple(float(v) * EFFORT_NOISE_FRACTION for v in params.array('effort_max'))
    return SimConfig(seed=seed, position_noise=(NOISE['position_noise'],) * 4,
                     velocity_noise=(NOISE['velocity_noise'],) * 4, effort_noise=effort)


def _job(args: tuple[str, str, int, float, bool]) -> list[Curve]:
    method, trainer, seed, seconds, noise = args
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    record = simulate_record(params, seconds=seconds, seed=seed, preset='sequence',
                             config=_config(noise, params, seed))
    held_out = held_out_set(params, seed=0, config=_config(noise, params, 99))
    checkpoints = tuple(s for s in CHECKPOINTS_S if s <= seconds)
    if method == 'regressor':
        return list(regressor_curves(record, held_out, seed=seed, checkpoints=checkpoints))
    return [network_curve(record, held_out, params, method=method, trainer=trainer, seed=seed,
                          checkpoints=checkpoints)]


def main() -> int:
    """Run the curves, print the table, write the figure."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seeds', type=int, default=5)
    parser.add_argument('--seconds', type=float, default=120.0)
    parser.add_argument('--methods', nargs='+', default=['ffs', 'ffw', 'ffmw'])
    parser.add_argument('--trainers', nargs='+', default=['lm', 'bp'])
    parser.add_argument('--noise', action='store_true')
    parser.add_argument('--figure', type=Path, default=None)
    parser.add_argument('--workers', type=int, default=2)
    args = parser.parse_args()
    jobs = [('regressor', '', seed, args.seconds, args.noise) for seed in range(args.seeds)]
    jobs += [(m, t, seed, args.seconds, args.noise) for t in args.trainers
             for m in args.methods for seed in range(args.seeds)]
    started = time.monotonic()
    with ProcessPoolExecutor(args.workers) as pool:
        curves = [curve for result in pool.map(_job, jobs) for curve in result]
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    floor = None
    if args.noise:
        held_out = held_out_set(params, seed=0, config=_config(True, params, 99))
        effort_std = params.array('effort_max') * EFFORT_NOISE_FRACTION
        floor = effort_std ** 2 / held_out.Y.var(axis=0)
    order = {label: i for i, label in enumerate(
        ['LS', 'RLS'] + [f'{m.upper()} {t}' for t in args.trainers for m in args.methods])}
    curves.sort(key=lambda c: (order.get(c.label, 99), c.seed))
    kind = 'with sensor noise' if args.noise else 'no noise'
    print(f'### Learning curves, {kind}: {args.seconds:g} s of `sequence` stream, '
          f'{args.seeds} seeds (load average {os.getloadavg()[0]:.1f}, '
          f'{time.monotonic() - started:.0f} s)\n')
    print(curves_markdown(curves, noise_floor=floor))
    figure = args.figure or HERE.parent / 'docs' / (
        'learning_curves_noise.png' if args.noise else 'learning_curves.png')
    from scara_ident_ros.offline.figures import plot_learning_curves
    plot_learning_curves(figure, curves, f'Frozen models on motions never seen ({kind})',
                         floor)
    print(f'\nfigure: {figure}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
