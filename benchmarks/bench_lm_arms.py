"""Cost of one Levenberg–Marquardt step of the identifier's ``lm`` trainer against the number
of joints (4: the SCARA, 6: a UR5, 7: a Panda) and the reservoir's size.

One step is what :class:`~scara_ident_ros.identification.reservoir_lm.ReservoirLM` does per LM
step: the normal equations' blocks on the reservoir (float32 hidden-layer blocks, the
default), one solve of the damped system, and the trial step's error on the reservoir. The
solve is timed both ways: ``structured`` (:meth:`NormalBlocks.solve`, the output weights
eliminated, one Cholesky of the hidden weights' Schur complement: the default) and
``plain`` (JᵀJ assembled, one Cholesky of the whole n_params system). Each part is timed
separately in CPU seconds (a busy machine stretches wall time, less so CPU time), median
of ``--repeats``, BLAS on one thread, on a 3n-40-n FFS network with
friction steps (the node's defaults) and random inputs in the network's scaled range (the
cost does not depend on the data). The last column is the share of one core taken by the
node's default schedule, 2 steps every 200 samples at 1 kHz (10 steps/s), counting one
solve per step (a rejected trial step adds a solve and a trial).

    nice -n 19 .venv/bin/python benchmarks/bench_lm_arms.py [--repeats 7]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable

import numpy as np
from scipy.linalg import cho_solve

from scara_ident_ros.blas_threads import single_blas_thread
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.nn.batch import mse_scaled
from scara_ident_ros.nn.levenberg_marquardt import normal_blocks

STEPS_PER_S = 10.0  # the node's default: 2 lm steps every 200 samples at 1 kHz


def _median_s(action: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        began = time.process_time()
        action()
        times.append(time.process_time() - began)
    return statistics.median(times)


def step_costs(n_joints: int, samples: int, *, repeats: int,
               n_hidden: int = 40) -> tuple[int, float, float, float, float]:
    """Return (weights, normal equations' blocks, plain solve, structured solve, trial), the
    times in seconds, for one LM step."""
    net = make_network('ffs', n_joints, n_hidden=n_hidden, seed=0, friction_steps=True)
    rng = np.random.default_rng(0)
    xs = rng.uniform(-1.0, 1.0, (samples, 3 * n_joints))
    ys = rng.uniform(-1.0, 1.0, (samples, n_joints))
    n = net.n_params
    jtr = np.empty(n)
    assemble = _median_s(lambda: normal_blocks(net, xs, ys, jtr=jtr, single=True), repeats)
    blocks = normal_blocks(net, xs, ys, jtr=jtr, single=True)
    jtj = np.empty((n, n))

    def plain() -> None:
        work = blocks.matrix(out=jtj)
        work.reshape(-1)[::n + 1] += 1e-3
        cho_solve((np.linalg.cholesky(work), True), jtr, check_finite=False)

    solve = _median_s(plain, repeats)
    structured = _median_s(lambda: blocks.solve(1e-3), repeats)
    trial = _median_s(lambda: mse_scaled(net, xs, ys), repeats)
    return n, assemble, solve, structured, trial


def main() -> int:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--repeats', type=int, default=7)
    parser.add_argument('--joints', type=int, nargs='+', default=[4, 6, 7])
    parser.add_argument('--samples', type=int, nargs='+', default=[1000, 2000, 3000, 4000])
    parser.add_argument('--hidden', type=int, default=40)
    args = parser.parse_args()
    print(f'### One lm step, 3n-{args.hidden}-n FFS, BLAS on one thread '
          f'(load average {os.getloadavg()[0]:.1f})\n')
    print('| joints | weights | reservoir samples | residuals | normal equations (ms) | '
          'solve, plain (ms) | solve, structured (ms) | trial (ms) | step, plain (ms) | '
          'step, structured (ms) | core at 10 steps/s, structured |')
    print('|---|---|---|---|---|---|---|---|---|---|---|')
    with single_blas_thread():
        for n_joints in args.joints:
            for samples in args.samples:
                n, assemble, solve, structured, trial = step_costs(
                    n_joints, samples, repeats=args.repeats, n_hidden=args.hidden)
                plain_s = assemble + solve + trial
                total = assemble + structured + trial
                print(f'| {n_joints} | {n} | {samples} | {samples * n_joints} | '
                      f'{assemble * 1e3:.1f} | {solve * 1e3:.1f} | {structured * 1e3:.1f} | '
                      f'{trial * 1e3:.1f} | {plain_s * 1e3:.1f} | {total * 1e3:.1f} | '
                      f'{total * STEPS_PER_S * 100:.0f} % |', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
