"""The one shooting problem: ``P^n`` of a modal system with impulsive stops, and its derivatives.

A period-``n`` orbit is a fixed point of the ``n``-th iterate of the stroboscopic map ``P``
(section at forcing phase 0; contract: :mod:`vibeam.models.core.periodic`).  ``P^n(x0; p)`` is one run
of the one event integrator (:func:`vibeam.models.core.integrator.integrate_work`) from ``x0`` with its
event log; the tangent ``J = d x_n / d(x0, p)`` (``M`` and ``x_p`` for any number of parameters)
is then assembled from the log by :func:`tangent` (numba), so that one shot is one compiled call
(:func:`shoot`):

free flight
    per mode the 2x2 transition matrix (:func:`vibeam.models.system.transition_entries`) and the
    explicit parameter dependence of the particular solution and of the damping
    (``d Phi / d sigma``);
held on a set ``H`` of stops
    the same in the constrained coordinates ``zeta = Psi^T (eta - eta_c)``
    (:class:`~vibeam.models.core.stops.HeldSets`), with the parameter dependence of the stops'
    offsets (``eta_c``, ``e``);
impact on stop ``k`` (Newton, ``U+ = -R(U-) U-``, impulse along ``d = Pi_H n_k``)
    the saltation matrix ``S = G_x + (f+ - G_x f-) h_x / (h_x f-)`` of the surface ``h = n_k^T eta
    - D_k``, a rank-one update, its jump written in closed form per unit ``U-`` (no cancellation
    as ``U- -> 0``): ``(-(1 + R) m d, (1 + R) m C_H d + (1 + R + R'(U) U) m d a_n / U)`` with
    ``m = 1 / (n^T d)``, ``a_n = n^T eta''-`` and ``C_H`` the damping of the current flow;
entry into sticking (plastic: the impact and the projection ``eta' -= m d U``)
    the same with the constrained field of ``H + k`` after: the jump per unit ``U`` is ``(-m d,
    m Pi' C d + (Psi' E' Psi'^T - Psi_H E_H Psi_H^T) eta' / U)``, ``E`` the part of ``Psi^T C Psi``
    that the held flows' diagonal damping leaves out (zero for Rayleigh damping; the derivatives
    are those of the held flow as it is: with damping that is not proportional a held orbit is the
    event integrator's, approximate while held, :func:`vibeam.models.core.event.held_damping_note`);
release of stop ``k`` (``lambda_k = g_k^T (K eta + C eta' - Gamma F sin) = 0``, ``g_k`` its row of
``(W W^T)^-1 W``)
    ``dt_r = -(lambda_x dx + lambda_p dp) / lambda_dot`` and ``S = I + (f+ - f-) lambda_x /
    lambda_dot`` (``f+ = f-`` where the contact force vanishes, up to the root's accuracy).

Parameters are directions (:class:`Direction`): what a unit change of ``p`` does to the forcing
frequency, the base amplitude, each stop's offset and restitution coefficient, each mode's damping
coefficient.  A fidelity maps its native keys onto them (the SDOF's ``beta`` is ``dc = 2``, the
beam's ``damping_D_s`` is ``dc_i = omega_i^2 / omega_ref``).

References
----------
R. I. Leine, H. Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, Springer
2004, Ch. 3 and 7 (saltation matrices); M. di Bernardo et al., *Piecewise-smooth Dynamical
Systems*, Springer 2008, Sec. 2.5; I. A. Hiskens, M. A. Pai, Trajectory sensitivity analysis of
hybrid systems, IEEE TCAS-I 47 (2000) 204-220 (parameter sensitivities through events).
"""
from __future__ import annotations

import math
from collections.abc import MutableMapping
from typing import NamedTuple

import numpy as np
from numba import njit

from ..compliant import R_MIN_LINEAR, damping_ratio_for_restitution
from ..contact import LAW_LINEAR
from .continuation_kernels import SMALL_SPECTRUM, bordered_tangent, corrector_step, floquet_spectrum_small
from .periodic import Shot
from ..system import (advance_count, advance_state, drive_displacement, drive_force, drive_slope,
                      drive_velocity_slope, transition_entries)
from . import ahead
from .contact_phase import rk_scales
from .integrator import (EV_ENTRY, EV_EXIT, EV_IMPACT, EV_RELEASE, EV_START, EV_STICK, EV_STICK_IMPACT, LOG_HEAD,
                         ST_FAILED, RunScalars, compliant_work, integrate_work, scalars, new_record, new_work, work_fits)
from .laws import force_partials, hertz_floor, newton_coefficient, start_velocity
from .variational import contact_accel, contact_damping, flow_linear, flow_rk, pair_particular

__all__ = ["Direction", "Directions", "directions", "tangent", "shoot", "correct_frequency", "held_at_section",
           "ShotSettings", "NewtonSettings", "restitution_slope", "dtransition_dsig", "ModalShooting", "Setup", "LazyExtra", "CORRECT_CONVERGED",
           "CORRECT_LEFT", "CORRECT_SINGULAR", "CORRECT_NONFINITE", "CORRECT_NO_CONVERGENCE", "CORRECT_FALLBACK"]

TWO_PI = 2.0 * math.pi
#: integer and flag arguments of compiled calls, typed (a literal argument makes numba compile
#: the callee again for that value)
_ZERO = np.int64(0)
_ONE = np.int64(1)
_MINUS_ONE = np.int64(-1)
_TRUE = np.bool_(True)
_FALSE = np.bool_(False)


class ShotSettings(NamedTuple):
    """The integrator's step cap and guards of a shot (:func:`shoot`, :func:`correct_frequency`;
    :func:`vibeam.models.core.integrator.integrate_work`'s arguments of the same names).  Build it
    with :func:`shot_settings` (one type per field: one compiled specialisation)."""

    h_cap: float
    max_impacts: int
    max_steps: int
    chatter_tol: float


def shot_settings(h_cap, max_impacts, max_steps, chatter_tol) -> ShotSettings:
    """A :class:`ShotSettings` with its fields as Python float and int."""
    return ShotSettings(float(h_cap), int(max_impacts), int(max_steps), float(chatter_tol))


class NewtonSettings(NamedTuple):
    """The stopping rules of :func:`correct_frequency`'s Newton iterations: the residual
    tolerance ``tol``, at most ``max_newton`` steps, the neighbourhood ``radius`` of the predictor
    (< 0: none).  Build it with :func:`newton_settings`."""

    tol: float
    max_newton: int
    radius: float


def newton_settings(tol, max_newton, radius) -> NewtonSettings:
    """A :class:`NewtonSettings` with its fields as Python float and int (``radius`` None: -1)."""
    return NewtonSettings(float(tol), int(max_newton), -1.0 if radius is None else float(radius))


class Direction(NamedTuple):
    """What a unit change of a parameter ``p`` does to the system and its stops.

    Attributes
    ----------
    name : str
    dOm : float
        ``d Omega / dp`` (1 for the forcing frequency).
    dB : float
        ``d B / dp`` (row unit): the base amplitude.
    dD : ndarray, shape (n_s,)
        ``d D_k / dp``: each stop's offset.
    dR : ndarray, shape (n_s,)
        ``d R_k / dp``: each stop's (constant part of its) coefficient of restitution.
    dc : ndarray, shape (n,)
        ``d c_i / dp``: each mode's damping coefficient.
    dkc, dcc : ndarray, shape (n_s,) or float, optional
        ``d kc_k / dp`` and ``d cc_k / dp``: a compliant law's stiffness and dashpot (or ``chi``),
        system units (:mod:`vibeam.models.core.laws`); a compliant stop's ``dR`` is turned into its
        ``dcc`` (the dashpot or ``chi`` of the target R) by :func:`directions`.
    """

    name: str
    dOm: float
    dB: float
    dD: np.ndarray
    dR: np.ndarray
    dc: np.ndarray
    dkc: object = 0.0
    dcc: object = 0.0


class Directions(NamedTuple):
    """``P`` parameter directions in kernel form, with what they do to the held sets.

    Attributes
    ----------
    dOm, dB : ndarray, shape (P,)
    dD, dR : ndarray, shape (P, n_s)
    dc : ndarray, shape (P, n)
    deta_c, de, dcC : ndarray, shape (P, S, n)
        ``d eta_c / dp``, ``d e / dp`` and the constrained modes' ``d c / dp`` of each held set
        (:class:`~vibeam.models.core.stops.HeldSets`).
    dkc, dcc : ndarray, shape (P, n_s)
        The compliant laws' stiffness and dashpot (or ``chi``) derivatives.
    dze : ndarray, shape (P, Q, 2n)
        ``d z_e / dp`` of each linear contact phase's equilibrium (:mod:`vibeam.models.core.phases`).
    """

    dOm: np.ndarray
    dB: np.ndarray
    dD: np.ndarray
    dR: np.ndarray
    dc: np.ndarray
    deta_c: np.ndarray
    de: np.ndarray
    dcC: np.ndarray
    dkc: np.ndarray
    dcc: np.ndarray
    dze: np.ndarray


def directions(core, dirs) -> Directions:
    """The kernel form of a sequence of :class:`Direction` for an
    :class:`~vibeam.models.core.event.EventIntegrator` ``core``."""
    hs = core.held
    st = core.kstops
    n = core.n
    ns = core.n_stops
    S = hs.valid.shape[0]
    P = len(dirs)
    k = core.ksys.k
    dOm = np.array([float(d.dOm) for d in dirs])
    dB = np.array([float(d.dB) for d in dirs])
    dD = np.zeros((P, ns))
    dR = np.zeros((P, ns))
    dc = np.zeros((P, n))
    for p, d in enumerate(dirs):
        dD[p] = np.broadcast_to(np.asarray(d.dD, float), (ns,))
        dR[p] = np.broadcast_to(np.asarray(d.dR, float), (ns,))
        dc[p] = np.broadcast_to(np.asarray(d.dc, float), (n,))
    deta_c = np.zeros((P, S, n))
    de = np.zeros((P, S, n))
    dcC = np.zeros((P, S, n))
    for m in range(1, S):
        if not hs.valid[m]:
            continue
        idx = [j for j in range(ns) if m >> j & 1]
        W = st.normal[idx]
        G = np.linalg.inv(W @ W.T)
        nc = int(hs.nc[m])
        Psi = hs.Psi[m, :, :nc]
        nu2 = hs.nu2[m, :nc]
        for p in range(P):
            dec = W.T @ (G @ dD[p, idx])
            deta_c[p, m] = dec
            de[p, m, :nc] = -(Psi.T @ (k * dec)) / np.where(nu2 > 0, nu2, 1.0)
            dcC[p, m, :nc] = np.einsum("ij,i,ij->j", Psi, dc[p], Psi)
    for p in range(P):
        dcC[p, 0] = dc[p]
    dkc = np.zeros((P, ns))
    dcc = np.zeros((P, ns))
    for p, d in enumerate(dirs):
        dkc[p] = np.broadcast_to(np.asarray(d.dkc, float), (ns,))
        dcc[p] = np.broadcast_to(np.asarray(d.dcc, float), (ns,))
    for k, s in enumerate(core.stops):
        if getattr(s.law, "kind", "") == "compliant":
            # the target R acts through the law's dashpot (Kelvin-Voigt) or chi (hysteretic Hertz)
            dcc[:, k] += dR[:, k] * law_damping_slope(s.law, float(st.kc[k]), float(st.m_eff[k]))
            dR[:, k] = 0.0
    ph = core.compliant.ph if core.compliant is not None else None
    Q = ph.m.shape[0] if ph is not None else 1
    dze = np.zeros((P, Q, 2 * n))
    if ph is not None:
        for (H, C) in zip(*np.nonzero(ph.index >= 0)):
            dze[:, ph.index[H, C]] = _equilibrium_slopes(core, int(H), int(C), deta_c, dD)
    return Directions(dOm, dB, dD, dR, dc, deta_c, de, dcC, dkc, dcc, dze)


