"""The paper's figures from our data, as PNG files (matplotlib, Agg backend).

=============  ==============================================  ==========================
paper          content                                         function
=============  ==============================================  ==========================
Figs 6–13      measured vs identified torque of each link       :func:`plot_torque`
               (FFMW: 6–9, FFS: 10–13; we also draw FFW)
Fig. 14        offline training MSE against iteration           :func:`plot_training_mse`
Fig. 15        online error against time                        :func:`plot_online_error`
=============  ==============================================  ==========================

Each ``plot_*`` function saves the :class:`~matplotlib.figure.Figure` its ``*_figure``
twin builds (``plot_torque`` draws ``torque_figure``), which tests can inspect. Each figure
is ``WIDTH_IN`` inches wide at ``DPI`` dots per inch, so its size in pixels is known in
advance (no tight bounding box). Long series are thinned to at most ``MAX_POINTS`` points
per line by taking every k-th sample.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ['DPI', 'MAX_POINTS', 'WIDTH_IN', 'effort_unit', 'figure_size_px',
           'learning_curves_figure', 'online_error_figure', 'plot_learning_curves',
           'plot_online_error', 'plot_torque', 'plot_training_mse', 'torque_figure',
           'training_mse_figure']

DPI = 100  # dots per inch
WIDTH_IN = 10.0  # inches
MAX_POINTS = 4000  # points per line
_PANEL_IN = 1.9  # inches per joint panel of the torque figures
_COLOURS = {'FFMW': 'tab:blue', 'FFW': 'tab:orange', 'FFS': 'tab:green', 'LS': 'tab:gray'}

#: The SCARA's joints (scara-model.md): joint3 is prismatic (N), the others revolute (N·m).
_SCARA_UNITS = {'joint1': 'N·m', 'joint2': 'N·m', 'joint3': 'N', 'joint4': 'N·m'}


def effort_unit(name: str, names: Sequence[str]) -> str:
    """Unit of a joint's effort: the SCARA's if ``names`` are its joints, else 'N·m or N'."""
    if sorted(names) == sorted(_SCARA_UNITS) and name in _SCARA_UNITS:
        return _SCARA_UNITS[name]
    return 'N·m or N'


def figure_size_px(kind: str, n_joints: int = 0) -> tuple[int, int]:
    """Width and height in pixels of a figure of ``kind`` ('torque', 'training', 'online')."""
    return (round(WIDTH_IN * DPI), round(_height_in(kind, n_joints) * DPI))


def _height_in(kind: str, n_joints: int) -> float:
    if kind == 'torque':
        return 1.2 + _PANEL_IN * max(n_joints, 1)
    if kind == 'training':
        return 5.0
    if kind == 'online':
        return 6.5
    raise ValueError(f'unknown figure kind {kind!r}')


def _pyplot() -> ModuleType:
    """matplotlib.pyplot on the Agg backend, imported when a figure is drawn."""
    import matplotlib
    matplotlib.use('Agg', force=True)
    import matplotlib.pyplot as plt
    return plt


def _thin(*arrays: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    count = arrays[0].shape[0]
    step = max(1, math.ceil(count / MAX_POINTS))
    return [a[::step] for a in arrays]


def _save(fig: Figure, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, format='png')
    _pyplot().close(fig)
    return path


def plot_torque(path: Path, time_s: NDArray[np.float64], measured: NDArray[np.float64],
                predicted: NDArray[np.float64], names: Sequence[str], *, title: str,
                predicted_label: str = 'identified') -> Path:
    """Write :func:`torque_figure` to ``path`` (PNG of ``figure_size_px('torque', n)``)."""
    return _save(torque_figure(time_s, measured, predicted, names, title=title,
                               predicted_label=predicted_label), path)


def torque_figure(time_s: NDArray[np.float64], measured: NDArray[np.float64],
                  predicted: NDArray[np.float64], names: Sequence[str], *, title: str,
                  predicted_label: str = 'identified') -> Figure:
    """Measured against identified effort, one panel per joint (Figs 6–13 of the paper).

    ``time_s`` (N,) in s, ``measured`` and ``predicted`` (N, n) in N·m or N, ``names`` the
    panel titles. The measured line is black, the prediction red and dashed.
    """
    plt = _pyplot()
    n = len(names)
    fig, axes = plt.subplots(n, 1, figsize=(WIDTH_IN, _height_in('torque', n)), sharex=True,
                             squeeze=False, layout='constrained')
    t, y, y_hat = _thin(np.asarray(time_s, float), np.asarray(measured, float),
                        np.asarray(predicted, float))
    for j, (ax, name) in enumerate(zip(axes[:, 0], names)):
        ax.plot(t, y[:, j], color='black', linewidth=1.0, label='measured')
        ax.plot(t, y_hat[:, j], color='tab:red', linewidth=0.8, linestyle='--',
                label=predicted_label)
        ax.set_ylabel(f'{name} ({effort_unit(name, names)})')
        ax.grid(True, alpha=0.3)
        if j == 0:
            ax.legend(loc='upper right', fontsize='small')
    axes[-1, 0].set_xlabel('time (s)')
    fig.suptitle(title)
    return fig


def plot_training_mse(path: Path, curves: Mapping[str, Sequence[Sequence[float]]], *,
                      title: str, goal: float | None = None) -> Path:
    """Write :func:`training_mse_figure` to ``path`` (PNG of ``figure_size_px('training')``)."""
    return _save(training_mse_figure(curves, title=title, goal=goal), path)


def training_mse_figure(curves: Mapping[str, Sequence[Sequence[float]]], *, title: str,
                        goal: float | None = None) -> Figure:
    """Training MSE against iteration for each method, log scale (Fig. 14 of the paper).

    ``curves`` maps a method label to one ``FitHistory.mse`` curve per seed (scaled
    units), drawn thin, with their median bold; ``goal`` is drawn as a horizontal line.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(WIDTH_IN, _height_in('training', 0)), layout='constrained')
    for label, seeds in curves.items():
        colour = _COLOURS.get(label)
        runs = [np.asarray(r, float) for r in seeds if len(r)]
        if not runs:
            continue
        for run in runs:
            ax.plot(np.arange(run.shape[0]), run, color=colour, linewidth=0.6, alpha=0.35)
        length = min(r.shape[0] for r in runs)
        median = np.median(np.vstack([r[:length] for r in runs]), axis=0)
        ax.plot(np.arange(length), median, color=colour, linewidth=2.0,
                label=f'{label} (median of {len(runs)})')
    if goal is not None:
        ax.axhline(goal, color='black', linestyle=':', linewidth=1.0, label=f'goal {goal:g}')
    ax.set_yscale('log')
    ax.set_xlabel('iteration')
    ax.set_ylabel('training MSE (outputs scaled to [-1, 1])')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend(loc='upper right')
    ax.set_title(title)
    return fig


