"""Learning curves: held-out NMSE of frozen models against seconds of stream.

The question an identifier answers is "after t seconds of this robot's stream, how well does
the model predict motions it has never seen?". Each curve runs the real online pipeline
(:class:`~scara_ident_ros.identification.OnlineIdentifier`: the input stage with the
zero-phase q'', the trainer, the node's held-out validation blocks) over a simulated stream,
and at each checkpoint scores the model *as it is then* (frozen: scoring changes nothing) on
held-out excitations that no model ever learns from. Beside the networks, two references on
the robot's physical regressor fitted to the same stream inputs: least squares on every
sample so far (``LS``) and recursive least squares updated sample by sample (``RLS``); they
know the robot's structure, the networks do not. The robot is the SCARA (``ScaraParams``,
its analytic regressor) or a URDF arm of ``robot_sim`` (``PinocchioRobot``, by name in
:data:`ROBOTS`: friction and rotor inertia simulated; the references are then the
:class:`~scara_ident_ros.dynamics.physical_model.PhysicalModel` of its URDF, base
parameters, rotor inertias, viscous and tanh Coulomb friction at the simulator's
``stick_velocity``; the simulated Stribeck bump is outside that model unless ``stribeck``
adds its column at the simulator's Stribeck velocity). Method ``hybrid`` is that physical
model learnt by RLS plus an FFS network of its residual learnt by ``lm``, as the node's
``method:=hybrid`` (URDF arms only).

NMSE per joint = MSE / variance of that joint's held-out effort; 1 is no better than the
mean effort.

Public API::

    CHECKPOINTS_S                                  default checkpoints (s)
    ROBOTS                                         'scara', 'ur5', 'panda'
    robot_by_name(name) -> ScaraParams | PinocchioRobot
    Curve                                          label, seed, seconds, nmse (K, n), cpu_s
    held_out_set(params, *, seed, config=None, excitation_s=6, sequence_s=30) -> Dataset
    network_curve(record, held_out, params, *, method, trainer, seed, checkpoints) -> Curve
    regressor_curves(record, held_out, *, seed, checkpoints, physical=None)
        -> (LS Curve, RLS Curve)
    run_curves(robot, *, seeds, methods, trainers, seconds, noise=False, workers=2,
               held_out_s=(6, 30), lm_steps=None, references=True, reservoir_size=None,
               stribeck=False)
        -> list[Curve]                             every curve, the jobs in worker processes
    noisy_config(params, seed) -> SimConfig        the simulator's sensor-noise options
    noise_floor(params, held_out) -> ndarray (n,)  effort noise variance / effort variance
    curves_markdown(curves, *, noise_floor=None) -> str
"""
from __future__ import annotations

import functools
import time
from collections import defaultdict
from collections.abc import Sequence
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from scara_ident_ros.blas_threads import single_blas_thread
from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.dynamics.joint_limits import LIMIT_NAMES
from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.dynamics.recursive_least_squares import RecursiveLeastSquares
from scara_ident_ros.identification import InputStage, JointMap, make_differentiator
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.identification.identifier_builder import (background_learner,
                                                               build_identifier)
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.nn.presets import method as method_spec
from scara_ident_ros.paper.datasets import dataset_from_record, simulate_record
from scara_ident_ros.paper.reference import fit_reference, predict_reference
from scara_ident_ros.paper.tables import format_value
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, SimRecord
from scara_ident_ros.sim.trajectory import Robot

__all__ = ['CHECKPOINTS_S', 'ROBOTS', 'Curve', 'curves_markdown', 'held_out_set',
           'network_curve', 'noise_floor', 'noisy_config', 'physical_model_of',
           'regressor_curves', 'robot_by_name', 'run_curves']

FloatArray = npt.NDArray[np.float64]

#: Seconds of stream after which the frozen models are scored (those within the stream).
CHECKPOINTS_S: tuple[float, ...] = (10.0, 20.0, 30.0, 60.0, 90.0, 120.0, 150.0, 180.0, 240.0)

