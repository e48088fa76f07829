"""``vibeam bench --continuation``: the continuation of a period-1 branch against its goal and
against the sweep of equal accuracy it replaces, for the SDOF (:func:`run_continuation_bench`) and
the all-modes beam of the shipped rig (:func:`run_beam_continuation_bench`)."""
from __future__ import annotations

import os
import statistics
import time

import numpy as np

from vibeam.bench.common import build_scene
from vibeam.models import EventSolver, shooting_problem, make_solver
from vibeam.models.builders.sdof import sdof
from vibeam.models import BeamEventSolver
from vibeam.models.orbits.continuation import Settings, start_point, trace
from vibeam.models.scene import outputs


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
    log = log or (lambda m: None)
    m = sdof(0.015, 0.5e-3, 0.7e-3, R=0.9)      # beta, B, Delta, R
    prob = shooting_problem(m)
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
    Q_ref = np.empty_like(grid)
    for i, W in enumerate(grid):
        k = int(np.argmin(np.abs(W_b - W)))
        pt, _ = start_point(prob, a["state"][upper][k], W, 1, 1.5, 2.5)
        Q_ref[i] = pt.shot.gap - pt.shot.q_min
    rows, equal = _sweep_at_equal_accuracy(make_solver(m, "event"), 0.7e-3, grid, Q_ref,
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


BEAM_CONTINUATION_GOAL_S = 10.0   # issue 10: all-modes branch of the 24-element rig over 14-17 Hz


def _timed_trace(prob, x0, p0, lo, hi, direction, settings, repeats):
    """Median wall and CPU time of :func:`trace` (after a warm-up call), shots per run, the
    branches of the last run."""
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
    log = log or (lambda m: None)
    out: dict = {}
    st = Settings()
    case, model, _, _ = build_scene("rig-fe-neutral.toml", {"n_modes": "all"})
    f_ref = model.system.reference_hz
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
    rows, equal = _sweep_at_equal_accuracy(make_solver(model, "event"), outputs(model).Delta, grid, Q_ref,
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
    case, model, _, _ = build_scene("rig-fe-tight.toml", {"n_modes": "all"})
    f_ref = model.system.reference_hz
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
