"""The hybrid's correction fades where the input leaves the states it was learnt on."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.estimator import load_model
from scara_ident_ros.learners import LinearFeatures
from scara_ident_ros.learners.data_region import FADE_END, DataRegion
from scara_ident_ros.learners.hybrid_model import HybridModel, fit_hybrid
from scara_ident_ros.nn.presets import make_network


def test_the_weight_is_1_on_the_data_and_0_beyond_twice_the_radius() -> None:
    rng = np.random.default_rng(0)
    X = rng.uniform(-1.0, 1.0, (3000, 6))
    region = DataRegion.of(X)
    assert np.all(region.weight(region.reference) == 1.0)
    inside = rng.uniform(-0.9, 0.9, (200, 6))
    assert np.mean(region.weight(inside) == 1.0) > 0.8  # the radius holds the data's gaps
    far = X[:50] + 2.0 * FADE_END * region.radius * region.scale * 3.0
    assert np.all(region.weight(far) == 0.0)
    assert region.weight(X[0]).shape == ()


def test_the_weight_falls_linearly_between_the_radius_and_its_end() -> None:
    region = DataRegion(np.zeros((1, 2)), np.array([1.0, 4.0]), radius=1.0)
    middle = (1.0 + FADE_END) / 2.0
    points = np.array([[0.5, 0.0], [0.0, 4.0], [middle, 0.0], [0.0, 4.0 * middle],
                       [FADE_END, 0.0], [2.0 * FADE_END, 0.0]])
    np.testing.assert_allclose(region.weight(points), [1.0, 1.0, 0.5, 0.5, 0.0, 0.0])


def test_a_region_needs_data_and_a_positive_scale() -> None:
    with pytest.raises(ValueError, match='at least 2'):
        DataRegion.of(np.zeros((1, 3)))
    with pytest.raises(ValueError, match='positive scale'):
        DataRegion(np.zeros((4, 3)), np.array([1.0, 0.0, 1.0]), 1.0)


def _residual_world(rows: int, low: float, high: float, seed: int
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One joint: effort = 2 q + sin(3 q') (the sine is what least squares leaves)."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(low, high, (rows, 3))
    return X, (2.0 * X[:, 0] + np.sin(3.0 * X[:, 1]))[:, None]


def test_a_hybrid_returns_to_its_linear_part_outside_its_training_states(tmp_path: Path
                                                                        ) -> None:
    """Its correction is learnt on [-1, 1]³ and kept there; outside, where the network
    would extrapolate, the hybrid predicts what its linear part predicts, and so does the
    model read back from its file."""
    X, Y = _residual_world(3000, -1.0, 1.0, seed=1)
    Xv, Yv = _residual_world(600, -1.0, 1.0, seed=2)
    network = make_network('ffs', 1, n_hidden=10, seed=0, friction_steps=False)
    hybrid, _ = fit_hybrid(LinearFeatures(), network, (X, Y), validation=(Xv, Yv),
                           iterations=60)
    assert hybrid.region is not None and hybrid.gate[0] > 0.0
    base_error = np.mean((hybrid.base.predict(Xv) - Yv) ** 2)
    assert np.mean((hybrid.predict(Xv) - Yv) ** 2) < 0.5 * base_error  # it learnt inside
    far, _ = _residual_world(300, 4.0, 6.0, seed=3)
    np.testing.assert_array_equal(hybrid.predict(far), hybrid.base.predict(far))
    assert np.any(hybrid.network.predict(far) != 0.0)  # the network alone would not be 0
    hybrid.save(tmp_path / 'h.npz')
    loaded = load_model(tmp_path / 'h.npz')
    assert isinstance(loaded, HybridModel) and loaded.region is not None
    np.testing.assert_array_equal(loaded.predict(far), hybrid.base.predict(far))
    np.testing.assert_allclose(loaded.predict(Xv), hybrid.predict(Xv))


def test_without_fade_the_network_extrapolates() -> None:
    X, Y = _residual_world(3000, -1.0, 1.0, seed=1)
    Xv, Yv = _residual_world(600, -1.0, 1.0, seed=2)
    network = make_network('ffs', 1, n_hidden=10, seed=0, friction_steps=False)
    hybrid, _ = fit_hybrid(LinearFeatures(), network, (X, Y), validation=(Xv, Yv),
                           iterations=60, fade=False)
    far, _ = _residual_world(300, 4.0, 6.0, seed=3)
    assert hybrid.region is None
    assert np.any(hybrid.predict(far) != hybrid.base.predict(far))
