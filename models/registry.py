"""The fidelity registry: what each fidelity of vibeam is and can do, in one table.

The framework (sweeps, effects, assessments, cost, the command line, case validation) never
branches on a fidelity's name; it asks this registry.  Adding a fidelity (e.g. a 2-DOF
model) means writing its module(s) under ``models/`` -- the model class, its solvers and,
optionally, its shooting problem -- plus one :class:`Fidelity` entry here, plus the spec
class of its ``[model]`` table, registered in the framework under the same name
(``vibeam.case.schema.CANONICAL_SPECS``, by its ``[model.system] builder``).

This module is pure Python (no numba, numpy or scipy): the case validator imports it to
check a run's method without loading any solver.  Classes are named by
``"module:attribute"`` strings relative to ``vibeam.models`` and loaded on first use
(:func:`resolve`).

Capabilities (:class:`Fidelity` fields) and the protocol they imply for the model class
--------------------------------------------------------------------------------------
A fidelity lists its methods, each as one :class:`Method`: its solver and the stops it
simulates (the laws and families it serves, on one or two stops, mixed or not).  The methods of
the one core (:mod:`vibeam.models.core`: event integrator, direct solver, shooting problem)
serve every law on any stops (:func:`on_the_core`), as does the SDOF's pointwise mapping on its
one or two stops (:mod:`vibeam.models.mapping`: a passage through a stop per kind and family; the
beam's, :mod:`vibeam.models.mapping.modal`, passes Newton and Kelvin-Voigt stops); the SDOF's
textbook methods say what they are limited to.  What a method simulates follows from these
entries by one function, :func:`supported_methods` (the laws of the stops at the mass, their
number, mixed kinds), used by :func:`vibeam.models.make_solver`, the shooting problem's builder
and case validation; a refusal names what it allows.  The per-method flags give the tables
``modal_state_methods``, ``restitution_law_methods`` and ``positive_R_methods``.

Every model has ``fidelity`` (its registry name), ``Delta`` (the gap of the amplitude
``Q = Delta - min q``, paper Sec. 4.1), ``natural_frequency_hz`` and ``length_m`` (None for a
nondimensional scene), ``phi_contact`` (static-mode value at the contact point over the
sensor's: contact displacements and velocities over it are the sensor's; 1 for the SDOF
model, whose coordinate is the sensor's), ``stops()`` (its contact relations and laws, :mod:`vibeam.models.contact`), ``two_sided`` and
``initial_state()``.

``modes``
    Several modes: the scene's frequencies label spectral peaks; modal participation is defined.
``contact_modes``
    The constrained system on the stop has modes (the scene's held on its first contact row,
    :func:`vibeam.models.scene.held_modes`).
``modal_state_methods``
    Methods whose solver records the modal states at the samples
    (``record_modal_states = True``): participation shares and the high-frequency component.
``eccentric_contact``, ``coupled_platform``
    The effects ``eccentric_impact`` and ``platform`` with ``level = "coupled"`` can be
    built for it (by its spec's ``effect_scene``).
``fe_model``
    A finite-element beam stands behind it (``vibeam derive``: the static-mode reduction).
``mode_shapes``
    Its spec reports its modes and writes their shapes (``vibeam modes``: the spec's
    ``modes_report(n)``).
``restitution_law_methods``
    Methods that take a velocity-dependent R (effect ``restitution_law``).
``solvers``
    Method name -> :class:`Method`; for a compliant law the model has ``contact_law`` (its
    stop's law name, ``"restitution"`` by default) and the law object ``contact`` (its
    ``family`` and numbers, e.g. ``chi``).  A method's ``laws`` entry of a family names the
    class that simulates that family's laws (for ``"continuation"`` its shooting problem,
    built as ``cls(scene, path, Omega=Omega, damping=damping)``); a family not listed is refused (by
    :func:`supported_methods`).  The kernels of a family never ask a law's name: they read its
    numbers from the law object (a new law of a family then costs one class and one
    :data:`LAWS` line).
``positive_R_methods``
    Methods that need ``R > 0`` (Ivanov's transformation, Eqs. 14-15, divides by
    ``K_N = 0`` at ``R = 0``); case validation refuses such a run with ``R = 0`` (also a
    ``[run.model]`` override or a ``[map]`` value of ``R``).
``shooting``
    Its periodic-orbit shooting problem (contract: :mod:`vibeam.models.core.periodic`), the
    class the continuation builds as ``cls(scene, path, Omega=Omega, damping=damping)`` (:func:`vibeam.models.shooting_problem`); None: cannot
    be continued.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import NamedTuple


class Law(NamedTuple):
    """One contact law of a stop (a row of :data:`LAWS`).

    Attributes
    ----------
    kind : str
        ``"impulsive"`` (a velocity map at the contact event) or ``"compliant"`` (a contact phase
        with its own force; :mod:`vibeam.models.contact`).
    implemented : bool
        Whether the kernels simulate it.
    keys : tuple of str
        Keys of the law's ``[model.contact]`` table besides ``law``.
    family : str or None
        A compliant law's family: the kernels that simulate it and the key of a
        :class:`Method`'s ``laws`` and ``two_sided`` (:data:`FAMILIES`).
    cls : str
        ``"module:Class"`` of the law (relative to ``vibeam.models``); a compliant law's class
        carries the same ``name`` and ``family`` and builds itself from a case's values
        (``from_spec``; :mod:`vibeam.models.compliant`).
    """

    kind: str
    implemented: bool
    keys: tuple
    family: str | None
    cls: str


#: families of compliant laws: one set of kernels each (vibeam.models.contact law codes)
FAMILIES = {
    "kelvin_voigt": "F = k_c delta + c_c delta' (the contact phase a linear flow, exact)",
    "hysteretic_hertz": "F = k_c delta^p (1 + chi delta' / v_in), chi a number of the law (contact phase integrated)",
}
_HERTZ_KEYS = ("stiffness", "stiffness_n_m", "exponent", "mass_kg")

#: contact laws of a stop (``[model.contact]`` / ``[model.contact_lower]`` key ``law``), the one
#: table of law names: name -> :class:`Law`.  A new law of an existing family is one class in
#: :mod:`vibeam.models.compliant` and one line here.
LAWS = {
    "restitution": Law("impulsive", True, ("R",), None, "contact:Restitution"),
    "linear": Law("compliant", True, ("stiffness", "stiffness_n_m", "damping_ratio", "mass_kg"), "kelvin_voigt",
                  "compliant:LinearContact"),
    "hunt_crossley": Law("compliant", True, _HERTZ_KEYS, "hysteretic_hertz", "compliant:HuntCrossley"),
    "lankarani_nikravesh": Law("compliant", True, _HERTZ_KEYS, "hysteretic_hertz", "compliant:LankaraniNikravesh"),
}
IMPLEMENTED_LAWS = tuple(n for n, law in LAWS.items() if law.implemented)


def mixed_stops(sc) -> bool:
    """Whether the stops at the scene's attached mass (contact row 0) mix the two kinds of law: a
    Newton stop beside a compliant one, either above.

    Parameters
    ----------
    sc : vibeam.models.scene.Scene
        Its stops, (relation, law) pairs (:mod:`vibeam.models.contact`).
    """
    return len({getattr(s.law, "kind", "") for s in sc.stops if s.relation.row == 0}) == 2


def law_family(law: str) -> str | None:
    """The family of compliant law ``law`` (None for an impulsive or unknown law)."""
    entry = LAWS.get(law)
    return None if entry is None else entry.family


def is_compliant(law: str) -> bool:
    """Whether ``law`` names a compliant law (a contact phase; :data:`LAWS`)."""
    entry = LAWS.get(law)
    return entry is not None and entry.kind == "compliant"


def law_class(law: str):
    """The class of law ``law`` (loads :mod:`vibeam.models.compliant`).

    Raises
    ------
    ValueError
        If ``law`` is not registered (the message lists the registered ones).
    """
    entry = LAWS.get(law)
    if entry is None:
        raise ValueError(f"contact law {law!r} is not registered; registered: {', '.join(LAWS)}")
    return resolve(entry.cls)


#: the key of Newton's (impulsive) law in a :class:`Method`'s tables, beside the families of
#: compliant laws (:data:`FAMILIES`)
IMPULSIVE = "impulsive"


class Method(NamedTuple):
    """One method of a fidelity and the stops it simulates: the one fact the registry keeps per
    method, from which every capability table of :class:`Fidelity` is derived.

    Attributes
    ----------
    solver : str
        ``"module:Class"`` of its solver for Newton's law (built as ``cls(scene, **settings)``);
        for ``continuation`` the shooting problem (``cls(scene, path, Omega=Omega, damping=damping)``).
    laws : dict
        Family of compliant laws (:data:`FAMILIES`) -> ``"module:Class"`` of the solver of its
        laws; a family not listed is refused by this method.
    two_sided : tuple of str
        The laws it simulates on two stops: :data:`IMPULSIVE` and/or families.
    mixed : bool
        It simulates a compliant stop beside a Newton one.
    restitution_law, positive_R, modal_states : bool
        It takes a velocity-dependent R; it needs ``R > 0``; it records the modal states.
    """

    solver: str
    laws: dict = {}       # never mutated: a changed entry is a new Method (``_replace``)
    two_sided: tuple = ()
    mixed: bool = False
    restitution_law: bool = False
    positive_R: bool = False
    modal_states: bool = False


def on_the_core(solver: str, **flags) -> Method:
    """A method of the one core (event integrator, direct solver or shooting problem,
    :mod:`vibeam.models.core`): every law of every family, on one or two stops, mixed ones
    included, by the same ``solver``."""
    return Method(solver, {f: solver for f in FAMILIES}, (IMPULSIVE,) + tuple(FAMILIES), True, **flags)


@dataclass(frozen=True)
class Fidelity:
    """One fidelity: its model, methods and capabilities (see the module docstring).

    Attributes
    ----------
    name : str
        Registry name, the ``fidelity`` key of a case's ``[model]`` table.
    model : str
        ``"module:name"`` of the model (relative to ``vibeam.models``): its class, or the builder
        of its scene (the SDOF's, :func:`vibeam.models.builders.sdof.sdof`; a structure's,
        :func:`vibeam.models.builders.matrices.structure_scene`), whose module's ``BUILDERS`` names it.
    solvers : dict
        Method name -> :class:`Method` (``"continuation"``: the shooting problem).  The tables
        ``methods``, ``shooting``, ``restitution_law_methods``, ``positive_R_methods`` and
        ``modal_state_methods`` are derived from it; what a method simulates by
        :func:`supported_methods`.
    """

    name: str
    model: str
    solvers: dict = field(compare=False)
    modes: bool = False
    contact_modes: bool = False
    eccentric_contact: bool = False
    coupled_platform: bool = False
    fe_model: bool = False
    mode_shapes: bool = False
    description: str = field(default="", compare=False)

    def _with(self, flag: str) -> tuple:
        return tuple(m for m, x in self.solvers.items() if getattr(x, flag))

    @property
    def methods(self) -> dict:
        """Method name -> ``"module:Class"`` of its solver for Newton's law (continuation apart)."""
        return {m: x.solver for m, x in self.solvers.items() if m != "continuation"}

    @property
    def shooting(self) -> str | None:
        """``"module:Class"`` of the shooting problem, or None."""
        x = self.solvers.get("continuation")
        return None if x is None else x.solver

    @property
    def method_names(self) -> tuple:
        """Names of the methods a case may ask for (``continuation`` when it has a shooting
        problem registered in :data:`vibeam.models.SHOOTING`, checked when planned)."""
        return tuple(self.methods) + ("continuation",)

    @property
    def restitution_law_methods(self) -> tuple:
        """Methods that take a velocity-dependent R (effect ``restitution_law``)."""
        return self._with("restitution_law")

    @property
    def positive_R_methods(self) -> tuple:
        """Methods that need ``R > 0`` (Ivanov's transformation, paper Eqs. 14-15)."""
        return self._with("positive_R")

    @property
    def modal_state_methods(self) -> tuple:
        """Methods whose solver records the modal states at the samples."""
        return self._with("modal_states")


