"""The one event, chatter and sticking policy of every event-driven kernel (SDOF and beam).

What happens at a contact of an *impulsive* law (:mod:`vibeam.models.contact`), in order:

1. **Apply the law** to the relation's pre-impact normal velocity ``U-``:
   ``U+ = -R(U-) U-`` (:func:`vibeam.models.impact.restitution_coefficient`); the kernel applies
   the impulse along ``M^-1 n`` of the stop.
2. **Decide what follows** (:func:`impact_outcome`), from the rebound speed ``u = -U+``, whether
   the free contact acceleration presses the body onto the stop (``pressed``), and the
   chatter estimate below:

   * no rebound (``u <= 0``: ``R = 0``, or a grazing contact): **stick** if pressed, else fly on;
   * a Zeno burst (:func:`burst_limit` impacts in a row, each within ``BURST_DT`` forcing periods
     of the last, while pressed): **stick** and count a chatter.  With several modes the contact
     acceleration is not smooth on the scale of the flights, so the geometric estimate may never
     pass while impacts pile up; with one DOF, whose estimate becomes exact as ``u -> 0``, the
     guard acts only on an elastic impact, ``R = 1``, whose sequence never accumulates: a body
     released at rest a hair's breadth below the stop and pressed onto it bounces elastically
     with that height, ~1e10 impacts per forcing period for a height of 1e-20 of the orbit, and
     the guard holds it on the stop, an error of the order of the bounce height;
   * the chatter sequence accumulates within the current step with a small enough error
     (:func:`chatter_jump`): **chatter**, jump to the accumulation point and stick;
   * otherwise **rebound** (the next impact is resolved).
3. **Release** a body held on a stop when the normal contact force (positive pressing onto
   the stop) turns negative (:func:`release_now` at a step start; kernels locate the zero
   crossing inside a step exactly: closed form for the SDOF, a certified scan for the beam).

A two-sided scene applies the same rules at each stop with that stop's relation (its
normal) and law.  A *compliant* law does not come here: its contact is a phase with its own
flow, which ends where its contact force returns to zero (plan in :mod:`vibeam.models.contact`).

The chatter estimate
--------------------
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

#: outcomes of :func:`impact_outcome`
REBOUND, STICK, CHATTER, CHATTER_GUARD = 0, 1, 2, 3
#: the beam kernel's Zeno guard: impacts closer than BURST_DT forcing periods in a row,
#: BURST_MAX of them, end a chatter sequence (0 disables the guard)
BURST_DT = 1e-3
BURST_MAX = 200


@njit(cache=True, error_model="numpy", inline="always")
def release_now(force, dforce):
    """Does a body held on a stop leave it now?

    Parameters
    ----------
    force : float
        Normal contact force (per unit mass or effective mass; positive pressing the body
        onto the stop) needed to hold the body there.
    dforce : float
        Its time derivative.

    Returns
    -------
    bool
        ``force < 0``, or ``force == 0`` and falling.
    """
    return force < 0.0 or (force == 0.0 and dforce < 0.0)


@njit(cache=True, error_model="numpy", inline="always")
def zeno_burst(burst, t_imp, t_last, window):
    """Impacts in the current burst: ``burst + 1`` if this impact follows the last one within
    ``window``, else 0."""
    if t_imp - t_last < window:
        return burst + 1
    return 0


@njit(cache=True, error_model="numpy", inline="always")
def burst_limit(n_modes, R):
    """The Zeno guard's limit for an impact (module docstring, step 2).

    Parameters
    ----------
    n_modes : int
        Modes of the system (1: the SDOF or a one-mode beam).
    R : float
        Coefficient of restitution of the impact.

    Returns
    -------
    int
        :data:`BURST_MAX` with several modes (the geometric chatter estimate may never pass) or
        for an elastic impact, ``R >= 1`` (its sequence never accumulates, ``D`` infinite);
        0 otherwise (one DOF, ``R < 1``: the estimate, exact as ``u -> 0``, decides alone).
    """
    if n_modes > 1 or R >= 1.0:
        return BURST_MAX
    return 0


@njit(cache=True, error_model="numpy", inline="always")
def impact_outcome(u, pressed, acc, jerk, c_eff, k_eff, R, chatter_tol, horizon, burst, burst_max):
    """What follows an impulsive impact (module docstring, step 2).

    Parameters
    ----------
    u : float
        Rebound speed ``-U+`` (``> 0`` leaving the stop).
    pressed : bool
        The free contact force would press the body onto the stop (held, it would stay).
    acc : float
        Free contact acceleration towards the stop just after the impact (rebound included).
    jerk, c_eff, k_eff : float
        As :func:`chatter_jump`.
    R : float
        Coefficient of restitution of this impact.
    chatter_tol, horizon : float
        As :func:`chatter_jump`.
    burst, burst_max : int
        Impacts of the current burst (:func:`zeno_burst`) and the guard's limit
        (:func:`burst_limit`; 0: none).

    Returns
    -------
    action : int
        :data:`REBOUND`, :data:`STICK`, :data:`CHATTER` (jump to the accumulation point
        ``D`` ahead and stick) or :data:`CHATTER_GUARD` (stick now, a chatter cut by the guard).
    D : float
        Accumulation time of :data:`CHATTER` (0 otherwise).
    """
    if u <= 0.0:
        if pressed:
            return STICK, 0.0
        return REBOUND, 0.0
    if burst_max > 0 and burst >= burst_max and acc > 0.0:
        return CHATTER_GUARD, 0.0
    D = chatter_jump(u, acc, jerk, c_eff, k_eff, R, chatter_tol, horizon)
    if D >= 0.0:
        return CHATTER, D
    return REBOUND, 0.0


@njit(cache=True, error_model="numpy", inline="always")
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
