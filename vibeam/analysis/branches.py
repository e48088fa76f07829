"""Continuation runs of a case (``method = "continuation"``): planning, the unit of work that
the one executor runs, results, the printed table and the plots.

A continuation run is one :class:`BranchTask`: it goes through :func:`vibeam.engine.sweep.run_lines`
beside the sweep lines of the case, on the same executor (local pool or dask), and returns
plain arrays (picklable).  In the worker it builds the fidelity's shooting problem from the
registration :data:`vibeam.models.SHOOTING` (no per-fidelity code here), finds the starting
orbits, runs :func:`vibeam.models.orbits.continuation.trace` and, for a ``[map]`` case, the
two-parameter curves of :func:`vibeam.models.orbits.continuation.trace_curve`.

Physical keys are continued through the scene's affine conversions (paper Eqs. 43-46; the
model spec's ``scene_parameter``), so ``F_p`` follows by the chain rule.
"""
from __future__ import annotations

import dataclasses
import json
import math
import time
import traceback
from dataclasses import dataclass, field, replace as dc_replace

import numpy as np
from matplotlib import patheffects

from vibeam.case.contact import model_with
from vibeam.case.expand import expand
from vibeam.case.paths import get_value, is_path, key_of
from vibeam.case.schema import check_frequency_range, continued_key
from vibeam.engine.records import summarize
from vibeam.engine.sweep import PointClock, Sweep, settle_transient
from vibeam.io.h5check import open_checked
from vibeam.io.netcdf import json_default, parameter_units, read_attrs, var, write_group
from vibeam.io.results import branch_name, read_branch_group
from vibeam.errors import CaseError
from vibeam.models import SHOOTING, make_solver, shooting_problem
from vibeam.models.orbits.continuation import (FOLD, GRAZING, PERIOD_DOUBLING, ContinuationError, FiniteDifferenceParameter,
                                        ScaledParameter, Settings, trace, trace_curves)
from vibeam.models.interrupts import reraise_interrupt
from vibeam.models.scene import outputs
from vibeam.plots import style
from vibeam.plots.lazy import plt
from vibeam.plots.style import label, proxy
from vibeam.plots.sweep import save_close

#: units of the continuation parameters (the HDF5 ``units`` attribute of ``parameter``)
PARAMETER_UNITS = {"Omega": "1 (forcing frequency / natural frequency)", "voltage": "V", "gain": "1/V",
                   "gap_mm": "mm (grazing gap at the sensor)", "damping_ratio": "1", "R": "1", "B": "1",
                   "Delta": "1", "beta": "1"}


def units_of(name: str) -> str:
    """Units of a continuation parameter, a flat key or a path into the scene (its last key)."""
    return PARAMETER_UNITS.get(name) or PARAMETER_UNITS.get(key_of(name)) or parameter_units(name)


BRANCH_UNITS = {
    "amplitude": "1 (Q = Delta - min q, paper Sec. 4.1)",
    "amplitude_mm": "mm (at the sensor)",
    "frequency_hz": "Hz",
    "impact_velocity": "1 (pre-impact velocity of each impact of the orbit, NaN padded)",
    "impact_phase": "rad (forcing phase of each impact, NaN padded)",
    "multipliers": "1 (Floquet multipliers, complex, by decreasing modulus)",
    "stable": "bool (all multipliers inside the unit circle)",
    "period": "forcing periods of the orbit",
    "impacts_per_period": "1/forcing period",
    "impacts_lower": "1 (impacts on the lower stop per orbit, two stops)",
    "impacts_per_period_lower": "1/forcing period (on the lower stop, two stops)",
    "state": "1 (state at forcing phase 0 of the fidelity's shooting problem)",
    "q_min": "1", "q_max": "1",
    "stuck_time": "1 (time on the stop per orbit, nondimensional)",
    "apex_gap": "1 (highest interior free-flight apex minus the stop, with two stops the nearer of that and the "
                "lower stop's gap at the deepest minimum; 0 = grazing)",
}


@dataclass(frozen=True)
class BranchTask:
    """One continuation run as a unit of work of :func:`vibeam.engine.sweep.run_lines`.

    Attributes
    ----------
    key, run : str
        Task key (unique in the run) and run name.
    spec : pydantic model spec
        The run's model table (case ``[model]`` with ``[run.model]``), rebuilt in the worker.
    parameter : str
        Continued key (``Omega`` or a model key).
    lo, hi : float
        Its range, in its own units.
    at : float or None
        Forcing frequency Omega of a continuation in another key.
    settings : dict
        The run's continuation settings (:class:`vibeam.case.schema.ContinuationRun`).
    sweep_periods : (int or "auto", int)
        Transient and recorded periods of a ``sweep`` start (``"auto"``: settled as the
        sweep settles its points, :func:`vibeam.engine.sweep.settle_transient`).
    curve_key : str or None
        The ``[map]`` parameter of a case with two-parameter curves.
    curve_range : (float, float) or None
        Its range.
    label : str or None
        The parameter as the case names it, when that is a path into the scene
        (``stops[1].law.R``: :mod:`vibeam.case.paths`) and ``parameter`` the flat key it
        stands for (``R_lower``); the results carry the label.
    table : dict or None
        The run's ``[model]`` table as written (overrides applied) when ``parameter`` is a path
        no flat key names (a law's stiffness, a stop's position): each value is set in it and
        the scene built again (:func:`spec_at`), ``d x / d p`` by finite differences.
    """

    key: str
    run: str
    spec: object
    parameter: str
    lo: float
    hi: float
    at: float | None
    settings: dict
    sweep_periods: tuple = (400, 16)
    curve_key: str | None = None
    curve_range: tuple | None = None
    label: str | None = None
    table: dict | None = None

    #: the progress bar of :func:`vibeam.engine.sweep.run_lines` advances per start (and curves)
    reports_progress = True

    @property
    def n_points(self) -> int:
        """Steps of the progress bar: each start tried (an end of the range or a value, times
        the kinds of start), and the two-parameter curves as one more."""
        return len(plan_starts(self)) * len(start_kinds(self)) + (1 if self.curve_key is not None else 0)

    def compute(self, report=None) -> list:
        """Run the continuation (in a worker); failures are statuses, never exceptions.
        ``report()`` is called after each start (tried, skipped or failed) and after the curves."""
        t0 = time.perf_counter()
        try:
            out = run_continuation(self, report)
        except Exception as e:  # a bug or an unforeseen numerical failure: recorded, not fatal
            reraise_interrupt(e)
            out = dict(branches=[], starts=[], curves=[], status="failed",
                       message=f"{type(e).__name__}: {e}; {traceback.format_exc(limit=3)}")
        out["wall_time_s"] = time.perf_counter() - t0
        return [out]

    def warm_up(self) -> None:
        """Load (or compile) this run's kernels in this process: the same continuation cut to 3
        points per branch, no switching, no curves, from the run's own starts (a start met only
        at the high end compiled its kernels in the workers: the SDOF averaging start's impact
        map, vibeam bench --compile), so that a forked pool worker inherits them and compiles
        nothing.  Failures are ignored: the run records them."""
        st = dict(self.settings, max_points=3, switch=False, curves=False)
        try:
            run_continuation(dataclasses.replace(self, settings=st, curve_key=None, curve_range=None))
        except Exception as e:
            reraise_interrupt(e)

    def lost_rows(self, err, attempts) -> list:
        return [dict(branches=[], starts=[], curves=[], status="failed", wall_time_s=0.0,
                     message=f"worker lost {attempts} time(s): {type(err).__name__}: {err}")]


