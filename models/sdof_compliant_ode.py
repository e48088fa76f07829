"""Method ``direct`` of an SDOF scene with a compliant stop: the solve_ivp reference.

The independent oracle of :mod:`vibeam.models.sdof_compliant` (shares none of its code):
:func:`scipy.integrate.solve_ivp` integrates the piecewise-smooth system in the state
``(q, q', E)``, ``E' = f delta'`` (the work done on the stop), with terminal events

* free, ``delta < 0``: ``delta = 0`` rising -> contact;
* free just after an exit, ``delta > 0``: ``f = 0`` rising -> contact, ``delta = 0`` falling ->
  free flight below the stop;
* contact: ``f = 0`` falling -> free (the force-zero separation),

with ``delta = q - Delta`` and ``f = k_c delta + c_c delta'`` (a Kelvin-Voigt law) or
``f = k_c delta^p (1 + chi delta' / v_in)`` (a hysteretic-Hertz law, ``chi`` the law's number,
``v_in`` the entry velocity).  Per contact the duration comes from the event times, the energy lost from
``E``, the peak force and largest penetration from the dense output (maximised by
:func:`scipy.optimize.minimize_scalar` around the best of 64 samples per integrator step).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from .trajectory import Trajectory

TWO_PI = 2.0 * math.pi


def _ev(fn, direction):
    fn.terminal = True
    fn.direction = direction
    return fn


def _impulsive(law) -> bool:
    """Is ``law`` Newton's (a restitution stop beside a compliant one)?"""
    return getattr(law, "kind", "") == "impulsive"


