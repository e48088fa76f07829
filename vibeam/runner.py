"""Running a case: every run (and, with ``[map]``, every value of the mapped parameter) is cut
into sweep lines, all lines go to one executor through :func:`vibeam.sweep.run_lines`, each
finished line is checkpointed into ``results.h5``, and the file is completed at the end.

With ``resume=True`` the lines already in the file's checkpoint are not computed again, and
the final file holds the same data as an uninterrupted run.
"""
from __future__ import annotations

import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .compiling import CompileClock
from .errors import CaseError


@dataclass
class _Job:
    """One run of a case at one value of the mapped parameter (``j`` = None: no map)."""

    run: object
    spec: object
    solver: object
    sweep: object
    j: int | None = None


def make_job(case, r, overrides: dict, j=None) -> _Job:
    """The job of run ``r`` of ``case`` with the model keys ``overrides`` (map value ``j``): its
    model spec, its solver with effects and hooks, and its sweep."""
    from . import assess
    from .effects import wrap_solver
    from .models import make_solver
    from .sweep import Sweep

    spec = case.model_spec(overrides) if overrides else case.model_spec()
    model = spec.build()
    Omega = case.sweep.grid(getattr(model, "natural_frequency_hz", None))
    sw = Sweep(Omega=Omega, **dict(case.sweep.engine_options(),
                                   samples_per_period=assess.samples_per_period(case, r, model, Omega),
                                   assess=assess.hooks(case, spec, r, model)))
    settings = dict(case.run_settings(r), **assess.solver_options(case, r, model))
    try:
        base = make_solver(model, r.method, **settings)
    except ValueError as e:         # a value the method's solver cannot take: bad input, one line
        from .errors import one_line

        where = f" at {', '.join(f'{k} = {v!r}' for k, v in overrides.items())}" if overrides else ""
        raise CaseError(one_line(f"'run[{case.run.index(r)}].method' = {r.method!r}{where}: {e}")) from None
    solver = wrap_solver(base, model, spec, assess.solver_effects(case.effects_for(r)), settings)
    return _Job(r, spec, solver, sw, j)


#: the name this module's own loops call :func:`make_job` by (a test replaces it to make points fail)
_job = make_job


def _jobs(case) -> list[_Job]:
    out = []
    for r in case.run:
        if r.method == "continuation":
            continue              # a BranchTask, see _tasks
        if case.map is None:
            out.append(_job(case, r, dict(r.model)))
        else:
            for j, v in enumerate(case.map.grid()):
                out.append(_job(case, r, dict(r.model, **{case.map.parameter: float(v)}), j))
    return out


def _notes(case, jobs_) -> None:
    """One line per ``[assess]`` item that does not apply to a run (printed once)."""
    from . import assess

    seen = []
    for job in jobs_:
        for msg in assess.not_applicable(case, job.run, job.solver.model, job.solver.time_domain):
            if msg not in seen:
                seen.append(msg)
                print(f"vibeam: note: {msg}; skipped", file=sys.stderr)


def file_stem(name: str) -> str:
    """A run name as part of a file name (``map_<stem>.png``): characters other than letters,
    digits and ``_.+-`` become ``_``.  Case validation refuses two runs with the same stem."""
    return re.sub(r"[^A-Za-z0-9_.+-]+", "_", name)


def _tasks(case) -> list:
    """The continuation runs of a case as units of work (:class:`vibeam.branches.BranchTask`)."""
    from .branches import plan

    return [plan(case, r, key="continuation") for r in case.run if r.method == "continuation"]


def _lines(job: _Job):
    from .sweep import plan_lines

    lines = plan_lines(job.solver, job.sweep, job.run.name)
    if job.j is None:
        return lines
    from dataclasses import replace

    return [replace(l, key=f"{job.j:04d}-{l.key}") for l in lines]


# ----------------------------------------------------------------------------- work limit
MAX_WORK_STEPS = 1e11
"""Refuse a case whose estimated work exceeds this many event-kernel steps (``--force``
overrides).  One step of the SDOF event kernel costs about 0.1 us on one core of the
development machine (2.5 us per forcing period of 400 + 64 periods at 16 + 64 steps), so
the limit is a few hours on one core; the largest shipped case (``rig-map-gap``) needs
8e7 steps."""
MAX_POINT_VALUES = 1e8
"""Refuse a case whose one point would record more than this many floats (0.8 GB)."""
ODE_STEP_COST = 1000.0
"""Cost of a period of the ``solve_ivp`` methods over one of ``event`` (measured ~700x,
``vibeam bench``), applied per step of the event grid."""
_STEPS_PER_NATURAL_PERIOD = 16     # the event kernels' sub-steps: below 1/16 of a natural period


