"""The work estimate that decides inline against pool (issue 42, item 9): a scene's stop laws
weigh its event grid's steps by what their contact phases cost (``work_factor``: Newton 1,
Kelvin-Voigt 12, the hysteretic-Hertz family 300, calibrated on the cell matrix's scenes by
``vibeam bench --estimate``, which prints each scene's run time over its estimate: 0.52-9.4
after, 25-1000 before).  These tests are deterministic (no timing): the estimate's arithmetic
and the decision it gives."""
from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import vibeam
from vibeam.engine.jobs import case_jobs, estimate_work
from vibeam.runner import _lines, plan_execution

ROOT = Path(__file__).resolve().parents[1]
RIG = tomllib.loads((ROOT / "cases" / "rig-fe-neutral.toml").read_text())["model"]


def _beam(lower_law: dict | None, n_modes: int = 4) -> dict:
    """The issue's scene: the rig FE beam with 4 modes, a lower stop 0.3 mm below the tip with
    ``lower_law`` (None: Newton's law, R 0.5), swept up and down over 14-17 Hz."""
    model = dict(RIG, n_modes=n_modes, gap_lower_mm=0.3)
    model["contact_lower"] = lower_law or {"law": "restitution", "R": 0.5}
    return {"name": "estimate", "model": model,
            "sweep": {"frequency_hz": [14.0, 17.0, 8], "direction": "both", "transient_periods": 100,
                      "record_periods": 32},
            "run": [{"name": "event", "method": "event"}]}


def _plan(d: dict) -> tuple:
    case = vibeam.load_case(d)
    jobs_ = case_jobs(case)
    todo = [l for j in jobs_ for l in _lines(j)]
    return estimate_work(case, jobs_), plan_execution(case, jobs_, todo, 2, None)


@pytest.mark.parametrize("law,factor", [("hunt_crossley", 300.0), ("lankarani_nikravesh", 300.0),
                                        ("linear", 12.0)])
def test_a_compliant_stop_weighs_the_estimate_by_its_law(law, factor):
    """Same grid, same steps; the time estimate (``work_min``) is the law's factor times the
    Newton scene's, exactly (one factor per point: the largest of the scene's laws)."""
    k = {"linear": 3e5, "hunt_crossley": 3e8, "lankarani_nikravesh": 3e8}[law]
    w_newton, _ = _plan(_beam(None))
    w_law, _ = _plan(_beam({"law": law, "stiffness_n_m": k}))
    assert w_law["steps_min"] == w_newton["steps_min"]          # the limits count steps, unchanged
    assert w_law["work_min"] == pytest.approx(factor * w_newton["work_min"], rel=1e-12)


def test_a_hunt_crossley_beam_goes_to_the_pool_and_a_newton_one_runs_inline():
    """Issue 42, item 9: a 4-mode beam with a Hunt-Crossley lower stop was estimated '~0.14 s on
    one core', ran inline and took 28.8 s with the second core idle.  Now its estimate is over a
    second and the plan is the pool (no 'inline first' reason); the same scene with a Newton
    lower stop stays inline (its grid is a fraction of a second: measured 0.005-0.015 s for 6
    points of the 2-mode beam, ``vibeam bench --estimate``)."""
    w, (n, why) = _plan(_beam({"law": "hunt_crossley", "stiffness_n_m": 3e8}))
    assert n == 2 and why == "", (w, why)
    _, (n, why) = _plan(_beam(None))
    assert n == 2 and why.startswith("small sweep"), why
