"""Small compiled helpers of the continuation engine (:mod:`vibeam.models.orbits.continuation`):
the bordered Newton step, the tangent and the spectrum of the monodromy, called once or a few
times per continuation point (numba keeps their call cost at a microsecond or two, against
~5-10 microseconds for the same NumPy calls on 3x3 matrices)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _newton_step(M, xp, x_new, x, u, u_pred, t, sx, sp):
    """One bordered Newton step of the corrector in scaled variables.

    Returns ``(|r|_inf, du)`` with ``r = (P^n(x) - x) / s_x``; ``du`` solves
    ``[[M - I, x_p s_p / s_x], [t^T]] du = -[r, t . (u - u_pred)]`` (NaN if singular)."""
    d = x.shape[0]
    A = np.empty((d + 1, d + 1))
    rhs = np.empty(d + 1)
    nr = 0.0
    for i in range(d):
        ri = (x_new[i] - x[i]) / sx
        if abs(ri) > nr or ri != ri:
            nr = abs(ri)
        rhs[i] = -ri
        for j in range(d):
            A[i, j] = M[i, j]
        A[i, i] -= 1.0
        A[i, d] = xp[i] * (sp / sx)
    g = 0.0
    for j in range(d + 1):
        A[d, j] = t[j]
        g += t[j] * (u[j] - u_pred[j])
    rhs[d] = -g
    if not np.isfinite(A).all():
        return np.inf, np.full(d + 1, np.nan)
    return nr, np.linalg.solve(A, rhs)


@njit(cache=True)
def corrector_step(M, xp, x_new, x, u, u_pred, t, sx, sp):
    """:func:`_newton_step` and its update in one call: returns ``(|r|_inf, |du|_inf, u + du,
    |u + du - u_pred|_2)`` (``|du| = inf`` if the step is not finite)."""
    nr, du = _newton_step(M, xp, x_new, x, u, u_pred, t, sx, sp)
    un = u + du
    ndu = 0.0
    dist = 0.0
    for j in range(u.shape[0]):
        a = abs(du[j])
        if not a < np.inf:
            return nr, np.inf, un, np.inf
        if a > ndu:
            ndu = a
        e = un[j] - u_pred[j]
        dist += e * e
    return nr, ndu, un, np.sqrt(dist)


@njit(cache=True)
def bordered_tangent(M, xp, sx, sp, t_ref):
    """Unit null vector of ``[M - I, x_p s_p / s_x]`` oriented along ``t_ref`` (bordered solve)."""
    d = M.shape[0]
    A = np.empty((d + 1, d + 1))
    for i in range(d):
        for j in range(d):
            A[i, j] = M[i, j]
        A[i, i] -= 1.0
        A[i, d] = xp[i] * (sp / sx)
    for j in range(d + 1):
        A[d, j] = t_ref[j]
    rhs = np.zeros(d + 1)
    rhs[d] = 1.0
    t = np.linalg.solve(A, rhs)
    return t / np.sqrt(np.sum(t * t))


#: largest state dimension whose spectrum is computed in compiled code: numba's eigvals keeps
#: real input real, so the kernel works on a complex copy (LAPACK zgeev), which costs 5-10 times
#: NumPy's real dgeev on large matrices (92 x 92: 70-130 ms against 13 ms); small matrices gain
#: from the compiled call (a microsecond against ~10)
SMALL_SPECTRUM = 8


def floquet_spectrum(M):
    """Floquet multipliers by decreasing modulus (complex), ``det(M + I)`` and ``max |mu| - 1``
    over the complex ones (NaN if none); ``M`` of shape (d, d), C-contiguous float.

    Compiled for ``d <= SMALL_SPECTRUM``, NumPy (LAPACK dgeev on the real matrix) beyond."""
    d = M.shape[0]
    if d <= SMALL_SPECTRUM:
        return floquet_spectrum_small(M)
    mu = np.linalg.eigvals(M).astype(np.complex128)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    pd = float(np.linalg.det(M + np.eye(d)))
    a = np.abs(mu)
    cplx = np.abs(mu.imag) > 1e-9 * np.maximum(a, 1e-300)
    ns = float(np.max(a[cplx]) - 1.0) if cplx.any() else np.nan
    return mu, pd, ns


@njit(cache=True)
def _eig2(M):
    """Eigenvalues of a real 2 x 2 matrix, by decreasing modulus: ``h +- sqrt(h^2 - det)`` with
    ``h = tr / 2`` and the discriminant formed as ``((a - d) / 2)^2 + b c`` (no cancellation of
    ``h^2`` against ``det``); a real pair as ``l1 = h + sign(h) r``, ``l2 = det / l1`` (the
    stable quadratic formula, Press et al., Numerical Recipes, Sec. 5.6); a complex pair
    ``h +- i r``, the positive imaginary part first (LAPACK's order)."""
    a = M[0, 0]
    b = M[0, 1]
    c = M[1, 0]
    e = M[1, 1]
    h = 0.5 * (a + e)
    q = 0.5 * (a - e)
    disc = q * q + b * c
    mu = np.empty(2, np.complex128)
    if disc >= 0.0:
        r = np.sqrt(disc)
        l1 = h + r if h >= 0.0 else h - r
        l2 = (a * e - b * c) / l1 if l1 != 0.0 else 0.0
        mu[0] = l1
        mu[1] = l2
    else:
        r = np.sqrt(-disc)
        mu[0] = complex(h, r)
        mu[1] = complex(h, -r)
    return mu


@njit(cache=True)
def by_decreasing_modulus(mu):
    """Floquet multipliers by decreasing modulus, ties in their given order, NaN last.

    A stable insertion sort on ``-|mu|``: the order of ``mu[np.argsort(-np.abs(mu))]`` for fewer
    than 16 entries (numba's quicksort sorts those by the same insertion sort;
    :func:`floquet_spectrum_small` has ``d <= SMALL_SPECTRUM``), without compiling numba's
    quicksort (~2.5 s of a cold continuation).

    Parameters
    ----------
    mu : ndarray of complex, shape (d,)
        Multipliers (nondimensional).

    Returns
    -------
    ndarray of complex, shape (d,)
        A new array, ``mu`` reordered.
    """
    d = mu.shape[0]
    key = -np.abs(mu)
    order = np.arange(d)
    for i in range(1, d):
        k = order[i]
        v = key[k]
        j = i
        while j > 0 and (v < key[order[j - 1]] or (np.isnan(key[order[j - 1]]) and not np.isnan(v))):
            order[j] = order[j - 1]
            j -= 1
        order[j] = k
    out = np.empty(d, np.complex128)
    for i in range(d):
        out[i] = mu[order[i]]
    return out


@njit(cache=True)
def floquet_spectrum_small(M):
    """:func:`floquet_spectrum` in compiled code (small ``d``; ``d = 2`` in closed form,
    :func:`_eig2`, LAPACK's zgeev beyond)."""
    d = M.shape[0]
    if d == 2 and np.isfinite(M).all():
        mu = _eig2(M)
    else:
        mu = by_decreasing_modulus(np.linalg.eigvals(M.astype(np.complex128)))
    A = M.copy()
    for i in range(d):
        A[i, i] += 1.0
    pd = np.linalg.det(A)
    ns = np.nan
    for k in range(d):
        a = abs(mu[k])
        if abs(mu[k].imag) > 1e-9 * max(a, 1e-300):
            if ns != ns or a - 1.0 > ns:
                ns = a - 1.0
    return mu, pd, ns
