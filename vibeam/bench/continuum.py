"""``vibeam bench --continuum``: what the top rung of the ladder costs (issue 59; :func:`run_continuum_bench`).

* **Build**: the rig's continuum of ``cases/rig-continuum.toml`` (20-node hexahedra of 2.5 mm, one
  layer: f1 and f2 within 0.3 % of the mesh-converged ones, ``models/builders/continuum.py``) built
  cold into an empty model cache (assembly, reduction with the rigid disc stack, ARPACK modes), then
  loaded from that cache by a second build.  Goals: at most :data:`BUILD_GOAL_S` s and
  :data:`LOAD_GOAL_S` s on 2 cores.
* **Sweep**: the neutral-gap scene (gap 0, R = 0.72, every point period-1: no chatter, so both
  models integrate the same kind of motion) swept over the same band of Omega = f / f1 by the
  continuum with ``n_modes`` modes and by the calibrated FE beam rung with as many modes
  (``cases/rig-fe-neutral.toml``); the seconds per point and per impact integrated (the impacts
  counted from each point's ``impacts_per_period`` over the periods it simulated) and their ratio.
  Goal: the continuum costs per impact what the beam does, within :data:`SWEEP_RATIO_GOAL`: both are
  the same N-mode event kernel; only the modal data differ.

Kernels are loaded (or compiled) by a first untimed sweep of each model.
"""
from __future__ import annotations

import os
import tempfile
import time
from contextlib import contextmanager

import numpy as np

from vibeam.bench.common import goal, root
from vibeam.bench.periods import periods_per_point
from vibeam.case.schema import load_case
from vibeam.case.structure import continuum_model
from vibeam.engine.jobs import case_jobs
from vibeam.engine.sweep import load_kernels, plan_lines, run_lines

#: goals of issue 59 (done-when 5)
BUILD_GOAL_S = 30.0
LOAD_GOAL_S = 1.0
#: continuum / beam seconds per impact, same modes, same Omega band
SWEEP_RATIO_GOAL = 1.25


@contextmanager
def _cache_in(folder):
    old = os.environ.get("VIBEAM_CACHE_DIR")
    os.environ["VIBEAM_CACHE_DIR"] = str(folder)
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("VIBEAM_CACHE_DIR", None)
        else:
            os.environ["VIBEAM_CACHE_DIR"] = old


def _one_run(case, run_name: str, model: dict, band_hz, points: int):
    """``case`` with one run (its model table ``model`` merged over the run's) on an up sweep of
    ``points`` frequencies over ``band_hz``, transient 200 and record 16 periods."""
    data = case.model_dump()
    run = next(r for r in data["run"] if r["name"] == run_name)
    run["model"] = dict(run.get("model") or {}, **model)
    data["run"] = [run]
    data["sweep"] = dict(data["sweep"], frequency_hz=[float(band_hz[0]), float(band_hz[1]), int(points)],
                         direction="up", transient_periods=200, record_periods=16)
    return type(case).model_validate(data)


def _sweep(case, repeats: int) -> dict:
    lines = [ln for job in case_jobs(case) for ln in plan_lines(job.solver, job.sweep, job.run.name)]
    load_kernels(lines)
    run_lines(lines, jobs=1)                                  # warm: kernels and caches, not timed
    times, rows = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = run_lines(lines, jobs=1)
        times.append(time.perf_counter() - t0)
        rows = [r for rs in out.values() for r in rs]
    t = float(np.median(times))
    per = periods_per_point(rows)
    ipp = np.array([float(r.get("impacts_per_period", 0.0)) for r in rows])
    impacts = float(np.nansum(ipp * per))
    status = [str(r.get("status", "ok")) for r in rows]
    return {"points": len(rows), "seconds": t, "s_per_point": t / len(rows),
            "us_per_impact": 1e6 * t / max(impacts, 1.0), "impacts": impacts,
            "periods": [int(x) for x in per], "status_ok": status.count("ok")}


