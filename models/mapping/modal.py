"""The pointwise mapping of an ``N``-mode system (paper Sec. 4.2, the beam's modes): Newton and
Kelvin-Voigt stops.

The one-mode map (:mod:`vibeam.models.mapping.orbit`) describes a section by ``(t, v)``: on the
stop the position is known.  With ``N`` modes the state on a stop has ``2N - 1`` free components,
so a section is here the arrival time ``t_j`` and the whole pre-impact state ``x_j^- = (eta,
eta')`` (shape ``(2N,)``) on stop ``k_j``, whose gap ``g_k = n_k^T eta - d_k`` is zero there
(:mod:`vibeam.models.contact`, :func:`vibeam.models.core.stops.kernel_stops`).  From a section the
map goes through

passage (:meth:`ModalMap.passage`)
    Newton's law (paper Eq. 2 and Eq. 41, a constant ``R``): ``x^+ = P_k x^-``, ``P_k = diag(I, I
    - (1 + R_k) n_k n_k^T / |n_k|^2)``, the impulse along ``n_k`` that maps the normal velocity
    ``U = n_k^T eta'`` to ``-R U`` (the event integrator's impact); a Kelvin-Voigt stop: the exact
    linear contact phase ``eta'' = ... - n_k (k_c g + c_c g')`` (``expm`` of its state matrix,
    harmonic and static particular solutions) up to the force's zero, located by a scan and
    Brent's method;
flight (the closed-form modal flow, paper Eq. 28 per mode, :func:`vibeam.models.system.modal_flow`)
    from the exit to the next section's time, with the transition ``Phi``
    (:func:`~vibeam.models.system.modal_transition`).

A period-n orbit with ``m`` sections is a zero of the multiple-shooting residual in ``(t_0 ..
t_{m-1}, x_0^- .. x_{m-1}^-)`` (``t_m = t_0 + n T``, ``x_m = x_0``)::

    r_j = ( phi(t_{j+1}; exit of section j) - x_{j+1}^-,   (n^T eta_{j+1}^- - d) / |n| of stop k_{j+1} ),

square (``2N + 1`` unknowns and equations per section), solved by damped Newton with the exact
Jacobian: the passage's variation ``y = dx_e - f dt_e = Dx dx + Dt dt`` (the field at the exit is
the free flow's: the reset is instantaneous, a contact phase ends at zero force; Newton: ``Dx =
P``, ``Dt = -f(x^+)``; a contact phase: ``Dx = Phi_c``, ``Dt = -Phi_c f_c(x^-)``), then ``Phi y``,
and ``d phi / d t_{j+1} = f(t_{j+1}, phi)`` for the affine flow ``x' = f(t, x)``.

An orbit found is *checked by the one event integrator*, which shares no code with the residual
but the free flow: from the orbit's state at a forcing period's start (in a flight), ``n`` periods
of the certified event kernel must meet the same stops at the same times (1e-9 of the period) and
return to the state (1e-8 of its size).  That is the admissibility test (no stop crossed or grazed
in a flight, no contact again inside a stop) and gives the record of the orbit (extremes of the
sensor, contact rows).  Its Floquet multipliers are the eigenvalues of the monodromy composed of
the flights' transitions and each passage's fixed-time variation ``S`` (Müller, 1995; di Bernardo
et al. 2008, Sec. 2.5): Newton's saltation matrix ``S = P + (f^+ - P f^-) grad g^T / (grad g^T
f^-)`` (``det S = R^2``), a contact phase's ``Phi_c S_in`` with the entry's saltation ``S_in = I +
(f_c - f) grad g^T / (grad g^T f)`` (the dashpot's force jump, ``det S_in = 1``; the exit, at zero
force, has none), so that ``det M = prod R_k^2 exp(-n T sum_i c_i - sum c_c |n_k|^2 tau_j)``
(Liouville).  All quantities are in the system's units (:class:`vibeam.models.system.ModalSystem`).

References
----------
.. [1] Paper: Reboucas, Santos & Thomsen, JSV 2019, Sec. 4.2, Eqs. 2, 28, 41.
.. [2] P. C. Müller, Calculation of Lyapunov exponents for dynamic systems with discontinuities,
   Chaos, Solitons & Fractals 5 (1995) 1671-1681 (the saltation matrix).
.. [3] M. di Bernardo, C. J. Budd, A. R. Champneys, P. Kowalczyk, *Piecewise-smooth Dynamical
   Systems*, Springer 2008, Sec. 2.5 and 6.2.
"""
from __future__ import annotations

