"""Lyapunov exponents of the stroboscopic map (vibeam.models.orbits.lyapunov, issue 21) on the one
shooting-problem contract, against closed forms, Floquet multipliers, Liouville's formula and an
independent two-trajectory estimate.

Tolerances: for a periodic orbit the QR exponents after ``K`` shots lie within ``ln cond(V) /
t`` of ``ln |mu_i| / T`` (``V`` the monodromy's eigenvectors, ``t = K T``): the singular values
of ``M^K = V D^K V^-1`` lie within a factor ``cond(V)`` of ``|mu|^K``, and the exponents' sum is
exact, so the bound holds for each of them (plus round-off).  The sum is ``ln |det M|`` at every
shot, so Liouville's formula holds to the round-off of ``K`` logarithms.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

from vibeam.models.orbits.lyapunov import lyapunov_spectrum
from vibeam.models import EventSolver, shooting_problem
from vibeam.models.builders.sdof import sdof

BETA, R = 0.015, 0.9
FIG8 = sdof(BETA, 0.5e-3, 0.7e-3, R)                             # paper Fig. 8
TWO_SIDED = sdof(BETA, 0.5e-3, 0.0, R, Delta_lower=2e-3)         # cases/paper-fig7-two-sided.toml
CHAOS_OMEGA = 2.38                                              # "not periodic (chaos)" there


def _attractor(m, W, periods=400):
    tr = EventSolver(m).point(W, None, periods, 1, 16)
    assert tr.status == "ok"
    return tr.final_state[:2]


def _fixed_point(prob, x, W):
    for _ in range(6):
        s = prob.shot(x, W, 1)
        x = x - np.linalg.solve(s.M - np.eye(2), s.x - x)
    return x


def test_a_scene_without_impacts_has_both_exponents_minus_beta():
    """Fig. 8's scene with its stop moved out of reach (Delta = 1, the linear amplitude ~1e-3) at
    Omega = 2.2 (no impact, asserted; with Fig. 8's Delta = 0.7e-3 the orbit from rest is on a
    chaotic transient for hundreds of periods): the monodromy is ``e^{A T}``, ``A = [[0, 1], [-1, -2 beta]]`` (computed here by expm), whose
    eigenvalues have modulus ``e^{-beta T}``: both exponents are ``-beta``; their sum is
    ``-2 beta`` to 1e-12 (measured 4.5e-16) and each lies within ``ln cond(V) / t`` of ``-beta``
    (measured 1.9e-7 against a bound of 1.3e-6 after 4000 shots)."""
    W = 2.2
    free = sdof(BETA, 0.5e-3, 1.0, R)
    prob = shooting_problem(free, "Omega")
    sp = lyapunov_spectrum(prob, _attractor(free, W), W, 4000)
    assert sp.status == "ok" and sp.impacts == 0
    T = 2 * math.pi / W
    Mf = expm(np.array([[0.0, 1.0], [-1.0, -2 * BETA]]) * T)
    assert np.allclose(np.abs(np.linalg.eigvals(Mf)), math.exp(-BETA * T), rtol=1e-12)
    bound = math.log(np.linalg.cond(np.linalg.eig(Mf)[1])) / sp.time
    assert abs(sp.exponents.sum() + 2 * BETA) < 1e-12
    assert np.all(np.abs(sp.exponents + BETA) <= bound + 1e-12), (sp.exponents + BETA, bound)


def test_a_stable_period_one_orbit_has_the_exponents_of_its_floquet_multipliers():
    """Fig. 8 at Omega = 1.8: the impacting period-1 orbit (its fixed point refined by Newton on
    the shot, one impact per period): ``lambda_i = ln |mu_i| / T`` for the multipliers of the
    continuation's monodromy, within ``ln cond(V) / t`` (measured 5.5e-6 against 1.7e-5)."""
    W = 1.8
    prob = shooting_problem(FIG8, "Omega")
    x = _fixed_point(prob, _attractor(FIG8, W, 2000), W)
    s = prob.shot(x, W, 1)
    assert s.status == "ok" and s.impact_times.size == 1 and np.max(np.abs(s.x - x)) < 1e-14
    mu, V = np.linalg.eig(s.M)
    assert np.all(np.abs(mu) < 1.0)
    sp = lyapunov_spectrum(prob, x, W, 4000)
    T = 2 * math.pi / W
    expected = np.sort(np.log(np.abs(mu)) / T)[::-1]
    bound = math.log(np.linalg.cond(V)) / sp.time
    assert np.all(np.abs(sp.exponents - expected) <= bound + 1e-12), (sp.exponents - expected, bound)
    assert sp.largest < 0.0