def _dofs(spec) -> int:
    """Degrees of freedom simulated by a model spec (1 for the SDOF and the static mode)."""
    return int(spec.dofs())


def _contact_steps(model, Omega, spec=None):
    """Steps per forcing period that a compliant stop adds, or None (Newton's law, a beam).

    The contact phase is stepped at 1/16 of its own natural period ``2 pi / sqrt(1 + k_c)``
    (:mod:`vibeam.models.sdof_compliant`), so its cost grows with the contact stiffness:
    ``16 sqrt(1 + k_c) / (2 pi)`` steps per unit of time in contact.  A stop at or inside the
    rest position (``Delta <= 0``) holds the mass for about half of each forcing period
    (``8 sqrt(1 + k_c) / Omega`` steps); a stop with a gap is met in impacts of half a contact
    period (8 steps each, one per period counted).  Returns ``(steps, key, value)``, steps of
    the shape of ``Omega``, with the case key that sets the stiffness."""
    law = getattr(model, "contact", None)
    k = getattr(law, "stiffness", None)
    if k is None or getattr(model, "fidelity", "") != "sdof":
        return None
    w = np.sqrt(1.0 + float(k))
    steps = 8.0 * w / Omega if float(model.Delta) <= 0.0 else np.full(np.shape(Omega), 8.0)
    table = getattr(spec, "contact", None)
    if table is not None and getattr(table, "stiffness", None) is None and table.stiffness_n_m is not None:
        return steps, "model.contact.stiffness_n_m", float(table.stiffness_n_m)
    return steps, "model.contact.stiffness", float(k)