# ----------------------------------------------------------------------------- planning
def plan(case, r, key: str = "continuation") -> BranchTask:
    """The :class:`BranchTask` of continuation run ``r`` of ``case``.

    Raises
    ------
    CaseError
        If the run's fidelity has no registered shooting problem, or its start cannot be
        served by it (one message naming the key and what is allowed).
    """
    i = case.run.index(r)
    spec = case.model_spec(dict(r.model)) if r.model else case.model_spec()
    fid = spec.fidelity
    if fid not in SHOOTING:
        raise CaseError(f"'run[{i}].method' = 'continuation' is not available for fidelity {fid!r} (no shooting "
                        f"problem registered in vibeam.models.SHOOTING); available for: {', '.join(sorted(SHOOTING))}")
    starts = ("sweep", "auto")
    if r.start not in starts:
        # the closed-form starts the scene offers (the averaging start: the one-mode oscillator's)
        starts += tuple(SHOOTING[fid].offered_starts(spec.scene()))
    if r.start not in starts:
        raise CaseError(f"'run[{i}].start' = {r.start!r} is not available for fidelity {fid!r}; allowed: "
                        f"{', '.join(starts)}")
    if not hasattr(spec, "scene_parameter"):
        if r.parameter != "Omega":
            raise CaseError(f"'run[{i}].parameter' = {r.parameter!r}: fidelity {fid!r} can be continued in "
                            f"'Omega' only")
    fn = _natural_frequency(spec)
    hz = case.sweep.frequency_hz is not None      # frequencies of the case in Hz
    # the frequencies against Omega's limit (a beam's natural frequency is known here, not at load)
    if r.parameter == "Omega" and r.range is not None:
        check_frequency_range(r.range, f"run[{i}].range", hz, fn if hz else 1.0)
    if r.at is not None:
        check_frequency_range([r.at, r.at], f"run[{i}].at", hz, fn if hz else 1.0)
    settings = case.run_settings(r)
    if r.parameter == "Omega":
        # range and start_at in the units of [sweep] (Hz for physical scenes)
        if r.range is not None:
            lo, hi = (v / fn for v in r.range) if hz else r.range
        else:
            grid = case.sweep.grid(fn)
            lo, hi = float(np.min(grid)), float(np.max(grid))
        if not isinstance(r.start_at, str) and hz:
            settings["start_at"] = r.start_at / fn
        at = None
    else:
        if r.range is not None:
            lo, hi = r.range
        else:
            v = case.map.grid()
            lo, hi = float(np.min(v)), float(np.max(v))
        at = r.at / fn if hz else r.at
    curve_key = curve_range = None
    if case.map is not None and r.curves:
        curve_key = case.map.parameter
        v = case.map.grid()
        curve_range = (float(np.min(v)), float(np.max(v)))
    table = model_with(case.model, dict(r.model))
    key_ = continued_key(spec, table, r.parameter) if hasattr(spec, "scene_parameter") else r.parameter
    return BranchTask(key=key, run=r.name, spec=spec, parameter=key_, label=r.parameter if key_ != r.parameter else None,
                      table=table if is_path(key_) and not _carried(spec, key_) else None, lo=float(lo), hi=float(hi),
                      at=at, settings=settings,
                      sweep_periods=(case.sweep.transient_periods, max(16, case.sweep.record_periods)),
                      curve_key=curve_key, curve_range=curve_range)


def _carried(spec, key: str) -> bool:
    """The scene's shooting problem carries ``key`` with its exact ``d x / d p`` (the spec's
    ``scene_parameter`` takes it)."""
    try:
        spec.scene_parameter(key)
    except (ValueError, AttributeError):
        return False
    return True


def _natural_frequency(spec):
    """``f_n`` of a physical scene (its builder's frequency, as the sweeps use it), None otherwise."""
    fn = getattr(spec.system, "natural_frequency_hz", None)
    if fn is None and getattr(spec, "physical", False):
        fn = outputs(spec.scene()).natural_frequency_hz
    return fn


def _with(spec, **over):
    """The spec with some keys (or continuation parameters) replaced, validated again: the
    canonical tables as written (every ``[model]`` is validated in them: :mod:`vibeam.case.expand`),
    each key set through the path it stands for (R -> stops[0].law.R, R_lower -> stops[1].law.R,
    voltage -> excitation.voltage: :func:`vibeam.case.paths.path_of`)."""
    return type(spec).model_validate(model_with(spec.model_dump(exclude_unset=True), over))


def spec_at(task: BranchTask, spec, value: float):
    """The scene's model table with the continuation parameter at ``value``: a flat key through
    the spec (:func:`_with`), a path set in the table as written (``task.table``)."""
    if task.table is None:
        return _with(spec, **{task.parameter: value})
    return type(spec).model_validate(expand(model_with(task.table, {task.parameter: float(value)})))


def task_problem(task: BranchTask, spec):
    """The shooting problem of a continuation run: :func:`problem` in a key the scene's problems
    carry, else (a path: ``task.table``) one problem per value, each at the run's frequency,
    with ``d x / d p`` by central differences (:class:`vibeam.models.orbits.continuation.FiniteDifferenceParameter`)."""
    if task.table is None:
        return problem(spec, task.parameter, task.at)

    p0 = float(get_value(task.table, task.parameter))
    return FiniteDifferenceParameter(lambda p: problem(spec_at(task, spec, p), "Omega", task.at),
                                     task.parameter, task.at, p0)


