"""The modal FE beam on a Kelvin-Voigt (piecewise-linear) stop: exact event-driven solver.

Model (kernel units of :mod:`vibeam.models.beam_dynamics`: time ``t = omega_ref t~``, modal
coordinates ``eta`` in sqrt(kg) m, ``U = w^T eta`` the contact displacement, m)::

    free     eta'' + C eta' + K eta = Gamma F sin(Omega t)                 (U < Delta_C)
    contact  eta'' + C eta' + K eta + w (k (U - Delta_C) + c U') = Gamma F sin(Omega t)

with ``k = k_c / omega_ref^2``, ``c = c_c / omega_ref`` (``k_c`` N/m, ``c_c`` N s/m): the stop
acts along the relation's normal ``w`` and couples the modes.  In state form ``z = (eta,
eta')``, ``z' = A_p z + b sin(Omega t) + b0_p`` per phase ``p``; each phase's ``2N x 2N``
matrix is diagonalised once per model (``A_p = V diag(lambda) V^-1``, numpy/LAPACK ``geev``
with balancing; the contact couples every mode so the phase has no modal closed form of its
own) and the flow is exact: ``z(s) = Re(V (a e^{lambda s})) + Im(Z e^{i phi(s)}) + z_e``,
``Z = (i Omega - A_p)^-1 b`` the forced response, ``z_e = -A_p^-1 b0_p``.  Every signal the
kernel needs -- the gap ``g = U - Delta_C``, the force ``k g + c g'``, the sensor velocity --
is a sum of exponentials ``Re sum_j alpha_j e^{lambda_j s} + Im(beta e^{i phi}) + gamma``
whose n-th derivative is bounded on a step by ``sum_j |alpha_j| |lambda_j|^n + |beta|
Omega^n`` (``Re lambda_j <= 0``).  With those bounds the certified scan of
:mod:`vibeam.models.sdof_compliant` locates contact entry (``g`` up through 0), exit (force
down through 0), the exact minima of the sensor displacement, the peak force and the largest
penetration; the work done on the stop is integrated by Gauss-Legendre on the exact flow.

A second (lower) stop at ``U = -Delta_l`` with its own Kelvin-Voigt law adds a third phase
(its contact matrix ``A - w w^T [k_l, c_l]``, load ``-w k_l Delta_l``), diagonalised like the
others (:func:`beam_compliant_kernel`).

Contact law and events are those of :mod:`vibeam.models.compliant` (force-zero separation;
a target R gives the dashpot ``c_c = 2 zeta_c sqrt(k_c m_eff)`` with ``zeta_c`` from the
isolated-impact relation and the relation's effective mass ``m_eff = 1 / |w|^2``).
Measured eigendecomposition accuracy on the rig mesh (46 modes): ``|A V - V Lambda| / |A|
<= 6e-16``, ``cond(V) ~ 3e2``, ``e^{A h}`` against ``scipy.linalg.expm`` to 6e-12.
"""
from __future__ import annotations

import copy
import math

import numpy as np
from numba import njit

from .beam_dynamics import BeamImpactModel
from .contact import EV_ENTRY, EV_EXIT, EV_GAPDOWN, EV_NONE, LAW_HYSTERETIC_HERTZ, NPAR, OFFSET, SIGN, \
    STIFFNESS, DAMPING, EXPONENT, LAW, Relation, Stop
from .contact import R as RCOL
from .hc_contact import contact_scales, hc_contact_step, hysteretic_hertz_force
from .sdof_compliant import HC_V_FLOOR
from .roots import rtsafe_update
from .core.signals import certify_curvature
from .trajectory import Trajectory, call_budget

TWO_PI = 2.0 * math.pi
FREE, CONTACT = 0, 1
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
GL_X = 0.5 * (_GL_X + 1.0)
GL_W = 0.5 * _GL_W


