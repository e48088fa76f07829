"""Pointwise (impact) mapping of the SDOF impact oscillator (paper Sec. 4.2, Eqs. 28-37).

The impact map takes the state at one impact, ``(phi_i, v_i)`` = forcing phase
``Omega t_i (mod 2 pi)`` and pre-impact velocity ``v_i = q'(t_i-) > 0``, to the
next one.  After the impact the state is ``q = Delta``, ``q' = -R v_i``
(:func:`~vibeam.models.impact.newton_restitution`, Eq. 2); the free flight is
the closed-form flow of :mod:`vibeam.models.sdof_flow` (Eq. 28) and the next
impact is the first upward crossing of ``q = Delta``.

Period-n orbits with one impact per ``n`` forcing periods (the assumption of
Eqs. 33-34, flight time ``tau = n T``, ``T = 2 pi / Omega``) are found by
Newton iteration on the closed form with the analytic Jacobian.

Stability is computed three ways:

* Floquet multipliers: eigenvalues of the monodromy matrix
  ``M = S Phi(n T)`` in ``(q, q')``, with ``Phi`` the homogeneous transition
  matrix and ``S`` the saltation matrix of the impact (see
  :func:`saltation_matrix`).  ``det M = R^2 exp(-2 beta n T)``.
* The exact Jacobian of the 2D impact map (:func:`impact_map_jacobian`),
  whose eigenvalues equal the multipliers.
* The paper's determinant/trace formulas, full (Eqs. 29-32) and simplified
  (Eqs. 35-37), evaluated exactly as printed (:func:`paper_det_trace`).

All quantities are nondimensional.  ``F = Omega^2 B`` plays the role of the
paper's ``gamma V Omega^2``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.optimize import brentq

from .impact import newton_restitution, saltation_matrix
from .sdof_averaging import averaging_guess
from .sdof_flow import flow_matrix, particular_coefficients, propagate, sample_flow, undamped_resonance

TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------
# flow helpers (all on top of sdof_flow.propagate)
# ----------------------------------------------------------------------------

class _Flow:
    """Closed-form free flight from a post-impact state of one model at one ``Omega``."""

    def __init__(self, model, Omega):
        self.beta = float(model.beta)
        self.R = float(model.R)
        self.Delta = float(model.Delta)
        self.Omega = float(Omega)
        self.F = self.Omega**2 * float(model.B)
        self.a, self.b = particular_coefficients(self.beta, self.F, self.Omega)
        self.T = TWO_PI / self.Omega

    def state(self, s, phi0, v_minus):
        """``(g, q', q'')`` at local time ``s`` after the impact at phase ``phi0`` with ``v_minus``."""
        g, v, a2, _, _ = propagate(float(s), float(phi0), self.Delta,
                                   newton_restitution(float(v_minus), self.R),
                                   self.beta, self.a, self.b, self.Omega, self.Delta)
        return g, v, a2

    def sample(self, s, phi0, v_minus):
        return sample_flow(np.asarray(s, dtype=float), float(phi0), self.Delta,
                       newton_restitution(float(v_minus), self.R),
                       self.beta, self.a, self.b, self.Omega, self.Delta)

    def P(self, phi):
        """Particular solution ``(q_p, q_p')`` at forcing phase ``phi``."""
        return np.array([self.a * math.sin(phi) + self.b * math.cos(phi),
                         self.Omega * (self.a * math.cos(phi) - self.b * math.sin(phi))])

    def dP(self, phi):
        """``d(q_p, q_p')/d phi``."""
        return np.array([self.a * math.cos(phi) - self.b * math.sin(phi),
                         -self.Omega * (self.a * math.sin(phi) + self.b * math.cos(phi))])

    def sensitivities(self, s, phi0, v_minus):
        """``d(q, q')(s) / d(phi0, v_minus)`` at fixed ``s``, shape (2, 2)."""
        Phi = flow_matrix(s, self.beta)
        d_phi = -Phi @ self.dP(phi0) + self.dP(phi0 + self.Omega * s)
        d_v = Phi @ np.array([0.0, -self.R])
        return np.column_stack([d_phi, d_v])


def _extrema(flow, phi0, v_minus, s_end, samples, kind):
    """Local times of the interior local maxima (kind 'max') or minima ('min') of ``q`` on (0, s_end)."""
    s = np.linspace(0.0, s_end, samples + 1)
    g, v, _ = flow.sample(s, phi0, v_minus)
    out = []
    for i in range(samples):
        if kind == "max" and v[i] > 0.0 >= v[i + 1]:
            out.append(brentq(lambda x: flow.state(x, phi0, v_minus)[1], s[i], s[i + 1], xtol=1e-15, rtol=1e-15))
        elif kind == "min" and v[i] < 0.0 <= v[i + 1]:
            out.append(brentq(lambda x: flow.state(x, phi0, v_minus)[1], s[i], s[i + 1], xtol=1e-15, rtol=1e-15))
    return s, g, v, out


def next_impact(model, Omega, phi0, v_minus, max_periods=50.0, samples_per_period=256):
    """Next impact after the impact ``(phi0, v_minus)``: one application of the impact map.

    The flight is sampled on a uniform grid (``samples_per_period`` per forcing
    period); a sign change of ``q - Delta`` is refined with ``brentq``, and a
    crossing hidden between two samples is caught by locating each interior
    maximum of ``q`` (a sign change of ``q'``) exactly and testing it against
    the stop.

    Parameters
    ----------
    model : SDOF
        The oscillator.
    Omega : float
        Forcing frequency (nondimensional).
    phi0 : float
        Forcing phase of the impact (rad).
    v_minus : float
        Pre-impact velocity of that impact (``> 0``).
    max_periods : float, optional
        Longest flight searched, in forcing periods.
    samples_per_period : int, optional
        Grid density of the bracketing search.

    Returns
    -------
    tuple or None
        ``(tau, phi1, v1, a1)``: flight time, forcing phase of the next impact
        (mod 2 pi), its pre-impact velocity and pre-impact acceleration
        ``q''``; None if no impact occurs within ``max_periods``.
    """
    flow = _Flow(model, Omega)
    m = max(int(math.ceil(max_periods * samples_per_period)), 2)
    s = np.linspace(0.0, max_periods * flow.T, m + 1)
    g, v, _ = flow.sample(s, phi0, v_minus)
    fg = lambda x: flow.state(x, phi0, v_minus)[0]
    fv = lambda x: flow.state(x, phi0, v_minus)[1]
    if v[0] >= 0.0:
        return None  # v+ = -R v- >= 0: not a departure from the stop
    for i in range(m):
        lo, hi = s[i], s[i + 1]
        if i == 0:
            lo = _first_negative(fg, lo, hi)  # g(0) = 0 exactly: step off the stop
            if lo is None:
                return None
        if g[i + 1] >= 0.0:
            t = brentq(fg, lo, hi, xtol=1e-15, rtol=1e-15)
            break
        if v[i] > 0.0 >= v[i + 1]:  # interior maximum of q in (lo, hi)
            sm = brentq(fv, s[i], hi, xtol=1e-15, rtol=1e-15)
            if fg(sm) >= 0.0:
                t = brentq(fg, lo, sm, xtol=1e-15, rtol=1e-15)
                break
    else:
        return None
    gt, vt, at = flow.state(t, phi0, v_minus)
    return t, (phi0 + flow.Omega * t) % TWO_PI, vt, at


def _first_negative(f, lo, hi):
    """A point in (lo, hi] just after ``lo`` where ``f < 0`` (leaving the stop)."""
    h = (hi - lo) * 1e-6
    while h < hi - lo:
        if f(lo + h) < 0.0:
            return lo + h
        h *= 4.0
    return None


def impact_map(model, Omega, phi0, v_minus, **kw):
    """The 2D impact map ``(phi_i, v_i) -> (phi_{i+1}, v_{i+1})`` (Shaw & Holmes; paper Sec. 4.2).

    Returns ``(phi1, v1)`` or None when no further impact occurs; see
    :func:`next_impact` for the parameters.
    """
    r = next_impact(model, Omega, phi0, v_minus, **kw)
    return None if r is None else (r[1], r[2])


def impact_map_jacobian(model, Omega, phi0, v_minus, tau):
    """Exact Jacobian of the impact map at ``(phi0, v_minus)`` with flight time ``tau``.

    With ``(q, q')(s) = Phi(s) ((Delta, -R v) - P(phi)) + P(phi + Omega s)``
    and the flight time defined implicitly by ``q(tau) = Delta``,
    ``d tau = -dq / q'(tau)``, so that::

        d phi1 / d(phi, v) = (1, 0) + Omega d tau / d(phi, v)
        d v1   / d(phi, v) = d q'/d(phi, v) + q''(tau-) d tau / d(phi, v)

    Parameters
    ----------
    model : SDOF
    Omega : float
    phi0 : float
        Forcing phase of the starting impact (rad).
    v_minus : float
        Its pre-impact velocity.
    tau : float
        Flight time to the next impact (from :func:`next_impact` or ``n T``
        at a period-n fixed point).

    Returns
    -------
    ndarray, shape (2, 2)
        ``d(phi1, v1) / d(phi0, v0)``.
    """
    flow = _Flow(model, Omega)
    J = flow.sensitivities(tau, phi0, v_minus)
    _, v1, a1 = flow.state(tau, phi0, v_minus)
    dtau = -J[0] / v1
    return np.array([[1.0 + flow.Omega * dtau[0], flow.Omega * dtau[1]],
                     J[1] + a1 * dtau])


def monodromy(model, Omega, phi0, v_minus, tau):
    """Monodromy ``S Phi(tau)`` over one flight, from just after one impact to just after the next.

    For a period-n one-impact orbit (``tau = n T``) its eigenvalues are the
    Floquet multipliers; shape (2, 2).
    """
    flow = _Flow(model, Omega)
    _, v1, a1 = flow.state(tau, phi0, v_minus)
    return saltation_matrix(flow.R, v1, a1, flow.beta) @ flow_matrix(tau, flow.beta)


def stable_from_det_trace(det, tr):
    """Schur-Cohn (Jury) test of a 2x2 map: both eigenvalues inside the unit circle.

    ``|det| < 1`` and ``|tr| < 1 + det``.  Vectorised.
    """
    det = np.asarray(det, float)
    tr = np.asarray(tr, float)
    return (np.abs(det) < 1.0) & (np.abs(tr) < 1.0 + det)


def paper_det_trace(form, beta, F, R, Delta, Omega, phi_prev, v_prev_minus, v_minus, v_next_minus, tau, n=1):
    """Determinant and trace of the impact-map Jacobian as printed in the paper.

    ``form="full"``: Eqs. 29-32 with ``q'+(i-1) = -R v_prev_minus``,
    ``q'-(i) = v_minus``, ``q'-(i+1) = v_next_minus`` (the printed trace has
    ``q'-(i+1)`` in its denominator), ``t+(i-1)`` at forcing phase
    ``phi_prev`` and flight time ``tau`` (Eq. 31)::

        det = -R q'+(i-1) / q'-(i) exp(-2 beta tau)
        tr  = -exp(-beta tau) / (wD q'-(i+1)) ((N + R beta q'-(i)) sin(wD tau)
              + wD (q'+(i-1) - R q'-(i)) cos(wD tau))
        N   = F sin(phi_prev) - beta q'+(i-1) - Delta

    ``form="simplified"``: Eqs. 35-37 (period ``n``, ``tau = n T``)::

        det = R^2 exp(-beta n T)        # as printed; a damped flow gives exp(-2 beta n T)
        tr  = exp(-beta n T) / (wD v) ((R beta v + N) sin(wD n T) - 2 wD R v cos(wD n T))
        N   = F sin(phi) + R beta v - Delta

    Findings (see ``tests/test_mapping.py``): at a fixed point Eq. 30 equals
    minus Eq. 36 (sign-symmetric Jury test, so the verdicts agree), and Eq. 36
    equals ``tr(S' Phi(nT))`` with ``S' = [[-R, 0], [a+ / v-, -R]]``, i.e. the
    saltation term ``R a- / v-`` is missing (true: ``(a+ + R a-) / v-``, see
    :func:`saltation_matrix`).  Use :func:`fixed_point_analysis` for the
    correct multipliers.

    Parameters
    ----------
    form : {"full", "simplified"}
    beta, F, R, Delta, Omega : float
        Damping ratio, forcing amplitude ``Omega^2 B`` (paper ``gamma V Omega^2``),
        restitution, gap, frequency.
    phi_prev : float
        Forcing phase of impact ``i-1`` (the fixed-point phase for period-n).
    v_prev_minus, v_minus, v_next_minus : float
        Pre-impact velocities of impacts ``i-1``, ``i``, ``i+1`` (all equal at a
        fixed point; only ``v_minus`` is used by the simplified form).
    tau : float
        Flight time (full form).
    n : int
        Period (simplified form).

    Returns
    -------
    det, tr : float

    Raises
    ------
    ValueError
        For an unknown ``form``.
    """
    wd = math.sqrt(1.0 - beta * beta)
    if form == "full":
        vp = -R * v_prev_minus
        det = -R * vp / v_minus * math.exp(-2.0 * beta * tau)
        N = F * math.sin(phi_prev) - beta * vp - Delta
        tr = -math.exp(-beta * tau) / (wd * v_next_minus) * (
            (N + R * beta * v_minus) * math.sin(wd * tau) + wd * (vp - R * v_minus) * math.cos(wd * tau))
        return det, tr
    if form == "simplified":
        nT = n * TWO_PI / Omega
        det = R * R * math.exp(-beta * nT)
        N = F * math.sin(phi_prev) + R * beta * v_minus - Delta
        tr = math.exp(-beta * nT) / (wd * v_minus) * (
            (R * beta * v_minus + N) * math.sin(wd * nT) - 2.0 * wd * R * v_minus * math.cos(wd * nT))
        return det, tr
    raise ValueError(f"form must be 'full' or 'simplified', got {form!r}")


# ----------------------------------------------------------------------------
# period-n fixed points
# ----------------------------------------------------------------------------

def newton_fixed_point(model, Omega, guess, n=1, tol=1e-13, max_iter=50):
    """Period-n one-impact fixed point ``(phi, v)`` by Newton's method on the closed form.

    Solves ``q(nT) = Delta`` and ``q'(nT-) = v`` for the flight that starts at
    ``q = Delta, q' = -R v`` at forcing phase ``phi`` (Eqs. 33-34), with the
    analytic Jacobian from :meth:`_Flow.sensitivities`.  Steps are damped
    (halved) until the residual decreases.  Admissibility (no earlier contact,
    ``v > 0``) is *not* checked here; see :func:`is_admissible`.

    Parameters
    ----------
    model : SDOF
    Omega : float
    guess : array_like, shape (2,)
        ``(phi, v)`` starting point.
    n : int
        Forcing periods per impact.
    tol : float
        Convergence tolerance on the residual, relative to ``v``.
    max_iter : int

    Returns
    -------
    x : ndarray, shape (2,) or None
        ``(phi mod 2 pi, v)``, or None if Newton did not converge.
    """
    flow = _Flow(model, Omega)
    tau = n * flow.T

    def resid(x):
        g, v1, _ = flow.state(tau, x[0], x[1])
        return np.array([g, v1 - x[1]])

    x = np.array(guess, dtype=float)
    r = resid(x)
    for _ in range(max_iter):
        scale = max(abs(x[1]), 1e-300)
        if np.max(np.abs(r)) <= tol * scale:
            x[0] %= TWO_PI
            return x
        J = flow.sensitivities(tau, x[0], x[1]) - np.array([[0.0, 0.0], [0.0, 1.0]])
        try:
            dx = np.linalg.solve(J, -r)
        except np.linalg.LinAlgError:
            return None
        lam = 1.0
        nr = np.max(np.abs(r))
        while lam > 1e-4:
            xn = x + lam * dx
            rn = resid(xn)
            if np.max(np.abs(rn)) < nr or lam < 2e-4:
                break
            lam *= 0.5
        x, r = xn, rn
        if not np.all(np.isfinite(x)):
            return None
    if np.max(np.abs(r)) <= 1e3 * tol * max(abs(x[1]), 1e-300):
        x[0] %= TWO_PI
        return x
    return None


def is_admissible(model, Omega, x, n=1, samples_per_period=256, rtol=1e-9):
    """Whether the fixed point ``x = (phi, v)`` is a true one-impact period-n orbit.

    Requires ``v > 0`` and ``q < Delta`` on the open flight ``(0, nT)``: every
    interior maximum of ``q`` is located exactly (bracketed ``brentq`` on
    ``q'``) and must stay below the stop by more than ``rtol`` times the orbit
    size.

    Returns
    -------
    ok : bool
    reason : str
    """
    phi, v = float(x[0]), float(x[1])
    if not v > 0.0:
        return False, f"pre-impact velocity {v:.3e} is not positive"
    flow = _Flow(model, Omega)
    tau = n * flow.T
    s, g, vv, smax = _extrema(flow, phi, v, tau, n * samples_per_period, "max")
    size = max(-np.min(g), v, 1e-300)
    # interior grid points (the end point is the impact itself)
    if np.any(g[1:-1] >= rtol * size):
        return False, "the orbit crosses the stop before n periods (more impacts per period)"
    for sm in smax:
        if 0.0 < sm < tau * (1 - 1e-12) and flow.state(sm, phi, v)[0] >= -rtol * size:
            return False, f"the orbit touches the stop at local time {sm:.6g} < nT (grazing / extra impact)"
    return True, ""


def orbit_extremes(model, Omega, x, n=1, samples_per_period=256):
    """Exact ``(q_min, q_max)`` over the fixed-point orbit ``x = (phi, v)``.

    Minima are zeros of ``q'`` located by ``brentq`` on the closed-form flow;
    the maximum of an impacting orbit is ``Delta`` (reached at the impact)
    unless an interior maximum is higher.
    """
    flow = _Flow(model, Omega)
    tau = n * flow.T
    s, g, vv, smin = _extrema(flow, x[0], x[1], tau, n * samples_per_period, "min")
    _, _, _, smax = _extrema(flow, x[0], x[1], tau, n * samples_per_period, "max")
    gmins = [flow.state(t, x[0], x[1])[0] for t in smin] + [g[0], g[-1]]
    gmaxs = [flow.state(t, x[0], x[1])[0] for t in smax] + [0.0]
    return flow.Delta + min(gmins), flow.Delta + max(gmaxs)


def fixed_point_analysis(model, Omega, x, n=1):
    """Stability of the period-n fixed point ``x = (phi, v)`` by every route.

    Returns
    -------
    dict
        ``multipliers`` (complex, shape (2,), eigenvalues of the monodromy
        ``S Phi(nT)``), ``map_jacobian`` (2, 2), ``map_eigenvalues`` (complex,
        (2,)), ``stable`` (``max |multiplier| < 1``), ``det_full``, ``tr_full``,
        ``stable_full`` (Eqs. 29-32), ``det_simplified``, ``tr_simplified``,
        ``stable_simplified`` (Eqs. 35-37), ``disagree_full``,
        ``disagree_simplified`` (paper verdict differs from the multipliers),
        ``det_true``, ``tr_true`` (of the monodromy), ``a_minus`` (pre-impact
        acceleration).
    """
    flow = _Flow(model, Omega)
    tau = n * flow.T
    phi, v = float(x[0]), float(x[1])
    M = monodromy(model, Omega, phi, v, tau)
    mult = np.linalg.eigvals(M).astype(complex)
    mult = mult[np.argsort(-np.abs(mult))]
    Jm = impact_map_jacobian(model, Omega, phi, v, tau)
    jev = np.linalg.eigvals(Jm).astype(complex)
    jev = jev[np.argsort(-np.abs(jev))]
    stable = bool(np.max(np.abs(mult)) < 1.0)
    dF, tF = paper_det_trace("full", flow.beta, flow.F, flow.R, flow.Delta, flow.Omega, phi, v, v, v, tau)
    dS, tS = paper_det_trace("simplified", flow.beta, flow.F, flow.R, flow.Delta, flow.Omega, phi, v, v, v, tau, n)
    sF = bool(stable_from_det_trace(dF, tF))
    sS = bool(stable_from_det_trace(dS, tS))
    _, _, a1 = flow.state(tau, phi, v)
    return dict(multipliers=mult, map_jacobian=Jm, map_eigenvalues=jev, stable=stable,
                det_full=dF, tr_full=tF, stable_full=sF, disagree_full=sF != stable,
                det_simplified=dS, tr_simplified=tS, stable_simplified=sS,
                disagree_simplified=sS != stable,
                det_true=float(np.linalg.det(M)), tr_true=float(np.trace(M)), a_minus=a1)


def resolved(out: dict, model, Omega: float, tol: float, failed) -> dict:
    """``out`` (a mapping point), or the failed point ``failed([reason])`` when its orbit is not
    resolved by the forcing.

    Newton's residual is accepted at ``tol`` times the impact velocity, so the forcing's effect
    on one flight must stand above it: the forced velocity amplitude ``Omega C``
    (``C = Omega^2 B / sqrt((1 - Omega^2)^2 + (2 beta Omega)^2)``, paper Eq. 28) must exceed
    1e3 ``tol`` times the orbit's scale (its amplitude ``Q`` or impact velocity ``v``).  An orbit
    beyond that -- ``Q`` or ``v`` more than ``1e-3 / tol`` (1e10) times ``Omega C``, or not
    finite -- is not an orbit of the forced oscillator but Newton losing the forcing in
    round-off: e.g. the undamped, elastic scene (``beta = 0``, ``R = 1``) at its impacting
    resonance ``Omega = 2k``, where no bounded orbit exists and Newton drifts to ``v ~ 1e22``.
    A real orbit of a lightly damped scene reaches ~1e3 ``C``.
    """
    if out.get("status") != "ok":
        return out
    from .sdof import linear_amplitude

    C = float(linear_amplitude(model.beta, model.B, Omega))
    Q = float(out.get("amplitude", np.nan))
    v = float(out.get("impact_velocity", np.nan))
    size = max(abs(Q), abs(v) / Omega) if np.isfinite(v) else abs(Q)
    limit = 1e-3 / tol
    if np.isfinite(Q) and np.isfinite(size) and size <= limit * max(C, 1e-300):
        return out
    return failed([f"the orbit found (amplitude {Q:.3g}, impact velocity {v:.3g}) is {size / max(C, 1e-300):.2g} "
                   f"times the forced amplitude C = {C:.3g}, beyond {limit:.0e} = 1e-3 / tol: the forcing is "
                   f"below Newton's tolerance, so no bounded orbit is resolved (beta = {model.beta:g}, "
                   f"R = {model.R:g}: an undamped resonance?)"])


def event_guess(model, Omega, n=1, n_transient=200):
    """Initial guess ``(phi, v)`` from a short run of the exact event solver (guess only).

    Returns the phase and velocity of the last recorded impact, or None if the
    run has no impact.
    """
    from .sdof import EventSolver
    tr = EventSolver(model).point(float(Omega), None, int(n_transient), 2 * n + 2, 8)
    k = min(tr.n_impacts, tr.impact_times.shape[0])
    if k == 0 or tr.status == "failed":
        return None
    return np.array([(Omega * tr.impact_times[k - 1]) % TWO_PI, tr.impact_velocities[k - 1]])


class MappingSolver:
    """Method ``mapping``: period-n one-impact orbits of the impact map (paper Sec. 4.2).

    Parameters
    ----------
    model : SDOF
        The oscillator.
    n : int, optional
        Forcing periods per impact (1 <= n <= 4).
    form : {"full", "simplified"}, optional
        Which of the paper's Jacobian formulas is reported as ``stable_paper``
        (both are always reported as ``stable_full`` / ``stable_simplified``).
    guess : {"event", "averaging"}, optional
        Source of the initial Newton guess when no continuation state is given
        (the other one is tried next).
    guess_periods : int, optional
        Transient periods of the short event run that provides a guess.
    samples_per_flight_period : int, optional
        Grid density of the bracketing searches (admissibility, extremes).
    tol : float, optional
        Newton tolerance on the residual relative to the impact velocity.

    Raises
    ------
    ValueError
        For ``n`` outside 1..4 or an unknown ``form`` / ``guess``.
    """

    name = "mapping"
    time_domain = False

    def __init__(self, model, n: int = 1, form: str = "full", guess: str = "event",
                 guess_periods: int = 200, samples_per_flight_period: int = 256, tol: float = 1e-13):
        if int(n) != n or not 1 <= n <= 4:
            raise ValueError(f"n must be an integer in 1..4, got {n!r}")
        if form not in ("full", "simplified"):
            raise ValueError(f"form must be 'full' or 'simplified', got {form!r}")
        if guess not in ("event", "averaging"):
            raise ValueError(f"guess must be 'event' or 'averaging', got {guess!r}")
        self.model = model
        self.n = int(n)
        self.form = form
        self.guess = guess
        self.guess_periods = int(guess_periods)
        self.samples = int(samples_per_flight_period)
        self.tol = float(tol)

    def settings(self) -> dict:
        return dict(n=self.n, form=self.form, guess=self.guess, guess_periods=self.guess_periods,
                    samples_per_flight_period=self.samples, tol=self.tol)

    def _guesses(self, Omega, state0):
        if isinstance(state0, dict):
            state0 = state0.get("final_state")
        if state0 is not None:
            s = np.asarray(state0, dtype=float).ravel()
            if s.shape == (2,) and np.all(np.isfinite(s)) and s[1] > 0:
                yield s
        order = ["event", "averaging"] if self.guess == "event" else ["averaging", "event"]
        for g in order:
            if g == "averaging" and self.n != 1:
                continue
            x = (event_guess(self.model, Omega, self.n, self.guess_periods) if g == "event"
                 else averaging_guess(self.model, Omega))
            if x is not None:
                yield x

    def point(self, Omega: float, state0, n_transient: int, n_record: int,
              samples_per_period: int = 64) -> dict:
        """Period-n fixed point and its stability at one frequency.

        Parameters
        ----------
        Omega : float
            Forcing frequency (nondimensional).
        state0 : None, ndarray of shape (2,), or dict with ``final_state``
            The previous point's fixed point ``(phi, v)`` for continuation;
            anything else is ignored.
        n_transient, n_record, samples_per_period :
            Ignored (interface compatibility).

        Returns
        -------
        dict
            ``amplitude`` (``Delta - q_min``), ``q_min``, ``q_max``, ``period``
            (``n``, or 0 when no admissible orbit), ``impacts_per_period``
            (``1/n``), ``impact_velocity``, ``impact_phase``, ``stable``
            (Floquet), ``stable_full``, ``stable_simplified``, ``stable_paper``
            (per ``form``), ``disagree_full``, ``disagree_simplified``,
            ``multipliers`` (complex (2,)), ``map_eigenvalues`` (complex (2,)),
            ``det_full``, ``tr_full``, ``det_simplified``, ``tr_simplified``,
            ``det_true``, ``tr_true``, ``final_state`` (``(phi, v)``, shape (2,)),
            ``status`` ``"ok"``/``"failed"``, ``message``.  Failure is a
            recorded status, never an exception.  A two-sided model (``Delta_lower``) is
            mapped by :func:`vibeam.models.sdof_mapping_stops.point_two_sided`: the same keys
            plus ``impacts_per_period_lower`` and ``impact_velocity_lower``; orbits with
            impacts on both stops have ``final_state`` ``(phi_j, v_j, k_j)`` flat (3m,).
        """
        why = undamped_resonance(self.model.beta, float(Omega))
        if why:
            return self._failed([why])
        if getattr(self.model, "Delta_lower", None) is not None:
            from .sdof_mapping_stops import point_two_sided
            return resolved(point_two_sided(self, Omega, state0), self.model, float(Omega), self.tol, self._failed)
        Omega = float(Omega)
        reasons = []
        for g in self._guesses(Omega, state0):
            out = self._one_impact(Omega, g)
            if isinstance(out, dict):
                return resolved(out, self.model, Omega, self.tol, self._failed)
            reasons.append(out)
        return self._failed(reasons)

    def _one_impact(self, Omega, g):
        """The period-n one-impact orbit from the guess ``g = (phi, v)``: outputs, or the reason."""
        m = self.model
        x = newton_fixed_point(m, Omega, g, self.n, self.tol)
        if x is None:
            return f"Newton did not converge from {np.array2string(np.asarray(g), precision=4)}"
        ok, why = is_admissible(m, Omega, x, self.n, self.samples)
        if not ok:
            return why
        an = fixed_point_analysis(m, Omega, x, self.n)
        q_min, q_max = orbit_extremes(m, Omega, x, self.n, self.samples)
        out = dict(amplitude=m.Delta - q_min, q_min=q_min, q_max=q_max, period=self.n,
                   impacts_per_period=1.0 / self.n, impact_velocity=float(x[1]),
                   impact_phase=float(x[0]), final_state=x.copy(),
                   status="ok", message="")
        for key in ("stable", "stable_full", "stable_simplified", "disagree_full",
                    "disagree_simplified", "multipliers", "map_eigenvalues", "det_full",
                    "tr_full", "det_simplified", "tr_simplified", "det_true", "tr_true"):
            out[key] = an[key]
        out["stable_paper"] = an["stable_" + self.form]
        return out

    @staticmethod
    def _failed(reasons) -> dict:
        nan = float("nan")
        return dict(amplitude=nan, q_min=nan, q_max=nan, period=0, impacts_per_period=nan,
                    impact_velocity=nan, impact_phase=nan, final_state=np.full(2, nan),
                    stable=False, stable_full=False, stable_simplified=False, stable_paper=False,
                    disagree_full=False, disagree_simplified=False,
                    multipliers=np.full(2, nan, dtype=complex), map_eigenvalues=np.full(2, nan, dtype=complex),
                    det_full=nan, tr_full=nan, det_simplified=nan, tr_simplified=nan,
                    det_true=nan, tr_true=nan, status="failed",
                    message="; ".join(reasons) if reasons else "no initial guess (no impacts)")
