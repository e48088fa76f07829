"""The event-driven simulation of a modal system with stops: one Python driver of the one kernel.

:class:`EventIntegrator` holds a :class:`~vibeam.models.system.ModalSystem` and its stops in
kernel form (:mod:`vibeam.models.core.stops`) and runs :func:`vibeam.models.core.integrator.integrate_work`
for one forcing frequency (:meth:`EventIntegrator.run`), returning the raw :class:`Run` (record
and scalars, row units).  The ``event`` method's solvers (:class:`EventSolver` of the one-mode oscillator's scene,
:class:`BeamEventSolver` of an N-mode scene) turn it into a
:class:`~vibeam.models.trajectory.Trajectory` in their units.

The state of a point is ``(eta (n), eta' (n), held)`` with ``held`` the code of
:func:`~vibeam.models.core.stops.held_code` (0 free; 1 held on stop 0; -1 on stop 1; else the bit
mask of the held stops): the SDOF's ``(q, q', stuck)`` and the beam's ``(eta, eta', stuck)``.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from ..contact import check_stops, restitution_coefficients
from ..scene import Scene, one_mode, rest_state
from .oscillator import undamped_resonance
from ..system import ModalSystem
from .integrator import (ST_FAILED, STATUS_NAMES, Record, RunScalars, compliant_work, integrate_work, new_record, new_work,
                         substeps)
from .phases import compliant_data
from .stops import held_code, held_mask, held_sets, kernel_stops, kernel_system
from ..trajectory import Trajectory, call_budget

__all__ = ["EventIntegrator", "Run"]


@dataclass
class Run:
    """One call of the kernel: its record and its scalars (row units, nondimensional time).

    Attributes
    ----------
    record : Record
    status : int
        :data:`vibeam.models.core.integrator.ST_OK` ...
    n_impacts : int
        Recorded impacts (may exceed the buffer).
    s_min, s_max : float
        Extremes of the sensor signal over the record.
    n_chatter : int
        Chatter sequences of the record.
    stuck_time : float
        Time held on stops in the record (chatter holds excluded).
    held_end : int
        Bit mask of the stops held at the end.
    n_impacts_total : int
        Impacts of the whole call; -1: the forced response is not finite (undamped exact
        resonance); -2: the motion's scale is subnormal (below 1e-290).
    gap_max : float
        Largest gap at the end of an event-free step (row units).
    n_steps : int
    eta, etad : ndarray, shape (n,)
        Final state.
    max_steps, max_impacts : int
        The guards of the call.
    n_periods : int
        Periods of the call.
    contact_time : float
        Time in compliant contact during the record.
    periods_skipped : int
        Periods not integrated because the state had recurred exactly (skipped in the
        transient, copied in the record; the integrator's module docstring; the outputs are
        those of the full run).
    """

    record: Record
    status: int
    n_impacts: int
    s_min: float
    s_max: float
    n_chatter: int
    stuck_time: float
    held_end: int
    n_impacts_total: int
    gap_max: float
    n_steps: int
    eta: np.ndarray
    etad: np.ndarray
    max_steps: int
    max_impacts: int
    n_periods: int = 0
    contact_time: float = 0.0
    periods_skipped: int = 0

    @property
    def held_code(self) -> int:
        return held_code(self.held_end)

    @property
    def final_state(self) -> np.ndarray:
        return np.concatenate([self.eta, self.etad, [float(self.held_code)]])

    @property
    def out_of_steps(self) -> bool:
        """Failed on the step budget (not on the impact guard, not at once)."""
        return self.status == ST_FAILED and self.n_steps > self.max_steps and \
            0 <= self.n_impacts_total <= self.max_impacts


class EventIntegrator:
    """The kernel's data for one model: system, stops and the held sets.

    Parameters
    ----------
    scene : vibeam.models.scene.Scene
        The modal system and its stops (relations on rows of ``system.contacts``) with Newton's law
        or a compliant law whose numbers are in the system's units (:mod:`vibeam.models.core.laws`).

    Raises
    ------
    ValueError
        From :func:`vibeam.models.contact.check_stops`,
        :func:`vibeam.models.core.stops.kernel_stops` and :func:`vibeam.models.core.phases.contact_phases`
        (a law not implemented, R out of range, overlapping stops, too many stops, a relation row the
        system lacks, an unstable or defective contact phase).
    """

    def __init__(self, scene: Scene):
        system, stops = scene.system, scene.stops
        check_stops(stops)
        self.scene = scene
        self.system = system
        self.stops = tuple(stops)
        self.ksys = kernel_system(system)
        self.kstops = kernel_stops(system, self.stops)
        self.held, self.damping_mismatch = held_sets(system, self.kstops)
        #: the largest off-diagonal part of a held set's damping the held flow drops (relative)
        self.held_dropped = held_damping_dropped(self.held, self.damping_mismatch)
        #: the compliant stops' data, None without one (:func:`vibeam.models.core.phases.compliant_data`)
        self.compliant = compliant_data(system, self.kstops, self.held)
        #: bit mask of the stops with a compliant law
        self.compliant_mask = sum(1 << k for k, s in enumerate(self.stops)
                                  if getattr(s.law, "kind", "") == "compliant")
        k = self.ksys.k
        #: the lowest nonzero modal frequency ``sqrt(min k_i)`` (nondimensional; NaN without one)
        self.lowest_omega = float(np.sqrt(np.min(k[k > 0]))) if np.any(k > 0) else math.nan
        # the last call's work arrays, kept for the next call of the same table sizes and grids in
        # the same thread (a basin's cells, a sweep's frequencies: one allocation and dispatch less
        # per call), and the compiled entry of integrate_work for this integrator's argument types
        self._work = None
        self._entry = None
        self._sizes = None          # (grids, work_sizes(*grids)) of the last call

    def __getstate__(self):
        """Pickled (to a pool worker) without the cached work arrays and compiled entry, which
        belong to this process."""
        state = self.__dict__.copy()
        state["_work"] = None
        state["_entry"] = None
        return state

    @property
    def n(self) -> int:
        return self.ksys.k.shape[0]

    @property
    def n_stops(self) -> int:
        return self.kstops.offset.shape[0]

    @property
    def n_held_sets(self) -> int:
        """Rows of the held-set tables (``2 ** n_stops``)."""
        return self.held.valid.shape[0]

    def held_set_of(self, code) -> int:
        """Bit mask of a state's held code (:func:`~vibeam.models.core.stops.held_mask`)."""
        return held_mask(code, self.n_stops)

    def run(self, Omega, eta, etad, held, n_transient, n_record, ns_transient, ns_record, h_cap,
            max_impacts, max_steps, chatter_tol, record: Record | None = None, impact_buffer=4096,
            modal_states=False, log_events=0, log_apexes=0, recurrence=True, record_of_new_types=False) -> Run:
        """Integrate one forcing frequency from phase 0 (:func:`~vibeam.models.core.integrator.integrate_work`).

        Parameters
        ----------
        Omega : float
            Forcing frequency (per unit nondimensional time).
        eta, etad : array_like, shape (n,)
            Initial state (copied).
        held : int
            Bit mask of the held stops at the start.
        n_transient, n_record, ns_transient, ns_record : int
            Periods and grid points per period.
        h_cap : float
            Largest step.
        max_impacts, max_steps : int
            Guards.
        chatter_tol : float
            Chatter accumulation tolerance.
        record : Record, optional
            Buffers to reuse (else new ones with ``impact_buffer``, ``modal_states`` and the log
            capacities).
        recurrence : bool
            Stop integrating a transient or a record once its state recurs exactly, with the
            same outputs bit for bit
            (:mod:`vibeam.models.core.integrator`; off with the event or apex log or compliant
            stops); False integrates every period.
        record_of_new_types : bool
            ``record`` was made by :func:`~vibeam.models.core.integrator.new_record` with this
            integrator's sizes (``compliant`` as it has compliant stops, no logs, no modal
            states): the cached compiled entry serves it as it serves a record of its own
            (a caller that reuses its records, :meth:`EventSolver.stroboscopic`).

        Returns
        -------
        Run
        """
        eta = np.array(eta, dtype=float)
        etad = np.array(etad, dtype=float)
        own = record is None or record_of_new_types     # a record of new_record's types: the cached entry serves it
        if record is None:
            record = new_record(self.n, self.n_stops, n_record, ns_record, impact_buffer, modal_states,
                                log_events, log_apexes, compliant=self.compliant is not None)
        record.nlog[:] = 0
        # the work arrays, then the one compiled call (integrate_work: a wrapper above it would
        # compile its code a second time)
        Om = float(Omega)
        ns_transient = int(ns_transient)
        ns_record = int(ns_record)
        h_cap = float(h_cap)
        recur = bool(recurrence)
        grids = (Om, ns_transient, ns_record, h_cap)
        sizes = self._sizes
        if sizes is None or sizes[0] != grids:
            # (a pure function of the grids: kept for the next call at the same ones, one compiled
            # call less per call of a basin's map, issue 60)
            sizes = self._sizes = (grids, work_sizes(Om, ns_transient, ns_record, h_cap))
        key = (threading.get_ident(), sizes[1], ns_transient, ns_record, h_cap, recur)
        if self._work is not None and self._work[0] == key:
            work = self._work[1]        # integrate_work writes every entry before reading it
        else:
            # the allocations run as Python (the kernels' own text, ``py_func``): the same arrays and
            # types, without compiling two functions only to allocate (0.6 s and 2.4 s of a first run)
            work = new_work.py_func(self.n, self.n_stops, self.n_held_sets, Om, ns_transient, ns_record, h_cap,
                                    recur)
            self._work = (key, work)
        cw = None if self.compliant is None else compliant_work.py_func(self.compliant, self.kstops, self.n, record)
        args = (self.ksys, self.kstops, self.held, cw, Om, eta, etad, int(held), int(n_transient), int(n_record),
                ns_transient, ns_record, h_cap, int(max_impacts), int(max_steps), float(chatter_tol), record, work)
        if own and self._entry is not None:
            out = self._entry(*args)
        else:
            out = compiled_call(integrate_work, args)
            if own:
                self._entry = entry_point(integrate_work, args)
        out = RunScalars(*out)
        return Run(record, int(out.status), int(out.n_imp_record), float(out.s_min), float(out.s_max),
                   int(out.n_chatter), float(out.stuck_time), int(out.held_end), int(out.n_imp_total),
                   float(out.gmax), int(out.n_steps), eta, etad, int(max_steps), int(max_impacts),
                   int(n_transient) + int(n_record), float(out.contact_time), int(out.periods_skipped))


