"""What a time-domain method of any fidelity hands back for one forcing frequency.

:class:`Trajectory` is produced by the models (every ``point`` of a time-domain solver
returns one) and consumed by the framework, whose one place for per-point outputs is
:func:`vibeam.engine.records.summarize` (which re-exports this class).  It lives here so that
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
        its start; event kernels, :mod:`vibeam.models.core.contact_policy`).
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
        (:data:`vibeam.models.core.integrator.C_DURATION` ...); None for impulsive laws.
    contact_stops : ndarray of int, shape (k,), optional
        Two-sided scenes: the stop of each row of ``contacts`` (0 upper, 1 lower).  None: one
        stop, or rows in one-to-one order with ``impact_stops``.
    incomplete : bool
        The call ran out of its work budget (the solver's ``max_steps_per_call``) before its
        periods were done; ``status`` is then ``failed`` and nothing else in it is valid.  It
        says that fewer periods per call may succeed: the sweep engine then repeats the call
        from the same state in two halves (:func:`vibeam.engine.sweep.simulate`).  A compiled kernel
        cannot be interrupted, so the budget is what bounds the time between its returns to
        Python (Ctrl-C, ``point_time_limit_s``).
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
    incomplete: bool = False

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


def call_budget(max_steps_per_period: int, n_periods: int, max_steps_per_call: int) -> tuple[int, bool]:
    """The step limit of one kernel call: the per-period guard times the periods, at most the
    solver's work budget of one call.

    Returns
    -------
    (int, bool)
        The limit to pass to the kernel, and whether it is the call's budget (then running out
        of it makes the trajectory ``incomplete``, not failed: fewer periods per call may fit).
    """
    per = int(max_steps_per_period) * max(int(n_periods), 1)
    return min(per, int(max_steps_per_call)), int(max_steps_per_call) < per


#: How :func:`concatenate` joins the ``extra`` outputs of consecutive pieces of one record:
#: ``"mean"`` weighted by each piece's recorded periods (shares of the window, per-period
#: rates), ``"max"``, ``"sum"``, ``"impacts"`` (a mean over impacts: weighted by each piece's
#: ``n_impacts``).  An array whose first axis runs over the samples is concatenated; any other
#: key keeps the first piece's value (a property of the point, e.g. the gap of an effect).
EXTRA_JOIN = {
    "stuck_fraction": "mean", "contact_fraction": "mean", "steps_per_period": "mean",
    "impulse_per_period": "mean",
    "contact_gap_max": "max", "mode_amplitudes": "max", "mode_contact_amplitudes": "max",
    "nfev": "sum", "impact_velocity_m_s": "impacts",
}
#: status of a joined record: the most severe of its pieces'
_SEVERITY = ("ok", "sticking", "chatter", "failed")


def concatenate(parts: list) -> Trajectory:
    """One record from consecutive pieces (each started from the previous one's final state).

    The sweep engine cuts a long record into calls of a bounded number of periods
    (:func:`vibeam.engine.sweep.simulate`) and joins them here: samples, impacts, contacts, the
    per-period minima and chatter times are concatenated (times shifted by the periods before
    each piece), counts added, extremes joined, ``final_state`` and ``Delta`` are the last
    piece's, the status is the most severe (``failed`` > ``chatter`` > ``sticking`` > ``ok``,
    messages joined), ``extra`` as :data:`EXTRA_JOIN`.

    Parameters
    ----------
    parts : list of Trajectory
        Pieces in time order, all with the same ``Omega`` and ``samples_per_period``.

    Returns
    -------
    Trajectory
    """
    if len(parts) == 1:
        return parts[0]
    first, last = parts[0], parts[-1]
    T = 2.0 * np.pi / first.Omega
    n_rec = [p.n_record for p in parts]
    t0 = np.cumsum([0] + n_rec[:-1]) * T

    def cat(name, shift=False):
        vals = [getattr(p, name) for p in parts]
        if any(v is None for v in vals):
            return None
        if shift:
            vals = [np.asarray(v, float) + o for v, o in zip(vals, t0)]
        return np.concatenate([np.asarray(v) for v in vals])

    n_s = [p.samples.shape[0] for p in parts]
    extra = {}
    for k, v0 in first.extra.items():
        vals = [p.extra.get(k, v0) for p in parts]
        rule = EXTRA_JOIN.get(k)
        if isinstance(v0, np.ndarray) and v0.ndim >= 1 and all(
                isinstance(v, np.ndarray) and v.shape[:1] == (n,) for v, n in zip(vals, n_s)) and n_s[0] > 0 \
                and rule is None:
            extra[k] = np.concatenate(vals)
        elif rule == "mean":
            w = np.asarray(n_rec, float)
            extra[k] = float(np.dot(w, np.asarray(vals, float)) / w.sum()) if w.sum() else v0
        elif rule == "max":
            extra[k] = np.max(np.asarray(vals, float), axis=0) if np.ndim(v0) else float(np.max(vals))
        elif rule == "sum":
            extra[k] = type(v0)(np.sum(vals)) if np.ndim(v0) == 0 else np.sum(vals, axis=0)
        elif rule == "impacts":
            w = np.asarray([p.n_impacts for p in parts], float)
            ok = w > 0
            extra[k] = float(np.dot(w[ok], np.asarray(vals, float)[ok]) / w[ok].sum()) if ok.any() else v0
        else:
            extra[k] = v0
    status = max((p.status for p in parts), key=lambda s: _SEVERITY.index(s) if s in _SEVERITY else 3)
    message = "; ".join(dict.fromkeys(p.message for p in parts if p.message))
    return Trajectory(
        Omega=first.Omega, samples=np.concatenate([p.samples for p in parts]),
        samples_per_period=first.samples_per_period,
        impact_times=cat("impact_times", shift=True), impact_velocities=cat("impact_velocities"),
        n_impacts=int(sum(p.n_impacts for p in parts)),
        q_min=float(min(p.q_min for p in parts)), q_max=float(max(p.q_max for p in parts)),
        status=status, message=message, final_state=last.final_state, extra=extra,
        period_min=cat("period_min"), Delta=last.Delta, chatter_times=cat("chatter_times", shift=True),
        impact_stops=cat("impact_stops"), n_impacts_lower=int(sum(p.n_impacts_lower for p in parts)),
        contacts=cat("contacts"), contact_stops=cat("contact_stops"),
        incomplete=any(p.incomplete for p in parts))
