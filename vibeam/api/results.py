"""What a case produced, as the API returns it: :class:`Results` (every group of ``results.h5``,
each with ``to_xarray()`` and ``plot()``) and :func:`open_results` (a results file)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vibeam.analysis.attractors import (BasinsResult, basins_figure, basins_from_dataset, basins_group,
                                        census_figure, read_basins)
from vibeam.analysis.branches import ContinuationResult, continuation_figure, curves_figure, read_continuation
from vibeam.analysis.maps import agreement_figure, map_figure
from vibeam.analysis.uncertainty import (UncertaintyResult, bands, outcome_entries, read_uncertainty, sobol_entries,
                                         uncertainty_group)
from vibeam.api.cases import case_text, load_case, remember
from vibeam.api.common import PrivateFolder, saved
from vibeam.case.schema import Case
from vibeam.engine.assess import participation_figure, spectra_figure, time_series_figure
from vibeam.errors import InputError
from vibeam.io.h5check import open_checked
from vibeam.io.inputs import check_input_file
from vibeam.io.objects import MapResult, SweepResult
from vibeam.io.results import LAYOUT_VERSION, branch_name, layout_of, load_results, result_groups
from vibeam.io.store import write_file
from vibeam.plots.sweep import bifurcation_figure, frc_figure
from vibeam.plots.uncertainty import band_figure, outcome_figure, sobol_figure


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
        kind = {"runs": "Run", "maps": "Map", "branches": "Branches", "basins": "Basins",
                "uncertainty": "Uncertainty"}.get(
            self._kind, type(self).__name__.lstrip("_"))
        return f"{kind}({self.name!r}: {self.group}, {self._sizes()})"


def _as(cls, obj, owner):
    """``obj`` (a dataclass instance) as the API's subclass ``cls``, bound to ``owner``."""
    if not isinstance(obj, cls):
        obj = cls(**{f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)})
    return obj._bind(owner)


class Run(SweepResult, _Group):
    """One ``[[run]]`` (:class:`vibeam.engine.sweep.SweepResult`: per-point arrays in
    ``.data``, visiting order); group ``runs/<name>`` on (direction, Omega)."""

    _kind = "runs"
    __repr__ = _Group.__repr__

    def plot(self, path=None, kind: str = "frc"):
        """The run's FRC (``kind="frc"``) or bifurcation diagram (``"bifurcation"``)."""
        fig = {"frc": frc_figure, "bifurcation": bifurcation_figure}[kind]
        r = self._results()
        return saved(fig([self], title=r._title(), case=r.case), path)


class Map(MapResult, _Group):
    """One run of a ``[map]`` (:class:`vibeam.analysis.maps.MapResult`); group ``maps/<name>``
    on (direction, <parameter>, Omega)."""

    _kind = "maps"
    __repr__ = _Group.__repr__

    def _sizes(self):
        return f"{self.parameter} x frequency, {_Group._sizes(self)}"

    def plot(self, path=None):
        """The class map (paper Fig. 18), with the two-parameter curves of the case."""
        r = self._results()
        return saved(map_figure(self, title=r._title(), case=r.case,
                                 curves=[b for b in r.branches if b.curves]), path)


class Branches(ContinuationResult, _Group):
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
        r = self._results()
        scene = {x.name: dict(x.model) for x in getattr(r.case, "run", [])}
        same = [s for s in r.runs if scene.get(s.name) == scene.get(self.name)] or r.runs
        return saved(continuation_figure(self, same, title=f"{r._title()}: {self.name}", case=r.case), path)


class Basins(BasinsResult, _Group):
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
        r = self._results()
        if i is None and len(self.Omega) > 1:
            br = {b.name: _branch_dicts(b) for b in r.branches}
            return saved(census_figure(self, r._title(), br), path)
        return saved(basins_figure(self, i or 0, r._title()), path)


class Uncertainty(UncertaintyResult, _Group):
    """The sampled sweeps of one run of ``[uncertainty]``
    (:class:`vibeam.analysis.uncertainty.UncertaintyResult`: the design, every sample's amplitude,
    period and status, the statistics); group ``uncertainty/<name>`` on (sample, direction, Omega),
    (quantile | outcome | bound | parameter, direction, Omega)."""

    _kind = "uncertainty"
    __repr__ = _Group.__repr__

    def _sizes(self):
        n, nd, nO = self.amplitude.shape
        return f"{int(self.base.sum())} samples of {', '.join(self.parameters)}, {nd} x {nO} points"

    def plot(self, path=None, kind: str = "bands"):
        """The FRC band (``kind="bands"``: median, 50 % and 90 % bands), the Sobol' indices against
        frequency (``"sobol"``; None without Saltelli's design) or the outcome probabilities against
        frequency (``"outcomes"``) of this run."""
        return self._results().plot_uncertainty(path, kind=kind, names=[self.name])


