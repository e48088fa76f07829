"""A structure given by its matrices, built from its case tables (issue 58).

The canonical tables of :class:`vibeam.case.schema.MatricesModelSpec` -- ``[model.system]``
(``builder = "matrices"``), ``[[model.stop]]`` and ``[model.excitation]`` -- to the reduced
structure (:func:`matrix_model`: :func:`vibeam.models.builders.matrices.build_matrices` on the
matrices read by :mod:`vibeam.io.matrices`) and to its scene (:func:`scene`:
:func:`vibeam.models.builders.matrices.structure_scene`, every method of the N-mode model).

Loaded only when a structure is built (``load_case`` stays free of scipy.io and the kernels).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.linalg

from vibeam.case.contact import ContactSpec, beam_law
from vibeam.io.matrices import inline_matrices, read_matrices
from vibeam.errors import CaseError, quote_value
from vibeam.models.builders.continuum import (STEEL, Material, RigGeometry, build_continuum, build_rig, mesh_mass,
                                              read_mesh, write_modes)
from vibeam.models.builders.matrices import MatrixModel, build_matrices, structure_scene
from vibeam.models.contact import Relation, Restitution, Stop
from vibeam.models.scene import Excitation
from vibeam.models.registry import is_compliant

__all__ = ["arrays", "matrix_model", "scene", "rig_geometry", "continuum_model", "modes_report",
           "mesh_model", "mesh_modes_report"]


def arrays(system) -> dict:
    """``{M, K, C, dofs, r, Mr}`` of a ``[model.system]`` table (:class:`vibeam.case.schema.SystemSpec`),
    read and checked: an ``.npz`` archive, MatrixMarket files (absolute paths: the case's relative
    ones were made absolute at load) or inline rows, each by :mod:`vibeam.io.matrices`' one check.

    Raises
    ------
    vibeam.errors.InputError
        A file that cannot be read or holds what is not allowed (one line).
    """
    given = {k: getattr(system, k) for k in ("M", "K", "C") if getattr(system, k) is not None}
    if system.matrices is not None:
        m = read_matrices(system.matrices)
    elif all(isinstance(v, str) for v in given.values()):
        m = read_matrices(given)
    else:
        m = inline_matrices(given)
    dofs = tuple(system.dofs) if system.dofs is not None else m.dofs
    r = system.base if system.base != "all" else (m.r if m.r is not None else "all")
    return {"M": m.M, "K": m.K, "C": m.C, "dofs": dofs, "r": r, "Mr": m.Mr}


def _at(spec, st) -> str:
    return spec.stop_at(st)


def matrix_model(spec) -> MatrixModel:
    """The structure of ``spec`` (:class:`vibeam.case.schema.MatricesModelSpec`) reduced to its
    modes: contact row 0 at the reference stop's DOF, then one row per further stop away from it.

    Raises
    ------
    ValueError
        From :func:`~vibeam.models.builders.matrices.build_matrices` (one line: a DOF that does not
        exist, a damping that couples the modes, ...); :class:`vibeam.errors.InputError` from the reading.
    """
    sy = spec.system
    a = arrays(sy)
    if a["C"] is not None and sy.damping_ratios is not None:
        raise ValueError("give the damping as a matrix C or as damping_ratios, not both")
    others = [_at(spec, st) for st in spec.stop[1 + int(spec.two_sided):]]
    return build_matrices(a["M"], a["K"], C=a["C"], damping_ratios=sy.damping_ratios if a["C"] is None else None,
                          r=a["r"], Mr=a["Mr"], dofs=a["dofs"], sensor=sy.sensor,
                          contacts=[_at(spec, spec.stop[0]), *others], n_modes=sy.n_modes,
                          base_amplitude_m=spec.excitation.base_amplitude_m, f_ref_hz=sy.f_ref_hz,
                          length_m=sy.length_mm * 1e-3)


def scene(spec):
    """The scene of ``spec`` (:func:`vibeam.models.builders.matrices.structure_scene` on
    :func:`matrix_model`): the reference stop (upper) at contact row 0 with its law, a lower stop at
    its DOF with its own (Newton's with its R, or compliant), stops at other DOFs with theirs;
    gaps ``contact_gap_mm`` at the stop, or ``gap_mm`` at the sensor times the DOF's static ratio
    (paper Eq. 45's ``Delta_C = phi Delta_G``); a compliant law in N/m^p (:func:`beam_law`); the
    drive of ``[model.excitation]``.

    Returns
    -------
    vibeam.models.scene.Scene
        Builder ``spec.fidelity`` (``"matrices"``, ``"continuum"``, ``"mesh"``).

    Raises
    ------
    ValueError
        From the reduction or the scene's builder (one line), a force's DOF that does not exist.
    """
    mm = spec.matrix_model()

    def gap_m(st, k):
        mm_gap = st.contact_gap_mm if st.contact_gap_mm is not None else st.gap_mm * float(mm.contact_static[k])
        return mm_gap * 1e-3

    def law_of(st):
        return beam_law(ContactSpec(**st.law_table()), st.R) if is_compliant(st.law) else Restitution(float(st.R))

    up = spec.stop[0]
    compliant = law_of(up) if is_compliant(up.law) else None
    stops = [Stop(Relation(1.0, gap_m(up, 0)), Restitution(float(up.R)) if compliant is None else compliant)]
    if spec.two_sided:
        lo = spec.stop[1]
        stops.append(Stop(Relation(-1.0, gap_m(lo, 0)), law_of(lo)))
    first_point = 1 + int(spec.two_sided)
    # a stop at another DOF holds its own law: Newton's, or a compliant one in N/m^p at its DOF
    stops += [Stop(Relation(1.0 if st.side == "upper" else -1.0, gap_m(st, 1 + j), row=1 + j), law_of(st),
                   f"{st.side} at {_at(spec, st)}")
              for j, st in enumerate(spec.stop[first_point:])]
    ex, excitation, row = spec.excitation, None, None
    if ex.kind != "base_displacement":
        # a base acceleration or a point force (vibeam.models.scene.driven: F = A at every frequency, p = 0)
        excitation = Excitation(ex.kind, ex.amplitude_m_s2 if ex.kind == "base_acceleration" else ex.amplitude_n)
        if ex.kind == "force":
            if ex.at not in mm.dofs:
                raise ValueError(f"excitation.at = {ex.at!r} names no DOF; allowed: one of {', '.join(mm.dofs[:20])}")
            row = mm.modal_row(ex.at)
    return structure_scene(mm, stops, spec.excitation.base_amplitude_m, spec.fidelity, excitation, row)


# ============================================================================ the continuum (issue 59)
def rig_geometry(system):
    """The :class:`vibeam.models.builders.continuum.RigGeometry` of a ``[model.system]`` table with
    ``builder = "continuum"`` (:class:`vibeam.case.schema.ContinuumSystemSpec`; mm to m, GPa to Pa).

    Raises
    ------
    ValueError
        A geometry :class:`~vibeam.models.builders.continuum.RigGeometry` refuses (one line).
    """
    sy, d = system, system.discs
    above = d.count // 2 if sy.discs_above is None else sy.discs_above
    return RigGeometry(length_m=sy.length_mm * 1e-3, width_m=sy.width_mm * 1e-3, thickness_m=sy.thickness_mm * 1e-3,
                       sensor_position_m=sy.sensor_position_mm * 1e-3, mass_position_m=sy.mass_position_mm * 1e-3,
                       disc_count=d.count, discs_above=above, disc_thickness_m=d.thickness_mm * 1e-3,
                       disc_diameter_m=d.diameter_mm * 1e-3, disc_mass_kg=d.mass_kg, disc_density_kg_m3=d.density_kg_m3,
                       material=Material(sy.youngs_modulus_gpa * 1e9, sy.poisson_ratio, sy.density_kg_m3),
                       contact_offset_m=tuple(1e-3 * float(v) for v in sy.contact_offset_mm))


def continuum_model(spec, vtu=None, cache=True):
    """The continuum of ``spec`` (:class:`vibeam.case.schema.ContinuumModelSpec`) reduced to its
    modes: :func:`vibeam.models.builders.continuum.build_rig` on :func:`rig_geometry`, its mesh
    (``element_size_mm``, ``layers``), ``n_modes``, damping, the drive's amplitude, ``f_ref_hz``;
    cached per content hash (a second build loads it).

    Parameters
    ----------
    spec : ContinuumModelSpec
    vtu : str or Path, optional
        Also write the mode shapes there (meshio).
    cache : bool or path
        As :func:`~vibeam.models.builders.continuum.build_continuum`.

    Returns
    -------
    model : vibeam.models.builders.matrices.MatrixModel
        Contact row 0: the stack's top face at the contact point, along ``z``.
    info : vibeam.models.builders.continuum.ContinuumInfo
    mesh : vibeam.models.builders.continuum.ContinuumMesh

    Raises
    ------
    ValueError
        The geometry or the damping refused (one line).
    """
    sy = spec.system
    damping = (dict(damping_ratios=sy.damping_ratios) if sy.rayleigh is None else
               dict(damping_ratios=None, rayleigh=(float(sy.rayleigh[0]), float(sy.rayleigh[1]))))
    return build_rig(rig_geometry(sy), h_m=sy.element_size_mm * 1e-3, nz=sy.layers, n_modes=sy.n_modes,
                     cache=cache, vtu=vtu, base_amplitude_m=spec.excitation.base_amplitude_m, f_ref_hz=sy.f_ref_hz,
                     **damping)


@dataclass
class ContinuumModes:
    """The modes of a continuum (:func:`modes_report`): the arrays ``vibeam modes`` prints.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n,)
    participation : ndarray, shape (n,)
        ``Gamma_i = phi_i^T M r`` (sqrt(kg)): the base load per unit base acceleration on mode i.
    effective_mass_kg : ndarray, shape (n,)
        ``Gamma_i^2`` (kg).
    shapes : ndarray, shape (n_nodes, 3, n)
        At the mesh's vertices (1/sqrt(kg)).
    """

    frequencies_hz: np.ndarray
    participation: np.ndarray
    effective_mass_kg: np.ndarray
    shapes: np.ndarray


def _held_modes(omega, w) -> np.ndarray:
    """Frequencies (Hz) of the kept modes held at the contact row ``w`` (``w . xi = 0``): the
    eigenvalues of ``diag(omega^2)`` on the null space of ``w``."""
    Z = scipy.linalg.null_space(np.asarray(w, float)[None, :])
    lam = np.linalg.eigvalsh(Z.T @ np.diag(np.asarray(omega, float) ** 2) @ Z)
    return np.sqrt(np.maximum(lam, 0.0)) / (2.0 * np.pi)


def _with_modes(spec, n: int):
    """``spec`` with ``n`` modes kept (the damping ratios, when a list, give way to their first value)."""
    sy = spec.system
    ratios = sy.damping_ratios if not isinstance(sy.damping_ratios, list) else float(sy.damping_ratios[0])
    return spec.model_copy(update={"system": sy.model_copy(update={"n_modes": int(n), "damping_ratios": ratios})})


def _report(mm, info, mesh, total_mass_kg: float, kind: str, note: str) -> dict:
    """The modes report of a reduced continuum (:func:`modes_report`, :func:`mesh_modes_report`)."""
    s = mm.system
    G = np.asarray(s.participation, float)
    f = np.asarray(mm.frequencies_hz, float)
    sphi = np.asarray(s.sensor, float)
    return {"modes": ContinuumModes(f, G, G ** 2, info.nodal_shapes),
            "contact": ContinuumModes(_held_modes(2.0 * np.pi * f, s.contacts[0]), np.zeros(0), np.zeros(0),
                                      np.zeros((0, 3, 0))),
            "total_mass_kg": total_mass_kg, "sensor_modal_mass_kg": 1.0 / np.maximum(sphi ** 2, 1e-300),
            "ndof": len(mm.dofs), "info": info, "mesh": mesh, "model": mm, "kind": kind, "contact_note": note,
            "write_vtu": lambda path: write_modes(path, mesh, info)}


def modes_report(spec, n: int = 8) -> dict:
    """``vibeam modes`` of a continuum: its ``n`` lowest modes (participation, effective masses,
    the modal mass at the sensor), the contact modes within them and writers of the shapes.

    Parameters
    ----------
    spec : vibeam.case.schema.ContinuumModelSpec
    n : int
        Modes (>= 1; the case's damping ratios, when a list, give way to their first value).

    Returns
    -------
    dict
        ``modes`` (:class:`ContinuumModes`), ``contact`` (``frequencies_hz`` of the kept modes held at
        the stack's contact point: Rayleigh-Ritz upper bounds of the continuum's own), ``total_mass_kg``
        (the strip and the discs), ``sensor_modal_mass_kg`` ``1 / (s phi_i)^2`` (kg), ``ndof``,
        ``kind`` (a line naming the model and its mesh), ``info``
        (:class:`~vibeam.models.builders.continuum.ContinuumInfo`: built or loaded, how long),
        ``mesh``, ``model`` (the :class:`~vibeam.models.builders.matrices.MatrixModel`),
        and ``write_vtu(path)`` (the shapes through meshio; the figure:
        :func:`vibeam.api.scene.continuum_modes_figure`).

    Raises
    ------
    ValueError
        From the build (one line).
    """
    spec = _with_modes(spec, n)
    mm, info, mesh = continuum_model(spec)
    g = rig_geometry(spec.system)
    strip = g.material.density_kg_m3 * g.length_m * g.width_m * g.thickness_m
    discs = sum(p[0] for p in g.body_parts())
    return _report(mm, info, mesh, strip + discs,
                   f"3D continuum, {info.n_cells} hexahedra of {spec.system.element_size_mm:g} mm, "
                   f"{spec.system.layers} layer(s), {len(mm.dofs)} DOFs",
                   "within the kept modes, the stack held at its contact point")


# ============================================================================ a user's mesh (issue 59)
def _refuse(key: str, value, what: str):
    return CaseError(f"'model.system.{key}' = {quote_value(value)}: {what}")


def mesh_of(system):
    """The :class:`~vibeam.models.builders.continuum.ContinuumMesh` of a ``[model.system]`` table with
    ``builder = "mesh"`` (:class:`vibeam.case.schema.MeshSystemSpec`), read by meshio, its region
    names checked (the clamp's, the rigid region's, the materials').

    Raises
    ------
    vibeam.errors.CaseError
        A file that does not exist or that meshio cannot read as a volume mesh; a region the mesh
        does not have (one line naming the key, the value and the mesh's regions).
    """
    sy = system
    path = Path(sy.file)
    if not path.is_file():
        raise _refuse("file", sy.file, "no such file; allowed: a volume mesh meshio reads (Gmsh .msh, .vtu, "
                                       ".xdmf, ...), its path relative to the case file's folder")
    try:
        mesh = read_mesh(path)
    except Exception as e:           # meshio raises its own errors (and others) on a file it cannot parse
        raise _refuse("file", sy.file, f"cannot be read as a volume mesh ({type(e).__name__}: {e}); allowed: a "
                                       f"volume mesh meshio reads (Gmsh .msh, .vtu, .xdmf, ...)") from None
    regions = ", ".join(sorted(mesh.regions)) or "none"
    for r, _ in sy.clamp_supports():
        if r not in mesh.regions:
            raise _refuse("clamp", r, f"{path.name} has no region of that name; allowed: one of its regions "
                                      f"({regions})")
    if sy.rigid is not None and sy.rigid not in mesh.regions:
        raise _refuse("rigid", sy.rigid, f"{path.name} has no region of that name; allowed: one of its regions "
                                         f"({regions})")
    for r in sy.materials:
        if r not in mesh.cell_sets:
            raise _refuse("materials", r, f"{path.name} has no volume region of that name; allowed: one of its "
                                          f"volume regions ({', '.join(sorted(mesh.cell_sets)) or 'none'}), "
                                          f"the rest steel")
    lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
    tol = 1e-9 * max(float(np.max(hi - lo)), 1e-300)
    p = np.asarray(sy.sensor_mm, float) * 1e-3
    if np.any(p < lo - tol) or np.any(p > hi + tol):
        raise _refuse("sensor_mm", sy.sensor_mm, f"outside {path.name}; allowed: a point of the part, within "
                                                 f"{np.round(lo * 1e3, 6).tolist()} ... {np.round(hi * 1e3, 6).tolist()} mm")
    return mesh


def mesh_materials(system) -> dict:
    """``{region: Material}`` of ``[model.system.materials]`` (GPa to Pa), the rest (``"*"``) steel."""
    out = {r: Material(m.youngs_modulus_gpa * 1e9, m.poisson_ratio, m.density_kg_m3)
           for r, m in system.materials.items()}
    out["*"] = STEEL
    return out


def mesh_model(spec, vtu=None, cache=True):
    """The part of ``spec`` (:class:`vibeam.case.schema.MeshModelSpec`) reduced to its modes:
    :func:`vibeam.models.builders.continuum.build_continuum` on the mesh file (its bytes in the cache
    key), the clamp's regions and components, the materials (steel unless given), the rigid region,
    the sensor, the reference stop's contact (``"body"``: a point of the rigid region; ``"node"``: the
    solid's displacement there) along its normal, ``n_modes``, the damping, the drive.

    Parameters
    ----------
    spec : MeshModelSpec
    vtu : str or Path, optional
        Also write the mode shapes there (meshio).
    cache : bool or path
        As :func:`~vibeam.models.builders.continuum.build_continuum`.

    Returns
    -------
    model : vibeam.models.builders.matrices.MatrixModel
        Contact row 0: the reference stop's point along its normal.
    info : vibeam.models.builders.continuum.ContinuumInfo
    mesh : vibeam.models.builders.continuum.ContinuumMesh

    Raises
    ------
    vibeam.errors.CaseError
        From :func:`mesh_of` (the file, a region, the sensor outside the part); a stop's point
        outside the part (``"node"``).
    ValueError
        From the build (one line: a clamp that touches the rigid region, a damping refused, ...).
    """
    sy = spec.system
    mesh = mesh_of(sy)
    kind, st = spec.stop_kind(spec.stop[0]), spec.stop[0]
    point = np.asarray(st.point_mm, float) * 1e-3
    if kind == "node":
        lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
        if np.any(point < lo - 1e-9) or np.any(point > hi + 1e-9):
            raise CaseError(f"'model.stop[0].point_mm' = {quote_value(st.point_mm)}: outside {Path(sy.file).name}; "
                            f"allowed with at = \"node\": a point of the part")
    damping = (dict(damping_ratios=sy.damping_ratios) if sy.rayleigh is None else
               dict(damping_ratios=None, rayleigh=(float(sy.rayleigh[0]), float(sy.rayleigh[1]))))
    model, info = build_continuum(
        Path(sy.file), mesh_materials(sy), n_modes=sy.n_modes,
        clamp=sy.clamp if isinstance(sy.clamp, str) else sy.clamp_supports(),
        rigid=sy.rigid, body_point=None if sy.body_point_mm is None else np.asarray(sy.body_point_mm, float) * 1e-3,
        sensor=(np.asarray(sy.sensor_mm, float) * 1e-3, np.asarray(sy.sensor_direction, float)),
        contacts=[(kind, point, np.asarray(spec.stop_normal(), float))],
        drive=np.asarray(sy.drive_direction, float), element=sy.element,
        base_amplitude_m=spec.excitation.base_amplitude_m, f_ref_hz=sy.f_ref_hz, length_m=sy.length_mm * 1e-3,
        cache=cache, vtu=vtu, **damping)
    return model, info, mesh


def mesh_modes_report(spec, n: int = 8) -> dict:
    """``vibeam modes`` of a user's mesh: as :func:`modes_report` (the contact modes: the kept modes
    held at the reference stop's point; the total mass ``int rho dV`` of the mesh).

    Raises
    ------
    vibeam.errors.CaseError, ValueError
        From :func:`mesh_model`.
    """
    spec = _with_modes(spec, n)
    mm, info, mesh = mesh_model(spec)
    cells = "hexahedra" if mesh.cell_type == "hexahedron" else "tetrahedra"
    return _report(mm, info, mesh, mesh_mass(mesh, mesh_materials(spec.system)),
                   f"3D continuum from {Path(spec.system.file).name}, {info.n_cells} {cells}, {len(mm.dofs)} DOFs",
                   f"within the kept modes, held at the stop's point ({spec.stop_at(spec.stop[0])})")
