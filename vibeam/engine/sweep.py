"""The one sweep engine: every fidelity and method goes through :func:`run_sweep`.

A sweep steps a solver over a grid of forcing frequencies.  With
``continuation`` (the default, as in a laboratory sweep) the state at the end
of one frequency starts the next, so ``up`` and ``down`` sweeps can land on
different branches of a multistable FRC; ``both`` runs the two directions as
independent chains.  Without continuation every point starts from the model's
initial state and all points are independent.  Independent chains or points
are submitted to a :class:`concurrent.futures.Executor` (a local process pool
by default; any executor with ``submit``, e.g. a dask.distributed client's,
can be dropped in).
"""
from __future__ import annotations

import concurrent.futures as cf
import ctypes
import math
import multiprocessing
import os
import signal
import threading
import time
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace

import numpy as np
import tqdm

from vibeam.io.objects import SweepResult  # noqa: F401 (re-exported)
from vibeam.io.outputs import MM_KEYS, UNITS  # noqa: F401 (re-exported)
from vibeam.case.schema import mass_law_tables
from vibeam.engine.records import (HARMONICS, PERIOD_MAX, SETTLED_MARGIN, STATUSES, amplitude_spread, period_minima, spread_agrees,
                                   summarize, transient_verdict, window_verdict)
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models.blas import one_blas_thread
from vibeam.models.orbits.continuation import start_point
from vibeam.models.interrupts import check as check_interrupt
from vibeam.models.interrupts import reraise_interrupt
from vibeam.models.orbits.lyapunov import classify_spectrum, floquet_exponents, lyapunov_spectrum
from vibeam.models.scene import outputs
from vibeam.models.trajectory import concatenate

# the per-point outputs and their units: vibeam.io.outputs (re-exported here)


@dataclass(frozen=True)
class Sweep:
    """How to sweep.

    Attributes
    ----------
    Omega : ndarray, shape (n,)
        Forcing frequencies (nondimensional), in increasing or any order; an
        ``up`` sweep visits them in increasing order, ``down`` in decreasing.
    direction : {'up', 'down', 'both'}
    transient_periods : int or 'auto'
        Forcing periods discarded per point; ``'auto'``: extended until the
        stroboscopic map settles, up to ``max_transient_periods`` (:func:`settle_transient`).
    record_periods : int
        Forcing periods recorded per point.
    statistics_periods : int
        Forcing periods over which the spread of a non-periodic point (period 0) is
        measured: its record is continued from its final state until the per-period
        amplitudes ``Q_k`` number ``statistics_periods`` (:func:`_statistics`; a
        look-ahead: the next point of a chain starts from the record's end).  At most
        ``record_periods``: no extension.
    max_transient_periods : int
        Most transient periods of ``'auto'``.
    settle : bool
        End the transient (of at most ``transient_periods``) as soon as the stroboscopic map has
        settled, after at least ``min_transient_periods`` (:func:`settle_early`).
    min_transient_periods : int
        The shortest transient of ``settle``.
    point_time_limit_s : float or None
        Wall time after which a point is ended as ``failed`` (checked between
        the calls of a time-domain point, each of bounded work: :func:`simulate`); None: no
        limit.
    samples_per_period : int
        Recorded samples per forcing period.
    continuation : bool
        Start each point from the previous point's final state.
    period_rtol : float
        Relative tolerance of the period-n test on the stroboscopic map.
    assess : tuple of callables
        Per-point assessments ``f(traj) -> dict`` applied to each recorded
        trajectory of a time-domain method (picklable: module-level functions
        or ``functools.partial``); their outputs join the point's datasets.
    lyapunov_shots : int
        0: no Lyapunov exponents; else the spectrum of the stroboscopic map over this many
        forcing periods from the point's final state, by the model's shooting problem
        (:func:`vibeam.models.orbits.lyapunov.lyapunov_spectrum`; time-domain methods): the point's
        ``lyapunov`` and ``lyapunov_error`` (batch-means standard error; NaN, with the reason in
        ``lyapunov_message``, where the shooting problem cannot follow the orbit).  At a periodic
        point the exponents are its orbit's Floquet exponents (exact; ``lyapunov_method`` =
        ``floquet``, error 0) and the QR estimate is kept in ``lyapunov_qr`` as a check.
    """

    Omega: np.ndarray
    direction: str = "up"
    transient_periods: int | str = 400
    record_periods: int = 64
    samples_per_period: int = 64
    statistics_periods: int = 0
    continuation: bool = True
    period_rtol: float = 1e-5
    assess: tuple = ()
    max_transient_periods: int = 10000
    point_time_limit_s: float | None = None
    lyapunov_shots: int = 0
    settle: bool = False
    min_transient_periods: int = 16

    @property
    def auto(self) -> bool:
        return isinstance(self.transient_periods, str)


class InlineExecutor(Executor):
    """Runs each submitted call at once in this process (``--jobs 1``)."""

    def submit(self, fn, /, *args, **kwargs):
        fut = Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except Exception as e:  # pragma: no cover - forwarded to the caller
            fut.set_exception(e)
        return fut


# periods of a time-domain point simulated per solver call when the solver does not say
# (``solver.chunk_periods``): a compiled kernel cannot be interrupted inside a call, so a long
# point is cut into calls between which Ctrl-C and the wall-time limit take effect
CHUNK_PERIODS = 1000
# a record of at most max(chunk_periods, RECORD_PIECE) periods is one call, together with the
# last transient chunk (as every record of the shipped cases); a longer record (or statistics
# window) is cut into calls of that many periods and joined (vibeam.models.trajectory.concatenate)
RECORD_PIECE = 256
# ``transient_periods = "auto"``: the first stage; each later stage is as long as everything before
AUTO_FIRST_STAGE = 100


class PointClock:
    """Wall time of one point for ``point_time_limit_s``, started when the first solver call
    returns (so a kernel's compilation or loading in a fresh worker does not count)."""

    def __init__(self):
        self.t0 = None

    def tick(self):
        if self.t0 is None:
            self.t0 = time.perf_counter()

    def over(self, limit) -> bool:
        return limit is not None and self.t0 is not None and time.perf_counter() - self.t0 > limit


