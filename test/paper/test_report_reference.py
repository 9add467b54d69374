"""The SCARA's least-squares row is in Table 2 only when the run is the SCARA's."""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.paper.tables import read_csv
from scara_ident_ros.paper.report import make_report

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'bag'))
from fake_bags import States, synthetic_states, write_rosbag  # noqa: E402  (not a package)

TINY = dict(methods=('ffs',), seeds=1, iterations=1, samples=100, progress=None)


def table2_methods(bag: Path, out: Path, **options: object) -> set[str]:
    make_report([bag], out, **TINY, **options)  # type: ignore[arg-type]
    return {row['method'] for row in read_csv(out / 'table2_offline.csv')}


def scara_like(states: States) -> States:
    """The same motion squeezed into the SCARA's joint limits."""
    params = ScaraParams()
    low, high = np.asarray(params.position_min), np.asarray(params.position_max)
    unit = (states.position - states.position.min(0)) / np.ptp(states.position, axis=0)
    span = 0.8 * (high - low)
    return States(states.stamp_ns, params.joint_names, low + 0.1 * (high - low) + span * unit,
                  states.velocity, states.effort)


@pytest.fixture(scope='module')
def motion() -> States:
    return synthetic_states(4, 2.0, seed=3)  # joints joint1..4, positions of ±2 rad or m


def test_a_four_joint_robot_that_is_not_the_scara_gets_no_ls_row(
        motion: States, tmp_path: Path) -> None:
    assert abs(motion.position[:, 2]).max() > 0.5  # joint3 far beyond the SCARA's quill
    bag = write_rosbag(tmp_path / 'other_robot', motion)
    assert table2_methods(bag, tmp_path / 'report') == {'FFS'}
    # within the limits, but another robot's joints
    renamed = replace(scara_like(motion), names=('shoulder', 'elbow', 'lift', 'wrist'))
    bag = write_rosbag(tmp_path / 'renamed', renamed)
    assert table2_methods(bag, tmp_path / 'report_renamed') == {'FFS'}


def test_the_scara_gets_its_ls_row_and_a_caller_can_say_otherwise(
        motion: States, tmp_path: Path) -> None:
    bag = write_rosbag(tmp_path / 'scara', scara_like(motion))
    assert table2_methods(bag, tmp_path / 'report') == {'FFS', 'LS'}
    assert table2_methods(bag, tmp_path / 'no_ls', reference=False) == {'FFS'}
