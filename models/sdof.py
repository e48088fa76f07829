"""The SDOF coefficient-of-restitution impact oscillator (paper Eqs. 1-2, 43-47).

Nondimensional model::

    q'' + 2 beta q' + q = Omega^2 B sin(Omega t)   while q < Delta
    q(t+) = q(t-),  q'(t+) = -R q'(t-)              at q = Delta

The physical rig scene maps onto it by paper Eqs. 43-46: ``beta = beta_S``,
``B = gamma V``, ``Delta = Delta_G / L``, ``Omega = f / f_n``, and the
displacement at the sensor is ``U(L_S) = q L``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .contact import Relation, Restitution, Stop
from .builders.sdof import sdof
from .scene import Scene

def _upper_law(law, R, R_table, contact):
    """The upper stop's law from the constructor's arguments: ``contact`` (a compliant law) when
    given; else, when ``R`` or ``R_table`` is given, Newton's law with them (what is not given
    taken from ``law``; a compliant ``law`` given ``R`` gets it as its target,
    ``with_restitution``); else ``law``.

    Raises
    ------
    TypeError
        Without a law and without ``R``.
    """
    if contact is not None:
        return contact
    if R is None and R_table is None:
        if law is None:
            raise TypeError("SDOF needs R (or a law of its upper stop)")
        return law
    if law is not None and law.kind != "impulsive":
        return law if R is None or float(R) == law.R else law.with_restitution(float(R))
    if R is None:
        R = law.R
    if R_table is None:
        table = ((), ()) if law is None else (law.table_U, law.table_R)
    else:
        table = (tuple(v for v, _ in R_table), tuple(r for _, r in R_table))
    return Restitution(R, *table)


@dataclass(frozen=True, init=False)
class SDOF:
    """Parameters of the nondimensional SDOF impact oscillator.

    Its stops are (relation, law) pairs (:meth:`stops`, :mod:`vibeam.models.contact`): the
    paper's stop at ``q = Delta`` with Newton's law and ``R`` (or the compliant law ``contact``,
    ``R`` then its target restitution), and optionally a lower one at ``q = -Delta_lower`` with
    the law ``lower_law`` (None: the upper stop's).

    Attributes
    ----------
    beta : float
        Damping ratio, ``0 <= beta < 1`` (paper's beta_S).
    B : float
        Base-excitation amplitude (nondimensional; ``gamma V`` for the rig).
    R : float
        Coefficient of restitution, ``0 <= R <= 1``.
    Delta : float
        Gap to the stop (nondimensional; negative = pre-stressed stop).
    natural_frequency_hz : float or None
        ``f_n`` of a physical scene (for ``frequency_hz`` outputs).
    length_m : float or None
        Normalising length ``L`` of a physical scene (for ``amplitude_mm``).
    R_table : tuple of (float, float) pairs, optional
        R against the pre-impact velocity q'- (effect ``restitution_law``; only the
        ``event`` method uses it); empty = constant ``R``.
    Delta_lower : float or None, optional
        A second (lower) stop at ``q = -Delta_lower`` (distance from the static equilibrium,
        positive; ``Delta + Delta_lower > 0``); None: the one stop of the paper.
    contact : LinearContact or None, optional
        A compliant law of the stop (:mod:`vibeam.models.compliant`, kernel units: stiffness
        ratio ``k_c / k``); None = Newton's law with ``R`` (paper Eq. 2).
    mass_kg : float or None, optional
        Effective mass of a physical scene's oscillator at the contact (kg): contact forces
        in N (``force_scale_n``); None: forces stay nondimensional.
    lower_law : law or None, optional
        The lower stop's own law: Newton's (:class:`vibeam.models.contact.Restitution`) or a
        compliant one; None: the upper stop's law (``contact``, or Newton's with ``R`` and
        ``R_table``, so that it follows ``R``).

    Parameters
    ----------
    R_lower, contact_lower : optional
        Shorthands of ``lower_law`` (as the case keys): ``R_lower`` for
        ``Restitution(R_lower)``, ``contact_lower`` for a compliant law; one of the two.

    Raises
    ------
    ValueError
        For both ``R_lower`` and ``contact_lower``.
    """

    beta: float
    B: float
    Delta: float
    natural_frequency_hz: float | None = None
    length_m: float | None = None
    Delta_lower: float | None = None
    mass_kg: float | None = None
    lower_law: object = None
    upper_law: object = None

    fidelity = "sdof"

    def __init__(self, beta, B, R=None, Delta=None, natural_frequency_hz=None, length_m=None, R_table=None,
                 Delta_lower=None, R_lower=None, contact=None, mass_kg=None, contact_lower=None, lower_law=None,
                 upper_law=None):
        if Delta is None:
            raise TypeError("SDOF needs Delta (the gap to the upper stop)")
        if R_lower is not None and contact_lower is not None:
            raise ValueError("the lower stop takes one law: contact_lower (compliant) or R_lower (restitution)")
        if R_lower is not None:
            lower_law = Restitution(float(R_lower))
        elif contact_lower is not None:
            lower_law = contact_lower
        upper_law = _upper_law(upper_law, R, R_table, contact)
        for k, v in (("beta", beta), ("B", B), ("Delta", Delta), ("natural_frequency_hz", natural_frequency_hz),
                     ("length_m", length_m), ("Delta_lower", Delta_lower), ("mass_kg", mass_kg),
                     ("lower_law", lower_law), ("upper_law", upper_law)):
            object.__setattr__(self, k, v)

    # the upper stop's numbers, read from its law (the model holds no copy; ``replace(m, R=...)``,
    # ``R_table=`` and ``contact=`` give a new law: :func:`_upper_law`)
    @property
    def R(self) -> float:
        """The upper stop's ``R``: Newton's, or the compliant law's target restitution."""
        return self.upper_law.R

    @property
    def R_table(self) -> tuple:
        """``((q'-, R), ...)`` of the upper stop's ``R(q'-)`` table; empty: constant ``R``."""
        law = self.upper_law
        return tuple(zip(law.table_U, law.table_R)) if law.kind == "impulsive" else ()

    @property
    def contact(self):
        """The upper stop's compliant law, or None for Newton's law."""
        return None if self.upper_law.kind == "impulsive" else self.upper_law

    @property
    def two_sided(self) -> bool:
        """A second stop below (``Delta_lower`` given)."""
        return self.Delta_lower is not None

    @property
    def contact_law(self) -> str:
        """Name of the stop's law (a key of :data:`vibeam.models.registry.LAWS`; the registry
        finds the law's family, the key of its methods' ``laws``)."""
        return "restitution" if self.contact is None else self.contact.name

    @property
    def force_scale_n(self) -> float | None:
        """Newtons per unit nondimensional force, ``m omega_n^2 L`` (None without a mass)."""
        if self.mass_kg is None or self.natural_frequency_hz is None or self.length_m is None:
            return None
        return self.mass_kg * (2 * math.pi * self.natural_frequency_hz) ** 2 * self.length_m

    def scene(self) -> Scene:
        """The oscillator as a scene (:func:`vibeam.models.builders.sdof.sdof`), its stops those
        of :meth:`stops`."""
        compliant = getattr(self.lower_law, "kind", "") == "compliant"
        lower = self.lower_law if self.Delta_lower is not None or compliant else None
        return sdof(self.beta, self.B, self.Delta, law=self.upper_law, Delta_lower=self.Delta_lower,
                    lower_law=lower, natural_frequency_hz=self.natural_frequency_hz,
                    length_m=self.length_m, mass_kg=self.mass_kg)

    def stops(self) -> tuple:
        """The contact relations and laws (:mod:`vibeam.models.contact`): the stop at
        ``q = Delta`` (normal ``+1``) with Newton's law, ``R`` and ``R(q'-)``, or the compliant
        law ``contact``; for a two-sided scene the stop at ``q = -Delta_lower`` (normal ``-1``)
        with ``lower_law`` (None: the upper stop's)."""
        upper = self.upper_law
        out = (Stop(Relation(1.0, self.Delta), upper),)
        if self.Delta_lower is not None:
            out += (Stop(Relation(-1.0, self.Delta_lower), upper if self.lower_law is None else self.lower_law),)
        elif getattr(self.lower_law, "kind", "") == "compliant":
            raise ValueError("contact_lower needs a lower stop (Delta_lower)")
        return out

    # ---- the model protocol of the fidelity registry (vibeam.models.registry)
    #: static-mode value at the contact point over the sensor's: 1, the coordinate is the sensor's
    phi_contact = 1.0

    def initial_state(self) -> np.ndarray:
        """Rest at the unloaded equilibrium, or on the stop if it is pre-stressed.

        Returns ``(q, q', stuck)`` with ``stuck`` as 0.0/1.0 (held on the upper stop) or
        -1.0 (held on the lower one); a lower stop that is pre-stressed (``Delta_lower < 0``)
        holds the mass at ``q = -Delta_lower``.
        """
        q = min(0.0, self.Delta)
        if self.Delta_lower is not None:
            q = max(q, -self.Delta_lower)
        return np.array([q, 0.0, 0.0])

    @classmethod
    def from_physical(cls, natural_frequency_hz, damping_ratio, R, gap_mm, length_mm, gain, voltage,
                      gap_lower_mm=None, R_lower=None):
        """Build the nondimensional model of a rig scene (paper Eqs. 43-46): the arguments of
        :func:`vibeam.models.builders.sdof.sdof_physical`, and ``R_lower``, the lower stop's
        coefficient of restitution (None: ``R``)."""
        return cls(beta=damping_ratio, B=gain * voltage, R=R, Delta=gap_mm / length_mm,
                   natural_frequency_hz=natural_frequency_hz, length_m=length_mm * 1e-3,
                   Delta_lower=None if gap_lower_mm is None else gap_lower_mm / length_mm, R_lower=R_lower)
