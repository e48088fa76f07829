"""Exact event-driven solver of the SDOF oscillator on a Kelvin-Voigt (piecewise-linear) stop.

Model (nondimensional, paper Eq. 1 with a compliant stop; :mod:`vibeam.models.compliant`)::

    free     q'' + 2 beta q' + q = F sin(phi)                      (delta = q - Delta < 0)
    contact  q'' + 2 beta q' + q + k_c delta + c_c delta' = F sin(phi)

``phi = Omega t``, ``F = Omega^2 B``.  Both phases are linear oscillators
``q'' + 2 b_p w_p q' + w_p^2 (q - q_e) = F sin(phi)``: free ``w_p = 1``, ``b_p = beta``,
``q_e = 0``; in contact ``w_p = sqrt(1 + k_c)``, ``b_p = (2 beta + c_c) / (2 w_p)`` and the
shifted equilibrium ``q_e = k_c Delta / (1 + k_c)``.  Each phase flows in closed form (paper
Eq. 28 in the phase's own time ``w_p t``, :func:`vibeam.models.sdof_flow.transition`; the
particular solution is the same function of the forcing phase in both).

Events (the contact relation's gap ``delta = q - Delta`` and the law's force
``f = k_c delta + c_c delta'``, per unit mass)
    entry  ``delta`` crosses 0 upwards (or, just after an exit while ``delta > 0``, ``f``
           crosses 0 upwards: the massless stop cannot pull, so contact is defined by
           ``delta >= 0`` and ``f > 0``);
    exit   ``f`` crosses 0 downwards (the force-zero separation; ``delta_e >= 0`` remains).
Every event function is ``c0 delta + c1 delta' + c2 delta''`` and is located by the
certified scan of :mod:`vibeam.models.core.signals` applied to it: on each interval the sign
of its second derivative is certified from exact bounds on its 3rd and 4th derivatives
(envelope of the homogeneous part times ``w_p^n`` plus the forced amplitude times
``Omega^n``), an uncertified interval is halved, and the crossing is refined by safeguarded
Newton (``rtsafe``) on a sign-changing bracket.  No crossing, however brief, is stepped over.
The same scan finds the exact minima and maxima of ``q``, the peak force and the largest
penetration.  The energy the body gives the stop, ``int f delta' dt`` over the contact, is
integrated by 8-point Gauss-Legendre on each step of the contact (exact flow at the nodes;
steps of at most 1/16 of the contact's natural period: relative error ~1e-15).

Two stops (:func:`compliant_kernel_stops`): the lower stop at ``q = -Delta_l`` is handled
in the mirrored frame ``q~ = -q``, ``phi~ = phi + pi`` (the equation is odd in ``(q, sin
phi)``), where it is an upper stop with its own law; a free step ends at the earlier of the
two stops' entries.

Not handled: overdamped phases (``b_p >= 1``; a target R above ``e^-2`` and moderate
``beta`` keep the contact underdamped), ``R(v)`` tables.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contact import DAMPING, EXPONENT, LAW, LAW_HYSTERETIC_HERTZ, LAW_RESTITUTION, OFFSET, R, STIFFNESS
from .contact_policy import REBOUND, impact_outcome
from .dormand_prince import DP_A, DP_C, DP_E
from .roots import rtsafe_update
from .core.signals import certify_curvature
from .sdof_flow import particular_coefficients, transition
from .trajectory import call_budget

TWO_PI = 2.0 * math.pi
FREE, CONTACT = 0, 1
#: :func:`upcross` could not advance (a step below the time's resolution, or non-finite bounds)
STALL = -2.0
#: most intervals of one :func:`upcross` scan (a usual scan takes a few; one whose bounds certify
#: nothing steps at ``h_min`` = 1e-13 of the phase's natural period and would take ~1e12)
MAX_SCAN = 100_000
EV_NONE, EV_ENTRY, EV_EXIT, EV_GAPDOWN = 0, 1, 2, 3
STATUS_OK, STATUS_CHATTER, STATUS_FAILED = 0, 1, 3
#: accepted relative error of the chatter estimate at a restitution stop beside a compliant one
#: (:func:`vibeam.models.contact_policy.chatter_jump`; the default of :class:`vibeam.models.sdof.EventSolver`)
CHATTER_TOL = 1e-7
STATUS_NAMES = ("ok", "chatter", "sticking", "failed")
#: columns of the per-contact record: duration, peak force, largest penetration, energy lost,
#: entry velocity (all per unit effective mass, nondimensional)
C_DURATION, C_FORCE, C_PENETRATION, C_ENERGY, C_VELOCITY = range(5)
NCON = 5

# Gauss-Legendre, 8 nodes on [0, 1]
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
GL_X = 0.5 * (_GL_X + 1.0)
GL_W = 0.5 * _GL_W


@njit(cache=True)
def phase_eval(s, phi0, q0, v0, pp, Omega, Delta, d):
    """Exact state of a phase at local time ``s`` and the derivatives of ``delta``.

    Parameters
    ----------
    s : float
        Time since the start state (nondimensional, ``>= 0``).
    phi0, q0, v0 : float
        Forcing phase, displacement and velocity at the start state.
    pp : ndarray, shape (6,)
        Phase parameters ``(w_p, b_p, q_e, a, b, C)``: natural frequency, damping ratio,
        equilibrium, particular coefficients (``q_p = a sin phi + b cos phi`` about ``q_e``)
        and ``C = sqrt(a^2 + b^2)``.
    Omega, Delta : float
        Forcing frequency and stop position.
    d : ndarray, shape (6,)
        Receives ``delta = q - Delta`` (formed as ``q0 - Delta`` plus a cancellation-free
        increment) and its time derivatives of order 1 to 5.
    """
    wp = pp[0]
    bp = pp[1]
    qe = pp[2]
    a = pp[3]
    b = pp[4]
    sp0 = math.sin(phi0)
    cp0 = math.cos(phi0)
    yp0 = a * sp0 + b * cp0
    dyp0 = Omega * (a * cp0 - b * sp0)
    x0 = q0 - qe - yp0
    xt0 = (v0 - dyp0) / wp
    p11, p12, p21, p22 = transition(wp * s, bp)
    dx = p11 * x0 + p12 * xt0
    x = x0 + dx
    xt = xt0 + p21 * x0 + p22 * xt0
    half = 0.5 * Omega * s
    dyp = 2.0 * math.sin(half) * (a * math.cos(phi0 + half) - b * math.sin(phi0 + half))
    phi = phi0 + Omega * s
    sp = math.sin(phi)
    cp = math.cos(phi)
    yp = a * sp + b * cp
    yp1 = Omega * (a * cp - b * sp)
    W2 = Omega * Omega
    x2 = -2.0 * bp * xt - x
    x3 = -2.0 * bp * x2 - xt
    x4 = -2.0 * bp * x3 - x2
    x5 = -2.0 * bp * x4 - x3
    w2 = wp * wp
    d[0] = (q0 - Delta) + dx + dyp
    d[1] = wp * xt + yp1
    d[2] = w2 * x2 - W2 * yp
    d[3] = w2 * wp * x3 - W2 * yp1
    d[4] = w2 * w2 * x4 + W2 * W2 * yp
    d[5] = w2 * w2 * wp * x5 + W2 * W2 * yp1


@njit(cache=True)
def envelope(phi0, q0, v0, pp, Omega):
    """``A`` with ``|x^(n)(t)| <= A w_p^n`` for the homogeneous part of a phase (all n)."""
    wp = pp[0]
    bp = pp[1]
    a = pp[3]
    b = pp[4]
    sp0 = math.sin(phi0)
    cp0 = math.cos(phi0)
    x0 = q0 - pp[2] - (a * sp0 + b * cp0)
    xt0 = (v0 - Omega * (a * cp0 - b * sp0)) / wp
    wd = math.sqrt(1.0 - bp * bp)
    w = (xt0 + bp * x0) / wd
    return math.sqrt(x0 * x0 + w * w)


@njit(cache=True)
def _fd(d, c0, c1, c2, n):
    """n-th time derivative of ``f = c0 delta + c1 delta' + c2 delta''`` from ``d``."""
    return c0 * d[n] + c1 * d[n + 1] + c2 * d[n + 2]


