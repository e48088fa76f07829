"""The paper's impact map of one Newton stop (Sec. 4.2, Eqs. 28-37) on the one pointwise mapping.

The impact map takes an impact on the stop at ``q = Delta`` (forcing phase ``phi = Omega t (mod 2
pi)``, pre-impact velocity ``v = q'(t-) > 0``) to the next one (Shaw & Holmes; the flight is
Eq. 28).  A period-n orbit with one impact per ``n`` forcing periods (Eqs. 33-34, flight time
``n T``) is its fixed point, found by Newton's method (:func:`newton_fixed_point`); its stability
is computed three ways (:func:`fixed_point_analysis`):

* the Floquet multipliers, eigenvalues of the monodromy ``M = S Phi(n T)`` in ``(q, q')``
  (:func:`monodromy`; ``S`` the saltation matrix, :func:`vibeam.models.impact.saltation_matrix`),
  ``det M = R^2 exp(-2 beta n T)``;
* the exact Jacobian of the impact map (:func:`impact_map_jacobian`), whose eigenvalues equal them;
* the paper's determinant/trace formulas, full (Eqs. 29-32) and simplified (Eqs. 35-37), as
  printed (:func:`paper_det_trace`), judged by :func:`stable_from_det_trace`.

Everything but the formulas is the general mapping's (:mod:`vibeam.models.mapping.orbit`) on one
section of stop 0; every function takes the scene (:class:`vibeam.models.scene.Scene`, the one-mode
oscillator: :func:`vibeam.models.scene.one_mode`), a second stop allowed (its arrivals end a flight
too).  All quantities are nondimensional; ``F = Omega^2 B`` plays the role of the paper's ``gamma V Omega^2``.
"""
from __future__ import annotations

import math

import numpy as np

from ..impact import saltation_matrix
from ..scene import one_mode
from ..core.oscillator import flow_matrix
from .orbit import DEFAULT_TOL, SectionMap
from .phases import TWO_PI


def stable_from_det_trace(det, tr):
    """Schur-Cohn (Jury) test of a 2x2 map: both eigenvalues inside the unit circle,
    ``|det| < 1`` and ``|tr| < 1 + det`` (vectorised; bool or ndarray of bool)."""
    det = np.asarray(det, float)
    tr = np.asarray(tr, float)
    return (np.abs(det) < 1.0) & (np.abs(tr) < 1.0 + det)


def paper_det_trace(form, beta, F, R, Delta, Omega, phi_prev, v_prev_minus, v_minus, v_next_minus, tau, n=1):
    """Determinant and trace of the impact-map Jacobian as printed in the paper.

    ``form="full"``: Eqs. 29-32 with ``q'+(i-1) = -R v_prev_minus``, ``q'-(i) = v_minus``,
    ``q'-(i+1) = v_next_minus`` (the printed trace has ``q'-(i+1)`` in its denominator),
    ``t+(i-1)`` at forcing phase ``phi_prev`` and flight time ``tau`` (Eq. 31)::

        det = -R q'+(i-1) / q'-(i) exp(-2 beta tau)
        tr  = -exp(-beta tau) / (wD q'-(i+1)) ((N + R beta q'-(i)) sin(wD tau)
              + wD (q'+(i-1) - R q'-(i)) cos(wD tau))
        N   = F sin(phi_prev) - beta q'+(i-1) - Delta

    ``form="simplified"``: Eqs. 35-37 (period ``n``, ``tau = n T``)::

        det = R^2 exp(-beta n T)        # as printed; a damped flow gives exp(-2 beta n T)
        tr  = exp(-beta n T) / (wD v) ((R beta v + N) sin(wD n T) - 2 wD R v cos(wD n T))
        N   = F sin(phi) + R beta v - Delta

    Findings (``tests/test_mapping.py``): at a fixed point Eq. 30 equals minus Eq. 36 (a
    sign-symmetric Jury test, so the verdicts agree), and Eq. 36 equals ``tr(S' Phi(nT))`` with
    ``S' = [[-R, 0], [a+ / v-, -R]]``: the saltation term ``R a- / v-`` is missing.

    Parameters
    ----------
    form : {"full", "simplified"}
    beta, F, R, Delta, Omega : float
        Damping ratio, forcing amplitude ``Omega^2 B``, restitution, gap, frequency.
    phi_prev : float
        Forcing phase of impact ``i-1`` (the fixed point's for period-n).
    v_prev_minus, v_minus, v_next_minus : float
        Pre-impact velocities of impacts ``i-1``, ``i``, ``i+1`` (equal at a fixed point; the
        simplified form uses ``v_minus``).
    tau : float
        Flight time (full form).
    n : int
        Period (simplified form).

    Returns
    -------
    det, tr : float

    Raises
    ------
    ValueError
        For an unknown ``form``.
    """
    wd = math.sqrt(1.0 - beta * beta)
    if form == "full":
        vp = -R * v_prev_minus
        det = -R * vp / v_minus * math.exp(-2.0 * beta * tau)
        N = F * math.sin(phi_prev) - beta * vp - Delta
        tr = -math.exp(-beta * tau) / (wd * v_next_minus) * (
            (N + R * beta * v_minus) * math.sin(wd * tau) + wd * (vp - R * v_minus) * math.cos(wd * tau))
        return det, tr
    if form == "simplified":
        nT = n * TWO_PI / Omega
        det = R * R * math.exp(-beta * nT)
        N = F * math.sin(phi_prev) + R * beta * v_minus - Delta
        tr = math.exp(-beta * nT) / (wd * v_minus) * (
            (R * beta * v_minus + N) * math.sin(wd * nT) - 2.0 * wd * R * v_minus * math.cos(wd * nT))
        return det, tr
    raise ValueError(f"form must be 'full' or 'simplified', got {form!r}")


