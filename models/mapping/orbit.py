"""Sections, passages, flights and the multiple-shooting problem of the pointwise mapping.

A *section* is an arrival at a stop ``k`` of the one-mode system (paper Eq. 1 with the stops of
:func:`vibeam.models.scene.one_mode`): time ``t`` (forcing phase ``Omega t``) and normal arrival
speed ``v = s_k q'(t) > 0`` at ``q = s_k d_k``.  From it the map goes through two pieces:

passage (the stop's law, :meth:`SectionMap.passage`; in the stop's normal coordinate ``u = s_k q``)
    Newton (``law.kind == "impulsive"``, paper Eq. 2): the instantaneous reset ``u' -> -R u'``;
    Kelvin-Voigt (family ``kelvin_voigt``): the exact linear contact phase up to its force-zero
    exit (:class:`~vibeam.models.mapping.phases.Phase`, certified scans); hysteretic Hertz (family
    ``hysteretic_hertz``): the contact phase integrated by scipy's DOP853 (rtol :data:`RTOL`)
    together with its variational equations.  Each gives the exit time and state and their
    derivatives ``D = d(t_e, u_e, u_e') / d(t, v)``, shape (3, 2);
flight (the closed-form free flow, paper Eq. 28)
    from the exit to the next arrival at *any* stop, located by the certified scans of
    :func:`~vibeam.models.mapping.phases.phase_step` (:meth:`SectionMap.fly`).

Its Jacobian is composed over the pieces (paper Sec. 4.2, the time of each event varied): for a
flight with transition matrix ``Phi`` from the exit ``(t_e, x_e)`` (free field ``f_e``) to the
arrival at ``t_1`` (field ``f_1 = (q', q'')``) on stop ``k'``::

    Y = Phi (D_x - f_e D_t),   dt_1 = -Y_q / q'(t_1),   dv_1 = s_k' (Y_q' + q''(t_1) dt_1).

A period-n orbit with ``m`` sections on the stops ``k_0 .. k_{m-1}`` is a zero of the
multiple-shooting residual (:meth:`SectionMap.residual`) in ``(t_0 .. t_{m-1}, v_0 .. v_{m-1})``
(``t_m = t_0 + n T``)::

    r_j = ( s_k' q_j(t_{j+1}) - d_k',  s_k' q_j'(t_{j+1}) - v_{j+1} ),   k' = k_{j+1},

``q_j`` the flight from the exit of section ``j``, solved by damped Newton with the analytic
Jacobian (:meth:`SectionMap.newton`).  All quantities are nondimensional.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from ..core.laws import V_FLOOR
from ..impact import saltation_matrix
from ..scene import one_mode
from ..core.oscillator import flow_matrix, particular_coefficients, propagate
from .newton import damped_newton
from .phases import CONTACT, EV_ARRIVAL, EV_EXIT, EV_FAIL, EV_GAPDOWN, EV_NONE, EV_RECONTACT, FREE, TWO_PI, Phase

#: tolerance of the integrated (hysteretic-Hertz) contact phase and its variational equations
RTOL = 1e-12
#: most steps of a contact phase or a flight (each at most 1/16 of a natural period)
MAX_STEPS = 100000
#: Newton's tolerance by the laws of the stops (the residual relative to the arrival speeds): the
#: exact flows reach round-off, the integrated contact phase its integration tolerance
DEFAULT_TOL = {"impulsive": 1e-13, "kelvin_voigt": 1e-12, "hysteretic_hertz": 1e-10}


def law_key(law) -> str:
    """``"impulsive"`` or the compliant law's family: the key of its passage and tolerance."""
    return "impulsive" if law.kind == "impulsive" else law.family


class Passage:
    """The passage of one section through its stop, in the stop's normal coordinate.

    Attributes
    ----------
    t : float
        Exit time.
    x : ndarray, shape (2,)
        Exit state ``(u, u')``.
    D : ndarray, shape (3, 2)
        ``d(t_e, u_e, u_e') / d(t, v)`` of the section.
    inside : tuple of float or None
        ``(r0, r1, roff)``, the sign function of the force, when the body leaves the stop with
        ``delta = u - d > 0`` (the flight must leave the stop before it can arrive anywhere).
    record : tuple of float
        ``(duration, peak force, largest penetration, energy lost)``; Newton's law: ``(0, nan, 0,
        (1 - R^2) v^2 / 2)``.
    """

    def __init__(self, t, x, D, inside, record):
        self.t, self.x, self.D, self.inside, self.record = float(t), np.asarray(x, float), D, inside, record


