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
"""
from __future__ import annotations

import json
import statistics
import time

import numpy as np


def _sweep(model, method, Omega, n_transient, n_record, **settings):
    from .models import make_solver
    from .sweep import Sweep, run_sweep

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
    from .models import SDOF

    model = SDOF(beta=0.015, B=0.5e-3, R=0.9, Delta=0.0)
    Omega = np.linspace(1.5, 2.5, points)
    n_tr = periods - record
    _sweep(model, "event", Omega[:2], 2, 2)  # warm-up (compilation / cache load)
    times = []
    for _ in range(repeats):
        t, ev = _sweep(model, "event", Omega, n_tr, record)
        times.append(t)
    t_event = statistics.median(times)
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
        "error_measure": "max |Q - Q_ref| / max Q_ref over the sweep; Q_ref from event with "
                         f"{reference_periods} transient periods",
        "goal": "event sweep well under 1 s, >= 300x faster than direct, >= 1000x smaller error",
    }


def main_bench(args) -> int:
    out = run_bench(points=args.points, periods=args.periods, repeats=args.repeats,
                    direct_points=args.direct_points)
    print(json.dumps(out, indent=2))
    return 0
