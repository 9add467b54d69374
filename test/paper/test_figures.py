"""The figures are real PNG files of the announced size, with the data drawn.

Each ``plot_*`` function saves the Figure of its ``*_figure`` twin: the tests check that
Figure's lines against the inputs (thinned as documented), its labels, legend and units,
and, in the saved PNG, that pixels of each series' colour are there.
"""
from __future__ import annotations

import math
import struct
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import matplotlib.image
import numpy as np
import pytest
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from numpy.typing import NDArray

from scara_ident_ros.paper.figures import (MAX_POINTS, effort_unit, figure_size_px,
                                           learning_curves_figure, online_error_figure,
                                           plot_learning_curves, plot_online_error, plot_torque,
                                           plot_training_mse, torque_figure, training_mse_figure)

PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'


def png_size(path: Path) -> tuple[int, int]:
    """Width and height from a PNG's IHDR chunk, checking the signature."""
    head = path.read_bytes()[:24]
    assert head[:8] == PNG_SIGNATURE, f'{path} is not a PNG'
    assert head[12:16] == b'IHDR'
    width, height = struct.unpack('>II', head[16:24])
    return width, height


def colour_pixels(path: Path, colour: str) -> int:
    """Pixels of the PNG within a small distance of ``colour`` (anti-aliasing aside)."""
    rgb = matplotlib.image.imread(path)[..., :3]
    return int((np.abs(rgb - np.array(to_rgb(colour))).max(axis=-1) < 0.06).sum())


