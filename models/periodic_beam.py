"""Periodic orbits of the modal FE beam as zeros of a shooting residual (fidelity ``"beam"``).

:class:`BeamShooting` implements the shooting-problem contract of
:mod:`vibeam.models.periodic` for :class:`~vibeam.models.beam_dynamics.BeamImpactModel`
with any number of modes (all modes of the mesh included): ``P^n`` of the stroboscopic
map (forcing phase 0), its monodromy ``M`` and ``d x / d p``, all exact.

How a shot is computed
    ``P^n`` is one run of the exact event kernel
    :func:`~vibeam.models.beam_dynamics.beam_kernel` from ``x0`` (``n_transient = 0``,
    ``n_record = n``) with its optional event log: the kernel's event policy (certified
    impact detection, the Newton impulse, sticking and release, chatter) is the only
    one, there is no second event loop.  The log holds every event (impact, entry into
    sticking, release) with its time and state and the interior free-flight apexes of
    the contact gap.  :func:`assemble_derivatives` (numba) then rebuilds the tangent
    ``J = d x / d(x0, p)`` (shape ``(2N, 2N + 1)``) along the logged events:

    * flight (free): every mode is a forced damped oscillator, ``z_i(t_b) = Phi_i(t_b -
      t_a) (z_i(t_a) - z_p,i(t_a)) + z_p,i(t_b)`` with the per-mode 2x2 transition matrix
      (under-, critically or over-damped, as :func:`~vibeam.models.system.transition_increment`,
      entries to relative precision: :func:`~vibeam.models.system.transition_entries`)
      and the harmonic particular solution ``z_p``; ``J`` is updated two rows at a time,
      O(N^2) per flight, never a dense ``2N x 2N`` product;
    * sticking: the constrained flow in the coordinates ``eta = eta_c + Psi zeta``
      (``Psi^T J``, per-mode 2x2 in ``zeta``, back with ``Psi``);
    * impact (Newton impulse through the mass matrix, ``eta' += w P``, ``P = -(1 + R)
      m_eff w^T eta'``, surface ``h = w^T eta - Delta_C``): the saltation matrix
      ``S = G_x + (f+ - G_x f-) h_x / (h_x f-)``, a rank-one update of ``J``; the jump
      ``f+ - G_x f-`` is written in closed form (no cancellation as ``U- -> 0``):
      ``(-(1+R) w, (1+R) C w + (1 + R + R'(U) U) w a_n / U) / |w|^2`` per unit ``U-``
      (``a_n = w^T eta''-``; ``R'`` the slope of a tabulated ``R(U-)``);
    * entry into sticking (plastic projection along ``w``, ``eta' -> P_w eta'``): the
      same formula with ``G_x = diag(I, P_w)`` and ``f+`` the constrained field; its jump
      is ``O(U-)`` (the constrained acceleration of a Rayleigh-damped beam is the
      projected free one), so the entry saltation stays bounded as ``U- -> 0``; with
      per-mode damping (``modal_damping_1_s``) the kernel's constrained damping
      ``diag(Psi^T C Psi)`` adds ``Psi (Psi^T C Psi - diag) Psi^T eta' / U-``;
    * release (``lambda = 0``): ``dt_r = -(lambda_x dx + lambda_p dp) / lambda_dot`` and
      ``S = I + (f+ - f-) lambda_x / lambda_dot``.  The two fields differ by the contact
      force, which vanishes at the release, so ``S = I`` up to the root accuracy; the
      release-time derivatives are returned (``extra["release_time_derivatives"]``).

    A second (lower) stop (``gap_contact_lower_m``, normal ``-w`` at ``w^T eta =
    -Delta_C,lower``, its own ``R_lower`` or the upper stop's law): its events are told apart by
    the logged position and use the same formulas with ``w -> n = -w`` (``U = n^T eta'``, ``a_n
    = n^T eta''``, ``C n``, ``P_w C n``); held on it, the beam moves about that stop's offsets
    ``eta_c``, ``eC`` (:attr:`BeamImpactModel.stop_rows`), which no native parameter moves.  The
    kernel also logs the interior minima of ``w^T eta`` as apexes of the lower gap, so
    ``apex_gap`` watches the grazing of both stops; ``extra["impact_stops"]`` gives the stop of
    each impact (0 upper, 1 lower).

    Parameter derivatives are analytic: Omega enters the forcing phase ``Omega t``, the
    particular solutions (``F = Omega^2 Y``) and the end time ``n T`` (``+ f(nT) d(nT) /
    d Omega``); ``Y`` (``base_amplitude_m``) the particular solutions; ``Delta_C``
    (``gap_contact_m``) the event surface (``h_p = -1``), the stop offset ``eta_c``,
    ``eC`` of the constrained modes and the initial projection; ``R`` the impulse
    (``G_R``); the damping coefficients ``D`` (``damping_D_s``) and ``alpha``
    (``rayleigh_alpha_1_s``) the transition matrices (closed-form ``d Phi / d sigma``,
    series near critical damping), the particular solutions and the contact force.

Chatter
    A chatter sequence ending in sticking is the kernel's (the one event policy): its
    impacts are real impacts until the kernel's accumulation test (error of the
    geometric sum below ``chatter_tol``, or its Zeno guard) cuts the sequence; that last
    impact is a plastic entry into sticking (the impact and the projection compose to
    the plastic projection of the pre-impact velocity), and the beam is held at least
    for the estimated accumulation time.  So ``P^n`` is the map a sweep iterates (the
    accumulation point is approximated to ``chatter_tol``), and ``M``, ``x_p`` are its
    exact derivatives on the piece where the number of impacts before the cut is fixed.
    When that number changes ``P^n`` stays continuous to round-off (measured: jumps of
    1e-15 of the state on the pre-stressed rig), so such orbits are returned with status
    ``"ok"`` and ``extra["n_chatter"] > 0``.  Their saltation matrices carry the
    ``a_n / U-`` terms of nearly grazing impacts, so ``P^n`` is strongly curved: central
    differences agree with ``M`` only to ~1e-7 (1e-8 with a 5-point stencil).  Not
    representable, status ``"chatter"``: a release forced at the end of the hold (the
    contact force turned positive during the estimated accumulation time), whose time
    is not a smooth event.

Section on the stop
    When ``x0`` lies on the stop with zero normal velocity (within ``1e-9`` of the state
    scale) the orbit is taken as stuck at the section: the kernel starts held, and the
    Jacobian includes the projection onto the constraint (two zero multipliers); it is
    the derivative along the constraint (off it ``P^n`` is only one-sided smooth), and
    ``d x / d Delta_C`` moves ``x0`` with the stop.

Parameters and conversions
    Native parameters: ``Omega``, ``base_amplitude_m``, ``gap_contact_m``, ``R``,
    ``damping_D_s``, ``rayleigh_alpha_1_s``.  Physical case keys map affinely onto them
    (:func:`conversions`); a key that changes the FE model (``length_mm``, ``EI_n_m2``,
    ...) is refused (:data:`REBUILD_KEYS`).

References
----------
R. I. Leine, H. Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*,
Springer 2004, Ch. 3 (saltation matrix); M. di Bernardo et al., *Piecewise-smooth
Dynamical Systems*, Springer 2008, Sec. 2.5 (discontinuity mappings, sliding/sticking);
paper Eqs. 39-47 (model, impact law, static-mode reduction).
"""
from __future__ import annotations

import copy
import math

import numpy as np
from numba import njit

from .beam_dynamics import TWO_PI, BeamImpactModel
from .core.event import EventIntegrator
from .core.integrator import EV_IMPACT, EV_RELEASE, EV_START, EV_STICK, EV_STICK_IMPACT, ST_FAILED
from .contact import pack
from .impact import restitution_coefficient
from .periodic import Shot
from .system import from_beam, mode_table, particular, transition_entries

