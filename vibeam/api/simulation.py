"""One forcing frequency: :func:`simulate` (the recorded time series and impacts,
:class:`Simulation`), :func:`lyapunov` (the Lyapunov spectrum of the attractor it settles on) and
:func:`poincare` (its Poincaré sections)."""
from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vibeam.analysis.attractors import behind_stop, stop_gaps
from vibeam.analysis.poincare import section
from vibeam.api.cases import load_case, pick_run
from vibeam.api.common import saved
from vibeam.case.arguments import check_case_value, check_flag, check_frequency, check_path, check_whole
from vibeam.case.schema import Case, SweepSpec
from vibeam.engine.records import summarize
from vibeam.engine.sweep import orbit_exponents, shooting_at
from vibeam.engine.sweep import simulate as simulate_point
from vibeam.errors import InputError, quote_value
from vibeam.models import make_solver
from vibeam.models.core.scene_shooting import SceneShooting
from vibeam.models.orbits.lyapunov import lyapunov_spectrum
from vibeam.models.scene import outputs
from vibeam.plots.lazy import plt
from vibeam.plots.sweep import simulation_figure
from vibeam.runner import MAX_POINT_VALUES, MAX_WORK_STEPS, check_work, make_job, point_work


@dataclass
class Simulation:
    """The recorded window of one forcing frequency (:func:`simulate`).

    Attributes
    ----------
    Omega : float
        Forcing frequency over the natural frequency.
    t : ndarray, shape (n,)
        Time from the start of the recorded window (nondimensional: ``2 pi`` is one
        natural period), ``n = periods x samples_per_period`` samples.
    q, dq : ndarray, shape (n,)
        Displacement ``q`` and velocity ``q'`` (nondimensional; for a beam, the sensor
        displacement ``U(L_S) / L``).
    impact_times, impact_velocities : ndarray, shape (k,)
        Impacts in the window: times (as ``t``) and pre-impact velocities ``q'- >= 0``.
    summary : dict
        The per-point outputs of the sweep (:func:`vibeam.engine.records.summarize`): amplitude,
        period, impacts_per_period, ...
    status, message : str
        The point's outcome as a sweep records it (``summary["status"]``): ``ok``, ``chatter``,
        ``sticking``, ``unsettled`` (the stroboscopic map shows a transient) or ``failed`` (also
        when the motion left the range of floating-point numbers), and the detail.
    final_state : ndarray
        The state at the end (to continue from).
    natural_frequency_hz, length_m : float or None
        Scales of a physical scene (then ``time_s``, ``U_mm``, ``dU_mm_s`` are set).
    name : str
        The case simulated (and its run, when the case has several): the figures' title; ''
        for a model.
    """

    Omega: float
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    impact_times: np.ndarray
    impact_velocities: np.ndarray
    summary: dict
    status: str
    message: str
    final_state: np.ndarray
    natural_frequency_hz: float | None = None
    length_m: float | None = None
    trajectory: object = None
    name: str = ""

    @property
    def physical(self) -> bool:
        return bool(self.natural_frequency_hz and self.length_m)

    @property
    def time_s(self) -> np.ndarray | None:
        """Time (s): ``t / (2 pi f_n)``; None for a nondimensional scene."""
        return self.t / (2 * np.pi * self.natural_frequency_hz) if self.physical else None

    @property
    def U_mm(self) -> np.ndarray | None:
        """Sensor displacement ``U(L_S) = q L`` (mm, paper Sec. 6)."""
        return self.q * self.length_m * 1e3 if self.physical else None

    @property
    def dU_mm_s(self) -> np.ndarray | None:
        """Sensor velocity ``U'(L_S) = q' L 2 pi f_n`` (mm/s)."""
        return self.dq * self.length_m * 1e3 * 2 * np.pi * self.natural_frequency_hz if self.physical else None

    @property
    def impact_times_s(self) -> np.ndarray | None:
        return self.impact_times / (2 * np.pi * self.natural_frequency_hz) if self.physical else None

    @property
    def impact_velocities_mm_s(self) -> np.ndarray | None:
        return (self.impact_velocities * self.length_m * 1e3 * 2 * np.pi * self.natural_frequency_hz
                if self.physical else None)

    def to_xarray(self):
        """An :class:`xarray.Dataset` on ``t`` (and ``impact``), with units."""
        import xarray as xr  # lazy: xarray (with pandas: 0.35 s) loads only when labelled data are asked for

        ds = xr.Dataset(
            {"q": ("t", self.q, {"units": "1", "long_name": "displacement q"}),
             "dq": ("t", self.dq, {"units": "1", "long_name": "velocity q'"}),
             "impact_velocity": ("impact", self.impact_velocities,
                                 {"units": "1", "long_name": "pre-impact velocity q'-"})},
            coords={"t": ("t", self.t, {"units": "1", "long_name": "time from the start of the record"}),
                    "impact_time": ("impact", self.impact_times, {"units": "1", "long_name": "impact time"})},
            attrs={"Omega": self.Omega, "status": self.status, "message": self.message})
        if self.physical:
            ds["U"] = ("t", self.U_mm, {"units": "mm", "long_name": "sensor displacement U(L_S)"})
            ds["dU"] = ("t", self.dU_mm_s, {"units": "mm s-1", "long_name": "sensor velocity U'(L_S)"})
            ds = ds.assign_coords(time_s=("t", self.time_s, {"units": "s", "long_name": "time"}))
            ds.attrs["frequency_hz"] = self.Omega * self.natural_frequency_hz
        return ds

    def plot(self, path=None):
        """Displacement and velocity against time, and the phase portrait (a Figure)."""
        return saved(simulation_figure(self), path)