_HELD_OUT_SEED = 1_000_000  # held-out excitations' seeds start here, far from any stream's
#: The simulator's sensor noise of the noisy curves: position (rad, m), velocity (rad/s, m/s)
#: standard deviations, and the effort's as a fraction of each joint's effort limit.
POSITION_NOISE, VELOCITY_NOISE, EFFORT_NOISE_FRACTION = 1e-4, 1e-3, 0.005
#: Robots by name: the shipped SCARA (config/scara.yaml) and arms of example-robot-data.
ROBOTS = ('scara', 'ur5', 'panda')


@functools.lru_cache(maxsize=None)
def robot_by_name(name: str) -> Robot:
    """The robot ``name`` of :data:`ROBOTS` (or any ``example_robot`` arm) as simulated:
    ``ScaraParams`` of config/scara.yaml, or a ``PinocchioRobot`` with the simulator's
    default friction and rotor inertia. Cached: a worker builds each robot once."""
    if name == 'scara':
        return ScaraParams.from_yaml(config_path('scara.yaml'))
    from scara_ident_ros.sim.example_robots import example_robot
    from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot
    arm = example_robot(name)
    return PinocchioRobot.from_urdf(arm.urdf, joints=arm.joints)


def physical_model_of(name: str, *, stribeck: bool = False) -> PhysicalModel:
    """The physical model of URDF arm ``name`` (module docstring), its θ still zero;
    ``stribeck``: with a Stribeck column at the simulator's Stribeck velocity."""
    from scara_ident_ros.sim.example_robots import example_robot
    robot = robot_by_name(name)
    if isinstance(robot, ScaraParams):
        raise ValueError("the SCARA's references are its analytic regressor, not a URDF's")
    eps = float(np.max(robot.friction.stick_velocity))
    vs = float(np.max(robot.friction.stribeck_velocity)) if stribeck else 0.0
    return PhysicalModel.from_urdf_file(example_robot(name).urdf,
                                        joint_names=robot.joint_names, coulomb='tanh',
                                        coulomb_eps=eps, stribeck_velocity=vs)


@dataclass(frozen=True)
class Curve:
    """One learning curve.

    Attributes
    ----------
    label : str
        ``'FFS lm'``, ``'FFMW bp'``, ``'LS'``, ``'RLS'``.
    seed : int
        Seed of the stream (and of the network's weights).
    seconds : ndarray of shape (K,)
        Seconds of stream at the checkpoints.
    nmse : ndarray of shape (K, n)
        Held-out NMSE per joint of the frozen model at each checkpoint.
    cpu_s : float
        CPU seconds the whole stream cost (prediction, learning, scoring excluded).
    """

    label: str
    seed: int
    seconds: FloatArray
    nmse: FloatArray
    cpu_s: float


def held_out_set(params: Robot, *, seed: int = 0, config: SimConfig | None = None,
                 excitation_s: float = 6.0, sequence_s: float = 30.0) -> Dataset:
    """Motions no stream contains: 5 ``standard`` excitations of ``excitation_s`` seconds
    and ``sequence_s`` seconds of ``sequence``.

    Their seeds are ``1_000_000 + 10 * seed + i``; the inputs go through the identifier's
    input stage (zero-phase q''), as a recorded robot's would. With ``config`` noise, the
    held-out measurements are noisy too (the noise floor is then reachable, not beatable).
    """
    parts = []
    for i in range(5):
        record = simulate_record(params, seconds=excitation_s,
                                 seed=_HELD_OUT_SEED + 10 * seed + i, config=config)
        parts.append(dataset_from_record(record, acceleration='estimated'))
    record = simulate_record(params, seconds=sequence_s, seed=_HELD_OUT_SEED + 10 * seed + 5,
                             preset='sequence', config=config)
    parts.append(dataset_from_record(record, acceleration='estimated'))
    return Dataset(np.concatenate([p.stamp_ns for p in parts]),
                   np.vstack([p.X for p in parts]), np.vstack([p.Y for p in parts]),
                   'estimated', 'held-out')


def _nmse(Y: FloatArray, predicted: FloatArray) -> FloatArray:
    return effort_errors(Y, predicted).nmse