class CompliantBeamModel(BeamImpactModel):
    """A :class:`~vibeam.models.beam_dynamics.BeamImpactModel` whose stop is a Kelvin-Voigt law.

    Attributes (beyond the base model's)
    ------------------------------------
    contact : vibeam.models.compliant.LinearContact
        ``stiffness`` in N/m, ``damping_ratio`` of the isolated contact (of mass ``m_eff``).
    """

    @classmethod
    def from_model(cls, base: BeamImpactModel, law, law_lower=None) -> "CompliantBeamModel":
        """The compliant model of ``base`` with the stop's law ``law``; a two-sided ``base``
        (``gap_contact_lower_m``) gets ``law_lower`` at its lower stop (None: ``law``)."""
        m = cls.__new__(cls)
        m.__dict__.update(copy.copy(base.__dict__))
        m.contact = law
        m.contact_lower = law_lower
        return m

    @property
    def contact_law(self) -> str:
        return self.contact.name

    @property
    def lower_law(self):
        """The law of the lower stop of a two-sided scene (``contact_lower`` or ``contact``),
        None with one stop."""
        if not self.two_sided:
            return None
        lo = getattr(self, "contact_lower", None)
        return self.contact if lo is None else lo

    def stops(self) -> tuple:
        """The contact relations and (compliant) laws: the stop at ``w^T eta = Delta_C`` and,
        for a two-sided scene, the one at ``w^T eta = -Delta_C,lower``."""
        out = (Stop(Relation(1.0, self.gap_contact_m), self.contact),)
        if self.two_sided:
            out += (Stop(Relation(-1.0, self.gap_contact_lower_m), self.lower_law),)
        return out

    def _damping(self, law) -> float:
        return 2.0 * law.damping_ratio * math.sqrt(law.stiffness * self.m_eff)

    @property
    def contact_damping_n_s_m(self) -> float:
        """``c_c = 2 zeta_c sqrt(k_c m_eff)`` (N s/m)."""
        return self._damping(self.contact)

    @property
    def force_scale_n(self) -> float:
        """Newtons per unit of the nondimensional contact force ``F / (m_eff omega_ref^2 L)``."""
        return self.m_eff * self.omega_ref ** 2 * self.length_m

    def linear_phase(self, law):
        """``(k, c)`` of a stop's linear (Kelvin-Voigt) contact phase in kernel units
        (``k_c / omega_ref^2``, ``c_c / omega_ref``); ``(0, 0)`` for a law whose contact phase has
        no closed form (its phase matrices are then the free ones, unused by the kernel)."""
        if not getattr(law, "linear_phase", False):
            return 0.0, 0.0
        return law.stiffness / self.omega_ref ** 2, self._damping(law) / self.omega_ref

    def lower_stop_params(self):
        """``(k, c, Delta_l)`` of the lower stop in kernel units (``k_l / omega_ref^2``,
        ``c_l / omega_ref``, gap at the contact point, m); zeros with one stop."""
        lo = self.lower_law
        if lo is None:
            return 0.0, 0.0, 0.0
        kl, cl = self.linear_phase(lo)
        return kl, cl, self.gap_contact_lower_m

    def kernel_stops(self) -> np.ndarray:
        """The stops as kernel rows (n_stops, :data:`vibeam.models.contact.NPAR`) of
        :func:`beam_compliant_kernel`: relation (sign, gap at the contact point in m) and law
        (code, R, stiffness ``k_c / omega_ref^2``, damping: the dashpot ``c_c / omega_ref`` of a
        Kelvin-Voigt law or the ``chi`` of a Hunt-Crossley one, exponent)."""
        stops = self.stops()
        rows = np.zeros((len(stops), NPAR))
        for k, st in enumerate(stops):
            code, R, _, _, expo = st.law.row()
            rows[k, SIGN] = st.relation.sign
            rows[k, OFFSET] = st.relation.offset
            rows[k, LAW] = code
            rows[k, RCOL] = R
            rows[k, STIFFNESS] = st.law.stiffness / self.omega_ref ** 2
            rows[k, DAMPING] = (self._damping(st.law) / self.omega_ref if getattr(st.law, "linear_phase", False)
                                else float(st.law.damping))
            rows[k, EXPONENT] = expo
        return rows

    def phase_matrices(self):
        """``A`` (P, 2N, 2N) of the free and contact phases (P = 2; 3 with a lower stop: its
        contact phase last), ``b`` (2N,) per unit forcing ``F``, ``b0`` (P, 2N) constant loads,
        and the upper stop's ``kc``, ``cc`` (kernel units)."""
        N = self.n_modes
        k, c, w = self.k_nd, self.c_nd, self.contact_row
        kc, cc = self.linear_phase(self.contact)
        kl, cl, Dl = self.lower_stop_params()
        P = 3 if self.two_sided else 2
        A = np.zeros((P, 2 * N, 2 * N))
        ww = np.outer(w, w)
        for p in range(P):
            kp, cp = (0.0, kc, kl)[p], (0.0, cc, cl)[p]
            A[p, :N, N:] = np.eye(N)
            A[p, N:, :N] = -np.diag(k) - (kp * ww if p else 0.0)
            A[p, N:, N:] = -np.diag(c) - (cp * ww if p else 0.0)
        b = np.concatenate([np.zeros(N), self.participation])
        b0 = np.zeros((P, 2 * N))
        b0[1, N:] = w * kc * self.gap_contact_m
        if P == 3:
            # the lower stop's force k_l (-U - Delta_l) + c_l (-U') acts along its normal -w
            b0[2, N:] = -w * kl * Dl
        return A, b, b0, kc, cc


# ---------------------------------------------------------------- signals (sums of exponentials)
@njit(cache=True)
def signal_derivatives(s, al, lam, be, ga, phi0, Om, out):
    """Value and derivatives 1..3 at ``s`` of ``Re sum al_j e^{lam_j s} + Im(be e^{i phi}) + ga``."""
    r0 = r1 = r2 = r3 = 0.0
    for j in range(lam.shape[0]):
        if al[j] == 0.0:
            continue
        e = al[j] * np.exp(lam[j] * s)
        l = lam[j]
        r0 += e.real
        e = e * l
        r1 += e.real
        e = e * l
        r2 += e.real
        e = e * l
        r3 += e.real
    ph = phi0 + Om * s
    f = be * complex(math.cos(ph), math.sin(ph))
    iO = complex(0.0, Om)
    out[0] = r0 + f.imag + ga
    f = f * iO
    out[1] = r1 + f.imag
    f = f * iO
    out[2] = r2 + f.imag
    f = f * iO
    out[3] = r3 + f.imag


@njit(cache=True)
def _bound(al, lam, be, Om, n):
    b = abs(be) * Om ** n
    for j in range(lam.shape[0]):
        if al[j] != 0.0:
            b += abs(al[j]) * abs(lam[j]) ** n
    return b * (1.0 + 1e-9) + 1e-300


