"""Periodic orbits of the modal FE beam as zeros of a shooting residual (fidelity ``"beam"``).

:class:`BeamShooting` implements the shooting-problem contract of
:mod:`vibeam.models.periodic` for :class:`~vibeam.models.beam_dynamics.BeamImpactModel`
with any number of modes (all modes of the mesh included): ``P^n`` of the stroboscopic
map (forcing phase 0), its monodromy ``M`` and ``d x / d p``, all exact.

How a shot is computed
    The beam is the ``N``-mode case of the one shooting problem
    (:class:`vibeam.models.core.shooting.ModalShooting`): ``P^n`` is one run of the one event
    integrator from ``x0`` with its event log (the sweep's event policy: certified impact
    detection, the Newton impulse, sticking and release, chatter), and the tangent ``J = d x /
    d(x0, p)`` is assembled from the log in compiled code: per-mode 2x2 transition matrices of
    the free flights (O(N^2) per flight, never a dense ``2N x 2N`` product), the constrained
    flow while held, the impacts' saltation matrices in closed form (no cancellation as ``U-
    -> 0``), the plastic entries into sticking and the releases with their time derivatives
    (``extra["release_time_derivatives"]``).  A second (lower) stop (``gap_contact_lower_m``,
    normal ``-w``, its own ``lower_law`` or the upper stop's) is one more stop of the same
    problem; ``extra["impact_stops"]`` gives the stop of each impact (0 upper, 1 lower) and
    ``apex_gap`` watches the grazing of both.  This class maps the beam's native parameters onto
    the problem's directions: Omega enters the forcing phase, the particular solutions and the
    end time ``n T``; ``Y`` (``base_amplitude_m``) the particular solutions; ``Delta_C``
    (``gap_contact_m``) the upper stop's offset (the event surface, ``eta_c`` and ``eC`` of the
    beam held on it, the initial projection); ``R`` its restitution (and the lower stop's when it
    has none of its own); ``D`` (``damping_D_s``, ``c_i = D omega_i^2 / omega_ref``) and
    ``alpha`` (``rayleigh_alpha_1_s``, ``c_i = alpha / omega_ref``) the modal damping.

Chatter
    A chatter sequence ending in sticking is the integrator's (the one event policy): its
    impacts are real impacts until the accumulation test (error of the geometric sum below
    ``chatter_tol``, or its Zeno guard) cuts the sequence; that last impact is a plastic entry
    into sticking, and the beam is held at least for the estimated accumulation time.  So ``P^n``
    is the map a sweep iterates, and ``M``, ``x_p`` are its exact derivatives on the piece where
    the number of impacts before the cut is fixed (``P^n`` stays continuous to round-off where it
    changes).  Not representable, status ``"chatter"``: a release forced at the end of the hold,
    whose time is not a smooth event.

Section on the stop
    When ``x0`` lies on a stop with zero normal velocity (within ``1e-9`` of the state scale)
    the orbit is taken as held at the section: the run starts held, and the Jacobian includes
    the projection onto the constraint (two zero multipliers); ``d x / d Delta_C`` moves ``x0``
    with the stop.

Parameters and conversions
    Native parameters: ``Omega``, ``base_amplitude_m``, ``gap_contact_m``, ``R``,
    ``damping_D_s``, ``rayleigh_alpha_1_s``.  Physical case keys map affinely onto them
    (:func:`conversions`); a key that changes the FE model (``length_mm``, ``EI_n_m2``,
    ...) is refused (:data:`REBUILD_KEYS`).

References
----------
R. I. Leine, H. Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*,
Springer 2004, Ch. 3 (saltation matrix); M. di Bernardo et al., *Piecewise-smooth
Dynamical Systems*, Springer 2008, Sec. 2.5 (discontinuity mappings, sliding/sticking);
paper Eqs. 39-47 (model, impact law, static-mode reduction).
"""
from __future__ import annotations

import copy
import math

import numpy as np

from .beam_dynamics import TWO_PI, BeamImpactModel
from .core.event import EventIntegrator
from .core.integrator import EV_IMPACT, EV_STICK_IMPACT
from .core.shooting import Direction, ModalShooting, Setup, directions, dtransition_dsig
from .contact import Restitution, restitution_problem
from .impact import restitution_at
from .system import forcing, particular, transition_entries