def network_curve(record: SimRecord, held_out: Dataset, params: Robot, *, method: str,
                  trainer: str, seed: int = 0, lm_steps: int | None = None,
                  checkpoints: Sequence[float] = CHECKPOINTS_S,
                  window: int | None = None, lm_interval: int | None = None,
                  validation_block: int | None = None, lm_float64: bool | None = None,
                  lm_slow_share: float | None = None, lm_friction_steps: bool | None = None,
                  reservoir_size: int | None = None, physical: PhysicalModel | None = None,
                  background: bool = False) -> Curve:
    """Stream ``record`` through the node's identifier of ``method`` and ``trainer``.

    The identifier is the node's (:func:`~scara_ident_ros.identification.
    identifier_builder.build_identifier` with ``IdentifierSettings.defaults()``): the network
    scaled by the robot's limits, the samples checked against them, a tenth of the samples
    (blocks of ``validation_block``) held back for its own validation. ``lm_steps``,
    ``lm_interval``, ``lm_float64``, ``lm_slow_share``, ``lm_friction_steps``, ``window``,
    ``validation_block`` and ``reservoir_size`` are the node's parameters of those names
    (the ``lm`` trainer's steps per update, samples between updates, float64 normal
    equations, share of slow samples, friction-step units and reservoir samples; the
    centred q'' fit's samples); None: the node's default.

    Method ``hybrid`` needs ``physical``, the arm's (fresh) physical model: it learns by
    RLS, its residual network by ``trainer`` (``lm``).

    ``background``: ``lm`` learns in a learner process, as in the node by default
    (``lm_background``); the stream is then fed at its own rate in wall time (a node's
    pace: the learner's updates depend on it), the latest weights taken at each checkpoint.
    """
    if method == 'hybrid' and physical is None:
        raise ValueError('method hybrid needs the physical model of a URDF arm')
    changes = {'lm_steps': lm_steps, 'lm_interval': lm_interval,
               'validation_block': validation_block, 'lm_float64': lm_float64,
               'lm_slow_share': lm_slow_share, 'lm_friction_steps': lm_friction_steps,
               'reservoir_size': reservoir_size}
    settings = IdentifierSettings.defaults(method=method, trainer=trainer, seed=seed,
                                           **{k: v for k, v in changes.items() if v is not None})
    limits = JointLimits.of(params.joint_names,
                            {name: params.array(name) for name in LIMIT_NAMES}, source='robot')
    ident = build_identifier(
        params.joint_names, settings, limits, physical=physical, background=background,
        differentiator=(None if window is None
                        else make_differentiator('centred', window=window)))
    model = ident.model
    beside = background_learner(ident.trainer)
    if beside is not None:
        beside.wait_ready(30.0)
    names = params.joint_names
    stamps = record.stamp_ns
    marks = [int(stamps[0] + round(s * 1e9)) for s in checkpoints]
    scores: list[FloatArray] = []
    cpu = 0.0
    start = 0
    wall0 = time.monotonic()
    for mark in marks:
        stop = int(np.searchsorted(stamps, mark))
        began = time.process_time()
        for i in range(start, stop):
            if beside is not None and i % 100 == 0:  # the stream's pace
                ahead = (stamps[i] - stamps[0]) * 1e-9 - (time.monotonic() - wall0)
                if ahead > 0:
                    time.sleep(ahead)
            ident.process(int(stamps[i]), names, record.q[i], record.qd[i], record.effort[i])
        cpu += time.process_time() - began
        start = stop
        if beside is not None:
            beside.poll()
        scores.append(_nmse(held_out.Y, model.predict(held_out.X)))
    if beside is not None:
        beside.close()
    label = 'hybrid' if method == 'hybrid' else f'{method_spec(method).label} {trainer}'
    node = IdentifierSettings.defaults()
    if trainer == 'lm' and settings.lm_steps != node.lm_steps:
        label += f' ×{settings.lm_steps}'
    if trainer == 'lm' and settings.reservoir_size != node.reservoir_size:
        label += f' ({settings.reservoir_size} samples)'
    if beside is not None:
        label += ' (background)'
    return Curve(label, seed, np.asarray(checkpoints, float), np.array(scores), cpu)


