"""Online identification at a real robot's rates: 1 kHz, 500 Hz and 100 Hz, jittered stamps.

A ros2_control joint_state_broadcaster publishes at its controller's rate (500 Hz on a UR
e-Series, 125 Hz on older arms) with jittered stamps. For each seed, ``--seconds`` of
``scara_sim``'s default stream (``sequence``) are simulated at each rate with the
simulator's ``jitter`` (the state simulated at each jittered stamp), learnt online by FFS
with the ``lm`` trainer through the identifier's own pipeline, and the frozen model is
scored at each checkpoint on the held-out motions of ``bench_learning_curves.py`` (at
1 kHz, never streamed). At 500 Hz also with ``lm_interval`` 100 (the LM updates per second
of 1 kHz), at 100 Hz with the settings docs/real_robot.md recommends there (``window`` 5,
``lm_interval`` 40, ``validation_block`` 100).

Prints a Markdown table: median [min-max] over seeds of the worst joint's held-out NMSE, and
the CPU per second of stream (the identifier's core, without ROS). Two worker processes, one
BLAS thread each.

    .venv/bin/python benchmarks/bench_rates.py [--seeds 3] [--seconds 120] [--only LABEL ...]
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from threadpoolctl import threadpool_limits

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.paper.datasets import simulate_record
from scara_ident_ros.paper.learning_curves import (CHECKPOINTS_S, Curve, curves_markdown,
                                                   held_out_set, network_curve)
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig

#: label -> (rate (Hz), jitter (s), identifier settings)
STREAMS: dict[str, tuple[float, float, dict[str, Any]]] = {
    '1 kHz': (1000.0, 0.0, {}),
    '500 Hz, jitter 0.2 ms': (500.0, 2e-4, {}),
    '500 Hz, jitter 0.2 ms, lm_interval 100': (500.0, 2e-4, {'lm_interval': 100}),
    '100 Hz, jitter 1 ms': (100.0, 1e-3, {}),
    '100 Hz, jitter 1 ms, window 5, lm_interval 40, validation_block 100':
        (100.0, 1e-3, {'window': 5, 'lm_interval': 40, 'validation_block': 100}),
}


def _curve(job: tuple[str, int, float]) -> Curve:
    label, seed, seconds = job
    rate, jitter, settings = STREAMS[label]
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    with threadpool_limits(limits=1, user_api='blas'):
        config = SimConfig(dt=round(1e9 / rate) * 1e-9, jitter=jitter, seed=seed)
        record = simulate_record(params, seconds=seconds, seed=seed, preset='sequence',
                                 config=config)
        checkpoints = tuple(s for s in CHECKPOINTS_S if s <= seconds) or (seconds,)
        curve = network_curve(record, held_out_set(params), params, method='ffs',
                              trainer='lm', seed=seed, checkpoints=checkpoints, **settings)
    return dataclasses.replace(curve, label=label)


def main() -> int:
    """Run every stream for every seed and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--seeds', type=int, default=3)
    parser.add_argument('--seconds', type=float, default=120.0)
    parser.add_argument('--workers', type=int, default=2)
    parser.add_argument('--only', nargs='+', choices=list(STREAMS), default=list(STREAMS),
                        metavar='LABEL', help='these streams only (labels of the table)')
    args = parser.parse_args()
    started = time.monotonic()
    jobs = [(label, seed, args.seconds) for label in args.only for seed in range(args.seeds)]
    with ProcessPoolExecutor(args.workers) as pool:
        curves = list(pool.map(_curve, jobs))
    print(curves_markdown(curves, stream_seconds=args.seconds))
    print(f'\n{time.monotonic() - started:.0f} s wall, load average '
          f'{os.getloadavg()[0]:.1f}', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
