"""One step of a compliant contact phase of the event integrator, and its events.

The event integrator (:mod:`vibeam.models.core.integrator`) calls :func:`linear_step` while only
Kelvin-Voigt stops are in contact (the exact flow of :mod:`vibeam.models.core.phases`, every event
located by the certified scans of :mod:`vibeam.models.core.signals`) and :func:`rk_phase_step`
while a hysteretic-Hertz stop is (the Runge-Kutta step of :mod:`vibeam.models.core.rk`).  Both
advance the state ``(eta, eta')`` in place by one step of at most ``h`` and say how the step ended:

``EK_NONE``     the whole step;
``EK_EXIT``     stop ``k``'s contact force returned to zero (``aux``: 1 by a hysteretic-Hertz
                stop's damping factor, the body left inside the stop);
``EK_ENTRY``    a compliant stop ``k`` not in contact starts one (its gap up through zero, or the
                sign of its force up through zero inside it);
``EK_IMPACT``   a Newton stop ``k``'s gap reached zero (the integrator applies the law);
``EK_RELEASE``  held stop ``k``'s constraint force turned positive;
``EK_GAPDOWN``  the gap of stop ``k``, inside which the body was, fell back through zero;
``EK_FAIL``     no step could be taken in double precision.

On the way each step updates the open contacts' records ``cs[k] = [t_entry, peak force, largest
penetration, work on the stop, entry velocity]`` (peak force and penetration at the step's ends and
interior maxima, the work by 8-point Gauss-Legendre on the exact flow or integrated with the state)
and, while recording, the sensor's extremes ``pext``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..contact import LAW_LINEAR
from .laws import ATOL, contact_scales, force, inside_sign
from .rk import (EVF_EXIT_DAMPING, EVF_EXIT_FORCE, EVF_EXIT_GAP, EVF_GAP, EVF_GAP_DOWN, EVF_INSIDE, EVF_MAX_PEN,
                 EVF_PEAK_FORCE, EVF_RELEASE, EVF_SENSOR_MAX, EVF_SENSOR_MIN, event_value, locate, rk_step)
from .signals import bounds, extremes, homogeneous_bounds, scan, signal, signal_start
from ..system import transition_increment

__all__ = ["EK_NONE", "EK_EXIT", "EK_ENTRY", "EK_IMPACT", "EK_RELEASE", "EK_GAPDOWN", "EK_FAIL", "linear_step",
           "rk_phase_step", "phase_harmonics", "GL_X", "GL_W"]

EK_NONE, EK_EXIT, EK_ENTRY, EK_IMPACT, EK_RELEASE, EK_GAPDOWN, EK_FAIL = 0, 1, 2, 3, 4, 5, -1

# Gauss-Legendre, 8 nodes on [0, 1] (the work of a linear contact phase)
_X, _W = np.polynomial.legendre.leggauss(8)
GL_X = 0.5 * (_X + 1.0)
GL_W = 0.5 * _W


@njit(cache=True, _nrt=False, error_model="numpy")
def phase_harmonics(cp, Om, F, ax, bx, ay, by):
    """The forced response ``x_p = ax sin + bx cos``, ``y_p = ay sin + by cos`` of every oscillator
    of every linear contact phase at forcing ``F sin(Om t)``: ``(i Om - A_j) Z = (f_x, f_y) F`` per
    pair, ``A_j = [[0, 1], [-k, -c]]``.  ``cp`` None (a scene that reaches no linear phase,
    :class:`vibeam.models.core.phases.Compliant`): nothing to do, and nothing compiled."""
    if cp is None:
        return
    for q in range(cp.m.shape[0]):
        for j in range(cp.m[q]):
            c = 2.0 * cp.mp[q, j, 0]
            k = cp.mp[q, j, 1]
            det = complex(k - Om * Om, c * Om)
            fx = cp.fx[q, j] * F
            fy = cp.fy[q, j] * F
            zx = (complex(c, Om) * fx + fy) / det
            zy = (-k * fx + complex(0.0, Om) * fy) / det
            ax[q, j] = zx.real
            bx[q, j] = zx.imag
            ay[q, j] = zy.real
            by[q, j] = zy.imag


@njit(cache=True, _nrt=False, error_model="numpy")
def _harm(p, r, ax, bx, ay, by, m):
    """Harmonic part ``(Sa, Sb)`` of a signal with weights ``p``, ``r`` on a phase's oscillators."""
    sa = 0.0
    sb = 0.0
    for j in range(m):
        sa += p[j] * ax[j] + r[j] * ay[j]
        sb += p[j] * bx[j] + r[j] * by[j]
    return sa, sb


