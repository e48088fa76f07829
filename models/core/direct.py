"""The one direct solver: the modal system with its stops integrated by ``solve_ivp`` (a reference).

Method ``direct`` of the modal fidelities, an independent check of the event integrator
(:mod:`vibeam.models.core.integrator`) that shares only the model with it: the equations of motion
are integrated by :func:`scipy.integrate.solve_ivp` (DOP853 by default) with events built from the
stops' relations:

free flight
    ``eta'' = Gamma F sin(Omega t) - C eta' - K eta``; a terminal event on every stop's gap ``g_k =
    n_k^T eta - D_k`` rising through zero, and one on the sensor velocity (the output's extremes);
held on a set ``H`` of stops
    the constrained modes ``zeta`` of :class:`~vibeam.models.core.stops.HeldSets` (``eta = eta_c +
    Psi zeta``); terminal events on each held stop's contact force ``lambda_k`` rising through zero
    (release) and on the gap of every other stop;
a contact
    Newton's law through the mass matrix along the stop's normal projected on the held constraints
    (:mod:`vibeam.models.contact`); an impact slower than ``chatter_velocity`` times the first
    impact's speed into a pressing contact acceleration ends a chatter (plastic projection, then
    held): a crude chatter model, fine for a reference of impacting and sticking orbits, not for
    resolving chatter (the event integrator sums chatter in closed form).

The state is scaled by ``1 / state_scale`` (the beam's ``L sqrt(m_eff)``) so that it is of the order
of the output; steps are capped at ``T / 16`` so that an event's sign change is not stepped over
(``solve_ivp`` only checks signs at step ends: detection is not guaranteed, unlike the integrator's).
"""
from __future__ import annotations

import math

import numpy as np

from ..impact import newton_restitution
from ..trajectory import Trajectory
from .event import EventIntegrator
from .stops import held_code

__all__ = ["DirectIntegrator"]

TWO_PI = 2.0 * math.pi


