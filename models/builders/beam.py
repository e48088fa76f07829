"""The FE cantilever with its attached mass as a scene (paper Sec. 6, Eqs. 39-42; the static mode,
Eqs. 42-47).

Model
    ``M u'' + C u' + K u = -M r b''(t)``, ``b = Y sin(Omega~ t~)`` (base displacement amplitude
    ``Y = gamma~ V``, m), while the contact displacement ``U = w^T u`` (relative to the base, at
    ``L_m``) stays below the stop ``Delta_C``.  With the ``N`` retained mass-normalised modes
    ``u = Phi eta`` each modal coordinate obeys::

        eta_i'' + c_i eta_i' + omega_i^2 eta_i = Gamma_i Omega~^2 Y sin(Omega~ t~),
        c_i = alpha + D omega_i^2       (Rayleigh; alpha = 0 is Eq. 39's D EI U'''')

    and ``U = sum_i w_i eta_i``, sensor ``U(L_S) = sum_i s_i eta_i``.

Units
    Time is the nondimensional ``t = omega_ref t~`` with ``omega_ref = 2 pi f_ref`` (default the FE
    ``f_1``), so the sweep's ``Omega = f / f_ref`` is the forcing frequency; modal coordinates keep
    their SI units (sqrt(kg) m), frequencies and damping are divided by ``omega_ref``; outputs are
    ``q = U(L_S) / L`` (the SDOF's measure when ``f_ref = f_n``):
    :func:`vibeam.models.builders.matrices.modal_scene`, the one packing of a reduced structure.

Stops
    The stops at the attached mass are relations on contact row 0 (:func:`mass_stops`: the upper one
    at ``w^T eta = Delta_C``, a lower one at ``w^T eta = -Delta_C,lower``); a stop at another point
    ``x`` of the beam is a relation on its own row ``w(x)`` (1, 2, ...), computed from the FE
    shapes (:func:`fe_beam`) or the static mode (:func:`static_mode_beam`).  Each law is in SI (a
    compliant stiffness in N/m^p at its point) and is held by the scene over ``omega_ref^2``.
"""
from __future__ import annotations

import math

import numpy as np

from ..contact import Relation, Stop
from ..scene import Scene
from .matrices import modal_scene

__all__ = ["fe_beam", "static_mode_beam", "mass_stops", "contact_row", "BUILDERS"]

#: the builder name of the scenes made here (the registry's fidelity)
BUILDERS = ("beam",)


def mass_stops(gap_m, law, gap_lower_m=None, lower_law=None) -> tuple:
    """The stops at the attached mass: the upper one at ``w^T eta = Delta_C`` (normal ``+w``) and,
    with ``gap_lower_m``, a lower one at ``w^T eta = -Delta_C,lower`` (normal ``-w``).

    Parameters
    ----------
    gap_m : float
        ``Delta_C`` (m; negative: a pre-stressed stop).
    law : law
        The upper stop's (:class:`vibeam.models.contact.Restitution` or a compliant law, SI).
    gap_lower_m : float or None
        ``Delta_C,lower`` (m, positive below the static equilibrium; ``Delta_C + Delta_C,lower > 0``);
        None: one stop.
    lower_law : law or None
        The lower stop's; None: the upper stop's (the same object, so that it follows it).

    Returns
    -------
    tuple of vibeam.models.contact.Stop
        One or two stops on contact row 0.
    """
    out = (Stop(Relation(1.0, float(gap_m)), law),)
    if gap_lower_m is not None:
        out += (Stop(Relation(-1.0, float(gap_lower_m)), law if lower_law is None else lower_law),)
    return out


def contact_row(fe, shapes, offset_m: float = 0.0) -> np.ndarray:
    """The modal row of the contact point ``e`` from the attached mass's centre along the beam,
    ``w(L_m) + e w'(L_m)`` (the mass's rotation moves an eccentric contact).

    Parameters
    ----------
    fe : vibeam.models.builders.beam_fe.BeamFE
    shapes : ndarray, shape (ndof, N)
        Mass-normalised mode shapes (1/sqrt(kg)).
    offset_m : float
        ``e`` (m); 0: the mass's centre.

    Returns
    -------
    ndarray, shape (N,)
        ``W phi_i`` (1/sqrt(kg)), giving metres.
    """
    return fe.contact_row @ shapes + offset_m * shapes[fe.mass_dof_slope, :] if offset_m else fe.contact_row @ shapes


def _point_stops(stops, point_stops):
    """The stops at the mass, then each point stop on its contact row ``1 + i``."""
    return tuple(stops) + tuple(Stop(Relation(st.relation.sign, st.relation.offset, row=1 + i), st.law, st.label)
                                for i, (_, st) in enumerate(point_stops))


