"""Scene effects (``[effects]`` of a case): applied only when a scene asks for them.

:func:`wrap_solver` is the single place where effects enter a run: with no
active effect it returns the plain solver unchanged (same model, same DOFs,
same kernel), so a plain scene never pays for an effect.  Otherwise it returns
an :class:`EffectSolver` that the one sweep engine drives like any solver.

Effects (paper Secs. 5-7)
-------------------------
``platform``, ``level = "filter"`` (both fidelities)
    The shaker drives the platform with a force; the platform is a second-order
    system, so the base displacement per volt is
    ``gamma(f) = gamma_ref |H(f)| / |H(f_ref)|`` with
    ``H(f) = 1 / (1 - (f/f_p)^2 + 2 i zeta_p f/f_p)``, normalised at
    ``reference_frequency_hz`` (default: the scene's natural frequency, where the
    paper identified gamma = 1.5e-3 /V, Sec. 6.1) with ``gamma_ref`` the scene's
    ``gain``.  Each frequency point is simulated with its own forcing amplitude
    (the phase of H is dropped: the steady state does not depend on it); the
    per-point dataset ``effective_gain`` is that gamma (1/V).
    With ``gains = [[f1, g1], [f2, g2]]`` the filter is identified from two
    measured gains instead: gamma(f) = g1 |H(f)| / |H(f1)| passes through both
    points (the scene's ``gain`` is then not used).  Two gains fix the level and
    *one* filter parameter (the force-to-displacement gain of the platform is
    unknown, so only g2/g1 constrains H): vibeam solves f_p on the branch below
    both frequencies with zeta_p = ``damping_ratio``; if g2/g1 is out of that
    branch's reach ((f1/f2)^2 at most for light damping) it solves zeta_p with
    f_p = ``frequency_hz``; if neither works it raises a CaseError naming the key.
``platform``, ``level = "coupled"`` (beam fidelity only)
    A platform DOF ``z_p`` of mass ``mass_kg`` carries the clamp and the stop;
    the beam (in its N retained fixed-base modes ``eta``, relative to the
    platform) loads it by its reaction.  Coupled system::

        [ I      Gamma       ] [eta'']   [c_i  0 ] [eta']   [w_i^2 0  ] [eta]   [0     ]
        [ Gamma' M_p + m_tot ] [z_p'' ] + [0   c_p] [z_p' ] + [0     k_p] [z_p ] = [F_s sin]

    with ``m_tot`` the beam's and the attached mass's total mass, ``k_p`` and
    ``c_p`` the suspension of the whole assembly at ``frequency_hz`` /
    ``damping_ratio``.  Its N + 1 mass-normalised modes feed the same closed-form
    modal kernel (a scene of arbitrary modal data,
    :func:`vibeam.models.builders.matrices.modal_scene`).  Approximation: damping stays modal -- the diagonal
    of ``V^T C V`` is kept, its (small) off-diagonal coupling is dropped.  The
    shaker force ``F_s`` is calibrated so that the assembly taken as rigid would
    move ``gamma~ V`` at the reference frequency; ``effective_gain`` is the
    linear platform amplitude of the coupled system (impacts aside) in the
    paper's gamma units.  Contact and sensor are relative to the platform.
``eccentric_impact`` (beam fidelity only)
    The contact point lies ``offset_mm`` from the mass centre along the beam:
    contact row ``w_c = w(L_m) + e w'(L_m)`` (the FE rotation DOF of the mass
    node), so every impulse also applies a moment ``e P`` to the mass (and
    ``m_eff = 1 / |w_c|^2`` changes).  The gap is measured at the contact point:
    ``Delta_C = phi_c Delta_G`` with ``phi_c = phi(x_m) (1 + 3 e / (2 L_m))`` the
    static mode at the contact point (load at L_m).  With ``n_modes = "static"``
    the single static shape's contact row is scaled by ``phi_c / phi(x_m)``.
``gap_drift`` (both fidelities, physical scenes)
    ``table``: the grazing gap at the sensor (as ``gap_mm`` of the scene) at each
    frequency point, linearly interpolated, constant beyond the ends.
    ``law = "sliding"``: after each point the stop slides away by
    ``slide_mm_per_impulse`` times the normalised impulse of that point, capped
    at ``max_drift_mm`` in all.  The normalised impulse is the impulse per
    forcing period in the units of the SDOF model, ``sum (1 + R) U-`` over the
    recorded impacts (sensor velocity, nondimensional) divided by the recorded
    periods (so it does not depend on the record window).  The drift is state:
    it travels with the continuation chain (appended to the state handed from
    point to point), so each chain (up, down) starts at the scene's gap; without
    continuation every point starts at the scene's gap.  Needs a time-domain
    method.  Per-point dataset ``gap_mm`` (the gap used at that point).
``restitution_law`` (SDOF ``event``; beam ``event`` and ``direct``)
    R piecewise linear in the pre-impact velocity at the sensor (mm/s, paper
    Fig. 26), constant beyond the ends, evaluated by
    :func:`vibeam.models.impact.restitution_coefficient` inside the kernels at
    every impact (the chatter test uses R at the current velocity).  Velocity
    conversion: SDOF ``U(L_S)' = q' L omega_n``; beam: the kernel sees the
    contact velocity, converted with the static-mode factor,
    ``U(L_S)' ~ U_c' / phi_c`` (exact for one static mode; an approximation when
    several modes move the sensor and the contact differently).
"""
from __future__ import annotations