def simulate(case_or_model, Omega: float | None = None, periods: int | None = None, transient: int | None = None,
             frequency_hz: float | None = None, samples_per_period: int | None = None, run: str | int = 0,
             method: str = "event", state=None, force: bool = False, **settings) -> Simulation:
    """Simulate one forcing frequency and return the recorded time series and impacts.

    Parameters
    ----------
    case_or_model : Case, str, Path, dict, or a Scene
        A case (anything :func:`load_case` takes; its run ``run`` with its method,
        settings and effects), or a :class:`vibeam.models.scene.Scene` (a case's
        ``model_spec().scene()``, or a model's ``scene()``) simulated by ``method``.
    Omega : float
        Forcing frequency over the natural frequency (or give ``frequency_hz`` for a
        physical scene).
    periods : int, optional
        Forcing periods recorded (default: the case's ``record_periods``, 16 for a model).
    transient : int, optional
        Forcing periods simulated first and discarded (default: the case's
        ``transient_periods``, 0 for a model).
    frequency_hz : float, optional
        Forcing frequency (Hz) of a physical scene: ``Omega = f / f_n``.
    samples_per_period : int, optional
        Samples per forcing period (default: the case's, 64 for a model).
    run : str or int
        The case's run (name or index) whose method, settings, model overrides and
        effects are used.
    method : str
        Method for a model (``event``, ``direct``, ...; time-domain methods only).
    state : array_like, shape (2 d,) or (2 d + 1,), optional
        Initial state at forcing phase 0 (default: the model's rest state,
        ``model.initial_state()``): the displacements then the velocities of the model's
        ``d`` degrees of freedom -- ``(q, q')`` of the SDOF oscillator (nondimensional), the
        modal coordinates ``(eta_1..eta_d, eta'_1..eta'_d)`` of a beam (mass-normalised, m
        kg^(1/2) and m kg^(1/2)/s over the time unit) -- optionally followed by the held flag
        (0 free, 1 held on the upper stop, -1 on the lower one; left out: 0, and a state on a
        stop with zero relative velocity is held by the solver's own sticking test).  Finite
        numbers, on the free side of every rigid stop (a state behind one is refused: the
        kernels would project it onto the stop), with a flag that names stops of the scene
        (-1 needs a lower stop) and holds the state only where it is on them: gap 0 and no
        velocity along a rigid stop's normal, gap >= 0 in contact with a compliant one (to
        ``HELD_RTOL``; else refused: the kernels would snap it onto the stop, or read a flag
        naming a missing stop as free); ``Simulation.final_state`` has the flag and can be
        passed back.
    force : bool
        Simulate even if the work is above the limit of ``vibeam run`` (as ``--force``).
    **settings
        Method settings for a model (e.g. ``rtol`` for ``direct``).

    Returns
    -------
    Simulation

    Raises
    ------
    TypeError, ValueError
        One line naming the argument, the value and what is allowed; the arguments are
        checked by the rules of the case keys they stand for (:mod:`vibeam.case.arguments`):
        ``Omega`` / ``frequency_hz`` a finite number > 0 (a point of ``[sweep] Omega``),
        ``periods`` as ``[sweep] record_periods`` (a whole number >= 1), ``transient`` as
        ``transient_periods`` (a whole number >= 0; ``"auto"`` is the sweep's and is
        refused here), ``samples_per_period`` as ``[sweep] samples_per_period``; ``run`` a
        run's index or name; ``state`` 2 d or 2 d + 1 finite numbers with a consistent held
        flag, not behind a rigid stop.  Also: neither
        or both of ``Omega`` and ``frequency_hz`` given, ``frequency_hz`` for a
        nondimensional scene, a method without a time history (averaging, mapping).
    vibeam.case.schema.InputError
        The work is above the limit of ``vibeam run`` (:func:`vibeam.runner.check_work`:
        e.g. ``periods = 10**12``) and ``force`` is not set; a ValueError too.
    """
    check_flag(force, "force")
    if Omega is not None:
        Omega = check_frequency(Omega, "Omega", "Omega")
    if frequency_hz is not None:
        frequency_hz = check_frequency(frequency_hz, "frequency_hz", "frequency_hz")
        if Omega is not None:
            raise ValueError(f"Omega = {Omega!r} and frequency_hz = {frequency_hz!r}: give one of them, not both")
    if Omega is None and frequency_hz is None:
        raise ValueError("Omega = None: give Omega (or frequency_hz for a physical scene)")
    if periods is not None:
        periods = check_case_value(periods, "periods", SweepSpec, "record_periods")
    if transient is not None:
        transient = check_case_value(transient, "transient", SweepSpec, "transient_periods")
    if samples_per_period is not None:
        samples_per_period = check_case_value(samples_per_period, "samples_per_period", SweepSpec,
                                              "samples_per_period")
    case = None
    if isinstance(case_or_model, (Case, str, Path, dict)):
        case = load_case(case_or_model)
        r = pick_run(case, run)
        job = make_job(case, r, dict(r.model))
        solver = job.solver
        periods = case.sweep.record_periods if periods is None else periods
        if transient is None:
            transient = case.sweep.transient_periods
            if transient == "auto":
                raise ValueError("transient = None: the case's [sweep] transient_periods is \"auto\" (settled by "
                                 "the sweep); give transient, a whole number >= 0")
        spp = case.sweep.samples_per_period if samples_per_period is None else samples_per_period
        period_rtol = case.sweep.period_rtol
    else:
        if not isinstance(method, str):
            raise TypeError(f"method = {quote_value(method)}: not a method name; allowed: a str (event, direct, ...)")
        solver = make_solver(case_or_model, method, **settings)
        periods = 16 if periods is None else periods
        transient = 0 if transient is None else transient
        spp = 64 if samples_per_period is None else samples_per_period
        period_rtol = 1e-5
    if transient == "auto":
        raise ValueError("transient = 'auto': simulate runs a fixed transient (the sweep settles 'auto'); "
                         "allowed: a whole number >= 0")
    out = outputs(solver.scene)
    fn, L = out.natural_frequency_hz, out.length_m
    if frequency_hz is not None:
        if not fn:
            raise ValueError(f"frequency_hz = {frequency_hz!r}: needs a physical scene (natural_frequency_hz); "
                             f"give Omega")
        Omega = check_frequency(frequency_hz / fn, "frequency_hz / natural_frequency_hz")
    if not solver.time_domain:
        raise ValueError(f"method {solver.name!r} computes no time history; use a time-domain method "
                         f"(event, direct, zhuravlev, ivanov)")
    if state is not None:
        state = _check_state(state, solver.scene)
    _check_point_work(case, job if case is not None else None, solver, Omega, int(transient), int(periods),
                      int(spp), force, settings)

    # the sweep engine's calls of bounded work: Ctrl-C stops a long simulation between them
    traj = simulate_point(solver, float(Omega), state, int(transient), int(periods), int(spp))
    summ = summarize(traj, out.Delta, period_rtol)
    return Simulation(Omega=float(Omega), t=traj.t, q=traj.samples[:, 0].copy(), dq=traj.samples[:, 1].copy(),
                      impact_times=np.asarray(traj.impact_times), impact_velocities=np.asarray(traj.impact_velocities),
                      summary=summ, status=summ["status"], message=summ["message"], final_state=traj.final_state,
                      natural_frequency_hz=fn, length_m=L, trajectory=traj,
                      name="" if case is None else (case.name if len(case.run) <= 1 else f"{case.name}, {r.name}"))


