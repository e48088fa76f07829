"""Exact event-driven solver of the SDOF coefficient-of-restitution oscillator.

Model (nondimensional, paper Eqs. 1-2 and 43, 47)::

    q'' + 2 beta q' + q = Omega^2 B sin(Omega t)      while q < Delta
    q(t+) = q(t-),  q'(t+) = -R q'(t-)                  at q = Delta

Between impacts the motion is the closed-form linear flow (paper Eq. 28,
:mod:`vibeam.models.sdof_flow`); the solver only finds event times.  The stop is a contact
relation with its law (:mod:`vibeam.models.contact`: gap ``q - Delta``, Newton's law with
``R(q'-)``), and what follows an impact is the policy shared with the beam kernel
(:mod:`vibeam.models.contact_policy`).

Guaranteed impact detection
    Time advances on a grid aligned with the forcing phase.  On each interval
    the sign of ``g'' = q''`` is *certified* from bounds on the third and fourth
    derivatives (``|q'''| <= A + C Omega^3``, ``|q''''| <= A + C Omega^4`` with
    ``A`` the homogeneous envelope and ``C`` the forced amplitude).  With
    ``g''`` of one sign the velocity is monotone, so ``g = q - Delta`` has at
    most one maximum (or minimum) inside; its apex is located by a bracketed
    root of ``q'`` and checked against the stop.  An uncertified interval is
    halved.  No crossing where ``g`` rises above zero and falls back inside a
    step can be missed (grazing included).  Impact times are refined by
    safeguarded Newton iteration on a sign-changing bracket to a few ulps.

Chatter (Zeno) and sticking
    After an impact with small rebound speed ``u`` into a region where the
    free-flight acceleration pushes the mass on the stop (``a > 0``), the
    remaining impacts form a geometric sequence (velocities ``R^k u``, flight
    times ``2 R^k u / a``) that accumulates after ``2 u / (a (1 - R))``
    (Budd & Dux 1994; Nordmark & Piiroinen 2009).  When the local estimate of
    the relative error of that constant-acceleration sum is below
    ``chatter_tol``, the solver jumps to the accumulation point and switches to
    sticking; the decision is the policy shared with the beam kernel,
    :func:`vibeam.models.contact_policy.chatter_jump`.  While stuck, ``q = Delta`` and ``q' = 0``; the mass is released
    exactly when the contact force ``Omega^2 B sin(Omega t) - Delta`` turns
    negative (closed form).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contact import OFFSET as _OFFSET
from .contact import impulsive_response
from .contact_policy import CHATTER, STICK, impact_outcome, release_now
from .roots import rtsafe_update, select
from .sdof_flow import (homogeneous_amplitude, particular_coefficients, propagate,
                        propagate_tabulated, transition)

TWO_PI = 2.0 * math.pi
EPS = 2.220446049250313e-16

STATUS_OK = 0
STATUS_CHATTER = 1
STATUS_STICKING = 2
STATUS_FAILED = 3
STATUS_NAMES = ("ok", "chatter", "sticking", "failed")

# kinds of the optional event log of :func:`event_kernel` (column 0 of ``ev_log``)
EV_IMPACT = 0
EV_STICK = 1
EV_RELEASE = 2
EV_APEX = 3
EV_MIN = 4
EV_NAMES = ("impact", "stick", "release", "apex", "minimum")


@njit(cache=True)
def _root(kind, lo, hi, phi0, q0, v0, beta, a, b, Omega, Delta):
    """Safeguarded Newton (rtsafe) on a bracket with f(lo) < 0 <= f(hi).

    kind 0: f = q - Delta (impact);  kind 1: f = -q' (apex of q, q' falling);
    kind 2: f = q' (minimum of q, q' rising).  Returns the end of the final
    bracket on which f >= 0, so an impact time is never before the crossing.
    """
    dxold = hi - lo
    dx = dxold
    s = 0.5 * (lo + hi)
    for _ in range(200):
        g, v, g2, g3, g4 = propagate(s, phi0, q0, v0, beta, a, b, Omega, Delta)
        F, dF = select(kind, g, v, g2)
        s, lo, hi, dx, dxold, done = rtsafe_update(F, dF, s, lo, hi, dx, dxold)
        if done:
            return s
    return hi


@njit(cache=True)
def _root_lower(kind, lo, hi, phi0, q0, v0, beta, a, b, Omega, Dl):
    """:func:`_root` on the lower stop's gap ``g_l = -q - Dl`` (normal ``-1``): kind 0:
    ``g_l`` (impact on the lower stop), 1: ``-g_l'`` (minimum of q), 2: ``g_l'``.  The signal is
    ``-(q + Dl)`` formed as ``(q0 + Dl)`` plus an accurate increment (:func:`propagate` about
    ``-Dl``), so it keeps full precision near the lower stop."""
    dxold = hi - lo
    dx = dxold
    s = 0.5 * (lo + hi)
    for _ in range(200):
        g, v, g2, g3, g4 = propagate(s, phi0, q0, v0, beta, a, b, Omega, -Dl)
        F, dF = select(kind, -g, -v, -g2)
        s, lo, hi, dx, dxold, done = rtsafe_update(F, dF, s, lo, hi, dx, dxold)
        if done:
            return s
    return hi


@njit(cache=True)
def certify_curvature(g20, g30, g21, g31, M3, M4, h, tol):
    """Certified sign of q'' on [0, h]: +1 convex, -1 concave, 0 unknown.

    ``g2x``/``g3x`` are the 2nd/3rd derivatives of q at the two ends,
    ``M3``/``M4`` bounds of the 3rd/4th derivatives, ``tol`` the round-off
    level of q''.
    """
    # first-order test with the 3rd-derivative bound (the lower envelope of
    # |q''| over the interval is V-shaped)
    if g20 >= -tol and g21 >= -tol and g20 + g21 > M3 * h:
        return 1
    if g20 <= tol and g21 <= tol and g20 + g21 < -M3 * h:
        return -1
    # second-order tests with the 4th-derivative bound, anchored at either
    # end; they certify intervals that start at a release or grazing point
    # where q'' = 0
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


@njit(cache=True)
def release_delay(phi, F, Delta, Omega):
    """Time until a mass stuck on the stop is released (inf: never).

    The contact force per unit mass is ``a(phi) = F sin(phi) - Delta``; the
    mass stays while ``a >= 0`` and leaves when ``a`` turns negative.
    """
    a_now = F * math.sin(phi) - Delta
    da = F * Omega * math.cos(phi)
    if release_now(a_now, da):
        return 0.0
    if F <= 0.0:
        return np.inf  # unforced: a = -Delta >= 0 stays
    r = Delta / F
    if r <= -1.0:
        return np.inf
    if r >= 1.0:
        return 0.0
    phid = math.pi - math.asin(r)  # downward zero crossing of a
    dphi = (phid - phi) % TWO_PI
    return dphi / Omega


@njit(cache=True)
def release_delay_lower(phi, F, Dl, Omega):
    """:func:`release_delay` on the lower stop at ``q = -Dl`` (normal ``-1``).

    The contact force per unit mass is ``a(phi) = -F sin(phi) - Dl``; it turns negative
    (downward zero crossing, ``cos(phi) > 0``) at ``phi = -asin(Dl / F)``.  Written like the
    upper stop's (no phase shift by pi, which would round), so that advancing the phase by
    the returned delay lands on the crossing.
    """
    a_now = -F * math.sin(phi) - Dl
    da = -F * Omega * math.cos(phi)
    if release_now(a_now, da):
        return 0.0
    if F <= 0.0:
        return np.inf  # unforced: a = -Dl >= 0 stays
    r = Dl / F
    if r <= -1.0:
        return np.inf
    if r >= 1.0:
        return 0.0
    phid = -math.asin(r)  # downward zero crossing of a
    dphi = (phid - phi) % TWO_PI
    return dphi / Omega


@njit(cache=True)
def _release_time(phi, F, D, Omega, side):
    """Release delay on stop ``side`` (0: :func:`release_delay`, 1: :func:`release_delay_lower`),
    0 when the crossing lies within round-off of the current phase (advancing the phase by
    the delay would not change it: without this, a mass could stick and release forever at
    one instant)."""
    if side == 0:
        s_r = release_delay(phi, F, D, Omega)
    else:
        s_r = release_delay_lower(phi, F, D, Omega)
    if s_r > 0.0 and (phi + Omega * s_r) % TWO_PI == phi:
        return 0.0
    return s_r


@njit(cache=True)
def _log_event(ev_log, ev_count, kind, t, q, v, a):
    """Append one row ``(kind, t, q, q', q'')`` to the event log (counted even when full)."""
    k = ev_count[0]
    if k < ev_log.shape[0]:
        ev_log[k, 0] = kind
        ev_log[k, 1] = t
        ev_log[k, 2] = q
        ev_log[k, 3] = v
        ev_log[k, 4] = a
    ev_count[0] = k + 1


@njit(cache=True)
def event_kernel(beta, B, stops, tab_U, tab_R, Omega, q_init, v_init, stuck_init,
                 n_transient, n_record, ns_transient, ns_record,
                 max_impacts, chatter_tol,
                 samples, imp_t, imp_v, imp_k, n_imp_stop, pmin, chat_t, ev_log=None, ev_count=None,
                 max_steps=-1):
    """Simulate whole forcing periods exactly; the numba core of method ``event``.

    Time starts at forcing phase 0.  ``samples`` (shape (n_record *
    ns_record, 2)) receives ``(q, q')`` at the phase grid of the recorded
    periods; ``imp_t``/``imp_v`` receive the times (from the start of the
    recording) and pre-impact velocities of the first ``len(imp_t)`` recorded
    impacts; ``pmin`` (shape (n_record,)) the exact minimum of ``q`` over each
    recorded period (the same root-found minima as ``q_min``); ``chat_t`` the times (from
    the start of the recording) of the first ``len(chat_t)`` chatter accumulation points.

    The stops are the rows of ``stops`` (shape (n_stops, NPAR)) with their ``R(U-)`` tables
    ``tab_U``/``tab_R`` (:func:`vibeam.models.contact.pack`; row 0: the upper stop at
    ``q = Delta``, Newton's law with ``R`` and ``R(q'-)``).  ``imp_k`` receives the stop of each
    stored impact (0 upper) and ``n_imp_stop`` (n_stops,) the recorded impacts per stop.
    ``stuck_init``: 0 free, 1 held on the upper stop.

    Optional event log (used by the shooting problem of :mod:`vibeam.models.periodic_sdof`):
    ``ev_log`` (shape (cap, 5)) receives one row ``(kind, t, q, q', q'')`` per event in
    time order -- kind :data:`EV_IMPACT` (pre-impact state and acceleration),
    :data:`EV_STICK` (onset of sticking, after a chatter accumulation or a contact without
    rebound), :data:`EV_RELEASE` (lift-off from the stop), :data:`EV_APEX` (an interior
    maximum of a free flight below the stop, located in recorded periods) and, with a second
    stop, :data:`EV_MIN` (an interior minimum of a free flight, located in recorded periods: the
    grazing test of the lower stop), with ``t``
    measured from the start of the call -- and ``ev_count[0]`` the number of events (it
    keeps counting beyond ``cap``).  Omitted (None), nothing is logged.

    ``max_steps`` bounds the work of the call: more than this many steps (trial steps of
    the scan, events and stuck intervals, counted together) end it with
    :data:`STATUS_FAILED` and ``n_imp_total <= max_impacts`` (what tells it from the impact
    guard); -1: no bound.  A compiled call cannot be interrupted, so this is what returns it to
    Python (Ctrl-C, the wall-time limit) within a bounded time whatever the scene: e.g. a
    motion whose scale is subnormal, where no step can be certified and every step shrinks
    to the smallest one (:attr:`vibeam.models.sdof.EventSolver.max_steps_per_call`).

    Returns
    -------
    tuple
        ``(status, n_imp_record, q_min, q_max, n_chatter, stuck_time,
        q_end, v_end, stuck_end, n_imp_total, gmax)``; ``stuck_end`` as ``stuck_init``;
        ``n_imp_total = -1`` (failed at once): the forced response is not finite;
        ``gmax`` is the largest
        gap ``q - Delta`` at the end of a step without an event, before ``q`` is
        put back on the stop (a certificate: positive beyond round-off only if
        a crossing had been stepped over).
    """
    F = Omega * Omega * B
    Delta = stops[0, _OFFSET]
    # a second (lower) stop at q = -Dl, normal -1 (vibeam.models.contact); DD: the distance between
    # the stops, so that the lower gap is g_l = -q - Dl = -(q - Delta) - DD
    two = stops.shape[0] > 1
    Dl = stops[1, _OFFSET] if two else np.inf
    DD = Delta + Dl
    side = 0 if stuck_init >= 0 else 1     # the stop the mass is held on (when stuck)
    tU0 = tab_U[0]
    tR0 = tab_R[0]
    a, b = particular_coefficients(beta, F, Omega)
    C = math.sqrt(a * a + b * b)
    T = TWO_PI / Omega
    W2 = C * Omega ** 2
    W3 = C * Omega ** 3
    W4 = C * Omega ** 4
    q = q_init
    v = v_init
    stuck = stuck_init != 0
    if q > Delta:
        q = Delta
    if two and q < -Dl:
        q = -Dl
    for k in range(n_imp_stop.shape[0]):
        n_imp_stop[k] = 0
    n_imp_total = 0
    n_imp_rec = 0
    n_chatter = 0
    stuck_time = 0.0
    q_min = np.inf
    q_max = -np.inf
    gmax = -np.inf
    cap = imp_t.shape[0]
    status = STATUS_OK
    if not (math.isfinite(a) and math.isfinite(b)):
        # no forced response (undamped exact resonance, or an overflow): n_imp_total = -1 says so
        return (STATUS_FAILED, 0, q_min, q_max, 0, 0.0, q, v, _held(stuck, side), -1, -np.inf)
    n_total = n_transient + n_record
    k_sample = 0
    n_steps = 0
    # derivatives at the start of the next interval are carried over from the
    # end of the previous one; ``fresh`` forces a recomputation after any jump
    # (impact, sticking, release).  The homogeneous envelope A only decays
    # between jumps, so its value at the last jump bounds it (Eq. 28).
    fresh = True
    A = 0.0
    g0 = v0 = g20 = g30 = 0.0
    # fixed sub-steps (grid step / sub, below 1/16 of the natural period) with
    # their transition matrix and forcing phases tabulated once: a step that
    # meets no event costs no transcendental function call
    sub_t = max(1, int(math.ceil((T / ns_transient) / (TWO_PI / 16.0))))
    sub_r = max(1, int(math.ceil((T / ns_record) / (TWO_PI / 16.0))))
    nt_t = ns_transient * sub_t
    nt_r = ns_record * sub_r
    P_t = np.empty(4)
    P_r = np.empty(4)
    P_t[0], P_t[1], P_t[2], P_t[3] = transition(T / nt_t, beta)
    P_r[0], P_r[1], P_r[2], P_r[3] = transition(T / nt_r, beta)
    tab_t = np.empty((nt_t + 1, 2))
    tab_r = np.empty((nt_r + 1, 2))
    for k in range(nt_t + 1):
        tab_t[k, 0] = math.sin(TWO_PI * k / nt_t)
        tab_t[k, 1] = math.cos(TWO_PI * k / nt_t)
    for k in range(nt_r + 1):
        tab_r[k, 0] = math.sin(TWO_PI * k / nt_r)
        tab_r[k, 1] = math.cos(TWO_PI * k / nt_r)
    for k in range(pmin.shape[0]):
        pmin[k] = np.inf
    kp = 0
    for p in range(n_total):
        recording = p >= n_transient
        kp = p - n_transient
        ns = ns_record if recording else ns_transient
        sub = sub_r if recording else sub_t
        P = P_r if recording else P_t
        tab = tab_r if recording else tab_t
        h_grid = T / ns
        t_period0 = (p - n_transient) * T
        for j in range(ns):
            phi = TWO_PI * j / ns
            if recording:
                samples[k_sample, 0] = q
                samples[k_sample, 1] = v
                k_sample += 1
                if q < q_min:
                    q_min = q
                if q < pmin[kp]:
                    pmin[kp] = q
                if q > q_max:
                    q_max = q
            for isub in range(sub):
                rem = h_grid / sub
                t_loc = j * h_grid + isub * h_grid / sub  # time within period
                kg = j * sub + isub
                at_grid = True  # still on the tabulated step (no event yet)
                while rem > 0.0:
                    n_steps += 1
                    if max_steps >= 0 and n_steps > max_steps:
                        return (STATUS_FAILED, n_imp_rec, q_min, q_max, n_chatter,
                                stuck_time, q, v, _held(stuck, side), n_imp_total, gmax)
                    if stuck:
                        fresh = True
                        at_grid = False
                        if side == 0:
                            s_r = _release_time(phi, F, Delta, Omega, 0)
                        else:
                            s_r = _release_time(phi, F, Dl, Omega, 1)
                        if s_r >= rem:
                            if recording:
                                stuck_time += rem
                            phi = (phi + Omega * rem) % TWO_PI
                            t_loc += rem
                            rem = 0.0
                            break
                        if recording:
                            stuck_time += s_r
                        phi = (phi + Omega * s_r) % TWO_PI
                        t_loc += s_r
                        rem -= s_r
                        stuck = False
                        q = Delta if side == 0 else -Dl
                        v = 0.0
                        if ev_log is not None:
                            _log_event(ev_log, ev_count, EV_RELEASE, p * T + t_loc, q, 0.0, 0.0)
                        continue
                    # ---- free flight from (phi, q, v) for at most rem ----
                    s_imp = -1.0
                    k_imp = 0
                    if q >= Delta and v >= 0.0:
                        # on the stop and not leaving: an impact now if approaching,
                        # otherwise sticking if the contact force presses it on
                        q = Delta
                        if v > 0.0:
                            s_imp = 0.0
                        elif _release_time(phi, F, Delta, Omega, 0) > 0.0:
                            stuck = True
                            side = 0
                            if ev_log is not None:
                                _log_event(ev_log, ev_count, EV_STICK, p * T + t_loc, Delta, 0.0,
                                           F * math.sin(phi) - Delta)
                            continue
                    elif two and q <= -Dl and v <= 0.0:
                        # the same on the lower stop (normal -1)
                        q = -Dl
                        if v < 0.0:
                            s_imp = 0.0
                            k_imp = 1
                        elif _release_time(phi, F, Dl, Omega, 1) > 0.0:
                            stuck = True
                            side = 1
                            if ev_log is not None:
                                _log_event(ev_log, ev_count, EV_STICK, p * T + t_loc, -Dl, 0.0,
                                           -F * math.sin(phi) - Dl)
                            continue
                    if s_imp < 0.0:
                        if fresh:
                            A = homogeneous_amplitude(phi, q, v, beta, a, b, Omega)
                            g0, v0, g20, g30, g40 = propagate(0.0, phi, q, v, beta, a, b, Omega, Delta)
                            fresh = False
                        M3 = (A + W3) * (1.0 + 1e-9) + 1e-300
                        M4 = (A + W4) * (1.0 + 1e-9) + 1e-300
                        M2 = (A + W2) * (1.0 + 1e-9) + 1e-300
                        tol2 = 1e-13 * M2  # q'' within round-off of zero counts as zero
                        h = rem
                        h_min = 1e-13 * T
                        while True:
                            if at_grid and h == rem:
                                g1, v1, g21, g31, g41 = propagate_tabulated(
                                    P, tab[kg, 0], tab[kg, 1], tab[kg + 1, 0], tab[kg + 1, 1],
                                    q, v, beta, a, b, Omega, Delta)
                            else:
                                g1, v1, g21, g31, g41 = propagate(h, phi, q, v, beta, a, b, Omega, Delta)
                            # far from the stop: linear interpolation error <= M2 h^2 / 8; with a
                            # lower stop, far from it too (g_l = -g - DD)
                            c8 = 0.125 * M2 * h * h
                            near_l = two and -min(g0, g1) - DD + c8 >= 0.0
                            if max(g0, g1) + c8 < 0.0 and not near_l:
                                cert = 2
                                break
                            cert = certify_curvature(g20, g30, g21, g31, M3, M4, h, tol2)
                            if cert != 0 or h < h_min or not h > 0.0:
                                break
                            h *= 0.5
                            n_steps += 1
                        if cert == 0:
                            cert = 1 if g20 + g21 > 0.0 else -1
                        if cert == 2:
                            # no impact possible; only the extrema of a recorded window
                            if recording:
                                if v0 < 0.0 < v1:
                                    sm = _root(2, 0.0, h, phi, q, v, beta, a, b, Omega, Delta)
                                    gm = propagate(sm, phi, q, v, beta, a, b, Omega, Delta)[0]
                                    if Delta + gm < q_min:
                                        q_min = Delta + gm
                                    if Delta + gm < pmin[kp]:
                                        pmin[kp] = Delta + gm
                                    if ev_log is not None and two:
                                        _log_event(ev_log, ev_count, EV_MIN, p * T + t_loc + sm,
                                                   Delta + gm, 0.0, 0.0)
                                elif v0 > 0.0 > v1:
                                    sa = _root(1, 0.0, h, phi, q, v, beta, a, b, Omega, Delta)
                                    ga = propagate(sa, phi, q, v, beta, a, b, Omega, Delta)[0]
                                    if Delta + ga > q_max:
                                        q_max = Delta + ga
                                    if ev_log is not None:
                                        _log_event(ev_log, ev_count, EV_APEX, p * T + t_loc + sa,
                                                   Delta + ga, 0.0, 0.0)
                        elif cert < 0:
                            # concave: v non-increasing
                            if v0 > 0.0:
                                if v1 >= 0.0:
                                    if g1 >= 0.0:
                                        s_imp = _root(0, 0.0, h, phi, q, v, beta, a, b, Omega, Delta)
                                else:
                                    # tangent lines bound a concave function from above
                                    bound = g0 + v0 * (g1 - g0 - v1 * h) / (v0 - v1) if v0 - v1 > 0.0 else g0
                                    if bound >= 0.0 or recording:
                                        sa = _root(1, 0.0, h, phi, q, v, beta, a, b, Omega, Delta)
                                        ga = propagate(sa, phi, q, v, beta, a, b, Omega, Delta)[0]
                                        if ga >= 0.0:
                                            s_imp = _root(0, 0.0, sa, phi, q, v, beta, a, b, Omega, Delta) if g0 < 0.0 else sa
                                        else:
                                            if recording and Delta + ga > q_max:
                                                q_max = Delta + ga
                                            if ev_log is not None and recording:
                                                _log_event(ev_log, ev_count, EV_APEX, p * T + t_loc + sa,
                                                           Delta + ga, 0.0, 0.0)
                            # lower stop (q concave: it can only fall through -Dl, after the apex if
                            # q rises first, e.g. in a chatter on the lower stop)
                            if near_l and s_imp < 0.0 and v1 < 0.0:
                                if propagate(h, phi, q, v, beta, a, b, Omega, -Dl)[0] <= 0.0:
                                    lo = _root(1, 0.0, h, phi, q, v, beta, a, b, Omega, Delta) if v0 > 0.0 else 0.0
                                    s_imp = _root_lower(0, lo, h, phi, q, v, beta, a, b, Omega, Dl)
                                    k_imp = 1
                        else:
                            # convex: v non-decreasing; a lower stop is met before the minimum of
                            # q, the upper one after it
                            if near_l and v0 < 0.0:
                                sl = _root(2, 0.0, h, phi, q, v, beta, a, b, Omega, Delta) if v1 > 0.0 else h
                                if propagate(sl, phi, q, v, beta, a, b, Omega, -Dl)[0] <= 0.0:
                                    s_imp = _root_lower(0, 0.0, sl, phi, q, v, beta, a, b, Omega, Dl)
                                    k_imp = 1
                            if k_imp == 1:
                                pass
                            elif v1 > 0.0 or (v1 == 0.0 and g1 >= 0.0):
                                if v0 < 0.0:
                                    # minimum of q: root of q' on [0, h] (q' increasing)
                                    sm = _root(2, 0.0, h, phi, q, v, beta, a, b, Omega, Delta)
                                    if recording:
                                        gm = propagate(sm, phi, q, v, beta, a, b, Omega, Delta)[0]
                                        if Delta + gm < q_min:
                                            q_min = Delta + gm
                                        if Delta + gm < pmin[kp]:
                                            pmin[kp] = Delta + gm
                                        if ev_log is not None and two:
                                            _log_event(ev_log, ev_count, EV_MIN, p * T + t_loc + sm,
                                                       Delta + gm, 0.0, 0.0)
                                    if g1 >= 0.0:
                                        s_imp = _root(0, sm, h, phi, q, v, beta, a, b, Omega, Delta)
                                elif g1 >= 0.0:
                                    s_imp = _root(0, 0.0, h, phi, q, v, beta, a, b, Omega, Delta)
                    if s_imp >= 0.0 and k_imp == 1:
                        # ---- impact on the lower stop: the same law and policy along the normal -1
                        fresh = True
                        at_grid = False
                        vi = propagate(s_imp, phi, q, v, beta, a, b, Omega, -Dl)[1] if s_imp > 0.0 else v
                        phi = (phi + Omega * s_imp) % TWO_PI
                        t_loc += s_imp
                        rem -= s_imp
                        if rem < 0.0:
                            rem = 0.0
                        q = -Dl
                        U_minus = -vi if vi < 0.0 else 0.0
                        if ev_log is not None:
                            _log_event(ev_log, ev_count, EV_IMPACT, p * T + t_loc, -Dl, U_minus,
                                       -F * math.sin(phi) - 2.0 * beta * U_minus - Dl)
                        # CONTACT EVENT (lower stop)
                        U_plus, Rc = impulsive_response(U_minus, stops[1], tab_U[1], tab_R[1])
                        v = -U_plus
                        n_imp_total += 1
                        if recording:
                            q_min = min(q_min, -Dl)
                            pmin[kp] = min(pmin[kp], -Dl)
                            if n_imp_rec < cap:
                                imp_t[n_imp_rec] = t_period0 + t_loc
                                imp_v[n_imp_rec] = U_minus
                                imp_k[n_imp_rec] = 1
                            n_imp_rec += 1
                            n_imp_stop[1] += 1
                        if n_imp_total > max_impacts:
                            return (STATUS_FAILED, n_imp_rec, q_min, q_max, n_chatter,
                                    stuck_time, q, v, _held(stuck, side), n_imp_total, gmax)
                        u = -U_plus
                        acc = -F * math.sin(phi) + 2.0 * beta * u - Dl
                        pressed = u <= 0.0 and _release_time(phi, F, Dl, Omega, 1) > 0.0
                        action, D = impact_outcome(u, pressed, acc, -F * Omega * math.cos(phi), 2.0 * beta,
                                                   1.0, Rc, chatter_tol, rem, 0, 0)
                        if action == STICK or action == CHATTER:
                            if action == CHATTER:
                                n_chatter += 1 if recording else 0
                                phi = (phi + Omega * D) % TWO_PI
                                t_loc += D
                                rem -= D
                                if recording and n_chatter <= chat_t.shape[0]:
                                    chat_t[n_chatter - 1] = t_period0 + t_loc
                            stuck = True
                            side = 1
                            v = 0.0
                            if ev_log is not None:
                                _log_event(ev_log, ev_count, EV_STICK, p * T + t_loc, -Dl, 0.0,
                                           -F * math.sin(phi) - Dl)
                        continue
                    if s_imp >= 0.0:
                        fresh = True
                        at_grid = False
                        vi = propagate(s_imp, phi, q, v, beta, a, b, Omega, Delta)[1] if s_imp > 0.0 else v
                        phi = (phi + Omega * s_imp) % TWO_PI
                        t_loc += s_imp
                        rem -= s_imp
                        if rem < 0.0:
                            rem = 0.0
                        q = Delta
                        v_minus = vi if vi > 0.0 else 0.0
                        if ev_log is not None:
                            _log_event(ev_log, ev_count, EV_IMPACT, p * T + t_loc, Delta, v_minus,
                                       F * math.sin(phi) - 2.0 * beta * v_minus - Delta)
                        # CONTACT EVENT: the stop's law (an impulsive one; a compliant law would
                        # enter its contact phase here, see vibeam.models.contact)
                        v, Rc = impulsive_response(v_minus, stops[0], tU0, tR0)
                        n_imp_total += 1
                        if recording:
                            q_max = Delta
                            if n_imp_rec < cap:
                                imp_t[n_imp_rec] = t_period0 + t_loc
                                imp_v[n_imp_rec] = v_minus
                                imp_k[n_imp_rec] = 0
                            n_imp_rec += 1
                            n_imp_stop[0] += 1
                        if n_imp_total > max_impacts:
                            return (STATUS_FAILED, n_imp_rec, q_min, q_max, n_chatter,
                                    stuck_time, q, v, _held(stuck, side), n_imp_total, gmax)
                        # the shared policy (vibeam.models.contact_policy), R at the current impact
                        # velocity: rebound speed u, contact acceleration with the rebound velocity;
                        # one DOF: the jerk beyond the flow part is the forcing term exactly,
                        # c_eff = 2 beta, k_eff = 1, no Zeno guard.  A chatter jumps only to an
                        # accumulation point inside this sub-step; beyond it the bounces are resolved
                        # one by one until the next sub-step (whose full length then contains the
                        # remaining D R^k).  "pressed" (closed form) is needed only without rebound.
                        u = -v
                        acc = F * math.sin(phi) + 2.0 * beta * u - Delta
                        pressed = u <= 0.0 and _release_time(phi, F, Delta, Omega, 0) > 0.0
                        action, D = impact_outcome(u, pressed, acc, F * Omega * math.cos(phi), 2.0 * beta,
                                                   1.0, Rc, chatter_tol, rem, 0, 0)
                        if action == STICK:
                            stuck = True
                            side = 0
                            v = 0.0
                            if ev_log is not None:
                                _log_event(ev_log, ev_count, EV_STICK, p * T + t_loc, Delta, 0.0,
                                           F * math.sin(phi) - Delta)
                        elif action == CHATTER:
                            n_chatter += 1 if recording else 0
                            phi = (phi + Omega * D) % TWO_PI
                            t_loc += D
                            rem -= D
                            stuck = True
                            side = 0
                            v = 0.0
                            if recording and n_chatter <= chat_t.shape[0]:
                                chat_t[n_chatter - 1] = t_period0 + t_loc
                            if ev_log is not None:
                                _log_event(ev_log, ev_count, EV_STICK, p * T + t_loc, Delta, 0.0,
                                           F * math.sin(phi) - Delta)
                        continue
                    # no event in [0, h]: move to its end (the unclamped gap is kept: a crossing
                    # stepped over would show as g1 > 0)
                    if g1 > gmax:
                        gmax = g1
                    if two and -g1 - DD > gmax:
                        gmax = -g1 - DD
                    if recording:
                        qe = Delta + g1
                        if qe < q_min:
                            q_min = qe
                        if qe < pmin[kp]:
                            pmin[kp] = qe
                        if qe > q_max:
                            q_max = qe
                    q = Delta + g1
                    if q > Delta:
                        q = Delta
                    if two and q < -Dl:
                        q = -Dl
                    v = v1
                    g0 = g1 if g1 < 0.0 else 0.0
                    v0 = v1
                    g20 = g21
                    g30 = g31
                    phi = (phi + Omega * h) % TWO_PI
                    t_loc += h
                    if h != rem:
                        at_grid = False
                    rem -= h
                    if rem < 1e-15 * T:
                        rem = 0.0
    if n_record > 0:
        if n_chatter > 0:
            status = STATUS_CHATTER
        elif stuck_time > 0.0:
            status = STATUS_STICKING
    return (status, n_imp_rec, q_min, q_max, n_chatter, stuck_time, q, v, _held(stuck, side),
            n_imp_total, gmax)


@njit(cache=True)
def _held(stuck, side):
    """Held-state code: 0 free, 1 on the upper stop, -1 on the lower one."""
    if not stuck:
        return 0
    return 1 if side == 0 else -1


