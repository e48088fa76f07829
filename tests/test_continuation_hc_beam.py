"""Continuation of the modal FE beam on a Hunt-Crossley stop (issue 13):
:class:`vibeam.models.core.scene_shooting.SceneShooting` of the beam.

Oracles: central differences of the shot (its Jacobian), the solve_ivp reference
(:class:`vibeam.models.core.direct.BeamODESolver`, no shared code with the kernel or
the variational integration), the SDOF Hunt-Crossley shooting problem on the mapped stop (another
flow, another derivative assembly, other units) and long event runs.
"""
from __future__ import annotations
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models import shooting_problem
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import outputs

import math

import numpy as np
import pytest


# slow (the default test step's time): the compliant laws' shooting tangents and two-stop
# kernels are compiled by these tests alone (~4 min of cold compile on 2 cores); .ci/run runs them
pytestmark = pytest.mark.slow

# the file runs in the slow step (CI runs `pytest -m slow` second) but for one representative
# check, test_two_mode_shot_jacobian_in_omega_against_central_differences: the Hunt-Crossley beam
# kernels' first compile costs ~20 s, which the default step's 10-minute budget takes only once


def _rig(n_modes, k=1e8, gap_mm=None):
    from vibeam.case.schema import load_case

    case, _ = load_case("cases/rig-fe-neutral.toml")
    over = {"n_modes": n_modes, "contact": {"law": "hunt_crossley", "stiffness_n_m": k}}
    if gap_mm is not None:
        over["gap_mm"] = gap_mm
    return case.model_spec(over).scene()


def _settled(m, W, periods=100):
    from vibeam.models import BeamEventSolver

    tr = BeamEventSolver(m).point(W, None, periods, 4, 16)
    assert tr.status == "ok" and tr.final_state[-1] == 0.0
    return tr.final_state[:2 * outputs(m).n_modes]


def test_two_mode_shot_jacobian_in_omega_against_central_differences():
    """Default-step representative of the slow checks below (same scene, one parameter): the rig
    FE beam with 2 modes on a Hertzian Hunt-Crossley stop (1e8 N/m^1.5) at 16 Hz, from a state
    0.1 % off its settled orbit (one contact per period): the monodromy M and d x / d Omega of
    the shot (variational equations integrated with the flow) against central differences of
    the shot (step 1e-6 of the state / Omega).  The shot is smooth only to the integrators'
    ~1e-12, i.e. ~1e-6 relative noise in a difference quotient at worst; measured 7.2e-10 (M)
    and 7.8e-10 (d x / d Omega) of the largest entry, so 1e-6 is asserted.  ~0.4 s once the
    kernels are compiled (their first compile ~20 s, once per machine: numba's cache)."""
    m = _rig(2)
    W = 16.0 / m.system.reference_hz
    x0 = _settled(m, W) * 1.001
    d = 4
    sc = float(np.max(np.abs(x0)))
    prob = shooting_problem(m, "Omega", Omega=W)
    s = prob.shot(x0, W, 1)
    assert s.status == "ok" and s.n_impacts == 1, s.message
    J = np.empty((d, d + 1))
    for c in range(d):
        e = np.zeros(d)
        e[c] = h = 1e-6 * sc
        J[:, c] = (prob.shot(x0 + e, W, 1).x - prob.shot(x0 - e, W, 1).x) / (2 * h)
    h = 1e-6 * W
    J[:, d] = (prob.shot(x0, W + h, 1).x - prob.shot(x0, W - h, 1).x) / (2 * h)
    assert np.max(np.abs(s.M - J[:, :d])) < 1e-6 * np.max(np.abs(s.M))
    assert np.max(np.abs(s.x_p - J[:, d])) < 1e-6 * np.max(np.abs(s.x_p))


