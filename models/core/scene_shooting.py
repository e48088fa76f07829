"""The shooting problem of a scene: ``P^n`` of any :class:`~vibeam.models.scene.Scene` (issue 58).

:class:`SceneShooting` gives the one shooting problem (:class:`~.shooting.ModalShooting`: one run
of the one event integrator per shot, the tangent assembled from its event log) the scene it
runs: the system, its stops and their laws as the scene holds them, whatever built it (the SDOF,
the FE beam, a user's matrices, a continuum).  Its parameter is a path into the scene
(:data:`PATHS`): the forcing frequency, the drive's amplitude, a stop's offset, a law's ``R``, the
modal damping along a given direction; the scene at a value is :meth:`SceneShooting.scene_at`, the
exact ``d x / d p`` comes from the parameter's :class:`~.shooting.Direction`.  It serves
continuation (every fidelity, :func:`vibeam.analysis.branches.problem`), a sweep's Floquet and
Lyapunov exponents, the basins' attractors and :func:`vibeam.api.lyapunov`.

Starts (:meth:`SceneShooting.start`): ``linear``, the contact-free harmonic steady state of any
scene (each stop's amplitude below its offset); ``averaging``, the paper's averaged period-1 orbit
(Eqs. 18-23, refined on the impact map, Eqs. 33-34) of the one-mode oscillator only
(:func:`~vibeam.models.scene.one_mode`), computed above the core by the function the registry names
(:data:`vibeam.models.registry.STARTS`: :func:`vibeam.models.mapping.start.shooting_start`).

References
----------
R. I. Leine, H. Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, Springer
2004, Ch. 7 (shooting, monodromy of non-smooth systems); I. A. Hiskens, M. A. Pai, IEEE TCAS-I 47
(2000) 204 (parameter sensitivities through events).
"""
from __future__ import annotations

import dataclasses
import math
import re

import numpy as np

from ..contact import check_stops, restitution_problem
from ..impact import restitution_at
from ..registry import STARTS, resolve
from ..scene import Scene, one_mode, outputs, with_amplitude
from ..system import forcing, modal_flow, particular
from .event import EventIntegrator
from .integrator import EV_IMPACT, EV_STICK_IMPACT
from .shooting import Direction, ModalShooting, Setup, directions

__all__ = ["SceneShooting", "PATHS"]

TWO_PI = 2.0 * math.pi

#: the parameters of a scene's shooting problem: the forcing frequency, the drive's amplitude
#: (``system.base_amplitude``), a stop's offset and its law's ``R`` (``k`` its index; a tuple of
#: such paths moves them together), the modal damping coefficients along a direction
PATHS = ("Omega", "system.base_amplitude", "stops[k].relation.offset", "stops[k].law.R", "system.damping")

_STOP = re.compile(r"stops\[(\d+)\]\.(relation\.offset|law\.R)$")


def _parse(scene: Scene, parameter) -> tuple[str, tuple]:
    """``(kind, stop indices)`` of a parameter path (or a tuple of stop paths of one kind)."""
    paths = (parameter,) if isinstance(parameter, str) else tuple(parameter)
    allowed = f"allowed: {', '.join(PATHS)}"
    if len(paths) == 1 and paths[0] in ("Omega", "system.base_amplitude", "system.damping"):
        return paths[0], ()
    kinds, ks = set(), []
    for p in paths:
        m = _STOP.match(str(p))
        if m is None:
            raise ValueError(f"parameter {p!r} is not a parameter of the scene's shooting problem; {allowed}")
        k = int(m.group(1))
        if k >= len(scene.stops):
            raise ValueError(f"parameter {p!r}: the scene has {len(scene.stops)} stop(s)")
        kinds.add(m.group(2))
        ks.append(k)
    if len(kinds) != 1 or len(set(ks)) != len(ks):
        raise ValueError(f"parameter {parameter!r}: paths moved together must be distinct stops' numbers of one kind")
    kind = kinds.pop()
    vals = {float(scene.stops[k].relation.offset if kind == "relation.offset" else scene.stops[k].law.R) for k in ks}
    if len(vals) > 1:
        raise ValueError(f"parameter {parameter!r}: paths moved together must hold one value, got {sorted(vals)}")
    return kind, tuple(ks)