@njit(cache=True)
def _bound(c0, c1, c2, n, A, pp, Omega):
    """Bound of ``|f^(n)|`` over a phase step (homogeneous envelope + forced amplitude)."""
    wp = pp[0]
    C = pp[5]
    return ((abs(c0) * (A * wp ** n + C * Omega ** n) + abs(c1) * (A * wp ** (n + 1) + C * Omega ** (n + 1))
             + abs(c2) * (A * wp ** (n + 2) + C * Omega ** (n + 2))) * (1.0 + 1e-9) + 1e-300)


@njit(cache=True)
def _root(c0, c1, c2, coff, order, sgn, lo, hi, phi, q, v, pp, Omega, Delta, d):
    """Root of ``F = sgn f^(order)`` (``f = c0 delta + c1 delta' + c2 delta'' + coff``) on
    ``[lo, hi]`` with ``F(lo) < 0 <= F(hi)`` (rtsafe); returns the end of the final bracket
    with ``F >= 0``."""
    off = coff if order == 0 else 0.0
    dxold = hi - lo
    dx = dxold
    s = 0.5 * (lo + hi)
    for _ in range(200):
        phase_eval(s, phi, q, v, pp, Omega, Delta, d)
        F = sgn * (_fd(d, c0, c1, c2, order) + off)
        dF = sgn * _fd(d, c0, c1, c2, order + 1)
        s, lo, hi, dx, dxold, done = rtsafe_update(F, dF, s, lo, hi, dx, dxold)
        if done:
            return s
    return hi


@njit(cache=True)
def upcross(c0, c1, c2, lo, hi, phi, q, v, pp, Omega, Delta, A, d, coff=0.0):
    """First time in ``(lo, hi]`` where ``f = c0 delta + c1 delta' + c2 delta'' + coff`` crosses
    from ``< 0`` to ``>= 0`` along the phase from ``(phi, q, v)``; ``-1`` if none; :data:`STALL`
    (-2) if the scan cannot advance: a step below the resolution of the time in double
    precision, bounds that are not finite (e.g. a stop so stiff that ``k_c w_p^5`` overflows),
    or more than :data:`MAX_SCAN` intervals -- the caller fails instead of looping for ever.

    Certified (module docstring): on each interval the sign of ``f''`` is certified or the
    interval halved; with ``f''`` of one sign ``f`` has at most one interior extremum, which
    is located when it could hide a crossing.
    """
    M2 = _bound(c0, c1, c2, 2, A, pp, Omega)
    M3 = _bound(c0, c1, c2, 3, A, pp, Omega)
    M4 = _bound(c0, c1, c2, 4, A, pp, Omega)
    if not (M2 < np.inf and M3 < np.inf and M4 < np.inf):
        return STALL    # the bounds overflow: nothing can be certified
    tol = 1e-13 * M2
    h_min = 1e-13 * (TWO_PI / pp[0])
    s = lo
    phase_eval(s, phi, q, v, pp, Omega, Delta, d)
    f0 = _fd(d, c0, c1, c2, 0) + coff
    f10 = _fd(d, c0, c1, c2, 1)
    f20 = _fd(d, c0, c1, c2, 2)
    f30 = _fd(d, c0, c1, c2, 3)
    n_scan = 0
    while s < hi:
        n_scan += 1
        if n_scan > MAX_SCAN:
            return STALL
        h = hi - s
        cert = 0
        f1 = f11 = f21 = f31 = 0.0
        while True:
            phase_eval(s + h, phi, q, v, pp, Omega, Delta, d)
            f1 = _fd(d, c0, c1, c2, 0) + coff
            f11 = _fd(d, c0, c1, c2, 1)
            f21 = _fd(d, c0, c1, c2, 2)
            f31 = _fd(d, c0, c1, c2, 3)
            e2 = 0.125 * M2 * h * h
            if min(f0, f1) - e2 > 0.0 or max(f0, f1) + e2 < 0.0:
                cert = 2
                break
            cert = certify_curvature(f20, f30, f21, f31, M3, M4, h, tol)
            if cert != 0 or h < h_min or not h > 0.0:
                break
            h *= 0.5
        e = s + h
        if not e > s:
            return STALL    # time cannot advance in double precision (or not a number)
        if f0 < 0.0 and f1 >= 0.0:
            return _root(c0, c1, c2, coff, 0, 1.0, s, e, phi, q, v, pp, Omega, Delta, d)
        if cert == 1 or cert == 0:
            if f0 >= 0.0 and f1 >= 0.0 and f10 < 0.0 < f11:
                sm = _root(c0, c1, c2, coff, 1, 1.0, s, e, phi, q, v, pp, Omega, Delta, d)
                phase_eval(sm, phi, q, v, pp, Omega, Delta, d)
                if _fd(d, c0, c1, c2, 0) + coff < 0.0:
                    return _root(c0, c1, c2, coff, 0, 1.0, sm, e, phi, q, v, pp, Omega, Delta, d)
        if cert == -1 or cert == 0:
            if f0 < 0.0 and f1 < 0.0 and f10 > 0.0 > f11:
                sa = _root(c0, c1, c2, coff, 1, -1.0, s, e, phi, q, v, pp, Omega, Delta, d)
                phase_eval(sa, phi, q, v, pp, Omega, Delta, d)
                if _fd(d, c0, c1, c2, 0) + coff >= 0.0:
                    return _root(c0, c1, c2, coff, 0, 1.0, s, sa, phi, q, v, pp, Omega, Delta, d)
        s = e
        f0 = f1
        f10 = f11
        f20 = f21
        f30 = f31
    return -1.0


@njit(cache=True)
def phase_params(beta, F, Omega, Delta, kc, cc):
    """``(2, 6)`` parameters of the free phase (row 0) and the contact phase (row 1)."""
    P = np.empty((2, 6))
    P[0, 0] = 1.0
    P[0, 1] = beta
    P[0, 2] = 0.0
    wc = math.sqrt(1.0 + kc)
    P[1, 0] = wc
    P[1, 1] = (2.0 * beta + cc) / (2.0 * wc)
    P[1, 2] = kc * Delta / (1.0 + kc)
    for r in range(2):
        a, b = particular_coefficients(P[r, 1], F / P[r, 0] ** 2, Omega / P[r, 0])
        P[r, 3] = a
        P[r, 4] = b
        P[r, 5] = math.sqrt(a * a + b * b)
    return P