def paper_verdicts(scene, Omega, phi, v, n, stable) -> dict:
    """Eqs. 29-32 and 35-37 at the period-n fixed point ``(phi, v)`` beside the multipliers'
    verdict ``stable``: ``det_full``, ``tr_full``, ``stable_full``, ``disagree_full`` and the
    same for ``simplified``."""
    om = one_mode(scene, "the paper's map")
    F = Omega * Omega * om.B
    R = om.stops[0].law.R
    out = {}
    for form in ("full", "simplified"):
        det, tr = paper_det_trace(form, om.beta, F, R, om.Delta, Omega, phi, v, v, v,
                                  n * TWO_PI / Omega, n)
        verdict = bool(stable_from_det_trace(det, tr))
        out.update({f"det_{form}": det, f"tr_{form}": tr, f"stable_{form}": verdict,
                    f"disagree_{form}": verdict != stable})
    return out


def impact_map_jacobian(scene, Omega, phi0, v_minus, tau):
    """Exact Jacobian ``d(phi1, v1) / d(phi0, v0)`` (2, 2) of the impact map at ``(phi0, v_minus)``
    with flight time ``tau`` (the flight's end ``q(tau) = Delta`` varied: ``d tau = -dq / q'(tau)``;
    :meth:`vibeam.models.mapping.orbit.SectionMap.section_map` in forcing phases)."""
    sc = SectionMap(scene, Omega)
    pas = sc.passage(0, phi0 / sc.Omega, float(v_minus))
    J = sc.arrival(pas, pas.t + tau, 0)[2]
    return np.array([[J[0, 0], sc.Omega * J[0, 1]], [J[1, 0] / sc.Omega, J[1, 1]]])


def monodromy(scene, Omega, phi0, v_minus, tau):
    """Monodromy ``S Phi(tau)`` (2, 2) over one flight, from just after one impact to just after
    the next; for a period-n one-impact orbit (``tau = n T``) its eigenvalues are the multipliers."""
    sc = SectionMap(scene, Omega)
    pas = sc.passage(0, phi0 / sc.Omega, float(v_minus))
    _, w, acc = sc.flight(pas, pas.t + tau, 0)
    return saltation_matrix(float(sc.laws[0].R), w, acc, sc.beta) @ flow_matrix(tau, sc.beta)


def _by_modulus(z):
    z = np.asarray(z).astype(complex)
    return z[np.argsort(-np.abs(z))]