def trajectory(run: Run, Omega, samples_per_period, n_record, scale, impact_buffer, contacts, messages=None,
               budget=True, stop_codes=None, core=None) -> "Trajectory":
    """The :class:`~vibeam.models.trajectory.Trajectory` of one run, in the units of ``q``.

    Parameters
    ----------
    run : Run
    Omega : float
    samples_per_period, n_record : int
    scale : float
        Row value per unit of ``q`` (:attr:`vibeam.models.system.ModalSystem.coordinate_scale`).
    impact_buffer : int
        Capacity of the impact buffers.
    contacts : callable
        ``contacts(v, stops) -> ndarray (k, 5)``: the per-impact contact rows of the fidelity
        (:attr:`~vibeam.models.trajectory.Trajectory.contacts`) from the normal speeds ``v`` (units of
        ``q'``) and the stops (None: one stop).
    messages : dict, optional
        Overrides of the status messages: ``"incomplete"``, ``"failed"``, ``"not_finite"``,
        ``"unresolved"`` (a step the kernel could not take).
    budget : bool
        The step limit of the run was the solver's work budget of one call (running out of it
        makes the trajectory ``incomplete``: fewer periods per call may fit), not a per-period guard
        (then ``failed``).
    stop_codes : ndarray of int, shape (n_s,), optional
        The output code of each stop (0 upper and 1 lower at the attached mass, 2 + i the point
        stop i: :func:`stop_codes`); given, the
        trajectory's ``impact_stops`` are these codes and ``extra["stop_impacts"]`` (shape
        (max code + 1,)) counts the recorded impacts of each.
    core : EventIntegrator, optional
        The run's integrator: with compliant stops, their contacts' rows come from the kernel's
        records (:data:`vibeam.models.core.integrator.C_DURATION` ...), per unit effective mass and
        in the units of ``q`` (force over ``m_eff scale``, penetration over ``scale``, work over
        ``m_eff scale^2``); a contact still open at the end has no row (``contact_stops`` gives the
        stop of each row), and ``extra["contact_fraction"]`` is the time in contact over the record.

    Returns
    -------
    Trajectory
        ``final_state = (eta, eta', held code)``; ``extra``: ``stuck_fraction``,
        ``contact_gap_max`` (``q`` units; 0 when the run held on a stop) and
        ``steps_per_period``.
    """
    msgs = messages or {}
    rec = run.record
    T = 2.0 * math.pi / Omega
    n_per = run.max_steps      # (messages only)
    k = min(run.n_impacts, impact_buffer)
    two = rec.n_imp_stop.shape[0] > 1
    message = ""
    incomplete = False
    if run.status == ST_FAILED and run.n_impacts_total == -2:
        message = ("the motion's scale is subnormal (forcing response, state and gaps below 1e-290): "
                   "numbers there carry fewer than 53 significant bits, so no result is given")
    elif run.status == ST_FAILED and run.n_impacts_total < 0:
        message = msgs.get("not_finite", "the forced response is not finite (undamped exact resonance)")
    elif run.out_of_steps and budget:
        incomplete = True
        message = msgs.get("incomplete", f"more than {n_per} steps in one call")
    elif run.status == ST_FAILED and run.n_steps <= run.max_steps and run.n_impacts_total <= run.max_impacts:
        # neither guard: a step the kernel could not take
        message = msgs.get("unresolved", "a step cannot be resolved in double precision (a contact far stiffer "
                                         "than the system, or a scale that overflows)")
    elif run.status == ST_FAILED:
        message = msgs.get("failed", f"more than {run.max_impacts} impacts (chatter that does not accumulate?)")
    elif run.status == 1:
        message = (f"{run.n_chatter} chatter sequence(s) ending in sticking; stuck {run.stuck_time:.4g} of the "
                   f"window")
    elif run.status == 2:
        message = f"stuck on the stop {run.stuck_time:.4g} of {n_record * T:.4g} time units"
    iv = rec.imp_v[:k] / scale
    ks = rec.imp_k[:k].copy()
    per_stop = None
    n_lower = int(rec.n_imp_stop[1]) if two else 0
    if stop_codes is not None:
        ks = np.asarray(stop_codes, np.int64)[ks]
        per_stop = np.zeros(int(np.max(stop_codes)) + 1)
        np.add.at(per_stop, stop_codes, rec.n_imp_stop)
        n_lower = int(per_stop[1])
    gmax = run.gap_max
    if run.stuck_time > 0.0 or run.held_end:
        gmax = max(gmax, 0.0)     # on a stop the gap is 0 exactly
    samples = rec.samples / scale if scale != 1.0 else rec.samples
    if run.status == ST_FAILED:
        # what the kernel did not finish is no result: no samples, extremes or minima
        samples = np.full_like(samples, np.nan)
        run.s_min = run.s_max = np.nan
        rec.pmin[:] = np.nan
    extra = {}
    contact_stops = None
    if rec.con.shape[0] and core is not None:
        kk = rec.imp_k[:k]
        comp = core.kstops.law[kk] != 0
        rows = np.empty((k, 5))
        if np.any(~comp):
            rows[~comp] = contacts(iv[~comp], ks[~comp] if two else None)
        me = core.kstops.m_eff[kk[comp]]
        c = rec.con[:k][comp].copy()
        c[:, 1] /= me * scale
        c[:, 2] /= scale
        c[:, 3] /= me * scale * scale
        c[:, 4] /= scale
        rows[comp] = c
        closed = np.isfinite(rows[:, 0])    # a contact still open at the end has no record
        crow = rows[closed]
        contact_stops = ks[closed].copy() if two else None
        extra["contact_fraction"] = float(run.contact_time / (n_record * T)) if n_record else 0.0
    else:
        crow = contacts(iv, ks if two else None)
    return Trajectory(
        Omega=float(Omega), samples=samples, samples_per_period=int(samples_per_period),
        impact_times=rec.imp_t[:k].copy(), impact_velocities=iv, contacts=crow, contact_stops=contact_stops,
        impact_stops=ks if two else None, n_impacts_lower=n_lower,
        n_impacts=int(run.n_impacts), q_min=float(run.s_min / scale), q_max=float(run.s_max / scale),
        period_min=rec.pmin / scale, chatter_times=rec.chat_t[:min(run.n_chatter, rec.chat_t.shape[0])].copy(),
        status=STATUS_NAMES[run.status], message=message, final_state=run.final_state,
        extra={"stuck_fraction": float(run.stuck_time / (n_record * T)) if n_record else 0.0,
               "contact_gap_max": float(gmax / scale),
               "steps_per_period": float(run.n_steps / max(run.n_periods, 1)),
               **({"stop_impacts": per_stop} if per_stop is not None else {}), **extra},
        incomplete=bool(incomplete))