FIDELITIES: dict[str, Fidelity] = {}
#: the starts of the shooting problem computed above the core, by name: ``"module:function"`` of
#: ``f(prob, scene, system, Omega, p) -> (x0 or None, reason)`` (the scene, its modal system and
#: Omega at the parameter's value ``p``), called by
#: :meth:`vibeam.models.core.scene_shooting.SceneShooting.start` for a period-1 start; its own
#: ``linear`` start is not listed
STARTS = {"averaging": "mapping.start:shooting_start"}
#: the families the SDOF's pointwise mapping passes a stop of (vibeam.models.mapping.orbit.PASSAGES)
_MAPPED = ("kelvin_voigt", "hysteretic_hertz")


def register(fid: Fidelity) -> Fidelity:
    """Add (or replace) a fidelity in :data:`FIDELITIES`; returns it."""
    FIDELITIES[fid.name] = fid
    return fid


register(Fidelity(
    name="sdof",
    model="builders.sdof:sdof",
    solvers={"event": on_the_core("core.event:EventSolver", restitution_law=True),
             "direct": on_the_core("paper.ode:DirectSolver"),
             # the textbook methods of one Newton stop (paper Sec. 3)
             "zhuravlev": Method("paper.ode:ZhuravlevSolver"),
             "ivanov": Method("paper.ode:IvanovSolver", positive_R=True),
             "averaging": Method("paper.averaging:AveragingSolver"),
             # the one pointwise mapping (paper Sec. 4.2): a passage through a stop of each law, on
             # one or two stops, mixed ones included
             "mapping": Method("mapping:MappingSolver", {f: "mapping:MappingSolver" for f in _MAPPED},
                               (IMPULSIVE,) + _MAPPED, True),
             "continuation": on_the_core("core.scene_shooting:SceneShooting")},
    description="SDOF coefficient-of-restitution oscillator (paper Eqs. 1-2, 43-47)"))

