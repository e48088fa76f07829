"""Continuation of periodic orbits with a compliant (Kelvin-Voigt) stop: the shooting problem of
vibeam.models.periodic_compliant against finite differences, the event kernel, the
entry-to-entry map of Sec. 4.2, Liouville's formula, the CoR limit and the command line."""
import math
from dataclasses import replace

import numpy as np
import pytest

from vibeam.case import CaseError, parse_case
from vibeam.models import shooting_problem
from vibeam.models.compliant import HuntCrossley, LinearContact
from vibeam.models.continuation import start_point, trace
from vibeam.models.periodic_compliant import CompliantSDOFShooting
from vibeam.models.sdof import SDOF, EventSolver
from vibeam.models.sdof_compliant import CompliantEventSolver
from vibeam.records import summarize

FIG8 = SDOF(0.015, 0.5e-3, 0.9, 0.7e-3)      # paper Fig. 8: fold and grazing in 1.5..2.5 (CoR)
FOLD_COR = 1.9850022038952106                # its CoR fold (tests/test_continuation.py branch)


def _kv(m, k, R=0.9):
    return replace(m, contact=LinearContact.from_restitution(k, R))


def _settled(m, Omega, periods=1500, x0=None):
    s0 = None if x0 is None else np.array([x0[0], x0[1], 0.0])
    tr = CompliantEventSolver(m).point(Omega, s0, periods, 16, 16)
    return np.asarray(tr.final_state[:2], float), summarize(tr, m.Delta)


@pytest.fixture(scope="module")
def fig8_kv():
    """The Fig. 8 scene on a Kelvin-Voigt stop (k_c = 1e4, target R = 0.9): period-1 branch
    from the contacting orbit at Omega = 1.5 up to 2.5."""
    m = _kv(FIG8, 1e4)
    x0, _ = _settled(m, 1.5)
    brs = trace(CompliantSDOFShooting(m), x0, 1.5, 1, 1.5, 2.5, +1)
    return m, brs


# ------------------------------------------------------------------ exact derivatives
CASES = {
    "one contact, Delta = 0": (SDOF(0.015, 0.5e-3, 0.9, 0.0), 1e4, 2.2, 1, None),
    "Fig. 8 gap, upper branch": (FIG8, 1e4, 1.9, 1, None),
    "period 2 (two contacts), soft": (SDOF(0.015, 0.5e-3, 0.9, 0.0), 1e4, 2.8, 2, None),
    "stiff stop": (FIG8, 1e6, 1.8, 1, None),
    "in contact at the section": (SDOF(0.015, 0.5e-3, 0.9, 0.0), 1e2, 2.9, 2, None),   # period 2
}


@pytest.mark.parametrize("name", list(CASES))
def test_shot_jacobian_equals_central_differences(name):
    """M = d P^n / d x0 and d P^n / d(Omega, B, Delta) against central differences of the shot
    itself, from a state off the orbit (a perturbed settled state: events at generic times).
    Step 1e-6 relative: truncation ~1e-12 and round-off ~1e-16 / 1e-6 = 1e-10 of the entries,
    so 1e-6 relative to the largest entry is a loose bound (measured <= 1e-8)."""
    base, k, W, n, _ = CASES[name]
    m = _kv(base, k)
    x, _ = _settled(m, W, 400)
    x = x * (1.0 + 1e-3)
    for par in ("Omega", "B", "Delta"):
        prob = CompliantSDOFShooting(m, par, Omega=W)
        p = W if par == "Omega" else float(getattr(m, par))
        s = prob.shot(x, p, n)
        assert s.status == "ok" and s.n_impacts >= 1, s.message
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
        # columns in the units of their variable: compare each column to its own scale
        for c in range(3):
            np.testing.assert_allclose(A[:, c], J[:, c], rtol=0, atol=1e-6 * np.max(np.abs(A[:, c])), err_msg=par)
    if name == "in contact at the section":
        assert s.extra["in_contact_end"]


def test_liouville_and_the_map_of_sec_4_2(fig8_kv):
    """Along the branch det M = exp(-2 beta T - c_c T_c) (the divergence of the free and the
    contact flows; the entry saltation has det 1) to 1e-10 relative (measured ~1e-14), and at
    stable one-contact points the multipliers equal those of the entry-to-entry map of Sec. 4.2
    (vibeam.models.sdof_compliant_map, another section of the same orbit) to 1e-9
    (measured ~1e-13)."""
    from vibeam.models.sdof_compliant_map import CompliantMappingSolver

    m, brs = fig8_kv
    b = brs[0]
    cc = m.contact.damping
    for pt in b.points:
        T = 2 * math.pi / pt.p
        det = math.exp(-2 * m.beta * T - cc * pt.shot.extra["contact_time"])
        assert np.linalg.det(pt.shot.M) == pytest.approx(det, rel=1e-10)
    ms = CompliantMappingSolver(m)
    checked = 0
    for pt in b.points[::40]:
        if pt.shot.n_impacts != 1 or not np.max(np.abs(pt.mu)) < 1.0:
            continue
        t_in, v_in = float(pt.shot.impact_times[0]), float(pt.shot.impact_velocities[0])
        out = ms.point(pt.p, np.array([(pt.p * t_in) % (2 * math.pi), v_in]), 0, 0)
        assert out["status"] == "ok"
        assert out["impact_velocity"] == pytest.approx(v_in, rel=1e-9)
        err = max(np.min(np.abs(pt.mu - z)) for z in out["multipliers"])   # each matched to its nearest
        assert err < 1e-9 and abs(np.prod(out["multipliers"]) - np.prod(pt.mu)) < 1e-9
        checked += 1
    assert checked >= 3