def simulate(solver, Omega, state, n_transient: int, n_record: int, samples_per_period: int = 64,
             time_limit_s: float | None = None, clock: PointClock | None = None):
    """Trajectory of ``n_transient`` discarded and ``n_record`` recorded periods of a
    time-domain solver, in calls of bounded work: the one place where such a solver is called.

    * The transient is cut into calls of ``solver.chunk_periods`` periods (default
      :data:`CHUNK_PERIODS`), each started from the last state; the last transient chunk
      runs together with the record when the record has at most ``max(chunk_periods,``
      :data:`RECORD_PIECE` ``)`` periods (so a point of at most one chunk is one call).  A
      longer record is cut into calls of that many periods, joined by
      :func:`vibeam.models.trajectory.concatenate`.
    * A call that runs out of the solver's work budget (``traj.incomplete``: the kernel's
      ``max_steps_per_call``) is repeated from the same state in calls of half as many
      periods, for the rest of the point; one period that does not fit the budget fails.
      The budget depends on step counts only, so the cuts (and the numbers) do not depend on
      the machine.
    * Between calls the wall-time limit ``time_limit_s`` is checked (:class:`PointClock`) and
      Python runs its signal handlers (Ctrl-C, SIGTERM): every compiled call returns within
      the budget's time, whatever the scene.

    A call that fails, or the wall-time limit passing, ends the point: a failed trajectory
    with the record's shapes (NaN samples) and the reason is returned.

    Parameters
    ----------
    solver : object
        A time-domain solver (``point(Omega, state, n_transient, n_record, samples_per_period)``).
    Omega : float
        Forcing frequency (nondimensional).
    state : array_like or None
        Start state at forcing phase 0 (None: the model's rest state).
    n_transient, n_record : int
        Periods discarded, then recorded.
    samples_per_period : int
        Recorded samples per period.
    time_limit_s : float, optional
        Wall time after which the point fails (``[sweep] point_time_limit_s``).
    clock : PointClock, optional
        The point's clock (shared by the calls of one point).

    Returns
    -------
    vibeam.models.trajectory.Trajectory
    """
    chunk = max(1, int(getattr(solver, "chunk_periods", CHUNK_PERIODS) or CHUNK_PERIODS))
    piece = max(chunk, RECORD_PIECE)
    clock = clock if clock is not None else PointClock()
    spp = int(samples_per_period)
    n_tr, n_rec = int(n_transient), int(n_record)
    done_tr = done_rec = 0
    parts = []
    limit = None        # most periods per call after a call ran out of its work budget
    traj = None
    while True:
        left_tr, left_rec = n_tr - done_tr, n_rec - done_rec
        if limit is None:
            a, b = (chunk, 0) if left_tr > chunk else (left_tr, min(left_rec, piece))
        else:
            a = min(left_tr, limit)
            b = min(left_rec, limit - a)
        if a + b == 0 and traj is not None:
            break
        traj = solver.point(Omega, state, a, b, spp)
        check_interrupt()           # a signal whose exception the compiled call swallowed (issue 57)
        clock.tick()
        if traj.incomplete and a + b > 1:
            limit = max(1, (a + b) // 2)    # the same state again, in shorter calls
            if clock.over(time_limit_s):
                where = (f"{done_tr} of {n_tr} transient periods" if done_tr < n_tr else
                         f"the {n_tr} transient periods and {done_rec} of {n_rec} recorded periods")
                msg = f"point_time_limit_s = {time_limit_s:g} s passed after {where}"
                return _failed_record(replace(traj, status="failed", message=msg), n_rec, spp, None)
            continue
        if traj.status == "failed":
            if b == n_rec and done_rec == 0:
                return traj         # the call of the whole record: its own shapes
            return _failed_record(traj, n_rec, spp, done_tr if b == 0 else None, done_rec if b else None)
        state = traj.final_state
        done_tr += a
        done_rec += b
        if b:
            parts.append(traj)
        if done_tr == n_tr and done_rec == n_rec:
            break
        if clock.over(time_limit_s):
            where = (f"{done_tr} of {n_tr} transient periods" if done_tr < n_tr else
                     f"the {n_tr} transient periods and {done_rec} of {n_rec} recorded periods")
            msg = f"point_time_limit_s = {time_limit_s:g} s passed after {where}"
            return _failed_record(replace(traj, status="failed", message=msg), n_rec, spp, None)
    return concatenate(parts) if parts else traj


def _simulate(solver, Omega, state, n_transient: int, sweep: Sweep, clock: PointClock | None = None):
    """:func:`simulate` of ``n_transient`` and ``sweep.record_periods`` periods with the sweep's
    samples and wall-time limit."""
    return simulate(solver, Omega, state, n_transient, sweep.record_periods, sweep.samples_per_period,
                    sweep.point_time_limit_s, clock)


def _failed_record(traj, n_record: int, samples_per_period: int, done: int | None, done_rec: int | None = None):
    """A failed trajectory with the shapes of a record of ``n_record`` periods (NaN samples);
    ``done``: the transient periods before the failing chunk, ``done_rec``: the recorded ones
    (None: the message is kept as it is)."""
    n_s = n_record * samples_per_period
    n0 = traj.samples.shape[0]
    extra = {k: (np.full((n_s,) + v.shape[1:], np.nan)
                 if isinstance(v, np.ndarray) and v.ndim == 2 and v.shape[0] == n0 else v)
             for k, v in traj.extra.items()}
    msg = traj.message
    if done is not None:
        msg = f"{traj.message} (in the transient chunk after {done} periods)"
    elif done_rec is not None:
        msg = f"{traj.message} (in the record after {done_rec} recorded periods)"
    return replace(traj, samples=np.full((n_s, 2), np.nan), impact_times=np.zeros(0),
                   impact_velocities=np.zeros(0), n_impacts=0, q_min=np.nan, q_max=np.nan,
                   period_min=None, chatter_times=None, extra=extra, message=msg,
                   impact_stops=None if traj.impact_stops is None else np.zeros(0, np.int64),
                   contacts=None if traj.contacts is None else np.zeros((0,) + np.shape(traj.contacts)[1:]),
                   contact_stops=None if traj.contact_stops is None else np.zeros(0, np.int64),
                   n_impacts_lower=0)


def settle_transient(solver, Omega, state, sweep: Sweep, Delta: float, clock: PointClock):
    """``transient_periods = "auto"``: extend the transient until the stroboscopic map settles.

    Stages of transient periods, the first :data:`AUTO_FIRST_STAGE` long and
    each later one as long as all periods before it (so the work is at most
    about twice what was needed), each followed by a probe window of
    ``record_periods``.  The point has settled when the probe

    * repeats with some period n (1..8, or no impact) within
      ``SETTLED_MARGIN x period_rtol`` (:func:`vibeam.engine.records.transient_verdict`
      with a margin), or
    * is not periodic, at least ``max_transient_periods / 2`` periods have
      passed, and the spread of its per-period amplitude agrees with the
      previous probe's (:func:`vibeam.engine.records.spread_agrees`).  Transient chaos
      cannot be told from a chaotic attractor by its statistics (Fig. 8,
      Omega = 2.1 from rest: 2800 periods of chaos, then the no-impact orbit),
      so a non-periodic point is only accepted after that long.

    Otherwise the probe becomes transient and the next stage runs, up to
    ``max_transient_periods``; the last probe is the record.  A non-periodic
    record whose spread still disagrees with the previous probe's is marked
    ``unsettled``.

    Returns
    -------
    (Trajectory, int, str)
        The record, the transient periods before it, and why it has not
        settled ('' when it has, or when :func:`vibeam.engine.records.summarize`
        will say so itself).
    """
    max_tr = int(sweep.max_transient_periods)
    n_rec = sweep.record_periods
    stage = min(AUTO_FIRST_STAGE, max_tr)
    used = 0
    prev = None
    while True:
        traj = _simulate(solver, Omega, state, stage, sweep, clock)
        used += stage
        if traj.status == "failed":
            return traj, used, ""
        q = traj.samples[:, 0]
        scale = max(traj.q_max - traj.q_min, np.max(np.abs(traj.samples[:, 1])) if q.size else 0.0, 1e-300)
        period, why = transient_verdict(traj.strobe, scale, sweep.period_rtol, traj.n_impacts == 0,
                                        margin=SETTLED_MARGIN, Omega=float(Omega))
        spread = amplitude_spread((traj.Delta if traj.Delta is not None else Delta) - period_minima(traj))
        if period != 0 and not why:
            return traj, used, ""
        agrees = prev is not None and spread_agrees(prev, spread)
        if period == 0 and not why and agrees and used >= max_tr / 2:
            return traj, used, ""
        if used + n_rec >= max_tr:
            if period == 0 and not why and prev is not None and not agrees:
                return traj, used, (f"the spread of the per-period amplitude still changes after "
                                    f"max_transient_periods = {max_tr} (mean {prev['amplitude_mean']:.6g} "
                                    f"then {spread['amplitude_mean']:.6g})")
            return traj, used, ""
        limit = sweep.point_time_limit_s
        if clock.over(limit):
            msg = (f"point_time_limit_s = {limit:g} s passed after {used} transient periods "
                   f"(transient_periods = \"auto\")")
            return _failed_record(replace(traj, status="failed", message=msg), sweep.record_periods,
                                  sweep.samples_per_period, None), used, ""
        prev = spread
        state = traj.final_state
        used += n_rec
        stage = max(1, min(used, max_tr - used))


#: ``settle``: a period-n record whose returns grow by more than this factor from the first half of
#: the window to the second (above :data:`GROWTH_FLOOR` of the orbit) is leaving an unstable orbit,
#: not settled on a stable one
GROWTH_FACTOR = 2.0
GROWTH_FLOOR = 1e-13


def growing(strobe: np.ndarray, n: int, scale: float) -> bool:
    """Whether the period-``n`` returns of the stroboscopic map grow over the window (a start near an
    unstable orbit, e.g. the previous point's orbit past a period doubling): the largest return of
    the second half is above ``GROWTH_FLOOR`` of the orbit and ``GROWTH_FACTOR`` times that of the
    first half.

    Parameters
    ----------
    strobe : ndarray, shape (m, 2)
        Stroboscopic samples of the window.
    n : int
        The period found (>= 1).
    scale : float
        Size of the orbit.
    """
    m = strobe.shape[0]
    if n < 1 or m - n < 4:
        return False
    e = np.max(np.abs(strobe[n:] - strobe[:-n]), axis=1) / max(scale, 1e-300)
    h = e.shape[0] // 2
    first, last = float(np.max(e[:h])), float(np.max(e[h:]))
    return last > GROWTH_FLOOR and last > GROWTH_FACTOR * first


def settle_early(solver, Omega, state, sweep: Sweep, clock: PointClock):
    """``settle = true``: end the transient once the stroboscopic map has settled, after at least
    ``min_transient_periods`` and at most ``transient_periods`` (issue 60).

    After ``min_transient_periods`` periods, probe windows of ``record_periods`` periods follow,
    each integrated exactly as the transient is (the solver's ``transient_samples`` grid: the same
    numbers, bit for bit, as a call that records nothing).  The point has settled when a probe
    repeats with some period n (1..8, or no impact) within ``SETTLED_MARGIN x period_rtol`` of the
    orbit, its returns do not still shrink steadily (:func:`vibeam.engine.records.transient_verdict`,
    as ``"auto"`` decides) and do not grow (:func:`growing`: a start near an unstable orbit); the
    record is then simulated from the probe's start.  Otherwise the next probe follows while two
    windows are left; then the rest of the transient and the record are one call.  A point that
    does not settle (chaos, chatter at a grazing, a slow drift) therefore runs exactly the
    ``transient_periods`` of the fixed transient along the same integration; its record differs
    from the fixed one only where the kernel's results depend on where calls are cut (at round-off,
    which a chaotic motion amplifies: its record is then another sample of the same attractor).  A
    settled orbit's distance to the orbit is about its returns over ``1 - rho`` (``rho`` the
    largest Floquet multiplier), so its amplitude is settled to about ``1e-3 period_rtol /
    (1 - rho)``, within the record's own tolerance for the orbits of the shipped scenes.

    Returns
    -------
    (Trajectory, int)
        The record and the transient periods before it.
    """
    max_tr = int(sweep.transient_periods)
    n_rec = int(sweep.record_periods)
    spp = int(sweep.samples_per_period)
    spp_p = int(getattr(solver, "transient_samples", 0) or spp)
    limit = sweep.point_time_limit_s
    used = min(int(sweep.min_transient_periods), max_tr)     # transient periods before the probe
    if max_tr - used < n_rec:                 # no room for a probe: the fixed transient
        return _simulate(solver, Omega, state, max_tr, sweep, clock), max_tr
    start = state
    if used:
        pre = simulate(solver, Omega, state, used, 0, spp_p, limit, clock)
        if pre.status == "failed":
            return _failed_record(pre, n_rec, spp, 0), used
        start = pre.final_state
    while True:
        probe = simulate(solver, Omega, start, 0, n_rec, spp_p, limit, clock)
        if probe.status == "failed":
            return (probe if spp_p == spp else _failed_record(probe, n_rec, spp, used)), used
        scale = max(probe.q_max - probe.q_min, float(np.max(np.abs(probe.samples[:, 1]))) if probe.samples.size
                    else 0.0, 1e-300)
        period, why = transient_verdict(probe.strobe, scale, sweep.period_rtol, probe.n_impacts == 0,
                                        margin=SETTLED_MARGIN, Omega=float(Omega))
        if period != 0 and not why and not growing(probe.strobe, max(period, 1), scale):
            rec = probe if spp_p == spp else _simulate(solver, Omega, start, 0, sweep, clock)
            return _in_phase(solver, Omega, rec, (max_tr - used) % max(period, 1), sweep, clock), used
        if clock.over(limit):
            msg = f"point_time_limit_s = {limit:g} s passed after {used} transient periods (settle = true)"
            return _failed_record(replace(probe, status="failed", message=msg), n_rec, spp, None), used
        end = used + n_rec                    # the periods behind probe.final_state
        if max_tr - end >= 2 * n_rec:         # the probe was transient: the next one follows it
            used, start = end, probe.final_state
            continue
        # the last: the rest of the transient and the record in one call, as the fixed transient's
        return _simulate(solver, Omega, probe.final_state, max_tr - end, sweep, clock), max_tr


def _in_phase(solver, Omega, traj, k: int, sweep: Sweep, clock: PointClock):
    """``traj`` whose final state (the next point's start) is advanced by ``k`` periods (``k`` < the
    orbit's period n): the point of a period-n orbit a record after the whole transient would end
    on, so that the next point of a chain starts where it would without ``settle``."""
    if k <= 0:
        return traj
    adv = simulate(solver, Omega, traj.final_state, k, 0, sweep.samples_per_period, sweep.point_time_limit_s, clock)
    return traj if adv.status == "failed" else replace(traj, final_state=adv.final_state)


def _statistics(solver, Omega, traj, out: dict, sweep: Sweep, Delta: float, clock: PointClock) -> None:
    """Continue a non-periodic record until it holds ``sweep.statistics_periods`` per-period
    amplitudes, and measure the spread over all of them.

    A chaotic attractor is reproducible only in its statistics, and a mean over 16 or 64
    correlated ``Q_k`` is a poor one (:func:`vibeam.engine.records.batch_means`), so a point
    whose record is not periodic (``period == 0``) is continued from the record's final
    state by ``statistics_periods - record_periods`` periods (:func:`simulate`: calls of
    bounded work with the wall-time limit checked between them; skipped once it has
    passed).  ``amplitude_mean``,
    ``amplitude_std``, ``amplitude_min``, ``amplitude_max``, ``amplitude_sem`` and
    ``record_periods`` then cover the whole window, and so do ``amplitude`` (``Delta -
    min q``), ``q_min`` and ``q_max``; the stroboscopic samples, harmonics, impacts and
    contact outputs stay the record's.  The window is a look-ahead: the next point of a
    continuation chain starts from the record's final state, as without it, so the
    statistics never change which attractor a later point lands on (nor a state-carried
    effect such as the sliding gap drift).  A continuation that fails leaves the
    record's own spread.  ``out`` is updated in place.
    """
    extra = int(sweep.statistics_periods) - int(sweep.record_periods)
    if extra <= 0 or out.get("period") != 0 or out.get("status") == "failed" or clock.over(sweep.point_time_limit_s):
        return
    ext = simulate(solver, Omega, traj.final_state, 0, extra, sweep.samples_per_period,
                   sweep.point_time_limit_s, clock)
    if ext.status == "failed":
        return
    d0 = traj.Delta if traj.Delta is not None else Delta
    d1 = ext.Delta if ext.Delta is not None else Delta
    Q = np.concatenate([d0 - period_minima(traj), d1 - period_minima(ext)])
    out.update(amplitude_spread(Q))
    out["q_min"] = min(out["q_min"], ext.q_min)
    out["q_max"] = max(out["q_max"], ext.q_max)
    out["amplitude"] = max(out["amplitude"], d1 - ext.q_min)
    n_tail = min(int(sweep.record_periods), ext.strobe.shape[0])
    scale = max(ext.q_max - ext.q_min, float(np.max(np.abs(ext.samples[:, 1]))) if ext.samples.size else 0.0,
                1e-300)
    why = window_verdict(Q, ext.strobe[ext.strobe.shape[0] - n_tail:], scale, sweep.period_rtol,
                         ext.n_impacts == 0, Omega=float(Omega))
    if why:
        why += f" (statistics_periods = {sweep.statistics_periods})"
    if why and out["status"] != "unsettled":
        out["message"] = f"unsettled: {why}" + (f"; {out['status']}: {out['message']}"
                                                 if out["status"] != "ok" else "")
        out["status"] = "unsettled"


def _point(solver, Omega, state, sweep: Sweep, Delta: float):
    """Simulate one point; dynamical outcomes and solver errors become a status."""
    check_interrupt()           # a signal recorded in the point before: no further point (issue 57)
    t0 = time.perf_counter()
    try:
        if solver.time_domain:
            why = ""
            clock = PointClock()
            if sweep.auto:
                traj, used, why = settle_transient(solver, Omega, state, sweep, Delta, clock)
            elif sweep.settle:
                traj, used = settle_early(solver, Omega, state, sweep, clock)
            else:
                used = int(sweep.transient_periods)
                traj = _simulate(solver, Omega, state, used, sweep, clock)
            out = summarize(traj, Delta, sweep.period_rtol)
            if why and out["status"] not in ("failed", "unsettled"):
                out["message"] = f"unsettled: {why}" + (f"; {out['status']}: {out['message']}"
                                                         if out["status"] != "ok" else "")
                out["status"] = "unsettled"
            out["transient_periods_used"] = used
            out.update(traj.extra)
            for fn in sweep.assess:
                out.update(fn(traj))
            _statistics(solver, Omega, traj, out, sweep, Delta, clock)
            if sweep.lyapunov_shots and out["status"] != "failed":
                _lyapunov(solver, Omega, traj, out, int(sweep.lyapunov_shots))
            new_state = traj.final_state
        else:
            n_tr = 0 if sweep.auto else sweep.transient_periods
            out = dict(solver.point(Omega, state, n_tr, sweep.record_periods, sweep.samples_per_period))
            new_state = out.pop("final_state", None)
    except Exception as e:  # a solver failure is recorded, never fatal to the sweep
        reraise_interrupt(e)         # Ctrl-C inside a compiled call: an interrupt, not a failed point
        out = dict(status="failed", message=f"{type(e).__name__}: {e}")
        new_state = None
    _not_finite(out)
    out["Omega"] = float(Omega)
    out["wall_time_s"] = time.perf_counter() - t0
    return out, new_state


def shooting_at(solver, Omega: float) -> SceneShooting:
    """The shooting problem (in ``Omega``) of the scene a solver simulates at ``Omega``: its
    ``scene``, or the point's scene of a solver whose effects change it per point (``scene_at``).

    Raises
    ------
    ValueError
        If the point's scene depends on the state (a gap that slides with the impacts), or the
        event integrator refuses the scene's stops.
    """
    at = getattr(solver, "scene_at", None)
    sc = solver.scene if at is None else at(float(Omega))
    if sc is None:
        raise ValueError("the scene changes with the state (a sliding gap): no shooting problem of its own")
    return SceneShooting(sc)


def _lyapunov(solver, Omega, traj, out: dict, shots: int) -> None:
    """The point's Lyapunov spectrum (:data:`UNITS` ``lyapunov``) from its final state, in place."""
    d = 2 * outputs(solver.scene).n_modes
    try:
        prob = shooting_at(solver, Omega)
        sp = lyapunov_spectrum(prob, np.asarray(traj.final_state, float)[:d], float(Omega), shots)
        ok, why = sp.status == "ok", sp.message
    except ValueError as e:       # a model without a shooting problem
        ok, why = False, str(e)
    if ok:
        out["lyapunov"], out["lyapunov_error"] = sp.exponents, sp.error
        out["lyapunov_qr"] = sp.exponents
        out["lyapunov_method"] = "qr"
        n = int(out.get("period", 0))
        if n > 0:
            # a periodic orbit: its Floquet exponents are exact, the QR estimate (biased like 1/K)
            # stays as the check; where the orbit cannot be refined, the QR values are reported
            lam = orbit_exponents(prob, traj.final_state, float(Omega), n, d)
            if lam is not None:
                out["lyapunov"], out["lyapunov_error"] = lam, np.zeros(d)
                out["lyapunov_method"] = "floquet"
        # periodic: a period found (or no impact: the linear response) on a record that has
        # settled -- an unsettled record (a window shorter than the transient's decay, as at
        # Omega 1e5 over 1000 periods) is classed by its spectrum, never called periodic
        settled = out.get("status") in ("ok", "chatter", "sticking")
        out["lyapunov_class"] = classify_spectrum(out["lyapunov"], out["lyapunov_error"], periodic=n != 0 and settled)
    else:
        out["lyapunov"], out["lyapunov_error"] = np.full(d, np.nan), np.full(d, np.nan)
        out["lyapunov_qr"] = np.full(d, np.nan)
        out["lyapunov_method"] = ""
        out["lyapunov_message"] = why


def orbit_exponents(prob, state, Omega: float, n: int, d: int):
    """The Floquet exponents of the period-``n`` orbit through ``state`` (its first ``d``
    coordinates at forcing phase 0), refined by Newton on the shooting problem ``prob`` (in ``Omega``)
    (:func:`vibeam.models.orbits.continuation.start_point`), as
    :func:`vibeam.models.orbits.lyapunov.floquet_exponents`; None where the orbit is not refined."""
    try:
        pt, _ = start_point(prob, np.asarray(state, float)[:d], float(Omega), int(n),
                            0.5 * Omega, 2.0 * Omega)
    except (ValueError, np.linalg.LinAlgError):
        return None
    if pt is None or np.size(pt.mu) != d:
        return None
    return floquet_exponents(pt.mu, n, Omega)


def _not_finite(out: dict) -> None:
    """A point is never reported with a number its method could not compute: an infinite
    amplitude or extreme, or a NaN amplitude of a point that claims an orbit (``period !=
    -1``; NaN with period -1 is the averaging's "no impacting solution"), makes it ``failed``
    with the reason (the method's own message kept).  ``out`` is changed in place."""
    if out.get("status") == "failed":
        return
    bad = []
    for k in ("amplitude", "q_min", "q_max"):
        v = out.get(k)
        if isinstance(v, (float, np.floating)) and math.isinf(v):
            bad.append(f"{k} = {float(v):g}")
    a = out.get("amplitude")
    if isinstance(a, (float, np.floating)) and math.isnan(a) and out.get("period", -1) != -1:
        bad.append(f"amplitude = nan with period {out.get('period')}")
    if bad:
        prev = f" ({out['status']}: {out['message']})" if out.get("message") else ""
        out["message"] = "the method returned no finite result: " + ", ".join(bad) + prev
        out["status"] = "failed"


def _chain(solver, Omegas, sweep: Sweep, Delta: float, direction: str, report=None):
    """A continuation chain (runs inside a worker): points in order, state handed on;
    ``report()`` is called after each point (the progress bar)."""
    state = None
    rows = []
    for W in Omegas:
        out, new_state = _point(solver, W, state, sweep, Delta)
        out["direction"] = direction
        rows.append(out)
        if new_state is not None and out.get("status") != "failed":
            state = new_state
        if report is not None:
            report()
    return rows


@dataclass(frozen=True)
class Line:
    """One independent unit of work: a sweep line along the frequency axis.

    With continuation a line is a whole up or down sweep; without it, one
    point.  Lines are what executors run, what is retried when a worker is
    lost, and what a checkpoint stores.

    Attributes
    ----------
    key : str
        Stable identifier, unique within a run (e.g. ``"up"``, ``"0003-down"``).
    solver : object
        The solver (pickled to the worker).
    Omega : ndarray, shape (n,)
        Forcing frequencies (nondimensional) in visiting order.
    direction : {'up', 'down'}
    sweep : Sweep
        Windows and tolerances.
    Delta : float
        Gap (nondimensional), for the amplitude of Sec. 4.1.
    run : str
        Name of the run the line belongs to.
    """

    key: str
    solver: object
    Omega: np.ndarray
    direction: str
    sweep: Sweep
    Delta: float
    run: str = "run"

    @property
    def n_points(self) -> int:
        return len(self.Omega)


# the queue through which the workers of the local pool report finished points (set in each
# worker by _worker_init; None elsewhere)
_PROGRESS_QUEUE = None


def run_line(line: Line, report=None) -> list[dict]:
    """Compute one line (in a worker); numerical failures are rows with ``status = 'failed'``.

    ``report()`` is called after each point; in a worker of the local pool each point is
    reported to the parent through the pool's progress queue (:func:`_worker_init`).

    Any other unit of work with ``key``, ``run``, ``n_points`` and a ``compute()`` returning
    its rows (e.g. a continuation run, :class:`vibeam.analysis.branches.BranchTask`) runs through the
    same executor, retries and progress bar: advancing when it finishes, or, for a unit with
    ``reports_progress = True``, by ``compute(report=...)`` calling ``report()`` once per step
    (at most ``n_points`` steps: a continuation run's starts)."""
    check_interrupt()       # a signal swallowed in the line before (issue 57): no further line
    if report is None and _PROGRESS_QUEUE is not None:
        q, ident = _PROGRESS_QUEUE, (line.run, line.key)

        def report():
            try:
                q.put_nowait(ident)
            except Exception:  # pragma: no cover - progress is informative only
                pass
    if hasattr(line, "compute"):
        if getattr(line, "reports_progress", False):
            return line.compute(report=report)
        return line.compute()
    return _chain(line.solver, line.Omega, line.sweep, line.Delta, line.direction, report)


def _lost_rows(line: Line, err: BaseException, attempts: int) -> list[dict]:
    if hasattr(line, "lost_rows"):
        return line.lost_rows(err, attempts)
    msg = f"worker lost {attempts} time(s): {type(err).__name__}: {err}"
    return [dict(Omega=float(W), direction=line.direction, status="failed", message=msg, wall_time_s=0.0)
            for W in line.Omega]


# the kinds of work whose kernels this process has loaded (:func:`load_kernels`)
_LOADED: set = set()


def _kernel_key(line):
    """What decides the compiled kernels a unit of work runs: its solver (or continuation run)
    kind and its scene's stop laws (the event integrator's compliant specialisations); None for
    work without a solver."""
    if hasattr(line, "warm_up"):          # a continuation run
        sp = getattr(line, "spec", None)
        laws = (None, None) if sp is None else mass_law_tables(sp)
        return ("task", getattr(sp, "fidelity", ""), str(laws[0]), str(laws[1]),
                getattr(line, "parameter", "") == "Omega")
    s = getattr(line, "solver", None)
    if s is None:
        return None
    scene = getattr(s, "scene", None)
    laws = () if scene is None else tuple(type(st.law).__name__ for st in scene.stops)
    return ("solver", type(s), type(getattr(s, "solver", None)), getattr(s, "name", ""), laws)


def load_kernels(lines) -> float:
    """Load (or compile) the numba kernels of the lines' work in this process, once per kind of work
    (:func:`_kernel_key`): one short call of each solver (two forcing periods at the line's first
    frequency), a cut-down run of each kind of continuation.  Returns the seconds it took.

    :func:`run_lines` calls it before it forks the workers of a local pool: forked workers inherit
    the loaded kernels, so no worker compiles a kernel or loads it from numba's cache (with an
    empty cache every worker would otherwise compile the same kernels side by side).  A call that
    fails is ignored (the work records the failure where it happens)."""
    t0 = time.perf_counter()
    for l in lines:
        key = _kernel_key(l)
        if key is None or key in _LOADED:
            continue
        _LOADED.add(key)
        if key[0] == "task":
            l.warm_up()
            continue
        try:
            l.solver.point(float(np.atleast_1d(l.Omega)[0]), None, 1, 1, 16)
        except Exception:
            pass
    return time.perf_counter() - t0


def run_lines(lines, executor: Executor | None = None, jobs: int | None = 1, on_line=None,
              progress: bool = False, desc: str = "", max_attempts: int = 3, stats: dict | None = None,
              inline_first_s: float | None = None) -> dict:
    """Run independent lines on an executor: the one engine under every sweep and map.

    Parameters
    ----------
    lines : sequence of Line
        Work; keys ``(line.run, line.key)`` must be unique.
    executor : concurrent.futures.Executor, optional
        Any executor with ``submit`` returning :class:`concurrent.futures.Future`
        (a local process pool, ``dask.distributed.Client.get_executor()``).
        Default: a local pool of ``jobs`` workers, rebuilt if a worker dies
        (with ``jobs = 1`` lines run inline, in this process, with no isolation).
    jobs : int or None
        Workers of the default executor (None: all cores; 1: inline).
    on_line : callable, optional
        ``on_line(line, rows)`` in this process as each line finishes (e.g. a
        checkpoint writer); lines finish in any order.
    progress : bool
        A tqdm bar of points done, with rate and time left.  It advances per point: inline
        directly, in the local pool through a queue the workers report each point to
        (:data:`_PROGRESS_QUEUE`); on another executor (dask) per finished line.
    max_attempts : int
        Times a line is submitted when its worker is lost (a killed process,
        a broken pool, a lost dask worker); after that its points are recorded
        with ``status = 'failed'`` and the reason, and the rest goes on.  A local
        pool that breaks fails every line it held although one worker died; such a
        shared loss counts against no line, and the rest of the run uses one worker,
        so that a line that kills its worker is told apart from its neighbours.
    stats : dict, optional
        Filled with ``executor`` ("inline", "pool of N workers" or the executor's type) and
        ``pool_startup_s``: the time until the local pool's workers were running
        (forked, initialised; 0 inline), measured before any line is submitted.
    inline_first_s : float, optional
        With the default executor and ``jobs > 1``: run the lines inline, in order, and
        start the pool for the rest only when this much time has passed and at least two
        lines are left (a small sweep never pays for the pool).

    An interrupt (``KeyboardInterrupt``, or SIGTERM turned into one by the
    command line) first hands every line that has already finished to
    ``on_line``, then cancels the queued lines, terminates the workers of the
    default pool and re-raises: it returns within about a second whatever the
    workers are doing (an inline line stops at its kernel's next return).

    Returns
    -------
    dict
        ``{(run, key): rows}``, rows being the per-point dicts in visiting order.
    """
    lines = list(lines)
    own = executor is None
    queue = None
    stats = stats if stats is not None else {}
    n = _pool_size(jobs, len(lines))
    inline_first = own and n > 1 and inline_first_s is not None

    def start_pool(k):
        nonlocal queue
        load_kernels(lines)     # before the fork: the workers inherit the kernels, none compiles
        t0 = time.perf_counter()
        queue = _progress_queue() if progress else None
        pool = _pool(k, queue)
        _start_workers(pool, k)
        stats["pool_startup_s"] = time.perf_counter() - t0
        return pool

    if own:
        stats.update(executor="inline", pool_startup_s=0.0)
        ex = InlineExecutor() if n <= 1 or inline_first else start_pool(n)
        if not isinstance(ex, InlineExecutor):
            stats["executor"] = f"pool of {n} workers"
    else:
        ex = executor
        stats.update(executor=type(executor).__name__, pool_startup_s=0.0)
        if isinstance(ex, ProcessPoolExecutor):     # a local pool (its workers fork at its first task)
            load_kernels(lines)
    attempts: dict = {}
    isolated = False        # after a pool broke under several lines: one line in flight from then on
    backlog: list = []      # lines waiting for their turn while isolated
    pending: dict = {}
    results: dict = {}
    bar = None
    done_pts: dict = {}
    size = {(l.run, l.key): l.n_points for l in lines}
    if progress and lines:
        bar = tqdm.tqdm(total=sum(l.n_points for l in lines), desc=desc or "sweep", unit="pt", leave=False,
                        smoothing=0.1)

    def advance(ident, k=1):
        """The bar by ``k`` points of line ``ident`` (never beyond the line's points: a retried
        line reports its points again)."""
        if bar is None:
            return
        c = done_pts.get(ident, 0)
        k = min(k, size.get(ident, 0) - c)
        if k > 0:
            done_pts[ident] = c + k
            bar.update(k)

    def drain():
        while queue is not None:
            try:
                ident = queue.get_nowait()
            except Exception:     # empty (or a message lost with a killed worker)
                return
            advance(ident)

    def submit(line):
        ident = (line.run, line.key)
        attempts[ident] = attempts.get(ident, 0) + 1
        try:
            pending[ex.submit(run_line, line)] = line
        except Exception as e:  # the executor refuses work (e.g. broken): treat as a lost worker
            f = Future()
            f.set_exception(e)
            pending[f] = line

    def finish(line, rows):
        ident = (line.run, line.key)
        results[ident] = rows
        if on_line is not None:
            on_line(line, rows)
        drain()
        advance(ident, size[ident])

    try:
        rest = lines
        if isinstance(ex, InlineExecutor):  # in order, each line reported as soon as it is done
            t_in = time.perf_counter()
            rest = []
            beside = []                     # lines handed to a pool while this process computes one

            def hand_over(i):
                """Inside line ``i``, after a point: once the inline time is spent, the lines after it
                go to a pool of the other cores now, not after this line (a sweep of two long
                lines -- up and down -- ran serially with a core idle, issue 42 item 9)."""
                nonlocal ex
                if beside or not inline_first or len(lines) - i < 2 or n < 2 \
                        or time.perf_counter() - t_in <= inline_first_s:
                    return
                beside.extend(lines[i + 1:])
                k = min(n - 1, len(beside))
                ex = start_pool(k)
                stats["executor"] = (f"inline for {time.perf_counter() - t_in:.2f} s, then a pool of {k} "
                                     f"worker(s) beside it")
                for other in beside:
                    submit(other)

            for i, line in enumerate(lines):
                if inline_first and len(lines) - i >= 2 and time.perf_counter() - t_in > inline_first_s:
                    rest = lines[i:]        # longer than it looked: the pool takes the rest
                    break
                ident = (line.run, line.key)

                def report(ident=ident, i=i):
                    advance(ident)
                    hand_over(i)

                finish(line, run_line(line, report=report))
                if beside:
                    break
            if rest:
                k = min(n, len(rest))
                ex = start_pool(k)
                stats["executor"] = f"inline for {time.perf_counter() - t_in:.2f} s, then a pool of {k} workers"
        for line in rest:
            submit(line)
        while pending or backlog:
            if not pending:
                submit(backlog.pop(0))
            done, _ = cf.wait(list(pending), timeout=0.2, return_when=FIRST_COMPLETED)
            check_interrupt()           # a signal whose exception was swallowed on its way (issue 57)
            drain()
            retry, broken = [], False
            for f in done:
                line = pending.pop(f)
                try:
                    rows = f.result()
                except Exception as e:  # infrastructure failure (the line itself never raises)
                    broken |= isinstance(e, BrokenProcessPool)
                    n = attempts[(line.run, line.key)]
                    if n < max_attempts:
                        retry.append(line)
                    else:
                        finish(line, _lost_rows(line, e, n))
                    continue
                finish(line, rows)
            if broken and own:
                # every line still queued on the broken pool fails too: collect them, then rebuild
                for f in list(pending):
                    line = pending.pop(f)
                    try:
                        finish(line, f.result())
                    except Exception as e:
                        n = attempts[(line.run, line.key)]
                        if n < max_attempts:
                            retry.append(line)
                        else:
                            finish(line, _lost_rows(line, e, n))
                ex.shutdown(wait=False, cancel_futures=True)
                queue = _progress_queue() if queue is not None else None   # the old one may be damaged
                # a broken pool fails every line it held, but one worker died: when several lines
                # were lost together, which one killed it is unknown, so the loss counts against
                # none of them, and from then on one line at a time is in flight (a pool of one
                # worker, nothing queued behind it), so that every later loss is that line's
                shared = len(retry) > 1 and not isolated
                if shared:
                    for line in retry:
                        attempts[(line.run, line.key)] -= 1
                isolated = isolated or shared
                ex = _pool(1 if isolated else max(1, min(jobs or os.cpu_count() or 1, len(retry))), queue)
            if isolated:
                backlog.extend(retry)
                for f in list(pending):        # lines queued before the isolation: back in line
                    if not f.running() and f.cancel():
                        backlog.append(pending.pop(f))
                        attempts[(backlog[-1].run, backlog[-1].key)] -= 1
                if not pending and backlog:
                    submit(backlog.pop(0))
            else:
                for line in retry:
                    submit(line)
    except BaseException as e:
        # interrupted (Ctrl-C, SIGTERM) or failing: report every line that has finished, then
        # stop the rest at once -- queued lines cancelled, the own pool's workers terminated
        try:
            for f, line in list(pending.items()):
                if f.done() and not f.cancelled() and f.exception() is None and \
                        (line.run, line.key) not in results:
                    pending.pop(f)
                    finish(line, f.result())      # may fail again (a full disk): the rest still stops
        finally:
            if own:
                # the pool cancels what is queued and the killed workers' futures fail (cancelling
                # them here as well trips Python 3.11's pool manager: InvalidStateError)
                _terminate(ex)
                pending[Future()] = None      # shut the pool down below without waiting for it
            else:
                for f in pending:
                    f.cancel()
        reraise_interrupt(e)      # an error a signal caused inside compiled code (numba's unboxing) is that interrupt
        raise
    finally:
        if bar is not None:
            bar.close()
        if own:
            ex.shutdown(wait=not pending, cancel_futures=True)
    return results


def _terminate(ex) -> None:
    """Shut a local pool down now: queued lines cancelled, workers killed (their lines are
    abandoned), without waiting for anything they run."""
    procs = list((getattr(ex, "_processes", None) or {}).values())   # shutdown() forgets them
    writer = getattr(getattr(ex, "_result_queue", None), "_writer", None)   # and this
    ex.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        try:
            p.kill()         # SIGKILL: a worker inside a numba kernel runs no Python signal handler
        except Exception:  # pragma: no cover - already gone
            pass
    for p in procs:
        try:
            p.join(timeout=1.0)
        except Exception:  # pragma: no cover
            pass
    # a worker killed while it wrote a result leaves a partial message in the result pipe, and the
    # pool's manager thread blocks reading the rest; Python joins that thread at exit, so the
    # command hung after "interrupted" (vibeam basins --jobs 2, Ctrl-C: 10 min and more).  With the
    # workers gone, the parent's write end is the pipe's last one: closing it ends that read (EOF),
    # the thread sees a broken pool and exits
    if writer is not None:
        try:
            writer.close()
        except Exception:  # pragma: no cover - already closed
            pass


def _worker_init(parent_pid: int, progress_queue=None) -> None:
    """Initializer of the local pool's workers.

    * Ctrl-C is the parent's business: the worker ignores SIGINT (a terminal sends it to the
      whole process group); the parent terminates its workers when it stops.
    * A worker never outlives its parent, even after ``kill -9`` of the parent: on Linux the
      kernel sends it SIGKILL when the parent ends (``prctl(PR_SET_PDEATHSIG)``), and a daemon
      thread exits the worker when its parent pid changes (elsewhere, and as a second guard).
    * With ``progress_queue`` each finished point is reported to the parent
      (:data:`_PROGRESS_QUEUE`); the worker never waits for the queue at exit.
    * Its BLAS runs one thread (:mod:`vibeam.models.blas`: the workers are the parallelism, and
      OpenBLAS's own threads on the methods' small matrices only compete with them).
    """
    global _PROGRESS_QUEUE
    one_blas_thread()               # entered for the worker's life (threadpoolctl: set on creation)
    if progress_queue is not None:
        progress_queue.cancel_join_thread()
    _PROGRESS_QUEUE = progress_queue

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)     # not the parent's handler (inherited by fork)
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except Exception:  # pragma: no cover - not Linux
        pass
    if os.getppid() != parent_pid:    # the parent ended before prctl took effect
        os._exit(1)

    def watch():
        while True:
            time.sleep(0.5)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="vibeam-parent-watch", daemon=True).start()


