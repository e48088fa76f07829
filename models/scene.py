"""The scene: one modal system and its stops, the only thing the methods' cores are built from.

A :class:`Scene` is Siconos' split (a ``NonSmoothDynamicalSystem`` of one ``LagrangianLinearTIDS``
and its ``Interaction``\\ s): ``system``, the base-excited linear system in modal coordinates
(:class:`vibeam.models.system.ModalSystem`; the SDOF is its one-mode case), and ``stops``, a tuple
of :class:`vibeam.models.contact.Stop` (relation, law), each law the only holder of its numbers,
in the system's units.  The units (seconds, metres and kilograms per unit of time, displacement
and effective mass) are the system's own fields, so nothing holds them twice: :func:`units`.

The fidelities are builders of scenes: :func:`sdof_scene` (paper Eqs. 1-2, 43-46) and
:func:`beam_scene` (the modal FE beam, Eqs. 39-42, with any number of modes or the static mode);
a model object's ``scene()`` calls its builder.  The event integrator
(:class:`vibeam.models.core.event.EventIntegrator`), the direct integrator, the shooting problems,
the N-mode mapping and the basins take a Scene.

References
----------
V. Acary, B. Brogliato, *Numerical Methods for Nonsmooth Dynamical Systems*, Springer 2008,
Ch. 3 and 7 (relations, laws, the event-driven scheme); Siconos' ``NonSmoothDynamicalSystem``.
"""
from __future__ import annotations

from typing import NamedTuple

from .system import ModalSystem, from_beam, from_sdof

__all__ = ["Scene", "sdof_scene", "beam_scene", "units"]


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
    """

    system: ModalSystem
    stops: tuple


def sdof_scene(sdof) -> Scene:
    """The SDOF impact oscillator as a scene: the one-mode system (paper Eqs. 1, 43-46,
    :func:`vibeam.models.system.from_sdof`) and its stops at ``q = Delta`` (and ``q = -Delta_lower``).

    Parameters
    ----------
    sdof : vibeam.models.sdof.SDOF
        Nondimensional or physical (then the scene's units are ``1 / (2 pi f_n)`` s and ``L`` m).
    """
    return Scene(from_sdof(sdof), tuple(sdof.stops()))


def beam_scene(model) -> Scene:
    """The modal FE beam as a scene: its retained modes (paper Eqs. 39-42,
    :func:`vibeam.models.system.from_beam`) and its stops (at the attached mass, and at other points
    of the beam) with the laws in the system's units (a compliant stiffness over ``omega_ref^2``).

    Parameters
    ----------
    model : vibeam.models.beam_dynamics.BeamImpactModel
        Or its compliant subclass; any number of modes, the static-mode model included.
    """
    return Scene(from_beam(model), tuple(model.system_stops()))


def units(sc: Scene) -> dict:
    """The scene's units: ``{"time_s", "length_m", "mass_kg", "coordinate_scale"}`` (seconds per
    unit of ``t``, metres per unit of the reported ``q``, kilograms per unit of effective mass, row
    value per unit of ``q``); NaN for what a nondimensional scene does not have."""
    s = sc.system
    return {"time_s": s.time_unit_s, "length_m": s.length_unit_m, "mass_kg": s.mass_unit_kg,
            "coordinate_scale": s.coordinate_scale}
