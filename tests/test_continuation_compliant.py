"""Continuation of periodic orbits with a compliant (Kelvin-Voigt) stop: the one shooting problem
(vibeam.models.core.shooting, served by the scene's SceneShooting) against finite differences, the event kernel, the
entry-to-entry map of Sec. 4.2, Liouville's formula, the CoR limit and the command line."""
import math

import numpy as np
import pytest

from vibeam.case.schema import CaseError, parse_case
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models import shooting_problem
from vibeam.models.compliant import HuntCrossley, LinearContact
from vibeam.models.orbits.continuation import trace
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import one_mode, outputs
from vibeam.engine.records import summarize

# slow (the default test step's time): the compliant laws' shooting tangents and two-stop
# kernels are compiled by these tests alone (~4 min of cold compile on 2 cores); .ci/run runs them
pytestmark = pytest.mark.slow

FIG8 = dict(beta=0.015, B=0.5e-3, Delta=0.7e-3)      # paper Fig. 8: fold and grazing in 1.5..2.5 (CoR, R = 0.9)
NEUTRAL = dict(beta=0.015, B=0.5e-3, Delta=0.0)     # the same at Delta = 0
FOLD_COR = 1.9850022038952106                # its CoR fold (tests/test_continuation.py branch)


def _kv(p, k, R=0.9):
    return sdof(**p, law=LinearContact.from_restitution(k, R))


def _settled(sc, Omega, periods=1500, x0=None):
    s0 = None if x0 is None else np.array([x0[0], x0[1], 0.0])
    tr = EventSolver(sc).point(Omega, s0, periods, 16, 16)
    return np.asarray(tr.final_state[:2], float), summarize(tr, one_mode(sc).Delta)


@pytest.fixture(scope="module")
def fig8_kv():
    """The Fig. 8 scene on a Kelvin-Voigt stop (k_c = 1e4, target R = 0.9): period-1 branch
    from the contacting orbit at Omega = 1.5 up to 2.5."""
    m = _kv(FIG8, 1e4)
    x0, _ = _settled(m, 1.5)
    brs = trace(shooting_problem(m), x0, 1.5, 1, 1.5, 2.5, +1)
    return m, brs


# ------------------------------------------------------------------ exact derivatives
CASES = {
    "one contact, Delta = 0": (NEUTRAL, 1e4, 2.2, 1, None),
    "Fig. 8 gap, upper branch": (FIG8, 1e4, 1.9, 1, None),
    "period 2 (two contacts), soft": (NEUTRAL, 1e4, 2.8, 2, None),
    "stiff stop": (FIG8, 1e6, 1.8, 1, None),
    "in contact at the section": (NEUTRAL, 1e2, 2.9, 2, None),   # period 2
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
    for par in ("Omega", "system.base_amplitude", "stops[0].relation.offset"):
        prob = shooting_problem(m, par, Omega=W)
        p = W if par == "Omega" else prob.value
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
    contact flows; the entry saltation has det 1) to 1e-10 relative (measured <= 5e-13), and at
    stable one-contact points the multipliers equal those of the entry-to-entry map of Sec. 4.2
    (vibeam.models.mapping, another section of the same orbit) to 1e-9
    (measured <= 6e-12)."""
    from vibeam.models.mapping import MappingSolver

    m, brs = fig8_kv
    b = brs[0]
    cc = m.stops[0].law.damping
    for pt in b.points:
        T = 2 * math.pi / pt.p
        det = math.exp(-2 * one_mode(m).beta * T - cc * pt.shot.extra["contact_time"])
        assert np.linalg.det(pt.shot.M) == pytest.approx(det, rel=1e-10)
    ms = MappingSolver(m)
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
    compliant kernel started 1 % off the orbit: points with max|mu| < 0.97, so that after 1500
    periods the distance has shrunk by max|mu|^1500 < 1e-19 (next to the fold the decay is too slow
    for any fixed run), and the amplitudes agree to round-off of the exact flows (1e-9
    relative; measured <= 1.2e-12).  Points on the sliver between the small fold next to the
    grazing (1.8702386) and the grazing are stable too, but their basin is thinner than 1 %: the
    runs start from the stable points away from it."""
    m, brs = fig8_kv
    b = brs[0]
    assert b.status == "range_end"
    folds = [f for f in b.bifurcations if f.type == "fold" and f.amplitude > 3e-3]
    assert len(folds) == 1 and np.min(np.abs(folds[0].multipliers - 1.0)) < 1e-6
    graze = [f for f in b.bifurcations if f.type == "grazing"]
    assert graze and graze[0].parameter == pytest.approx(1.870239215, abs=1e-8)
    A = b.arrays()
    rho = np.max(np.abs(A["multipliers"]), axis=1)
    stable = np.flatnonzero((rho < 0.97) & (A["impacts"] == 1) & (np.abs(A["parameter"] - 1.87024) > 1e-4))
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
        b = trace(shooting_problem(m), x0, 1.9, 1, 1.8, 2.05, +1)[0]
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


