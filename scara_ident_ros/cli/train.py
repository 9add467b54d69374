"""``scara-ident train``: train a network or a physical model offline from recorded joint states.

Reads sensor_msgs/JointState messages from any rosbag2 bag (MCAP or sqlite3), a bare
.mcap file or a ROS 1 .bag, or the joint states of a table (.npz or CSV with named
columns, a /joint_states CSV export; FILE.npz:SPLIT for a published split, such as
barrett_wam.npz:train), turns them into network samples exactly as the online identifier
does (its input stage: the same sample checks, repeated samples refused, and zero-phase q''
estimate; q' derived from q where the recording has none, q'' as given where a table gives
it; docs/recording_and_retraining.md), and trains the method's
3n-40-n network with Levenberg-Marquardt (or batch gradient descent), scaled to the
training data's ranges.

Validation: the recording is cut into blocks of --validation-block seconds and a
--validation-fraction of them, one drawn from each stretch, validate: spread over the whole
recording, they see every excitation it holds (whole blocks, since neighbouring samples at
1 kHz are nearly identical). Training uses --samples random samples of the other blocks
for at most --iterations; it stops once the validation error has not reached a new best
for --max-fail iterations (counted from --min-iterations) and keeps the best weights: LM
often raises the validation error for tens of iterations before lowering it by orders of
magnitude. The network starts with friction steps (--friction-steps, as the identifier's
lm trainer). The defaults come from benchmarks/bench_train_defaults.py (docs/results.md).
The model predicts the motion it was trained on: record varied motion, as wide as the
motion it is to predict. A progress bar goes to stderr, the errors to stdout.

--method physical: the robot's physical model from its URDF (--urdf, required): base
parameters of the rigid bodies and rotor inertias, viscous and Coulomb friction per joint
fitted by linear least squares on every training sample (--samples does not apply); the
identified parameters are printed. The Coulomb shape (--coulomb auto, the default) is the
one of sign(qd) and tanh(qd/eps), eps 0.005-0.2, whose fit has the lowest validation
NMSE (without validation: tanh with --coulomb-eps); --coulomb tanh or sign imposes one.
Real arms: --offsets adds an effort offset per joint (torque sensors drift), --asymmetric a
Coulomb friction that differs by direction, --coupled J5,J6 the friction of coupled wrist
motors on both joints (the TX40's), --stribeck-velocity a Stribeck term; --consistent (the
default) fits physically consistent parameters (positive masses, inertias a body can have:
a pseudo-inertia LMI per body, solved with cvxpy) as close to least squares as the data
allow, which scara-ident export --urdf writes back as a URDF.
--method hybrid: the physical model, then an FFS network on its residual (output scaling:
the residual's range) with Levenberg-Marquardt on --samples of the training samples, early-
stopped as above on every other validation block; its correction is then scaled per joint
by a factor in [0, 1] fitted on all validation blocks, and kept only on the joints where its
gain, measured block by block, is significant (learners.hybrid_model.gate_scales: a gate per
joint, so that the hybrid is not worse than its physical part). With --urdf, networks (the
hybrid's too) scale their inputs by the URDF's joint limits (positions, velocities; the
accelerations by the training data's largest |q''|) and a network alone its outputs by the
effort limits.

--method gp: exact Gaussian-process regression (learners.exact_gp: one RBF kernel shared by
the joints, its length and noise chosen on blocks of 50 of its first 3000 samples) on at
most 12000 samples (a random draw beyond: O(N^3) time, 8 N^2 bytes). The GP has no early
stop and predicts from the samples it holds, so the validation blocks only score it: the
validation errors printed are those of the GP fitted on the training blocks, and the model
saved is the GP fitted again, its kernel chosen again, on every sample, the validation
blocks too: the validation scores the procedure, as cross-validation does (--validation-
fraction 0: one fit, no validation errors). A published split's training rows
(barrett_wam.npz:train) are thus all learnt, as the published GP learnt them, whether
named as FILE.npz:SPLIT or given as a table of those rows. --method kernel: the
sparse-spectrum GP (random features) on every training sample; --method linear: least
squares of each effort on [q, q', q'', sin q, cos q, tanh(q'/0.05), 1]
(learners.linear_features), the baseline every learner must beat; --method linear_hybrid:
that least squares in place of the physical model of --method hybrid (an FFS network on its
residual, early-stopped and gated per joint the same way), for an arm without a URDF.

--method auto (the default) follows the measurements (docs/results.md): with --urdf, the
hybrid (its gate keeps it no worse than its physical part); without, the best of linear,
linear_hybrid, gp and ffs on the recording itself (linear_hybrid gates its network on the
blocks it early-stops on). The validation blocks are dealt alternately in two: the
network early-stops on the first, every candidate is scored on the second (mean over the
joints of the MSE over the variance of all validation efforts; a single validation block is
cut in its two halves), the best is saved and all scores printed. No learner wins
everywhere: on TIAGo's held-out seconds auto chooses linear (0.54 against GP 0.72, FFS
0.70), on the WAM's linear_hybrid or FFS (0.11-0.13 against linear 0.17-0.18, GP 0.32-0.37;
benchmarks/train_auto.md). The GP
wins the WAM's published split (9.8e-4), whose test rows lie between training rows: for
that, --method gp. The chosen model's validation errors are slightly optimistic (half of
those blocks chose it). --method kernel is not a candidate: with its default features it
scores worse than the linear model on the WAM (SMSE 0.23 against 0.15).
"""
from __future__ import annotations