def regressor_curves(record: SimRecord, held_out: Dataset, *, seed: int = 0,
                     checkpoints: Sequence[float] = CHECKPOINTS_S,
                     physical: PhysicalModel | None = None) -> tuple[Curve, Curve]:
    """The LS and RLS references on the stream's inputs (the same input stage).

    ``physical``: the URDF arm's model (:func:`physical_model_of`); None: the SCARA's
    analytic regressor.
    """
    n = record.q.shape[1]
    names = tuple(f'joint{j + 1}' for j in range(n))
    stage = InputStage(JointMap(names, n_joints=n))
    stamps, X, Y = stage.batch(record.stamp_ns, names, record.q, record.qd, record.effort)
    rls = RecursiveLeastSquares(physical)
    q_held, qd_held, qdd_held = (held_out.X[:, :n], held_out.X[:, n:2 * n],
                                 held_out.X[:, 2 * n:])
    ls_scores, rls_scores = [], []
    ls_cpu = rls_cpu = 0.0
    start = 0
    for seconds in checkpoints:
        stop = int(np.searchsorted(stamps, stamps[0] + round(seconds * 1e9)))
        began = time.process_time()
        if physical is None:
            fit = fit_reference(X[:stop], Y[:stop])
            ls_cpu = time.process_time() - began  # a batch fit: the last one is the cost
            ls_predicted = predict_reference(fit.identifier, held_out.X)
        else:
            physical.fit(X[:stop], Y[:stop])
            ls_cpu = time.process_time() - began
            ls_predicted = physical.predict(held_out.X)
        ls_scores.append(_nmse(held_out.Y, ls_predicted))
        began = time.process_time()
        for block in range(start, stop, 100):
            end = min(block + 100, stop)
            rls.update(X[block:end, :n], X[block:end, n:2 * n], X[block:end, 2 * n:],
                       Y[block:end])
        rls_cpu += time.process_time() - began
        start = stop
        rls_scores.append(_nmse(held_out.Y, rls.predict(q_held, qd_held, qdd_held)))
    times = np.asarray(checkpoints, float)
    return (Curve('LS', seed, times, np.array(ls_scores), ls_cpu),
            Curve('RLS', seed, times, np.array(rls_scores), rls_cpu))


def curves_markdown(curves: Sequence[Curve], *, noise_floor: FloatArray | None = None,
                    stream_seconds: float | None = None) -> str:
    """Median [min–max] over seeds of the worst joint's held-out NMSE at each checkpoint.

    Then, per curve label, the per-joint medians at the last checkpoint and the CPU cost
    per second of stream.
    """
    groups: dict[str, list[Curve]] = defaultdict(list)
    for curve in curves:
        groups[curve.label].append(curve)
    seconds = next(iter(groups.values()))[0].seconds
    header = ('| method | ' + ' | '.join(f'{s:g} s' for s in seconds)
              + ' | per joint at the end (median) | CPU per s of stream |')
    lines = ['Held-out NMSE of the worst joint, median [min–max] over '
             f'{len(next(iter(groups.values())))} seeds:', '', header,
             '|' + '---|' * (len(seconds) + 3)]
    for label, group in groups.items():
        worst = np.array([c.nmse.max(axis=1) for c in group])  # (seeds, K)
        cells = [f'{format_value(float(np.median(col)))} [{format_value(float(col.min()))}–'
                 f'{format_value(float(col.max()))}]' for col in worst.T]
        joints = np.median(np.array([c.nmse[-1] for c in group]), axis=0)
        per_joint = ', '.join(format_value(float(v)) for v in joints)
        span = stream_seconds if stream_seconds else float(seconds[-1])
        cpu = np.median([c.cpu_s for c in group]) / span
        lines.append(f'| {label} | ' + ' | '.join(cells) + f' | {per_joint} | '
                     f'{cpu * 100:.1f} % |')
    if noise_floor is not None:
        lines += ['', 'Noise floor (effort noise variance / held-out effort variance) per '
                  'joint: ' + ', '.join(format_value(float(v)) for v in noise_floor)]
    return '\n'.join(lines)


def noisy_config(params: Robot, seed: int) -> SimConfig:
    """Simulation settings with the sensor noise of the noisy learning curves."""
    effort = tuple(float(v) * EFFORT_NOISE_FRACTION for v in params.array('effort_max'))
    n = len(effort)
    return SimConfig(seed=seed, position_noise=(POSITION_NOISE,) * n,
                     velocity_noise=(VELOCITY_NOISE,) * n, effort_noise=effort, n_joints=n)


