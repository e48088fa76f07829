"""Vibro-impact dynamics of the FE cantilever in modal coordinates (paper Sec. 6, Eqs. 39-41).

Model
    ``M u'' + C u' + K u = -M r b''(t)``, ``b = Y sin(Omega~ t~)`` (base displacement
    amplitude ``Y = gamma~ V``, m), while the contact displacement ``U = w^T u`` (relative to
    the base, at ``L_m``) stays below the stop ``Delta_C``; Newton's impact law (Eq. 41) on
    ``U``.  With the ``N`` retained mass-normalised modes ``u = Phi eta`` each modal
    coordinate obeys::

        eta_i'' + c_i eta_i' + omega_i^2 eta_i = Gamma_i Omega~^2 Y sin(Omega~ t~),
        c_i = alpha + D omega_i^2       (Rayleigh; alpha = 0 is Eq. 39's D EI U'''')

    and ``U = sum_i w_i eta_i``, sensor ``U(L_S) = sum_i s_i eta_i``.

Units of the kernel
    Time is the nondimensional ``t = omega_ref t~`` with ``omega_ref = 2 pi f_ref``, so the
    sweep's ``Omega = f / f_ref`` is the forcing frequency; modal coordinates keep their SI
    units (sqrt(kg) m), modal frequencies/damping are divided by ``omega_ref``.  Outputs
    are ``q = U(L_S) / L`` and ``q' = dq/dt`` (same measure as the SDOF model when
    ``f_ref = f_n``).

Exact flow
    Between events every modal coordinate follows its closed-form damped forced response
    (underdamped, critically damped or overdamped: stiffness-proportional damping makes
    the high modes overdamped), written as increments ``Phi(s) - I`` free of cancellation.

Guaranteed impact detection
    As :mod:`vibeam.models.sdof_event`: on each step the cheap interpolation bound
    ``max(g0, g1) + M2 h^2 / 8 < 0`` clears intervals far from the stop; otherwise the
    sign of ``g''`` is certified with :func:`vibeam.models.sdof_event.certify_curvature` from bounds
    ``M3, M4`` that sum, over every retained mode, the homogeneous bound of its k-th
    derivative (underdamped: ``A_i omega_i^k``; overdamped: ``|c1| |l1|^k + |c2| |l2|^k``;
    critical: a universal bound) plus the forced amplitude times ``Omega^k``.  Steps are
    halved only where needed (and the last accepted step is remembered), so the step
    scales with the highest mode only where that mode is excited near the stop.

Contact relation and law (Moreau / Siconos; :mod:`vibeam.models.contact`)
    Each stop is a relation (normal ``n = s w``, offset ``Delta``: gap ``n^T eta - Delta``,
    normal velocity ``U = n^T eta'``, ``m_eff = 1 / sum_i w_i^2``) and a law.  At a contact
    event the law gives ``U+`` (Newton: ``U+ = -R(U-) U-``) and the kernel applies the impulse
    ``P = m_eff (U+ - U-)`` along ``n`` (:func:`apply_impulse`; energy loss ``(1 - R^2) m_eff
    U-^2 / 2``); what follows (rebound, chatter, sticking) is the shared policy of
    :mod:`vibeam.models.contact_policy`.

Sticking and chatter
    On the stop the beam is the constrained linear system ``w^T eta = Delta_C``: with an
    orthonormal basis ``T`` of ``null(w^T)`` and ``T^T K T = V diag(nu^2) V^T``,
    ``eta = eta_c + Psi zeta`` (``Psi = T V``, ``eta_c = w Delta_C / |w|^2``) and each
    ``zeta_j`` again is a proportionally damped forced oscillator (constant + harmonic
    load), integrated in closed form.  The contact force (positive pulling the beam
    away from the stop; the beam is held while ``lambda <= 0``) is
    ``lambda = -m_eff w^T (Gamma F sin - C eta' - K eta)``; release at its first upward
    zero crossing, found with the same certified scan.  Entering contact removes the
    normal velocity with the plastic (R = 0) impulse.  Chatter: after an impact with a
    small rebound speed ``u`` into a free contact acceleration ``a > 0``, if the
    constant-acceleration estimate of the accumulation time ``2 u / (a (1 - R))`` is
    accurate to ``chatter_tol`` (the policy shared with the SDOF kernel,
    :func:`vibeam.models.contact_policy.chatter_jump`: the jerk includes the forcing
    term; the accumulation point must lie in the current step) the solver sticks at
    once and holds the beam on the stop
    (constrained flow, no release check) for that accumulation time, then continues as
    stuck: with one mode this is exactly the SDOF kernel's jump (state frozen on the
    stop for the accumulation time); with several modes the other modes keep moving
    during the chatter as in the constrained system (an O(u) approximation).
"""
from __future__ import annotations

import copy
import math

import numpy as np
import scipy.linalg
from numba import njit

from .trajectory import Trajectory, call_budget

from .contact import OFFSET as _OFFSET
from .contact import Relation, Restitution, Stop, check_stops, impulsive_response, pack
from .contact_policy import (BURST_DT, BURST_MAX, CHATTER, CHATTER_GUARD, REBOUND, STICK, impact_outcome,
                             release_now, zeno_burst)
from .roots import rtsafe_update, select
from .impact import newton_restitution, restitution_coefficient, restitution_impulse
from .sdof_event import STATUS_NAMES, certify_curvature
from .system import advance_modes, mode_table, particular, transition_increment

TWO_PI = 2.0 * math.pi
EPS = 2.220446049250313e-16
ST_OK, ST_CHATTER, ST_STICKING, ST_FAILED = 0, 1, 2, 3

__all__ = ["BeamImpactModel", "BeamEventSolver", "BeamODESolver", "mode_table", "apply_impact"]

# the closed-form modal flow lives in vibeam.models.system (the one dynamical system); the kernels
# below call it by these names (mode_table and particular are re-exported from there)
_trans = transition_increment
_advance = advance_modes


# ============================================================================ mode algebra
@njit(cache=True)
def _clock(phi, t_loc, rem, s, Om, T):
    """Advance forcing phase, time within the period and the rest of the step by ``s``."""
    rem -= s
    if rem < 1e-15 * T:
        rem = 0.0
    return (phi + Om * s) % TWO_PI, t_loc + s, rem


@njit(cache=True)
def _hb(x0, y0, sig, k, typ, q, l1, l2, out):
    """Bounds ``out[m] >= sup_{s>=0} |x^(m)(s)|``, m = 0..5, of a homogeneous solution."""
    if typ == 0:
        w = (y0 + sig * x0) / q
        A = math.sqrt(x0 * x0 + w * w)
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
    else:
        d = np.empty(7)
        d[0] = x0
        d[1] = y0
        for m in range(5):
            d[m + 2] = -2.0 * sig * d[m + 1] - k * d[m]
        for m in range(6):
            out[m] = abs(d[m]) + abs(d[m + 1] + sig * d[m]) / (math.e * sig)
    for m in range(6):
        out[m] = out[m] * (1.0 + 1e-9) + 1e-300


@njit(cache=True)
def _sig(s, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0):
    """Signal ``f = sum_j p_j x_j + r_j x_j' + Sa sin + Sb cos (+ const)`` at local time ``s``.

    ``x_j`` are homogeneous modal responses starting at ``(x0_j, y0_j)``; ``f0, fp0`` are
    the signal value and slope at ``s = 0`` (the value is returned as ``f0`` plus an
    increment computed without cancellation).  Returns ``(f, f', f'', f''', f'''')``.
    """
    f = f0
    f1 = fp0
    f2 = 0.0
    f3 = 0.0
    f4 = 0.0
    for j in range(x0.shape[0]):
        sig = mp[j, 0]
        k = mp[j, 1]
        a11, a12, a21, a22 = _trans(s, sig, k, int(mp[j, 2]), mp[j, 3], mp[j, 4], mp[j, 5])
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
    ph = phi0 + half
    sph = math.sin(ph)
    cph = math.cos(ph)
    f += 2.0 * sh * (Sa * cph - Sb * sph)
    f1 += Om * (-2.0 * sh) * (Sa * sph + Sb * cph)
    phi = phi0 + Om * s
    S = Sa * math.sin(phi) + Sb * math.cos(phi)
    Sd = Om * (Sa * math.cos(phi) - Sb * math.sin(phi))
    W2 = Om * Om
    f2 -= W2 * S
    f3 -= W2 * Sd
    f4 += W2 * W2 * S
    return f, f1, f2, f3, f4


@njit(cache=True)
def _start(phi0, Om, x0, y0, mp, p, r, Sa, Sb, const):
    """Value and slope of the signal at ``s = 0`` computed from the state."""
    f = const + Sa * math.sin(phi0) + Sb * math.cos(phi0)
    fp = Om * (Sa * math.cos(phi0) - Sb * math.sin(phi0))
    for j in range(x0.shape[0]):
        x2 = -2.0 * mp[j, 0] * y0[j] - mp[j, 1] * x0[j]
        f += p[j] * x0[j] + r[j] * y0[j]
        fp += p[j] * y0[j] + r[j] * x2
    return f, fp


@njit(cache=True)
def _bounds(x0, y0, mp, p, r, Csin, Om):
    """Bounds ``M2, M3, M4`` of the 2nd-4th derivatives of the signal over ``s >= 0``."""
    M2 = Csin * Om ** 2
    M3 = Csin * Om ** 3
    M4 = Csin * Om ** 4
    hb = np.empty(6)
    for j in range(x0.shape[0]):
        _hb(x0[j], y0[j], mp[j, 0], mp[j, 1], int(mp[j, 2]), mp[j, 3], mp[j, 4], mp[j, 5], hb)
        ap = abs(p[j])
        ar = abs(r[j])
        M2 += ap * hb[2] + ar * hb[3]
        M3 += ap * hb[3] + ar * hb[4]
        M4 += ap * hb[4] + ar * hb[5]
    f = 1.0 + 1e-9
    return M2 * f + 1e-300, M3 * f + 1e-300, M4 * f + 1e-300


