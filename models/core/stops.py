"""Stops of the one dynamical system in kernel form: relations, laws, and the system held on them.

A stop is a pair (relation, law) (:mod:`vibeam.models.contact`; Siconos' ``Relation`` and
``NonSmoothLaw``).  Its relation is a row ``w`` of the modal system (``ModalSystem.contacts[row]``:
a point of the beam, a DOF of a lumped model, the SDOF's coordinate), a side ``s = +1`` (upper,
the stop above the point) or ``-1`` (lower) and an offset ``D``: normal ``n = s w``, gap ``g = n^T
eta - D`` (free while ``g < 0``), normal velocity ``U = n^T eta'`` (approaching while ``U > 0``),
effective mass ``m_eff = 1 / |n|^2`` (mass-normalised modes).

The system *held* on a set ``H`` of stops (sticking, ``n_k^T eta = D_k`` for ``k`` in ``H``) moves
in ``eta = eta_c + Psi zeta``, ``Psi`` an orthonormal basis of the null space of the held rows
``W_H`` diagonalising ``Psi^T K Psi = diag(nu^2)``, ``eta_c = W_H^T (W_H W_H^T)^-1 D_H`` the
nearest point of the constraint.  Each ``zeta_j`` is again a damped forced oscillator::

    zeta_j'' + c_j zeta_j' + nu_j^2 (zeta_j - e_j) = (Psi^T Gamma)_j F sin(Omega t)

(``Gamma`` the forcing vector, ``F = Omega^p A`` the drive's amplitude:
:func:`vibeam.models.system.drive_force`) with ``e = -(Psi^T K eta_c) / nu^2`` and the constrained
damping ``c = diag(Psi^T C Psi)`` (exact for Rayleigh damping ``C = alpha + D K``, where ``Psi^T
C Psi`` is diagonal; the off-diagonal remainder of other modal damping, ``Emis``, is dropped by
the event integrator's held flow, whose held points say so (:func:`vibeam.models.core.event.
held_damping_note`), kept by the direct solver, and returned by :func:`held_sets` as ``mismatch``).
The constraint forces are ``lambda_H = -(W_H W_H^T)^-1 W_H a_free`` with the free acceleration
``a_free = Gamma F sin - C eta' - K eta``; the stops push (hold) while ``lambda_k <= 0`` and
release stop ``k`` when ``lambda_k`` turns positive (:mod:`vibeam.models.core.contact_policy`).  An
impact on a further stop ``j`` while held applies its impulse along ``Pi_H n_j`` (``Pi_H = Psi
Psi^T``, the held constraints kept) with the effective mass ``1 / (n_j^T Pi_H n_j)``.

Everything here is computed once per model (it does not depend on the forcing frequency) and
handed to the kernels as plain NamedTuples of float64 / int64 arrays (:class:`KernelSystem`,
:class:`KernelStops`, :class:`HeldSets`); sets are indexed by their bit mask over the stops
(``2^n_stops`` rows; a set whose rows are dependent, e.g. the upper and lower stop of one point,
is marked invalid).

References
----------
V. Acary, B. Brogliato, *Numerical Methods for Nonsmooth Dynamical Systems*, Springer 2008,
Ch. 3 (relations, laws, the Newton impact law through the mass matrix); L. Meirovitch,
*Fundamentals of Vibrations*, 2001, Ch. 7 (constrained modes).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import scipy.linalg

from ..contact import LAW, LAW_LINEAR, NODES, OFFSET, R as RCOL, pack
from ..system import DRIVE_POWERS, ModalSystem, mode_table

__all__ = ["KernelSystem", "KernelStops", "HeldSets", "kernel_system", "kernel_stops", "held_sets",
           "MAX_STOPS", "held_code", "held_mask"]

#: most stops of one scene (the held sets are tabulated over their 2^n subsets)
MAX_STOPS = 6


class KernelSystem(NamedTuple):
    """The modal system as the kernels read it (nondimensional time, row units).

    Attributes
    ----------
    mp : ndarray, shape (n, 6)
        Mode table (:func:`vibeam.models.system.mode_table`).
    c, k, gam, sensor : ndarray, shape (n,)
        Damping coefficients, stiffnesses ``omega_i^2``, participation, sensor row.
    B : float
        The drive's amplitude ``A`` (system units; a base displacement's ``B`` in the row unit).
    p : int
        The drive exponent (:data:`vibeam.models.system.DRIVE_POWERS`): the forcing is ``gam
        Omega^p B sin(Omega t)`` (:func:`vibeam.models.system.drive_force`), ``p = 2`` the base
        displacement drive.
    """

    mp: np.ndarray
    c: np.ndarray
    k: np.ndarray
    gam: np.ndarray
    sensor: np.ndarray
    B: float
    p: int


class KernelStops(NamedTuple):
    """The stops as the kernels read them; row ``k`` is stop ``k``.

    Attributes
    ----------
    normal : ndarray, shape (n_s, n)
        ``n_k = s_k w_k``.
    offset : ndarray, shape (n_s,)
        ``D_k``: contact where ``n_k^T eta = D_k``.
    law : ndarray of int64, shape (n_s,)
        Law codes (:data:`vibeam.models.contact.LAW_RESTITUTION`, ...).
    R : ndarray, shape (n_s,)
        Newton's coefficient of restitution (constant part).
    nodes : ndarray of int64, shape (n_s,)
        Nodes of each stop's ``R(U-)`` table (0: constant R).
    tab_U, tab_R : ndarray, shape (n_s, m)
        ``R(U-)`` tables (normal velocity in row units per unit time).
    m_eff, c_eff, k_eff : ndarray, shape (n_s,)
        ``1 / |n|^2`` and the damping rate and stiffness of the contact coordinate
        (``m_eff n^T C n``, ``m_eff n^T K n``; the chatter estimate of
        :mod:`vibeam.models.core.contact_policy`).
    kc, cc, pe : ndarray, shape (n_s,)
        A compliant law's stiffness (system units: ``eta'' = ... - n f``, ``f = kc g^pe ...``), its
        dashpot (Kelvin-Voigt, ``2 zeta_c sqrt(kc m_eff)``) or ``chi`` (hysteretic Hertz), and its
        exponent (:mod:`vibeam.models.core.laws`); zeros for Newton's law.
    """

    normal: np.ndarray
    offset: np.ndarray
    law: np.ndarray
    R: np.ndarray
    nodes: np.ndarray
    tab_U: np.ndarray
    tab_R: np.ndarray
    m_eff: np.ndarray
    c_eff: np.ndarray
    k_eff: np.ndarray
    kc: np.ndarray
    cc: np.ndarray
    pe: np.ndarray


class HeldSets(NamedTuple):
    """The system held on each set of stops (index: bit mask of the set); see the module text.

    Attributes
    ----------
    valid : ndarray of int64, shape (S,)
        1 if the set's rows are independent (the set can be held), else 0.
    nc : ndarray of int64, shape (S,)
        Constrained coordinates ``n - |H|``.
    Psi : ndarray, shape (S, n, n)
        Null-space modes (first ``nc`` columns).
    eta_c : ndarray, shape (S, n)
        Nearest point of the constraint.
    mp : ndarray, shape (S, n, 6)
        Mode tables of the constrained coordinates (first ``nc`` rows).
    e, c, nu2, gam : ndarray, shape (S, n)
        Static offsets, damping coefficients, stiffnesses and participation of the
        constrained coordinates.
    pL, rL : ndarray, shape (S, n_s, n)
        Weights of ``zeta`` and ``zeta'`` in the constraint force ``lambda_k`` of each held stop.
    cL, lamF : ndarray, shape (S, n_s)
        Its constant (``e`` included) and the coefficient of ``F sin(Omega t)`` (``F = Omega^p B``).
    pG : ndarray, shape (S, n_s, n)
        Weights of ``zeta`` in the gap of each stop (``Psi^T n_j``).
    cG : ndarray, shape (S, n_s)
        The gap's constant (``e`` included).
    moves : ndarray of int64, shape (S, n_s)
        1 if stop ``j``'s gap moves while the set is held (0 for a held stop, and for a stop on
        a held row).
    pS : ndarray, shape (S, n)
        Weights of ``zeta`` in the sensor.
    cS : ndarray, shape (S,)
        The sensor's constant (``e`` included).
    dirn : ndarray, shape (S, n_s, n)
        Impulse direction ``Pi_H n_j`` of an impact on stop ``j``.
    meff, ceff, keff : ndarray, shape (S, n_s)
        Its effective mass ``1 / (n_j^T Pi_H n_j)`` and the chatter estimate's damping rate and
        stiffness along it.
    gw : ndarray, shape (S, n_s, n)
        Row ``k`` of ``(W_H W_H^T)^-1 W_H`` for each held stop ``k``: ``lambda_k = gw^T (K eta + C
        eta' - Gamma F sin)`` in full coordinates.
    Emis : ndarray, shape (S, n, n)
        ``Psi^T C Psi - diag(c)`` (first ``nc`` rows and columns): the damping coupling that the
        held flow's diagonal damping leaves out (zero for Rayleigh damping).
    """

    valid: np.ndarray
    nc: np.ndarray
    Psi: np.ndarray
    eta_c: np.ndarray
    mp: np.ndarray
    e: np.ndarray
    c: np.ndarray
    nu2: np.ndarray
    gam: np.ndarray
    pL: np.ndarray
    rL: np.ndarray
    cL: np.ndarray
    lamF: np.ndarray
    pG: np.ndarray
    cG: np.ndarray
    moves: np.ndarray
    pS: np.ndarray
    cS: np.ndarray
    dirn: np.ndarray
    meff: np.ndarray
    ceff: np.ndarray
    keff: np.ndarray
    gw: np.ndarray
    Emis: np.ndarray


def kernel_system(system: ModalSystem) -> KernelSystem:
    """The kernels' view of a :class:`~vibeam.models.system.ModalSystem` (its forcing vector,
    amplitude and drive exponent as ``gam``, ``B``, ``p``).

    Raises
    ------
    ValueError
        On a ``drive_power`` not in :data:`vibeam.models.system.DRIVE_POWERS`.
    """
    p = int(system.drive_power)
    if p not in DRIVE_POWERS:
        raise ValueError(f"drive_power = {system.drive_power!r}; allowed: {' or '.join(map(str, DRIVE_POWERS))}")
    k = np.ascontiguousarray(system.omega ** 2)
    c = np.ascontiguousarray(system.damping, dtype=float)
    return KernelSystem(mode_table(c, k), c, k, np.ascontiguousarray(system.participation, dtype=float),
                        np.ascontiguousarray(system.sensor, dtype=float), float(system.base_amplitude), p)


def _rows(system: ModalSystem, stops) -> np.ndarray:
    W = np.asarray(system.contacts, dtype=float)
    out = np.empty((len(stops), W.shape[1]))
    for i, s in enumerate(stops):
        row = int(getattr(s.relation, "row", 0))
        if not 0 <= row < W.shape[0]:
            raise ValueError(f"stop {i} references contact row {row}; the system has {W.shape[0]} row(s)")
        out[i] = s.relation.sign * W[row]
    return out


def kernel_stops(system: ModalSystem, stops) -> KernelStops:
    """The kernels' view of a sequence of :class:`vibeam.models.contact.Stop` on ``system``.

    Raises
    ------
    ValueError
        On more than :data:`MAX_STOPS` stops, a relation row the system does not have, or a row
        that no retained mode moves.
    """
    if not 1 <= len(stops) <= MAX_STOPS:
        raise ValueError(f"a scene takes 1 to {MAX_STOPS} stops, got {len(stops)}")
    N = _rows(system, stops)
    par, tU, tR = pack(stops)
    n2 = np.einsum("ij,ij->i", N, N)
    if np.any(n2 <= 0.0):
        raise ValueError("a stop's contact row is zero: no retained mode moves its contact point")
    me = 1.0 / n2
    c = np.asarray(system.damping, float)
    k = np.asarray(system.omega, float) ** 2
    kc = np.zeros(len(stops))
    cc = np.zeros(len(stops))
    pe = np.zeros(len(stops))
    for i, s in enumerate(stops):
        if getattr(s.law, "kind", "") != "compliant":
            continue
        kc[i] = float(s.law.stiffness)
        if s.law.code == LAW_LINEAR:
            cc[i] = 2.0 * float(s.law.damping_ratio) * math.sqrt(kc[i] * me[i])
            pe[i] = 1.0
        else:
            cc[i] = float(s.law.chi)
            pe[i] = float(s.law.exponent)
    return KernelStops(np.ascontiguousarray(N), np.ascontiguousarray(par[:, OFFSET]),
                       par[:, LAW].astype(np.int64), np.ascontiguousarray(par[:, RCOL]),
                       par[:, NODES].astype(np.int64), np.ascontiguousarray(tU), np.ascontiguousarray(tR),
                       me, me * ((N * N) @ c), me * ((N * N) @ k), kc, cc, pe)


def held_sets(system: ModalSystem, ks: KernelStops) -> tuple[HeldSets, np.ndarray]:
    """The system held on every set of stops (:class:`HeldSets`) and the damping mismatch.

    Returns
    -------
    sets : HeldSets
    mismatch : ndarray, shape (S,)
        Largest off-diagonal entry of ``Psi^T C Psi`` of each set relative to its largest
        diagonal entry (0 for Rayleigh damping up to round-off): what the held flow neglects.
    """
    Nrm = ks.normal
    ns, n = Nrm.shape
    S = 1 << ns
    kk = np.asarray(system.omega, float) ** 2
    cc = np.asarray(system.damping, float)
    gam = np.asarray(system.participation, float)
    sens = np.asarray(system.sensor, float)
    K = np.diag(kk)
    C = np.diag(cc)
    out = dict(valid=np.zeros(S, np.int64), nc=np.zeros(S, np.int64), Psi=np.zeros((S, n, n)),
               eta_c=np.zeros((S, n)), mp=np.zeros((S, n, 6)), e=np.zeros((S, n)), c=np.zeros((S, n)),
               nu2=np.zeros((S, n)), gam=np.zeros((S, n)), pL=np.zeros((S, ns, n)), rL=np.zeros((S, ns, n)),
               cL=np.zeros((S, ns)), lamF=np.zeros((S, ns)), pG=np.zeros((S, ns, n)), cG=np.zeros((S, ns)),
               moves=np.zeros((S, ns), np.int64), pS=np.zeros((S, n)), cS=np.zeros(S),
               dirn=np.zeros((S, ns, n)), meff=np.zeros((S, ns)), ceff=np.zeros((S, ns)), keff=np.zeros((S, ns)),
               gw=np.zeros((S, ns, n)), Emis=np.zeros((S, n, n)))
    mismatch = np.zeros(S)
    for mask in range(S):
        idx = [k for k in range(ns) if mask >> k & 1]
        m = len(idx)
        if m > n:
            continue
        if m:
            Wh = Nrm[idx]
            sv = np.linalg.svd(Wh, compute_uv=False)
            if sv[-1] <= 1e-10 * sv[0]:
                continue          # dependent rows (e.g. both stops of one point): never held together
            Q, _ = np.linalg.qr(np.column_stack([Wh.T, np.eye(n)]))
            T = Q[:, m:n]
            G = np.linalg.inv(Wh @ Wh.T)
            eta_c = Wh.T @ (G @ ks.offset[idx])
        else:
            T = np.eye(n)
            G = np.zeros((0, 0))
            eta_c = np.zeros(n)
        nc = n - m
        if 0 < nc < n:
            nu2, V = scipy.linalg.eigh(T.T @ K @ T)
            Psi = T @ V
        elif nc == n:
            nu2, Psi = kk.copy(), np.eye(n)
        else:
            nu2, Psi = np.zeros(0), np.zeros((n, 0))
        CC = Psi.T @ C @ Psi
        cC = np.diag(CC).copy()
        if nc > 1:
            off = np.max(np.abs(CC - np.diag(cC)))
            mismatch[mask] = off / max(np.max(np.abs(cC)), 1e-300)
            if off > 1e-12 * max(np.max(np.abs(cC)), 1e-300):     # not Rayleigh's round-off
                out["Emis"][mask, :nc, :nc] = CC - np.diag(cC)
        e = -(Psi.T @ (K @ eta_c)) / np.where(nu2 > 0, nu2, 1.0)
        o = out
        o["valid"][mask] = 1
        o["nc"][mask] = nc
        o["Psi"][mask, :, :nc] = Psi
        o["eta_c"][mask] = eta_c
        o["mp"][mask, :nc] = mode_table(cC, nu2)
        o["e"][mask, :nc] = e
        o["c"][mask, :nc] = cC
        o["nu2"][mask, :nc] = nu2
        o["gam"][mask, :nc] = Psi.T @ gam
        o["pS"][mask, :nc] = Psi.T @ sens
        o["cS"][mask] = float(sens @ eta_c) + float((Psi.T @ sens) @ e)
        for a, k in enumerate(idx):
            out["gw"][mask, k] = sum(G[a, b] * Nrm[l] for b, l in enumerate(idx))
            pL = sum(G[a, b] * (Psi.T @ (K @ Nrm[l])) for b, l in enumerate(idx))
            rL = sum(G[a, b] * (Psi.T @ (C @ Nrm[l])) for b, l in enumerate(idx))
            o["pL"][mask, k, :nc] = pL
            o["rL"][mask, k, :nc] = rL
            o["cL"][mask, k] = sum(G[a, b] * float(Nrm[l] @ (K @ eta_c)) for b, l in enumerate(idx)) + float(pL @ e)
            o["lamF"][mask, k] = -sum(G[a, b] * float(Nrm[l] @ gam) for b, l in enumerate(idx))
        P = Psi @ Psi.T
        for j in range(ns):
            if j in idx:
                continue
            pG = Psi.T @ Nrm[j]
            o["pG"][mask, j, :nc] = pG
            o["cG"][mask, j] = float(Nrm[j] @ eta_c) - ks.offset[j] + float(pG @ e)
            o["moves"][mask, j] = 1 if np.linalg.norm(pG) > 1e-12 * np.linalg.norm(Nrm[j]) else 0
            d = P @ Nrm[j]
            dd = float(Nrm[j] @ d)
            o["dirn"][mask, j] = d
            if o["moves"][mask, j]:
                me = 1.0 / dd
                o["meff"][mask, j] = me
                o["ceff"][mask, j] = me * float(d @ (C @ d))     # |d|^2 = 1 / me
                o["keff"][mask, j] = me * float(d @ (K @ d))
    arrays = {k: np.ascontiguousarray(v) for k, v in out.items()}
    return HeldSets(**arrays), mismatch


def held_code(mask: int) -> int:
    """The held-state code of a state vector's last entry for the set ``mask``: 0 free, 1 held on
    stop 0 alone, -1 on stop 1 alone (the lower stop of a two-sided scene), else the mask."""
    return -1 if mask == 2 else int(mask)


def held_mask(code: float, n_stops: int) -> int:
    """Inverse of :func:`held_code` (rounded; a code naming a stop the scene lacks is 0)."""
    c = int(round(float(code)))
    mask = 2 if c == -1 else (c if c > 0 else 0)
    return mask if mask < (1 << n_stops) else 0
