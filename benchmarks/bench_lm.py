"""Levenberg–Marquardt time to the same training error: ours against
``scipy.optimize.least_squares(method='lm')`` (MINPACK) given the same analytic Jacobian.

For each activation, on the same data and from the same initial weights: ours runs a fixed
number of iterations and its final MSE (scaled outputs) becomes the target; then scipy runs
until its MSE reaches that target (timed to the first residual evaluation at or below it),
or until a time limit, and the table says where it ended. Our time is the median of
several identical runs; scipy's is one run (it is slow, and it is deterministic too).

Data: 2,000 samples of the simulated SCARA (20 s of the 'standard' excitation at 1 kHz,
every 10th sample), or a smooth synthetic 12 → 4 map if the simulator is not importable.
BLAS is held to one thread for both (threadpoolctl).

Usage::

    .venv/bin/python benchmarks/bench_lm.py [--iterations 20] [--repeats 3] [--limit 600]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from scara_ident_ros.blas_threads import single_blas_thread  # noqa: E402
from scara_ident_ros.nn import FeedForwardNet, fit  # noqa: E402
from scara_ident_ros.nn.batch import jacobian  # noqa: E402
from scara_ident_ros.nn.network import predict_scaled  # noqa: E402
from scara_samples import scara_samples  # noqa: E402  (benchmarks/: the script's own folder)

ACTIVATIONS = ('mslog', 'slog', 'sigmoid')


class _Stop(Exception):
    pass


class ScipyRun:
    """Residuals and Jacobian for least_squares, stopping at a target MSE or a time limit."""

    def __init__(self, net: FeedForwardNet, x: np.ndarray, y: np.ndarray, target: float,
                 limit: float) -> None:
        self.net, self.x = net, x
        self.xs, self.ys = net.x_scaling.transform(x), net.y_scaling.transform(y)
        self.target, self.limit = target, limit
        self.best = np.inf
        self.start = 0.0
        self.reached_after: float | None = None
        self.nfev = self.njev = 0

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        self.nfev += 1
        r = (predict_scaled(self.net, self.xs, theta) - self.ys).ravel()
        mse = float(r @ r) / r.size
        self.best = min(self.best, mse)
        elapsed = time.perf_counter() - self.start
        if mse <= self.target:
            self.reached_after = elapsed
            raise _Stop
        if elapsed > self.limit:
            raise _Stop
        return r

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        self.njev += 1
        self.net.set_theta(theta)
        return jacobian(self.net, self.x)  # the same analytic Jacobian LM uses, dense

    def run(self, theta0: np.ndarray) -> None:
        from scipy.optimize import least_squares
        self.start = time.perf_counter()
        try:
            least_squares(self.residuals, theta0, jac=self.jacobian, method='lm', ftol=1e-15,
                          xtol=1e-15, gtol=1e-15, max_nfev=100_000)
        except _Stop:
            pass
        self.elapsed = time.perf_counter() - self.start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--samples', type=int, default=2000)
    parser.add_argument('--iterations', type=int, default=20, help='our LM iterations')
    parser.add_argument('--repeats', type=int, default=3, help='runs of ours (median)')
    parser.add_argument('--limit', type=float, default=600.0, help='scipy time limit, s')
    args = parser.parse_args()
    x, y, origin = scara_samples(args.samples, 10)
    rows = []
    with single_blas_thread():
        load_before = os.getloadavg()[0]
        fit(FeedForwardNet(12, 40, 4), x, y, iterations=2)  # warm caches and allocators
        for activation in ACTIVATIONS:
            times, mse = [], []
            for _ in range(args.repeats):
                net = FeedForwardNet(12, 40, 4, activation, seed=0)
                start = time.perf_counter()
                history = fit(net, x, y, iterations=args.iterations)
                times.append(time.perf_counter() - start)
                mse.append(history.mse[-1])
            assert len(set(mse)) == 1, 'our LM is deterministic'
            target = mse[0]
            net = FeedForwardNet(12, 40, 4, activation, seed=0)
            fit(net, x, y, iterations=0)  # the same scaling ours used, weights untouched
            scipy_run = ScipyRun(net, x, y, target, args.limit)
            scipy_run.run(net.get_theta())
            rows.append((activation, history, statistics.median(times), min(times),
                         max(times), scipy_run))
        load_after = os.getloadavg()[0]

    print(f'\nLevenberg–Marquardt, 12-40-4 (684 weights), {len(x)} samples of {origin}, '
          f'{4 * len(x)} residuals; 1 BLAS thread; load average {load_before:.2f} → '
          f'{load_after:.2f} on {os.cpu_count()} cores.\n')
    print('| activation | ours: iterations | ours: MSE reached | ours: s (median, min – max) '
          '| ours: ms/iteration | scipy lm: s to that MSE | scipy: f / J evaluations '
          '| speed-up |')
    print('|---|---:|---:|---:|---:|---:|---:|---:|')
    for activation, history, median, low, high, run in rows:
        if run.reached_after is not None:
            scipy_time = f'{run.reached_after:.1f}'
            speed_up = f'{run.reached_after / median:.0f}×'
        else:
            scipy_time = (f'not reached in {run.elapsed:.0f} s (best MSE {run.best:.3e})')
            speed_up = f'> {run.elapsed / median:.0f}×'
        per_iteration = 1e3 * statistics.median(history.time)
        print(f'| {activation} | {history.iterations} | {history.mse[-1]:.3e} | '
              f'{median:.2f} ({low:.2f} – {high:.2f}) | {per_iteration:.0f} | {scipy_time} | '
              f'{run.nfev} / {run.njev} | {speed_up} |')


if __name__ == '__main__':
    main()
