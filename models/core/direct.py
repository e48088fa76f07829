"""The one direct solver: the modal system with its stops integrated by ``solve_ivp`` (a reference).

Method ``direct`` of the modal fidelities, an independent check of the event integrator
(:mod:`vibeam.models.core.integrator`) that shares with it only the model and the laws' formulas
(:mod:`vibeam.models.core.laws`, evaluated here in plain Python): the equations of motion are
integrated by :func:`scipy.integrate.solve_ivp` (DOP853 by default) phase by phase.  A phase is the
set ``H`` of Newton stops the system is held on and the set ``C`` of compliant stops in contact::

    eta''  = Gamma F sin(Omega t) - C eta' - K eta - sum_{k in C} n_k f_k(g_k, g_k')           (H empty)
    zeta'' = Psi^T Gamma F sin(Omega t) - c_H zeta' - nu^2 (zeta - e) - sum_{k in C} Psi^T n_k f_k   (held)

(held on ``H``: the constrained modes ``eta = eta_c + Psi zeta`` of
:class:`~vibeam.models.core.stops.HeldSets`; ``F = Omega^2 B``), the work ``E_k' = f_k g_k'`` of each
stop in contact appended to the state.  A phase ends at the first terminal event, a function of
the state rising (``+``) or falling (``-``) through zero:

========================  =====================================================================
impact, entry             ``g_k = n_k^T eta - D_k`` (+) of a stop outside it: Newton's law acts
                          (through the mass matrix, along ``n_k`` projected on the held
                          constraints, :mod:`vibeam.models.contact`), or a compliant contact begins
exit                      Kelvin-Voigt: its force ``f = k_c g + c_c g'`` (-); hysteretic Hertz: ``g``
                          (-) or the damping factor ``1 + chi g' / v_in`` (-), which leaves the body
                          inside the stop ('relaxed')
entry inside a stop       the force's sign function ``r0 g + r1 g' + roff`` (+)
                          (:func:`~vibeam.models.core.laws.inside_sign`)
back below a stop         ``g`` (-) of a stop the body is inside of without contact
release                   a held stop's constraint force ``lambda_k`` (+), the compliant forces included
========================  =====================================================================

Non-terminal events give the extremes: the sensor's (its velocity through zero, both ways) and, per
open contact, the largest penetration (``g'`` (-)) and the peak force (``f'`` (-)).  A transition
already due when a phase starts (a held stop's force already pulling, a contact force already
negative, a sign function already positive, a compliant stop touched while approaching or pressed) is
taken at once, with the event integrator's round-off margins (``1e-13`` of the terms) widened by the
error of a located event time (a value within it is zero, and its rate decides).  The contact
semantics are the event integrator's
(:mod:`vibeam.models.core.contact_phase`): the force acts while ``g >= 0`` and ``f > 0``, a
hysteretic-Hertz contact's ``v_in`` is its entry velocity floored at
:func:`~vibeam.models.core.laws.hertz_floor`, a contact's record (duration, peak force, largest
penetration, work done on the stop, entry velocity) is closed at its exit.

An impact slower than ``chatter_velocity`` times the first impact's speed into a pressing contact
acceleration ends a chatter (plastic projection, then held): a crude chatter model, fine for a
reference of impacting and sticking orbits, not for resolving chatter (the event integrator sums
chatter in closed form).

The state is scaled by ``1 / state_scale`` (the beam's ``L sqrt(m_eff)``) so that it is of the order
of the output; steps are capped at ``T / 16``, and while a compliant stop is in contact or the body
inside one at ``1 / 20`` of the isolated contact's time scale
(:func:`~vibeam.models.core.laws.contact_scales`), so that an event's sign change is not stepped over
(``solve_ivp`` only checks signs at step ends: detection is not guaranteed, unlike the
integrator's).

References
----------
E. Hairer, S. P. Norsett, G. Wanner, *Solving Ordinary Differential Equations I*, 2nd ed., Springer
1993, Sec. II.5 (DOP853) and II.6 (dense output, event location); K. H. Hunt, F. R. E. Crossley,
J. Appl. Mech. 42 (1975) 440 (the hysteretic-Hertz law).
"""
from __future__ import annotations

import math

import numpy as np

from ..contact import LAW_HYSTERETIC_HERTZ, LAW_LINEAR
from ..impact import newton_restitution
from ..scene import Scene, rest_state
from ..system import drive_displacement, drive_force
from ..trajectory import Trajectory
from .event import EventIntegrator, stop_codes
from . import laws
from .stops import held_code

__all__ = ["DirectIntegrator", "BeamODESolver", "RTOL_IMPULSIVE", "ATOL_IMPULSIVE", "RTOL_COMPLIANT", "ATOL_COMPLIANT"]

TWO_PI = 2.0 * math.pi
#: default tolerances with impulsive (Newton) stops only, and with a compliant stop (the reference of
#: the event kernels' contact phases); ``atol`` in the scaled state's units, those of the output ``q``:
#: with a compliant stop below ``rtol`` times the motion (``q ~ 1e-3`` in the shipped scenes), so that
#: ``rtol`` governs (at ``1e-13`` the 4-mode beam's samples drift to ``4e-9`` of the orbit, at
#: ``1e-15`` ``1e-11``)
RTOL_IMPULSIVE, ATOL_IMPULSIVE = 1e-9, 1e-12
RTOL_COMPLIANT, ATOL_COMPLIANT = 1e-11, 1e-15
#: largest step while in contact with (or inside) a compliant stop, in units of the isolated contact's
#: time scale
CONTACT_STEP = 0.05
#: round-off margin of a transition due at a phase's start (the event integrator's)
ROUND = 1e-13
#: resolution of a ``solve_ivp`` event time relative to ``1 + |t|`` (its root finder's 4 eps, with margin)
T_RES = 16.0 * np.finfo(float).eps

