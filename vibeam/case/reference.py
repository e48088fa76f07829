"""The case-file reference and the catalogue of shipped cases, generated from the schema.

:func:`cases_readme` rewrites two blocks of ``cases/README.md``, between the markers
``<!-- begin generated: catalogue -->`` / ``<!-- end generated: catalogue -->`` (every shipped case
with its ``description``, also printed by ``vibeam cases``) and ``<!-- begin generated: keys -->`` /
``<!-- end generated: keys -->`` (every key of every table with its type, unit, default, allowed
range and meaning); the hand-written text around them is kept.  Types, defaults and ranges
are read from the pydantic models of :mod:`vibeam.case.schema` and :mod:`vibeam.case.contact`;
only the unit and the meaning are written here, in :data:`MEANINGS`, and ``tests/test_docs.py``
fails when a key of the schema has no meaning here, when a meaning names a key the schema does
not have, or when a generated block of ``cases/README.md`` differs from what :func:`cases_readme` generates.
"""
from __future__ import annotations

import typing
from pathlib import Path

import annotated_types as at
from pydantic import BaseModel, create_model

from vibeam.case import schema
from vibeam.case.contact import Bounds, ContactSpec, StopSpec
from vibeam.case.expand import SHORTHAND_KEYS, alias, required_keys
from vibeam.errors import InputError
from vibeam.io.outdir import write_text_file
from vibeam.models.registry import IMPLEMENTED_LAWS
from vibeam.case.uncertainty import UncertaintyParameterSpec, UncertaintySpec

def shorthand_table(fidelity: str) -> type[BaseModel]:
    """The shorthand ``[model]`` table of ``fidelity`` (``"sdof"``, ``"beam"``) as a pydantic model
    for the key reference (not a validator: a shorthand table is validated by its expansion with the
    canonical spec, :func:`vibeam.case.schema._validate_model`).

    Its keys are :data:`vibeam.case.expand.SHORTHAND_KEYS`, each with the type, allowed range and
    default of the canonical key it expands into (:func:`vibeam.case.expand.alias`: ``[model.system]``,
    ``[model.excitation]``, a ``[[model.stop]]`` of :data:`vibeam.case.schema.CANONICAL_SPECS`); the
    law tables ``contact``, ``contact_lower`` are :class:`ContactSpec`, ``stop`` a list of
    :class:`StopSpec`.  A key is required when the table must give it whichever form it is written
    in (:func:`vibeam.case.expand.required_keys`), or when its canonical key is required and no other
    shorthand key gives it (``beta`` and ``damping_ratio`` both give the SDOF's damping ratio: neither
    is required by itself); the others default to the canonical key's default, or none.
    """
    spec = schema.CANONICAL_SPECS[fidelity]
    keys = SHORTHAND_KEYS[fidelity]
    flat = {k: (alias(fidelity, k) or f"system.{k}") for k in keys if k not in ("contact", "contact_lower", "stop")}
    flat["fidelity"] = "system.builder"

    def field(path):
        table, name = path.split(".")[0], path.split(".")[-1]    # stops[i].law.R: a stop table's R
        ann = spec.model_fields["stop" if table.startswith("stops[") else table].annotation
        return (typing.get_args(ann)[0] if table.startswith("stops[") else ann).model_fields[name]

    every_form = set(required_keys(fidelity, {})) & set(required_keys(fidelity, dict.fromkeys(flat, 0.0)))
    fields = {}
    for k in keys:
        if k in ("contact", "contact_lower"):
            fields[k] = (ContactSpec | None, None)
            continue
        if k == "stop":
            fields[k] = (list[StopSpec] | None, None)
            continue
        f = field(flat[k])
        alone = [q for q in flat if flat[q] == flat[k]] == [k]
        required = k in every_form or (f.is_required() and alone)
        ann = typing.Annotated[(f.annotation, *f.metadata)] if f.metadata else f.annotation
        fields[k] = (ann, ...) if required else (ann | None, None if f.is_required() else f.default)
    return create_model(f"{spec.__name__}Shorthand", **fields)