def problem(spec, key: str, at: float | None):
    """The shooting problem of ``spec`` continued in ``key`` (physical keys through the scene's
    affine conversion, :class:`vibeam.models.orbits.continuation.ScaledParameter`)."""
    path, factor, damping = spec.scene_parameter(key) if hasattr(spec, "scene_parameter") else (key, 1.0, None)
    prob = shooting_problem(spec.scene(), path, Omega=at, damping=damping)
    if path == key and factor == 1.0:
        return prob
    return ScaledParameter(prob, key, factor)


# ----------------------------------------------------------------------------- the run
def _sweep_start(task, spec, value):
    """Settled state and detected period of an event run at the start value (a sweep point)."""
    if task.parameter == "Omega":
        scene, Omega = spec.scene(), value
    else:
        scene, Omega = spec_at(task, spec, value).scene(), task.at
    solver = make_solver(scene, "event")
    n_tr = task.sweep_periods[0]
    if n_tr == "auto":
        # the sweep's own settling (transient_periods = "auto", e.g. a [quick] variant's)
        sw = Sweep(Omega=np.array([float(Omega)]), transient_periods="auto", record_periods=task.sweep_periods[1],
                   samples_per_period=16)
        tr, n_tr, _ = settle_transient(solver, float(Omega), None, sw, outputs(solver.scene).Delta, PointClock())
    else:
        tr = solver.point(float(Omega), None, n_tr, task.sweep_periods[1], 16)
    sm = summarize(tr, outputs(solver.scene).Delta)
    if tr.status == "failed":
        return None, 0, f"the event run failed: {tr.message}"
    n = int(sm["period"])
    if n == 0:
        return None, 0, (f"the sweep point is not periodic within 8 periods after {n_tr} transient "
                         f"periods (a sample of a non-periodic attractor)")
    return np.asarray(tr.final_state, float), max(n, 1), ""


def _start(task, spec, prob, kind, value):
    """``(x0, n, reason)`` of a start of one kind (``sweep``, ``linear``, ``averaging``)."""
    n = int(task.settings.get("n", 1))
    if kind == "sweep":
        x, nn, why = _sweep_start(task, spec, value)
        return (None, n, why) if x is None else (x[:int(prob.dim)], nn, "")
    if kind in getattr(prob, "starts", ()):
        x, why = prob.start(kind, value, n)
        return (None, n, why) if x is None else (np.asarray(x, float), n, "")
    return None, n, "not offered by this fidelity"


def _duplicate(branches, first, n) -> bool:
    """Whether the first point of a new start lies on a branch already traced."""
    for b in branches:
        if b.n != n:
            continue
        for q in b.points:
            if abs(q.p - first.p) <= 1e-9 * max(1.0, abs(first.p)) and \
                    np.max(np.abs(q.x - first.x)) <= 1e-6 * max(np.max(np.abs(first.x)), 1e-300):
                return True
    return False


def plan_starts(task: BranchTask) -> list:
    """``(value, direction)`` of each place a continuation run starts from (``start_at``)."""
    where = task.settings.get("start_at", "both")
    if where == "low":
        return [(task.lo, +1)]
    if where == "high":
        return [(task.hi, -1)]
    if where == "both":
        return [(task.lo, +1), (task.hi, -1)]
    return [(float(where), 0)]


def start_kinds(task: BranchTask) -> list:
    """The kinds of start tried at each place (``start``; ``auto``: linear, sweep, averaging)."""
    st = task.settings.get("start", "auto")
    return ["linear", "sweep", "averaging"] if st == "auto" else [st]


def run_continuation(task: BranchTask, report=None) -> dict:
    """Everything a continuation run computes, as plain arrays (see :func:`branch_arrays`).
    ``report()`` (optional) is called after each start and after the two-parameter curves."""
    st = task.settings
    settings = Settings(ds=st["ds"], ds_min=st["ds_min"], ds_max=st["ds_max"], max_points=st["max_points"],
                        max_period=st["max_period"], switch=st["switch"])
    spec = task.spec
    prob = task_problem(task, spec)
    ahead = getattr(prob, "compile_corrector_ahead", None)
    if ahead is not None:       # a first run: its corrector compiles in a second process meanwhile
        ahead(0.5 * (task.lo + task.hi), 1, True)
    tick = report if report is not None else (lambda: None)
    branches, starts = [], []
    kinds = start_kinds(task)
    for value, direction in plan_starts(task):
        for kind in kinds:
            try:
                _one_start(task, spec, prob, kind, value, direction, settings, branches, starts)
            finally:
                tick()
    out = dict(branches=[branch_arrays(b, spec, task) for b in branches], starts=starts, curves=[],
               status="ok" if branches else "failed",
               message="" if branches else "no branch could start: " + "; ".join(
                   f"{s['kind']} at {s['value']:.6g}: {s['message']}" for s in starts if s["status"] != "ok"))
    if task.curve_key is not None and branches:
        out["curves"] = _curves(task, spec, branches, settings)
    if task.curve_key is not None:
        tick()
    return out


def _one_start(task, spec, prob, kind, value, direction, settings, branches, starts) -> None:
    """Trace the branches of one start (``kind`` at ``value``) into ``branches``; its record (its
    status: ok, not_available, failed_start, failed, duplicate, ...) into ``starts``."""
    if kind != "sweep" and kind not in getattr(prob, "starts", ()):
        return
    x0, n, why = _start(task, spec, prob, kind, value)
    info = dict(value=value, kind=kind, n=n, status="ok", message=why)
    starts.append(info)
    if x0 is None:
        info["status"] = "not_available"
        return
    try:
        got = trace(prob, x0, value, n, task.lo, task.hi, direction, settings)
    except ContinuationError as e:
        info.update(status="failed_start", message=str(e))
        return
    except Exception as e:       # an unforeseen numerical failure: this start only
        reraise_interrupt(e)
        info.update(status="failed", message=f"{type(e).__name__}: {e}")
        return
    if not got[0].points:
        info.update(status=got[0].status, message=got[0].message)
        return
    if _duplicate(branches, got[0].points[0], got[0].n):
        info.update(status="duplicate", message="its orbit lies on a branch already traced")
        return
    base = len(branches)
    for b in got:
        b.index += base
        for bf in b.bifurcations:
            bf.branch = b.index
        b.origin = b.origin.replace("of branch ", "of branch #")
    branches.extend(got)


