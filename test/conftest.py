"""Test-wide set-up: DDS stays on this machine, each run (each xdist worker) gets its own
domain, and BLAS runs on one thread whichever command started the tests."""
from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import IO

from threadpoolctl import threadpool_limits

# One BLAS thread, as the identifier's learner processes and `scara-ident run` have: Levenberg-
# Marquardt is chaotic in the rounding, and a BLAS splitting its sums over two threads gives
# other weights than one thread. make test-core pinned one thread and make test did not, so
# two tests whose results sat near their bounds failed under one command and passed under
# the other. The variables reach the BLAS libraries loaded from now on and the processes the
# tests start; threadpoolctl limits those already loaded (numpy's, imported by plugins).
for _variable in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
    os.environ.setdefault(_variable, '1')
threadpool_limits(limits=int(os.environ['OPENBLAS_NUM_THREADS']), user_api='blas')

# Before anything imports rclpy: keep Fast DDS discovery on loopback, and keep
# this test run (and the processes it starts) in a domain of its own so parallel
# runs on the same machine do not hear each other.
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ros_domains import claim_domain  # noqa: E402  (test/ is no package)

#: The domain this conftest claimed, passed on so that an xdist worker, which inherits its
#: controller's environment, knows the ROS_DOMAIN_ID it sees is a claim and not the user's.
CLAIMED = 'SCARA_IDENT_TEST_CLAIMED_DOMAIN'

_held: IO[str] | None = None  # the lock of this process's domain, held until it ends
_inherited_claim = ('PYTEST_XDIST_WORKER' in os.environ
                    and os.environ.get(CLAIMED) == os.environ.get('ROS_DOMAIN_ID'))
if 'ROS_DOMAIN_ID' not in os.environ or _inherited_claim:
    _domain, _held = claim_domain()
    os.environ['ROS_DOMAIN_ID'] = os.environ[CLAIMED] = str(_domain)
