"""Per-sample cost of online learning for the 12-40-4 network: ours against PyTorch and
scikit-learn, side by side in one process.

Every implementation learns the same deterministic stream one sample per call (the 1 kHz
identifier's situation) with SGD and momentum on ½·Σ_j e_j², starting from the same
weights. Rounds interleave the implementations, so background load hits them alike; the
table gives the median over rounds of the mean time per sample, and the largest weight
difference from ours after the stream (a check that they compute the same thing).

What each call does:

* ours: ``FeedForwardNet.partial_fit(x, y)`` with physical x (12,) and y (4,): scales them,
  predicts, returns the a-priori error, updates the weights.
* PyTorch: from_numpy of the *pre-scaled* sample (spared the scaling), forward, loss,
  backward, ``SGD(momentum=…).step()``, error back to numpy; float64, one thread.
* scikit-learn: ``MLPRegressor.partial_fit`` on the pre-scaled sample as a (1, 12) batch
  (sigmoid only: it has no SLOG/MSLOG), ``solver='sgd'``, ``alpha=0``, no Nesterov.

BLAS is held to one thread everywhere (threadpoolctl, ``torch.set_num_threads(1)``).

Usage::

    .venv/bin/python benchmarks/bench_online.py [--samples 2000] [--rounds 7] [--calls 20000]
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from functools import partial
from pathlib import Path
from typing import Any, Callable

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from scara_ident_ros.blas_threads import single_blas_thread  # noqa: E402
from scara_ident_ros.nn import FeedForwardNet  # noqa: E402
from scara_samples import scara_samples  # noqa: E402  (benchmarks/: the script's own folder)

ACTIVATIONS = ('mslog', 'slog', 'sigmoid')
LEARNING_RATE = 0.01
MOMENTUM = 0.9
Step = Callable[[int], Any]


def to_packed(v: np.ndarray, c: np.ndarray, w: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Pack V (12, 40), c (40,), W (4, 40), d (4,) like FeedForwardNet's θ."""
    return np.concatenate([np.vstack([v, c]).ravel(), np.hstack([w, d[:, None]]).ravel()])


def ours(activation: str, x: np.ndarray, y: np.ndarray) -> tuple[Step, Callable[[], Any]]:
    net = FeedForwardNet(12, 40, 4, activation, seed=0, learning_rate=LEARNING_RATE,
                         momentum=MOMENTUM)
    net.set_scaling(x.min(axis=0), x.max(axis=0), y.min(axis=0), y.max(axis=0))
    partial_fit = net.partial_fit
    return (lambda i: partial_fit(x[i], y[i])), net.get_theta


def torch_sgd(activation: str, xs: np.ndarray, ys: np.ndarray,
              reference: FeedForwardNet) -> tuple[Step, Callable[[], Any]]:
    import torch

    k, a, b = reference.constants
    Vt, Wt = reference.unpack(reference.get_theta())
    shifts = (0.0,) if activation == 'sigmoid' else (2.0, 3.0, -3.0, -1.0)
    signs = (1.0,) if activation == 'sigmoid' else (1.0, -1.0, -1.0, 1.0)

    class Hidden(torch.nn.Module):
        def forward(self, u: torch.Tensor) -> torch.Tensor:
            z = (u - b) / a
            out = signs[0] * torch.sigmoid(z + shifts[0])
            for shift, sign in zip(shifts[1:], signs[1:]):
                out = out + sign * torch.sigmoid(z + shift)
            return k * out

    model = torch.nn.Sequential(torch.nn.Linear(12, 40), Hidden(), torch.nn.Linear(40, 4))
    model.double()
    with torch.no_grad():
        model[0].weight.copy_(torch.from_numpy(Vt[:12].T.copy()))
        model[0].bias.copy_(torch.from_numpy(Vt[12].copy()))
        model[2].weight.copy_(torch.from_numpy(Wt[:, :40].copy()))
        model[2].bias.copy_(torch.from_numpy(Wt[:, 40].copy()))
    optimizer = torch.optim.SGD(model.parameters(), lr=LEARNING_RATE, momentum=MOMENTUM)
    from_numpy = torch.from_numpy

    def step(i: int) -> np.ndarray:
        optimizer.zero_grad(set_to_none=True)
        error = from_numpy(ys[i]) - model(from_numpy(xs[i]))
        loss = 0.5 * (error * error).sum()
        loss.backward()
        optimizer.step()
        return error.detach().numpy()

    def params() -> np.ndarray:
        p = [t.detach().numpy() for t in model.parameters()]
        return to_packed(p[0].T, p[1], p[2], p[3])

    return step, params


