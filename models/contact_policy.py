"""The chatter policy shared by every event-driven kernel (SDOF and beam).

After an impact with a small rebound speed ``u`` into a contact acceleration
``a > 0`` that presses the body back onto the stop, the following impacts form
a sequence whose speeds fall like ``R^k u`` and whose flight times, under a
constant acceleration, are ``2 R^k u / a``; it accumulates after

    D = 2 u / (a (1 - R))

(Budd & Dux 1994; Nordmark & Piiroinen 2009, complete chatter).  A kernel may
jump to that accumulation point and stick instead of resolving the impacts one
by one once the constant-acceleration estimate is accurate enough.  Its
relative error is estimated by how much the acceleration changes over ``D``::

    err = D (|j| / a + c_eff + k_eff D)

with ``j`` the part of the time derivative of the contact acceleration that is
*not* the one-DOF flow part ``-c_eff a + k_eff u`` (the latter is covered by
the ``c_eff`` term and, since ``u / a = D (1 - R) / 2 <= D``, by the
``k_eff D`` term).  For one DOF (the SDOF oscillator, a one-mode beam) ``j`` is
exactly the forcing term ``d/dt (F sin Omega t) = F Omega cos Omega t``; for a
beam with several modes ``j`` is the forcing term plus the modal remainder
``sum_i w_i (-c_i a_i - k_i eta_i') + c_eff a - k_eff u`` (zero for one mode).
The estimate is invariant under a change of the time unit (``D``, ``1/c_eff``
and ``1/sqrt(k_eff)`` are times), so a one-mode beam whose time unit is not
``1/omega_n`` takes the same decisions as the SDOF kernel of its parameters.

The kernel advances its clock to the accumulation point only when it lies
within the current time step (``horizon``, the time left to the step's end, a
fixed point of the phase grid); beyond it the impacts are resolved one by one
until the next step, whose full length then contains the rest of the sequence.
"""
from __future__ import annotations

from numba import njit


@njit(cache=True)
def chatter_jump(u, a, jerk, c_eff, k_eff, R, chatter_tol, horizon):
    """Accumulation time of a chatter sequence, or -1 to resolve the next impact.

    Parameters
    ----------
    u : float
        Rebound speed just after the impact, ``> 0`` (away from the stop).
    a : float
        Free contact acceleration towards the stop just after the impact (the
        rebound velocity included); the sequence can accumulate only if ``a > 0``.
    jerk : float
        Time derivative of ``a`` beyond its one-DOF flow part (module docstring):
        the forcing term, plus the modal remainder for several modes.
    c_eff : float
        Damping rate of the contact coordinate (``2 beta`` for the SDOF,
        ``m_eff sum_i w_i^2 c_i`` for a beam).
    k_eff : float
        Stiffness per unit mass of the contact coordinate (``1`` for the
        nondimensional SDOF, ``m_eff sum_i w_i^2 k_i`` for a beam).
    R : float
        Coefficient of restitution of this impact (``0 <= R <= 1``).
    chatter_tol : float
        Largest accepted relative error of the estimate.
    horizon : float
        Time left in the kernel's current step; only an accumulation point
        strictly inside it is jumped to.

    Returns
    -------
    float
        ``D = 2 u / (a (1 - R))`` (same time unit as the inputs) when the kernel
        should jump to the accumulation point and stick, otherwise ``-1.0``.
    """
    if not (u > 0.0 and a > 0.0 and R < 1.0):
        return -1.0
    D = 2.0 * u / (a * (1.0 - R))
    err = D * (abs(jerk) / a + c_eff + k_eff * D)
    if err < chatter_tol and D < horizon:
        return D
    return -1.0