def law_damping_slope(law, kc: float, m_eff: float, h: float = 1e-6) -> float:
    """``d cc / dR`` of a compliant law (system units): the Kelvin-Voigt dashpot ``2 zeta(R) sqrt(kc
    m_eff)`` or the hysteretic-Hertz ``chi(R)``, by a central difference of the law's own relation
    (step ``h``, inside ``(0, 1]``; truncation ~1e-12 relative)."""
    R = float(law.R)
    if law.code == LAW_LINEAR:
        a, b = max(R - h, R_MIN_LINEAR + h), min(R + h, 1.0)
        if b <= a:
            return 0.0
        zeta = damping_ratio_for_restitution
        return 2.0 * math.sqrt(kc * m_eff) * (zeta(b) - zeta(a)) / (b - a)
    a, b = max(R - h, 1e-12), min(R + h, 1.0)
    return (law.chi_of(b) - law.chi_of(a)) / (b - a)


def _equilibrium_slopes(core, H: int, C: int, deta_c: np.ndarray, dD: np.ndarray) -> np.ndarray:
    """``d z_e / dp`` (P, 2n) of the linear contact phase ``(H, C)``: ``z_e = (eta_c + Psi zeta_e,
    0)``, ``K_z zeta_e = -Psi^T K eta_c - sum_{k in C} Psi^T n_k kc_k (n_k^T eta_c - D_k)``."""
    hs, st = core.held, core.kstops
    n = core.n
    nc = int(hs.nc[H])
    Psi = hs.Psi[H][:, :nc]
    kk = core.ksys.k
    Kz = np.diag(hs.nu2[H, :nc]).astype(float)
    idx = [k for k in range(core.n_stops) if C >> k & 1]
    for k in idx:
        pn = Psi.T @ st.normal[k]
        Kz = Kz + st.kc[k] * np.outer(pn, pn)
    P = dD.shape[0]
    out = np.zeros((P, 2 * n))
    for p in range(P):
        dec = deta_c[p, H]
        rhs = -(Psi.T @ (kk * dec))
        for k in idx:
            rhs = rhs - (Psi.T @ st.normal[k]) * st.kc[k] * (float(st.normal[k] @ dec) - dD[p, k])
        out[p, :n] = dec + Psi @ np.linalg.solve(Kz, rhs)
    return out


# ============================================================================ helpers
@njit(cache=True, _nrt=False, error_model="numpy")
def restitution_slope(U, table_U, table_R):
    """``dR/dU-`` of a piecewise-linear restitution law (0 for a constant R or outside its nodes)."""
    n = table_U.shape[0]
    if n < 2 or U <= table_U[0] or U >= table_U[n - 1]:
        return 0.0
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if table_U[mid] <= U:
            lo = mid
        else:
            hi = mid
    return (table_R[hi] - table_R[lo]) / (table_U[hi] - table_U[lo])


@njit(cache=True, _nrt=False, error_model="numpy")
def _series_ds(z):
    """``sum_{n>=1} n z^(n-1) / (2n+1)!`` (``dS/d(Delta^2) = s^3`` times this)."""
    out = 0.0
    term = 1.0 / 6.0
    zn = 1.0
    for n in range(1, 10):
        out += n * zn * term
        zn *= z
        term /= (2 * n + 2) * (2 * n + 3)
    return out


@njit(cache=True, _nrt=False, error_model="numpy")
def dtransition_dsig(s, sig, k, typ, q, l1, l2):
    """``d Phi(s) / d sig`` (entries 11, 12, 21, 22) of ``x'' + 2 sig x' + k x = 0`` at fixed ``k``.

    With ``Phi = e^{-sig s} [C I + S (A + sig I)]``, ``C = cosh(mu s)``, ``S = sinh(mu s) / mu``
    (entire functions of ``mu^2 = sig^2 - k``; cos/sin when underdamped), ``dC/dmu^2 = s S / 2`` and
    ``dS/dmu^2 = (s C - S) / (2 mu^2)``, summed as a series when ``|mu^2| s^2 < 0.1`` (near
    critical damping).
    """
    E = math.exp(-sig * s)
    z = (sig * sig - k) * s * s
    if typ == 0:
        c = math.cos(q * s)
        sn = math.sin(q * s)
        Ec = E * c
        Es = E * sn / q
        if abs(z) < 0.1:
            Ed = E * s * s * s * _series_ds(z)
        else:
            Ed = E * (s * c - sn / q) / (-2.0 * q * q)
    elif typ == 2:
        e1 = math.exp(l1 * s)
        e2 = math.exp(l2 * s)
        Ec = 0.5 * (e1 + e2)
        Es = -e1 * math.expm1(-2.0 * q * s) / (2.0 * q)
        if abs(z) < 0.1:
            Ed = E * s * s * s * _series_ds(z)
        else:
            Ed = (s * Ec - Es) / (2.0 * q * q)
    else:
        Ec = E
        Es = s * E
        Ed = E * s * s * s / 6.0
    dEc = -s * Ec + sig * s * Es
    dEs = -s * Es + 2.0 * sig * Ed
    return dEc + sig * dEs + Es, dEs, -k * dEs, dEc - sig * dEs - Es


@njit(cache=True, _nrt=False, error_model="numpy")
def _particular_d(c, k, G, F, Om, dF, dOm, dc, a, b, da, db, m):
    """Particular coefficients ``a, b`` (:func:`vibeam.models.system.particular`) of the first ``m``
    coordinates and their derivatives ``da, db`` (P, m) along the parameter directions."""
    P = dF.shape[0]
    for j in range(m):
        den = complex(k[j] - Om * Om, c[j] * Om)
        z = G[j] * F / den
        a[j] = z.real
        b[j] = z.imag
        for p in range(P):
            dden = complex(-2.0 * Om * dOm[p], dc[p, j] * Om + c[j] * dOm[p])
            dz = G[j] * (dF[p] / den - F * dden / (den * den))
            da[p, j] = dz.real
            db[p, j] = dz.imag


@njit(cache=True, _nrt=False, error_model="numpy")
def _accel(H, eta, etad, t, Om, F, sy, hs, out):
    """The acceleration ``eta''`` of the flow of held set ``H`` (0: free) at a state, in full
    coordinates (the held flows' constrained modal form)."""
    n = eta.shape[0]
    s = math.sin(Om * t)
    if H == 0:
        for i in range(n):
            out[i] = sy.gam[i] * F * s - sy.c[i] * etad[i] - sy.k[i] * eta[i]
        return
    nc = hs.nc[H]
    for i in range(n):
        out[i] = 0.0
    for j in range(nc):
        z = 0.0
        zd = 0.0
        for i in range(n):
            z += hs.Psi[H, i, j] * (eta[i] - hs.eta_c[H, i])
            zd += hs.Psi[H, i, j] * etad[i]
        azj = hs.gam[H, j] * F * s - hs.c[H, j] * zd - hs.nu2[H, j] * (z - hs.e[H, j])
        for i in range(n):
            out[i] += hs.Psi[H, i, j] * azj


@njit(cache=True, _nrt=False, error_model="numpy")
def _flow_free(J, ta, tb, eta, etad, Om, mp, a, b, da, db, dc, dOm, n):
    """Tangent of the free modal flow from ``ta`` to ``tb`` (absolute times), in place.

    ``J`` (2n, 2n + P): rows ``eta``, ``eta'``; the last ``P`` columns ``d/dp``; ``(eta, etad)`` the
    state at ``ta``; ``a, b`` the particular solution, ``da, db`` (P, n) its derivatives, ``dc``
    (P, n) the damping's, ``dOm`` (P,)."""
    ncol = J.shape[1]
    P = da.shape[0]
    ip0 = ncol - P
    s = tb - ta
    if s <= 0.0:
        return
    sa, ca = math.sin(Om * ta), math.cos(Om * ta)
    sb, cb = math.sin(Om * tb), math.cos(Om * tb)
    for i in range(n):
        sig = mp[i, 0]
        kk = mp[i, 1]
        typ = int(mp[i, 2])
        t11, t12, t21, t22 = transition_entries(s, sig, kk, typ, mp[i, 3], mp[i, 4], mp[i, 5])
        for c in range(ncol):
            u = J[i, c]
            v = J[n + i, c]
            J[i, c] = t11 * u + t12 * v
            J[n + i, c] = t21 * u + t22 * v
        for p in range(P):
            dpa = da[p, i] * sa + db[p, i] * ca + dOm[p] * ta * (a[i] * ca - b[i] * sa)
            dva = (dOm[p] * (a[i] * ca - b[i] * sa) + Om * (da[p, i] * ca - db[p, i] * sa)
                   - Om * dOm[p] * ta * (a[i] * sa + b[i] * ca))
            dpb = da[p, i] * sb + db[p, i] * cb + dOm[p] * tb * (a[i] * cb - b[i] * sb)
            dvb = (dOm[p] * (a[i] * cb - b[i] * sb) + Om * (da[p, i] * cb - db[p, i] * sb)
                   - Om * dOm[p] * tb * (a[i] * sb + b[i] * cb))
            ep = dpb - (t11 * dpa + t12 * dva)
            ev = dvb - (t21 * dpa + t22 * dva)
            if dc[p, i] != 0.0:
                x0 = eta[i] - (a[i] * sa + b[i] * ca)
                y0 = etad[i] - Om * (a[i] * ca - b[i] * sa)
                d11, d12, d21, d22 = dtransition_dsig(s, sig, kk, typ, mp[i, 3], mp[i, 4], mp[i, 5])
                ep += 0.5 * dc[p, i] * (d11 * x0 + d12 * y0)
                ev += 0.5 * dc[p, i] * (d21 * x0 + d22 * y0)
            J[i, ip0 + p] += ep
            J[n + i, ip0 + p] += ev