#: the dropped off-diagonal held damping (relative) from which a held point says so: beyond the
#: round-off of a Rayleigh-damped mesh's eigenvectors (measured up to 5e-11: the shipped plate and
#: continuum), far below the 2.5e-2 of the 3-DOF chain's 2 % modal damping
HELD_DAMPING_NOTED = 1e-6


def held_damping_dropped(held, mismatch) -> float:
    """The largest off-diagonal entry of a held set's damping ``Psi^T C Psi`` relative to its
    diagonal that the held flow drops: the largest ``mismatch`` (shape (S,)) of the sets whose
    ``Emis`` is stored, i.e. beyond round-off (:func:`vibeam.models.core.stops.held_sets`, which
    returns both); 0.0 for Rayleigh damping and one-mode scenes."""
    stored = [m for m in range(held.Emis.shape[0]) if np.any(held.Emis[m] != 0.0)]
    return float(max((mismatch[m] for m in stored), default=0.0))


def held_damping_note(dropped: float) -> str:
    """The message of a point that was held on a stop of a scene whose held damping is not
    diagonal (non-proportional damping, e.g. a damping ratio per mode): the event integrator's held
    flow keeps the diagonal of ``Psi^T C Psi`` only (:mod:`vibeam.models.core.stops`), so the
    motion while held is approximate; method ``direct`` integrates the held system whole."""
    return (f"held on a stop whose held damping is not diagonal (non-proportional damping): the event "
            f"integrator's held flow drops its off-diagonal part (up to {dropped:.2g} of the diagonal), so "
            f"the motion while held is approximate; method 'direct' integrates it whole")


