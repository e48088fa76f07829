"""Method ``mapping`` on a Hunt-Crossley stop (:mod:`vibeam.models.mapping`): the
entry-to-entry map of paper Sec. 4.2 with the contact phase integrated together with its
variational equations.

Oracles: the event integrator (:mod:`vibeam.models.core.integrator`, its Runge-Kutta contact phase
at rtol 1e-11 with located events; the map integrates with scipy's DOP853 at rtol 1e-12, so the
two share only the closed-form free flight), central differences of the map and of the event
kernel's stroboscopic map.
"""
from __future__ import annotations

import numpy as np
import pytest

from vibeam.models import make_solver
from vibeam.models.compliant import HuntCrossley
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.mapping import MappingSolver
from vibeam.engine.records import summarize

KEYS = ("amplitude", "q_max", "impact_velocity", "contact_duration", "contact_force_max", "penetration_max",
        "energy_per_impact")


def _model(k, R):
    return sdof(beta=0.015, B=0.5e-3, Delta=0.0, law=HuntCrossley(k, R))


@pytest.mark.parametrize("k, W, R", [(1e4, 1.8, 0.9), (1e5, 1.8, 0.3)])
def test_hc_map_fixed_point_is_the_event_orbit_and_multipliers_match(k, W, R):
    """The fixed point is the event kernel's settled period-1 orbit (400 periods from rest,
    multipliers <= 0.86: the transient is below 1e-25): amplitude, q_max, entry speed
    and the contact record (duration, peak force, penetration, energy lost) to 1e-8 relative (two
    integrations of the contact phase at rtol 1e-11 and 1e-12; measured <= 1.5e-10).  The
    multipliers (from the variational equations) equal those of central differences of the event
    kernel's stroboscopic map to 1e-7 (step 1e-5 of the orbit: the kernel's 1e-11 tolerance over
    the step; measured 2.5e-8 and 4e-9), and the map's Jacobian equals central differences of the map
    to 1e-6 (measured 2e-9).  The stroboscopic map's runs record one sample per period: each sample
    point truncates a Runge-Kutta step of the contact, and a small change of the state that moves
    the step sequence across one moves the end state by up to the integrator's tolerance (~1e-12 of
    the state; measured 1.1e-7 with 8 samples per period on the event integrator, and 1.1e-7 / 2.4e-7
    with 16 / 32 on the former compliant kernel, which passed with its 8 by where its grid fell)."""
    m = _model(k, R)
    s = MappingSolver(m)
    out = s.point(W, None, 0, 0)
    assert out["status"] == "ok" and out["period"] == 1 and out["stable"]
    ev = EventSolver(m).point(W, None, 400, 8, 64)
    se = summarize(ev, 0.0)
    assert se["period"] == 1 and se["status"] == "ok"
    for key in KEYS:
        assert out[key] == pytest.approx(se[key], rel=1e-8), key
    # the stroboscopic map of the event kernel
    s0 = ev.final_state.copy()
    h = 1e-5 * np.max(np.abs(ev.strobe))

    def strobe(z):
        return EventSolver(m).point(W, np.array([z[0], z[1], s0[2]]), 0, 1, 1).final_state[:2]
    J = np.column_stack([(strobe(s0[:2] + h * e) - strobe(s0[:2] - h * e)) / (2 * h) for e in np.eye(2)])
    fd = np.sort_complex(np.linalg.eigvals(J).astype(complex))
    assert np.max(np.abs(fd - np.sort_complex(out["multipliers"]))) < 1e-7
    # the map's own Jacobian
    T = 2 * np.pi / W
    x = np.array([out["final_state"][0] / W, out["final_state"][1]])
    Jm = s.evaluate(W, *x)[2]
    steps = (1e-6 * T, 1e-6 * x[1])
    Jfd = np.column_stack([(np.array(s.evaluate(W, *(x + e * hh))[:2]) - np.array(s.evaluate(W, *(x - e * hh))[:2]))
                           / (2 * hh) for e, hh in zip(np.eye(2), steps)])
    assert np.max(np.abs(Jm - Jfd)) < 1e-6 * np.max(np.abs(Jm))


def test_hc_mapping_case_and_continued_sweep():
    """A Hunt-Crossley case takes method ``mapping`` (registry ``contact_laws``); a continued
    sweep hands the fixed point on and its last point equals the event kernel's orbit (amplitude
    to 1e-8)."""
    from vibeam.case.schema import parse_case
    from vibeam.engine.sweep import Sweep, run_sweep

    text = """name = "x"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
[model.contact]
law = "hunt_crossley"
stiffness = 1e5
[sweep]
Omega = [1.8, 2.0, 2]
[[run]]
name = "map"
method = "mapping"
"""
    sc = parse_case(text, "x.toml").model_spec().scene()
    solver = make_solver(sc, "mapping")
    assert isinstance(solver, MappingSolver)
    W = np.array([1.8, 2.0])
    d = run_sweep(solver, Sweep(Omega=W, direction="up"), jobs=1).data
    assert np.all(d["status"] == "ok") and np.all(d["period"] == 1)
    se = summarize(EventSolver(sc).point(W[-1], None, 400, 8, 64), 0.0)   # the last, continued point
    assert d["amplitude"][-1] == pytest.approx(se["amplitude"], rel=1e-8)
