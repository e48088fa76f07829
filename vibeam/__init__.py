"""vibeam: vibro-impact structural dynamics of an impacting cantilever beam.

Fidelities live in :mod:`vibeam.models`, reductions in :mod:`vibeam.reductions`;
the sweep engine, case files, results and plots in this package.
"""
__version__ = "0.1.0"
