"""The physical model, the hybrid and FFS alone on held-out motion of the same kind.

Two robots, each simulated at 1 kHz without noise, its q'' estimated from q' by the
identifier's input stage (the zero-phase centred fit), as ``scara-ident train`` reads a bag:

``scara``
    the project's simulator (``sim/simulator.py``: the SCARA of config/scara.yaml, computed
    torque + PD, Coulomb friction tanh(q'/0.05)), its 'sequence' excitation (a new random
    excitation every 5 s, blended): ``--seconds`` of seed 7 to train, ``--held-out`` seconds
    of seed 1000 to evaluate. Modelled from urdf/scara.urdf.
``ur5``
    the UR5 of example-robot-data, simulated here: Pinocchio's forward dynamics
    (``pin.aba``, 4 semi-implicit Euler steps per sample) under computed torque + PD
    (ωn = 20 rad/s) on a sum of 3 random sinusoids per joint (0.2-0.8 Hz), with joint
    friction the model does not have exactly: viscous, Coulomb tanh(q'/0.01) and a Stribeck
    bump 0.5·f_c·exp(−(q'/0.1)²)·tanh(q'/0.01). Training: seed 7, held out: seed 1000.

Models, as ``scara-ident train`` fits them:

Every model trains on the samples outside the validation blocks (``train``'s block split:
20 % of the 1 s blocks validate).

``physical[...]``
    least squares on every training sample, Coulomb shape sign or tanh(q'/ε) (ε in rad/s).
``physical[auto]``
    the shape of lowest validation NMSE among ``physical_options.CANDIDATES``, as
    ``scara-ident train`` chooses it by default.
``hybrid``
    physical[auto], then FFS on its residual: ``--samples`` training
    samples, Levenberg-Marquardt up to ``--iterations``, early-stopped on the validation
    blocks (``train``'s max_fail and min_iterations), inputs scaled by the URDF's limits,
    outputs by the residual's range; the network starts at 0 (``start_at_zero``).
``hybrid, no stop``
    the same network trained for ``--iterations`` without a validation split.
``FFS``
    an FFS network alone, ``train``'s defaults (friction steps, data scaling, the same
    block split and samples).

Prints per robot and model the held-out NMSE per joint, the fit's wall time (BLAS on one
thread) and the load average. The default is CI-sized (~2-4 min on 2 shared cores);
``--seconds 80 --iterations 500 --samples 8000`` is ``train``'s default scale.

Usage::

    .venv/bin/python benchmarks/bench_physical.py [--robots scara ur5] [--seconds 30]
"""
from __future__ import annotations

import argparse
import importlib.metadata
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from scara_ident_ros.blas_threads import single_blas_thread  # noqa: E402
from scara_ident_ros.cli import train as train_cli  # noqa: E402
from scara_ident_ros.dynamics import ScaraParams  # noqa: E402
from scara_ident_ros.dynamics.physical_options import select_coulomb  # noqa: E402
from scara_ident_ros.learners.hybrid_model import fit_hybrid  # noqa: E402
from scara_ident_ros.dynamics.physical_model import PhysicalModel  # noqa: E402
from scara_ident_ros.identification.dataset import Dataset, make_dataset  # noqa: E402
from scara_ident_ros.identification.metrics import effort_errors  # noqa: E402
from scara_ident_ros.paper.datasets import dataset_from_record, simulate_record  # noqa: E402
from scara_ident_ros.nn import fit  # noqa: E402
from scara_ident_ros.nn.presets import make_network  # noqa: E402
from scara_ident_ros.identification.split import block_split  # noqa: E402

SCARA_URDF = ROOT / 'urdf' / 'scara.urdf'
UR5_VISCOUS = np.array([2.0, 2.0, 1.5, 0.5, 0.5, 0.3])   # N·m·s/rad
UR5_COULOMB = np.array([4.0, 4.0, 3.0, 1.0, 1.0, 0.8])   # N·m
UR5_EPS = 0.01                                           # rad/s, the true tanh's
UR5_STRIBECK_SPEED = 0.1                                 # rad/s
UR5_HOME = np.array([0.0, -1.2, 1.2, -1.5, -1.5, 0.0])   # rad
COULOMB_VARIANTS = (('sign', 1.0), ('tanh', 0.01), ('tanh', 0.05), ('tanh', 0.2))


