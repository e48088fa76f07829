"""The shooting problem of a scene: ``P^n`` of any :class:`~vibeam.models.scene.Scene` (issue 58).

:class:`SceneShooting` gives the one shooting problem (:class:`~.shooting.ModalShooting`: one run
of the one event integrator per shot, the tangent assembled from its event log) the scene it
runs: the system, its stops and their laws as the scene holds them, whatever built it (the SDOF,
the FE beam, a user's matrices, a continuum).  The parameter is the forcing frequency ``Omega``,
the one a sweep's Floquet and Lyapunov exponents, the basins' attractors and the Lyapunov
spectrum of :func:`vibeam.api.lyapunov` need.

References
----------
R. I. Leine, H. Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, Springer
2004, Ch. 7 (shooting, monodromy of non-smooth systems).
"""
from __future__ import annotations

import math

import numpy as np

from ..scene import Scene, outputs
from .event import EventIntegrator
from .shooting import Direction, ModalShooting, Setup, directions

__all__ = ["SceneShooting"]


class SceneShooting(ModalShooting):
    """``P^n`` of a scene in the forcing frequency (contract: :mod:`vibeam.models.periodic`).

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
        ``n`` modes and their stops (any laws the event integrator takes).
    parameter : {"Omega"}
        The continuation parameter: the forcing frequency (nondimensional, the system's time
        unit).
    Omega : float, optional
        Only the reported ``value``.
    chatter_tol, steps_per_fundamental, max_impacts_per_period, max_steps_per_period :
        Settings of the event integrator (:class:`~.shooting.ModalShooting`; the ``event``
        method's defaults, so that a stable fixed point is what a sweep lands on).

    Attributes
    ----------
    dim : int
        ``2 n``: the state ``(eta, eta')`` at forcing phase 0.
    scene : Scene

    Raises
    ------
    ValueError
        For another parameter, or stops the event integrator refuses
        (:func:`vibeam.models.contact.check_stops`).
    """

    def __init__(self, scene: Scene, parameter: str = "Omega", Omega: float | None = None,
                 chatter_tol: float = 1e-7, steps_per_fundamental: int = 16,
                 max_impacts_per_period: int = 20000, max_steps_per_period: int = 20000):
        if parameter != "Omega":
            raise ValueError(f"parameter {parameter!r} is not a parameter of the scene's shooting problem; "
                             f"allowed: Omega")
        super().__init__(chatter_tol, steps_per_fundamental, max_impacts_per_period, max_steps_per_period)
        self.scene = scene
        self.parameter = parameter
        self.index = 0
        self.value = math.nan if Omega is None else float(Omega)
        s = scene.system
        self._omega = np.asarray(s.omega, float)
        self._undamped = np.asarray(s.damping, float) == 0.0
        self.dim = 2 * int(self._omega.size)
        self._core = EventIntegrator(scene)
        z = np.zeros(self._core.n_stops)
        self._dirs = directions(self._core, [Direction("Omega", 1.0, 0.0, z, z, np.zeros(self._omega.size))])
        self._gap = outputs(scene).Delta
        self._scale = float(s.coordinate_scale)

    def setup(self, p: float) -> Setup:
        """The scene's integrator and the direction of ``Omega`` at ``Omega = p`` (built once)."""
        return Setup(self._core, float(p), self._dirs, self._gap, self._scale)

    def invalid(self, p: float) -> str:
        """Why ``Omega = p`` has no shot ('' if it has): ``Omega`` not positive, or an undamped
        mode at exact resonance (no periodic particular solution)."""
        if not (math.isfinite(p) and p > 0.0):
            return f"Omega must be positive and finite, got {p!r}"
        res = np.flatnonzero(self._undamped & (self._omega ** 2 == float(p) ** 2))
        if res.size:
            return f"undamped exact resonance of mode {int(res[0])}: no periodic particular solution"
        return ""

    def frequency_corrector(self) -> bool:
        """The compiled corrector serves a scene without an undamped mode (with one, a
        resonance is a validity beyond ``Omega > 0`` that the corrector does not check)."""
        return not bool(self._undamped.any())
