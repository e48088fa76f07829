"""Beam scenes: from a ``fidelity = "beam"`` case table to the FE model, its
static-mode SDOF reduction (``vibeam derive``) and its modes (``vibeam modes``).

Conversions (paper Secs. 5-6):

* gain: the case gives the paper's normalised gamma (1/V, Eq. 46); the base
  displacement per volt is ``gamma~ = gamma phi(x_m) L`` (m/V), so the base
  motion is ``b = gamma~ V sin(Omega~ t~)`` (Eq. 38);
* damping: ``damping_ratio`` is the ratio of the first FE mode; the
  stiffness-proportional coefficient of Eq. 39 is ``D = 2 beta / omega_1``
  (so mode i has ``zeta_i = D omega_i / 2``);
* gap: ``gap_mm`` is the grazing gap at the sensor ``Delta_G``, the gap at the
  stop is ``Delta_C = phi(x_m) Delta_G`` (Eq. 45 and Fig. 16).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.linalg

from vibeam.errors import CaseError
from vibeam.models.builders.beam_fe import BeamFE, BeamGeometry, shared_calibration, shared_fe
from vibeam.models.builders.beam import contact_row, fe_beam, mass_stops, static_mode_beam
from vibeam.models.builders.matrices import modal_scene
from vibeam.models.contact import Relation, Restitution, Stop
from vibeam.models.registry import fidelity, with_capability
from vibeam.models.scene import Excitation
from vibeam.reductions.modal import modal_reduction
from vibeam.reductions.static_mode import reduce_static_mode, static_mode_shape


@dataclass(frozen=True)
class BeamScene:
    """Everything derived from a beam case table (SI units)."""

    geometry: object          # vibeam.models.builders.beam_fe.BeamGeometry (calibrated if asked)
    calibration: object       # vibeam.models.builders.beam_fe.Calibration or None
    damping_D_s: float
    f1_hz: float              # first FE bending frequency of the (calibrated) model
    phi_at_mass: float
    Delta_G_m: float
    Delta_C_m: float
    gamma_tilde_m_per_V: float
    base_amplitude_m: float
    Delta_C_lower_m: float | None = None    # a second stop below (at the contact point)


# ----------------------------------------------------------------------------- continuation keys
#: case keys of a beam scene that change the FE model (modes, shapes): not continuable
REBUILD_KEYS = ("length_mm", "sensor_position_mm", "mass_position_mm", "width_mm",
                "thickness_mm", "youngs_modulus_gpa", "density_kg_m3", "EI_n_m2", "rhoA_kg_m",
                "mass_kg", "rotary_inertia_kg_m2", "discs", "calibrate", "n_modes", "n_elements")


def conversions(spec, scene, gain_per_V: float | None = None,
                voltage: float | None = None) -> dict:
    """Affine map of the physical case keys onto paths into a beam scene, the parameters of its
    shooting problem (:class:`vibeam.models.core.scene_shooting.SceneShooting`).

    ``value at the path = scale * key`` for every key in the table, so a derivative with respect
    to the key is ``scale`` times the path's (chain rule).

    Parameters
    ----------
    spec : vibeam.case.schema.BeamSceneSpec
        The case's beam table (its Rayleigh ``D`` and ``alpha``: :func:`scene_of`).
    scene : vibeam.models.scene.Scene
        Its scene (:func:`scene`).
    gain_per_V : float, optional
        The case's ``gain`` (the paper's normalised gamma, 1/V); needed for ``voltage``.
    voltage : float, optional
        The case's ``voltage`` (V); needed for ``gain``.

    Returns
    -------
    dict
        ``key -> (path, scale, damping)``, ``damping`` the ``(value, d c / d p)`` of a
        ``system.damping`` path (None for the others):

        * ``frequency_hz`` -> ``Omega``, ``1 / f_ref``;
        * ``voltage`` -> ``system.base_amplitude`` (m), ``gamma~ = gain phi(x_m) L`` (m/V, Eq. 46
          inverted, :func:`vibeam.case.beamscene.scene_of`); ``gain`` -> the same, ``V phi(x_m) L``;
        * ``gap_mm`` (grazing gap at the sensor) -> ``stops[0].relation.offset`` (m),
          ``1e-3 phi(x_m)`` (Eq. 45: ``Delta_C = phi(x_m) Delta_G``); ``contact_gap_mm`` -> the
          same, ``1e-3``; the lower stop's ``gap_lower_mm``, ``contact_gap_lower_mm`` ->
          ``stops[1].relation.offset``;
        * ``damping_ratio`` -> ``system.damping`` in ``D = 2 beta / omega_1`` (Eq. 39, ``omega_1 =
          omega_ref``, the first FE mode of a built scene), ``2 / omega_ref``: the modal damping
          ``c_i = (alpha + D omega_i^2) / omega_ref`` moves along ``omega_ref (omega_i /
          omega_ref)^2``; ``rayleigh_alpha_1_s`` -> ``system.damping`` in alpha, 1, along
          ``1 / omega_ref`` (the static mode has no alpha: 0);
        * ``R`` -> ``stops[0].law.R`` (and the lower stop's R when its law is the upper
          stop's), 1; ``R_lower`` -> ``stops[1].law.R``, 1.
    """
    sy = scene.system
    L = float(sy.length_unit_m)
    phim = float(sy.contact_static[0])
    f_ref = float(sy.reference_hz)
    om_ref = 2 * math.pi * f_ref
    mass = [st for st in scene.stops if st.relation.row == 0]
    two = len(mass) == 2
    R = ("stops[0].law.R", "stops[1].law.R") if two and mass[1].law is mass[0].law else "stops[0].law.R"
    tab = {"Omega": ("Omega", 1.0, None), "frequency_hz": ("Omega", 1.0 / f_ref, None),
           "gap_mm": ("stops[0].relation.offset", 1e-3 * phim, None),
           "contact_gap_mm": ("stops[0].relation.offset", 1e-3, None), "R": (R, 1.0, None)}
    if two:
        tab.update(gap_lower_mm=("stops[1].relation.offset", 1e-3 * phim, None),
                   contact_gap_lower_mm=("stops[1].relation.offset", 1e-3, None),
                   R_lower=("stops[1].law.R", 1.0, None))
    # the Rayleigh damping of Eq. 39
    alpha = 0.0 if spec.system.n_modes == "static" else float(spec.system.rayleigh_alpha_1_s)
    tab["damping_ratio"] = ("system.damping", 2.0 / om_ref, (float(scene_of(spec).damping_D_s), om_ref * sy.omega ** 2))
    tab["rayleigh_alpha_1_s"] = ("system.damping", 1.0, (alpha, np.full(sy.omega.shape[0], 1.0 / om_ref)))
    if gain_per_V is not None:
        tab["voltage"] = ("system.base_amplitude", float(gain_per_V) * phim * L, None)
    if voltage is not None:
        tab["gain"] = ("system.base_amplitude", float(voltage) * phim * L, None)
    return tab


def geometry_of(spec):
    """BeamGeometry of a :class:`vibeam.case.schema.BeamSceneSpec` before calibration."""
    sy = spec.system
    kw = dict(length_m=sy.length_mm * 1e-3, mass_position_m=sy.mass_position_mm * 1e-3,
              sensor_position_m=sy.sensor_position_mm * 1e-3)
    if sy.EI_n_m2 is not None:
        kw.update(EI_n_m2=sy.EI_n_m2, rhoA_kg_m=sy.rhoA_kg_m)
    else:
        b, t = sy.width_mm * 1e-3, sy.thickness_mm * 1e-3
        kw.update(EI_n_m2=sy.youngs_modulus_gpa * 1e9 * b * t**3 / 12.0,
                  rhoA_kg_m=sy.density_kg_m3 * b * t)
    if sy.discs is not None:
        d = sy.discs
        return BeamGeometry.with_discs(d.count, d.thickness_mm * 1e-3, d.diameter_mm * 1e-3,
                                       d.density_kg_m3, mass_kg=d.mass_kg, **kw)
    return BeamGeometry(mass_kg=sy.mass_kg, rotary_inertia_kg_m2=sy.rotary_inertia_kg_m2, **kw)


def scene_of(spec) -> BeamScene:
    """Calibrate (if asked), damping, gap and gain of a beam case table."""
    g = geometry_of(spec)
    sy = spec.system
    cal = None
    if sy.calibrate is not None:
        cal = shared_calibration(g, sy.calibrate.f1_hz, sy.calibrate.f2_hz, n_elements=sy.n_elements)
        g = cal.geometry
    f = shared_fe(g, n_elements=sy.n_elements).modes(1).frequencies_hz
    if f.size == 0 or not (np.isfinite(f[0]) and f[0] > 0.0):
        raise ValueError(f"the FE model has no positive finite first frequency (EI = {g.EI_n_m2:g} N m^2, rho A = "
                         f"{g.rhoA_kg_m:g} kg/m, m = {g.mass_kg:g} kg, L = {g.length_m:g} m)")
    f1 = float(f[0])
    D = 2.0 * sy.damping_ratio / (2 * math.pi * f1)
    L = g.length_m
    phim = float(static_mode_shape(g.mass_position_m / L, g.mass_position_m / L, g.sensor_position_m / L))
    up = spec.stop[0]
    if up.gap_mm is not None:
        DG = up.gap_mm * 1e-3
        DC = DG * phim
    else:
        DC = up.contact_gap_mm * 1e-3
        DG = DC / phim
    gain, voltage = spec.excitation.shaker()        # (0, 0) for a base acceleration: no gamma V
    gt = gain * phim * L
    DCl = None
    lo = spec.stop[1] if spec.two_sided else None
    if lo is not None and lo.gap_mm is not None:
        DCl = lo.gap_mm * 1e-3 * phim
    elif lo is not None:
        DCl = lo.contact_gap_mm * 1e-3
    return BeamScene(geometry=g, calibration=cal, damping_D_s=D, f1_hz=f1, phi_at_mass=phim,
                     Delta_G_m=DG, Delta_C_m=DC, gamma_tilde_m_per_V=gt, base_amplitude_m=gt * voltage,
                     Delta_C_lower_m=DCl)


def scene(spec, law, lower_law=None):
    """The scene of a beam case table: its FE modes (or the static mode, ``n_modes = "static"``), its
    stops and its drive (:mod:`vibeam.models.builders.beam`).

    Parameters
    ----------
    spec : vibeam.case.schema.BeamSceneSpec
    law, lower_law : law
        The SI laws of the stops at the attached mass (the lower one's None: the upper one's).

    Returns
    -------
    vibeam.models.scene.Scene
    """
    sc = scene_of(spec)
    sy = spec.system
    stops = mass_stops(sc.Delta_C_m, law, sc.Delta_C_lower_m, lower_law)
    if sy.n_modes == "static":
        # the paper's SDOF reduction as a one-shape model (Eqs. 42-47, beam mass excluded);
        # the reference frequency stays the FE f_1 so both fidelities share one grid
        return static_mode_beam(sc.geometry, stops, point_stops(spec, sc), sc.base_amplitude_m, sc.damping_D_s,
                                sc.f1_hz, excitation=excitation(spec))
    fe = shared_fe(sc.geometry, n_elements=sy.n_elements, damping_D_s=sc.damping_D_s,
                   rayleigh_alpha_1_s=sy.rayleigh_alpha_1_s)
    return fe_beam(fe, sy.n_modes, stops, point_stops(spec, sc), sc.base_amplitude_m, sc.f1_hz,
                   excitation=excitation(spec))


def excitation(spec):
    """The drive of a beam table other than the shaker's base displacement ``gamma V``:
    ``[model.excitation] kind = "base_acceleration"`` (the spec's ``drive``, ``(kind, a)`` in
    m/s^2) as an :class:`~vibeam.models.scene.Excitation`, else None."""
    drive = getattr(spec, "drive", None)
    return None if drive is None else Excitation(*drive)


def point_stops(spec, sc) -> list:
    """The scene's stops away from the attached mass (``[[model.stop]]`` with ``position_mm``) as
    ``(x, stop)`` pairs (position in m, :class:`~vibeam.models.contact.Stop`): the gap at the stop is ``contact_gap_mm``, or
    ``gap_mm`` seen at the sensor times the static mode ``phi(x)`` at the stop's point (``phi(L_S)
    = 1``; Eq. 45 at another point)."""
    out = []
    g = sc.geometry
    L = g.length_m
    for i, p in enumerate(spec.point_stop_tables):
        x = p.position_mm * 1e-3
        if p.contact_gap_mm is not None:
            gap = p.contact_gap_mm * 1e-3
        else:
            gap = p.gap_mm * 1e-3 * float(static_mode_shape(x / L, g.mass_position_m / L, g.sensor_position_m / L))
        out.append((x, Stop(Relation(1.0 if p.side == "upper" else -1.0, gap), Restitution(p.R),
                            f"{p.side} at {p.position_mm:g} mm")))
    return out


def beam_spec(case, command: str = "derive"):
    """The model spec of a scene with a finite-element beam (capability ``fe_model``: ``vibeam
    derive``) or whose modes can be reported (``mode_shapes``: ``vibeam modes``).

    Parameters
    ----------
    case : vibeam.case.schema.Case
    command : str
        The command named in the message (``derive``, ``modes``).

    Raises
    ------
    vibeam.errors.CaseError
        If the scene's fidelity has no finite-element model (one line naming the key, the
        value and the fidelities allowed).
    """
    spec = case.model_spec()
    flag = "mode_shapes" if command == "modes" else "fe_model"
    if not getattr(fidelity(spec.fidelity), flag):
        fe = " or ".join(f'fidelity = "{n}"' for n in with_capability(flag))
        what = ("a scene whose modes it can report (" if flag == "mode_shapes" else
                "a beam scene, one with a finite-element model (")
        raise CaseError(f"'model.fidelity' = {spec.fidelity!r}: `vibeam {command}` needs {what}{fe})")
    return spec


def derive(spec) -> dict:
    """SDOF parameters of a beam scene by the assumed static mode (paper Eqs. 42-46).

    Parameters
    ----------
    spec : model spec or vibeam.case.schema.Case
        A beam scene's ``[model]`` spec, or a case (its spec through :func:`beam_spec`:
        CaseError if it is not a beam scene).

    Returns
    -------
    dict
        ``scene`` (:class:`BeamScene`), ``reduction`` (StaticModeReduction,
        beam mass excluded as in the paper), ``with_beam_mass`` (the same with
        the beam's modal mass) and ``rows``: (name, value, unit, source).
    """
    if hasattr(spec, "model_spec"):            # a case
        spec = beam_spec(spec, "derive")
    sc = scene_of(spec)
    red = reduce_static_mode(sc.geometry, damping_D_s=sc.damping_D_s, gap_contact_m=sc.Delta_C_m,
                             gamma_tilde_m_per_V=sc.gamma_tilde_m_per_V)
    red_b = reduce_static_mode(sc.geometry, damping_D_s=sc.damping_D_s, gap_contact_m=sc.Delta_C_m,
                               gamma_tilde_m_per_V=sc.gamma_tilde_m_per_V, include_beam_mass=True)
    g = sc.geometry
    rows = [
        ("EI", g.EI_n_m2, "N m^2", "calibrated (Sec. 5)" if sc.calibration else "case"),
        ("rho A", g.rhoA_kg_m, "kg/m", "case"),
        ("m", g.mass_kg, "kg", "case"),
        ("J", g.rotary_inertia_kg_m2, "kg m^2", "calibrated (Sec. 5)" if sc.calibration else "case"),
        ("phi(x_m)", red.phi_at_mass, "1", "static mode, phi(x_S) = 1 (Eq. 42)"),
        ("M_S", red.M_S_kg, "kg", "m phi(x_m)^2 (Eq. 45)"),
        ("K_S", red.K_S_n_m, "N/m", "EI/L^3 int phi''^2 dx (Eq. 46)"),
        ("omega_n", red.omega_n_rad_s, "rad/s", "sqrt(K_S / M_S) (Eq. 45)"),
        ("f_n", red.f_n_hz, "Hz", "omega_n / 2 pi"),
        ("D", sc.damping_D_s, "s", "2 beta_1 / omega_1 of the FE model (Eq. 39)"),
        ("beta_S", red.beta_S, "1", "D omega_n / 2 (Eq. 44)"),
        ("gamma~", sc.gamma_tilde_m_per_V, "m/V", "gamma phi(x_m) L (Eq. 46 inverted)"),
        ("gamma", red.gamma_per_V, "1/V", "gamma~ / (phi(x_m) L) (Eq. 46)"),
        ("B", red.gamma_per_V * spec.excitation.shaker()[1], "1", "gamma V (Eq. 43)"),
        ("Delta_C", sc.Delta_C_m * 1e3, "mm", "gap at the stop"),
        ("Delta_G", red.Delta_G_m * 1e3, "mm", "Delta_C / phi(x_m), gap at the sensor"),
        ("Delta", red.Delta, "1", "Delta_G / L (Eq. 45)"),
        ("f_1 (FE)", sc.f1_hz, "Hz", "first bending mode of the FE model"),
        ("f_n - f_1", red.f_n_hz - sc.f1_hz, "Hz",
         f"{(red.f_n_hz / sc.f1_hz - 1) * 100:+.2f} % (static mode neglects the beam's mass)"),
        ("f_n with beam mass", red_b.f_n_hz, "Hz", f"{(red_b.f_n_hz / sc.f1_hz - 1) * 100:+.2f} % vs FE"),
    ]
    drive = getattr(spec, "drive", None)
    if drive is not None:    # a base acceleration: no gamma V; the SDOF's B = a / ((2 pi f)^2 L) follows f
        rows = [r for r in rows if r[0] not in ("gamma~", "gamma", "B")]
        rows.insert(11, ("a", drive[1], "m/s^2", "base acceleration held at every f ([model.excitation]; "
                                                 "B = a / ((2 pi f)^2 L) at f, not Eq. 43)"))
    if sc.Delta_C_lower_m is not None:   # a second stop below: the same static-mode conversion
        DGl = sc.Delta_C_lower_m / red.phi_at_mass
        rows += [("Delta_C,lower", sc.Delta_C_lower_m * 1e3, "mm", "lower stop's gap at the stop"),
                 ("Delta_G,lower", DGl * 1e3, "mm", "Delta_C,lower / phi(x_m), at the sensor"),
                 ("Delta_lower", DGl / red.length_m, "1", "Delta_G,lower / L (Eq. 45)")]
    return {"scene": sc, "reduction": red, "with_beam_mass": red_b, "rows": rows}


def sdof_case_text(case, spec, red, sc) -> str:
    """TOML of the SDOF scene that the static-mode reduction gives for ``case``."""
    sw = case.sweep
    grid = (f"frequency_hz = [{sw.frequency_hz[0]}, {sw.frequency_hz[1]}, {int(sw.frequency_hz[2])}]"
            if sw.frequency_hz is not None else
            f"frequency_hz = [{sw.Omega[0] * sc.f1_hz:.6g}, {sw.Omega[1] * sc.f1_hz:.6g}, {int(sw.Omega[2])}]")
    return f"""# SDOF scene derived by `vibeam derive` from {case.name} (assumed static mode, paper Eqs. 42-46)
name = "{case.name}-sdof"
description = "static-mode SDOF reduction of {case.name}"

[model]
fidelity = "sdof"
natural_frequency_hz = {red.f_n_hz:.10g}
damping_ratio = {red.beta_S:.10g}
R = {spec.stop[0].R}
gap_mm = {red.Delta_G_m * 1e3:.10g}
length_mm = {red.length_m * 1e3:.10g}
gain = {red.gamma_per_V:.10g}
voltage = {spec.excitation.shaker()[1]}
{_lower_stop_text(spec, red, sc)}
[sweep]
{grid}
direction = "{sw.direction}"
transient_periods = {sw.transient_periods!r}
max_transient_periods = {sw.max_transient_periods}
record_periods = {sw.record_periods}

[[run]]
name = "sdof"
method = "event"
"""


def _lower_stop_text(spec, red, sc) -> str:
    """``gap_lower_mm`` and ``[model.contact_lower]`` lines of a derived SDOF case ('' for one stop)."""
    if sc.Delta_C_lower_m is None:
        return ""
    text = f"gap_lower_mm = {sc.Delta_C_lower_m / red.phi_at_mass * 1e3:.10g}\n"
    R = spec.stop[1].R           # the lower stop's own R (None: its law follows the upper stop's)
    if R is not None:
        text += f"\n[model.contact_lower]\nR = {R}\n"
    return text


def modes_report(spec, n: int = 8) -> dict:
    """Modes, participation and effective masses for base excitation, and contact modes."""
    sc = scene_of(spec)
    fe = BeamFE(sc.geometry, n_elements=spec.system.n_elements, damping_D_s=sc.damping_D_s,
                rayleigh_alpha_1_s=spec.system.rayleigh_alpha_1_s)
    n = min(n, fe.ndof)
    md = fe.modes(n)
    cm = fe.contact_modes(min(n, fe.ndof - 1))
    total = sc.geometry.mass_kg + sc.geometry.beam_mass_kg
    s_phi = fe.sensor_row @ md.shapes
    return {"fe": fe, "scene": sc, "modes": md, "contact": cm, "total_mass_kg": total,
            "sensor_modal_mass_kg": 1.0 / np.maximum(s_phi**2, 1e-300)}


def _err(msg):
    return CaseError(msg)


# ============================================================================ structural effects
# (eccentric contact, a coupled platform, an R table: the scene effects that change the model itself;
# vibeam.engine.effects applies the others per point)
def contact_factor(spec, offset_m: float) -> float:
    """Static-mode value at the contact point over phi(x_S): ``phi(x_m) (1 + 3 e / (2 L_m))``."""
    sc = scene_of(spec)
    return sc.phi_at_mass * (1.0 + 1.5 * offset_m / sc.geometry.mass_position_m)


def effects_scene(spec, effects, law, lower_law=None):
    """``(scene, coupled)``: the scene of a beam table with its structural effects (eccentric
    contact, coupled platform, R table), driven as the table says, and the coupled platform's
    record (:class:`CoupledPlatform`) or None.

    Parameters
    ----------
    spec : vibeam.case.schema.BeamSceneSpec
    effects : vibeam.case.schema.EffectsSpec
    law, lower_law : law
        The SI laws of the stops at the attached mass, as :func:`scene`'s.

    Raises
    ------
    vibeam.errors.CaseError
        An eccentric contact or a coupled platform with stops away from the attached mass; a coupled
        platform on the static mode, or without its mass.
    """
    ecc = effects.eccentric_impact
    plat = effects.platform
    coupled = plat is not None and plat.level == "coupled"
    e = ecc.offset_mm * 1e-3 if ecc is not None else 0.0
    if (ecc is not None or coupled) and spec.point_stop_tables:
        which = "effects.eccentric_impact" if ecc is not None else "effects.platform (level = \"coupled\")"
        raise _err(f"{which} with stops away from the attached mass ([[model.stop]] with position_mm) is not "
                   f"implemented; allowed: these effects with the stops at the mass")
    sc = scene_of(spec)
    phic = contact_factor(spec, e) if ecc is not None else sc.phi_at_mass
    up, sy = spec.stop[0], spec.system
    DC = sc.Delta_C_m if up.gap_mm is None else (up.gap_mm * 1e-3) * phic
    DCl = sc.Delta_C_lower_m
    if DCl is not None and spec.stop[1].gap_mm is not None:
        DCl = spec.stop[1].gap_mm * 1e-3 * phic
    stops = mass_stops(DC, law, DCl, lower_law)
    info = None
    if not (ecc or coupled):
        new = scene(spec, law, lower_law)
    elif sy.n_modes == "static":
        if coupled:
            raise _err("effects.platform: level = \"coupled\" needs FE modes (n_modes an integer or "
                       "\"all\"), not the static mode")
        new = static_mode_beam(sc.geometry, stops, (), sc.base_amplitude_m, sc.damping_D_s, sc.f1_hz, phi_contact=phic,
                               excitation=excitation(spec))
    else:
        fe = shared_fe(sc.geometry, n_elements=sy.n_elements, damping_D_s=sc.damping_D_s,
                       rayleigh_alpha_1_s=sy.rayleigh_alpha_1_s)
        if not coupled:
            new = fe_beam(fe, sy.n_modes, stops, (), sc.base_amplitude_m, sc.f1_hz, contact_offset_m=e,
                          phi_contact=phic, excitation=excitation(spec))
        else:
            new, info = _coupled_scene(plat, spec, sc, fe, e, stops, phic)
    if effects.restitution_law is not None:
        t = effects.restitution_law
        # sensor velocity (mm/s) -> contact velocity in kernel units (m per nondimensional time)
        om_ref = 2 * math.pi * new.system.reference_hz
        up = new.stops[0].law
        tab = dataclasses.replace(up, table_U=tuple(float(x) for x in np.asarray(t.velocity_mm_s, float) * 1e-3 * phic / om_ref),
                                  table_R=tuple(float(x) for x in np.asarray(t.R, float)))
        new = new._replace(stops=tuple(Stop(st.relation, tab, st.label) if st.law is up else st for st in new.stops))
    return new, info


class CoupledPlatform(NamedTuple):
    """What the coupled platform's gain (:meth:`vibeam.engine.effects.EffectSolver.effective_gain`)
    reads of the beam + platform scene (:func:`effects_scene`): the platform's row of the coupled
    modes ``platform_row`` (shape ``(n,)``, ``z_p = platform_row @ xi``), their circular
    frequencies ``omega_rad_s`` (rad/s, shape ``(n,)``) and modal damping ``c_phys`` (1/s, shape
    ``(n,)``), and the shaker force ``platform_force_n`` (N) holding the reference amplitude."""

    platform_row: np.ndarray
    omega_rad_s: np.ndarray
    c_phys: np.ndarray
    platform_force_n: float


def _coupled_scene(plat, spec, sc, fe, offset_m, stops, phic):
    """Beam + platform DOF as one modal scene (module doc) and its :class:`CoupledPlatform`."""
    if plat.mass_kg is None:
        raise _err("effects.platform.mass_kg is required for level = \"coupled\" (the platform's mass, kg)")
    red = modal_reduction(fe, spec.system.n_modes)
    P = red.shapes
    w = contact_row(fe, P, offset_m)
    s = red.sensor_row
    G = fe.modes(red.n_modes).participation
    om = red.omega_rad_s
    c = fe.rayleigh_alpha_1_s + fe.damping_D_s * om ** 2
    g = sc.geometry
    N = om.size
    m_tot = g.mass_kg + g.beam_mass_kg
    Mtot = plat.mass_kg + m_tot
    wp = 2 * math.pi * plat.frequency_hz
    kp = Mtot * wp ** 2
    cp = 2 * plat.damping_ratio * wp * Mtot
    Mc = np.eye(N + 1)
    Mc[:N, N] = Mc[N, :N] = G
    Mc[N, N] = Mtot
    Kc = np.diag(np.concatenate([om ** 2, [kp]]))
    Cc = np.diag(np.concatenate([c, [cp]]))
    lam, V = scipy.linalg.eigh(Kc, Mc)
    V = V / np.sqrt(np.einsum("ij,ik,kj->j", V, Mc, V))
    V = V * np.where(V[N] < 0, -1.0, 1.0)
    f_ref = plat.reference_frequency_hz or sc.f1_hz
    W = 2 * math.pi * f_ref
    Y = sc.base_amplitude_m
    F_s = Y * abs(kp - Mtot * W ** 2 + 1j * cp * W)
    om_c = np.sqrt(lam)
    c_c = np.einsum("ij,i,ij->j", V, np.diag(Cc), V)
    new = modal_scene(om_c, c_c, V[N], np.concatenate([s, [0.0]]) @ V, (np.concatenate([w, [0.0]]) @ V)[None, :],
                      stops, 0.0, sc.f1_hz, g.length_m, phic, "beam", excitation(spec))
    # per-point base amplitude F_s / Omega~^2; z_p = platform_row @ xi
    return new, CoupledPlatform(V[N].copy(), om_c, c_c, float(F_s))
