"""Stops anywhere (issue 20): ``[[model.stop]]`` tables, a beam with stops at different points,
each with its own side, gap and law, simulated by the one event integrator, the one direct solver
and the one shooting problem, checked against independent oracles:

* the tables are the shorthand keys where they say the same (identical models and trajectories);
* a stop below the tip of a 2-mode beam: the event integrator against ``solve_ivp`` with events on
  both stops (the direct solver shares the model only);
* a one-mode beam: a stop at the tip is a second stop at the mass, at the gap the mode's shape
  scales it to (one DOF: the same relation up to its row's factor);
* continuation: stable points of the continued branch against settled event runs, and Liouville's
  formula for the monodromy of an orbit with impacts on both stops;
* bad tables are refused in one line naming the stop and the key.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from vibeam.case.schema import CaseError, parse_case
from vibeam.engine.records import summarize
from vibeam.models import shooting_problem
from vibeam.models.core.direct import BeamODESolver
from vibeam.models import BeamEventSolver
from vibeam.models.scene import outputs

RIG = """name = "tip"
[model]
fidelity = "beam"
length_mm = 180.0
sensor_position_mm = 100.0
mass_position_mm = 132.0
width_mm = 20.0
thickness_mm = 1.0
gain = 5.16e-4
voltage = 0.6
damping_ratio = 0.017
n_modes = {n_modes}
n_elements = 24
{keys}
[model.discs]
count = 4
thickness_mm = 7.0
diameter_mm = 35.0
mass_kg = 0.2
[model.calibrate]
f1_hz = 7.6
f2_hz = 98.75
{stops}
[sweep]
frequency_hz = [14.0, 17.0, 5]
[[run]]
name = "event"
method = "event"
"""

TIP = """[[model.stop]]
side = "upper"
gap_mm = 0.0
R = 0.72
[[model.stop]]
side = "lower"
position_mm = 180.0
contact_gap_mm = 1.2
R = 0.9
"""


def _model(stops=TIP, n_modes=2, keys=""):
    return parse_case(RIG.format(n_modes=n_modes, stops=stops, keys=keys)).model_spec().scene()


def test_stop_tables_are_the_shorthand_keys():
    """Two stops at the attached mass given as [[model.stop]] tables build the model the shorthand
    keys build (beam and SDOF), and it moves the same, bit for bit."""
    tables = """[[model.stop]]
side = "upper"
gap_mm = 0.05
R = 0.8
[[model.stop]]
side = "lower"
gap_mm = 0.4
R = 0.6
"""
    keys = """R = 0.8
