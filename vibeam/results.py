"""The one results writer (HDF5, h5py) for every fidelity and method.

Layout of ``results.h5``::

    /                attrs: vibeam_version, case_name, case_text, case_json, created, complete
    /runs/<run>/     attrs: fidelity, method, settings (JSON), wall_time_s, run attrs
        <dataset>    one entry per frequency point; attrs: units
    /maps/<run>/     a parameter map (``[map]``): attrs as a run, plus parameter
        <dataset>    shape (n_direction, n_values, n_frequency, ...)
    /lines/<run>/<line>/   the checkpoint: each finished sweep line's per-point datasets;
                     attrs: case_hash (:func:`case_hash` of the case as run)

Every write goes to a temporary file in the same folder that is then moved
over the old one (:func:`os.replace` is atomic): the whole file at the end of
a case, and one copy-and-append per batch of finished lines while it runs
(:func:`append_lines`).  An interrupted or killed run therefore leaves either
the previous complete file or the next one, never a corrupt one, and
``--resume`` recomputes only the lines missing from ``/lines``.
"""
from __future__ import annotations

import contextlib
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


def _atomic(path: Path, fill, copy_from: Path | None = None) -> Path:
    """Write ``path`` through a temporary file: ``fill(h5file)`` then :func:`os.replace`."""
    import shutil

    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(prefix=".results-", suffix=".h5.tmp", dir=path.parent)
    except OSError as e:
        raise OSError(e.errno, e.strerror, str(path)) from e
    os.close(fd)
    with _signals_deferred():
        try:
            if copy_from is not None:
                shutil.copyfile(copy_from, tmp)
            with h5py.File(tmp, "a" if copy_from is not None else "w") as f:
                fill(f)
            os.chmod(tmp, 0o666 & ~_umask())   # mkstemp makes 0600; a results file is shared
            os.replace(tmp, path)
        except BaseException as e:
            if os.path.exists(tmp):
                os.unlink(tmp)
            if isinstance(e, OSError) and not isinstance(e, BrokenPipeError) and e.filename != str(path):
                # name the results file (not the temporary one) in the one-line error
                raise OSError(e.errno, e.strerror or str(e).splitlines()[0], str(path)) from e
            raise
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def _signals_deferred():
    """Hold SIGINT/SIGTERM back while a file is written (delivered right after), so Ctrl-C
    never interrupts HDF5 in the middle of a call; a no-op off the main thread or on Windows."""
    import signal
    import threading

    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    sigs = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _root_attrs(f, case_name, case_text, case_json="", complete=True):
    f.attrs["vibeam_version"] = __version__
    f.attrs["case_name"] = case_name
    f.attrs["case_text"] = case_text
    f.attrs["case_json"] = case_json
    f.attrs["created"] = datetime.now(timezone.utc).isoformat()
    f.attrs["complete"] = complete


def case_hash(case_json: str) -> str:
    """Identity of a case as run (its validated JSON): SHA-256, 16 hex digits.

    Every checkpointed line carries it (attribute ``case_hash``), so a resume
    keeps only lines computed for the same case and variant."""
    import hashlib

    return hashlib.sha256(case_json.encode()).hexdigest()[:16]


class ForeignFileError(ValueError):
    """A results file that belongs to another case (written by another process meanwhile)."""


def append_lines(path, lines: dict, case_name: str = "", case_text: str = "", case_json: str = "") -> Path:
    """Add finished sweep lines to the checkpoint ``/lines`` of ``path`` atomically.

    Parameters
    ----------
    path : str or Path
        Results file; created (marked ``complete = False``) if missing.
    lines : dict
        ``{"<run>/<line key>": {dataset: array of length n_points}}``.
    case_name, case_text, case_json : str
        Root attributes of a new file (the case identifies what may be resumed).

    Returns
    -------
    Path

    Raises
    ------
    ForeignFileError
        If ``path`` holds the checkpoint of another case (``case_json``
        differs): lines of two cases are never mixed in one file.
    """
    path = Path(path)
    ident = case_hash(case_json)

    def fill(f):
        if "case_text" not in f.attrs:
            _root_attrs(f, case_name, case_text, case_json, complete=False)
        elif str(f.attrs.get("case_json", "")) != case_json:
            raise ForeignFileError(f"{path} now holds the results of another case "
                                   f"({f.attrs.get('case_name', '?')!s}): another process wrote it")
        f.attrs["complete"] = False
        g = f.require_group("lines")
        for key, data in lines.items():
            if key in g:
                del g[key]
            gl = g.create_group(key)
            gl.attrs["case_hash"] = ident
            for k, v in data.items():
                _write_dataset(gl, k, v)

    return _atomic(path, fill, copy_from=path if path.exists() else None)


