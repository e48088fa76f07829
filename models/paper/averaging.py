"""Averaging of the SDOF impact oscillator after Zhuravlev's transformation (paper Sec. 4.1).

With ``q = Delta - |z|`` (paper Eq. 4) the unfolded coordinate obeys paper
Eqs. 16-17.  For near-elastic impacts (``R ~ 1``) and small ``beta``, ``B``
and ``Delta`` the Van der Pol substitution ``z = Q sin(phi)``,
``z' = Q cos(phi)``, ``phi = Omega t / (2k) + theta`` (Eq. 22) and first-order
averaging give, near the resonance ``Omega ~ 2k``, the stationary amplitudes as
the roots of (Eqs. 18-21)::

    P(Q) = g2 Q^2 + g1 Q + g0 = 0
    g2 = pi^2 (sigma_k^2 + beta_k^2),  g1 = 4 pi Delta sigma_k,
    g0 = 4 (Delta^2 - (B_k Omega^2)^2),  B_k = B / (4 k^2 - 1),
    sigma_k = Omega / (2k) - 1,  beta_k = beta_eff / (2k),  beta_eff = beta + (1 - R) / pi.

The amplitude ``Q`` of ``z`` equals ``Delta - min q`` (Eq. 4), the measure the
exact solvers report.  Everything is nondimensional; all functions accept
``Omega`` as a scalar or an array and broadcast.

Phase (Eq. 23).  The stationary averaged equations are
``pi beta_k Q = -2 B_k Omega^2 cos(psi)`` and
``pi sigma_k Q + 2 Delta = 2 B_k Omega^2 sin(psi)`` with ``psi = 2 k theta``,
so ``cos(psi) < 0`` always.  The paper prints ``theta = arctan(...)/(2k)``,
which returns the branch with ``cos(psi) > 0``, i.e. ``psi`` off by ``pi``.
:func:`phase` uses the quadrant-correct ``arctan2``; ``phase(printed=True)``
returns the expression as printed.  Impacts (``z = 0``) then occur at the
forcing phase ``Omega t = -psi (mod 2 pi)``.
"""
from __future__ import annotations

import math

import numpy as np

from ..scene import one_mode


def _coefficients(Omega, beta, B, R, Delta, k):
    Omega = np.asarray(Omega, dtype=float)
    sigma = Omega / (2.0 * k) - 1.0
    beta_eff = beta + (1.0 - R) / math.pi
    beta_k = beta_eff / (2.0 * k)
    Bk = B / (4.0 * k * k - 1.0)
    g2 = math.pi**2 * (sigma**2 + beta_k**2)
    g1 = 4.0 * math.pi * Delta * sigma
    g0 = 4.0 * (Delta**2 - (Bk * Omega**2) ** 2)
    return sigma, beta_k, Bk, g2, g1, g0


def _check_k(k):
    if int(k) != k or k < 1:
        raise ValueError(f"resonance index k must be a positive integer, got {k!r}")
    return int(k)


def polynomial_coefficients(Omega, beta, B, R, Delta, k=1):
    """Coefficients ``(g2, g1, g0)`` of the frequency-amplitude polynomial (Eqs. 18-21).

    Parameters
    ----------
    Omega : float or ndarray, shape (m,)
        Forcing frequency (nondimensional, near ``2k``).
    beta, B, R, Delta : float
        Damping ratio, forcing amplitude, coefficient of restitution, gap.
    k : int, optional
        Resonance index (``Omega ~ 2k``).

    Returns
    -------
    g2, g1, g0 : ndarray, shape of ``Omega``

    Raises
    ------
    ValueError
        If ``k`` is not a positive integer.
    """
    k = _check_k(k)
    _, _, _, g2, g1, g0 = _coefficients(Omega, beta, B, R, Delta, k)
    return g2, g1, g0


def P_of_Q(Q, Omega, beta, B, R, Delta, k=1):
    """``P(Q) = g2 Q^2 + g1 Q + g0`` (Eq. 18); broadcasts ``Q`` against ``Omega``."""
    g2, g1, g0 = polynomial_coefficients(Omega, beta, B, R, Delta, k)
    Q = np.asarray(Q, dtype=float)
    return g2 * Q * Q + g1 * Q + g0


def discriminant(Omega, beta, B, R, Delta, k=1):
    """``D[P] = g1^2 - 4 g0 g2 = h2 Delta^2 + h0`` (Eqs. 25-26), shape of ``Omega``."""
    g2, g1, g0 = polynomial_coefficients(Omega, beta, B, R, Delta, k)
    return g1 * g1 - 4.0 * g0 * g2


