"""Pointwise mapping of the SDOF oscillator between two stops (paper Sec. 4.2 extended to Sec. 8).

A two-sided scene has the upper stop at ``q = d_0 = Delta`` (normal ``s_0 = +1``) and the lower
one at ``q = d_1 = -Delta_lower`` (``s_1 = -1``), each with Newton's law and its own ``R_k``
(paper Eq. 2).  An impact is ``(phi, v, k)``: forcing phase, normal pre-impact speed ``v =
s_k q'(t-) > 0`` and the stop hit; after it ``q = d_k``, ``q' = -s_k R_k v``.  The impact map
(:func:`next_impact`) follows the closed-form flight (Eq. 28, :mod:`vibeam.models.sdof_flow`)
and *chooses the stop*: the next impact is the first crossing of either ``q = d_0`` upwards or
``q = d_1`` downwards (sampled grid, sign changes refined with ``brentq``, interior extrema of
``q`` located exactly so that a crossing hidden between samples is not missed).

A period-n orbit with ``m`` impacts on the stops ``k_0 .. k_{m-1}`` (any mix) is a zero of
the multiple-shooting residual in the unknowns ``(phi_0 .. phi_{m-1}, v_0 .. v_{m-1})`` (phases
unwrapped, ``phi_m = phi_0 + 2 pi n``, flight times ``tau_j = (phi_{j+1} - phi_j) / Omega``)::

    r_j = ( q_j(tau_j) - d_{k_{j+1}},  s_{k_{j+1}} q_j'(tau_j) - v_{j+1} )

solved by Newton's method with the analytic Jacobian (the flow's sensitivities to the start
phase and speed and the end-time derivative ``(q', q'')``).  It is admissible when every flight
ends at its first impact: :func:`next_impact` from each impact returns the next one of the
orbit (same stop, same time to 1e-9 of the period).

Floquet multipliers: eigenvalues of the monodromy ``M = S_m Phi(tau_{m-1}) ... S_1 Phi(tau_0)``
in ``(q, q')`` (homogeneous transition ``Phi`` and the saltation matrix ``S`` of each impact,
:func:`vibeam.models.impact.saltation_matrix` with the signed pre-impact velocity); the
composed impact-map Jacobian ``J_{m-1} ... J_0`` (:func:`map_jacobian`) has the same
eigenvalues (reported as ``map_eigenvalues``).  ``det M = prod R_k^2 exp(-2 beta n T)``.

The orbits with one impact on the upper stop per ``n`` periods are those of the one-stop
mapping (:mod:`vibeam.models.sdof_mapping`, which :class:`~vibeam.models.sdof_mapping.MappingSolver`
keeps using for them, so that a lower stop that is never reached changes nothing); the paper's
determinant/trace formulas (Eqs. 29-37) assume such orbits and are not evaluated for the others.
All quantities are nondimensional.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from .impact import saltation_matrix
from .sdof_flow import flow_matrix, particular_coefficients, propagate, sample_flow

TWO_PI = 2.0 * math.pi
SIGN = (1.0, -1.0)


class Flights:
    """Closed-form flights between the two stops of one model at one ``Omega``.

    Attributes
    ----------
    d : tuple of float
        Stop positions ``(Delta, -Delta_lower)``.
    R : tuple of float
        Restitution of each stop.
    """

    def __init__(self, model, Omega):
        self.beta = float(model.beta)
        self.Omega = float(Omega)
        self.F = self.Omega ** 2 * float(model.B)
        self.a, self.b = particular_coefficients(self.beta, self.F, self.Omega)
        self.T = TWO_PI / self.Omega
        self.d = (float(model.Delta), -float(model.Delta_lower))
        Rl = model.stops()[1].law.R       # the lower stop's law: its own, or the upper one's
        self.R = (float(model.R), float(Rl))

    def start(self, k, v):
        """Post-impact ``(q, q')`` of an impact on stop ``k`` with normal speed ``v``."""
        return self.d[k], -SIGN[k] * self.R[k] * v

    def state(self, s, phi0, k, v, ref):
        """``(q - ref, q', q'')`` at local time ``s`` of the flight after the impact ``(phi0, v, k)``."""
        q0, v0 = self.start(k, v)
        g, vq, a2, _, _ = propagate(float(s), float(phi0), q0, v0, self.beta, self.a, self.b, self.Omega, ref)
        return g, vq, a2

    def sample(self, s, phi0, k, v, ref):
        q0, v0 = self.start(k, v)
        return sample_flow(np.asarray(s, dtype=float), float(phi0), q0, v0, self.beta, self.a, self.b,
                       self.Omega, ref)

    def dP(self, phi):
        """``d(q_p, q_p') / d phi`` of the particular solution."""
        return np.array([self.a * math.cos(phi) - self.b * math.sin(phi),
                         -self.Omega * (self.a * math.sin(phi) + self.b * math.cos(phi))])

    def sensitivities(self, s, phi0, k):
        """``d(q, q')(s) / d(phi0, v)`` at fixed ``s`` (shape (2, 2)) and ``Phi(s)``."""
        Phi = flow_matrix(s, self.beta)
        d_phi = -Phi @ self.dP(phi0) + self.dP(phi0 + self.Omega * s)
        d_v = Phi @ np.array([0.0, -SIGN[k] * self.R[k]])
        return np.column_stack([d_phi, d_v]), Phi


def _first_negative(f, lo, hi):
    """A point in (lo, hi] just after ``lo`` where ``f < 0`` (leaving the stop)."""
    h = (hi - lo) * 1e-6
    while h < hi - lo:
        if f(lo + h) < 0.0:
            return lo + h
        h *= 4.0
    return None


def next_impact(model, Omega, phi0, k0, v, max_periods=50.0, samples_per_period=256):
    """The impact map between two stops: the first impact after ``(phi0, v, k0)``.

    Parameters
    ----------
    model : SDOF
        A two-sided oscillator (``Delta_lower`` set).
    Omega : float
        Forcing frequency.
    phi0 : float
        Forcing phase of the impact (rad).
    k0 : int
        Its stop (0 upper, 1 lower).
    v : float
        Its normal pre-impact speed (``> 0``).
    max_periods : float, optional
        Longest flight searched, in forcing periods.
    samples_per_period : int, optional
        Grid density of the bracketing search.

    Returns
    -------
    tuple or None
        ``(tau, phi1, v1, k1, a1)``: flight time, phase of the next impact (mod 2 pi), its
        normal pre-impact speed, its stop and the pre-impact acceleration ``q''``; None when no
        impact occurs within ``max_periods``.
    """
    fl = Flights(model, Omega)
    m = max(int(math.ceil(max_periods * samples_per_period)), 2)
    s = np.linspace(0.0, max_periods * fl.T, m + 1)
    h = []       # h_k = s_k (q - d_k) <= 0 while free
    for k in (0, 1):
        g, vq, _ = fl.sample(s, phi0, k0, v, fl.d[k])
        h.append(SIGN[k] * g)
    if SIGN[k0] * vq[0] >= 0.0:
        return None   # not a departure from the stop
    fh = [lambda x, k=k: SIGN[k] * fl.state(x, phi0, k0, v, fl.d[k])[0] for k in (0, 1)]
    fv = lambda x: fl.state(x, phi0, k0, v, 0.0)[1]
    for i in range(m):
        hits = []
        for k in (0, 1):
            lo, hi = s[i], s[i + 1]
            if i == 0 and k == k0:
                lo = _first_negative(fh[k], lo, hi)
                if lo is None:
                    return None
            if h[k][i + 1] >= 0.0:
                hits.append((brentq(fh[k], lo, hi, xtol=1e-15, rtol=1e-15), k))
            elif SIGN[k] * vq[i] > 0.0 >= SIGN[k] * vq[i + 1]:   # interior extremum towards stop k
                se = brentq(fv, s[i], hi, xtol=1e-15, rtol=1e-15)
                if fh[k](se) >= 0.0 and se > lo:
                    hits.append((brentq(fh[k], lo, se, xtol=1e-15, rtol=1e-15), k))
        if hits:
            t, k1 = min(hits)
            _, v1, a1 = fl.state(t, phi0, k0, v, fl.d[k1])
            return t, (phi0 + fl.Omega * t) % TWO_PI, SIGN[k1] * v1, k1, a1
    return None


def map_jacobian(fl, phi0, k0, v, tau, k1):
    """Jacobian ``d(phi1, v1) / d(phi0, v0)`` of the impact map for the flight ``(phi0, v, k0)``
    to stop ``k1`` after ``tau`` (``d tau = -dq / q'(tau)`` from ``q(tau) = d_{k1}``), (2, 2)."""
    J, _ = fl.sensitivities(tau, phi0, k0)
    _, v1, a1 = fl.state(tau, phi0, k0, v, fl.d[k1])
    dtau = -J[0] / v1
    return np.array([[1.0 + fl.Omega * dtau[0], fl.Omega * dtau[1]],
                     SIGN[k1] * (J[1] + a1 * dtau)])


def residual(fl, x, stops, n, jac=True):
    """Multiple-shooting residual (2m,) of the orbit ``x = (phi_0..phi_{m-1}, v_0..v_{m-1})`` with
    impacts on ``stops`` over ``n`` forcing periods, and its Jacobian (2m, 2m)."""
    m = len(stops)
    phi, v = x[:m], x[m:]
    r = np.zeros(2 * m)
    J = np.zeros((2 * m, 2 * m)) if jac else None
    for j in range(m):
        j1 = (j + 1) % m
        phi1 = phi[j1] + (TWO_PI * n if j1 == 0 else 0.0)
        tau = (phi1 - phi[j]) / fl.Omega
        k, k1 = stops[j], stops[j1]
        g, vq, a2 = fl.state(tau, phi[j], k, v[j], fl.d[k1])
        r[2 * j] = g
        r[2 * j + 1] = SIGN[k1] * vq - v[j1]
        if jac:
            S, _ = fl.sensitivities(tau, phi[j], k)
            f = np.array([vq, a2])
            dphi0 = S[:, 0] - f / fl.Omega
            dphi1 = f / fl.Omega
            w = np.array([1.0, SIGN[k1]])
            J[2 * j:2 * j + 2, j] += w * dphi0
            J[2 * j:2 * j + 2, j1] += w * dphi1
            J[2 * j:2 * j + 2, m + j] += w * S[:, 1]
            J[2 * j + 1, m + j1] -= 1.0
    return r, J


def newton_orbit(fl, guess, stops, n, tol=1e-13, max_iter=50):
    """Newton's method (damped) on :func:`residual` from ``guess``; the orbit or None."""
    x = np.array(guess, dtype=float)
    m = len(stops)
    r, J = residual(fl, x, stops, n)
    for _ in range(max_iter):
        scale = max(np.max(np.abs(x[m:])), 1e-300)
        if np.max(np.abs(r)) <= tol * scale:
            return x
        try:
            dx = np.linalg.solve(J, -r)
        except np.linalg.LinAlgError:
            return None
        lam, nr = 1.0, np.max(np.abs(r))
        while True:
            xn = x + lam * dx
            rn, Jn = residual(fl, xn, stops, n)
            if np.max(np.abs(rn)) < nr or lam < 2e-4:
                break
            lam *= 0.5
        x, r, J = xn, rn, Jn
        if not np.all(np.isfinite(x)):
            return None
    return x if np.max(np.abs(r)) <= 1e3 * tol * max(np.max(np.abs(x[m:])), 1e-300) else None


def analyse_orbit(model, Omega, x, stops, n, samples_per_period=256):
    """Admissibility, extremes and stability of the orbit ``x`` (from :func:`newton_orbit`).

    Returns
    -------
    dict or str
        The reason as a string when the orbit is not admissible; otherwise ``q_min``, ``q_max``
        (exact: interior extrema located with ``brentq``), ``multipliers`` (complex (2,), of the
        monodromy), ``map_eigenvalues`` (of the composed impact-map Jacobian), ``monodromy``,
        ``map_jacobian`` (2, 2), ``stable``.
    """
    fl = Flights(model, Omega)
    m = len(stops)
    phi, v = x[:m], x[m:]
    if not np.all(v > 0.0):
        return f"a pre-impact speed is not positive ({np.min(v):.3e})"
    M = np.eye(2)
    Jm = np.eye(2)
    q_lo, q_hi = min(fl.d[k] for k in stops), max(fl.d[k] for k in stops)
    for j in range(m):
        j1 = (j + 1) % m
        tau = ((phi[j1] + (TWO_PI * n if j1 == 0 else 0.0)) - phi[j]) / fl.Omega
        if not tau > 0.0:
            return "the impacts are not in time order"
        k, k1 = stops[j], stops[j1]
        nxt = next_impact(model, Omega, phi[j] % TWO_PI, k, v[j], max_periods=tau / fl.T * 1.01 + 0.01,
                          samples_per_period=samples_per_period)
        if nxt is None or nxt[3] != k1 or abs(nxt[0] - tau) > 1e-9 * fl.T:
            where = "no impact" if nxt is None else f"stop {nxt[3]} after {nxt[0] / fl.T:.6g} periods"
            return (f"flight {j} of the orbit is not its first impact ({where}; the orbit: stop {k1} after "
                    f"{tau / fl.T:.6g} periods): grazing or another sequence")
        # exact extremes on the flight
        ng = max(int(math.ceil(tau / fl.T * samples_per_period)), 2)
        s = np.linspace(0.0, tau, ng + 1)
        _, vq, _ = fl.sample(s, phi[j], k, v[j], 0.0)
        fv = lambda t, j=j, k=k: fl.state(t, phi[j], k, v[j], 0.0)[1]
        for i in range(ng):
            if (vq[i] < 0.0 <= vq[i + 1]) or (vq[i] > 0.0 >= vq[i + 1]):
                se = brentq(fv, s[i], s[i + 1], xtol=1e-15, rtol=1e-15)
                qe = fl.d[k] + fl.state(se, phi[j], k, v[j], fl.d[k])[0]
                q_lo, q_hi = min(q_lo, qe), max(q_hi, qe)
        _, vq1, a1 = fl.state(tau, phi[j], k, v[j], fl.d[k1])
        S = saltation_matrix(fl.R[k1], vq1, a1, fl.beta)
        M = S @ flow_matrix(tau, fl.beta) @ M
        Jm = map_jacobian(fl, phi[j], k, v[j], tau, k1) @ Jm
    mult = np.linalg.eigvals(M).astype(complex)
    mult = mult[np.argsort(-np.abs(mult))]
    jev = np.linalg.eigvals(Jm).astype(complex)
    jev = jev[np.argsort(-np.abs(jev))]
    return dict(q_min=q_lo, q_max=q_hi, multipliers=mult, map_eigenvalues=jev, monodromy=M,
                map_jacobian=Jm, stable=bool(np.max(np.abs(mult)) < 1.0),
                det_true=float(np.linalg.det(M)), tr_true=float(np.trace(M)))


def event_sequence(model, Omega, n, n_transient):
    """The impacts ``(phi, v, k)`` of the last ``n`` periods of a short event run (a guess), flat
    ``(3m,)``; None without impacts or when the run sticks, chatters or fails."""
    from .sdof import EventSolver

    tr = EventSolver(model).point(float(Omega), None, int(n_transient), 2 * n + 2, 8)
    k = min(tr.n_impacts, tr.impact_times.shape[0])
    if k == 0 or tr.status != "ok" or k != tr.n_impacts:
        return None
    T = TWO_PI / Omega
    t0 = (n + 2) * T
    sel = tr.impact_times >= t0 - 1e-12 * T
    if not np.any(sel):
        return None
    stops = tr.impact_stops[sel] if tr.impact_stops is not None else np.zeros(int(np.sum(sel)), int)
    return np.column_stack([Omega * tr.impact_times[sel], tr.impact_velocities[sel], stops]).ravel()


def orbit_outputs(model, Omega, x, stops, n, an):
    """Per-point outputs of an admissible orbit (the sweep's keys, both stops)."""
    m = len(stops)
    v = x[m:]
    st = np.asarray(stops)
    up, lo = v[st == 0], v[st == 1]
    nan = float("nan")
    phis = x[:m] - TWO_PI * math.floor(x[0] / TWO_PI)
    phi0 = float(phis[0])
    return dict(amplitude=float(model.Delta) - an["q_min"], q_min=an["q_min"], q_max=an["q_max"], period=int(n),
                impacts_per_period=up.size / n, impact_velocity=float(np.mean(up)) if up.size else nan,
                impacts_per_period_lower=lo.size / n, impact_velocity_lower=float(np.mean(lo)) if lo.size else nan,
                impact_phase=phi0,
                final_state=np.column_stack([phis, v, st]).ravel(),
                stable=an["stable"], multipliers=an["multipliers"], map_eigenvalues=an["map_eigenvalues"],
                det_true=an["det_true"], tr_true=an["tr_true"],
                # the paper's formulas (Eqs. 29-37) assume one impact on one stop per orbit
                stable_full=False, stable_simplified=False, stable_paper=False,
                disagree_full=False, disagree_simplified=False,
                det_full=nan, tr_full=nan, det_simplified=nan, tr_simplified=nan,
                status="ok", message="")


def solve_sequence(model, Omega, seq, n, tol=1e-13, samples_per_period=256):
    """The period-n orbit near the flat guess ``seq = (phi_j, v_j, k_j)`` (3m,): outputs or a reason."""
    seq = np.asarray(seq, float).reshape(-1, 3)
    stops = tuple(int(k) for k in seq[:, 2])
    phi = seq[:, 0].copy()            # consecutive impacts of one orbit: phases increase
    for j in range(1, phi.size):
        while phi[j] <= phi[j - 1]:
            phi[j] += TWO_PI
    fl = Flights(model, Omega)
    x = newton_orbit(fl, np.concatenate([phi, seq[:, 1]]), stops, n, tol)
    if x is None:
        return f"Newton did not converge for the impact sequence {stops} (m = {len(stops)} in {n} periods)"
    p = minimal_period(x, stops, n)
    if p < n:
        return f"the orbit found has period {p}, not n = {n} (impact sequence {stops[:len(stops) * p // n]})"
    an = analyse_orbit(model, Omega, x, stops, n, samples_per_period)
    if isinstance(an, str):
        return an
    return orbit_outputs(model, Omega, x, stops, n, an)


def minimal_period(x, stops, n, rtol=1e-9):
    """The least ``p`` dividing ``n`` for which the orbit's impacts repeat after ``p`` periods
    (same stops, phases ``+ 2 pi p``, speeds to ``rtol``)."""
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


def point_two_sided(solver, Omega, state0):
    """:meth:`vibeam.models.sdof_mapping.MappingSolver.point` for a two-sided model.

    Guesses, in order: the previous point's orbit (``state0``: ``(phi, v)`` of a one-impact
    orbit or the flat ``(phi_j, v_j, k_j)`` of a sequence), the impacts of the last ``n``
    periods of a short event run, then averaging (``n = 1``).  A guess without lower impacts
    goes through the one-stop mapping from its last impact (one impact per ``n`` periods, as
    without the lower stop; its orbit must also stay above the lower stop): a lower stop that
    is never reached leaves every output as it was.  A sequence with lower impacts goes through
    :func:`solve_sequence` (any mix, minimal period ``n``).
    """
    m = solver.model
    n = solver.n
    Omega = float(Omega)
    d1 = -float(m.Delta_lower)
    reasons = []

    def guesses():
        s0 = state0.get("final_state") if isinstance(state0, dict) else state0
        if s0 is not None:
            s = np.asarray(s0, dtype=float).ravel()
            if np.all(np.isfinite(s)) and s.shape == (2,) and s[1] > 0:
                yield s
            elif np.all(np.isfinite(s)) and s.size % 3 == 0 and s.size and np.any(s[2::3] == 1):
                yield s
        seq = event_sequence(m, Omega, n, solver.guess_periods)
        if seq is not None:
            if np.all(seq[2::3] == 0):
                # the upper stop only: the one-stop mapping's one-impact orbit, from its last impact
                # (as without the lower stop; several impacts on one stop are not mapped there)
                yield np.array([seq[-3] % TWO_PI, seq[-2]])
            else:
                yield seq
        if n == 1:
            from .sdof_averaging import averaging_guess
            x = averaging_guess(m, Omega)
            if x is not None:
                yield x

    for g in guesses():
        if g.shape == (2,):
            out = solver._one_impact(Omega, g)
            if isinstance(out, dict) and not out["q_min"] > d1:
                out = (f"the one-impact orbit crosses the lower stop (q_min = {out['q_min']:.6g} <= "
                       f"-Delta_lower = {d1:.6g})")
            if isinstance(out, dict):
                out.update(impacts_per_period_lower=0.0, impact_velocity_lower=float("nan"))
        else:
            out = solve_sequence(m, Omega, g, n, solver.tol, solver.samples)
        if isinstance(out, dict):
            return out
        reasons.append(out)
    out = solver._failed(reasons)
    out.update(impacts_per_period_lower=float("nan"), impact_velocity_lower=float("nan"))
    return out