__all__ = ["BeamShooting", "BeamContinuation", "conversions", "assemble_derivatives", "NATIVE_PARAMETERS",
           "REBUILD_KEYS"]

#: the per-mode transition matrix, :func:`vibeam.models.system.transition_entries`
_phi = transition_entries

#: native continuation parameters of the beam and the model attribute each one sets
NATIVE_PARAMETERS = ("Omega", "base_amplitude_m", "gap_contact_m", "R", "damping_D_s",
                     "rayleigh_alpha_1_s")
_PID = {name: i for i, name in enumerate(NATIVE_PARAMETERS)}

#: case keys of a beam scene that change the FE model (modes, shapes): not continuable
REBUILD_KEYS = ("length_mm", "sensor_position_mm", "mass_position_mm", "width_mm",
                "thickness_mm", "youngs_modulus_gpa", "density_kg_m3", "EI_n_m2", "rhoA_kg_m",
                "mass_kg", "rotary_inertia_kg_m2", "discs", "calibrate", "n_modes", "n_elements")


def conversions(model: BeamImpactModel, gain_per_V: float | None = None,
                voltage: float | None = None) -> dict:
    """Affine map of the physical case keys onto the native parameters.

    ``native = scale * key`` for every key in the table, so a derivative with respect
    to the key is ``scale`` times the native one (chain rule).

    Parameters
    ----------
    model : BeamImpactModel
        The model (built by :func:`vibeam.case.beamscene.build_beam_model` for a case).
    gain_per_V : float, optional
        The case's ``gain`` (the paper's normalised gamma, 1/V); needed for ``voltage``.
    voltage : float, optional
        The case's ``voltage`` (V); needed for ``gain``.

    Returns
    -------
    dict
        ``key -> (native name, scale)``:

        * ``Omega`` -> ``Omega``, 1; ``frequency_hz`` -> ``Omega``, ``1 / f_ref``;
        * ``voltage`` -> ``base_amplitude_m``, ``gamma~ = gain phi(x_m) L`` (m/V, Eq. 46
          inverted, :func:`vibeam.case.beamscene.scene_of`); ``gain`` -> ``base_amplitude_m``,
          ``V phi(x_m) L``;
        * ``gap_mm`` (grazing gap at the sensor) -> ``gap_contact_m``, ``1e-3 phi(x_m)``
          (Eq. 45: ``Delta_C = phi(x_m) Delta_G``); ``contact_gap_mm`` -> ``gap_contact_m``,
          ``1e-3``;
        * ``damping_ratio`` -> ``damping_D_s``, ``2 / omega_ref`` (``D = 2 beta / omega_1``
          with ``omega_1 = 2 pi f_ref``, the first FE mode of a built scene);
        * ``R`` -> ``R``, 1; ``rayleigh_alpha_1_s`` -> itself, 1; and every native name
          to itself.
    """
    L = model.length_m
    phim = model.phi_at_mass
    tab = {name: (name, 1.0) for name in NATIVE_PARAMETERS}
    tab["frequency_hz"] = ("Omega", 1.0 / model.f_ref_hz)
    tab["gap_mm"] = ("gap_contact_m", 1e-3 * phim)
    tab["contact_gap_mm"] = ("gap_contact_m", 1e-3)
    tab["damping_ratio"] = ("damping_D_s", 2.0 / model.omega_ref)
    if gain_per_V is not None:
        tab["voltage"] = ("base_amplitude_m", float(gain_per_V) * phim * L)
    if voltage is not None:
        tab["gain"] = ("base_amplitude_m", float(voltage) * phim * L)
    return tab


def _check_parameter(name: str):
    if name in REBUILD_KEYS:
        raise ValueError(f"parameter {name!r} changes the FE model (modes and shapes): the beam "
                         f"shooting cannot continue in it; allowed: {', '.join(NATIVE_PARAMETERS)} "
                         f"(or a physical key of conversions())")
    if name not in _PID:
        raise ValueError(f"parameter {name!r} is not a native beam parameter; allowed: "
                         f"{', '.join(NATIVE_PARAMETERS)} (physical keys map onto them through "
                         f"conversions())")


# ============================================================================ mode algebra
@njit(cache=True)
def _series_ds(z):
    """``sum_{n>=1} n z^(n-1) / (2n+1)!`` (``dS/d(Delta^2) = s^3`` times this)."""
    out = 0.0
    term = 1.0 / 6.0
    zn = 1.0
    for n in range(1, 10):
        out += n * zn * term
        zn *= z
        term /= (2 * n + 2) * (2 * n + 3)
    return out


@njit(cache=True)
def _dtrans_dsig(s, sig, k, typ, q, l1, l2):
    """``d Phi(s) / d sig`` (entries 11, 12, 21, 22) of ``x'' + 2 sig x' + k x = 0`` at fixed ``k``.

    With ``Phi = e^{-sig s} [C I + S (A + sig I)]``, ``C = cosh(mu s)``, ``S = sinh(mu s) /
    mu`` (entire functions of ``mu^2 = sig^2 - k``; cos/sin in the underdamped case),
    ``dC/dmu^2 = s S / 2`` and ``dS/dmu^2 = (s C - S) / (2 mu^2)``, summed as a series
    when ``|mu^2| s^2 < 0.1`` (near critical damping).
    """
    E = math.exp(-sig * s)
    z = (sig * sig - k) * s * s
    if typ == 0:
        c = math.cos(q * s)
        sn = math.sin(q * s)
        Ec = E * c
        Es = E * sn / q
        if abs(z) < 0.1:
            Ed = E * s * s * s * _series_ds(z)
        else:
            Ed = E * (s * c - sn / q) / (-2.0 * q * q)
    elif typ == 2:
        e1 = math.exp(l1 * s)
        e2 = math.exp(l2 * s)
        Ec = 0.5 * (e1 + e2)
        Es = -e1 * math.expm1(-2.0 * q * s) / (2.0 * q)
        if abs(z) < 0.1:
            Ed = E * s * s * s * _series_ds(z)
        else:
            Ed = (s * Ec - Es) / (2.0 * q * q)
    else:
        Ec = E
        Es = s * E
        Ed = E * s * s * s / 6.0
    dEc = -s * Ec + sig * s * Es
    dEs = -s * Es + 2.0 * sig * Ed
    return dEc + sig * dEs + Es, dEs, -k * dEs, dEc - sig * dEs - Es


@njit(cache=True)
def _restitution_slope(U, table_U, table_R):
    """``dR/dU-`` of the piecewise-linear restitution law (0 for a constant R)."""
    n = table_U.shape[0]
    if n < 2 or U <= table_U[0] or U >= table_U[n - 1]:
        return 0.0
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if table_U[mid] <= U:
            lo = mid
        else:
            hi = mid
    return (table_R[hi] - table_R[lo]) / (table_U[hi] - table_U[lo])


