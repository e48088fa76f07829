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

from .case import CaseError


@dataclass
class _Job:
    """One run of a case at one value of the mapped parameter (``j`` = None: no map)."""

    run: object
    spec: object
    solver: object
    sweep: object
    j: int | None = None


def _job(case, r, overrides: dict, j=None) -> _Job:
    from . import assess
    from .effects import wrap_solver
    from .models import make_solver
    from .sweep import Sweep

    spec = case.model_spec(overrides) if overrides else case.model_spec()
    model = spec.build()
    Omega = case.sweep.grid(getattr(model, "natural_frequency_hz", None))
    sw = Sweep(Omega=Omega, direction=case.sweep.direction, transient_periods=case.sweep.transient_periods,
               record_periods=case.sweep.record_periods,
               samples_per_period=assess.samples_per_period(case, r, model, Omega),
               continuation=case.sweep.continuation, period_rtol=case.sweep.period_rtol,
               assess=assess.hooks(case, spec, r, model))
    settings = dict(case.run_settings(r), **assess.solver_options(case, r, model))
    solver = wrap_solver(make_solver(model, r.method, **settings), model, spec,
                         assess.solver_effects(case.effects_for(r)), settings)
    return _Job(r, spec, solver, sw, j)


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
    except (OSError, TimeoutError) as e:
        raise CaseError(f"--scheduler {scheduler!r}: cannot connect ({e})") from None
    return client.get_executor(), client