def _pool(workers: int, progress_queue=None) -> ProcessPoolExecutor:
    """A local process pool whose workers ignore Ctrl-C and die with their parent (and report
    finished points to ``progress_queue``).

    On Linux the workers are forked, so they inherit the parent's imported modules and the
    numba kernels it has loaded (:func:`load_kernels`, called before the fork): nothing is compiled or
    loaded from the cache again in a worker."""
    return ProcessPoolExecutor(max_workers=workers, initializer=_worker_init,
                               initargs=(os.getpid(), progress_queue))


def _progress_queue():
    return multiprocessing.get_context().Queue()


def _ready() -> int:
    return os.getpid()


def _start_workers(ex, n: int) -> None:
    """Start the pool's ``n`` workers now (a no-op task each), so that their start-up is
    measured apart from the sweep."""
    cf.wait([ex.submit(_ready) for _ in range(n)])


def _pool_size(jobs: int | None, n_tasks: int) -> int:
    if jobs is None:
        jobs = os.cpu_count() or 1
    return max(1, min(jobs, n_tasks))


def _plan(sweep: Sweep):
    """Independent tasks as (key, direction, ordered Omegas)."""
    up = np.sort(np.asarray(sweep.Omega, dtype=float))
    dirs = ["up", "down"] if sweep.direction == "both" else [sweep.direction]
    tasks = []
    for d in dirs:
        grid = up if d == "up" else up[::-1]
        if sweep.continuation:
            tasks.append((d, d, grid))
        else:
            tasks.extend((f"{d}-{i:05d}", d, grid[i:i + 1]) for i in range(len(grid)))
    return tasks