# the laws' formulas in plain Python (numba's compiled functions would cost a dispatch per call)
_force = laws.force.py_func
_partials = laws.force_partials.py_func
_inside_sign = laws.inside_sign.py_func
_scales = laws.contact_scales.py_func
_start_velocity = laws.start_velocity.py_func
_floor = laws.hertz_floor.py_func
_drive_force = drive_force.py_func
_drive_displacement = drive_displacement.py_func

# terminal event kinds
RELEASE, EXIT, EXIT_DAMPING, ENTRY_INSIDE, GAP_DOWN, GAP, TURN = range(7)
# non-terminal event kinds
SENSOR, MAX_PEN, PEAK_FORCE = 7, 8, 9


def _now(v, rate, size, t):
    """The sign of a function of the state at a phase's start, ``v`` with its rate ``rate``: +1 or -1
    beyond its round-off (:data:`ROUND` of the terms' ``size``) and the error of an event time
    located by ``solve_ivp`` (:data:`T_RES` of ``1 + |t|``, times the rate); within them, the sign of
    the rate (0: at zero and stationary)."""
    tol = ROUND * size + abs(rate) * T_RES * (1.0 + abs(t))
    if v > tol:
        return 1
    if v < -tol:
        return -1
    return (rate > 0.0) - (rate < 0.0)


