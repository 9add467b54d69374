"""``--help`` on every node: its parameters, exit 0, nothing started or created."""
from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

NODES = ('identifier', 'scara_sim', 'robot_sim', 'recorder', 'player', 'excitation')


@pytest.mark.parametrize('node', NODES)
@pytest.mark.parametrize('flag', ['--help', '-h'])
def test_help_lists_every_parameter_and_starts_nothing(node: str, flag: str,
                                                       tmp_path: Path) -> None:
    module = f'scara_ident_ros.nodes.{node}'
    out = subprocess.run([sys.executable, '-m', module, flag], cwd=tmp_path, text=True,
                         capture_output=True, timeout=60, check=False)
    assert out.returncode == 0, out.stderr
    assert out.stderr == ''  # no node started: no log line
    assert list(tmp_path.iterdir()) == []  # the recorder made no bag directory
    for spec in importlib.import_module(module).PARAMETERS:
        assert f'  {spec.name} = {spec.default!r}' in out.stdout
        assert spec.description.split(';')[0][:40] in out.stdout
