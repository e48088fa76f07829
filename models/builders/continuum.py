"""The rig (or a user's part) as a 3D linear-elastic continuum, reduced to vibeam's modal system (issue 59).

Model
    Small-strain linear elasticity of an isotropic solid per region (Young's modulus ``E``, Poisson's
    ratio ``nu``, density ``rho``), discretised by scikit-fem with quadratic hexahedra (20-node
    serendipity :class:`skfem.ElementHexS2`, default, or 27-node Lagrange :class:`skfem.ElementHex2`)
    or quadratic tetrahedra (:class:`skfem.ElementTetP2`, meshes read by meshio), three displacement
    components per scalar DOF (``u_x, u_y, u_z``):

        ``K[(a,i),(b,j)] = int lambda d_i N_a d_j N_b + mu d_j N_a d_i N_b + mu delta_ij grad N_a . grad N_b``,
        ``M[(a,i),(b,j)] = int rho N_a N_b delta_ij``,

    i.e. ``int lambda div u div v + 2 mu eps(u) : eps(v)`` and ``int rho u . v`` (consistent mass),
    assembled per region with its Lame parameters.  3D rather than a 2D plane-stress model: the rig's
    strip (1 mm x 20 mm) is neither a beam nor a plate everywhere: far from the clamp and the disc
    stack its anticlastic curvature is free (beam stiffness ``E b t^3 / 12``, linear plate theory with
    free long edges gives exactly this), while over a width-sized layer at the clamp and under the
    stack it is held (plate stiffness ``E / (1 - nu^2)``, +10 %); the clamped face, the stack's
    footprint and the torsion mode (the paper's 67 Hz) are three-dimensional.  The bare strip
    clamped at one end bends as a beam: f1 and f2 +0.8 % over Euler-Bernoulli's with ``E`` (72 x 8 x 2
    elements), the plate's ``E / (1 - nu^2)`` would give +4.8 % (tests/test_continuum.py).  A quadratic element
    through the thickness represents the linear bending strain exactly, so one or two layers suffice.

Clamp
    A Dirichlet region: every DOF on a facet whose nodes all lie in the clamp's node set is zero
    (the rig: the strip's end face ``X = 0``, a rigid clamp).

The base drive
    Coordinates relative to the base; the base translates along ``drive`` (unit vector, the rig: ``z``,
    the bending direction ``U`` of paper Eq. 39): the influence vector ``r`` is ``drive`` on every
    displacement DOF (clamped ones included, through ``M_full r_full``) and on the rigid body's
    translation, 0 on its rotations; the load per unit base acceleration is ``M r``, the Galerkin form
    of Eq. 39's ``(rho A + m delta(X - L_m)) b''``.

Contact, well posed: the rigid disc stack
    A Newton (coefficient of restitution) stop acting on one node of a continuum sees the node's
    effective mass ``1 / (w M^-1 w^T)``, which goes to zero as the mesh is refined (the impulse of an
    impact on a point of an elastic solid is not defined).  Here the stop acts on a rigid body: the
    disc stack of the rig (four steel discs bolted through the strip) is tied to the strip by a
    master-slave transformation.  Every DOF of the tie region (the strip under the discs' footprint,
    or a user's named region) follows the body's rigid motion,

        ``u(p) = U + theta x (p - p_0)``,  ``x = T q``,  ``q = (u_free, U, theta)``,

    ``K_r = T^T K T``, ``M_r = T^T M T + M_body`` (``M_body``: the 6 x 6 mass matrix of the discs
    about ``p_0``, when the discs are not meshed), and a contact point ``p_c`` on the body's face
    with normal ``n`` has the row ``n . (U + theta x (p_c - p_0))`` over the body's six DOFs.  Its
    effective mass ``1 / (w M_r^-1 w^T)`` is finite (about the body's mass plus the strip it
    carries) and converges under refinement (tests/test_continuum.py), and an eccentric contact point
    (off the strip's axis on the disc face, paper Sec. 7) couples the impact to the body's rotations.

Modes
    :func:`vibeam.models.builders.matrices.build_matrices` (``scipy.sparse.linalg.eigsh`` in
    shift-invert about 0 above its ``DENSE_MAX`` DOFs, mass-normalised), with the sensor and contact
    rows named, modal damping ratios or a Rayleigh ``C = a M + b K`` (paper Eq. 39: ``a = 0``,
    ``b = D``).

Cache
    The built model is stored under ``$VIBEAM_CACHE_DIR/continuum`` (else
    ``$XDG_CACHE_HOME/vibeam/continuum``, else ``~/.cache/vibeam/continuum``), one ``.npz`` per content
    hash of every input (geometry, mesh size, the mesh file's bytes, materials, rows, damping,
    ``n_modes``, this module's source), written atomically (temporary file, fsync, rename); a second
    build with the same inputs loads it.

The rig from geometry alone (measured with :func:`build_rig`, defaults, no fitted parameter)
    f1 = 7.12 Hz, f2 = 101.7 Hz (bending), a torsion mode at 62.4 Hz.  Over the meshes h = 2.5, 1.25,
    0.625 mm with one layer, 2.5 and 1.25 mm with two, 20- and 27-node: f1 7.123-7.132 Hz, f2
    101.46-102.03 Hz (the footprint's circle staircased by the structured grid), torsion 62.35-62.51 Hz;
    h = 1.25 mm, one layer: 42,000 DOFs, built in 23 s on 2 shared cores, 0.05 s from the cache.
    Against the measured 7.6 and 98.75 Hz (paper Secs. 5, 6.1; torsion 67 Hz): f1 -6 %, f2 +3 %;
    the uncalibrated beam (``vibeam modes`` on ``cases/rig-fe-tight.toml`` without
    ``[model.calibrate]``): 7.05 Hz, 80.7 Hz (-7 %, -18 %).  What moves them most (h = 2.5 mm, one
    layer; base 7.132 / 101.67 Hz): the strip's thickness +-0.05 mm: f1 +7.4 / -7.2 %, f2 +6.6 /
    -6.5 %; for f2 the stack's split across the strip (all four discs on one face: 74.3 Hz, -27 %, the
    stack's centre of mass 14.5 mm off the mid-plane; three and one: 92.0 Hz, -9.5 %) and the
    footprint that moves with the stack (25 mm: 95.2 Hz, -6.4 %; 30 mm: -3.3 %); the discs' mass
    from their volume (0.2116 kg instead of the weighed 0.2 kg): -2.5 / -1.9 %; width 19 mm: -2.4 /
    -1.7 %; E = 210 GPa: +2.5 %; an effective clamp 1 mm deeper (clamp compliance): -1.1 / -0.8 %.

Units: SI throughout (m, kg, N, s); modal coordinates sqrt(kg) m, rows 1/sqrt(kg) (metres).

References
----------
.. [1] Paper, Secs. 2, 5-7, Eqs. 39-47, Fig. 15 (``/work/shared/paper/000_db9366990d60f12d.txt``):
   L = 180 mm, L_S = 100 mm, L_m = 132 mm, 4 steel discs 7 mm x 35 mm, 0.2 kg; measured 7.6 (Sec. 6.1)
   and 98.75 Hz, a torsional resonance at 67 Hz (Sec. 5).
.. [2] T. J. R. Hughes, *The Finite Element Method*, Dover 2000, Ch. 2, 7 (linear elasticity, the
   consistent mass; eigenvalue error ``O(h^{2p})`` of degree-``p`` elements, Strang & Fix 1973).
.. [3] T. Gustafsson, G. D. McBain, scikit-fem: A Python package for finite element assembly,
   J. Open Source Softw. 5 (2020) 2369; https://scikit-fem.readthedocs.io (``Basis``, ``probes``).
.. [4] M. Geradin, D. Rixen, *Mechanical Vibrations*, 3rd ed., Wiley 2015, Ch. 6 (rigid-body
   constraints by master-slave transformation, the rigid body's mass matrix).
.. [5] N. Schloemer et al., meshio (https://github.com/nschloe/meshio): mesh I/O.
"""
from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import io
import json
import math
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import meshio
import numpy as np
import scipy.sparse
import scipy.sparse.linalg
from skfem import Basis, ElementHex1, ElementHex2, ElementHexS2, ElementTetP1, ElementTetP2, MeshHex, MeshTet

