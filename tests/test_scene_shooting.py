"""The shooting problem of a scene (vibeam.models.core.scene_shooting.SceneShooting, issue 58)
against closed forms, the paper's impact map, central differences and the direct integrator."""
import math

import numpy as np
import pytest

from vibeam.models import make_solver
from vibeam.models.builders.matrices import build_matrices, structure_scene
from vibeam.models.builders.sdof import sdof
from vibeam.models.contact import Relation, Restitution, Stop
from vibeam.models.orbits.continuation import start_point
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models.core.oscillator import particular_coefficients


def _multipliers(s):
    return np.sort_complex(np.linalg.eigvals(s.M))


def test_the_contact_free_orbit_has_the_damped_oscillators_multipliers():
    """Far from the stop the period-1 orbit is the harmonic response ``(b, Omega a)`` (paper
    Eq. 28) and its monodromy is ``exp(A T)``: multipliers ``exp((-beta +- i sqrt(1 - beta^2))
    T)``, ``T = 2 pi / Omega`` (closed form; 1e-12, round-off of the exact flow is ~1e-15)."""
    beta, B, Om = 0.03, 0.02, 1.7
    prob = SceneShooting(sdof(beta=beta, B=B, R=0.8, Delta=10.0))
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
    M = np.diag([2.0, 0.5])
    K = np.array([[4.2e4, -1.2e4], [-1.2e4, 1.2e4]])
    mm = build_matrices(M, K, damping_ratios=0.02, dofs=["m1", "m2"], sensor="m1", contacts=["m2"], length_m=0.1)
    sc = structure_scene(mm, (Stop(Relation(1.0, 1.0), Restitution(0.7)),), 1e-5)
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


def _central_monodromy(prob, x, p, n=1, rel=1e-6):
    """``d P^n / d x0`` by central differences of the shots (steps ``rel max |x|``)."""
    h = rel * np.max(np.abs(x))
    cols = []
    for j in range(x.size):
        e = np.zeros(x.size)
        e[j] = h
        cols.append((prob.shot(x + e, p, n, derivatives=False).x - prob.shot(x - e, p, n, derivatives=False).x) / (2 * h))
    return np.column_stack(cols)


def test_an_impacting_orbit_obeys_liouville_and_is_the_impact_maps_fixed_point():
    """A period-1 orbit with one impact per period (Fig. 7 values, Omega = 1.8), refined by
    Newton on the scene's problem: ``det M = R^2 exp(-2 beta T)`` (Liouville with the
    saltation matrix's determinant ``R^2``; 1e-10); its state is the paper's impact map's fixed
    point (Eqs. 33-34, Newton on the closed form) carried by the closed-form flow (Eq. 28) to
    phase 0 (1e-10: two independent codes, each exact to round-off; measured 8e-16); its
    monodromy equals the central differences of the shots (steps 1e-6: truncation ~1e-12,
    round-off ~1e-10 amplified by |M| ~ 1: 1e-7; measured 1.7e-10)."""
    from vibeam.models.mapping import newton_fixed_point
    from vibeam.models.core.oscillator import propagate

    sc = sdof(beta=0.015, B=0.01, R=0.8, Delta=0.0)
    Om = 1.8
    x = make_solver(sc, "event").point(Om, None, 400, 1, 8).final_state[:2]
    prob = SceneShooting(sc)
    pt, why = start_point(prob, x, Om, 1, 0.5 * Om, 2 * Om)
    assert pt is not None, why
    s = prob.shot(pt.x, Om, 1)
    assert s.n_impacts == 1
    T = 2 * math.pi / Om
    assert np.linalg.det(s.M) == pytest.approx(0.8 ** 2 * math.exp(-2 * 0.015 * T), rel=1e-10)
    fp = newton_fixed_point(sc, Om, ((Om * s.impact_times[0]) % (2 * math.pi), s.impact_velocities[0]), 1)
    assert fp is not None
    phi, v = fp
    a, b = particular_coefficients(0.015, Om * Om * 0.01, Om)
    g, w, _, _, _ = propagate(((2 * math.pi - phi) % (2 * math.pi)) / Om, phi, 0.0, -0.8 * v, 0.015, a, b, Om, 0.0)
    np.testing.assert_allclose(s.x, [g, w], rtol=1e-10, atol=1e-13)
    Mfd = _central_monodromy(prob, pt.x, Om)
    assert np.max(np.abs(Mfd - s.M)) <= 1e-7 * max(1.0, np.max(np.abs(s.M)))


