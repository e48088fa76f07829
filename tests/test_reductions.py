"""Tests of the static-mode SDOF reduction (paper Eqs. 42-47) and modal truncation."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from vibeam.models.builders.beam_fe import BeamFE, BeamGeometry, paper_rig
from vibeam.reductions.modal import contact_effective_mass_kg, modal_reduction
from vibeam.reductions.static_mode import (check_static_mode, reduce_static_mode,
                                           static_mode_curvature, static_mode_fe,
                                           static_mode_mismatch, static_mode_shape)


def _closed_form_deflection(X, a, EI=1.0, P=1.0):
    X = np.asarray(X, dtype=float)
    return np.where(X <= a, P * X**2 * (3 * a - X), P * a**2 * (3 * X - a)) / (6 * EI)


@pytest.mark.parametrize("LS,Lm", [(0.100, 0.132), (0.150, 0.090), (0.180, 0.180)])
def test_static_mode_closed_form_and_fe_agree(LS, Lm):
    g = BeamGeometry(length_m=0.18, EI_n_m2=0.38, rhoA_kg_m=0.157, mass_kg=0.2,
                     mass_position_m=Lm, sensor_position_m=LS)
    xm, xs = Lm / 0.18, LS / 0.18
    x = np.linspace(0, 1, 101)
    phi = static_mode_shape(x, xm, xs)
    assert math.isclose(float(static_mode_shape(xs, xm, xs)), 1.0)
    # phi is the Euler-Bernoulli point-load deflection (in metres) up to a factor
    ref = _closed_form_deflection(x * 0.18, Lm)
    assert np.allclose(phi, ref / float(_closed_form_deflection(LS, Lm)), rtol=1e-12)
    # curvature: finite differences of phi
    h = 1e-4
    xi = np.array([0.2, 0.45, 0.9]) * xm
    fd = (static_mode_shape(xi + h, xm, xs) - 2 * static_mode_shape(xi, xm, xs)
          + static_mode_shape(xi - h, xm, xs)) / h**2
    assert np.allclose(static_mode_curvature(xi, xm, xs), fd, rtol=1e-5)
    fe = BeamFE(g, n_elements=18)
    assert check_static_mode(fe) < 1e-9
    assert np.allclose(static_mode_fe(fe, x), phi, atol=1e-10)


def test_static_mode_mismatch_detects_wrong_mode():
    """The checker can fail: an FE model normalised at a different sensor position
    (L_S = 0.120 m) than the closed form (L_S = 0.100 m)."""
    g = paper_rig()
    fe = BeamFE(g.replace(sensor_position_m=0.120), n_elements=18)
    fe.geometry = g                    # closed form uses L_S = 0.100, FE rows 0.120
    assert static_mode_mismatch(fe) > 1e-2
    with pytest.raises(AssertionError):
        check_static_mode(fe)


def test_reduction_parameters_and_units():
    g = paper_rig()
    D = 7.1e-4
    gt = 2.0e-3
    red = reduce_static_mode(g, damping_D_s=D, gap_contact_m=1.0e-4, gamma_tilde_m_per_V=gt)
    L, xm, xs = g.length_m, g.mass_position_m / g.length_m, g.sensor_position_m / g.length_m
    # integrals against adaptive quadrature of the closed form
    I2 = quad(lambda x: float(static_mode_shape(x, xm, xs)) ** 2, 0, 1, points=[xm])[0]
    Ik = quad(lambda x: float(static_mode_curvature(x, xm, xs)) ** 2, 0, 1, points=[xm])[0]
    I1 = quad(lambda x: float(static_mode_shape(x, xm, xs)), 0, 1, points=[xm])[0]
    assert math.isclose(red.int_phi2, I2, rel_tol=1e-10)
    assert math.isclose(red.int_phi_xx2, Ik, rel_tol=1e-10)
    assert math.isclose(red.int_phi, I1, rel_tol=1e-10)
    # Eq. 45-46 and the unit check: K_S [N/m] equals the static stiffness at the mass
    # divided by phi(x_m)^2 ... i.e. omega_n^2 = 3 EI / (m L_m^3) exactly
    phim = red.phi_at_mass
    assert math.isclose(red.M_S_kg, g.mass_kg * phim**2)
    assert math.isclose(red.K_S_n_m, g.EI_n_m2 / L**3 * Ik)
    assert math.isclose(red.K_S_n_m, 3 * g.EI_n_m2 / g.mass_position_m**3 * phim**2, rel_tol=1e-12)
    assert math.isclose(red.omega_n_rad_s**2, 3 * g.EI_n_m2 / (g.mass_kg * g.mass_position_m**3),
                        rel_tol=1e-12)
    assert math.isclose(red.f_n_hz, red.omega_n_rad_s / (2 * math.pi))
    assert math.isclose(red.beta_S, D * red.omega_n_rad_s / 2)                     # Eq. 44
    assert math.isclose(red.gamma_per_V, gt / (phim * L))                           # Eq. 46
    assert math.isclose(red.Delta_G_m, 1.0e-4 / phim)
    assert math.isclose(red.Delta, red.Delta_G_m / L)                               # Eq. 45
    red2 = reduce_static_mode(g, grazing_gap_m=red.Delta_G_m)
    assert math.isclose(red2.Delta_C_m, 1.0e-4)
    with pytest.raises(ValueError):
        reduce_static_mode(g, gap_contact_m=1e-4, grazing_gap_m=1e-4)
    # with beam mass: M_S grows by rhoA L int phi^2
    redb = reduce_static_mode(g, include_beam_mass=True)
    assert math.isclose(redb.M_S_kg - red.M_S_kg, g.rhoA_kg_m * L * I2)


@pytest.mark.parametrize("mu", [7.0, 100.0, 1000.0])
def test_reduced_frequency_vs_fe_first_mode(mu):
    """With J = 0 the static mode lies in the FE space (node at L_m), so its Rayleigh
    quotient with the beam mass included is an upper bound of the FE omega_1 and is
    very close to it (static mode ~ first mode).  Excluding the beam mass (paper,
    m >> rhoA L) raises the estimate by the factor sqrt(1 + eps),
    eps = rhoA L int phi^2 / (m phi(x_m)^2) ~ 0.61 / mu here; so
    omega_n / omega_1 - 1 = sqrt(1 + eps) - 1 (+ a Rayleigh error < 1e-4), i.e. 4.3 %
    for the rig's mu ~ 7, 0.3 % for mu = 100 and 0.03 % for mu = 1000."""
    g0 = paper_rig()
    g = g0.replace(rotary_inertia_kg_m2=0.0, mass_kg=mu * g0.beam_mass_kg)
    f1 = BeamFE(g, n_elements=36).modes(1).frequencies_hz[0]
    red = reduce_static_mode(g)
    redb = reduce_static_mode(g, include_beam_mass=True)
    assert redb.f_n_hz >= f1 * (1 - 1e-12)                    # Rayleigh upper bound
    assert redb.f_n_hz / f1 - 1 < 1e-3
    eps = red.beam_modal_mass_kg / red.M_S_kg
    assert red.f_n_hz > redb.f_n_hz
    assert abs((red.f_n_hz / f1 - 1) - (math.sqrt(1 + eps) - 1)) < 1e-4
    if mu >= 1000:
        assert math.isclose(red.f_n_hz, f1, rel_tol=5e-4)


