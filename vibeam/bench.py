"""``vibeam bench``: the speed goal of the exact solver, as machine-readable JSON.

On the paper's Fig. 7 scene (beta 0.015, B 0.5e-3, R 0.9, Delta 0; Omega from
1.5 to 2.5) it times a sweep of ``points`` frequencies with
``transient + record = periods`` forcing periods per point, for

* ``event`` (exact, numba; timed after a warm-up call, median of repeats), and
* ``direct`` (scipy ``solve_ivp`` with events at the paper's tolerances:
  RK23, rtol 1e-4, atol 1e-8),

both inline in one process, and measures each one's amplitude error against a
converged reference: ``event`` with ``reference_periods`` transient periods
(the transient decays as exp(-beta t); 3000 periods leave < 1e-60 of it, so
the reference is exact to round-off).  It prints ratios, never asserts them.

``--map`` instead measures map throughput on 1 and 2 workers and the cost of the
line checkpoint (:func:`run_map_bench`); ``--effects`` instead times each scene effect (:func:`run_effects_bench`);
``--continuation`` instead times the continuation of a period-1 branch through its fold and
grazing and compares its cost per FRC point with a sweep of equal accuracy
(:func:`run_continuation_bench`, JSON key ``sdof``), and the same for the beam with all modes
of the shipped rig (:func:`run_beam_continuation_bench`, key ``beam``);
``--shooting`` instead measures the beam's periodic-orbit shots and Newton solves against
the event solver (:func:`run_shooting_bench`); ``--scaling`` instead measures how the cost of a sweep grows with the periods
simulated and with the retained modes of the FE beam, with fitted exponents
(:func:`run_scaling_bench`); ``--fit`` instead times ``vibeam fit`` against its goal
(:func:`run_fit_bench`); ``--latency`` instead measures how fast Ctrl-C stops an inline and a
pooled run and how far a point overshoots its wall-time limit (:func:`run_latency_bench`);
``--compile`` instead measures the cold and warm numba compile time of shipped scenarios (the quick
start, a compliant SDOF point, FE points, continuations), per kernel specialisation (the event
integrator's for Newton stops only and with compliant stops) and per compiled function, in fresh
processes with an empty ``NUMBA_CACHE_DIR`` (:func:`run_compile_bench`).
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np


def _sweep(model, method, Omega, n_transient, n_record, **settings):
    from vibeam.models import make_solver
    from vibeam.engine.sweep import Sweep, run_sweep

    sw = Sweep(Omega=Omega, direction="up", transient_periods=n_transient, record_periods=n_record,
               continuation=False)
    t0 = time.perf_counter()
    res = run_sweep(make_solver(model, method, **settings), sw, jobs=1)
    return time.perf_counter() - t0, res


def run_bench(points: int = 101, periods: int = 500, record: int = 64, repeats: int = 5,
              reference_periods: int = 3000, direct_points: int | None = None) -> dict:
    """Measure the ratios of the speed goal; returns a JSON-ready dict.

    Parameters
    ----------
    points : int
        Frequencies in the sweep.
    periods : int
        Forcing periods per point (transient + recorded).
    record : int
        Recorded periods per point.
    repeats : int
        Repeats of the event sweep (median reported).
    reference_periods : int
        Transient periods of the converged reference.
    direct_points : int, optional
        Time ``direct`` on this many evenly spread points only and scale its
        time to ``points`` (for a quick look); default: the full sweep.
    """
    from vibeam.models import SDOF

    model = SDOF(beta=0.015, B=0.5e-3, R=0.9, Delta=0.0)
    Omega = np.linspace(1.5, 2.5, points)
    n_tr = periods - record
    _sweep(model, "event", Omega[:2], 2, 2)  # warm-up (compilation / cache load)
    times, cpus = [], []
    for _ in range(repeats):
        c0 = time.process_time()
        t, ev = _sweep(model, "event", Omega, n_tr, record)
        cpus.append(time.process_time() - c0)
        times.append(t)
    t_event = statistics.median(times)
    # the same sweep integrating every period (the exact recurrence off: the same
    # outputs bit for bit, so its time is the kernel's cost per impact actually integrated)
    full = []
    for _ in range(repeats):
        t, ev_full = _sweep(model, "event", Omega, n_tr, record, recurrence=False)
        full.append(t)
    t_full = statistics.median(full)
    same = all(np.array_equal(ev.data[k], ev_full.data[k], equal_nan=True)
               for k in ("amplitude", "impacts_per_period", "impact_velocity", "strobe"))
    _, ref = _sweep(model, "event", Omega, reference_periods, record)
    A_ref = ref.data["amplitude"]
    idx = np.arange(points) if direct_points is None else \
        np.unique(np.linspace(0, points - 1, direct_points).round().astype(int))
    t_direct, di = _sweep(model, "direct", Omega[idx], n_tr, record, solver="RK23", rtol=1e-4, atol=1e-8)
    t_direct_full = t_direct * points / len(idx)
    scale = np.max(np.abs(A_ref))
    err_event = float(np.max(np.abs(ev.data["amplitude"] - A_ref)) / scale)
    err_direct = float(np.nanmax(np.abs(di.data["amplitude"] - A_ref[idx])) / scale)
    n_imp = float(np.sum(ev.data["impacts_per_period"]) * periods)
    return {
        "scene": "paper-fig7 (beta 0.015, B 0.5e-3, R 0.9, Delta 0)",
        "points": points, "periods_per_point": periods,
        "event_time_s": t_event,
        "direct_time_s": t_direct_full,
        "direct_points_timed": int(len(idx)),
        "speedup_event_vs_direct": t_direct_full / t_event,
        "event_error": err_event,
        "direct_error": err_direct,
        "error_ratio_direct_over_event": err_direct / max(err_event, 1e-300),
        "event_impacts_per_second": n_imp / t_event,
        "event_us_per_impact": 1e6 * t_event / max(n_imp, 1.0),
        "event_cpu_time_s": statistics.median(cpus),
        "event_us_per_impact_cpu": 1e6 * statistics.median(cpus) / max(n_imp, 1.0),
        "event_time_every_period_s": t_full,
        "event_us_per_impact_every_period": 1e6 * t_full / max(n_imp, 1.0),
        "recurrence_speedup": t_full / t_event,
        "recurrence_outputs_identical": bool(same),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "error_measure": "max |Q - Q_ref| / max Q_ref over the sweep; Q_ref from event with "
                         f"{reference_periods} transient periods",
        "goal": "event sweep well under 1 s, >= 300x faster than direct, >= 1000x smaller error",
    }


#: effects timed by :func:`run_effects_bench` (name, [effects] table, fidelities)
EFFECTS_BENCH = (
    ("platform filter", {"platform": {"frequency_hz": 3.25, "damping_ratio": 0.05}}, ("sdof", "beam")),
    ("platform coupled", {"platform": {"level": "coupled", "mass_kg": 2.0}}, ("beam",)),
    ("eccentric_impact", {"eccentric_impact": {"offset_mm": 5.0}}, ("beam",)),
    ("gap_drift table", {"gap_drift": {"table": [[14.0, 0.0], [15.0, 0.0], [15.2, 0.05], [17.0, 0.06]]}},
     ("sdof", "beam")),
    ("gap_drift sliding", {"gap_drift": {"law": "sliding", "slide_mm_per_impulse": 0.3, "max_drift_mm": 0.1}},
     ("sdof", "beam")),
    ("restitution_law", {"restitution_law": {"velocity_mm_s": [0.0, 30.0, 100.0, 150.0],
                                             "R": [0.85, 0.6, 0.75, 0.8]}}, ("sdof", "beam")),
)


def run_effects_bench(points: int = 61, transient: int = 400, record: int = 64, repeats: int = 3) -> dict:
    """Cost of each scene effect: a rig sweep (14-17 Hz, both directions, continuation,
    inline) of the SDOF scene ``rig-neutral`` and of the FE scene ``rig-fe-neutral`` with 2
    modes, plain and with each effect on; median of ``repeats`` after a warm-up, as ratios
    to plain.  Returns a JSON-ready dict."""
    from pathlib import Path

    from vibeam.case.schema import EffectsSpec, load_case
    from vibeam.engine.effects import wrap_solver
    from vibeam.models import make_solver
    from vibeam.engine.sweep import Sweep, run_sweep

    root = Path(__file__).resolve().parent.parent / "cases"
    scenes = {"sdof": ("rig-neutral.toml", None), "beam": ("rig-fe-neutral.toml", {"n_modes": 2})}
    out = {"points": points, "transient_periods": transient, "record_periods": record,
           "direction": "both", "repeats": repeats, "scenes": {}}
    for fid, (fname, over) in scenes.items():
        case, _ = load_case(root / fname)
        spec = case.model_spec(over)
        model = spec.build()
        f_n = model.natural_frequency_hz
        grid = np.linspace(case.sweep.frequency_hz[0], case.sweep.frequency_hz[1], points) / f_n
        sw = Sweep(Omega=grid, direction="both", transient_periods=transient, record_periods=record)

        def timed(effects):
            solver = wrap_solver(make_solver(model, "event"), model, spec, EffectsSpec.model_validate(effects), {})
            run_sweep(solver, Sweep(Omega=grid[:2], transient_periods=2, record_periods=2), jobs=1)  # warm-up
            ts = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                run_sweep(solver, sw, jobs=1)
                ts.append(time.perf_counter() - t0)
            return statistics.median(ts)

        t_plain = timed({})
        row = {"case": fname + (f" (n_modes = {over['n_modes']})" if over else ""), "plain_time_s": t_plain,
               "time_s": {}, "ratio_to_plain": {}}
        for name, eff, fids in EFFECTS_BENCH:
            if fid not in fids:
                continue
            t = timed(eff)
            row["time_s"][name] = t
            row["ratio_to_plain"][name] = t / t_plain
        out["scenes"][fid] = row
    return out


# ----------------------------------------------------------------------------- goals
def goal(text: str, measured: str, ok: bool, not_checked: str = "") -> dict:
    """One stated goal of a benchmark and its verdict (in the JSON, and printed by
    :func:`print_verdicts`): ``pass`` True or False, or None with ``not_checked`` saying why
    when the benchmark did not run in the goal's configuration (``--points 21`` against a
    101-point goal): such a measurement neither passes nor fails it."""
    if not_checked:
        return {"goal": text, "measured": measured, "pass": None, "not_checked": not_checked}
    return {"goal": text, "measured": measured, "pass": bool(ok)}


def verdict_word(g: dict) -> str:
    """``PASS``, ``FAIL`` or ``NOT CHECKED`` of a :func:`goal`."""
    return "NOT CHECKED" if g.get("pass") is None else ("PASS" if g["pass"] else "FAIL")


def print_verdicts(mode: str, goals: list) -> None:
    """``vibeam bench MODE: PASS|FAIL|NOT CHECKED goal (measured)`` on stderr, one line per goal
    (stdout keeps the JSON); a goal not checked says why."""
    for g in goals:
        why = f"; {g['not_checked']}" if g.get("pass") is None else ""
        print(f"vibeam bench{' ' + mode if mode else ''}: {verdict_word(g)}  {g['goal']}  "
              f"(measured: {g['measured']}{why})", file=sys.stderr)


#: the configuration of the default benchmark's time goal (``--points``, ``--periods``)
GOAL_POINTS, GOAL_PERIODS = 101, 500


def bench_goals(out: dict) -> list:
    """The speed goal of the exact solver (:func:`run_bench`).  The time goal holds for
    :data:`GOAL_POINTS` points x :data:`GOAL_PERIODS` periods only: another configuration leaves
    it NOT CHECKED (the ratios per point and per impact are checked at any size)."""
    pts, per = out.get("points", GOAL_POINTS), out.get("periods_per_point", GOAL_PERIODS)
    other = ("" if (pts, per) == (GOAL_POINTS, GOAL_PERIODS) else
             f"not the goal's configuration: {pts} points x {per} periods (the goal: --points {GOAL_POINTS} "
             f"--periods {GOAL_PERIODS})")
    return [goal(f"event sweep well under 1 s ({GOAL_POINTS} points x {GOAL_PERIODS} periods, one core)",
                 f"{out['event_time_s']:.3f} s for {pts} points x {per} periods", out["event_time_s"] < 1.0,
                 not_checked=other),
            goal(">= 300x faster than direct (solve_ivp RK23, rtol 1e-4, atol 1e-8, with events)",
                 f"{out['speedup_event_vs_direct']:.0f}x", out["speedup_event_vs_direct"] >= 300),
            goal(">= 1000x smaller amplitude error than direct",
                 f"{out['error_ratio_direct_over_event']:.3g}x", out["error_ratio_direct_over_event"] >= 1000),
            goal("event kernel <= 1 us per impact (issue 20; the whole sweep's time over its impacts)",
                 f"{out['event_us_per_impact']:.2f} us ({out['event_impacts_per_second']:.3g} impacts/s; "
                 f"{out['event_us_per_impact_cpu']:.2f} us of CPU time; "
                 f"{out['event_us_per_impact_every_period']:.2f} us integrating every period, the "
                 f"exact recurrence off: {out['recurrence_speedup']:.2f}x, outputs identical: "
                 f"{out['recurrence_outputs_identical']})",
                 out["event_us_per_impact"] <= 1.0)]


# ----------------------------------------------------------------------------- the command line
def _direct_time_per_period(points: int, periods: int = 500, record: int = 64, case: str | None = None) -> dict:
    """Seconds per point and forcing period of ``direct`` (solve_ivp RK23, rtol 1e-4, atol 1e-8,
    with events) on ``points`` frequencies spread over the case's grid (Fig. 7 scene),
    ``periods - record`` transient periods each, from rest (inline, one core)."""
    from vibeam.case.schema import load_case

    case, _ = load_case(case or _root() / "cases" / "paper-fig7.toml")
    model = case.model_spec().build()
    grid = case.sweep.grid(getattr(model, "natural_frequency_hz", None))
    Om = np.linspace(grid.min(), grid.max(), points)
    t, res = _sweep(model, "direct", Om, periods - record, record, solver="RK23", rtol=1e-4, atol=1e-8)
    return {"time_s": t, "points": points, "periods_per_point": periods, "s_per_point_period": t / (points * periods),
            "failed": int(np.sum(res.data["status"] == "failed"))}


def _root():
    from pathlib import Path

    return Path(__file__).resolve().parent.parent


def run_cli_bench(case: str | None = None, repeats: int = 3, direct_points: int = 11, goal_ratio: float = 300.0,
                  log=None) -> dict:
    """The kernel's speed as ``vibeam run`` shows it: the CLI on the Fig. 7 case (101 points,
    up and down, 400 + 64 periods per point) in a fresh process each time, its own reported
    run time (sweeps only: the numba kernel load and the results file are reported apart),
    against ``direct`` (scipy solve_ivp RK23, rtol 1e-4, atol 1e-8, with events) timed inline
    on ``direct_points`` points of the same scene with 500 periods each.

    Both are compared per point and forcing period (the CLI's points have 464 periods, the
    direct ones 500).  Returns a JSON-ready dict with the ratio (median CLI run), the ratio
    with the kernel load included, and the verdict against ``goal_ratio``; asserts nothing.
    """
    import re
    import subprocess
    import tempfile

    from vibeam.case.schema import load_case

    path = str(case or _root() / "cases" / "paper-fig7.toml")
    c, _ = load_case(path)
    periods = c.sweep.transient_periods + c.sweep.record_periods
    say = log or (lambda m: None)
    runs = []
    for i in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            p = subprocess.run([sys.executable, "-m", "vibeam.cli", "run", path, "--out", tmp, "--no-plots",
                                "--quiet"], capture_output=True, text=True)
            wall = time.perf_counter() - t0
        if p.returncode != 0:
            raise RuntimeError(f"vibeam run {path} exited {p.returncode}: {p.stderr.strip()[-300:]}")
        m = re.search(r"run time ([\d.]+) s for (\d+) points", p.stdout)
        k = re.search(r"kernel load ([\d.]+) s", p.stdout)
        ex = re.search(r"ms per point \(([^;]*)", p.stdout)
        runs.append({"run_time_s": float(m.group(1)), "points": int(m.group(2)),
                     "kernel_load_s": float(k.group(1)) if k else float("nan"),
                     "executor": ex.group(1) if ex else "", "process_wall_s": wall})
        say(f"vibeam run {Path(path).name}: run time {runs[-1]['run_time_s']:.3f} s, kernel load "
            f"{runs[-1]['kernel_load_s']:.3f} s, process {wall:.2f} s")
    med = sorted(runs, key=lambda r: r["run_time_s"])[len(runs) // 2]
    say(f"direct RK23 on {direct_points} points x 500 periods...")
    d = _direct_time_per_period(direct_points, case=path)
    cli_pp = med["run_time_s"] / (med["points"] * periods)
    cli_pp_load = (med["run_time_s"] + med["kernel_load_s"]) / (med["points"] * periods)
    ratio = d["s_per_point_period"] / cli_pp
    out = {"case": path, "cli_runs": runs, "cli_points": med["points"], "cli_periods_per_point": periods,
           "cli_run_time_s": med["run_time_s"], "cli_s_per_point_period": cli_pp,
           "cli_ms_per_point": 1e3 * med["run_time_s"] / med["points"],
           "direct": d, "direct_s_per_point_period": d["s_per_point_period"],
           "speedup_cli_vs_direct_per_point": ratio,
           "speedup_including_kernel_load": d["s_per_point_period"] / cli_pp_load,
           "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
           "note": "per point and forcing period; the CLI's run time is what `vibeam run` prints (the sweeps, "
                   "pool start-up included); its kernel load (numba cache, once per process) and results "
                   "writing are printed apart and not in it"}
    out["goals"] = [goal(f">= {goal_ratio:g}x faster per point than direct RK23 (rtol 1e-4, atol 1e-8, events), "
                         f"through `vibeam run`'s reported run time",
                         f"{ratio:.0f}x ({out['cli_ms_per_point']:.2f} ms per point of {periods} periods; "
                         f"{out['speedup_including_kernel_load']:.0f}x with the kernel load)", ratio >= goal_ratio)]
    return out


CONTINUATION_GOAL_S = 0.1   # issue 10: ~500-point SDOF branch with stability, after warm-up


def _sweep_at_equal_accuracy(solver, Delta, grid, Q_ref, transients, target_error, log):
    """The laboratory sweep a continuation replaces: ``solver`` over ``grid`` (Omega, state
    carried from point to point) with more and more transient periods until every amplitude
    ``Delta - min q`` agrees with the exact branch values ``Q_ref`` (shape of ``grid``) to the
    relative ``target_error``.  Returns the rows (one per transient) and the first row that
    reaches the target (None if none does)."""
    rows = []
    for n_tr in transients:
        t0 = time.perf_counter()
        state = None
        Q = np.empty_like(grid)
        for i, W in enumerate(grid):
            tr = solver.point(W, state, n_tr, 1, 8)
            state = tr.final_state
            Q[i] = Delta - tr.q_min
        ts = time.perf_counter() - t0
        err = float(np.max(np.abs(Q - Q_ref) / Q_ref))
        rows.append(dict(transient_periods=n_tr, time_s=ts, time_per_point_s=ts / len(grid), max_rel_error=err))
        log(f"sweep with {n_tr} transient periods: max rel. error {err:.2e}, {ts:.3f} s")
        if err <= target_error:
            break
    return rows, next((r for r in rows if r["max_rel_error"] <= target_error), None)


def run_continuation_bench(repeats: int = 5, sweep_points: int = 41, target_error: float = 1e-8,
                           log=None) -> dict:
    """Speed of the continuation against its goal and against the sweep it replaces.

    Scene: paper Fig. 8 (beta 0.015, B 0.5e-3, R 0.9, Delta 0.7e-3), Omega 1.5 .. 2.5: the
    period-1 branch from the impacting orbit at 1.5 up to its fold (1.985), back on its
    unstable part to the grazing (1.870) and on the non-impacting orbit to 2.5, with Floquet
    multipliers at every point and the fold and grazing located.  Timed inline after a warm-up,
    median of ``repeats``; the verdict compares it with :data:`CONTINUATION_GOAL_S` (a number,
    not an assertion).

    Equal accuracy: the stable impacting part (Omega 1.5 .. 1.98) is swept by the ``event``
    solver as a laboratory sweep (``sweep_points`` frequencies, continuation from point to
    point) with more and more transient periods until every amplitude agrees with the
    branch to ``target_error`` (relative; the branch points are exact to that, see
    ``tests/test_continuation.py``); the cost per point of that sweep is set against the cost
    per point of the continuation.  The unstable part has no sweep counterpart at any cost.
    """
    from vibeam.models import SDOF, EventSolver
    from vibeam.models.continuation import Settings, trace
    from vibeam.models.periodic_sdof import SDOFShooting

    log = log or (lambda m: None)
    m = SDOF(beta=0.015, B=0.5e-3, R=0.9, Delta=0.7e-3)
    prob = SDOFShooting(m)
    x0 = EventSolver(m).point(1.5, None, 400, 4, 8).final_state[:2]
    st = Settings()
    trace(prob, x0, 1.5, 1, 1.5, 2.5, +1, st)  # warm-up (compiled kernels, cache load)
    times, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        branches = trace(prob, x0, 1.5, 1, 1.5, 2.5, +1, st)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    t = statistics.median(times)
    calls = _count_shots(prob, lambda: trace(prob, x0, 1.5, 1, 1.5, 2.5, +1, st))
    b = branches[0]
    a = b.arrays()
    n_pts = len(b)
    bifs = {f.type: f.parameter for f in b.bifurcations}
    log(f"continuation: {n_pts} points in {t:.4f} s")
    # the sweep it replaces, at equal accuracy, on the stable impacting part
    upper = np.flatnonzero(a["stable"] & (a["impacts"] == 1) & (a["parameter"] <= 1.98))
    W_b = a["parameter"][upper]
    grid = np.linspace(1.5, 1.98, sweep_points)
    # exact branch values on the grid: correct at each grid frequency (natural-parameter Newton)
    from vibeam.models.continuation import start_point
    Q_ref = np.empty_like(grid)
    for i, W in enumerate(grid):
        k = int(np.argmin(np.abs(W_b - W)))
        pt, _ = start_point(prob, a["state"][upper][k], W, 1, 1.5, 2.5)
        Q_ref[i] = pt.shot.gap - pt.shot.q_min
    rows, equal = _sweep_at_equal_accuracy(EventSolver(m), m.Delta, grid, Q_ref,
                                           (50, 100, 200, 400, 800, 1600, 3200), target_error,
                                           lambda msg: log(msg))
    per_point = t / n_pts
    return {
        "scene": "paper Fig. 8 (beta 0.015, B 0.5e-3, R 0.9, Delta 0.7e-3), Omega 1.5 .. 2.5, period-1 branch",
        "continuation": {
            "points": n_pts, "time_s": t, "times_s": times, "time_per_point_s": per_point,
            "cpu_time_s": statistics.median(cpu),
            "shots": calls, "stable_points": int(a["stable"].sum()), "unstable_points": int((~a["stable"]).sum()),
            "bifurcations": bifs, "status": b.status},
        "goal": {"points": "~500", "time_s": CONTINUATION_GOAL_S,
                 "verdict": "pass" if t < CONTINUATION_GOAL_S else "fail",
                 "ratio_to_goal": t / CONTINUATION_GOAL_S,
                 "cpu_verdict": "pass" if statistics.median(cpu) < CONTINUATION_GOAL_S else "fail",
                 "note": "time_s is wall-clock (it includes waiting for a core on a shared machine); "
                         "cpu_time_s is the time this process ran"},
        "sweep_at_equal_accuracy": {
            "grid": f"{sweep_points} frequencies on the stable impacting part, Omega 1.5 .. 1.98 (up, continuation)",
            "target_max_rel_error": target_error, "ladder": rows,
            "transient_periods": equal["transient_periods"] if equal else None,
            "time_per_point_s": equal["time_per_point_s"] if equal else None,
            "cost_ratio_sweep_to_continuation_per_point":
                (equal["time_per_point_s"] / per_point) if equal else None,
            "note": "the unstable part of the branch (between the fold and the grazing) has no sweep counterpart",
        },
        "load_average": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
    }


def run_fit_bench(points: int = 30, jobs: int = 2, sigma_mm: float = 0.01, seed: int = 1,
                  goal_s: float = 10.0) -> dict:
    """Cost of ``vibeam fit`` (:func:`vibeam.identify.fit.fit_case`): a two-parameter (gain, R) fit of the
    SDOF rig scene (``rig-neutral``, 400 + 64 periods) to ``points`` synthetic points (14-17 Hz,
    up, Gaussian noise ``sigma_mm``) from a start 10 % off, on a local pool of ``jobs`` workers
    (its start-up included), against the goal; and the same for R alone on the FE beam with
    2 modes (``rig-fe-neutral``).  Returns a JSON-ready dict; prints no assertion."""
    from pathlib import Path

    from vibeam.case.schema import load_case
    from vibeam.identify.fit import fit_case, synthetic_reference

    root = Path(__file__).resolve().parent.parent / "cases"
    f = np.linspace(14.0, 17.0, points)
    out = {"points": points, "jobs": jobs, "noise_mm": sigma_mm, "goal_s": goal_s, "fits": {}}
    scenes = (("sdof gain,R", "rig-neutral.toml", None, {"gain": 5.16e-4, "R": 0.72}, {"gain": 4.64e-4, "R": 0.65}),
              ("FE 2 modes R", "rig-fe-neutral.toml", "FE 2 modes", {"R": 0.72}, {"R": 0.65}))
    for label, fname, run, truth, start in scenes:
        case, _ = load_case(root / fname)
        ref = synthetic_reference(case, f, truth, run=run, sigma=sigma_mm, seed=seed)
        t0 = time.perf_counter()
        res = fit_case(case, ref, list(truth), run=run, jobs=jobs, x0=start)
        t = time.perf_counter() - t0
        out["fits"][label] = {
            "case": fname, "run": res.run, "time_s": t, "evaluations_sweeps": res.evaluations,
            "nfev": res.nfev, "njev": res.njev, "truth": truth, "start": start,
            "estimate": dict(zip(res.parameters, map(float, res.estimate))),
            "standard_error": dict(zip(res.parameters, map(float, res.standard_error))),
            "within_2se": bool(np.all(np.abs(res.estimate - np.array(list(truth.values())))
                                      <= 2 * res.standard_error)),
            "time_per_sweep_s": t / max(res.evaluations, 1)}
    t_sdof = out["fits"]["sdof gain,R"]["time_s"]
    out["goal"] = f"two-parameter SDOF fit on {points} points in under {goal_s:g} s on {jobs} cores"
    out["ratio_to_goal"] = t_sdof / goal_s
    out["pass"] = bool(t_sdof < goal_s)
    return out


BEAM_CONTINUATION_GOAL_S = 10.0   # issue 10: all-modes branch of the 24-element rig over 14-17 Hz


def _timed_trace(prob, x0, p0, lo, hi, direction, settings, repeats):
    """Median wall and CPU time of :func:`trace` (after a warm-up call), shots per run, the
    branches of the last run."""
    from vibeam.models.continuation import trace

    trace(prob, x0, p0, 1, lo, hi, direction, settings)          # warm-up: kernels, cache load
    times, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        brs = trace(prob, x0, p0, 1, lo, hi, direction, settings)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    calls = _count_shots(prob, lambda: trace(prob, x0, p0, 1, lo, hi, direction, settings))
    return statistics.median(times), statistics.median(cpu), times, calls, brs


def _count_shots(prob, run) -> int:
    """The shots ``run()`` makes of ``prob``: its calls of ``prob.shot`` and the shots of its
    compiled corrector (``prob.correct``)."""
    calls = [0]
    shot, correct = prob.shot, getattr(prob, "correct", None)

    def counted(*a, **k):
        calls[0] += 1
        return shot(*a, **k)

    def counted_correct(*a, **k):
        r = correct(*a, **k)
        if r is not None:
            calls[0] += r[-1]
        return r

    prob.shot = counted
    if correct is not None:
        prob.correct = counted_correct
    try:
        run()
    finally:
        del prob.shot
        if correct is not None:
            del prob.correct
    return calls[0]


def run_beam_continuation_bench(repeats: int = 3, sweep_points: int = 16, target_error: float = 1e-8,
                                log=None) -> dict:
    """Speed of the beam's continuation with all modes of the shipped 24-element rig (46 modes,
    d = 92) against the goal :data:`BEAM_CONTINUATION_GOAL_S` and against the sweep it replaces.

    * ``neutral``: cases/rig-fe-neutral.toml, 14-17 Hz, the period-1 branch from the orbit an
      event run from rest reaches at 14 Hz (400 periods, timed apart: ``start_s``); the verdict
      compares the branch's median time (after a warm-up) with the goal.  Equal accuracy: a
      laboratory sweep of the event solver over ``sweep_points`` frequencies (state carried
      from point to point) with more and more transient periods until every amplitude agrees
      with the exact branch values (Newton at the grid frequencies) to ``target_error``; its
      cost per point is set against the branch's.
    * ``tight``: cases/rig-fe-tight.toml (pre-stressed stop, chatter): over 14-17 Hz from the
      orbit the event run reaches at 14 Hz (~110 impacts per period ending in sticking; its
      branch ends where the sticking does and a 20-impact orbit grazes, at 14.375 Hz), and the
      shipped ladder's all-modes branch (cases/rig-fe-tight-continuation.toml: 14-21 Hz from
      18 Hz, through its folds, non-smooth folds and period doublings), each timed once (the
      second is the case's, not the goal's).
    """
    from vibeam.models import shooting_problem
    from vibeam.models.beam_dynamics import BeamEventSolver
    from vibeam.models.continuation import Settings, start_point, trace

    log = log or (lambda m: None)
    out: dict = {}
    st = Settings()
    case, model, _, _ = _scene("rig-fe-neutral.toml", {"n_modes": "all"})
    f_ref = model.f_ref_hz
    lo, hi = 14.0 / f_ref, 17.0 / f_ref
    t0 = time.perf_counter()
    x0 = BeamEventSolver(model).point(lo, None, 400, 1, 1).final_state[:-1]
    t_start = time.perf_counter() - t0
    prob = shooting_problem(model, "Omega")
    t, c, times, shots, brs = _timed_trace(prob, x0, lo, lo, hi, +1, st, repeats)
    b = brs[0]
    a = b.arrays()
    n_pts = len(b)
    log(f"beam continuation (neutral, all modes): {n_pts} points in {t:.3f} s")
    # the sweep it replaces at equal accuracy (every point of this branch is stable)
    grid = np.linspace(lo, hi, sweep_points)
    Q_ref = np.empty_like(grid)
    for i, W in enumerate(grid):
        k = int(np.argmin(np.abs(a["parameter"] - W)))
        pt, _ = start_point(prob, a["state"][k], W, 1, lo, hi)
        Q_ref[i] = pt.shot.amplitude
    rows, equal = _sweep_at_equal_accuracy(BeamEventSolver(model), model.Delta, grid, Q_ref,
                                           (25, 50, 100, 200, 400, 800), target_error,
                                           lambda msg: log("  all-modes " + msg))
    per_point = t / n_pts
    out["neutral"] = {
        "scene": "cases/rig-fe-neutral.toml, all 46 modes (d = 92), 14-17 Hz, period-1 branch from the event orbit at 14 Hz",
        "points": n_pts, "status": b.status, "time_s": t, "times_s": times, "cpu_time_s": c,
        "time_per_point_s": per_point, "shots": shots, "shots_per_point": shots / n_pts,
        "start_s": t_start, "stable_points": int(a["stable"].sum()),
        "bifurcations": [(f.type, f.parameter * f_ref) for f in b.bifurcations],
        "goal": {"time_s": BEAM_CONTINUATION_GOAL_S,
                 "verdict": "pass" if t < BEAM_CONTINUATION_GOAL_S else "fail",
                 "verdict_with_start": "pass" if t + t_start < BEAM_CONTINUATION_GOAL_S else "fail",
                 "ratio_to_goal": t / BEAM_CONTINUATION_GOAL_S},
        "sweep_at_equal_accuracy": {
            "grid": f"{sweep_points} frequencies over 14-17 Hz (up, state carried on)",
            "target_max_rel_error": target_error, "ladder": rows,
            "transient_periods": equal["transient_periods"] if equal else None,
            "time_per_point_s": equal["time_per_point_s"] if equal else None,
            "cost_ratio_sweep_to_continuation_per_point": (equal["time_per_point_s"] / per_point) if equal else None},
    }
    # the pre-stressed stop: chatter orbits, ~40 ms per shot with M
    case, model, _, _ = _scene("rig-fe-tight.toml", {"n_modes": "all"})
    f_ref = model.f_ref_hz
    lo, hi = 14.0 / f_ref, 17.0 / f_ref
    x0 = BeamEventSolver(model).point(lo, None, 400, 1, 1).final_state[:-1]
    prob = shooting_problem(model, "Omega")
    trace(prob, x0, lo, 1, lo, hi, +1, Settings(switch=False, max_points=3))      # warm-up
    rows = {}
    for label, (x, p0, lo_, hi_, direction) in {
            "14-17 Hz from the event orbit at 14 Hz": (x0, lo, lo, hi, +1),
            "ladder 14-21 Hz from 18 Hz (cases/rig-fe-tight-continuation.toml)":
                (BeamEventSolver(model).point(18.0 / f_ref, None, 400, 1, 1).final_state[:-1], 18.0 / f_ref,
                 lo, 21.0 / f_ref, 0)}.items():
        t0, c0 = time.perf_counter(), time.process_time()
        (b, *_) = trace(prob, x, p0, 1, lo_, hi_, direction, Settings(switch=False))
        tt, cc = time.perf_counter() - t0, time.process_time() - c0
        a = b.arrays()
        rows[label] = {"points": len(b), "status": b.status, "message": b.message, "time_s": tt, "cpu_time_s": cc,
                       "time_per_point_s": tt / max(len(b), 1),
                       "impacts_per_orbit_max": int(a["impacts"].max()) if len(b) else 0,
                       "bifurcations": [(f.type, f.parameter * f_ref) for f in b.bifurcations]}
        log(f"beam continuation (tight, all modes, {label}): {len(b)} points in {tt:.2f} s, {b.status}")
    out["tight"] = rows
    out["tight"]["goal_verdict_14_17_Hz"] = ("pass" if rows["14-17 Hz from the event orbit at 14 Hz"]["time_s"]
                                             < BEAM_CONTINUATION_GOAL_S else "fail")
    out["load_average"] = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    return out


def main_bench(args) -> int:
    """``vibeam bench``: one benchmark as JSON on stdout, a PASS/FAIL/NOT CHECKED line per stated
    goal on stderr; exit code 1 when any goal FAILed (0 otherwise: every goal passed or was not
    checked in this configuration)."""
    log = (lambda m: print(m, file=sys.stderr))
    if getattr(args, "fit", False):
        out, mode = run_fit_bench(jobs=getattr(args, "jobs", None) or 2), "--fit"
        out["goals"] = [goal(out["goal"], f"{out['fits']['sdof gain,R']['time_s']:.2f} s", out["pass"])]
    elif getattr(args, "continuation", False):
        sdof = run_continuation_bench(repeats=getattr(args, "repeats", 5), log=log)
        beam = run_beam_continuation_bench(repeats=min(3, getattr(args, "repeats", 3)), log=log)
        out, mode = {"sdof": sdof, "beam": beam}, "--continuation"
        g, bn = sdof["goal"], beam["neutral"]
        out["goals"] = [goal(f"~500-point SDOF branch with stability in under {g['time_s']:g} s (wall)",
                             f"{sdof['continuation']['time_s']:.4f} s", g["verdict"] == "pass"),
                        goal("the same in CPU time (a shared machine)", f"{sdof['continuation']['cpu_time_s']:.4f} s",
                             g["cpu_verdict"] == "pass"),
                        goal(f"all-modes beam branch, rig-fe-neutral 14-17 Hz, in under {BEAM_CONTINUATION_GOAL_S:g} s",
                             f"{bn['time_s']:.2f} s", bn["goal"]["verdict"] == "pass"),
                        goal(f"all-modes beam, rig-fe-tight 14-17 Hz (chatter ending in sticking), in under "
                             f"{BEAM_CONTINUATION_GOAL_S:g} s",
                             f"{beam['tight']['14-17 Hz from the event orbit at 14 Hz']['time_s']:.2f} s",
                             beam["tight"]["goal_verdict_14_17_Hz"] == "pass")]
    elif getattr(args, "scaling", False):
        out, mode = run_scaling_bench(repeats=getattr(args, "repeats", 3)), "--scaling"
        out["goals"] = scaling_goals(out)
    elif getattr(args, "map", False):
        out, mode = run_map_bench(log=log), "--map"
        out["goals"] = map_goals(out)
    elif getattr(args, "shooting", False):
        out, mode = run_shooting_bench(repeats=getattr(args, "repeats", 5)), "--shooting"
        out["goals"] = shooting_goals(out)
    elif getattr(args, "effects", False):
        out, mode = run_effects_bench(), "--effects"
        out["goals"] = effects_goals(out)
    elif getattr(args, "latency", False):
        out, mode = run_latency_bench(repeats=getattr(args, "repeats", 3), log=log), "--latency"
        out["goals"] = latency_goals(out)
    elif getattr(args, "basins", False):
        out, mode = run_basins_bench(jobs=getattr(args, "jobs", None) or 2, log=log), "--basins"
        out["goals"] = basins_goals(out)
    elif getattr(args, "estimate", False):
        out, mode = run_estimate_bench(log=log), "--estimate"
        out["goals"] = estimate_goals(out)
    elif getattr(args, "compile", False):
        out, mode = run_compile_bench(log=log), "--compile"
        out["goals"] = compile_goals(out)
    elif getattr(args, "cli", False):
        out, mode = run_cli_bench(repeats=args.repeats, direct_points=args.direct_points or 11, log=log), "--cli"
    else:
        out = run_bench(points=args.points, periods=args.periods, repeats=args.repeats,
                        direct_points=args.direct_points)
        out["goals"], mode = bench_goals(out), ""
    print(json.dumps(out, indent=2))
    print_verdicts(mode, out["goals"])
    failed = [g for g in out["goals"] if g.get("pass") is False]
    return 1 if failed else 0


# ----------------------------------------------------------------------------- work estimate
#: the estimate's goal: every row's run time within this factor of its estimate, either way
ESTIMATE_GOAL_FACTOR = 10.0
#: a compliant stop's stiffness in the estimate's scenes, per law family: (SDOF ratio k_c, beam N/m),
#: the cell matrix's (tests/test_matrix.py)
_ESTIMATE_STIFFNESS = {"kelvin_voigt": (1e4, 1e5), "hysteretic_hertz": (1e5, 1e8)}


def _estimate_case(fid: str, law: str, stops: str) -> dict:
    """A scene of the cell matrix (tests/test_matrix.py's rows: the SDOF of beta 0.015,
    B 5e-3, R 0.8, Delta 0.002 with a lower stop at 0.003, or the rig FE beam with 2 modes and a
    lower stop 0.3 mm below) with the upper stop's ``law`` and ``stops`` ``one`` or ``two``
    (the lower stop of the same law), a 6-point sweep of 100 + 32 periods."""
    import tomllib

    if fid == "sdof":
        model = {"fidelity": "sdof", "beta": 0.015, "B": 5e-3, "R": 0.8, "Delta": 0.002}
        sweep = {"Omega": [0.75, 2.5, 6]}
        lower, key = ("Delta_lower", 0.003), "stiffness"
    else:
        root = Path(__file__).resolve().parent.parent / "cases"
        model = dict(tomllib.loads((root / "rig-fe-neutral.toml").read_text())["model"], n_modes=2)
        sweep = {"frequency_hz": [10.0, 20.0, 6]}
        lower, key = ("gap_lower_mm", 0.3), "stiffness_n_m"
    from vibeam.models.registry import law_family

    fam = law_family(law)
    k = None if fam is None else _ESTIMATE_STIFFNESS[fam][0 if fid == "sdof" else 1]
    if k is not None:
        model["contact"] = {"law": law, key: k}
    if stops == "two":
        model[lower[0]] = lower[1]
        if k is not None:
            model["contact_lower"] = {"law": law, key: k * (0.3 if fid == "sdof" else 3.0)}
    sweep.update(transient_periods=100, record_periods=32)
    return {"name": f"estimate-{fid}-{law}-{stops}", "model": model, "sweep": sweep,
            "run": [{"name": "event", "method": "event"}]}


def run_estimate_bench(repeats: int = 2, log=None) -> dict:
    """The work estimate that decides inline against pool (:func:`vibeam.runner.plan_execution`)
    against the run time it estimates: each scene of :func:`_estimate_case` (SDOF and 2-mode
    beam, each law, one or two stops) run inline, warm (the first of ``repeats`` runs loads the
    kernels), its reported run time over ``work_min x STEP_SECONDS``.  The laws' ``work_factor``
    were calibrated on these rows (issue 42: a 4-mode Hunt-Crossley beam was estimated 200x too
    small, before any law had a factor)."""
    import tempfile

    from vibeam.api import case_text, load_case
    from vibeam.engine.jobs import estimate_work
    from vibeam.models.registry import IMPLEMENTED_LAWS
    from vibeam.runner import STEP_SECONDS, run_case

    rows = []
    for fid in ("sdof", "beam"):
        for law in IMPLEMENTED_LAWS:
            for stops in ("one", "two"):
                case = load_case(_estimate_case(fid, law, stops))
                w = estimate_work(case)
                est = w["work_min"] * STEP_SECONDS
                times = []
                for _ in range(max(repeats, 2)):
                    with tempfile.TemporaryDirectory() as t, contextlib.redirect_stdout(io.StringIO()):
                        runs = run_case(case, case_text(case), t, jobs=1, quiet=True, plots=False)
                    times.append(float(runs[0].attrs["_timing"]["run_s"]))
                t_run = min(times[1:])
                rows.append({"fidelity": fid, "law": law, "stops": stops, "estimate_s": est,
                             "steps_min": w["steps_min"], "run_s": t_run, "ratio": t_run / est})
                if log:
                    log(f"{fid:5s} {law:20s} {stops:4s} estimate {est:9.3g} s  run {t_run:8.3g} s  "
                        f"ratio {t_run / est:8.3g}")
    ratios = np.array([r["ratio"] for r in rows])
    return {"rows": rows, "ratio_min": float(ratios.min()), "ratio_max": float(ratios.max()),
            "ratio_geomean": float(np.exp(np.mean(np.log(ratios)))), "goal_factor": ESTIMATE_GOAL_FACTOR}


def estimate_goals(out: dict) -> list:
    f = out["goal_factor"]
    return [goal(f"every scene's run time within {f:g}x of the work estimate (inline or pool decided on it)",
                 f"ratios {out['ratio_min']:.2g} to {out['ratio_max']:.2g} (geometric mean "
                 f"{out['ratio_geomean']:.2g})", 1.0 / f <= out["ratio_min"] and out["ratio_max"] <= f)]


# ----------------------------------------------------------------------------- basins
BASINS_GOAL_S = 20.0


def run_basins_bench(jobs: int = 2, log=None) -> dict:
    """Basins of attraction (:mod:`vibeam.analysis.attractors`): the tight rig's SDOF on 200 x 200 at 16.5 Hz
    (goal: under :data:`BASINS_GOAL_S` s on 2 cores, every attractor described with its Lyapunov
    spectrum over 1000 periods), inline and on ``jobs`` workers; the labels with basin hits against
    following every state to an attractor (100 x 100); and the 24-element FE rig with 4 modes on
    50 x 50 (time reported).  A 10 x 10 run of each scene first loads (or compiles) the kernels:
    its time is reported apart, as ``warm_up_s``."""
    from vibeam.api import basins

    log = log or (lambda m: None)
    out: dict = {"jobs": jobs}
    tight = str(_root() / "cases" / "rig-tight.toml")
    t0 = time.perf_counter()
    basins(tight, frequency_hz=16.5, grid=(10, 10), lyapunov_periods=10)
    out["sdof_warm_up_s"] = time.perf_counter() - t0
    for j in (1, jobs):
        log(f"basins: SDOF 200 x 200, jobs = {j}")
        t0 = time.perf_counter()
        r = basins(tight, frequency_hz=16.5, grid=(200, 200), jobs=j)
        t = time.perf_counter() - t0
        a = r.attractors
        out[f"sdof_200x200_jobs_{j}"] = {
            "time_s": t, "map_iterations": int(r.periods[0]), "periods_per_state": float(r.periods[0]) / 40000,
            "us_per_state": 1e6 * t / 40000,
            "attractors": [{"type": a["type"][0][k], "period": int(a["period"][0, k]),
                            "amplitude_mm": float(a["amplitude"][0, k] * r.amplitude_scale_mm),
                            "fraction": float(a["fraction"][0, k]), "fraction_se": float(a["fraction_se"][0, k]),
                            "lyapunov_1_per_s": float(a["lyapunov"][0, k, 0] / r.time_scale_s)}
                           for k in range(r.n_attractors)]}
    log("basins: basin hits against full trajectories, 100 x 100")
    t0 = time.perf_counter()
    hit = basins(tight, frequency_hz=16.5, grid=(100, 100), jobs=1, lyapunov_periods=0)
    t1 = time.perf_counter()
    full = basins(tight, frequency_hz=16.5, grid=(100, 100), jobs=1, lyapunov_periods=0, basin_hits=False)
    t2 = time.perf_counter()
    out["basin_hits_100x100"] = {"time_s": t1 - t0, "time_without_s": t2 - t1,
                                 "labels_equal": float(np.mean(hit.labels == full.labels)),
                                 "periods_per_state": float(hit.periods[0]) / 1e4,
                                 "periods_per_state_without": float(full.periods[0]) / 1e4}
    beam = str(_root() / "cases" / "rig-fe-tight.toml")
    t0 = time.perf_counter()
    basins(beam, run="FE 4 modes", frequency_hz=16.5, grid=(4, 4), lyapunov_periods=10)
    out["beam_warm_up_s"] = time.perf_counter() - t0
    log(f"basins: FE 4 modes (24 elements) 50 x 50, jobs = {jobs}")
    t0 = time.perf_counter()
    r = basins(beam, run="FE 4 modes", frequency_hz=16.5, grid=(50, 50), jobs=jobs)
    t = time.perf_counter() - t0
    a = r.attractors
    out["beam_4_modes_50x50"] = {"time_s": t, "map_iterations": int(r.periods[0]),
                                 "periods_per_state": float(r.periods[0]) / 2500,
                                 "attractors": [{"type": a["type"][0][k], "period": int(a["period"][0, k]),
                                                 "amplitude_mm": float(a["amplitude"][0, k] * r.amplitude_scale_mm),
                                                 "fraction": float(a["fraction"][0, k])}
                                                for k in range(r.n_attractors)]}
    return out


def basins_goals(out: dict) -> list:
    j = out["jobs"]
    t = out[f"sdof_200x200_jobs_{j}"]["time_s"]
    return [goal(f"200 x 200 SDOF basin of the tight rig at 16.5 Hz on {j} cores in under {BASINS_GOAL_S:g} s",
                 f"{t:.2f} s", t < BASINS_GOAL_S),
            goal("a 50 x 50 basin of the 24-element beam with 4 modes: time reported",
                 f"{out['beam_4_modes_50x50']['time_s']:.2f} s", True)]


# ----------------------------------------------------------------------------- scaling
def _loglog_fit(x, t) -> dict:
    """Least-squares fit of log t = log c + p log x; returns p, c, R^2 and the local slopes."""
    lx, lt = np.log(np.asarray(x, float)), np.log(np.asarray(t, float))
    p, lc = np.polyfit(lx, lt, 1)
    resid = lt - (p * lx + lc)
    ss = float(np.sum((lt - lt.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid ** 2)) / ss if ss > 0 else float("nan")
    local = np.diff(lt) / np.diff(lx)
    return {"exponent": float(p), "prefactor_s": float(np.exp(lc)), "r2_loglog": r2,
            "local_exponents": [float(v) for v in local]}


def _smooth(x: float) -> int:
    """The 5-smooth integer (prime factors 2, 3, 5 only) nearest to ``x`` (>= 1).

    Recorded periods are rounded to such counts: the harmonics of a record come from an
    FFT of all its samples (:func:`vibeam.engine.records.harmonic_amplitudes`), and numpy's FFT
    of a length with a large prime factor is an order of magnitude slower (64 x 883
    samples: 18 ms against 3 ms for 64 x 882), which would show as a jump in the ladder.
    """
    def smooth(n):
        for p in (2, 3, 5):
            while n % p == 0:
                n //= p
        return n == 1

    lo = hi = max(1, int(round(x)))
    while not smooth(lo) and lo > 1:
        lo -= 1
    while not smooth(hi):
        hi += 1
    return lo if x - lo <= hi - x else hi


def _scene(fname: str, over: dict | None):
    """Case, spec, model, solver settings and sweep settings of a shipped case, built as
    ``vibeam run`` builds them (:func:`vibeam.cli.run_case`)."""
    from pathlib import Path

    from vibeam.case.schema import load_case

    root = Path(__file__).resolve().parent.parent / "cases"
    case, _ = load_case(root / fname)
    run = next((r for r in case.run if r.method == "event"), case.run[0])
    spec = case.model_spec(over)
    spec.build()                  # first build: imports (scikit-fem, ...) and caches
    t0 = time.perf_counter()
    model = spec.build()
    t_build = time.perf_counter() - t0
    return case, model, case.run_settings(run), t_build


def _time_sweep(case, model, settings, points: int, n_periods: int, repeats: int,
                record_fraction: float | None = None, record: int | None = None,
                min_total_s: float = 0.25, max_repeats: int = 25, recurrence: bool = False) -> tuple[float, dict]:
    """Median wall time of an inline (jobs=1) event sweep of ``points`` frequencies spread
    over the case's grid with ``n_periods`` = transient + record periods per point, after
    a warm-up; the case's direction, continuation, samples per period and period rtol; every
    period integrated unless ``recurrence`` (the solver's exact recurrence)."""
    from vibeam.models import make_solver
    from vibeam.engine.sweep import Sweep, run_sweep

    cs = case.sweep
    fn = getattr(model, "natural_frequency_hz", None)
    full = cs.grid(fn)
    grid = np.linspace(full[0], full[-1], points)
    if record is None:
        record = _smooth(n_periods * record_fraction)
    transient = n_periods - record
    solver = make_solver(model, "event", **{**settings, "recurrence": recurrence})
    kw = dict(direction=cs.direction, continuation=cs.continuation,
              samples_per_period=cs.samples_per_period, period_rtol=cs.period_rtol)
    run_sweep(solver, Sweep(Omega=grid[:2], transient_periods=2, record_periods=2, **kw), jobs=1)  # warm-up
    sw = Sweep(Omega=grid, transient_periods=transient, record_periods=record, **kw)
    ts, cs_ = [], []
    # at least ``repeats`` runs, more for cheap sweeps (until min_total_s is spent, at most
    # max_repeats): a median of ms-long runs is otherwise at the mercy of timer and OS noise
    while len(ts) < repeats or (sum(ts) < min_total_s and len(ts) < max_repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        res = run_sweep(solver, sw, jobs=1)
        ts.append(time.perf_counter() - t0)
        cs_.append(time.process_time() - c0)
    n_solves = len(res.data["Omega"])
    return statistics.median(ts), {"cpu_s": statistics.median(cs_), "transient": transient, "record": record,
                                   "point_solves": n_solves, "repeats": len(ts),
                                   "impacts_per_period_mean": float(np.mean(res.data["impacts_per_period"]))}


def run_scaling_bench(points: int = 11,
                      sdof_periods=(50, 100, 200, 400, 800, 1600, 3200, 6400, 12800),
                      beam_periods=(25, 50, 100, 200, 400, 800, 1600, 3200), beam_modes_for_periods: int = 2,
                      mode_points: int = 11, mode_periods: int = 200,
                      modes=(1, 2, 4, 8, 16, 32, "all"), repeats: int = 3,
                      mode_budget_s: float = 60.0) -> dict:
    """How the cost of an inline event sweep grows with periods simulated and with retained
    modes; returns a JSON-ready dict.

    The ladders integrate every period (the solvers' exact recurrence off: with it, a settled
    point's cost stops growing with its periods, which is not the integrator's cost); the same
    sweeps with the recurrence on are timed beside them (``time_s_with_recurrence``).

    * Periods: ``points`` frequencies of the rig SDOF scene (``cases/rig-neutral.toml``)
      at ``sdof_periods`` and of the FE rig (``cases/rig-fe-neutral.toml``) with
      ``beam_modes_for_periods`` modes at ``beam_periods`` forcing periods per point
      (transient + record, the record share as in the case, 64 of 464, rounded to a
      5-smooth count, see :func:`_smooth`); the exponent p of time ~ N^p is fitted by
      least squares on log-log, and the cost per period and point solve with p fixed at
      1 (geometric mean of t / (N * solves)), besides a linear fit t = t0 + b N (t0: the
      per-sweep overhead).
    * Modes: ``mode_points`` frequencies, ``mode_periods`` periods per point of the FE
      rig with ``modes`` retained modes ("all": every mode of the mesh), the fit of
      time ~ n_modes^p, and the static-mode SDOF (``n_modes = "static"``) beside it.
      The ladder stops early once a rung took more than ``mode_budget_s``.

    Timings (wall ``time_s``, fitted; process CPU ``cpu_time_s`` beside it, less sensitive
    to other load on the machine) are the median of ``repeats`` (more, up to 25, for
    sweeps under 0.25 s in all) after a warm-up sweep (numba compilation and cache loading
    excluded); model construction (FE assembly and eigensolution) is timed apart.  The
    case's sweep direction ("both": each frequency is solved twice), continuation,
    samples per period and period rtol are used.  ``total_time_s`` is about 70 s with
    ``repeats = 5`` on the 2-core development machine.
    """
    t_all = time.perf_counter()
    out: dict = {"repeats": repeats, "jobs": 1, "method": "event", "periods": {}, "modes": {}}

    def periods_study(label, fname, over, ladder):
        case, model, settings, t_build = _scene(fname, over)
        frac = case.sweep.record_periods / (case.sweep.transient_periods + case.sweep.record_periods)
        ts, infos, ts_on = [], [], []
        for N in ladder:
            t, info = _time_sweep(case, model, settings, points, int(N), repeats, record_fraction=frac)
            ts.append(t)
            infos.append(info)
            ts_on.append(_time_sweep(case, model, settings, points, int(N), repeats, record_fraction=frac,
                                     recurrence=True)[0])
        N = np.asarray(ladder, float)
        solves = infos[0]["point_solves"]
        fit = _loglog_fit(N, ts)
        cpu = [i["cpu_s"] for i in infos]
        b, t0 = np.polyfit(N, ts, 1)
        c1 = float(np.exp(np.mean(np.log(np.asarray(ts) / (N * solves)))))
        # where the fixed cost of a point (the sweep engine's, the record's) is below 10 % of the
        # time, at least the 3 longest runs: the slope there is the cost per period
        big = [i for i, t in enumerate(ts) if t0 <= 0.1 * t]
        big = big if len(big) >= 3 else list(range(len(ts) - 3, len(ts)))
        fit_big = _loglog_fit(np.asarray(N)[big], np.asarray(ts)[big])
        out["periods"][label] = {
            "case": fname + (f" (n_modes = {over['n_modes']})" if over else ""),
            "points": points, "direction": case.sweep.direction, "point_solves": solves,
            "N": [int(n) for n in ladder],
            "record_periods": [i["record"] for i in infos],
            "time_s": ts,
            "time_s_with_recurrence": ts_on,
            "repeats": [i["repeats"] for i in infos],
            "exponent": fit["exponent"],
            "prefactor_s": fit["prefactor_s"],
            "exponent_beyond_overhead": fit_big["exponent"],
            "beyond_overhead_from_N": int(np.asarray(N)[big][0]),
            "s_per_period_per_point": c1,
            "s_per_period_per_point_note": "time / (N * point_solves), geometric mean (p fixed at 1); "
                                           "time ~ prefactor_s * N^exponent for the whole sweep",
            "r2_loglog": fit["r2_loglog"],
            "local_exponents": fit["local_exponents"],
            "linear_fit": {"overhead_s": float(t0), "s_per_period": float(b),
                           "s_per_period_per_point": float(b) / solves},
            "cpu_time_s": cpu,
            "exponent_cpu": _loglog_fit(N, cpu)["exponent"],
            "s_per_period_per_point_cpu": float(np.exp(np.mean(np.log(np.asarray(cpu) / (N * solves))))),
            "impacts_per_period_mean": [i["impacts_per_period_mean"] for i in infos],
            "model_build_s": t_build,
        }

    periods_study("sdof", "rig-neutral.toml", None, sdof_periods)
    periods_study(f"beam_{beam_modes_for_periods}_modes", "rig-fe-neutral.toml",
                  {"n_modes": beam_modes_for_periods}, beam_periods)

    # ---- modes
    fname = "rig-fe-neutral.toml"
    case, model, settings, t_build = _scene(fname, {"n_modes": "static"})
    frac = case.sweep.record_periods / (case.sweep.transient_periods + case.sweep.record_periods)
    t_static, info = _time_sweep(case, model, settings, mode_points, mode_periods, repeats,
                                 record_fraction=frac)
    t_static_on = _time_sweep(case, model, settings, mode_points, mode_periods, repeats, record_fraction=frac,
                              recurrence=True)[0]
    n_list, ts, cpu, reps, builds, labels, skipped, ts_on = [], [], [], [], [], [], [], []
    stop = False
    for m in modes:
        if stop:
            skipped.append(m)
            continue
        case, model, settings, t_build = _scene(fname, {"n_modes": m})
        n = int(model.n_modes)
        if n in n_list:   # e.g. "all" equal to the last integer rung
            continue
        t, inf = _time_sweep(case, model, settings, mode_points, mode_periods, repeats,
                             record=info["record"])
        ts_on.append(_time_sweep(case, model, settings, mode_points, mode_periods, repeats, record=info["record"],
                                 recurrence=True)[0])
        reps.append(inf["repeats"])
        n_list.append(n)
        cpu.append(inf["cpu_s"])
        labels.append(m)
        ts.append(t)
        builds.append(t_build)
        if t * repeats > mode_budget_s:
            stop = True
    fit = _loglog_fit(n_list, ts)
    upper = [i for i, n in enumerate(n_list) if n >= 4]
    fit_up = _loglog_fit([n_list[i] for i in upper], [ts[i] for i in upper]) if len(upper) >= 2 else None
    out["modes"] = {
        "case": fname, "points": mode_points, "direction": case.sweep.direction,
        "point_solves": info["point_solves"], "periods_per_point": mode_periods,
        "record_periods": info["record"],
        "n_modes_requested": [str(m) for m in labels],
        "n_modes": n_list, "time_s": ts, "repeats": reps,
        "time_s_with_recurrence": ts_on,
        "exponent_with_recurrence": _loglog_fit(n_list, ts_on)["exponent"],
        "static_mode_sdof_time_s_with_recurrence": t_static_on,
        "exponent": fit["exponent"], "prefactor_s": fit["prefactor_s"], "r2_loglog": fit["r2_loglog"],
        "local_exponents": fit["local_exponents"],
        "exponent_n_modes_ge_4": fit_up["exponent"] if fit_up else None,
        "cpu_time_s": cpu,
        "exponent_cpu": _loglog_fit(n_list, cpu)["exponent"],
        "model_build_s": builds,
        "static_mode_sdof_time_s": t_static,
        "static_mode_sdof_cpu_s": info["cpu_s"],
        "ratio_to_static_mode": [t / t_static for t in ts],
        "s_per_period_per_point": [t / (mode_periods * info["point_solves"]) for t in ts],
        "skipped_over_budget": [str(m) for m in skipped],
    }
    out["summary"] = {
        "exponent_periods": {k: v["exponent"] for k, v in out["periods"].items()},
        "exponent_periods_beyond_overhead": {k: (v["exponent_beyond_overhead"], v["beyond_overhead_from_N"])
                                             for k, v in out["periods"].items()},
        "s_per_period_per_point": {k: v["s_per_period_per_point"] for k, v in out["periods"].items()},
        "exponent_modes": out["modes"]["exponent"],
        "exponent_modes_n_ge_4": out["modes"]["exponent_n_modes_ge_4"],
    }
    out["total_time_s"] = time.perf_counter() - t_all
    return out


# ----------------------------------------------------------------------------- maps
def run_map_bench(case_file: str | None = None, frequencies: int = 61, values: int = 8, repeats: int = 1,
                  log=None) -> dict:
    """Throughput of a parameter map on 1 and 2 local workers, and the cost of checkpointing.

    The map is the Fig. 18 scene of ``case_file`` (default ``cases/paper-fig18-tight.toml``:
    chatter, sticking and lift-off make its points uneven in cost, as in a real map) thinned
    to ``frequencies`` x ``values`` points per direction, run through
    :func:`vibeam.runner.run_case` as ``vibeam map`` runs it (each worker loads the numba
    kernels from the on-disk cache; a warm-up map fills that cache first).

    Returns
    -------
    dict
        ``points``, ``lines``; ``points_per_s`` for 1 and 2 workers (checkpointed) and their
        ratio ``speedup_2_workers``; ``checkpoint_cost_ratio`` = time with the line
        checkpoint / time without it (1 worker), with the number of checkpoint writes and
        the final file size.
    """
    import tempfile
    from pathlib import Path

    from vibeam.case.schema import load_case
    from vibeam.runner import run_case

    path = Path(case_file) if case_file else Path(__file__).resolve().parents[1] / "cases" / \
        "paper-fig18-tight.toml"
    base, text = load_case(path)
    data = base.model_dump()
    key = "frequency_hz" if base.sweep.frequency_hz is not None else "Omega"
    g = getattr(base.sweep, key)
    data["sweep"] = dict(data["sweep"], **{key: [g[0], g[1], frequencies]})
    data["map"] = dict(data["map"], values=[base.map.values[0], base.map.values[1], values])
    case = type(base).model_validate(data)
    say = log or (lambda m: None)

    def timed(jobs, checkpoint):
        ts = []
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                with contextlib.redirect_stdout(io.StringIO()):   # keep stdout for the JSON
                    m = run_case(case, text, tmp, jobs=jobs, quiet=True, plots=False, checkpoint=checkpoint)[0]
                ts.append(time.perf_counter() - t0)
                size = (Path(tmp) / "results.h5").stat().st_size
        return statistics.median(ts), m, size

    with tempfile.TemporaryDirectory() as tmp:   # warm-up: compile / fill the numba cache
        small = type(base).model_validate(dict(data, sweep=dict(data["sweep"], **{key: [g[0], g[1], 2]}),
                                               map=dict(data["map"], values=[base.map.values[0],
                                                                             base.map.values[0], 1])))
        with contextlib.redirect_stdout(io.StringIO()):
            run_case(small, text, tmp, jobs=1, quiet=True, plots=False)
    out = {"case": str(path), "frequencies": frequencies, "values": values,
           "directions": 2 if case.sweep.direction == "both" else 1, "repeats": repeats}
    n_pts = frequencies * values * out["directions"]
    n_lines = values * out["directions"]
    t_plain, _, _ = timed(1, False)
    say(f"map {n_pts} points, 1 worker, no checkpoint: {t_plain:.2f} s")
    t1, m, size = timed(1, True)
    say(f"map {n_pts} points, 1 worker, checkpoint: {t1:.2f} s")
    t2, m2, _ = timed(2, True)
    say(f"map {n_pts} points, 2 workers, checkpoint: {t2:.2f} s")
    same = all(np.array_equal(m.data[k], m2.data[k], equal_nan=m.data[k].dtype.kind == "f")
               for k in ("classification", "amplitude", "period"))
    out.update(points=n_pts, lines=n_lines, time_s={"1_worker": t1, "2_workers": t2, "1_worker_no_checkpoint": t_plain},
               points_per_s={"1_worker": n_pts / t1, "2_workers": n_pts / t2},
               speedup_2_workers=t1 / t2, checkpoint_cost_ratio=t1 / t_plain, checkpoint_writes=n_lines,
               results_file_kB=size / 1024, results_equal_1_and_2_workers=bool(same),
               cores=os.cpu_count())
    return out


def map_goals(out: dict) -> list:
    """Goals of :func:`run_map_bench` (README, "What it costs")."""
    g = [goal("the line checkpoint costs at most 10 % (1 worker)", f"ratio {out['checkpoint_cost_ratio']:.3f}",
              out["checkpoint_cost_ratio"] <= 1.10),
         goal("1 and 2 workers give the same map, bit for bit", str(out["results_equal_1_and_2_workers"]),
              out["results_equal_1_and_2_workers"])]
    if (out.get("cores") or 1) >= 2:
        g.append(goal("2 workers at least 1.6x faster than 1 (2 cores)", f"{out['speedup_2_workers']:.2f}x",
                      out["speedup_2_workers"] >= 1.6))
    return g


def scaling_goals(out: dict) -> list:
    """Goals of :func:`run_scaling_bench`: linear in the periods simulated, at most linear in the
    retained modes."""
    g = [goal(f"cost linear in the periods simulated ({k}: exponent 0.9 .. 1.1 from {n0} periods, where a "
              f"point's fixed cost is below 10 %; {out['summary']['exponent_periods'][k]:.3f} over the whole ladder)",
              f"{p:.3f}", 0.9 <= p <= 1.1)
         for k, (p, n0) in out["summary"]["exponent_periods_beyond_overhead"].items()]
    e = out["summary"].get("exponent_modes_n_ge_4")
    if e is not None:
        g.append(goal("cost at most linear in the retained modes (exponent <= 1.1 from 4 modes)", f"{e:.3f}",
                      e <= 1.1))
    return g


def effects_goals(out: dict) -> list:
    """Goals of :func:`run_effects_bench`: no scene effect more than doubles the cost of a sweep
    (each changes the forcing, the gap, R or adds one DOF)."""
    return [goal(f"{fid}: '{name}' at most 2x the plain sweep", f"{r:.2f}x", r <= 2.0)
            for fid, row in out["scenes"].items() for name, r in row["ratio_to_plain"].items()]


# ----------------------------------------------------------------------------- shooting
def _median_time(f, repeats: int = 5, min_total_s: float = 0.2, max_repeats: int = 200) -> float:
    ts = []
    while len(ts) < repeats or (sum(ts) < min_total_s and len(ts) < max_repeats):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def _newton(prob, x, p, n=1, tol=1e-12, max_iter=30):
    """Plain Newton on P^n(x) = x with the shot's monodromy (bench only, not an engine)."""
    for it in range(max_iter):
        s = prob.shot(x, p, n)
        if s.status != "ok":
            return None, s, it
        r = s.x - x
        if np.max(np.abs(r)) <= tol * np.max(np.abs(x)):
            return x, s, it
        x = x - np.linalg.solve(s.M - np.eye(prob.dim), r)
    return None, s, max_iter


def run_shooting_bench(modes=(1, 2, 4, "all"), repeats: int = 5, frc_points: int = 31) -> dict:
    """Cost of the beam's periodic-orbit shooting (:class:`vibeam.models.periodic_beam.BeamShooting`).

    * ``shot``: one ``P^1`` with and without the monodromy and ``d x / d Omega``, for the
      period-1 one-impact orbit of ``rig-fe-neutral`` at 15.5 Hz and the period-1 chatter +
      sticking orbit of ``rig-fe-tight`` at 13 Hz, with ``modes`` retained modes (median
      wall time, after a warm-up).
    * ``newton_vs_event``: the neutral orbit by Newton with the shot's M from the
      contact-free linear orbit, against the event solver from rest: the periods it needs
      to come within 1e-10 of the fixed point and their wall time.
    * ``frc``: ``frc_points`` frequencies over the case's 14-17 Hz with all modes, each
      Newton solve started from the previous point's orbit (what a continuation step
      costs, without the engine), against the case's sweep (transient + record periods per
      point, timed on 3 points and scaled).
    """
    from vibeam.models.beam_dynamics import BeamEventSolver, particular
    from vibeam.models.periodic_beam import BeamShooting

    out: dict = {"shot": {}, "newton_vs_event": {}, "frc": {}}
    t_all = time.perf_counter()
    built: dict = {}

    def scene(fname, nm):
        if (fname, nm) not in built:
            built[fname, nm] = _scene(fname, {"n_modes": nm})
        return built[fname, nm]

    scenes = {"rig-fe-neutral 15.5 Hz": ("rig-fe-neutral.toml", 15.5),
              "rig-fe-tight 13 Hz": ("rig-fe-tight.toml", 13.0)}
    for label, (fname, f_hz) in scenes.items():
        row = {}
        for nm in modes:
            case, model, settings, _ = scene(fname, nm)
            W = f_hz / model.f_ref_hz
            x0 = BeamEventSolver(model).point(W, None, 300, 1, 1).final_state[:-1]
            prob = BeamShooting(model, W)
            s = prob.shot(x0, W, 1)
            prob.shot(x0, W, 1, derivatives=False)
            t_no = _median_time(lambda: prob.shot(x0, W, 1, derivatives=False), repeats)
            t_m = _median_time(lambda: prob.shot(x0, W, 1), repeats)
            row[str(nm)] = {"dim": prob.dim, "impacts": s.n_impacts, "stuck_time": s.stuck_time,
                            "events": int(s.extra["event_kinds"].size),
                            "shot_ms": 1e3 * t_no, "shot_with_M_ms": 1e3 * t_m,
                            "M_share": (t_m - t_no) / t_m}
        out["shot"][label] = row
    for nm in modes:
        case, model, settings, _ = scene("rig-fe-neutral.toml", nm)
        W = 15.5 / model.f_ref_hz
        a, b = particular(model.c_nd, model.k_nd, model.participation, W**2 * model.base_amplitude_m, W)
        prob = BeamShooting(model, W)
        t0 = time.perf_counter()
        x, s, it = _newton(prob, np.concatenate([b, W * a]), W)
        t_newton = time.perf_counter() - t0
        K = 400
        sol = BeamEventSolver(model, record_modal_states=True)
        t0 = time.perf_counter()
        tr = sol.point(W, None, 0, K, 1)
        t_ev = time.perf_counter() - t0
        err = np.max(np.abs(tr.extra["modal_states"] - x), axis=1) / np.max(np.abs(x))
        k = int(np.argmax(err < 1e-10)) if np.any(err < 1e-10) else -1
        out["newton_vs_event"][str(nm)] = {
            "newton_iterations": it, "newton_s": t_newton,
            "multiplier_modulus": float(np.max(np.abs(s.multipliers()))),
            "event_periods_to_1e-10": k, "event_s_to_1e-10": t_ev * k / K if k > 0 else None,
            "ratio_event_to_newton": (t_ev * k / K) / t_newton if k > 0 else None}
    case, model, settings, _ = scene("rig-fe-neutral.toml", "all")
    grid = np.linspace(14.0, 17.0, frc_points) / model.f_ref_hz
    prob = BeamShooting(model, grid[0])
    x = BeamEventSolver(model).point(grid[0], None, 300, 1, 1).final_state[:-1]
    its, ok, stable = [], 0, 0
    t0 = time.perf_counter()
    for W in grid:
        xn, s, it = _newton(prob, x, W)
        its.append(it)
        if xn is not None:
            x = xn
            ok += 1
            stable += bool(np.max(np.abs(s.multipliers())) < 1)
    t_frc = time.perf_counter() - t0
    cs = case.sweep
    sol = BeamEventSolver(model, **settings)
    sol.point(grid[0], None, 2, 2, cs.samples_per_period)
    t0 = time.perf_counter()
    for W in grid[:3]:
        sol.point(W, None, cs.transient_periods, cs.record_periods, cs.samples_per_period)
    t_pt = (time.perf_counter() - t0) / 3
    out["frc"] = {"points": frc_points, "converged": ok, "stable": stable,
                  "newton_iterations_mean": float(np.mean(its)), "time_s": t_frc,
                  "time_per_point_s": t_frc / frc_points,
                  "sweep_point_s": t_pt, "sweep_periods_per_point": cs.transient_periods + cs.record_periods,
                  "ratio_sweep_to_newton_per_point": t_pt / (t_frc / frc_points)}
    out["total_time_s"] = time.perf_counter() - t_all
    return out


def shooting_goals(out: dict) -> list:
    """Goals of :func:`run_shooting_bench`: Newton on the shot converges at every FRC point and
    a point costs less by Newton than by the sweep's transient."""
    f = out["frc"]
    return [goal("Newton on the beam's shot converges at every FRC point (all modes)",
                 f"{f['converged']} of {f['points']}", f["converged"] == f["points"]),
            goal("an FRC point by Newton costs less than the sweep's point (transient + record)",
                 f"{f['ratio_sweep_to_newton_per_point']:.2f}x", f["ratio_sweep_to_newton_per_point"] > 1)]


# ----------------------------------------------------------------------------- latency
#: the scene of the interrupt figures (tests/test_interrupts.py): the rig's SDOF on a pre-stressed
#: stop (chatter), a map of 2 x 6 lines of 6 points; 400000 transient periods make a point 200
#: solver calls of 2000 periods (seconds), so a signal always falls inside a long point
LATENCY_CASE = """
name = "latency"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.72
gap_mm = -0.05
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [14.0, 17.0, 6]
direction = "both"
transient_periods = 400000
record_periods = 16
[map]
parameter = "voltage"
values = [0.5, 0.7, 6]
[[run]]
name = "exact"
method = "event"
recurrence = false
"""

#: ``python -c PROBE MARKS vibeam-args...``: the command line with markers ``<pid> <monotonic s>
#: begin|end <n_transient> <n_record>`` around every EventSolver.point call (forked pool workers
#: inherit the patched class) and ``<pid> <s> handler`` when the main process's SIGINT handler
#: (Python's own, wrapped) runs; one os.write per line on an O_APPEND file
LATENCY_PROBE = """
import os, signal, sys, time
fd = os.open(sys.argv[1], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
def mark(text):
    os.write(fd, f"{os.getpid()} {time.monotonic():.6f} {text}\\n".encode())
from vibeam.models import EventSolver
inner = EventSolver.point
def point(self, Omega, state, n_tr, n_rec, *a, **k):
    mark(f"begin {n_tr} {n_rec}")
    out = inner(self, Omega, state, n_tr, n_rec, *a, **k)
    mark(f"end {n_tr} {n_rec}")
    return out
EventSolver.point = point
def on_int(signum, frame):
    mark("handler")
    signal.default_int_handler(signum, frame)
signal.signal(signal.SIGINT, on_int)
from vibeam.cli import main
sys.exit(main(sys.argv[2:]))
"""

LATENCY_GOAL_S = 1.0     # "Ctrl-C and the wall-time limit act within a second" (EventSolver.chunk_periods)


def _probe_marks(path) -> list:
    """The probe's marker file as ``(pid, t, word, rest)`` rows (a torn last line is skipped)."""
    rows = []
    for line in Path(path).read_text().splitlines(keepends=True):
        if line.endswith("\n"):
            pid, t, word, *rest = line.split()
            rows.append((int(pid), float(t), word, rest))
    return rows


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")


def _interrupt_once(jobs: int, hang_s: float = 120.0) -> dict:
    """One ``vibeam map`` of :data:`LATENCY_CASE` with ``--jobs jobs`` under the probe: SIGINT as
    soon as the main process (``jobs = 1``) or both workers are inside a long point's solver
    calls, then the time to the process's exit (and to its handler), the exit code, the
    solver calls begun after the handler ran, the median call's length and the workers still
    alive at the exit."""
    import signal
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        case, marks = Path(tmp) / "latency.toml", Path(tmp) / "marks.txt"
        case.write_text(LATENCY_CASE)
        marks.touch()
        p = subprocess.Popen([sys.executable, "-c", LATENCY_PROBE, str(marks), "map", str(case), "--out",
                              str(Path(tmp) / "out"), "--jobs", str(jobs), "--quiet", "--no-plots"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        try:
            t0 = time.monotonic()
            while True:
                rows = _probe_marks(marks)
                n = {}
                for r in rows:       # transient calls of a long point begun, per process
                    if r[2] == "begin" and r[3] == ["2000", "0"]:
                        n[r[0]] = n.get(r[0], 0) + 1
                inside = {pid for pid, k in n.items() if k >= 3}
                workers = sorted(set(n) - {p.pid})
                if (p.pid in inside) if jobs == 1 else len(inside - {p.pid}) >= min(jobs, 2):
                    break
                if p.poll() is not None or time.monotonic() - t0 > hang_s:
                    raise RuntimeError(f"the map never reached its long points (exit {p.poll()}): "
                                       f"{(p.stderr.read() if p.poll() is not None else '')[-300:]}")
                time.sleep(0.01)
            t_sig = time.monotonic()
            p.send_signal(signal.SIGINT)
            p.wait(timeout=hang_s)
            t_exit = time.monotonic()
        finally:
            if p.poll() is None:
                p.kill()
                p.wait()
        rows = _probe_marks(marks)
    hand = [r[1] for r in rows if r[2] == "handler"]
    t_hand = hand[0] if hand else None
    began = {}
    calls = []
    for pid, t, word, rest in rows:
        if rest == ["2000", "0"]:
            if word == "begin":
                began[pid] = t
            elif pid in began:
                calls.append(t - began.pop(pid))
    return {"sigint_to_exit_s": t_exit - t_sig, "exit_code": p.returncode,
            "sigint_to_handler_s": None if t_hand is None else t_hand - t_sig,
            "calls_after_handler": None if t_hand is None else sum(1 for r in rows if r[2] == "begin" and r[1] >= t_hand),
            "median_call_s": float(np.median(calls)) if calls else None, "calls_timed": len(calls),
            "workers": len(workers), "workers_alive_at_exit": sum(_alive(w) for w in workers)}


def _time_limit_overshoot(name: str, model, Omega: float, limit_s: float) -> dict:
    """A point of 10^7 transient periods (each integrated) with ``point_time_limit_s = limit_s``, inline: its wall
    time (the point's own ``wall_time_s``), the overshoot beyond the limit, and the solver calls
    (chunks) it made."""
    from vibeam.models import make_solver
    from vibeam.engine.sweep import Sweep, run_sweep

    # every period integrated: a transient that recurs exactly would end long before the limit
    solver = make_solver(model, "event", recurrence=False)
    run_sweep(solver, Sweep(Omega=np.array([Omega]), transient_periods=2, record_periods=2))   # warm-up
    calls = []
    inner = solver.point

    def counting(*a, **k):
        calls.append(a[2])
        return inner(*a, **k)

    solver.point = counting
    out = run_sweep(solver, Sweep(Omega=np.array([Omega]), transient_periods=10 ** 7, record_periods=4,
                                  point_time_limit_s=limit_s)).data
    wall = float(out["wall_time_s"][0])
    return {"scene": name, "limit_s": limit_s, "status": str(out["status"][0]), "message": str(out["message"][0]),
            "wall_time_s": wall, "overshoot_s": wall - limit_s, "calls": len(calls),
            "chunk_periods": int(getattr(solver, "chunk_periods", 0) or 0),
            "mean_call_s": wall / max(len(calls), 1)}


def run_latency_bench(repeats: int = 3, limit_s: float = 0.5, beam: bool = True, log=None) -> dict:
    """How fast a run stops: SIGINT to exit of an inline long point and of a ``--jobs 2`` map,
    and the wall-time limit's overshoot.

    A compiled kernel cannot be interrupted inside a call, so the sweep engine cuts a point
    into calls of ``solver.chunk_periods`` periods (:func:`vibeam.engine.sweep._simulate`): Ctrl-C
    lands at the next return, the wall-time limit is checked between calls, and a pooled run
    terminates its workers instead of waiting for their lines.  Measured here, never asserted
    (the tests check the behaviour by counting calls: tests/test_interrupts.py,
    tests/test_settle.py):

    * ``inline``, ``pool_2_workers``: ``vibeam map`` of :data:`LATENCY_CASE` in a fresh process
      with ``--jobs 1`` / ``--jobs 2`` under :data:`LATENCY_PROBE`; SIGINT once the main process
      / both workers are inside a long point (200 calls of 2000 periods); the time from the
      signal to the process's exit (median of ``repeats``; interpreter shutdown included, as a
      user sees it), to the handler, and the calls begun after the handler ran.
    * ``time_limit``: a point of 10^7 transient periods with ``point_time_limit_s = limit_s``,
      inline, on the Fig. 13 SDOF (Omega 2.0), the chatter scene of :data:`LATENCY_CASE` (15.5 Hz)
      and (``beam``) the rig's FE beam with all modes (rig-fe-neutral, 15.4 Hz): the point's wall
      time beyond the limit (it includes the first call, before the clock starts).

    Returns
    -------
    dict
        JSON-ready: ``inline``, ``pool_2_workers`` (``sigint_to_exit_s`` median and ``runs``),
        ``time_limit`` (per scene), ``goal_s``, ``cores``, ``load_average``.
    """
    from vibeam.case.schema import load_case, parse_case
    from vibeam.models import SDOF

    say = log or (lambda m: None)
    out = {"case": "SDOF on a pre-stressed stop (gap -0.05 mm, chatter), map 2 x 6 lines of 6 points, "
                   "400000 transient periods per point", "repeats": repeats, "goal_s": LATENCY_GOAL_S}
    for key, jobs in (("inline", 1), ("pool_2_workers", 2)):
        runs = []
        for _ in range(repeats):
            runs.append(_interrupt_once(jobs))
            r = runs[-1]
            say(f"SIGINT, --jobs {jobs}: exit after {r['sigint_to_exit_s']:.3f} s (exit code {r['exit_code']}; "
                f"calls of 2000 periods ~{(r['median_call_s'] or 0.0) * 1e3:.1f} ms, {r['calls_after_handler']} "
                f"begun after the handler)")
        hand = [r["sigint_to_handler_s"] for r in runs if r["sigint_to_handler_s"] is not None]
        out[key] = {"jobs": jobs, "sigint_to_exit_s": statistics.median(r["sigint_to_exit_s"] for r in runs),
                    "sigint_to_handler_s": statistics.median(hand) if hand else None,
                    "exit_codes": sorted({r["exit_code"] for r in runs}), "runs": runs}
    chatter = parse_case(LATENCY_CASE.split("[map]")[0] + '[[run]]\nname = "exact"\nmethod = "event"\n')
    scenes = [("sdof fig13 Omega 2.0", SDOF(beta=0.015, B=0.5e-3, R=0.9, Delta=0.5e-3), 2.0),
              ("sdof chatter 15.5 Hz", chatter.model_spec().build(), 15.5 / 7.6)]
    if beam:
        case, _ = load_case(_root() / "cases" / "rig-fe-neutral.toml")
        scenes.append(("beam rig-fe-neutral all modes 15.4 Hz", case.model_spec().build(), 15.4 / 7.6))
    out["time_limit"] = {}
    for name, model, W in scenes:
        r = _time_limit_overshoot(name, model, W, limit_s)
        out["time_limit"][name] = r
        say(f"point_time_limit_s = {limit_s:g}, {name}: point ended after {r['wall_time_s']:.3f} s "
            f"({r['calls']} calls of {r['chunk_periods']} periods)")
    out["cores"] = os.cpu_count()
    out["load_average"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    return out


def latency_goals(out: dict) -> list:
    """Goals of :func:`run_latency_bench`: Ctrl-C stops a run, and the wall-time limit ends a
    point, within about a second."""
    g = [goal(f"Ctrl-C stops {k.replace('_', ' ')} within {LATENCY_GOAL_S:g} s (SIGINT to exit, code 130)",
              f"{out[k]['sigint_to_exit_s']:.3f} s, exit {out[k]['exit_codes']}",
              out[k]["sigint_to_exit_s"] <= LATENCY_GOAL_S and out[k]["exit_codes"] == [130])
         for k in ("inline", "pool_2_workers")]
    g += [goal(f"point_time_limit_s overshoot within {LATENCY_GOAL_S:g} s ({name})", f"{r['overshoot_s']:.3f} s",
               r["status"] == "failed" and r["overshoot_s"] <= LATENCY_GOAL_S)
          for name, r in out["time_limit"].items()]
    return g


# ----------------------------------------------------------------------------- compile time
COMPILE_GOAL_S = 5.0   # issue 20: the quick start's first run compiles in <= 5 s

#: ``python -c COMPILE_PROBE EVENTS cli|code ARGS...``: runs ``vibeam ARGS`` (``cli``) or the
#: Python text ARGS[0] (``code``) with a listener on numba's ``"numba:compile"`` event and timers
#: around numba's cache loads and saves; one JSON line per event on the O_APPEND file EVENTS
#: (``os.write``, so forked pool workers, which inherit the listener, append their own lines)
COMPILE_PROBE = """
import json, os, sys, time
fd = os.open(sys.argv[1], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
def emit(**rec):
    rec["pid"] = os.getpid()
    os.write(fd, (json.dumps(rec) + "\\n").encode())
t_start = time.perf_counter()
emit(kind="main")
from numba.core import caching, event
def name_of(f):
    return f"{getattr(f, '__module__', '?')}.{getattr(f, '__qualname__', getattr(f, '__name__', repr(f)))}"
class Compiles(event.Listener):
    def __init__(self):
        self.stack = []         # [start, seconds of nested compilations] per open compilation
    def on_start(self, ev):
        self.stack.append([time.perf_counter(), 0.0])
    def on_end(self, ev):
        t0, nested = self.stack.pop()
        dt = time.perf_counter() - t0
        if self.stack:
            self.stack[-1][1] += dt
        args = tuple(ev.data.get("args") or ())
        emit(kind="compile", kernel=name_of(ev.data["dispatcher"].py_func), args=[str(a) for a in args],
             depth=len(self.stack),
             inclusive_s=dt, self_s=dt - nested)
event.register("numba:compile", Compiles())
os.register_at_fork(after_in_child=lambda: emit(kind="fork"))
def timed(method, kind):
    inner = getattr(caching.Cache, method)
    def wrapper(self, *a, **k):
        t0 = time.perf_counter()
        out = inner(self, *a, **k)
        emit(kind=kind, kernel=name_of(getattr(self, "_py_func", None)), seconds=time.perf_counter() - t0,
             hit=out is not None)
        return out
    setattr(caching.Cache, method, wrapper)
timed("load_overload", "load")
timed("save_overload", "save")
rc = 0
try:
    if sys.argv[2] == "cli":
        from vibeam.cli import main
        rc = main(sys.argv[3:])
    else:
        exec(compile(sys.argv[3], "<scenario>", "exec"), {"__name__": "__scenario__"})
finally:
    emit(kind="exit", seconds=time.perf_counter() - t_start)
sys.exit(rc)
"""

#: the first point of the rig's FE beam (``cases/rig-fe-neutral.toml``) with ``{n}`` modes, as
#: ``vibeam run`` builds its solver: the case's first frequency, two transient and two recorded
#: periods
FE_POINT = """
from pathlib import Path
import vibeam
from vibeam.case.schema import load_case
from vibeam.models import make_solver
case, _ = load_case(Path(vibeam.__file__).resolve().parent.parent / "cases" / "rig-fe-neutral.toml")
run = next(r for r in case.run if r.method == "event")
model = case.model_spec({{"n_modes": {n}}}).build()
W = float(case.sweep.grid(model.natural_frequency_hz)[0])
make_solver(model, "event", **case.run_settings(run)).point(W, None, 2, 2, case.sweep.samples_per_period)
"""

#: the first point of the quick start's SDOF scene (paper Fig. 7: beta 0.015, B 0.5e-3, Delta 0) on a
#: compliant stop, as ``vibeam run`` builds its solver: Kelvin-Voigt, stiffness 1e4, the dashpot of an
#: isolated impact's R = 0.8 (the event integrator's compliant specialisation)
COMPLIANT_POINT = """
from vibeam.models import SDOF, make_solver
from vibeam.models.compliant import LinearContact
m = SDOF(beta=0.015, B=0.5e-3, R=0.8, Delta=0.0, contact=LinearContact.from_restitution(1e4, 0.8))
make_solver(m, "event").point(1.8, None, 2, 2, 64)
"""

#: the scenarios of ``vibeam bench --compile``: (name, ``cli`` or ``code``, vibeam arguments or
#: Python text); ``{root}`` is the checkout, ``{out}`` a fresh output folder
COMPILE_SCENARIOS = (
    ("quick start: vibeam run cases/paper-fig7.toml", "cli",
     ["run", "{root}/cases/paper-fig7.toml", "--out", "{out}", "--no-plots", "--quiet"]),
    ("first compliant SDOF point (Kelvin-Voigt stop, paper-fig7 scene)", "code", COMPLIANT_POINT),
    ("first FE 2-mode point (rig-fe-neutral, n_modes = 2)", "code", FE_POINT.format(n=2)),
    ("first FE 4-mode point (rig-fe-neutral, n_modes = 4)", "code", FE_POINT.format(n=4)),
    ("first SDOF continuation: vibeam continue cases/paper-fig13-continuation.toml --quick", "cli",
     ["continue", "{root}/cases/paper-fig13-continuation.toml", "--quick", "--out", "{out}", "--no-plots",
      "--quiet"]),
    ("pooled SDOF continuation: vibeam continue cases/rig-tight-continuation.toml --quick --jobs 2", "cli",
     ["continue", "{root}/cases/rig-tight-continuation.toml", "--quick", "--jobs", "2", "--out", "{out}",
      "--no-plots", "--quiet"]),
)


def _short(sig: str, limit: int = 240) -> str:
    return sig if len(sig) <= limit else sig[:limit] + " ...)"


def _specialisation(kernel: str, args: list) -> str:
    """A readable name of a compiled specialisation: the event integrator's (``integrate_work``) by
    its compliant data (``cw``: None for a scene of Newton stops only; else the kinds of contact
    phase compiled, :class:`vibeam.models.core.phases.Compliant`'s ``lin`` and ``itab``: a second
    ``ContactPhases`` or ``Tableau`` beside ``ph`` and ``tab``), any other by its signature."""
    if kernel.endswith("core.integrator.integrate_work") and len(args) > 3:
        if args[3] == "none":
            return "Newton stops only (cw None)"
        kinds = [k for k, t in (("linear", "ContactPhases("), ("Runge-Kutta", "Tableau(")) if args[3].count(t) > 1]
        return f"with compliant stops ({' and '.join(kinds) or 'no'} contact phases)"
    return _short("(" + ", ".join(args) + ")", 120)


def _compile_summary(records: list, process_wall_s: float) -> dict:
    """One probed process (and its forked workers) from its event lines: compile time (the
    outermost compilations, nested ones are inside them), the kernel specialisations the work
    compiled (the outermost ones, each with the seconds of everything compiled for it), each
    specialisation with its own (``self_s``: less its nested compilations) and inclusive seconds,
    and the cache's loads and saves."""
    main = next(r["pid"] for r in records if r["kind"] == "main")
    comp = [r for r in records if r["kind"] == "compile"]
    loads = [r for r in records if r["kind"] == "load"]
    saves = [r for r in records if r["kind"] == "save"]
    ext = [r["seconds"] for r in records if r["kind"] == "exit" and r["pid"] == main]
    top = lambda rs: float(sum(r["inclusive_s"] for r in rs if r["depth"] == 0))   # noqa: E731
    workers = [r for r in comp if r["pid"] != main]
    per_kernel: dict = {}
    for r in comp:
        r["signature"] = "(" + ", ".join(r["args"]) + ")"
        per_kernel.setdefault(r["kernel"], {})[r["signature"]] = r["args"]
    several = {}
    for k, sigs in per_kernel.items():
        if len(sigs) > 1:        # the arguments whose types differ between the specialisations
            arglists = list(sigs.values())
            n = max(len(a) for a in arglists)
            at = {str(i): sorted({a[i] if i < len(a) else "-" for a in arglists}) for i in range(n)}
            several[k] = {"specialisations": len(sigs),
                          "differing_arguments": {i: t for i, t in at.items() if len(t) > 1}}
    kernels = sorted(({"kernel": r["kernel"], "signature": _short(r["signature"]), "n_args": len(r["args"]),
                       "none_args": [i for i, a in enumerate(r["args"]) if a == "none"],
                       "self_s": r["self_s"], "inclusive_s": r["inclusive_s"], "nested": r["depth"] > 0,
                       "process": "main" if r["pid"] == main else "worker"} for r in comp),
                     key=lambda k: -k["self_s"])
    outer = [{"kernel": r["kernel"], "specialisation": _specialisation(r["kernel"], r["args"]),
              "compile_s": r["inclusive_s"], "nested_compilations": 0,
              "process": "main" if r["pid"] == main else "worker"} for r in comp if r["depth"] == 0]
    i = 0
    for r in comp:               # events end innermost first: a top-level one closes its nested ones
        if r["depth"] == 0:
            i += 1
        elif i < len(outer):
            outer[i]["nested_compilations"] += 1
    return {"process_wall_s": process_wall_s, "probe_wall_s": ext[0] if ext else None,
            "kernel_specialisations": outer,
            "compile_s": top(comp), "compile_s_main": top([r for r in comp if r["pid"] == main]),
            "compile_s_workers": top(workers),
            "specialisations": len(comp), "specialisations_in_workers": len(workers),
            "worker_processes_compiling": len({r["pid"] for r in workers}),
            "dispatchers": len(per_kernel),
            "dispatchers_with_several_specialisations": several,
            "forked_workers": len({r["pid"] for r in records if r["kind"] == "fork"}),
            "cache_loads": sum(r["hit"] for r in loads), "cache_misses": sum(not r["hit"] for r in loads),
            "cache_loads_in_workers": sum(r["hit"] for r in loads if r["pid"] != main),
            "cache_load_s": float(sum(r["seconds"] for r in loads if r["hit"])),
            "cache_miss_s": float(sum(r["seconds"] for r in loads if not r["hit"])),
            "cache_saves": len(saves), "cache_save_s": float(sum(r["seconds"] for r in saves)),
            "kernels": kernels}


def _probe_compile(kind: str, payload, cache_dir, tmp, timeout: float = 1800.0) -> dict:
    """One scenario in a fresh interpreter under :data:`COMPILE_PROBE`, numba's cache in
    ``cache_dir``; returns :func:`_compile_summary` of its event lines."""
    import subprocess
    import uuid

    tmp = Path(tmp)
    marks = tmp / f"events-{uuid.uuid4().hex}.jsonl"
    out = tmp / f"out-{uuid.uuid4().hex}"
    args = [str(a).format(root=_root(), out=out) for a in payload] if kind == "cli" else [payload]
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", COMPILE_PROBE, str(marks), kind, *args], capture_output=True,
                       text=True, env=env, cwd=str(tmp), timeout=timeout)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"compile probe ({kind} {' '.join(args)[:200]}) exited {p.returncode}: "
                           f"{p.stderr.strip()[-500:]}")
    records = [json.loads(line) for line in marks.read_text().splitlines() if line.strip()]
    return _compile_summary(records, wall)


def run_compile_bench(scenarios=None, log=None) -> dict:
    """Cold and warm compile time of the shipped scenarios (issue 20's compile goal).

    Each scenario (default :data:`COMPILE_SCENARIOS`) runs twice, each time in a fresh
    interpreter under :data:`COMPILE_PROBE`: first with an empty temporary
    ``NUMBA_CACHE_DIR`` (cold: every kernel it uses is compiled and saved), then again on
    that cache (warm: loaded, nothing should compile).  Reported per run: the process's
    wall time, the compile time (the outermost ``"numba:compile"`` events; a kernel's
    callees compile inside it), every specialisation compiled (kernel, signature, its own
    and its inclusive seconds, main process or pool worker; sorted by own cost), the
    specialisations compiled in forked pool workers, and the cache's loads and saves.
    Measured, never asserted.

    Returns
    -------
    dict
        JSON-ready: ``scenarios`` (name -> ``{"cold": ..., "warm": ...}``), ``kernel_specialisations``
        (name -> the outermost specialisations compiled cold, each with the seconds of everything
        compiled for it: the event integrator's ``integrate_work`` for Newton stops only or with
        compliant stops and its work arrays' ``new_work``, the shooting problem's ``shoot``), ``goal_s``, ``cores``, ``load_average``, ``numba``.
    """
    import tempfile

    import numba

    say = log or (lambda m: None)
    out = {"goal_s": COMPILE_GOAL_S, "numba": numba.__version__, "cores": os.cpu_count(),
           "load_average_before": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
           "note": "compile_s: numba's 'numba:compile' events (cache misses), outermost ones summed; self_s of a "
                   "specialisation excludes the kernels compiled inside it; compile_s sums the main process and the "
                   "pool workers (which compile side by side, so it can exceed the wall time); cold: empty "
                   "NUMBA_CACHE_DIR, warm: the same cache in a second fresh process", "scenarios": {}}
    for name, kind, payload in (scenarios or COMPILE_SCENARIOS):
        with tempfile.TemporaryDirectory() as tmp:
            cache = Path(tmp) / "numba-cache"
            cache.mkdir()
            cold = _probe_compile(kind, payload, cache, tmp)
            say(f"{name}: cold {cold['process_wall_s']:.2f} s, compiling {cold['compile_s']:.2f} s "
                f"({cold['specialisations']} specialisations, {cold['specialisations_in_workers']} in pool workers)")
            warm = _probe_compile(kind, payload, cache, tmp)
            say(f"{name}: warm {warm['process_wall_s']:.2f} s, compiling {warm['compile_s']:.2f} s, "
                f"{warm['cache_loads']} cache loads in {warm['cache_load_s']:.2f} s")
        out["scenarios"][name] = {"kind": kind, "command": "vibeam " + " ".join(payload) if kind == "cli" else
                                  payload.strip(), "cold": cold, "warm": warm}
        for k in cold["kernel_specialisations"]:
            say(f"  cold: {k['kernel'].rsplit('.', 1)[-1]} [{k['specialisation']}] {k['compile_s']:.2f} s "
                f"({k['nested_compilations']} nested compilations, {k['process']})")
    # the figure of issue 20: the cold compile time of each kernel specialisation a scenario uses
    out["kernel_specialisations"] = {name: [{"kernel": k["kernel"], "specialisation": k["specialisation"],
                                             "cold_compile_s": k["compile_s"]}
                                            for k in v["cold"]["kernel_specialisations"]]
                                     for name, v in out["scenarios"].items()}
    out["load_average_after"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    return out


def compile_goals(out: dict) -> list:
    """Goals of :func:`run_compile_bench` (issue 20): the quick start compiles in
    :data:`COMPILE_GOAL_S`; pool workers never compile; a warm cache compiles nothing."""
    sc = out["scenarios"]
    g = []
    quick = next((k for k in sc if k.startswith("quick start")), None)
    if quick is not None:
        c = sc[quick]["cold"]
        g.append(goal(f"quick start (`vibeam run cases/paper-fig7.toml`, cold cache) compiles in <= "
                      f"{out['goal_s']:g} s", f"{c['compile_s']:.2f} s in {c['specialisations']} specialisations "
                      f"({c['process_wall_s']:.1f} s wall)", c["compile_s"] <= out["goal_s"]))
    for k, v in sc.items():
        if "compliant" in k or k.startswith(("quick start", "first FE")):
            want = "with compliant stops" if "compliant" in k else "Newton stops only"
            got = [f"{s['kernel'].rsplit('.', 1)[-1]} [{s['specialisation']}]" for s in v["cold"]["kernel_specialisations"]]
            # the event integrator (integrate_work) once, of the kind the scene needs; beside it only
            # the sizing and allocation of its work arrays (substeps, new_work, compliant_work)
            integ = [s for s in got if not s.startswith(("substeps [", "new_work [", "compliant_work ["))]
            g.append(goal(f"{k.split(':')[0].split(' (')[0]} compiles the event integrator's specialisation it uses "
                          f"({want}) and no other", ", ".join(got) or "nothing",
                          len(integ) == 1 and integ[0].startswith("integrate_work [" + want)))
    n_w = {k: v["cold"]["specialisations_in_workers"] + v["warm"]["specialisations_in_workers"] for k, v in sc.items()}
    forked = sum(v["cold"]["forked_workers"] + v["warm"]["forked_workers"] for v in sc.values())
    loads = sum(v["warm"]["cache_loads_in_workers"] for v in sc.values())
    g.append(goal("pool workers never compile (every scenario, cold and warm)",
                  ", ".join(f"{k.split(':')[0].split(' (')[0]}: {n}" for k, n in n_w.items())
                  + f" ({forked} workers forked; {loads} cache loads in workers with a warm cache)",
                  not any(n_w.values())))
    n_warm = {k: v["warm"]["specialisations"] for k, v in sc.items()}
    g.append(goal("a warm cache compiles nothing (every scenario)",
                  ", ".join(f"{k.split(':')[0].split(' (')[0]}: {n}" for k, n in n_warm.items()),
                  not any(n_warm.values())))
    return g
