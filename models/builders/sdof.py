"""The SDOF coefficient-of-restitution impact oscillator as a scene (paper Eqs. 1-2, 43-47).

Nondimensional model::

    q'' + 2 beta q' + q = Omega^2 B sin(Omega t)   while -Delta_lower < q < Delta
    q(t+) = q(t-),  q'(t+) = -R q'(t-)              at q = Delta (and at q = -Delta_lower)

the one-mode :class:`~vibeam.models.system.ModalSystem` (``omega = 1``, ``c = 2 beta``,
``Gamma = s = W = 1``, :func:`vibeam.models.system.sdof_system`) with a stop at ``q = Delta``
(normal ``+1``) and optionally one at ``q = -Delta_lower`` (normal ``-1``), each a
(relation, law) pair on contact row 0.  The physical rig maps onto it by paper Eqs. 43-46
(:func:`sdof_physical`): ``beta = beta_S``, ``B = gamma V``, ``Delta = Delta_G / L``,
``Omega = f / f_n``, and the displacement at the sensor is ``U(L_S) = q L``.
"""
from __future__ import annotations

from ..contact import Relation, Restitution, Stop
from ..scene import Scene
from ..system import sdof_system

__all__ = ["sdof", "sdof_physical", "BUILDERS"]

#: the builder name of the scenes :func:`sdof` makes (the registry's fidelity)
BUILDERS = ("sdof",)


def sdof(beta, B, Delta, R=None, *, law=None, Delta_lower=None, lower_law=None, natural_frequency_hz=None,
         length_m=None, mass_kg=None) -> Scene:
    """The SDOF impact oscillator (paper Eqs. 1-2) as a scene, builder ``"sdof"``.

    Parameters
    ----------
    beta : float
        Damping ratio ``beta_S >= 0`` (nondimensional).
    B : float
        Base-displacement amplitude (nondimensional; ``gamma V`` for the rig, Eq. 46).
    Delta : float
        Gap to the upper stop at ``q = Delta`` (nondimensional; negative: a pre-stressed stop).
    R : float, optional
        Newton's coefficient of restitution of the upper stop, ``0 <= R <= 1`` (paper Eq. 2):
        shorthand of ``law = Restitution(R)``; give ``R`` or ``law``.
    law : law, optional
        The upper stop's law: :class:`vibeam.models.contact.Restitution` or a compliant law
        (:mod:`vibeam.models.compliant`, stiffness as the ratio ``k_c / k``).
    Delta_lower : float, optional
        A second stop at ``q = -Delta_lower`` (``Delta + Delta_lower > 0``); None: the paper's one stop.
    lower_law : law, optional
        The lower stop's law; None: the upper stop's (the same object, so that it follows it).
    natural_frequency_hz, length_m, mass_kg : float, optional
        ``f_n`` (Hz), the normalising length ``L`` (m) and the effective mass (kg) of a physical
        scene: its units (``time_unit_s = 1 / (2 pi f_n)``, ``length_unit_m = L``); None: nondimensional.

    Returns
    -------
    Scene
        One mode, one or two stops on contact row 0, ``builder = "sdof"``.

    Raises
    ------
    TypeError
        Without ``R`` and ``law``, or with both.
    ValueError
        ``R`` outside ``[0, 1]`` (the law's own check), ``beta`` negative or not finite, a
        compliant ``lower_law`` without ``Delta_lower``.
    """
    if (R is None) == (law is None):
        raise TypeError("sdof takes the upper stop's R or its law (one of the two)")
    upper = Restitution(float(R)) if law is None else law
    stops = (Stop(Relation(1.0, Delta), upper),)
    if Delta_lower is not None:
        stops += (Stop(Relation(-1.0, Delta_lower), upper if lower_law is None else lower_law),)
    elif lower_law is not None:
        raise ValueError("lower_law (a case's contact_lower) needs a lower stop (Delta_lower)")
    return Scene(sdof_system(beta, B, natural_frequency_hz, length_m, mass_kg), stops, "sdof")


def sdof_physical(natural_frequency_hz, damping_ratio, gap_mm, length_mm, gain, voltage, R=None, *, law=None,
                  gap_lower_mm=None, lower_law=None, mass_kg=None) -> Scene:
    """The rig's SDOF scene from its measured values (paper Eqs. 43-46): ``beta = beta_S``,
    ``B = gamma V``, ``Delta = Delta_G / L``, ``Delta_lower = gap_lower_mm / L``, in the units
    ``1 / (2 pi f_n)`` s and ``L`` m (:func:`sdof`).

    Parameters
    ----------
    natural_frequency_hz : float
        ``f_n`` (Hz).
    damping_ratio : float
        ``beta_S``.
    gap_mm, gap_lower_mm : float
        Grazing gap at the sensor ``Delta_G`` (mm), and a lower stop's (None: one stop).
    length_mm : float
        Normalising beam length ``L`` (mm).
    gain : float
        Normalised unit conversion gain ``gamma`` (1/V, Eq. 46).
    voltage : float
        Excitation voltage amplitude ``V`` (V).
    R, law, lower_law, mass_kg
        As :func:`sdof`.

    Raises
    ------
    TypeError, ValueError
        As :func:`sdof`.
    """
    return sdof(damping_ratio, gain * voltage, gap_mm / length_mm, R, law=law,
                Delta_lower=None if gap_lower_mm is None else gap_lower_mm / length_mm, lower_law=lower_law,
                natural_frequency_hz=natural_frequency_hz, length_m=length_mm * 1e-3, mass_kg=mass_kg)
