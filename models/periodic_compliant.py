"""Shooting problem of the SDOF oscillator on a Kelvin-Voigt (piecewise-linear) stop.

Contract: :mod:`vibeam.models.periodic` (driven unchanged by :mod:`vibeam.models.continuation`).
``P^n`` is evaluated by the steps of the exact compliant event kernel
(:func:`vibeam.models.sdof_compliant.advance`: certified entry / exit location, closed-form
phase flows), so a shot follows the same orbit as method ``event`` of the law; its exact first
derivatives are composed over the phases (paper Sec. 4.2; Leine & Nijmeijer 2004, Ch. 7;
di Bernardo et al. 2008, Sec. 2.5).

Model (nondimensional; :mod:`vibeam.models.sdof_compliant`)::

    free     q'' + 2 beta q' + q = F sin(Omega t)                          delta = q - Delta < 0
    contact  q'' + 2 beta q' + q + k_c delta + c_c delta' = F sin(Omega t)  delta >= 0, f > 0

``F = Omega^2 B``, ``f = k_c delta + c_c delta'`` the contact force.  The contact region is
``{delta >= 0, f > 0}`` (the stop is massless and cannot pull: force-zero separation).  Each
phase ``r`` is a linear oscillator with the closed-form flow ``x(t_b) = Phi_r(t_b - t_a) (x_a
- P_r(t_a)) + P_r(t_b)`` (``P_r`` its periodic particular state, ``Phi_r`` its state-transition
matrix).

Derivatives.  With ``Y = d x(t) / d(x0, p)`` at fixed time:

* within a phase, ``Y <- Phi_r Y + dP_r/dp(t_b) - Phi_r dP_r/dp(t_a)`` (``p`` = ``Omega``,
  ``B`` or ``Delta``: they enter the particular state only, ``Phi_r`` does not depend on them);
* at an event ``h(x, p) = 0`` with fields ``f-`` before and ``f+`` after (states continuous):
  ``dt = -(h_x Y + h_p) / (h_x f-)`` and ``Y+ = Y- + (f- - f+) dt``;

  - entry through ``delta = 0`` (``h = q - Delta``, ``h_x f- = delta' = v > 0``): the field
    jumps by ``f+ - f- = (0, -c_c v)`` (the dashpot acts at once), so ``Y+ = S Y-`` with the
    saltation matrix ``S = [[1, 0], [-c_c, 1]]`` (``det S = 1``) and ``Y_Delta+ = Y_Delta- - (0,
    c_c (Y_{q,Delta} - 1))``.  The velocity cancels: ``S`` stays finite at a grazing entry
    (``v -> 0``), unlike Newton's law whose saltation has ``1 / v-``;
  - exit (``f`` down through 0) and re-entry inside the stop (``delta > 0``, ``f`` up through
    0): the force is zero there, the two fields agree, ``S = I`` and nothing jumps;
* the window ends at ``n T = 2 pi n / Omega``: ``Y_Omega += f(x(nT)) d(nT)/dOmega``.

Hence ``det M = exp(-2 beta n T - c_c T_c)`` (Liouville; ``T_c`` the time in contact over the
``n`` periods), the check of the tests.

Bifurcations.  Folds, period doublings and Neimark-Sacker points come from the multipliers
as for the CoR problem.  A *grazing* of a compliant stop is the birth of a contact: a
free-flight maximum of ``delta`` touches the stop, or (inside the stop after an exit) a maximum
of the force touches zero, or a contact splits in two where an interior minimum of its force
touches zero.  ``Shot.apex_gap`` is the largest of those extremes in gap units (``delta``,
``f / k_c``, ``-f / k_c``), negative on an admissible orbit and zero at such a grazing; the
entry rates ``Shot.impact_velocities`` (``delta'`` at an entry through ``delta = 0``, ``f' /
k_c`` at a re-entry) vanish where a contact dies.  The engine locates both as it does for
impacts (signature = contacts per orbit).  Unlike an impact, a shot never becomes singular at
a grazing (``S`` above is finite); the map's correction there is of order ``eps^(3/2)``
(short contact of duration ``~ sqrt(eps)`` and force ``~ eps``), so branches pass it with a
mild corner.

Not handled (a shot with ``status = "failed"`` and a message, never a crash): overdamped
phases, more than ``max_events`` contacts in a shot, a two-sided scene (refused when built).
"""
from __future__ import annotations

import math

import numpy as np

from .periodic import Shot
from .sdof_compliant import (CONTACT, EV_ENTRY, EV_EXIT, FREE, advance, envelope, phase_eval, phase_params,
                             upcross)
from .sdof_flow import transition

TWO_PI = 2.0 * math.pi

