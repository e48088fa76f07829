"""The one linear dynamical system of vibeam: a base-excited, proportionally damped modal system.

Every fidelity of vibeam is, between contacts, the same linear system in ``n`` decoupled modal
coordinates ``eta_i`` (issue 20, "one dynamical system")::

    eta_i'' + c_i eta_i' + omega_i^2 eta_i = Gamma_i Omega^2 B sin(Omega t),   i = 1..n

in the nondimensional time ``t`` (one unit is :attr:`ModalSystem.time_unit_s` seconds), with the
sensor reading ``y = s^T eta`` and the contact points ``u_k = W[k] @ eta`` (the rows that the
stops' relations reference by index).  Here ``c_i = 2 zeta_i omega_i`` (modal, i.e. proportional
damping), ``Gamma_i`` the base-excitation participation factor and ``B`` the base displacement
amplitude ``b = B sin(Omega t)``: the load ``-M r b''`` of the physical model becomes
``Gamma Omega^2 B sin(Omega t)`` in the modes.  The other drives (a base acceleration, a point
force) give ``f A sin(Omega t)`` instead: ``Gamma Omega^2 B`` is generalised to ``f Omega^p A``
(:attr:`ModalSystem.drive_power`, :func:`forcing`), ``p = 2`` being the displacement drive.

* The paper's SDOF (Eqs. 43-47; the scene of :func:`vibeam.models.builders.sdof.sdof`) is the
  one-mode case ``omega = 1``, ``c = 2 beta``, ``Gamma = s = W = 1``: :func:`sdof_system`.
* The FE cantilever (Eqs. 39-42; modes of :class:`vibeam.models.builders.beam_fe.BeamFE`) is the ``N``-mode
  case in its own kernel units: :func:`vibeam.models.builders.beam.fe_beam` (through
  :func:`vibeam.models.builders.matrices.modal_scene`).
* A lumped ``n``-DOF model ``M x'' + C x' + K x = -M r b''`` reduces to it by the generalized
  eigenproblem ``K phi = omega^2 M phi`` when ``C`` is classical (Caughey):
  :func:`vibeam.models.builders.matrices.build_matrices`.

Between contacts the motion is known in closed form (paper Eq. 28 for one mode; e.g.
Meirovitch, *Fundamentals of Vibrations*, McGraw-Hill 2001, Ch. 4 and 7, for the modal
superposition of a proportionally damped system): per mode the homogeneous part moves by its
2 x 2 transition matrix (under-, critically or over-damped) and the harmonic particular part is
``a_i sin(Omega t) + b_i cos(Omega t)``.  This module holds the one implementation of that flow:
the numba kernels :func:`transition_increment` (``Phi - I``, used by the event kernels),
:func:`transition_entries` (``Phi`` to relative precision, used by the shooting problems) and
:func:`advance_modes`, their table :func:`mode_table` and :func:`particular`, and the Python entry
points :func:`modal_flow` (the state after a free flight) and :func:`modal_transition` (its
``2n x 2n`` state-transition matrix).  It imports nothing of vibeam.

Units
    Nondimensional time ``t = t~ / time_unit_s``; ``omega`` and ``damping`` are per unit of ``t``,
    ``Omega`` the forcing frequency in the same unit.  Lengths: the rows ``s``, ``W`` give
    displacements in the system's *row unit* (the SDOF: ``q``, multiples of ``L``; the beam and a
    lumped model: metres), ``B`` and the stops' gaps are in that unit too; the reported
    nondimensional displacement is ``q = (row @ eta) / coordinate_scale`` and
    ``q * length_unit_m`` is metres.

References
----------
.. [1] Paper: Reboucas, Santos & Thomsen, JSV 2019, Eqs. 28, 39-47
   (``/work/shared/paper/000_db9366990d60f12d.txt``).
.. [2] L. Meirovitch, *Fundamentals of Vibrations*, McGraw-Hill 2001 (modal analysis of
   proportionally damped systems, base excitation, state-transition matrix).
.. [3] T. K. Caughey, M. E. J. O'Kelly, Classical normal modes in damped linear dynamic systems,
   J. Appl. Mech. 32 (1965) 583-588 (when a damping matrix is diagonalised by the undamped modes).
"""
from __future__ import annotations

import math
from typing import NamedTuple, Optional

import numpy as np
import scipy.linalg
from numba import njit

TWO_PI = 2.0 * math.pi

