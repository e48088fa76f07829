"""``vibeam bench --settling``: forcing periods simulated per sweep point, with the fixed transient and
with ``[sweep] settle = true`` (issue 60; :func:`run_periods_bench`).

A point simulates its transient (``transient_periods_used``) and its record, continued to
``statistics_periods`` where it is not periodic (``record_periods`` of the point then covers that
window); the Lyapunov shots, when asked for, come on top and are not counted.  Counted from the
points' own outputs, so the figures are those of the engine's actual schedule.
"""
from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from vibeam.analysis.uncertainty import plan_samples
from vibeam.bench.common import goal
from vibeam.bench.uncertainty import CASE as UNCERTAINTY_CASE
from vibeam.case.schema import load_case, parse_case
from vibeam.engine.jobs import case_jobs, make_job
from vibeam.engine.sweep import load_kernels, plan_lines, run_lines

CASES = Path(__file__).resolve().parents[2] / "cases"


def periods_per_point(rows) -> np.ndarray:
    """Periods each point simulated: ``transient_periods_used + record_periods``, shape (points,)."""
    return np.array([int(r.get("transient_periods_used", 0)) + int(r.get("record_periods", 0)) for r in rows])


def _case_rows(case, settle: bool, jobs) -> tuple[list, float]:
    lines = []
    for job in case_jobs(case):
        lines.extend(plan_lines(job.solver, replace(job.sweep, settle=settle), job.run.name))
    load_kernels(lines)
    t0 = time.perf_counter()
    out = run_lines(lines, jobs=jobs)
    return [r for rows in out.values() for r in rows], time.perf_counter() - t0


def _summary(rows, seconds) -> dict:
    p = periods_per_point(rows)
    return {"points": int(p.size), "periods_mean": float(p.mean()), "periods_max": int(p.max()),
            "seconds": seconds}


def run_periods_bench(samples: int = 16, jobs: int | None = 1, log=None) -> dict:
    """Periods per point (mean, max) and wall time of the Fig. 7 sweep (``cases/paper-fig7.toml``),
    the tight rig's ladder (``cases/rig-fe-tight.toml``, quick variant: its five rungs at 5
    frequencies both ways) and ``vibeam bench --uncertainty``'s scene (``samples`` samples), each with
    the fixed transient and with ``settle = true``.  Kernels are loaded first (not timed)."""
    say = log or (lambda *_: None)
    scenes = {}
    for name, case in (("paper-fig7", load_case(CASES / "paper-fig7.toml")[0]),
                       ("rig-fe-tight --quick", load_case(CASES / "rig-fe-tight.toml")[0].quick_variant())):
        scenes[name] = {}
        for settle in (False, True):
            rows, s = _case_rows(case, settle, jobs)
            scenes[name]["settle" if settle else "fixed"] = _summary(rows, s)
            say(f"{name} ({'settle' if settle else 'fixed'}): {scenes[name]['settle' if settle else 'fixed']}")
    name = f"uncertainty scene ({samples} samples)"
    scenes[name] = {}
    for settle in (False, True):
        text = UNCERTAINTY_CASE.format(samples=samples)        # (the fixed transient)
        if settle:
            text = text.replace("[sweep]\n", "[sweep]\nsettle = true\n")
        case = parse_case(text)
        lines = []
        for t in plan_samples(case).tasks:        # the design's units, as sweeps whose points are kept whole
            job = make_job(case, t.spec_run, dict(t.spec_run.model, **dict(t.values)), t.index)
            lines += [replace(ln, key=f"{t.key}-{ln.key}") for ln in plan_lines(job.solver, job.sweep, t.run)]
        load_kernels(lines[:1])
        t0 = time.perf_counter()
        out = run_lines(lines, jobs=jobs)
        rows = [r for rs in out.values() for r in rs]
        scenes[name]["settle" if settle else "fixed"] = _summary(rows, time.perf_counter() - t0)
        say(f"{name} ({'settle' if settle else 'fixed'}): {scenes[name]['settle' if settle else 'fixed']}")
    return {"what": "forcing periods simulated per point (transient + record, continued to statistics_periods "
                    "where not periodic), fixed transient against settle = true", "jobs": jobs, "scenes": scenes}


def periods_goals(out: dict) -> list:
    """No goal of its own: the ratios are printed (``settle`` shortens every scene's mean)."""
    return [goal(f"settle = true simulates fewer periods per point than the fixed transient ({k})",
                 f"mean {v['fixed']['periods_mean']:.1f} -> {v['settle']['periods_mean']:.1f} "
                 f"(max {v['fixed']['periods_max']} -> {v['settle']['periods_max']})",
                 v["settle"]["periods_mean"] < v["fixed"]["periods_mean"])
            for k, v in out["scenes"].items()]