class SceneShooting(ModalShooting):
    """``P^n`` of a scene in one of its parameters (contract: :mod:`vibeam.models.core.periodic`).

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
        ``n`` modes and their stops (any laws the event integrator takes).
    parameter : str or tuple of str
        A path of :data:`PATHS`: ``"Omega"`` (nondimensional, the system's time unit),
        ``"system.base_amplitude"`` (the drive's ``A``), ``"stops[k].relation.offset"`` (row
        units), ``"stops[k].law.R"`` (Newton's R or a compliant law's target R), or a tuple of
        stop paths of one kind set to one value (the SDOF's lower stop following the upper
        stop's ``R``), or ``"system.damping"`` with ``damping``.
    Omega : float, optional
        The forcing frequency, fixed for another parameter (required then); for ``"Omega"`` only
        the reported ``value``.
    damping : tuple (value, slope), optional
        For ``"system.damping"``: the parameter's value in the scene and ``d c / d p``, shape
        (n,): the damping coefficients at ``p`` are ``c + (p - value) slope`` (e.g. the beam's
        ``D``: ``slope = omega_ref omega_i^2``, paper Eq. 39).
    chatter_tol, steps_per_fundamental, max_impacts_per_period, max_steps_per_period :
        Settings of the event integrator (:class:`~.shooting.ModalShooting`; the ``event``
        method's defaults, so that a stable fixed point is what a sweep lands on).

    Attributes
    ----------
    dim : int
        ``2 n``: the state ``(eta, eta')`` at forcing phase 0.
    scene : Scene
    value : float
        The parameter's value in ``scene`` (NaN for ``"Omega"`` without ``Omega``).
    starts : tuple of str
        The closed-form starts the scene offers (``linear``; ``averaging`` for the one-mode
        oscillator).

    Raises
    ------
    ValueError
        For a path the problem does not carry, a missing ``Omega`` or ``damping``, ``R`` of a
        tabulated law, or stops the event integrator refuses
        (:func:`vibeam.models.contact.check_stops`).
    """

    def __init__(self, scene: Scene, parameter="Omega", Omega: float | None = None,
                 damping: tuple | None = None, chatter_tol: float = 1e-7, steps_per_fundamental: int = 16,
                 max_impacts_per_period: int = 20000, max_steps_per_period: int = 20000):
        kind, ks = _parse(scene, parameter)
        if kind != "Omega" and Omega is None:
            raise ValueError(f"continuation in {parameter!r} needs the forcing frequency Omega")
        if kind == "system.damping" and damping is None:
            raise ValueError("continuation in 'system.damping' needs damping = (value, slope)")
        if kind == "law.R" and any(len(getattr(scene.stops[k].law, "table_U", ())) for k in ks):
            raise ValueError("a tabulated restitution law cannot be continued in R (effect restitution_law)")
        super().__init__(chatter_tol, steps_per_fundamental, max_impacts_per_period, max_steps_per_period)
        self.scene = scene
        self.parameter = parameter if isinstance(parameter, str) else tuple(parameter)
        self.index = 0          # the directions hold the continuation parameter alone
        self._kind, self._ks = kind, ks
        s = scene.system
        n = int(np.asarray(s.omega).size)
        self.dim = 2 * n
        self.Omega = None if Omega is None else float(Omega)
        if kind == "system.damping":
            v0, slope = damping
            self._damp = (float(v0), np.broadcast_to(np.asarray(slope, float), (n,)).copy())
        if kind == "Omega":
            self.value = math.nan if Omega is None else float(Omega)
        elif kind == "system.base_amplitude":
            self.value = float(s.base_amplitude)
        elif kind == "relation.offset":
            self.value = float(scene.stops[ks[0]].relation.offset)
        elif kind == "law.R":
            self.value = float(scene.stops[ks[0]].law.R)
        else:
            self.value = self._damp[0]
        z = np.zeros(len(scene.stops))
        e = np.zeros(len(scene.stops))
        e[list(ks)] = 1.0
        self._dir = Direction(str(self.parameter), float(kind == "Omega"), float(kind == "system.base_amplitude"),
                              e if kind == "relation.offset" else z, e if kind == "law.R" else z,
                              self._damp[1] if kind == "system.damping" else np.zeros(n))
        self._setups = {}
        self._last = None
        if kind == "Omega":
            self._setups[None] = self._build(scene)

    # ------------------------------------------------------------------ the scene at p
    def scene_at(self, p: float) -> Scene:
        """The scene with the parameter set to ``p`` (the scene itself for ``Omega``)."""
        kind = self._kind
        if kind == "Omega" or p == self.value:
            return self.scene
        last = self._last
        if last is not None and last[0] == p:
            return last[1]
        sc, p = self.scene, float(p)
        if kind == "system.base_amplitude":
            sc = with_amplitude(sc, p)
        elif kind == "system.damping":
            v0, slope = self._damp
            sc = sc._replace(system=sc.system._replace(damping=np.asarray(sc.system.damping, float) + (p - v0) * slope))
        else:
            stops = list(sc.stops)
            for k in self._ks:
                st = stops[k]
                if kind == "relation.offset":
                    stops[k] = dataclasses.replace(st, relation=dataclasses.replace(st.relation, offset=p))
                elif st.law.kind == "impulsive":
                    stops[k] = dataclasses.replace(st, law=dataclasses.replace(st.law, R=p))
                else:       # a compliant law: its target R (the law sets its dashpot or chi)
                    stops[k] = dataclasses.replace(st, law=st.law.with_restitution(p))
            sc = sc._replace(stops=tuple(stops))
        self._last = (p, sc)
        return sc

    def _build(self, sc: Scene):
        core = EventIntegrator(sc)
        return core, directions(core, [self._dir]), outputs(sc).Delta

    def setup(self, p: float) -> Setup:
        """The scene's integrator at ``p`` and the parameter's direction (built once for
        ``Omega``, kept for the last 64 values of another parameter)."""
        key = None if self._kind == "Omega" else float(p)
        su = self._setups.get(key)
        if su is None:
            if len(self._setups) > 64:
                self._setups.clear()
            su = self._setups[key] = self._build(self.scene_at(p))
        Om = float(p) if self._kind == "Omega" else self.Omega
        return Setup(su[0], Om, su[1], su[2], float(self.scene.system.coordinate_scale))

    def invalid(self, p: float) -> str:
        """Why the parameter at ``p`` has no shot ('' if it has): ``Omega`` not positive, an
        undamped mode at exact resonance (no periodic particular solution), ``R`` out of
        ``[0, 1]`` or a compliant law's range, overlapping stops, a negative damping."""
        kind = self._kind
        if not math.isfinite(p):
            return f"{self.parameter} must be finite, got {p!r}"
        Om = float(p) if kind == "Omega" else self.Omega
        if not Om > 0.0:
            return f"Omega must be positive and finite, got {Om!r}"
        if kind == "law.R":
            bad = restitution_problem(p, "R")
            if bad:
                return f"out of range: {bad}"
        if kind in ("law.R", "relation.offset"):
            try:
                check_stops(self.scene_at(p).stops)
            except ValueError as e:
                return str(e)
        s = self.scene_at(p).system
        c = np.asarray(s.damping, float)
        if kind == "system.damping" and np.any(c < 0.0):
            return f"the damping at {self.parameter} = {p!r} is negative for mode {int(np.flatnonzero(c < 0)[0])}"
        res = np.flatnonzero((c == 0.0) & (np.asarray(s.omega, float) ** 2 == Om ** 2))
        if res.size:
            return f"undamped exact resonance of mode {int(res[0])}: no periodic particular solution"
        return ""

    def frequency_corrector(self) -> bool:
        """The compiled corrector serves a continuation in ``Omega`` of a scene without an undamped
        mode (with one, a resonance is a validity beyond ``Omega > 0`` that the corrector does not
        check)."""
        return self._kind == "Omega" and not bool(np.any(np.asarray(self.scene.system.damping) == 0.0))

    # ------------------------------------------------------------------ starting orbits
    @staticmethod
    def offered_starts(scene: Scene) -> tuple:
        """The closed-form starts of ``scene``: ``("linear", "averaging")`` for the one-mode
        oscillator (:func:`~vibeam.models.scene.one_mode`), else ``("linear",)``."""
        try:
            one_mode(scene)
        except ValueError:
            return ("linear",)
        return ("linear", "averaging")

    @property
    def starts(self) -> tuple:
        """:meth:`offered_starts` of the scene."""
        return self.offered_starts(self.scene)

    def _free(self, p):
        """The system at ``p``, ``Omega`` and the free particular solution ``(a, b)`` per mode."""
        s = self.scene_at(p).system
        Om = float(p) if self._kind == "Omega" else self.Omega
        om = np.asarray(s.omega, float)
        a, b = particular(np.asarray(s.damping, float), om * om, np.asarray(s.participation, float),
                          forcing(s, Om), Om)
        return s, Om, a, b

    def linear_amplitude(self, p: float, stop: int = 0) -> float:
        """Amplitude ``|W_k (a + i b)|`` (row units: the beam's metres) at stop ``stop``'s contact
        row of the contact-free harmonic steady state at ``p`` (closed form; its grazing is where it
        equals the stop's offset)."""
        s, _, a, b = self._free(p)
        row = np.asarray(s.contacts, float)[self.scene.stops[stop].relation.row]
        return float(abs(row @ (a + 1j * b)))

    def start(self, kind: str, p: float, n: int = 1):
        """Initial state ``(eta, eta')`` at forcing phase 0 of a closed-form or averaged orbit.

        Parameters
        ----------
        kind : {"linear", "averaging"}
            ``linear``: the contact-free harmonic steady state ``(b, Omega a)`` (paper Eq. 28's
            particular part, per mode), where each stop's amplitude ``|W_k (a + i b)|`` stays
            below its offset; ``averaging`` (one-mode oscillator only): the upper averaging branch
            (paper Eqs. 18-23, ``k = 1``) refined, where it converges to an admissible orbit, by
            Newton on the impact map (Eqs. 33-34, :func:`vibeam.models.mapping.newton_fixed_point`),
            turned into the post-impact state and carried by the free flow to the next phase 0
            (:func:`vibeam.models.mapping.start.shooting_start`, named in
            :data:`vibeam.models.registry.STARTS`).
        p : float
            Value of the parameter.
        n : int
            Period (``linear``: any; ``averaging``: 1).

        Returns
        -------
        x0 : ndarray, shape (2 n_modes,) or None
        reason : str
            Empty when the orbit exists, else why not.

        Raises
        ------
        ValueError
            A start the scene does not offer (:attr:`starts`).
        """
        if kind not in self.starts:
            raise ValueError(f"start {kind!r} is not available for this scene; allowed: {', '.join(self.starts)}")
        bad = self.invalid(p)
        if bad:
            return None, bad
        sc = self.scene_at(p)
        s, Om, a, b = self._free(p)
        if kind == "linear":
            W = np.asarray(s.contacts, float)
            for st in sc.stops:
                A = float(abs(W[st.relation.row] @ (a + 1j * b)))
                if not A < st.relation.offset:
                    return None, (f"the non-impacting orbit does not exist: its amplitude {A:.6g} at the {st.name} "
                                  f"stop reaches its offset {st.relation.offset:.6g} at {self.parameter} = {p:.6g}")
            return np.concatenate([b, Om * a]), ""
        if n != 1:
            return None, f"the {kind} start gives period-1 orbits only (k = 1)"
        # a start computed above the core (the paper's averaging), named in the registry
        return resolve(STARTS[kind])(self, sc, s, Om, p)

    # ------------------------------------------------------------------ section crossing
    def resect(self, x0, p: float, n: int = 1):
        """The same orbit seen on the other side of an impact that coincides with the section.

        When an impact of the orbit through ``x0`` approaches forcing phase 0 (the first one at
        ``t -> 0+`` or the last one at ``t -> n T-``, within ``1e-6 T``), the state at the section
        jumps between the pre- and post-impact states although the orbit does not.  Returns the
        state at phase 0 with that impact moved to the other side of the section: the
        post-impact state of the first impact (Newton's impulse, paper Eq. 41), or the pre-impact
        state of the last one; None if no impact lies there, or the stops are compliant (a
        contact with a duration: no jump).

        One mode: the state is carried across the gap to the section by the free flow (paper
        Eq. 28), exact.  Several: it is not (first order in the gap; the engine's Newton
        corrects it beyond the crossing), since with the stiff, overdamped high modes of a fine
        mesh the impulse sets off damping forces of order ``c_i U`` and the carried state is a
        virtual one whose contact velocity may point into the stop (measured with all 46 modes
        of the rig: a spurious impact 1e-10 T after the section).
        """
        sc = self.scene_at(p)
        if any(st.law.kind != "impulsive" for st in sc.stops):
            return None
        s = self.shot(x0, p, n, derivatives=False)
        if s.status != "ok" or not s.n_impacts:
            return None
        kinds = s.extra["event_kinds"]
        rows = np.flatnonzero((kinds == EV_IMPACT) | (kinds == EV_STICK_IMPACT))
        if not rows.size:
            return None
        sys_, Om, _, _ = self._free(p)
        T = TWO_PI / Om
        N = self.dim // 2
        times, states = s.extra["event_times"], s.extra["event_states"]
        i, j = rows[0], rows[-1]
        if times[i] < 1e-6 * T and kinds[i] == EV_IMPACT:
            eta, etad = states[i, :N].copy(), states[i, N:].copy()
            core = self.setup(p).core
            k = int(s.extra["event_stops"][i])
            nv, law = core.kstops.normal[k], sc.stops[k].law
            U = float(nv @ etad)
            Rc = restitution_at(U, law.R, np.asarray(law.table_U, float), np.asarray(law.table_R, float))
            etad -= nv * (1.0 + Rc) * U * float(core.kstops.m_eff[k])
            if N == 1:
                eta, etad = modal_flow(sys_, times[i], 0.0, eta, etad, Om)
            return np.concatenate([eta, etad])
        if times[j] > n * T - 1e-6 * T and kinds[j] == EV_IMPACT:
            if N == 1:
                return np.concatenate(modal_flow(sys_, times[j], n * T, states[j, :1], states[j, 1:], Om))
            return states[j].copy()
        return None
