"""Periodic orbits of the impacting fidelities as zeros of a shooting residual: the contract.

A period-n orbit of the base-excited impacting system is a fixed point of the n-th iterate
of the stroboscopic map ``P`` (section at forcing phase 0, i.e. ``t = k T``, ``T = 2 pi /
Omega``).  Each fidelity provides a *shooting problem* that evaluates ``P^n`` on its exact
flow (closed-form flow between events, the impact law, sticking phases with their release
times), together with exact first derivatives:

    x_n = P^n(x_0; p)
    M   = d x_n / d x_0       (monodromy: transition matrices of the flight segments composed
                               with the saltation matrices of the impacts and the maps of the
                               sticking phases; its eigenvalues are the Floquet multipliers)
    x_p = d x_n / d p         (at fixed x_0; exact, from the closed-form flow, the event-time
                               sensitivities and the derivative of the reset / release time)

The continuation engine (:mod:`vibeam.models.orbits.continuation`) solves ``F(x_0, p) = P^n(x_0; p)
- x_0 = 0`` with ``F_x = M - I`` and ``F_p = x_p``; it knows nothing about the fidelity.
Finite differences are used only as a test oracle.

Contract of a shooting problem ``prob`` (one class per fidelity)::

    prob.dim          int, size d of the state at the section
    prob.parameter    str, name of the continuation parameter (a path into the scene, or a case key)
    prob.value        float, its value in the model the problem was built from
    prob.shot(x0, p, n) -> Shot

``x0`` has shape (d,) (SDOF: ``(q, q')``; modal beam: ``(eta, eta')``), ``p`` is the value of
the continuation parameter in the scene's units, ``n`` the number of forcing
periods.  ``shot`` never raises for a dynamical outcome: an orbit the problem cannot
represent (more events than its buffer, a non-accumulating chatter, an unsupported
configuration) comes back with ``status != "ok"`` and a ``message``.

Construction and registration: the framework builds a problem as ``cls(scene, path,
Omega=Omega, damping=damping)`` from ``vibeam.models.SHOOTING[fidelity]``
(:func:`vibeam.models.shooting_problem`: ``path`` a path into the scene; ``Omega`` the forcing
frequency of a continuation in another path, None for ``"Omega"``); the model spec's
``scene_parameter(key) -> (path, factor, damping)`` maps a case's keys onto paths.

Optional capabilities (duck-typed; used when present):

* ``Shot.gap`` and ``Shot.Omega`` (amplitude ``Q = gap - q_min`` and impact phases) and
  ``Shot.impact_accelerations``;
* ``prob.starts`` (tuple of start names besides ``"sweep"``, e.g. ``("linear",
  "averaging")``) and ``prob.start(kind, p, n) -> (x0 or None, reason)``;
* ``prob.resect(x0, p, n) -> x1 or None``: the same orbit seen on the other side of an
  impact that coincides with the section (the stroboscopic state jumps there); without it a
  branch whose impact crosses forcing phase 0 ends with a status.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Shot:
    """One evaluation of ``P^n`` from the stroboscopic section, with its derivatives and events.

    Attributes
    ----------
    x : ndarray, shape (d,)
        State after ``n`` forcing periods (forcing phase 0 again).
    M : ndarray, shape (d, d)
        Monodromy ``d x / d x0``.
    x_p : ndarray, shape (d,)
        ``d x / d p`` at fixed ``x0``.
    impact_times : ndarray, shape (m,)
        Impact instants from the section (nondimensional time, ``0 <= t < n T``).
    impact_velocities : ndarray, shape (m,)
        Pre-impact normal velocities ``U- >= 0`` of those impacts (nondimensional, in the
        units of ``q'`` of the fidelity's sweep output).
    q_min, q_max : float
        Exact extremes of the output coordinate ``q`` over the orbit (amplitude
        ``Q = Delta - q_min``, paper Sec. 4.1).
    apex_gap : float
        Largest value of the contact gap function ``g = w^T eta - Delta_C`` (SDOF: ``q -
        Delta``) at the interior maxima of the free flights, i.e. excluding the impact
        instants (``< 0`` on an admissible orbit, ``-inf`` if there is none).  Its zero is a
        grazing: a new impact is born.
    stuck_time : float
        Total time on the stop (sticking) over the ``n`` periods.
    status : str
        ``"ok"`` or the reason the orbit cannot be represented (``"failed"``, ``"chatter"``).
    message : str
        Detail when not ok.
    Omega : float
        Forcing frequency of the shot (nondimensional; NaN if the problem does not say):
        impact phases are ``Omega t mod 2 pi``.
    gap : float
        ``Delta`` of the output coordinate at the shot's parameter, so that the amplitude is
        ``Q = gap - q_min`` (NaN if the problem does not say).
    impact_accelerations : ndarray, shape (m,) or None
        Pre-impact accelerations of the contact gap (``g''(t-)``), if known.
    extra : dict
        Fidelity-specific values (e.g. the state at each impact).
    """

    x: np.ndarray
    M: np.ndarray
    x_p: np.ndarray
    impact_times: np.ndarray
    impact_velocities: np.ndarray
    q_min: float
    q_max: float
    apex_gap: float = -np.inf
    stuck_time: float = 0.0
    status: str = "ok"
    message: str = ""
    Omega: float = float("nan")
    gap: float = float("nan")
    impact_accelerations: np.ndarray | None = None
    extra: dict = field(default_factory=dict)

    @property
    def n_impacts(self) -> int:
        return int(self.impact_times.shape[0])

    @property
    def min_impact_velocity(self) -> float:
        """Smallest pre-impact velocity (its zero is a grazing of an existing impact); inf
        without impacts."""
        return float(np.min(self.impact_velocities)) if self.impact_velocities.size else np.inf

    @property
    def amplitude(self) -> float:
        """``Q = gap - q_min`` (paper Sec. 4.1); NaN if ``gap`` is unknown."""
        return self.gap - self.q_min

    def multipliers(self) -> np.ndarray:
        """Floquet multipliers (eigenvalues of ``M``), complex, ordered by decreasing modulus."""
        mu = np.linalg.eigvals(self.M).astype(complex)
        return mu[np.argsort(-np.abs(mu), kind="stable")]
