"""Vibro-impact dynamics of the FE cantilever in modal coordinates (paper Sec. 6, Eqs. 39-41).

Model
    ``M u'' + C u' + K u = -M r b''(t)``, ``b = Y sin(Omega~ t~)`` (base displacement
    amplitude ``Y = gamma~ V``, m), while the contact displacement ``U = w^T u`` (relative to
    the base, at ``L_m``) stays below the stop ``Delta_C``; Newton's impact law (Eq. 41) on
    ``U``.  With the ``N`` retained mass-normalised modes ``u = Phi eta`` each modal
    coordinate obeys::

        eta_i'' + c_i eta_i' + omega_i^2 eta_i = Gamma_i Omega~^2 Y sin(Omega~ t~),
        c_i = alpha + D omega_i^2       (Rayleigh; alpha = 0 is Eq. 39's D EI U'''')

    and ``U = sum_i w_i eta_i``, sensor ``U(L_S) = sum_i s_i eta_i``.

Units
    Time is the nondimensional ``t = omega_ref t~`` with ``omega_ref = 2 pi f_ref``, so the
    sweep's ``Omega = f / f_ref`` is the forcing frequency; modal coordinates keep their SI
    units (sqrt(kg) m), modal frequencies/damping are divided by ``omega_ref``.  Outputs
    are ``q = U(L_S) / L`` and ``q' = dq/dt`` (same measure as the SDOF model when
    ``f_ref = f_n``).

Method ``event``
    The beam is the ``N``-mode case of vibeam's one dynamical system
    (:func:`vibeam.models.system.from_beam`), simulated by the one event integrator
    (:mod:`vibeam.models.core.integrator`): the closed-form modal flow between events, every
    stop's gap scanned with certified bounds, Newton's law through the mass matrix along the
    stop's normal (``P = m_eff (U+ - U-)``, ``m_eff = 1 / |w|^2``), the one chatter / sticking
    policy (:mod:`vibeam.models.contact_policy`), and the beam held on a stop as the constrained
    modal system ``eta = eta_c + Psi zeta`` (:mod:`vibeam.models.core.stops`; with several modes
    the chatter hold lets the other modes move as in the constrained system, an O(u)
    approximation).  Method ``direct`` (:class:`BeamODESolver`) integrates the same modes with
    ``solve_ivp`` and events.
"""
from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
from numba import njit

from .trajectory import Trajectory

from .contact import Relation, Restitution, Stop
from .core.direct import DirectIntegrator
from .core.event import EventIntegrator, stop_codes
from .impact import newton_restitution, restitution_impulse
from .scene import Excitation, Scene, beam_scene, driven, held_modes, rest_state
from .system import advance_modes, forcing, mode_table, particular, transition_increment

TWO_PI = 2.0 * math.pi

__all__ = ["BeamImpactModel", "BeamODESolver", "mode_table", "apply_impact"]

# the closed-form modal flow lives in vibeam.models.system (the one dynamical system); the kernels
# below call it by these names (mode_table and particular are re-exported from there)
_trans = transition_increment
_advance = advance_modes


# ============================================================================ impulses


@njit(cache=True)
def apply_impact(etad, w, U_minus, R, m_eff):
    """Newton impact on the contact ``U = w^T eta`` (Moreau / Siconos): impulse
    ``P = restitution_impulse(U-, R, m_eff)`` along ``w``, ``eta' += w P`` in place.
    Returns ``U+ = -R U-`` (the exact law value, used as the contact velocity)."""
    P = restitution_impulse(U_minus, R, m_eff)
    for i in range(etad.shape[0]):
        etad[i] += w[i] * P
    return newton_restitution(U_minus, R)