import math

import numpy as np

from vibeam.errors import CaseError
from vibeam.models import make_solver
from vibeam.models.contact import restitution_coefficients
from vibeam.models.registry import fidelity, is_compliant, law_name, with_capability
from vibeam.models.scene import outputs, with_amplitude, with_gap

#: effects handled here (``sensor`` belongs to :mod:`vibeam.engine.sensor` / the assessments)
HANDLED = ("platform", "eccentric_impact", "gap_drift", "restitution_law")
#: gamma identified at 2 f_n in Sec. 7 over the 1.5e-3 /V near f_n of Sec. 6.1 (tight, neutral, loose)
PAPER_GAIN_RATIOS = (3.78e-4 / 1.5e-3, 5.16e-4 / 1.5e-3, 7.66e-4 / 1.5e-3)


def _err(msg):
    return CaseError(msg)


# ============================================================================ platform filter
def platform_H(f, f_p, zeta_p):
    """``H(f) = 1 / (1 - (f/f_p)^2 + 2 i zeta_p f/f_p)``: force-driven platform displacement."""
    r = np.asarray(f, dtype=float) / f_p
    return 1.0 / (1.0 - r * r + 2j * zeta_p * r)


def identify_platform(gains, zeta_p: float, f_p_default: float):
    """``(f_p, zeta_p)`` from two measured gains ``[[f1, g1], [f2, g2]]`` (see module doc).

    Raises CaseError if g2/g1 cannot be reproduced.
    """
    from scipy.optimize import brentq  # lazy: keeps scipy.optimize (0.35 s) out of `vibeam run` (platform gains only)

    (f1, g1), (f2, g2) = sorted((tuple(p) for p in gains), key=lambda p: p[0])
    if not (f1 > 0 and f2 > f1 and g1 > 0 and g2 > 0):
        raise _err(f"effects.platform.gains = {gains!r}: need two distinct positive frequencies "
                   f"and positive gains")
    rho = g2 / g1

    def ratio(fp, z):
        return abs(platform_H(f2, fp, z)) / abs(platform_H(f1, fp, z))

    # f_p on the branch below both frequencies, zeta fixed
    lo, hi = 1e-6 * f1, f1 * (1 - 1e-9)
    xs = np.geomspace(lo, hi, 400)
    F = np.array([ratio(x, zeta_p) - rho for x in xs])
    for i in range(len(xs) - 1):
        if F[i] == 0.0:
            return float(xs[i]), float(zeta_p)
        if F[i] * F[i + 1] < 0:
            return float(brentq(lambda x: ratio(x, zeta_p) - rho, xs[i], xs[i + 1], xtol=1e-14)), float(zeta_p)
    # zeta with f_p fixed
    zs = np.concatenate([[0.0], np.geomspace(1e-4, 100.0, 400)])
    G = np.array([ratio(f_p_default, z) - rho for z in zs])
    for i in range(len(zs) - 1):
        if G[i] * G[i + 1] < 0:
            return float(f_p_default), float(brentq(lambda z: ratio(f_p_default, z) - rho, zs[i], zs[i + 1],
                                                    xtol=1e-14))
    raise _err(f"effects.platform.gains = {gains!r}: the ratio g2/g1 = {rho:.4g} is out of reach of a "
               f"second-order platform (f_p below {f1:g} Hz with damping_ratio = {zeta_p:g} gives at most "
               f"{F.max() + rho:.4g}; f_p = {f_p_default:g} Hz with any damping gives {G.min() + rho:.4g} to "
               f"{G.max() + rho:.4g})")


