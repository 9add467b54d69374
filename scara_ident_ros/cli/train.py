"""``scara-ident train``: train a network offline from the joint states of a bag.

Reads sensor_msgs/JointState messages from any rosbag2 bag (MCAP or sqlite3, recorded by
this project or not) or a bare .mcap file, turns them into network samples exactly as the
online identifier does (the same sample checks; q'' estimated from q' by the identifier's
default differentiator, a 50 Hz low-pass of the backward difference, over the stamps in
order; warm-up samples dropped), splits them BY TIME (the last --validation-fraction of
the recording validates: early stopping after 6 failures, best-validation weights kept),
and trains the method's 3n-40-n network with Levenberg-Marquardt (or batch gradient
descent). The input and output scaling is fitted to the training data's ranges.

The saved model (.npz, FeedForwardNet.save) records metadata joint_names and method, so
the identifier node can warm-start from it (parameter model_path).

Time: one LM iteration costs about 15 ms plus 12 ms per 1000 training samples on one core
(BLAS is held to one thread), so 315 iterations take about 10 s on 1000 samples and about
3 minutes on all 48000 training samples of a 60 s bag at 1 kHz (--samples 2000: ~15 s).
A progress bar goes to stderr, the errors on the training and validation data to stdout.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from scara_ident_ros.cli import CliError
from scara_ident_ros.methods import METHODS, make_network
from scara_ident_ros.nn import ALGORITHMS

__all__ = ['add_parser', 'run']


def add_parser(subparsers: argparse._SubParsersAction) -> None:
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
    parser.add_argument('--iterations', type=int, default=315,
                        help='iteration limit (default: 315, the paper\'s Table 2)')
    parser.add_argument('--goal', type=float, default=0.0,
                        help='stop when the training MSE of the outputs scaled to [-1, 1] '
                             'is at most this (default: 0, run to the limit)')
    parser.add_argument('--topic', default=None,
                        help='JointState topic (default: the only one, or /joint_states)')
    parser.add_argument('--joints', nargs='+', default=None, metavar='NAME',
                        help='joints to model, in this order (default: all, as in the '
                             'messages)')
    parser.add_argument('--validation-fraction', type=float, default=0.2,
                        help='last fraction of the recording\'s time used for validation '
                             '(default: 0.2; 0: none)')
    parser.add_argument('--samples', type=int, default=0,
                        help='train on at most this many samples drawn at random from the '
                             'training part (default: 0, all)')
    parser.add_argument('--seed', type=int, default=0,
                        help='seed of the initial weights and of --samples (default: 0)')
    parser.add_argument('--out', type=Path, required=True, metavar='MODEL',
                        help='model file to write (.npz)')
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Train and save; print the errors on the training and validation data."""
    from scara_ident_ros.bag import BagError
    from scara_ident_ros.offline.blas_threads import single_blas_thread
    from scara_ident_ros.offline.dataset import time_split
    from scara_ident_ros.offline.evaluation import errors_markdown, evaluate
    from scara_ident_ros.offline.progress import TrainingProgress
    from scara_ident_ros.offline.recording import RecordingError, load_recording, skipped_text

    if args.iterations < 1:
        raise CliError(f'--iterations must be at least 1, got {args.iterations}')
    if not 0.0 <= args.validation_fraction < 1.0:
        raise CliError(f'--validation-fraction must be in [0, 1), got '
                       f'{args.validation_fraction}')
    if args.samples < 0 or args.seed < 0 or args.goal < 0.0:
        raise CliError('--samples, --seed and --goal must not be negative')
    if args.out.is_dir():
        raise CliError(f'--out {args.out} is a directory; give a file name such as model.npz')
    try:
        recording = load_recording(args.bag, topic=args.topic, joints=args.joints)
    except (BagError, RecordingError) as exc:
        raise CliError(str(exc)) from None
    samples = recording.samples
    names = samples.names
    train, validation = time_split(samples.data, args.validation_fraction)
    if len(train) < 2:
        raise CliError(f'{args.bag}: only {len(train)} training samples before the '
                       f'validation part; lower --validation-fraction')
    if args.samples:
        train = train.subsample(args.samples, seed=args.seed, name='train')
    print(f'scara-ident train: {args.bag} {recording.topic}: {len(samples.data)} samples '
          f'of {len(names)} joints {list(names)} over {samples.data.seconds:.1f} s '
          f'(skipped: {skipped_text(samples)}); training on {len(train)}, validating on '
          f'{len(validation)}', flush=True)

    network = make_network(args.method, len(names), seed=args.seed)
    progress = TrainingProgress(args.iterations, label=f'{args.method.upper()} {args.algorithm}')
    started = time.perf_counter()
    with single_blas_thread():
        history = network.fit(
            train.X, train.Y, algorithm=args.algorithm, iterations=args.iterations,
            goal=args.goal,
            validation=(validation.X, validation.Y) if len(validation) else None,
            callback=progress)
    progress.close()
    seconds = time.perf_counter() - started

    network.metadata.update({
        'joint_names': np.array(names), 'method': np.array(args.method),
        'algorithm': np.array(args.algorithm), 'iterations': np.array(history.iterations),
        'stop_reason': np.array(history.stop_reason), 'seed': np.array(args.seed),
        'source_bag': np.array(str(args.bag)), 'topic': np.array(recording.topic),
        'train_samples': np.array(len(train)),
        'validation_fraction': np.array(args.validation_fraction),
        'differentiator': np.array('lowpass'), 'cutoff_hz': np.array(50.0),
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