# ============================================================================ model
class BeamImpactModel:
    """Impacting cantilever in ``N`` modal coordinates (fidelity ``"beam"``).

    Build it with :meth:`from_fe` (FE modes) or :meth:`static_mode` (the paper's single
    static assumed mode, beam mass excluded), or directly from modal data.

    Parameters
    ----------
    omega_rad_s, participation, contact_row, sensor_row : array_like, shape (N,)
        Modal frequencies ``omega_i``, ``Gamma_i = phi_i^T M r`` (sqrt(kg)), ``w_i = w^T
        phi_i`` and ``s_i = s^T phi_i`` (1/sqrt(kg)) of mass-normalised shapes.
    R : float
        Coefficient of restitution.
    gap_contact_m : float
        ``Delta_C`` (m; negative = pre-stressed stop).
    base_amplitude_m : float
        ``Y = gamma~ V`` (m).
    f_ref_hz : float
        Reference frequency: ``Omega = f / f_ref``, ``t = 2 pi f_ref t~``.
    length_m : float
        ``L``.
    phi_at_mass : float
        Static-mode ratio ``phi(x_m)`` (``phi(x_S) = 1``), giving
        ``Delta = Delta_C / (phi(x_m) L)`` as in the SDOF model.
    damping_D_s, rayleigh_alpha_1_s : float
        ``C = alpha M + D K`` so that ``c_i = alpha + D omega_i^2``.
    modal_damping_1_s : array_like, shape (N,), optional
        Per-mode damping ``c_i`` (1/s) replacing the Rayleigh law (used by the coupled
        platform of :mod:`vibeam.engine.effects`); the constrained modes then get the diagonal of
        ``Psi^T diag(c) Psi`` (modal damping kept modal, off-diagonal terms dropped).
    restitution_table : (array_like, array_like), optional
        ``(U-, R)`` nodes of a velocity-dependent R with ``U-`` the pre-impact contact
        velocity in kernel units (m per nondimensional time); None = constant ``R``.
    gap_contact_lower_m : float or None, optional
        A second (lower) stop at ``w^T eta = -Delta_C,lower`` (m, distance from the static
        equilibrium at the contact point, positive; ``Delta_C + Delta_C,lower > 0``); None: one
        stop.
    R_lower : float or None, optional
        Shorthand of ``lower_law = Restitution(R_lower)``: Newton's law with its own R at the lower
        stop; None: the upper stop's law (``R`` and the table).

    Attributes
    ----------
    upper_law : law
        The upper stop's law, the one holder of its numbers (``R`` and the table above build a
        :class:`vibeam.models.contact.Restitution`; :attr:`R`, :attr:`R_table_U` and
        :attr:`R_table_R` read and replace it).
    lower_law : law or None
        The lower stop's own law (:mod:`vibeam.models.contact`: Newton's, or a compliant one in
        N/m^p at the contact point); None: the upper stop's.
    point_stops : sequence of (Stop, ndarray (N,)), optional
        Further stops at other points of the beam (:class:`vibeam.models.contact.Stop`: its
        relation's sign and offset, the gap along its normal in m, negative pre-stressed; its law,
        the only holder of its numbers, Newton's or compliant in N/m^p at the point; its label,
        its name in outputs and messages), each with its contact row ``w(x)`` in the retained
        modes (:meth:`from_fe` and :meth:`static_mode` compute them from positions; the
        relation's ``row`` is set by :meth:`stops`).  They are relations on the system's contact rows 1, 2, ...
        (:meth:`contact_rows`).
    """

    fidelity = "beam"

    def __init__(self, omega_rad_s, participation, contact_row, sensor_row, R, gap_contact_m,
                 base_amplitude_m, f_ref_hz, length_m, phi_at_mass, damping_D_s=0.0,
                 rayleigh_alpha_1_s=0.0, label="", modal_damping_1_s=None, restitution_table=None,
                 gap_contact_lower_m=None, R_lower=None, point_stops=()):
        self.omega_rad_s = np.asarray(omega_rad_s, dtype=float).copy()
        self.participation = np.asarray(participation, dtype=float).copy()
        self.contact_row = np.asarray(contact_row, dtype=float).copy()
        self.sensor_row = np.asarray(sensor_row, dtype=float).copy()
        n = self.omega_rad_s.size
        if not (self.participation.size == self.contact_row.size == self.sensor_row.size == n and n >= 1):
            raise ValueError("modal arrays must have the same length >= 1")
        if not np.all(self.omega_rad_s > 0):
            raise ValueError("modal frequencies must be positive")
        if damping_D_s < 0 or rayleigh_alpha_1_s < 0:
            raise ValueError("damping coefficients must be >= 0")
        if not np.any(self.contact_row != 0):
            raise ValueError("no retained mode moves the contact point")
        self.gap_contact_m = float(gap_contact_m)
        self.base_amplitude_m = float(base_amplitude_m)
        self.f_ref_hz = float(f_ref_hz)
        self.length_m = float(length_m)
        self.phi_at_mass = float(phi_at_mass)
        self.damping_D_s = float(damping_D_s)
        self.rayleigh_alpha_1_s = float(rayleigh_alpha_1_s)
        self.modal_damping_1_s = (None if modal_damping_1_s is None
                                  else np.asarray(modal_damping_1_s, dtype=float).copy())
        if self.modal_damping_1_s is not None and self.modal_damping_1_s.shape != (n,):
            raise ValueError("modal_damping_1_s must have one entry per mode")
        table = ((), ()) if restitution_table is None else \
            tuple(tuple(float(x) for x in np.ascontiguousarray(c, dtype=float)) for c in restitution_table)
        #: the upper stop's law, the one holder of its R (and R(U-) table): Newton's law here, the
        #: compliant law (:meth:`with_laws`)
        self.upper_law = Restitution(float(R), *table)
        self.gap_contact_lower_m = None if gap_contact_lower_m is None else float(gap_contact_lower_m)
        self.lower_law = None if R_lower is None else Restitution(float(R_lower))
        if self.gap_contact_lower_m is not None and not self.gap_contact_m + self.gap_contact_lower_m > 0.0:
            raise ValueError("the stops overlap: gap_contact_m + gap_contact_lower_m must be > 0")
        self.label = label
        self.point_stops = tuple((st, np.ascontiguousarray(row, dtype=float)) for st, row in point_stops)
        for st, row in self.point_stops:
            if row.shape != (n,) or not np.any(row != 0.0):
                raise ValueError(f"the {st.name} stop: no retained mode moves its point")
        self._constrained()

    # ---------------------------------------------------------------- constructors
    @classmethod
    def from_fe(cls, fe, n_modes=2, R=0.72, gap_contact_m=0.0, base_amplitude_m=0.0,
                f_ref_hz=None, damping_D_s=None, rayleigh_alpha_1_s=None, gap_contact_lower_m=None,
                R_lower=None, point_stops=()):
        """Modal truncation of a :class:`vibeam.models.beam.BeamFE` to ``n_modes`` (int or
        ``"all"``).  Damping defaults to the FE model's; ``f_ref`` to its ``f_1``;
        ``point_stops``, ``(x, stop)`` pairs (position in m from the clamp, a
        :class:`vibeam.models.contact.Stop`), get their rows from the FE shapes at their points."""
        from vibeam.reductions.modal import modal_reduction
        from vibeam.reductions.static_mode import static_mode_shape

        red = modal_reduction(fe, n_modes)
        md = fe.modes(red.n_modes)
        g = fe.geometry
        L = g.length_m
        phim = float(static_mode_shape(g.mass_position_m / L, g.mass_position_m / L,
                                       g.sensor_position_m / L))
        return cls(red.omega_rad_s, md.participation, red.contact_row, red.sensor_row, R,
                   gap_contact_m, base_amplitude_m,
                   md.frequencies_hz[0] if f_ref_hz is None else f_ref_hz, L, phim,
                   fe.damping_D_s if damping_D_s is None else damping_D_s,
                   fe.rayleigh_alpha_1_s if rayleigh_alpha_1_s is None else rayleigh_alpha_1_s,
                   label=f"FE {red.n_modes} modes", gap_contact_lower_m=gap_contact_lower_m, R_lower=R_lower,
                   point_stops=[(st, fe.point_rows([x])[0] @ red.shapes) for x, st in point_stops])

    @classmethod
    def static_mode(cls, geometry, R=0.72, gap_contact_m=0.0, base_amplitude_m=0.0,
                    damping_D_s=0.0, f_ref_hz=None, gap_contact_lower_m=None, R_lower=None, point_stops=()):
        """One assumed shape, the static mode ``phi`` (paper Eqs. 42-47, beam mass
        excluded): mass ``M_S = m phi(x_m)^2``, stiffness ``K_S``, load ``m phi(x_m)``.

        The mass-normalised shape is ``phi / sqrt(M_S)`` in ``U = L phi q``, i.e. the
        modal coordinate is ``eta = L sqrt(M_S) q``, so ``w = phi(x_m) / sqrt(M_S)``,
        ``s = 1 / sqrt(M_S)``, ``Gamma = m phi(x_m) / sqrt(M_S)`` and ``m_eff = m``.
        """
        from vibeam.reductions.static_mode import reduce_static_mode, static_mode_shape

        red = reduce_static_mode(geometry, damping_D_s=damping_D_s, gap_contact_m=gap_contact_m)
        L = geometry.length_m
        xm, xs = geometry.mass_position_m / L, geometry.sensor_position_m / L
        sq = math.sqrt(red.M_S_kg)
        phim = red.phi_at_mass
        return cls([red.omega_n_rad_s], [geometry.mass_kg * phim / sq], [phim / sq], [1.0 / sq],
                   R, gap_contact_m, base_amplitude_m,
                   red.f_n_hz if f_ref_hz is None else f_ref_hz, geometry.length_m, phim,
                   damping_D_s, 0.0, label="static mode", gap_contact_lower_m=gap_contact_lower_m,
                   R_lower=R_lower,
                   point_stops=[(st, [float(static_mode_shape(x / L, xm, xs)) / sq]) for x, st in point_stops])

    # ---------------------------------------------------------------- derived data
    @property
    def n_modes(self) -> int:
        return self.omega_rad_s.size

    @property
    def omega_ref(self) -> float:
        return TWO_PI * self.f_ref_hz

    @property
    def natural_frequency_hz(self) -> float:
        return self.f_ref_hz

    @property
    def Delta_G_m(self) -> float:
        return self.gap_contact_m / self.phi_at_mass

    @property
    def Delta(self) -> float:
        """``Delta_G / L`` with ``Delta_G = Delta_C / phi(x_m)``."""
        return self.Delta_G_m / self.length_m

    @property
    def m_eff(self) -> float:
        return float(1.0 / np.sum(self.contact_row ** 2))

    @property
    def force_scale_n(self) -> float:
        """Newtons per unit of the nondimensional contact force ``F / (m_eff omega_ref^2 L)``
        (joules per unit of the nondimensional energy: this times ``L``)."""
        return self.m_eff * self.omega_ref ** 2 * self.length_m

    @property
    def k_nd(self) -> np.ndarray:
        """``(omega_i / omega_ref)^2``."""
        return (self.omega_rad_s / self.omega_ref) ** 2

    @property
    def c_nd(self) -> np.ndarray:
        """``(alpha + D omega_i^2) / omega_ref`` (or ``modal_damping_1_s / omega_ref``)."""
        return self.c_phys / self.omega_ref

    @property
    def c_phys(self) -> np.ndarray:
        """Modal damping ``c_i`` (1/s)."""
        if getattr(self, "modal_damping_1_s", None) is not None:
            return self.modal_damping_1_s
        return self.rayleigh_alpha_1_s + self.damping_D_s * self.omega_rad_s ** 2

    @property
    def two_sided(self) -> bool:
        """A second stop below (``gap_contact_lower_m`` given)."""
        return getattr(self, "gap_contact_lower_m", None) is not None

    # the upper stop's numbers, read from and written to its law (the model holds no copy)
    @property
    def R(self) -> float:
        """The upper stop's ``R`` (its law's; a compliant law's target R)."""
        return float(self.upper_law.R)

    @R.setter
    def R(self, value: float) -> None:
        self.upper_law = dataclasses.replace(self.upper_law, R=float(value))

    @property
    def R_table_U(self) -> np.ndarray:
        """Nodes ``U-`` of the upper stop's ``R(U-)`` table (kernel units), shape (k,); empty: constant R."""
        return np.asarray(self.upper_law.table_U, dtype=float)

    @R_table_U.setter
    def R_table_U(self, value) -> None:
        self.upper_law = dataclasses.replace(self.upper_law, table_U=tuple(float(x) for x in np.ravel(value)))

    @property
    def R_table_R(self) -> np.ndarray:
        """Values ``R`` of the upper stop's ``R(U-)`` table, shape (k,)."""
        return np.asarray(self.upper_law.table_R, dtype=float)

    @R_table_R.setter
    def R_table_R(self, value) -> None:
        self.upper_law = dataclasses.replace(self.upper_law, table_R=tuple(float(x) for x in np.ravel(value)))

    def stops(self) -> tuple:
        """The contact relations and laws (:mod:`vibeam.models.contact`): the stop at
        ``w^T eta = Delta_C`` (normal ``w``) with Newton's law, ``R`` and ``R(U-)``, and for a
        two-sided scene the stop at ``w^T eta = -Delta_C,lower`` (normal ``-w``) with its law."""
        return self.mass_stops() + tuple(
            Stop(Relation(st.relation.sign, st.relation.offset, row=1 + i), st.law, st.label)
            for i, (st, _) in enumerate(self.point_stops))

    #: the drive when it is not the base displacement ``base_amplitude_m``
    #: (:class:`vibeam.models.scene.Excitation`, SI; a force acts along :attr:`drive_row`)
    excitation = None
    #: the modal row (N,) of a force's point (1/sqrt(kg))
    drive_row = None

    def scene(self) -> Scene:
        """The beam as a scene: its modal system and :meth:`system_stops`
        (:func:`vibeam.models.scene.beam_scene`), driven by :attr:`excitation` when one is set
        (:func:`vibeam.models.scene.driven`: a base acceleration, or a force along :attr:`drive_row`)."""
        sc = beam_scene(self)
        ex = self.excitation
        if ex is None:
            return sc
        sy = sc.system
        if ex.kind != "force":
            return sc._replace(system=driven(sy, ex))
        n_c = sy.contacts.shape[0]
        with_row = sy._replace(contacts=np.vstack([sy.contacts, np.asarray(self.drive_row, float)[None, :]]))
        return sc._replace(system=driven(with_row, Excitation("force", ex.amplitude, n_c))._replace(contacts=sy.contacts))

    def system_stops(self) -> tuple:
        """:meth:`stops` in the units of the modal system (:func:`vibeam.models.system.from_beam`): a
        compliant law's stiffness (N/m^p) over ``omega_ref^2`` (the system's time unit is
        ``1 / omega_ref``, its modes mass-normalised in kg), its damping ratio or ``chi`` as they are."""
        out = []
        for s in self.stops():
            law = s.law
            if getattr(law, "kind", "") == "compliant":
                law = dataclasses.replace(law, stiffness=law.stiffness / self.omega_ref ** 2)
            out.append(Stop(s.relation, law, s.label))
        return tuple(out)

    #: the lower stop's own law (None: the upper stop's); set by ``R_lower`` or a compliant law
    lower_law = None

    def with_laws(self, law, law_lower=None) -> "BeamImpactModel":
        """A copy of this model (of its class) whose stops at the attached mass have the laws
        ``law`` (upper) and ``law_lower`` (the lower stop of a two-sided model; None: ``law``):
        Newton's (:class:`vibeam.models.contact.Restitution`) or compliant
        (:mod:`vibeam.models.compliant`, ``stiffness`` in N/m^p at the contact point, the damping
        ratio of the isolated contact of mass ``m_eff`` or ``chi``)."""
        m = copy.copy(self)
        m.upper_law = law
        m.lower_law = law_lower
        return m

    @property
    def contact(self):
        """The upper stop's compliant law (its ``upper_law``), None when it is Newton's."""
        return None if getattr(self.upper_law, "kind", "") == "impulsive" else self.upper_law

    @contact.setter
    def contact(self, law) -> None:
        self.upper_law = law

    @property
    def contact_law(self) -> str:
        """The name of the upper stop's law (``"restitution"`` for Newton's)."""
        return "restitution" if self.contact is None else self.upper_law.name

    @property
    def contact_damping_n_s_m(self) -> float:
        """The upper Kelvin-Voigt stop's dashpot ``c_c = 2 zeta_c sqrt(k_c m_eff)`` (N s/m); raises
        AttributeError for a law without a damping ratio."""
        return 2.0 * self.upper_law.damping_ratio * math.sqrt(self.upper_law.stiffness * self.m_eff)

    def mass_stops(self) -> tuple:
        """The stops at the attached mass (the paper's, and a lower one): the first of :meth:`stops`.
        The upper stop has its law ``upper_law`` (Newton's with ``R`` and its table, or a compliant
        one); the lower one ``lower_law`` (None: the upper stop's law)."""
        upper = self.upper_law
        out = (Stop(Relation(1.0, self.gap_contact_m), upper),)
        if self.two_sided:
            out += (Stop(Relation(-1.0, self.gap_contact_lower_m),
                         upper if self.lower_law is None else self.lower_law),)
        return out

    def stop_codes(self) -> np.ndarray | None:
        """The output code of each of :meth:`stops` (0 the upper stop at the mass, 1 a lower one
        there, 2 + i the point stop i): the stop numbering of the trajectories' ``impact_stops``
        and of the per-stop outputs; None without point stops (the codes are the indices):
        :func:`vibeam.models.core.event.stop_codes`."""
        return stop_codes(self.stops())

    def contact_rows(self) -> np.ndarray:
        """The contact rows of the system, shape (1 + len(point_stops), N): the attached mass's,
        then each point stop's (:func:`vibeam.models.system.from_beam`)."""
        return np.vstack([self.contact_row] + [row for _, row in self.point_stops])

    def _constrained(self):
        """The beam held on a stop at the mass: ``eta = eta_c + Psi zeta``, ``Psi`` (shape (N, N - 1))
        and the squared frequencies ``nu2`` of the constrained modes, the same for every stop (the
        null space of ``w``: :func:`vibeam.models.scene.held_modes`).  The event integrator derives its own held sets from the
        system (:func:`vibeam.models.core.stops.held_sets`), the pre-stressed start its offsets
        (:func:`vibeam.models.scene.rest_state`)."""
        Psi, self.nu2 = held_modes(self.contact_row, np.diag(self.k_nd))
        self.Psi = np.ascontiguousarray(Psi)

    # ---- the model protocol of the fidelity registry (vibeam.models.registry)
    @property
    def phi_contact(self) -> float:
        """Static-mode value at the contact point over the sensor's (``phi(x_m)``, or
        ``phi_c`` of an eccentric contact): contact displacements over it are the sensor's."""
        return self.phi_at_mass

    def initial_state(self) -> np.ndarray:
        """``(eta, eta', stuck)``: rest at the origin, or on a pre-stressed stop at the
        static constrained equilibrium (:func:`vibeam.models.scene.rest_state`)."""
        return rest_state(self.scene())

    def linear_sensor_amplitude_m(self, Omega):
        """Steady-state sensor amplitude without the stop (m), from the modal sum."""
        if self.excitation is not None:      # the driven system's forcing F(Omega) = Omega^p A
            sy = self.scene().system
            H = sy.participation * forcing(sy, Omega) / (sy.omega ** 2 - Omega ** 2 + 1j * Omega * sy.damping)
            return float(abs(sy.sensor @ H))
        W = Omega * self.omega_ref
        H = self.participation * W**2 * self.base_amplitude_m / (
            self.omega_rad_s**2 - W**2 + 1j * W * self.c_phys)
        return float(abs(self.sensor_row @ H))



