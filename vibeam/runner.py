"""Running a case: every run (and, with ``[map]``, every value of the mapped parameter) is cut
into sweep lines, all lines go to one executor through :func:`vibeam.engine.sweep.run_lines`, each
finished line is checkpointed into ``results.h5``, and the file is completed at the end.

With ``resume=True`` the lines already in the file's checkpoint are not computed again, and
the final file holds the same data as an uninterrupted run.
"""
from __future__ import annotations

import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from pydantic import ValidationError
import tqdm

from vibeam.analysis.branches import assemble, plan, plot_continuation, plot_curves, print_results
from vibeam.analysis.attractors import OUTPUT_NAMES as BASIN_PLOTS
from vibeam.analysis.maps import agreement_text, assemble_map, plot_agreement, plot_map, print_map
from vibeam.analysis.summary import print_summary
from vibeam.case.schema import Case, check_time_series
from vibeam.engine.compiling import CompileClock
from vibeam.engine import assess, sweep
from vibeam.engine.sweep import check_line, load_kernels, plan_lines, stack, unstack
from vibeam.engine.jobs import (MAX_POINT_VALUES, MAX_WORK_STEPS, Job, case_jobs, check_model_size, check_work,  # noqa: F401
                               estimate_work, file_stem, make_job, point_work)
from vibeam.errors import CaseError, InputError, one_line
from vibeam.io.results import case_hash, line_group, load_results, read_results, result_groups
from vibeam.io.store import Store
from vibeam.models.scene import outputs
from vibeam.plots.sweep import plot_bifurcation, plot_frc, plot_impacts


#: the name this module's own loops call :func:`make_job` by (a test replaces it to make points fail)
_job = make_job


def _jobs(case) -> list[Job]:
    return case_jobs(case, _job)


def _notes(case, jobs_) -> None:
    """One line per ``[assess]`` item that does not apply to a run (printed once)."""
    seen = []
    for job in jobs_:
        for msg in assess.not_applicable(case, job.run, job.spec, job.solver.time_domain):
            if msg not in seen:
                seen.append(msg)
                print(f"vibeam: note: {msg}; skipped", file=sys.stderr)


def _tasks(case) -> list:
    """The continuation runs of a case as units of work (:class:`vibeam.analysis.branches.BranchTask`)."""
    return [plan(case, r, key="continuation") for r in case.run if r.method == "continuation"]


def _lines(job: Job):
    lines = plan_lines(job.solver, job.sweep, job.run.name)
    if job.j is None:
        return lines

    return [replace(l, key=f"{job.j:04d}-{l.key}") for l in lines]


def open_executor(scheduler: str | None):
    """A dask.distributed executor for ``--scheduler ADDRESS`` (None: the local default).

    Raises
    ------
    CaseError
        If dask.distributed is not installed or the scheduler cannot be reached.
    """
    if not scheduler:
        return None, None
    try:
        # lazy: optional (the dask extra); keeps it (0.3 s) out of `vibeam run` without --scheduler
        from distributed import Client
    except ImportError:
        raise CaseError("--scheduler needs dask.distributed: pip install 'vibeam[dask]'") from None
    try:
        client = Client(scheduler, timeout="20s")
    except Exception as e:   # OSError, TimeoutError, ValueError (not an address), ...
        raise CaseError(one_line(f"--scheduler {scheduler!r}: cannot connect: {e}; give the address "
                                  f"of a dask scheduler, e.g. tcp://host:8786")) from None
    return client.get_executor(), client


