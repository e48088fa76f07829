"""One BLAS thread for the small dense linear algebra of the dynamics.

The dense matrices of vibeam's methods are small: a monodromy matrix of dimension ``d = 2 n``
(``n`` retained modes, 92 for the all-modes rig beam), a shooting Jacobian, a bordered corrector.
On them OpenBLAS's worker threads cost more than they give, and far more on a loaded machine,
where they spin waiting for a core.  Measured on the 2-core development machine with one other
process running: ``numpy.linalg.eigvals`` of a 92 x 92 matrix 6.7 ms with OpenBLAS's 2 threads
against 2.0 ms with one; the all-modes neutral beam's period-1 branch (``vibeam bench
--continuation``, 38 points) 0.55-0.75 s against 0.07 s.  The limit is threadpoolctl's (the
libraries loaded when it is entered: numpy's and scipy's OpenBLAS, which numba's LAPACK calls use
too), entered once per branch or curve (about 1 ms) and restored on leaving.
"""
from __future__ import annotations

import functools

from threadpoolctl import threadpool_limits

__all__ = ["one_blas_thread", "with_one_blas_thread"]


def one_blas_thread():
    """A context manager holding the loaded BLAS libraries to one thread (restored on exit)."""
    return threadpool_limits(limits=1, user_api="blas")


def with_one_blas_thread(fn):
    """``fn`` run under :func:`one_blas_thread` (a decorator)."""
    @functools.wraps(fn)
    def run(*args, **kwargs):
        with one_blas_thread():
            return fn(*args, **kwargs)
    return run
