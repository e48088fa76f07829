"""Single assumed static mode: the beam -> SDOF reduction of paper Eqs. 42-47.

Derivation and units (paper Sec. 6).  Eq. 39 with ``U = u L``, ``X = x L`` and the
one-term Galerkin ansatz ``u(x, t) = phi(x) q(t)`` (Eq. 42, ``N = 1``): multiply by
``phi(X/L)``, integrate over ``0 <= X <= L`` (``dX = L dx``) and use
``d/dX = (1/L) d/dx``, ``delta(X - L_m) = delta(x - x_m) / L``:

* inertia: ``L [m phi(x_m)^2 + rhoA L int_0^1 phi^2 dx] q''``
* stiffness: ``EI int_0^L U'''' phi dX = L (EI / L^3) int_0^1 (phi_xx)^2 dx q``
  (integration by parts with Eq. 40 and ``phi(0) = phi'(0) = 0``)
* base load ``(rhoA + m delta) (-b'')``: ``[m phi(x_m) + rhoA L int_0^1 phi dx] (-b'')``.

Dividing by ``L``::

    M_S q'' + D K_S q' + K_S q = -(m phi(x_m) + rhoA L int phi) b'' / L

with ``M_S = m phi(x_m)^2`` [kg] (Eq. 45; the paper neglects the beam term
``rhoA L int phi^2``, assumption ``m >> rhoA L``) and ``K_S = EI/L^3 int_0^1 phi_xx^2 dx``
[N m^2 / m^3 = N/m] (Eq. 46), so ``omega_n^2 = K_S / M_S`` is in 1/s^2.  ``q`` is
dimensionless.  With ``t = omega_n t~`` and ``b = gamma~ V sin(Omega~ t~)`` (Eq. 38)
this is Eq. 43, ``q'' + 2 beta_S q' + q = gamma V Omega^2 sin(Omega t)``, with
``beta_S = D omega_n / 2`` (Eq. 44) and ``gamma = gamma~ / (phi(x_m) L)`` (Eq. 46;
``gamma~`` in m/V, ``gamma`` in 1/V).  The contact condition ``U(L_m) = Delta_C``
becomes ``q = Delta_C / (L phi(x_m)) = Delta_G / L = Delta`` (Eq. 45), where
``Delta_G = Delta_C / phi(x_m)`` is the gap measured at the sensor
(``U(L_S) = q L`` because ``phi(x_S) = 1``).

The static mode (deflection under a point load at ``x_m``, Euler-Bernoulli)::

    y(x) = x^2 (3 x_m - x) / 6      x <= x_m
    y(x) = x_m^2 (3 x - x_m) / 6    x >= x_m          phi = y / y(x_S)

so ``int_0^1 phi_xx^2 dx = x_m^3 / (3 y(x_S)^2)`` and ``omega_n^2 = 3 EI / (m L_m^3)``
exactly (the static stiffness at the mass over ``m``) when the beam mass is excluded.

References
----------
Paper Sec. 6, Eqs. 38-47; S. Timoshenko, J. Gere, *Mechanics of Materials*
(cantilever point-load deflection).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import Polynomial

from vibeam.models.builders.beam_fe import BeamFE, BeamGeometry

__all__ = [
    "StaticModeReduction",
    "static_mode_shape",
    "static_mode_curvature",
    "static_mode_fe",
    "static_mode_mismatch",
    "check_static_mode",
    "reduce_static_mode",
]


def _raw(x, xm):
    x = np.asarray(x, dtype=float)
    return np.where(x <= xm, x**2 * (3 * xm - x) / 6.0, xm**2 * (3 * x - xm) / 6.0)


def static_mode_shape(x, x_m: float, x_s: float) -> np.ndarray:
    """Closed-form static mode ``phi(x)`` (nondimensional, ``phi(x_s) = 1``).

    Parameters
    ----------
    x : array_like
        Nondimensional positions ``X / L`` in ``[0, 1]``.
    x_m, x_s : float
        ``L_m / L`` and ``L_S / L`` in ``(0, 1]``.

    Returns
    -------
    ndarray, same shape as ``x``

    Raises
    ------
    ValueError
        If ``x_m`` or ``x_s`` is outside ``(0, 1]``.
    """
    if not (0 < x_m <= 1 and 0 < x_s <= 1):
        raise ValueError("x_m and x_s must lie in (0, 1]")
    return _raw(x, x_m) / float(_raw(x_s, x_m))


def static_mode_curvature(x, x_m: float, x_s: float) -> np.ndarray:
    """``phi_xx(x)`` of :func:`static_mode_shape` (nondimensional)."""
    x = np.asarray(x, dtype=float)
    return np.where(x <= x_m, x_m - x, 0.0) / float(_raw(x_s, x_m))


def _integrals(x_m, x_s):
    """Exact ``int phi``, ``int phi^2``, ``int phi_xx^2`` over ``[0, 1]``."""
    c = float(_raw(x_s, x_m))
    p1 = Polynomial([0, 0, 3 * x_m, -1]) / (6 * c)
    p2 = Polynomial([-x_m**3, 3 * x_m**2]) / (6 * c)
    I1 = p1.integ()(x_m) + p2.integ()(1.0) - p2.integ()(x_m)
    I2 = (p1**2).integ()(x_m) + (p2**2).integ()(1.0) - (p2**2).integ()(x_m)
    Ik = x_m**3 / (3 * c**2)
    return float(I1), float(I2), float(Ik)


@dataclass(frozen=True)
class StaticModeReduction:
    """SDOF parameters of the rig from the static assumed mode (paper Eqs. 42-47).

    Attributes
    ----------
    length_m : float
        ``L`` (normalising length, ``U = u L``, ``X = x L``).
    x_m, x_s : float
        ``L_m / L``, ``L_S / L``.
    phi_at_mass : float
        ``phi(x_m)`` (>1 when ``L_m > L_S``), with ``phi(x_s) = 1``.
    int_phi, int_phi2, int_phi_xx2 : float
        ``int_0^1 phi dx``, ``int_0^1 phi^2 dx``, ``int_0^1 phi_xx^2 dx``.
    beam_modal_mass_kg : float
        ``rhoA L int phi^2`` (neglected by the paper).
    includes_beam_mass : bool
        Whether ``M_S_kg`` includes ``beam_modal_mass_kg``.
    M_S_kg : float
        ``m phi(x_m)^2`` [+ beam term] (Eq. 45).
    K_S_n_m : float
        ``EI / L^3 int phi_xx^2`` (Eq. 46).
    omega_n_rad_s, f_n_hz : float
        ``sqrt(K_S / M_S)`` (Eq. 45) and ``omega_n / 2 pi``.
    D_s : float
        Stiffness-proportional damping coefficient of Eq. 39.
    beta_S : float
        ``D omega_n / 2`` (Eq. 44).
    load_coefficient_per_m : float
        Modal base-acceleration coefficient ``(m phi(x_m) [+ rhoA L int phi]) / (M_S L)``
        (= ``1 / (phi(x_m) L)`` without beam mass).
    gamma_tilde_m_per_V, gamma_per_V : float or None
        Unit-conversion gain of Eq. 38 and ``gamma = gamma~ load_coefficient``
        (= ``gamma~ / (phi(x_m) L)``, Eq. 46).
    Delta_C_m : float
        Gap at the stop (``U(L_m)`` at contact; negative = pre-stressed).
    Delta_G_m : float
        Grazing gap seen by the sensor, ``Delta_C / phi(x_m)``.
    Delta : float
        ``Delta_G / L`` (Eq. 45).
    """

    length_m: float
    x_m: float
    x_s: float
    phi_at_mass: float
    int_phi: float
    int_phi2: float
    int_phi_xx2: float
    beam_modal_mass_kg: float
    includes_beam_mass: bool
    M_S_kg: float
    K_S_n_m: float
    omega_n_rad_s: float
    f_n_hz: float
    D_s: float
    beta_S: float
    load_coefficient_per_m: float
    gamma_tilde_m_per_V: float | None
    gamma_per_V: float | None
    Delta_C_m: float
    Delta_G_m: float
    Delta: float

    def phi(self, x) -> np.ndarray:
        """``phi(x)`` at nondimensional positions ``x`` (closed form)."""
        return static_mode_shape(x, self.x_m, self.x_s)


def reduce_static_mode(geometry: BeamGeometry, damping_D_s: float = 0.0,
                       gap_contact_m: float | None = None, grazing_gap_m: float | None = None,
                       gamma_tilde_m_per_V: float | None = None,
                       include_beam_mass: bool = False) -> StaticModeReduction:
    """Reduce the beam to the SDOF of paper Eq. 43 with the static assumed mode.

    Parameters
    ----------
    geometry : BeamGeometry
        ``L``, ``EI``, ``rhoA``, ``m``, ``L_m``, ``L_S`` (``J`` plays no role: the static
        mode's rotation at ``L_m`` is not included in the paper's ``M_S``).
    damping_D_s : float
        ``D`` of Eq. 39 (s).
    gap_contact_m, grazing_gap_m : float or None
        Give at most one: the gap at the stop ``Delta_C`` or the sensor grazing gap
        ``Delta_G``; default 0.
    gamma_tilde_m_per_V : float or None
        Gain of Eq. 38.
    include_beam_mass : bool
        Add ``rhoA L int phi^2`` to ``M_S`` (and ``rhoA L int phi`` to the load).

    Returns
    -------
    StaticModeReduction

    Raises
    ------
    ValueError
        If both gaps are given, ``m = 0`` without ``include_beam_mass``, or ``D < 0``.
    """
    if gap_contact_m is not None and grazing_gap_m is not None:
        raise ValueError("give gap_contact_m or grazing_gap_m, not both")
    if damping_D_s < 0:
        raise ValueError("damping_D_s must be >= 0")
    g = geometry
    L = g.length_m
    xm, xs = g.mass_position_m / L, g.sensor_position_m / L
    phim = float(static_mode_shape(xm, xm, xs))
    I1, I2, Ik = _integrals(xm, xs)
    beam_mass = g.rhoA_kg_m * L * I2
    M_S = g.mass_kg * phim**2 + (beam_mass if include_beam_mass else 0.0)
    if M_S <= 0:
        raise ValueError("M_S = 0: no attached mass and beam mass excluded")
    K_S = g.EI_n_m2 / L**3 * Ik
    om = math.sqrt(K_S / M_S)
    load = (g.mass_kg * phim + (g.rhoA_kg_m * L * I1 if include_beam_mass else 0.0)) / (M_S * L)
    if grazing_gap_m is not None:
        DG = float(grazing_gap_m)
        DC = DG * phim
    else:
        DC = 0.0 if gap_contact_m is None else float(gap_contact_m)
        DG = DC / phim
    gam = None if gamma_tilde_m_per_V is None else gamma_tilde_m_per_V * load
    return StaticModeReduction(
        length_m=L, x_m=xm, x_s=xs, phi_at_mass=phim, int_phi=I1, int_phi2=I2, int_phi_xx2=Ik,
        beam_modal_mass_kg=beam_mass, includes_beam_mass=include_beam_mass, M_S_kg=M_S,
        K_S_n_m=K_S, omega_n_rad_s=om, f_n_hz=om / (2 * math.pi), D_s=float(damping_D_s),
        beta_S=0.5 * damping_D_s * om, load_coefficient_per_m=load,
        gamma_tilde_m_per_V=gamma_tilde_m_per_V, gamma_per_V=gam,
        Delta_C_m=DC, Delta_G_m=DG, Delta=DG / L)


def static_mode_fe(fe: BeamFE, x) -> np.ndarray:
    """Static mode from the FE model: ``K u = N(L_m)``, normalised to 1 at ``L_S``.

    Parameters
    ----------
    fe : BeamFE
    x : array_like, shape (k,)
        Nondimensional positions ``X / L``.

    Returns
    -------
    ndarray, shape (k,)
    """
    g = fe.geometry
    u = fe.static_deflection(g.mass_position_m)
    return fe.deflection(u, np.asarray(x, dtype=float) * g.length_m) / (fe.sensor_row @ u)


def static_mode_mismatch(fe: BeamFE, n_points: int = 181) -> float:
    """Max ``|phi_FE - phi_closed|`` over ``n_points`` equispaced ``x`` in ``[0, 1]``.

    Cubic Hermite elements with a node at ``L_m`` reproduce the piecewise-cubic static
    deflection exactly, so this is at round-off level.
    """
    g = fe.geometry
    x = np.linspace(0.0, 1.0, n_points)
    ref = static_mode_shape(x, g.mass_position_m / g.length_m, g.sensor_position_m / g.length_m)
    return float(np.max(np.abs(static_mode_fe(fe, x) - ref)))


def check_static_mode(fe: BeamFE, atol: float = 1e-9, n_points: int = 181) -> float:
    """Verify that the FE and closed-form static modes agree.

    Returns
    -------
    float
        The mismatch of :func:`static_mode_mismatch`.

    Raises
    ------
    AssertionError
        If the mismatch exceeds ``atol``.
    """
    err = static_mode_mismatch(fe, n_points)
    if not err <= atol:
        raise AssertionError(f"FE static mode differs from the closed form by {err:.3e} > {atol:.1e}")
    return err
