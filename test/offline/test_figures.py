"""The figures are real PNG files of the announced size, with the data drawn."""
from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.offline.figures import (effort_unit, figure_size_px, plot_online_error,
                                             plot_torque, plot_training_mse)

PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'


def png_size(path: Path) -> tuple[int, int]:
    """Width and height from a PNG's IHDR chunk, checking the signature."""
    head = path.read_bytes()[:24]
    assert head[:8] == PNG_SIGNATURE, f'{path} is not a PNG'
    assert head[12:16] == b'IHDR'
    width, height = struct.unpack('>II', head[16:24])
    return width, height


@pytest.mark.parametrize('n_joints', [2, 6])
def test_torque_figure(tmp_path: Path, n_joints: int) -> None:
    t = np.linspace(0.0, 10.0, 10_001)
    measured = np.sin(t[:, None] * np.arange(1, n_joints + 1))
    names = [f'j{i}' for i in range(n_joints)]
    path = plot_torque(tmp_path / 'sub' / 'torque.png', t, measured, measured + 0.01, names,
                       title='FFMW')
    assert path == tmp_path / 'sub' / 'torque.png'
    assert png_size(path) == figure_size_px('torque', n_joints)


def test_training_and_online_figures(tmp_path: Path) -> None:
    curves = {'FFMW': [np.logspace(0, -6, 316), np.logspace(0, -5, 316)],
              'FFW': [np.logspace(0, -4, 100)], 'FFS': []}
    path = plot_training_mse(tmp_path / 'fig14.png', curves, title='Fig. 14', goal=1e-5)
    assert png_size(path) == figure_size_px('training')
    t = np.linspace(0, 5, 5000)
    online = {'FFMW': (t, np.exp(-t), np.exp(-t) / 10), 'FFS': (t, 1 + 0 * t, np.nan * t)}
    path = plot_online_error(tmp_path / 'fig15.png', online, title='Fig. 15', mse_window=100,
                             nmse_window=1000)
    assert png_size(path) == figure_size_px('online')


def test_effort_units() -> None:
    scara = ['joint1', 'joint2', 'joint3', 'joint4']
    assert [effort_unit(n, scara) for n in scara] == ['N·m', 'N·m', 'N', 'N·m']
    assert effort_unit('joint1', ['joint1', 'joint2']) == 'N·m or N'
    with pytest.raises(ValueError):
        figure_size_px('pie')
