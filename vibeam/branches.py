"""Continuation runs of a case (``method = "continuation"``): planning, the unit of work that
the one executor runs, results, the printed table and the plots.

A continuation run is one :class:`BranchTask`: it goes through :func:`vibeam.sweep.run_lines`
beside the sweep lines of the case, on the same executor (local pool or dask), and returns
plain arrays (picklable).  In the worker it builds the fidelity's shooting problem from the
registration :data:`vibeam.models.SHOOTING` (no per-fidelity code here), finds the starting
orbits, runs :func:`vibeam.models.continuation.trace` and, for a ``[map]`` case, the
two-parameter curves of :func:`vibeam.models.continuation.trace_curve`.

Physical keys are continued through the scene's affine conversions (paper Eqs. 43-46; the
model spec's ``native_parameter``), so ``F_p`` follows by the chain rule.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .case import CaseError

#: units of the continuation parameters (the HDF5 ``units`` attribute of ``parameter``)
PARAMETER_UNITS = {"Omega": "1 (forcing frequency / natural frequency)", "voltage": "V", "gain": "1/V",
                   "gap_mm": "mm (grazing gap at the sensor)", "damping_ratio": "1", "R": "1", "B": "1",
                   "Delta": "1", "beta": "1"}
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
    "state": "1 (state at forcing phase 0 of the fidelity's shooting problem)",
    "q_min": "1", "q_max": "1",
    "stuck_time": "1 (time on the stop per orbit, nondimensional)",
    "apex_gap": "1 (highest interior free-flight apex minus the stop; 0 = grazing)",
}


@dataclass(frozen=True)
class BranchTask:
    """One continuation run as a unit of work of :func:`vibeam.sweep.run_lines`.

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
        The run's continuation settings (:class:`vibeam.case.ContinuationRun`).
    sweep_periods : (int, int)
        Transient and recorded periods of a ``sweep`` start.
    curve_key : str or None
        The ``[map]`` parameter of a case with two-parameter curves.
    curve_range : (float, float) or None
        Its range.
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

    @property
    def n_points(self) -> int:
        return 1

    def compute(self) -> list:
        """Run the continuation (in a worker); failures are statuses, never exceptions."""
        t0 = time.perf_counter()
        try:
            out = run_continuation(self)
        except Exception as e:  # a bug or an unforeseen numerical failure: recorded, not fatal
            import traceback
            out = dict(branches=[], starts=[], curves=[], status="failed",
                       message=f"{type(e).__name__}: {e}; {traceback.format_exc(limit=3)}")
        out["wall_time_s"] = time.perf_counter() - t0
        return [out]

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
    from .models import SHOOTING

    i = case.run.index(r)
    spec = case.model_spec(dict(r.model)) if r.model else case.model_spec()
    fid = spec.fidelity
    if fid not in SHOOTING:
        raise CaseError(f"'run[{i}].method' = 'continuation' is not available for fidelity {fid!r} (no shooting "
                        f"problem registered in vibeam.models.SHOOTING); available for: {', '.join(sorted(SHOOTING))}")
    starts = ("sweep", "auto") + tuple(getattr(SHOOTING[fid], "starts", ()))
    if r.start not in starts:
        raise CaseError(f"'run[{i}].start' = {r.start!r} is not available for fidelity {fid!r}; allowed: "
                        f"{', '.join(starts)}")
    if not hasattr(spec, "native_parameter"):
        if r.parameter != "Omega":
            raise CaseError(f"'run[{i}].parameter' = {r.parameter!r}: fidelity {fid!r} can be continued in "
                            f"'Omega' only")
    fn = _natural_frequency(spec)
    hz = case.sweep.frequency_hz is not None      # frequencies of the case in Hz
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
    return BranchTask(key=key, run=r.name, spec=spec, parameter=r.parameter, lo=float(lo), hi=float(hi),
                      at=at, settings=settings,
                      sweep_periods=(case.sweep.transient_periods, max(16, case.sweep.record_periods)),
                      curve_key=curve_key, curve_range=curve_range)


def _natural_frequency(spec):
    """``f_n`` of a physical scene's model (as the sweeps use it), None otherwise."""
    fn = getattr(spec, "natural_frequency_hz", None)
    if fn is None and getattr(spec, "physical", False):
        fn = getattr(spec.build(), "natural_frequency_hz", None)
    return fn


def _with(spec, **over):
    """The spec with some keys replaced (validated again)."""
    data = spec.model_dump()
    data.update(over)
    return type(spec).model_validate(data)


