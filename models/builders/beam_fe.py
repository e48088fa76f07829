"""Finite-element model of the linear cantilever beam with an attached mass (paper Eq. 39-40).

Euler-Bernoulli cantilever of length ``L`` clamped at ``X = 0`` and free at ``X = L``,
carrying a rigid body (mass ``m``, rotary inertia ``J``) at ``X = L_m`` where the
unilateral stop also sits; the displacement sensor is at ``X = L_S`` (paper Sec. 5,
Fig. 15; Sec. 6, Eq. 39-41).  Only the *linear* parts live here: mass, stiffness and
damping matrices, the base-excitation load, contact/sensor rows, modes, static
deflection, calibration and export.  The impact law (Eq. 41) is handled elsewhere.

Discretisation (scikit-fem):

* :class:`skfem.MeshLine` with nodes exactly at ``L_S`` and ``L_m`` (segments between
  the key points are subdivided uniformly, then the whole mesh is bisected ``refine``
  times), :class:`skfem.ElementLineHermite` (cubic Hermite; DOFs ``w`` and ``w'`` per
  node);
* stiffness ``K_ij = EI int N_i'' N_j'' dX``, consistent mass ``M_ij = rhoA int N_i N_j dX``
  (``BilinearForm``), plus ``m`` on the ``w`` DOF and ``J`` on the ``w'`` DOF of the
  mass node; both DOFs of the node at ``X = 0`` are removed (clamp, Eq. 40); the free
  end conditions ``U'' = U''' = 0`` are natural;
* damping ``C = alpha M + D K`` (``alpha = 0`` gives the paper's stiffness-proportional
  damping ``D EI U''''`` of Eq. 39);
* base excitation ``b(t)``: with ``U = b + w`` (``w`` relative to the base),
  ``M w'' + C w' + K w = -M r b''(t)`` where ``r`` is the rigid-translation influence
  vector (``w = 1``, ``w' = 0`` at every node, including the clamped node), which is the
  Galerkin form of the right-hand side ``(rhoA + m delta(X - L_m)) b''`` of Eq. 39
  (the paper's ``+Omega^2 gamma V sin`` is ``-b''`` for ``b = gamma V sin``, Eq. 38).
  ``K r = 0`` so stiffness-proportional damping does not load the beam; a mass-
  proportional ``alpha`` damps the relative motion only (a modelling choice).

All quantities are SI.  Matrices are dense :class:`numpy.ndarray` on the free DOFs
(a few hundred at most), ordered as scikit-fem's global DOFs with the clamped ones
removed.

References
----------
.. [1] Paper, Sec. 5-6, Eq. 39-47 (``/work/shared/paper/000_db9366990d60f12d.txt``).
.. [2] M. Geradin, D. Rixen, *Mechanical Vibrations*, 3rd ed., Wiley 2015 (Hermite beam
   element, effective modal masses).
.. [3] I. Karnovsky, O. Lebed, *Formulas for Structural Dynamics*, McGraw-Hill 2001
   (cantilever with tip mass frequency equation).
"""
from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.linalg
import scipy.optimize

from skfem import Basis, BilinearForm, ElementLineHermite, MeshLine
from skfem.helpers import dd, ddot

from ..system import lowest_modes

#: the eigen-solver, now :func:`vibeam.models.system.lowest_modes` (one for every modal model)
_lowest_eigs = lowest_modes

__all__ = [
    "BeamGeometry",
    "BeamFE",
    "Modes",
    "Calibration",
    "disc_stack",
    "paper_rig",
    "calibrate",
    "shared_fe",
    "shared_calibration",
    "write_modes",
]

STEEL_E_PA = 200e9
STEEL_DENSITY_KG_M3 = 7850.0