import argparse
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from scara_ident_ros.cli import CliError
from scara_ident_ros.cli.recording_options import (RECORDING_HELP, recording_note,
                                                    urdf_joints_not_recorded)
from scara_ident_ros.cli.validation_options import (add_validation_options,
                                                     check_validation_options)
from scara_ident_ros.dynamics.physical_model import COULOMB_EPS, COULOMB_MODES
from scara_ident_ros.identification import DIFFERENTIATOR_WINDOW
from scara_ident_ros.identification.split import VALIDATION_BLOCK_S
from scara_ident_ros.nn.presets import METHODS, make_network
from scara_ident_ros.nn import ALGORITHMS
from scara_ident_ros.nn.fitting import ITERATIONS, MAX_FAIL, MIN_ITERATIONS, SAMPLES
from scara_ident_ros.paths import unwritable_file

if TYPE_CHECKING:
    from scara_ident_ros.identification.dataset import Dataset
    from scara_ident_ros.estimator import Estimator
    from scara_ident_ros.nn import FitHistory

__all__ = ['AUTO_CANDIDATES', 'AUTO_METHOD', 'FRICTION_STEPS', 'GP_METHOD', 'GP_SAMPLES',
           'HYBRID_NETWORK', 'ITERATIONS', 'KERNEL_METHOD', 'LINEAR_HYBRID_METHOD',
           'LINEAR_METHOD', 'MAX_FAIL',
           'MIN_ITERATIONS', 'PHYSICAL_METHODS', 'SAMPLES', 'VALIDATION_BLOCK_S', 'add_parser',
           'run']