def fe_beam(fe, n_modes=2, stops=(), point_stops=(), base_amplitude_m=0.0, f_ref_hz=None, contact_offset_m=0.0,
            phi_contact=None, excitation=None) -> Scene:
    """The FE beam truncated to its ``n_modes`` lowest modes as a scene, builder ``"beam"``.

    Parameters
    ----------
    fe : vibeam.models.builders.beam_fe.BeamFE
        The finite-element model (its Rayleigh damping ``C = alpha M + D K``: ``c_i = alpha + D
        omega_i^2``).
    n_modes : int or "all"
    stops : sequence of vibeam.models.contact.Stop
        The stops at the attached mass (:func:`mass_stops`), SI.
    point_stops : sequence of (float, Stop)
        Stops at other points: the position ``x`` (m from the clamp) and the stop (its relation's
        sign and gap in m along its normal, its law, its label); their rows ``w(x)`` come from the
        FE shapes.
    base_amplitude_m : float
        ``Y`` (m).
    f_ref_hz : float or None
        The reference frequency (Hz); None: the FE ``f_1``.
    contact_offset_m : float
        An eccentric contact ``e`` (m) from the mass centre along the beam: row ``w(L_m) + e
        w'(L_m)``.
    phi_contact : float or None
        The contact point's static ratio to the sensor; None: the static mode's ``phi(x_m)`` (Eq. 42).
    excitation : vibeam.models.scene.Excitation or None
        A base acceleration (SI) instead of the base displacement.

    Returns
    -------
    Scene

    Raises
    ------
    ValueError
        ``n_modes`` not ``"all"`` or in ``1..ndof``; no retained mode moving a stop's point;
        overlapping stops at the mass.
    """
    # lazy: vibeam.reductions builds on the models (the modal truncation and the static mode)
    from vibeam.reductions.modal import modal_reduction
    from vibeam.reductions.static_mode import static_mode_shape

    red = modal_reduction(fe, n_modes)
    md = fe.modes(red.n_modes)
    g = fe.geometry
    L = g.length_m
    if phi_contact is None:
        phi_contact = float(static_mode_shape(g.mass_position_m / L, g.mass_position_m / L, g.sensor_position_m / L))
    P = red.shapes
    rows = [contact_row(fe, P, contact_offset_m)] + [fe.point_rows([x])[0] @ P for x, _ in point_stops]
    c = fe.rayleigh_alpha_1_s + fe.damping_D_s * red.omega_rad_s ** 2
    return modal_scene(red.omega_rad_s, c, md.participation, red.sensor_row, np.vstack(rows),
                       _point_stops(stops, point_stops), base_amplitude_m,
                       md.frequencies_hz[0] if f_ref_hz is None else f_ref_hz, L, phi_contact, "beam", excitation)


def static_mode_beam(geometry, stops=(), point_stops=(), base_amplitude_m=0.0, damping_D_s=0.0, f_ref_hz=None,
                     phi_contact=None, excitation=None) -> Scene:
    """One assumed shape, the static mode ``phi`` (paper Eqs. 42-47, beam mass excluded), as a
    scene, builder ``"beam"``: mass ``M_S = m phi(x_m)^2``, stiffness ``K_S``, load ``m phi(x_m)``.

    The mass-normalised shape is ``phi / sqrt(M_S)`` in ``U = L phi q``, i.e. the modal coordinate
    is ``eta = L sqrt(M_S) q``, so ``w = phi(x_m) / sqrt(M_S)``, ``s = 1 / sqrt(M_S)``, ``Gamma = m
    phi(x_m) / sqrt(M_S)`` and ``m_eff = m``; damping ``c = D omega_n^2``.

    Parameters
    ----------
    geometry : vibeam.models.builders.beam_fe.BeamGeometry
    stops, point_stops, base_amplitude_m, excitation
        As :func:`fe_beam`'s (a point stop's row is ``phi(x) / sqrt(M_S)``).
    damping_D_s : float
        ``D`` (s), Eq. 39.
    f_ref_hz : float or None
        The reference frequency (Hz); None: the static mode's ``f_n`` (the case gives the FE
        ``f_1`` so that both share one grid).
    phi_contact : float or None
        An eccentric contact's static ratio ``phi_c``: the contact row is ``phi_c / sqrt(M_S)``;
        None: ``phi(x_m)``.

    Returns
    -------
    Scene
    """
    # lazy: vibeam.reductions builds on the models (the static-mode reduction)
    from vibeam.reductions.static_mode import reduce_static_mode, static_mode_shape

    red = reduce_static_mode(geometry, damping_D_s=damping_D_s, gap_contact_m=0.0)
    L = geometry.length_m
    xm, xs = geometry.mass_position_m / L, geometry.sensor_position_m / L
    sq = math.sqrt(red.M_S_kg)
    phim = red.phi_at_mass
    w = np.array([phim / sq])
    if phi_contact is not None:
        w = w * (phi_contact / phim)
    rows = [w] + [[float(static_mode_shape(x / L, xm, xs)) / sq] for x, _ in point_stops]
    om = np.array([red.omega_n_rad_s])
    return modal_scene(om, 0.0 + damping_D_s * om ** 2, [geometry.mass_kg * phim / sq], [1.0 / sq], np.vstack(rows),
                       _point_stops(stops, point_stops), base_amplitude_m,
                       red.f_n_hz if f_ref_hz is None else f_ref_hz, L, phim if phi_contact is None else phi_contact,
                       "beam", excitation)