def estimate_work(case, jobs_=None) -> dict:
    """Estimate what a case costs before running it.

    Per point of a time-domain run, the event kernels step a fixed grid:
    ``max(samples, 16 / Omega)`` steps per forcing period (``samples`` =
    ``transient_samples`` in the transient, ``samples_per_period`` in the record;
    the kernel sub-steps below 1/16 of the natural period 2 pi, so a forcing
    period at small Omega costs 16 / Omega steps), plus the steps of a compliant stop's
    contact phase, which is stepped at 1/16 of the contact's period ``2 pi / sqrt(1 + k_c)``
    (:func:`_contact_steps`; the SDOF's stiffness ratio ``k_c``).  Scales that double precision
    cannot carry (a subnormal ``B``, a stiffness beyond 1e20) are refused by case validation
    before this (:data:`vibeam.case.B_RANGE`, :data:`vibeam.case.MAX_CONTACT_STIFFNESS`).  The work is the sum over
    points, directions, runs and map values of ``transient x steps + record x
    steps``, times the retained modes for the FE beam and :data:`ODE_STEP_COST`
    for the ``solve_ivp`` methods (``averaging`` and ``mapping`` count one step
    per point).  It is a lower bound: chatter, impacts and high modes add to it.

    Parameters
    ----------
    case : vibeam.case.Case
        The case as run (e.g. its quick variant).
    jobs_ : list, optional
        Its jobs (:func:`_jobs`), to reuse their grids; built if not given.

    Returns
    -------
    dict
        ``steps`` (float), ``point_values`` (most floats recorded by one point),
        and ``culprit`` ``(key, value)``: the case key that contributes most
        beyond a usual case (101 points, 400 + 64 periods, 64 samples, Omega >= 1,
        one mode, the event method, one map value).
    """
    jobs_ = _jobs(case) if jobs_ is None else jobs_
    sw = case.sweep
    grid_key = "sweep.Omega" if sw.Omega is not None else "sweep.frequency_hz"
    n_dir = 2 if sw.direction == "both" else 1
    steps = steps_min = 0.0
    point_values = 0.0
    w_min = np.inf
    worst_modes, worst_cost = (None, 1), (None, 1.0)
    worst_contact = (None, None, 0.0)
    for job in jobs_:
        r = job.run
        Om = np.abs(np.asarray(job.sweep.Omega, float))
        Om = Om[Om > 0] if (Om > 0).any() else np.array([1e-300])
        Om = np.maximum(Om, 1e-300)     # a subnormal Omega: 16 / Omega stays finite, the estimate huge
        w_min = min(w_min, float(Om.min()))
        dofs = _dofs(job.spec)
        if r.method in ("averaging", "mapping"):
            steps += n_dir * Om.size
            steps_min += n_dir * Om.size
            continue
        ts = getattr(r, "transient_samples", 16)
        spp = job.sweep.samples_per_period
        sub = _STEPS_PER_NATURAL_PERIOD / Om
        con = _contact_steps(job.solver.model, Om, job.spec)
        if con is not None and float(np.max(con[0])) > worst_contact[2]:
            worst_contact = (con[1], con[2], float(np.max(con[0])))
        con = 0.0 if con is None else con[0]
        n_tr = job.sweep.max_transient_periods if job.sweep.auto else job.sweep.transient_periods
        n_rec = max(job.sweep.record_periods, job.sweep.statistics_periods)   # a non-periodic point's window
        # the Lyapunov spectrum's shots: one event run each, with its tangent (counted twice)
        n_ly = 2 * int(getattr(job.sweep, "lyapunov_shots", 0))
        per = (n_tr * (np.maximum(ts, sub) + con) + n_rec * (np.maximum(spp, sub) + con)
               + n_ly * (np.maximum(ts, sub) + con))
        cost = ODE_STEP_COST if r.method in ("direct", "zhuravlev", "ivanov") else 1.0
        steps += n_dir * float(per.sum()) * dofs * cost
        per_min = (n_tr * (np.maximum(ts, sub) + con) + job.sweep.record_periods * (np.maximum(spp, sub) + con)
                   + n_ly * (np.maximum(ts, sub) + con))
        steps_min += n_dir * float(per_min.sum()) * dofs * cost
        point_values = max(point_values, n_rec * spp * 2.0 * (1 + dofs))
        i = case.run.index(r)
        if dofs > worst_modes[1]:
            worst_modes = (f"run[{i}].model.n_modes" if "n_modes" in r.model else "model.n_modes", dofs)
        if cost > worst_cost[1]:
            worst_cost = (f"run[{i}].method", cost)
    n_pts = len(sw.grid(1.0))
    auto = sw.transient_periods == "auto"
    n_tr = sw.max_transient_periods if auto else sw.transient_periods
    tr_key = "sweep.max_transient_periods" if auto else "sweep.transient_periods"
    rec_key, n_rec = max(("sweep.record_periods", sw.record_periods),
                         ("sweep.statistics_periods", sw.statistics_periods), key=lambda c: c[1])
    periods = n_tr + n_rec
    cands = [
        ((tr_key if n_tr >= n_rec else rec_key), (n_tr if n_tr >= n_rec else n_rec), periods / 464),
        (grid_key, getattr(sw, grid_key.split(".")[1]), max(n_pts / 101, 1.0 / max(w_min, 1e-300))),
        ("sweep.samples_per_period", sw.samples_per_period, sw.samples_per_period / 64),
        ("map.values", case.map.values if case.map else None, len(case.map.grid()) if case.map else 0),
        (worst_modes[0], worst_modes[1], worst_modes[1]),
        (worst_cost[0], None, worst_cost[1]),
        (worst_contact[0], worst_contact[1], worst_contact[2] / 64.0),
    ]
    key, val, _ = max((c for c in cands if c[0]), key=lambda c: c[2])
    if key.endswith(".method"):
        val = case.run[int(key[4:key.index("]")])].method
    return {"steps": steps, "steps_min": steps_min, "point_values": point_values, "culprit": (key, val)}


def point_work(Omega: float, transient_periods: int, record_periods: int, samples_per_period: int,
               dofs: int = 1, method: str = "event", transient_samples: int = 16, model=None) -> dict:
    """The work of one time-domain point as :func:`estimate_work` counts it (its per-point
    term, with a compliant stop's contact steps of ``model``): ``steps`` and
    ``point_values``, for a point simulated outside a case's sweep (:func:`vibeam.api.simulate`
    with a model), checked against the same limits."""
    Om = max(float(Omega), 1e-300)
    sub = _STEPS_PER_NATURAL_PERIOD / Om
    con = _contact_steps(model, np.array([Om])) if model is not None else None
    con = float(con[0][0]) if con is not None else 0.0
    cost = ODE_STEP_COST if method in ("direct", "zhuravlev", "ivanov") else 1.0
    steps = (transient_periods * (max(transient_samples, sub) + con)
             + record_periods * (max(samples_per_period, sub) + con))
    return {"steps": float(steps) * dofs * cost,
            "point_values": float(record_periods) * samples_per_period * 2.0 * (1 + dofs)}