import math

from typing import NamedTuple

import numpy as np
import scipy.linalg
import scipy.optimize

from ..core.event import BeamEventSolver, stop_codes
from ..core.stops import kernel_stops
from ..scene import outputs
from ..system import forcing, modal_flow, modal_transition
from .newton import damped_newton
from .phases import TWO_PI
from .solver import contact_means, failed_outputs

#: Newton's tolerance on the residual relative to the orbit's state (exact flows: round-off)
TOL = 1e-12
#: transient periods of the event run that gives the first guess
GUESS_PERIODS = 200
#: the event integrator's check of an orbit: section times (fraction of the period) and the return
#: to the state after n periods (fraction of its size)
TIME_RTOL, STATE_RTOL = 1e-9, 1e-8
#: the families of compliant laws with a passage (their contact phase an exact linear flow)
PASSED = ("kelvin_voigt",)


class Passage(NamedTuple):
    """The passage of a section through its stop: exit time and state, and the variation
    ``y = dx_e - f(t_e, x_e) dt_e = Dx dx + Dt dt`` of the section's ``(t, x^-)`` (the exit's field
    is the free flow's: Newton's reset is instantaneous, a Kelvin-Voigt phase ends at zero force),
    and ``S``, the fixed-time variation from before the entry to after the exit (the monodromy's
    factor: Newton's saltation matrix; ``Phi_c S_in`` of a contact phase)."""

    t: float
    x: np.ndarray
    Dx: np.ndarray
    Dt: np.ndarray
    S: np.ndarray


