"""The training progress bar: in place on a terminal, a line per tenth elsewhere."""
from __future__ import annotations

import io

import numpy as np

from scara_ident_ros.nn import fit
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.cli.progress import TrainingProgress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _train(progress: TrainingProgress, iterations: int) -> None:
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (50, 6))
    y = np.stack([np.sin(x[:, 0]), x[:, 1] * x[:, 4]], axis=1)
    net = make_network('ffs', 2, n_hidden=5)
    fit(net, x, y, algorithm='gd', iterations=iterations, callback=progress,
        validation=(x[:10], y[:10]), max_fail=1000)
    progress.close()


def test_log_stream_gets_a_line_per_tenth() -> None:
    stream = io.StringIO()
    _train(TrainingProgress(40, label='FFS gd', stream=stream), 40)
    lines = stream.getvalue().splitlines()
    assert len(lines) == 12  # 0 %..100 % and the closing line
    assert lines[-1].startswith('FFS gd [##############################] 40/40 mse ')
    assert ' val ' in lines[-1] and lines[-1].endswith('stopped: iterations')


def test_terminal_redraws_in_place() -> None:
    stream = _Terminal()
    _train(TrainingProgress(20, stream=stream, min_interval_s=0.0), 20)
    text = stream.getvalue()
    assert text.count('\n') == 1 and text.endswith('stopped: iterations\n')
    assert text.count('\r') == 21