def test_modal_reduction_matrices():
    D = 1e-3
    fe = BeamFE(paper_rig(), n_elements=18, damping_D_s=D)
    red = modal_reduction(fe, 5)
    om = red.omega_rad_s
    assert np.allclose(red.M, np.eye(5))
    assert np.allclose(red.K, np.diag(om**2))
    assert np.allclose(red.C, D * np.diag(om**2), atol=1e-9 * om[-1] ** 2 * D)
    md = fe.modes(5)
    assert np.allclose(red.load, -md.participation)
    assert np.allclose(red.contact_row, fe.contact_row @ md.shapes)
    assert np.allclose(red.sensor_row, fe.sensor_row @ md.shapes)
    # first mode ~ static mode: phi_1(L_m)/phi_1(L_S) close to phi(x_m)
    r1 = modal_reduction(fe, 1)
    ratio = r1.contact_row[0] / r1.sensor_row[0]
    assert math.isclose(ratio, reduce_static_mode(fe.geometry).phi_at_mass, rel_tol=0.02)
    full = modal_reduction(fe, "all")
    assert full.n_modes == fe.ndof
    P = full.shapes
    assert np.allclose(P @ P.T @ fe.M, np.eye(fe.ndof), atol=1e-7)      # M^-1 = Phi Phi^T
    with pytest.raises(ValueError):
        modal_reduction(fe, 0)
    with pytest.raises(ValueError):
        modal_reduction(fe, "most")


def test_contact_effective_mass_truncation_and_mesh_convergence():
    """m_eff(N) = 1 / sum_{i<=N} (w^T phi_i)^2 DEcreases monotonically with N (each
    mode adds a non-negative term) to the full-model 1/(w^T M^-1 w); under mesh
    refinement that value tends to the attached mass m from above, m_eff - m = O(h)
    (the Euler-Bernoulli continuum has w^T M_beam^-1 w -> infinity: a point impulse
    only sees the rigid body at the node; J sits on the slope DOF and drops out)."""
    g = paper_rig()
    fe = BeamFE(g, n_elements=18)
    meff = np.array([contact_effective_mass_kg(fe, n) for n in range(1, fe.ndof + 1)])
    assert np.all(np.diff(meff) <= 1e-12 * meff[0])
    direct = 1.0 / (fe.contact_row @ np.linalg.solve(fe.M, fe.contact_row))
    assert math.isclose(meff[-1], direct, rel_tol=1e-9)
    assert math.isclose(contact_effective_mass_kg(fe, "all"), fe.contact_effective_mass_kg(), rel_tol=1e-9)
    assert math.isclose(modal_reduction(fe, 3).contact_effective_mass_kg, meff[2])
    # first-mode value: modal mass of mode 1 at the contact, > m
    assert meff[0] > 1.05 * g.mass_kg
    # mesh refinement: m_eff -> m from above at first order
    ex = np.array([BeamFE(g, 9, refine=r).contact_effective_mass_kg() - g.mass_kg for r in range(4)])
    assert np.all(ex > 0)
    assert np.all((ex[:-1] / ex[1:] > 1.8) & (ex[:-1] / ex[1:] < 2.2)), ex[:-1] / ex[1:]
    assert ex[-1] < 2e-3 * g.mass_kg
    # J does not change the limit (only the rate)
    exJ0 = BeamFE(g.replace(rotary_inertia_kg_m2=0.0), 9, refine=3).contact_effective_mass_kg() - g.mass_kg
    assert 0 < exJ0 < 2e-3 * g.mass_kg