def run_case(case, text, out_dir, jobs=None, quiet=False, plots=True, quick=False, resume=False,
             executor=None, checkpoint=True, checkpoint_interval_s=0.5, force=False, source="",
             continuation_only=False, store=None, fresh=False, inputs=(), announce=None):
    """Run a case: its runs, or its parameter map; write ``results.h5``, plots and a table.

    Parameters
    ----------
    case : vibeam.case.schema.Case
    text : str
        The case file's text (stored in the results).
    out_dir : str or Path
        Output folder.  Held by this process for the whole run
        (:class:`vibeam.io.outdir.OutputLock`); temporary files of killed writes
        found there are removed.
    jobs : int or None
        Workers of the local process pool (None: all cores; 1: inline).
    quiet : bool
        No progress bar (``--quiet``); and, unless ``announce`` says otherwise, no header line
        (``[case] 1 run(s), 2 sweep lines, 22 points``) and no lines about compiling kernels on
        standard error.  Errors, notes (``vibeam: note: ...``) and what a resume takes from the
        checkpoint are still said.
    plots : bool
        Write the PNG plots and assessments.
    quick : bool
        Run the case's quick variant (``[quick]``).
    resume : bool
        Continue an interrupted run: the lines already in ``results.h5`` that
        were computed for this case (same ``case_hash``) are kept.
    executor : concurrent.futures.Executor, optional
        Where lines run (e.g. ``dask.distributed.Client(...).get_executor()``);
        default a local pool of ``jobs`` workers.
    checkpoint : bool
        Append finished lines to ``results.h5`` as they finish.
    checkpoint_interval_s : float
        Lines finishing within this time of the last append are appended
        together (each line whole) at the next append, on an interrupt, or at
        the end -- so maps of many short lines do not rewrite the file per
        line; a killed process loses at most this much finished work.
    force : bool
        Run even if the estimated work is above the limit (:func:`check_work`).
    source : str
        Name of the case file, for messages.
    continuation_only : bool
        Run only the continuation runs (``vibeam continue``): only the ``/branches`` of these
        runs are replaced; the sweeps and maps of the same case are overlaid in the plots.
    store : vibeam.io.store.Store, optional
        The results store of ``out_dir`` that the calling command holds (default: one is
        opened for this call).  Every group of an existing ``results.h5`` is kept; a group of
        another case is marked stale (:mod:`vibeam.io.store`).
    fresh : bool
        Start a new results file (``--fresh``): the old file's groups are not kept.
    inputs : iterable of (path, option)
        Files the command reads (a reference): never the results file it writes.
    announce : bool, optional
        The header line and the compile lines on standard error (default: ``not quiet``; the API
        says them without a progress bar).

    Continuation runs (``method = "continuation"``) go to the same executor as the sweep
    lines, one unit of work each; they are not checkpointed (``--resume`` computes them again).

    Returns
    -------
    list
        The :class:`vibeam.engine.sweep.SweepResult` of each run, or the
        :class:`vibeam.analysis.maps.MapResult` of each mapped run (with ``continuation_only``, the
        :class:`vibeam.analysis.branches.ContinuationResult` of each continuation run).

    Raises
    ------
    InputError
        If the output folder is used by another running process or cannot be
        written, ``results.h5`` is not a regular file, ``resume`` finds a results file
        written by another case or variant or a checkpoint this vibeam would not have
        written, an input is the results file, or the work is above the limit.
    """
    if quick:
        case = case.quick_variant()
    check_model_size(case, force=force, source=source)
    try:
        jobs_ = _jobs(case)
    except CaseError as e:          # a model or solver that cannot be built: name the case file
        if source and not str(e).startswith(f"{source}: "):
            raise CaseError(f"{source}: {e}") from None
        raise
    for fn in {outputs(j.solver.scene).natural_frequency_hz for j in jobs_}:
        check_time_series(case, source, fn)
    _notes(case, jobs_)
    check_work(case, jobs_, force=force, source=source)
    tasks = _tasks(case)          # planned first: a continuation the scene cannot serve fails here
    if store is not None and Path(store.folder).resolve() != Path(out_dir).resolve():
        raise ValueError(f"run_case: the store of {store.folder} given for out_dir {out_dir}")
    silent = not announce if announce is not None else quiet
    with (store if store is not None else Store(out_dir, fresh=fresh, inputs=inputs)) as st:
        return _run_locked(case, text, st, jobs_, tasks, jobs, quiet, plots, resume, executor,
                           checkpoint, checkpoint_interval_s, continuation_only, silent)


