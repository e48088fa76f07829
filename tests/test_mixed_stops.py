"""A compliant upper stop beside a restitution (Newton) lower stop, SDOF ``event`` and
``direct`` (issue 13: each stop with its own law), and ``mapping``.

Oracles: the solve_ivp reference (DOP853 at rtol 1e-11 with the impact applied at a located
event, independently of the kernel's mirrored frame and certified scans), the one-stop
compliant kernel (a restitution stop that is never reached), and Newton's law's energy loss
``(1 - R^2) v^2 / 2`` per impact.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vibeam.models import make_solver, shooting_problem
from vibeam.models.registry import mixed_stops
from vibeam.models.compliant import LinearContact
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.contact import Restitution
from vibeam.models.scene import one_mode
from vibeam.models.paper.ode import DirectSolver
from vibeam.engine.records import summarize

KV = LinearContact.from_restitution(1e4, 0.8)


def _mixed(Delta_lower=0.003, R_lower=0.6, B=5e-3, Delta=0.002):
    return sdof(beta=0.015, B=B, Delta=Delta, law=KV, Delta_lower=Delta_lower, lower_law=Restitution(float(R_lower)))


@pytest.mark.parametrize("W", [0.9, 1.0, 1.1])
def test_event_agrees_with_the_direct_reference_on_a_mixed_scene(W):
    """Chatter-free orbits with a Kelvin-Voigt contact above and a Newton impact below (6
    upper and 4 lower contacts in 4 periods, from rest): the same contact sequence on the
    same stops, samples to 1e-8 of the orbit (measured <= 1.7e-10: both flows exact against
    DOP853 at rtol 1e-11), contact rows to 1e-6 relative (measured <= 3.0e-11); the lower
    stop's rows are impulses whose energy is (1 - R_l^2) v^2 / 2 (round-off)."""
    m = _mixed()
    a = EventSolver(m).point(W, None, 4, 4, 32)
    b = DirectSolver(m).point(W, None, 4, 4, 32)
    assert a.status == b.status == "ok"
    assert a.n_impacts == b.n_impacts and a.n_impacts_lower == b.n_impacts_lower >= 3
    np.testing.assert_array_equal(a.impact_stops, b.impact_stops)
    np.testing.assert_array_equal(a.contact_stops, b.contact_stops)
    assert np.max(np.abs(a.samples - b.samples)) <= 1e-8 * np.max(np.abs(a.samples))
    np.testing.assert_allclose(a.contacts, b.contacts, rtol=1e-6)
    s = summarize(a, one_mode(m).Delta)
    lo = a.contacts[a.contact_stops == 1]
    assert s["energy_per_impact_lower"] == pytest.approx(np.mean(0.5 * (1 - 0.6 ** 2) * lo[:, 4] ** 2), rel=1e-12)
    assert s["contact_duration_lower"] == 0.0 and math.isnan(s["contact_force_max_lower"])
    assert s["contact_duration"] > 0.0 and s["contact_force_max"] > 0.0   # the compliant upper stop
    # the impacts reach the lower stop exactly; both solvers record it as the minimum of q
    assert s["q_min"] == pytest.approx(-0.003, abs=1e-15) and b.q_min == pytest.approx(-0.003, abs=1e-15)
    np.testing.assert_allclose(a.period_min, b.period_min, rtol=0, atol=1e-8 * np.max(np.abs(a.samples)))


def test_a_far_restitution_stop_gives_the_one_stop_compliant_run_identically():
    """A restitution stop that is never reached leaves every step of the one-stop kernel as it
    was: samples, extremes, contact rows and final state bit-for-bit."""
    one = sdof(beta=0.015, B=5e-4, Delta=0.0, law=LinearContact.from_restitution(1e4, 0.9))
    two = sdof(beta=0.015, B=5e-4, Delta=0.0, Delta_lower=1.0, lower_law=Restitution(0.5),
               law=LinearContact.from_restitution(1e4, 0.9))
    a = EventSolver(one).point(2.0, None, 8, 8, 32)
    b = EventSolver(two).point(2.0, None, 8, 8, 32)
    assert a.n_impacts >= 8 and b.n_impacts_lower == 0 and np.all(b.impact_stops == 0)
    for x, y in ((a.samples, b.samples), (a.contacts, b.contacts), (a.period_min, b.period_min),
                 (a.impact_times, b.impact_times), (a.final_state, b.final_state)):
        np.testing.assert_array_equal(x, y)
    assert (a.q_min, a.q_max) == (b.q_min, b.q_max)


def test_chatter_on_the_restitution_stop_ends_in_sticking_as_in_the_direct_reference():
    """The oscillator starts at rest on a restitution stop at its equilibrium (Delta_lower = 0)
    and is pressed back after each slow rebound: the chatter sequence accumulates (the shared
    policy's estimate) and ends in sticking on the Newton stop beside the compliant one (the
    old compliant kernel refused this, ending the point with NaN outputs; the one event
    integrator holds the system on the stop): status ``chatter``, and the samples and the time
    stuck are the direct reference's (solve_ivp with the held stop's constraint force as its
    release event): samples to 1e-8 of the orbit (measured 2e-11), stuck fraction to 1e-6
    relative (measured 8e-8)."""
    m = _mixed(Delta_lower=0.0, R_lower=0.5, Delta=0.05)
    t = EventSolver(m).point(0.5, None, 20, 4, 32)
    assert t.status == "chatter" and "ending in sticking" in t.message
    s = summarize(t, one_mode(m).Delta)
    assert s["status"] == "chatter"
    d = DirectSolver(m).point(0.5, None, 20, 4, 32)
    assert d.status == "chatter"
    assert np.max(np.abs(t.samples - d.samples)) <= 1e-8 * np.max(np.abs(t.samples))
    assert t.extra["stuck_fraction"] == pytest.approx(d.extra["stuck_fraction"], rel=1e-6)


