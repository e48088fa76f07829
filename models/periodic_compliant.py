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

Two stops.  A lower Kelvin-Voigt stop at ``q = -Delta_lower`` (its own ``k_l``, ``c_l``) is
followed as the two-stop kernel (:func:`~vibeam.models.sdof_compliant.compliant_kernel_stops`)
does it: its entry scan, contact phase and exit run in the mirrored frame ``q~ = -q``,
``phi~ = phi + pi``, and a free step ends at the earlier of the two stops' entries.  The
derivatives are carried in the physical frame over three phases (free, upper contact, lower
contact ``q'' + (2 beta + c_l) q' + (1 + k_l) q + k_l Delta_l = F sin(Omega t)``).  At an entry
into the lower stop (``h = -q - Delta_l``, ``h_x f- = -v > 0``, jump ``f+ - f- = (0, -c_l v)``)
the signs of the normal cancel and the saltation is again ``S = [[1, 0], [-c_l, 1]]``;
``h_p = 0`` (``Delta`` moves the upper stop only).  ``det M = exp(-2 beta n T - c_c T_up - c_l
T_low)``.  ``apex_gap`` is the larger of the two stops' grazing indicators (each in its own
frame), and ``extra["impact_stops"]`` gives the stop of each contact (0 upper, 1 lower).

Not handled (a shot with ``status = "failed"`` and a message, never a crash): overdamped
phases, more than ``max_events`` contacts in a shot; a second stop with a law other than
``linear`` (refused when built).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contact import DAMPING, EXPONENT, OFFSET, SIGN, STIFFNESS
from .periodic import Shot
from .registry import family_laws
from .sdof_compliant import (CONTACT, EV_ENTRY, EV_EXIT, EV_NONE, FREE, mirror_in, mirror_out, advance, envelope,
                             phase_eval, phase_params, upcross)
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