def _curves(task, spec, branches, settings) -> list:
    """Two-parameter curves of the folds, period doublings and grazings of ``branches``,
    seeded at ``slices`` values of the map parameter (see trace_curve)."""
    k2 = task.curve_key
    lo2, hi2 = task.curve_range
    st = task.settings

    def factory(free: str, fixed: float):
        # free = "p1": continue in the frequency at the map value `fixed`; "p2": in the map
        # key at the frequency `fixed` (native Omega)
        if free == "p1":
            return problem(_with(spec, **{k2: float(fixed)}), task.parameter, task.at)
        return problem(spec, k2, float(fixed))

    seeds = []
    v0 = float(spec.shorthand()[k2])         # the map's key by its flat name (the SDOF's or the beam's)
    for b in branches:
        for bf in b.bifurcations:
            if bf.type in (FOLD, PERIOD_DOUBLING, GRAZING):
                seeds.append((bf, v0))
    # interior slices of the map range (seeds on the edges give curves that end at once)
    slices = [v for v in np.linspace(lo2, hi2, st.get("slices", 3) + 2)[1:-1]
              if abs(v - v0) > 1e-3 * (hi2 - lo2)]
    curves = trace_curves(factory, seeds, (task.lo, task.hi), (lo2, hi2), slices, settings,
                          max_points=st.get("curve_points", 200), base_value=v0,
                          seed_slice=lambda v: _slice_bifurcations(task, spec, v, settings),
                          max_period=st.get("curve_max_period", 2))
    return [dict(type=c.type, p1=np.asarray(c.p1), p2=np.asarray(c.p2), n=c.n, status=c.status,
                 message=c.message) for c in curves]


def _slice_bifurcations(task, spec, v, settings):
    """Bifurcations of the one-parameter branches at map value ``v`` (seeds of more curves)."""
    sp2 = _with(spec, **{task.curve_key: float(v)})
    prob = problem(sp2, task.parameter, task.at)
    out = []
    kinds = ["linear", "sweep", "averaging"] if task.settings.get("start", "auto") == "auto" \
        else [task.settings["start"]]
    for value, direction in ((task.lo, +1), (task.hi, -1)):
        x0 = None
        for kind in kinds:
            if kind != "sweep" and kind not in getattr(prob, "starts", ()):
                continue
            x0, n, why = _start(dc_replace(task, spec=sp2), sp2, prob, kind, value)
            if x0 is not None:
                break
        if x0 is None:
            continue
        if n > task.settings.get("curve_max_period", 2):
            continue
        try:
            got = trace(prob, x0, value, n, task.lo, task.hi, direction,
                        dc_replace(settings, max_branches=2, max_period=task.settings.get("curve_max_period", 2)))
        except Exception as e:
            reraise_interrupt(e)
            continue
        for b in got:
            out.extend(b.bifurcations)
    return out


def branch_arrays(b, spec, task) -> dict:
    """Per-point arrays of a branch plus its metadata, with ``frequency_hz`` / ``amplitude_mm``
    for physical scenes; bifurcations as a list of dicts."""
    d = b.arrays() if b.points else {}
    fn = _natural_frequency(spec)
    L = _length_m(spec)
    gap = _gap_fallback(spec, task)
    if d and gap is not None and np.isnan(d["amplitude"]).all():
        d["amplitude"] = gap - d["q_min"]          # a problem that does not fill Shot.gap
    if d:
        if fn and task.parameter == "Omega":
            d["frequency_hz"] = d["parameter"] * fn
        if L:
            d["amplitude_mm"] = d["amplitude"] * L * 1e3
    bifs = [dict(type=f.type, parameter=f.parameter, branch=f.branch, index=f.index, n=f.n,
                 amplitude=f.amplitude if math.isfinite(f.amplitude) or gap is None else _bif_amplitude(b, f, gap),
                 detail=f.detail, state=np.asarray(f.x), multipliers=np.asarray(f.multipliers))
            for f in b.bifurcations]
    return dict(index=b.index, n=b.n, status=b.status, message=b.message, origin=b.origin, data=d,
                bifurcations=bifs)


def _gap_fallback(spec, task):
    """``Delta`` of the output coordinate when the parameter does not change it (for shooting
    problems that leave ``Shot.gap`` unset), else None."""
    if task.parameter != "Omega":
        return None
    try:
        return float(outputs(spec.scene()).Delta)
    except Exception:
        return None


def _bif_amplitude(b, f, gap):
    """``Q`` at a bifurcation from the branch point next to it (problems without ``Shot.gap``)."""
    k = min(max(f.index, 0), len(b.points) - 1)
    return gap - b.points[k].shot.q_min if b.points else math.nan


def _length_m(spec):
    """``L`` of a physical scene (``amplitude_mm = Q L``, as the sweeps), None otherwise."""
    if not getattr(spec, "physical", False):
        return None
    return outputs(spec.scene()).length_m


# ----------------------------------------------------------------------------- results
@dataclass
class ContinuationResult:
    """The branches, bifurcations and curves of one continuation run."""

    name: str
    fidelity: str
    parameter: str
    settings: dict
    branches: list
    starts: list
    curves: list
    status: str
    message: str
    wall_time_s: float
    attrs: dict = field(default_factory=dict)

    def __repr__(self) -> str:
        """``ContinuationResult('exact': Omega, 2 branches, 1 curves, ok)``: never the arrays."""
        return (f"{type(self).__name__}({self.name!r}: {self.parameter}, {len(self.branches)} branches, "
                f"{len(self.curves)} curves, {self.status})")

    def write(self, f) -> None:
        """This run's ``/branches/<run>/`` group into the open HDF5 file ``f``
        (:func:`write_branches`; what the results writer calls)."""
        write_branches(f, [self])

    @property
    def bifurcations(self) -> list:
        return [bf for b in self.branches for bf in b["bifurcations"]]

    def bifurcation_table(self) -> dict:
        """``/branches/<run>/bifurcations`` datasets: ``type``, ``parameter``, ``branch``, ``period``,
        ``amplitude``, ``detail`` (+ ``frequency_hz`` / ``amplitude_mm``)."""
        bfs = self.bifurcations
        t = dict(type=np.array([b["type"] for b in bfs], dtype=object),
                 parameter=np.array([b["parameter"] for b in bfs], float),
                 branch=np.array([b["branch"] for b in bfs], np.int64),
                 period=np.array([b["n"] for b in bfs], np.int64),
                 amplitude=np.array([b["amplitude"] for b in bfs], float),
                 detail=np.array([b["detail"] for b in bfs], dtype=object))
        fn, L = self.attrs.get("natural_frequency_hz"), self.attrs.get("length_m")
        if fn and self.parameter == "Omega":
            t["frequency_hz"] = t["parameter"] * fn
        if L:
            t["amplitude_mm"] = t["amplitude"] * L * 1e3
        return t


