"""The tangent of the compliant contact phases: what the shooting problem's derivatives need of them.

The shooting problem (:mod:`vibeam.models.core.shooting`) carries ``J = d x(t) / d(x0, p)`` along a
run of the event integrator from its event log.  Besides the free and held flows and the Newton
events, a compliant contact phase contributes (Leine & Nijmeijer 2004, Ch. 7; Hiskens & Pai 2000):

linear (Kelvin-Voigt) phase ``q`` (:mod:`vibeam.models.core.phases`)
    exact: ``x(t_b) = z_e + T w_p(t_b) + T Phi(s) (Ti (x(t_a) - z_e) - w_p(t_a))``, so
    ``J <- T Phi Ti J`` and, for a parameter, ``+ dz_e + T dw_p(t_b) - T Phi (Ti dz_e + dw_p(t_a))``
    (``w_p`` the oscillators' forced response, its derivatives in the forcing frequency and
    amplitude in closed form; ``z_e`` the equilibrium, moved by the stops' offsets);
Runge-Kutta phase
    the variational equations ``J' = A(t) J + b_p(t)`` integrated with the state by the same
    embedded pair (:mod:`vibeam.models.core.rk`), ``A`` the Jacobian of the field with the law's
    partials (:func:`vibeam.models.core.laws.force_partials`) and ``b_p`` the field's parameter
    derivatives, including the dependence of a hysteretic-Hertz contact's force on its entry
    velocity ``v_in`` (a row ``dvr`` of the tangent, fixed at the entry);
the contact forces in the accelerations of the Newton events and releases (:func:`contact_accel`).

References
----------
R. I. Leine, H. Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, Springer
2004, Ch. 7; I. A. Hiskens, M. A. Pai, IEEE TCAS-I 47 (2000) 204-220; E. Hairer, S. P. Norsett,
G. Wanner, *Solving Ordinary Differential Equations I*, Sec. I.14 (variational equations).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..contact import LAW_LINEAR
from ..system import transition_entries
from .laws import RTOL, force, force_partials

__all__ = ["pair_particular", "flow_linear", "flow_rk", "contact_accel", "contact_damping", "YTOL"]

#: error tolerance of each tangent column of a Runge-Kutta contact phase, relative to the column's
#: largest entry or absolute below 1 (the state's own tolerance is the phase's,
#: :data:`vibeam.models.core.laws.RTOL`)
YTOL = 1e-10


@njit(cache=True, error_model="numpy")
def pair_particular(ph, q, Om, F, dF, dOm, ZX, ZY, dZX, dZY):
    """Forced response of the oscillators of linear phase ``q`` (complex amplitudes ``ZX``, ``ZY``,
    shape (m,): ``x_p = Im(ZX e^{i Om t})``) and its derivatives along ``P`` parameter directions
    (``dZX``, ``dZY``, shape (P, m)): ``Z = M^-1 f F``, ``M = i Om - A_j``, ``dZ = M^-1 f dF - i dOm
    M^-1 Z``."""
    P = dF.shape[0]
    for j in range(ph.m[q]):
        c = 2.0 * ph.mp[q, j, 0]
        k = ph.mp[q, j, 1]
        det = complex(k - Om * Om, c * Om)
        fx = ph.fx[q, j]
        fy = ph.fy[q, j]
        ux = (complex(c, Om) * fx + fy) / det        # M^-1 f (per unit F)
        uy = (-k * fx + complex(0.0, Om) * fy) / det
        ZX[j] = ux * F
        ZY[j] = uy * F
        vx = (complex(c, Om) * ZX[j] + ZY[j]) / det  # M^-1 Z
        vy = (-k * ZX[j] + complex(0.0, Om) * ZY[j]) / det
        for p in range(P):
            dZX[p, j] = ux * dF[p] - complex(0.0, dOm[p]) * vx
            dZY[p, j] = uy * dF[p] - complex(0.0, dOm[p]) * vy


@njit(cache=True, error_model="numpy")
def _dwp(t, Om, Z, dZ, dOm):
    """``d/dp Im(Z e^{i Om t})`` at fixed ``t``."""
    e = complex(math.cos(Om * t), math.sin(Om * t))
    return ((dZ + Z * complex(0.0, t * dOm)) * e).imag


@njit(cache=True, error_model="numpy")
def flow_linear(J, ta, tb, q, ph, Om, ZX, ZY, dZX, dZY, dze, dOm, W):
    """Tangent of linear phase ``q`` from ``ta`` to ``tb`` (absolute times), in place.

    ``J`` (2n, 2n + P): rows ``eta``, ``eta'``, the last ``P`` columns ``d/dp``; ``dze`` (P, Q, 2n)
    the equilibria's parameter derivatives; ``W`` (2n, 2n + P) a work array."""
    n2, ncol = J.shape
    P = dOm.shape[0]
    ip0 = ncol - P
    m = ph.m[q]
    s = tb - ta
    for c in range(ncol):
        for j in range(m):
            wx = 0.0
            wy = 0.0
            for i in range(n2):
                wx += ph.Tix[q, j, i] * J[i, c]
                wy += ph.Tiy[q, j, i] * J[i, c]
            W[j, c] = wx
            W[m + j, c] = wy
    for p in range(P):
        for j in range(m):
            wx = 0.0
            wy = 0.0
            for i in range(n2):
                wx += ph.Tix[q, j, i] * dze[p, q, i]
                wy += ph.Tiy[q, j, i] * dze[p, q, i]
            W[j, ip0 + p] -= wx + _dwp(ta, Om, ZX[j], dZX[p, j], dOm[p])
            W[m + j, ip0 + p] -= wy + _dwp(ta, Om, ZY[j], dZY[p, j], dOm[p])
    for j in range(m):
        t11, t12, t21, t22 = transition_entries(s, ph.mp[q, j, 0], ph.mp[q, j, 1], int(ph.mp[q, j, 2]),
                                                ph.mp[q, j, 3], ph.mp[q, j, 4], ph.mp[q, j, 5])
        for c in range(ncol):
            u = W[j, c]
            v = W[m + j, c]
            W[j, c] = t11 * u + t12 * v
            W[m + j, c] = t21 * u + t22 * v
    for p in range(P):
        for j in range(m):
            W[j, ip0 + p] += _dwp(tb, Om, ZX[j], dZX[p, j], dOm[p])
            W[m + j, ip0 + p] += _dwp(tb, Om, ZY[j], dZY[p, j], dOm[p])
    for c in range(ncol):
        for i in range(n2):
            r = dze[c - ip0, q, i] if c >= ip0 else 0.0
            for j in range(m):
                r += ph.Tx[q, i, j] * W[j, c] + ph.Ty[q, i, j] * W[m + j, c]
            J[i, c] = r