@dataclass
class Lyapunov:
    """The Lyapunov spectrum of the attractor one simulation settles on (:func:`lyapunov`).

    Attributes
    ----------
    Omega : float
        Forcing frequency over the natural (reference) frequency.
    exponents, error : ndarray, shape (d,)
        ``lambda_1 >= ... >= lambda_d`` and their error estimates per unit of the model's
        nondimensional time: on a periodic orbit its Floquet exponents ``ln |mu_i| / (n T)``
        (``method = "floquet"``, error 0: exact to the shooting refinement, as a sweep's
        ``lyapunov``), else the QR estimate and its batch-means standard error
        (``method = "qr"``, :class:`vibeam.models.orbits.lyapunov.LyapunovSpectrum`).
    exponents_per_s, error_per_s : ndarray, shape (d,) or None
        The same per second for a physical scene (1/s), else None.
    status, message : str
        ``"ok"``, or ``"failed"`` with the reason (a shot the shooting problem could not take).
    impacts_per_period : float
        Impacts (contacts) per forcing period on the attractor.
    spectrum : vibeam.models.orbits.lyapunov.LyapunovSpectrum
        The QR estimate (kept as the check on a periodic orbit: its bias there falls like
        ``1 / shots`` and its batch-means error does not see it).
    method : str
        ``"floquet"`` or ``"qr"``: where ``exponents`` come from.
    period : int
        The orbit's period in forcing periods (0: not periodic within the record's test,
        :func:`vibeam.engine.records.summarize`).
    """

    Omega: float
    exponents: np.ndarray
    error: np.ndarray
    exponents_per_s: np.ndarray | None
    error_per_s: np.ndarray | None
    status: str
    message: str
    impacts_per_period: float
    spectrum: object
    method: str = "qr"
    period: int = 0


