"""Fidelities of vibeam: the SDOF impact oscillator and (later) the FE beam.

Solvers are built by :func:`make_solver` from a model, a method name and its
settings; every solver has ``point(Omega, state0, n_transient, n_record,
samples_per_period)`` so that the one sweep engine drives them all.
"""
from __future__ import annotations

from . import _cache

_cache.install()   # before any kernel module: the cache key covers the whole package

from .sdof import SDOF, EventSolver, linear_amplitude

from .sdof_averaging import AveragingSolver
from .sdof_mapping import MappingSolver
from .beam_dynamics import BeamEventSolver, BeamImpactModel, BeamODESolver
from .sdof_ode import DirectSolver, IvanovSolver, ZhuravlevSolver
from .periodic_sdof import SDOFShooting

METHODS = {
    ("beam", "event"): BeamEventSolver,
    ("beam", "direct"): BeamODESolver,
    ("sdof", "event"): EventSolver,
    ("sdof", "averaging"): AveragingSolver,
    ("sdof", "mapping"): MappingSolver,
    ("sdof", "direct"): DirectSolver,
    ("sdof", "zhuravlev"): ZhuravlevSolver,
    ("sdof", "ivanov"): IvanovSolver,
}


# shooting problems of the periodic-orbit continuation (contract: vibeam.models.periodic), by
# fidelity; a fidelity that registers one here can be continued (`method = "continuation"`)
SHOOTING = {
    "sdof": SDOFShooting,
}


def shooting_problem(model, parameter: str, Omega: float | None = None):
    """The shooting problem of ``model`` in the native ``parameter`` (``Omega``: forcing
    frequency of a continuation in another parameter).

    Raises
    ------
    ValueError
        If no shooting problem is registered for the model's fidelity, or the parameter is not
        one of the problem's.
    """
    cls = SHOOTING.get(model.fidelity)
    if cls is None:
        raise ValueError(f"continuation is not available for fidelity {model.fidelity!r} (no shooting "
                         f"problem registered); available: {', '.join(sorted(SHOOTING))}")
    return cls(model, parameter, Omega=Omega)


def make_solver(model, method: str, **settings):
    """Solver for ``model`` by ``method`` (e.g. ``"event"``) with its settings.

    Raises
    ------
    ValueError
        If the method does not exist for the model's fidelity.
    """
    key = (model.fidelity, method)
    if key not in METHODS:
        allowed = sorted(m for f, m in METHODS if f == model.fidelity)
        raise ValueError(f"method {method!r} is not available for fidelity {model.fidelity!r}; "
                         f"allowed: {', '.join(allowed)}")
    return METHODS[key](model, **settings)


__all__ = ["SDOF", "EventSolver", "linear_amplitude", "make_solver", "METHODS", "SHOOTING",
           "shooting_problem", "SDOFShooting"]
