"""The Python API: what the command line does, from a notebook.

::

    import vibeam
    case = vibeam.load_case("cases/paper-fig7.toml")     # a path, TOML text or a dict
    res = vibeam.run(case, jobs=2)                         # every run (or the [map]) of the case
    ds = res.to_xarray("exact")                            # xarray.Dataset on (direction, Omega)
    fig = res.plot_frc()                                   # matplotlib Figures, the CLI's plots
    sim = vibeam.simulate(case, Omega=2.0, periods=4)      # one frequency: t, q, q', impacts

Heavy modules (numba kernels, h5py, xarray, matplotlib) are imported when a function
needs them, so ``import vibeam`` stays fast.
"""
from __future__ import annotations

import contextlib
import io
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np



class _PrivateFolder:
    """A temporary folder removed with its last reference (or at exit), quietly: the file behind an
    in-memory result's ``to_xarray()`` lives there."""

    def __init__(self, prefix: str):
        import shutil
        import weakref

        self.name = tempfile.mkdtemp(prefix=prefix)
        self._finalizer = weakref.finalize(self, shutil.rmtree, self.name, True)

    def cleanup(self) -> None:
        self._finalizer()


# ============================================================================ cases
def load_case(source):
    """A validated case from a file, TOML text or a dict.

    Parameters
    ----------
    source : str, Path, dict or vibeam.case.schema.Case
        A path to a case file (``.toml``); the TOML text of a case (any string with a
        newline, or one that is not an existing file); a dict with the case's tables
        (as ``tomllib`` would read them); or a Case (returned as it is).

    Returns
    -------
    vibeam.case.schema.Case
        The case; its text (for the results file) is in ``case_text(case)``.

    Raises
    ------
    vibeam.case.schema.CaseError
        If the file cannot be read (not a regular file, larger than 10 MB:
        :func:`vibeam.io.inputs.read_input_text`) or the case is invalid (one line naming the
        key, the value and what is allowed).
    TypeError
        If ``source`` is none of the above (None, a number, bytes, ...).
    """
    import os

    from vibeam.case.schema import Case, validation_message, load_case as _load, parse_case
    from vibeam.errors import CaseError, quote_value

    if isinstance(source, Case):
        return source
    if not isinstance(source, (str, os.PathLike, dict)):
        raise TypeError(f"source = {quote_value(source)}: not a case; allowed: a path to a case file (str or "
                        f"pathlib.Path), the TOML text of a case, a dict of its tables or a Case")
    if isinstance(source, dict):
        import tomllib

        from pydantic import ValidationError

        text = _toml_text(source)
        try:
            tomllib.loads(text)
        except tomllib.TOMLDecodeError:      # not writable as TOML: validate the dict as it is
            try:
                case = Case.model_validate(source)
            except ValidationError as e:
                raise CaseError(validation_message(e, "", Case)) from None
            return _remember(case, "")
        return _remember(parse_case(text, "<dict>"), text)
    if not isinstance(source, str) or _names_a_file(source):
        case, text = _load(source)
        return _remember(case, text)
    return _remember(parse_case(source, "<text>"), source)


def _names_a_file(text: str) -> bool:
    """Is a string given to :func:`load_case` a path (rather than TOML text)?  One line that
    names something on disk (a file, a folder, a device: what is not a regular file is then
    refused as such), ends with ``.toml``, is empty, or could not be TOML (no ``=``)."""
    if "\n" in text:
        return False
    if not text.strip() or text.endswith(".toml") or "=" not in text:
        return True
    try:
        return Path(text).exists()
    except (OSError, ValueError):        # a name too long, a NUL byte: not a file
        return False


_TEXT: dict = {}


def _remember(case, text: str):
    """Keep the text a case came from (for its results file) as long as the case lives."""
    import weakref

    _TEXT[id(case)] = text
    weakref.finalize(case, _TEXT.pop, id(case), None)
    return case


def case_text(case) -> str:
    """The TOML text a case was loaded from (by :func:`load_case`), else one written from it."""
    return _TEXT.get(id(case)) or _toml_text(case.model_dump(exclude_none=True))


def _toml_text(d: dict, prefix: str = "") -> str:
    """TOML text of a case dict (tables and arrays of tables; strings, numbers, lists)."""
    import json

    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{json.dumps(k)} = {val(x)}" for k, x in v.items()) + "}"
        return repr(float(v)) if isinstance(v, float) else str(v)

    lines, tables = [], []
    for k, v in d.items():
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            tables.append((k, v))
        elif v is not None:
            lines.append(f"{json.dumps(k) if not k.isidentifier() else k} = {val(v)}")
    out = "\n".join(lines) + ("\n" if lines else "")
    for k, v in tables:
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out += f"\n[{name}]\n" + _toml_text(v, name + ".")
        else:
            for item in v:
                out += f"\n[[{name}]]\n" + _toml_text(item, name + ".")
    return out


# ============================================================================ runs
class _Group:
    """What every group of :class:`Results` has: ``to_xarray()`` (its group of ``results.h5`` as
    an :class:`xarray.Dataset`, loaded in memory) and ``plot(path=None)`` (a matplotlib Figure,
    saved atomically when ``path`` is given).  ``group`` is its path in the file."""

    _kind = "runs"

    @property
    def group(self) -> str:
        return f"{self._kind}/{self.name}"

    def _bind(self, owner):
        object.__setattr__(self, "_owner", owner)
        return self

    def _results(self):
        owner = getattr(self, "_owner", None)
        return owner if owner is not None else Results(**{self._kind: [self]})

    def to_xarray(self):
        """This group as an :class:`xarray.Dataset` (the variables, dimensions and units of
        ``results.h5``, README "Results")."""
        return self._results().dataset(self.group)

    def _title(self) -> str:
        return self._results()._title()

    def _sizes(self) -> str:
        """What the group holds, in a few words (its sizes), for the repr."""
        data = getattr(self, "data", None) or {}
        pts = next((int(np.size(v)) for k, v in data.items() if k in ("Omega", "classification")), 0)
        return f"{pts} points, {len(data)} variables"

    def __repr__(self) -> str:
        """``Run('exact': runs/exact, 202 points, 25 variables)``: the group, its name and sizes,
        never its arrays."""
        kind = {"runs": "Run", "maps": "Map", "branches": "Branches", "basins": "Basins"}.get(
            self._kind, type(self).__name__.lstrip("_"))
        return f"{kind}({self.name!r}: {self.group}, {self._sizes()})"


def _as(cls, obj, owner):
    """``obj`` (a dataclass instance) as the API's subclass ``cls``, bound to ``owner``."""
    import dataclasses

    if not isinstance(obj, cls):
        obj = cls(**{f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)})
    return obj._bind(owner)


def _group_classes():
    """The API's group classes (built on first use: their bases live in modules that load
    numba and scipy, kept out of ``import vibeam``)."""
    global Run, Map, Branches, Basins
    if Run is not None:
        return
    from vibeam.analysis.attractors import BasinsResult
    from vibeam.analysis.branches import ContinuationResult
    from vibeam.io.objects import MapResult, SweepResult

    class _Run(SweepResult, _Group):
        """One ``[[run]]`` (:class:`vibeam.engine.sweep.SweepResult`: per-point arrays in
        ``.data``, visiting order); group ``runs/<name>`` on (direction, Omega)."""

        _kind = "runs"
        __repr__ = _Group.__repr__

        def plot(self, path=None, kind: str = "frc"):
            """The run's FRC (``kind="frc"``) or bifurcation diagram (``"bifurcation"``)."""
            from vibeam.plots.sweep import bifurcation_figure, frc_figure

            fig = {"frc": frc_figure, "bifurcation": bifurcation_figure}[kind]
            r = self._results()
            return _saved(fig([self], title=r._title(), case=r.case), path)

    class _Map(MapResult, _Group):
        """One run of a ``[map]`` (:class:`vibeam.analysis.maps.MapResult`); group ``maps/<name>``
        on (direction, <parameter>, Omega)."""

        _kind = "maps"
        __repr__ = _Group.__repr__

        def _sizes(self):
            return f"{self.parameter} x frequency, {_Group._sizes(self)}"

        def plot(self, path=None):
            """The class map (paper Fig. 18), with the two-parameter curves of the case."""
            from vibeam.analysis.maps import map_figure

            r = self._results()
            return _saved(map_figure(self, title=r._title(), case=r.case,
                                     curves=[b for b in r.branches if b.curves]), path)

    class _Branches(ContinuationResult, _Group):
        """One continuation run (:class:`vibeam.analysis.branches.ContinuationResult`: ``branches``,
        their ``bifurcations``, two-parameter ``curves``); group ``branches/<name>`` on
        (branch, point)."""

        _kind = "branches"
        __repr__ = _Group.__repr__

        def _sizes(self):
            pts = sum(int(b.get("n", 0) or 0) for b in self.branches if isinstance(b, dict))
            return (f"parameter {self.parameter}, {len(self.branches)} branches ({pts} points), "
                    f"{len(self.curves)} curves, status {self.status}")

        def plot(self, path=None):
            """Branches (stable solid, unstable dashed), bifurcations and the sweeps of the same
            scene overlaid (``continuation_<run>.png`` of ``vibeam continue``)."""
            from vibeam.analysis.branches import continuation_figure

            r = self._results()
            scene = {x.name: dict(x.model) for x in getattr(r.case, "run", [])}
            same = [s for s in r.runs if scene.get(s.name) == scene.get(self.name)] or r.runs
            return _saved(continuation_figure(self, same, title=f"{r._title()}: {self.name}", case=r.case), path)

    class _Basins(BasinsResult, _Group):
        """Basins of attraction or the census of attractors of one run
        (:class:`vibeam.analysis.attractors.BasinsResult`); group ``basins/<name>``."""

        _kind = "basins"
        __repr__ = _Group.__repr__

        def _sizes(self):
            return BasinsResult.sizes(self)

        def to_xarray(self):
            """The variables of ``/basins/<run>/`` (computed from the result in memory)."""
            return BasinsResult.to_xarray(self)

        def plot(self, path=None, i: int | None = None):
            """The basin image at frequency ``i`` (default the first), or with several
            frequencies and ``i=None`` the census figure (fractions and amplitudes over the
            continuation branches of the results)."""
            from vibeam.analysis.attractors import basins_figure, census_figure

            r = self._results()
            if i is None and len(self.Omega) > 1:
                br = {b.name: _branch_dicts(b) for b in r.branches}
                return _saved(census_figure(self, r._title(), br), path)
            return _saved(basins_figure(self, i or 0, r._title()), path)

    Run, Map, Branches, Basins = _Run, _Map, _Branches, _Basins