@njit(cache=True, _nrt=False, error_model="numpy")
def _mag(hb, p, r, Cs, Om, m, order):
    """A bound of a signal's derivative of ``order`` (0-3) along the phase (its round-off scale)."""
    b = Cs * Om ** order
    for j in range(m):
        b += abs(p[j]) * hb[j, order] + abs(r[j]) * hb[j, order + 1]
    return b


@njit(cache=True, _nrt=False, error_model="numpy")
def _combo(a0, p0, r0, a1, p1, r1, wp, wr, m):
    """``wp = a0 p0 + a1 p1``, ``wr = a0 r0 + a1 r1`` (weights of a combination of two signals)."""
    for j in range(m):
        wp[j] = a0 * p0[j] + a1 * p1[j]
        wr[j] = a0 * r0[j] + a1 * r1[j]


@njit(cache=True, _nrt=False, error_model="numpy")
def linear_step(q, H, C, inside, relaxed, h, h_min, phi, Om, F, eta, etad, st, hs, cp, cw, fresh, recording, pext):
    """One step of the linear contact phase ``q`` (held set ``H``, contact set ``C``) of at most ``h``.

    Parameters
    ----------
    inside, relaxed : int
        Bit masks of the stops the body is inside of without contact, and of those left by a
        hysteretic-Hertz stop's damping factor.
    h_min : float
        Smallest step of a certified scan.
    eta, etad : ndarray, shape (n,)
        The state, advanced in place.
    st, hs, cp : KernelStops, HeldSets, ContactPhases
        (``cp`` None: the scene reaches no linear phase, :class:`vibeam.models.core.phases.Compliant`;
        the step fails, and numba compiles nothing of it.)
    cw : vibeam.models.core.integrator._CompliantWork
        The compliant stops' work record of the call, whose arrays this step reads and writes:
        ``pax, pbx, pay, pby`` (Q, n) :func:`phase_harmonics` at this frequency; ``xq, yq`` (n,)
        the oscillators' homogeneous parts, carried from step to step of one phase (recomputed
        from the state when ``fresh``), advanced in place; ``vr`` (n_s,) the entry velocities of
        the open contacts; ``cs`` (n_s, 5) their records, updated; ``hbq`` (n, 6) the
        oscillators' bounds, ``wpa, wra, wpb, wrb`` (n,) signal weights and ``ext2`` (2,): work
        arrays.
    pext : ndarray, shape (2,)
        Sensor extremes of the period, updated while ``recording``.

    Returns
    -------
    s, kind, stop, aux : float, int, int, int
        The step taken, how it ended (module docstring) and the stop of the event.
    """
    if cp is None:
        return -1.0, EK_FAIL, -1, 0
    n = eta.shape[0]
    ns = st.offset.shape[0]
    m = cp.m[q]
    mp = cp.mp[q]
    if not cp.hcap[q] > 0.0:
        return -1.0, EK_FAIL, -1, 0       # a phase not resolved in double precision (phases.UnresolvedPhase)
    sp0 = math.sin(phi)
    cp0 = math.cos(phi)
    axq, bxq, ayq, byq = cw.pax[q], cw.pbx[q], cw.pay[q], cw.pby[q]
    xh, yh, hb, vr, cs = cw.xq, cw.yq, cw.hbq, cw.vr, cw.cs
    wp, wr, wp2, wr2, ext2 = cw.wpa, cw.wra, cw.wpb, cw.wrb, cw.ext2
    if fresh:
        for j in range(m):
            xs = 0.0
            ys = 0.0
            for i in range(n):
                de = eta[i] - cp.ze[q, i]
                dv = etad[i] - cp.ze[q, n + i]
                xs += cp.Tix[q, j, i] * de + cp.Tix[q, j, n + i] * dv
                ys += cp.Tiy[q, j, i] * de + cp.Tiy[q, j, n + i] * dv
            xh[j] = xs - (axq[j] * sp0 + bxq[j] * cp0)
            yh[j] = ys - (ayq[j] * sp0 + byq[j] * cp0)
    for j in range(m):
        homogeneous_bounds(xh[j], yh[j], mp[j, 0], mp[j, 1], int(mp[j, 2]), mp[j, 3], mp[j, 4], mp[j, 5], hb[j])
    hh = min(h, cp.hcap[q])
    s_ev = -1.0
    k_ev = -1
    kind = EK_NONE
    # ---- exits: the force of each stop in contact back down through zero
    for k in range(ns):
        if (C >> k) & 1 == 0:
            continue
        kc = st.kc[k]
        cc = st.cc[k]
        _combo(-kc, cp.pg[q, k], cp.rg[q, k], -cc, cp.pv[q, k], cp.rv[q, k], wp, wr, m)
        Sa, Sb = _harm(wp, wr, axq, bxq, ayq, byq, m)
        f0, fp0 = signal_start(phi, Om, xh, yh, mp, wp, wr, Sa, Sb, -kc * cp.gc[q, k], m)
        Cs = math.sqrt(Sa * Sa + Sb * Sb)
        # the force is known to the round-off of the gap n^T eta - D and the rate n^T eta' it is
        # formed of: just after an entry (located on the free flow, the gap 0 there to that
        # round-off) an undamped stop's force k g must not count as an exit
        gsc = abs(st.offset[k])
        vsc = 0.0
        for i in range(n):
            gsc += abs(st.normal[k, i] * eta[i])
            vsc += abs(st.normal[k, i] * etad[i])
        tol0 = 1e-13 * (_mag(hb, wp, wr, Cs, Om, m, 0) + abs(kc * cp.gc[q, k]) + kc * gsc + abs(cc) * vsc)
        tol1 = 1e-13 * _mag(hb, wp, wr, Cs, Om, m, 1)
        if f0 > tol0 or (f0 >= -tol0 and fp0 > tol1):
            return 0.0, EK_EXIT, k, 0
        if f0 >= -tol0 and fp0 >= -tol1:
            # the force and its rate are zero to round-off (a contact entered at rest, g = g' = 0):
            # the force's sign is round-off until it grows, so the exit is its fall below -tol0, not
            # a crossing of zero by round-off (a contact of duration 5e-17, then entered again)
            f0 -= tol0
        M2, M3, M4 = bounds(hb, wp, wr, Cs, Om, m)
        hk = hh if s_ev < 0.0 else s_ev
        sk, hk2 = scan(hk, h_min, phi, Om, xh, yh, mp, wp, wr, Sa, Sb, f0, fp0, M2, M3, M4, m)
        if sk >= 0.0:
            s_ev = sk
            k_ev = k
            kind = EK_EXIT
        elif hk2 < hk:
            s_ev = -1.0
            k_ev = -1
            kind = EK_NONE
            hh = hk2
    # ---- the other stops: entries, impacts, releases
    for j in range(ns):
        if (C >> j) & 1:
            continue
        if (H >> j) & 1:
            # a held stop's constraint force up through zero: its release
            for i in range(m):
                wp[i] = cp.pl[q, j, i]
                wr[i] = cp.rl[q, j, i]
            Sa, Sb = _harm(wp, wr, axq, bxq, ayq, byq, m)
            Sa += cp.lF[q, j] * F
            f0, fp0 = signal_start(phi, Om, xh, yh, mp, wp, wr, Sa, Sb, cp.lc[q, j], m)
            Cs = math.sqrt(Sa * Sa + Sb * Sb)
            tol0 = 1e-13 * (_mag(hb, wp, wr, Cs, Om, m, 0) + abs(cp.lc[q, j]))
            if f0 > tol0:
                return 0.0, EK_RELEASE, j, 0
            M2, M3, M4 = bounds(hb, wp, wr, Cs, Om, m)
            hk = hh if s_ev < 0.0 else s_ev
            sk, hk2 = scan(hk, h_min, phi, Om, xh, yh, mp, wp, wr, Sa, Sb, f0, fp0, M2, M3, M4, m)
            if sk >= 0.0:
                s_ev = sk
                k_ev = j
                kind = EK_RELEASE
            elif hk2 < hk:
                s_ev = -1.0
                k_ev = -1
                kind = EK_NONE
                hh = hk2
            continue
        if H != 0 and hs.moves[H, j] == 0:
            continue
        for i in range(m):
            wp2[i] = cp.pg[q, j, i]
            wr2[i] = cp.rg[q, j, i]
        Sg, Sgb = _harm(wp2, wr2, axq, bxq, ayq, byq, m)
        g0, gp0 = signal_start(phi, Om, xh, yh, mp, wp2, wr2, Sg, Sgb, cp.gc[q, j], m)
        Cg = math.sqrt(Sg * Sg + Sgb * Sgb)
        if (inside >> j) & 1:
            r0, r1, roff = inside_sign(st.law[j], st.kc[j], st.cc[j], vr[j], (relaxed >> j) & 1 == 1)
            _combo(r0, cp.pg[q, j], cp.rg[q, j], r1, cp.pv[q, j], cp.rv[q, j], wp, wr, m)
            Sa, Sb = _harm(wp, wr, axq, bxq, ayq, byq, m)
            Cs = math.sqrt(Sa * Sa + Sb * Sb)
            c0 = r0 * cp.gc[q, j] + roff
            f0, fp0 = signal_start(phi, Om, xh, yh, mp, wp, wr, Sa, Sb, c0, m)
            tol0 = 1e-13 * (_mag(hb, wp, wr, Cs, Om, m, 0) + abs(c0))
            tol1 = 1e-13 * _mag(hb, wp, wr, Cs, Om, m, 1)
            if f0 > tol0 or (f0 >= -tol0 and fp0 > tol1):
                return 0.0, EK_ENTRY, j, 0
            M2, M3, M4 = bounds(hb, wp, wr, Cs, Om, m)
            hk = hh if s_ev < 0.0 else s_ev
            sk, hk2 = scan(hk, h_min, phi, Om, xh, yh, mp, wp, wr, Sa, Sb, f0, fp0, M2, M3, M4, m)
            if sk >= 0.0:
                s_ev = sk
                k_ev = j
                kind = EK_ENTRY
            elif hk2 < hk:
                s_ev = -1.0
                k_ev = -1
                kind = EK_NONE
                hh = hk2
            # the gap back down through zero
            for i in range(m):
                wp[i] = -wp2[i]
                wr[i] = -wr2[i]
            M2, M3, M4 = bounds(hb, wp, wr, Cg, Om, m)
            hk = hh if s_ev < 0.0 else s_ev
            sk, hk2 = scan(hk, h_min, phi, Om, xh, yh, mp, wp, wr, -Sg, -Sgb, -g0, -gp0, M2, M3, M4, m)
            if sk >= 0.0:
                s_ev = sk
                k_ev = j
                kind = EK_GAPDOWN
            elif hk2 < hk:
                s_ev = -1.0
                k_ev = -1
                kind = EK_NONE
                hh = hk2
            continue
        tolg = 1e-13 * (_mag(hb, wp2, wr2, Cg, Om, m, 0) + abs(cp.gc[q, j]))
        if g0 >= -tolg and gp0 > 0.0:
            return 0.0, EK_ENTRY if st.law[j] != 0 else EK_IMPACT, j, 0
        M2, M3, M4 = bounds(hb, wp2, wr2, Cg, Om, m)
        hk = hh if s_ev < 0.0 else s_ev
        sk, hk2 = scan(hk, h_min, phi, Om, xh, yh, mp, wp2, wr2, Sg, Sgb, g0, gp0, M2, M3, M4, m)
        if sk >= 0.0:
            s_ev = sk
            k_ev = j
            kind = EK_ENTRY if st.law[j] != 0 else EK_IMPACT
        elif hk2 < hk:
            s_ev = -1.0
            k_ev = -1
            kind = EK_NONE
            hh = hk2
    s_mv = s_ev if s_ev >= 0.0 else hh
    if not s_mv >= 0.0:
        return -1.0, EK_FAIL, -1, 0
    # ---- the open contacts' records over [0, s_mv]: peak force, largest penetration, work
    for k in range(ns):
        if (C >> k) & 1 == 0:
            continue
        kc = st.kc[k]
        cc = st.cc[k]
        for i in range(m):
            wp2[i] = cp.pg[q, k, i]
            wr2[i] = cp.rg[q, k, i]
        Sg, Sgb = _harm(wp2, wr2, axq, bxq, ayq, byq, m)
        g0, gp0 = signal_start(phi, Om, xh, yh, mp, wp2, wr2, Sg, Sgb, cp.gc[q, k], m)
        # the force k g + c g' as a signal
        _combo(kc, cp.pg[q, k], cp.rg[q, k], cc, cp.pv[q, k], cp.rv[q, k], wp, wr, m)
        Sa, Sb = _harm(wp, wr, axq, bxq, ayq, byq, m)
        f0, fp0 = signal_start(phi, Om, xh, yh, mp, wp, wr, Sa, Sb, kc * cp.gc[q, k], m)
        f1, fp1, _a, _b, _c = signal(s_mv, phi, Om, xh, yh, mp, wp, wr, Sa, Sb, f0, fp0, m)
        ext2[0] = np.inf
        ext2[1] = max(f0, f1)
        extremes(s_mv, phi, Om, xh, yh, mp, wp, wr, Sa, Sb, f0, fp0, fp0, fp1, ext2, m)
        if ext2[1] > cs[k, 1]:
            cs[k, 1] = ext2[1]
        g1, gp1, _a, _b, _c = signal(s_mv, phi, Om, xh, yh, mp, wp2, wr2, Sg, Sgb, g0, gp0, m)
        ext2[0] = np.inf
        ext2[1] = max(g0, g1)
        extremes(s_mv, phi, Om, xh, yh, mp, wp2, wr2, Sg, Sgb, g0, gp0, gp0, gp1, ext2, m)
        if ext2[1] > cs[k, 2]:
            cs[k, 2] = ext2[1]
        acc = 0.0
        for i in range(GL_X.shape[0]):
            gi, gpi, _a, _b, _c = signal(GL_X[i] * s_mv, phi, Om, xh, yh, mp, wp2, wr2, Sg, Sgb, g0, gp0, m)
            acc += GL_W[i] * (kc * gi + cc * gpi) * gpi
        cs[k, 3] += acc * s_mv
    if recording:
        for i in range(m):
            wp2[i] = cp.ps[q, i]
            wr2[i] = cp.rs[q, i]
        Sg, Sgb = _harm(wp2, wr2, axq, bxq, ayq, byq, m)
        q0, qp0 = signal_start(phi, Om, xh, yh, mp, wp2, wr2, Sg, Sgb, cp.sc[q], m)
        q1, qp1, _a, _b, _c = signal(s_mv, phi, Om, xh, yh, mp, wp2, wr2, Sg, Sgb, q0, qp0, m)
        extremes(s_mv, phi, Om, xh, yh, mp, wp2, wr2, Sg, Sgb, q0, qp0, qp0, qp1, pext, m)
    # ---- advance the oscillators and recompose the state
    for j in range(m):
        a11, a12, a21, a22 = transition_increment(s_mv, mp[j, 0], mp[j, 1], int(mp[j, 2]), mp[j, 3], mp[j, 4],
                                                  mp[j, 5])
        dx = a11 * xh[j] + a12 * yh[j]
        dy = a21 * xh[j] + a22 * yh[j]
        xh[j] += dx
        yh[j] += dy
    p1 = phi + Om * s_mv
    sp1 = math.sin(p1)
    cp1 = math.cos(p1)
    for i in range(n):
        eta[i] = cp.ze[q, i]
        etad[i] = cp.ze[q, n + i]
    for j in range(m):
        xt = xh[j] + axq[j] * sp1 + bxq[j] * cp1
        yt = yh[j] + ayq[j] * sp1 + byq[j] * cp1
        for i in range(n):
            eta[i] += cp.Tx[q, i, j] * xt + cp.Ty[q, i, j] * yt
            etad[i] += cp.Tx[q, n + i, j] * xt + cp.Ty[q, n + i, j] * yt
    return s_mv, kind, k_ev, 0


