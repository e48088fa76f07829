"""Lyapunov exponents of the stroboscopic map, on the one shooting-problem contract.

A shooting problem (:mod:`vibeam.models.periodic`: ``shot(x0, p, n)`` returns ``P^n(x0)`` and
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

The error estimate is half the difference between the spectra of the record's two halves: a
spectrum that is still drifting shows it, a converged one gives the sampling error of the
finite record (a chaotic attractor's exponents converge like ``1 / sqrt(K)``; a periodic
orbit's like ``1 / K``, with ``ln cond`` of the monodromy's eigenvectors over the time).
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
        Half the difference between the two halves' spectra (same unit).
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
        Any object of the contract of :mod:`vibeam.models.periodic` (e.g.
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
    half = shots // 2
    sums = [np.zeros(d), np.zeros(d)]
    times = [0.0, 0.0]
    impacts = 0
    for k in range(shots):
        s = problem.shot(x, p, n)
        if s.status != "ok" or not np.all(np.isfinite(s.M)):
            return failed(s, transient + k)
        Q, R = np.linalg.qr(s.M @ Q)
        h = 0 if k < half else 1
        sums[h] += _log_diag(R)
        times[h] += n * TWO_PI / float(s.Omega)
        impacts += int(np.size(s.impact_times))
        x = np.asarray(s.x, float)
    total = times[0] + times[1]
    with np.errstate(invalid="ignore"):
        lam = (sums[0] + sums[1]) / total
        err = 0.5 * np.abs(sums[0] / times[0] - sums[1] / times[1])
    err[~np.isfinite(err)] = 0.0
    order = np.argsort(-lam, kind="stable")
    return LyapunovSpectrum(lam[order], err[order], "ok", "", shots, n, total, impacts, x)


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