@njit(cache=True, _nrt=False, error_model="numpy")
def _flow_held(J, ta, tb, eta, etad, Om, H, hs, aC, bC, daC, dbC, dd, n, Z, Zd):
    """Tangent of the flow held on set ``H`` from ``ta`` to ``tb``, in place: the tangent is taken
    to ``zeta`` with ``Psi^T``, advanced per constrained mode and taken back, ``d eta_c / dp`` added
    to the parameter columns (``Z``, ``Zd``: work arrays of at least ``nc`` rows and the tangent's
    columns)."""
    ncol = J.shape[1]
    P = daC.shape[0]
    ip0 = ncol - P
    nc = hs.nc[H]
    s = tb - ta
    for j in range(nc):             # Z = Psi^T J_eta, Zd = Psi^T J_eta'  (nc x ncol)
        for c in range(ncol):
            Z[j, c] = 0.0
            Zd[j, c] = 0.0
        for i in range(n):
            w = hs.Psi[H, i, j]
            if w != 0.0:
                for c in range(ncol):
                    Z[j, c] += w * J[i, c]
                    Zd[j, c] += w * J[n + i, c]
    sa, ca = math.sin(Om * ta), math.cos(Om * ta)
    sb, cb = math.sin(Om * tb), math.cos(Om * tb)
    if s > 0.0:
        for j in range(nc):
            sig = hs.mp[H, j, 0]
            kk = hs.mp[H, j, 1]
            typ = int(hs.mp[H, j, 2])
            t11, t12, t21, t22 = transition_entries(s, sig, kk, typ, hs.mp[H, j, 3], hs.mp[H, j, 4], hs.mp[H, j, 5])
            for c in range(ncol):
                u = Z[j, c]
                v = Zd[j, c]
                Z[j, c] = t11 * u + t12 * v
                Zd[j, c] = t21 * u + t22 * v
            for p in range(P):
                dpa = daC[p, j] * sa + dbC[p, j] * ca + dd.dOm[p] * ta * (aC[j] * ca - bC[j] * sa)
                dva = (dd.dOm[p] * (aC[j] * ca - bC[j] * sa) + Om * (daC[p, j] * ca - dbC[p, j] * sa)
                       - Om * dd.dOm[p] * ta * (aC[j] * sa + bC[j] * ca))
                dpb = daC[p, j] * sb + dbC[p, j] * cb + dd.dOm[p] * tb * (aC[j] * cb - bC[j] * sb)
                dvb = (dd.dOm[p] * (aC[j] * cb - bC[j] * sb) + Om * (daC[p, j] * cb - dbC[p, j] * sb)
                       - Om * dd.dOm[p] * tb * (aC[j] * sb + bC[j] * cb))
                # offset e: zeta = e + zp + Phi (zeta_a - e - zp_a)
                dej = dd.de[p, H, j]
                ep = dpb - (t11 * dpa + t12 * dva) + dej * (1.0 - t11)
                ev = dvb - (t21 * dpa + t22 * dva) - dej * t21
                dcj = dd.dcC[p, H, j]
                if dcj != 0.0:
                    z0 = 0.0
                    zd0 = 0.0
                    for i in range(n):
                        z0 += hs.Psi[H, i, j] * (eta[i] - hs.eta_c[H, i])
                        zd0 += hs.Psi[H, i, j] * etad[i]
                    x0 = z0 - hs.e[H, j] - (aC[j] * sa + bC[j] * ca)
                    y0 = zd0 - Om * (aC[j] * ca - bC[j] * sa)
                    d11, d12, d21, d22 = dtransition_dsig(s, sig, kk, typ, hs.mp[H, j, 3], hs.mp[H, j, 4],
                                                          hs.mp[H, j, 5])
                    ep += 0.5 * dcj * (d11 * x0 + d12 * y0)
                    ev += 0.5 * dcj * (d21 * x0 + d22 * y0)
                Z[j, ip0 + p] += ep
                Zd[j, ip0 + p] += ev
    for i in range(n):              # J = Psi Z
        for c in range(ncol):
            J[i, c] = 0.0
            J[n + i, c] = 0.0
        for j in range(nc):
            w = hs.Psi[H, i, j]
            if w != 0.0:
                for c in range(ncol):
                    J[i, c] += w * Z[j, c]
                    J[n + i, c] += w * Zd[j, c]
    for p in range(P):
        for i in range(n):
            J[i, ip0 + p] += dd.deta_c[p, H, i]


@njit(cache=True, _nrt=False, error_model="numpy")
def _project_velocity(J, d, nrm, me, n):
    """``J_eta' -= m d (n^T J_eta')`` (a velocity reset along ``d``), every column."""
    for c in range(J.shape[1]):
        r = 0.0
        for i in range(n):
            r += nrm[i] * J[n + i, c]
        for i in range(n):
            J[n + i, c] -= d[i] * me * r


# ============================================================================ the tangent
@njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def tangent_work(n, ns, S, P):
    """The work arrays of :func:`tangent` for ``n`` modes, ``ns`` stops, ``S`` held sets and ``P``
    parameter directions (allocated once for the shots of a call; :func:`tangent` sets what it
    reads: the arrays read before written are cleared there)."""
    ncol = 2 * n + P
    return (np.empty(P), np.empty(n), np.empty(n), np.empty((P, n)), np.empty((P, n)), np.empty((S, n)),
            np.empty((S, n)), np.empty((S, P, n)), np.empty((S, P, n)), np.empty((P, n)), np.empty((n, ncol)),
            np.empty((n, ncol)), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(ncol),
            np.empty(ncol), np.empty(ns), np.empty((ns, ncol)))