from ..system import ModalSystem
from .matrices import MatrixModel, build_matrices

__all__ = ["Material", "STEEL", "RigGeometry", "ContinuumMesh", "rig_mesh", "read_mesh", "rigid_body_mass", "rigid_motion", "box_mesh", "write_mesh",
           "assemble", "mesh_mass", "build_continuum", "build_rig", "write_modes", "cache_dir", "ContinuumInfo"]


# ============================================================================ data
@dataclass(frozen=True)
class Material:
    """An isotropic linear-elastic material (SI).

    Attributes
    ----------
    youngs_modulus_pa : float
        ``E`` (Pa).
    poisson_ratio : float
        ``nu``, in (-1, 0.5).
    density_kg_m3 : float
        ``rho`` (kg/m^3).
    """

    youngs_modulus_pa: float = 200e9
    poisson_ratio: float = 0.3
    density_kg_m3: float = 7850.0

    def __post_init__(self):
        if not (self.youngs_modulus_pa > 0 and -1.0 < self.poisson_ratio < 0.5 and self.density_kg_m3 > 0):
            raise ValueError(f"material {self}: allowed E > 0, -1 < nu < 0.5, rho > 0")

    @property
    def lame(self):
        """``(lambda, mu)`` (Pa)."""
        E, nu = self.youngs_modulus_pa, self.poisson_ratio
        return E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu))


#: steel as the rig's cases assume it (vibeam's case schema: ``youngs_modulus_gpa = 200``, 7850 kg/m^3)
STEEL = Material(200e9, 0.3, 7850.0)


@dataclass(frozen=True)
class RigGeometry:
    """The rig of paper Sec. 5 (Fig. 15) as a solid: a clamped strip and a bolted disc stack.

    Coordinates: ``x`` along the strip from the clamp (``0 <= x <= L``), ``y`` across its width
    (``|y| <= b/2``), ``z`` through its thickness (``|z| <= t/2``), the bending direction ``U`` (the
    drive and the stop's normal).  The discs are coaxial with ``z`` (bolted through the strip), centred
    at ``(L_m, 0)``, ``discs_above`` of them on the ``+z`` face (the stop's side) and the rest on the
    ``-z`` face; they are rigid and tied to the strip over their footprint (a disc of diameter
    ``tie_diameter_m``, default the discs').

    Attributes
    ----------
    length_m, width_m, thickness_m : float
        The strip's free length ``L`` (180 mm, paper), width ``b`` and thickness ``t`` (20 mm x 1 mm:
        not in the paper; ``cases/rig-fe-tight.toml``'s assumption).
    sensor_position_m, mass_position_m : float
        ``L_S = 100 mm``, ``L_m = 132 mm`` (paper Sec. 5).
    disc_count, discs_above : int
        Number of discs (4) and how many on the ``+z`` face (default 2: the stack's centre of mass on
        the strip's mid-plane, as the beam model assumes).
    disc_thickness_m, disc_diameter_m : float
        7 mm, 35 mm (paper Sec. 5).
    disc_mass_kg : float or None
        The stack's mass (None: solid steel discs of ``disc_density_kg_m3``, 0.2116 kg; the paper
        weighs 0.2 kg with bolts, the case's ``mass_kg``): the density is scaled to it.
    disc_density_kg_m3 : float
        7850 (steel).
    tie_diameter_m : float or None
        Diameter of the footprint over which the strip moves with the stack (None: the discs').
    material : Material
        The strip's material (:data:`STEEL`).
    contact_offset_m : tuple of float
        ``(dx, dy)`` of the contact point on the stack's ``+z`` face from its centre (0, 0): the
        paper's eccentric collision (Sec. 7).
    """

    length_m: float = 0.180
    width_m: float = 0.020
    thickness_m: float = 0.001
    sensor_position_m: float = 0.100
    mass_position_m: float = 0.132
    disc_count: int = 4
    discs_above: int = 2
    disc_thickness_m: float = 0.007
    disc_diameter_m: float = 0.035
    disc_mass_kg: float | None = 0.2
    disc_density_kg_m3: float = 7850.0
    tie_diameter_m: float | None = None
    material: Material = STEEL
    contact_offset_m: tuple = (0.0, 0.0)

    def __post_init__(self):
        pos = (self.length_m, self.width_m, self.thickness_m, self.disc_thickness_m, self.disc_diameter_m,
               self.disc_density_kg_m3)
        if not all(v > 0 and math.isfinite(v) for v in pos):
            raise ValueError("RigGeometry: lengths and density must be positive and finite")
        if not (0 < self.sensor_position_m <= self.length_m and 0 < self.mass_position_m < self.length_m):
            raise ValueError("RigGeometry: the sensor and the stack must lie on the strip (0 < x <= L)")
        if not (self.disc_count >= 1 and 0 <= self.discs_above <= self.disc_count):
            raise ValueError("RigGeometry: disc_count >= 1 and 0 <= discs_above <= disc_count")
        R = 0.5 * self.tie_diameter
        if self.mass_position_m - R <= 0 or self.mass_position_m + R > self.length_m:
            raise ValueError("RigGeometry: the stack's footprint must lie within 0 < x <= L")

    @property
    def tie_diameter(self) -> float:
        """The tie footprint's diameter (m)."""
        return self.disc_diameter_m if self.tie_diameter_m is None else float(self.tie_diameter_m)

    def replace(self, **changes) -> "RigGeometry":
        """Copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    def body_parts(self):
        """The stack as cylinders ``(mass_kg, centre (3,), radius_m, height_m)`` (axis ``z``)."""
        R, td, t = 0.5 * self.disc_diameter_m, self.disc_thickness_m, self.thickness_m
        rho = self.disc_density_kg_m3
        if self.disc_mass_kg is not None:
            rho = float(self.disc_mass_kg) / (math.pi * R * R * td * self.disc_count)
        parts = []
        for n, sign in ((self.discs_above, 1.0), (self.disc_count - self.discs_above, -1.0)):
            if n:
                H = n * td
                parts.append((rho * math.pi * R * R * H, np.array([self.mass_position_m, 0.0, sign * (0.5 * t + 0.5 * H)]),
                              R, H))
        return parts

    def contact_point(self) -> np.ndarray:
        """The contact point on the stack's ``+z`` face, shape (3,) (m)."""
        top = 0.5 * self.thickness_m + self.discs_above * self.disc_thickness_m
        dx, dy = self.contact_offset_m
        return np.array([self.mass_position_m + dx, dy, top])