def test_the_beam_scenes_shot_equals_the_direct_integrator_and_central_differences():
    """The FE rig (2 modes) on its stop at 15.2 Hz: the scene's shot from a settled state equals
    one period of the direct integrator (scipy's event-located ODE solution, an independent
    integrator; 1e-9 of the state's norm, its tolerances; measured 1.5e-11), and the shot's
    monodromy the central differences of the shots (steps 1e-6 of the state: truncation ~1e-12,
    round-off ~1e-10; 1e-8 of the norm, measured 1.2e-10)."""
    from vibeam.case.schema import load_case

    case, _ = load_case("cases/rig-fe-neutral.toml")
    m = case.model_spec({"n_modes": 2}).scene()
    W = 15.2 / m.system.reference_hz
    x = make_solver(m, "event").point(W, None, 300, 1, 8).final_state[:4]
    prob = SceneShooting(m)
    s = prob.shot(x, W, 1)
    assert s.status == "ok" and s.n_impacts >= 1
    ref = make_solver(m, "direct").point(W, np.r_[x, 0.0], 0, 1, 8).final_state[:4]
    np.testing.assert_allclose(s.x, ref, rtol=0, atol=1e-9 * np.linalg.norm(ref))
    Mfd = _central_monodromy(prob, x, W)
    np.testing.assert_allclose(s.M, Mfd, rtol=0, atol=1e-8 * np.linalg.norm(s.M))


def test_what_has_no_shot_is_said():
    prob = SceneShooting(sdof(beta=0.0, B=0.01, R=0.8, Delta=0.5))
    assert "positive" in prob.invalid(0.0) and "positive" in prob.invalid(-1.0)
    assert "resonance" in prob.invalid(1.0) and prob.invalid(1.1) == ""
    assert not prob.frequency_corrector()
    assert prob.shot(np.zeros(2), 1.0, 1).status == "failed"
    assert SceneShooting(sdof(beta=0.01, B=0.01, R=0.8, Delta=0.5)).frequency_corrector()
    with pytest.raises(ValueError, match="allowed: Omega"):
        SceneShooting(sdof(beta=0.01, B=0.01, R=0.8, Delta=0.5), "R")


def test_a_tabulated_restitution_obeys_liouville_with_its_slope():
    """Newton's law with ``R(U)`` tabulated (piecewise linear): an impact's saltation matrix has
    ``det S = R (R + U R'(U))`` (``dU+/dU- = -(R + U R')``), so the Lyapunov exponents of the
    scene's problem sum to ``-2 beta + sum ln(R (R + U R')) / t`` over the shots' impacts, with
    ``R`` and ``R'`` of the table written here (1e-10 of the sum; measured 2e-15).  The orbit's
    speed lies inside the table, so the slope term is exercised."""
    from vibeam.models.orbits.lyapunov import lyapunov_spectrum

    tU, tR = (0.0, 0.05, 0.15), (0.85, 0.55, 0.8)
    sc = sdof(beta=0.015, B=0.01, Delta=0.0, law=Restitution(0.8, tU, tR))
    Om = 1.8
    x = make_solver(sc, "event").point(Om, None, 300, 1, 8).final_state[:2]
    prob = SceneShooting(sc)
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