Run = Map = Branches = Basins = None


def _branch_dicts(b) -> dict:
    """A continuation run in the shape of :func:`vibeam.io.results.read_branch_group` (what the
    census figure overlays)."""
    from vibeam.io.results import branch_name

    return {branch_name(x): dict(x["data"], attrs=dict(index=x["index"], n=x["n"], parameter=b.parameter))
            for x in b.branches if x["data"]}


@dataclass(eq=False)
class Bifurcations(_Group):
    """The bifurcations of one continuation run: ``table`` (``type``, ``parameter``, ``branch``,
    ``period``, ``amplitude``, ``detail``, and ``frequency_hz`` / ``amplitude_mm`` for a
    physical scene; one entry per bifurcation); group ``branches/<run>/bifurcations``."""

    name: str
    table: dict
    run: object = None

    @property
    def group(self) -> str:
        return f"branches/{self.name}/bifurcations"

    def __repr__(self) -> str:
        n = max((int(np.size(v)) for v in self.table.values()), default=0)
        return f"Bifurcations({self.name!r}: {self.group}, {n} bifurcations)"

    def _results(self):
        return self.run._results()

    def plot(self, path=None):
        """The continuation figure of the run, where the bifurcations are marked."""
        return self.run.plot(path)


@dataclass(eq=False)
class Curves(_Group):
    """The two-parameter curves of one continuation run (``curves``: dicts with ``type``,
    ``p1`` (the continuation parameter), ``p2`` (the second one), ``n``, ``status``);
    group ``branches/<run>/curves`` on (curve, curve_point)."""

    name: str
    curves: list
    run: object = None

    @property
    def group(self) -> str:
        return f"branches/{self.name}/curves"

    def __repr__(self) -> str:
        return f"Curves({self.name!r}: {self.group}, {len(self.curves)} curves)"

    def _results(self):
        return self.run._results()

    def plot(self, path=None):
        """The curves of the run alone (frequency x the second parameter)."""
        from vibeam.analysis.branches import curves_figure

        r = self._results()
        return _saved(curves_figure(self.run, title=f"{r._title()}: {self.name}", case=r.case), path)


@dataclass(eq=False)
class Results:
    """Every group a case produced (:func:`run`, ``vibeam run``/``continue``/``basins``), or a
    results file holds (:func:`open_results`).

    Attributes
    ----------
    runs : list of Run
        One per ``[[run]]`` of a sweep (:class:`vibeam.engine.sweep.SweepResult` with
        ``to_xarray()`` and ``plot()``; per-point arrays in ``.data``, visiting order).
    maps : list of Map
        One per run of a ``[map]`` case (:class:`vibeam.analysis.maps.MapResult`).
    case : vibeam.case.schema.Case or None
        The case as run (its quick variant with ``quick``).
    path : Path or None
        The results file (None when the run kept nothing on disk: the groups are in memory).
    branches : list of Branches
        One per continuation run (``method = "continuation"``;
        :class:`vibeam.analysis.branches.ContinuationResult`).
    basins : list of Basins
        Basins of attraction or census of attractors (``[basins]``, :func:`basins`;
        :class:`vibeam.analysis.attractors.BasinsResult`).

    ``bifurcations`` and ``curves`` (properties) give each continuation run's bifurcations and
    two-parameter curves; ``groups`` all of them by their path in ``results.h5``;
    ``res["exact"]`` a group by its run's name, ``res["runs/exact"]`` the node of the
    :class:`xarray.DataTree` (:meth:`tree`).
    """

    runs: list = field(default_factory=list)
    maps: list = field(default_factory=list)
    case: object = None
    path: Path | None = None
    branches: list = field(default_factory=list)
    basins: list = field(default_factory=list)

    def __repr__(self) -> str:
        """The groups by kind with their names and sizes (never their arrays), e.g.
        ``Results('paper-fig7', path='results.h5', runs: 'exact' (202 points, 25 variables);
        maps: none; branches: none; basins: none)``."""
        name = getattr(self.case, "name", None)
        parts = [repr(name) if name else "case unknown", f"path={str(self.path)!r}" if self.path else "in memory"]
        for kind in ("runs", "maps", "branches", "basins"):
            gs = getattr(self, kind)
            parts.append(f"{kind}: " + (", ".join(f"{g.name!r} ({g._sizes()})" for g in gs) if gs else "none"))
        return "Results(" + ", ".join(parts[:2]) + "; " + "; ".join(parts[2:]) + ")"

    def __post_init__(self):
        _group_classes()
        self.runs = [_as(Run, r, self) for r in self.runs]
        self.maps = [_as(Map, m, self) for m in self.maps]
        self.branches = [_as(Branches, b, self) for b in self.branches]
        self.basins = [_as(Basins, b, self) for b in self.basins]
        self._tree = None
        self._file = None        # a file holding the groups (self.path, or a private temporary one)
        self._tmp = None

    @classmethod
    def from_file(cls, path) -> "Results":
        """Every group of a results file (``results.h5``): runs, maps, continuation branches
        (with bifurcations and curves) and basins."""
        from vibeam.analysis.attractors import basins_from_dataset, read_basins
        from vibeam.analysis.branches import read_continuation
        from vibeam.case.schema import Case
        from vibeam.io.inputs import check_input_file
        from vibeam.io.results import layout_of, load_results

        check_input_file(path, "results file")
        runs, maps, attrs = load_results(path)
        case = None
        try:                   # the case as run (e.g. its quick variant), else the case file's text
            if attrs.get("case_json"):
                case = _remember(Case.model_validate_json(str(attrs["case_json"])), str(attrs.get("case_text", "")))
            elif attrs.get("case_text"):
                case = load_case(str(attrs["case_text"]))
        except Exception:      # a case of an older vibeam: the data are still readable
            case = None
        branches, basins = [], []
        if layout_of(path) >= 2:
            from vibeam.io.h5check import open_checked

            branches = read_continuation(path)
            with open_checked(path) as f:
                names = list(f.get("basins", {}))
            basins = [basins_from_dataset(read_basins(path, n), n) for n in names]
        return cls(runs, maps, case, Path(path), branches, basins)

    def _source(self, name: str):
        for r in self.runs + self.maps + self.branches + self.basins:
            if r.name == name:
                return r
        return None

    def __getitem__(self, name: str):
        if "/" in name:
            return self.tree()[name]
        r = self._source(name)
        if r is None:
            raise KeyError(f"no run named {name!r}; runs: {self.names}")
        return r

    @property
    def names(self) -> list:
        """The names of the runs, maps and continuation runs (the case's ``[[run]]`` names)."""
        return [r.name for r in self.runs + self.maps + self.branches]

    @property
    def bifurcations(self) -> list:
        """One :class:`Bifurcations` per continuation run."""
        return [Bifurcations(b.name, b.bifurcation_table(), b) for b in self.branches]

    @property
    def curves(self) -> list:
        """One :class:`Curves` per continuation run that traced two-parameter curves."""
        return [Curves(b.name, b.curves, b) for b in self.branches if b.curves]

    @property
    def groups(self) -> dict:
        """Every group by its path in ``results.h5``: ``runs/<run>``, ``maps/<run>``,
        ``branches/<run>``, ``branches/<run>/bifurcations``, ``branches/<run>/curves``,
        ``basins/<run>``."""
        out = {}
        for g in self.runs + self.maps + self.branches:
            out[g.group] = g
        for g in self.bifurcations + self.curves + self.basins:
            out[g.group] = g
        return out

    def _h5(self) -> Path:
        """A file holding every group: the results file, or one written once to a private
        temporary folder (removed with this object)."""
        if self.path is not None and Path(self.path).is_file():
            return Path(self.path)
        if self._file is not None and Path(self._file).is_file():
            return self._file
        from vibeam.analysis.attractors import basins_group
        from vibeam.io.results import result_groups
        from vibeam.io.store import write_file

        self._tmp = _PrivateFolder("vibeam-results-")
        name = getattr(self.case, "name", "")
        text = case_text(self.case) if self.case is not None else ""
        cj = self.case.model_dump_json() if self.case is not None else ""
        groups = result_groups(self.runs, self.maps, self.branches)
        groups.update({f"basins/{b.name}": basins_group(b) for b in self.basins})
        f = write_file(Path(self._tmp.name) / "results.h5", groups, name, text, cj)
        self._file = f
        return f

    def tree(self):
        """Every group as one :class:`xarray.DataTree`, loaded in memory (``tree["runs/<run>"]``,
        ``tree["branches/<run>/bifurcations"]``, ...)."""
        if self._tree is None:
            import xarray as xr

            tree = xr.open_datatree(self._h5(), engine="h5netcdf")
            tree.load()
            tree.close()
            self._tree = tree
        return self._tree

    def dataset(self, group: str):
        """One group (its path in ``results.h5``) as an :class:`xarray.Dataset`."""
        return self.tree()[group].to_dataset()

    def to_xarray(self, name: str | None = None):
        """The results as labelled data (the layout of :mod:`vibeam.io.results`), loaded in memory.

        Parameters
        ----------
        name : str, optional
            One run, map, continuation run or basins: its :class:`xarray.Dataset` (on
            (direction, Omega), (direction, <parameter>, Omega), (branch, point), ...), or a
            group's path (``"branches/<run>/bifurcations"``).  Default: an
            :class:`xarray.DataTree` of every group (``tree["runs/<name>"]``).
        """
        if name is None:
            return self.tree()
        if "/" in name:
            return self.dataset(name)
        r = self._source(name)
        if r is None:
            raise KeyError(f"no run named {name!r}; runs: {self.names}")
        return r.to_xarray()

    # ---------------------------------------------------------------- plots (matplotlib Figures)
    def _title(self) -> str:
        return getattr(self.case, "name", "") or ""

    def plot_frc(self, path=None):
        """FRC of every run (``frc.png``): a :class:`matplotlib.figure.Figure`, saved if ``path``."""
        from vibeam.plots.sweep import frc_figure

        return _saved(frc_figure(self.runs, title=self._title(), case=self.case), path)

    def plot_bifurcation(self, path=None):
        """Bifurcation diagram (stroboscopic samples) of the time-domain runs; None without any."""
        from vibeam.plots.sweep import bifurcation_figure

        return _saved(bifurcation_figure(self.runs, title=self._title(), case=self.case), path)

    def plot_map(self, name: str | None = None, path=None):
        """Class map of one map run (default the first; paper Fig. 18)."""
        m = self[name] if name else self.maps[0]
        return m.plot(path)

    def plot_agreement(self, path=None):
        """Where the maps' classes differ from the first map's; None with fewer than two maps."""
        from vibeam.analysis.maps import agreement_figure

        return _saved(agreement_figure(self.maps, title=self._title(), case=self.case), path)

    def plot_continuation(self, name: str | None = None, path=None):
        """Branches of one continuation run (default the first) with the sweeps overlaid."""
        b = self[name] if name else self.branches[0]
        return b.plot(path)

    def plot_curves(self, name: str | None = None, path=None):
        """Two-parameter curves of one continuation run (default the first with curves)."""
        c = next(c for c in self.curves if name is None or c.name == name)
        return c.plot(path)

    def plot_basins(self, name: str | None = None, path=None, i: int | None = None):
        """Basins (or the census) of one run (default the first)."""
        b = next(b for b in self.basins if name is None or b.name == name)
        return b.plot(path, i=i)

    def plot_spectra(self, path=None):
        """Sensor velocity spectra against the forcing frequency (``[assess] spectra``)."""
        from vibeam.engine.assess import spectra_figure

        return _saved(spectra_figure(self.runs, self._title(), case=self.case), path)

    def plot_time_series(self, label, path=None):
        """Time series and phase portrait at the grid frequency ``label`` (``[assess] time_series``)."""
        from vibeam.engine.assess import time_series_figure

        return _saved(time_series_figure(self.runs, label, self._title(), case=self.case), path)

    def plot_participation(self, path=None):
        """Modal shares in the sensor displacement and the energy (``[assess] participation``)."""
        from vibeam.engine.assess import participation_figure

        return _saved(participation_figure(self.runs, self._title(), case=self.case), path)


