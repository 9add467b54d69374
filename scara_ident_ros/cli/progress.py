"""A plain-text progress bar for offline training, as a ``nn.fit`` callback.

On a terminal the bar is redrawn in place (carriage return), at most every
``min_interval_s``; on anything else (a log file, a pipe) one line is written per tenth of
the iterations, so logs stay short. No dependency beyond the standard library.
"""
from __future__ import annotations

import sys
import time
from typing import TextIO

from scara_ident_ros.nn import FitHistory

__all__ = ['TrainingProgress']


class TrainingProgress:
    """Show training progress: iteration, training and validation MSE, elapsed time.

    ``total`` is the iteration limit (the bar is full there), ``min_interval_s`` the least
    time (s) between two redraws on a terminal. Use the instance as ``callback`` of ``fit``
    and call :meth:`close` afterwards (it reports why training stopped); the errors shown
    are ``fit``'s scaled MSE.
    """

    def __init__(self, total: int, *, label: str = '', stream: TextIO | None = None,
                 width: int = 30, min_interval_s: float = 0.1) -> None:
        self.total = max(int(total), 1)
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.width = int(width)
        self.min_interval_s = float(min_interval_s)
        self.interactive = bool(getattr(self.stream, 'isatty', lambda: False)())
        self._start = time.monotonic()
        self._last_draw = -float('inf')
        self._last_tenth = -1
        self._history: FitHistory | None = None

    def __call__(self, history: FitHistory) -> None:
        """Record one iteration (the ``fit`` callback); never asks to stop."""
        self._history = history
        now = time.monotonic()
        if self.interactive:
            if now - self._last_draw >= self.min_interval_s or history.iterations >= self.total:
                self._last_draw = now
                self.stream.write('\r' + self.line(history))
                self.stream.flush()
        else:
            tenth = 10 * history.iterations // self.total
            if tenth > self._last_tenth:
                self._last_tenth = tenth
                self.stream.write(self.line(history) + '\n')
                self.stream.flush()

    def line(self, history: FitHistory) -> str:
        """The progress text for ``history`` (no line end)."""
        done = min(history.iterations, self.total)
        filled = round(self.width * done / self.total)
        bar = '#' * filled + '.' * (self.width - filled)
        text = f'{self.label} [{bar}] {history.iterations}/{self.total}'
        if history.mse:
            text += f' mse {history.mse[-1]:.3e}'
        if history.val_mse:
            text += f' val {history.val_mse[-1]:.3e}'
        return text + f' {time.monotonic() - self._start:.1f} s'

    def close(self) -> None:
        """End the bar's line and say why training stopped."""
        history = self._history
        if history is None:
            return
        start = '\r' if self.interactive else ''
        self.stream.write(f'{start}{self.line(history)} stopped: {history.stop_reason}\n')
        self.stream.flush()
