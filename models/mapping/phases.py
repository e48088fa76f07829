"""The two linear phases of the one-mode system and their certified step (paper Eq. 28).

Between contacts the oscillator flies freely, ``q'' + 2 beta q' + q = F sin(Omega t)``; pressed by
a Kelvin-Voigt stop ``(k_c, c_c)`` at ``u = d`` it moves, in the stop's normal coordinate ``u = s
q`` (``s = +1`` upper, ``-1`` lower; forcing ``s F``), as ``u'' + (2 beta + c_c) u' + (1 + k_c) u =
s F sin(Omega t) + k_c d``.  Both are one damped oscillator about an equilibrium ``q_e`` plus a
harmonic part, the form of the event integrator's *signals* (:mod:`vibeam.models.core.signals`):
every event of a step is found by the certified :func:`~vibeam.models.core.signals.scan` (no
crossing stepped over, grazing included) and every extreme by
:func:`~vibeam.models.core.signals.extremes`.

:func:`phase_step` takes one step of a phase:

* ``CONTACT`` (one stop, normal coordinate): up to the exit, the force ``k_c delta + c_c delta'``
  (``delta = u - d``) back down through zero; the contact's record ``[peak force, largest
  penetration, work on the stop]`` (work by 8-point Gauss-Legendre) updated on the way;
* ``FREE`` (physical coordinate, any number of stops, rows ``[s, d, r0, r1, roff]``): up to the
  first *arrival*, a gap ``delta_k = s_k q - d_k`` up through zero; or, for a stop the body is
  still inside of after a compliant exit (``inside[k]``), the force's sign function ``r0 delta +
  r1 delta' + roff`` up through zero (contact again before leaving the stop: ``EV_RECONTACT``) or
  ``delta_k`` back down through zero (``EV_GAPDOWN``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..core.contact_phase import GL_W, GL_X
from ..core.signals import bounds, extremes, homogeneous_bounds, scan, signal
from ..system import mode_table, particular, transition_entries

TWO_PI = 2.0 * math.pi
#: the one mode, typed int64 (a literal 1 would compile the signal kernels a second time)
_ONE = np.int64(1)
#: the phases of :func:`phase_step`
FREE, CONTACT = 0, 1
#: how a step ended: the whole step, an arrival at a stop, a contact exit, the gap of a stop the
#: body was inside of back down through zero, contact again inside a stop, no step certified
EV_NONE, EV_ARRIVAL, EV_EXIT, EV_GAPDOWN, EV_RECONTACT, EV_FAIL = 0, 1, 2, 3, 4, -1


class Phase:
    """One linear phase of the one-mode system: ``u'' + c u' + k (u - q_e) = F sin(Omega t)``.

    Free: ``Phase(beta, F, Omega)``, ``c = 2 beta``, ``k = 1``, ``q_e = 0``.  Pressed by a
    Kelvin-Voigt stop at ``u = d`` (normal coordinate, forcing ``s F``): ``Phase(beta, s F, Omega,
    d, k_c, c_c)``, ``c = 2 beta + c_c``, ``k = 1 + k_c``, ``q_e = k_c d / (1 + k_c)``.

    Parameters
    ----------
    beta, F, Omega : float
        Damping ratio, forcing amplitude (``Omega^2 B``, signed in a normal coordinate) and
        frequency (nondimensional).
    d, kc, cc : float, optional
        The stop's position, stiffness and dashpot (per unit mass) of a contact phase.
    """

    def __init__(self, beta, F, Omega, d=0.0, kc=0.0, cc=0.0):
        self.F, self.Omega, self.d, self.kc, self.cc = float(F), float(Omega), float(d), float(kc), float(cc)
        self.c, self.k = 2.0 * beta + cc, 1.0 + kc
        self.qe = kc * d / self.k
        self.mp = mode_table([self.c], [self.k])
        a, b = particular(np.array([self.c]), np.array([self.k]), np.array([1.0]), self.F, self.Omega)
        self.a, self.b = float(a[0]), float(b[0])

    def field(self, t, u, w):
        """The field ``(u', u'')`` at time ``t`` and state ``(u, u')``, ndarray of shape (2,)."""
        return np.array([w, self.F * math.sin(self.Omega * t) - self.c * w - self.k * (u - self.qe)])

    def transition(self, s):
        """State-transition matrix of ``(u, u')`` over a time ``s`` (closed form), shape (2, 2)."""
        p11, p12, p21, p22 = transition_entries(float(s), *self.mp[0])
        return np.array([[p11, p12], [p21, p22]])

    def step(self, kind, h, t, u, w, rows, inside, ext, cs):
        """One :func:`phase_step` of at most ``h`` from ``(t, u, u')``.

        Parameters
        ----------
        kind : int
            :data:`FREE` or :data:`CONTACT`.
        rows : ndarray, shape (n_stops, 5)
            ``[s, d, r0, r1, roff]`` per stop (free phase; a contact phase reads row 0's ``d``).
        inside : ndarray of int64, shape (n_stops,)
            1 for a stop the body is inside of without contact (free phase).
        ext : ndarray, shape (4,)
            ``[min, max]`` of ``u`` over the steps and ``[min, max]`` of its interior extrema,
            updated.
        cs : ndarray, shape (3,)
            The contact's record (contact phase), updated.

        Returns
        -------
        s, event, stop, u, w : float, int, int, float, float
            The step taken, how it ended (``EV_*``), the stop of the event and the state at
            the step's end.
        """
        out = np.empty(2)
        s, ev, k = phase_step(kind, float(h), 1e-13 * TWO_PI / self.Omega, float(t), float(u), float(w), self.mp,
                              self.qe, self.a, self.b, self.F, self.Omega, self.kc, self.cc, rows, inside, ext,
                              cs, out)
        return s, ev, k, out[0], out[1]


@njit(cache=True, error_model="numpy")
def _weights(c0, c1, a, b, Om, p, r):
    """Weights and harmonic part ``(Sa, Sb)`` of the signal ``c0 u + c1 u'`` of a phase."""
    p[0] = c0
    r[0] = c1
    return c0 * a - c1 * Om * b, c0 * b + c1 * Om * a


@njit(cache=True, error_model="numpy")
def _watch(c0, c1, f0, fp0, hh, s_ev, h_min, phi, Om, x0, y0, mp, a, b, hb, p, r):
    """Scan the signal ``c0 u + c1 u' + const`` (value ``f0``, slope ``fp0`` now) up through zero on
    ``[0, s_ev]`` (``[0, hh]`` while no event is found): ``(s_event, hh, found)``, the earliest
    event so far (-1: none; also when the scan had to shorten the horizon below it), the certified
    horizon, and whether this signal's crossing is that event."""
    Sa, Sb = _weights(c0, c1, a, b, Om, p, r)
    M2, M3, M4 = bounds(hb, p, r, math.sqrt(Sa * Sa + Sb * Sb), Om, _ONE)
    hk = hh if s_ev < 0.0 else s_ev
    sk, hk2 = scan(hk, h_min, phi, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, M2, M3, M4, _ONE)
    if sk >= 0.0:
        return sk, hh, True
    if hk2 < hk:
        return -1.0, hk2, False
    return s_ev, hh, False


@njit(cache=True, error_model="numpy")
def _maximum(c0, c1, f0, fp0, s, phi, Om, x0, y0, mp, a, b, p, r, e2):
    """Largest value on ``[0, s]`` of the signal ``c0 u + c1 u' + const`` (value ``f0``, slope ``fp0``
    at 0): its ends and an interior maximum."""
    Sa, Sb = _weights(c0, c1, a, b, Om, p, r)
    f1, fp1, _f2, _f3, _f4 = signal(s, phi, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, _ONE)
    e2[0] = np.inf
    e2[1] = max(f0, f1)
    extremes(s, phi, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, fp0, fp1, e2, _ONE)
    return e2[1]


@njit(cache=True, error_model="numpy")
def phase_step(kind, h, h_min, t, u, w, mp, qe, a, b, F, Om, kc, cc, rows, inside, ext, cs, out):
    """One step of at most ``h`` of a phase (:class:`Phase`) from ``(t, u, u')`` (module docstring).

    Parameters
    ----------
    kind : int
        :data:`CONTACT` (stop ``kc``, ``cc`` at ``rows[0, 1]``, normal coordinate) or :data:`FREE`.
    h, h_min : float
        Largest step; smallest step of a certified scan.
    mp : ndarray, shape (1, 6)
        The phase's mode table; ``qe``, ``a``, ``b`` its equilibrium and particular coefficients.
    rows : ndarray, shape (n_stops, 5)
        ``[s, d, r0, r1, roff]`` of each stop.
    inside : ndarray of int64, shape (n_stops,)
        Free phase: 1 for a stop the body is inside of without contact.
    ext : ndarray, shape (4,)
        ``[min u, max u]`` over the step and ``[min, max]`` of its interior extrema, updated.
    cs : ndarray, shape (3,)
        Contact phase: ``[peak force, largest penetration, work on the stop]``, updated.
    out : ndarray, shape (2,)
        Receives ``(u, u')`` at the step's end.

    Returns
    -------
    s, event, stop : float, int, int
        The step taken (-1 with :data:`EV_FAIL` when none could be certified), how it ended and
        the stop of its event (-1: none).
    """
    phi = (Om * t) % TWO_PI
    sp = math.sin(phi)
    cp = math.cos(phi)
    x0 = np.empty(1)
    y0 = np.empty(1)
    p = np.empty(1)
    r = np.empty(1)
    hb = np.empty((1, 6))
    e2 = np.empty(2)
    x0[0] = u - qe - (a * sp + b * cp)
    y0[0] = w - Om * (a * cp - b * sp)
    homogeneous_bounds(x0[0], y0[0], mp[0, 0], mp[0, 1], int(mp[0, 2]), mp[0, 3], mp[0, 4], mp[0, 5], hb[0])
    acc0 = F * sp - 2.0 * mp[0, 0] * w - mp[0, 1] * (u - qe)
    s_ev = -1.0
    ev = EV_NONE
    kk = -1
    hh = h
    if kind == CONTACT:
        g0 = u - rows[0, 1]
        s_ev, hh, found = _watch(-kc, -cc, -(kc * g0 + cc * w), -(kc * w + cc * acc0), hh, s_ev, h_min, phi, Om,
                                 x0, y0, mp, a, b, hb, p, r)
        if found:
            ev = EV_EXIT
            kk = 0
    else:
        for k in range(rows.shape[0]):
            sg, d = rows[k, 0], rows[k, 1]
            g0 = sg * u - d
            if inside[k]:
                r0, r1, roff = rows[k, 2], rows[k, 3], rows[k, 4]
                f0 = r0 * g0 + r1 * sg * w + roff
                fp0 = sg * (r0 * w + r1 * acc0)
                tol0 = 1e-13 * (abs(r0) * (abs(u) + abs(d)) + abs(r1 * w) + abs(roff))
                tol1 = 1e-13 * (abs(r0 * w) + abs(r1) * (abs(F) + abs(mp[0, 0] * w) + abs(mp[0, 1] * u)))
                if f0 > tol0 or (f0 >= -tol0 and fp0 > tol1):
                    out[0] = u
                    out[1] = w
                    return 0.0, EV_RECONTACT, k
                s_ev, hh, found = _watch(sg * r0, sg * r1, f0, fp0, hh, s_ev, h_min, phi, Om, x0, y0, mp, a, b, hb,
                                         p, r)
                if found:
                    ev, kk = EV_RECONTACT, k
                elif s_ev < 0.0:
                    ev, kk = EV_NONE, -1
                s_ev, hh, found = _watch(-sg, 0.0, -g0, -sg * w, hh, s_ev, h_min, phi, Om, x0, y0, mp, a, b, hb, p,
                                         r)
                if found:
                    ev, kk = EV_GAPDOWN, k
                elif s_ev < 0.0:
                    ev, kk = EV_NONE, -1
            else:
                if g0 >= -1e-13 * (abs(u) + abs(d)) and sg * w > 0.0:
                    out[0] = u
                    out[1] = w
                    return 0.0, EV_ARRIVAL, k
                s_ev, hh, found = _watch(sg, 0.0, g0, sg * w, hh, s_ev, h_min, phi, Om, x0, y0, mp, a, b, hb, p, r)
                if found:
                    ev, kk = EV_ARRIVAL, k
                elif s_ev < 0.0:
                    ev, kk = EV_NONE, -1
    s = s_ev if s_ev >= 0.0 else hh
    if not s >= 0.0:
        return -1.0, EV_FAIL, -1
    # the state at the step's end from its exact start values
    Sa, Sb = _weights(1.0, 0.0, a, b, Om, p, r)
    u1, w1, _f2, _f3, _f4 = signal(s, phi, Om, x0, y0, mp, p, r, Sa, Sb, u, w, _ONE)
    if kind == CONTACT:
        d = rows[0, 1]
        g0 = u - d
        cs[0] = max(cs[0], _maximum(kc, cc, kc * g0 + cc * w, kc * w + cc * acc0, s, phi, Om, x0, y0, mp, a, b, p, r,
                                    e2))
        cs[1] = max(cs[1], _maximum(1.0, 0.0, g0, w, s, phi, Om, x0, y0, mp, a, b, p, r, e2))
        Sa, Sb = _weights(1.0, 0.0, a, b, Om, p, r)
        work = 0.0
        for i in range(GL_X.shape[0]):
            g, gd, _f2, _f3, _f4 = signal(GL_X[i] * s, phi, Om, x0, y0, mp, p, r, Sa, Sb, u, w, _ONE)
            work += GL_W[i] * (kc * (g - d) + cc * gd) * gd
        cs[2] += work * s
    e2[0] = np.inf
    e2[1] = -np.inf
    extremes(s, phi, Om, x0, y0, mp, p, r, Sa, Sb, u, w, w, w1, e2, _ONE)
    ext[0] = min(ext[0], u, u1, e2[0])
    ext[1] = max(ext[1], u, u1, e2[1])
    ext[2] = min(ext[2], e2[0])
    ext[3] = max(ext[3], e2[1])
    out[0] = u1
    out[1] = w1
    return s, ev, kk
