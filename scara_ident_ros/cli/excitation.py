"""``scara-ident excitation --dry-run``: the excitation a real arm would get, moving nothing.

Plans, as the ``excitation`` node does, the approach from ``--start`` (default: the middle
of each range) to the sequence excitation, ``--seconds`` of it and the stop to rest, for the
joints and limits of a URDF with the node's margins; checks every sample (``--point-period``)
against the limits with margins; writes the samples to ``OUTPUT/excitation.csv`` (time, then
q, q', q'' of each joint, SI) and a figure to ``OUTPUT/excitation.png``; prints the peaks as
fractions of the robot's limits. With ``--optimize`` the excitation is not the random
sequence but the periodic Fourier motion (``--harmonics``, ``--period``) optimised within
the same limits for the physical model to predict other motion
(:mod:`~scara_ident_ros.excitation.optimized_excitation`, at most ``--max-seconds`` of
optimisation; its links kept apart where the URDF has collision geometry); it prints the
regressor's condition number over ``--seconds`` of it against the random sequence's over
the same length. A URDF without limits, a start outside
the limits or a plan outside the margins ends it with one line and exit status 2. To move
the arm, run the node:
``ros2 run scara_ident_ros excitation --ros-args -p urdf_file:=...`` (docs/real_robot.md).
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from scara_ident_ros.cli import CliError

if TYPE_CHECKING:
    from scara_ident_ros.dynamics.joint_limits import JointLimits
    from scara_ident_ros.excitation import ExcitationPlan

__all__ = ['add_parser', 'run']


def _floats(text: str) -> list[float]:
    return [float(item) for item in text.replace(',', ' ').split()]


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident excitation``, with the node's defaults."""
    from scara_ident_ros.excitation import LoopSettings
    from scara_ident_ros.excitation.optimized_excitation import (DEFAULT_HARMONICS,
                                                                 DEFAULT_PERIOD)

    node = LoopSettings()
    parser = subparsers.add_parser(
        'excitation', help="plan a real arm's excitation and check it (--dry-run)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--dry-run', action='store_true', required=True,
                        help='plan, check and write; move nothing (required)')
    parser.add_argument('--urdf', type=Path, required=True, help="the arm's URDF file")
    parser.add_argument('--joint-names', default='',
                        help='comma-separated joints to excite (default: every limited one)')
    parser.add_argument('--robot-config', default='',
                        help='robot YAML with acceleration_max by joint name '
                             '(default: config/scara.yaml)')
    parser.add_argument('--acceleration-max', type=_floats, default=[],
                        help='comma-separated acceleration limits of --joint-names')
    parser.add_argument('--start', type=_floats, default=None,
                        help='comma-separated start positions (default: mid-range)')
    parser.add_argument('--seconds', type=float, default=30.0,
                        help='seconds of excitation after the approach (default 30)')
    parser.add_argument('--seed', type=int, default=node.seed, help='seed of the sequence')
    parser.add_argument('--position-margin', type=float, default=node.position_margin,
                        help='fraction of each range kept clear at both ends (default '
                             '%(default)s)')
    parser.add_argument('--velocity-scale', type=float, default=node.velocity_scale,
                        help='fraction of the velocity limits (default %(default)s)')
    parser.add_argument('--acceleration-scale', type=float, default=node.acceleration_scale,
                        help='fraction of the acceleration limits (default %(default)s)')
    parser.add_argument('--point-period', type=float, default=node.point_period,
                        help='seconds between two samples (default %(default)s)')
    parser.add_argument('--optimize', action='store_true',
                        help='the Fourier motion optimised to predict other motion (least '
                             'variance of the physical model\'s efforts, well-conditioned '
                             'regressor) instead of the random sequence')
    parser.add_argument('--harmonics', type=int, default=DEFAULT_HARMONICS,
                        help='--optimize: harmonics per joint (default %(default)s)')
    parser.add_argument('--period', type=float, default=DEFAULT_PERIOD,
                        help='--optimize: base period in seconds (default %(default)s)')
    parser.add_argument('--max-seconds', type=float, default=120.0,
                        help='--optimize: time budget of the optimisation (default '
                             '%(default)s s)')
    parser.add_argument('--output', type=Path, default=Path('excitation'),
                        help='directory for excitation.csv and excitation.png')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Plan, check, write and summarise."""
    from scara_ident_ros.dynamics.joint_limits import LimitsError
    from scara_ident_ros.excitation import ExcitationPlan, load_motion_limits, make_chunk

    if not args.seconds > 0 or not 0.0 < args.point_period <= 0.1:
        raise CliError('--seconds must be > 0 and --point-period in (0, 0.1]')
    names = [name for name in args.joint_names.split(',') if name]
    try:
        limits = load_motion_limits(urdf_file=str(args.urdf), joint_names=names,
                                    robot_config=args.robot_config,
                                    acceleration_max=args.acceleration_max)
        margined = limits.with_margins(args.position_margin, args.velocity_scale,
                                       args.acceleration_scale)
    except LimitsError as exc:
        raise CliError(str(exc)) from None
    start = limits.centre if args.start is None else np.array(args.start, dtype=float)
    if start.shape != (limits.n_joints,):
        raise CliError(f'--start needs {limits.n_joints} positions ({list(limits.names)}), '
                       f'got {start.size}')
    outside = limits.outside(start)
    if outside:
        raise CliError(f'the start is outside the limits: {", ".join(outside)}')
    plan = ExcitationPlan(margined, start, seed=args.seed)
    if args.optimize:
        plan = _optimized_plan(args, margined, start, plan)
    chunk = make_chunk(plan, 0.0, plan.approach_duration + args.seconds, args.point_period,
                       margined)
    broken = margined.violations(chunk.q, chunk.qd, chunk.qdd, position_hull=start)
    if broken:
        raise CliError(f'the plan leaves the limits with margins: {"; ".join(broken)}')
    args.output.mkdir(parents=True, exist_ok=True)
    csv = args.output / 'excitation.csv'
    header = ','.join(['t'] + [f'{kind}_{name}' for kind in ('q', 'qd', 'qdd')
                               for name in limits.names])
    np.savetxt(csv, np.column_stack([chunk.times, chunk.q, chunk.qd, chunk.qdd]),
               delimiter=',', header=header, comments='', fmt='%.9g')
    figure = args.output / 'excitation.png'
    _plot(figure, chunk.times, (chunk.q, chunk.qd, chunk.qdd), limits, margined,
          (plan.approach_duration, chunk.stop_time))
    what = 'optimised' if args.optimize else 'random sequence'
    print(f'{len(chunk)} samples every {args.point_period:g} s: approach '
          f'{plan.approach_duration:g} s, excitation {args.seconds:g} s ({what}, seed '
          f'{args.seed}), '
          f'stop {chunk.rest_time - chunk.stop_time:g} s; within the limits with margins')
    print('peak |q\'| / velocity limit:     ' + _fractions(chunk.qd, limits.velocity_max))
    print('peak |q\'\'| / acceleration limit: ' + _fractions(chunk.qdd, limits.acceleration_max))
    print(f'wrote {csv} and {figure}')
    return 0


def _optimized_plan(args: argparse.Namespace, margined: JointLimits, start: np.ndarray,
                    random: ExcitationPlan) -> ExcitationPlan:
    """The plan of the optimised excitation; prints its condition number and the random
    sequence's (``random``) over ``--seconds``."""
    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from scara_ident_ros.errors import ScaraIdentError
    from scara_ident_ros.excitation import ExcitationPlan
    from scara_ident_ros.excitation.optimized_excitation import (optimize_excitation,
                                                                 plan_condition)
    from scara_ident_ros.excitation.self_collision import self_collision

    if args.harmonics < 1 or not args.period > 0 or not args.max_seconds > 0:
        raise CliError('--harmonics must be >= 1, --period and --max-seconds > 0')
    try:
        model = PhysicalModel.from_urdf_file(args.urdf, joint_names=list(margined.names))
        collision = self_collision(args.urdf, margined.names, margined.centre)
        found = optimize_excitation(model, margined, seed=args.seed,
                                    n_harmonics=args.harmonics, period=args.period,
                                    max_seconds=args.max_seconds, collision=collision)
        plan = ExcitationPlan(margined, start, seed=args.seed, excitation=found)
    except ScaraIdentError as exc:
        raise CliError(str(exc)) from None
    print(f'optimised {args.harmonics} harmonics of a {args.period:g} s period in '
          f'{found.seconds:.0f} s ({found.iterations} iterations): condition number '
          f'{found.start_condition:.4g} at the seeded start, {found.condition:.4g} at the end')
    print('self-collision: no collision geometry in the URDF, not checked' if collision is None
          else f'self-collision: {collision.n_pairs} pairs of links checked along the motion; '
               + found.collision_summary())
    ours = plan_condition(plan, model, args.seconds, args.point_period)
    theirs = plan_condition(random, model, args.seconds, args.point_period)
    print(f'condition number of the physical model\'s regressor over {args.seconds:g} s of '
          f'excitation: optimised {ours:.4g}, random sequence {theirs:.4g} '
          f'(ratio {ours / theirs:.2f})')
    return plan