_ENTRIES: dict = {}


def compiled_call(dispatcher, args):
    """Call a numba kernel through its compiled entry point for these argument types.

    numba's dispatcher resolves the types of tuple arguments in Python (about 0.1 ms per
    NamedTuple of arrays, i.e. most of a short call); the entry point of the overload, found once
    per type signature, takes the arguments as they are.  The key is cheap: the arrays' dtype,
    dimensions and layout, the class of a NamedTuple (whose array fields this package always
    builds with one dtype and dimension each: :mod:`vibeam.models.core.stops`) with which of its
    fields are None and the keys of its tuple fields (an optional field, such as
    :class:`vibeam.models.core.phases.Compliant`'s ``lin`` and ``itab``, makes another
    specialisation), the type of a scalar.
    """
    key = (id(dispatcher),) + tuple(_key(a) for a in args)
    entry = _ENTRIES.get(key)
    if entry is None:
        out = dispatcher(*args)
        from numba import typeof
        sig = tuple(typeof(a) for a in args)
        cres = dispatcher.overloads.get(sig)
        if cres is not None:
            _ENTRIES[key] = cres.entry_point
        return out
    return entry(*args)


def work_sizes(Om: float, ns_transient: int, ns_record: int, h_cap: float) -> tuple[int, int]:
    """What the sizes of :func:`~vibeam.models.core.integrator.new_work`'s arrays depend on at
    ``Om`` beside the grids: the sub-steps per grid step ``(sub_r, sub_t)``.

    Parameters
    ----------
    Om : float
        Forcing frequency (nondimensional).
    ns_transient, ns_record : int
        Grid points per period of the transient and of the record.
    h_cap : float
        Largest step (nondimensional time).

    Returns
    -------
    (int, int)
        :func:`~vibeam.models.core.integrator.substeps` itself (compiled, the kernel's own
        numbers), so that work arrays kept under this key have the tables a call at ``Om`` needs.
    """
    return compiled_call(substeps, (Om, ns_transient, ns_record, h_cap))