# ============================================================================ tangent flows
@njit(cache=True)
def _flow_free(J, ta, tb, eta, etad, Om, mp, a, b, da, db, dsig, dOm):
    """Tangent of the free modal flow from ``ta`` to ``tb`` (absolute times), in place.

    ``J`` (2N, 2N+1): rows ``eta``, ``eta'``; last column ``d/dp``.  ``(eta, etad)`` is
    the state at ``ta``; ``a, b`` the particular solution ``a sin + b cos`` and ``da,
    db, dsig, dOm`` their derivatives, the damping derivative and 1 for Omega.
    """
    N = eta.shape[0]
    ncol = J.shape[1]
    s = tb - ta
    if s <= 0.0:
        return
    sa, ca = math.sin(Om * ta), math.cos(Om * ta)
    sb, cb = math.sin(Om * tb), math.cos(Om * tb)
    ip = ncol - 1
    for i in range(N):
        sig = mp[i, 0]
        kk = mp[i, 1]
        typ = int(mp[i, 2])
        t11, t12, t21, t22 = _phi(s, sig, kk, typ, mp[i, 3], mp[i, 4], mp[i, 5])
        for c in range(ncol):
            u = J[i, c]
            v = J[N + i, c]
            J[i, c] = t11 * u + t12 * v
            J[N + i, c] = t21 * u + t22 * v
        # explicit parameter dependence of the flow map at fixed times and fixed z(ta)
        dpa = da[i] * sa + db[i] * ca + dOm * ta * (a[i] * ca - b[i] * sa)
        dva = (dOm * (a[i] * ca - b[i] * sa) + Om * (da[i] * ca - db[i] * sa)
               - Om * dOm * ta * (a[i] * sa + b[i] * ca))
        dpb = da[i] * sb + db[i] * cb + dOm * tb * (a[i] * cb - b[i] * sb)
        dvb = (dOm * (a[i] * cb - b[i] * sb) + Om * (da[i] * cb - db[i] * sb)
               - Om * dOm * tb * (a[i] * sb + b[i] * cb))
        ep = dpb - (t11 * dpa + t12 * dva)
        ev = dvb - (t21 * dpa + t22 * dva)
        if dsig[i] != 0.0:
            x0 = eta[i] - (a[i] * sa + b[i] * ca)
            y0 = etad[i] - Om * (a[i] * ca - b[i] * sa)
            d11, d12, d21, d22 = _dtrans_dsig(s, sig, kk, typ, mp[i, 3], mp[i, 4], mp[i, 5])
            ep += dsig[i] * (d11 * x0 + d12 * y0)
            ev += dsig[i] * (d21 * x0 + d22 * y0)
        J[i, ip] += ep
        J[N + i, ip] += ev


@njit(cache=True)
def _flow_stuck(J, ta, tb, eta, etad, Om, mpC, aC, bC, eC, Psi, daC, dbC, deC, dsigC,
                deta_c, eta_c, dOm):
    """Tangent of the constrained flow (held on the stop) from ``ta`` to ``tb``, in place.

    ``eta = eta_c + Psi zeta``; the tangent is mapped to ``zeta`` with ``Psi^T``,
    advanced per constrained mode and mapped back (``d eta_c / dp`` added to the
    parameter column).
    """
    N = eta.shape[0]
    Nc = Psi.shape[1]
    ncol = J.shape[1]
    ip = ncol - 1
    Z = Psi.T @ J[:N]
    Zd = Psi.T @ J[N:]
    s = tb - ta
    sa, ca = math.sin(Om * ta), math.cos(Om * ta)
    sb, cb = math.sin(Om * tb), math.cos(Om * tb)
    if s > 0.0:
        for j in range(Nc):
            sig = mpC[j, 0]
            kk = mpC[j, 1]
            typ = int(mpC[j, 2])
            t11, t12, t21, t22 = _phi(s, sig, kk, typ, mpC[j, 3], mpC[j, 4], mpC[j, 5])
            for c in range(ncol):
                u = Z[j, c]
                v = Zd[j, c]
                Z[j, c] = t11 * u + t12 * v
                Zd[j, c] = t21 * u + t22 * v
            dpa = daC[j] * sa + dbC[j] * ca + dOm * ta * (aC[j] * ca - bC[j] * sa)
            dva = (dOm * (aC[j] * ca - bC[j] * sa) + Om * (daC[j] * ca - dbC[j] * sa)
                   - Om * dOm * ta * (aC[j] * sa + bC[j] * ca))
            dpb = daC[j] * sb + dbC[j] * cb + dOm * tb * (aC[j] * cb - bC[j] * sb)
            dvb = (dOm * (aC[j] * cb - bC[j] * sb) + Om * (daC[j] * cb - dbC[j] * sb)
                   - Om * dOm * tb * (aC[j] * sb + bC[j] * cb))
            # offset eC: zeta = eC + zp + Phi (zeta_a - eC - zp_a)
            ep = dpb - (t11 * dpa + t12 * dva) + deC[j] * (1.0 - t11)
            ev = dvb - (t21 * dpa + t22 * dva) - deC[j] * t21
            if dsigC[j] != 0.0:
                z0 = 0.0
                zd0 = 0.0
                for i in range(N):
                    z0 += Psi[i, j] * (eta[i] - eta_c[i])
                    zd0 += Psi[i, j] * etad[i]
                x0 = z0 - eC[j] - (aC[j] * sa + bC[j] * ca)
                y0 = zd0 - Om * (aC[j] * ca - bC[j] * sa)
                d11, d12, d21, d22 = _dtrans_dsig(s, sig, kk, typ, mpC[j, 3], mpC[j, 4], mpC[j, 5])
                ep += dsigC[j] * (d11 * x0 + d12 * y0)
                ev += dsigC[j] * (d21 * x0 + d22 * y0)
            Z[j, ip] += ep
            Zd[j, ip] += ev
    J[:N] = Psi @ Z
    J[N:] = Psi @ Zd
    for i in range(N):
        J[i, ip] += deta_c[i]


@njit(cache=True)
def _acc_free(eta, etad, t, Om, GF, cF, kF, out):
    s = math.sin(Om * t)
    for i in range(eta.shape[0]):
        out[i] = GF[i] * s - cF[i] * etad[i] - kF[i] * eta[i]


@njit(cache=True)
def _acc_stuck(eta, etad, t, Om, Psi, eta_c, GCF, cC, nu2, eC, out):
    """Constrained acceleration in full coordinates, ``Psi zeta''``."""
    N = eta.shape[0]
    Nc = Psi.shape[1]
    s = math.sin(Om * t)
    for i in range(N):
        out[i] = 0.0
    for j in range(Nc):
        z = 0.0
        zd = 0.0
        for i in range(N):
            z += Psi[i, j] * (eta[i] - eta_c[i])
            zd += Psi[i, j] * etad[i]
        azj = GCF[j] * s - cC[j] * zd - nu2[j] * (z - eC[j])
        for i in range(N):
            out[i] += Psi[i, j] * azj


