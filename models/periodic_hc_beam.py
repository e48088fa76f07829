"""Shooting problem of the modal FE beam on a Hunt-Crossley stop (one stop).

Contract: :mod:`vibeam.models.periodic` (driven unchanged by :mod:`vibeam.models.continuation`).
The model is :mod:`vibeam.models.beam_hc`'s (kernel units: ``eta``, ``eta'``, gap ``g = w^T eta
- Delta_C`` in m, force ``k g^p (1 + chi g' / v_r)``, ``v_r = max(v_in, v_floor)``).

A shot is one run of the one compliant beam event kernel
(:func:`vibeam.models.beam_compliant.beam_compliant_kernel`, the stop's law dispatched inside it)
over ``n`` periods: its end state is the shot's value, so a branch follows the orbit of method ``event``.
The derivatives are composed along the kernel's contacts on a rebuilt trajectory:

* free flight: the exact modal flow of the free phase (as
  :class:`~vibeam.models.periodic_compliant.CompliantBeamShooting`), with ``d/dOmega`` and
  ``d/dY`` of its forced response;
* contact: the ``2N`` modal state and its variational equations ``J' = A(t) J + d(acc)/dp -
  w f_vr dv_r/d(x0, p)`` integrated by :func:`scipy.integrate.solve_ivp` (DOP853, ``rtol =
  1e-12``) from the kernel's entry time to the exit, where the force returns to zero (``g``
  falls through 0, or the damping factor ``1 + chi g' / v_r`` does);
* entry: the force ``k g^p (...)`` is zero at ``g = 0``, so the vector field is continuous and
  the saltation matrix is ``S = I``; but ``v_r`` is the entry velocity, whose sensitivity
  ``dv_in = w^T (J_v + eta''_- dt)``, ``dt = -w^T J_eta / v_in`` (``h_p = 0``: ``Omega`` and
  ``Y`` do not move the stop) enters the contact's variational equations (below the floor,
  ``v_r = v_floor = 1e-2 Omega Y |w^T Gamma|`` and ``dv_r = (0, ..., d/dOmega, d/dY)``);
* exit: the force is zero again, ``S = I``;
* the window ends at ``n T``: ``J_Omega += z'(nT) d(nT)/dOmega``.

So ``P^n`` and its derivatives are accurate to the integrator, not exact: the kernel's contact
phase is its own Dormand-Prince 5(4) at ``rtol = 1e-11`` and the derivatives' trajectory is
DOP853's at ``rtol = 1e-12`` (on the rig they agree to ~2e-11 of the state, as does the
solve_ivp reference of method ``direct``); ``P^n`` is smooth only to about that level (adaptive
steps change with ``x0``), so its difference quotients and Newton's residual stop there, not at
round-off (central differences of the shot match the Jacobian to ~3e-9).

Not represented (``status = "failed"`` with the reason, never a crash): a section inside the
stop (the open contact depends on its ``v_r``, which is not part of the state), a re-entry
inside the stop after a damping-factor exit (it depends on the previous contact's ``v_r``),
more than ``max_contacts`` contacts.  ``apex_gap`` (m) is the largest interior free-flight
maximum of ``g`` below the stop (a grazing contact is born where it reaches 0); interior force
minima during a contact are not watched.  Parameters ``Omega``, ``base_amplitude_m``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .beam_compliant import FREE
from .periodic import Shot
from .periodic_compliant import BEAM_PARAMETERS, TWO_PI, CompliantBeamShooting, failed_shot


@njit(cache=True)
def _hc_beam_variational(t, y, vr, dvr, DC, kc, pe, chi, knd, cnd, part, w, Om, Yb):
    """Right-hand side of the beam's Hunt-Crossley contact phase and its variational equations:
    ``y = (eta, eta', J (2N, 2N + 2) row-major)``, ``J = d(eta, eta') / d(x0, Omega, Y)``;
    ``dvr`` (2N + 2,) the sensitivity of the contact's ``v_r``."""
    N = knd.shape[0]
    n2 = 2 * N
    nc = n2 + 2
    g = -DC
    gd = 0.0
    for i in range(N):
        g += w[i] * y[i]
        gd += w[i] * y[N + i]
    dp = g if g > 0.0 else 0.0
    fac = 1.0 + chi * gd / vr
    f = kc * dp ** pe * fac
    F = Om * Om * Yb
    sn = math.sin(Om * t)
    cs = math.cos(Om * t)
    out = np.empty(y.shape[0])
    for i in range(N):
        out[i] = y[N + i]
        out[N + i] = part[i] * F * sn - cnd[i] * y[N + i] - knd[i] * y[i] - w[i] * f
    f_g = kc * pe * dp ** (pe - 1.0) * fac if dp > 0.0 else 0.0
    f_gd = kc * dp ** pe * chi / vr
    f_vr = -kc * dp ** pe * chi * gd / (vr * vr)
    for j in range(nc):
        wq = 0.0
        wv = 0.0
        for i in range(N):
            wq += w[i] * y[n2 + i * nc + j]
            wv += w[i] * y[n2 + (N + i) * nc + j]
        df = f_g * wq + f_gd * wv + f_vr * dvr[j]
        for i in range(N):
            out[n2 + i * nc + j] = y[n2 + (N + i) * nc + j]
            out[n2 + (N + i) * nc + j] = -knd[i] * y[n2 + i * nc + j] - cnd[i] * y[n2 + (N + i) * nc + j] - w[i] * df
    for i in range(N):
        out[n2 + (N + i) * nc + n2] += part[i] * (2.0 * Om * Yb * sn + F * t * cs)
        out[n2 + (N + i) * nc + n2 + 1] += part[i] * Om * Om * sn
    return out