#: the tables of a case file in reading order: (heading, pydantic model, note)
TABLES = (
    ("top level", schema.Case, "the scene's name and what it shows; the tables below"),
    ("[model] (fidelity = \"sdof\")", shorthand_table("sdof"),
     "the coefficient-of-restitution oscillator: nondimensional (paper Eqs. 1-2: beta, B, Delta) or "
     "physical (Eqs. 43-46: natural_frequency_hz, damping_ratio, gap_mm, length_mm, gain, voltage), not both"),
    ("[model] (fidelity = \"beam\")", shorthand_table("beam"),
     "the finite-element cantilever with its attached mass (paper Eqs. 39-41, Fig. 15); lengths in mm"),
    ("[model.discs]", schema.DiscsSpec, "the attached mass as a stack of discs (paper Sec. 5)"),
    ("[model.calibrate]", schema.CalibrateSpec, "EI (and J) fitted to measured bending frequencies"),
    ("[model.contact], [model.contact_lower]", ContactSpec,
     "the contact law of the stop and of a second stop below; the stop's compliant law takes its target "
     "restitution from [model] R, the lower stop's from its own R (default [model] R)"),
    ("[[model.stop]]", StopSpec,
     "one table per stop, each complete: where, its gap, its law with the law's keys and its R (instead of "
     "the shorthand keys R, Delta, gap_mm, ... and [model.contact]); the first upper stop at the attached "
     "mass is the paper's, a beam takes Newton stops at any other point"),
    ("[model] (canonical: [model.system] builder = \"matrices\")", schema.MatricesModelSpec,
     "a structure of your own given by its matrices (issue 58): three tables, the system, its stops and the "
     "drive; the first stop is the reference (upper) stop, from which Q is measured"),
    ("[model.system] (builder = \"matrices\")", schema.SystemSpec,
     "M, K and C (or damping ratios) in SI over named DOFs: inline rows, MatrixMarket files or one .npz "
     "archive, paths relative to the case file; reduced to its lowest modes"),
    ("[[model.stop]] (builder = \"matrices\")", schema.StructureStopSpec,
     "a stop at a named DOF: the reference stop first, a lower stop at its DOF (any law), Newton stops at "
     "other DOFs"),
    ("[model] (canonical: [model.system] builder = \"continuum\")", schema.ContinuumModelSpec,
     "the rig as a 3D elastic continuum from its geometry alone (issue 59): the same three tables as a "
     "structure given by its matrices, the stops on the rigid disc stack"),
    ("[model.system] (builder = \"continuum\")", schema.ContinuumSystemSpec,
     "the strip, its material, the disc stack ([model.system.discs], as [model.discs]) and the mesh; "
     "lengths in mm; built once per geometry and mesh (cached)"),
    ("[model] (canonical: [model.system] builder = \"sdof\" or \"beam\")", schema.SDOFSceneSpec,
     "the paper's two models in the canonical tables (issue 58), what the shorthand above means "
     "(vibeam.case.expand): the system, its stops (the upper stop at the attached mass first, a lower one there "
     "second, a beam's point stops after them) and the drive"),
    ("[model.system] (builder = \"sdof\")", schema.SDOFSystemSpec,
     "the one-mode oscillator: damping_ratio alone (nondimensional, the paper's beta) or with "
     "natural_frequency_hz and length_mm (physical, Eqs. 43-46)"),
    ("[model.system] (builder = \"beam\")", schema.BeamSystemSpec,
     "the FE cantilever: the keys of [model] (fidelity = \"beam\") but its stops and drive; "
     "[model.system.discs], [model.system.calibrate] as [model.discs], [model.calibrate]"),
    ("[[model.stop]] (builder = \"sdof\" or \"beam\")", schema.SceneStopSpec,
     "as [[model.stop]] above; the lower stop at the attached mass (stop[1]) without R nor law has the upper "
     "stop's law"),
    ("[model] (canonical: [model.system] builder = \"mesh\")", schema.MeshModelSpec,
     "a part of your own from a mesh file (issue 59): the same three tables, a Newton stop on a region tied as a "
     "rigid body, a compliant one on a point of the solid too"),
    ("[model.system] (builder = \"mesh\")", schema.MeshSystemSpec,
     "the mesh file (meshio: Gmsh .msh, .vtu, .xdmf, ...; relative to the case file) and its named regions: the "
     "clamp, the materials, a rigid region; points in mm; built once per file and table (cached)"),
    ("[model.system.materials.<region>]", schema.MaterialSpec,
     "the material of a volume region of the mesh (the regions not named: steel)"),
    ("[[model.stop]] (builder = \"mesh\")", schema.MeshStopSpec,
     "where the stop acts: a point of the rigid region or of the solid, and the direction it is met in"),
    ("[model.excitation]", schema.ExcitationSpec, "the harmonic drive of the structure"),
    ("[sweep]", schema.SweepSpec, "the forcing-frequency grid and how each point is simulated"),
    ("[[run]] (every method)", schema.EventRun, "one table per run; keys common to every method"),
    ("[[run]] method = \"event\"", schema.EventRun, "the exact event-driven solver"),
    ("[[run]] method = \"direct\", \"zhuravlev\", \"ivanov\"", schema.ODERun,
     "scipy solve_ivp on the physical, Zhuravlev or Ivanov coordinates (paper Sec. 4.1)"),
    ("[[run]] method = \"averaging\"", schema.AveragingRun, "averaging, paper Eqs. 18-27"),
    ("[[run]] method = \"mapping\"", schema.MappingRun, "pointwise mapping, paper Eqs. 28-37"),
    ("[[run]] method = \"continuation\"", schema.ContinuationRun,
     "pseudo-arclength continuation of periodic orbits with Floquet multipliers and bifurcations"),
    ("[effects]", schema.EffectsSpec, "the effects a scene calls for; each is off unless its table is present"),
    ("[effects.platform]", schema.PlatformSpec, "the shaker platform that carries the clamp (paper Sec. 5.2)"),
    ("[effects.eccentric_impact]", schema.EccentricImpactSpec, "the stop hits off the mass centre"),
    ("[effects.gap_drift]", schema.GapDriftSpec, "the gap changes during a sweep (paper Fig. 21)"),
    ("[effects.restitution_law]", schema.RestitutionLawSpec, "R as a function of the impact velocity (Fig. 26)"),
    ("[effects.sensor]", schema.SensorSpec, "the displacement sensor at L_S and the CoR identification (Sec. 5.1)"),
    ("[assess]", schema.AssessSpec, "assessments written by vibeam run when asked"),
    ("[map]", schema.MapSpec, "a parameter map over frequency x one model key (paper Fig. 18)"),
    ("[basins]", schema.BasinsSpec, "basins of attraction or a census of attractors"),
    ("[uncertainty]", UncertaintySpec, "FRC bands from sampled parameters (vibeam uncertainty; Table 1's R spread)"),
    ("[[uncertainty.parameter]]", UncertaintyParameterSpec,
     "one sampled parameter and its distribution (scipy.stats), in the parameter's case unit"),
    ("[quick]", schema.QuickSpec, "the quick variant (vibeam run --quick; the tests regress it)"),
    ("[regress]", schema.RegressSpec, "tolerances of vibeam regress"),
)

#: keys of [[run]] documented once, under "every method"
RUN_COMMON = ("name", "method", "model", "effects")

_RANGE = "[low, high]"