@njit(cache=True)
def assemble_derivatives(evlog, n_ev, x_start, x_end, stuck_end, T_end, Om, w, m_eff, GF, Gam, cF, kF,
                         mpF, aF, bF, R, R_table_U, R_table_R,
                         mpC, aC, bC, eC, Psi, eta_c, GCF, cC, nu2, Emis,
                         dOm, dF, F, daF, dbF, dsF, dcF, daC, dbC, deC, dsC, deta_c, dR, dDelta,
                         Delta_C, Dl, R_l, R_table_U_l, R_table_R_l, dR_l, eC_l, eta_c_l):
    """Tangent ``J = d x(T_end) / d(x0, p)`` of one logged run of the beam kernel.

    Parameters
    ----------
    evlog : ndarray, shape (>= n_ev, 3 + 2N)
        The kernel's event log (``EV_*`` rows ``[kind, t, aux, eta, eta']``).
    n_ev : int
        Number of logged events.
    x_start : ndarray, shape (2N,)
        State passed to the kernel (at ``t = 0``).
    x_end : ndarray, shape (2N,)
        Final state of the run; ``stuck_end`` whether it ends on the stop.
    T_end : float
        End time ``n T`` (nondimensional).
    Om, w, m_eff, GF, Gam, cF, kF, mpF, aF, bF, R, R_table_U, R_table_R :
        Free-flight data of the kernel (``GF = Gamma F``, ``F = Omega^2 Y``).
    mpC, aC, bC, eC, Psi, eta_c, GCF, cC, nu2 :
        Constrained-flow data (``GCF = Psi^T Gamma F``).
    Emis : ndarray, shape (Nc, Nc)
        ``Psi^T C Psi - diag(cC)`` (zero for Rayleigh damping, where the constrained
        damping is exactly the projected one).
    dOm, dF, daF, dbF, dsF, dcF, daC, dbC, deC, dsC, deta_c, dR, dDelta :
        Derivatives with respect to the parameter ``p``: 1 for Omega, ``dF/dp``, the
        particular solutions, ``d sig_i / dp`` and ``d c_i / dp`` of the free and
        constrained modes, ``d eC / dp``, ``d eta_c / dp``, 1 for R, 1 for ``Delta_C``.
    Delta_C, Dl, R_l, R_table_U_l, R_table_R_l, dR_l, eC_l, eta_c_l :
        A second (lower) stop at ``w^T eta = -Dl`` (``Dl = inf``: one stop; ``Delta_C``
        tells the stops' events apart by the logged position): its law (``R_l`` and its
        table), ``d R_l / dp`` and the offsets ``eC``, ``eta_c`` of the beam held on it.  Its
        events use the upper stop's formulas with the normal ``n = -w`` (``U = n^T eta'``,
        ``a_n = n^T eta''``, surface ``h = n^T eta - Dl``, no ``Delta_C`` dependence); no
        native parameter moves it, so ``d eta_c / dp = d eC / dp = 0`` there.

    Returns
    -------
    J : ndarray, shape (2N, 2N + 1)
        ``[M | x_p]``.
    rel : ndarray, shape (n_rel, 2N + 2)
        Per release: time and ``d t_r / d(x0, p)``.
    n_rel : int
    n_inexact : int
        Events without an exact derivative (release forced at the end of a chatter hold,
        entry into sticking at zero velocity after the start).
    """
    N = w.shape[0]
    ncol = 2 * N + 1
    ip = 2 * N
    J = np.zeros((2 * N, ncol))
    for i in range(2 * N):
        J[i, i] = 1.0
    w2 = 0.0
    for i in range(N):
        w2 += w[i] * w[i]
    cw = np.empty(N)          # C w / |w|^2
    for i in range(N):
        cw[i] = cF[i] * w[i] / w2
    PcwC = Psi @ (Psi.T @ cw)  # P_w C w / |w|^2
    af = np.empty(N)
    ac = np.empty(N)
    rel = np.zeros((n_ev, ncol + 1))
    n_rel = 0
    n_inexact = 0
    eta = x_start[:N].copy()
    etad = x_start[N:].copy()
    t_cur = 0.0
    stuck = False
    # the stops' events are told apart by the logged position w^T eta (Delta_C or -Dl)
    mid = 0.5 * (Delta_C - Dl)
    nl = -w                    # normal of the lower stop
    cwl = -cw
    PcwCl = -PcwC
    zC = np.zeros(eC.shape[0])
    zN = np.zeros(N)
    held_low = False           # the stop the beam is held on (when stuck)
    k = 0
    while k < n_ev:
        kind = int(evlog[k, 0])
        te = evlog[k, 1]
        aux = evlog[k, 2]
        eta_e = evlog[k, 3:3 + N]
        etad_e = evlog[k, 3 + N:3 + 2 * N]
        low = False
        if Dl < np.inf:
            r = 0.0
            for i in range(N):
                r += w[i] * eta_e[i]
            low = r < mid
        if kind == EV_START:
            # the kernel put the initial state on the stop (position; velocity if held)
            for c in range(ncol):
                r = 0.0
                for i in range(N):
                    r += w[i] * J[i, c]
                for i in range(N):
                    J[i, c] -= w[i] * r / w2
                if abs(aux) > 0.5:
                    r = 0.0
                    for i in range(N):
                        r += w[i] * J[N + i, c]
                    for i in range(N):
                        J[N + i, c] -= w[i] * r / w2
            if not low:
                for i in range(N):
                    J[i, ip] += dDelta * w[i] / w2
            stuck = abs(aux) > 0.5
            held_low = low
            eta[:] = eta_e
            etad[:] = etad_e
            k += 1
            continue
        # ---- flow up to the event
        if stuck:
            if held_low:
                _flow_stuck(J, t_cur, te, eta, etad, Om, mpC, aC, bC, eC_l, Psi, daC, dbC, zC, dsC,
                            zN, eta_c_l, dOm)
            else:
                _flow_stuck(J, t_cur, te, eta, etad, Om, mpC, aC, bC, eC, Psi, daC, dbC, deC, dsC,
                            deta_c, eta_c, dOm)
        else:
            _flow_free(J, t_cur, te, eta, etad, Om, mpF, aF, bF, daF, dbF, dsF, dOm)
        t_cur = te
        # the event's stop: normal, law, d/dp of its offset (upper: w, R, Delta_C)
        if low:
            nv, cwk, Pck, Rk, tUk, tRk, dRk, dDk = nl, cwl, PcwCl, R_l, R_table_U_l, R_table_R_l, dR_l, 0.0
        else:
            nv, cwk, Pck, Rk, tUk, tRk, dRk, dDk = w, cw, PcwC, R, R_table_U, R_table_R, dR, dDelta
        # row h_x J + h_p e_p of the contact surface h = n^T eta - Delta_k
        hrow = np.zeros(ncol)
        if kind == EV_IMPACT or kind == EV_STICK:
            for c in range(ncol):
                r = 0.0
                for i in range(N):
                    r += nv[i] * J[i, c]
                hrow[c] = r
            hrow[ip] -= dDk
        if kind == EV_IMPACT and not (k + 1 < n_ev and int(evlog[k + 1, 0]) == EV_STICK_IMPACT):
            U = 0.0
            for i in range(N):
                U += nv[i] * etad_e[i]
            Rc = restitution_coefficient(U, Rk, tUk, tRk)
            Rp = _restitution_slope(U, tUk, tRk)
            _acc_free(eta_e, etad_e, te, Om, GF, cF, kF, af)
            an = 0.0
            for i in range(N):
                an += nv[i] * af[i]
            gv = (1.0 + Rc + Rp * U) / w2
            # G_x: eta' -= n (1 + R + R'U) n^T eta' / |w|^2 ; G_R = -n U / |w|^2
            for c in range(ncol):
                r = 0.0
                for i in range(N):
                    r += nv[i] * J[N + i, c]
                for i in range(N):
                    J[N + i, c] -= nv[i] * gv * r
            for i in range(N):
                J[N + i, ip] -= dRk * nv[i] * U / w2
            # (f+ - G_x f-) / (h_x f-), in closed form
            if U > 0.0:
                for c in range(ncol):
                    hc = hrow[c]
                    if hc != 0.0:
                        for i in range(N):
                            J[i, c] -= (1.0 + Rc) * nv[i] / w2 * hc
                            J[N + i, c] += ((1.0 + Rc) * cwk[i] + gv * nv[i] * an / U) * hc
            P = -(1.0 + Rc) * m_eff * U
            eta[:] = eta_e
            for i in range(N):
                etad[i] = etad_e[i] + nv[i] * P
            k += 1
            continue
        if kind == EV_IMPACT or kind == EV_STICK:
            # plastic entry into sticking from the pre-event state (impact + projection,
            # or a touch at zero velocity)
            U = 0.0
            for i in range(N):
                U += nv[i] * etad_e[i]
            zd = Psi.T @ etad_e
            corr = np.zeros(N)
            if Emis.shape[0] > 0 and U != 0.0:
                corr = Psi @ (Emis @ zd) / U
            for c in range(ncol):
                r = 0.0
                for i in range(N):
                    r += nv[i] * J[N + i, c]
                for i in range(N):
                    J[N + i, c] -= nv[i] * r / w2
            if U > 0.0:
                for c in range(ncol):
                    hc = hrow[c]
                    if hc != 0.0:
                        for i in range(N):
                            J[i, c] -= nv[i] / w2 * hc
                            J[N + i, c] += (Pck[i] + corr[i]) * hc
            elif te > 0.0:
                n_inexact += 1
            eta[:] = eta_e
            for i in range(N):
                etad[i] = etad_e[i] - nv[i] * U / w2
            stuck = True
            held_low = low
            if kind == EV_IMPACT:
                k += 2
            else:
                k += 1
            continue
        if kind == EV_RELEASE:
            eta[:] = eta_e
            etad[:] = etad_e
            _acc_free(eta, etad, te, Om, GF, cF, kF, af)
            if held_low:
                _acc_stuck(eta, etad, te, Om, Psi, eta_c_l, GCF, cC, nu2, eC_l, ac)
            else:
                _acc_stuck(eta, etad, te, Om, Psi, eta_c, GCF, cC, nu2, eC, ac)
            # lambda = -m_eff n^T a_free;  d lambda / dt along the constrained flow
            ldot = 0.0
            cs = math.cos(Om * te)
            sn = math.sin(Om * te)
            for i in range(N):
                ldot += nv[i] * (GF[i] * Om * cs - cF[i] * ac[i] - kF[i] * etad[i])
            ldot *= -m_eff
            lrow = np.zeros(ncol)
            for c in range(ncol):
                r = 0.0
                for i in range(N):
                    r += m_eff * nv[i] * (kF[i] * J[i, c] + cF[i] * J[N + i, c])
                lrow[c] = r
            lp = 0.0
            for i in range(N):
                lp -= m_eff * nv[i] * (Gam[i] * (dF * sn + dOm * F * te * cs) - dcF[i] * etad[i])
            lrow[ip] += lp
            rel[n_rel, 0] = te
            if ldot > 0.0 and aux <= 0.0:
                for c in range(ncol):
                    rel[n_rel, 1 + c] = -lrow[c] / ldot
                    for i in range(N):
                        J[N + i, c] += (af[i] - ac[i]) * lrow[c] / ldot
            elif te > 0.0:
                n_inexact += 1   # release at a step start with lambda > 0 (end of a chatter hold)
            n_rel += 1
            stuck = False
            k += 1
            continue
        # EV_STICK_IMPACT without its impact cannot happen; skip defensively
        k += 1
    if stuck:
        if held_low:
            _flow_stuck(J, t_cur, T_end, eta, etad, Om, mpC, aC, bC, eC_l, Psi, daC, dbC, zC, dsC,
                        zN, eta_c_l, dOm)
        else:
            _flow_stuck(J, t_cur, T_end, eta, etad, Om, mpC, aC, bC, eC, Psi, daC, dbC, deC, dsC,
                        deta_c, eta_c, dOm)
    else:
        _flow_free(J, t_cur, T_end, eta, etad, Om, mpF, aF, bF, daF, dbF, dsF, dOm)
    if dOm != 0.0:
        # the end time n T = 2 pi n / Omega moves with Omega: + f(nT) d(nT)/dOmega
        xe = x_end[:N]
        xde = x_end[N:]
        if stuck_end and held_low:
            _acc_stuck(xe, xde, T_end, Om, Psi, eta_c_l, GCF, cC, nu2, eC_l, ac)
        elif stuck_end:
            _acc_stuck(xe, xde, T_end, Om, Psi, eta_c, GCF, cC, nu2, eC, ac)
        else:
            _acc_free(xe, xde, T_end, Om, GF, cF, kF, ac)
        dT = -T_end / Om
        for i in range(N):
            J[i, ip] += xde[i] * dT
            J[N + i, ip] += ac[i] * dT
    return J, rel[:n_rel], n_rel, n_inexact