#: the plots a run, map or continuation writes beside results.h5 (:func:`vibeam.io.outdir.check_outputs`
#: patterns; the names of the per-run ones depend on the runs)
PLOT_NAMES = ("frc.png", "bifurcation.png", "impacts.png", "map_*.png", "maps_agreement.png",
              "continuation_*.png", "curves_*.png")


def output_names(plots: bool = True, basins: bool = False) -> list:
    """The files besides ``results.h5`` and its checkpoint that :func:`run_case` (and with
    ``basins`` the basins after it) may write into the output folder: names and :mod:`fnmatch`
    patterns, for :func:`vibeam.io.outdir.check_outputs` before anything is computed.  None
    without ``plots``."""
    if not plots:
        return []
    return [*PLOT_NAMES, *assess.OUTPUT_NAMES, *(BASIN_PLOTS if basins else ())]


def same_case(stored_json, case_json: str) -> bool:
    """Whether a results file's case is the case ``case_json`` once read by this vibeam.

    Equal, or equal after validation by this vibeam's schema, which gives a key that the file's
    vibeam did not have yet its default (every other key, defaults included, is stored as it
    was run, so a changed value is still another case).

    Parameters
    ----------
    stored_json : str or None
        The file's ``case_json`` attribute (any text).
    case_json : str
        ``Case.model_dump_json()`` of the case to run.

    Returns
    -------
    bool
        False also when ``stored_json`` is None or does not validate (never raises).
    """
    if stored_json is None:
        return False
    if str(stored_json) == case_json:
        return True
    try:
        return Case.model_validate_json(str(stored_json)).model_dump_json() == case_json
    except (ValidationError, ValueError):
        return False


def case_identity(store, case_json: str) -> tuple[str, list]:
    """The case JSON a command writes under, and its aliases: a results file of an earlier
    vibeam whose stored case lacks only keys added since is the same case (:func:`same_case`),
    so the command goes on under the file's own case text and both texts name its groups
    (:meth:`vibeam.io.store.Store.commit`)."""
    root = store.info()["attrs"].get("case_json")
    if root is not None and str(root) != case_json and same_case(root, case_json):
        return str(root), [case_json]
    return case_json, []


def _unit_paths(case) -> list:
    """The units of ``results.h5`` the sweeps and maps of a case write (``runs/<run>`` or ``maps/<run>``)."""
    kind = "maps" if case.map else "runs"
    return [f"{kind}/{r.name}" for r in case.run if r.method != "continuation"]


