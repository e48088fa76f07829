"""Fidelities of vibeam: the SDOF impact oscillator and the modal FE beam.

What each fidelity is and can do is declared once, in :mod:`vibeam.models.registry`;
:data:`METHODS` and :data:`SHOOTING` are views of it.  Solvers are built by
:func:`make_solver` from a model, a method name and its settings; every time-domain solver
has ``point(Omega, state0, n_transient, n_record, samples_per_period)`` returning a
:class:`~vibeam.models.trajectory.Trajectory`, so that the one sweep engine drives them all.

Submodules are imported on first use (``vibeam.models.SDOF`` loads :mod:`.sdof`), so that
the case validator can read the registry without loading numba kernels or scipy.
"""
from __future__ import annotations

import importlib

from . import _cache

_cache.install()   # before any kernel module: the cache key covers the whole package

from .registry import FIDELITIES, fidelity, is_compliant, law_family, mixed_stops, resolve  # noqa: E402

# public names -> their module (imported on first access, PEP 562)
_LAZY = {
    "SDOF": "sdof", "EventSolver": "sdof", "linear_amplitude": "sdof",
    "AveragingSolver": "sdof_averaging", "MappingSolver": "mapping",
    "BeamEventSolver": "beam_dynamics", "BeamImpactModel": "beam_dynamics",
    "BeamODESolver": "beam_dynamics",
    "DirectSolver": "sdof_ode", "IvanovSolver": "sdof_ode", "ZhuravlevSolver": "sdof_ode",
    "SDOFShooting": "periodic_sdof", "BeamContinuation": "periodic_beam", "Trajectory": "trajectory",
}


def __getattr__(name):
    if name == "METHODS":
        # solver classes by (fidelity, method), from the registry (loads every solver module)
        table = {(f.name, m): resolve(p) for f in FIDELITIES.values() for m, p in f.methods.items()}
        globals()["METHODS"] = table
        return table
    if name == "SHOOTING":
        # shooting problems of the periodic-orbit continuation (contract: vibeam.models.periodic), by
        # fidelity, from the registry; a plain dict (tests may patch it), built once
        table = {f.name: resolve(f.shooting) for f in FIDELITIES.values() if f.shooting}
        globals()["SHOOTING"] = table
        return table
    mod = _LAZY.get(name)
    if mod is not None:
        value = getattr(importlib.import_module(f".{mod}", __name__), name)
        globals()[name] = value
        return value
    try:
        return importlib.import_module(f".{name}", __name__)
    except ModuleNotFoundError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | {"SHOOTING", "METHODS"})


def shooting_problem(model, parameter: str, Omega: float | None = None):
    """The shooting problem of ``model`` in the native ``parameter`` (``Omega``: forcing
    frequency of a continuation in another parameter).

    Raises
    ------
    ValueError
        If no shooting problem is registered for the model's fidelity, or the parameter is not
        one of the problem's. A scene with two stops is served (the restitution shooting problems
        follow impacts on both). A model with a compliant stop gets its law's shooting problem
        (registry ``contact_laws[family]["continuation"]`` of the law's family), or this error when
        the family has none or the scene has two stops and the family's ``two_sided_law_methods``
        lack ``"continuation"``.
    """
    law = getattr(model, "contact_law", "restitution")
    if is_compliant(law):
        # a compliant law: its shooting problem is its family's "continuation" entry of the registry
        fam = law_family(law)
        path = fidelity(model).contact_laws.get(fam, {}).get("continuation")
        if path is None:
            raise ValueError(f"continuation is not available for contact law {law!r} of fidelity "
                             f"{model.fidelity!r} (no shooting problem registered); use method = \"event\"")
        if mixed_stops(model) and "continuation" not in fidelity(model).mixed_stop_methods:
            raise ValueError("continuation with a restitution stop beside a compliant one is not implemented; "
                             "use method = \"event\"")
        if getattr(model, "two_sided", False) and \
                "continuation" not in fidelity(model).two_sided_law_methods.get(fam, ()):
            raise ValueError(f"continuation with contact law {law!r} and a second (lower) stop is not "
                             f"implemented for this law and fidelity; use method = \"event\"")
        return resolve(path)(model, parameter, Omega=Omega)
    if mixed_stops(model) and "continuation" not in fidelity(model).mixed_stop_methods:
        raise ValueError("continuation with a compliant stop beside a restitution one is not implemented for "
                         f"fidelity {model.fidelity!r}; use method = \"event\"")
    shooting = globals()["SHOOTING"] if "SHOOTING" in globals() else __getattr__("SHOOTING")
    cls = shooting.get(model.fidelity)
    if cls is None:
        raise ValueError(f"continuation is not available for fidelity {model.fidelity!r} (no shooting "
                         f"problem registered); available: {', '.join(sorted(shooting))}")
    return cls(model, parameter, Omega=Omega)