@njit(cache=True, error_model="numpy")
def contact_accel(H, C, eta, etad, st, hs, vr, out):
    """Subtract the contact forces of the compliant stops in ``C`` from an acceleration ``out``
    (shape (n,)) of the flow held on ``H``: ``- n_k f_k`` free, ``- Psi Psi^T n_k f_k`` held."""
    n = eta.shape[0]
    for k in range(st.offset.shape[0]):
        if (C >> k) & 1 == 0:
            continue
        g = -st.offset[k]
        gd = 0.0
        for i in range(n):
            g += st.normal[k, i] * eta[i]
            gd += st.normal[k, i] * etad[i]
        f = force(st.law[k], g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k])
        if H == 0:
            for i in range(n):
                out[i] -= st.normal[k, i] * f
        else:
            for i in range(n):
                out[i] -= hs.dirn[H, k, i] * f


@njit(cache=True, error_model="numpy")
def contact_damping(H, C, eta, etad, st, hs, vr, d, out):
    """Add ``sum_k n_k (df_k/dg') (n_k^T d)`` (projected on the held constraints) to ``out``: the
    compliant stops' damping applied to a velocity jump ``d`` (the saltation of a Newton impact
    during a contact phase)."""
    n = eta.shape[0]
    for k in range(st.offset.shape[0]):
        if (C >> k) & 1 == 0:
            continue
        g = -st.offset[k]
        gd = 0.0
        nd = 0.0
        for i in range(n):
            g += st.normal[k, i] * eta[i]
            gd += st.normal[k, i] * etad[i]
            nd += st.normal[k, i] * d[i]
        _fg, fgd, _fv = force_partials(st.law[k], g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k])
        for i in range(n):
            out[i] += (st.normal[k, i] if H == 0 else hs.dirn[H, k, i]) * fgd * nd


