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
stiff and slow).  The event solver is the one compliant beam kernel
(:func:`vibeam.models.beam_compliant.beam_compliant_kernel`), which dispatches each stop's law:
a Hunt-Crossley stop may be the upper or the lower one, beside either compliant law.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .beam_compliant import TWO_PI, CompliantBeamEventSolver, velocity_floor
from .contact import EV_EXIT
from .hc_contact import hc_contact_step
from .registry import family_laws
from .sdof_compliant import HC_ATOL
from .trajectory import Trajectory


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


class HuntCrossleyBeamEventSolver(CompliantBeamEventSolver):
    """Method ``event`` of a beam scene with a Hunt-Crossley stop (module docstring).

    The one compliant beam kernel (:func:`vibeam.models.beam_compliant.beam_compliant_kernel`)
    with the stop's law dispatched inside it; the interface of
    :class:`vibeam.models.beam_compliant.CompliantBeamEventSolver` (state ``(eta, eta', phase)``,
    phase 1 in contact; contact records per unit effective mass).

    Parameters
    ----------
    model : vibeam.models.beam_compliant.CompliantBeamModel
        With ``contact`` a :class:`vibeam.models.compliant.HuntCrossley` (``stiffness`` in
        N/m^p at the contact point); a lower stop of a two-sided scene may have either
        compliant law.
    transient_samples, steps_per_fundamental, max_impacts_per_period, max_steps_per_period
        As :class:`~vibeam.models.beam_compliant.CompliantBeamEventSolver`.

    Raises
    ------
    ValueError
        If the upper stop's law is not of the hysteretic-Hertz family.
    """

    def __init__(self, model, **kwargs):
        if getattr(model, "contact", None) is None or getattr(model.contact, "family", "") != "hysteretic_hertz":
            raise ValueError(f"HuntCrossleyBeamEventSolver needs a beam model with {family_laws('hysteretic_hertz')}")
        super().__init__(model, **kwargs)


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
        if getattr(model, "contact", None) is None or getattr(model.contact, "family", "") != "hysteretic_hertz":
            raise ValueError(f"HuntCrossleyBeamODESolver needs a beam model with {family_laws('hysteretic_hertz')}")
        if getattr(model, "two_sided", False):
            raise ValueError(f"{family_laws('hysteretic_hertz')} on the beam takes one stop with method \"direct\"")
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