#: the methods of an N-mode scene (the beam's, a structure's given by matrices): the event
#: and direct integrators, the N-mode pointwise mapping (paper Sec. 4.2: Newton and Kelvin-Voigt stops,
#: exact flows, anywhere, one or two at the mass, mixed ones included) and the shooting problem
N_MODE_SOLVERS = {"event": on_the_core("core.event:BeamEventSolver", restitution_law=True, modal_states=True),
                  "direct": on_the_core("core.direct:BeamODESolver", restitution_law=True),
                  "mapping": Method("mapping.modal:ModalMappingSolver",
                                    {"kelvin_voigt": "mapping.modal:ModalMappingSolver"},
                                    (IMPULSIVE, "kelvin_voigt"), True),
                  "continuation": on_the_core("core.scene_shooting:SceneShooting")}

register(Fidelity(
    name="beam",
    model="builders.beam:fe_beam",
    solvers=dict(N_MODE_SOLVERS),
    modes=True,
    contact_modes=True,
    eccentric_contact=True,
    coupled_platform=True,
    fe_model=True,
    mode_shapes=True,
    description="FE cantilever in modal coordinates (paper Sec. 6, Eqs. 39-41)"))


register(Fidelity(
    name="matrices",
    model="builders.matrices:structure_scene",
    # the N-mode modal system of any linear structure given by its matrices (issue 58): the same
    # methods as the beam's modal model (its scene: builders.matrices.structure_scene)
    solvers=dict(N_MODE_SOLVERS),
    modes=True,
    contact_modes=True,
    description="a linear structure given by its mass, stiffness and damping matrices, in modal coordinates"))