@dataclass
class ContinuumMesh:
    """A linear-geometry volume mesh with named regions (what meshio reads and writes).

    Attributes
    ----------
    points : ndarray, shape (N, 3)
        Node coordinates (m).
    cells : ndarray, shape (E, 8) or (E, 4)
        Hexahedra (meshio/VTK node order) or tetrahedra.
    cell_type : {"hexahedron", "tetra"}
    cell_sets : dict of str -> ndarray of int
        Named groups of cells (materials; a rigid region).
    point_sets : dict of str -> ndarray of int
        Named groups of nodes (the clamp; a rigid region; a sensor node).
    """

    points: np.ndarray
    cells: np.ndarray
    cell_type: str
    cell_sets: dict = field(default_factory=dict)
    point_sets: dict = field(default_factory=dict)

    def nodes_of(self, name: str) -> np.ndarray:
        """Node indices of region ``name`` (a point set, or the nodes of a cell set).

        Raises
        ------
        KeyError
            When no region has that name (the message lists them).
        """
        if name in self.point_sets:
            return np.unique(np.asarray(self.point_sets[name], dtype=np.int64))
        if name in self.cell_sets:
            return np.unique(self.cells[np.asarray(self.cell_sets[name], dtype=np.int64)])
        raise KeyError(f"no region named {name!r}; the regions: {', '.join(sorted(self.regions)) or 'none'}")

    @property
    def regions(self):
        return list(self.cell_sets) + list(self.point_sets)

    def to_meshio(self):
        """The mesh as a :class:`meshio.Mesh`: cell sets as ``cell_sets`` (one block), point sets as
        ``vertex`` cell blocks named in ``cell_sets`` too (what Gmsh's physical points become)."""
        blocks = [(self.cell_type, self.cells)]
        sets = {k: [np.asarray(v, dtype=np.int64)] for k, v in self.cell_sets.items()}
        for k, v in self.point_sets.items():
            blocks.append(("vertex", np.asarray(v, dtype=np.int64).reshape(-1, 1)))
        nb = len(blocks)
        for k in sets:
            sets[k] = sets[k] + [np.zeros(0, dtype=np.int64)] * (nb - 1)
        for j, k in enumerate(self.point_sets, start=1):
            sets[k] = [np.zeros(0, dtype=np.int64)] * nb
            sets[k][j] = np.arange(len(self.point_sets[k]), dtype=np.int64)
        return meshio.Mesh(self.points, blocks, cell_sets=sets)


def rig_mesh(geometry: RigGeometry = RigGeometry(), h_m: float = 0.0025, nz: int = 1) -> ContinuumMesh:
    """A structured hexahedral mesh of the rig's strip with its named regions.

    The ``x`` grid has nodes at the clamp, the sensor, the stack's centre and footprint edges (``L_m
    +- R`` and ``L_m +- sqrt(R^2 - (b/2)^2)``, where the footprint leaves the strip's edges) and the
    tip, and segments between them of at most ``h_m``; the ``y`` grid has ``ceil(b / h_m)`` (even:
    a node on the axis) elements, ``z`` has ``nz``.

    Parameters
    ----------
    geometry : RigGeometry
    h_m : float
        Largest element length along ``x`` and ``y`` (m).
    nz : int
        Elements through the thickness.

    Returns
    -------
    ContinuumMesh
        Cell set ``"strip"``; point sets ``"clamp"`` (the nodes at ``x = 0``) and ``"stack"`` (the
        nodes in the footprint ``(x - L_m)^2 + y^2 <= R_tie^2``).

    Raises
    ------
    ValueError
        For ``h_m <= 0`` or ``nz < 1``.
    """
    if not (h_m > 0 and nz >= 1):
        raise ValueError(f"h_m = {h_m!r}, nz = {nz!r}; allowed: h_m > 0, nz >= 1")
    g = geometry
    L, b, t, Lm, R = g.length_m, g.width_m, g.thickness_m, g.mass_position_m, 0.5 * g.tie_diameter
    keys = {0.0, g.sensor_position_m, Lm, Lm - R, Lm + R, L}
    if R > 0.5 * b:
        c = math.sqrt(R * R - 0.25 * b * b)
        keys |= {Lm - c, Lm + c}
    keys = sorted(k for k in keys if 0.0 <= k <= L)
    xs = [0.0]
    for a, bb in zip(keys[:-1], keys[1:]):
        if bb - a < 1e-12:
            continue
        n = max(1, math.ceil((bb - a) / h_m - 1e-9))
        xs.extend(np.linspace(a, bb, n + 1)[1:])
    ny = max(2, 2 * math.ceil(0.5 * b / h_m - 1e-9))
    m = MeshHex.init_tensor(np.array(xs), np.linspace(-0.5 * b, 0.5 * b, ny + 1), np.linspace(-0.5 * t, 0.5 * t, nz + 1))
    p = m.p.T.copy()
    tol = 1e-9 * L
    clamp = np.flatnonzero(p[:, 0] <= tol)
    stack = np.flatnonzero((p[:, 0] - Lm) ** 2 + p[:, 1] ** 2 <= (R + tol) ** 2)
    return ContinuumMesh(p, _skfem_to_vtk_hex(m.t.T), "hexahedron", {"strip": np.arange(m.t.shape[1])},
                         {"clamp": clamp, "stack": stack})


def box_mesh(length_m: float, width_m: float, height_m: float, nx: int, ny: int, nz: int) -> ContinuumMesh:
    """A structured hexahedral mesh of the box ``[0, L] x [-b/2, b/2] x [-h/2, h/2]``.

    Parameters
    ----------
    length_m, width_m, height_m : float
        ``L``, ``b``, ``h`` (m).
    nx, ny, nz : int
        Elements along each side (>= 1).

    Returns
    -------
    ContinuumMesh
        Cell set ``"solid"``; point sets ``"clamp"`` (``x = 0``) and ``"end"`` (``x = L``).
    """
    if min(nx, ny, nz) < 1 or min(length_m, width_m, height_m) <= 0:
        raise ValueError("box_mesh: positive sizes and at least one element per side")
    m = MeshHex.init_tensor(np.linspace(0.0, length_m, nx + 1), np.linspace(-0.5 * width_m, 0.5 * width_m, ny + 1),
                            np.linspace(-0.5 * height_m, 0.5 * height_m, nz + 1))
    p = m.p.T.copy()
    tol = 1e-9 * length_m
    return ContinuumMesh(p, _skfem_to_vtk_hex(m.t.T), "hexahedron", {"solid": np.arange(m.t.shape[1])},
                         {"clamp": np.flatnonzero(p[:, 0] <= tol), "end": np.flatnonzero(p[:, 0] >= length_m - tol)})


# scikit-fem's MeshHex node order vs VTK/meshio's hexahedron: permutation found by the reference
# element's vertices (MeshHex.init_refdom: (0,0,0),(0,0,1),(0,1,0),(1,0,0),(0,1,1),(1,0,1),(1,1,0),(1,1,1);
# VTK: (0,0,0),(1,0,0),(1,1,0),(0,1,0),(0,0,1),(1,0,1),(1,1,1),(0,1,1))
_SK_FROM_VTK = np.array([0, 4, 3, 1, 7, 5, 2, 6])   # skfem vertex k is VTK vertex _SK_FROM_VTK[k]
_VTK_FROM_SK = np.argsort(_SK_FROM_VTK)