def newton_passage(law, d, scene, t0, v0, F):
    """Newton's law ``u' -> -R u'`` at ``u = d`` (paper Eq. 2): the exit is the arrival's instant.

    The parameters and result are those of every passage of :data:`PASSAGES`.

    Parameters
    ----------
    law : law object
        The stop's law (:class:`vibeam.models.contact.Restitution` or a compliant law of
        :mod:`vibeam.models.compliant`).
    d : float
        The stop's offset along its normal (the section is at ``u = d``).
    scene : SectionMap
        The frequency, damping and time limit ``t_max`` of a passage.
    t0, v0 : float
        The section's time and normal arrival speed (``> 0``).
    F : float
        The forcing amplitude along the stop's normal (``s_k Omega^2 B``).

    Returns
    -------
    Passage or None
        None when the contact has no exit within ``scene.t_max``.
    """
    R = float(law.R)
    D = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, -R]])
    return Passage(t0, (d, -R * v0), D, None, (0.0, math.nan, 0.0, 0.5 * (1.0 - R * R) * v0 * v0))


def kelvin_voigt_passage(law, d, scene, t0, v0, F):
    """The exact linear contact phase of a Kelvin-Voigt stop from entry to its force-zero exit.

    With the contact phase's transition ``Pc`` and field ``f_c`` (the dashpot acts at entry, so
    its field starts there) and the exit event ``h = k_c delta + c_c delta' = 0``::

        y = Pc (dx_0 - f_c(x_0) dt_0),  dt_e = -grad h . y / (grad h . f_c(x_e)),  dx_e = f_c(x_e) dt_e + y.

    Returns None when no exit is certified within ``scene.t_max``.
    """
    kc, cc = float(law.stiffness), float(law.damping)
    con = Phase(scene.beta, F, scene.Omega, d, kc, cc)
    rows = np.array([[1.0, d, 0.0, 0.0, 0.0]])
    ext = np.array([np.inf, -np.inf, np.inf, -np.inf])
    cs = np.array([cc * v0, 0.0, 0.0])       # peak force (the entry's), largest penetration, work
    u, w, t = d, v0, t0
    h = TWO_PI / math.sqrt(con.k) / 16.0
    for _ in range(MAX_STEPS):
        s, ev, _, u, w = con.step(CONTACT, h, t, u, w, rows, np.zeros(1, np.int64), ext, cs)
        if ev == EV_FAIL or t + s - t0 > scene.t_max:
            return None
        t += s
        if ev == EV_EXIT:
            break
    else:
        return None
    f0, fx, P, g = con.field(t0, d, v0), con.field(t, u, w), con.transition(t - t0), np.array([kc, cc])
    D = np.empty((3, 2))
    for col, (dt0, dx0) in enumerate(((1.0, np.zeros(2)), (0.0, np.array([0.0, 1.0])))):
        y = P @ (dx0 - f0 * dt0)
        dte = -(g @ y) / (g @ fx)
        D[:, col] = (dte, *(fx * dte + y))
    inside = (kc, cc, 0.0) if u - d > 0.0 else None
    return Passage(t, (u, w), D, inside, (t - t0, cs[0], cs[1], cs[2]))