#: (unit, meaning) of every key, by table heading (see :data:`TABLES`)
MEANINGS: dict[str, dict[str, tuple[str, str]]] = {
    "top level": {
        "name": ("", "the scene's name: the output folder and file stems"),
        "description": ("", "one line saying what the scene shows (printed by vibeam cases)"),
        "model": ("", "the [model] table (below, by fidelity)"),
        "sweep": ("", "the [sweep] table"),
        "run": ("", "the [[run]] tables: one per method and model variant"),
        "regress": ("", "the [regress] table"),
        "effects": ("", "the [effects.*] tables; an effect is off unless its table is present"),
        "assess": ("", "the [assess] table"),
        "quick": ("", "the [quick] table"),
        "map": ("", "the [map] table: a map instead of one sweep per run"),
        "basins": ("", "the [basins] table: basins of attraction written by vibeam run"),
        "uncertainty": ("", "the [uncertainty] table: FRC bands written by vibeam uncertainty"),
    },
    "[model] (fidelity = \"sdof\")": {
        "fidelity": ("", "\"sdof\": the assumed static mode (Eqs. 39-47) or the paper's nondimensional oscillator"),
        "beta": ("1", "viscous damping ratio beta (Eq. 1)"),
        "B": ("1", "base-excitation amplitude B; the forcing is Omega^2 B sin(Omega t) (Eq. 1)"),
        "R": ("1", "coefficient of restitution R of Newton's law q'+ = -R q'- (Eq. 2); the target R of a "
              "compliant law"),
        "Delta": ("1", "gap Delta from the static equilibrium to the stop (Eq. 2; < 0: pre-stressed)"),
        "natural_frequency_hz": ("Hz", "natural frequency f_n of the assumed static mode (Eq. 43)"),
        "damping_ratio": ("1", "damping ratio of the static mode (beta, Eq. 44)"),
        "gap_mm": ("mm", "grazing gap Delta_G at the sensor (Delta = gap_mm / length_mm, Eq. 46)"),
        "length_mm": ("mm", "the sensor's distance L_S from the clamp (the length scale of Eq. 46)"),
        "gain": ("1/V", "normalised shaker gain gamma (B = gamma V, Eq. 45)"),
        "voltage": ("V", "shaker voltage V"),
        "Delta_lower": ("1", "a second stop at q = -Delta_lower below the equilibrium"),
        "gap_lower_mm": ("mm", "a second stop gap_lower_mm below the equilibrium, at the sensor"),
        "contact": ("", "[model.contact]: the stop's law (default Newton's restitution)"),
        "contact_lower": ("", "[model.contact_lower]: the lower stop's law"),
        "stop": ("", "[[model.stop]]: the stops, one table each (below), instead of R, Delta, gap_mm, the lower "
                 "stop's keys and the contact tables"),
    },
    "[model] (fidelity = \"beam\")": {
        "fidelity": ("", "\"beam\": Euler-Bernoulli cantilever (scikit-fem Hermite elements), modal flow"),
        "length_mm": ("mm", "beam length L from the clamp"),
        "sensor_position_mm": ("mm", "sensor position L_S (the FRC's displacement U)"),
        "mass_position_mm": ("mm", "position of the attached mass and of the stop"),
        "width_mm": ("mm", "section width (with thickness_mm, youngs_modulus_gpa, density_kg_m3)"),
        "thickness_mm": ("mm", "section thickness"),
        "youngs_modulus_gpa": ("GPa", "Young's modulus E of the section"),
        "density_kg_m3": ("kg/m^3", "density of the section"),
        "EI_n_m2": ("N m^2", "bending stiffness EI (instead of the section)"),
        "rhoA_kg_m": ("kg/m", "mass per length rho A (instead of the section)"),
        "mass_kg": ("kg", "attached mass M (or [model.discs])"),
        "rotary_inertia_kg_m2": ("kg m^2", "rotary inertia J of the attached mass"),
        "discs": ("", "[model.discs]: the attached mass as discs"),
        "calibrate": ("", "[model.calibrate]: EI, J fitted to measured frequencies"),
        "R": ("1", "coefficient of restitution of Newton's law at the stop; the target R of a compliant law"),
        "gap_mm": ("mm", "grazing gap Delta_G seen at the sensor (as the SDOF rig scenes)"),
        "contact_gap_mm": ("mm", "gap Delta_C at the stop itself (instead of gap_mm)"),
        "gap_lower_mm": ("mm", "a second stop below, its gap seen at the sensor"),
        "contact_gap_lower_mm": ("mm", "a second stop below, its gap at the stop"),
        "contact": ("", "[model.contact]: the stop's law"),
        "contact_lower": ("", "[model.contact_lower]: the lower stop's law"),
        "stop": ("", "[[model.stop]]: the stops, one table each (below); the shorthand keys stand for one or "
                 "two stops at the attached mass"),
        "gain": ("1/V", "normalised shaker gain gamma (base displacement gamma V L_S)"),
        "voltage": ("V", "shaker voltage V"),
        "damping_ratio": ("1", "damping ratio of the first mode (stiffness-proportional D, Eq. 39)"),
        "rayleigh_alpha_1_s": ("1/s", "mass-proportional Rayleigh damping alpha"),
        "n_modes": ("", "retained modes: an integer, \"all\", or \"static\" (the paper's assumed static mode, "
                    "the SDOF of Eqs. 42-47)"),
        "n_elements": ("", "finite elements along the beam"),
    },
    "[model.discs]": {
        "count": ("", "number of discs"),
        "thickness_mm": ("mm", "thickness of one disc"),
        "diameter_mm": ("mm", "disc diameter"),
        "density_kg_m3": ("kg/m^3", "disc density"),
        "mass_kg": ("kg", "measured mass of the stack (overrides the discs' volume times density)"),
    },
    "[model.calibrate]": {
        "f1_hz": ("Hz", "measured first bending frequency (fits EI)"),
        "f2_hz": ("Hz", "measured second bending frequency (fits the rotary inertia J)"),
    },
    "[model.contact], [model.contact_lower]": {
        "law": ("", "one of " + ", ".join(f'"{n}"' for n in IMPLEMENTED_LAWS) + ": \"restitution\" is Newton's "
                "law (Eq. 2), the others compliant laws with a contact phase (vibeam.models.compliant)"),
        "R": ("1", "the lower stop's own R: Newton's, or its compliant law's target (default [model] R)"),
        "stiffness": ("1", "contact stiffness k_c over the oscillator's stiffness (nondimensional scenes)"),
        "stiffness_n_m": ("N/m (N/m^p)", "contact stiffness (physical scenes; Hertz-type laws: N/m^p)"),
        "damping_ratio": ("1", "linear law: damping ratio of the contact phase (else set by [model] R)"),
        "exponent": ("1", "Hertz-type laws: the force exponent p, 1 <= p <= 3 (default 1.5)"),
        "mass_kg": ("kg", "physical SDOF: the effective mass that turns stiffness_n_m into k_c"),
    },
    "[[model.stop]]": {
        "law": ("", "the stop's law, as [model.contact] law (default \"restitution\", Newton's); away from "
                "the attached mass only \"restitution\""),
        "R": ("1", "Newton's coefficient of restitution of the stop, or a compliant law's target R"),
        "stiffness": ("1", "compliant law: contact stiffness over the oscillator's (nondimensional scenes)"),
        "stiffness_n_m": ("N/m (N/m^p)", "compliant law: contact stiffness (physical scenes)"),
        "damping_ratio": ("1", "linear law: damping ratio of the contact phase (else set by R)"),
        "exponent": ("1", "Hertz-type laws: the force exponent p, 1 <= p <= 3"),
        "mass_kg": ("kg", "physical SDOF: the effective mass that turns stiffness_n_m into k_c"),
        "side": ("", "\"upper\": above the point (the paper's side), \"lower\": below it"),
        "position_mm": ("mm", "beam: the stop's point along the beam (default the attached mass)"),
        "gap_mm": ("mm", "gap seen at the sensor (at another point: times the static mode there, Eq. 45)"),
        "contact_gap_mm": ("mm", "beam: gap at the stop itself"),
        "Delta": ("1", "nondimensional SDOF: the gap from the equilibrium (the lower stop's downwards)"),
    },
    "[model] (canonical: [model.system] builder = \"matrices\")": {
        "system": ("", "[model.system]: the structure (below)"),
        "stop": ("", "[[model.stop]]: one table per stop (below), at least one"),
        "excitation": ("", "[model.excitation]: the drive (below)"),
    },
    "[model.system] (builder = \"matrices\")": {
        "builder": ("", "\"matrices\": a structure given by its mass, stiffness and damping matrices"),
        "matrices": ("", "an .npz archive holding M, K and optionally C, dofs, r (path relative to the case file)"),
        "M": ("kg", "mass matrix: inline rows, or a MatrixMarket file"),
        "K": ("N/m", "stiffness matrix: inline rows, or a MatrixMarket file"),
        "C": ("N s/m", "damping matrix (classical: the undamped modes diagonalise it), instead of damping_ratios"),
        "dofs": ("", "the DOFs' names, one per row of M"),
        "damping_ratios": ("1", "modal damping ratios: one for every mode, or one per kept mode"),
        "base": ("", "influence vector of the base translation: \"all\" (every DOF moves with it) or d numbers"),
        "sensor": ("", "the DOF whose displacement is reported (q = its displacement / length_mm)"),
        "n_modes": ("", "the lowest modes kept, or \"all\""),
        "f_ref_hz": ("Hz", "reference frequency of Omega = f / f_ref (default: the first kept mode's)"),
        "length_mm": ("mm", "normalising length of the reported q (default 1 mm)"),
    },
    "[[model.stop]] (builder = \"matrices\")": {
        "law": ("", "the stop's law (default \"restitution\", Newton's); at other DOFs than the reference "
                "stop's only \"restitution\""),
        "R": ("1", "Newton's coefficient of restitution, or a compliant law's target R"),
        "stiffness": ("1", "not for structures (a ratio of the SDOF's)"),
        "stiffness_n_m": ("N/m (N/m^p)", "compliant law: contact stiffness at the DOF"),
        "damping_ratio": ("1", "linear law: damping ratio of the contact phase (else set by R)"),
        "exponent": ("1", "Hertz-type laws: the force exponent p, 1 <= p <= 3"),
        "mass_kg": ("kg", "not for structures (the effective mass is the structure's at the DOF)"),
        "side": ("", "\"upper\": above the DOF, \"lower\": below it; the first stop is upper"),
        "position_mm": ("mm", "not for structures (at places the stop)"),
        "gap_mm": ("mm", "gap seen at the sensor (times the DOF's static ratio K^-1 M r, Eq. 45)"),
        "contact_gap_mm": ("mm", "gap at the DOF itself"),
        "Delta": ("1", "not for structures (nondimensional SDOF scenes)"),
        "at": ("", "the DOF the stop acts on, by name (default the sensor's)"),
    },
    "[model] (canonical: [model.system] builder = \"continuum\")": {
        "system": ("", "[model.system]: the continuum (below)"),
        "stop": ("", "[[model.stop]]: an upper stop on the disc stack, optionally a lower one; at = \"stack\" "
                 "or none"),
        "excitation": ("", "[model.excitation]: the drive (below)"),
    },
    "[model.system] (builder = \"continuum\")": {
        "builder": ("", "\"continuum\": the rig as a 3D linear-elastic solid (scikit-fem, 20-node hexahedra)"),
        "length_mm": ("mm", "free length L of the strip from the clamp (also the normalising length of q)"),
        "width_mm": ("mm", "strip width b"),
        "thickness_mm": ("mm", "strip thickness t"),
        "sensor_position_mm": ("mm", "sensor position L_S on the strip's mid-plane"),
        "mass_position_mm": ("mm", "the disc stack's axis L_m"),
        "youngs_modulus_gpa": ("GPa", "the strip's Young's modulus E"),
        "poisson_ratio": ("1", "the strip's Poisson's ratio nu"),
        "density_kg_m3": ("kg/m^3", "the strip's density"),
        "discs": ("", "[model.system.discs]: the disc stack (keys as [model.discs]), a rigid body tied to the "
                  "strip over its footprint"),
        "discs_above": ("", "discs on the stop's (+z) face (default half of them: the stack's centre of mass "
                        "on the mid-plane)"),
        "contact_offset_mm": ("mm", "[dx, dy] of the contact point on the stack's top face from its axis (the "
                              "paper's eccentric collision, Sec. 7)"),
        "element_size_mm": ("mm", "hexahedron size in the strip's plane (the rig: f1, f2 within 0.3 % of the "
                            "converged ones at 2.5 mm)"),
        "layers": ("", "hexahedra through the thickness (quadratic: one bends exactly)"),
        "n_modes": ("", "the lowest modes kept (the rig's second is torsion, which a centred stop neither "
                    "drives nor sees)"),
        "damping_ratios": ("1", "modal damping ratios: one for every mode, or one per kept mode"),
        "rayleigh": ("1/s, s", "[a, b] of C = a M + b K (paper Eq. 39: [0, D]), instead of damping_ratios"),
        "f_ref_hz": ("Hz", "reference frequency of Omega = f / f_ref (default: the first kept mode's)"),
    },
    "[model] (canonical: [model.system] builder = \"mesh\")": {
        "system": ("", "[model.system]: the part's mesh and regions (below)"),
        "stop": ("", "[[model.stop]]: an upper stop, optionally a lower one at the same point (below)"),
        "excitation": ("", "[model.excitation]: the drive (below)"),
    },
    "[model.system] (builder = \"mesh\")": {
        "builder": ("", "\"mesh\": a part from a mesh file as a 3D linear-elastic solid (scikit-fem, quadratic "
                    "elements on the mesh's hexahedra or tetrahedra)"),
        "file": ("", "the mesh (coordinates in m), any format meshio reads; its named regions (Gmsh physical "
                 "groups, meshio cell sets) name the clamp, materials and rigid region"),
        "clamp": ("", "the held region(s): a name, a list of names (every displacement component held), or a table "
                  "{region = \"<components>\"} holding only those (\"yz\": free along x)"),
        "materials": ("", "[model.system.materials.<region>]: a volume region's material (the rest steel)"),
        "rigid": ("", "a region tied as one rigid body (a pad, a tip mass): where a Newton stop acts, well posed"),
        "body_point_mm": ("mm", "the rigid body's reference point (default the centroid of its region's nodes)"),
        "sensor_mm": ("mm", "the point whose displacement is reported (inside the part)"),
        "sensor_direction": ("1", "the direction the sensor reads along (unit after scaling)"),
        "drive_direction": ("1", "the direction the base translates along"),
        "length_mm": ("mm", "normalising length of the reported q (default 1 mm)"),
        "n_modes": ("", "the lowest modes kept"),
        "damping_ratios": ("1", "modal damping ratios: one for every mode, or one per kept mode"),
        "rayleigh": ("1/s, s", "[a, b] of C = a M + b K (paper Eq. 39: [0, D]), instead of damping_ratios"),
        "f_ref_hz": ("Hz", "reference frequency of Omega = f / f_ref (default: the first kept mode's)"),
        "element": ("", "hexahedra with 20 nodes (\"serendipity\") or 27 (\"lagrange\"); tetrahedra: 10 nodes"),
    },
    "[model.system.materials.<region>]": {
        "youngs_modulus_gpa": ("GPa", "Young's modulus E"),
        "poisson_ratio": ("1", "Poisson's ratio nu"),
        "density_kg_m3": ("kg/m^3", "density"),
    },
    "[[model.stop]] (builder = \"mesh\")": {
        "law": ("", "the stop's law (default \"restitution\", Newton's: on the rigid region only)"),
        "R": ("1", "Newton's coefficient of restitution, or a compliant law's target R"),
        "stiffness": ("1", "not for structures (a ratio of the SDOF's)"),
        "stiffness_n_m": ("N/m (N/m^p)", "compliant law: contact stiffness at the stop's point"),
        "damping_ratio": ("1", "linear law: damping ratio of the contact phase (else set by R)"),
        "exponent": ("1", "Hertz-type laws: the force exponent p, 1 <= p <= 3"),
        "mass_kg": ("kg", "not for structures (the effective mass is the part's at the point)"),
        "side": ("", "\"upper\": met moving along normal, \"lower\": against it; the first stop is upper"),
        "position_mm": ("mm", "not for structures (point_mm places the stop)"),
        "gap_mm": ("mm", "gap seen at the sensor (times the point's static ratio K^-1 M r, Eq. 45)"),
        "contact_gap_mm": ("mm", "gap at the stop's point, along normal"),
        "Delta": ("1", "not for structures (nondimensional SDOF scenes)"),
        "at": ("", "\"body\": a point of the rigid region (default with one), \"node\": the solid's displacement "
               "there (compliant laws only: its effective mass vanishes under refinement)"),
        "point_mm": ("mm", "where the stop acts (the reference stop; a lower stop acts at the same point)"),
        "normal": ("1", "the direction the part moves in towards the stop (default the sensor's)"),
    },
    "[model.excitation]": {
        "kind": ("", "\"base_displacement\" (Y sin 2 pi f t, the paper's shaker), \"base_acceleration\" (a held "
                 "at every frequency) or \"force\" (F0 sin 2 pi f t at the DOF at)"),
        "amplitude_mm": ("mm", "Y, the base's displacement amplitude (base_displacement)"),
        "amplitude_m_s2": ("m/s^2", "a, the base's acceleration amplitude (base_acceleration)"),
        "amplitude_n": ("N", "F0, the force's amplitude (force)"),
        "at": ("", "the DOF the force acts on, along it (force)"),
        "amplitude": ("1", "builder \"sdof\", nondimensional: B, the base's amplitude over L (paper Eq. 1)"),
        "gain": ("1/V", "builders \"sdof\", \"beam\": the shaker's normalised gain gamma (Eq. 46), with voltage"),
        "voltage": ("V", "builders \"sdof\", \"beam\": the shaker's voltage amplitude V (B = gamma V)"),
    },
    "[sweep]": {
        "Omega": ("1", "frequency grid [start, stop, number of points] in Omega = f / f_n"),
        "frequency_hz": ("Hz", "frequency grid [start, stop, number of points] (physical scenes)"),
        "direction": ("", "sweep up, down or both (hysteresis shows with both)"),
        "transient_periods": ("periods", "transient discarded per point; \"auto\": until the stroboscopic "
                              "map settles"),
        "max_transient_periods": ("periods", "bound of an \"auto\" transient"),
        "settle": ("", "end the transient once the stroboscopic map has settled (then transient_periods is "
                   "a maximum); not with \"auto\""),
        "min_transient_periods": ("periods", "transient periods run before settle = true tests the map"),
        "record_periods": ("periods", "periods recorded per point (amplitude, period detection)"),
        "statistics_periods": ("periods", "a non-periodic point's spread is measured over this many periods"),
        "samples_per_period": ("", "output samples per forcing period"),
        "continuation": ("", "each point starts from the previous point's final state"),
        "period_rtol": ("1", "relative tolerance of the period-n detection on the stroboscopic map"),
        "point_time_limit_s": ("s", "a point running longer ends as failed (default: no limit)"),
        "lyapunov": ("", "add each point's Lyapunov spectrum (saltation-matrix variational equations)"),
        "lyapunov_periods": ("periods", "length of the Lyapunov estimate"),
    },
    "[[run]] (every method)": {
        "name": ("", "the run's name (an HDF5 group: no '/', no control characters)"),
        "method": ("", "event, direct, zhuravlev, ivanov, averaging, mapping or continuation"),
        "model": ("", "keys of [model] overridden for this run (e.g. n_modes, R, a contact table)"),
        "effects": ("", "[effects.*] tables overridden for this run"),
    },
    "[[run]] method = \"event\"": {
        "transient_samples": ("", "grid points per forcing period in the discarded transient (steps are sub-steps of at most 1/16 of the natural period; efficiency only, but for integrated hysteretic-Hertz contact phases); a one-mode record with Newton stops whose samples refine this grid steps on it too, the samples inside a step evaluated from the closed-form flow (the same numbers to round-off, and the recurrence then copies a settled record after one cycle)"),
        "chatter_tol": ("1", "a chatter sequence is summed in closed form once its neglected terms are below "
                        "this (Nordmark & Piiroinen 2009)"),
        "max_impacts_per_period": ("", "impact guard: more impacts in one period end the point as failed"),
        "recurrence": ("", "true (default): a transient or record whose state recurs bit for bit is not integrated "
                       "further (whole cycles skipped or copied; a record's cycle that holds or chatters with its "
                       "time held and chatter sequences summed again in the full run's order), with the same "
                       "outputs bit for bit; false "
                       "integrates every period (Newton stops; a check or a timing)"),
    },
    "[[run]] method = \"direct\", \"zhuravlev\", \"ivanov\"": {
        "solver": ("", "the solve_ivp method"),
        "rtol": ("1", "solve_ivp relative tolerance"),
        "atol": ("1", "solve_ivp absolute tolerance"),
        "max_step": ("1", "solve_ivp largest step (nondimensional time)"),
    },
    "[[run]] method = \"averaging\"": {
        "k": ("", "the resonance Omega ~ 2k (Eqs. 18-27)"),
    },
    "[[run]] method = \"mapping\"": {
        "n": ("", "period n of the impact-map fixed point (n impacts in n periods)"),
        "form": ("", "stability by the full (Eqs. 29-32) or simplified (Eqs. 35-37) Jacobian"),
    },
    "[[run]] method = \"continuation\"": {
        "parameter": ("", "Omega, or a numeric model key (B, Delta, R, beta; voltage, gain, gap_mm, "
                      "damping_ratio, R for physical scenes; with a lower stop Delta_lower or gap_lower_mm "
                      "and R_lower)"),
        "range": ("parameter", f"{_RANGE} of the parameter (default the [sweep] range for the frequency)"),
        "at": ("Hz or 1", "forcing frequency of a continuation in another parameter"),
        "start": ("", "start orbits: sweep (settled event run), averaging, linear (non-impacting) or auto (all)"),
        "start_at": ("parameter", "low, high, both ends of the range, or a value"),
        "n": ("", "period of a linear or averaging start"),
        "ds": ("1", "initial pseudo-arclength step"),
        "ds_min": ("1", "smallest step before a branch ends as failed"),
        "ds_max": ("1", "largest step"),
        "max_points": ("", "points per branch"),
        "max_period": ("", "period-doubling branch switching stops at this period"),
        "switch": ("", "switch to the period-2n branch at each period doubling"),
        "curves": ("", "[map] cases: two-parameter curves of folds, period doublings and grazings"),
        "slices": ("", "extra values of the map key that seed the curves"),
        "curve_points": ("", "points per two-parameter curve"),
        "curve_max_period": ("", "curves of orbits up to this period"),
    },
    "[effects]": {
        "platform": ("", "[effects.platform]"),
        "eccentric_impact": ("", "[effects.eccentric_impact]"),
        "gap_drift": ("", "[effects.gap_drift]"),
        "restitution_law": ("", "[effects.restitution_law]"),
        "sensor": ("", "[effects.sensor]"),
    },
    "[effects.platform]": {
        "level": ("", "\"filter\": the platform's transfer function on the base motion; \"coupled\": a platform "
                  "DOF loaded by the beam (beam fidelity)"),
        "frequency_hz": ("Hz", "platform mode frequency (3.25 Hz in the paper)"),
        "damping_ratio": ("1", "platform mode damping ratio"),
        "reference_frequency_hz": ("Hz", "where the filter is normalised to 1 (default the scene's f_n)"),
        "gains": ("Hz, 1", "two measured [[f1_hz, g1], [f2_hz, g2]] that identify the platform mode"),
        "mass_kg": ("kg", "platform mass (level = \"coupled\")"),
    },
    "[effects.eccentric_impact]": {
        "offset_mm": ("mm", "contact point's distance from the mass centre along the beam"),
    },
    "[effects.gap_drift]": {
        "table": ("Hz, mm", "prescribed [[frequency_hz, gap_mm], ...], linear in between"),
        "law": ("", "\"sliding\": the stop slides with the impulse delivered"),
        "slide_mm_per_impulse": ("mm", "slide per normalised impulse of a frequency point"),
        "max_drift_mm": ("mm", "largest drift"),
    },
    "[effects.restitution_law]": {
        "velocity_mm_s": ("mm/s", "pre-impact velocities at the sensor, increasing"),
        "R": ("1", "R at those velocities (piecewise linear, constant beyond the ends)"),
    },
    "[effects.sensor]": {
        "sampling_hz": ("Hz", "sensor sampling rate (5 kHz in the paper)"),
        "noise_mm": ("mm", "standard deviation of Gaussian sensor noise"),
        "seed": ("", "seed of the noise"),
        "identify_R": ("", "run the paper's CoR identification R = -U'+/U'- on the simulated record"),
        "noise_ladder_mm": ("mm", "noise levels at which the identification is repeated"),
        "impacts": ("", "impacts used per point: the first three (paper) or all"),
        "oversample": ("", "recorded samples per sensor sample"),
    },
    "[assess]": {
        "spectra": ("", "windowed FFT of the sensor signals per point with the non-harmonic peaks"),
        "participation": ("", "share of each mode in the sensor displacement and energy"),
        "time_series": ("Hz or 1", "frequencies at which time series and phase portraits are plotted"),
        "peaks": ("", "non-harmonic peaks listed per point"),
        "subharmonic_order": ("", "k/n Omega with n up to this count as harmonics"),
        "mode_tolerance": ("1", "relative distance within which a peak belongs to a mode"),
        "hfc_band": ("Hz or 1", f"{_RANGE}: band of the high-frequency (~103 Hz) component (default 50-500 Hz)"),
        "spectrum_max": ("Hz or 1", "top of the stored spectrum map"),
        "time_series_periods": ("periods", "periods shown in a time series"),
    },
    "[map]": {
        "parameter": ("", "a numeric [model] key (voltage, gap_mm, R, ...; B, Delta, R, beta)"),
        "values": ("key's unit", "[start, stop, number of values] of the parameter"),
    },
    "[basins]": {
        "Omega": ("1", "forcing frequency (a number or a list; default every frequency of the sweep)"),
        "frequency_hz": ("Hz", "forcing frequency (physical scenes)"),
        "grid": ("", "[nx, ny] initial states (default 200 x 200)"),
        "samples": ("", "random initial states instead of a grid: a census of attractors"),
        "seed": ("", "seed of the samples"),
        "x_range": ("1 or mm", f"{_RANGE} of the first coordinate (default a box around the stop)"),
        "y_range": ("1 or mm/s", f"{_RANGE} of the second coordinate"),
        "coordinates": ("", "beam: the two modal state coordinates [i, j] of the grid (default the first "
                        "mode's displacement and velocity), or \"sensor\": U (mm) and U' (mm/s) at the sensor, "
                        "the beam in its static deflection shape"),
        "run": ("", "the run whose model and solver are used (default the first time-domain run)"),
        "recurrences": ("", "consecutive revisits of the same cells that find an attractor"),
        "locate_periods": ("periods", "stroboscopic samples that describe a new attractor"),
        "max_periods": ("periods", "bound of one trajectory; beyond it the state is unsettled"),
        "hit_attractor": ("", "visits of a known attractor's cells that decide a state"),
        "hit_basin": ("", "visits of a known basin's cells that decide a state"),
        "basin_hits": ("", "decide by the basin cells of earlier states"),
        "verify": ("", "labelled states per frequency checked by long simulation (the mislabel rate; 0: none)"),
        "verify_periods": ("periods", "length of each check"),
        "record_periods": ("periods", "simulation describing each attractor (type, amplitude)"),
        "lyapunov_periods": ("periods", "length of each attractor's Lyapunov spectrum (0: none)"),
        "along": ("", "\"frequency\": the census along the forcing frequency; \"map\": at one frequency along "
                  "the [map] parameter's values"),
    },
    "[uncertainty]": {
        "samples": ("", "scrambled Sobol' samples, a power of 2 (default 64); each is a sweep of every sweep run"),
        "seed": ("", "seed of the scrambling (the same seed, the same samples)"),
        "sobol": ("", "first-order and total Sobol' indices of the amplitude and the jump frequency (Saltelli's "
                  "design: samples x (parameters + 2) sweeps; scipy.stats.sobol_indices)"),
        "parameter": ("", "the [[uncertainty.parameter]] tables: one per sampled parameter"),
    },
    "[[uncertainty.parameter]]": {
        "name": ("", "a name or path that [map] accepts (R, gap_mm, stops[1].law.stiffness_n_m, ...)"),
        "distribution": ("", "normal, truncnorm, uniform, lognormal or triangular; its support must stay in "
                         "the parameter's allowed range"),
        "mean": ("key's unit", "mean (normal, lognormal: of the parameter itself; truncnorm: before truncation)"),
        "std": ("key's unit", "standard deviation (normal, truncnorm, lognormal)"),
        "bounds": ("key's unit", f"{_RANGE} (truncnorm, uniform, triangular)"),
        "mode": ("key's unit", "the most likely value (triangular)"),
    },
    "[quick]": {
        "points": ("", "frequency points of the quick variant"),
        "map_values": ("", "values of a [map] parameter kept"),
        "transient_periods": ("periods", "[sweep] transient_periods of the quick variant"),
        "max_transient_periods": ("periods", "[sweep] max_transient_periods of the quick variant"),
        "record_periods": ("periods", "[sweep] record_periods of the quick variant"),
        "statistics_periods": ("periods", "[sweep] statistics_periods of the quick variant"),
    },
    "[regress]": {
        "amplitude_atol": ("FRC unit", "absolute tolerance of a periodic point's amplitude"),
        "amplitude_rtol": ("1", "relative tolerance of a periodic point's amplitude"),
        "period": ("", "the period n must match"),
        "spread_sigmas": ("", "non-periodic points: means within this many standard errors"),
        "spread_range": ("1", "non-periodic points: extremes within this fraction of the range"),
    },
}