def _run_locked(case, text, store, jobs_, tasks, jobs, quiet, plots, resume, executor, checkpoint,
                checkpoint_interval_s, continuation_only=False, silent=None):
    silent = quiet if silent is None else silent        # no header, no compile lines (--quiet)
    case_json = case.model_dump_json()
    h5 = store.path
    out_dir = store.folder
    case_json, aliases = case_identity(store, case_json)
    if continuation_only:
        return _run_continuation_only(case, text, store, tasks, case_json, jobs, quiet, plots, executor, aliases,
                                      silent)
    all_lines = [(job, l) for job in jobs_ for l in _lines(job)]
    stored = {}
    if resume:
        stored, cj = _resume_lines(store, case_json, all_lines)
        if cj != case_json:
            aliases, case_json = aliases + [case_json], cj
        if not stored:
            want = _unit_paths(case)
            if want and set(want) <= set(store.current(case_json, aliases)):
                if tasks:          # continuation runs are not checkpointed: computed again, sweeps kept
                    _run_continuation_only(case, text, store, tasks, case_json, jobs, quiet, plots, executor,
                                           aliases, silent)
                return _finished(case, store, out_dir, plots, want)
            roots = [a.get("case_json") for a in (store.checkpoint_attrs(), store.info()["attrs"]) if a]
            if roots and not any(same_case(r, case_json) for r in roots):
                raise InputError(f"--resume: {h5} was written by another case or variant; run without "
                                 f"--resume (its groups are kept, marked stale) or use another --out")
    t_all = time.perf_counter()
    task_rows: dict = {}
    line_data = {}          # "<run>/<key>" -> stacked datasets (the checkpoint)
    for job, l in all_lines:
        got = stored.get(l.run, {}).get(l.key)
        if got is not None:
            line_data[f"{l.run}/{l.key}"] = got
    todo = [l for _, l in all_lines if f"{l.run}/{l.key}" not in line_data]
    sweep_of = {(l.run, l.key): job.sweep for job, l in all_lines}
    n_pts = sum(l.n_points for _, l in all_lines)
    what = f"map of {case.map.parameter} x frequency, " if case.map else ""
    if not silent:
        print(f"[{case.name}] {what}{len(case.run)} run(s), {len(all_lines)} sweep lines, {n_pts} points"
              + (f", {len(tasks)} continuation run(s)" if tasks else "")
              + (f"; resuming: {len(all_lines) - len(todo)} lines done" if resume and stored else ""),
              file=sys.stderr)
    elif resume and stored:     # --quiet keeps what changes the work done: the lines taken from the checkpoint
        print(f"[{case.name}] resuming: {len(all_lines) - len(todo)} of {len(all_lines)} sweep lines done",
              file=sys.stderr)
    buffer: dict = {}
    last_flush = [time.perf_counter()]

    def flush():
        if checkpoint and buffer:
            # finished lines go to the checkpoint beside results.h5 (results.h5.partial), never
            # into the complete file; the first checkpoint of a run that is not resumed starts anew
            store.checkpoint("lines", {k: line_group(v, case_json) for k, v in buffer.items()},
                             case.name, text, case_json, start=not resume)
            buffer.clear()
        last_flush[0] = time.perf_counter()

    def on_line(line, rows):
        if hasattr(line, "compute"):      # a continuation run: kept in memory
            task_rows[line.run] = rows[0]
            return
        data = stack(rows, sweep_of[(line.run, line.key)])
        line_data[f"{line.run}/{line.key}"] = data
        buffer[f"{line.run}/{line.key}"] = data
        # the last line is checkpointed right after the sweeps (below), not inside the run time
        if time.perf_counter() - last_flush[0] >= checkpoint_interval_s and len(line_data) < len(all_lines):
            flush()

    timing = {"kernel_load_s": 0.0, "pool_startup_s": 0.0, "executor": "inline"}
    try:
        # continuation runs are warmed up (a cut-down run) only before a pool: inline, their
        # compile time is measured where it happens (CompileClock) and taken out of the run time
        pooled_tasks = tasks if (executor is None and jobs != 1 and len(todo) + len(tasks) > 1) else []
        said = _compile_talk(silent)
        cc = CompileClock(*said)
        if (todo or pooled_tasks) and executor is None:
            # numba kernels loaded (or compiled) once, here: a forked worker inherits them
            with CompileClock(*said) as cc:
                timing["kernel_load_s"] = load_kernels(todo + pooled_tasks)
        n_workers, why = plan_execution(case, jobs_, todo, jobs, executor) if not tasks else (jobs, "")
        t_run = last_flush[0] = time.perf_counter()
        with CompileClock(*said) as cr:
            sweep.run_lines(todo + tasks, executor=executor, jobs=n_workers, on_line=on_line, progress=not quiet,
                            desc=case.name, stats=timing, inline_first_s=2 * POOL_STARTUP_S if why else None)
        timing["run_s"] = time.perf_counter() - t_run - cr.seconds
        timing["kernel_load_s"] += cr.seconds
        if not silent:
            announce_kernels(cc.seconds + cr.seconds, f"{len(todo)} sweep line(s)"
                             + (f", {len(tasks)} continuation run(s)" if tasks else ""))
        timing["why"] = why
    finally:
        flush()              # on an interrupt too: every finished line is kept

    rows_of = {k: unstack(v) for k, v in line_data.items()}
    runs, maps = _assemble(case, jobs_, rows_of)
    conts = _assemble_continuation(tasks, task_rows)
    # the successor of results.h5: every group it had, these runs' groups replaced; the checkpoint's
    # lines are then removed (the finished file holds every point once, in /runs and /maps)
    t_w = time.perf_counter()
    store.commit(result_groups(runs, maps, conts), case.name, text, case_json, done=["lines"], aliases=aliases)
    timing["write_s"] = time.perf_counter() - t_w
    n_done = sum(l.n_points for l in todo)
    print(f"\ncase {case.name}: {len(runs) + len(maps) + len(conts)} run(s) in "
          f"{time.perf_counter() - t_all:.2f} s -> {h5}")
    if todo:
        run_s = timing["run_s"]
        print(f"run time {run_s:.3f} s for {n_done} points{' and the continuation runs' if tasks else ''}: "
              f"{1e3 * run_s / max(n_done, 1):.3g} ms per point "
              f"({timing['executor']}{': ' + timing['why'] if timing.get('why') else ''}; "
              f"pool start-up {timing['pool_startup_s']:.3f} s)\n"
              f"not in the run time: kernel load {timing['kernel_load_s']:.3f} s (numba cache or compilation, "
              f"once per process), results written in {timing['write_s']:.3f} s")
    _report(case, runs, maps, out_dir, plots, conts)
    for r in list(runs) + list(maps):
        r.attrs.setdefault("_timing", timing)
    return maps if case.map else runs