__all__ = ["ModalSystem", "modal_system", "sdof_system", "modal_flow", "forcing",
           "DRIVE_POWERS", "drive_force", "drive_slope", "drive_displacement", "drive_velocity_slope",
           "modal_transition", "damping_ratios", "lowest_modes", "mode_table", "particular",
           "transition_increment", "increment_of", "transition_entries", "advance_modes", "advance_count",
           "reference_hz"]


#: the drive exponents ``p`` of ``F(Omega) = Omega^p A`` (:attr:`ModalSystem.drive_power`): 2, a base
#: displacement; 0, a base acceleration or a force of fixed amplitude
DRIVE_POWERS = (0, 2)


class ModalSystem(NamedTuple):
    """A harmonically driven linear system in ``n`` decoupled modal coordinates (plain data).

    ``eta_i'' + damping_i eta_i' + omega_i^2 eta_i = participation_i Omega^p base_amplitude
    sin(Omega t)`` with ``p = drive_power``: the forcing vector ``f = participation`` times the
    forcing amplitude ``F(Omega) = Omega^p A`` (:func:`forcing`), ``A = base_amplitude``.  As built
    (:func:`sdof_system`, :func:`vibeam.models.builders.matrices.modal_scene`) the
    drive is the paper's base displacement, ``f = Gamma``, ``A = B``, ``p = 2``; :func:`vibeam.models.scene.driven` sets a base
    acceleration (``f = Gamma``, ``p = 0``) or a point force (``f = W[j]``, ``p = 0``).  A
    ``typing.NamedTuple`` of float64 arrays and numbers, so numba kernels take it as an argument (no
    methods, no behaviour).

    Attributes
    ----------
    omega : ndarray, shape (n,)
        Modal circular frequencies ``omega_i >= 0`` per unit nondimensional time (the SDOF: 1;
        the beam: ``omega_i / omega_ref``).
    damping : ndarray, shape (n,)
        Modal damping *coefficients* ``c_i = 2 zeta_i omega_i >= 0`` per unit time, the
        coefficient of ``eta_i'`` (not the ratios ``zeta_i``: :func:`damping_ratios`).  The SDOF:
        ``2 beta``; the beam: ``(alpha + D omega_i^2) / omega_ref`` (Rayleigh, Eq. 39's ``D EI
        U''''`` for ``alpha = 0``) or its per-mode ``modal_damping_1_s / omega_ref``.
    participation : ndarray, shape (n,)
        The forcing vector ``f``: for a base drive the base-excitation participation ``Gamma_i =
        phi_i^T M r`` (the beam: sqrt(kg); the SDOF: 1), for a point force the forced row ``W[j]``.
    sensor : ndarray, shape (n,)
        Sensor row ``s``: the sensor displacement is ``s @ eta`` (row unit; the beam: 1/sqrt(kg),
        giving metres).
    contacts : ndarray, shape (n_c, n)
        Contact rows ``W``: ``W[k] @ eta`` is the displacement of contact point ``k`` (row unit).
        A stop's relation references a row by its index ``k``, with its own side and gap.  The
        SDOF and the beam have one (the sensor's coordinate; the attached mass at ``L_m``).
    base_amplitude : float
        The drive's amplitude ``A`` in system units.  A base displacement (``p = 2``): ``B`` in the
        row unit (the SDOF: ``B = gamma V``, Eq. 43; the beam: ``Y = gamma~ V`` in metres, Eq. 38),
        the forcing of mode ``i`` ``Gamma_i Omega^2 B sin(Omega t)``.  With ``p = 0`` the forcing
        is ``f_i A sin(Omega t)`` (a base acceleration ``a``: ``A = a time_unit_s^2 / row unit``;
        a force ``F0``: ``A = F0 time_unit_s^2 / (mass_unit_kg row unit)``, the row unit being
        ``length_unit_m / coordinate_scale`` metres; :func:`vibeam.models.scene.driven`).
    time_unit_s : float
        Seconds per unit of ``t``: ``1 / (2 pi f_ref)`` (the SDOF: ``f_n``; the beam: ``f_ref``);
        NaN for a nondimensional scene.
    length_unit_m : float
        Metres per unit of the reported displacement ``q`` (the paper's normalising length ``L``);
        NaN for a nondimensional scene.
    coordinate_scale : float
        Row value per unit of ``q``: ``q = (row @ eta) / coordinate_scale``.  The SDOF: 1 (its
        coordinate is ``q``); the beam: ``L`` (its rows give metres, its modal coordinates are
        sqrt(kg) m, and it reports ``q = U / L``).  ``coordinate_scale / |W[k]|`` is the scale of
        the shooting problems' states (the beam's ``state_scale = L sqrt(m_eff)``).
    mass_unit_kg : float
        Kilograms per unit of the effective mass ``m_eff = 1 / |W[k]|^2`` at a contact (the beam:
        1, its rows are 1/sqrt(kg); the SDOF: its ``mass_kg``, NaN without it).  Forces in newtons
        are ``m_eff mass_unit_kg length_unit_m / time_unit_s^2`` per unit nondimensional force.
    drive_power : int
        ``p`` in :data:`DRIVE_POWERS`: the forcing amplitude is ``Omega^p A`` (default 2, the base
        displacement drive).  Its equivalent base displacement at ``Omega`` is ``Omega^(p - 2) A``
        (:func:`drive_displacement`), the base-velocity amplitude ``Omega^(p - 1) A``.
    contact_static : ndarray, shape (n_c,)
        Each contact row's static deflection under the base load over the sensor's (paper Eq. 45's
        ``phi(x_m)``: a gap ``Delta_C`` at contact ``k`` is seen at the sensor as ``Delta_C /
        contact_static[k]``); what the reported gap ``Delta`` of a scene is referred to the
        sensor by (:func:`vibeam.models.scene.outputs`).  The SDOF: 1; the beam: its ``phi_contact``
        at the mass (NaN for the rows of stops elsewhere); a matrix model: ``W_k K^-1 M r / s K^-1
        M r``.  ``None`` only for a system built without :func:`modal_system` (read as ones).
    reference_hz : float
        Hz per unit of ``Omega``, exactly as the builder was given it (the SDOF's ``f_n``, the
        beam's ``f_ref``): ``1 / (2 pi time_unit_s)`` can be an ulp off it, and the frequency grid
        of a case is built from it; NaN: ``1 / (2 pi time_unit_s)`` (:func:`reference_hz`).
    """

    omega: np.ndarray
    damping: np.ndarray
    participation: np.ndarray
    sensor: np.ndarray
    contacts: np.ndarray
    base_amplitude: float
    time_unit_s: float
    length_unit_m: float
    coordinate_scale: float
    mass_unit_kg: float
    drive_power: int = 2
    contact_static: Optional[np.ndarray] = None
    reference_hz: float = math.nan


