"""Continuation of periodic orbits between two stops (restitution law on each stop; SDOF
and modal beam: the scene's shooting problem, models/core/scene_shooting.py) against independent oracles:

* stable branch points against long runs of the event solver (amplitude and impacts per stop);
* Floquet multipliers against finite differences of the stroboscopic map iterated by the event
  solver (not the shot's derivative assembly);
* Liouville with impact contraction: ``det M = R^(2 m_up) R_low^(2 m_low) e^(-2 beta n T)``;
* symmetric stops: the orbit with one impact on each stop has the symmetry ``x(t + T/2) =
  -x(t)``, and a lower stop that is never touched gives the one-stop branch identically;
* the grazing of the lower stop where the linear free response's minimum reaches
  ``-Delta_lower`` (closed form);
* the one-mode beam against the SDOF branch; the two-mode beam's derivatives (impacts and
  sticking on the lower stop) against central differences.
"""
import functools
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from vibeam.case.schema import parse_case
from vibeam.models import EventSolver, linear_amplitude, shooting_problem
from vibeam.models import BeamEventSolver
from vibeam.models.builders.beam import mass_stops
from vibeam.models.builders.matrices import modal_scene
from vibeam.models.orbits.continuation import Settings, trace
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models.builders.sdof import sdof
from vibeam.models.contact import Restitution
from vibeam.models.scene import one_mode

#: the first scene of cases/paper-fig7-two-sided.toml: Fig. 7's stop at Delta = 0 and a lower stop at
#: q = -2e-3 (an impact on it is born at Omega = 1.6976)
LOW = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9, Delta_lower=2e-3)
#: its symmetric scene: both stops 2e-3 from the equilibrium
SYM = sdof(beta=0.015, B=0.5e-3, Delta=2e-3, R=0.9, Delta_lower=2e-3)
NO_SWITCH = Settings(switch=False)


def _settled(sc, W, n_tr=3000):
    tr = EventSolver(sc).point(W, None, n_tr, 16, 16)
    return np.asarray(tr.final_state[:2], float)


@functools.lru_cache(maxsize=None)
def low_branch():
    """The period-1 branch of LOW from the settled orbit at Omega = 1.5 (one impact on the upper
    stop) up to 2.5: through the grazing of the lower stop at 1.6976 and the period doubling at
    2.0846 (no switching)."""
    (b,) = trace(shooting_problem(LOW, "Omega"), _settled(LOW, 1.5), 1.5, 1, 1.5, 2.5, +1, NO_SWITCH)
    return b


def test_the_shooting_problem_serves_two_stops_and_the_case_allows_it():
    """The refusal is gone: vibeam.models.shooting_problem builds both fidelities' problems for a
    two-sided scene, and a case with method = "continuation" and a lower stop validates."""
    # the scene's one problem (vibeam.models.core.scene_shooting), on both stops
    for m in (LOW, _beam1(0.0, 2e-3)):
        p = shooting_problem(m, "Omega")
        assert isinstance(p, SceneShooting) and len(p.scene.stops) == 2
    case = parse_case('name = "x"\n[model]\nfidelity = "sdof"\nbeta = 0.015\nB = 0.5e-3\nR = 0.9\n'
                      'Delta = 0.0\nDelta_lower = 2e-3\n[sweep]\nOmega = [1.5, 2.5, 3]\n[[run]]\nname = "a"\n'
                      'method = "continuation"\n', "x.toml")
    assert case.run[0].method == "continuation"


