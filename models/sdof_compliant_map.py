"""Method ``mapping`` on a Kelvin-Voigt stop: the piecewise-linear map of paper Sec. 4.2.

The section is contact entry, ``q = Delta`` with ``q' = v > 0`` at time ``t`` (forcing phase
``Omega t``).  One contact per ``n`` forcing periods composes two exact linear flows
(:mod:`vibeam.models.sdof_compliant`)::

    P(t0, v0) = F(exit -> next entry) o C(entry -> exit) = (t1, v1)

the contact phase ``C`` up to the force-zero exit ``h_x = k_c delta + c_c delta' = 0``, the
free flight ``F`` up to the next ``h_e = delta = 0`` rising.  A period-n orbit with one contact
is a fixed point ``t1 = t0 + n T``, ``v1 = v0`` (Newton).  The Jacobian is composed over the
phases (paper Sec. 4.2, with the time of each event varied): for a phase with state-transition
matrix ``Phi`` (closed form), field ``f`` and an event ``h(x) = 0`` reached at ``x_e``,

    dt_e = -grad h . Phi (dx_0 - f(x_0) dt_0) / (grad h . f(x_e)),
    dx_e = f(x_e) dt_e + Phi (dx_0 - f(x_0) dt_0),

starting from ``dx_0 = (0, dv_0)`` on the section, the contact field at the start and the free
field at the end (the two fields agree at the exit, where the contact force is zero, so no
saltation arises there).  The eigenvalues of ``d(t1, v1) / d(t0, v0)`` are the orbit's Floquet
multipliers.  Extremes, contact duration, peak force, penetration and the energy lost come
from the event kernel's own step (:func:`vibeam.models.sdof_compliant.advance`).
"""
from __future__ import annotations

import math

import numpy as np

from .sdof_compliant import (CONTACT, EV_ENTRY, EV_EXIT, EV_GAPDOWN, FREE, TWO_PI, advance, phase_eval,
                             phase_params)
from .sdof_flow import transition
from .registry import family_laws


def phase_transition(s, pp):
    """Closed-form state-transition matrix of a phase over ``s`` (physical time), (2, 2)."""
    w, b = pp[0], pp[1]
    p11, p12, p21, p22 = transition(w * s, b)
    return np.array([[1.0 + p11, p12 / w], [w * p21, 1.0 + p22]])


def phase_field(q, v, t, pp, F, Omega):
    """``(q', q'')`` of a phase: ``q'' = F sin(Omega t) - 2 b w q' - w^2 (q - q_e)``."""
    w, b, qe = pp[0], pp[1], pp[2]
    return np.array([v, F * math.sin(Omega * t) - 2.0 * b * w * v - w * w * (q - qe)])