@njit(cache=True)
def advance(phase, h, phi, q, v, pp, kc, cc, Omega, Delta, rec, ex, cs, d, r0, r1, roff):
    """One step of at most ``h`` in ``phase`` from ``(phi, q, v)``: the event it ends with.

    Parameters
    ----------
    phase : int
        :data:`FREE` or :data:`CONTACT`.
    pp : ndarray, shape (6,)
        The phase's parameters (:func:`phase_params`).
    kc, cc : float
        Stiffness and damping of the stop (per unit mass; the contact phase of the linear law).
    r0, r1, roff : float
        The sign of the contact force while ``delta > 0`` in free flight (just after an exit)
        is that of ``r0 delta + r1 delta' + roff``: linear ``(k_c, c_c, 0)``; Hunt-Crossley
        ``(0, 1, v_in / chi)`` (the factor ``1 + chi delta' / v_in``).
    rec : bool
        Update the extremes ``ex = [q_min, q_max, q_min of this period]`` (shape (3,)).
    cs : ndarray, shape (4,)
        Running record of the current contact ``[t_entry, peak force, largest delta,
        energy]``; updated in contact.
    d : ndarray, shape (6,)
        Work array.

    Returns
    -------
    s, event : float, int
        Length of the step taken and :data:`EV_ENTRY`, :data:`EV_EXIT`,
        :data:`EV_GAPDOWN` (free, ``delta`` back to 0 from above after an exit) or
        :data:`EV_NONE` (``s = h``).
    """
    A = envelope(phi, q, v, pp, Omega)
    ev = EV_NONE
    s_adv = h
    if phase == FREE:
        phase_eval(0.0, phi, q, v, pp, Omega, Delta, d)
        if d[0] >= 0.0:
            # at or inside the stop: contact now if the force would be positive just after.
            # On the stop (delta = 0): the first non-zero of delta', ..., delta'''' positive
            # (e.g. at rest on the stop at Delta = 0: delta''' = F Omega > 0); inside it (just
            # after an exit): the first non-zero derivative of the force's sign function.
            # Values within round-off of their bound count as zero.
            for n in range(4):
                if d[0] == 0.0:
                    f = d[n + 1]
                    tol = 1e-13 * _bound(1.0, 0.0, 0.0, n + 1, A, pp, Omega)
                else:
                    f = r0 * d[n] + r1 * d[n + 1] + (roff if n == 0 else 0.0)
                    tol = 1e-13 * (_bound(r0, r1, 0.0, n, A, pp, Omega) + (abs(roff) if n == 0 else 0.0))
                if f > tol:
                    return 0.0, EV_ENTRY
                if f < -tol:
                    break
        if d[0] >= 0.0:
            s_d = upcross(-1.0, 0.0, 0.0, 0.0, h, phi, q, v, pp, Omega, Delta, A, d)
            if s_d == STALL:
                return -1.0, EV_NONE
            lim = s_d if s_d >= 0.0 else h
            s_e = upcross(r0, r1, 0.0, 0.0, lim, phi, q, v, pp, Omega, Delta, A, d, roff)
            if s_e == STALL:
                return -1.0, EV_NONE
            if s_e >= 0.0:
                s_adv, ev = s_e, EV_ENTRY
            elif s_d >= 0.0:
                s_adv, ev = s_d, EV_GAPDOWN
        else:
            s_e = upcross(1.0, 0.0, 0.0, 0.0, h, phi, q, v, pp, Omega, Delta, A, d)
            if s_e == STALL:
                return -1.0, EV_NONE
            if s_e >= 0.0:
                s_adv, ev = s_e, EV_ENTRY
    else:
        s_x = upcross(-kc, -cc, 0.0, 0.0, h, phi, q, v, pp, Omega, Delta, A, d)
        if s_x == STALL:
            return -1.0, EV_NONE
        if s_x >= 0.0:
            s_adv, ev = s_x, EV_EXIT
        # peak force: entry value (cs[1] set at entry), interior maxima, step end
        s = 0.0
        while True:
            s = upcross(0.0, -kc, -cc, s, s_adv, phi, q, v, pp, Omega, Delta, A, d)
            if s == STALL:
                return -1.0, EV_NONE
            if s < 0.0:
                break
            phase_eval(s, phi, q, v, pp, Omega, Delta, d)
            f = kc * d[0] + cc * d[1]
            if f > cs[1]:
                cs[1] = f
        # largest penetration: interior maxima of delta, step end
        s = 0.0
        while True:
            s = upcross(0.0, -1.0, 0.0, s, s_adv, phi, q, v, pp, Omega, Delta, A, d)
            if s == STALL:
                return -1.0, EV_NONE
            if s < 0.0:
                break
            phase_eval(s, phi, q, v, pp, Omega, Delta, d)
            if d[0] > cs[2]:
                cs[2] = d[0]
            if rec and Delta + d[0] > ex[1]:
                ex[1] = Delta + d[0]
        # energy given to the stop, int f delta' dt (Gauss-Legendre on the step)
        acc = 0.0
        for i in range(GL_X.shape[0]):
            phase_eval(GL_X[i] * s_adv, phi, q, v, pp, Omega, Delta, d)
            acc += GL_W[i] * (kc * d[0] + cc * d[1]) * d[1]
        cs[3] += acc * s_adv
        phase_eval(s_adv, phi, q, v, pp, Omega, Delta, d)
        f = kc * d[0] + cc * d[1]
        if f > cs[1]:
            cs[1] = f
        if d[0] > cs[2]:
            cs[2] = d[0]
    if rec:
        # exact minima (and maxima of the free phase) of q inside the step
        s = 0.0
        while True:
            s = upcross(0.0, 1.0, 0.0, s, s_adv, phi, q, v, pp, Omega, Delta, A, d)
            if s == STALL:
                return -1.0, EV_NONE
            if s < 0.0:
                break
            phase_eval(s, phi, q, v, pp, Omega, Delta, d)
            qm = Delta + d[0]
            if qm < ex[0]:
                ex[0] = qm
            if qm < ex[2]:
                ex[2] = qm
        if phase == FREE:
            s = 0.0
            while True:
                s = upcross(0.0, -1.0, 0.0, s, s_adv, phi, q, v, pp, Omega, Delta, A, d)
                if s == STALL:
                    return -1.0, EV_NONE
                if s < 0.0:
                    break
                phase_eval(s, phi, q, v, pp, Omega, Delta, d)
                if Delta + d[0] > ex[1]:
                    ex[1] = Delta + d[0]
    return s_adv, ev


# ---------------------------------------------------------------- Hunt-Crossley contact phase
#: Hunt-Crossley contact phase: relative tolerance of the DOPRI5 steps, and the absolute ones
#: as fractions of the isolated contact's penetration and of the entry velocity
HC_RTOL = 1e-11
HC_ATOL = 1e-13
#: entry velocities below ``HC_V_FLOOR`` times the base velocity amplitude ``Omega B`` are floored
#: there (the damping chi / v_in of a contact entered at rest; vibeam.models.compliant)
HC_V_FLOOR = 1e-2


