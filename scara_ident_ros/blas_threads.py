"""Hold the BLAS to one thread while training (offline, in experiments and in the identifier).

Levenberg–Marquardt spends its time in a Cholesky factorisation and matrix products of a
few hundred unknowns: too small to gain from a second BLAS thread, and on a busy machine
OpenBLAS's spinning threads fight each other and everything else, which makes an LM
iteration several times slower (docs/results.md). :func:`single_blas_thread` limits numpy's
(and scipy's) BLAS pools with ``threadpoolctl`` when it is installed (it comes with
scikit-learn) and does nothing otherwise.
"""
from __future__ import annotations

import contextlib
from collections.abc import Iterator

try:
    from threadpoolctl import threadpool_limits
except ImportError:  # pragma: no cover - optional
    threadpool_limits = None

__all__ = ['BLAS_THREADS', 'single_blas_thread']

#: What :func:`single_blas_thread` does here, for reports.
BLAS_THREADS = ('1 (threadpoolctl)' if threadpool_limits is not None
                else 'library default (threadpoolctl not installed)')


@contextlib.contextmanager
def single_blas_thread() -> Iterator[None]:
    """Context in which the BLAS libraries use one thread (if threadpoolctl is available)."""
    if threadpool_limits is None:
        yield
        return
    with threadpool_limits(limits=1, user_api='blas'):
        yield
