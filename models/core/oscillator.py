"""Closed-form flow of the base-excited linear oscillator between impacts.

Nondimensional equation of free flight (paper Eq. 1 and Eq. 43)::

    q'' + 2 beta q' + q = F sin(phi),    phi = Omega t + phi0,   F = Omega^2 B

Its solution is the steady-state particular response plus the decaying
homogeneous response (paper Eq. 28)::

    q(s) = x(s) + a sin(phi) + b cos(phi)
    [x, x'](s) = Phi(s) [x, x'](0)

with ``Phi(s)`` the state-transition matrix of the damped oscillator
(``omega_D = sqrt(1 - beta^2)``, underdamped, ``0 <= beta < 1``).  These
functions are the single implementation of that flow in vibeam: the exact
event-driven solver, the pointwise mapping and its Jacobians all use them.

All quantities are nondimensional (time scaled by the natural frequency,
displacement by the normalising length ``L``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def particular_coefficients(beta, F, Omega):
    """Coefficients ``(a, b)`` of the steady forced response ``a sin(phi) + b cos(phi)``.

    Parameters
    ----------
    beta : float
        Damping ratio (nondimensional).
    F : float
        Forcing amplitude ``Omega^2 B`` (nondimensional).
    Omega : float
        Forcing frequency over the natural frequency.

    Returns
    -------
    a, b : float
        From ``(1 - Omega^2) a - 2 beta Omega b = F`` and
        ``(1 - Omega^2) b + 2 beta Omega a = 0``.  Undamped exact resonance
        (``beta = 0, Omega = 1``) has no periodic particular solution; it then
        returns ``inf`` coefficients and callers reject it beforehand.
    """
    if F == 0.0:
        return 0.0, 0.0
    k = 1.0 - Omega * Omega
    c = 2.0 * beta * Omega
    D = k * k + c * c
    if D == 0.0:
        return np.inf, np.inf   # (numba's float division by zero would raise ZeroDivisionError)
    return F * k / D, -F * c / D


def undamped_resonance(beta: float, Omega: float) -> str:
    """Why the closed-form flow has no forced response at ``(beta, Omega)``, or ''.

    The particular solution ``a sin(phi) + b cos(phi)`` (:func:`particular_coefficients`)
    divides by ``(1 - Omega^2)^2 + (2 beta Omega)^2``, which is zero in double precision only at
    exact undamped resonance, ``beta = 0`` and ``Omega = 1``: the forced linear flow there is
    the secular ``t cos t`` that grows without bound, which the closed-form solvers (``event``,
    ``mapping``, the shooting problems) do not compute.  Case validation refuses such a scene
    (:mod:`vibeam.case.schema`); a model built directly fails its points with this reason.
    """
    k = 1.0 - float(Omega) ** 2
    c = 2.0 * float(beta) * float(Omega)
    if k * k + c * c == 0.0:
        return (f"undamped exact resonance (beta = {beta:g}, Omega = {Omega:g}): the forced flow grows as "
                f"t cos t and has no periodic particular solution; give beta > 0 or another Omega")
    return ""


@njit(cache=True)
def transition(s, beta):
    """``Phi(s) - I`` of the homogeneous oscillator, computed without cancellation.

    Parameters
    ----------
    s : float
        Elapsed nondimensional time, ``s >= 0``.
    beta : float
        Damping ratio, ``0 <= beta < 1``.

    Returns
    -------
    p11, p12, p21, p22 : float
        Entries of ``Phi(s) - I`` for the state ``(x, x')``.  ``e^{-beta s} cos
        - 1`` is formed as ``expm1(-beta s) cos - 2 sin^2(omega_D s / 2)`` so
        that short flights (chatter) keep full relative accuracy.
    """
    wd = math.sqrt(1.0 - beta * beta)
    E = math.exp(-beta * s)
    c = math.cos(wd * s)
    sn = math.sin(wd * s)
    hs = math.sin(0.5 * wd * s)
    em1c = math.expm1(-beta * s) * c - 2.0 * hs * hs
    es = E * sn / wd
    return em1c + beta * es, es, -es, em1c - beta * es


@njit(cache=True)
def propagate(s, phi0, q0, v0, beta, a, b, Omega, Delta):
    """Exact state at local time ``s`` after a start state, with derivatives.

    Parameters
    ----------
    s : float
        Local time since the start state (nondimensional, ``s >= 0``).
    phi0 : float
        Forcing phase at the start state (rad).
    q0, v0 : float
        Displacement and velocity at the start state.
    beta, a, b, Omega, Delta : float
        Damping ratio, particular-solution coefficients, forcing frequency, gap.

    Returns
    -------
    g, v, g2, g3, g4 : float
        ``g = q - Delta`` (formed as ``(q0 - Delta)`` plus an accurate
        increment), ``v = q'`` and the 2nd to 4th time derivatives of ``q``.
    """
    sp0 = math.sin(phi0)
    cp0 = math.cos(phi0)
    qp0 = a * sp0 + b * cp0
    dqp0 = Omega * (a * cp0 - b * sp0)
    x0 = q0 - qp0
    y0 = v0 - dqp0
    p11, p12, p21, p22 = transition(s, beta)
    dx = p11 * x0 + p12 * y0
    x = x0 + dx
    y = y0 + p21 * x0 + p22 * y0
    half = 0.5 * Omega * s
    sh = math.sin(half)
    ph = phi0 + half
    # qp(phi0 + Omega s) - qp(phi0), free of cancellation for short s
    dqp = 2.0 * sh * (a * math.cos(ph) - b * math.sin(ph))
    phi = phi0 + Omega * s
    sp = math.sin(phi)
    cp = math.cos(phi)
    qp = a * sp + b * cp
    dqp_dt = Omega * (a * cp - b * sp)
    g = (q0 - Delta) + dx + dqp
    v = y + dqp_dt
    x2 = -2.0 * beta * y - x
    x3 = -2.0 * beta * x2 - y
    x4 = -2.0 * beta * x3 - x2
    W2 = Omega * Omega
    g2 = x2 - W2 * qp
    g3 = x3 - W2 * dqp_dt
    g4 = x4 + W2 * W2 * qp
    return g, v, g2, g3, g4


def flow_matrix(s, beta):
    """State-transition matrix ``Phi(s)`` of ``x'' + 2 beta x' + x = 0`` (shape (2, 2)).

    Python convenience wrapper of :func:`transition` for the mapping method.
    """
    p11, p12, p21, p22 = transition(float(s), float(beta))
    return np.array([[1.0 + p11, p12], [p21, 1.0 + p22]])


@njit(cache=True)
def largest_gap(s, q0, v0, beta, a, b, Omega, Delta):
    """``max_i (q - Delta)`` of the free flight at the times ``s`` (shape (m,)) from each state
    ``(q0[k], v0[k])`` at forcing phase 0 (shapes (K,)): one value per state, shape (K,).

    The flow is affine in the initial state (paper Eq. 28), so each sample time's gap is
    ``c0_i + c1_i q0 + c2_i v0``: three flows per sample time, then O(K m) multiply-adds."""
    m = s.shape[0]
    c0 = np.empty(m)
    c1 = np.empty(m)
    c2 = np.empty(m)
    for i in range(m):
        g0 = propagate(s[i], 0.0, 0.0, 0.0, beta, a, b, Omega, Delta)[0]
        c0[i] = g0
        c1[i] = propagate(s[i], 0.0, 1.0, 0.0, beta, a, b, Omega, Delta)[0] - g0
        c2[i] = propagate(s[i], 0.0, 0.0, 1.0, beta, a, b, Omega, Delta)[0] - g0
    out = np.empty(q0.shape[0])
    for k in range(q0.shape[0]):
        g = -np.inf
        for i in range(m):
            gi = c0[i] + c1[i] * q0[k] + c2[i] * v0[k]
            if gi > g:
                g = gi
        out[k] = g
    return out


def linear_amplitude(beta: float, B: float, Omega):
    """Steady-state amplitude ``C = Omega^2 B / sqrt((1 - Omega^2)^2 + (2 beta Omega)^2)``.

    Nondimensional response of the oscillator without the stop (paper Eq. 28, the particular
    part).

    Parameters
    ----------
    beta : float
        Damping ratio.
    B : float
        Base-displacement amplitude (nondimensional).
    Omega : float or ndarray, shape (n,)
        Forcing frequency over the natural frequency.

    Returns
    -------
    ndarray, shape () or (n,)
        ``C`` at each ``Omega`` (nondimensional, in units of the normalising length).
    """
    Omega = np.asarray(Omega, dtype=float)
    return Omega**2 * B / np.sqrt((1 - Omega**2) ** 2 + (2 * beta * Omega) ** 2)
