"""The Python API: what the command line does, from a notebook.

::

    import vibeam
    case = vibeam.load_case("cases/paper-fig7.toml")     # a path, TOML text or a dict
    res = vibeam.run(case, jobs=2)                         # every run (or the [map]) of the case
    ds = res.to_xarray("exact")                            # xarray.Dataset on (direction, Omega)
    fig = res.plot_frc()                                   # matplotlib Figures, the CLI's plots
    sim = vibeam.simulate(case, Omega=2.0, periods=4)      # one frequency: t, q, q', impacts

Its modules, by topic:

* :mod:`vibeam.api.cases`: :func:`load_case`, :func:`case_text`;
* :mod:`vibeam.api.results`: :class:`Results` (with its groups ``Run``, ``Map``, ``Branches``,
  ``Basins``, ``Bifurcations``, ``Curves``, ``Uncertainty``) and :func:`open_results`;
* :mod:`vibeam.api.runs`: :func:`run`, :func:`continuation` (``continue_``), :func:`basins`,
  :func:`run_basins`;
* :mod:`vibeam.api.simulation`: one frequency, :func:`simulate`, :func:`lyapunov`, :func:`poincare`;
* :mod:`vibeam.api.scene`: a beam scene's :func:`derive` and :func:`modes`;
* :mod:`vibeam.api.references`: :func:`regress`, :func:`cost`, :func:`fit`;
* :mod:`vibeam.api.tables`: :func:`export`;
* :mod:`vibeam.api.uncertainty`: :func:`uncertainty` (FRC bands of ``[uncertainty]``).

A name's module is imported on its first use (``vibeam.api.run``, ``from vibeam.api import run``),
with what that module needs: ``vibeam.load_case`` loads the case schema only, not the sweep engine,
the results readers or the figures (0.4 s against 1.1 s with every module), and ``vibeam derive``
no results reader; xarray loads when labelled data are asked for.
"""
from __future__ import annotations

import importlib

#: every public name of the API -> its module in this package
WHERE = {
    "load_case": "cases", "case_text": "cases",
    "Results": "results", "open_results": "results", "Run": "results", "Map": "results", "Branches": "results",
    "Basins": "results", "Bifurcations": "results", "Curves": "results", "Uncertainty": "results",
    "run": "runs", "continuation": "runs", "continue_": "runs", "basins": "runs", "run_basins": "runs",
    "Simulation": "simulation", "simulate": "simulation", "Lyapunov": "simulation", "lyapunov": "simulation",
    "poincare": "simulation", "STATE_MAX": "simulation",
    "Derived": "scene", "derive": "scene", "Modes": "scene", "modes": "scene", "write_modes_files": "scene",
    "modes_figure": "scene",
    "Regression": "references", "regress": "references", "Cost": "references", "cost": "references",
    "fit": "references",
    "export": "tables", "MAX_STEM_BYTES": "tables",
    "uncertainty": "uncertainty",
}
__all__ = list(WHERE)


def __getattr__(name):
    if name not in WHERE:
        raise AttributeError(f"module 'vibeam.api' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"vibeam.api.{WHERE[name]}"), name)
    globals()[name] = value          # found here from now on
    return value


def __dir__():
    return sorted(set(globals()) | set(WHERE))