def lyapunov(case_or_model, Omega: float | None = None, shots: int = 2000, transient: int | None = None,
             frequency_hz: float | None = None, run: str | int = 0, state=None, n: int = 1) -> Lyapunov:
    """Lyapunov spectrum of the stroboscopic map at one forcing frequency (issue 21).

    The state from ``state`` (default: rest) is simulated by :func:`simulate` for ``transient``
    periods (default: the case's ``transient_periods``), then ``shots`` shots of ``n`` periods of
    the scene's shooting problem (:class:`vibeam.models.core.scene_shooting.SceneShooting`) give the spectrum by
    the QR method (:func:`vibeam.models.orbits.lyapunov.lyapunov_spectrum`: exact flows, saltation
    matrices at impacts, Müller 1995; Benettin et al. 1980).  As in a sweep (``[sweep] lyapunov``),
    the state the shots end on is then simulated over the case's ``record_periods`` (16 for a
    model): where that record is periodic (period ``n``) and the shooting
    problem refines its orbit, the exponents returned are the orbit's Floquet exponents
    ``ln |mu_i| / (n T)`` with error 0 (``method = "floquet"``), the QR estimate kept in
    ``spectrum`` -- on Fig. 7 at Omega = 2.0 it is off by 9e-5, three times its batch-means error
    (issue 56); elsewhere the QR estimate and its error (``method = "qr"``).

    Parameters
    ----------
    case_or_model : Case, str, Path, dict, or a Scene
        As :func:`simulate` (a case's run ``run`` gives the scene).
    Omega, frequency_hz : float
        The forcing frequency (one of them), as :func:`simulate`.
    shots : int
        Shots averaged, 2 ... 10**6.
    transient : int, optional
        Periods simulated first, as :func:`simulate`.
    state : array_like, optional
        Initial state, as :func:`simulate`.
    n : int
        Forcing periods per shot, 1 ... 64.

    Returns
    -------
    Lyapunov

    Raises
    ------
    TypeError, ValueError
        One line naming the argument, the value and what is allowed (as :func:`simulate`); a
        model without a shooting problem.
    """
    shots = check_whole(shots, "shots", 2, 10 ** 6)
    n = check_whole(n, "n", 1, 64)
    sim = simulate(case_or_model, Omega=Omega, periods=1, transient=transient, frequency_hz=frequency_hz,
                   run=run, state=state, samples_per_period=16)

    if isinstance(case_or_model, (Case, str, Path, dict)):
        case = load_case(case_or_model)
        r = pick_run(case, run)
        problem = shooting_at(make_job(case, r, dict(r.model)).solver, sim.Omega)
    else:
        problem = SceneShooting(make_solver(case_or_model, "event").scene)
    d = problem.dim
    sp = lyapunov_spectrum(problem, np.asarray(sim.final_state, float)[:d], sim.Omega, shots, 0, n)
    lam, err, method, period = sp.exponents, sp.error, "qr", 0
    if sp.status == "ok":
        # the sweep's rule (vibeam.engine.sweep): a periodic record reports its orbit's Floquet
        # exponents; the record starts where the shots ended (free: the shooting state has no flag)
        try:
            rec = simulate(case_or_model, Omega=sim.Omega, transient=0, run=run,
                           state=np.append(sp.final_state, 0.0), samples_per_period=16)
            period = max(int(rec.summary.get("period", 0)), 0)
        except ValueError:      # the shots' state refused (behind a stop by round-off): QR stands
            period = 0
        if period > 0:
            fl = orbit_exponents(problem, rec.final_state, sim.Omega, period, d)
            if fl is not None:
                lam, err, method = fl, np.zeros(d), "floquet"
    # the scene's time unit: 1 / (2 pi f) of its natural (SDOF) or reference (beam) frequency
    f = outputs(problem.scene).natural_frequency_hz
    scale = 2.0 * math.pi * f if f else None
    return Lyapunov(Omega=float(sim.Omega), exponents=lam, error=err,
                    exponents_per_s=None if scale is None else lam * scale,
                    error_per_s=None if scale is None else err * scale, status=sp.status, message=sp.message,
                    impacts_per_period=sp.impacts / max(sp.shots * sp.periods_per_shot, 1), spectrum=sp,
                    method=method, period=period)


