"""Shooting problem of the modal FE beam on a Hunt-Crossley stop.

Contract: :mod:`vibeam.models.periodic` (driven unchanged by :mod:`vibeam.models.continuation`).
The model is :mod:`vibeam.models.beam_hc`'s (kernel units: ``eta``, ``eta'``, gap ``g = w^T eta
- Delta_C`` in m, force ``k g^p (1 + chi g' / v_r)``, ``v_r = max(v_in, v_floor)``).

The one shooting problem of the compliant beam
(:class:`vibeam.models.periodic_compliant.CompliantBeamShooting`) with its upper stop's law
checked: every stop (upper or lower) may be Kelvin-Voigt or Hunt-Crossley, each contact phase
composed by its law.  A shot is one run of the one compliant beam event kernel
(:func:`vibeam.models.beam_compliant.beam_compliant_kernel`, each stop's law dispatched inside it)
over ``n`` periods: its end state is the shot's value, so a branch follows the orbit of method
``event``.  The derivatives are composed along the kernel's contacts on a rebuilt trajectory;
for a Hunt-Crossley contact:

* free flight: the exact modal flow of the free phase (as
  :class:`~vibeam.models.periodic_compliant.CompliantBeamShooting`), with ``d/dOmega`` and
  ``d/dY`` of its forced response;
* contact: the ``2N`` modal state and its variational equations ``J' = A(t) J + d(acc)/dp -
  w f_vr dv_r/d(x0, p)`` integrated by :func:`scipy.integrate.solve_ivp` (DOP853, ``rtol =
  1e-12``, :func:`vibeam.models.hc_contact.hc_variational_rhs`) from the kernel's entry time to
  its exit, where the force returns to zero (``g`` falls through 0, or the damping factor ``1 +
  chi g' / v_r`` does);
* entry: the force ``k g^p (...)`` is zero at ``g = 0``, so the vector field is continuous and
  the saltation matrix is ``S = I``; but ``v_r`` is the entry velocity, whose sensitivity
  ``dv_in = w^T (J_v + eta''_- dt)``, ``dt = -w^T J_eta / v_in`` (``h_p = 0``: ``Omega`` and
  ``Y`` do not move the stop) enters the contact's variational equations (below the floor,
  ``v_r = v_floor = 1e-2 Omega Y |w^T Gamma|`` and ``dv_r = (0, ..., d/dOmega, d/dY)``);
* exit: the force is zero again, ``S = I``;
* the window ends at ``n T``: ``J_Omega += z'(nT) d(nT)/dOmega``.

So ``P^n`` and its derivatives are accurate to the integrator, not exact: the kernel's contact
phase is its own Dormand-Prince 5(4) at ``rtol = 1e-11`` and the derivatives' trajectory is
DOP853's at ``rtol = 1e-12`` (on the rig they agree to ~2e-11 of the state, as does the
solve_ivp reference of method ``direct``); ``P^n`` is smooth only to about that level (adaptive
steps change with ``x0``), so its difference quotients and Newton's residual stop there, not at
round-off (central differences of the shot match the Jacobian to ~3e-9).

Not represented (``status = "failed"`` with the reason, never a crash): a section inside the
stop (the open contact depends on its ``v_r``, which is not part of the state), a re-entry
inside the stop after a damping-factor exit (it depends on the previous contact's ``v_r``),
more than ``max_contacts`` contacts.  ``apex_gap`` (m) is the largest interior free-flight
maximum of ``g`` below the stop (a grazing contact is born where it reaches 0); interior force
minima during a contact are not watched.  Parameters ``Omega``, ``base_amplitude_m``.
"""

from __future__ import annotations

from .periodic_compliant import BEAM_PARAMETERS, CompliantBeamShooting
from .registry import family_laws


class HuntCrossleyBeamShooting(CompliantBeamShooting):
    """Shooting problem ``P^n`` of the modal FE beam (any number of modes) whose upper stop is
    Hunt-Crossley (module docstring; contract :mod:`vibeam.models.periodic`).  Accurate to the
    integrator, not exact.

    Parameters
    ----------
    model : vibeam.models.beam_compliant.CompliantBeamModel
        With ``contact`` a :class:`vibeam.models.compliant.HuntCrossley`; a lower stop may have
        either compliant law.
    parameter : {"Omega", "base_amplitude_m"}
    Omega : float, optional
        Forcing frequency ``f / f_ref``; required unless ``parameter == "Omega"``.
    steps_per_fundamental : int, optional
        As :class:`~vibeam.models.beam_hc.HuntCrossleyBeamEventSolver`.
    max_contacts : int, optional
        Most contacts in one shot (beyond: ``status = "failed"``).
    rtol : float, optional
        Relative tolerance of the contact phases' variational integration.

    Raises
    ------
    ValueError
        For another upper law, an unknown parameter or a missing ``Omega``.
    """

    def __init__(self, model, parameter: str = "Omega", Omega: float | None = None,
                 steps_per_fundamental: int = 16, max_contacts: int = 4096, rtol: float = 1e-12):
        if getattr(model, "contact", None) is None or getattr(model.contact, "family", "") != "hysteretic_hertz":
            raise ValueError(f"HuntCrossleyBeamShooting needs a beam model with contact {family_laws('hysteretic_hertz')}")
        if parameter not in BEAM_PARAMETERS:
            raise ValueError(f"parameter {parameter!r} cannot be continued with contact law {model.contact.name!r} on "
                             f"the beam; allowed: {', '.join(BEAM_PARAMETERS)}")
        super().__init__(model, parameter, Omega=Omega, steps_per_fundamental=steps_per_fundamental,
                         max_contacts=max_contacts, rtol=rtol)
