"""The contact phase with no closed form: one tableau-driven Runge-Kutta step and its events.

While a hysteretic-Hertz stop (or any mix of compliant stops with one) is in contact, the modal
system is integrated numerically::

    eta'' = Gamma F sin(Omega t) - C eta' - K eta - sum_{k in C} n_k f_k(g_k, g_k')      (H empty)
    zeta'' = Psi^T Gamma F sin - c_H zeta' - nu^2 (zeta - e) - sum_{k in C} Psi^T n_k f_k    (held on H)

(:mod:`vibeam.models.core.laws` for ``f_k``; :class:`~vibeam.models.core.stops.HeldSets` for the
constrained coordinates), with the work ``E_k' = f_k g_k'`` of each stop appended to the state.
A step is one embedded explicit Runge-Kutta step of the tableau handed in (:data:`DOPRI5`,
Dormand & Prince 1980; Hairer, Norsett & Wanner, *Solving ODEs I*, Sec. II.5), accepted when its
error estimate is below ``RTOL |y| + ATOL`` scales of the contact (the isolated contact's
penetration and entry velocity, :func:`vibeam.models.core.laws.contact_scales`), the step size
controlled as usual (factor ``0.9 err^(-1/5)`` within ``[0.1, 5]``).  Events -- a contact's exit
(its force back to zero), the entry or impact of another stop, a held stop's release, and the
extremes recorded (largest penetration, peak force, the sensor's minima and maxima) -- are sign
changes of functions of the state, located by bisection on single steps from the accepted step's
start (each as accurate as the step).

The step and its events call :func:`phase_rhs` directly: no function objects in the kernels.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from ..contact import LAW_LINEAR
from .laws import RTOL, force, force_partials

__all__ = ["Tableau", "DOPRI5", "phase_rhs", "rk_step", "event_value", "locate", "EVF_EXIT_FORCE", "EVF_EXIT_GAP",
           "EVF_EXIT_DAMPING", "EVF_GAP", "EVF_GAP_DOWN", "EVF_INSIDE", "EVF_RELEASE", "EVF_MAX_PEN",
           "EVF_PEAK_FORCE", "EVF_SENSOR_MIN", "EVF_SENSOR_MAX"]


class Tableau(NamedTuple):
    """An embedded explicit Runge-Kutta pair (first-same-as-last).

    Attributes
    ----------
    a : ndarray, shape (s, s)
        Stage coefficients (row ``s - 1``: the weights of the propagated solution).
    c : ndarray, shape (s,)
        Nodes.
    e : ndarray, shape (s,)
        Weights of the error estimate (propagated minus embedded).
    order : int
        Order of the embedded solution plus one (the exponent of the step control is ``-1 / order``).
    """

    a: np.ndarray
    c: np.ndarray
    e: np.ndarray
    order: int


#: Dormand-Prince 5(4) (Dormand & Prince 1980; Hairer, Norsett & Wanner, Sec. II.5)
DOPRI5 = Tableau(
    a=np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                [1 / 5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                [3 / 40, 9 / 40, 0.0, 0.0, 0.0, 0.0, 0.0],
                [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0, 0.0, 0.0],
                [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0, 0.0, 0.0],
                [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0.0, 0.0],
                [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0]]),
    c=np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0]),
    e=np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40]),
    order=5)

# ---- event functions (each rises through zero at its event)
EVF_EXIT_FORCE = 0     # -f of a Kelvin-Voigt contact
EVF_EXIT_GAP = 1       # -g of a hysteretic-Hertz contact
EVF_EXIT_DAMPING = 2   # -(1 + chi g' / v_in) of a hysteretic-Hertz contact
EVF_GAP = 3            # g of a stop outside it: an entry (compliant) or impact (Newton)
EVF_GAP_DOWN = 4       # -g of a stop the body is inside of (no contact)
EVF_INSIDE = 5         # the force's sign function inside a stop: an entry
EVF_RELEASE = 6        # lambda of a held stop: its release
EVF_MAX_PEN = 7        # -g' (largest penetration)
EVF_PEAK_FORCE = 8     # -f' (peak force)
EVF_SENSOR_MIN = 9     # s^T eta' (a minimum of the sensor)
EVF_SENSOR_MAX = 10    # -s^T eta'


@njit(cache=True, _nrt=False, error_model="numpy")
def _gaps(k, y, H, sy, st, hs, m):
    """Gap and normal velocity of stop ``k`` at the state ``y`` of the phase."""
    n = sy.k.shape[0]
    g = 0.0
    gd = 0.0
    if H == 0:
        g = -st.offset[k]
        for i in range(n):
            g += st.normal[k, i] * y[i]
            gd += st.normal[k, i] * y[m + i]
    else:
        g = hs.cG[H, k]
        for j in range(m):
            g += hs.pG[H, k, j] * (y[j] - hs.e[H, j])
            gd += hs.pG[H, k, j] * y[m + j]
    return g, gd


@njit(cache=True, _nrt=False, error_model="numpy")
def phase_rhs(s, y, phi0, Om, F, sy, st, hs, H, C, vr, out):
    """Right-hand side of the phase (module docstring) at local time ``s``; ``y`` (2m + n_s):
    coordinates, velocities (``eta`` free, ``zeta`` held on ``H``) and the works of the stops."""
    n = sy.k.shape[0]
    ns = st.offset.shape[0]
    m = n if H == 0 else hs.nc[H]
    sn = F * math.sin(phi0 + Om * s)
    if H == 0:
        for i in range(n):
            out[i] = y[m + i]
            out[m + i] = sy.gam[i] * sn - sy.c[i] * y[m + i] - sy.k[i] * y[i]
    else:
        for j in range(m):
            out[j] = y[m + j]
            out[m + j] = hs.gam[H, j] * sn - hs.c[H, j] * y[m + j] - hs.nu2[H, j] * (y[j] - hs.e[H, j])
    for k in range(ns):
        out[2 * m + k] = 0.0
        if (C >> k) & 1 == 0:
            continue
        g, gd = _gaps(k, y, H, sy, st, hs, m)
        f = force(st.law[k], g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k])
        out[2 * m + k] = f * gd
        if H == 0:
            for i in range(n):
                out[m + i] -= st.normal[k, i] * f
        else:
            for j in range(m):
                out[m + j] -= hs.pG[H, k, j] * f


@njit(cache=True, _nrt=False, error_model="numpy")
def _stage(hs_, y0, phi0, Om, F, sy, st, hs, H, C, vr, tab, K, tmp, y1):
    """One step of length ``hs_`` (no control): ``y1`` the propagated solution, ``K`` the stages."""
    L = y0.shape[0]
    S = tab.c.shape[0]
    for i in range(S - 1):
        for c in range(L):
            acc = y0[c]
            for j in range(i):
                acc += hs_ * tab.a[i, j] * K[j, c]
            tmp[c] = acc
        phase_rhs(tab.c[i] * hs_, tmp, phi0, Om, F, sy, st, hs, H, C, vr, K[i])
    for c in range(L):
        acc = y0[c]
        for j in range(S - 1):
            acc += hs_ * tab.a[S - 1, j] * K[j, c]
        y1[c] = acc
    phase_rhs(hs_, y1, phi0, Om, F, sy, st, hs, H, C, vr, K[S - 1])


@njit(cache=True, _nrt=False, error_model="numpy")
def rk_step(h, y0, phi0, Om, F, sy, st, hs, H, C, vr, tab, rk, K, tmp, y1):
    """One accepted step of at most ``h`` from ``y0`` (local time 0).

    Parameters
    ----------
    rk : ndarray, shape (4,)
        Step-size estimate, absolute error scales of the coordinates and velocities, and the
        smallest step (below it the step fails).
    K, tmp : ndarray, shapes (s, L), (L,)
        Work arrays.
    y1 : ndarray, shape (L,)
        Receives the state at the step's end.

    Returns
    -------
    float
        The step taken, -1 if its size underflowed (failed).
    """
    n = sy.k.shape[0]
    m = n if H == 0 else hs.nc[H]
    S = tab.c.shape[0]
    err = 0.0
    hs_ = h
    while True:
        hs_ = min(rk[0], h)
        _stage(hs_, y0, phi0, Om, F, sy, st, hs, H, C, vr, tab, K, tmp, y1)
        err = 0.0
        for c in range(2 * m):
            e = 0.0
            for j in range(S):
                e += hs_ * tab.e[j] * K[j, c]
            sc = (rk[1] if c < m else rk[2]) + RTOL * max(abs(y0[c]), abs(y1[c]))
            err = max(err, abs(e) / sc)
        if err <= 1.0:
            break
        rk[0] = hs_ * max(0.1, 0.9 * err ** (-1.0 / tab.order))
        if rk[0] < rk[3] or not rk[0] > 0.0:
            return -1.0
    if hs_ == rk[0]:
        rk[0] = hs_ * min(5.0, 0.9 * err ** (-1.0 / tab.order)) if err > 0.0 else 5.0 * hs_
    return hs_


@njit(cache=True, _nrt=False, error_model="numpy")
def event_value(kind, k, y, s, phi0, Om, F, sy, st, hs, H, C, vr, relaxed, acc):
    """Value of event function ``kind`` (:data:`EVF_EXIT_FORCE` ...) of stop ``k`` at state ``y``
    (local time ``s``); ``acc`` (2m + n_s,) a work array."""
    n = sy.k.shape[0]
    m = n if H == 0 else hs.nc[H]
    if kind == EVF_SENSOR_MIN or kind == EVF_SENSOR_MAX:
        v = 0.0
        if H == 0:
            for i in range(n):
                v += sy.sensor[i] * y[m + i]
        else:
            for j in range(m):
                v += hs.pS[H, j] * y[m + j]
        return v if kind == EVF_SENSOR_MIN else -v
    if kind == EVF_RELEASE:
        # lambda_k = gw^T (K eta + C eta' - Gamma F sin + sum_c n_c f_c)
        sn = F * math.sin(phi0 + Om * s)
        lam = 0.0
        for i in range(n):
            e = hs.eta_c[H, i]
            ed = 0.0
            for j in range(m):
                e += hs.Psi[H, i, j] * y[j]
                ed += hs.Psi[H, i, j] * y[m + j]
            lam += hs.gw[H, k, i] * (sy.k[i] * e + sy.c[i] * ed - sy.gam[i] * sn)
        for c in range(st.offset.shape[0]):
            if (C >> c) & 1:
                g, gd = _gaps(c, y, H, sy, st, hs, m)
                f = force(st.law[c], g, gd, st.kc[c], st.cc[c], st.pe[c], vr[c])
                w = 0.0
                for i in range(n):
                    w += hs.gw[H, k, i] * st.normal[c, i]
                lam += w * f
        return lam
    g, gd = _gaps(k, y, H, sy, st, hs, m)
    if kind == EVF_GAP:
        return g
    if kind == EVF_GAP_DOWN:
        return -g
    if kind == EVF_MAX_PEN:
        return -gd
    code = st.law[k]
    if kind == EVF_EXIT_FORCE:
        return -(st.kc[k] * g + st.cc[k] * gd)
    if kind == EVF_EXIT_GAP:
        return -g
    if kind == EVF_EXIT_DAMPING:
        return -(1.0 + st.cc[k] * gd / vr[k])
    if kind == EVF_INSIDE:
        if code == LAW_LINEAR:
            return st.kc[k] * g + st.cc[k] * gd
        if (relaxed >> k) & 1:
            return gd + (vr[k] / st.cc[k] if st.cc[k] > 0.0 else 1.0)
        return g
    # EVF_PEAK_FORCE: -(f_g g' + f_g' g'')
    phase_rhs(s, y, phi0, Om, F, sy, st, hs, H, C, vr, acc)
    gdd = 0.0
    if H == 0:
        for i in range(n):
            gdd += st.normal[k, i] * acc[m + i]
    else:
        for j in range(m):
            gdd += hs.pG[H, k, j] * acc[m + j]
    fg, fgd, _fv = force_partials(code, g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k])
    return -(fg * gd + fgd * gdd)


@njit(cache=True, _nrt=False, error_model="numpy")
def locate(kind, k, hs_, y0, phi0, Om, F, sy, st, hs, H, C, vr, relaxed, tab, K, tmp, y1, yhi, acc):
    """Root in ``(0, hs_]`` of an event function negative before it and ``>= 0`` at ``hs_`` (state
    ``yhi``), by bisection on single steps from ``y0``; returns the end where it is ``>= 0`` and
    leaves that state in ``yhi`` (``y1``: work array)."""
    lo = 0.0
    hi = hs_
    L = y0.shape[0]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if not (lo < mid < hi):
            break
        _stage(mid, y0, phi0, Om, F, sy, st, hs, H, C, vr, tab, K, tmp, y1)
        if event_value(kind, k, y1, mid, phi0, Om, F, sy, st, hs, H, C, vr, relaxed, acc) >= 0.0:
            hi = mid
            for c in range(L):
                yhi[c] = y1[c]
        else:
            lo = mid
    return hi