@njit(cache=True, error_model="numpy")
def tangent(sy, st, hs, cp, dd, Om, evlog, n_ev, held0, x_start, x_end, held_end, T_end, J, rel, rst, tw):
    """The tangent ``J = d x(T_end) / d(x0, p)`` of one logged run of the event integrator.

    Parameters
    ----------
    sy, st, hs : KernelSystem, KernelStops, HeldSets
        The run's system, stops and held sets (:mod:`vibeam.models.core.stops`).
    cp : Compliant or None
        The compliant stops' data (:mod:`vibeam.models.core.phases`); None: Newton stops only.
    dd : Directions
        ``P`` parameter directions (:func:`directions`).
    Om : float
        Forcing frequency.
    evlog : ndarray, shape (>= n_ev, LOG_HEAD + 2n)
        The run's event log (:mod:`vibeam.models.core.integrator`).
    n_ev : int
    held0 : int
        The mask of the stops the run started held on (Newton) or in contact with (compliant).
    x_start, x_end : ndarray, shape (2n,)
        State passed to the run (before its projection onto held stops) and its final state.
    held_end : int
        The same mask at the end.
    T_end : float
        End time ``n T``.
    J : ndarray, shape (2n, 2n + P)
        Receives ``[M | x_p]``.
    rel : ndarray, shape (>= releases, 2n + P + 1)
        Receives, per release, its time and ``d t_r / d(x0, p)``.
    rst : ndarray, shape (2n,)
        Receives the end state rebuilt by the tangent's own flows from the last logged event (a
        check of their consistency with the run; with compliant stops only, ``cp`` not None:
        otherwise the state at the last event).
    tw : tuple
        Work arrays (:func:`tangent_work`), overwritten.

    Returns
    -------
    n_rel : int
    n_inexact : int
        Events without an exact derivative (a release forced at the end of a chatter hold, an
        entry into sticking at zero velocity after the start); -1: a hysteretic-Hertz contact
        entered inside its stop (its force depends on an earlier contact), -2: a Runge-Kutta
        contact phase whose step underflowed.
    """
    n = sy.k.shape[0]
    ns = st.offset.shape[0]
    S = hs.valid.shape[0]
    P = dd.dOm.shape[0]
    ncol = 2 * n + P
    ip0 = 2 * n
    F = drive_force(sy.p, sy.B, Om)
    (dF, aF, bF, daF, dbF, aC, bC, daC, dbC, dcC, Z, Zd, eta, etad, a0, a1, cd, hrow, lrow, vr, dvr) = tw
    for p in range(P):
        dF[p] = drive_slope(sy.p, sy.B, Om, dd.dOm[p], dd.dB[p])
    _particular_d(sy.c, sy.k, sy.gam, F, Om, dF, dd.dOm, dd.dc, aF, bF, daF, dbF, n)
    aC[:] = 0.0
    bC[:] = 0.0
    daC[:] = 0.0
    dbC[:] = 0.0
    dcC[:] = 0.0
    vr[:] = 0.0
    dvr[:] = 0.0
    for m in range(1, S):
        if hs.valid[m] == 1:
            for p in range(P):
                for j in range(n):
                    dcC[p, j] = dd.dcC[p, m, j]
            _particular_d(hs.c[m], hs.nu2[m], hs.gam[m], F, Om, dF, dd.dOm, dcC, aC[m], bC[m], daC[m], dbC[m],
                          hs.nc[m])
    for i in range(2 * n):
        for c in range(ncol):
            J[i, c] = 1.0 if i == c else 0.0
    for i in range(n):
        eta[i] = x_start[i]
        etad[i] = x_start[n + i]
    n_rel = 0
    n_inexact = 0
    t_cur = 0.0
    # ---- compliant stops: the contact set C, each open contact's v_in and its sensitivity row
    cmask = 0
    C = 0
    if cp is not None:
        ph = cp.ph
        Q = ph.m.shape[0]
        ZX = np.zeros((Q, n), np.complex128)
        ZY = np.zeros((Q, n), np.complex128)
        dZX = np.zeros((Q, P, n), np.complex128)
        dZY = np.zeros((Q, P, n), np.complex128)
        for q in range(Q):
            pair_particular(ph, q, Om, F, dF, dd.dOm, ZX[q], ZY[q], dZX[q], dZY[q])
        W = np.zeros((2 * n, ncol))
        rkc = np.zeros(4)
        # a direction that changes a linear contact phase's matrix (modal damping, a law's stiffness
        # or dashpot) has no closed-form derivative here: its phases are integrated with their
        # variational equations instead (to the Runge-Kutta tolerance)
        apar = False
        for p in range(P):
            for i in range(n):
                if dd.dc[p, i] != 0.0:
                    apar = True
            for k in range(ns):
                if dd.dkc[p, k] != 0.0 or dd.dcc[p, k] != 0.0:
                    apar = True
        vfl = np.zeros(ns)
        dfl = np.zeros((ns, P))
        for k in range(ns):
            if st.law[k] != 0:
                cmask |= 1 << k
                gn = 0.0
                for i in range(n):
                    gn += st.normal[k, i] * sy.gam[i]
                vfl[k] = hertz_floor(Om, drive_displacement(sy.p, sy.B, Om), gn, cp.vfall, cp.vfac)
                if Om * sy.B > 0.0:
                    for p in range(P):
                        dfl[k, p] = vfl[k] * drive_velocity_slope(sy.p, sy.B, Om, dd.dOm[p], dd.dB[p])
        C = held0 & cmask
        for k in range(ns):
            if (C >> k) & 1:
                _start_row(st, dd, k, eta, etad, vfl[k], dfl[k], vr, dvr[k], ip0)
    H = held0 & ~cmask
    if H != 0:
        # the run put the state on the held set's constraint: J_eta -> Pi J_eta + d eta_c / dp,
        # J_eta' -> Pi J_eta'
        nc = hs.nc[H]
        for c in range(ncol):
            for half in range(2):
                o = half * n
                for j in range(nc):
                    r = 0.0
                    for i in range(n):
                        r += hs.Psi[H, i, j] * J[o + i, c]
                    Z[j, c] = r
                for i in range(n):
                    r = 0.0
                    for j in range(nc):
                        r += hs.Psi[H, i, j] * Z[j, c]
                    J[o + i, c] = r
        for p in range(P):
            for i in range(n):
                J[i, ip0 + p] += dd.deta_c[p, H, i]
    k_ev = 0
    while k_ev <= n_ev:
        if k_ev < n_ev:
            kind = int(evlog[k_ev, 0])
            te = evlog[k_ev, 1]
            aux = evlog[k_ev, 2]
            k = int(evlog[k_ev, 3])
        else:
            kind = -1
            te = T_end
            aux = 0.0
            k = 0
        if kind == EV_START:
            if aux < 0.5:
                # the position put on stop k (not held): eta -= m n (n^T eta - D)
                me = st.m_eff[k]
                for c in range(ncol):
                    r = 0.0
                    for i in range(n):
                        r += st.normal[k, i] * J[i, c]
                    for i in range(n):
                        J[i, c] -= st.normal[k, i] * me * r
                for p in range(P):
                    for i in range(n):
                        J[i, ip0 + p] += st.normal[k, i] * me * dd.dD[p, k]
            for i in range(n):
                eta[i] = evlog[k_ev, LOG_HEAD + i]
                etad[i] = evlog[k_ev, LOG_HEAD + n + i]
            k_ev += 1
            continue
        # ---- flow up to the event (or the end), in the phase (H, C); the state it rebuilds
        for i in range(n):
            rst[i] = eta[i]
            rst[n + i] = etad[i]
        if cp is not None and C != 0:
            qq = ph.index[H, C]
            if qq >= 0 and not apar:
                flow_linear(J, t_cur, te, qq, ph, Om, ZX[qq], ZY[qq], dZX[qq], dZY[qq], dd.dze, dd.dOm, W)
                _linear_state(rst, t_cur, te, qq, ph, Om, ZX[qq], ZY[qq], n)
            else:
                rk_scales(H, C, sy, st, hs, vr, rkc)
                if not flow_rk(J, t_cur, te, eta, etad, H, C, Om, F, dF, sy, st, hs, dd, vr, dvr, cp.tab, rkc, rst):
                    return n_rel, -2
        elif H == 0:
            _flow_free(J, t_cur, te, eta, etad, Om, sy.mp, aF, bF, daF, dbF, dd.dc, dd.dOm, n)
            if cp is not None:      # the rebuilt state is a check of the compliant phases' flows
                _free_state(rst, t_cur, te, Om, sy.mp, aF, bF, n)
        else:
            _flow_held(J, t_cur, te, eta, etad, Om, H, hs, aC[H], bC[H], daC[H], dbC[H], dd, n, Z, Zd)
            if cp is not None:
                _held_state(rst, t_cur, te, Om, H, hs, aC[H], bC[H], n)
        t_cur = te
        if kind < 0:
            break
        for i in range(n):
            eta[i] = evlog[k_ev, LOG_HEAD + i]
            etad[i] = evlog[k_ev, LOG_HEAD + n + i]
        nv = st.normal[k]
        U = 0.0
        for i in range(n):
            U += nv[i] * etad[i]
        if cp is not None and (kind == EV_ENTRY or kind == EV_EXIT):
            if kind == EV_EXIT:
                C &= ~(1 << k)          # the force is zero there: the fields agree, S = I
                k_ev += 1
                continue
            # ---- a compliant contact begins: through its gap (h = n^T eta - D) or inside the stop
            g = -st.offset[k]
            sc = abs(st.offset[k]) + abs(U) / Om
            for i in range(n):
                g += nv[i] * eta[i]
                sc += abs(nv[i] * eta[i])
            through = abs(g) <= 1e-10 * sc
            for c in range(ncol):
                r = 0.0
                for i in range(n):
                    r += nv[i] * J[i, c]
                hrow[c] = r
            for p in range(P):
                hrow[ip0 + p] -= dd.dD[p, k]
            if st.law[k] == LAW_LINEAR:
                vr[k] = max(abs(U), vfl[k])
                if through:
                    # the dashpot acts at once: the field jumps by -d c U, S = I - d c h_x (U cancels)
                    for c in range(ncol):
                        hc = hrow[c]
                        if hc != 0.0:
                            for i in range(n):
                                J[n + i, c] -= (nv[i] if H == 0 else hs.dirn[H, k, i]) * st.cc[k] * hc
            else:
                if not through:
                    return n_rel, -1
                # v_in = max(U, floor) moves with the entry: dU = n^T J_eta' - (n^T a-) h_row / U
                if U > vfl[k]:
                    vr[k] = U
                    _accel(H, eta, etad, te, Om, F, sy, hs, a0)
                    contact_accel(H, C, eta, etad, st, hs, vr, a0)
                    an = 0.0
                    for i in range(n):
                        an += nv[i] * a0[i]
                    for c in range(ncol):
                        r = 0.0
                        for i in range(n):
                            r += nv[i] * J[n + i, c]
                        dvr[k, c] = r - an * hrow[c] / U
                else:
                    vr[k] = vfl[k]
                    for c in range(ncol):
                        dvr[k, c] = dfl[k, c - ip0] if c >= ip0 else 0.0
            C |= 1 << k
            k_ev += 1
            continue
        if H == 0:
            d = st.normal[k]
            me = st.m_eff[k]
        else:
            d = hs.dirn[H, k]
            me = hs.meff[H, k]
        if kind == EV_IMPACT or kind == EV_STICK:
            # row h_x J + h_p of the contact surface h = n^T eta - D_k
            for c in range(ncol):
                r = 0.0
                for i in range(n):
                    r += nv[i] * J[i, c]
                hrow[c] = r
            for p in range(P):
                hrow[ip0 + p] -= dd.dD[p, k]
        plastic = kind == EV_STICK or (kind == EV_IMPACT and k_ev + 1 < n_ev and
                                       int(evlog[k_ev + 1, 0]) == EV_STICK_IMPACT)
        if kind == EV_IMPACT and not plastic:
            m_nodes = st.nodes[k]
            Rc = newton_coefficient(st, k, U)
            Rp = restitution_slope(U, st.tab_U[k, :m_nodes], st.tab_R[k, :m_nodes])
            _accel(H, eta, etad, te, Om, F, sy, hs, a0)
            if cp is not None and C != 0:
                contact_accel(H, C, eta, etad, st, hs, vr, a0)
            an = 0.0
            for i in range(n):
                an += nv[i] * a0[i]
            gv = (1.0 + Rc + Rp * U) * me
            # G_x: eta' -= d (1 + R + R'U) m n^T eta';  G_R: -d m U per unit R
            for c in range(ncol):
                r = 0.0
                for i in range(n):
                    r += nv[i] * J[n + i, c]
                for i in range(n):
                    J[n + i, c] -= d[i] * gv * r
            for p in range(P):
                for i in range(n):
                    J[n + i, ip0 + p] -= dd.dR[p, k] * d[i] * me * U
            # the damping of the current flow applied to d: C d free, Psi c Psi^T d held (and the
            # compliant stops' in contact)
            if H == 0:
                for i in range(n):
                    cd[i] = sy.c[i] * d[i]
            else:
                for i in range(n):
                    cd[i] = 0.0
                for j in range(hs.nc[H]):
                    r = 0.0
                    for i in range(n):
                        r += hs.Psi[H, i, j] * d[i]
                    for i in range(n):
                        cd[i] += hs.Psi[H, i, j] * hs.c[H, j] * r
            if cp is not None and C != 0:
                contact_damping(H, C, eta, etad, st, hs, vr, d, cd)
            if U > 0.0:
                for c in range(ncol):
                    hc = hrow[c]
                    if hc != 0.0:
                        for i in range(n):
                            J[i, c] -= (1.0 + Rc) * me * d[i] * hc
                            J[n + i, c] += ((1.0 + Rc) * me * cd[i] + gv * d[i] * an / U) * hc
            P_imp = -(1.0 + Rc) * me * U
            for i in range(n):
                etad[i] += d[i] * P_imp
            k_ev += 1
            continue
        if plastic:
            H2 = H | (1 << k)
            # the plastic projection eta' -= m d U, and the constrained field of H2 after it
            _project_velocity(J, d, nv, me, n)
            if U > 0.0:
                # jump per unit U: (-m d, m Pi' C d + (Psi' E' Psi'^T - Psi_H E_H Psi_H^T) eta' / U)
                for i in range(n):
                    cd[i] = 0.0
                nc2 = hs.nc[H2]
                for j in range(nc2):
                    r = 0.0
                    for i in range(n):
                        r += hs.Psi[H2, i, j] * sy.c[i] * d[i]
                    for i in range(n):
                        cd[i] += hs.Psi[H2, i, j] * me * r
                    # the mismatch E' of the held damping, on the pre-event velocity
                    for jj in range(nc2):
                        e = hs.Emis[H2, j, jj]
                        if e != 0.0:
                            zd = 0.0
                            for i in range(n):
                                zd += hs.Psi[H2, i, jj] * etad[i]
                            for i in range(n):
                                cd[i] += hs.Psi[H2, i, j] * e * zd / U
                if H != 0:
                    nc1 = hs.nc[H]
                    for j in range(nc1):
                        for jj in range(nc1):
                            e = hs.Emis[H, j, jj]
                            if e != 0.0:
                                zd = 0.0
                                for i in range(n):
                                    zd += hs.Psi[H, i, jj] * etad[i]
                                for i in range(n):
                                    cd[i] -= hs.Psi[H, i, j] * e * zd / U
                for c in range(ncol):
                    hc = hrow[c]
                    if hc != 0.0:
                        for i in range(n):
                            J[i, c] -= me * d[i] * hc
                            J[n + i, c] += cd[i] * hc
            elif te > 0.0:
                n_inexact += 1
            for i in range(n):
                etad[i] -= d[i] * me * U
            H = H2
            k_ev += 2 if kind == EV_IMPACT else 1
            continue
        if kind == EV_RELEASE:
            H2 = H & ~(1 << k)
            g = hs.gw[H, k]
            # lambda_k = g^T (K eta + C eta' - Gamma F sin(Om t) + sum_c n_c f_c)
            _accel(H, eta, etad, te, Om, F, sy, hs, a0)
            _accel(H2, eta, etad, te, Om, F, sy, hs, a1)
            if cp is not None and C != 0:
                contact_accel(H, C, eta, etad, st, hs, vr, a0)
                contact_accel(H2, C, eta, etad, st, hs, vr, a1)
            cs = math.cos(Om * te)
            sn = math.sin(Om * te)
            ldot = 0.0
            for i in range(n):
                ldot += g[i] * (sy.k[i] * etad[i] + sy.c[i] * a0[i] - sy.gam[i] * F * Om * cs)
            for c in range(ncol):
                r = 0.0
                for i in range(n):
                    r += g[i] * (sy.k[i] * J[i, c] + sy.c[i] * J[n + i, c])
                lrow[c] = r
            for p in range(P):
                r = 0.0
                for i in range(n):
                    r += g[i] * (dd.dc[p, i] * etad[i]
                                 - sy.gam[i] * (dF[p] * sn + dd.dOm[p] * F * te * cs))
                lrow[ip0 + p] += r
            if cp is not None and C != 0:
                _release_contacts(C, g, eta, etad, a0, J, st, dd, vr, dvr, lrow, n, ip0)
                for c in range(ns):
                    if (C >> c) & 1:
                        w = 0.0
                        gg = -st.offset[c]
                        gd = 0.0
                        gdd = 0.0
                        for i in range(n):
                            w += g[i] * st.normal[c, i]
                            gg += st.normal[c, i] * eta[i]
                            gd += st.normal[c, i] * etad[i]
                            gdd += st.normal[c, i] * a0[i]
                        fg, fgd, _fv = force_partials(st.law[c], gg, gd, st.kc[c], st.cc[c], st.pe[c], vr[c])
                        ldot += w * (fg * gd + fgd * gdd)
            if n_rel < rel.shape[0]:
                rel[n_rel, 0] = te
            if ldot > 0.0 and aux <= 0.0:
                for c in range(ncol):
                    if n_rel < rel.shape[0]:
                        rel[n_rel, 1 + c] = -lrow[c] / ldot
                    for i in range(n):
                        J[n + i, c] += (a1[i] - a0[i]) * lrow[c] / ldot
            elif te > 0.0:
                n_inexact += 1   # released at a step start with lambda > 0 (the end of a chatter hold)
            n_rel += 1
            H = H2
            k_ev += 1
            continue
        k_ev += 1    # EV_STICK_IMPACT without its impact cannot happen; skip defensively
    # the end time n T = 2 pi n / Omega moves with Omega: + f(nT) d(nT)/dOmega
    _accel(held_end & ~cmask, x_end[:n], x_end[n:], T_end, Om, F, sy, hs, a0)
    if cp is not None and C != 0:
        contact_accel(held_end & ~cmask, C, x_end[:n], x_end[n:], st, hs, vr, a0)
    dT = -T_end / Om
    for p in range(P):
        if dd.dOm[p] != 0.0:
            for i in range(n):
                J[i, ip0 + p] += x_end[n + i] * dT * dd.dOm[p]
                J[n + i, ip0 + p] += a0[i] * dT * dd.dOm[p]
    return n_rel, n_inexact


