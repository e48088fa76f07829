"""``vibeam bench --cli``: the kernel's speed as ``vibeam run`` shows it, against ``direct``
(:func:`run_cli_bench`)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from vibeam.bench.common import goal, root, timed_sweep
from vibeam.case.schema import load_case
from vibeam.models.scene import outputs


def _direct_time_per_period(points: int, periods: int = 500, record: int = 64, case: str | None = None) -> dict:
    """Seconds per point and forcing period of ``direct`` (solve_ivp RK23, rtol 1e-4, atol 1e-8,
    with events) on ``points`` frequencies spread over the case's grid (Fig. 7 scene),
    ``periods - record`` transient periods each, from rest (inline, one core)."""
    case, _ = load_case(case or root() / "cases" / "paper-fig7.toml")
    model = case.model_spec().scene()
    grid = case.sweep.grid(outputs(model).natural_frequency_hz)
    Om = np.linspace(grid.min(), grid.max(), points)
    t, res = timed_sweep(model, "direct", Om, periods - record, record, solver="RK23", rtol=1e-4, atol=1e-8)
    return {"time_s": t, "points": points, "periods_per_point": periods, "s_per_point_period": t / (points * periods),
            "failed": int(np.sum(res.data["status"] == "failed"))}


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
    path = str(case or root() / "cases" / "paper-fig7.toml")
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
                         f"{out['speedup_including_kernel_load']:.0f}x with the kernel load)", ratio >= goal_ratio,
                         timing=True)]
    return out