_BEAM_SHORT = MEANINGS["[model] (fidelity = \"beam\")"]
MEANINGS.update({
    "[model] (canonical: [model.system] builder = \"sdof\" or \"beam\")": {
        "system": ("", "[model.system]: the oscillator or the beam (below)"),
        "stop": ("", "[[model.stop]]: the SDOF's upper stop and optionally a lower one; the beam's also point stops"),
        "excitation": ("", "[model.excitation]: a base displacement, amplitude (B) or gain and voltage; the "
                       "physical SDOF also amplitude_mm"),
    },
    "[model.system] (builder = \"sdof\")": {
        "builder": ("", "\"sdof\": the paper's one-degree-of-freedom impact oscillator"),
        "damping_ratio": ("1", "the damping ratio, the paper's beta (beta_S of the rig)"),
        "natural_frequency_hz": ("Hz", "f_n of a physical scene (Omega = f / f_n)"),
        "length_mm": ("mm", "normalising length L of a physical scene (gaps and amplitude over L)"),
    },
    "[model.system] (builder = \"beam\")": {
        "builder": ("", "\"beam\": the paper's FE cantilever with its attached mass"),
        **{k: _BEAM_SHORT[k] for k in schema.BeamSystemSpec.model_fields if k != "builder"},
    },
    "[[model.stop]] (builder = \"sdof\" or \"beam\")": dict(
        MEANINGS["[[model.stop]]"],
        R=("1", "Newton's R of the stop, or a compliant law's target R; the lower stop at the attached mass "
                "may omit it (then the upper stop's law)")),
})


