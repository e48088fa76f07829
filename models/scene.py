"""The scene: one modal system and its stops, the only thing the methods' cores are built from.

A :class:`Scene` is Siconos' split (a ``NonSmoothDynamicalSystem`` of one ``LagrangianLinearTIDS``
and its ``Interaction``\\ s): ``system``, the base-excited linear system in modal coordinates
(:class:`vibeam.models.system.ModalSystem`; the SDOF is its one-mode case), and ``stops``, a tuple
of :class:`vibeam.models.contact.Stop` (relation, law), each law the only holder of its numbers,
in the system's units.  The units (seconds, metres and kilograms per unit of time, displacement
and effective mass) are the system's own fields, so nothing holds them twice; :func:`outputs`
reads what results are reported in.

The drive is the system's (its forcing vector, amplitude and exponent ``p``: ``f Omega^p A
sin(Omega t)``); :func:`driven` sets it from an :class:`Excitation` in SI units: a harmonic base
displacement (the paper's shaker), base acceleration or point force.

The fidelities are builders of scenes: :func:`vibeam.models.builders.sdof.sdof` (paper Eqs. 1-2, 43-46) and
:mod:`vibeam.models.builders.beam` (the modal FE beam, Eqs. 39-42, with any number of modes or the
static mode), :mod:`vibeam.models.builders.matrices` (a structure given by matrices, a continuum).  The event integrator
(:class:`vibeam.models.core.event.EventIntegrator`), the direct integrator, the shooting problems,
the N-mode mapping and the basins take a Scene.

References
----------
V. Acary, B. Brogliato, *Numerical Methods for Nonsmooth Dynamical Systems*, Springer 2008,
Ch. 3 and 7 (relations, laws, the event-driven scheme); Siconos' ``NonSmoothDynamicalSystem``.
"""
from __future__ import annotations

import dataclasses
import math
from numbers import Integral
from typing import NamedTuple, Optional

import numpy as np

import scipy.linalg

from .system import ModalSystem, reference_hz

__all__ = ["Scene", "outputs", "Outputs", "one_mode", "OneMode", "rest_state", "held_modes", "Excitation", "EXCITATION_KINDS",
           "driven"]

#: the harmonic drives of a scene (:class:`Excitation`)
EXCITATION_KINDS = ("base_displacement", "base_acceleration", "force")


class Scene(NamedTuple):
    """One modal system and its stops (plain data).

    Attributes
    ----------
    system : ModalSystem
        ``n`` modes; its contact rows ``system.contacts`` (shape ``(n_c, n)``) are what the stops'
        relations reference.
    stops : tuple of vibeam.models.contact.Stop
        ``(relation, law)`` pairs (checked by the integrator that takes the scene:
        :func:`vibeam.models.contact.check_stops`), at most :data:`vibeam.models.core.stops.MAX_STOPS`; a compliant
        law's stiffness in the system's units (force per row unit over the effective mass, per unit
        time squared).
    builder : str
        The name of the builder that made it (``"sdof"``, ``"beam"``, ``"matrices"``,
        ``"continuum"``, ``"mesh"``; ``""`` unknown): provenance the results record, never a branch.
    """

    system: ModalSystem
    stops: tuple
    builder: str = ""