__all__ = ["BeamShooting", "BeamContinuation", "conversions", "NATIVE_PARAMETERS", "REBUILD_KEYS"]

#: the per-mode transition matrix, :func:`vibeam.models.system.transition_entries`
_phi = transition_entries
#: ``d Phi / d sigma``, :func:`vibeam.models.core.shooting.dtransition_dsig`
_dtrans_dsig = dtransition_dsig

#: native continuation parameters of the beam and the model attribute each one sets
NATIVE_PARAMETERS = ("Omega", "base_amplitude_m", "gap_contact_m", "R", "damping_D_s",
                     "rayleigh_alpha_1_s")
#: the lower stop's parameters: its offset (m, at the contact point) and its R (Newton's, or a
#: compliant law's target R); native parameters of a two-sided model only
LOWER = ("gap_contact_lower_m", "R_lower")
_PID = {name: i for i, name in enumerate(NATIVE_PARAMETERS + LOWER)}

#: case keys of a beam scene that change the FE model (modes, shapes): not continuable
REBUILD_KEYS = ("length_mm", "sensor_position_mm", "mass_position_mm", "width_mm",
                "thickness_mm", "youngs_modulus_gpa", "density_kg_m3", "EI_n_m2", "rhoA_kg_m",
                "mass_kg", "rotary_inertia_kg_m2", "discs", "calibrate", "n_modes", "n_elements")


def conversions(model: BeamImpactModel, gain_per_V: float | None = None,
                voltage: float | None = None) -> dict:
    """Affine map of the physical case keys onto the native parameters.

    ``native = scale * key`` for every key in the table, so a derivative with respect
    to the key is ``scale`` times the native one (chain rule).

    Parameters
    ----------
    model : BeamImpactModel
        The model (built by :func:`vibeam.case.beamscene.build_beam_model` for a case).
    gain_per_V : float, optional
        The case's ``gain`` (the paper's normalised gamma, 1/V); needed for ``voltage``.
    voltage : float, optional
        The case's ``voltage`` (V); needed for ``gain``.

    Returns
    -------
    dict
        ``key -> (native name, scale)``:

        * ``Omega`` -> ``Omega``, 1; ``frequency_hz`` -> ``Omega``, ``1 / f_ref``;
        * ``voltage`` -> ``base_amplitude_m``, ``gamma~ = gain phi(x_m) L`` (m/V, Eq. 46
          inverted, :func:`vibeam.case.beamscene.scene_of`); ``gain`` -> ``base_amplitude_m``,
          ``V phi(x_m) L``;
        * ``gap_mm`` (grazing gap at the sensor) -> ``gap_contact_m``, ``1e-3 phi(x_m)``
          (Eq. 45: ``Delta_C = phi(x_m) Delta_G``); ``contact_gap_mm`` -> ``gap_contact_m``,
          ``1e-3``;
        * ``damping_ratio`` -> ``damping_D_s``, ``2 / omega_ref`` (``D = 2 beta / omega_1``
          with ``omega_1 = 2 pi f_ref``, the first FE mode of a built scene);
        * ``R`` -> ``R``, 1; ``rayleigh_alpha_1_s`` -> itself, 1; and every native name
          to itself.
    """
    L = model.length_m
    phim = model.phi_at_mass
    tab = {name: (name, 1.0) for name in NATIVE_PARAMETERS + LOWER}
    tab["frequency_hz"] = ("Omega", 1.0 / model.f_ref_hz)
    tab["gap_mm"] = ("gap_contact_m", 1e-3 * phim)
    tab["contact_gap_mm"] = ("gap_contact_m", 1e-3)
    tab["gap_lower_mm"] = ("gap_contact_lower_m", 1e-3 * phim)
    tab["contact_gap_lower_mm"] = ("gap_contact_lower_m", 1e-3)
    tab["damping_ratio"] = ("damping_D_s", 2.0 / model.omega_ref)
    if gain_per_V is not None:
        tab["voltage"] = ("base_amplitude_m", float(gain_per_V) * phim * L)
    if voltage is not None:
        tab["gain"] = ("base_amplitude_m", float(voltage) * phim * L)
    return tab


