"""The hysteretic-Hertz contact phase of a linear modal system: force, one Dormand-Prince step, exits.

A modal system (``eta'' + C eta' + K eta = Gamma F sin(Omega t)``, ``C``, ``K`` diagonal, kernel
units of :mod:`vibeam.models.beam_compliant`) in contact with a stop of relation ``g = w^T eta -
Delta`` (``w`` the stop's normal row: the contact row for an upper stop, its negative for a lower
one) and a hysteretic-Hertz law ``f = k g^p (1 + chi g' / v_in)`` acting along ``-w``, ``chi`` a
number of the law (:class:`vibeam.models.compliant.HystereticHertz`: Hunt-Crossley, Hunt & Crossley
1975 with ``chi`` of Flores et al. 2011, or another law of the family).  The
phase has no closed form; it is integrated by Dormand-Prince 5(4) on ``(eta, eta', E)``
(``E' = f g'``, the work done on the stop) with relative tolerance
:data:`vibeam.models.sdof_compliant.HC_RTOL` and absolute ones from the isolated contact's
penetration and entry velocity (:func:`contact_scales`).  Its events -- the exit where the force
returns to zero (``g`` back to 0, or the damping factor ``1 + chi g' / v_in`` to 0), the largest
penetration, the peak force and the sensor's extrema -- are located by bisection on single steps
from the accepted step's start, as the SDOF kernel does
(:func:`vibeam.models.sdof_compliant.hc_advance`).  The event kernel of
:mod:`vibeam.models.beam_compliant` calls :func:`hc_contact_step` for every stop whose law is
of the hysteretic-Hertz family, on either side.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contact import EV_EXIT, EV_NONE
from .dormand_prince import DP_A, DP_C, DP_E
from .sdof_compliant import HC_ATOL, HC_RTOL


@njit(cache=True)
def contact_scales(vr, kc, p, wn, rk):
    """Step-control scales of one contact entered at normal velocity ``vr`` into ``rk`` (4,):
    the first step, the absolute error scales of ``eta`` and ``eta'``, and the contact's time
    scale, from the isolated contact's penetration ``((p + 1) m_eff v_r^2 / (2 k))^(1 / (p + 1))``
    with ``m_eff = 1 / wn^2`` (``wn = |w|``)."""
    pen = ((p + 1.0) * vr * vr / (2.0 * kc * wn * wn)) ** (1.0 / (p + 1.0))
    rk[0] = 1e-3 * pen / vr
    rk[1] = HC_ATOL * pen / wn
    rk[2] = HC_ATOL * vr / wn
    rk[3] = pen / vr


@njit(cache=True)
def hysteretic_hertz_force(g, gd, kc, p, chi, vr):
    """Force ``k g^p (1 + chi g' / v_r)`` per unit effective mass (0 for ``g <= 0``), kernel units."""
    if g <= 0.0:
        return 0.0
    return kc * g ** p * (1.0 + chi * gd / vr)


@njit(cache=True)
def contact_rhs(s, y, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, out):
    """``y = (eta, eta', E)`` of the contact phase (module docstring)."""
    N = knd.shape[0]
    g = -DC
    gd = 0.0
    for i in range(N):
        g += w[i] * y[i]
        gd += w[i] * y[N + i]
    f = hysteretic_hertz_force(g, gd, kc, p, chi, vr)
    fs = F * math.sin(phi0 + Om * s)
    for i in range(N):
        out[i] = y[N + i]
        out[N + i] = part[i] * fs - cnd[i] * y[N + i] - knd[i] * y[i] - w[i] * f
    out[2 * N] = f * gd


@njit(cache=True)
def dp_step(hs, y0, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K, tmp, y1, sc_x, sc_v):
    """One DOPRI5 step of length ``hs`` from ``y0``; ``y1`` the 5th-order result; returns the
    error norm (max over eta and eta' of the estimate over ``atol + rtol |y|``)."""
    n = y0.shape[0]
    N = knd.shape[0]
    for i in range(7):
        for c in range(n):
            acc = y0[c]
            for j in range(i):
                acc += hs * DP_A[i, j] * K[j, c]
            tmp[c] = acc
        contact_rhs(DP_C[i] * hs, tmp, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K[i])
        if i == 6:
            break
    for c in range(n):
        acc = y0[c]
        for j in range(6):
            acc += hs * DP_A[6, j] * K[j, c]
        y1[c] = acc
    contact_rhs(hs, y1, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K[6])
    err = 0.0
    for c in range(2 * N):
        e = 0.0
        for j in range(7):
            e += hs * DP_E[j] * K[j, c]
        sc = (sc_x if c < N else sc_v) + HC_RTOL * max(abs(y0[c]), abs(y1[c]))
        err = max(err, abs(e) / sc)
    return err


@njit(cache=True)
def event_function(kind, y, s, phi0, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr):
    """Event functions of the contact phase, each rising through 0 at its event: 0 ``-g``
    (exit), 1 ``-(1 + chi g' / v_r)`` (exit), 2 ``-g'`` (largest penetration), 3 the sensor
    velocity (a minimum of the sensor), 5 minus it (a maximum), 4 ``-dF/dt`` (peak force)."""
    N = knd.shape[0]
    g = -DC
    gd = 0.0
    sd = 0.0
    for i in range(N):
        g += w[i] * y[i]
        gd += w[i] * y[N + i]
        sd += srow[i] * y[N + i]
    if kind == 0:
        return -g
    if kind == 1:
        return -(1.0 + chi * gd / vr)
    if kind == 2:
        return -gd
    if kind == 3:
        return sd
    if kind == 5:
        return -sd
    if g <= 0.0:
        return 0.0
    f = hysteretic_hertz_force(g, gd, kc, p, chi, vr)
    fs = F * math.sin(phi0 + Om * s)
    gdd = 0.0
    for i in range(N):
        gdd += w[i] * (part[i] * fs - cnd[i] * y[N + i] - knd[i] * y[i] - w[i] * f)
    return -(kc * p * g ** (p - 1.0) * gd * (1.0 + chi * gd / vr) + kc * g ** p * chi * gdd / vr)


@njit(cache=True)
def locate_event(kind, hs, y0, phi0, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr, K, tmp, y1, yhi):
    """Root in ``(0, hs]`` of an event rising through 0 (negative at 0, >= 0 at ``hs``, where the
    state is ``yhi``), by bisection on single DOPRI5 steps from ``y0``; returns the end with the
    event ``>= 0`` and leaves its state in ``yhi`` (``y1``: work array)."""
    lo = 0.0
    hi = hs
    n = y0.shape[0]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if not (lo < mid < hi):
            break
        dp_step(mid, y0, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K, tmp, y1, 1.0, 1.0)
        if event_function(kind, y1, mid, phi0, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr) >= 0.0:
            hi = mid
            for c in range(n):
                yhi[c] = y1[c]
        else:
            lo = mid
    return hi


@njit(cache=True)
def hc_contact_step(h, phi, y0, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr, rk, rec, ext, cs, y1):
    """One accepted DOPRI5 step (at most ``h``) of the beam's Hunt-Crossley contact phase from
    ``y0 = (eta, eta', 0)`` at forcing phase ``phi``.

    Parameters
    ----------
    rk : ndarray, shape (4,)
        Step-size estimate, the absolute error scales of ``eta`` and ``eta'``, and the
        contact's time scale (penetration over entry velocity; steps below 1e-12 of it fail).
    rec : bool
        Update the sensor extremes ``ext = [s_min, s_max, s_min of this period]`` (sensor
        displacement ``srow^T eta``, m).
    cs : ndarray, shape (4,)
        The open contact's ``[t_entry, peak force, largest g, work]``; updated.
    y1 : ndarray, shape (2N + 1,)
        Receives the state at the step's end (``E`` the work over the step).

    Returns
    -------
    s, event : float, int
        The step taken and :data:`EV_EXIT` (force back to zero) or :data:`EV_NONE`;
        ``s = -1``: the step size underflowed (failed).
    """
    n = y0.shape[0]
    N = knd.shape[0]
    K = np.empty((7, n))
    tmp = np.empty(n)
    yt = np.empty(n)
    ye = np.empty(n)
    yw = np.empty(n)
    h_min = 1e-12 * rk[3]
    err = 0.0
    while True:
        hs = min(rk[0], h)
        err = dp_step(hs, y0, phi, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K, tmp, y1, rk[1], rk[2])
        if err <= 1.0:
            break
        rk[0] = hs * max(0.1, 0.9 * err ** -0.2)
        if rk[0] < h_min or not rk[0] > 0.0:
            return -1.0, EV_NONE
    if hs == rk[0]:
        rk[0] = hs * min(5.0, 0.9 * err ** -0.2) if err > 0.0 else 5.0 * hs
    s_adv = hs
    ev = EV_NONE
    for c in range(n):
        ye[c] = y1[c]
    # events in order: the two exits (on the whole step; the earlier ends it), then on the
    # step as taken the largest penetration, the peak force and the sensor's minima / maxima
    for kind in range(6):
        if not rec and kind >= 3 and kind != 4:
            continue
        if kind == 2:
            for c in range(n):
                y1[c] = ye[c]
        g0 = event_function(kind, y0, 0.0, phi, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr)
        g1 = event_function(kind, y1, s_adv, phi, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr)
        if not (g1 >= 0.0 and (kind <= 1 or g0 < 0.0)):
            continue
        for c in range(n):
            yt[c] = y1[c]
        s_k = locate_event(kind, s_adv if kind > 1 else hs, y0, phi, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi,
                      vr, K, tmp, yw, yt)
        if kind <= 1:
            if s_k <= s_adv:
                s_adv = s_k
                ev = EV_EXIT
                for c in range(n):
                    ye[c] = yt[c]
            continue
        g = -DC
        gd = 0.0
        sv = 0.0
        for i in range(N):
            g += w[i] * yt[i]
            gd += w[i] * yt[N + i]
            sv += srow[i] * yt[i]
        if kind == 2:
            cs[2] = max(cs[2], g)
        elif kind == 4:
            cs[1] = max(cs[1], hysteretic_hertz_force(g, gd, kc, p, chi, vr))
        elif kind == 3:
            ext[0] = min(ext[0], sv)
            ext[2] = min(ext[2], sv)
        else:
            ext[1] = max(ext[1], sv)
    for c in range(n):
        y1[c] = ye[c]
    g = -DC
    gd = 0.0
    for i in range(N):
        g += w[i] * y1[i]
        gd += w[i] * y1[N + i]
    cs[1] = max(cs[1], hysteretic_hertz_force(g, gd, kc, p, chi, vr))
    cs[2] = max(cs[2], g)
    cs[3] += y1[2 * N]
    return s_adv, ev


@njit(cache=True)
def hc_variational_rhs(t, y, vr, dvr, DC, kc, pe, chi, knd, cnd, part, w, Om, Yb):
    """Right-hand side of a modal system's Hunt-Crossley contact phase and its variational
    equations: ``y = (eta, eta', J (2N, 2N + 2) row-major)``, ``J = d(eta, eta') / d(x0, Omega,
    Y)``; ``dvr`` (2N + 2,) the sensitivity of the contact's ``v_r``; ``w`` (N,) the stop's
    normal row (the contact row, negated for a lower stop) and ``DC`` its offset (m), ``kc``,
    ``pe``, ``chi`` the law; the load ``Gamma Omega^2 Y sin(Omega t)``.  The force is zero at
    entry and exit, so the phase has no saltation; its variational terms are ``df = f_g dg +
    f_g' dg' + f_vr dv_r`` (the derivative of the force along ``w``)."""
    N = knd.shape[0]
    n2 = 2 * N
    nc = n2 + 2
    g = -DC
    gd = 0.0
    for i in range(N):
        g += w[i] * y[i]
        gd += w[i] * y[N + i]
    dp = g if g > 0.0 else 0.0
    fac = 1.0 + chi * gd / vr
    f = kc * dp ** pe * fac
    F = Om * Om * Yb
    sn = math.sin(Om * t)
    cs = math.cos(Om * t)
    out = np.empty(y.shape[0])
    for i in range(N):
        out[i] = y[N + i]
        out[N + i] = part[i] * F * sn - cnd[i] * y[N + i] - knd[i] * y[i] - w[i] * f
    f_g = kc * pe * dp ** (pe - 1.0) * fac if dp > 0.0 else 0.0
    f_gd = kc * dp ** pe * chi / vr
    f_vr = -kc * dp ** pe * chi * gd / (vr * vr)
    for j in range(nc):
        wq = 0.0
        wv = 0.0
        for i in range(N):
            wq += w[i] * y[n2 + i * nc + j]
            wv += w[i] * y[n2 + (N + i) * nc + j]
        df = f_g * wq + f_gd * wv + f_vr * dvr[j]
        for i in range(N):
            out[n2 + i * nc + j] = y[n2 + (N + i) * nc + j]
            out[n2 + (N + i) * nc + j] = -knd[i] * y[n2 + i * nc + j] - cnd[i] * y[n2 + (N + i) * nc + j] - w[i] * df
    for i in range(N):
        out[n2 + (N + i) * nc + n2] += part[i] * (2.0 * Om * Yb * sn + F * t * cs)
        out[n2 + (N + i) * nc + n2 + 1] += part[i] * Om * Om * sn
    return out