class Outputs(NamedTuple):
    """What a scene's results are reported in (:func:`outputs`): its physical units and the gap
    ``Delta`` the amplitude is measured from (paper Sec. 4.1, ``Q = Delta - min q``).

    Attributes
    ----------
    natural_frequency_hz : float or None
        Hz per unit of ``Omega``, the builder's own (the SDOF's ``f_n``, the beam's ``f_ref``;
        :func:`vibeam.models.system.reference_hz`); None for a nondimensional scene.
    length_m : float or None
        Metres per unit of the reported ``q`` (``L``); None for a nondimensional scene.
    force_scale_n : float or None
        Newtons per unit of the nondimensional contact force ``F / (m_eff omega_ref^2 L)``,
        ``mass_unit_kg m_eff length_unit_m / time_unit_s^2`` with ``m_eff = 1 / |W[0]|^2``
        (joules per unit of energy: this times ``length_m``); None without a known mass.
    Delta : float
        The first stop's gap seen at the sensor, in units of ``q``: its offset over the contact
        row's static ratio (``contact_static``, paper Eq. 45's ``Delta_G = Delta_C / phi(x_m)``)
        and ``coordinate_scale``; NaN for a scene without stops.
    n_modes : int
        The modes of the system.
    m_eff : float
        Effective mass at the first contact row, ``1 / |W[0]|^2`` (units of ``mass_unit_kg``).
    phi_contact : float
        The first contact row's static ratio to the sensor (1 for the SDOF).
    """

    natural_frequency_hz: Optional[float]
    length_m: Optional[float]
    force_scale_n: Optional[float]
    Delta: float
    n_modes: int
    m_eff: float
    phi_contact: float


def outputs(sc: Scene) -> Outputs:
    """The units and reference gap of ``sc``'s results (:class:`Outputs`), from its system and
    first stop alone: what the sweep engine, the attractors and the fit report in."""
    s = sc.system
    cs = np.ones(s.contacts.shape[0]) if s.contact_static is None else s.contact_static
    T, L, mu = s.time_unit_s, s.length_unit_m, s.mass_unit_kg
    m_eff = float(1.0 / np.sum(np.asarray(s.contacts[0], float) ** 2))
    fn = None if math.isnan(T) else reference_hz(s)
    fs = None if math.isnan(T) or math.isnan(L) or math.isnan(mu) else mu * m_eff * L / (T * T)
    Delta = math.nan
    if sc.stops:
        rel = sc.stops[0].relation
        Delta = rel.offset / float(cs[rel.row]) / s.coordinate_scale
    return Outputs(fn, None if math.isnan(L) else float(L), fs, float(Delta), int(s.omega.shape[0]), m_eff,
                   float(cs[0]))


def with_amplitude(sc: Scene, amplitude: float) -> Scene:
    """``sc`` driven at the amplitude ``amplitude`` (``system.base_amplitude``: the base
    displacement ``B`` in coordinate units, ``B length_unit_m / coordinate_scale`` metres, or the
    drive's ``A``, :func:`vibeam.models.system.forcing`); the rows, stops and units unchanged."""
    return sc._replace(system=sc.system._replace(base_amplitude=float(amplitude)))


def with_gap(sc: Scene, Delta: float) -> Scene:
    """``sc`` with its first stop at the gap ``Delta`` seen at the sensor (units of ``q``): the
    inverse of :func:`outputs`' ``Delta``, offset ``= Delta contact_static[row] coordinate_scale``
    (paper Eq. 45, ``Delta_C = phi(x_m) Delta_G``); its other stops unchanged.

    Raises
    ------
    ValueError
        If the scene has no stop, or the first stop's row has no known static ratio (NaN).
    """
    if not sc.stops:
        raise ValueError("with_gap: the scene has no stop to place")
    s, st = sc.system, sc.stops[0]
    cs = 1.0 if s.contact_static is None else float(s.contact_static[st.relation.row])
    if math.isnan(cs):
        raise ValueError(f"with_gap: contact row {st.relation.row} has no static ratio to the sensor (NaN)")
    rel = dataclasses.replace(st.relation, offset=float(Delta) * cs * s.coordinate_scale)
    return sc._replace(stops=(dataclasses.replace(st, relation=rel),) + tuple(sc.stops[1:]))