def assemble(task: BranchTask, row: dict) -> ContinuationResult:
    spec = task.spec
    name = task.label or task.parameter
    attrs = {"parameter": name, "range": np.array([task.lo, task.hi]),
             "parameter_units": units_of(name)}
    fn, L = _natural_frequency(spec), _length_m(spec)
    if fn:
        attrs["natural_frequency_hz"] = fn
    if L:
        attrs["length_m"] = L
    if task.at is not None:
        attrs["Omega"] = task.at
        if fn:
            attrs["frequency_hz"] = task.at * fn
    if task.curve_key:
        attrs["curve_parameter"] = task.curve_key
    attrs["model"] = spec.as_written(exclude_unset=True)
    return ContinuationResult(name=task.run, fidelity=spec.fidelity, parameter=name,
                              settings=task.settings, branches=row.get("branches", []),
                              starts=row.get("starts", []), curves=row.get("curves", []),
                              status=row.get("status", "failed"), message=row.get("message", ""),
                              wall_time_s=float(row.get("wall_time_s", 0.0)), attrs=attrs)


def _cf(text: str) -> tuple:
    """``(units, long_name)`` from a ``"unit (what)"`` text of :data:`BRANCH_UNITS` /
    :data:`PARAMETER_UNITS` (UDUNITS: ``1/V`` is ``V-1``; flags and counts are ``1``)."""
    head, _, rest = str(text).partition(" (")
    rest = rest.rstrip(")")
    if head in ("1/V",):
        return "V-1", rest or "per volt"
    if " " in head or head in ("bool", "1/forcing period") or "/" in head:
        return "1", (rest or text) if head not in ("1/forcing period",) else "per forcing period"
    return head or "1", rest


# trailing axes of the per-point branch data
_BRANCH_EXTRA = {"impact_velocity": "impact", "impact_phase": "impact", "multipliers": "multiplier",
                 "state": "state_component"}


def _padded(arrays: list, n_p: int, extra: tuple):
    """The arrays of the branches padded along the point (and trailing) axes: NaN for floats,
    False / 0 / '' for flags, integers and text (``n_points`` says what is data)."""
    a0 = next((np.asarray(a) for a in arrays if np.asarray(a).size or np.asarray(a).ndim), np.zeros(0))
    kind = a0.dtype.kind
    if kind in "US" or a0.dtype == object:
        out = np.full((len(arrays), n_p) + extra, "", dtype=object)
    elif kind == "b":
        out = np.zeros((len(arrays), n_p) + extra, bool)
    elif kind in "iu":
        out = np.zeros((len(arrays), n_p) + extra, a0.dtype)
    else:
        out = np.full((len(arrays), n_p) + extra, np.nan, dtype=np.result_type(a0.dtype, float))
    for i, a in enumerate(arrays):
        a = np.asarray(a)
        if a.size:
            out[(i,) + tuple(slice(0, s) for s in a.shape)] = a
    return out


def branch_variables(r) -> tuple:
    """The variables of ``/branches/<run>/`` (:func:`vibeam.io.results.write_group`): every branch
    on the dimensions (branch, point), the bifurcations on (bifurcation), the two-parameter
    curves on (curve, curve_point).  Returns ``(variables, subgroups)``."""
    B = r.branches
    lens = [len(b["data"].get("parameter", ())) for b in B]
    n_p = max(lens, default=0)
    v = {"branch": var(("branch",), np.array([b["index"] for b in B], np.int64), "1",
                       "branch index (the order the branches were traced)"),
         "n_points": var(("branch",), np.array(lens, np.int64), "1",
                         "points of the branch (the rest of the point dimension is padding)"),
         "branch_period": var(("branch",), np.array([b["n"] for b in B], np.int64), "1",
                              "period-n of the branch's orbits"),
         "branch_status": var(("branch",), np.array([str(b["status"]) for b in B], dtype=object), None,
                              "how the branch ended"),
         "branch_message": var(("branch",), np.array([str(b["message"]) for b in B], dtype=object), None,
                               "detail of the branch's status"),
         "branch_origin": var(("branch",), np.array([str(b["origin"]) for b in B], dtype=object), None,
                              "where the branch started (a start or a branch switch)")}
    keys = list(dict.fromkeys(k for b in B for k in b["data"]))
    for k in keys:
        arrays = [np.asarray(b["data"].get(k, np.zeros(0))) for b in B]
        nd = max(a.ndim for a in arrays)
        extra = tuple(max((a.shape[i] if a.ndim > i else 0) for a in arrays) for i in range(1, nd))
        dims = ("branch", "point") + tuple(_BRANCH_EXTRA.get(k, f"{k}_dim{i}") if i == 0 else f"{k}_dim{i}"
                                           for i in range(len(extra)))
        u, ln = _cf(units_of(r.parameter) if k == "parameter" else BRANCH_UNITS.get(k, k))
        if k == "parameter":
            ln = f"continuation parameter {r.parameter}" + (f" ({ln})" if ln else "")
        data = _padded(arrays, n_p, extra)
        text = data.dtype == object
        v[k] = var(dims, data, None if text else u, ln or k.replace("_", " "))
    groups = {}
    t = r.bifurcation_table()
    bv = {}
    for k, a in t.items():
        a = np.asarray(a)
        name = "bifurcation_branch" if k == "branch" else k      # "branch" is the parent's dimension
        u, ln = _cf(units_of(r.parameter) if k == "parameter" else
                    {"type": "1 (fold, period_doubling, neimark_sacker, grazing, sticking)",
                     "branch": "1 (index of the branch it lies on)", "period": "1 (period-n of that branch)",
                     "detail": "1 (what was located)"}.get(k, BRANCH_UNITS.get(k, k)))
        bv[name] = var(("bifurcation",), a, None if a.dtype == object or a.dtype.kind in "US" else u,
                       ln or k.replace("_", " "), **({"vibeam_name": k} if name != k else {}))
    groups["bifurcations"] = (bv, {"types": "fold, period_doubling, neimark_sacker, grazing, sticking"})
    if r.curves:
        C = r.curves
        key2 = r.attrs.get("curve_parameter", "parameter2")
        n_c = max(len(c["p1"]) for c in C)
        fn = r.attrs.get("natural_frequency_hz") if r.parameter == "Omega" else None
        cv = {"curve": var(("curve",), np.arange(len(C)), "1", "curve index"),
              "n_curve_points": var(("curve",), np.array([len(c["p1"]) for c in C], np.int64), "1",
                                    "points of the curve (the rest is padding)"),
              "curve_type": var(("curve",), np.array([c["type"] for c in C], dtype=object), None,
                                "bifurcation the curve follows"),
              "curve_status": var(("curve",), np.array([str(c["status"]) for c in C], dtype=object), None,
                                  "how the curve ended"),
              "curve_message": var(("curve",), np.array([str(c["message"]) for c in C], dtype=object), None,
                                   "detail of the curve's status"),
              "curve_period": var(("curve",), np.array([c["n"] for c in C], np.int64), "1",
                                  "period-n of the orbits along the curve")}
        u1, _ = _cf(units_of(r.parameter))
        cv["parameter"] = var(("curve", "curve_point"), _padded([c["p1"] for c in C], n_c, ()), u1,
                              f"continuation parameter {r.parameter}")

        cv[key2] = var(("curve", "curve_point"), _padded([c["p2"] for c in C], n_c, ()), parameter_units(key2),
                       f"second parameter {key2}")
        if fn:
            cv["frequency_hz"] = var(("curve", "curve_point"),
                                     _padded([np.asarray(c["p1"]) * fn for c in C], n_c, ()), "Hz",
                                     "forcing frequency f")
        groups["curves"] = (cv, {"curve_parameter": key2})
    return v, groups


