"""A structure given by its matrices, reduced to the one modal system of vibeam (issue 58).

A base-driven lumped or finite-element model in coordinates ``x`` relative to the base,

    ``M x'' + C x' + K x = -(M r) b''(t)``,    ``b = B sin(Omega~ t~)``,

with ``d`` degrees of freedom (DOFs), each named, is reduced to its ``n`` lowest undamped modes
(generalized eigenproblem ``K phi = omega^2 M phi``, ``Phi^T M Phi = I``): with ``x = Phi eta``

    ``eta_i'' + c_i eta_i' + omega_i^2 eta_i = Gamma_i Omega~^2 B sin(Omega~ t~)``,
    ``Gamma = Phi^T (M r)``,

the :class:`~vibeam.models.system.ModalSystem` of every method of vibeam, whose sensor row is
``s^T Phi`` and whose contact rows are ``W Phi`` (``s``, ``W``: rows over the DOFs, usually one
named DOF each).  The damping is modal: either the damping ratios ``zeta_i`` of the modes
(``c_i = 2 zeta_i omega_i``), or a damping matrix ``C`` that the undamped modes diagonalise
(classical normal modes, Caughey & O'Kelly 1965: ``C M^-1 K = K M^-1 C``; Rayleigh's ``a M + b K``
is one), ``c_i = phi_i^T C phi_i``.  A ``C`` that couples the modes is refused: the reduction
would drop the coupling.

The base enters through the inertia load per unit base acceleration ``M r`` (kg): ``r`` is the
influence vector of the base's translation (1 on every DOF that translates with it, 0 on a
rotation: ``"all"`` when every DOF is a translation along the drive), or ``M r`` is given as is
when the base couples through constrained DOFs (a consistent mass matrix of a clamped structure:
``(M_full r_full)`` on the free DOFs, :attr:`vibeam.models.builders.beam_fe.BeamFE.base_load` with its sign
changed).

Units
    The matrices in SI (kg, N s/m, N/m for translations; rotations in rad), the DOFs in metres:
    the modal coordinates are then sqrt(kg) m and the rows 1/sqrt(kg), giving metres (the FE
    beam's convention, :func:`vibeam.models.builders.beam.fe_beam`).  Time is the nondimensional
    ``t = omega_ref t~``, ``omega_ref = 2 pi f_ref`` (default ``f_ref = f_1``); the reported
    displacement ``q = (row @ eta) / L`` with the normalising length ``L`` (``length_m``).

Eigen-solvers
    Dense matrices, and sparse ones up to :data:`DENSE_MAX` DOFs, by
    :func:`vibeam.models.system.lowest_modes` (LAPACK, the FE beam's solver: its inverse problem
    up to half the spectrum); larger sparse ones by :func:`scipy.sparse.linalg.eigsh` in
    shift-invert mode about 0 (ARPACK, the ``n`` eigenvalues nearest 0: the lowest, ``K`` being
    positive definite).

References
----------
.. [1] L. Meirovitch, *Fundamentals of Vibrations*, McGraw-Hill 2001, Ch. 7 (the generalized
   eigenproblem, mass normalisation, modal analysis of base-excited proportionally damped
   systems).
.. [2] T. K. Caughey, M. E. J. O'Kelly, Classical normal modes in damped linear dynamic systems,
   J. Appl. Mech. 32 (1965) 583-588 (``C`` is diagonalised by the undamped modes iff
   ``C M^-1 K = K M^-1 C``).
.. [3] R. B. Lehoucq, D. C. Sorensen, C. Yang, *ARPACK Users' Guide*, SIAM 1998 (shift-invert
   mode of the generalized symmetric problem).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from ..contact import Stop
from ..scene import Excitation, Scene, driven
from ..system import ModalSystem, lowest_modes, modal_system

__all__ = ["MatrixModel", "build_matrices", "structure_scene", "modal_scene", "BUILDERS", "lowest_modes_of", "matrix_problem", "as_matrix", "DENSE_MAX",
           "CAUGHEY_RTOL", "SYMMETRY_RTOL", "REPEATED_RTOL"]

TWO_PI = 2.0 * math.pi
#: the builder names of the scenes :func:`structure_scene` makes (the registry's fidelities)
BUILDERS = ("matrices", "continuum", "mesh")
#: largest size solved densely (LAPACK); larger sparse matrices go to ARPACK (eigsh, shift-invert)
DENSE_MAX = 2000
#: largest coupling of a mode by ``C`` accepted, relative to its own damping (beyond the round-off
#: of ``C phi``): ``|C phi_i - c_i M phi_i|_{M^-1} <= CAUGHEY_RTOL c_i``; a coupling this small
#: changes the response by a like fraction of the damping's effect
CAUGHEY_RTOL = 1e-6
#: largest ``|A - A^T|`` accepted, relative to the largest ``|A|``: a matrix printed with 9
#: significant digits is symmetric to 5e-10 (the mean of ``A`` and ``A^T`` is used)
SYMMETRY_RTOL = 1e-8
#: two squared frequencies are one repeated frequency when ``lam_j - lam_i <= REPEATED_RTOL lam_j``
REPEATED_RTOL = 1e-10

_EPS = np.finfo(float).eps


# ============================================================================ matrices
def as_matrix(A):
    """``A`` as a float64 matrix: a dense C-contiguous ndarray, or a ``scipy.sparse`` CSR array.

    Parameters
    ----------
    A : array_like or scipy.sparse matrix / array

    Returns
    -------
    ndarray or scipy.sparse.csr_array
        The values as float64 (a copy); sparse input stays sparse.

    Raises
    ------
    ValueError
        If the values are not real numbers (complex, text, objects, booleans).
    """
    if scipy.sparse.issparse(A):
        if not (np.issubdtype(A.dtype, np.number) and not np.issubdtype(A.dtype, np.complexfloating)):
            raise ValueError(f"values of type {A.dtype} are not real numbers")
        return scipy.sparse.csr_array(A, dtype=float, copy=True)
    a = np.asarray(A)
    if not (np.issubdtype(a.dtype, np.number) and not np.issubdtype(a.dtype, np.complexfloating)):
        raise ValueError(f"values of type {a.dtype} are not real numbers")
    return np.array(a, dtype=float, order="C")


def _values(A) -> np.ndarray:
    return A.data if scipy.sparse.issparse(A) else A.ravel()


def _max_abs(A) -> float:
    v = _values(A)
    return float(np.max(np.abs(v))) if v.size else 0.0


def _symmetric_pivots(A) -> np.ndarray:
    """Pivots of the symmetric factorisation ``P^T A P = L D L^T`` of a sparse symmetric ``A``
    (SuperLU without row pivoting, symmetric mode): their signs are ``A``'s inertia (Sylvester)."""
    lu = scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                  options=dict(SymmetricMode=True))
    return lu.U.diagonal()