#: continuation parameters of the compliant SDOF problem (they enter the particular states only)
PARAMETERS = ("Omega", "B", "Delta")


def phase_stm(s: float, pp) -> np.ndarray:
    """State-transition matrix ``Phi_r(s)`` of a phase (:func:`~vibeam.models.sdof_compliant.phase_params`
    row ``pp``: ``w_p``, ``b_p``, ...), shape (2, 2), for the state ``(q, q')``, ``s >= 0``."""
    w, b = pp[0], pp[1]
    p11, p12, p21, p22 = transition(w * s, b)
    return np.array([[1.0 + p11, p12 / w], [w * p21, 1.0 + p22]])


def particular_sensitivities(pp, F, B, Omega, kc, phase):
    """``(X, dX)`` of a phase's particular response ``q_e + Im(X e^{i Omega t})``:
    ``X = a + i b = F / (w^2 - Omega^2 + 2 i b_p w Omega)`` and ``dX`` (3,) its derivatives by
    ``(Omega, B, Delta)`` (``F = Omega^2 B``; ``Delta`` moves only ``q_e``)."""
    w, bp = pp[0], pp[1]
    D = w * w - Omega * Omega + 2j * bp * w * Omega
    X = F / D
    dX = np.zeros(3, complex)
    dX[0] = 2.0 * Omega * B / D - F * (-2.0 * Omega + 2j * bp * w) / (D * D)
    dX[1] = Omega * Omega / D
    return X, dX


def _dP(t, X, dX, dqe, Omega, j):
    """``d P_r(t) / d p_j`` at fixed ``t``, ``j`` in (Omega, B, Delta): the particular state
    ``P_r = (q_e + Im(X e^{i Omega t}), Im(i Omega X e^{i Omega t}))``."""
    e = complex(math.cos(Omega * t), math.sin(Omega * t))
    if j == 0:
        dz = (dX[0] + 1j * t * X) * e
        return np.array([dz.imag, (1j * X * e + 1j * Omega * dz).imag])
    if j == 1:
        dz = dX[1] * e
        return np.array([dz.imag, (1j * Omega * dz).imag])
    return np.array([dqe, 0.0])