def run_case(case, text, out_dir, jobs=None, quiet=False, plots=True, quick=False, resume=False,
             executor=None, checkpoint=True, checkpoint_interval_s=0.5, continuation_only=False):
    """Run a case: its runs, or its parameter map; write ``results.h5``, plots and a table.

    Parameters
    ----------
    case : vibeam.case.Case
    text : str
        The case file's text (stored in the results).
    out_dir : str or Path
        Output folder.
    jobs : int or None
        Workers of the local process pool (None: all cores; 1: inline).
    quiet : bool
        No progress bar.
    plots : bool
        Write the PNG plots and assessments.
    quick : bool
        Run the case's quick variant (``[quick]``).
    resume : bool
        Continue an interrupted run: the lines already in ``results.h5`` are kept.
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
    CaseError
        If ``resume`` finds a results file written by another case or variant.
    """
    from .results import append_lines, read_lines, write_results
    from .sweep import run_lines, stack, unstack

    if quick:
        case = case.quick_variant()
    case_json = case.model_dump_json()
    tasks = _tasks(case)          # planned first: a continuation the scene cannot serve fails here
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    h5 = out_dir / "results.h5"
    if continuation_only:
        return _run_continuation_only(case, text, out_dir, h5, tasks, case_json, jobs, quiet, plots, executor)
    stored = {}
    if resume and h5.exists():
        try:
            attrs, stored = read_lines(h5)
        except OSError as e:
            raise CaseError(f"--resume: cannot read {h5}: {e}") from None
        if attrs.get("case_json") != case_json:
            raise CaseError(f"--resume: {h5} was written by another case or variant; run without "
                            f"--resume to start afresh, or use another --out")
    t_all = time.perf_counter()
    jobs_ = _jobs(case)
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
            if fresh[0] and h5.exists():
                h5.unlink()          # a new run replaces an old file (use --resume to keep it)
            fresh[0] = False
            append_lines(h5, dict(buffer), case.name, text, case_json)
            buffer.clear()
        last_flush[0] = time.perf_counter()

    def on_line(line, rows):
        if hasattr(line, "compute"):      # a continuation run: kept in memory
            task_rows[line.run] = rows[0]
            return
        data = stack(rows, sweep_of[(line.run, line.key)])
        line_data[f"{line.run}/{line.key}"] = data
        buffer[f"{line.run}/{line.key}"] = data
        if time.perf_counter() - last_flush[0] >= checkpoint_interval_s:
            flush()

    try:
        run_lines(todo + tasks, executor=executor, jobs=jobs, on_line=on_line, progress=not quiet,
                  desc=case.name)
    finally:
        flush()              # on an interrupt too: every finished line is kept

    rows_of = {k: unstack(v) for k, v in line_data.items()}
    runs, maps = _assemble(case, jobs_, rows_of)
    conts = _assemble_continuation(tasks, task_rows)
    write_results(h5, runs, case.name, text, maps=maps, lines=line_data, case_json=case_json,
                  branches=conts)
    print(f"\ncase {case.name}: {len(runs) + len(maps) + len(conts)} run(s) in "
          f"{time.perf_counter() - t_all:.2f} s -> {h5}")
    if runs:
        _print_table(runs)
    if conts:
        from .branches import print_results
        print_results(conts)
    if plots:
        _plots(case, runs, maps, out_dir, conts)
    return maps if case.map else runs


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
    task_rows = {}
    done = run_lines(tasks, executor=executor, jobs=jobs, progress=not quiet, desc=case.name)
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
    print(f"\ncase {case.name}: {len(conts)} continuation run(s) in {time.perf_counter() - t_all:.2f} s -> {h5}"
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

    for r in conts:
        safe = re.sub(r"[^A-Za-z0-9_.+-]+", "_", r.name)
        if r.branches:
            p = plot_continuation(r, sweeps, out_dir / f"continuation_{safe}.png", title=f"{case.name}: {r.name}")
            print(f"continuation plot: {p}")
        if r.curves:
            p = plot_curves(r, out_dir / f"curves_{safe}.png", title=f"{case.name}: {r.name}")
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
            if job.spec.fidelity == "beam":
                res.attrs.update(_beam_attrs(job.spec))
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
    from .maps import class_agreement, plot_agreement, plot_map, print_map
    from .plots import plot_bifurcation, plot_frc

    curves = [c for c in conts if c.curves]
    for m in maps:
        print_map(m)
        safe = re.sub(r"[^A-Za-z0-9_.+-]+", "_", m.name)
        p = plot_map(m, out_dir / f"map_{safe}.png", title=case.name, curves=curves)
        print(f"map plot: {p}")
    if len(maps) > 1:
        for m in maps[1:]:
            same = class_agreement(maps[0], m)
            if same is not None:
                print(f"  {m.name} vs {maps[0].name}: classes differ at {int((~same).sum())} of {same.size} points")
        p = plot_agreement(maps, out_dir / "map_agreement.png", title=case.name)
        if p:
            print(f"map agreement plot: {p}")
    if runs:
        assess.finish(case, runs, out_dir)
        p1 = plot_frc(runs, out_dir / "frc.png", title=case.name)
        p2 = plot_bifurcation(runs, out_dir / "bifurcation.png", title=case.name)
        print(f"plots: {p1}" + (f", {p2}" if p2 else ""))
    if conts:
        _plot_continuation(case, conts, runs, out_dir)


def _print_table(runs) -> None:
    ref = runs[0]
    key = "amplitude_mm" if "amplitude_mm" in ref.data else "amplitude"
    unit = " (mm)" if key == "amplitude_mm" else ""
    head = f"{'run':<22}{'method':<12}{'points':>7}{'compute (s)':>13}{'max |dA| vs ' + ref.name + unit:>30}"
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
        print(f"{r.name:<22}{r.method:<12}{r.n_points:>7}{r.wall_time_s:>13.3f}{diff:>30}{extra}")


def _beam_attrs(spec) -> dict:
    """Calibrated and derived values of a beam scene, stored with its results."""
    from .beamscene import scene_of

    sc = scene_of(spec)
    g = sc.geometry
    out = {"EI_n_m2": g.EI_n_m2, "rotary_inertia_kg_m2": g.rotary_inertia_kg_m2,
           "rhoA_kg_m": g.rhoA_kg_m, "mass_kg": g.mass_kg, "f1_fe_hz": sc.f1_hz,
           "damping_D_s": sc.damping_D_s, "Delta_C_m": sc.Delta_C_m, "Delta_G_m": sc.Delta_G_m,
           "gamma_tilde_m_per_V": sc.gamma_tilde_m_per_V, "calibrated": sc.calibration is not None}
    if sc.calibration is not None:
        out["calibrated_frequencies_hz"] = np.asarray(sc.calibration.frequencies_hz)
    return out