def test_registry_dispatch_and_case_validation(monkeypatch):
    """shooting_problem takes the law's 'continuation' entry of the registry (no law branches); a
    law without one is refused with one line; R and beta are not continuation keys here."""
    from vibeam.models.registry import FIDELITIES

    sc = parse_case(CASE).model_spec().scene()
    assert isinstance(shooting_problem(sc, "Omega"), SceneShooting)
    with pytest.raises(ValueError, match="'gamma' is not a parameter of the scene's shooting problem"):
        shooting_problem(sc, "gamma", Omega=2.0)
    hc = CASE.replace('law = "linear"', 'law = "hunt_crossley"').replace("stiffness = 1e4", "stiffness = 1e6")
    assert isinstance(shooting_problem(parse_case(hc).model_spec().scene(), "Omega"), SceneShooting)
    # the registry's tables derive from each method's entry, keyed by the law's family
    # (vibeam.models.registry.Method, LAWS): a shooting problem without the hysteretic-Hertz family
    cont = FIDELITIES["sdof"].solvers["continuation"]
    monkeypatch.setitem(FIDELITIES["sdof"].solvers, "continuation",
                        cont._replace(laws={f: c for f, c in cont.laws.items() if f != "hysteretic_hertz"}))
    with pytest.raises(CaseError, match="allowed: event, direct, mapping$"):
        parse_case(hc)
    with pytest.raises(ValueError, match="no shooting problem registered"):
        shooting_problem(sdof(**NEUTRAL, law=HuntCrossley(1e6, 0.9)), "Omega")


def test_vibeam_continue_end_to_end(tmp_path):
    """`vibeam continue` on a compliant scene writes the branch; its points are orbits of the
    event kernel (a stable point checked against a long event run)."""
    from vibeam.cli import main
    from vibeam.io.results import read_results

    (tmp_path / "kv.toml").write_text(CASE)
    assert main(["continue", str(tmp_path / "kv.toml"), "--out", str(tmp_path / "out"), "--jobs", "1",
                 "--no-plots", "--quiet"]) == 0
    g = read_results(tmp_path / "out" / "results.h5")["branches"]["branches"]
    b = g["00-period1"]
    assert len(b["parameter"]) > 50 and b["parameter"][0] == 1.5 and b["parameter"][-1] == pytest.approx(2.6)
    sc = parse_case(CASE).model_spec().scene()
    i = int(np.flatnonzero(np.asarray(b["stable"]))[-1])
    x = np.asarray(b["state"][i], float)
    _, sm = _settled(sc, float(b["parameter"][i]), 1500, x0=x * 1.01)
    assert sm["amplitude"] == pytest.approx(float(b["amplitude"][i]), rel=1e-9)


# ------------------------------------------------------------------ the modal beam
def _rig(n_modes, k=1e5, gap_mm=0.0):
    from vibeam.case.schema import load_case

    case, _ = load_case("cases/rig-fe-neutral.toml")
    return case.model_spec({"n_modes": n_modes, "gap_mm": gap_mm,
                            "contact": {"law": "linear", "stiffness_n_m": k}}).scene()