# ============================================================================ the wrapper
class EffectSolver:
    """A solver with scene effects: per point it edits the scene of its plain solver (forcing
    amplitude, gap: :func:`vibeam.models.scene.with_amplitude`, :func:`~vibeam.models.scene.with_gap`)
    and runs the plain solver of that scene; adds the effects' per-point outputs.  Picklable
    (runs in worker processes).

    The scene of a point, :meth:`scene_at`, is what the Lyapunov and Floquet exponents of the
    point are computed on.  ``coupled`` is the record of a coupled platform (its modes and the
    shaker force, :class:`vibeam.case.beamscene.CoupledPlatform`), else None."""

    time_domain = True

    def __init__(self, inner, spec, effects, settings, active, f_n_hz, coupled=None):
        self.inner = inner
        self.scene = inner.scene
        self.name = inner.name
        self.time_domain = inner.time_domain
        self.chunk_periods = getattr(inner, "chunk_periods", None)
        self.spec = spec
        self.effects = effects
        self._settings = dict(settings or {})
        self.active = list(active)
        self.f_n_hz = float(f_n_hz)
        self.run_attrs = {"effects": ", ".join(self.active)}
        plat = effects.platform
        L_mm = spec.system.length_mm
        self._L_mm = L_mm
        # the shaker's gain (1/V) and voltage (V): B = gamma V, paper Eq. 43
        self._gain, self._voltage = spec.excitation.shaker(L_mm)
        # static-mode value at the contact point over the sensor's (1 for the SDOF model)
        out = outputs(self.scene)
        self._phic = out.phi_contact
        if plat is not None:
            self._setup_platform(plat, coupled)
        gd = effects.gap_drift
        if gd is not None:
            self.run_attrs["gap_drift"] = "table" if gd.table is not None else gd.law
            if gd.table is not None:
                t = np.array(sorted(gd.table, key=lambda p: p[0]), dtype=float)
                self._gap_f, self._gap_v = t[:, 0], t[:, 1]
            else:
                self.run_attrs["gap_slide_mm_per_impulse"] = gd.slide_mm_per_impulse
                self.run_attrs["gap_max_drift_mm"] = gd.max_drift_mm
        if effects.eccentric_impact is not None:
            self.run_attrs["eccentric_offset_mm"] = effects.eccentric_impact.offset_mm
            self.run_attrs["contact_static_factor"] = self._phic
            self.run_attrs["contact_effective_mass_kg"] = float(out.m_eff)
        if effects.restitution_law is not None:
            self.run_attrs["restitution_velocity_mm_s"] = np.asarray(effects.restitution_law.velocity_mm_s)
            self.run_attrs["restitution_R"] = np.asarray(effects.restitution_law.R)

    # ------------------------------------------------------------------ platform
    def _setup_platform(self, plat, m):
        a = self.run_attrs
        a["platform_level"] = plat.level
        gain = float(self._gain)
        if plat.level == "filter":
            fp, zp = plat.frequency_hz, plat.damping_ratio
            if plat.gains is not None:
                fp, zp = identify_platform(plat.gains, zp, fp)
                (f1, g1), _ = sorted((tuple(p) for p in plat.gains), key=lambda p: p[0])
                f_ref, g_ref = f1, g1
            else:
                f_ref = plat.reference_frequency_hz or self.f_n_hz
                g_ref = gain
            if gain <= 0:
                raise _err("effects.platform needs the scene's gain > 0 (it scales the forcing)")
            H_ref = abs(platform_H(f_ref, fp, zp))
            self._filter = (fp, zp, f_ref, g_ref, H_ref)
            a.update(platform_frequency_hz=fp, platform_damping_ratio=zp, platform_reference_frequency_hz=f_ref,
                     platform_reference_gain_per_V=g_ref)
        else:
            self._coupled = (m.platform_row, m.omega_rad_s, m.c_phys)
            self._coupled_fs = m.platform_force_n
            a.update(platform_frequency_hz=plat.frequency_hz, platform_damping_ratio=plat.damping_ratio,
                     platform_mass_kg=plat.mass_kg, platform_force_n=m.platform_force_n,
                     coupled_frequencies_hz=m.omega_rad_s / (2 * math.pi))
        fn = self.f_n_hz
        a["gain_ratio_2fn_to_fn"] = float(self.effective_gain(2 * fn) / self.effective_gain(fn))
        a["paper_gain_ratios_2fn_to_fn"] = np.array(PAPER_GAIN_RATIOS)

    def effective_gain(self, f_hz):
        """The paper's gamma (1/V) at ``f_hz`` as the platform model predicts it."""
        plat = self.effects.platform
        if plat.level == "filter":
            fp, zp, f_ref, g_ref, H_ref = self._filter
            return g_ref * abs(platform_H(f_hz, fp, zp)) / H_ref
        row, om, c = self._coupled
        W = 2 * math.pi * np.asarray(f_hz, float)
        z = np.sum(row ** 2 / (om ** 2 - W ** 2 + 1j * W * c)) * self._coupled_fs
        V = self._voltage
        return abs(z) / (V * self._phim() * self._L_mm * 1e-3) if V > 0 else 0.0

    def _phim(self):
        # lazy: keeps skfem and the FE beam (0.4 s) out of `vibeam run` of an SDOF case
        from vibeam.case.beamscene import scene_of

        if not hasattr(self, "_phim_v"):
            self._phim_v = scene_of(self.spec).phi_at_mass
        return self._phim_v

    # ------------------------------------------------------------------ solver interface
    def settings(self) -> dict:
        return dict(self.inner.settings(), effects=list(self.active))

    def _gap_mm(self, f_hz, drift):
        gd = self.effects.gap_drift
        if gd is None:
            return None
        if gd.table is not None:
            return float(np.interp(f_hz, self._gap_f, self._gap_v))
        up = self.spec.stop[0]
        return up.gap_mm + drift if up.gap_mm is not None else up.contact_gap_mm / self._phic + drift

    def point_scene(self, Omega, drift=0.0):
        """The scene of one point (and the extras it implies): the filtered platform scales the
        drive amplitude with the gain (paper Eq. 46), the coupled one drives by the shaker force
        over ``Omega~^2`` (metres, over the system's ``length_unit_m / coordinate_scale``), the
        gap drift places the first stop at the sensor gap ``gap_mm / length_mm`` (Eq. 45)."""
        sc = self.inner.scene
        f = float(Omega) * self.f_n_hz
        extra = {}
        plat = self.effects.platform
        gap = self._gap_mm(f, drift)
        if plat is not None:
            g = float(self.effective_gain(f))
            extra["effective_gain"] = g
            if plat.level == "filter":
                sc = with_amplitude(sc, sc.system.base_amplitude * (g / float(self._gain)))
            else:   # coupled (capability coupled_platform): the shaker force over Omega~^2
                W = 2 * math.pi * f
                s = sc.system
                sc = with_amplitude(sc, self._coupled_fs / (W * W) / (s.length_unit_m / s.coordinate_scale))
        if gap is not None:
            sc = with_gap(sc, gap / self._L_mm)
            extra["gap_mm"] = gap
        return sc, extra

    def scene_at(self, Omega):
        """The scene simulated at ``Omega`` (:meth:`point_scene` without drift); None when it
        depends on the state (a gap that slides with the impacts)."""
        gd = self.effects.gap_drift
        if gd is not None and gd.law == "sliding":
            return None
        return self.point_scene(Omega)[0]

    def point(self, Omega, state0, n_transient, n_record, samples_per_period=64):
        sliding = self.effects.gap_drift is not None and self.effects.gap_drift.law == "sliding"
        drift = 0.0
        if sliding and state0 is not None:
            state0 = np.asarray(state0, dtype=float)
            state0, drift = state0[:-1], float(state0[-1])
        ps, extra = self.point_scene(Omega, drift)
        solver = self.inner if ps is self.inner.scene else _rebuild(self.inner, ps, self._settings)
        out = solver.point(Omega, state0, n_transient, n_record, samples_per_period)
        if not self.time_domain:
            out = dict(out)
            out.update(extra)
            return out
        out.extra.update(extra)
        if "gap_mm" in extra:
            out.Delta = outputs(ps).Delta   # Q (and its spread) against this point's gap
        if sliding:
            gd = self.effects.gap_drift
            imp = self._impulse_per_period(out, ps, n_record)
            out.extra["gap_drift_mm"] = drift
            out.extra["impulse_per_period"] = imp
            new = min(drift + gd.slide_mm_per_impulse * imp, gd.max_drift_mm)
            out.final_state = np.concatenate([np.asarray(out.final_state, float), [new]])
        return out

    def _impulse_per_period(self, traj, ps, n_record):
        """Normalised impulse per forcing period, ``sum (1 + R(U-)) U-`` / periods (sensor units)."""
        v = np.asarray(traj.impact_velocities, float)   # q'- (SDOF) or contact velocity / L (beam)
        if v.size == 0 or n_record <= 0 or traj.status == "failed":
            return 0.0
        k = traj.impact_stops
        if k is not None:          # two stops: the drift of the upper stop follows its own impulse
            v = v[k == 0]
            if v.size == 0:
                return 0.0
        Rs = restitution_coefficients([ps.stops[0].law], v, None, ps.system.coordinate_scale)
        vs = v / self._phic            # sensor velocity
        tot = float(np.sum((1.0 + Rs) * vs)) * ((traj.n_impacts - traj.n_impacts_lower) / v.size)
        return tot / n_record