def make_solver(model, method: str, **settings):
    """Solver for ``model`` by ``method`` (e.g. ``"event"``) with its settings.

    Raises
    ------
    ValueError
        If the method does not exist for the model's fidelity, does not simulate the model's
        contact law (registry ``contact_laws`` of its family), or cannot simulate the model's second stop
        (``two_sided_methods`` of the registry).
    """
    fid = fidelity(model)
    law = getattr(model, "contact_law", "restitution")
    if is_compliant(law):   # a compliant law: its family's solvers (registry ``contact_laws``)
        fam = law_family(law)
        if mixed_stops(model) and method not in fid.mixed_stop_methods:
            raise ValueError(f"method {method!r} cannot simulate a restitution stop beside a compliant one; "
                             f"allowed: {', '.join(fid.mixed_stop_methods) or 'none'}")
        table = {k: v for k, v in fid.contact_laws.get(fam, {}).items() if k != "continuation"}
        if method not in table:
            allowed = ", ".join(table) or "none"
            raise ValueError(f"method {method!r} does not simulate contact law {law!r} of fidelity "
                             f"{fid.name!r}; allowed: {allowed}")
        two = fid.two_sided_law_methods.get(fam, ())
        if getattr(model, "two_sided", False) and method not in two:
            raise ValueError(f"method {method!r} cannot simulate contact law {law!r} on a second (lower) stop; "
                             f"allowed with two stops: {', '.join(two) or 'none'}")
        lower = getattr(getattr(model, "lower_law", None), "name", law)
        two_lower = fid.two_sided_law_methods.get(law_family(lower), ())
        if getattr(model, "two_sided", False) and not mixed_stops(model) and lower != law and \
                method not in two_lower:
            raise ValueError(f"method {method!r} cannot simulate contact law {lower!r} on the lower stop; allowed: "
                             f"{', '.join(two_lower) or 'none'}")
        return resolve(table[method])(model, **settings)
    path = fid.methods.get(method)
    if path is None:
        raise ValueError(f"method {method!r} is not available for fidelity {fid.name!r}; "
                         f"allowed: {', '.join(sorted(fid.methods))}")
    if mixed_stops(model) and method not in fid.mixed_stop_methods:
        # a restitution upper stop above a compliant lower one
        raise ValueError(f"method {method!r} cannot simulate a compliant stop beside a restitution one; "
                         f"allowed: {', '.join(fid.mixed_stop_methods) or 'none'}")
    if getattr(model, "two_sided", False) and method not in fid.two_sided_methods:
        raise ValueError(f"method {method!r} cannot simulate a second (lower) stop; allowed with two stops: "
                         f"{', '.join(fid.two_sided_methods)}")
    return resolve(path)(model, **settings)


__all__ = ["SDOF", "EventSolver", "linear_amplitude", "make_solver", "METHODS", "SHOOTING",
           "shooting_problem", "SDOFShooting", "BeamContinuation", "FIDELITIES", "fidelity", "Trajectory"]