#: the largest magnitude of an initial state's numbers (:func:`simulate`): squares stay finite
STATE_MAX = 1e100


def _check_state(state, scene) -> np.ndarray:
    """An initial state (TypeError/ValueError): the scene's displacements and velocities
    (``(q, q')``, or ``(eta, eta')`` of a modal beam: ``n - 1`` numbers), optionally followed by the
    held flag (``n`` numbers, :meth:`initial_state`'s layout); returned with the flag (0, free,
    when it was left out).  The one check of every initial state a user gives (:func:`simulate`,
    and through it :func:`poincare` and :func:`lyapunov`): finite numbers, the held flag
    consistent with the state (:func:`_check_held`), nothing behind a rigid stop."""
    n = 2 * outputs(scene).n_modes + 1
    allowed = (f"{n - 1} or {n} finite numbers: the displacements and velocities{' (q, dq)' if n == 3 else ''}, "
               f"optionally followed by the held flag (0 free, 1 held on the upper stop, -1 on the lower one)")
    try:
        x = np.asarray(state, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"state = {quote_value(state)}: not numbers; allowed: {allowed}") from None
    if x.ndim != 1 or x.size not in (n - 1, n) or not np.isfinite(x).all():
        raise ValueError(f"state = {quote_value(state)}: allowed: {allowed}")
    if np.abs(x).max() > STATE_MAX:
        raise ValueError(f"state = {quote_value(state)}: allowed: |values| <= {STATE_MAX:g} (the record's energies "
                         f"and spreads square them: 1e300 overflows double precision)")
    x = np.append(x, 0.0) if x.size == n - 1 else x
    _check_held(state, scene, x)
    if behind_stop(scene, x[None, :])[0]:
        # the kernels would project it onto the stop and report a motion it never had
        g = stop_gaps(scene, x[None, :])[0]
        k = int(np.argmax(g))
        raise ValueError(f"state = {quote_value(state)}: lies behind stop {k} (gap {g[k]:.6g} > 0, the "
                         f"{'upper' if k == 0 else 'lower' if k == 1 else 'point'} stop); allowed: a state the "
                         f"motion can reach, every rigid stop's gap <= 0")
    return x