def write_branches(f, results: list) -> None:
    """``/branches/<run>/`` of every continuation run into the open HDF5 file ``f`` through the
    one labelled-data writer (:func:`vibeam.io.results.write_group`): the branches on
    (branch, point), ``bifurcations/`` on (bifurcation), ``curves/`` on (curve, curve_point)."""
    for r in results:
        v, groups = branch_variables(r)
        attrs = {"fidelity": r.fidelity, "method": "continuation",
                 "settings": json.dumps(r.settings, default=json_default), "wall_time_s": r.wall_time_s,
                 "status": r.status, "message": r.message,
                 "starts": json.dumps(r.starts, default=json_default), **r.attrs}
        write_group(f, f"branches/{r.name}", v, attrs, groups)


# ----------------------------------------------------------------------------- printing
_SHORT_UNITS = {"voltage": "V", "gain": "1/V", "gap_mm": "mm"}


def _x(r: ContinuationResult, p: float) -> str:
    fn = r.attrs.get("natural_frequency_hz")
    if r.parameter == "Omega":
        return f"{p * fn:.6f} Hz (Omega {p:.8f})" if fn else f"Omega = {p:.10f}"
    return f"{r.parameter} = {p:.10g} {_SHORT_UNITS.get(key_of(r.parameter), '')}".rstrip()


def print_results(results: list) -> None:
    """The bifurcation points of every continuation run; for several runs in the frequency
    (a fidelity ladder), their fold and period-doubling frequencies side by side."""
    for r in results:
        print(f"\ncontinuation '{r.name}' ({r.fidelity}, in {r.parameter}, {r.wall_time_s:.2f} s): "
              f"{len(r.branches)} branch(es), {sum(len(b['data'].get('parameter', [])) for b in r.branches)} points")
        for s in r.starts:
            print(f"  start {s['kind']} (period {s['n']}) at {_x(r, s['value'])}: {s['status']}"
                  + (f": {s['message']}" if s["message"] else ""))
        if r.status != "ok":
            print(f"  {r.status}: {r.message}")
        for b in r.branches:
            d = b["data"]
            span = (f"{_x(r, float(np.min(d['parameter'])))} .. {_x(r, float(np.max(d['parameter'])))}"
                    if d else "no points")
            print(f"  branch {branch_name(b)}: {span}; {b['status']}: {b['message']}")
        bfs = r.bifurcations
        if bfs:
            amp = "amplitude_mm" if r.attrs.get("length_m") else "amplitude"
            unit = "Q (mm)" if amp == "amplitude_mm" else "Q"
            print(f"  {'type':<16}{'at':<40}{unit:>12}{'n':>4}{'branch':>8}  detail")
            L = r.attrs.get("length_m")
            for bf in bfs:
                Q = bf["amplitude"] * L * 1e3 if L else bf["amplitude"]
                print(f"  {bf['type']:<16}{_x(r, bf['parameter']):<40}{Q:>12.6g}{bf['n']:>4}{bf['branch']:>8}  "
                      f"{bf['detail']}")
        for c in r.curves:
            print(f"  curve {c['type']} (period {c['n']}): {len(c['p1'])} points; {c['status']}"
                  + (f": {c['message']}" if c['message'] else ""))
    freq = [r for r in results if r.parameter == "Omega"]
    if len(freq) > 1:
        _print_rungs(freq)


def _print_rungs(results: list) -> None:
    """Fold and period-doubling frequencies of the period-1 branches of every run side by side.

    A rung may have several of each (e.g. the fold where a down sweep jumps and folds of a
    small chatter orbit): they are numbered by decreasing amplitude ``Q``, which pairs the
    same bifurcation of topologically equal branches across rungs whose frequencies shift
    (numbering by frequency would pair different ones); each cell gives the frequency and
    ``Q`` there."""
    fn_all = all(r.attrs.get("natural_frequency_hz") for r in results)
    unit = "Hz" if fn_all else "Omega"
    L_all = all(r.attrs.get("length_m") for r in results)
    rows = {}
    for r in results:
        fn = r.attrs.get("natural_frequency_hz") if fn_all else 1.0
        L = r.attrs.get("length_m") if L_all else None
        for kind in ("fold", "period_doubling"):
            seen = {}
            for bf in r.bifurcations:
                if bf["type"] == kind and bf["n"] == 1:
                    Q = bf["amplitude"] * L * 1e3 if L else bf["amplitude"]
                    seen.setdefault(round(bf["parameter"] * fn, 9), Q)
            vals = sorted(seen.items(), key=lambda fq: -fq[1] if math.isfinite(fq[1]) else math.inf)
            for j, fq in enumerate(vals):
                rows.setdefault((kind, j), {})[r.name] = fq
    if not rows:
        return
    qu = "Q mm" if L_all else "Q"
    print(f"\nfold and period-doubling frequencies of the period-1 branches ({unit}; {qu} in brackets; "
          f"numbered by decreasing Q), run by run:")
    head = f"{'':<20}" + "".join(f"{r.name[:22]:>24}" for r in results)
    print(head)
    for (kind, j), vals in sorted(rows.items()):
        print(f"{kind + ' ' + str(j + 1):<20}" + "".join(
            f"{vals[r.name][0]:>13.6f} ({vals[r.name][1]:7.4g})" if r.name in vals else f"{'-':>24}"
            for r in results))


# ----------------------------------------------------------------------------- plots
# bifurcation markers: colours apart from every branch colour (vibeam.plots.style.BRANCH_STYLES:
# blue, vermillion, green, purple), drawn over the branches with a thin black rim
MARKERS = {"fold": ("s", "#777777", "fold"), "period_doubling": ("D", "#000000", "period doubling"),
           "neimark_sacker": ("*", "#F0E442", "Neimark-Sacker"), "grazing": ("v", "#882255", "grazing"),
           "sticking": ("P", "#56B4E9", "sticking")}