def amplitudes(Omega, beta, B, R, Delta, k=1):
    """Both roots of ``P(Q) = 0`` (Eq. 18).

    Returns
    -------
    upper, lower : ndarray, shape of ``Omega``
        ``(-g1 +- sqrt(D)) / (2 g2)``; NaN where the root is not real and
        strictly positive.
    """
    g2, g1, g0 = polynomial_coefficients(Omega, beta, B, R, Delta, k)
    D = g1 * g1 - 4.0 * g0 * g2
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.where(D >= 0.0, D, np.nan))
        upper = (-g1 + sq) / (2.0 * g2)
        # lower root in the cancellation-free form 2 g0 / (-g1 - sqrt(D))
        lower = np.where(g1 < 0, 2.0 * g0 / (-g1 + sq), (-g1 - sq) / (2.0 * g2))
    upper = np.where(upper > 0.0, upper, np.nan)
    lower = np.where(lower > 0.0, lower, np.nan)
    return upper, lower


def phase(Q, Omega, beta, B, R, Delta, k=1, printed=False):
    """Phase ``theta`` of ``phi = Omega t / (2k) + theta`` (Eq. 23), rad.

    Parameters
    ----------
    Q : float or ndarray
        Amplitude (a root of Eq. 18), broadcast against ``Omega``.
    printed : bool, optional
        If True, evaluate Eq. 23 as printed (``arctan``, range
        ``(-pi/2, pi/2) / (2k)``); otherwise the quadrant-correct
        ``arctan2(pi sigma_k Q + 2 Delta, -pi beta_k Q) / (2k)``.

    Returns
    -------
    ndarray
        ``theta`` (NaN where ``Q`` is NaN).
    """
    k = _check_k(k)
    sigma, beta_k, _, _, _, _ = _coefficients(Omega, beta, B, R, Delta, k)
    Q = np.asarray(Q, dtype=float)
    num = math.pi * sigma * Q + 2.0 * Delta
    den = -math.pi * beta_k * Q
    with np.errstate(invalid="ignore", divide="ignore"):
        if printed:
            return np.arctan(num / den) / (2.0 * k)
        return np.arctan2(num, den) / (2.0 * k)


def Q_star(Omega, beta, B, R, Delta, k=1):
    """Minimum point of ``P`` and lower stability bound of ``Q`` (Eq. 24).

    Returns ``-g1 / (2 g2) = -2 sigma_k Delta / (pi (sigma_k^2 + beta_k^2))``
    where positive, NaN elsewhere (shape of ``Omega``).
    """
    g2, g1, _ = polynomial_coefficients(Omega, beta, B, R, Delta, k)
    with np.errstate(divide="ignore", invalid="ignore"):    # g2 = g1 = 0 undamped with R = 1: NaN
        qs = -g1 / (2.0 * g2)
    return np.where(qs > 0.0, qs, np.nan)


def Delta_max(Omega, beta, B, R, k=1):
    """Largest ``|Delta|`` with real amplitudes, ``B_k Omega^2 sqrt((sigma_k/beta_k)^2 + 1)`` (Eq. 27).

    ``beta_k`` includes the impact loss ``(1 - R)/pi`` (Eq. 21); for
    ``beta = 0, R = 1`` it is infinite.  Shape of ``Omega``.
    """
    k = _check_k(k)
    sigma, beta_k, Bk, _, _, _ = _coefficients(Omega, beta, B, R, 0.0, k)
    with np.errstate(divide="ignore", invalid="ignore"):    # 0 / 0 at resonance: NaN
        return Bk * np.asarray(Omega, float) ** 2 * np.sqrt((sigma / beta_k) ** 2 + 1.0)


def solve(Omega, beta, B, R, Delta, k=1):
    """All averaging outputs near resonance ``Omega ~ 2k`` (Eqs. 18-27), vectorised.

    Parameters
    ----------
    Omega : float or ndarray, shape (m,)
        Forcing frequency (nondimensional).
    beta, B, R, Delta : float
        Damping ratio, forcing amplitude, coefficient of restitution, gap.
    k : int, optional
        Resonance index, ``k >= 1`` (the paper uses 1, 2, 3).

    Returns
    -------
    dict of ndarray, each of the shape of ``Omega``
        ``amplitude`` (upper root), ``amplitude_lower``, ``theta`` and
        ``theta_lower`` (Eq. 23, quadrant-correct), ``impact_phase``
        (forcing phase ``-2k theta mod 2 pi`` of the impacts of the upper
        branch), ``stable`` (upper branch: real and ``Q > Q*``, Eq. 24),
        ``stable_lower`` (always False: the lower branch is unstable),
        ``Q_star``, ``Delta_max`` (Eq. 27), ``discriminant`` (Eq. 25).

    Raises
    ------
    ValueError
        If ``k`` is not a positive integer.
    """
    k = _check_k(k)
    up, lo = amplitudes(Omega, beta, B, R, Delta, k)
    qs = Q_star(Omega, beta, B, R, Delta, k)
    th = phase(up, Omega, beta, B, R, Delta, k)
    th_lo = phase(lo, Omega, beta, B, R, Delta, k)
    with np.errstate(invalid="ignore"):
        stable = np.isfinite(up) & (np.isnan(qs) | (up > qs))
    return dict(amplitude=up, amplitude_lower=lo, theta=th, theta_lower=th_lo,
                impact_phase=np.mod(-2.0 * k * th, 2.0 * math.pi),
                stable=stable, stable_lower=np.zeros_like(stable, dtype=bool),
                Q_star=qs, Delta_max=Delta_max(Omega, beta, B, R, k),
                discriminant=discriminant(Omega, beta, B, R, Delta, k))


