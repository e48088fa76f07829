"""``vibeam bench --shooting``: the beam's periodic-orbit shots and Newton solves against the event
solver (:func:`run_shooting_bench`)."""
from __future__ import annotations

import statistics
import time

import numpy as np

from vibeam.bench.common import build_scene, goal
from vibeam.models.system import particular
from vibeam.models import BeamEventSolver, make_solver
from vibeam.models import shooting_problem


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
    """Cost of the beam's periodic-orbit shooting (the scene's :class:`vibeam.models.core.scene_shooting.SceneShooting`).

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
    out: dict = {"shot": {}, "newton_vs_event": {}, "frc": {}}
    t_all = time.perf_counter()
    built: dict = {}

    def scene(fname, nm):
        if (fname, nm) not in built:
            built[fname, nm] = build_scene(fname, {"n_modes": nm})
        return built[fname, nm]

    scenes = {"rig-fe-neutral 15.5 Hz": ("rig-fe-neutral.toml", 15.5),
              "rig-fe-tight 13 Hz": ("rig-fe-tight.toml", 13.0)}
    for label, (fname, f_hz) in scenes.items():
        row = {}
        for nm in modes:
            case, model, settings, _ = scene(fname, nm)
            W = f_hz / model.system.reference_hz
            x0 = BeamEventSolver(model).point(W, None, 300, 1, 1).final_state[:-1]
            prob = shooting_problem(model, Omega=W)
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
        W = 15.5 / model.system.reference_hz
        sy = model.system
        a, b = particular(sy.damping, sy.omega ** 2, sy.participation, W**2 * sy.base_amplitude, W)
        prob = shooting_problem(model, Omega=W)
        t0 = time.perf_counter()
        x, s, it = _newton(prob, np.concatenate([b, W * a]), W)
        t_newton = time.perf_counter() - t0
        K = 400
        sol = make_solver(model, "event", record_modal_states=True)
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
    grid = np.linspace(14.0, 17.0, frc_points) / model.system.reference_hz
    prob = shooting_problem(model, Omega=grid[0])
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
    sol = make_solver(model, "event", **settings)
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
                 f"{f['ratio_sweep_to_newton_per_point']:.2f}x", f["ratio_sweep_to_newton_per_point"] > 1,
                 timing=True)]