def table_keys(heading: str, model: type[BaseModel]) -> list[str]:
    """The keys documented under ``heading``: the model's fields (``[[run]]`` methods without
    the keys common to every run), in declaration order."""
    keys = list(model.model_fields)
    if heading.startswith("[[run]] method"):
        keys = [k for k in keys if k not in RUN_COMMON]
    elif heading.startswith("[[run]] (every"):
        keys = [k for k in keys if k in RUN_COMMON]
    return keys


def _bounds(meta) -> list[str]:
    out, lengths = [], {}
    for m in meta:
        if isinstance(m, Bounds):      # a range a validator checks (R: the law's own function)
            out += [f">= {m.ge:g}", f"<= {m.le:g}"]
        for cls, op, attr in ((at.Ge, ">=", "ge"), (at.Gt, ">", "gt"), (at.Le, "<=", "le"), (at.Lt, "<", "lt")):
            if isinstance(m, cls):
                out.append(f"{op} {getattr(m, attr):g}")
        if isinstance(m, at.MinLen) and m.min_length:
            lengths["min"] = m.min_length
        if isinstance(m, at.MaxLen):
            lengths["max"] = m.max_length
        pattern = getattr(m, "pattern", None)
        if pattern:
            out.append(f"pattern `{pattern}`")
    if lengths.get("min") is not None and lengths.get("min") == lengths.get("max"):
        out.append(f"length {lengths['min']}")
    else:
        out += [f"length {op} {lengths[k]}" for k, op in (("min", ">="), ("max", "<=")) if k in lengths]
    return out


