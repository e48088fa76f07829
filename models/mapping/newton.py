"""Damped Newton with a halving line search: the root finder of both multiple-shooting residuals
of the pointwise mapping (the one-mode map's :meth:`vibeam.models.mapping.orbit.SectionMap.newton`, the
N-mode map's :meth:`vibeam.models.mapping.modal.ModalMap.newton`).

Here *Newton* is the root-finding method, not Newton's law of restitution at a stop.
"""
from __future__ import annotations

import numpy as np

#: the line search halves the step until the residual decreases; the last trial is the first step
#: below this fraction of the full one (2**-13), taken whether the residual decreased or not
MIN_STEP = 2e-4
#: after ``max_iter`` iterations the last iterate counts as converged to this factor times ``tol``
FALLBACK = 1e3


def damped_newton(residual, x0, tol, skip, max_iter=50, fallback=FALLBACK):
    """Damped Newton on ``residual`` from ``x0``, the step shortened by halving until the residual's
    largest component decreases.

    Each iteration first tests convergence, ``max |r(x)| <= tol * max(max |x[skip:]|, 1e-300)``
    (the residual relative to the unknowns that set its scale: the arrival speeds or states, not
    the leading section times); then solves ``J dx = -r`` and tries ``x + lam dx`` for ``lam = 1,
    1/2, 1/4, ...`` until ``max |r|`` is smaller than at ``x`` or ``lam < 2e-4``
    (:data:`MIN_STEP`; that last trial, ``lam = 2**-13``, is taken anyway).

    Parameters
    ----------
    residual : callable
        ``residual(x) -> (r, J)``: the residual, shape ``(k,)``, and its Jacobian ``dr/dx``, shape
        ``(k, k)``, at ``x``; ``(None, None)`` where it is not defined (a passage without exit,
        a section passed).
    x0 : array_like, shape (k,)
        The guess (copied as float).
    tol : float
        Tolerance on ``max |r|`` relative to ``max |x[skip:]|``.
    skip : int
        The leading components of ``x`` that do not set the scale (the ``m`` section times).
    max_iter : int, optional
        Iterations (Newton steps) at most.
    fallback : float, optional
        After ``max_iter`` steps the last iterate counts as converged when ``max |r| <= fallback *
        tol * max(max |x[skip:]|, 1e-300)`` (:data:`FALLBACK`).

    Returns
    -------
    x : ndarray, shape (k,)
        The last accepted iterate (``x0`` itself, as float, when ``residual(x0)`` is undefined).
    converged : bool
        Whether it meets ``tol`` (``fallback * tol`` after ``max_iter`` steps); False at once when
        ``residual(x0)`` is undefined, the Jacobian is singular, or the accepted trial has an
        undefined residual or a non-finite component (then ``x`` is the iterate before it).

    Raises
    ------
    Exception
        Only what ``residual`` raises (propagated).  A singular Jacobian
        (:class:`numpy.linalg.LinAlgError`) is caught: it ends the iteration as not converged.

    References
    ----------
    .. [1] J. E. Dennis, R. B. Schnabel, *Numerical Methods for Unconstrained Optimization and
       Nonlinear Equations*, SIAM Classics in Applied Mathematics 16, 1996, Ch. 6 (globally
       convergent modifications of Newton's method: backtracking line search); here the simple
       decrease of ``max |r|`` with halving, not the Armijo condition.
    """
    x = np.array(x0, float)
    r, J = residual(x)
    if r is None:
        return x, False

    def scale(y):
        return max(np.max(np.abs(y[skip:])), 1e-300)

    for _ in range(max_iter):
        if np.max(np.abs(r)) <= tol * scale(x):
            return x, True
        try:
            dx = np.linalg.solve(J, -r)
        except np.linalg.LinAlgError:
            return x, False
        lam, nr = 1.0, np.max(np.abs(r))
        while True:
            xn = x + lam * dx
            rn, Jn = residual(xn)
            if (rn is not None and np.max(np.abs(rn)) < nr) or lam < MIN_STEP:
                break
            lam *= 0.5
        if rn is None or not np.all(np.isfinite(xn)):
            return x, False
        x, r, J = xn, rn, Jn
    return x, bool(np.max(np.abs(r)) <= fallback * tol * scale(x))
