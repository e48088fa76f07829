"""Basins count only states the motion can reach (issue 42, item 2).

On the two-sided Fig. 7 scene (stops at q = 0 and q = -Delta_lower = -2e-3) the default box used
to run q from Delta - 8A = -4.86e-3 to 0: 58-60 % of the initial states lay behind the lower stop,
the event kernel projected each onto the stop, and one line of projected states carried the
fractions.  The oracle here is the closed form of the admissible region, -Delta_lower <= q <=
Delta for a rigid stop, checked state by state.
"""
from __future__ import annotations

import numpy as np
import pytest

import vibeam
from vibeam.api import load_case
from vibeam.engine.jobs import make_job
from vibeam.models.scene import one_mode

TWO = "cases/paper-fig7-two-sided.toml"


def _scene(path=TWO, run=0):
    c = load_case(path)
    r = [x for x in c.run if x.method != "continuation"][run]
    return make_job(c, r, dict(r.model)).spec.scene()


def test_the_default_box_lies_between_the_stops():
    """Both runs of the two-sided scene (lower stop at 2e-3 below the upper one at 0, and the
    symmetric pair at +-2e-3), at three frequencies: the default q range lies in
    [-Delta_lower, Delta] and reaches both ends where 8 A exceeds the distance between them."""
    from vibeam.analysis.attractors import axes_of, default_ranges

    for run in (0, 1):
        sc = _scene(run=run)
        m = one_mode(sc)
        lo, hi = -float(m.Delta_lower), float(m.Delta)
        for W in (1.6, 2.0, 2.38):
            (q0, q1), _ = default_ranges(sc, axes_of(sc, None), W)
            assert lo <= q0 < q1 <= hi, (run, W, q0, q1, lo, hi)
            assert q1 == hi and q0 == lo            # the span 8 A is larger than the gap here


def test_behind_stop_is_the_closed_form_region():
    """Random states on (q, q'): behind a stop exactly where q > Delta or q < -Delta_lower (rigid
    stops); a compliant stop admits penetration, so nothing is behind it."""
    from vibeam.analysis.attractors import behind_stop, stop_gaps

    rng = np.random.default_rng(3)
    sc = _scene()
    m = one_mode(sc)
    S = np.column_stack([rng.uniform(-5e-3, 2e-3, 2000), rng.uniform(-1e-2, 1e-2, 2000), np.zeros(2000)])
    want = (S[:, 0] > m.Delta) | (S[:, 0] < -m.Delta_lower)
    assert want.any() and (~want).any()
    np.testing.assert_array_equal(behind_stop(sc, S), want)
    g = stop_gaps(sc, S)
    np.testing.assert_allclose(g[:, 0], S[:, 0] - m.Delta, rtol=0, atol=1e-18)
    np.testing.assert_allclose(g[:, 1], -S[:, 0] - m.Delta_lower, rtol=0, atol=1e-18)
    # a state exactly on a stop (the box's edge) is admissible
    assert not behind_stop(sc, [[0.0, 1e-3, 0.0], [-m.Delta_lower, -1e-3, 0.0]]).any()
    kv = vibeam.api.load_case({"name": "kv", "model": {"fidelity": "sdof", "beta": 0.015, "B": 5e-4, "Delta": 0.0,
                                                       "R": 0.9, "contact": {"law": "linear", "stiffness": 1e4}},
                               "sweep": {"Omega": [2.0, 2.1, 2]}, "run": [{"name": "e", "method": "event"}]})
    mk = make_job(kv, kv.run[0], {}).spec.scene()
    assert not behind_stop(mk, S).any()


def test_states_behind_a_stop_are_excluded_counted_and_not_simulated(tmp_path, monkeypatch):
    """A user box reaching q = -4e-3 (below the lower stop): every state with q < -Delta_lower is
    labelled behind-stop (-4), none of them is simulated, the fractions are those of the admissible
    states (they and the unsettled/failed shares add up to 1), and the count is stored and printed."""
    from vibeam.analysis import attractors
    from vibeam.models.orbits.attractors import Recurrences

    calls = []
    real = Recurrences.label

    def label(self, step, x):
        calls.append(float(x[0]))
        return real(self, step, x)

    monkeypatch.setattr(Recurrences, "label", label)
    r = vibeam.basins(TWO, Omega=2.38, samples=200, seed=1, x_range=[-4e-3, 0.0], lyapunov_periods=0,
                      out=tmp_path / "results.h5")
    q = r.initial[:, 0]
    behind = q < -2e-3
    assert 0.3 < behind.mean() < 0.7
    np.testing.assert_array_equal(r.labels[0] == attractors.BEHIND_STOP, behind)
    assert r.behind_stop(0) == behind.sum()
    assert len(calls) == (~behind).sum() and min(calls) >= -2e-3
    counted = r.labels[0][~behind]
    total = sum(float(np.mean(counted == k)) for k in range(r.n_attractors))
    total += float(np.mean(counted < 0))
    assert total == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(r.attractors["fraction"][0], [np.mean(counted == k) for k in range(r.n_attractors)])
    ds = attractors.read_basins(tmp_path / "results.h5", r.name)
    assert int(ds["states_behind_stop"].values[0]) == behind.sum()