@pytest.mark.slow
@pytest.mark.parametrize("n_modes", [1, 2])
def test_shot_jacobian_against_central_differences(n_modes):
    """Rig FE beam on a Hertzian Hunt-Crossley stop (1e8 N/m^1.5) at 16 Hz, from a state 0.1 %
    off its settled orbit (one contact per period): M and d/d(Omega, Y) against central
    differences (step 1e-6 of the state / parameter).  The shot is smooth only to the
    integrators' ~1e-12, i.e. ~1e-6 relative noise in a difference quotient at worst; measured
    agreement <= 3e-9 of the largest entry, so 1e-6 is asserted."""
    m = _rig(n_modes)
    W = 16.0 / m.system.reference_hz
    x0 = _settled(m, W) * 1.001
    d = 2 * n_modes
    sc = float(np.max(np.abs(x0)))
    for par, p in (("Omega", W), ("system.base_amplitude", m.system.base_amplitude)):
        prob = shooting_problem(m, par, Omega=W)
        s = prob.shot(x0, p, 1)
        assert s.status == "ok" and s.n_impacts == 1, s.message
        J = np.empty((d, d + 1))
        for c in range(d + 1):
            if c < d:
                e = np.zeros(d)
                e[c] = h = 1e-6 * sc
                J[:, c] = (prob.shot(x0 + e, p, 1).x - prob.shot(x0 - e, p, 1).x) / (2 * h)
            else:
                h = 1e-6 * p
                J[:, c] = (prob.shot(x0, p + h, 1).x - prob.shot(x0, p - h, 1).x) / (2 * h)
        assert np.max(np.abs(s.M - J[:, :d])) < 1e-6 * np.max(np.abs(s.M))
        assert np.max(np.abs(s.x_p - J[:, d])) < 1e-6 * np.max(np.abs(s.x_p))


@pytest.mark.slow
@pytest.mark.parametrize("n_modes", [1, 2])
def test_shot_end_state_is_the_event_kernels(n_modes):
    """The shot's value is the event kernel's end state: the solver of method ``event`` from the
    same state over the same periods gives it to 1e-10 of the state (its sampling grid differs,
    which moves the steps; measured ~1e-12), the independent solve_ivp reference (method
    ``direct``, DOP853 rtol 1e-11) to 1e-8 (measured ~1e-10), and the derivatives' own DOP853
    trajectory ends within 1e-8 of it (measured ~1e-11)."""
    from vibeam.models.core.direct import BeamODESolver
    from vibeam.models import BeamEventSolver

    m = _rig(n_modes)
    W = 16.0 / m.system.reference_hz
    x0 = _settled(m, W) * 1.001
    sc = float(np.max(np.abs(x0)))
    s = shooting_problem(m).shot(x0, W, 2)
    assert s.status == "ok" and s.n_impacts == 2
    s0 = np.concatenate([x0, [0.0]])
    ev = BeamEventSolver(m).point(W, s0, 0, 2, 16)
    ref = BeamODESolver(m).point(W, s0, 0, 2, 16)
    assert np.max(np.abs(ev.final_state[:-1] - s.x)) < 1e-10 * sc
    assert np.max(np.abs(ref.final_state[:-1] - s.x)) < 1e-8 * sc
    assert np.max(np.abs(s.extra["rebuilt_state"] - s.x)) < 1e-8 * sc


@pytest.mark.slow
def test_refusals():
    """A section inside the stop is a failed shot with its reason, not a crash; an unknown
    parameter is refused when built.  (A linear-law model, refused while each law had its own
    shooting class, is now served by the one shooting problem: it builds with its law.)"""
    m = _rig(1)
    W = 16.0 / m.system.reference_hz
    x = np.array([2.0 * m.stops[0].relation.offset / m.system.contacts[0][0], 0.0])
    s = shooting_problem(m).shot(x, W, 1)
    assert s.status == "failed" and "inside the stop" in s.message
    with pytest.raises(ValueError, match="parameter"):
        shooting_problem(m, "gap_mm", Omega=W)
    from vibeam.case.schema import load_case

    case, _ = load_case("cases/rig-fe-neutral.toml")
    lin = case.model_spec({"n_modes": 1, "contact": {"law": "linear", "stiffness_n_m": 1e8}}).scene()
    assert shooting_problem(lin).scene.stops[0].law.name == "linear"


def _case_text(lo=16.5, hi=17.0):
    """The 2-mode rig (neutral gap, R 0.72) on a Hertzian Hunt-Crossley stop, one continuation run."""
    text = open("cases/rig-fe-neutral.toml").read().split("# quick variant")[0]
    text = text.replace("n_modes = 4", "n_modes = 2")
    text = text.replace("[model.discs]", '[model.contact]\nlaw = "hunt_crossley"\nstiffness_n_m = 1e8\n\n'
                                         '[model.discs]')
    text = text.replace("frequency_hz = [14.0, 17.0, 61]", f"frequency_hz = [{lo}, {hi}, 3]")
    text = text.replace('direction = "both"\n', "")
    return text + '\n[[run]]\nname = "branches"\nmethod = "continuation"\nstart_at = "high"\n'


