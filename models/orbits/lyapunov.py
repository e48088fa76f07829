"""Lyapunov exponents of the stroboscopic map, on the one shooting-problem contract.

A shooting problem (:mod:`vibeam.models.core.periodic`: ``shot(x0, p, n)`` returns ``P^n(x0)`` and
its monodromy ``M = d P^n / d x0``) already composes, along the orbit it follows, the exact
state-transition matrices of the flows with the saltation matrices of the impacts (Newton's law:
Müller, *Calculation of Lyapunov exponents for dynamic systems with discontinuities*, Chaos,
Solitons & Fractals 5, 1995) or the variational equations of a contact phase, and a sticking
phase's projection.  The spectrum of the stroboscopic map is then the QR method of Benettin et
al. (Meccanica 15, 1980) on the products of those monodromies along the attractor::

    Q_0 = I,   M_k Q_{k-1} = Q_k R_k,   lambda_i = sum_k ln |R_k,ii| / (K n T)

(``K`` shots of ``n`` forcing periods ``T = 2 pi / Omega`` each), per unit of the problem's own
time (nondimensional for the SDOF, the kernel's for the beam).  Nothing here is specific to a
fidelity or a law: every model with a shooting problem has its spectrum.  The sum of the
exponents is exact at every shot (``ln |det M| = sum ln |R_ii|``): the Liouville check of the
tests.  A sticking phase maps the state onto the stop, so ``M`` is singular there and one
exponent is ``-inf`` (the dimension lost), reported as it is.

The error estimate is the standard error of the record's exponents by non-overlapping batch
means (Schmeiser, Oper. Res. 30, 1982: 10 to 30 batches): the ``K`` shots are cut into ``a =
min(10, K // 2)`` batches of ``b = K // a`` consecutive shots (the oldest ``K - a b`` left out),
each batch gives its own spectrum ``lambda^(j)``, and ``e_i = std_j(lambda_i^(j), ddof=1) /
sqrt(a)``: the standard deviation of the whole record's ``lambda_i`` over independent records of
the same length, honest when a batch is much longer than the correlation time of the local
stretching rates.  On the two-sided Fig. 7 scene those rates alternate (autocorrelation -0.46,
+0.30, -0.37, ... at Omega = 2.38; a period-4 pattern at 2.40), so short batches overstate the
error by their ends' share: against the scatter of 40 independent 2000-period records the ratio
was 1.5 with ``sqrt(K)`` batches and 1.2 with 10 (both frequencies), where Geyer's initial
sequence estimator gave 0.95 and 0.37; the 10 batches err on the safe side.  Half the difference
of the record's two halves, used before, has one degree of freedom and was 3-14 times too small.  A chaotic attractor's exponents converge like ``1 / sqrt(K)``; a periodic
orbit's like ``1 / K`` (the QR vectors' alignment), a bias the batch means do not see: for a
periodic orbit the exact exponents are its Floquet exponents ``ln |mu_i| / (n T)``
(:func:`floquet_exponents`), which the framework reports, keeping the QR estimate as a check.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

TWO_PI = 2.0 * math.pi


@dataclass
class LyapunovSpectrum:
    """The Lyapunov spectrum of one attractor of the stroboscopic map.

    Attributes
    ----------
    exponents : ndarray, shape (d,)
        ``lambda_1 >= ... >= lambda_d`` per unit of the problem's time (nondimensional time of
        the model; ``-inf`` for a direction a sticking phase collapses); NaN when not ``ok``.
    error : ndarray, shape (d,)
        Standard error of ``exponents`` by batch means over the shots (module docstring; same
        unit); 0 for an exponent that is ``-inf``, NaN with fewer than 2 batches.
    dof : int
        Degrees of freedom of ``error``: the number of batches less one.
    status : str
        ``"ok"`` or ``"failed"`` (a shot failed: its message says why).
    message : str
    shots, periods_per_shot : int
        ``K`` shots of ``n`` forcing periods were averaged (after the transient).
    time : float
        ``K n T``, the averaging time.
    impacts : int
        Impacts (contacts) over the averaging time.
    final_state : ndarray, shape (d,)
        The state after the last shot (at forcing phase 0).
    """

    exponents: np.ndarray
    error: np.ndarray
    status: str = "ok"
    message: str = ""
    shots: int = 0
    periods_per_shot: int = 1
    time: float = 0.0
    impacts: int = 0
    final_state: np.ndarray = field(default_factory=lambda: np.zeros(0))
    dof: int = 0

    @property
    def largest(self) -> float:
        """``lambda_1``."""
        return float(self.exponents[0]) if self.exponents.size else math.nan


def _log_diag(R: np.ndarray) -> np.ndarray:
    d = np.abs(np.diag(R))
    with np.errstate(divide="ignore"):
        return np.log(d)


def lyapunov_spectrum(problem, x0, p: float, shots: int, transient: int = 0, n: int = 1) -> LyapunovSpectrum:
    """Lyapunov spectrum of the attractor reached from ``x0`` (module docstring).

    Parameters
    ----------
    problem : shooting problem
        Any object of the contract of :mod:`vibeam.models.core.periodic` (e.g.
        :func:`vibeam.models.shooting_problem` of a model).
    x0 : array_like, shape (d,)
        State at forcing phase 0 (the problem's state, nondimensional or kernel units).
    p : float
        The problem's parameter value (e.g. ``Omega``).
    shots : int
        ``K >= 2`` shots averaged.
    transient : int
        Shots taken first and discarded (the orbit settles onto its attractor).
    n : int
        Forcing periods per shot.

    Returns
    -------
    LyapunovSpectrum

    Raises
    ------
    ValueError
        If ``shots < 2``, ``transient < 0`` or ``n < 1``.
    """
    shots, transient, n = int(shots), int(transient), int(n)
    if shots < 2 or transient < 0 or n < 1:
        raise ValueError(f"lyapunov_spectrum: shots = {shots} must be >= 2, transient = {transient} >= 0 "
                         f"and n = {n} >= 1")
    x = np.asarray(x0, float).copy()
    d = x.size
    nan = np.full(d, np.nan)

    def failed(s, k):
        return LyapunovSpectrum(nan, nan.copy(), "failed", f"shot {k}: {s.status}: {s.message}", k, n,
                                final_state=x)

    for k in range(transient):
        s = problem.shot(x, p, n)
        if s.status != "ok":
            return failed(s, k)
        x = np.asarray(s.x, float)
    Q = np.eye(d)
    logs = np.zeros((shots, d))
    times = np.zeros(shots)
    impacts = 0
    for k in range(shots):
        s = problem.shot(x, p, n)
        if s.status != "ok" or not np.all(np.isfinite(s.M)):
            return failed(s, transient + k)
        Q, R = np.linalg.qr(s.M @ Q)
        logs[k] = _log_diag(R)
        times[k] = n * TWO_PI / float(s.Omega)
        impacts += int(np.size(s.impact_times))
        x = np.asarray(s.x, float)
    total = float(times.sum())
    with np.errstate(invalid="ignore"):
        lam = logs.sum(axis=0) / total
    err, dof = batch_error(logs, times)
    order = np.argsort(-lam, kind="stable")
    return LyapunovSpectrum(lam[order], err[order], "ok", "", shots, n, total, impacts, x, dof)


#: batches of the error estimate (module docstring)
BATCHES = 10


def batch_error(logs, times) -> tuple[np.ndarray, int]:
    """Standard error of the exponents ``sum(logs) / sum(times)`` by non-overlapping batch means.

    Parameters
    ----------
    logs : ndarray, shape (K, d)
        ``ln |R_k,ii|`` of each shot (``-inf`` where a direction collapsed).
    times : ndarray, shape (K,)
        Each shot's duration (the problem's time unit).

    Returns
    -------
    (ndarray, int)
        ``e`` (shape (d,), the exponents' unit): the standard deviation of the batches' own
        exponents over the square root of their number (module docstring), 0 where an exponent
        is ``-inf``; and its degrees of freedom (batches less one).  NaN and 0 with fewer than
        two batches (``K < 4``).
    """
    logs = np.asarray(logs, float)
    times = np.asarray(times, float)
    K, d = logs.shape
    a = min(BATCHES, K // 2)
    if a < 2:
        return np.full(d, np.nan), 0
    b = K // a
    L = logs[K - a * b:].reshape(a, b, d).sum(axis=1)
    T = times[K - a * b:].reshape(a, b).sum(axis=1)
    with np.errstate(invalid="ignore"):
        lam_j = L / T[:, None]
        err = np.std(lam_j, axis=0, ddof=1) / math.sqrt(a)
    err[~np.isfinite(err)] = 0.0
    return err, a - 1


def floquet_exponents(mu, n: int, Omega: float) -> np.ndarray:
    """The Lyapunov exponents of a period-``n`` orbit of the stroboscopic map: ``ln |mu_i| /
    (n T)`` of its Floquet multipliers ``mu`` (the eigenvalues of the monodromy of ``P^n``, the
    saltation matrices included), ``T = 2 pi / Omega``, largest first (``-inf`` for a zero
    multiplier, a direction a sticking phase collapses).

    Parameters
    ----------
    mu : array_like, shape (d,)
        Floquet multipliers (complex allowed).
    n : int
        Forcing periods of the orbit (>= 1).
    Omega : float
        Forcing frequency (the problem's units).

    Returns
    -------
    ndarray, shape (d,)
        Per unit of the problem's time, as :func:`lyapunov_spectrum`.
    """
    with np.errstate(divide="ignore"):
        lam = np.log(np.abs(np.asarray(mu, complex))) / (int(n) * TWO_PI / float(Omega))
    return -np.sort(-lam.real)


def classify_spectrum(exponents, error, periodic: bool = False, floor: float = 1e-6) -> str:
    """The class of an attractor from its Lyapunov spectrum (issue 21).

    ``"periodic"`` when the orbit is known to be periodic; else ``"chaotic"`` when ``lambda_1 >
    max(3 e_1, floor)``; ``"quasi_periodic"`` when ``|lambda_1| <= max(3 e_1, floor)`` and (with
    two or more exponents) ``lambda_2 < -max(3 e_2, floor)``; ``"non_periodic"`` otherwise (e.g.
    ``lambda_1 < 0`` on a record that does not repeat within the period test: a long period or a
    slow transient), and ``""`` when the exponents are not finite numbers (not computed).  ``e_i``
    are the error estimates of :class:`LyapunovSpectrum` (same units as the exponents); ``floor``
    keeps a round-off-sized exponent from being called chaotic.
    """
    if periodic:
        return "periodic"
    lam = np.asarray(exponents, float)
    err = np.asarray(error, float)
    if lam.size == 0 or not np.isfinite(lam[0]) or not np.isfinite(err[0]):
        return ""
    t1 = max(3.0 * float(err[0]), floor)
    if lam[0] > t1:
        return "chaotic"
    if abs(lam[0]) <= t1:
        if lam.size < 2:
            return "quasi_periodic"
        t2 = max(3.0 * float(err[1]) if np.isfinite(err[1]) else 0.0, floor)
        if lam[1] < -t2:
            return "quasi_periodic"
    return "non_periodic"