def _saved(fig, path):
    if fig is not None and path is not None:
        from vibeam.plots.sweep import save_figure

        save_figure(fig, path)
    return fig


def _check_run_args(jobs, out, executor, **flags):
    from vibeam.case.arguments import check_flag, check_jobs, check_path

    jobs = check_jobs(jobs)
    out = check_path(out, "out")
    for name, flag in flags.items():
        check_flag(flag, name)
    if executor is not None and not callable(getattr(executor, "submit", None)):
        from vibeam.errors import quote_value

        raise TypeError(f"executor = {quote_value(executor)}: not an executor; allowed: a "
                        f"concurrent.futures.Executor (with submit) or None")
    return jobs, out


def _collect(case, h5: Path, out, tmp, runs=None, maps=None, basins=()) -> Results:
    """The Results of a run into ``h5``: the runs and maps in memory (as computed), the
    continuation branches read back from the file (every group, nothing dropped)."""
    from vibeam.analysis.branches import read_continuation
    from vibeam.io.store import current_units

    # what the file holds of this case (a group of another case is kept there, marked stale)
    current = set(current_units(h5, case.model_dump_json())) if Path(h5).is_file() else set()
    branches = [b for b in read_continuation(h5) if f"branches/{b.name}" in current] if Path(h5).is_file() else []
    if runs is None:
        back = Results.from_file(h5) if Path(h5).is_file() else Results()
        runs = [r for r in back.runs if f"runs/{r.name}" in current]
        maps = [m for m in back.maps if f"maps/{m.name}" in current]
    res = Results(list(runs), list(maps or []), case, None if out is None else Path(h5), branches, list(basins))
    res._tmp = tmp                       # kept alive with the results: the file behind to_xarray()
    res._file = Path(h5) if Path(h5).is_file() else None
    return res


def run(case, jobs: int | None = None, executor=None, out=None, quick: bool = False, progress: bool = False,
        plots: bool = False, resume: bool = False, force: bool = False, verbose: bool = False,
        basins: bool = True, fresh: bool = False) -> Results:
    """Run a case (``vibeam run``): its runs, or its parameter map, its continuation runs and
    its ``[basins]``.

    Parameters
    ----------
    case : Case, str, Path or dict
        Anything :func:`load_case` takes.
    jobs : int or None
        Workers of the local process pool (None: all cores; 1: in this process).  Small
        sweeps run in this process whatever ``jobs`` is (:func:`vibeam.runner.plan_execution`).
    executor : concurrent.futures.Executor, optional
        Where the sweep lines run, e.g. ``distributed.Client(...).get_executor()``.
    out : str or Path, optional
        Output folder: ``results.h5`` (checkpointed as lines finish) and, with ``plots``,
        the PNGs.  Default: nothing is kept on disk (the results are in memory, the file
        behind :meth:`Results.to_xarray` in a private temporary folder removed with them).
    quick : bool
        The case's quick variant (``[quick]``).
    progress : bool
        A progress bar of points.
    plots, resume, force : bool
        As the command line's ``--no-plots`` (inverted), ``--resume``, ``--force``.
    verbose : bool
        Print the tables the command line prints.
    basins : bool
        Compute the case's ``[basins]`` too (as ``vibeam run``).
    fresh : bool
        As ``--fresh``: start a new ``results.h5`` in ``out`` (without it, every group of the
        one there is kept, those of another case marked stale: :mod:`vibeam.io.store`).

    Returns
    -------
    Results
        ``runs`` (or ``maps``), ``branches`` (continuation runs, with ``bifurcations`` and
        ``curves``), ``basins``.

    Raises
    ------
    vibeam.case.schema.CaseError
        Bad case or input (:class:`vibeam.case.schema.InputError`: a folder in use, a work
        estimate above the limit without ``force``, ...).
    TypeError, ValueError
        An argument of the wrong type or out of range, e.g. ``jobs`` not a whole number
        from 1 to :func:`vibeam.case.arguments.max_jobs` (the rule of ``--jobs``), ``out`` an
        empty string; one line naming the argument, the value and what is allowed.
    """
    from vibeam.runner import run_case

    jobs, out = _check_run_args(jobs, out, executor, quick=quick, progress=progress, plots=plots, resume=resume,
                                force=force, verbose=verbose, basins=basins, fresh=fresh)
    if fresh and resume:
        raise ValueError("fresh = True and resume = True: choose one (fresh starts a new results file, resume "
                         "continues the checkpoint of an interrupted run)")
    c = load_case(case)
    text = case_text(c)
    source = str(case) if isinstance(case, (str, Path)) and _names_a_file(str(case)) else ""
    ctx = contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO())
    tmp = None
    if out is None:
        tmp = _PrivateFolder("vibeam-run-")
        folder = Path(tmp.name)
    else:
        folder = Path(out)
    from vibeam.io.store import Store

    run_c = c.quick_variant() if quick else c
    found = []
    # one results store for the whole call: the sweeps, then the [basins], under one lock
    with ctx, Store(folder, fresh=fresh) as store:
        res = run_case(c, text, folder, jobs=jobs, quiet=not progress, plots=plots and out is not None,
                       quick=quick, resume=resume and out is not None, executor=executor,
                       checkpoint=out is not None, force=force, source=source, store=store)
        if basins and c.basins is not None:
            found = [run_basins(run_c, text, folder, None, jobs=jobs, executor=executor, progress=progress,
                                resume=resume and out is not None, plots=plots and out is not None, store=store)]
    from vibeam.analysis.maps import MapResult

    maps = [r for r in res if isinstance(r, MapResult)]
    runs = [r for r in res if not isinstance(r, MapResult)]
    return _collect(run_c, folder / "results.h5", out, tmp, runs, maps, found)


def run_basins(case, text, folder, spec, jobs=None, executor=None, progress=False, resume=False, plots=True,
               log=None, store=None):
    """Basins of ``case`` (``spec`` or its ``[basins]``) into ``folder/results.h5``
    (``/basins/<run>/``; finished rows checkpointed in ``results.h5.partial``), the table printed
    and, with ``plots``, the PNGs (over the file's continuation branches of the same case).
    ``store``: the results store of ``folder`` the command holds (default: one is opened).
    Returns the BasinsResult."""
    from vibeam.analysis.attractors import compute, plot_basins, print_basins, write_basins
    from vibeam.io.store import Store

    with (store if store is not None else Store(folder)) as st:
        r = compute(case, jobs=jobs, executor=executor, progress=progress, spec=spec, checkpoint=st,
                    resume=resume, case_text=text)
        from vibeam.runner import case_identity

        cj, aliases = case_identity(st, case.model_dump_json())
        h5 = write_basins(st, [r], case.name, text, cj, aliases)
        print_basins(r)
        if plots:
            from vibeam.io.results import read_results

            current = set(st.current(cj, aliases))
            branches = {k: v for k, v in read_results(h5)["branches"].items() if f"branches/{k}" in current}
            for p in plot_basins(r, folder, branches=branches):   # over the branches `vibeam continue` wrote
                print(f"plot: {p}")
    print(f"basins -> {h5} (group /basins/{r.name})")
    return r


def continuation(case, jobs: int | None = None, executor=None, out=None, quick: bool = False,
                 progress: bool = False, plots: bool = False, force: bool = False, verbose: bool = False,
                 fresh: bool = False) -> Results:
    """The continuation runs of a case alone (``vibeam continue``): branches of periodic orbits
    with their Floquet multipliers, bifurcations and two-parameter curves
    (:mod:`vibeam.analysis.branches`; pseudo-arclength continuation of the shooting problem).

    Parameters
    ----------
    case : Case, str, Path or dict
        Anything :func:`load_case` takes; at least one ``[[run]]`` with
        ``method = "continuation"``.
    jobs, executor, out, quick, progress, plots, force, verbose, fresh
        As :func:`run`.  A ``results.h5`` in ``out`` keeps every other group (its sweeps and
        maps are in the returned Results too); only ``/branches/<run>`` of these runs is
        replaced.

    Returns
    -------
    Results
        ``branches`` (one per continuation run), ``bifurcations``, ``curves``; the sweeps of
        the file in ``out`` when it holds the same case.

    Raises
    ------
    vibeam.case.schema.CaseError
        No continuation run (one line), or a bad case; TypeError, ValueError as :func:`run`.
    """
    from vibeam.runner import run_case

    jobs, out = _check_run_args(jobs, out, executor, quick=quick, progress=progress, plots=plots, force=force,
                                verbose=verbose, fresh=fresh)
    c = load_case(case)
    text = case_text(c)
    source = str(case) if isinstance(case, (str, Path)) and _names_a_file(str(case)) else ""
    tmp = None
    if out is None:
        tmp = _PrivateFolder("vibeam-continue-")
        folder = Path(tmp.name)
    else:
        folder = Path(out)
    ctx = contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO())
    with ctx:
        run_case(c, text, folder, jobs=jobs, quiet=not progress, plots=plots and out is not None, quick=quick,
                 executor=executor, force=force, source=source, continuation_only=True, fresh=fresh)
    return _collect(c.quick_variant() if quick else c, folder / "results.h5", out, tmp)


# alias: ``continue`` is a Python keyword
continue_ = continuation