@njit(cache=True, error_model="numpy")
def _var_rhs(t, y, Y, H, C, Om, F, dF, sy, st, hs, dd, vr, dvr, out, dY, m, ip0):
    """Field of the state ``y`` (2m) and of its tangent ``Y`` (2m, ncol) in a contact phase
    (coordinates ``eta`` free, ``zeta`` held on ``H``), at absolute time ``t``."""
    n = sy.k.shape[0]
    ns = st.offset.shape[0]
    ncol = Y.shape[1]
    P = dF.shape[0]
    sn = math.sin(Om * t)
    cs = math.cos(Om * t)
    for j in range(m):
        out[j] = y[m + j]
        if H == 0:
            out[m + j] = sy.gam[j] * F * sn - sy.c[j] * y[m + j] - sy.k[j] * y[j]
        else:
            out[m + j] = hs.gam[H, j] * F * sn - hs.c[H, j] * y[m + j] - hs.nu2[H, j] * (y[j] - hs.e[H, j])
        for c in range(ncol):
            dY[j, c] = Y[m + j, c]
            if H == 0:
                dY[m + j, c] = -sy.c[j] * Y[m + j, c] - sy.k[j] * Y[j, c]
            else:
                dY[m + j, c] = -hs.c[H, j] * Y[m + j, c] - hs.nu2[H, j] * Y[j, c]
        for p in range(P):
            if H == 0:
                dY[m + j, ip0 + p] += (sy.gam[j] * (dF[p] * sn + F * t * cs * dd.dOm[p]) - dd.dc[p, j] * y[m + j])
            else:
                dY[m + j, ip0 + p] += (hs.gam[H, j] * (dF[p] * sn + F * t * cs * dd.dOm[p])
                                       - dd.dcC[p, H, j] * y[m + j] + hs.nu2[H, j] * dd.de[p, H, j])
    for k in range(ns):
        if (C >> k) & 1 == 0:
            continue
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
        code = st.law[k]
        f = force(code, g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k])
        fg, fgd, fv = force_partials(code, g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k])
        # df/dkc and df/dcc
        fk = f / st.kc[k] if st.kc[k] != 0.0 else 0.0
        if code == LAW_LINEAR:
            fc = gd
        else:
            fc = (st.kc[k] * g ** st.pe[k] * gd / vr[k]) if g > 0.0 else 0.0
        for j in range(m):
            w = st.normal[k, j] if H == 0 else hs.pG[H, k, j]
            out[m + j] -= w * f
        for c in range(ncol):
            dg = 0.0
            dgd = 0.0
            for j in range(m):
                w = st.normal[k, j] if H == 0 else hs.pG[H, k, j]
                dg += w * Y[j, c]
                dgd += w * Y[m + j, c]
            df = fg * dg + fgd * dgd + fv * dvr[k, c]
            if c >= ip0:
                p = c - ip0
                dgp = -dd.dD[p, k]
                if H != 0:
                    for i in range(n):
                        dgp += st.normal[k, i] * dd.deta_c[p, H, i]
                df += fg * dgp + fk * dd.dkc[p, k] + fc * dd.dcc[p, k]
            for j in range(m):
                w = st.normal[k, j] if H == 0 else hs.pG[H, k, j]
                dY[m + j, c] -= w * df


