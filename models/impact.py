"""Impact laws, kept apart from the contact relation (Siconos style).

An impact law maps the normal relative velocity before impact, ``U_minus``,
to the normal relative velocity after impact.  The contact relation (which
generalised velocities make up ``U`` and how the impulse is distributed over
the degrees of freedom) belongs to the model.  One law therefore serves the
SDOF oscillator (``U = q'``) and the multi-DOF beam (``U = w^T u'``) alike.

Sign convention: ``U > 0`` means the contact point approaches the stop
(paper Eq. 2 and Eq. 41, where the stop lies at ``q = Delta`` above the mass).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def newton_restitution(U_minus, R):
    """Newton's kinematic impact law, paper Eq. 2: ``U+ = -R U-``.

    Parameters
    ----------
    U_minus : float
        Normal relative velocity just before impact (nondimensional or SI; the
        law is unit free).  Positive when approaching the stop.
    R : float
        Coefficient of restitution, ``0 <= R <= 1``.

    Returns
    -------
    float
        Normal relative velocity just after impact, ``-R U_minus``.
    """
    return -R * U_minus


@njit(cache=True, error_model="numpy", inline="always")
def restitution_coefficient(U_minus, R, table_U, table_R):
    """Coefficient of restitution at the pre-impact velocity ``U_minus`` (paper Fig. 26).

    ``R(U-)`` is piecewise linear through ``(table_U[k], table_R[k])`` (``table_U``
    increasing, in the caller's velocity units) and constant beyond the ends.  An empty
    table is the constant law: ``R`` is returned at once (one length test, nothing else).

    Parameters
    ----------
    U_minus : float
        Pre-impact normal velocity (positive approaching), same units as ``table_U``.
    R : float
        Constant coefficient used when the table is empty.
    table_U, table_R : ndarray, shape (n,)
        Velocity nodes (increasing) and R at them; ``n = 0`` for the constant law.
    """
    n = table_U.shape[0]
    if n == 0:
        return R
    if U_minus <= table_U[0]:
        return table_R[0]
    if U_minus >= table_U[n - 1]:
        return table_R[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if table_U[mid] <= U_minus:
            lo = mid
        else:
            hi = mid
    t = (U_minus - table_U[lo]) / (table_U[hi] - table_U[lo])
    return table_R[lo] + t * (table_R[hi] - table_R[lo])

def restitution_at(U_minus, R, table_U, table_R) -> float:
    """:func:`restitution_coefficient` evaluated in Python (its own code, the same arithmetic):
    for callers outside the kernels, which would otherwise compile a specialisation of it for
    a few calls."""
    return float(restitution_coefficient.py_func(float(U_minus), float(R), table_U, table_R))


@njit(cache=True, error_model="numpy")
def restitution_impulse(U_minus, R, m_eff):
    """Normal impulse that realises Newton's law on a contact of effective mass ``m_eff``.

    For a multi-DOF system with mass matrix ``M`` and contact row ``w``
    (``U = w^T u'``), the impulse ``P`` applied along ``w`` changes the
    velocities by ``M^-1 w P``.  Choosing ``P = -(1 + R) m_eff U-`` with
    ``m_eff = 1 / (w^T M^-1 w)`` gives ``U+ = -R U-`` exactly and dissipates
    ``(1 - R^2) m_eff U-^2 / 2`` (Moreau's / Siconos' Newton impact law).

    Parameters
    ----------
    U_minus : float
        Normal relative velocity before impact (positive when approaching).
    R : float
        Coefficient of restitution in [0, 1].
    m_eff : float
        Effective mass of the contact, ``1 / (w^T M^-1 w)`` (kg or nondimensional).

    Returns
    -------
    float
        The impulse ``P`` (negative: it pushes away from the stop).
    """
    U_plus = newton_restitution(U_minus, R)
    return m_eff * (U_plus - U_minus)


def saltation_matrix(R, v_minus, a_minus, beta):
    """Saltation matrix of the impact ``q = Delta``, ``q'+ = -R q'-`` in ``(q, q')``.

    For the surface ``h = q - Delta``, reset ``G(q, q') = (q, -R q')`` and
    vector fields ``f- = (v-, a-)`` before and ``f+ = (v+, a+)`` after the impact
    (Leine & Nijmeijer 2004; di Bernardo et al. 2008)::

        S = G_x + (f+ - G_x f-) h_x / (h_x f-)
          = [[-R, 0], [(a+ + R a-) / v-, -R]]

    with ``a+ - a- = -2 beta (v+ - v-) = 2 beta (1 + R) v-`` (same position and
    forcing), i.e. ``S21 = (1 + R)(a- + 2 beta v-) / v-
    = (1 + R)(F sin(phi) - Delta) / v-``.  ``det S = R^2``.

    Parameters
    ----------
    R : float
        Coefficient of restitution.
    v_minus : float
        Pre-impact velocity (``> 0``).
    a_minus : float
        Pre-impact acceleration ``q''(t-)``.
    beta : float
        Damping ratio.

    Returns
    -------
    ndarray, shape (2, 2)
    """
    a_plus = a_minus + 2.0 * beta * (1.0 + R) * v_minus
    return np.array([[-R, 0.0], [(a_plus + R * a_minus) / v_minus, -R]])
