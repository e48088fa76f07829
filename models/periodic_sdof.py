"""Shooting problem of the SDOF coefficient-of-restitution oscillator (paper Eqs. 1-2, 28).

``P^n`` is evaluated by the exact event kernel (:func:`vibeam.models.sdof_event.event_kernel`,
the one event / chatter / sticking policy of the SDOF model) run from the stroboscopic
section for ``n`` forcing periods with its event log switched on; the derivatives are then
assembled from that log in :func:`assemble_derivatives` (numba), so one shot is one call
into compiled code whatever the number of events.

Derivatives (Leine & Nijmeijer 2004, Ch. 7; di Bernardo et al. 2008, Sec. 2.5; Hiskens &
Pai 2000 for the parameter sensitivities).  With ``X = d x(t) / d(x0, p)`` at fixed time:

* free flight from ``t_a`` (post-event state ``x_a``) to ``t_b``, ``s = t_b - t_a``
  (closed form, paper Eq. 28, :mod:`vibeam.models.sdof_flow`)::

      x(t_b) = Phi(s) (x_a - P(t_a)) + P(t_b)
      X <- Phi(s) X + [d Phi/d beta (x_a - P(t_a)) - Phi(s) dP/dp(t_a) + dP/dp(t_b)]

  with ``P(t) = (a sin Omega t + b cos Omega t, Omega (a cos - b sin))`` the particular
  solution and ``Phi`` the transition matrix of the damped oscillator;
* impact on ``h = q - Delta = 0``, reset ``G(q, q') = (q, -R q')``: the event-time
  sensitivity ``dt = -(h_x X + h_p) / (h_x f-)`` and::

      X+ = G_x X + G_p + (G_x f- - f+) dt

  whose ``x0`` block is the saltation matrix ``S = [[-R, 0], [(a+ + R a-)/v-, -R]]``
  (:func:`vibeam.models.impact.saltation_matrix`) times ``X-``;
* sticking: the state on the stop is ``(Delta, 0)`` whatever came before, so ``X <- [0 |
  (dDelta/dp, 0)]``; the release time drops out because the vector field after release
  vanishes there (contact force zero, ``q' = 0``);
* the end of the window ``t = n T`` moves with ``Omega``: ``x_Omega += f(x_end) d(nT)/dOmega``.

A second (lower) stop at ``q = -Delta_lower`` (``model.Delta_lower``, normal ``-1``, its own
constant ``R_lower`` or the upper stop's ``R``) enters the same way: an impact on it has the
surface ``h = -q - Delta_lower`` (``h_p = 0``: none of :data:`PARAMETERS` moves it), the reset
``q' -> -R_lower q'`` and so the same saltation formula with the signed pre-impact velocity; the
mass held on it is at ``(-Delta_lower, 0)``.  Its grazing (a free-flight minimum touching
``-Delta_lower``) is watched through the logged minima (``apex_gap`` is the nearer of the two
stops' gaps at the interior extrema).  Hence ``det M = R^(2 m_up) R_lower^(2 m_low)
exp(-2 beta n T)`` for ``m_up`` and ``m_low`` impacts on the two stops and no sticking, ``M = 0``
with sticking.  All quantities nondimensional.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contact import LAW, NPAR, OFFSET, R as _RCOL, SIGN
from .periodic import Shot
from .sdof_event import EV_APEX, EV_IMPACT, EV_MIN, EV_RELEASE, EV_STICK, STATUS_FAILED, event_kernel
from .sdof_flow import particular_coefficients, transition

TWO_PI = 2.0 * math.pi

#: native continuation parameters of the SDOF model, in the column order of the kernel's d/dp
PARAMETERS = ("Omega", "B", "Delta", "R", "beta")
_ORDER = (4, 1, 3, 2, 0)   # position of each parameter in (beta, B, R, Delta, Omega)


@njit(cache=True)
def _particular_derivatives(beta, B, Omega):
    """``(a, b)`` of the particular solution and their derivatives by (Omega, B, beta).

    Returns ``a, b, da (3,), db (3,)`` with the columns in the order Omega, B, beta.
    """
    F = Omega * Omega * B
    k = 1.0 - Omega * Omega
    c = 2.0 * beta * Omega
    D = k * k + c * c
    a = F * k / D
    b = -F * c / D
    da = np.zeros(3)
    db = np.zeros(3)
    # Omega
    F_W = 2.0 * Omega * B
    k_W = -2.0 * Omega
    c_W = 2.0 * beta
    D_W = 2.0 * k * k_W + 2.0 * c * c_W
    da[0] = (F_W * k + F * k_W) / D - F * k * D_W / (D * D)
    db[0] = -(F_W * c + F * c_W) / D + F * c * D_W / (D * D)
    # B
    da[1] = Omega * Omega * k / D
    db[1] = -Omega * Omega * c / D
    # beta
    c_b = 2.0 * Omega
    D_b = 2.0 * c * c_b
    da[2] = -F * k * D_b / (D * D)
    db[2] = -(F * c_b) / D + F * c * D_b / (D * D)
    return a, b, da, db


@njit(cache=True)
def _dP(t, a, b, da, db, Omega, j):
    """``d P(t) / d p_j`` of the particular state ``(q_p, q_p')`` at fixed time ``t``.

    ``j`` indexes (Omega, B, beta) as in :func:`_particular_derivatives`.
    """
    ph = Omega * t
    s = math.sin(ph)
    c = math.cos(ph)
    dW = 1.0 if j == 0 else 0.0
    d0 = da[j] * s + db[j] * c + dW * t * (a * c - b * s)
    d1 = (dW * (a * c - b * s) + Omega * (da[j] * c - db[j] * s)
          - Omega * dW * t * (a * s + b * c))
    return d0, d1


@njit(cache=True)
def _phi(s, beta):
    """Transition matrix ``Phi(s)`` of ``x'' + 2 beta x' + x = 0`` and ``d Phi / d beta``."""
    p11, p12, p21, p22 = transition(s, beta)
    Phi = np.empty((2, 2))
    Phi[0, 0] = 1.0 + p11
    Phi[0, 1] = p12
    Phi[1, 0] = p21
    Phi[1, 1] = 1.0 + p22
    w = math.sqrt(1.0 - beta * beta)
    E = math.exp(-beta * s)
    cs = math.cos(w * s)
    sn = math.sin(w * s)
    u = sn / w
    du = -beta * s * cs / (w * w) + beta * sn / (w * w * w)
    dPhi = np.empty((2, 2))
    # d/dbeta of E (cos + beta u), E u, -E u, E (cos - beta u); d cos(w s)/dbeta = s beta/w sin
    dcos = s * beta / w * sn
    dPhi[0, 1] = -s * E * u + E * du
    dPhi[1, 0] = -dPhi[0, 1]
    dPhi[0, 0] = -s * Phi[0, 0] + E * (dcos + u + beta * du)
    dPhi[1, 1] = -s * Phi[1, 1] + E * (dcos - u - beta * du)
    return Phi, dPhi


@njit(cache=True)
def _flight(X, XP, s, t_a, t_b, qa, va, beta, a, b, da, db, Omega):
    """Carry ``X`` (2, 2) and ``XP`` (2, 5) through a free flight of length ``s`` in place."""
    Phi, dPhi = _phi(s, beta)
    m00 = Phi[0, 0] * X[0, 0] + Phi[0, 1] * X[1, 0]
    m01 = Phi[0, 0] * X[0, 1] + Phi[0, 1] * X[1, 1]
    m10 = Phi[1, 0] * X[0, 0] + Phi[1, 1] * X[1, 0]
    m11 = Phi[1, 0] * X[0, 1] + Phi[1, 1] * X[1, 1]
    X[0, 0] = m00
    X[0, 1] = m01
    X[1, 0] = m10
    X[1, 1] = m11
    for j in range(5):
        p0 = Phi[0, 0] * XP[0, j] + Phi[0, 1] * XP[1, j]
        p1 = Phi[1, 0] * XP[0, j] + Phi[1, 1] * XP[1, j]
        XP[0, j] = p0
        XP[1, j] = p1
    # explicit parameter dependence of the flight (Omega, B, beta): particular solution
    cols = (0, 1, 4)
    for jj in range(3):
        j = cols[jj]
        ka = jj  # index into da/db (Omega, B, beta)
        pa0, pa1 = _dP(t_a, a, b, da, db, Omega, ka)
        pb0, pb1 = _dP(t_b, a, b, da, db, Omega, ka)
        XP[0, j] += pb0 - (Phi[0, 0] * pa0 + Phi[0, 1] * pa1)
        XP[1, j] += pb1 - (Phi[1, 0] * pa0 + Phi[1, 1] * pa1)
    # beta also enters the homogeneous flow
    sa = math.sin(Omega * t_a)
    ca = math.cos(Omega * t_a)
    y0 = qa - (a * sa + b * ca)
    y1 = va - Omega * (a * ca - b * sa)
    XP[0, 4] += dPhi[0, 0] * y0 + dPhi[0, 1] * y1
    XP[1, 4] += dPhi[1, 0] * y0 + dPhi[1, 1] * y1


@njit(cache=True)
def assemble_derivatives(ev_log, n_events, q0, v0, q_end, v_end, stuck_end, t_end,
                         beta, B, R, Delta, Omega, Dl=np.inf, R_low=0.0, dR_low=0.0):
    """Monodromy and parameter derivatives of ``P^n`` from the kernel's event log.

    Parameters
    ----------
    ev_log : ndarray, shape (cap, 5)
        Rows ``(kind, t, q, q', q'')`` of :func:`vibeam.models.sdof_event.event_kernel`
        (an impact on the lower stop is logged with its normal velocity and acceleration,
        ``-q'-`` and ``-q''-``).
    n_events : int
        Rows used (``<= cap``).
    q0, v0 : float
        State at the start of the window (section, forcing phase 0).
    q_end, v_end : float
        State at ``t_end``.
    stuck_end : bool
        Whether the mass is stuck on a stop at ``t_end``.
    t_end : float
        ``n T`` (nondimensional).
    beta, B, R, Delta, Omega : float
        Model parameters.
    Dl, R_low : float, optional
        A second (lower) stop at ``q = -Dl`` with coefficient of restitution ``R_low``
        (``Dl = inf``: one stop).
    dR_low : float, optional
        ``d R_low / d R`` (1 when the lower stop follows the upper stop's law, 0 when it
        has its own R).

    Returns
    -------
    M : ndarray, shape (2, 2)
        ``d x(t_end) / d x0``.
    XP : ndarray, shape (2, 5)
        ``d x(t_end) / d p`` for p = Omega, B, Delta, R, beta (columns).

    Notes
    -----
    An impact on the lower stop (surface ``h = -q - Dl``, reset ``q' -> -R_low q'``) has the
    event-time sensitivity ``dt = -X_q / q'-`` (``h_x f- = -q'-``, ``h_p = 0``: no native
    parameter moves the lower stop) and the jump ``G_x f- - f+ = ((1 + R_low) q'-, -(R_low
    q''- + q''+))`` of the upper stop's formula, with the physical (signed) velocities; the
    mass held on it is at ``(-Dl, 0)`` whatever the parameters.
    """
    a, b, da, db = _particular_derivatives(beta, B, Omega)
    F = Omega * Omega * B
    X = np.eye(2)
    XP = np.zeros((2, 5))
    t_prev = 0.0
    qa = q0
    va = v0
    stuck = False
    mid = 0.5 * (Delta - Dl)      # rows logged at q < mid are on the lower stop (-inf: one stop)
    for k in range(n_events):
        kind = int(ev_log[k, 0])
        t = ev_log[k, 1]
        if kind == EV_APEX or kind == EV_MIN:
            continue
        lower = ev_log[k, 2] < mid
        if stuck:
            if kind == EV_RELEASE:
                stuck = False
                t_prev = t
                qa = -Dl if lower else Delta
                va = 0.0
            continue
        if kind == EV_RELEASE:  # (not stuck by the log: cannot happen; be safe)
            t_prev = t
            qa = -Dl if lower else Delta
            va = 0.0
            continue
        _flight(X, XP, t - t_prev, t_prev, t, qa, va, beta, a, b, da, db, Omega)
        if kind == EV_STICK:
            X[:, :] = 0.0
            XP[:, :] = 0.0
            if not lower:
                XP[0, 2] = 1.0
            stuck = True
            t_prev = t
            continue
        if lower:
            # impact on the lower stop: physical pre-impact velocity and acceleration
            vm = -ev_log[k, 3]
            am = -ev_log[k, 4]
            Rl = R_low
            ap = am + 2.0 * beta * (1.0 + Rl) * vm
            w0 = (1.0 + Rl) * vm
            w1 = -(Rl * am + ap)
            inv = 1.0 / vm if vm < 0.0 else -np.inf
            for j in range(2):
                dt = -X[0, j] * inv
                X[0, j] = X[0, j] + w0 * dt
                X[1, j] = -Rl * X[1, j] + w1 * dt
            for j in range(5):
                dt = -XP[0, j] * inv
                x0n = XP[0, j] + w0 * dt
                x1n = -Rl * XP[1, j] + w1 * dt
                if j == 3:
                    x1n -= dR_low * vm
                XP[0, j] = x0n
                XP[1, j] = x1n
            t_prev = t
            qa = -Dl
            va = -Rl * vm
            continue
        # impact: pre-impact velocity and acceleration
        vm = ev_log[k, 3]
        am = ev_log[k, 4]
        ap = am + 2.0 * beta * (1.0 + R) * vm
        # (G_x f- - f+) = ((1 + R) v-, -(R a- + a+))
        w0 = (1.0 + R) * vm
        w1 = -(R * am + ap)
        inv = 1.0 / vm if vm > 0.0 else np.inf
        for j in range(2):
            dt = -X[0, j] * inv
            x0n = X[0, j] + w0 * dt
            x1n = -R * X[1, j] + w1 * dt
            X[0, j] = x0n
            X[1, j] = x1n
        for j in range(5):
            hp = -1.0 if j == 2 else 0.0
            dt = -(XP[0, j] + hp) * inv
            x0n = XP[0, j] + w0 * dt
            x1n = -R * XP[1, j] + w1 * dt
            if j == 3:
                x1n -= vm
            XP[0, j] = x0n
            XP[1, j] = x1n
        t_prev = t
        qa = Delta
        va = -R * vm
    if not stuck:
        _flight(X, XP, t_end - t_prev, t_prev, t_end, qa, va, beta, a, b, da, db, Omega)
        if not stuck_end:
            # the window ends at n T = 2 pi n / Omega: d(nT)/dOmega = -nT/Omega, forcing phase 0
            XP[0, 0] += v_end * (-t_end / Omega)
            XP[1, 0] += (F * math.sin(Omega * t_end) - 2.0 * beta * v_end - q_end) * (-t_end / Omega)
    return X, XP


@njit(cache=True)
def shoot(par, n, ns, max_impacts, samples, imp_buf, ev_log, ev_count, out, imp, index):
    """One shot: ``n`` periods of the event kernel from ``(q0, q0')`` at phase 0, then the
    derivatives from its event log, all in compiled code (no Python per event, no array
    returned: one call from Python costs a few microseconds beyond the kernel).

    Parameters
    ----------
    par : ndarray, shape (8,) or (11,)
        ``(beta, B, R, Delta, Omega, q0, q0', chatter_tol)`` and, for a two-sided scene,
        ``(Delta_lower, R_lower, dR_lower/dR)`` (a second stop at ``q = -Delta_lower``).
    n, ns, max_impacts : int
        Periods, grid points per period, impact limit.
    samples, imp_buf, ev_log, ev_count : ndarray
        Work buffers of the kernel (``ev_log`` shape (cap, 5)).
    out : ndarray, shape (23,)
        Receives ``x_end (2), M (4, row-major), x_p (2, column index of XP), XP (10,
        row-major (2, 5)), apex_max, q_min, q_max, stuck_time, stuck_end``; ``apex_max`` is the
        largest gap at an interior free-flight extremum: ``q - Delta`` at the maxima and, with
        a lower stop, ``-q - Delta_lower`` at the minima (its zero is a grazing on either stop).
    imp : ndarray, shape (cap, 4)
        Receives ``(t, U-, g''-, stop)`` of each impact: time, normal pre-impact velocity and
        acceleration of the stop's gap, stop (0 upper, 1 lower).
    index : int
        Column of the continuation parameter in ``PARAMETERS``.

    Returns
    -------
    code : int
        0 ok, 1 more events than the log holds, 2 more impacts than ``max_impacts``, 3
        non-finite derivatives (a grazing impact with zero velocity).
    m : int
        Number of impacts.
    """
    beta, B, R, Delta, Omega = par[0], par[1], par[2], par[3], par[4]
    q0, v0 = par[5], par[6]
    two = par.shape[0] > 8
    ev_count[0] = 0
    pmin = np.empty(n)       # per-period minima (not needed here; the kernel fills them)
    chat_t = np.empty(0)     # chatter accumulation times (not needed here)
    # the stops (vibeam.models.contact): normal +1 at q = Delta, Newton's law with constant R; a
    # lower one at q = -Delta_lower, normal -1, with its own constant R
    stops = np.zeros((2 if two else 1, NPAR))
    stops[0, SIGN] = 1.0
    stops[0, OFFSET] = Delta
    stops[0, LAW] = 0.0
    stops[0, _RCOL] = R
    Dl = np.inf
    R_low = 0.0
    dR_low = 0.0
    if two:
        Dl = par[8]
        R_low = par[9]
        dR_low = par[10]
        stops[1, SIGN] = -1.0
        stops[1, OFFSET] = Dl
        stops[1, LAW] = 0.0
        stops[1, _RCOL] = R_low
    tab = np.zeros((stops.shape[0], 1))
    imp_k = np.zeros(imp_buf.shape[0], np.int64)
    n_stop = np.zeros(stops.shape[0], np.int64)
    res = event_kernel(beta, B, stops, tab, tab, Omega, q0, v0, 0,
                       0, n, ns, ns, max_impacts, par[7], samples, imp_buf, imp_buf, imp_k, n_stop,
                       pmin, chat_t, ev_log, ev_count)
    status, n_imp, q_min, q_max, n_chat, stuck_time, q_end, v_end, stuck_end, n_tot, gmax = res
    n_ev = ev_count[0]
    code = 0
    if n_ev > ev_log.shape[0]:
        code = 1
        n_ev = ev_log.shape[0]
    elif status == STATUS_FAILED:
        code = 2
    if two:
        M, XP = assemble_derivatives(ev_log, n_ev, q0, v0, q_end, v_end, stuck_end != 0,
                                     n * TWO_PI / Omega, beta, B, R, Delta, Omega, Dl, R_low, dR_low)
    else:
        M, XP = assemble_derivatives(ev_log, n_ev, q0, v0, q_end, v_end, stuck_end != 0,
                                     n * TWO_PI / Omega, beta, B, R, Delta, Omega)
    m = 0
    apex = -np.inf
    mid = 0.5 * (Delta - Dl)
    for k in range(n_ev):
        kind = int(ev_log[k, 0])
        if kind == EV_IMPACT:
            if m < imp.shape[0]:
                imp[m, 0] = ev_log[k, 1]
                imp[m, 1] = ev_log[k, 3]
                imp[m, 2] = ev_log[k, 4]
                imp[m, 3] = 1.0 if ev_log[k, 2] < mid else 0.0
            m += 1
        elif kind == EV_APEX and ev_log[k, 2] - Delta > apex:
            apex = ev_log[k, 2] - Delta
        elif kind == EV_MIN and -ev_log[k, 2] - Dl > apex:
            apex = -ev_log[k, 2] - Dl
    out[0] = q_end
    out[1] = v_end
    for i in range(2):
        for k in range(2):
            out[2 + 2 * i + k] = M[i, k]
            if code == 0 and not math.isfinite(M[i, k]):
                code = 3
        out[6 + i] = XP[i, index]
        for k in range(5):
            out[8 + 5 * i + k] = XP[i, k]
            if code == 0 and not math.isfinite(XP[i, k]):
                code = 3
    out[18] = apex
    out[19] = q_min
    out[20] = q_max
    out[21] = stuck_time
    out[22] = 1.0 if stuck_end else 0.0
    return code, m


class SDOFShooting:
    """Shooting problem ``P^n`` of the SDOF CoR oscillator (contract: :mod:`vibeam.models.periodic`).

    Parameters
    ----------
    model : SDOF
        The oscillator (constant ``R``; a velocity-dependent ``R_table`` is not supported), with
        one stop or two (``Delta_lower``, ``R_lower``: a shot's ``extra["impact_stops"]`` gives
        the stop of each impact, 0 upper, 1 lower).
    parameter : {"Omega", "B", "Delta", "R", "beta"}
        Continuation parameter (native, nondimensional).
    Omega : float, optional
        Forcing frequency; required unless ``parameter == "Omega"`` (then it is only the
        reported ``value``).
    chatter_tol : float, optional
        Chatter accumulation tolerance of the event kernel (the event policy of method
        ``event``).
    max_events : int, optional
        Events (impacts, sticks, releases, apexes) one shot may log; beyond it the shot
        has ``status = "failed"``.
    samples_per_period : int, optional
        Grid points per period of the kernel (detection efficiency only).

    Raises
    ------
    ValueError
        For an unknown parameter, a missing ``Omega`` or a model with ``R_table``.
    """

    dim = 2

    def __init__(self, model, parameter: str = "Omega", Omega: float | None = None,
                 chatter_tol: float = 1e-7, max_events: int = 4096, samples_per_period: int = 8):
        if parameter not in PARAMETERS:
            raise ValueError(f"parameter {parameter!r} is not a parameter of the SDOF model; "
                             f"allowed: {', '.join(PARAMETERS)}")
        if parameter != "Omega" and Omega is None:
            raise ValueError(f"continuation in {parameter!r} needs the forcing frequency Omega")
        if getattr(model, "R_table", ()):
            raise ValueError("the shooting problem supports a constant R only (no restitution_law)")
        self.model = model
        self.parameter = parameter
        self.index = PARAMETERS.index(parameter)
        self.Omega = None if Omega is None else float(Omega)
        self.value = (float(Omega) if Omega is not None else math.nan) if parameter == "Omega" \
            else float(getattr(model, parameter))
        self.chatter_tol = float(chatter_tol)
        self.ns = int(samples_per_period)
        self._log = np.zeros((int(max_events), 5))
        self._count = np.zeros(1, dtype=np.int64)
        self._imp = np.zeros(1)
        self._impacts = np.empty((64, 4))
        # a second (lower) stop at q = -Delta_lower: its R (the upper stop's when R_lower is None,
        # then d R_lower / d R = 1)
        self.two_sided = bool(getattr(model, "two_sided", False))
        self._par = np.zeros(11 if self.two_sided else 8)
        self._par[7] = self.chatter_tol
        if self.two_sided:
            own = getattr(model, "R_lower", None) is not None
            self._par[8] = float(model.Delta_lower)
            self._par[9] = float(model.R_lower) if own else float(model.R)
            self._par[10] = 0.0 if own else 1.0
        self._samples = {}
        # (beta, B, R, Delta, Omega) of the model and the slot of the continuation parameter
        self._base = [float(model.beta), float(model.B), float(model.R), float(model.Delta), self.Omega]
        self._slot = _ORDER[self.index]

    def params(self, p: float):
        """``(beta, B, R, Delta, Omega)`` with the continuation parameter set to ``p``."""
        v = self._base.copy()
        v[self._slot] = float(p)
        return tuple(v)

    def shot(self, x0, p, n) -> Shot:
        """``P^n(x0; p)`` with monodromy and ``d/dp`` (see the module docstring).

        Parameters
        ----------
        x0 : array_like, shape (2,)
            ``(q, q')`` at forcing phase 0.
        p : float
            Value of the continuation parameter.
        n : int
            Forcing periods.

        Returns
        -------
        Shot
            ``extra["x_all_p"]`` holds ``d x / d(Omega, B, Delta, R, beta)`` (shape (2, 5));
            ``extra["stuck_end"]`` whether the mass is on the stop at the end.
        """
        v = self._base.copy()
        v[self._slot] = p
        beta, B, R, Delta, Omega = v
        n = int(n)
        q0, v0 = float(x0[0]), float(x0[1])
        if not (0.0 <= beta < 1.0 and 0.0 <= R <= 1.0 and Omega is not None and Omega > 0.0
                and math.isfinite(q0) and math.isfinite(v0) and math.isfinite(B) and math.isfinite(Delta)
                and n >= 1):
            return _failed(f"parameters or state out of range (beta {beta}, R {R}, Omega {Omega}, "
                           f"n {n}, x0 ({q0}, {v0}))")
        if beta == 0.0 and Omega == 1.0:
            return _failed("undamped exact resonance: no periodic particular solution")
        smp = self._samples.get(n)
        if smp is None:
            smp = self._samples[n] = np.zeros((n * self.ns, 2))
        par = self._par
        par[0], par[1], par[2], par[3], par[4], par[5], par[6] = beta, B, R, Delta, Omega, q0, v0
        if self.two_sided:
            if par[10] == 1.0:
                par[9] = R                 # the lower stop follows the upper stop's law
            if not Delta + par[8] > 0.0:
                return _failed(f"the stops overlap: Delta + Delta_lower = {Delta + par[8]} must be > 0")
        out = np.empty(23)
        imp = self._impacts
        code, m = shoot(par, n, self.ns, 20000 * n, smp, self._imp, self._log, self._count, out, imp,
                        self.index)
        if m > imp.shape[0]:     # more impacts than the buffer: grow it and shoot again
            self._impacts = np.empty((2 * m, 4))
            return self.shot(x0, p, n)
        if code:
            msg = _MESSAGES[code].format(cap=self._log.shape[0], imp=20000 * n, n=n)
            if code < 3:
                return _failed(msg)
        imp = imp[:m].copy()
        extra = {"x_all_p": out[8:18].reshape(2, 5), "stuck_end": out[22] > 0.5}
        if self.two_sided:
            extra["impact_stops"] = imp[:, 3].astype(np.int64)
        return Shot(x=out[0:2], M=out[2:6].reshape(2, 2), x_p=out[6:8], impact_times=imp[:, 0],
                    impact_velocities=imp[:, 1], q_min=out[19], q_max=out[20], apex_gap=out[18],
                    stuck_time=out[21], status="failed" if code else "ok", message=msg if code else "",
                    Omega=Omega, gap=Delta, impact_accelerations=imp[:, 2], extra=extra)

    def resect(self, x0, p, n):
        """The same orbit seen on the other side of an impact that coincides with the section.

        When an impact of the orbit through ``x0`` approaches forcing phase 0 (the first one
        at ``t -> 0+``, or the last one at ``t -> n T-``), the state at the section jumps
        between the pre- and post-impact states: the stroboscopic fixed point is
        discontinuous although the orbit is not.  Returns the state at phase 0 with that
        impact moved to the other side of the section -- the post-impact state carried back to
        ``t = 0`` by the free flow, or the pre-impact state carried on to ``t = n T`` -- or None
        if no impact lies within ``1e-6 T`` of the section.
        """
        from .sdof_flow import propagate
        s = self.shot(x0, p, n)
        if s.status != "ok" or not s.n_impacts:
            return None
        beta, B, R, Delta, Omega = self.params(p)
        T = TWO_PI / Omega
        a, b = particular_coefficients(beta, Omega * Omega * B, Omega)
        t1, tm = float(s.impact_times[0]), float(s.impact_times[-1])
        # the stop of each impact: position and sign of the physical velocity (+1 upper, -1 lower)
        stops = s.extra.get("impact_stops", np.zeros(s.n_impacts, np.int64))
        where = (Delta, 1.0, R) if not self.two_sided else None

        def at(k):
            if stops[k] == 0:
                return Delta, 1.0, R
            return -self._par[8], -1.0, (R if self._par[10] == 1.0 else self._par[9])

        if t1 < 1e-6 * T:
            qs, sg, Rk = at(0) if where is None else where
            v = -Rk * sg * float(s.impact_velocities[0])
            phi = (Omega * t1) % TWO_PI
            g, w, _, _, _ = propagate(-t1, phi, qs, v, beta, a, b, Omega, Delta)
            return np.array([Delta + g, w])
        if tm > n * T - 1e-6 * T:
            qs, sg, Rk = at(s.n_impacts - 1) if where is None else where
            phi = (Omega * tm) % TWO_PI
            g, w, _, _, _ = propagate(n * T - tm, phi, qs, sg * float(s.impact_velocities[-1]),
                                      beta, a, b, Omega, Delta)
            return np.array([Delta + g, w])
        return None

    # ------------------------------------------------------------------ starting orbits
    starts = ("linear", "averaging")

    def start(self, kind: str, p: float, n: int = 1):
        """Initial state ``(q, q')`` at forcing phase 0 of a closed-form or averaged orbit.

        Parameters
        ----------
        kind : {"linear", "averaging"}
            ``linear``: the non-impacting steady state ``P(0) = (b, Omega a)`` (paper Eq. 28,
            particular part); ``averaging``: the upper averaging branch (paper Eqs. 18-23,
            ``k = 1``: impact phase and velocity ~ Q) refined, where it converges to an
            admissible orbit, by Newton on the impact map (Eqs. 33-34,
            :func:`vibeam.models.sdof_mapping.newton_fixed_point`), turned into the
            post-impact state and carried by the closed-form flow to the next phase 0.
        p : float
            Value of the continuation parameter.
        n : int
            Period (``linear``: any; ``averaging``: 1).

        Returns
        -------
        x0 : ndarray, shape (2,)
        reason : str
            Empty when the orbit exists; else why not (then ``x0`` is None).
        """
        from .sdof_flow import propagate
        beta, B, R, Delta, Omega = self.params(p)
        F = Omega * Omega * B
        a, b = particular_coefficients(beta, F, Omega)
        if kind == "linear":
            C = math.hypot(a, b)
            if not C < Delta:
                return None, (f"the non-impacting orbit does not exist: its amplitude C = {C:.6g} "
                              f"reaches the stop Delta = {Delta:.6g} at {self.parameter} = {p:.6g}")
            if self.two_sided and not C < self._par[8]:
                return None, (f"the non-impacting orbit does not exist: its amplitude C = {C:.6g} "
                              f"reaches the lower stop Delta_lower = {self._par[8]:.6g} at "
                              f"{self.parameter} = {p:.6g}")
            return np.array([b, Omega * a]), ""
        if kind == "averaging":
            if n != 1:
                return None, "the averaging start gives period-1 orbits only (k = 1)"
            from dataclasses import replace
            from .sdof_averaging import solve
            from .sdof_mapping import is_admissible, newton_fixed_point
            r = solve(Omega, beta, B, R, Delta, 1)
            Q = float(r["amplitude"])
            if not np.isfinite(Q):
                return None, f"averaging has no real amplitude at {self.parameter} = {p:.6g}"
            phi, v = float(r["impact_phase"]), Q
            # refine on the impact map (Newton on the closed form, paper Eqs. 33-34): averaging is
            # a first-order guess, poor for R well below 1
            m = replace(self.model, beta=beta, B=B, R=R, Delta=Delta)
            fp = newton_fixed_point(m, Omega, (phi, v), 1)
            if fp is not None and is_admissible(m, Omega, fp, 1)[0]:
                phi, v = float(fp[0]), float(fp[1])
            s = ((TWO_PI - phi) % TWO_PI) / Omega
            g, w, _, _, _ = propagate(s, phi, Delta, -R * v, beta, a, b, Omega, Delta)
            x0 = np.array([Delta + g, w])
            if self.two_sided:
                # the averaged orbit is a one-stop orbit: admissible only if it stays above the
                # lower stop (one impact per period on the upper stop, none below)
                sh = self.shot(x0, p, 1)
                if sh.status != "ok" or np.any(sh.extra["impact_stops"] == 1) or sh.q_min <= -self._par[8]:
                    return None, (f"the averaging orbit reaches the lower stop Delta_lower = "
                                  f"{self._par[8]:.6g} at {self.parameter} = {p:.6g}")
            return x0, ""
        raise ValueError(f"unknown start {kind!r}; allowed: {', '.join(self.starts)}")


_MESSAGES = {1: "more than {cap} events in {n} period(s) (chatter that does not accumulate?)",
             2: "more than {imp} impacts in {n} period(s) (chatter that does not accumulate?)",
             3: "grazing impact (zero impact velocity): the monodromy is singular"}


def _failed(message: str) -> Shot:
    nan2 = np.full(2, np.nan)
    return Shot(x=nan2, M=np.full((2, 2), np.nan), x_p=nan2.copy(), impact_times=np.zeros(0),
                impact_velocities=np.zeros(0), q_min=np.nan, q_max=np.nan, status="failed",
                message=message)