@njit(cache=True)
def signal_combo(c0, c1, c2, al, lam, be, ga, Om, al_out):
    """Coefficients of ``c0 f + c1 f' + c2 f''`` of a signal; returns ``(be, ga)``."""
    for j in range(lam.shape[0]):
        al_out[j] = al[j] * (c0 + c1 * lam[j] + c2 * lam[j] * lam[j])
    iO = complex(0.0, Om)
    return be * (c0 + c1 * iO + c2 * iO * iO), ga * c0


@njit(cache=True)
def _broot(al, lam, be, ga, phi0, Om, order, sgn, lo, hi, buf):
    """rtsafe on ``sgn f^(order)`` (order 0 or 1) over ``[lo, hi]``, ``F(lo) < 0 <= F(hi)``."""
    dxold = hi - lo
    dx = dxold
    s = 0.5 * (lo + hi)
    for _ in range(200):
        signal_derivatives(s, al, lam, be, ga, phi0, Om, buf)
        F = sgn * buf[order]
        dF = sgn * buf[order + 1]
        s, lo, hi, dx, dxold, done = rtsafe_update(F, dF, s, lo, hi, dx, dxold)
        if done:
            return s
    return hi


#: work budget of one kernel call of the compliant beam solvers, in steps x modes (their
#: ``max_steps_per_call`` is this over the modes, at least one period's guard)
MAX_STEP_MODES_PER_CALL = 4_000_000
#: :func:`bupcross` could not scan (non-finite bounds, or too many intervals): the step fails
STALL = -2.0
#: most intervals of one :func:`bupcross` scan (a usual scan takes a few; a scan whose bounds
#: certify nothing steps at ``h_min`` = 1e-13 T and would take ~1e12)
MAX_SCAN = 100_000


@njit(cache=True)
def bupcross(al, lam, be, ga, phi0, Om, lo, hi, h_min):
    """First upward zero crossing of a signal in ``(lo, hi]`` (-1 if none); the certified
    scan of :func:`vibeam.models.sdof_compliant.upcross` on a sum of exponentials.
    :data:`STALL` (-2) when the scan cannot be done in double precision: bounds that are not
    finite (a stop so stiff that ``|lambda|^4`` overflows), or more than :data:`MAX_SCAN`
    intervals (each then as short as ``h_min``); the caller fails the step."""
    M2 = _bound(al, lam, be, Om, 2)
    M3 = _bound(al, lam, be, Om, 3)
    M4 = _bound(al, lam, be, Om, 4)
    if not (M2 < np.inf and M3 < np.inf and M4 < np.inf):
        return STALL
    tol = 1e-13 * M2
    b0 = np.empty(4)
    b1 = np.empty(4)
    s = lo
    signal_derivatives(s, al, lam, be, ga, phi0, Om, b0)
    n_scan = 0
    while s < hi:
        n_scan += 1
        if n_scan > MAX_SCAN:
            return STALL
        h = hi - s
        cert = 0
        while True:
            signal_derivatives(s + h, al, lam, be, ga, phi0, Om, b1)
            e2 = 0.125 * M2 * h * h
            if min(b0[0], b1[0]) - e2 > 0.0 or max(b0[0], b1[0]) + e2 < 0.0:
                cert = 2
                break
            cert = certify_curvature(b0[2], b0[3], b1[2], b1[3], M3, M4, h, tol)
            if cert != 0 or h < h_min or not h > 0.0:
                break
            h *= 0.5
        e = s + h
        if not e > s:
            return STALL
        if b0[0] < 0.0 and b1[0] >= 0.0:
            return _broot(al, lam, be, ga, phi0, Om, 0, 1.0, s, e, b1)
        if cert == 1 or cert == 0:
            if b0[0] >= 0.0 and b1[0] >= 0.0 and b0[1] < 0.0 < b1[1]:
                sm = _broot(al, lam, be, ga, phi0, Om, 1, 1.0, s, e, b1)
                signal_derivatives(sm, al, lam, be, ga, phi0, Om, b1)
                if b1[0] < 0.0:
                    return _broot(al, lam, be, ga, phi0, Om, 0, 1.0, sm, e, b1)
        if cert == -1 or cert == 0:
            if b0[0] < 0.0 and b1[0] < 0.0 and b0[1] > 0.0 > b1[1]:
                sa = _broot(al, lam, be, ga, phi0, Om, 1, -1.0, s, e, b1)
                signal_derivatives(sa, al, lam, be, ga, phi0, Om, b1)
                if b1[0] >= 0.0:
                    return _broot(al, lam, be, ga, phi0, Om, 0, 1.0, s, sa, b1)
        s = e
        signal_derivatives(s, al, lam, be, ga, phi0, Om, b0)
    return -1.0


# ---------------------------------------------------------------- kernel
@njit(cache=True)
def modal_state(s, a, lam, V, Z, ze, phi0, Om, z):
    """``z(s) = Re(V (a e^{lam s})) + Im(Z e^{i phi}) + z_e``."""
    n = lam.shape[0]
    e = np.empty(n, np.complex128)
    for j in range(n):
        e[j] = a[j] * np.exp(lam[j] * s)
    ph = phi0 + Om * s
    ep = complex(math.cos(ph), math.sin(ph))
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += (V[i, j] * e[j]).real
        z[i] = acc + (Z[i] * ep).imag + ze[i]