def plan_lines(solver, sweep: Sweep, run: str = "run") -> list[Line]:
    """The lines of one sweep, in the order their points are reported (up, then down)."""
    Delta = outputs(solver.scene).Delta
    return [Line(key, solver, grid, d, sweep, Delta, run) for key, d, grid in _plan(sweep)]


def default_executor(jobs: int | None, n_tasks: int) -> Executor:
    """Inline for one job or one task, else a local process pool of ``jobs`` workers (which
    ignore Ctrl-C, and end when this process ends, however it ends: :func:`_worker_init`)."""
    n = _pool_size(jobs, n_tasks)
    return InlineExecutor() if n <= 1 else _pool(n)


def run_sweep(solver, sweep: Sweep, name: str = "run", executor: Executor | None = None,
              jobs: int | None = 1, progress: bool = False) -> SweepResult:
    """Sweep ``solver`` over ``sweep.Omega``.

    Parameters
    ----------
    solver : object
        A solver from :func:`vibeam.models.make_solver` (has ``point``,
        ``time_domain``, ``name``, ``settings()``, ``scene`` (the units and the gap ``Delta`` of
        its results, :func:`vibeam.models.scene.outputs`) and ``model`` (its fidelity name and
        shooting problem)).
    sweep : Sweep
        Grid, direction and windows.
    name : str
        Run name stored with the result.
    executor : concurrent.futures.Executor, optional
        Where independent chains/points run; default from ``jobs``.
    jobs : int or None
        Workers of the default executor (None: all cores; 1: inline).
    progress : bool
        Show a tqdm progress bar (points done, rate, time left).

    Returns
    -------
    SweepResult
        Datasets ``Omega``, ``amplitude``, ``amplitude_mean``, ``amplitude_std``,
        ``amplitude_min``, ``amplitude_max``, ``record_periods``,
        ``transient_periods_used``, ``q_max``, ``q_min``, ``period``,
        ``impacts_per_period``, ``impact_velocity``, ``strobe`` (n, n_record,
        2), ``harmonics`` (n, 6), ``direction``, ``status``, ``message``,
        ``wall_time_s``, plus ``frequency_hz`` and the ``*_mm`` displacements
        (:data:`MM_KEYS`) for physical scenes and any method-specific outputs.  Points are ordered
        as visited: the up branch, then the down branch.
    """
    lines = plan_lines(solver, sweep, name)
    t0 = time.perf_counter()
    done = run_lines(lines, executor=executor, jobs=jobs, progress=progress and len(lines) > 1, desc=name)
    wall = time.perf_counter() - t0
    return assemble(solver, sweep, name, [done[(l.run, l.key)] for l in lines], wall)