def open_results(path) -> Results:
    """A results file (``results.h5``) as :class:`Results`: every group (runs, maps, continuation
    branches with their bifurcations and curves, basins), each with ``to_xarray()`` and
    ``plot()``; ``res["runs/<run>"]`` is the node of the file's :class:`xarray.DataTree`.

    Raises
    ------
    vibeam.errors.InputError (a ValueError)
        One line naming the file: not a regular file, not an HDF5 file, an HDF5 file that is
        not a vibeam results file (no ``vibeam_layout``, no runs, maps, branches or basins), or a
        file of the first layout (no dimensions: convert it with
        :func:`vibeam.io.results.load_results` and :func:`vibeam.io.results.write_results`).
    """
    from vibeam.errors import InputError
    from vibeam.io.h5check import open_checked
    from vibeam.io.inputs import check_input_file
    from vibeam.io.results import LAYOUT_VERSION

    p = check_input_file(path, "results file")
    with open_checked(p) as f:
        layout = f.attrs.get("vibeam_layout")
        groups = [g for g in ("runs", "maps", "branches", "basins") if g in f]
    if layout is None and not groups:
        raise InputError(f"{p}: not a vibeam results file (an HDF5 file without vibeam_layout and without runs, "
                         f"maps, branches or basins); allowed: a results.h5 written by vibeam")
    if int(layout if layout is not None else 1) < LAYOUT_VERSION:
        raise InputError(f"{p}: a results file of the first layout (no dimensions); rewrite it with "
                         f"vibeam.io.results.load_results and write_results")
    return Results.from_file(p)


# ============================================================================ one frequency
@dataclass
class Simulation:
    """The recorded window of one forcing frequency (:func:`simulate`).

    Attributes
    ----------
    Omega : float
        Forcing frequency over the natural frequency.
    t : ndarray, shape (n,)
        Time from the start of the recorded window (nondimensional: ``2 pi`` is one
        natural period), ``n = periods x samples_per_period`` samples.
    q, dq : ndarray, shape (n,)
        Displacement ``q`` and velocity ``q'`` (nondimensional; for a beam, the sensor
        displacement ``U(L_S) / L``).
    impact_times, impact_velocities : ndarray, shape (k,)
        Impacts in the window: times (as ``t``) and pre-impact velocities ``q'- >= 0``.
    summary : dict
        The per-point outputs of the sweep (:func:`vibeam.engine.records.summarize`): amplitude,
        period, impacts_per_period, ...
    status, message : str
        The point's outcome as a sweep records it (``summary["status"]``): ``ok``, ``chatter``,
        ``sticking``, ``unsettled`` (the stroboscopic map shows a transient) or ``failed`` (also
        when the motion left the range of floating-point numbers), and the detail.
    final_state : ndarray
        The state at the end (to continue from).
    natural_frequency_hz, length_m : float or None
        Scales of a physical scene (then ``time_s``, ``U_mm``, ``dU_mm_s`` are set).
    name : str
        The case simulated (and its run, when the case has several): the figures' title; ''
        for a model.
    """

    Omega: float
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    impact_times: np.ndarray
    impact_velocities: np.ndarray
    summary: dict
    status: str
    message: str
    final_state: np.ndarray
    natural_frequency_hz: float | None = None
    length_m: float | None = None
    trajectory: object = None
    name: str = ""

    @property
    def physical(self) -> bool:
        return bool(self.natural_frequency_hz and self.length_m)

    @property
    def time_s(self) -> np.ndarray | None:
        """Time (s): ``t / (2 pi f_n)``; None for a nondimensional scene."""
        return self.t / (2 * np.pi * self.natural_frequency_hz) if self.physical else None

    @property
    def U_mm(self) -> np.ndarray | None:
        """Sensor displacement ``U(L_S) = q L`` (mm, paper Sec. 6)."""
        return self.q * self.length_m * 1e3 if self.physical else None

    @property
    def dU_mm_s(self) -> np.ndarray | None:
        """Sensor velocity ``U'(L_S) = q' L 2 pi f_n`` (mm/s)."""
        return self.dq * self.length_m * 1e3 * 2 * np.pi * self.natural_frequency_hz if self.physical else None

    @property
    def impact_times_s(self) -> np.ndarray | None:
        return self.impact_times / (2 * np.pi * self.natural_frequency_hz) if self.physical else None

    @property
    def impact_velocities_mm_s(self) -> np.ndarray | None:
        return (self.impact_velocities * self.length_m * 1e3 * 2 * np.pi * self.natural_frequency_hz
                if self.physical else None)

    def to_xarray(self):
        """An :class:`xarray.Dataset` on ``t`` (and ``impact``), with units."""
        import xarray as xr

        ds = xr.Dataset(
            {"q": ("t", self.q, {"units": "1", "long_name": "displacement q"}),
             "dq": ("t", self.dq, {"units": "1", "long_name": "velocity q'"}),
             "impact_velocity": ("impact", self.impact_velocities,
                                 {"units": "1", "long_name": "pre-impact velocity q'-"})},
            coords={"t": ("t", self.t, {"units": "1", "long_name": "time from the start of the record"}),
                    "impact_time": ("impact", self.impact_times, {"units": "1", "long_name": "impact time"})},
            attrs={"Omega": self.Omega, "status": self.status, "message": self.message})
        if self.physical:
            ds["U"] = ("t", self.U_mm, {"units": "mm", "long_name": "sensor displacement U(L_S)"})
            ds["dU"] = ("t", self.dU_mm_s, {"units": "mm s-1", "long_name": "sensor velocity U'(L_S)"})
            ds = ds.assign_coords(time_s=("t", self.time_s, {"units": "s", "long_name": "time"}))
            ds.attrs["frequency_hz"] = self.Omega * self.natural_frequency_hz
        return ds

    def plot(self, path=None):
        """Displacement and velocity against time, and the phase portrait (a Figure)."""
        from vibeam.plots.sweep import simulation_figure

        return _saved(simulation_figure(self), path)


def simulate(case_or_model, Omega: float | None = None, periods: int | None = None, transient: int | None = None,
             frequency_hz: float | None = None, samples_per_period: int | None = None, run: str | int = 0,
             method: str = "event", state=None, force: bool = False, **settings) -> Simulation:
    """Simulate one forcing frequency and return the recorded time series and impacts.

    Parameters
    ----------
    case_or_model : Case, str, Path, dict, or a model
        A case (anything :func:`load_case` takes; its run ``run`` with its method,
        settings and effects), or a model (:class:`vibeam.models.SDOF`, a beam model)
        simulated by ``method``.
    Omega : float
        Forcing frequency over the natural frequency (or give ``frequency_hz`` for a
        physical scene).
    periods : int, optional
        Forcing periods recorded (default: the case's ``record_periods``, 16 for a model).
    transient : int, optional
        Forcing periods simulated first and discarded (default: the case's
        ``transient_periods``, 0 for a model).
    frequency_hz : float, optional
        Forcing frequency (Hz) of a physical scene: ``Omega = f / f_n``.
    samples_per_period : int, optional
        Samples per forcing period (default: the case's, 64 for a model).
    run : str or int
        The case's run (name or index) whose method, settings, model overrides and
        effects are used.
    method : str
        Method for a model (``event``, ``direct``, ...; time-domain methods only).
    state : array_like, shape (2 d,) or (2 d + 1,), optional
        Initial state at forcing phase 0 (default: the model's rest state,
        ``model.initial_state()``): the displacements then the velocities of the model's
        ``d`` degrees of freedom -- ``(q, q')`` of the SDOF oscillator (nondimensional), the
        modal coordinates ``(eta_1..eta_d, eta'_1..eta'_d)`` of a beam (mass-normalised, m
        kg^(1/2) and m kg^(1/2)/s over the time unit) -- optionally followed by the held flag
        (0 free, 1 held on the upper stop, -1 on the lower one; left out: 0, and a state on a
        stop with zero relative velocity is held by the solver's own sticking test).  Finite
        numbers, on the free side of every rigid stop (a state behind one is refused: the
        kernels would project it onto the stop); ``Simulation.final_state`` has the flag and
        can be passed back.
    force : bool
        Simulate even if the work is above the limit of ``vibeam run`` (as ``--force``).
    **settings
        Method settings for a model (e.g. ``rtol`` for ``direct``).

    Returns
    -------
    Simulation

    Raises
    ------
    TypeError, ValueError
        One line naming the argument, the value and what is allowed; the arguments are
        checked by the rules of the case keys they stand for (:mod:`vibeam.case.arguments`):
        ``Omega`` / ``frequency_hz`` a finite number > 0 (a point of ``[sweep] Omega``),
        ``periods`` as ``[sweep] record_periods`` (a whole number >= 1), ``transient`` as
        ``transient_periods`` (a whole number >= 0; ``"auto"`` is the sweep's and is
        refused here), ``samples_per_period`` as ``[sweep] samples_per_period``; ``run`` a
        run's index or name; ``state`` 2 d or 2 d + 1 finite numbers.  Also: neither
        or both of ``Omega`` and ``frequency_hz`` given, ``frequency_hz`` for a
        nondimensional scene, a method without a time history (averaging, mapping).
    vibeam.case.schema.InputError
        The work is above the limit of ``vibeam run`` (:func:`vibeam.runner.check_work`:
        e.g. ``periods = 10**12``) and ``force`` is not set; a ValueError too.
    """
    from vibeam.case.arguments import check_case_value, check_flag, check_frequency
    from vibeam.case.schema import Case, SweepSpec
    from vibeam.errors import quote_value
    from vibeam.engine.records import summarize

    check_flag(force, "force")
    if Omega is not None:
        Omega = check_frequency(Omega, "Omega", "Omega")
    if frequency_hz is not None:
        frequency_hz = check_frequency(frequency_hz, "frequency_hz", "frequency_hz")
        if Omega is not None:
            raise ValueError(f"Omega = {Omega!r} and frequency_hz = {frequency_hz!r}: give one of them, not both")
    if Omega is None and frequency_hz is None:
        raise ValueError("Omega = None: give Omega (or frequency_hz for a physical scene)")
    if periods is not None:
        periods = check_case_value(periods, "periods", SweepSpec, "record_periods")
    if transient is not None:
        transient = check_case_value(transient, "transient", SweepSpec, "transient_periods")
    if samples_per_period is not None:
        samples_per_period = check_case_value(samples_per_period, "samples_per_period", SweepSpec,
                                              "samples_per_period")
    case = None
    if isinstance(case_or_model, (Case, str, Path, dict)):
        from vibeam.runner import make_job

        case = load_case(case_or_model)
        r = _pick_run(case, run)
        job = make_job(case, r, dict(r.model))
        solver = job.solver
        periods = case.sweep.record_periods if periods is None else periods
        if transient is None:
            transient = case.sweep.transient_periods
            if transient == "auto":
                raise ValueError("transient = None: the case's [sweep] transient_periods is \"auto\" (settled by "
                                 "the sweep); give transient, a whole number >= 0")
        spp = case.sweep.samples_per_period if samples_per_period is None else samples_per_period
        period_rtol = case.sweep.period_rtol
    else:
        from vibeam.models import make_solver

        if not isinstance(method, str):
            raise TypeError(f"method = {quote_value(method)}: not a method name; allowed: a str (event, direct, ...)")
        solver = make_solver(case_or_model, method, **settings)
        periods = 16 if periods is None else periods
        transient = 0 if transient is None else transient
        spp = 64 if samples_per_period is None else samples_per_period
        period_rtol = 1e-5
    if transient == "auto":
        raise ValueError("transient = 'auto': simulate runs a fixed transient (the sweep settles 'auto'); "
                         "allowed: a whole number >= 0")
    model = solver.model
    fn = getattr(model, "natural_frequency_hz", None)
    L = getattr(model, "length_m", None)
    if frequency_hz is not None:
        if not fn:
            raise ValueError(f"frequency_hz = {frequency_hz!r}: needs a physical scene (natural_frequency_hz); "
                             f"give Omega")
        Omega = check_frequency(frequency_hz / fn, "frequency_hz / natural_frequency_hz")
    if not solver.time_domain:
        raise ValueError(f"method {solver.name!r} computes no time history; use a time-domain method "
                         f"(event, direct, zhuravlev, ivanov)")
    if state is not None:
        state = _check_state(state, model)
    _check_point_work(case, job if case is not None else None, solver, Omega, int(transient), int(periods),
                      int(spp), force, settings)
    from vibeam.engine.sweep import simulate as _run_point

    # the sweep engine's calls of bounded work: Ctrl-C stops a long simulation between them
    traj = _run_point(solver, float(Omega), state, int(transient), int(periods), int(spp))
    summ = summarize(traj, float(model.Delta), period_rtol)
    return Simulation(Omega=float(Omega), t=traj.t, q=traj.samples[:, 0].copy(), dq=traj.samples[:, 1].copy(),
                      impact_times=np.asarray(traj.impact_times), impact_velocities=np.asarray(traj.impact_velocities),
                      summary=summ, status=summ["status"], message=summ["message"], final_state=traj.final_state,
                      natural_frequency_hz=fn, length_m=L, trajectory=traj,
                      name="" if case is None else (case.name if len(case.run) <= 1 else f"{case.name}, {r.name}"))