@pytest.mark.parametrize("n_modes", [1, 2, 4])
def test_beam_shot_jacobian_liouville_and_state(n_modes):
    """Rig FE beam on a Kelvin-Voigt stop at 16 Hz, from a state 0.1 % off its settled orbit:
    * the end state equals the kernel's, rebuilt along the recorded phases by the exact flows
      the Jacobian uses (1e-13 of the state; measured ~1e-15);
    * M and d/d(Omega, Y) against central differences (step 1e-6; 1e-7 of the largest entry
      of M for its columns (the stiff high modes' columns are ~1e-30 of it: absolute
      comparison) and of the parameter column's own scale; measured <= 4e-10);
    * Liouville: det M = exp(trace(A_free) T - c |w|^2 T_c) to 1e-9 (measured ~1e-15)."""
    from vibeam.models import BeamEventSolver

    m = _rig(n_modes)
    W = 16.0 / m.system.reference_hz
    x0 = BeamEventSolver(m).point(W, None, 200, 4, 16).final_state[:2 * n_modes] * 1.001
    d = 2 * n_modes
    sc = float(np.max(np.abs(x0)))
    for par, p in (("Omega", W), ("system.base_amplitude", m.system.base_amplitude)):
        prob = shooting_problem(m, par, Omega=W)
        s = prob.shot(x0, p, 1)
        assert s.status == "ok" and s.n_impacts == 1
        assert np.max(np.abs(s.extra["rebuilt_state"] - s.x)) < 1e-13 * sc
        J = np.empty((d, d + 1))
        for c in range(d + 1):
            if c < d:
                e = np.zeros(d)
                e[c] = h = 1e-6 * sc
                J[:, c] = (prob.shot(x0 + e, p, 1).x - prob.shot(x0 - e, p, 1).x) / (2 * h)
            else:
                h = 1e-6 * p
                J[:, c] = (prob.shot(x0, p + h, 1).x - prob.shot(x0, p - h, 1).x) / (2 * h)
        assert np.max(np.abs(s.M - J[:, :d])) < 1e-7 * np.max(np.abs(s.M))
        assert np.max(np.abs(s.x_p - J[:, d])) < 1e-7 * np.max(np.abs(s.x_p))
        # trace of the free phase's state matrix -sum c_i; the contact's dashpot c_c / omega_ref along w
        w = m.system.contacts[0]
        law, om_ref = m.stops[0].law, 2 * math.pi * m.system.reference_hz
        # c_c = 2 zeta_c sqrt(k_c m_eff) (N s/m), k_c in SI (the scene holds it over omega_ref^2)
        cc = 2.0 * law.damping_ratio * math.sqrt(law.stiffness * om_ref ** 2 * outputs(m).m_eff) / om_ref
        det = math.exp(-np.sum(m.system.damping) * 2 * math.pi / W - cc * float(w @ w) * s.extra["contact_time"])
        assert np.linalg.det(s.M) == pytest.approx(det, rel=1e-9, abs=1e-300)


def _one_dof(m):
    """The SDOF on a Kelvin-Voigt stop of a one-mode beam (as tests/test_continuation_beam.py's
    map, paper Eqs. 1-2): ``q = w eta / (phi L)``, ``tau = sqrt(k) t``; the stop's stiffness
    ratio is ``w^2 k_c / k`` and its damping ratio is the beam's (``c_c = 2 zeta sqrt(k_c m_eff)``,
    ``m_eff = 1 / w^2``)."""
    sy = m.system
    (k,), (c,) = sy.omega ** 2, sy.damping
    (w,), (G,) = sy.contacts[0], sy.participation
    phiL = float(sy.contact_static[0]) * sy.length_unit_m
    a = w / phiL
    sk = math.sqrt(k)
    law = m.stops[0].law
    kc = law.stiffness      # the scene holds the SI stiffness over omega_ref^2
    sd = sdof(beta=c / (2 * sk), B=w * G * sy.base_amplitude / phiL,
              Delta=a * m.stops[0].relation.offset / w,
              law=LinearContact.from_damping_ratio(w * w * kc / k, law.damping_ratio))
    return sd, sk, (lambda x: np.array([a * x[0], a * x[1] / sk]))


