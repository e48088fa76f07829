"""Fault injection for testing the sweep engine's recovery (not used by the framework itself).

:class:`CrashingSolver` wraps a solver and kills the worker process running it at chosen
forcing frequencies, once per marker file, as a killed machine or an out-of-memory kill
would; :class:`FailingSolver` raises at chosen frequencies, as a numerical failure would.
Both are picklable, so they travel to process pools and dask workers like any solver.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np


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


def check_labelled(path) -> dict:
    """Check that a results file is labelled data (the layout of :mod:`vibeam.io.results`), as
    xarray sees it; returns ``{group path: xarray.Dataset}`` of the runs and maps.

    Every run has the dimensions ``direction`` and ``Omega`` (coordinates; physical scenes
    also the coordinate ``frequency_hz`` along ``Omega``); every map ``direction``, its
    parameter (a coordinate named after it, with units) and ``Omega`` or ``frequency_hz``;
    no phony dimensions; every numeric variable has ``units``, every variable a
    ``long_name``; strings are ``str``.

    Raises
    ------
    AssertionError
        Naming the group and variable at fault.
    """
    import xarray as xr  # lazy: xarray (with pandas: 0.35 s) loads only when labelled data are asked for

    out = {}
    with xr.open_datatree(path, engine="h5netcdf", phony_dims="sort") as tree:
        tree.load()
    for node in tree.subtree:
        ds = node.to_dataset(inherit=False)
        where = f"{path}:{node.path}"
        for d in ds.dims:
            assert not str(d).startswith("phony_dim"), f"{where}: phony dimension {d}"
        for k, v in ds.variables.items():
            assert v.attrs.get("long_name"), f"{where}/{k}: no long_name"
            if v.dtype.kind in "fciub":
                assert "units" in v.attrs and str(v.attrs["units"]) != "", f"{where}/{k}: no units"
            else:
                assert v.dtype.kind == "U", f"{where}/{k}: {v.dtype} is not text (str)"
        parts = node.path.strip("/").split("/")
        if len(parts) == 2 and parts[0] == "runs":
            assert ds["direction"].dims == ("direction",) and ds["Omega"].dims == ("Omega",), where
            assert set(ds["direction"].values) <= {"up", "down"}, where
            assert ds["amplitude"].dims[:2] == ("direction", "Omega"), where
            assert np.all(np.diff(ds["Omega"].values) > 0), f"{where}: Omega not increasing"
            if "amplitude_mm" in ds:
                assert "frequency_hz" in ds.coords and ds["frequency_hz"].dims == ("Omega",), where
                assert ds["frequency_hz"].attrs["units"] == "Hz" and ds["amplitude_mm"].attrs["units"] == "mm"
            if "strobe" in ds:
                assert ds["strobe"].dims == ("direction", "Omega", "record_period", "state"), where
            if "harmonics" in ds:
                assert ds["harmonics"].dims[-1] == "harmonic" and "harmonic" in ds.coords, where
            out[node.path] = ds
        elif len(parts) == 2 and parts[0] == "maps":
            par = ds.attrs["parameter"]
            assert par in ds.coords and ds[par].attrs.get("units"), f"{where}: parameter coordinate {par}"
            f = "Omega" if "Omega" in ds.dims else "frequency_hz"
            assert ds["classification"].dims == ("direction", par, f), where
            assert "flag_meanings" in ds["classification"].attrs, where
            out[node.path] = ds
    assert out, f"{path}: no runs or maps"
    return out