@dataclass
class Lyapunov:
    """The Lyapunov spectrum of the attractor one simulation settles on (:func:`lyapunov`).

    Attributes
    ----------
    Omega : float
        Forcing frequency over the natural (reference) frequency.
    exponents, error : ndarray, shape (d,)
        ``lambda_1 >= ... >= lambda_d`` and their error estimates per unit of the model's
        nondimensional time (:class:`vibeam.models.lyapunov.LyapunovSpectrum`).
    exponents_per_s, error_per_s : ndarray, shape (d,) or None
        The same per second for a physical scene (1/s), else None.
    status, message : str
        ``"ok"``, or ``"failed"`` with the reason (a shot the shooting problem could not take).
    impacts_per_period : float
        Impacts (contacts) per forcing period on the attractor.
    spectrum : vibeam.models.lyapunov.LyapunovSpectrum
    """

    Omega: float
    exponents: np.ndarray
    error: np.ndarray
    exponents_per_s: np.ndarray | None
    error_per_s: np.ndarray | None
    status: str
    message: str
    impacts_per_period: float
    spectrum: object


def lyapunov(case_or_model, Omega: float | None = None, shots: int = 2000, transient: int | None = None,
             frequency_hz: float | None = None, run: str | int = 0, state=None, n: int = 1) -> Lyapunov:
    """Lyapunov spectrum of the stroboscopic map at one forcing frequency (issue 21).

    The state from ``state`` (default: rest) is simulated by :func:`simulate` for ``transient``
    periods (default: the case's ``transient_periods``), then ``shots`` shots of ``n`` periods of
    the model's shooting problem (:func:`vibeam.models.shooting_problem`) give the spectrum by
    the QR method (:func:`vibeam.models.lyapunov.lyapunov_spectrum`: exact flows, saltation
    matrices at impacts, Müller 1995; Benettin et al. 1980).

    Parameters
    ----------
    case_or_model : Case, str, Path, dict, or a model
        As :func:`simulate` (a case's run ``run`` gives the model).
    Omega, frequency_hz : float
        The forcing frequency (one of them), as :func:`simulate`.
    shots : int
        Shots averaged, 2 ... 10**6.
    transient : int, optional
        Periods simulated first, as :func:`simulate`.
    state : array_like, optional
        Initial state, as :func:`simulate`.
    n : int
        Forcing periods per shot, 1 ... 64.

    Returns
    -------
    Lyapunov

    Raises
    ------
    TypeError, ValueError
        One line naming the argument, the value and what is allowed (as :func:`simulate`); a
        model without a shooting problem.
    """
    from vibeam.case.arguments import check_whole
    from vibeam.models import shooting_problem
    from vibeam.models.lyapunov import lyapunov_spectrum

    shots = check_whole(shots, "shots", 2, 10 ** 6)
    n = check_whole(n, "n", 1, 64)
    sim = simulate(case_or_model, Omega=Omega, periods=1, transient=transient, frequency_hz=frequency_hz,
                   run=run, state=state, samples_per_period=16)
    from vibeam.case.schema import Case

    if isinstance(case_or_model, (Case, str, Path, dict)):
        from vibeam.runner import make_job

        case = load_case(case_or_model)
        r = _pick_run(case, run)
        model = make_job(case, r, dict(r.model)).solver.model
    else:
        model = case_or_model
    problem = shooting_problem(model, "Omega")
    d = 2 * int(getattr(model, "n_modes", 1))
    sp = lyapunov_spectrum(problem, np.asarray(sim.final_state, float)[:d], sim.Omega, shots, 0, n)
    # the model's time unit: 1 / (2 pi f) of its natural (SDOF) or reference (beam) frequency
    f = getattr(model, "natural_frequency_hz", None) or getattr(model, "f_ref_hz", None)
    scale = 2.0 * math.pi * f if f else None
    return Lyapunov(Omega=float(sim.Omega), exponents=sp.exponents, error=sp.error,
                    exponents_per_s=None if scale is None else sp.exponents * scale,
                    error_per_s=None if scale is None else sp.error * scale, status=sp.status, message=sp.message,
                    impacts_per_period=sp.impacts / max(sp.shots * sp.periods_per_shot, 1), spectrum=sp)


def basins(case, frequency_hz=None, Omega=None, grid=None, samples: int | None = None, run: str | None = None,
           jobs: int | None = 1, executor=None, out=None, progress: bool = False, **keys):
    """Basins of attraction (a grid of initial states) or the census of attractors (random
    initial states) of a case at one or more forcing frequencies (issue 21).

    Every initial state is followed by the case's exact solver until the recurrences of its
    stroboscopic samples on a cell grid name the attractor it reaches (Datseris & Wagemakers,
    Chaos 32, 2022); each attractor is then typed (period-n, sticking, chaotic, quasi-periodic),
    refined by the shooting problem and given its Lyapunov spectrum (:mod:`vibeam.analysis.attractors`).

    Parameters
    ----------
    case : Case, str, Path or dict
        Anything :func:`load_case` takes; its ``[basins]`` table gives the defaults.
    frequency_hz, Omega : float or list of float, optional
        Forcing frequencies (Hz for a physical scene, or nondimensional); default the case's
        ``[basins]`` ones, else every frequency of its sweep.
    grid : (int, int), optional
        ``(nx, ny)`` initial states on a grid (default 200 x 200).
    samples : int, optional
        Random initial states instead of a grid (seeded by ``seed``).
    run : str, optional
        The run whose model and solver are used (default: the first time-domain run).
    jobs : int or None
        Workers of the local pool (1: in this process; None: all cores).
    executor : concurrent.futures.Executor, optional
        Where the grid's rows run (e.g. a dask client's executor).
    out : str or Path, optional
        A results file: the result is written to its ``/basins/<run>/`` (other groups kept).
    progress : bool
        A progress bar.
    **keys
        Any other key of ``[basins]`` (``x_range``, ``y_range``, ``coordinates``, ``seed``,
        ``max_periods``, ``recurrences``, ``lyapunov_periods``, ...).

    Returns
    -------
    vibeam.analysis.attractors.BasinsResult
        ``labels`` per initial state, ``attractors`` (type, period, amplitude, fraction and its
        standard error, Lyapunov spectrum), ``to_xarray()``.

    Raises
    ------
    vibeam.case.schema.CaseError, ValueError
        One line naming the key, the value and what is allowed.
    """
    from vibeam.analysis.attractors import compute, write_basins
    from vibeam.case.schema import BasinsSpec
    from vibeam.errors import CaseError

    c = load_case(case)
    data = c.basins.model_dump(exclude_none=True) if c.basins is not None else {}
    aslist = lambda v: list(v) if isinstance(v, (tuple, np.ndarray)) else v
    given = dict(frequency_hz=aslist(frequency_hz), Omega=aslist(Omega), grid=aslist(grid), samples=samples,
                 run=run, **{k: aslist(v) for k, v in keys.items()})
    given = {k: v for k, v in given.items() if v is not None}
    if "frequency_hz" in given or "Omega" in given:
        data.pop("frequency_hz", None)
        data.pop("Omega", None)
    if "samples" in given:
        data.pop("grid", None)
    if "grid" in given:
        data.pop("samples", None)
    data.update(given)
    from pydantic import ValidationError

    from vibeam.case.schema import validation_message

    try:
        spec = BasinsSpec.model_validate(data)
    except ValidationError as e:
        raise CaseError(validation_message(e, "basins", BasinsSpec)) from None
    if out is None:
        return compute(c, jobs=jobs, executor=executor, progress=progress, spec=spec)
    from vibeam.io.store import Store
    from vibeam.runner import case_identity

    out = Path(out)
    with Store(out.parent, out.name) as st:       # the file's folder held for the computation and the write
        res = compute(c, jobs=jobs, executor=executor, progress=progress, spec=spec)
        cj, aliases = case_identity(st, c.model_dump_json())
        write_basins(st, [res], c.name, case_text(c), cj, aliases)
    return res