def matrix_problem(A, definite=None, size=None, dense_max=DENSE_MAX):
    """What makes ``A`` unusable as a mass, stiffness or damping matrix, or None.

    One check for the builder (:func:`build_matrices`) and the file reader
    (:mod:`vibeam.io.matrices`), which words the answer for its file and key.

    Parameters
    ----------
    A : ndarray or scipy.sparse array, shape (d, d)
        Float64 (:func:`as_matrix`).
    definite : {None, "positive", "semi"}
        Also require ``A`` positive definite (a mass matrix, a stiffness held by its base) or
        positive semi-definite.  Dense and up to ``dense_max`` DOFs: Cholesky (``"positive"``) or
        the smallest eigenvalue ``>= -1e-10`` times the largest (``"semi"``); larger sparse: the
        pivots' signs of a symmetric factorisation (of ``A + 1e-10 max|A_ii| I`` for ``"semi"``).
    size : int or None
        The size ``A`` must have (M's).

    Returns
    -------
    tuple of (str, str) or None
        ``(problem, allowed)``, e.g. ``("not symmetric (|A - A^T| up to 3e-2 of max |A|)",
        "a symmetric matrix ...")``; None when ``A`` is usable.
    """
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        return (f"not a square matrix (shape {'x'.join(map(str, A.shape))})",
                "a square matrix" + ("" if size is None else f" of {size} x {size}, M's size"))
    d = A.shape[0]
    if d < 1:
        return ("an empty matrix", "a square matrix of at least one degree of freedom")
    if size is not None and d != size:
        return (f"{d} x {d}, not M's size", f"a matrix of {size} x {size}, M's size")
    v = _values(A)
    if not np.all(np.isfinite(v)):
        bad = int(np.sum(~np.isfinite(v)))
        return (f"{bad} entries not finite (NaN or infinite)", "finite numbers only")
    big = _max_abs(A)
    asym = _max_abs(A - A.T)
    if asym > SYMMETRY_RTOL * big:
        return (f"not symmetric (|A - A^T| up to {asym / big:.3g} of max |A|)",
                f"a symmetric matrix (to {SYMMETRY_RTOL:g} of its largest entry; a damping with gyroscopic "
                f"or circulatory parts is not modal)")
    if definite is None:
        return None
    S = (A + A.T) * 0.5
    allowed = ("a positive definite matrix" if definite == "positive" else "a positive semi-definite matrix")
    sparse_big = scipy.sparse.issparse(S) and d > dense_max
    if definite == "positive":
        if sparse_big:
            try:
                piv = _symmetric_pivots(S)
            except RuntimeError:
                return ("singular", allowed)
            ok = bool(np.all(piv > 0.0))
        else:
            try:
                np.linalg.cholesky(S.toarray() if scipy.sparse.issparse(S) else S)
                ok = True
            except np.linalg.LinAlgError:
                ok = False
        return None if ok else ("not positive definite", allowed)
    if sparse_big:
        diag = np.abs(S.diagonal())
        shift = 1e-10 * (float(diag.max()) if diag.size else 0.0)
        try:
            piv = _symmetric_pivots(S + shift * scipy.sparse.eye_array(d, format="csr"))
        except RuntimeError:
            return ("not positive semi-definite (a zero pivot)", allowed)
        return None if np.all(piv > 0.0) else ("not positive semi-definite (a negative eigenvalue)", allowed)
    w = scipy.linalg.eigvalsh(S.toarray() if scipy.sparse.issparse(S) else S)
    if w[0] < -1e-10 * max(abs(w[-1]), abs(w[0])):
        return (f"not positive semi-definite (an eigenvalue {w[0]:.3g}, the largest {w[-1]:.3g})", allowed)
    return None


