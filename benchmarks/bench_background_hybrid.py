"""The online hybrid learnt beside the stream (the node's default) against the synchronous one.

Both stream the same simulated ``sequence`` of an arm through the learning curves' identifier
(:func:`~scara_ident_ros.paper.learning_curves.network_curve`, node defaults) and score
their frozen models on the learning curves' held-out excitations. The background one is fed
at the stream's rate in wall time, as a node is, its ``lm`` in a learner process; the
synchronous one takes every update in the message path (``lm_background:=false``).
Figures: docs/results.md ("The node's default").

    python benchmarks/bench_background_hybrid.py --robot ur5 --seconds 30
"""
from __future__ import annotations

import argparse
import os
import sys
import time

from scara_ident_ros.paper.learning_curves import (CHECKPOINTS_S, held_out_set, network_curve,
                                                   physical_model_of, robot_by_name)
from scara_ident_ros.paper.datasets import simulate_record
from scara_ident_ros.sim import SimConfig


def main() -> int:
    """Run both, print worst-joint NMSE per checkpoint with the load average."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--robot', default='ur5')
    parser.add_argument('--seconds', type=float, default=30.0)
    parser.add_argument('--seed', type=int, default=0)
    args = parser.parse_args()
    params = robot_by_name(args.robot)
    n = len(params.joint_names)
    record = simulate_record(params, seconds=args.seconds, seed=args.seed, preset='sequence',
                             config=SimConfig(seed=args.seed, n_joints=n))
    held_out = held_out_set(params)
    checkpoints = tuple(s for s in CHECKPOINTS_S if s <= args.seconds) or (args.seconds,)
    print(f'{args.robot}, {args.seconds:g} s of sequence, seed {args.seed}: worst-joint '
          f'NMSE on held-out excitations at {", ".join(f"{c:g}" for c in checkpoints)} s')
    for background in (False, True):
        started, load = time.monotonic(), os.getloadavg()[0]
        curve = network_curve(record, held_out, params, method='hybrid', trainer='lm',
                              seed=args.seed, checkpoints=checkpoints,
                              physical=physical_model_of(args.robot), background=background)
        worst = ', '.join(f'{row.max():.2g}' for row in curve.nmse)
        print(f'  {curve.label}: {worst} (message path {curve.cpu_s:.1f} s CPU, '
              f'{time.monotonic() - started:.0f} s wall, load average {load:.1f} -> '
              f'{os.getloadavg()[0]:.1f})')
    return 0


if __name__ == '__main__':
    sys.exit(main())
