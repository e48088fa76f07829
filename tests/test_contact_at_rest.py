"""A compliant stop touched at rest: the contact is one contact, not a round-off pair.

Found on the rig FE beam (2 modes, a Kelvin-Voigt stop of 1e5 N/m at the attached mass with a
zero gap, from rest at forcing phase 0): the force k g + c g' and its rate are zero at the start,
and the event integrator's exit scan took a crossing of zero by round-off for the contact's end,
recording a contact of duration 5.4e-17 and entering the stop again at once (3 entries against
the direct solver's 2).  The exit of a contact whose force and rate are zero to round-off is now
the force's fall below that round-off (:func:`vibeam.models.core.contact_phase.linear_step`).

The oracle is the direct solver (solve_ivp, DOP853 at rtol 1e-10, with the laws' events: no
code shared with the event integrator but the model).  Entry times agree to 1e-7 of the forcing
period (the direct solver's event location at rtol 1e-10; measured 1e-11 on the beam), and no
contact is shorter than 1e-9 of the period (a real contact of these scenes lasts a quarter of it
or more).
"""
from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

import vibeam

ROOT = Path(__file__).resolve().parents[1]


def _case(fid: str, law: str) -> dict:
    if fid == "beam":
        model = tomllib.loads((ROOT / "cases" / "rig-fe-contact.toml").read_text())["model"]
        model = copy.deepcopy(model)
        model["n_modes"] = 2
        model["contact"] = {"law": law, "stiffness_n_m": {"linear": 1e5, "hunt_crossley": 1e8}[law]}
        sweep = {"frequency_hz": [15.4, 15.4, 1], "transient_periods": 0, "record_periods": 2}
    else:
        model = {"fidelity": "sdof", "beta": 0.015, "B": 5e-3, "R": 0.8, "Delta": 0.0,
                 "contact": {"law": law, "stiffness": {"linear": 1e4, "hunt_crossley": 1e5}[law]}}
        sweep = {"Omega": [2.0, 2.0, 1], "transient_periods": 0, "record_periods": 2}
    runs = [{"name": "event", "method": "event"},
            {"name": "direct", "method": "direct", "solver": "DOP853", "rtol": 1e-10, "atol": 1e-13}]
    return {"name": f"at-rest-{fid}-{law}", "model": model, "sweep": sweep, "run": runs}


@pytest.mark.parametrize("fid,law", [("beam", "linear"), ("sdof", "linear"), ("sdof", "hunt_crossley")])
def test_a_stop_touched_at_rest_gives_one_contact_as_the_direct_solver_does(fid, law):
    case = vibeam.load_case(_case(fid, law))
    kw = {"frequency_hz": 15.4} if fid == "beam" else {"Omega": 2.0}
    ev, di = (vibeam.simulate(case, run=r, periods=2, transient=0, **kw) for r in ("event", "direct"))
    T = 2 * np.pi / ev.Omega
    assert ev.impact_times.size >= 1 and ev.impact_times.size == di.impact_times.size, \
        (ev.impact_times, di.impact_times)
    assert np.max(np.abs(ev.impact_times - di.impact_times)) <= 1e-7 * T
    durations = ev.trajectory.contacts[:, 0]
    assert np.all(durations > 1e-9 * T), durations
