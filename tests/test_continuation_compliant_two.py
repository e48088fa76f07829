"""Continuation of periodic orbits with two Kelvin-Voigt stops (SDOF, law "linear"): the shooting
problem of vibeam.models.core.shooting (the scene's SceneShooting with a lower stop) against
finite differences, Liouville's formula, the two-stop event kernel, the one-stop problem and
the mirror symmetry of a symmetric scene."""

import math

import numpy as np
import pytest

from vibeam.models import shooting_problem, make_solver
from vibeam.models.compliant import HuntCrossley, LinearContact
from vibeam.models.orbits.continuation import Settings, start_point, trace
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import one_mode, outputs
from vibeam.engine.records import summarize

# slow (the default test step's time): the compliant laws' shooting tangents and two-stop
# kernels are compiled by these tests alone (~4 min of cold compile on 2 cores); .ci/run runs them
pytestmark = pytest.mark.slow

FIG8 = dict(beta=0.015, B=0.5e-3, Delta=0.7e-3)      # paper Fig. 8 scene (its Newton stop: R = 0.9)


def _kv(p, k, Delta_lower, R=0.9, lower_law=None):
    return sdof(**p, law=LinearContact.from_restitution(k, R), Delta_lower=Delta_lower, lower_law=lower_law)


TWO = _kv(FIG8, 1e4, 0.9e-3)                                   # contacts on both stops each period
SOFT = _kv(dict(beta=0.015, B=0.5e-3, Delta=0.2e-3), 1e2, 0.3e-3)     # soft, long contacts, 2-3 per period


def _settled(m, Omega, periods=1500, x0=None):
    s0 = None if x0 is None else np.array([x0[0], x0[1], 0.0])
    tr = EventSolver(m).point(Omega, s0, periods, 16, 16)
    return np.asarray(tr.final_state[:2], float), tr


# ------------------------------------------------------------------ exact derivatives
CASES = {
    "both stops, stiff": (TWO, 1.9, 1, None),
    "soft, three contacts": (SOFT, 2.0, 1, None),
    "soft, period 2": (SOFT, 2.9, 2, None),
    "in contact with the lower stop at the section": (SOFT, 2.9, 1, (-0.3e-3 - 2e-5, -1e-4)),
    "a lower stop with its own law": (_kv(FIG8, 1e4, 0.9e-3, lower_law=LinearContact.from_restitution(3e3, 0.7)),
                                      1.9, 1, None),
}


def _check_shot_jacobian(m, par, W, x, n):
    """The shot of ``shooting_problem(m, par)`` from ``x`` (status ok, contacts on both stops) and
    its ``[M, d P^n / d par]`` against central differences (step 1e-6 relative; the same number
    of impacts on both sides; bound 1e-6 of the largest entry)."""
    prob = shooting_problem(m, par, Omega=W)
    p = W if par == "Omega" else prob.value
    s = prob.shot(x, p, n)
    assert s.status == "ok", s.message
    assert set(s.extra["impact_stops"]) == {0, 1}
    scale = max(float(np.max(np.abs(x))), 1e-4)
    J = np.empty((2, 3))
    for c in range(3):
        if c < 2:
            e = np.zeros(2)
            e[c] = 1e-6 * scale
            a, b, h = prob.shot(x + e, p, n), prob.shot(x - e, p, n), e[c]
        else:
            h = 1e-6 * max(abs(p), 1e-3)
            a, b = prob.shot(x, p + h, n), prob.shot(x, p - h, n)
        assert a.n_impacts == b.n_impacts == s.n_impacts
        J[:, c] = (a.x - b.x) / (2 * h)
    A = np.column_stack([s.M, s.x_p])
    assert np.max(np.abs(A - J)) <= 1e-6 * np.max(np.abs(A)), (par, A, J)