@njit(cache=True)
def hc_force(dl, v, kc, p, chi, vr):
    """Hunt-Crossley force ``k_c delta^p (1 + chi delta' / v_r)`` (0 for ``delta <= 0``)."""
    if dl <= 0.0:
        return 0.0
    return kc * dl ** p * (1.0 + chi * v / vr)


@njit(cache=True)
def _hc_rhs(s, y, phi0, beta, F, Omega, Delta, kc, p, chi, vr, ks, out):
    """``y = (delta, delta', E)``: the contact phase of the SDOF with a Hunt-Crossley stop
    (``ks``: the oscillator's stiffness, 1; 0 for the isolated contact)."""
    f = hc_force(y[0], y[1], kc, p, chi, vr)
    out[0] = y[1]
    out[1] = F * math.sin(phi0 + Omega * s) - 2.0 * beta * y[1] - ks * (Delta + y[0]) - f
    out[2] = f * y[1]


@njit(cache=True)
def _dp_step(hs, y0, phi0, beta, F, Omega, Delta, kc, p, chi, vr, ks, K, y1):
    """One DOPRI5 step of length ``hs`` from ``y0`` (s = 0); ``y1`` the 5th-order result,
    returns the error estimate vector's (delta, delta') components."""
    tmp = np.empty(3)
    for i in range(7):
        for c in range(3):
            acc = y0[c]
            for j in range(i):
                acc += hs * DP_A[i, j] * K[j, c]
            tmp[c] = acc
        _hc_rhs(DP_C[i] * hs, tmp, phi0, beta, F, Omega, Delta, kc, p, chi, vr, ks, K[i])
        if i == 6:
            break
    for c in range(3):
        acc = y0[c]
        for j in range(6):
            acc += hs * DP_A[6, j] * K[j, c]
        y1[c] = acc
    _hc_rhs(hs, y1, phi0, beta, F, Omega, Delta, kc, p, chi, vr, ks, K[6])
    e0 = 0.0
    e1 = 0.0
    for j in range(7):
        e0 += hs * DP_E[j] * K[j, 0]
        e1 += hs * DP_E[j] * K[j, 1]
    return e0, e1


@njit(cache=True)
def _hc_event(kind, y, s, phi0, beta, F, Omega, Delta, kc, p, chi, vr, ks):
    """Event functions of the contact phase: 0 exit by ``delta`` (``-delta``), 1 exit by the
    damping factor (``-(1 + chi delta' / v_r)``), 2 ``-delta'`` (largest penetration),
    3 ``delta'`` (a minimum of q), 4 ``-dF/dt`` (peak force); each rises through 0."""
    if kind == 0:
        return -y[0]
    if kind == 1:
        return -(1.0 + chi * y[1] / vr)
    if kind == 2:
        return -y[1]
    if kind == 3:
        return y[1]
    dl = y[0]
    if dl <= 0.0:
        return 0.0
    acc = F * math.sin(phi0 + Omega * s) - 2.0 * beta * y[1] - ks * (Delta + dl) - hc_force(dl, y[1], kc, p, chi, vr)
    g = kc * p * dl ** (p - 1.0) * y[1] * (1.0 + chi * y[1] / vr) + kc * dl ** p * chi * acc / vr
    return -g


@njit(cache=True)
def _hc_locate(kind, hs, y0, phi0, beta, F, Omega, Delta, kc, p, chi, vr, ks, K, y1):
    """Root in ``(0, hs]`` of an event rising through 0 (negative at 0, >= 0 at ``hs``), by
    bisection on single DOPRI5 steps from ``y0`` (each as accurate as the accepted step);
    returns the end with the event ``>= 0`` and leaves its state in ``y1``."""
    lo = 0.0
    hi = hs
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if not (lo < mid < hi):
            break
        _dp_step(mid, y0, phi0, beta, F, Omega, Delta, kc, p, chi, vr, ks, K, y1)
        if _hc_event(kind, y1, mid, phi0, beta, F, Omega, Delta, kc, p, chi, vr, ks) >= 0.0:
            hi = mid
        else:
            lo = mid
    _dp_step(hi, y0, phi0, beta, F, Omega, Delta, kc, p, chi, vr, ks, K, y1)
    return hi


@njit(cache=True)
def hc_advance(h, phi, q, v, beta, F, Omega, Delta, kc, p, chi, vr, ks, rk, rec, ex, cs, y1):
    """One accepted DOPRI5 step (at most ``h``) of a Hunt-Crossley contact from ``(phi, q, v)``.

    ``rk`` (shape (2,)): the step-size estimate and the error scale of the penetration;
    ``cs``, ``ex`` as :func:`advance`.  Returns ``(s, event)``: :data:`EV_EXIT` where the force
    returns to zero (``delta`` back to 0, or the damping factor ``1 + chi delta' / v_r`` to 0)
    or :data:`EV_NONE`; ``y1`` receives ``(delta, delta', E)`` at ``s``, ``s = -1``: the step
    size underflowed (failed).
    """
    K = np.empty((7, 3))
    y0 = np.empty(3)
    y0[0] = q - Delta
    y0[1] = v
    y0[2] = 0.0
    h_min = 1e-12 * rk[1] / vr
    while True:
        hs = min(rk[0], h)
        e0, e1 = _dp_step(hs, y0, phi, beta, F, Omega, Delta, kc, p, chi, vr, ks, K, y1)
        err = max(abs(e0) / (HC_ATOL * rk[1] + HC_RTOL * max(abs(y0[0]), abs(y1[0]))),
                  abs(e1) / (HC_ATOL * vr + HC_RTOL * max(abs(y0[1]), abs(y1[1]))))
        if err <= 1.0:
            break
        rk[0] = hs * max(0.1, 0.9 * err ** -0.2)
        if rk[0] < h_min or not rk[0] > 0.0:     # (0 or NaN: the scales are not computable)
            return -1.0, EV_NONE
    if hs == rk[0]:
        rk[0] = hs * min(5.0, 0.9 * err ** -0.2) if err > 0.0 else 5.0 * hs
    s_adv = hs
    ev = EV_NONE
    for kind in (0, 1):
        if _hc_event(kind, y1, hs, phi, beta, F, Omega, Delta, kc, p, chi, vr, ks) >= 0.0:
            s_k = _hc_locate(kind, hs, y0, phi, beta, F, Omega, Delta, kc, p, chi, vr, ks, K, y1)
            if s_k <= s_adv:
                s_adv = s_k
                ev = EV_EXIT
    if ev == EV_EXIT:
        # the step ends at the exit: the state there (y1 of the earlier root)
        _dp_step(s_adv, y0, phi, beta, F, Omega, Delta, kc, p, chi, vr, ks, K, y1)
    yt = np.empty(3)
    # largest penetration, peak force and minima of q inside the step (sign changes of their
    # event functions across it; located like the exit)
    for kind in (2, 4, 3):
        if kind == 3 and not rec:
            continue
        g0 = _hc_event(kind, y0, 0.0, phi, beta, F, Omega, Delta, kc, p, chi, vr, ks)
        g1 = _hc_event(kind, y1, s_adv, phi, beta, F, Omega, Delta, kc, p, chi, vr, ks)
        if g0 < 0.0 <= g1:
            _hc_locate(kind, s_adv, y0, phi, beta, F, Omega, Delta, kc, p, chi, vr, ks, K, yt)
            if kind == 2:
                if yt[0] > cs[2]:
                    cs[2] = yt[0]
                if rec and Delta + yt[0] > ex[1]:
                    ex[1] = Delta + yt[0]
            elif kind == 4:
                f = hc_force(yt[0], yt[1], kc, p, chi, vr)
                if f > cs[1]:
                    cs[1] = f
            elif Delta + yt[0] < ex[0] or Delta + yt[0] < ex[2]:
                ex[0] = min(ex[0], Delta + yt[0])
                ex[2] = min(ex[2], Delta + yt[0])
    _dp_step(s_adv, y0, phi, beta, F, Omega, Delta, kc, p, chi, vr, ks, K, y1)
    f = hc_force(y1[0], y1[1], kc, p, chi, vr)
    if f > cs[1]:
        cs[1] = f
    if y1[0] > cs[2]:
        cs[2] = y1[0]
    cs[3] += y1[2]
    return s_adv, ev


