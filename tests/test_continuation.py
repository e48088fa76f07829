"""Continuation of periodic orbits (the SDOF scene's shooting problem, models.core.scene_shooting; models.orbits.continuation): exact derivatives,
branches through folds, bifurcations located against independent oracles."""
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from vibeam.models import linear_amplitude, make_solver, shooting_problem
from vibeam.models.orbits.continuation import (ContinuationError, Settings, start_point, trace)
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof, sdof_physical
from vibeam.models.scene import one_mode, with_gap
from vibeam.models.paper.averaging import solve as averaging
from vibeam.engine.records import summarize

TWO_PI = 2 * math.pi
FIG8 = sdof(0.015, 0.5e-3, 0.7e-3, 0.9)      # paper Fig. 8: fold and grazing in 1.5..2.5
FIG13 = sdof(0.015, 0.5e-3, 0.5e-3, 0.9)     # paper Fig. 13: period doubling near 2.28
FN = 7.6
RIG_TIGHT = sdof_physical(FN, 0.017, -0.1, 180.0, 3.78e-4, 0.6, 0.80)     # cases/rig-tight.toml
RIG_STICK = sdof_physical(FN, 0.017, -0.1, 180.0, 5.16e-4, 0.35, 0.72)    # sticks every period


def _value(sc, key):
    """The SDOF parameter ``key`` (``beta``, ``B``, ``Delta`` or ``R``, paper Eqs. 1-2) of the scene ``sc``."""
    om = one_mode(sc)
    return om.stops[0].law.R if key == "R" else getattr(om, key)


def _settled(m, Omega, n_transient=1000):
    tr = EventSolver(m).point(Omega, None, n_transient, 16, 8)
    return tr.final_state[:2], summarize(tr, _value(m, "Delta"))


@pytest.fixture(scope="module")
def fig8_branch():
    """Fig. 8 period-1 branch from the impacting orbit at Omega = 1.5 upwards."""
    x0, _ = _settled(FIG8, 1.5)
    return trace(shooting_problem(FIG8), x0, 1.5, 1, 1.5, 2.5, +1)


@pytest.fixture(scope="module")
def fig13_branches():
    x0, _ = _settled(FIG13, 1.5)
    return trace(shooting_problem(FIG13), x0, 1.5, 1, 1.5, 2.5, +1)


# ------------------------------------------------------------------ exact derivatives
def _orbit(m, Omega, n, x0=None, periods=3000):
    """A settled state at phase 0 (or ``x0`` corrected by Newton) and the problem."""
    pr = shooting_problem(m, "Omega")
    if x0 is None:
        x0, _ = _settled(m, Omega)
    pt, why = start_point(pr, x0, Omega, n, Omega - 1, Omega + 1)
    assert pt is not None, why
    return pt.x, pt.shot


ORBITS = {
    "period-1": (FIG13, 2.0, 1),
    "period-2": (FIG13, 2.29, 2),           # on the period-2 branch born at 2.2808 (stable there)
    "two impacts": (sdof(0.015, 0.5e-3, 0.0, 0.5), 1.0, 1),
    "pre-stressed": (RIG_TIGHT, 16.5 / FN, 1),
    "sticking": (RIG_STICK, 15.0 / FN, 1),
}
#: Newton's start where the settled state is not one: at 16.5 Hz the tight rig's period-1 orbit is
#: unstable (|mu| = 1.22) beside the chaotic chatter attractor that a run from rest lands on
#: (README, example (b)); that attractor's state after 1000 periods depends on round-off, and
#: Newton from it met the orbit on some machines only.  The orbit's state to 5 digits instead.
GUESS = {"pre-stressed": np.array([-2.2492e-3, 5.4533e-4])}


#: the SDOF's parameters (paper Eqs. 1-2) in the order of :class:`EveryDirection`'s columns
PARAMETERS = ("Omega", "B", "Delta", "R", "beta")
#: the SDOF's parameters (paper Eqs. 1-2) as paths into its scene (beta along c = 2 beta)
PATHS = {"Omega": "Omega", "B": "system.base_amplitude", "Delta": "stops[0].relation.offset", "R": "stops[0].law.R",
         "beta": "system.damping"}