def check_work(case, jobs_=None, force: bool = False, source: str = "") -> dict:
    """Refuse a case whose work (:func:`estimate_work`) exceeds :data:`MAX_WORK_STEPS` or whose
    one point records more than :data:`MAX_POINT_VALUES` floats, unless ``force``.

    Raises
    ------
    InputError
        Naming the key that contributes most, its value, the estimate and the limit.
    """
    from .errors import InputError, quote_value

    with np.errstate(over="ignore"):      # an estimate beyond 1e308 is inf: refused, without a warning line
        w = estimate_work(case, jobs_)
    if force:
        return w
    where = f"{source}: " if source else ""
    if w["point_values"] > MAX_POINT_VALUES:
        sw = case.sweep
        rec_key, n_rec = max(("record_periods", sw.record_periods), ("statistics_periods", sw.statistics_periods),
                             key=lambda c: c[1])
        raise InputError(f"{where}'sweep.{rec_key}' = {n_rec}: one point would record "
                         f"{w['point_values']:.3g} values (limit {MAX_POINT_VALUES:.0e}, "
                         f"{MAX_POINT_VALUES * 8 / 1e9:.1f} GB); record fewer periods or samples, or pass --force")
    if w["steps"] > MAX_WORK_STEPS:
        key, val = w["culprit"]
        hours = w["steps"] * 1e-7 / 3600
        raise InputError(f"{where}'{key}' = {quote_value(val)}: the case needs about {w['steps']:.2g} solver steps "
                         f"(~{hours:.3g} h on one core), above the limit of {MAX_WORK_STEPS:.0e}; "
                         f"reduce it, or pass --force to run anyway")
    return w


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
        from distributed import Client
    except ImportError:
        raise CaseError("--scheduler needs dask.distributed: pip install 'vibeam[dask]'") from None
    try:
        client = Client(scheduler, timeout="20s")
    except Exception as e:   # OSError, TimeoutError, ValueError (not an address), ...
        from .errors import one_line

        raise CaseError(one_line(f"--scheduler {scheduler!r}: cannot connect: {e}; give the address "
                                  f"of a dask scheduler, e.g. tcp://host:8786")) from None
    return client.get_executor(), client


def run_case(case, text, out_dir, jobs=None, quiet=False, plots=True, quick=False, resume=False,
             executor=None, checkpoint=True, checkpoint_interval_s=0.5, force=False, source="",
             continuation_only=False):
    """Run a case: its runs, or its parameter map; write ``results.h5``, plots and a table.

    Parameters
    ----------
    case : vibeam.case.Case
    text : str
        The case file's text (stored in the results).
    out_dir : str or Path
        Output folder.  Held by this process for the whole run
        (:class:`vibeam.outdir.OutputLock`); temporary files of killed writes
        found there are removed.
    jobs : int or None
        Workers of the local process pool (None: all cores; 1: inline).
    quiet : bool
        No progress bar.
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
        Run only the continuation runs (``vibeam continue``): an existing ``results.h5`` of the
        same case keeps its sweeps and maps (and they are overlaid in the plots); only its
        ``/branches`` are replaced.

    Continuation runs (``method = "continuation"``) go to the same executor as the sweep
    lines, one unit of work each; they are not checkpointed (``--resume`` computes them again).

    Returns
    -------
    list
        The :class:`vibeam.sweep.SweepResult` of each run, or the
        :class:`vibeam.maps.MapResult` of each mapped run (with ``continuation_only``, the
        :class:`vibeam.branches.ContinuationResult` of each continuation run).

    Raises
    ------
    InputError
        If the output folder is used by another running process or cannot be
        written, ``results.h5`` is not a file, ``resume`` finds a results file
        written by another case or variant, or the work is above the limit.
    """
    from .outdir import OutputLock

    from .case import check_time_series

    if quick:
        case = case.quick_variant()
    try:
        jobs_ = _jobs(case)
    except CaseError as e:          # a model or solver that cannot be built: name the case file
        if source and not str(e).startswith(f"{source}: "):
            raise CaseError(f"{source}: {e}") from None
        raise
    for fn in {getattr(j.solver.model, "natural_frequency_hz", None) for j in jobs_}:
        check_time_series(case, source, fn)
    _notes(case, jobs_)
    check_work(case, jobs_, force=force, source=source)
    tasks = _tasks(case)          # planned first: a continuation the scene cannot serve fails here
    with OutputLock(out_dir):
        return _run_locked(case, text, Path(out_dir), jobs_, tasks, jobs, quiet, plots, resume, executor,
                           checkpoint, checkpoint_interval_s, continuation_only)


