"""Root bracketing shared by the exact event kernels (numba).

Both the SDOF and the FE kernels locate impacts, apexes and minima of a gap
signal ``g(s)`` on a bracket ``[lo, hi]`` with ``F(lo) < 0 <= F(hi)``, where
``F`` is ``g``, ``-g'`` or ``g'``.  Each kernel evaluates its own signal; the
iteration itself (safeguarded Newton, "rtsafe": Press et al., *Numerical
Recipes*, 3rd ed., Sec. 9.4) lives here once.
"""
from __future__ import annotations

import numpy as np
from numba import njit

EPS = 2.220446049250313e-16


@njit(cache=True, error_model="numpy", inline="always")
def select(kind, g, v, g2):
    """``(F, F')`` of the three bracketed problems from ``g, g', g''``.

    kind 0: ``F = g`` (crossing); 1: ``F = -g'`` (apex, g' falling);
    2: ``F = g'`` (minimum, g' rising).
    """
    if kind == 0:
        return g, v
    if kind == 1:
        return -v, -g2
    return v, g2


@njit(cache=True, error_model="numpy", inline="always")
def rtsafe_update(F, dF, s, lo, hi, dx, dxold):
    """One step of safeguarded Newton on a sign-changing bracket.

    Parameters
    ----------
    F, dF : float
        Function value and derivative at ``s``.
    s, lo, hi : float
        Current iterate and bracket (``F(lo) < 0 <= F(hi)``).
    dx, dxold : float
        Last two step lengths (the Newton step is accepted only if it stays in
        the bracket and at least halves the step before last).

    Returns
    -------
    s, lo, hi, dx, dxold, done
        Next iterate and bracket; ``done`` when ``F(s) == 0`` (then ``s`` is the
        root), when the bracket is a few ulps wide (then ``s = hi``, the side with
        ``F >= 0``, so an impact is never placed before the crossing), or when the
        Newton correction at an ``s`` with ``F(s) > 0`` is below two ulps of ``s``
        (converged: without this test the iteration met round-off in ``F`` near the
        root, refused the Newton steps and bisected ~50 times down to ulps).
    """
    if F == 0.0:
        return s, lo, hi, dx, dxold, True
    if F < 0.0:
        lo = s
    else:
        hi = s
    if hi - lo <= 4.0 * EPS * max(abs(hi), 1e-300):
        return hi, lo, hi, dx, dxold, True
    if dF != 0.0:
        step = F / dF
        sn = s - step
        tol = 2.0 * EPS * abs(s)
        if abs(step) <= tol and lo < sn + tol and sn - tol < hi:
            # converged to round-off: the Newton correction is below two ulps of s.  On the side
            # F > 0, s is the answer; on the side F < 0 the crossing lies within round-off above
            # s: the next iterate is at least the next float above s, so that F >= 0 is met (then
            # the bracket is ulps wide) or lo moves up by an ulp at a time
            if F > 0.0:
                return s, lo, hi, dx, dxold, True
            sn = max(sn, np.nextafter(s, np.inf))
            if sn >= hi:
                return hi, lo, hi, dx, dxold, True
            return sn, lo, hi, step, dx, False
        if lo < sn < hi and abs(2.0 * F) <= abs(dxold * dF):
            return sn, lo, hi, sn - s, dx, False
    dxold = dx
    dx = 0.5 * (hi - lo)
    return lo + dx, lo, hi, dx, dxold, False
