"""The closed-form flow of the linear modal system shared by every fidelity (issue 20).

Between contacts each modal coordinate of vibeam's models obeys ``x'' + c x' + k x = G F
sin(Omega t)`` (paper Eq. 28 for the SDOF, Eqs. 39-42 for the modal FE beam).  This module holds
the one implementation of its closed-form flow: :func:`mode_table` and :func:`particular`, the
numba kernels :func:`transition_increment` (``Phi - I``, for the event kernels),
:func:`transition_entries` (``Phi`` to relative precision, for the shooting problems) and
:func:`advance_modes`, and the eigen-solver :func:`lowest_modes` of the modal reduction.  It
imports nothing of vibeam.

References
----------
.. [1] Paper: Reboucas, Santos & Thomsen, JSV 2019, Eqs. 28, 39-47.
.. [2] L. Meirovitch, *Fundamentals of Vibrations*, McGraw-Hill 2001.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from numba import njit

TWO_PI = 2.0 * math.pi

__all__ = ["lowest_modes", "mode_table", "particular", "transition_increment", "transition_entries",
           "advance_modes"]


def lowest_modes(K, M, n=None, eigvals_only=False):
    """Lowest ``n`` (all if ``None``) eigenpairs of ``K v = lam M v``, ascending, M-normalised.

    Up to half of the spectrum the inverse problem ``M v = mu K v`` (``mu = 1 / lam``) is solved:
    the fundamental, dominant there, is then accurate to round-off instead of ``eps lam_max /
    lam_1`` (poorly scaled for fine meshes and ``m >> rhoA L``).  For larger ``n`` the direct
    problem, whose complete basis is M-orthonormal to round-off (the inverse problem's highest
    modes, tiny ``mu``, are not).  The two agree to ``~eps lam_max / lam_1`` relative.

    Parameters
    ----------
    K, M : ndarray, shape (d, d)
        Symmetric stiffness and mass matrices, ``M`` positive definite (and ``K`` too when
        ``n <= d / 2``: the inverse problem factorises it).
    n : int or None
        Number of modes (clipped to ``d``).
    eigvals_only : bool
        Return the eigenvalues only.

    Returns
    -------
    lam : ndarray, shape (k,)
        ``omega^2`` (units of ``K / M``), ascending, ``>= 0``.
    V : ndarray, shape (d, k)
        ``V^T M V = I`` (not returned with ``eigvals_only``).

    Raises
    ------
    numpy.linalg.LinAlgError
        From :func:`scipy.linalg.eigh` when a matrix it factorises is not positive definite.
    """
    N = K.shape[0]
    k = N if n is None else min(int(n), N)
    if k > N // 2:
        res = scipy.linalg.eigh(K, M, subset_by_index=[0, k - 1], eigvals_only=eigvals_only)
        lam = np.clip(res if eigvals_only else res[0], 0.0, None)
        return lam if eigvals_only else (lam, res[1])
    res = scipy.linalg.eigh(M, K, subset_by_index=[N - k, N - 1], eigvals_only=eigvals_only)
    mu = res if eigvals_only else res[0]
    lam = 1.0 / mu[::-1]
    if eigvals_only:
        return lam
    V = res[1][:, ::-1]
    V = V / np.sqrt(np.einsum("ij,ij->j", V, M @ V))
    return lam, V


# ============================================================================ mode algebra
def mode_table(c, k):
    """Per-mode flow parameters ``[sig, k, typ, q, l1, l2]`` for ``x'' + c x' + k x = 0``.

    ``sig = c/2``; ``typ`` 0 underdamped (``q = omega_D``), 1 critical, 2 overdamped
    (``q = mu = sqrt(sig^2 - k)``, roots ``l1 = -k/(sig+mu)`` (slow), ``l2 = -(sig+mu)``).

    Parameters
    ----------
    c, k : array_like, shape (n,)
        Damping coefficients ``2 zeta omega`` and stiffnesses ``omega^2`` (nondimensional).

    Returns
    -------
    ndarray, shape (n, 6)
        The table the kernels :func:`transition_increment`, :func:`transition_entries` and
        :func:`advance_modes` read.
    """
    c = np.asarray(c, dtype=float)
    k = np.asarray(k, dtype=float)
    out = np.zeros((c.size, 6))
    for i in range(c.size):
        sig = 0.5 * c[i]
        d = sig * sig - k[i]
        out[i, 0], out[i, 1] = sig, k[i]
        if d < 0:
            out[i, 2], out[i, 3] = 0, math.sqrt(-d)
        elif d == 0:
            out[i, 2], out[i, 3] = 1, 0.0
            out[i, 4] = out[i, 5] = -sig
        else:
            mu = math.sqrt(d)
            out[i, 2], out[i, 3] = 2, mu
            out[i, 4], out[i, 5] = -k[i] / (sig + mu), -(sig + mu)
    return out


def particular(c, k, G, F, Omega):
    """Steady response ``a sin + b cos`` of ``x'' + c x' + k x = G F sin(Omega t)``.

    Parameters
    ----------
    c, k, G : array_like, shape (n,)
        Damping coefficients, stiffnesses, participation factors.
    F : float
        Forcing amplitude (``Omega^2 B`` for base excitation).
    Omega : float
        Forcing frequency.

    Returns
    -------
    a, b : ndarray, shape (n,)
        Non-finite for a mode at undamped exact resonance (``k = Omega^2``, ``c = 0``), which
        has no periodic particular solution (callers refuse it).
    """
    z = G * F / (k - Omega**2 + 1j * c * Omega)   # response to G F e^{i Omega t}
    return z.real, z.imag  # Im(z e^{i phi}) = Re z sin + Im z cos


@njit(cache=True)
def transition_increment(s, sig, k, typ, q, l1, l2):
    """``Phi(s) - I`` of ``x'' + 2 sig x' + k x = 0`` (entries 11, 12, 21, 22).

    Formed without cancellation for short ``s`` (``e^{-sig s} cos - 1`` as ``expm1(-sig s) cos -
    2 sin^2(q s / 2)``), which the event kernels need for chatter; ``(sig, k, typ, q, l1, l2)`` is
    a row of :func:`mode_table`.  The decayed entries lose relative precision once 1 is added back:
    :func:`transition_entries` gives ``Phi`` itself.
    """
    if typ == 0:
        E = math.exp(-sig * s)
        c = math.cos(q * s)
        hs = math.sin(0.5 * q * s)
        cm1 = math.expm1(-sig * s) * c - 2.0 * hs * hs
        S = E * math.sin(q * s) / q
    elif typ == 2:
        cm1 = 0.5 * (math.expm1(l1 * s) + math.expm1(l2 * s))
        S = -math.exp(l1 * s) * math.expm1(-2.0 * q * s) / (2.0 * q)
    else:
        E = math.exp(-sig * s)
        cm1 = math.expm1(-sig * s)
        S = s * E
    return cm1 + sig * S, S, -k * S, cm1 - sig * S


@njit(cache=True)
def transition_entries(s, sig, k, typ, q, l1, l2):
    """Transition matrix ``Phi(s)`` (11, 12, 21, 22) of ``x'' + 2 sig x' + k x = 0``, entries
    to relative precision (:func:`transition_increment` returns ``Phi - I`` for the flow,
    whose decayed entries lose their relative precision when 1 is added back).

    ``Phi = e^{-sig s} C I + e^{-sig s} S (A + sig I)`` with ``C = cos(q s)``, ``S = sin(q s) /
    q`` (underdamped; ``cosh``, ``sinh`` overdamped, ``1``, ``s`` critical); overdamped:
    ``(e^{l1 s} +- e^{l2 s}) / 2`` combinations.  Valid for either sign of ``s``.
    """
    if typ == 0:
        E = math.exp(-sig * s)
        Ec = E * math.cos(q * s)
        Es = E * math.sin(q * s) / q
        return Ec + sig * Es, Es, -k * Es, Ec - sig * Es
    if typ == 2:
        e1 = math.exp(l1 * s)
        e2 = math.exp(l2 * s)
        Es = -e1 * math.expm1(-2.0 * q * s) / (2.0 * q)
        # l1 = -k / (sig + q) (slow), l2 = -(sig + q): no cancellation in the diagonal
        return (-l2 * e1 + l1 * e2) / (2.0 * q), Es, -k * Es, (l1 * e1 - l2 * e2) / (2.0 * q)
    E = math.exp(-sig * s)
    return E * (1.0 + sig * s), s * E, -k * s * E, E * (1.0 - sig * s)


@njit(cache=True)
def advance_modes(s, phi0, Om, z, zd, mp, a, b, e):
    """Move modal coordinates ``z`` (with offsets ``e`` and harmonic particular ``a, b``)
    by ``s`` in closed form, in place.

    Each ``z_j = e_j + a_j sin(phi) + b_j cos(phi) + x_j`` with ``phi = phi0 + Om s`` and ``x_j``
    the homogeneous part moved by :func:`transition_increment`; the particular part's increment
    is formed without cancellation (``2 sin(Om s / 2) cos(phi0 + Om s / 2)``).

    Parameters
    ----------
    s : float
        Time step (nondimensional).
    phi0 : float
        Forcing phase at the start (rad).
    Om : float
        Forcing frequency.
    z, zd : ndarray, shape (n,)
        Coordinates and velocities, overwritten.
    mp : ndarray, shape (n, 6)
        :func:`mode_table` of the modes.
    a, b, e : ndarray, shape (n,)
        Particular coefficients (:func:`particular`) and constant offsets (a stop's static
        offset of the constrained modes; zeros in free flight).
    """
    half = 0.5 * Om * s
    sh = math.sin(half)
    ph = phi0 + half
    sph = math.sin(ph)
    cph = math.cos(ph)
    sp0 = math.sin(phi0)
    cp0 = math.cos(phi0)
    for j in range(z.shape[0]):
        x0 = z[j] - e[j] - (a[j] * sp0 + b[j] * cp0)
        y0 = zd[j] - Om * (a[j] * cp0 - b[j] * sp0)
        a11, a12, a21, a22 = transition_increment(s, mp[j, 0], mp[j, 1], int(mp[j, 2]), mp[j, 3],
                                                  mp[j, 4], mp[j, 5])
        z[j] += a11 * x0 + a12 * y0 + 2.0 * sh * (a[j] * cph - b[j] * sph)
        zd[j] += a21 * x0 + a22 * y0 - 2.0 * Om * sh * (a[j] * sph + b[j] * cph)