@pytest.mark.parametrize("name", list(CASES))
def test_shot_jacobian_equals_central_differences(name):
    """M = d P^n / d x0 and d P^n / d(Omega, B, Delta) against central differences of the shot,
    from a state off the orbit (events at generic times), with contacts on both stops.  Step
    1e-6 relative: truncation ~1e-12, round-off ~1e-10 of the entries; bound 1e-6 relative to
    the largest entry (measured <= 5e-9)."""
    m, W, n, x0 = CASES[name]
    if x0 is None:
        x, _ = _settled(m, W, 400)
        x = x * (1.0 + 1e-3)
    else:
        x = np.array(x0)
    for par in ("Omega", "system.base_amplitude", "stops[0].relation.offset"):
        _check_shot_jacobian(m, par, W, x, n)


@pytest.mark.parametrize("name", list(CASES))
def test_liouville(name):
    """det M = exp(-2 beta n T - c_up T_up - c_low T_low) (the trace of each phase's state
    matrix, det S = 1 at every entry); closed-form flows: agreement to round-off (1e-12)."""
    m, W, n, x0 = CASES[name]
    x = _settled(m, W, 400)[0] if x0 is None else np.array(x0)
    prob = shooting_problem(m)
    s = prob.shot(x, W, n)
    e = s.extra
    assert e["contact_time_upper"] > 0.0 and e["contact_time_lower"] > 0.0
    low = m.stops[1].law     # the lower stop's law
    want = np.exp(-2 * one_mode(m).beta * n * 2 * np.pi / W - m.stops[0].law.damping * e["contact_time_upper"]
                  - low.damping * e["contact_time_lower"])
    assert abs(np.linalg.det(s.M) / want - 1.0) < 1e-12


# ------------------------------------------------------------------ branches
@pytest.fixture(scope="module")
def two_branch():
    x0, _ = _settled(TWO, 1.6)
    brs = trace(shooting_problem(TWO, "Omega"), x0, 1.6, 1, 1.5, 2.4, +1)
    return brs