@njit(cache=True, error_model="numpy")
def _release_contacts(C, g, eta, etad, a0, J, st, dd, vr, dvr, lrow, n, ip0):
    """The compliant contacts' part of a held stop's constraint-force row ``lrow``:
    ``sum_c (g^T n_c) df_c`` with ``df = f_g dg + f_g' dg' + f_v dv_in`` (and ``dg_p = -dD``)."""
    ncol = J.shape[1]
    for c in range(st.offset.shape[0]):
        if (C >> c) & 1 == 0:
            continue
        w = 0.0
        gg = -st.offset[c]
        gd = 0.0
        for i in range(n):
            w += g[i] * st.normal[c, i]
            gg += st.normal[c, i] * eta[i]
            gd += st.normal[c, i] * etad[i]
        fg, fgd, fv = force_partials(st.law[c], gg, gd, st.kc[c], st.cc[c], st.pe[c], vr[c])
        for col in range(ncol):
            dg = 0.0
            dgd = 0.0
            for i in range(n):
                dg += st.normal[c, i] * J[i, col]
                dgd += st.normal[c, i] * J[n + i, col]
            if col >= ip0:
                dg -= dd.dD[col - ip0, c]
            lrow[col] += w * (fg * dg + fgd * dgd + fv * dvr[c, col])


@njit(cache=True, _nrt=False, error_model="numpy")
def _free_state(z, ta, tb, Om, mp, a, b, n):
    """The free flight's state ``z = (eta, eta')`` carried from ``ta`` to ``tb`` (closed form)."""
    advance_state(tb - ta, Om * ta, Om, z, mp, a, b, n)


@njit(cache=True, error_model="numpy")
def _held_state(z, ta, tb, Om, H, hs, a, b, n):
    """The same on the held set ``H`` (its constrained coordinates)."""
    nc = hs.nc[H]
    zeta = np.zeros(n)
    zetad = np.zeros(n)
    for j in range(nc):
        for i in range(n):
            zeta[j] += hs.Psi[H, i, j] * (z[i] - hs.eta_c[H, i])
            zetad[j] += hs.Psi[H, i, j] * z[n + i]
    advance_count(tb - ta, Om * ta, Om, zeta, zetad, hs.mp[H], a, b, hs.e[H], nc)
    for i in range(n):
        e = hs.eta_c[H, i]
        ed = 0.0
        for j in range(nc):
            e += hs.Psi[H, i, j] * zeta[j]
            ed += hs.Psi[H, i, j] * zetad[j]
        z[i] = e
        z[n + i] = ed


@njit(cache=True, error_model="numpy")
def _linear_state(z, ta, tb, q, ph, Om, ZX, ZY, n):
    """The same in the linear contact phase ``q``: ``z_e + T (w_p(tb) + Phi (Ti (z - z_e) - w_p(ta)))``."""
    m = ph.m[q]
    w = np.zeros(2 * m)
    sa, ca = math.sin(Om * ta), math.cos(Om * ta)
    sb, cb = math.sin(Om * tb), math.cos(Om * tb)
    for j in range(m):
        x = 0.0
        y = 0.0
        for i in range(2 * n):
            x += ph.Tix[q, j, i] * (z[i] - ph.ze[q, i])
            y += ph.Tiy[q, j, i] * (z[i] - ph.ze[q, i])
        x -= ZX[j].real * sa + ZX[j].imag * ca
        y -= ZY[j].real * sa + ZY[j].imag * ca
        t11, t12, t21, t22 = transition_entries(tb - ta, ph.mp[q, j, 0], ph.mp[q, j, 1], int(ph.mp[q, j, 2]),
                                                ph.mp[q, j, 3], ph.mp[q, j, 4], ph.mp[q, j, 5])
        w[j] = t11 * x + t12 * y + ZX[j].real * sb + ZX[j].imag * cb
        w[m + j] = t21 * x + t22 * y + ZY[j].real * sb + ZY[j].imag * cb
    for i in range(2 * n):
        r = ph.ze[q, i]
        for j in range(m):
            r += ph.Tx[q, i, j] * w[j] + ph.Ty[q, i, j] * w[m + j]
        z[i] = r


# ============================================================================ one shot
@njit(cache=True, _nrt=False, error_model="numpy")
def held_at_section(st, hs, x0, Om):
    """The stops a state ``(eta, eta')`` lies on with zero normal velocity, within 1e-9 of the
    state's scale (bit mask, 0 none): an orbit through it is taken as held there at the section."""
    n = x0.shape[0] // 2
    en = 0.0
    vn = 0.0
    for i in range(n):
        en += x0[i] * x0[i]
        vn += x0[n + i] * x0[n + i]
    en = math.sqrt(en)
    vn = math.sqrt(vn) + Om * en
    mask = 0
    for k in range(st.offset.shape[0]):
        if st.law[k] != 0:
            continue            # a compliant stop is never held (see contact_at_section)
        nn = 0.0
        g = -st.offset[k]
        U = 0.0
        for i in range(n):
            nn += st.normal[k, i] * st.normal[k, i]
            g += st.normal[k, i] * x0[i]
            U += st.normal[k, i] * x0[n + i]
        nn = math.sqrt(nn)
        if g > -1e-9 * (abs(st.offset[k]) + nn * en + 1e-300) and abs(U) <= 1e-9 * (nn * vn + 1e-300):
            if hs.valid[mask | (1 << k)] == 1:
                mask |= 1 << k
    return mask


@njit(cache=True, _nrt=False, error_model="numpy")
def contact_at_section(st, x0):
    """The compliant stops a state ``(eta, eta')`` is in contact with (bit mask: the penetration
    ``g >= 0`` and the force positive), and the hysteretic-Hertz stops it lies inside of (their
    force depends on the entry velocity of a contact before the section: not a state of the
    shooting problem)."""
    n = x0.shape[0] // 2
    mask = 0
    bad = 0
    for k in range(st.offset.shape[0]):
        if st.law[k] == 0:
            continue
        g = -st.offset[k]
        gd = 0.0
        for i in range(n):
            g += st.normal[k, i] * x0[i]
            gd += st.normal[k, i] * x0[n + i]
        if g < 0.0:
            continue
        if st.law[k] != LAW_LINEAR:
            bad |= 1 << k
        elif st.kc[k] * g + st.cc[k] * gd > 0.0:
            mask |= 1 << k
    return mask, bad


#: the header of a packed shot (:func:`shoot`): its scalars, in this order, before the arrays
(H_STATUS, H_NIMP, H_SMIN, H_SMAX, H_NCHAT, H_STUCK, H_HELD_END, H_NTOT, H_GMAX, H_NSTEPS, H_TCON, H_NREL,
 H_NINEXACT, H_FINITE, H_HELD0, H_NEV, H_NAP, H_APEX) = range(18)
HEAD = 18


@njit(cache=True, error_model="numpy")
def shoot(sy, st, hs, cp, dd, Om, x0, held0, n_periods, settings, rec, J, rel, derivatives, scale):
    """``P^n(x0)``: the integrator's run of ``n_periods`` from phase 0 with its event log, then
    (``derivatives``) the tangent, in one compiled call, its outputs packed in two new arrays.

    ``held0 < 0``: start held where :func:`held_at_section` finds the state held, in contact with
    the compliant stops :func:`contact_at_section` finds.  ``rec``, ``J`` and ``rel`` are work
    buffers (:class:`~vibeam.models.core.integrator.Record` with an event and an apex log, the
    tangent ``[M | x_p]``, the releases); ``scale``: row value per unit of the output coordinate;
    ``settings``: the integrator's step cap and guards (:class:`ShotSettings`).

    Returns
    -------
    f : ndarray, shape (HEAD + ...,)
        The header (``H_STATUS ... H_APEX``: the run's scalars of
        :func:`vibeam.models.core.integrator.integrate_work`, ``s_min``/``s_max`` divided by ``scale``;
        ``n_rel``, ``n_inexact`` of :func:`tangent`, -1 without derivatives, after a failed run or
        a full log; ``finite``: every entry of the tangent is finite; ``held0``, the held mask the
        run started with; the events and apexes logged; the largest logged apex gap, ``-inf`` if
        none), then the final state (2n), the tangent (2n x (2n + P), row-major; unset without
        derivatives), the end state rebuilt by the tangent's flows (2n), the ``m`` impact times
        and normal velocities (divided by ``scale``), the event log (``e`` rows of ``LOG_HEAD +
        2n``), the apex log (``a`` rows of 3), the releases (``n_rel`` rows of ``2n + P + 1``).
        ``m``, ``e`` and ``a`` are the counts clipped to the buffers' capacities.
    i : ndarray of int64, shape (2 e + m,)
        The events' kinds and stops, the impacts' stops.
    """
    n = sy.k.shape[0]
    d = 2 * n
    xe = np.empty(d)
    rst = np.zeros(d)
    work = new_work(n, st.offset.shape[0], hs.valid.shape[0], Om, _ONE, _ONE, settings.h_cap, _FALSE)
    tw = tangent_work(n, st.offset.shape[0], hs.valid.shape[0], dd.dOm.shape[0])
    out, held0, n_rel, n_inexact, finite = _shot(sy, st, hs, cp, dd, Om, x0, held0, n_periods, settings, rec, J, rel,
                                                 derivatives, xe, rst, work, tw)
    return _pack(out, held0, n_rel, n_inexact, finite, xe, rst, rec, J, rel, derivatives, scale)


@njit(cache=True, error_model="numpy", inline="always")
def _start_row(st, dd, k, eta, etad, vfl, dfl, vr, row, ip0):
    """``v_in`` of a compliant contact a shot starts inside of (stop ``k``; :func:`~vibeam.models.core.
    laws.start_velocity`, at least the floor ``vfl``) into ``vr[k]``, and its tangent row ``row``
    (shape ``(2n + P,)``: partials in ``eta``, ``eta'`` and the parameters; the floor's ``dfl``)."""
    n = eta.shape[0]
    U = 0.0
    gk = -st.offset[k]
    for i in range(n):
        U += st.normal[k, i] * etad[i]
        gk += st.normal[k, i] * eta[i]
    v, vg, vU, vk = start_velocity(st.law[k], gk, U, st.kc[k], st.pe[k], 1.0 / st.m_eff[k])
    if v > vfl:
        vr[k] = v
        for i in range(n):
            row[i] = st.normal[k, i] * vg
            row[n + i] = st.normal[k, i] * vU
        for p in range(dfl.shape[0]):
            row[ip0 + p] = vk * dd.dkc[p, k] - vg * dd.dD[p, k]
    else:
        vr[k] = vfl
        for p in range(dfl.shape[0]):
            row[ip0 + p] = dfl[p]