def _problem(m, key, Omega):
    """The shooting problem of the SDOF scene ``m`` in its parameter ``key`` at ``Omega``."""
    damping = (_value(m, "beta"), np.array([2.0])) if key == "beta" else None
    return shooting_problem(m, PATHS[key], Omega=Omega, damping=damping)


class EveryDirection(SceneShooting):
    """The scene's problem with the five SDOF directions in the kernel at once (Omega, B, the stop's
    offset, its R, beta: ``c = 2 beta``), in this order or reversed: the tangent's columns of one
    shot, to compare with the one-column problems of each parameter."""

    reverse = False

    def setup(self, p):
        from vibeam.models.core.shooting import Direction, Setup, directions
        su = super().setup(p)
        z = np.zeros(su.core.n_stops)
        up = np.eye(su.core.n_stops)[0]
        every = [Direction("Omega", 1.0, 0.0, z, z, np.zeros(1)), Direction("B", 0.0, 1.0, z, z, np.zeros(1)),
                 Direction("Delta", 0.0, 0.0, up, z, np.zeros(1)), Direction("R", 0.0, 0.0, z, up, np.zeros(1)),
                 Direction("beta", 0.0, 0.0, z, z, np.array([2.0]))]
        return Setup(su.core, su.Omega, directions(su.core, every[::-1] if self.reverse else every), su.gap, su.scale)

    @property
    def column(self):
        return 4 if self.reverse else 0       # Omega's


