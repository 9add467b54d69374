"""``scara-ident train``: fit an effort model offline from recorded joint states.

Reads sensor_msgs/JointState messages from any rosbag2 bag (MCAP or sqlite3), a bare
.mcap file or a ROS 1 .bag, or the joint states of a table (.npz or CSV with named
columns, a /joint_states CSV export; FILE.npz:SPLIT for a published split, such as
barrett_wam.npz:train), turns them into network samples exactly as the online identifier
does (its input stage: the same sample checks, repeated samples refused, and zero-phase q''
estimate; q' derived from q where the recording has none, q'' as given where a table gives
it; faster than 1 kHz both fits span 20 ms; docs/recording_and_retraining.md), and fits the
method's model. --span 0:0.7 takes a part of the recording (its first 70 %), so that
``evaluate --span 0.7:1`` scores the rest.

Held out, two ways (both reported, per joint):
  later motion   the last --later-fraction (0.3) of the recording's time, or with several
                 recordings (oldest first) the last one whole: what comes after the
                 training motion, as in use. Every choice is made on it: auto's model per
                 joint, the physical model's options, the networks' early stop, the
                 hybrid's gate.
  validation     blocks of --validation-block seconds interleaved with the rest, a
                 --validation-fraction of them, one drawn from each stretch: they measure
                 interpolation (whole blocks, since neighbouring samples are nearly
                 identical). With --later-fraction 0, choices are made on them instead.
The rest trains. A network trains on --samples random samples of it for at most
--iterations, stops once its held-out error has not reached a new best for --max-fail
iterations (counted from --min-iterations) and keeps the best weights; it starts with
friction steps (--friction-steps, as the identifier's lm trainer). Once chosen, the least-
squares and GP parts (physical, linear, gp) are refitted on every sample (--refit): the
errors printed are those before, on samples the model had not learnt. The defaults come
from benchmarks/bench_train_defaults.py and benchmarks/later_motion.md (docs/results.md).
A model predicts the motion it was trained on: record varied motion, as wide as the motion
it is to predict. A progress bar goes to stderr, the errors to stdout.

--method physical: the robot's physical model from its URDF (--urdf, required): base
parameters of the rigid bodies and rotor inertias, viscous and Coulomb friction per joint
fitted by linear least squares on every training sample (--samples does not apply); the
identified parameters are printed. What a real arm needs beyond that is chosen on the
later motion (dynamics.physical_options): tanh(qd/0.05) Coulomb friction unless sign(qd) or
another eps (0.005-0.2) scores 15 % lower, then an effort offset per joint (torque sensors
drift) and the friction of coupled neighbouring motors (a wrist, the TX40's 5-6), each kept
if it lowers the mean NMSE by 15 %. --coulomb tanh|sign, --offsets/--no-offsets and
--coupled J5,J6 (or none) impose them; --asymmetric adds a Coulomb friction that differs by
direction, --stribeck-velocity a Stribeck term; --consistent (the default) fits physically
consistent parameters (positive masses, inertias a body can have: a pseudo-inertia LMI per
body, solved with cvxpy) as close to least squares as the data allow, which scara-ident
export --urdf writes back as a URDF.
--method hybrid: the physical model, then an FFS network on its residual (output scaling:
the residual's range) with Levenberg-Marquardt on --samples of the training samples, early-
stopped on every other block of the later motion; its correction fades to 0 away from the
training states (learners.data_region: 1 within the distance of the validation blocks'
states, 0 beyond three times it), then is scaled per joint by a factor in [0, 1] fitted on the
later motion and kept only on the joints where its gain, block by block, is significant
(learners.hybrid_model.gate_scales), so that on motion it has not seen the hybrid is its
physical part. With --urdf, networks (the hybrid's too) scale their inputs by the URDF's
joint limits (positions, velocities; the accelerations by the training data's largest
|q''|) and a network alone its outputs by the effort limits.

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
residual, early-stopped, faded and gated the same way), for an arm without a URDF.

--method auto (the default) fits every candidate (with --urdf: physical, hybrid, linear and
gp; without: linear, linear_hybrid, gp and ffs), its network early-stopped and gated on every
other block of the later motion, scores each on the other blocks, and keeps per joint
(learners.joint_choice): the physical model (with --urdf; without, linear least squares)
unless another candidate scores at most 0.8 of its NMSE on both halves of those blocks in
time, then the lowest mean NMSE of those that do (on TIAGo without a URDF, the GP beat
linear on arm_2 on average over the later motion, not in its first half, and predicted the
motion after it 14 times worse). One candidate for every joint is saved as itself, several
as a joint_choice model. All
scores are printed, on the later motion and on the validation blocks. No learner wins
everywhere (benchmarks/later_motion.md). The WAM's published test rows lie between its
training rows (interpolation): for that split --method gp. --method kernel is not a
candidate: with its default features it scores worse than the linear model on the WAM
(SMSE 0.23 against 0.15).
"""
from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from scara_ident_ros.cli import CliError
from scara_ident_ros.cli.recording_options import (RECORDING_HELP, add_span_option,
                                                    cut_span, recording_note,
                                                    urdf_joints_not_recorded)
