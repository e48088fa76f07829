"""Method ``mapping`` on a Hunt-Crossley stop: the entry-to-entry map with variational equations.

As :mod:`vibeam.models.sdof_compliant_map` (paper Sec. 4.2: contact and free phases composed),
with the section at contact entry, ``q = Delta``, ``q' = v0 > 0`` at time ``t0``, and one
contact per ``n`` forcing periods a fixed point ``t1 = t0 + n T``, ``v1 = v0`` (Newton).  The
contact phase of ``F = k_c delta^p (1 + chi delta' / v_r)`` (``v_r = max(v0, v_floor)``, the
entry speed, floored as in the event integrator, :data:`vibeam.models.core.laws.V_FLOOR`)
has no closed form: it is integrated with scipy's DOP853 (rtol 1e-12) *together with its
variational equations*::

    Phi' = A(t) Phi,  Phi(t0) = I;     s' = A(t) s + df/dv_r,  s(t0) = 0,
    A = [[0, 1], [-1 - p k_c delta^(p-1) (1 + chi delta' / v_r), -2 beta - k_c delta^p chi / v_r]],
    df/dv_r = (0, k_c delta^p chi delta' / v_r^2),

so that ``d x(t) = Phi (dx0 - f(x0) dt0) + s dv_r`` exactly to the integration tolerance (no
finite differences).  The contact ends where the force returns to zero: ``delta = 0`` falling,
or the damping factor ``h = 1 + chi delta' / v_r`` falling through 0 (an event that depends on
``v_r`` too: ``dt_x = -(grad h . dx + dh/dv_r dv_r) / (grad h . f)``).  The fields of the
contact and the free phase agree at entry and exit (the force is zero there), so no saltation
arises.  The free flight to the next entry (``delta`` up through 0 after having fallen through
0) is the closed-form flow and the certified scans of the event integrator
(:func:`vibeam.models.sdof_compliant_map.phase_step`), its transition matrix closed form.  Floquet
multipliers: eigenvalues of ``d(t1, v1) / d(t0, v0)``.

Measured (tests/test_hc_mapping.py): fixed points equal the event kernel's settled orbits to
<= 1.5e-10 (amplitude and contact record), multipliers equal central differences of the event
kernel's stroboscopic map to <= 2.5e-10, the Jacobian those of the map to 2e-9.  The exit by the
damping factor is implemented (with its ``v_r`` sensitivity) but no tested orbit reaches it.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from .core import laws
from .sdof_compliant_map import EV_ENTRY, EV_FAIL, EV_GAPDOWN, FREE, TWO_PI, EntryMappingSolver, LinearPhase

#: tolerance of the contact phase (DOP853 with its variational equations)
RTOL = 1e-12


class HuntCrossleyMappingSolver(EntryMappingSolver):
    """The entry-to-entry map on a hysteretic-Hertz stop (Hunt-Crossley and its kin): the contact
    phase with its variational equations by DOP853, the free flight in closed form (module
    docstring); :class:`~vibeam.models.sdof_compliant_map.EntryMappingSolver` for the parameters
    (``tol`` 1e-10 by default)."""

    family = "hysteretic_hertz"
    default_tol = 1e-10

    def settings(self) -> dict:
        return {**super().settings(), "rtol": RTOL}

    # ------------------------------------------------------------------ the contact phase
    def contact_phase(self, Omega, t0, v0):
        """Integrate the contact from entry ``(t0, v0)`` with its variational equations.

        Returns
        -------
        dict
            ``t`` (exit time), ``x`` (exit ``(delta, delta')``), ``Phi`` (2, 2), ``s`` (2,),
            ``kind`` (0: ``delta`` back to 0, 1: the damping factor to 0), ``vr``, ``dvr``
            (``d v_r / d v0``: 1 or 0 at the floor), ``force``, ``penetration``, ``energy``;
            None when no exit within one forcing period.
        """
        m = self.model
        law = m.contact
        kc, p, chi = law.stiffness, law.exponent, law.chi
        beta, Delta = m.beta, m.Delta
        F = Omega * Omega * m.B
        v_floor = laws.V_FLOOR * Omega * m.B if m.B > 0.0 else 1e-6
        vr = max(v0, v_floor)
        dvr = 1.0 if v0 > v_floor else 0.0

        def rhs(t, z):
            dl, dv = z[0], z[1]
            dp = max(dl, 0.0)
            fac = 1.0 + chi * dv / vr
            f = kc * dp ** p * fac
            a = F * math.sin(Omega * t) - 2.0 * beta * dv - (Delta + dl) - f
            a10 = -1.0 - (p * kc * dp ** (p - 1.0) * fac if dp > 0.0 else 0.0)
            a11 = -2.0 * beta - kc * dp ** p * chi / vr
            P = z[2:6].reshape(2, 2)
            dP = np.array([P[1], a10 * P[0] + a11 * P[1]]).ravel()
            s = z[6:8]
            ds = np.array([s[1], a10 * s[0] + a11 * s[1] + kc * dp ** p * chi * dv / (vr * vr)])
            return np.concatenate([[dv, a], dP, ds, [f * dv]])

        def ev_delta(t, z):
            return z[0]
        ev_delta.terminal = True
        ev_delta.direction = -1.0

        def ev_factor(t, z):
            return 1.0 + chi * z[1] / vr
        ev_factor.terminal = True
        ev_factor.direction = -1.0

        def ev_pen(t, z):          # largest penetration
            return z[1]
        ev_pen.direction = -1.0

        def ev_force(t, z):        # peak force: dF/dt = 0 falling
            dl, dv = max(z[0], 0.0), z[1]
            if dl <= 0.0:
                return 0.0
            a = rhs(t, z)[1]
            return kc * p * dl ** (p - 1.0) * dv * (1.0 + chi * dv / vr) + kc * dl ** p * chi * a / vr
        ev_force.direction = -1.0

        z0 = np.zeros(9)
        z0[1] = v0
        z0[2] = z0[5] = 1.0
        pen0 = ((p + 1.0) * vr * vr / (2.0 * kc)) ** (1.0 / (p + 1.0))   # isolated contact's penetration
        atol = np.array([1e-14 * pen0, 1e-14 * vr, 1e-14, 1e-14, 1e-14, 1e-14, 1e-14 * pen0 / vr, 1e-14,
                         1e-14 * vr * vr])
        T = TWO_PI / Omega
        sol = solve_ivp(rhs, (t0, t0 + T), z0, method="DOP853", rtol=RTOL, atol=atol,
                        events=[ev_delta, ev_factor, ev_pen, ev_force], max_step=pen0 / vr)
        if sol.status != 1:
            return None
        kind = 0 if sol.t_events[0].size else 1
        z = sol.y[:, -1]
        force = 0.0
        for ze in sol.y_events[3]:
            force = max(force, kc * max(ze[0], 0.0) ** p * (1.0 + chi * ze[1] / vr))
        pen = max([float(ze[0]) for ze in sol.y_events[2]] + [0.0])
        return dict(t=float(sol.t[-1]), x=z[:2].copy(), Phi=z[2:6].reshape(2, 2).copy(), s=z[6:8].copy(),
                    kind=kind, vr=vr, dvr=dvr, force=force, penetration=pen, energy=float(z[8]),
                    kc=kc, p=p, chi=chi, F=F)

    # ------------------------------------------------------------------ the map
    def evaluate(self, Omega, t0, v0, want_record=False):
        """``P(t0, v0)``: ``(t1, v1, J, record)`` with ``J = d(t1, v1) / d(t0, v0)`` (2, 2), or
        None when the orbit leaves the one-contact family."""
        m = self.model
        Delta, beta = m.Delta, m.beta
        T = TWO_PI / Omega
        c = self.contact_phase(Omega, t0, v0)
        if c is None:
            return None
        F = c["F"]
        tx, (dx, vx) = c["t"], c["x"]
        if c["kind"] == 0:
            dx = 0.0      # the exit through delta = 0 (located to round-off): on the section's surface
        qx = Delta + dx
        # free flight to the next entry (delta through 0 falling first when the exit left delta > 0,
        # where the force's sign function is that of the damping factor, v_r / chi + delta')
        free = LinearPhase(beta, F, Omega, Delta)
        ext = np.array([np.inf, -np.inf])
        roff = c["vr"] / c["chi"] if c["chi"] > 0.0 else 1.0
        q, v, t = qx, vx, tx
        below = c["kind"] == 0 or q - Delta <= 0.0
        hf = TWO_PI / 16.0
        for _ in range(100000):
            if t - t0 > (self.n + 1) * T:
                return None
            s, ev, q, v = free.step(FREE, hf, t, q, v, r=(0.0, 1.0, roff), rec=want_record, ext=ext)
            if ev == EV_FAIL:
                return None
            t = t + s
            if ev == EV_GAPDOWN:
                below = True
            elif ev == EV_ENTRY:
                if not below:
                    return None      # back into contact before leaving the stop: not one contact
                break
        t1, v1 = t, v
        # the contact phase: exact variations from the variational equations
        f0 = free.field(Delta, v0, t0)      # the contact force is zero at entry
        fx = free.field(qx, vx, tx)         # and at the exit
        f1 = free.field(Delta, v1, t1)
        Pf = free.transition(t1 - tx)
        if c["kind"] == 0:
            gh, dh_dvr = np.array([1.0, 0.0]), 0.0
        else:
            gh, dh_dvr = np.array([0.0, c["chi"] / c["vr"]]), -c["chi"] * vx / c["vr"] ** 2
        J = np.empty((2, 2))
        for col, (dt0, dv0) in enumerate(((1.0, 0.0), (0.0, 1.0))):
            dvr = c["dvr"] * dv0
            y = c["Phi"] @ (np.array([0.0, dv0]) - f0 * dt0) + c["s"] * dvr
            dtx = -(gh @ y + dh_dvr * dvr) / (gh @ fx)
            dxx = fx * dtx + y
            y = Pf @ (dxx - fx * dtx)
            dt1 = -y[0] / f1[0]
            dx1 = f1 * dt1 + y
            J[0, col] = dt1
            J[1, col] = dx1[1]
        rec = dict(q_min=ext[0], q_max=max(ext[1], Delta + c["penetration"], qx), duration=tx - t0,
                   force=c["force"], penetration=c["penetration"], energy=c["energy"])
        return t1, v1, J, rec