def _report(case, runs, maps, out_dir, plots, conts=()) -> None:
    """The tables (and the plots) of finished runs, maps and continuation runs."""
    if runs:
        print_summary(runs)     # timings, then the physics: peaks, period-n and status counts, jumps

    for m in maps:
        print_map(m)
    for m in maps[1:]:
        text = agreement_text(maps[0], m)
        if text is not None:
            print(f"  {text}")
    if conts:
        print_results(conts)
    if plots:
        _plots(case, runs, maps, out_dir, conts)


def _resume_lines(store, case_json: str, all_lines) -> tuple[dict, str]:
    """The finished lines of ``all_lines`` in the checkpoint, validated (``{run: {key: data}}``),
    and the case JSON they were computed for: ``case_json``, or the stored case of an earlier
    vibeam that is the same case (:func:`same_case`; the run goes on under the file's own text).

    Raises
    ------
    InputError
        A checkpointed line whose structure, shape, type or values this vibeam would not have
        written (one line naming the file and the dataset).
    """
    by_run: dict = {}
    for _, l in all_lines:
        by_run.setdefault(l.run, {})[l.key] = l

    def read(cj):
        attrs, out = {}, {}
        for run, lines in by_run.items():
            def check(key, meta, got, lines=lines):
                return check_line(meta, got, lines[key]) if key in lines else None
            attrs, got = store.read_checkpoint(f"lines/{run}", "case_hash", case_hash(cj), check)
            got = {k: v for k, v in got.items() if k in lines}
            _same_trailing(store, run, got)
            if got:
                out[run] = got
        return attrs, out

    try:
        attrs, lines = read(case_json)
        old = attrs.get("case_json")
        if not lines and old is not None and str(old) != case_json and same_case(old, case_json):
            attrs, lines = read(str(old))
            case_json = str(old) if lines else case_json
    except OSError as e:
        raise InputError(f"--resume: cannot read {store.path}: {e}") from None
    return lines, case_json


def _same_trailing(store, run: str, got: dict) -> None:
    """The per-point arrays of a run's checkpointed lines have one shape (each output's trailing
    axes depend on the run, never on the line: :func:`vibeam.engine.sweep.stack` joins them).

    Raises
    ------
    InputError
        One line naming the checkpoint, the dataset and two lines whose shapes differ.
    """
    seen: dict = {}
    for key in sorted(got):
        for k, v in got[key].items():
            sh = np.shape(v)[1:]
            if k in seen and seen[k][1] != sh:
                raise InputError(f"--resume: {store.partial}: /lines/{run}: dataset {k} has per-point shape "
                                 f"{seen[k][1]} in line {seen[k][0]} and {sh} in line {key}; this vibeam never "
                                 f"writes that: remove {store.partial.name} (or run without --resume) to compute "
                                 f"afresh")
            seen.setdefault(k, (key, sh))