BIFURCATION_MS = 5.5
#: the end of a branch the corrector could not continue (status ``no_convergence``: the step fell
#: below ``ds_min``): a white cross rimmed in black, apart from every branch colour and from the
#: bifurcation markers; the continuation does not say that the branch ends there, only that it was
#: not followed further
END_MARKER = ("X", "#FFFFFF", "branch not continued past here: no convergence (step below ds_min)")
#: bifurcation points of one type nearer than this fraction of the axes are drawn once
MARKER_SPACING = 0.015


# line styles of the two-parameter curves (drawn black over the maps' class colours)
CURVE_STYLES = {"grazing": "-", "fold": "--", "period_doubling": ":", "neimark_sacker": "-.",
                "sticking": (0, (1, 3))}


def _param_label(r, use_hz):
    if use_hz:
        return label("forcing frequency f", "Hz")
    if r.parameter == "Omega":
        return label(r"forcing frequency $\Omega = f/f_n$", None)
    return label(r.parameter, parameter_units(r.parameter))


def _apart(points, xspan, yspan, frac: float = MARKER_SPACING) -> list:
    """The bifurcation points of one type that are at least ``frac`` of the axes apart (in x or
    y, as fractions of the spans): nearer ones (the same bifurcation found from two branches,
    or two closer than a marker) are drawn once, so no marker hides another."""
    kept = []
    for p in points:
        if all(abs(p[0] - q[0]) >= frac * xspan or abs(p[1] - q[1]) >= frac * yspan for q in kept):
            kept.append(p)
    return kept


def continuation_figure(r: ContinuationResult, sweep_runs: list, title: str = "", case=None):
    """The FRC of a continuation run in the style of every vibeam figure (:mod:`vibeam.plots.style`).

    Each period has its colour and marker (:func:`vibeam.plots.style.branch_style`: period-1
    blue circles, period-2 vermillion triangles, period-4 green squares, period-8 purple
    pentagons), stable stretches solid and unstable ones dashed (said in the legend);
    bifurcations are marked in colours apart from every branch colour (period doubling black
    diamonds), one marker per point (:func:`_apart`); the case's sweep points are overlaid
    (up filled, down open, grey) when there are any, and only then does the subtitle give the
    sweep's settings.  The last point of a branch that ended in ``no_convergence`` is marked
    (:data:`END_MARKER`): the corrector gave up there, the branch may go on.  A Figure."""
    fn, L = r.attrs.get("natural_frequency_hz"), r.attrs.get("length_m")
    use_hz = bool(fn) and r.parameter == "Omega"
    xs = fn if use_hz else 1.0
    ys = L * 1e3 if L else 1.0
    with style.context():
        fig, ax = plt.subplots(figsize=(8.0, 4.6))
        handles, overlaid = [], False
        if r.parameter == "Omega":
            for s in sweep_runs:
                d = s.data
                x = d["frequency_hz"] if use_hz and "frequency_hz" in d else d["Omega"]
                y = d["amplitude_mm"] if L and "amplitude_mm" in d else d["amplitude"]
                dirs = np.asarray([str(v) for v in d.get("direction", ["up"] * len(x))])
                for dname in ("up", "down"):
                    sel = dirs == dname
                    if sel.any():
                        overlaid = True
                        fill = style.DIRECTIONS[dname]["fill"]
                        ax.plot(np.asarray(x)[sel], np.asarray(y)[sel], ls="none", marker="o",
                                ms=3.5 if fill else 6, mfc="0.6" if fill else "none", mec="0.6", zorder=1)
                        handles.append(style.proxy("0.6", marker="o", fill=fill,
                                                   label=f"sweep '{s.name}' ({dname})"))
        periods, stab = [], set()
        for b in r.branches:
            d = b["data"]
            if not d:
                continue
            c, mk = style.branch_style(b["n"])
            x, y, st = d["parameter"] * xs, d["amplitude"] * ys, d["stable"]
            k0 = 0
            for k in range(1, len(x) + 1):      # runs of equal stability, solid / dashed
                if k == len(x) or st[k] != st[k0]:
                    seg = slice(k0, min(k + 1, len(x)))
                    ax.plot(x[seg], y[seg], "-" if st[k0] else "--", color=c, lw=1.3, zorder=2, marker=mk,
                            ms=4, mfc=c if st[k0] else "white", mec=c, markevery=0.08)   # evenly along the line
                    stab.add(bool(st[k0]))
                    k0 = k
            if b["n"] not in periods:
                periods.append(b["n"])
        ends = [(b["data"]["parameter"][-1] * xs, b["data"]["amplitude"][-1] * ys) for b in r.branches
                if str(b.get("status", "")) == "no_convergence" and b["data"] and len(b["data"]["parameter"])]
        if ends:
            mk, c, lab = END_MARKER
            ax.plot([p[0] for p in ends], [p[1] for p in ends], ls="none", marker=mk, color="k", mfc=c, mec="k",
                    mew=1.0, ms=BIFURCATION_MS + 2.5, zorder=6 + len(MARKERS), gid="no_convergence")
            end = style.proxy("k", marker=mk, ms=BIFURCATION_MS + 2.5,
                              label=f"{lab}{f' ({len(ends)} branches)' if len(ends) > 1 else ''}")
            end.set_markerfacecolor(c)
            end.set_markeredgewidth(1.0)
            handles_end = [end]
        else:
            handles_end = []
        for n in sorted(periods):
            c, mk = style.branch_style(n)
            handles.append(style.proxy(c, ls="-", marker=mk, ms=4, label=f"period-{n} branch"))
        if True in stab:
            handles.append(style.proxy("0.25", ls="-", label="stable (solid line, filled markers)"))
        if False in stab:
            handles.append(style.proxy("0.25", ls="--", fill=False, marker="o", ms=4,
                                       label="unstable (dashed line, open markers)"))
        ax.relim()
        ax.autoscale_view()
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        by_type: dict = {}
        for bf in r.bifurcations:
            by_type.setdefault(bf["type"], []).append((bf["parameter"] * xs, bf["amplitude"] * ys))
        for kind, pts in by_type.items():
            mk, c, lab = MARKERS.get(kind, ("o", "k", kind))
            found = [p for p in pts if np.isfinite(p[0]) and np.isfinite(p[1])]
            pts = _apart(found, x1 - x0, y1 - y0)
            if not pts:
                continue
            if len(pts) < len(found):
                lab = f"{lab} ({len(found)} found; {len(found) - len(pts)} within a marker of another)"
            px, py = zip(*pts)
            ax.plot(px, py, ls="none", marker=mk, color=c, mfc=c, ms=BIFURCATION_MS, mec="k", mew=0.5,
                    zorder=5 + list(MARKERS).index(kind) if kind in MARKERS else 5)
            handles.append(style.proxy(c, marker=mk, label=lab, ms=BIFURCATION_MS))
        handles += handles_end
        ax.set_xlabel(_param_label(r, use_hz))
        ax.set_ylabel(style.label(r"amplitude at the sensor, $U(L_S)$", "mm") if L else
                      style.label(r"amplitude $Q = \Delta - \min q$", None))
        style.legend_outside(fig, handles)
        style.titles(fig, title or f"continuation '{r.name}'",
                     style.subtitle(case, runs=[r], sweep=overlaid)
                     + ("; sweeps overlaid (grey)" if overlaid else "; no sweep overlaid"))
    return fig


