"""Pseudo-arclength continuation of periodic orbits of impacting systems, with stability and
bifurcations.  Numerics only: it drives any shooting problem of :mod:`vibeam.models.core.periodic`
and knows nothing about the fidelity.

A period-n orbit is a zero of ``F(x, p) = P^n(x; p) - x`` with ``F_x = M - I`` (``M`` the
monodromy of the shot) and ``F_p = x_p``.  Branches of zeros are followed by
pseudo-arclength continuation (Keller 1977; Allgower & Georg 1990, Ch. 2; Seydel 2010,
Ch. 4) in the scaled variables ``u = (x / s_x, p / s_p)``:

* predictor ``u + ds t`` along the unit tangent ``t``, the null vector of ``[F_x, F_p]``
  obtained from the bordered system ``[[F_x, F_p], [t_old^T]] t = e`` (orientation kept);
* corrector: Newton on ``F = 0``, ``t^T (u - u_pred) = 0`` with the bordered Jacobian;
* step control: ``ds`` grows after a fast corrector, halves after a failure (no convergence,
  a shot the problem cannot represent, a corrector that leaves the step's neighbourhood or a
  tangent that turns too much), between ``ds_min`` and ``ds_max``.

The branch passes folds (the tangent turns, ``p`` need not be monotone) and is followed on its
stable and unstable parts alike.  At every point the Floquet multipliers (eigenvalues of
``M``) give the stability.  Test functions are watched between consecutive points and their
zeros located by bracketing on the arclength between the two points (Illinois regula falsi
with bisection; every trial point is corrected onto the branch):

=================== ============================================================
fold                ``t_p``, the parameter component of the tangent
period doubling     ``det(M + I)`` (a real multiplier through -1)
Neimark-Sacker      ``max |mu| - 1`` over the complex multipliers (eigenvalue tracking;
                    it cannot occur for the dissipative SDOF: ``det M = R^(2m)
                    exp(-2 beta n T) < 1`` with ``d = 2``)
grazing             the impact signature (number of impacts per orbit) changes:
                    bisection; a new impact is born where an apex touches the stop
                    (``apex_gap -> 0``) or an impact dies (impact velocity ``-> 0``)
sticking            the orbit starts or stops sticking (``stuck_time`` crosses 0)
=================== ============================================================

After a grazing the map has a square-root singularity and the branch has a corner.  The
branch is continued on the new signature from the first corrected point beyond the corner
(tangent turned away from the grazing point); if no such point exists nearby (a non-smooth
fold whose partner branch is not found) the branch ends with status ``grazing``.  At a period
doubling the period-2n branch is started from ``x_PD + eps v`` (``v`` the eigenvector of the
multiplier -1) and continued too.

Entry points: :func:`trace` (one-parameter branches, with branch switching) and
:func:`trace_curve` (two-parameter curves of folds, period doublings and grazings).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..blas import with_one_blas_thread
from ..interrupts import check as check_interrupt
from ..interrupts import reraise_interrupt
from ..core.continuation_kernels import SMALL_SPECTRUM, corrector_step, floquet_spectrum, floquet_spectrum_small, bordered_tangent

FOLD = "fold"
PERIOD_DOUBLING = "period_doubling"
NEIMARK_SACKER = "neimark_sacker"
GRAZING = "grazing"
STICKING = "sticking"
TYPES = (FOLD, PERIOD_DOUBLING, NEIMARK_SACKER, GRAZING, STICKING)


@dataclass(frozen=True)
class Settings:
    """Step control and tolerances of the continuation (scaled units: state / ``s_x``,
    parameter / ``s_p``, ``s_p`` = the width of the parameter range).

    Attributes
    ----------
    ds, ds_min, ds_max : float
        Initial, smallest and largest arclength step.
    max_points : int
        Most points per branch.
    grow, shrink : float
        Step factors after a corrector of at most ``fast`` iterations / after a failure.
    fast : int
        Corrector iterations counted as fast.
    max_newton : int
        Corrector iterations before a step is rejected.
    tol : float
        Residual ``|P^n(x) - x| / s_x`` accepted as converged.
    locate_tol : float
        Width of the final arclength bracket of a located bifurcation (the parameter is then
        known to ``locate_tol * s_p``, to ``~locate_tol^2`` at a fold).
    min_cos : float
        Smallest cosine between consecutive tangents on one impact signature.
    max_period : int
        Period-doubling branch switching up to this period.
    max_branches : int
        Most branches of one :func:`trace` (the start and its period-doubled offspring).
    switch : bool
        Switch branches at period doublings.
    """

    ds: float = 0.01
    ds_min: float = 1e-9
    ds_max: float = 0.05
    max_points: int = 2000
    grow: float = 1.6
    shrink: float = 0.5
    fast: int = 3
    max_newton: int = 8
    tol: float = 1e-11
    locate_tol: float = 1e-10
    min_cos: float = 0.8
    max_period: int = 8
    max_branches: int = 12
    switch: bool = True


@dataclass
class Point:
    """One corrected point of a branch."""

    x: np.ndarray            # state at the section (native units)
    p: float                 # parameter
    u: np.ndarray            # scaled (x / s_x, p / s_p)
    t: np.ndarray | None     # unit tangent (scaled), oriented along the branch
    shot: object             # the Shot at (x, p)
    mu: np.ndarray           # Floquet multipliers, complex, by decreasing modulus
    its: int = 0             # corrector iterations
    pd: float = np.nan       # det(M + I)
    ns: float = np.nan       # max |mu| - 1 over complex multipliers

    @property
    def signature(self) -> tuple:
        """``(impacts per orbit, sticks)``; a sticking orbit counts no impacts: the number of
        bounces resolved before a chatter accumulation is a numerical choice (the event
        policy's ``chatter_tol``), not a property of the orbit, and the orbit does not depend
        on them (the state after the sticking phase is fixed)."""
        if self.shot.stuck_time > 0.0:
            return (0, True)
        return (self.shot.n_impacts, False)


@dataclass
class Bifurcation:
    """A located bifurcation.

    Attributes
    ----------
    type : str
        One of :data:`TYPES`.
    parameter : float
        Its parameter value.
    x : ndarray, shape (d,)
        State at the section.
    n : int
        Period of the branch it lies on.
    branch : int
        Index of that branch in the :func:`trace` result.
    index : int
        Position in the branch: it lies between points ``index - 1`` and ``index``.
    multipliers : ndarray, complex
        Floquet multipliers there.
    amplitude : float
        ``Q`` there.
    detail : str
        E.g. which multiplier crossed, or the signatures on both sides of a grazing.
    test : float
        Value of the test function at the located point (its residual).
    """

    type: str
    parameter: float
    x: np.ndarray
    n: int
    branch: int
    index: int
    multipliers: np.ndarray
    amplitude: float
    detail: str = ""
    test: float = 0.0


@dataclass
class Branch:
    """A continued branch: its points, bifurcations and how it ended.

    ``status``: ``range_end`` (left the parameter range), ``max_points``, ``closed`` (came back
    to its start), ``merged`` (a period-2n branch that rejoined the period-n branch), ``grazing``
    (ended at a grazing that could not be continued), ``no_convergence`` (the step fell below
    ``ds_min``), ``failed_start``; ``message`` says why.
    """

    n: int
    points: list = field(default_factory=list)
    bifurcations: list = field(default_factory=list)
    status: str = ""
    message: str = ""
    origin: str = "start"
    index: int = 0
    resections: int = 0      # impacts that crossed the section (the state representation jumped)

    def __len__(self):
        return len(self.points)

    def arrays(self) -> dict:
        """Per-point arrays: ``parameter`` (k,), ``state`` (k, d), ``amplitude``, ``q_min``,
        ``q_max``, ``impact_velocity`` (k, m_max; NaN padded), ``impact_phase`` (k, m_max, rad),
        ``multipliers`` (k, d) complex, ``stable`` (k,) bool, ``period`` (k,), ``impacts``
        (per orbit), ``impacts_per_period`` (k,), ``stuck_time``, ``apex_gap``; with two stops
        (shots with ``extra["impact_stops"]``) also ``impacts_lower`` (per orbit) and
        ``impacts_per_period_lower`` (the lower stop's share of ``impacts``)."""
        k = len(self.points)
        d = self.points[0].x.shape[0] if k else 0
        mmax = max([pt.shot.n_impacts for pt in self.points] + [1])
        iv = np.full((k, mmax), np.nan)
        ph = np.full((k, mmax), np.nan)
        for i, pt in enumerate(self.points):
            s = pt.shot
            m = s.n_impacts
            if m:
                iv[i, :m] = s.impact_velocities
                if np.isfinite(s.Omega):
                    ph[i, :m] = np.mod(s.Omega * s.impact_times, 2 * math.pi)
        amp = np.array([_amplitude(pt.shot) for pt in self.points])
        lower = {}
        if any("impact_stops" in pt.shot.extra for pt in self.points):
            nl = np.array([int(np.sum(np.asarray(pt.shot.extra.get("impact_stops", ())) == 1))
                           for pt in self.points], dtype=np.int64)
            lower = dict(impacts_lower=nl, impacts_per_period_lower=nl / self.n)
        return dict(
            parameter=np.array([pt.p for pt in self.points]),
            state=np.array([pt.x for pt in self.points]).reshape(k, d),
            amplitude=amp,
            q_min=np.array([pt.shot.q_min for pt in self.points]),
            q_max=np.array([pt.shot.q_max for pt in self.points]),
            impact_velocity=iv, impact_phase=ph,
            multipliers=np.array([pt.mu for pt in self.points], dtype=complex).reshape(k, d),
            stable=np.array([_stable(pt.mu) for pt in self.points], dtype=bool),
            period=np.full(k, self.n, dtype=np.int64),
            impacts=np.array([pt.shot.n_impacts for pt in self.points], dtype=np.int64),
            impacts_per_period=np.array([pt.shot.n_impacts / self.n for pt in self.points]),
            stuck_time=np.array([pt.shot.stuck_time for pt in self.points]),
            apex_gap=np.array([pt.shot.apex_gap for pt in self.points]),
            **lower,
        )


def _amplitude(shot) -> float:
    return shot.gap - shot.q_min if np.isfinite(shot.gap) else np.nan


def _stable(mu) -> bool:
    return bool(np.max(np.abs(mu)) < 1.0) if mu.size else True


class ContinuationError(ValueError):
    """A request the engine cannot serve (bad range, bad problem)."""


class _Engine:
    """Continuation of one problem over ``[lo, hi]`` with fixed scales."""

    def inside(self, p, slack=0.0):
        return self.lo - slack <= p <= self.hi + slack

    def __init__(self, prob, lo, hi, settings: Settings, s_x: float):
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ContinuationError(f"parameter range [{lo}, {hi}] is empty or not finite")
        self.prob = prob
        self.d = int(prob.dim)
        self.lo, self.hi = float(lo), float(hi)
        self.S = settings
        self.sp = self.hi - self.lo
        self.sx = float(s_x)
        self.I = np.eye(self.d)
        self.n_shots = 0
        # the spectrum: compiled for small d (no Python dispatch per point), LAPACK beyond
        self.spectrum = floquet_spectrum_small if self.d <= SMALL_SPECTRUM else floquet_spectrum
        self._tangent_at = None      # (point, t_ref, tangent) of the compiled corrector's last point
        # the compiled corrector of a first run compiles in a second process meanwhile (issue 44)
        ahead = getattr(prob, "compile_corrector_ahead", None)
        if ahead is not None:
            ahead(0.5 * (self.lo + self.hi))

    # ------------------------------------------------------------------ basic evaluations
    def shot(self, x, p, n):
        check_interrupt()              # a signal swallowed inside compiled code stops here (issue 57)
        self.n_shots += 1
        try:
            s = self.prob.shot(x, p, n)
        except Exception as e:  # a problem must not raise; if it does, it is a failed shot
            from ..core.periodic import Shot

            reraise_interrupt(e)       # Ctrl-C inside the compiled shot: an interrupt, not a failure
            nan = np.full(self.d, np.nan)
            s = Shot(x=nan, M=np.full((self.d, self.d), np.nan), x_p=nan, impact_times=np.zeros(0),
                     impact_velocities=np.zeros(0), q_min=np.nan, q_max=np.nan, status="failed",
                     message=f"{type(e).__name__}: {e}")
        return s

    def u_of(self, x, p):
        u = np.empty(self.d + 1)
        u[:self.d] = x / self.sx
        u[self.d] = p / self.sp
        return u

    def jac(self, s):
        """``[F_x, F_p]`` in scaled variables, shape (d, d+1)."""
        J = np.empty((self.d, self.d + 1))
        J[:, :self.d] = s.M - self.I
        J[:, self.d] = s.x_p * (self.sp / self.sx)
        return J

    def tangent(self, J, t_ref=None, direction=1.0):
        """Unit null vector of ``J``; oriented along ``t_ref`` or by the sign of its p-part."""
        d = self.d
        _, _, Vt = np.linalg.svd(J)
        t = Vt[-1].copy()
        if t_ref is not None:
            return t if t @ t_ref >= 0 else -t
        return t if t[d] * direction >= 0 else -t

    def make_point(self, x, p, s, t=None, its=0, u=None, spectrum=None):
        """The :class:`Point` of a corrected shot (``spectrum``: its Floquet spectrum if known)."""
        mu, pd, ns = spectrum if spectrum is not None else self.spectrum(np.ascontiguousarray(s.M, dtype=float))
        return Point(x=np.asarray(x, float).copy(), p=float(p), u=self.u_of(x, p) if u is None else u,
                     t=t, shot=s, mu=mu, its=its, pd=pd, ns=ns)

    # ------------------------------------------------------------------ correctors
    def newton_fixed(self, x0, p, n, max_iter=30):
        """Natural-parameter Newton at fixed ``p`` (damped); returns (Point or None, reason)."""
        x = np.asarray(x0, float).copy()
        last = ""
        for it in range(max_iter):
            s = self.shot(x, p, n)
            if s.status != "ok":
                return None, f"shot failed at {x}: {s.message}"
            r = s.x - x
            if np.max(np.abs(r)) <= self.S.tol * self.sx:
                return self.make_point(x, p, s, its=it), ""
            try:
                dx = np.linalg.solve(s.M - self.I, -r)
            except (np.linalg.LinAlgError, ValueError):
                return None, "singular monodromy - I (a fold or a branch point?)"
            # damping: halve while the residual does not decrease
            lam = 1.0
            nr = np.max(np.abs(r))
            while True:
                xn = x + lam * dx
                sn = self.shot(xn, p, n)
                if sn.status == "ok" and np.max(np.abs(sn.x - xn)) < nr:
                    break
                lam *= 0.5
                if lam < 1e-4:
                    last = "Newton stalled (damped step does not reduce the residual)"
                    break
            if lam < 1e-4:
                return None, last
            x = xn
        return None, f"Newton at fixed {getattr(self.prob, 'parameter', 'p')} did not converge in {max_iter} iterations"

    def deflated_newton(self, x0, p, n, roots, max_iter=40):
        """Newton at fixed ``p`` on the deflated residual ``D(x) F(x)``, ``D = prod_j (1 +
        s_x^2 / |x - r_j|^2)``, which cannot converge to the known roots ``r_j`` (Farrell,
        Birkisson & Funke 2015); used to find the partner branch of a grazing next to the
        branch that arrives there.  Returns a Point or None."""
        x = np.asarray(x0, float).copy()
        sx2 = self.sx * self.sx
        I = self.I

        def defl(x):
            D, g = 1.0, np.zeros(self.d)
            for r in roots:
                dr = x - r
                q = float(dr @ dr) / sx2
                if q == 0.0:
                    return np.inf, g
                Dj = 1.0 + 1.0 / q
                gj = -2.0 * dr / sx2 / (q * q) / Dj      # grad log Dj
                D *= Dj
                g += gj
            return D, g * D

        for _ in range(max_iter):
            s = self.shot(x, p, n)
            if s.status != "ok":
                return None
            F = s.x - x
            if np.max(np.abs(F)) <= self.S.tol * self.sx:
                return self.make_point(x, p, s)
            D, gD = defl(x)
            if not math.isfinite(D):
                return None
            J = D * (s.M - I) + np.outer(F, gD)
            try:
                dx = np.linalg.solve(J, -D * F)
            except np.linalg.LinAlgError:
                return None
            G0 = D * np.max(np.abs(F))
            lam = 1.0
            while lam > 1e-6:
                xn = x + lam * dx
                sn = self.shot(xn, p, n)
                if sn.status == "ok":
                    Dn, _ = defl(xn)
                    if Dn * np.max(np.abs(sn.x - xn)) < G0:
                        break
                lam *= 0.5
            if lam <= 1e-6:
                return None
            x = xn
        return None

    def correct(self, u_pred, t, n, radius=None):
        """Pseudo-arclength corrector: ``F = 0`` and ``t . (u - u_pred) = 0``.

        Returns (Point or None, reason).  ``radius``: largest accepted distance from ``u_pred``.
        """
        d, S = self.d, self.S
        fast = getattr(self.prob, "correct", None)
        if fast is not None:
            # the problem's compiled corrector (the same iterates, without a Python round trip per
            # shot; :meth:`vibeam.models.core.shooting.ModalShooting.correct`); None: not served
            try:
                r = fast(u_pred, t, n, self.sx, self.sp, S.tol, S.max_newton, radius)
            except Exception as e:  # noqa: BLE001 - the loop below meets the same shots and reports
                reraise_interrupt(e)
                r = None
            # a signal whose handler ran inside the compiled corrector (numba's _numba_unpickle,
            # caught by the kernel's own try): recorded, so it stops here (issue 57)
            check_interrupt()
            if r is not None:
                code, it, u, x, p, nr, s, n_shots, (spectrum, tan) = r
                self.n_shots += n_shots
                if code == 0:
                    pt = self.make_point(x, p, s, its=it, u=u, spectrum=spectrum)
                    # the tangent the compiled corrector computed at the point along t (finish's)
                    self._tangent_at = (pt, t, tan) if tan is not None else None
                    return pt, ""
                return None, {1: "the corrector left the neighbourhood of the predictor",
                              2: "singular bordered Jacobian",
                              3: "non-finite residual or Newton step (singular bordered Jacobian)"}.get(
                    code, f"no convergence in {S.max_newton} corrector iterations (residual {nr:.2e})")
        u = u_pred
        sx, sp = self.sx, self.sp
        nr, dist = np.inf, 0.0
        tol = S.tol
        for it in range(S.max_newton + 1):
            x = u[:d] * sx
            p = u[d] * sp
            s = self.shot(x, p, n)
            if s.status != "ok":
                return None, s.message or s.status
            try:
                # x_p contiguous: the types of the compiled corrector's own call (one specialisation)
                nr, ndu_new, un, dist_new = corrector_step(s.M, np.ascontiguousarray(s.x_p), s.x, x, u, u_pred, t,
                                                           sx, sp)
            except Exception as e:  # numba's solve raises on an exactly singular matrix
                reraise_interrupt(e)
                return None, "singular bordered Jacobian"
            # converged: residual at tolerance, or (near a grazing, where the impact time is
            # ill-conditioned and the residual has a round-off floor) a negligible Newton step
            if nr <= tol or (nr <= 1e3 * tol and it > 0 and ndu_new <= tol):
                if radius is not None and dist > radius:
                    return None, "the corrector left the neighbourhood of the predictor"
                return self.make_point(x, p, s, its=it, u=u), ""
            if it == S.max_newton:
                break
            if not (nr < np.inf and ndu_new < np.inf):
                return None, "non-finite residual or Newton step (singular bordered Jacobian)"
            u, dist = un, dist_new
            if radius is not None and dist > 2.0 * radius:
                return None, "the corrector left the neighbourhood of the predictor"
        return None, f"no convergence in {S.max_newton} corrector iterations (residual {nr:.2e})"

    def finish(self, pt, t_ref=None, direction=1.0, away=None):
        """Tangent of a corrected point (oriented along ``t_ref``, or away from ``away``)."""
        t = None
        known = self._tangent_at
        if t_ref is not None and known is not None and known[0] is pt and known[1] is t_ref:
            t = known[2]
        elif t_ref is not None:
            try:
                # contiguous: the compiled corrector's own call has C arrays (one specialisation)
                t = bordered_tangent(np.ascontiguousarray(pt.shot.M), np.ascontiguousarray(pt.shot.x_p),
                                     self.sx, self.sp, np.ascontiguousarray(t_ref))
            except Exception as e:
                reraise_interrupt(e)
                t = None
            if t is not None and not np.isfinite(t).all():
                t = None
        if t is None:
            t = self.tangent(self.jac(pt.shot), t_ref, direction)
        if away is not None and t @ (pt.u - away) < 0:
            t = -t
        pt.t = t
        return pt

    # ------------------------------------------------------------------ test functions
    @staticmethod
    def tau(kind, pt, d):
        if kind == FOLD:
            return pt.t[d]
        if kind == PERIOD_DOUBLING:
            return pt.pd
        if kind == NEIMARK_SACKER:
            return pt.ns
        raise ValueError(kind)

    def trial(self, a, b, sigma, sigma_b, n):
        """The corrected point at arclength ``sigma`` along ``t_a`` between ``a`` and ``b``."""
        u_pred = a.u + (sigma / sigma_b) * (b.u - a.u)
        pt, why = self.correct(u_pred, a.t, n, radius=2.0 * np.linalg.norm(b.u - a.u) + 1e-12)
        if pt is not None:
            self.finish(pt, a.t)
        return pt, why

    def locate(self, kind, a, b, n):
        """Zero of test function ``kind`` between points ``a`` and ``b`` (Illinois + bisection).

        Returns the located Point (or None) and the test value there."""
        d = self.d
        sb = float(a.t @ (b.u - a.u))
        if not sb > 0:
            return None, np.nan
        lo, hi = 0.0, sb
        flo, fhi = self.tau(kind, a, d), self.tau(kind, b, d)
        best, fbest = (a, flo) if abs(flo) < abs(fhi) else (b, fhi)
        side = 0
        for _ in range(200):
            if hi - lo <= self.S.locate_tol:
                break
            # Illinois step, kept inside the middle of the bracket, else bisection
            s = hi - fhi * (hi - lo) / (fhi - flo) if fhi != flo else 0.5 * (lo + hi)
            w = hi - lo
            if not (lo + 1e-3 * w < s < hi - 1e-3 * w):
                s = 0.5 * (lo + hi)
            pt, _ = self.trial(a, b, s, sb, n)
            if pt is None:
                s = 0.5 * (lo + hi)
                pt, _ = self.trial(a, b, s, sb, n)
                if pt is None or pt.signature != a.signature:
                    return None, np.nan
            f = self.tau(kind, pt, d)
            if not math.isfinite(f):
                return None, np.nan
            if abs(f) < abs(fbest):
                best, fbest = pt, f
            if f == 0.0:
                return pt, f
            if (f > 0) == (flo > 0):
                lo, flo = s, f
                if side == -1:
                    fhi *= 0.5
                side = -1
            else:
                hi, fhi = s, f
                if side == 1:
                    flo *= 0.5
                side = 1
        return best, fbest

    @staticmethod
    def graze_indicator(pt, sig_new):
        """A test function on the old side of a signature change, positive there and linear in
        the arclength up to the grazing point: ``-apex_gap`` when an impact is born, the smallest
        impact velocity when one dies, ``stuck_time`` at the end of sticking; None (bisection
        only) at the onset of sticking."""
        m, stuck = pt.signature
        if sig_new is None:
            return None
        if stuck != sig_new[1]:
            return pt.shot.stuck_time if stuck else None
        if sig_new[0] > m:
            return -pt.shot.apex_gap if math.isfinite(pt.shot.apex_gap) else None
        return pt.shot.min_impact_velocity

    def _old_side(self, p_lo, h, n, sig):
        """Trial ``h`` beyond ``p_lo`` along its tangent, corrected; (Point or None, same sig)."""
        pt, _ = self.correct(p_lo.u + h * p_lo.t, p_lo.t, n, radius=0.3 * h + 1e-12)
        if pt is None:
            return None, False
        if pt.signature == sig:
            self.finish(pt, p_lo.t)
            return pt, True
        return pt, False

    def locate_graze(self, a, n, s_hi, sig_new):
        """Locate where the impact signature of the branch through ``a`` ends.

        Secant iteration on :meth:`graze_indicator` (positive on the old side, linear in the
        arclength up to the grazing point) along the old branch: each trial is predicted
        from the last point of the old signature along its tangent and corrected there.  A
        trial that lands on another signature bounds the grazing from above; one that does not
        converge (the impact time is ill-conditioned next to a grazing) halves the step.
        Without an indicator (onset of sticking) it bisects; ``s_hi`` is the first guess of
        the distance (arclength, scaled).

        Returns
        -------
        (Point, Point or None, ndarray)
            The last point with ``a``'s signature, the nearest corrected point of another
            signature (or None) and the grazing point ``u_g`` (scaled): the zero of the
            indicator extrapolated linearly from the last two old-side points (the last
            old-side point when there is no indicator).
        """
        tol = self.S.locate_tol
        sig = a.signature
        lo = 0.0
        p_lo, p_hi = a, None
        f_lo = self.graze_indicator(a, sig_new)
        if f_lo is None or not math.isfinite(f_lo):
            # no indicator: bisection between the old signature and the first other one
            hi = max(float(s_hi), 10 * tol)
            for _ in range(60):                 # make sure the old signature fails at hi
                pt, same = self._old_side(p_lo, hi - lo, n, sig)
                if not same:
                    p_hi = pt if pt is not None else p_hi
                    break
                lo, p_lo, hi = hi, pt, lo + 2.0 * (hi - lo) + hi - lo
            while hi - lo > tol:
                m = 0.5 * (lo + hi)
                pt, same = self._old_side(p_lo, m - lo, n, sig)
                if same:
                    lo, p_lo = m, pt
                else:
                    hi = m
                    p_hi = pt if pt is not None else p_hi
            u_g = p_lo.u
        else:
            # secant on the indicator, aiming at 90 % of the distance to its zero (staying on the
            # old side, where Newton converges); any failure halves the step.  Next to the
            # grazing the indicator itself is ill-conditioned (an impact velocity from a nearly
            # tangential crossing): the iteration stops when it no longer decreases
            f_a = f_lo
            prev = None
            h = max(float(s_hi), 10 * tol)
            h_root = None
            fails = 0
            for _ in range(200):
                if prev is not None and prev[1] != f_lo:
                    slope = (f_lo - prev[1]) / (lo - prev[0])
                    h_root = -f_lo / slope if slope < 0 else None
                    if h_root is not None:
                        if h_root <= tol:
                            break
                        if fails == 0:
                            h = 0.9 * h_root
                if h <= 0.1 * tol or fails > 50:
                    break
                pt, same = self._old_side(p_lo, h, n, sig)
                if same:
                    f = self.graze_indicator(pt, sig_new)
                    if f is None or not math.isfinite(f):
                        break
                    if prev is not None and f > 0.5 * f_lo and h_root is not None and fails == 0:
                        if f < f_lo:
                            p_lo, f_lo = pt, f
                        break                      # the indicator's round-off floor
                    prev = (lo, f_lo)
                    lo, p_lo, f_lo = lo + h, pt, f
                    fails = 0
                    if h_root is None:
                        h = 2.0 * h
                else:
                    if pt is not None and (p_hi is None or
                                           np.linalg.norm(pt.u - p_lo.u) < np.linalg.norm(p_hi.u - p_lo.u)):
                        p_hi = pt
                    fails += 1
                    h *= 0.5
            if f_lo <= 1e-5 * f_a or h_root is None or h_root > max(0.05, 10.0 * h):
                u_g = p_lo.u
            else:
                u_g = p_lo.u + h_root * p_lo.t
        if p_hi is not None:
            self.finish(p_hi, None, away=u_g)
        return p_lo, p_hi, u_g


def _graze_detail(a, b) -> tuple:
    """Type and description of a signature change ``a -> b``."""
    (ma, sa), (mb, sb) = a, b
    if sa != sb:
        return STICKING, "onset of sticking" if sb else "end of sticking"
    return GRAZING, f"{ma} -> {mb} impacts per orbit (" + ("a new impact is born" if mb > ma else
                                                           "an impact velocity vanishes") + ")"


def _bif(kind, pt, n, bi, index, detail, test=0.0, at=None):
    """A Bifurcation at point ``pt`` (or at ``at = (x, p)``, e.g. an extrapolated grazing point,
    with the multipliers and amplitude of ``pt``)."""
    x, p = (pt.x, pt.p) if at is None else at
    return Bifurcation(type=kind, parameter=float(p), x=np.array(x, float), n=n, branch=bi, index=index,
                       multipliers=pt.mu.copy(), amplitude=_amplitude(pt.shot), detail=detail, test=test)


def _period_doubling_detail(pt) -> str:
    mu = pt.mu
    k = int(np.argmin(np.abs(mu + 1.0)))
    return f"multiplier {mu[k].real:+.10f}{mu[k].imag:+.1e}j"


class _Tracer:
    """Runs branches of one problem: the loop, detection, grazing switches and PD switches."""

    def __init__(self, eng: _Engine):
        self.eng = eng
        self.S = eng.S

    def inside(self, p, slack=0.0):
        return self.eng.lo - slack <= p <= self.eng.hi + slack

    def boundary_point(self, a, b, n):
        """The branch point at the range end crossed between ``a`` (inside) and ``b``."""
        eng = self.eng
        bound = eng.hi if b.p > eng.hi else eng.lo
        w = (bound - a.p) / (b.p - a.p) if b.p != a.p else 1.0
        x0 = a.x + w * (b.x - a.x)
        pt, _ = eng.newton_fixed(x0, bound, n)
        if pt is None or pt.signature != a.signature:
            return None
        return eng.finish(pt, a.t)

    def detect(self, br, bi, a, b, n):
        """Bifurcations between consecutive points of one signature; appended to ``br``."""
        eng, d = self.eng, self.eng.d
        found = []
        for kind in (FOLD, PERIOD_DOUBLING, NEIMARK_SACKER):
            fa, fb = eng.tau(kind, a, d), eng.tau(kind, b, d)
            if not (math.isfinite(fa) and math.isfinite(fb)) or (fa > 0) == (fb > 0) or fa == 0:
                continue
            pt, f = eng.locate(kind, a, b, n)
            if pt is None:
                continue
            if kind == PERIOD_DOUBLING:
                k = int(np.argmin(np.abs(pt.mu + 1.0)))
                if abs(pt.mu[k] + 1.0) > 1e-4:   # det(M + I) changed sign through infinity
                    continue
                detail = _period_doubling_detail(pt)
            elif kind == NEIMARK_SACKER:
                if abs(f) > 1e-6:
                    continue
                c = pt.mu[np.abs(pt.mu.imag) > 0]
                detail = f"complex pair |mu| = 1, angle {abs(np.angle(c[0])) if c.size else np.nan:.6f} rad"
            else:
                detail = f"t_p = {f:.1e}"
            found.append(_bif(kind, pt, n, bi, len(br.points), detail, f))
        found.sort(key=lambda bf: float(np.linalg.norm(eng.u_of(bf.x, bf.parameter) - a.u)))
        br.bifurcations.extend(found)
        return found

    def run(self, br: Branch, bi: int, first: Point, ds: float):
        """Continue ``br`` from its last point ``first`` (with tangent) until it ends."""
        eng, S, n = self.eng, self.S, br.n
        a = first
        start_u = br.points[0].u
        reason = ""
        curv = None          # curvature estimate (change of the tangent per arclength)
        while True:
            check_interrupt()        # every step: a signal swallowed inside compiled code stops here
            if len(br.points) >= S.max_points:
                br.status, br.message = "max_points", f"{S.max_points} points"
                return
            # second-order predictor along the branch (tangent and the curvature of the last
            # step), corrected in the hyperplane normal to the tangent
            u_pred = a.u + ds * a.t
            if curv is not None:
                u_pred = u_pred + (0.5 * ds * ds) * curv
            pt, why = eng.correct(u_pred, a.t, n, radius=0.5 * ds + 1e-12)
            ok = pt is not None
            if ok:
                if pt.signature == a.signature:
                    eng.finish(pt, a.t)
                    if pt.t @ a.t < S.min_cos:
                        ok, why = False, "the tangent turned too much"
                else:
                    eng.finish(pt, a.t)
            if not ok:
                reason = why
                ds *= S.shrink
                if ds < S.ds_min:
                    if self.resect(br, a, n):
                        a = br.points[-1]
                        ds, curv = S.ds, None
                        continue
                    if self.graze_end(br, bi, a, n, reason):
                        a = br.points[-1]
                        ds, curv = S.ds, None
                        continue
                    if br.status == "grazing":
                        return       # graze_end's own status and message: the grazing is the reason
                    br.status = "no_convergence"
                    br.message = (f"step below ds_min = {S.ds_min:g} at {eng.prob_name} = {a.p:.10g}: "
                                  f"{reason}")
                    return
                continue
            # accepted
            if pt.signature != a.signature:
                g_lo, g_hi, u_g = eng.locate_graze(a, n, float(a.t @ (pt.u - a.u)), pt.signature)
                if g_hi is not None and g_hi.signature != pt.signature:
                    g_hi = None
                kind, detail = _graze_detail(a.signature, pt.signature)
                nxt = g_hi if g_hi is not None else pt
                self.orient_away(nxt, u_g, n)
                u_g = self.refine_graze(nxt, u_g, a.signature, n)
                if g_lo is not a:
                    br.points.append(g_lo)
                    self.detect(br, bi, a, g_lo, n)
                br.bifurcations.append(_bif(kind, g_lo, n, bi, len(br.points), detail,
                                            at=(u_g[:eng.d] * eng.sx, u_g[eng.d] * eng.sp)))
                # continue on the new signature, turned away from the grazing point
                self.orient_away(nxt, u_g, n)
                if not self.inside(nxt.p):
                    br.status, br.message = "range_end", "left the parameter range"
                    return
                br.points.append(nxt)
                if nxt is not pt and pt.signature == nxt.signature:
                    eng.finish(pt, nxt.t)
                    if pt.t @ nxt.t > S.min_cos and self.inside(pt.p):
                        self.detect(br, bi, nxt, pt, n)
                        br.points.append(pt)
                        nxt = pt
                a = nxt
                ds = max(min(ds, S.ds), S.ds_min * 10)
                curv = None
                continue
            if not self.inside(pt.p):
                c = self.boundary_point(a, pt, n)
                if c is not None:
                    self.detect(br, bi, a, c, n)
                    br.points.append(c)
                br.status, br.message = "range_end", f"reached {eng.prob_name} = {(c or a).p:.10g}"
                return
            self.detect(br, bi, a, pt, n)
            br.points.append(pt)
            du_ = pt.u - a.u
            step = math.sqrt(float(du_ @ du_))
            curv = (pt.t - a.t) / step if step > 0 else None
            if self.closed(br, pt, start_u, ds):
                br.status, br.message = "closed", "the branch came back to its first point (an isola)"
                return
            if br.origin != "start" and self.merged(br, pt):
                br.status = "merged"
                br.message = f"the period-{n} orbit became period-{n // 2} again (reverse period doubling)"
                return
            ds = min(ds * S.grow, S.ds_max) if pt.its <= S.fast else ds
            a = pt

    def resect(self, br, a, n) -> bool:
        """An impact of the orbit at ``a`` coincides with the section: continue from the same
        orbit seen on the other side of it (``prob.resect``, optional).  True if continued."""
        eng = self.eng
        f = getattr(eng.prob, "resect", None)
        if f is None or not a.shot.n_impacts:
            return False
        try:
            x1 = f(a.x, a.p, n)
        except Exception as e:
            reraise_interrupt(e)
            return False
        if x1 is None:
            return False
        # the other representation exists just beyond the crossing: natural-parameter Newton
        # from it at small steps of the parameter in the direction of travel
        sgn = 1.0 if a.t[eng.d] >= 0 else -1.0
        pt = None
        for delta in (1e-10, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4):
            p = a.p + sgn * delta * eng.sp
            if not self.inside(p):
                break
            q, _ = eng.newton_fixed(np.asarray(x1, float), p, n)
            if q is not None and np.linalg.norm(q.u - a.u) > 1e3 * delta + 1e-6:
                pt = q
                break
        if pt is None:
            return False
        t = eng.tangent(eng.jac(pt.shot), None, 1.0)
        # same direction of travel: the parameter component keeps its sign (or, at a
        # vertical tangent, the state follows the old one)
        if abs(a.t[eng.d]) > 1e-3:
            t = t if t[eng.d] * a.t[eng.d] > 0 else -t
        elif t[:eng.d] @ a.t[:eng.d] < 0:
            t = -t
        pt.t = t
        br.points.append(pt)
        br.resections += 1
        return True

    def partner(self, g, u_g, n, expect=None):
        """A point of another impact signature next to the grazing point ``u_g`` reached along
        the branch of ``g``: at ``p_g +- delta`` the branch of ``g`` is solved first (where
        Newton from the grazing state lands on the signature ``expect`` that the grazing gives,
        that orbit is a candidate: the branch passes the grazing with a corner), then deflated Newton from perturbations
        of it finds the other solutions; the nearest one of another signature is returned
        (tangent turned away from ``u_g``), or None."""
        eng = self.eng
        d = eng.d
        x_g, p_g = u_g[:d] * eng.sx, u_g[d] * eng.sp
        if d <= 4:
            dirs = list(np.eye(d))
        else:
            w, V = np.linalg.eig(g.shot.M)
            dirs = [np.real(V[:, k]) / np.linalg.norm(np.real(V[:, k])) for k in np.argsort(-np.abs(w))[:4]]
        best, best_dist = None, np.inf
        for delta in (1e-3, 1e-2):
            for sgn in (1.0, -1.0):
                p = p_g + sgn * delta * eng.sp
                if not self.inside(p):
                    continue
                old, _ = eng.newton_fixed(x_g, p, n)
                if old is None:
                    continue
                if old.signature != g.signature:
                    # beyond the grazing only an orbit of another signature exists next to it:
                    # the branch goes on through the grazing (a corner, not a non-smooth fold) --
                    # if it has the signature the grazing gives (not an orbit of another branch
                    # that Newton fell onto, e.g. the one before the previous signature change)
                    if old.signature != expect:
                        continue
                    dist = float(np.linalg.norm(old.u - u_g))
                    if dist < best_dist and dist < 0.25:
                        best, best_dist = old, dist
                    continue
                for v in dirs:
                    for e in (1e-3, -1e-3):
                        pt = eng.deflated_newton(old.x + e * eng.sx * v, p, n, [old.x])
                        if pt is None or pt.signature == g.signature:
                            continue
                        dist = float(np.linalg.norm(pt.u - u_g))
                        if dist < best_dist and dist < 0.25:
                            best, best_dist = pt, dist
            if best is not None:
                break
        if best is None:
            return None
        return self.orient_away(best, u_g, n)

    def orient_away(self, pt, u_g, n):
        """Give ``pt`` (just beyond a grazing at ``u_g``, on the new impact signature) the
        tangent that leads away from the grazing: probe a short step each way and keep the side
        that stays on the new signature and moves away (the other crosses back or fails); if
        the probes cannot tell, the side pointing away from ``u_g``."""
        eng = self.eng
        t = eng.tangent(eng.jac(pt.shot), None, 1.0)
        dist = float(np.linalg.norm(pt.u - u_g))
        h = min(max(4.0 * dist, 1e-7), 1e-2)
        ok = []
        for sgn in (1.0, -1.0):
            q, _ = eng.correct(pt.u + sgn * h * t, sgn * t, n, radius=h)
            if q is not None and q.signature == pt.signature and np.linalg.norm(q.u - u_g) > dist:
                ok.append(sgn)
        if len(ok) == 1:
            pt.t = ok[0] * t
        else:
            pt.t = t if t @ (pt.u - u_g) >= 0 else -t
        return pt

    def refine_graze(self, b, u_g, sig_old, n):
        """A grazing located from the side with fewer impacts is better conditioned (the
        indicator is an apex height, not the velocity of a nearly tangential impact): when
        the new side ``b`` has fewer impacts than the old one, locate the grazing again from
        ``b`` backwards and return that point; else ``u_g``."""
        if not (b.signature[1] == sig_old[1] and b.signature[0] < sig_old[0]
                and math.isfinite(b.shot.apex_gap)):
            return u_g
        eng = self.eng
        back = replace(b, t=-b.t)
        dist = float(np.linalg.norm(b.u - u_g))
        try:
            _, _, u2 = eng.locate_graze(back, n, max(dist, 10 * self.S.locate_tol), sig_old)
        except Exception as e:
            reraise_interrupt(e)
            return u_g
        return u2 if np.linalg.norm(u2 - u_g) < 10 * dist + 1e-9 else u_g

    def closed(self, br, pt, start_u, ds):
        if len(br.points) <= 10:
            return False
        e = pt.u - start_u
        return float(e @ e) < 0.25 * ds * ds and br.points[0].t is not None and pt.t @ br.points[0].t > 0.9

    def merged(self, br, pt):
        """A period-2n branch point that is a period-n orbit (back on its parent branch)."""
        if br.n % 2:
            return False
        s = self.eng.shot(pt.x, pt.p, br.n // 2)
        return s.status == "ok" and np.max(np.abs(s.x - pt.x)) < 1e-7 * self.eng.sx

    def graze_end(self, br, bi, a, n, reason) -> bool:
        """At a failure to continue from ``a``: a grazing (non-smooth fold)?  Locate the
        grazing, record it and switch to a branch of another impact signature next to it.
        True if the branch continues."""
        eng = self.eng
        s = a.shot
        if a.signature[1]:
            return False     # a sticking orbit: its chatter impacts are not grazing ones
        size = max(abs(s.q_max - s.q_min), float(np.max(np.abs(a.x))), 1e-300)
        vmin = s.min_impact_velocity
        v_scale = max(float(np.max(s.impact_velocities)) if s.n_impacts else 0.0, float(np.max(np.abs(a.x))))
        born = math.isfinite(s.apex_gap) and -s.apex_gap < 1e-3 * size
        dies = math.isfinite(vmin) and vmin < 1e-3 * v_scale
        if not (born or dies):
            return False
        sig_new = (a.signature[0] + (1 if born and not dies else -1), a.signature[1])
        g, g_hi, u_g = eng.locate_graze(a, n, max(self.S.ds_min * 4, 1e-8), sig_new)
        at = (u_g[:eng.d] * eng.sx, u_g[eng.d] * eng.sp)
        if g is not a:
            self.detect(br, bi, a, g, n)
            br.points.append(g)
        cands = [self.orient_away(g_hi, u_g, n)] if g_hi is not None and self.inside(g_hi.p) else []
        if not cands:
            pt = self.partner(g, u_g, n, expect=sig_new)
            if pt is not None:
                cands.append(pt)
        if cands:
            pt = cands[0]
            kind, detail = _graze_detail(g.signature, pt.signature)
            d = eng.d
            turn = ("non-smooth fold" if g.t is None or pt.t[d] * g.t[d] <= 0.0 else
                    "the branch goes on through it with a corner")
            br.bifurcations.append(_bif(kind, g, n, bi, len(br.points), f"{detail}; {turn}", at=at))
            br.points.append(pt)
            return True
        kind, detail = _graze_detail(g.signature, sig_new)
        br.bifurcations.append(_bif(kind, g, n, bi, len(br.points),
                                    detail + "; no orbit of another signature found next to it", at=at))
        # how close the last point is to the grazing: the apex's distance to the stop (an impact
        # born) or the smallest impact velocity (one dying), against the orbit's own scale
        s = g.shot
        if born and not dies:
            how = f"the last point's apex {-s.apex_gap:.2g} from the stop ({-s.apex_gap / size:.1g} of the orbit's size)"
        else:
            how = (f"the last point's smallest impact velocity {s.min_impact_velocity:.2g} "
                   f"({s.min_impact_velocity / v_scale:.1g} of the largest)")
        br.status = "grazing"
        br.message = (f"ended at a grazing at {eng.prob_name} = {at[1]:.10g}, {detail}, {how}: the impact map "
                      f"has a square-root singularity there, the corrector cannot step across it ({reason}) "
                      f"and no branch of {sig_new[0]} impacts per orbit was found next to it")
        return False


class ScaledParameter:
    """A shooting problem continued in a key that is affine in its native parameter,
    ``native = offset + factor * value`` (e.g. a rig's voltage: ``B = gamma V``, paper Eq. 44):
    ``d x / d value = factor * d x / d native`` (chain rule).  Other attributes (``start``,
    ``resect``, ``starts``, ``model``, ...) are the wrapped problem's, with values converted."""

    def __init__(self, prob, parameter: str, factor: float, offset: float = 0.0):
        if not (math.isfinite(factor) and factor != 0.0):
            raise ContinuationError(f"the factor of {parameter!r} must be finite and non-zero, got {factor}")
        self.prob = prob
        self.parameter = parameter
        self.factor = float(factor)
        self.offset = float(offset)
        self.dim = prob.dim
        self.value = (float(getattr(prob, "value", math.nan)) - self.offset) / self.factor

    def native(self, p):
        return self.offset + self.factor * float(p)

    def shot(self, x0, p, n):
        s = self.prob.shot(x0, self.native(p), n)
        s.x_p = s.x_p * self.factor
        return s

    def correct(self, u_pred, t, n, sx, sp, tol, max_newton, radius, factor=1.0, offset=0.0):
        """The wrapped problem's compiled corrector (if any) in the native parameter
        ``offset + factor value``; None where it has none."""
        f = getattr(self.prob, "correct", None)
        if f is None:
            return None
        return f(u_pred, t, n, sx, sp, tol, max_newton, radius, factor=self.factor * factor,
                 offset=self.offset + self.factor * offset)

    @property
    def starts(self):
        return getattr(self.prob, "starts", ())

    def start(self, kind, p, n=1):
        return self.prob.start(kind, self.native(p), n)

    def compile_corrector_ahead(self, p, n=1, before_start=False):
        f = getattr(self.prob, "compile_corrector_ahead", None)
        return False if f is None else f(self.native(p), n, before_start)

    def resect(self, x0, p, n):
        f = getattr(self.prob, "resect", None)
        return None if f is None else f(x0, self.native(p), n)

    def __getattr__(self, name):
        if name == "prob":
            raise AttributeError(name)
        return getattr(self.prob, name)


class FiniteDifferenceParameter:
    """A shooting problem continued in a parameter its problems do not carry as one of theirs
    (a law's stiffness, a stop's position: a parameter path of the case, issue 43): one problem
    per value, ``make(p)`` (each continued in its own parameter, held at ``native``), and ``d x /
    d p`` by central differences of their shots, ``h = rel_step max(|p|, scale)`` (error
    O(h^2); the shots' state is exact to round-off, so ``rel_step = 1e-5`` leaves ~1e-10 of
    ``x_p``).  An inexact ``F_p`` changes only the corrector's path and the tangent: a point is
    a zero of ``F`` (the residual is the exact shot), and its multipliers come from the exact
    monodromy.  No compiled corrector (``correct`` is None): the corrector runs in Python.

    Parameters
    ----------
    make : callable
        ``p -> problem``: the shooting problem of the scene with the parameter set to ``p``.
    parameter : str
        The parameter's name (for messages and results).
    native : float
        The value of each problem's own parameter at which it is shot (e.g. the frequency Omega).
    p0 : float
        A value of the parameter (the start; the scale of the step).
    rel_step : float
        Relative step of the central differences.
    """

    def compile_corrector_ahead(self, p, n=1, before_start=False):
        return False            # no compiled corrector to compile (its problems' shots only)

    def __init__(self, make, parameter: str, native: float, p0: float, rel_step: float = 1e-5):
        if not (math.isfinite(p0) and math.isfinite(native)):
            raise ContinuationError(f"{parameter!r}: start {p0} and native value {native} must be finite")
        self.make = make
        self.parameter = parameter
        self.native = float(native)
        self.value = float(p0)
        self.scale = max(abs(float(p0)), 1e-300)
        self.rel_step = float(rel_step)
        self._probs: dict = {}
        self.dim = self._at(p0).dim

    def _at(self, p):
        """The problem at ``p`` (the last few kept: a shot and its two neighbours)."""
        p = float(p)
        prob = self._probs.get(p)
        if prob is None:
            if len(self._probs) >= 6:
                self._probs.pop(next(iter(self._probs)))
            prob = self._probs[p] = self.make(p)
        return prob

    def shot(self, x0, p, n=1, derivatives: bool = True, stuck=None):
        s = self._at(p).shot(x0, self.native, n, derivatives, stuck)
        if not derivatives or s.status != "ok":
            return s
        h = self.rel_step * max(abs(float(p)), self.scale)
        a = self._at(float(p) + h).shot(x0, self.native, n, False, stuck)
        b = self._at(float(p) - h).shot(x0, self.native, n, False, stuck)
        if a.status == "ok" and b.status == "ok":
            s.x_p = (np.asarray(a.x) - np.asarray(b.x)) / (2.0 * h)
        elif a.status == "ok":
            s.x_p = (np.asarray(a.x) - np.asarray(s.x)) / h
        elif b.status == "ok":
            s.x_p = (np.asarray(s.x) - np.asarray(b.x)) / h
        else:
            s.x_p = np.full_like(np.asarray(s.x, float), np.nan)
        return s

    correct = None

    @property
    def starts(self):
        return getattr(self._at(self.value), "starts", ())

    def start(self, kind, p, n=1):
        return self._at(p).start(kind, self.native, n)

    def resect(self, x0, p, n):
        f = getattr(self._at(p), "resect", None)
        return None if f is None else f(x0, self.native, n)

    def __getattr__(self, name):
        if name in ("make", "_probs", "value"):
            raise AttributeError(name)
        return getattr(self._at(self.value), name)


def _prob_name(prob) -> str:
    return str(getattr(prob, "parameter", "p"))


def start_point(prob, x0, p0, n, lo, hi, settings: Settings = Settings(), s_x=None):
    """Correct a starting guess at fixed parameter (natural-parameter Newton).

    Returns (Point or None, reason).  Used by :func:`trace`; exposed for tests.
    """
    x0 = np.asarray(x0, float)
    sx = s_x if s_x is not None else max(float(np.max(np.abs(x0))), 1e-12)
    eng = _Engine(prob, lo, hi, settings, sx)
    eng.prob_name = _prob_name(prob)
    return eng.newton_fixed(x0, p0, n)


@with_one_blas_thread
def trace(prob, x0, p0, n, lo, hi, direction: int = 1, settings: Settings = Settings(),
          s_x: float | None = None) -> list:
    """Continue the period-n orbit through ``(x0, p0)`` over ``lo <= p <= hi``.

    Parameters
    ----------
    prob : shooting problem
        Contract of :mod:`vibeam.models.core.periodic` (``dim``, ``parameter``, ``shot(x0, p, n)``).
    x0 : array_like, shape (d,)
        Guess of the state at the section (corrected at fixed ``p0`` first).
    p0 : float
        Parameter of the start.
    n : int
        Period of the orbit (forcing periods).
    lo, hi : float
        Parameter range.
    direction : {1, -1, 0}
        Continue towards increasing / decreasing parameter first; 0 both ways (the two halves
        are joined into one branch).
    settings : Settings
    s_x : float, optional
        Scale of the state (default: its largest component at the start).

    Returns
    -------
    list of Branch
        The start's branch first, then the period-2n branches switched to at its period
        doublings (and theirs, up to ``settings.max_period``).  A branch that cannot start
        has ``status = "failed_start"`` and no points.

    Raises
    ------
    ContinuationError
        If the range is empty or not finite.
    """
    x0 = np.asarray(x0, float)
    if x0.shape != (int(prob.dim),) or not np.all(np.isfinite(x0)):
        raise ContinuationError(f"the starting state must be {int(prob.dim)} finite numbers, got {x0!r}")
    sx = s_x if s_x is not None else max(float(np.max(np.abs(x0))), 1e-12)
    eng = _Engine(prob, lo, hi, settings, sx)
    if not lo <= p0 <= hi:
        raise ContinuationError(f"the start {p0!r} lies outside the range [{lo}, {hi}]")
    eng.prob_name = _prob_name(prob)
    tr = _Tracer(eng)
    br = Branch(n=int(n))
    branches = [br]
    pt, why = eng.newton_fixed(x0, p0, n)
    if pt is None:
        br.status, br.message = "failed_start", f"no period-{n} orbit found at {eng.prob_name} = {p0:.10g}: {why}"
        return branches
    if direction == 0:
        back = Branch(n=int(n))
        back.points.append(eng.finish(replace(pt), None, -1.0))
        tr.run(back, 0, back.points[0], settings.ds)
        br.points.append(eng.finish(pt, None, 1.0))
        tr.run(br, 0, br.points[0], settings.ds)
        L = len(back.points)
        for q in back.points[1:]:
            q.t = -q.t
        for bf in back.bifurcations:
            bf.index = L - bf.index
        for bf in br.bifurcations:
            bf.index += L - 1
        br.points = back.points[:0:-1] + br.points
        br.bifurcations = back.bifurcations[::-1] + br.bifurcations
        if back.status != "range_end":
            br.message = f"decreasing side: {back.status}: {back.message}; increasing side: {br.status}: {br.message}"
            br.status = back.status if br.status == "range_end" else br.status
    else:
        br.points.append(eng.finish(pt, None, float(direction)))
        tr.run(br, 0, br.points[0], settings.ds)
    # period-doubling branch switching, breadth first
    queue = [0]
    while queue and settings.switch:
        bi = queue.pop(0)
        parent = branches[bi]
        for bf in list(parent.bifurcations):
            if bf.type != PERIOD_DOUBLING or 2 * parent.n > settings.max_period:
                continue
            if len(branches) >= settings.max_branches:
                break
            if _already_switched(branches, bf, eng):
                continue
            try:
                child = switch_period_doubling(eng, tr, bf, parent, bi)
            except Exception as e:   # never lose the branches already traced
                reraise_interrupt(e)
                child = Branch(n=2 * parent.n, origin=f"period doubling of branch {bi} at "
                               f"{eng.prob_name} = {bf.parameter:.10g}", status="failed_start",
                               message=f"branch switching failed: {type(e).__name__}: {e}")
            child.index = len(branches)
            for b2 in child.bifurcations:
                b2.branch = child.index
            branches.append(child)
            if child.points:
                queue.append(child.index)
    for i, b in enumerate(branches):
        b.index = i
        for bf in b.bifurcations:
            bf.branch = i
    return branches


def _already_switched(branches, bf, eng) -> bool:
    """Whether a period-2n branch already ends (merged) at the period doubling ``bf``."""
    u = eng.u_of(bf.x, bf.parameter)
    for b in branches:
        if b.n == 2 * bf.n and b.points:
            for q in (b.points[0], b.points[-1]):
                if np.linalg.norm(q.u - u) < 1e-5:
                    return True
    return False


def switch_period_doubling(eng, tr, bf, parent, bi) -> Branch:
    """Start and continue the period-2n branch born at the period doubling ``bf``."""
    n2 = 2 * bf.n
    child = Branch(n=n2, origin=f"period doubling of branch {bi} at {eng.prob_name} = {bf.parameter:.10g}")
    s = eng.shot(bf.x, bf.parameter, bf.n)
    mu, V = np.linalg.eig(s.M)
    k = int(np.argmin(np.abs(mu + 1.0)))
    v = np.real(V[:, k])
    v = v / np.linalg.norm(v)
    d = eng.d
    t0 = np.zeros(d + 1)
    t0[:d] = v  # scaled state direction (x / s_x): same direction
    u0 = eng.u_of(bf.x, bf.parameter)
    first = eng.shot(bf.x, bf.parameter, n2)
    why = ""
    for eps in (1e-3, 3e-3, 1e-2, 3e-2, 1e-1):
        for sgn in (1.0, -1.0):
            pt, why = eng.correct(u0 + sgn * eps * t0, sgn * t0, n2, radius=10 * eps)
            if pt is None:
                continue
            half = eng.shot(pt.x, pt.p, bf.n)
            if half.status != "ok" or np.max(np.abs(half.x - pt.x)) < 0.25 * eps * eng.sx:
                why = "the corrector fell back onto the period-n orbit"
                continue
            if first.status == "ok":
                p0 = eng.make_point(bf.x, bf.parameter, first)
                eng.finish(p0, None, away=None)
                p0.t = (pt.u - p0.u) / np.linalg.norm(pt.u - p0.u)
                child.points.append(p0)
            eng.finish(pt, None, away=u0)
            child.points.append(pt)
            tr.run(child, bi, pt, eng.S.ds)
            return child
    child.status = "failed_start"
    child.message = f"no period-{n2} orbit found next to the period doubling: {why}"
    return child


# ============================================================================ two parameters
@dataclass
class Curve:
    """A two-parameter curve of one bifurcation type: ``p1`` (the first parameter, e.g. the
    frequency), ``p2`` (the second, e.g. a voltage or gap), states ``x`` at the section, the
    period ``n``; ``status`` ``box`` (left the parameter box at both ends), ``max_points``,
    ``lost`` (the bifurcation could not be relocated, with the reason in ``message``)."""

    type: str
    n: int
    p1: list = field(default_factory=list)
    p2: list = field(default_factory=list)
    x: list = field(default_factory=list)
    status: str = ""
    message: str = ""


def _relocate(factory, kind, n, free, fixed, x_guess, p_guess, box, width, settings):
    """The bifurcation ``kind`` of period ``n`` nearest to ``p_guess`` in the free parameter at
    the fixed value of the other one: a short continuation in a window around ``p_guess``
    (every detection and location of :func:`trace` applies), started from ``x_guess``.

    Returns ``(p, x)`` or None."""
    prob = factory(free, fixed)
    lo, hi = max(box[0], p_guess - width), min(box[1], p_guess + width)
    if not hi > lo:
        return None
    p0 = min(max(p_guess, lo), hi)
    st = replace(settings, switch=False, max_points=40, ds=0.03, ds_max=0.15)
    sx = max(float(np.max(np.abs(x_guess))), 1e-12)
    eng = _Engine(prob, lo, hi, st, sx)
    eng.prob_name = _prob_name(prob)
    start = None
    for delta in (0.0, 0.05, 0.15, 0.3, 0.5):
        for sgn in ((1.0,) if delta == 0.0 else (1.0, -1.0)):
            p = p0 + sgn * delta * (hi - lo)
            if not lo <= p <= hi:
                continue
            pt, _ = eng.newton_fixed(x_guess, p, n)
            if pt is not None:
                start = p
                break
        if start is not None:
            break
    if start is None:
        return None
    try:
        brs = trace(prob, x_guess, start, n, lo, hi, 0, st, s_x=sx)
    except ContinuationError:
        return None
    cands = [bf for bf in brs[0].bifurcations if bf.type == kind and bf.n == n]
    if not cands:
        return None
    bf = min(cands, key=lambda b: abs(b.parameter - p_guess))
    return bf.parameter, bf.x


@with_one_blas_thread
def trace_curve(factory, bif, p2, box1, box2, settings: Settings = Settings(), max_points: int = 200,
                h0: float = 0.02, h_min: float = 2e-4, h_max: float = 0.05) -> Curve:
    """Continue the bifurcation ``bif`` (located at ``p2`` of the second parameter) in two
    parameters: a secant predictor in the scaled plane ``(p1 / w1, p2 / w2)``, and a corrector
    that relocates the bifurcation in one parameter at a fixed value of the other
    (:func:`_relocate`: the slice is the parameter the curve moves least in, so the slice
    switches where the curve turns); the step adapts (grow on success, halve on failure).

    Parameters
    ----------
    factory : callable
        ``factory("p1", value_of_p2)`` -> shooting problem continued in the first parameter at
        that value of the second; ``factory("p2", value_of_p1)`` -> in the second at that
        value of the first.
    bif : Bifurcation
        A fold, period doubling or grazing located in the first parameter.
    p2 : float
        The value of the second parameter there.
    box1, box2 : (float, float)
        Ranges of the two parameters.
    settings : Settings
        Settings of the one-parameter relocations (step, tolerances).
    max_points : int
        Most curve points.
    h0, h_min, h_max : float
        First, smallest and largest step in the scaled plane.

    Returns
    -------
    Curve
    """
    w1, w2 = box1[1] - box1[0], box2[1] - box2[0]
    kind, n = bif.type, bif.n
    halves, reasons = [], []
    for sgn in (1.0, -1.0):
        pts = [(bif.parameter, p2, np.asarray(bif.x, float))]
        h = h0
        why = "left the parameter box"
        while len(pts) < max_points // 2:
            q1, q2, xq = pts[-1]
            if len(pts) >= 2:
                d1 = (q1 - pts[-2][0]) / w1
                d2 = (q2 - pts[-2][1]) / w2
                nrm = math.hypot(d1, d2)
                trials = [(d1 / nrm, d2 / nrm)] if nrm > 0 else [(0.0, sgn)]
                wide = 1.0
            else:
                # first step, direction unknown: slice at the next p2, else at the next p1, in
                # wide windows
                trials = [(0.0, sgn), (sgn, 0.0)]
                wide = 3.0
            nxt = None
            for d1, d2 in trials:
                g1, g2 = q1 + h * d1 * w1, q2 + h * d2 * w2
                if abs(d2) >= abs(d1):       # the curve moves in p2 more than in p1: fix p2, find p1
                    if not box2[0] <= g2 <= box2[1]:
                        continue
                    r = _relocate(factory, kind, n, "p1", g2, xq, g1, box1,
                                  wide * max(4 * h * w1, 0.02 * w1), settings)
                    nxt = None if r is None else (r[0], g2, r[1])
                else:                         # fix p1, find p2
                    if not box1[0] <= g1 <= box1[1]:
                        continue
                    r = _relocate(factory, kind, n, "p2", g1, xq, g2, box2,
                                  wide * max(4 * h * w2, 0.02 * w2), settings)
                    nxt = None if r is None else (g1, r[0], r[1])
                if nxt is not None and math.hypot((nxt[0] - q1) / w1, (nxt[1] - q2) / w2) <= 3 * wide * h:
                    break
                nxt = None
            if nxt is None:
                g1, g2 = q1 + h * trials[0][0] * w1, q2 + h * trials[0][1] * w2
                if len(pts) >= 2 and not (box1[0] <= g1 <= box1[1] and box2[0] <= g2 <= box2[1]):
                    # the predictor left the box: end the curve on its edge
                    e = _edge_point(factory, kind, n, pts[-1], (g1, g2), box1, box2, w1, w2, h, settings)
                    if e is not None:
                        pts.append(e)
                    break
                h *= 0.5
                if h < h_min:
                    why = (f"the {kind} could not be relocated beyond ({q1:.8g}, {q2:.8g}) (step below "
                           f"{h_min}): the curve ends there (a cusp, a meeting with a grazing curve) or "
                           f"its orbit changes type")
                    break
                continue
            pts.append(nxt)
            h = min(1.5 * h, h_max)
        else:
            why = "max_points"
        halves.append(pts)
        reasons.append(why)
    if len(halves[1]) > 1 and len(halves[0]) > 1:
        probe = Curve(type=kind, n=n, p1=[q[0] for q in halves[0]], p2=[q[1] for q in halves[0]])
        if _on_curve(probe, halves[1][1][0], halves[1][1][1], w1, w2, tol=0.25 * h0):
            halves[1] = halves[1][:1]        # the second half retraced the first
    both = halves[1][:0:-1] + halves[0]
    c = Curve(type=kind, n=n, p1=[q[0] for q in both], p2=[q[1] for q in both], x=[q[2] for q in both])
    if all(r == "left the parameter box" for r in reasons):
        c.status, c.message = "box", ""
    elif any(r == "max_points" for r in reasons):
        c.status, c.message = "max_points", f"{max_points} points"
    else:
        c.status = "lost"
        c.message = "; ".join(r for r in reasons if r != "left the parameter box")
    return c


def _edge_point(factory, kind, n, last, pred, box1, box2, w1, w2, h, settings):
    """The curve's point on the edge of the box that the predictor ``pred`` crossed."""
    q1, q2, xq = last
    g1, g2 = pred
    if not box2[0] <= g2 <= box2[1]:
        e2 = box2[1] if g2 > box2[1] else box2[0]
        t = (e2 - q2) / (g2 - q2) if g2 != q2 else 1.0
        r = _relocate(factory, kind, n, "p1", e2, xq, q1 + t * (g1 - q1), box1, max(4 * h * w1, 0.02 * w1), settings)
        return None if r is None else (r[0], e2, r[1])
    e1 = box1[1] if g1 > box1[1] else box1[0]
    t = (e1 - q1) / (g1 - q1) if g1 != q1 else 1.0
    r = _relocate(factory, kind, n, "p2", e1, xq, q2 + t * (g2 - q2), box2, max(4 * h * w2, 0.02 * w2), settings)
    return None if r is None else (e1, r[0], r[1])


def _on_curve(c: Curve, p1, p2, w1, w2, tol=2e-2) -> bool:
    """Whether ``(p1, p2)`` lies within ``tol`` (scaled plane) of the polyline of ``c``."""
    P = np.column_stack([np.asarray(c.p1) / w1, np.asarray(c.p2) / w2])
    q = np.array([p1 / w1, p2 / w2])
    if len(P) == 1:
        return float(np.linalg.norm(P[0] - q)) < tol
    a, b = P[:-1], P[1:]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
    d = np.linalg.norm(a + t[:, None] * ab - q, axis=1)
    return bool(np.min(d) < tol)


def trace_curves(factory, seeds, box1, box2, slices=(), settings: Settings = Settings(), max_points=200,
                 base_value=None, seed_slice=None, types=(FOLD, PERIOD_DOUBLING, GRAZING),
                 max_period: int = 2) -> list:
    """Two-parameter curves of the bifurcations ``seeds`` (pairs ``(Bifurcation, p2)``) and of
    those ``seed_slice(v)`` finds at each value ``v`` of ``slices`` (one-parameter branches
    at other values of the second parameter: curves that do not cross the first slice); a
    seed lying on a curve already traced is skipped, and so are orbits of period above
    ``max_period``.  Returns a list of :class:`Curve`."""
    w1, w2 = box1[1] - box1[0], box2[1] - box2[0]
    curves = []

    def covered(bf, v):
        return any(c.type == bf.type and c.n == bf.n and _on_curve(c, bf.parameter, v, w1, w2) for c in curves)

    def run(pairs):
        for bf, v in pairs:
            if bf.type in types and bf.n <= max_period and not covered(bf, v):
                curves.append(trace_curve(factory, bf, v, box1, box2, settings, max_points))

    run(seeds)
    for v in slices:
        if seed_slice is not None:
            run([(bf, v) for bf in seed_slice(v)])
    return curves


__all__ = ["Settings", "Point", "Bifurcation", "Branch", "trace", "start_point", "TYPES", "ScaledParameter",
           "Curve", "trace_curve", "trace_curves",
           "FOLD", "PERIOD_DOUBLING", "NEIMARK_SACKER", "GRAZING", "STICKING", "ContinuationError"]