def reference_hz(system: ModalSystem) -> float:
    """Hz per unit of ``Omega``: the builder's own frequency (``system.reference_hz``), else ``1 /
    (2 pi time_unit_s)``; NaN for a nondimensional system."""
    f = float(system.reference_hz)
    if math.isfinite(f):
        return f
    T = float(system.time_unit_s)
    return 1.0 / (TWO_PI * T) if math.isfinite(T) else math.nan


def _vec(x, n, name):
    v = np.array(x, dtype=float, order="C").reshape(-1)     # a copy: the system never shares a model's arrays
    if v.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {np.shape(x)}")
    return v


def modal_system(omega, damping, participation, sensor, contacts, base_amplitude, time_unit_s=math.nan,
                 length_unit_m=math.nan, coordinate_scale=1.0, mass_unit_kg=math.nan,
                 drive_power=2, contact_static=None, reference_hz=math.nan) -> ModalSystem:
    """A :class:`ModalSystem` from modal data, checked, its arrays contiguous float64.

    Parameters
    ----------
    omega, damping, participation, sensor : array_like, shape (n,)
        ``omega_i >= 0``, ``c_i = 2 zeta_i omega_i >= 0`` (per unit time), ``Gamma_i``, ``s``.
    contacts : array_like, shape (n_c, n) or (n,)
        Contact rows (one row for a 1-D input).
    base_amplitude : float
        ``B`` (row unit).
    time_unit_s, length_unit_m, coordinate_scale, mass_unit_kg : float, optional
        The scales (:class:`ModalSystem`); NaN: a nondimensional scene; ``coordinate_scale``
        defaults to 1 (the rows give ``q``).
    drive_power : int, optional
        ``p`` of the forcing amplitude ``Omega^p A`` (:data:`DRIVE_POWERS`; default 2, a base
        displacement ``A = B``).
    contact_static : array_like, shape (n_c,), optional
        Each contact's static ratio to the sensor (:class:`ModalSystem`); default ones (a contact
        row read as the sensor).
    reference_hz : float, optional
        The builder's frequency per unit of ``Omega`` (Hz), ``1 / (2 pi time_unit_s)`` up to
        round-off; NaN (default): that quotient.

    Returns
    -------
    ModalSystem

    Raises
    ------
    ValueError
        On no mode, shapes that do not match, negative or non-finite frequencies or damping, a
        ``coordinate_scale`` that is not positive and finite, or a ``drive_power`` not in
        :data:`DRIVE_POWERS`.
    """
    om = np.array(omega, dtype=float, order="C").reshape(-1)
    n = om.size
    if n < 1:
        raise ValueError("a modal system needs at least one mode")
    c = _vec(damping, n, "damping")
    W = np.array(np.atleast_2d(contacts), dtype=float, order="C")
    if W.ndim != 2 or W.shape[1] != n:
        raise ValueError(f"contacts must have shape (n_c, {n}), got {np.shape(contacts)}")
    if not (np.all(np.isfinite(om)) and np.all(om >= 0.0)):
        raise ValueError("modal frequencies omega must be finite and >= 0")
    if not (np.all(np.isfinite(c)) and np.all(c >= 0.0)):
        raise ValueError("modal damping coefficients must be finite and >= 0")
    if not (coordinate_scale > 0 and math.isfinite(coordinate_scale)):
        raise ValueError(f"coordinate_scale must be positive and finite, got {coordinate_scale!r}")
    if drive_power not in DRIVE_POWERS:
        raise ValueError(f"drive_power = {drive_power!r}; allowed: {' or '.join(map(str, DRIVE_POWERS))}")
    n_c = W.shape[0]
    cs = np.ones(n_c) if contact_static is None else _vec(contact_static, n_c, "contact_static")
    return ModalSystem(om, c, _vec(participation, n, "participation"), _vec(sensor, n, "sensor"), W,
                       float(base_amplitude), float(time_unit_s), float(length_unit_m),
                       float(coordinate_scale), float(mass_unit_kg), int(drive_power), cs, float(reference_hz))