def _finished(case, store, out_dir, plots, want):
    """``--resume`` of a complete run: nothing is recomputed; its runs are read back."""
    h5 = store.path
    runs, maps, _ = load_results(h5)
    runs = [r for r in runs if f"runs/{r.name}" in want]
    maps = [m for m in maps if f"maps/{m.name}" in want]
    order = {r.name: i for i, r in enumerate(case.run)}
    runs.sort(key=lambda r: order.get(r.name, len(order)))
    maps.sort(key=lambda m: order.get(m.name, len(order)))
    print(f"[{case.name}] {h5} is complete; resuming recomputes nothing", file=sys.stderr)
    print(f"\ncase {case.name}: {len(runs) + len(maps)} run(s) read from {h5}")
    _report(case, runs, maps, out_dir, plots)
    return maps if case.map else runs


# ----------------------------------------------------------------------------- execution
STEP_SECONDS = 1.1e-7
"""Wall time of one event-kernel step on one core of the development machine (2.5 us per
forcing period of 400 + 64 periods at 16 + 64 steps, ``vibeam bench``): turns
:func:`estimate_work` into seconds."""
POOL_STARTUP_S = 0.15
"""What starting the local pool costs (fork and initialise the workers, hand out the
lines, collect the rows): measured 0.05-0.15 s for 2 workers on the development machine
(``pool start-up`` in the run's report)."""


#: kernel loading above this (seconds) is announced: numba compiles them for first use
COMPILE_NOTICE_S = 1.0


_NOTICED = []


def _say(msg: str) -> None:
    try:
        tqdm.tqdm.write(msg, file=sys.stderr)  # above a progress bar, if one is drawn
    except ImportError:                        # pragma: no cover - tqdm is a dependency
        print(msg, file=sys.stderr)


def compile_notice(name: str = "", expected_s: float | None = None, source: str = "") -> None:
    """The lines said when numba starts compiling an entry point in this process, before the wait
    (:class:`vibeam.engine.compiling.CompileClock`'s ``notice``): once per process a header, then a
    line naming the entry point and the time it took the last time (on this machine, else on the
    development machine); :func:`compile_done` says what it took."""
    if not _NOTICED:
        _NOTICED.append(True)
        _say("compiling kernels for first use (numba: once per machine and vibeam version, then loaded "
             "from its cache in about a second; kept out of the run times):")
    if name and (expected_s is None or expected_s >= COMPILE_NOTICE_S):   # not the sub-second ones
        about = f", about {expected_s:.0f} s ({source})" if expected_s is not None else ""
        _say(f"  compiling {name}{about} ...")


def compile_done(name: str, seconds: float) -> None:
    """The line said when an entry point's compilation ends (those of a second and more)."""
    if seconds >= COMPILE_NOTICE_S:
        _say(f"  compiled {name} in {seconds:.1f} s")


def _compile_talk(quiet: bool) -> tuple:
    """The ``(notice, done)`` of :class:`vibeam.engine.compiling.CompileClock` for a run: the lines
    of :func:`compile_notice` and :func:`compile_done`, or none under ``--quiet``."""
    return (None, None) if quiet else (compile_notice, compile_done)


def announce_kernels(seconds: float, what: str) -> None:
    """The one line that says a first run compiled (or loaded) its kernels, and for how long,
    so that the time is not mistaken for the run's (it is kept out of every run time)."""
    if seconds >= COMPILE_NOTICE_S:
        print(f"kernels compiled or loaded for first use ({what}): {seconds:.1f} s in all, kept out of the run "
              f"times (numba caches them: later runs load them in about a second)", file=sys.stderr)


