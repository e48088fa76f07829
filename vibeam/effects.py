"""Scene effects (``[effects]`` of a case): applied only when a scene asks for them.

:func:`wrap_solver` is the single place where effects enter a run: with no
active effect it returns the plain solver unchanged (same model, same DOFs,
same kernel), so a plain scene never pays for an effect.
"""
from __future__ import annotations


def wrap_solver(solver, model, spec, effects, run_settings: dict | None = None):
    """Solver of a run with its effects applied (the plain solver when none is active).

    Parameters
    ----------
    solver : object
        Solver from :func:`vibeam.models.make_solver`.
    model : object
        Its model.
    spec : vibeam.case.SDOFModelSpec or vibeam.case.BeamModelSpec
        The validated model table.
    effects : vibeam.case.EffectsSpec
        Active effects of the run.

    Raises
    ------
    vibeam.case.CaseError
        If an effect does not make sense for the fidelity or method.
    """
    if not effects.active():
        return solver
    from .case import CaseError

    raise CaseError(f"effects {effects.active()} are not implemented yet")