@njit(cache=True)
def modal_coordinates(z, W, Z, ze, phi0, a):
    """``a = V^-1 (z - Im(Z e^{i phi0}) - z_e)``."""
    n = z.shape[0]
    ep = complex(math.cos(phi0), math.sin(phi0))
    x = np.empty(n)
    for i in range(n):
        x[i] = z[i] - (Z[i] * ep).imag - ze[i]
    for i in range(n):
        acc = 0j
        for j in range(n):
            acc += W[i, j] * x[j]
        a[i] = acc


@njit(cache=True)
def free_scan(al, lam, beU, gaU, phi, Om, kc, cc, h, h_min, buf, al2, foff=0.0):
    """Contact entry of one stop in a free step of at most ``h``: the signal ``(al, lam, beU,
    gaU)`` is the stop's gap ``g`` (< 0 free), ``kc g + cc g' + foff`` has the sign of its
    force inside the stop (Kelvin-Voigt: the force; Hunt-Crossley after an exit by its damping
    factor: ``g' + v_r / chi``, :mod:`vibeam.models.beam_hc`).  Returns ``(s, event)``:
    :data:`EV_ENTRY` (``s = 0`` when the body is on or inside the stop and the force is positive
    just after), :data:`EV_GAPDOWN` (inside it after an exit, ``g`` back to 0) or
    :data:`EV_NONE` (``s = h``)."""
    ev = EV_NONE
    s_adv = h
    signal_derivatives(0.0, al, lam, beU, gaU, phi, Om, buf)
    g0 = buf[0]
    # the gap from the modal reconstruction carries round-off (1e-13 of its
    # bound): within it the body is on the stop (g0 = 0)
    tolg = 1e-13 * _bound(al, lam, beU, Om, 0)
    on_stop = abs(g0) <= tolg
    entered = False
    if on_stop or g0 > 0.0:
        # at or inside the stop: contact now if the force is positive just after
        # (on it: the first non-zero of U', U'', U'''; inside: of the force k g + c g')
        for n in range(3):
            if on_stop:
                f = buf[n + 1]
                tol = 1e-13 * _bound(al, lam, beU, Om, n + 1)
            else:
                f = kc * buf[n] + cc * buf[n + 1]
                tol = 1e-13 * (kc * _bound(al, lam, beU, Om, n) + cc * _bound(al, lam, beU, Om, n + 1))
                if n == 0 and foff != 0.0:
                    f += foff
                    tol += 1e-13 * abs(foff)
            if f > tol:
                entered = True
                break
            if f < -tol:
                break
    if on_stop and not entered:
        g0 = -1.0   # on the stop and leaving it: free flight below it
    if entered:
        s_adv = 0.0
        ev = EV_ENTRY
    elif g0 >= 0.0:
        b2, g2 = signal_combo(-1.0, 0.0, 0.0, al, lam, beU, gaU, Om, al2)
        s_d = bupcross(al2, lam, b2, g2, phi, Om, 0.0, h, h_min)
        if s_d == STALL:
            return -1.0, EV_NONE
        lim = s_d if s_d >= 0.0 else h
        b2, g2 = signal_combo(kc, cc, 0.0, al, lam, beU, gaU, Om, al2)
        if foff != 0.0:
            g2 += foff
        s_e = bupcross(al2, lam, b2, g2, phi, Om, 0.0, lim, h_min)
        if s_e == STALL:
            return -1.0, EV_NONE
        if s_e >= 0.0:
            s_adv = s_e
            ev = EV_ENTRY
        elif s_d >= 0.0:
            s_adv = s_d
            ev = EV_GAPDOWN
    else:
        s_e = bupcross(al, lam, beU, gaU, phi, Om, 0.0, h, h_min)
        if s_e == STALL:
            return -1.0, EV_NONE
        if s_e >= 0.0:
            s_adv = s_e
            ev = EV_ENTRY
    return s_adv, ev