def sklearn_sgd(xs: np.ndarray, ys: np.ndarray,
                reference: FeedForwardNet) -> tuple[Step, Callable[[], Any]]:
    from sklearn.neural_network import MLPRegressor

    model = MLPRegressor(hidden_layer_sizes=(40,), activation='logistic', solver='sgd',
                         learning_rate_init=LEARNING_RATE, momentum=MOMENTUM,
                         nesterovs_momentum=False, alpha=0.0, batch_size=1, shuffle=False,
                         random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter('ignore')
        model.partial_fit(xs[:1], ys[:1])  # allocates; then start from our weights
    Vt, Wt = reference.unpack(reference.get_theta())
    model.coefs_[0][...] = Vt[:12]
    model.intercepts_[0][...] = Vt[12]
    model.coefs_[1][...] = Wt[:, :40].T
    model.intercepts_[1][...] = Wt[:, 40]
    model._optimizer.velocities = [np.zeros_like(p) for p in
                                   model.coefs_ + model.intercepts_]
    partial_fit = model.partial_fit

    def params() -> np.ndarray:
        return to_packed(model.coefs_[0], model.intercepts_[0], model.coefs_[1].T,
                         model.intercepts_[1])

    return (lambda i: partial_fit(xs[i:i + 1], ys[i:i + 1])), params


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--samples', type=int, default=2000, help='samples per round')
    parser.add_argument('--rounds', type=int, default=7, help='timed rounds (median)')
    parser.add_argument('--calls', type=int, default=20000, help='calls timed one by one')
    args = parser.parse_args()
    n = args.samples

    x, y, origin = scara_samples(n)
    reference = FeedForwardNet(12, 40, 4)
    reference.set_scaling(x.min(axis=0), x.max(axis=0), y.min(axis=0), y.max(axis=0))
    xs, ys = reference.x_scaling.transform(x), reference.y_scaling.transform(y)

    torch_name = sklearn_name = ''
    try:
        import torch
        torch.set_num_threads(1)
        torch_name = f'PyTorch {torch.__version__}'
    except ImportError:
        print('(PyTorch not importable: skipped; install requirements-bench.txt)')
    try:
        import sklearn
        sklearn_name = f'scikit-learn {sklearn.__version__}'
    except ImportError:
        print('(scikit-learn not importable: skipped)')

    rows = []
    with single_blas_thread():
        load_before = os.getloadavg()[0]
        for activation in ACTIVATIONS:
            start_net = FeedForwardNet(12, 40, 4, activation, seed=0)  # = ours' initial one
            builders: dict[str, Callable[[], tuple[Step, Callable[[], Any]]]] = {
                'ours (numpy)': partial(ours, activation, x, y)}
            if torch_name:
                builders[torch_name] = partial(torch_sgd, activation, xs, ys, start_net)
            if sklearn_name and activation == 'sigmoid':
                builders[sklearn_name] = partial(sklearn_sgd, xs, ys, start_net)
            times: dict[str, list[float]] = {name: [] for name in builders}
            final: dict[str, np.ndarray] = {}
            for round_ in range(args.rounds + 1):  # round 0 warms up and checks equivalence
                for name, build in builders.items():
                    step, params = build()
                    start = time.perf_counter()
                    for i in range(n):
                        step(i)
                    elapsed = time.perf_counter() - start
                    if round_ == 0:
                        final[name] = np.asarray(params())
                    else:
                        times[name].append(elapsed / n)
            for name in builders:
                diff = float(np.max(np.abs(final[name] - final['ours (numpy)'])))
                rows.append((activation, name, statistics.median(times[name]) * 1e6,
                             min(times[name]) * 1e6, max(times[name]) * 1e6, diff))
        load_after = os.getloadavg()[0]

    print(f'\nOnline learning, 12-40-4, one sample per call: {n} samples of {origin} per '
          f'round, median of {args.rounds} interleaved rounds; lr {LEARNING_RATE}, momentum '
          f'{MOMENTUM}; 1 BLAS thread; load average {load_before:.2f} → {load_after:.2f} '
          f'on {os.cpu_count()} cores.\n')
    print('| activation | implementation | µs/sample (median) | min – max | '
          'vs ours | max abs Δθ vs ours after the stream |')
    print('|---|---|---:|---:|---:|---:|')
    ours_time = {row[0]: row[2] for row in rows if row[1] == 'ours (numpy)'}
    for activation, name, median, low, high, diff in rows:
        print(f'| {activation} | {name} | {median:.1f} | {low:.1f} – {high:.1f} | '
              f'{median / ours_time[activation]:.1f}× | {diff:.1e} |')
    with single_blas_thread():
        latency_table(x, y, args.calls)


def latency_table(x: np.ndarray, y: np.ndarray, calls: int) -> None:
    """Print percentiles of single calls of ours: the 1 kHz loop cares about the tail."""
    print(f'\nOurs, single calls timed one by one ({calls} calls each; percentiles in µs):\n')
    print('| activation | call | p50 | p90 | p99 | p99.9 | max |')
    print('|---|---|---:|---:|---:|---:|---:|')
    clock = time.perf_counter_ns
    n = len(x)
    for activation in ACTIVATIONS:
        net = FeedForwardNet(12, 40, 4, activation, seed=0, learning_rate=LEARNING_RATE,
                             momentum=MOMENTUM)
        net.set_scaling(x.min(axis=0), x.max(axis=0), y.min(axis=0), y.max(axis=0))
        for label, call in (('predict(x)', lambda i: net.predict(x[i % n])),
                            ('partial_fit(x, y)',
                             lambda i: net.partial_fit(x[i % n], y[i % n]))):
            samples = np.empty(calls)
            for i in range(calls):
                start = clock()
                call(i)
                samples[i] = clock() - start
            p = np.percentile(samples / 1e3, [50, 90, 99, 99.9, 100])
            print(f'| {activation} | {label} | ' + ' | '.join(f'{v:.1f}' for v in p) + ' |')


if __name__ == '__main__':
    main()