def _check(A, name, definite=None, size=None, dense_max=DENSE_MAX):
    try:
        A = as_matrix(A)
    except ValueError as e:
        raise ValueError(f"{name}: {e}; allowed: a real matrix") from None
    p = matrix_problem(A, definite, size, dense_max)
    if p is not None:
        raise ValueError(f"{name} is {p[0]}; allowed: {p[1]}")
    return (A + A.T) * 0.5       # exactly A when A is exactly symmetric


# ============================================================================ eigenpairs
def lowest_modes_of(K, M, n, dense_max=DENSE_MAX):
    """Lowest ``n`` eigenpairs of ``K v = lam M v``, ascending, M-normalised, dense or sparse.

    Dense input, and sparse input of at most ``dense_max`` DOFs (made dense), by
    :func:`vibeam.models.system.lowest_modes` (bit for bit the FE beam's modes); larger sparse
    input by :func:`scipy.sparse.linalg.eigsh` in shift-invert mode about ``sigma = 0`` (the
    ``n`` eigenvalues nearest 0, ``K`` positive definite), then ``V^T M V = I``.

    Parameters
    ----------
    K, M : ndarray or scipy.sparse array, shape (d, d)
        Symmetric; ``M`` positive definite, ``K`` positive definite.
    n : int
        ``1 <= n <= d`` (``n < d`` for the sparse solver).
    dense_max : int
        Largest size solved densely.

    Returns
    -------
    lam : ndarray, shape (n,)
        ``omega^2`` (units of ``K / M``: 1/s^2 in SI), ascending.
    V : ndarray, shape (d, n)
        Mass-normalised modes, ``V^T M V = I`` (1/sqrt(kg) in SI).

    Raises
    ------
    numpy.linalg.LinAlgError
        From LAPACK when a matrix it factorises is not positive definite.
    scipy.sparse.linalg.ArpackError, RuntimeError
        From ARPACK or SuperLU (a singular ``K``).
    """
    d = K.shape[0]
    if not (scipy.sparse.issparse(K) or scipy.sparse.issparse(M)) or d <= dense_max:
        Kd = K.toarray() if scipy.sparse.issparse(K) else K
        Md = M.toarray() if scipy.sparse.issparse(M) else M
        return lowest_modes(Kd, Md, n)
    Ks, Ms = scipy.sparse.csc_matrix(K), scipy.sparse.csc_matrix(M)
    # a fixed start vector (ARPACK's default is random): the same matrices give the same modes bit for
    # bit, so a model rebuilt (another cache, another machine's first run) is the one its references
    # were computed with; its components are nonzero on every DOF (no mode orthogonal to it by symmetry)
    v0 = np.random.default_rng(0).uniform(0.5, 1.5, Ks.shape[0])
    lam, V = scipy.sparse.linalg.eigsh(Ks, k=n, M=Ms, sigma=0.0, which="LM", v0=v0)
    order = np.argsort(lam)
    lam, V = lam[order], V[:, order]
    V = V / np.sqrt(np.einsum("ij,ij->j", V, Ms @ V))
    return np.clip(lam, 0.0, None), V


def _clusters(lam):
    """``[(i, j), ...]``: index ranges of equal squared frequencies (:data:`REPEATED_RTOL`)."""
    out, i = [], 0
    while i < lam.size:
        j = i + 1
        while j < lam.size and lam[j] - lam[i] <= REPEATED_RTOL * lam[j]:
            j += 1
        out.append((i, j))
        i = j
    return out