@njit(cache=True)
def beam_compliant_kernel(Om, lamA, VA, WA, ZA, zeA, PU, PS, wrow, srow, bU, bS, gU, gS, stops, knd, cnd, part, F,
                          v_floor, z0, phase0, n_transient, n_record, ns_transient, ns_record, hmax, max_contacts,
                          max_steps, samples, pmin, imp_t, imp_v, con, imp_k, msamp):
    """Simulate whole forcing periods of the modal beam on compliant stops (the one event kernel
    of :class:`CompliantBeamEventSolver` and of the compliant beam shooting problems).

    Stops: row k of ``stops`` (n_stops, :data:`vibeam.models.contact.NPAR`) is the relation
    (``SIGN`` s_k, ``OFFSET`` Delta_k in m: gap ``g_k = s_k w^T eta - Delta_k``) and the law
    (``LAW`` code; ``STIFFNESS`` k in kernel units, ``k_c / omega_ref^2``; ``DAMPING`` the
    Kelvin-Voigt dashpot ``c_c / omega_ref`` or the Hunt-Crossley ``chi``; ``EXPONENT`` p) of
    stop k; row 0 is the upper stop.  Phases: 0 free, ``1 + k`` in contact with stop k.  A free
    step ends at the earliest certified entry of any stop.  A Kelvin-Voigt contact phase is
    exact (its eigendecomposed ``2N x 2N`` flow), a Hunt-Crossley one is integrated
    (:func:`vibeam.models.hc_contact.hc_contact_step`, entry velocity floored at ``v_floor``).

    Per phase ``p``: ``lamA[p]`` (2N,) eigenvalues, ``VA[p]``/``WA[p]`` (2N, 2N) eigenvectors
    and inverse, ``ZA[p]`` (2N,) forced response (complex), ``zeA[p]`` (2N,) equilibrium;
    ``PU[p]``, ``PS[p]`` (2N,): rows ``w^T`` and ``s^T`` (on eta) times ``V``; ``bU[p]``,
    ``bS[p]`` their forced coefficients, ``gU[p]``, ``gS[p]`` their constants (a Hunt-Crossley
    stop's phase rows are unused: any finite arrays).  ``wrow``, ``srow`` (N,) the contact and
    sensor rows; ``knd``, ``cnd``, ``part`` (N,) modal stiffness, damping and participation and
    ``F = Omega^2 Y`` (used by Hunt-Crossley phases only).  ``samples`` (n_record * ns_record, 2)
    receives ``(s^T eta, s^T eta')``; ``con`` (cap, 5) per contact: duration, peak force, largest
    penetration (m), work on the stop (kernel units), entry velocity; ``imp_k`` (cap,) the stop
    of each recorded contact; ``msamp`` (m, 2N) the modal state at each sample when ``m > 0``.

    Returns ``(status, n_rec, smin, smax, phase_end, n_con, t_contact, n_steps, n_rec_lower)``
    (status 0 ok, 3 gave up); ``z0`` (2N,) is left at the end state.
    """
    n2 = z0.shape[0]
    N = n2 // 2
    nst = stops.shape[0]
    T = TWO_PI / Om
    z = z0.copy()
    a = np.empty(n2, np.complex128)
    al = np.empty(n2, np.complex128)
    al2 = np.empty(n2, np.complex128)
    alk = np.empty(n2, np.complex128)
    buf = np.empty(4)
    y0 = np.zeros(n2 + 1)
    y1 = np.zeros(n2 + 1)
    rk = np.zeros(4)
    # the sensor's extremes: [min, max, min of the current period]
    ext = np.empty(3)
    ext[0] = np.inf
    ext[1] = -np.inf
    ext[2] = np.inf
    phase = phase0
    cs = np.zeros(4)
    n_con = 0
    n_rec = 0
    n_rec_l = 0
    n_steps = 0
    t_con = 0.0
    in_rec = False
    k_sample = 0
    cap = con.shape[0]
    # each stop's normal row s_k w, and the law's state: a Hunt-Crossley contact's damping scale v_r
    # and, free inside a stop after an exit by the damping factor, the offset v_r / chi of the
    # force's sign g' + v_r / chi (0 otherwise)
    wst = np.empty((nst, N))
    hc = np.zeros(nst, np.bool_)
    foff = np.zeros(nst)
    for k in range(nst):
        hc[k] = int(stops[k, LAW]) == LAW_HYSTERETIC_HERTZ
        for i in range(N):
            wst[k, i] = wrow[i] if stops[k, SIGN] > 0.0 else -wrow[i]
    wn = 0.0
    for i in range(N):
        wn += wrow[i] * wrow[i]
    wn = math.sqrt(wn)
    vr = v_floor
    if phase != FREE and hc[phase - 1]:
        k = phase - 1
        uz = 0.0
        for i in range(N):
            uz += wst[k, i] * z[N + i]
        vr = max(uz, v_floor)
        contact_scales(vr, stops[k, STIFFNESS], stops[k, EXPONENT], wn, rk)
    # the modal coefficients of the homogeneous part are carried from step to step (a_j e^{lam_j s},
    # exact; fast overdamped modes decay to exactly 0 and drop out of the sums) and recomputed
    # from the state only at a change of phase
    modal_coordinates(z, WA[phase], ZA[phase], zeA[phase], 0.0, a)
    for p in range(n_transient + n_record):
        recording = p >= n_transient
        ns = ns_record if recording else ns_transient
        h_grid = T / ns
        t0p = (p - n_transient) * T
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
                    return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps, n_rec_l)
                h_min = 1e-13 * T
                side = 0
                if phase != FREE and hc[phase - 1]:
                    # a Hunt-Crossley contact phase: one accepted Dormand-Prince step
                    side = phase - 1
                    for i in range(n2):
                        y0[i] = z[i]
                    y0[n2] = 0.0
                    s_adv, ev = hc_contact_step(rem, phi, y0, F, Om, knd, cnd, part, wst[side], srow,
                                                stops[side, OFFSET], stops[side, STIFFNESS], stops[side, EXPONENT],
                                                stops[side, DAMPING], vr, rk, recording, ext, cs, y1)
                    if s_adv < 0.0:
                        z0[:] = z
                        return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps, n_rec_l)
                    for i in range(n2):
                        z[i] = y1[i]
                else:
                    lam = lamA[phase]
                    for j in range(n2):
                        al[j] = PU[phase, j] * a[j]
                    h = min(rem, hmax[phase])
                    if phase == FREE:
                        # every stop's entry, the last one scanned up to the earliest found
                        s_adv = h
                        ev = EV_NONE
                        for k in range(nst - 1, -1, -1):
                            up = stops[k, SIGN] > 0.0
                            if not up:
                                for j in range(n2):
                                    alk[j] = -al[j]
                            beK = bU[phase] if up else -bU[phase]
                            gaK = (gU[phase] if up else -gU[phase]) - stops[k, OFFSET]
                            # the sign of the force inside the stop: Kelvin-Voigt k g + c g';
                            # Hunt-Crossley g, or g' + v_r / chi after an exit by the damping factor
                            if hc[k]:
                                kf = 0.0 if foff[k] != 0.0 else 1.0
                                cf = 1.0 if foff[k] != 0.0 else 0.0
                            else:
                                kf = stops[k, STIFFNESS]
                                cf = stops[k, DAMPING]
                            s_k, ev_k = free_scan(al if up else alk, lam, beK, gaK, phi, Om, kf, cf, h, h_min, buf, al2,
                                                  foff[k])
                            if s_k < 0.0:
                                z0[:] = z
                                return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps, n_rec_l)
                            if ev_k != EV_NONE:
                                s_adv = s_k
                                ev = ev_k
                                side = k
                                h = s_k
                    else:
                        # the signals of the stop in contact: its gap and force
                        side = phase - 1
                        if stops[side, SIGN] > 0.0:
                            beU = bU[phase]
                            gaU = gU[phase] - stops[side, OFFSET]
                        else:
                            for j in range(n2):
                                al[j] = -al[j]
                            beU = -bU[phase]
                            gaU = -gU[phase] - stops[side, OFFSET]
                        k_s = stops[side, STIFFNESS]
                        c_s = stops[side, DAMPING]
                        ev = EV_NONE
                        s_adv = h
                        b2, g2 = signal_combo(-k_s, -c_s, 0.0, al, lam, beU, gaU, Om, al2)
                        s_x = bupcross(al2, lam, b2, g2, phi, Om, 0.0, h, h_min)
                        if s_x == STALL:
                            s_adv = -1.0
                        elif s_x >= 0.0:
                            s_adv = s_x
                            ev = EV_EXIT
                        # peak force (interior maxima), largest penetration, work on the stop
                        b2, g2 = signal_combo(0.0, -k_s, -c_s, al, lam, beU, gaU, Om, al2)
                        s = 0.0
                        while True:
                            s = bupcross(al2, lam, b2, g2, phi, Om, s, s_adv, h_min)
                            if s == STALL:
                                s_adv = -1.0
                                break
                            if s < 0.0:
                                break
                            signal_derivatives(s, al, lam, beU, gaU, phi, Om, buf)
                            cs[1] = max(cs[1], k_s * buf[0] + c_s * buf[1])
                        b2, g2 = signal_combo(0.0, -1.0, 0.0, al, lam, beU, gaU, Om, al2)
                        s = 0.0
                        while True:
                            s = bupcross(al2, lam, b2, g2, phi, Om, s, s_adv, h_min)
                            if s == STALL:
                                s_adv = -1.0
                                break
                            if s < 0.0:
                                break
                            signal_derivatives(s, al, lam, beU, gaU, phi, Om, buf)
                            cs[2] = max(cs[2], buf[0])
                        acc = 0.0
                        for i in range(GL_X.shape[0]):
                            signal_derivatives(GL_X[i] * s_adv, al, lam, beU, gaU, phi, Om, buf)
                            acc += GL_W[i] * (k_s * buf[0] + c_s * buf[1]) * buf[1]
                        cs[3] += acc * s_adv
                        signal_derivatives(s_adv, al, lam, beU, gaU, phi, Om, buf)
                        cs[1] = max(cs[1], k_s * buf[0] + c_s * buf[1])
                        cs[2] = max(cs[2], buf[0])
                    if recording and s_adv > 0.0:
                        # exact minima (and maxima) of the sensor displacement inside the step
                        for j in range(n2):
                            al[j] = PS[phase, j] * a[j]
                        for sgn in (1.0, -1.0):
                            b2, g2 = signal_combo(0.0, sgn, 0.0, al, lam, bS[phase], gS[phase], Om, al2)
                            s = 0.0
                            while True:
                                s = bupcross(al2, lam, b2, g2, phi, Om, s, s_adv, h_min)
                                if s == STALL:
                                    s_adv = -1.0
                                    break
                                if s < 0.0:
                                    break
                                signal_derivatives(s, al, lam, bS[phase], gS[phase], phi, Om, buf)
                                if sgn > 0.0:
                                    ext[0] = min(ext[0], buf[0])
                                    ext[2] = min(ext[2], buf[0])
                                else:
                                    ext[1] = max(ext[1], buf[0])
                    if s_adv < 0.0:     # a scan that could not be done in double precision (STALL)
                        z0[:] = z
                        return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps, n_rec_l)
                    modal_state(s_adv, a, lam, VA[phase], ZA[phase], zeA[phase], phi, Om, z)
                    for j in range(n2):
                        if a[j] != 0.0:
                            a[j] = a[j] * np.exp(lam[j] * s_adv)
                if phase != FREE and recording:
                    t_con += s_adv
                phi = (phi + Om * s_adv) % TWO_PI
                t_loc += s_adv
                rem -= s_adv
                if rem < 1e-15 * T:
                    rem = 0.0
                if ev == EV_ENTRY or ev == EV_EXIT:
                    nxt = FREE if ev == EV_EXIT else 1 + side
                    if not (ev == EV_ENTRY and hc[side]):
                        modal_coordinates(z, WA[nxt], ZA[nxt], zeA[nxt], phi, a)
                if ev == EV_ENTRY:
                    phase = 1 + side
                    foff[side] = 0.0
                    n_con += 1
                    if n_con > max_contacts:
                        z0[:] = z
                        return (3, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps, n_rec_l)
                    gz = -stops[side, OFFSET]
                    uz = 0.0
                    for i in range(N):
                        gz += wst[side, i] * z[i]
                        uz += wst[side, i] * z[N + i]
                    if hc[side]:
                        # the damping scale v_r of this contact and its step-control scales
                        vr = max(uz, v_floor)
                        contact_scales(vr, stops[side, STIFFNESS], stops[side, EXPONENT], wn, rk)
                        cs[1] = hysteretic_hertz_force(gz, uz, stops[side, STIFFNESS], stops[side, EXPONENT],
                                                    stops[side, DAMPING], vr)
                    else:
                        cs[1] = stops[side, STIFFNESS] * gz + stops[side, DAMPING] * uz
                    cs[0] = t0p + t_loc
                    cs[2] = gz
                    cs[3] = 0.0
                    in_rec = recording
                    if recording:
                        if n_rec < imp_t.shape[0]:
                            imp_t[n_rec] = t0p + t_loc
                            imp_v[n_rec] = uz
                            imp_k[n_rec] = side
                        n_rec += 1
                        if side > 0:
                            n_rec_l += 1
                elif ev == EV_EXIT:
                    phase = FREE
                    if hc[side]:
                        # an exit by the damping factor inside the stop: its force's sign is
                        # g' + v_r / chi until the gap falls back through 0
                        gz = -stops[side, OFFSET]
                        for i in range(N):
                            gz += wst[side, i] * z[i]
                        chi = stops[side, DAMPING]
                        foff[side] = (vr / chi if chi > 0.0 else 1.0) if gz > 0.0 else 0.0
                    if in_rec and n_rec - 1 < cap:
                        r = n_rec - 1
                        con[r, 0] = t0p + t_loc - cs[0]
                        con[r, 1] = cs[1]
                        con[r, 2] = cs[2]
                        con[r, 3] = cs[3]
                        con[r, 4] = imp_v[r] if r < imp_v.shape[0] else np.nan
                    in_rec = False
                elif ev == EV_GAPDOWN:
                    foff[side] = 0.0     # back below the stop (its gap fell through 0)
        if recording:
            pmin[p - n_transient] = ext[2]
    for i in range(n2):
        z0[i] = z[i]
    return (0, n_rec, ext[0], ext[1], phase, n_con, t_con, n_steps, n_rec_l)


