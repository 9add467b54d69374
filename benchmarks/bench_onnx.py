"""One sample through the exported ONNX model in ONNX Runtime (Python), against `predict`.

For each method (FFMW, FFW, FFS: 12-40-4 SCARA networks with the friction steps and the
SCARA's limit scaling), the network is exported (`scara_ident_ros.nn.onnx_export`) and one
sample x of shape (1, 12) float64 is run at a time, each call timed on its own with
``perf_counter_ns`` after a warm-up. Rounds interleave the contenders, so background load
hits them alike. Contenders:

* ``ort.run``: ``session.run(['effort'], {'x': x})``, what a Python caller writes;
* ``ort.iobinding``: ``session.run_with_iobinding`` with the input and output bound once to
  preallocated buffers, what a C++ controller does with ``Ort::Value::CreateTensor`` over its
  own arrays and ``Session::Run`` into a preallocated output;
* ``predict``: ``FeedForwardNet.predict(x)`` with x of shape (12,), the package's own
  preallocated single-sample numpy path (what the identifier node calls at 1 kHz).

Every session: ``intra_op_num_threads = 1``, ``inter_op_num_threads = 1``, sequential
execution, all graph optimisations, CPU provider; numpy's BLAS is held to one thread. Also
times a batch of 1000 samples both ways, and checks the agreement of ONNX Runtime with
``predict`` (`relative_difference` on the timed inputs, drawn within the joint limits).

Prints the tables and writes them to ``benchmarks/onnx.md``::

    .venv/bin/python benchmarks/bench_onnx.py [--calls 20000] [--rounds 5] [--out FILE]
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import onnxruntime
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from scara_ident_ros.dynamics import ScaraParams  # noqa: E402
from scara_ident_ros.dynamics.joint_limits import LIMIT_NAMES  # noqa: E402
from scara_ident_ros.nn.presets import METHODS, limit_scaling, make_network  # noqa: E402
from scara_ident_ros.nn import FeedForwardNet  # noqa: E402
from scara_ident_ros.nn.onnx_export import (INPUT_NAME, OUTPUT_NAME,  # noqa: E402
                                            network_to_onnx, relative_difference)

HERE = Path(__file__).resolve().parent
TARGET_US = 50.0  # issue 20: one sample through onnxruntime (Python) in <= 50 µs
BATCH = 1000
WARM_UP = 2000
Call = Callable[[int], Any]


def scara_network(method: str) -> FeedForwardNet:
    """The identifier's network of ``method`` for the default SCARA, before learning."""
    params = ScaraParams()
    network = make_network(method, 4, seed=0, friction_steps=True)
    network.set_scaling(*limit_scaling(*(params.array(name) for name in LIMIT_NAMES)))
    return network


def session_options() -> onnxruntime.SessionOptions:
    """One thread, sequential, every graph optimisation: a controller's setting."""
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.execution_mode = onnxruntime.ExecutionMode.ORT_SEQUENTIAL
    options.graph_optimization_level = onnxruntime.GraphOptimizationLevel.ORT_ENABLE_ALL
    return options


def contenders(network: FeedForwardNet, method: str,
               X: np.ndarray) -> tuple[dict[str, Call], onnxruntime.InferenceSession]:
    """The timed calls of one sample, each taking the sample's index into X (n, 12)."""
    model = network_to_onnx(network, method=method, joint_names=None)
    session = onnxruntime.InferenceSession(model.SerializeToString(), session_options(),
                                           providers=['CPUExecutionProvider'])
    rows = [np.ascontiguousarray(X[i:i + 1]) for i in range(X.shape[0])]
    run, outputs = session.run, [OUTPUT_NAME]

    def ort_run(i: int) -> Any:
        return run(outputs, {INPUT_NAME: rows[i]})

    x_buffer = np.empty((1, X.shape[1]))
    y_buffer = np.empty((1, network.n_outputs))
    binding = session.io_binding()
    binding.bind_cpu_input(INPUT_NAME, x_buffer)
    binding.bind_output(OUTPUT_NAME, 'cpu', 0, np.float64, y_buffer.shape,
                        y_buffer.ctypes.data)
    run_bound = session.run_with_iobinding

    def ort_iobinding(i: int) -> Any:
        x_buffer[0] = X[i]  # the controller writes its state into the bound buffer
        run_bound(binding)
        return y_buffer

    predict = network.predict

    def numpy_predict(i: int) -> Any:
        return predict(X[i])

    return ({'ort.run': ort_run, 'ort.iobinding': ort_iobinding, 'predict': numpy_predict},
            session)