def thinned(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """What the figures draw of a long series: every k-th sample, at most MAX_POINTS."""
    return a[::max(1, math.ceil(a.shape[0] / MAX_POINTS))]


def legend_texts(ax: object) -> list[str]:
    legend = ax.get_legend()  # type: ignore[attr-defined]
    return [t.get_text() for t in legend.get_texts()]


def close(fig: Figure) -> None:
    import matplotlib.pyplot as plt
    plt.close(fig)


@pytest.mark.parametrize('n_joints', [2, 6])
def test_torque_figure(tmp_path: Path, n_joints: int) -> None:
    t = np.linspace(0.0, 10.0, 10_001)
    measured = np.sin(t[:, None] * np.arange(1, n_joints + 1))
    names = [f'j{i}' for i in range(n_joints)]
    path = plot_torque(tmp_path / 'sub' / 'torque.png', t, measured, measured + 0.01, names,
                       title='FFMW')
    assert path == tmp_path / 'sub' / 'torque.png'
    assert png_size(path) == figure_size_px('torque', n_joints)
    assert colour_pixels(path, 'tab:red') > 100  # the prediction (measured: black, as text)

    fig = torque_figure(t, measured, measured + 0.01, names, title='FFMW',
                        predicted_label='FFMW online')
    axes = fig.axes
    assert len(axes) == n_joints and fig.get_suptitle() == 'FFMW'
    assert thinned(t).shape[0] <= MAX_POINTS
    for j, (ax, name) in enumerate(zip(axes, names)):
        line_measured, line_predicted = ax.get_lines()
        np.testing.assert_array_equal(line_measured.get_xdata(), thinned(t))
        np.testing.assert_array_equal(line_measured.get_ydata(), thinned(measured[:, j]))
        np.testing.assert_array_equal(line_predicted.get_ydata(),
                                      thinned(measured[:, j] + 0.01))
        assert (line_measured.get_label(), line_predicted.get_label()) == (
            'measured', 'FFMW online')
        assert ax.get_ylabel() == f'{name} (N·m or N)'
    assert legend_texts(axes[0]) == ['measured', 'FFMW online']
    assert axes[-1].get_xlabel() == 'time (s)'
    close(fig)


def test_torque_figure_of_the_scara_names_each_unit() -> None:
    t = np.linspace(0.0, 1.0, 11)
    names = ['joint1', 'joint2', 'joint3', 'joint4']
    fig = torque_figure(t, np.zeros((11, 4)), np.ones((11, 4)), names, title='')
    assert [ax.get_ylabel() for ax in fig.axes] == [
        'joint1 (N·m)', 'joint2 (N·m)', 'joint3 (N)', 'joint4 (N·m)']
    np.testing.assert_array_equal(fig.axes[2].get_lines()[1].get_ydata(), np.ones(11))
    close(fig)


def test_training_and_online_figures(tmp_path: Path) -> None:
    curves: dict[str, Any] = {'FFMW': [np.logspace(0, -6, 316), np.logspace(0, -5, 316)],
              'FFW': [np.logspace(0, -4, 100)], 'FFS': []}
    path = plot_training_mse(tmp_path / 'fig14.png', curves, title='Fig. 14', goal=1e-5)
    assert png_size(path) == figure_size_px('training')
    assert colour_pixels(path, 'tab:blue') > 100 and colour_pixels(path, 'tab:orange') > 100
    assert colour_pixels(path, 'tab:green') == 0  # FFS has no curve
    t = np.linspace(0, 5, 5000)
    online = {'FFMW': (t, np.exp(-t), np.exp(-t) / 10), 'FFS': (t, 1 + 0 * t, np.nan * t)}
    path = plot_online_error(tmp_path / 'fig15.png', online, title='Fig. 15', mse_window=100,
                             nmse_window=1000)
    assert png_size(path) == figure_size_px('online')
    assert colour_pixels(path, 'tab:blue') > 100 and colour_pixels(path, 'tab:green') > 100


def test_training_figure_draws_each_seed_and_their_median() -> None:
    curves: dict[str, Any] = {'FFMW': [np.logspace(0, -6, 316), np.logspace(0, -5, 300)],
              'FFW': [np.logspace(0, -4, 100)], 'FFS': []}
    fig = training_mse_figure(curves, title='Fig. 14', goal=1e-5)
    (ax,) = fig.axes
    lines = ax.get_lines()
    assert len(lines) == 2 + 1 + 1 + 1 + 1  # FFMW seeds + median, FFW seed + median, goal
    np.testing.assert_array_equal(lines[0].get_ydata(), curves['FFMW'][0])
    np.testing.assert_array_equal(lines[1].get_ydata(), curves['FFMW'][1])
    np.testing.assert_allclose(np.asarray(lines[2].get_ydata(), float),
                               np.median([curves['FFMW'][0][:300], curves['FFMW'][1]], axis=0))
    np.testing.assert_array_equal(lines[2].get_xdata(), np.arange(300))
    np.testing.assert_array_equal(lines[4].get_ydata(), curves['FFW'][0])
    assert to_rgb(lines[2].get_color()) == to_rgb('tab:blue')
    assert to_rgb(lines[4].get_color()) == to_rgb('tab:orange')
    assert legend_texts(ax) == ['FFMW (median of 2)', 'FFW (median of 1)', 'goal 1e-05']
    np.testing.assert_array_equal(lines[5].get_ydata(), [1e-5, 1e-5])
    assert ax.get_yscale() == 'log' and ax.get_title() == 'Fig. 14'
    assert ax.get_xlabel() == 'iteration'
    assert ax.get_ylabel() == 'training MSE (outputs scaled to [-1, 1])'
    close(fig)


def test_online_figure_draws_mse_above_and_nmse_below() -> None:
    t = np.linspace(0, 5, 5000)
    online = {'FFMW': (t, np.exp(-t), np.exp(-t) / 10), 'FFS': (t, 1 + 0 * t, 2 + 0 * t)}
    fig = online_error_figure(online, title='Fig. 15', mse_window=100, nmse_window=1000)
    top, bottom = fig.axes
    for ax, column in ((top, 1), (bottom, 2)):
        assert [line.get_label() for line in ax.get_lines()] == ['FFMW', 'FFS']
        for line, (time_s, *errors) in zip(ax.get_lines(), online.values()):
            np.testing.assert_array_equal(line.get_xdata(), thinned(time_s))
            np.testing.assert_array_equal(line.get_ydata(), thinned(errors[column - 1]))
        assert legend_texts(ax) == ['FFMW', 'FFS'] and ax.get_yscale() == 'log'
    assert top.get_ylabel() == 'MSE, last 100 samples\n(N·m)² and N²'
    assert bottom.get_ylabel() == 'normalised MSE,\nlast 1000 samples'
    assert bottom.get_xlabel() == 'time (s)' and fig.get_suptitle() == 'Fig. 15'
    close(fig)


def test_learning_curves_figure_draws_the_median_of_the_worst_joint(tmp_path: Path) -> None:
    seconds = np.array([1.0, 2.0, 4.0])
    ls = [SimpleNamespace(label='LS', seconds=seconds,
                          nmse=np.array([[1e-2, 2e-2], [1e-3, 3e-3], [1e-4, 1e-5]]) * k)
          for k in (1.0, 2.0, 4.0)]
    ffs = [SimpleNamespace(label='FFS lm', seconds=seconds,
                           nmse=np.array([[0.5, 0.1], [0.2, 0.1], [0.1, 0.05]]))]
    fig = learning_curves_figure([*ls, *ffs], 'curves', noise_floor=np.array([1e-6, 3e-6]))
    (ax,) = fig.axes
    ls_line, ffs_line, floor = ax.get_lines()
    np.testing.assert_array_equal(ls_line.get_xdata(), seconds)
    # the worst joint of the median seed (k = 2)
    np.testing.assert_allclose(np.asarray(ls_line.get_ydata(), float), [4e-2, 6e-3, 2e-4])
    np.testing.assert_allclose(np.asarray(ffs_line.get_ydata(), float), [0.5, 0.2, 0.1])
    np.testing.assert_array_equal(floor.get_ydata(), [3e-6, 3e-6])
    assert legend_texts(ax) == ['LS', 'FFS lm', 'noise floor (worst joint)']
    assert ax.get_title() == 'curves' and ax.get_ylabel() == 'held-out NMSE, worst joint'
    close(fig)
    path = plot_learning_curves(tmp_path / 'curves.png', [*ls, *ffs])
    assert colour_pixels(path, 'tab:blue') > 50 and colour_pixels(path, 'tab:orange') > 50


def test_effort_units() -> None:
    scara = ['joint1', 'joint2', 'joint3', 'joint4']
    assert [effort_unit(n, scara) for n in scara] == ['N·m', 'N·m', 'N', 'N·m']
    assert effort_unit('joint1', ['joint1', 'joint2']) == 'N·m or N'
    with pytest.raises(ValueError):
        figure_size_px('pie')