def entry_point(dispatcher, args):
    """The compiled entry point of ``dispatcher`` for these arguments (after a call), or None."""
    return _ENTRIES.get((id(dispatcher),) + tuple(_key(a) for a in args))


def _key(a):
    t = type(a)
    if t is np.ndarray:
        return (a.dtype.char, a.ndim, a.flags.c_contiguous)
    if isinstance(a, tuple):
        return (t,) + tuple(_key(x) if isinstance(x, tuple) else x is None for x in a)
    return t


def fundamental_step(system: ModalSystem, steps_per_fundamental: int = 16) -> float:
    """The largest step: ``1 / steps_per_fundamental`` of the lowest modal period."""
    om = float(np.min(system.omega[system.omega > 0])) if np.any(system.omega > 0) else 1.0
    return 2.0 * math.pi / om / int(steps_per_fundamental)


class EventSolver:
    """Method ``event``: the exact event-driven solver (closed-form flow, numba core).

    Parameters
    ----------
    scene : Scene
        The one-mode oscillator and its stops (:func:`vibeam.models.scene.one_mode`: ``beta``,
        ``B``, a stop at ``q = Delta``, optionally one at ``q = -Delta_lower``, each with its law).
    transient_samples : int, optional
        Grid points per forcing period during the discarded transient (the steps are
        sub-steps of it of at most 1/16 of the natural period).  Only the efficiency of
        impact detection depends on it, except for a contact phase that is integrated
        (hysteretic-Hertz stops): its Runge-Kutta steps end on the grid too, so the
        transient's numerical orbit differs from the record's within the integration
        tolerance (measured 5e-11 relative with 4 points, 5e-14 with 16).  With Newton
        stops, a record whose samples per period are a multiple of it steps on this grid
        too (one sub-step per grid step), its samples inside a step evaluated from the
        closed-form flow (:mod:`vibeam.models.core.integrator`): the same numbers to
        round-off, and a settled record is copied after one cycle.
    chatter_tol : float, optional
        Relative error allowed in the constant-acceleration estimate of the
        chatter accumulation time before the solver jumps to it.
    max_impacts_per_period : int, optional
        Beyond this many impacts per forcing period on average the point is
        recorded as ``failed`` instead of looping.
    impact_buffer : int, optional
        Most impacts whose time and velocity are stored per point.
    max_steps_per_call : int, optional
        Work budget of one call of the kernel (its steps, the integrator's ``max_steps``):
        a call that needs more returns ``incomplete`` (:class:`Trajectory`), and the sweep
        engine repeats it in shorter calls; one forcing period that needs more fails.
    recurrence : bool, optional
        Stop integrating a transient or a record once its state recurs exactly (skip or copy
        whole cycles), with the same outputs bit for bit
        (:mod:`vibeam.models.core.integrator`); False integrates every period (a check, a timing).
    """

    name = "event"
    time_domain = True
    # periods per call of the sweep engine (vibeam.engine.sweep.simulate): ~5 ms at 2.5 us per period,
    # ~0.3 s on chatter-heavy points, so Ctrl-C and the wall-time limit act within a second
    chunk_periods = 2000
    #: default work budget of one kernel call: 0.3-2.5 s at the measured 0.06-0.65 us per step
    #: (the cost grows with the share of impacts); a usual period takes 25-80 steps, so a chunk
    #: of 2000 periods uses 5e4-2e5 of it
    MAX_STEPS_PER_CALL = 4_000_000

    def __init__(self, scene: Scene, transient_samples: int = 16, chatter_tol: float = 1e-7,
                 max_impacts_per_period: int = 20000, impact_buffer: int = 4096,
                 max_steps_per_call: int | None = None, recurrence: bool = True):
        self.scene = scene
        self.one = one_mode(scene, "method 'event' of the one-mode oscillator")
        self.recurrence = bool(recurrence)
        self.max_steps_per_call = int(self.MAX_STEPS_PER_CALL if max_steps_per_call is None else max_steps_per_call)
        self.transient_samples = int(transient_samples)
        self.chatter_tol = float(chatter_tol)
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.impact_buffer = int(impact_buffer)
        # the one event integrator on the one-mode modal system with the model's stops
        self._core = EventIntegrator(scene)
        self._h_cap = fundamental_step(self._core.system)

    def settings(self) -> dict:
        return dict(transient_samples=self.transient_samples, chatter_tol=self.chatter_tol,
                    max_impacts_per_period=self.max_impacts_per_period)

    def point(self, Omega: float, state0, n_transient: int, n_record: int,
              samples_per_period: int = 64) -> Trajectory:
        """Simulate one forcing frequency from ``state0`` at forcing phase 0.

        The one event integrator of the modal system (:mod:`vibeam.models.core.integrator`) on
        the oscillator as its one-mode case (:func:`vibeam.models.system.sdof_system`).

        Parameters
        ----------
        Omega : float
            Forcing frequency (nondimensional).
        state0 : array_like, shape (3,) or None
            ``(q, q', stuck)`` (stuck: 0 free, 1 held on the upper stop, -1 on the lower one);
            None starts from rest (:meth:`vibeam.models.scene.OneMode.initial_state`).
        n_transient, n_record : int
            Forcing periods discarded, then recorded.
        samples_per_period : int
            Recorded samples per period.

        Returns
        -------
        Trajectory
            With ``final_state`` ``(q, q', stuck)`` at the end of the record and
            ``period_min``, the exact minimum of ``q`` over each recorded period,
            ``chatter_times``, the accumulation points of the chatter sequences,
            and ``extra["contact_gap_max"]``, the largest unclamped gap ``q - Delta``
            at the end of an event-free step over the whole run (<= round-off).
        """
        m = self.one
        s0 = m.initial_state() if state0 is None else np.asarray(state0, dtype=float)
        held = self._core.held_set_of(s0[2]) if s0.shape[0] > 2 else 0
        n_per = int(n_transient) + int(n_record)
        max_imp = self.max_impacts_per_period * n_per
        run = self._core.run(float(Omega), s0[:1], s0[1:2], held, int(n_transient), int(n_record),
                             self.transient_samples, int(samples_per_period), self._h_cap, max_imp,
                             self.max_steps_per_call, self.chatter_tol, impact_buffer=self.impact_buffer,
                             recurrence=self.recurrence)
        msgs = {"not_finite": (undamped_resonance(m.beta, Omega) or
                               f"the forced response is not finite (F = Omega^2 B = {Omega * Omega * m.B:g})"),
                "incomplete": (f"more than max_steps_per_call = {self.max_steps_per_call} steps in {n_per} "
                               f"period(s) (no step could be certified at the scale of the motion?)"),
                "failed": f"more than {max_imp} impacts in {n_per} periods (chatter that does not accumulate?)"}
        traj = trajectory(run, Omega, samples_per_period, n_record, 1.0, self.impact_buffer, self._contacts,
                          messages=msgs, core=self._core)
        del traj.extra["steps_per_period"]
        return traj

    def stroboscopic(self, Omega: float):
        """The stroboscopic map at ``Omega`` as ``sections(x, n)``: the kernel call of
        ``point(Omega, x, 0, n, 1)`` without the :class:`Trajectory` around it.

        For the basins (:func:`vibeam.analysis.attractors.strobe`), which read only the
        stroboscopic samples and the final state of each call: the impacts' contact rows, the
        status messages and the per-call records are not built.  The records (one per ``n``)
        are allocated once per map and reused (the kernel resets every entry it reads,
        :func:`vibeam.models.core.integrator.integrate_work`); the stops, their laws and the
        system are the integrator's packed kernel data (:attr:`_core`), as in :meth:`point`.

        Parameters
        ----------
        Omega : float
            Forcing frequency (nondimensional).

        Returns
        -------
        callable
            ``sections(x, n) -> (S, final)`` or None: ``x`` the state ``(q, q', stuck)`` (shape
            (3,)) at forcing phase 0, ``n >= 1`` periods; ``S`` (shape (n, 2), a copy) the
            ``(q, q')`` at the start of each period (``S[0]`` is ``x``'s), ``final`` (shape
            (3,)) the state after ``n`` periods: ``point``'s ``samples`` and ``final_state``,
            the same numbers.  None where ``point`` would be ``failed`` (not finite, out of
            the step budget, the impact guard).
        """
        core = self._core
        Om = float(Omega)
        args = (self.transient_samples, 1, self._h_cap)
        records: dict = {}
        compliant = core.compliant is not None

        def sections(x, n):
            n = int(n)
            rec = records.get(n)
            if rec is None:
                rec = records[n] = new_record(core.n, core.n_stops, n, 1, self.impact_buffer, compliant=compliant)
            held = core.held_set_of(x[2]) if x.shape[0] > 2 else 0
            run = core.run(Om, x[:1], x[1:2], held, 0, n, *args, self.max_impacts_per_period * n,
                           self.max_steps_per_call, self.chatter_tol, record=rec, recurrence=self.recurrence,
                           record_of_new_types=True)
            if run.status == ST_FAILED:
                return None
            return rec.samples.copy(), run.final_state

        return sections

    def _contacts(self, v, stops):
        """Per impact (Newton's law): no duration, an impulse (no finite force), no penetration,
        energy lost ``(1 - R^2) U-^2 / 2`` per unit mass (``U-`` the normal pre-impact speed)."""
        k = v.shape[0]
        rows = np.zeros((k, 5))
        rows[:, 1] = np.nan
        law = self.one.stops[0].law
        if stops is not None or (law.kind == "impulsive" and law.table_U):
            Rk = restitution_coefficients([st.law for st in self.one.stops], v, stops)
            rows[:, 3] = 0.5 * (1.0 - Rk ** 2) * v ** 2
        else:
            R = float(law.R)
            rows[:, 3] = 0.5 * (1.0 - R * R) * (v * v)     # (the same operations, one R)
        rows[:, 4] = v
        return rows