def disc_stack(count: int, thickness_m: float, diameter_m: float,
               density_kg_m3: float = STEEL_DENSITY_KG_M3,
               axis: str = "bending") -> tuple[float, float]:
    """Mass and rotary inertia of a stack of identical solid discs.

    The rotary inertia is the one that enters the beam model: the moment of inertia
    about the axis of *bending rotation* of the cross-section (the beam's width
    direction, normal to the plane of bending) through the stack's centre of mass,
    which is assumed to lie on the beam's neutral axis at ``X = L_m`` (discs split
    symmetrically on both faces / the bolt offset and the beam's own thickness are
    neglected).

    Parameters
    ----------
    count : int
        Number of discs (paper rig: 4).
    thickness_m : float
        Thickness of one disc (paper: 7 mm).
    diameter_m : float
        Disc diameter (paper: 35 mm).
    density_kg_m3 : float
        Disc density (steel: 7850 kg/m^3).
    axis : {"bending", "transverse"}
        Orientation of the disc axis.  ``"bending"`` (default, the assumption for the
        paper's rig, Fig. 15): the disc axis is normal to the plane of bending, i.e.
        parallel to the bending-rotation axis, so the stack rotates about its own axis
        and ``J = m R^2 / 2``.  ``"transverse"``: the disc axis is along the bending
        displacement ``U`` (discs bolted through the beam thickness); the stack
        (cylinder of height ``H = count * thickness``) rotates about a diameter and
        ``J = m (3 R^2 + H^2) / 12``.

    Returns
    -------
    mass_kg, rotary_inertia_kg_m2 : float
        For the paper's discs: 0.2116 kg (the paper quotes 0.2 kg with bolts) and,
        with ``axis="bending"``, 3.24e-5 kg m^2.

    Raises
    ------
    ValueError
        On non-positive sizes or an unknown ``axis``.
    """
    if count < 1 or thickness_m <= 0 or diameter_m <= 0 or density_kg_m3 <= 0:
        raise ValueError("disc count, thickness, diameter and density must be positive")
    R = 0.5 * diameter_m
    H = count * thickness_m
    mass = density_kg_m3 * math.pi * R**2 * H
    if axis == "bending":
        J = 0.5 * mass * R**2
    elif axis == "transverse":
        J = mass * (3.0 * R**2 + H**2) / 12.0
    else:
        raise ValueError(f"axis must be 'bending' or 'transverse', got {axis!r}")
    return mass, J