# ============================================================================ the problem
class BeamShooting:
    """Shooting problem of the modal FE beam (contract of :mod:`vibeam.models.periodic`).

    Parameters
    ----------
    model : BeamImpactModel
        Any number of modes (``from_fe(fe, "all")`` included) or the static-mode model.
    Omega : float
        Forcing frequency ``f / f_ref`` (nondimensional): the starting value when the
        parameter is ``"Omega"``, the fixed frequency otherwise.
    parameter : str, optional
        Native continuation parameter, one of :data:`NATIVE_PARAMETERS` (``Omega``,
        ``base_amplitude_m`` (m), ``gap_contact_m`` (m), ``R``, ``damping_D_s`` (s),
        ``rayleigh_alpha_1_s`` (1/s)).  Physical keys go through :func:`conversions`.
    chatter_tol, steps_per_fundamental, max_impacts_per_period, max_steps_per_period :
        Settings of the event kernel, as :class:`~vibeam.models.beam_dynamics.BeamEventSolver`
        (same defaults, so that a stable fixed point is what a sweep lands on).

    Attributes
    ----------
    dim : int
        ``2 N``: the state is ``(eta, eta')`` (modal coordinates, sqrt(kg) m, and their
        derivatives with respect to the nondimensional time ``t = omega_ref t~``).
    parameter : str
    value : float
        The parameter's value in ``model`` (``Omega`` for ``"Omega"``).
    state_scale : float
        ``L sqrt(m_eff)``: ``x / state_scale`` is of the order of ``U / L`` (a natural
        norm for a continuation engine).

    Raises
    ------
    ValueError
        For a parameter that is not native (a key that needs an FE rebuild is named as
        such), ``R`` with a tabulated restitution law, or a damping parameter of a model
        with per-mode damping.
    """

    fidelity = "beam"

    def __init__(self, model: BeamImpactModel, Omega: float, parameter: str = "Omega",
                 chatter_tol: float = 1e-7, steps_per_fundamental: int = 16,
                 max_impacts_per_period: int = 20000, max_steps_per_period: int = 20000):
        _check_parameter(parameter)
        if parameter == "R" and model.R_table_U.size:
            raise ValueError("parameter 'R' cannot be continued with a tabulated restitution law "
                             "(effect restitution_law)")
        if parameter in ("damping_D_s", "rayleigh_alpha_1_s") and model.modal_damping_1_s is not None:
            raise ValueError(f"parameter {parameter!r} does not act on a model with per-mode damping "
                             f"(modal_damping_1_s)")
        if not (np.isfinite(Omega) and Omega > 0):
            raise ValueError(f"Omega must be positive and finite, got {Omega!r}")
        self.model = model
        self.Omega = float(Omega)
        self.parameter = parameter
        self.pid = _PID[parameter]
        self.value = self.Omega if parameter == "Omega" else float(getattr(model, parameter))
        self.dim = 2 * model.n_modes
        self.state_scale = model.length_m * math.sqrt(model.m_eff)
        self.chatter_tol = float(chatter_tol)
        self.steps_per_fundamental = int(steps_per_fundamental)
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.max_steps_per_period = int(max_steps_per_period)
        self._cache_key = None
        self._cache = None
        self._tables = None
        self._cap = 64
        self._capa = 64

    # ------------------------------------------------------------------ model at p
    def model_at(self, p: float) -> BeamImpactModel:
        """The model with the parameter set to ``p`` (the model itself for Omega)."""
        if self.parameter == "Omega" or p == self.value:
            return self.model
        m = copy.copy(self.model)
        setattr(m, self.parameter, float(p))
        m._constrained()
        return m

    def _data(self, p):
        """Kernel arrays and parameter derivatives at ``p`` (cached for the last ``p``)."""
        key = float(p)
        if key == self._cache_key:
            return self._cache
        m = self.model_at(p)
        Om = key if self.parameter == "Omega" else self.Omega
        N = m.n_modes
        Y = m.base_amplitude_m
        F = Om ** 2 * Y
        k, c = m.k_nd, m.c_nd
        G = m.participation
        w = m.contact_row
        w2 = float(w @ w)
        Nc = m.nu2.size
        if self.parameter in ("damping_D_s", "rayleigh_alpha_1_s") or self._tables is None:
            tables = (mode_table(c, k), mode_table(m.cC, m.nu2) if Nc else np.zeros((0, 6)))
            if self.parameter not in ("damping_D_s", "rayleigh_alpha_1_s"):
                self._tables = tables     # the mode tables depend on the damping only
        else:
            tables = self._tables
        mpF, mpC = tables
        aF, bF = particular(c, k, G, F, Om)
        GF = G * F
        aC, bC = particular(m.cC, m.nu2, m.GC, F, Om)
        me = m.m_eff
        lamF = -me * float(w @ G) * F
        SaL = lamF + float(m.pL @ aC - Om * (m.rL @ bC))
        SbL = float(m.pL @ bC + Om * (m.rL @ aC))
        SaS = float(m.pS @ aC)
        SbS = float(m.pS @ bC)
        # ---- derivatives with respect to the parameter
        pid = self.pid
        dOm = 1.0 if pid == 0 else 0.0
        dF = 2.0 * Om * Y if pid == 0 else (Om ** 2 if pid == 1 else 0.0)
        zN = np.zeros(N)
        zC = np.zeros(Nc)
        dcF, dcC = zN.copy(), zC.copy()
        if pid == 4:
            dcF = m.omega_ref * k
            dcC = m.omega_ref * m.nu2
        elif pid == 5:
            dcF = np.full(N, 1.0 / m.omega_ref)
            dcC = np.full(Nc, 1.0 / m.omega_ref)

        def dpart(cc, kk, GG, dc):
            """d(a + i b)/dp of z = G F / (k - Omega^2 + i c Omega) (see ``particular``)."""
            den = kk - Om ** 2 + 1j * cc * Om
            dz = GG * (dF / den - dOm * F * (-2.0 * Om + 1j * cc) / den ** 2
                       - F * 1j * Om * dc / den ** 2)
            return np.ascontiguousarray(dz.real), np.ascontiguousarray(dz.imag)

        daF, dbF = dpart(c, k, G, dcF)
        daC, dbC = dpart(m.cC, m.nu2, m.GC, dcC) if Nc else (zC, zC)
        deC, deta_c = zC.copy(), zN.copy()
        if pid == 2:
            deta_c = w / w2
            if Nc:
                deC = -(m.Psi.T @ (k * deta_c)) / np.where(m.nu2 > 0, m.nu2, 1.0)
        if m.modal_damping_1_s is not None and Nc:
            Emis = m.Psi.T @ (c[:, None] * m.Psi)
            Emis[np.diag_indices(Nc)] -= m.cC
        else:
            Emis = np.zeros((0, 0))
        stops, tab_U, tab_R = pack(m.stops())
        if m.two_sided:
            # the contact force of the beam held on either stop (kernel rows), and the lower stop's
            # law: its own R, or the upper stop's law (then R moves it too: d R_l / d R = 1)
            SaLk, SbLk = m.stop_forcing(aC, bC, F, Om)
            own = m.R_lower is not None
            lower = dict(Dl=float(m.gap_contact_lower_m), R_l=float(m.R_lower) if own else float(m.R),
                         tU_l=np.zeros(0) if own else m.R_table_U, tR_l=np.zeros(0) if own else m.R_table_R,
                         dR_l=0.0 if own or pid != 3 else 1.0,
                         eC_l=np.ascontiguousarray(m.stop_rows["eC"][1]),
                         eta_c_l=np.ascontiguousarray(m.stop_rows["eta_c"][1]))
        else:
            SaLk, SbLk = np.array([SaL]), np.array([SbL])
            lower = dict(Dl=np.inf, R_l=0.0, tU_l=m.R_table_U, tR_l=m.R_table_R, dR_l=0.0,
                         eC_l=m.eC, eta_c_l=m.eta_c)
        self._cache_key = key
        self._cache = dict(
            core=EventIntegrator(from_beam(m), m.stops()), stops=stops, tab_U=tab_U, tab_R=tab_R, m=m, me=me, Om=Om, F=F, mpF=mpF, aF=aF, bF=bF, GF=GF, c=c, k=k,
            mpC=mpC, aC=aC, bC=bC,
            SaL=SaL, SbL=SbL, SaS=SaS, SbS=SbS, GCF=m.GC * F, Emis=np.ascontiguousarray(Emis),
            dOm=dOm, dF=dF, daF=daF, dbF=dbF, dsF=0.5 * dcF, dcF=dcF, daC=daC, dbC=dbC,
            deC=np.ascontiguousarray(deC), dsC=0.5 * dcC, deta_c=np.ascontiguousarray(deta_c),
            dR=1.0 if pid == 3 else 0.0, dDelta=1.0 if pid == 2 else 0.0,
            SaLk=SaLk, SbLk=SbLk, lower=lower)
        return self._cache

    def linear_orbit(self, p: float | None = None) -> np.ndarray:
        """Start of the contact-free branch: ``(eta, eta')`` at forcing phase 0 of the
        harmonic steady state without the stop (``eta_i = a_i sin + b_i cos``), shape (2N,).

        It is a fixed point of ``P`` while ``apex_gap < 0``; ``apex_gap = 0`` is its grazing.
        """
        D = self._data(self.value if p is None else p)
        return np.concatenate([D["bF"], D["Om"] * D["aF"]])

    @staticmethod
    def _invalid(p, name):
        if name == "R" and not 0.0 <= p <= 1.0:
            return "R must lie in [0, 1]"
        if name in ("damping_D_s", "rayleigh_alpha_1_s") and p < 0.0:
            return f"{name} must be >= 0"
        if name == "Omega" and not p > 0.0:
            return "Omega must be positive"
        return ""

    # ------------------------------------------------------------------ the shot
    def shot(self, x0, p: float, n: int = 1, derivatives: bool = True, stuck=None) -> Shot:
        """``P^n(x0; p)`` with its monodromy, ``d x / d p``, events and test values.

        Parameters
        ----------
        x0 : array_like, shape (2N,)
            ``(eta, eta')`` at forcing phase 0.
        p : float
            Value of the parameter (native units).
        n : int, optional
            Number of forcing periods.
        derivatives : bool, optional
            Assemble ``M`` and ``x_p`` (False: NaN arrays, the cost of the kernel alone).
        stuck : bool or None, optional
            Start held on the stop; None: when ``x0`` lies on the stop with zero normal
            velocity within ``1e-9`` of the state scale.

        Returns
        -------
        Shot
            ``x``, ``M`` (2N, 2N), ``x_p`` (2N,), ``impact_times`` (from the section,
            nondimensional), ``impact_velocities`` (``U- / L`` per unit nondimensional time,
            as the sweep's output), ``q_min``/``q_max`` of ``q = U(L_S) / L`` (exact
            extremes located by the kernel), ``apex_gap`` (m, ``w^T eta - Delta_C`` at the
            largest located interior free-flight apex), ``stuck_time`` (nondimensional),
            ``status`` (``ok``, ``chatter``, ``failed``), ``Omega`` (the forcing frequency),
            ``gap`` (``Delta = Delta_C / (phi(x_m) L)`` at ``p``: the stop of the output
            coordinate, so that ``Q = gap - q_min`` is the sweep's amplitude) and ``extra``:
            ``event_kinds``, ``event_times``, ``event_states`` (n_ev, 2N: the state logged with
            each event, before an impact), ``release_times``, ``release_time_derivatives`` (n_rel, 2N+1),
            ``apexes`` (k, 2: time, gap), ``n_chatter``, ``stuck_start``, ``stuck_end``,
            ``n_inexact``.
        """
        n = int(n)
        d = self.dim
        N = d // 2
        x0 = np.asarray(x0, dtype=float).reshape(-1)
        nanM = np.full((d, d), np.nan)
        nanv = np.full(d, np.nan)
        bad = self._invalid(float(p), self.parameter)
        if x0.shape != (d,) or not np.all(np.isfinite(x0)) or n < 1 or bad or not np.isfinite(p):
            msg = bad or (f"x0 must be finite with shape ({d},) and n >= 1; got shape {x0.shape}, n = {n}")
            return Shot(x=nanv, M=nanM, x_p=nanv, impact_times=np.zeros(0),
                        impact_velocities=np.zeros(0), q_min=np.nan, q_max=np.nan,
                        status="failed", message=msg)
        D = self._data(p)
        m = D["m"]
        Om = D["Om"]
        T = TWO_PI / Om
        w = m.contact_row
        w2 = float(w @ w)
        eta = x0[:N].copy()
        etad = x0[N:].copy()
        stuck_low = False
        if m.two_sided and not m.gap_contact_m + m.gap_contact_lower_m > 0.0:
            return Shot(x=nanv, M=nanM, x_p=nanv, impact_times=np.zeros(0),
                        impact_velocities=np.zeros(0), q_min=np.nan, q_max=np.nan, status="failed",
                        message=f"the stops overlap: gap_contact_m + gap_contact_lower_m = "
                                f"{m.gap_contact_m + m.gap_contact_lower_m:.6g} must be > 0")
        if stuck is None:
            g0 = float(w @ eta) - m.gap_contact_m
            v0 = float(w @ etad)
            sg = abs(m.gap_contact_m) + math.sqrt(w2) * float(np.linalg.norm(eta)) + 1e-300
            sv = math.sqrt(w2) * (float(np.linalg.norm(etad)) + Om * float(np.linalg.norm(eta))) + 1e-300
            stuck = bool(g0 > -1e-9 * sg and abs(v0) <= 1e-9 * sv)
            if not stuck and m.two_sided:
                # held on the lower stop at the section
                gl0 = -float(w @ eta) - m.gap_contact_lower_m
                sgl = abs(m.gap_contact_lower_m) + math.sqrt(w2) * float(np.linalg.norm(eta)) + 1e-300
                stuck = stuck_low = bool(gl0 > -1e-9 * sgl and abs(v0) <= 1e-9 * sv)
        elif stuck and m.two_sided:
            stuck_low = float(w @ eta) < 0.5 * (m.gap_contact_m - m.gap_contact_lower_m)
        if stuck:
            etad -= w * float(w @ etad) / w2
        x_start = np.concatenate([eta, etad])
        h_cap = TWO_PI / math.sqrt(D["k"][0]) / self.steps_per_fundamental
        imp_cap = 64 * n + 64
        held = (2 if stuck_low else 1) if stuck else 0
        while True:
            # the one event integrator (:mod:`vibeam.models.core.integrator`) with its event log
            run = D["core"].run(Om, eta, etad, held, 0, n, 1, 1, float(h_cap), self.max_impacts_per_period * n,
                                self.max_steps_per_period * n, self.chatter_tol, impact_buffer=imp_cap,
                                log_events=self._cap, log_apexes=self._capa)
            nlog = run.record.nlog
            n_imp = run.n_impacts
            if nlog[0] <= self._cap and nlog[1] <= self._capa and n_imp <= imp_cap:
                break
            self._cap = max(self._cap, int(nlog[0]) + 16)
            self._capa = max(self._capa, int(nlog[1]) + 16)
            imp_cap = max(imp_cap, int(n_imp) + 16)
        status, smin, smax, n_chat, stuck_time = run.status, run.s_min, run.s_max, run.n_chatter, run.stuck_time
        stuck_end, n_tot, n_steps = run.held_end != 0, run.n_impacts_total, run.n_steps
        imp_t, imp_v, imp_k = run.record.imp_t, run.record.imp_v, run.record.imp_k
        e, ed = run.eta, run.etad
        # the log's rows without their stop column (the derivatives tell the stops apart by position)
        evlog = np.ascontiguousarray(np.delete(run.record.evlog, 3, axis=1))
        aplog = run.record.aplog[:, :2]
        L = m.length_m
        n_ev, n_ap = int(nlog[0]), int(nlog[1])
        x = np.concatenate([e, ed])
        extra = dict(event_kinds=evlog[:n_ev, 0].astype(int), event_times=evlog[:n_ev, 1].copy(),
                     event_states=evlog[:n_ev, 3:].copy(),
                     apexes=aplog[:n_ap].copy(), n_chatter=int(n_chat), stuck_start=bool(stuck),
                     stuck_end=bool(stuck_end), n_steps=int(n_steps))
        if m.two_sided:
            extra["impact_stops"] = imp_k[:n_imp].copy()
        if status == ST_FAILED:
            return Shot(x=x, M=nanM, x_p=nanv, impact_times=imp_t[:n_imp].copy(),
                        impact_velocities=imp_v[:n_imp] / L, q_min=smin / L, q_max=smax / L,
                        stuck_time=float(stuck_time), status="failed", Omega=Om, gap=m.Delta,
                        message=f"event kernel gave up after {n_tot} impacts / {n_steps} steps in "
                                f"{n} periods (non-accumulating chatter or step collapse)",
                        extra=extra)
        M, xp = nanM, nanv
        n_inexact = 0
        if derivatives:
            lo = D["lower"]
            J, rel, n_rel, n_inexact = assemble_derivatives(
                evlog, n_ev, x_start, x, bool(stuck_end), n * T, Om, w, D["me"], D["GF"],
                m.participation, D["c"], D["k"], D["mpF"], D["aF"], D["bF"], m.R, m.R_table_U,
                m.R_table_R, D["mpC"], D["aC"], D["bC"], m.eC, m.Psi, m.eta_c, D["GCF"], m.cC,
                m.nu2, D["Emis"], D["dOm"], D["dF"], D["F"], D["daF"], D["dbF"], D["dsF"],
                D["dcF"], D["daC"], D["dbC"], D["deC"], D["dsC"], D["deta_c"], D["dR"], D["dDelta"],
                m.gap_contact_m, lo["Dl"], lo["R_l"], lo["tU_l"], lo["tR_l"], lo["dR_l"], lo["eC_l"],
                lo["eta_c_l"])
            M = J[:, :d].copy()
            xp = J[:, d].copy()
            extra["release_times"] = rel[:, 0].copy()
            extra["release_time_derivatives"] = rel[:, 1:].copy()
        extra["n_inexact"] = int(n_inexact)
        apex = float(np.max(aplog[:n_ap, 1])) if n_ap else -np.inf
        st, msg = "ok", ""
        if n_inexact:
            st = "chatter"
            msg = (f"{n_inexact} event(s) without an exact derivative (release forced at the end "
                   f"of a chatter hold, or entry into sticking at zero velocity)")
        return Shot(x=x, M=M, x_p=xp, impact_times=imp_t[:n_imp].copy(),
                    impact_velocities=imp_v[:n_imp] / L, q_min=float(smin / L), q_max=float(smax / L),
                    apex_gap=apex, stuck_time=float(stuck_time), status=st, message=msg, extra=extra,
                    Omega=Om, gap=m.Delta)

    # ------------------------------------------------------------------ starting orbits
    #: starts this problem offers besides the framework's ``sweep`` (no averaging for the beam:
    #: paper Eqs. 18-27 are the SDOF's)
    starts = ("linear",)

    def linear_amplitude(self, p: float) -> float:
        """Amplitude ``|w^T (a + i b)|`` (m) of the contact displacement of the contact-free
        harmonic steady state at ``p`` (closed form; its grazing is where it equals
        ``Delta_C``)."""
        D = self._data(p)
        w = D["m"].contact_row
        return float(abs(w @ (D["aF"] + 1j * D["bF"])))

    def start(self, kind: str, p: float, n: int = 1):
        """Initial state of a closed-form orbit at ``p`` (contract of
        :mod:`vibeam.models.periodic`).

        Parameters
        ----------
        kind : {"linear"}
            The contact-free harmonic steady state (:meth:`linear_orbit`), where its contact
            amplitude stays below ``Delta_C``.
        p : float
            Value of the parameter (native units).
        n : int, optional
            Period (any: the orbit has period 1).

        Returns
        -------
        x0 : ndarray, shape (2N,) or None
        reason : str
            Empty when the orbit exists, else why not.

        Raises
        ------
        ValueError
            For a start the beam does not offer (``averaging``: the averaging solution of paper
            Eqs. 18-27 is the SDOF model's).
        """
        if kind != "linear":
            raise ValueError(f"start {kind!r} is not available for the beam; allowed: "
                             f"{', '.join(self.starts)} (and 'sweep')")
        bad = self._invalid(float(p), self.parameter)
        if bad:
            return None, bad
        A = self.linear_amplitude(p)
        mp = self._data(p)["m"]
        DC = mp.gap_contact_m
        if not A < DC:
            return None, (f"the non-impacting orbit does not exist: its contact amplitude {A:.6g} m "
                          f"reaches the stop Delta_C = {DC:.6g} m at {self.parameter} = {p:.6g}")
        if mp.two_sided and not A < mp.gap_contact_lower_m:
            return None, (f"the non-impacting orbit does not exist: its contact amplitude {A:.6g} m "
                          f"reaches the lower stop Delta_C,lower = {mp.gap_contact_lower_m:.6g} m at "
                          f"{self.parameter} = {p:.6g}")
        return self.linear_orbit(p), ""

    # ------------------------------------------------------------------ section crossing
    def resect(self, x0, p: float, n: int = 1):
        """The same orbit seen on the other side of an impact that coincides with the section.

        When an impact of the orbit through ``x0`` approaches forcing phase 0 (the first one
        at ``t -> 0+`` or the last one at ``t -> n T-``), the state at the section jumps
        between the pre- and post-impact states although the orbit does not.  Returns the
        state at phase 0 with that impact moved to the other side of the section, to first
        order in its distance ``t_c < 1e-6 T`` from the section (the engine corrects it by
        Newton beyond the crossing): the post-impact state of the first impact (Newton impulse
        through the mass matrix, paper Eq. 41), or the pre-impact state of the last one; None if
        no impact lies within ``1e-6 T`` of the section (a sticking orbit held at the section is
        represented already, see the class docstring).

        The states are not carried across ``t_c`` by the free flow, as the SDOF's are: with the
        stiff, overdamped high modes of a fine mesh the impulse sets off damping forces of
        order ``c_i U`` (``c_i = D omega_i^2``), so the post-impact state carried back to phase
        0 is a virtual state whose contact velocity may point into the stop (measured with all
        46 modes of the rig: a spurious impact 1e-10 T after the section).
        """
        s = self.shot(x0, p, n, derivatives=False)
        if s.status != "ok" or not s.n_impacts:
            return None
        kinds = s.extra["event_kinds"]
        D = self._data(p)
        m, Om = D["m"], D["Om"]
        T = TWO_PI / Om
        N = m.n_modes
        w = m.contact_row
        rows = np.flatnonzero((kinds == EV_IMPACT) | (kinds == EV_STICK_IMPACT))
        if not rows.size:
            return None
        times, states = s.extra["event_times"], s.extra["event_states"]
        i, j = rows[0], rows[-1]
        if times[i] < 1e-6 * T and kinds[i] == EV_IMPACT:
            eta, etad = states[i, :N].copy(), states[i, N:].copy()
            nv, law = w, m.stops()[0].law
            if m.two_sided and float(w @ eta) < 0.5 * (m.gap_contact_m - m.gap_contact_lower_m):
                nv, law = -w, m.stops()[1].law        # an impact on the lower stop (normal -w)
            U = float(nv @ etad)
            Rc = restitution_coefficient(U, law.R, np.asarray(law.table_U, float), np.asarray(law.table_R, float)) \
                if m.two_sided else restitution_coefficient(U, m.R, m.R_table_U, m.R_table_R)
            etad -= nv * (1.0 + Rc) * U / float(w @ w)
            return np.concatenate([eta, etad])
        if times[j] > n * T - 1e-6 * T and kinds[j] == EV_IMPACT:
            return states[j].copy()
        return None

    @staticmethod
    def _free_flow(eta, etad, ta, tb, D):
        """``(eta, eta')`` at ``tb`` from the state at ``ta`` by the closed-form free modal
        flow (either direction in time; per mode ``z(tb) = Phi(tb - ta) (z(ta) - z_p(ta)) +
        z_p(tb)``, :func:`_phi`)."""
        Om, mp, a, b = D["Om"], D["mpF"], D["aF"], D["bF"]
        s = tb - ta
        zp = lambda t: (a * math.sin(Om * t) + b * math.cos(Om * t),
                        Om * (a * math.cos(Om * t) - b * math.sin(Om * t)))
        pa, va = zp(ta)
        pb, vb = zp(tb)
        N = eta.size
        out = np.empty(2 * N)
        for i in range(N):
            t11, t12, t21, t22 = _phi(s, mp[i, 0], mp[i, 1], int(mp[i, 2]), mp[i, 3], mp[i, 4], mp[i, 5])
            u, v = eta[i] - pa[i], etad[i] - va[i]
            out[i] = t11 * u + t12 * v + pb[i]
            out[N + i] = t21 * u + t22 * v + vb[i]
        return out


class BeamContinuation(BeamShooting):
    """:class:`BeamShooting` built the way the continuation framework builds every shooting
    problem, ``cls(model, parameter, Omega=Omega)`` (registered as
    ``vibeam.models.SHOOTING["beam"]``).

    Parameters
    ----------
    model : BeamImpactModel
    parameter : str, optional
        Native parameter (:data:`NATIVE_PARAMETERS`).
    Omega : float, optional
        The fixed forcing frequency of a continuation in another parameter (required then);
        for ``"Omega"`` only the reported ``value``.
    **settings
        Event settings of :class:`BeamShooting`.

    Raises
    ------
    ValueError
        As :class:`BeamShooting`; or a missing ``Omega`` for another parameter.
    """

    def __init__(self, model: BeamImpactModel, parameter: str = "Omega", Omega: float | None = None,
                 **settings):
        if parameter != "Omega" and Omega is None:
            _check_parameter(parameter)
            raise ValueError(f"continuation in {parameter!r} needs the forcing frequency Omega")
        super().__init__(model, 1.0 if Omega is None else Omega, parameter, **settings)
        if parameter == "Omega" and Omega is None:
            self.value = math.nan