def _pick_run(case, run):
    """The run ``run`` (index or name) of a case (TypeError/ValueError naming the runs)."""
    from vibeam.errors import quote_value

    names = [x.name for x in case.run]
    if isinstance(run, bool) or not isinstance(run, (int, str)):
        raise TypeError(f"run = {quote_value(run)}: allowed: a run's index (0 ... {len(names) - 1}) or name ({names})")
    if isinstance(run, int):
        if not 0 <= run < len(names):
            raise ValueError(f"run = {run}: no such run; allowed: 0 ... {len(names) - 1} or a name of {names}")
        return case.run[run]
    r = next((x for x in case.run if x.name == run), None)
    if r is None:
        raise ValueError(f"run = {quote_value(run)}: no run of that name; allowed: {names} or 0 ... {len(names) - 1}")
    return r


#: the largest magnitude of an initial state's numbers (:func:`simulate`): squares stay finite
STATE_MAX = 1e100


def _check_state(state, model) -> np.ndarray:
    """An initial state (TypeError/ValueError): the model's displacements and velocities
    (``(q, q')``, or ``(eta, eta')`` of a modal beam: ``n - 1`` numbers), optionally followed by the
    held flag (``n`` numbers, :meth:`initial_state`'s layout); returned with the flag (0, free,
    when it was left out)."""
    from vibeam.errors import quote_value

    n = int(np.size(model.initial_state()))
    allowed = (f"{n - 1} or {n} finite numbers: the displacements and velocities{' (q, dq)' if n == 3 else ''}, "
               f"optionally followed by the held flag (0 free, 1 held on the upper stop, -1 on the lower one)")
    try:
        x = np.asarray(state, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"state = {quote_value(state)}: not numbers; allowed: {allowed}") from None
    if x.ndim != 1 or x.size not in (n - 1, n) or not np.isfinite(x).all():
        raise ValueError(f"state = {quote_value(state)}: allowed: {allowed}")
    if np.abs(x).max() > STATE_MAX:
        raise ValueError(f"state = {quote_value(state)}: allowed: |values| <= {STATE_MAX:g} (the record's energies "
                         f"and spreads square them: 1e300 overflows double precision)")
    x = np.append(x, 0.0) if x.size == n - 1 else x
    from vibeam.analysis.attractors import behind_stop, stop_gaps

    if hasattr(model, "stops") and behind_stop(model, x[None, :])[0]:
        # the kernels would project it onto the stop and report a motion it never had
        g = stop_gaps(model, x[None, :])[0]
        k = int(np.argmax(g))
        raise ValueError(f"state = {quote_value(state)}: lies behind stop {k} (gap {g[k]:.6g} > 0, the "
                         f"{'upper' if k == 0 else 'lower' if k == 1 else 'point'} stop); allowed: a state the "
                         f"motion can reach, every rigid stop's gap <= 0")
    return x


_WORK_ARGS = {"sweep.record_periods": "periods", "sweep.transient_periods": "transient",
              "sweep.samples_per_period": "samples_per_period", "sweep.Omega": "Omega"}


def _check_point_work(case, job, solver, Omega, transient, periods, spp, force, settings) -> None:
    """Refuse a point above the work limits of ``vibeam run`` (:data:`vibeam.runner.MAX_WORK_STEPS`,
    :data:`vibeam.runner.MAX_POINT_VALUES`) unless ``force``: a case's point by the runner's
    own estimate (:func:`vibeam.runner.check_work` of the one-point case), a model's by its
    per-point term (:func:`vibeam.runner.point_work`)."""
    import dataclasses
    import re

    from vibeam.case.schema import Case
    from vibeam.errors import InputError, quote_value
    from vibeam.runner import MAX_POINT_VALUES, MAX_WORK_STEPS, check_work, point_work

    if force:
        return
    if case is not None:
        data = case.model_dump()
        data["sweep"] = dict(data["sweep"], Omega=[Omega, Omega, 1], frequency_hz=None, direction="up",
                             transient_periods=transient, record_periods=periods, statistics_periods=0,
                             samples_per_period=spp)
        data["run"] = [job.run.model_dump()]
        data["map"] = None
        one = Case.model_validate(data)
        sw = dataclasses.replace(job.sweep, Omega=np.array([Omega]), direction="up", transient_periods=transient,
                                 record_periods=periods, statistics_periods=0, samples_per_period=spp)
        try:
            check_work(one, [dataclasses.replace(job, run=one.run[0], sweep=sw)], source="simulate")
        except InputError as e:
            msg = str(e).replace(f"'sweep.Omega' = {quote_value(one.sweep.Omega)}", f"Omega = {Omega!r}")
            msg = re.sub(r"'(sweep\.[a-z_A-Z]+)'", lambda m: _WORK_ARGS.get(m.group(1), m.group(0)), msg)
            raise InputError(msg.replace("the case needs", "the point needs")
                             .replace("pass --force", "pass force=True")) from None
        return
    w = point_work(Omega, transient, periods, spp, dofs=max(1, int(np.size(solver.model.initial_state())) // 2),
                   method=solver.name, transient_samples=int(settings.get("transient_samples", 16)),
                   model=solver.model)
    if w["point_values"] > MAX_POINT_VALUES:
        raise InputError(f"simulate: periods = {periods}, samples_per_period = {spp}: the point would record "
                         f"{w['point_values']:.3g} values (limit {MAX_POINT_VALUES:.0e}); record fewer periods or "
                         f"samples, or pass force=True")
    if w["steps"] > MAX_WORK_STEPS:
        raise InputError(f"simulate: Omega = {Omega:g}, transient = {transient}, periods = {periods}: the point needs "
                         f"about {w['steps']:.2g} solver steps, above the limit of {MAX_WORK_STEPS:.0e}; reduce "
                         f"them, or pass force=True")


# ============================================================================ the other commands
def _case_and_source(case):
    """``(Case, source)``: the case, and the file it came from (for messages) or ''."""
    c = load_case(case)
    source = str(case) if isinstance(case, (str, Path)) and _names_a_file(str(case)) else ""
    return c, source


@dataclass
class Derived:
    """SDOF parameters of a beam scene by the assumed static mode (:func:`derive`).

    Attributes
    ----------
    case : Case
    rows : list of (name, value, unit, source)
        The table of ``vibeam derive`` (EI, M_S, K_S, f_n, beta_S, ...; SI units).
    reduction, with_beam_mass : vibeam.reductions.static_mode.StaticModeReduction
        The reduction without (the paper's) and with the beam's modal mass.
    scene : vibeam.case.beamscene.BeamScene
    sdof_case_text : str
        The TOML of the SDOF case of the same scene (``vibeam derive --write``).
    """

    case: object
    rows: list
    reduction: object
    with_beam_mass: object
    scene: object
    sdof_case_text: str

    def write(self, path) -> Path:
        """Write :attr:`sdof_case_text` to ``path`` atomically (``--write``)."""
        from vibeam.io.outdir import write_text_file

        return write_text_file(Path(path), self.sdof_case_text, "--write")


def derive(case, write=None) -> Derived:
    """SDOF parameters of a beam scene by the assumed static mode (``vibeam derive``; paper
    Eqs. 42-46: ``M_S = m phi(x_m)^2``, ``K_S = EI/L^3 int phi''^2``, ``beta_S = D omega_n / 2``).

    Parameters
    ----------
    case : Case, str, Path or dict
        A beam scene (a fidelity with a finite-element model).
    write : str or Path, optional
        Also write the SDOF case file of the same scene there (``--write``).

    Returns
    -------
    Derived

    Raises
    ------
    vibeam.case.schema.CaseError
        Not a beam scene (one line naming ``model.fidelity``), or a bad case.
    """
    from vibeam.case.arguments import check_path
    from vibeam.case.beamscene import beam_spec, derive as _derive, sdof_case_text

    write = check_path(write, "write")
    c, _ = _case_and_source(case)
    spec = beam_spec(c, "derive")
    d = _derive(spec)
    res = Derived(c, d["rows"], d["reduction"], d["with_beam_mass"], d["scene"],
                  sdof_case_text(c, spec, d["reduction"], d["scene"]))
    if write is not None:
        res.write(write)
    return res


@dataclass
class Modes:
    """Modes of a beam scene (:func:`modes`).

    Attributes
    ----------
    case : Case
    fe : vibeam.models.beam.BeamFE
        The finite-element model (``fe.ndof`` degrees of freedom).
    modes, contact : modal data
        Free modes (``frequencies_hz`` (n,), ``shapes`` (ndof, n), ``participation`` (n,),
        kg^0.5, ``effective_mass_kg`` (n,)) and contact modes (beam held at the stop).
    total_mass_kg : float
    sensor_modal_mass_kg : ndarray, shape (n,)
        The modal mass seen at the sensor, ``1 / (s phi_i)^2`` (kg).
    n : int
        Modes asked for.
    paths : dict
        ``vtu`` and ``png`` written (with ``out``).
    """

    case: object
    fe: object
    modes: object
    contact: object
    total_mass_kg: float
    sensor_modal_mass_kg: np.ndarray
    n: int
    report: dict
    paths: dict = field(default_factory=dict)

    def plot(self, path=None):
        """Free and contact mode shapes along the beam (``modes.png``)."""
        return _saved(modes_figure(self.report, self.case.name), path)


def modes(case, n: int = 6, out=None) -> Modes:
    """Natural frequencies, participation, effective masses and contact modes of a beam scene
    (``vibeam modes``; Hermite FE cantilever with point mass and rotary inertia, base excitation).

    Parameters
    ----------
    case : Case, str, Path or dict
        A beam scene.
    n : int
        Number of modes (>= 1; at most the FE model's degrees of freedom).
    out : str or Path, optional
        A folder: ``modes.vtu`` (ParaView) and ``modes.png`` are written there atomically.

    Returns
    -------
    Modes

    Raises
    ------
    vibeam.case.schema.CaseError
        Not a beam scene; the folder in use by another vibeam process.
    TypeError, ValueError
        ``n`` not a whole number >= 1, ``out`` not a path.
    """
    from vibeam.case.arguments import check_path, check_whole
    from vibeam.case.beamscene import beam_spec, modes_report

    n = check_whole(n, "n", 1, 10 ** 6)
    out = check_path(out, "out")
    c, _ = _case_and_source(case)
    spec = beam_spec(c, "modes")
    rep = modes_report(spec, n=n)
    res = Modes(c, rep["fe"], rep["modes"], rep["contact"], rep["total_mass_kg"], rep["sensor_modal_mass_kg"],
                n, rep)
    if out is not None:
        from vibeam.io.outdir import OutputLock, check_folder

        folder = check_folder(Path(out))
        with OutputLock(folder):          # like every writer: one vibeam process per folder
            res.paths = write_modes_files(res, folder)
    return res


def write_modes_files(res: Modes, folder) -> dict:
    """``modes.vtu`` and ``modes.png`` of :func:`modes` into ``folder`` (atomically)."""
    from vibeam.io.outdir import replace_file
    from vibeam.models.beam import write_modes
    from vibeam.plots.sweep import save_close

    folder = Path(folder)
    vtu = replace_file(folder / "modes.vtu",
                       lambda p: write_modes(p, res.fe, n=min(res.n, len(res.modes.frequencies_hz))))
    png = save_close(modes_figure(res.report, res.case.name), folder / "modes.png")
    return {"vtu": vtu, "png": png}


def modes_figure(rep: dict, title: str = ""):
    """Free and contact mode shapes along the beam (the first four of each), normalised; a
    Figure (``modes.png`` of ``vibeam modes``).  ``rep``: :func:`vibeam.case.beamscene.modes_report`."""
    import matplotlib.pyplot as plt

    from vibeam.plots import style

    fe, md, cm = rep["fe"], rep["modes"], rep["contact"]
    L = fe.geometry.length_m
    x = np.linspace(0, L, 361)
    with style.context():
        fig, axes = plt.subplots(1, 2, figsize=(10, 4.4), sharey=True)
        for ax, m, lab in ((axes[0], md, "free"), (axes[1], cm, "contact (held at the stop)")):
            for i in range(min(4, m.shapes.shape[1])):
                w = fe.deflection(m.shapes[:, i], x)
                ax.plot(x * 1e3, w / np.max(np.abs(w)), label=f"{m.frequencies_hz[i]:.2f} Hz")
            for xp, nm in ((fe.geometry.sensor_position_m, "$L_S$"), (fe.geometry.mass_position_m, "$L_m$")):
                ax.axvline(xp * 1e3, color="0.6", ls=":")
                ax.text(xp * 1e3, 1.02, nm, ha="center", fontsize=8)
            ax.set_title(f"{lab} modes", loc="left")
            ax.set_xlabel(style.label("position along the beam x", "mm"))
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=4, title="mode")
        axes[0].set_ylabel(style.label("normalised deflection", None))
        style.titles(fig, title, "mode shapes of the FE beam")
    return fig


