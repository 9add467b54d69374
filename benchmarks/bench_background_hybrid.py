"""The online hybrid learnt beside the stream (the node's default) against the synchronous one.

Both stream the same simulated ``sequence`` of an arm through the learning curves' identifier
(:func:`~scara_ident_ros.paper.learning_curves.network_curve`, node defaults) and score
their frozen models on the learning curves' held-out excitations. The background one is fed
at the stream's rate in wall time, as a node is, its ``lm`` in a learner process; the
synchronous one takes every update in the message path (``lm_background:=false``).
With several seeds it ends with each path's median and range of the worst joint at the
last checkpoint. Figures: docs/results.md ("The node's default").

    python benchmarks/bench_background_hybrid.py --robot ur5 --seconds 30
    python benchmarks/bench_background_hybrid.py --robot panda --seconds 120 \
        --seeds 0 1 2 3 4 --paths background
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from scara_ident_ros.paper.learning_curves import (CHECKPOINTS_S, held_out_set, network_curve,
                                                   physical_model_of, robot_by_name)
from scara_ident_ros.paper.datasets import simulate_record
from scara_ident_ros.sim import SimConfig


def main() -> int:
    """Run the paths for each seed, print worst-joint NMSE per checkpoint with the load
    average, then each path's median [min-max] at the last checkpoint."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--robot', default='ur5')
    parser.add_argument('--seconds', type=float, default=30.0)
    parser.add_argument('--seeds', type=int, nargs='+', default=[0])
    parser.add_argument('--paths', nargs='+', choices=('synchronous', 'background'),
                        default=['synchronous', 'background'],
                        help='learn in the message path, in a learner process, or both')
    args = parser.parse_args()
    params = robot_by_name(args.robot)
    n = len(params.joint_names)
    held_out = held_out_set(params)
    checkpoints = tuple(s for s in CHECKPOINTS_S if s <= args.seconds) or (args.seconds,)
    finals: dict[str, list[float]] = {path: [] for path in args.paths}
    for seed in args.seeds:
        record = simulate_record(params, seconds=args.seconds, seed=seed, preset='sequence',
                                 config=SimConfig(seed=seed, n_joints=n))
        print(f'{args.robot}, {args.seconds:g} s of sequence, seed {seed}: worst-joint '
              f'NMSE on held-out excitations at {", ".join(f"{c:g}" for c in checkpoints)} s')
        for path in args.paths:
            started, load = time.monotonic(), os.getloadavg()[0]
            curve = network_curve(record, held_out, params, method='hybrid', trainer='lm',
                                  seed=seed, checkpoints=checkpoints,
                                  physical=physical_model_of(args.robot),
                                  background=path == 'background')
            worst = ', '.join(f'{row.max():.2g}' for row in curve.nmse)
            finals[path].append(float(curve.nmse[-1].max()))
            print(f'  {path} ({curve.label}): {worst} (message path {curve.cpu_s:.1f} s CPU, '
                  f'{time.monotonic() - started:.0f} s wall, load average {load:.1f} -> '
                  f'{os.getloadavg()[0]:.1f})', flush=True)
    if len(args.seeds) > 1:
        print(f'worst joint at {checkpoints[-1]:g} s over seeds {args.seeds}:')
        for path, values in finals.items():
            print(f'  {path}: median {np.median(values):.2g} '
                  f'[{min(values):.2g}-{max(values):.2g}]')
    return 0


if __name__ == '__main__':
    sys.exit(main())