def _skfem_to_vtk_hex(t):
    return np.ascontiguousarray(t[:, _VTK_FROM_SK])


def read_mesh(path) -> ContinuumMesh:
    """Read a volume mesh with named regions through meshio (Gmsh ``.msh``, ``.vtu``, ``.xdmf``, ...).

    Volume cells (``hexahedron``, ``tetra``; the corner nodes of ``hexahedron20/27``, ``tetra10``:
    straight-sided) form the mesh; each named ``cell_sets`` entry (Gmsh physical groups, read by
    meshio as ``cell_sets``) becomes a cell set when it holds volume cells and a point set (the nodes
    of its cells) when it holds surface, line or vertex cells.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    ContinuumMesh

    Raises
    ------
    ValueError
        When the file holds no volume cells or two kinds of them.
    OSError, meshio.ReadError
        From meshio when the file cannot be read.
    """
    # meshio tries each reader of the suffix (".msh": ANSYS, then Gmsh) and prints the error of each
    # that fails, an empty line on stdout for a Gmsh file: kept out of the command's output (the
    # last reader's ReadError still says why a file cannot be read)
    with contextlib.redirect_stdout(io.StringIO()):
        msh = meshio.read(path)
    vol = {"hexahedron": ("hexahedron", 8), "hexahedron20": ("hexahedron", 8), "hexahedron27": ("hexahedron", 8),
           "tetra": ("tetra", 4), "tetra10": ("tetra", 4)}
    kinds = {vol[b.type][0] for b in msh.cells if b.type in vol}
    if len(kinds) != 1:
        raise ValueError(f"{path}: volume cells {sorted(kinds) or 'none'}; allowed: hexahedra or tetrahedra "
                         f"(one kind)")
    kind = kinds.pop()
    offsets, cells = {}, []
    n = 0
    for j, blk in enumerate(msh.cells):
        if blk.type in vol:
            offsets[j] = n
            c = blk.data[:, :vol[blk.type][1]]
            cells.append(c)
            n += len(c)
    cells = np.vstack(cells).astype(np.int64)
    sets = dict(msh.cell_sets)
    phys = msh.cell_data.get("gmsh:physical")
    if not sets and phys is not None and msh.field_data:
        # Gmsh's physical groups: field_data {name: [tag, dim]}, a tag per cell
        dims = {"vertex": 0, "line": 1, "line3": 1, "triangle": 2, "triangle6": 2, "quad": 2, "quad8": 2, "quad9": 2}
        for name, (tag, dim) in ((k, tuple(np.asarray(v).ravel()[:2])) for k, v in msh.field_data.items()):
            sets[name] = [np.flatnonzero(np.asarray(phys[j]) == tag) if dims.get(blk.type, 3) == dim
                          else np.zeros(0, dtype=np.int64) for j, blk in enumerate(msh.cells)]
    if not sets:
        # meshio's cell_sets written as one integer cell_data named "set1-set2-..." (.vtu, .xdmf)
        for k, data in msh.cell_data.items():
            if not k.startswith("gmsh:") and all(np.asarray(v).dtype.kind in "iu" for v in data):
                names = list(dict.fromkeys(k.split("-")))
                for i, name in enumerate(names):
                    sets[name] = [np.flatnonzero(np.asarray(v).ravel() == i) for v in data]
    cell_sets, point_sets = {}, {}
    for name, per_block in sets.items():
        if name.startswith("gmsh:"):
            continue
        vids, pids = [], []
        for j, ids in enumerate(per_block):
            ids = np.asarray(ids, dtype=np.int64)
            if ids.size == 0:
                continue
            if j in offsets:
                vids.append(ids + offsets[j])
            else:
                pids.append(np.asarray(msh.cells[j].data[ids]).ravel())
        if vids:
            cell_sets[name] = np.concatenate(vids)
        if pids:
            point_sets[name] = np.unique(np.concatenate(pids))
    used = np.unique(cells)
    if used.size != len(msh.points):     # drop nodes no volume cell uses (Gmsh's geometry points)
        new = -np.ones(len(msh.points), dtype=np.int64)
        new[used] = np.arange(used.size)
        cells = new[cells]
        point_sets = {k: new[v][new[v] >= 0] for k, v in point_sets.items()}
        pts = msh.points[used]
    else:
        pts = msh.points
    pts = np.asarray(pts, dtype=float)
    if pts.shape[1] == 2:
        pts = np.hstack([pts, np.zeros((len(pts), 1))])
    return ContinuumMesh(pts, cells, kind, cell_sets, point_sets)


def write_mesh(path, mesh: ContinuumMesh) -> Path:
    """Write a mesh with its named regions through meshio, so that :func:`read_mesh` reads them back.

    ``.msh``: Gmsh 2.2 (ASCII), each cell set a physical volume and each point set a physical point
    (``field_data`` ``{name: [tag, dim]}``, ``gmsh:physical`` tags; cell sets must then be disjoint);
    other suffixes: meshio's ``cell_sets`` (``.vtu`` stores them as one integer ``cell_data``).

    Parameters
    ----------
    path : str or Path
    mesh : ContinuumMesh

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        Overlapping cell sets, or cells in none, for ``.msh``.
    """
    path = Path(path)
    if path.suffix.lower() != ".msh":
        meshio.write(path, mesh.to_meshio())
        return path
    tag = np.zeros(len(mesh.cells), dtype=np.int64)
    field_data = {}
    for i, (name, ids) in enumerate(mesh.cell_sets.items(), start=1):
        if np.any(tag[ids] != 0):
            raise ValueError(f"{path}: cell set {name!r} overlaps another; allowed in .msh: disjoint cell sets")
        tag[ids] = i
        field_data[name] = np.array([i, 3])
    if np.any(tag == 0):
        raise ValueError(f"{path}: {int(np.sum(tag == 0))} cells in no cell set; allowed in .msh: every cell in one")
    blocks = [(mesh.cell_type, mesh.cells)]
    tags = [tag]
    for i, (name, ids) in enumerate(mesh.point_sets.items(), start=len(mesh.cell_sets) + 1):
        blocks.append(("vertex", np.asarray(ids, dtype=np.int64).reshape(-1, 1)))
        tags.append(np.full(len(ids), i, dtype=np.int64))
        field_data[name] = np.array([i, 0])
    meshio.write(path, meshio.Mesh(mesh.points, blocks, cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
                                   field_data=field_data), file_format="gmsh22", binary=False)
    return path


# ============================================================================ assembly
def _skfem_mesh(mesh: ContinuumMesh):
    if mesh.cell_type == "hexahedron":
        return MeshHex(mesh.points.T.copy(), mesh.cells[:, _SK_FROM_VTK].T.copy())
    return MeshTet(mesh.points.T.copy(), mesh.cells.T.copy())


def _element(mesh: ContinuumMesh, element: str):
    if mesh.cell_type == "tetra":
        return ElementTetP2()
    if element == "serendipity":
        return ElementHexS2()
    if element == "lagrange":
        return ElementHex2()
    raise ValueError(f"element = {element!r}; allowed: 'serendipity' (20-node hexahedra) or 'lagrange' (27-node)")