@pytest.mark.slow
def test_registry_dispatch_and_case_validation():
    """The beam's hunt_crossley table names the shooting problem; a case asking for
    ``method = "continuation"`` on a beam Hunt-Crossley scene validates."""
    from vibeam.case.schema import parse_case
    from vibeam.models import shooting_problem

    case = parse_case(_case_text())
    assert [r.method for r in case.run] == ["continuation"]
    m = case.model_spec().scene()
    assert isinstance(shooting_problem(m, "Omega"), SceneShooting)


def _one_dof(m):
    """The SDOF on a Hunt-Crossley stop of a one-mode beam (paper Eqs. 1-2, as
    tests/test_continuation_compliant.py maps the linear law): ``q = U / (phi L)``, ``tau =
    sqrt(k) t``; the force ``w^2 k_c g^p (...)`` on ``q`` (``g = phi L delta``) is the SDOF law's
    with stiffness ``w^2 k_c (phi L)^(p - 1) / k`` and the same chi; the velocity floors agree
    (``1e-2 Omega B`` both)."""
    from vibeam.models.compliant import HuntCrossley

    sy = m.system
    (k,), (c,) = sy.omega ** 2, sy.damping
    (w,), (G,) = sy.contacts[0], sy.participation
    s = float(sy.contact_static[0]) * sy.length_unit_m
    a = w / s
    sk = math.sqrt(k)
    law = m.stops[0].law
    kc = law.stiffness      # the scene holds the SI stiffness over omega_ref^2
    p = float(law.exponent)
    sd = sdof(c / (2 * sk), w * G * m.system.base_amplitude / s, m.stops[0].relation.offset / s,
              law=HuntCrossley(w * w * kc * s ** (p - 1.0) / k, law.R, p))
    return sd, sk, (lambda x: np.array([a * x[0], a * x[1] / sk]))


@pytest.mark.slow
def test_one_mode_beam_branch_equals_its_sdof_branch():
    """A one-mode beam on a Hunt-Crossley stop is the SDOF on the mapped stop: every point of the
    beam branch (neutral gap, 16.5-17 Hz), mapped to the SDOF's coordinates, is a fixed point of the
    SDOF Hunt-Crossley problem (another kernel, another derivative assembly, other units) to 1e-8
    of the state (both are accurate to their integrators, ~1e-10; measured 2e-11), with the
    same multipliers to 1e-8 (measured 1e-11) and contact count."""
    from vibeam.models.orbits.continuation import Settings, trace

    m = _rig(1)
    sd, sk, to_sdof = _one_dof(m)
    lo, hi = 16.5 / m.system.reference_hz, 17.0 / m.system.reference_hz
    x0 = _settled(m, lo, 100)
    bb = trace(shooting_problem(m), x0, lo, 1, lo, hi, +1, Settings(switch=False))[0]
    assert len(bb.points) > 5
    prob = shooting_problem(sd)
    err_x = err_mu = 0.0
    for pt in bb.points:
        xs = to_sdof(pt.x)
        s = prob.shot(xs, pt.p / sk, 1)
        assert s.status == "ok" and s.n_impacts == pt.shot.n_impacts >= 1
        err_x = max(err_x, np.max(np.abs(s.x - xs)) / np.max(np.abs(xs)))
        err_mu = max(err_mu, max(np.min(np.abs(pt.mu - z)) for z in s.multipliers()))
    print(f"one-mode beam vs SDOF HC: {len(bb.points)} points, state {err_x:.2e}, multipliers {err_mu:.2e}")
    assert err_x < 1e-8 and err_mu < 1e-8