@njit(cache=True)
def _root(kind, lo, hi, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0):
    """Safeguarded Newton on a bracket with F(lo) < 0 <= F(hi); returns the bracket end
    where F >= 0.  kind 0: F = f; 1: F = -f'; 2: F = f'."""
    dxold = hi - lo
    dx = dxold
    s = 0.5 * (lo + hi)
    for _ in range(200):
        g, v, g2, g3, g4 = _sig(s, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)
        F, dF = select(kind, g, v, g2)
        s, lo, hi, dx, dxold, done = rtsafe_update(F, dF, s, lo, hi, dx, dxold)
        if done:
            return s
    return hi


@njit(cache=True)
def _scan(h, h_min, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, M2, M3, M4):
    """One certified step of at most ``h``: first time the signal reaches 0 from below.

    Returns ``(s_event, h_used)``; ``s_event = -1`` when the signal stays negative on
    ``[0, h_used]`` (guaranteed unless the step fell below ``h_min``).
    """
    g0, v0, g20, g30, _ = _sig(0.0, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)
    tol2 = 1e-13 * M2
    while True:
        g1, v1, g21, g31, _ = _sig(h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)
        if max(g0, g1) + 0.125 * M2 * h * h < 0.0:
            return -1.0, h
        cert = certify_curvature(g20, g30, g21, g31, M3, M4, h, tol2)
        if cert != 0 or h < h_min or not h > 0.0:
            break
        h *= 0.5
    if cert == 0:
        cert = 1 if g20 + g21 > 0.0 else -1
    if cert < 0:
        if v0 > 0.0:
            if v1 >= 0.0:
                if g1 >= 0.0:
                    return _root(0, 0.0, h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0), h
            else:
                bound = g0 + v0 * (g1 - g0 - v1 * h) / (v0 - v1) if v0 - v1 > 0.0 else g0
                if bound >= 0.0:
                    sa = _root(1, 0.0, h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)
                    ga = _sig(sa, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)[0]
                    if ga >= 0.0:
                        if g0 < 0.0:
                            return _root(0, 0.0, sa, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0), h
                        return sa, h
    else:
        if v1 > 0.0 or (v1 == 0.0 and g1 >= 0.0):
            if v0 < 0.0:
                if g1 >= 0.0:
                    sm = _root(2, 0.0, h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)
                    return _root(0, sm, h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0), h
            elif g1 >= 0.0:
                return _root(0, 0.0, h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0), h
    return -1.0, h


@njit(cache=True)
def _extremes(h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, vstart, vend, ext):
    """Update ``ext = [min, max]`` of a signal with the apex/minimum inside ``[0, h]``
    when its slope changes sign between the ends."""
    if vstart < 0.0 < vend:
        sm = _root(2, 0.0, h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)
        v = _sig(sm, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)[0]
        if v < ext[0]:
            ext[0] = v
    elif vstart > 0.0 > vend:
        sa = _root(1, 0.0, h, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)
        v = _sig(sa, phi0, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0)[0]
        if v > ext[1]:
            ext[1] = v


@njit(cache=True)
def _homog(phi0, Om, z, zd, a, b, e, x0, y0):
    sp0 = math.sin(phi0)
    cp0 = math.cos(phi0)
    for j in range(z.shape[0]):
        x0[j] = z[j] - e[j] - (a[j] * sp0 + b[j] * cp0)
        y0[j] = zd[j] - Om * (a[j] * cp0 - b[j] * sp0)


@njit(cache=True)
def _contact_acc(phi, Om, eta, etad, w, cF, kF, GF):
    """Free acceleration of the contact point ``a = w^T (Gamma F sin - C eta' - K eta)`` and
    its time derivative ``w^T (Gamma F Omega cos - C eta'' - K eta')`` (forcing term included)."""
    s = math.sin(phi)
    c = Om * math.cos(phi)
    acc = 0.0
    jerk = 0.0
    for i in range(eta.shape[0]):
        ai = GF[i] * s - cF[i] * etad[i] - kF[i] * eta[i]
        acc += w[i] * ai
        jerk += w[i] * (GF[i] * c - cF[i] * ai - kF[i] * etad[i])
    return acc, jerk


@njit(cache=True)
def apply_impulse(etad, n, U_minus, U_plus, m_eff):
    """Impulse of a contact law through the mass matrix (Moreau / Siconos): ``P = m_eff (U+ -
    U-)`` along ``M^-1 n = n`` (mass-normalised modes), ``eta' += n P`` in place; returns ``U+``.

    ``n`` is the stop's normal (``s w``, :class:`vibeam.models.contact.Relation`)."""
    P = m_eff * (U_plus - U_minus)
    for i in range(etad.shape[0]):
        etad[i] += n[i] * P
    return U_plus


@njit(cache=True)
def apply_impact(etad, w, U_minus, R, m_eff):
    """Newton impact on the contact ``U = w^T eta`` (Moreau / Siconos): impulse
    ``P = restitution_impulse(U-, R, m_eff)`` along ``w``, ``eta' += w P`` in place.
    Returns ``U+ = -R U-`` (the exact law value, used as the contact velocity)."""
    P = restitution_impulse(U_minus, R, m_eff)
    for i in range(etad.shape[0]):
        etad[i] += w[i] * P
    return newton_restitution(U_minus, R)


# Optional event log of ``beam_kernel`` (used by the periodic-orbit shooting of
# :mod:`vibeam.models.periodic_beam`): one row ``[kind, t, aux, eta (N), eta' (N)]`` per
# event, ``t`` from the call start.  Kinds and ``aux``:
#   EV_START    the initial state was put on the stop (aux 1: held, 0: position only);
#               the state logged is the one after the projection;
#   EV_IMPACT   an impact; state just before it (on the stop, pre-impact velocity), aux U-;
#   EV_STICK    sticking entered without an impact (v = 0 at the stop, pressed); state
#               before the velocity projection;
#   EV_STICK_IMPACT  the impact logged just before ends in sticking (plastic entry, chatter
#               or R = 0); aux = chatter hold time (0 if none);
#   EV_RELEASE  release from the stop; state at the release, aux = contact force at
#               the release (0 at a located zero crossing, > 0 when released at a step start).
# ``nlog[0]`` counts events, ``nlog[1]`` apexes (rows beyond the capacity are counted,
# not stored); ``aplog[j] = (t, g)`` holds the interior free-flight apexes of the contact
# gap ``g = w^T eta - Delta_C`` located on steps where ``g'`` falls through zero and, with a
# lower stop, those of its gap ``g_l = -w^T eta - Delta_C,lower`` (minima of ``w^T eta``).
EV_START, EV_IMPACT, EV_STICK, EV_STICK_IMPACT, EV_RELEASE = 0, 1, 2, 3, 4


@njit(cache=True)
def _log_event(evlog, nlog, kind, t, aux, eta, etad):
    k = nlog[0]
    if k < evlog.shape[0]:
        N = eta.shape[0]
        evlog[k, 0] = kind
        evlog[k, 1] = t
        evlog[k, 2] = aux
        for i in range(N):
            evlog[k, 3 + i] = eta[i]
            evlog[k, 3 + N + i] = etad[i]
    nlog[0] = k + 1


@njit(cache=True)
def _log_apex(aplog, nlog, t, h, phi0, Om, x0, y0, mp, p, Sa, Sb, f0, fp0):
    """Locate the apex of the contact gap inside ``[0, h]`` (slope + at 0, <= 0 at h) and log it."""
    zero = np.zeros(x0.shape[0])
    sa = _root(1, 0.0, h, phi0, Om, x0, y0, mp, p, zero, Sa, Sb, f0, fp0)
    ga = _sig(sa, phi0, Om, x0, y0, mp, p, zero, Sa, Sb, f0, fp0)[0]
    k = nlog[1]
    if k < aplog.shape[0]:
        aplog[k, 0] = t + sa
        aplog[k, 1] = ga
    nlog[1] = k + 1