@njit(cache=True)
def compliant_kernel(beta, B, stops, Omega, q_init, v_init, phase_init, n_transient, n_record,
                     ns_transient, ns_record, max_contacts, samples, pmin, imp_t, imp_v, con, max_steps=-1):
    """Simulate whole forcing periods exactly with the one stop ``stops[0]``: the numba core of
    :class:`CompliantEventSolver` for one stop (:func:`compliant_kernel_stops` with
    ``stops[:1]``; same arguments and results, without the per-stop ones).

    Parameters
    ----------
    beta, B : float
        Damping ratio and base amplitude of the oscillator.
    stops : ndarray, shape (1, NPAR)
        The stop row (:func:`vibeam.models.contact.pack`) of a ``linear`` law:
        ``OFFSET`` = Delta, ``STIFFNESS`` = k_c, ``DAMPING`` = c_c.
    Omega : float
        Forcing frequency.
    q_init, v_init : float
        Start state at forcing phase 0; ``phase_init`` 0 free, 1 in contact.
    n_transient, n_record, ns_transient, ns_record : int
        Periods discarded / recorded, grid points per period in each.
    max_contacts : int
        More contacts than this over the run: ``failed``.
    max_steps : int
        More steps than this over the run (a contact phase far stiffer than the forcing
        resolves ~16 steps per contact period): ``failed`` (-1: no limit).
    samples : ndarray, shape (n_record * ns_record, 2)
        Receives ``(q, q')`` on the recorded phase grid.
    pmin : ndarray, shape (n_record,)
        Receives the exact minimum of ``q`` over each recorded period.
    imp_t, imp_v : ndarray, shape (cap,)
        Receive the entry times (from the start of the record) and entry velocities of the
        recorded contacts.
    con : ndarray, shape (cap, NCON)
        Receives one row per contact that begins in the record and ends before its end:
        duration, peak force, largest penetration, energy lost, entry velocity.

    Returns
    -------
    tuple
        ``(status, n_contacts_recorded, q_min, q_max, q_end, v_end, phase_end,
        n_contacts_total, contact_time)``; ``contact_time`` is the time in contact during
        the record.
    """
    imp_k = np.zeros(imp_t.shape[0], np.int64)
    out = compliant_kernel_stops(beta, B, stops[:1], Omega, q_init, v_init, phase_init, n_transient, n_record,
                                 ns_transient, ns_record, max_contacts, samples, pmin, imp_t, imp_v, con, imp_k,
                                 max_steps)
    return out[:9]


@njit(cache=True)
def mirror_in(ex, exm):
    """Extremes of the lower stop's mirrored frame ``q~ = -q``: ``exm = [-max q, -min q of
    this period, (unused)]`` (see :func:`compliant_kernel_stops`)."""
    exm[0] = -ex[1]
    exm[1] = -ex[2]
    exm[2] = np.inf


@njit(cache=True)
def mirror_out(ex, exm):
    """Extremes ``exm`` of the mirrored frame back into the extremes ``ex`` of ``q`` (the inverse
    of :func:`mirror_in`), in place."""
    ex[1] = max(ex[1], -exm[0])
    ex[2] = min(ex[2], -exm[1])
    ex[0] = min(ex[0], ex[2])