# ============================================================================ the model
@dataclass(frozen=True)
class MatrixModel:
    """A structure given by its matrices, reduced to ``n`` modes, with its DOFs' names.

    Attributes
    ----------
    system : ModalSystem
        The modal system (``omega``, ``damping`` per unit nondimensional time; ``participation``
        sqrt(kg); ``sensor`` and ``contacts`` rows 1/sqrt(kg), giving the DOFs' units, metres; units
        ``time_unit_s = 1 / (2 pi f_ref)``, ``length_unit_m = coordinate_scale = L``,
        ``mass_unit_kg = 1``).
    dofs : tuple of str, length d
        The DOFs' names, in the matrices' order.
    sensor_name : str
        The sensor's DOF name (or ``"row"`` for a row given as a vector).
    contact_names : tuple of str, length n_c
        The name of each contact row's DOF (``"row k"`` for a vector), in ``system.contacts``' order:
        a stop's relation references contact row ``k``.
    shapes : ndarray, shape (d, n)
        Mass-normalised modes ``Phi`` (``Phi^T M Phi = I``; 1/sqrt(kg)), each signed so that its
        largest component is positive.
    frequencies_hz : ndarray, shape (n,)
        Natural frequencies ``omega_i / 2 pi`` (Hz), ascending.
    damping_ratios : ndarray, shape (n,)
        ``zeta_i = c_i / (2 omega_i)``.
    static : ndarray, shape (d,)
        Static deflection of each DOF under the base load ``K^-1 M r`` over the sensor's:
        a gap ``g`` seen at the sensor is ``static[j] g`` at DOF ``j`` (the FE beam's ``phi(x_m)``,
        which is the paper's static mode, a point load at the mass, Eq. 42: for the rig's beam
        ``K^-1 M r`` gives 1.5526 at the mass, the point-load mode 1.5540).  NaN where the sensor
        does not move under that load.
    caughey_ratio : float
        Largest coupling of a kept mode by ``C`` relative to its own damping,
        ``|C phi_i - c_i M phi_i|_{M^-1} / c_i`` (0 with damping ratios given).
    """

    system: ModalSystem
    dofs: tuple
    sensor_name: str
    contact_names: tuple
    shapes: np.ndarray
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    static: np.ndarray
    caughey_ratio: float

    @property
    def contact_static(self) -> np.ndarray:
        """The same for each contact row, ``W_k K^-1 M r / s K^-1 M r``, shape (n_c,): the system's
        :attr:`~vibeam.models.system.ModalSystem.contact_static`."""
        return self.system.contact_static

    @property
    def n_modes(self) -> int:
        """``n``, the modes kept."""
        return int(self.system.omega.shape[0])

    def index(self, name: str) -> int:
        """The index of DOF ``name``.

        Raises
        ------
        KeyError
            For a name that is not a DOF's (the message lists the names).
        """
        try:
            return self.dofs.index(name)
        except ValueError:
            raise KeyError(f"no DOF named {name!r}; the DOFs: {', '.join(self.dofs[:20])}"
                           + (" ..." if len(self.dofs) > 20 else "")) from None

    def modal_row(self, name: str) -> np.ndarray:
        """Row of DOF ``name`` in the modal coordinates, ``Phi[j]``, shape (n,) (1/sqrt(kg)): its
        displacement is ``modal_row(name) @ eta`` (a force point's row, a further sensor's)."""
        return self.shapes[self.index(name)].copy()

    def contact_gap(self, k: int, gap_at_sensor: float) -> float:
        """The gap at contact row ``k`` of a gap ``gap_at_sensor`` seen at the sensor (the same
        unit): ``contact_static[k] * gap_at_sensor`` (paper Eq. 45's ``Delta_C = phi(x_m) Delta_G``).

        Raises
        ------
        ValueError
            When the sensor does not move under the base load (no ratio).
        """
        ratio = float(self.contact_static[k])
        if not math.isfinite(ratio):
            raise ValueError("the sensor does not move under the base load K^-1 M r: a gap seen at the sensor "
                             "has no gap at the contact; allowed: the gap at the contact itself")
        return ratio * float(gap_at_sensor)


def _row(spec, dofs, what):
    """A physical row (d,) and its label from a DOF name, an index or a row vector."""
    d = len(dofs)
    if isinstance(spec, str):
        if spec not in dofs:
            raise ValueError(f"{what} = {spec!r} names no DOF; allowed: one of {', '.join(dofs[:20])}"
                             + (" ..." if d > 20 else ""))
        row = np.zeros(d)
        row[dofs.index(spec)] = 1.0
        return row, spec
    if isinstance(spec, (int, np.integer)) and not isinstance(spec, bool):
        if not 0 <= int(spec) < d:
            raise ValueError(f"{what} = {spec!r} is no DOF index; allowed: 0 .. {d - 1} or a DOF's name")
        row = np.zeros(d)
        row[int(spec)] = 1.0
        return row, dofs[int(spec)]
    row = np.array(spec, dtype=float).reshape(-1)
    if row.shape != (d,) or not np.all(np.isfinite(row)) or not np.any(row != 0.0):
        raise ValueError(f"{what} must be a DOF's name, its index or a finite nonzero row of {d} numbers, "
                         f"got shape {np.shape(spec)}")
    return row, "row"


def _dof_names(dofs, d):
    if dofs is None:
        return tuple(f"dof{i}" for i in range(d))
    names = tuple(str(x) for x in (dofs.tolist() if isinstance(dofs, np.ndarray) else dofs))
    if len(names) != d:
        raise ValueError(f"dofs has {len(names)} names for {d} DOFs; allowed: one name per DOF")
    if any(not s.strip() for s in names):
        raise ValueError("dofs: an empty name; allowed: non-empty names")
    seen = set()
    for s in names:
        if s in seen:
            raise ValueError(f"dofs: {s!r} appears twice; allowed: distinct names")
        seen.add(s)
    return names


