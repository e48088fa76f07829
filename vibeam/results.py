"""The one results writer (HDF5, h5py) for every fidelity and method.

Layout of ``results.h5``::

    /                attrs: vibeam_version, case_name, case_text, created
    /runs/<run>/     attrs: fidelity, method, settings (JSON), wall_time_s, run attrs
        <dataset>    one entry per frequency point; attrs: units

The file is always written whole to a temporary file in the same folder and
moved over the old one (:func:`os.replace` is atomic), so an interrupted run
leaves either the previous complete file or the new complete file, never a
corrupt one; runs already finished are never lost.
"""
from __future__ import annotations

import json
import os
import tempfile
from datetime import datetime, timezone
from pathlib import Path

import h5py
import numpy as np

from . import __version__
from .sweep import UNITS, SweepResult


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def write_results(path, runs: list[SweepResult], case_name: str = "", case_text: str = "",
                  extra: dict | None = None) -> Path:
    """Write all runs to ``path`` atomically.

    Parameters
    ----------
    path : str or Path
        Target HDF5 file; its folder is created if needed.
    runs : list of SweepResult
        Completed runs.
    case_name, case_text : str
        Stored as root attributes (the case text makes the file reproducible).
    extra : dict, optional
        Additional groups: ``{group_path: {dataset: array}}`` (e.g. tables of
        ``vibeam cost``).

    Returns
    -------
    Path
        The written file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".results-", suffix=".h5.tmp", dir=path.parent)
    os.close(fd)
    try:
        with h5py.File(tmp, "w") as f:
            f.attrs["vibeam_version"] = __version__
            f.attrs["case_name"] = case_name
            f.attrs["case_text"] = case_text
            f.attrs["created"] = datetime.now(timezone.utc).isoformat()
            g_runs = f.create_group("runs")
            for r in runs:
                g = g_runs.create_group(r.name)
                g.attrs["fidelity"] = r.fidelity
                g.attrs["method"] = r.method
                g.attrs["settings"] = json.dumps(r.settings, default=_json_default)
                g.attrs["wall_time_s"] = r.wall_time_s
                for k, v in r.attrs.items():
                    g.attrs[k] = v if not isinstance(v, dict) else json.dumps(v, default=_json_default)
                for k, v in r.data.items():
                    _write_dataset(g, k, v)
            for gpath, table in (extra or {}).items():
                g = f.require_group(gpath)
                for k, v in table.items():
                    _write_dataset(g, k, v)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _write_dataset(g, name, v):
    v = np.asarray(v)
    if v.dtype == object or v.dtype.kind in "US":
        d = g.create_dataset(name, data=np.array([str(x) for x in v.ravel()], dtype=h5py.string_dtype())
                             .reshape(v.shape))
    else:
        d = g.create_dataset(name, data=v)
    if name in UNITS:
        d.attrs["units"] = UNITS[name]


def read_results(path) -> dict:
    """Read a results file into ``{"attrs": {...}, "runs": {name: {"attrs": {...}, dataset: array}}}``.

    String datasets come back as arrays of Python ``str``; subgroups of a run (time
    series) as nested dicts.
    """
    out = {"attrs": {}, "runs": {}}
    with h5py.File(path, "r") as f:
        out["attrs"] = dict(f.attrs)
        for name, g in f.get("runs", {}).items():
            run = _read_group(g)
            run["attrs"] = dict(g.attrs)
            out["runs"][name] = run
    return out


def _read_group(g) -> dict:
    """Datasets of a group; subgroups (e.g. ``time_series/<f>/<direction>``) as nested dicts."""
    out = {}
    for k, d in g.items():
        if isinstance(d, h5py.Dataset):
            if d.dtype.kind == "O" or h5py.check_string_dtype(d.dtype):
                out[k] = d.asstr()[()]
            else:
                out[k] = d[()]
        elif isinstance(d, h5py.Group):
            out[k] = _read_group(d)
    return out