def stop_codes(stops) -> np.ndarray | None:
    """The output code of each stop: those on the system's first contact row (the attached mass)
    their index (0 the upper stop, 1 a lower one), the others ``2 + i`` (point stop ``i``); the
    numbering of the trajectories' ``impact_stops`` and of the per-stop outputs.

    Parameters
    ----------
    stops : sequence of vibeam.models.contact.Stop
        A scene's stops, those on row 0 first.

    Returns
    -------
    ndarray of int, shape (n_s,), or None
        None when every stop is on row 0 (the codes are the indices).
    """
    at_mass = [st.relation.row == 0 for st in stops]
    if all(at_mass):
        return None
    n = sum(at_mass)
    return np.array(list(range(n)) + [2 + i for i in range(len(at_mass) - n)], np.int64)


def newton_contact_rows(laws, velocities, stops=None, scale: float = 1.0) -> np.ndarray:
    """Contact rows (:attr:`vibeam.models.trajectory.Trajectory.contacts`) of Newton impacts.

    An impact with normal pre-impact speed ``U-`` on the relation ``g = n^T eta - Delta`` of the
    mass-normalised modal beam receives the impulse ``P = -m_eff (1 + R) U-`` along ``n``
    (the event integrator's impact, ``m_eff = 1 / |w|^2``), which removes the kinetic energy
    ``(1 - R^2) m_eff U-^2 / 2`` of the modal state (``|eta'|^2 / 2``) and nothing else.  In
    the units of the compliant contacts' rows (:func:`vibeam.models.core.event.trajectory`: work per
    ``m_eff L^2``, time unit ``1 / omega_ref``) that is ``(1 - R^2) v^2 / 2`` with ``v = U- / L``,
    the one-mode oscillator's expression (:class:`EventSolver`).

    Parameters
    ----------
    laws : dict or sequence
        The law of each stop by its output code (:func:`stop_codes`).
    velocities : ndarray, shape (k,)
        Recorded pre-impact normal speeds ``U- / L`` (per nondimensional time).
    stops : ndarray of int, shape (k,), or None
        The code of each impact's stop (0 upper, 1 lower, 2 + i point stop i), each with its own
        law; None: all on the upper one.
    scale : float
        ``L``, the row value per unit of ``q`` (the laws' tables are in ``U-``).

    Returns
    -------
    ndarray, shape (k, 5)
        Duration 0, peak force NaN (an impulse), penetration 0, energy lost, ``v``.
    """
    v = np.asarray(velocities, float)
    k = v.shape[0]
    Rk = restitution_coefficients(laws, v, stops, scale) if k else np.zeros(0)
    return np.column_stack([np.zeros(k), np.full(k, np.nan), np.zeros(k), 0.5 * (1.0 - Rk ** 2) * v ** 2, v])