@njit(cache=True)
def beam_kernel(Om, mpF, aF, bF, w, sv, cF, kF, GF, stops, tab_U, tab_R, normals, m_eff,
                mpC, aC, bC, eC, Psi, eta_c, pL, rL, SaL, SbL, cL, pS, SaS, SbS, cS,
                eta, etad, stuck_init,
                n_transient, n_record, ns_transient, ns_record, h_cap,
                max_impacts, max_steps, chatter_tol,
                samples, imp_t, imp_v, imp_k, n_imp_stop, modamp, msamp, pmin, chat_t,
                evlog=None, aplog=None, nlog=None):
    """Exact event-driven simulation of whole forcing periods (numba core).

    ``eta, etad`` (N,) hold the initial modal state and receive the final one.
    ``samples`` (n_record * ns_record, 2) receive ``(s^T eta, s^T eta')``; ``modamp``
    (N,) the max ``|eta_i|`` over the samples; ``msamp`` (same rows or 0 rows, 2N) the
    modal state ``(eta, eta')`` at the samples; ``pmin`` (n_record,) the minimum of the sensor
    signal ``s^T eta`` over each recorded period (root-found like ``smin``); ``chat_t`` the
    times of the first ``len(chat_t)`` chatter accumulation points of the record.

    Stops (:mod:`vibeam.models.contact`): row k of ``stops`` (n_stops, NPAR) is the relation
    (normal ``normals[k] = s_k w``, offset ``Delta_k``) and law of stop k, with its ``R(U-)``
    table in ``tab_U``/``tab_R`` (contact velocity in kernel units); row 0 is the upper stop
    at ``w^T eta = Delta_C``.  The constrained data of the beam held on stop k are the rows
    ``eC[k]``, ``eta_c[k]``, ``pL[k]``, ``rL[k]``, ``SaL[k]``, ``SbL[k]``, ``cL[k]``, ``cS[k]``
    (:meth:`BeamImpactModel.kernel_stops`).  ``imp_k`` receives the stop of each stored impact
    and ``n_imp_stop`` (n_stops,) the recorded impacts per stop; ``stuck_init``: 0 free, 1 held
    on the upper stop.  Returns ``(status, n_imp_rec, smin, smax, n_chatter, stuck_time,
    stuck_end, n_imp_total, gmax, n_steps)`` with ``stuck_end`` as ``stuck_init``.

    ``evlog`` (cap, 3 + 2N), ``aplog`` (cap_a, 2), ``nlog`` (2,) int64: optional event
    and apex log (see ``EV_START``); omitted in sweeps, where the logging branches are
    compiled out.
    """
    N = eta.shape[0]
    Nc = eC.shape[1]
    Delta_C = stops[0, _OFFSET]
    # a second (lower) stop: normal -w at w^T eta = -Dl (vibeam.models.contact); its gap
    # g_l = -w^T eta - Dl is carried beside g like g (value + accurate increments)
    two = stops.shape[0] > 1
    Dl = stops[1, _OFFSET] if two else np.inf
    nl = normals[1] if two else normals[0]
    side = 0 if stuck_init >= 0 else 1     # the stop the beam is held on (when stuck)
    T = TWO_PI / Om
    zeroN = np.zeros(N)
    zeroC = np.zeros(Nc)
    x0 = np.empty(N)
    y0 = np.empty(N)
    xc = np.empty(Nc)
    yc = np.empty(Nc)
    zeta = np.empty(Nc)
    zetad = np.empty(Nc)
    SaF = 0.0
    SbF = 0.0
    SaSF = 0.0
    SbSF = 0.0
    for i in range(N):
        SaF += w[i] * aF[i]
        SbF += w[i] * bF[i]
        SaSF += sv[i] * aF[i]
        SbSF += sv[i] * bF[i]
    CsF = math.sqrt(SaF * SaF + SbF * SbF)
    CsL = np.empty(SaL.shape[0])
    for k in range(SaL.shape[0]):
        CsL[k] = math.sqrt(SaL[k] * SaL[k] + SbL[k] * SbL[k])
    for k in range(n_imp_stop.shape[0]):
        n_imp_stop[k] = 0
    w2 = 0.0
    for i in range(N):
        w2 += w[i] * w[i]
    # damping rate and stiffness per unit mass of the contact coordinate (chatter policy)
    c_eff = 0.0
    k_eff = 0.0
    for i in range(N):
        c_eff += w[i] * w[i] * cF[i]
        k_eff += w[i] * w[i] * kF[i]
    c_eff *= m_eff
    k_eff *= m_eff
    ext = np.array([np.inf, -np.inf])
    # extremes of the current recorded period, folded into ``ext`` at its end
    pext = np.array([np.inf, -np.inf])
    for i in range(pmin.shape[0]):
        pmin[i] = np.inf
    stuck = stuck_init != 0
    g = 0.0
    v = 0.0
    for i in range(N):
        g += w[i] * eta[i]
        v += w[i] * etad[i]
    g -= Delta_C
    scale = abs(Delta_C) + math.sqrt(w2) * math.sqrt(np.sum(eta * eta)) + 1e-300
    gl = -np.inf
    if two:
        gl = -Dl
        for i in range(N):
            gl -= w[i] * eta[i]
    if (stuck and side == 0) or g > -1e-13 * scale:
        corr = g / w2
        for i in range(N):
            eta[i] -= w[i] * corr
        g = 0.0
        if two:
            gl = -Delta_C - Dl
        if stuck:
            v = 0.0
        if evlog is not None:
            _log_event(evlog, nlog, EV_START, 0.0, 1.0 if stuck else 0.0, eta, etad)
    elif two and ((stuck and side == 1) or gl > -1e-13 * (scale + abs(Dl))):
        corr = gl / w2
        for i in range(N):
            eta[i] -= nl[i] * corr
        gl = 0.0
        g = -Dl - Delta_C
        if stuck:
            v = 0.0
        if evlog is not None:
            _log_event(evlog, nlog, EV_START, 0.0, -1.0 if stuck else 0.0, eta, etad)
    gmax = -np.inf
    n_imp_total = 0
    n_imp_rec = 0
    n_chatter = 0
    # Zeno guard: with many modes the contact acceleration is not smooth on the
    # scale of the flights, so the geometric estimate of the chatter accumulation
    # can stay above chatter_tol while the impacts pile up (rebounds of 1e-15 and
    # less).  ``burst`` counts impacts that follow each other within BURST_DT of a
    # forcing period; past BURST_MAX with the contact pressed the sequence is
    # ended as a plastic impact (sticking), counted as chatter.
    burst = 0
    t_last_imp = -1e300
    n_steps = 0
    stuck_time = 0.0
    cap = imp_t.shape[0]
    for i in range(N):
        modamp[i] = 0.0
    just_released = False
    just_stuck = False
    hold = 0.0
    h_last = h_cap
    k_sample = 0
    n_total = n_transient + n_record
    for pp in range(n_total):
        recording = pp >= n_transient
        ns = ns_record if recording else ns_transient
        h_grid = T / ns
        t_period0 = (pp - n_transient) * T
        if pp > n_transient:
            # fold the extremes of the period just finished
            pmin[pp - n_transient - 1] = pext[0]
            ext[0] = min(ext[0], pext[0])
            ext[1] = max(ext[1], pext[1])
            pext[0] = np.inf
            pext[1] = -np.inf
        for jg in range(ns):
            phi = TWO_PI * jg / ns
            t_loc = jg * h_grid
            if recording:
                qs = 0.0
                qd = 0.0
                for i in range(N):
                    qs += sv[i] * eta[i]
                    qd += sv[i] * etad[i]
                    if abs(eta[i]) > modamp[i]:
                        modamp[i] = abs(eta[i])
                samples[k_sample, 0] = qs
                samples[k_sample, 1] = qd
                if msamp.shape[0] > 0:
                    for i in range(N):
                        msamp[k_sample, i] = eta[i]
                        msamp[k_sample, N + i] = etad[i]
                k_sample += 1
                if qs < pext[0]:
                    pext[0] = qs
                if qs > pext[1]:
                    pext[1] = qs
            rem = h_grid
            while rem > 0.0:
                n_steps += 1
                if n_steps > max_steps:
                    return (ST_FAILED, n_imp_rec, min(ext[0], pext[0]), max(ext[1], pext[1]), n_chatter, stuck_time,
                            _side_code(stuck, side), n_imp_total, gmax, n_steps)
                h_try = min(rem, h_cap, 2.0 * h_last)
                if stuck:
                    # ---- constrained motion on stop ``side``; scan the contact force ----
                    eCk = eC[side]
                    etck = eta_c[side]
                    pLk = pL[side]
                    rLk = rL[side]
                    for j in range(Nc):
                        zz = 0.0
                        zd = 0.0
                        for i in range(N):
                            zz += Psi[i, j] * (eta[i] - etck[i])
                            zd += Psi[i, j] * etad[i]
                        zeta[j] = zz
                        zetad[j] = zd
                    _homog(phi, Om, zeta, zetad, aC, bC, eCk, xc, yc)
                    const = cL[side]
                    for j in range(Nc):
                        const += pLk[j] * eCk[j]
                    lam0, lamp0 = _start(phi, Om, xc, yc, mpC, pLk, rLk, SaL[side], SbL[side], const)
                    # the shared release rule: lambda > 0 pulls the beam away (-lambda presses)
                    if release_now(-lam0, -lamp0) and not just_stuck and hold <= 0.0:
                        if evlog is not None:
                            _log_event(evlog, nlog, EV_RELEASE, pp * T + t_loc, lam0, eta, etad)
                        stuck = False
                        just_released = True
                        g, gl = _on_stop(side, two, Delta_C, Dl)
                        v = 0.0
                        continue
                    if lam0 > 0.0:
                        lam0 = 0.0
                    # the hold is the rest of a chatter sequence (impacts accumulating), not
                    # sticking: it is not counted in stuck_time, as in the SDOF kernel, whose
                    # chatter jump advances the clock to the accumulation point unstuck
                    held = hold > 0.0
                    if hold > 0.0:
                        # held through the chatter accumulation time: no release check
                        s_ev = -1.0
                        h = min(h_try, hold)
                        hold -= h
                        if hold < 1e-15 * T:
                            hold = 0.0
                    else:
                        M2, M3, M4 = _bounds(xc, yc, mpC, pLk, rLk, CsL[side], Om)
                        s_ev, h = _scan(h_try, 1e-13 * T, phi, Om, xc, yc, mpC, pLk, rLk, SaL[side], SbL[side],
                                        lam0, lamp0, M2, M3, M4)
                        if s_ev < 0.0:
                            h_last = h
                    s_mv = s_ev if s_ev >= 0.0 else h
                    if recording:
                        # sensor extremes while stuck
                        constS = cS[side]
                        for j in range(Nc):
                            constS += pS[j] * eCk[j]
                        q0s, qp0s = _start(phi, Om, xc, yc, mpC, pS, zeroC, SaS, SbS, constS)
                        q1s, qp1s, _a, _b, _c = _sig(s_mv, phi, Om, xc, yc, mpC, pS, zeroC, SaS, SbS, q0s, qp0s)
                        _extremes(s_mv, phi, Om, xc, yc, mpC, pS, zeroC, SaS, SbS, q0s, qp0s, qp0s, qp1s, pext)
                        if not held:
                            stuck_time += s_mv
                    _advance(s_mv, phi, Om, zeta, zetad, mpC, aC, bC, eCk)
                    for i in range(N):
                        zz = etck[i]
                        zd = 0.0
                        for j in range(Nc):
                            zz += Psi[i, j] * zeta[j]
                            zd += Psi[i, j] * zetad[j]
                        eta[i] = zz
                        etad[i] = zd
                    phi, t_loc, rem = _clock(phi, t_loc, rem, s_mv, Om, T)
                    if s_mv > 0.0:
                        just_stuck = False
                        just_released = False
                    if s_ev >= 0.0:
                        if evlog is not None:
                            _log_event(evlog, nlog, EV_RELEASE, pp * T + t_loc, 0.0, eta, etad)
                        stuck = False
                        just_released = True
                        g, gl = _on_stop(side, two, Delta_C, Dl)
                        v = 0.0
                    continue
                # ---- free flight ----
                s_imp = -1.0
                k_imp = 0
                if g >= 0.0 and v >= 0.0:
                    g = 0.0
                    if v > 0.0:
                        s_imp = 0.0
                    elif not just_released:
                        acc, jerk = _contact_acc(phi, Om, eta, etad, w, cF, kF, GF)
                        if acc > 0.0:
                            if evlog is not None:
                                _log_event(evlog, nlog, EV_STICK, pp * T + t_loc, 0.0, eta, etad)
                            stuck = True
                            side = 0
                            just_stuck = True
                            corr = v / w2
                            for i in range(N):
                                etad[i] -= w[i] * corr
                            continue
                elif two and gl >= 0.0 and v <= 0.0:
                    # the same on the lower stop (normal -w, normal velocity -v)
                    gl = 0.0
                    if v < 0.0:
                        s_imp = 0.0
                        k_imp = 1
                    elif not just_released:
                        acc, jerk = _contact_acc(phi, Om, eta, etad, nl, cF, kF, GF)
                        if acc > 0.0:
                            if evlog is not None:
                                _log_event(evlog, nlog, EV_STICK, pp * T + t_loc, 0.0, eta, etad)
                            stuck = True
                            side = 1
                            just_stuck = True
                            corr = -v / w2
                            for i in range(N):
                                etad[i] -= nl[i] * corr
                            continue
                if s_imp < 0.0:
                    _homog(phi, Om, eta, etad, aF, bF, zeroN, x0, y0)
                    M2, M3, M4 = _bounds(x0, y0, mpF, w, zeroN, CsF, Om)
                    s_ev, h = _scan(h_try, 1e-13 * T, phi, Om, x0, y0, mpF, w, zeroN, SaF, SbF,
                                    g, v, M2, M3, M4)
                    if two:
                        # the lower gap on [0, first upper event or certified step]: the same
                        # bounds (|-w| = |w|); the earlier event wins, a shorter certified step
                        # of the lower scan shortens the step
                        h_l = s_ev if s_ev >= 0.0 else h
                        s_evl, h_l2 = _scan(h_l, 1e-13 * T, phi, Om, x0, y0, mpF, nl, zeroN, -SaF, -SbF,
                                            gl, -v, M2, M3, M4)
                        if s_evl >= 0.0:
                            s_ev = s_evl
                            k_imp = 1
                        elif h_l2 < h_l:
                            s_ev = -1.0
                            h = h_l2
                    s_mv = s_ev if s_ev >= 0.0 else h
                    if s_ev < 0.0:
                        h_last = h
                    g1, v1, _a, _b, _c = _sig(s_mv, phi, Om, x0, y0, mpF, w, zeroN, SaF, SbF, g, v)
                    gl1 = -np.inf
                    if two:
                        gl1 = _sig(s_mv, phi, Om, x0, y0, mpF, nl, zeroN, -SaF, -SbF, gl, -v)[0]
                    if aplog is not None and s_ev < 0.0 and v > 0.0 and v1 <= 0.0:
                        _log_apex(aplog, nlog, pp * T + t_loc, s_mv, phi, Om, x0, y0, mpF, w, SaF, SbF, g, v)
                    if aplog is not None and two and s_ev < 0.0 and v < 0.0 and v1 >= 0.0:
                        # the lower stop's: an interior minimum of w^T eta, logged as its gap g_l
                        _log_apex(aplog, nlog, pp * T + t_loc, s_mv, phi, Om, x0, y0, mpF, nl, -SaF, -SbF, gl, -v)
                    if recording:
                        q0s, qp0s = _start(phi, Om, x0, y0, mpF, sv, zeroN, SaSF, SbSF, 0.0)
                        q1s, qp1s, _a, _b, _c = _sig(s_mv, phi, Om, x0, y0, mpF, sv, zeroN, SaSF, SbSF, q0s, qp0s)
                        _extremes(s_mv, phi, Om, x0, y0, mpF, sv, zeroN, SaSF, SbSF, q0s, qp0s, qp0s, qp1s, pext)
                        if q1s < pext[0]:
                            pext[0] = q1s
                        if q1s > pext[1]:
                            pext[1] = q1s
                    _advance(s_mv, phi, Om, eta, etad, mpF, aF, bF, zeroN)
                    phi, t_loc, rem = _clock(phi, t_loc, rem, s_mv, Om, T)
                    if s_mv > 0.0:
                        just_stuck = False
                        just_released = False
                    if g1 > gmax:
                        gmax = g1
                    if gl1 > gmax:
                        gmax = gl1
                    if s_ev < 0.0:
                        g = g1 if g1 < 0.0 else 0.0
                        if two:
                            gl = gl1 if gl1 < 0.0 else 0.0
                        v = v1
                        continue
                    v = v1
                    s_imp = s_ev
                # ---- impact at the current time on stop k_imp (normal n, offset Dk) ----
                n = normals[k_imp]
                vk = v if k_imp == 0 else -v
                g, gl = _on_stop(k_imp, two, Delta_C, Dl)
                # Re-sync the state with the carried contact signal: ``g, v`` are carried
                # as value + increment (no cancellation), so they differ from the state's
                # ``w^T eta - Delta_C, w^T eta'`` by round-off that nothing contracts (the
                # impact resets ``g`` to 0 and maps the velocity offset to itself).  On a
                # periodic orbit that round-off is the same every period, so the offset,
                # i.e. a shift of the stop seen by the state, grew linearly with the
                # periods of one call (~1.6e-18 per period, 4e-13 in the state after 10^4
                # periods of the one-mode beam).  Project the state onto the event
                # (contact at gap 0 with velocity v) along w, as at a stick.
                gs = -stops[k_imp, _OFFSET]
                vs = 0.0
                for i in range(N):
                    gs += n[i] * eta[i]
                    vs += n[i] * etad[i]
                gs /= w2
                vs = (vs - vk) / w2
                for i in range(N):
                    eta[i] -= n[i] * gs
                    etad[i] -= n[i] * vs
                Um = vk if vk > 0.0 else 0.0
                if evlog is not None:
                    _log_event(evlog, nlog, EV_IMPACT, pp * T + t_loc, Um, eta, etad)
                # CONTACT EVENT: the stop's law (an impulsive one; a compliant law would enter
                # its contact phase here, see vibeam.models.contact), impulse along its normal
                Up, Rc = impulsive_response(Um, stops[k_imp], tab_U[k_imp], tab_R[k_imp])
                vk = apply_impulse(etad, n, Um, Up, m_eff)
                v = vk if k_imp == 0 else -vk
                n_imp_total += 1
                if recording:
                    if n_imp_rec < cap:
                        imp_t[n_imp_rec] = t_period0 + t_loc
                        imp_v[n_imp_rec] = Um
                        imp_k[n_imp_rec] = k_imp
                    n_imp_rec += 1
                    n_imp_stop[k_imp] += 1
                if n_imp_total > max_impacts:
                    return (ST_FAILED, n_imp_rec, min(ext[0], pext[0]), max(ext[1], pext[1]), n_chatter, stuck_time,
                            _side_code(stuck, side), n_imp_total, gmax, n_steps)
                # the shared policy (vibeam.models.contact_policy), R at the current impact
                # velocity: the jerk beyond the one-DOF flow part -c_eff a + k_eff u is the
                # forcing term plus the modal remainder (zero for one mode); a chatter jumps only
                # to an accumulation point inside the current grid step; the Zeno guard is on
                u = -vk
                acc, jerk = _contact_acc(phi, Om, eta, etad, n, cF, kF, GF)
                t_imp = t_period0 + t_loc
                burst = zeno_burst(burst, t_imp, t_last_imp, BURST_DT * T)
                t_last_imp = t_imp
                action, D = impact_outcome(u, acc > 0.0, acc, jerk + c_eff * acc - k_eff * u, c_eff, k_eff,
                                           Rc, chatter_tol, rem, burst, BURST_MAX)
                stick_now = action != REBOUND
                if action == STICK or action == CHATTER_GUARD:
                    burst = 0
                if action == CHATTER_GUARD:
                    if recording:
                        n_chatter += 1
                        if n_chatter <= chat_t.shape[0]:
                            chat_t[n_chatter - 1] = t_imp
                elif action == CHATTER:
                    hold = D
                    if recording:
                        n_chatter += 1
                        if n_chatter <= chat_t.shape[0]:
                            chat_t[n_chatter - 1] = t_imp + D
                if stick_now:
                    if evlog is not None:
                        _log_event(evlog, nlog, EV_STICK_IMPACT, pp * T + t_loc, hold, eta, etad)
                    corr = vk / w2
                    for i in range(N):
                        etad[i] -= n[i] * corr
                    v = 0.0
                    stuck = True
                    side = k_imp
                    just_stuck = True
    if n_record > 0:
        pmin[n_record - 1] = pext[0]
        ext[0] = min(ext[0], pext[0])
        ext[1] = max(ext[1], pext[1])
    status = ST_OK
    if n_record > 0:
        if n_chatter > 0:
            status = ST_CHATTER
        elif stuck_time > 0.0:
            status = ST_STICKING
    return (status, n_imp_rec, ext[0], ext[1], n_chatter, stuck_time, _side_code(stuck, side),
            n_imp_total, gmax, n_steps)