@njit(cache=True, _nrt=False, error_model="numpy")
def rk_phase_step(H, C, inside, relaxed, h, phi, Om, F, eta, etad, sy, st, hs, tab, cw, recording, pext):
    """One accepted Runge-Kutta step of at most ``h`` of the contact phase ``(H, C)`` (any
    compliant laws; :mod:`vibeam.models.core.rk`).

    Parameters
    ----------
    tab : vibeam.models.core.rk.Tableau or None
        The Runge-Kutta pair (None: the scene reaches no phase that is not linear,
        :class:`vibeam.models.core.phases.Compliant`; the step fails, and numba compiles nothing
        of it).
    cw : vibeam.models.core.integrator._CompliantWork
        The compliant stops' work record of the call: ``rkc`` (4,) the phase's step control
        (:func:`vibeam.models.core.rk.rk_step`), carried; ``ry0, ry1, rtmp, ryt, ryw, rye, racc``
        (2n + n_s,) and ``rK`` (stages, 2n + n_s) work arrays; ``vr``, ``cs`` as in
        :func:`linear_step`.
    (others)
        As :func:`linear_step`.

    Returns
    -------
    s, kind, stop, aux : float, int, int, int
        As :func:`linear_step`; ``aux`` 1 for an exit by a hysteretic-Hertz stop's damping factor.
    """
    if tab is None:
        return -1.0, EK_FAIL, -1, 0
    vr, rk, cs = cw.vr, cw.rkc, cw.cs
    y0, y1, K, tmp, yt, yw, ye, acc = cw.ry0, cw.ry1, cw.rK, cw.rtmp, cw.ryt, cw.ryw, cw.rye, cw.racc
    n = eta.shape[0]
    ns = st.offset.shape[0]
    m = n if H == 0 else hs.nc[H]
    L = 2 * m + ns
    if H == 0:
        for i in range(n):
            y0[i] = eta[i]
            y0[n + i] = etad[i]
    else:
        for j in range(m):
            z = 0.0
            zd = 0.0
            for i in range(n):
                z += hs.Psi[H, i, j] * (eta[i] - hs.eta_c[H, i])
                zd += hs.Psi[H, i, j] * etad[i]
            y0[j] = z
            y0[m + j] = zd
    for k in range(ns):
        y0[2 * m + k] = 0.0
    # a contact whose force is not positive now ends at once
    for k in range(ns):
        if (C >> k) & 1:
            if st.law[k] == LAW_LINEAR:
                if event_value(EVF_EXIT_FORCE, k, y0, 0.0, phi, Om, F, sy, st, hs, H, C, vr, relaxed, acc) > 0.0:
                    return 0.0, EK_EXIT, k, 0
            elif event_value(EVF_EXIT_DAMPING, k, y0, 0.0, phi, Om, F, sy, st, hs, H, C, vr, relaxed, acc) > 0.0:
                return 0.0, EK_EXIT, k, 1
    s1 = rk_step(h, y0, phi, Om, F, sy, st, hs, H, C, vr, tab, rk, K, tmp, y1)
    if s1 < 0.0:
        return -1.0, EK_FAIL, -1, 0
    s_adv = s1
    kind = EK_NONE
    k_ev = -1
    aux = 0
    for c in range(L):
        ye[c] = y1[c]
    # ---- events that end the step (located on the whole accepted step; the earliest wins)
    for k in range(ns):
        moving = H == 0 or hs.moves[H, k] == 1
        for e in range(2):
            ev = -1
            if (C >> k) & 1:
                if st.law[k] == LAW_LINEAR:
                    ev = EVF_EXIT_FORCE if e == 0 else -1
                else:
                    ev = EVF_EXIT_GAP if e == 0 else EVF_EXIT_DAMPING
                need_neg = False
            elif (H >> k) & 1:
                ev = EVF_RELEASE if e == 0 else -1
                need_neg = True
            elif moving and (inside >> k) & 1:
                ev = EVF_INSIDE if e == 0 else EVF_GAP_DOWN
                need_neg = True
            elif moving:
                ev = EVF_GAP if e == 0 else -1
                need_neg = True
            if ev < 0:
                continue
            v1 = event_value(ev, k, y1, s1, phi, Om, F, sy, st, hs, H, C, vr, relaxed, acc)
            if not v1 >= 0.0:
                continue
            if need_neg and not event_value(ev, k, y0, 0.0, phi, Om, F, sy, st, hs, H, C, vr, relaxed, acc) < 0.0:
                continue
            for c in range(L):
                yt[c] = y1[c]
            sk = locate(ev, k, s1, y0, phi, Om, F, sy, st, hs, H, C, vr, relaxed, tab, K, tmp, yw, yt, acc)
            if sk <= s_adv:
                s_adv = sk
                k_ev = k
                aux = 0
                if ev == EVF_EXIT_GAP or ev == EVF_EXIT_FORCE:
                    kind = EK_EXIT
                elif ev == EVF_EXIT_DAMPING:
                    kind = EK_EXIT
                    aux = 1
                elif ev == EVF_RELEASE:
                    kind = EK_RELEASE
                elif ev == EVF_INSIDE:
                    kind = EK_ENTRY
                elif ev == EVF_GAP_DOWN:
                    kind = EK_GAPDOWN
                else:
                    kind = EK_ENTRY if st.law[k] != 0 else EK_IMPACT
                for c in range(L):
                    ye[c] = yt[c]
    # ---- the records over [0, s_adv]: largest penetration, peak force, sensor extremes
    for k in range(ns + 1):
        for ev in (EVF_MAX_PEN, EVF_PEAK_FORCE, EVF_SENSOR_MIN, EVF_SENSOR_MAX):
            if k < ns and ((C >> k) & 1 == 0 or ev == EVF_SENSOR_MIN or ev == EVF_SENSOR_MAX):
                continue
            if k == ns and (not recording or ev == EVF_MAX_PEN or ev == EVF_PEAK_FORCE):
                continue
            g0 = event_value(ev, k, y0, 0.0, phi, Om, F, sy, st, hs, H, C, vr, relaxed, acc)
            g1 = event_value(ev, k, ye, s_adv, phi, Om, F, sy, st, hs, H, C, vr, relaxed, acc)
            if not (g0 < 0.0 <= g1):
                continue
            for c in range(L):
                yt[c] = ye[c]
            locate(ev, k, s_adv, y0, phi, Om, F, sy, st, hs, H, C, vr, relaxed, tab, K, tmp, yw, yt, acc)
            if ev == EVF_MAX_PEN or ev == EVF_PEAK_FORCE:
                g, gd = _gap_of(k, yt, H, sy, st, hs, m)
                if ev == EVF_MAX_PEN:
                    cs[k, 2] = max(cs[k, 2], g)
                else:
                    cs[k, 1] = max(cs[k, 1], force(st.law[k], g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k]))
            else:
                sv = _sensor_of(yt, H, sy, hs, m)
                if ev == EVF_SENSOR_MIN:
                    pext[0] = min(pext[0], sv)
                else:
                    pext[1] = max(pext[1], sv)
    # ---- the state at the step's end
    for k in range(ns):
        if (C >> k) & 1:
            g, gd = _gap_of(k, ye, H, sy, st, hs, m)
            cs[k, 1] = max(cs[k, 1], force(st.law[k], g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k]))
            cs[k, 2] = max(cs[k, 2], g)
            cs[k, 3] += ye[2 * m + k]
    if H == 0:
        for i in range(n):
            eta[i] = ye[i]
            etad[i] = ye[n + i]
    else:
        for i in range(n):
            e = hs.eta_c[H, i]
            ed = 0.0
            for j in range(m):
                e += hs.Psi[H, i, j] * ye[j]
                ed += hs.Psi[H, i, j] * ye[m + j]
            eta[i] = e
            etad[i] = ed
    return s_adv, kind, k_ev, aux


