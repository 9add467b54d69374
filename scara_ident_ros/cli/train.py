"""``scara-ident train``: train a network offline from the joint states of a bag.

Reads sensor_msgs/JointState messages from any rosbag2 bag (MCAP or sqlite3, recorded by
this project or not) or a bare .mcap file, turns them into network samples exactly as the
online identifier does (its input stage: the same sample checks; q'' from q' by the
zero-phase centred estimate, a quadratic fitted to the 21 velocities around each sample at
their stamps), and trains the method's 3n-40-n network with
Levenberg-Marquardt (or batch gradient descent). The input and output scaling is fitted to
the training data's ranges.

Validation: the recording is cut into blocks of --validation-block seconds (1 s) and 20 %
of them (--validation-fraction), one drawn from each stretch of 5 blocks, validate: spread
over the whole recording, they see every excitation it holds. Whole blocks, not single
samples: neighbouring samples at 1 kHz are nearly identical, a random split would validate
on the training data. Training uses 8000 samples (--samples) drawn at random from the
other blocks and runs at most 500 iterations (--iterations); it stops early when the
validation error has not reached a new best for 50 iterations in a row (--max-fail),
counted from iteration 50 on (--min-iterations), and keeps the weights of the best
validation error. Levenberg-Marquardt often raises the validation error for tens of
iterations (once, measured, 170) before lowering it by orders of magnitude; a short
patience (MATLAB's 6) stops it there.

The network starts with friction steps (--friction-steps, as the identifier's lm trainer:
up to 5 hidden units per joint, at most half the hidden units, begin as steps of its
speed at 0, the shape of Coulomb friction).

Measured (benchmarks/bench_train_defaults.py: FFS, 80 s of the simulated SCARA's
'sequence' excitation, what scara-ident run records; NMSE on 4 other excitations; seeds
0-5): these defaults give 3.0e-4 on the worst joint (joint 2 in most seeds) in the median
seed, 1.3e-4 to 8.9e-4, in 15-45 s (2 shared cores); without friction steps 7.0e-4, 6.8e-5
to 0.079; the former defaults (the last 20 % of the time validating, a stop after 6
failures, all samples, 315 iterations, no steps) 1e-3 to 0.6 (seeds 0-2), in 35-210 s. On
8 periodic excitations of 10 s (each one closed curve traced twice) the friction steps
make the difference: 2.2e-4 in the median seed (1.1e-4 to 0.013) against 0.87 (0.39 to
1.4) without. Record varied motion.

Time: one LM iteration costs about 15 ms plus 12 ms per 1000 training samples on one core
(BLAS is held to one thread): 500 iterations on 8000 samples take at most about 1 minute,
all 64000 samples of an 80 s bag (--samples 0) about 0.5 s per iteration.
A progress bar goes to stderr, the errors on the training and validation data to stdout.

The saved model (.npz, FeedForwardNet.save) records metadata joint_names and method, so
the identifier node can warm-start from it (parameter model_path).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from scara_ident_ros.cli import CliError
from scara_ident_ros.methods import METHODS, make_network
from scara_ident_ros.nn import ALGORITHMS
from scara_ident_ros.paths import unwritable_file

__all__ = ['FRICTION_STEPS', 'ITERATIONS', 'MAX_FAIL', 'MIN_ITERATIONS', 'SAMPLES',
           'VALIDATION_BLOCK_S', 'add_parser', 'run']

#: Defaults of the options, chosen with benchmarks/bench_train_defaults.py (module docstring).
ITERATIONS = 500           # Levenberg–Marquardt iterations at most
SAMPLES = 8000             # training samples drawn from the training blocks
VALIDATION_BLOCK_S = 1.0   # s, length of the validation time blocks
MAX_FAIL = 50              # validation failures in a row that stop training
MIN_ITERATIONS = 50        # iterations before validation failures count
FRICTION_STEPS = True      # the network starts with friction steps, as the identifier's


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident train``."""
    parser = subparsers.add_parser(
        'train', help='train a network offline from the joint states of a bag',
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('bag', type=Path, metavar='BAG',
                        help='rosbag2 bag directory (MCAP or sqlite3) or .mcap file')
    parser.add_argument('--method', required=True, choices=list(METHODS),
                        help='network: ffmw (MSLOG), ffw (SLOG) or ffs (sigmoid)')
    parser.add_argument('--algorithm', default='lm', choices=list(ALGORITHMS),
                        help='lm: Levenberg-Marquardt (default); gd: batch gradient descent '
                             'with the method\'s learning rate and momentum')
    parser.add_argument('--iterations', type=int, default=ITERATIONS,
                        help=f'iteration limit (default: {ITERATIONS})')
    parser.add_argument('--goal', type=float, default=0.0,
                        help='stop when the training MSE of the outputs scaled to [-1, 1] '
                             'is at most this (default: 0, run to the limit)')
    parser.add_argument('--topic', default=None,
                        help='JointState topic (default: the only one, or /joint_states)')
    parser.add_argument('--joints', nargs='+', default=None, metavar='NAME',
                        help='joints to model, in this order (default: all, as in the '
                             'messages)')
    parser.add_argument('--validation-fraction', type=float, default=0.2,
                        help='fraction of the recording\'s time blocks used for validation, '
                             'one block drawn from each stretch of 1/fraction blocks '
                             '(default: 0.2; 0: none, no early stop)')
    parser.add_argument('--validation-block', type=float, default=VALIDATION_BLOCK_S,
                        metavar='SECONDS',
                        help=f'length of the time blocks (default: {VALIDATION_BLOCK_S:g} s)')
    parser.add_argument('--max-fail', type=int, default=MAX_FAIL,
                        help='stop after this many iterations in a row without a new best '
                             f'validation error (default: {MAX_FAIL})')
    parser.add_argument('--min-iterations', type=int, default=MIN_ITERATIONS,
                        help='validation failures count only after this many iterations '
                             f'(default: {MIN_ITERATIONS})')
    parser.add_argument('--samples', type=int, default=SAMPLES,
                        help='train on at most this many samples drawn at random from the '
                             f'training blocks (default: {SAMPLES}; 0: all)')
    parser.add_argument('--friction-steps', action=argparse.BooleanOptionalAction,
                        default=FRICTION_STEPS,
                        help='start up to 5 hidden units per joint (at most half the hidden '
                             "units) as steps of its speed at 0, the "
                             "shape of Coulomb friction, as the identifier's lm trainer does "
                             '(default: on)')
    parser.add_argument('--seed', type=int, default=0,
                        help='seed of the initial weights and of --samples (default: 0)')
    parser.add_argument('--out', type=Path, required=True, metavar='MODEL',
                        help='model file to write (.npz)')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Train and save; print the errors on the training and validation data."""
    from scara_ident_ros.blas_threads import single_blas_thread
    from scara_ident_ros.offline.evaluation import errors_markdown, evaluate
    from scara_ident_ros.offline.progress import TrainingProgress
    from scara_ident_ros.offline.recording import load_recording, skipped_text
    from scara_ident_ros.offline.split import block_index, block_split

    if args.iterations < 1:
        raise CliError(f'--iterations must be at least 1, got {args.iterations}')
    if not 0.0 <= args.validation_fraction < 1.0:
        raise CliError(f'--validation-fraction must be in [0, 1), got '
                       f'{args.validation_fraction}')
    if not args.validation_block > 0.0:
        raise CliError(f'--validation-block must be positive, got {args.validation_block}')
    if args.max_fail < 1:
        raise CliError(f'--max-fail must be at least 1, got {args.max_fail}')
    if args.samples < 0 or args.seed < 0 or args.goal < 0.0 or args.min_iterations < 0:
        raise CliError('--samples, --seed, --goal and --min-iterations must not be negative')
    problem = unwritable_file(args.out)
    if problem:  # before minutes of training, not after
        raise CliError(f'--out {args.out} {problem}')
    recording = load_recording(args.bag, topic=args.topic, joints=args.joints)
    samples = recording.samples
    names = samples.names
    try:
        train, validation = block_split(samples.data, args.validation_fraction,
                                        block_s=args.validation_block, seed=args.seed)
    except ValueError as exc:
        raise CliError(f'{args.bag}: {exc}; lower --validation-block or give '
                       '--validation-fraction 0') from None
    if len(train) < 2:
        raise CliError(f'{args.bag}: only {len(train)} training samples outside the '
                       f'validation blocks; lower --validation-fraction')
    if args.samples:
        train = train.subsample(args.samples, seed=args.seed, name='train')
    where = ''
    if len(validation):
        start = int(samples.data.stamp_ns[0])
        blocks = np.unique(block_index(validation.stamp_ns, block_s=args.validation_block,
                                       start_ns=start))
        plural = 's' if len(blocks) > 1 else ''
        where = (f' in {len(blocks)} block{plural} of {args.validation_block:g} s from '
                 f'{blocks[0] * args.validation_block:.1f} s to '
                 f'{(blocks[-1] + 1) * args.validation_block:.1f} s')
    print(f'scara-ident train: {args.bag} {recording.topic}: {len(samples.data)} samples '
          f'of {len(names)} joints {list(names)} over {samples.data.seconds:.1f} s '
          f'(skipped: {skipped_text(samples)}); training on {len(train)}, validating on '
          f'{len(validation)}{where}', flush=True)

    network = make_network(args.method, len(names), seed=args.seed,
                           friction_steps=args.friction_steps)
    progress = TrainingProgress(args.iterations, label=f'{args.method.upper()} {args.algorithm}')
    started = time.perf_counter()
    with single_blas_thread():
        history = network.fit(
            train.X, train.Y, algorithm=args.algorithm, iterations=args.iterations,
            goal=args.goal,
            validation=(validation.X, validation.Y) if len(validation) else None,
            max_fail=args.max_fail, min_iterations=args.min_iterations, callback=progress)
    progress.close()
    seconds = time.perf_counter() - started

    network.metadata.update({
        'joint_names': np.array(names), 'method': np.array(args.method),
        'algorithm': np.array(args.algorithm), 'iterations': np.array(history.iterations),
        'stop_reason': np.array(history.stop_reason), 'seed': np.array(args.seed),
        'source_bag': np.array(str(args.bag)), 'topic': np.array(recording.topic),
        'train_samples': np.array(len(train)),
        'validation_fraction': np.array(args.validation_fraction),
        'validation_block_s': np.array(args.validation_block),
        'max_fail': np.array(args.max_fail), 'min_iterations': np.array(args.min_iterations),
        'differentiator': np.array('centred'), 'window': np.array(21),
        'friction_steps': np.array(args.friction_steps),
        'train_mse_scaled': np.array(history.final_mse)})
    args.out.parent.mkdir(parents=True, exist_ok=True)
    network.save(args.out)

    results = {'train': evaluate(network, train.X, train.Y)}
    if len(validation):
        results['validation'] = evaluate(network, validation.X, validation.Y)
    print(f'\n{args.method.upper()} trained with {args.algorithm.upper()}: '
          f'{history.iterations} iterations in {seconds:.1f} s (stopped: '
          f'{history.stop_reason}; weights of iteration {history.best_iteration})\n')
    print(errors_markdown(names, results))
    print(f'model written to {args.out}')
    return 0