@njit(cache=True)
def _on_stop(k, two, Delta_C, Dl):
    """Carried gaps ``(g, g_l)`` of the beam on stop k (0 upper, 1 lower)."""
    if k == 0:
        return 0.0, (-Delta_C - Dl if two else -np.inf)
    return -Dl - Delta_C, 0.0


@njit(cache=True)
def _side_code(stuck, side):
    """Held-state code of the kernels: 0 free, 1 on the upper stop, -1 on the lower one."""
    if not stuck:
        return 0
    return 1 if side == 0 else -1


# ============================================================================ model
class BeamImpactModel:
    """Impacting cantilever in ``N`` modal coordinates (fidelity ``"beam"``).

    Build it with :meth:`from_fe` (FE modes) or :meth:`static_mode` (the paper's single
    static assumed mode, beam mass excluded), or directly from modal data.

    Parameters
    ----------
    omega_rad_s, participation, contact_row, sensor_row : array_like, shape (N,)
        Modal frequencies ``omega_i``, ``Gamma_i = phi_i^T M r`` (sqrt(kg)), ``w_i = w^T
        phi_i`` and ``s_i = s^T phi_i`` (1/sqrt(kg)) of mass-normalised shapes.
    R : float
        Coefficient of restitution.
    gap_contact_m : float
        ``Delta_C`` (m; negative = pre-stressed stop).
    base_amplitude_m : float
        ``Y = gamma~ V`` (m).
    f_ref_hz : float
        Reference frequency: ``Omega = f / f_ref``, ``t = 2 pi f_ref t~``.
    length_m : float
        ``L``.
    phi_at_mass : float
        Static-mode ratio ``phi(x_m)`` (``phi(x_S) = 1``), giving
        ``Delta = Delta_C / (phi(x_m) L)`` as in the SDOF model.
    damping_D_s, rayleigh_alpha_1_s : float
        ``C = alpha M + D K`` so that ``c_i = alpha + D omega_i^2``.
    modal_damping_1_s : array_like, shape (N,), optional
        Per-mode damping ``c_i`` (1/s) replacing the Rayleigh law (used by the coupled
        platform of :mod:`vibeam.engine.effects`); the constrained modes then get the diagonal of
        ``Psi^T diag(c) Psi`` (modal damping kept modal, off-diagonal terms dropped).
    restitution_table : (array_like, array_like), optional
        ``(U-, R)`` nodes of a velocity-dependent R with ``U-`` the pre-impact contact
        velocity in kernel units (m per nondimensional time); None = constant ``R``.
    gap_contact_lower_m : float or None, optional
        A second (lower) stop at ``w^T eta = -Delta_C,lower`` (m, distance from the static
        equilibrium at the contact point, positive; ``Delta_C + Delta_C,lower > 0``); None: one
        stop.
    R_lower : float or None, optional
        Coefficient of restitution of the lower stop; None: the upper stop's law (``R`` and
        the table).
    """

    fidelity = "beam"

    def __init__(self, omega_rad_s, participation, contact_row, sensor_row, R, gap_contact_m,
                 base_amplitude_m, f_ref_hz, length_m, phi_at_mass, damping_D_s=0.0,
                 rayleigh_alpha_1_s=0.0, label="", modal_damping_1_s=None, restitution_table=None,
                 gap_contact_lower_m=None, R_lower=None):
        self.omega_rad_s = np.asarray(omega_rad_s, dtype=float).copy()
        self.participation = np.asarray(participation, dtype=float).copy()
        self.contact_row = np.asarray(contact_row, dtype=float).copy()
        self.sensor_row = np.asarray(sensor_row, dtype=float).copy()
        n = self.omega_rad_s.size
        if not (self.participation.size == self.contact_row.size == self.sensor_row.size == n and n >= 1):
            raise ValueError("modal arrays must have the same length >= 1")
        if not np.all(self.omega_rad_s > 0):
            raise ValueError("modal frequencies must be positive")
        if not 0.0 <= R <= 1.0:
            raise ValueError("R must lie in [0, 1]")
        if damping_D_s < 0 or rayleigh_alpha_1_s < 0:
            raise ValueError("damping coefficients must be >= 0")
        if not np.any(self.contact_row != 0):
            raise ValueError("no retained mode moves the contact point")
        self.R = float(R)
        self.gap_contact_m = float(gap_contact_m)
        self.base_amplitude_m = float(base_amplitude_m)
        self.f_ref_hz = float(f_ref_hz)
        self.length_m = float(length_m)
        self.phi_at_mass = float(phi_at_mass)
        self.damping_D_s = float(damping_D_s)
        self.rayleigh_alpha_1_s = float(rayleigh_alpha_1_s)
        self.modal_damping_1_s = (None if modal_damping_1_s is None
                                  else np.asarray(modal_damping_1_s, dtype=float).copy())
        if self.modal_damping_1_s is not None and self.modal_damping_1_s.shape != (n,):
            raise ValueError("modal_damping_1_s must have one entry per mode")
        if restitution_table is None:
            self.R_table_U = np.zeros(0)
            self.R_table_R = np.zeros(0)
        else:
            self.R_table_U = np.ascontiguousarray(restitution_table[0], dtype=float)
            self.R_table_R = np.ascontiguousarray(restitution_table[1], dtype=float)
        self.gap_contact_lower_m = None if gap_contact_lower_m is None else float(gap_contact_lower_m)
        self.R_lower = None if R_lower is None else float(R_lower)
        if self.R_lower is not None and not 0.0 <= self.R_lower <= 1.0:
            raise ValueError("R_lower must lie in [0, 1]")
        if self.gap_contact_lower_m is not None and not self.gap_contact_m + self.gap_contact_lower_m > 0.0:
            raise ValueError("the stops overlap: gap_contact_m + gap_contact_lower_m must be > 0")
        self.label = label
        self._constrained()

    # ---------------------------------------------------------------- constructors
    @classmethod
    def from_fe(cls, fe, n_modes=2, R=0.72, gap_contact_m=0.0, base_amplitude_m=0.0,
                f_ref_hz=None, damping_D_s=None, rayleigh_alpha_1_s=None, gap_contact_lower_m=None,
                R_lower=None):
        """Modal truncation of a :class:`vibeam.models.beam.BeamFE` to ``n_modes`` (int or
        ``"all"``).  Damping defaults to the FE model's; ``f_ref`` to its ``f_1``."""
        from vibeam.reductions.modal import modal_reduction
        from vibeam.reductions.static_mode import static_mode_shape

        red = modal_reduction(fe, n_modes)
        md = fe.modes(red.n_modes)
        g = fe.geometry
        L = g.length_m
        phim = float(static_mode_shape(g.mass_position_m / L, g.mass_position_m / L,
                                       g.sensor_position_m / L))
        return cls(red.omega_rad_s, md.participation, red.contact_row, red.sensor_row, R,
                   gap_contact_m, base_amplitude_m,
                   md.frequencies_hz[0] if f_ref_hz is None else f_ref_hz, L, phim,
                   fe.damping_D_s if damping_D_s is None else damping_D_s,
                   fe.rayleigh_alpha_1_s if rayleigh_alpha_1_s is None else rayleigh_alpha_1_s,
                   label=f"FE {red.n_modes} modes", gap_contact_lower_m=gap_contact_lower_m, R_lower=R_lower)

    @classmethod
    def static_mode(cls, geometry, R=0.72, gap_contact_m=0.0, base_amplitude_m=0.0,
                    damping_D_s=0.0, f_ref_hz=None, gap_contact_lower_m=None, R_lower=None):
        """One assumed shape, the static mode ``phi`` (paper Eqs. 42-47, beam mass
        excluded): mass ``M_S = m phi(x_m)^2``, stiffness ``K_S``, load ``m phi(x_m)``.

        The mass-normalised shape is ``phi / sqrt(M_S)`` in ``U = L phi q``, i.e. the
        modal coordinate is ``eta = L sqrt(M_S) q``, so ``w = phi(x_m) / sqrt(M_S)``,
        ``s = 1 / sqrt(M_S)``, ``Gamma = m phi(x_m) / sqrt(M_S)`` and ``m_eff = m``.
        """
        from vibeam.reductions.static_mode import reduce_static_mode

        red = reduce_static_mode(geometry, damping_D_s=damping_D_s, gap_contact_m=gap_contact_m)
        sq = math.sqrt(red.M_S_kg)
        phim = red.phi_at_mass
        return cls([red.omega_n_rad_s], [geometry.mass_kg * phim / sq], [phim / sq], [1.0 / sq],
                   R, gap_contact_m, base_amplitude_m,
                   red.f_n_hz if f_ref_hz is None else f_ref_hz, geometry.length_m, phim,
                   damping_D_s, 0.0, label="static mode", gap_contact_lower_m=gap_contact_lower_m,
                   R_lower=R_lower)

    # ---------------------------------------------------------------- derived data
    @property
    def n_modes(self) -> int:
        return self.omega_rad_s.size

    @property
    def omega_ref(self) -> float:
        return TWO_PI * self.f_ref_hz

    @property
    def natural_frequency_hz(self) -> float:
        return self.f_ref_hz

    @property
    def Delta_G_m(self) -> float:
        return self.gap_contact_m / self.phi_at_mass

    @property
    def Delta(self) -> float:
        """``Delta_G / L`` with ``Delta_G = Delta_C / phi(x_m)``."""
        return self.Delta_G_m / self.length_m

    @property
    def m_eff(self) -> float:
        return float(1.0 / np.sum(self.contact_row ** 2))

    @property
    def force_scale_n(self) -> float:
        """Newtons per unit of the nondimensional contact force ``F / (m_eff omega_ref^2 L)``
        (joules per unit of the nondimensional energy: this times ``L``)."""
        return self.m_eff * self.omega_ref ** 2 * self.length_m

    @property
    def k_nd(self) -> np.ndarray:
        """``(omega_i / omega_ref)^2``."""
        return (self.omega_rad_s / self.omega_ref) ** 2

    @property
    def c_nd(self) -> np.ndarray:
        """``(alpha + D omega_i^2) / omega_ref`` (or ``modal_damping_1_s / omega_ref``)."""
        return self.c_phys / self.omega_ref

    @property
    def c_phys(self) -> np.ndarray:
        """Modal damping ``c_i`` (1/s)."""
        if getattr(self, "modal_damping_1_s", None) is not None:
            return self.modal_damping_1_s
        return self.rayleigh_alpha_1_s + self.damping_D_s * self.omega_rad_s ** 2

    @property
    def two_sided(self) -> bool:
        """A second stop below (``gap_contact_lower_m`` given)."""
        return getattr(self, "gap_contact_lower_m", None) is not None

    def stops(self) -> tuple:
        """The contact relations and laws (:mod:`vibeam.models.contact`): the stop at
        ``w^T eta = Delta_C`` (normal ``w``) with Newton's law, ``R`` and ``R(U-)``, and for a
        two-sided scene the stop at ``w^T eta = -Delta_C,lower`` (normal ``-w``) with its law."""
        upper = Restitution(self.R, tuple(self.R_table_U), tuple(self.R_table_R))
        out = (Stop(Relation(1.0, self.gap_contact_m), upper),)
        if self.two_sided:
            law = upper if self.R_lower is None else Restitution(self.R_lower)
            out += (Stop(Relation(-1.0, self.gap_contact_lower_m), law),)
        return out

    def _constrained(self):
        """Null-space basis, constrained modes and contact-force coefficients.

        The beam held on stop k (``s_k w^T eta = Delta_k``) moves in ``eta = eta_c,k + Psi
        zeta``: ``Psi`` and the constrained modes are the same for every stop (the null space of
        ``w``), the offsets ``eta_c,k``, ``eC_k`` and the contact-force coefficients differ; they
        are the rows of :attr:`stop_rows` (``eta_c``, ``eC``, ... are the upper stop's)."""
        w = self.contact_row
        N = w.size
        w2 = float(w @ w)
        Q, _ = np.linalg.qr(np.column_stack([w, np.eye(N)]))
        Tn = Q[:, 1:N]
        K = np.diag(self.k_nd)
        if N > 1:
            nu2, V = scipy.linalg.eigh(Tn.T @ K @ Tn)
            Psi = Tn @ V
        else:
            nu2, Psi = np.zeros(0), np.zeros((1, 0))
        self.Psi = np.ascontiguousarray(Psi)
        self.nu2 = nu2
        aD = self.rayleigh_alpha_1_s / self.omega_ref
        DD = self.damping_D_s * self.omega_ref
        self.cC = aD + DD * nu2
        if self.modal_damping_1_s is not None:
            self.cC = np.einsum("ij,i,ij->j", Psi, self.c_nd, Psi)
        self.GC = Psi.T @ self.participation
        me = 1.0 / w2
        C = np.diag(self.c_nd)
        self.pS = self.sensor_row @ Psi
        rows = {k: [] for k in ("normals", "eta_c", "eC", "pL", "rL", "cL", "cS")}
        for st in self.stops():
            s, D = st.relation.sign, st.relation.offset
            n = st.relation.normal(w)
            eta_c = w * D / w2 if s > 0 else w * (-D) / w2
            rows["normals"].append(n)
            rows["eta_c"].append(eta_c)
            rows["eC"].append(-(Psi.T @ (K @ eta_c)) / np.where(nu2 > 0, nu2, 1.0))
            rows["pL"].append(me * (n @ K @ Psi))
            rows["rL"].append(me * (n @ C @ Psi))
            rows["cL"].append(me * float(n @ K @ eta_c))
            rows["cS"].append(float(self.sensor_row @ eta_c))
        #: per-stop kernel data (row k: stop k), see :func:`beam_kernel`
        self.stop_rows = {k: np.ascontiguousarray(np.stack(v) if k not in ("cL", "cS") else np.array(v, dtype=float))
                          for k, v in rows.items()}
        r = self.stop_rows
        self.eta_c = r["eta_c"][0].copy()
        self.eC = r["eC"][0].copy()
        self.pL = r["pL"][0].copy()
        self.rL = r["rL"][0].copy()
        self.lam_const = float(r["cL"][0])
        self.sens_const = float(r["cS"][0])

    def stop_forcing(self, aC, bC, F, Om):
        """Harmonic coefficients ``(SaL, SbL)`` (n_stops,) of the contact force of the beam held
        on each stop, for the constrained particular solution ``aC, bC`` at forcing ``F``, ``Om``."""
        me = self.m_eff
        r = self.stop_rows
        SaL = np.empty(r["cL"].size)
        SbL = np.empty(r["cL"].size)
        for k in range(SaL.size):
            lamF = -me * float(r["normals"][k] @ self.participation) * F
            SaL[k] = lamF + float(r["pL"][k] @ aC - Om * (r["rL"][k] @ bC))
            SbL[k] = float(r["pL"][k] @ bC + Om * (r["rL"][k] @ aC))
        return SaL, SbL

    # ---- the model protocol of the fidelity registry (vibeam.models.registry)
    @property
    def phi_contact(self) -> float:
        """Static-mode value at the contact point over the sensor's (``phi(x_m)``, or
        ``phi_c`` of an eccentric contact): contact displacements over it are the sensor's."""
        return self.phi_at_mass

    def free_mode_frequencies(self) -> np.ndarray:
        """Frequencies of the retained modes over the reference frequency, shape (N,)."""
        return np.asarray(self.omega_rad_s) / (2 * math.pi) / self.f_ref_hz

    def contact_mode_frequencies(self) -> np.ndarray:
        """Frequencies of the modes of the beam held on the stop over the reference, (N - 1,)."""
        return np.sqrt(np.maximum(np.asarray(self.nu2), 0.0))

    def restitution_coefficients(self, velocities, stops=None) -> np.ndarray:
        """R of impacts with recorded pre-impact normal velocities ``U- / L`` (per
        nondimensional time, the trajectory's unit), shape (k,), on the stops ``stops`` (k,)
        (0 upper, 1 lower; None: all on the upper one): the law of the kernel, in its units."""
        v = np.asarray(velocities, float)
        if stops is None:
            return np.array([restitution_coefficient(float(x) * self.length_m, self.R, self.R_table_U,
                                                     self.R_table_R) for x in v])
        laws = [s.law for s in self.stops()]
        return np.array([laws[int(k)].coefficient(float(x) * self.length_m) for x, k in zip(v, stops)])

    def with_gain(self, gain_per_V: float, scene_gain_per_V: float, voltage: float) -> "BeamImpactModel":
        """The model at excitation gain ``gamma`` (1/V) instead of the scene's: the base
        amplitude ``Y = gamma~ V`` scales with it (Eq. 46)."""
        m = copy.copy(self)
        m.base_amplitude_m = self.base_amplitude_m * (gain_per_V / scene_gain_per_V)
        return m

    def with_base_amplitude_m(self, Y: float) -> "BeamImpactModel":
        """The model with base displacement amplitude ``Y`` (m)."""
        m = copy.copy(self)
        m.base_amplitude_m = float(Y)
        return m

    def with_sensor_gap_mm(self, gap_mm: float, length_mm: float) -> "BeamImpactModel":
        """The model with the grazing gap ``gap_mm`` at the sensor: ``Delta_C = phi_c Delta_G``."""
        m = copy.copy(self)
        m.gap_contact_m = (gap_mm * 1e-3) * self.phi_contact
        m._constrained()
        return m

    def initial_state(self) -> np.ndarray:
        """``(eta, eta', stuck)``: rest at the origin, or on a pre-stressed stop at the
        static constrained equilibrium ``eta_c + Psi e``."""
        N = self.n_modes
        s = np.zeros(2 * N + 1)
        if self.gap_contact_m < 0:
            s[:N] = self.eta_c + self.Psi @ self.eC
        elif self.two_sided and self.gap_contact_lower_m < 0:
            r = self.stop_rows
            s[:N] = r["eta_c"][1] + self.Psi @ r["eC"][1]
        return s

    def linear_sensor_amplitude_m(self, Omega):
        """Steady-state sensor amplitude without the stop (m), from the modal sum."""
        W = Omega * self.omega_ref
        H = self.participation * W**2 * self.base_amplitude_m / (
            self.omega_rad_s**2 - W**2 + 1j * W * self.c_phys)
        return float(abs(self.sensor_row @ H))