def time_calls(call: Call, start: int, count: int, n: int) -> np.ndarray:
    """Time ``count`` calls one by one (ns), samples start, start+1, ... modulo n."""
    times = np.empty(count, dtype=np.int64)
    clock = time.perf_counter_ns
    for k in range(count):
        i = (start + k) % n
        began = clock()
        call(i)
        times[k] = clock() - began
    return times


def percentiles_us(times: np.ndarray) -> list[float]:
    """p50, p90, p99, p99.9 and max of times in ns, in µs."""
    return [float(v) / 1e3 for v in np.percentile(times, [50, 90, 99, 99.9, 100])]


def cpu_name() -> str:
    try:
        for line in Path('/proc/cpuinfo').read_text().splitlines():
            if line.startswith('model name'):
                return line.split(':', 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or 'unknown CPU'


def main() -> int:
    """Time every contender for every method, print and write the tables."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--calls', type=int, default=20000,
                        help='timed calls per contender and method (default 20000)')
    parser.add_argument('--rounds', type=int, default=5, help='interleaved rounds (default 5)')
    parser.add_argument('--out', type=Path, default=HERE / 'onnx.md',
                        help='Markdown file to write (default benchmarks/onnx.md)')
    args = parser.parse_args()
    params = ScaraParams()
    x_min, x_max, _, _ = limit_scaling(*(params.array(name) for name in LIMIT_NAMES))
    X = np.random.default_rng(1).uniform(x_min, x_max, (BATCH, x_min.size))
    per_round = max(1, args.calls // args.rounds)
    load_before, started = os.getloadavg()[0], time.monotonic()
    rows, batch_rows = [], []
    with threadpool_limits(limits=1, user_api='blas'):
        for method in METHODS:
            network = scara_network(method)
            calls, session = contenders(network, method, X)
            agreement = float(np.max(relative_difference(
                session.run([OUTPUT_NAME], {INPUT_NAME: X})[0], network.predict(X))))
            for call in calls.values():
                time_calls(call, 0, WARM_UP, BATCH)
            times: dict[str, list[np.ndarray]] = {name: [] for name in calls}
            for r in range(args.rounds):
                for name, call in calls.items():
                    times[name].append(time_calls(call, r * per_round, per_round, BATCH))
            for name in calls:
                rows.append((method, name, percentiles_us(np.concatenate(times[name])),
                             agreement if name.startswith('ort') else 0.0))
            batch: dict[str, list[float]] = {'ort.run': [], 'predict': []}
            for _ in range(max(3, args.rounds)):
                for name, fn in (('ort.run', lambda: session.run([OUTPUT_NAME],
                                                                 {INPUT_NAME: X})),
                                 ('predict', lambda: network.predict(X))):
                    began = time.perf_counter_ns()
                    fn()
                    batch[name].append((time.perf_counter_ns() - began) / 1e3)
            batch_rows.append((method, {name: float(np.median(v)) for name, v in batch.items()}))
    load_after, seconds = os.getloadavg()[0], time.monotonic() - started

    lines = [
        '### One sample through the exported ONNX model (`bench_onnx.py`)',
        '',
        f'onnxruntime {onnxruntime.__version__} (CPU provider, intra_op_num_threads 1, '
        f'sequential), numpy {np.__version__}, Python {platform.python_version()}, '
        f'{cpu_name()}, {os.cpu_count()} cores; {args.rounds} interleaved rounds, '
        f'{per_round * args.rounds} timed calls per row after {WARM_UP} warm-up calls; '
        f'load average {load_before:.1f} → {load_after:.1f}, {seconds:.0f} s.',
        '',
        f'One sample (1, 12) float64 → (1, 4), µs per call (target: ort.run p50 ≤ '
        f'{TARGET_US:g} µs). Last column: ONNX Runtime\'s largest difference from predict '
        f'over {BATCH} inputs within the joint limits, relative to each joint\'s largest '
        'effort.',
        '',
        '| method | call | p50 | p90 | p99 | p99.9 | max | vs predict |',
        '|---|---|---:|---:|---:|---:|---:|---:|',
    ]
    for method, name, stats, agreement in rows:
        cells = ' | '.join(f'{v:.1f}' for v in stats)
        diff = f'{agreement:.1e}' if name.startswith('ort') else '(reference)'
        lines.append(f'| {METHODS[method].label} | {name} | {cells} | {diff} |')
    lines += ['', f'A batch of {BATCH} samples, one call, µs (median of '
              f'{max(3, args.rounds)}):', '', '| method | ort.run | predict |',
              '|---|---:|---:|']
    for method, medians in batch_rows:
        lines.append(f'| {METHODS[method].label} | {medians["ort.run"]:.0f} | '
                     f'{medians["predict"]:.0f} |')
    text = '\n'.join(lines) + '\n'
    print(text)
    args.out.write_text(text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