def describe_type(ann, meta=()) -> str:
    """A readable type with its allowed range, e.g. ``number (>= 0, <= 1)`` or ``"up" | "down"``."""
    origin = typing.get_origin(ann)
    args = typing.get_args(ann)
    if origin is typing.Annotated:
        extra = []
        for a in args[1:]:   # annotated_types bounds, or a pydantic Field(...) carrying them
            extra += list(getattr(a, "metadata", [a]))
        return describe_type(args[0], list(meta) + extra)
    bounds = _bounds(meta)
    tail = f" ({', '.join(bounds)})" if bounds else ""
    if origin in (typing.Union, __import__("types").UnionType):
        parts = list(dict.fromkeys(describe_type(a) for a in args if a is not type(None)))
        return " or ".join(parts) + tail
    if origin is typing.Literal:
        return " | ".join(f'"{a}"' if isinstance(a, str) else str(a) for a in args)
    if origin is list:
        return f"list of {describe_type(args[0])}" + tail if args else "list" + tail
    if origin is dict and args:
        return f"table of {describe_type(args[1])} by name" + tail
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return "table"
    name = {float: "number", int: "integer", str: "string", bool: "true/false", dict: "table"}.get(ann, str(ann))
    return name + tail


def _default(field) -> str:
    if field.is_required():
        return "required"
    if field.default_factory is not None:
        v = field.default_factory()
        return "empty" if not v or isinstance(v, BaseModel) else repr(v)
    if field.default is None:
        return "-"
    if isinstance(field.default, bool):
        return str(field.default).lower()
    if isinstance(field.default, str):
        return f'"{field.default}"'
    return f"{field.default!r}"