def _run_locked(case, text, out_dir, jobs_, tasks, jobs, quiet, plots, resume, executor, checkpoint,
                checkpoint_interval_s, continuation_only=False):
    from .errors import InputError
    from .errors import ForeignFileError
    from .results import append_lines, read_lines, write_results
    from .sweep import run_lines, stack, unstack

    case_json = case.model_dump_json()
    h5 = out_dir / "results.h5"
    if h5.exists() and not h5.is_file():
        raise InputError(f"{h5} is not a file (a folder?); remove it or use another --out")
    if continuation_only:
        return _run_continuation_only(case, text, out_dir, h5, tasks, case_json, jobs, quiet, plots, executor)
    stored = {}
    if resume and h5.exists():
        try:
            attrs, stored = read_lines(h5, case_json=case_json)
        except OSError as e:
            raise InputError(f"--resume: cannot read {h5}: {e}") from None
        if attrs.get("case_json") != case_json:
            raise InputError(f"--resume: {h5} was written by another case or variant; run without "
                             f"--resume to start afresh, or use another --out")
        if attrs.get("complete") and not stored:
            if tasks:              # continuation runs are not checkpointed: computed again, sweeps kept
                _run_continuation_only(case, text, out_dir, h5, tasks, case_json, jobs, quiet, plots, executor)
            return _finished(case, h5, out_dir, plots)
    t_all = time.perf_counter()
    all_lines = [(job, l) for job in jobs_ for l in _lines(job)]
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
    print(f"[{case.name}] {what}{len(case.run)} run(s), {len(all_lines)} sweep lines, {n_pts} points"
          + (f", {len(tasks)} continuation run(s)" if tasks else "")
          + (f"; resuming: {len(all_lines) - len(todo)} lines done" if resume and stored else ""),
          file=sys.stderr)
    fresh = [not (resume and h5.exists())]
    buffer: dict = {}
    last_flush = [time.perf_counter()]

    def flush():
        if checkpoint and buffer:
            try:
                # the first checkpoint of a new run is a new file, renamed over an old one only
                # once it is complete: a failed write leaves the old file as it was
                append_lines(h5, dict(buffer), case.name, text, case_json, fresh=fresh[0])
            except ForeignFileError as e:
                raise InputError(str(e)) from None
            fresh[0] = False
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
        cc = CompileClock()
        if (todo or pooled_tasks) and executor is None:
            # numba kernels loaded (or compiled) once, here: a forked worker inherits them
            with CompileClock() as cc:
                timing["kernel_load_s"] = load_kernels(todo + pooled_tasks)
        n_workers, why = plan_execution(case, jobs_, todo, jobs, executor) if not tasks else (jobs, "")
        t_run = last_flush[0] = time.perf_counter()
        with CompileClock() as cr:
            run_lines(todo + tasks, executor=executor, jobs=n_workers, on_line=on_line, progress=not quiet,
                      desc=case.name, stats=timing, inline_first_s=2 * POOL_STARTUP_S if why else None)
        timing["run_s"] = time.perf_counter() - t_run - cr.seconds
        timing["kernel_load_s"] += cr.seconds
        announce_kernels(cc.seconds + cr.seconds, f"{len(todo)} sweep line(s)"
                         + (f", {len(tasks)} continuation run(s)" if tasks else ""))
        timing["why"] = why
    finally:
        flush()              # on an interrupt too: every finished line is kept

    rows_of = {k: unstack(v) for k, v in line_data.items()}
    runs, maps = _assemble(case, jobs_, rows_of)
    conts = _assemble_continuation(tasks, task_rows)
    # the checkpoint lines are compacted: the finished file holds every point once (/runs, /maps)
    t_w = time.perf_counter()
    write_results(h5, runs, case.name, text, maps=maps, case_json=case_json, branches=conts)
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
        _print_table(runs)
    from .maps import class_agreement, print_map

    for m in maps:
        print_map(m)
    for m in maps[1:]:
        same = class_agreement(maps[0], m)
        if same is not None:
            print(f"  {m.name} vs {maps[0].name}: classes differ at {int((~same).sum())} of {same.size} points")
    if conts:
        from .branches import print_results

        print_results(conts)
    if plots:
        _plots(case, runs, maps, out_dir, conts)


