"""Fault injection for testing the sweep engine's recovery (not used by the framework itself).

:class:`CrashingSolver` wraps a solver and kills the worker process running it at chosen
forcing frequencies, once per marker file, as a killed machine or an out-of-memory kill
would; :class:`FailingSolver` raises at chosen frequencies, as a numerical failure would.
Both are picklable, so they travel to process pools and dask workers like any solver.
"""
from __future__ import annotations

import os
from pathlib import Path


class _Wrapped:
    def __init__(self, solver, Omegas):
        self.solver = solver
        self.Omegas = tuple(float(w) for w in Omegas)

    def __getattr__(self, name):  # model, name, time_domain, settings, ...
        if name == "solver":
            raise AttributeError(name)
        return getattr(self.solver, name)

    def _hit(self, Omega) -> bool:
        return any(abs(float(Omega) - w) <= 1e-12 * max(1.0, abs(w)) for w in self.Omegas)


class CrashingSolver(_Wrapped):
    """Kill the worker process (``os._exit``) at the first point with Omega in ``Omegas``,
    once: the marker file ``marker`` records the crash, so the retried line runs normally.

    Parameters
    ----------
    solver : object
        The solver to wrap.
    Omegas : sequence of float
        Forcing frequencies (nondimensional) at which to crash.
    marker : str or Path or None
        A file created just before the crash (must not exist beforehand);
        None: crash at every attempt.
    """

    def __init__(self, solver, Omegas, marker=None):
        super().__init__(solver, Omegas)
        self.marker = None if marker is None else str(marker)

    def point(self, Omega, *args, **kwargs):
        if self._hit(Omega) and (self.marker is None or not Path(self.marker).exists()):
            if self.marker is not None:
                Path(self.marker).write_text(f"crashed at Omega = {Omega!r} in pid {os.getpid()}\n")
            os._exit(17)
        return self.solver.point(Omega, *args, **kwargs)


class FailingSolver(_Wrapped):
    """Raise ``FloatingPointError`` at every point with Omega in ``Omegas``."""

    def point(self, Omega, *args, **kwargs):
        if self._hit(Omega):
            raise FloatingPointError(f"injected numerical failure at Omega = {Omega!r}")
        return self.solver.point(Omega, *args, **kwargs)