class _Phase:
    """The equations of one phase: held on the Newton stops ``H``, in contact with the compliant
    stops ``C`` (module docstring); coordinates ``z = (x (m), x' (m), E (|C|))``, ``x = eta`` (free)
    or ``zeta`` (held), all scaled by ``1 / sc``."""

    def __init__(self, run, H, C):
        self.r = r = run
        hs = r.hs
        self.H, self.C = H, C
        if H:
            m = int(hs.nc[H])
            self.P = hs.Psi[H][:, :m]
            self.a = hs.eta_c[H] / r.sc
            self.gam, self.c, self.k, self.e = hs.gam[H, :m] * r.F / r.sc, hs.c[H, :m], hs.nu2[H, :m], hs.e[H, :m] / r.sc
            # the held damping Psi^T C Psi whole: its off-diagonal part (non-proportional damping,
            # HeldSets.Emis; zero for Rayleigh damping), which the event kernels' held flow drops
            E = hs.Emis[H, :m, :m]
            if np.any(E != 0.0):
                self.c = np.diag(self.c) + E
            self.Nz = r.Nrm @ self.P
        else:
            m = r.N
            self.P = self.a = None
            self.gam, self.c, self.k, self.e = r.sy.gam * r.F / r.sc, r.sy.c, r.sy.k, 0.0
            self.Nz = r.Nrm
        self.m = m
        self.cl = [k for k in range(r.ns) if C >> k & 1]
        #: state length (a constrained system without coordinates and contacts still carries two zeros)
        self.L = max(2 * m + len(self.cl), 2)

    # ---- coordinates
    def eta(self, x):
        return x if self.P is None else self.a + self.P @ x

    def etad(self, v):
        return v if self.P is None else self.P @ v

    def of(self, y):
        """Phase coordinates of the full (scaled) state ``y = (eta, eta')`` (projected on the
        constraints when held), the works zero."""
        z = np.zeros(self.L)
        N, m = self.r.N, self.m
        if self.P is None:
            z[:2 * N] = y
        elif m:
            z[:m] = self.P.T @ (y[:N] - self.a)
            z[m:2 * m] = self.P.T @ y[N:]
        return z

    def full(self, Z):
        """Full scaled states ``(eta, eta')`` of phase states ``Z`` (columns), shape (2N, k)."""
        m = self.m
        if self.P is None:
            return Z[:2 * m]
        return np.concatenate([self.a[:, None] + self.P @ Z[:m], self.P @ Z[m:2 * m]])

    # ---- the stops
    def gap(self, j, z):
        """Gap and its rate of stop ``j`` (row units)."""
        r, m = self.r, self.m
        return (r.sc * (float(r.Nrm[j] @ self.eta(z[:m])) - r.D[j]),
                r.sc * float(r.Nrm[j] @ self.etad(z[m:2 * m])))

    def force(self, j, g, gd):
        r = self.r
        return _force(r.law[j], g, gd, r.kc[j], r.cc[j], r.pe[j], r.vr[j])

    def rhs(self, t, z):
        m, r = self.m, self.r
        x, v = z[:m], z[m:2 * m]
        out = np.zeros(self.L)
        out[:m] = v
        cv = self.c @ v if self.c.ndim == 2 else self.c * v
        out[m:2 * m] = self.gam * math.sin(r.Om * t) - cv - self.k * (x - self.e)
        for i, j in enumerate(self.cl):
            g, gd = self.gap(j, z)
            f = self.force(j, g, gd)
            out[m:2 * m] -= self.Nz[j] * (f / r.sc)
            out[2 * m + i] = f * gd / (r.sc * r.sc)
        return out

    def gap_acc(self, j, t, z):
        """``g''`` of stop ``j`` (row units), the compliant forces included."""
        m = self.m
        return self.r.sc * float(self.Nz[j] @ self.rhs(t, z)[m:2 * m])

    def lam(self, j, t, z, dt=0.0):
        """Constraint force of held stop ``j`` (scaled; held while <= 0): ``pL zeta + rL zeta' + cL +
        lamF F sin`` (:class:`~vibeam.models.core.stops.HeldSets`, whose ``cL`` holds ``pL e`` for the
        kernel's homogeneous parts: removed here) plus the compliant stops' push along ``gw``."""
        r, hs, H, m = self.r, self.r.hs, self.H, self.m
        out = (hs.cL[H, j] - hs.pL[H, j, :m] @ hs.e[H, :m] + hs.lamF[H, j] * r.F * math.sin(r.Om * (t + dt))) / r.sc
        if m:
            out += hs.pL[H, j, :m] @ z[:m] + hs.rL[H, j, :m] @ z[m:2 * m]
        for i in self.cl:
            g, gd = self.gap(i, z)
            out += float(hs.gw[H, j] @ r.Nrm[i]) * self.force(i, g, gd) / r.sc
        return float(out)

    def sign(self, j, g, gd):
        """Inside stop ``j`` without contact: its force's sign function and the terms' size."""
        r = self.r
        r0, r1, roff = _inside_sign(r.law[j], r.kc[j], r.cc[j], r.vr[j], r.relaxed >> j & 1 == 1)
        return r0 * g + r1 * gd + roff, r0, r1, abs(r0 * g) + abs(r1 * gd) + abs(roff)

    def exit_value(self, j, g, gd, kind):
        """The exit function of a contact (positive in contact): the Kelvin-Voigt force, or the
        hysteretic-Hertz gap (``kind == EXIT``) or damping factor (``EXIT_DAMPING``)."""
        r = self.r
        if r.law[j] == LAW_LINEAR:
            return r.kc[j] * g + r.cc[j] * gd
        return g if kind == EXIT else 1.0 + r.cc[j] * gd / r.vr[j]

    # ---- events
    def events(self, moving):
        """``(functions, kinds)``: the terminal events of the phase, then the extremes."""
        r, H, C = self.r, self.H, self.C
        fns, kinds = [], []

        def add(fn, direction, terminal, kind, j):
            fn.terminal, fn.direction = terminal, direction
            fns.append(fn)
            kinds.append((kind, j))

        for j in range(r.ns):
            if H >> j & 1:
                add(lambda t, z, j=j: self.lam(j, t, z), 1.0, True, RELEASE, j)
            elif C >> j & 1:
                add(lambda t, z, j=j: self.exit_value(j, *self.gap(j, z), EXIT), -1.0, True, EXIT, j)
                if r.law[j] == LAW_HYSTERETIC_HERTZ:
                    add(lambda t, z, j=j: self.exit_value(j, *self.gap(j, z), EXIT_DAMPING), -1.0, True,
                        EXIT_DAMPING, j)
            elif not moving[j]:
                continue
            elif r.inside >> j & 1:
                add(lambda t, z, j=j: self.sign(j, *self.gap(j, z))[0], 1.0, True, ENTRY_INSIDE, j)
                add(lambda t, z, j=j: self.gap(j, z)[0], -1.0, True, GAP_DOWN, j)
            else:
                add(lambda t, z, j=j: self.gap(j, z)[0], 1.0, True, GAP, j)
                if j == r.turn:
                    eta = ROUND * r.vscale * r.sc
                    add(lambda t, z, j=j: self.gap(j, z)[1] - eta, 1.0, True, TURN, j)
        m, sv = self.m, r.sy.sensor
        if self.P is None:
            add(lambda t, z: float(sv @ z[m:2 * m]), 0.0, False, SENSOR, -1)
        else:
            add(lambda t, z: float(sv @ (self.P @ z[m:2 * m])) if m else 1.0, 0.0, False, SENSOR, -1)
        for j in self.cl:
            add(lambda t, z, j=j: self.gap(j, z)[1], -1.0, False, MAX_PEN, j)
            add(lambda t, z, j=j: self.force_rate(j, t, z), -1.0, False, PEAK_FORCE, j)
        return fns, kinds

    def force_rate(self, j, t, z):
        """``f'`` of stop ``j``'s contact force."""
        r = self.r
        g, gd = self.gap(j, z)
        fg, fgd, _ = _partials(r.law[j], g, gd, r.kc[j], r.cc[j], r.pe[j], r.vr[j])
        return fg * gd + fgd * self.gap_acc(j, t, z)


