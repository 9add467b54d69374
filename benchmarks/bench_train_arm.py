"""``scara-ident train`` with its defaults on a recording of a ``robot_sim`` arm.

The issue's offline target: 120 s of a UR5's ``sequence`` excitation at 1 kHz (what
``scara-ident run --robot ur5 --duration 120`` records: ``robot_sim`` with friction and
rotor inertia), trained with ``scara-ident train`` and its defaults, each method scored on
held-out excitations of the same kind and range: the learning curves' held-out set
(``held_out_set``: 5 ``standard`` excitations and one ``sequence``, other seeds), its
q'' estimated by the identifier's input stage as ``train`` estimates the recording's.

The recording is simulated in-process (``simulate_record``, the simulator ``robot_sim``
runs) and written as a rosbag2 bag (MCAP, ``BagWriter``), the JointState messages
serialized by rosbags; ``train`` then reads it as any bag. Methods: ``physical`` and
``hybrid`` with ``--urdf`` (the arm's example-robot-data URDF), ``ffs`` alone without
(its defaults: data scaling). Prints per method the held-out NMSE per joint, the worst
joint and the training's wall time, and the load average.

    .venv/bin/python benchmarks/bench_train_arm.py [--robot ur5] [--seconds 120]
        [--methods physical hybrid ffs] [--held-out 6 30]
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from scara_ident_ros.bag.writer import BagWriter
from scara_ident_ros.cli import main as cli_main
from scara_ident_ros.nn.model_file import read_model_file
from scara_ident_ros.paper.datasets import simulate_record
from scara_ident_ros.paper.learning_curves import held_out_set, robot_by_name
from scara_ident_ros.sim import SimRecord


def write_bag(path: Path, record: SimRecord, names: tuple[str, ...]) -> Path:
    """``record``'s samples as sensor_msgs/JointState messages on /joint_states."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    msgtype = 'sensor_msgs/msg/JointState'
    JointState = store.types[msgtype]
    Header, Time = store.types['std_msgs/msg/Header'], store.types['builtin_interfaces/msg/Time']
    with BagWriter(path) as writer:
        connection = writer.add_connection('/joint_states', msgtype)
        batch = []
        for i, stamp in enumerate(record.stamp_ns.tolist()):
            msg = JointState(Header(Time(stamp // 1_000_000_000, stamp % 1_000_000_000), ''),
                             list(names), record.q[i].copy(), record.qd[i].copy(),
                             record.effort[i].copy())
            batch.append((connection.id, stamp, bytes(store.serialize_cdr(msg, msgtype))))
            if len(batch) == 1000:
                writer.write_batch(batch)
                batch = []
        writer.write_batch(batch)
    return path


def load_model(path: Path) -> object:
    """The trained model file, whatever its kind."""
    kind = read_model_file(path).kind
    if kind == 'physical':
        from scara_ident_ros.dynamics.physical_model import PhysicalModel
        return PhysicalModel.load(path)
    if kind == 'hybrid':
        from scara_ident_ros.learners.hybrid_model import HybridModel
        return HybridModel.load(path)
    from scara_ident_ros.nn import FeedForwardNet
    return FeedForwardNet.load(path)


def main() -> int:
    """Record, train each method, score on held-out excitations, print a table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--robot', default='ur5')
    parser.add_argument('--seconds', type=float, default=120.0)
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--methods', nargs='+', default=['physical', 'hybrid', 'ffs'])
    parser.add_argument('--held-out', type=float, nargs=2, default=(6.0, 30.0),
                        metavar=('EXCITATION_S', 'SEQUENCE_S'))
    args = parser.parse_args()
    from scara_ident_ros.sim.example_robots import example_robot

    robot = robot_by_name(args.robot)
    urdf = example_robot(args.robot).urdf
    names = tuple(robot.joint_names)
    record = simulate_record(robot, seconds=args.seconds, seed=args.seed, preset='sequence')
    held = held_out_set(robot, seed=args.seed, excitation_s=args.held_out[0],
                        sequence_s=args.held_out[1])
    print(f'### `scara-ident train` defaults on {args.seconds:g} s of {args.robot} '
          f'`sequence` (seed {args.seed}); held out {args.held_out[0]:g} s x 5 standard + '
          f'{args.held_out[1]:g} s sequence\n')
    print('| method | held-out NMSE per joint | worst | train wall time (s) |')
    print('|---|---|---|---|')
    with tempfile.TemporaryDirectory() as tmp:
        bag = write_bag(Path(tmp) / 'bag', record, names)
        for method in args.methods:
            out = Path(tmp) / f'{method}.npz'
            argv = ['train', str(bag), '--method', method, '--out', str(out),
                    '--seed', str(args.seed)]
            if method in ('physical', 'hybrid'):
                argv += ['--urdf', str(urdf)]
            began = time.monotonic()
            with contextlib.redirect_stdout(io.StringIO()), \
                    contextlib.redirect_stderr(io.StringIO()) as err:
                code = cli_main(argv)
            wall = time.monotonic() - began
            if code != 0:
                print(f'| {method} | train failed ({code}): {err.getvalue()[-200:]} | | |')
                continue
            model = load_model(out)
            predicted = model.predict(held.X)  # type: ignore[attr-defined]
            nmse = np.mean((held.Y - predicted) ** 2, axis=0) / held.Y.var(axis=0)
            print(f'| {method} | {", ".join(f"{v:.2g}" for v in nmse)} | '
                  f'{nmse.max():.2g} | {wall:.0f} |')
    print(f'\nload average {os.getloadavg()[0]:.1f}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