def damping_ratios(system: ModalSystem) -> np.ndarray:
    """Modal damping ratios ``zeta_i = c_i / (2 omega_i)``, shape (n,) (inf for ``omega_i = 0``
    with ``c_i > 0``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(system.damping == 0.0, 0.0, system.damping / (2.0 * system.omega))


# ============================================================================ constructors
def sdof_system(beta, B, natural_frequency_hz=None, length_m=None, mass_kg=None) -> ModalSystem:
    """The SDOF impact oscillator as the one-mode system (paper Eqs. 43-46).

    ``q'' + 2 beta q' + q = Omega^2 B sin(Omega t)``: ``omega = 1``, ``damping = 2 beta``,
    ``Gamma = s = W = 1``, ``B`` as is; the coordinate is ``q`` itself (``coordinate_scale = 1``).

    Parameters
    ----------
    beta, B : float
        Damping ratio and base-displacement amplitude (nondimensional).
    natural_frequency_hz, length_m, mass_kg : float or None
        ``f_n`` (Hz), ``L`` (m) and the effective mass (kg) of a physical scene.

    Returns
    -------
    ModalSystem
        ``time_unit_s = 1 / (2 pi f_n)``, ``length_unit_m = L``, ``mass_unit_kg = mass_kg`` when
        the scene is physical, NaN otherwise.

    Raises
    ------
    ValueError
        If ``beta`` is negative or not finite.
    """
    beta = float(beta)
    if not (math.isfinite(beta) and beta >= 0.0):
        raise ValueError(f"beta must be finite and >= 0, got {beta!r}")
    f_n, L, mass = natural_frequency_hz, length_m, mass_kg
    return modal_system([1.0], [2.0 * beta], [1.0], [1.0], [[1.0]], float(B),
                         time_unit_s=math.nan if f_n is None else 1.0 / (TWO_PI * float(f_n)),
                         length_unit_m=math.nan if L is None else float(L), coordinate_scale=1.0,
                         mass_unit_kg=math.nan if mass is None else float(mass),
                         reference_hz=math.nan if f_n is None else float(f_n))


def lowest_modes(K, M, n=None, eigvals_only=False):
    """Lowest ``n`` (all if ``None``) eigenpairs of ``K v = lam M v``, ascending, M-normalised.

    Up to half of the spectrum the inverse problem ``M v = mu K v`` (``mu = 1 / lam``) is solved:
    the fundamental, dominant there, is then accurate to round-off instead of ``eps lam_max /
    lam_1`` (poorly scaled for fine meshes and ``m >> rhoA L``).  For larger ``n`` the direct
    problem, whose complete basis is M-orthonormal to round-off (the inverse problem's highest
    modes, tiny ``mu``, are not).  The two agree to ``~eps lam_max / lam_1`` relative.

    Parameters
    ----------
    K, M : ndarray, shape (d, d)
        Symmetric stiffness and mass matrices, ``M`` positive definite (and ``K`` too when
        ``n <= d / 2``: the inverse problem factorises it).
    n : int or None
        Number of modes (clipped to ``d``).
    eigvals_only : bool
        Return the eigenvalues only.

    Returns
    -------
    lam : ndarray, shape (k,)
        ``omega^2`` (units of ``K / M``), ascending, ``>= 0``.
    V : ndarray, shape (d, k)
        ``V^T M V = I`` (not returned with ``eigvals_only``).

    Raises
    ------
    numpy.linalg.LinAlgError
        From :func:`scipy.linalg.eigh` when a matrix it factorises is not positive definite.
    """
    N = K.shape[0]
    k = N if n is None else min(int(n), N)
    if k > N // 2:
        res = scipy.linalg.eigh(K, M, subset_by_index=[0, k - 1], eigvals_only=eigvals_only)
        lam = np.clip(res if eigvals_only else res[0], 0.0, None)
        return lam if eigvals_only else (lam, res[1])
    res = scipy.linalg.eigh(M, K, subset_by_index=[N - k, N - 1], eigvals_only=eigvals_only)
    mu = res if eigvals_only else res[0]
    lam = 1.0 / mu[::-1]
    if eigvals_only:
        return lam
    V = res[1][:, ::-1]
    V = V / np.sqrt(np.einsum("ij,ij->j", V, M @ V))
    return lam, V


# ============================================================================ mode algebra
def mode_table(c, k):
    """Per-mode flow parameters ``[sig, k, typ, q, l1, l2]`` for ``x'' + c x' + k x = 0``.

    ``sig = c/2``; ``typ`` 0 underdamped (``q = omega_D``), 1 critical, 2 overdamped
    (``q = mu = sqrt(sig^2 - k)``, roots ``l1 = -k/(sig+mu)`` (slow), ``l2 = -(sig+mu)``).

    Parameters
    ----------
    c, k : array_like, shape (n,)
        Damping coefficients ``2 zeta omega`` and stiffnesses ``omega^2`` (nondimensional).

    Returns
    -------
    ndarray, shape (n, 6)
        The table the kernels :func:`transition_increment`, :func:`transition_entries` and
        :func:`advance_modes` read.
    """
    c = np.asarray(c, dtype=float)
    k = np.asarray(k, dtype=float)
    out = np.zeros((c.size, 6))
    for i in range(c.size):
        sig = 0.5 * c[i]
        d = sig * sig - k[i]
        out[i, 0], out[i, 1] = sig, k[i]
        if d < 0:
            out[i, 2], out[i, 3] = 0, math.sqrt(-d)
        elif d == 0:
            out[i, 2], out[i, 3] = 1, 0.0
            out[i, 4] = out[i, 5] = -sig
        else:
            mu = math.sqrt(d)
            out[i, 2], out[i, 3] = 2, mu
            out[i, 4], out[i, 5] = -k[i] / (sig + mu), -(sig + mu)
    return out


# ============================================================================ the drive
# F(Omega) = Omega^p A, p in DRIVE_POWERS: one branch per call (per frequency or contact phase, never per
# step); p = 2 is the expressions of the base-displacement drive bit for bit (``Om * Om * B``,
# ``2 Om B dOm + Om^2 dB``, the floor's ``Om B``)
@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def drive_force(p, A, Om):
    """The forcing amplitude ``F = Omega^p A`` (the forcing of mode ``i`` is ``f_i F sin(Omega t)``)."""
    if p == 2:
        return Om * Om * A
    return A


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def drive_slope(p, A, Om, dOm, dA):
    """``dF = p Omega^(p-1) A dOmega + Omega^p dA``: the forcing amplitude's change along a
    direction that moves ``Omega`` by ``dOm`` and ``A`` by ``dA``."""
    if p == 2:
        return 2.0 * Om * A * dOm + Om * Om * dA
    return dA


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def drive_displacement(p, A, Om):
    """The equivalent base-displacement amplitude ``B_eq = Omega^(p-2) A`` (``Omega^2 B_eq = F``);
    ``Omega B_eq = Omega^(p-1) A`` is the base-velocity amplitude (the compliant stops' entry
    velocity floor, :func:`vibeam.models.core.laws.hertz_floor`)."""
    if p == 2:
        return A
    return A / (Om * Om)


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def drive_velocity_slope(p, A, Om, dOm, dA):
    """``dv / v = (p - 1) dOmega / Omega + dA / A``: the relative change of the base-velocity
    amplitude ``v = Omega^(p-1) A`` along ``(dOm, dA)`` (``A != 0``)."""
    if p == 2:
        return dOm / Om + dA / A
    return dA / A - dOm / Om


def forcing(system: ModalSystem, Omega) -> float:
    """The forcing amplitude ``F(Omega) = Omega^p A`` of ``system`` (``p = drive_power``, ``A =
    base_amplitude``): mode ``i`` is forced by ``participation_i F sin(Omega t)``.

    Parameters
    ----------
    system : ModalSystem
    Omega : float
        Forcing frequency (per unit nondimensional time).

    Returns
    -------
    float
        ``Omega^2 B`` for the base-displacement drive (bit for bit the kernels' ``Om * Om * B``),
        ``A`` for ``p = 0`` (system units: the kernels' ``F``).
    """
    return drive_force.py_func(int(system.drive_power), float(system.base_amplitude), float(Omega))


def particular(c, k, G, F, Omega):
    """Steady response ``a sin + b cos`` of ``x'' + c x' + k x = G F sin(Omega t)``.

    Parameters
    ----------
    c, k, G : array_like, shape (n,)
        Damping coefficients, stiffnesses, participation factors.
    F : float
        Forcing amplitude (``Omega^2 B`` for base excitation; in general :func:`forcing`).
    Omega : float
        Forcing frequency.

    Returns
    -------
    a, b : ndarray, shape (n,)
        Non-finite for a mode at undamped exact resonance (``k = Omega^2``, ``c = 0``), which
        has no periodic particular solution (callers refuse it: :func:`modal_flow`).
    """
    z = G * F / (k - Omega**2 + 1j * c * Omega)   # response to G F e^{i Omega t}
    return z.real, z.imag  # Im(z e^{i phi}) = Re z sin + Im z cos


@njit(cache=True, error_model="numpy")
def transition_increment(s, sig, k, typ, q, l1, l2):
    """``Phi(s) - I`` of ``x'' + 2 sig x' + k x = 0`` (entries 11, 12, 21, 22).

    Formed without cancellation for short ``s`` (``e^{-sig s} cos - 1`` as ``expm1(-sig s) cos -
    2 sin^2(q s / 2)``), which the event kernels need for chatter; ``(sig, k, typ, q, l1, l2)`` is
    a row of :func:`mode_table`.  The decayed entries lose relative precision once 1 is added back:
    :func:`transition_entries` gives ``Phi`` itself.
    """
    if typ == 0:
        # one expm1 and one sincos of the half angle: cos(q s) = hc^2 - hs^2, sin(q s) = 2 hs hc
        em1 = math.expm1(-sig * s)
        E = 1.0 + em1 if sig * s < 0.25 else math.exp(-sig * s)
        hs = math.sin(0.5 * q * s)
        hc = math.cos(0.5 * q * s)
        cm1 = em1 * (hc * hc - hs * hs) - 2.0 * hs * hs
        S = E * (2.0 * hs * hc) / q
    elif typ == 2:
        e1m1 = math.expm1(l1 * s)
        E1 = 1.0 + e1m1 if -l1 * s < 0.25 else math.exp(l1 * s)
        cm1 = 0.5 * (e1m1 + math.expm1(l2 * s))
        S = -E1 * math.expm1(-2.0 * q * s) / (2.0 * q)
    else:
        cm1 = math.expm1(-sig * s)
        E = 1.0 + cm1 if sig * s < 0.25 else math.exp(-sig * s)
        S = s * E
    return cm1 + sig * S, S, -k * S, cm1 - sig * S


@njit(cache=True, _nrt=False, error_model="numpy", inline="always")
def increment_of(tab, P, j, s, mp):
    """``Phi(s) - I`` of coordinate ``j`` (entries 11, 12, 21, 22): the tabulated row ``P[j]``
    (shape (>= j + 1, 4), for this fixed ``s``) if ``tab``, else :func:`transition_increment` of
    its row of the mode table ``mp`` (:func:`mode_table`)."""
    if tab:
        return P[j, 0], P[j, 1], P[j, 2], P[j, 3]
    return transition_increment(s, mp[j, 0], mp[j, 1], int(mp[j, 2]), mp[j, 3], mp[j, 4], mp[j, 5])


@njit(cache=True, error_model="numpy")
def transition_entries(s, sig, k, typ, q, l1, l2):
    """Transition matrix ``Phi(s)`` (11, 12, 21, 22) of ``x'' + 2 sig x' + k x = 0``, entries
    to relative precision (:func:`transition_increment` returns ``Phi - I`` for the flow,
    whose decayed entries lose their relative precision when 1 is added back).

    ``Phi = e^{-sig s} C I + e^{-sig s} S (A + sig I)`` with ``C = cos(q s)``, ``S = sin(q s) /
    q`` (underdamped; ``cosh``, ``sinh`` overdamped, ``1``, ``s`` critical); overdamped:
    ``(e^{l1 s} +- e^{l2 s}) / 2`` combinations.  Valid for either sign of ``s``.
    """
    if typ == 0:
        E = math.exp(-sig * s)
        Ec = E * math.cos(q * s)
        Es = E * math.sin(q * s) / q
        return Ec + sig * Es, Es, -k * Es, Ec - sig * Es
    if typ == 2:
        e1 = math.exp(l1 * s)
        e2 = math.exp(l2 * s)
        Es = -e1 * math.expm1(-2.0 * q * s) / (2.0 * q)
        # l1 = -k / (sig + q) (slow), l2 = -(sig + q): no cancellation in the diagonal
        return (-l2 * e1 + l1 * e2) / (2.0 * q), Es, -k * Es, (l1 * e1 - l2 * e2) / (2.0 * q)
    E = math.exp(-sig * s)
    return E * (1.0 + sig * s), s * E, -k * s * E, E * (1.0 - sig * s)


@njit(cache=True, error_model="numpy")
def advance_modes(s, phi0, Om, z, zd, mp, a, b, e):
    """:func:`advance_count` over every coordinate of ``z``."""
    advance_count(s, phi0, Om, z, zd, mp, a, b, e, z.shape[0])


@njit(cache=True, _nrt=False, error_model="numpy")
def advance_state(s, phi0, Om, z, mp, a, b, m):
    """:func:`advance_count` of a state vector ``z = (eta, eta')`` (shape (2m,)) without offsets, in
    place: the same arithmetic, no allocation and no reference counting (the tangent of the
    shooting problem calls it per segment)."""
    advance_count(s, phi0, Om, z[:m], z[m:], mp, a, b, z[:0], m)


@njit(cache=True, error_model="numpy", inline="always")
def advance_count(s, phi0, Om, z, zd, mp, a, b, e, m):
    """Move modal coordinates ``z`` (with offsets ``e`` and harmonic particular ``a, b``)
    by ``s`` in closed form, in place.

    Each ``z_j = e_j + a_j sin(phi) + b_j cos(phi) + x_j`` with ``phi = phi0 + Om s`` and ``x_j``
    the homogeneous part moved by :func:`transition_increment`; the particular part's increment
    is formed without cancellation (``2 sin(Om s / 2) cos(phi0 + Om s / 2)``).

    Parameters
    ----------
    s : float
        Time step (nondimensional).
    phi0 : float
        Forcing phase at the start (rad).
    Om : float
        Forcing frequency.
    z, zd : ndarray, shape (n,)
        Coordinates and velocities, overwritten.
    mp : ndarray, shape (n, 6)
        :func:`mode_table` of the modes.
    a, b, e : ndarray, shape (n,)
        Particular coefficients (:func:`particular`) and constant offsets (a stop's static
        offset of the constrained modes; zeros in free flight; ``e`` of length 0: none).
    m : int
        Coordinates moved (the first ``m``; all of them for :func:`advance_modes`).
    """
    half = 0.5 * Om * s
    sh = math.sin(half)
    ph = phi0 + half
    sph = math.sin(ph)
    cph = math.cos(ph)
    sp0 = math.sin(phi0)
    cp0 = math.cos(phi0)
    for j in range(m):
        x0 = z[j] - (e[j] if e.shape[0] > 0 else 0.0) - (a[j] * sp0 + b[j] * cp0)
        y0 = zd[j] - Om * (a[j] * cp0 - b[j] * sp0)
        a11, a12, a21, a22 = transition_increment(s, mp[j, 0], mp[j, 1], int(mp[j, 2]), mp[j, 3],
                                                  mp[j, 4], mp[j, 5])
        z[j] += a11 * x0 + a12 * y0 + 2.0 * sh * (a[j] * cph - b[j] * sph)
        zd[j] += a21 * x0 + a22 * y0 - 2.0 * Om * sh * (a[j] * sph + b[j] * cph)


# ============================================================================ the flow
def _times(t0, t1):
    t0, t1 = float(t0), float(t1)
    if not (math.isfinite(t0) and math.isfinite(t1)):
        raise ValueError(f"times must be finite, got t0 = {t0!r}, t1 = {t1!r}")
    return t0, t1


def modal_flow(system: ModalSystem, t0, t1, eta, etad, Omega=0.0):
    """The state at ``t1`` of the free flight (no contact) from ``(eta, eta')`` at ``t0``.

    Closed form per mode (paper Eq. 28; Meirovitch Ch. 4): ``z(t1) = z_p(t1) + Phi(t1 - t0)
    (z(t0) - z_p(t0))`` with the homogeneous transition ``Phi`` (under-, critically or
    over-damped) and the particular response ``z_p = a sin(Omega t) + b cos(Omega t)`` to the
    forcing ``Gamma Omega^2 B sin(Omega t)`` (absolute time ``t``: phase ``Omega t0`` at ``t0``).
    The beam's event kernel moves its modes with the same kernel (:func:`advance_modes`).

    Parameters
    ----------
    system : ModalSystem
    t0, t1 : float
        Start and end times (nondimensional, units of ``system.time_unit_s``); ``t1 < t0`` flows
        backward by the same closed form.
    eta, etad : array_like, shape (n,)
        Modal coordinates and their derivatives with respect to ``t`` at ``t0``.
    Omega : float
        Forcing frequency (per unit ``t``; the sweep's ``f / f_ref``); 0 (or ``B = 0``): free
        vibration.

    Returns
    -------
    eta1, etad1 : ndarray, shape (n,)

    Raises
    ------
    ValueError
        On shapes that do not match, non-finite times, or a forced mode at undamped exact
        resonance (``omega_i = Omega``, ``c_i = 0``: the response grows as ``t cos t``, no
        periodic particular solution).
    """
    t0, t1 = _times(t0, t1)
    n = system.omega.size
    z = _vec(eta, n, "eta")
    zd = _vec(etad, n, "etad")
    Om = float(Omega)
    k = system.omega ** 2
    F = forcing(system, Om)
    if F != 0.0:
        bad = (k - Om ** 2 == 0.0) & (system.damping * Om == 0.0) & (system.participation != 0.0)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise ValueError(f"mode {i} is at undamped exact resonance (omega = Omega = {Om:g}, damping 0): "
                             f"the forced flow grows as t cos t; give it damping or another Omega")
        a, b = particular(system.damping, k, system.participation, F, Om)
    else:
        a = b = np.zeros(n)
    advance_modes(t1 - t0, Om * t0, Om, z, zd, mode_table(system.damping, k), np.ascontiguousarray(a),
                  np.ascontiguousarray(b), np.zeros(n))
    return z, zd


def modal_transition(system: ModalSystem, t0, t1) -> np.ndarray:
    """State-transition matrix ``d(eta, eta')(t1) / d(eta, eta')(t0)`` of the free flight.

    The flow is affine in the state, so this is the homogeneous transition: per mode the 2 x 2
    ``Phi(t1 - t0)`` (:func:`transition_entries`, entries to relative precision), independent of
    the forcing and of ``t0``.  Its determinant is ``exp(-sum_i c_i (t1 - t0))`` (Liouville: the
    trace of the state matrix is ``-sum_i c_i``).

    Parameters
    ----------
    system : ModalSystem
    t0, t1 : float
        Start and end times (nondimensional; either order).

    Returns
    -------
    ndarray, shape (2n, 2n)
        Rows and columns ordered ``(eta_1..eta_n, eta'_1..eta'_n)`` (the shooting problems'
        state); blocks ``[[diag(P11), diag(P12)], [diag(P21), diag(P22)]]``.

    Raises
    ------
    ValueError
        On non-finite times.
    """
    t0, t1 = _times(t0, t1)
    n = system.omega.size
    mp = mode_table(system.damping, system.omega ** 2)
    out = np.zeros((2 * n, 2 * n))
    s = t1 - t0
    for i in range(n):
        p11, p12, p21, p22 = transition_entries(s, mp[i, 0], mp[i, 1], int(mp[i, 2]), mp[i, 3], mp[i, 4],
                                                mp[i, 5])
        out[i, i], out[i, n + i], out[n + i, i], out[n + i, n + i] = p11, p12, p21, p22
    return out
