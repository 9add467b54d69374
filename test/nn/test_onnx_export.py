"""The ONNX export: ONNX Runtime computes what `predict` computes, and says what it is.

"Agrees to 1e-6" means, for each joint (output column): the largest absolute difference
over the held-out samples, divided by that joint's largest absolute effort over the same
samples, is below 1e-6.
"""
from __future__ import annotations

import stat
from importlib.metadata import version
from pathlib import Path

import numpy as np
import onnx
import onnxruntime
import pytest
from onnx import numpy_helper

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.nn.presets import METHODS, make_network
from scara_ident_ros.nn import FeedForwardNet, fit
from scara_ident_ros.nn.onnx_export import (INPUT_NAME, IR_VERSION, OPSET, OUTPUT_NAME,
                                            network_to_onnx, onnx_agreement,
                                            relative_difference, save_onnx)
from robot_scaling import robot_scaling  # test/robot_scaling.py

PARAMS = ScaraParams()
SCALING = robot_scaling(PARAMS)
JOINTS = ['joint1', 'joint2', 'joint3', 'joint4']
TOLERANCE = 1e-6


def within_limits(n_samples: int, seed: int) -> np.ndarray:
    """Inputs [q, q', q''] drawn uniformly within the SCARA's joint limits, (n_samples, 12)."""
    x_min, x_max = SCALING[0], SCALING[1]
    return np.random.default_rng(seed).uniform(x_min, x_max, (n_samples, x_min.size))


def trained_network(method: str) -> FeedForwardNet:
    """A SCARA network of ``method`` (friction steps, limit scaling) after a few LM steps on
    a smooth map, so that every weight, the output biases included, is away from its start."""
    network = make_network(method, 4, seed=2, friction_steps=True)
    network.set_scaling(*SCALING)
    X = within_limits(400, seed=0)
    q, qd, qdd = X[:, :4], X[:, 4:8], X[:, 8:]
    Y = 3.0 * qdd + 0.5 * np.sin(q) * qd + 2.0 * np.tanh(qd / 0.05) + [0.0, 0.0, -20.0, 0.0]
    fit(network, X, Y, iterations=3)
    return network


def session(model: onnx.ModelProto) -> onnxruntime.InferenceSession:
    return onnxruntime.InferenceSession(model.SerializeToString(),
                                        providers=['CPUExecutionProvider'])


def run(model: onnx.ModelProto, X: np.ndarray) -> np.ndarray:
    (effort,) = session(model).run([OUTPUT_NAME], {INPUT_NAME: X})
    assert effort.dtype == np.float64
    return np.asarray(effort)


def worst_relative(actual: np.ndarray, expected: np.ndarray) -> np.ndarray:
    """Per joint: max |actual − expected| / max |expected| (see the module docstring)."""
    return np.abs(actual - expected).max(axis=0) / np.abs(expected).max(axis=0)


@pytest.mark.parametrize('method', list(METHODS))
def test_onnx_runtime_matches_predict_on_held_out_inputs(method: str) -> None:
    network = trained_network(method)
    model = network_to_onnx(network, method=method, joint_names=JOINTS)
    X = within_limits(2000, seed=1)  # not the training inputs (seed 0)
    expected = network.predict(X)
    assert np.all(np.abs(expected).max(axis=0) > 1.0)  # efforts, not a near-zero output
    effort = run(model, X)
    assert effort.shape == (2000, 4)
    assert np.all(worst_relative(effort, expected) < TOLERANCE)
    # One sample at a time, against predict's single-sample path (1-D input).
    for x in X[:5]:
        one = run(model, x[None, :])
        assert one.shape == (1, 4)
        assert np.all(np.abs(one[0] - network.predict(x)) < TOLERANCE * np.abs(expected).max(0))


def test_every_layer_counts_a_perturbed_weight_is_caught() -> None:
    """The comparison can fail: one hidden weight changed by 1e-4 in the ONNX file."""
    network = trained_network('ffmw')
    model = network_to_onnx(network, method='ffmw')
    X = within_limits(500, seed=3)
    assert np.all(onnx_agreement(model, network, X) < TOLERANCE)
    for tensor in model.graph.initializer:
        if tensor.name == 'V':
            weights = numpy_helper.to_array(tensor).copy()
            weights[8, 30] += 1e-4  # qdd of joint 1 into a hidden unit without a step
            tensor.CopyFrom(numpy_helper.from_array(weights, 'V'))
    assert np.max(onnx_agreement(model, network, X)) > TOLERANCE