gap_mm = 0.05
gap_lower_mm = 0.4
contact_lower = {R = 0.6}
"""
    a, b = _model(tables), _model("", keys=keys)
    assert a.stops == b.stops and not [st for st in a.stops if st.relation.row > 0]
    W = 15.5 / a.system.reference_hz
    ta, tb = BeamEventSolver(a).point(W, None, 50, 4, 16), BeamEventSolver(b).point(W, None, 50, 4, 16)
    assert np.array_equal(ta.samples, tb.samples) and ta.n_impacts == tb.n_impacts
    sd = """name = "s"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
{0}
[sweep]
Omega = [1.5, 2.5, 3]
[[run]]
name = "event"
method = "event"
"""
    s1 = parse_case(sd.format('[[model.stop]]\nDelta = 0.0\nR = 0.9\n[[model.stop]]\nside = "lower"\n'
                              'Delta = 2e-3\nR = 0.7\n')).model_spec().scene()
    s2 = parse_case(sd.format('R = 0.9\nDelta = 0.0\nDelta_lower = 2e-3\n[model.contact_lower]\nR = 0.7\n')
                    ).model_spec().scene()
    assert s1 == s2 and s1.stops == s2.stops


@pytest.mark.parametrize("f_hz", [15.5, 16.5])
def test_a_stop_below_the_tip_against_solve_ivp(f_hz):
    """2 modes, the paper's stop at the mass and one 1.2 mm below the tip (R 0.9): a period-1
    orbit with an impact at the mass and 4-6 at the tip per period.  The direct solver (DOP853,
    rtol 1e-9, events on both stops' gaps) gives the same orbit: the same impacts per period on
    each stop and the amplitude to 1e-8 (measured 6e-11 and 2e-10: the ODE tolerance)."""
    m = _model()
    assert [s.name for s in m.stops] == ["upper", "lower at 180 mm"] and m.system.contacts.shape == (2, 2)
    W = f_hz / m.system.reference_hz
    a = BeamEventSolver(m).point(W, None, 400, 16, 64)
    b = BeamODESolver(m).point(W, None, 400, 16, 64)
    Delta = outputs(m).Delta
    sa, sb = summarize(a, Delta), summarize(b, Delta)
    assert sa["period"] == sb["period"] == 1 and a.status == b.status == "ok"
    assert sa["stop_impacts_per_period"][0] == 1.0 and sa["stop_impacts_per_period"][2] >= 4.0
    np.testing.assert_array_equal(sa["stop_impacts_per_period"], sb["stop_impacts_per_period"])
    assert sa["amplitude"] == pytest.approx(sb["amplitude"], rel=1e-8)


def test_one_mode_a_tip_stop_is_a_stop_at_the_mass():
    """With one mode the tip's displacement is w_tip / w_mass times the mass's: a stop D below the
    tip is a lower stop D w_mass / w_tip below the mass.  The two models move the same to 1e-12 of
    the orbit (the same relation up to its row's factor: the gap and the impulse scale together),
    on a periodic orbit: where the motion is chaotic, round-off tells them apart after a few
    periods."""
    tip = TIP.replace("gap_mm = 0.0", "contact_gap_mm = 0.0")
    m = _model(tip, n_modes=1)
    ps = [st for st in m.stops if st.relation.row > 0][0]
    row = m.system.contacts[ps.relation.row]
    ratio = float(m.system.contacts[0][0] / row[0])
    at_mass = _model(tip.replace('position_mm = 180.0\ncontact_gap_mm = 1.2',
                                 f'contact_gap_mm = {1.2 * ratio!r}'), n_modes=1)
    W = 16.5 / m.system.reference_hz       # a period-3 orbit (at 14.5-16 Hz the one-mode motion is chaotic)
    a = BeamEventSolver(m).point(W, None, 300, 8, 32)
    b = BeamEventSolver(at_mass).point(W, None, 300, 8, 32)
    assert a.n_impacts == b.n_impacts > 8 and summarize(a, outputs(m).Delta)["period"] == 3
    assert np.max(np.abs(a.samples - b.samples)) < 1e-12 * np.max(np.abs(a.samples))   # measured 7e-14


def test_continued_tip_branch_against_event_runs_and_liouville():
    """The tip scene continued in Omega (2 modes): at stable points of the branch the settled event
    run is the continued orbit (state to 1e-8 of its scale: the corrector's residual over 1 - |mu|),
    and every shot with impacts on both stops and no sticking has det M = prod R_k^2 exp(-sum_i c_i
    T) (Liouville; each Newton impact's saltation has determinant R^2; measured 1e-13)."""
    from vibeam.models.orbits.continuation import Settings, trace

    m = _model()
    W0 = 15.5 / m.system.reference_hz
    x0 = BeamEventSolver(m).point(W0, None, 400, 1, 1).final_state[:-1]
    prob = shooting_problem(m, "Omega")
    br = trace(prob, x0, W0, 1, W0, 16.5 / m.system.reference_hz, +1, Settings(switch=False, max_points=40))[0]
    stable = [p for p in br.points if np.max(np.abs(p.mu)) < 1.0]
    assert len(stable) >= 10
    c = m.system.damping
    checked = 0
    for p in stable[::4]:
        ev = BeamEventSolver(m).point(p.p, np.concatenate([p.x, [0.0]]), 300, 1, 1)
        scale = np.max(np.abs(p.x))
        assert np.max(np.abs(ev.final_state[:-1] - p.x)) < 1e-8 * scale
        s = prob.shot(p.x, p.p, 1)
        stops = s.extra["impact_stops"]
        if s.stuck_time == 0.0 and 0 in stops and 1 in stops:
            R = np.where(stops == 0, 0.72, 0.9)
            T = 2 * math.pi / p.p
            expect = np.prod(R ** 2) * math.exp(-np.sum(c) * T)
            assert np.linalg.det(s.M) == pytest.approx(expect, rel=1e-9)
            checked += 1
    assert checked >= 2


@pytest.mark.parametrize("stops, words", [
    (TIP.replace("position_mm = 180.0", "position_mm = 200.0"), "beyond length_mm"),
    (TIP + '[[model.stop]]\nside = "upper"\ngap_mm = 0.1\nR = 0.5\n', "two upper stops at the attached mass"),
    (TIP.replace('side = "upper"\ngap_mm = 0.0', 'side = "lower"\ngap_mm = 0.3'), "no upper stop at the attached mass"),
    (TIP.replace("R = 0.9", 'law = "linear"\nstiffness_n_m = 1e5\nR = 0.9'), "away from the attached mass"),
    (TIP.replace("R = 0.9\n", ""), "give the stop's R"),
    (TIP.replace("contact_gap_mm = 1.2", "contact_gap_mm = 1.2\ngap_mm = 1.0"), "give the stop's gap once"),
    (TIP.replace('side = "lower"', 'side = "below"'), "side"),
])
def test_bad_stop_tables_are_refused_in_one_line(stops, words):
    """Each mistake in a [[model.stop]] table is one line naming it (CaseError, no traceback)."""
    with pytest.raises(CaseError) as e:
        parse_case(RIG.format(n_modes=2, stops=stops, keys=""), "tip.toml").model_spec().scene()
    msg = str(e.value)
    assert words in msg and "\n" not in msg, msg


def test_shorthand_keys_beside_stop_tables_are_refused():
    with pytest.raises(CaseError) as e:
        parse_case(RIG.format(n_modes=2, stops=TIP, keys="R = 0.7"), "tip.toml")
    assert "not both" in str(e.value) and "'R'" in str(e.value).replace('"', "'") or "['R']" in str(e.value)


def test_an_sdof_stop_has_no_position():
    sd = """name = "s"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
[[model.stop]]
Delta = 0.0
R = 0.9
position_mm = 10.0
[sweep]
Omega = [1.5, 2.5, 3]
[[run]]
name = "event"
method = "event"
"""
    with pytest.raises(CaseError) as e:
        parse_case(sd, "s.toml")
    assert "position_mm is a beam key" in str(e.value)


def test_overrides_of_shorthand_keys_go_into_the_stop_tables():
    """A [run.model] override, a [map] value or a fitted value of a shorthand key (R, gap_mm,
    gap_lower_mm) on a scene with [[model.stop]] tables sets the stop it stands for: the model
    spec equals the one whose tables carry the value (equal pydantic specs, so every number)."""
    from vibeam.case.contact import model_with
    from vibeam.identify.fit import fitted_case_text

    base = parse_case(RIG.format(n_modes=2, stops=TIP, keys=""))
    def spec(stops):
        return parse_case(RIG.format(n_modes=2, stops=stops, keys="")).model_spec()

    want = spec(TIP.replace("R = 0.72", "R = 0.6").replace("gap_mm = 0.0", "gap_mm = 0.1"))
    assert base.model_spec({"R": 0.6, "gap_mm": 0.1}) == want
    # a gap of another kind replaces the stop's gap key; the point stop is kept
    got = model_with(base.model, {"contact_gap_mm": 0.3})["stop"]
    assert got[0] == {"side": "upper", "contact_gap_mm": 0.3, "R": 0.72} and got[1] == base.model["stop"][1]
    # a lower stop at the mass is added by its shorthand key
    low = spec(TIP + '[[model.stop]]\nside = "lower"\ngap_mm = 0.4\nR = 0.72\n')
    assert base.model_spec({"gap_lower_mm": 0.4}) == low
    # a [map] over R and a [run.model] override validate, and the fitted case carries the value
    text = RIG.format(n_modes=2, stops=TIP, keys="") + '\n[map]\nparameter = "R"\nvalues = [0.6, 0.8, 2]\n'
    parse_case(text.replace('[[run]]\nname = "event"\nmethod = "event"\n',
                            '[[run]]\nname = "event"\nmethod = "event"\n[run.model]\ngap_mm = 0.1\n'))
    fit = parse_case(fitted_case_text(base, base.run[0], {"R": 0.5}))
    assert fit.model["stop"][0]["R"] == 0.5 and "R" not in fit.model
    assert base.model["stop"][0]["R"] == 0.72          # the case's own table is not changed