def plan_execution(case, jobs_, todo, jobs, executor) -> tuple:
    """Workers for the lines ``todo``: ``(n, why)``; ``why`` is set when the lines are to run
    inline first.

    A given executor is used as it is.  Otherwise the local pool (``jobs`` workers, None: all
    cores) is used only when it is faster: with ``n`` workers the serial time ``t``
    (:func:`estimate_work`'s ``work_min`` x :data:`STEP_SECONDS`, for the points still to
    do: the event grid's steps weighted by the stop laws' cost) becomes
    about ``POOL_STARTUP_S + t / n``, so a sweep with ``t < POOL_STARTUP_S n / (n - 1)``
    runs inline (e.g. the Fig. 7 case: 2e6 steps, ~0.2 s).  The estimate is a lower bound
    (chatter and impacts add work), so such a sweep starts inline and hands the lines left
    to the pool once it has run ``2 POOL_STARTUP_S`` (:func:`vibeam.engine.sweep.run_lines`,
    ``inline_first_s``)."""
    if executor is not None:
        return jobs, ""
    n = min(jobs or os.cpu_count() or 1, len(todo))
    if n <= 1:
        return 1, ""
    total = sum(l.n_points for j in jobs_ for l in _lines(j)) or 1
    frac = sum(l.n_points for l in todo) / total
    t = estimate_work(case, jobs_)["work_min"] * STEP_SECONDS * frac
    if t < POOL_STARTUP_S * n / (n - 1):
        return n, f"small sweep, ~{t:.2g} s on one core: inline first"
    return n, ""


def failure_summary(results) -> str | None:
    """A one-line summary when every point of every run (or map) failed, else None."""
    n = 0
    msgs = []
    for r in results or []:
        if not hasattr(r, "data"):     # a continuation run: its branches carry their own statuses
            return None
        st = np.asarray(r.data.get("status", []), dtype=object).ravel()
        if st.size == 0 or not (st == "failed").all():
            return None
        n += st.size
        msgs += [str(m) for m in np.asarray(r.data.get("message", []), dtype=object).ravel() if str(m)]
    if not n:
        return None
    common = max(set(msgs), key=msgs.count) if msgs else "no message"
    return f"every point failed ({n} points); most common reason: {common}"


def _assemble_continuation(tasks, task_rows) -> list:
    return [assemble(t, task_rows.get(t.run, dict(status="failed", message="not computed")))
            for t in tasks]


def _run_continuation_only(case, text, store, tasks, case_json, jobs, quiet, plots, executor, aliases=(),
                           silent=None):
    """``vibeam continue``: the continuation runs alone, written as ``/branches/<run>`` of the
    results file through its store (every other group kept); the sweeps of the same case are
    overlaid in the plots."""
    if not tasks:
        raise CaseError(f"{case.name}: no run has method = \"continuation\"; add a [[run]] with "
                        f"method = \"continuation\" (parameter, start, ...) or use `vibeam run`")
    h5, out_dir = store.path, store.folder
    silent = quiet if silent is None else silent
    t_all = time.perf_counter()
    if not silent:
        print(f"[{case.name}] {len(tasks)} continuation run(s)", file=sys.stderr)
    said = _compile_talk(silent)
    compiled = 0.0
    if executor is None:
        # before the progress bar (whose ETA would count the compile) and a pool: load the kernels
        # here (a cut-down run of each kind), a forked worker inherits them
        with CompileClock(*said) as cc:
            load_kernels(tasks)
        compiled += cc.seconds
    t_run = time.perf_counter()
    task_rows = {}
    with CompileClock(*said) as cr:
        done = sweep.run_lines(tasks, executor=executor, jobs=jobs, progress=not quiet, desc=case.name)
    run_s = time.perf_counter() - t_run - cr.seconds
    if not silent:
        announce_kernels(compiled + cr.seconds, f"{len(tasks)} continuation run(s)")
    for t in tasks:
        task_rows[t.run] = done[(t.run, t.key)][0]
    conts = _assemble_continuation(tasks, task_rows)
    kept = [p for p in store.info()["units"] if not p.startswith("branches/")]
    store.commit(result_groups(branches=conts), case.name, text, case_json, aliases=aliases)
    print(f"\ncase {case.name}: {len(conts)} continuation run(s) in {run_s:.2f} s "
          f"({time.perf_counter() - t_all:.2f} s with kernel loading and writing) -> {h5}"
          + (f" (the file's {len(kept)} other group(s) kept)" if kept else ""))
    print_results(conts)
    if plots:
        current = set(store.current(case_json, aliases))
        sweeps = [s for s in _stored_sweeps(h5) if f"runs/{s.name}" in current]
        _plot_continuation(case, conts, sweeps, out_dir)
    return conts