def assemble(solver, sweep: Sweep, name: str, line_rows: list, wall_time_s: float) -> SweepResult:
    """The :class:`SweepResult` of a run from its lines' rows (in plan order)."""
    out = outputs(solver.scene)
    rows = [r for rs in line_rows for r in rs]
    data = stack(rows, sweep)
    fn, L = out.natural_frequency_hz, out.length_m
    attrs = {}
    if fn:
        data["frequency_hz"] = data["Omega"] * fn
        attrs["natural_frequency_hz"] = fn
    if L:
        for k in MM_KEYS:
            if k in data:
                data[k + "_mm"] = data[k] * L * 1e3
        attrs["length_m"] = L
    fs = out.force_scale_n                           # N per nondimensional force (a known mass)
    for sfx in ("", "_lower"):                       # "_lower": the lower stop of a two-sided scene
        if fn and "contact_duration" + sfx in data:
            data["contact_duration" + sfx + "_s"] = data["contact_duration" + sfx] / (2 * np.pi * fn)
        if fs and L and "contact_force_max" + sfx in data:
            data["contact_force_max" + sfx + "_n"] = data["contact_force_max" + sfx] * fs
            data["energy_per_impact" + sfx + "_j"] = data["energy_per_impact" + sfx] * fs * L
    return SweepResult(name=name, fidelity=solver.scene.builder, method=solver.name, settings=solver.settings(),
                       data=data, wall_time_s=wall_time_s, attrs=attrs)