#: how far (relative to the stop's offset and the contact coordinate, or to the velocity's size) a
#: held state may lie off its stop or move along its normal: the kernels put a held state on its
#: stop to round-off (1e-16 relative); 1e-9 takes a state written out with ten digits
HELD_RTOL = 1e-9


def _stop_name(k: int, n_stops: int) -> str:
    return ("the stop" if n_stops == 1 else "the upper stop (stop 0)" if k == 0 else
            "the lower stop (stop 1)" if k == 1 else f"stop {k}")


def _held_codes(n_stops: int) -> str:
    """The held flags a scene of ``n_stops`` stops allows (:func:`vibeam.models.core.stops.held_code`)."""
    if n_stops == 0:
        return "0 (free: the scene has no stop)"
    if n_stops == 1:
        return "0 (free) or 1 (on the stop)"
    return (f"0 (free), 1 (on the upper stop), -1 (on the lower stop), or the sum of 2^k over the stops k it is on "
            f"(at most {2 ** n_stops - 1})")


def _check_held(state, scene, x) -> None:
    """The held flag ``x[-1]`` of an initial state against its coordinates (ValueError, one line).

    The flag names the stops the state is on (:func:`vibeam.models.core.stops.held_code`: 0 free,
    1 stop 0, -1 stop 1, else the bit mask).  The kernels take a flag as given: a held flag on a
    free state snapped it onto the stop (``q = -0.001`` held on the stop at 0 started at ``q =
    0``), and a flag naming a stop the scene lacks was read as free (issue 56).  So the flag must
    be a whole number naming stops of the scene; on a rigid (Newton) stop the state must lie on it
    (gap 0) with no velocity along its normal; in contact with a compliant stop, not outside it
    (gap >= 0); all to :data:`HELD_RTOL`.
    """
    stops, system = scene.stops, scene.system
    ns = len(stops)
    code = float(x[-1])
    allowed = _held_codes(ns)
    c = int(round(code))
    mask = 2 if c == -1 and ns >= 2 else c if c >= 0 else -1
    if code != c or mask < 0 or mask >= (1 << ns):
        why = "not a whole number" if code != c else f"names a stop the scene does not have ({ns} stop{'s' * (ns != 1)})"
        raise ValueError(f"state = {quote_value(state)}: held flag {code:g} {why}; allowed: {allowed}")
    if mask == 0:
        return
    n = system.omega.size
    eta, etad = x[:n], x[n:2 * n]
    for k, st in enumerate(stops):
        if not (mask >> k) & 1:
            continue
        r = st.relation
        w = system.contacts[r.row]
        g = r.sign * float(eta @ w) - r.offset
        g_scale = max(abs(r.offset), abs(float(eta @ w)), 1e-300)
        name = _stop_name(k, ns)
        if getattr(st.law, "kind", "") == "compliant":
            if g < -HELD_RTOL * g_scale:
                raise ValueError(f"state = {quote_value(state)}: held flag {code:g} puts it in contact with {name} "
                                 f"(compliant), but it lies outside it (gap {g:.6g} < 0); allowed: a contact state "
                                 f"at or inside its stop (gap >= 0), or flag 0")
            continue
        if abs(g) > HELD_RTOL * g_scale:
            raise ValueError(f"state = {quote_value(state)}: held flag {code:g} holds it on {name}, but it is not on "
                             f"it (gap {g:.6g}, {'free of' if g < 0 else 'behind'} it); allowed: a held state on its "
                             f"stop (gap 0) with no velocity along its normal, or flag 0 (free); flags: {allowed}")
        v = r.sign * float(etad @ w)
        if abs(v) > HELD_RTOL * max(float(np.linalg.norm(w) * np.linalg.norm(etad)), 1e-300):
            raise ValueError(f"state = {quote_value(state)}: held flag {code:g} holds it on {name}, but it moves "
                             f"along the stop's normal (velocity {v:.6g}); allowed: a held state on its stop with "
                             f"no velocity along its normal, or flag 0 (free: the motion decides)")


_WORK_ARGS = {"sweep.record_periods": "periods", "sweep.transient_periods": "transient",
              "sweep.samples_per_period": "samples_per_period", "sweep.Omega": "Omega"}