def key_reference() -> str:
    """The case-file key reference (markdown): one table per case-file table."""
    lines = ["## Case-file keys", "",
             "Generated from the schema (`vibeam.case.reference`); unit `1` is nondimensional.  "
             "A wrong key, type or value is refused with one line naming the file, the key, the value "
             "and what is allowed.", ""]
    for heading, model, note in TABLES:
        lines += [f"### {heading}", "", note[0].upper() + note[1:] + ".", "",
                  "| key | type and allowed values | unit | default | meaning |", "|---|---|---|---|---|"]
        meanings = MEANINGS[heading]
        for k in table_keys(heading, model):
            f = model.model_fields[k]
            unit, meaning = meanings[k]
            typ = describe_type(f.annotation, f.metadata).replace("|", "\\|")
            lines.append(f"| `{k}` | {typ} | {unit} | {_default(f).replace('|', '/')} | {meaning} |")
        lines.append("")
    return "\n".join(lines)


def catalogue(cases_dir) -> list[tuple[str, str, str]]:
    """The shipped cases: ``(file name, fidelity, description)`` sorted by file name.

    Raises
    ------
    vibeam.errors.InputError
        A case file that does not validate (named with its key and value).
    """
    out = []
    for path in sorted(Path(cases_dir).glob("*.toml")):
        case, _ = schema.load_case(path)
        out.append((path.name, str(case.model_spec().fidelity), case.description))   # canonical tables: the builder's
    return out