def _mnorm(x, solve_M):
    """``sqrt(x^T M^-1 x)`` for the columns of ``x`` (d, k)."""
    return np.sqrt(np.maximum(np.einsum("ij,ij->j", x, solve_M(x)), 0.0))


def build_matrices(M, K, C=None, damping_ratios=None, r="all", Mr=None, dofs=None, sensor=0, contacts=None,
                   n_modes=None, base_amplitude_m=0.0, f_ref_hz=None, length_m=1.0, caughey_rtol=CAUGHEY_RTOL,
                   dense_max=DENSE_MAX) -> MatrixModel:
    """Reduce ``M x'' + C x' + K x = -(M r) b''`` to its lowest ``n_modes`` undamped modes.

    Parameters
    ----------
    M, K : array_like or scipy.sparse, shape (d, d)
        Mass (kg) and stiffness (N/m) matrices over the DOFs (SI; any consistent units), symmetric
        (to :data:`SYMMETRY_RTOL`, then their mean with the transpose), ``M`` positive definite,
        ``K`` positive definite (the structure held by its base: no rigid-body mode).
    C : array_like or scipy.sparse, shape (d, d), optional
        Damping matrix (N s/m), symmetric, diagonalised by the undamped modes (Caughey):
        ``c_i = phi_i^T C phi_i``.  Exactly one of ``C`` and ``damping_ratios``.
    damping_ratios : float or array_like, shape (n,), optional
        Modal damping ratios ``zeta_i >= 0``, one per kept mode or one for all:
        ``c_i = 2 zeta_i omega_i``.
    r : "all" or array_like, shape (d,)
        Influence vector of the base translation (``"all"``: ones, every DOF translates with the
        base); the base load per unit base acceleration is ``M r``.
    Mr : array_like, shape (d,), optional
        That load itself (kg), instead of ``r`` (a base coupled through constrained DOFs).
    dofs : sequence of str, length d, optional
        Distinct names of the DOFs (default ``dof0``, ``dof1``, ...).
    sensor : str, int or array_like (d,)
        The sensor's DOF (name or index) or physical row ``s`` (``s @ x`` is its reading).
    contacts : sequence of (str, int or array_like (d,)), optional
        The contact points' DOFs or rows ``W``, in the order the stops' relations reference them
        (default: the sensor's).
    n_modes : int, "all" or None
        The lowest modes kept, ``1 <= n_modes <= d`` (None or ``"all"``: all; a number is required
        for sparse input of more than ``dense_max`` DOFs).  Its last kept frequency must not be
        repeated by the next.
    base_amplitude_m : float
        ``B`` (m, the DOFs' unit).
    f_ref_hz : float or None
        Reference frequency of the time unit (Hz; default the lowest kept ``f_1``).
    length_m : float
        Normalising length ``L`` (m) of the reported ``q = (row @ eta) / L``.
    caughey_rtol : float
        Largest coupling by ``C`` accepted (:data:`CAUGHEY_RTOL`).
    dense_max : int
        Largest size solved densely (:func:`lowest_modes_of`).

    Returns
    -------
    MatrixModel
        The modal system, the DOFs' names, the kept shapes and the static deflection ratios.

    Raises
    ------
    ValueError
        One line naming what is wrong and what is allowed: a matrix not real, not square, of
        another size than ``M``, not finite, not symmetric, ``M`` or ``K`` not positive definite;
        neither or both of ``C`` and ``damping_ratios``; ``C`` not diagonalised by the undamped
        modes (naming the largest coupling ratio and its mode) or giving a negative modal damping;
        damping ratios negative or of the wrong count, or different within a repeated frequency;
        ``n_modes`` out of range or splitting a repeated frequency; a DOF name, index or row that
        does not exist; ``r`` and ``Mr`` both given; ``f_ref_hz`` or ``length_m`` not positive.
    """
    M = _check(M, "M", "positive", dense_max=dense_max)
    d = M.shape[0]
    K = _check(K, "K", "positive", size=d, dense_max=dense_max)
    if (C is None) == (damping_ratios is None):
        raise ValueError("give the damping as C (a matrix) or as damping_ratios (per mode), exactly one of them")
    if C is not None:
        C = _check(C, "C", size=d, dense_max=dense_max)
    names = _dof_names(dofs, d)
    sparse_big = (scipy.sparse.issparse(M) or scipy.sparse.issparse(K)) and d > dense_max
    if n_modes is None or (isinstance(n_modes, str) and n_modes == "all"):
        if sparse_big:
            raise ValueError(f"n_modes: give the number of modes to keep of a sparse system of {d} DOFs "
                             f"(more than {dense_max}: ARPACK finds the lowest few)")
        n = d
    else:
        try:
            n = int(n_modes)
        except (TypeError, ValueError):
            n = -1
        if isinstance(n_modes, bool) or n != n_modes or not 1 <= n <= (d - 1 if sparse_big else d):
            raise ValueError(f"n_modes = {n_modes!r}; allowed: an integer in [1, {d - 1 if sparse_big else d}]")
    r = "all" if r is None else r
    if Mr is not None and not (isinstance(r, str) and r == "all"):
        raise ValueError("give the base as r (influence vector) or as Mr (its load M r), not both")
    if Mr is not None:
        load = np.array(Mr, dtype=float).reshape(-1)
        what = "Mr"
    elif isinstance(r, str):
        if r != "all":
            raise ValueError(f"r = {r!r}; allowed: 'all' or a vector of {d} numbers")
        load = M @ np.ones(d)
        what = "r"
    else:
        rv = np.array(r, dtype=float).reshape(-1)
        if rv.shape != (d,):
            raise ValueError(f"r has shape {np.shape(r)}; allowed: 'all' or a vector of {d} numbers")
        load, what = M @ rv, "r"
    if load.shape != (d,) or not np.all(np.isfinite(load)):
        raise ValueError(f"{what} must be {d} finite numbers, got shape {load.shape}")
    s_phys, s_name = _row(sensor, names, "sensor")
    specs = (sensor,) if contacts is None else tuple(contacts)
    if not specs:
        raise ValueError("contacts: no contact point; allowed: one or more DOFs or rows")
    rows = [_row(c, names, f"contacts[{k}]") for k, c in enumerate(specs)]
    W_phys = np.vstack([rw for rw, _ in rows])
    L = float(length_m)
    if not (L > 0 and math.isfinite(L)):
        raise ValueError(f"length_m = {length_m!r}; allowed: a positive length (m)")

    # the modes, and whether the truncation splits a repeated frequency (the next eigenvalue)
    if sparse_big:
        lam, V = lowest_modes_of(K, M, min(n + 1, d - 1), dense_max)
        nxt = lam[n] if lam.size > n else math.inf
        lam, V = lam[:n], V[:, :n]
    else:
        Kd = K.toarray() if scipy.sparse.issparse(K) else K
        Md = M.toarray() if scipy.sparse.issparse(M) else M
        lam, V = lowest_modes(Kd, Md, n)
        nxt = lowest_modes(Kd, Md, n + 1, eigvals_only=True)[n] if n < d else math.inf
    V = np.array(V, order="C")
    if n < d:
        if nxt - lam[-1] <= REPEATED_RTOL * nxt:
            raise ValueError(f"n_modes = {n} splits a repeated frequency ({math.sqrt(lam[-1]) / TWO_PI:.6g} Hz, modes "
                             f"{n} and {n + 1}); allowed: n_modes keeping the whole eigenspace or none of it")
    clusters = _clusters(lam)

    if scipy.sparse.issparse(M):
        lu = scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(M))

        def solve_M(x):
            return lu.solve(x)
    else:
        cf = scipy.linalg.cho_factor(M)

        def solve_M(x):
            return scipy.linalg.cho_solve(cf, x)

    om = np.sqrt(lam)
    ratio_max = 0.0
    if C is not None:
        # a repeated frequency leaves the basis of its eigenspace free: rotate it to diagonalise C
        for i, j in clusters:
            if j - i > 1:
                _, Q = np.linalg.eigh(V[:, i:j].T @ (C @ V[:, i:j]))
                V[:, i:j] = V[:, i:j] @ Q
        CV = C @ V
        c = np.einsum("ij,ij->j", V, CV)
        MV = M @ V
        cmax = float(np.max(np.abs(c)))
        if np.any(c < -1e-12 * cmax):
            i = int(np.argmin(c))
            raise ValueError(f"C gives mode {i + 1} ({om[i] / TWO_PI:.6g} Hz) a negative damping phi^T C phi = "
                             f"{c[i]:.3g}; allowed: C positive semi-definite on the modes")
        c = np.maximum(c, 0.0)
        # Caughey: C phi_i = c_i M phi_i, i.e. column i of Phi^T C Phi (over all d modes) is zero
        # off its diagonal; its M^-1-norm off the diagonal against c_i, beyond the round-off of C phi
        coupling = _mnorm(CV - MV * c, solve_M)
        absV = np.abs(V)
        noise = 16.0 * _EPS * _mnorm(abs(C) @ absV + (abs(M) @ absV) * c, solve_M)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(coupling == 0.0, 0.0, coupling / c)
        bad = coupling - noise > caughey_rtol * c
        i = int(np.argmax(np.where(bad, ratio, -1.0))) if np.any(bad) else int(np.argmax(ratio))
        ratio_max = float(ratio[i])
        if np.any(bad):
            raise ValueError(f"C is not diagonalised by the undamped modes: it couples mode {i + 1} "
                             f"({om[i] / TWO_PI:.6g} Hz) to the others by {ratio_max:.3g} of its own damping "
                             f"(|C phi - c M phi| / c, tolerance {caughey_rtol:g}); allowed: classical damping "
                             f"(Caughey: C M^-1 K = K M^-1 C, e.g. C = a M + b K) or damping_ratios per mode")
    else:
        z = np.array(damping_ratios, dtype=float).reshape(-1)
        if z.size == 1:
            z = np.full(n, float(z[0]))
        if z.shape != (n,) or not np.all(np.isfinite(z)) or np.any(z < 0.0):
            raise ValueError(f"damping_ratios = {np.array(damping_ratios).tolist()!r}; allowed: one ratio >= 0 "
                             f"for all modes or one per kept mode ({n})")
        for i, j in clusters:
            if j - i > 1 and np.any(z[i:j] != z[i]):
                raise ValueError(f"damping_ratios differ within the repeated frequency {om[i] / TWO_PI:.6g} Hz "
                                 f"(modes {i + 1} to {j}), whose modes are any basis of its eigenspace; allowed: "
                                 f"equal ratios there")
        c = 2.0 * z * om
        zeta = z

    # signs: each mode's largest component positive
    big = np.argmax(np.abs(V), axis=0)
    V = V * np.where(V[big, np.arange(n)] < 0.0, -1.0, 1.0)

    om_ref = om[0] if f_ref_hz is None else TWO_PI * float(f_ref_hz)
    if not (om_ref > 0 and math.isfinite(om_ref)):
        raise ValueError(f"f_ref_hz = {f_ref_hz!r}; allowed: a positive frequency (Hz)")
    system = modal_system(om / om_ref, c / om_ref, V.T @ load, s_phys @ V, W_phys @ V, float(base_amplitude_m),
                          time_unit_s=1.0 / om_ref, length_unit_m=L, coordinate_scale=L, mass_unit_kg=1.0)

    # static deflection under the base load, over the sensor's
    if scipy.sparse.issparse(K):
        us = scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(K)).solve(load)
    else:
        us = scipy.linalg.solve(K, load, assume_a="pos")
    ys = float(s_phys @ us)
    with np.errstate(divide="ignore", invalid="ignore"):
        static = us / ys if ys != 0.0 else np.full(d, math.nan)
        cstatic = W_phys @ us / ys if ys != 0.0 else np.full(W_phys.shape[0], math.nan)
    system = system._replace(contact_static=np.asarray(cstatic, float))
    if C is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            zeta = np.where(c == 0.0, 0.0, c / (2.0 * om))
    return MatrixModel(system, names, s_name, tuple(lab if lab != "row" else f"row {k}" for k, (_, lab) in
                                                    enumerate(rows)),
                       V, om / TWO_PI, zeta, static, ratio_max)