# ============================================================================ solvers
class BeamODESolver:
    """Method ``direct`` for the beam, every contact law: the same modal system and stops integrated
    by :func:`scipy.integrate.solve_ivp` (the reference solver), through the one direct solver
    (:class:`vibeam.models.core.direct.DirectIntegrator`; the beam's stops in system units,
    :meth:`BeamImpactModel.system_stops`).

    Newton stops: a terminal event at each contact (a gap ``n^T eta - Delta`` rising) and the same
    impact law; held on stops, the constrained system ``eta = eta_c + Psi zeta`` with a terminal
    event on each contact force ``lambda`` turning positive; an impact with ``U- < chatter_velocity``
    times the first impact speed into a pressing contact acceleration ends a chatter (plastic
    projection, then sticking): a crude chatter model, fine for a reference of impacting/sticking
    orbits, not for resolving chatter.  Compliant stops (Kelvin-Voigt, hysteretic Hertz): the
    contact forces in the equations while in contact, with terminal events at the entries and exits
    of :mod:`vibeam.models.core.contact_phase` and the work done on each stop integrated with the
    state; the contacts' rows are the event method's (:func:`vibeam.models.core.event.trajectory`).

    The state is scaled by ``1 / (L sqrt(m_eff))`` so that it is of the order of ``U / L``.
    ``q_min/q_max`` use the sensor-velocity zero crossings (events) and the samples.  Steps are
    capped at ``T / 16`` (and at a twentieth of a compliant contact's time scale) so that sign
    changes of the event functions are not stepped over (solve_ivp only checks signs at step ends:
    detection is not guaranteed).

    Parameters
    ----------
    scene : Scene
        As :class:`~vibeam.models.core.event.BeamEventSolver`'s.
    solver : str
        ``solve_ivp`` method (DOP853 default).
    rtol, atol : float or None
        Tolerances (``atol`` in units of ``q``); None: 1e-9 and 1e-12 with Newton stops, 1e-11 and
        1e-15 with a compliant stop (:data:`vibeam.models.core.direct.RTOL_IMPULSIVE` ...).
    max_impacts_per_period : int
        More impacts and contact entries per period on average: ``failed``.
    chatter_velocity : float
    max_step : float or None
        Largest step (nondimensional time; default ``T / 16``).
    """

    name = "direct"
    time_domain = True
    chunk_periods = 200   # a restart of solve_ivp changes the result at the level of rtol

    def __init__(self, scene: Scene, solver: str = "DOP853", rtol: float | None = None,
                 atol: float | None = None, max_impacts_per_period: int = 200,
                 chatter_velocity: float = 1e-6, max_step: float | None = None):
        self.scene = scene
        sy = scene.system
        self.n_modes = int(sy.omega.shape[0])
        self._scale = float(sy.coordinate_scale)
        self._codes = stop_codes(scene.stops)
        self._laws = [st.law for st in scene.stops]
        self._rest = rest_state(scene)
        m_eff = float(1.0 / np.sum(np.asarray(sy.contacts[0], float) ** 2))
        self.max_step = max_step
        self.solver = solver
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.chatter_velocity = float(chatter_velocity)
        self._direct = DirectIntegrator(EventIntegrator(scene), self._scale * math.sqrt(m_eff), solver, rtol, atol,
                                        self.max_impacts_per_period, self.chatter_velocity, max_step)
        self.rtol = self._direct.rtol
        self.atol = self._direct.atol

    def settings(self) -> dict:
        return dict(solver=self.solver, rtol=self.rtol, atol=self.atol, n_modes=self.n_modes,
                    chatter_velocity=self.chatter_velocity)

    def point(self, Omega, state0, n_transient, n_record, samples_per_period=64) -> Trajectory:
        """One forcing frequency by the one direct solver (:mod:`vibeam.models.core.direct`) on the
        beam's modal system and stops; ``state0`` as :meth:`BeamEventSolver.point` (its last entry
        the held code of the Newton stops held and the compliant stops in contact)."""
        s0 = self._rest.copy() if state0 is None else np.asarray(state0, dtype=float)
        laws = self._laws
        return self._direct.run(float(Omega), s0, n_transient, n_record, samples_per_period, self._scale,
                                lambda k: laws[k], self._codes)