def _finished(case, h5, out_dir, plots):
    """``--resume`` of a complete file: nothing is recomputed; its runs are read back."""
    from .results import load_results

    runs, maps, _ = load_results(h5)
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


def load_kernels(lines) -> float:
    """Load (or compile) the numba kernels of the lines' solvers in this process, once per
    solver class: one short call each (two forcing periods, at the line's first frequency).
    Returns the seconds it took.  Forked pool workers inherit the loaded kernels, so a
    sweep's run time holds neither a cache load per worker nor a compilation per worker.
    A call that fails is ignored (the sweep records the failure where it happens)."""
    t0 = time.perf_counter()
    seen = set()
    for l in lines:
        if hasattr(l, "warm_up"):          # a continuation run: a cut-down run of the same kind
            sp = getattr(l, "spec", None)
            key = ("task", getattr(sp, "fidelity", ""), str(getattr(sp, "contact", None)),
                   str(getattr(sp, "contact_lower", None)), l.parameter == "Omega")
            if key not in seen:
                seen.add(key)
                l.warm_up()
            continue
        s = getattr(l, "solver", None)
        if s is None:
            continue
        inner = getattr(s, "solver", None)
        key = (type(s), type(inner), getattr(s, "name", ""), getattr(getattr(s, "model", None), "fidelity", ""))
        if key in seen:
            continue
        seen.add(key)
        try:
            s.point(float(l.Omega[0]), None, 1, 1, 16)
        except Exception:
            pass
    return time.perf_counter() - t0


#: kernel loading above this (seconds) is announced: numba compiles them for first use
COMPILE_NOTICE_S = 1.0


def announce_kernels(seconds: float, what: str) -> None:
    """The one line that says a first run compiled (or loaded) its kernels, and for how long,
    so that the time is not mistaken for the run's (it is kept out of every run time)."""
    if seconds >= COMPILE_NOTICE_S:
        print(f"compiling kernels for first use ({what}): {seconds:.1f} s, kept out of the run times "
              f"(numba caches them: later runs load them in about a second)", file=sys.stderr)


def plan_execution(case, jobs_, todo, jobs, executor) -> tuple:
    """Workers for the lines ``todo``: ``(n, why)``; ``why`` is set when the lines are to run
    inline first.

    A given executor is used as it is.  Otherwise the local pool (``jobs`` workers, None: all
    cores) is used only when it is faster: with ``n`` workers the serial time ``t``
    (:func:`estimate_work` x :data:`STEP_SECONDS`, for the points still to do) becomes
    about ``POOL_STARTUP_S + t / n``, so a sweep with ``t < POOL_STARTUP_S n / (n - 1)``
    runs inline (e.g. the Fig. 7 case: 2e6 steps, ~0.2 s).  The estimate is a lower bound
    (chatter and impacts add work), so such a sweep starts inline and hands the lines left
    to the pool once it has run ``2 POOL_STARTUP_S`` (:func:`vibeam.sweep.run_lines`,
    ``inline_first_s``)."""
    import os

    if executor is not None:
        return jobs, ""
    n = min(jobs or os.cpu_count() or 1, len(todo))
    if n <= 1:
        return 1, ""
    total = sum(l.n_points for j in jobs_ for l in _lines(j)) or 1
    frac = sum(l.n_points for l in todo) / total
    t = estimate_work(case, jobs_)["steps_min"] * STEP_SECONDS * frac
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
    from .branches import assemble

    return [assemble(t, task_rows.get(t.run, dict(status="failed", message="not computed")))
            for t in tasks]