@dataclass
class Regression:
    """A case's FRCs against reference FRCs (:func:`regress`).

    Attributes
    ----------
    case : Case
    reference : Path
    rows : list of vibeam.analysis.regress.RegressRow
        One per run: points compared, failures, max |dA| and relative, period mismatches.
    atol, rtol : float
        The amplitude tolerances used (``[regress]`` or the arguments).
    ok : bool
        Every run within the tolerances (``vibeam regress`` exits 0).
    """

    case: object
    reference: Path
    rows: list
    atol: float
    rtol: float

    @property
    def ok(self) -> bool:
        return bool(self.rows) and all(r.ok for r in self.rows)

    def print(self) -> None:
        """The table of ``vibeam regress``."""
        from vibeam.analysis.regress import print_rows

        tol = self.case.regress
        print(f"\nregression of {self.case.name} against {self.reference}")
        print_rows(self.rows, self.atol, self.rtol, tol.spread_sigmas, tol.spread_range)


def regress(case, reference, results=None, out=None, jobs: int | None = None, executor=None,
            atol: float | None = None, rtol: float | None = None, quick: bool = False,
            force: bool = False) -> Regression:
    """Compare a case's FRCs with reference FRCs (``vibeam regress``): rerun the case (or take
    ``results``) and compare amplitudes point by point (``[regress]`` tolerances).

    Parameters
    ----------
    case : Case, str, Path or dict
    reference : str or Path
        Reference ``results.h5`` or CSV (``Omega,amplitude`` or ``frequency_hz,amplitude_mm``).
    results : str or Path, optional
        Compare this results file instead of rerunning the case.
    out : str or Path, optional
        Folder of the rerun (default: a temporary folder, removed afterwards).
    jobs, executor, quick, force
        As :func:`run`.
    atol, rtol : float, optional
        Override ``[regress] amplitude_atol`` / ``amplitude_rtol``; checked by those keys' rule
        (a finite number >= 0).

    Returns
    -------
    Regression

    Raises
    ------
    vibeam.case.schema.InputError
        A reference or results file that is not of this case or not readable (one line): a
        results-file reference (or ``results``) written by another case (another name, model,
        effects or runs: :func:`vibeam.analysis.regress.check_results_of_case`).
    TypeError, ValueError
        ``atol`` / ``rtol`` not a finite number >= 0 (NaN, infinite, negative).
    """
    from vibeam.analysis.regress import (check_reference_of_case, check_results_of_case, compare, load_results,
                                         read_reference)
    from vibeam.case.arguments import check_case_value, check_path
    from vibeam.case.schema import RegressSpec

    jobs, out = _check_run_args(jobs, out, executor, quick=quick, force=force)
    if atol is not None:
        atol = check_case_value(atol, "atol", RegressSpec, "amplitude_atol")
    if rtol is not None:
        rtol = check_case_value(rtol, "rtol", RegressSpec, "amplitude_rtol")
    reference = check_path(reference, "reference", optional=False)
    results = check_path(results, "results")
    c, source = _case_and_source(case)
    ref = read_reference(reference)    # a bad reference is refused before anything runs
    check_reference_of_case(c, ref, reference, source)
    if results is not None:
        new = load_results(results, "--results")
        check_results_of_case(c, new, results, source)
    if isinstance(ref, dict):          # a results-file reference: of this case too
        check_results_of_case(c, ref, reference, source, option="--reference")
    if results is None:
        from vibeam.io.outdir import check_folder
        from vibeam.runner import run_case

        # the rerun goes to its own folder: out, or a temporary one removed afterwards --
        # never results/<case>/, where it would replace the results of the user's run, and never
        # into the reference it is compared with
        with tempfile.TemporaryDirectory(prefix=f"vibeam-regress-{c.name}-") as tmp:
            out_dir = check_folder(Path(out) if out else Path(tmp))
            run_case(c, case_text(c), out_dir, jobs=jobs, quiet=True, plots=False, quick=quick,
                     executor=executor, force=force, source=source, inputs=[(reference, "--reference")])
            new = load_results(out_dir / "results.h5", "results")
    tol = c.regress
    atol = tol.amplitude_atol if atol is None else atol
    rtol = tol.amplitude_rtol if rtol is None else rtol
    rows = compare(new, reference, atol=atol, rtol=rtol, period=tol.period, sigmas=tol.spread_sigmas,
                   spread_range=tol.spread_range, continuation=c.sweep.continuation)
    return Regression(c, Path(reference), rows, atol, rtol)


@dataclass
class Cost:
    """Accuracy against time of every run (:func:`cost`): ``result`` as
    :func:`vibeam.analysis.cost.run_cost` returns it (``rows``: method, settings, seconds,
    errors against the converged reference; the paper's claims), ``paths`` written."""

    case: object
    result: dict
    paths: dict = field(default_factory=dict)

    @property
    def rows(self) -> list:
        return self.result["rows"]

    def to_xarray(self):
        """The cost table (the variables of ``cost.h5`` ``/cost``) as an :class:`xarray.Dataset`."""
        import xarray as xr

        from vibeam.analysis.cost import cost_tables
        from vibeam.io.results import table_variables

        v = table_variables(cost_tables(self.result))
        return xr.Dataset({k: (x.dims, x.data, x.attrs) for k, x in v.items()})

    def plot(self, path=None):
        """The work-precision figure (``work_precision.png``)."""
        from vibeam.analysis.cost import work_precision_figure

        return _saved(work_precision_figure(self.result, title=self.case.name, case=self.case), path)


def cost(case, out=None, ladder: bool = False, repeats: int = 3, quick: bool = False, jobs: int | None = None,
         force: bool = False, log=None) -> Cost:
    """Accuracy against time of every run (``vibeam cost``): each run's sweep timed (median of
    ``repeats``, inline) and its error against a converged reference.

    Parameters
    ----------
    case : Case, str, Path or dict
    out : str or Path, optional
        A folder: ``cost.h5`` (``/cost``) and ``work_precision.png`` written there atomically.
    ladder : bool
        Also a ladder of tolerances per ODE method.
    repeats : int
        Timed repetitions (>= 1).
    quick, jobs, force
        As :func:`run` (``jobs``: the workers of the converged references).
    log : callable, optional
        Progress messages (default: none).

    Returns
    -------
    Cost

    Raises
    ------
    vibeam.case.schema.CaseError
        Work above the limit without ``force``; a bad case.
    """
    from vibeam.analysis.cost import check_cost_work, cost_tables, plot_work_precision, run_cost
    from vibeam.case.arguments import check_whole

    jobs, out = _check_run_args(jobs, out, None, ladder=ladder, quick=quick, force=force)
    repeats = check_whole(repeats, "repeats", 1, 10 ** 6)
    c, source = _case_and_source(case)
    text = case_text(c)
    if quick:
        c = c.quick_variant()
    check_cost_work(c, force=force, source=source)
    log = log or (lambda m: None)
    if out is None:
        return Cost(c, run_cost(c, ladder=ladder, repeats=repeats, jobs=jobs, log=log))
    from vibeam.io.outdir import OutputLock, check_folder
    from vibeam.io.results import write_results

    folder = check_folder(Path(out))
    with OutputLock(folder):
        res = run_cost(c, ladder=ladder, repeats=repeats, jobs=jobs, log=log)
        h5 = write_results(folder / "cost.h5", [], c.name, text, extra={"cost": cost_tables(res)},
                           case_json=c.model_dump_json())
        png = plot_work_precision(res, folder / "work_precision.png", title=c.name, case=c)
    return Cost(c, res, {"h5": h5, "png": png})


