"""The paper's three scipy time-integration methods for the SDOF impact oscillator.

Model (nondimensional, paper Eqs. 1-2)::

    q'' + 2 beta q' + q = Omega^2 B sin(Omega t)      while q < Delta
    q(t+) = q(t-),  q'(t+) = -R q'(t-)                  at q = Delta

Paper Sec. 3 integrates it with MATLAB's ``ode23`` (``RelTol = 1e-4``,
``AbsTol = 1e-8``) in three ways, reproduced here with
:func:`scipy.integrate.solve_ivp` (``RK23`` is the same Bogacki-Shampine pair
as ``ode23``):

``direct`` (:class:`DirectSolver`, Sec. 3.1)
    Eq. 1 in ``(q, q')`` with a terminal event at ``q = Delta`` (rising) and a
    restart after the impact law Eq. 2.  A scene with a compliant stop is the
    one direct solver's (:class:`vibeam.models.core.direct.DirectIntegrator`:
    the contact force in the equations, events at the contacts' entries and
    exits), with its reference tolerances.
``zhuravlev`` (:class:`ZhuravlevSolver`, Sec. 3.2)
    The unfolded variable ``q = Delta - |z|`` (Eqs. 4-6); Eq. 7 in ``(z, z')``
    with a terminal event at ``z = 0`` and the reduced jump ``z'+ = R z'-``
    (Eq. 8).
``ivanov`` (:class:`IvanovSolver`, Sec. 3.3)
    Ivanov's variables ``(z, s)`` (Eqs. 11-13); Eqs. 14-15 are integrated
    with no event at all, the impact losses being inside ``K_N``.  Impacts are
    found after the fact as sign changes of ``z``.

All three share one driver, :func:`integrate_piecewise`, which takes the
right-hand side, the event and the jump as functions.  Unlike the exact
method ``event`` (:class:`vibeam.models.core.event.EventSolver`), these event
solvers cannot pass the accumulation point of a chatter sequence (nor, for
``ivanov``, slide along ``z = 0``): such a point ends with status ``failed``.
The only sticking they handle is a start at rest on the stop, which is held
in closed form until the contact force releases the mass (as ``event`` does).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from numba import njit
from scipy.optimize import brentq

from ..trajectory import Trajectory

from ..impact import newton_restitution
from ..core.contact_policy import release_now
from ..core.direct import ATOL_COMPLIANT, RTOL_COMPLIANT, DirectIntegrator
from ..core.event import EventIntegrator
from ..scene import one_mode

TWO_PI = 2.0 * math.pi
EPS = 2.220446049250313e-16
SOLVERS = ("RK23", "RK45", "DOP853", "Radau", "LSODA")


class _Budget(Exception):
    """Raised inside the right-hand side when the evaluation budget is spent."""


@dataclass
class _Run:
    """Result of :func:`integrate_piecewise` (internal)."""

    status: str = "ok"
    message: str = ""
    n_events: int = 0
    impact_times: list = field(default_factory=list)       # absolute times
    impact_velocities: list = field(default_factory=list)  # q'(t-) > 0
    impact_stops: list = field(default_factory=list)       # event index (0 upper, 1 lower stop)
    segments: list = field(default_factory=list)           # (OdeSolution, mode) in the record
    y_end: np.ndarray | None = None
    mode_end: float = 0.0
    nfev: int = 0


# the closed-form release of the SDOF held on a stop: the direct solver's (its own event loop)
@njit(cache=True)
def release_delay(phi, F, Delta, Omega):
    """Time until a mass stuck on the stop is released (inf: never).

    The contact force per unit mass is ``a(phi) = F sin(phi) - Delta``; the
    mass stays while ``a >= 0`` and leaves when ``a`` turns negative.
    """
    a_now = F * math.sin(phi) - Delta
    da = F * Omega * math.cos(phi)
    if release_now(a_now, da):
        return 0.0
    if F <= 0.0:
        return np.inf  # unforced: a = -Delta >= 0 stays
    r = Delta / F
    if r <= -1.0:
        return np.inf
    if r >= 1.0:
        return 0.0
    phid = math.pi - math.asin(r)  # downward zero crossing of a
    dphi = (phid - phi) % TWO_PI
    return dphi / Omega


@njit(cache=True)
def release_delay_lower(phi, F, Dl, Omega):
    """:func:`release_delay` on the lower stop at ``q = -Dl`` (normal ``-1``).

    The contact force per unit mass is ``a(phi) = -F sin(phi) - Dl``; it turns negative
    (downward zero crossing, ``cos(phi) > 0``) at ``phi = -asin(Dl / F)``.  Written like the
    upper stop's (no phase shift by pi, which would round), so that advancing the phase by
    the returned delay lands on the crossing.
    """
    a_now = -F * math.sin(phi) - Dl
    da = -F * Omega * math.cos(phi)
    if release_now(a_now, da):
        return 0.0
    if F <= 0.0:
        return np.inf  # unforced: a = -Dl >= 0 stays
    r = Dl / F
    if r <= -1.0:
        return np.inf
    if r >= 1.0:
        return 0.0
    phid = -math.asin(r)  # downward zero crossing of a
    dphi = (phid - phi) % TWO_PI
    return dphi / Omega


def integrate_piecewise(rhs, event, jump, to_q, y0, mode0, t0, period, n_transient, n_record,
                        t_samples, samples, method, rtol, atol, max_step, max_events,
                        max_nfev_per_period, crossings=None):
    """Integrate a piecewise-smooth ODE with terminal events and state jumps.

    One driver for the three methods: between events the smooth system
    ``y' = rhs(mode)(t, y)`` is integrated by :func:`scipy.integrate.solve_ivp`;
    at a terminal event of ``event(mode)`` the state is mapped by ``jump`` and
    the integration restarts (the paper's ``ode23`` + ``'events'`` approach).
    Integration is chunked at the forcing-period boundaries so that the work
    per period can be bounded.

    Parameters
    ----------
    rhs : callable
        ``rhs(mode) -> f(t, y)``, the right-hand side of the smooth system in
        the internal coordinates, ``y`` of shape (2,).
    event : callable or None
        ``event(mode) -> g(t, y)`` with ``terminal`` and ``direction``
        attributes (see ``solve_ivp``), or a list of them (one per stop), or None for an
        event-free system.
    jump : callable or None
        ``jump(t, y, mode) -> (y_plus, mode_plus, v_minus)``: the post-event
        internal state, the new mode and the pre-impact velocity ``q'(t-)``; with a list of
        events ``jump(t, y, mode, j)``, ``j`` the index of the event that fired first
        (recorded in ``impact_stops``).
    to_q : callable
        ``to_q(Y, mode) -> (q, q')`` for ``Y`` of shape (2,) or (2, n).
    y0 : ndarray, shape (2,)
        Internal state at ``t0``.
    mode0 : float
        Initial mode (e.g. the side of the stop in Zhuravlev's unfolding).
    t0 : float
        Start time (nondimensional), ``0 <= t0``; forcing phase 0 is ``t = 0``.
    period : float
        Forcing period ``2 pi / Omega``.
    n_transient, n_record : int
        Periods before the recorded window and in it.
    t_samples : ndarray, shape (n,)
        Increasing sample times in the recorded window.
    samples : ndarray, shape (n, 2)
        Filled in place with ``(q, q')`` at the ``t_samples >= t0`` (a sample
        at an impact instant holds the pre-impact velocity).
    method, rtol, atol, max_step
        ``solve_ivp`` settings.
    max_events : int
        Most events (impacts) allowed over the whole run.
    max_nfev_per_period : int
        Right-hand-side evaluations allowed within any one forcing period;
        a stalled or sliding integration stops there instead of hanging.
    crossings : callable or None
        ``crossings(ts, Y) -> int``: events found after the fact on the
        integrator steps ``ts`` (shape (m,)) with states ``Y`` (shape
        (2, m)) of an event-free system; counted against ``max_events``.

    Returns
    -------
    _Run
        Status (``ok`` or ``failed``), impacts at events, the record segments
        (dense solutions with their modes) and the end state.

    Notes
    -----
    Never raises for a dynamical outcome: an integrator failure, too many
    events, a stall at an accumulation point (events with no time between
    them) or an exhausted evaluation budget give ``status = "failed"``.
    """
    run = _Run()
    counter = [0, max_nfev_per_period]  # evaluations so far, current limit
    opts = dict(method=method, rtol=rtol, atol=atol)
    if max_step is not None:
        opts["max_step"] = max_step
    n_total = n_transient + n_record
    t_record = n_transient * period
    t = float(t0)
    y = np.asarray(y0, dtype=float)
    mode = mode0
    k = int(np.searchsorted(t_samples, t, side="left"))  # next sample to fill
    stall = 0

    def fail(message):
        run.status = "failed"
        run.message = message
        run.nfev = counter[0]
        run.y_end = y      # last state reached (start of the failing segment)
        run.mode_end = mode
        return run

    for p in range(n_total):
        b = (p + 1) * period
        if t >= b:
            continue
        record = p >= n_transient
        counter[1] = counter[0] + max_nfev_per_period
        while t < b:
            f = rhs(mode)

            def fun(tt, yy, f=f):
                counter[0] += 1
                if counter[0] > counter[1]:
                    raise _Budget
                return f(tt, yy)

            t_eval = None
            if record:
                k_hi = int(np.searchsorted(t_samples, b, side="left"))
                t_eval = t_samples[k:k_hi]
            ev = None if event is None else event(mode)
            try:
                sol = solve_ivp(fun, (t, b), y, t_eval=t_eval, events=ev, dense_output=record,
                                **opts)
            except _Budget:
                return fail(f"more than {max_nfev_per_period} right-hand side evaluations in "
                            f"forcing period {p} (t = {t:.6g}): stalled or sliding integration")
            except ValueError as exc:
                # scipy's dense output (OdeSolution) raises on a segment whose step times
                # are not strictly increasing, as in chatter where impacts come within
                # round-off of each other: a dynamical outcome, reported, not raised
                return fail(f"{method} failed near t = {t:.6g} (impacts within round-off, "
                            f"chatter the event solver cannot pass): {exc}")
            if sol.status == -1:
                return fail(f"{method} failed near t = {t:.6g}: {sol.message}")
            if record:
                # solve_ivp leaves ``t`` as an empty *list* when a terminal event comes
                # before the first requested sample (two impacts within one sample
                # interval of the record, e.g. chatter): np.asarray, not .shape
                n_new = np.asarray(sol.t).shape[0]
                if n_new:
                    q, v = to_q(sol.y, mode)
                    samples[k:k + n_new, 0] = q
                    samples[k:k + n_new, 1] = v
                    k += n_new
                run.segments.append((sol.sol, mode))
            if crossings is not None:
                if record:
                    ts = np.asarray(sol.sol.ts)
                    run.n_events += int(crossings(ts, sol.sol(ts)))
                else:
                    run.n_events += int(crossings(sol.t, sol.y))
            if sol.status == 1:  # terminal event: impact
                if isinstance(ev, (list, tuple)):   # several stops: the one that fired first
                    j = min((i for i, te in enumerate(sol.t_events) if te.size),
                            key=lambda i: sol.t_events[i][0])
                    t_ev = float(sol.t_events[j][0])
                    y, mode, v_minus = jump(t_ev, sol.y_events[j][0], mode, j)
                else:
                    j = 0
                    t_ev = float(sol.t_events[0][0])
                    y, mode, v_minus = jump(t_ev, sol.y_events[0][0], mode)
                run.n_events += 1
                if t_ev >= t_record:
                    run.impact_times.append(t_ev)
                    run.impact_velocities.append(float(v_minus))
                    run.impact_stops.append(j)
                stall = stall + 1 if t_ev - t <= 4.0 * EPS * max(1.0, abs(t_ev)) else 0
                t = t_ev
                if stall >= 8:
                    return fail(f"accumulation point of impacts (chatter) at t = {t:.6g}: "
                                f"event solvers cannot pass it")
            else:
                t = b
                # with t_eval the last column is a sample, not the end point
                y = np.asarray(sol.sol(b), dtype=float) if record else sol.y[:, -1].copy()
            if run.n_events > max_events:
                return fail(f"more than {max_events} impacts before t = {t:.6g} "
                            f"(chatter the event solver cannot pass)")
    if k != t_samples.shape[0]:  # defensive: a sample missed by the t_eval bookkeeping
        return fail(f"only {k} of {t_samples.shape[0]} samples recorded")
    run.y_end = y
    run.mode_end = mode
    run.nfev = counter[0]
    return run


def _refine_extremes(segments, to_q, t_lo, t_hi, minima=None):
    """Local extremes of ``q`` on the dense record segments.

    For every integrator step of every segment on which ``q'`` changes sign,
    the root of ``q'`` is located by :func:`scipy.optimize.brentq` on the
    dense interpolant and ``q`` evaluated there.

    ``minima``, a list, receives ``(t, q)`` of every local minimum found.

    Returns
    -------
    (float, float)
        Smallest local minimum and largest local maximum found (``inf`` /
        ``-inf`` when none).
    """
    q_min, q_max = np.inf, -np.inf
    for sol, mode in segments:
        ts = np.asarray(sol.ts)
        ts = ts[(ts >= t_lo) & (ts <= t_hi)]
        if ts.shape[0] < 2:
            continue
        _, v = to_q(sol(ts), mode)
        change = np.nonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0)[0]
        for i in change:
            try:
                tr = brentq(lambda tt: to_q(sol(tt), mode)[1], ts[i], ts[i + 1], xtol=1e-14)
            except ValueError:
                continue
            qr = float(to_q(sol(tr), mode)[0])
            if v[i] < 0.0:
                q_min = min(q_min, qr)
                if minima is not None:
                    minima.append((tr, qr))
            else:
                q_max = max(q_max, qr)
    return q_min, q_max


class _ScipyMethod:
    """Shared settings, start handling and output of the three scipy methods.

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
        The one-mode oscillator and its stops (:func:`vibeam.models.scene.one_mode`).
    solver : str, optional
        ``solve_ivp`` method, one of ``RK23`` (the paper's ``ode23``), ``RK45``,
        ``DOP853``, ``Radau``, ``LSODA``.
    rtol, atol : float, optional
        Relative and absolute error tolerances (paper: 1e-4 and 1e-8).
    max_step : float or None, optional
        Largest step (nondimensional time); None = unbounded.
    max_events_per_period : int, optional
        Beyond this many events per forcing period on average the point is
        ``failed`` (chatter the event solver cannot pass).
    max_nfev_per_period : int, optional
        Right-hand-side evaluations allowed within any one forcing period
        (a regular point needs ~10^2 at the paper's tolerances, ~10^3 for
        ``ivanov`` at ``rtol = 1e-10``); beyond it the point is ``failed``
        instead of hanging (sliding of ``ivanov`` along ``z = 0``).

    Raises
    ------
    ValueError
        If ``solver`` is not one of the allowed methods, a tolerance is not
        positive, the scene is not the one-mode oscillator or has a second stop the method does not
        simulate.
    """

    name = "scipy"
    time_domain = True
    #: simulates a second (lower) stop (at ``q = -Delta_lower``); see ``supported_methods`` of the registry
    two_sided = False
    # periods per call of the sweep engine (vibeam.engine.sweep._simulate); a restart of solve_ivp changes
    # the result at the level of its tolerance, so chunks are long (Python code is interruptible
    # anyway; the chunk only sets how often the wall-time limit is checked)
    chunk_periods = 1000

    def __init__(self, scene, solver: str = "RK23", rtol: float = 1e-4, atol: float = 1e-8,
                 max_step=None, max_events_per_period: int = 20000,
                 max_nfev_per_period: int = 50000):
        one = one_mode(scene, f"method {self.name!r}")
        if solver not in SOLVERS:
            raise ValueError(f"setting solver={solver!r} is not allowed for method {self.name!r}; "
                             f"allowed: {', '.join(SOLVERS)}")
        for key, val in (("rtol", rtol), ("atol", atol)):
            if not (float(val) > 0.0):
                raise ValueError(f"setting {key}={val!r} must be a positive float")
        if max_step is not None and not (float(max_step) > 0.0):
            raise ValueError(f"setting max_step={max_step!r} must be positive or None")
        if len(one.stops) > 1 and not self.two_sided:
            raise ValueError(f"method {self.name!r} cannot simulate a second (lower) stop")
        self.scene, self.one = scene, one
        self.solver = solver
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.max_step = None if max_step is None else float(max_step)
        self.max_events_per_period = int(max_events_per_period)
        self.max_nfev_per_period = int(max_nfev_per_period)

    def settings(self) -> dict:
        return dict(solver=self.solver, rtol=self.rtol, atol=self.atol, max_step=self.max_step,
                    max_events_per_period=self.max_events_per_period,
                    max_nfev_per_period=self.max_nfev_per_period)

    # ---- method hooks (internal coordinates y, mode) ----
    def _to_internal(self, q, v):
        raise NotImplementedError

    def _rhs(self, Omega):
        raise NotImplementedError

    def _event(self):
        return None

    def _jump(self):
        return None

    def _to_q(self):
        raise NotImplementedError

    def _crossings(self):
        """Counter of after-the-fact events on integrator steps (None: events are events)."""
        return None

    def _impacts_after(self, run, to_q, t_lo, t_hi):
        """Impacts not reported as events (only Ivanov's method has any)."""
        return [], []

    def point(self, Omega: float, state0, n_transient: int, n_record: int,
              samples_per_period: int = 64) -> Trajectory:
        """Simulate one forcing frequency from ``state0`` at forcing phase 0.

        Parameters
        ----------
        Omega : float
            Forcing frequency over the natural frequency (nondimensional).
        state0 : array_like, shape (2,) or (3,), or None
            ``(q, q'[, stuck])``; only ``(q, q')`` is used.  None starts from
            :meth:`vibeam.models.scene.OneMode.initial_state` (on the stop when ``Delta < 0``).  A
            ``q`` beyond the stop is put on it; on the stop a positive ``q'``
            is an impact at ``t = 0`` and ``q' = 0`` is held in contact until
            the contact force releases the mass.
        n_transient, n_record : int
            Forcing periods discarded, then recorded.
        samples_per_period : int
            Recorded samples per period.

        Returns
        -------
        Trajectory
            ``samples`` of shape (n_record * samples_per_period, 2), impacts of
            the window (times from the start of the recording, pre-impact
            velocities ``q'(t-) > 0``), ``q_min``/``q_max`` (samples refined by
            the roots of ``q'`` on the dense output; ``q_max`` includes
            ``Delta`` when an impact occurs), ``final_state`` ``(q, q', 0.0)``
            (for ``failed``: the last state reached, so a continuation can go
            on) and ``extra["nfev"]`` (right-hand-side evaluations).  A
            non-finite ``state0`` is replaced by :meth:`vibeam.models.scene.OneMode.initial_state`.  ``status`` is ``ok``; ``failed`` (with a
            message) when the integrator fails, an accumulation point of
            impacts is reached or more than ``max_events_per_period`` events
            per period occur; ``sticking`` only if the initial contact lasts
            into the recorded window.
        """
        m = self.one
        Omega = float(Omega)
        T = TWO_PI / Omega
        n_transient, n_record, spp = int(n_transient), int(n_record), int(samples_per_period)
        t_record = n_transient * T
        t_end = (n_transient + n_record) * T
        n_s = n_record * spp
        t_samples = t_record + np.arange(n_s) * (T / spp)
        samples = np.full((n_s, 2), np.nan)
        s0 = m.initial_state() if state0 is None else np.asarray(state0, dtype=float)
        if not np.all(np.isfinite(s0[:2])):  # e.g. handed on from a failed point
            s0 = m.initial_state()
        q0, v0 = float(s0[0]), float(s0[1])
        Delta, F = m.Delta, Omega * Omega * m.B
        two = len(m.stops) > 1 and self.two_sided
        Dl = m.Delta_lower if two else math.inf
        imp_t, imp_v, imp_k = [], [], []
        n_pre = 0
        t0 = 0.0
        status, message = "ok", ""
        # a start on a stop (the upper one, or the lower one of a two-sided scene, normal -1)
        side = 0 if q0 >= Delta else (1 if q0 <= -Dl else -1)
        if side >= 0:
            sg = 1.0 if side == 0 else -1.0
            qs = Delta if side == 0 else -Dl
            q0 = qs
            U0 = sg * v0    # normal velocity, > 0 approaching
            if U0 > 0.0:  # impact at t = 0 (Eq. 2)
                n_pre = 1
                if n_transient == 0:
                    imp_t.append(0.0)
                    imp_v.append(U0)
                    imp_k.append(side)
                v0 = sg * float(newton_restitution(U0, m.stops[side].law.R))
            elif U0 == 0.0:  # resting on the stop: held until released
                t0 = float(release_delay(0.0, F, Delta, Omega) if side == 0 else
                           release_delay_lower(0.0, F, Dl, Omega))
                held = t_samples < t0
                samples[held] = (qs, 0.0)
                if t0 > t_record:
                    status = "sticking"
                    message = f"held on the stop from the start until t = {t0:.6g}"
                if not t0 < t_end:
                    return Trajectory(Omega=Omega, samples=samples, samples_per_period=spp,
                                      impact_times=np.zeros(0), impact_velocities=np.zeros(0),
                                      impact_stops=np.zeros(0, np.int64) if two else None,
                                      n_impacts=0, q_min=qs, q_max=qs, status=status,
                                      message=message,
                                      final_state=np.array([qs, 0.0, 1.0 if side == 0 else -1.0]),
                                      extra=dict(nfev=0))
        y0, mode0 = self._to_internal(q0, v0)
        to_q = self._to_q()
        n_periods = max(n_transient + n_record, 1)
        run = integrate_piecewise(self._rhs(Omega), self._event(), self._jump(), to_q,
                                  y0, mode0, t0, T, n_transient, n_record, t_samples, samples,
                                  self.solver, self.rtol, self.atol, self.max_step,
                                  self.max_events_per_period * n_periods - n_pre,
                                  self.max_nfev_per_period, self._crossings())
        if run.status != "ok":
            # hand on the last state reached so that a continuation can go on
            q_f, v_f = to_q(run.y_end, run.mode_end)
            final = np.array([max(min(float(q_f), Delta), -Dl), float(v_f), 0.0])
            if not np.all(np.isfinite(final)):
                final = m.initial_state()
            return Trajectory(Omega=Omega, samples=samples, samples_per_period=spp,
                              impact_times=np.zeros(0), impact_velocities=np.zeros(0),
                              n_impacts=0, q_min=np.nan, q_max=np.nan, status="failed",
                              message=run.message, final_state=final,
                              extra=dict(nfev=run.nfev))
        it, iv = self._impacts_after(run, to_q, t_record, t_end)
        imp_t += [t - t_record for t in run.impact_times] + [t - t_record for t in it]
        imp_v += run.impact_velocities + list(iv)
        imp_k += run.impact_stops + [0] * len(it)
        order = np.argsort(imp_t, kind="stable")
        imp_t = np.asarray(imp_t, dtype=float)[order]
        imp_v = np.asarray(imp_v, dtype=float)[order]
        imp_k = np.asarray(imp_k, dtype=np.int64)[order]
        minima = []
        r_min, r_max = _refine_extremes(run.segments, to_q, t_record, t_end, minima)
        # per-period minima: the samples of each period and the refined minima inside it
        pmin = samples[:, 0].reshape(n_record, spp).min(axis=1) if n_s else np.zeros(0)
        for tm, qm in (minima if n_record else []):
            kp = min(max(int((tm - t_record) // T), 0), n_record - 1)
            pmin[kp] = min(pmin[kp], qm)
        q_min = float(min(np.min(samples[:, 0]), r_min)) if n_s else r_min
        q_max = float(max(np.max(samples[:, 0]), r_max)) if n_s else r_max
        if np.any(imp_k == 0):
            q_max = max(q_max, Delta)
        if np.any(imp_k == 1):
            q_min = min(q_min, -Dl)
        q_end, v_end = to_q(run.y_end, run.mode_end)
        return Trajectory(Omega=Omega, samples=samples, samples_per_period=spp,
                          impact_times=imp_t, impact_velocities=imp_v, n_impacts=int(imp_t.size),
                          impact_stops=imp_k if two else None,
                          n_impacts_lower=int(np.sum(imp_k == 1)) if two else 0,
                          q_min=q_min, q_max=q_max, period_min=pmin, status=status, message=message,
                          final_state=np.array([float(q_end), float(v_end), 0.0]),
                          extra=dict(nfev=run.nfev))


def _event_fn(g, direction):
    """Terminal ``solve_ivp`` event ``g(t, y) = 0`` crossed in ``direction``."""
    g.terminal = True
    g.direction = direction
    return g


class DirectSolver(_ScipyMethod):
    """Method ``direct``: Eq. 1 with an impact event, paper Sec. 3.1; with a compliant stop, the one
    direct solver of the modal system.

    Newton stops: ``y = (q, q')``; ``solve_ivp`` integrates paper Eq. 1 until the terminal event
    ``q - Delta = 0`` (rising), applies Eq. 2 through :func:`vibeam.models.impact.newton_restitution`
    and restarts, as MATLAB's ``ode23`` with ``'events'`` does in the paper (defaults: ``RK23``,
    ``rtol = 1e-4``, ``atol = 1e-8``, the paper's).  Parameters, errors and outputs as in
    :class:`_ScipyMethod`.

    A compliant stop (Kelvin-Voigt or hysteretic Hertz, on one or two stops, or beside a Newton
    stop): the oscillator as the one-mode modal system (:func:`vibeam.models.system.sdof_system`)
    on :class:`vibeam.models.core.direct.DirectIntegrator`, whose outputs are the event method's
    (contacts' rows, ``final_state`` ``(q, q', code)`` with code 1 / -1 in contact with the upper /
    lower stop); defaults ``DOP853``, ``rtol = 1e-11``, ``atol = 1e-15`` (the reference of the event
    kernels) and at most ``max_events_per_period = 200`` impacts and contact entries per period.
    ``max_nfev_per_period`` is the paper method's only.
    """

    name = "direct"
    two_sided = True

    #: defaults of the paper's method (Newton stops) and of the compliant reference
    PAPER = dict(solver="RK23", rtol=1e-4, atol=1e-8, max_events_per_period=20000)
    REFERENCE = dict(solver="DOP853", rtol=RTOL_COMPLIANT, atol=ATOL_COMPLIANT, max_events_per_period=200)

    def __init__(self, scene, solver: str | None = None, rtol: float | None = None, atol: float | None = None,
                 max_step=None, max_events_per_period: int | None = None, max_nfev_per_period: int = 50000):
        compliant = any(getattr(s.law, "kind", "") == "compliant" for s in scene.stops)
        given = dict(solver=solver, rtol=rtol, atol=atol, max_events_per_period=max_events_per_period)
        kw = {k: (self.REFERENCE if compliant else self.PAPER)[k] if v is None else v for k, v in given.items()}
        super().__init__(scene, kw["solver"], kw["rtol"], kw["atol"], max_step, kw["max_events_per_period"],
                         max_nfev_per_period)
        self._direct = None
        if compliant:
            self._direct = DirectIntegrator(EventIntegrator(scene), 1.0, self.solver,
                                            self.rtol, self.atol, self.max_events_per_period, max_step=self.max_step)
            self._laws = [s.law for s in scene.stops]

    def point(self, Omega: float, state0, n_transient: int, n_record: int,
              samples_per_period: int = 64) -> Trajectory:
        """One forcing frequency from ``state0`` (:meth:`_ScipyMethod.point`; with a compliant stop
        :meth:`vibeam.models.core.direct.DirectIntegrator.run` from ``(q, q', code)``, code 1 / -1 in
        contact with the upper / lower stop)."""
        if self._direct is None:
            return super().point(Omega, state0, n_transient, n_record, samples_per_period)
        m = self.one
        s0 = m.initial_state() if state0 is None else np.asarray(state0, dtype=float)
        if not np.all(np.isfinite(s0)):  # e.g. handed on from a failed point
            s0 = m.initial_state()
        return self._direct.run(float(Omega), s0, n_transient, n_record, samples_per_period, 1.0,
                                lambda k: self._laws[k])

    def _to_internal(self, q, v):
        return np.array([q, v]), 0.0

    def _rhs(self, Omega):
        m = self.one
        b2, F = 2.0 * m.beta, Omega * Omega * m.B

        def f(t, y):
            return np.array([y[1], F * math.sin(Omega * t) - b2 * y[1] - y[0]])

        return lambda mode: f

    def _event(self):
        m = self.one
        Delta = m.Delta
        ev = _event_fn(lambda t, y: y[0] - Delta, 1.0)
        if len(m.stops) > 1:
            # the lower stop's gap -q - Delta_lower, rising (vibeam.models.contact: normal -1)
            Dl = m.Delta_lower
            evs = [ev, _event_fn(lambda t, y: -y[0] - Dl, 1.0)]
            return lambda mode: evs
        return lambda mode: ev

    def _jump(self):
        m = self.one
        Delta, R = m.Delta, m.stops[0].law.R
        if len(m.stops) > 1:
            laws = [s.law for s in m.stops]
            offsets = (Delta, -m.Delta_lower)

            def jump2(t, y, mode, j):
                # Newton's law of stop j on its normal velocity U = s q' (s = +1, -1)
                sg = 1.0 if j == 0 else -1.0
                U = sg * float(y[1])
                Up = newton_restitution(U, laws[j].coefficient(U))
                return np.array([offsets[j], sg * Up]), mode, U

            return jump2

        def jump(t, y, mode):
            return np.array([Delta, newton_restitution(float(y[1]), R)]), mode, float(y[1])

        return jump

    def _to_q(self):
        return lambda Y, mode: (Y[0], Y[1])


class ZhuravlevSolver(_ScipyMethod):
    """Method ``zhuravlev``: the unfolded variable of paper Sec. 3.2.

    ``q = Delta - |z|`` (Eq. 4), ``q' = -z' sgn(z)`` (Eq. 5).  ``y = (z, z')``
    obeys Eq. 7, ``z'' + 2 beta z' + z = sgn(z) (Delta - Omega^2 B sin(Omega
    t))``, on one side ``sgn(z) = mode`` of the stop; the terminal event
    ``z = 0`` (crossed from that side) is an impact, after which the side
    flips and ``z'+ = R z'-`` (Eq. 8).  The jump is obtained by mapping
    ``z'-`` to ``q'-`` with Eq. 5, applying
    :func:`vibeam.models.impact.newton_restitution` and mapping back with the
    new side, so the impact law exists once.  The start is on the free side
    ``mode = -1`` (``z = q - Delta <= 0``, ``z' = q'``).  Parameters, errors
    and outputs as in :class:`_ScipyMethod`.
    """

    name = "zhuravlev"

    def _to_internal(self, q, v):
        return np.array([q - self.one.Delta, v]), -1.0

    def _rhs(self, Omega):
        m = self.one
        b2, F, Delta = 2.0 * m.beta, Omega * Omega * m.B, m.Delta
        cache = {}

        def make(mode):
            def f(t, y):
                return np.array([y[1], mode * (Delta - F * math.sin(Omega * t)) - b2 * y[1] - y[0]])
            return f

        def get(mode):
            if mode not in cache:
                cache[mode] = make(mode)
            return cache[mode]

        return get

    def _event(self):
        # leave the side sgn(z) = mode: z falls through 0 for mode +1, rises for -1
        evs = {1.0: _event_fn(lambda t, y: y[0], -1.0), -1.0: _event_fn(lambda t, y: y[0], 1.0)}
        return lambda mode: evs[mode]

    def _jump(self):
        R = self.one.stops[0].law.R

        def jump(t, y, mode):
            v_minus = -float(y[1]) * mode                 # Eq. 5 before the impact
            v_plus = newton_restitution(v_minus, R)       # Eq. 2
            new = -mode
            return np.array([0.0, -v_plus * new]), new, v_minus  # Eq. 5 after: z'+ = R z'-

        return jump

    def _to_q(self):
        Delta = self.one.Delta
        return lambda Y, mode: (Delta - np.abs(Y[0]), -Y[1] * mode)


class IvanovSolver(_ScipyMethod):
    """Method ``ivanov``: Ivanov's transformation, paper Sec. 3.3.

    ``q = Delta - |z|`` (Eq. 11), ``q' = -K_N s sgn(z)`` (Eq. 12) with
    ``K_N = 1 - K sgn(z s)`` and ``K = (1 - R) / (1 + R)`` (Eq. 13).
    ``y = (z, s)`` obeys Eqs. 14-15,

        z' = K_N s,   s' = -2 beta s + ((Delta - Omega^2 B sin(Omega t)) sgn(z) - z) / K_N,

    integrated over the whole run with no event: the impact loss is in the
    switch of ``K_N`` when ``z`` changes sign (``q'+ / q'- = -(1-K)/(1+K) =
    -R``).  ``sgn(0)`` is taken as ``-1`` (the free side), where the start
    lies (``z = q - Delta``).  Impacts are found after the run as sign changes
    of ``z`` between integrator steps, refined by ``brentq`` on the dense
    output; the pre-impact velocity is Eq. 12 on the side being left.  The
    right-hand side is discontinuous at ``z s = 0``, so the step-size control
    resolves every switch to the tolerance; tight tolerances are needed for
    accuracy.  ``K`` is ``(1 - R') / (1 + R')`` with ``R' =
    -newton_restitution(1, R)``, the one impact law.

    Raises
    ------
    ValueError
        In addition to :class:`_ScipyMethod`: if ``R <= 0`` (``K_N = 0`` on
        the quadrants ``z s > 0`` makes Eq. 15 singular).
    """

    name = "ivanov"

    def __init__(self, scene, solver: str = "RK23", rtol: float = 1e-4, atol: float = 1e-8,
                 max_step=None, max_events_per_period: int = 20000,
                 max_nfev_per_period: int = 50000):
        super().__init__(scene, solver, rtol, atol, max_step, max_events_per_period,
                         max_nfev_per_period)
        R = self.one.stops[0].law.R
        r = -float(newton_restitution(1.0, R))
        if not r > 0.0:
            raise ValueError(f"method 'ivanov' needs R > 0 (Eq. 15 divides by K_N = 0); got R={R!r}")
        self.K = (1.0 - r) / (1.0 + r)

    def _to_internal(self, q, v):
        K = self.K
        return np.array([q - self.one.Delta, v / (1.0 + K * (1.0 if v > 0.0 else -1.0))]), 0.0

    def _rhs(self, Omega):
        m = self.one
        b2, F, Delta, K = 2.0 * m.beta, Omega * Omega * m.B, m.Delta, self.K

        def f(t, y):
            z, s = y[0], y[1]
            sz = 1.0 if z > 0.0 else -1.0
            kn = 1.0 - K * (sz if s > 0.0 else (-sz if s < 0.0 else 0.0))
            return np.array([kn * s, -b2 * s + ((Delta - F * math.sin(Omega * t)) * sz - z) / kn])

        return lambda mode: f

    def _to_q(self):
        Delta, K = self.one.Delta, self.K

        def to_q(Y, mode):
            z, s = Y[0], Y[1]
            sz = np.where(z > 0.0, 1.0, -1.0)
            kn = 1.0 - K * sz * np.sign(s)
            return Delta - np.abs(z), -kn * s * sz

        return to_q

    def _crossings(self):
        def count(ts, Y):
            side = Y[0] > 0.0
            return int(np.count_nonzero(side[:-1] != side[1:]))
        return count

    def _impacts_after(self, run, to_q, t_lo, t_hi):
        K = self.K
        times, vels = [], []
        for sol, mode in run.segments:
            ts = np.asarray(sol.ts)
            ts = ts[(ts >= t_lo) & (ts <= t_hi)]
            if ts.shape[0] < 2:
                continue
            z = sol(ts)[0]
            side = np.where(z > 0.0, 1.0, -1.0)
            for i in np.nonzero(side[:-1] != side[1:])[0]:
                try:
                    tr = brentq(lambda tt: sol(tt)[0], ts[i], ts[i + 1], xtol=1e-14)
                except ValueError:
                    tr = ts[i + 1]
                s = float(sol(tr)[1])
                sz = side[i]  # side being left
                kn = 1.0 - K * sz * np.sign(s)
                times.append(tr)
                vels.append(float(-kn * s * sz))
        return times, vels
