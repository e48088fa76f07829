"""Linear contact phases: the modal system pressed by Kelvin-Voigt stops, as decoupled oscillators.

While a set ``C`` of stops with a linear (Kelvin-Voigt) law is in contact, and a set ``H`` of
Newton stops holds the system (``eta = eta_c + Psi zeta``, :class:`~vibeam.models.core.stops.HeldSets`),
the motion is again linear::

    zeta'' + C_z zeta' + K_z zeta = Psi^T Gamma F sin(Omega t) + b0,
    K_z = diag(nu^2) + sum_{k in C} k_k Psi^T n_k n_k^T Psi,   C_z = diag(c_H) + sum_{k in C} c_k Psi^T n_k n_k^T Psi

(``k_k``, ``c_k`` the stop's stiffness and dashpot in system units, its force ``f_k = k_k g_k + c_k
g_k'`` acting along ``-n_k``; ``b0`` the constant loads of the stops' offsets and of the held
constraint).  The stops couple the modes, so the phase has no modal closed form of its own; its
state matrix ``A = [[0, I], [-K_z, -C_z]]`` is diagonalised once per model (LAPACK ``geev``).
Every pair of its eigenvalues is one *real* damped oscillator: a complex pair ``-sigma +- i q``
with eigenvector ``v`` contributes ``X x + Y y`` to the state, with ``x'' + 2 sigma x' + (sigma^2 +
q^2) x = 0``, ``y = x'``, ``X = Re v + (sigma / q) Im v``, ``Y = Im v / q``; two real eigenvalues
``l1 > l2`` with vectors ``v1, v2`` contribute the overdamped oscillator with ``X = (l1 v2 - l2 v1)
/ (l1 - l2)``, ``Y = (v1 - v2) / (l1 - l2)``.  In these coordinates the phase is exactly the kind
of flow the event integrator already knows (:mod:`vibeam.models.core.signals`: a mode table, the
homogeneous parts ``(x, y)``, signals with position and velocity weights), so the certified scans,
roots and extremes serve the contact phase unchanged.  The harmonic forcing projects onto each
pair as a vector ``(f_x, f_y)`` (``(x, y)' = A_j (x, y) + (f_x, f_y) F sin``), whose particular
response the kernel forms per forcing frequency.

Everything here is a function of the model (not of the frequency) and is handed to the kernel
as the plain NamedTuple :class:`ContactPhases`, one row ``q`` per pair ``(H, C)`` (``index[H, C]``).

References
----------
V. Acary, B. Brogliato, *Numerical Methods for Nonsmooth Dynamical Systems*, Springer 2008,
Ch. 2 (compliant contact); L. Meirovitch, *Fundamentals of Vibrations*, 2001, Ch. 7
(non-proportionally damped systems, state-space modes); paper Eq. 28 (the closed-form flow).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..contact import LAW_HYSTERETIC_HERTZ, LAW_LINEAR, LAW_RESTITUTION
from ..system import mode_table
from . import laws
from .rk import DOPRI5

__all__ = ["ContactPhases", "Compliant", "contact_phases", "compliant_data", "reachable_phases", "pair_modes",
           "UnresolvedPhase"]

TWO_PI = 2.0 * math.pi


class ContactPhases(NamedTuple):
    """The linear contact phases of a model (module docstring); row ``q`` is one phase.

    Attributes
    ----------
    index : ndarray of int64, shape (S, S)
        ``index[H, C]``: the phase of held set ``H`` (Newton stops) and contact set ``C``
        (Kelvin-Voigt stops), -1 if none.
    m : ndarray of int64, shape (Q,)
        Oscillators of the phase (``n - |H|``).
    mp : ndarray, shape (Q, n, 6)
        Their mode table (first ``m`` rows; :func:`vibeam.models.system.mode_table`).
    Tx, Ty : ndarray, shape (Q, 2n, n)
        The homogeneous part of the state ``(eta, eta')`` is ``Tx x + Ty y``.
    Tix, Tiy : ndarray, shape (Q, n, 2n)
        ``x = Tix z_h``, ``y = Tiy z_h`` of a homogeneous state ``z_h`` (on the held constraint).
    fx, fy : ndarray, shape (Q, n)
        Projection of the forcing (per unit ``F sin(Omega t)``) on each oscillator.
    ze : ndarray, shape (Q, 2n)
        The phase's equilibrium state (the stops' and constraint's constant loads).
    hcap : ndarray, shape (Q,)
        Largest step: 1/16 of the shortest isolated contact period ``2 pi / sqrt(k_k |n_k|^2)``
        of the stops in contact (a Gauss-Legendre panel of the contact work); 0 for a phase that
        cannot be resolved in double precision (:class:`UnresolvedPhase`; the rest of its row
        zeros), on which the kernel fails at once.
    pg, rg : ndarray, shape (Q, ns, n)
        Weights of ``x`` and ``y`` in each stop's gap ``g_k = n_k^T eta - D_k``; ``gc`` (Q, ns) its
        constant (the equilibrium's gap).
    pv, rv : ndarray, shape (Q, ns, n)
        The same of its normal velocity ``n_k^T eta'`` (no constant).
    pl, rl : ndarray, shape (Q, ns, n)
        The same of each held stop's constraint force ``lambda_k`` (the contact forces of the
        stops in ``C`` included); ``lc`` (Q, ns) its constant and ``lF`` (Q, ns) its coefficient of
        ``F sin(Omega t)``.
    ps, rs : ndarray, shape (Q, n)
        The same of the sensor ``s^T eta``; ``sc`` (Q,) its constant.
    """

    index: np.ndarray
    m: np.ndarray
    mp: np.ndarray
    Tx: np.ndarray
    Ty: np.ndarray
    Tix: np.ndarray
    Tiy: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    ze: np.ndarray
    hcap: np.ndarray
    pg: np.ndarray
    rg: np.ndarray
    gc: np.ndarray
    pv: np.ndarray
    rv: np.ndarray
    pl: np.ndarray
    rl: np.ndarray
    lc: np.ndarray
    lF: np.ndarray
    ps: np.ndarray
    rs: np.ndarray
    sc: np.ndarray


class UnresolvedPhase(ValueError):
    """A contact phase whose oscillators cannot be represented in double precision (their modes
    overflow or underflow: a stop far stiffer than the system)."""


def pair_modes(A: np.ndarray):
    """Real oscillators of a diagonalisable state matrix ``A`` (2m, 2m) (module docstring).

    Returns
    -------
    c, k : ndarray, shape (m,)
        Damping coefficients ``2 sigma`` and stiffnesses of the oscillators.
    X, Y : ndarray, shape (2m, m)
        Their columns: a homogeneous state is ``X x + Y y``.

    Raises
    ------
    ValueError
        If ``A`` has an eigenvalue with a positive real part, a repeated real eigenvalue (a
        critically damped pair, not diagonalisable in this form) or its eigenvectors are
        singular to working precision.
    UnresolvedPhase
        If the oscillators or their columns are not finite, or a column is below 1e-290.
    """
    d = A.shape[0]
    m = d // 2
    lam, V = np.linalg.eig(A)
    scale = max(np.max(np.abs(lam)), 1e-300)
    if np.any(lam.real > 1e-12 * scale):
        raise ValueError("a contact phase is unstable (an eigenvalue with a positive real part)")
    cplx = [i for i in range(d) if lam[i].imag > 1e-13 * scale]
    conj = [i for i in range(d) if lam[i].imag < -1e-13 * scale]
    real = [i for i in range(d) if abs(lam[i].imag) <= 1e-13 * scale]
    if len(cplx) != len(conj) or len(real) % 2:
        raise ValueError("the eigenvalues of a contact phase do not come in pairs")
    c = np.empty(m)
    k = np.empty(m)
    X = np.empty((d, m))
    Y = np.empty((d, m))
    j = 0
    for i in sorted(cplx, key=lambda i: abs(lam[i])):
        sig, q = -lam[i].real, lam[i].imag
        v = V[:, i]
        c[j], k[j] = 2.0 * sig, sig * sig + q * q
        X[:, j] = v.real + (sig / q) * v.imag
        Y[:, j] = v.imag / q
        j += 1
    rs = sorted(real, key=lambda i: lam[i].real, reverse=True)
    for a, b in zip(rs[0::2], rs[1::2]):
        l1, l2 = lam[a].real, lam[b].real            # l1 >= l2 (l1 the slower)
        if not l1 - l2 > 1e-10 * max(abs(l1), abs(l2), 1e-300):
            raise ValueError("a contact phase has a repeated real eigenvalue (critically damped); change "
                             "the stop's stiffness or damping slightly")
        v1, v2 = V[:, a].real, V[:, b].real
        c[j], k[j] = -(l1 + l2), l1 * l2
        X[:, j] = (l1 * v2 - l2 * v1) / (l1 - l2)
        Y[:, j] = (v1 - v2) / (l1 - l2)
        j += 1
    T = np.hstack([X, Y])
    norms = np.linalg.norm(T, axis=0)
    if not (np.all(np.isfinite(T)) and np.all(np.isfinite(c)) and np.all(np.isfinite(k)) and np.all(norms > 1e-290)):
        raise UnresolvedPhase("a contact phase cannot be resolved in double precision (its modes overflow or "
                              "underflow: a stop far stiffer than the system)")
    if np.linalg.cond(T / norms) > 1e12:    # (scale-free: columns normalised)
        raise ValueError("the modes of a contact phase are nearly dependent (defective state matrix)")
    return c, k, X, Y


def contact_phases(system, ks, hs) -> ContactPhases:
    """The linear contact phases of a modal system with its stops and held sets.

    Parameters
    ----------
    system : vibeam.models.system.ModalSystem
    ks : vibeam.models.core.stops.KernelStops
        With the laws' stiffness ``kc`` and dashpot ``cc`` (system units) and codes.
    hs : vibeam.models.core.stops.HeldSets

    Returns
    -------
    ContactPhases
        One phase per valid held set ``H`` of Newton stops and non-empty set ``C`` of
        Kelvin-Voigt stops outside ``H`` (none: arrays with one zero row, so that the kernel
        compiles once).

    Raises
    ------
    ValueError
        From :func:`pair_modes` (but for :class:`UnresolvedPhase`: that phase gets ``hcap = 0``).
    """
    Nrm = ks.normal
    ns, n = Nrm.shape
    S = 1 << ns
    lin = [k for k in range(ns) if ks.law[k] == LAW_LINEAR]
    newton = [k for k in range(ns) if ks.law[k] == LAW_RESTITUTION]
    kk = np.asarray(system.omega, float) ** 2
    cc = np.asarray(system.damping, float)
    gam = np.asarray(system.participation, float)
    index = np.full((S, S), -1, np.int64)
    rows = []
    for H in range(S):
        if any(H >> k & 1 for k in range(ns) if k not in newton) or not hs.valid[H]:
            continue
        nc = int(hs.nc[H])
        if nc == 0:
            continue
        Psi = hs.Psi[H][:, :nc]
        eta_c = hs.eta_c[H]
        free_lin = [k for k in lin if not H >> k & 1]
        for C in range(1, S):
            if any(C >> k & 1 for k in range(ns) if k not in free_lin):
                continue
            idx = [k for k in range(ns) if C >> k & 1]
            Kz = np.diag(hs.nu2[H, :nc]).astype(float)
            Cz = np.diag(hs.c[H, :nc]).astype(float)
            b0 = -(Psi.T @ (kk * eta_c))
            for k in idx:
                pn = Psi.T @ Nrm[k]
                Kz = Kz + ks.kc[k] * np.outer(pn, pn)
                Cz = Cz + ks.cc[k] * np.outer(pn, pn)
                b0 = b0 - pn * ks.kc[k] * (float(Nrm[k] @ eta_c) - ks.offset[k])
            A = np.zeros((2 * nc, 2 * nc))
            A[:nc, nc:] = np.eye(nc)
            A[nc:, :nc] = -Kz
            A[nc:, nc:] = -Cz
            try:
                c2, k2, X, Y = pair_modes(A)
            except UnresolvedPhase:
                rows.append(dict(H=H, C=C, m=0, hcap=0.0))
                continue
            Tz = np.hstack([X, Y])
            Ti = np.linalg.inv(Tz)
            # the forcing Psi^T Gamma F sin and the constant loads act on zeta''
            fz = np.concatenate([np.zeros(nc), Psi.T @ gam])
            f = Ti @ fz
            zeta_e = np.linalg.solve(Kz, b0)
            B2 = np.zeros((2 * n, 2 * nc))            # blockdiag(Psi, Psi)
            B2[:n, :nc] = Psi
            B2[n:, nc:] = Psi
            hcap = min(TWO_PI / math.sqrt(ks.kc[k] * float(Nrm[k] @ Nrm[k])) for k in idx) / 16.0
            ze = np.concatenate([eta_c + Psi @ zeta_e, np.zeros(n)])
            ll = np.zeros((ns, 2 * n))
            cl = np.zeros(ns)
            lF = np.zeros(ns)
            for j in range(ns):
                if H >> j & 1:
                    g = hs.gw[H, j]
                    ll[j, :n] = kk * g
                    ll[j, n:] = cc * g
                    for k in idx:
                        w = float(Nrm[k] @ g)
                        ll[j, :n] += ks.kc[k] * w * Nrm[k]
                        ll[j, n:] += ks.cc[k] * w * Nrm[k]
                        cl[j] -= ks.kc[k] * w * ks.offset[k]
                    lF[j] = -float(g @ gam)
            Tx, Ty = B2 @ X, B2 @ Y
            sens = np.asarray(system.sensor, float)
            rows.append(dict(H=H, C=C, m=nc, mp=mode_table(c2, k2), Tx=Tx, Ty=Ty,
                             Tix=Ti[:nc] @ B2.T, Tiy=Ti[nc:] @ B2.T, fx=f[:nc], fy=f[nc:], ze=ze, hcap=hcap,
                             pg=_by_row(Nrm, Tx[:n]), rg=_by_row(Nrm, Ty[:n]),
                             gc=_by_row(Nrm, ze[:n]) - np.asarray(ks.offset, float),
                             pv=_by_row(Nrm, Tx[n:]), rv=_by_row(Nrm, Ty[n:]), pl=_by_row(ll, Tx), rl=_by_row(ll, Ty),
                             lc=_by_row(ll, ze) + cl, lF=lF,
                             ps=sens @ Tx[:n], rs=sens @ Ty[:n], sc=float(sens @ ze[:n])))
    Q = max(len(rows), 1)
    out = dict(m=np.zeros(Q, np.int64), mp=np.zeros((Q, n, 6)), Tx=np.zeros((Q, 2 * n, n)),
               Ty=np.zeros((Q, 2 * n, n)), Tix=np.zeros((Q, n, 2 * n)), Tiy=np.zeros((Q, n, 2 * n)),
               fx=np.zeros((Q, n)), fy=np.zeros((Q, n)), ze=np.zeros((Q, 2 * n)), hcap=np.ones(Q),
               pg=np.zeros((Q, ns, n)), rg=np.zeros((Q, ns, n)), gc=np.zeros((Q, ns)),
               pv=np.zeros((Q, ns, n)), rv=np.zeros((Q, ns, n)), pl=np.zeros((Q, ns, n)), rl=np.zeros((Q, ns, n)),
               lc=np.zeros((Q, ns)), lF=np.zeros((Q, ns)), ps=np.zeros((Q, n)), rs=np.zeros((Q, n)), sc=np.zeros(Q))
    for q, r in enumerate(rows):
        m = r["m"]
        index[r["H"], r["C"]] = q
        out["m"][q] = m
        if "mp" not in r:             # an unresolved phase (UnresolvedPhase): hcap 0, zeros
            out["hcap"][q] = r["hcap"]
            continue
        for key in ("mp", "Tix", "Tiy", "fx", "fy"):
            out[key][q, :m] = r[key]
        for key in ("Tx", "Ty", "pg", "rg", "pv", "rv", "pl", "rl", "ps", "rs"):
            out[key][q, ..., :m] = r[key]
        for key in ("ze", "hcap", "gc", "lc", "lF", "sc"):
            out[key][q] = r[key]
    arrays = {k: np.ascontiguousarray(v) for k, v in out.items()}
    return ContactPhases(index=index, **arrays)


def _by_row(M: np.ndarray, A: np.ndarray) -> np.ndarray:
    """``M @ A`` one row of ``M`` at a time: each stop's row gets the same bits whatever the number
    of stops (BLAS takes other kernels, with other sums, for other shapes), so that a stop the
    motion never reaches changes nothing."""
    return np.array([row @ A for row in M]).reshape((M.shape[0],) + A.shape[1:])


class Compliant(NamedTuple):
    """What the event integrator needs of a scene's compliant stops (its argument ``cp``).

    Attributes
    ----------
    ph : ContactPhases
        The linear contact phases.
    tab : vibeam.models.core.rk.Tableau
        The Runge-Kutta pair of the other contact phases.
    vfall : float
        The hysteretic-Hertz ``v_in`` floor without forcing (row units per unit time).
    vfac : float
        The floor's factor :data:`vibeam.models.core.laws.V_FLOOR` (read when built).
    lin : ContactPhases or None
        ``ph`` if the scene can reach a linear contact phase (:func:`reachable_phases`), else None.
    itab : vibeam.models.core.rk.Tableau or None
        ``tab`` if the scene can reach a contact phase that is not linear, else None.

    The event integrator takes a phase's kind from ``lin`` and ``itab``, so that numba compiles only
    the kinds a scene reaches (it prunes the code behind an argument that is None): a scene of
    Kelvin-Voigt stops compiles no Runge-Kutta phase, one of hysteretic-Hertz stops no linear
    phase.  The shooting problem's tangent takes ``ph`` and ``tab`` (its variational equations
    integrate a linear phase too when a parameter changes its matrix).
    """

    ph: ContactPhases
    tab: object
    vfall: float
    vfac: float
    lin: object
    itab: object


def reachable_phases(ph: ContactPhases, law, valid) -> tuple[bool, bool]:
    """Whether a scene can reach a linear contact phase, and one that is not linear.

    A contact phase is a pair ``(H, C)``: ``H`` a set of Newton stops the system can be held on
    (``valid[H]``, :class:`~vibeam.models.core.stops.HeldSets`), ``C`` a non-empty set of compliant
    stops in contact; it is linear if ``ph.index[H, C] >= 0`` (:func:`contact_phases`), else the
    event integrator integrates it (Runge-Kutta).

    Parameters
    ----------
    ph : ContactPhases
    law : array_like of int, shape (ns,)
        The stops' law codes (:data:`vibeam.models.contact.LAW_RESTITUTION` ...).
    valid : array_like of int, shape (2**ns,)
        The held sets the system can be held on.

    Returns
    -------
    (bool, bool)
        Some reachable phase is linear; some is not.
    """
    codes = [int(c) for c in law]
    S = 1 << len(codes)
    newton = sum(1 << k for k, c in enumerate(codes) if c == LAW_RESTITUTION)
    linear = integrated = False
    for H in range(S):
        if H & ~newton or not valid[H]:
            continue
        for C in range(1, S):
            if C & (newton | H):
                continue
            if ph.index[H, C] >= 0:
                linear = True
            else:
                integrated = True
    return linear, integrated


def compliant_data(system, ks, hs):
    """The :class:`Compliant` data of a scene, or None if it has no compliant stop (the integrator
    then compiles and runs its Newton-only specialisation)."""
    if not any(int(c) in (LAW_LINEAR, LAW_HYSTERETIC_HERTZ) for c in ks.law):
        return None
    ph = contact_phases(system, ks, hs)
    linear, integrated = reachable_phases(ph, ks.law, hs.valid)
    return Compliant(ph, DOPRI5, 1e-6 * float(system.coordinate_scale), float(laws.V_FLOOR),
                     ph if linear else None, DOPRI5 if integrated else None)