class _StoredRun:
    """A sweep run read back from a results file, for the overlays (``name``, ``data``)."""

    def __init__(self, name, data):
        self.name = name
        self.data = data


def _stored_sweeps(h5) -> list:
    res = read_results(h5)
    return [_StoredRun(k, {kk: vv for kk, vv in v.items() if kk != "attrs"}) for k, v in res["runs"].items()]


def _plot_continuation(case, conts, sweeps, out_dir, maps=()):
    scene = {r.name: dict(r.model) for r in case.run}      # each run's [run.model] overrides
    for r in conts:
        safe = file_stem(r.name)
        if r.branches:
            # the sweeps of the same scene overlaid (all of them when none is of the same scene)
            same = [s for s in sweeps if scene.get(s.name) == scene.get(r.name)] or sweeps
            p = plot_continuation(r, same, out_dir / f"continuation_{safe}.png", title=f"{case.name}: {r.name}",
                                  case=case)
            print(f"continuation plot: {p}")
        if r.curves:
            p = plot_curves(r, out_dir / f"curves_{safe}.png", title=f"{case.name}: {r.name}", case=case)
            print(f"two-parameter curves: {p}")


def _assemble(case, jobs_, rows_of):
    runs, maps = [], []
    for r in case.run:
        if r.method == "continuation":
            continue
        js = [j for j in jobs_ if j.run is r]
        if case.map is None:
            job = js[0]
            lines = _lines(job)
            line_rows = [rows_of[f"{r.name}/{l.key}"] for l in lines]
            wall = float(sum(row.get("wall_time_s", 0.0) for rs in line_rows for row in rs))
            res = sweep.assemble(job.solver, job.sweep, r.name, line_rows, wall)
            res.attrs["model"] = job.spec.as_written()
            assess.collect(case, r, res)
            res.attrs.update(getattr(job.solver, "run_attrs", {}))
            res.attrs.update(job.spec.result_attrs())
            runs.append(res)
        else:
            dirs = ["up", "down"] if case.sweep.direction == "both" else [case.sweep.direction]
            line_rows = {}
            for job in js:
                for l in _lines(job):
                    line_rows.setdefault((job.j, l.direction), []).extend(rows_of[f"{r.name}/{l.key}"])
            m = assemble_map(r.name, [j.solver for j in js], js[0].sweep, case.map.parameter,
                             case.map.grid(), dirs, line_rows)
            m.attrs["model"] = js[0].spec.as_written()
            maps.append(m)
    return runs, maps


def _plots(case, runs, maps, out_dir, conts=()):
    curves = [c for c in conts if c.curves]
    for m in maps:
        p = plot_map(m, out_dir / f"map_{file_stem(m.name)}.png", title=case.name, case=case, curves=curves)
        print(f"map plot: {p}")
    if len(maps) > 1:
        # "maps_" never begins a per-run plot ("map_<run>.png"), so no run name can collide with it
        p = plot_agreement(maps, out_dir / "maps_agreement.png", title=case.name, case=case)
        if p:
            print(f"map agreement plot: {p}")
    if runs:
        assess.finish(case, runs, out_dir)
        p1 = plot_frc(runs, out_dir / "frc.png", title=case.name, case=case)
        p2 = plot_bifurcation(runs, out_dir / "bifurcation.png", title=case.name, case=case)
        p3 = plot_impacts(runs, out_dir / "impacts.png", title=case.name, case=case)   # two-sided runs only
        print(f"plots: {p1}" + (f", {p2}" if p2 else "") + (f", {p3}" if p3 else ""))
    if conts:
        _plot_continuation(case, conts, runs, out_dir)