def fit(case, reference=None, params=None, run: str | None = None, out=None, jobs: int | None = 1,
        quick: bool = False, loss: str | None = None, f_scale: float = 3.0, max_evaluations: int = 60,
        reference_run: str | None = None, plots: bool = True, log=None):
    """Fit model parameters to a measured FRC (``vibeam fit``), with standard errors.

    Parameters
    ----------
    case : Case, str, Path or dict
        Its ``[model]`` values start the fit.
    reference : str or Path
        Measured FRC: CSV ``frequency_hz,amplitude_mm`` (or ``Omega,amplitude``), optional
        ``direction`` and ``sigma`` columns; or a results.h5 (``reference_run`` names its run).
    params : list of str or str, optional
        Numeric ``[model]`` keys to fit (default ``gain, R``; a comma-separated str too).
    run : str, optional
        Fit this run only (default: every run, one by one).
    out : str or Path, optional
        A folder for each fit's files (fitted case, table, ``fit.png``); default none written.
    jobs : int or None
        Workers (1: inline).
    quick : bool
        Sweep with the quick variant's periods.
    loss, f_scale, max_evaluations
        As ``--loss`` (default soft_l1), ``--f-scale`` (units of sigma), ``--max-evaluations``.

    Returns
    -------
    list of vibeam.identify.fit.FitResult
        One per run: ``estimate``, ``standard_error``, ``correlation``, ``residuals``, ...

    Raises
    ------
    vibeam.case.schema.CaseError
        A parameter that is not a numeric key of the scene, an unreadable reference (one line).
    """
    from vibeam.case.arguments import check_path
    from vibeam.engine.sweep import default_executor
    from vibeam.errors import CaseError
    from vibeam.identify.fit import DEFAULT_LOSS, check_params, default_params, fit_runs, read_reference

    out = check_path(out, "out")
    reference = check_path(reference, "reference", optional=False)
    if not (isinstance(f_scale, (int, float)) and math.isfinite(f_scale) and f_scale > 0):
        raise CaseError(f"f_scale = {f_scale!r}: must be a finite positive number (units of sigma)")
    c, source = _case_and_source(case)
    text = case_text(c)
    if isinstance(params, str):
        params = [p.strip() for p in params.split(",") if p.strip()]
    if quick:
        c = c.quick_variant()
    ref = read_reference(reference, reference_run)
    check_params(c, params or default_params(c), source)
    ex = default_executor(jobs, 2)
    try:
        if out is None:
            return fit_runs(c, ref, params, runs=[run] if run else None, case_text=text, plots=False, log=log,
                            executor=ex, loss=loss or DEFAULT_LOSS, f_scale=f_scale,
                            max_evaluations=max_evaluations, source=source)
        from vibeam.io.outdir import OutputLock, check_folder

        folder = check_folder(Path(out))
        with OutputLock(folder):
            return fit_runs(c, ref, params, runs=[run] if run else None, out_dir=folder, case_text=text,
                            plots=plots, log=log, executor=ex, loss=loss or DEFAULT_LOSS, f_scale=f_scale,
                            max_evaluations=max_evaluations, source=source)
    finally:
        ex.shutdown(wait=True, cancel_futures=True)


# ============================================================================ export
def export(path, csv_dir) -> list:
    """Every group of a results file as tidy CSV files (``vibeam export RESULTS.h5 --csv DIR``).

    Long format: one row per point, the dimensions' coordinates as the first columns, one column
    per variable.  A group whose variables lie on several sets of dimensions (a run's per-point
    outputs on (direction, Omega), its strobe on (direction, Omega, record_period, state), ...)
    gives one file per set: ``<group>.csv`` for the set with most variables, else
    ``<group>@<dim>-<dim>.csv`` (``/`` in a group's path is ``.``); where two groups would give one
    file name (run names ``a`` and ``a.units``, or ``a@direction-Omega-harmonic``), the later one
    gets ``~2``, ``~3``, ... before ``.csv``, so every table has a file of its own.
    ``index.csv`` lists each file once, with its group, dimensions and rows.  Complex values are
    two columns ``<name>_real``, ``<name>_imag``.  Units and long names are in a sidecar
    ``<file>.units.csv`` (``column,units,long_name``; ``1`` is nondimensional).  Padding (NaN
    beyond a branch's ``n_points``) is kept as empty cells, so every row maps to one stored
    value.  Every table is built before any file is written; then each file goes to a
    temporary file, flushed and renamed (:func:`vibeam.io.outdir.replace_file`): a file is never
    left partial, and a results file that cannot be read in full writes no file at all.

    Parameters
    ----------
    path : str or Path
        A results file (layout 2).
    csv_dir : str or Path
        Output folder (created if missing).

    Returns
    -------
    list of Path
        The CSV files written (data files; each with its ``.units.csv``).

    Raises
    ------
    ValueError
        Not a results file of layout 2, or one whose structure vibeam refuses (links, data
        beyond the size bounds; :mod:`vibeam.io.h5check`): one line naming the file
        (:class:`vibeam.errors.InputError`).
    """
    from vibeam.case.arguments import check_path
    from vibeam.io.outdir import check_output_file, replace_file

    csv_dir = check_path(csv_dir, "csv_dir", optional=False)
    res = open_results(path)
    tree = res.tree()
    folder = Path(csv_dir)
    import pandas as pd

    files, index, used = [], [], set()
    for node in tree.subtree:
        ds = node.to_dataset(inherit=False)
        if not ds.data_vars:
            continue
        gname = node.path.strip("/").replace("/", ".")
        for stem, dims, table, units in _tidy_tables(node.to_dataset(), ds, gname):
            stem = _unique_stem(stem, used)
            files.append((f"{stem}.csv", table.to_csv(index=False)))
            files.append((f"{stem}.units.csv", units.to_csv(index=False)))
            index.append((f"{stem}.csv", node.path.strip("/"), " ".join(dims), len(table)))
    # what each file holds: its group in results.h5 and its dimensions (the coordinate columns)
    files.append(("index.csv", pd.DataFrame(index, columns=["file", "group", "dimensions", "rows"])
                  .to_csv(index=False)))
    folder.mkdir(parents=True, exist_ok=True)
    for name, _ in files:
        check_output_file(folder / name)
    written = []
    for name, text in files:
        p = replace_file(folder / name, text)
        if name != "index.csv" and not name.endswith(".units.csv"):
            written.append(p)
    return written


#: the longest file stem export writes (bytes of UTF-8; file systems allow 255 per name)
MAX_STEM_BYTES = 200


def _unique_stem(stem: str, used: set) -> str:
    """``stem`` made unique among ``used`` (and added to it): no two tables share a data file,
    and no data file is another's ``.units.csv`` sidecar; cut to :data:`MAX_STEM_BYTES` on a
    character boundary."""
    raw = stem.encode("utf-8")
    if len(raw) > MAX_STEM_BYTES:
        stem = raw[:MAX_STEM_BYTES].decode("utf-8", "ignore")
    names = lambda s: {s.lower(), f"{s}.units".lower()}
    cand, k = stem, 1
    while names(cand) & used or cand.lower() == "index" or any(cand.lower() == f"{u}.units" for u in used):
        k += 1
        cand = f"{stem}~{k}"
    used |= names(cand)
    return cand


def _tidy_tables(full, own, gname: str):
    """``(stem, DataFrame, units DataFrame)`` per set of dimensions of a group's own variables."""
    import pandas as pd

    sets: dict = {}
    for k, v in own.data_vars.items():
        sets.setdefault(tuple(v.dims), []).append(k)
    main = max(sets, key=lambda d: (len(sets[d]), -len(d)))
    for dims, names in sets.items():
        stem = gname if dims == main else f"{gname}@{'-'.join(dims) or 'scalar'}"
        # the coordinates on exactly these dimensions (e.g. frequency_hz on Omega) as columns too
        coords = [c for c in full.coords if set(full[c].dims) <= set(dims) and c not in dims]
        cols, meta = {}, []
        shape = tuple(full.sizes[d] for d in dims)
        grids = np.meshgrid(*[np.arange(n) for n in shape], indexing="ij") if dims else []
        for d, g in zip(dims, grids):
            vals = full[d].values if d in full.coords else np.arange(full.sizes[d])
            cols[d] = np.asarray(vals)[g.ravel()]
            a = full[d].attrs if d in full.coords else {}
            meta.append((d, a.get("units", ""), a.get("long_name", "index")))
        for k in coords + names:
            v = full[k]
            if not v.dims:
                a = np.broadcast_to(np.asarray(v.values), shape)
            elif tuple(v.dims) == dims:
                a = np.asarray(v.values)
            else:                   # a coordinate on fewer dimensions (frequency_hz on Omega): gathered
                idx = tuple(g for d, g in zip(dims, grids) if d in v.dims)
                a = np.asarray(v.transpose(*[d for d in dims if d in v.dims]).values)[idx]
            a = np.asarray(a).reshape(-1)
            u, ln = v.attrs.get("units", ""), v.attrs.get("long_name", "")
            if np.iscomplexobj(a):
                cols[f"{k}_real"], cols[f"{k}_imag"] = a.real, a.imag
                meta += [(f"{k}_real", u, f"{ln} (real part)"), (f"{k}_imag", u, f"{ln} (imaginary part)")]
            else:
                cols[k] = a
                meta.append((k, u, ln))
        yield stem, dims, pd.DataFrame(cols), pd.DataFrame(meta, columns=["column", "units", "long_name"])


# ============================================================================ Poincaré sections
def poincare(case, Omega: float | None = None, frequency_hz: float | None = None, periods: int = 64,
             transient: int | None = None, run: str | int = 0, samples_per_period: int | None = None,
             state=None, out=None, force: bool = False):
    """Poincaré sections at one forcing frequency (``vibeam poincare``): the stroboscopic samples
    ``(q, q')`` at forcing phase 0 after the transient, and the impact map (impact phase
    ``Omega t mod 2 pi`` against the pre-impact velocity) from the event kernel's impact log
    (:mod:`vibeam.analysis.poincare`).

    Parameters
    ----------
    case : Case, str, Path, dict or a model
        As :func:`simulate`.
    Omega, frequency_hz : float
        The forcing frequency (one of them), as :func:`simulate`.
    periods : int
        Forcing periods recorded: stroboscopic samples (default 64).
    transient : int, optional
        Periods simulated first (default: the case's ``transient_periods``; 2000 when that is
        ``"auto"`` or for a model).
    run, samples_per_period, state, force
        As :func:`simulate`.
    out : str or Path, optional
        A PNG file (written atomically) of the two sections.

    Returns
    -------
    vibeam.analysis.poincare.PoincareSection
        ``strobe_q``, ``strobe_dq`` (periods,), ``impact_phase`` (rad), ``impact_velocity``;
        ``plot()``, ``to_xarray()``; mm and mm/s for a physical scene (``scales``).

    Raises
    ------
    TypeError, ValueError
        As :func:`simulate` (one line naming the argument).
    """
    from vibeam.analysis.poincare import section
    from vibeam.case.arguments import check_path
    from vibeam.case.schema import Case

    out = check_path(out, "out")
    if transient is None:
        t = None
        if isinstance(case, (Case, str, Path, dict)):
            t = load_case(case).sweep.transient_periods
        transient = 2000 if t in (None, "auto") else t
    sim = simulate(case, Omega=Omega, frequency_hz=frequency_hz, periods=periods, transient=transient, run=run,
                   samples_per_period=samples_per_period, state=state, force=force)
    sec = section(sim)
    if out is not None:
        import matplotlib.pyplot as plt

        plt.close(sec.plot(out))
    return sec