def test_the_basin_plot_draws_every_stop(tmp_path):
    """Both stops of the two-sided scene are drawn (read back from the figure's artists)."""
    from vibeam.analysis.attractors import basins_figure

    r = vibeam.basins(TWO, Omega=2.0, grid=(6, 5), lyapunov_periods=0)
    fig = basins_figure(r, 0)
    xs = sorted(float(l.get_xdata()[0]) for l in fig.axes[0].lines if l.get_linestyle() == "--")
    assert xs == pytest.approx([-2e-3, 0.0], abs=1e-15)


# ----------------------------------------------------------------------------- item 3: labels
P1_FIXED_POINT = np.array([-0.00137751, 0.00126769])   # the period-1 orbit at Omega = 2.38 (q, q')


def _reaches_period_one(sc, state, periods=20000):
    """An independent label: the event kernel followed up to ``periods`` periods (chunks of 2000,
    no cells, no recurrence) ends on the period-1 fixed point (to 1e-5 relative)."""
    from vibeam.models import EventSolver

    sol = EventSolver(sc)
    x = np.array([state[0], state[1], 0.0])
    for _ in range(periods // 2000):
        x = sol.point(2.38, x, 2000, 1, 16).final_state
        if np.max(np.abs(x[:2] - P1_FIXED_POINT) / np.abs(P1_FIXED_POINT)) < 1e-5:
            return True
    return False


def test_states_on_their_way_to_period_one_are_labelled_period_one():
    """The census of the two-sided scene at Omega = 2.38 (400 samples, seed 1): states 41 and 288
    reach the period-1 orbit (followed 20000 periods by the event kernel alone) but, deciding by
    10 consecutive basin cells of earlier states (the old hit_basin), were labelled chaotic (their
    transients cross cells of the chaotic attractor's basin).  The default (50) labels them
    period-1, and the census reports its own check: 50 labels followed 5000 periods, none wrong."""
    sc = _scene()
    r = vibeam.basins(TWO, Omega=2.38, samples=400, seed=1, lyapunov_periods=0)
    p1 = [k for k in range(r.n_attractors) if r.attractors["type"][0][k] == "period"]
    assert len(p1) == 1
    for i in (41, 288):
        assert _reaches_period_one(sc, r.initial[i])
        assert r.labels[0][i] == p1[0], i
    assert int(r.labels_checked[0]) == 50 and int(r.labels_wrong[0]) == 0
    rate, upper = r.mislabel_rate(0)
    assert rate == 0.0 and upper == pytest.approx(1 - 0.05 ** (1 / 50), rel=1e-6)
    old = vibeam.basins(TWO, Omega=2.38, samples=400, seed=1, lyapunov_periods=0, hit_basin=10, verify=0)
    assert old.labels[0][41] != p1[0] and old.labels[0][288] != p1[0]      # the mechanism, as measured


@pytest.mark.slow
def test_the_default_mislabels_at_most_one_in_two_thousand():
    """2000 census states, each followed 20000 periods by the event kernel alone: the default
    settings label at most 1 of them wrong (measured 0; with hit_basin = 10: 12, with 20: 2;
    the issue's independent check found 4 of 4000 wrong with the old settings and box), and the
    census's own check with every state (verify = 2000) counts those wrong labels too: at least
    them, and at most 2 more (it tells every attractor apart, the independent check only period-1
    or not, so a label between two other attractors is wrong to it alone: 13 against 12 on CI's
    first run of this test, 12 against 12 before)."""
    sc = _scene()
    r = vibeam.basins(TWO, Omega=2.38, samples=2000, seed=1, lyapunov_periods=0, verify=0)
    p1 = [k for k in range(r.n_attractors) if r.attractors["type"][0][k] == "period"][0]
    truth = np.array([_reaches_period_one(sc, s) for s in r.initial])
    wrong = int(np.sum((r.labels[0] == p1) != truth))
    assert wrong <= 1, wrong
    old = vibeam.basins(TWO, Omega=2.38, samples=2000, seed=1, lyapunov_periods=0, hit_basin=10, verify=2000,
                        verify_periods=20000)
    p1o = [k for k in range(old.n_attractors) if old.attractors["type"][0][k] == "period"][0]
    truth_wrong = int(np.sum((old.labels[0] == p1o) != truth))
    assert truth_wrong + 2 >= int(old.labels_wrong[0]) >= truth_wrong >= 5, (int(old.labels_wrong[0]), truth_wrong)


def test_simulate_refuses_a_state_behind_a_stop():
    """simulate(state=[-0.004, 0.005]) on the two-sided scene (q below the lower stop at -2e-3)
    returned ``ok`` from the state projected onto the stop; now it is refused in one line naming
    the state and the stop; a state on the stop is taken."""
    with pytest.raises(ValueError, match=r"state = .*behind stop 1 .*lower stop"):
        vibeam.simulate(TWO, Omega=2.38, periods=2, state=[-0.004, 0.005, 0.0])
    sim = vibeam.simulate(TWO, Omega=2.38, periods=2, state=[-0.002, 0.005, 0.0])
    assert sim.summary["status"] in ("ok", "chatter", "unsettled")
