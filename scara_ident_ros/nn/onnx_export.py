"""A trained network as an ONNX model, for controllers that run it outside Python.

The graph computes what `FeedForwardNet.predict` computes, scaling included, from standard
ONNX operators (opset 13), in float64 from input to output::

    xs     = x·x_gain + x_offset                  x (batch, 3n): [q, q', q''] in SI units
    p      = xs·V + c                             (batch, n_hidden)
    z      = (p − b) / a
    h      = Σ_i coef_i·Sigmoid(z + shift_i)      coef_i = k·sign_i (`LOGISTIC_TERMS`)
    ys     = h·Wᵀ + d                             (batch, n)
    effort = (ys − y_offset) / y_gain             efforts in N·m (revolute) or N (prismatic)

For SLOG and MSLOG the four terms are evaluated side by side: z is unsqueezed to
(batch, 1, n_hidden), the shifts of shape (4, 1) broadcast against it, and ReduceSum over
axis 1 adds the weighted terms. Sigmoid is ONNX's logistic σ(z) = 1/(1 + e^−z), the
reference `activations.logistic`; the package's own hot path evaluates the same sum in the
equivalent tanh form, which agrees with it to ~1e-16.

Why float64: a ros2_control controller reads and writes ``double`` state and command
interfaces, the package computes in float64, and the CPU provider of ONNX Runtime has
float64 kernels for every operator used here (MatMul, Add, Sub, Mul, Div, Sigmoid,
Unsqueeze, ReduceSum). Opset 13 and IR version 7 keep the file loadable by older ONNX
Runtime releases too (1.8 and later), such as a robot's controller computer may have.

Public API::

    INPUT_NAME, OUTPUT_NAME                 'x' and 'effort'
    network_to_onnx(network, ...) -> ModelProto
    save_onnx(model, path)                  written atomically
    onnx_agreement(model, network, X)       per joint: how far ONNX Runtime is from predict
    relative_difference(actual, expected)   per joint: max |difference| / max |expected|
    package_version()                       what the metadata records
"""
from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
import numpy.typing as npt
import onnx
from onnx import TensorProto, helper, numpy_helper

from scara_ident_ros.nn.activations import LOGISTIC_TERMS
from scara_ident_ros.nn.network import FeedForwardNet

__all__ = ['INPUT_NAME', 'IR_VERSION', 'OPSET', 'OUTPUT_NAME', 'network_to_onnx',
           'onnx_agreement', 'package_version', 'relative_difference', 'save_onnx']

INPUT_NAME = 'x'
OUTPUT_NAME = 'effort'
#: ONNX operator set and IR version of the exported file (see the module docstring).
OPSET = 13
IR_VERSION = 7
#: Name of the batch dimension of the input and the output.
BATCH = 'batch'
_PACKAGE = 'scara_ident_ros'

FloatArray = npt.NDArray[np.float64]


def package_version() -> str:
    """The installed version of the package, or 'unknown' when it is not installed."""
    try:
        return version(_PACKAGE)
    except PackageNotFoundError:
        return 'unknown'


