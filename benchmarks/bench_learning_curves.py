"""Learning curves of online identification: frozen models on motions never seen.

For each seed, ``scara_sim``'s default stream (``trajectory: sequence``, 1 kHz) is simulated
for ``--seconds``; every method (FFMW, FFW, FFS) learns it online with every trainer (``lm``:
the identifier's default, Levenberg-Marquardt steps on a reservoir; ``bp``: the paper's
per-sample back-propagation) through the identifier's own pipeline, and at each checkpoint
its frozen model is scored on held-out excitations (5 ``standard`` ones and 30 s of another
``sequence``, never streamed). LS and RLS on the SCARA's physical regressor, fitted to the
same stream inputs, are the references (``scara_ident_ros.paper.learning_curves``).
``--noise`` adds the simulator's sensor noise (position 1e-4, velocity 1e-3, effort 0.5 % of
its limit) to the stream and the held-out data, and reports the noise floor. ``--robot``
takes ``scara`` (the default), ``ur5`` or ``panda`` (``robot_sim``'s arms with friction and
rotor inertia; LS and RLS are then the physical model of their URDF, ``--stribeck`` with
a Stribeck column; ``--methods hybrid`` the node's ``method:=hybrid``, that model plus an
FFS network of its residual) or another SCARA robot
file (e.g. ``benchmarks/other_scara.yaml``: other masses, lengths, friction, effort limits
and joint names); its limits scale the networks as the node's limit parameters would.

Prints a Markdown table (median [min-max] over seeds of the worst joint's NMSE) and writes a
figure to docs/. Two worker processes, one BLAS thread each.

    .venv/bin/python benchmarks/bench_learning_curves.py [--seeds 5] [--seconds 120] [--noise]
        [--robot scara|ur5|panda|FILE]
"""
from __future__ import annotations

import argparse
import functools
import json
import os
import sys
import time
from pathlib import Path

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.paper.figures import plot_learning_curves
from scara_ident_ros.paper.learning_curves import (ROBOTS, Curve, curves_markdown, held_out_set,
                                                   noise_floor, noisy_config, robot_by_name,
                                                   run_curves)
from scara_ident_ros.resources import config_path

HERE = Path(__file__).resolve().parent


def append_curves(path: Path, curves: list[Curve]) -> None:
    """Append ``curves`` to the JSON-lines file ``path``, one curve a line."""
    with path.open('a', encoding='utf-8') as stream:
        for curve in curves:
            stream.write(json.dumps({'label': curve.label, 'seed': curve.seed,
                                     'seconds': curve.seconds.tolist(),
                                     'nmse': curve.nmse.tolist(), 'cpu_s': curve.cpu_s})
                         + '\n')


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
    parser.add_argument('--lm-steps', type=int, default=2,
                        help="the lm trainer's steps per update (the node's lm_steps)")
    parser.add_argument('--reservoir-size', type=int, default=4000,
                        help="the lm trainer's samples (the node's reservoir_size)")
    parser.add_argument('--no-references', dest='references', action='store_false',
                        help='leave out LS and RLS')
    parser.add_argument('--partial', type=Path, default=None, metavar='FILE.jsonl',
                        help='append each job\'s curves to FILE as it ends (JSON lines)')
    parser.add_argument('--stribeck', action='store_true',
                        help="a URDF arm's physical model (LS, RLS, hybrid) with a Stribeck "
                        "column at the simulator's Stribeck velocity")
    parser.add_argument('--robot', default='scara',
                        help=f'one of {", ".join(ROBOTS)} or a SCARA robot file '
                        '(default: scara, the installed config/scara.yaml)')
    parser.add_argument('--held-out', type=float, nargs=2, default=(6.0, 30.0),
                        metavar=('EXCITATION_S', 'SEQUENCE_S'),
                        help='seconds of each held-out excitation and of the held-out '
                        'sequence')
    args = parser.parse_args()
    name = args.robot if args.robot in ROBOTS else None
    robot_file = None if name else Path(args.robot)
    params = (robot_by_name(name) if name else
              ScaraParams.from_yaml(robot_file or config_path('scara.yaml')))
    job_robot = name if name and name != 'scara' else params
    started = time.monotonic()
    curves = run_curves(job_robot, seeds=range(args.seeds), methods=args.methods,
                        trainers=args.trainers, seconds=args.seconds, noise=args.noise,
                        workers=args.workers, lm_steps=args.lm_steps,
                        reservoir_size=args.reservoir_size,
                        references=args.references, held_out_s=tuple(args.held_out),
                        stribeck=args.stribeck,
                        finished=functools.partial(append_curves, args.partial)
                        if args.partial else None)
    floor = (noise_floor(params, held_out_set(params, config=noisy_config(params, 99)))
             if args.noise else None)
    kind = title = 'with sensor noise' if args.noise else 'no noise'
    if name != 'scara':
        label = name or Path(args.robot).name
        title += f', robot {label}'  # the joints would not fit in the figure's title
        kind = title + f' (joints {", ".join(params.joint_names)})'
    print(f'### Learning curves, {kind}: {args.seconds:g} s of `sequence` stream, '
          f'{args.seeds} seeds (load average {os.getloadavg()[0]:.1f}, '
          f'{time.monotonic() - started:.0f} s)\n')
    print(curves_markdown(curves, noise_floor=floor))
    figure = args.figure or HERE.parent / 'docs' / (
        'learning_curves' + ('_noise' if args.noise else '')
        + ('' if name == 'scara' else f'_{name or Path(args.robot).stem}') + '.png')
    plot_learning_curves(figure, curves, f'Frozen models on motions never seen ({title})',
                         floor)
    print(f'\nfigure: {figure}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
