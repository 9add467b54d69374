"""The hybrid's gate on the simulated arms: is the gated hybrid still as good?

The SCARA and the UR5 of ``bench_physical.py`` (its data, split and hybrid: 30 s of motion
to train, 10 s of another motion held out, LM up to 150 iterations on 4,000 samples, early
stop on ``train``'s validation blocks of 1 s), one hybrid network per ``--seeds``; each
network's correction gated on the validation blocks by each rule of
``bench_physical_real.GATES`` (the same network for every rule). Prints, per robot and rule,
the held-out worst-joint NMSE per seed, its mean, and the (seed, joint) where the hybrid is
worse than its physical part.

Usage::

    nice -n 5 .venv/bin/python benchmarks/bench_gate_sim.py [--robots scara ur5] \\
        [--seeds 0 1 2 3 4]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / 'benchmarks'))

import bench_physical as sim  # noqa: E402
from bench_physical_real import GATES  # noqa: E402

from scara_ident_ros.blas_threads import single_blas_thread  # noqa: E402
from scara_ident_ros.cli import train as train_cli  # noqa: E402
from scara_ident_ros.dynamics.physical_options import select_coulomb  # noqa: E402
from scara_ident_ros.learners.hybrid_model import fit_hybrid  # noqa: E402
from scara_ident_ros.dynamics.physical_model import PhysicalModel  # noqa: E402
from scara_ident_ros.identification.split import block_index, block_split  # noqa: E402
from scara_ident_ros.nn.presets import make_network  # noqa: E402

SHOWN = ('no gate', 'old gate', 'gate', 'gate, level 0.5')


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--robots', nargs='+', default=['scara', 'ur5'],
                        choices=['scara', 'ur5'])
    parser.add_argument('--seeds', type=int, nargs='+', default=[0, 1, 2, 3, 4])
    args = parser.parse_args()
    print(f'load average {open("/proc/loadavg").read().split()[:3]}')
    for robot in args.robots:
        urdf, make = ((sim.SCARA_URDF, sim.scara_dataset) if robot == 'scara'
                      else (sim.ur5_urdf(), sim.ur5_dataset))
        train_all, held = make(30.0, 7), make(10.0, 1000)
        train, validation = block_split(train_all, 0.2, block_s=1.0, seed=0)
        blocks = block_index(validation.stamp_ns, block_s=1.0,
                             start_ns=int(train_all.stamp_ns[0]))

        def build(coulomb: str, eps: float, urdf: Path = urdf) -> PhysicalModel:
            return PhysicalModel.from_urdf_file(urdf, coulomb=coulomb, coulomb_eps=eps)

        _, choice = select_coulomb(build, (train.X, train.Y), (validation.X, validation.Y))
        names = build(choice.coulomb, choice.eps).joint_names
        x_min, x_max, _, _ = train_cli._limit_ranges(urdf, names, train_all.X, train_all.Y)
        scores: dict[str, list[np.ndarray]] = {key: [] for key in SHOWN}
        physical: list[np.ndarray] = []
        for seed in args.seeds:
            started = time.perf_counter()
            with single_blas_thread():
                hybrid, _ = fit_hybrid(
                    build(choice.coulomb, choice.eps),
                    make_network('ffs', len(names), seed=seed, friction_steps=True),
                    (train.X, train.Y), validation=(validation.X, validation.Y),
                    x_range=(x_min, x_max), network_samples=4000, seed=seed,
                    iterations=150, max_fail=train_cli.MAX_FAIL,
                    min_iterations=train_cli.MIN_ITERATIONS)
            c_val = hybrid.raw_correction(validation.X)
            r_val = validation.Y - hybrid.physical.predict(validation.X)
            c_held = hybrid.raw_correction(held.X)
            r_held = held.Y - hybrid.physical.predict(held.X)
            var = held.Y.var(axis=0)
            physical.append(np.mean(r_held ** 2, axis=0) / var)
            for key in SHOWN:
                gate = GATES[key](c_val, r_val, blocks)
                scores[key].append(np.mean((r_held - gate * c_held) ** 2, axis=0) / var)
            print(f'{robot} seed {seed}: {time.perf_counter() - started:.0f} s', flush=True)
        base = np.array(physical)
        print(f'\n{robot}: physical part, worst joint {base.max(axis=1).mean():.3g}')
        print('| gate | worst joint per seed | mean | (seed, joint) worse than physical |')
        print('|---|---|---|---|')
        for key in SHOWN:
            values = np.array(scores[key])
            worse = [(seed, names[j]) for s, seed in enumerate(args.seeds)
                     for j in range(len(names)) if values[s, j] > base[s, j] * (1 + 1e-9)]
            print(f'| {key} | {", ".join(f"{v:.3g}" for v in values.max(axis=1))} | '
                  f'{values.max(axis=1).mean():.3g} | {len(worse)}: '
                  f'{", ".join(f"{s} {n}" for s, n in worse)} |', flush=True)
    print(f'load average {open("/proc/loadavg").read().split()[:3]}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