@pytest.mark.parametrize("scene", ["period-1", "chaos"])
def test_liouville_the_sum_is_damping_plus_the_impacts_restitution(scene):
    """``sum lambda_i = -2 beta + 2 ln R x (impacts per unit time)`` (``det S = R^2`` per impact,
    ``det e^{A T} = e^{-2 beta T}``), on Fig. 8's period-1 orbit and on the chaotic attractor of
    the two-sided Fig. 7 scene (both stops R = 0.9), to 1e-11 (measured <= 5e-14)."""
    m, W = (FIG8, 1.8) if scene == "period-1" else (TWO_SIDED, CHAOS_OMEGA)
    prob = shooting_problem(m, "Omega")
    sp = lyapunov_spectrum(prob, _attractor(m, W), W, 2000)
    assert sp.status == "ok" and sp.impacts > 0
    assert abs(sp.exponents.sum() - (-2 * BETA + 2 * math.log(R) * sp.impacts / sp.time)) < 1e-11


def test_a_chaotic_attractor_has_a_positive_exponent_equal_to_the_two_trajectory_estimate():
    """The two-sided Fig. 7 scene at Omega = 2.38 (the case's "not periodic (chaos)"): lambda_1 >
    0 beyond 10 times its standard error, lambda_2 < 0; and lambda_1 equals Benettin's
    two-trajectory estimate along the same orbit -- a neighbour 1e-9 of the state away, its
    separation renormalised after every period, using the maps' end states only (no monodromy,
    no saltation matrix) -- to 1e-4 relative (measured 4.7e-7).

    The exponent of 2000 periods of one chaotic orbit is a random variable: over six orbits
    started 1e-9 apart on the attractor (decorrelated after 2000 periods: e^(lambda_1 t) ~ e^60)
    it was 0.0103-0.0147, and one orbit's own error estimate (half the difference of its two
    halves) 0.0004-0.0026.  So the significance is that of the six orbits' mean over their
    standard error (measured 0.0124 +- 0.0007)."""
    W = CHAOS_OMEGA
    prob = shooting_problem(TWO_SIDED, "Omega")
    x0 = _attractor(TWO_SIDED, W)
    K = 2000
    sp = lyapunov_spectrum(prob, x0, W, K)
    assert sp.status == "ok" and sp.largest > 0.0 and sp.exponents[1] < 0.0
    orbits = [sp] + [lyapunov_spectrum(prob, x0 + np.array([1e-9 * k * abs(x0[0]), 0.0]), W, K) for k in range(1, 6)]
    assert all(o.status == "ok" and o.exponents[1] < 0.0 for o in orbits)
    lam = np.array([o.largest for o in orbits])
    assert lam.mean() > 10 * lam.std(ddof=1) / math.sqrt(lam.size) and lam.mean() > 0.0
    x, u, S = x0.copy(), np.array([1.0, 0.0]), 0.0
    d0 = 1e-9 * float(np.max(np.abs(x0)))
    for _ in range(K):
        a = prob.shot(x, W, 1).x
        dv = prob.shot(x + d0 * u, W, 1).x - a
        dn = float(np.linalg.norm(dv))
        S += math.log(dn / d0)
        u, x = dv / dn, a
    assert abs(S / sp.time - sp.largest) < 1e-4 * sp.largest


def test_the_beam_on_a_kelvin_voigt_stop_obeys_liouville():
    """The same function on the compliant beam's shooting problem (2 modes, Kelvin-Voigt stop of
    1e5 N/m, 15.4 Hz, settled; every shot exact): ``sum lambda_i = trace(A_free) - c |w|^2 T_c /
    t`` (the contact phase's trace loses ``c w w^T``; ``T_c`` the contact time of the shots,
    recounted here), to 1e-9 of ``|trace A_free|`` (measured 2.7e-14)."""
    from vibeam.case.schema import load_case
    from vibeam.models import make_solver, shooting_problem
    from vibeam.models.scene import outputs

    case, _ = load_case("cases/rig-fe-neutral.toml")
    m = case.model_spec({"n_modes": 2, "contact": {"law": "linear", "stiffness_n_m": 1e5}}).scene()
    sy = m.system
    W = 15.4 / sy.reference_hz
    x = make_solver(m, "event").point(W, None, 200, 1, 16).final_state[:4]
    prob = shooting_problem(m, "Omega")
    K = 40
    sp = lyapunov_spectrum(prob, x, W, K)
    assert sp.status == "ok" and sp.impacts >= K
    Tc, y = 0.0, x.copy()
    for _ in range(K):
        s = prob.shot(y, W, 1)
        Tc += s.extra["contact_time"]
        y = s.x
    # the stop's dashpot c_c = 2 zeta_c sqrt(k_c m_eff) (k_c in SI: the scene holds it over omega_ref^2), per omega_ref
    law, om_ref = m.stops[0].law, 2 * math.pi * sy.reference_hz
    c = 2.0 * law.damping_ratio * math.sqrt(law.stiffness * om_ref ** 2 * outputs(m).m_eff) / om_ref
    tr_free = -float(np.sum(sy.damping))
    expected = tr_free - c * float(sy.contacts[0] @ sy.contacts[0]) * Tc / sp.time
    assert abs(sp.exponents.sum() - expected) < 1e-9 * abs(tr_free)


