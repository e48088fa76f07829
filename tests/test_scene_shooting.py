"""The shooting problem of a scene (vibeam.models.core.scene_shooting.SceneShooting, issue 58)
against closed forms and against the fidelities' own shooting problems."""
import math

import numpy as np
import pytest

from vibeam.models import SDOF, make_solver, shooting_problem
from vibeam.models.continuation import start_point
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models.sdof_flow import particular_coefficients


def _multipliers(s):
    return np.sort_complex(np.linalg.eigvals(s.M))


def test_the_contact_free_orbit_has_the_damped_oscillators_multipliers():
    """Far from the stop the period-1 orbit is the harmonic response ``(b, Omega a)`` (paper
    Eq. 28) and its monodromy is ``exp(A T)``: multipliers ``exp((-beta +- i sqrt(1 - beta^2))
    T)``, ``T = 2 pi / Omega`` (closed form; 1e-12, round-off of the exact flow is ~1e-15)."""
    beta, B, Om = 0.03, 0.02, 1.7
    prob = SceneShooting(SDOF(beta=beta, B=B, R=0.8, Delta=10.0).scene())
    a, b = particular_coefficients(beta, Om * Om * B, Om)
    x0 = np.array([b, Om * a])
    s = prob.shot(x0, Om, 1)
    assert s.status == "ok" and s.n_impacts == 0
    np.testing.assert_allclose(s.x, x0, rtol=0, atol=1e-14)
    # the extremes of q in the scene's units and the gap they are measured from (Q = Delta - q_min)
    assert s.q_max == pytest.approx(math.hypot(a, b), rel=1e-12) and s.gap == 10.0
    T = 2 * math.pi / Om
    lam = -beta + 1j * math.sqrt(1 - beta * beta)
    expected = np.sort_complex(np.exp(np.array([lam, lam.conjugate()]) * T))
    np.testing.assert_allclose(_multipliers(s), expected, rtol=1e-12)


def test_a_chain_of_masses_has_each_modes_multipliers():
    """A two-mass chain given by its matrices (modal damping 2 %, stop out of reach): the
    contact-free monodromy is block-diagonal in the modes, multipliers ``exp(lambda_i T)`` with
    ``lambda_i = -c_i / 2 +- i sqrt(omega_i^2 - c_i^2 / 4)`` of the system's own modes (1e-11)."""
    from vibeam.models.beam_dynamics import MatrixImpactModel
    from vibeam.models.builders.matrices import build_matrices

    M = np.diag([2.0, 0.5])
    K = np.array([[4.2e4, -1.2e4], [-1.2e4, 1.2e4]])
    mm = build_matrices(M, K, damping_ratios=0.02, dofs=["m1", "m2"], sensor="m1", contacts=["m2"], length_m=0.1)
    sc = MatrixImpactModel.from_matrix_model(mm, R=0.7, gap_contact_m=1.0, base_amplitude_m=1e-5).scene()
    prob = SceneShooting(sc)
    assert prob.dim == 4
    Om = 1.3
    s = prob.shot(np.zeros(4), Om, 1)
    assert s.status == "ok" and s.n_impacts == 0
    assert s.gap == pytest.approx(1.0 / float(sc.system.contact_static[0]) / 0.1, rel=1e-15)
    om, c = sc.system.omega, sc.system.damping
    lam = -c / 2 + 1j * np.sqrt(om ** 2 - c ** 2 / 4)
    T = 2 * math.pi / Om
    expected = np.sort_complex(np.exp(np.concatenate([lam, lam.conj()]) * T))
    np.testing.assert_allclose(_multipliers(s), expected, rtol=1e-11)


