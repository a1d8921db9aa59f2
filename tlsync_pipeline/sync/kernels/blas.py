"""The BLAS threads the sync runs with: one, whoever calls it.

The fits' matrices are small (a pose's 4000 x 8 Jacobian, the joint fit's
normal equations): OpenBLAS's threads spin on them rather than help, a pose's
Jacobian's SVD 48 ms of CPU on two busy cores against 0.3 ms on one thread.
The pipeline runs its stages under this limit (pipeline/engine.py);
synchronize() sets it itself, so a library call runs as the sync stage does.
"""

from __future__ import annotations

from contextlib import AbstractContextManager


def one_blas_thread() -> AbstractContextManager:
    """A context in which numpy's and scipy's OpenBLAS (two libraries in their wheels) run one thread each."""
    import scipy.linalg  # noqa: F401 - loads scipy's OpenBLAS, so that the limit covers it too
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")