def test_arguments_are_checked():
    with pytest.raises(ValueError, match="shots"):
        lyapunov_spectrum(shooting_problem(FIG8, "Omega"), [0.0, 0.0], 1.8, 1)


def test_the_api_settles_the_case_and_converts_to_seconds():
    """``vibeam.lyapunov`` on the shipped two-sided Fig. 7 case (its first run's model) equals the
    model-level spectrum from the same settled state (the same computation: to round-off), and on
    the physical rig scene gives the exponents per second as ``2 pi f_n`` times the
    nondimensional ones (hand conversion); bad arguments get one line.  Independently of the
    function the API calls, both sums obey Liouville's formula ``-2 beta + 2 ln R x (impacts per
    unit time)`` with the case files' values written here."""
    import vibeam

    res = vibeam.lyapunov("cases/paper-fig7-two-sided.toml", Omega=CHAOS_OMEGA, shots=400, transient=400)
    sp = lyapunov_spectrum(shooting_problem(TWO_SIDED, "Omega"), _attractor(TWO_SIDED, CHAOS_OMEGA), CHAOS_OMEGA, 400)
    assert res.status == "ok" and res.exponents_per_s is None
    np.testing.assert_allclose(res.exponents, sp.exponents, rtol=1e-9, atol=1e-15)
    # independent of the function it calls: Liouville's formula (both stops R = 0.9, beta = 0.015
    # of the case file) with the API's own impact count, to 1e-11 as above (measured 2e-15)
    ipp = res.impacts_per_period
    assert ipp > 1.0
    assert abs(res.exponents.sum() - (-2 * BETA + 2 * math.log(R) * ipp * CHAOS_OMEGA / (2 * math.pi))) < 1e-11
    rig = vibeam.lyapunov("cases/rig-neutral.toml", frequency_hz=15.0, shots=200, transient=200)
    case = vibeam.load_case("cases/rig-neutral.toml")
    assert rig.status == "ok"
    fn = case.model_spec().system.natural_frequency_hz
    np.testing.assert_allclose(rig.exponents_per_s, rig.exponents * 2 * math.pi * fn,
                               rtol=1e-15)
    # the rig's per-second sum by Liouville with the case file's values written here (f_n = 7.6 Hz,
    # damping_ratio 0.017, R = 0.72; Omega = 15 / 7.6): 1e-11 of the nondimensional sum (times 2 pi
    # f_n ~ 48), round-off of the logarithms over 200 shots
    W_rig = 15.0 / 7.6
    liouville = 2 * math.pi * 7.6 * (-2 * 0.017 + 2 * math.log(0.72) * rig.impacts_per_period * W_rig / (2 * math.pi))
    assert rig.impacts_per_period > 0 and abs(rig.exponents_per_s.sum() - liouville) < 1e-11 * 2 * math.pi * 7.6
    with pytest.raises(ValueError, match="shots = 1 is not allowed"):
        vibeam.lyapunov(case, frequency_hz=15.0, shots=1)
    with pytest.raises(TypeError, match="shots = 2.5: not a whole number"):
        vibeam.lyapunov(case, frequency_hz=15.0, shots=2.5)


def test_a_sweep_stores_each_points_spectrum_in_the_results_file(tmp_path):
    """``[sweep] lyapunov = true`` on the two-sided Fig. 7 scene (Omega = 2.30 ... 2.42, up):
    ``lyapunov`` and ``lyapunov_error`` on (direction, Omega, exponent) in ``results.h5`` (read
    back with ``vibeam.open_results``); at the period-4 point (1.5 impacts per period on the two
    stops) the sum obeys Liouville's formula to 1e-10 and lambda_1 < 0; at 2.38 (chaos) lambda_1 >
    0 beyond twice its error (over 2000 periods: 0.0148 +- 0.0003 from rest in the test above; here
    the point starts from the previous point's state)."""
    import tomllib

    import vibeam

    raw = tomllib.loads(open("cases/paper-fig7-two-sided.toml").read())
    raw["sweep"] = {"Omega": [2.30, 2.42, 4], "direction": "up", "transient_periods": 400, "record_periods": 32,
                    "lyapunov": True, "lyapunov_periods": 2000}
    raw["run"] = [raw["run"][0]]
    for k in ("quick", "regress", "map"):
        raw.pop(k, None)
    vibeam.run(vibeam.load_case(raw), jobs=1, out=tmp_path)
    ds = vibeam.open_results(tmp_path / "results.h5")[f"runs/{raw['run'][0]['name']}"].to_dataset()
    lam = ds["lyapunov"].sel(direction="up")
    assert lam.dims == ("Omega", "exponent") and list(ds["exponent"].values) == [1, 2]
    p4 = ds.sel(direction="up", Omega=2.30)
    assert int(p4["period"]) == 4
    n_imp = float(p4["impacts_per_period"]) + float(p4["impacts_per_period_lower"])
    assert n_imp == 1.5
    liouville = -2 * BETA + 2 * math.log(R) * n_imp / (2 * math.pi / 2.30)
    assert abs(float(lam.sel(Omega=2.30).sum()) - liouville) < 1e-10
    assert float(lam.sel(Omega=2.30)[0]) < 0.0
    chaos = ds.sel(direction="up", Omega=2.38)
    assert float(chaos["lyapunov"][0]) > 2 * float(chaos["lyapunov_error"][0]) > 0.0
    # the classes of the spectrum (vibeam.models.orbits.lyapunov.classify_spectrum): the period-4 point
    # is periodic, the point at 2.38 chaotic (lambda_1 beyond 3 errors here: 0.0148 +- 0.0003)
    assert str(p4["lyapunov_class"].values) == "periodic"
    assert str(chaos["lyapunov_class"].values) == "chaotic"