@pytest.mark.slow   # default step budget (30-50 s on a cold numba cache); CI runs it in the slow step
def test_branch_crosses_the_lower_grazing_and_doubles():
    """The branch of LOW: one impact per period on the upper stop below Omega = 1.6976, then one on
    each stop (a new impact is born on the lower stop: the grazing is located where the deepest
    free-flight minimum touches -Delta_lower).  The orbit born there is unstable (a multiplier
    ~ -120 next to the grazing) and becomes stable at the period doubling at 2.0846 (multiplier
    -1; the period-2 orbits of the sweeps lie between)."""
    b = low_branch()
    a = b.arrays()
    assert b.status == "range_end"
    kinds = [f.type for f in b.bifurcations]
    assert kinds == ["grazing", "period_doubling"]
    g, pd = b.bifurcations
    assert g.parameter == pytest.approx(1.6976049, abs=1e-6) and "a new impact is born" in g.detail
    assert pd.parameter == pytest.approx(2.0845911, abs=1e-6)
    assert np.min(np.abs(pd.multipliers + 1.0)) < 1e-6
    stable = a["stable"]
    assert not stable[(a["parameter"] > g.parameter) & (a["parameter"] < pd.parameter)].any()
    assert stable[a["parameter"] > pd.parameter].all() and stable[a["parameter"] < g.parameter].all()
    before, after = a["parameter"] < g.parameter, a["parameter"] > g.parameter
    assert np.all(a["impacts"][before] == 1) and np.all(a["impacts_lower"][before] == 0)
    assert np.all(a["impacts"][after] == 2) and np.all(a["impacts_lower"][after] == 1)
    # below the grazing the lower stop is approached (apex_gap: its gap at the deepest minimum)
    k = np.flatnonzero(before)[-1]
    assert -1e-4 < a["apex_gap"][k] < 0