# ============================================================================ solvers
def newton_contact_rows(model: BeamImpactModel, velocities, stops=None) -> np.ndarray:
    """Contact rows (:attr:`vibeam.models.trajectory.Trajectory.contacts`) of Newton impacts.

    An impact with normal pre-impact speed ``U-`` on the relation ``g = n^T eta - Delta`` of the
    mass-normalised modal beam receives the impulse ``P = -m_eff (1 + R) U-`` along ``n``
    (:func:`apply_impulse`, ``m_eff = 1 / |w|^2``), which removes the kinetic energy
    ``(1 - R^2) m_eff U-^2 / 2`` of the modal state (``|eta'|^2 / 2``) and nothing else.  In
    the units of the compliant beam's rows (:mod:`vibeam.models.beam_compliant`: work per
    ``m_eff L^2``, time unit ``1 / omega_ref``) that is ``(1 - R^2) v^2 / 2`` with ``v = U- / L``,
    the SDOF's expression (:class:`vibeam.models.sdof.EventSolver`).

    Parameters
    ----------
    model : BeamImpactModel
    velocities : ndarray, shape (k,)
        Recorded pre-impact normal speeds ``U- / L`` (per nondimensional time).
    stops : ndarray of int, shape (k,), or None
        Stop of each impact (0 upper, 1 lower), each with its own law; None: one stop.

    Returns
    -------
    ndarray, shape (k, 5)
        Duration 0, peak force NaN (an impulse), penetration 0, energy lost, ``v``.
    """
    v = np.asarray(velocities, float)
    k = v.shape[0]
    Rk = model.restitution_coefficients(v, stops) if k else np.zeros(0)
    return np.column_stack([np.zeros(k), np.full(k, np.nan), np.zeros(k), 0.5 * (1.0 - Rk ** 2) * v ** 2, v])


