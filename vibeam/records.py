"""What a time-domain method hands to the sweep for one forcing frequency, and
the one place where it is turned into the per-point outputs of an FRC.

Every time-domain method of every fidelity returns a :class:`Trajectory`;
:func:`summarize` computes the amplitude (paper Sec. 4.1), period-n from the
stroboscopic map, impacts per period, harmonics (paper Fig. 20), so that those
definitions exist once.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

STATUSES = ("ok", "chatter", "sticking", "failed")
HARMONICS = 6  # 0 .. 5 Omega
PERIOD_MAX = 8


@dataclass
class Trajectory:
    """Recorded steady-state window of one frequency point (nondimensional).

    Attributes
    ----------
    Omega : float
        Forcing frequency over the natural frequency.
    samples : ndarray, shape (n_record * samples_per_period, 2)
        ``(q, q')`` at forcing phases ``2 pi j / samples_per_period`` of each
        recorded period, starting at phase 0 of the first recorded period.
    samples_per_period : int
        Samples per forcing period.
    impact_times : ndarray, shape (k,)
        Impact instants measured from the start of the recording.
    impact_velocities : ndarray, shape (k,)
        Pre-impact velocities ``q'(t-) >= 0`` of those impacts.
    n_impacts : int
        Number of impacts in the recorded window (may exceed ``k`` when the
        buffer was capped).
    q_min, q_max : float
        Extremes of ``q`` over the recorded window (exact where the method can
        locate them, otherwise from the samples).
    status : str
        One of ``ok``, ``chatter``, ``sticking``, ``failed``.
    message : str
        Human-readable detail (empty when ok).
    final_state : ndarray, shape (n_state,)
        State at the end of the recording (phase 0), used to start the next
        point of a continuation sweep.
    extra : dict
        Method-specific per-point outputs (e.g. per-mode amplitudes), each a
        float or an ndarray of fixed shape across points.
    """

    Omega: float
    samples: np.ndarray
    samples_per_period: int
    impact_times: np.ndarray
    impact_velocities: np.ndarray
    n_impacts: int
    q_min: float
    q_max: float
    status: str = "ok"
    message: str = ""
    final_state: np.ndarray = field(default_factory=lambda: np.zeros(2))
    extra: dict = field(default_factory=dict)

    @property
    def n_record(self) -> int:
        return self.samples.shape[0] // self.samples_per_period

    @property
    def strobe(self) -> np.ndarray:
        """Stroboscopic (Poincare) samples at phase 0, shape (n_record, 2)."""
        return self.samples[:: self.samples_per_period]

    @property
    def t(self) -> np.ndarray:
        """Times of ``samples`` from the start of the recording (the time base of
        ``impact_times``): ``j T / samples_per_period`` with ``T = 2 pi / Omega``, shape (n,),
        nondimensional (natural time: 2 pi = one natural period)."""
        return np.arange(self.samples.shape[0]) * (2.0 * np.pi / self.Omega / self.samples_per_period)


def period_of_strobe(strobe: np.ndarray, scale: float, rtol: float = 1e-5) -> int:
    """Smallest n in 1..8 with ``strobe[k + n] == strobe[k]`` over the window.

    Parameters
    ----------
    strobe : ndarray, shape (m, 2)
        Stroboscopic samples ``(q, q')``.
    scale : float
        Size of the orbit; points closer than ``rtol * scale`` are equal.
    rtol : float
        Relative tolerance.

    Returns
    -------
    int
        The period n, or 0 when no n <= 8 repeats (not periodic within 8).
    """
    m = strobe.shape[0]
    tol = rtol * max(scale, 1e-300)
    for n in range(1, PERIOD_MAX + 1):
        if m <= n:
            break
        d = np.max(np.abs(strobe[n:] - strobe[:-n]))
        if d <= tol:
            return n
    return 0


def harmonic_amplitudes(q: np.ndarray, samples_per_period: int, n_harmonics: int = HARMONICS) -> np.ndarray:
    """Amplitudes of the harmonics ``0, Omega, ..., (n-1) Omega`` of a periodic record.

    Parameters
    ----------
    q : ndarray, shape (n_record * samples_per_period,)
        Uniform samples over whole forcing periods.
    samples_per_period : int
        Samples per forcing period (must exceed ``2 (n_harmonics - 1)``).

    Returns
    -------
    ndarray, shape (n_harmonics,)
        Mean value (k = 0) and single-sided amplitudes ``2 |X_k| / N`` (k >= 1),
        in the units of ``q``.
    """
    # bin k n_rec of the record's DFT equals bin k of the DFT of the period-averaged record
    # (exp(-2 pi i k n / spp) depends on n mod spp only), so one FFT of length spp suffices
    # whatever the number of periods (an FFT of a length with a large prime factor is slow)
    spp = samples_per_period
    n_rec = q.shape[0] // spp
    X = np.fft.rfft(q[: n_rec * spp].reshape(n_rec, spp).mean(axis=0)) / spp
    out = np.full(n_harmonics, np.nan)
    k = min(n_harmonics, X.shape[0])
    out[:k] = np.abs(X[:k]) * np.r_[1.0, np.full(k - 1, 2.0)]
    return out


def summarize(traj: Trajectory, Delta: float, period_rtol: float = 1e-5) -> dict:
    """Per-point FRC outputs of a trajectory (all nondimensional).

    Returns a dict with ``amplitude`` (``Q = Delta - min q``, paper Sec. 4.1),
    ``q_max``, ``q_min``, ``period`` (1..8, 0 = not periodic within 8, -1 = no
    impact in the window), ``impacts_per_period``, ``impact_velocity`` (mean
    pre-impact velocity, NaN without impacts), ``strobe`` (n_record, 2),
    ``harmonics`` (6,), ``status`` and ``message``.
    """
    n_rec = traj.n_record
    if traj.status == "failed":
        nan = np.nan
        return dict(amplitude=nan, q_max=nan, q_min=nan, period=0, impacts_per_period=nan,
                    impact_velocity=nan, strobe=np.full((n_rec, 2), nan),
                    harmonics=np.full(HARMONICS, nan), status=traj.status, message=traj.message)
    q = traj.samples[:, 0]
    scale = max(traj.q_max - traj.q_min, np.max(np.abs(traj.samples[:, 1])), 1e-300)
    if traj.n_impacts == 0:
        period = -1
    else:
        period = period_of_strobe(traj.strobe, scale, period_rtol)
    iv = traj.impact_velocities
    return dict(
        amplitude=Delta - traj.q_min,
        q_max=traj.q_max,
        q_min=traj.q_min,
        period=period,
        impacts_per_period=traj.n_impacts / n_rec if n_rec else np.nan,
        impact_velocity=float(np.mean(iv)) if iv.size else np.nan,
        strobe=traj.strobe.copy(),
        harmonics=harmonic_amplitudes(q, traj.samples_per_period),
        status=traj.status,
        message=traj.message,
    )
