"""A saved model checked against a recording, evaluated, and its errors as a table.

A model file holds a network, a physical model, a hybrid or another model of the estimator
contract (its ``kind``, :mod:`scara_ident_ros.estimator`); all predict efforts from
X = [q, q', q''].
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from scara_ident_ros.dynamics.urdf_limits import UrdfError
from scara_ident_ros.estimator import Estimator
from scara_ident_ros.estimator import load_model as load_estimator
from scara_ident_ros.identification import ErrorStats
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.identification.warm_start import ModelMismatch, check_warm_start
from scara_ident_ros.nn import ModelFormatError
from scara_ident_ros.paper.figures import effort_unit
from scara_ident_ros.paper.tables import format_value

if TYPE_CHECKING:
    from scara_ident_ros.identification.recording import Recording

__all__ = ['ModelMismatch', 'errors_markdown', 'evaluate', 'evaluate_recording', 'load_model']


def load_model(path: Path) -> Estimator:
    """Read a model file of any kind (:func:`scara_ident_ros.estimator.load_model`) that
    maps [q, q', q''] to efforts.

    Raises
    ------
    ModelMismatch
        If the file is missing, the path is a directory, the file is not a model of
        ours (not a .npz archive, another format, corrupt), its sizes are not 3n inputs
        for n outputs, or it records another number of joints
        (:func:`~scara_ident_ros.identification.warm_start.check_warm_start`).
    """
    path = Path(path)
    if path.is_dir():
        raise ModelMismatch(f'{path}: is a directory, not a model file (.npz)')
    if not path.exists():
        raise ModelMismatch(f'{path}: no such model file')
    if not path.is_file():
        raise ModelMismatch(f'{path}: not a regular file, not a model file')
    try:
        model = load_estimator(path)
    except (ModelFormatError, UrdfError) as exc:
        raise ModelMismatch(' '.join(str(exc).split())) from None
    except (OSError, ValueError, KeyError, EOFError) as exc:
        raise ModelMismatch(f'{path}: not a scara-ident model file '
                            f'({type(exc).__name__}: {" ".join(str(exc).split())})') from None
    check_warm_start(model, source=str(path))
    return model


def evaluate(model: Estimator, X: npt.ArrayLike, Y: npt.ArrayLike) -> ErrorStats:
    """Per-joint MSE and NMSE of the model's predictions of Y (N, n) from X (N, 3n)."""
    return effort_errors(Y, model.predict(np.asarray(X, dtype=np.float64)))


def evaluate_recording(model_path: Path, recording_path: Path, *, topic: str | None = None,
                       span: tuple[float, float] | None = None
                       ) -> tuple[Estimator, Recording, ErrorStats]:
    """What ``scara-ident evaluate MODEL RECORDING`` scores: the model file (:func:`load_model`),
    the recording's samples of its joints (by name; in message order for a model without
    names), and the model's errors on them (on its ``span``, as fractions of its time, if
    given: ``recording_options.cut_span``).

    Raises
    ------
    ModelMismatch
        If the file is no model (:func:`load_model`) or the recording has another number
        of joints.
    BagError, RecordingError
        If the recording cannot be read (:func:`~scara_ident_ros.identification.recording.
        load_recording`).
    """
    from scara_ident_ros.cli.recording_options import cut_span
    from scara_ident_ros.identification.recording import load_recording

    model = load_model(model_path)
    recording = load_recording(recording_path, topic=topic, joints=model.joint_names)
    samples = recording.samples
    if len(samples.names) != model.n_outputs:
        raise ModelMismatch(f'{model_path} is a model of {model.n_outputs} joints, but '
                            f'{recording_path} {recording.topic} has {len(samples.names)}: '
                            f'{list(samples.names)}')
    data = samples.data if span is None else cut_span(samples.data, span)
    if len(data) < 2:
        raise ModelMismatch(f'{recording_path}: its part {span[0]:g}:{span[1]:g} holds '  # type: ignore[index]
                            f'{len(data)} samples')
    return model, recording, evaluate(model, data.X, data.Y)


def errors_markdown(names: Sequence[str], results: Mapping[str, ErrorStats]) -> str:
    """A Markdown table: one row per joint of ``names`` (and their mean), MSE and NMSE per
    data set of ``results`` (name → statistics); below it each data set's sample count and
    SMSE (:mod:`~scara_ident_ros.identification.metrics`)."""
    header = ['joint']
    for data, stats in results.items():
        header += [f'{data} MSE', f'{data} NMSE']
    rows = []
    for j, name in enumerate(names):
        unit = effort_unit(name, names)
        cells = [f'{name} ({unit})']
        for stats in results.values():
            cells += [format_value(float(stats.mse[j])), format_value(float(stats.nmse[j]))]
        rows.append(cells)
    mean = ['mean']
    for stats in results.values():
        mean += [format_value(stats.mse_total), format_value(stats.nmse_total)]
    rows.append(mean)
    counts = ', '.join(f'{data}: {stats.count} samples (SMSE {format_value(stats.smse)})'
                       for data, stats in results.items())
    lines = ['| ' + ' | '.join(header) + ' |', '|' + '|'.join('---' for _ in header) + '|']
    lines += ['| ' + ' | '.join(cells) + ' |' for cells in rows]
    units = ('MSE in (N·m)² or N² per joint (the mean mixes units); '
             'NMSE = MSE / variance of the joint\'s effort; SMSE = the squared errors of all '
             'joints over their squared deviations from the mean (1 − R², variance-weighted).')
    return '\n'.join(lines) + f'\n\n{counts}. {units}\n'
