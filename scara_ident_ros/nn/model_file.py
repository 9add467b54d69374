"""The model file: a plain ``.npz`` archive, written and read without pickle.

Every effort model of the package is saved in this container, and ``kind`` says which:

=========== ==================================================================== ============
kind        what                                                                 arrays
=========== ==================================================================== ============
network     a ``FeedForwardNet`` (no ``kind`` entry: the files of before kinds)  table below
physical    a ``PhysicalModel`` (``dynamics.physical_model``)                    its own
hybrid      a physical model plus a network on its residual                      prefixed
kernel      a ``SparseSpectrumGP`` (``learners.sparse_spectrum_gp``)             its own
gp          an ``ExactGP`` (``learners.exact_gp``)                               its own
=========== ==================================================================== ============

A network file is exactly what it was before kinds existed (no ``kind`` entry), so network
files old and new read the same everywhere. The others carry ``kind``; this module checks
their container (format, version, metadata) and, for a hybrid, its network's entries
(prefixed ``network.``); the physical entries (prefixed ``physical.`` in a hybrid) are
checked by ``PhysicalModel.from_arrays``.

Format version 1 of a network holds these arrays (n = n_params, sizes = n_inputs, n_hidden,
n_outputs):

================ ========= ============= ==============================================
key              dtype     shape         meaning
================ ========= ============= ==============================================
format           str       ()            always ``'scara_ident_ros.nn.FeedForwardNet'``
format_version   int64     ()            1
sizes            int64     (3,)          n_inputs, n_hidden, n_outputs
activation       str       ()            'sigmoid', 'slog' or 'mslog'
constants        float64   (3,)          k, a, b
params           float64   (n,)          packed weights θ (see `network`)
velocity         float64   (n,)          momentum state of partial_fit
x_min, x_max     float64   (n_inputs,)   input scaling range
y_min, y_max     float64   (n_outputs,)  output scaling range
scaling_set      bool      ()            whether the scaling was set
training         float64   (3,)          learning_rate, momentum, weight_scale
seed             int64     ()            initialisation seed
meta.<name>      any       any           metadata (numbers, booleans or strings only)
================ ========= ============= ==============================================

Anything else, a missing entry, a wrong dtype or shape, or a non-finite weight makes
`read_model` raise `ModelFormatError`, naming the path and the problem.
"""
from __future__ import annotations

import os
import tempfile
import zipfile
import zlib
from pathlib import Path
from typing import NamedTuple

import numpy as np

from scara_ident_ros.nn.activations import ACTIVATIONS
from scara_ident_ros.nn.errors import ModelFormatError

__all__ = ['FORMAT', 'FORMAT_VERSION', 'KINDS', 'METADATA_PREFIX', 'ModelFile',
           'NETWORK_PREFIX', 'read_model', 'read_model_file', 'write_model']

FORMAT = 'scara_ident_ros.nn.FeedForwardNet'
FORMAT_VERSION = 1
METADATA_PREFIX = 'meta.'
#: Kinds of model file; ``'network'`` when the file has no ``kind`` entry.
KINDS = ('network', 'physical', 'hybrid', 'kernel', 'gp', 'linear', 'joint_choice')
NETWORK_PREFIX = 'network.'  # a hybrid's network entries

_FIELDS = ('sizes', 'activation', 'constants', 'params', 'velocity', 'x_min', 'x_max',
           'y_min', 'y_max', 'scaling_set', 'training', 'seed')
_METADATA_KINDS = 'biufcUS'  # bool, integers, floats, complex, strings: nothing pickled
_NPY_MAGIC = b'\x93NUMPY'
_ZIP_MAGICS = (b'PK\x03\x04', b'PK\x05\x06')  # a local file header; an empty archive


class ModelFile(NamedTuple):
    """A model file's contents (:func:`read_model_file`).

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    arrays : dict of str to ndarray
        The model's entries (format, version, kind and metadata removed).
    metadata : dict of str to ndarray
        The ``meta.`` entries, prefix removed.
    """

    kind: str
    arrays: dict[str, np.ndarray]
    metadata: dict[str, np.ndarray]