@njit(cache=True, error_model="numpy", inline="always")
def _shot(sy, st, hs, cp, dd, Om, x0, held0, n_periods, settings, rec, J, rel, derivatives, xe, rst, work, tw):
    """The run and tangent of :func:`shoot` into the buffers (``xe``: the final state, shape (2n,);
    ``rst``: the rebuilt state; ``work``: the integrator's work arrays for a grid of one point per
    period at ``Om``, :func:`~vibeam.models.core.integrator.work_fits`;
    ``tw``: the tangent's, :func:`tangent_work`),
    without packing them: ``(out, held0, n_rel, n_inexact, finite)``, ``out`` the
    :class:`~vibeam.models.core.integrator.RunScalars` of
    :func:`vibeam.models.core.integrator.integrate_work`.  Inlined into its two callers (:func:`shoot`,
    :func:`correct_frequency`): numba links a compiled callee's code into each caller and optimises
    and emits it again there, so every compiled level between them and the integrator and tangent
    cost a cold continuation seconds (this one and the former Newton-only level without reference
    counting: a cold first continuation 51-53 -> 45-47 s, no measurable run-time difference)."""
    n = sy.k.shape[0]
    d = 2 * n
    ncol = J.shape[1]
    if held0 < 0:
        held0 = held_at_section(st, hs, x0, Om)
        if cp is not None:
            cm, _bad = contact_at_section(st, x0)
            held0 |= cm
    for i in range(d):
        xe[i] = x0[i]
    eta = xe[:n]
    etad = xe[n:]
    h_cap, max_impacts, max_steps, chatter_tol = settings
    if cp is None:
        out = scalars(integrate_work(sy, st, hs, None, Om, eta, etad, held0, _ZERO, n_periods, _ONE, _ONE, h_cap,
                                     max_impacts, max_steps, chatter_tol, rec, work))
    else:
        out = scalars(integrate_work(sy, st, hs, compliant_work(cp, st, n, rec), Om, eta, etad, held0, _ZERO,
                                     n_periods, _ONE, _ONE, h_cap, max_impacts, max_steps, chatter_tol, rec, work))
    n_rel = -1
    n_inexact = -1
    finite = _TRUE
    n_ev = rec.nlog[0]
    if derivatives and out.status != ST_FAILED and n_ev <= rec.evlog.shape[0]:
        n_rel, n_inexact = tangent(sy, st, hs, cp, dd, Om, rec.evlog, n_ev, held0, x0, xe, out.held_end,
                                   n_periods * TWO_PI / Om, J, rel, rst, tw)
        for i in range(d):
            for c in range(ncol):
                if not math.isfinite(J[i, c]):
                    finite = _FALSE
    return out, held0, n_rel, n_inexact, finite


@njit(cache=True, error_model="numpy")
def _pack(out, held0, n_rel, n_inexact, finite, xe, rst, rec, J, rel, derivatives, scale):
    """The two arrays of :func:`shoot` from a shot's buffers (:func:`_shot`)."""
    d = xe.shape[0]
    ncol = J.shape[1]
    n_ev = rec.nlog[0]
    n_ap = rec.nlog[1]
    m = min(out.n_imp_record, rec.imp_t.shape[0])
    e = min(n_ev, rec.evlog.shape[0])
    a = min(n_ap, rec.aplog.shape[0])
    r = max(n_rel, 0)
    w = rec.evlog.shape[1]
    f = np.empty(HEAD + 2 * d + d * ncol + 2 * m + e * w + 3 * a + r * (ncol + 1))
    f[H_STATUS] = out.status
    f[H_NIMP] = out.n_imp_record
    f[H_SMIN] = out.s_min / scale
    f[H_SMAX] = out.s_max / scale
    f[H_NCHAT] = out.n_chatter
    f[H_STUCK] = out.stuck_time
    f[H_HELD_END] = out.held_end
    f[H_NTOT] = out.n_imp_total
    f[H_GMAX] = out.gmax
    f[H_NSTEPS] = out.n_steps
    f[H_TCON] = out.contact_time
    f[H_NREL] = n_rel
    f[H_NINEXACT] = n_inexact
    f[H_FINITE] = 1.0 if finite else 0.0
    f[H_HELD0] = held0
    f[H_NEV] = n_ev
    f[H_NAP] = n_ap
    apex = -np.inf
    for j in range(a):
        apex = max(apex, rec.aplog[j, 1])
    f[H_APEX] = apex
    o = HEAD
    for i in range(d):
        f[o + i] = xe[i]
    o += d
    if derivatives:
        for i in range(d):
            for c in range(ncol):
                f[o + i * ncol + c] = J[i, c]
    o += d * ncol
    for i in range(d):
        f[o + i] = rst[i]
    o += d
    for j in range(m):
        f[o + j] = rec.imp_t[j]
        f[o + m + j] = rec.imp_v[j] / scale
    o += 2 * m
    for j in range(e):
        for c in range(w):
            f[o + j * w + c] = rec.evlog[j, c]
    o += e * w
    for j in range(a):
        for c in range(3):
            f[o + 3 * j + c] = rec.aplog[j, c]
    o += 3 * a
    for j in range(r):
        for c in range(ncol + 1):
            f[o + j * (ncol + 1) + c] = rel[j, c]
    iv = np.empty(2 * e + m, np.int64)
    for j in range(e):
        iv[j] = int(rec.evlog[j, 0])
        iv[e + j] = int(rec.evlog[j, 3])
    for j in range(m):
        iv[2 * e + j] = rec.imp_k[j]
    return f, iv


#: outcomes of :func:`correct_frequency`
(CORRECT_CONVERGED, CORRECT_LEFT, CORRECT_SINGULAR, CORRECT_NONFINITE, CORRECT_NO_CONVERGENCE,
 CORRECT_FALLBACK) = range(6)


@njit(cache=True, error_model="numpy")
def _bordered_step(M, xp, x_new, x, u, u_pred, t, sx, sp):
    """:func:`vibeam.models.core.continuation_kernels.corrector_step`, with a singular bordered matrix
    (numba's solve raises) as a flag: ``(|r|, |du|, u + du, |u + du - u_pred|, singular)``."""
    try:
        nr, ndu, un, dist = corrector_step(M, xp, x_new, x, u, u_pred, t, sx, sp)
    except Exception:       # noqa: BLE001 - numba raises LinAlgError for an exactly singular matrix
        return np.inf, np.inf, u, np.inf, True
    return nr, ndu, un, dist, False