from scara_ident_ros.cli.validation_options import (add_validation_options,
                                                     check_validation_options)
from scara_ident_ros.dynamics.physical_model import COULOMB_EPS, COULOMB_MODES
from scara_ident_ros.identification.centred_differentiator import recording_window
from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.identification.split import LATER_FRACTION, VALIDATION_BLOCK_S
from scara_ident_ros.nn.presets import METHODS, make_network
from scara_ident_ros.nn import ALGORITHMS
from scara_ident_ros.nn.fitting import ITERATIONS, MAX_FAIL, MIN_ITERATIONS, SAMPLES
from scara_ident_ros.paths import unwritable_file

if TYPE_CHECKING:
    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from scara_ident_ros.learners.hybrid_model import HybridModel
    from scara_ident_ros.identification.recording import Recording
    from scara_ident_ros.estimator import Estimator
    from scara_ident_ros.nn import FitHistory

__all__ = ['AUTO_CANDIDATES', 'AUTO_METHOD', 'FRICTION_STEPS', 'GP_METHOD', 'GP_SAMPLES',
           'HYBRID_NETWORK', 'ITERATIONS', 'KERNEL_METHOD', 'LINEAR_HYBRID_METHOD',
           'LINEAR_METHOD', 'MAX_FAIL', 'MIN_ITERATIONS', 'PHYSICAL_METHODS', 'SAMPLES',
           'URDF_CANDIDATES', 'VALIDATION_BLOCK_S', 'add_parser', 'read_recordings', 'run']

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
#: Auto's candidates with a URDF: the physical model is kept on a joint unless another is
#: clearly better there (``learners.joint_choice.MARGIN``).
URDF_CANDIDATES = ('physical', 'hybrid', LINEAR_METHOD, GP_METHOD)
HYBRID_NETWORK = 'ffs'     # the hybrid's residual network


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``scara-ident train``."""
    parser = subparsers.add_parser(
        'train', help='train a network offline from the joint states of a bag',
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('bag', type=Path, metavar='RECORDING', nargs='+',
                        help=RECORDING_HELP + '; several recordings of the same joints, '
                        'oldest first: the last is held out whole as the later motion')
    add_span_option(parser)
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
    parser.add_argument('--offsets', action=argparse.BooleanOptionalAction, default=None,
                        help='physical/hybrid: an effort offset per joint (default: if it '
                             'lowers the later motion\'s NMSE by 15 %%)')
    parser.add_argument('--weighted', action=argparse.BooleanOptionalAction, default=False,
                        help='physical/hybrid: least squares weighted per joint by 1/its '
                             'residual RMS after an unweighted fit (default: off; on the real '
                             'recordings here it won or lost by chance)')
    parser.add_argument('--asymmetric', action=argparse.BooleanOptionalAction, default=False,
                        help='physical/hybrid: Coulomb friction that differs by direction '
                             '(default: off)')
    parser.add_argument('--coupled', action='append', default=[], metavar='JOINT_A,JOINT_B',
                        help='physical/hybrid: two joints whose motors are coupled (a wrist): '
                             'each gets friction of the other\'s speed; repeatable; none: no '
                             'coupling (default: each neighbouring pair whose coupling '
                             'lowers the later motion\'s NMSE by 15 %%)')
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
    add_validation_options(parser, zero='none')
    parser.add_argument('--later-fraction', type=float, default=LATER_FRACTION,
                        metavar='SHARE',
                        help='share of the recording\'s time, at its end, held out as later '
                             'motion: choices, early stops and gates are made on it '
                             f'(default: {LATER_FRACTION:g}; 0: on the validation blocks)')
    parser.add_argument('--refit', action=argparse.BooleanOptionalAction, default=True,
                        help='refit the least-squares and GP parts on every sample once '
                             'chosen (default: on)')
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
    """Train and save; print the errors on the training, validation and later samples."""
    from scara_ident_ros.identification.recording import skipped_text
    from scara_ident_ros.identification.split import (SplitError, block_index, block_split,
                                                      later_split)

    if args.iterations < 1:
        raise CliError(f'--iterations must be at least 1, got {args.iterations}')
    check_validation_options(args)
    if not 0.0 <= args.later_fraction < 1.0:
        raise CliError(f'--later-fraction must be in [0, 1), got {args.later_fraction}')
    if args.max_fail < 1:
        raise CliError(f'--max-fail must be at least 1, got {args.max_fail}')
    if args.samples < 0 or args.seed < 0 or args.goal < 0.0 or args.min_iterations < 0:
        raise CliError('--samples, --seed, --goal and --min-iterations must not be negative')
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
    source = ' + '.join(str(path) for path in args.bag)
    recording, data, labels = read_recordings(args.bag, topic=args.topic, joints=args.joints,
                                              span=args.span)
    samples = recording.samples
    names = samples.names
    start_ns = int(data.stamp_ns[0])
    earlier, later = data, data.take(slice(0, 0), 'later')
    try:
        if labels is not None:  # several recordings: the last, whole
            earlier, later = later_split(data, recording=labels)
        elif args.later_fraction > 0.0:
            earlier, later = later_split(data, args.later_fraction)
        train, validation = block_split(earlier, args.validation_fraction,
                                        block_s=args.validation_block, seed=args.seed)
    except SplitError as exc:
        raise CliError(f'{source}: {exc}; lower --validation-block, give '
                       '--validation-fraction 0 or --later-fraction 0') from None
    if len(train) < 2:
        raise CliError(f'{source}: only {len(train)} training samples outside the '
                       f'validation blocks; lower --validation-fraction')
    every_train = train  # least squares takes them all
    if args.method != AUTO_METHOD:
        train = _training_rows(args, args.method, every_train)
    where = ''
    if len(validation):
        blocks = np.unique(block_index(validation.stamp_ns, block_s=args.validation_block,
                                       start_ns=start_ns))
        plural = 's' if len(blocks) > 1 else ''
        where = (f' in {len(blocks)} block{plural} of {args.validation_block:g} s from '
                 f'{blocks[0] * args.validation_block:.1f} s to '
                 f'{(blocks[-1] + 1) * args.validation_block:.1f} s')
    if len(later):
        where += (f'; later motion, held out to choose and stop on: {len(later)} samples '
                  + (f'of the last recording, {args.bag[-1]}' if labels is not None else
                     f'from {(later.stamp_ns[0] - start_ns) * 1e-9:.1f} s to the end'))
    print(f'scara-ident train: {source} {recording.topic}: {len(data)} samples '
          f'of {len(names)} joints {list(names)} over {data.seconds:.1f} s '
          f'(skipped: {skipped_text(samples)}{recording_note(recording)}); training on '
          f'{len(train)}, validating on '
          f'{len(validation)}{where}', flush=True)

    metadata = {
        'joint_names': np.array(names), 'method': np.array(args.method),
        'seed': np.array(args.seed), 'source_bag': np.array(source),
        'topic': np.array(recording.topic), 'train_samples': np.array(len(train)),
        'validation_fraction': np.array(args.validation_fraction),
        'validation_block_s': np.array(args.validation_block),
        'later_fraction': np.array(args.later_fraction),
        'differentiator': np.array('centred'),
        'window': np.array(recording_window(recording.series.stamp_ns))}
    if args.urdf is not None:
        metadata['urdf_file'] = np.array(str(args.urdf))
        fixed = urdf_joints_not_recorded(args.urdf, names)
        if fixed and args.method in (*PHYSICAL_METHODS, AUTO_METHOD):
            print(f'{args.urdf}: joints not in the recording, held fixed at 0: '
                  f'{", ".join(fixed)}', flush=True)
    parts = Parts(data, every_train, train, validation, later, start_ns)
    if args.method in PHYSICAL_METHODS:
        return _train_physical(args, names, parts, metadata)
    if args.method == AUTO_METHOD:
        return _train_auto(args, names, parts, metadata)
    decide = later if len(later) else validation
    model, summary = _fit(args, args.method, names, train, decide, every_train,
                          start_ns=start_ns, inside=validation)
    model.metadata.update(metadata)
    return _save_and_report(args, model, names, parts, summary)


class Parts(NamedTuple):
    """The recording's samples as ``train`` uses them.

    ``data``: all of them; ``every_train``: those outside the validation blocks and the
    later motion (least squares fits them all); ``train``: what the method fits (a draw of
    ``every_train`` for a network); ``validation``: the interleaved blocks (interpolation);
    ``later``: the later motion (what comes next; empty with --later-fraction 0);
    ``start_ns``: the first stamp, from which blocks count.
    """

    data: Dataset
    every_train: Dataset
    train: Dataset
    validation: Dataset
    later: Dataset
    start_ns: int

    @property
    def decide(self) -> Dataset:
        """What choices, early stops and gates are made on: the later motion if any, else the
        validation blocks."""
        return self.later if len(self.later) else self.validation


def read_recordings(paths: Sequence[Path], *, topic: str | None, joints: Sequence[str] | None,
                    span: tuple[float, float] | None = None
                    ) -> tuple[Recording, Dataset, np.ndarray | None]:
    """Read one or several recordings of the same joints, in the order given (the last is
    the latest).

    Returns
    -------
    recording : Recording
        The first (what the summary line describes).
    data : Dataset
        Every recording's samples, the later ones' stamps shifted to follow the earlier ones
        (one second apart), cut to ``span`` (fractions of the time, one recording only).
    labels : ndarray of shape (N,) or None
        The recording of each sample (0, 1, ...), None for a single recording.
    """
    from scara_ident_ros.identification.recording import load_recording

    first = load_recording(paths[0], topic=topic, joints=joints)
    if len(paths) == 1:
        data = first.samples.data
        if span is not None:
            data = cut_span(data, span)
        return first, data, None
    if span is not None:
        raise CliError('--span cuts a single recording; give one, or cut each beforehand')
    names = first.samples.names
    parts, labels, end = [first.samples.data], [np.zeros(len(first.samples.data), int)], 0
    for k, path in enumerate(paths[1:], start=1):
        other = load_recording(path, topic=topic, joints=names).samples.data
        end = int(parts[-1].stamp_ns[-1]) + 1_000_000_000
        shifted = other.stamp_ns - other.stamp_ns[0] + end
        parts.append(Dataset(shifted, other.X, other.Y, other.acceleration, other.name))
        labels.append(np.full(len(other), k))
    data = Dataset(np.concatenate([p.stamp_ns for p in parts]),
                   np.vstack([p.X for p in parts]), np.vstack([p.Y for p in parts]),
                   parts[0].acceleration, 'recordings')
    return first, data, np.concatenate(labels)


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
         gate: Dataset | None = None, inside: Dataset | None = None
         ) -> tuple[Estimator, str]:
    """Fit a model of no URDF's ``method`` (a network, kernel, gp, linear or
    linear_hybrid) to ``train``, a network early-stopped on ``stop`` (if it has samples)
    and, with --urdf, scaled by its limits and ``every_train``'s accelerations; return it,
    with its training recorded in its metadata, and a line saying how it was fitted.

    linear_hybrid gates its network on ``gate`` (in --validation-block blocks from
    ``start_ns``, the recording's first stamp); without, it early-stops on every other
    block of ``stop`` and gates on all of them, as --method hybrid; its correction fades
    beyond the distance of the ``inside`` samples (the validation blocks)."""
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
        return _fit_linear_hybrid(args, names, train, stop, start_ns=start_ns, gate=gate,
                                  inside=inside)
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
                       stop: Dataset, *, start_ns: int, gate: Dataset | None,
                       inside: Dataset | None = None) -> tuple[Estimator, str]:
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
            min_iterations=args.min_iterations, callback=progress,
            region_inputs=inside.X if inside is not None and len(inside) else None)
    progress.close()
    return hybrid, _hybrid_summary(args, 'LINEAR_HYBRID', hybrid, history, names,
                                   samples=len(train), started=started)


def _hybrid_summary(args: argparse.Namespace, label: str, hybrid: HybridModel,
                    history: FitHistory, names: Sequence[str], *, samples: int,
                    started: float) -> str:
    """Record the network's training in ``hybrid``'s metadata; return the line saying how
    it was fitted: least squares on ``samples``, the network's iterations since ``started``
    (``time.perf_counter``) and the joints its correction is kept on."""
    hybrid.metadata.update(_network_metadata(args, history))
    hybrid.metadata['network'] = np.array(HYBRID_NETWORK)
    kept = ', '.join(f'{n} (×{g:.2f})' for n, g in zip(names, hybrid.gate) if g)
    return (f'{label}: least squares on {samples} samples, then {HYBRID_NETWORK.upper()} on '
            f'its residual: {history.iterations} iterations in '
            f'{time.perf_counter() - started:.1f} s (stopped: {history.stop_reason}; weights '
            f'of iteration {history.best_iteration}); correction kept on '
            f'{kept or "no joint"}, fading away from the training states')


def _train_auto(args: argparse.Namespace, names: Sequence[str], parts: Parts,
                metadata: dict[str, np.ndarray]) -> int:
    """``--method auto``: fit each candidate (with --urdf: physical, hybrid, linear and gp;
    without: AUTO_CANDIDATES), a network early-stopped and a hybrid gated on the first of the
    alternate blocks of the later motion, score each on the second, and keep per joint the
    best (``learners.joint_choice``: the physical model, without --urdf the linear one,
    unless another is clearly better there); refit the least-squares and GP parts on every
    sample (:func:`_refit`)."""
    from scara_ident_ros.identification.split import alternate_blocks
    from scara_ident_ros.learners.joint_choice import MARGIN, JointChoice, choose_joints

    decide = parts.decide
    if len(decide) < 2:
        raise CliError(f'{args.bag[0]}: --method auto chooses on held-out samples and has '
                       f'{len(decide)}; give a --later-fraction or --validation-fraction '
                       'above 0, or a --method')
    stop, score = alternate_blocks(decide, block_s=args.validation_block,
                                   start_ns=parts.start_ns)
    if not len(score):  # one block: its first half and its second
        half = np.arange(len(decide)) >= len(decide) // 2
        stop, score = decide.take(~half, 'stop'), decide.take(half, 'score')
    # each joint's MSE over the variance of all held-out efforts (the table's NMSE): a
    # half's own variance can be near 0 on a joint that barely moves
    variance = np.maximum(decide.Y.var(axis=0), np.finfo(np.float64).tiny)
    # a candidate must win on both halves of the scoring samples in time
    first_half = score.stamp_ns < score.stamp_ns[len(score) // 2]
    candidates = URDF_CANDIDATES if args.urdf is not None else AUTO_CANDIDATES
    fitted: dict[str, tuple[Estimator, str]] = {}
    errors: dict[str, np.ndarray] = {}
    physical = None  # the hybrid takes the physical model's options
    for method in candidates:
        train = _training_rows(args, method, parts.every_train)
        try:
            if method in PHYSICAL_METHODS:
                model, summary, physical = _fit_physical(args, method, names, parts,
                                                         stop=stop, gate=stop,
                                                         chosen=physical)
            else:
                model, summary = _fit(args, method, names, train, stop, parts.every_train,
                                      start_ns=parts.start_ns, gate=stop,
                                      inside=parts.validation)
        except (ValueError, CliError) as exc:  # e.g. too few samples for the GP's kernel
            print(f'auto: {method} not fitted: {exc}', flush=True)
            continue
        squares = (model.predict(score.X) - score.Y) ** 2
        halves = np.array([np.mean(squares[part], axis=0) / variance
                           for part in (first_half, ~first_half)])
        per_joint = halves.mean(axis=0)
        if not np.all(np.isfinite(per_joint)):
            print(f'auto: {method} predicts non-finite efforts; not a candidate', flush=True)
            continue
        interleaved = ''
        if len(parts.later) and len(parts.validation):
            blocks = (np.mean((model.predict(parts.validation.X) - parts.validation.Y) ** 2,
                              axis=0) / np.maximum(parts.validation.Y.var(axis=0),
                                                   np.finfo(np.float64).tiny))
            interleaved = (f' (validation blocks: {", ".join(f"{e:.3g}" for e in blocks)})')
        print(f'auto: {method} NMSE per joint {", ".join(f"{e:.3g}" for e in per_joint)} '
              f'(mean {np.mean(per_joint):.4g}) on {len(score)} held-out samples'
              f'{interleaved} (halves in time: '
              f'{"; ".join(", ".join(f"{e:.3g}" for e in half) for half in halves)}); '
              f'{summary}', flush=True)
        fitted[method], errors[method] = (model, summary), halves
    if not fitted:
        raise CliError(f'{args.bag[0]}: --method auto fitted none of '
                       f'{", ".join(candidates)} (above); give a --method')
    # the model that degrades most gracefully away from its data is kept unless another
    # is clearly better: the physical model, else least squares on simple features
    default = next((m for m in ('physical', LINEAR_METHOD) if m in fitted), None)
    choice = choose_joints(errors, default)
    chosen = list(dict.fromkeys(choice))
    model = (fitted[chosen[0]][0] if len(chosen) == 1 else
             JointChoice({label: fitted[label][0] for label in chosen}, choice))
    metadata['method'] = np.array(chosen[0] if len(chosen) == 1 else 'joint_choice')
    metadata['chosen_by'] = np.array(AUTO_METHOD)
    metadata['joint_choice'] = np.array(choice)
    for method, halves in errors.items():
        metadata[f'auto_nmse_{method}'] = halves.mean(axis=0)
    model.metadata.update(metadata)
    what = ('later motion' if len(parts.later) else 'validation blocks')
    rule = (f'the {default} model unless another scores at most {MARGIN:g} of its NMSE on '
            'both halves in time' if default else 'the lowest mean NMSE of the two halves in '
            'time')
    lines = [f'auto: per joint {rule} on every other block of the {what}: '
             + ', '.join(f'{n} {c}' for n, c in zip(names, choice))]
    lines += [fitted[label][1] for label in chosen]
    return _save_and_report(args, model, names, parts, '\n'.join(lines))


def _refit(model: Estimator, data: Dataset, *, seed: int) -> tuple[Estimator, list[str]]:
    """``model`` with its least-squares and GP parts (physical, linear, gp; a joint
    choice's of them) fitted again on ``data``, every sample the recording gave, their
    options and choices kept (a GP chooses its kernel again, as ``ExactGP().fit`` on those
    samples would), and the kinds refitted.

    Networks and hybrids keep the fit their early stop and gate chose: a network trained
    again from its first weights on every sample, for the iterations its early stop kept,
    is a new draw that nothing judged. On TIAGo's last 30 % (first 70 % learnt; FFS with and
    without ``tiago.urdf``, seeds 0-2 and 0-1) such a refit scored better on 12 of 25 joints
    and runs, and predicted the torso at NMSE 62 and 491 where the early-stopped networks
    scored 1.33 and 28.4; a hybrid so refitted went from 0.247 to 0.421 on arm_4 and from
    0.618 to 0.22 on arm_2."""
    from scara_ident_ros.learners import ExactGP
    from scara_ident_ros.learners.joint_choice import JointChoice

    if isinstance(model, JointChoice):
        kinds = []
        for label, part in list(model.models.items()):
            model.models[label], refitted = _refit(part, data, seed=seed)
            kinds += refitted
        return model, kinds
    if model.kind in ('physical', 'linear'):
        return model.fit(data.X, data.Y), [model.kind]
    if isinstance(model, ExactGP):
        rows = data.subsample(GP_SAMPLES, seed=seed)
        fresh = ExactGP(**model.get_params()).fit(rows.X, rows.Y)
        fresh.metadata.update(model.metadata)
        return fresh, [model.kind]
    return model, []


def _save_and_report(args: argparse.Namespace, model: Estimator, names: Sequence[str],
                     parts: Parts, summary: str, *extra: Callable[[], str]) -> int:
    """Print ``summary`` and the model's errors on the training, validation-block and later
    samples (a Markdown table), refit it on every sample if --refit (:func:`_refit`), write
    it to ``--out``, print the ``extra`` sections (made after the refit: the parameters
    saved); exit status 0."""
    from scara_ident_ros.blas_threads import single_blas_thread
    from scara_ident_ros.cli.evaluation import errors_markdown, evaluate

    results = {'train': evaluate(model, parts.train.X, parts.train.Y)}
    if len(parts.validation):
        results['validation'] = evaluate(model, parts.validation.X, parts.validation.Y)
    if len(parts.later):
        results['later'] = evaluate(model, parts.later.X, parts.later.Y)
    print(f'\n{summary}\n')
    print(errors_markdown(names, results))
    print('validation: blocks interleaved with the training motion (interpolation); later: '
          'the motion after it (what a model predicts in use).')
    if args.refit:
        with single_blas_thread():
            model, refitted = _refit(model, parts.data, seed=args.seed)
        if refitted:
            model.metadata['train_samples'] = np.array(
                min(len(parts.data), GP_SAMPLES) if set(refitted) == {GP_METHOD}
                else len(parts.data))
            print(f'then refitted on all {len(parts.data)} samples (its {", ".join(refitted)} '
                  'part, options and choices kept): the errors above are of the model '
                  'before, on samples it had not learnt')
    args.out.parent.mkdir(parents=True, exist_ok=True)
    model.save(args.out)
    for section in extra:
        print(section())
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


def _train_physical(args: argparse.Namespace, names: Sequence[str], parts: Parts,
                    metadata: dict[str, np.ndarray]) -> int:
    """``--method physical`` or ``hybrid``: fit (the hybrid's network early-stopped on every
    other block of the later motion, gated on all of it), save, print errors and
    parameters."""
    from scara_ident_ros.cli.physical_parameters import parameters_markdown
    from scara_ident_ros.identification.split import alternate_blocks

    stop, other = alternate_blocks(parts.decide, block_s=args.validation_block,
                                   start_ns=parts.start_ns)
    if not len(other):  # one block: stop on it
        stop = parts.decide
    model, summary, physical = _fit_physical(args, args.method, names, parts, stop=stop,
                                             gate=parts.decide)
    model.metadata.update(metadata)
    model.metadata.update({k: v for k, v in physical.metadata.items()
                           if k.startswith('coulomb')})
    return _save_and_report(args, model, names, parts, summary,
                            lambda: parameters_markdown(physical))


def _fit_physical(args: argparse.Namespace, method: str, names: Sequence[str], parts: Parts,
                  *, stop: Dataset, gate: Dataset, chosen: PhysicalModel | None = None
                  ) -> tuple[Estimator, str, PhysicalModel]:
    """The physical model (``method`` 'physical') or the hybrid ('hybrid') of --urdf: the
    options the flags leave open chosen on the later motion (``dynamics.physical_options``),
    fitted on every training sample; the hybrid's network early-stopped on ``stop``, gated
    on ``gate``; ``chosen``: a physical model whose options to take instead of choosing.
    Returns the model, a line saying how it was fitted, and its physical model."""
    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from scara_ident_ros.blas_threads import single_blas_thread
    from scara_ident_ros.cli.progress import TrainingProgress
    from scara_ident_ros.dynamics.physical_options import WEIGHTED, select_options
    from scara_ident_ros.identification.split import block_index
    from scara_ident_ros.learners.hybrid_model import HybridModel

    coupled = []
    for pair in args.coupled:
        if pair == 'none':
            continue
        joints = pair.split(',')
        if len(joints) != 2 or any(j not in names for j in joints) or joints[0] == joints[1]:
            raise CliError(f'--coupled {pair}: need two distinct modelled joints A,B of '
                           f'{", ".join(names)}, or none')
        coupled.append((joints[0], joints[1]))
    if not args.stribeck_velocity >= 0.0:
        raise CliError(f'--stribeck-velocity must be >= 0, got {args.stribeck_velocity}')
    fixed: dict[str, object] = {}
    if args.coulomb != 'auto':
        fixed.update(coulomb=args.coulomb, coulomb_eps=args.coulomb_eps)
    if args.offsets is not None:
        fixed['offsets'] = args.offsets
    if args.coupled:
        fixed['coupled'] = tuple(coupled)
    fixed['weighted'] = args.weighted
    if chosen is not None:
        fixed = {'coulomb': chosen.coulomb, 'coulomb_eps': chosen.coulomb_eps,
                 'offsets': chosen.offsets, 'coupled': chosen.coupled,
                 'weighted': chosen.weighted}
    reduction = None

    def build(**options: Any) -> PhysicalModel:
        nonlocal reduction
        model = PhysicalModel.from_urdf_file(
            args.urdf, joint_names=names, reduction=reduction,
            asymmetric=args.asymmetric, stribeck_velocity=args.stribeck_velocity,
            consistent=args.consistent, **options)
        reduction = model.reduction  # computed once: the same URDF and joints
        return model

    started = time.perf_counter()
    every_train, decide = parts.every_train, parts.decide
    defaults: dict[str, Any] = {'coulomb': 'tanh', 'coulomb_eps': args.coulomb_eps,
                                'offsets': False, 'coupled': (), 'weighted': WEIGHTED}
    probe = build(**{**defaults, **fixed})
    if len(every_train) * len(names) < probe.n_parameters:
        raise CliError(f'{args.bag[0]}: {len(every_train)} training samples of {len(names)} '
                       f'joints cannot determine the physical model\'s '
                       f'{probe.n_parameters} parameters; record more motion')
    with single_blas_thread():
        if chosen is not None:  # nothing to choose; a hybrid fits its physical part itself
            options = fixed
            physical = build(**options)
            if method == 'physical':
                physical.fit(every_train.X, every_train.Y)
        elif len(decide) >= 2:
            physical, choice = select_options(build, (every_train.X, every_train.Y),
                                              (decide.X, decide.Y), fixed=fixed)
            options = choice.options
            scores = ', '.join(f'{label} {value:.3g}' for label, value in choice.scores.items())
            print(f'physical model options: {choice.label} (mean NMSE on the '
                  f'{"later motion" if len(parts.later) else "validation blocks"}: {scores})',
                  flush=True)
        else:
            options = {**defaults, **fixed}
            physical = build(**options).fit(every_train.X, every_train.Y)
            print(f'physical model options: {options} (no held-out samples to choose by)',
                  flush=True)
    physical.metadata.update({'coulomb': np.array(options['coulomb']),
                              'coulomb_eps': np.array(options['coulomb_eps'])})
    if method == 'physical':
        how = ' (physically consistent)' if args.consistent else ''
        return physical, (f'PHYSICAL fitted by least squares on {len(every_train)} '
                          f'samples{how}: {physical.n_base} base parameters and '
                          f'{physical.n_parameters - physical.n_base} friction and offset '
                          f'coefficients in {time.perf_counter() - started:.1f} s'), physical
    network = make_network(HYBRID_NETWORK, len(names), seed=args.seed,
                           friction_steps=args.friction_steps)
    x_min, x_max, _, _ = _limit_ranges(args.urdf, names, every_train.X, every_train.Y)
    progress = TrainingProgress(args.iterations, label=f'HYBRID {HYBRID_NETWORK} lm')
    hybrid = HybridModel(physical, network)  # fit_hybrid fits it on every_train
    with single_blas_thread():  # the validation blocks are drawn above
        hybrid.fit(every_train.X, every_train.Y, validation_fraction=0.0,
                   validation=(stop.X, stop.Y) if len(stop) else None,
                   gate_validation=(gate.X, gate.Y) if len(gate) else None,
                   gate_groups=block_index(gate.stamp_ns, block_s=args.validation_block,
                                           start_ns=parts.start_ns),
                   x_range=(x_min, x_max), samples=args.samples,
                   iterations=args.iterations, max_fail=args.max_fail,
                   min_iterations=args.min_iterations, callback=progress,
                   region_inputs=parts.validation.X if len(parts.validation) else None)
    progress.close()
    history = hybrid.history_
    assert history is not None
    return hybrid, _hybrid_summary(args, 'HYBRID', hybrid, history, names,
                                   samples=len(every_train), started=started), hybrid.physical