def unstack(data: dict) -> list[dict]:
    """Inverse of the stacking of per-point dicts: rows from stacked arrays (a checkpointed line)."""
    n = len(data["Omega"])
    return [{k: (v[i].item() if isinstance(v[i], np.generic) else v[i]) for k, v in data.items()}
            for i in range(n)]


def stack(rows: list[dict], sweep: Sweep) -> dict:
    """Stack per-point dicts into arrays; missing entries become NaN (or '' for text); a text longer
    than :data:`TEXT_MAX` characters is cut there (its last character an ellipsis)."""
    n_rec = sweep.record_periods
    defaults = {"strobe": np.full((n_rec, 2), np.nan), "harmonics": np.full(HARMONICS, np.nan)}
    keys = []
    for r in rows:
        for k in r:
            if k not in keys:
                keys.append(k)
    data = {}
    for k in keys:
        vals = [r.get(k) for r in rows]
        if all(isinstance(v, str) or v is None for v in vals):
            data[k] = np.array(["" if v is None else v if len(v) <= TEXT_MAX else v[:TEXT_MAX - 1] + "\u2026"
                                for v in vals], dtype=object)
            continue
        col = _scalar_column(vals)
        if col is not None:
            data[k] = col
            continue
        proto = next(v for v in vals if v is not None)
        shape = np.shape(proto)
        fill = defaults.get(k, np.full(shape, np.nan) if shape else np.nan)
        arr = [np.asarray(v) if v is not None else fill for v in vals]
        dtype = np.result_type(*[a.dtype if hasattr(a, "dtype") else type(a) for a in arr])
        data[k] = np.array(arr, dtype=dtype)
    for k in CORE_OUTPUTS:              # points that all failed still give every core dataset
        if k not in data and rows:
            data[k] = np.full(len(rows), np.nan) if k not in ("status", "message") else \
                np.array(["failed" if k == "status" else "" for _ in rows], dtype=object)
    if "period" in data:
        data["period"] = np.nan_to_num(data["period"].astype(float), nan=0).astype(np.int64)
    return data


#: the scalar types of per-point outputs, by the dtype :func:`stack` gives a column of them
#: (0 bool, 1 int64, 2 float64: the ``np.result_type`` of their arrays)
_SCALAR_KIND = {bool: 0, np.bool_: 0, int: 1, np.int64: 1, float: 2, np.float64: 2, type(None): 2}
_KIND_DTYPE = (np.bool_, np.int64, np.float64)


def _scalar_column(vals: list):
    """The column of :func:`stack` for per-point values that are all plain scalars (None a NaN),
    built at once: the array the general rule gives (same dtype, same values), or None when
    some value is not such a scalar."""
    kind = 0
    for v in vals:
        c = _SCALAR_KIND.get(type(v), -1)
        if c < 0:
            return None
        kind = max(kind, c)
    try:
        return np.array([np.nan if v is None else v for v in vals], dtype=_KIND_DTYPE[kind])
    except OverflowError:       # an int beyond int64: the general rule
        return None


# datasets every run has, even when every point failed (NaN, status 'failed')
CORE_OUTPUTS = ("amplitude", "q_max", "q_min", "period", "impacts_per_period", "impact_velocity", "status",
                "message")

#: per-point outputs stored as text (every other output is a number)
TEXT_OUTPUTS = ("status", "message", "direction", "lyapunov_message", "lyapunov_class", "lyapunov_method")
#: per-point outputs that are numbers in every line this vibeam writes
NUMBER_OUTPUTS = ("Omega", "amplitude", "q_max", "q_min", "period", "impacts_per_period", "impact_velocity")
#: the longest text of one point :func:`stack` keeps (a message is a sentence or two; an exception's
#: text that is longer is cut there, so no checkpoint or results file holds a longer one)
TEXT_MAX = 4000
#: per-point outputs of complex numbers (the mapping method's Floquet multipliers and map eigenvalues);
#: every other number vibeam writes is real
COMPLEX_OUTPUTS = ("multipliers", "map_eigenvalues")
#: whole numbers (stored as integers, or as floats with NaN at a point that failed before it had them)
WHOLE_OUTPUTS = ("period", "record_periods", "transient_periods_used", "amplitude_sem_dof")
#: outputs in units of the motion (displacements, velocities, amplitudes and their spreads): at a
#: point that is not ``failed`` each is at most :data:`MOTION_MAX` in magnitude
MOTION_OUTPUTS = ("amplitude", "amplitude_mean", "amplitude_std", "amplitude_min", "amplitude_max",
                  "amplitude_sem", "amplitude_lower", "q_min", "q_max", "strobe", "harmonics", "impact_velocity",
                  "impact_velocity_lower", "stop_impact_velocity", "penetration_max", "penetration_max_lower",
                  "contact_gap_max", "mode_amplitudes", "mode_contact_amplitudes")