def write_model(path: str | Path, arrays: dict[str, np.ndarray],
                metadata: dict[str, np.ndarray], *, kind: str = 'network') -> None:
    """Write a model file atomically (a reader never sees half a file).

    Parameters
    ----------
    path : str or Path
        Destination, used as given (no ``.npz`` suffix is added).
    arrays : dict of str to ndarray
        The model's entries (for a network, the table in the module docstring but format
        and format_version).
    metadata : dict of str to array_like
        Stored as ``meta.<name>``; values must convert to non-object arrays.
    kind : str
        One of :data:`KINDS`; a network's file has no ``kind`` entry.

    Raises
    ------
    ValueError
        If a metadata name or value cannot be stored without pickle.
    """
    if kind not in KINDS:
        raise ValueError(f'kind must be one of {KINDS}, got {kind!r}')
    path = Path(path)
    entries: dict[str, np.ndarray] = {
        'format': np.array(FORMAT), 'format_version': np.array(FORMAT_VERSION, np.int64)}
    if kind != 'network':
        entries['kind'] = np.array(kind)
    entries.update(arrays)
    for name, value in metadata.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f'metadata names must be non-empty strings, got {name!r}')
        array = np.asarray(value)
        if array.dtype.kind not in _METADATA_KINDS:
            raise ValueError(f'metadata {name!r} has dtype {array.dtype}: only numbers, '
                             'booleans and strings are stored (no pickle)')
        entries[METADATA_PREFIX + name] = array
    descriptor, temporary = tempfile.mkstemp(prefix=f'.{path.name}.', suffix='.tmp',
                                             dir=path.parent)
    try:
        with os.fdopen(descriptor, 'wb') as stream:
            np.savez(stream, allow_pickle=False, **entries)
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise


