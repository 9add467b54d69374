"""ROS domains for test runs, claimed by a lock so that two runs never share one."""
from __future__ import annotations

import fcntl
import tempfile
from pathlib import Path
from typing import IO

__all__ = ['DOMAINS', 'LOCK_DIR', 'claim_domain']

DOMAINS = range(100, 233)  # Fast DDS accepts 0-232; below 100 is left to users' graphs
#: Where every test run on this machine keeps its domain locks.
LOCK_DIR = Path(tempfile.gettempdir()) / 'scara_ident_ros-domains'


def claim_domain(lock_dir: Path = LOCK_DIR, domains: range = DOMAINS
                 ) -> tuple[int, IO[str]]:
    """Take the first domain no other process on this machine holds, by an flock.

    A pid modulo can give two runs the same domain (seen: one run's bag held another's
    samples); a lock cannot. The lock is released when its file is closed or the process
    ends, however it ends.
    """
    lock_dir.mkdir(parents=True, exist_ok=True)
    for domain in domains:
        handle = open(lock_dir / f'domain-{domain}.lock', 'w')  # noqa: SIM115 (held open)
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        return domain, handle
    raise RuntimeError(f'every ROS domain {domains.start}-{domains.stop - 1} is held by '
                       f'another test run on this machine ({lock_dir})')