def _branch_dicts(b) -> dict:
    """A continuation run in the shape of :func:`vibeam.io.results.read_branch_group` (what the
    census figure overlays)."""
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
        r = self._results()
        return saved(curves_figure(self.run, title=f"{r._title()}: {self.name}", case=r.case), path)


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
    uncertainty : list of Uncertainty
        The sampled sweeps of ``[uncertainty]``, one per run (:func:`vibeam.uncertainty`;
        :class:`vibeam.analysis.uncertainty.UncertaintyResult`), each with ``to_xarray()`` and
        ``plot(kind="bands" | "sobol" | "outcomes")``.

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
    uncertainty: list = field(default_factory=list)

    def __repr__(self) -> str:
        """The groups by kind with their names and sizes (never their arrays), e.g.
        ``Results('paper-fig7', path='results.h5', runs: 'exact' (202 points, 25 variables);
        maps: none; branches: none; basins: none)``."""
        name = getattr(self.case, "name", None)
        parts = [repr(name) if name else "case unknown", f"path={str(self.path)!r}" if self.path else "in memory"]
        for kind in ("runs", "maps", "branches", "basins") + (("uncertainty",) if self.uncertainty else ()):
            gs = getattr(self, kind)
            parts.append(f"{kind}: " + (", ".join(f"{g.name!r} ({g._sizes()})" for g in gs) if gs else "none"))
        return "Results(" + ", ".join(parts[:2]) + "; " + "; ".join(parts[2:]) + ")"

    def __post_init__(self):
        self.runs = [_as(Run, r, self) for r in self.runs]
        self.maps = [_as(Map, m, self) for m in self.maps]
        self.branches = [_as(Branches, b, self) for b in self.branches]
        self.basins = [_as(Basins, b, self) for b in self.basins]
        self.uncertainty = [_as(Uncertainty, u, self) for u in self.uncertainty]
        self._tree = None
        self._file = None        # a file holding the groups (self.path, or a private temporary one)
        self._tmp = None

    @classmethod
    def from_file(cls, path) -> "Results":
        """Every group of a results file (``results.h5``): runs, maps, continuation branches
        (with bifurcations and curves), basins and the sampled sweeps of ``[uncertainty]``."""
        check_input_file(path, "results file")
        runs, maps, attrs = load_results(path)
        case = None
        try:                   # the case as run (e.g. its quick variant), else the case file's text
            if attrs.get("case_json"):
                case = remember(Case.model_validate_json(str(attrs["case_json"])), str(attrs.get("case_text", "")))
            elif attrs.get("case_text"):
                case = load_case(str(attrs["case_text"]))
        except Exception:      # a case of an older vibeam: the data are still readable
            case = None
        branches, basins, unc = [], [], []
        if layout_of(path) >= 2:
            branches = read_continuation(path)
            with open_checked(path) as f:
                names = list(f.get("basins", {}))
            basins = [basins_from_dataset(read_basins(path, n), n) for n in names]
            unc = read_uncertainty(path)
        return cls(runs, maps, case, Path(path), branches, basins, unc)

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
        ``basins/<run>``, ``uncertainty/<run>``."""
        out = {}
        for g in self.runs + self.maps + self.branches:
            out[g.group] = g
        for g in self.bifurcations + self.curves + self.basins + self.uncertainty:
            out[g.group] = g
        return out

    def _h5(self) -> Path:
        """A file holding every group: the results file, or one written once to a private
        temporary folder (removed with this object)."""
        if self.path is not None and Path(self.path).is_file():
            return Path(self.path)
        if self._file is not None and Path(self._file).is_file():
            return self._file

        self._tmp = PrivateFolder("vibeam-results-")
        name = getattr(self.case, "name", "")
        text = case_text(self.case) if self.case is not None else ""
        cj = self.case.model_dump_json() if self.case is not None else ""
        groups = result_groups(self.runs, self.maps, self.branches)
        groups.update({f"basins/{b.name}": basins_group(b) for b in self.basins})
        groups.update({f"uncertainty/{u.name}": uncertainty_group(u) for u in self.uncertainty})
        f = write_file(Path(self._tmp.name) / "results.h5", groups, name, text, cj)
        self._file = f
        return f

    def tree(self):
        """Every group as one :class:`xarray.DataTree`, loaded in memory (``tree["runs/<run>"]``,
        ``tree["branches/<run>/bifurcations"]``, ...)."""
        if self._tree is None:
            # xarray (with pandas, 0.5 s) only when labelled data are asked for: open_results and
            # the plots do without it
            import xarray as xr  # lazy: xarray (with pandas: 0.35 s) loads only when labelled data are asked for

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
        return saved(frc_figure(self.runs, title=self._title(), case=self.case), path)

    def plot_bifurcation(self, path=None):
        """Bifurcation diagram (stroboscopic samples) of the time-domain runs; None without any."""
        return saved(bifurcation_figure(self.runs, title=self._title(), case=self.case), path)

    def plot_map(self, name: str | None = None, path=None):
        """Class map of one map run (default the first; paper Fig. 18)."""
        m = self[name] if name else self.maps[0]
        return m.plot(path)

    def plot_agreement(self, path=None):
        """Where the maps' classes differ from the first map's; None with fewer than two maps."""
        return saved(agreement_figure(self.maps, title=self._title(), case=self.case), path)

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

    def plot_uncertainty(self, path=None, kind: str = "bands", names=None):
        """The figures of ``vibeam uncertainty`` over the runs (default all; ``names`` some): the FRC
        bands of a ladder overlaid (``kind="bands"``, ``uncertainty.png``), the Sobol' indices against
        frequency (``"sobol"``, ``uncertainty_sobol.png``; None without Saltelli's design) or the
        outcome probabilities against frequency (``"outcomes"``, ``uncertainty_outcomes.png``).

        Raises
        ------
        ValueError
            ``kind`` not one of bands, sobol, outcomes.
        """
        figures = {"bands": (band_figure, bands, "FRC bands"), "sobol": (sobol_figure, sobol_entries, "Sobol' indices"),
                   "outcomes": (outcome_figure, outcome_entries, "outcome probabilities")}
        if kind not in figures:
            raise ValueError(f"kind = {kind!r}: allowed: {', '.join(figures)}")
        fig, data, what = figures[kind]
        us = [u for u in self.uncertainty if names is None or u.name in names]
        return saved(fig(data(us), title=f"{self._title()}: {what}"), path)

    def plot_spectra(self, path=None):
        """Sensor velocity spectra against the forcing frequency (``[assess] spectra``)."""
        return saved(spectra_figure(self.runs, self._title(), case=self.case), path)

    def plot_time_series(self, label, path=None):
        """Time series and phase portrait at the grid frequency ``label`` (``[assess] time_series``)."""
        return saved(time_series_figure(self.runs, label, self._title(), case=self.case), path)

    def plot_participation(self, path=None):
        """Modal shares in the sensor displacement and the energy (``[assess] participation``)."""
        return saved(participation_figure(self.runs, self._title(), case=self.case), path)


def open_results(path) -> Results:
    """A results file (``results.h5``) as :class:`Results`: every group (runs, maps, continuation
    branches with their bifurcations and curves, basins, uncertainty), each with ``to_xarray()`` and
    ``plot()``; ``res["runs/<run>"]`` is the node of the file's :class:`xarray.DataTree`.

    Raises
    ------
    vibeam.errors.InputError (a ValueError)
        One line naming the file: not a regular file, not an HDF5 file, an HDF5 file that is
        not a vibeam results file (no ``vibeam_layout``, no runs, maps, branches or basins), or a
        file of the first layout (no dimensions: convert it with
        :func:`vibeam.io.results.load_results` and :func:`vibeam.io.results.write_results`).
    """
    p = check_input_file(path, "results file")
    with open_checked(p) as f:
        layout = f.attrs.get("vibeam_layout")
        groups = [g for g in ("runs", "maps", "branches", "basins", "uncertainty") if g in f]
    if layout is None and not groups:
        raise InputError(f"{p}: not a vibeam results file (an HDF5 file without vibeam_layout and without runs, "
                         f"maps, branches, basins or uncertainty); allowed: a results.h5 written by vibeam")
    if int(layout if layout is not None else 1) < LAYOUT_VERSION:
        raise InputError(f"{p}: a results file of the first layout (no dimensions); rewrite it with "
                         f"vibeam.io.results.load_results and write_results")
    return Results.from_file(p)