def run_continuum_bench(n_modes: int = 4, points: int = 31, repeats: int = 3, log=None) -> dict:
    """The continuum's build, cached load and sweep cost against the beam's (module docstring).

    Parameters
    ----------
    n_modes : int
        Modes of both models in the sweep comparison.
    points, repeats : int
        Frequencies of the sweep; timed repetitions (median).

    Returns
    -------
    dict
        ``build`` (cold and cached: seconds, mesh, DOFs, stage timings), ``sweep`` (``continuum``,
        ``beam``: seconds, per point, per impact; ``ratio_per_impact``, ``ratio_per_point``).
    """
    say = log or (lambda *_: None)
    cases = root() / "cases"
    cont_case = load_case(cases / "rig-continuum.toml")[0]
    beam_case = load_case(cases / "rig-fe-neutral.toml")[0]
    out: dict = {"n_modes": n_modes}
    with tempfile.TemporaryDirectory() as d, _cache_in(d):
        spec = cont_case.model_spec({"system": {"n_modes": n_modes}})
        say("continuum: cold build into an empty cache")
        t0 = time.perf_counter()
        _, cold, _ = continuum_model(spec)
        t_cold = time.perf_counter() - t0
        t0 = time.perf_counter()
        _, warm, _ = continuum_model(spec)
        t_warm = time.perf_counter() - t0
        out["build"] = {"cold_s": t_cold, "cold_built": bool(cold.built), "cold_stages_s": dict(cold.timings_s),
                        "cached_s": t_warm, "cached_loaded": not warm.built, "n_dofs": int(cold.n_dofs),
                        "n_cells": int(cold.n_cells), "frequencies_hz": [float(f) for f in cold.frequencies_hz[:4]],
                        "summary": cold.summary()}
        say(cold.summary())
        say(warm.summary())
        f1_cont = float(cold.frequencies_hz[0])
        f1_beam = 7.6                                   # rig-fe-neutral's calibrated f1 ([model.calibrate])
        band_omega = (14.0 / f1_beam, 17.0 / f1_beam)   # the FE ladder's 14-17 Hz, as Omega = f / f1
        neutral = {"stops[0].gap_mm": 0.0, "stops[0].law.R": 0.72, "system": {"n_modes": n_modes},
                   "excitation": {"amplitude_mm": 0.086604}}
        cc = _one_run(cont_case, "continuum 4 modes", neutral,
                      (band_omega[0] * f1_cont, band_omega[1] * f1_cont), points)
        bc = _one_run(beam_case, "FE 4 modes", {"n_modes": n_modes},
                      (band_omega[0] * f1_beam, band_omega[1] * f1_beam), points)
        say(f"sweeps: continuum and FE beam, {n_modes} modes, {points} points over Omega "
            f"{band_omega[0]:.3f}..{band_omega[1]:.3f}")
        out["sweep"] = {"omega_band": list(band_omega), "continuum": _sweep(cc, repeats), "beam": _sweep(bc, repeats)}
    s = out["sweep"]
    s["ratio_per_impact"] = s["continuum"]["us_per_impact"] / s["beam"]["us_per_impact"]
    s["ratio_per_point"] = s["continuum"]["s_per_point"] / s["beam"]["s_per_point"]
    return out


def continuum_goals(out: dict) -> list:
    """Build <= 30 s, cached load <= 1 s, the sweep per impact within 1.25x of the beam's."""
    b, s = out["build"], out["sweep"]
    return [goal(f"build the rig's continuum ({b['n_dofs']} DOFs) cold in <= {BUILD_GOAL_S:g} s",
                 f"{b['cold_s']:.2f} s", b["cold_built"] and b["cold_s"] <= BUILD_GOAL_S, timing=True),
            goal(f"load it from the model cache in <= {LOAD_GOAL_S:g} s", f"{b['cached_s']:.3f} s",
                 b["cached_loaded"] and b["cached_s"] <= LOAD_GOAL_S, timing=True),
            goal(f"sweep cost per impact of the continuum within {SWEEP_RATIO_GOAL:g}x of the FE beam's with "
                 f"{out['n_modes']} modes",
                 f"{s['continuum']['us_per_impact']:.2f} us against {s['beam']['us_per_impact']:.2f} us per impact "
                 f"(x{s['ratio_per_impact']:.2f}; per point x{s['ratio_per_point']:.2f})",
                 s["ratio_per_impact"] <= SWEEP_RATIO_GOAL, timing=True)]