# ============================================================================ the scene
def structure_scene(mm, stops, base_amplitude_m, builder="matrices", excitation=None, drive_row=None):
    """The structure reduced to its modes, with its stops and its drive, as a scene (issue 58):
    what every method of the N-mode model takes.

    The system is the reduced one in its own units (time ``1 / omega_ref``, ``omega_ref = 2 pi
    f_ref``; modal coordinates in sqrt(kg) m, rows giving metres; ``B = base_amplitude_m``), its
    frequencies and damping carried in that unit as the FE beam's (:func:`modal_scene`:
    ``omega_i = 2 pi f_i / omega_ref``, ``c_i`` per second over ``omega_ref``); the first contact
    row's static ratio to the sensor is kept (paper Eq. 45's ``phi(x_m)``: the gap the results are
    reported from), the others' are NaN.

    Parameters
    ----------
    mm : MatrixModel
        Its contact row 0 is the first stop's point; its further rows those of the further stops.
    stops : sequence of vibeam.models.contact.Stop
        The stops at row 0 first (the upper one, then a lower one), then one per further row; each
        relation's offset in metres along its normal (negative: pre-stressed), each law in SI (a
        compliant stiffness in N/m^p at its point): the scene holds it over ``omega_ref^2``.
    base_amplitude_m : float
        ``B`` (m) of the base-displacement drive, the DOFs' unit.
    builder : str
        The scene's builder name (``"matrices"``, ``"continuum"``, ``"mesh"``: :data:`BUILDERS`).
    excitation, drive_row
        As :func:`modal_scene`'s (a force's row: :meth:`MatrixModel.modal_row`).

    Returns
    -------
    vibeam.models.scene.Scene

    Raises
    ------
    ValueError
        The sensor or the first stop's point not moved by the base load (no static ratio refers
        the gap to the sensor); and :func:`modal_scene`'s refusals.
    """
    s = mm.system
    phim = float(mm.contact_static[0])
    if not (math.isfinite(phim) and phim != 0.0):
        raise ValueError("the sensor or the first stop's point does not move under the base load K^-1 M r: "
                         "no static ratio refers the gap to the sensor (paper Eq. 45)")
    return modal_scene(TWO_PI * np.asarray(mm.frequencies_hz, dtype=float), np.asarray(s.damping, float) / s.time_unit_s,
                       s.participation, s.sensor, s.contacts, stops, base_amplitude_m,
                       1.0 / (TWO_PI * s.time_unit_s), s.length_unit_m, phim, builder, excitation, drive_row)