def fixed_point_analysis(scene, Omega, x, n=1):
    """Stability of the period-n fixed point ``x = (phi, v)`` by every route.

    Returns
    -------
    dict
        ``multipliers`` (complex (2,), eigenvalues of ``S Phi(nT)``), ``map_jacobian`` (2, 2),
        ``map_eigenvalues`` (complex (2,)), ``stable`` (``max |multiplier| < 1``), ``det_full``,
        ``tr_full``, ``stable_full``, ``disagree_full`` (Eqs. 29-32), the same for
        ``simplified`` (Eqs. 35-37), ``det_true``, ``tr_true`` (of the monodromy) and
        ``a_minus`` (pre-impact acceleration).
    """
    phi, v = float(x[0]), float(x[1])
    tau = n * TWO_PI / Omega
    M = monodromy(scene, Omega, phi, v, tau)
    mult = _by_modulus(np.linalg.eigvals(M))
    Jm = impact_map_jacobian(scene, Omega, phi, v, tau)
    stable = bool(np.max(np.abs(mult)) < 1.0)
    sc = SectionMap(scene, Omega)
    _, _, a1 = sc.flight(sc.passage(0, phi / Omega, v), (phi / Omega) + tau, 0)
    return dict(multipliers=mult, map_jacobian=Jm, map_eigenvalues=_by_modulus(np.linalg.eigvals(Jm)), stable=stable,
                **paper_verdicts(scene, Omega, phi, v, n, stable), det_true=float(np.linalg.det(M)),
                tr_true=float(np.trace(M)), a_minus=a1)


def newton_fixed_point(scene, Omega, guess, n=1, tol=DEFAULT_TOL["impulsive"], max_iter=50):
    """Period-n one-impact fixed point ``(phi mod 2 pi, v)`` (ndarray (2,)) by Newton's method on
    the closed form (Eqs. 33-34: ``q(nT) = Delta``, ``q'(nT-) = v`` after ``q' = -R v``), or None.
    Admissibility is not checked here (:func:`is_admissible`)."""
    sc = SectionMap(scene, Omega, n)
    x, ok = sc.newton(np.array([guess[0] / sc.Omega, guess[1]], float), (0,), n, tol, max_iter)
    return np.array([(sc.Omega * x[0]) % TWO_PI, x[1]]) if ok else None


def _analyse(scene, Omega, x, n):
    sc = SectionMap(scene, Omega, n)
    return sc.analyse(np.array([x[0] / sc.Omega, x[1]], float), (0,), n)


def is_admissible(scene, Omega, x, n=1):
    """Whether ``x = (phi, v)`` is a true one-impact period-n orbit: ``(ok, reason)``
    (:meth:`vibeam.models.mapping.orbit.SectionMap.analyse`: ``v > 0``, no earlier arrival at a stop,
    no grazing)."""
    an = _analyse(scene, Omega, x, n)
    return (False, an) if isinstance(an, str) else (True, "")


def orbit_extremes(scene, Omega, x, n=1):
    """Exact ``(q_min, q_max)`` over the fixed-point orbit ``x = (phi, v)``.

    Raises
    ------
    ValueError
        If the orbit is not admissible (the reason).
    """
    an = _analyse(scene, Omega, x, n)
    if isinstance(an, str):
        raise ValueError(an)
    return an["q_min"], an["q_max"]


def next_impact(scene, Omega, phi0, v_minus, max_periods=50.0):
    """One application of the impact map from the impact ``(phi0, v_minus)`` on stop 0.

    Returns
    -------
    tuple or None
        ``(tau, phi1, v1, a1)``: flight time, forcing phase of the next arrival (mod 2 pi), its
        normal speed and ``q''`` before it; None without an arrival within ``max_periods``.
    """
    sc = SectionMap(scene, Omega)
    t0 = phi0 / sc.Omega
    r = sc.section_map(0, t0, float(v_minus), max_periods * sc.T)
    if isinstance(r, str):
        return None
    return r["t"] - t0, (sc.Omega * r["t"]) % TWO_PI, r["v"], r["a"]


def impact_map(scene, Omega, phi0, v_minus, **kw):
    """The 2D impact map ``(phi_i, v_i) -> (phi_{i+1}, v_{i+1})`` (Shaw & Holmes; Sec. 4.2), or None
    (:func:`next_impact` for the parameters)."""
    r = next_impact(scene, Omega, phi0, v_minus, **kw)
    return None if r is None else (r[1], r[2])
