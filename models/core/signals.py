"""Signals of a linear flow and their certified scan: the event location of every phase.

Between events every phase of vibeam's one dynamical system (free flight, the system held on
stops) moves ``m`` decoupled coordinates ``x_j`` as damped oscillators (homogeneous parts from
``(x0_j, y0_j)``, mode table rows of :func:`vibeam.models.system.mode_table`) plus a harmonic
particular part.  Everything an event kernel watches -- a stop's gap, a held stop's contact
force, the sensor -- is then a *signal*::

    f(s) = f0 + sum_j p_j (x_j(s) - x0_j) + r_j (y_j(s) - y0_j) + Sa (sin(phi0 + Om s) - sin phi0)
           + Sb (cos(phi0 + Om s) - cos phi0)

formed from its value ``f0`` and slope ``fp0`` at ``s = 0`` plus increments free of
cancellation (:func:`vibeam.models.system.transition_increment`).  :func:`scan` finds the
first time it reaches zero from below on ``[0, h]`` with a guarantee: the sign of ``f''`` is
certified on the interval from bounds of the third and fourth derivatives (:func:`bounds`,
:func:`certify_curvature`), so ``f`` has at most one extremum there, located by a bracketed
root of ``f'`` and checked; an interval that cannot be certified is halved.  No zero crossing
can be stepped over (grazing included), whatever the number of coordinates.

These helpers allocate nothing and are compiled without numba's reference counting
(``_nrt=False``): an array argument would otherwise cost an atomic increment and decrement per
call, which dominated the event kernel's time.

References
----------
Press et al., *Numerical Recipes*, 3rd ed., Sec. 9.4 (safeguarded Newton, ``rtsafe``);
paper Eq. 28 (the closed-form flow).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .roots import rtsafe_update, select
from ..system import increment_of, transition_increment

#: the bracketed problems of :func:`root` (int64, not literal ints: one compiled specialisation)
ROOT_CROSS, ROOT_APEX, ROOT_MIN = np.int64(0), np.int64(1), np.int64(2)
#: the helpers are called from compiled code only: no Python or C wrappers, no reference counting
_kernel = njit(cache=True, _nrt=False, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)

__all__ = ["certify_curvature", "homogeneous_bounds", "signal", "signal_sc", "signal_start", "bounds", "hermite_guess",
           "root", "root_value", "scan", "extremes_from",
           "extremes", "homogeneous"]


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def certify_curvature(g20, g30, g21, g31, M3, M4, h, tol):
    """Certified sign of ``f''`` on ``[0, h]``: +1 convex, -1 concave, 0 unknown.

    Parameters
    ----------
    g20, g30, g21, g31 : float
        Second and third derivatives of the signal at ``0`` and ``h``.
    M3, M4 : float
        Bounds of its third and fourth derivatives over the interval.
    h : float
        Interval length (nondimensional time).
    tol : float
        Round-off level of ``f''`` (values within it count as zero).
    """
    # first-order test with the 3rd-derivative bound (the lower envelope of |f''| over the
    # interval is V-shaped)
    if g20 >= -tol and g21 >= -tol and g20 + g21 > M3 * h:
        return 1
    if g20 <= tol and g21 <= tol and g20 + g21 < -M3 * h:
        return -1
    # second-order tests with the 4th-derivative bound, anchored at either end; they certify
    # intervals that start at a release or grazing point where f'' = 0
    c = 0.5 * M4 * h * h
    if g20 <= tol and g20 + g30 * h + c <= tol:
        return -1
    if g21 <= tol and g21 - g31 * h + c <= tol:
        return -1
    if g20 >= -tol and g20 + g30 * h - c >= -tol:
        return 1
    if g21 >= -tol and g21 - g31 * h - c >= -tol:
        return 1
    return 0


@_kernel
def homogeneous_bounds(x0, y0, sig, k, typ, q, l1, l2, out):
    """Bounds ``out[m] >= sup_{s >= 0} |x^(m)(s)|``, ``m = 0..5``, of the homogeneous solution
    of ``x'' + 2 sig x' + k x = 0`` from ``(x0, y0)`` (a row ``(sig, k, typ, q, l1, l2)`` of
    :func:`vibeam.models.system.mode_table`): underdamped ``A omega^m``, overdamped ``|c1| |l1|^m
    + |c2| |l2|^m``, critical a bound of ``(c1 + c2 s) e^{-sig s}`` and its derivatives."""
    if typ == 0:
        w = (y0 + sig * x0) / q
        A = math.hypot(x0, w)        # no underflow of the squares at tiny amplitudes
        om = math.sqrt(k)
        p = A
        for m in range(6):
            out[m] = p
            p *= om
    elif typ == 2:
        c1 = (y0 - l2 * x0) / (l1 - l2)
        c2 = (l1 * x0 - y0) / (l1 - l2)
        a1 = abs(c1)
        a2 = abs(c2)
        for m in range(6):
            out[m] = a1 + a2
            a1 *= -l1
            a2 *= -l2
    elif sig == 0.0:
        # a free mass (k = 0): x0 + y0 s, unbounded in position, its derivatives y0, 0, 0, ...
        # (out[0] is read only as a contact phase's round-off scale, whose modes never are free)
        out[0] = math.inf
        out[1] = abs(y0)
        for m in range(2, 6):
            out[m] = 0.0
    else:
        # derivatives d_m of the critically damped solution by the recursion of the ODE
        d0 = x0
        d1 = y0
        for m in range(6):
            out[m] = abs(d0) + abs(d1 + sig * d0) / (math.e * sig)
            d0, d1 = d1, -2.0 * sig * d1 - k * d0
    for m in range(6):
        out[m] = out[m] * (1.0 + 1e-9) + 1e-300


@_kernel
def signal(s, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m):
    """:func:`signal_sc` from the phase ``phi0`` itself."""
    return signal_sc(s, math.sin(phi0), math.cos(phi0), Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def signal_sc(s, sp0, cp0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m):
    """The signal and its first four derivatives at local time ``s``.

    Parameters
    ----------
    s : float
        Time from the start of the step.
    sp0, cp0 : float
        sin and cos of the forcing phase at ``s = 0`` (the phase at ``s`` by angle addition:
        one sincos per evaluation).
    Om : float
        Forcing frequency.
    x0, y0 : ndarray, shape (>= m,)
        Homogeneous parts of the coordinates and velocities at ``s = 0``.
    mp : ndarray, shape (>= m, 6)
        Mode table of the coordinates.
    p, r : ndarray, shape (>= m,)
        Weights of the coordinates and of their velocities.
    Sa, Sb : float
        Harmonic part ``Sa sin + Sb cos`` of the signal.
    f0, fp0 : float
        Value and slope at ``s = 0`` (:func:`signal_start`).
    m : int
        Number of coordinates.

    Returns
    -------
    (f, f', f'', f''', f'''') : tuple of float
    """
    f = f0
    f1 = fp0
    f2 = 0.0
    f3 = 0.0
    f4 = 0.0
    for j in range(m):
        sig = mp[j, 0]
        k = mp[j, 1]
        a11, a12, a21, a22 = transition_increment(s, sig, k, int(mp[j, 2]), mp[j, 3], mp[j, 4], mp[j, 5])
        dx = a11 * x0[j] + a12 * y0[j]
        dy = a21 * x0[j] + a22 * y0[j]
        x = x0[j] + dx
        y = y0[j] + dy
        dx2 = -2.0 * sig * dy - k * dx
        x2 = -2.0 * sig * y - k * x
        x3 = -2.0 * sig * x2 - k * y
        x4 = -2.0 * sig * x3 - k * x2
        x5 = -2.0 * sig * x4 - k * x3
        f += p[j] * dx + r[j] * dy
        f1 += p[j] * dy + r[j] * dx2
        f2 += p[j] * x2 + r[j] * x3
        f3 += p[j] * x3 + r[j] * x4
        f4 += p[j] * x4 + r[j] * x5
    half = 0.5 * Om * s
    sh = math.sin(half)
    ch = math.cos(half)
    sph = sp0 * ch + cp0 * sh          # sin and cos of phi0 + half
    cph = cp0 * ch - sp0 * sh
    f += 2.0 * sh * (Sa * cph - Sb * sph)
    f1 += Om * (-2.0 * sh) * (Sa * sph + Sb * cph)
    sp = sph * ch + cph * sh           # of phi0 + Om s
    cp = cph * ch - sph * sh
    S = Sa * sp + Sb * cp
    Sd = Om * (Sa * cp - Sb * sp)
    W2 = Om * Om
    f2 -= W2 * S
    f3 -= W2 * Sd
    f4 += W2 * W2 * S
    return f, f1, f2, f3, f4


@_kernel
def signal_start(phi0, Om, x0, y0, mp, p, r, Sa, Sb, const, m):
    """Value and slope at ``s = 0`` of the signal ``const + sum p x + r x' + Sa sin + Sb cos``
    (arguments as :func:`signal`)."""
    f = const + Sa * math.sin(phi0) + Sb * math.cos(phi0)
    fp = Om * (Sa * math.cos(phi0) - Sb * math.sin(phi0))
    for j in range(m):
        x2 = -2.0 * mp[j, 0] * y0[j] - mp[j, 1] * x0[j]
        f += p[j] * x0[j] + r[j] * y0[j]
        fp += p[j] * y0[j] + r[j] * x2
    return f, fp


@_kernel
def bounds(hb, p, r, Csin, Om, m):
    """Bounds ``M2, M3, M4`` of the 2nd-4th derivatives of a signal over ``s >= 0``.

    Parameters
    ----------
    hb : ndarray, shape (>= m, 6)
        :func:`homogeneous_bounds` of each coordinate.
    p, r : ndarray, shape (>= m,)
        Weights of the coordinates and velocities.
    Csin : float
        Amplitude ``sqrt(Sa^2 + Sb^2)`` of the harmonic part.
    Om : float
        Forcing frequency.
    m : int
        Number of coordinates.
    """
    M2 = Csin * Om ** 2
    M3 = Csin * Om ** 3
    M4 = Csin * Om ** 4
    for j in range(m):
        ap = abs(p[j])
        ar = abs(r[j])
        M2 += ap * hb[j, 2] + ar * hb[j, 3]
        M3 += ap * hb[j, 3] + ar * hb[j, 4]
        M4 += ap * hb[j, 4] + ar * hb[j, 5]
    f = 1.0 + 1e-9
    return M2 * f + 1e-300, M3 * f + 1e-300, M4 * f + 1e-300


@_kernel
def hermite_guess(lo, hi, Fa, dFa, Fb, dFb):
    """A start for :func:`root`: the zero of the cubic Hermite interpolant of ``F`` on ``[lo, hi]``
    from its values and slopes at both ends (``Fa < 0 <= Fb``), by safeguarded Newton steps on
    the polynomial (no transcendental call).  Its error is ``O(h^4 max |F^(4)|)``, so Newton on
    the signal itself then converges in two or three evaluations instead of five to seven from
    the midpoint.  Always strictly inside the bracket."""
    h = hi - lo
    a = 0.0
    b = 1.0
    t = Fa / (Fa - Fb) if Fa - Fb != 0.0 else 0.5
    for _ in range(12):
        if not (a < t < b):
            t = 0.5 * (a + b)
        t2 = t * t
        t3 = t2 * t
        p = (Fa * (2.0 * t3 - 3.0 * t2 + 1.0) + h * dFa * (t3 - 2.0 * t2 + t) + Fb * (3.0 * t2 - 2.0 * t3)
             + h * dFb * (t3 - t2))
        dp = 6.0 * (Fa - Fb) * (t2 - t) + h * dFa * (3.0 * t2 - 4.0 * t + 1.0) + h * dFb * (3.0 * t2 - 2.0 * t)
        if p < 0.0:
            a = t
        else:
            b = t
        if dp == 0.0:
            continue
        dt = p / dp
        t = t - dt
        if abs(dt) < 1e-9:
            break
    if not (a < t < b):
        t = 0.5 * (a + b)
    s = lo + t * h
    if not (lo < s < hi):
        s = 0.5 * (lo + hi)
    return s


@_kernel
def root_value(kind, lo, hi, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m):
    """:func:`root` and the signal's value at the returned time, from the evaluation the iteration
    made there (the same number as evaluating it again; one evaluation fewer)."""
    dxold = hi - lo
    dx = dxold
    s = s0 if lo < s0 < hi else 0.5 * (lo + hi)
    sp0 = math.sin(phi0)
    cp0 = math.cos(phi0)
    g_hi = np.nan            # the value at hi once an iterate became hi (F >= 0 there)
    for _ in range(200):
        g, v, g2, g3, g4 = signal_sc(s, sp0, cp0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)
        F, dF = select(kind, g, v, g2)
        s_now = s
        if F >= 0.0:
            g_hi = g
        s, lo, hi, dx, dxold, done = rtsafe_update(F, dF, s, lo, hi, dx, dxold)
        if done:
            if s == s_now:
                return s, g
            if g_hi == g_hi and s == hi:
                return s, g_hi
            hi = s             # (returned: the bracket end rtsafe_update chose)
            break
    s_out = hi
    # (the rare fallback: one more evaluation, by the compiled signal rather than a third inlined
    # copy of signal_sc, for the compile time; the same numbers)
    return s_out, signal(s_out, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)[0]


@_kernel
def root(kind, lo, hi, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m):
    """Safeguarded Newton on a bracket with ``F(lo) < 0 <= F(hi)``, started at ``s0`` (the
    midpoint unless ``lo < s0 < hi``; :func:`hermite_guess` gives a close one); returns the
    bracket end where ``F >= 0`` (an event is never placed before its crossing).  kind 0:
    ``F = f``; 1: ``F = -f'`` (a maximum); 2: ``F = f'`` (a minimum).  The time of
    :func:`root_value` (one compiled iteration for both)."""
    return root_value(kind, lo, hi, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)[0]


@_kernel
def scan(h, h_min, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, M2, M3, M4, m):
    """One certified step of at most ``h``: the first time the signal reaches 0 from below.

    Returns
    -------
    (s_event, h_used) : (float, float)
        ``s_event = -1`` when the signal stays negative on ``[0, h_used]`` (guaranteed unless
        the step fell below ``h_min``); ``h_used <= h`` is the certified step.
    """
    g0, v0, g20, g30, _ = signal(0.0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)
    if M2 <= 1e-290 and M3 <= 1e-290 and g0 <= 0.0:
        return -1.0, h          # a constant signal (every bound zero): it never rises through zero
    g1, v1, g21, g31, _ = signal(h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)
    return scan_from(h, h_min, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, (g0, v0, g20, g30), (g1, v1, g21, g31),
                     M2, M3, M4, m)


@_kernel
def extremes(h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, vstart, vend, ext, m):
    """Update ``ext = [min, max]`` with the interior minimum or maximum of a signal on ``[0, h]``
    when its slope changes sign between the ends (``vstart``, ``vend``)."""
    extremes_from(h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, vstart, vend, h * vstart / (vstart - vend), ext, m)


@_kernel
def extremes_from(h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, vstart, vend, s0, ext, m):
    """:func:`extremes` with the root search started at ``s0`` (e.g. :func:`hermite_guess` of the
    slope from its values and derivatives at both ends)."""
    if vstart < 0.0 < vend:
        sm, v = root_value(ROOT_MIN, 0.0, h, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)
        if v < ext[0]:
            ext[0] = v
    elif vstart > 0.0 > vend:
        sa, v = root_value(ROOT_APEX, 0.0, h, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)
        if v > ext[1]:
            ext[1] = v


@_kernel
def homogeneous(phi0, Om, z, zd, a, b, e, x0, y0, m):
    """Homogeneous parts ``x0 = z - e - (a sin + b cos)``, ``y0 = z' - Om (a cos - b sin)`` of
    coordinates ``z`` with static offsets ``e`` and particular coefficients ``a, b``."""
    sp0 = math.sin(phi0)
    cp0 = math.cos(phi0)
    for j in range(m):
        x0[j] = z[j] - e[j] - (a[j] * sp0 + b[j] * cp0)
        y0[j] = zd[j] - Om * (a[j] * cp0 - b[j] * sp0)


@_kernel
def scan_from(h, h_min, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, start, end, M2, M3, M4, m):
    """:func:`scan` with the signal's value, slope and derivatives at ``0`` (``start = (g0, v0,
    g20, g30)``; ``f0, fp0`` the signal's own start, :func:`signal`) and at ``h`` given (``end =
    (g1, v1, g21, g31)``: the caller's tabulated flow, or :func:`scan`'s evaluation): no
    transcendental call unless the step must be halved or an event is located.  (The two tuples
    cost nothing: numba passes a tuple's members as separate arguments.)"""
    g0, v0, g20, g30 = start
    g1, v1, g21, g31 = end
    tol2 = 1e-13 * M2
    if max(g0, g1) + 0.125 * M2 * h * h < 0.0:
        return -1.0, h
    if M2 <= 1e-290 and M3 <= 1e-290 and g0 <= 0.0:
        return -1.0, h          # a constant signal (every bound zero): it never rises through zero
    cert = certify_curvature(g20, g30, g21, g31, M3, M4, h, tol2)
    while cert == 0 and not (h < h_min or not h > 0.0):
        h *= 0.5
        g1, v1, g21, g31, _ = signal(h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)
        if max(g0, g1) + 0.125 * M2 * h * h < 0.0:
            return -1.0, h
        cert = certify_curvature(g20, g30, g21, g31, M3, M4, h, tol2)
    if cert == 0:
        cert = 1 if g20 + g21 > 0.0 else -1
    if cert < 0:
        # concave: rising at the start, a crossing before the slope turns (v1 >= 0) or before the apex
        if v0 > 0.0 and v1 >= 0.0:
            if g1 >= 0.0:
                s0 = hermite_guess(0.0, h, g0, v0, g1, v1)
                return root(ROOT_CROSS, 0.0, h, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m), h
        elif v0 > 0.0:
            bound = g0 + v0 * (g1 - g0 - v1 * h) / (v0 - v1) if v0 - v1 > 0.0 else g0
            if bound >= 0.0:
                s0 = hermite_guess(0.0, h, -v0, -g20, -v1, -g21)
                sa = root(ROOT_APEX, 0.0, h, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)
                ga = signal(sa, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)[0]
                if ga >= 0.0:
                    if g0 < 0.0:
                        s0 = hermite_guess(0.0, sa, g0, v0, ga, 0.0)
                        return root(ROOT_CROSS, 0.0, sa, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m), h
                    return sa, h
    else:
        if v1 > 0.0 or (v1 == 0.0 and g1 >= 0.0):
            if v0 < 0.0:
                if g1 >= 0.0:
                    s0 = hermite_guess(0.0, h, v0, g20, v1, g21)
                    sm = root(ROOT_MIN, 0.0, h, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m)
                    return root(ROOT_CROSS, sm, h, -1.0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m), h
            elif g1 >= 0.0:
                s0 = hermite_guess(0.0, h, g0, v0, g1, v1)
                return root(ROOT_CROSS, 0.0, h, s0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, m), h
    return -1.0, h


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def mode_ends(s, x0, y0, mp, P, tab, dx, dy, x2, x3, m):
    """Per-coordinate increments and derivatives of the homogeneous flow at local time ``s``.

    ``dx, dy`` receive ``x(s) - x0``, ``y(s) - y0``; ``x2, x3`` the second and third derivatives
    ``x''(s)``, ``x'''(s)``.  ``tab``: use the tabulated increments ``P`` (shape (>= m, 4),
    ``Phi(s) - I`` of each coordinate for this fixed ``s``) instead of evaluating them."""
    for j in range(m):
        sig = mp[j, 0]
        k = mp[j, 1]
        a11, a12, a21, a22 = increment_of(tab, P, j, s, mp)
        ddx = a11 * x0[j] + a12 * y0[j]
        ddy = a21 * x0[j] + a22 * y0[j]
        x = x0[j] + ddx
        y = y0[j] + ddy
        dx[j] = ddx
        dy[j] = ddy
        xx2 = -2.0 * sig * y - k * x
        x2[j] = xx2
        x3[j] = -2.0 * sig * xx2 - k * y