def test_mixed_stops_are_served_by_the_mapping_and_refused_by_the_textbook_methods():
    """The mapping (vibeam.models.mapping: a passage through each stop by its law) serves mixed
    stops, in either order of the laws -- refused here before; now its period-1 orbit of each scene
    is the event kernel's settled one (amplitude and the speed on each stop to 1e-9 relative: two
    exact flows, measured <= 1e-13; tests/test_mapping_stops.py checks more) -- and the methods of
    one Newton stop (averaging) are refused in one line for either order; continuation is the one
    shooting problem (vibeam.models.core.shooting).  A restitution upper stop above a compliant
    lower one, refused before the one shooting problem, is now served: its stops are Newton's law
    above the law of contact_lower (tests/test_continuation_compliant_two.py checks its shots)."""
    from vibeam.models.mapping import MappingSolver

    up = sdof(beta=0.015, B=5e-3, Delta=0.002, R=0.8, Delta_lower=0.003, lower_law=KV)
    assert [s.law.kind for s in up.stops] == ["impulsive", "compliant"]
    assert mixed_stops(up)
    with pytest.raises(ValueError, match="cannot simulate a compliant stop beside a restitution one"):
        make_solver(up, "averaging")
    m = _mixed()
    with pytest.raises(ValueError, match="a restitution stop beside a compliant one"):
        make_solver(m, "averaging")
    for scene in (up, m):
        solver = make_solver(scene, "mapping")
        assert isinstance(solver, MappingSolver)
        out = solver.point(0.75, None, 0, 0)
        ev = summarize(EventSolver(scene).point(0.75, None, 1500, 4, 32), one_mode(scene).Delta)
        assert out["status"] == "ok" and ev["period"] == out["period"] == 1, out["message"]
        for key in ("amplitude", "impact_velocity", "impact_velocity_lower"):
            assert out[key] == pytest.approx(ev[key], rel=1e-9), key
    assert shooting_problem(m, "Omega", Omega=1.0).shot(np.zeros(2), 1.0, 1).status == "ok"
    assert isinstance(make_solver(m, "event"), EventSolver)
    assert isinstance(make_solver(m, "direct"), DirectSolver)


def test_a_compliant_lower_stop_has_its_own_target_R():
    """Issue 43: an SDOF with a Newton upper stop (R 0.9) and a Kelvin-Voigt lower stop of target
    R 0.8, as two [[model.stop]] tables (refused before: 'a compliant lower stop takes the upper
    stop's target R').  The lower law's isolated impact, integrated here by solve_ivp with the
    force-zero exit (the law's stiffness and damping only), has restitution 0.8 (1e-8: the
    integration's tolerance); the upper stop keeps Newton's 0.9; the shorthand table with
    [model.contact_lower] R = 0.8 is the same scene (bit for bit); event and direct agree from rest
    over 2 periods to 1e-7 of the motion (tests/test_matrix.py's bound) with both stops hit."""
    import vibeam
    from scipy.integrate import solve_ivp

    base = {"fidelity": "sdof", "beta": 0.015, "B": 5e-3}
    listed = dict(base, stop=[{"side": "upper", "Delta": 0.002, "R": 0.9},
                              {"side": "lower", "Delta": 0.003, "R": 0.8, "law": "linear", "stiffness": 3e3}])
    short = dict(base, R=0.9, Delta=0.002, Delta_lower=0.003,
                 contact_lower={"law": "linear", "stiffness": 3e3, "R": 0.8})

    def case(model):
        return vibeam.load_case({"name": "own-R", "model": model, "sweep": {"Omega": [0.75, 0.8, 2]},
                                 "run": [{"name": "event", "method": "event"},
                                         {"name": "direct", "method": "direct", "solver": "DOP853",
                                          "rtol": 1e-10, "atol": 1e-13}]})

    a, b = case(listed), case(short)
    sc = a.model_spec().scene()
    lo = sc.stops[1].law
    assert sc.stops[0].law.R == 0.9 and sc.stops[0].law.R == 0.9 and lo.R == 0.8
    w, z = math.sqrt(lo.stiffness), lo.damping_ratio

    def rhs(t, y):
        return [y[1], -2 * z * w * y[1] - w * w * y[0]]

    def force_zero(t, y):
        return w * w * y[0] + 2 * z * w * y[1]
    force_zero.terminal, force_zero.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 10 * math.pi / w), [0.0, 1.0], events=force_zero, rtol=1e-12, atol=1e-14,
                    method="DOP853")
    assert -sol.y_events[0][0][1] == pytest.approx(0.8, abs=1e-8)
    sims = [vibeam.simulate(c, run=r, Omega=0.75, periods=2, transient=0) for c in (a, b) for r in ("event", "direct")]
    np.testing.assert_array_equal(sims[0].q, sims[2].q)                      # shorthand = [[model.stop]]
    ev, di = sims[0], sims[1]
    assert len(set(ev.trajectory.impact_stops.tolist())) == 2               # both stops hit
    assert np.max(np.abs(ev.q - di.q)) <= 1e-7 * np.max(np.abs(ev.q))