class DirectIntegrator:
    """``solve_ivp`` on a modal system with impulsive stops (module docstring).

    Parameters
    ----------
    core : EventIntegrator
        The system and its stops in kernel form (the held sets included).
    state_scale : float
        The integration's unit of the modal coordinates (row units).
    solver, rtol, atol : str, float, float
        :func:`scipy.integrate.solve_ivp` settings.
    max_impacts_per_period : int
    chatter_velocity : float
        Relative speed below which an impact into a pressing contact ends a chatter.
    max_step : float or None
        Largest step (default ``T / 16``).
    """

    def __init__(self, core: EventIntegrator, state_scale: float = 1.0, solver: str = "DOP853",
                 rtol: float = 1e-9, atol: float = 1e-12, max_impacts_per_period: int = 200,
                 chatter_velocity: float = 1e-6, max_step: float | None = None):
        self.core = core
        self.sc = float(state_scale)
        self.solver = solver
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.chatter_velocity = float(chatter_velocity)
        self.max_step = max_step

    def run(self, Omega, state0, n_transient, n_record, samples_per_period, scale, contacts_of, stop_codes=None):
        """One forcing frequency from ``state0`` (``(eta, eta', held code)``, row units).

        Parameters
        ----------
        Omega : float
        state0 : ndarray, shape (2n + 1,)
        n_transient, n_record, samples_per_period : int
        scale : float
            Row value per unit of the output ``q`` (:attr:`~vibeam.models.system.ModalSystem.coordinate_scale`).
        contacts_of : callable
            ``contacts_of(stop)`` -> the law object of a stop (its ``coefficient(U-)``): the
            stops' own laws, as the fidelity holds them.
        stop_codes : ndarray of int, optional
            As :func:`vibeam.models.core.event.trajectory`.

        Returns
        -------
        Trajectory
            As the event solver's (samples of ``q``, impacts with their stops and the energy each
            removed, ``final_state``), or a failed one with the reason.
        """
        from scipy.integrate import solve_ivp

        core = self.core
        st, hs, sy = core.kstops, core.held, core.ksys
        N = core.n
        ns = core.n_stops
        Om = float(Omega)
        sc = self.sc
        T = TWO_PI / Om
        F = Om * Om * sy.B
        k, c = sy.k, sy.c
        GF = sy.gam * F / sc
        sv = sy.sensor
        Nrm = st.normal
        D = st.offset / sc
        s0 = np.asarray(state0, dtype=float)
        y = s0[:2 * N] / sc
        H = core.held_set_of(s0[2 * N]) if s0.shape[0] > 2 * N else 0

        def rhs(t, z):
            return np.concatenate([z[N:], GF * math.sin(Om * t) - c * z[N:] - k * z[:N]])

        def held_data(H):
            nc = int(hs.nc[H])
            return dict(nc=nc, Psi=hs.Psi[H][:, :nc], etac=hs.eta_c[H] / sc, e=hs.e[H, :nc] / sc,
                        c=hs.c[H, :nc], nu2=hs.nu2[H, :nc], G=hs.gam[H, :nc] * F / sc)

        def to_zeta(hd, y):
            return np.concatenate([hd["Psi"].T @ (y[:N] - hd["etac"]), hd["Psi"].T @ y[N:]])

        def full(hd, zc):            # constrained -> full state, columns
            nc = hd["nc"]
            return np.concatenate([hd["etac"][:, None] + hd["Psi"] @ zc[:nc], hd["Psi"] @ zc[nc:2 * nc]])

        def lam(H, k_, t, eta, etad):
            """Contact force of held stop k_ (scaled; held while <= 0): gw^T (K eta + C eta' - Gamma F sin)."""
            g = hs.gw[H, k_]
            return float(g @ (k * eta + c * etad - GF * math.sin(Om * t)))

        def lam_z(H, k_, t, z, nc):
            """The same in the constrained coordinates ``z = (zeta, zeta')`` (scaled): ``pL zeta +
            rL zeta' + cL + lamF F sin`` (:class:`~vibeam.models.core.stops.HeldSets`)."""
            # HeldSets.cL holds pL e besides the force of eta_c (the kernel's signals are of the
            # homogeneous parts, zeta - e - particular); here of zeta itself
            out = (hs.cL[H, k_] - hs.pL[H, k_, :nc] @ hs.e[H, :nc] + hs.lamF[H, k_] * F * math.sin(Om * t)) / sc
            if nc:
                out += hs.pL[H, k_, :nc] @ z[:nc] + hs.rL[H, k_, :nc] @ z[nc:2 * nc]
            return float(out)

        def acc_along(d, t, y):
            return float(d @ (GF * math.sin(Om * t) - c * y[N:] - k * y[:N]))

        def project(H, y):
            """The state on the constraint of held set H (position and velocity)."""
            hd = held_data(H)
            return full(hd, to_zeta(hd, y)[:, None])[:, 0]

        t = 0.0
        t_end = (n_transient + n_record) * T
        t_rec = n_transient * T
        ts = t_rec + np.arange(n_record * samples_per_period) * (T / samples_per_period)
        samples = np.zeros((ts.size, 2))
        filled = np.zeros(ts.size, bool)
        ext = [np.inf, -np.inf]
        ev_min = []
        imp_t, imp_v, imp_k, imp_e = [], [], [], []
        n_imp = 0
        n_chat = 0
        stuck_time = 0.0
        max_imp = self.max_impacts_per_period * (n_transient + n_record)
        vscale = None
        modamp = np.zeros(N)
        max_step = min(T / 16, self.max_step or np.inf)
        if H:
            y = project(H, y)
        else:
            for j in range(ns):   # at rest on a stop: held if the contact force presses
                gj = Nrm[j] @ y[:N] - D[j]
                if gj >= -1e-13 * (abs(D[j]) + np.abs(Nrm[j]) @ np.abs(y[:N])) and Nrm[j] @ y[N:] <= 0:
                    H = 1 << j
                    y = project(H, y)
                    break
        guard = 0
        while t < t_end:
            guard += 1
            if guard > 10 * max_imp + 100:
                return self._failed(Om, s0, n_record, samples_per_period, "no progress")
            hit, released = -1, -1
            if H:
                hd = held_data(H)
                held_k = [j for j in range(ns) if H >> j & 1]
                nc = hd["nc"]
                zc = to_zeta(hd, y) if nc else np.zeros(2)
                # a held stop whose force pulls away now (or is zero and about to): released at once;
                # the force as the release event computes it (constrained coordinates), so that the
                # two never disagree at round-off
                eps_t = 1e-9 * T
                pull = [j for j in held_k if lam_z(H, j, t, zc, nc) > 0.0 or
                        (lam_z(H, j, t, zc, nc) == 0.0 and lam_z(H, j, t + eps_t, zc, nc) > 0.0)]
                if pull:
                    H &= ~(1 << pull[0])
                    continue

                def rhs_c(tt, z, hd=hd, nc=nc):
                    if nc == 0:
                        return np.zeros(2)
                    return np.concatenate([z[nc:], hd["G"] * math.sin(Om * tt) - hd["c"] * z[nc:]
                                           - hd["nu2"] * (z[:nc] - hd["e"])])

                events, kinds = [], []
                for j in held_k:
                    def ev(tt, z, j=j, H=H, nc=nc):
                        return lam_z(H, j, tt, z, nc)
                    ev.terminal, ev.direction = True, 1.0
                    events.append(ev)
                    kinds.append(("release", j))
                for j in range(ns):
                    if H >> j & 1 or not hs.moves[H, j]:
                        continue

                    def ev(tt, z, j=j, hd=hd):
                        return float(Nrm[j] @ (hd["etac"] + hd["Psi"] @ z[:nc])) - D[j]
                    ev.terminal, ev.direction = True, 1.0
                    events.append(ev)
                    kinds.append(("gap", j))

                def ev_sens(tt, z, hd=hd, nc=nc):
                    return float(sv @ (hd["Psi"] @ z[nc:2 * nc])) if nc else 1.0
                events.append(ev_sens)
                kinds.append(("sensor", -1))
                sol = solve_ivp(rhs_c, (t, t_end), zc, method=self.solver, rtol=self.rtol, atol=self.atol,
                                events=events, dense_output=True, max_step=max_step)
                if sol.status < 0:
                    return self._failed(Om, s0, n_record, samples_per_period, sol.message)
                t1 = sol.t[-1]

                def Zf(tt, hd=hd, sol=sol):
                    return full(hd, np.atleast_2d(sol.sol(tt).T).T)
                if t1 > t_rec:
                    stuck_time += t1 - max(t, t_rec)
                y = Zf(np.array([t1]))[:, 0]
            else:
                events, kinds = [], []
                for j in range(ns):
                    def ev(tt, z, j=j):
                        return float(Nrm[j] @ z[:N]) - D[j]
                    ev.terminal, ev.direction = True, 1.0
                    events.append(ev)
                    kinds.append(("gap", j))

                def ev_sens(tt, z):
                    return float(sv @ z[N:])
                events.append(ev_sens)
                kinds.append(("sensor", -1))
                sol = solve_ivp(rhs, (t, t_end), y, method=self.solver, rtol=self.rtol, atol=self.atol,
                                events=events, dense_output=True, max_step=max_step)
                if sol.status < 0:
                    return self._failed(Om, s0, n_record, samples_per_period, sol.message)
                t1 = sol.t[-1]
                Zf = sol.sol
                y = sol.y[:, -1].copy()
            if sol.status == 1:
                for i, (kind, j) in enumerate(kinds):
                    if kind != "sensor" and sol.t_events[i].size:
                        if kind == "release":
                            released = j
                        else:
                            hit = j
                        break
            sel = (ts >= t - 1e-12 * T) & (ts <= t1) & ~filled
            if np.any(sel):
                Z = Zf(ts[sel])
                samples[sel, 0] = sv @ Z[:N] * sc / scale
                samples[sel, 1] = sv @ Z[N:] * sc / scale
                filled[sel] = True
                modamp = np.maximum(modamp, np.max(np.abs(Z[:N]), axis=1) * sc)
            for te in sol.t_events[-1]:
                if te >= t_rec:
                    qv = float(sv @ Zf(np.array([te]))[:N, 0]) * sc / scale
                    ev_min.append((te, qv))
                    ext[0] = min(ext[0], qv)
                    ext[1] = max(ext[1], qv)
            t = t1
            if released >= 0:
                H &= ~(1 << released)
                continue
            if hit < 0:
                continue
            # ---- a contact on stop `hit`, held set H kept: impulse along d = Pi_H n
            if H:
                d, me = hs.dirn[H, hit], float(hs.meff[H, hit])
            else:
                d, me = Nrm[hit], float(st.m_eff[hit])
            n_ = Nrm[hit]
            Um = float(n_ @ y[N:])
            if vscale is None:
                vscale = max(abs(Um), 1e-300)
            n_imp += 1
            if n_imp > max_imp:
                return self._failed(Om, s0, n_record, samples_per_period, "too many impacts")
            rec = t >= t_rec
            ke0 = 0.5 * float(y[N:] @ y[N:])
            if rec:
                imp_t.append(t - t_rec)
                imp_v.append(max(Um, 0.0) * sc / scale)
                imp_k.append(hit)
                qv = float(sv @ y[:N]) * sc / scale
                ext[0] = min(ext[0], qv)
                ext[1] = max(ext[1], qv)
            H2 = H | (1 << hit)
            can_hold = bool(hs.valid[H2])
            law = contacts_of(hit)
            if Um <= self.chatter_velocity * vscale and can_hold:
                y = project(H2, y)
                if rec:
                    imp_e.append(ke0 - 0.5 * float(y[N:] @ y[N:]))
                if acc_along(d, t, y) > 0:
                    H = H2
                    n_chat += rec
                continue
            Up = newton_restitution(Um, law.coefficient(Um * sc))
            y[N:] += d * me * (Up - Um)
            if rec:
                imp_e.append(ke0 - 0.5 * float(y[N:] @ y[N:]))
            if Up == 0.0 and can_hold and acc_along(d, t, y) > 0:   # plastic into a pressing contact
                y = project(H2, y)
                H = H2
        q = samples[:, 0]
        pmin = q.reshape(n_record, samples_per_period).min(axis=1) if q.size else np.zeros(n_record)
        for te, qv in (ev_min if n_record else []):
            kp = min(max(int((te - t_rec) // T), 0), n_record - 1)
            pmin[kp] = min(pmin[kp], qv)
        status = "chatter" if n_chat else ("sticking" if stuck_time > 0 else "ok")
        two = ns > 1
        ik = np.array(imp_k, np.int64)
        extra_stop = {}
        if stop_codes is not None:
            codes = np.asarray(stop_codes, np.int64)
            ik = codes[ik] if ik.size else ik
            per = np.zeros(int(codes.max()) + 1)
            np.add.at(per, ik, 1.0)
            extra_stop = {"stop_impacts": per}
        return Trajectory(
            Omega=Om, samples=samples, samples_per_period=samples_per_period,
            impact_times=np.array(imp_t), impact_velocities=np.array(imp_v), n_impacts=len(imp_t),
            contacts=np.column_stack([np.zeros(len(imp_e)), np.full(len(imp_e), np.nan), np.zeros(len(imp_e)),
                                      np.array(imp_e, float), np.array(imp_v, float)]).reshape(-1, 5),
            impact_stops=ik if two else None, n_impacts_lower=int(np.sum(ik == 1)) if two else 0,
            q_min=float(min(ext[0], q.min())) if q.size else float(ext[0]),
            q_max=float(max(ext[1], q.max())) if q.size else float(ext[1]), period_min=pmin,
            status=status, message="" if status == "ok" else f"stuck {stuck_time:.4g} of the window",
            final_state=np.concatenate([y * sc, [float(held_code(H))]]),
            extra={"mode_amplitudes": modamp,
                   "stuck_fraction": float(stuck_time / (n_record * T)) if n_record else 0.0, **extra_stop})

    def _failed(self, Om, s0, n_record, spp, msg):
        return Trajectory(Omega=Om, samples=np.full((n_record * spp, 2), np.nan), samples_per_period=spp,
                          impact_times=np.zeros(0), impact_velocities=np.zeros(0), n_impacts=0,
                          q_min=np.nan, q_max=np.nan, status="failed", message=msg,
                          final_state=np.asarray(s0, float).copy(),
                          extra={"mode_amplitudes": np.full(self.core.n, np.nan), "stuck_fraction": np.nan})