def problem(spec, key: str, at: float | None):
    """The shooting problem of ``spec`` continued in ``key`` (physical keys through the scene's
    affine conversion, :class:`vibeam.models.continuation.ScaledParameter`)."""
    from .models import shooting_problem
    from .models.continuation import ScaledParameter

    model = spec.build()
    native, factor = spec.native_parameter(key) if hasattr(spec, "native_parameter") else (key, 1.0)
    prob = shooting_problem(model, native, Omega=at)
    if native == key and factor == 1.0:
        return prob
    return ScaledParameter(prob, key, factor)


# ----------------------------------------------------------------------------- the run
def _sweep_start(task, spec, value):
    """Settled state and detected period of an event run at the start value (a sweep point)."""
    from .models import make_solver
    from .records import summarize

    if task.parameter == "Omega":
        model, Omega = spec.build(), value
    else:
        model, Omega = _with(spec, **{task.parameter: value}).build(), task.at
    tr = make_solver(model, "event").point(float(Omega), None, task.sweep_periods[0], task.sweep_periods[1], 16)
    sm = summarize(tr, model.Delta)
    if tr.status == "failed":
        return None, 0, f"the event run failed: {tr.message}"
    n = int(sm["period"])
    if n == 0:
        return None, 0, (f"the sweep point is not periodic within 8 periods after {task.sweep_periods[0]} transient "
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


def run_continuation(task: BranchTask) -> dict:
    """Everything a continuation run computes, as plain arrays (see :func:`branch_arrays`)."""
    from .models.continuation import ContinuationError, Settings, trace

    st = task.settings
    settings = Settings(ds=st["ds"], ds_min=st["ds_min"], ds_max=st["ds_max"], max_points=st["max_points"],
                        max_period=st["max_period"], switch=st["switch"])
    spec = task.spec
    prob = problem(spec, task.parameter, task.at)
    where = st.get("start_at", "both")
    if where == "low":
        plan_ = [(task.lo, +1)]
    elif where == "high":
        plan_ = [(task.hi, -1)]
    elif where == "both":
        plan_ = [(task.lo, +1), (task.hi, -1)]
    else:
        plan_ = [(float(where), 0)]
    branches, starts = [], []
    kinds = ["linear", "sweep", "averaging"] if st.get("start", "auto") == "auto" else [st["start"]]
    for value, direction in plan_:
        for kind in kinds:
            if kind != "sweep" and kind not in getattr(prob, "starts", ()):
                continue
            x0, n, why = _start(task, spec, prob, kind, value)
            info = dict(value=value, kind=kind, n=n, status="ok", message=why)
            starts.append(info)
            if x0 is None:
                info["status"] = "not_available"
                continue
            try:
                got = trace(prob, x0, value, n, task.lo, task.hi, direction, settings)
            except ContinuationError as e:
                info.update(status="failed_start", message=str(e))
                continue
            except Exception as e:       # an unforeseen numerical failure: this start only
                info.update(status="failed", message=f"{type(e).__name__}: {e}")
                continue
            if not got[0].points:
                info.update(status=got[0].status, message=got[0].message)
                continue
            if _duplicate(branches, got[0].points[0], got[0].n):
                info.update(status="duplicate", message="its orbit lies on a branch already traced")
                continue
            base = len(branches)
            for b in got:
                b.index += base
                for bf in b.bifurcations:
                    bf.branch = b.index
                b.origin = b.origin.replace("of branch ", "of branch #")
            branches.extend(got)
    out = dict(branches=[branch_arrays(b, spec, task) for b in branches], starts=starts, curves=[],
               status="ok" if branches else "failed",
               message="" if branches else "no branch could start: " + "; ".join(
                   f"{s['kind']} at {s['value']:.6g}: {s['message']}" for s in starts if s["status"] != "ok"))
    if task.curve_key is not None and branches:
        out["curves"] = _curves(task, spec, branches, settings)
    return out


def _curves(task, spec, branches, settings) -> list:
    """Two-parameter curves of the folds, period doublings and grazings of ``branches``,
    seeded at ``slices`` values of the map parameter (see trace_curve)."""
    from .models.continuation import FOLD, GRAZING, PERIOD_DOUBLING, trace_curves

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
    v0 = float(getattr(spec, k2))
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
    from dataclasses import replace as dc_replace
    from .models.continuation import trace

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
        except Exception:
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
        return float(spec.build().Delta)
    except Exception:
        return None


def _bif_amplitude(b, f, gap):
    """``Q`` at a bifurcation from the branch point next to it (problems without ``Shot.gap``)."""
    k = min(max(f.index, 0), len(b.points) - 1)
    return gap - b.points[k].shot.q_min if b.points else math.nan


def _length_m(spec):
    """``L`` of a physical scene's model (``amplitude_mm = Q L``, as the sweeps), None otherwise."""
    if not getattr(spec, "physical", False):
        return None
    return getattr(spec.build(), "length_m", None)


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
    attrs = {"parameter": task.parameter, "range": np.array([task.lo, task.hi]),
             "parameter_units": PARAMETER_UNITS.get(task.parameter, "")}
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
    attrs["model"] = spec.model_dump()
    return ContinuationResult(name=task.run, fidelity=spec.fidelity, parameter=task.parameter,
                              settings=task.settings, branches=row.get("branches", []),
                              starts=row.get("starts", []), curves=row.get("curves", []),
                              status=row.get("status", "failed"), message=row.get("message", ""),
                              wall_time_s=float(row.get("wall_time_s", 0.0)), attrs=attrs)


def write_branches(f, results: list) -> None:
    """``/branches/<run>/<branch>/``, ``/branches/<run>/bifurcations/`` and
    ``/branches/<run>/curves/<curve>/`` into the open HDF5 file ``f``."""
    import json

    from .results import _json_default, _write_dataset

    root = f.require_group("branches")
    for r in results:
        g = root.create_group(r.name)
        g.attrs["fidelity"] = r.fidelity
        g.attrs["method"] = "continuation"
        g.attrs["settings"] = json.dumps(r.settings, default=_json_default)
        g.attrs["wall_time_s"] = r.wall_time_s
        g.attrs["status"] = r.status
        g.attrs["message"] = r.message
        g.attrs["starts"] = json.dumps(r.starts, default=_json_default)
        for k, v in r.attrs.items():
            g.attrs[k] = v if not isinstance(v, dict) else json.dumps(v, default=_json_default)
        for b in r.branches:
            gb = g.create_group(branch_name(b))
            for k in ("index", "n", "status", "message", "origin"):
                gb.attrs[k] = b[k]
            for k, v in b["data"].items():
                _write_dataset(gb, k, v)
                gb[k].attrs["units"] = PARAMETER_UNITS.get(r.parameter, "") if k == "parameter" else \
                    BRANCH_UNITS.get(k, gb[k].attrs.get("units", ""))
        gt = g.create_group("bifurcations")
        for k, v in r.bifurcation_table().items():
            _write_dataset(gt, k, v)
        gt["parameter"].attrs["units"] = PARAMETER_UNITS.get(r.parameter, "")
        gt.attrs["types"] = "fold, period_doubling, neimark_sacker, grazing, sticking"
        if r.curves:
            gc = g.create_group("curves")
            for i, c in enumerate(r.curves):
                gi = gc.create_group(f"{i:02d}-{c['type']}")
                gi.attrs["type"] = c["type"]
                gi.attrs["status"] = c["status"]
                gi.attrs["message"] = c["message"]
                gi.attrs["period"] = c["n"]
                _write_dataset(gi, "parameter", c["p1"])
                gi["parameter"].attrs["units"] = PARAMETER_UNITS.get(r.parameter, "")
                _write_dataset(gi, r.attrs.get("curve_parameter", "parameter2"), c["p2"])
                if r.attrs.get("natural_frequency_hz") and r.parameter == "Omega":
                    _write_dataset(gi, "frequency_hz", np.asarray(c["p1"]) * r.attrs["natural_frequency_hz"])


def branch_name(b: dict) -> str:
    return f"{b['index']:02d}-period{b['n']}"


# ----------------------------------------------------------------------------- printing
_SHORT_UNITS = {"voltage": "V", "gain": "1/V", "gap_mm": "mm"}


def _x(r: ContinuationResult, p: float) -> str:
    fn = r.attrs.get("natural_frequency_hz")
    if r.parameter == "Omega":
        return f"{p * fn:.6f} Hz (Omega {p:.8f})" if fn else f"Omega = {p:.10f}"
    return f"{r.parameter} = {p:.10g} {_SHORT_UNITS.get(r.parameter, '')}".rstrip()


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
MARKERS = {"fold": ("s", "C3", "fold"), "period_doubling": ("D", "C2", "period doubling"),
           "neimark_sacker": ("*", "C4", "Neimark-Sacker"), "grazing": ("v", "C1", "grazing"),
           "sticking": ("P", "C5", "sticking")}


def plot_continuation(r: ContinuationResult, sweep_runs: list, path, title: str = ""):
    """The FRC of a continuation run: stable branches solid, unstable dashed, bifurcations
    marked (legend), and the case's sweep points overlaid; returns the path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fn, L = r.attrs.get("natural_frequency_hz"), r.attrs.get("length_m")
    use_hz = bool(fn) and r.parameter == "Omega"
    xs = fn if use_hz else 1.0
    ys = L * 1e3 if L else 1.0
    fig, ax = plt.subplots(figsize=(8, 5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    if r.parameter == "Omega":
        for i, s in enumerate(sweep_runs):
            d = s.data
            x = d["frequency_hz"] if use_hz and "frequency_hz" in d else d["Omega"]
            y = d["amplitude_mm"] if L and "amplitude_mm" in d else d["amplitude"]
            dirs = d.get("direction", np.array(["up"] * len(x), dtype=object))
            for dname, mk in (("up", "^"), ("down", "v")):
                sel = np.array([str(v) == dname for v in dirs])
                if sel.any():
                    ax.plot(x[sel], y[sel], mk, ms=3.5, mfc="none", color="0.55", alpha=0.8,
                            label=f"sweep '{s.name}' ({dname})")
    seen = set()
    for b in r.branches:
        d = b["data"]
        if not d:
            continue
        c = colors[int(np.log2(max(b["n"], 1))) % len(colors)]
        x, y, st = d["parameter"] * xs, d["amplitude"] * ys, d["stable"]
        # split into runs of equal stability, drawn solid / dashed (joined at the switches)
        k0 = 0
        for k in range(1, len(x) + 1):
            if k == len(x) or st[k] != st[k0]:
                seg = slice(k0, min(k + 1, len(x)))
                lab = f"period {b['n']} {'stable' if st[k0] else 'unstable'}"
                ax.plot(x[seg], y[seg], "-" if st[k0] else "--", color=c, lw=1.3,
                        label=lab if lab not in seen else None)
                seen.add(lab)
                k0 = k
    for bf in r.bifurcations:
        mk, c, lab = MARKERS.get(bf["type"], ("o", "k", bf["type"]))
        ax.plot(bf["parameter"] * xs, bf["amplitude"] * ys, mk, color=c, ms=7, mec="k", mew=0.6,
                label=lab if lab not in seen else None, zorder=5)
        seen.add(lab)
    if use_hz:
        ax.set_xlabel("forcing frequency (Hz)")
    elif r.parameter == "Omega":
        ax.set_xlabel(r"$\Omega$")
    else:
        ax.set_xlabel(f"{r.parameter} ({r.attrs.get('parameter_units', '')})")
    ax.set_ylabel("amplitude at sensor (mm)" if L else r"$Q = \Delta - \min q$")
    ax.set_title(title or f"continuation '{r.name}'")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_curves_on(ax, results: list, frequency_hz: bool) -> None:
    """Overlay the two-parameter curves of ``results`` on a map axis (x: frequency, y: the
    map parameter)."""
    seen = set()
    for r in results:
        fn = r.attrs.get("natural_frequency_hz") if frequency_hz else 1.0
        for c in r.curves:
            if len(c["p1"]) < 2:
                continue
            mk, col, lab = MARKERS.get(c["type"], ("o", "k", c["type"]))
            lab = f"{lab} (period {c['n']})"
            ax.plot(np.asarray(c["p1"]) * (fn or 1.0), c["p2"], "-", color=col, lw=1.6,
                    label=lab if lab not in seen else None)
            seen.add(lab)
    if seen:
        ax.legend(fontsize=7, loc="upper right")


def plot_curves(r: ContinuationResult, path, title: str = ""):
    """The two-parameter curves of one run alone (frequency x map parameter)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    fn = r.attrs.get("natural_frequency_hz")
    plot_curves_on(ax, [r], bool(fn))
    ax.set_xlabel("forcing frequency (Hz)" if fn else r"$\Omega$")
    ax.set_ylabel(r.attrs.get("curve_parameter", ""))
    lo, hi = r.attrs["range"]
    ax.set_xlim(lo * (fn or 1.0), hi * (fn or 1.0))
    ax.set_title(title or f"two-parameter curves of '{r.name}'")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
