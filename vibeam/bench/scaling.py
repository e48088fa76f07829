"""``vibeam bench --scaling``: how the cost of a sweep grows with the periods simulated and the
retained modes (:func:`run_scaling_bench`)."""
from __future__ import annotations

import statistics
import time

import numpy as np

from vibeam.bench.common import build_scene, goal
from vibeam.engine.sweep import Sweep, run_sweep
from vibeam.models import make_solver
from vibeam.models.scene import outputs


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


def _time_sweep(case, model, settings, points: int, n_periods: int, repeats: int,
                record_fraction: float | None = None, record: int | None = None,
                min_total_s: float = 0.25, max_repeats: int = 25, recurrence: bool = False) -> tuple[float, dict]:
    """Median wall time of an inline (jobs=1) event sweep of ``points`` frequencies spread
    over the case's grid with ``n_periods`` = transient + record periods per point, after
    a warm-up; the case's direction, continuation, samples per period and period rtol; every
    period integrated unless ``recurrence`` (the solver's exact recurrence)."""
    cs = case.sweep
    full = cs.grid(outputs(model).natural_frequency_hz)
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
        case, model, settings, t_build = build_scene(fname, over)
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
    case, model, settings, t_build = build_scene(fname, {"n_modes": "static"})
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
        case, model, settings, t_build = build_scene(fname, {"n_modes": m})
        n = int(model.system.omega.shape[0])
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


def scaling_goals(out: dict) -> list:
    """Goals of :func:`run_scaling_bench`: linear in the periods simulated, at most linear in the
    retained modes."""
    g = [goal(f"cost linear in the periods simulated ({k}: exponent 0.9 .. 1.1 from {n0} periods, where a "
              f"point's fixed cost is below 10 %; {out['summary']['exponent_periods'][k]:.3f} over the whole ladder)",
              f"{p:.3f}", 0.9 <= p <= 1.1, timing=True)
         for k, (p, n0) in out["summary"]["exponent_periods_beyond_overhead"].items()]
    e = out["summary"].get("exponent_modes_n_ge_4")
    if e is not None:
        g.append(goal("cost at most linear in the retained modes (exponent <= 1.1 from 4 modes)", f"{e:.3f}",
                      e <= 1.1, timing=True))
    return g