def test_an_impacting_orbit_obeys_liouville_and_equals_the_sdofs_problem():
    """A period-1 orbit with one impact per period (Fig. 7 values, Omega = 1.8), refined by
    Newton on the scene's problem: ``det M = R^2 exp(-2 beta T)`` (Liouville with the
    saltation matrix's determinant ``R^2``; 1e-10) and the SDOF's own shooting problem
    (periodic_sdof.SDOFShooting, its own parametrisation) gives the same state and monodromy
    (1e-12: the same integrator on the same scene)."""
    m = SDOF(beta=0.015, B=0.01, R=0.8, Delta=0.0)
    Om = 1.8
    x = make_solver(m, "event").point(Om, None, 400, 1, 8).final_state[:2]
    prob = SceneShooting(m.scene())
    pt, why = start_point(prob, x, Om, 1, 0.5 * Om, 2 * Om)
    assert pt is not None, why
    s = prob.shot(pt.x, Om, 1)
    assert s.n_impacts == 1
    T = 2 * math.pi / Om
    assert np.linalg.det(s.M) == pytest.approx(0.8 ** 2 * math.exp(-2 * 0.015 * T), rel=1e-10)
    ref = shooting_problem(m, "Omega").shot(pt.x, Om, 1)
    np.testing.assert_allclose(s.x, ref.x, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(s.M, ref.M, rtol=1e-12, atol=1e-14)


def test_the_beam_scene_equals_the_beams_problem():
    """The FE rig (2 modes) on its stop at 15.2 Hz: the scene's problem and the beam's own
    (periodic_beam.BeamContinuation) give the same shot, state and monodromy (1e-12 of their
    norms: the same integrator on the same scene)."""
    from vibeam.case.schema import load_case

    case, _ = load_case("cases/rig-fe-neutral.toml")
    m = case.model_spec({"n_modes": 2}).build()
    W = 15.2 / m.f_ref_hz
    x = make_solver(m, "event").point(W, None, 300, 1, 8).final_state[:4]
    s = SceneShooting(m.scene()).shot(x, W, 1)
    ref = shooting_problem(m, "Omega").shot(x, W, 1)
    assert s.status == ref.status == "ok" and s.n_impacts == ref.n_impacts >= 1
    np.testing.assert_allclose(s.x, ref.x, rtol=0, atol=1e-12 * np.linalg.norm(ref.x))
    np.testing.assert_allclose(s.M, ref.M, rtol=0, atol=1e-12 * np.linalg.norm(ref.M))


def test_what_has_no_shot_is_said():
    prob = SceneShooting(SDOF(beta=0.0, B=0.01, R=0.8, Delta=0.5).scene())
    assert "positive" in prob.invalid(0.0) and "positive" in prob.invalid(-1.0)
    assert "resonance" in prob.invalid(1.0) and prob.invalid(1.1) == ""
    assert not prob.frequency_corrector()
    assert prob.shot(np.zeros(2), 1.0, 1).status == "failed"
    assert SceneShooting(SDOF(beta=0.01, B=0.01, R=0.8, Delta=0.5).scene()).frequency_corrector()
    with pytest.raises(ValueError, match="allowed: Omega"):
        SceneShooting(SDOF(beta=0.01, B=0.01, R=0.8, Delta=0.5).scene(), "R")


def test_a_tabulated_restitution_obeys_liouville_with_its_slope():
    """Newton's law with ``R(U)`` tabulated (piecewise linear): an impact's saltation matrix has
    ``det S = R (R + U R'(U))`` (``dU+/dU- = -(R + U R')``), so the Lyapunov exponents of the
    scene's problem sum to ``-2 beta + sum ln(R (R + U R')) / t`` over the shots' impacts, with
    ``R`` and ``R'`` of the table written here (1e-10 of the sum; measured 2e-15).  The orbit's
    speed lies inside the table, so the slope term is exercised."""
    from vibeam.models.lyapunov import lyapunov_spectrum

    tU, tR = (0.0, 0.05, 0.15), (0.85, 0.55, 0.8)
    m = SDOF(beta=0.015, B=0.01, R=0.8, Delta=0.0, R_table=tuple(zip(tU, tR)))
    Om = 1.8
    x = make_solver(m, "event").point(Om, None, 300, 1, 8).final_state[:2]
    prob = SceneShooting(m.scene())
    K = 100
    sp = lyapunov_spectrum(prob, x, Om, K)
    assert sp.status == "ok" and sp.impacts >= K
    y, S, inside = x.copy(), 0.0, 0
    for _ in range(K):
        s = prob.shot(y, Om, 1)
        for U in np.abs(s.impact_velocities):
            k = int(np.clip(np.searchsorted(tU, U), 1, len(tU) - 1))
            slope = (tR[k] - tR[k - 1]) / (tU[k] - tU[k - 1]) if U < tU[-1] else 0.0
            inside += U < tU[-1]
            R = float(np.interp(U, tU, tR))
            S += math.log(R * (R + U * slope))
        y = s.x
    assert inside == sp.impacts
    expected = -2 * 0.015 + S / (K * 2 * math.pi / Om)
    assert abs(sp.exponents.sum() - expected) < 1e-10 * abs(expected)
