"""The modal FE beam on a Hunt-Crossley stop: free flight exact, contact phase integrated.

Model (kernel units of :mod:`vibeam.models.beam_compliant`: time ``t = omega_ref t~``, modal
coordinates ``eta``, contact displacement ``U = w^T eta`` in m, gap ``g = U - Delta_C``)::

    free     eta'' + C eta' + K eta = Gamma F sin(Omega t)                        (g < 0)
    contact  eta'' + C eta' + K eta + w k g^p (1 + chi g' / v_in) = Gamma F sin(Omega t)

with ``k = k_c / omega_ref^2`` (``k_c`` in N/m^p), ``chi = 8 (1 - R) / (5 R)`` (Flores et al.
2011, :class:`vibeam.models.compliant.HuntCrossley`) and ``v_in`` the contact's entry velocity
``g'`` (floored at ``1e-2 Omega Y |w^T Gamma|``, the SDOF's floor ``1e-2 Omega B`` for one
mode).  Along the relation's normal the stop acts on the effective mass ``m_eff = 1 / |w|^2``:
an isolated contact is the SDOF law's with stiffness ``k / m_eff``, and since the Flores
relation makes the restitution a function of ``chi`` only, the beam's isolated contact has the
SDOF value for the same ``chi`` at any ``k_c``, ``m_eff`` and ``v_in`` (the tests check it).

Free flight is the exact modal flow of :mod:`vibeam.models.beam_compliant` (the free phase's
eigendecomposition; contact entry located by the same certified scan,
:func:`vibeam.models.beam_compliant.free_scan`).  The contact phase is integrated by
Dormand-Prince 5(4) on ``(eta, eta', E)`` (``E' = f g'``, the work done on the stop), relative
tolerance 1e-11 (:data:`vibeam.models.sdof_compliant.HC_RTOL`, absolute ones scaled by the
isolated contact's penetration and the entry velocity along ``w``), its events -- the exit
where the force returns to zero (``g`` back to 0, or the damping factor ``1 + chi g' / v_in``
to 0), the largest penetration, the peak force and the sensor's extrema -- located by
bisection on single steps from the accepted step's start, as the SDOF kernel does
(:func:`vibeam.models.sdof_compliant.hc_advance`).  Explicit steps resolve the fastest retained
mode: this suits few modes (the high modes of an ``"all"``-mode model make the contact phase
stiff and slow).  The event solver is the one compliant beam kernel
(:func:`vibeam.models.beam_compliant.beam_compliant_kernel`), which dispatches each stop's law:
a Hunt-Crossley stop may be the upper or the lower one, beside either compliant law.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .beam_compliant import CompliantBeamEventSolver
from .contact import EV_EXIT
from .hc_contact import hc_contact_step
from .registry import family_laws
from .sdof_compliant import HC_ATOL


def free_data(model, Om):
    """Eigen-data of the free phase (cached on the model) and its signal rows at ``Om``."""
    N = model.n_modes
    key = ("hc", N)
    if getattr(model, "_hc_key", None) != key:
        A = np.zeros((2 * N, 2 * N))
        A[:N, N:] = np.eye(N)
        A[N:, :N] = -np.diag(model.k_nd)
        A[N:, N:] = -np.diag(model.c_nd)
        lam, V = np.linalg.eig(A)
        model._hc_eig = (A, lam.astype(np.complex128), np.ascontiguousarray(V, dtype=np.complex128),
                         np.ascontiguousarray(np.linalg.inv(V), dtype=np.complex128))
        model._hc_key = key
    A, lam, V, W = model._hc_eig
    F = Om ** 2 * model.base_amplitude_m
    b = np.concatenate([np.zeros(N), model.participation])
    Z = np.linalg.solve(1j * Om * np.eye(2 * N) - A, b * F)
    rowU = np.concatenate([model.contact_row, np.zeros(N)])
    rowS = np.concatenate([model.sensor_row, np.zeros(N)])
    return lam, V, W, Z, rowU @ V, rowS @ V, complex(rowU @ Z), complex(rowS @ Z), F


class HuntCrossleyBeamEventSolver(CompliantBeamEventSolver):
    """Method ``event`` of a beam scene with a Hunt-Crossley stop (module docstring).

    The one compliant beam kernel (:func:`vibeam.models.beam_compliant.beam_compliant_kernel`)
    with the stop's law dispatched inside it; the interface of
    :class:`vibeam.models.beam_compliant.CompliantBeamEventSolver` (state ``(eta, eta', phase)``,
    phase 1 in contact; contact records per unit effective mass).

    Parameters
    ----------
    model : vibeam.models.beam_compliant.CompliantBeamModel
        With ``contact`` a :class:`vibeam.models.compliant.HuntCrossley` (``stiffness`` in
        N/m^p at the contact point); a lower stop of a two-sided scene may have either
        compliant law.
    transient_samples, steps_per_fundamental, max_impacts_per_period, max_steps_per_period
        As :class:`~vibeam.models.beam_compliant.CompliantBeamEventSolver`.

    Raises
    ------
    ValueError
        If the upper stop's law is not of the hysteretic-Hertz family.
    """

    def __init__(self, model, **kwargs):
        if getattr(model, "contact", None) is None or getattr(model.contact, "family", "") != "hysteretic_hertz":
            raise ValueError(f"HuntCrossleyBeamEventSolver needs a beam model with {family_laws('hysteretic_hertz')}")
        super().__init__(model, **kwargs)


@njit(cache=True)
def isolated_contact_beam(kc, p, chi, w, v_in):
    """One Hunt-Crossley contact of the free, unforced, undamped modes (``K = C = 0``) entered
    at contact velocity ``v_in`` along ``w`` (``eta' = w v_in / |w|^2``), through the
    kernel's own contact step (:func:`hc_contact_step`).

    Returns
    -------
    R, duration : float
        ``-g'(t_e) / v_in`` at the force-zero exit and the contact's duration.
    """
    N = w.shape[0]
    wn2 = 0.0
    for i in range(N):
        wn2 += w[i] * w[i]
    y = np.zeros(2 * N + 1)
    for i in range(N):
        y[N + i] = w[i] * v_in / wn2
    z0 = np.zeros(N)
    y1 = np.zeros(2 * N + 1)
    rk = np.zeros(4)
    pen = ((p + 1.0) * v_in * v_in / (2.0 * kc * wn2)) ** (1.0 / (p + 1.0))
    rk[0] = 1e-3 * pen / v_in
    rk[1] = HC_ATOL * pen / math.sqrt(wn2)
    rk[2] = HC_ATOL * v_in / math.sqrt(wn2)
    rk[3] = pen / v_in
    ext = np.empty(3)
    cs = np.zeros(4)
    t = 0.0
    for _ in range(10 ** 6):
        s, ev = hc_contact_step(np.inf, 0.0, y, 0.0, 1.0, z0, z0, z0, w, w, 0.0, kc, p, chi, v_in, rk, False, ext,
                                cs, y1)
        if s < 0.0:
            return np.nan, np.nan
        for i in range(2 * N):
            y[i] = y1[i]
        t += s
        if ev == EV_EXIT:
            break
    gd = 0.0
    for i in range(N):
        gd += w[i] * y[N + i]
    return -gd / v_in, t
