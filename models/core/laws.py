"""The compliant laws in kernel form: contact force, its partial derivatives, and its sign inside a stop.

A compliant stop ``k`` (:mod:`vibeam.models.compliant`) pushes the system along ``-n_k`` with a force
``f_k(g, g')`` of its penetration ``g = n_k^T eta - D_k`` (positive inside) and its rate ``g' = n_k^T
eta'``, in system units (``eta'' = ... - n_k f_k``):

Kelvin-Voigt (code :data:`vibeam.models.contact.LAW_LINEAR`)
    ``f = k g + c g'``; a contact phase is linear (:mod:`vibeam.models.core.phases`, exact flow);
hysteretic Hertz (code :data:`vibeam.models.contact.LAW_HYSTERETIC_HERTZ`)
    ``f = k g^p (1 + chi g' / v_in)`` for ``g > 0`` (0 otherwise), ``v_in`` the contact's entry
    velocity (floored, :data:`V_FLOOR`); ``c`` holds ``chi`` (Hunt & Crossley 1975, ``chi`` of a law
    of the family: Flores et al. 2011, Lankarani & Nikravesh 1990); the phase is integrated
    (:mod:`vibeam.models.core.rk`).

Contact is the region ``g >= 0`` and ``f > 0``: the massless stop cannot pull, so a contact ends
where its force returns to zero (an exit event, not where ``g`` does), and a body left inside the
stop (``g > 0`` after an exit) enters again where the force's sign function turns positive:
``k g + c g'`` (Kelvin-Voigt), ``g' + v_in / chi`` after an exit by the damping factor of a
hysteretic-Hertz stop, ``g`` otherwise (:func:`inside_sign`).  The force is continuous at every
exit and re-entry, so only a Kelvin-Voigt entry through ``g = 0`` has a saltation (the dashpot acts
at once: the field jumps by ``-n c U``); the variational terms are the partials of
:func:`force_partials`.  The kernels dispatch on the law's integer code: no function objects
(numba's cache cannot key them).
"""
from __future__ import annotations

from numba import njit

from ..contact import LAW_HYSTERETIC_HERTZ, LAW_LINEAR
from ..impact import restitution_coefficient

__all__ = ["newton_coefficient", "force", "force_partials", "inside_sign", "is_compliant", "V_FLOOR", "RTOL", "ATOL", "contact_scales", "start_velocity"]

#: a hysteretic-Hertz contact entered below ``V_FLOOR`` times the base-velocity amplitude along the
#: stop's normal (``Omega B |n^T Gamma|``; ``Omega^(p-1) A |n^T f|`` for any drive) takes that floor
#: as its ``v_in`` (the law's damping ``chi / v_in`` is undefined at rest)
V_FLOOR = 1e-2
#: the Runge-Kutta contact phase: relative tolerance, and the absolute ones as fractions of the
#: isolated contact's penetration and of its entry velocity
RTOL = 1e-11
ATOL = 1e-13


@njit(cache=True, error_model="numpy", inline="always")
def newton_coefficient(st, k, U_minus):
    """``R(U-)`` of stop ``k``'s Newton law in its packed form (paper Eq. 2; the table ``R(U-)`` of
    Fig. 26: :func:`vibeam.models.impact.restitution_coefficient`).

    Parameters
    ----------
    st : vibeam.models.core.stops.KernelStops
        The stops' laws packed as arrays (``R``, shape ``(n_stops,)``; ``nodes``, ``tab_U``,
        ``tab_R``, shape ``(n_stops, max_nodes)``).
    k : int
        The stop.
    U_minus : float
        Pre-impact normal velocity (system units, positive approaching).
    """
    m = st.nodes[k]
    return restitution_coefficient(U_minus, st.R[k], st.tab_U[k, :m], st.tab_R[k, :m])


@njit(cache=True, _nrt=False)
def is_compliant(code):
    """Whether a law code is a compliant law's (a contact phase)."""
    return code == LAW_LINEAR or code == LAW_HYSTERETIC_HERTZ


@njit(cache=True, _nrt=False, error_model="numpy")
def force(code, g, gd, kc, cc, pe, vr):
    """The contact force ``f(g, g')`` of a compliant law (module docstring), system units.

    Parameters
    ----------
    code : int
        Law code.
    g, gd : float
        Penetration and its rate.
    kc, cc, pe : float
        Stiffness, dashpot (Kelvin-Voigt) or ``chi`` (hysteretic Hertz), exponent.
    vr : float
        The contact's ``v_in`` (hysteretic Hertz).
    """
    if code == LAW_LINEAR:
        return kc * g + cc * gd
    if g <= 0.0:
        return 0.0
    return kc * g ** pe * (1.0 + cc * gd / vr)