def _fractions(values: np.ndarray, limit: np.ndarray) -> str:
    return ', '.join(f'{x:.2f}' for x in np.abs(values).max(axis=0) / limit)


def _plot(path: Path, t: np.ndarray, motion: tuple[np.ndarray, ...], limits: JointLimits,
          margined: JointLimits, marks: tuple[float, float]) -> None:
    """q, q', q'' of each joint against time, with the limits and their margins."""
    import matplotlib
    matplotlib.use('Agg', force=True)
    import matplotlib.pyplot as plt

    names = limits.names
    rows = len(names)
    fig, axes = plt.subplots(rows, 3, figsize=(12, 1.8 * rows + 0.6), sharex=True,
                             squeeze=False)
    bounds = {0: ('position_min', 'position_max'), 1: ('velocity_max',),
              2: ('acceleration_max',)}
    for j, name in enumerate(names):
        for col, (label, values) in enumerate(zip(('q', "q'", "q''"), motion)):
            ax = axes[j, col]
            ax.plot(t, values[:, j], lw=0.8)
            for source, style in ((limits, 'r-'), (margined, 'r--')):
                for key in bounds[col]:
                    level = getattr(source, key)[j]
                    ax.axhline(level, color=style[0], ls=style[1:], lw=0.6)
                    if col:
                        ax.axhline(-level, color=style[0], ls=style[1:], lw=0.6)
            for mark in marks:
                ax.axvline(mark, color='0.6', lw=0.6)
            ax.set_ylabel(f'{name} {label}', fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel('plan time [s]')
    fig.suptitle('excitation plan: approach | excitation | stop (red: limits, dashed: '
                 'margins)',
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