def ur5_urdf() -> Path:
    """The UR5 URDF of the installed example-robot-data (its file record)."""
    for file in importlib.metadata.files('example-robot-data') or ():
        if str(file).endswith('ur_description/urdf/ur5_robot.urdf'):
            return Path(str(file.locate()))
    raise FileNotFoundError('example-robot-data has no ur5_robot.urdf')


def ur5_friction(qd: np.ndarray) -> np.ndarray:
    """The simulated UR5's joint friction (N·m) at speeds ``qd`` (rad/s)."""
    shape = np.tanh(qd / UR5_EPS)
    return (UR5_VISCOUS * qd + UR5_COULOMB * shape
            + 0.5 * UR5_COULOMB * np.exp(-(qd / UR5_STRIBECK_SPEED) ** 2) * shape)


def ur5_dataset(seconds: float, seed: int) -> Dataset:
    """The UR5 under computed torque on random sinusoids; q'' estimated (module docstring)."""
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(ur5_urdf()))
    data = model.createData()
    rng = np.random.default_rng(seed)
    n, dt, substeps = model.nv, 1e-3, 4
    amp = rng.uniform(0.15, 0.5, (3, n))                       # rad
    omega = 2 * np.pi * rng.uniform(0.2, 0.8, (3, n))          # rad/s
    phase = rng.uniform(0.0, 2 * np.pi, (3, n))

    def desired(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        arg = omega * t + phase
        return (UR5_HOME + (amp * np.sin(arg)).sum(axis=0),
                (amp * omega * np.cos(arg)).sum(axis=0),
                -(amp * omega ** 2 * np.sin(arg)).sum(axis=0))

    count = round(seconds / dt)
    q, qd, _ = desired(0.0)
    qs, qds, efforts = np.empty((count, n)), np.empty((count, n)), np.empty((count, n))
    kp, kd = 400.0, 40.0
    for k in range(count):
        q_d, qd_d, qdd_d = desired(k * dt)
        command = qdd_d + kp * (q_d - q) + kd * (qd_d - qd)
        tau = pin.rnea(model, data, q, qd, command) + ur5_friction(qd)
        qs[k], qds[k], efforts[k] = q, qd, tau
        for _ in range(substeps):
            qdd = pin.aba(model, data, q, qd, tau - ur5_friction(qd))
            qd = qd + qdd * (dt / substeps)
            q = q + qd * (dt / substeps)
    stamps = np.arange(count, dtype=np.int64) * 1_000_000
    return make_dataset(stamps, qs, qds, efforts)


def scara_dataset(seconds: float, seed: int) -> Dataset:
    """The project's simulated SCARA on its 'sequence' excitation; q'' estimated."""
    record = simulate_record(ScaraParams(), seconds=seconds, seed=seed, preset='sequence')
    return dataset_from_record(record, acceleration='estimated')


def nmse(model: Callable[[np.ndarray], np.ndarray], data: Dataset) -> np.ndarray:
    """Held-out NMSE per joint of ``model``'s predictions (the package's one NMSE)."""
    return effort_errors(data.Y, model(data.X)).nmse


def row(robot: str, label: str, values: np.ndarray, seconds: float, note: str = '') -> str:
    cells = ' | '.join(f'{v:.2e}' for v in values)
    return (f'| {robot} | {label} | {cells} | {values.max():.2e} | {seconds:.1f} | '
            f'{os.getloadavg()[0]:.1f} | {note} |')


def run_robot(robot: str, urdf: Path, train_all: Dataset, held_out: Dataset,
              args: argparse.Namespace) -> list[str]:
    """Every model of the module docstring on one robot; Markdown rows."""
    rows = []
    train, validation = block_split(train_all, 0.2, block_s=1.0, seed=0)
    for coulomb, eps in COULOMB_VARIANTS:
        started = time.perf_counter()
        model = PhysicalModel.from_urdf_file(urdf, coulomb=coulomb, coulomb_eps=eps)
        model.fit(train.X, train.Y)
        label = 'physical[sign]' if coulomb == 'sign' else f'physical[tanh {eps:g}]'
        rows.append(row(robot, label, nmse(model.predict, held_out),
                        time.perf_counter() - started))

    def build(coulomb: str, eps: float) -> PhysicalModel:
        return PhysicalModel.from_urdf_file(urdf, coulomb=coulomb, coulomb_eps=eps)

    started = time.perf_counter()
    chosen, choice = select_coulomb(build, (train.X, train.Y), (validation.X, validation.Y))
    rows.append(row(robot, 'physical[auto]', nmse(chosen.predict, held_out),
                    time.perf_counter() - started, f'chose {choice.label}'))
    names = chosen.joint_names
    x_min, x_max, _, _ = train_cli._limit_ranges(urdf, names, train_all.X, train_all.Y)
    for label, stop in (('hybrid', True), ('hybrid, no stop', False)):
        started = time.perf_counter()
        with single_blas_thread():
            hybrid, history = fit_hybrid(
                build(choice.coulomb, choice.eps),
                make_network('ffs', len(names), seed=0, friction_steps=True),
                (train.X, train.Y),
                validation=(validation.X, validation.Y) if stop else None,
                x_range=(x_min, x_max), network_samples=args.samples, seed=0,
                iterations=args.iterations, max_fail=train_cli.MAX_FAIL,
                min_iterations=train_cli.MIN_ITERATIONS)
        rows.append(row(robot, label, nmse(hybrid.predict, held_out),
                        time.perf_counter() - started,
                        f'{history.best_iteration} of {history.iterations} iterations, '
                        f'{history.stop_reason}'))
    started = time.perf_counter()
    network = make_network('ffs', len(names), seed=0, friction_steps=True)
    fitted = train.subsample(args.samples, seed=0) if args.samples < len(train) else train
    with single_blas_thread():
        history = fit(network, fitted.X, fitted.Y, iterations=args.iterations,
                      validation=(validation.X, validation.Y),
                      max_fail=train_cli.MAX_FAIL,
                      min_iterations=train_cli.MIN_ITERATIONS)
    rows.append(row(robot, 'FFS', nmse(network.predict, held_out),
                    time.perf_counter() - started,
                    f'{history.best_iteration} of {history.iterations} iterations, '
                    f'{history.stop_reason}'))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--robots', nargs='+', default=['scara', 'ur5'],
                        choices=['scara', 'ur5'])
    parser.add_argument('--seconds', type=float, default=30.0, help='training motion (s)')
    parser.add_argument('--held-out', type=float, default=10.0, help='held-out motion (s)')
    parser.add_argument('--iterations', type=int, default=150)
    parser.add_argument('--samples', type=int, default=4000)
    args = parser.parse_args()
    print(f'bench_physical: {args.seconds:g} s to train, {args.held_out:g} s held out, '
          f'LM up to {args.iterations} iterations on {args.samples} samples\n')
    header = None
    for robot in args.robots:
        if robot == 'scara':
            urdf, data = SCARA_URDF, scara_dataset
        else:
            urdf, data = ur5_urdf(), ur5_dataset
        started = time.perf_counter()
        train_all, held_out = data(args.seconds, 7), data(args.held_out, 1000)
        print(f'{robot}: {len(train_all)} training and {len(held_out)} held-out samples '
              f'simulated in {time.perf_counter() - started:.1f} s\n')
        n = held_out.Y.shape[1]
        if header != n:
            header = n
            joints = ' | '.join(f'joint {j + 1}' for j in range(n))
            print(f'| robot | model | {joints} | worst | fit (s) | load | notes |')
            print('|' + '---|' * (n + 6))
        for line in run_robot(robot, urdf, train_all, held_out, args):
            print(line, flush=True)
        print()


if __name__ == '__main__':
    main()