@njit(cache=True, _nrt=False, error_model="numpy")
def _gap_of(k, y, H, sy, st, hs, m):
    n = sy.k.shape[0]
    if H == 0:
        g = -st.offset[k]
        gd = 0.0
        for i in range(n):
            g += st.normal[k, i] * y[i]
            gd += st.normal[k, i] * y[m + i]
        return g, gd
    g = hs.cG[H, k]
    gd = 0.0
    for j in range(m):
        g += hs.pG[H, k, j] * (y[j] - hs.e[H, j])
        gd += hs.pG[H, k, j] * y[m + j]
    return g, gd


@njit(cache=True, _nrt=False, error_model="numpy")
def _sensor_of(y, H, sy, hs, m):
    n = sy.k.shape[0]
    v = 0.0
    if H == 0:
        for i in range(n):
            v += sy.sensor[i] * y[i]
        return v
    v = hs.cS[H]
    for j in range(m):
        v += hs.pS[H, j] * (y[j] - hs.e[H, j])
    return v


@njit(cache=True, _nrt=False, error_model="numpy")
def rk_scales(H, C, sy, st, hs, vr, rk):
    """Step control of a Runge-Kutta contact phase entered now: the first step, the error scales of
    the coordinates and velocities and the smallest step, from the isolated contacts of the stops in
    contact (:func:`vibeam.models.core.laws.contact_scales`; the smallest over them)."""
    ax = np.inf
    av = np.inf
    dur = np.inf
    for k in range(st.offset.shape[0]):
        if (C >> k) & 1 == 0:
            continue
        nn = 1.0 / st.m_eff[k]
        pen, d = contact_scales(st.law[k], st.kc[k], st.pe[k], nn, vr[k])
        wn = math.sqrt(nn)
        ax = min(ax, pen / wn)
        av = min(av, abs(vr[k]) / wn)
        dur = min(dur, d)
    rk[0] = 1e-3 * dur
    rk[1] = ATOL * ax
    rk[2] = ATOL * av
    rk[3] = 1e-12 * dur