def noise_floor(params: Robot, held_out: Dataset) -> FloatArray:
    """The NMSE per joint of a perfect model on noisy held-out efforts (n,)."""
    effort_std = params.array('effort_max') * EFFORT_NOISE_FRACTION
    return np.asarray(effort_std ** 2 / held_out.Y.var(axis=0))


def _job(job: tuple[ScaraParams | str, str, str, int, float, bool, tuple[float, float],
                    int | None, int | None, bool]) -> list[Curve]:
    # One BLAS thread: a worker's LM systems gain nothing from more, and two workers with
    # two threads each on 2 cores doubled the CPU time measured per curve.
    with single_blas_thread():
        return _curves(*job)


def _curves(robot: ScaraParams | str, method: str, trainer: str, seed: int, seconds: float,
            noise: bool, held_out_s: tuple[float, float], lm_steps: int | None,
            reservoir_size: int | None, stribeck: bool) -> list[Curve]:
    params = robot_by_name(robot) if isinstance(robot, str) else robot
    physical = (physical_model_of(robot, stribeck=stribeck)
                if isinstance(robot, str) and robot != 'scara' else None)
    n = len(params.joint_names)
    config = noisy_config(params, seed) if noise else SimConfig(seed=seed, n_joints=n)
    record = simulate_record(params, seconds=seconds, seed=seed, preset='sequence',
                             config=config)
    held_out = held_out_set(params, config=noisy_config(params, 99) if noise else None,
                            excitation_s=held_out_s[0], sequence_s=held_out_s[1])
    checkpoints = tuple(s for s in CHECKPOINTS_S if s <= seconds) or (seconds,)
    if method == 'regressor':
        return list(regressor_curves(record, held_out, seed=seed, checkpoints=checkpoints,
                                     physical=physical))
    return [network_curve(record, held_out, params, method=method, trainer=trainer, seed=seed,
                          lm_steps=lm_steps, checkpoints=checkpoints,
                          reservoir_size=reservoir_size, physical=physical)]


def run_curves(robot: ScaraParams | str, *, seeds: Sequence[int], methods: Sequence[str],
               trainers: Sequence[str], seconds: float = 120.0, noise: bool = False,
               workers: int = 2, held_out_s: tuple[float, float] = (6.0, 30.0),
               lm_steps: int | None = None, references: bool = True,
               reservoir_size: int | None = None, stribeck: bool = False,
               finished: Callable[[list[Curve]], None] | None = None) -> list[Curve]:
    """Every curve: LS and RLS, then each trainer and method, for each seed.

    ``robot`` is a SCARA's parameters or a name of :data:`ROBOTS` (built in each worker).

    Each seed's stream is ``seconds`` of ``sequence`` (seed = stream seed = weight seed),
    with the sensor noise of :func:`noisy_config` if ``noise`` (held-out data noisy too).
    ``held_out_s`` are the seconds of each held-out excitation and of the held-out
    sequence (:func:`held_out_set`); ``lm_steps`` the ``lm`` trainer's steps per update,
    ``reservoir_size`` its samples (None: the node's); ``references`` False leaves out LS
    and RLS; ``stribeck`` gives a URDF arm's physical model (LS, RLS, ``hybrid``) its
    Stribeck column;
    ``finished`` is called with each job's curves as it ends (a long run on a busy machine
    keeps what it has done).
    The jobs run in ``workers`` processes, each with one BLAS thread. The CPU figures are
    then per process: on a machine with fewer free cores than workers they include waiting
    for the memory bus, not for the processor.
    """
    jobs = [(robot, 'regressor', '', seed, seconds, noise, held_out_s, lm_steps,
             reservoir_size, stribeck) for seed in seeds] if references else []
    jobs += [(robot, m, t, seed, seconds, noise, held_out_s, lm_steps, reservoir_size,
              stribeck) for t in trainers for m in methods for seed in seeds]
    if workers <= 1:
        results = [_job(job) for job in jobs]
        if finished is not None:
            for result in results:
                finished(result)
    else:
        with ProcessPoolExecutor(workers) as pool:
            futures = [pool.submit(_job, job) for job in jobs]
            if finished is not None:
                for future in as_completed(futures):
                    finished(future.result())
            results = [future.result() for future in futures]
    return [curve for result in results for curve in result]
