"""Per joint, the candidate that predicted later motion best; the physical model by default."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.estimator import load_model
from scara_ident_ros.learners import ExactGP, LinearFeatures
from scara_ident_ros.learners.joint_choice import MARGIN, JointChoice, choose_joints
from scara_ident_ros.nn.presets import make_network


def test_the_default_is_kept_unless_another_is_clearly_better() -> None:
    errors = {'physical': [1.0, 1.0, 1.0], 'linear': [0.5, 0.9, 2.0],
              'gp': [0.7, MARGIN * 1.0, 0.95]}
    assert choose_joints(errors, 'physical') == ['linear', 'gp', 'physical']
    assert choose_joints(errors) == ['linear', 'gp', 'gp']  # no default: the lowest


def _models(rows: int = 400) -> tuple[np.ndarray, np.ndarray, dict[str, object]]:
    rng = np.random.default_rng(0)
    X = rng.uniform(-1.0, 1.0, (rows, 6))
    Y = np.column_stack([3.0 * X[:, 0] - X[:, 2], np.sin(2.0 * X[:, 1])])
    linear = LinearFeatures().fit(X, Y)
    gp = ExactGP(length=1.0, noise=1e-3).fit(X, Y)
    network = make_network('ffs', 2, n_hidden=6, seed=0)
    network.fit(X, Y, iterations=5)
    return X, Y, {'linear': linear, 'gp': gp, 'ffs': network}


def test_each_joint_is_predicted_by_its_model_and_read_back(tmp_path: Path) -> None:
    X, _, models = _models()
    choice = JointChoice(models, ['gp', 'linear'])  # type: ignore[arg-type]
    assert set(choice.models) == {'gp', 'linear'}  # the unused candidate is not kept
    predicted = choice.predict(X)
    np.testing.assert_array_equal(predicted[:, 0], models['gp'].predict(X)[:, 0])  # type: ignore[attr-defined]
    np.testing.assert_array_equal(predicted[:, 1],
                                  models['linear'].predict(X)[:, 1])  # type: ignore[attr-defined]
    assert choice.predict(X[0]).shape == (2,)
    choice.metadata['method'] = np.array('joint_choice')
    choice.save(tmp_path / 'c.npz')
    loaded = load_model(tmp_path / 'c.npz')
    assert isinstance(loaded, JointChoice) and loaded.choice == ('gp', 'linear')
    np.testing.assert_allclose(loaded.predict(X), predicted, rtol=1e-12, atol=1e-12)
    network_choice = JointChoice(models, ['ffs', 'ffs'])  # type: ignore[arg-type]
    network_choice.save(tmp_path / 'n.npz')
    np.testing.assert_allclose(load_model(tmp_path / 'n.npz').predict(X),
                               models['ffs'].predict(X))  # type: ignore[attr-defined]


def test_a_choice_needs_a_model_of_every_joint_it_names() -> None:
    _, _, models = _models()
    with pytest.raises(ValueError, match='missing'):
        JointChoice(models, ['gp', 'kernel'])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match='inputs'):
        JointChoice(models, ['gp'])  # type: ignore[arg-type]
