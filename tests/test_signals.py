"""The certified scan's building blocks (vibeam.models.core.signals) against what they certify,
written out here (cosmic-ray's mutants of the curvature test, the start slope and the derivative
bounds survived tests/test_event.py and tests/test_recurrence.py: the events those tests meet do
not reach the branches a wrong bound or slope would take).

A signal is ``f(s) = const + sum_j p_j x_j + r_j x_j' + Sa sin(phi0 + Om s) + Sb cos(phi0 + Om s)``
with each ``x_j'' + 2 sig_j x_j' + k_j x_j = 0`` (the free flow's homogeneous part)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from vibeam.models.core.signals import bounds, certify_curvature, homogeneous_bounds, signal_start
from vibeam.models.system import mode_table


@njit(cache=False)
def _start(phi0, Om, x0, y0, mp, p, r, Sa, Sb, const, m):
    return signal_start(phi0, Om, x0, y0, mp, p, r, Sa, Sb, const, m)


@njit(cache=False)
def _bounds(x0, y0, mp, p, r, Csin, Om, m):
    hb = np.zeros((m, 6))
    for j in range(m):
        homogeneous_bounds(x0[j], y0[j], mp[j, 0], mp[j, 1], int(mp[j, 2]), mp[j, 3], mp[j, 4], mp[j, 5], hb[j])
    return bounds(hb, p, r, Csin, Om, m)


def _scene():
    """Two underdamped modes and one overdamped, a harmonic part."""
    mp = mode_table(np.array([0.03, 0.5, 5.0]), np.array([1.0, 9.0, 4.0]))
    x0 = np.array([0.3, -0.2, 0.1])
    y0 = np.array([-0.5, 0.4, -0.3])
    p = np.array([1.0, -0.7, 0.4])
    r = np.array([0.2, 0.1, -0.3])
    return mp, x0, y0, p, r, 0.05, -0.02, 0.01, 1.7, 0.4


def _x(mp, x0, y0, s):
    """``(x_j(s), x_j'(s))`` of each mode, closed form (under- or overdamped)."""
    x, v = [], []
    for (sig, k, typ, q, l1, l2), a, b in zip(mp, x0, y0):
        if typ == 0:
            B = (b + sig * a) / q
            e, c, sn = math.exp(-sig * s), math.cos(q * s), math.sin(q * s)
            x.append(e * (a * c + B * sn))
            v.append(e * ((q * B - sig * a) * c - (sig * B + q * a) * sn))
        else:
            c1 = (b - l2 * a) / (l1 - l2)
            x.append(c1 * math.exp(l1 * s) + (a - c1) * math.exp(l2 * s))
            v.append(c1 * l1 * math.exp(l1 * s) + (a - c1) * l2 * math.exp(l2 * s))
    return np.array(x), np.array(v)


def test_the_start_slope_is_the_signals_derivative():
    """signal_start's (f, f') at s = 0 against f' written out: Om (Sa cos - Sb sin) + sum p y0 +
    r x''(0) with x'' = -2 sig y - k x (a mutant of x'' survived), and against a central
    difference of the closed-form signal (1e-8: h = 1e-5, error h^2 |f'''|)."""
    mp, x0, y0, p, r, Sa, Sb, const, Om, phi0 = _scene()
    f, fp = _start(phi0, Om, x0, y0, mp, p, r, Sa, Sb, const, 3)
    x2 = -2.0 * mp[:, 0] * y0 - mp[:, 1] * x0
    want = Om * (Sa * math.cos(phi0) - Sb * math.sin(phi0)) + np.sum(p * y0 + r * x2)
    assert abs(fp - want) <= 1e-14 * abs(want) and abs(f - (const + Sa * math.sin(phi0) + Sb * math.cos(phi0)
                                                               + np.sum(p * x0 + r * y0))) <= 1e-15

    def sig(s):
        x, dx = _x(mp, x0, y0, s)
        return const + np.sum(p * x + r * dx) + Sa * math.sin(phi0 + Om * s) + Sb * math.cos(phi0 + Om * s)

    h = 1e-5              # error h^2 |f3| / 6 ~ 1e-10, round-off 1e-16 / h ~ 1e-11
    assert abs((sig(h) - sig(-h)) / (2 * h) - fp) <= 1e-8 * abs(fp)


def test_the_derivative_bounds_bound_the_signal():
    """bounds' M2, M3, M4 hold over s in [0, 20] for the closed-form signal's derivatives (by
    differences of the exact solution; a mutant that made M3 1e-300 survived): each sampled
    |f^(m)| <= M_m (M3 with 1e-3 for the differences' error), and M_m within 10x of the largest
    sample (not vacuous: a sum of amplitude bounds, measured ~3x)."""
    mp, x0, y0, p, r, Sa, Sb, const, Om, phi0 = _scene()
    M2, M3, M4 = _bounds(x0, y0, mp, p, r, math.hypot(Sa, Sb), Om, 3)
    s = np.linspace(0.0, 20.0, 2001)
    h = 2e-3

    def f(t):
        xv = [_x(mp, x0, y0, u) for u in np.atleast_1d(t)]
        x, dx = np.array([a for a, _ in xv]), np.array([b for _, b in xv])
        return const + x @ p + dx @ r + Sa * np.sin(phi0 + Om * t) + Sb * np.cos(phi0 + Om * t)

    F = [f(s + k * h) for k in range(-2, 3)]
    d2 = (F[3] - 2 * F[2] + F[1]) / h ** 2
    d3 = (F[4] - 2 * F[3] + 2 * F[1] - F[0]) / (2 * h ** 3)
    assert np.max(np.abs(d2)) <= M2 and np.max(np.abs(d3)) <= M3 * (1 + 1e-3), (np.max(np.abs(d3)), M3)
    assert M2 <= 10 * np.max(np.abs(d2)) and M3 <= 10 * np.max(np.abs(d3)) and M4 > M3   # measured ~3x


def test_curvature_is_certified_only_where_it_holds():
    """certify_curvature on f'' = a + b s + e s^2 / 2 over [0, 1] with its true derivative bounds:
    concave (-1) and convex (+1) where f'' keeps its sign, 0 where it changes sign -- f'' = 1 - 3 s
    is not concave (a mutant that certified it from the end point survived)."""
    def case(a, b, e, h=1.0):
        g2 = lambda s: a + b * s + 0.5 * e * s * s
        g3 = lambda s: b + e * s
        M3 = max(abs(g3(0.0)), abs(g3(h)))
        return certify_curvature(g2(0.0), g3(0.0), g2(h), g3(h), M3, abs(e), h, 0.0)

    assert case(1.0, -3.0, 0.0) == 0            # changes sign at s = 1/3
    assert case(-1.0, 3.0, 0.0) == 0
    assert case(-1.0, -1.0, 0.0) == -1 and case(1.0, 1.0, 0.0) == 1
    assert case(0.0, -1.0, -0.5) == -1 and case(0.0, 1.0, 0.5) == 1      # from a zero of f'' (a release)
    assert case(0.5, -3.0, 2.0) == 0