@dataclass(frozen=True)
class BeamGeometry:
    """Geometry, section and attached body of the impacting cantilever (paper Fig. 15).

    Attributes
    ----------
    length_m : float
        Beam length ``L`` (paper: 0.180 m).
    EI_n_m2 : float
        Bending stiffness ``EI`` (N m^2).
    rhoA_kg_m : float
        Mass per unit length ``rho A`` (kg/m).
    mass_kg : float
        Attached mass ``m`` (paper: 0.2 kg); 0 for a bare beam.
    rotary_inertia_kg_m2 : float
        Rotary inertia ``J`` of the attached body about the bending-rotation axis
        through its centre (see :func:`disc_stack`).
    mass_position_m : float or None
        ``L_m`` (paper: 0.132 m); ``None`` means the tip ``L``.  The stop is here.
    sensor_position_m : float or None
        ``L_S`` (paper: 0.100 m); ``None`` means ``L_m``.

    Raises
    ------
    ValueError
        If a size is non-positive, a mass negative, or a position outside ``(0, L]``.
    """

    length_m: float
    EI_n_m2: float
    rhoA_kg_m: float
    mass_kg: float = 0.0
    rotary_inertia_kg_m2: float = 0.0
    mass_position_m: float | None = None
    sensor_position_m: float | None = None

    def __post_init__(self):
        if not (self.length_m > 0 and self.EI_n_m2 > 0 and self.rhoA_kg_m > 0):
            raise ValueError("length_m, EI_n_m2 and rhoA_kg_m must be positive")
        if self.mass_kg < 0 or self.rotary_inertia_kg_m2 < 0:
            raise ValueError("mass_kg and rotary_inertia_kg_m2 must be >= 0")
        if self.mass_position_m is None:
            object.__setattr__(self, "mass_position_m", float(self.length_m))
        if self.sensor_position_m is None:
            object.__setattr__(self, "sensor_position_m", float(self.mass_position_m))
        for name in ("mass_position_m", "sensor_position_m"):
            x = getattr(self, name)
            if not (0.0 < x <= self.length_m * (1 + 1e-12)):
                raise ValueError(f"{name} = {x} must lie in (0, L = {self.length_m}]")

    @property
    def beam_mass_kg(self) -> float:
        """``rho A L``."""
        return self.rhoA_kg_m * self.length_m

    @classmethod
    def from_section(cls, length_m: float, width_m: float, thickness_m: float,
                     youngs_modulus_pa: float = STEEL_E_PA,
                     density_kg_m3: float = STEEL_DENSITY_KG_M3, **kwargs) -> "BeamGeometry":
        """Rectangular section: ``EI = E b t^3 / 12``, ``rhoA = rho b t`` (bending about
        the width axis, i.e. displacement along the thickness).

        Raises
        ------
        ValueError
            On non-positive section data.
        """
        if min(width_m, thickness_m, youngs_modulus_pa, density_kg_m3) <= 0:
            raise ValueError("section data must be positive")
        EI = youngs_modulus_pa * width_m * thickness_m**3 / 12.0
        rhoA = density_kg_m3 * width_m * thickness_m
        return cls(length_m=length_m, EI_n_m2=EI, rhoA_kg_m=rhoA, **kwargs)

    @classmethod
    def with_discs(cls, count: int, disc_thickness_m: float, disc_diameter_m: float,
                   disc_density_kg_m3: float = STEEL_DENSITY_KG_M3, axis: str = "bending",
                   mass_kg: float | None = None, **kwargs) -> "BeamGeometry":
        """Geometry whose ``m`` and ``J`` come from a stack of discs (:func:`disc_stack`).

        If ``mass_kg`` is given (e.g. the paper's measured 0.2 kg) it overrides the disc
        mass and ``J`` is scaled by the same ratio (same radius of gyration).
        Remaining keyword arguments go to the constructor (``length_m``, ``EI_n_m2``,
        ``rhoA_kg_m``, positions).
        """
        m, J = disc_stack(count, disc_thickness_m, disc_diameter_m, disc_density_kg_m3, axis)
        if mass_kg is not None:
            J *= mass_kg / m
            m = mass_kg
        return cls(mass_kg=m, rotary_inertia_kg_m2=J, **kwargs)

    def replace(self, **changes) -> "BeamGeometry":
        """Copy with some fields changed (:func:`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)


def paper_rig(width_m: float = 0.020, thickness_m: float = 0.001,
              youngs_modulus_pa: float = STEEL_E_PA,
              density_kg_m3: float = STEEL_DENSITY_KG_M3) -> BeamGeometry:
    """The rig of paper Sec. 5 before calibration.

    ``L = 180 mm``, ``L_S = 100 mm``, ``L_m = 132 mm``, ``m = 0.2 kg`` made of 4 steel
    discs (7 mm thick, 35 mm diameter) with their axis normal to the plane of bending
    (``J = m R^2/2 = 3.06e-5 kg m^2`` with ``m = 0.2 kg``).  The paper gives no beam
    section: the default is an *assumed* steel strip 20 mm x 1 mm (``rhoA = 0.157 kg/m``,
    beam mass 0.028 kg, i.e. ``m / (rho A L) = 7``; ``EI = 0.333 N m^2`` which gives
    ``f_1`` close to the measured 7.6-8 Hz).  Use :func:`calibrate` to fit ``EI`` and
    ``J`` to the measured frequencies.
    """
    sec = BeamGeometry.from_section(0.180, width_m, thickness_m, youngs_modulus_pa, density_kg_m3)
    return BeamGeometry.with_discs(4, 0.007, 0.035, STEEL_DENSITY_KG_M3, axis="bending",
                                   mass_kg=0.2, length_m=0.180, EI_n_m2=sec.EI_n_m2,
                                   rhoA_kg_m=sec.rhoA_kg_m, mass_position_m=0.132,
                                   sensor_position_m=0.100)


@dataclass(frozen=True)
class Modes:
    """Modal data of a :class:`BeamFE` (free DOFs).

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n,)
        Natural frequencies, ascending.
    omega_rad_s : ndarray, shape (n,)
        ``2 pi f``.
    shapes : ndarray, shape (ndof, n)
        Mass-normalised mode shapes ``Phi^T M Phi = I`` (units 1/sqrt(kg)); sign chosen
        so that the tip displacement is >= 0.
    participation : ndarray, shape (n,)
        ``Gamma_i = phi_i^T M r`` (sqrt(kg)); modal force is ``-Gamma_i b''``.
    effective_mass_kg : ndarray, shape (n,)
        ``Gamma_i^2``; over all modes sums to ``m + rhoA L`` as the mesh is refined.
    """

    frequencies_hz: np.ndarray
    omega_rad_s: np.ndarray
    shapes: np.ndarray
    participation: np.ndarray
    effective_mass_kg: np.ndarray


class BeamFE:
    """Cubic-Hermite finite-element model of the cantilever with attached mass.

    Parameters
    ----------
    geometry : BeamGeometry
    n_elements : int
        Target number of elements before refinement; each segment between the key
        points ``0, L_S, L_m, L`` gets ``max(1, round(n * len / L))`` equal elements.
    refine : int
        Number of uniform bisections applied afterwards (element size halves each time).
    damping_D_s : float
        Stiffness-proportional damping coefficient ``D`` (s) of Eq. 39 (``C = D K``).
    rayleigh_alpha_1_s : float
        Optional mass-proportional Rayleigh coefficient ``alpha`` (1/s), ``C += alpha M``.

    Attributes
    ----------
    mesh : skfem.MeshLine
    basis : skfem.Basis
    free : ndarray of int, shape (ndof,)
        Global scikit-fem DOFs kept (all but the two at ``X = 0``).
    K, M, C : ndarray, shape (ndof, ndof)
        Stiffness (N/m, N, N m per unit DOF), mass (incl. ``m`` and ``J``), damping.
    M_beam : ndarray, shape (ndof, ndof)
        Consistent beam mass only.
    r : ndarray, shape (ndof,)
        Rigid-translation influence vector on the free DOFs.
    base_load : ndarray, shape (ndof,)
        ``-(M_full r_full)_free``: load per unit base acceleration ``b''`` (N per m/s^2).
    contact_row, sensor_row : ndarray, shape (ndof,)
        ``w(L_m) = contact_row @ u``, ``w(L_S) = sensor_row @ u``.
    mass_dof_w, mass_dof_slope : int
        Free-DOF indices of ``w`` and ``w'`` at the mass node.

    Raises
    ------
    ValueError
        If ``n_elements < 1``, ``refine < 0`` or damping coefficients are negative.
    """

    def __init__(self, geometry: BeamGeometry, n_elements: int = 24, refine: int = 0,
                 damping_D_s: float = 0.0, rayleigh_alpha_1_s: float = 0.0):
        if n_elements < 1 or refine < 0:
            raise ValueError("n_elements must be >= 1 and refine >= 0")
        if damping_D_s < 0 or rayleigh_alpha_1_s < 0:
            raise ValueError("damping coefficients must be >= 0")
        self.geometry = g = geometry
        self.n_elements, self.refine = int(n_elements), int(refine)
        self.damping_D_s = float(damping_D_s)
        self.rayleigh_alpha_1_s = float(rayleigh_alpha_1_s)
        L = g.length_m
        keys = np.unique(np.array([0.0, g.sensor_position_m, g.mass_position_m, L]))
        pts = [np.array([0.0])]
        for a, b in zip(keys[:-1], keys[1:]):
            ne = max(1, int(round(n_elements * (b - a) / L)))
            pts.append(np.linspace(a, b, ne + 1)[1:])
        mesh = MeshLine(np.concatenate(pts))
        if refine:
            mesh = mesh.refined(refine)
        self.mesh = mesh
        self.basis = basis = Basis(mesh, ElementLineHermite())

        EI, rhoA = g.EI_n_m2, g.rhoA_kg_m

        @BilinearForm
        def stiffness(u, v, w):
            return EI * ddot(dd(u), dd(v))

        @BilinearForm
        def mass(u, v, w):
            return rhoA * u * v

        K_full = stiffness.assemble(basis).toarray()
        M_full = mass.assemble(basis).toarray()
        self.M_beam_full = M_full.copy()
        clamp = basis.get_dofs(lambda x: np.isclose(x[0], 0.0))
        mnode = basis.get_dofs(nodes=lambda x: np.isclose(x[0], g.mass_position_m))
        w_dof, t_dof = int(mnode.nodal["u"][0]), int(mnode.nodal["u_x"][0])
        M_full[w_dof, w_dof] += g.mass_kg
        M_full[t_dof, t_dof] += g.rotary_inertia_kg_m2
        self.K_full, self.M_full = K_full, M_full
        self.free = basis.complement_dofs(clamp)
        f = self.free
        self.K = K_full[np.ix_(f, f)]
        self.M = M_full[np.ix_(f, f)]
        self.M_beam = self.M_beam_full[np.ix_(f, f)]
        self.C = self.rayleigh_alpha_1_s * self.M + self.damping_D_s * self.K
        index = -np.ones(basis.N, dtype=int)
        index[f] = np.arange(f.size)
        self.mass_dof_w, self.mass_dof_slope = int(index[w_dof]), int(index[t_dof])
        r_full = np.zeros(basis.N)
        r_full[basis.nodal_dofs[0]] = 1.0
        self.r = r_full[f]
        self.base_load = -(M_full @ r_full)[f]
        self.contact_row = self.point_rows(g.mass_position_m)[0]
        self.sensor_row = self.point_rows(g.sensor_position_m)[0]

    # ------------------------------------------------------------------ helpers
    @property
    def ndof(self) -> int:
        """Number of free DOFs."""
        return self.free.size

    def point_rows(self, x_m) -> np.ndarray:
        """Rows evaluating ``w`` at points, via ``Basis.probes``.

        Parameters
        ----------
        x_m : float or array_like, shape (k,)
            Positions in ``[0, L]``.

        Returns
        -------
        ndarray, shape (k, ndof)
            ``w(x_j) = rows[j] @ u`` for a free-DOF vector ``u``.
        """
        x = np.atleast_1d(np.asarray(x_m, dtype=float))
        P = self.basis.probes(x[None, :]).toarray()
        # at mesh nodes use the exact nodal 'u' DOF (basis.get_dofs) instead of the
        # probe, whose inverse mapping leaves ~1e-12 round-off on the slope DOFs
        nodes = self.mesh.p[0]
        tol = 1e-12 * self.geometry.length_m
        for k, xk in enumerate(x):
            if np.min(np.abs(nodes - xk)) <= tol:
                dof = self.basis.get_dofs(nodes=lambda p, xk=xk: np.abs(p[0] - xk) <= tol).nodal["u"]
                P[k] = 0.0
                P[k, dof[0]] = 1.0
        return P[:, self.free]

    def expand(self, u) -> np.ndarray:
        """Free-DOF vector(s) ``(ndof,)`` or ``(ndof, k)`` to all scikit-fem DOFs (zeros at the clamp)."""
        u = np.asarray(u)
        out = np.zeros((self.basis.N,) + u.shape[1:])
        out[self.free] = u
        return out

    def deflection(self, u, x_m) -> np.ndarray:
        """``w(x)`` (m per unit of ``u``) of free-DOF vector(s) ``u`` at points ``x_m``.

        Returns shape ``(k,)`` for ``u`` of shape ``(ndof,)``, ``(k, n)`` for ``(ndof, n)``.
        """
        return self.point_rows(x_m) @ np.asarray(u)

    # ------------------------------------------------------------------ analyses
    @staticmethod
    def _eig(K, M, n):
        """Lowest ``n`` eigenpairs of ``K v = lam M v`` via the inverse problem
        ``M v = mu K v`` (``mu = 1/lam``): the fundamental, dominant there, is then
        accurate to round-off instead of ``eps * lam_max / lam_1`` (poorly scaled for
        fine meshes and ``m >> rhoA L``).  Vectors are rescaled to ``V^T M V = I``."""
        return _lowest_eigs(K, M, n)

    @functools.cached_property
    def _tip_row(self) -> np.ndarray:
        """``w(L) = _tip_row @ u`` (ndof,): the row the mode shapes' signs are fixed by, probed once."""
        return self.point_rows(self.geometry.length_m)[0]

    def _fix_signs(self, V):
        tip = self._tip_row @ V
        ref = np.where(np.abs(tip) > 1e-12 * np.abs(V).max(axis=0), tip,
                       V[np.argmax(np.abs(V), axis=0), np.arange(V.shape[1])])
        return V * np.where(ref < 0, -1.0, 1.0)

    def modes(self, n: int | None = None) -> Modes:
        """Natural frequencies and mass-normalised modes (``eigh(K, M)``).

        Parameters
        ----------
        n : int or None
            Number of lowest modes; ``None`` = all ``ndof``.

        Returns
        -------
        Modes
        """
        lam, V = self._eig(self.K, self.M, n)
        V = self._fix_signs(V)
        om = np.sqrt(lam)
        gam = -V.T @ self.base_load       # phi^T M r (full M, incl. the clamp coupling)
        return Modes(om / (2 * np.pi), om, V, gam, gam**2)

    def contact_modes(self, n: int | None = None) -> Modes:
        """Modes of the beam held at the stop (``w(L_m) = 0``, rotation free).

        The ``w`` DOF of the mass node is removed (the stop acts as a pin while in
        contact); shapes are returned on the full free-DOF set with a zero there.
        ``participation`` is computed with the same ``M r`` load.
        """
        keep = np.setdiff1d(np.arange(self.ndof), [self.mass_dof_w])
        lam, Vk = self._eig(self.K[np.ix_(keep, keep)], self.M[np.ix_(keep, keep)], n)
        V = np.zeros((self.ndof, Vk.shape[1]))
        V[keep] = Vk
        V = self._fix_signs(V)
        om = np.sqrt(lam)
        gam = -V.T @ self.base_load
        return Modes(om / (2 * np.pi), om, V, gam, gam**2)

    def static_deflection(self, position_m: float | None = None, force_n: float = 1.0) -> np.ndarray:
        """Static solution ``K u = F N(x_F)`` for a transverse point force.

        Parameters
        ----------
        position_m : float or None
            Load position (default ``L_m``, the contact point).
        force_n : float
            Force (N).

        Returns
        -------
        ndarray, shape (ndof,)
            Free-DOF displacement vector (m, rad).
        """
        x = self.geometry.mass_position_m if position_m is None else position_m
        F = force_n * self.point_rows(x)[0]
        return scipy.linalg.solve(self.K, F, assume_a="pos")

    def contact_effective_mass_kg(self) -> float:
        """``1 / (w^T M^-1 w)``: apparent mass at the contact point of the full FE model.

        Tends to ``m`` from above as the mesh is refined (``m_eff - m = O(rhoA h)``),
        since ``w^T M_beam^-1 w -> infinity`` for an Euler-Bernoulli continuum.
        """
        y = scipy.linalg.solve(self.M, self.contact_row, assume_a="pos")
        return float(1.0 / (self.contact_row @ y))

    def calibrate(self, target_f1_hz: float, target_f2_hz: float | None = None, **kw) -> "Calibration":
        """See :func:`calibrate` (same ``n_elements`` and ``refine`` as this model)."""
        kw.setdefault("n_elements", self.n_elements)
        kw.setdefault("refine", self.refine)
        return calibrate(self.geometry, target_f1_hz, target_f2_hz, **kw)

    def write_modes(self, path, n: int = 6, **kw) -> Path:
        """See :func:`write_modes`."""
        return write_modes(path, self, n=n, **kw)


