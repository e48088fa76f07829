"""Method ``mapping`` on a Kelvin-Voigt stop: the piecewise-linear map of paper Sec. 4.2.

The section is contact entry, ``q = Delta`` with ``q' = v > 0`` at time ``t`` (forcing phase
``Omega t``).  One contact per ``n`` forcing periods composes two exact linear flows, the
phases of the SDOF (:class:`LinearPhase`)::

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
saltation arises).  The eigenvalues of ``d(t1, v1) / d(t0, v0)`` are the orbit's Floquet
multipliers.  The phases are stepped by :func:`phase_step`, every event (exit, entry, the gap
back through zero) and every extreme (of ``q``, the contact force, the penetration) located by
the certified scans of the event integrator (:mod:`vibeam.models.core.signals`), the work done
on the stop by 8-point Gauss-Legendre on each contact step (as
:func:`vibeam.models.core.contact_phase.linear_step` records it).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .core.contact_phase import GL_W, GL_X
from .core.signals import bounds, extremes, homogeneous_bounds, scan, signal
from .registry import family_laws
from .system import mode_table, particular, transition_entries

TWO_PI = 2.0 * math.pi
#: the phases of :func:`phase_step`
FREE, CONTACT = 0, 1
#: how a step of :func:`phase_step` ended: the whole step, a contact entry, a contact exit (the
#: force back to zero), the gap back down through zero (after an exit inside the stop), failed
EV_NONE, EV_ENTRY, EV_EXIT, EV_GAPDOWN, EV_FAIL = 0, 1, 2, 3, -1


class LinearPhase:
    """One linear phase of the SDOF: ``q'' + 2 b w q' + w^2 (q - q_e) = F sin(Omega t)``.

    Free (``k_c = c_c = 0``): ``w = 1``, ``b = beta``, ``q_e = 0``; pressed by a Kelvin-Voigt
    stop ``(k_c, c_c)`` at ``Delta``: ``w^2 = 1 + k_c``, ``2 b w = 2 beta + c_c``, ``q_e = k_c
    Delta / (1 + k_c)``.  In the form of the event integrator's signals: one coordinate, the
    homogeneous part ``x = q - q_e - (a sin + b cos)`` of mode table ``mp`` (:func:`vibeam.models.system.mode_table`).

    Parameters
    ----------
    beta, F, Omega, Delta : float
        Damping ratio, forcing amplitude ``Omega^2 B``, forcing frequency, stop position.
    kc, cc : float, optional
        The stop's stiffness and dashpot (per unit mass) of a contact phase.
    """

    def __init__(self, beta, F, Omega, Delta, kc=0.0, cc=0.0):
        c = 2.0 * beta + cc
        k = 1.0 + kc
        self.F, self.Omega, self.Delta, self.kc, self.cc = float(F), float(Omega), float(Delta), float(kc), float(cc)
        self.c, self.k = c, k
        self.qe = kc * Delta / k
        self.mp = mode_table([c], [k])
        a, b = particular(np.array([c]), np.array([k]), np.array([1.0]), float(F), float(Omega))
        self.a, self.b = float(a[0]), float(b[0])

    def field(self, q, v, t):
        """The phase's field ``(q', q'')`` at ``(q, q')`` and time ``t`` (ndarray, shape (2,))."""
        return np.array([v, self.F * math.sin(self.Omega * t) - self.c * v - self.k * (q - self.qe)])

    def transition(self, s):
        """Closed-form state-transition matrix of ``(q, q')`` over a time ``s`` (ndarray, shape (2, 2))."""
        p11, p12, p21, p22 = transition_entries(s, *self.mp[0])
        return np.array([[p11, p12], [p21, p22]])

    def step(self, kind, h, t, q, v, r=(0.0, 0.0, 0.0), rec=False, ext=None, cs=None):
        """One :func:`phase_step` of this phase of at most ``h`` from ``(t, q, q')``.

        Parameters
        ----------
        kind : int
            :data:`FREE` or :data:`CONTACT`.
        r : tuple of float
            ``(r0, r1, roff)``: the force's sign function inside the stop (free phase).
        rec : bool
            Update ``ext`` (shape (2,): min and max of ``q``).
        cs : ndarray, shape (3,), optional
            The contact's record (contact phase), updated.

        Returns
        -------
        s, event, q, v : float, int, float, float
            The step taken, how it ended and the state at its end.
        """
        out = np.empty(2)
        ext = np.array([np.inf, -np.inf]) if ext is None else ext
        cs = np.zeros(3) if cs is None else cs
        s, ev = phase_step(kind, float(h), 1e-13 * TWO_PI / self.Omega, float(t), float(q), float(v), self.mp,
                           self.qe, self.a, self.b, self.F, self.Omega, self.Delta, self.kc, self.cc,
                           float(r[0]), float(r[1]), float(r[2]), bool(rec), ext, cs, out)
        return s, ev, out[0], out[1]


@njit(cache=True, error_model="numpy")
def _weights(c0, c1, a, b, Om, p, r):
    """Weights and harmonic part ``(Sa, Sb)`` of the signal ``c0 delta + c1 delta'`` of a phase."""
    p[0] = c0
    r[0] = c1
    return c0 * a - c1 * Om * b, c0 * b + c1 * Om * a


@njit(cache=True, error_model="numpy")
def _watch(c0, c1, coff, d0, v0, acc0, hh, s_ev, h_min, phi, Om, x0, y0, mp, a, b, hb, p, r):
    """Scan ``c0 delta + c1 delta' + coff`` up through zero on ``[0, s_ev]`` (``[0, hh]`` while no
    event is found): ``(s_event, hh, found)``, the earliest event so far (-1: none; also when the
    scan had to shorten the horizon below it), the certified horizon, and whether this signal's
    crossing is that event."""
    Sa, Sb = _weights(c0, c1, a, b, Om, p, r)
    f0 = c0 * d0 + c1 * v0 + coff
    fp0 = c0 * v0 + c1 * acc0
    M2, M3, M4 = bounds(hb, p, r, math.sqrt(Sa * Sa + Sb * Sb), Om, 1)
    hk = hh if s_ev < 0.0 else s_ev
    sk, hk2 = scan(hk, h_min, phi, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, M2, M3, M4, 1)
    if sk >= 0.0:
        return sk, hh, True
    if hk2 < hk:
        return -1.0, hk2, False
    return s_ev, hh, False


@njit(cache=True, error_model="numpy")
def _maximum(c0, c1, d0, v0, acc0, s, phi, Om, x0, y0, mp, a, b, p, r, ext):
    """Largest value of ``c0 delta + c1 delta'`` on ``[0, s]`` (its ends and an interior maximum)."""
    Sa, Sb = _weights(c0, c1, a, b, Om, p, r)
    f0 = c0 * d0 + c1 * v0
    fp0 = c0 * v0 + c1 * acc0
    f1, fp1, _f2, _f3, _f4 = signal(s, phi, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, 1)
    ext[0] = np.inf
    ext[1] = max(f0, f1)
    extremes(s, phi, Om, x0, y0, mp, p, r, Sa, Sb, f0, fp0, fp0, fp1, ext, 1)
    return ext[1]


@njit(cache=True, error_model="numpy")
def phase_step(kind, h, h_min, t, q, v, mp, qe, a, b, F, Om, Delta, kc, cc, r0, r1, roff, rec, ext, cs, out):
    """One step of at most ``h`` of an SDOF phase (:class:`LinearPhase`) from ``(t, q, q')``.

    ``kind`` :data:`CONTACT`: a Kelvin-Voigt contact (stop ``kc``, ``cc`` at ``Delta``) up to its
    exit, the force ``kc delta + cc delta'`` back down through zero; ``cs = [peak force, largest
    penetration, work on the stop]`` updated.  :data:`FREE`: up to the next entry, ``delta =
    q - Delta`` up through zero; or, inside the stop (``delta > 0`` after an exit), the force's
    sign function ``r0 delta + r1 delta' + roff`` up through zero (an entry; at once if it is
    positive now) or ``delta`` back down through zero (:data:`EV_GAPDOWN`).

    Parameters
    ----------
    mp : ndarray, shape (1, 6)
        The phase's mode table; ``qe``, ``a``, ``b`` its equilibrium and particular coefficients.
    rec : bool
        Update ``ext = [min q, max q]`` (shape (2,)) with the step's extremes.
    out : ndarray, shape (2,)
        Receives ``(q, q')`` at the step's end.

    Returns
    -------
    s, event : float, int
        The step taken and how it ended (:data:`EV_NONE` ..., :data:`EV_FAIL` if no step
        could be certified).
    """
    phi = (Om * t) % TWO_PI
    sp = math.sin(phi)
    cp = math.cos(phi)
    x0 = np.empty(1)
    y0 = np.empty(1)
    p = np.empty(1)
    r = np.empty(1)
    hb = np.empty((1, 6))
    e2 = np.empty(2)
    x0[0] = q - qe - (a * sp + b * cp)
    y0[0] = v - Om * (a * cp - b * sp)
    homogeneous_bounds(x0[0], y0[0], mp[0, 0], mp[0, 1], int(mp[0, 2]), mp[0, 3], mp[0, 4], mp[0, 5], hb[0])
    d0 = q - Delta
    acc0 = F * sp - 2.0 * mp[0, 0] * v - mp[0, 1] * (q - qe)
    s_ev = -1.0
    ev = EV_NONE
    hh = h
    if kind == CONTACT:
        s_ev, hh, found = _watch(-kc, -cc, 0.0, d0, v, acc0, hh, s_ev, h_min, phi, Om, x0, y0, mp, a, b, hb, p, r)
        if found:
            ev = EV_EXIT
    elif d0 > 0.0:
        # inside the stop without contact: a contact now if the force's sign function is positive
        f0 = r0 * d0 + r1 * v + roff
        fp0 = r0 * v + r1 * acc0
        tol0 = 1e-13 * (abs(r0) * (abs(q) + abs(Delta)) + abs(r1 * v) + abs(roff))
        tol1 = 1e-13 * (abs(r0 * v) + abs(r1) * (abs(F) + abs(mp[0, 0] * v) + abs(mp[0, 1] * (q - qe))))
        if f0 > tol0 or (f0 >= -tol0 and fp0 > tol1):
            out[0] = q
            out[1] = v
            return 0.0, EV_ENTRY
        s_ev, hh, found = _watch(r0, r1, roff, d0, v, acc0, hh, s_ev, h_min, phi, Om, x0, y0, mp, a, b, hb, p, r)
        if found:
            ev = EV_ENTRY
        s_ev, hh, found = _watch(-1.0, 0.0, 0.0, d0, v, acc0, hh, s_ev, h_min, phi, Om, x0, y0, mp, a, b, hb, p, r)
        if found:
            ev = EV_GAPDOWN
        elif s_ev < 0.0:
            ev = EV_NONE
    else:
        if d0 >= -1e-13 * (abs(q) + abs(Delta)) and v > 0.0:
            out[0] = q
            out[1] = v
            return 0.0, EV_ENTRY
        s_ev, hh, found = _watch(1.0, 0.0, 0.0, d0, v, acc0, hh, s_ev, h_min, phi, Om, x0, y0, mp, a, b, hb, p, r)
        if found:
            ev = EV_ENTRY
    s = s_ev if s_ev >= 0.0 else hh
    if not s >= 0.0:
        return -1.0, EV_FAIL
    # the state at the step's end: delta and delta' from their exact start values
    Sa, Sb = _weights(1.0, 0.0, a, b, Om, p, r)
    d1, v1, _f2, _f3, _f4 = signal(s, phi, Om, x0, y0, mp, p, r, Sa, Sb, d0, v, 1)
    if kind == CONTACT:
        cs[0] = max(cs[0], _maximum(kc, cc, d0, v, acc0, s, phi, Om, x0, y0, mp, a, b, p, r, e2))
        cs[1] = max(cs[1], _maximum(1.0, 0.0, d0, v, acc0, s, phi, Om, x0, y0, mp, a, b, p, r, e2))
        Sa, Sb = _weights(1.0, 0.0, a, b, Om, p, r)
        w = 0.0
        for i in range(GL_X.shape[0]):
            g, gd, _f2, _f3, _f4 = signal(GL_X[i] * s, phi, Om, x0, y0, mp, p, r, Sa, Sb, d0, v, 1)
            w += GL_W[i] * (kc * g + cc * gd) * gd
        cs[2] += w * s
    if rec:
        Sa, Sb = _weights(1.0, 0.0, a, b, Om, p, r)
        e2[0] = min(d0, d1)
        e2[1] = max(d0, d1)
        extremes(s, phi, Om, x0, y0, mp, p, r, Sa, Sb, d0, v, v, v1, e2, 1)
        ext[0] = min(ext[0], Delta + e2[0])
        ext[1] = max(ext[1], Delta + e2[1])
    out[0] = Delta + d1
    out[1] = v1
    return s, ev


def entry_guess(model, Omega, n, guess_periods):
    """The first Newton guess of a one-contact orbit: the last contact entry of an event run.

    Parameters
    ----------
    model : vibeam.models.SDOF
    Omega : float
    n : int
        Forcing periods per contact (the run records ``n + 1``).
    guess_periods : int
        Transient periods of the run (:class:`vibeam.models.sdof.EventSolver`, from rest).

    Returns
    -------
    tuple of float or None
        ``(t0, v0)``: the entry's time within its forcing period and its speed; None without a
        contact.
    """
    from .sdof import EventSolver

    tr = EventSolver(model).point(Omega, None, guess_periods, n + 1, 16)
    if tr.n_impacts:
        return float(tr.impact_times[-1] % (TWO_PI / Omega)), float(tr.impact_velocities[-1])
    return None


class EntryMappingSolver:
    """Method ``mapping`` on a compliant stop: period-n one-contact orbits as fixed points of the
    entry-to-entry map ``P(t0, v0) = (t1, v1)`` (paper Sec. 4.2; module docstring), one class for
    every family of laws.

    A family's subclass gives the map, :meth:`evaluate` (``(t1, v1, J, record)``, ``J = d(t1, v1)
    / d(t0, v0)``, or None when the orbit leaves the one-contact family); here are the Newton
    iteration ``t1 = t0 + n T``, ``v1 = v0`` from the guesses (the previous point's entry, then an
    event run's), the Floquet multipliers (eigenvalues of ``J``, by decreasing modulus) and the
    point's outputs.

    Parameters
    ----------
    model : vibeam.models.SDOF
        With ``contact`` a law of the subclass's ``family``.
    n : int
        Forcing periods per contact (1..4).
    guess_periods : int
        Transient periods of the event run that provides the first Newton guess.
    tol : float, optional
        Newton tolerance (residual relative to the entry velocity and the period); the family's
        ``default_tol`` if None.

    Raises
    ------
    ValueError
        For ``n`` outside 1..4 or a model whose stop is not of the family.
    """

    name = "mapping"
    time_domain = False
    #: the family of laws the subclass maps (:data:`vibeam.models.registry.FAMILIES`)
    family = ""
    default_tol = 1e-12

    def __init__(self, model, n: int = 1, guess_periods: int = 300, tol: float | None = None,
                 form: str = "full", guess: str = "event", samples_per_flight_period: int = 256):
        if int(n) != n or not 1 <= n <= 4:
            raise ValueError(f"n must be an integer in 1..4, got {n!r}")
        if getattr(getattr(model, "contact", None), "family", "") != self.family:
            raise ValueError(f"{type(self).__name__} needs {family_laws(self.family)}")
        self.model = model
        self.n = int(n)
        self.guess_periods = int(guess_periods)
        self.tol = float(self.default_tol if tol is None else tol)

    def settings(self) -> dict:
        return dict(n=self.n, guess_periods=self.guess_periods, tol=self.tol)

    def evaluate(self, Omega, t0, v0, want_record=False):      # pragma: no cover - the families'
        raise NotImplementedError

    def _guess(self, Omega, state0):
        if isinstance(state0, dict):
            state0 = state0.get("final_state")
        if state0 is not None:
            s = np.asarray(state0, float).ravel()
            if s.shape == (2,) and np.all(np.isfinite(s)) and s[1] > 0:
                yield s[0] / Omega, s[1]
        g = entry_guess(self.model, Omega, self.n, self.guess_periods)
        if g is not None:
            yield g

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
                x = x + np.linalg.solve(J - np.eye(2), -res)
                if not x[1] > 0.0:
                    break
            if not ok:
                reasons.append(f"Newton did not converge from t = {t0:.4g}, v = {v0:.4g}")
                continue
            t1, v1, J, rec = self.evaluate(Omega, x[0], x[1], want_record=True)
            mult = np.linalg.eigvals(J)
            mult = mult[np.argsort(-np.abs(mult))]
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


class CompliantMappingSolver(EntryMappingSolver):
    """The entry-to-entry map on a Kelvin-Voigt stop: both phases linear, composed in closed form
    (module docstring); :class:`EntryMappingSolver` for the parameters."""

    family = "kelvin_voigt"
    default_tol = 1e-12

    # ------------------------------------------------------------------ the map
    def _phases(self, Omega):
        m = self.model
        F = Omega * Omega * m.B
        law = m.contact
        return (LinearPhase(m.beta, F, Omega, m.Delta),
                LinearPhase(m.beta, F, Omega, m.Delta, law.stiffness, law.damping), F)

    def evaluate(self, Omega, t0, v0, want_record=False):
        """``P(t0, v0)``: ``(t1, v1, J, record)`` with ``J = d(t1, v1) / d(t0, v0)`` (2, 2) and
        ``record`` (extremes, contact data), or None when the orbit leaves the one-contact
        family (no exit, a second contact before leaving the stop, no entry within n + 1
        periods)."""
        m = self.model
        free, con, F = self._phases(Omega)
        kc, cc = con.kc, con.cc
        Delta = m.Delta
        T = TWO_PI / Omega
        ext = np.array([np.inf, -np.inf])
        cs = np.array([cc * v0, 0.0, 0.0])     # peak force (the entry's), largest penetration, work
        # contact phase
        q, v, t = Delta, v0, t0
        hc = TWO_PI / math.sqrt(con.k) / 16.0
        s_c = 0.0
        for _ in range(100000):
            s, ev, q, v = con.step(CONTACT, hc, t, q, v, rec=want_record, ext=ext, cs=cs)
            if ev == EV_FAIL:
                return None
            t, s_c = t + s, s_c + s
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
            s, ev, q, v = free.step(FREE, hf, t, q, v, r=(kc, cc, 0.0), rec=want_record, ext=ext)
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
        # Jacobian composed over the two phases (module docstring)
        f0 = con.field(Delta, v0, t0)
        fx = con.field(qx, vx, tx)
        fxf = free.field(qx, vx, tx)       # equal to fx: the force is zero at the exit
        f1 = free.field(Delta, v1, t1)
        Pc = con.transition(s_c)
        Pf = free.transition(t1 - tx)
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
        rec = dict(q_min=ext[0], q_max=max(ext[1], Delta + cs[1]), duration=s_c, force=cs[0], penetration=cs[1],
                   energy=cs[2])
        return t1, v1, J, rec
