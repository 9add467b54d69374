"""Samples of the simulated SCARA for the network benchmarks, or a stand-in if it fails.

x = [q, q', q''] and y = effort of the ``standard`` excitation (seed 0) at 1 kHz; should the
simulator not run, a smooth synthetic 12 -> 4 map stands in, and the benchmark says so.
"""
from __future__ import annotations

import numpy as np

__all__ = ['scara_samples']


def scara_samples(n: int, stride: int = 1) -> tuple[np.ndarray, np.ndarray, str]:
    """Return n samples x (n, 12), y = effort (n, 4), each ``stride``-th of the stream, and
    their origin."""
    try:
        from scara_ident_ros.dynamics.params import ScaraParams
        from scara_ident_ros.sim import Simulator, make_trajectory
        params = ScaraParams()
        record = Simulator(params, make_trajectory('standard', params, seed=0)).simulate(
            n * stride)
        x = np.hstack([record.q, record.qd, record.qdd])[::stride]
        y = np.asarray(record.effort, dtype=np.float64)[::stride]
        return x, y, ('simulated SCARA, 1 kHz' if stride == 1 else
                      f'simulated SCARA (1 kHz, every {stride}th sample)')
    except Exception as exc:  # the simulator is another team's: fall back, say so
        print(f'(simulator unavailable: {exc!r}; using a smooth synthetic map)')
        rng = np.random.default_rng(0)
        x = rng.uniform(-1.0, 1.0, (n, 12))
        y = np.stack([np.sin(x[:, 0] + x[:, 1]) * x[:, 8], np.cos(x[:, 1]) * x[:, 9],
                      9.81 + x[:, 10], 0.1 * x[:, 11] + 0.05 * np.tanh(x[:, 7])], axis=1)
        return x, y, 'synthetic smooth map'
