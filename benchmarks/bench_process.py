"""Per-sample overhead of :meth:`OnlineIdentifier.process`, the model excluded.

    PYTHONPATH=. .venv/bin/python benchmarks/bench_process.py
"""
from __future__ import annotations

import array
import statistics
import timeit

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification import (DIFFERENTIATOR_WINDOW, DIFFERENTIATORS,
                                            OnlineIdentifier, make_differentiator)

NAMES = ['joint1', 'joint2', 'joint3', 'joint4']
PERIOD_NS = 1_000_000  # 1 kHz
SAMPLES = 2000  # per timing run
RUNS = 15


class NullModel:
    """A model that costs (almost) nothing, so only the identifier's own work is timed."""

    n_inputs, n_outputs = 12, 4

    def __init__(self) -> None:
        self._out = np.zeros(4)

    def predict(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        return self._out

    def partial_fit(self, X: NDArray[np.float64],
                    Y: NDArray[np.float64]) -> NDArray[np.float64]:
        return Y


def median_us(method: str, names: list[str]) -> float:
    """Median time per ``process`` call, µs, with rclpy-like ``array.array`` inputs."""
    ident = OnlineIdentifier(NullModel(), joint_names=NAMES,
                             differentiator=make_differentiator(method))
    rng = np.random.default_rng(0)
    data = [array.array('d', rng.normal(size=4)) for _ in range(3)]
    clock = [0]

    def step() -> None:
        clock[0] += PERIOD_NS
        ident.process(clock[0], names, *data)

    timeit.timeit(step, number=SAMPLES)  # warm up, fill the error window once
    runs = timeit.repeat(step, number=SAMPLES, repeat=RUNS)
    # the hot path was timed: every sample predicted but those of the centred fit's lag
    assert ident.counts.predicted >= ident.counts.processed - DIFFERENTIATOR_WINDOW
    return statistics.median(runs) / SAMPLES * 1e6


def main() -> None:
    for method in DIFFERENTIATORS:
        for label, names in (('in order', NAMES), ('reordered', NAMES[::-1])):
            print(f'{method:10s} {label:9s} {median_us(method, names):6.1f} µs per sample')


if __name__ == '__main__':
    main()