@pytest.mark.slow
def test_stable_branch_points_are_long_event_runs():
    """Stable points of the 2-mode branch (neutral gap, 15-17 Hz) are the attractors of long
    event runs started 1 % off them: after 600 periods the event kernel's state at phase 0 is
    the branch's to 1e-8 of the state (Newton converges to the shot's ~1e-10 smoothness and the
    slowest multiplier decays to < 1e-9 over the run; measured 2.3e-11) with as many contacts
    per period."""
    from vibeam.models import BeamEventSolver
    from vibeam.models.orbits.continuation import Settings, trace

    m = _rig(2)
    lo, hi = 15.0 / m.system.reference_hz, 17.0 / m.system.reference_hz
    x0 = _settled(m, hi, 300)
    b = trace(shooting_problem(m), x0, hi, 1, lo, hi, -1, Settings(switch=False))[0]
    a = b.arrays()
    idx = [i for i in np.flatnonzero(a["stable"]) if np.abs(a["multipliers"][i]).max() < 0.95]
    assert len(idx) >= 3
    worst = 0.0
    for i in idx[:: max(1, len(idx) // 4)]:
        x = np.asarray(a["state"][i], float)
        t = BeamEventSolver(m).point(float(a["parameter"][i]), np.concatenate([x * 1.01, [0.0]]), 600, 1, 16)
        assert t.status == "ok" and t.n_impacts == int(a["impacts"][i])
        worst = max(worst, np.max(np.abs(t.final_state[:4] - x)) / np.max(np.abs(x)))
    print(f"stable HC beam points vs 600-period event runs: {worst:.2e}")
    assert worst < 1e-8


@pytest.mark.slow
def test_vibeam_continue_end_to_end(tmp_path):
    """`vibeam continue` on the 2-mode rig with a Hunt-Crossley stop writes the branch from 17
    down to 16.5 Hz, one contact per period (~5 s once the kernels are compiled)."""
    from vibeam.cli import main
    from vibeam.io.results import read_results

    (tmp_path / "hc.toml").write_text(_case_text(16.5, 17.0))
    assert main(["continue", str(tmp_path / "hc.toml"), "--out", str(tmp_path / "out"), "--jobs", "1",
                 "--no-plots", "--quiet"]) == 0
    g = read_results(tmp_path / "out" / "results.h5")["branches"]["branches"]
    b = g[sorted(g)[0]]
    assert len(b["parameter"]) > 5 and np.all(np.asarray(b["impacts_per_period"]) == 1)
    assert float(b["parameter"][0]) * 7.6 == pytest.approx(17.0) and float(b["parameter"][-1]) * 7.6 == pytest.approx(16.5)


@pytest.mark.slow
def test_grazing_indicator_of_the_contact_free_orbit():
    """The apex indicator of the contact-free orbit (2 modes, gap 0.1 mm, 19 Hz) is its
    closed-form contact amplitude minus the gap (to 1e-12 m: a located extremum of the exact
    free flow), and the shot of that orbit returns it (no contact; 1e-12 of the state)."""
    m = _rig(2, gap_mm=0.1)
    prob = shooting_problem(m)
    W = 19.0 / m.system.reference_hz
    x, why = prob.start("linear", W)
    assert x is not None, why
    s = prob.shot(x, W, 1)
    assert s.status == "ok" and s.n_impacts == 0 and np.max(np.abs(s.x - x)) < 1e-12 * np.max(np.abs(x))
    assert s.apex_gap < 0.0
    assert s.apex_gap == pytest.approx(prob.linear_amplitude(W) - m.stops[0].relation.offset, abs=1e-12)


@pytest.mark.slow
def test_voltage_continuation_is_the_chain_rule_of_the_base_amplitude():
    """The case key ``voltage`` is affine in ``base_amplitude_m`` (``Y = gamma~ V``): the framework's
    problem in the voltage gives the same shot as the native one and ``d x / d V = gamma~ d x / d Y``
    (1e-12: the same arithmetic up to the scaling)."""
    from vibeam.analysis.branches import problem
    from vibeam.case.schema import load_case

    case, _ = load_case("cases/rig-fe-neutral.toml")
    spec = case.model_spec({"n_modes": 2, "contact": {"law": "hunt_crossley", "stiffness_n_m": 1e8}})
    m = spec.scene()
    W = 16.0 / m.system.reference_hz
    x = _settled(m, W) * 1.001
    V = float(spec.excitation.voltage)
    sv = problem(spec, "voltage", W).shot(x, V, 1)
    sy = shooting_problem(m, "system.base_amplitude", Omega=W).shot(x, m.system.base_amplitude, 1)
    g = spec.scene_parameter("voltage")[1]
    assert sv.status == sy.status == "ok" and sv.n_impacts == 1
    np.testing.assert_allclose(sv.x, sy.x, rtol=0, atol=1e-14 * np.max(np.abs(x)))
    np.testing.assert_allclose(sv.x_p, g * sy.x_p, rtol=1e-12)


@pytest.mark.slow
def test_jacobian_with_the_velocity_floor(monkeypatch):
    """With the velocity floor raised above the entry velocity (1e-2 -> 10 Omega Y |w^T Gamma|:
    the floor, 1.8e-3, exceeds the entry's 8e-4), v_r = v_floor depends on (Omega, Y) only: the
    Jacobian still equals central differences (tolerance as above; measured <= 2.3e-8, the
    damping now being ~2x larger)."""
    import vibeam.models.core.laws as laws

    m = _rig(2)
    W = 16.0 / m.system.reference_hz
    x0 = _settled(m, W) * 1.001
    monkeypatch.setattr(laws, "V_FLOOR", 10.0)     # the floor of the compliant laws (read when a model's kernel data are built)
    d = 4
    h0 = 1e-6 * float(np.max(np.abs(x0)))
    for par, p in (("Omega", W), ("system.base_amplitude", m.system.base_amplitude)):
        prob = shooting_problem(m, par, Omega=W)
        s = prob.shot(x0, p, 1)
        assert s.status == "ok" and s.n_impacts == 1
        Y = p if par == "system.base_amplitude" else m.system.base_amplitude
        v_floor = 10.0 * W * Y * abs(float(m.system.contacts[0] @ m.system.participation))
        assert s.impact_velocities[0] * m.system.length_unit_m < v_floor
        J = np.empty((d, d + 1))
        for c in range(d + 1):
            if c < d:
                e = np.zeros(d)
                e[c] = h0
                J[:, c] = (prob.shot(x0 + e, p, 1).x - prob.shot(x0 - e, p, 1).x) / (2 * h0)
            else:
                h = 1e-6 * p
                J[:, c] = (prob.shot(x0, p + h, 1).x - prob.shot(x0, p - h, 1).x) / (2 * h)
        assert np.max(np.abs(s.M - J[:, :d])) < 1e-6 * np.max(np.abs(s.M))
        assert np.max(np.abs(s.x_p - J[:, d])) < 1e-6 * np.max(np.abs(s.x_p))


@pytest.mark.parametrize("lower", ["hunt_crossley", "linear"])
def test_two_stop_shot_fixed_point_and_jacobian_against_central_differences(lower):
    """The one compliant beam shooting problem on two stops (issue 20: each contact phase composed
    by its own law): the rig FE beam with 2 modes, a Hertzian Hunt-Crossley upper stop (1e8
    N/m^1.5) and, 0.3 mm below, a lower stop of 3e8 N/m^1.5 (Hunt-Crossley) or 3e5 N/m
    (Kelvin-Voigt), at 16 Hz: a settled period-2 orbit with two upper contacts and one lower
    contact per orbit (asserted; the scene of ``test_energy_balance.py``'s ``beam-hc-two``).
    The event run's settled state is a fixed point of the shot ``P^2`` to 1e-9 of the orbit (the
    shot is the same kernel; measured 4.6e-12 and 1.1e-11), and the shot's monodromy and
    d x / d Omega equal central differences of the shot (step 1e-6) to 1e-6 of their largest
    entry, the tolerance of the one-stop checks above (measured 1.0e-7 and 1.5e-8 with the
    Hunt-Crossley lower stop, 7.5e-8 and 1.3e-8 with the Kelvin-Voigt one: the difference
    quotients' noise over two integrated contacts, far below the lower stop's terms -- its
    variational equations along its normal -w, its own stiffness and v_r)."""
    from vibeam.case.schema import load_case
    from vibeam.models import make_solver, shooting_problem

    case, _ = load_case("cases/rig-fe-neutral.toml")
    low = {"law": "hunt_crossley", "stiffness_n_m": 3e8} if lower == "hunt_crossley" else \
        {"law": "linear", "stiffness_n_m": 3e5}
    m = case.model_spec({"n_modes": 2, "gap_lower_mm": 0.3, "contact": {"law": "hunt_crossley", "stiffness_n_m": 1e8},
                         "contact_lower": low}).scene()
    W = 16.0 / m.system.reference_hz
    tr = make_solver(m, "event").point(W, None, 300, 4, 16)
    assert tr.status == "ok" and tr.final_state[-1] == 0.0
    x = tr.final_state[:4]
    prob = shooting_problem(m, "Omega", Omega=W)
    s = prob.shot(x, W, 2)
    assert s.status == "ok" and s.n_impacts == 3 and list(s.extra["impact_stops"]).count(1) == 1, s.message
    sc = float(np.max(np.abs(x)))
    assert np.max(np.abs(s.x - x)) < 1e-9 * sc
    x0 = x * 1.001
    s = prob.shot(x0, W, 2)
    assert s.status == "ok" and s.n_impacts == 3
    J = np.empty((4, 5))
    for c in range(4):
        e = np.zeros(4)
        e[c] = h = 1e-6 * sc
        J[:, c] = (prob.shot(x0 + e, W, 2).x - prob.shot(x0 - e, W, 2).x) / (2 * h)
    h = 1e-6 * W
    J[:, 4] = (prob.shot(x0, W + h, 2).x - prob.shot(x0, W - h, 2).x) / (2 * h)
    assert np.max(np.abs(s.M - J[:, :4])) < 1e-6 * np.max(np.abs(s.M))
    assert np.max(np.abs(s.x_p - J[:, 4])) < 1e-6 * np.max(np.abs(s.x_p))
