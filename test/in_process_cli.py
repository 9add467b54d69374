"""``scara-ident`` run in the test's own process, and the check of its one-line errors."""
from __future__ import annotations

import re

import pytest

from scara_ident_ros.cli import main


def run_cli(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    """``scara-ident *argv`` (each argument as ``str``): exit status, stdout, stderr."""
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_one_line_error(code: int, out: str, err: str, pattern: str) -> None:
    """A bad input ends with exit status 2 and one line on stderr that matches ``pattern``."""
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert re.search(pattern, lines[0]), lines[0]