class DirectIntegrator:
    """``solve_ivp`` on a modal system with its stops, impulsive and compliant (module docstring).

    Parameters
    ----------
    core : EventIntegrator
        The system and its stops in kernel form (the held sets and the compliant laws' numbers
        included: :class:`~vibeam.models.core.stops.KernelStops`).
    state_scale : float
        The integration's unit of the modal coordinates (row units).
    solver : str
        :func:`scipy.integrate.solve_ivp` method.
    rtol, atol : float or None
        Its tolerances (``atol`` in the scaled state's units); None: :data:`RTOL_IMPULSIVE`,
        :data:`ATOL_IMPULSIVE` for a scene of Newton stops, :data:`RTOL_COMPLIANT`,
        :data:`ATOL_COMPLIANT` with a compliant stop.
    max_impacts_per_period : int
        More impacts and contacts per period on average: ``failed``.
    chatter_velocity : float
        Relative speed below which an impact into a pressing contact ends a chatter.
    max_step : float or None
        Largest step (default ``T / 16``).
    """

    def __init__(self, core: EventIntegrator, state_scale: float = 1.0, solver: str = "DOP853",
                 rtol: float | None = None, atol: float | None = None, max_impacts_per_period: int = 200,
                 chatter_velocity: float = 1e-6, max_step: float | None = None):
        comp = core.compliant is not None
        self.core = core
        self.sc = float(state_scale)
        self.solver = solver
        self.rtol = float(rtol if rtol is not None else (RTOL_COMPLIANT if comp else RTOL_IMPULSIVE))
        self.atol = float(atol if atol is not None else (ATOL_COMPLIANT if comp else ATOL_IMPULSIVE))
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.chatter_velocity = float(chatter_velocity)
        self.max_step = max_step

    def run(self, Omega, state0, n_transient, n_record, samples_per_period, scale, contacts_of, stop_codes=None):
        """One forcing frequency from ``state0`` (``(eta, eta', held code)``, row units).

        Parameters
        ----------
        Omega : float
        state0 : ndarray, shape (2n + 1,)
            The held code (:func:`~vibeam.models.core.stops.held_code`) names the Newton stops held
            and the compliant stops in contact at the start (a contact open at the start has no
            record row).
        n_transient, n_record, samples_per_period : int
        scale : float
            Row value per unit of the output ``q`` (:attr:`~vibeam.models.system.ModalSystem.coordinate_scale`).
        contacts_of : callable
            ``contacts_of(stop)`` -> the law object of a Newton stop (its ``coefficient(U-)``): the
            stops' own laws, as the fidelity holds them.
        stop_codes : ndarray of int, optional
            As :func:`vibeam.models.core.event.trajectory`.

        Returns
        -------
        Trajectory
            As the event solver's (:func:`vibeam.models.core.event.trajectory`): samples of ``q``,
            impacts and contact entries with their stops, the contacts' rows (per unit effective
            mass, in the units of ``q``: duration, peak force over ``m_eff scale``, largest
            penetration over ``scale``, work done on the stop over ``m_eff scale^2``, entry
            velocity over ``scale``; Newton's: 0, NaN, 0, the kinetic energy the impulse removed,
            ``U-``; a contact still open at the end has no row), ``final_state`` ``(eta, eta',
            held code)`` (the code of the held stops and the compliant stops in contact),
            ``extra`` ``mode_amplitudes``, ``stuck_fraction`` and, with a compliant stop,
            ``contact_fraction``; or a failed one with the reason (``solve_ivp``'s failure, too
            many impacts, no progress).
        """
        return _Run(self, Omega, n_transient, n_record, samples_per_period, scale, contacts_of,
                    stop_codes).go(state0)