class OneMode(NamedTuple):
    """The paper's oscillator ``q'' + 2 beta q' + q = Omega^2 B sin(Omega t)`` and its ``stops`` (paper
    Eqs. 1-2) read from a scene (:func:`one_mode`); the gaps are the relations' offsets, ``R`` the laws'."""

    beta: float
    B: float
    stops: tuple

    Delta = property(lambda self: self.stops[0].relation.offset, doc="The upper stop's gap.")
    Delta_lower = property(lambda self: self.stops[1].relation.offset if len(self.stops) > 1 else None,
                           doc="The lower stop's gap (None: one stop).")

    def initial_state(self) -> np.ndarray:
        """``(q, q', 0)``: rest at ``q = 0``, or on a pre-stressed stop (``Delta < 0``, ``Delta_lower < 0``)."""
        q = min(0.0, self.Delta)
        return np.array([q if len(self.stops) < 2 else max(q, -self.Delta_lower), 0.0, 0.0])


def one_mode(sc: Scene, method: str = "the method") -> OneMode:
    """The one-mode oscillator of ``sc``, what the SDOF methods (mapping, averaging, Zhuravlev, Ivanov,
    direct) take: ``beta = damping / 2`` (the SDOF builder's ``2 beta``, bit for bit), ``B`` and the stops.

    Raises
    ------
    ValueError
        One line naming ``method`` and what is allowed, unless the scene is the SDOF builder's kind:
        one mode, ``omega = Gamma = s = W = coordinate_scale = 1``, a base displacement drive and a
        stop at ``q = Delta`` (sign +1), optionally one at ``q = -Delta_lower`` (sign -1), on row 0.
    """
    s, st = sc.system, tuple(sc.stops)
    signs = tuple(float(x.relation.sign) for x in st)
    if not (s.contacts.shape == (1, 1) and s.omega[0] == s.participation[0] == s.sensor[0] == s.contacts[0, 0] == 1.0
            and s.coordinate_scale == 1.0 and s.drive_power == 2 and signs in ((1.0,), (1.0, -1.0))
            and all(x.relation.row == 0 for x in st)):
        raise ValueError(f"{method} takes the one-mode oscillator of paper Eqs. 1-2, got {s.omega.shape[0]} mode(s), "
                         f"drive power {s.drive_power}, stops of signs {signs}; allowed: one mode with omega = 1 and "
                         f"unit rows, a base displacement drive, a stop at q = Delta and optionally one at q = -Delta_lower")
    return OneMode(float(s.damping[0]) / 2.0, float(s.base_amplitude), st)


def held_modes(w, K) -> tuple[np.ndarray, np.ndarray]:
    """The modes of a modal system held on a stop of row ``w``: ``eta = eta_c + Psi zeta`` with
    ``Psi`` an orthonormal basis of the null space of ``w`` in which the held stiffness ``Psi^T K
    Psi = diag(nu^2)`` is diagonal (Acary & Brogliato 2008, Sec. 7.2).

    Parameters
    ----------
    w : ndarray, shape (n,)
        The contact row.
    K : ndarray, shape (n, n)
        The modal stiffness ``diag(omega^2)`` (system units).

    Returns
    -------
    Psi : ndarray, shape (n, n - 1)
    nu2 : ndarray, shape (n - 1,)
        The held system's squared frequencies, ascending.
    """
    N = w.size
    if N < 2:
        return np.zeros((1, 0)), np.zeros(0)
    Q, _ = np.linalg.qr(np.column_stack([w, np.eye(N)]))
    Tn = Q[:, 1:N]
    nu2, V = scipy.linalg.eigh(Tn.T @ K @ Tn)
    return Tn @ V, nu2