class CompliantMappingSolver:
    """Period-n one-contact orbits of an SDOF on a Kelvin-Voigt stop (module docstring).

    Parameters
    ----------
    model : vibeam.models.SDOF
        With ``contact`` a :class:`vibeam.models.compliant.LinearContact`.
    n : int
        Forcing periods per contact (1..4).
    guess_periods : int
        Transient periods of the event run that provides the first Newton guess.
    tol : float
        Newton tolerance (residual relative to the entry velocity and the period).
    """

    name = "mapping"
    time_domain = False

    def __init__(self, model, n: int = 1, guess_periods: int = 300, tol: float = 1e-12,
                 form: str = "full", guess: str = "event", samples_per_flight_period: int = 256):
        if int(n) != n or not 1 <= n <= 4:
            raise ValueError(f"n must be an integer in 1..4, got {n!r}")
        if getattr(model, "contact", None) is None or model.contact.family != "kelvin_voigt":
            raise ValueError(f"CompliantMappingSolver needs {family_laws('kelvin_voigt')}")
        self.model = model
        self.n = int(n)
        self.guess_periods = int(guess_periods)
        self.tol = float(tol)

    def settings(self) -> dict:
        return dict(n=self.n, guess_periods=self.guess_periods, tol=self.tol)

    # ------------------------------------------------------------------ the map
    def _params(self, Omega):
        m = self.model
        F = Omega * Omega * m.B
        law = m.contact
        P = phase_params(m.beta, F, Omega, m.Delta, law.stiffness, law.damping)
        return P, F, law.stiffness, law.damping

    def evaluate(self, Omega, t0, v0, want_record=False):
        """``P(t0, v0)``: ``(t1, v1, J, record)`` with ``J = d(t1, v1) / d(t0, v0)`` (2, 2) and
        ``record`` (extremes, contact data), or None when the orbit leaves the one-contact
        family (no exit, a second contact before leaving the stop, no entry within n + 1
        periods)."""
        m = self.model
        P, F, kc, cc = self._params(Omega)
        Delta = m.Delta
        T = TWO_PI / Omega
        d = np.empty(6)
        ex = np.array([np.inf, -np.inf, np.inf])
        cs = np.zeros(4)
        cs[1] = cc * v0
        # contact phase
        q, v, t = Delta, v0, t0
        hc = TWO_PI / P[1, 0] / 16.0
        s_c = 0.0
        for _ in range(100000):
            s, ev = advance(CONTACT, hc, (Omega * t) % TWO_PI, q, v, P[1], kc, cc, Omega, Delta, want_record,
                            ex, cs, d, kc, cc, 0.0)
            phase_eval(s, (Omega * t) % TWO_PI, q, v, P[1], Omega, Delta, d)
            q, v, t, s_c = Delta + d[0], d[1], t + s, s_c + s
            if ev == EV_EXIT:
                break
        else:
            return None
        qx, vx, tx = q, v, t
        # free flight to the next entry (through delta = 0 falling when the exit leaves delta > 0)
        hf = TWO_PI / 16.0
        below = q - Delta <= 0.0
        for _ in range(100000):
            if t - t0 > (self.n + 1) * T:
                return None
            s, ev = advance(FREE, hf, (Omega * t) % TWO_PI, q, v, P[0], kc, cc, Omega, Delta, want_record,
                            ex, cs, d, kc, cc, 0.0)
            phase_eval(s, (Omega * t) % TWO_PI, q, v, P[0], Omega, Delta, d)
            q, v, t = Delta + d[0], d[1], t + s
            if ev == EV_GAPDOWN:
                below = True
            elif ev == EV_ENTRY:
                if not below:
                    return None      # back into contact before leaving the stop: not one contact
                break
        t1, v1 = t, v
        # Jacobian composed over the two phases (module docstring)
        f0 = phase_field(Delta, v0, t0, P[1], F, Omega)
        fx = phase_field(qx, vx, tx, P[1], F, Omega)
        fxf = phase_field(qx, vx, tx, P[0], F, Omega)       # equal to fx: the force is zero at the exit
        f1 = phase_field(Delta, v1, t1, P[0], F, Omega)
        Pc = phase_transition(s_c, P[1])
        Pf = phase_transition(t1 - tx, P[0])
        gx = np.array([kc, cc])
        J = np.empty((2, 2))
        for col, (dt0, dx0) in enumerate(((1.0, np.zeros(2)), (0.0, np.array([0.0, 1.0])))):
            y = Pc @ (dx0 - f0 * dt0)
            dtx = -(gx @ y) / (gx @ fx)
            dxx = fx * dtx + y
            y = Pf @ (dxx - fxf * dtx)
            dt1 = -y[0] / f1[0]
            dx1 = f1 * dt1 + y
            J[0, col] = dt1
            J[1, col] = dx1[1]
        rec = dict(q_min=ex[0], q_max=max(ex[1], Delta + cs[2]), duration=s_c, force=cs[1], penetration=cs[2],
                   energy=cs[3])
        return t1, v1, J, rec

    def _guess(self, Omega, state0):
        if isinstance(state0, dict):
            state0 = state0.get("final_state")
        if state0 is not None:
            s = np.asarray(state0, float).ravel()
            if s.shape == (2,) and np.all(np.isfinite(s)) and s[1] > 0:
                yield s[0] / Omega, s[1]
        from .sdof_compliant import CompliantEventSolver

        tr = CompliantEventSolver(self.model).point(Omega, None, self.guess_periods, self.n + 1, 16)
        if tr.n_impacts:
            yield float(tr.impact_times[-1] % (TWO_PI / Omega)), float(tr.impact_velocities[-1])

    def point(self, Omega: float, state0, n_transient: int, n_record: int, samples_per_period: int = 64) -> dict:
        """Period-n one-contact fixed point, its multipliers and its contact data.

        Returns
        -------
        dict
            ``amplitude``, ``q_min``, ``q_max``, ``period`` (n, or 0), ``impacts_per_period``,
            ``impact_velocity`` (entry), ``impact_phase``, ``stable``, ``multipliers`` (complex
            (2,)), ``contact_duration``, ``contact_force_max``, ``penetration_max``,
            ``energy_per_impact``, ``final_state`` ``(phase, v)``, ``status``, ``message``.
        """
        m = self.model
        Omega = float(Omega)
        T = TWO_PI / Omega
        reasons = []
        for t0, v0 in self._guess(Omega, state0):
            x = np.array([t0, v0])
            ok = False
            for _ in range(50):
                r = self.evaluate(Omega, x[0], x[1])
                if r is None:
                    break
                t1, v1, J, _ = r
                res = np.array([(t1 - x[0] - self.n * T), v1 - x[1]])
                if abs(res[0]) <= self.tol * T and abs(res[1]) <= self.tol * abs(x[1]):
                    ok = True
                    break
                dx = np.linalg.solve(J - np.eye(2), -res)
                x = x + dx
                if not x[1] > 0.0:
                    break
            if not ok:
                reasons.append(f"Newton did not converge from t = {t0:.4g}, v = {v0:.4g}")
                continue
            t1, v1, J, rec = self.evaluate(Omega, x[0], x[1], want_record=True)
            mult = np.linalg.eigvals(J)
            return dict(amplitude=m.Delta - rec["q_min"], q_min=rec["q_min"], q_max=rec["q_max"], period=self.n,
                        impacts_per_period=1.0 / self.n, impact_velocity=float(x[1]),
                        impact_phase=float((Omega * x[0]) % TWO_PI), stable=bool(np.max(np.abs(mult)) < 1.0),
                        multipliers=mult.astype(complex), contact_duration=rec["duration"],
                        contact_force_max=rec["force"], penetration_max=rec["penetration"],
                        energy_per_impact=rec["energy"],
                        final_state=np.array([(Omega * x[0]) % TWO_PI, x[1]]), status="ok", message="")
        nan = float("nan")
        return dict(amplitude=nan, q_min=nan, q_max=nan, period=0, impacts_per_period=nan, impact_velocity=nan,
                    impact_phase=nan, stable=False, multipliers=np.full(2, nan, dtype=complex),
                    contact_duration=nan, contact_force_max=nan, penetration_max=nan, energy_per_impact=nan,
                    final_state=np.full(2, nan), status="failed",
                    message="; ".join(reasons) if reasons else "no initial guess (no contact)")
