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
            import h5py

            branches = read_continuation(path)
            with h5py.File(path, "r") as f:
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
        from vibeam.analysis.attractors import write_basins
        from vibeam.io.results import write_results

        self._tmp = tempfile.TemporaryDirectory(prefix="vibeam-results-")
        name = getattr(self.case, "name", "")
        text = case_text(self.case) if self.case is not None else ""
        f = write_results(Path(self._tmp.name) / "results.h5", self.runs, name, text, maps=self.maps,
                          branches=self.branches)
        if self.basins:
            write_basins(f, self.basins, name, text)
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

    branches = read_continuation(h5) if Path(h5).is_file() else []
    if runs is None:
        back = Results.from_file(h5) if Path(h5).is_file() else Results()
        runs, maps = back.runs, back.maps
    res = Results(list(runs), list(maps or []), case, None if out is None else Path(h5), branches, list(basins))
    res._tmp = tmp                       # kept alive with the results: the file behind to_xarray()
    res._file = Path(h5) if Path(h5).is_file() else None
    return res


def run(case, jobs: int | None = None, executor=None, out=None, quick: bool = False, progress: bool = False,
        plots: bool = False, resume: bool = False, force: bool = False, verbose: bool = False,
        basins: bool = True) -> Results:
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
                                force=force, verbose=verbose, basins=basins)
    c = load_case(case)
    text = case_text(c)
    source = str(case) if isinstance(case, (str, Path)) and _names_a_file(str(case)) else ""
    ctx = contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO())
    tmp = None
    if out is None:
        tmp = tempfile.TemporaryDirectory(prefix="vibeam-run-")
        folder = Path(tmp.name)
    else:
        folder = Path(out)
    with ctx:
        res = run_case(c, text, folder, jobs=jobs, quiet=not progress, plots=plots and out is not None,
                       quick=quick, resume=resume and out is not None, executor=executor,
                       checkpoint=out is not None, force=force, source=source)
    run_c = c.quick_variant() if quick else c
    found = []
    if basins and c.basins is not None:
        with ctx:
            found = [run_basins(run_c, text, folder, None, jobs=jobs, executor=executor, progress=progress,
                                  resume=resume and out is not None, plots=plots and out is not None)]
    from vibeam.analysis.maps import MapResult

    maps = [r for r in res if isinstance(r, MapResult)]
    runs = [r for r in res if not isinstance(r, MapResult)]
    return _collect(run_c, folder / "results.h5", out, tmp, runs, maps, found)


def run_basins(case, text, folder, spec, jobs=None, executor=None, progress=False, resume=False, plots=True,
                 log=None):
    """Basins of ``case`` (``spec`` or its ``[basins]``) into ``folder/results.h5``
    (``/basins/<run>/``; finished rows checkpointed in ``/basin_lines``), the table printed and,
    with ``plots``, the PNGs (over the file's continuation branches).  Returns the BasinsResult."""
    from vibeam.analysis.attractors import compute, plot_basins, print_basins, write_basins

    h5 = Path(folder) / "results.h5"
    r = compute(case, jobs=jobs, executor=executor, progress=progress, spec=spec, checkpoint=h5, resume=resume,
                case_text=text)
    h5 = write_basins(h5, [r], case.name, text)
    print_basins(r)
    if plots:
        from vibeam.io.results import read_results

        branches = read_results(h5)["branches"]     # overlaid on a census (vibeam continue wrote them)
        for p in plot_basins(r, folder, branches=branches):
            print(f"plot: {p}")
    print(f"basins -> {h5} (group /basins/{r.name})")
    return r


def continuation(case, jobs: int | None = None, executor=None, out=None, quick: bool = False,
                 progress: bool = False, plots: bool = False, force: bool = False, verbose: bool = False) -> Results:
    """The continuation runs of a case alone (``vibeam continue``): branches of periodic orbits
    with their Floquet multipliers, bifurcations and two-parameter curves
    (:mod:`vibeam.analysis.branches`; pseudo-arclength continuation of the shooting problem).

    Parameters
    ----------
    case : Case, str, Path or dict
        Anything :func:`load_case` takes; at least one ``[[run]]`` with
        ``method = "continuation"``.
    jobs, executor, out, quick, progress, plots, force, verbose
        As :func:`run`.  A ``results.h5`` of the same case in ``out`` keeps its sweeps and
        maps (they are in the returned Results too); only its ``/branches`` are replaced.

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
                                verbose=verbose)
    c = load_case(case)
    text = case_text(c)
    source = str(case) if isinstance(case, (str, Path)) and _names_a_file(str(case)) else ""
    tmp = None
    if out is None:
        tmp = tempfile.TemporaryDirectory(prefix="vibeam-continue-")
        folder = Path(tmp.name)
    else:
        folder = Path(out)
    ctx = contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO())
    with ctx:
        run_case(c, text, folder, jobs=jobs, quiet=not progress, plots=plots and out is not None, quick=quick,
                 executor=executor, force=force, source=source, continuation_only=True)
    return _collect(c.quick_variant() if quick else c, folder / "results.h5", out, tmp)


# alias: ``continue`` is a Python keyword
continue_ = continuation


def open_results(path) -> Results:
    """A results file (``results.h5``) as :class:`Results`: every group (runs, maps, continuation
    branches with their bifurcations and curves, basins), each with ``to_xarray()`` and
    ``plot()``; ``res["runs/<run>"]`` is the node of the file's :class:`xarray.DataTree`.

    Raises
    ------
    ValueError
        Not a regular file, or a file of the first layout (no dimensions: convert it with
        :func:`vibeam.io.results.load_results` and :func:`vibeam.io.results.write_results`).
    """
    from vibeam.io.inputs import check_input_file
    from vibeam.io.results import LAYOUT_VERSION, layout_of

    p = check_input_file(path, "results file")
    if layout_of(p) < LAYOUT_VERSION:
        raise ValueError(f"{p}: a results file of the first layout (no dimensions); rewrite it with "
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
        ``ok``, ``chatter``, ``sticking`` or ``failed``, and the detail.
    final_state : ndarray
        The state at the end (to continue from).
    natural_frequency_hz, length_m : float or None
        Scales of a physical scene (then ``time_s``, ``U_mm``, ``dU_mm_s`` are set).
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
    state : array_like, optional
        Initial state at forcing phase 0 (default: the model's rest state): finite
        numbers, as many as the model's state.
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
        run's index or name; ``state`` finite numbers of the state's size.  Also: neither
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
                      summary=summ, status=traj.status, message=traj.message, final_state=traj.final_state,
                      natural_frequency_hz=fn, length_m=L, trajectory=traj)


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
    res = compute(c, jobs=jobs, executor=executor, progress=progress, spec=spec)
    if out is not None:
        write_basins(out, [res], c.name, case_text(c))
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


def _check_state(state, model) -> np.ndarray:
    """An initial state: finite numbers of the model's state size (TypeError/ValueError)."""
    from vibeam.errors import quote_value

    n = int(np.size(model.initial_state()))
    try:
        x = np.asarray(state, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"state = {quote_value(state)}: not numbers; allowed: {n} finite numbers") from None
    if x.shape != (n,) or not np.isfinite(x).all():
        raise ValueError(f"state = {quote_value(state)}: allowed: {n} finite numbers (the model's state)")
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
