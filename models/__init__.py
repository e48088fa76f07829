"""The dynamics of vibeam, in rooms from the bottom up (``tests/test_architecture.py``):

* the scene and what it holds: :mod:`.scene` (``Scene(system, stops, builder)``), :mod:`.system`
  (the linear modal system), :mod:`.contact`, :mod:`.impact`, :mod:`.compliant` (relations and
  laws), :mod:`.builders` (the SDOF, the FE beam, a user's matrices, a continuum or mesh), the
  :mod:`.registry` of fidelities and :mod:`.trajectory` (what a time-domain method returns);
* :mod:`.core`: flows, the one event integrator, the one direct solver, the one shooting problem;
* :mod:`.paper` and :mod:`.mapping`: the paper's methods of the one-mode scene, the pointwise maps;
* :mod:`.orbits`: continuation, Lyapunov exponents, attractors and basins of the stroboscopic map.

What each fidelity is and can do is declared once, in :mod:`vibeam.models.registry`;
:data:`METHODS` and :data:`SHOOTING` are views of it.  Solvers are built by
:func:`make_solver` from a model, a method name and its settings; every time-domain solver
has ``point(Omega, state0, n_transient, n_record, samples_per_period)`` returning a
:class:`~vibeam.models.trajectory.Trajectory`, so that the one sweep engine drives them all.

Submodules are imported on first use (``vibeam.models.EventSolver`` loads :mod:`.core.event`), so that
the case validator can read the registry without loading numba kernels or scipy.
"""
from __future__ import annotations

import importlib

from . import _cache, _inline_copy

_cache.install()   # before any kernel module: the cache key covers the whole package
_inline_copy.install()   # numba's inliner copies a callee's scope once, not once per block

from .registry import (FIDELITIES, IMPULSIVE, fidelity, law_key, law_name, mass_law_keys, resolve,  # noqa: E402
                       supported_methods)

# public names -> their module (imported on first access, PEP 562)
_LAZY = {
    "EventSolver": "core.event", "linear_amplitude": "core.oscillator",
    "AveragingSolver": "paper.averaging", "MappingSolver": "mapping",
    "BeamEventSolver": "core.event",
    "BeamODESolver": "core.direct",
    "DirectSolver": "paper.ode", "IvanovSolver": "paper.ode", "ZhuravlevSolver": "paper.ode",
    "SceneShooting": "core.scene_shooting", "Trajectory": "trajectory",
}


def __getattr__(name):
    if name == "METHODS":
        # solver classes by (fidelity, method), from the registry (loads every solver module)
        table = {(f.name, m): resolve(p) for f in FIDELITIES.values() for m, p in f.methods.items()}
        globals()["METHODS"] = table
        return table
    if name == "SHOOTING":
        # shooting problems of the periodic-orbit continuation (contract: vibeam.models.core.periodic), by
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


def _scene_of(model):
    """``model`` as a scene: a :class:`~vibeam.models.scene.Scene` itself, else its ``scene()``."""
    return model.scene() if hasattr(model, "scene") else model


