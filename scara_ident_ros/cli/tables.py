"""``scara-ident tables``: the paper's Tables 2-3 and Figures 6-15 from recorded runs.

BAG is a recording of ``scara-ident run`` (or any bag with JointState messages with
effort): /joint_states and, per method, /<m>/identified_torque (the identifier's a-priori
predictions, stamped like their input) and /<m>/identification_mse. MORE_BAGS are
held-out runs (other excitations) evaluated by the offline models.

Table 2 analog (offline): each method's 3n-40-n network retrained from --seeds seeds with
Levenberg-Marquardt for --iterations iterations on --samples random samples of BAG's
training blocks (the validation blocks of scara-ident train). MSE and normalised MSE (MSE /
variance of each joint's effort) on the training samples, the validation blocks and
MORE_BAGS, iterations to the goal, training time: median [min-max] over seeds.
Table 3 analog (online): what the identifiers published during the run, paired by stamp
with /joint_states: error over the last 100 samples (the paper's figure), over the last
5000, and over the whole run. Figures: measured vs identified effort per joint and method
(online and offline; the paper's Figs 6-13), offline MSE per iteration (Fig. 14), online
error against time (Fig. 15). All written to DIR: report.md, table2_offline.csv,
table3_online.csv and PNG files. The paper's numbers are printed beside ours; it does not
state its data scaling, so compare the normalised MSE and the ranking.

Time: a couple of minutes for a 60 s run, most of it LM training (docs/results.md);
--time-budget stops starting rounds of seeds once the next would exceed it.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from scara_ident_ros.cli import CliError
from scara_ident_ros.cli.recording_options import RECORDING_HELP
from scara_ident_ros.cli.validation_options import (add_validation_options,
                                                     check_validation_options)
from scara_ident_ros.identification.split import SplitError
from scara_ident_ros.nn.presets import METHODS
from scara_ident_ros.paper.report import (DEFAULT_SAMPLES, DEFAULT_SEEDS, DEFAULT_TIME_BUDGET_S,
                                          make_report)
from scara_ident_ros.paths import unwritable_dir

__all__ = ['add_parser', 'make_report', 'run']


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident tables``."""
    parser = subparsers.add_parser(
        'tables', help="the paper's Tables 2-3 and Figures 6-15 from recorded runs",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('bags', type=Path, nargs='+', metavar='BAG',
                        help='the run to analyse, then any held-out runs (MORE_BAGS); each '
                             'a recording of any kind (a ROS 1 bag or a table has no online '
                             'results: Table 3 is then empty): ' + RECORDING_HELP)
    parser.add_argument('--out', type=Path, required=True, metavar='DIR',
                        help='output directory (created; its files are overwritten)')
    parser.add_argument('--methods', nargs='+', default=list(METHODS), choices=list(METHODS),
                        help='methods (default: all three)')
    parser.add_argument('--seeds', type=int, default=DEFAULT_SEEDS,
                        help=f'seeds 0..N-1 of the initial weights per method '
                             f'(default: {DEFAULT_SEEDS})')
    parser.add_argument('--iterations', type=int, default=315,
                        help="LM iterations (default: 315, the paper's)")
    parser.add_argument('--samples', type=int, default=DEFAULT_SAMPLES,
                        help=f'training samples drawn at random from the run for LM '
                             f'(default: {DEFAULT_SAMPLES}; 0: all)')
    add_validation_options(parser)
    parser.add_argument('--time-budget', type=float, default=0.0, metavar='SECONDS',
                        help='start no new round of seeds after this much offline training '
                             f'(default: 0, no limit; scara-ident run uses '
                             f'{DEFAULT_TIME_BUDGET_S:g})')
    parser.add_argument('--topic', default=None,
                        help='JointState topic of the measurements (default: /joint_states '
                             'or the only one)')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Make the report; print where it is."""
    if args.seeds < 1 or args.iterations < 1 or args.samples < 0 or args.time_budget < 0:
        raise CliError('need --seeds >= 1, --iterations >= 1, --samples >= 0 and '
                       '--time-budget >= 0')
    check_validation_options(args)
    problem = unwritable_dir(args.out)
    if problem:
        raise CliError(f'--out {args.out} {problem}')
    try:
        report = make_report(list(args.bags), args.out, methods=args.methods,
                             seeds=args.seeds, iterations=args.iterations,
                             samples=args.samples, validation_fraction=args.validation_fraction,
                             validation_block_s=args.validation_block, topic=args.topic,
                             time_budget_s=args.time_budget or None)
    except SplitError as exc:
        raise CliError(f'{args.bags[0]}: {exc}; lower --validation-block or give '
                       '--validation-fraction 0') from None
    print(f'report: {report}')
    return 0
