"""``vibeam bench --fit``: the cost of ``vibeam fit`` against its goal (:func:`run_fit_bench`)."""
from __future__ import annotations

import time

import numpy as np

from vibeam.bench.common import root
from vibeam.case.schema import load_case
from vibeam.identify.fit import fit_case, synthetic_reference


def run_fit_bench(points: int = 30, jobs: int = 2, sigma_mm: float = 0.01, seed: int = 1,
                  goal_s: float = 10.0) -> dict:
    """Cost of ``vibeam fit`` (:func:`vibeam.identify.fit.fit_case`): a two-parameter (gain, R) fit of the
    SDOF rig scene (``rig-neutral``, 400 + 64 periods) to ``points`` synthetic points (14-17 Hz,
    up, Gaussian noise ``sigma_mm``) from a start 10 % off, on a local pool of ``jobs`` workers
    (its start-up included), against the goal; and the same for R alone on the FE beam with
    2 modes (``rig-fe-neutral``).  Returns a JSON-ready dict; prints no assertion."""
    cases = root() / "cases"
    f = np.linspace(14.0, 17.0, points)
    out = {"points": points, "jobs": jobs, "noise_mm": sigma_mm, "goal_s": goal_s, "fits": {}}
    scenes = (("sdof gain,R", "rig-neutral.toml", None, {"gain": 5.16e-4, "R": 0.72}, {"gain": 4.64e-4, "R": 0.65}),
              ("FE 2 modes R", "rig-fe-neutral.toml", "FE 2 modes", {"R": 0.72}, {"R": 0.65}))
    for label, fname, run, truth, start in scenes:
        case, _ = load_case(cases / fname)
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