@pytest.mark.parametrize('activation', ['sigmoid', 'slog', 'mslog'])
def test_other_sizes_constants_and_scalings(activation: str) -> None:
    rng = np.random.default_rng(4)
    network = FeedForwardNet(6, 7, 2, activation, seed=1, k=1.7, a=3.0, b=-2.0,
                             weight_scale=6.0)
    network.set_theta(rng.normal(0.0, 2.0, network.n_params))
    network.set_scaling([-3, -1, -2, -2, -9, -9], [3, 0.5, 2, 2, 9, 9], [-40, -5], [60, 5])
    model = network_to_onnx(network, method='ffs', joint_names=['shoulder', 'slide'])
    X = rng.uniform(network.x_scaling.lo, network.x_scaling.hi, (300, 6))
    assert np.all(worst_relative(run(model, X), network.predict(X)) < TOLERANCE)


def test_a_network_without_scaling_exports_as_it_predicts() -> None:
    network = make_network('ffw', 3, n_hidden=5, seed=7)
    assert not network.scaling_set
    X = np.random.default_rng(5).uniform(-1.0, 1.0, (50, 9))
    model = network_to_onnx(network, method='ffw')
    assert np.all(worst_relative(run(model, X), network.predict(X)) < TOLERANCE)


def test_inputs_outputs_and_metadata() -> None:
    network = trained_network('ffs')
    model = network_to_onnx(network, method='ffs', joint_names=JOINTS)
    assert model.ir_version == IR_VERSION
    assert [(o.domain, o.version) for o in model.opset_import] == [('', OPSET)]
    (given,), (out,) = model.graph.input, model.graph.output
    assert given.name == INPUT_NAME and out.name == OUTPUT_NAME
    for value, width in ((given, 12), (out, 4)):
        assert value.type.tensor_type.elem_type == onnx.TensorProto.DOUBLE
        dims = value.type.tensor_type.shape.dim
        assert dims[0].dim_param == 'batch' and dims[1].dim_value == width
    props = {p.key: p.value for p in model.metadata_props}
    assert props['joint_names'] == 'joint1,joint2,joint3,joint4'
    assert props['method'] == 'ffs' and props['activation'] == 'sigmoid'
    assert props['scara_ident_ros_version'] == version('scara_ident_ros')
    assert props['constants'] == 'k=1.0, a=1.0, b=0.0'
    assert 'qdd' in props['input_layout'] and 'N m' in props['output_layout']
    assert model.producer_name == 'scara_ident_ros'
    # Standard operators only: a stock ONNX Runtime runs it.
    assert {node.domain for node in model.graph.node} == {''}
    assert 'joint_names' not in {p.key for p in network_to_onnx(network, method='ffs')
                                 .metadata_props}


def test_refuses_what_is_not_an_inverse_dynamics_model() -> None:
    with pytest.raises(ValueError, match='not an inverse-dynamics model'):
        network_to_onnx(FeedForwardNet(12, 8, 3), method='ffmw')
    network = make_network('ffmw', 2, n_hidden=4)
    for names in (['a'], ['a', ''], ['a', 'b,c'], ['a', 'b', 'c']):
        with pytest.raises(ValueError, match='joint names'):
            network_to_onnx(network, method='ffmw', joint_names=names)


def test_save_is_atomic_and_readable_by_others(tmp_path: Path) -> None:
    network = make_network('ffs', 2, n_hidden=4)
    model = network_to_onnx(network, method='ffs')
    path = tmp_path / 'ffs.onnx'
    save_onnx(model, path)
    save_onnx(model, path)  # overwrite
    assert [p.name for p in tmp_path.iterdir()] == ['ffs.onnx']
    assert stat.S_IMODE(path.stat().st_mode) == 0o644
    loaded = onnx.load(str(path))
    onnx.checker.check_model(loaded, full_check=True)
    X = np.zeros((3, 6))
    np.testing.assert_array_equal(run(loaded, X), run(model, X))


def test_relative_difference_is_per_joint_and_relative_to_its_largest_effort() -> None:
    expected = np.array([[100.0, 0.0], [-200.0, 0.5], [50.0, -1.0]])
    actual = expected + np.array([[0.0, 0.0], [2e-3, 0.0], [0.0, 1e-3]])
    np.testing.assert_allclose(relative_difference(actual, expected), [1e-5, 1e-3])
    # All-zero efforts: the difference itself over the smallest normal, not a division by 0.
    assert relative_difference(np.zeros((2, 1)), np.zeros((2, 1)))[0] == 0.0
