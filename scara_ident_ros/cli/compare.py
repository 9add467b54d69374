"""``scara-ident compare``: the paper's comparison of FFMW, FFW and FFS on simulated data,
or on a recording (``--recording``) with held-out validation blocks.

Argument parsing only; the comparison is :mod:`scara_ident_ros.paper.comparison`.
"""
from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from scara_ident_ros.cli import CliError
from scara_ident_ros.cli.validation_options import (add_validation_options,
                                                    check_validation_options)
from scara_ident_ros.paper.table2 import DEFAULT_GOAL
from scara_ident_ros.paper.table3 import DEFAULT_WINDOW
from scara_ident_ros.paper.tables import PAPER_ITERATIONS
from scara_ident_ros.nn.presets import METHODS
from scara_ident_ros.paper import comparison
from scara_ident_ros.paper.comparison import CompareSettings, run_comparison
from scara_ident_ros.sim import TRAJECTORIES

__all__ = ['DEFAULTS', 'DEFAULT_WALL_TIME', 'QUICK', 'add_parser', 'main', 'run']

#: Settings of the default run (each is a command-line option of the same name).
DEFAULTS: dict[str, Any] = {
    'seeds': 5, 'train_seconds': 60.0, 'test_seconds': 20.0, 'online_seconds': 60.0,
    'search_seconds': 10.0, 'iterations': PAPER_ITERATIONS, 'samples': 1000,
    'window': DEFAULT_WINDOW, 'curve_seconds': 120.0,
}
#: Settings of ``--quick`` (explicit options still win).
QUICK: dict[str, Any] = {
    'seeds': 2, 'train_seconds': 4.0, 'test_seconds': 2.0, 'online_seconds': 4.0,
    'search_seconds': 2.0, 'iterations': 5, 'samples': 200, 'window': 1000,
    'curve_seconds': 2.0,
}
#: Help of the options ``DEFAULTS`` sets, ``{}`` their default.
_HELP = {
    'seeds': 'network seeds 0..N-1 per method (default {})',
    'train_seconds': 'training run used offline, s (default {:g})',
    'test_seconds': 'held-out run, s (default {:g})',
    'online_seconds': 'online stream, s at 1 kHz (default {:g})',
    'search_seconds': 'start of the stream used by the hyperparameter search, s (default {:g})',
    'iterations': 'LM iterations (default {}, as the paper)',
    'samples': 'training samples for LM (default {})',
    'window': 'samples of the longer online error window (default {})',
    'curve_seconds': 'seconds of stream of the learning curves (default {:g}; 0: no curves)',
}
#: How long ``scara-ident compare`` takes with the defaults, roughly (figures with their
#: conditions: docs/results.md, "The paper's Tables 2 and 3").
DEFAULT_WALL_TIME = ('a few minutes without the learning curves (--curve-seconds 0); the '
                     'learning curves add about a quarter of an hour')


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident compare``."""
    parser = subparsers.add_parser(
        'compare', help="reproduce the paper's Tables 2 and 3 on simulated data or a "
                        'recording',
        description=comparison.__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    for key, default in DEFAULTS.items():  # the type of each option is its default's
        parser.add_argument(f'--{key.replace("_", "-")}', type=type(default), default=None,
                            help=_HELP[key].format(default))
    parser.add_argument('--goal', type=float, default=DEFAULT_GOAL,
                        help='LM goal: training MSE of outputs scaled to [-1, 1] '
                             f'(default {DEFAULT_GOAL:g})')
    parser.add_argument('--acceleration', choices=('true', 'estimated'), default='true',
                        help="q'' of the offline data: the simulator's or estimated from q' "
                             '(default true)')
    parser.add_argument('--methods', nargs='+', choices=list(METHODS), default=list(METHODS),
                        help='methods to compare (default all three)')
    parser.add_argument('--preset', choices=sorted(TRAJECTORIES), default='standard',
                        help='excitation preset, or sequence: a new random excitation every '
                             '5 s (default standard)')
    parser.add_argument('--train-seed', type=int, default=0,
                        help='excitation seed of the training run (default 0)')
    parser.add_argument('--test-seed', type=int, default=1,
                        help='excitation seed of the held-out run (default 1)')
    parser.add_argument('--no-search', dest='search', action='store_false',
                        help='skip the grid search; use the METHODS defaults')
    parser.add_argument('--recording', metavar='FILE', default=None,
                        help='compare on this recording instead of simulated data: anything '
                             'train reads (rosbag2 or ROS 1 bag, CSV export, .npz/CSV table, '
                             'FILE.npz:SPLIT); held-out: its validation blocks; '
                             '--train-seconds and --online-seconds default to the whole '
                             'training part')
    parser.add_argument('--topic', default=None,
                        help='JointState topic of a bag (default: the only one, or '
                             '/joint_states); with --recording')
    parser.add_argument('--joints', nargs='+', default=None, metavar='NAME',
                        help='joints to compare on, in this order (default all); with '
                             '--recording')
    add_validation_options(parser)
    parser.add_argument('--quick', action='store_true',
                        help='tiny sizes for tests: ' + ', '.join(
                            f'{k.replace("_", "-")} {v:g}' for k, v in QUICK.items()))
    parser.add_argument('--out', type=Path, default=Path('out/compare'),
                        help='output directory (default out/compare)')
    parser.set_defaults(func=run)


def _settings(args: argparse.Namespace) -> CompareSettings:
    base = dict(QUICK if args.quick else DEFAULTS)
    recording = args.recording is not None
    if recording:  # the whole training part unless limited
        base.update(train_seconds=math.inf, online_seconds=math.inf)
        check_validation_options(args)
        if args.validation_fraction == 0.0:
            raise CliError('--validation-fraction must be > 0 with --recording: the held-out '
                           'part is the validation blocks')
    elif args.topic is not None or args.joints is not None:
        raise CliError('--topic and --joints need --recording')
    s = {k: (getattr(args, k) if getattr(args, k) is not None else v) for k, v in base.items()}
    for key in ('train_seconds', 'test_seconds', 'online_seconds', 'search_seconds'):
        if not (s[key] > 0.0 and (math.isfinite(s[key]) or recording)):
            raise CliError(f'--{key.replace("_", "-")} must be > 0, got {s[key]}')
    if not (math.isfinite(s['curve_seconds']) and s['curve_seconds'] >= 0.0):
        raise CliError(f'--curve-seconds must be >= 0, got {s["curve_seconds"]}')
    for key in ('seeds', 'iterations', 'samples', 'window'):
        if s[key] < 1:
            raise CliError(f'--{key} must be >= 1, got {s[key]}')
    if s['search_seconds'] > s['online_seconds']:
        raise CliError('--search-seconds must not exceed --online-seconds (the search uses '
                       'the start of the stream)')
    if not args.goal >= 0.0:
        raise CliError(f'--goal must be >= 0, got {args.goal}')
    if args.train_seed == args.test_seed and not recording:
        raise CliError('--train-seed and --test-seed must differ (held-out data must be '
                       'another excitation)')
    return CompareSettings(**s, goal=args.goal, acceleration=args.acceleration,
                           methods=tuple(args.methods), preset=args.preset,
                           train_seed=args.train_seed, test_seed=args.test_seed,
                           search=args.search, quick=args.quick, out=args.out,
                           recording=args.recording, topic=args.topic,
                           joints=tuple(args.joints) if args.joints else None,
                           validation_fraction=args.validation_fraction,
                           validation_block=args.validation_block)


def run(args: argparse.Namespace) -> int:
    """Run the comparison, print the tables, write the files; return the exit status."""
    print(run_comparison(_settings(args), progress=_log), end='')
    return 0


def _log(message: str) -> None:
    print(f'compare: {message}', file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``scara-ident compare`` with ``argv`` (for ``python -m``)."""
    from scara_ident_ros.cli import main as cli_main

    return cli_main(['compare', *(sys.argv[1:] if argv is None else argv)])


if __name__ == '__main__':
    sys.exit(main())