class BeamEventSolver:
    """Method ``event`` for the beam: exact event-driven modal solver (numba core).

    Parameters
    ----------
    model : BeamImpactModel
    transient_samples : int
        Grid points per forcing period in the transient (efficiency only).
    chatter_tol : float
        Accuracy required of the chatter accumulation estimate before sticking.
    max_impacts_per_period : int
        Guard against non-accumulating chatter (status ``failed``).
    max_steps_per_period : int
        Guard against step-size collapse (status ``failed``; never hangs).
    steps_per_fundamental : int
        Largest step is ``1 / steps_per_fundamental`` of the first modal period.
    impact_buffer : int
        Most impacts stored per point.
    """

    name = "event"
    time_domain = True
    #: work budget of one kernel call in steps x modes (``max_steps_per_call`` = this / n_modes)
    MAX_STEP_MODES_PER_CALL = 20_000_000

    def __init__(self, model: BeamImpactModel, transient_samples: int = 16, chatter_tol: float = 1e-7,
                 max_impacts_per_period: int = 20000, max_steps_per_period: int = 20000,
                 steps_per_fundamental: int = 16, impact_buffer: int = 4096,
                 record_modal_states: bool = False):
        self.model = model
        self.transient_samples = int(transient_samples)
        self.chatter_tol = float(chatter_tol)
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.max_steps_per_period = int(max_steps_per_period)
        self.steps_per_fundamental = int(steps_per_fundamental)
        self.impact_buffer = int(impact_buffer)
        self.record_modal_states = bool(record_modal_states)
        check_stops(model.stops())
        # periods per call of the sweep engine (vibeam.engine.sweep.simulate): the cost per period grows
        # with the modes (29 us for 2 modes, ~15 ms for the 46 of the rig mesh when it chatters),
        # so a call lasts well under a second
        self.chunk_periods = max(16, 2000 // model.n_modes)
        # work budget of one kernel call (steps; a step costs more with more modes): beyond it the
        # call is ``incomplete`` and the sweep engine repeats it in shorter calls
        self.max_steps_per_call = max(100_000, self.MAX_STEP_MODES_PER_CALL // model.n_modes)

    def settings(self) -> dict:
        return dict(transient_samples=self.transient_samples, chatter_tol=self.chatter_tol,
                    max_impacts_per_period=self.max_impacts_per_period,
                    max_steps_per_period=self.max_steps_per_period,
                    steps_per_fundamental=self.steps_per_fundamental,
                    n_modes=self.model.n_modes)

    def point(self, Omega: float, state0, n_transient: int, n_record: int,
              samples_per_period: int = 64) -> Trajectory:
        """Simulate one forcing frequency ``Omega = f / f_ref`` from ``state0`` (phase 0).

        ``state0``: ``(eta (N), eta' (N), stuck)`` or None (:meth:`BeamImpactModel.initial_state`).
        """
        m = self.model
        N = m.n_modes
        Om = float(Omega)
        s0 = m.initial_state() if state0 is None else np.asarray(state0, dtype=float)
        if s0.shape != (2 * N + 1,):
            raise ValueError(f"state0 must have shape ({2 * N + 1},), got {s0.shape}")
        eta = s0[:N].copy()
        etad = s0[N:2 * N].copy()
        F = Om**2 * m.base_amplitude_m
        k, c = m.k_nd, m.c_nd
        mpF = mode_table(c, k)
        aF, bF = particular(c, k, m.participation, F, Om)
        GF = m.participation * F
        mpC = mode_table(m.cC, m.nu2) if m.nu2.size else np.zeros((0, 6))
        aC, bC = particular(m.cC, m.nu2, m.GC, F, Om)
        me = m.m_eff
        SaL, SbL = m.stop_forcing(aC, bC, F, Om)
        SaS = float(m.pS @ aC)
        SbS = float(m.pS @ bC)
        par, tU, tR = pack(m.stops())
        r = m.stop_rows
        samples = np.zeros((n_record * samples_per_period, 2))
        imp_t = np.zeros(self.impact_buffer)
        imp_v = np.zeros(self.impact_buffer)
        imp_k = np.zeros(self.impact_buffer, np.int64)
        n_stop = np.zeros(par.shape[0], np.int64)
        modamp = np.zeros(N)
        msamp = np.zeros((samples.shape[0] if self.record_modal_states else 0, 2 * N))
        pmin = np.zeros(n_record)
        chat_t = np.zeros(self.impact_buffer)
        n_per = n_transient + n_record
        h_cap = TWO_PI / np.sqrt(k[0]) / self.steps_per_fundamental
        max_steps, budget = call_budget(self.max_steps_per_period, n_per, self.max_steps_per_call)
        out = beam_kernel(Om, mpF, aF, bF, m.contact_row, m.sensor_row, c, k, GF,
                          par, tU, tR, r["normals"], me,
                          mpC, aC, bC, r["eC"], m.Psi, r["eta_c"], r["pL"], r["rL"], SaL, SbL, r["cL"],
                          m.pS, SaS, SbS, r["cS"],
                          eta, etad, 1 if s0[2 * N] > 0.5 else (-1 if s0[2 * N] < -0.5 and par.shape[0] > 1 else 0),
                          int(n_transient), int(n_record), self.transient_samples,
                          int(samples_per_period), float(h_cap),
                          self.max_impacts_per_period * n_per, max_steps,
                          self.chatter_tol, samples, imp_t, imp_v, imp_k, n_stop, modamp, msamp, pmin,
                          chat_t)
        status, n_imp, smin, smax, n_chat, stuck_time, stuck_end, n_tot, gmax, n_steps = out
        incomplete = (status == ST_FAILED and budget and n_steps > max_steps
                      and n_tot <= self.max_impacts_per_period * n_per)
        L = m.length_m
        if stuck_time > 0.0 or stuck_end:
            gmax = max(gmax, 0.0)  # on the stop U = Delta_C exactly
        samples /= L
        kk = min(n_imp, self.impact_buffer)
        T = TWO_PI / Om
        message = ""
        if incomplete:
            message = f"more than max_steps_per_call = {self.max_steps_per_call} steps in {n_per} period(s)"
        elif status == ST_FAILED:
            message = (f"gave up after {n_tot} impacts / {n_steps} steps in {n_per} periods "
                       f"(non-accumulating chatter or step collapse)")
        elif status == ST_CHATTER:
            message = f"{n_chat} chatter sequence(s) ending in sticking; stuck {stuck_time:.4g} of the window"
        elif status == ST_STICKING:
            message = f"stuck on the stop {stuck_time:.4g} of {n_record * T:.4g} time units"
        iv = imp_v[:kk] / L
        two = par.shape[0] > 1
        iv_up = iv[imp_k[:kk] == 0] if two else iv
        traj = Trajectory(
            Omega=Om, samples=samples, samples_per_period=samples_per_period,
            impact_times=imp_t[:kk].copy(), impact_velocities=iv,
            contacts=newton_contact_rows(m, iv, imp_k[:kk] if two else None),
            impact_stops=imp_k[:kk].copy() if two else None, n_impacts_lower=int(n_stop[1]) if two else 0,
            n_impacts=int(n_imp), q_min=float(smin / L), q_max=float(smax / L),
            period_min=pmin / L, chatter_times=chat_t[:min(n_chat, self.impact_buffer)].copy(),
            status=STATUS_NAMES[status], message=message,
            final_state=np.concatenate([eta, etad, [float(stuck_end)]]),
            extra={"mode_amplitudes": modamp,
                   "mode_contact_amplitudes": np.abs(m.contact_row) * modamp / L,
                   "stuck_fraction": float(stuck_time / (n_record * T)) if n_record else 0.0,
                   "contact_gap_max": float(gmax / L),
                   "impact_velocity_m_s": float(np.mean(iv_up) * L * m.omega_ref) if iv_up.size else np.nan,
                   "steps_per_period": float(n_steps / max(n_per, 1))}, incomplete=bool(incomplete))
        if self.record_modal_states:
            traj.extra["modal_states"] = msamp
        return traj


class BeamODESolver:
    """Method ``direct`` for the beam: the same modal system integrated with
    :func:`scipy.integrate.solve_ivp` (reference solver).

    Free flight: a terminal event at the contact (``U = Delta_C`` upward) and the same
    impact law (:func:`apply_impact` / ``restitution_impulse``).  Sticking: the
    constrained system in the coordinates ``zeta`` (``eta = eta_c + Psi zeta``) is
    integrated too, with a terminal event on the contact force ``lambda`` turning
    positive.  An impact with ``U- < chatter_velocity`` times the first impact speed into
    a pressing contact acceleration is treated as the end of a chatter (plastic
    projection, then sticking): a crude chatter model, fine for a reference of
    impacting/sticking orbits, not for resolving chatter.

    The state is scaled by ``1 / (L sqrt(m_eff))`` so that it is of the order of ``U / L``.
    ``q_min/q_max`` use the sensor-velocity zero crossings (events) and the samples.
    Steps are capped at ``T / 16`` so that sign changes of the event functions are not
    stepped over (solve_ivp only checks signs at step ends: detection is not guaranteed).
    """

    name = "direct"
    time_domain = True
    chunk_periods = 200   # a restart of solve_ivp changes the result at the level of rtol

    def __init__(self, model: BeamImpactModel, solver: str = "DOP853", rtol: float = 1e-9,
                 atol: float = 1e-12, max_impacts_per_period: int = 200,
                 chatter_velocity: float = 1e-6, max_step: float | None = None):
        self.model = model
        self.max_step = max_step
        self.solver = solver
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.chatter_velocity = float(chatter_velocity)

    def settings(self) -> dict:
        return dict(solver=self.solver, rtol=self.rtol, atol=self.atol, n_modes=self.model.n_modes,
                    chatter_velocity=self.chatter_velocity)

    def point(self, Omega, state0, n_transient, n_record, samples_per_period=64) -> Trajectory:
        from scipy.integrate import solve_ivp

        m = self.model
        N = m.n_modes
        Om = float(Omega)
        L = m.length_m
        sc = L * math.sqrt(m.m_eff)
        s0 = m.initial_state() if state0 is None else np.asarray(state0, dtype=float)
        y = s0[:2 * N] / sc
        stuck = bool(s0[2 * N] > 0.5)
        k, c = m.k_nd, m.c_nd
        F = Om**2 * m.base_amplitude_m
        GF = m.participation * F / sc
        w, sv = m.contact_row, m.sensor_row
        w2 = float(w @ w)
        me = m.m_eff
        Psi = m.Psi
        Nc = Psi.shape[1]
        cC, nu2, GC = m.cC, m.nu2, m.GC * F / sc
        T = TWO_PI / Om
        # each stop (vibeam.models.contact): normal n = s w, offset, its law, and the data of the
        # beam held on it (constrained offset eta_c, load of the constrained modes, contact force)
        stops = m.stops()
        two = len(stops) > 1
        r = m.stop_rows
        sides = []
        for j, st in enumerate(stops):
            n = r["normals"][j]
            etac = r["eta_c"][j] / sc
            sides.append(dict(n=n, D=st.relation.offset / sc, law=st.law, etac=etac,
                              gconst=-(Psi.T @ (k * etac)), pL=r["pL"][j], rL=r["rL"][j],
                              lam_sin=-me * float(n @ m.participation) * F / sc,
                              lam_const=me * float(n @ (k * etac))))
        side = 0 if s0[2 * N] > -0.5 or not two else 1
        stuck = stuck or (two and s0[2 * N] < -0.5)

        def rhs(t, z):
            return np.concatenate([z[N:], GF * math.sin(Om * t) - c * z[N:] - k * z[:N]])

        def rhs_c(t, z):
            if Nc == 0:
                return np.zeros(2)
            return np.concatenate([z[Nc:], GC * math.sin(Om * t) - cC * z[Nc:] - nu2 * z[:Nc]
                                   + sides[side]["gconst"]])

        def lam(t, z):  # contact force / m_eff-scaled units; the beam is held while <= 0
            d = sides[side]
            if Nc == 0:
                return d["lam_const"] + d["lam_sin"] * math.sin(Om * t)
            return (d["lam_const"] + d["lam_sin"] * math.sin(Om * t) + d["pL"] @ z[:Nc] + d["rL"] @ z[Nc:])
        lam.terminal = True
        lam.direction = 1.0

        DC = sides[0]["D"]

        def ev_contact(t, z):
            return w @ z[:N] - DC
        ev_contact.terminal = True
        ev_contact.direction = 1.0
        events_free = [ev_contact]

        if two:
            nl, Dlow = sides[1]["n"], sides[1]["D"]

            def ev_lower(t, z):
                return nl @ z[:N] - Dlow
            ev_lower.terminal = True
            ev_lower.direction = 1.0

        def ev_sens(t, z):
            return sv @ z[N:]
        events_free.append(ev_sens)
        if two:
            events_free.append(ev_lower)

        def ev_sens_c(t, z):
            return sv @ (Psi @ z[Nc:2 * Nc]) if Nc else 1.0

        def acc_U(t, z, j=0):
            return float(sides[j]["n"] @ (GF * math.sin(Om * t) - c * z[N:] - k * z[:N]))

        def full(zc):  # constrained -> full state, columns
            etac = sides[side]["etac"]
            if Nc == 0:
                return np.concatenate([np.repeat(etac[:, None], zc.shape[1], 1), np.zeros((N, zc.shape[1]))])
            return np.concatenate([etac[:, None] + Psi @ zc[:Nc], Psi @ zc[Nc:2 * Nc]])

        def stick(y, j=0):
            n, D = sides[j]["n"], sides[j]["D"]
            y = y.copy()
            y[:N] -= n * (n @ y[:N] - D) / w2
            y[N:] -= n * (n @ y[N:]) / w2
            return y

        t = 0.0
        t_end = (n_transient + n_record) * T
        t_rec = n_transient * T
        ts = t_rec + np.arange(n_record * samples_per_period) * (T / samples_per_period)
        samples = np.zeros((ts.size, 2))
        filled = np.zeros(ts.size, bool)
        ext = [np.inf, -np.inf]
        ev_min = []   # (t, q) of sensor extremes located by events in the record
        imp_t, imp_v, imp_k, imp_e = [], [], [], []
        n_imp = 0
        n_chat = 0
        stuck_time = 0.0
        max_imp = self.max_impacts_per_period * (n_transient + n_record)
        vscale = None
        modamp = np.zeros(N)
        if not stuck:
            for j, d in enumerate(sides):   # at rest on a stop: held if the contact force presses
                n, D = d["n"], d["D"]
                if n @ y[:N] - D >= -1e-13 * (abs(D) + np.abs(n) @ np.abs(y[:N])) and n @ y[N:] <= 0:
                    y = stick(y, j)
                    stuck = True
                    side = j
                    break
        guard = 0
        while t < t_end:
            guard += 1
            if guard > 10 * max_imp + 100:
                return self._failed(Om, s0, n_record, samples_per_period, "no progress")
            if stuck:
                etac = sides[side]["etac"]
                zc = np.concatenate([Psi.T @ (y[:N] - etac), Psi.T @ y[N:]]) if Nc else np.zeros(2)
                l0 = lam(t, zc)
                eps_t = 1e-9 * T
                if l0 > 0 or (l0 == 0 and lam(t + eps_t, zc) > 0):
                    stuck = False
                    continue
                sol = solve_ivp(rhs_c, (t, t_end), zc, method=self.solver, rtol=self.rtol,
                                atol=self.atol, events=[lam, ev_sens_c], dense_output=True,
                                max_step=min(T / 16, self.max_step or np.inf))
                if sol.status < 0:
                    return self._failed(Om, s0, n_record, samples_per_period, sol.message)
                t1 = sol.t[-1]
                Zf = lambda tt: full(np.atleast_2d(sol.sol(tt).T).T)
                if t1 > t_rec:
                    stuck_time += t1 - max(t, t_rec)
                y = Zf(np.array([t1]))[:, 0]
                released = sol.status == 1 and sol.t_events[0].size > 0
                ev_ext = sol.t_events[1]
            else:
                sol = solve_ivp(rhs, (t, t_end), y, method=self.solver, rtol=self.rtol, atol=self.atol,
                                events=events_free, dense_output=True,
                                max_step=min(T / 16, self.max_step or np.inf))
                if sol.status < 0:
                    return self._failed(Om, s0, n_record, samples_per_period, sol.message)
                t1 = sol.t[-1]
                Zf = sol.sol
                y = sol.y[:, -1].copy()
                released = False
                ev_ext = sol.t_events[1]
            sel = (ts >= t - 1e-12 * T) & (ts <= t1) & ~filled
            if np.any(sel):
                Z = Zf(ts[sel])
                samples[sel, 0] = sv @ Z[:N] * sc / L
                samples[sel, 1] = sv @ Z[N:] * sc / L
                filled[sel] = True
                modamp = np.maximum(modamp, np.max(np.abs(Z[:N]), axis=1) * sc)
            for te in ev_ext:
                if te >= t_rec:
                    qv = float(sv @ Zf(np.array([te]))[:N, 0]) * sc / L
                    ev_min.append((te, qv))
                    ext[0] = min(ext[0], qv)
                    ext[1] = max(ext[1], qv)
            t = t1
            if stuck:
                if released:
                    stuck = False
                continue
            hit = -1
            if sol.status == 1 and sol.t_events[0].size:
                hit = 0
            elif two and sol.status == 1 and sol.t_events[2].size:
                hit = 1
            if hit >= 0:
                n = sides[hit]["n"]
                Um = float(n @ y[N:])
                if vscale is None:
                    vscale = max(abs(Um), 1e-300)
                n_imp += 1
                if n_imp > max_imp:
                    return self._failed(Om, s0, n_record, samples_per_period, "too many impacts")
                rec = t >= t_rec
                if rec:
                    imp_t.append(t - t_rec)
                    imp_v.append(max(Um, 0.0) * sc / L)
                    imp_k.append(hit)
                    # energy lost: the jump of the modal kinetic energy |eta'|^2 / 2 over the impact
                    # (state scaled by 1 / (L sqrt(m_eff)): already per m_eff L^2)
                    ke0 = 0.5 * float(y[N:] @ y[N:])
                    qv = float(sv @ y[:N]) * sc / L
                    if hit == 0:
                        ext[1] = max(ext[1], qv)
                    else:
                        ext[0] = min(ext[0], qv)
                if Um <= self.chatter_velocity * vscale:
                    y = stick(y, hit)
                    if rec:
                        imp_e.append(ke0 - 0.5 * float(y[N:] @ y[N:]))
                    if acc_U(t, y, hit) > 0:
                        stuck = True
                        side = hit
                        n_chat += t >= t_rec
                    continue
                ydot = y[N:].copy()
                law = sides[hit]["law"]
                Up = newton_restitution(Um, law.coefficient(Um * sc))
                apply_impulse(ydot, n, Um, Up, me)
                y[N:] = ydot
                if rec:
                    imp_e.append(ke0 - 0.5 * float(ydot @ ydot))
                if law.R == 0.0 and acc_U(t, y, hit) > 0:   # plastic impact into a pressing contact
                    y = stick(y, hit)
                    stuck = True
                    side = hit
        q = samples[:, 0]
        pmin = q.reshape(n_record, samples_per_period).min(axis=1) if q.size else np.zeros(n_record)
        for te, qv in (ev_min if n_record else []):
            kp = min(max(int((te - t_rec) // T), 0), n_record - 1)
            pmin[kp] = min(pmin[kp], qv)
        status = "chatter" if n_chat else ("sticking" if stuck_time > 0 else "ok")
        return Trajectory(
            Omega=Om, samples=samples, samples_per_period=samples_per_period,
            impact_times=np.array(imp_t), impact_velocities=np.array(imp_v), n_impacts=len(imp_t),
            contacts=np.column_stack([np.zeros(len(imp_e)), np.full(len(imp_e), np.nan), np.zeros(len(imp_e)),
                                      np.array(imp_e, float), np.array(imp_v, float)]).reshape(-1, 5),
            impact_stops=np.array(imp_k, np.int64) if two else None,
            n_impacts_lower=int(np.sum(np.array(imp_k) == 1)) if two else 0,
            q_min=float(min(ext[0], q.min())) if q.size else float(ext[0]),
            q_max=float(max(ext[1], q.max())) if q.size else float(ext[1]), period_min=pmin,
            status=status, message="" if status == "ok" else f"stuck {stuck_time:.4g} of the window",
            final_state=np.concatenate([y * sc, [(1.0 if side == 0 else -1.0) if stuck else 0.0]]),
            extra={"mode_amplitudes": modamp,
                   "stuck_fraction": float(stuck_time / (n_record * T)) if n_record else 0.0})

    def _failed(self, Om, s0, n_record, spp, msg):
        return Trajectory(Omega=Om, samples=np.full((n_record * spp, 2), np.nan), samples_per_period=spp,
                          impact_times=np.zeros(0), impact_velocities=np.zeros(0), n_impacts=0,
                          q_min=np.nan, q_max=np.nan, status="failed", message=msg,
                          final_state=np.asarray(s0, float).copy(),
                          extra={"mode_amplitudes": np.full(self.model.n_modes, np.nan),
                                 "stuck_fraction": np.nan})