def hertz_passage(law, d, scene, t0, v0, F):
    """The hysteretic-Hertz contact phase ``F = k_c delta^p (1 + chi delta' / v_r)`` (``v_r`` the
    entry speed, floored as in the event integrator, :data:`vibeam.models.core.laws.V_FLOOR`)
    integrated by DOP853 with its variational equations::

        Phi' = A Phi, Phi(t_0) = I;   s' = A s + df/dv_r, s(t_0) = 0;
        A = [[0, 1], [-1 - p k_c delta^(p-1) (1 + chi delta' / v_r), -2 beta - k_c delta^p chi / v_r]],

    so that ``dx(t) = Phi (dx_0 - f(x_0) dt_0) + s dv_r`` to the integration tolerance.  The
    contact ends where the force returns to zero: ``delta`` down through 0 (the exit on the
    stop's surface) or the damping factor ``1 + chi delta' / v_r`` down through 0 (inside the stop;
    ``dt_e`` then has a ``v_r`` term).  The force is zero at entry and exit: no saltation.
    Returns None when no exit within ``scene.t_max``.
    """
    kc, p, chi = float(law.stiffness), float(law.exponent), float(law.chi)
    beta, Om = scene.beta, scene.Omega
    vr = max(v0, scene.v_floor)
    dvr = 1.0 if v0 > scene.v_floor else 0.0

    def rhs(t, z):
        dl, dv = z[0], z[1]
        dp = max(dl, 0.0)
        fac = 1.0 + chi * dv / vr
        f = kc * dp ** p * fac
        a10 = -1.0 - (p * kc * dp ** (p - 1.0) * fac if dp > 0.0 else 0.0)
        a11 = -2.0 * beta - kc * dp ** p * chi / vr
        P, s = z[2:6].reshape(2, 2), z[6:8]
        return np.concatenate([[dv, F * math.sin(Om * t) - 2.0 * beta * dv - (d + dl) - f],
                               np.array([P[1], a10 * P[0] + a11 * P[1]]).ravel(),
                               [s[1], a10 * s[0] + a11 * s[1] + kc * dp ** p * chi * dv / (vr * vr)], [f * dv]])

    def ev_delta(t, z):
        return z[0]

    def ev_factor(t, z):
        return 1.0 + chi * z[1] / vr

    def ev_pen(t, z):           # largest penetration
        return z[1]

    def ev_force(t, z):         # peak force: dF/dt = 0 falling
        dl, dv = max(z[0], 0.0), z[1]
        if dl <= 0.0:
            return 0.0
        return kc * p * dl ** (p - 1.0) * dv * (1.0 + chi * dv / vr) + kc * dl ** p * chi * rhs(t, z)[1] / vr

    ev_delta.terminal = ev_factor.terminal = True
    ev_delta.direction = ev_factor.direction = ev_pen.direction = ev_force.direction = -1.0
    z0 = np.zeros(9)
    z0[1] = v0
    z0[2] = z0[5] = 1.0
    pen0 = ((p + 1.0) * vr * vr / (2.0 * kc)) ** (1.0 / (p + 1.0))   # the isolated contact's penetration
    atol = np.array([1e-14 * pen0, 1e-14 * vr, 1e-14, 1e-14, 1e-14, 1e-14, 1e-14 * pen0 / vr, 1e-14, 1e-14 * vr * vr])
    sol = solve_ivp(rhs, (t0, t0 + scene.t_max), z0, method="DOP853", rtol=RTOL, atol=atol,
                    events=[ev_delta, ev_factor, ev_pen, ev_force], max_step=pen0 / vr)
    if sol.status != 1:
        return None
    by_gap = sol.t_events[0].size > 0
    z = sol.y[:, -1]
    te, dx, vx = float(sol.t[-1]), (0.0 if by_gap else float(z[0])), float(z[1])   # on the surface to round-off
    force = max([kc * max(ze[0], 0.0) ** p * (1.0 + chi * ze[1] / vr) for ze in sol.y_events[3]] + [0.0])
    pen = max([float(ze[0]) for ze in sol.y_events[2]] + [0.0])
    free = Phase(beta, F, Om)
    f0, fx = free.field(t0, d, v0), free.field(te, d + dx, vx)    # the force is zero at entry and exit
    gh, dh_dvr = (np.array([1.0, 0.0]), 0.0) if by_gap else (np.array([0.0, chi / vr]), -chi * vx / vr ** 2)
    Phi, sv = z[2:6].reshape(2, 2), z[6:8]
    D = np.empty((3, 2))
    for col, (dt0, dv0) in enumerate(((1.0, 0.0), (0.0, 1.0))):
        y = Phi @ (np.array([0.0, dv0]) - f0 * dt0) + sv * dvr * dv0
        dte = -(gh @ y + dh_dvr * dvr * dv0) / (gh @ fx)
        D[:, col] = (dte, *(fx * dte + y))
    inside = None if by_gap or not dx > 0.0 else (0.0, 1.0, vr / chi if chi > 0.0 else 1.0)
    return Passage(te, (d + dx, vx), D, inside, (te - t0, force, pen, float(z[8])))


#: the passage of each kind or family of law (:func:`law_key`)
PASSAGES = {"impulsive": newton_passage, "kelvin_voigt": kelvin_voigt_passage, "hysteretic_hertz": hertz_passage}