@njit(cache=True)
def compliant_kernel_stops(beta, B, stops, Omega, q_init, v_init, phase_init, n_transient, n_record,
                           ns_transient, ns_record, max_contacts, samples, pmin, imp_t, imp_v, con, imp_k,
                           max_steps=-1):
    """Simulate whole forcing periods exactly on one or two compliant stops; the numba core of
    :class:`CompliantEventSolver`.

    The lower stop (row 1, at ``q = -Delta_l``) is handled in the mirrored frame
    ``q~ = -q``, ``phi~ = phi + pi``, in which the oscillator's equation is unchanged (it is
    odd in ``(q, sin phi)``) and the lower stop is an upper one at ``q~ = Delta_l``: its
    entry, contact phase and exit are the one-stop steps (:func:`advance`,
    :func:`hc_advance`) with the lower stop's parameters, and the free step is the earlier
    of the two stops' certified entry scans.  With one stop the computation is the
    one-stop kernel's, operation for operation.

    Parameters
    ----------
    stops : ndarray, shape (n_stops, NPAR)
        ``n_stops`` 1 or 2 rows (:func:`vibeam.models.contact.pack`), each Kelvin-Voigt or
        hysteretic Hertz (its ``chi`` in the ``DAMPING`` column); row 1 the lower stop (``OFFSET`` = Delta_lower > -Delta).
    phase_init : int
        0 free, 1 in contact with the upper stop, 2 with the lower one.
    imp_k : ndarray of int64, shape (cap,)
        Receives the stop (0 upper, 1 lower) of each recorded contact; ``imp_v`` holds the
        normal entry velocities (``q'`` upper, ``-q'`` lower).
    (others)
        As :func:`compliant_kernel`.

    Returns
    -------
    tuple
        ``(status, n_rec, q_min, q_max, q_end, v_end, phase_end, n_contacts_total,
        contact_time, n_rec_lower, n_steps)``; ``phase_end`` 0, 1 or 2; ``n_steps`` the steps
        taken (above ``max_steps``: the step guard ended the call).
    """
    F = Omega * Omega * B
    nst = stops.shape[0]
    Delta = stops[0, OFFSET]
    kc = stops[0, STIFFNESS]
    cc = stops[0, DAMPING]
    hunt = int(stops[0, LAW]) == LAW_HYSTERETIC_HERTZ
    pexp = stops[0, EXPONENT]
    chi = cc if hunt else 0.0
    if hunt:
        cc = 0.0   # the contact phase is integrated (hc_advance); no linear contact phase
        P = phase_params(beta, F, Omega, Delta, 0.0, 0.0)
    else:
        P = phase_params(beta, F, Omega, Delta, kc, cc)
    # the lower stop (row 1), in the mirrored frame; a placeholder with one stop
    ls = 1 if nst > 1 else 0
    DeltaL = stops[ls, OFFSET]
    kcl = stops[ls, STIFFNESS]
    ccl = stops[ls, DAMPING]
    huntl = int(stops[ls, LAW]) == LAW_HYSTERETIC_HERTZ
    pexpl = stops[ls, EXPONENT]
    chil = ccl if huntl else 0.0
    if huntl:
        ccl = 0.0
        PL = phase_params(beta, F, Omega, DeltaL, 0.0, 0.0)
    else:
        PL = phase_params(beta, F, Omega, DeltaL, kcl, ccl)
    rk = np.zeros(2)
    y1 = np.zeros(3)
    v_floor = HC_V_FLOOR * Omega * B if B > 0.0 else 1e-6
    vr = v_floor
    r0, r1, roff = kc, cc, 0.0
    r0l, r1l, roffl = kcl, ccl, 0.0
    # a restitution (Newton) stop beside a compliant one: an impact, no contact phase; its free
    # entry scan is the gap itself (r = (1, 0, 0)); the lower stop only (row 1)
    rest_l = nst > 1 and int(stops[1, LAW]) == LAW_RESTITUTION
    R_l = stops[ls, R] if rest_l else 0.0
    if rest_l:
        r0l, r1l, roffl = 1.0, 0.0, 0.0
    q = q_init
    v = v_init
    phase = 1 if phase_init == 1 else (2 if (phase_init == 2 and nst > 1 and not rest_l) else 0)
    if not (P[1, 1] < 1.0 and math.isfinite(P[0, 3]) and math.isfinite(P[1, 3])):
        return (STATUS_FAILED, 0, np.inf, -np.inf, q, v, phase, 0, 0.0, 0, 0)
    if nst > 1 and not (PL[1, 1] < 1.0 and math.isfinite(PL[1, 3])):
        return (STATUS_FAILED, 0, np.inf, -np.inf, q, v, phase, 0, 0.0, 0, 0)
    T = TWO_PI / Omega
    hmax = np.empty(3)
    hmax[0] = TWO_PI / P[0, 0] / 16.0
    hmax[1] = TWO_PI / P[1, 0] / 16.0
    hmax[2] = TWO_PI / PL[1, 0] / 16.0
    ex = np.empty(3)
    ex[0] = np.inf
    ex[1] = -np.inf
    exm = np.empty(3)
    cs = np.zeros(4)
    d = np.empty(6)
    cap = con.shape[0]
    n_total = n_transient + n_record
    n_con = 0
    n_rec = 0
    n_rec_l = 0
    t_contact = 0.0
    in_record_contact = False
    v_in = 0.0
    k_sample = 0
    n_steps = 0
    phi = 0.0
    for p in range(n_total):
        recording = p >= n_transient
        ns = ns_record if recording else ns_transient
        h_grid = T / ns
        t0p = (p - n_transient) * T
        if recording:
            ex[2] = np.inf
        for j in range(ns):
            phi = TWO_PI * j / ns
            t_loc = j * h_grid
            if recording:
                samples[k_sample, 0] = q
                samples[k_sample, 1] = v
                k_sample += 1
                if q < ex[0]:
                    ex[0] = q
                if q < ex[2]:
                    ex[2] = q
                if q > ex[1]:
                    ex[1] = q
            rem = h_grid
            while rem > 0.0:
                n_steps += 1
                if max_steps >= 0 and n_steps > max_steps:
                    return (STATUS_FAILED, n_rec, ex[0], ex[1], q, v, phase, n_con, t_contact, n_rec_l, n_steps)
                # one call site per step function (compile time): a free step of a two-sided
                # scene calls advance twice, the lower stop's entry scan first (mirrored frame,
                # nothing recorded), then the upper stop's scan up to it (which records the
                # step's extremes); a contact step once, in the frame of the stop in contact
                n_calls = 2 if (phase == FREE and nst > 1) else 1
                h = min(rem, hmax[phase])
                s = h
                ev = EV_NONE
                s_l = h
                ev_l = EV_NONE
                side = 0          # the stop whose frame the step's end state is evaluated in
                phs = phi
                qs = q
                vs = v
                pp = P[0]
                Ds = Delta
                for it in range(n_calls):
                    sd = (1 if it == 0 else 0) if n_calls == 2 else (1 if phase == 2 else 0)
                    pk = FREE if phase == FREE else CONTACT
                    if sd == 1:
                        phs = (phi + math.pi) % TWO_PI
                        qs = -q
                        vs = -v
                        pp = PL[pk]
                        Ds, ks, cks, r0s, r1s, rfs = DeltaL, kcl, ccl, r0l, r1l, roffl
                        hs_, ps_, xs_ = huntl, pexpl, chil
                    else:
                        phs = phi
                        qs = q
                        vs = v
                        pp = P[pk]
                        Ds, ks, cks, r0s, r1s, rfs = Delta, kc, cc, r0, r1, roff
                        hs_, ps_, xs_ = hunt, pexp, chi
                    rec_s = recording and not (n_calls == 2 and it == 0)
                    if sd == 1 and rec_s:
                        mirror_in(ex, exm)
                    exs = exm if sd == 1 else ex
                    if pk == CONTACT and hs_:
                        s, ev = hc_advance(rem, phs, qs, vs, beta, F, Omega, Ds, ks, ps_, xs_, vr, 1.0, rk, rec_s,
                                           exs, cs, y1)
                    else:
                        s, ev = advance(pk, h, phs, qs, vs, pp, ks, cks, Omega, Ds, rec_s, exs, cs, d, r0s, r1s, rfs)
                    if sd == 1 and rec_s:
                        mirror_out(ex, exm)
                    if n_calls == 2 and it == 0:
                        s_l = s
                        ev_l = ev
                        if ev_l != EV_NONE:
                            h = s_l
                    side = sd
                if n_calls == 2 and s_l < 0.0:
                    s = s_l   # the lower stop's scan could not advance: fail below
                elif n_calls == 2 and ev == EV_NONE and ev_l != EV_NONE:
                    # the lower stop's event ends the step: its frame
                    s, ev, side = s_l, ev_l, 1
                    phs = (phi + math.pi) % TWO_PI
                    qs = -q
                    vs = -v
                    pp = P[0]
                    Ds = DeltaL
                if s < 0.0:
                    return (STATUS_FAILED, n_rec, ex[0], ex[1], q, v, phase, n_con, t_contact, n_rec_l, n_steps)
                if (phase == CONTACT and hunt) or (phase == 2 and huntl):
                    qn = Ds + y1[0]
                    vn_ = y1[1]
                else:
                    phase_eval(s, phs, qs, vs, pp, Omega, Ds, d)
                    qn = Ds + d[0]
                    vn_ = d[1]
                if side == 1:
                    q = -qn
                    v = -vn_
                else:
                    q = qn
                    v = vn_
                if phase != FREE and recording:
                    t_contact += s
                phi = (phi + Omega * s) % TWO_PI
                t_loc += s
                rem -= s
                if rem < 1e-15 * T:
                    rem = 0.0
                if ev == EV_ENTRY and side == 1 and rest_l:
                    # Newton's law on the lower (restitution) stop, paper Eq. 2, in its frame:
                    # delta'+ = -R delta'-; then the shared chatter/sticking policy
                    vn = d[1]
                    u = R_l * vn
                    q = -DeltaL
                    v = u
                    n_con += 1
                    if n_con > max_contacts:
                        return (STATUS_FAILED, n_rec, ex[0], ex[1], q, v, phase, n_con, t_contact, n_rec_l, n_steps)
                    if recording:
                        if q < ex[0]:
                            ex[0] = q
                        if q < ex[2]:
                            ex[2] = q
                        if n_rec < imp_t.shape[0]:
                            imp_t[n_rec] = t0p + t_loc
                            imp_v[n_rec] = vn
                            imp_k[n_rec] = 1
                        if n_rec < cap:
                            con[n_rec, C_DURATION] = 0.0
                            con[n_rec, C_FORCE] = np.nan
                            con[n_rec, C_PENETRATION] = 0.0
                            con[n_rec, C_ENERGY] = 0.5 * (1.0 - R_l * R_l) * vn * vn
                            con[n_rec, C_VELOCITY] = vn
                        n_rec += 1
                        n_rec_l += 1
                    # free contact acceleration towards the stop after the rebound (its frame:
                    # delta'' = F sin phi~ - 2 beta delta' - q~ at q~ = Delta_l, delta' = -u)
                    phl = (phi + math.pi) % TWO_PI
                    acc = F * math.sin(phl) + 2.0 * beta * u - DeltaL
                    pressed = acc - 2.0 * beta * u > 0.0
                    act, _D = impact_outcome(u, pressed, acc, F * Omega * math.cos(phl), 2.0 * beta, 1.0, R_l,
                                             CHATTER_TOL, rem, 0, 0)
                    if act != REBOUND:
                        # sticking on a restitution stop beside a compliant one is not implemented
                        return (STATUS_CHATTER, n_rec, ex[0], ex[1], q, v, phase, n_con, t_contact, n_rec_l, n_steps)
                elif ev == EV_ENTRY:
                    # d: the gap function of the entered stop and its derivatives (its own frame)
                    phase = CONTACT if side == 0 else 2
                    n_con += 1
                    if n_con > max_contacts:
                        return (STATUS_FAILED, n_rec, ex[0], ex[1], q, v, phase, n_con, t_contact, n_rec_l, n_steps)
                    kk = kc if side == 0 else kcl
                    ck = cc if side == 0 else ccl
                    vn = d[1]
                    cs[0] = t0p + t_loc
                    cs[1] = kk * d[0] + ck * d[1]
                    cs[2] = d[0]
                    cs[3] = 0.0
                    v_in = vn
                    if (hunt and side == 0) or (huntl and side == 1):
                        # damping chi / v_r of this contact; DOPRI5 scales from the isolated
                        # contact's penetration ((p + 1) v_r^2 / (2 k_c))^(1 / (p + 1))
                        pk = pexp if side == 0 else pexpl
                        xk = chi if side == 0 else chil
                        vr = max(vn, v_floor)
                        rk[1] = ((pk + 1.0) * vr * vr / (2.0 * kk)) ** (1.0 / (pk + 1.0))
                        rk[0] = 1e-3 * rk[1] / vr
                        cs[1] = hc_force(d[0], vn, kk, pk, xk, vr)
                        if side == 0:
                            r0, r1, roff = 0.0, 1.0, (vr / chi if chi > 0.0 else 1.0)
                        else:
                            r0l, r1l, roffl = 0.0, 1.0, (vr / chil if chil > 0.0 else 1.0)
                    in_record_contact = recording
                    if recording:
                        if n_rec < imp_t.shape[0]:
                            imp_t[n_rec] = t0p + t_loc
                            imp_v[n_rec] = vn
                            imp_k[n_rec] = side
                        n_rec += 1
                        n_rec_l += side
                elif ev == EV_EXIT:
                    phase = FREE
                    if in_record_contact and n_rec - 1 < cap:
                        r = n_rec - 1
                        con[r, C_DURATION] = t0p + t_loc - cs[0]
                        con[r, C_FORCE] = cs[1]
                        con[r, C_PENETRATION] = cs[2]
                        con[r, C_ENERGY] = cs[3]
                        con[r, C_VELOCITY] = v_in
                    in_record_contact = False
        if recording:
            pmin[p - n_transient] = ex[2]
    return (STATUS_OK, n_rec, ex[0], ex[1], q, v, phase, n_con, t_contact, n_rec_l, n_steps)