def assemble(mesh: ContinuumMesh, materials, element: str = "serendipity", chunk: int = 2000):
    """Stiffness and consistent mass of the solid, three components per scalar DOF.

    Parameters
    ----------
    mesh : ContinuumMesh
    materials : Material or dict of str -> Material
        One material for every cell, or one per cell set (cells in no named set: the entry
        ``"*"``, else an error).
    element : {"serendipity", "lagrange"}
        Quadratic hexahedra with 20 or 27 nodes (tetrahedra: always ``P2``).
    chunk : int
        Cells per vectorised batch (memory ~ ``chunk * (3 n_loc)^2 * 24`` bytes).

    Returns
    -------
    K, M : scipy.sparse.csr_array, shape (3 N, 3 N)
        N/m and kg, DOF ``3 s + i`` is component ``i`` of scalar DOF ``s``.
    basis : skfem.CellBasis
        The scalar basis (DOF locations ``basis.doflocs``, shape (3, N)).

    Raises
    ------
    ValueError
        A cell without a material, an unknown element.
    """
    sk = _skfem_mesh(mesh)
    basis = Basis(sk, _element(mesh, element), intorder=4)   # 3-point Gauss per direction: exact for Q2 x Q2
    ne = sk.t.shape[1]
    lam = np.full(ne, np.nan)
    mu = np.full(ne, np.nan)
    rho = np.full(ne, np.nan)
    if isinstance(materials, Material):
        materials = {"*": materials}
    for name, mat in materials.items():
        if name == "*":
            continue
        if name not in mesh.cell_sets:
            raise ValueError(f"materials: no cell set named {name!r}; the cell sets: "
                             f"{', '.join(mesh.cell_sets) or 'none'}")
        ids = np.asarray(mesh.cell_sets[name], dtype=np.int64)
        lam[ids], mu[ids] = mat.lame
        rho[ids] = mat.density_kg_m3
    if "*" in materials:
        miss = np.isnan(lam)
        lam[miss], mu[miss] = materials["*"].lame
        rho[miss] = materials["*"].density_kg_m3
    if np.any(np.isnan(lam)):
        raise ValueError(f"{int(np.isnan(lam).sum())} cells in no cell set with a material; allowed: a material per "
                         f"cell set, or one for all ('*')")
    G = np.stack([basis.basis[a][0].grad for a in range(len(basis.basis))])      # (nl, 3, ne, nq)
    Nv = np.stack([np.asarray(basis.basis[a][0]) for a in range(len(basis.basis))])    # (nl, ne, nq)
    dx = basis.dx                                                                # (ne, nq)
    nl = G.shape[0]
    edofs = basis.element_dofs                                                   # (nl, ne)
    N3 = 3 * basis.N
    K = scipy.sparse.csr_array((N3, N3))
    M = scipy.sparse.csr_array((N3, N3))
    comp = np.arange(3)
    for s in range(0, ne, chunk):
        e = slice(s, min(ne, s + chunk))
        A = np.einsum("aieq,bjeq,eq->eijab", G[:, :, e], G[:, :, e], dx[e], optimize=True)   # (ce, 3, 3, nl, nl)
        tr = A[:, 0, 0] + A[:, 1, 1] + A[:, 2, 2]
        Ke = (lam[e, None, None, None, None] * A + mu[e, None, None, None, None] * A.transpose(0, 2, 1, 3, 4))
        for i in range(3):
            Ke[:, i, i] += mu[e, None, None] * tr
        Me = rho[e, None, None] * np.einsum("aeq,beq,eq->eab", Nv[:, e], Nv[:, e], dx[e], optimize=True)
        d = edofs[:, e].T                                                        # (ce, nl)
        rows = 3 * d[:, None, None, :, None] + comp[None, :, None, None, None]   # (ce, 3, 1, nl, 1)
        cols = 3 * d[:, None, None, None, :] + comp[None, None, :, None, None]   # (ce, 1, 3, 1, nl)
        rows, cols = np.broadcast_arrays(rows, cols, Ke)[:2]
        K = K + scipy.sparse.csr_array((Ke.ravel(), (rows.ravel(), cols.ravel())), shape=(N3, N3))
        mr = 3 * d[:, :, None, None] + comp[None, None, :, None]                # (ce, nl, 3, 1)
        mc = 3 * d[:, None, None, :] + comp[None, None, :, None]                # (ce, 1, 3, nl)
        Mfull = np.broadcast_to(Me[:, :, None, :], (Me.shape[0], nl, 3, nl))
        mr, mc = np.broadcast_arrays(mr, mc, Mfull)[:2]
        M = M + scipy.sparse.csr_array((Mfull.ravel(), (mr.ravel(), mc.ravel())), shape=(N3, N3))
    return K, M, basis


def mesh_mass(mesh: ContinuumMesh, materials=STEEL) -> float:
    """The solid's mass ``int rho dV`` (kg), by Gauss quadrature on its (trilinear or linear) cells.

    Parameters
    ----------
    mesh : ContinuumMesh
    materials : Material or dict of str -> Material
        As :func:`assemble` (``"*"``: the cells in no named set).

    Raises
    ------
    ValueError
        A cell without a material.
    """
    sk = _skfem_mesh(mesh)
    vol = Basis(sk, ElementHex1() if mesh.cell_type == "hexahedron" else ElementTetP1(), intorder=2).dx.sum(axis=1)
    if isinstance(materials, Material):
        materials = {"*": materials}
    rho = np.full(len(vol), np.nan)
    for name, mat in materials.items():
        if name != "*":
            rho[np.asarray(mesh.cell_sets[name], dtype=np.int64)] = mat.density_kg_m3
    if "*" in materials:
        rho[np.isnan(rho)] = materials["*"].density_kg_m3
    if np.any(np.isnan(rho)):
        raise ValueError(f"{int(np.isnan(rho).sum())} cells in no cell set with a material")
    return float(rho @ vol)


def _entity_dofs(basis, nodes: np.ndarray) -> np.ndarray:
    """Scalar DOFs on entities (nodes, edges, facets, cells) whose vertices all lie in ``nodes``."""
    sk = basis.mesh
    inset = np.zeros(sk.p.shape[1], dtype=bool)
    inset[nodes] = True
    out = [basis.nodal_dofs[:, nodes].ravel()] if basis.nodal_dofs.size else []
    if basis.edge_dofs.size:
        out.append(basis.edge_dofs[:, np.all(inset[sk.edges], axis=0)].ravel())
    if basis.facet_dofs.size:
        out.append(basis.facet_dofs[:, np.all(inset[sk.facets], axis=0)].ravel())
    if basis.interior_dofs.size:
        out.append(basis.interior_dofs[:, np.all(inset[sk.t], axis=0)].ravel())
    return np.unique(np.concatenate(out)) if out else np.zeros(0, dtype=np.int64)


def rigid_body_mass(parts, p0) -> np.ndarray:
    """6 x 6 mass matrix of rigid cylinders (axis ``z``) about ``p0`` in the DOFs ``(U, theta)``.

    Kinetic energy ``1/2 sum_k m_k |U' + theta' x d_k|^2 + 1/2 theta'^T I_k theta'`` (``d_k``: the
    part's centre of mass from ``p0``; ``I_k = diag(m (3R^2 + H^2)/12, same, m R^2 / 2)`` about its
    centre).

    Parameters
    ----------
    parts : sequence of (mass_kg, centre (3,), radius_m, height_m)
    p0 : array_like, shape (3,)
        Reference point (m).

    Returns
    -------
    ndarray, shape (6, 6)
        kg, kg m, kg m^2.
    """
    Mb = np.zeros((6, 6))
    for m, c, R, H in parts:
        d = np.asarray(c, float) - np.asarray(p0, float)
        Gm = np.hstack([np.eye(3), -_cross(d)])            # v_c = U' - d x theta' = U' + theta' x d
        Ic = np.diag([m * (3 * R * R + H * H) / 12.0, m * (3 * R * R + H * H) / 12.0, 0.5 * m * R * R])
        Mb += m * Gm.T @ Gm
        Mb[3:, 3:] += Ic
    return Mb