class ModalMap:
    """The ``N``-mode system with its stops at one forcing frequency: passages, flights, the
    multiple-shooting residual and the monodromy (module docstring).

    Parameters
    ----------
    system : vibeam.models.system.ModalSystem
    stops : sequence of vibeam.models.contact.Stop
        In the system's units (a relation's ``row`` indexes ``system.contacts``): Newton's law
        with a constant ``R`` or a Kelvin-Voigt law (family ``kelvin_voigt``).
    Omega : float
        Forcing frequency (per unit time of the system).
    n : int, optional
        Periods of the orbits sought: a contact phase longer than ``n + 1`` periods fails.

    Raises
    ------
    ValueError
        For a law of another family or an ``R(U-)`` table.
    """

    def __init__(self, system, stops, Omega, n=1):
        for s in stops:
            if s.law.kind != "impulsive" and getattr(s.law, "family", None) not in PASSED:
                raise ValueError(f"the N-mode mapping has no passage through a stop of law "
                                 f"{getattr(s.law, 'name', s.law.kind)!r} (family {s.law.family!r})")
            if s.law.table_U:
                raise ValueError("the mapping takes a constant R (no R(U-) table)")
        self.system, self.Omega = system, float(Omega)
        self.T = TWO_PI / self.Omega
        self.t_max = (n + 1) * self.T
        self.N = N = system.omega.size
        self.k, self.c = system.omega ** 2, system.damping
        self.g = system.participation * forcing(system, self.Omega)
        ks = kernel_stops(system, stops)
        self.normal = list(ks.normal)
        self.offset = [float(d) for d in ks.offset]
        self.size = [float(np.sqrt(n @ n)) for n in self.normal]
        self.impulsive = [s.law.kind == "impulsive" for s in stops]
        self.reset, self.phase = [], []
        for i, (nk, s) in enumerate(zip(self.normal, stops)):
            P = np.eye(2 * N)
            if self.impulsive[i]:
                P[N:, N:] -= (1.0 + float(s.law.R)) * np.outer(nk, nk) / (nk @ nk)
            self.reset.append(P)
            self.phase.append(None if self.impulsive[i] else self._contact_phase(nk, self.offset[i], ks.kc[i],
                                                                                  ks.cc[i]))

    def _contact_phase(self, nk, d, kc, cc):
        """The linear flow of a Kelvin-Voigt contact: ``A``, its constant and harmonic particular
        solutions ``x_c + a sin(Omega t) + b cos(Omega t)``, the force gradient and the scan step."""
        N, Om = self.N, self.Omega
        A = np.zeros((2 * N, 2 * N))
        A[:N, N:] = np.eye(N)
        A[N:, :N] = -np.diag(self.k) - kc * np.outer(nk, nk)
        A[N:, N:] = -np.diag(self.c) - cc * np.outer(nk, nk)
        const = np.concatenate([np.zeros(N), kc * d * nk])
        xc = -np.linalg.solve(A, const)
        z = np.linalg.solve(1j * Om * np.eye(2 * N) - A, np.concatenate([np.zeros(N), self.g]).astype(complex))
        lam = np.linalg.eigvals(A)
        fast = max(float(np.max(np.abs(lam))), Om)
        return dict(A=A, const=const, xc=xc, a=z.real.copy(), b=z.imag.copy(), grad=np.concatenate([kc * nk, cc * nk]),
                    d=d, kc=kc, cc=cc, h=min(TWO_PI / fast / 32.0, self.T / 64.0))

    # ------------------------------------------------------------------ the pieces
    def field(self, t, x) -> np.ndarray:
        """``f(t, x) = (eta', -c eta' - k eta + Gamma Omega^2 B sin(Omega t))``, shape (2N,)."""
        N = self.N
        return np.concatenate([x[N:], -self.c * x[N:] - self.k * x[:N] + self.g * math.sin(self.Omega * t)])

    def flow(self, t0, t1, x) -> np.ndarray:
        """The state at ``t1`` of the free flight from ``x`` at ``t0``, shape (2N,)."""
        eta, etad = modal_flow(self.system, t0, t1, x[:self.N], x[self.N:], self.Omega)
        return np.concatenate([eta, etad])

    def speed(self, k, x) -> float:
        """Normal velocity ``U = n_k^T eta'`` (> 0 approaching stop ``k``)."""
        return float(self.normal[k] @ x[self.N:])

    def saltation(self, k, t, xm) -> np.ndarray:
        """The saltation matrix (2N, 2N) of a Newton impact on stop ``k`` at ``t`` from ``xm``."""
        P = self.reset[k]
        fm, fp = self.field(t, xm), self.field(t, P @ xm)
        grad = np.concatenate([self.normal[k], np.zeros(self.N)])
        return P + np.outer(fp - P @ fm, grad) / (grad @ fm)

    def passage(self, k, t, xm):
        """The passage of the section ``(t, x^-)`` through stop ``k`` (:class:`Passage`), or None
        when a contact phase has no exit within ``n + 1`` periods."""
        if self.impulsive[k]:
            xp = self.reset[k] @ xm
            return Passage(t, xp, self.reset[k], -self.field(t, xp), self.saltation(k, t, xm))
        return self._kelvin_voigt(self.phase[k], k, t, xm)

    def _particular(self, ph, t):
        w = self.Omega * t
        return ph["xc"] + ph["a"] * math.sin(w) + ph["b"] * math.cos(w)

    def _kelvin_voigt(self, ph, k, t0, x0):
        """The exact linear contact phase from ``x0`` (on the stop's surface) to the first zero of
        the force ``h = k_c g + c_c g'`` (down through it), located by a scan of steps ``ph['h']``
        and Brent's method; the variations by the phase's transition ``Phi_c = expm(A tau)``::

            y = Phi_c (dx_0 - f_c(t_0, x_0) dt_0),   S = Phi_c S_in,
            S_in = I + (f_c - f) grad g^T / (grad g^T f)   at the entry (the dashpot's jump).
        """
        A, grad, h = ph["A"], ph["grad"], ph["h"]
        h0 = ph["kc"] * ph["d"]            # the force h = grad . x - k_c d
        E = scipy.linalg.expm(A * h)
        u = x0 - self._particular(ph, t0)
        t, prev = t0, grad @ x0 - h0
        for _ in range(int(self.t_max / h) + 1):
            un = E @ u
            xn = un + self._particular(ph, t + h)
            hn = grad @ xn - h0
            if hn <= 0.0 and (prev > 0.0 or t > t0):
                break
            t, u, prev = t + h, un, hn
        else:
            return None
        u0 = x0 - self._particular(ph, t0)

        def force(s):
            return grad @ (scipy.linalg.expm(A * (s - t0)) @ u0 + self._particular(ph, s)) - h0

        te = scipy.optimize.brentq(force, t, t + h, xtol=1e-15 * max(abs(t0), 1.0), rtol=4 * np.finfo(float).eps)
        Pc = scipy.linalg.expm(A * (te - t0))
        xe = Pc @ u0 + self._particular(ph, te)
        fc0 = A @ x0 + ph["const"] + np.concatenate([np.zeros(self.N), self.g * math.sin(self.Omega * t0)])
        f0 = self.field(t0, x0)
        gg = np.concatenate([self.normal[k], np.zeros(self.N)])
        S_in = np.eye(2 * self.N) + np.outer(fc0 - f0, gg) / (gg @ f0)
        return Passage(te, xe, Pc, -Pc @ fc0, Pc @ S_in)

    # ------------------------------------------------------------------ the orbit
    def _end(self, t, j, m, n):
        j1 = (j + 1) % m
        return j1, t[j1] + (n * self.T if j1 == 0 else 0.0)

    def residual(self, X, stops, n, jac=True):
        """The residual (m (2N + 1),) at ``X = (t_0 .. t_{m-1}, x_0^- .. x_{m-1}^-)`` and its
        Jacobian (module docstring); ``(None, None)`` when a passage has no exit or ends after the
        next section's time."""
        m, N2 = len(stops), 2 * self.N
        sz = N2 + 1
        t, xs = X[:m], X[m:].reshape(m, N2)
        r = np.empty(m * sz)
        J = np.zeros((m * sz, m * sz)) if jac else None
        for j in range(m):
            j1, t1 = self._end(t, j, m, n)
            k, k1 = stops[j], stops[j1]
            pas = self.passage(k, t[j], xs[j])
            if pas is None or not t1 > pas.t:
                return None, None
            y = self.flow(pas.t, t1, pas.x)
            row = j * sz
            r[row:row + N2] = y - xs[j1]
            r[row + N2] = (self.normal[k1] @ xs[j1][:self.N] - self.offset[k1]) / self.size[k1]
            if jac:
                Phi = modal_transition(self.system, pas.t, t1)
                cj, cj1 = m + j * N2, m + j1 * N2
                J[row:row + N2, j] += Phi @ pas.Dt
                J[row:row + N2, cj:cj + N2] += Phi @ pas.Dx
                J[row:row + N2, j1] += self.field(t1, y)
                J[row:row + N2, cj1:cj1 + N2] -= np.eye(N2)
                J[row + N2, cj1:cj1 + self.N] += self.normal[k1] / self.size[k1]
        return r, J

    def newton(self, X, stops, n, tol=TOL, max_iter=50):
        """Damped Newton on :meth:`residual` from ``X``
        (:func:`vibeam.models.mapping.newton.damped_newton`): the last iterate and whether it
        converged to ``max |r| <= tol`` times the largest state component (1e3 ``tol`` after
        ``max_iter``)."""
        return damped_newton(lambda Y: self.residual(Y, stops, n), X, tol, len(stops), max_iter)

    def monodromy(self, X, stops, n) -> np.ndarray:
        """``Phi_{m-1} S_{m-1} ... Phi_0 S_0`` (2N, 2N), ``S_j`` the passage's fixed-time variation and
        ``Phi_j`` the flight's transition: the period-n map's Jacobian from before section 0,
        conjugate to the stroboscopic monodromy (the same multipliers)."""
        m, N2 = len(stops), 2 * self.N
        t, xs = X[:m], X[m:].reshape(m, N2)
        M = np.eye(N2)
        for j in range(m):
            _, t1 = self._end(t, j, m, n)
            pas = self.passage(stops[j], t[j], xs[j])
            M = modal_transition(self.system, pas.t, t1) @ pas.S @ M
        return M

    def state_at_period_start(self, X, stops, n):
        """``(tau, x(tau), j)``: a multiple ``tau`` of the period in ``[t_0, t_0 + n T)`` that lies in
        a flight (from the exit of section ``j`` to section ``j + 1``) and the state there;
        ``x`` None when every one lies in a contact phase."""
        m, N2 = len(stops), 2 * self.N
        t, xs = X[:m], X[m:].reshape(m, N2)
        first = self.T * math.ceil(t[0] / self.T - 1e-12)
        for i in range(n):
            tau = first + i * self.T
            for j in range(m):
                _, t1 = self._end(t, j, m, n)
                if t[j] <= tau < t1:
                    pas = self.passage(stops[j], t[j], xs[j])
                    if pas is not None and pas.t <= tau:
                        return tau, self.flow(pas.t, tau, pas.x), j
        return first, None, -1


