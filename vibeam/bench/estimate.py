"""``vibeam bench --estimate``: the work estimate that decides inline against pool, against the run
time it estimates (:func:`run_estimate_bench`)."""
from __future__ import annotations

import contextlib
import io
import tempfile
import tomllib

import numpy as np

from vibeam.api import case_text, load_case
from vibeam.bench.common import goal, root
from vibeam.engine.jobs import estimate_work
from vibeam.models.registry import IMPLEMENTED_LAWS, law_family
from vibeam.runner import STEP_SECONDS, run_case


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
    if fid == "sdof":
        model = {"fidelity": "sdof", "beta": 0.015, "B": 5e-3, "R": 0.8, "Delta": 0.002}
        sweep = {"Omega": [0.75, 2.5, 6]}
        lower, key = ("Delta_lower", 0.003), "stiffness"
    else:
        model = dict(tomllib.loads((root() / "cases" / "rig-fe-neutral.toml").read_text())["model"], n_modes=2)
        sweep = {"frequency_hz": [10.0, 20.0, 6]}
        lower, key = ("gap_lower_mm", 0.3), "stiffness_n_m"

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
                 f"{out['ratio_geomean']:.2g})", 1.0 / f <= out["ratio_min"] and out["ratio_max"] <= f,
                 timing=True)]