@pytest.mark.parametrize("name", sorted(ORBITS))
def test_monodromy_and_parameter_derivatives_against_central_differences(name):
    m, Omega, n = ORBITS[name]
    x, s = _orbit(m, Omega, n, GUESS.get(name))
    if name == "two impacts":
        assert s.n_impacts == 2
    if name == "sticking":
        assert s.stuck_time > 0 and np.all(s.M == 0.0)
    if name == "period-2":
        assert s.n_impacts == 2 and np.max(np.abs(shooting_problem(m).shot(x, Omega, 1).x - x)) > 1e-4
    pr = shooting_problem(m, "Omega")
    # central differences with relative steps 1e-6: truncation ~1e-12, round-off ~1e-16/1e-6
    # amplified by the orbit's sensitivity (|M| up to ~10): agreement to 1e-7 of the scale
    h = 1e-6 * np.max(np.abs(x))
    Mfd = np.empty((2, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = h
        Mfd[:, j] = (pr.shot(x + e, Omega, n).x - pr.shot(x - e, Omega, n).x) / (2 * h)
    assert np.max(np.abs(Mfd - s.M)) <= 1e-7 * max(1.0, np.max(np.abs(s.M)))
    every = EveryDirection(m, "Omega").shot(x, Omega, n).extra["x_all_p"]
    for key in PARAMETERS:
        val = Omega if key == "Omega" else _value(m, key)
        pp = _problem(m, key, Omega)
        hp = 1e-6 * max(abs(val), 1e-3)
        fd = (pp.shot(x, val + hp, n).x - pp.shot(x, val - hp, n).x) / (2 * hp)
        an = pp.shot(x, val, n).x_p
        assert np.allclose(an, every[:, PARAMETERS.index(key)], rtol=0, atol=0)
        scale = max(np.max(np.abs(an)), np.max(np.abs(x)))
        assert np.max(np.abs(fd - an)) <= 2e-6 * scale, (key, fd, an)


@pytest.mark.parametrize("name", ["period-1", "period-2", "two impacts", "pre-stressed"])
def test_det_monodromy_is_R_to_2m_times_damping(name):
    """Liouville with the saltation matrices: det M = R^(2m) exp(-2 beta n T) (d = 2)."""
    m, Omega, n = ORBITS[name]
    _, s = _orbit(m, Omega, n, GUESS.get(name))
    expected = _value(m, "R") ** (2 * s.n_impacts) * math.exp(-2 * _value(m, "beta") * n * TWO_PI / Omega)
    assert np.linalg.det(s.M) == pytest.approx(expected, rel=1e-10)


def test_det_monodromy_along_a_whole_branch(fig8_branch):
    b = fig8_branch[0]
    for pt in b.points:
        T = TWO_PI / pt.p
        expected = _value(FIG8, "R") ** (2 * pt.shot.n_impacts) * math.exp(-2 * _value(FIG8, "beta") * T)
        # grows with the condition of M near the grazing (|mu| up to ~1e5): relative to |M|^2
        assert abs(np.linalg.det(pt.shot.M) - expected) <= 1e-12 * max(1.0, np.max(np.abs(pt.shot.M)) ** 2)


# ------------------------------------------------------------------ branches and bifurcations
def test_branch_passes_the_fold_and_comes_back(fig8_branch):
    """PALC follows the stable upper branch to the fold, the unstable part back, and the
    non-impacting orbit after the grazing (Fig. 8 scene)."""
    (b,) = fig8_branch
    a = b.arrays()
    W, stable = a["parameter"], a["stable"]
    assert b.status == "range_end" and W[0] == 1.5 and W[-1] == pytest.approx(2.5, abs=1e-12)
    folds = [f for f in b.bifurcations if f.type == "fold"]
    assert len(folds) == 1
    k = folds[0].index
    assert np.all(np.diff(W[:k]) > 0) and np.all(np.diff(W[k:k + 20]) < 0)  # turns back at the fold
    assert W[k - 1] < folds[0].parameter and W[k] < folds[0].parameter
    assert stable[:k].all() and not stable[k + 1:k + 20].any()               # stable -> unstable
    # at the fold a multiplier is +1 (to the location tolerance)
    assert np.min(np.abs(folds[0].multipliers - 1.0)) < 1e-6
    # the impacting branch ends in a grazing where the non-impacting orbit takes over
    assert a["impacts"][0] == 1 and a["impacts"][-1] == 0 and stable[-1]
    assert "neimark_sacker" not in [f.type for f in b.bifurcations]


def test_grazing_where_the_linear_amplitude_equals_the_gap():
    """Start on the non-impacting orbit (closed form) and continue down in Omega: the grazing
    is where C(Omega) = Delta (closed form, brentq to 1e-15), and the branch goes on, on the
    impacting orbit born there (a non-smooth fold: the impacting branch turns back up)."""
    pr = shooting_problem(FIG8, "Omega")
    x0, why = pr.start("linear", 2.5)
    assert why == ""
    (b,) = trace(pr, x0, 2.5, 1, 1.5, 2.5, -1)
    beta, B, Delta = (_value(FIG8, k) for k in ("beta", "B", "Delta"))
    Wg = brentq(lambda W: linear_amplitude(beta, B, W) - Delta, 1.5, 2.5, xtol=1e-15)
    g = [f for f in b.bifurcations if f.type == "grazing"]
    assert len(g) == 1 and abs(g[0].parameter - Wg) < 1e-8
    assert g[0].amplitude == pytest.approx(2 * Delta, rel=1e-6)   # Q = Delta + C = 2 Delta
    a = b.arrays()
    assert b.status == "range_end" and a["impacts"][0] == 0 and a["impacts"][-1] == 1
    assert [f.type for f in b.bifurcations] == ["grazing", "fold"]


def test_grazing_in_the_gap_at_fixed_frequency():
    """Continuation in Delta of the non-impacting orbit: grazing at Delta = C(Omega)."""
    Omega = 2.3
    pr = shooting_problem(FIG8, "stops[0].relation.offset", Omega=Omega)
    C = float(linear_amplitude(_value(FIG8, "beta"), _value(FIG8, "B"), Omega))
    x0, why = pr.start("linear", 2 * C)
    branches = trace(pr, x0, 2 * C, 1, 0.5 * C, 2 * C, -1)
    g = [f for f in branches[0].bifurcations if f.type == "grazing"]
    assert g and abs(g[0].parameter - C) < 1e-8 * max(1.0, C) + 1e-12


def test_period_doubling_of_fig13_against_finite_difference_multipliers(fig13_branches):
    """The located period doubling is where the multipliers of the stroboscopic map computed by
    central differences of P (no analytic Jacobian) cross -1."""
    b0 = fig13_branches[0]
    pd = [f for f in b0.bifurcations if f.type == "period_doubling"]
    assert len(pd) == 1
    W = pd[0].parameter
    assert W == pytest.approx(2.281, abs=1e-3)          # README: Floquet puts it at ~2.281
    pr = shooting_problem(FIG13, "Omega")

    def fd_multipliers(Wq):
        pt, why = start_point(pr, pd[0].x, Wq, 1, 1.5, 2.5)
        assert pt is not None, why
        x = pt.x
        h = 1e-6 * np.max(np.abs(x))
        J = np.empty((2, 2))
        for j in range(2):
            e = np.zeros(2)
            e[j] = h
            J[:, j] = (pr.shot(x + e, Wq, 1).x - pr.shot(x - e, Wq, 1).x) / (2 * h)
        return np.sort(np.linalg.eigvals(J).real)

    # d(mu)/dOmega ~ 10 here, FD multipliers good to ~1e-8: they bracket -1 within 1e-6 of W
    assert fd_multipliers(W - 1e-6)[0] > -1.0 > fd_multipliers(W + 1e-6)[0]
    assert abs(fd_multipliers(W)[0] + 1.0) < 1e-6


def test_period_doubling_cascade_and_stable_period2_equals_simulation(fig13_branches):
    """Branch switching at the period doubling: the period-2 branch starts at the PD point, is
    stable just after it, and there equals a long event simulation started nearby."""
    types = [(b.n, [f.type for f in b.bifurcations]) for b in fig13_branches]
    assert [n for n, _ in types][:3] == [1, 2, 4]                 # period doubling cascade
    b2 = fig13_branches[1]
    assert b2.n == 2 and b2.points[0].p == pytest.approx(fig13_branches[0].bifurcations[0].parameter)
    a = b2.arrays()
    k = int(np.argmin(np.abs(a["parameter"] - 2.29)))
    assert a["stable"][k]
    W, x = a["parameter"][k], a["state"][k]
    tr = EventSolver(FIG13).point(W, np.r_[x * (1 + 1e-4), 0.0], 3000, 4, 8)
    assert np.max(np.abs(tr.final_state[:2] - x)) < 1e-10 * np.max(np.abs(x)) or \
        np.max(np.abs(tr.strobe[1] - x)) < 1e-10 * np.max(np.abs(x))   # either phase of the orbit
    # the PD cascade of the Fig. 13 scene accumulates (Feigenbaum): successive gaps shrink
    p = [b.points[0].p for b in fig13_branches[:4]]
    assert p[1] - p[0] > p[2] - p[1] > p[3] - p[2] > 0


def test_stable_branch_points_equal_long_event_simulations(fig8_branch):
    """Stable points stay put under 2000 periods of the event solver; an unstable one does not
    (so the check can fail).  Tolerance: the corrector's residual (1e-11 of the state scale)
    amplified by 1 / (1 - max |mu|), up to ~1e3 next to the fold: 1e-8 relative."""
    a = fig8_branch[0].arrays()
    stable_idx = np.flatnonzero(a["stable"] & (a["impacts"] == 1))
    for k in stable_idx[:: max(1, len(stable_idx) // 6)]:
        W, x = a["parameter"][k], a["state"][k]
        tr = EventSolver(FIG8).point(W, np.r_[x * (1 + 1e-6), 0.0], 2000, 2, 8)
        assert np.max(np.abs(tr.final_state[:2] - x)) < 1e-8 * np.max(np.abs(x))
        assert tr.q_min == pytest.approx(a["q_min"][k], rel=1e-8)
    # a clearly unstable point (largest multiplier ~2): round-off grows like 2^periods
    mu = np.max(np.abs(a["multipliers"]), axis=1)
    k = int(np.argmin(np.abs(mu - 2.0)))
    assert not a["stable"][k] and 1.5 < mu[k] < 3
    tr = EventSolver(FIG8).point(a["parameter"][k], np.r_[a["state"][k], 0.0], 2000, 2, 8)
    assert np.max(np.abs(tr.final_state[:2] - a["state"][k])) > 1e-6


def test_fold_lies_between_the_jumps_of_fine_up_and_down_sweeps(fig8_branch):
    """Fig. 8 scene: an up sweep (continuation, step 1e-4) leaves the upper branch within one
    step after the fold; a down sweep leaves the non-impacting orbit at the grazing."""
    (b,) = fig8_branch
    W_fold = [f.parameter for f in b.bifurcations if f.type == "fold"][0]
    W_graze = [f.parameter for f in b.bifurcations if f.type == "grazing"][0]
    a = b.arrays()
    k0 = int(np.argmin(np.abs(a["parameter"][:50] - 1.975)))
    solver = make_solver(FIG8, "event")
    state = np.r_[a["state"][k0], 0.0]
    up = []
    # 2000 periods per step: 1e-4 past the fold the passage through its ghost (time ~ 1/sqrt(W -
    # W_fold)) took ~600 periods, so with 600 the step past the fold ended inside the passage or
    # after it depending on round-off (1e-16 changes of the impact times moved it by periods)
    for W in np.arange(1.975, 1.99, 1e-4):
        tr = solver.point(W, state, 2000, 4, 8)
        state = tr.final_state
        up.append((W, _value(FIG8, "Delta") - tr.q_min))
    upper = [W for W, Q in up if Q > 3e-3]        # upper branch: Q > 6e-3; linear: Q ~ 1.3e-3
    assert upper[-1] <= W_fold < min(W for W, Q in up if Q <= 3e-3)
    state = None
    down = []
    for W in np.arange(1.88, 1.86, -1e-4):
        tr = solver.point(W, state if state is not None else np.r_[shooting_problem(FIG8).start("linear", W)[0], 0.0],
                          600, 4, 8)
        state = tr.final_state
        down.append((W, _value(FIG8, "Delta") - tr.q_min))
    lin = [W for W, Q in down if Q < 3e-3]
    assert min(lin) >= W_graze > max(W for W, Q in down if Q >= 3e-3)
    assert min(lin) - W_graze < 1.5e-4


def test_rig_tight_fold_brackets_the_down_sweep_jump():
    """cases/rig-tight.toml: bistable ~16.3-17 Hz; the down sweep from 17 Hz stays on the
    period-1 orbit down to its fold and jumps within one grid step (0.005 Hz) below it."""
    x0, sm = _settled(RIG_TIGHT, 17 / FN)
    assert sm["period"] == 1
    (b,) = trace(shooting_problem(RIG_TIGHT), x0, 17 / FN, 1, 14 / FN, 17 / FN, -1)
    folds = [f.parameter * FN for f in b.bifurcations if f.type == "fold"]
    assert len(folds) == 1 and 16.2 < folds[0] < 16.35
    solver = make_solver(RIG_TIGHT, "event")
    state = np.r_[x0, 0.0]
    last_p1, first_other = None, None
    for f in np.arange(16.40, 16.10, -0.005):
        tr = solver.point(f / FN, state, 600, 16, 8)
        state = tr.final_state
        if summarize(tr, _value(RIG_TIGHT, "Delta"))["period"] == 1:
            last_p1 = f
        else:
            first_other = f
            break
    assert first_other < folds[0] <= last_p1 + 1e-12


def test_branch_agrees_with_averaging_at_R_1_near_Omega_2():
    """R = 1 (paper Fig. 11 scene): first-order averaging is exact to O(beta, B) at Omega = 2
    (measured 3e-5) and its error grows with the detuning sigma = Omega/2 - 1 (first order:
    measured 0.3 % at |sigma| = 0.025, 0.7 % at 0.05): |Q - Q_avg| / Q <= 1e-4 + 0.2 |sigma|."""
    m = sdof(0.015, 0.5e-3, 0.0, 1.0)
    pr = shooting_problem(m, "Omega")
    x0, why = pr.start("averaging", 2.0)
    (b,) = trace(pr, x0, 2.0, 1, 1.9, 2.1, 0)
    a = b.arrays()
    W, Q = a["parameter"], a["amplitude"]
    Qa = averaging(W, _value(m, "beta"), _value(m, "B"), _value(m, "R"), _value(m, "Delta"), 1)["amplitude"]
    sigma = np.abs(W / 2 - 1)
    assert W.min() == pytest.approx(1.9) and W.max() == pytest.approx(2.1)
    assert np.all(np.abs(Q - Qa) / Q <= 1e-4 + 0.2 * sigma)
    assert abs(Q[np.argmin(np.abs(W - 2))] / Qa[np.argmin(np.abs(W - 2))] - 1) < 1e-4


def test_no_neimark_sacker_for_the_dissipative_sdof(fig13_branches):
    """det M = R^(2m) exp(-2 beta n T) < 1 with d = 2: a complex pair has |mu| = sqrt(det M) < 1,
    so no Neimark-Sacker is possible (nor reported); complex pairs do occur on the branch."""
    seen_complex = False
    for b in fig13_branches:
        assert "neimark_sacker" not in [f.type for f in b.bifurcations]
        for pt in b.points:
            c = pt.mu[np.abs(pt.mu.imag) > 0]
            if c.size:
                seen_complex = True
                assert np.all(np.abs(c) < 1)
    assert seen_complex


def test_sticking_orbits_are_continued_and_their_end_located():
    """Pre-stressed rig at 0.35 V: period-1 orbits that stick once per period (M = 0,
    superstable) are continued; where the sticking phase vanishes the end of sticking is
    located, and points on either side have / have not a sticking phase."""
    x0, sm = _settled(RIG_STICK, 15 / FN)
    pr = shooting_problem(RIG_STICK, "Omega")
    branches = trace(pr, x0, 15 / FN, 1, 14 / FN, 16 / FN, +1, Settings(switch=False))
    b = branches[0]
    a = b.arrays()
    assert a["stuck_time"][0] > 0 and np.all(a["multipliers"][0] == 0)
    st = [f for f in b.bifurcations if f.type == "sticking"]
    assert st, [f.type for f in b.bifurcations]
    W = st[0].parameter
    lo, _ = start_point(pr, b.points[st[0].index - 1].x, W - 1e-7, 1, 14 / FN, 16 / FN)
    hi, _ = start_point(pr, b.points[st[0].index].x, W + 1e-7, 1, 14 / FN, 16 / FN)
    assert lo.shot.stuck_time > 0 and hi.shot.stuck_time == 0


def test_section_crossing_impact_is_passed():
    """When an impact moves through forcing phase 0 the stroboscopic state jumps between pre-
    and post-impact values; the branch goes on from the other representation (resect)."""
    x0, _ = _settled(RIG_STICK, 15 / FN)
    (b,) = trace(shooting_problem(RIG_STICK), x0, 15 / FN, 1, 14 / FN, 16 / FN, -1, Settings(switch=False))
    assert b.status == "range_end" and b.points[-1].p == pytest.approx(14 / FN)
    assert b.resections >= 1


def test_bad_requests():
    with pytest.raises(ValueError, match="'Gamma' is not a parameter"):
        shooting_problem(FIG8, "Gamma")
    with pytest.raises(ValueError, match="needs the forcing frequency"):
        shooting_problem(FIG8, "system.base_amplitude")
    x, why = shooting_problem(FIG8).start("linear", 1.6)
    assert x is None and "does not exist" in why
    with pytest.raises(ContinuationError, match="outside the range"):
        trace(shooting_problem(FIG8), np.zeros(2), 3.0, 1, 1.5, 2.5)
    with pytest.raises(ContinuationError, match="empty"):
        trace(shooting_problem(FIG8), np.zeros(2), 2.0, 1, 2.5, 1.5)
    # a start the problem cannot represent is a status, not an exception (R > 1)
    (b,) = trace(shooting_problem(FIG8, "stops[0].law.R", Omega=2.0), np.array([0.0, 0.0]), 1.2, 1, 0.5, 1.5)
    assert b.status == "failed_start" and "out of range" in b.message


def test_two_parameter_period_doubling_curve(fig13_branches):
    """The period doubling of Fig. 13 continued in (Omega, Delta): a point of the curve is the
    period doubling of a one-parameter continuation at that Delta (to 1e-8)."""
    from vibeam.models.orbits.continuation import trace_curve

    def factory(free, fixed):
        if free == "p1":
            return shooting_problem(with_gap(FIG13, fixed), "Omega")
        return shooting_problem(FIG13, "stops[0].relation.offset", Omega=fixed)

    bf = [f for f in fig13_branches[0].bifurcations if f.type == "period_doubling"][0]
    c = trace_curve(factory, bf, _value(FIG13, "Delta"), (1.5, 2.5), (0.4e-3, 0.6e-3), max_points=16)
    assert c.type == "period_doubling" and len(c.p1) >= 5
    assert min(c.p2) < 0.45e-3 and max(c.p2) > 0.55e-3          # both halves went somewhere
    k = int(np.argmax(np.abs(np.asarray(c.p2) - _value(FIG13, "Delta"))))
    m = with_gap(FIG13, c.p2[k])
    pr = shooting_problem(m)
    pt, why = start_point(pr, c.x[k], c.p1[k] - 0.01, 1, 1.5, 2.5)
    assert pt is not None, why
    (b,) = trace(pr, pt.x, c.p1[k] - 0.01, 1, 1.5, c.p1[k] + 0.01, +1, Settings(switch=False))
    pd = [f.parameter for f in b.bifurcations if f.type == "period_doubling"]
    assert pd and abs(pd[0] - c.p1[k]) < 1e-8


@pytest.mark.parametrize("fidelity", ["sdof", "beam-2-modes"])
def test_the_compiled_corrector_serves_a_frequency_continuation(fidelity, monkeypatch):
    """The engine's corrector calls the problem's compiled one (:meth:`ModalShooting.correct`) and
    falls back to its own Python loop when that raises or declines; the fallback meets the same
    iterates, so the branch is the same either way, but ~30x slower.  A compiled corrector that no
    longer compiles (a kernel's output tuple grew by one entry: its placeholder in
    correct_frequency did not) was hidden that way: every call must return, converged at least
    once, and none may raise."""
    from pathlib import Path

    from vibeam.case.schema import load_case
    from vibeam.models.core.shooting import ModalShooting

    calls, raised, served = [], [], []
    inner = ModalShooting.correct

    def counting(self, *a, **k):
        calls.append(1)
        try:
            r = inner(self, *a, **k)
        except Exception as e:      # noqa: BLE001 - recorded, then re-raised for the engine
            raised.append(repr(e)[:300])
            raise
        served.append(r is not None and r[0] == 0)
        return r

    monkeypatch.setattr(ModalShooting, "correct", counting)
    if fidelity == "sdof":
        m = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9)
        prob, W0, W1 = shooting_problem(m), 1.5, 1.7
        x0 = _settled(m, W0)[0]
    else:
        from vibeam.models import BeamEventSolver

        root = Path(__file__).resolve().parents[1]
        m = load_case(root / "cases" / "rig-fe-neutral.toml")[0].model_spec({"n_modes": 2}).scene()
        W0, W1 = 14.0 / m.system.reference_hz, 14.5 / m.system.reference_hz
        prob = shooting_problem(m, "Omega")
        x0 = BeamEventSolver(m).point(W0, None, 400, 1, 1).final_state[:-1]
    trace(prob, x0, W0, 1, W0, W1, +1, Settings())
    assert calls and not raised, raised[:1]
    assert any(served)


class _AffineSectionMap:
    """A 2-D stroboscopic map with the fixed point ``c(p) = (1 + p, 0)`` and multipliers 0.5,
    whose shot cannot be resolved within ``5e-7`` of ``p_cross`` (an impact closer to the
    section than the event tolerance) -- the situation ``resect`` steps across."""

    dim = 2
    parameter = "p"

    def __init__(self, p_cross):
        self.p_cross = p_cross

    def shot(self, x, p, n):
        from vibeam.models.core.periodic import Shot

        c = np.array([1.0 + p, 0.0])
        status = "failed" if abs(p - self.p_cross) < 5e-7 else "ok"
        return Shot(x=c + 0.5 * (np.asarray(x, float) - c), M=0.5 * np.eye(2), x_p=np.array([0.5, 0.0]),
                    impact_times=np.zeros(1), impact_velocities=np.ones(1), q_min=0.0, q_max=1.0,
                    status=status)

    def resect(self, x, p, n):
        return np.array([1.0 + p, 0.0])          # the orbit seen from the other side of the section


def test_resect_steps_to_the_first_resolvable_parameter_beyond_the_crossing():
    """``_Tracer.resect``: after an impact crosses the section the orbit is continued from its
    other representation at the smallest step of the parameter (of 1e-10 ... 1e-4 of the range)
    where Newton converges, inside the range, in the direction of travel.  Here every step below
    1e-6 is unresolvable, so the new point must be the fixed point ``c(p)`` at exactly ``p_cross +
    1e-6`` (a larger step in the ladder, e.g. a mutated 1e-6, leaves the range and gives up)."""
    from vibeam.models.orbits.continuation import Branch, _Engine, _Tracer

    p_cross = 0.5
    prob = _AffineSectionMap(p_cross)
    eng = _Engine(prob, 0.0, 1.0, Settings(), s_x=1.0)
    tr = _Tracer(eng)
    far = np.array([0.0, 5.0])                     # the orbit as seen before the crossing
    a = eng.make_point(far, p_cross, prob.shot(far, 0.0, 1), t=np.array([0.0, 0.0, 1.0]))
    br = Branch(n=1, origin="start")
    assert tr.resect(br, a, 1)
    pt = br.points[-1]
    assert pt.p == pytest.approx(p_cross + 1e-6, rel=0, abs=1e-15)
    np.testing.assert_allclose(pt.x, [1.0 + pt.p, 0.0], rtol=0, atol=Settings().tol)   # Newton's own tolerance
    assert br.resections == 1
    assert pt.t[2] > 0                              # still travelling towards larger p


def test_the_parameter_derivatives_do_not_depend_on_the_order_of_the_directions():
    """The shooting tangent's parameter columns (``d x / d p`` of each :class:`Direction`) are
    independent of where a direction sits in the list: the frequency as the last of the five
    SDOF directions (every fidelity puts it first today, so a column offset wrong for p >= 1
    is otherwise unseen) gives the columns of the usual order, reversed, and its own column is
    the central difference of the shot in Omega (relative steps 1e-6: as above, 2e-6 of the
    scale)."""
    m, Omega, n = ORBITS["two impacts"]
    x, s = _orbit(m, Omega, n, None)
    usual = EveryDirection(m, "Omega").shot(x, Omega, n).extra["x_all_p"]

    class Reversed(EveryDirection):
        reverse = True

    pr = Reversed(m, "Omega")
    got = pr.shot(x, Omega, n)
    assert got.status == "ok" and got.n_impacts == s.n_impacts
    scale = max(np.max(np.abs(usual)), np.max(np.abs(x)))
    np.testing.assert_allclose(got.extra["x_all_p"], usual[:, ::-1], rtol=0, atol=1e-12 * scale)
    hp = 1e-6 * Omega
    fd = (pr.shot(x, Omega + hp, n).x - pr.shot(x, Omega - hp, n).x) / (2 * hp)
    assert np.max(np.abs(fd - got.x_p)) <= 2e-6 * scale, (fd, got.x_p)