def test_the_spectrum_classes_and_the_map_classes():
    """classify_spectrum: chaotic beyond 3 errors, quasi-periodic at 0 within them with lambda_2
    below, non-periodic otherwise, empty when not computed; maps.classify turns the non-periodic
    points (and only them) into CHAOTIC and QUASI_PERIODIC."""
    from vibeam.analysis.maps import CHAOTIC, NON_PERIODIC, PERIOD_1, QUASI_PERIODIC, classify
    from vibeam.models.orbits.lyapunov import classify_spectrum

    assert classify_spectrum([0.01, -0.2], [0.001, 0.001]) == "chaotic"
    assert classify_spectrum([0.002, -0.2], [0.001, 0.001]) == "quasi_periodic"
    assert classify_spectrum([1e-12, -1e-12], [0.0, 0.0]) == "non_periodic"     # lambda_2 not below
    assert classify_spectrum([-0.05, -0.2], [0.001, 0.001]) == "non_periodic"
    assert classify_spectrum([-0.05, -0.2], [0.001, 0.001], periodic=True) == "periodic"
    assert classify_spectrum([np.nan, np.nan], [np.nan, np.nan]) == ""
    c = classify([1, 0, 0, 0], ["ok"] * 4, ["chaotic", "chaotic", "quasi_periodic", ""])
    assert list(c) == [PERIOD_1, CHAOTIC, QUASI_PERIODIC, NON_PERIODIC]


def test_lambda_1_tends_to_zero_at_the_period_doubling_located_by_continuation():
    """Fig. 13's period-1 branch (paper Fig. 13: beta = 0.015, B = 0.5e-3, R = 0.9, Delta = 0.5e-3)
    continued from Omega = 1.5 loses stability by a period doubling (tests/test_continuation.py).
    Approaching it from the stable side (1e-3, 1e-4, 1e-5 before it), lambda_1 of the period-1
    orbit (QR over 4000 shots started on the fixed point) equals ln |mu_1| / T of the
    continuation's Floquet multiplier within the bound ln cond(V) / t of the first test (plus
    1e-9), and goes to 0: |lambda_1| decreases (measured 0.053, 0.0038, 0.00012), and is below
    1e-3 at 1e-5 before the doubling."""
    from vibeam.models.orbits.continuation import start_point, trace

    fig13 = sdof(BETA, 0.5e-3, 0.5e-3, R)
    prob = shooting_problem(fig13, "Omega")
    x0 = _attractor(fig13, 1.5)
    branches = trace(prob, x0, 1.5, 1, 1.5, 2.5, +1)
    pd = [f for f in branches[0].bifurcations if f.type == "period_doubling"][0]
    lam = []
    for d in (1e-3, 1e-4, 1e-5):
        W = pd.parameter - d
        pt, why = start_point(prob, pd.x, W, 1, 1.5, 2.5)
        assert pt is not None, why
        sp = lyapunov_spectrum(prob, pt.x, W, 4000)
        assert sp.status == "ok"
        T = 2 * math.pi / W
        mu = np.linalg.eigvals(pt.shot.M)
        floquet = np.sort(np.log(np.abs(mu)) / T)[::-1]
        bound = math.log(np.linalg.cond(np.linalg.eig(pt.shot.M)[1])) / sp.time + 1e-9
        assert np.all(np.abs(sp.exponents - floquet) <= bound), (d, sp.exponents, floquet, bound)
        lam.append(sp.largest)
    assert lam[0] < lam[1] < lam[2] < 0
    assert abs(lam[2]) < 1e-3