def test_branch_points_equal_event_runs(two_branch):
    """Stable branch points are fixed points of the two-stop event kernel: 1500 periods from the
    branch state end on it (max|mu| <= 0.78 here: the transient decays below 1e-12 of the
    state), with the same contacts per period on each stop."""
    a = two_branch[0].arrays()
    assert two_branch[0].status == "range_end" and a["parameter"][-1] == pytest.approx(2.4)
    assert np.all(a["impacts_lower"] == 1) and np.all(a["impacts"] == 2)
    idx = [i for i in range(len(a["parameter"])) if a["stable"][i]]
    assert len(idx) >= 5
    for i in idx[:: max(1, len(idx) // 3)]:
        W, x = a["parameter"][i], a["state"][i]
        y, tr = _settled(TWO, W, 1500, x)
        assert np.max(np.abs(y - x)) < 1e-9 * np.max(np.abs(x)), (W, x, y)
        rec = summarize(tr, one_mode(TWO).Delta)
        assert tr.n_impacts == 32 and np.sum(tr.impact_stops == 1) == 16
        assert rec["q_max"] == pytest.approx(a["q_max"][i], rel=1e-9)


#: a lower stop of its own law: softer (k_l = 3e3 against 1e4) and lossier (R_l = 0.7 against 0.9)
OWN = _kv(FIG8, 1e4, 0.9e-3, lower_law=LinearContact.from_restitution(3e3, 0.7))


def _event_map_jacobian(solver, W, x, phase=0.0, rel=1e-5):
    """Central differences of the event kernel's stroboscopic map ``x -> x(T)`` (one forcing
    period from forcing phase 0; ``solver.point(W, (x, phase), 0, 1)``), step ``rel |x_c|``."""
    d = x.shape[0]
    J = np.empty((d, d))
    for c in range(d):
        e = np.zeros(d)
        e[c] = rel * max(abs(x[c]), 1e-3 * np.max(np.abs(x)))
        a = solver.point(W, np.concatenate([x + e, [phase]]), 0, 1, 4)
        b = solver.point(W, np.concatenate([x - e, [phase]]), 0, 1, 4)
        assert a.final_state[d] == b.final_state[d] == phase and a.n_impacts == b.n_impacts
        J[:, c] = (a.final_state[:d] - b.final_state[:d]) / (2 * e[c])
    return J


def _same_multipliers(mu, ev):
    """Largest distance from a multiplier to the nearest eigenvalue, and back (a matching
    of the two spectra up to order)."""
    return max(max(np.min(np.abs(ev - m_)) for m_ in mu), max(np.min(np.abs(mu - e_)) for e_ in ev))


@pytest.fixture(scope="module")
def own_branch():
    x0, _ = _settled(OWN, 1.6)
    return trace(shooting_problem(OWN, "Omega"), x0, 1.6, 1, 1.5, 2.4, +1)


def test_own_lower_law_branch_equals_event_runs_and_map_jacobian(own_branch):
    """The lower stop's law is its own (``[model.contact_lower]``: k_l = 3e3, R_l = 0.7 beside
    k = 1e4, R = 0.9), and the shooting problem must use it: the two-stop event kernel, which
    takes both laws from ``model.stops()``, is the oracle.

    * Scenario: one period-1 branch over 1.6..2.4, stable throughout (max|mu| 0.59..0.61), one
      contact on each stop per period.
    * Branch points are its fixed points: 1500 periods of the event kernel from the branch
      state end on it (relative 1e-9; max|mu|^1500 < 1e-300, so the transient is round-off;
      measured <= 6e-14) with 16 contacts on each stop in 16 recorded periods and the
      same q_min (the lower stop's largest penetration depends on k_l).
    * The Floquet multipliers are the eigenvalues of a central-difference Jacobian of the
      event kernel's one-period map (step 1e-5 relative: truncation ~1e-10, round-off
      ~1e-11; measured <= 1.7e-9 of max|mu|; bound 1e-6).
    Both fail if the shooting problem's lower stop takes the upper law (the orbit of another
    scene: event runs drift ~1e-1 away)."""
    assert len(own_branch) == 1 and own_branch[0].status == "range_end"
    a = own_branch[0].arrays()
    assert a["parameter"][-1] == pytest.approx(2.4)
    assert np.all(a["impacts_lower"] == 1) and np.all(a["impacts"] == 2) and np.all(a["stable"])
    solver = make_solver(OWN, "event")
    idx = range(0, len(a["parameter"]), 5)
    assert len(idx) >= 4
    for i in idx:
        W, x = a["parameter"][i], a["state"][i]
        y, tr = _settled(OWN, W, 1500, x)
        assert np.max(np.abs(y - x)) < 1e-9 * np.max(np.abs(x)), (W, x, y)
        assert tr.n_impacts == 32 and np.sum(tr.impact_stops == 1) == 16
        assert tr.q_min == pytest.approx(a["q_min"][i], rel=1e-9)
        mu = a["multipliers"][i]
        ev = np.linalg.eigvals(_event_map_jacobian(solver, W, x))
        assert _same_multipliers(mu, ev) < 1e-6 * np.max(np.abs(mu)), (W, mu, ev)


def test_far_lower_stop_gives_the_one_stop_branch():
    """A lower stop the orbit never reaches changes nothing: the two-stop problem's free steps
    run the one-stop step up to the same step ends, so the branch agrees with the one-stop
    branch to round-off (measured: bit for bit in states and multipliers)."""
    law = LinearContact.from_restitution(1e4, 0.9)
    one = sdof(**FIG8, law=law)
    far = sdof(**FIG8, law=law, Delta_lower=1.0)
    x0, _ = _settled(one, 2.3)
    b1 = trace(shooting_problem(one), x0, 2.3, 1, 2.0, 2.5, +1, Settings(max_points=12))[0].arrays()
    b2 = trace(shooting_problem(far), x0, 2.3, 1, 2.0, 2.5, +1, Settings(max_points=12))[0].arrays()
    assert len(b1["parameter"]) == len(b2["parameter"]) >= 5
    assert np.all(b2["impacts_lower"] == 0)
    np.testing.assert_allclose(b2["parameter"], b1["parameter"], rtol=1e-13, atol=0)
    np.testing.assert_allclose(b2["state"], b1["state"], rtol=1e-11, atol=1e-18)
    np.testing.assert_allclose(b2["multipliers"], b1["multipliers"], rtol=1e-10, atol=1e-14)


def test_symmetric_stops_give_a_symmetric_orbit():
    """Delta_lower = Delta and the same law: the period-1 orbit is invariant under (q, t) ->
    (-q, t + T/2), so q_min = -q_max and the upper and lower contacts have the same entry
    velocity, duration, peak force, penetration and energy (relative 1e-9: Newton tolerance)."""
    m = _kv(FIG8, 1e4, FIG8["Delta"])
    x0, _ = _settled(m, 1.9)
    prob = shooting_problem(m)
    pt, why = start_point(prob, x0, 1.9, 1, 1.5, 2.5)
    assert pt is not None, why
    s = prob.shot(pt.x, 1.9, 1)
    assert np.max(np.abs(s.x - pt.x)) < 1e-12
    assert s.q_min == pytest.approx(-s.q_max, rel=1e-9)
    k = s.extra["impact_stops"]
    assert list(sorted(k)) == [0, 1]
    up, lo = k == 0, k == 1
    assert s.impact_velocities[up][0] == pytest.approx(s.impact_velocities[lo][0], rel=1e-9)
    assert s.extra["contact_time_upper"] == pytest.approx(s.extra["contact_time_lower"], rel=1e-9)
    # the second half period is the mirror of the first: entries half a period apart
    t = s.impact_times
    assert abs(abs(t[1] - t[0]) - np.pi / 1.9) < 1e-9


def test_hertz_stops_are_continued_with_exact_jacobians():
    """Two stops with a Hunt-Crossley law (both, or the lower one beside a Kelvin-Voigt upper stop),
    once refused, are one shooting problem (the integrator's Runge-Kutta contact phases with their
    variational equations): M and d/dOmega against central differences of the shot (step 1e-5,
    tolerance 1e-6 of each column, the Hunt-Crossley checks' of tests/test_continuation_compliant.py)."""
    for m, W in ((sdof(**FIG8, law=HuntCrossley(1e4, 0.9), Delta_lower=0.9e-3), 2.0),
                 (_kv(FIG8, 1e4, 0.9e-3, lower_law=HuntCrossley(1e4, 0.9)), 2.0)):
        prob = shooting_problem(m, "Omega")
        x = _settled(m, W, 400)[0] * (1.0 + 1e-3)
        s = prob.shot(x, W, 1)
        assert s.status == "ok" and s.n_impacts >= 1, s.message
        A = np.column_stack([s.M, s.x_p])
        for c in range(3):
            if c < 2:
                e = np.zeros(2)
                e[c] = h = 1e-5 * np.max(np.abs(x))
                col = (prob.shot(x + e, W, 1).x - prob.shot(x - e, W, 1).x) / (2 * h)
            else:
                h = 1e-5 * W
                col = (prob.shot(x, W + h, 1).x - prob.shot(x, W - h, 1).x) / (2 * h)
            assert np.max(np.abs(A[:, c] - col)) < 1e-6 * np.max(np.abs(A[:, c]))


CASE = '''
name = "kv2c"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.7e-3
Delta_lower = 0.9e-3
[model.contact]
law = "linear"
stiffness = 1e4
[sweep]
Omega = [1.6, 2.4, 5]
transient_periods = 300
record_periods = 16
[[run]]
name = "branches"
method = "continuation"
start_at = "low"
'''


def test_vibeam_continue_end_to_end(tmp_path):
    """`vibeam continue` on a two-stop compliant scene writes the branch with the lower stop's
    contact count; it is the branch traced directly (same start, same settings)."""
    from vibeam.cli import main
    from vibeam.io.results import read_results

    (tmp_path / "kv2.toml").write_text(CASE)
    assert main(["continue", str(tmp_path / "kv2.toml"), "--out", str(tmp_path / "out"), "--jobs", "1",
                 "--no-plots", "--quiet"]) == 0
    b = read_results(tmp_path / "out" / "results.h5")["branches"]["branches"]["00-period1"]
    assert b["parameter"][0] == 1.6 and b["parameter"][-1] == pytest.approx(2.4)
    assert np.all(np.asarray(b["impacts_lower"]) == 1) and np.all(np.asarray(b["impacts"]) == 2)
    i = int(np.flatnonzero(np.asarray(b["stable"]))[-1])
    x = np.asarray(b["state"][i], float)
    y, _ = _settled(TWO, float(b["parameter"][i]), 1500, x * 1.01)
    assert np.max(np.abs(y - x)) < 1e-9 * np.max(np.abs(x))


# ------------------------------------------------------------------ the modal beam
def _rig2(n_modes, gap_lower_mm=0.3, lower=None):
    from vibeam.case.schema import load_case

    case, _ = load_case("cases/rig-fe-neutral.toml")
    over = {"n_modes": n_modes, "contact": {"law": "linear", "stiffness_n_m": 1e5}}
    if gap_lower_mm is not None:
        over["gap_lower_mm"] = gap_lower_mm
    if lower is not None:
        over["contact_lower"] = lower
    return case.model_spec(over).scene()


def _beam_jacobian(prob, x, W):
    """Central differences of the shot in (x0, Omega) (steps 1e-6 relative)."""
    d = x.shape[0]
    s = prob.shot(x, W, 1)
    J = np.empty((d, d + 1))
    for c in range(d + 1):
        if c < d:
            e = np.zeros(d)
            e[c] = 1e-6 * np.max(np.abs(x))
            a, b, h = prob.shot(x + e, W, 1), prob.shot(x - e, W, 1), e[c]
        else:
            h = 1e-6 * W
            a, b = prob.shot(x, W + h, 1), prob.shot(x, W - h, 1)
        assert a.n_impacts == b.n_impacts == s.n_impacts
        J[:, c] = (a.x - b.x) / (2 * h)
    return s, J


@pytest.mark.parametrize("n_modes", [1, 2])
def test_beam_shot_jacobian_and_liouville(n_modes):
    """The two-stop beam shot (rig, neutral gap, 1e5 N/m on both stops, lower gap 0.3 mm) from
    a state off the orbit and from one inside the lower stop: the Jacobian equals central
    differences (bound 1e-7 relative; measured <= 1.3e-9) and det M = exp(trace(A_free) T -
    |w|^2 (c T_up + c_l T_low)) to round-off (1e-12)."""
    from vibeam.models import BeamEventSolver

    m = _rig2(n_modes)
    N = outputs(m).n_modes
    W = 15.4 / 7.6
    tr = BeamEventSolver(m, record_modal_states=True).point(W, None, 40, 1, 64)
    prob = shooting_problem(m)
    w = m.system.contacts[0]
    om_ref, m_eff = 2 * np.pi * m.system.reference_hz, outputs(m).m_eff
    up, lo = m.stops[0].law, m.stops[1].law   # the stops' laws in kernel units (the scene's): k / omega_ref^2
    # the lower stop in kernel units: k_l / omega_ref^2, c_l / omega_ref (c_l = 2 zeta_l sqrt(k_l m_eff), k_l
    # in SI), its gap
    kl = lo.stiffness
    cl = 2.0 * lo.damping_ratio * np.sqrt(lo.stiffness * om_ref ** 2 * m_eff) / om_ref
    Dl = m.stops[1].relation.offset
    ms = tr.extra["modal_states"]
    gl = -(ms[:, :N] @ w) - Dl
    inside = np.flatnonzero((gl > 0) & (kl * gl - cl * (ms[:, N:] @ w) > 0))
    assert inside.size
    # near the 18 Hz orbit (one contact on each stop), and inside the lower stop at 15.4 Hz
    x18 = BeamEventSolver(m).point(18.0 / 7.6, None, 100, 1, 4).final_state[:2 * N] * (1 + 1e-3)
    for x, W in ((x18, 18.0 / 7.6), (ms[inside[inside.size // 2]], W)):
        s, J = _beam_jacobian(prob, x, W)
        assert s.status == "ok" and s.extra["contact_time_lower"] > 0 and s.extra["contact_time_upper"] > 0
        A = np.column_stack([s.M, s.x_p])
        assert np.max(np.abs(A - J)) <= 1e-7 * np.max(np.abs(A))
        e = s.extra
        # trace of the free phase's state matrix -sum c_i; each stop's dashpot c / omega_ref along w
        cc = 2.0 * up.damping_ratio * np.sqrt(up.stiffness * om_ref ** 2 * m_eff) / om_ref
        cl = 2.0 * lo.damping_ratio * np.sqrt(lo.stiffness * om_ref ** 2 * m_eff) / om_ref
        want = np.exp(-np.sum(m.system.damping) * 2 * np.pi / W - float(w @ w) * (cc * e["contact_time_upper"]
                                                                      + cl * e["contact_time_lower"]))
        assert abs(np.linalg.det(s.M) / want - 1.0) < 1e-12


def test_beam_two_stop_branch_period_doubling_and_event_runs():
    """Two modes, 18 -> 17 Hz: the period-1 orbit with one contact on each stop loses stability
    in a period doubling at 17.8443 Hz; its stable points and those of the period-2 branch are
    fixed points of the two-stop beam kernel (400-period `event` runs from the branch state end
    on it to 1e-9: the slowest multiplier used, 0.99, leaves 400 periods of decay ~1e-2 of a
    1e-9 perturbation)."""
    from vibeam.models import BeamEventSolver
    from vibeam.models import shooting_problem

    m = _rig2(2)
    W = 18.0 / 7.6
    tr = BeamEventSolver(m).point(W, None, 400, 4, 32)
    brs = trace(shooting_problem(m, "Omega"), tr.final_state[:4], W, 1, 17.0 / 7.6, 19.0 / 7.6, -1)
    assert [b.n for b in brs] == [1, 2]
    pd = [f for f in brs[0].bifurcations if f.type == "period_doubling"]
    assert len(pd) == 1 and pd[0].parameter * 7.6 == pytest.approx(17.8443, abs=1e-3)
    for b in brs:
        a = b.arrays()
        assert np.all(a["impacts_lower"] == b.n) and np.all(a["impacts"] == 2 * b.n)
        idx = [i for i in np.flatnonzero(a["stable"]) if np.abs(a["multipliers"][i]).max() < 0.99]
        assert idx
        for i in idx[:: max(1, len(idx) // 2)]:
            x = a["state"][i]
            t = BeamEventSolver(m).point(a["parameter"][i], np.concatenate([x, [0.0]]), 400, 4, 32)
            assert np.max(np.abs(t.final_state[:4] - x)) < 1e-9 * np.max(np.abs(x))
            assert t.n_impacts_lower == 4 and t.n_impacts == 8


def test_beam_own_lower_law_branch_equals_event_runs_and_map_jacobian():
    """Two modes, lower stop of its own law (``[model.contact_lower]`` 3e4 N/m, damping ratio
    0.15, i.e. R_l = 0.65, beside 1e5 N/m, R = 0.72), 18 -> 17 Hz: the two-stop beam kernel
    (laws from the scene's stops) is the oracle of the beam's shooting problem.

    * Scenario: one period-1 branch, stable throughout (max|mu| 0.64..0.80), one contact on
      each stop per period.
    * Branch points are fixed points of the kernel: 400 periods from the branch state end on
      it (relative 1e-9; 0.8^400 ~ 1e-39; measured <= 9e-15), 4 contacts on each stop in 4
      recorded periods, the same q_min and q_max of the sensor (relative 1e-9).
    * Floquet multipliers = eigenvalues of a central-difference Jacobian of the kernel's
      one-period map (step 1e-5 relative; measured <= 1.2e-9 of max|mu|; bound 1e-6).
    Both fail if the shooting problem's lower stop takes the upper law."""
    m = _rig2(2, lower={"law": "linear", "stiffness_n_m": 3e4, "damping_ratio": 0.15})
    up, lo = (st.law for st in m.stops)
    # the scene holds each SI stiffness over omega_ref^2 (the same division: bit for bit)
    om_ref = 2 * math.pi * m.system.reference_hz
    assert (lo.stiffness, lo.damping_ratio) == (3e4 / om_ref ** 2, 0.15) and up.stiffness == 1e5 / om_ref ** 2
    solver = make_solver(m, "event")
    W = 18.0 / 7.6
    tr = solver.point(W, None, 400, 4, 32)
    brs = trace(shooting_problem(m, "Omega"), tr.final_state[:4], W, 1, 17.0 / 7.6, W, -1)
    assert len(brs) == 1 and brs[0].status == "range_end"
    a = brs[0].arrays()
    assert a["parameter"][-1] * 7.6 == pytest.approx(17.0)
    assert np.all(a["impacts_lower"] == 1) and np.all(a["impacts"] == 2) and np.all(a["stable"])
    idx = range(0, len(a["parameter"]), 6)
    assert len(idx) >= 3
    for i in idx:
        Wi, x = a["parameter"][i], a["state"][i]
        t = solver.point(Wi, np.concatenate([x, [0.0]]), 400, 4, 32)
        assert np.max(np.abs(t.final_state[:4] - x)) < 1e-9 * np.max(np.abs(x)), (Wi, x, t.final_state)
        assert t.n_impacts_lower == 4 and t.n_impacts == 8
        assert t.q_min == pytest.approx(a["q_min"][i], rel=1e-9) and t.q_max == pytest.approx(a["q_max"][i], rel=1e-9)
        mu = a["multipliers"][i]
        ev = np.linalg.eigvals(_event_map_jacobian(solver, Wi, x))
        assert _same_multipliers(mu, ev) < 1e-6 * np.max(np.abs(mu)), (Wi, mu, ev)


def test_beam_far_lower_stop_gives_the_one_stop_shot():
    """A lower stop 100 mm away changes nothing the orbit sees: the two-stop shot equals the
    one-stop shot (state, monodromy, d/dOmega) to round-off (measured: bit for bit)."""
    from vibeam.models import BeamEventSolver

    one, far = _rig2(2, None), _rig2(2, 100.0)
    W = 15.4 / 7.6
    x = BeamEventSolver(one).point(W, None, 40, 4, 32).final_state[:4]
    a, b = shooting_problem(one).shot(x, W, 1), shooting_problem(far).shot(x, W, 1)
    assert a.n_impacts >= 1 and list(b.extra["impact_stops"]) == [0] * a.n_impacts
    np.testing.assert_allclose(b.x, a.x, rtol=0, atol=1e-15 * np.max(np.abs(a.x)))
    np.testing.assert_allclose(b.M, a.M, rtol=0, atol=1e-13 * np.max(np.abs(a.M)))
    np.testing.assert_allclose(b.x_p, a.x_p, rtol=0, atol=1e-13 * np.max(np.abs(a.x_p)))


def test_vibeam_continue_beam_two_stops(tmp_path):
    """`vibeam continue` on the rig with two Kelvin-Voigt stops (2 modes): the case validates
    and the branch from 18 to 17.5 Hz records one contact per period on the lower stop."""
    from vibeam.cli import main
    from vibeam.io.results import read_results

    text = open("cases/rig-fe-neutral.toml").read().split("# quick variant")[0]
    text = text.replace("n_modes = 4", "n_modes = 2\ngap_lower_mm = 0.3")
    text = text.replace("[model.discs]", '[model.contact]\nlaw = "linear"\nstiffness_n_m = 1e5\n\n[model.discs]')
    text = text.replace("frequency_hz = [14.0, 17.0, 61]", "frequency_hz = [17.5, 18.0, 3]")
    text = text.replace('direction = "both"\n', "")
    text += '\n[[run]]\nname = "branches"\nmethod = "continuation"\nstart_at = "high"\n'
    (tmp_path / "rig2.toml").write_text(text)
    assert main(["continue", str(tmp_path / "rig2.toml"), "--out", str(tmp_path / "out"), "--jobs", "1",
                 "--no-plots", "--quiet"]) == 0
    g = read_results(tmp_path / "out" / "results.h5")["branches"]["branches"]
    b = g[sorted(g)[0]]
    assert np.all(np.asarray(b["impacts_per_period_lower"]) == 1)
    # native Omega = f / f1 (f1 = 7.6 Hz)
    assert float(b["parameter"][0]) * 7.6 == pytest.approx(18.0) and float(b["parameter"][-1]) * 7.6 == pytest.approx(17.5)


# ------------------------------------------------------------------ Newton above a compliant stop
#: a Newton upper stop (R = 0.9, [model] R) above a Kelvin-Voigt lower one of its own (k 1e4, R 0.7)
NEWTON_ABOVE = sdof(**FIG8, R=0.9, Delta_lower=0.9e-3, lower_law=LinearContact.from_restitution(1e4, 0.7))


def _settled_any(m, W, periods, x0=None):
    from vibeam.models import EventSolver

    s0 = None if x0 is None else np.array([x0[0], x0[1], 0.0])
    tr = EventSolver(m).point(W, s0, periods, 16, 16)
    return np.asarray(tr.final_state[:2], float), tr


def test_newton_above_compliant_shot_jacobian_and_liouville():
    """A Newton upper stop above a Kelvin-Voigt lower one (refused until the one shooting problem):
    from a state 0.1 % off the settled orbit at Omega 1.9 (an impact above and a contact below
    each period), M and d P / d(Omega, B, Delta, R) against central differences of the shot (step
    1e-6 relative; bound 1e-6 of the largest entry as above), and Liouville's formula with an
    impulsive and a compliant stop: det M = R^(2 m_up) exp(-2 beta T - c_low T_low) (each Newton
    impact's saltation has det R^2, each Kelvin-Voigt phase the trace of its matrix; 1e-10)."""
    m, W = NEWTON_ABOVE, 1.9
    x, tr = _settled_any(m, W, 400)
    assert tr.status == "ok" and set(tr.impact_stops) == {0, 1}
    x = x * (1.0 + 1e-3)
    for par in ("Omega", "system.base_amplitude", "stops[0].relation.offset", "stops[0].law.R"):
        _check_shot_jacobian(m, par, W, x, 1)
    s = shooting_problem(m).shot(x, W, 1)
    m_up = int(np.sum(np.asarray(s.extra["impact_stops"]) == 0))
    want = m.stops[0].law.R ** (2 * m_up) * np.exp(-2 * one_mode(m).beta * 2 * np.pi / W
                                                   - m.stops[1].law.damping * s.extra["contact_time_lower"])
    assert abs(np.linalg.det(s.M) / want - 1.0) < 1e-10


def test_newton_above_compliant_branch_points_are_event_runs():
    """The branch of that scene (Omega 1.6 ... 2.2) through the registry's shooting problem: its
    stable points are fixed points of the event integrator (1500 periods from the branch state
    end on it to 1e-9 of the state, as for two compliant stops above)."""
    m = NEWTON_ABOVE
    x0, _ = _settled_any(m, 1.6, 1500)
    b = trace(shooting_problem(m, "Omega"), x0, 1.6, 1, 1.6, 2.2, +1)[0]
    a = b.arrays()
    idx = [i for i in range(len(a["parameter"])) if a["stable"][i]]
    assert len(idx) >= 3
    for i in idx[:: max(1, len(idx) // 3)]:
        W, x = a["parameter"][i], a["state"][i]
        y, tr = _settled_any(m, W, 1500, x)
        assert np.max(np.abs(y - x)) < 1e-9 * np.max(np.abs(x)), (W, x, y)