def test_stable_branch_points_equal_long_event_runs():
    """Stable points (with impacts on one or both stops) stay put under 2000 periods of the event
    solver started 1e-6 off the orbit; the amplitude and the impacts per period on each stop of
    the recorded periods are the branch's.  Tolerance 1e-8 relative: the corrector's residual
    (1e-11 of the state scale) amplified by 1 / (1 - max |mu|) (<= 30 at the points taken, which
    keep max |mu| < 0.97), and the perturbation decayed by max |mu|^2000 < 1e-26."""
    a = low_branch().arrays()
    mu = np.max(np.abs(a["multipliers"]), axis=1)
    # away from the grazing (a perturbation of 1e-6 must not reach the lower stop: apex_gap < -1e-5)
    idx = np.flatnonzero(a["stable"] & (mu < 0.97) & (a["apex_gap"] < -1e-5))
    taken = idx[:: max(1, len(idx) // 6)]
    assert set(a["impacts_lower"][taken]) == {0, 1}          # both kinds of orbit are checked
    for k in taken:
        W, x = a["parameter"][k], a["state"][k]
        tr = EventSolver(LOW).point(W, np.r_[x * (1 + 1e-6), 0.0], 2000, 4, 8)
        assert np.max(np.abs(tr.final_state[:2] - x)) < 1e-8 * np.max(np.abs(x))
        assert one_mode(LOW).Delta - tr.q_min == pytest.approx(a["amplitude"][k], rel=1e-8)
        assert tr.n_impacts_lower == 4 * a["impacts_lower"][k]
        assert tr.n_impacts - tr.n_impacts_lower == 4 * (a["impacts"][k] - a["impacts_lower"][k])
    # an unstable point (the orbit born at the grazing, multiplier ~ -4, stable only beyond the
    # period doubling) leaves under the same run: the check can fail
    k = int(np.argmin(np.abs(mu - 4.0)))
    assert not a["stable"][k] and 3 < mu[k] < 5 and a["impacts_lower"][k] == 1
    tr = EventSolver(LOW).point(a["parameter"][k], np.r_[a["state"][k] * (1 + 1e-6), 0.0], 2000, 4, 8)
    assert np.max(np.abs(tr.final_state[:2] - a["state"][k])) > 1e-6 * np.max(np.abs(a["state"][k]))


def _event_map_jacobian(sc, W, x, n, rel=1e-7):
    """Central differences of ``P^n`` iterated by the event solver (its own kernel call, no event
    log, no derivative assembly)."""
    h = rel * np.max(np.abs(x))
    J = np.empty((2, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = h
        xp = EventSolver(sc).point(W, np.r_[x + e, 0.0], 0, n, 8).final_state[:2]
        xm = EventSolver(sc).point(W, np.r_[x - e, 0.0], 0, n, 8).final_state[:2]
        J[:, j] = (np.asarray(xp) - np.asarray(xm)) / (2 * h)
    return J


@pytest.mark.parametrize("W", [1.6, 1.9, 2.3])
def test_multipliers_against_finite_differences_of_the_event_map(W):
    """Monodromy and Floquet multipliers of branch points with impacts on the upper stop only
    (1.6) and on both stops (1.9, and 2.3 past the period doubling), against central differences
    of the event solver's stroboscopic map (h = 1e-7 of the state: truncation ~h^2 times the
    curvature of P, round-off ~1e-16 / h; measured <= 4.6e-9 relative): 1e-6."""
    b = low_branch()
    k = int(np.argmin([abs(pt.p - W) for pt in b.points]))
    pt = b.points[k]
    J = _event_map_jacobian(LOW, pt.p, pt.x, 1)
    assert np.max(np.abs(J - pt.shot.M)) < 1e-6 * np.max(np.abs(pt.shot.M))
    mu_fd = np.linalg.eigvals(J)
    assert max(np.min(np.abs(pt.mu - z)) for z in mu_fd) < 1e-6 * max(1.0, np.max(np.abs(pt.mu)))


def test_liouville_with_impact_contraction():
    """``det M = R^(2 m_up) R_low^(2 m_low) exp(-2 beta n T)`` (the flow's contraction and the
    saltation matrices' determinants R, d = 2): along the whole branch of LOW (same R), and for
    period-1/2 orbits of a scene whose lower stop has its own R_low = 0.6 (settled by the event
    solver); 1e-10 relative (round-off of the products; measured <= 5.3e-12 on the branch)."""
    for pt in low_branch().points:
        st = pt.shot.extra["impact_stops"]
        expect = 0.9 ** (2 * st.size) * math.exp(-2 * one_mode(LOW).beta * 2 * math.pi / pt.p)
        assert np.linalg.det(pt.shot.M) == pytest.approx(expect, rel=1e-10)
    m = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9, Delta_lower=2e-3, lower_law=Restitution(0.6))
    seen = set()
    for W in (1.8, 2.0, 2.3):
        x = _settled(m, W)
        pr = shooting_problem(m, "Omega")
        n = 1 if np.max(np.abs(pr.shot(x, W, 1).x - x)) < 1e-9 * np.max(np.abs(x)) else 2
        s = pr.shot(x, W, n)
        st = s.extra["impact_stops"]
        up, lo = int(np.sum(st == 0)), int(np.sum(st == 1))
        seen.add(lo > 0)
        expect = 0.9 ** (2 * up) * 0.6 ** (2 * lo) * math.exp(-2 * one_mode(m).beta * n * 2 * math.pi / W)
        assert np.linalg.det(s.M) == pytest.approx(expect, rel=1e-10)
    # every one of the three orbits meets the lower stop (measured: period 2, one lower impact
    # each), so R_low's factor is checked in each determinant, not only in one
    assert seen == {True}
    assert seen == {True}


def test_symmetric_orbit_of_symmetric_stops():
    """Delta = Delta_lower, one R: the branch of the orbit with one impact on each stop (from the
    settled orbit at Omega = 1.5) is continued over [1.5, 2.5] without a bifurcation, and every
    point is symmetric: the impacts alternate between the stops half a period apart with equal
    velocities, q_max = -q_min, and the event solver started from the section state is at
    -x0 half a period later (tolerances: the corrector's residual, 1e-9 relative)."""
    pr = shooting_problem(SYM, "Omega")
    (b,) = trace(pr, _settled(SYM, 1.5), 1.5, 1, 1.5, 2.5, +1, NO_SWITCH)
    assert b.status == "range_end" and not b.bifurcations
    for pt in b.points[::4]:
        s = pt.shot
        T = 2 * math.pi / pt.p
        assert sorted(s.extra["impact_stops"]) == [0, 1]
        v = s.impact_velocities
        assert v[0] == pytest.approx(v[1], rel=1e-9)
        assert abs(abs(s.impact_times[1] - s.impact_times[0]) - T / 2) < 1e-9 * T
        assert s.q_max == pytest.approx(-s.q_min, rel=1e-9)
        tr = EventSolver(SYM).point(pt.p, np.r_[pt.x, 0.0], 0, 1, 16)
        assert np.max(np.abs(tr.samples[8] + pt.x)) < 1e-9 * np.max(np.abs(pt.x))
        assert np.max(np.abs(pt.mu)) < 1.0


def test_a_far_lower_stop_gives_the_one_stop_branch_identically():
    """The Fig. 13 scene (Delta = 0.5e-3) with a lower stop at q = -1, never reached (|q| < 0.02):
    the continuation from the same start gives the one-stop branches, the period-2 branch of the
    period doubling included, point for point and bifurcation for bifurcation, bit for bit (the
    kernel takes the same steps; only the log of minima is added)."""
    one = sdof(beta=0.015, B=0.5e-3, Delta=0.5e-3, R=0.9)
    two = sdof(beta=0.015, B=0.5e-3, Delta=0.5e-3, R=0.9, Delta_lower=1.0)
    x0 = _settled(one, 2.0)
    st = Settings(max_period=2)
    b1 = trace(shooting_problem(one, "Omega"), x0, 2.0, 1, 1.9, 2.4, +1, st)
    b2 = trace(shooting_problem(two, "Omega"), x0, 2.0, 1, 1.9, 2.4, +1, st)
    assert len(b1) == len(b2) == 2 and [b.n for b in b2] == [1, 2]
    for a, b in zip(b1, b2):
        assert (a.status, len(a)) == (b.status, len(b))
        assert np.array_equal([p.p for p in a.points], [p.p for p in b.points])
        assert np.array_equal(np.array([p.x for p in a.points]), np.array([p.x for p in b.points]))
        assert np.array_equal(np.array([p.mu for p in a.points]), np.array([p.mu for p in b.points]))
        assert [(f.type, f.parameter) for f in a.bifurcations] == [(f.type, f.parameter) for f in b.bifurcations]
        assert not b.arrays()["impacts_lower"].any()


def test_lower_grazing_where_the_linear_minimum_reaches_the_lower_stop():
    """The upper stop out of reach (Delta = 1), the lower one at q = -0.7e-3 (Fig. 8's gap): from
    the non-impacting orbit (closed form) at Omega = 2.5 downwards, the grazing of the lower stop
    lies where the linear response's minimum -C(Omega) equals -Delta_lower (brentq to 1e-15; 1e-8
    as the one-stop test), and the branch goes on through a non-smooth fold on the orbit with one
    impact per period on the lower stop.  The scene is the mirror image (q -> -q, t -> t + T/2) of
    Fig. 8's one-stop scene: its fold is the one-stop branch's (1e-8)."""
    m = sdof(beta=0.015, B=0.5e-3, Delta=1.0, R=0.9, Delta_lower=0.7e-3)
    o = one_mode(m)
    pr = shooting_problem(m, "Omega")
    x0, why = pr.start("linear", 2.5)
    assert why == ""
    (b,) = trace(pr, x0, 2.5, 1, 1.5, 2.5, -1, NO_SWITCH)
    Wg = brentq(lambda W: linear_amplitude(o.beta, o.B, W) - o.Delta_lower, 1.5, 2.5, xtol=1e-15)
    assert [f.type for f in b.bifurcations] == ["grazing", "fold"]
    g, fold = b.bifurcations
    assert abs(g.parameter - Wg) < 1e-8
    a = b.arrays()
    assert b.status == "range_end" and a["impacts"][0] == 0 and a["impacts"][-1] == 1
    assert a["impacts_lower"][-1] == 1
    one = sdof(beta=0.015, B=0.5e-3, Delta=0.7e-3, R=0.9)
    p1 = shooting_problem(one, "Omega")
    (b1,) = trace(p1, p1.start("linear", 2.5)[0], 2.5, 1, 1.5, 2.5, -1, NO_SWITCH)
    assert abs(b1.bifurcations[1].parameter - fold.parameter) < 1e-8
    # the linear start refuses an orbit that would reach the lower stop
    assert pr.start("linear", 1.5)[0] is None


# ------------------------------------------------------------------ the beam
def _beam1(Delta, Dl, R=0.9, R_lower=None, B=0.5e-3, beta=0.015):
    """The SDOF oscillator as a one-mode beam: k = 1 (f = f_ref), c = 2 beta, w = Gamma = s = 1,
    phi(x_m) = L = 1 (so q = eta, B = Gamma Y, Delta = Delta_C, m_eff = 1)."""
    f = 10.0
    om = np.array([2 * math.pi * f])
    return modal_scene(om, 2 * beta * 2 * math.pi * f + 0.0 * om ** 2, [1.0], [1.0], np.atleast_2d([1.0]),
                       mass_stops(Delta, Restitution(R), Dl, None if R_lower is None else Restitution(R_lower)),
                       B, f, 1.0, 1.0, "beam")


@pytest.mark.slow   # default step budget (30-50 s on a cold numba cache); CI runs it in the slow step
def test_one_mode_beam_equals_the_sdof_branch():
    """The branch of LOW followed by the beam's shooting problem (another kernel, another
    derivative assembly) on the one-mode beam of the same ODE: the same points (parameter and
    state to 1e-10 of the state scale), impacts per stop and multipliers (1e-9 of the largest;
    ~-120 next to the grazing), and the same grazing and period doubling (1e-8 in Omega: the
    location tolerances).  Measured over all 66 points: 3.6e-12, 5e-9 (4e-11 relative), 4e-16."""
    sd = low_branch()
    (bm,) = trace(shooting_problem(_beam1(0.0, 2e-3), "Omega"), sd.points[0].x, 1.5, 1, 1.5, 2.5, +1, NO_SWITCH)
    assert [f.type for f in bm.bifurcations] == [f.type for f in sd.bifurcations]
    for f, g in zip(bm.bifurcations, sd.bifurcations):
        assert abs(f.parameter - g.parameter) < 1e-8
    scale = np.max(np.abs([p.x for p in sd.points]))
    pr = shooting_problem(LOW, "Omega")
    for pt in bm.points[::5]:
        s = pr.shot(pt.x, pt.p, 1)          # the beam's fixed point is the SDOF's
        assert np.max(np.abs(s.x - pt.x)) < 1e-10 * scale
        assert list(s.extra["impact_stops"]) == list(pt.shot.extra["impact_stops"])
        mu = np.linalg.eigvals(s.M)            # nearest: conjugate pairs may come in either order
        assert max(np.min(np.abs(pt.mu - z)) for z in mu) < 1e-9 * max(1.0, np.max(np.abs(pt.mu)))


def _beam2(Dl, R_lower, Y):
    f = 10.0
    om = np.array([2 * math.pi * f, 2 * math.pi * 63])
    return modal_scene(om, 1.0 + 2e-5 * om ** 2, [1.0, 0.3], [1.0, 0.5], np.atleast_2d([1.0, -0.8]),
                       mass_stops(0.0, Restitution(0.8), Dl, None if R_lower is None else Restitution(R_lower)),
                       Y, f, 1.0, 1.0, "beam")


@pytest.mark.slow   # default step budget (~33 s on a cold numba cache)
@pytest.mark.parametrize("Dl, R_lower, Y, W, sticks", [(2e-3, 0.6, 0.5e-3, 1.8, False),
                                                       (1e-3, 0.0, 0.8e-3, 1.4, True)])
def test_two_mode_beam_derivatives_against_central_differences(Dl, R_lower, Y, W, sticks):
    """A two-mode beam between two stops over two periods from a state on its attractor: impacts on
    both stops (R_lower = 0.6), and plastic impacts with sticking and release on the lower stop
    (R_lower = 0): the monodromy and d x / d(Omega, gap_contact_m, R, gap_contact_lower_m, R_lower)
    against central differences
    of the shot, Richardson-extrapolated from h and h / 2 (h = 1e-6 relative: truncation ~h^4 times
    the fourth derivative): 1e-6.  The first attractor is chaotic (the 2-period map's multipliers
    ~11 and ~3), so the state, and the curvature of P^2 there, is decided by round-off: a plain
    central difference measured 1.6e-8 at one such state and 1.5e-6 at another (its error h^2
    times the curvature: 1.6e-8 at h = 1e-7 there)."""
    m = _beam2(Dl, R_lower, Y)
    x0 = np.asarray(BeamEventSolver(m).point(W, None, 400, 8, 16).final_state[:4])

    def central(f, h):
        """Central difference extrapolated to h -> 0 from h and h / 2 (Richardson)."""
        d1 = (f(h) - f(-h)) / (2 * h)
        d2 = (f(h / 2) - f(-h / 2)) / h
        return (4 * d2 - d1) / 3

    # the lower stop's offset and R too (issue 20: continuation in any numeric parameter); R_lower = 0
    # is the corner of its range (R_lower < 0 is refused), left out
    lower = (("stops[1].relation.offset", Dl),) + ((("stops[1].law.R", R_lower),) if R_lower > 0 else ())
    for par, p in (("Omega", W), ("stops[0].relation.offset", 0.0), ("stops[0].law.R", 0.8)) + lower:
        pr = shooting_problem(m, par, Omega=W)
        s = pr.shot(x0, p, 2)
        assert s.status == "ok" and 1 in s.extra["impact_stops"] and (s.stuck_time > 0) == sticks
        if par == "Omega":
            h = 1e-6 * np.max(np.abs(x0))
            J = np.empty((4, 4))
            for j in range(4):
                e = np.zeros(4)
                e[j] = 1.0
                J[:, j] = central(lambda d: pr.shot(x0 + d * e, p, 2).x, h)
            assert np.max(np.abs(J - s.M)) < 1e-6 * np.max(np.abs(s.M))
        h = 1e-6 * max(abs(p), 1e-3)
        fd = central(lambda d: pr.shot(x0, p + d, 2).x, h)
        assert np.max(np.abs(fd - s.x_p)) < 1e-6 * np.max(np.abs(s.x_p))


def _own_two_stop_period(omega, c, gam, w, Y, W, x, D_up, D_low, R):
    """One forcing period of the modal beam with two Newton stops, integrated here from ``x`` (an
    own solve_ivp with events; nondimensional time ``t = omega_ref t~``): ``eta_i'' + c_i eta_i'
    + omega_i^2 eta_i = Gamma_i Omega^2 Y sin(Omega t)`` while ``-D_low < w^T eta < D_up``; at a
    stop Newton's law along the contact row, ``eta'+ = eta'- - (1 + R) (w^T eta'-) w / |w|^2``
    (the impulse of a point impact on mass-normalised modes).  Returns the state after one period
    and the impacts on each stop."""
    from scipy.integrate import solve_ivp

    n = omega.size
    T = 2 * math.pi / W
    ww = float(w @ w)

    def rhs(t, y):
        eta, v = y[:n], y[n:]
        return np.concatenate([v, -c * v - omega ** 2 * eta + gam * W * W * Y * math.sin(W * t)])

    def up(t, y):
        return w @ y[:n] - D_up
    up.terminal, up.direction = True, 1

    def low(t, y):
        return w @ y[:n] + D_low
    low.terminal, low.direction = True, -1

    t, y = 0.0, np.asarray(x, float).copy()
    hits = [0, 0]
    while True:
        sol = solve_ivp(rhs, (t, T), y, method="DOP853", rtol=1e-12, atol=1e-20, events=[up, low],
                        max_step=T / 256)
        t, y = float(sol.t[-1]), sol.y[:, -1].copy()
        if sol.status == 0:
            return y, hits
        k = 0 if sol.t_events[0].size else 1
        hits[k] += 1
        assert sum(hits) < 50                     # no chatter at the points checked
        y[n:] -= (1 + R) * (w @ y[n:]) * w / ww


@pytest.mark.slow   # an FE build and a beam continuation through the framework (2-3 s warm): the default step
#                     keeps its margin under 10 min
def test_fe_beam_scene_with_two_stops_through_the_framework(tmp_path):
    """A physical FE scene (the rig, 2 modes, gap 0.1 mm, a lower stop 0.3 mm below) continued by
    `vibeam continue`: the case validates, the branches carry the lower stop's impacts, and stable
    points with impacts on both stops stay put under 400 periods of the beam's event solver
    (state to 1e-8 of its scale: the corrector's residual amplified by 1 / (1 - max |mu|))."""
    from vibeam.runner import run_case

    text = """name = "fe-two-sided"
[model]
fidelity = "beam"
length_mm = 180.0
sensor_position_mm = 100.0
mass_position_mm = 132.0
width_mm = 20.0
thickness_mm = 1.0
R = 0.80
gap_mm = 0.1
gap_lower_mm = 0.3
gain = 3.78e-4
voltage = 0.6
damping_ratio = 0.017
n_modes = 2
n_elements = 24
[model.discs]
count = 4
thickness_mm = 7.0
diameter_mm = 35.0
mass_kg = 0.2
[model.calibrate]
f1_hz = 7.6
f2_hz = 98.75
[sweep]
frequency_hz = [16.5, 20.0, 5]
transient_periods = 2000
[[run]]
name = "branches"
method = "continuation"
start = "sweep"
start_at = "high"
switch = false
"""
    case = parse_case(text, "fe-two-sided.toml")
    (r,) = run_case(case, text, tmp_path, jobs=1, quiet=True, plots=False, continuation_only=True)
    assert r.status == "ok" and r.branches
    model = case.model_spec().scene()
    sy = model.system
    checked = 0
    for b in r.branches:
        d = b["data"]
        assert "impacts_lower" in d
        for k in np.flatnonzero(d["stable"] & (d["impacts_lower"] > 0))[::10][:3]:
            W, x = d["parameter"][k], d["state"][k]
            tr = BeamEventSolver(model).point(W, np.r_[x, 0.0], 400, 2, 16)
            assert np.max(np.abs(np.asarray(tr.final_state[:4]) - x)) < 1e-8 * np.max(np.abs(x))
            # independent of the case's gap conversion: the stops at 0.1 mm and 0.3 mm (at the
            # sensor) times phi(x_m) of the static mode written out (phi(x_S) = 1), the period
            # integrated here with the FE model's modal data (input): the orbit closes to 1e-9 of
            # its scale (the continuation's tolerance and an rtol-1e-12 integration amplified by
            # the impacts; measured <= 1.2e-14; a gap off by a factor moves the orbit by O(1))
            xm, xs = 132.0 / 180.0, 100.0 / 180.0
            phim = (xm ** 3 / 3) / (xs * xs * (3 * xm - xs) / 6)
            om = sy.omega               # omega_i / omega_ref
            c = sy.damping              # (alpha + D omega_i^2) / omega_ref
            y, hits = _own_two_stop_period(om, c, sy.participation, sy.contacts[0], sy.base_amplitude,
                                           W, x, 0.1e-3 * phim, 0.3e-3 * phim, 0.8)
            assert hits[0] >= 1 and hits[1] == d["impacts_lower"][k]
            assert np.max(np.abs(y - x)) < 1e-9 * np.max(np.abs(x)), (W, y - x)
            checked += 1
    assert checked


# --------------------------------------------------------------------------- the lower stop's parameters
#: Fig. 7's upper stop and a lower stop at q = -1e-3 with its own R = 0.6: at these frequencies the
#: settled period-1 orbit hits both stops (once above, once or twice below)
OWN = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9, Delta_lower=1e-3, lower_law=Restitution(0.6))


@pytest.mark.parametrize("parameter", ["stops[1].relation.offset", "stops[1].law.R"])
@pytest.mark.parametrize("W", [1.8, 2.2])
def test_the_lower_stops_offset_and_R_are_continuation_parameters(parameter, W):
    """Continuation in the lower stop's offset and R (issue 20: continuation in any numeric
    parameter): ``x_p`` of the shot against central differences of the shot itself (h = 1e-6 of
    the value; bound 1e-7 relative, measured <= 5e-10), on orbits that hit both stops."""
    x0 = _settled(OWN, W, 800)
    prob = shooting_problem(OWN, parameter, Omega=W)
    p0 = prob.value
    assert p0 == (1e-3 if parameter == "stops[1].relation.offset" else 0.6)
    s = prob.shot(x0, p0, 1)
    assert s.status == "ok" and set(s.extra["impact_stops"]) == {0, 1}
    h = 1e-6 * p0
    fd = (prob.shot(x0, p0 + h, 1).x - prob.shot(x0, p0 - h, 1).x) / (2 * h)
    assert np.max(np.abs(s.x_p - fd)) <= 1e-7 * np.max(np.abs(fd)), (s.x_p, fd)
    with pytest.raises(ValueError, match=r"stops\[1\]"):
        shooting_problem(sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9), parameter, Omega=W)


def test_a_branch_in_R_lower_is_made_of_event_orbits_and_obeys_liouville():
    """The period-1 branch in R_lower at Omega = 1.8 (from the settled orbit at R_lower = 0.6, over
    0.3 .. 0.9): each stable point is a fixed point of the event solver's one-period map at its
    R_lower (1e-9 of the state: the corrector's 1e-10 times max |mu| < 1), and each point without
    sticking satisfies ``det M = R^(2 m_up) R_lower^(2 m_low) e^(-2 beta T)`` (1e-9; round-off of
    the saltation products).  A case continues in ``R_lower`` too, and refuses it without a
    lower stop, naming what it allows."""
    W = 1.8
    prob = shooting_problem(OWN, "stops[1].law.R", Omega=W)
    (b, *_) = trace(prob, _settled(OWN, W, 800), 0.6, 1, 0.3, 0.9, 0, NO_SWITCH)
    assert len(b) > 10
    checked = 0
    for pt in b.points:
        s = pt.shot
        if s.status != "ok":
            continue
        stops = np.asarray(s.extra.get("impact_stops", np.zeros(s.n_impacts, int)))
        if s.stuck_time == 0.0:
            want = 0.9 ** (2 * np.sum(stops == 0)) * pt.p ** (2 * np.sum(stops == 1)) * np.exp(-2 * 0.015 * 2 * np.pi / W)
            assert abs(np.linalg.det(s.M) / want - 1.0) <= 1e-9, (pt.p, np.linalg.det(s.M), want)
        if np.max(np.abs(pt.mu)) < 0.95:
            m = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9, Delta_lower=1e-3, lower_law=Restitution(float(pt.p)))
            one = EventSolver(m).point(W, np.concatenate([pt.x, [0.0]]), 0, 1, 16)
            assert np.max(np.abs(one.final_state[:2] - pt.x)) <= 1e-9 * np.max(np.abs(pt.x)), pt.p
            checked += 1
    assert checked >= 5
    text = ('name = "x"\n[model]\nfidelity = "sdof"\nbeta = 0.015\nB = 0.5e-3\nR = 0.9\nDelta = 0.0\n{lower}'
            '[sweep]\nOmega = [1.5, 2.5, 3]\n[[run]]\nname = "a"\nmethod = "continuation"\nparameter = "R_lower"\n'
            'at = 1.8\nrange = [0.3, 0.9]\nstart_at = 0.6\n')
    case = parse_case(text.format(lower="Delta_lower = 1e-3\n[model.contact_lower]\nR = 0.6\n"), "x.toml")
    assert case.run[0].parameter == "R_lower"
    from vibeam.errors import CaseError
    with pytest.raises(CaseError, match="R_lower.*allowed: Omega, B, Delta, R, beta"):
        parse_case(text.format(lower=""), "x.toml")