class _Run:
    """One call of :meth:`DirectIntegrator.run`: its data, state and records."""

    def __init__(self, di, Omega, n_transient, n_record, spp, scale, contacts_of, stop_codes):
        core = self.core = di.core
        self.di = di
        self.sy, st, self.hs = core.ksys, core.kstops, core.held
        self.st = st
        self.N, self.ns = core.n, core.n_stops
        self.Om = Om = float(Omega)
        self.sc = sc = di.sc
        self.T = T = TWO_PI / Om
        self.F = _drive_force(self.sy.p, self.sy.B, Om)
        self.Nrm = st.normal
        self.D = st.offset / sc
        self.law = [int(c) for c in st.law]
        self.kc, self.cc, self.pe = [float(x) for x in st.kc], [float(x) for x in st.cc], [float(x) for x in st.pe]
        self.comp = [c in (LAW_LINEAR, LAW_HYSTERETIC_HERTZ) for c in self.law]
        self.cmask = sum(1 << k for k in range(self.ns) if self.comp[k])
        cp = core.compliant
        vfall, vfac = (cp.vfall, cp.vfac) if cp is not None else (0.0, 0.0)
        Beq = _drive_displacement(self.sy.p, float(self.sy.B), Om)
        self.vfl = [_floor(Om, Beq, float(st.normal[k] @ self.sy.gam), vfall, vfac) if self.comp[k] else 0.0
                    for k in range(self.ns)]
        self.vr = [0.0] * self.ns
        self.inside = self.relaxed = 0
        self.n_record, self.spp = int(n_record), int(spp)
        self.scale = float(scale)
        self.contacts_of = contacts_of
        self.stop_codes = stop_codes
        self.t_rec = n_transient * T
        self.t_end = (n_transient + n_record) * T
        self.ts = self.t_rec + np.arange(n_record * spp) * (T / spp)
        self.samples = np.zeros((self.ts.size, 2))
        self.filled = np.zeros(self.ts.size, bool)
        self.ext = [np.inf, -np.inf]
        self.minima = []
        self.imp_t, self.imp_v, self.imp_k, self.rows = [], [], [], []
        self.cs = np.zeros((self.ns, 5))     # open contacts: t_entry, peak force, penetration, work, U (row units)
        self.crow = [-1] * self.ns
        self.n_imp = self.n_chat = 0
        self.stuck_time = self.contact_time = 0.0
        self.max_imp = di.max_impacts_per_period * (n_transient + n_record)
        self.vscale = None
        self.turn = -1          # a Newton stop left by a slow rebound (its gap's minimum is an event)
        self.modamp = np.zeros(self.N)
        self.max_step = min(T / 16, di.max_step or np.inf)

    # ------------------------------------------------------------------ the run
    def go(self, state0):
        N, ns, hs, sc = self.N, self.ns, self.hs, self.sc
        s0 = np.asarray(state0, dtype=float)
        self.s0 = s0
        y = s0[:2 * N] / sc
        mask = self.core.held_set_of(s0[2 * N]) if s0.shape[0] > 2 * N else 0
        H, C = mask & ~self.cmask, mask & self.cmask
        if not hs.valid[H]:
            H = 0
        t = 0.0
        if H:
            y = self.project(H, y)
        elif C == 0:
            for j in range(ns):   # at rest on a Newton stop: held if the contact force presses
                if self.comp[j]:
                    continue
                gj = self.Nrm[j] @ y[:N] - self.D[j]
                if gj >= -ROUND * (abs(self.D[j]) + np.abs(self.Nrm[j]) @ np.abs(y[:N])) and self.Nrm[j] @ y[N:] <= 0:
                    H = 1 << j
                    y = self.project(H, y)
                    break
        ph = _Phase(self, H, 0)
        z = ph.of(y)
        for k in range(ns):
            if C >> k & 1:
                self.open_contact(k, ph, z, 0.0, record=False, start=True)
            elif self.comp[k] and ph.gap(k, z)[0] > 0.0:
                self.inside |= 1 << k
        guard = 0
        while t < self.t_end:
            guard += 1
            if guard > 20 * self.max_imp + 100:
                return self.failed("no progress")
            ph = _Phase(self, H, C)
            z = ph.of(y)
            event = self.due(ph, t, z)
            if event is None:
                out = self.integrate(ph, t, z)
                if isinstance(out, str):
                    return self.failed(out)
                t, y, *event = out
                if event[0] is None:
                    continue      # the end of the run
            kind, j = event
            # ---- the transition
            if kind == TURN:
                self.turn = -1      # strictly below the stop again: its gap's event sees the return
            elif kind == RELEASE:
                H &= ~(1 << j)
            elif kind in (EXIT, EXIT_DAMPING):
                C &= ~(1 << j)
                self.close_contact(j, t)
                if ph.gap(j, ph.of(y))[0] > 0.0:
                    self.inside |= 1 << j
                    if kind == EXIT_DAMPING:
                        self.relaxed |= 1 << j
            elif kind == GAP_DOWN:
                self.inside &= ~(1 << j)
                self.relaxed &= ~(1 << j)
            elif self.comp[j]:     # an entry (through the gap, or inside the stop)
                C |= 1 << j
                self.inside &= ~(1 << j)
                self.relaxed &= ~(1 << j)
                ph = _Phase(self, H, C)
                self.open_contact(j, ph, ph.of(y), t, record=True)
                if self.n_imp > self.max_imp:
                    return self.failed("too many impacts")
            else:
                H, y = self.impact(j, H, C, t, y)
                if H is None:
                    return self.failed("too many impacts")
        return self.trajectory(y, H, C)

    def project(self, H, y):
        """The state on the constraint of held set ``H`` (position and velocity)."""
        ph = _Phase(self, H, 0)
        return ph.full(ph.of(y)[:, None])[:, 0]

    def moving(self, H):
        return [bool(self.hs.moves[H, j]) for j in range(self.ns)]

    # ------------------------------------------------------------------ transitions due now
    def due(self, ph, t, z):
        """A transition due at the phase's start, ``(kind, stop)``, or None (module docstring)."""
        H, C, ns = ph.H, ph.C, self.ns
        # a held stop whose force pulls away now (or is zero and about to): released at once; the force
        # as the release event computes it, so that the two never disagree at round-off
        for j in range(ns):
            if H >> j & 1:
                lam = ph.lam(j, t, z)
                if lam > 0.0 or (lam == 0.0 and ph.lam(j, t, z, 1e-9 * self.T) > 0.0):
                    return RELEASE, j
        moving = self.moving(H)
        for j in range(ns):
            if H >> j & 1 or not (C >> j & 1 or moving[j]):
                continue
            g, gd = ph.gap(j, z)
            gsize = abs(g) + self.sc * abs(self.D[j])
            if C >> j & 1:
                # a contact whose force is not positive now (or zero and falling) ends at once
                if self.law[j] == LAW_LINEAR:
                    f = ph.exit_value(j, g, gd, EXIT)
                    rate = self.kc[j] * gd + self.cc[j] * ph.gap_acc(j, t, z)
                    if _now(f, rate, abs(self.kc[j] * g) + abs(self.cc[j] * gd), t) < 0:
                        return EXIT, j
                else:
                    fac = ph.exit_value(j, g, gd, EXIT_DAMPING)
                    rate = self.cc[j] * ph.gap_acc(j, t, z) / self.vr[j]
                    if _now(fac, rate, 1.0 + abs(fac - 1.0), t) < 0:
                        return EXIT_DAMPING, j
                    if _now(g, gd, gsize, t) < 0:
                        return EXIT, j
            elif self.inside >> j & 1:
                # inside a compliant stop without contact: below it again, or a contact now
                if g <= 0.0 or _now(g, gd, gsize, t) < 0:
                    return GAP_DOWN, j
                s, r0, r1, size = ph.sign(j, g, gd)
                if _now(s, r0 * gd + r1 * ph.gap_acc(j, t, z), size, t) > 0:
                    return ENTRY_INSIDE, j
            elif self.comp[j]:
                # touching a compliant stop: approaching, or pressed onto it (a Newton stop's
                # impact is its gap's event, at a phase's start too)
                at = _now(g, gd, gsize, t)
                if at > 0 or (at == 0 and ph.gap_acc(j, t, z) > 0.0):
                    return GAP, j
        return None

    # ------------------------------------------------------------------ one phase
    def integrate(self, ph, t, z):
        """Integrate the phase from ``(t, z)`` to its first terminal event or the end of the run.

        Returns
        -------
        (t1, y1, kind, stop) or str
            The end time, the full scaled state there, the event's kind and stop (None, -1 at the
            end of the run); a string: ``solve_ivp``'s failure.
        """
        from scipy.integrate import solve_ivp

        di, N = self.di, self.N
        fns, kinds = ph.events(self.moving(ph.H))
        max_step = self.max_step
        cap = [k for k in range(self.ns) if (ph.C | self.inside) >> k & 1]
        for k in cap:
            max_step = min(max_step, CONTACT_STEP * self.contact_time_scale(k))
        atol = di.atol
        if ph.cl:
            atol = np.full(ph.L, di.atol)
            atol[2 * ph.m:] = 1e300     # the works: quadratures on the state's steps, not controlled
        sol = solve_ivp(ph.rhs, (t, self.t_end), z, method=di.solver, rtol=di.rtol, atol=atol, events=fns,
                        dense_output=True, max_step=max_step)
        if sol.status < 0:
            return sol.message
        t1 = float(sol.t[-1])
        kind, stop = None, -1
        if sol.status == 1:
            for i, (kd, j) in enumerate(kinds):
                if fns[i].terminal and sol.t_events[i].size and sol.t_events[i][-1] == t1:
                    kind, stop = kd, j
                    break

        def Zf(tt):
            return ph.full(np.atleast_2d(sol.sol(tt).T).T)

        self.record_segment(ph, t, t1, sol, kinds, Zf)
        y1 = Zf(np.array([t1]))[:, 0] if ph.P is not None else sol.y[:2 * N, -1].copy()
        return t1, y1, kind, stop

    def contact_time_scale(self, k):
        """Time scale of stop ``k``'s isolated contact (:func:`~vibeam.models.core.laws.contact_scales`;
        Kelvin-Voigt: ``1 / omega_c``)."""
        nn = 1.0 / float(self.st.m_eff[k])
        if self.law[k] == LAW_LINEAR:
            return 1.0 / math.sqrt(self.kc[k] * nn)
        return _scales(self.law[k], self.kc[k], self.pe[k], nn, max(self.vr[k], self.vfl[k]))[1]

    def record_segment(self, ph, t, t1, sol, kinds, Zf):
        """Samples, extremes, times held and in contact, and the open contacts' records of one
        integrated phase ``[t, t1]``."""
        sc, scale, N, T, sv = self.sc, self.scale, self.N, self.T, self.sy.sensor
        if t1 > self.t_rec:
            dt = t1 - max(t, self.t_rec)
            if ph.H:
                self.stuck_time += dt
            if ph.C:
                self.contact_time += dt
        sel = (self.ts >= t - 1e-12 * T) & (self.ts <= t1) & ~self.filled
        if np.any(sel):
            Z = Zf(self.ts[sel])
            self.samples[sel, 0] = sv @ Z[:N] * sc / scale
            self.samples[sel, 1] = sv @ Z[N:] * sc / scale
            self.filled[sel] = True
            self.modamp = np.maximum(self.modamp, np.max(np.abs(Z[:N]), axis=1) * sc)
        for i, (kd, j) in enumerate(kinds):
            if kd == SENSOR:
                for te in sol.t_events[i]:
                    if te >= self.t_rec:
                        self.extreme(te, float(sv @ Zf(np.array([te]))[:N, 0]) * sc / scale)
            elif kd == MAX_PEN:
                for ye in sol.y_events[i]:
                    self.cs[j, 2] = max(self.cs[j, 2], ph.gap(j, ye)[0])
            elif kd == PEAK_FORCE:
                for ye in sol.y_events[i]:
                    self.cs[j, 1] = max(self.cs[j, 1], ph.force(j, *ph.gap(j, ye)))
        z1 = sol.y[:, -1]
        for i, j in enumerate(ph.cl):
            g, gd = ph.gap(j, z1)
            self.cs[j, 1] = max(self.cs[j, 1], ph.force(j, g, gd))
            self.cs[j, 2] = max(self.cs[j, 2], g)
            self.cs[j, 3] += z1[2 * ph.m + i] * sc * sc

    def extreme(self, te, qv):
        """A value of the sensor at time ``te`` of the record (an extreme): the extremes and the
        periods' minima."""
        self.minima.append((te, qv))
        self.ext[0] = min(self.ext[0], qv)
        self.ext[1] = max(self.ext[1], qv)

    # ------------------------------------------------------------------ contacts and impacts
    def open_contact(self, k, ph, z, t, record, start=False):
        """A compliant contact of stop ``k`` begins at ``t`` (state ``z`` of a phase with it in contact)."""
        g, U = ph.gap(k, z)
        if start:
            # a contact the run starts inside of: its entry is not seen (laws.start_velocity)
            v = _start_velocity(self.law[k], g, U, self.kc[k], self.pe[k], 1.0 / float(self.st.m_eff[k]))[0]
            self.vr[k] = max(v, self.vfl[k])
        else:
            self.vr[k] = max(U if self.law[k] == LAW_HYSTERETIC_HERTZ else abs(U), self.vfl[k])
        self.cs[k] = (t, ph.force(k, g, U), g, 0.0, U)
        self.crow[k] = -1
        if not record:
            return
        self.n_imp += 1
        if t >= self.t_rec:
            self.crow[k] = len(self.rows)
            self.imp_t.append(t - self.t_rec)
            self.imp_v.append(U / self.scale)
            self.imp_k.append(k)
            self.rows.append([np.nan] * 5)

    def close_contact(self, k, t):
        """Stop ``k``'s contact ends at ``t``: its record row (per unit effective mass, ``q`` units)."""
        r = self.crow[k]
        if r < 0:
            return
        me, s = float(self.st.m_eff[k]), self.scale
        c = self.cs[k]
        self.rows[r] = [t - c[0], c[1] / (me * s), c[2] / s, c[3] / (me * s * s), c[4] / s]
        self.crow[k] = -1

    def acc_along(self, d, t, y, C):
        """Acceleration along ``d`` of the free flow at full scaled state ``y``, the compliant
        stops in contact ``C`` pushing."""
        N, sy = self.N, self.sy
        a = float(d @ (sy.gam * self.F / self.sc * math.sin(self.Om * t) - sy.c * y[N:] - sy.k * y[:N]))
        for k in range(self.ns):
            if C >> k & 1:
                g = self.sc * (float(self.Nrm[k] @ y[:N]) - self.D[k])
                gd = self.sc * float(self.Nrm[k] @ y[N:])
                a -= float(d @ self.Nrm[k]) * _force(self.law[k], g, gd, self.kc[k], self.cc[k], self.pe[k],
                                                     self.vr[k]) / self.sc
        return a

    def impact(self, hit, H, C, t, y):
        """Newton's law on stop ``hit`` at ``t`` (held set ``H`` kept): impulse along ``d = Pi_H n``;
        returns the new held set and state (``(None, y)``: too many impacts)."""
        N, hs, st, sc = self.N, self.hs, self.st, self.sc
        y = y.copy()
        if H:
            d, me = hs.dirn[H, hit], float(hs.meff[H, hit])
        else:
            d, me = self.Nrm[hit], float(st.m_eff[hit])
        Um = float(self.Nrm[hit] @ y[N:])
        if self.vscale is None:
            self.vscale = max(abs(Um), 1e-300)
        self.n_imp += 1
        if self.n_imp > self.max_imp:
            return None, y
        rec = t >= self.t_rec
        ke0 = 0.5 * float(y[N:] @ y[N:])
        if rec:
            self.imp_t.append(t - self.t_rec)
            self.imp_v.append(max(Um, 0.0) * sc / self.scale)
            self.imp_k.append(hit)
            self.extreme(t, float(self.sy.sensor @ y[:N]) * sc / self.scale)
        H2 = H | (1 << hit)
        can_hold = bool(hs.valid[H2])
        law = self.contacts_of(hit)
        if Um <= self.di.chatter_velocity * self.vscale and can_hold:
            y = self.project(H2, y)
            if rec:
                self.newton_row(hit, ke0 - 0.5 * float(y[N:] @ y[N:]), Um)
            if self.acc_along(d, t, y, C) > 0:
                H = H2
                self.n_chat += rec
        else:
            Up = newton_restitution(Um, law.coefficient(Um * sc))
            y[N:] += d * me * (Up - Um)
            if rec:
                self.newton_row(hit, ke0 - 0.5 * float(y[N:] @ y[N:]), Um)
            if Up == 0.0 and can_hold and self.acc_along(d, t, y, C) > 0:   # plastic into a pressing contact
                y = self.project(H2, y)
                H = H2
        self.turn = -1
        if not H >> hit & 1:
            # a slow rebound, whose flight may end inside one step (solve_ivp compares signs at step
            # ends only): the gap's minimum is an event, after which the stop is strictly ahead
            up = -float(self.Nrm[hit] @ y[N:])
            if 2.0 * up <= abs(self.acc_along(self.Nrm[hit], t, y, C)) * self.max_step:
                self.turn = hit
        return H, y

    def newton_row(self, k, de, Um):
        """The contact row of a Newton impact: no duration, an impulse (no finite force), no
        penetration, the kinetic energy removed ``de`` (scaled) per unit effective mass of the stop."""
        me, s, sc = float(self.st.m_eff[k]), self.scale, self.sc
        self.rows.append([0.0, np.nan, 0.0, de * sc * sc / (me * s * s), max(Um, 0.0) * sc / s])

    # ------------------------------------------------------------------ the result
    def trajectory(self, y, H, C):
        n_record, spp, T, t_rec = self.n_record, self.spp, self.T, self.t_rec
        # each period over its closed interval: its samples and the value at its end
        q = np.append(self.samples[:, 0], float(self.sy.sensor @ y[:self.N]) * self.sc / self.scale)
        pmin = np.zeros(n_record)
        if n_record:
            pmin = np.minimum(q[:-1].reshape(n_record, spp).min(axis=1), q[spp::spp])
        for te, qv in (self.minima if n_record else []):
            kp = min(max(int((te - t_rec) // T), 0), n_record - 1)
            pmin[kp] = min(pmin[kp], qv)
        status = "chatter" if self.n_chat else ("sticking" if self.stuck_time > 0 else "ok")
        two = self.ns > 1
        ik = np.array(self.imp_k, np.int64)
        rows = np.array(self.rows, float).reshape(-1, 5)
        extra = {}
        if self.stop_codes is not None:
            codes = np.asarray(self.stop_codes, np.int64)
            ik = codes[ik] if ik.size else ik
            per = np.zeros(int(codes.max()) + 1)
            np.add.at(per, ik, 1.0)
            extra["stop_impacts"] = per
        contact_stops = None
        if self.cmask:
            closed = np.isfinite(rows[:, 0])    # a contact still open at the end has no row
            rows = rows[closed]
            contact_stops = ik[closed] if two else None
            extra["contact_fraction"] = float(self.contact_time / (n_record * T)) if n_record else 0.0
        ext = self.ext
        return Trajectory(
            Omega=self.Om, samples=self.samples, samples_per_period=spp,
            impact_times=np.array(self.imp_t), impact_velocities=np.array(self.imp_v), n_impacts=len(self.imp_t),
            contacts=rows, contact_stops=contact_stops,
            impact_stops=ik if two else None, n_impacts_lower=int(np.sum(ik == 1)) if two else 0,
            q_min=float(min(ext[0], q.min())) if n_record else float(ext[0]),
            q_max=float(max(ext[1], q.max())) if n_record else float(ext[1]), period_min=pmin,
            status=status, message="" if status == "ok" else f"stuck {self.stuck_time:.4g} of the window",
            final_state=np.concatenate([y * self.sc, [float(held_code(H | C))]]),
            extra={"mode_amplitudes": self.modamp,
                   "stuck_fraction": float(self.stuck_time / (n_record * T)) if n_record else 0.0, **extra})

    def failed(self, msg):
        n_record, spp = self.n_record, self.spp
        return Trajectory(Omega=self.Om, samples=np.full((n_record * spp, 2), np.nan), samples_per_period=spp,
                          impact_times=np.zeros(0), impact_velocities=np.zeros(0), n_impacts=0,
                          q_min=np.nan, q_max=np.nan, status="failed", message=msg,
                          final_state=np.asarray(self.s0, float).copy(),
                          extra={"mode_amplitudes": np.full(self.N, np.nan), "stuck_fraction": np.nan})


# ============================================================================ method ``direct`` of an N-mode scene
class BeamODESolver:
    """Method ``direct`` of an N-mode scene (the beam's, a structure's), every contact law: the same
    modal system and stops integrated by :func:`scipy.integrate.solve_ivp` (the reference solver),
    through :class:`DirectIntegrator` (the stops in system units,
    :func:`vibeam.models.builders.matrices.modal_scene`).

    Newton stops: a terminal event at each contact (a gap ``n^T eta - Delta`` rising) and the same
    impact law; held on stops, the constrained system ``eta = eta_c + Psi zeta`` (its whole damping
    ``Psi^T C Psi``, non-diagonal for damping that is not proportional) with a terminal
    event on each contact force ``lambda`` turning positive; an impact with ``U- < chatter_velocity``
    times the first impact speed into a pressing contact acceleration ends a chatter (plastic
    projection, then sticking): a crude chatter model, fine for a reference of impacting/sticking
    orbits, not for resolving chatter.  Compliant stops (Kelvin-Voigt, hysteretic Hertz): the
    contact forces in the equations while in contact, with terminal events at the entries and exits
    of :mod:`vibeam.models.core.contact_phase` and the work done on each stop integrated with the
    state; the contacts' rows are the event method's (:func:`vibeam.models.core.event.trajectory`).

    The state is scaled by ``1 / (L sqrt(m_eff))`` so that it is of the order of ``U / L``.
    ``q_min/q_max`` use the sensor-velocity zero crossings (events) and the samples.  Steps are
    capped at ``T / 16`` (and at a twentieth of a compliant contact's time scale) so that sign
    changes of the event functions are not stepped over (solve_ivp only checks signs at step ends:
    detection is not guaranteed).

    Parameters
    ----------
    scene : Scene
        As :class:`~vibeam.models.core.event.BeamEventSolver`'s.
    solver : str
        ``solve_ivp`` method (DOP853 default).
    rtol, atol : float or None
        Tolerances (``atol`` in units of ``q``); None: 1e-9 and 1e-12 with Newton stops, 1e-11 and
        1e-15 with a compliant stop (:data:`vibeam.models.core.direct.RTOL_IMPULSIVE` ...).
    max_impacts_per_period : int
        More impacts and contact entries per period on average: ``failed``.
    chatter_velocity : float
    max_step : float or None
        Largest step (nondimensional time; default ``T / 16``).
    """

    name = "direct"
    time_domain = True
    chunk_periods = 200   # a restart of solve_ivp changes the result at the level of rtol

    def __init__(self, scene: Scene, solver: str = "DOP853", rtol: float | None = None,
                 atol: float | None = None, max_impacts_per_period: int = 200,
                 chatter_velocity: float = 1e-6, max_step: float | None = None):
        self.scene = scene
        sy = scene.system
        self.n_modes = int(sy.omega.shape[0])
        self._scale = float(sy.coordinate_scale)
        self._codes = stop_codes(scene.stops)
        self._laws = [st.law for st in scene.stops]
        self._rest = rest_state(scene)
        m_eff = float(1.0 / np.sum(np.asarray(sy.contacts[0], float) ** 2))
        self.max_step = max_step
        self.solver = solver
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.chatter_velocity = float(chatter_velocity)
        self._direct = DirectIntegrator(EventIntegrator(scene), self._scale * math.sqrt(m_eff), solver, rtol, atol,
                                        self.max_impacts_per_period, self.chatter_velocity, max_step)
        self.rtol = self._direct.rtol
        self.atol = self._direct.atol

    def settings(self) -> dict:
        return dict(solver=self.solver, rtol=self.rtol, atol=self.atol, n_modes=self.n_modes,
                    chatter_velocity=self.chatter_velocity)

    def point(self, Omega, state0, n_transient, n_record, samples_per_period=64) -> Trajectory:
        """One forcing frequency by the one direct solver (:mod:`vibeam.models.core.direct`) on the
        beam's modal system and stops; ``state0`` as :meth:`vibeam.models.core.event.BeamEventSolver.point` (its last entry
        the held code of the Newton stops held and the compliant stops in contact)."""
        s0 = self._rest.copy() if state0 is None else np.asarray(state0, dtype=float)
        laws = self._laws
        return self._direct.run(float(Omega), s0, n_transient, n_record, samples_per_period, self._scale,
                                lambda k: laws[k], self._codes)