@njit(cache=True, _nrt=False, error_model="numpy")
def force_partials(code, g, gd, kc, cc, pe, vr):
    """``(df/dg, df/dg', df/dv_in)`` of :func:`force` (the variational terms of the law)."""
    if code == LAW_LINEAR:
        return kc, cc, 0.0
    if g <= 0.0:
        return 0.0, 0.0, 0.0
    gp = g ** pe
    fac = 1.0 + cc * gd / vr
    return kc * pe * g ** (pe - 1.0) * fac, kc * gp * cc / vr, -kc * gp * cc * gd / (vr * vr)


@njit(cache=True, _nrt=False, error_model="numpy")
def inside_sign(code, kc, cc, vr, relaxed):
    """``(r0, r1, roff)``: inside a stop (``g > 0``, no contact) the force would be positive where
    ``r0 g + r1 g' + roff > 0`` (module docstring); ``relaxed``: left by a hysteretic-Hertz
    stop's damping factor."""
    if code == LAW_LINEAR:
        return kc, cc, 0.0
    if relaxed:
        return 0.0, 1.0, (vr / cc if cc > 0.0 else 1.0)
    return 1.0, 0.0, 0.0


@njit(cache=True, _nrt=False, error_model="numpy")
def contact_scales(code, kc, pe, nn, vr):
    """Scales of one contact entered at normal velocity ``vr``: ``(penetration, duration)`` of the
    isolated contact (``nn = |n|^2``, ``m_eff = 1 / nn``): ``((p + 1) v^2 / (2 k nn))^(1 / (p + 1))``
    and that over ``v`` (Kelvin-Voigt: ``p = 1``)."""
    p = 1.0 if code == LAW_LINEAR else pe
    v = max(abs(vr), 1e-300)
    pen = ((p + 1.0) * v * v / (2.0 * kc * nn)) ** (1.0 / (p + 1.0))
    return pen, pen / v


@njit(cache=True, _nrt=False, error_model="numpy")
def start_velocity(code, g, U, kc, pe, nn):
    """``v_in`` of a contact a run starts inside of (penetration ``g``, rate ``U``), whose entry the
    run has not seen, and its partials: ``(v, dv/dg, dv/dU, dv/dk)``.

    Kelvin-Voigt: ``|U|`` (the law has no ``v_in``).  Hysteretic Hertz: the entry velocity of the
    isolated conservative contact through this state, ``v^2 = U^2 + 2 k nn g^(p+1) / (p + 1)``
    (``nn = 1 / m_eff``; the energy of the contact's spring added back to the kinetic energy, as
    :func:`contact_scales`): a state on a rebound (``U < 0``) has entered at about ``|U|`` or more,
    not at rest.  The law's own dissipation since the entry is not known, so this is a lower bound
    of the true ``v_in`` (Hunt & Crossley 1975: the loss per contact is ``O(chi v_in)``); taken
    as ``max(U, floor)`` before, a start on a rebound had ``v_in`` at the floor, a damping
    ``chi g' / v_in`` hundreds of times too large and a collapsed step (cases/chain-3dof.toml).
    ``v`` is a function of the state, so a shot's map from the section is one (a periodic orbit
    through a contact is a fixed point of it).

    Parameters
    ----------
    code : int
        Law code.
    g, U : float
        Penetration and its rate at the start (system units).
    kc, pe : float
        Stiffness and exponent.
    nn : float
        ``|n|^2 = 1 / m_eff`` of the stop.
    """
    if code == LAW_LINEAR:
        return abs(U), 0.0, (1.0 if U >= 0.0 else -1.0), 0.0
    if g <= 0.0:
        return U, 0.0, 1.0, 0.0
    e = 2.0 * nn * g ** (pe + 1.0) / (pe + 1.0)
    v = (U * U + kc * e) ** 0.5
    if v <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    return v, kc * nn * g ** pe / v, U / v, 0.5 * e / v


@njit(cache=True, _nrt=False, error_model="numpy")
def hertz_floor(Om, B, gn, fallback, factor):
    """``v_in`` floor of a hysteretic-Hertz stop: ``factor Omega B |n^T Gamma|`` (``gn``; ``factor``
    is :data:`V_FLOOR` as read when the scene's kernel data were built), or ``fallback`` without
    forcing.  ``B`` is the drive's equivalent base displacement ``Omega^(p-2) A``
    (:func:`vibeam.models.system.drive_displacement`), so ``Omega B = Omega^(p-1) A`` is the
    base-velocity amplitude of any drive."""
    v = factor * Om * B * abs(gn)
    return v if v > 0.0 else fallback