def velocity_floor(model, Om) -> float:
    """Hunt-Crossley entry velocities below this are floored (m per kernel time unit):
    ``1e-2 Omega Y |w^T Gamma|`` (the SDOF's ``1e-2 Omega B`` for one mode)."""
    v = HC_V_FLOOR * Om * model.base_amplitude_m * abs(float(model.contact_row @ model.participation))
    return v if v > 0.0 else 1e-6 * model.length_m


def phase_data(model: CompliantBeamModel, Om: float):
    """Eigen-data and signal rows of the phases (free, upper contact[, lower contact]) at forcing
    ``Om`` (see the kernel)."""
    A, b, b0, kc, cc = model.phase_matrices()
    N = model.n_modes
    F = Om ** 2 * model.base_amplitude_m
    n2 = 2 * N
    P = A.shape[0]
    lamA = np.empty((P, n2), np.complex128)
    VA = np.empty((P, n2, n2), np.complex128)
    WA = np.empty((P, n2, n2), np.complex128)
    ZA = np.empty((P, n2), np.complex128)
    zeA = np.empty((P, n2))
    rowU = np.concatenate([model.contact_row, np.zeros(N)])
    rowS = np.concatenate([model.sensor_row, np.zeros(N)])
    PU = np.empty((P, n2), np.complex128)
    PS = np.empty((P, n2), np.complex128)
    bU = np.empty(P, np.complex128)
    bS = np.empty(P, np.complex128)
    gU = np.empty(P)
    gS = np.empty(P)
    for p in range(P):
        lam, V = model._eig[p]
        lamA[p], VA[p], WA[p] = lam, V, model._eiginv[p]
        ZA[p] = np.linalg.solve(1j * Om * np.eye(n2) - A[p], b * F)
        zeA[p] = -np.linalg.solve(A[p], b0[p]) if np.any(b0[p]) else 0.0
        PU[p] = rowU @ V
        PS[p] = rowS @ V
        bU[p] = rowU @ ZA[p]
        bS[p] = rowS @ ZA[p]
        gU[p] = rowU @ zeA[p]
        gS[p] = rowS @ zeA[p]
    return lamA, VA, WA, ZA, zeA, PU, PS, bU, bS, gU, gS, kc, cc