#: the largest magnitude of the motion at a point that is not ``failed``: the kernels square the
#: motion's numbers (energies ``(1 - R^2) v^2 / 2``, the envelope ``sqrt(x^2 + w^2)``, spreads;
#: :data:`vibeam.case.schema.B_RANGE`), and beyond ``sqrt(1.8e308) = 1.3e154`` those squares are
#: infinite: such a point is failed (:func:`vibeam.engine.records.summarize`), never reported
MOTION_MAX = 1e154
#: outputs that are shares of the record (0 ... 1)
FRACTION_OUTPUTS = ("stuck_fraction", "contact_fraction")
#: outputs that are never negative (counts per period, durations, largest penetrations, amplitudes of
#: harmonics, spreads)
NONNEGATIVE_OUTPUTS = ("impacts_per_period", "impacts_per_period_lower", "stop_impacts_per_period",
                       "contact_duration", "contact_duration_lower", "penetration_max", "penetration_max_lower",
                       "harmonics", "amplitude_std", "amplitude_sem", "wall_time_s", *FRACTION_OUTPUTS)
#: what :func:`vibeam.engine.records.summarize` gives a time-domain point: never infinite at a point that
#: is not failed (an infinite output makes it failed)
SUMMARY_OUTPUTS = ("amplitude", "amplitude_mean", "amplitude_std", "amplitude_min", "amplitude_max", "amplitude_sem",
                   "q_max", "q_min", "impacts_per_period", "impact_velocity", "strobe", "harmonics",
                   "contact_duration", "contact_force_max", "penetration_max", "energy_per_impact",
                   "impacts_per_period_lower", "impact_velocity_lower", "contact_duration_lower",
                   "contact_force_max_lower", "penetration_max_lower", "energy_per_impact_lower",
                   "stop_impacts_per_period", "stop_impact_velocity")
#: outputs of one number (or text) per point
SCALAR_OUTPUTS = frozenset(TEXT_OUTPUTS + NUMBER_OUTPUTS + SUMMARY_OUTPUTS + WHOLE_OUTPUTS + FRACTION_OUTPUTS
                           + ("wall_time_s",)) - {"strobe", "harmonics", "stop_impacts_per_period",
                                                  "stop_impact_velocity"}
#: outputs that are numbers wherever they are written (every output with a unit, :data:`UNITS`)
NUMERIC_OUTPUTS = frozenset(NUMBER_OUTPUTS + SUMMARY_OUTPUTS + MOTION_OUTPUTS + WHOLE_OUTPUTS + FRACTION_OUTPUTS
                            + NONNEGATIVE_OUTPUTS + COMPLEX_OUTPUTS + tuple(UNITS)) - set(TEXT_OUTPUTS)
#: names of the dimensions of a stored line (coordinates, never per-point outputs)
LINE_DIMS = ("point", "record_period", "state", "harmonic", "mode", "peak", "multiplier", "eigenvalue",
             "exponent", "stop", "spectrum_frequency", "noise_level")


def _trailing(line) -> dict:
    """The trailing shape of the per-point arrays whose shape the line fixes: ``strobe`` (one
    ``(q, q')`` per recorded period), ``harmonics``, the Lyapunov exponents (one per state of the
    mechanical system: 2 per mode)."""
    d = 2 * outputs(line.solver.scene).n_modes
    return {"strobe": (int(line.sweep.record_periods), 2), "harmonics": (HARMONICS,),
            "lyapunov": (d,), "lyapunov_error": (d,), "lyapunov_qr": (d,)}


def check_line(meta: dict, data: dict | None, line) -> str | None:
    """What is wrong with a checkpointed sweep line, or None: what ``--resume`` reads is what
    this vibeam writes for ``line`` (:func:`stack` of its rows).

    Parameters
    ----------
    meta : dict
        ``{dataset: (shape, dtype)}`` of the stored line (read before any value).
    data : dict or None
        ``{dataset: array}`` once read (None: check the shapes and types only).
    line : Line
        The planned line (its points, in visiting order).

    Returns
    -------
    str or None
        One phrase naming the dataset (and the point) and what is wrong.

    Shapes and types (before any value is read): every output of :data:`CORE_OUTPUTS` and
    ``Omega`` present; every dataset one value or one array per point of the line, a scalar
    output one value (no trailing axis), ``strobe`` ``(record_periods, 2)``, ``harmonics``
    ``(6,)`` and the Lyapunov exponents one per state (:func:`_trailing`) per point; no dataset
    named as a dimension (:data:`LINE_DIMS`); :data:`TEXT_OUTPUTS` text, :data:`NUMERIC_OUTPUTS`
    numbers; real numbers in 64 bits (complex only for :data:`COMPLEX_OUTPUTS`).

    Values (each what :func:`_point` and :func:`vibeam.engine.records.summarize` can give):

    * ``Omega`` the line's frequencies in its visiting order (within 1e-12 relative),
      ``direction`` the line's, ``status`` one of :data:`vibeam.engine.records.STATUSES`, texts at
      most :data:`TEXT_MAX` characters;
    * whole numbers (:data:`WHOLE_OUTPUTS`): ``period`` -1 ... 8 (or the method's own ``k``/``n``),
      ``record_periods`` the sweep's ``record_periods`` or ``statistics_periods``,
      ``transient_periods_used`` the sweep's (``auto``: at most ``max_transient_periods`` and a
      record), ``amplitude_sem_dof`` below ``record_periods``;
    * ranges: shares (:data:`FRACTION_OUTPUTS`) in 0 ... 1, :data:`NONNEGATIVE_OUTPUTS` not
      negative, ``wall_time_s`` finite and no longer than the time since 1970;
    * status against finiteness, at a point that is not ``failed``: no infinite number (but the
      Lyapunov exponents' -inf) of a time-domain method (``amplitude``, ``q_min``, ``q_max`` of every
      method: :func:`_not_finite`), ``amplitude``
      a number (NaN only with ``period`` -1, a method's "no solution"), the motion
      (:data:`MOTION_OUTPUTS`) at most :data:`MOTION_MAX`; for a time-domain method also ``q_min``,
      ``q_max``, ``impacts_per_period`` and the per-period amplitudes finite;
    * consistency at such a time-domain point: ``q_min <= q_max``, ``amplitude`` = ``Delta - q_min``
      (without scene effects, which move the stop per point), the per-period amplitudes
      ``amplitude - (q_max - q_min) <= amplitude_min <= amplitude_mean <= amplitude_max <=
      amplitude``, their spread at most their range, ``impacts_per_period`` a whole number of
      impacts over the record and at most what the method's ``max_impacts_per_period`` lets a call
      hold, the stroboscopic ``q`` within ``[q_min, q_max]``, each harmonic's
      amplitude at most twice the largest ``|q|``.
    Comparisons allow the rounding of the numbers compared (1e-9 of their scale).
    """
    n = line.n_points
    for k in CORE_OUTPUTS + ("Omega",):
        if k not in meta:
            return f"dataset {k} is missing"
    fixed = _trailing(line)
    for k, (shape, dtype) in meta.items():
        shape = tuple(shape)
        if not shape or shape[0] != n:
            return f"dataset {k} has shape {shape}; the line has {n} point(s)"
        if k in LINE_DIMS:
            return f"dataset {k} is a dimension of the line, not an output"
        dt = np.dtype(dtype)
        kind = dt.kind
        text = kind in "OSU"
        if k in NUMERIC_OUTPUTS and kind not in "biufc":
            return f"dataset {k} holds {dt} values; allowed: numbers"
        if k in TEXT_OUTPUTS and not text:
            return f"dataset {k} holds {dt} values; allowed: text"
        if not text and kind not in "biufc":
            return f"dataset {k} holds {dt} values; allowed: numbers or text"
        if kind == "c" and k not in COMPLEX_OUTPUTS:
            return f"dataset {k} holds {dt} values; allowed: real numbers"
        if kind in "fc" and dt.itemsize != (8 if kind == "f" else 16):
            return f"dataset {k} holds {dt} values; allowed: {'float64' if kind == 'f' else 'complex128'}"
        want = fixed.get(k, () if k in SCALAR_OUTPUTS else None)
        if want is not None and shape[1:] != want:
            return (f"dataset {k} has shape {shape}; allowed: {(n,) + want} (one {'value' if not want else want} "
                    f"per point)")
    if data is None:
        return None
    return _line_values(data, line)


def _first(mask) -> int:
    return int(np.flatnonzero(np.asarray(mask).reshape(len(mask), -1).any(axis=1))[0])