def _rebuild(inner, scene, settings):
    """The plain solver of ``inner``'s method for another scene of the same stops' laws (same
    class, same settings)."""
    return type(inner)(scene, **settings)


# ============================================================================ entry point
def wrap_solver(solver, scene, spec, effects, run_settings: dict | None = None):
    """Solver of a run with its effects applied (the plain solver when none is active).

    Parameters
    ----------
    solver : object
        Solver from :func:`vibeam.models.make_solver`.
    scene : vibeam.models.scene.Scene
        Its scene (``spec.scene()``).
    spec : vibeam.case.schema.SDOFSceneSpec or vibeam.case.schema.BeamSceneSpec
        The validated model table (a shorthand table is validated as the spec it expands into).
    effects : vibeam.case.schema.EffectsSpec
        Active effects of the run.
    run_settings : dict, optional
        The run's method settings (to build the solver of a changed scene).

    Raises
    ------
    vibeam.case.schema.CaseError
        If an effect does not make sense for the fidelity or method.
    """
    active = [k for k in effects.active() if k in HANDLED]
    if not active:
        return solver
    law = law_name(scene)
    if is_compliant(law):   # the effect models are built for Newton's law (issue 13: not yet)
        raise _err(f"effects.{active[0]}: not available with contact.law = \"{law}\" yet; use law = \"restitution\"")
    caps = fidelity(spec.fidelity)
    method = solver.name
    settings = dict(run_settings or {})

    def names(flag):
        return " or ".join(f'fidelity = "{n}"' for n in with_capability(flag))

    if effects.eccentric_impact is not None and not caps.eccentric_contact:
        raise _err(f"effects.eccentric_impact: the {caps.name.upper()} model has no rotation of the attached mass "
                   f"(a point mass on one assumed shape); use a beam scene ({names('eccentric_contact')})")
    if not getattr(spec, "physical", False):
        raise _err(f"effects.{active[0]}: needs a physical {caps.name.upper()} scene (natural_frequency_hz, "
                   f"gap_mm, length_mm, gain, voltage), not the nondimensional keys")
    if effects.platform is not None and effects.platform.level == "coupled" and not caps.coupled_platform:
        raise _err(f"effects.platform.level = \"coupled\" is implemented for beam scenes only "
                   f"({names('coupled_platform')}); use level = \"filter\" with this scene")
    if effects.restitution_law is not None and method not in caps.restitution_law_methods:
        allowed = " or ".join(f'"{m}"' for m in caps.restitution_law_methods)
        raise _err(f"effects.restitution_law: method {method!r} does not support a velocity-dependent R; "
                   f"use method = {allowed}")
    if effects.gap_drift is not None and effects.gap_drift.law == "sliding" and not solver.time_domain:
        raise _err(f"effects.gap_drift: law = \"sliding\" needs impacts, i.e. a time-domain method "
                   f"(not {method!r})")
    new, coupled = spec.effect_scene(effects, scene)
    inner = solver if new is scene else make_solver(new, solver.name, **settings)
    return EffectSolver(inner, spec, effects, settings, active, outputs(scene).natural_frequency_hz, coupled)