class CompliantBeamEventSolver:
    """Method ``event`` of a beam scene with a Kelvin-Voigt stop (module docstring).

    Same interface as :class:`vibeam.models.beam_dynamics.BeamEventSolver`; the state is
    ``(eta (N), eta' (N), phase)`` (phase 1: in contact with the upper stop, -1 with the
    lower one of a two-sided scene, whose contacts the trajectory's ``impact_stops`` mark).

    Parameters
    ----------
    model : CompliantBeamModel
    transient_samples : int
        Grid points per period in the transient (efficiency only).
    steps_per_fundamental : int
        Largest free step is 1/this of the first modal period; in contact 1/this of the
        isolated contact's period.
    max_impacts_per_period, max_steps_per_period : int
        Guards (status ``failed``).
    """

    name = "event"
    time_domain = True

    def __init__(self, model: CompliantBeamModel, transient_samples: int = 16, steps_per_fundamental: int = 16,
                 max_impacts_per_period: int = 2000, max_steps_per_period: int = 200000,
                 impact_buffer: int = 4096, chatter_tol: float | None = None, record_modal_states: bool = False):
        if getattr(model, "contact", None) is None or \
                any(getattr(st.law, "kind", "") != "compliant" for st in model.stops()):
            raise ValueError("CompliantBeamEventSolver needs a beam model with compliant stops")
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
        ensure_eig(model)

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
        data = phase_data(m, Om)
        lamA, VA, WA, ZA, zeA, PU, PS, bU, bS, gU, gS, kc, cc = data
        stops = m.kernel_stops()
        two = m.two_sided
        hmax = phase_steps(m, self.steps_per_fundamental)
        samples = np.zeros((n_record * samples_per_period, 2))
        pmin = np.zeros(n_record)
        imp_t = np.zeros(self.impact_buffer)
        imp_v = np.zeros(self.impact_buffer)
        imp_k = np.zeros(self.impact_buffer, np.int64)
        con = np.full((self.impact_buffer, 5), np.nan)
        msamp = np.zeros((samples.shape[0] if self.record_modal_states else 0, 2 * N))
        z = s0[:2 * N].copy()
        n_per = max(n_transient + n_record, 1)
        ph0 = 1 if s0[2 * N] > 0.5 else (2 if (s0[2 * N] < -0.5 and two) else 0)
        max_steps, budget = call_budget(self.max_steps_per_period, n_per, self.max_steps_per_call)
        out = beam_compliant_kernel(Om, lamA, VA, WA, ZA, zeA, PU, PS, m.contact_row, m.sensor_row, bU, bS, gU, gS,
                                    stops, m.k_nd, m.c_nd, m.participation, Om ** 2 * m.base_amplitude_m,
                                    velocity_floor(m, Om), z, ph0, int(n_transient), int(n_record),
                                    self.transient_samples, int(samples_per_period), hmax,
                                    self.max_impacts_per_period * n_per, max_steps, samples, pmin, imp_t, imp_v, con,
                                    imp_k, msamp)
        status, n_rec, smin, smax, ph_end, n_con, t_con, n_steps, n_low = out
        incomplete = (status != 0 and budget and n_steps > max_steps
                      and n_con <= self.max_impacts_per_period * n_per)
        ph_end = -1 if ph_end == 2 else ph_end
        L = m.length_m
        k = min(n_rec, self.impact_buffer)
        c = con[:k]
        closed = np.isfinite(c[:, 0])   # a contact still open at the end is not counted
        c = c[closed].copy()
        # nondimensional per unit effective mass (as the SDOF's): force / (m_eff L), penetration
        # / L, work / (m_eff L^2), velocities / L (time unit 1 / omega_ref)
        me = m.m_eff
        c[:, 1] /= me * L
        c[:, 2] /= L
        c[:, 3] /= me * L * L
        c[:, 4] /= L
        T = TWO_PI / Om
        message = "" if status == 0 else f"gave up after {n_con} contacts / {n_steps} steps in {n_per} periods"
        if incomplete:
            message = f"more than max_steps_per_call = {self.max_steps_per_call} steps in {n_per} period(s)"
        extra = {"contact_fraction": t_con / (n_record * T) if n_record else 0.0,
                 "steps_per_period": float(n_steps / n_per)}
        if self.record_modal_states:
            extra["modal_states"] = msamp
        return Trajectory(Omega=Om, samples=samples / L, samples_per_period=samples_per_period,
                          impact_times=imp_t[:k].copy(), impact_velocities=imp_v[:k] / L, n_impacts=int(n_rec),
                          q_min=float(smin / L), q_max=float(smax / L), period_min=pmin / L,
                          status="ok" if status == 0 else "failed", message=message,
                          final_state=np.concatenate([z, [float(ph_end)]]),
                          extra=extra, contacts=c, impact_stops=imp_k[:k].copy() if two else None,
                          contact_stops=imp_k[:k][closed].copy() if two else None,
                          n_impacts_lower=int(n_low) if two else 0, incomplete=bool(incomplete))