def test_one_mode_beam_branch_equals_its_sdof_branch():
    """A one-mode beam on a Kelvin-Voigt stop is the SDOF on the mapped stop: every point of the
    beam branch (13 Hz up through its fold, gap 0.1 mm), mapped to the SDOF's coordinates, is a
    fixed point of the SDOF problem (another flow, another derivative assembly, other units) to
    1e-9 of the state (measured 1e-11), with the same multipliers to 1e-9 (measured 1e-13) and
    contact count; the SDOF branch has the same fold to 1e-10 in frequency (measured 1e-15)."""
    from vibeam.models import BeamEventSolver
    from vibeam.models.orbits.continuation import Settings

    m = _rig(1, gap_mm=0.1)
    sd, sk, to_sdof = _one_dof(m)
    lo, hi = 13.0 / m.system.reference_hz, 19.0 / m.system.reference_hz
    x0 = BeamEventSolver(m).point(lo, None, 600, 4, 16).final_state[:2]
    bb = trace(shooting_problem(m), x0, lo, 1, lo, hi, +1, Settings(switch=False))[0]
    assert len(bb.points) > 10
    prob = shooting_problem(sd)
    for pt in bb.points:
        xs = to_sdof(pt.x)
        s = prob.shot(xs, pt.p / sk, 1)
        assert np.max(np.abs(s.x - xs)) < 1e-9 * np.max(np.abs(xs))
        assert max(np.min(np.abs(pt.mu - z)) for z in s.multipliers()) < 1e-9
        assert s.n_impacts == pt.shot.n_impacts
    bs = trace(prob, to_sdof(x0), lo / sk, 1, lo / sk, hi / sk, +1, Settings(switch=False))[0]
    fb = [f.parameter for f in bb.bifurcations if f.type == "fold"]
    fs = [f.parameter * sk for f in bs.bifurcations if f.type == "fold"]
    assert len(fb) == len(fs) == 1 and fb[0] == pytest.approx(fs[0], rel=1e-10)