register(Fidelity(
    name="continuum",
    model="builders.matrices:structure_scene",
    # the rig as a 3D elastic continuum (issue 59, vibeam.models.builders.continuum) reduced to its
    # modes: the N-mode modal system, the same methods as a structure given by its matrices
    solvers=dict(N_MODE_SOLVERS),
    modes=True,
    contact_modes=True,
    mode_shapes=True,
    description="the rig as a 3D linear-elastic continuum (scikit-fem) with a rigid disc stack, in modal coordinates"))

register(Fidelity(
    name="mesh",
    model="builders.matrices:structure_scene",
    # a user's part from a mesh file (meshio) as a 3D elastic continuum (issue 59), reduced to its
    # modes by the continuum's builder: the N-mode modal system, the same methods again
    solvers=dict(N_MODE_SOLVERS),
    modes=True,
    contact_modes=True,
    mode_shapes=True,
    description="a user's part from a mesh file (meshio: Gmsh .msh, .vtu, ...) as a 3D linear-elastic continuum, "
                "in modal coordinates"))


def fidelity(name_or_model) -> Fidelity:
    """The :class:`Fidelity` of a registry name, or of a model or spec (its ``fidelity``).

    Raises
    ------
    ValueError
        If the name is not registered (the message lists the registered ones).
    """
    name = name_or_model if isinstance(name_or_model, str) else getattr(name_or_model, "fidelity", None)
    fid = FIDELITIES.get(name)
    if fid is None:
        raise ValueError(f"fidelity {name!r} is not registered; registered: {', '.join(sorted(FIDELITIES))}")
    return fid