class BeamEventSolver:
    """Method ``event`` of an N-mode scene (the FE beam, a user's matrices, a continuum): the exact
    event-driven modal solver (numba core).

    Parameters
    ----------
    scene : Scene
        Its modal system (``n`` modes; row 0 of its contacts the attached mass, whose
        ``coordinate_scale`` ``L`` makes ``q = s eta / L``) and stops: those on row 0 first (the
        mass's upper and lower stops, output codes 0 and 1), then the point stops (codes 2 + i).
    transient_samples : int
        Grid points per forcing period in the transient (the steps are sub-steps of at most
        ``h_cap``; efficiency only, but for integrated contact phases, as
        :class:`EventSolver`).
    chatter_tol : float
        Accuracy required of the chatter accumulation estimate before sticking.
    max_impacts_per_period : int
        Guard against non-accumulating chatter (status ``failed``).
    max_steps_per_period : int
        Guard against step-size collapse (status ``failed``; never hangs).
    steps_per_fundamental : int
        Largest step is ``1 / steps_per_fundamental`` of the first modal period.
    impact_buffer : int
        Most impacts stored per point.
    record_modal_states : bool
        Also record the modal state at the samples.
    recurrence : bool
        Stop integrating a transient or a record once its state recurs exactly (skip or copy
        whole cycles), with the same outputs bit for bit
        (:mod:`vibeam.models.core.integrator`); False integrates every period (a check, a timing).
    """

    name = "event"
    time_domain = True
    #: work budget of one kernel call in steps x modes (``max_steps_per_call`` = this / n_modes)
    MAX_STEP_MODES_PER_CALL = 20_000_000

    def __init__(self, scene: Scene, transient_samples: int = 16, chatter_tol: float = 1e-7,
                 max_impacts_per_period: int = 20000, max_steps_per_period: int = 20000,
                 steps_per_fundamental: int = 16, impact_buffer: int = 4096,
                 record_modal_states: bool = False, recurrence: bool = True):
        self.scene = scene
        sy = scene.system
        self.n_modes = int(sy.omega.shape[0])
        self._scale = float(sy.coordinate_scale)
        self._omega_ref = 1.0 / float(sy.time_unit_s)
        self._contact_row = np.asarray(sy.contacts[0], float)
        self._codes = stop_codes(scene.stops)
        codes = range(len(scene.stops)) if self._codes is None else self._codes
        self._laws = {int(c): st.law for c, st in zip(codes, scene.stops)}
        self._rest = rest_state(scene)
        self.recurrence = bool(recurrence)
        self.transient_samples = int(transient_samples)
        self.chatter_tol = float(chatter_tol)
        self.max_impacts_per_period = int(max_impacts_per_period)
        self.max_steps_per_period = int(max_steps_per_period)
        self.steps_per_fundamental = int(steps_per_fundamental)
        self.impact_buffer = int(impact_buffer)
        self.record_modal_states = bool(record_modal_states)
        # the one event integrator on the beam's modal system with its stops
        self._core = EventIntegrator(scene)
        self._h_cap = fundamental_step(self._core.system, self.steps_per_fundamental)
        # periods per call of the sweep engine (vibeam.engine.sweep.simulate): the cost per period grows
        # with the modes (29 us for 2 modes, ~15 ms for the 46 of the rig mesh when it chatters),
        # so a call lasts well under a second
        self.chunk_periods = max(16, 2000 // self.n_modes)
        # work budget of one kernel call (steps; a step costs more with more modes): beyond it the
        # call is ``incomplete`` and the sweep engine repeats it in shorter calls
        self.max_steps_per_call = max(100_000, self.MAX_STEP_MODES_PER_CALL // self.n_modes)

    def settings(self) -> dict:
        return dict(transient_samples=self.transient_samples, chatter_tol=self.chatter_tol,
                    max_impacts_per_period=self.max_impacts_per_period,
                    max_steps_per_period=self.max_steps_per_period,
                    steps_per_fundamental=self.steps_per_fundamental,
                    n_modes=self.n_modes)

    def point(self, Omega: float, state0, n_transient: int, n_record: int,
              samples_per_period: int = 64) -> Trajectory:
        """Simulate one forcing frequency ``Omega = f / f_ref`` from ``state0`` (phase 0).

        The one event integrator of the modal system (:mod:`vibeam.models.core.integrator`) on
        the scene's modes.

        ``state0``: ``(eta (N), eta' (N), stuck)`` or None (rest, or held on a pre-stressed stop at
        the mass: :func:`vibeam.models.scene.rest_state`).
        """
        N = self.n_modes
        Om = float(Omega)
        s0 = self._rest.copy() if state0 is None else np.asarray(state0, dtype=float)
        if s0.shape != (2 * N + 1,):
            raise ValueError(f"state0 must have shape ({2 * N + 1},), got {s0.shape}")
        n_per = n_transient + n_record
        max_steps, budget = call_budget(self.max_steps_per_period, n_per, self.max_steps_per_call)
        max_imp = self.max_impacts_per_period * n_per
        run = self._core.run(Om, s0[:N], s0[N:2 * N], self._core.held_set_of(s0[2 * N]), int(n_transient),
                             int(n_record), self.transient_samples, int(samples_per_period), self._h_cap, max_imp,
                             max_steps, self.chatter_tol, impact_buffer=self.impact_buffer,
                             modal_states=self.record_modal_states, recurrence=self.recurrence)
        L = self._scale
        msgs = {"incomplete": f"more than max_steps_per_call = {self.max_steps_per_call} steps in {n_per} period(s)",
                "failed": (f"gave up after {run.n_impacts_total} impacts / {run.n_steps} steps in {n_per} periods "
                           f"(non-accumulating chatter or step collapse)")}
        laws = self._laws
        traj = trajectory(run, Om, samples_per_period, n_record, L, self.impact_buffer,
                          lambda v, ks: newton_contact_rows(laws, v, ks, L), messages=msgs, budget=budget,
                          stop_codes=self._codes, core=self._core)
        iv = traj.impact_velocities
        iv_up = iv[traj.impact_stops == 0] if traj.impact_stops is not None else iv
        modamp = run.record.modamp
        traj.extra.update({"mode_amplitudes": modamp,
                           "mode_contact_amplitudes": np.abs(self._contact_row) * modamp / L,
                           "impact_velocity_m_s": float(np.mean(iv_up) * L * self._omega_ref) if iv_up.size else np.nan})
        if self.record_modal_states:
            traj.extra["modal_states"] = run.record.msamp
        if self._core.held_dropped > HELD_DAMPING_NOTED and traj.extra["stuck_fraction"] > 0.0:
            traj.message = "; ".join(m for m in (traj.message, held_damping_note(self._core.held_dropped)) if m)
        return traj
