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

    from .case import EffectsSpec, load_case
    from .effects import wrap_solver
    from .models import make_solver
    from .sweep import Sweep, run_sweep

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


def main_bench(args) -> int:
    if getattr(args, "effects", False):
        print(json.dumps(run_effects_bench(), indent=2))
        return 0
    out = run_bench(points=args.points, periods=args.periods, repeats=args.repeats,
                    direct_points=args.direct_points)
    print(json.dumps(out, indent=2))
    return 0