def read_lines(path, case_json: str | None = None) -> tuple[dict, dict]:
    """The checkpoint of a results file: ``(root attrs, {run: {line key: {dataset: array}}})``.

    With ``case_json``, only the lines whose ``case_hash`` attribute is that of
    ``case_json`` (:func:`case_hash`) are returned: a line of another case, or
    one without the attribute, is never kept.
    """
    out = {}
    ident = None if case_json is None else case_hash(case_json)
    with h5py.File(path, "r") as f:
        attrs = dict(f.attrs)
        for run, g in f.get("lines", {}).items():
            got = {key: _read_group(gl) for key, gl in g.items()
                   if ident is None or str(gl.attrs.get("case_hash", "")) == ident}
            if got:
                out[run] = got
    return attrs, out


def write_results(path, runs: list[SweepResult], case_name: str = "", case_text: str = "",
                  extra: dict | None = None, maps: list | None = None, lines: dict | None = None,
                  case_json: str = "", branches: list | None = None, extra_attrs: dict | None = None) -> Path:
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
    maps : list of vibeam.maps.MapResult, optional
        Parameter maps, written to ``/maps/<name>``.
    lines : dict, optional
        The checkpoint ``{"<run>/<line key>": {dataset: array}}`` kept in ``/lines``.
    case_json : str
        The validated case (as run, e.g. its quick variant) as JSON; ``--resume``
        only continues a file whose ``case_json`` matches.
    branches : list of vibeam.branches.ContinuationResult, optional
        Continuation runs, written to ``/branches/<run>/`` (:func:`vibeam.branches.write_branches`).
    extra_attrs : dict, optional
        Attributes set last on groups or datasets of the file, ``{path: {name: value}}``
        (e.g. ``{"fit/residuals": {"units": "mm"}}``); a missing path becomes a group.

    Returns
    -------
    Path
        The written file.
    """
    def fill(f):
        _root_attrs(f, case_name, case_text, case_json, complete=True)
        f.create_group("runs")
        for kind, r in [("runs", r) for r in runs] + [("maps", m) for m in (maps or [])]:
            g = f.require_group(kind).create_group(r.name)
            g.attrs["fidelity"] = r.fidelity
            g.attrs["method"] = r.method
            g.attrs["settings"] = json.dumps(r.settings, default=_json_default)
            g.attrs["wall_time_s"] = r.wall_time_s
            for k, v in r.attrs.items():
                g.attrs[k] = v if not isinstance(v, dict) else json.dumps(v, default=_json_default)
            for k, v in r.data.items():
                _write_dataset(g, k, v)
        for gpath, table in list((extra or {}).items()) + [(f"lines/{k}", v) for k, v in (lines or {}).items()]:
            g = f.require_group(gpath)
            if gpath.startswith("lines/"):
                g.attrs["case_hash"] = case_hash(case_json)
            for k, v in table.items():
                _write_dataset(g, k, v)
        if branches:
            from .branches import write_branches
            write_branches(f, branches)
        for apath, attrs in (extra_attrs or {}).items():
            obj = f[apath] if apath in f else f.require_group(apath)
            for k, v in attrs.items():
                obj.attrs[k] = v if not isinstance(v, dict) else json.dumps(v, default=_json_default)

    return _atomic(Path(path), fill)


def replace_branches(path, branches: list) -> Path:
    """Replace the ``/branches`` of an existing results file (atomically, everything else kept)."""
    from .branches import write_branches

    def fill(f):
        if "branches" in f:
            del f["branches"]
        write_branches(f, branches)

    return _atomic(Path(path), fill, copy_from=Path(path))


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
    """Read a results file into ``{"attrs": {...}, "runs": {name: {"attrs": {...}, dataset: array}},
    "maps": {name: {...}}, "branches": {run: {"attrs": ..., branch: {...}, "bifurcations": {...}}}}``
    (the checkpoint ``/lines`` is read by :func:`read_lines`).

    String datasets come back as arrays of Python ``str``; subgroups of a run (time
    series) as nested dicts.
    """
    out = {"attrs": {}, "runs": {}, "maps": {}, "branches": {}}
    with h5py.File(path, "r") as f:
        out["attrs"] = dict(f.attrs)
        for kind in ("runs", "maps", "branches"):
            for name, g in f.get(kind, {}).items():
                run = _read_group(g, attrs=kind == "branches")
                run["attrs"] = dict(g.attrs)
                out[kind][name] = run
    return out


def _read_group(g, attrs: bool = False) -> dict:
    """Datasets of a group; subgroups (e.g. ``time_series/<f>/<direction>``) as nested dicts
    (with ``attrs``: each subgroup's attributes under ``"attrs"``, as for ``/branches``)."""
    out = {}
    for k, d in g.items():
        if isinstance(d, h5py.Dataset):
            if d.dtype.kind == "O" or h5py.check_string_dtype(d.dtype):
                out[k] = d.asstr()[()]
            else:
                out[k] = d[()]
        elif isinstance(d, h5py.Group):
            out[k] = _read_group(d, attrs)
            if attrs:
                out[k]["attrs"] = dict(d.attrs)
    return out
