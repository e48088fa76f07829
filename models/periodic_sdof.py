"""Shooting problem of the SDOF coefficient-of-restitution oscillator (paper Eqs. 1-2, 28).

``P^n`` is the one shooting problem of the modal system
(:class:`vibeam.models.core.shooting.ModalShooting`) on the oscillator as its one-mode case
(:func:`vibeam.models.system.from_sdof`): one run of the one event integrator (its event /
chatter / sticking policy is the ``event`` method's) from the stroboscopic section for ``n``
forcing periods with its event log, then the derivatives assembled from that log in compiled
code, so one shot is one call into compiled code whatever the number of events.  This module
maps the SDOF's parameters (:data:`PARAMETERS`) onto the problem's directions and adds the
SDOF's starting orbits and section crossing.

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
surface ``h = -q - Delta_lower`` (``h_p = 0`` but along ``Delta_lower``), the reset
``q' -> -R_lower q'`` and so the same saltation formula with the signed pre-impact velocity; the
mass held on it is at ``(-Delta_lower, 0)``.  Its grazing (a free-flight minimum touching
``-Delta_lower``) is watched through the logged minima (``apex_gap`` is the nearer of the two
stops' gaps at the interior extrema).  Hence ``det M = R^(2 m_up) R_lower^(2 m_low)
exp(-2 beta n T)`` for ``m_up`` and ``m_low`` impacts on the two stops and no sticking, ``M = 0``
with sticking.  All quantities nondimensional.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .core.event import EventIntegrator
from .contact import Restitution, restitution_problem
from .core.shooting import Direction, ModalShooting, Setup, directions
from .periodic import Shot
from .sdof_flow import particular_coefficients

TWO_PI = 2.0 * math.pi

#: native continuation parameters of every SDOF model, in the column order of the kernel's d/dp
PARAMETERS = ("Omega", "B", "Delta", "R", "beta")
_ORDER = (4, 1, 3, 2, 0)   # position of each parameter in (beta, B, R, Delta, Omega)
#: the lower stop's offset and R, native parameters of a two-sided model only (columns 5 and 6)
LOWER = ("Delta_lower", "R_lower")


class SDOFShooting(ModalShooting):
    """Shooting problem ``P^n`` of the SDOF CoR oscillator (contract: :mod:`vibeam.models.periodic`).

    The one shooting problem of the modal system (:class:`vibeam.models.core.shooting.ModalShooting`)
    on the oscillator as its one-mode case; this class maps the SDOF's parameters onto it and adds
    the SDOF's own starts (``linear``, ``averaging``) and section crossing (:meth:`resect`).

    Parameters
    ----------
    model : SDOF
        The oscillator (constant ``R``; a velocity-dependent ``R_table`` is not supported), with
        one stop or two (``Delta_lower``, ``R_lower``: a shot's ``extra["impact_stops"]`` gives
        the stop of each impact, 0 upper, 1 lower).
    parameter : {"Omega", "B", "Delta", "R", "beta", "Delta_lower", "R_lower"}
        (:data:`PARAMETERS`, then :data:`LOWER`)
        Continuation parameter (native, nondimensional); the lower stop's offset and R (its
        Newton R, or a compliant law's target R) with a lower stop only.
    Omega : float, optional
        Forcing frequency; required unless ``parameter == "Omega"`` (then it is only the
        reported ``value``).
    chatter_tol : float, optional
        Chatter accumulation tolerance of the event integrator (the event policy of method
        ``event``).

    Raises
    ------
    ValueError
        For an unknown parameter, a missing ``Omega``, a model with ``R_table`` or a lower stop's
        parameter without a lower stop.
    """

    dim = 2

    def __init__(self, model, parameter: str = "Omega", Omega: float | None = None,
                 chatter_tol: float = 1e-7, **settings):
        if parameter not in PARAMETERS + LOWER:
            raise ValueError(f"parameter {parameter!r} is not a parameter of the SDOF model; "
                             f"allowed: {', '.join(PARAMETERS + LOWER)}")
        if parameter != "Omega" and Omega is None:
            raise ValueError(f"continuation in {parameter!r} needs the forcing frequency Omega")
        if getattr(model, "R_table", ()):
            raise ValueError("the shooting problem supports a constant R only (no restitution_law)")
        if parameter in LOWER and not getattr(model, "two_sided", False):
            raise ValueError(f"continuation in {parameter!r} needs a lower stop (Delta_lower)")
        super().__init__(chatter_tol=chatter_tol)
        self.model = model
        self.parameter = parameter
        self.index = (PARAMETERS + LOWER).index(parameter)
        self.Omega = None if Omega is None else float(Omega)
        #: the upper stop's law when it is compliant (R is then its target restitution)
        self.law = getattr(model, "contact", None)
        #: a compliant stop in the scene: the continuation parameter's direction alone
        self.compliant = any(getattr(s.law, "kind", "") == "compliant" for s in model.stops())
        R0 = float(model.stops()[0].law.R)      # Newton's R, or the compliant law's target R
        self.value = (float(Omega) if Omega is not None else math.nan) if parameter == "Omega" \
            else (R0 if parameter == "R" else float(model.stops()[1].law.R) if parameter == "R_lower"
                  else float(getattr(model, parameter)))
        # a second (lower) stop at q = -Delta_lower: its own R, or the upper stop's (then it moves
        # with R: d R_lower / d R = 1)
        self.two_sided = bool(getattr(model, "two_sided", False))
        # (beta, B, R, Delta, Omega) of the model and the slot of the continuation parameter
        self._base = [float(model.beta), float(model.B), R0, float(model.Delta), self.Omega]
        self._slot = _ORDER[self.index] if parameter not in LOWER else None
        self._setups = {}
        self._last = None

    def params(self, p: float):
        """``(beta, B, R, Delta, Omega)`` with the continuation parameter set to ``p``."""
        last = self._last
        if last is not None and last[0] == p and p != 0.0:     # (-0.0 == 0.0: recomputed)
            return last[1]      # a shot asks twice (:meth:`invalid`, :meth:`setup`)
        v = self._base.copy()
        if self._slot is not None:
            v[self._slot] = float(p)
        v = tuple(v)
        self._last = (p, v)
        return v

    def lower(self, p: float):
        """``(Delta_lower, lower_law)`` of the lower stop at ``p`` (``lower_law`` None: the upper
        stop's law; ``(inf, None)`` without a lower stop)."""
        if not self.two_sided:
            return math.inf, None
        m = self.model
        if self.parameter == "Delta_lower":
            return float(p), m.lower_law
        if self.parameter == "R_lower":
            law = m.stops()[1].law
            return float(m.Delta_lower), (Restitution(float(p)) if law.kind == "impulsive"
                                          else law.with_restitution(float(p)))
        return float(m.Delta_lower), m.lower_law

    def lower_restitution(self, R: float, p: float | None = None) -> float:
        """The lower stop's R when the upper stop's is ``R`` (at ``p`` for a continuation in
        ``R_lower``): its own law's, or ``R``; None for a compliant lower law of its own."""
        law = self.lower(self.value if p is None else p)[1] if self.two_sided else None
        if law is None:
            return float(R)
        return float(law.R) if getattr(law, "kind", "") == "impulsive" else None

    def invalid(self, p: float) -> str:
        beta, B, R, Delta, Omega = self.params(p)
        if restitution_problem(R) or not (0.0 <= beta < 1.0 and Omega is not None and Omega > 0.0
                                          and math.isfinite(B) and math.isfinite(Delta)):
            return f"parameters out of range (beta {beta}, R {R}, Omega {Omega})"
        if self.law is not None and R != float(self.law.R):
            try:
                self.law.with_restitution(R).check()
            except ValueError as e:
                return str(e)
        if beta == 0.0 and Omega == 1.0:
            return "undamped exact resonance: no periodic particular solution"
        Dl, lower = self.lower(p)
        if self.two_sided and not Delta + Dl > 0.0:
            return f"the stops overlap: Delta + Delta_lower = {Delta + Dl} must be > 0"
        if self.parameter == "R_lower":
            if restitution_problem(p, "R_lower"):
                return restitution_problem(p, "R_lower")
            try:
                lower.check() if hasattr(lower, "check") else None
            except ValueError as e:
                return str(e)
        return ""

    def setup(self, p: float) -> Setup:
        """The one-mode system at ``p`` with the directions of :data:`PARAMETERS` (cached: a
        continuation in Omega builds it once)."""
        beta, B, R, Delta, Omega = self.params(p)
        Dl, lower_law = self.lower(p) if self.parameter in LOWER else (None, None)
        key = (beta, B, R, Delta, Dl, None if lower_law is None else lower_law.R)
        su = self._setups.get(key)
        if su is None:
            if self.invalid(p):
                m = self.model     # a placeholder: the shot returns the reason before running
            elif self.law is not None:
                # a compliant upper stop: R is its law's target restitution (the lower stop's law
                # follows it unless it has its own)
                law = self.law if R == float(self.law.R) else self.law.with_restitution(R)
                m = replace(self.model, beta=beta, B=B, Delta=Delta, contact=law)
            else:
                m = replace(self.model, beta=beta, B=B, R=R, Delta=Delta)   # its lower_law kept (None: follows R)
            if Dl is not None and m is not self.model:
                m = replace(m, Delta_lower=Dl, lower_law=lower_law)   # the lower stop at p
            core = EventIntegrator(m.scene())
            ns = core.n_stops
            z = np.zeros(ns)
            up = np.eye(ns)[0]
            own = self.two_sided and m.lower_law is not None
            both = np.array([1.0, 0.0 if own else 1.0])[:ns]
            every = [Direction("Omega", 1.0, 0.0, z, z, np.zeros(1)),
                     Direction("B", 0.0, 1.0, z, z, np.zeros(1)),
                     Direction("Delta", 0.0, 0.0, up, z, np.zeros(1)),
                     Direction("R", 0.0, 0.0, z, both, np.zeros(1)),
                     Direction("beta", 0.0, 0.0, z, z, np.array([2.0]))]
            if ns > 1:
                # the lower stop's offset and its own R
                low = np.eye(ns)[1]
                every += [Direction("Delta_lower", 0.0, 0.0, low, z, np.zeros(1)),
                          Direction("R_lower", 0.0, 0.0, z, low if own else z, np.zeros(1))]
            # a compliant stop: the continuation parameter's direction alone (a direction that changes a
            # Kelvin-Voigt contact phase's matrix, R or beta, integrates its variational equations)
            dirs = directions(core, [every[self.index]] if self.compliant else every)
            if len(self._setups) > 64:
                self._setups.clear()
            su = self._setups[key] = (core, dirs)
        return Setup(su[0], float(Omega) if Omega is not None else math.nan, su[1], float(Delta), 1.0)

    @property
    def column(self) -> int:
        """The continuation parameter's column among the directions of :meth:`setup`."""
        return 0 if self.compliant else self.index

    def frequency_corrector(self) -> bool:
        """The compiled corrector serves a continuation in Omega with damping (without it,
        ``Omega = 1`` is a resonance the shot refuses, a validity beyond ``Omega > 0``)."""
        return self.parameter == "Omega" and float(self.model.beta) > 0.0

    def shot(self, x0, p, n=1, derivatives: bool = True, stuck=None) -> Shot:
        """``P^n(x0; p)`` with monodromy and ``d/dp`` (:meth:`ModalShooting.shot`).

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
            ``extra["x_all_p"]`` holds ``d x / d(Omega, B, Delta, R, beta)`` (shape (2, 5); with a
            lower stop (2, 7), ``Delta_lower`` and ``R_lower`` after them, the latter zero when
            the lower stop follows ``R``);
            ``extra["stuck_end"]`` whether the mass is on the stop at the end.
        """
        return super().shot(x0, p, n, derivatives, stuck)

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
        if self.compliant:
            return None     # a compliant contact has a duration: no jump of the section's state
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
            return -self.lower(p)[0], -1.0, self.lower_restitution(R, p)

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
            :func:`vibeam.models.mapping.newton_fixed_point`), turned into the
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
            Dl = self.lower(p)[0]
            if self.two_sided and not C < Dl:
                return None, (f"the non-impacting orbit does not exist: its amplitude C = {C:.6g} "
                              f"reaches the lower stop Delta_lower = {Dl:.6g} at "
                              f"{self.parameter} = {p:.6g}")
            return np.array([b, Omega * a]), ""
        if kind == "averaging":
            if n != 1:
                return None, "the averaging start gives period-1 orbits only (k = 1)"
            from dataclasses import replace
            from .sdof_averaging import solve
            from .mapping import is_admissible, newton_fixed_point
            r = solve(Omega, beta, B, R, Delta, 1)
            Q = float(r["amplitude"])
            if not np.isfinite(Q):
                return None, f"averaging has no real amplitude at {self.parameter} = {p:.6g}"
            phi, v = float(r["impact_phase"]), Q
            # refine on the impact map (Newton on the closed form, paper Eqs. 33-34): averaging is
            # a first-order guess, poor for R well below 1
            m = replace(self.model, beta=beta, B=B, R=R, Delta=Delta).scene()
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
                Dl = self.lower(p)[0]
                if sh.status != "ok" or np.any(sh.extra["impact_stops"] == 1) or sh.q_min <= -Dl:
                    return None, (f"the averaging orbit reaches the lower stop Delta_lower = "
                                  f"{Dl:.6g} at {self.parameter} = {p:.6g}")
            return x0, ""
        raise ValueError(f"unknown start {kind!r}; allowed: {', '.join(self.starts)}")


def _failed(message: str) -> Shot:
    nan2 = np.full(2, np.nan)
    return Shot(x=nan2, M=np.full((2, 2), np.nan), x_p=nan2.copy(), impact_times=np.zeros(0),
                impact_velocities=np.zeros(0), q_min=np.nan, q_max=np.nan, status="failed",
                message=message)