def rest_state(sc: Scene) -> np.ndarray:
    """The state a run starts from by default: rest at the origin, or held on a pre-stressed stop
    of the system's first contact row (the attached mass).

    When the first stop on row 0 has a negative offset (pre-stressed: the structure at rest would
    be beyond it), the state is the static equilibrium held on it, ``eta = eta_c + Psi e`` with
    ``eta_c = s w Delta / |w|^2`` on the relation ``s w^T eta = Delta``, ``Psi`` (shape (n, n - 1))
    the modes of the held system (the null space of ``w``, made K-orthogonal) and ``e = -Psi^T K
    eta_c / nu^2`` its static coordinates (``K = diag(omega^2)``); else the same on the second stop
    of row 0 when it is pre-stressed.  The one-mode oscillator's is ``q = Delta`` (or
    ``-Delta_lower``), :meth:`OneMode.initial_state`.  (Reduction of the held system: Acary &
    Brogliato 2008, Sec. 7.2; the beam's held phase, paper Sec. 6.)

    Parameters
    ----------
    sc : Scene

    Returns
    -------
    ndarray, shape (2 n + 1,)
        ``(eta, eta', 0)``: the held code 0 (the integrator finds the contact at its first step).
    """
    s = sc.system
    w = np.asarray(s.contacts[0], float)
    N = w.size
    out = np.zeros(2 * N + 1)
    at_mass = [st for st in sc.stops if st.relation.row == 0][:2]
    held = next((st for st in at_mass if st.relation.offset < 0), None)
    if held is None:
        return out
    w2 = float(w @ w)
    K = np.diag(np.asarray(s.omega, float) ** 2)
    Psi, nu2 = held_modes(w, K)
    D = held.relation.offset
    eta_c = w * D / w2 if held.relation.sign > 0 else w * (-D) / w2
    eC = -(Psi.T @ (K @ eta_c)) / np.where(nu2 > 0, nu2, 1.0)
    out[:N] = eta_c + Psi @ eC
    return out


class Excitation(NamedTuple):
    """A harmonic drive ``amplitude sin(Omega t)`` in SI units (plain data; :func:`driven` applies it).

    Attributes
    ----------
    kind : str
        One of :data:`EXCITATION_KINDS`:

        ``"base_displacement"``
            The base moves by ``b = Y sin(Omega t)`` (the paper's shaker, Eqs. 38, 43); every DOF
            translates with it (the system's participation ``Gamma``); the forcing grows as
            ``Omega^2``.
        ``"base_acceleration"``
            The base accelerates by ``b'' = -a sin(Omega t)`` (the acceleration of the displacement
            drive above with ``a = Omega^2 Y``, so both drives have the same phase), of fixed
            amplitude at every frequency (what a shaker controller holds in a sine sweep).
        ``"force"``
            A force ``F0 sin(Omega t)`` on the structure at one output row, along the row's
            positive direction (the displacement it reads).
    amplitude : float
        ``Y`` (m), ``a`` (m/s^2) or ``F0`` (N).
    at : int or None
        A force's point: the index ``j`` of the system's contact row ``contacts[j]`` (the SDOF: 0,
        its coordinate; a matrix model: the row of a DOF named among its ``contacts``, which need
        not carry a stop); None for a base drive.
    """

    kind: str
    amplitude: float
    at: Optional[int] = None