#: Defaults of the options (ITERATIONS, SAMPLES, MAX_FAIL, MIN_ITERATIONS: those of the
#: models' offline training, nn.fitting), chosen with benchmarks/bench_train_defaults.py.
FRICTION_STEPS = True      # the network starts with friction steps, as the identifier's
#: Models built from a URDF rather than a network alone.
PHYSICAL_METHODS = ('physical', 'hybrid')
#: The sparse-spectrum GP (``learners.sparse_spectrum_gp``): no URDF, no iterations.
KERNEL_METHOD = 'kernel'
#: Exact GP regression (``learners.exact_gp``) on at most GP_SAMPLES training samples.
GP_METHOD = 'gp'
GP_SAMPLES = 12000
#: Least squares on simple features (``learners.linear_features``): the baseline.
LINEAR_METHOD = 'linear'
#: That least squares plus an FFS network of its residual, gated per joint (the hybrid of an
#: arm without a URDF).
LINEAR_HYBRID_METHOD = 'linear_hybrid'
#: Choose by validation (module docstring): the hybrid with a URDF, else the best of
#: AUTO_CANDIDATES.
AUTO_METHOD = 'auto'
AUTO_CANDIDATES = (LINEAR_METHOD, LINEAR_HYBRID_METHOD, GP_METHOD, 'ffs')
HYBRID_NETWORK = 'ffs'     # the hybrid's residual network


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident train``."""
    parser = subparsers.add_parser(
        'train', help='train a network offline from the joint states of a bag',
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('bag', type=Path, metavar='RECORDING',
                        help=RECORDING_HELP)
    parser.add_argument('--method', default=AUTO_METHOD,
                        choices=[AUTO_METHOD, *METHODS, *PHYSICAL_METHODS, KERNEL_METHOD,
                                 GP_METHOD, LINEAR_METHOD, LINEAR_HYBRID_METHOD],
                        help='auto: hybrid with --urdf, else the best of linear, '
                             'linear_hybrid, gp and ffs on validation blocks (default); '
                             'network: ffmw (MSLOG), ffw (SLOG) or ffs (sigmoid); physical: '
                             'least squares on the URDF\'s base parameters and friction; '
                             'hybrid: physical plus an FFS network on its residual; '
                             'kernel: sparse-spectrum GP regression (random features); '
                             'gp: exact GP regression (at most 12000 samples, saved fitted on '
                             'the validation blocks too); linear: least '
                             'squares on [q, dq, ddq, sin q, cos q, tanh(dq/0.05), 1]; '
                             'linear_hybrid: that plus an FFS network on its residual')
    parser.add_argument('--urdf', type=Path, default=None, metavar='ROBOT.urdf',
                        help='the robot\'s URDF: required by physical and hybrid; gives a '
                             'network its limit scaling')
    parser.add_argument('--coulomb', default='auto', choices=['auto', *COULOMB_MODES],
                        help='Coulomb friction shape of physical/hybrid: auto (the best on '
                             'validation of sign and tanh with several eps), tanh(qd/eps) '
                             'or sign(qd) (default: auto)')
    parser.add_argument('--coulomb-eps', type=float, default=COULOMB_EPS, metavar='SPEED',
                        help=f'eps of tanh(qd/eps), rad/s or m/s (default: {COULOMB_EPS:g})')
    parser.add_argument('--offsets', action=argparse.BooleanOptionalAction, default=False,
                        help='physical/hybrid: an effort offset per joint (default: off)')
    parser.add_argument('--asymmetric', action=argparse.BooleanOptionalAction, default=False,
                        help='physical/hybrid: Coulomb friction that differs by direction '
                             '(default: off)')
    parser.add_argument('--coupled', action='append', default=[], metavar='JOINT_A,JOINT_B',
                        help='physical/hybrid: two joints whose motors are coupled (a wrist): '
                             'each gets friction of the other\'s speed; repeatable')
    parser.add_argument('--stribeck-velocity', type=float, default=0.0, metavar='SPEED',
                        help='physical/hybrid: v_s of a Stribeck term per joint, rad/s or m/s '
                             '(default: 0, none)')
    parser.add_argument('--consistent', action=argparse.BooleanOptionalAction, default=True,
                        help='physical/hybrid: physically consistent parameters (pseudo-'
                             'inertia LMI, cvxpy), not plain least squares (default: on)')
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
    add_validation_options(parser, zero='none, no early stop')
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
    from scara_ident_ros.identification.recording import load_recording, skipped_text
    from scara_ident_ros.identification.split import block_index, block_split

    if args.iterations < 1:
        raise CliError(f'--iterations must be at least 1, got {args.iterations}')
    check_validation_options(args)
    if args.max_fail < 1:
        raise CliError(f'--max-fail must be at least 1, got {args.max_fail}')
    if args.samples < 0 or args.seed < 0 or args.goal < 0.0 or args.min_iterations < 0:
        raise CliError('--samples, --seed, --goal and --min-iterations must not be negative')
    if args.method == AUTO_METHOD and args.urdf is not None:
        args.method = 'hybrid'
        print('--method auto with --urdf: hybrid', flush=True)
    if args.method == AUTO_METHOD and args.algorithm != 'lm':
        raise CliError('--method auto trains its network with lm only')
    if args.method in PHYSICAL_METHODS and args.urdf is None:
        raise CliError(f'--method {args.method} needs the robot\'s --urdf')
    if args.method in ('hybrid', LINEAR_HYBRID_METHOD) and args.algorithm != 'lm':
        raise CliError(f'--method {args.method} trains its network with lm only')
    if not args.coulomb_eps > 0.0:
        raise CliError(f'--coulomb-eps must be positive, got {args.coulomb_eps}')
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
    every_train = train  # least squares takes them all
    if args.method != AUTO_METHOD:
        train = _training_rows(args, args.method, every_train)
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
          f'(skipped: {skipped_text(samples)}{recording_note(recording)}); training on '
          f'{len(train)}, validating on '
          f'{len(validation)}{where}', flush=True)

    metadata = {
        'joint_names': np.array(names), 'method': np.array(args.method),
        'seed': np.array(args.seed), 'source_bag': np.array(str(args.bag)),
        'topic': np.array(recording.topic), 'train_samples': np.array(len(train)),
        'validation_fraction': np.array(args.validation_fraction),
        'validation_block_s': np.array(args.validation_block),
        'differentiator': np.array('centred'), 'window': np.array(DIFFERENTIATOR_WINDOW)}
    if args.urdf is not None:
        metadata['urdf_file'] = np.array(str(args.urdf))
        fixed = urdf_joints_not_recorded(args.urdf, names)
        if fixed and args.method in PHYSICAL_METHODS:
            print(f'{args.urdf}: joints not in the recording, held fixed at 0: '
                  f'{", ".join(fixed)}', flush=True)
    if args.method in PHYSICAL_METHODS:
        return _train_physical(args, names, every_train, train, validation, metadata,
                               start_ns=int(samples.data.stamp_ns[0]))
    if args.method == AUTO_METHOD:
        return _train_auto(args, names, every_train, validation, metadata,
                           start_ns=int(samples.data.stamp_ns[0]))
    model, summary = _fit(args, args.method, names, train, validation, every_train,
                          start_ns=int(samples.data.stamp_ns[0]))
    validated = model
    if args.method == GP_METHOD and len(validation):  # saved: the GP of every sample
        train = _training_rows(args, GP_METHOD, samples.data)
        model, refitted = _fit(args, GP_METHOD, names, train, validation, train,
                               start_ns=int(samples.data.stamp_ns[0]))
        metadata['train_samples'] = np.array(len(train))
        summary = (f'{summary}: its errors on the validation blocks are below\nsaved: '
                   f'{refitted}, on every sample (the validation blocks too)')
    model.metadata.update(metadata)
    return _save_and_report(args, model, names, train, validation, summary,
                            validated=validated)


def _training_rows(args: argparse.Namespace, method: str, every_train: Dataset) -> Dataset:
    """The training samples ``method`` fits: all for least squares and the kernel, at most
    GP_SAMPLES for the GP, at most --samples (a random draw) for a network."""
    if method == GP_METHOD:  # whatever --samples says: O(N^3)
        return every_train.subsample(GP_SAMPLES, seed=args.seed, name='train')
    if method in ('physical', KERNEL_METHOD, LINEAR_METHOD, LINEAR_HYBRID_METHOD) \
            or not args.samples:  # the linear hybrid draws its network's samples itself
        return every_train
    return every_train.subsample(args.samples, seed=args.seed, name='train')


def _fit(args: argparse.Namespace, method: str, names: Sequence[str], train: Dataset,
         stop: Dataset, every_train: Dataset, *, start_ns: int,
         gate: Dataset | None = None) -> tuple[Estimator, str]:
    """Fit a model of no URDF's ``method`` (a network, kernel, gp, linear or
    linear_hybrid) to ``train``, a network early-stopped on ``stop`` (if it has samples)
    and, with --urdf, scaled by its limits and ``every_train``'s accelerations; return it,
    with its training recorded in its metadata, and a line saying how it was fitted.

    linear_hybrid gates its network on ``gate`` (in --validation-block blocks from
    ``start_ns``, the recording's first stamp); without, it early-stops on every other
    block of ``stop`` and gates on all of them, as --method hybrid."""
    from scara_ident_ros.blas_threads import single_blas_thread
    from scara_ident_ros.cli.progress import TrainingProgress
    from scara_ident_ros.learners import ExactGP, LinearFeatures, SparseSpectrumGP

    started = time.perf_counter()
    if method == GP_METHOD:
        gp = ExactGP()
        with single_blas_thread():
            gp.fit(train.X, train.Y)
        return gp, (f'GP ({gp.n_points_} samples, length {gp.length_:g}, noise '
                    f'{gp.noise_:g} by validation) fitted in '
                    f'{time.perf_counter() - started:.1f} s')
    if method == KERNEL_METHOD:
        kernel = SparseSpectrumGP(seed=args.seed)
        with single_blas_thread():
            kernel.fit(train.X, train.Y)
        return kernel, (f'KERNEL ({kernel.n_features} random features) fitted in '
                        f'{time.perf_counter() - started:.1f} s')
    if method == LINEAR_METHOD:
        linear = LinearFeatures().fit(train.X, train.Y)
        return linear, (f'LINEAR (least squares on {linear.coef_.shape[0]} features) fitted '
                        f'in {time.perf_counter() - started:.1f} s')
    if method == LINEAR_HYBRID_METHOD:
        return _fit_linear_hybrid(args, names, train, stop, start_ns=start_ns, gate=gate)
    network = make_network(method, len(names), seed=args.seed,
                           friction_steps=args.friction_steps)
    if args.urdf is not None:
        x_min, x_max, y_min, y_max = _limit_ranges(args.urdf, names, every_train.X,
                                                    every_train.Y)
        network.set_scaling(x_min, x_max, y_min, y_max)
    progress = TrainingProgress(args.iterations, label=f'{method.upper()} {args.algorithm}')
    with single_blas_thread():  # the samples and validation blocks are drawn above
        network.fit(train.X, train.Y, validation_fraction=0.0, samples=0,
                    algorithm=args.algorithm, iterations=args.iterations, goal=args.goal,
                    validation=(stop.X, stop.Y) if len(stop) else None,
                    max_fail=args.max_fail, min_iterations=args.min_iterations,
                    callback=progress)
    progress.close()
    history = network.history_
    assert history is not None
    network.metadata.update(_network_metadata(args, history))
    return network, (f'{method.upper()} trained with {args.algorithm.upper()}: '
                     f'{history.iterations} iterations in '
                     f'{time.perf_counter() - started:.1f} s (stopped: '
                     f'{history.stop_reason}; weights of iteration {history.best_iteration})')


def _fit_linear_hybrid(args: argparse.Namespace, names: Sequence[str], train: Dataset,
                       stop: Dataset, *, start_ns: int, gate: Dataset | None
                       ) -> tuple[Estimator, str]:
    """``_fit``'s linear_hybrid: least squares on every sample of ``train``, then an FFS
    network on its residual (--samples of them), early-stopped and gated (``_fit``)."""
    from scara_ident_ros.blas_threads import single_blas_thread
    from scara_ident_ros.cli.progress import TrainingProgress
    from scara_ident_ros.identification.split import alternate_blocks, block_index
    from scara_ident_ros.learners import LinearFeatures
    from scara_ident_ros.learners.hybrid_model import fit_hybrid

    started = time.perf_counter()
    if gate is None:  # as --method hybrid: stop on every other block, gate on all
        gate = stop
        stop, other = alternate_blocks(gate, block_s=args.validation_block, start_ns=start_ns)
        if not len(other):
            stop = gate
    linear = LinearFeatures()
    linear.metadata['joint_names'] = np.array(names)
    network = make_network(HYBRID_NETWORK, len(names), seed=args.seed,
                           friction_steps=args.friction_steps)
    x_range = None
    if args.urdf is not None:
        x_min, x_max, _, _ = _limit_ranges(args.urdf, names, train.X, train.Y)
        x_range = (x_min, x_max)
    progress = TrainingProgress(args.iterations, label=f'LINEAR_HYBRID {HYBRID_NETWORK} lm')
    with single_blas_thread():
        hybrid, history = fit_hybrid(
            linear, network, (train.X, train.Y),
            validation=(stop.X, stop.Y) if len(stop) else None,
            gate_validation=(gate.X, gate.Y) if len(gate) else None,
            gate_groups=(block_index(gate.stamp_ns, block_s=args.validation_block,
                                     start_ns=start_ns) if len(gate) else None),
            x_range=x_range, network_samples=args.samples, seed=args.seed,
            iterations=args.iterations, max_fail=args.max_fail,
            min_iterations=args.min_iterations, callback=progress)
    progress.close()
    hybrid.metadata.update(_network_metadata(args, history))
    hybrid.metadata['network'] = np.array(HYBRID_NETWORK)
    kept = ', '.join(f'{n} (×{g:.2f})' for n, g in zip(names, hybrid.gate) if g)
    return hybrid, (f'LINEAR_HYBRID: least squares on {len(train)} samples, then '
                    f'{HYBRID_NETWORK.upper()} on its residual: {history.iterations} '
                    f'iterations in {time.perf_counter() - started:.1f} s (stopped: '
                    f'{history.stop_reason}; weights of iteration {history.best_iteration}); '
                    f'correction kept on {kept or "no joint"}')


def _train_auto(args: argparse.Namespace, names: Sequence[str], every_train: Dataset,
                validation: Dataset, metadata: dict[str, np.ndarray], *,
                start_ns: int) -> int:
    """``--method auto`` without a URDF: fit each of AUTO_CANDIDATES (a network early-
    stopped on the first of the alternate validation blocks), score each on the second, save
    the best (module docstring). A single validation block is cut in two halves in time."""
    from scara_ident_ros.identification.split import alternate_blocks

    if len(validation) < 2:
        raise CliError(f'{args.bag}: --method auto chooses on validation samples and has '
                       f'{len(validation)}; give a --validation-fraction above 0 or a --method')
    stop, score = alternate_blocks(validation, block_s=args.validation_block,
                                   start_ns=start_ns)
    if not len(score):  # one block: its first half and its second
        half = np.arange(len(validation)) >= len(validation) // 2
        stop, score = validation.take(~half, 'stop'), validation.take(half, 'score')
    # each joint's MSE over the variance of all validation efforts (the table's NMSE): a
    # half's own variance can be near 0 on a joint that barely moves (TIAGo: the linear
    # model's mean 1.6 on one half, 0.37 on both)
    variance = np.maximum(validation.Y.var(axis=0), np.finfo(np.float64).tiny)
    fitted: dict[str, tuple[Estimator, str, float, Dataset]] = {}
    for method in AUTO_CANDIDATES:
        train = _training_rows(args, method, every_train)
        try:
            model, summary = _fit(args, method, names, train, stop, every_train,
                                  start_ns=start_ns, gate=stop)
        except ValueError as exc:  # e.g. too few samples for the GP's kernel choice
            print(f'auto: {method} not fitted: {exc}', flush=True)
            continue
        per_joint = np.mean((model.predict(score.X) - score.Y) ** 2, axis=0) / variance
        nmse = float(np.mean(per_joint))
        if not np.isfinite(nmse):
            print(f'auto: {method} predicts non-finite efforts; not a candidate', flush=True)
            continue
        print(f'auto: {method} mean NMSE {nmse:.4g} on {len(score)} validation samples '
              f'(per joint {", ".join(f"{e:.3g}" for e in per_joint)}; {summary})',
              flush=True)
        fitted[method] = (model, summary, nmse, train)
    if not fitted:
        raise CliError(f'{args.bag}: --method auto fitted none of '
                       f'{", ".join(AUTO_CANDIDATES)} (above); give a --method')
    chosen = min(fitted, key=lambda method: fitted[method][2])
    model, summary, _, train = fitted[chosen]
    metadata['method'] = np.array(chosen)
    metadata['chosen_by'] = np.array(AUTO_METHOD)
    metadata['train_samples'] = np.array(len(train))
    for method, (_, _, nmse, _) in fitted.items():
        metadata[f'auto_nmse_{method}'] = np.array(nmse)
    model.metadata.update(metadata)
    scores = ', '.join(f'{method} {fitted[method][2]:.3g}' for method in fitted)
    return _save_and_report(
        args, model, names, train, validation,
        f'auto: {chosen.upper()}, the lowest mean validation NMSE of {scores} (on every '
        f'other validation block; the errors below include the blocks that chose it)\n'
        f'{summary}')


def _save_and_report(args: argparse.Namespace, model: Estimator, names: Sequence[str],
                     train: Dataset, validation: Dataset, summary: str, *extra: str,
                     validated: Estimator | None = None) -> int:
    """Write ``model`` to ``--out``, then print ``summary``, its errors on the training
    samples and those of ``validated`` (default ``model``; --method gp: the GP fitted
    without the validation blocks) on the validation samples (a Markdown table) and the
    ``extra`` sections; exit status 0."""
    from scara_ident_ros.cli.evaluation import errors_markdown, evaluate

    args.out.parent.mkdir(parents=True, exist_ok=True)
    model.save(args.out)
    results = {'train': evaluate(model, train.X, train.Y)}
    if len(validation):
        scored = model if validated is None else validated
        results['validation'] = evaluate(scored, validation.X, validation.Y)
    print(f'\n{summary}\n')
    print(errors_markdown(names, results))
    for section in extra:
        print(section)
    print(f'model written to {args.out}')
    return 0


def _network_metadata(args: argparse.Namespace, history: FitHistory) -> dict[str, np.ndarray]:
    """What a network's file records of its training."""
    return {'algorithm': np.array(args.algorithm), 'iterations': np.array(history.iterations),
            'stop_reason': np.array(history.stop_reason),
            'max_fail': np.array(args.max_fail),
            'min_iterations': np.array(args.min_iterations),
            'friction_steps': np.array(args.friction_steps),
            'train_mse_scaled': np.array(history.final_mse)}


def _limit_ranges(urdf: Path, names: Sequence[str], X: np.ndarray, Y: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A network's input and output ranges from the URDF's limits of ``names``.

    The URDF has no acceleration limits: each joint's largest |q''| in ``X`` (N, 3n) stands
    for one. A joint without limits in the URDF (continuous, or no ``<limit>``) takes its
    position and speed ranges from ``X`` and its effort range from ``Y`` (N, n); a joint
    the URDF does not have is refused (``UrdfError``).
    """
    from scara_ident_ros.dynamics.urdf_limits import read_urdf
    from scara_ident_ros.nn.presets import limit_scaling

    limits = read_urdf(urdf)
    limits.select([name for name in names if name not in limits.unlimited])  # or UrdfError
    n = len(names)
    data = np.abs(X).max(axis=0)
    position_min, position_max = X[:, :n].min(axis=0), X[:, :n].max(axis=0)
    velocity, effort = data[n:2 * n], np.abs(Y).max(axis=0)
    for j, name in enumerate(names):
        if name in limits.names:
            k = limits.names.index(name)
            position_min[j], position_max[j] = limits.position_min[k], limits.position_max[k]
            velocity[j], effort[j] = limits.velocity_max[k], limits.effort_max[k]
    acceleration = data[2 * n:]
    return limit_scaling(position_min, position_max, velocity,
                         np.where(acceleration > 0.0, acceleration, 1.0), effort)


def _train_physical(args: argparse.Namespace, names: Sequence[str], every_train: Dataset,
                    train: Dataset, validation: Dataset,
                    metadata: dict[str, np.ndarray], *, start_ns: int) -> int:
    """``--method physical`` or ``hybrid``: fit, save, print errors and parameters;
    ``start_ns`` the recording's first stamp (its validation blocks count from it)."""
    from scara_ident_ros.blas_threads import single_blas_thread
    from scara_ident_ros.dynamics.coulomb_selection import select_coulomb
    from scara_ident_ros.learners.hybrid_model import HybridModel
    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from scara_ident_ros.cli.physical_parameters import parameters_markdown
    from scara_ident_ros.identification.split import alternate_blocks, block_index
    from scara_ident_ros.cli.progress import TrainingProgress

    coupled = []
    for pair in args.coupled:
        joints = pair.split(',')
        if len(joints) != 2 or any(j not in names for j in joints) or joints[0] == joints[1]:
            raise CliError(f'--coupled {pair}: need two distinct modelled joints A,B of '
                           f'{", ".join(names)}')
        coupled.append((joints[0], joints[1]))
    if not args.stribeck_velocity >= 0.0:
        raise CliError(f'--stribeck-velocity must be >= 0, got {args.stribeck_velocity}')

    def build(coulomb: str, eps: float) -> PhysicalModel:
        return PhysicalModel.from_urdf_file(args.urdf, joint_names=names, coulomb=coulomb,
                                            coulomb_eps=eps, offsets=args.offsets,
                                            asymmetric=args.asymmetric, coupled=coupled,
                                            stribeck_velocity=args.stribeck_velocity,
                                            consistent=args.consistent)

    started = time.perf_counter()
    coulomb, eps = ('tanh' if args.coulomb == 'auto' else args.coulomb), args.coulomb_eps
    physical = build(coulomb, eps)
    if len(every_train) * len(names) < physical.n_parameters:
        raise CliError(f'{args.bag}: {len(every_train)} training samples of {len(names)} '
                       f'joints cannot determine the physical model\'s '
                       f'{physical.n_parameters} parameters; record more motion')
    fitted = False  # on every training sample
    if args.coulomb == 'auto' and len(validation) >= 2:
        physical, choice = select_coulomb(build, (every_train.X, every_train.Y),
                                          (validation.X, validation.Y))
        coulomb, eps, fitted = choice.coulomb, choice.eps, True
        scores = ', '.join(f'{label} {score:.3g}' for label, score in choice.scores.items())
        print(f'Coulomb friction shape: {choice.label} (mean validation NMSE of each: '
              f'{scores})')
    elif args.coulomb == 'auto':
        print(f'Coulomb friction shape: tanh {eps:g} (no validation samples to choose by)')
    model: PhysicalModel | HybridModel
    if args.method == 'physical':
        model = physical if fitted else physical.fit(every_train.X, every_train.Y)
        how = ' (physically consistent)' if args.consistent else ''
        summary = (f'PHYSICAL fitted by least squares on {len(every_train)} samples{how}: '
                   f'{physical.n_base} base parameters and '
                   f'{physical.n_parameters - physical.n_base} friction and offset '
                   f'coefficients in {time.perf_counter() - started:.1f} s')
    else:
        network = make_network(HYBRID_NETWORK, len(names), seed=args.seed,
                               friction_steps=args.friction_steps)
        x_min, x_max, _, _ = _limit_ranges(args.urdf, names, every_train.X, every_train.Y)
        progress = TrainingProgress(args.iterations, label=f'HYBRID {HYBRID_NETWORK} lm')
        stop, other = alternate_blocks(validation, block_s=args.validation_block,
                                       start_ns=start_ns)
        if not len(other):  # one validation block: stop on it
            stop = validation
        hybrid = HybridModel(physical, network)
        with single_blas_thread():  # the validation blocks are drawn above
            hybrid.fit(every_train.X, every_train.Y, validation_fraction=0.0,
                       validation=(stop.X, stop.Y) if len(stop) else None,
                       gate_validation=(validation.X, validation.Y) if len(validation)
                       else None,
                       gate_groups=block_index(validation.stamp_ns,
                                               block_s=args.validation_block,
                                               start_ns=start_ns),
                       x_range=(x_min, x_max), samples=args.samples,
                       iterations=args.iterations, max_fail=args.max_fail,
                       min_iterations=args.min_iterations, callback=progress)
        progress.close()
        model, history = hybrid, hybrid.history_
        assert history is not None
        metadata.update(_network_metadata(args, history))
        metadata['network'] = np.array(HYBRID_NETWORK)
        kept = ', '.join(f'{n} (×{g:.2f})' for n, g in zip(names, model.gate) if g)
        summary = (f'HYBRID: least squares on {len(every_train)} samples, then '
                   f'{HYBRID_NETWORK.upper()} on the residual of {len(train)}: '
                   f'{history.iterations} iterations in {time.perf_counter() - started:.1f} s '
                   f'(stopped: {history.stop_reason}; weights of iteration '
                   f'{history.best_iteration}); correction kept on {kept or "no joint"}')
    metadata.update({'coulomb': np.array(coulomb), 'coulomb_eps': np.array(eps)})
    model.metadata.update(metadata)
    return _save_and_report(args, model, names, train, validation, summary,
                            parameters_markdown(physical))