def _chain_on_two_stops(R_lower=0.7):
    """The two-mass chain with a stop on each side of mass 2, at 0.6 and 0.8 of its contact-free
    amplitude at Omega = 1.3 (so both are hit), Newton's law on each."""
    M = np.diag([2.0, 0.5])
    K = np.array([[4.2e4, -1.2e4], [-1.2e4, 1.2e4]])
    mm = build_matrices(M, K, damping_ratios=0.02, dofs=["m1", "m2"], sensor="m1", contacts=["m2"], length_m=0.1)
    sc = structure_scene(mm, (Stop(Relation(1.0, 1.0), Restitution(0.7)),), 1e-5)
    A = SceneShooting(sc).linear_amplitude(1.3)
    return sc._replace(stops=(Stop(Relation(1.0, 0.6 * A, 0), Restitution(0.7)),
                              Stop(Relation(-1.0, 0.8 * A, 0), Restitution(R_lower)))), A


@pytest.mark.parametrize("path", ["Omega", "system.base_amplitude", "stops[0].relation.offset",
                                  "stops[1].relation.offset", "stops[1].law.R",
                                  ("stops[0].law.R", "stops[1].law.R"), "system.damping"])
def test_every_scene_path_has_the_exact_parameter_derivative(path):
    """A structure given by its matrices on two stops, each path of the scene's problem: ``d x /
    d p`` of the shot against central differences of the shots at ``p +- 1e-6 p`` (truncation
    ~1e-12, round-off ~1e-16 / 1e-6 amplified by the orbit: 1e-7 of the scale; measured <= 3e-9).
    The damping path moves every mode's coefficient along the scene's own (``slope = c``: ``p =
    1`` is the scene)."""
    sc, _ = _chain_on_two_stops()
    Om = 1.3
    kw = dict(damping=(1.0, sc.system.damping)) if path == "system.damping" else {}
    prob = SceneShooting(sc, path, Omega=Om, **kw)
    p = Om if path == "Omega" else prob.value
    x = np.zeros(4)
    for _ in range(30):
        x = prob.shot(x, p, 1, derivatives=False).x
    s = prob.shot(x, p, 1)
    assert s.status == "ok" and set(s.extra["impact_stops"]) == {0, 1}
    h = 1e-6 * abs(p)
    fd = (prob.shot(x, p + h, 1).x - prob.shot(x, p - h, 1).x) / (2 * h)
    scale = max(np.max(np.abs(fd)), np.max(np.abs(x)))
    assert np.max(np.abs(fd - s.x_p)) <= 1e-7 * scale, (fd, s.x_p)


def test_the_scene_at_a_value_and_what_a_path_refuses():
    """``scene_at`` sets the path's numbers and nothing else; the starts follow the scene (the
    averaging start is the one-mode oscillator's); what cannot be continued is said in one line."""
    sc, A = _chain_on_two_stops()
    both = SceneShooting(sc, ("stops[0].law.R", "stops[1].law.R"), Omega=1.3)
    at = both.scene_at(0.4)
    assert [st.law.R for st in at.stops] == [0.4, 0.4] and at.system is sc.system
    off = SceneShooting(sc, "stops[1].relation.offset", Omega=1.3).scene_at(2 * A)
    assert off.stops[1].relation.offset == 2 * A and off.stops[0] == sc.stops[0]
    assert SceneShooting.offered_starts(sc) == ("linear",)
    assert SceneShooting.offered_starts(sdof(beta=0.01, B=0.01, R=0.8, Delta=0.5)) == ("linear", "averaging")
    x, why = SceneShooting(sc).start("linear", 1.3)
    assert x is None and "upper stop reaches its offset" in why
    far = SceneShooting(sc, "stops[0].relation.offset", Omega=1.3)
    assert far.start("linear", 0.7 * A)[0] is None
    with pytest.raises(ValueError, match="not available"):
        SceneShooting(sc).start("averaging", 1.3)
    assert "out of range" in both.invalid(1.2)
    assert "overlap" in SceneShooting(sc, "stops[0].relation.offset", Omega=1.3).invalid(-0.9 * A)
    with pytest.raises(ValueError, match="must hold one value"):
        SceneShooting(_chain_on_two_stops(0.5)[0], ("stops[0].law.R", "stops[1].law.R"), Omega=1.3)
    with pytest.raises(ValueError, match="needs the forcing frequency"):
        SceneShooting(sc, "stops[0].law.R")
    with pytest.raises(ValueError, match="2 stop"):
        SceneShooting(sc, "stops[2].law.R", Omega=1.3)
    with pytest.raises(ValueError, match="damping = "):
        SceneShooting(sc, "system.damping", Omega=1.3)