def check_stops(stops):
    """``stops``, once checked to have passages.

    Raises
    ------
    ValueError
        For a law without a passage (:data:`PASSAGES`) or a velocity-dependent ``R`` (the map
        takes a constant one).
    """
    for s in stops:
        if law_key(s.law) not in PASSAGES:
            raise ValueError(f"the mapping has no passage through a stop of family {law_key(s.law)!r}")
        if getattr(s.law, "table_U", ()):
            raise ValueError("the mapping takes a constant R (no R(U-) table)")
    return stops


class SectionMap:
    """The one-mode system with its stops at one forcing frequency: passages, flights, the
    multiple-shooting residual and the analysis of an orbit (module docstring).

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
        The one-mode oscillator and its stops (one or two, any laws with a passage;
        :func:`vibeam.models.scene.one_mode`).
    Omega : float
        Forcing frequency.
    n : int, optional
        Periods of the orbits sought: a passage or flight longer than ``n + 1`` periods fails.

    Raises
    ------
    ValueError
        For a scene that is not the one-mode oscillator (:func:`vibeam.models.scene.one_mode`) or
        stops without a passage (:func:`check_stops`).
    """

    def __init__(self, scene, Omega, n=1):
        om = one_mode(scene, "the mapping")
        self.beta, self.Omega, self.B = om.beta, float(Omega), om.B
        self.F = self.Omega ** 2 * self.B
        self.T = TWO_PI / self.Omega
        self.t_max = (n + 1) * self.T
        self.a, self.b = particular_coefficients(self.beta, self.F, self.Omega)
        self.free = Phase(self.beta, self.F, self.Omega)
        stops = check_stops(om.stops)
        self.laws = [s.law for s in stops]
        self.sign = [float(s.relation.sign) for s in stops]
        self.d = [float(s.relation.offset) for s in stops]
        self.rows = np.array([[s, d, 0.0, 0.0, 0.0] for s, d in zip(self.sign, self.d)])
        self.impulsive = all(law.kind == "impulsive" for law in self.laws)
        self.v_floor = V_FLOOR * self.Omega * self.B if self.B > 0.0 else 1e-6

    # ------------------------------------------------------------------ the pieces
    def passage(self, k, t0, v0):
        """The passage of the section ``(t0, v0)`` on stop ``k`` in the physical coordinate:
        :class:`Passage` with ``x`` ``(q, q')`` and ``D`` ``d(t_e, q, q') / d(t0, v0)``, or None."""
        law, s = self.laws[k], self.sign[k]
        pas = PASSAGES[law_key(law)](law, self.d[k], self, t0, v0, s * self.F)
        if pas is not None:
            pas.x = s * pas.x
            pas.D = np.vstack([pas.D[:1], s * pas.D[1:]])
        return pas

    def flight(self, pas, t, k1):
        """``(s_k1 q - d_k1, q', q'')`` at time ``t`` of the flight from the exit ``pas`` (closed form)."""
        p = self.sign[k1] * self.d[k1]
        g, w, acc, _, _ = propagate(t - pas.t, self.Omega * pas.t, pas.x[0], pas.x[1], self.beta, self.a, self.b,
                                    self.Omega, p)
        return self.sign[k1] * g, w, acc

    def flight_jacobian(self, pas, t):
        """``Y = d(q, q')(t) / d(t0, v0)`` at fixed ``t`` of the flight from the exit ``pas`` (2, 2)."""
        fe = self.free.field(pas.t, *pas.x)
        return flow_matrix(t - pas.t, self.beta) @ (pas.D[1:] - np.outer(fe, pas.D[0]))

    def arrival(self, pas, t1, k1):
        """The arrival at stop ``k1`` at ``t1`` of the flight from ``pas``: ``q'``, ``q''`` there and the
        section map's Jacobian ``d(t1, v1) / d(t0, v0)`` (2, 2), the arrival time varied (module
        docstring)."""
        _, w, acc = self.flight(pas, t1, k1)
        Y = self.flight_jacobian(pas, t1)
        dt1 = -Y[0] / w
        return w, acc, np.array([dt1, self.sign[k1] * (Y[1] + acc * dt1)])

    def fly(self, k, pas, t_end, ext):
        """The first event of the flight from the exit ``pas`` of stop ``k`` (certified scans).

        Parameters
        ----------
        k : int
            The stop of the passage (the one the body may still be inside of).
        pas : Passage
            The exit, physical coordinate (:meth:`passage`).
        t_end : float
            Time after which the flight is given up.
        ext : ndarray, shape (4,)
            ``[min q, max q]`` and ``[min, max]`` of the interior extrema of ``q``, updated.

        Returns
        -------
        tuple
            ``(event, stop, t, q, q')`` with event ``EV_ARRIVAL`` (an arrival at ``stop``),
            ``EV_RECONTACT`` (contact again before leaving stop ``k``), ``EV_FAIL`` or ``EV_NONE``
            (nothing before ``t_end``).
        """
        rows = self.rows.copy()
        inside = np.zeros(len(self.laws), np.int64)
        if pas.inside is not None:
            rows[k, 2:] = pas.inside
            inside[k] = 1
        t, q, w = pas.t, pas.x[0], pas.x[1]
        cs = np.zeros(3)
        for _ in range(MAX_STEPS):
            if t > t_end:
                return EV_NONE, -1, t, q, w
            s, ev, kk, q, w = self.free.step(FREE, TWO_PI / 16.0, t, q, w, rows, inside, ext, cs)
            if ev == EV_FAIL:
                break
            t += s
            if ev == EV_GAPDOWN:
                inside[kk] = 0
            elif ev in (EV_ARRIVAL, EV_RECONTACT):
                return ev, kk, t, q, w
        return EV_FAIL, -1, t, q, w

    def section_map(self, k, t0, v0, max_time):
        """The map from the section ``(t0, v0)`` on stop ``k`` to the next arrival at any stop
        (within ``max_time``).

        Returns
        -------
        dict or str
            ``stop``, ``t``, ``v``, ``a`` (``q''`` at arrival), ``J`` (``d(t, v) / d(t0, v0)``, (2, 2)),
            ``passage``, ``ext`` (:meth:`fly`); or the reason why there is no next arrival.
        """
        pas = self.passage(k, t0, v0)
        if pas is None:
            return f"no exit from stop {k} within {self.t_max / self.T:g} periods"
        ext = np.array([np.inf, -np.inf, np.inf, -np.inf])
        ev, k1, t1, q1, w1 = self.fly(k, pas, pas.t + max_time, ext)
        if ev != EV_ARRIVAL:
            return ("contact again before leaving the stop" if ev == EV_RECONTACT else
                    f"no arrival within {max_time / self.T:g} periods")
        _, acc, J = self.arrival(pas, t1, k1)
        return dict(stop=k1, t=t1, v=self.sign[k1] * w1, a=acc, J=J, passage=pas, ext=ext)

    # ------------------------------------------------------------------ the orbit
    def _end(self, x, j, m, n):
        """Index of the next of ``m`` sections and its time (``t_m = t_0 + n T``)."""
        j1 = (j + 1) % m
        return j1, x[j1] + (n * self.T if j1 == 0 else 0.0)

    def residual(self, x, stops, n, jac=True):
        """The multiple-shooting residual (2m,) at ``x = (t_0 .. t_{m-1}, v_0 .. v_{m-1})`` and its
        Jacobian (2m, 2m) (module docstring); None where a passage has no exit or ends after the
        next section's time."""
        m = len(stops)
        r = np.empty(2 * m)
        J = np.zeros((2 * m, 2 * m)) if jac else None
        for j in range(m):
            j1, t1 = self._end(x, j, m, n)
            pas = self.passage(stops[j], x[j], x[m + j])
            if pas is None or not t1 > pas.t:
                return None, None
            k1 = stops[j1]
            g, w, acc = self.flight(pas, t1, k1)
            s1 = self.sign[k1]
            r[2 * j], r[2 * j + 1] = g, s1 * w - x[m + j1]
            if jac:
                Y = s1 * self.flight_jacobian(pas, t1)
                J[2 * j:2 * j + 2, j] += Y[:, 0]
                J[2 * j:2 * j + 2, m + j] += Y[:, 1]
                J[2 * j:2 * j + 2, j1] += s1 * np.array([w, acc])
                J[2 * j + 1, m + j1] -= 1.0
        return r, J

    def newton(self, x, stops, n, tol, max_iter=50):
        """Damped Newton on :meth:`residual` from ``x``
        (:func:`vibeam.models.mapping.newton.damped_newton`).

        Returns
        -------
        x, converged : ndarray (2m,), bool
            The last iterate and whether it converged to ``max |r| <= tol max |v|`` (1e3 ``tol``
            after ``max_iter`` iterations).
        """
        return damped_newton(lambda y: self.residual(y, stops, n), x, tol, len(stops), max_iter)

    def analyse(self, x, stops, n, rtol=1e-9):
        """Admissibility, extremes, records and stability of the orbit ``x`` (from :meth:`newton`).

        Admissible: every speed positive, every flight's first event (certified) the orbit's next
        arrival (same stop, same time to 1e-9 of the period), and no flight grazing a stop (an
        interior extreme of ``q`` within ``rtol`` times the orbit's size of it).

        Returns
        -------
        dict or str
            The reason as a string when not admissible; otherwise ``q_min``, ``q_max``, ``records``
            (per section: the passage's record), ``J`` (the composed section-map Jacobian, (2, 2),
            whose eigenvalues are the Floquet multipliers), ``M`` (impulsive laws only: the
            monodromy ``S_m Phi(tau_{m-1}) ... S_1 Phi(tau_0)`` in ``(q, q')``, else None) and
            ``a_minus`` (``q''`` before each arrival).
        """
        m = len(stops)
        v = x[m:]
        if not np.all(v > 0.0):
            return f"an arrival speed is not positive ({np.min(v):.3e})"
        q_lo = q_hi = self.sign[stops[0]] * self.d[stops[0]]
        Jm, M = np.eye(2), (np.eye(2) if self.impulsive else None)
        records, acc_minus, near = [], [], []
        for j in range(m):
            j1, t1 = self._end(x, j, m, n)
            k, k1 = stops[j], stops[j1]
            pas = self.passage(k, x[j], v[j])
            if pas is None or not t1 > pas.t:
                return f"section {j}: no exit from stop {k} before the next section"
            ext = np.array([np.inf, -np.inf, np.inf, -np.inf])
            ev, ka, ta, _, _ = self.fly(k, pas, t1 + 0.01 * self.T, ext)
            if ev != EV_ARRIVAL or ka != k1 or abs(ta - t1) > 1e-9 * self.T:
                where = ("contact again inside the stop" if ev == EV_RECONTACT else "no arrival" if ev != EV_ARRIVAL
                         else f"stop {ka} after {(ta - pas.t) / self.T:.6g} periods")
                return (f"flight {j} of the orbit does not end at its next section ({where}; the orbit: stop {k1} "
                        f"after {(t1 - pas.t) / self.T:.6g} periods): grazing or another sequence")
            rec = pas.record
            s, d = self.sign[k], self.d[k]
            q_lo, q_hi = min(q_lo, ext[0], s * d, s * (d + rec[2])), max(q_hi, ext[1], s * d, s * (d + rec[2]))
            near.append(ext[2:])
            w, acc, J = self.arrival(pas, t1, k1)
            Jm = J @ Jm
            if M is not None:
                M = saltation_matrix(float(self.laws[k1].R), w, acc, self.beta) @ flow_matrix(t1 - x[j], self.beta) @ M
            records.append(rec)
            acc_minus.append(acc)
        size = max(q_hi - q_lo, float(np.max(v)), 1e-300)
        for j, (lo, hi) in enumerate(near):
            for s, d in zip(self.sign, self.d):
                gap = s * (hi if s > 0 else lo) - d
                if gap >= -rtol * size:
                    return (f"flight {j} of the orbit touches a stop ({'upper' if s > 0 else 'lower'}; gap "
                            f"{gap:.3e}): grazing")
        return dict(q_min=q_lo, q_max=q_hi, records=records, J=Jm, M=M, a_minus=acc_minus)


def minimal_period(x, stops, n, rtol=1e-9):
    """The least ``p`` dividing ``n`` after which the orbit's sections repeat (same stops, times
    ``+ p T`` to ``rtol`` of the period, speeds to ``rtol``); ``x`` as :meth:`SectionMap.residual`'s with
    ``T = 2 pi`` (forcing phases)."""
    m = len(stops)
    phi, v = x[:m], x[m:]
    for p in range(1, n):
        if n % p or (m * p) % n:
            continue
        sh = m * p // n
        idx = (np.arange(m) + sh) % m
        wrap = np.where(np.arange(m) + sh >= m, TWO_PI * n, 0.0)
        if (all(stops[i] == stops[j] for i, j in zip(range(m), idx))
                and np.allclose(phi[idx] + wrap, phi + TWO_PI * p, rtol=0, atol=rtol * TWO_PI)
                and np.allclose(v[idx], v, rtol=rtol, atol=0)):
            return p
    return n
