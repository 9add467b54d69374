"""The test runs' ROS domains: claimed by lock, never shared by two runs at once."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from ros_domains import claim_domain  # noqa: E402  (test/ is no package)

pytestmark = pytest.mark.ros


def test_two_claims_never_get_the_same_domain(tmp_path: Path) -> None:
    first, held = claim_domain(tmp_path, range(150, 153))
    # another process (flock is per open file; a child holds its own) gets another one
    code = ('import sys; sys.path.insert(0, sys.argv[1]); from ros_domains import claim_domain; '
            'from pathlib import Path; print(claim_domain(Path(sys.argv[2]), range(150, 153))[0])')
    test_dir = str(Path(__file__).resolve().parent)
    other = subprocess.run([sys.executable, '-c', code, test_dir, str(tmp_path)], text=True,
                           capture_output=True, check=True, env={**os.environ}).stdout
    assert first == 150 and int(other) == 151
    held.close()  # released: the next claim may have it again
    again, handle = claim_domain(tmp_path, range(150, 153))
    assert again == 150
    handle.close()


def test_all_domains_held_is_an_error(tmp_path: Path) -> None:
    _, handle = claim_domain(tmp_path, range(150, 151))
    code = ('import sys; sys.path.insert(0, sys.argv[1]); from ros_domains import claim_domain; '
            'from pathlib import Path; claim_domain(Path(sys.argv[2]), range(150, 151))')
    out = subprocess.run([sys.executable, '-c', code, str(Path(__file__).resolve().parent),
                          str(tmp_path)], text=True, capture_output=True, check=False)
    assert out.returncode != 0 and 'every ROS domain 150-150 is held' in out.stderr
    handle.close()


def test_this_run_holds_its_domain() -> None:
    """Another process cannot claim the domain this run was given (unless a user set it)."""
    domain = int(os.environ['ROS_DOMAIN_ID'])
    assert 0 <= domain <= 232
    if domain < 100:
        return  # the user's choice, not a claim
    code = ('import sys; sys.path.insert(0, sys.argv[1]); '
            'from ros_domains import LOCK_DIR, claim_domain; '
            f'claim_domain(LOCK_DIR, range({domain}, {domain + 1}))')
    out = subprocess.run([sys.executable, '-c', code, str(Path(__file__).resolve().parent)],
                         text=True, capture_output=True, check=False,
                         env={k: v for k, v in os.environ.items() if k != 'ROS_DOMAIN_ID'})
    assert out.returncode != 0 and f'every ROS domain {domain}-{domain} is held' in out.stderr


def test_each_xdist_worker_claims_a_domain_of_its_own(tmp_path: Path) -> None:
    """make test runs the suite on two xdist workers; each inherits its controller's
    environment, claimed domain included, and must claim one of its own (test/conftest.py)."""
    suite_conftest = Path(__file__).resolve().parent / 'conftest.py'
    (tmp_path / 'conftest.py').write_text(
        'import importlib.util\n'
        'spec = importlib.util.spec_from_file_location(\n'
        f'    "suite_conftest", {str(suite_conftest)!r})\n'
        'suite = importlib.util.module_from_spec(spec)  # holds its domain lock\n'
        'spec.loader.exec_module(suite)\n')
    (tmp_path / 'test_domain.py').write_text(
        'import os\n'
        'from pathlib import Path\n\n\n'
        'def test_domain() -> None:\n'
        '    worker = os.environ["PYTEST_XDIST_WORKER"]\n'
        f'    domain_file = Path({str(tmp_path)!r}, worker + ".domain")\n'
        '    domain_file.write_text(os.environ["ROS_DOMAIN_ID"])\n')
    env = {k: v for k, v in os.environ.items()
           if k not in ('ROS_DOMAIN_ID', 'SCARA_IDENT_TEST_CLAIMED_DOMAIN')
           and not k.startswith('PYTEST_XDIST')}
    run = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-n', '2', '--dist', 'each',
                          '-p', 'no:randomly', '-p', 'no:cacheprovider', '--rootdir',
                          str(tmp_path), str(tmp_path / 'test_domain.py')],
                         cwd=tmp_path, env=env, text=True, capture_output=True, check=False)
    assert run.returncode == 0, run.stdout + run.stderr
    domains = {int(p.read_text()) for p in tmp_path.glob('gw*.domain')}
    assert len(domains) == 2 and os.environ['ROS_DOMAIN_ID'] not in map(str, domains)