def _line_values(data: dict, line) -> str | None:
    """The value rules of :func:`check_line` (the shapes and types already checked)."""
    n = line.n_points
    sw = line.sweep
    om = np.asarray(data["Omega"], float)
    want = np.asarray(line.Omega, float)
    if om.shape != want.shape or not np.allclose(om, want, rtol=1e-12, atol=0):
        return f"dataset Omega is not the line's frequencies ({want[:3].tolist()}...)"
    texts = {}
    for k, v in data.items():
        a = np.asarray(v)
        if a.dtype.kind in "OSU":
            t = np.array([x.decode("utf-8", "replace") if isinstance(x, bytes) else str(x) for x in a.ravel()],
                         dtype=object).reshape(a.shape)
            long = [len(x) > TEXT_MAX for x in t.ravel()]
            if any(long):
                i = int(np.flatnonzero(long)[0])
                return f"dataset {k} holds a text of {len(t.ravel()[i])} characters; allowed: at most {TEXT_MAX}"
            texts[k] = t
    st = texts["status"].astype(str)
    bad = [x for x in st if x not in STATUSES]
    if bad:
        return f"dataset status holds {bad[0][:40]!r}; allowed: {', '.join(STATUSES)}"
    if "direction" in texts and np.any(texts["direction"].astype(str) != line.direction):
        i = _first(texts["direction"].astype(str) != line.direction)
        return f"dataset direction is {texts['direction'][i][:20]!r} at point {i}; the line is {line.direction!r}"
    live = st != "failed"
    td = bool(getattr(line.solver, "time_domain", True))
    num = {k: np.asarray(v) for k, v in data.items() if k not in texts and np.asarray(v).dtype.kind in "biufc"}
    f = {k: v.astype(complex if v.dtype.kind == "c" else float) for k, v in num.items()}

    def at(k, mask):
        """The first point of ``mask`` (per point, any element), for the message."""
        i = _first(mask)
        v = f[k][i]
        return i, (v if np.ndim(v) == 0 else v[np.asarray(mask[i])][0] if np.any(mask[i]) else v.ravel()[0])

    def live_(a):
        return live.reshape((n,) + (1,) * (np.ndim(a) - 1))

    # whole numbers
    s = line.solver
    p_max = max(PERIOD_MAX, int(getattr(s, "k", 0) or 0), int(getattr(s, "n", 0) or 0)) if not td else PERIOD_MAX
    for k in WHOLE_OUTPUTS:
        if k not in f:
            continue
        a = f[k]
        fin = np.isfinite(a)
        if np.any(fin & (a != np.round(np.where(fin, a, 0)))):
            i, v = at(k, fin & (a != np.round(np.where(fin, a, 0))))
            return f"dataset {k} is {v:g} at point {i}; allowed: whole numbers"
        if np.any(~np.isnan(a) & ~fin):
            i, v = at(k, ~np.isnan(a) & ~fin)
            return f"dataset {k} is {v} at point {i}; allowed: whole numbers"
    per = f["period"]
    if np.any((per < -1) | (per > p_max)):
        i, v = at("period", (per < -1) | (per > p_max))
        return f"dataset period is {v:.0f} at point {i}; allowed: -1 (no impact), 0 (not periodic) ... {p_max}"
    if td and "record_periods" in f:
        rp = f["record_periods"]
        allowed = {int(sw.record_periods), max(int(sw.record_periods), int(getattr(sw, "statistics_periods", 0) or 0))}
        bad_ = ~np.isnan(rp) & ~np.isin(rp, sorted(allowed))
        if np.any(bad_):
            i, v = at("record_periods", bad_)
            return (f"dataset record_periods is {v:g} at point {i}; allowed: "
                    f"{' or '.join(str(x) for x in sorted(allowed))} (record_periods, statistics_periods)")
    if td and "transient_periods_used" in f:
        tp = f["transient_periods_used"]
        if sw.auto:
            hi = int(sw.max_transient_periods) + int(sw.record_periods)
            bad_ = ~np.isnan(tp) & ((tp < 0) | (tp > hi))
            allowed = f"0 ... {hi} (transient_periods = \"auto\", max_transient_periods and a record)"
        else:
            bad_ = ~np.isnan(tp) & (tp != int(sw.transient_periods))
            allowed = f"{int(sw.transient_periods)} (transient_periods)"
        if np.any(bad_):
            i, v = at("transient_periods_used", bad_)
            return f"dataset transient_periods_used is {v:g} at point {i}; allowed: {allowed}"
    if "amplitude_sem_dof" in f and "record_periods" in f:
        d, rp = f["amplitude_sem_dof"], f["record_periods"]
        bad_ = ~np.isnan(d) & ((d < 0) | (~np.isnan(rp) & (d >= np.maximum(rp, 1))))
        if np.any(bad_):
            i, v = at("amplitude_sem_dof", bad_)
            return f"dataset amplitude_sem_dof is {v:g} at point {i}; allowed: 0 ... record_periods - 1"
    # ranges
    for k in NONNEGATIVE_OUTPUTS:
        if k in f and f[k].dtype.kind != "c" and np.any(f[k] < 0):
            i, v = at(k, f[k] < 0)
            return f"dataset {k} is {v:g} at point {i}; allowed: not negative"
    for k in FRACTION_OUTPUTS:
        if k in f and np.any(f[k] > 1 + 1e-9):
            i, v = at(k, f[k] > 1 + 1e-9)
            return f"dataset {k} is {v:g} at point {i}; allowed: a share of the record, 0 ... 1"
    if "wall_time_s" in f:
        w = f["wall_time_s"]
        bad_ = ~np.isfinite(w) | (w > time.time())
        if np.any(bad_):
            i, v = at("wall_time_s", bad_)
            return f"dataset wall_time_s is {v:g} at point {i}; allowed: a finite time, at most the time since 1970"
    # status against finiteness: a time-domain point that is not failed has no infinite number but
    # its Lyapunov exponents (-inf: a direction a sticking phase collapses); any method's amplitude
    # and extremes (vibeam.engine.sweep._not_finite)
    finite = [k for k in f if f[k].dtype.kind == "f" and not k.startswith("lyapunov")] if td else \
        ["amplitude", "q_min", "q_max"]
    for k in finite:
        if k in f:
            bad_ = live_(f[k]) & np.isinf(f[k])
            if np.any(bad_):
                i, v = at(k, bad_)
                return f"dataset {k} is {v} at point {i} whose status is {st[i]!r}; allowed there: finite numbers"
    amp = f["amplitude"]
    bad_ = live & np.isnan(amp) & (per != -1)
    if np.any(bad_):
        i = _first(bad_)
        return (f"dataset amplitude is nan at point {i} whose status is {st[i]!r} and period {per[i]:.0f}; "
                f"allowed there: a number")
    for k in MOTION_OUTPUTS:
        if k in f:
            bad_ = live_(f[k]) & (np.abs(f[k]) > MOTION_MAX)
            if np.any(bad_):
                i, v = at(k, bad_)
                return (f"dataset {k} is {v:g} at point {i} whose status is {st[i]!r}; allowed there: at most "
                        f"{MOTION_MAX:g} in magnitude (its square overflows)")
    if not td:
        return None
    need = ["amplitude", "q_min", "q_max", "impacts_per_period"] + \
        [k for k in ("amplitude_mean", "amplitude_min", "amplitude_max") if k in f]
    for k in need:
        bad_ = live & np.isnan(f[k])
        if np.any(bad_):
            i = _first(bad_)
            return f"dataset {k} is nan at point {i} whose status is {st[i]!r}; allowed there: a number"
    # consistency of one record's numbers, at the points that are not failed
    qn, qx = f["q_min"], f["q_max"]
    with np.errstate(invalid="ignore", over="ignore"):
        scale = np.maximum.reduce([np.abs(amp), np.abs(qn), np.abs(qx), np.full(n, abs(float(line.Delta)))])
        tol = 1e-9 * np.where(np.isfinite(scale), scale, 0) + 1e-300

        def check(cond, what):
            bad_ = live & ~cond
            if np.any(bad_):
                return _first(bad_), what
            return None

        rules = [(qn <= qx + tol, "q_min is above q_max")]
        if getattr(s, "inner", None) is None:          # no scene effects: the stop is the line's
            rules.append((np.abs(amp - (float(line.Delta) - qn)) <= tol,
                          f"amplitude is not Delta - q_min (Delta = {float(line.Delta):.10g})"))
        if "amplitude_max" in f:
            lo, mean, hi = f["amplitude_min"], f["amplitude_mean"], f["amplitude_max"]
            rules += [(lo >= amp - (qx - qn) - tol, "amplitude_min is below amplitude - (q_max - q_min)"),
                      (lo <= mean + tol, "amplitude_min is above amplitude_mean"),
                      (mean <= hi + tol, "amplitude_mean is above amplitude_max"),
                      (hi <= amp + tol, "amplitude_max is above amplitude")]
            for k in ("amplitude_std", "amplitude_sem"):
                if k in f:
                    rules.append((np.isnan(f[k]) | (f[k] <= (hi - lo) + tol), f"{k} is larger than the range of "
                                                                               f"the per-period amplitudes"))
        n_rec = int(sw.record_periods)
        ipp = f["impacts_per_period"] * n_rec
        rules.append((np.abs(ipp - np.round(ipp)) <= 1e-9 * np.abs(np.round(ipp)),      # 0 impacts: exactly 0
                      f"impacts_per_period is not a whole number of impacts over {n_rec} periods"))
        inner = getattr(s, "inner", None) or s
        most = getattr(inner, "max_impacts_per_period", None)
        if most:
            # a call of a periods may hold most * a impacts (else it fails): a record that shares its
            # call with the last chunk of the transient has at most most * (chunk + n_rec) / n_rec per period
            chunk = max(1, int(getattr(s, "chunk_periods", None) or CHUNK_PERIODS))
            top = float(most) * (chunk + n_rec) / n_rec
            rules.append((f["impacts_per_period"] <= top,
                          f"impacts_per_period is above {top:g} (max_impacts_per_period = {most} of the method)"))
        if "strobe" in f:
            q = f["strobe"][:, :, 0]
            rules.append((np.all(np.isnan(q) | ((q >= (qn - tol)[:, None]) & (q <= (qx + tol)[:, None])), axis=1),
                          "strobe holds a q outside [q_min, q_max]"))
        if "harmonics" in f:
            h = f["harmonics"]
            big = 2 * np.maximum(np.abs(qn), np.abs(qx)) * (1 + 1e-9) + tol
            rules.append((np.all(np.isnan(h) | (h <= big[:, None]), axis=1),
                          "harmonics holds an amplitude above twice the largest |q|"))
        for cond, what in rules:
            got = check(cond, what)
            if got is not None:
                return f"at point {got[0]} (status {st[got[0]]!r}) {what}"
    return None
