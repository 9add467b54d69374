"""Shared data for the network tests: the activations, a smooth 12 → 4 map shaped like
inverse dynamics."""
from __future__ import annotations

import numpy as np
import pytest


def smooth_map(x: np.ndarray) -> np.ndarray:
    """A smooth function of 12 inputs (q, q', q'' of 4 joints) with 4 outputs."""
    q, qd, qdd = x[:, 0:4], x[:, 4:8], x[:, 8:12]
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    return np.stack([
        (2.0 + c2) * qdd[:, 0] + (0.5 + 0.5 * c2) * qdd[:, 1] - s2 * qd[:, 1] * qd[:, 0],
        (0.5 + 0.5 * c2) * qdd[:, 0] + 0.6 * qdd[:, 1] + 0.5 * s2 * qd[:, 0] ** 2,
        0.8 * qdd[:, 2] - 9.81 + 0.3 * qd[:, 2],
        0.1 * qdd[:, 3] + 0.05 * np.tanh(qd[:, 3] / 0.2),
    ], axis=1)


@pytest.fixture(scope='session')
def smooth_data() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(42)
    x = rng.uniform(-1.0, 1.0, (300, 12))
    return x, smooth_map(x)


@pytest.fixture(params=('sigmoid', 'slog', 'mslog'))
def name(request: pytest.FixtureRequest) -> str:
    """Each of the paper's three activations, by its name in the network's tables."""
    return str(request.param)