class HuntCrossleyBeamShooting(CompliantBeamShooting):
    """Shooting problem ``P^n`` of the modal FE beam (any number of modes) on one Hunt-Crossley
    stop (module docstring; contract :mod:`vibeam.models.periodic`).  Accurate to the
    integrator, not exact.

    Parameters
    ----------
    model : vibeam.models.beam_compliant.CompliantBeamModel
        With ``contact`` a :class:`vibeam.models.compliant.HuntCrossley`, one stop.
    parameter : {"Omega", "base_amplitude_m"}
    Omega : float, optional
        Forcing frequency ``f / f_ref``; required unless ``parameter == "Omega"``.
    steps_per_fundamental : int, optional
        As :class:`~vibeam.models.beam_hc.HuntCrossleyBeamEventSolver`.
    max_contacts : int, optional
        Most contacts in one shot (beyond: ``status = "failed"``).
    rtol : float, optional
        Relative tolerance of the contact phases' variational integration.

    Raises
    ------
    ValueError
        For another law, a second stop, an unknown parameter or a missing ``Omega``.
    """

    def __init__(self, model, parameter: str = "Omega", Omega: float | None = None,
                 steps_per_fundamental: int = 16, max_contacts: int = 4096, rtol: float = 1e-12):
        if getattr(model, "contact", None) is None or getattr(model.contact, "name", "") != "hunt_crossley":
            raise ValueError("HuntCrossleyBeamShooting needs a beam model with contact law \"hunt_crossley\"")
        if getattr(model, "two_sided", False):
            raise ValueError("continuation with contact law \"hunt_crossley\" on the beam follows one stop")
        if parameter not in BEAM_PARAMETERS:
            raise ValueError(f"parameter {parameter!r} cannot be continued with contact law \"hunt_crossley\" on "
                             f"the beam; allowed: {', '.join(BEAM_PARAMETERS)}")
        if parameter != "Omega" and Omega is None:
            raise ValueError(f"continuation in {parameter!r} needs the forcing frequency Omega")
        self.model = model
        self.two = False
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

    def data(self, p: float) -> dict:
        """Free-phase data at ``p`` (cached for the last ``p``), in the layout of
        :meth:`CompliantBeamShooting.data` (phase index 0 only)."""
        from .beam_compliant import ensure_eig, phase_data, phase_steps, velocity_floor
        from .beam_hc import free_data

        if self._key == float(p):
            return self._data
        m = self.model_at(p)
        Om = float(p) if self.parameter == "Omega" else self.Omega
        N = m.n_modes
        n2 = 2 * N
        lam, V, W, Z, PU, PS, bU, bS, F = free_data(m, Om)
        ensure_eig(m)
        A = m._hc_eig[0]
        b = np.concatenate([np.zeros(N), m.participation])
        Yb = m.base_amplitude_m
        Rinv = np.linalg.inv(1j * Om * np.eye(n2) - A)
        Zu = Rinv @ b
        dZ = np.empty((1, 2, n2), complex)
        dZ[0, 0] = 2.0 * Om * Yb * Zu - 1j * F * (Rinv @ Zu)
        dZ[0, 1] = Om * Om * Zu
        law = m.contact
        ze = np.zeros((1, n2))
        wG = abs(float(m.contact_row @ m.participation))
        vf = velocity_floor(m, Om)
        from .sdof_compliant import HC_V_FLOOR
        dvf = np.array([HC_V_FLOOR * Yb * wG, HC_V_FLOOR * Om * wG]) if Yb * wG > 0.0 else np.zeros(2)
        D = dict(m=m, Om=Om, A=A[None], b=b * F, b0=np.zeros((1, n2)), F=F, Yb=Yb,
                 kc=1.0, cc=0.0,         # the free-flight grazing scan's "force" is g itself (see _extremes_stop)
                 khc=law.stiffness / m.omega_ref ** 2, pe=float(law.exponent), chi=float(law.chi),
                 lam=lam[None], V=V[None], W=W[None], pd=(lam[None], V[None], W[None], Z[None], ze),
                 dZ=dZ, hmax=np.array([TWO_PI / math.sqrt(m.k_nd[0]) / self.steps_per_fundamental]),
                 v_floor=vf, dv_floor=dvf,
                 phases=phase_data(m, Om)[:11], stops=m.kernel_stops(),
                 hmaxes=phase_steps(m, self.steps_per_fundamental))
        self._key, self._data = float(p), D
        return D

    def _extremes(self, D, r, z, ta, tb):
        """Free-flight maxima of ``g`` below the stop (m); contact phases are not scanned."""
        if tb <= ta or r != FREE:
            return -np.inf
        rowU = np.concatenate([self.model.contact_row, np.zeros(self.model.n_modes)])
        return self._extremes_stop(D, FREE, z, ta, tb, rowU, 0)

    def shot(self, x0, p, n: int = 1) -> Shot:
        """``P^n(x0; p)`` with monodromy and ``d/dp`` (module docstring).

        Parameters
        ----------
        x0 : array_like, shape (2N,)
            ``(eta, eta')`` at forcing phase 0, below the stop (``g < 0``).
        p : float
            Parameter value (native units).
        n : int
            Forcing periods.

        Returns
        -------
        Shot
            As :meth:`CompliantBeamShooting.shot`; ``x`` is the event kernel's end state,
            ``extra["rebuilt_state"]`` the derivatives' (DOP853) one.
        """
        from scipy.integrate import solve_ivp

        from .beam_compliant import beam_compliant_kernel

        n = int(n)
        x0 = np.asarray(x0, float)
        if not (np.all(np.isfinite(x0)) and math.isfinite(float(p)) and n >= 1) or \
                (self.parameter == "Omega" and not p > 0.0):
            return failed_shot(self.dim, f"parameters or state out of range ({self.parameter} = {p}, n = {n})")
        D = self.data(p)
        m, Om = D["m"], D["Om"]
        N = m.n_modes
        n2 = 2 * N
        w = m.contact_row
        DC = m.gap_contact_m
        L = m.length_m
        T = TWO_PI / Om
        t_end = n * T
        if float(w @ x0[:N]) - DC >= 0.0:
            return failed_shot(self.dim, "the section lies inside the stop: a Hunt-Crossley contact depends on its "
                                       "entry velocity, which is not part of the state (eta, eta')")
        kc, pe, chi = D["khc"], D["pe"], D["chi"]
        cap = self.max_contacts
        ns = 4
        samples = np.zeros((n * ns, 2))
        pmin = np.zeros(n)
        imp_t = np.zeros(cap)
        imp_v = np.zeros(cap)
        con = np.full((cap, 5), np.nan)
        z = x0.copy()
        lamA, VA, WA, ZA, zeA, PU, PS, bU, bS, gU, gS = D["phases"]
        status, n_rec, smin, smax, ph_end, n_con, t_con, n_steps, _ = beam_compliant_kernel(
            Om, lamA, VA, WA, ZA, zeA, PU, PS, w, m.sensor_row, bU, bS, gU, gS, D["stops"], m.k_nd, m.c_nd,
            m.participation, D["F"], D["v_floor"], z, FREE, 0, n, 1, ns, D["hmaxes"], cap, 200000 * n, samples, pmin,
            imp_t, imp_v, con, np.zeros(cap, np.int64), np.zeros((0, n2)))
        if status != 0 or n_rec > cap:
            return failed_shot(self.dim, f"the event kernel gave up after {n_con} contacts / {n_steps} steps in "
                                       f"{n} period(s)")
        wn = math.sqrt(float(w @ w))
        J = np.zeros((n2, n2 + 2))
        J[:, :n2] = np.eye(n2)
        zc = x0.copy()
        ta = 0.0
        apex = -np.inf
        entries, rates, contacts = [], [], []
        t_c = 0.0
        inside = False          # free inside the stop after a damping-factor exit
        in_contact_end = False
        knd, cnd, part = m.k_nd, m.c_nd, m.participation
        atol_J = np.full(n2 * (n2 + 2), 1e-13)
        for r in range(n_rec + 1):
            tb = float(imp_t[r]) if r < n_rec else t_end
            tb = max(tb, ta)
            # free flight [ta, tb], exact
            Phi = self._stm(D, FREE, tb - ta)
            za = zc
            zc = Phi @ (zc - self._zp(D, FREE, ta)) + self._zp(D, FREE, tb)
            J = Phi @ J
            for j in range(2):
                J[:, n2 + j] += self._dzp(D, FREE, tb, j) - Phi @ self._dzp(D, FREE, ta, j)
            apex = max(apex, self._extremes(D, FREE, za, ta, tb))
            ta = tb
            if r == n_rec:
                break
            if inside and float(w @ zc[:N]) - DC > 1e-9 * max(abs(DC), 1e-12):
                return failed_shot(self.dim, "re-entry inside the stop after a damping-factor exit (depends on the "
                                           "previous contact's entry velocity): not represented")
            # entry: S = I (zero force), v_r and its sensitivity
            U = float(w @ zc[N:])
            a_m = float(w @ self._field(D, FREE, zc, tb)[N:])
            if not U > 0.0:
                return failed_shot(self.dim, f"contact entry with non-positive velocity {U:.3g} (inconsistent record)")
            dt = -(w @ J[:N, :]) / U
            if U > D["v_floor"]:
                vr, dvr = U, w @ J[N:, :] + a_m * dt
            else:
                vr, dvr = D["v_floor"], np.concatenate([np.zeros(n2), D["dv_floor"]])
            entries.append(tb)
            rates.append(U / L)
            pen = ((pe + 1.0) * vr * vr / (2.0 * kc * wn * wn)) ** (1.0 / (pe + 1.0))

            def ev_gap(tt, y, *args):
                return float(w @ y[:N]) - DC
            ev_gap.terminal, ev_gap.direction = True, -1.0

            def ev_fac(tt, y, *args, vr=vr):
                return 1.0 + chi * float(w @ y[N:n2]) / vr
            ev_fac.terminal, ev_fac.direction = True, -1.0
            y0 = np.concatenate([zc, J.ravel()])
            atol = np.concatenate([np.full(N, 1e-13 * pen / wn), np.full(N, 1e-13 * vr / wn),
                                   atol_J * max(float(np.max(np.abs(J))), 1.0)])
            sol = solve_ivp(_hc_beam_variational, (tb, t_end), y0, method="DOP853", rtol=self.rtol, atol=atol,
                            events=(ev_gap, ev_fac), first_step=1e-3 * pen / vr,
                            args=(vr, dvr, DC, kc, pe, chi, knd, cnd, part, w, Om, D["Yb"]))
            if sol.status < 0:
                return failed_shot(self.dim, f"the contact phase's integration failed: {sol.message}")
            yend = sol.y[:, -1]
            zc = yend[:n2].copy()
            J = yend[n2:].reshape(n2, n2 + 2).copy()
            t_x = float(sol.t[-1])
            t_c += t_x - tb
            ta = t_x
            if sol.status == 1:
                contacts.append(con[r, :4])
                inside = not sol.t_events[0].size and float(w @ zc[:N]) - DC > 0.0
            else:
                in_contact_end = True
                break
        if in_contact_end:
            g = float(w @ zc[:N]) - DC
            f = kc * max(g, 0.0) ** pe * (1.0 + chi * float(w @ zc[N:]) / vr)
            fld = self._field(D, FREE, zc, t_end)
            fld[N:] -= w * f
        else:
            fld = self._field(D, FREE, zc, t_end)
        J[:, n2] += fld * (-t_end / Om)
        if not np.all(np.isfinite(J)):
            return failed_shot(self.dim, "non-finite derivatives")
        jcol = n2 + BEAM_PARAMETERS.index(self.parameter)
        extra = {"x_all_p": J[:, n2:].copy(), "contact_time": t_c, "rebuilt_state": zc,
                 "contacts": np.array(contacts, float).reshape(-1, 4), "in_contact_end": in_contact_end}
        return Shot(x=z.copy(), M=J[:, :n2].copy(), x_p=J[:, jcol].copy(), impact_times=np.array(entries, float),
                    impact_velocities=np.array(rates, float), q_min=float(smin / L), q_max=float(smax / L),
                    apex_gap=float(apex), stuck_time=0.0, status="ok", message="", Omega=Om, gap=m.Delta,
                    extra=extra)

    def start(self, kind: str, p: float, n: int = 1):
        """As :meth:`CompliantBeamShooting.start` (the contact-free steady state)."""
        return super().start(kind, p, n)