def test_branch_fold_grazing_and_event_runs(fig8_kv):
    """The compliant branch has the CoR branch's shape: a fold (multiplier +1 there, to 1e-6)
    and, on the lower part, the grazing where the contact dies at the grazing frequency of the
    non-impacting orbit (a property of the linear orbit, law-independent: equal to the CoR
    grazing 1.870239215 to 1e-8).  Stable points are the attractors of long event runs of the
    compliant kernel started 1 % off the orbit: after 1500 periods the distance has shrunk by
    max|mu|^1500 < 1e-30, so the amplitudes agree to round-off of the exact flows (1e-9
    relative; measured ~1e-13)."""
    m, brs = fig8_kv
    b = brs[0]
    assert b.status == "range_end"
    folds = [f for f in b.bifurcations if f.type == "fold" and f.amplitude > 3e-3]
    assert len(folds) == 1 and np.min(np.abs(folds[0].multipliers - 1.0)) < 1e-6
    graze = [f for f in b.bifurcations if f.type == "grazing"]
    assert graze and graze[0].parameter == pytest.approx(1.870239215, abs=1e-8)
    A = b.arrays()
    stable = np.flatnonzero(A["stable"] & (A["impacts"] == 1))
    for i in stable[:: max(1, len(stable) // 4)]:
        pt = b.points[i]
        _, sm = _settled(m, pt.p, 1500, x0=pt.x * 1.01)
        assert sm["period"] == 1
        assert sm["amplitude"] == pytest.approx(A["amplitude"][i], rel=1e-9)


def test_branch_tends_to_the_cor_branch_as_the_stiffness_grows():
    """As k_c grows (target R fixed) the compliant fold tends to the CoR fold like the contact
    duration, k_c^(-1/2): the fold shifts by 1.9e-3 and 5.9e-4 in Omega at k_c = 1e6 and 1e7
    (measured; CoR fold 1.98500220, tests/test_continuation.py); their ratio lies within
    [2.5, 4] of sqrt(10) = 3.16, and the fold amplitude converges too."""
    shifts, amps = [], []
    for k in (1e6, 1e7):
        m = _kv(FIG8, k)
        x0, _ = _settled(m, 1.9, 600)
        b = trace(CompliantSDOFShooting(m), x0, 1.9, 1, 1.8, 2.05, +1)[0]
        folds = [f for f in b.bifurcations if f.type == "fold"]
        assert len(folds) == 1
        shifts.append(FOLD_COR - folds[0].parameter)
        amps.append(folds[0].amplitude)
    assert 0 < shifts[1] < shifts[0] < 3e-3
    assert 2.5 < shifts[0] / shifts[1] < 4.0
    assert abs(amps[1] - 0.006385050265680355) < 0.5 * abs(amps[0] - 0.006385050265680355)


# ------------------------------------------------------------------ framework
CASE = '''
name = "kvc"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
[model.contact]
law = "linear"
stiffness = 1e4
[sweep]
Omega = [1.5, 2.6, 5]
transient_periods = 300
record_periods = 16
[[run]]
name = "branches"
method = "continuation"
start_at = "low"
'''


def test_registry_dispatch_and_case_validation():
    """shooting_problem takes the law's 'continuation' entry; laws without one are refused with
    one line, at validation and when built; R and beta are not continuation keys here."""
    m = parse_case(CASE).model_spec().build()
    assert isinstance(shooting_problem(m, "Omega"), CompliantSDOFShooting)
    with pytest.raises(ValueError, match="allowed: Omega, B, Delta"):
        shooting_problem(m, "R", Omega=2.0)
    hc = CASE.replace('law = "linear"', 'law = "hunt_crossley"').replace("stiffness = 1e4", "stiffness = 1e6")
    with pytest.raises(CaseError, match="allowed: event, direct$"):
        parse_case(hc)
    with pytest.raises(ValueError, match="no shooting problem registered"):
        shooting_problem(replace(m, contact=HuntCrossley(1e6, 0.9)), "Omega")


def test_vibeam_continue_end_to_end(tmp_path):
    """`vibeam continue` on a compliant scene writes the branch; its points are orbits of the
    event kernel (a stable point checked against a long event run)."""
    from vibeam.cli import main
    from vibeam.results import read_results

    (tmp_path / "kv.toml").write_text(CASE)
    assert main(["continue", str(tmp_path / "kv.toml"), "--out", str(tmp_path / "out"), "--jobs", "1",
                 "--no-plots", "--quiet"]) == 0
    g = read_results(tmp_path / "out" / "results.h5")["branches"]["branches"]
    b = g["00-period1"]
    assert len(b["parameter"]) > 50 and b["parameter"][0] == 1.5 and b["parameter"][-1] == pytest.approx(2.6)
    m = parse_case(CASE).model_spec().build()
    i = int(np.flatnonzero(np.asarray(b["stable"]))[-1])
    x = np.asarray(b["state"][i], float)
    _, sm = _settled(m, float(b["parameter"][i]), 1500, x0=x * 1.01)
    assert sm["amplitude"] == pytest.approx(float(b["amplitude"][i]), rel=1e-9)