@dataclass(frozen=True)
class Calibration:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    EI_n_m2, rotary_inertia_kg_m2 : float
        Calibrated values.
    geometry : BeamGeometry
        Input geometry with those values.
    frequencies_hz : ndarray, shape (4,)
        First four FE frequencies of the calibrated model.
    target_f1_hz, target_f2_hz : float or None
    """

    EI_n_m2: float
    rotary_inertia_kg_m2: float
    geometry: BeamGeometry
    frequencies_hz: np.ndarray
    target_f1_hz: float
    target_f2_hz: float | None


def calibrate(geometry: BeamGeometry, target_f1_hz: float, target_f2_hz: float | None = None,
              n_elements: int = 36, refine: int = 0, J_max_kg_m2: float | None = None) -> Calibration:
    """Fit ``EI`` (and ``J``) so that the first two bending frequencies match targets.

    Because ``K`` is linear in ``EI``, the ratio ``f_2/f_1`` depends on ``J`` only:
    ``J`` is found by :func:`scipy.optimize.brentq` on ``f_2/f_1 = target``, then ``EI``
    by exact scaling ``EI <- EI (f_1target/f_1)^2``.  With ``target_f2_hz=None`` only
    ``EI`` is fitted.  Paper Sec. 5/6.1: ``f_1 = 7.6 Hz`` (8 Hz from the hammer test),
    ``f_2 = 98.75 Hz``.

    Parameters
    ----------
    geometry : BeamGeometry
        Starting geometry (``rhoA``, ``m``, positions are kept).
    target_f1_hz, target_f2_hz : float
        Target first and second bending frequencies (Hz).
    n_elements, refine : int
        Mesh of the FE model used (see :class:`BeamFE`).
    J_max_kg_m2 : float or None
        Upper end of the ``J`` search (default ``m L^2``).

    Returns
    -------
    Calibration

    Raises
    ------
    ValueError
        If the targets are not positive and increasing, or ``f_2/f_1`` is out of the
        range reachable with ``0 <= J <= J_max``.
    """
    if target_f1_hz <= 0 or (target_f2_hz is not None and target_f2_hz <= target_f1_hz):
        raise ValueError("need 0 < target_f1_hz < target_f2_hz")
    fe = BeamFE(geometry, n_elements=n_elements, refine=refine)
    K, Mb = fe.K, fe.M - geometry.rotary_inertia_kg_m2 * _unit(fe.ndof, fe.mass_dof_slope)
    E_t = _unit(fe.ndof, fe.mass_dof_slope)

    def freqs(J):
        lam = _lowest_eigs(K, Mb + J * E_t, 4, eigvals_only=True)
        return np.sqrt(lam) / (2 * np.pi)

    J = geometry.rotary_inertia_kg_m2
    if target_f2_hz is not None:
        target = target_f2_hz / target_f1_hz

        def g(J):
            f = freqs(J)
            return f[1] / f[0] - target

        J_hi = J_max_kg_m2 if J_max_kg_m2 is not None else max(geometry.mass_kg, 1e-12) * geometry.length_m**2
        g0, g1 = g(0.0), g(J_hi)
        if g0 * g1 > 0:
            raise ValueError(f"f2/f1 = {target:.4g} not reachable with 0 <= J <= {J_hi:.3g} "
                             f"(range {g1 + target:.4g} .. {g0 + target:.4g})")
        J = scipy.optimize.brentq(g, 0.0, J_hi, xtol=1e-16, rtol=1e-13)
    f = freqs(J)
    EI = geometry.EI_n_m2 * (target_f1_hz / f[0]) ** 2
    cal = geometry.replace(EI_n_m2=EI, rotary_inertia_kg_m2=J)
    f_cal = f * target_f1_hz / f[0]
    return Calibration(EI, J, cal, f_cal, target_f1_hz, target_f2_hz)


@functools.lru_cache(maxsize=16)
def shared_fe(geometry: BeamGeometry, n_elements: int = 24, refine: int = 0, damping_D_s: float = 0.0,
              rayleigh_alpha_1_s: float = 0.0) -> BeamFE:
    """The :class:`BeamFE` of these arguments, assembled once per process and shared.

    A scene rebuilt with a number that does not enter the FE model (a stop's position or gap, a
    law's stiffness: a parameter map, a continuation's finite differences, a fit) reuses its
    matrices: assembling the rig's beam takes ~10 ms against ~1 ms for a shot of its 2 modes.
    The arguments are the key (``BeamGeometry`` is frozen); the 16 latest are kept.  The
    model is shared: read it, never change its arrays in place.

    Returns
    -------
    BeamFE
        Identical to ``BeamFE(geometry, n_elements, refine, damping_D_s, rayleigh_alpha_1_s)``.

    Raises
    ------
    ValueError
        As :class:`BeamFE`.
    """
    return BeamFE(geometry, n_elements=n_elements, refine=refine, damping_D_s=damping_D_s,
                  rayleigh_alpha_1_s=rayleigh_alpha_1_s)


@functools.lru_cache(maxsize=16)
def shared_calibration(geometry: BeamGeometry, target_f1_hz: float, target_f2_hz: float | None = None,
                       n_elements: int = 36, refine: int = 0) -> Calibration:
    """:func:`calibrate` once per process for these arguments (a frozen result, shared; see
    :func:`shared_fe`); the same ``Calibration`` as ``calibrate(geometry, target_f1_hz,
    target_f2_hz, n_elements=n_elements, refine=refine)``."""
    return calibrate(geometry, target_f1_hz, target_f2_hz, n_elements=n_elements, refine=refine)


def _unit(n, i):
    E = np.zeros((n, n))
    E[i, i] = 1.0
    return E


def write_modes(path, fe: BeamFE, n: int = 6, contact: bool = False, static: bool = True) -> Path:
    """Write the line mesh and mode shapes with :mod:`meshio` (format from the suffix,
    e.g. ``.vtu`` or ``.xdmf``).

    Point data per mode ``i`` (1-based): ``mode_i_w`` (deflection, 1/sqrt(kg)) and
    ``mode_i_slope``; with ``static=True`` also ``static_mode_w`` (FE static deflection
    under a load at ``L_m``, normalised to 1 at ``L_S``).  Field data ``frequencies_hz``.
    Points are the mesh nodes ``(X, 0, 0)`` in metres.

    Parameters
    ----------
    path : str or Path
    fe : BeamFE
    n : int
        Number of modes.
    contact : bool
        Export :meth:`BeamFE.contact_modes` instead of free modes.
    static : bool
        Include the static mode.

    Returns
    -------
    Path
    """
    import meshio

    path = Path(path)
    md = fe.contact_modes(n) if contact else fe.modes(n)
    full = fe.expand(md.shapes)
    nd = fe.basis.nodal_dofs
    pts = np.zeros((fe.mesh.p.shape[1], 3))
    pts[:, 0] = fe.mesh.p[0]
    point_data = {}
    for i in range(md.shapes.shape[1]):
        point_data[f"mode_{i + 1}_w"] = full[nd[0], i]
        point_data[f"mode_{i + 1}_slope"] = full[nd[1], i]
    if static:
        u = fe.expand(fe.static_deflection())
        ws = fe.deflection(fe.static_deflection(), fe.geometry.sensor_position_m)[0]
        point_data["static_mode_w"] = u[nd[0]] / ws
    mesh = meshio.Mesh(pts, [("line", fe.mesh.t.T.astype(np.int64))], point_data=point_data,
                       field_data={"frequencies_hz": np.asarray(md.frequencies_hz)})
    meshio.write(path, mesh)
    return path