def degenerate(Omega, beta, B, R, Delta, k=1) -> str:
    """Why the averaged equations (Eqs. 18-21) say nothing at this point, or ''.

    ``P(Q) = g2 Q^2 + g1 Q + g0`` with ``g2 = pi^2 (sigma_k^2 + beta_k^2)``: at
    ``sigma_k = 0`` (``Omega = 2k``) with ``beta_k = 0`` (``beta = 0``, ``R = 1``: no damping
    and no impact loss) ``g2 = 0`` and the stationary amplitude is unbounded -- the roots are
    ``0/0`` (NaN), which is not the "no impacting solution" a NaN amplitude otherwise means.
    Coefficients that are not finite (an overflow of ``(B_k Omega^2)^2`` or ``Delta^2``) say
    nothing either.
    """
    g2, g1, g0 = polynomial_coefficients(Omega, beta, B, R, Delta, k)
    if not (np.isfinite(g2) and np.isfinite(g1) and np.isfinite(g0)):
        return (f"averaging: the coefficients of P(Q) are not finite at Omega = {Omega:g} (g2 = {float(g2):g}, "
                f"g1 = {float(g1):g}, g0 = {float(g0):g})")
    if g2 == 0.0:
        beta_eff = beta + (1.0 - R) / math.pi
        return (f"averaging: no bounded amplitude at Omega = {Omega:g} = 2k (k = {k}) with beta + (1 - R)/pi = "
                f"{beta_eff:g}: without damping or impact loss P(Q) degenerates (g2 = 0; undamped resonance)")
    return ""


class AveragingSolver:
    """Method ``averaging``: first-order averaging near ``Omega ~ 2k`` (paper Sec. 4.1).

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
        The one-mode oscillator (:func:`vibeam.models.scene.one_mode`: ``beta``, ``B``, the stop's
        ``Delta`` and its law's ``R``).
    k : int, optional
        Resonance index (``Omega ~ 2k``).

    Raises
    ------
    ValueError
        If ``k`` is not a positive integer or the scene not the one-mode oscillator.
    """

    name = "averaging"
    time_domain = False

    def __init__(self, scene, k: int = 1):
        self.scene = scene
        self.one = one_mode(scene, "method 'averaging'")
        self.k = _check_k(k)

    def settings(self) -> dict:
        return dict(k=self.k)

    def point(self, Omega: float, state0, n_transient: int, n_record: int,
              samples_per_period: int = 64) -> dict:
        """Averaged stationary solution at one frequency.

        ``state0``, ``n_transient``, ``n_record`` and ``samples_per_period`` are
        accepted for interface compatibility and ignored.

        Returns
        -------
        dict
            ``amplitude``, ``amplitude_lower``, ``theta``, ``impact_phase``
            (float, NaN if none), ``stable`` (bool, upper branch), ``Q_star``,
            ``Delta_max``, ``period`` (``k`` if a real solution exists, else
            -1: ``q = Delta - |Q sin(Omega t/(2k) + theta)|`` repeats after
            ``k`` forcing periods, so ``k = 1`` gives 1), ``status`` ``"ok"``,
            ``message`` ``""``; ``status`` ``"failed"`` with the reason where the averaged
            equations are degenerate (:func:`degenerate`).
        """
        m = self.one
        R = m.stops[0].law.R
        why = degenerate(float(Omega), m.beta, m.B, R, m.Delta, self.k)
        if why:
            nan = float("nan")
            return dict(amplitude=nan, amplitude_lower=nan, theta=nan, impact_phase=nan, stable=False,
                        Q_star=nan, Delta_max=nan, period=0, status="failed", message=why)
        r = solve(float(Omega), m.beta, m.B, R, m.Delta, self.k)
        up = float(r["amplitude"])
        return dict(amplitude=up, amplitude_lower=float(r["amplitude_lower"]),
                    theta=float(r["theta"]), impact_phase=float(r["impact_phase"]),
                    stable=bool(r["stable"]), Q_star=float(r["Q_star"]),
                    Delta_max=float(r["Delta_max"]),
                    period=self.k if np.isfinite(up) else -1, status="ok", message="")


def averaging_guess(om, Omega):
    """Initial guess ``(phi, v)`` from averaging (k = 1): impact phase ``-psi``, ``v ~ Q``; ``om`` the
    scene's :func:`vibeam.models.scene.one_mode`."""
    r = solve(float(Omega), om.beta, om.B, om.stops[0].law.R, om.Delta, 1)
    Q = float(r["amplitude"])
    if not np.isfinite(Q):
        return None
    return np.array([float(r["impact_phase"]), Q])