def _check_point_work(case, job, solver, Omega, transient, periods, spp, force, settings) -> None:
    """Refuse a point above the work limits of ``vibeam run`` (:data:`vibeam.runner.MAX_WORK_STEPS`,
    :data:`vibeam.runner.MAX_POINT_VALUES`) unless ``force``: a case's point by the runner's
    own estimate (:func:`vibeam.runner.check_work` of the one-point case), a model's by its
    per-point term (:func:`vibeam.runner.point_work`)."""
    if force:
        return
    if case is not None:
        data = case.model_dump()
        data["sweep"] = dict(data["sweep"], Omega=[Omega, Omega, 1], frequency_hz=None, direction="up",
                             transient_periods=transient, record_periods=periods, statistics_periods=0,
                             samples_per_period=spp)
        data["run"] = [job.run.model_dump()]
        data["map"] = None
        one = Case.model_validate(data)
        sw = dataclasses.replace(job.sweep, Omega=np.array([Omega]), direction="up", transient_periods=transient,
                                 record_periods=periods, statistics_periods=0, samples_per_period=spp)
        try:
            check_work(one, [dataclasses.replace(job, run=one.run[0], sweep=sw)], source="simulate")
        except InputError as e:
            msg = str(e).replace(f"'sweep.Omega' = {quote_value(one.sweep.Omega)}", f"Omega = {Omega!r}")
            msg = re.sub(r"'(sweep\.[a-z_A-Z]+)'", lambda m: _WORK_ARGS.get(m.group(1), m.group(0)), msg)
            raise InputError(msg.replace("the case needs", "the point needs")
                             .replace("pass --force", "pass force=True")) from None
        return
    w = point_work(Omega, transient, periods, spp, dofs=outputs(solver.scene).n_modes,
                   method=solver.name, transient_samples=int(settings.get("transient_samples", 16)),
                   scene=solver.scene)
    if w["point_values"] > MAX_POINT_VALUES:
        raise InputError(f"simulate: periods = {periods}, samples_per_period = {spp}: the point would record "
                         f"{w['point_values']:.3g} values (limit {MAX_POINT_VALUES:.0e}); record fewer periods or "
                         f"samples, or pass force=True")
    if w["steps"] > MAX_WORK_STEPS:
        raise InputError(f"simulate: Omega = {Omega:g}, transient = {transient}, periods = {periods}: the point needs "
                         f"about {w['steps']:.2g} solver steps, above the limit of {MAX_WORK_STEPS:.0e}; reduce "
                         f"them, or pass force=True")


def poincare(case, Omega: float | None = None, frequency_hz: float | None = None, periods: int = 64,
             transient: int | None = None, run: str | int = 0, samples_per_period: int | None = None,
             state=None, out=None, force: bool = False):
    """Poincaré sections at one forcing frequency (``vibeam poincare``): the stroboscopic samples
    ``(q, q')`` at forcing phase 0 after the transient, and the impact map (impact phase
    ``Omega t mod 2 pi`` against the pre-impact velocity) from the event kernel's impact log
    (:mod:`vibeam.analysis.poincare`).

    Parameters
    ----------
    case : Case, str, Path, dict or a model
        As :func:`simulate`.
    Omega, frequency_hz : float
        The forcing frequency (one of them), as :func:`simulate`.
    periods : int
        Forcing periods recorded: stroboscopic samples (default 64).
    transient : int, optional
        Periods simulated first (default: the case's ``transient_periods``; 2000 when that is
        ``"auto"`` or for a model).
    run, samples_per_period, state, force
        As :func:`simulate`.
    out : str or Path, optional
        A PNG file (written atomically) of the two sections.

    Returns
    -------
    vibeam.analysis.poincare.PoincareSection
        ``strobe_q``, ``strobe_dq`` (periods,), ``impact_phase`` (rad), ``impact_velocity``;
        ``plot()``, ``to_xarray()``; mm and mm/s for a physical scene (``scales``).

    Raises
    ------
    TypeError, ValueError
        As :func:`simulate` (one line naming the argument).
    """
    out = check_path(out, "out")
    if transient is None:
        t = None
        if isinstance(case, (Case, str, Path, dict)):
            t = load_case(case).sweep.transient_periods
        transient = 2000 if t in (None, "auto") else t
    sim = simulate(case, Omega=Omega, frequency_hz=frequency_hz, periods=periods, transient=transient, run=run,
                   samples_per_period=samples_per_period, state=state, force=force)
    sec = section(sim)
    if out is not None:
        plt.close(sec.plot(out))
    return sec
