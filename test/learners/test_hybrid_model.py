"""The hybrid's gate (``gate_scales``, ``HybridModel.validate_gate``): a scale in [0, 1] per
joint, withheld where held-out blocks do not show a gain."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.learners.hybrid_model import (GATE_LEVEL, HybridModel, fit_hybrid,
                                                   gate_scales)
from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.nn import ModelFormatError
from scara_ident_ros.nn.model_file import read_model_file, write_model
from scara_ident_ros.nn.presets import make_network

from physical_robots import SCARA_URDF, states  # test/


def test_the_scale_is_least_squares_within_0_and_1() -> None:
    rng = np.random.default_rng(1)
    residual = rng.normal(size=(400, 4))
    blocks = np.repeat(np.arange(8), 50)
    correction = np.column_stack([
        2.0 * residual[:, 0],   # twice the residual: halved
        residual[:, 1],         # the residual itself: kept whole
        -residual[:, 2],        # its opposite: withheld (least squares would say −1)
        0.5 * residual[:, 3]])  # half of it: least squares says 2, clipped to 1
    gate = gate_scales(correction, residual, blocks)
    np.testing.assert_allclose(gate, [0.5, 1.0, 0.0, 1.0], atol=1e-12)
    # a correction of noise alone: its least-squares scale is small (on one block, not
    # tested), and the blocks show no gain, so it is withheld
    noise = rng.normal(size=(400, 4))
    assert np.all(gate_scales(noise, residual, np.zeros(400)) < 0.2)
    assert np.all(gate_scales(noise, residual, blocks) == 0.0)
    # a shrunk scale lowers the error below both no correction and the whole correction
    noisy = residual + rng.normal(size=(400, 4))
    gate = gate_scales(noisy, residual, blocks)
    assert np.all((0.3 < gate) & (gate < 0.7))
    error = np.mean((residual - gate * noisy) ** 2, axis=0)
    assert np.all(error < np.mean(residual ** 2, axis=0))
    assert np.all(error < np.mean((residual - noisy) ** 2, axis=0))


def test_a_gain_in_few_blocks_is_not_enough() -> None:
    """The mean gain over blocks must pass a one-sided t-test: a correction that
    helps a lot in one block and hurts in the others is withheld; one that helps a little
    in every block is kept."""
    rng = np.random.default_rng(2)
    residual = rng.normal(size=(600, 2))
    blocks = np.repeat(np.arange(6), 100)
    correction = np.zeros_like(residual)
    first = blocks == 0
    correction[first, 0] = residual[first, 0]  # joint 0: right in block 0 ...
    correction[~first, 0] = 0.3 * rng.normal(size=500)  # ... noise elsewhere
    correction[:, 1] = 0.2 * residual[:, 1]  # joint 1: a small gain everywhere
    gate = gate_scales(correction, residual, blocks)
    # over all samples the first joint's correction still lowers the error ...
    assert np.mean((residual[:, 0] - correction[:, 0]) ** 2) < np.mean(residual[:, 0] ** 2)
    assert gate[0] == 0.0 and gate[1] == 1.0  # ... but not in enough blocks
    # without groups: the rows are cut into runs of consecutive rows (here the same blocks)
    np.testing.assert_array_equal(gate_scales(correction, residual), gate)
    # a single block: no test, the least-squares scale
    single = gate_scales(correction, residual, np.zeros(600))
    assert 0.0 < single[0] < 1.0
    with pytest.raises(ValueError, match='a group per sample'):
        gate_scales(correction, residual, blocks[:10])
    with pytest.raises(ValueError, match='one shape'):
        gate_scales(correction[:, :1], residual)
    with pytest.raises(ValueError, match='level'):
        gate_scales(correction, residual, blocks, level=0.0)
    assert 0.0 < GATE_LEVEL < 0.5


def test_the_gate_withholds_a_residual_that_makes_held_out_data_worse(tmp_path: Path
                                                                      ) -> None:
    """A network that learns an effect of the training motion alone (one that changes
    sign in another motion) makes held-out data worse on that joint: gated on validation
    blocks of the other motion it is withheld, and the gated hybrid is nowhere worse than
    its physical part on the held-out motion; a residual the network does learn is kept."""
    physical = PhysicalModel.from_urdf_file(SCARA_URDF, coulomb='sign')
    rng = np.random.default_rng(12)
    q, qd, qdd = states(rng, 900, 4)
    tau = physical.regressor(q, qd, qdd) @ rng.uniform(0.1, 2.0, physical.n_parameters)
    tau[:, 1] += 2.0 * np.sin(2.0 * q[:, 1])  # learnt, and true everywhere
    # joint 0: an effect the physical model has no column for, that flips after training
    tau[:, 0] += np.where(np.arange(900) < 400, 1.0, -1.0) * np.sin(3.0 * q[:, 0])
    x = np.hstack([q, qd, qdd])
    hybrid, _ = fit_hybrid(physical, make_network('ffs', 4, n_hidden=8),
                           (x[:400], tau[:400]), iterations=15, min_iterations=15,
                           max_fail=15)
    validation, held = slice(400, 650), slice(650, 900)
    hybrid.validate_gate(x[validation], tau[validation],
                         groups=np.repeat(np.arange(5), 50))
    assert np.all((hybrid.gate >= 0.0) & (hybrid.gate <= 1.0))
    assert hybrid.gate[0] == 0.0 and hybrid.gate[1] > 0.5
    alone = np.mean((hybrid.physical.predict(x[held]) - tau[held]) ** 2, axis=0)
    gated = np.mean((hybrid.predict(x[held]) - tau[held]) ** 2, axis=0)
    ungated = np.mean((hybrid.physical.predict(x[held]) + hybrid.raw_correction(x[held])
                       - tau[held]) ** 2, axis=0)
    assert ungated[0] > alone[0]  # the correction makes joint 0's held-out data worse
    assert np.all(gated <= alone + 1e-12) and gated[1] < 0.5 * alone[1]
    # the file keeps a fractional gate; one outside [0, 1] is refused
    hybrid.gate = np.array([0.0, 0.75, 0.25, 1.0])
    hybrid.save(tmp_path / 'scaled.npz')
    loaded = HybridModel.load(tmp_path / 'scaled.npz')
    np.testing.assert_array_equal(loaded.gate, hybrid.gate)
    np.testing.assert_array_equal(loaded.predict(x), hybrid.predict(x))
    file = read_model_file(tmp_path / 'scaled.npz', kind='hybrid')
    file.arrays['residual_gate'] = np.array([0.0, 1.5, 0.0, 1.0])
    write_model(tmp_path / 'bad.npz', file.arrays, file.metadata, kind='hybrid')
    with pytest.raises(ModelFormatError, match=r'not in \[0, 1\]'):
        HybridModel.load(tmp_path / 'bad.npz')


def test_a_hybrid_of_linear_least_squares_fits_saves_and_loads(tmp_path: Path) -> None:
    """Without a URDF the linear part is least squares on simple features: the same fit,
    gate and file (its kind recorded), and no physical model to hand out."""
    from scara_ident_ros.learners import LinearFeatures

    rng = np.random.default_rng(0)
    X = rng.uniform(-1.0, 1.0, (3000, 6))
    Y = np.column_stack([np.sin(3 * X[:, 0]) * X[:, 2], X[:, 1] * X[:, 3] ** 2])
    train, held = slice(0, 2000), slice(2000, 3000)
    linear = LinearFeatures()
    linear.metadata['joint_names'] = np.array(['a', 'b'])
    network = make_network('ffs', 2, seed=0, friction_steps=False)
    hybrid, history = fit_hybrid(linear, network, (X[train], Y[train]),
                                 validation=(X[held], Y[held]), iterations=30)
    assert hybrid.base is linear and history.iterations > 0
    alone = np.mean((LinearFeatures().fit(X[train], Y[train]).predict(X[held])
                     - Y[held]) ** 2, axis=0)
    corrected = np.mean((hybrid.predict(X[held]) - Y[held]) ** 2, axis=0)
    assert np.all(hybrid.gate > 0) and np.all(corrected < 0.5 * alone)  # products: nonlinear
    assert hybrid.joint_names == ('a', 'b')
    with pytest.raises(TypeError, match='linear part is a linear model'):
        _ = hybrid.physical
    hybrid.metadata['method'] = np.array('linear_hybrid')
    hybrid.save(tmp_path / 'lh.npz')
    assert str(read_model_file(tmp_path / 'lh.npz', kind='hybrid').arrays['base_kind']) \
        == 'linear'
    loaded = HybridModel.load(tmp_path / 'lh.npz')
    assert loaded.base.kind == 'linear' and loaded.method == 'linear_hybrid'
    assert loaded.joint_names == ('a', 'b')
    np.testing.assert_array_equal(loaded.predict(X[held]), hybrid.predict(X[held]))
    # a file whose linear part is of a kind no code knows is refused in one line
    file = read_model_file(tmp_path / 'lh.npz', kind='hybrid')
    write_model(tmp_path / 'odd.npz', {**file.arrays, 'base_kind': np.array('spline')},
                file.metadata, kind='hybrid')
    with pytest.raises(ModelFormatError, match="unknown kind 'spline'"):
        HybridModel.load(tmp_path / 'odd.npz')
