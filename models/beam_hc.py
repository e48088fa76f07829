"""The modal FE beam on a Hunt-Crossley stop: free flight exact, contact phase integrated.

Model (kernel units of :mod:`vibeam.models.beam_compliant`: time ``t = omega_ref t~``, modal
coordinates ``eta``, contact displacement ``U = w^T eta`` in m, gap ``g = U - Delta_C``)::

    free     eta'' + C eta' + K eta = Gamma F sin(Omega t)                        (g < 0)
    contact  eta'' + C eta' + K eta + w k g^p (1 + chi g' / v_in) = Gamma F sin(Omega t)

with ``k = k_c / omega_ref^2`` (``k_c`` in N/m^p), ``chi = 8 (1 - R) / (5 R)`` (Flores et al.
2011, :class:`vibeam.models.compliant.HuntCrossley`) and ``v_in`` the contact's entry velocity
``g'`` (floored at ``1e-2 Omega Y |w^T Gamma|``, the SDOF's floor ``1e-2 Omega B`` for one
mode).  Along the relation's normal the stop acts on the effective mass ``m_eff = 1 / |w|^2``:
an isolated contact is the SDOF law's with stiffness ``k / m_eff``, and since the Flores
relation makes the restitution a function of ``chi`` only, the beam's isolated contact has the
SDOF value for the same ``chi`` at any ``k_c``, ``m_eff`` and ``v_in`` (the tests check it).

Free flight is the exact modal flow of :mod:`vibeam.models.beam_compliant` (the free phase's
eigendecomposition; contact entry located by the same certified scan,
:func:`vibeam.models.beam_compliant.free_scan`).  The contact phase is integrated by
Dormand-Prince 5(4) on ``(eta, eta', E)`` (``E' = f g'``, the work done on the stop), relative
tolerance 1e-11 (:data:`vibeam.models.sdof_compliant.HC_RTOL`, absolute ones scaled by the
isolated contact's penetration and the entry velocity along ``w``), its events -- the exit
where the force returns to zero (``g`` back to 0, or the damping factor ``1 + chi g' / v_in``
to 0), the largest penetration, the peak force and the sensor's extrema -- located by
bisection on single steps from the accepted step's start, as the SDOF kernel does
(:func:`vibeam.models.sdof_compliant.hc_advance`).  Explicit steps resolve the fastest retained
mode: this suits few modes (the high modes of an ``"all"``-mode model make the contact phase
stiff and slow).  One stop only.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .beam_compliant import (CONTACT, EV_ENTRY, EV_EXIT, EV_NONE, FREE, TWO_PI, signal_combo, free_scan,
                             modal_coordinates, signal_derivatives, modal_state, bupcross, STALL, MAX_STEP_MODES_PER_CALL)
from .dormand_prince import DP_A, DP_C, DP_E
from .sdof_compliant import HC_ATOL, HC_RTOL, HC_V_FLOOR
from .trajectory import Trajectory, call_budget


@njit(cache=True)
def _force(g, gd, kc, p, chi, vr):
    if g <= 0.0:
        return 0.0
    return kc * g ** p * (1.0 + chi * gd / vr)


@njit(cache=True)
def _rhs(s, y, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, out):
    """``y = (eta, eta', E)`` of the contact phase (module docstring)."""
    N = knd.shape[0]
    g = -DC
    gd = 0.0
    for i in range(N):
        g += w[i] * y[i]
        gd += w[i] * y[N + i]
    f = _force(g, gd, kc, p, chi, vr)
    fs = F * math.sin(phi0 + Om * s)
    for i in range(N):
        out[i] = y[N + i]
        out[N + i] = part[i] * fs - cnd[i] * y[N + i] - knd[i] * y[i] - w[i] * f
    out[2 * N] = f * gd


@njit(cache=True)
def _dp_step(hs, y0, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K, tmp, y1, sc_x, sc_v):
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
        _rhs(DP_C[i] * hs, tmp, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K[i])
        if i == 6:
            break
    for c in range(n):
        acc = y0[c]
        for j in range(6):
            acc += hs * DP_A[6, j] * K[j, c]
        y1[c] = acc
    _rhs(hs, y1, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K[6])
    err = 0.0
    for c in range(2 * N):
        e = 0.0
        for j in range(7):
            e += hs * DP_E[j] * K[j, c]
        sc = (sc_x if c < N else sc_v) + HC_RTOL * max(abs(y0[c]), abs(y1[c]))
        err = max(err, abs(e) / sc)
    return err


@njit(cache=True)
def _event(kind, y, s, phi0, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr):
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
    f = _force(g, gd, kc, p, chi, vr)
    fs = F * math.sin(phi0 + Om * s)
    gdd = 0.0
    for i in range(N):
        gdd += w[i] * (part[i] * fs - cnd[i] * y[N + i] - knd[i] * y[i] - w[i] * f)
    return -(kc * p * g ** (p - 1.0) * gd * (1.0 + chi * gd / vr) + kc * g ** p * chi * gdd / vr)


@njit(cache=True)
def _locate(kind, hs, y0, phi0, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr, K, tmp, y1, yhi):
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
        _dp_step(mid, y0, phi0, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K, tmp, y1, 1.0, 1.0)
        if _event(kind, y1, mid, phi0, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr) >= 0.0:
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
        err = _dp_step(hs, y0, phi, F, Om, knd, cnd, part, w, DC, kc, p, chi, vr, K, tmp, y1, rk[1], rk[2])
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
        g0 = _event(kind, y0, 0.0, phi, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr)
        g1 = _event(kind, y1, s_adv, phi, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi, vr)
        if not (g1 >= 0.0 and (kind <= 1 or g0 < 0.0)):
            continue
        for c in range(n):
            yt[c] = y1[c]
        s_k = _locate(kind, s_adv if kind > 1 else hs, y0, phi, F, Om, knd, cnd, part, w, srow, DC, kc, p, chi,
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
            cs[1] = max(cs[1], _force(g, gd, kc, p, chi, vr))
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
    cs[1] = max(cs[1], _force(g, gd, kc, p, chi, vr))
    cs[2] = max(cs[2], g)
    cs[3] += y1[2 * N]
    return s_adv, ev


@njit(cache=True)
def beam_hc_kernel(Om, lam, V, W, Z, PU, PS, bU, bS, wrow, srow, knd, cnd, part, F, kc, p, chi, DC, v_floor,
                   z0, phase0, n_transient, n_record, ns_transient, ns_record, hmax, max_contacts, max_steps,
                   samples, pmin, imp_t, imp_v, con, msamp):
    """Simulate whole forcing periods; the numba core of :class:`HuntCrossleyBeamEventSolver`.

    ``lam`` (2N,), ``V``, ``W`` (2N, 2N), ``Z`` (2N,): eigen-data and forced response of the
    free phase; ``PU``, ``PS`` (2N,) the contact and sensor rows times ``V``, ``bU``, ``bS``
    their forced coefficients; ``knd``, ``cnd``, ``part`` (N,) modal stiffness, damping and
    participation; ``F = Om^2 Y``; ``kc``, ``p``, ``chi`` the law; ``DC`` the gap (m);
    ``msamp`` (m, 2N) receives the modal state at each sample when ``m > 0``.
    Outputs as :func:`vibeam.models.beam_compliant.beam_compliant_kernel`.  Returns
    ``(status, n_rec, smin, smax, phase_end, n_con, t_contact, n_steps)``; ``z0`` is left at
    the end state.
    """
    n2 = z0.shape[0]
    N = n2 // 2
    T = TWO_PI / Om
    z = z0.copy()
    a = np.empty(n2, np.complex128)
    al = np.empty(n2, np.complex128)
    al2 = np.empty(n2, np.complex128)
    buf = np.empty(4)
    y0 = np.zeros(n2 + 1)
    y1 = np.zeros(n2 + 1)
    rk = np.zeros(4)
    ext = np.empty(3)
    ext[0] = np.inf
    ext[1] = -np.inf
    ze = np.zeros(n2)
    phase = phase0
    cs = np.zeros(4)
    n_con = 0
    n_rec = 0
    n_steps = 0
    t_con = 0.0
    in_rec = False
    k_sample = 0
    cap = con.shape[0]
    vr = v_floor
    foff = 0.0       # the force's sign just after an exit inside the stop: g' + v_r / chi
    wn = 0.0
    for i in range(N):
        wn += wrow[i] * wrow[i]
    wn = math.sqrt(wn)
    modal_coordinates(z, W, Z, ze, 0.0, a)
    if phase == CONTACT:
        gz = -DC
        uz = 0.0
        for i in range(N):
            gz += wrow[i] * z[i]
            uz += wrow[i] * z[N + i]
        vr = max(uz, v_floor)
        pen = ((p + 1.0) * vr * vr / (2.0 * kc * wn * wn)) ** (1.0 / (p + 1.0))
        rk[0] = 1e-3 * pen / vr
        rk[1] = HC_ATOL * pen / wn
        rk[2] = HC_ATOL * vr / wn
        rk[3] = pen / vr
    for per in range(n_transient + n_record):
        recording = per >= n_transient
        ns = ns_record if recording else ns_transient
        h_grid = T / ns
        t0p = (per - n_transient) * T
        ext[2] = np.inf
        for jg in range(ns):
            phi = TWO_PI * jg / ns
            t_loc = jg * h_grid
            if recording:
                sv = 0.0
                svd = 0.0
                for i in range(N):
                    sv += srow[i] * z[i]
                    svd += srow[i] * z[N + i]
                samples[k_sample, 0] = sv
                samples[k_sample, 1] = svd
                if msamp.shape[0] > k_sample:
                    for i in range(n2):
                        msamp[k_sample, i] = z[i]
                k_sample += 1
                ext[0] = min(ext[0], sv)
                ext[1] = max(ext[1], sv)
                ext[2] = min(ext[2], sv)
            rem = h_grid
            while rem > 0.0:
                n_steps += 1
                if n_steps > max_steps:
                    z0[:] = z
                    return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps)
                h_min = 1e-13 * T
                if phase == FREE:
                    for j in range(n2):
                        al[j] = PU[j] * a[j]
                    h = min(rem, hmax)
                    kk = 1.0 if foff != 0.0 else 0.0
                    # inside the stop after an exit by the damping factor: entry where
                    # g' + v_r / chi rises through 0 (force sign), else where g does
                    s_adv, ev = free_scan(al, lam, bU, -DC, phi, Om, 0.0 if kk else 1.0, kk, h, h_min, buf, al2,
                                           foff)
                    if s_adv < 0.0:     # a scan that could not be done in double precision
                        z0[:] = z
                        return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps)
                    if recording and s_adv > 0.0:
                        for j in range(n2):
                            al[j] = PS[j] * a[j]
                        for sgn in (1.0, -1.0):
                            b2, g2 = signal_combo(0.0, sgn, 0.0, al, lam, bS, 0.0, Om, al2)
                            s = 0.0
                            while True:
                                s = bupcross(al2, lam, b2, g2, phi, Om, s, s_adv, h_min)
                                if s == STALL:
                                    z0[:] = z
                                    return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps)
                                if s < 0.0:
                                    break
                                signal_derivatives(s, al, lam, bS, 0.0, phi, Om, buf)
                                if sgn > 0.0:
                                    ext[0] = min(ext[0], buf[0])
                                    ext[2] = min(ext[2], buf[0])
                                else:
                                    ext[1] = max(ext[1], buf[0])
                    modal_state(s_adv, a, lam, V, Z, ze, phi, Om, z)
                    for j in range(n2):
                        if a[j] != 0.0:
                            a[j] = a[j] * np.exp(lam[j] * s_adv)
                else:
                    for i in range(n2):
                        y0[i] = z[i]
                    y0[n2] = 0.0
                    s_adv, ev = hc_contact_step(rem, phi, y0, F, Om, knd, cnd, part, wrow, srow, DC, kc, p, chi, vr,
                                                rk, recording, ext, cs, y1)
                    if s_adv < 0.0:
                        z0[:] = z
                        return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps)
                    for i in range(n2):
                        z[i] = y1[i]
                    if recording:
                        t_con += s_adv
                phi = (phi + Om * s_adv) % TWO_PI
                t_loc += s_adv
                rem -= s_adv
                if rem < 1e-15 * T:
                    rem = 0.0
                if ev == EV_ENTRY:
                    phase = CONTACT
                    foff = 0.0
                    n_con += 1
                    if n_con > max_contacts:
                        z0[:] = z
                        return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps)
                    gz = -DC
                    uz = 0.0
                    for i in range(N):
                        gz += wrow[i] * z[i]
                        uz += wrow[i] * z[N + i]
                    # damping chi / v_r of this contact; DOPRI5 scales from the isolated contact's
                    # penetration ((p + 1) m_eff v_r^2 / (2 k))^(1 / (p + 1)), m_eff = 1 / |w|^2
                    vr = max(uz, v_floor)
                    pen = ((p + 1.0) * vr * vr / (2.0 * kc * wn * wn)) ** (1.0 / (p + 1.0))
                    rk[0] = 1e-3 * pen / vr
                    rk[1] = HC_ATOL * pen / wn
                    rk[2] = HC_ATOL * vr / wn
                    rk[3] = pen / vr
                    cs[0] = t0p + t_loc
                    cs[1] = _force(gz, uz, kc, p, chi, vr)
                    cs[2] = gz
                    cs[3] = 0.0
                    in_rec = recording
                    if recording:
                        if n_rec < imp_t.shape[0]:
                            imp_t[n_rec] = t0p + t_loc
                            imp_v[n_rec] = uz
                        n_rec += 1
                elif ev == EV_EXIT:
                    phase = FREE
                    modal_coordinates(z, W, Z, ze, phi, a)
                    gz = -DC
                    for i in range(N):
                        gz += wrow[i] * z[i]
                    foff = (vr / chi if chi > 0.0 else 1.0) if gz > 0.0 else 0.0
                    if in_rec and n_rec - 1 < cap:
                        r = n_rec - 1
                        con[r, 0] = t0p + t_loc - cs[0]
                        con[r, 1] = cs[1]
                        con[r, 2] = cs[2]
                        con[r, 3] = cs[3]
                        con[r, 4] = imp_v[r] if r < imp_v.shape[0] else np.nan
                    in_rec = False
                elif ev != EV_NONE:
                    foff = 0.0     # back below the stop (the gap fell through 0)
        if recording:
            pmin[per - n_transient] = ext[2]
    for i in range(n2):
        z0[i] = z[i]
    return (0, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps)