def particular_sensitivities(pp, F, B, Omega):
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
        With ``contact`` a :class:`vibeam.models.compliant.LinearContact`; optionally a second
        (lower) stop, ``Delta_lower``, whose law (``contact_lower`` or ``contact``) is linear too.
    parameter : {"Omega", "B", "Delta"}
        Continuation parameter (native, nondimensional).
    Omega : float, optional
        Forcing frequency; required unless ``parameter == "Omega"``.
    max_events : int, optional
        Most contacts in one shot; beyond it the shot has ``status = "failed"``.

    Raises
    ------
    ValueError
        For another law (on either stop), an unknown parameter, a missing ``Omega`` or an
        overdamped contact phase.
    """

    dim = 2
    starts = ("linear",)

    def __init__(self, model, parameter: str = "Omega", Omega: float | None = None, max_events: int = 4096):
        law = getattr(model, "contact", None)
        if law is None or getattr(law, "family", "") != "kelvin_voigt":
            raise ValueError(f"CompliantSDOFShooting needs a stop with contact {family_laws('kelvin_voigt')}")
        self.two = bool(getattr(model, "two_sided", False))
        if self.two:
            low = model.stops()[1].law
            if getattr(low, "family", "") != "kelvin_voigt":
                raise ValueError(f"continuation with two stops needs contact {family_laws('kelvin_voigt')} on the lower stop too "
                                 f"([model.contact_lower] law = {getattr(low, 'name', '?')!r}); use method = \"event\"")
            self.Dl = float(model.Delta_lower)
            self.kcl = float(low.stiffness)
            self.ccl = float(low.damping)
            if not (2.0 * float(model.beta) + self.ccl) / (2.0 * math.sqrt(1.0 + self.kcl)) < 1.0:
                raise ValueError("the lower stop's contact phase is overdamped: lower [model.contact_lower] "
                                 "damping_ratio or raise R")
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
        if self.two:
            return self._shot_two(x0, p, n)
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
        part = [particular_sensitivities(P[r], F, B, Omega) for r in (0, 1)]
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

    def _shot_two(self, x0, p, n) -> Shot:
        """``P^n`` with a second (lower) Kelvin-Voigt stop at ``q = -Delta_lower`` (module
        docstring, "Two stops"): the steps of :func:`~vibeam.models.sdof_compliant.compliant_kernel_stops`
        (the lower stop's entry scan, contact phase and exit in the mirrored frame ``q~ = -q``,
        ``phi~ = phi + pi``) with the derivatives carried in the physical frame over three
        phases (free, upper contact, lower contact)."""
        beta = float(self.model.beta)
        B, Delta, Omega = self.params(p)
        kc, cc, kl, cl, Dl = self.kc, self.cc, self.kcl, self.ccl, self.Dl
        n = int(n)
        q, v = float(x0[0]), float(x0[1])
        if not (Omega is not None and Omega > 0.0 and math.isfinite(q) and math.isfinite(v)
                and math.isfinite(B) and math.isfinite(Delta) and n >= 1):
            return _failed(f"parameters or state out of range (Omega {Omega}, n {n}, x0 ({q}, {v}))")
        if not Delta + Dl > 0.0:
            return _failed(f"the stops overlap: Delta + Delta_lower = {Delta + Dl} must be > 0")
        if beta == 0.0 and Omega == 1.0:
            return _failed("undamped exact resonance: no periodic particular solution")
        F = Omega * Omega * B
        P = phase_params(beta, F, Omega, Delta, kc, cc)
        PL = phase_params(beta, F, Omega, Dl, kl, cl)       # the lower stop's mirrored frame
        if not (P[1, 1] < 1.0 and PL[1, 1] < 1.0 and np.all(np.isfinite(P)) and np.all(np.isfinite(PL))):
            return _failed("overdamped or resonant phase")
        # physical-frame rows: free, upper contact, lower contact q'' + 2 b w q' + w^2 (q - q_e)
        # = F sin(Omega t) with q_e = -k_l Delta_l / (1 + k_l) (the mirror of PL's contact row)
        LOWER = 2
        Po = np.vstack([P, PL[1:2]])
        Po[2, 2] = -PL[1, 2]
        T = TWO_PI / Omega
        t_end = n * T
        hmax = (TWO_PI / P[0, 0] / 16.0, TWO_PI / P[1, 0] / 16.0, TWO_PI / PL[1, 0] / 16.0)
        part = [particular_sensitivities(Po[r], F, B, Omega) for r in range(3)]
        dqe = (0.0, kc / (1.0 + kc), 0.0)     # Delta moves the upper stop only
        j = self.index

        def field(r, q, v, t):
            w, b, qe = Po[r, 0], Po[r, 1], Po[r, 2]
            return np.array([v, F * math.sin(Omega * t) - 2.0 * b * w * v - w * w * (q - qe)])

        def carry(Y, r, ta, tb):
            Phi = phase_stm(tb - ta, Po[r])
            Y = Phi @ Y
            X, dX = part[r]
            for k in range(3):
                Y[:, 2 + k] += _dP(tb, X, dX, dqe[r], Omega, k) - Phi @ _dP(ta, X, dX, dqe[r], Omega, k)
            return Y

        Y = np.zeros((2, 5))
        Y[0, 0] = Y[1, 1] = 1.0
        d = np.empty(6)
        dl0, dll = q - Delta, -q - Dl
        if dl0 >= 0.0 and kc * dl0 + cc * v > 0.0:
            phase = CONTACT
        elif dll >= 0.0 and kl * dll - cl * v > 0.0:
            phase = LOWER
        else:
            phase = FREE
        ex = np.array([q, q, np.inf])
        exm = np.empty(3)
        cs = np.zeros(4)
        t = phi = t_seg = 0.0
        t_con = [0.0, 0.0]
        apex = -np.inf
        entries, rates, kinds, sides, contacts = [], [], [], [], []
        open_contact = None
        steps = 0
        max_steps = 200 * n * (1 + int(math.ceil(max(P[1, 0], PL[1, 0])))) + 64 * self.max_events
        while t_end - t > 1e-15 * T:
            steps += 1
            if steps > max_steps:
                return _failed(f"more than {max_steps} steps in {n} period(s)")
            h = min(t_end - t, hmax[phase])
            phl = (phi + math.pi) % TWO_PI
            below = (q - Delta < 0.0, -q - Dl < 0.0)   # an entry from here is through the gap's zero
            if phase == FREE:
                # the lower stop's entry scan first (mirrored frame, nothing recorded), then the
                # upper stop's up to it (records the extremes), as the two-stop kernel
                s_l, ev_l = advance(FREE, h, phl, -q, -v, PL[0], kl, cl, Omega, Dl, False, ex, cs, d, kl, cl, 0.0)
                s, ev = advance(FREE, s_l if ev_l != EV_NONE else h, phi, q, v, P[0], kc, cc, Omega, Delta, True,
                                ex, cs, d, kc, cc, 0.0)
                side = 0
                if ev == EV_NONE and ev_l != EV_NONE:
                    s, ev, side = s_l, ev_l, 1
                if s > 0.0:
                    apex = max(apex, self._extremes(FREE, s, phi, q, v, P[0], Omega, Delta),
                               self._extremes(FREE, s, phl, -q, -v, PL[0], Omega, Dl, kl, cl))
            elif phase == CONTACT:
                side = 0
                s, ev = advance(CONTACT, h, phi, q, v, P[1], kc, cc, Omega, Delta, True, ex, cs, d, kc, cc, 0.0)
                if s > 0.0:
                    apex = max(apex, self._extremes(CONTACT, s, phi, q, v, P[1], Omega, Delta))
            else:
                side = 1
                mirror_in(ex, exm)
                s, ev = advance(CONTACT, h, phl, -q, -v, PL[1], kl, cl, Omega, Dl, True, exm, cs, d, kl, cl, 0.0)
                mirror_out(ex, exm)
                if s > 0.0:
                    apex = max(apex, self._extremes(CONTACT, s, phl, -q, -v, PL[1], Omega, Dl, kl, cl))
            if s < 0.0:
                return _failed("event location failed")
            if side == 0:
                phase_eval(s, phi, q, v, P[0] if phase == FREE else P[1], Omega, Delta, d)
                q_new, v_new = Delta + d[0], d[1]
            else:
                phase_eval(s, phl, -q, -v, PL[0] if phase == FREE else PL[1], Omega, Dl, d)
                q_new, v_new = -(Dl + d[0]), -d[1]
            if phase != FREE:
                t_con[phase - 1] += s
            t += s
            phi = (phi + Omega * s) % TWO_PI
            q, v = q_new, v_new
            if ev == EV_ENTRY:
                if len(entries) >= self.max_events:
                    return _failed(f"more than {self.max_events} contacts in {n} period(s)")
                Y = carry(Y, FREE, t_seg, t)
                t_seg = t
                k_, c_ = (kc, cc) if side == 0 else (kl, cl)
                if below[side]:
                    # dashpot saltation S = [[1, 0], [-c, 1]] on either stop (the signs of the
                    # lower stop's normal cancel); h_p = -1 for Delta on the upper stop only
                    Y[1, :] -= c_ * Y[0, :]
                    if side == 0:
                        Y[1, 4] += cc
                    kinds.append(0)
                    rates.append(d[1])
                else:
                    kinds.append(1)
                    rates.append((k_ * d[1] + c_ * d[2]) / k_)
                entries.append(t)
                sides.append(side)
                cs[0] = t
                cs[1] = k_ * d[0] + c_ * d[1]
                cs[2] = d[0]
                cs[3] = 0.0
                open_contact = t
                phase = CONTACT if side == 0 else LOWER
            elif ev == EV_EXIT:
                Y = carry(Y, phase, t_seg, t)
                t_seg = t
                if open_contact is not None:
                    contacts.append((t - open_contact, cs[1], cs[2], cs[3]))
                open_contact = None
                phase = FREE
        Y = carry(Y, phase, t_seg, t_end)
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
                    extra={"x_all_p": xp_all, "contact_time": t_con[0] + t_con[1],
                           "contact_time_upper": t_con[0], "contact_time_lower": t_con[1], "contacts": con,
                           "entry_kind": np.array(kinds, np.int64), "impact_stops": np.array(sides, np.int64),
                           "in_contact_end": phase != FREE, "contact_side_end": phase})

    def _extremes(self, phase, s, phi, q, v, pp, Omega, Delta, kc=None, cc=None):
        """Largest grazing indicator inside a step (module docstring): free-flight maxima of
        ``delta`` below the stop, maxima of ``f / k_c`` inside it, and ``-f / k_c`` at the
        interior minima of the force in contact; ``-inf`` if none.  ``kc, cc``: the stop's law
        (default the upper stop's; the lower stop's in its mirrored frame)."""
        if kc is None:
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
        if getattr(self, "two", False) and not C < self.Dl:
            return None, (f"the non-contacting orbit does not exist: its amplitude C = {C:.6g} reaches the "
                          f"lower stop Delta_lower = {self.Dl:.6g} at {self.parameter} = {p:.6g}")
        return np.array([b, Omega * a]), ""


def _failed(message: str) -> Shot:
    nan2 = np.full(2, np.nan)
    return Shot(x=nan2, M=np.full((2, 2), np.nan), x_p=nan2.copy(), impact_times=np.zeros(0),
                impact_velocities=np.zeros(0), q_min=np.nan, q_max=np.nan, status="failed", message=message)


# ============================================================================ the modal beam
#: continuation parameters of the compliant beam problem (they enter the forced response only)
BEAM_PARAMETERS = ("Omega", "base_amplitude_m")


class CompliantBeamShooting:
    """Shooting problem ``P^n`` of the modal FE beam (any number of modes) on a Kelvin-Voigt
    stop (contract: :mod:`vibeam.models.periodic`).

    The shot is one run of the exact compliant beam kernel
    (:func:`vibeam.models.beam_compliant.beam_compliant_kernel`: eigendecomposed ``2N x 2N``
    phase flows, certified entry and exit) from ``x0`` over ``n`` periods, recording its
    contact entries and durations; the derivatives are then composed along those events with
    the same exact flows, as for the SDOF (module docstring):

    * a phase ``p`` with state matrix ``A_p = V diag(lambda) V^-1`` flows as ``z(t_b) =
      Phi_p (z(t_a) - z_p(t_a)) + z_p(t_b)``, ``Phi_p(s) = Re(V diag(e^{lambda s}) V^-1)``,
      ``z_p(t) = Im(Z_p e^{i Omega t}) + z_e,p``, ``Z_p = (i Omega - A_p)^-1 b Omega^2 Y``;
    * entry through ``g = w^T eta - Delta_C = 0``: the dashpot's force ``c w w^T eta'`` appears
      at once, saltation ``S = I - c [[0, 0], [w w^T, 0]]`` (velocity-free, ``det S = 1``);
    * exit and re-entry inside the stop (contact force zero): ``S = I``;
    * ``d/dOmega`` of ``Z_p`` (``F = Omega^2 Y`` and the resolvent), of the phase ``Omega t`` and
      of the end time ``n T``; ``d/dY`` of ``Z_p``.

    ``det M = exp(trace(A_free) n T - c |w|^2 T_c)``.  The first exit of a contact already
    open at the section is located by the kernel's certified scan
    (:func:`~vibeam.models.beam_compliant.bupcross`) on the contact force.  ``apex_gap`` (m) is
    the largest interior free-flight maximum of ``g`` below the stop (or of the force over
    ``k_c`` inside it, or minus the force's interior minima in contact over ``k_c``), as for the
    SDOF.

    A second (lower) Kelvin-Voigt stop at ``U = -Delta_C,lower`` (``model.two_sided``, its law
    ``model.lower_law``, linear too) adds the third phase of
    :func:`~vibeam.models.beam_compliant.beam_compliant_kernel` (state matrix with
    ``- k_l w w^T``, ``- c_l w w^T``), which the shot runs instead; an entry into it (gap ``-U -
    Delta_l``, normal velocity ``-U'``) has the same saltation ``I - c_l [[0, 0], [w w^T, 0]]``
    (the normal's signs cancel in ``w w^T``), so ``det M = exp(trace(A_free) n T - |w|^2 (c
    T_up + c_l T_low))``; ``apex_gap`` watches both stops and ``extra["impact_stops"]`` gives
    the stop of each contact (0 upper, 1 lower).

    Parameters
    ----------
    model : vibeam.models.beam_compliant.CompliantBeamModel
    parameter : {"Omega", "base_amplitude_m"}
    Omega : float, optional
        Forcing frequency ``f / f_ref``; required unless ``parameter == "Omega"``.
    steps_per_fundamental : int, optional
        As :class:`~vibeam.models.beam_compliant.CompliantBeamEventSolver`.
    max_contacts : int, optional
        Most contacts in one shot (beyond: ``status = "failed"``).

    Raises
    ------
    ValueError
        For another law (on either stop), an unknown parameter or a missing ``Omega``.
    """

    fidelity = "beam"
    starts = ("linear",)

    def __init__(self, model, parameter: str = "Omega", Omega: float | None = None,
                 steps_per_fundamental: int = 16, max_contacts: int = 4096, rtol: float = 1e-12):
        from .beam_compliant import ensure_eig

        if getattr(model, "contact", None) is None or \
                any(getattr(st.law, "kind", "") != "compliant" for st in model.stops()):
            raise ValueError("CompliantBeamShooting needs a beam model with compliant stops (contact law "
                             "of the Kelvin-Voigt or hysteretic-Hertz family)")
        self.two = bool(getattr(model, "two_sided", False))
        if parameter not in BEAM_PARAMETERS:
            raise ValueError(f"parameter {parameter!r} cannot be continued with a compliant stop on the "
                             f"beam; allowed: {', '.join(BEAM_PARAMETERS)}")
        if parameter != "Omega" and Omega is None:
            raise ValueError(f"continuation in {parameter!r} needs the forcing frequency Omega")
        ensure_eig(model)
        self.model = model
        self.parameter = parameter
        self.Omega = None if Omega is None else float(Omega)
        self.value = (float(Omega) if Omega is not None else math.nan) if parameter == "Omega" \
            else float(getattr(model, parameter))
        self.dim = 2 * model.n_modes
        self.state_scale = model.length_m * math.sqrt(model.m_eff)
        self.steps_per_fundamental = int(steps_per_fundamental)
        self.max_contacts = int(max_contacts)
        self.rtol = float(rtol)
        self._key = None
        self._data = None

    def model_at(self, p: float):
        if self.parameter == "Omega" or p == self.value:
            return self.model
        import copy
        m = copy.copy(self.model)
        setattr(m, self.parameter, float(p))
        return m

    def data(self, p: float) -> dict:
        """Phase data at ``p`` (cached for the last ``p``): the kernel's arrays and the
        forced-response derivatives."""
        from .beam_compliant import phase_data, phase_steps, velocity_floor
        from .sdof_compliant import HC_V_FLOOR

        if self._key == float(p):
            return self._data
        m = self.model_at(p)
        Om = float(p) if self.parameter == "Omega" else self.Omega
        A, b, b0, kc, cc = m.phase_matrices()
        pd = phase_data(m, Om)
        n2 = self.dim
        Y = m.base_amplitude_m
        F = Om * Om * Y
        dZ = np.empty((A.shape[0], 2, n2), complex)        # [phase, (Omega, Y)]
        for r in range(A.shape[0]):
            Rinv = np.linalg.inv(1j * Om * np.eye(n2) - A[r])
            Zu = Rinv @ b
            dZ[r, 0] = 2.0 * Om * Y * Zu - 1j * F * (Rinv @ Zu)
            dZ[r, 1] = Om * Om * Zu
        lam, V, W = pd[0], pd[1], pd[2]
        w = m.contact_row
        kl, cl, Dl = m.lower_stop_params()
        # per stop: whether its contact phase is integrated (Hunt-Crossley) and its law's kernel
        # values (sign, offset, k, p, chi); the free-flight scans watch k g + c g' (Kelvin-Voigt)
        # or g itself (Hunt-Crossley: the force's sign at entry)
        rows = m.kernel_stops()
        hc = [not getattr(st.law, "linear_phase", False) for st in m.stops()]
        scan = [(1.0, 0.0) if hc[k] else ((kc, cc) if k == 0 else (kl, cl)) for k in range(len(hc))]
        wG = abs(float(w @ m.participation))
        Yb = m.base_amplitude_m
        dvf = np.array([HC_V_FLOOR * Yb * wG, HC_V_FLOOR * Om * wG]) if Yb * wG > 0.0 else np.zeros(2)
        D = dict(m=m, Om=Om, A=A, b=b * F, b0=b0, kc=kc, cc=cc, pd=pd, dZ=dZ, lam=lam, V=V, W=W,
                 hmax=phase_steps(m, self.steps_per_fundamental), F=F, Yb=Yb, kl=kl, cl=cl, Dl=Dl, stops=rows,
                 hc=hc, scan=scan, v_floor=velocity_floor(m, Om), dv_floor=dvf)
        self._key, self._data = float(p), D
        return D

    @staticmethod
    def _stm(D, r, s):
        return ((D["V"][r] * np.exp(D["lam"][r] * s)) @ D["W"][r]).real

    @staticmethod
    def _zp(D, r, t):
        Z, ze = D["pd"][3][r], D["pd"][4][r]
        return (Z * complex(math.cos(D["Om"] * t), math.sin(D["Om"] * t))).imag + ze

    def _dzp(self, D, r, t, j):
        """``d z_p / d p_j`` at fixed ``t`` (j = 0 Omega, 1 Y)."""
        Om = D["Om"]
        e = complex(math.cos(Om * t), math.sin(Om * t))
        if j == 0:
            return ((D["dZ"][r, 0] + 1j * t * D["pd"][3][r]) * e).imag
        return (D["dZ"][r, 1] * e).imag

    def _field(self, D, r, z, t):
        return D["A"][r] @ z + D["b"] * math.sin(D["Om"] * t) + D["b0"][r]

    def shot(self, x0, p, n: int = 1) -> Shot:
        """``P^n(x0; p)`` with monodromy and ``d/dp`` (class docstring).

        Parameters
        ----------
        x0 : array_like, shape (2N,)
            ``(eta, eta')`` at forcing phase 0 (in contact where ``g >= 0`` and the force
            ``k g + c g' > 0``).
        p : float
            Parameter value (native units).
        n : int
            Forcing periods.

        Returns
        -------
        Shot
            ``impact_times``/``impact_velocities``: contact entries and their rates (``U' / L``
            per unit nondimensional time); ``q_min``/``q_max`` of the sensor (``/ L``);
            ``apex_gap`` in m; ``extra``: ``x_all_p`` (2N, 2) ``d x / d(Omega, Y)``,
            ``contact_time``, ``contacts`` (k, 4) per contact of the window (kernel units).
        """
        from .beam_compliant import beam_compliant_kernel

        n = int(n)
        x0 = np.asarray(x0, float)
        if not (np.all(np.isfinite(x0)) and math.isfinite(float(p)) and n >= 1) or \
                (self.parameter == "Omega" and not p > 0.0):
            return failed_shot(self.dim, f"parameters or state out of range ({self.parameter} = {p}, n = {n})")
        D = self.data(p)
        m, Om, kc, cc = D["m"], D["Om"], D["kc"], D["cc"]
        lamA, VA, WA, ZA, zeA, PU, PS, bU, bS, gU, gS = D["pd"][:11]
        N = m.n_modes
        n2 = 2 * N
        w = m.contact_row
        DC = m.gap_contact_m
        L = m.length_m
        T = TWO_PI / Om
        t_end = n * T
        g0 = float(w @ x0[:N]) - DC
        u0 = float(w @ x0[N:])
        kl, cl, Dl = D["kl"], D["cl"], D["Dl"]
        hc = D["hc"]
        if (hc[0] and g0 >= 0.0) or (self.two and hc[1] and -g0 - DC - Dl >= 0.0):
            return failed_shot(self.dim, "the section lies inside the stop: a Hunt-Crossley contact depends on its "
                                       "entry velocity, which is not part of the state (eta, eta')")
        phase0 = CONTACT if (g0 >= 0.0 and kc * g0 + cc * u0 > 0.0) else FREE
        if self.two and phase0 == FREE and -g0 - DC - Dl >= 0.0 and kl * (-g0 - DC - Dl) - cl * u0 > 0.0:
            phase0 = 2                 # in contact with the lower stop (gap -U - Delta_l)
        ns = 4
        cap = self.max_contacts
        samples = np.zeros((n * ns, 2))
        pmin = np.zeros(n)
        imp_t = np.zeros(cap)
        imp_v = np.zeros(cap)
        con = np.full((cap, 5), np.nan)
        msamp = np.zeros((0, n2))
        z = x0.copy()
        imp_k = np.zeros(cap, np.int64)
        status, n_rec, smin, smax, ph_end, n_con, t_con, n_steps, _ = beam_compliant_kernel(
            Om, lamA, VA, WA, ZA, zeA, PU, PS, w, m.sensor_row, bU, bS, gU, gS, D["stops"], m.k_nd, m.c_nd,
            m.participation, D["F"], D["v_floor"], z, phase0, 0, n, 1, ns, D["hmax"], cap, 200000 * n, samples, pmin,
            imp_t, imp_v, con, imp_k, msamp)
        if status != 0 or n_rec > cap:
            return failed_shot(self.dim, f"the event kernel gave up after {n_con} contacts / {n_steps} steps in "
                                       f"{n} period(s)")
        # the phase sequence: [start phase, events (t, kind)], kind 1 entry, 2 exit
        # events (t, kind, stop): kind 1 entry, 2 exit; stop 0 upper, 1 lower
        events = []
        for r in range(n_rec):
            events.append((float(imp_t[r]), 1, int(imp_k[r])))
            if math.isfinite(con[r, 0]):
                events.append((float(imp_t[r] + con[r, 0]), 2, int(imp_k[r])))
        if phase0 != FREE:
            t_first = events[0][0] if events else t_end
            tx = self._first_exit(D, x0, t_first, phase0 - 1)
            if tx is not None:
                events.append((tx, 2, phase0 - 1))
        events.sort()
        # alternation check (entry after free, exit after contact)
        ph = phase0
        for _, kind, _k in events:
            if (kind == 1) != (ph == FREE):
                return failed_shot(self.dim, "contact events do not alternate (inconsistent event record)")
            ph = 1 + _k if kind == 1 else FREE
        if ph != int(ph_end):
            return failed_shot(self.dim, "the event record does not end in the kernel's phase")
        # compose the tangent along the phases (exact flows), with the state rebuilt on them
        J = np.zeros((n2, n2 + 2))
        J[:, :n2] = np.eye(n2)
        zc = x0.copy()
        ta = 0.0
        ph = phase0
        apex = -np.inf
        rates, entries, contacts, t_c, sides = [], [], [], 0.0, []
        t_cs = [0.0, 0.0]
        t_open = None
        vr, dvr = 0.0, None      # a Hunt-Crossley contact's damping scale and its sensitivity
        inside = [False, False]  # free inside a Hunt-Crossley stop after an exit by its damping factor
        for (tb, kind, side) in events + [(t_end, 0, 0)]:
            if ph != FREE and hc[ph - 1]:
                # a Hunt-Crossley contact phase: its variational equations, integrated
                zc, J, msg = self._hc_phase(D, ph - 1, zc, J, ta, tb, vr, dvr)
                if msg:
                    return failed_shot(self.dim, msg)
            else:
                Phi = self._stm(D, ph, tb - ta)
                za = zc
                zc = Phi @ (zc - self._zp(D, ph, ta)) + self._zp(D, ph, tb)
                J = Phi @ J
                for j in range(2):
                    J[:, n2 + j] += self._dzp(D, ph, tb, j) - Phi @ self._dzp(D, ph, ta, j)
                apex = max(apex, self._extremes(D, ph, za, ta, tb))
            if ph != FREE:
                t_c += tb - ta
                t_cs[ph - 1] += tb - ta
            if kind == 1 and hc[side]:
                # entry into a Hunt-Crossley stop: the force is zero there (S = I), but v_r is the
                # entry velocity, whose sensitivity enters the contact's variational equations
                sg, off = (1.0, DC) if side == 0 else (-1.0, Dl)
                g = sg * float(w @ zc[:N]) - off
                U = sg * float(w @ zc[N:])
                if inside[side] and g > 1e-9 * max(abs(off), 1e-12):
                    return failed_shot(self.dim, "re-entry inside the stop after a damping-factor exit (depends on "
                                               "the previous contact's entry velocity): not represented")
                if not U > 0.0:
                    return failed_shot(self.dim, f"contact entry with non-positive velocity {U:.3g} (inconsistent "
                                               f"record)")
                a_m = sg * float(w @ self._field(D, FREE, zc, tb)[N:])
                dt = -sg * (w @ J[:N, :]) / U
                if U > D["v_floor"]:
                    vr, dvr = U, sg * (w @ J[N:, :]) + a_m * dt
                else:
                    vr, dvr = D["v_floor"], np.concatenate([np.zeros(n2), D["dv_floor"]])
                entries.append(tb)
                sides.append(side)
                rates.append(U / L)
                t_open = tb
                ph = 1 + side
            elif kind == 1:
                # the entered stop's gap, normal velocity and law (lower: gap -U - Delta_l)
                sg, off, k_, c_ = (1.0, DC, kc, cc) if side == 0 else (-1.0, Dl, kl, cl)
                g = sg * float(w @ zc[:N]) - off
                U = sg * float(w @ zc[N:])
                entries.append(tb)
                sides.append(side)
                if g <= 1e-9 * max(abs(off), self.state_scale * 1e-3 / math.sqrt(m.m_eff)) and U > 0.0:
                    # saltation of the dashpot's jump; the same on the lower stop (the signs of
                    # its normal -w cancel in w w^T)
                    J[N:, :] -= c_ * np.outer(w, w @ J[:N, :])
                    rates.append(U / L)
                else:
                    a_n = sg * float(w @ self._field(D, FREE, zc, tb)[N:])
                    rates.append((k_ * U + c_ * a_n) / k_ / L)
                t_open = tb
                ph = 1 + side
            elif kind == 2:
                if t_open is not None:
                    r = len(contacts)
                    contacts.append(con[r if r < n_rec else 0, :4])
                    if hc[side]:
                        # an exit by the damping factor leaves the section inside the stop (g > 0,
                        # beyond the round-off of a gap exit: 1e-6 of the contact's penetration)
                        sg, off = (1.0, DC) if side == 0 else (-1.0, Dl)
                        inside[side] = sg * float(w @ zc[:N]) - off > 1e-6 * abs(con[r if r < n_rec else 0, 2])
                t_open = None
                ph = FREE
            ta = tb
        if ph != FREE and hc[ph - 1]:
            # the window ends inside a Hunt-Crossley contact: the field with its force
            ws, off, kh, pe, chi = self._hc_law(D, ph - 1)
            g = float(ws @ zc[:N]) - off
            fld = self._field(D, FREE, zc, t_end)
            fld[N:] -= ws * (kh * max(g, 0.0) ** pe * (1.0 + chi * float(ws @ zc[N:]) / vr))
        else:
            fld = self._field(D, ph, z, t_end)
        J[:, n2] += fld * (-t_end / Om)
        jcol = n2 + BEAM_PARAMETERS.index(self.parameter)
        M = J[:, :n2].copy()
        if not np.all(np.isfinite(J)):
            return failed_shot(self.dim, "non-finite derivatives")
        extra = {"x_all_p": J[:, n2:].copy(), "contact_time": t_c, "rebuilt_state": zc,
                 "contacts": np.array(contacts, float).reshape(-1, 4), "in_contact_end": ph != FREE}
        if self.two:
            extra.update(impact_stops=np.array(sides, np.int64), contact_time_upper=t_cs[0],
                         contact_time_lower=t_cs[1], contact_side_end=ph)
        return Shot(x=z.copy(), M=M, x_p=J[:, jcol].copy(), impact_times=np.array(entries, float),
                    impact_velocities=np.array(rates, float), q_min=float(smin / L), q_max=float(smax / L),
                    apex_gap=float(apex), stuck_time=0.0, status="ok", message="", Omega=Om, gap=m.Delta,
                    extra=extra)

    def _hc_law(self, D, k):
        """``(w_k, Delta_k, k, p, chi)`` of Hunt-Crossley stop ``k`` in kernel units (``w_k`` its
        normal row: the contact row, negated for the lower stop)."""
        row = D["stops"][k]
        return row[SIGN] * self.model.contact_row, row[OFFSET], row[STIFFNESS], row[EXPONENT], row[DAMPING]

    def _hc_phase(self, D, k, zc, J, ta, tb, vr, dvr):
        """The state and the tangent ``J`` (2N, 2N + 2) carried through a Hunt-Crossley contact
        with stop ``k`` from ``ta`` to ``tb`` (the kernel's exit, or the window's end) by
        :func:`vibeam.models.hc_contact.hc_variational_rhs` (DOP853 at ``self.rtol``); returns
        ``(zc, J, message)``, a non-empty message when the integration failed."""
        from scipy.integrate import solve_ivp

        from .hc_contact import hc_variational_rhs

        if not tb > ta:
            return zc, J, ""
        m = D["m"]
        N = m.n_modes
        n2 = 2 * N
        ws, off, kh, pe, chi = self._hc_law(D, k)
        wn = math.sqrt(float(ws @ ws))
        pen = ((pe + 1.0) * vr * vr / (2.0 * kh * wn * wn)) ** (1.0 / (pe + 1.0))
        atol = np.concatenate([np.full(N, 1e-13 * pen / wn), np.full(N, 1e-13 * vr / wn),
                               np.full(n2 * (n2 + 2), 1e-13 * max(float(np.max(np.abs(J))), 1.0))])
        sol = solve_ivp(hc_variational_rhs, (ta, tb), np.concatenate([zc, J.ravel()]), method="DOP853",
                        rtol=self.rtol, atol=atol, first_step=min(1e-3 * pen / vr, tb - ta),
                        args=(vr, dvr, off, kh, pe, chi, m.k_nd, m.c_nd, m.participation, ws, D["Om"], D["Yb"]))
        if sol.status < 0:
            return zc, J, f"the contact phase's integration failed: {sol.message}"
        y = sol.y[:, -1]
        return y[:n2].copy(), y[n2:].reshape(n2, n2 + 2).copy(), ""

    def _signal(self, D, r, z, ta, rowc):
        """Coefficients ``(al, be, ga)`` of ``rowc . z(ta + s)`` in phase ``r`` from ``z`` at ``ta``."""
        from .beam_compliant import modal_coordinates

        phi = (D["Om"] * ta) % TWO_PI
        a = np.empty(self.dim, np.complex128)
        modal_coordinates(np.ascontiguousarray(z), D["W"][r], D["pd"][3][r], D["pd"][4][r], phi, a)
        al = (rowc @ D["V"][r]) * a
        return al, complex(rowc @ D["pd"][3][r]), float(rowc @ D["pd"][4][r]), phi

    def _first_exit(self, D, z, t_max, side=0):
        """Exit time of a contact open at the section: the force ``k g + c g'`` down through 0
        (the kernel's certified scan, in its contact step lengths); ``side`` 1: the lower stop
        (gap ``-U - Delta_l``, its law)."""
        from .beam_compliant import signal_combo, bupcross

        N = self.model.n_modes
        rowU = np.concatenate([self.model.contact_row, np.zeros(N)])
        r = CONTACT + side
        if side == 0:
            al, be, ga, phi = self._signal(D, r, z, 0.0, rowU)
            ga -= self.model.gap_contact_m
        else:
            al, be, ga, phi = self._signal(D, r, z, 0.0, -rowU)
            ga -= D["Dl"]
        kc, cc = D["scan"][side]
        lam = D["lam"][r]
        Om = D["Om"]
        al2 = np.empty_like(al)
        h = D["hmax"][r]
        s = 0.0
        while s < t_max:
            # the kernel's steps: the coefficients carried as a_j e^{lambda_j s} (decayed modes drop
            # out of the derivative bounds), the scan restarted on each step
            e = min(s + h, t_max)
            als = al * np.exp(lam * s)
            b2, g2 = signal_combo(-kc, -cc, 0.0, als, lam, be, ga, Om, al2)
            r = bupcross(al2, lam, b2, g2, (phi + Om * s) % TWO_PI, Om, 0.0, e - s, 1e-13 * TWO_PI / Om)
            if r >= 0.0:
                return s + r
            s = e
        return None

    def _extremes(self, D, r, z, ta, tb):
        """Grazing indicator (m) inside the phase segment ``[ta, tb]`` (class docstring): the
        larger of the two stops' in free flight with a lower stop; a Hunt-Crossley contact
        phase is not scanned."""
        if tb <= ta or (r != FREE and D["hc"][r - 1]):
            return -np.inf
        N = self.model.n_modes
        rowU = np.concatenate([self.model.contact_row, np.zeros(N)])
        best = -np.inf
        # the stops watched in this phase: both in free flight, the one in contact otherwise
        sides = ((0, 1) if self.two else (0,)) if r == FREE else (r - 1,)
        for side in sides:
            best = max(best, self._extremes_stop(D, r, z, ta, tb, rowU, side))
        return best

    def _extremes_stop(self, D, r, z, ta, tb, rowU, side):
        """:meth:`_extremes` of one stop (``side`` 1: the lower one, gap ``-U - Delta_l``)."""
        from .beam_compliant import signal_combo, signal_derivatives, bupcross

        if side == 0:
            al, be, ga, phi = self._signal(D, r, z, ta, rowU)
            ga -= self.model.gap_contact_m
        else:
            al, be, ga, phi = self._signal(D, r, z, ta, -rowU)
            ga -= D["Dl"]
        kc, cc = D["scan"][side]
        lam = D["lam"][r]
        Om = D["Om"]
        al2 = np.empty_like(al)
        buf = np.empty(4)
        h_min = 1e-13 * TWO_PI / Om
        best = -np.inf
        combos = ((0.0, -1.0, 0.0, 0), (0.0, -kc, -cc, 1)) if r == FREE else ((0.0, kc, cc, 2),)
        h = D["hmax"][r]
        S = tb - ta
        s = 0.0
        while s < S:
            # the kernel's steps (see _first_exit): coefficients decayed to the step's start
            e = min(s + h, S)
            als = al * np.exp(lam * s)
            ph = (phi + Om * s) % TWO_PI
            for c0, c1, c2, kind in combos:
                b2, g2 = signal_combo(c0, c1, c2, als, lam, be, ga, Om, al2)
                u = 0.0
                while True:
                    u = bupcross(al2, lam, b2, g2, ph, Om, u, e - s, h_min)
                    if u < 0.0 or s + u >= S:
                        break
                    signal_derivatives(u, als, lam, be, ga, ph, Om, buf)
                    f = kc * buf[0] + cc * buf[1]
                    if kind == 0 and buf[0] < 0.0:
                        best = max(best, buf[0])
                    elif kind == 1 and buf[0] > 0.0:
                        best = max(best, f / kc)
                    elif kind == 2:
                        best = max(best, -f / kc)
                    u = u + 1e-12 * h
            s = e
        return best

    def linear_orbit(self, p: float) -> np.ndarray:
        """``(eta, eta')`` at forcing phase 0 of the contact-free harmonic steady state."""
        D = self.data(p)
        return self._zp(D, FREE, 0.0)

    def start(self, kind: str, p: float, n: int = 1):
        """``linear``: the contact-free steady state where its contact amplitude stays below
        ``Delta_C``; returns ``(x0 or None, reason)``."""
        if kind != "linear":
            raise ValueError(f"start {kind!r} is not available for the beam; allowed: {', '.join(self.starts)} "
                             f"(and 'sweep')")
        D = self.data(p)
        m = D["m"]
        N = m.n_modes
        A = abs(complex(m.contact_row @ D["pd"][3][FREE][:N]))
        if not A < m.gap_contact_m:
            return None, (f"the non-contacting orbit does not exist: its contact amplitude {A:.6g} m reaches the "
                          f"stop Delta_C = {m.gap_contact_m:.6g} m at {self.parameter} = {p:.6g}")
        if self.two and not A < D["Dl"]:
            return None, (f"the non-contacting orbit does not exist: its contact amplitude {A:.6g} m reaches the "
                          f"lower stop Delta_C,lower = {D['Dl']:.6g} m at {self.parameter} = {p:.6g}")
        return self.linear_orbit(p), ""


def failed_shot(d: int, message: str) -> Shot:
    """A failed :class:`Shot` of dimension ``d`` (NaN state and monodromy) with ``message``."""
    nan = np.full(d, np.nan)
    return Shot(x=nan, M=np.full((d, d), np.nan), x_p=nan.copy(), impact_times=np.zeros(0),
                impact_velocities=np.zeros(0), q_min=np.nan, q_max=np.nan, status="failed", message=message)


# ============================================================================ Hunt-Crossley (SDOF)
@njit(cache=True)
def _hc_variational(t, y, vr, dvr, Delta, kc, chi, pe, beta, F, Omega, B):
    """Right-hand side of the Hunt-Crossley contact phase with its variational equations:
    ``y = (q, q', Y (2, 5) row-major)``, ``Y = d(q, q') / d(q0, q0', Omega, B, Delta)``; ``vr`` the
    contact's reference velocity and ``dvr`` (5,) its sensitivity."""
    dl = y[0] - Delta
    dv = y[1]
    dp = dl if dl > 0.0 else 0.0
    fac = 1.0 + chi * dv / vr
    f = kc * dp ** pe * fac
    out = np.empty(12)
    out[0] = dv
    ph = Omega * t
    out[1] = F * math.sin(ph) - 2.0 * beta * dv - y[0] - f
    f_d = kc * pe * dp ** (pe - 1.0) * fac if dp > 0.0 else 0.0
    f_v = kc * dp ** pe * chi / vr
    f_vr = -kc * dp ** pe * chi * dv / (vr * vr)
    a_q = -1.0 - f_d
    a_v = -2.0 * beta - f_v
    for j in range(5):
        y0 = y[2 + j]
        y1 = y[7 + j]
        out[2 + j] = y1
        out[7 + j] = a_q * y0 + a_v * y1 - f_vr * dvr[j]
    out[9] += 2.0 * Omega * B * math.sin(ph) + F * t * math.cos(ph)
    out[10] += Omega * Omega * math.sin(ph)
    out[11] += f_d
    return out


class HuntCrossleySDOFShooting(CompliantSDOFShooting):
    """Shooting problem ``P^n`` of the SDOF on a Hunt-Crossley stop (contract:
    :mod:`vibeam.models.periodic`), ``f = k_c delta^p (1 + chi delta' / v_r)``
    (:mod:`vibeam.models.compliant`).

    Free flight is the exact flow of the event kernel (:func:`~vibeam.models.sdof_compliant.advance`,
    certified entry); the contact phase is integrated *numerically* by
    :func:`scipy.integrate.solve_ivp` (DOP853, ``rtol = 1e-12``) together with its variational
    equations ``Y' = A(t) Y + d(acc)/dp + d(acc)/dv_r dv_r/d(x0, p)``, the exit located as the
    zero of ``delta`` or of the damping factor ``1 + chi delta' / v_r``.  So ``P^n`` and its
    derivatives are accurate to the integrator's tolerance, not exact: ``P^n`` is smooth only to
    ~1e-12 of the state (the adaptive steps change with ``x0``), and the orbit differs from the
    kernel's (its own Dormand-Prince 5(4) at ``rtol = 1e-11``) by ~1e-10.

    Events: at entry through ``delta = 0`` the force is zero (``delta^p``), so the field is
    continuous and ``S = I``; but the law depends on the entry velocity ``v_r = max(v_in,
    v_floor)`` (Flores' damping per contact), whose sensitivity ``dv_in = Y_v + delta''_- dt``
    (``dt = -(Y_q + h_p) / v_in``) enters the contact's variational equations.  At the exit the
    force is zero again (``S = I``).  Not represented (``status = "failed"`` with the reason):
    a section inside the stop (the contact depends on its ``v_r``, which is not part of the state
    ``(q, q')``) and a re-entry inside the stop after a damping-factor exit (it depends on the
    previous contact's ``v_r``).  Parameters ``Omega``, ``B``, ``Delta``.
    """

    def __init__(self, model, parameter: str = "Omega", Omega: float | None = None, max_events: int = 4096,
                 rtol: float = 1e-12):
        law = getattr(model, "contact", None)
        if law is None or getattr(law, "family", "") != "hysteretic_hertz":
            raise ValueError(f"HuntCrossleySDOFShooting needs a stop with contact {family_laws('hysteretic_hertz')}")
        if getattr(model, "two_sided", False):
            raise ValueError("continuation with a compliant law follows one stop (no second stop)")
        if parameter not in PARAMETERS:
            raise ValueError(f"parameter {parameter!r} cannot be continued with contact law {law.name!r}; "
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
        self.chi = float(law.chi)
        self.pexp = float(law.exponent)
        self.cc = 0.0
        self.max_events = int(max_events)
        self.rtol = float(rtol)

    def shot(self, x0, p, n) -> Shot:
        """``P^n(x0; p)`` with monodromy and ``d/dp`` (class docstring); as
        :meth:`CompliantSDOFShooting.shot`."""
        from scipy.integrate import solve_ivp

        from .sdof_compliant import HC_V_FLOOR

        beta = float(self.model.beta)
        B, Delta, Omega = self.params(p)
        kc, chi, pe = self.kc, self.chi, self.pexp
        n = int(n)
        q, v = float(x0[0]), float(x0[1])
        if not (Omega is not None and Omega > 0.0 and math.isfinite(q) and math.isfinite(v) and n >= 1):
            return _failed(f"parameters or state out of range (Omega {Omega}, n {n}, x0 ({q}, {v}))")
        if q - Delta >= 0.0:
            return _failed("the section lies inside the stop: a Hunt-Crossley contact depends on its entry "
                           "velocity, which is not part of the state (q, q')")
        F = Omega * Omega * B
        P = phase_params(beta, F, Omega, Delta, 0.0, 0.0)
        T = TWO_PI / Omega
        t_end = n * T
        hf = TWO_PI / 16.0
        X, dX = particular_sensitivities(P[0], F, B, Omega)
        if B > 0.0:
            v_floor, dfloor = HC_V_FLOOR * Omega * B, np.array([HC_V_FLOOR * B, HC_V_FLOOR * Omega, 0.0])
        else:
            v_floor, dfloor = 1e-6, np.zeros(3)

        def carry(Y, ta, tb):
            Phi = phase_stm(tb - ta, P[0])
            Y = Phi @ Y
            for k in range(3):
                Y[:, 2 + k] += _dP(tb, X, dX, 0.0, Omega, k) - Phi @ _dP(ta, X, dX, 0.0, Omega, k)
            return Y

        def acc_free(q, v, t):
            return F * math.sin(Omega * t) - 2.0 * beta * v - q

        Y = np.zeros((2, 5))
        Y[0, 0] = Y[1, 1] = 1.0
        d = np.empty(6)
        ex = np.array([q, q, np.inf])
        cs = np.zeros(4)
        t, phi, t_seg, t_con = 0.0, 0.0, 0.0, 0.0
        apex = -np.inf
        entries, rates, contacts = [], [], []
        r0, r1, roff = kc, 0.0, 0.0
        steps = 0
        in_contact_end = False
        while t_end - t > 1e-15 * T:
            steps += 1
            if steps > 400 * n + 64 * self.max_events:
                return _failed(f"more than {steps - 1} steps in {n} period(s)")
            below = q - Delta < 0.0
            h = min(t_end - t, hf)
            s, ev = advance(FREE, h, phi, q, v, P[0], kc, 0.0, Omega, Delta, True, ex, cs, d, r0, r1, roff)
            if s > 0.0:
                apex = max(apex, self._apex(s, phi, q, v, P[0], Omega, Delta))
            phase_eval(s, phi, q, v, P[0], Omega, Delta, d)
            q, v = Delta + d[0], d[1]
            t += s
            phi = (phi + Omega * s) % TWO_PI
            if ev != EV_ENTRY:
                continue
            if not below:
                return _failed("re-entry inside the stop after a damping-factor exit (depends on the previous "
                               "contact's entry velocity): not represented")
            if len(entries) >= self.max_events:
                return _failed(f"more than {self.max_events} contacts in {n} period(s)")
            Y = carry(Y, t_seg, t)
            # entry through delta = 0: S = I (zero force); the law's v_r = max(v_in, v_floor) and its
            # sensitivity (the entry time moves with x0 and p: dt = -(Y_q + h_p) / v, h_Delta = -1)
            a_m = acc_free(q, v, t)
            hp = np.array([0.0, 0.0, 0.0, 0.0, -1.0])
            dt_e = -(Y[0] + hp) / v
            if v > v_floor:
                vr, dvr = v, Y[1] + a_m * dt_e
            else:
                vr, dvr = v_floor, np.concatenate([[0.0, 0.0], dfloor])
            entries.append(t)
            rates.append(v)
            t0 = t

            def ev_gap(tt, y, *args):
                return y[0] - Delta
            ev_gap.terminal, ev_gap.direction = True, -1.0

            def ev_fac(tt, y, *args, vr=vr):
                return 1.0 + chi * y[1] / vr
            ev_fac.terminal, ev_fac.direction = True, -1.0
            y0 = np.concatenate([[q, v], Y.ravel()])
            # start a hair inside (delta = 0 is the gap event's zero); the first step is tiny anyway
            sol = solve_ivp(_hc_variational, (t0, t_end), y0, method="DOP853", rtol=self.rtol,
                            atol=np.concatenate([[1e-13 * max(abs(v) / Omega, abs(Delta), 1e-300), 1e-13 * abs(v)],
                                                 np.full(10, 1e-13 * max(float(np.max(np.abs(Y))), 1.0))]),
                            events=(ev_gap, ev_fac), args=(vr, dvr, Delta, kc, chi, pe, beta, F, Omega, B),
                            first_step=1e-6 * T)
            if sol.status < 0:
                return _failed(f"the contact phase's integration failed: {sol.message}")
            yend = sol.y[:, -1]
            t_x = float(sol.t[-1])
            q, v = float(yend[0]), float(yend[1])
            Y = yend[2:].reshape(2, 5).copy()
            t_con += t_x - t0
            ex[0] = min(ex[0], float(np.min(sol.y[0])))
            ex[1] = max(ex[1], float(np.max(sol.y[0])))
            t = t_x
            phi = (Omega * t) % TWO_PI
            t_seg = t
            if sol.status == 1:        # exit (the force is zero there: S = I)
                contacts.append((t_x - t0, np.nan, float(np.max(sol.y[0])) - Delta, np.nan))
                r0, r1, roff = 0.0, 1.0, vr / chi if chi > 0.0 else 1.0
                if q - Delta > 0.0 and sol.t_events[0].size:
                    q = Delta       # exit through delta = 0: on the stop, leaving it
            else:
                in_contact_end = True
                break
        if in_contact_end:
            a_end = acc_free(q, v, t_end) - kc * max(q - Delta, 0.0) ** pe * (1.0 + chi * v / vr)
        else:
            Y = carry(Y, t_seg, t_end)
            a_end = acc_free(q, v, t_end)
        Y[:, 2] += np.array([v, a_end]) * (-t_end / Omega)
        ex[0] = min(ex[0], q)
        ex[1] = max(ex[1], q)
        if not np.all(np.isfinite(Y)):
            return _failed("non-finite derivatives")
        return Shot(x=np.array([q, v]), M=Y[:, :2].copy(), x_p=Y[:, 2 + self.index].copy(),
                    impact_times=np.array(entries, float), impact_velocities=np.array(rates, float),
                    q_min=float(ex[0]), q_max=float(ex[1]), apex_gap=float(apex), stuck_time=0.0,
                    status="ok", message="", Omega=Omega, gap=Delta,
                    extra={"x_all_p": Y[:, 2:].copy(), "contact_time": t_con,
                           "contacts": np.array(contacts, float).reshape(-1, 4), "in_contact_end": in_contact_end})

    def _apex(self, s, phi, q, v, pp, Omega, Delta):
        """Largest interior free-flight maximum of ``delta`` below the stop in a step."""
        A = envelope(phi, q, v, pp, Omega)
        d = np.empty(6)
        best = -np.inf
        u = 0.0
        while True:
            u = upcross(0.0, -1.0, 0.0, u, s, phi, q, v, pp, Omega, Delta, A, d)
            if u < 0.0 or u >= s:
                break
            phase_eval(u, phi, q, v, pp, Omega, Delta, d)
            if d[0] < 0.0:
                best = max(best, d[0])
        return best
