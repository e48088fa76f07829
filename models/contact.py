"""Contact relations and contact laws, kept apart, and how both reach the event kernels.

vibeam follows the split of the nonsmooth-dynamics codes (Siconos keeps a ``Relation``,
e.g. ``LagrangianLinearTIR``, apart from a ``NonSmoothLaw``, e.g. ``NewtonImpactNSL``;
Acary & Brogliato, *Numerical Methods for Nonsmooth Dynamical Systems*, Springer 2008,
Ch. 3): *where* and *along what* bodies touch is the relation, *what happens* when they
touch is the law.  One law therefore serves one DOF or many, and one relation any law.

Relation of stop k (:class:`Relation`; geometry only, in the model's own coordinates)
    gap        ``g_k = s_k w^T eta - Delta_k``   (free while ``g_k < 0``, contact at ``g_k = 0``)
    velocity   ``U_k = s_k w^T eta'``            (approaching the stop while ``U_k > 0``)
    impulse    along ``M^-1 n_k``, ``n_k = s_k w``, effective mass
               ``m_eff = 1 / (n_k^T M^-1 n_k) = 1 / |w|^2`` (mass-normalised modes, ``M = I``)

    ``w`` is the model's contact row (SDOF: ``w = 1``, ``eta = q``; beam: ``w_i`` of the
    retained modes, paper Eq. 41).  The *upper* stop (paper Eq. 2, Sec. 6) has ``s = +1`` at
    ``w^T eta = Delta``; a second, *lower* stop of a two-sided scene has ``s = -1`` at
    ``w^T eta = -Delta_lower``: two relations with opposite normals, each with its own law.
    Both distances are measured from the static equilibrium; ``Delta + Delta_lower > 0``.

Law of stop k (unit free, acts on the relation's ``U``; :class:`Restitution`)
    *impulsive*  a velocity map at the contact event, ``U+ = L(U-)``; the kernels apply the
                 impulse ``P = m_eff (U+ - U-)`` along ``M^-1 n_k``.  Newton's law
                 ``U+ = -R(U-) U-`` (paper Eq. 2 and Eq. 41; ``R(U-)`` tabulated, Fig. 26)
                 is the one implemented: ``law = "restitution"``.
    *compliant*  a contact *phase* with its own flow (the stop's force ``F(delta, delta')``,
                 ``delta = g_k`` the penetration, added to the free flow) that ends at an
                 exit event where the contact force returns to zero (not where ``delta``
                 does).  Two families are implemented, each by its own kernels: Kelvin-Voigt
                 (:data:`LAW_LINEAR`) and hysteretic Hertz (:data:`LAW_HYSTERETIC_HERTZ`,
                 ``k delta^p (1 + chi delta' / v_in)``, ``chi`` a number of the law); the laws
                 are named in :data:`vibeam.models.registry.LAWS` (:mod:`vibeam.models.compliant`; in
                 kernel form :mod:`vibeam.models.core.laws`, simulated by the one event integrator,
                 :mod:`vibeam.models.core.contact_phase`, beside the impulsive ones), on one stop or
                 on two (each its own law; a compliant upper stop also beside a Newton lower one).

Kernel representation (numba: plain arrays, one row per stop; :func:`pack`)
    ``stops``   float64 (n_stops, :data:`NPAR`): row k = ``[sign s_k, offset Delta_k, law code,
                R, stiffness, damping, exponent, table nodes]`` (columns :data:`SIGN`,
                :data:`OFFSET`, :data:`LAW`, :data:`R`, :data:`STIFFNESS`, :data:`DAMPING`,
                :data:`EXPONENT`, :data:`NODES`); row 0 is the upper stop;
    ``tab_U``, ``tab_R``  float64 (n_stops, n_nodes): the ``R(U-)`` table of each stop
                (first ``NODES`` entries used; 0 nodes = constant R).
    The kernels apply Newton's law with :func:`vibeam.models.impact.restitution_coefficient`
    and decide what follows with the one policy of :mod:`vibeam.models.core.contact_policy`.

How a law plugs in
    A new law of an existing family is one class in :mod:`vibeam.models.compliant` (its
    ``name``, ``family``, ``code`` and numbers, e.g. its ``chi``) and one line of
    :data:`vibeam.models.registry.LAWS`; nothing else changes.  A new family adds its law code
    here and its force, partials, inside sign and exit condition to :mod:`vibeam.models.core.laws`
    (the one place the one event integrator, :mod:`vibeam.models.core.integrator` with the
    contact phase of :mod:`vibeam.models.core.contact_phase`, the direct solver and the shooting
    problem's saltation and variational terms branch on a law code).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .impact import restitution_at
from .registry import IMPLEMENTED_LAWS

# ---- layout of a stop row (kernel arrays)
SIGN, OFFSET, LAW, R, STIFFNESS, DAMPING, EXPONENT, NODES = range(8)
NPAR = 8

# ---- law codes and kinds
LAW_RESTITUTION = 0       # Newton's impact law, U+ = -R(U-) U- (impulsive)
LAW_LINEAR = 1            # Kelvin-Voigt spring-dashpot stop (compliant; vibeam.models.compliant)
LAW_HYSTERETIC_HERTZ = 2  # F = k delta^p (1 + chi delta' / v_in), chi from the law (compliant)



@dataclass(frozen=True)
class Relation:
    """Geometry of one stop: gap ``s w^T eta - offset``, velocity ``s w^T eta'``.

    Attributes
    ----------
    sign : float
        ``+1`` for the upper stop (at ``w^T eta = offset``), ``-1`` for a lower one (at
        ``w^T eta = -offset``).
    offset : float
        Distance of the stop from the static equilibrium along its normal (model units;
        negative = pre-stressed).
    row : int
        The system's contact row ``w`` the relation reads (index into
        :attr:`vibeam.models.system.ModalSystem.contacts`; 0: the attached mass, the paper's
        stop).
    """

    sign: float
    offset: float
    row: int = 0

    def gap(self, w, eta) -> float:
        """``g = s w^T eta - offset`` (< 0 free)."""
        return float(self.sign * (np.dot(w, eta)) - self.offset)

    def velocity(self, w, etad) -> float:
        """``U = s w^T eta'`` (> 0 approaching)."""
        return float(self.sign * np.dot(w, etad))

    def normal(self, w) -> np.ndarray:
        """``n = s w``: the impulse direction ``M^-1 n`` in mass-normalised coordinates."""
        return self.sign * np.atleast_1d(np.asarray(w, float))

    @staticmethod
    def effective_mass(w) -> float:
        """``1 / (n^T M^-1 n) = 1 / |w|^2`` (mass-normalised coordinates, ``M = I``)."""
        w = np.atleast_1d(np.asarray(w, float))
        return float(1.0 / np.sum(w * w))