def network_to_onnx(network: FeedForwardNet, *, method: str,
                    joint_names: Sequence[str] | None = None) -> onnx.ModelProto:
    """Return the network, scaling included, as a checked float64 ONNX model.

    Parameters
    ----------
    network : FeedForwardNet
        An inverse-dynamics network: 3n inputs [q, q', q''], n outputs (efforts).
    method : str
        The method key (``'ffmw'``, ``'ffw'`` or ``'ffs'``), stored in the metadata.
    joint_names : sequence of str, optional
        The joints in output order; stored comma-separated when given.

    Returns
    -------
    onnx.ModelProto
        Input `INPUT_NAME` of shape (batch, 3n), output `OUTPUT_NAME` of shape (batch, n),
        both float64. ``metadata_props`` hold ``method``, ``activation``, ``constants``
        (k, a, b), ``scara_ident_ros_version``, ``input_layout``, ``output_layout`` and,
        when known, ``joint_names``.

    Raises
    ------
    ValueError
        If the network has not 3n inputs for n outputs, or the joint names are not n
        non-empty names without commas.
    """
    n = network.n_outputs
    if network.n_inputs != 3 * n:
        raise ValueError(f'a network with {network.n_inputs} inputs and {n} outputs is not '
                         'an inverse-dynamics model (3n inputs [q, qd, qdd] for n efforts)')
    names = list(joint_names) if joint_names is not None else None
    if names is not None and (len(names) != n or not all(names)
                              or any(',' in name for name in names)):
        raise ValueError(f'need {n} non-empty joint names without commas, got {names}')

    Vt, Wt = network.unpack(network.theta)
    n_in, n_hid = network.n_inputs, network.n_hidden
    k, a, b = network.constants
    shifts, signs = (np.array(terms, dtype=np.float64) for terms in
                     LOGISTIC_TERMS[network.activation])
    constants = {
        'x_gain': network.x_scaling.gain, 'x_offset': network.x_scaling.offset,
        'V': Vt[:n_in], 'c': Vt[n_in],
        'b': np.array(b), 'a': np.array(a),
        'shift': shifts[:, None], 'coef': (k * signs)[:, None],
        'W_t': Wt[:, :n_hid].T, 'd': Wt[:, n_hid],
        'y_offset': network.y_scaling.offset, 'y_gain': network.y_scaling.gain,
        'term_axis': np.array([1], dtype=np.int64),
    }
    initializers = [numpy_helper.from_array(np.ascontiguousarray(value), name)
                    for name, value in constants.items()]
    node = helper.make_node
    nodes = [
        node('Mul', [INPUT_NAME, 'x_gain'], ['x_gained']),
        node('Add', ['x_gained', 'x_offset'], ['xs'], name='input_scaling'),
        node('MatMul', ['xs', 'V'], ['xs_V']),
        node('Add', ['xs_V', 'c'], ['p'], name='hidden_net_input'),
        node('Sub', ['p', 'b'], ['p_minus_b']),
        node('Div', ['p_minus_b', 'a'], ['z']),
    ]
    if len(shifts) == 1:  # sigmoid: one term, no extra axis
        nodes += [node('Add', ['z', 'shift'], ['z_shifted']),
                  node('Sigmoid', ['z_shifted'], ['sigma']),
                  node('Mul', ['sigma', 'coef'], ['h'], name='hidden_output')]
    else:  # SLOG, MSLOG: the terms along axis 1 of (batch, n_terms, n_hidden)
        nodes += [node('Unsqueeze', ['z', 'term_axis'], ['z_3d']),
                  node('Add', ['z_3d', 'shift'], ['z_shifted']),
                  node('Sigmoid', ['z_shifted'], ['sigma']),
                  node('Mul', ['sigma', 'coef'], ['terms']),
                  node('ReduceSum', ['terms', 'term_axis'], ['h'], keepdims=0,
                       name='hidden_output')]
    nodes += [
        node('MatMul', ['h', 'W_t'], ['h_W']),
        node('Add', ['h_W', 'd'], ['ys'], name='output_layer'),
        node('Sub', ['ys', 'y_offset'], ['ys_minus_offset']),
        node('Div', ['ys_minus_offset', 'y_gain'], [OUTPUT_NAME], name='output_scaling'),
    ]
    if len(shifts) == 1:
        initializers = [i for i in initializers if i.name != 'term_axis']
    graph = helper.make_graph(
        nodes, f'{method}_inverse_dynamics',
        [helper.make_tensor_value_info(INPUT_NAME, TensorProto.DOUBLE, [BATCH, n_in])],
        [helper.make_tensor_value_info(OUTPUT_NAME, TensorProto.DOUBLE, [BATCH, n])],
        initializers,
        doc_string=f'{n_in}-{n_hid}-{n} {network.activation} network of scara_ident_ros: '
                   'joint positions, velocities, accelerations in, joint efforts out (SI)')
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid('', OPSET)],
                              producer_name=_PACKAGE, producer_version=package_version())
    model.ir_version = IR_VERSION
    model.doc_string = graph.doc_string
    metadata = {
        'method': method,
        'activation': network.activation,
        'constants': f'k={k!r}, a={a!r}, b={b!r}',
        'scara_ident_ros_version': package_version(),
        'input_layout': f'x[:, 0:{n}] = q (rad or m), x[:, {n}:{2 * n}] = qd (rad/s or m/s), '
                        f'x[:, {2 * n}:{3 * n}] = qdd (rad/s^2 or m/s^2)',
        'output_layout': f'effort[:, 0:{n}] (N m or N), one column per joint',
    }
    if names is not None:
        metadata['joint_names'] = ','.join(names)
    helper.set_model_props(model, metadata)
    onnx.checker.check_model(model, full_check=True)
    return model


def save_onnx(model: onnx.ModelProto, path: str | Path) -> None:
    """Write ``model`` to ``path`` atomically (a reader never sees half a file).

    Parameters
    ----------
    model : onnx.ModelProto
    path : str or Path
        Written exactly as given (no suffix is added).
    """
    path = Path(path)
    descriptor, temporary = tempfile.mkstemp(prefix=f'.{path.name}.', suffix='.tmp',
                                             dir=path.parent)
    try:
        os.fchmod(descriptor, 0o644)  # mkstemp's 0600 would hide it from a controller's user
        with os.fdopen(descriptor, 'wb') as stream:
            stream.write(model.SerializeToString())
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise


def relative_difference(actual: npt.ArrayLike, expected: npt.ArrayLike) -> FloatArray:
    """Per column: max over samples of |actual − expected| / max over samples of |expected|.

    Relative to each joint's largest effort, so that efforts near zero do not inflate it
    (the denominator is at least the smallest normal float64, never zero).

    Parameters
    ----------
    actual, expected : array_like of shape (n_samples, n)

    Returns
    -------
    ndarray of shape (n,)
    """
    actual = np.asarray(actual, dtype=np.float64)
    expected = np.asarray(expected, dtype=np.float64)
    scale = np.maximum(np.max(np.abs(expected), axis=0), np.finfo(np.float64).tiny)
    result: FloatArray = np.max(np.abs(actual - expected), axis=0) / scale
    return result


def onnx_agreement(model: onnx.ModelProto, network: FeedForwardNet,
                   X: npt.ArrayLike) -> FloatArray:
    """Run ``model`` with ONNX Runtime's CPU provider and compare it with `predict`.

    Parameters
    ----------
    model : onnx.ModelProto
        The network's export (`network_to_onnx`).
    network : FeedForwardNet
    X : array_like of shape (n_samples, 3n)
        Physical inputs.

    Returns
    -------
    ndarray of shape (n,)
        `relative_difference` of ONNX Runtime's efforts from ``network.predict(X)``.
    """
    import onnxruntime

    x = np.ascontiguousarray(X, dtype=np.float64)
    session = onnxruntime.InferenceSession(model.SerializeToString(),
                                           providers=['CPUExecutionProvider'])
    (effort,) = session.run([OUTPUT_NAME], {INPUT_NAME: x})
    return relative_difference(effort, network.predict(x))