def catalogue_text(cases_dir) -> str:
    """The catalogue as printed by ``vibeam cases``: one line per case."""
    rows = catalogue(cases_dir)
    width = max(len(n) for n, _, _ in rows)
    return "\n".join(f"{n:<{width}}  {fid:<4}  {d}" for n, fid, d in rows)


#: the generated blocks of ``cases/README.md``, in order; everything outside them is hand-written
BLOCKS = ("catalogue", "keys")


def _markers(name: str) -> tuple[str, str]:
    return f"<!-- begin generated: {name} -->", f"<!-- end generated: {name} -->"


def catalogue_block(cases_dir) -> str:
    """The catalogue of shipped cases as a markdown table (the ``catalogue`` block)."""
    lines = ["| case | fidelity | what it shows |", "|---|---|---|"]
    for name, fid, desc in catalogue(cases_dir):
        lines.append(f"| [`{name}`]({name}) | {fid} | {desc.replace('|', '/')} |")
    return "\n".join(lines)


def generated_blocks(cases_dir) -> dict[str, str]:
    """The content of every generated block of ``cases/README.md``, by block name."""
    return {"catalogue": catalogue_block(cases_dir), "keys": key_reference().rstrip()}


def fill_blocks(text: str, blocks: dict[str, str], source: str = "cases/README.md") -> str:
    """``text`` with the content between each block's markers replaced by ``blocks[name]``.

    The hand-written text outside the markers is kept byte for byte.

    Raises
    ------
    vibeam.errors.InputError
        A block's begin or end marker missing, repeated or out of order (named with ``source``).
    """
    for name, content in blocks.items():
        begin, end = _markers(name)
        if text.count(begin) != 1 or text.count(end) != 1 or text.index(begin) > text.index(end):
            raise InputError(f"{source}: needs exactly one '{begin}' followed by one '{end}'")
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        text = f"{head}{begin}\n{content}\n{end}{tail}"
    return text


def skeleton() -> str:
    """A ``cases/README.md`` with empty generated blocks, for a folder that has none yet."""
    parts = ["# Cases", ""]
    for name in BLOCKS:
        parts += list(_markers(name)) + [""]
    return "\n".join(parts)


def cases_readme(cases_dir, text: str | None = None) -> str:
    """``cases/README.md`` with its generated blocks brought up to date.

    Parameters
    ----------
    cases_dir : path
        The folder of the shipped cases.
    text : str, optional
        The current file's text (default: ``cases_dir/README.md``, or :func:`skeleton` when it
        does not exist); only the blocks between ``<!-- begin generated: NAME -->`` and
        ``<!-- end generated: NAME -->`` (NAME in :data:`BLOCKS`) are rewritten.
    """
    if text is None:
        path = Path(cases_dir) / "README.md"
        text = path.read_text(encoding="utf-8") if path.exists() else skeleton()
    return fill_blocks(text, generated_blocks(cases_dir))


if __name__ == "__main__":   # regenerate cases/README.md next to the shipped cases
    root = Path(__file__).resolve().parents[2] / "cases"
    write_text_file(root / "README.md", cases_readme(root))   # rewrites the generated blocks only
