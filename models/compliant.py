"""Compliant contact laws: the Kelvin-Voigt (piecewise-linear) stop and Hunt-Crossley.

A compliant law (``kind = "compliant"``, :mod:`vibeam.models.contact`) replaces the
instantaneous velocity jump of Newton's law by a contact *phase* with its own force,
acting along the relation's normal on the penetration ``delta = g >= 0`` (the gap function
of the stop, positive inside)::

    linear               F = k_c delta + c_c delta'                (Kelvin-Voigt)
    hunt_crossley        F = k_c delta^p (1 + chi delta' / v_in)   (Hunt & Crossley 1975)
    lankarani_nikravesh  the same, chi = 3 (1 - R^2) / 4            (Lankarani & Nikravesh 1990)

The last two are one family, hysteretic Hertz (:class:`HystereticHertz`): its kernels take
``chi`` as a number of the law object; a law of the family only chooses ``chi(R)``.

The contact begins where ``delta`` crosses zero upwards and ends where the contact force
returns to zero (not where ``delta`` does): the stop is massless and cannot pull, so once
``F = 0`` the body leaves it while a small penetration ``delta_e >= 0`` remains, which the
stop's dashpot then relaxes.  The energy the body loses per contact is the work it does on
the stop, ``E = int F delta' dt = int c_c delta'^2 dt + k_c delta_e^2 / 2`` (linear law),
which is all dissipated by the contact damping (in contact, then as the stop relaxes).

Units are the kernel's: per unit effective mass ``m_eff`` of the relation
(:meth:`vibeam.models.contact.Relation.effective_mass`) and in the model's time unit;
for the nondimensional SDOF model (``m_eff = 1``, time ``1/omega_n``) ``k_c`` is the ratio
of the stop's stiffness to the oscillator's and ``c_c = 2 zeta_c sqrt(k_c)``.

Restitution of an isolated Kelvin-Voigt impact (force-zero separation)
------------------------------------------------------------------------
A mass on the spring-dashpot alone, ``delta'' + 2 zeta w delta' + w^2 delta = 0``,
``delta(0) = 0``, ``delta'(0) = v``, ``w = sqrt(k_c)``, ``zeta = c_c / (2 w)`` (< 1)::

    delta(t)  = v e^{-zeta w t} sin(w_d t) / w_d,          w_d = w sqrt(1 - zeta^2)
    F(t) / v  = e^{-zeta w t} [(1 - 2 zeta^2) sin(w_d t) / sqrt(1 - zeta^2)
                               + 2 zeta cos(w_d t)] w

so ``F = 0`` first at ``w_d t_e = pi - psi``, ``psi = atan2(2 zeta sqrt(1 - zeta^2),
1 - 2 zeta^2)`` in ``(0, pi)``, and the restitution ``R = -delta'(t_e) / v`` is::

    R(zeta) = exp(-zeta (pi - psi) / sqrt(1 - zeta^2))
              * (zeta sin(pi - psi) / sqrt(1 - zeta^2) - cos(pi - psi))

independent of ``v`` and ``w`` (derived here; the force criterion of separation for the
linear dashpot is discussed by Schwager & Poeschel, *Granular Matter* 9 (2007) 465).  ``R`` falls
monotonically from 1 (``zeta = 0``) to ``e^{-2}`` (``zeta -> 1``); the target damping
ratio is its inverse (:func:`damping_ratio_for_restitution`, a bracketed root).  Contact
phases are underdamped here, so a target ``R`` must exceed ``e^{-2} = 0.1353``.  The duration
of the undamped contact is ``pi / w``.

Hunt-Crossley damping from a target R
---------------------------------------
``chi`` is chosen by Flores, Machado, Silva & Martins, *Multibody Syst. Dyn.* 25 (2011)
357: ``chi = 8 (1 - R) / (5 R)``; the damping factor of each contact is
``chi / v_in`` (``v_in`` its entry velocity), so the restitution is the same at every
impact velocity; a contact entered at (near) rest takes ``v_in = max(v_in, 1e-2 Omega B)``,
a hundredth of the base's velocity amplitude (the law is undefined at ``v_in = 0``).  Chosen
because it is derived for the whole range of R; the Hunt &
Crossley (``3 (1 - R) / 2``) and Lankarani & Nikravesh (``3 (1 - R^2) / 4``) relations follow
from a first-order energy balance and hold only for ``1 - R << 1`` (they under-damp the rig's
R = 0.72).  All three give, to first order in ``chi``, the same energy loss per contact,
``E = (2/3) chi v_in^2`` per unit mass (independent of ``k_c`` and ``p``), the closed form the
tests check.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .contact import LAW_HYSTERETIC_HERTZ, LAW_LINEAR

#: the smallest restitution of an underdamped Kelvin-Voigt contact with force-zero separation
R_MIN_LINEAR = math.exp(-2.0)


def restitution_of_damping_ratio(zeta: float) -> float:
    """Restitution ``R(zeta)`` of an isolated Kelvin-Voigt impact (module docstring).

    Parameters
    ----------
    zeta : float
        Damping ratio of the contact, ``0 <= zeta < 1``.

    Returns
    -------
    float
        ``-delta'(t_e) / delta'(0)`` at the first zero of the contact force.

    Raises
    ------
    ValueError
        If ``zeta`` is outside ``[0, 1)``.
    """
    z = float(zeta)
    if not 0.0 <= z < 1.0:
        raise ValueError(f"contact damping ratio {zeta} must lie in [0, 1)")
    s = math.sqrt(1.0 - z * z)
    th = math.pi - math.atan2(2.0 * z * s, 1.0 - 2.0 * z * z)
    return math.exp(-z * th / s) * (z * math.sin(th) / s - math.cos(th))


def contact_duration(zeta: float, omega: float) -> float:
    """Duration ``(pi - psi) / (omega sqrt(1 - zeta^2))`` of an isolated Kelvin-Voigt contact
    (force-zero exit; module docstring), ``omega = sqrt(k_c / m_eff)``; ``pi / omega`` undamped."""
    z = float(zeta)
    s = math.sqrt(1.0 - z * z)
    return (math.pi - math.atan2(2.0 * z * s, 1.0 - 2.0 * z * z)) / (omega * s)


def damping_ratio_for_restitution(R: float) -> float:
    """Damping ratio of a Kelvin-Voigt contact whose isolated impact has restitution ``R``.

    The inverse of :func:`restitution_of_damping_ratio` (monotone), by
    :func:`scipy.optimize.brentq` to a few ulps of ``zeta``.

    Raises
    ------
    ValueError
        If ``R`` is not in ``(e^-2, 1]`` (:data:`R_MIN_LINEAR`).
    """
    from scipy.optimize import brentq

    R = float(R)
    if not R_MIN_LINEAR < R <= 1.0:
        raise ValueError(f"target R = {R} of law \"linear\" must lie in (e^-2 = {R_MIN_LINEAR:.4f}, 1] "
                         f"(underdamped contact with force-zero separation)")
    if R == 1.0:
        return 0.0
    hi = 1.0 - 1e-15
    return float(brentq(lambda z: restitution_of_damping_ratio(z) - R, 0.0, hi, xtol=1e-16, rtol=8.9e-16,
                        maxiter=200))


@dataclass(frozen=True)
class LinearContact:
    """Kelvin-Voigt stop ``F = k_c delta + c_c delta'`` (compliant; module docstring).

    Attributes
    ----------
    stiffness : float
        ``k_c`` per unit effective mass in the model's time unit (SDOF: the ratio of the
        stop's stiffness to the oscillator's), ``> 0``.
    damping_ratio : float
        ``zeta_c = c_c / (2 sqrt(k_c))``, ``0 <= zeta_c < 1``.
    R : float
        Restitution of an isolated impact, ``R(zeta_c)``.
    """

    stiffness: float
    damping_ratio: float
    R: float

    kind = "compliant"
    family = "kelvin_voigt"    # the registry's key of the kernels that simulate it
    code = LAW_LINEAR
    table_U = ()      # no R(U-) table (kernel stop rows, vibeam.models.contact.pack)
    table_R = ()
    name = "linear"
    #: the contact phase is a linear flow (exact, eigendecomposed: vibeam.models.core.phases)
    linear_phase = True
    #: cost of a sweep point with this law against the event grid's step count
    #: (:func:`vibeam.engine.jobs.estimate_work`): measured 5-47x on the cell matrix's event rows
    #: (SDOF and 2-mode beam, one, two, mixed and point stops; ``vibeam bench --estimate``)
    work_factor = 12.0

    @staticmethod
    def force_exponent(exponent: float | None = None) -> float:
        """Power of ``delta`` in the elastic force (1: the stiffness is N/m in physical units)."""
        return 1.0

    @classmethod
    def from_spec(cls, stiffness: float, R: float, exponent: float | None = None,
                  damping_ratio: float | None = None) -> "LinearContact":
        """The law of a case's ``[model.contact]`` values in kernel units: its ``damping_ratio``,
        else the dashpot that gives an isolated impact the target ``R``.

        Raises
        ------
        ValueError
            If ``R`` is out of ``(e^-2, 1]`` (:func:`damping_ratio_for_restitution`).
        """
        if damping_ratio is not None:
            return cls.from_damping_ratio(stiffness, damping_ratio)
        return cls.from_restitution(stiffness, R)

    def check(self, stop: str = "upper") -> None:
        """Raise ValueError unless ``stiffness > 0`` and ``0 <= damping_ratio < 1``."""
        if not (self.stiffness > 0.0 and 0.0 <= self.damping_ratio < 1.0):
            raise ValueError(f"law \"{self.name}\" of the {stop} stop needs stiffness > 0 and "
                             f"0 <= damping_ratio < 1")

    @classmethod
    def from_damping_ratio(cls, stiffness: float, damping_ratio: float) -> "LinearContact":
        return cls(float(stiffness), float(damping_ratio), restitution_of_damping_ratio(damping_ratio))

    @classmethod
    def from_restitution(cls, stiffness: float, R: float) -> "LinearContact":
        """The law whose isolated impact has restitution ``R`` (the dashpot solved once)."""
        return cls(float(stiffness), damping_ratio_for_restitution(R), float(R))

    @property
    def damping(self) -> float:
        """``c_c = 2 zeta_c sqrt(k_c)`` (per unit effective mass)."""
        return 2.0 * self.damping_ratio * math.sqrt(self.stiffness)

    def with_restitution(self, R: float) -> "LinearContact":
        """The law of the same stiffness with target restitution ``R`` (its dashpot solved anew)."""
        return self.from_restitution(self.stiffness, R)

    def row(self) -> tuple:
        """``(law code, R, stiffness, damping, exponent)`` of a kernel stop row."""
        return (float(self.code), float(self.R), float(self.stiffness), float(self.damping), 1.0)


@dataclass(frozen=True)
class HystereticHertz:
    """The hysteretic-Hertz family ``F = k_c delta^p (1 + chi delta' / v_in)`` (module
    docstring): what its kernels need of a law -- ``stiffness``, ``exponent`` and the number
    ``chi`` -- whatever relation between ``chi`` and the target ``R`` a law of the family
    chooses (a subclass defines :meth:`chi_of` and its ``name``).

    Attributes
    ----------
    stiffness : float
        ``k_c`` per unit effective mass (model units, length^(1-p) / time^2).
    R : float
        Target restitution, ``0 < R <= 1``.
    exponent : float
        ``p`` (Hertz: 3/2).
    """

    stiffness: float
    R: float
    exponent: float = 1.5

    kind = "compliant"
    family = "hysteretic_hertz"    # the registry's key of the kernels that simulate it
    code = LAW_HYSTERETIC_HERTZ
    table_U = ()
    table_R = ()
    name = ""                      # a law of the family names itself (vibeam.models.registry.LAWS)
    #: ``chi`` as a function of ``R`` (for messages)
    chi_formula = ""
    #: the contact phase has no closed form (integrated: vibeam.models.core.rk)
    linear_phase = False
    #: cost of a sweep point with a law of this family against the event grid's step count
    #: (:func:`vibeam.engine.jobs.estimate_work`): measured 146-1000x on the cell matrix's event
    #: rows (Hunt-Crossley and Lankarani-Nikravesh, SDOF and 2-mode beam; ``vibeam bench --estimate``)
    work_factor = 300.0

    @staticmethod
    def chi_of(R: float) -> float:
        """Nondimensional damping ``chi`` of target restitution ``R`` (the law's relation)."""
        raise NotImplementedError

    @property
    def chi(self) -> float:
        """Nondimensional damping ``chi = c v_in`` (:meth:`chi_of` at the law's ``R``)."""
        return self.chi_of(self.R)

    @property
    def damping(self) -> float:
        return self.chi

    def with_restitution(self, R: float):
        """The law of the same stiffness and exponent with target restitution ``R``."""
        return dataclasses.replace(self, R=float(R))

    @staticmethod
    def force_exponent(exponent: float | None = None) -> float:
        """Power ``p`` of ``delta`` in the elastic force (default 3/2, Hertz)."""
        return 1.5 if exponent is None else float(exponent)

    @classmethod
    def from_spec(cls, stiffness: float, R: float, exponent: float | None = None,
                  damping_ratio: float | None = None):
        """The law of a case's ``[model.contact]`` values in kernel units.

        Raises
        ------
        ValueError
            If ``R <= 0`` (``chi`` is undefined or infinite there).
        """
        if not R > 0.0:
            raise ValueError(f"law = \"{cls.name}\" needs R > 0 ({cls.chi_formula})")
        return cls(float(stiffness), float(R), cls.force_exponent(exponent))

    def check(self, stop: str = "upper") -> None:
        """Raise ValueError unless ``stiffness > 0``, ``exponent > 0`` and ``0 < R <= 1``."""
        if not (self.stiffness > 0.0 and self.exponent > 0.0 and 0.0 < self.R <= 1.0):
            raise ValueError(f"law \"{self.name}\" of the {stop} stop needs stiffness > 0, exponent > 0 "
                             f"and 0 < R <= 1")

    def row(self) -> tuple:
        """``(law code, R, stiffness, chi, exponent)`` of a kernel stop row."""
        return (float(self.code), float(self.R), float(self.stiffness), float(self.chi), float(self.exponent))


@dataclass(frozen=True)
class HuntCrossley(HystereticHertz):
    """Hunt-Crossley stop ``F = k_c delta^p (1 + chi delta' / v_in)`` with
    ``chi = 8 (1 - R) / (5 R)`` (Flores et al. 2011; module docstring).

    Attributes
    ----------
    stiffness : float
        ``k_c`` per unit effective mass (model units, length^(1-p) / time^2).
    R : float
        Target restitution; ``chi = 8 (1 - R) / (5 R)`` (Flores et al. 2011).
    exponent : float
        ``p`` (Hertz: 3/2).
    """

    name = "hunt_crossley"
    chi_formula = "chi = 8 (1 - R) / (5 R), Flores et al. 2011"

    @staticmethod
    def chi_of(R: float) -> float:
        """Nondimensional damping ``chi = c v_in = 8 (1 - R) / (5 R)``."""
        return 8.0 * (1.0 - R) / (5.0 * R)


@dataclass(frozen=True)
class LankaraniNikravesh(HystereticHertz):
    """Lankarani-Nikravesh stop ``F = k_c delta^p (1 + chi delta' / v_in)`` with
    ``chi = 3 (1 - R^2) / 4`` (Lankarani & Nikravesh, *J. Mech. Des.* 112 (1990) 369, Eq. 21
    written with ``D = chi k_c delta^p / v_in``; compared by Flores, Machado, Silva & Martins,
    *Mech. Mach. Theory* 46 (2011)).

    The relation comes from a first-order energy balance (the hysteresis loss equals the
    kinetic-energy loss ``(1 - R^2) v_in^2 / 2``, with the contact's path approximated by the
    undamped Hertz one), so it holds for ``1 - R << 1``: the effective restitution of an
    isolated impact tends to ``R`` as ``R -> 1`` (``1 - R_eff = (1 - R)(1 - 1.5 (1 - R) + ...)``)
    and exceeds it below (under-damped: 0.913 for a target 0.9, 0.805 for 0.72, 0.725 for 0.5,
    measured in ``tests/test_lankarani_nikravesh.py``); use :class:`HuntCrossley` (``chi`` of
    Flores et al., within 0.03 of the target down to 0.5) for a low ``R``.

    Attributes
    ----------
    stiffness : float
        ``k_c`` per unit effective mass (model units, length^(1-p) / time^2).
    R : float
        Target restitution, ``0 < R <= 1`` (valid near 1).
    exponent : float
        ``p`` (Hertz: 3/2).
    """

    name = "lankarani_nikravesh"
    chi_formula = "chi = 3 (1 - R^2) / 4, Lankarani & Nikravesh 1990"

    @staticmethod
    def chi_of(R: float) -> float:
        """Nondimensional damping ``chi = c v_in = 3 (1 - R^2) / 4``."""
        return 0.75 * (1.0 - R * R)