def shooting_problem(model, parameter="Omega", Omega: float | None = None, damping=None, **settings):
    """The shooting problem of a scene (or a model's scene) continued in ``parameter``: the
    scene's one problem, :class:`~vibeam.models.core.scene_shooting.SceneShooting`.

    Parameters
    ----------
    model : Scene or a model with ``scene()``
        Its builder (``scene.builder``) names its fidelity in the registry.
    parameter : str or tuple of str
        A path into the scene (``SceneShooting.PATHS``: ``"Omega"``, ``"system.base_amplitude"``,
        ``"stops[k].relation.offset"``, ``"stops[k].law.R"``, ``"system.damping"``), in the scene's
        units; a tuple of stop paths of one kind moves them together.
    Omega : float or None
        The forcing frequency of a continuation in another parameter (the scene's units).
    damping : (float, array of shape (n,)) or None
        For ``"system.damping"``: the parameter's value and ``d c / d p`` of each mode.
    settings
        The event integrator's (``chatter_tol``, ``max_steps_per_period``, ...).

    Raises
    ------
    ValueError
        If no shooting problem is registered for the scene's fidelity, the parameter is not one
        of the scene's paths, or the problem does not serve the stops at the attached mass
        (:func:`vibeam.models.registry.supported_methods`).  A compliant upper stop gets its
        family's shooting problem (the ``continuation`` :class:`~vibeam.models.registry.Method`'s
        ``laws``).
    """
    sc = _scene_of(model)
    fid = fidelity(sc.builder)
    up, _ = mass_law_keys(sc)
    if "continuation" not in supported_methods(fid.name, up):
        raise ValueError(f"continuation is not available for contact law {law_name(sc)!r} of fidelity "
                         f"{fid.name!r} (no shooting problem registered); use method = \"event\"")
    why = _refusal(sc, "continuation")
    if why:
        raise ValueError(f"continuation {why}; use method = \"event\"")
    if up != IMPULSIVE:
        # a compliant upper stop: its family's shooting problem (registry ``Method.laws``)
        cls = resolve(fid.solvers["continuation"].laws[up])
    else:
        shooting = globals()["SHOOTING"] if "SHOOTING" in globals() else __getattr__("SHOOTING")
        cls = shooting.get(fid.name)
        if cls is None:
            raise ValueError(f"continuation is not available for fidelity {fid.name!r} (no shooting "
                             f"problem registered); available: {', '.join(sorted(shooting))}")
    return cls(sc, parameter, Omega=Omega, damping=damping, **settings)


def make_solver(model, method: str, **settings):
    """Solver for a scene (or a model's scene) by ``method`` (e.g. ``"event"``) with its settings.

    Raises
    ------
    ValueError
        If the method does not exist for the scene's fidelity (its ``builder``) or does not
        simulate the stops at its attached mass (their laws, two stops, mixed kinds: the one
        capability function :func:`vibeam.models.registry.supported_methods`).
    """
    sc = _scene_of(model)
    fid = fidelity(sc.builder)
    if method not in fid.methods:
        raise ValueError(f"method {method!r} is not available for fidelity {fid.name!r}; "
                         f"allowed: {', '.join(sorted(fid.methods))}")
    why = _refusal(sc, method)
    if why:
        raise ValueError(f"method {method!r} {why}")
    up, _ = mass_law_keys(sc)
    x = fid.solvers[method]
    return resolve(x.solver if up == IMPULSIVE else x.laws[up])(sc, **settings)


def _refusal(sc, method: str) -> str:
    """Why ``method`` cannot simulate the scene's stops at its attached mass ('' when it can), by
    the one capability function :func:`vibeam.models.registry.supported_methods`."""
    fid = fidelity(sc.builder)
    up, lo = mass_law_keys(sc)
    one = supported_methods(fid.name, up)
    both = one if lo is None else supported_methods(fid.name, up, lo)
    allowed = f"allowed with these stops: {', '.join(both) or 'none'}"
    if lo is not None and (up == IMPULSIVE) != (lo == IMPULSIVE) and method not in both:
        what = ("a compliant stop beside a restitution one" if up == IMPULSIVE else
                "a restitution stop beside a compliant one")
        return f"cannot simulate {what}; {allowed}"
    if method not in one:
        return (f"does not simulate contact law {law_name(sc)!r} of fidelity {fid.name!r}; allowed: "
                f"{', '.join(m for m in one if m != 'continuation') or 'none'}")
    if method not in both:
        return f"cannot simulate a second (lower) stop{'' if lo == up else f' of another law ({lo})'}; {allowed}"
    # the stops away from the attached mass (a structure's, each its own law): each law with the upper one's
    away = tuple(s for s in sc.stops if s.relation.row != 0)
    for k in dict.fromkeys(law_key(s.law) for s in away):
        ok = supported_methods(fid.name, up, k)
        if method not in ok:
            return f"cannot simulate a stop of law family {k!r} away from the attached mass; allowed: {', '.join(ok) or 'none'}"
    return ""


__all__ = ["EventSolver", "linear_amplitude", "make_solver", "METHODS", "SHOOTING",
           "shooting_problem", "SceneShooting", "FIDELITIES", "fidelity", "Trajectory"]