def _cross(d):
    return np.array([[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]])


# ============================================================================ reduction
@dataclass
class ContinuumInfo:
    """What a build did and what it found.

    Attributes
    ----------
    n_nodes, n_cells, n_dofs : int
        Mesh nodes and cells; reduced DOFs (``u_free`` + the rigid body's 6).
    element : str
    built : bool
        True when the model was built now, False when loaded from the cache.
    build_s : float
        Seconds spent (building, or loading).
    timings_s : dict
        ``assemble``, ``reduce``, ``modes`` (s) of the build that made the model.
    cache_path : str or None
    contact_effective_mass_kg : ndarray, shape (n_c,)
        ``1 / (w M_r^-1 w^T)`` of each contact row over every DOF (kg): the mass an impulse at the
        contact meets.
    body_mass_kg : float
        The rigid body's own mass (kg).
    nodal_shapes : ndarray, shape (n_nodes, 3, n)
        The mode shapes at the mesh's vertices (1/sqrt(kg)).
    frequencies_hz : ndarray, shape (n,)
    """

    n_nodes: int
    n_cells: int
    n_dofs: int
    element: str
    built: bool
    build_s: float
    timings_s: dict
    cache_path: str | None
    contact_effective_mass_kg: np.ndarray
    body_mass_kg: float
    nodal_shapes: np.ndarray
    frequencies_hz: np.ndarray

    def summary(self) -> str:
        """One line: built (and how long each stage took) or loaded from the cache, and where."""
        t = self.timings_s
        how = (f"built in {self.build_s:.2f} s (assemble {t['assemble']:.2f} s, reduce {t['reduce']:.2f} s, "
               f"modes {t['modes']:.2f} s)" if self.built else
               f"loaded from the cache in {self.build_s:.3f} s (its build took "
               f"{t['assemble'] + t['reduce'] + t['modes']:.2f} s)")
        return (f"continuum model: {self.n_cells} cells, {self.n_nodes} nodes, {self.n_dofs} DOFs ({self.element}); "
                f"{how}" + (f"; cache {self.cache_path}" if self.cache_path else ""))


def rigid_motion(points, p0) -> np.ndarray:
    """The rigid-body motion matrix ``R`` (3 n x 6): ``u(p_k) = U + theta x (p_k - p_0)`` for
    ``q = (U, theta)``, rows ``3 k + i`` (component ``i`` of point ``k``).

    Parameters
    ----------
    points : array_like, shape (n, 3)
        Points (m).
    p0 : array_like, shape (3,)
        The reference point (m).

    Returns
    -------
    ndarray, shape (3 n, 6)
        Dimensionless on ``U``, metres on ``theta`` (rad).
    """
    pts = np.asarray(points, float).reshape(-1, 3)
    Rm = np.zeros((3 * len(pts), 6))
    for k, r in enumerate(pts - np.asarray(p0, float)):
        Rm[3 * k:3 * k + 3, :3] = np.eye(3)
        Rm[3 * k:3 * k + 3, 3:] = -_cross(r)                 # theta x r = -r x theta
    return Rm


def _tie(basis, slave_sdofs, p0):
    """The master-slave transformation over the slave DOFs: the nonzero triplets of
    :func:`rigid_motion` at their locations, rows the global DOFs, columns the body's 0..5."""
    Rm = rigid_motion(basis.doflocs[:, slave_sdofs].T, p0)                  # (3 ns, 6)
    glob = (3 * np.asarray(slave_sdofs)[:, None] + np.arange(3)).ravel()
    r, c = np.nonzero(Rm)
    return glob[r], c, Rm[r, c]


def _source_stamp():
    return hashlib.sha256(Path(__file__).read_bytes() + Path(__file__).with_name("matrices.py").read_bytes()).hexdigest()


def cache_dir() -> Path:
    """``$VIBEAM_CACHE_DIR/continuum``, else ``$XDG_CACHE_HOME/vibeam/continuum``, else
    ``~/.cache/vibeam/continuum``."""
    env = os.environ.get("VIBEAM_CACHE_DIR")
    if env:
        return Path(env) / "continuum"
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "vibeam" / "continuum"


def _jsonable(x):
    if isinstance(x, Material):
        return dataclasses.asdict(x)
    if isinstance(x, np.ndarray):
        return {"shape": list(x.shape), "sha": hashlib.sha256(np.ascontiguousarray(x, float).tobytes()).hexdigest()}
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in sorted(x.items(), key=lambda kv: str(kv[0]))}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if dataclasses.is_dataclass(x):
        return {f.name: _jsonable(getattr(x, f.name)) for f in dataclasses.fields(x)}
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


def _write_atomic(path: Path, arrays: dict):
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


_SYSTEM_FIELDS = ("omega", "damping", "participation", "sensor", "contacts", "base_amplitude", "time_unit_s",
                  "length_unit_m", "coordinate_scale", "mass_unit_kg")
_MODEL_ARRAYS = ("shapes", "frequencies_hz", "damping_ratios", "static")


def _save(path, model: MatrixModel, extra: dict):
    arrays = {f"system.{k}": np.asarray(getattr(model.system, k)) for k in _SYSTEM_FIELDS}
    arrays.update({k: getattr(model, k) for k in _MODEL_ARRAYS + ("contact_static",)})
    arrays["dofs"] = np.array(model.dofs)
    arrays["names"] = np.array([model.sensor_name, *model.contact_names])
    arrays["caughey_ratio"] = np.array(model.caughey_ratio)
    arrays.update({f"x.{k}": np.asarray(v) for k, v in extra.items()})
    _write_atomic(Path(path), arrays)


def _load(path):
    with np.load(path, allow_pickle=False) as z:
        sysd = {}
        for k in _SYSTEM_FIELDS:
            v = z[f"system.{k}"]
            sysd[k] = float(v) if v.ndim == 0 else v
        names = [str(s) for s in z["names"]]
        sysd["contact_static"] = np.asarray(z["contact_static"], float)
        model = MatrixModel(ModalSystem(**sysd), tuple(str(s) for s in z["dofs"]), names[0], tuple(names[1:]),
                            *(z[k] for k in _MODEL_ARRAYS), float(z["caughey_ratio"]))
        extra = {k[2:]: z[k] for k in z.files if k.startswith("x.")}
    return model, extra