def _check_parameter(name: str):
    if name in REBUILD_KEYS:
        raise ValueError(f"parameter {name!r} changes the FE model (modes and shapes): the beam "
                         f"shooting cannot continue in it; allowed: {', '.join(NATIVE_PARAMETERS + LOWER)} "
                         f"(or a physical key of conversions())")
    if name not in _PID:
        raise ValueError(f"parameter {name!r} is not a native beam parameter; allowed: "
                         f"{', '.join(NATIVE_PARAMETERS + LOWER)} (physical keys map onto them through "
                         f"conversions())")


# ============================================================================ the problem
class BeamShooting(ModalShooting):
    """Shooting problem of the modal FE beam (contract of :mod:`vibeam.models.periodic`).

    Parameters
    ----------
    model : BeamImpactModel
        Any number of modes (``from_fe(fe, "all")`` included) or the static-mode model.
    Omega : float
        Forcing frequency ``f / f_ref`` (nondimensional): the starting value when the
        parameter is ``"Omega"``, the fixed frequency otherwise.
    parameter : str, optional
        Native continuation parameter, one of :data:`NATIVE_PARAMETERS` (``Omega``,
        ``base_amplitude_m`` (m), ``gap_contact_m`` (m), ``R``, ``damping_D_s`` (s),
        ``rayleigh_alpha_1_s`` (1/s)) or, with a lower stop, :data:`LOWER`
        (``gap_contact_lower_m`` (m), ``R_lower``).  Physical keys go through :func:`conversions`.
    chatter_tol, steps_per_fundamental, max_impacts_per_period, max_steps_per_period :
        Settings of the event kernel, as :class:`~vibeam.models.core.event.BeamEventSolver`
        (same defaults, so that a stable fixed point is what a sweep lands on).

    Attributes
    ----------
    dim : int
        ``2 N``: the state is ``(eta, eta')`` (modal coordinates, sqrt(kg) m, and their
        derivatives with respect to the nondimensional time ``t = omega_ref t~``).
    parameter : str
    value : float
        The parameter's value in ``model`` (``Omega`` for ``"Omega"``).
    state_scale : float
        ``L sqrt(m_eff)``: ``x / state_scale`` is of the order of ``U / L`` (a natural
        norm for a continuation engine).

    Raises
    ------
    ValueError
        For a parameter that is not native (a key that needs an FE rebuild is named as
        such), ``R`` with a tabulated restitution law, or a damping parameter of a model
        with per-mode damping.
    """

    fidelity = "beam"

    def __init__(self, model: BeamImpactModel, Omega: float, parameter: str = "Omega",
                 chatter_tol: float = 1e-7, steps_per_fundamental: int = 16,
                 max_impacts_per_period: int = 20000, max_steps_per_period: int = 20000):
        _check_parameter(parameter)
        if parameter == "R" and model.R_table_U.size:
            raise ValueError("parameter 'R' cannot be continued with a tabulated restitution law "
                             "(effect restitution_law)")
        if parameter in ("damping_D_s", "rayleigh_alpha_1_s") and model.modal_damping_1_s is not None:
            raise ValueError(f"parameter {parameter!r} does not act on a model with per-mode damping "
                             f"(modal_damping_1_s)")
        if not (np.isfinite(Omega) and Omega > 0):
            raise ValueError(f"Omega must be positive and finite, got {Omega!r}")
        if parameter in LOWER and not model.two_sided:
            raise ValueError(f"continuation in {parameter!r} needs a lower stop (gap_contact_lower_m)")
        super().__init__(chatter_tol, steps_per_fundamental, max_impacts_per_period, max_steps_per_period)
        self.model = model
        self.Omega = float(Omega)
        self.parameter = parameter
        self.pid = _PID[parameter]
        self.index = 0           # the directions hold the continuation parameter alone
        law = getattr(model, "contact", None)
        self.value = self.Omega if parameter == "Omega" else (
            float(law.R) if parameter == "R" and law is not None else
            float(model.mass_stops()[1].law.R) if parameter == "R_lower" else float(getattr(model, parameter)))
        self.dim = 2 * model.n_modes
        self.state_scale = model.length_m * math.sqrt(model.m_eff)
        self._cache_key = None
        self._cache = None

    # ------------------------------------------------------------------ model at p
    def model_at(self, p: float) -> BeamImpactModel:
        """The model with the parameter set to ``p`` (the model itself for Omega)."""
        if self.parameter == "Omega" or p == self.value:
            return self.model
        m = copy.copy(self.model)
        law = getattr(m, "contact", None)
        if self.parameter == "R" and law is not None:
            m.contact = law.with_restitution(float(p))     # a compliant stop: its law's target R
        elif self.parameter == "R_lower":
            low = m.mass_stops()[1].law                    # the lower stop's own law from now on
            m.lower_law = Restitution(float(p)) if low.kind == "impulsive" else low.with_restitution(float(p))
        else:
            setattr(m, self.parameter, float(p))
        m._constrained()
        return m

    def _data(self, p):
        """The model, its integrator and directions and its free particular solution at ``p``
        (cached for the last ``p``; the integrator once for a continuation in Omega)."""
        key = float(p)
        if key == self._cache_key:
            return self._cache
        Om = key if self.parameter == "Omega" else self.Omega
        core_key = None if self.parameter == "Omega" else key
        if self._cache is None or self._cache["core_key"] != core_key:
            m = self.model_at(p)
            core = EventIntegrator(m.scene())
            ns = core.n_stops
            z = np.zeros(ns)
            N = m.n_modes
            up = np.eye(ns)[0]
            low = np.eye(ns)[1] if ns > 1 else z
            # the lower stop follows the upper stop's law when it has no R of its own
            own = m.lower_law is not None
            both = np.array([1.0, 0.0 if own else 1.0])[:ns]
            # the continuation parameter's direction only (one column: the cost of a tangent
            # grows with the columns, and with every mode for a damping parameter)
            dirs = directions(core, [{
                "Omega": Direction("Omega", 1.0, 0.0, z, z, np.zeros(N)),
                "base_amplitude_m": Direction("base_amplitude_m", 0.0, 1.0, z, z, np.zeros(N)),
                "gap_contact_m": Direction("gap_contact_m", 0.0, 0.0, up, z, np.zeros(N)),
                "R": Direction("R", 0.0, 0.0, z, both, np.zeros(N)),
                # c_i = (alpha + D omega_i^2) / omega_ref
                "damping_D_s": Direction("damping_D_s", 0.0, 0.0, z, z, m.omega_ref * m.k_nd),
                "rayleigh_alpha_1_s": Direction("rayleigh_alpha_1_s", 0.0, 0.0, z, z,
                                                np.full(N, 1.0 / m.omega_ref)),
                # the lower stop's offset and its R (the parameter is its own R, even where it
                # followed the upper stop's law at the start value)
                "gap_contact_lower_m": Direction("gap_contact_lower_m", 0.0, 0.0, low, z, np.zeros(N)),
                "R_lower": Direction("R_lower", 0.0, 0.0, z, low, np.zeros(N))}[self.parameter]])
        else:
            m, core, dirs = self._cache["m"], self._cache["core"], self._cache["dirs"]
        aF, bF = particular(m.c_nd, m.k_nd, m.participation, forcing(core.system, Om), Om)
        self._cache_key = key
        self._cache = dict(m=m, core=core, dirs=dirs, core_key=core_key, Om=Om, aF=aF, bF=bF,
                           mpF=core.ksys.mp)
        return self._cache

    def setup(self, p: float) -> Setup:
        D = self._data(p)
        return Setup(D["core"], D["Om"], D["dirs"], D["m"].Delta, D["m"].length_m)

    def invalid(self, p: float) -> str:
        bad = self._invalid(float(p), self.parameter)
        if bad:
            return bad
        m = self._data(p)["m"]
        if m.two_sided and not m.gap_contact_m + m.gap_contact_lower_m > 0.0:
            return (f"the stops overlap: gap_contact_m + gap_contact_lower_m = "
                    f"{m.gap_contact_m + m.gap_contact_lower_m:.6g} must be > 0")
        return ""

    def linear_orbit(self, p: float | None = None) -> np.ndarray:
        """Start of the contact-free branch: ``(eta, eta')`` at forcing phase 0 of the
        harmonic steady state without the stop (``eta_i = a_i sin + b_i cos``), shape (2N,).

        It is a fixed point of ``P`` while ``apex_gap < 0``; ``apex_gap = 0`` is its grazing.
        """
        D = self._data(self.value if p is None else p)
        return np.concatenate([D["bF"], D["Om"] * D["aF"]])

    @staticmethod
    def _invalid(p, name):
        if name in ("R", "R_lower") and restitution_problem(p, name):
            return restitution_problem(p, name)
        if name in ("damping_D_s", "rayleigh_alpha_1_s") and p < 0.0:
            return f"{name} must be >= 0"
        if name == "Omega" and not p > 0.0:
            return "Omega must be positive"
        return ""

    def linear_amplitude(self, p: float) -> float:
        """Amplitude ``|w^T (a + i b)|`` (m) of the contact displacement of the contact-free
        harmonic steady state at ``p`` (closed form; its grazing is where it equals
        ``Delta_C``)."""
        D = self._data(p)
        w = D["m"].contact_row
        return float(abs(w @ (D["aF"] + 1j * D["bF"])))

    # ------------------------------------------------------------------ starting orbits
    #: starts this problem offers besides the framework's ``sweep`` (no averaging for the beam:
    #: paper Eqs. 18-27 are the SDOF's)
    starts = ("linear",)

    def start(self, kind: str, p: float, n: int = 1):
        """Initial state of a closed-form orbit at ``p`` (contract of
        :mod:`vibeam.models.periodic`).

        Parameters
        ----------
        kind : {"linear"}
            The contact-free harmonic steady state (:meth:`linear_orbit`), where its contact
            amplitude stays below ``Delta_C``.
        p : float
            Value of the parameter (native units).
        n : int, optional
            Period (any: the orbit has period 1).

        Returns
        -------
        x0 : ndarray, shape (2N,) or None
        reason : str
            Empty when the orbit exists, else why not.

        Raises
        ------
        ValueError
            For a start the beam does not offer (``averaging``: the averaging solution of paper
            Eqs. 18-27 is the SDOF model's).
        """
        if kind != "linear":
            raise ValueError(f"start {kind!r} is not available for the beam; allowed: "
                             f"{', '.join(self.starts)} (and 'sweep')")
        bad = self._invalid(float(p), self.parameter)
        if bad:
            return None, bad
        A = self.linear_amplitude(p)
        mp = self._data(p)["m"]
        DC = mp.gap_contact_m
        if not A < DC:
            return None, (f"the non-impacting orbit does not exist: its contact amplitude {A:.6g} m "
                          f"reaches the stop Delta_C = {DC:.6g} m at {self.parameter} = {p:.6g}")
        if mp.two_sided and not A < mp.gap_contact_lower_m:
            return None, (f"the non-impacting orbit does not exist: its contact amplitude {A:.6g} m "
                          f"reaches the lower stop Delta_C,lower = {mp.gap_contact_lower_m:.6g} m at "
                          f"{self.parameter} = {p:.6g}")
        D = self._data(p)
        for st, row in mp.point_stops:      # the stops at other points
            Ak = float(abs(row @ (D["aF"] + 1j * D["bF"])))
            if not Ak < st.relation.offset:
                return None, (f"the non-impacting orbit does not exist: its amplitude {Ak:.6g} m at the "
                              f"{st.name} stop reaches it ({st.relation.offset:.6g} m) at "
                              f"{self.parameter} = {p:.6g}")
        return self.linear_orbit(p), ""

    # ------------------------------------------------------------------ section crossing
    def resect(self, x0, p: float, n: int = 1):
        """The same orbit seen on the other side of an impact that coincides with the section.

        When an impact of the orbit through ``x0`` approaches forcing phase 0 (the first one
        at ``t -> 0+`` or the last one at ``t -> n T-``), the state at the section jumps
        between the pre- and post-impact states although the orbit does not.  Returns the
        state at phase 0 with that impact moved to the other side of the section, to first
        order in its distance ``t_c < 1e-6 T`` from the section (the engine corrects it by
        Newton beyond the crossing): the post-impact state of the first impact (Newton impulse
        through the mass matrix, paper Eq. 41), or the pre-impact state of the last one; None if
        no impact lies within ``1e-6 T`` of the section (a sticking orbit held at the section is
        represented already, see the class docstring).

        The states are not carried across ``t_c`` by the free flow, as the SDOF's are: with the
        stiff, overdamped high modes of a fine mesh the impulse sets off damping forces of
        order ``c_i U`` (``c_i = D omega_i^2``), so the post-impact state carried back to phase
        0 is a virtual state whose contact velocity may point into the stop (measured with all
        46 modes of the rig: a spurious impact 1e-10 T after the section).
        """
        s = self.shot(x0, p, n, derivatives=False)
        if s.status != "ok" or not s.n_impacts:
            return None
        kinds = s.extra["event_kinds"]
        D = self._data(p)
        m, Om = D["m"], D["Om"]
        T = TWO_PI / Om
        N = m.n_modes
        rows = np.flatnonzero((kinds == EV_IMPACT) | (kinds == EV_STICK_IMPACT))
        if not rows.size:
            return None
        times, states = s.extra["event_times"], s.extra["event_states"]
        i, j = rows[0], rows[-1]
        if times[i] < 1e-6 * T and kinds[i] == EV_IMPACT:
            eta, etad = states[i, :N].copy(), states[i, N:].copy()
            k = int(s.extra["event_stops"][i])
            st = D["core"].kstops
            nv, law = st.normal[k], m.stops()[k].law      # the impact's stop (normal, law)
            U = float(nv @ etad)
            Rc = restitution_at(U, law.R, np.asarray(law.table_U, float), np.asarray(law.table_R, float))
            etad -= nv * (1.0 + Rc) * U * float(st.m_eff[k])
            return np.concatenate([eta, etad])
        if times[j] > n * T - 1e-6 * T and kinds[j] == EV_IMPACT:
            return states[j].copy()
        return None

    @staticmethod
    def _free_flow(eta, etad, ta, tb, D):
        """``(eta, eta')`` at ``tb`` from the state at ``ta`` by the closed-form free modal
        flow (either direction in time; per mode ``z(tb) = Phi(tb - ta) (z(ta) - z_p(ta)) +
        z_p(tb)``, :func:`_phi`)."""
        Om, mp, a, b = D["Om"], D["mpF"], D["aF"], D["bF"]
        s = tb - ta
        zp = lambda t: (a * math.sin(Om * t) + b * math.cos(Om * t),
                        Om * (a * math.cos(Om * t) - b * math.sin(Om * t)))
        pa, va = zp(ta)
        pb, vb = zp(tb)
        N = eta.size
        out = np.empty(2 * N)
        for i in range(N):
            t11, t12, t21, t22 = _phi(s, mp[i, 0], mp[i, 1], int(mp[i, 2]), mp[i, 3], mp[i, 4], mp[i, 5])
            u, v = eta[i] - pa[i], etad[i] - va[i]
            out[i] = t11 * u + t12 * v + pb[i]
            out[N + i] = t21 * u + t22 * v + vb[i]
        return out


class BeamContinuation(BeamShooting):
    """:class:`BeamShooting` built the way the continuation framework builds every shooting
    problem, ``cls(model, parameter, Omega=Omega)`` (registered as
    ``vibeam.models.SHOOTING["beam"]``).

    Parameters
    ----------
    model : BeamImpactModel
    parameter : str, optional
        Native parameter (:data:`NATIVE_PARAMETERS`).
    Omega : float, optional
        The fixed forcing frequency of a continuation in another parameter (required then);
        for ``"Omega"`` only the reported ``value``.
    **settings
        Event settings of :class:`BeamShooting`.

    Raises
    ------
    ValueError
        As :class:`BeamShooting`; or a missing ``Omega`` for another parameter.
    """

    def __init__(self, model: BeamImpactModel, parameter: str = "Omega", Omega: float | None = None,
                 **settings):
        if parameter != "Omega" and Omega is None:
            _check_parameter(parameter)
            raise ValueError(f"continuation in {parameter!r} needs the forcing frequency Omega")
        super().__init__(model, 1.0 if Omega is None else Omega, parameter, **settings)
        if parameter == "Omega" and Omega is None:
            self.value = math.nan