def free_data(model, Om):
    """Eigen-data of the free phase (cached on the model) and its signal rows at ``Om``."""
    N = model.n_modes
    key = ("hc", N)
    if getattr(model, "_hc_key", None) != key:
        A = np.zeros((2 * N, 2 * N))
        A[:N, N:] = np.eye(N)
        A[N:, :N] = -np.diag(model.k_nd)
        A[N:, N:] = -np.diag(model.c_nd)
        lam, V = np.linalg.eig(A)
        model._hc_eig = (A, lam.astype(np.complex128), np.ascontiguousarray(V, dtype=np.complex128),
                         np.ascontiguousarray(np.linalg.inv(V), dtype=np.complex128))
        model._hc_key = key
    A, lam, V, W = model._hc_eig
    F = Om ** 2 * model.base_amplitude_m
    b = np.concatenate([np.zeros(N), model.participation])
    Z = np.linalg.solve(1j * Om * np.eye(2 * N) - A, b * F)
    rowU = np.concatenate([model.contact_row, np.zeros(N)])
    rowS = np.concatenate([model.sensor_row, np.zeros(N)])
    return lam, V, W, Z, rowU @ V, rowS @ V, complex(rowU @ Z), complex(rowS @ Z), F


def velocity_floor(model, Om) -> float:
    """Entry velocities below this are floored here (m per kernel time unit):
    ``1e-2 Omega Y |w^T Gamma|`` (the SDOF's ``1e-2 Omega B`` for one mode)."""
    v = HC_V_FLOOR * Om * model.base_amplitude_m * abs(float(model.contact_row @ model.participation))
    return v if v > 0.0 else 1e-6 * model.length_m