def plot_continuation(r: ContinuationResult, sweep_runs: list, path, title: str = "", case=None):
    """:func:`continuation_figure` saved to ``path``; returns the path."""
    return save_close(continuation_figure(r, sweep_runs, title, case), path)


def plot_curves_on(ax, results: list, frequency_hz: bool) -> list:
    """Draw the two-parameter curves of ``results`` on a map axis (x: frequency, y: the map
    parameter); returns one legend handle per kind of curve (the figure's legend takes them)."""
    halo = [patheffects.withStroke(linewidth=3.2, foreground="white")]
    seen, handles = set(), []
    for r in results:
        fn = r.attrs.get("natural_frequency_hz") if frequency_hz else 1.0
        for c in r.curves:
            if len(c["p1"]) < 2:
                continue
            mk, col, lab = MARKERS.get(c["type"], ("o", "k", c["type"]))
            ls = CURVE_STYLES.get(c["type"], "-")
            lab = f"{lab} curve (period {c['n']})"
            # black with a white halo: readable over every class colour of a map
            ax.plot(np.asarray(c["p1"]) * (fn or 1.0), c["p2"], ls=ls, color="k", lw=1.5, path_effects=halo)
            if lab not in seen:
                seen.add(lab)
                handles.append(proxy("k", ls=ls, label=lab, lw=1.5))
    return handles


def curves_figure(r: ContinuationResult, title: str = "", case=None):
    """The two-parameter curves of one run alone (frequency x the second parameter); a Figure."""
    fn = r.attrs.get("natural_frequency_hz")
    with style.context():
        fig, ax = plt.subplots(figsize=(7.5, 4.6))
        handles = plot_curves_on(ax, [r], bool(fn))
        key2 = r.attrs.get("curve_parameter", "")
        ax.set_xlabel(style.label("forcing frequency f", "Hz") if fn else
                      style.label(r"forcing frequency $\Omega = f/f_n$", None))
        ax.set_ylabel(style.label(key2, parameter_units(key2)))
        lo, hi = r.attrs["range"]
        ax.set_xlim(lo * (fn or 1.0), hi * (fn or 1.0))
        style.legend_outside(fig, handles)
        style.titles(fig, title or f"two-parameter curves of '{r.name}'",
                     style.subtitle(case, runs=[r], exclude=(key2,)))
    return fig


def plot_curves(r: ContinuationResult, path, title: str = "", case=None):
    """:func:`curves_figure` saved to ``path``; returns the path."""
    return save_close(curves_figure(r, title, case), path)


# ----------------------------------------------------------------------------- reading back
def _decoded(attrs: dict) -> dict:
    """Group attributes as written by :func:`write_branches`: JSON ones (``json_attrs``, and
    ``settings``/``starts``) back to Python values, numpy scalars to Python numbers."""
    a = dict(attrs)
    for k in set(str(a.pop("json_attrs", "")).split()) | {"settings", "starts"}:
        if isinstance(a.get(k), str):
            try:
                a[k] = json.loads(a[k])
            except ValueError:
                pass
    return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in a.items()}


def read_continuation(path) -> list:
    """Every ``/branches/<run>/`` group of a results file back as a :class:`ContinuationResult`
    (as :func:`assemble` built it: branches with their per-point ``data``, bifurcations and
    two-parameter curves), so that the figures and tables work on a file as on a fresh run.

    Parameters
    ----------
    path : str or Path
        A results file (``results.h5``, layout 2).

    Returns
    -------
    list of ContinuationResult
        In the order of the file's groups (empty if it has no ``/branches``).  Per-point arrays
        lose their padding (``n_points``); the bifurcations' ``state`` and ``multipliers``
        (not stored) are absent.
    """
    out = []
    with open_checked(path) as f:
        for name, g in f.get("branches", {}).items():
            d = read_branch_group(g)
            a = _decoded(read_attrs(g))
            bt = d.pop("bifurcations", {})
            cs = d.pop("curves", {})
            bifs = [dict(type=str(bt["type"][i]), parameter=float(bt["parameter"][i]), branch=int(bt["branch"][i]),
                         n=int(bt["period"][i]), amplitude=float(bt["amplitude"][i]), detail=str(bt["detail"][i]))
                    for i in range(len(bt.get("type", ())))]
            branches = []
            for b in d.values():
                if not isinstance(b, dict) or "attrs" not in b:
                    continue
                ba = b["attrs"]
                data = {k: v for k, v in b.items() if k != "attrs"}
                branches.append(dict(index=int(ba["index"]), n=int(ba["n"]), status=ba["status"],
                                     message=ba["message"], origin=ba["origin"], data=data,
                                     bifurcations=[x for x in bifs if x["branch"] == int(ba["index"])]))
            branches.sort(key=lambda b: b["index"])
            key2 = str(cs.get("attrs", {}).get("curve_parameter", a.get("curve_parameter", "parameter2")))
            curves = [dict(type=c["attrs"]["type"], p1=np.asarray(c["parameter"]), p2=np.asarray(c[key2]),
                           n=int(c["attrs"]["period"]), status=c["attrs"]["status"], message=c["attrs"]["message"])
                      for k, c in sorted(cs.items()) if k != "attrs"]
            settings = a.pop("settings", {})
            starts = a.pop("starts", [])
            a.pop("method", None)
            if "range" in a:
                a["range"] = np.asarray(a["range"], float)
            out.append(ContinuationResult(name=name, fidelity=str(a.pop("fidelity", "")),
                                          parameter=str(a.get("parameter", "Omega")), settings=settings,
                                          branches=branches, starts=starts, curves=curves,
                                          status=str(a.pop("status", "")), message=str(a.pop("message", "")),
                                          wall_time_s=float(a.pop("wall_time_s", 0.0)), attrs=a))
    return out