@njit(cache=True)
def isolated_contact(kc, cc, v_in, d):
    """One contact of a unit mass on the stop alone (no oscillator, no forcing), through the
    kernel's own contact step (:func:`advance`): the oracle case of the law.

    Returns
    -------
    R, duration, peak force, largest penetration, energy : float
        ``R = -delta'(t_e) / v_in`` at the force-zero exit ``t_e``.
    """
    P = np.empty(6)
    P[0] = math.sqrt(kc)
    P[1] = cc / (2.0 * P[0])
    P[2] = 0.0
    P[3] = 0.0
    P[4] = 0.0
    P[5] = 0.0
    ex = np.empty(3)
    cs = np.zeros(4)
    cs[1] = cc * v_in
    q = 0.0
    v = v_in
    t = 0.0
    h = TWO_PI / P[0] / 16.0
    for _ in range(1000):
        s, ev = advance(CONTACT, h, 0.0, q, v, P, kc, cc, 1.0, 0.0, False, ex, cs, d, kc, cc, 0.0)
        phase_eval(s, 0.0, q, v, P, 1.0, 0.0, d)
        q = d[0]
        v = d[1]
        t += s
        if ev == EV_EXIT:
            break
    return -v / v_in, t, cs[1], cs[2], cs[3]


class CompliantEventSolver:
    """Method ``event`` of an SDOF scene with a compliant stop (any law of the Kelvin-Voigt or
    hysteretic-Hertz family; a lower stop of either family or Newton's).

    The event-driven solver of this module (closed-form free flow and Kelvin-Voigt contact
    phase, a hysteretic-Hertz one by DOPRI5; certified entry and exit).  Same interface as :class:`vibeam.models.sdof.EventSolver`.

    Parameters
    ----------
    model : vibeam.models.SDOF
        The oscillator; ``model.contact`` a compliant law of :mod:`vibeam.models.compliant`.
    transient_samples : int, optional
        Grid points per forcing period during the transient (efficiency only).
    max_impacts_per_period : int, optional
        More contacts per period on average: ``failed``.
    impact_buffer : int, optional
        Most contacts whose time and record are stored per point.

    Raises
    ------
    ValueError
        If the stop's law is not ``linear`` or the contact phase is overdamped.
    """

    name = "event"
    time_domain = True
    chunk_periods = 500
    #: work budget of one kernel call (steps; ~1.5 s at the ~3 us of a step of a stiff contact):
    #: a call that needs more is ``incomplete`` and repeated in shorter calls by the sweep engine
    MAX_STEPS_PER_CALL = 500_000

    def __init__(self, model, transient_samples: int = 16, max_impacts_per_period: int = 2000,
                 impact_buffer: int = 4096, chatter_tol: float | None = None,
                 max_steps_per_period: int = 200_000, max_steps_per_call: int | None = None):
        from .contact import LAW_LINEAR, pack

        stops = model.stops()
        compliant = (LAW_LINEAR, LAW_HYSTERETIC_HERTZ)
        # the upper stop compliant; a lower stop compliant or Newton's (a restitution stop beside it)
        if not 1 <= len(stops) <= 2 or getattr(stops[0].law, "code", -1) not in compliant or (
                len(stops) == 2 and getattr(stops[1].law, "code", -1) not in compliant + (LAW_RESTITUTION,)):
            raise ValueError("CompliantEventSolver needs an upper stop with a compliant law (Kelvin-Voigt or "
                             "hysteretic Hertz) and a lower stop with one of those or Newton's law")
        self.model = model
        self.transient_samples = int(transient_samples)
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.impact_buffer = int(impact_buffer)
        self.max_steps_per_period = int(max_steps_per_period)
        self.max_steps_per_call = int(self.MAX_STEPS_PER_CALL if max_steps_per_call is None else max_steps_per_call)
        self._stops = pack(stops)
        for st, key in zip(stops, ("[model.contact]", "[model.contact_lower]")):
            law = st.law
            if law.code == LAW_RESTITUTION:
                continue
            bc = (2.0 * model.beta + law.damping) / (2.0 * math.sqrt(1.0 + law.stiffness))
            if law.code == LAW_LINEAR and not bc < 1.0:
                raise ValueError(f"the contact phase is overdamped (damping ratio {bc:.4g} >= 1): lower "
                                 f"{key} damping_ratio or raise R")

    def settings(self) -> dict:
        return dict(transient_samples=self.transient_samples,
                    max_impacts_per_period=self.max_impacts_per_period,
                    max_steps_per_period=self.max_steps_per_period)

    def point(self, Omega: float, state0, n_transient: int, n_record: int,
              samples_per_period: int = 64):
        """Simulate one forcing frequency from ``state0 = (q, q', phase)`` at forcing phase 0.

        Returns
        -------
        Trajectory
            Contacts as impacts (entry times and normal entry velocities), ``period_min``
            exact, ``final_state`` ``(q, q', phase)`` (phase 1: in contact with the upper
            stop, -1 with the lower one), ``contacts`` (k, 5) per recorded contact (duration,
            peak force, largest penetration, energy lost, entry velocity; :data:`C_DURATION`
            ...) and ``extra["contact_fraction"]``; two stops: ``impact_stops`` (0 upper, 1
            lower) and ``n_impacts_lower``.
        """
        from .trajectory import Trajectory

        m = self.model
        s0 = m.initial_state() if state0 is None else np.asarray(state0, dtype=float)
        if not np.all(np.isfinite(s0[:2])):
            s0 = m.initial_state()
        samples = np.zeros((n_record * samples_per_period, 2))
        pmin = np.zeros(n_record)
        imp_t = np.zeros(self.impact_buffer)
        imp_v = np.zeros(self.impact_buffer)
        con = np.full((self.impact_buffer, NCON), np.nan)
        par = self._stops[0]
        two = par.shape[0] > 1
        max_con = self.max_impacts_per_period * max(n_transient + n_record, 1)
        ph0 = 0
        if s0.shape[0] > 2:
            ph0 = 1 if s0[2] > 0.5 else (2 if (s0[2] < -0.5 and two) else 0)
        imp_k = np.zeros(self.impact_buffer, np.int64)
        max_steps, budget = call_budget(self.max_steps_per_period, n_transient + n_record, self.max_steps_per_call)
        out = compliant_kernel_stops(m.beta, m.B, par, float(Omega), float(s0[0]), float(s0[1]), ph0,
                                     int(n_transient), int(n_record), self.transient_samples,
                                     int(samples_per_period), max_con, samples, pmin, imp_t, imp_v, con, imp_k,
                                     max_steps)
        status, n_rec, q_min, q_max, q_end, v_end, ph_end, n_tot, t_con, n_low, n_steps = out
        incomplete = status == STATUS_FAILED and budget and n_steps > max_steps and n_tot <= max_con
        ph_end = -1 if ph_end == 2 else ph_end
        k = min(n_rec, self.impact_buffer)
        con = con[:k]
        closed = np.isfinite(con[:, C_DURATION])   # a contact still open at the end is not counted
        con = con[closed]
        message = ""
        if status == STATUS_CHATTER:
            # the point ends at the chatter: no numbers from an unfinished record
            message = ("chatter on the restitution lower stop (rebound too slow to resolve); sticking "
                       "beside a compliant stop is not implemented")
            samples[:] = np.nan
            pmin[:] = np.nan
            q_min = q_max = np.nan
        elif status == STATUS_FAILED:
            if n_tot > max_con:
                message = f"more than {max_con} contacts in {n_transient + n_record} periods"
            elif incomplete:
                message = (f"more than max_steps_per_call = {self.max_steps_per_call} steps in "
                           f"{n_transient + n_record} period(s)")
            elif n_steps > max_steps:
                message = (f"more than {self.max_steps_per_period} steps per period (a contact far stiffer than "
                           f"the forcing; lower [model.contact] stiffness)")
            else:
                message = ("a step cannot be resolved in double precision (a contact far stiffer than the "
                           "forcing, or a scale that overflows: lower [model.contact] stiffness) or a resonant "
                           "phase")
        T_rec = n_record * TWO_PI / Omega
        return Trajectory(Omega=float(Omega), samples=samples, samples_per_period=samples_per_period,
                          impact_times=imp_t[:k].copy(), impact_velocities=imp_v[:k].copy(),
                          n_impacts=int(n_rec), q_min=float(q_min), q_max=float(q_max), period_min=pmin,
                          status=STATUS_NAMES[status], message=message,
                          final_state=np.array([q_end, v_end, float(ph_end)]),
                          extra={"contact_fraction": t_con / T_rec if n_record else 0.0},
                          contacts=con, impact_stops=imp_k[:k].copy() if two else None,
                          contact_stops=imp_k[:k][closed].copy() if two else None,
                          n_impacts_lower=int(n_low) if two else 0, incomplete=bool(incomplete))



@njit(cache=True)
def isolated_contact_hc(kc, p, chi, v_in):
    """One Hunt-Crossley contact of a unit mass on the stop alone, through the kernel's own
    contact step (:func:`hc_advance`).

    Returns
    -------
    R, duration, peak force, largest penetration, energy : float
    """
    rk = np.empty(2)
    rk[1] = ((p + 1.0) * v_in * v_in / (2.0 * kc)) ** (1.0 / (p + 1.0))
    rk[0] = 1e-3 * rk[1] / v_in
    ex = np.empty(3)
    cs = np.zeros(4)
    y1 = np.zeros(3)
    q = 0.0
    v = v_in
    t = 0.0
    for _ in range(10 ** 6):
        s, ev = hc_advance(np.inf, 0.0, q, v, 0.0, 0.0, 0.0, 0.0, kc, p, chi, v_in, 0.0, rk, False, ex, cs, y1)
        if s < 0.0:
            return np.nan, np.nan, np.nan, np.nan, np.nan
        q = y1[0]
        v = y1[1]
        t += s
        if ev == EV_EXIT:
            break
    return -v / v_in, t, cs[1], cs[2], cs[3]