@njit(cache=True, error_model="numpy")
def correct_frequency(sy, st, hs, cp, dd, factor, offset, col, u_pred, t, n_periods, sx, sp, newton, settings, rec, J,
                      rel, scale):
    """The pseudo-arclength corrector of :mod:`vibeam.models.orbits.continuation` in the forcing
    frequency, its Newton iterations and their shots (:func:`shoot`) in one compiled call.

    Solves ``P^n(x) - x = 0`` and ``t . (u - u_pred) = 0`` for ``u = (x / sx, p / sp)`` with
    ``Omega = offset + factor p``, by the bordered Newton step of
    :func:`vibeam.models.core.continuation_kernels.corrector_step`, stopping as the engine's own
    corrector does (``_Engine.correct``; the same iterates, to the last bit): converged when the
    residual ``|P^n(x) - x|_inf / sx <= tol`` (or ``<= 1e3 tol`` after a Newton step ``<= tol``),
    out of the neighbourhood ``radius`` of the predictor (``radius < 0``: none), singular, not
    finite, or after ``max_newton`` steps.

    Parameters
    ----------
    sy, st, hs, cp, dd :
        The system, stops, held sets, compliant data and parameter directions of the shots.
    factor, offset : float
        ``Omega = offset + factor p``.
    col : int
        The column of the directions that is ``d / d Omega``.
    u_pred, t : ndarray, shape (d + 1,)
        Predictor and tangent (scaled).
    n_periods : int
    sx, sp : float
        Scales of the state and the parameter.
    newton : NewtonSettings
        Tolerance and limits of the corrector (``tol, max_newton, radius``).
    settings, rec, J, rel, scale :
        As :func:`shoot`.

    Returns
    -------
    code : int
        :data:`CORRECT_CONVERGED` ... :data:`CORRECT_FALLBACK` (a shot that is not ``ok``, or a
        state or frequency out of range: the caller's own corrector takes over, from the start).
    it, n_shots : int
        The last iteration and the shots run.
    nr : float
        The last residual.
    u : ndarray, shape (d + 1,)
        The last iterate.
    f, iv : ndarray
        The last shot, packed (:func:`shoot`).
    mu, pd, ns : ndarray of complex, float, float
        The converged point's Floquet spectrum
        (:func:`vibeam.models.core.continuation_kernels.floquet_spectrum_small`; ``mu`` empty when not
        computed: not converged, ``d > SMALL_SPECTRUM`` or a LAPACK failure).
    tan : ndarray, shape (d + 1,) or (0,)
        The converged point's unit tangent oriented along ``t``
        (:func:`vibeam.models.core.continuation_kernels.bordered_tangent`; empty when not computed or
        not finite).  The engine's own calls of the two functions on the point give the same bits.
    """
    tol, max_newton, radius = newton
    h_cap = settings.h_cap
    d = u_pred.shape[0] - 1
    u = u_pred.copy()
    dist = 0.0
    nr = np.inf
    xp = np.empty(d)
    xe = np.empty(d)
    rst = np.zeros(d)
    n_shots = 0
    code = CORRECT_NO_CONVERGENCE
    it_out = max_newton
    # the last shot's outcome, packed once at the end (:func:`_pack`; the iterations' shots before
    # it only need the state and the tangent, which stay in the buffers)
    out = RunScalars(_ZERO, _ZERO, 0.0, 0.0, _ZERO, 0.0, _ZERO, _ZERO, 0.0, _ZERO, 0.0, _ZERO)
    held0 = 0
    n_rel = -1
    n_inexact = -1
    finite = _TRUE
    Om0 = offset + factor * u[d] * sp
    work = new_work(d // 2, st.offset.shape[0], hs.valid.shape[0], Om0 if math.isfinite(Om0) and Om0 > 0.0 else 1.0,
                    _ONE, _ONE, h_cap, _FALSE)
    tw = tangent_work(d // 2, st.offset.shape[0], hs.valid.shape[0], dd.dOm.shape[0])
    for it in range(max_newton + 1):
        x = u[:d] * sx
        p = u[d] * sp
        Om = offset + factor * p
        ok = math.isfinite(Om) and Om > 0.0
        for i in range(d):
            if not math.isfinite(x[i]):
                ok = False
        if ok and cp is not None:
            _cm, bad = contact_at_section(st, x)
            ok = bad == 0
        if not ok:
            code, it_out = CORRECT_FALLBACK, it
            break
        if not work_fits(work, Om, 1, h_cap):
            work = new_work(d // 2, st.offset.shape[0], hs.valid.shape[0], Om, _ONE, _ONE, h_cap, _FALSE)
        out, held0, n_rel, n_inexact, finite = _shot(sy, st, hs, cp, dd, Om, x, _MINUS_ONE, n_periods, settings, rec,
                                                     J, rel, _TRUE, xe, rst, work, tw)
        n_shots += 1
        if out.status == ST_FAILED or n_inexact != 0 or not finite:
            code, it_out = CORRECT_FALLBACK, it
            break
        for i in range(d):
            xp[i] = J[i, d + col] * factor
        nr, ndu, un, dist_new, singular = _bordered_step(J[:, :d], xp, xe, x, u, u_pred, t, sx, sp)
        if singular:
            code, it_out = CORRECT_SINGULAR, it
            break
        if nr <= tol or (nr <= 1e3 * tol and it > 0 and ndu <= tol):
            code, it_out = (CORRECT_LEFT if radius >= 0.0 and dist > radius else CORRECT_CONVERGED), it
            break
        if it == max_newton:
            break
        if not (nr < np.inf and ndu < np.inf):
            code, it_out = CORRECT_NONFINITE, it
            break
        u = un
        dist = dist_new
        if radius >= 0.0 and dist > 2.0 * radius:
            code, it_out = CORRECT_LEFT, it
            break
    mu = np.empty(0, np.complex128)
    pd = np.nan
    nsv = np.nan
    tan = np.empty(0)
    if n_shots == 0:
        return code, it_out, n_shots, nr, u, np.empty(0), np.empty(0, np.int64), mu, pd, nsv, tan
    if code == CORRECT_CONVERGED and d <= SMALL_SPECTRUM:
        # what the engine computes next at the point (its spectrum and tangent), in this call
        Mc = J[:, :d].copy()
        try:
            mu, pd, nsv = floquet_spectrum_small(Mc)
        except Exception:       # noqa: BLE001 - LAPACK's failure: the engine's own call reports it
            mu = np.empty(0, np.complex128)
        try:
            tn = bordered_tangent(Mc, xp, sx, sp, t)
            if np.isfinite(tn).all():
                tan = tn
        except Exception:       # noqa: BLE001 - a singular bordered matrix: the engine falls back
            pass
    f, iv = _pack(out, held0, n_rel, n_inexact, finite, xe, rst, rec, J, rel, _TRUE, scale)
    return code, it_out, n_shots, nr, u, f, iv, mu, pd, nsv, tan


# ============================================================================ the problem
def _shot_extra(f, iv, d, nc, n, n_imp, n_ev, n_ap, n_rel, n_inexact, held, held_end, n_chat, n_steps, t_con,
                tangent, ok, core, Om) -> dict:
    """A shot's ``extra`` from its packed arrays (:func:`shoot`; :meth:`ModalShooting.shot`)."""
    w = LOG_HEAD + d
    o = HEAD + 2 * d + d * nc + 2 * n_imp
    ev = f[o:o + n_ev * w].reshape(n_ev, w)
    o += n_ev * w
    cmask = core.compliant_mask
    ns = core.n_stops
    extra = dict(event_kinds=iv[:n_ev], event_times=ev[:, 1], event_stops=iv[n_ev:2 * n_ev], event_states=ev[:, 4:],
                 apexes=f[o:o + 3 * n_ap].reshape(n_ap, 3), n_chatter=int(n_chat), stuck_start=bool(held & ~cmask),
                 stuck_end=bool(held_end & ~cmask), n_steps=int(n_steps))
    o += 3 * n_ap
    if core.compliant is not None:
        extra.update(_contact_times(ev, held & cmask, held_end & cmask, ns, n * 2.0 * math.pi / Om))
        extra["contact_time"] = t_con
        extra["in_contact_end"] = bool(held_end & cmask)
        extra["rebuilt_state"] = f[HEAD + d + d * nc:HEAD + 2 * d + d * nc]
    if ns > 1:
        extra["impact_stops"] = iv[2 * n_ev:]
    if tangent:
        extra["x_all_p"] = f[HEAD + d:HEAD + d + d * nc].reshape(d, nc)[:, d:]
        rl = f[o:o + n_rel * (nc + 1)].reshape(n_rel, nc + 1)
        extra["release_times"] = rl[:, 0]
        extra["release_time_derivatives"] = rl[:, 1:]
    if ok:
        extra["n_inexact"] = max(n_inexact, 0)
    return extra


class LazyExtra(MutableMapping):
    """A shot's ``extra`` dict, built on first use (most shots of a Newton iteration are read only
    for ``x``, ``M`` and ``x_p``): ``make(*args)`` returns the dict; a mapping like it otherwise."""

    __slots__ = ("_d", "_make", "_args")

    def __init__(self, make, args=()):
        self._d = None
        self._make = make
        self._args = args

    def _dict(self) -> dict:
        if self._d is None:
            self._d = self._make(*self._args)
            self._make = self._args = None
        return self._d

    def __getitem__(self, key):
        return self._dict()[key]

    def __setitem__(self, key, value):
        self._dict()[key] = value

    def __delitem__(self, key):
        del self._dict()[key]

    def __iter__(self):
        return iter(self._dict())

    def __len__(self):
        return len(self._dict())

    def __contains__(self, key):
        return key in self._dict()

    def get(self, key, default=None):
        return self._dict().get(key, default)

    def __repr__(self):
        return repr(self._dict())


class Setup(NamedTuple):
    """What a fidelity's shooting problem gives the one shot at a parameter value.

    Attributes
    ----------
    core : EventIntegrator
        The model at the value (system, stops, held sets).
    Omega : float
        Forcing frequency.
    dirs : Directions
        Its native parameters' directions (:func:`directions`), in a fixed order.
    gap : float
        ``Delta`` of the output coordinate (``Q = gap - q_min``).
    scale : float
        Row value per unit of ``q`` (:attr:`vibeam.models.system.ModalSystem.coordinate_scale`).
    """

    core: object
    Omega: float
    dirs: Directions
    gap: float
    scale: float


class ModalShooting:
    """``P^n`` of a modal system with impulsive stops (contract of :mod:`vibeam.models.core.periodic`).

    The fidelities' problems subclass it and provide :meth:`setup` (the model, its directions
    and scales at a parameter value), ``parameter``, ``value`` and ``index`` (the continuation
    parameter's column among the directions); everything else -- the run, the derivatives, the
    events, the section held on a stop -- is here once.

    Parameters
    ----------
    chatter_tol, steps_per_fundamental, max_impacts_per_period, max_steps_per_period :
        Settings of the event integrator, as the fidelity's ``event`` solver (same defaults, so
        that a stable fixed point is what a sweep lands on).
    """

    #: events, apexes and impacts a shot may log before its buffers grow
    _CAP = 64

    def __init__(self, chatter_tol: float = 1e-7, steps_per_fundamental: int = 16,
                 max_impacts_per_period: int = 20000, max_steps_per_period: int = 20000):
        self.chatter_tol = float(chatter_tol)
        self.steps_per_fundamental = int(steps_per_fundamental)
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.max_steps_per_period = int(max_steps_per_period)
        self._cap = self._CAP
        self._capa = self._CAP
        self._capi = self._CAP
        self._bufs = {}
        self._entry = None
        self._correct_entry = None
        self._correct_args = None

    def setup(self, p: float) -> Setup:      # pragma: no cover - the fidelities' own
        raise NotImplementedError

    # ------------------------------------------------------------------ the shot
    def shot(self, x0, p: float, n: int = 1, derivatives: bool = True, stuck=None) -> "Shot":
        """``P^n(x0; p)`` with its monodromy, ``d x / d p``, events and test values.

        Parameters
        ----------
        x0 : array_like, shape (2n,)
            ``(eta, eta')`` at forcing phase 0.
        p : float
            Value of the parameter (native units).
        n : int, optional
            Number of forcing periods.
        derivatives : bool, optional
            Assemble ``M`` and ``x_p`` (False: NaN arrays, the cost of the run alone).
        stuck : bool, int or None, optional
            Start held: True on the stops the state lies on, an int: that bit mask of stops;
            None: where :func:`held_at_section` finds the state held.

        Returns
        -------
        Shot
            ``x``, ``M``, ``x_p``, ``impact_times`` (from the section), ``impact_velocities``
            (normal ``U- `` in units of ``q'``), ``q_min``/``q_max`` (exact extremes of the output
            coordinate), ``apex_gap`` (row units: the largest gap at an interior free-flight
            maximum of any stop's gap), ``stuck_time``, ``status`` (``ok``, ``chatter``,
            ``failed``), ``Omega``, ``gap`` and ``extra``: ``x_all_p`` (2n, P) along every native
            parameter, ``event_kinds``, ``event_times``, ``event_stops``, ``event_states``,
            ``apexes`` (k, 3: time, gap, stop), ``impact_stops``, ``n_chatter``, ``stuck_start``,
            ``stuck_end``, ``n_steps``, ``release_times``, ``release_time_derivatives``,
            ``n_inexact``.
        """
        n = int(n)
        d = int(self.dim)
        x0 = np.ascontiguousarray(x0, dtype=float).reshape(-1)
        bad = self.invalid(float(p)) if math.isfinite(p) else f"the parameter must be finite, got {p}"
        if x0.shape != (d,) or not all(map(math.isfinite, x0.tolist())) or n < 1 or bad:
            nanM = np.full((d, d), np.nan)
            nanv = np.full(d, np.nan)
            msg = bad or f"x0 must be finite with shape ({d},) and n >= 1; got shape {x0.shape}, n = {n}"
            return Shot(x=nanv, M=nanM, x_p=nanv, impact_times=np.zeros(0), impact_velocities=np.zeros(0),
                        q_min=np.nan, q_max=np.nan, status="failed", message=msg)
        set_ = self.setup(p)
        core = set_.core
        N = core.n
        Om = set_.Omega
        if stuck is None:
            held = -1
        elif stuck is True:
            held = int(held_at_section(core.kstops, core.held, np.concatenate([x0[:N], np.zeros(N)]), Om))
        else:
            held = int(stuck)
        cp = core.compliant
        if cp is not None and held < 0:
            _cm, bad = contact_at_section(core.kstops, x0)
            if bad:
                k = int(bad).bit_length() - 1
                return self._failed(d, f"the section lies inside the stop {k} of a "
                                       f"{getattr(core.stops[k].law, 'name', 'compliant')} law: its contact "
                                       f"depends on its entry velocity, which is not part of the state")
        while True:
            rec, J, rel = self._buffers(set_, n)
            args = (core.ksys, core.kstops, core.held, cp, set_.dirs, float(Om), x0, held, n,
                    self._settings(core, n), rec, J, rel, bool(derivatives), float(set_.scale))
            kinds = _phase_kinds(cp)
            if self._entry is None or self._entry[0] != kinds:
                f, iv = _call_shoot(args)
                self._entry = (kinds, _ENTRY.get("shoot")) if _ENTRY.get("shoot") is not None else None
            else:
                # the same argument types every call of this problem (the kinds of contact phase of
                # its compliant data included): its compiled entry point
                f, iv = self._entry[1](*args)
            if self._fits(f):
                return self._unpack(set_, f, iv, n, derivatives)

    def _settings(self, core, n: int) -> ShotSettings:
        """The integrator's step cap and guards of a shot of ``n`` periods."""
        return shot_settings(2.0 * math.pi / core.lowest_omega / self.steps_per_fundamental,
                             self.max_impacts_per_period * n, self.max_steps_per_period * n, self.chatter_tol)

    def _buffers(self, set_: Setup, n: int):
        """The work buffers of a shot of ``n`` periods: a :class:`Record` with event and apex logs,
        the tangent, the releases (kept between shots; :meth:`_fits` grows them)."""
        core = set_.core
        P = set_.dirs.dOm.shape[0]
        key = (n, core.n, core.n_stops, P)
        bufs = self._bufs.get(key)
        if bufs is None:
            d = 2 * core.n
            bufs = self._bufs[key] = (new_record(core.n, core.n_stops, n, 1, self._capi, False, self._cap, self._capa,
                                                 compliant=core.compliant is not None),
                                      np.empty((d, d + P)), np.zeros((self._cap, d + P + 1)))
        return bufs

    def _fits(self, f) -> bool:
        """Whether a packed shot's events, apexes and impacts fitted the buffers (else they grow,
        and the shot is to be run again)."""
        n_imp, n_ev, n_ap = int(f[H_NIMP]), int(f[H_NEV]), int(f[H_NAP])
        if n_ev <= self._cap and n_ap <= self._capa and n_imp <= self._capi:
            return True
        self._cap = max(self._cap, n_ev + 16)
        self._capa = max(self._capa, n_ap + 16)
        self._capi = max(self._capi, n_imp + 16)
        self._bufs.clear()
        self._correct_args = None
        return False

    def _unpack(self, set_: Setup, f, iv, n: int, derivatives: bool) -> Shot:
        """The :class:`Shot` of a packed shot (:func:`shoot`): its arrays are views of ``f`` and
        ``iv``; the events, apexes and releases go to ``extra``, built on first use."""
        core = set_.core
        Om = set_.Omega
        d = 2 * core.n
        nc = d + set_.dirs.dOm.shape[0]
        (status, n_imp, smin, smax, n_chat, stuck_time, held_end, n_tot, gmax, n_steps, t_con, n_rel, n_inexact,
         finite, held, n_ev, n_ap, apex) = f[:HEAD].tolist()
        n_imp, n_ev, n_ap = int(n_imp), int(n_ev), int(n_ap)
        held, held_end, n_rel, n_inexact = int(held), int(held_end), int(n_rel), int(n_inexact)
        o = HEAD + 2 * d + d * nc
        extra = LazyExtra(_shot_extra, (f, iv, d, nc, n, n_imp, n_ev, n_ap, n_rel, n_inexact, held, held_end, n_chat,
                                        n_steps, t_con, status != ST_FAILED and derivatives, status != ST_FAILED,
                                        core, Om))
        it = f[o:o + n_imp]
        iv_ = f[o + n_imp:o + 2 * n_imp]
        x = f[HEAD:HEAD + d]
        if status == ST_FAILED:
            return Shot(x=x, M=np.full((d, d), np.nan), x_p=np.full(d, np.nan), impact_times=it, impact_velocities=iv_,
                        q_min=smin, q_max=smax, stuck_time=stuck_time, status="failed", Omega=Om, gap=set_.gap,
                        message=(f"the event integrator gave up after {int(n_tot)} impacts / {int(n_steps)} steps in "
                                 f"{n} period(s) (non-accumulating chatter or step collapse)"), extra=extra)
        if not derivatives:
            M, xp = np.full((d, d), np.nan), np.full(d, np.nan)
        else:
            Jc = f[HEAD + d:HEAD + d + d * nc].reshape(d, nc)
            M = Jc[:, :d]
            xp = Jc[:, d + self.column]
        st, msg = "ok", ""
        if derivatives and n_inexact == -1:
            st = "failed"
            msg = ("re-entry inside the stop after a damping-factor exit (the contact depends on the previous "
                   "contact's entry velocity): not represented")
        elif derivatives and n_inexact == -2:
            st = "failed"
            msg = "the variational equations of a contact phase could not be integrated (step size underflow)"
        elif n_inexact > 0:
            st = "chatter"
            msg = (f"{n_inexact} event(s) without an exact derivative (release forced at the end of a chatter "
                   f"hold, or entry into sticking at zero velocity)")
        elif derivatives and not finite:
            st = "failed"
            msg = "grazing impact (zero impact velocity): the monodromy is singular"
        return Shot(x=x, M=M, x_p=xp, impact_times=it, impact_velocities=iv_, q_min=smin, q_max=smax, apex_gap=apex,
                    stuck_time=stuck_time, status=st, message=msg, extra=extra, Omega=Om, gap=set_.gap)

    # ------------------------------------------------------------------ the corrector, compiled
    def frequency_corrector(self) -> bool:
        """Whether :meth:`correct` serves this problem: a continuation in the forcing frequency
        (``parameter == "Omega"``), whose system does not change along the branch (a fidelity
        may refuse it where its validity depends on more than ``Omega > 0``)."""
        return getattr(self, "parameter", None) == "Omega"

    def correct(self, u_pred, t, n: int, sx: float, sp: float, tol: float, max_newton: int, radius,
                factor: float = 1.0, offset: float = 0.0):
        """The pseudo-arclength corrector of :mod:`vibeam.models.orbits.continuation` in one compiled call
        (:func:`correct_frequency`): ``F(x, p) = P^n(x) - x = 0`` and ``t . (u - u_pred) = 0`` in the
        scaled variables ``u = (x / sx, p / sp)``, ``Omega = offset + factor p``.

        Returns
        -------
        None
            Not served here (:meth:`frequency_corrector` false), or a shot of the iteration was not
            ``ok`` or not of the problem's range: the caller runs its own corrector (which meets
            the same iterates, one :meth:`shot` at a time, and reports what stopped it).
        tuple
            ``(code, it, u, x, p, nr, shot, n_shots, pre)``: the outcome (:data:`CORRECT_CONVERGED`,
            ``..._LEFT``, ``..._SINGULAR``, ``..._NONFINITE``, ``..._NO_CONVERGENCE``), the last
            iteration, its scaled point, state and parameter, its residual ``|P^n(x) - x|_inf / sx``,
            the converged point's :class:`Shot` (``x_p`` along ``p``; None otherwise), the shots
            run and ``(spectrum, tangent)`` of the converged point (``(mu, det(M + I), max |mu| -
            1)`` and the unit tangent along ``t``; each None where not computed).
        """
        if not self.frequency_corrector():
            return None
        d = int(self.dim)
        u_pred = np.ascontiguousarray(u_pred, dtype=float)
        p0 = float(offset + factor * float(u_pred[d] * sp))
        if not math.isfinite(p0) or self.invalid(p0) or n < 1:
            return None
        set_ = self.setup(p0)
        core = set_.core
        mid = (float(factor), float(offset), int(self.column), u_pred, np.ascontiguousarray(t, dtype=float), n,
               float(sx), float(sp), newton_settings(tol, max_newton, radius))
        while True:
            c = self._correct_args
            if c is None or c[0] is not core or c[1] != n:
                # the arguments that stay along a branch (the cache holds the core: its id stays its own)
                rec, J, rel = self._buffers(set_, n)
                c = self._correct_args = (core, n, (core.ksys, core.kstops, core.held, core.compliant, set_.dirs),
                                          (self._settings(core, n), rec, J, rel, float(set_.scale)))
            args = c[2] + mid + c[3]
            kinds = _phase_kinds(core.compliant)
            if self._correct_entry is None or self._correct_entry[0] != kinds:
                out = _call_correct(args)
                self._correct_entry = (kinds, _ENTRY.get("correct")) if _ENTRY.get("correct") is not None else None
            else:
                out = self._correct_entry[1](*args)
            code, it, n_shots, nr, u, f, iv, mu, pd, nsv, tan = out
            if code == CORRECT_FALLBACK:
                return None
            if self._fits(f):
                break
        x = u[:d] * sx
        p = u[d] * sp
        shot = None
        if code == CORRECT_CONVERGED:
            # the setup at the point: the same system, its frequency (:meth:`setup` for Omega = p)
            shot = self._unpack(Setup(core, float(offset + factor * p), set_.dirs, set_.gap, set_.scale), f, iv, n, True)
            if factor != 1.0:
                shot.x_p = shot.x_p * factor
        pre = ((mu, float(pd), float(nsv)) if mu.shape[0] else None, tan if tan.shape[0] else None)
        return int(code), int(it), u, x, p, float(nr), shot, int(n_shots), pre

    def compile_corrector_ahead(self, p: float, n: int = 1, before_start: bool = False) -> bool:
        """Compile :func:`correct_frequency` (and the :func:`tangent` it shares with the shots, and
        its own callees: the bordered Newton step, the small Floquet spectrum, the bordered tangent)
        for this problem's argument types in a second process while this one compiles the start and
        the shots (:mod:`vibeam.models.core.ahead`); the corrector's first call (:meth:`correct`)
        waits for it.

        A continuation calls it once its start is found (:class:`vibeam.models.orbits.continuation`'s
        engine); a caller that knows it will continue may call it before the start too
        (``before_start``): the child then compiles the tangent and the corrector's callees at once
        and the corrector only after the second call, when the integrator is compiled and cached (the child loads it
        instead of compiling it a second time).

        Parameters
        ----------
        p : float
            A value of the parameter (native units) at which :meth:`setup` builds the arguments
            (only their types matter).
        n : int, optional
            Periods of the shots (the buffers' sizes do not change the types).
        before_start : bool, optional
            The first of two calls (above).

        Returns
        -------
        bool
            Whether a child compiles them (False: not served by :meth:`correct`, already compiled
            or cached, or compiling ahead is off: :func:`vibeam.models.core.ahead.enabled`).
        """
        if correct_frequency in ahead.pending():
            ahead.proceed(correct_frequency)
            return True
        try:
            if not self.frequency_corrector() or self.invalid(float(p)) or not ahead.enabled():
                return False
            set_ = self.setup(float(p))
            core = set_.core
            d = int(self.dim)
            N = d // 2
            rec, J, rel = self._buffers(set_, int(n))
            u = np.zeros(d + 1)
            x = np.zeros(d)
            sys_ = (core.ksys, core.kstops, core.held, core.compliant, set_.dirs)
            tw = tangent_work.py_func(N, core.kstops.offset.shape[0], core.held.valid.shape[0],
                                      set_.dirs.dOm.shape[0])
            # the types of _shot's call of the tangent and of the continuation's corrector calls
            t_args = sys_ + (1.0, rec.evlog, np.int64(0), np.int64(0), x, x.copy(), np.int64(0), 1.0, J, rel,
                             np.zeros(d), tw)
            c_args = (sys_ + (1.0, 0.0, int(self.column), u, u.copy(), int(n), 1.0, 1.0,
                              newton_settings(1e-10, 1, -1.0), shot_settings(1.0, 1, 1, self.chatter_tol), rec, J,
                              rel, float(set_.scale)))
            M = np.zeros((d, d))
            # the corrector's callees that do not call the integrator: before the gate too
            own = [(_bordered_step, (J[:, :d], x, x, x, u, u, u, 1.0, 1.0)), (floquet_spectrum_small, (M,)),
                   (bordered_tangent, (M, x, 1.0, 1.0, u))]
            gate = [ahead.GATE] if before_start else []
            return ahead.start([(tangent, t_args)] + own + gate + [(correct_frequency, c_args)])
        except Exception:       # only a head start: the corrector compiles at its first call anyway
            return False

    def invalid(self, p: float) -> str:
        """Why ``p`` is not a value of the parameter ('' if it is)."""
        return ""

    @property
    def column(self) -> int:
        """The continuation parameter's column among the directions of :meth:`setup`."""
        return self.index

    @staticmethod
    def _failed(d: int, message: str) -> Shot:
        nan = np.full(d, np.nan)
        return Shot(x=nan, M=np.full((d, d), np.nan), x_p=nan.copy(), impact_times=np.zeros(0),
                    impact_velocities=np.zeros(0), q_min=np.nan, q_max=np.nan, status="failed", message=message)


def _contact_times(ev, c0, c1, ns, t_end) -> dict:
    """Time in contact of each compliant stop over a shot, from its event log (entries and exits;
    ``c0``, ``c1`` the masks in contact at the start and the end): ``contact_time_upper`` (stop 0),
    ``contact_time_lower`` (stop 1), ``contact_times`` (n_s,)."""
    out = np.zeros(ns)
    start = np.full(ns, np.nan)
    for k in range(ns):
        if c0 >> k & 1:
            start[k] = 0.0
    for kind, t, k in zip(ev[:, 0].astype(int), ev[:, 1], ev[:, 3].astype(int)):
        if kind == EV_ENTRY:
            start[k] = t
        elif kind == EV_EXIT and np.isfinite(start[k]):
            out[k] += t - start[k]
            start[k] = np.nan
    for k in range(ns):
        if c1 >> k & 1 and np.isfinite(start[k]):
            out[k] += t_end - start[k]
    return {"contact_times": out, "contact_time_upper": float(out[0]),
            "contact_time_lower": float(out[1]) if ns > 1 else 0.0}



_ENTRY = {}


def _phase_kinds(cp):
    """Which kinds of contact phase the compliant data ``cp`` compiles (None: Newton stops only;
    else whether its linear phases and its tableau are None,
    :class:`vibeam.models.core.phases.Compliant`): a problem keeps its compiled entry points only
    for calls of the same kinds, another kind being another specialisation."""
    return None if cp is None else (cp.lin is None, cp.itab is None)


def _call_correct(args):
    """:func:`correct_frequency` through its compiled entry point (as :func:`_call_shoot`)."""
    from .event import compiled_call, entry_point
    ahead.wait(correct_frequency, args)     # compiled by a child of :meth:`compile_corrector_ahead`
    out = compiled_call(correct_frequency, args)
    _ENTRY["correct"] = entry_point(correct_frequency, args)
    return out


def _call_shoot(args):
    """:func:`shoot` through its compiled entry point (no per-call type resolution of the
    NamedTuple arguments; :func:`vibeam.models.core.event.compiled_call`), which is kept for the
    problem's later shots."""
    from .event import compiled_call, entry_point
    out = compiled_call(shoot, args)
    _ENTRY["shoot"] = entry_point(shoot, args)
    return out