def plot_online_error(path: Path,
                      curves: Mapping[str, tuple[NDArray[np.float64], NDArray[np.float64],
                                                 NDArray[np.float64]]], *,
                      title: str, mse_window: int, nmse_window: int,
                      units: str = '(N·m)² and N²') -> Path:
    """Write :func:`online_error_figure` to ``path`` (PNG of ``figure_size_px('online')``)."""
    return _save(online_error_figure(curves, title=title, mse_window=mse_window,
                                     nmse_window=nmse_window, units=units), path)


def online_error_figure(curves: Mapping[str, tuple[NDArray[np.float64], NDArray[np.float64],
                                                   NDArray[np.float64]]], *,
                        title: str, mse_window: int, nmse_window: int,
                        units: str = '(N·m)² and N²') -> Figure:
    """Online error against time for each method, log scale (Fig. 15 of the paper).

    ``curves`` maps a method label to time (s), windowed MSE and NMSE (N,) each
    (:func:`~scara_ident_ros.paper.online_results.rolling_errors`); MSE is drawn above,
    NMSE below, the windows (samples) named in the axis labels.
    """
    plt = _pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(WIDTH_IN, _height_in('online', 0)),
                                      sharex=True, layout='constrained')
    for label, (time_s, mse, nmse) in curves.items():
        colour = _COLOURS.get(label)
        t, e, ne = _thin(np.asarray(time_s, float), np.asarray(mse, float),
                         np.asarray(nmse, float))
        top.plot(t, e, color=colour, linewidth=1.0, label=label)
        bottom.plot(t, ne, color=colour, linewidth=1.0, label=label)
    top.set_yscale('log')
    bottom.set_yscale('log')
    top.set_ylabel(f'MSE, last {mse_window} samples\n{units}')
    bottom.set_ylabel(f'normalised MSE,\nlast {nmse_window} samples')
    bottom.set_xlabel('time (s)')
    for ax in (top, bottom):
        ax.grid(True, which='both', alpha=0.3)
        ax.legend(loc='upper right')
    fig.suptitle(title)
    return fig


def plot_learning_curves(path: Path, curves: Sequence[Any], title: str = '',
                         noise_floor: NDArray[np.float64] | None = None) -> Path:
    """Write :func:`learning_curves_figure` to ``path`` (PNG)."""
    return _save(learning_curves_figure(curves, title, noise_floor), path)


def learning_curves_figure(curves: Sequence[Any], title: str = '',
                           noise_floor: NDArray[np.float64] | None = None) -> Figure:
    """Held-out NMSE of the worst joint against seconds of stream, median and range over seeds.

    ``curves`` are :class:`~scara_ident_ros.paper.learning_curves.Curve` (label,
    seconds, nmse (K, n)); one line per label, its band the min–max over seeds.
    """
    plt = _pyplot()
    groups: dict[str, list[Any]] = {}
    for curve in curves:
        groups.setdefault(curve.label, []).append(curve)
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for label, group in groups.items():
        seconds = group[0].seconds
        worst = np.array([c.nmse.max(axis=1) for c in group])
        style = '--' if label in ('LS', 'RLS') else '-'
        line, = ax.plot(seconds, np.median(worst, axis=0), style, marker='o', ms=3,
                        label=label)
        ax.fill_between(seconds, worst.min(axis=0), worst.max(axis=0), alpha=0.15,
                        color=line.get_color())
    if noise_floor is not None:
        ax.axhline(float(np.max(noise_floor)), color='k', lw=0.8, ls=':',
                   label='noise floor (worst joint)')
    ax.set_yscale('log')
    ax.set_xlabel('seconds of stream')
    ax.set_ylabel('held-out NMSE, worst joint')
    ax.set_title(title or 'Frozen models on motions never seen')
    ax.grid(True, which='both', alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    return fig