#: the range of a coefficient of restitution (Newton's, paper Eq. 2): 0 plastic, 1 elastic
R_RANGE = (0.0, 1.0)


def restitution_problem(R, name: str = "R") -> str:
    """What is wrong with ``R`` as a coefficient of restitution (Newton's, paper Eq. 2), ``""`` if
    nothing: ``0 <= R <= 1`` (a NaN is refused).  The one range check of R in vibeam:
    :class:`Restitution` calls it for its R and its table's values when it is made, a continuation
    in R before it makes one, the case tables (:mod:`vibeam.case.contact`) for the key the user
    wrote."""
    why = ": a coefficient of restitution is greater than or equal to 0 (plastic) and less than or equal to 1 (elastic)"
    return "" if R_RANGE[0] <= R <= R_RANGE[1] else f"{name} must lie in [{R_RANGE[0]:g}, {R_RANGE[1]:g}], got {R}{why}"


@dataclass(frozen=True)
class Restitution:
    """Newton's impact law (impulsive): ``U+ = -R(U-) U-`` (paper Eq. 2, Eq. 41).

    Attributes
    ----------
    R : float
        Coefficient of restitution, ``0 <= R <= 1``.
    table_U, table_R : tuple of float
        ``R(U-)`` nodes (pre-impact normal velocity in the kernel's units, increasing),
        piecewise linear, constant beyond the ends (paper Fig. 26); empty = constant ``R``.
    """

    R: float
    table_U: tuple = ()
    table_R: tuple = ()

    def __post_init__(self):
        """Raises ValueError unless ``0 <= R <= 1`` and every ``table_R`` value too
        (:func:`restitution_problem`): the law holds and checks its numbers."""
        problem = restitution_problem(self.R) or next(
            (p for p in (restitution_problem(r, "R(U-)") for r in self.table_R) if p), "")
        if problem:
            raise ValueError(problem)

    kind = "impulsive"
    code = LAW_RESTITUTION
    #: cost of a sweep point with this law against the event grid's step count
    #: (:func:`vibeam.engine.jobs.estimate_work`): an impact is one map, the grid is the work
    work_factor = 1.0

    def coefficient(self, U_minus) -> float:
        """``R(U-)`` as the kernels evaluate it."""
        return restitution_at(U_minus, self.R, np.asarray(self.table_U, float), np.asarray(self.table_R, float))

    def row(self) -> tuple:
        """``(law code, R, stiffness, damping, exponent)`` of a kernel stop row."""
        return (float(self.code), float(self.R), 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Stop:
    """One stop: a relation and its law."""

    relation: Relation
    law: Restitution
    label: str = ""

    @property
    def name(self) -> str:
        """Its label, else ``"upper"`` or ``"lower"``."""
        return self.label or ("upper" if self.relation.sign > 0 else "lower")


def restitution_coefficients(laws, velocities, stops=None, scale: float = 1.0) -> np.ndarray:
    """R of impacts by Newton's law, each by its stop's law (the kernel's law in Python,
    :func:`vibeam.models.impact.restitution_at`).

    Parameters
    ----------
    laws : sequence or dict
        The law of each stop, indexed by the stop's code (``laws[0]`` the upper stop's).
    velocities : ndarray, shape (k,)
        Pre-impact normal speeds, in units whose ``scale`` multiple is the laws' (a table's
        ``U-``): the trajectory's, with ``scale`` the row value per unit of ``q``.
    stops : ndarray of int, shape (k,), or None
        The code of each impact's stop; None: all on ``laws[0]``.
    scale : float

    Returns
    -------
    ndarray, shape (k,)
        ``R`` of a constant law itself, else ``R(scale U-)`` of its table.

    Raises
    ------
    KeyError, IndexError
        A code without a law.
    """
    v = np.asarray(velocities, float)
    out = np.empty(v.shape[0])
    for i, x in enumerate(v):
        law = laws[0 if stops is None else int(stops[i])]
        out[i] = float(law.R) if law.kind == "impulsive" and not law.table_U else law.coefficient(float(x) * scale)
    return out


def pack(stops) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kernel arrays of a sequence of :class:`Stop` (module docstring).

    Returns
    -------
    par : ndarray, shape (n_stops, NPAR)
    tab_U, tab_R : ndarray, shape (n_stops, max(1, n_nodes))
    """
    n = len(stops)
    nodes = max([len(s.law.table_U) for s in stops] + [1])
    par = np.zeros((n, NPAR))
    tU = np.zeros((n, nodes))
    tR = np.zeros((n, nodes))
    for k, s in enumerate(stops):
        par[k, SIGN] = s.relation.sign
        par[k, OFFSET] = s.relation.offset
        par[k, LAW:EXPONENT + 1] = s.law.row()
        m = len(s.law.table_U)
        par[k, NODES] = m
        tU[k, :m] = s.law.table_U
        tR[k, :m] = s.law.table_R
    return par, tU, tR


def check_stops(stops) -> None:
    """Raise ValueError for stops the kernels cannot simulate (a law not implemented, a compliant
    law's numbers out of range, a lower stop overlapping the upper one; Newton's R is checked by
    :class:`Restitution` itself)."""
    for s in stops:
        if getattr(s.law, "kind", "") == "compliant" and s.law.code in (LAW_LINEAR, LAW_HYSTERETIC_HERTZ):
            s.law.check(s.name)    # the law's own ranges (vibeam.models.compliant)
            continue
        if getattr(s.law, "kind", "") != "impulsive" or s.law.code != LAW_RESTITUTION:
            raise ValueError(f"contact law of the {s.name} stop is not implemented; implemented: "
                             f"{', '.join(IMPLEMENTED_LAWS)}")
    if len(stops) == 2:
        up, lo = stops[0].relation, stops[1].relation
        if not up.offset + lo.offset > 0.0 or not math.isfinite(up.offset + lo.offset):
            raise ValueError(f"the stops overlap: Delta + Delta_lower = {up.offset + lo.offset} must be > 0")
