"""Computations of a case into results, as ``vibeam run``, ``continue`` and ``basins``: :func:`run`,
:func:`continuation` (``continue_``), :func:`basins` and :func:`run_basins` (the command's basins
into its results store)."""
from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np
from pydantic import ValidationError

from vibeam.analysis import attractors     # by the module: its compute may be replaced (tests)
from vibeam.analysis.branches import read_continuation
from vibeam.analysis.maps import MapResult
from vibeam.api.cases import case_text, load_case, names_a_file
from vibeam.api.common import PrivateFolder, check_run_args
from vibeam.api.results import Results
from vibeam.case.schema import BasinsSpec, validation_message
from vibeam.errors import CaseError
from vibeam.io.outdir import check_outputs
from vibeam.io.results import read_results
from vibeam.io.store import Store, current_units
from vibeam.runner import case_identity, run_case


def _collect(case, h5: Path, out, tmp, runs=None, maps=None, basins=()) -> Results:
    """The Results of a run into ``h5``: the runs and maps in memory (as computed), the
    continuation branches read back from the file (every group, nothing dropped)."""
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
    jobs, out = check_run_args(jobs, out, executor, quick=quick, progress=progress, plots=plots, resume=resume,
                                force=force, verbose=verbose, basins=basins, fresh=fresh)
    if fresh and resume:
        raise ValueError("fresh = True and resume = True: choose one (fresh starts a new results file, resume "
                         "continues the checkpoint of an interrupted run)")
    c = load_case(case)
    text = case_text(c)
    source = str(case) if isinstance(case, (str, Path)) and names_a_file(str(case)) else ""
    ctx = contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO())
    tmp = None
    if out is None:
        tmp = PrivateFolder("vibeam-run-")
        folder = Path(tmp.name)
    else:
        folder = Path(out)

    run_c = c.quick_variant() if quick else c
    found = []
    # one results store for the whole call: the sweeps, then the [basins], under one lock
    with ctx, Store(folder, fresh=fresh) as store:
        res = run_case(c, text, folder, jobs=jobs, quiet=not progress, announce=True, plots=plots and out is not None,
                       quick=quick, resume=resume and out is not None, executor=executor,
                       checkpoint=out is not None, force=force, source=source, store=store)
        if basins and c.basins is not None:
            found = [run_basins(run_c, text, folder, None, jobs=jobs, executor=executor, progress=progress,
                                resume=resume and out is not None, plots=plots and out is not None, store=store)]

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
    with (store if store is not None else Store(folder)) as st:
        if plots:                         # every name written, checked before anything is computed
            check_outputs(folder, attractors.OUTPUT_NAMES)
        r = attractors.compute(case, jobs=jobs, executor=executor, progress=progress, spec=spec, checkpoint=st,
                               resume=resume, case_text=text)
        cj, aliases = case_identity(st, case.model_dump_json())
        h5 = attractors.write_basins(st, [r], case.name, text, cj, aliases)
        attractors.print_basins(r)
        if plots:
            current = set(st.current(cj, aliases))
            branches = {k: v for k, v in read_results(h5)["branches"].items() if f"branches/{k}" in current}
            for p in attractors.plot_basins(r, folder, branches=branches):   # over the branches `vibeam continue` wrote
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
    jobs, out = check_run_args(jobs, out, executor, quick=quick, progress=progress, plots=plots, force=force,
                                verbose=verbose, fresh=fresh)
    c = load_case(case)
    text = case_text(c)
    source = str(case) if isinstance(case, (str, Path)) and names_a_file(str(case)) else ""
    tmp = None
    if out is None:
        tmp = PrivateFolder("vibeam-continue-")
        folder = Path(tmp.name)
    else:
        folder = Path(out)
    ctx = contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO())
    with ctx:
        run_case(c, text, folder, jobs=jobs, quiet=not progress, announce=True, plots=plots and out is not None,
                 quick=quick, executor=executor, force=force, source=source, continuation_only=True, fresh=fresh)
    return _collect(c.quick_variant() if quick else c, folder / "results.h5", out, tmp)


# alias: ``continue`` is a Python keyword
continue_ = continuation


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

    try:
        spec = BasinsSpec.model_validate(data)
    except ValidationError as e:
        raise CaseError(validation_message(e, "basins", BasinsSpec)) from None
    if out is None:
        return attractors.compute(c, jobs=jobs, executor=executor, progress=progress, spec=spec)

    out = Path(out)
    with Store(out.parent, out.name) as st:       # the file's folder held for the computation and the write
        res = attractors.compute(c, jobs=jobs, executor=executor, progress=progress, spec=spec)
        cj, aliases = case_identity(st, c.model_dump_json())
        attractors.write_basins(st, [res], c.name, case_text(c), cj, aliases)
    return res