class CompliantDirectSolver:
    """Method ``direct`` for a compliant stop (module docstring).

    Parameters
    ----------
    model : vibeam.models.SDOF
        With ``model.contact`` a compliant law.
    solver : str
        ``solve_ivp`` method (default ``DOP853``).
    rtol, atol : float
        Tolerances (default 1e-11, 1e-13: the reference of the tests).
    max_events_per_period : int
        More events per period on average: ``failed``.
    """

    name = "direct"
    time_domain = True
    chunk_periods = 1000

    def __init__(self, model, solver: str = "DOP853", rtol: float = 1e-11, atol: float = 1e-13,
                 max_events_per_period: int = 200, max_step=None):
        law = model.contact
        if law is None or getattr(law, "kind", "") != "compliant":
            raise ValueError("CompliantDirectSolver needs a compliant [model.contact] law")
        self.model = model
        self.solver = solver
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.max_events_per_period = int(max_events_per_period)
        self.max_step = max_step

    def settings(self) -> dict:
        return dict(solver=self.solver, rtol=self.rtol, atol=self.atol,
                    max_events_per_period=self.max_events_per_period)

    def _laws(self):
        """``[(sign, offset, law), ...]`` of the stops: the upper one at ``q = Delta``, and the
        lower one at ``q = -Delta_lower`` of a two-sided scene (``contact_lower`` or ``contact``)."""
        return [(s.relation.sign, s.relation.offset, s.law) for s in self.model.stops()]

    def _force(self, v_in, k=0):
        """Force of stop ``k`` on ``(q, q')`` (penetration ``s q - D``, rate ``s q'``)."""
        sg, D, law = self._laws()[k]
        kc = law.stiffness
        if law.linear_phase:
            c = law.damping
            return lambda q, v: kc * (sg * q - D) + c * (sg * v)
        p, cv = law.exponent, law.chi / max(v_in, 1e-300)
        return lambda q, v: kc * max(sg * q - D, 0.0) ** p * (1.0 + cv * (sg * v))

    def point(self, Omega: float, state0, n_transient: int, n_record: int,
              samples_per_period: int = 64) -> Trajectory:
        """Simulate one forcing frequency from ``state0 = (q, q', phase)`` (phase 1: in contact
        with the upper stop, -1 with the lower one; its entry velocity is then taken as the
        normal velocity)."""
        m = self.model
        laws = self._laws()
        two = len(laws) > 1
        Omega = float(Omega)
        T = TWO_PI / Omega
        Fa = Omega * Omega * m.B
        b2 = 2.0 * m.beta
        spp = int(samples_per_period)
        t_rec = n_transient * T
        t_end = (n_transient + n_record) * T
        ts = t_rec + np.arange(n_record * spp) * (T / spp)
        samples = np.full((ts.size, 2), np.nan)
        s0 = m.initial_state() if state0 is None else np.asarray(state0, float)
        q, v = float(s0[0]), float(s0[1])
        ks = 0        # the stop in contact (mode "contact")
        mode = "free"
        if s0.shape[0] > 2 and s0[2] > 0.5:
            mode = "contact"
        elif s0.shape[0] > 2 and s0[2] < -0.5 and two and not _impulsive(laws[1][2]):
            mode, ks = "contact", 1
        entries, contacts, contact_k = [], [], []
        impacts_at = []   # (t, q, sign) of the restitution impacts: extremes at the stop (no v = 0 there)
        # hysteretic Hertz: entry velocities floored at 1e-2 Omega B (vibeam.models.compliant)
        v_floor = 1e-2 * Omega * m.B if m.B > 0.0 else 1e-6
        v_in = max(laws[ks][0] * v, v_floor)
        if mode == "free":
            for k, (sg, D, law) in enumerate(laws):
                if sg * q - D < 0.0 or _impulsive(law):
                    continue
                # contact now if the force is positive just after t = 0: the first non-zero of
                # f, f', f'' (free-flight derivatives at forcing phase 0)
                kc, c = law.stiffness, getattr(law, "damping", 0.0)
                a2 = -b2 * v - q
                a3 = Fa * Omega - b2 * a2 - v
                fs = [kc * (sg * q - D) + c * (sg * v), kc * (sg * v) + c * (sg * a2), kc * (sg * a2) + c * (sg * a3)]
                first = next((x for x in fs if x != 0.0), 0.0)
                if first > 0.0:
                    mode, ks, v_in = "contact", k, max(sg * v, v_floor)
                    if n_transient == 0:
                        entries.append((0.0, sg * v, k))
                    break
        y = np.array([q, v, 0.0])
        t = 0.0
        segs = []
        cur = None   # open contact: [t_entry, v_in, E_entry, peak f, peak delta]
        if mode == "contact":
            sg, D, _ = laws[ks]
            cur = [0.0, v_in, 0.0, self._force(v_in, ks)(q, v), sg * q - D]
        n_ev = 0
        max_ev = self.max_events_per_period * max(n_transient + n_record, 1)
        while t < t_end:
            force = self._force(v_in, ks)
            tags = []
            if mode == "contact":
                sg, D, law = laws[ks]

                def rhs(tt, yy, force=force, sg=sg):
                    f = force(yy[0], yy[1])
                    return [yy[1], Fa * math.sin(Omega * tt) - b2 * yy[1] - yy[0] - sg * f, f * (sg * yy[1])]
                if law.linear_phase:
                    events = [_ev(lambda tt, yy, force=force: force(yy[0], yy[1]), -1.0)]
                else:   # the force k delta^p (1 + chi delta' / v_in) returns to 0 with either factor
                    cv = law.chi / v_in
                    events = [_ev(lambda tt, yy, sg=sg, D=D: sg * yy[0] - D, -1.0),
                              _ev(lambda tt, yy, cv=cv, sg=sg: 1.0 + cv * (sg * yy[1]), -1.0)]
            else:
                def rhs(tt, yy):
                    return [yy[1], Fa * math.sin(Omega * tt) - b2 * yy[1] - yy[0], 0.0]
                events = []
                for k, (sg, D, law) in enumerate(laws):
                    if sg * y[0] - D > 0.0 and not _impulsive(law):
                        if law.linear_phase:
                            fk = self._force(1.0, k)
                        else:
                            cv = law.chi / (v_in if k == ks else v_floor)
                            fk = lambda qq, vv, cv=cv, sg=sg: 1.0 + cv * (sg * vv)   # noqa: E731
                        events += [_ev(lambda tt, yy, fk=fk: fk(yy[0], yy[1]), 1.0),
                                   _ev(lambda tt, yy, sg=sg, D=D: sg * yy[0] - D, -1.0)]
                        tags += [(k, "entry"), (k, "down")]
                    else:
                        events += [_ev(lambda tt, yy, sg=sg, D=D: sg * yy[0] - D, 1.0)]
                        tags += [(k, "entry")]
            opts = dict(method=self.solver, rtol=self.rtol, atol=self.atol, dense_output=True)
            if self.max_step is not None:
                opts["max_step"] = self.max_step
            elif mode == "contact":
                law = laws[ks][2]
                opts["max_step"] = 0.1 * TWO_PI / math.sqrt(1.0 + law.stiffness) if law.linear_phase \
                    else 0.05 * ((law.exponent + 1) * v_in ** 2 / (2 * law.stiffness)) ** (
                        1 / (law.exponent + 1)) / v_in
            sol = solve_ivp(rhs, (t, t_end), y, events=events, **opts)
            if sol.status == -1:
                return self._failed(Omega, samples, spp, f"{self.solver} failed near t = {t:.6g}: {sol.message}")
            t_new = float(sol.t[-1])
            if t_new > t_rec or mode == "contact":
                segs.append((t, t_new, sol.sol, mode, force))
            if cur is not None and mode == "contact":
                sg, D, _ = laws[ks]
                self._peaks(cur, t, t_new, sol.sol, force, D, sg)
            y = np.asarray(sol.y[:, -1], float)
            t = t_new
            if sol.status != 1:
                break
            n_ev += 1
            if n_ev > max_ev:
                return self._failed(Omega, samples, spp, f"more than {max_ev} contact events")
            which = next(i for i, te in enumerate(sol.t_events) if te.size)
            if mode == "contact":
                cur_row = cur
                if cur_row[0] >= t_rec:
                    contacts.append([t - cur_row[0], cur_row[3], cur_row[4], y[2] - cur_row[2], cur_row[1]])
                    contact_k.append(ks)
                cur = None
                mode = "free"
                # the event is located within the tolerance on either side of f = 0
            elif tags[which][1] == "entry" and _impulsive(laws[tags[which][0]][2]):
                # Newton's law (paper Eq. 2) on a restitution stop beside a compliant one
                k = tags[which][0]
                sg, D, law = laws[k]
                vn = float(sg * y[1])
                Rk = law.coefficient(vn)
                y[0] = sg * D
                y[1] = -sg * Rk * vn
                if t >= t_rec:
                    entries.append((t - t_rec, vn, k))
                    contacts.append([0.0, np.nan, 0.0, 0.5 * (1.0 - Rk * Rk) * vn * vn, vn])
                    contact_k.append(k)
                    impacts_at.append((t, sg * D, sg))
            elif tags[which][1] == "entry":
                mode = "contact"
                ks = tags[which][0]
                sg, D, _ = laws[ks]
                v_in = max(float(sg * y[1]), v_floor)
                f0 = self._force(v_in, ks)(y[0], y[1])
                cur = [t, v_in, y[2], f0, sg * y[0] - D]
                if t >= t_rec:
                    entries.append((t - t_rec, v_in, ks))
            else:
                k = tags[which][0]
                y[0] = min(y[0], laws[0][1]) if k == 0 else max(y[0], -laws[1][1])
        # samples and extremes from the dense segments
        minima, q_min, q_max = [], np.inf, -np.inf
        for ti, qi, sgi in impacts_at:
            if sgi < 0.0:   # a lower stop: a minimum of q
                minima.append((ti, qi))
                q_min = min(q_min, qi)
            else:
                q_max = max(q_max, qi)
        for (a, b, sol, md, force) in segs:
            sel = (ts >= a) & (ts <= b)
            if sel.any():
                samples[sel] = sol(ts[sel])[:2].T
            lo, hi = max(a, t_rec), b
            if hi <= lo:
                continue
            grid = np.linspace(lo, hi, 65)
            vv = sol(grid)[1]
            for i in np.nonzero(np.sign(vv[:-1]) * np.sign(vv[1:]) < 0)[0]:
                tr = brentq(lambda x: sol(x)[1], grid[i], grid[i + 1], xtol=1e-15)
                qr = float(sol(tr)[0])
                if vv[i] < 0:
                    minima.append((tr, qr))
                    q_min = min(q_min, qr)
                else:
                    q_max = max(q_max, qr)
        pmin = samples[:, 0].reshape(n_record, spp).min(axis=1) if ts.size else np.zeros(0)
        for tm, qm in minima:
            kp = min(max(int((tm - t_rec) // T), 0), n_record - 1)
            pmin[kp] = min(pmin[kp], qm)
        q_min = min(q_min, float(np.min(samples[:, 0]))) if ts.size else q_min
        q_max = max(q_max, float(np.max(samples[:, 0]))) if ts.size else q_max
        it = np.array([e[0] for e in entries])
        iv = np.array([e[1] for e in entries])
        ik = np.array([e[2] for e in entries], np.int64)
        con = np.array(contacts, float).reshape(-1, 5)
        ph = 0.0 if mode != "contact" else (1.0 if ks == 0 else -1.0)
        return Trajectory(Omega=Omega, samples=samples, samples_per_period=spp, impact_times=it,
                          impact_velocities=iv, n_impacts=int(it.size), q_min=q_min, q_max=q_max,
                          period_min=pmin, final_state=np.array([y[0], y[1], ph]),
                          contacts=con, impact_stops=ik if two else None,
                          contact_stops=np.array(contact_k, np.int64) if two else None,
                          n_impacts_lower=int(np.sum(ik == 1)) if two else 0)

    @staticmethod
    def _peaks(cur, a, b, sol, force, Delta, sg=1.0):
        """Update the peak force ``cur[3]`` and the largest penetration ``cur[4]`` (``sg q -
        Delta``) of the open contact with the dense output on ``[a, b]``."""
        grid = np.linspace(a, b, 64)
        funs = ((3, lambda x: force(*sol(x)[:2])), (4, lambda x: sg * sol(x)[0] - Delta))
        for slot, fun in funs:
            vals = np.array([fun(x) for x in grid])
            i = int(np.argmax(vals))
            best = vals[i]
            if 0 < i < grid.size - 1:
                r = minimize_scalar(lambda x: -fun(x), bounds=(grid[i - 1], grid[i + 1]), method="bounded",
                                    options=dict(xatol=1e-14 * max(1.0, abs(b))))
                best = max(best, -r.fun)
            cur[slot] = max(cur[slot], best)
        return cur

    def _failed(self, Omega, samples, spp, msg):
        return Trajectory(Omega=Omega, samples=samples, samples_per_period=spp, impact_times=np.zeros(0),
                          impact_velocities=np.zeros(0), n_impacts=0, q_min=np.nan, q_max=np.nan,
                          status="failed", message=msg, final_state=self.model.initial_state())