class HuntCrossleyBeamEventSolver:
    """Method ``event`` of a beam scene with a Hunt-Crossley stop (module docstring).

    Same interface as :class:`vibeam.models.beam_compliant.CompliantBeamEventSolver` (state
    ``(eta, eta', phase)``, phase 1 in contact; contact records per unit effective mass).

    Parameters
    ----------
    model : vibeam.models.beam_compliant.CompliantBeamModel
        With ``contact`` a :class:`vibeam.models.compliant.HuntCrossley` (``stiffness`` in
        N/m^p at the contact point), one stop.
    transient_samples : int
        Grid points per period in the transient (efficiency only).
    steps_per_fundamental : int
        Largest free step is 1/this of the first modal period.
    max_impacts_per_period, max_steps_per_period : int
        Guards (status ``failed``).

    Raises
    ------
    ValueError
        If the law is not ``hunt_crossley`` or the scene has two stops.
    """

    name = "event"
    time_domain = True

    def __init__(self, model, transient_samples: int = 16, steps_per_fundamental: int = 16,
                 max_impacts_per_period: int = 2000, max_steps_per_period: int = 200000,
                 impact_buffer: int = 4096, chatter_tol: float | None = None, record_modal_states: bool = False):
        if getattr(model, "contact", None) is None or model.contact.name != "hunt_crossley":
            raise ValueError("HuntCrossleyBeamEventSolver needs a beam model with law \"hunt_crossley\"")
        if getattr(model, "two_sided", False):
            raise ValueError("law \"hunt_crossley\" on the beam takes one stop")
        self.model = model
        self.transient_samples = int(transient_samples)
        self.steps_per_fundamental = int(steps_per_fundamental)
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.max_steps_per_period = int(max_steps_per_period)
        self.impact_buffer = int(impact_buffer)
        self.chunk_periods = max(16, 2000 // model.n_modes)
        # work budget of one kernel call (steps x modes; :class:`Trajectory` ``incomplete``)
        self.max_steps_per_call = max(self.max_steps_per_period, MAX_STEP_MODES_PER_CALL // model.n_modes)
        self.record_modal_states = bool(record_modal_states)

    def settings(self) -> dict:
        return dict(transient_samples=self.transient_samples, steps_per_fundamental=self.steps_per_fundamental,
                    max_impacts_per_period=self.max_impacts_per_period,
                    max_steps_per_period=self.max_steps_per_period, n_modes=self.model.n_modes)

    def point(self, Omega: float, state0, n_transient: int, n_record: int, samples_per_period: int = 64):
        m = self.model
        N = m.n_modes
        Om = float(Omega)
        s0 = m.initial_state() if state0 is None else np.asarray(state0, dtype=float)
        if s0.shape != (2 * N + 1,) or not np.all(np.isfinite(s0)):
            s0 = m.initial_state()
        lam, V, W, Z, PU, PS, bU, bS, F = free_data(m, Om)
        law = m.contact
        kc = law.stiffness / m.omega_ref ** 2
        hmax = TWO_PI / math.sqrt(m.k_nd[0]) / self.steps_per_fundamental
        samples = np.zeros((n_record * samples_per_period, 2))
        pmin = np.zeros(n_record)
        imp_t = np.zeros(self.impact_buffer)
        imp_v = np.zeros(self.impact_buffer)
        con = np.full((self.impact_buffer, 5), np.nan)
        z = s0[:2 * N].copy()
        msamp = np.zeros((samples.shape[0] if self.record_modal_states else 0, 2 * N))
        n_per = max(n_transient + n_record, 1)
        max_steps, budget = call_budget(self.max_steps_per_period, n_per, self.max_steps_per_call)
        out = beam_hc_kernel(Om, lam, V, W, Z, PU, PS, bU, bS, m.contact_row, m.sensor_row, m.k_nd, m.c_nd,
                             m.participation, F, kc, float(law.exponent), float(law.chi), m.gap_contact_m,
                             velocity_floor(m, Om), z, 1 if s0[2 * N] > 0.5 else 0, int(n_transient), int(n_record),
                             self.transient_samples, int(samples_per_period), hmax,
                             self.max_impacts_per_period * n_per, max_steps, samples, pmin,
                             imp_t, imp_v, con, msamp)
        status, n_rec, smin, smax, ph_end, n_con, t_con, n_steps = out
        tr = _trajectory(m, Om, samples, samples_per_period, pmin, imp_t, imp_v, con, n_rec, smin, smax, z,
                         ph_end, status, n_con, n_steps, n_per, t_con, n_record, self.impact_buffer)
        if status != 0 and budget and n_steps > max_steps and n_con <= self.max_impacts_per_period * n_per:
            tr.incomplete = True
            tr.message = f"more than max_steps_per_call = {self.max_steps_per_call} steps in {n_per} period(s)"
        if self.record_modal_states:
            tr.extra["modal_states"] = msamp
        return tr


def _trajectory(m, Om, samples, spp, pmin, imp_t, imp_v, con, n_rec, smin, smax, z, ph_end, status, n_con, n_steps,
                n_per, t_con, n_record, cap):
    L = m.length_m
    k = min(n_rec, cap)
    c = con[:k]
    c = c[np.isfinite(c[:, 0])].copy()
    # nondimensional per unit effective mass (as the SDOF's and the linear beam law's)
    me = m.m_eff
    c[:, 1] /= me * L
    c[:, 2] /= L
    c[:, 3] /= me * L * L
    c[:, 4] /= L
    T = TWO_PI / Om
    message = "" if status == 0 else f"gave up after {n_con} contacts / {n_steps} steps in {n_per} periods"
    extra = {"contact_fraction": t_con / (n_record * T) if n_record else 0.0,
             "steps_per_period": float(n_steps / n_per)}
    return Trajectory(Omega=Om, samples=samples / L, samples_per_period=spp,
                      impact_times=imp_t[:k].copy(), impact_velocities=imp_v[:k] / L, n_impacts=int(n_rec),
                      q_min=float(smin / L), q_max=float(smax / L), period_min=pmin / L,
                      status="ok" if status == 0 else "failed", message=message,
                      final_state=np.concatenate([z, [float(ph_end)]]), extra=extra, contacts=c)


@njit(cache=True)
def isolated_contact_beam(kc, p, chi, w, v_in):
    """One Hunt-Crossley contact of the free, unforced, undamped modes (``K = C = 0``) entered
    at contact velocity ``v_in`` along ``w`` (``eta' = w v_in / |w|^2``), through the
    kernel's own contact step (:func:`hc_contact_step`).

    Returns
    -------
    R, duration : float
        ``-g'(t_e) / v_in`` at the force-zero exit and the contact's duration.
    """
    N = w.shape[0]
    wn2 = 0.0
    for i in range(N):
        wn2 += w[i] * w[i]
    y = np.zeros(2 * N + 1)
    for i in range(N):
        y[N + i] = w[i] * v_in / wn2
    z0 = np.zeros(N)
    y1 = np.zeros(2 * N + 1)
    rk = np.zeros(4)
    pen = ((p + 1.0) * v_in * v_in / (2.0 * kc * wn2)) ** (1.0 / (p + 1.0))
    rk[0] = 1e-3 * pen / v_in
    rk[1] = HC_ATOL * pen / math.sqrt(wn2)
    rk[2] = HC_ATOL * v_in / math.sqrt(wn2)
    rk[3] = pen / v_in
    ext = np.empty(3)
    cs = np.zeros(4)
    t = 0.0
    for _ in range(10 ** 6):
        s, ev = hc_contact_step(np.inf, 0.0, y, 0.0, 1.0, z0, z0, z0, w, w, 0.0, kc, p, chi, v_in, rk, False, ext,
                                cs, y1)
        if s < 0.0:
            return np.nan, np.nan
        for i in range(2 * N):
            y[i] = y1[i]
        t += s
        if ev == EV_EXIT:
            break
    gd = 0.0
    for i in range(N):
        gd += w[i] * y[N + i]
    return -gd / v_in, t


class HuntCrossleyBeamODESolver:
    """Method ``direct`` for a beam on a Hunt-Crossley stop: :func:`scipy.integrate.solve_ivp`
    on ``(eta, eta', E)`` with terminal events (entry: ``g = 0`` rising; exit: ``g = 0`` or the
    damping factor ``1 + chi g' / v_in = 0`` falling; just after an exit by the factor: the
    factor rising or ``g = 0`` falling), the reference of :class:`HuntCrossleyBeamEventSolver`
    (no shared code but the model's matrices and the velocity floor).

    Parameters
    ----------
    model : vibeam.models.beam_compliant.CompliantBeamModel
    solver : str
        ``solve_ivp`` method (DOP853 default).
    rtol, atol : float
        Tolerances (``atol`` relative to the base amplitude).
    """

    name = "direct"
    time_domain = True
    chunk_periods = 1000

    def __init__(self, model, solver: str = "DOP853", rtol: float = 1e-11, atol: float = 1e-13,
                 max_events_per_period: int = 200, max_step=None):
        if getattr(model, "contact", None) is None or model.contact.name != "hunt_crossley":
            raise ValueError("HuntCrossleyBeamODESolver needs a beam model with law \"hunt_crossley\"")
        if getattr(model, "two_sided", False):
            raise ValueError("law \"hunt_crossley\" on the beam takes one stop")
        self.model = model
        self.solver = solver
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.max_events_per_period = int(max_events_per_period)

    def settings(self) -> dict:
        return dict(solver=self.solver, rtol=self.rtol, atol=self.atol)

    def point(self, Omega, state0, n_transient, n_record, samples_per_period=64):
        from scipy.integrate import solve_ivp
        from scipy.optimize import brentq, minimize_scalar

        m = self.model
        N = m.n_modes
        Om = float(Omega)
        T = TWO_PI / Om
        law = m.contact
        kc, p, chi = law.stiffness / m.omega_ref ** 2, float(law.exponent), float(law.chi)
        knd, cnd, part = m.k_nd, m.c_nd, m.participation
        F = Om ** 2 * m.base_amplitude_m
        w, sr, DC = m.contact_row, m.sensor_row, m.gap_contact_m
        v_floor = velocity_floor(m, Om)
        spp = int(samples_per_period)
        t_rec, t_end = n_transient * T, (n_transient + n_record) * T
        ts = t_rec + np.arange(n_record * spp) * (T / spp)
        samples = np.full((ts.size, 2), np.nan)
        s0 = m.initial_state() if state0 is None else np.asarray(state0, float)
        y = np.concatenate([s0[:2 * N], [0.0]])
        mode = "contact" if s0[2 * N] > 0.5 else "free"
        atol = self.atol * max(abs(m.base_amplitude_m), 1e-12) / max(np.max(np.abs(w)), 1e-300)

        def gap(yy):
            return float(w @ yy[:N]) - DC

        def vel(yy):
            return float(w @ yy[N:2 * N])

        def force(yy, vin):
            g = gap(yy)
            return kc * g ** p * (1.0 + chi * vel(yy) / vin) if g > 0.0 else 0.0

        def rhs_for(contact, vin):
            def rhs(t, yy):
                f = force(yy, vin) if contact else 0.0
                acc = part * (F * math.sin(Om * t)) - cnd * yy[N:2 * N] - knd * yy[:N] - w * f
                return np.concatenate([yy[N:2 * N], acc, [f * vel(yy)]])
            return rhs

        def ev(fn, direction):
            fn.terminal = True
            fn.direction = direction
            return fn

        v_in = max(vel(y), v_floor)
        t = 0.0
        entries, contacts, segs = [], [], []
        cur = [0.0, vel(y), 0.0, force(y, v_in), gap(y)] if mode == "contact" else None
        n_ev, max_ev = 0, self.max_events_per_period * max(n_transient + n_record, 1)
        inside = False      # free inside the stop after an exit by the damping factor
        wn2 = float(w @ w)
        while t < t_end:
            contact = mode == "contact"
            if contact:
                events = [ev(lambda tt, yy: -gap(yy), 1.0),
                          ev(lambda tt, yy, vin=v_in: -(1.0 + chi * vel(yy) / vin), 1.0)]
                pen = ((p + 1.0) * v_in ** 2 / (2.0 * kc * wn2)) ** (1.0 / (p + 1.0))
                max_step = 0.05 * pen / v_in
            elif inside:
                events = [ev(lambda tt, yy, vin=v_in: 1.0 + chi * vel(yy) / vin, 1.0),
                          ev(lambda tt, yy: gap(yy), -1.0)]
                max_step = np.inf
            else:
                events = [ev(lambda tt, yy: gap(yy), 1.0)]
                max_step = np.inf
            sol = solve_ivp(rhs_for(contact, v_in), (t, t_end), y, method=self.solver, rtol=self.rtol,
                            atol=np.r_[np.full(2 * N, atol), 1e300], dense_output=True, events=events,
                            max_step=max_step)
            if sol.status == -1:
                return _failed(m, Om, samples, spp, f"{self.solver}: {sol.message}")
            t_new = float(sol.t[-1])
            segs.append((t, t_new, sol.sol))
            if cur is not None and contact:
                grid = np.linspace(t, t_new, 257)
                Y = sol.sol(grid)
                for slot, fun in ((3, lambda yy, vin=v_in: force(yy, vin)), (4, gap)):
                    vals = np.array([fun(Y[:, i]) for i in range(grid.size)])
                    i = int(np.argmax(vals))
                    best = vals[i]
                    if 0 < i < grid.size - 1:
                        r = minimize_scalar(lambda x, fun=fun, sl=sol.sol: -fun(sl(x)), method="bounded",
                                            bounds=(grid[i - 1], grid[i + 1]),
                                            options=dict(xatol=1e-14 * max(1.0, t_new)))
                        best = max(best, -r.fun)
                    cur[slot] = max(cur[slot], best)
            y = np.asarray(sol.y[:, -1], float)
            t = t_new
            if sol.status != 1:
                break
            n_ev += 1
            if n_ev > max_ev:
                return _failed(m, Om, samples, spp, "too many contact events")
            first = next(i for i, te in enumerate(sol.t_events) if te.size)
            if contact:
                if cur[0] >= t_rec:
                    contacts.append([t - cur[0], cur[3], cur[4], y[2 * N] - cur[2], cur[1]])
                cur, mode = None, "free"
                inside = first == 1 and gap(y) > 0.0
            elif inside and first == 1:
                inside = False      # back below the stop
            else:
                mode, inside = "contact", False
                v_in = max(vel(y), v_floor)
                cur = [t, vel(y), y[2 * N], force(y, v_in), gap(y)]
                if t >= t_rec:
                    entries.append((t - t_rec, vel(y)))
        minima, smin, smax = [], np.inf, -np.inf
        for (a, bnd, sol) in segs:
            sel = (ts >= a) & (ts <= bnd)
            if sel.any():
                Y = sol(ts[sel])
                samples[sel, 0] = sr @ Y[:N]
                samples[sel, 1] = sr @ Y[N:2 * N]
            lo, hi = max(a, t_rec), bnd
            if hi <= lo:
                continue
            grid = np.linspace(lo, hi, 129)
            vv = sr @ sol(grid)[N:2 * N]
            for i in np.nonzero(np.sign(vv[:-1]) * np.sign(vv[1:]) < 0)[0]:
                tr = brentq(lambda x: float(sr @ sol(x)[N:2 * N]), grid[i], grid[i + 1], xtol=1e-15)
                qv = float(sr @ sol(tr)[:N])
                if vv[i] < 0:
                    minima.append((tr, qv))
                    smin = min(smin, qv)
                else:
                    smax = max(smax, qv)
        pmin = samples[:, 0].reshape(n_record, spp).min(axis=1) if ts.size else np.zeros(0)
        for tm, qm in minima:
            kp = min(max(int((tm - t_rec) // T), 0), n_record - 1)
            pmin[kp] = min(pmin[kp], qm)
        L, me = m.length_m, m.m_eff
        if ts.size:
            smin, smax = min(smin, np.min(samples[:, 0])), max(smax, np.max(samples[:, 0]))
        c = np.array(contacts, float).reshape(-1, 5)
        c[:, 1] /= me * L
        c[:, 2] /= L
        c[:, 3] /= me * L * L
        c[:, 4] /= L
        it = np.array([e[0] for e in entries])
        iv = np.array([e[1] for e in entries]) / L
        return Trajectory(Omega=Om, samples=samples / L, samples_per_period=spp, impact_times=it,
                          impact_velocities=iv, n_impacts=int(it.size), q_min=smin / L, q_max=smax / L,
                          period_min=pmin / L,
                          final_state=np.concatenate([y[:2 * N], [1.0 if mode == "contact" else 0.0]]),
                          contacts=c)


def _failed(m, Om, samples, spp, msg):
    return Trajectory(Omega=Om, samples=samples, samples_per_period=spp, impact_times=np.zeros(0),
                      impact_velocities=np.zeros(0), n_impacts=0, q_min=np.nan, q_max=np.nan,
                      status="failed", message=msg, final_state=m.initial_state())