def law_key(law) -> str:
    """:data:`IMPULSIVE` or the family of a compliant law: the key of a :class:`Method`'s tables.

    ``law`` is a law object (its ``kind`` and ``family``) or a law's name in :data:`LAWS`.

    Raises
    ------
    ValueError
        For a name that is not registered (the message lists the registered ones).
    """
    if isinstance(law, str):
        entry = LAWS.get(law)
        if entry is None:
            raise ValueError(f"contact law {law!r} is not registered; registered: {', '.join(LAWS)}")
        return IMPULSIVE if entry.kind == "impulsive" else entry.family
    return IMPULSIVE if getattr(law, "kind", "impulsive") == "impulsive" else law.family


def supported_methods(name: str, upper: str = IMPULSIVE, lower: str | None = None) -> tuple:
    """The methods of fidelity ``name`` that simulate the stops at its attached mass: the one
    capability function (issue 43: derived, not tabulated).

    A method simulates them when its :class:`Method` serves the law of each stop (Newton's, or a
    family in its ``laws``), each on two stops when there are two (``two_sided``), and a Newton
    stop beside a compliant one when they mix (``mixed``).  Stops elsewhere on a beam are Newton
    stops of the one core, served by every method of the beam.

    Parameters
    ----------
    name : str
        The fidelity's registry name.
    upper : str
        :func:`law_key` of the upper stop's law (the paper's stop).
    lower : str or None
        :func:`law_key` of the lower stop's law at the mass; None without one.

    Returns
    -------
    tuple of str
        Method names in the fidelity's order, ``"continuation"`` among them when its shooting
        problem serves the stops.
    """
    fid = fidelity(name)
    keys = (upper,) if lower is None else (upper, lower)
    mixed = len({k == IMPULSIVE for k in keys}) == 2
    return tuple(m for m, x in fid.solvers.items()
                 if all(k == IMPULSIVE or k in x.laws for k in keys)
                 and (lower is None or all(k in x.two_sided for k in keys))
                 and (x.mixed or not mixed))


def mass_law_keys(scene) -> tuple:
    """``(upper, lower)``: the :func:`law_key` of the laws of a scene's stops at the attached mass
    (those on its first contact row, ``relation.row == 0``), ``lower`` None without a second stop
    there."""
    keys = [law_key(s.law) for s in scene.stops if s.relation.row == 0]
    return keys[0], (keys[1] if len(keys) > 1 else None)


def law_name(scene) -> str:
    """The name of the law of a scene's first stop: ``"restitution"`` for Newton's, else the
    compliant law's ``name`` (a key of :data:`LAWS`)."""
    law = scene.stops[0].law
    return "restitution" if law.kind == "impulsive" else law.name


def with_capability(flag: str) -> list[str]:
    """Names of the fidelities whose capability ``flag`` is true (or non-empty)."""
    return [n for n, f in FIDELITIES.items() if getattr(f, flag)]


def resolve(path: str):
    """The object named by ``"module:attribute"`` (module relative to ``vibeam.models``)."""
    mod, _, attr = path.partition(":")
    return getattr(importlib.import_module(f"vibeam.models.{mod}"), attr)