def phase_steps(model: CompliantBeamModel, steps_per_fundamental: int) -> np.ndarray:
    """Largest step of each phase of :func:`beam_compliant_kernel` (kernel time units), shape
    (1 + n_stops,): 1/``steps_per_fundamental`` of the first modal period free, of the isolated
    contact's period in a Kelvin-Voigt contact phase (a Hunt-Crossley phase controls its own
    steps: the free value, unused)."""
    free = TWO_PI / math.sqrt(model.k_nd[0])
    ww = float(model.contact_row @ model.contact_row)
    out = [free]
    for st in model.stops():
        k, _ = model.linear_phase(st.law)
        out.append(TWO_PI / math.sqrt(k * ww) if k > 0.0 else free)
    return np.array(out) / steps_per_fundamental


def ensure_eig(model):
    """Diagonalise the phase matrices once per model (cached on it)."""
    key = (model.contact, model.n_modes, model.lower_law, getattr(model, "gap_contact_lower_m", None))
    if getattr(model, "_eig_key", None) == key:
        return
    A, *_ = model.phase_matrices()
    model._eig = []
    model._eiginv = []
    for p in range(A.shape[0]):
        lam, V = np.linalg.eig(A[p])
        model._eig.append((lam.astype(np.complex128), np.ascontiguousarray(V, dtype=np.complex128)))
        model._eiginv.append(np.ascontiguousarray(np.linalg.inv(V), dtype=np.complex128))
    model._eig_key = key
