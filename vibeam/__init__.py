"""vibeam: vibro-impact structural dynamics of an impacting cantilever beam.

Fidelities live in :mod:`vibeam.models`, reductions in :mod:`vibeam.reductions`;
the sweep engine, case files, results and plots in this package.  The Python API
(:mod:`vibeam.api`)::

    import vibeam
    case = vibeam.load_case("cases/paper-fig7.toml")
    res = vibeam.run(case)                   # Results: .runs, .to_xarray(), .plot_frc(), ...
    sim = vibeam.simulate(case, Omega=2.0)   # one frequency: .t, .q, .dq, .impact_times, ...
    tree = vibeam.open_results("results/paper-fig7/results.h5")   # xarray.DataTree
    bas = vibeam.basins("cases/rig-tight.toml", frequency_hz=16.5)   # basins of attraction
    con = vibeam.continuation("cases/paper-fig13-continuation.toml")  # Results: .branches, .bifurcations
    sec = vibeam.poincare("cases/paper-fig7.toml", Omega=2.0)         # Poincaré sections
    vibeam.export("results/paper-fig7/results.h5", "csv/")           # tidy CSV per group
    # and vibeam.derive, modes, regress, cost, fit: the other commands

Its names are imported on first use, so ``import vibeam`` stays fast.
"""
from vibeam.version import __version__

_API = ("load_case", "run", "simulate", "lyapunov", "basins", "open_results", "continuation", "continue_", "derive",
        "modes", "regress", "cost", "fit", "export", "poincare", "uncertainty", "Results", "Simulation", "Lyapunov")
__all__ = ["__version__", *_API]


def __getattr__(name):
    if name in _API:
        from vibeam import api  # lazy: keeps the API out of `import vibeam` (its names load on first use)

        # through the API's own lookup, not getattr: once its module vibeam.api.uncertainty is imported
        # (the command line does), the package attribute of that name is the module, not the function
        return api.__getattr__(name)
    raise AttributeError(f"module 'vibeam' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + list(_API))
