"""What a time-domain method of any fidelity hands back for one forcing frequency.

:class:`Trajectory` is produced by the models (every ``point`` of a time-domain solver
returns one) and consumed by the framework, whose one place for per-point outputs is
:func:`vibeam.records.summarize` (which re-exports this class).  It lives here so that
``vibeam.models`` does not import the framework.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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
    period_min : ndarray, shape (n_record,), optional
        Minimum of ``q`` over each recorded period, exact where the method
        locates the extremes (the event kernels); None: taken from the samples.
    status : str
        One of ``ok``, ``chatter``, ``sticking``, ``failed`` (``unsettled`` is
        decided by :func:`summarize`).
    message : str
        Human-readable detail (empty when ok).
    final_state : ndarray, shape (n_state,)
        State at the end of the recording (phase 0), used to start the next
        point of a continuation sweep.
    extra : dict
        Method-specific per-point outputs (e.g. per-mode amplitudes), each a
        float or an ndarray of fixed shape across points.
    Delta : float, optional
        Gap of this point when it differs from the scene's (an effect that
        moves the stop); the amplitude is measured from it.
    chatter_times : ndarray, shape (c,), optional
        Accumulation points of the chatter sequences of the record (times from
        its start; event kernels, :mod:`vibeam.models.contact_policy`).
    impact_stops : ndarray of int, shape (k,), optional
        Two-sided scenes: the stop of each impact (0 the upper stop at ``q = Delta``, 1 the
        lower one at ``q = -Delta_lower``); ``impact_velocities`` are then the normal
        pre-impact speeds ``|q'(t-)|``.  None: one stop.
    n_impacts_lower : int
        Impacts on the lower stop in the recorded window (of ``n_impacts``).
    contacts : ndarray, shape (k, 5), optional
        One row per recorded contact of a compliant stop (nondimensional, per unit
        effective mass): duration, peak contact force, largest penetration, energy
        lost (work done on the stop), entry velocity
        (:data:`vibeam.models.sdof_compliant.C_DURATION` ...); None for impulsive laws.
    contact_stops : ndarray of int, shape (k,), optional
        Two-sided scenes: the stop of each row of ``contacts`` (0 upper, 1 lower).  None: one
        stop, or rows in one-to-one order with ``impact_stops``.
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
    period_min: np.ndarray | None = None
    Delta: float | None = None
    chatter_times: np.ndarray | None = None
    impact_stops: np.ndarray | None = None
    n_impacts_lower: int = 0
    contacts: np.ndarray | None = None
    contact_stops: np.ndarray | None = None

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