def test_beam_grazing_indicator_and_event_runs():
    """The apex indicator of the contact-free orbit (2 modes, gap 0.1 mm, 19 Hz) is its closed-form
    contact amplitude minus the gap (to 1e-12 m, located extremum of the exact flow); stable points
    of the 2-mode contacting branch (12.5-16 Hz, neutral gap) are the attractors of long event runs
    of the compliant beam kernel started 1 % off the orbit (amplitude to 1e-9 relative:
    max|mu|^800 is negligible; measured ~1e-14)."""
    from vibeam.models import BeamEventSolver

    m = _rig(2, gap_mm=0.1)
    prob = shooting_problem(m)
    W = 19.0 / m.system.reference_hz
    x, why = prob.start("linear", W)
    s = prob.shot(x, W, 1)
    assert s.n_impacts == 0 and np.max(np.abs(s.x - x)) < 1e-12 * np.max(np.abs(x))
    assert s.apex_gap == pytest.approx(prob.linear_amplitude(W) - m.stops[0].relation.offset, abs=1e-12)
    m = _rig(2)
    lo, hi = 12.5 / m.system.reference_hz, 16.0 / m.system.reference_hz
    x0 = BeamEventSolver(m).point(lo, None, 400, 4, 16).final_state[:4]
    b = trace(shooting_problem(m), x0, lo, 1, lo, hi, +1)[0]
    assert b.status == "range_end"
    A = b.arrays()
    idx = np.flatnonzero(A["stable"])
    assert idx.size > 10
    for i in idx[[0, idx.size // 2, -1]]:
        pt = b.points[i]
        tr = BeamEventSolver(m).point(pt.p, np.concatenate([pt.x * 1.01, [0.0]]), 800, 4, 64)
        sm = summarize(tr, outputs(m).Delta)
        assert sm["period"] == 1
        assert sm["amplitude"] == pytest.approx(A["amplitude"][i], rel=1e-9)


# ------------------------------------------------------------------ Hunt-Crossley (numerical contact phase)
def test_hunt_crossley_shot_against_differences_and_the_kernel():
    """The Hunt-Crossley problem integrates the contact phase and its variational equations
    (DOP853, rtol 1e-12), so it is accurate to the integrator, not exact: at the settled orbit of
    the event kernel (Fig. 8 gap, k_c = 1e6, Omega = 1.9) the shot returns the kernel's state to
    1e-9 (the kernel's own DOPRI5 runs at rtol 1e-11; measured 3e-11), and M, d/d(Omega, B,
    Delta) agree with central differences (step 1e-5, larger than the integrator's noise
    1e-12 / 1e-5; tolerance 1e-6 of each column, measured ~1e-9)."""

    m = sdof(**FIG8, law=HuntCrossley(1e6, 0.9))
    W = 1.9
    x0, sm = _settled(m, W, 1500)
    assert sm["period"] == 1
    assert isinstance(shooting_problem(m, "Omega"), SceneShooting)
    for par in ("Omega", "system.base_amplitude", "stops[0].relation.offset"):
        prob = shooting_problem(m, par, Omega=W)
        p = W if par == "Omega" else prob.value
        s = prob.shot(x0, p, 1)
        assert s.status == "ok" and s.n_impacts == 1
        assert np.max(np.abs(s.x - x0)) < 1e-9 * np.max(np.abs(x0))
        A = np.column_stack([s.M, s.x_p])
        for c in range(3):
            if c < 2:
                e = np.zeros(2)
                e[c] = h = 1e-5 * np.max(np.abs(x0))
                col = (prob.shot(x0 + e, p, 1).x - prob.shot(x0 - e, p, 1).x) / (2 * h)
            else:
                h = 1e-5 * abs(p)
                col = (prob.shot(x0, p + h, 1).x - prob.shot(x0, p - h, 1).x) / (2 * h)
            assert np.max(np.abs(A[:, c] - col)) < 1e-6 * np.max(np.abs(A[:, c]))
    # a section inside the stop is not a state of this law: a status, not a crash
    s = shooting_problem(m).shot(np.array([one_mode(m).Delta + 1e-6, 0.01]), W, 1)
    assert s.status == "failed" and "inside the stop" in s.message


@pytest.mark.slow   # ~140 shots of ~80 ms (solve_ivp per contact): ~1-2 min
def test_hunt_crossley_branch_fold_grazing_and_event_runs():
    """The Hunt-Crossley branch of the Fig. 8 scene (k_c = 1e6, 1.8 .. 2.1) has a fold (multiplier
    +1 to 1e-6) and the law-independent grazing of the contact-free orbit (1.870239215 to 1e-8);
    its stable points are the long event runs' attractors to 1e-9 (the two integrators' tolerances;
    measured ~1e-10)."""
    from vibeam.models.orbits.continuation import Settings

    m = sdof(**FIG8, law=HuntCrossley(1e6, 0.9))
    x0, _ = _settled(m, 1.8, 1500)
    b = trace(shooting_problem(m), x0, 1.8, 1, 1.8, 2.1, +1, Settings(switch=False))[0]
    assert b.status == "range_end"
    folds = [f for f in b.bifurcations if f.type == "fold" and f.amplitude > 3e-3]
    assert len(folds) == 1 and np.min(np.abs(folds[0].multipliers - 1.0)) < 1e-6
    assert [f for f in b.bifurcations if f.type == "grazing"][0].parameter == pytest.approx(1.870239215, abs=1e-8)
    A = b.arrays()
    for i in np.flatnonzero(A["stable"])[::20][:4]:
        pt = b.points[i]
        _, sm = _settled(m, pt.p, 1500, x0=pt.x * 1.01)
        assert sm["amplitude"] == pytest.approx(A["amplitude"][i], rel=1e-9)


@pytest.mark.parametrize("law", [LinearContact.from_restitution(1e4, 0.9), HuntCrossley(1e6, 0.9)],
                         ids=["kelvin_voigt", "hunt_crossley"])
def test_continuation_in_the_laws_restitution_and_the_damping(law):
    """Continuation in R (the law's target restitution: its dashpot or chi) and in beta, once
    refused for compliant laws: the contact phases then carry their variational equations (the
    Runge-Kutta pair; M and d/dp against central differences of the shot, step 1e-5, tolerance
    1e-6 of each column, the Hunt-Crossley checks' above)."""
    m = sdof(**FIG8, law=law)
    o = one_mode(m)
    W = 1.9
    x0 = _settled(m, W, 400)[0] * (1.0 + 1e-3)
    for par in ("stops[0].law.R", "system.damping"):
        # beta along c = 2 beta (paper Eq. 1)
        prob = shooting_problem(m, par, Omega=W, damping=(o.beta, np.array([2.0])) if par == "system.damping" else None)
        p = prob.value
        assert p == (law.R if par == "stops[0].law.R" else o.beta)
        s = prob.shot(x0, p, 1)
        assert s.status == "ok" and s.n_impacts == 1, s.message
        A = np.column_stack([s.M, s.x_p])
        for c in range(3):
            if c < 2:
                e = np.zeros(2)
                e[c] = h = 1e-5 * np.max(np.abs(x0))
                col = (prob.shot(x0 + e, p, 1).x - prob.shot(x0 - e, p, 1).x) / (2 * h)
            else:
                h = 1e-5 * abs(p)
                col = (prob.shot(x0, p + h, 1).x - prob.shot(x0, p - h, 1).x) / (2 * h)
            assert np.max(np.abs(A[:, c] - col)) < 1e-6 * np.max(np.abs(A[:, c])), (par, c)
