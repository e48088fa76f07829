"""Tests of the cubic-Hermite FE cantilever (vibeam.models.builders.beam_fe) against analytical
Euler-Bernoulli solutions whose frequency equations are solved here, independently
of the code under test."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from vibeam.models.builders.beam_fe import (BeamFE, BeamGeometry, calibrate, disc_stack, paper_rig,
                                shared_calibration, shared_fe, write_modes)


# ----------------------------------------------------------------- analytical roots
def _roots(f, n, lo=0.3, hi=20.0, step=1e-3):
    """First ``n`` sign-change roots of ``f`` on ``(lo, hi)`` refined by brentq."""
    xs = np.arange(lo, hi, step)
    vals = np.array([f(x) for x in xs])
    out = []
    for i in np.nonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)[0]:
        out.append(brentq(f, xs[i], xs[i + 1], xtol=1e-14, rtol=1e-15))
        if len(out) == n:
            break
    assert len(out) == n
    return np.array(out)


def bare_roots(n=4):
    # 1 + cos l cosh l = 0, divided by cosh l for conditioning
    return _roots(lambda l: 1.0 / math.cosh(l) + math.cos(l), n)


def tip_mass_roots(mu, n=4):
    # Karnovsky & Lebed: 1 + cos cosh + mu l (cos sinh - sin cosh) = 0  (/cosh)
    return _roots(lambda l: 1.0 / math.cosh(l) + math.cos(l)
                  + mu * l * (math.cos(l) * math.tanh(l) - math.sin(l)), n)


def _row(b, x, k):
    """k-th derivative / b^k of [cos, sin, cosh, sinh](b x)."""
    t = b * x
    return np.array([math.cos(t + k * math.pi / 2), math.sin(t + k * math.pi / 2),
                     math.cosh(t) if k % 2 == 0 else math.sinh(t),
                     math.sinh(t) if k % 2 == 0 else math.cosh(t)])


def intermediate_mass_det(b, a, mu, j):
    """8x8 determinant for a clamped-free beam (L = EI = rhoA = 1) with a rigid body
    (mass mu, rotary inertia j) at x = a; omega = b^2.  Unknowns: 4 coefficients on
    [0, a] (coordinate x) and 4 on [a, 1] (coordinate xi = x - a).  Jump conditions from
    EI w'''' - rhoA w^2 w = m w^2 w(a) delta - J w^2 w'(a) delta':
    [w'''] = mu w^2 w(a), [w''] = -j w^2 w'(a); scaled by b^k they read
    [w'''_n] = mu b w_n(a), [w''_n] = -j b^3 w'_n(a)."""
    A = np.zeros((8, 8))
    z4 = np.zeros(4)
    l2 = 1.0 - a
    A[0] = np.r_[_row(b, 0, 0), z4]                       # w(0) = 0
    A[1] = np.r_[_row(b, 0, 1), z4]                       # w'(0) = 0
    A[2] = np.r_[z4, _row(b, l2, 2)]                      # w''(1) = 0
    A[3] = np.r_[z4, _row(b, l2, 3)]                      # w'''(1) = 0
    A[4] = np.r_[_row(b, a, 0), -_row(b, 0, 0)]           # continuity of w
    A[5] = np.r_[_row(b, a, 1), -_row(b, 0, 1)]           # continuity of w'
    A[6] = np.r_[-_row(b, a, 2) + j * b**3 * _row(b, a, 1), _row(b, 0, 2)]
    A[7] = np.r_[-_row(b, a, 3) - mu * b * _row(b, a, 0), _row(b, 0, 3)]
    return np.linalg.det(A) / math.cosh(b) ** 2


def omega_scale(g):
    return math.sqrt(g.EI_n_m2 / (g.rhoA_kg_m * g.length_m**4))


# ----------------------------------------------------------------- frequencies
def test_bare_cantilever_frequencies_and_h4_convergence_from_above():
    lam = bare_roots()
    assert np.allclose(lam, [1.87510407, 4.69409113, 7.85475744, 10.99554073], atol=1e-8)
    g = BeamGeometry(length_m=0.5, EI_n_m2=2.0, rhoA_kg_m=0.3)
    exact = lam**2 * omega_scale(g)
    om = [BeamFE(g, n_elements=2, refine=r).modes(4).omega_rad_s for r in (2, 3, 4)]
    errs = [o - exact for o in om]
    for e in errs:
        assert np.all(e > 0)                                 # conforming FE: from above
    for e1, e2 in zip(errs[:-1], errs[1:]):
        order = np.log2(e1 / e2)                             # vs exact
        assert np.all((order > 3.6) & (order < 4.4)), order
    order3 = np.log2((om[0] - om[1]) / (om[1] - om[2]))      # 3 meshes, no exact value
    assert np.all((order3 > 3.6) & (order3 < 4.4)), order3
    assert np.allclose(om[-1], exact, rtol=2e-5)


def test_tip_mass_frequencies():
    g = BeamGeometry(length_m=0.18, EI_n_m2=0.38, rhoA_kg_m=0.157, mass_kg=0.05)
    mu = g.mass_kg / g.beam_mass_kg
    exact = tip_mass_roots(mu) ** 2 * omega_scale(g)
    fe = BeamFE(g, n_elements=96)
    assert np.allclose(fe.modes(4).omega_rad_s, exact, rtol=1e-6)


@pytest.mark.parametrize("use_rig", [True, False])
def test_intermediate_mass_with_rotary_inertia(use_rig):
    if use_rig:
        g = paper_rig()
    else:
        g = BeamGeometry(length_m=1.0, EI_n_m2=1.0, rhoA_kg_m=1.0, mass_kg=2.0,
                         rotary_inertia_kg_m2=0.01, mass_position_m=0.6, sensor_position_m=0.3)
    L, rA = g.length_m, g.rhoA_kg_m
    a, mu, j = g.mass_position_m / L, g.mass_kg / (rA * L), g.rotary_inertia_kg_m2 / (rA * L**3)
    b = _roots(lambda b: intermediate_mass_det(b, a, mu, j), 4, lo=0.2, hi=25.0, step=2e-3)
    exact = b**2 * omega_scale(g)
    fe = BeamFE(g, n_elements=48)
    assert np.allclose(fe.modes(4).omega_rad_s, exact, rtol=1e-6)
    # the rotary inertia matters (guards against J being dropped)
    fe0 = BeamFE(g.replace(rotary_inertia_kg_m2=0.0), n_elements=48)
    assert fe0.modes(2).omega_rad_s[1] > 1.01 * exact[1]


def test_contact_modes_interlace():
    """Rayleigh's constraint theorem: one constraint (w(L_m) = 0) gives
    f_i <= f_i^contact <= f_{i+1}."""
    fe = BeamFE(paper_rig(), n_elements=36)
    f = fe.modes(6).frequencies_hz
    fc = fe.contact_modes(5).frequencies_hz
    assert np.all(f[:5] <= fc + 1e-9) and np.all(fc <= f[1:6] + 1e-9)
    assert np.all(np.abs(fe.contact_row @ fe.contact_modes(5).shapes) < 1e-14)


def test_modes_normalisation_and_participation():
    g = paper_rig()
    fe = BeamFE(g, n_elements=18, refine=2)
    md = fe.modes()
    P = md.shapes
    assert np.allclose(P.T @ fe.M @ P, np.eye(fe.ndof), atol=1e-8)
    assert np.allclose(md.participation, P.T @ (-fe.base_load))
    # rigid influence vector: r^T M_full r = total mass (Hermite w-functions sum to 1)
    r_full = fe.expand(fe.r)
    r_full[fe.basis.nodal_dofs[0]] = 1.0
    assert math.isclose(r_full @ fe.M_full @ r_full, g.mass_kg + g.beam_mass_kg, rel_tol=1e-12)
    assert np.allclose(fe.K_full @ r_full, 0.0, atol=1e-9 * np.abs(fe.K).max())
    # sum of effective masses -> m + rhoA L from below, O(h)
    deficit = [(g.mass_kg + g.beam_mass_kg) - BeamFE(g, 9, refine=r).modes().effective_mass_kg.sum()
               for r in (1, 2, 3)]
    assert deficit[0] > deficit[1] > deficit[2] > 0
    # each refinement bisects every element (h -> h/2): a first-order deficit halves; measured 2 to
    # 1e-11 on both pairs, so 1e-8 leaves room for round-off and fails on any other rate
    assert deficit[0] / deficit[1] == pytest.approx(2.0, rel=1e-8)
    assert deficit[1] / deficit[2] == pytest.approx(2.0, rel=1e-8)


def test_damping_matrices():
    g = paper_rig()
    fe = BeamFE(g, 12, damping_D_s=1e-3)
    assert np.allclose(fe.C, 1e-3 * fe.K)
    fe2 = BeamFE(g, 12, damping_D_s=1e-3, rayleigh_alpha_1_s=0.5)
    assert np.allclose(fe2.C, 0.5 * fe2.M + 1e-3 * fe2.K)
    with pytest.raises(ValueError):
        BeamFE(g, 12, damping_D_s=-1.0)


# ----------------------------------------------------------------- statics
def _cantilever_point_load(X, a, P, EI):
    X = np.asarray(X)
    return np.where(X <= a, P * X**2 * (3 * a - X), P * a**2 * (3 * X - a)) / (6 * EI)


def test_static_deflection_closed_form():
    g = paper_rig()
    fe = BeamFE(g, n_elements=18)
    X = np.linspace(0, g.length_m, 97)
    u = fe.static_deflection(force_n=2.5)
    assert np.allclose(fe.deflection(u, X), _cantilever_point_load(X, g.mass_position_m, 2.5, g.EI_n_m2),
                       rtol=1e-10, atol=1e-14)
    # load off the nodes: nodal values still exact (Green's function in the FE space)
    a = 0.0517
    u = fe.static_deflection(a)
    nodes = fe.mesh.p[0]
    assert not np.any(np.isclose(nodes, a))
    assert np.allclose(fe.deflection(u, nodes), _cantilever_point_load(nodes, a, 1.0, g.EI_n_m2),
                       rtol=1e-9, atol=1e-15)
    # tip stiffness 3EI/L_m^3 at the mass
    assert math.isclose(fe.contact_row @ fe.static_deflection(), g.mass_position_m**3 / (3 * g.EI_n_m2),
                        rel_tol=1e-10)


def test_mesh_has_nodes_at_sensor_and_mass():
    g = paper_rig()
    for r in (0, 2):
        fe = BeamFE(g, n_elements=7, refine=r)
        p = fe.mesh.p[0]
        assert np.any(p == g.sensor_position_m) and np.any(p == g.mass_position_m)
        assert np.allclose(fe.sensor_row, np.eye(fe.ndof)[np.argmax(fe.sensor_row)], rtol=0, atol=1e-15)


# ----------------------------------------------------------------- calibration, io
def test_calibration_reproduces_targets():
    g = paper_rig()
    cal = calibrate(g, 7.6, 98.75, n_elements=36)
    f = BeamFE(cal.geometry, n_elements=36).modes(2).frequencies_hz
    assert np.allclose(f, [7.6, 98.75], rtol=1e-7)
    assert cal.EI_n_m2 > 0 and cal.rotary_inertia_kg_m2 > 0
    # EI only
    cal1 = calibrate(g, 8.0, None, n_elements=36)
    assert math.isclose(BeamFE(cal1.geometry, 36).modes(1).frequencies_hz[0], 8.0, rel_tol=1e-9)
    assert cal1.rotary_inertia_kg_m2 == g.rotary_inertia_kg_m2
    with pytest.raises(ValueError):
        calibrate(g, 7.6, 7.6 * 1e3)       # ratio not reachable with J >= 0


def test_disc_stack_and_geometry_validation():
    m, J = disc_stack(4, 0.007, 0.035)
    assert math.isclose(m, 7850 * math.pi * 0.0175**2 * 0.028, rel_tol=1e-12)
    assert math.isclose(J, 0.5 * m * 0.0175**2, rel_tol=1e-12)
    _, Jt = disc_stack(4, 0.007, 0.035, axis="transverse")
    assert math.isclose(Jt, m * (3 * 0.0175**2 + 0.028**2) / 12, rel_tol=1e-12)
    with pytest.raises(ValueError):
        disc_stack(4, 0.007, 0.035, axis="diagonal")
    with pytest.raises(ValueError):
        BeamGeometry(length_m=0.18, EI_n_m2=1.0, rhoA_kg_m=0.1, mass_position_m=0.2)
    g = BeamGeometry.from_section(0.18, 0.02, 0.001)
    assert math.isclose(g.EI_n_m2, 200e9 * 0.02 * 1e-9 / 12) and math.isclose(g.rhoA_kg_m, 0.157)


def test_write_modes_roundtrip(tmp_path):
    meshio = pytest.importorskip("meshio")
    fe = BeamFE(paper_rig(), n_elements=12)
    path = write_modes(tmp_path / "modes.vtu", fe, n=3)
    m = meshio.read(path)
    md = fe.modes(3)
    full = fe.expand(md.shapes)
    assert np.allclose(m.points[:, 0], fe.mesh.p[0])
    assert np.allclose(m.point_data["mode_2_w"], full[fe.basis.nodal_dofs[0], 1])
    i_s = np.argmin(np.abs(fe.mesh.p[0] - fe.geometry.sensor_position_m))
    assert math.isclose(m.point_data["static_mode_w"][i_s], 1.0)


def test_a_shared_fe_model_is_the_model_its_arguments_build():
    """shared_fe and shared_calibration (what a scene rebuilt for a map, a continuation's finite
    differences or a fit reuses): the same arguments give the same object, and it holds exactly
    the matrices, rows and modes of a model built anew (bit for bit: the same assembly); other
    arguments give another model."""
    g = paper_rig()
    a = shared_fe(g, n_elements=12, damping_D_s=1e-4)
    assert shared_fe(g, n_elements=12, damping_D_s=1e-4) is a
    b = BeamFE(g, n_elements=12, damping_D_s=1e-4)
    for k in ("K", "M", "C", "M_beam", "r", "base_load", "contact_row", "sensor_row"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    np.testing.assert_array_equal(a.modes(3).shapes, b.modes(3).shapes)
    c = shared_fe(g, n_elements=12, damping_D_s=2e-4)
    assert c is not a and np.array_equal(c.K, a.K) and not np.array_equal(c.C, a.C)
    cal = shared_calibration(g, 7.6, 98.75, n_elements=12)
    assert shared_calibration(g, 7.6, 98.75, n_elements=12) is cal
    ref = calibrate(g, 7.6, 98.75, n_elements=12)
    assert (cal.EI_n_m2, cal.rotary_inertia_kg_m2, cal.geometry) == (ref.EI_n_m2, ref.rotary_inertia_kg_m2, ref.geometry)