def read_model(path: str | Path) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Read and validate a network file (kind ``'network'``).

    Returns
    -------
    arrays, metadata
        As :func:`read_model_file`.

    Raises
    ------
    ModelFormatError
        As :func:`read_model_file`, and for a model of another kind.
    FileNotFoundError
        If there is no such file.
    """
    file = read_model_file(path, kind='network')
    return file.arrays, file.metadata


def read_model_file(path: str | Path, *, kind: str | None = None) -> ModelFile:
    """Read a model file; validate a network's (or a hybrid's network) entries.

    Parameters
    ----------
    path : str or Path
    kind : str, optional
        The kind the caller reads (one of :data:`KINDS`); None: any kind.

    Returns
    -------
    ModelFile
        Kind, entries and metadata.

    Raises
    ------
    ModelFormatError
        If the path is a directory, or the file is not a model file (not a zip/.npz
        archive, a single .npy array, object arrays), has another format version, an
        unknown kind or another than ``kind``, or is corrupt.
    FileNotFoundError
        If there is no such file.
    """
    path = Path(path)
    entries = _read_npz(path)
    fmt = entries.pop('format', None)
    if fmt is None or fmt.shape != () or fmt.dtype.kind != 'U' or str(fmt) != FORMAT:
        raise ModelFormatError(f'{path}: not a scara_ident_ros network file '
                               f'(no format entry {FORMAT!r})')
    version = entries.pop('format_version', None)
    if version is None or version.shape != () or version.dtype.kind not in 'iu':
        raise ModelFormatError(f'{path}: corrupt network file: no integer format_version')
    if int(version) != FORMAT_VERSION:
        raise ModelFormatError(f'{path}: network file format version {int(version)}, '
                               f'this code reads version {FORMAT_VERSION} only')
    kind_entry = entries.pop('kind', None)
    found = 'network' if kind_entry is None else str(kind_entry)
    if kind_entry is not None and (kind_entry.shape != () or kind_entry.dtype.kind != 'U'
                                   or found not in KINDS[1:]):
        raise ModelFormatError(f'{path}: unknown model kind {found!r}; this code reads '
                               f'{", ".join(KINDS)}')
    metadata = {name[len(METADATA_PREFIX):]: value for name, value in entries.items()
                if name.startswith(METADATA_PREFIX)}
    arrays = {name: value for name, value in entries.items()
              if not name.startswith(METADATA_PREFIX)}
    if found == 'network':
        problem = _check_arrays(arrays)
    elif found == 'hybrid':
        problem = _check_arrays({name[len(NETWORK_PREFIX):]: value
                                 for name, value in arrays.items()
                                 if name.startswith(NETWORK_PREFIX)})
    else:
        problem = ''
    if problem:
        raise ModelFormatError(f'{path}: corrupt {found} model file: {problem}'
                               if found != 'network' else
                               f'{path}: corrupt network file: {problem}')
    if kind is not None and found != kind:
        raise ModelFormatError(f'{path}: a {found} model, not a {kind} one')
    return ModelFile(found, arrays, metadata)


def _read_npz(path: Path) -> dict[str, np.ndarray]:
    """Every entry of the ``.npz`` archive at ``path``, nothing unpickled.

    The file's first bytes are checked before numpy sees it, so a file that is not a zip
    archive is reported as such (numpy would try to unpickle it and say so).
    """
    if path.is_dir():
        raise ModelFormatError(f'{path}: is a directory, not a network file')
    if not path.exists():
        raise FileNotFoundError(f'{path}: no such network file')
    try:
        with path.open('rb') as stream:
            head = stream.read(len(_NPY_MAGIC))  # the longer magic
    except OSError as exc:
        raise ModelFormatError(f'{path}: cannot read the network file: '
                               f'{exc.strerror or exc}') from exc
    if head.startswith(_NPY_MAGIC):
        raise ModelFormatError(f'{path}: a single .npy array, not a network file')
    if not head.startswith(_ZIP_MAGICS):
        what = 'an empty file' if not head else 'not a zip/.npz archive'
        raise ModelFormatError(f'{path}: not a .npz network file ({what})')
    unreadable = (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error, KeyError)
    try:
        loaded = np.load(path, allow_pickle=False)
    except zipfile.BadZipFile as exc:
        raise ModelFormatError(f'{path}: not a .npz network file (a truncated or damaged '
                               'zip archive)') from exc
    except unreadable as exc:
        raise ModelFormatError(f'{path}: not a .npz network file ({_one_line(exc)})') from exc
    if not isinstance(loaded, np.lib.npyio.NpzFile):
        raise ModelFormatError(f'{path}: not a .npz network file')
    entries: dict[str, np.ndarray] = {}
    with loaded:
        for name in loaded.files:
            try:
                entries[name] = loaded[name]
            except ValueError as exc:
                if 'allow_pickle' in str(exc):  # numpy refusing an object array
                    raise ModelFormatError(f'{path}: not a network file of ours: entry '
                                           f'{name!r} is an object array (never unpickled)'
                                           ) from exc
                raise ModelFormatError(f'{path}: corrupt network file: entry {name!r}: '
                                       f'{_one_line(exc)}') from exc
            except unreadable as exc:
                raise ModelFormatError(f'{path}: corrupt network file: entry {name!r}: '
                                       f'{_one_line(exc)}') from exc
    return entries


def _one_line(exc: BaseException) -> str:
    """The exception's message on one line, or its type's name if it has none."""
    return ' '.join(str(exc).split()) or type(exc).__name__


def _check_arrays(arrays: dict[str, np.ndarray]) -> str:
    """Return what is wrong with the entries, or '' when they are consistent."""
    missing = [name for name in _FIELDS if name not in arrays]
    if missing:
        return f'missing entries {missing}'
    unknown = sorted(set(arrays) - set(_FIELDS))
    if unknown:
        return f'unknown entries {unknown}'
    sizes = arrays['sizes']
    if sizes.shape != (3,) or sizes.dtype.kind not in 'iu' or np.any(sizes < 1):
        return f'sizes must be 3 positive integers, got {sizes!r}'
    n_in, n_hid, n_out = (int(v) for v in sizes)
    n_params = (n_in + 1) * n_hid + (n_hid + 1) * n_out
    activation = arrays['activation']
    if activation.shape != () or activation.dtype.kind != 'U' \
            or str(activation) not in ACTIVATIONS:
        return f'activation must be one of {sorted(ACTIVATIONS)}, got {activation!r}'
    expected = {'constants': (3,), 'params': (n_params,), 'velocity': (n_params,),
                'x_min': (n_in,), 'x_max': (n_in,), 'y_min': (n_out,), 'y_max': (n_out,),
                'training': (3,)}
    for name, shape in expected.items():
        value = arrays[name]
        if value.dtype != np.float64 or value.shape != shape:
            return f'{name} must be float64 of shape {shape}, got {value.dtype} {value.shape}'
        if not np.all(np.isfinite(value)):
            return f'{name} holds non-finite values'
    if arrays['constants'][1] == 0.0:
        return 'activation constant a is 0'
    if np.any(arrays['x_max'] < arrays['x_min']) or np.any(arrays['y_max'] < arrays['y_min']):
        return 'a scaling range has max < min'
    if arrays['scaling_set'].shape != () or arrays['scaling_set'].dtype != np.bool_:
        return 'scaling_set must be a boolean'
    if arrays['seed'].shape != () or arrays['seed'].dtype.kind not in 'iu':
        return 'seed must be an integer'
    lr, momentum, weight_scale = arrays['training']
    if not (lr > 0.0 and 0.0 <= momentum < 1.0 and weight_scale > 0.0):
        return f'training options out of range: {arrays["training"]}'
    return ''