def modal_scene(omega_rad_s, damping_1_s, participation, sensor_row, contact_rows, stops, base_amplitude_m,
                f_ref_hz, length_m, phi_contact, builder, excitation=None, drive_row=None) -> Scene:
    """A structure reduced to ``n`` mass-normalised modes, with its stops and its drive, as a scene
    (issue 58): the one packing of every builder of an ``n``-mode structure (the FE beam,
    :mod:`.beam`; matrices, a continuum, a mesh: :func:`structure_scene`).

    The system is in its own units: time ``1 / omega_ref`` (``omega_ref = 2 pi f_ref``), so its
    frequencies are ``omega_i / omega_ref`` and its damping ``c_i / omega_ref``; modal coordinates
    in sqrt(kg) m, rows giving metres, ``B = base_amplitude_m``; ``length_unit_m =
    coordinate_scale = L``, ``mass_unit_kg = 1``; the first contact row's static ratio to the sensor
    is ``phi_contact`` (paper Eq. 45's ``phi(x_m)``), the others' NaN.

    Parameters
    ----------
    omega_rad_s, damping_1_s, participation, sensor_row : array_like, shape (n,)
        Natural frequencies ``omega_i`` (rad/s, > 0), modal damping ``c_i`` (1/s, >= 0; ``2 zeta_i
        omega_i``), base participations ``Gamma_i = phi_i^T M r`` (sqrt(kg)) and the sensor's row
        ``s^T phi_i`` (1/sqrt(kg)).
    contact_rows : array_like, shape (n_c, n)
        The rows ``W phi_i`` (1/sqrt(kg)) of the contact points: row 0 the first stop's.
    stops : sequence of vibeam.models.contact.Stop
        Each relation's offset in metres along its normal (negative: pre-stressed) on its contact
        row, each law in SI (a compliant stiffness in N/m^p at its point): the scene holds it over
        ``omega_ref^2``.  Two stops on row 0 are an upper and a lower one.
    base_amplitude_m : float
        ``B`` (m) of the base-displacement drive.
    f_ref_hz, length_m, phi_contact : float
        ``f_ref`` (Hz: ``Omega = f / f_ref``), the normalising length ``L`` (m: ``q = U(L_S) / L``)
        and the static ratio of contact row 0 to the sensor.
    builder : str
        The scene's builder name (``"beam"``, ``"matrices"``, ...: its module's ``BUILDERS``).
    excitation : vibeam.models.scene.Excitation or None
        Another drive (SI): a base acceleration, or a force along ``drive_row``
        (:func:`vibeam.models.scene.driven`); None: the base displacement.
    drive_row : array_like, shape (n,), optional
        The modal row of a force's point (1/sqrt(kg)).

    Returns
    -------
    vibeam.models.scene.Scene
        The system in its own units, the stops in them, ``builder``.

    Raises
    ------
    ValueError
        Modal arrays of different lengths or none; a frequency that is not positive or a damping
        below 0; no mode moving contact row 0 or a stop's point; two stops at row 0 that overlap.
    """
    om = np.array(omega_rad_s, dtype=float)
    c = np.array(damping_1_s, dtype=float)
    n = om.size
    rows = np.array(contact_rows, dtype=float)
    if not (np.size(participation) == np.size(sensor_row) == c.size == rows.shape[-1] == n and n >= 1):
        raise ValueError("modal arrays must have the same length >= 1")
    if not np.all(om > 0):
        raise ValueError("modal frequencies must be positive")
    if not np.all(c >= 0):
        raise ValueError("damping coefficients must be >= 0")
    if not np.any(rows[0] != 0.0):
        raise ValueError("no retained mode moves the contact point")
    for st in stops:
        if not np.any(rows[st.relation.row] != 0.0):
            raise ValueError(f"the {st.name} stop: no retained mode moves its point")
    mass = [st for st in stops if st.relation.row == 0]
    if len(mass) == 2 and not mass[0].relation.offset + mass[1].relation.offset > 0.0:
        raise ValueError("the stops overlap: gap_contact_m + gap_contact_lower_m must be > 0")
    f_ref = float(f_ref_hz)
    om_ref = TWO_PI * f_ref
    static = np.full(rows.shape[0], math.nan)
    static[0] = float(phi_contact)
    system = modal_system(om / om_ref, c / om_ref, np.array(participation, dtype=float),
                          np.array(sensor_row, dtype=float), rows, float(base_amplitude_m), time_unit_s=1.0 / om_ref,
                          length_unit_m=float(length_m), coordinate_scale=float(length_m), mass_unit_kg=1.0,
                          contact_static=static, reference_hz=f_ref)
    own = tuple(Stop(st.relation, dataclasses.replace(st.law, stiffness=st.law.stiffness / om_ref ** 2)
                     if getattr(st.law, "kind", "") == "compliant" else st.law, st.label) for st in stops)
    sc = Scene(system, own, builder)
    if excitation is None:
        return sc
    if excitation.kind != "force":
        return sc._replace(system=driven(system, excitation))
    n_c = rows.shape[0]
    with_row = system._replace(contacts=np.vstack([rows, np.asarray(drive_row, float)[None, :]]))
    return sc._replace(system=driven(with_row, Excitation("force", excitation.amplitude, n_c))._replace(contacts=rows))