class CompliantSDOFShooting:
    """Shooting problem ``P^n`` of the SDOF oscillator on a Kelvin-Voigt stop (contract:
    :mod:`vibeam.models.periodic`; module docstring).

    Parameters
    ----------
    model : vibeam.models.SDOF
        With ``contact`` a :class:`vibeam.models.compliant.LinearContact` (one stop).
    parameter : {"Omega", "B", "Delta"}
        Continuation parameter (native, nondimensional).
    Omega : float, optional
        Forcing frequency; required unless ``parameter == "Omega"``.
    max_events : int, optional
        Most contacts in one shot; beyond it the shot has ``status = "failed"``.

    Raises
    ------
    ValueError
        For another law, a second stop, an unknown parameter, a missing ``Omega`` or an
        overdamped contact phase.
    """

    dim = 2
    starts = ("linear",)

    def __init__(self, model, parameter: str = "Omega", Omega: float | None = None, max_events: int = 4096):
        law = getattr(model, "contact", None)
        if law is None or getattr(law, "name", "") != "linear":
            raise ValueError("CompliantSDOFShooting needs a stop with contact law \"linear\"")
        if getattr(model, "two_sided", False):
            raise ValueError("continuation with a compliant law follows one stop (no second stop)")
        if parameter not in PARAMETERS:
            raise ValueError(f"parameter {parameter!r} cannot be continued with contact law \"linear\"; "
                             f"allowed: {', '.join(PARAMETERS)}")
        if parameter != "Omega" and Omega is None:
            raise ValueError(f"continuation in {parameter!r} needs the forcing frequency Omega")
        self.model = model
        self.parameter = parameter
        self.index = PARAMETERS.index(parameter)
        self.Omega = None if Omega is None else float(Omega)
        self.value = (float(Omega) if Omega is not None else math.nan) if parameter == "Omega" \
            else float(getattr(model, parameter))
        self.kc = float(law.stiffness)
        self.cc = float(law.damping)
        self.max_events = int(max_events)
        wc = math.sqrt(1.0 + self.kc)
        if not (2.0 * float(model.beta) + self.cc) / (2.0 * wc) < 1.0:
            raise ValueError("the contact phase is overdamped: lower [model.contact] damping_ratio or raise R")

    def params(self, p: float):
        """``(B, Delta, Omega)`` with the continuation parameter set to ``p``."""
        m = self.model
        v = {"Omega": self.Omega, "B": float(m.B), "Delta": float(m.Delta)}
        v[self.parameter] = float(p)
        return v["B"], v["Delta"], v["Omega"]

    # ------------------------------------------------------------------ the shot
    def shot(self, x0, p, n) -> Shot:
        """``P^n(x0; p)`` with monodromy and ``d/dp`` (module docstring).

        Parameters
        ----------
        x0 : array_like, shape (2,)
            ``(q, q')`` at forcing phase 0 (in contact if ``q >= Delta`` and the force
            ``k_c (q - Delta) + c_c q' > 0``).
        p : float
            Value of the continuation parameter.
        n : int
            Forcing periods.

        Returns
        -------
        Shot
            ``impact_times`` / ``impact_velocities``: contact entries and their rates;
            ``extra``: ``x_all_p`` (2, 3) ``d x / d(Omega, B, Delta)``, ``contact_time`` (time
            in contact over the ``n`` periods), ``contacts`` (k, 4) duration, peak force,
            largest penetration and energy given to the stop of the contacts that begin and end
            inside the window, ``entry_kind`` (0 through ``delta = 0``, 1 re-entry inside the
            stop).
        """
        beta = float(self.model.beta)
        B, Delta, Omega = self.params(p)
        kc, cc = self.kc, self.cc
        n = int(n)
        q, v = float(x0[0]), float(x0[1])
        if not (Omega is not None and Omega > 0.0 and math.isfinite(q) and math.isfinite(v)
                and math.isfinite(B) and math.isfinite(Delta) and n >= 1):
            return _failed(f"parameters or state out of range (Omega {Omega}, n {n}, x0 ({q}, {v}))")
        if beta == 0.0 and Omega == 1.0:
            return _failed("undamped exact resonance: no periodic particular solution")
        F = Omega * Omega * B
        P = phase_params(beta, F, Omega, Delta, kc, cc)
        if not (P[1, 1] < 1.0 and np.all(np.isfinite(P))):
            return _failed("overdamped or resonant phase")
        T = TWO_PI / Omega
        t_end = n * T
        hmax = (TWO_PI / P[0, 0] / 16.0, TWO_PI / P[1, 0] / 16.0)
        part = [particular_sensitivities(P[r], F, B, Omega, kc, r) for r in (0, 1)]
        dqe = (0.0, kc / (1.0 + kc))
        j = self.index

        def field(r, q, v, t):
            w, b, qe = P[r, 0], P[r, 1], P[r, 2]
            return np.array([v, F * math.sin(Omega * t) - 2.0 * b * w * v - w * w * (q - qe)])

        def carry(Y, r, ta, tb):
            """Y over the segment [ta, tb] of phase r (closed form)."""
            Phi = phase_stm(tb - ta, P[r])
            Y = Phi @ Y
            X, dX = part[r]
            for k in range(3):
                Y[:, 2 + k] += _dP(tb, X, dX, dqe[r], Omega, k) - Phi @ _dP(ta, X, dX, dqe[r], Omega, k)
            return Y

        Y = np.zeros((2, 5))
        Y[0, 0] = Y[1, 1] = 1.0
        d = np.empty(6)
        dl0 = q - Delta
        phase = CONTACT if (dl0 >= 0.0 and kc * dl0 + cc * v > 0.0) else FREE
        ex = np.array([q, q, np.inf])
        cs = np.zeros(4)
        t = 0.0
        phi = 0.0
        t_seg = 0.0                   # start of the current phase segment
        t_con = 0.0
        apex = -np.inf
        entries, rates, kinds, contacts = [], [], [], []
        open_contact = None           # (t_entry) of a contact begun inside the window
        steps = 0
        max_steps = 200 * n * (1 + int(math.ceil(P[1, 0]))) + 64 * self.max_events
        while t_end - t > 1e-15 * T:
            steps += 1
            if steps > max_steps:
                return _failed(f"more than {max_steps} steps in {n} period(s)")
            rem = t_end - t
            pp = P[phase]
            h = min(rem, hmax[phase])
            below = q - Delta < 0.0          # an entry from here is through delta = 0
            s, ev = advance(phase, h, phi, q, v, pp, kc, cc, Omega, Delta, True, ex, cs, d, kc, cc, 0.0)
            if s > 0.0:
                apex = max(apex, self._extremes(phase, s, phi, q, v, pp, Omega, Delta))
            phase_eval(s, phi, q, v, pp, Omega, Delta, d)
            q_new, v_new = Delta + d[0], d[1]
            if phase == CONTACT:
                t_con += s
            t += s
            phi = (phi + Omega * s) % TWO_PI
            q, v = q_new, v_new
            if ev == EV_ENTRY:
                if len(entries) >= self.max_events:
                    return _failed(f"more than {self.max_events} contacts in {n} period(s)")
                Y = carry(Y, FREE, t_seg, t)
                t_seg = t
                if below:
                    # saltation of the dashpot's jump (module docstring): finite at any v > 0
                    Y[1, :] -= cc * Y[0, :]
                    Y[1, 4] += cc          # h_Delta = -1
                    kinds.append(0)
                    rates.append(v)
                else:
                    kinds.append(1)
                    rates.append((kc * d[1] + cc * d[2]) / kc)
                entries.append(t)
                cs[0] = t
                cs[1] = kc * d[0] + cc * d[1]
                cs[2] = d[0]
                cs[3] = 0.0
                open_contact = t
                phase = CONTACT
            elif ev == EV_EXIT:
                Y = carry(Y, CONTACT, t_seg, t)
                t_seg = t
                if open_contact is not None:
                    contacts.append((t - open_contact, cs[1], cs[2], cs[3]))
                open_contact = None
                phase = FREE
        Y = carry(Y, phase, t_seg, t_end)
        # the window ends at n T = 2 pi n / Omega (forcing phase 0)
        Y[:, 2] += field(phase, q, v, t_end) * (-t_end / Omega)
        ex[0] = min(ex[0], q)
        ex[1] = max(ex[1], q)
        M = Y[:, :2].copy()
        xp_all = Y[:, 2:].copy()
        if not (np.all(np.isfinite(M)) and np.all(np.isfinite(xp_all))):
            return _failed("non-finite derivatives")
        con = np.array(contacts, float).reshape(-1, 4)
        return Shot(x=np.array([q, v]), M=M, x_p=xp_all[:, j].copy(), impact_times=np.array(entries, float),
                    impact_velocities=np.array(rates, float), q_min=float(ex[0]), q_max=float(ex[1]),
                    apex_gap=float(apex), stuck_time=0.0, status="ok", message="", Omega=Omega, gap=Delta,
                    extra={"x_all_p": xp_all, "contact_time": t_con, "contacts": con,
                           "entry_kind": np.array(kinds, np.int64), "in_contact_end": phase == CONTACT})

    def _extremes(self, phase, s, phi, q, v, pp, Omega, Delta):
        """Largest grazing indicator inside a step (module docstring): free-flight maxima of
        ``delta`` below the stop, maxima of ``f / k_c`` inside it, and ``-f / k_c`` at the
        interior minima of the force in contact; ``-inf`` if none."""
        kc, cc = self.kc, self.cc
        A = envelope(phi, q, v, pp, Omega)
        d = np.empty(6)
        best = -np.inf
        if phase == FREE:
            for (c0, c1, c2, kind) in ((0.0, -1.0, 0.0, 0), (0.0, -kc, -cc, 1)):
                u = 0.0
                while True:
                    u = upcross(c0, c1, c2, u, s, phi, q, v, pp, Omega, Delta, A, d)
                    if u < 0.0 or u >= s:
                        break
                    phase_eval(u, phi, q, v, pp, Omega, Delta, d)
                    if kind == 0 and d[0] < 0.0:
                        best = max(best, d[0])
                    elif kind == 1 and d[0] > 0.0:
                        best = max(best, (kc * d[0] + cc * d[1]) / kc)
        else:
            u = 0.0
            while True:
                u = upcross(0.0, kc, cc, u, s, phi, q, v, pp, Omega, Delta, A, d)
                if u < 0.0 or u >= s:
                    break
                phase_eval(u, phi, q, v, pp, Omega, Delta, d)
                best = max(best, -(kc * d[0] + cc * d[1]) / kc)
        return best

    # ------------------------------------------------------------------ starting orbits
    def start(self, kind: str, p: float, n: int = 1):
        """Initial state at forcing phase 0: ``linear``, the non-contacting steady state
        ``P_free(0) = (b, Omega a)`` where its amplitude stays below the stop.

        Returns ``(x0 or None, reason)``."""
        from .sdof_flow import particular_coefficients

        if kind != "linear":
            raise ValueError(f"unknown start {kind!r}; allowed: {', '.join(self.starts)}")
        B, Delta, Omega = self.params(p)
        a, b = particular_coefficients(float(self.model.beta), Omega * Omega * B, Omega)
        C = math.hypot(a, b)
        if not C < Delta:
            return None, (f"the non-contacting orbit does not exist: its amplitude C = {C:.6g} reaches the "
                          f"stop Delta = {Delta:.6g} at {self.parameter} = {p:.6g}")
        return np.array([b, Omega * a]), ""


def _failed(message: str) -> Shot:
    nan2 = np.full(2, np.nan)
    return Shot(x=nan2, M=np.full((2, 2), np.nan), x_p=nan2.copy(), impact_times=np.zeros(0),
                impact_velocities=np.zeros(0), q_min=np.nan, q_max=np.nan, status="failed", message=message)