def _run_continuation_only(case, text, out_dir, h5, tasks, case_json, jobs, quiet, plots, executor):
    """``vibeam continue``: the continuation runs alone; an existing results file of the same case
    keeps its sweeps and maps (overlaid in the plots), its ``/branches`` are replaced."""
    from .branches import print_results
    from .results import read_results, replace_branches, write_results
    from .sweep import run_lines

    if not tasks:
        raise CaseError(f"{case.name}: no run has method = \"continuation\"; add a [[run]] with "
                        f"method = \"continuation\" (parameter, start, ...) or use `vibeam run`")
    t_all = time.perf_counter()
    print(f"[{case.name}] {len(tasks)} continuation run(s)", file=sys.stderr)
    compiled = 0.0
    if executor is None and jobs != 1 and len(tasks) > 1:
        # before a pool: load the kernels here, a forked worker inherits them
        with CompileClock() as cc:
            load_kernels(tasks)
        compiled += cc.seconds
    t_run = time.perf_counter()
    task_rows = {}
    with CompileClock() as cr:
        done = run_lines(tasks, executor=executor, jobs=jobs, progress=not quiet, desc=case.name)
    run_s = time.perf_counter() - t_run - cr.seconds
    announce_kernels(compiled + cr.seconds, f"{len(tasks)} continuation run(s)")
    for t in tasks:
        task_rows[t.run] = done[(t.run, t.key)][0]
    conts = _assemble_continuation(tasks, task_rows)
    same = False
    if h5.exists():
        try:
            same = read_results(h5)["attrs"].get("case_json") == case_json
        except OSError:
            same = False
    if same:
        replace_branches(h5, conts)
    else:
        write_results(h5, [], case.name, text, case_json=case_json, branches=conts)
    print(f"\ncase {case.name}: {len(conts)} continuation run(s) in {run_s:.2f} s "
          f"({time.perf_counter() - t_all:.2f} s with kernel loading and writing) -> {h5}"
          + (" (sweeps and maps of the file kept)" if same else ""))
    print_results(conts)
    if plots:
        sweeps = _stored_sweeps(h5) if same else []
        _plot_continuation(case, conts, sweeps, out_dir)
    return conts


class _StoredRun:
    """A sweep run read back from a results file, for the overlays (``name``, ``data``)."""

    def __init__(self, name, data):
        self.name = name
        self.data = data


def _stored_sweeps(h5) -> list:
    from .results import read_results

    res = read_results(h5)
    return [_StoredRun(k, {kk: vv for kk, vv in v.items() if kk != "attrs"}) for k, v in res["runs"].items()]


def _plot_continuation(case, conts, sweeps, out_dir, maps=()):
    from .branches import plot_continuation, plot_curves

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
    from . import assess
    from .maps import assemble_map
    from .sweep import assemble

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
            res = assemble(job.solver, job.sweep, r.name, line_rows, wall)
            res.attrs["model"] = job.spec.model_dump()
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
            m.attrs["model"] = js[0].spec.model_dump()
            maps.append(m)
    return runs, maps


def _plots(case, runs, maps, out_dir, conts=()):
    from . import assess
    from .maps import plot_agreement, plot_map
    from .plots import plot_bifurcation, plot_frc, plot_impacts

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


def _print_table(runs) -> None:
    ref = runs[0]
    key = "amplitude_mm" if "amplitude_mm" in ref.data else "amplitude"
    unit = " (mm)" if key == "amplitude_mm" else ""
    wn = max([22] + [len(r.name) + 2 for r in runs])          # columns as wide as the longest name
    wm = max([12] + [len(r.method) + 2 for r in runs])
    wd = max(30, len('max |dA| vs ' + ref.name + unit) + 2)
    head = f"{'run':<{wn}}{'method':<{wm}}{'points':>7}{'compute (s)':>13}{'max |dA| vs ' + ref.name + unit:>{wd}}"
    print(head)
    print("-" * len(head))
    for r in runs:
        if r is ref:
            diff = "reference"
        elif key in r.data and len(r.data[key]) == len(ref.data[key]) and \
                np.allclose(r.data["Omega"], ref.data["Omega"]):
            d = np.abs(np.asarray(r.data[key], float) - np.asarray(ref.data[key], float))
            diff = f"{np.nanmax(d):.3e}" if np.isfinite(d).any() else "n/a"
        else:
            diff = "n/a (different grid)"
        n_bad = int(sum(1 for s in r.data.get("status", []) if s != "ok"))
        extra = f"  [{n_bad} point(s) not ok]" if n_bad else ""
        print(f"{r.name:<{wn}}{r.method:<{wm}}{r.n_points:>7}{r.wall_time_s:>13.3f}{diff:>{wd}}{extra}")
