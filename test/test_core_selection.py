"""``make test-core`` selects the tests not marked ``ros``: those must not need ROS.

A test module that imports rclpy, joins DDS or starts ROS processes says so with
``pytestmark = pytest.mark.ros``; ``make test-core`` runs ``-m 'not ros and not slow'``. This
test keeps that marker honest: every module without it is imported in one fresh
interpreter, and none may bring rclpy in.
"""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]  # one interpreter importing the whole suite

TEST_DIR = Path(__file__).resolve().parent
MARKED = re.compile(r'^pytestmark = .*pytest\.mark\.ros\b', re.MULTILINE)

# the paths pytest gives a test module: test/ (its conftest.py) and the module's own folder
IMPORT_EACH = """
import importlib.util, os, sys
test_dir, modules = sys.argv[1], sys.argv[2:]
sys.path.insert(0, test_dir)
for index, path in enumerate(modules):
    if os.path.dirname(path) not in sys.path:
        sys.path.insert(0, os.path.dirname(path))
    spec = importlib.util.spec_from_file_location(f'core_selection_{index}', path)
    module = sys.modules[spec.name] = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    if 'rclpy' in sys.modules:
        print(path)
        break
"""


def unmarked_modules() -> list[Path]:
    """The test modules ``make test-core`` runs: those without the ``ros`` marker."""
    return [path for path in sorted(TEST_DIR.rglob('test_*.py'))
            if not MARKED.search(path.read_text())]


def test_the_marker_is_found_where_it_is_written() -> None:
    marked = set(TEST_DIR.rglob('test_*.py')) - set(unmarked_modules())
    assert Path(__file__).resolve() in marked
    assert TEST_DIR / 'nodes' / 'test_identifier.py' in marked
    assert TEST_DIR / 'nn' / 'test_network.py' not in marked


def test_modules_not_marked_ros_import_no_rclpy() -> None:
    modules = unmarked_modules()
    assert len(modules) > 50
    out = subprocess.run([sys.executable, '-c', IMPORT_EACH, str(TEST_DIR),
                          *map(str, modules)],
                         capture_output=True, text=True, timeout=300, check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == '', (
        f'{out.stdout.strip()} imports rclpy: mark it with pytestmark = pytest.mark.ros')
