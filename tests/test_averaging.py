"""Averaging with Zhuravlev's transformation (paper Sec. 4.1, Eqs. 18-27)."""
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from vibeam.models import make_solver
from vibeam.models import EventSolver
from vibeam.models.builders.sdof import sdof
from vibeam.models.paper.averaging import (Delta_max, P_of_Q, amplitudes, discriminant,
                                          phase, polynomial_coefficients, solve)

BETA, B = 0.015, 0.5e-3


@pytest.mark.parametrize("k", [1, 2, 3])
@pytest.mark.parametrize("Delta", [-0.7e-3, 0.0, 0.7e-3])
def test_roots_solve_P(k, Delta):
    Omega = np.linspace(2 * k - 0.4, 2 * k + 0.4, 401)
    up, lo = amplitudes(Omega, BETA, B, 0.9, Delta, k)
    g2, g1, g0 = polynomial_coefficients(Omega, BETA, B, 0.9, Delta, k)
    scale = np.abs(g0) + np.abs(g1) * np.nan_to_num(up) + g2 * np.nan_to_num(up) ** 2
    for Q in (up, lo):
        ok = np.isfinite(Q)
        assert np.all(Q[ok] > 0)
        assert np.all(np.abs(P_of_Q(Q, Omega, BETA, B, 0.9, Delta, k)[ok]) <= 1e-12 * scale[ok])
    assert np.isfinite(up).sum() > 10
    # the upper root exists wherever D >= 0 and g0 < 0 (one positive, one negative root)
    D = discriminant(Omega, BETA, B, 0.9, Delta, k)
    assert np.all(np.isfinite(up[(D > 0) & (g0 < 0)]))
    assert np.all(np.isnan(lo[(D > 0) & (g0 < 0)]))
    # both roots are NaN where the discriminant is negative
    assert np.all(np.isnan(up[D < 0])) and np.all(np.isnan(lo[D < 0]))


@pytest.mark.parametrize("k", [1, 2, 3])
def test_Delta_max_is_where_discriminant_vanishes(k):
    for Omega in (2 * k - 0.2, 2 * k - 0.03, 2 * k, 2 * k + 0.1):
        for R in (1.0, 0.8):
            f = lambda d: float(discriminant(Omega, BETA, B, R, d, k))
            assert f(0.0) > 0
            d0 = brentq(f, 0.0, 1.0, xtol=1e-16, rtol=1e-14)
            d1 = brentq(f, -1.0, 0.0, xtol=1e-16, rtol=1e-14)
            dm = float(Delta_max(Omega, BETA, B, R, k))
            assert dm == pytest.approx(d0, rel=1e-10)
            assert -d1 == pytest.approx(dm, rel=1e-10)
            # just inside there are real amplitudes, just outside none
            # (gaps beyond B_k Omega^2 need sigma_k Delta < 0, Eq. 24)
            sgn = -1.0 if Omega > 2 * k else 1.0
            assert np.isfinite(amplitudes(Omega, BETA, B, R, 0.999 * sgn * dm, k)[0])
            assert np.isnan(amplitudes(Omega, BETA, B, R, 1.001 * sgn * dm, k)[0])
            assert np.isnan(amplitudes(Omega, BETA, B, R, -1.001 * sgn * dm, k)[0])
    # minimum at resonance Omega = 2k (Eq. 27)
    W = np.linspace(2 * k - 0.3, 2 * k + 0.3, 6001)
    dm = Delta_max(W, BETA, B, 1.0, k)
    assert abs(W[np.argmin(dm)] - 2 * k) < 0.01


def test_Q_star_and_stability():
    W = np.linspace(1.6, 2.4, 801)
    for Delta in (0.7e-3, -0.7e-3):
        r = solve(W, BETA, B, 0.9, Delta)
        both = np.isfinite(r["amplitude"]) & np.isfinite(r["amplitude_lower"])
        assert both.sum() > 0  # a fold region with two branches
        assert np.all(r["amplitude"][both] > r["Q_star"][both])
        assert np.all(r["amplitude_lower"][both] < r["Q_star"][both])
        # Q* > 0 requires sigma Delta < 0 (Eq. 24): two branches only before (Delta > 0)
        # or after (Delta < 0) the resonance
        sigma = W / 2 - 1
        assert np.all(sigma[both] * Delta < 0)
        assert np.all(np.isnan(r["Q_star"][sigma * Delta > 0]))
        assert np.array_equal(r["stable"], np.isfinite(r["amplitude"]))
        assert not np.any(r["stable_lower"])


def test_solver_interface():
    m = sdof(BETA, B, 0.7e-3, 0.9)
    s = make_solver(m, "averaging")
    assert s.name == "averaging" and s.time_domain is False and s.settings() == {"k": 1}
    p = s.point(1.95, None, 0, 0)
    for key in ("amplitude", "amplitude_lower", "stable", "Q_star", "Delta_max", "period"):
        assert key in p
    assert p["status"] == "ok" and p["message"] == "" and p["period"] == 1 and p["stable"] is True
    # sigma Delta > 0 and Delta > B Omega^2 / 3 (g1, g0 > 0): no positive root
    far = make_solver(sdof(BETA, B, 2e-3, 0.9), "averaging").point(2.2, None, 0, 0)
    assert far["period"] == -1 and math.isnan(far["amplitude"])
    assert p["amplitude"] > p["Q_star"] > p["amplitude_lower"] > 0
    # at Omega = 2 this gap exceeds Delta_max = B Omega^2 / 3 (Eq. 27): no solution
    assert s.point(2.0, None, 0, 0)["period"] == -1
    assert make_solver(sdof(BETA, B, 0.0, 0.9), "averaging", k=2).point(4.0, None, 0, 0)["period"] == 2
    with pytest.raises(ValueError):
        make_solver(m, "averaging", k=0)


def test_averaging_vs_event_as_R_falls(capsys):
    """Paper Fig. 11: averaging agrees as R -> 1 and departs as R falls (~16 % at R = 0.6)."""
    Rs = [1.0, 0.9, 0.8, 0.7, 0.6]
    rel = []
    phases = []
    for R in Rs:
        Delta = 0.0
        m = sdof(BETA, B, Delta, R)
        tr = EventSolver(m).point(2.0, None, 800, 4, 64)
        assert tr.status == "ok"
        Qe = Delta - tr.q_min
        Qa = float(make_solver(m, "averaging").point(2.0, None, 0, 0)["amplitude"])
        rel.append(abs(Qa - Qe) / Qe)
        phases.append(((2.0 * tr.impact_times[-1]) % (2 * math.pi),
                       float(solve(2.0, BETA, B, R, 0.0)["impact_phase"]),
                       float(np.mod(-2 * phase(Qa, 2.0, BETA, B, R, 0.0, printed=True), 2 * math.pi))))
    with capsys.disabled():
        print("\nR, |Q_avg - Q_event| / Q_event at Omega = 2, Delta = 0:")
        for R, e, ph in zip(Rs, rel, phases):
            print(f"  R = {R:.1f}: {100 * e:6.2f} %   impact phase event {ph[0]:.4f}, "
                  f"averaging {ph[1]:.4f} (Eq. 23 as printed: {ph[2]:.4f})")
    assert rel[0] < 0.01
    assert all(b > a for a, b in zip(rel, rel[1:]))
    assert 0.08 < rel[-1] < 0.30
    # impact phase: quadrant-correct Eq. 23 agrees; the printed arctan is off by pi
    for (pe, pa, pp), R in zip(phases, Rs):
        assert abs(pe - pa) < 0.03
        assert abs(abs(pe - pp) - math.pi) < 0.03