def minimal_period(X, stops, n, T, N, rtol=1e-9):
    """The least ``p`` dividing ``n`` after which the sections repeat (same stops, times ``+ p T``
    to ``rtol T``, states to ``rtol`` of their size)."""
    m = len(stops)
    t, xs = X[:m], X[m:].reshape(m, 2 * N)
    scale = max(np.max(np.abs(xs)), 1e-300)
    for p in range(1, n):
        if n % p or (m * p) % n:
            continue
        sh = m * p // n
        idx = (np.arange(m) + sh) % m
        wrap = np.where(np.arange(m) + sh >= m, n * T, 0.0)
        if (all(stops[i] == stops[j] for i, j in zip(range(m), idx))
                and np.allclose(t[idx] + wrap, t + p * T, rtol=0, atol=rtol * T)
                and np.allclose(xs[idx], xs, rtol=0, atol=rtol * scale)):
            return p
    return n


class ModalMappingSolver:
    """Method ``mapping`` of the modal beam: period-n orbits of the pointwise map with Newton and
    Kelvin-Voigt stops anywhere on the beam (module docstring; the SDOF's is
    :class:`vibeam.models.mapping.solver.MappingSolver`).

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
        The modal system and its stops in the system's units (the beam's
        :func:`vibeam.models.builders.beam.fe_beam`; any number of modes).
    n : int, optional
        Forcing periods of the orbit (1..4).
    form : str, optional
        Accepted for the case interface; the paper's formulas (Eqs. 29-37) are the SDOF's.
    guess_periods : int, optional
        Transient periods of the event run that gives the first guess.
    tol : float, optional
        Newton's tolerance relative to the orbit's state (:data:`TOL`).

    Raises
    ------
    ValueError
        For ``n`` outside 1..4 or stops that are neither Newton's with a constant ``R`` nor
        Kelvin-Voigt ones.
    """

    name = "mapping"
    time_domain = False

    def __init__(self, scene, n: int = 1, form: str = "full", guess_periods: int = GUESS_PERIODS, tol: float = TOL):
        if int(n) != n or not 1 <= n <= 4:
            raise ValueError(f"n must be an integer in 1..4, got {n!r}")
        self.n, self.form = int(n), form
        self.guess_periods, self.tol = int(guess_periods), float(tol)
        self.scene = scene
        self.system, self.stops = scene.system, scene.stops
        #: the reported gap (the first stop's, seen at the sensor) and the row value per unit of ``q``
        self.Delta = outputs(scene).Delta
        self.scale = float(scene.system.coordinate_scale)
        ModalMap(self.system, self.stops, 1.0)          # the stops are checked once
        codes = stop_codes(self.stops)
        #: the stops have codes of their own (point stops): the per-stop outputs are reported
        self.coded = codes is not None
        self.codes = np.arange(len(self.stops)) if codes is None else np.asarray(codes)
        self.event = BeamEventSolver(scene)
        self.n_stops = len(self.stops)

    def settings(self) -> dict:
        return dict(n=self.n, form=self.form, guess_periods=self.guess_periods, tol=self.tol)

    # ------------------------------------------------------------------ guesses
    def _sections(self, mp, tr, x0):
        """The sections ``(t, stop index, x^-)`` of an event record from ``x0`` at its start."""
        index = {int(c): i for i, c in enumerate(self.codes)}
        ks = np.zeros(tr.impact_times.size, int) if tr.impact_stops is None else tr.impact_stops
        out, t, x = [], 0.0, x0
        for ti, c in zip(tr.impact_times, ks):
            k = index[int(c)]
            if float(ti) < t:
                return None
            x = mp.flow(t, float(ti), x)
            out.append((float(ti), k, x.copy()))
            pas = mp.passage(k, float(ti), x)
            if pas is None:
                return None
            x, t = pas.x, pas.t
        return out

    def _guesses(self, mp, state0):
        """Guesses ``(X, stops)``: the previous point's sections, then those of an event run's last
        ``n`` periods (reasons as strings where there are none)."""
        N2, n = 2 * mp.N, self.n
        s0 = state0.get("final_state") if isinstance(state0, dict) else state0
        if s0 is not None:
            s = np.asarray(s0, float).ravel()
            if s.size and s.size % (N2 + 2) == 0 and np.all(np.isfinite(s)):
                s = s.reshape(-1, N2 + 2)
                yield np.concatenate([s[:, 0] / mp.Omega, s[:, 1:N2 + 1].ravel()]), tuple(int(k) for k in s[:, -1])
        warm = self.event.point(mp.Omega, None, self.guess_periods, 1, 8)
        if warm.status != "ok" or warm.final_state[-1] != 0.0:
            yield f"the event run from rest ends {warm.status} ({warm.message or 'held on a stop'}): no guess"
            return
        x0 = np.asarray(warm.final_state[:-1], float)
        tr = self.event.point(mp.Omega, np.concatenate([x0, [0.0]]), 0, 2 * n, 8)
        if tr.status != "ok" or tr.n_impacts != tr.impact_times.size:
            yield f"the event run ends {tr.status}: no guess"
            return
        sec = self._sections(mp, tr, x0)
        if sec is None:
            yield "the event run's contacts overlap or do not end: no guess"
            return
        sec = [s for s in sec if s[0] >= (1.0 - 1e-12) * n * mp.T]
        if not sec:
            yield "no impact in the event run's last periods: no orbit of the map"
            return
        if len(sec) > 16 * n:
            yield f"the event run has {len(sec)} arrivals in {n} period(s) (chatter?): not a guess of the map"
            return
        t = np.array([s[0] for s in sec]) - n * mp.T
        yield np.concatenate([t, np.concatenate([s[2] for s in sec])]), tuple(s[1] for s in sec)

    # ------------------------------------------------------------------ one point
    def point(self, Omega: float, state0, n_transient: int, n_record: int, samples_per_period: int = 64) -> dict:
        """The period-n orbit at one frequency, its stability and its record.

        Parameters
        ----------
        Omega : float
            Forcing frequency ``f / f_ref``.
        state0 : None, ndarray or dict with ``final_state``
            The previous point's ``final_state`` (continuation); anything else is ignored.
        n_transient, n_record, samples_per_period :
            Ignored (interface compatibility).

        Returns
        -------
        dict
            The outputs of the SDOF's mapping (:meth:`MappingSolver.point`) in the beam's units:
            ``amplitude`` (``Delta - q_min``, ``q`` the sensor over ``L``), ``q_min``, ``q_max``,
            ``period``, ``impacts_per_period``, ``impact_velocity`` (stop code 0; normal
            pre-impact speed ``U- / L``), ``impact_phase``, ``stable``, ``multipliers`` (complex
            (2N,), by decreasing modulus), ``det_true``, ``tr_true``, the contact outputs,
            ``final_state`` (per section ``(phase, x^- (2N), stop)``, flat), ``status`` and
            ``message``; two stops add the ``_lower`` outputs (stop code 1), point stops
            ``stop_impacts_per_period`` and ``stop_impact_velocity`` per stop code.  A failure
            is a status with its reasons, never an exception.
        """
        Omega = float(Omega)
        mp = ModalMap(self.system, self.stops, Omega, self.n)
        reasons = []
        for g in self._guesses(mp, state0):
            out = g if isinstance(g, str) else self._solve(mp, *g)
            if isinstance(out, dict):
                return out
            reasons.append(out)
        return self._failed(reasons)

    def _solve(self, mp, X, stops):
        n, m = self.n, len(stops)
        X, ok = mp.newton(X, stops, n, self.tol)
        if not ok:
            return f"Newton did not converge from the guess (sections on stops {stops} in {n} periods)"
        p = minimal_period(X, stops, n, mp.T, mp.N)
        if p < n:
            return f"the orbit found has period {p}, not n = {n} (sections on stops {stops[:m * p // n]})"
        xs = X[m:].reshape(m, 2 * mp.N)
        U = np.array([mp.speed(k, x) for k, x in zip(stops, xs)])
        if not np.all(U > 0.0):
            return f"an arrival speed is not positive ({np.min(U):.3e})"
        rec = self._record(mp, X, stops)
        if isinstance(rec, str):
            return rec
        return self._outputs(mp, X, stops, U, rec)

    def _record(self, mp, X, stops):
        """n periods of the event integrator from the orbit's state at a period's start: the same
        sections and the return to the state, or the reason why not (module docstring)."""
        n, m = self.n, len(stops)
        tau, x, j = mp.state_at_period_start(X, stops, n)
        if x is None:
            return "every period start of the orbit lies in a contact phase (the event check starts at one)"
        tr = self.event.point(mp.Omega, np.concatenate([x, [0.0]]), 0, n, 32)
        order = [(j + 1 + i) % m for i in range(m)]
        want_t = np.array([X[i] + (n * mp.T if i <= j else 0.0) - tau for i in order])
        ks = np.zeros(tr.impact_times.size, int) if tr.impact_stops is None else tr.impact_stops
        want_k = self.codes[[stops[i] for i in order]]
        if (tr.status != "ok" or tr.impact_times.size != m or not np.array_equal(ks, want_k)
                or np.max(np.abs(tr.impact_times - want_t)) > TIME_RTOL * mp.T):
            return (f"the event integrator from the orbit meets other sections ({tr.impact_times.size} impacts on "
                    f"stops {list(ks)} against the orbit's {m} on {list(want_k)}; {tr.status}): grazing or a "
                    f"stop crossed in a flight")
        if np.max(np.abs(tr.final_state[:-1] - x)) > STATE_RTOL * max(np.max(np.abs(x)), 1e-300):
            return "the event integrator from the orbit does not return to it after n periods"
        return tr

    def _outputs(self, mp, X, stops, U, tr):
        n, m = self.n, len(stops)
        codes = self.codes[list(stops)]
        v = U / self.scale
        M = mp.monodromy(X, stops, n)
        mu = np.linalg.eigvals(M)
        mu = mu[np.argsort(-np.abs(mu))]
        phis = mp.Omega * X[:m]
        rows = tr.contacts if tr.contacts is not None else np.zeros((0, 5))
        # the record's rows in the order of the orbit's sections from the period start
        rk = np.zeros(rows.shape[0], int) if tr.impact_stops is None else tr.impact_stops
        xs = X[m:].reshape(m, 2 * mp.N)
        out = dict(amplitude=self.Delta - tr.q_min, q_min=tr.q_min, q_max=tr.q_max, period=n,
                   impacts_per_period=int(np.sum(codes == 0)) / n,
                   impact_velocity=float(np.mean(v[codes == 0])) if np.any(codes == 0) else math.nan,
                   impact_phase=float(phis[0] % TWO_PI), stable=bool(np.max(np.abs(mu)) < 1.0),
                   multipliers=mu, det_true=float(np.linalg.det(M)), tr_true=float(np.trace(M)),
                   **contact_means(rows[:, :4], rk == 0, ""),
                   final_state=np.column_stack([phis, xs, np.asarray(stops, float)]).ravel(),
                   status="ok", message="")
        if self.n_stops > 1:
            lo = codes == 1
            out.update(impacts_per_period_lower=int(np.sum(lo)) / n,
                       impact_velocity_lower=float(np.mean(v[lo])) if np.any(lo) else math.nan,
                       **contact_means(rows[:, :4], rk == 1, "_lower"))
        if self.coded:
            size = int(np.max(self.codes)) + 1
            out["stop_impacts_per_period"] = np.array([np.sum(codes == c) / n for c in range(size)], float)
            out["stop_impact_velocity"] = np.array([float(np.mean(v[codes == c])) if np.any(codes == c) else math.nan
                                                    for c in range(size)])
        return out

    def _failed(self, reasons) -> dict:
        N2 = 2 * self.system.omega.size
        out = failed_outputs(reasons, N2, N2 + 2, self.n_stops > 1, det_trace=True)
        if self.coded:
            size = int(np.max(self.codes)) + 1
            out.update(stop_impacts_per_period=np.full(size, math.nan), stop_impact_velocity=np.full(size, math.nan))
        return out