def test_resect_carries_a_one_mode_impact_across_the_section_exactly():
    """The one-mode oscillator (Fig. 7 values, Omega = 1.8): ``resect`` moves an impact that
    coincides with the section to its other side and carries the state there by the exact free
    flow: the state it returns is the post-impact (pre-impact) state flown to the section in closed
    form (1e-15 of the state: round-off; measured 1e-17), and the motions agree from the next
    period on to the event location's tolerance (1e-7, as the beam's first-order version in
    test_continuation_beam; measured 6e-9):

    * first impact 1e-9 T after phase 0: the post-impact state; one period later both are the same
      state, one impact fewer;
    * last impact 1e-9 T before the end (a state receding from the stop, Omega tuned by brentq):
      the pre-impact state carried to the end, whose next period (impact at 0+ included) is the
      original's next period."""
    from scipy.optimize import brentq

    from vibeam.models.system import modal_flow

    sc = sdof(beta=0.015, B=0.01, R=0.8, Delta=0.0)
    prob = SceneShooting(sc)
    sy = sc.system
    W = 1.8
    T = 2 * math.pi / W
    x0 = np.concatenate(modal_flow(sy, 1e-9 * T, 0.0, np.zeros(1), np.array([0.05]), W))
    s0 = prob.shot(x0, W, 1)
    assert s0.n_impacts >= 1 and abs(s0.impact_times[0] - 1e-9 * T) < 1e-12 * T
    x1 = prob.resect(x0, W, 1)
    assert x1 is not None and x1[1] < 0 < x0[1]
    post = np.concatenate(modal_flow(sy, 1e-9 * T, 0.0, np.zeros(1), np.array([-0.8 * 0.05]), W))
    np.testing.assert_allclose(x1, post, rtol=0, atol=1e-15 * np.max(np.abs(post)))
    s1 = prob.shot(x1, W, 1)
    assert s1.n_impacts == s0.n_impacts - 1
    np.testing.assert_allclose(s1.x, s0.x, rtol=0, atol=1e-7 * np.max(np.abs(s0.x)))
    xa = np.array([0.0, -0.1])

    def late(Wq):
        s = prob.shot(xa, Wq, 1, derivatives=False)
        return (s.impact_times[0] * Wq / (2 * math.pi) if s.n_impacts else 2.0) - (1 - 1e-9)

    grid = np.linspace(1.0, 3.0, 41)
    vals = [late(w) for w in grid]
    i = next(k for k in range(40) if vals[k] < 0 < vals[k + 1])
    W2 = brentq(late, grid[i], grid[i + 1], xtol=1e-15, rtol=1e-15)
    if late(W2) > 0.5:        # brentq may end on the side without an impact: take the other neighbour
        W2 = np.nextafter(W2, 0.0)
    T2 = 2 * math.pi / W2
    s2 = prob.shot(xa, W2, 1)
    assert s2.n_impacts == 1 and T2 - 1e-6 * T2 < s2.impact_times[0] < T2
    y = prob.resect(xa, W2, 1)
    assert y is not None
    pre = np.concatenate(modal_flow(sy, s2.impact_times[0], T2, np.zeros(1), np.array([s2.impact_velocities[0]]), W2))
    np.testing.assert_allclose(y, pre, rtol=0, atol=1e-15 * np.max(np.abs(pre)))
    nxt_a, nxt_b = prob.shot(s2.x, W2, 1), prob.shot(y, W2, 1)
    assert nxt_b.n_impacts == nxt_a.n_impacts + 1 and nxt_b.impact_times[0] < 1e-9 * T2
    np.testing.assert_allclose(nxt_b.x, nxt_a.x, rtol=0, atol=1e-7 * np.max(np.abs(nxt_a.x)))