def build_continuum(mesh, materials=STEEL, n_modes: int = 6, damping_ratios=None, rayleigh=None,
                    clamp="clamp", rigid: str | None = None, body_mass=None, body_point=None,
                    sensor=None, contacts=(), drive=(0.0, 0.0, 1.0), element: str = "serendipity",
                    base_amplitude_m: float = 0.0, f_ref_hz=None, length_m: float = 1.0,
                    cache: bool | str | Path = True, vtu=None, _mesh_bytes: bytes | None = None):
    """A solid's lowest modes as vibeam's modal system, through :func:`build_matrices`.

    Parameters
    ----------
    mesh : ContinuumMesh, str or Path
        The mesh (:func:`rig_mesh`) or a file meshio reads (:func:`read_mesh`; its bytes enter the
        cache key).
    materials : Material or dict of str -> Material
        One material, or one per cell set (``"*"``: the rest).
    n_modes : int
        Modes kept (``>= 1``).
    damping_ratios : float or array_like (n_modes,), optional
        Modal damping ratios.
    rayleigh : (float, float), optional
        ``(a, b)`` of ``C = a M + b K`` (1/s, s; paper Eq. 39: ``(0, D)``).  Exactly one of the two.
    clamp : str or sequence of (str, str)
        Region (point set or cell set) whose facets are held (Dirichlet: every component), or
        ``[(region, components), ...]`` holding only some components of each region (``"yz"``: a
        diaphragm support, free along ``x``; ``"x"``: a symmetry plane normal to ``x``).
    rigid : str or None
        Region tied as one rigid body (six DOFs ``body.ux .. body.rz`` about ``body_point``).
    body_mass : ndarray (6, 6), optional
        Mass matrix of an unmeshed body carried by the rigid region, about ``body_point``
        (:func:`rigid_body_mass`).
    body_point : array_like (3,), optional
        The body's reference point (m); default the rigid region's node centroid.
    sensor : (array_like (3,), array_like (3,))
        ``(point, direction)``: the sensor reads the displacement at ``point`` (interpolated) along the
        unit ``direction``.
    contacts : sequence of (str, array_like (3,), array_like (3,))
        ``(kind, point, normal)``, ``kind`` ``"body"`` (a point of the rigid body: well posed) or
        ``"node"`` (the interpolated displacement of the solid at ``point``: its effective mass goes
        to 0 under refinement).  Empty: the sensor.
    drive : array_like (3,)
        The base's direction of translation (unit).
    element : {"serendipity", "lagrange"}
    base_amplitude_m, f_ref_hz, length_m
        As :func:`build_matrices`.
    cache : bool or path
        True: the user's cache folder (:func:`cache_dir`); a path: that folder; False: none.
    vtu : str or Path, optional
        Also write the mode shapes there (:func:`write_modes`).

    Returns
    -------
    model : MatrixModel
        ``model.system`` is the ModalSystem; ``dofs`` names ``u{x,y,z}.{s}`` (component of scalar DOF
        ``s``) and ``body.{ux,uy,uz,rx,ry,rz}``.
    info : ContinuumInfo

    Raises
    ------
    ValueError
        A region that does not exist, a clamp and a rigid region sharing DOFs, no sensor, bad damping
        (and every error of :func:`build_matrices`).
    KeyError
        A region name not in the mesh.
    """
    t_all = time.perf_counter()
    path = None
    if not isinstance(mesh, ContinuumMesh):
        path = Path(mesh)
        _mesh_bytes = path.read_bytes()
        mesh = read_mesh(path)
    if sensor is None:
        raise ValueError("sensor: give (point, direction)")
    if (damping_ratios is None) == (rayleigh is None):
        raise ValueError("give the damping as damping_ratios or as rayleigh = (a, b), exactly one of them")
    drive = np.asarray(drive, float)
    drive = drive / np.linalg.norm(drive)
    key_src = {"mesh": {"points": mesh.points, "cells": mesh.cells, "type": mesh.cell_type,
                        "cell_sets": {k: np.asarray(v, float) for k, v in mesh.cell_sets.items()},
                        "point_sets": {k: np.asarray(v, float) for k, v in mesh.point_sets.items()}},
               "file": hashlib.sha256(_mesh_bytes).hexdigest() if _mesh_bytes is not None else None,
               "materials": materials, "n_modes": n_modes, "damping_ratios": damping_ratios, "rayleigh": rayleigh,
               "clamp": clamp, "rigid": rigid, "body_mass": body_mass, "body_point": body_point,
               "sensor": sensor, "contacts": contacts, "drive": drive, "element": element,
               "base_amplitude_m": base_amplitude_m, "f_ref_hz": f_ref_hz, "length_m": length_m,
               "source": _source_stamp()}
    key = hashlib.sha256(json.dumps(_jsonable(key_src), sort_keys=True, default=str).encode()).hexdigest()[:32]
    folder = None if cache is False else (cache_dir() if cache is True else Path(cache))
    cpath = None if folder is None else folder / f"{key}.npz"
    if cpath is not None and cpath.is_file():
        try:
            model, extra = _load(cpath)
        except (OSError, ValueError, KeyError):
            model = None                         # a damaged file: build afresh, replace it
        if model is not None:
            info = ContinuumInfo(int(extra["n_nodes"]), int(extra["n_cells"]), len(model.dofs), element, False,
                                 time.perf_counter() - t_all,
                                 {k: float(extra[f"t_{k}"]) for k in ("assemble", "reduce", "modes")},
                                 str(cpath), np.array(extra["m_eff"]), float(extra["body_mass"]),
                                 extra["nodal_shapes"], model.frequencies_hz)
            if vtu is not None:
                _write_vtu(vtu, mesh, extra["nodal_shapes"], model.frequencies_hz)
            return model, info

    t0 = time.perf_counter()
    K, M, basis = assemble(mesh, materials, element)
    t1 = time.perf_counter()
    N = basis.N
    supports = [(clamp, "xyz")] if isinstance(clamp, str) else [(r, c) for r, c in clamp]
    fixed_parts, fixed_s = [], []
    for region, comps in supports:
        if not comps or any(c not in "xyz" for c in comps):
            raise ValueError(f"clamp: components {comps!r} of {region!r}; allowed: a non-empty subset of 'xyz'")
        sd = _entity_dofs(basis, mesh.nodes_of(region))
        fixed_s.append(sd)
        fixed_parts.append((3 * sd[:, None] + np.array(["xyz".index(c) for c in comps])).ravel())
    fixed = np.unique(np.concatenate(fixed_parts))
    fixed_s = np.unique(np.concatenate(fixed_s))
    if rigid is not None:
        rnodes = mesh.nodes_of(rigid)
        slave_s = _entity_dofs(basis, rnodes)
        if np.intersect1d(slave_s, fixed_s).size:
            raise ValueError(f"the rigid region {rigid!r} touches the clamp {clamp!r}; allowed: disjoint regions")
        p0 = (mesh.points[rnodes].mean(axis=0) if body_point is None else np.asarray(body_point, float))
    else:
        slave_s, p0 = np.zeros(0, dtype=np.int64), np.zeros(3)
    slave = (3 * slave_s[:, None] + np.arange(3)).ravel()
    nb = 6 if rigid is not None else 0
    keep = np.ones(3 * N, dtype=bool)
    keep[fixed] = False
    keep[slave] = False
    free = np.flatnonzero(keep)
    nf = free.size
    # T over all 3N DOFs (clamped rows zero): free DOFs -> identity, slaves -> rigid motion
    rows = [free]
    cols = [np.arange(nf)]
    vals = [np.ones(nf)]
    if nb:
        r_, c_, v_ = _tie(basis, slave_s, p0)
        rows.append(r_)
        cols.append(c_ + nf)
        vals.append(v_)
    T = scipy.sparse.csr_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                               shape=(3 * N, nf + nb))
    TT = T.T.tocsr()
    Kr = (TT @ K @ T).tocsr()
    Mr = (TT @ M @ T).tolil()
    rfull = np.tile(drive, N)
    load = TT @ (M @ rfull)
    bm = 0.0
    if nb and body_mass is not None:
        Mb = np.asarray(body_mass, float)
        Mr[nf:, nf:] = Mr[nf:, nf:].toarray() + Mb
        load[nf:] += Mb @ np.concatenate([drive, np.zeros(3)])
        bm = float(Mb[0, 0])
    Mr = Mr.tocsr()
    Kr = (Kr + Kr.T) * 0.5
    Mr = (Mr + Mr.T) * 0.5

    def point_row(point, direction):
        P = basis.probes(np.asarray(point, float).reshape(3, 1)).tocsr()     # (1, N)
        dvec = np.asarray(direction, float)
        dvec = dvec / np.linalg.norm(dvec)
        full = np.zeros(3 * N)
        idx = P.indices
        for c in range(3):
            full[3 * idx + c] += P.data * dvec[c]
        return TT @ full

    def body_row(point, normal):
        if not nb:
            raise ValueError("a contact of kind 'body' needs a rigid region (rigid=...)")
        n_ = np.asarray(normal, float)
        n_ = n_ / np.linalg.norm(n_)
        rr = np.asarray(point, float) - p0
        w = np.zeros(nf + nb)
        w[nf:nf + 3] = n_
        w[nf + 3:] = np.cross(rr, n_)            # n . (theta x r) = theta . (r x n)
        return w

    s_row = point_row(*sensor)
    c_rows = []
    for k, c in enumerate(contacts):
        kind, point, normal = c
        if kind == "body":
            c_rows.append(body_row(point, normal))
        elif kind == "node":
            c_rows.append(point_row(point, normal))
        else:
            raise ValueError(f"contacts[{k}]: kind {kind!r}; allowed: 'body' or 'node'")
    comp = "xyz"
    names = [f"u{comp[i % 3]}.{i // 3}" for i in free] + (
        ["body.ux", "body.uy", "body.uz", "body.rx", "body.ry", "body.rz"] if nb else [])
    t2 = time.perf_counter()
    kw = dict(damping_ratios=damping_ratios) if damping_ratios is not None else dict(
        C=rayleigh[0] * Mr + rayleigh[1] * Kr)
    model = build_matrices(Mr, Kr, Mr=load, dofs=names, sensor=s_row, contacts=c_rows or None, n_modes=n_modes,
                           base_amplitude_m=base_amplitude_m, f_ref_hz=f_ref_hz, length_m=length_m, dense_max=0, **kw)
    rows_eff = c_rows or [s_row]
    lu = scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(Mr))
    m_eff = np.array([1.0 / float(w @ lu.solve(w)) for w in rows_eff])
    t3 = time.perf_counter()
    # the shapes at the mesh's vertices, (N_nodes, 3, n)
    full = T @ model.shapes
    nd = basis.nodal_dofs[0]
    nodal = np.stack([full[3 * nd + c] for c in range(3)], axis=1)
    timings = {"assemble": t1 - t0, "reduce": t2 - t1, "modes": t3 - t2}
    info = ContinuumInfo(len(mesh.points), len(mesh.cells), nf + nb, element, True, time.perf_counter() - t_all,
                         timings, None if cpath is None else str(cpath), m_eff, bm, nodal, model.frequencies_hz)
    if cpath is not None:
        _save(cpath, model, {"n_nodes": info.n_nodes, "n_cells": info.n_cells, "m_eff": m_eff, "body_mass": bm,
                             "nodal_shapes": nodal, **{f"t_{k}": v for k, v in timings.items()}})
    if vtu is not None:
        _write_vtu(vtu, mesh, nodal, model.frequencies_hz)
    return model, info