def driven(system: ModalSystem, excitation: Excitation) -> ModalSystem:
    """``system`` driven by ``excitation``: its forcing vector ``f`` (``participation``), amplitude
    ``A`` (``base_amplitude``) and exponent ``p`` (``drive_power``) in system units.

    With the system's row unit ``u = length_unit_m / coordinate_scale`` metres (the SDOF: ``L``;
    the beam and a matrix model: 1 m) and ``T = time_unit_s`` (the forcing of mode ``i`` is ``f_i
    Omega^p A sin(Omega t)`` in the nondimensional time ``t = t~ / T``):

    ====================  =========  ================================  =====
    kind                  ``f``      ``A``                             ``p``
    ====================  =========  ================================  =====
    base displacement Y   ``Gamma``  ``Y / u``                         2
    base acceleration a   ``Gamma``  ``a T^2 / u``                     0
    force F0 at row j     ``W[j]``   ``F0 T^2 / (mass_unit_kg u)``     0
    ====================  =========  ================================  =====

    (``M x~'' + C x~' + K x = -M r b''`` or ``= e_j F0 sin``, reduced by the mass-normalised modes
    and ``d/dt = T d/dt~``; the SDOF ``q'' + 2 beta q' + q = F0 / (m omega_n^2 L) sin(Omega t)``.)
    A base acceleration ``a = Omega^2 Y`` gives the displacement drive's forcing at that
    ``Omega``.

    Parameters
    ----------
    system : ModalSystem
        As built (:func:`vibeam.models.system.sdof_system`, :func:`~vibeam.models.builders.matrices.modal_scene`,
        :func:`vibeam.models.builders.matrices.build_matrices`): its ``participation`` is the base
        participation ``Gamma`` (a system already driven by a force has lost it: drive the built
        system).
    excitation : Excitation

    Returns
    -------
    ModalSystem
        A copy with ``participation``, ``base_amplitude`` and ``drive_power`` set; the rest shared.

    Raises
    ------
    ValueError
        One line naming the kind and what is allowed: an unknown kind; a non-finite amplitude; a
        point ``at`` for a base drive, or a force without a contact row ``0 <= at < n_c``; a drive in
        SI units on a system without them (``length_unit_m``, and ``time_unit_s`` for an
        acceleration or force, NaN: a nondimensional scene); a force on a system without a mass
        unit (``mass_unit_kg`` NaN: an SDOF without ``mass_kg``).
    """
    kind, amp, at = excitation
    if kind not in EXCITATION_KINDS:
        raise ValueError(f"excitation kind {kind!r}; allowed: {', '.join(EXCITATION_KINDS)}")
    try:
        amp = float(amp)
    except (TypeError, ValueError):
        amp = math.nan
    if not math.isfinite(amp):
        raise ValueError(f"excitation {kind}: amplitude = {excitation.amplitude!r}; allowed: a finite number "
                         f"({'m' if kind == 'base_displacement' else 'm/s^2' if kind == 'base_acceleration' else 'N'})")
    u = float(system.length_unit_m) / float(system.coordinate_scale)
    T = float(system.time_unit_s)
    if not (math.isfinite(u) and u > 0):
        raise ValueError(f"excitation {kind}: the system has no length unit (length_unit_m = "
                         f"{system.length_unit_m!r}); allowed: a physical system (an SDOF with length_m, a beam, "
                         f"matrices)")
    if kind != "base_displacement" and not (math.isfinite(T) and T > 0):
        raise ValueError(f"excitation {kind}: the system has no time unit (time_unit_s = {system.time_unit_s!r}); "
                         f"allowed: a physical system (an SDOF with natural_frequency_hz, a beam, matrices)")
    if kind != "force":
        if at is not None:
            raise ValueError(f"excitation {kind}: at = {at!r}; allowed: none (a base drive moves every DOF; "
                             f"'at' is a force's point)")
        if kind == "base_displacement":
            return system._replace(base_amplitude=amp / u, drive_power=2)
        return system._replace(base_amplitude=amp * T * T / u, drive_power=0)
    n_c = system.contacts.shape[0]
    if isinstance(at, bool) or not isinstance(at, Integral) or not 0 <= int(at) < n_c:
        raise ValueError(f"excitation force: at = {at!r}; allowed: the index of one of the system's {n_c} "
                         f"contact row(s), 0 to {n_c - 1}")
    mu = float(system.mass_unit_kg)
    if not (math.isfinite(mu) and mu > 0):
        raise ValueError(f"excitation force: the system has no mass unit (mass_unit_kg = {system.mass_unit_kg!r}); "
                         f"allowed: a system with masses (an SDOF with mass_kg, a beam, matrices)")
    f = np.array(system.contacts[int(at)], dtype=float, order="C")
    return system._replace(participation=f, base_amplitude=amp * T * T / (mu * u), drive_power=0)