@njit(cache=True, error_model="numpy")
def flow_rk(J, ta, tb, eta, etad, H, C, Om, F, dF, sy, st, hs, dd, vr, dvr, tab, rk, out_state):
    """Tangent (and state) of a Runge-Kutta contact phase from ``ta`` to ``tb`` (absolute times),
    from the state ``(eta, eta')`` at ``ta``; ``J`` updated in place, the state at ``tb`` into
    ``out_state`` (2n).  ``rk`` (4,): the phase's step control (:func:`vibeam.models.core.contact_phase.rk_scales`).

    Returns
    -------
    bool
        False if the step size underflowed.
    """
    n = sy.k.shape[0]
    n2, ncol = J.shape
    P = dF.shape[0]
    ip0 = ncol - P
    m = n if H == 0 else hs.nc[H]
    S = tab.c.shape[0]
    y = np.empty(2 * m)
    Y = np.empty((2 * m, ncol))
    if H == 0:
        for i in range(n):
            y[i] = eta[i]
            y[n + i] = etad[i]
        for i in range(n2):
            for c in range(ncol):
                Y[i, c] = J[i, c]
    else:
        for j in range(m):
            z = 0.0
            zd = 0.0
            for i in range(n):
                z += hs.Psi[H, i, j] * (eta[i] - hs.eta_c[H, i])
                zd += hs.Psi[H, i, j] * etad[i]
            y[j] = z
            y[m + j] = zd
            for c in range(ncol):
                a = 0.0
                b = 0.0
                for i in range(n):
                    a += hs.Psi[H, i, j] * J[i, c]
                    b += hs.Psi[H, i, j] * J[n + i, c]
                Y[j, c] = a
                Y[m + j, c] = b
    K = np.empty((S, 2 * m))
    KY = np.empty((S, 2 * m, ncol))
    ys = np.empty(2 * m)
    Ys = np.empty((2 * m, ncol))
    y1 = np.empty(2 * m)
    Y1 = np.empty((2 * m, ncol))
    t = ta
    h = rk[0]
    guard = 0
    while tb - t > 1e-15 * max(abs(tb), 1.0):
        guard += 1
        if guard > 10_000_000:
            return False
        hs_ = min(h, tb - t)
        for i in range(S):
            for a in range(2 * m):
                acc = y[a]
                for j in range(i):
                    acc += hs_ * tab.a[i, j] * K[j, a]
                ys[a] = acc
                for c in range(ncol):
                    acc = Y[a, c]
                    for j in range(i):
                        acc += hs_ * tab.a[i, j] * KY[j, a, c]
                    Ys[a, c] = acc
            _var_rhs(t + tab.c[i] * hs_, ys, Ys, H, C, Om, F, dF, sy, st, hs, dd, vr, dvr, K[i], KY[i], m, ip0)
        err = 0.0
        for a in range(2 * m):
            acc = y[a]
            e = 0.0
            for j in range(S - 1):
                acc += hs_ * tab.a[S - 1, j] * K[j, a]
            for j in range(S):
                e += hs_ * tab.e[j] * K[j, a]
            y1[a] = acc
            sc = (rk[1] if a < m else rk[2]) + RTOL * max(abs(y[a]), abs(acc))
            err = max(err, abs(e) / sc)
        # the tangent too (its field is not smooth where a Hertz contact starts, g^(p - 1) at g = 0):
        # each column against its own scale
        for c in range(ncol):
            ysc = 0.0
            for a in range(2 * m):
                ysc = max(ysc, abs(Y[a, c]))
            ysc = YTOL * max(ysc, 1.0)
            for a in range(2 * m):
                e = 0.0
                for j in range(S):
                    e += hs_ * tab.e[j] * KY[j, a, c]
                err = max(err, abs(e) / ysc)
        if err > 1.0:
            h = hs_ * max(0.1, 0.9 * err ** (-1.0 / tab.order))
            if h < rk[3]:
                return False
            continue
        for a in range(2 * m):
            for c in range(ncol):
                acc = Y[a, c]
                for j in range(S - 1):
                    acc += hs_ * tab.a[S - 1, j] * KY[j, a, c]
                Y1[a, c] = acc
        t += hs_
        for a in range(2 * m):
            y[a] = y1[a]
            for c in range(ncol):
                Y[a, c] = Y1[a, c]
        if hs_ >= h:
            h = hs_ * min(5.0, 0.9 * err ** (-1.0 / tab.order)) if err > 0.0 else 5.0 * hs_
    if H == 0:
        for i in range(n):
            out_state[i] = y[i]
            out_state[n + i] = y[n + i]
        for i in range(n2):
            for c in range(ncol):
                J[i, c] = Y[i, c]
    else:
        for i in range(n):
            e = hs.eta_c[H, i]
            ed = 0.0
            for j in range(m):
                e += hs.Psi[H, i, j] * y[j]
                ed += hs.Psi[H, i, j] * y[m + j]
            out_state[i] = e
            out_state[n + i] = ed
            for c in range(ncol):
                a = dd.deta_c[c - ip0, H, i] if c >= ip0 else 0.0
                b = 0.0
                for j in range(m):
                    a += hs.Psi[H, i, j] * Y[j, c]
                    b += hs.Psi[H, i, j] * Y[m + j, c]
                J[i, c] = a
                J[n + i, c] = b
    return True