def _write_vtu(path, mesh: ContinuumMesh, nodal, freqs):
    pdata = {f"mode_{i + 1}": np.ascontiguousarray(nodal[:, :, i]) for i in range(nodal.shape[2])}
    out = meshio.Mesh(mesh.points, [(mesh.cell_type, mesh.cells)], point_data=pdata,
                      field_data={"frequencies_hz": np.asarray(freqs, float)})
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        meshio.write(tmp, out)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def write_modes(path, mesh: ContinuumMesh, info: "ContinuumInfo") -> Path:
    """Write the mode shapes at the mesh's vertices through meshio (``.vtu``; any format by the suffix).

    Point data ``mode_i`` (1-based): vectors, shape (N, 3), 1/sqrt(kg) (mass-normalised: a modal
    coordinate of 1 sqrt(kg) m displaces the vertices by these metres); field data
    ``frequencies_hz`` (in formats that keep field data: ``.xdmf``, not ``.vtu``).  Written atomically (temporary file, fsync, rename).

    Parameters
    ----------
    path : str or Path
    mesh : ContinuumMesh
        The mesh the model was built on.
    info : ContinuumInfo
        Of that build (``info.nodal_shapes``, ``info.frequencies_hz``).

    Returns
    -------
    Path
    """
    return _write_vtu(path, mesh, info.nodal_shapes, info.frequencies_hz)


def build_rig(geometry: RigGeometry = RigGeometry(), h_m: float = 0.0025, nz: int = 1, n_modes: int = 6,
              damping_ratios=0.017, rayleigh=None, element: str = "serendipity", cache=True, vtu=None,
              base_amplitude_m: float = 0.0, f_ref_hz=None):
    """The rig of paper Sec. 5 from its geometry alone: :func:`rig_mesh` + :func:`build_continuum`.

    The strip (``geometry.material``) clamped at ``x = 0``, the disc stack a rigid body tied over its
    footprint (mass matrix :func:`rigid_body_mass` about ``(L_m, 0, 0)``), the sensor the strip's
    mid-plane at ``(L_S, 0, 0)`` along ``z``, the contact the stack's ``+z`` face at
    ``geometry.contact_point()`` along ``z``; ``length_m = L`` (the beam's normalising length).

    Parameters
    ----------
    geometry : RigGeometry
    h_m, nz : float, int
        Mesh size (:func:`rig_mesh`).
    n_modes, damping_ratios, rayleigh, element, cache, vtu, base_amplitude_m, f_ref_hz
        As :func:`build_continuum` (default damping: the paper's beta = 0.017 on every mode).

    Returns
    -------
    model : MatrixModel
    info : ContinuumInfo
    mesh : ContinuumMesh
    """
    g = geometry
    mesh = rig_mesh(g, h_m, nz)
    p0 = np.array([g.mass_position_m, 0.0, 0.0])
    Mb = rigid_body_mass(g.body_parts(), p0)
    model, info = build_continuum(
        mesh, {"strip": g.material}, n_modes=n_modes, damping_ratios=damping_ratios, rayleigh=rayleigh,
        clamp="clamp", rigid="stack", body_mass=Mb, body_point=p0,
        sensor=((g.sensor_position_m, 0.0, 0.0), (0.0, 0.0, 1.0)),
        contacts=[("body", g.contact_point(), (0.0, 0.0, 1.0))], element=element, cache=cache, vtu=vtu,
        base_amplitude_m=base_amplitude_m, f_ref_hz=f_ref_hz, length_m=g.length_m)
    return model, info, mesh
