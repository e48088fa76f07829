"""``vibeam cost``: what accuracy costs in time (a work-precision study), with the two sources
of error kept apart.

For every run of a case (and, with ``ladder``, for a ladder of tolerances of each ODE-based
method) the sweep is timed in this process, inline, after a warm-up, as the median of
``repeats`` repetitions.  Its error is measured twice:

* **the method's own error** (what the method costs): against the exact ``event`` solver
  run on the same model with the *same* transient and record (same start, same periods,
  same continuation).  Both follow the same trajectory, so what remains is the method's
  integration error, whatever is left of the transient.  Methods without a transient
  (``averaging``, ``mapping``: steady-state orbits directly) are measured against the
  converged reference instead (their own approximation error).
* **the transient truncation of the case's settings**, once per model: ``event`` with the
  case's transient against a converged transient of ``max(4 x transient, 2000)`` periods
  (the transient decays at least like exp(-beta t) and every impact removes a further
  share: with beta >= 0.01 less than exp(-0.01 * 2000 * 2 pi / Omega_max) < 1e-20 of it
  remains, so the reference is exact to round-off wherever the orbit is an attractor).
  A short transient makes every time-domain method look equally inaccurate against the
  converged reference (each inherits the same truncation); split this way, the diagram
  shows what each method costs, and the truncation is a line of its own.

For a beam scene a third quantity is the **model error** of each rung of the fidelity ladder
(static-mode SDOF, FE with 1, 2, 4 ... modes): its converged FRC against the finest FE
model of the scene (all modes, mesh twice as fine).  ``err_max`` / ``err_rms`` of a row keep
the total error against the converged reference of the reference model.

Errors are ``|Q - Q_against| / max Q_ref`` over the points where the converged reference
holds an orbit (periodic or without impact): there the attractor is an orbit, so two
trajectories from one start (the method's and event's) do not separate, settled or not;
where the motion is not periodic no sweep converges to a point value and the difference is
one of two samples of the attractor; those points are counted apart.

Continuation runs (``method = "continuation"``) are not sweeps: they are skipped with a note
(``vibeam bench --continuation`` times them).
"""
from __future__ import annotations

import json
import statistics
import time
from dataclasses import dataclass, field, replace

import numpy as np

from vibeam.engine.jobs import check_work
from vibeam.engine.records import summarize
from vibeam.engine import sweep
from vibeam.engine.sweep import Sweep, assemble, plan_lines, run_sweep
from vibeam.io.netcdf import var
from vibeam.models import make_solver
from vibeam.models.builders.sdof import sdof
from vibeam.models.registry import fidelity
from vibeam.models.scene import one_mode, outputs
from vibeam.plots import style
from vibeam.plots.lazy import plt
from vibeam.plots.sweep import save_close

# the paper's own figures (Secs. 3.3 and 4.2): time saved against direct simulation
PAPER_TIME_SAVED = {"ivanov": 0.80, "zhuravlev": 0.70, "mapping": 0.14, "averaging": 0.93}
PAPER_AVERAGING_ERROR_R06 = 0.16  # Fig. 11: 16 % off at R = 0.6, Omega = 2
ODE_METHODS = ("direct", "zhuravlev", "ivanov")
LADDER_RTOL = (1e-3, 1e-4, 1e-6, 1e-8, 1e-10)


@dataclass
class CostRow:
    """One line of the work-precision table.

    ``err_method_*``: against ``event`` with the same transient and record (``against =
    "event, same transient"``) or, for methods without a transient, the converged
    reference (``"converged event"``); ``err_*``: total, against the converged reference
    of the reference model; ``case_settings``: the run's own settings (not a ladder rung).
    """

    run: str
    method: str
    settings: dict
    time_s: float
    err_max: float
    err_rms: float
    n_period_diff: int
    n_points: int
    n_nonperiodic_ref: int
    time_rel_event: float = float("nan")
    err_method_max: float = float("nan")
    err_method_rms: float = float("nan")
    against: str = ""
    model_key: str = ""
    case_settings: bool = True


@dataclass
class ModelSources:
    """The error sources of one model of the case (one per distinct ``[run.model]``)."""

    key: str
    label: str
    event_time_s: float
    transient_periods: int
    reference_periods: int
    transient_max: float
    transient_rms: float
    n_compared: int
    model_max: float = float("nan")     # beam: converged rung vs the finest FE model
    model_rms: float = float("nan")
    extra: dict = field(default_factory=dict)


def _sweep_for(case, run_model: dict):
    spec = case.model_spec(run_model) if run_model else case.model_spec()
    scene = spec.scene()
    Omega = case.sweep.grid(outputs(scene).natural_frequency_hz)
    sw = Sweep(Omega=Omega, **case.sweep.engine_options())
    return scene, sw


def _timed(solver, sw, repeats):
    warm = Sweep(Omega=sw.Omega[:1], transient_periods=2, record_periods=2)
    run_sweep(solver, warm, jobs=1)
    times = []
    res = None
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        res = run_sweep(solver, sw, jobs=1)
        times.append(time.perf_counter() - t0)
    return statistics.median(times), res


def converged_sweep(sw):
    """The converged counterpart of a sweep: ``max(4 x transient, 2000)`` transient periods
    (with ``transient_periods = "auto"``: 4 x max_transient_periods)."""
    n = 4 * sw.max_transient_periods if sw.auto else max(4 * sw.transient_periods, 2000)
    return replace(sw, transient_periods=n)


def _sweeps(tasks: dict, jobs) -> dict:
    """Several untimed sweeps at once through the one engine: ``{key: (solver, sweep)}`` ->
    ``{key: SweepResult}``; their lines share ``jobs`` workers."""
    plans = {k: plan_lines(s, sw, run=k) for k, (s, sw) in tasks.items()}
    done = sweep.run_lines([l for ls in plans.values() for l in ls], jobs=jobs)
    out = {}
    for k, ls in plans.items():
        rows = [done[(k, l.key)] for l in ls]
        wall = float(sum(r.get("wall_time_s", 0.0) for rs in rows for r in rs))
        out[k] = assemble(tasks[k][0], tasks[k][1], k, rows, wall)
    return out


def reference_scene(case, run_model: dict):
    """The scene the errors of a run are measured against, and its key.

    SDOF: the run's own scene (the reference differs only in its transient).
    Beam: the finest FE model of the scene, all modes on a mesh twice as fine
    (``n_elements`` doubled), so every rung of the fidelity ladder (static mode,
    1, 2, 4 ... modes, coarser meshes) is measured against the same thing.
    """
    spec = case.model_spec(run_model) if run_model else case.model_spec()
    fine = spec.converged_reference(dict(case.model), dict(run_model or {}))
    if fine is None:
        return spec.scene(), json.dumps(run_model, sort_keys=True)
    return case.model_spec(fine).scene(), json.dumps(fine, sort_keys=True)


def check_cost_work(case, force: bool = False, source: str = "") -> dict:
    """Refuse unbounded work before timing (:func:`vibeam.runner.check_work`): the case as
    given, and its converged reference with max(4 x transient, 2000) transient periods."""
    w = check_work(case, force=force, source=source)
    data = case.model_dump()
    sw = case.sweep
    n_ref = 4 * sw.max_transient_periods if sw.transient_periods == "auto" else max(4 * sw.transient_periods, 2000)
    data["sweep"] = dict(data["sweep"], transient_periods=n_ref)
    check_work(type(case).model_validate(data), force=force, source=source)
    return w


def _orbit(res) -> np.ndarray:
    """Points of a sweep that hold an orbit (periodic or without impact) and did not fail."""
    per = np.asarray(res.data.get("period", np.zeros(res.n_points)))
    st = np.asarray([str(s) for s in res.data.get("status", ["ok"] * res.n_points)])
    return (per != 0) & (st != "failed")


def _err(a, b, sel, scale):
    """Largest and RMS of ``|a - b| / scale`` over ``sel`` (NaN when nothing is finite)."""
    d = np.abs(np.asarray(a, float) - np.asarray(b, float))[sel] / scale
    d = d[np.isfinite(d)]
    if not d.size:
        return np.nan, np.nan
    return float(d.max()), float(np.sqrt(np.mean(d ** 2)))


def run_cost(case, ladder: bool = False, repeats: int = 3, log=print, jobs: int | None = 1,
             quick: bool = False) -> dict:
    """Time and errors of every run (and ladder rung) of ``case``.

    Parameters
    ----------
    case : vibeam.case.schema.Case
    ladder : bool
        Also a ladder of tolerances (rtol 1e-3 ... 1e-10, atol = 1e-4 rtol) per ODE method.
    repeats : int
        Timed repetitions of each sweep (median), inline after a warm-up.
    log : callable
        Progress messages.
    jobs : int or None
        Workers for the untimed sweeps (converged references; None: all cores).  Timed
        sweeps always run inline, one at a time.
    quick : bool
        The case's quick variant (``[quick]``).

    Returns
    -------
    dict
        ``rows`` (list of :class:`CostRow`), ``models`` (``{key: ModelSources}``: the
        transient truncation and, for a beam, the model error), ``reference_periods``,
        ``transient_periods`` and the ``claims`` of the paper beside the measurements
        (one per claim).
    """
    if quick:
        case = case.quick_variant()
    rows: list[CostRow] = []
    models: dict = {}
    plan = {}                    # model key -> (model, sweep, reference key)
    ref_models = {}
    for r in case.run:
        if r.method == "continuation":
            continue
        mkey = json.dumps(r.model, sort_keys=True)
        if mkey not in plan:
            model, sw = _sweep_for(case, r.model)
            ref_model, rkey = reference_scene(case, r.model)
            plan[mkey] = (model, sw, rkey, r.name)
            ref_models.setdefault(rkey, (ref_model, sw))
    # converged sweeps (references of the reference models, and of each rung for a beam): untimed, on `jobs`
    tasks = {}
    for rkey, (ref_model, sw) in ref_models.items():
        tasks[f"ref {len(tasks)}"] = (make_solver(ref_model, "event"), converged_sweep(sw))
    ref_of = dict(zip(ref_models, tasks))
    for mkey, (model, sw, rkey, _) in plan.items():
        if mkey != rkey:                       # beam: the rung's own converged FRC (its transient error)
            tasks[f"conv {len(tasks)}"] = (make_solver(model, "event"), converged_sweep(sw))
    if tasks:
        log(f"converged references ({len(tasks)} sweep(s) of event, "
            f"{converged_sweep(next(iter(plan.values()))[1]).transient_periods} transient periods)...")
    done = _sweeps(tasks, jobs) if tasks else {}
    conv_of = {}
    k = len(ref_models)
    for mkey, (model, sw, rkey, _) in plan.items():
        if mkey == rkey:
            conv_of[mkey] = done[ref_of[rkey]]
        else:
            conv_of[mkey] = done[list(tasks)[k]]
            k += 1
    event_same = {}
    for r in case.run:
        if r.method == "continuation":
            log(f"run '{r.name}' (continuation) is not a sweep: no cost row (timed by `vibeam bench "
                f"--continuation`)")
            continue
        mkey = json.dumps(r.model, sort_keys=True)
        model, sw, rkey, first = plan[mkey]
        ref = done[ref_of[rkey]]
        conv = conv_of[mkey]
        scale = np.nanmax(np.abs(np.asarray(ref.data["amplitude"], float)))
        orbit_ref = _orbit(ref)
        if mkey not in event_same:
            log(f"timing event on the model of run '{r.name}'...")
            t_ev, ev = _timed(make_solver(model, "event"), sw, repeats)
            event_same[mkey] = (t_ev, ev)
            sel = _orbit(conv)
            tmax, trms = _err(ev.data["amplitude"], conv.data["amplitude"], sel, scale)
            src = ModelSources(key=mkey, label=first if r.model else "case model", event_time_s=t_ev,
                               transient_periods=sw.transient_periods,
                               reference_periods=converged_sweep(sw).transient_periods,
                               transient_max=tmax, transient_rms=trms, n_compared=int(sel.sum()))
            if mkey != rkey:
                src.model_max, src.model_rms = _err(conv.data["amplitude"], ref.data["amplitude"], orbit_ref, scale)
            models[mkey] = src
        t_ev, ev = event_same[mkey]
        settings = case.run_settings(r)
        variants = [(settings, True)]
        if ladder and r.method in ODE_METHODS:
            variants += [(dict(settings, rtol=rt, atol=rt * 1e-4), False) for rt in LADDER_RTOL
                         if rt != settings.get("rtol")]
        for st, own in variants:
            solver = make_solver(model, r.method, **st)
            if r.method == "event" and own:
                t, res = t_ev, ev                     # already timed, the same sweep
            else:
                log(f"timing run '{r.name}' ({r.method}, {_settings_text(st) or 'defaults'})...")
                t, res = _timed(solver, sw, repeats)
            A = np.asarray(res.data["amplitude"], float)
            # over the points whose attractor is an orbit (the converged FRC): there trajectories from
            # one start do not depend sensitively on it, so event and the method follow one transient
            against, B = (("event, same transient", ev.data["amplitude"]) if solver.time_domain
                          else ("converged event", conv.data["amplitude"]))
            sel = _orbit(conv)
            mmax, mrms = _err(A, B, sel, scale)
            emax, erms = _err(A, ref.data["amplitude"], orbit_ref, scale)
            per = np.asarray(res.data.get("period", np.zeros(len(A))))
            per_ref = np.asarray(ref.data["period"])
            periodic = per_ref > 0
            rows.append(CostRow(
                run=r.name, method=r.method, settings=st, time_s=t, err_max=emax, err_rms=erms,
                n_period_diff=int(np.sum(per[periodic] != per_ref[periodic])), n_points=len(A),
                n_nonperiodic_ref=int(np.sum(~periodic)), time_rel_event=t / t_ev, err_method_max=mmax,
                err_method_rms=mrms, against=against, model_key=mkey, case_settings=own))
    ref_periods = next((m.reference_periods for m in models.values()), None)
    return {"rows": rows, "models": models, "reference_periods": ref_periods,
            "transient_periods": case.sweep.transient_periods, "claims": paper_claims(rows, case)}


def paper_claims(rows, case) -> list[dict]:
    """The paper's figures beside the measured ones, with a verdict and a reason: each claim
    once, measured on the runs' own settings (not the ladder's rungs)."""
    out = []
    own = [r for r in rows if r.case_settings]
    base = next(({"time": r.time_s, "settings": r.settings} for r in own if r.method == "direct"), None)
    seen = set()
    for row in own:
        if row.method in PAPER_TIME_SAVED and base and row.method not in seen:
            seen.add(row.method)
            saved = 1 - row.time_s / base["time"]
            claim = PAPER_TIME_SAVED[row.method]
            ok = abs(saved - claim) < 0.15
            out.append(dict(
                claim=f"{row.method}: {time_ratio(1 - claim)} (paper, MATLAB ode23: {claim:.0%} of the time "
                      f"saved)",
                measured=f"{time_ratio(row.time_s / base['time'])} ({base['settings'].get('solver', 'RK23')}, "
                         f"rtol {base['settings'].get('rtol')})",
                reproduced=bool(ok),
                why="" if ok else _why(row.method, saved)))
    # averaging accuracy at R = 0.6, Omega = 2 (Fig. 11), computed directly
    try:
        spec = case.model_spec()
        if "averaging" not in fidelity(spec.fidelity).methods:
            return out
        m0 = one_mode(spec.scene(), "the averaging claim")
        m = sdof(m0.beta, m0.B, m0.Delta, R=0.6)
        ev = summarize(make_solver(m, "event").point(2.0, None, 2000, 16), m0.Delta)["amplitude"]
        av = make_solver(m, "averaging").point(2.0, None, 0, 1)["amplitude"]
        diff = abs(av - ev) / ev
        ok = abs(diff - PAPER_AVERAGING_ERROR_R06) < 0.05
        out.append(dict(claim="averaging 16 % off the simulation at R = 0.6, Omega = 2 (Fig. 11)",
                        measured=f"{diff:.1%} off the exact event solution (beta {m0.beta}, B {m0.B}, "
                                 f"Delta {m0.Delta})",
                        reproduced=bool(ok),
                        why="" if ok else "the paper's value was read off its own ode23 simulation"))
    except Exception as e:  # the comparison is informative, never fatal
        out.append(dict(claim="averaging 16 % off at R = 0.6", measured=f"not computed: {e}",
                        reproduced=False, why="not applicable to this case's model"))
    return out


def time_ratio(r: float, other: str = "direct") -> str:
    """A method's wall time over ``other``'s as people read it: ``"0.98x the time of direct"``,
    ``"2.5x the time of direct"``, or for less than half the time ``"45x faster than direct"``
    (never a negative or a 100 % "less time")."""
    if not (np.isfinite(r) and r > 0):
        return f"time against {other} not measured"
    if r < 0.5:
        return f"{1 / r:.2g}x faster than {other}"
    return f"{r:.2g}x the time of {other}"


def _why(method, saved):
    if method in ("ivanov", "zhuravlev"):
        return ("scipy's solve_ivp handles events by root-finding on its dense output at little extra "
                "cost, so removing the event (ivanov) or shrinking the jump (zhuravlev) saves little; "
                "MATLAB's ode23 restarts were the paper's bottleneck. Ivanov's right-hand side is "
                "discontinuous at z s = 0, which costs step rejections")
    if method == "mapping":
        return ("vibeam's mapping finds fixed points by Newton iteration on the closed-form flow "
                "instead of iterating the map over the transient, so it costs far less than the "
                "paper's root-finding iteration" if saved > 0.14 else
                "the per-point Newton solve with an admissibility check dominates")
    if method == "averaging":
        return "averaging is closed form here (vectorised numpy), not the paper's MATLAB evaluation"
    return ""


def _settings_text(st: dict) -> str:
    """The settings that distinguish methods, in full (``atol=1e-07``, never truncated)."""
    return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in st.items()
                     if k in ("solver", "rtol", "atol", "k", "n", "form"))


def print_cost(result: dict) -> None:
    """The work-precision table (columns as wide as their longest entry), the error sources
    per model, and each of the paper's claims once."""
    rows = result["rows"]
    models = result.get("models", {})
    print(f"\nconverged reference: event with {result['reference_periods']} transient periods; the case runs "
          f"{result.get('transient_periods')} transient periods")
    print("errors are |Q - Q_against| / max Q_ref over the points that hold an orbit in the comparison")
    if models:
        print("\ntransient truncation of the case's settings (event, the case's transient vs converged)"
              + (" and model error (converged, vs the finest FE model)" if any(np.isfinite(m.model_max)
                                                                                 for m in models.values()) else ""))
        w = max(len(m.label) for m in models.values()) + 2
        for m in models.values():
            line = (f"  {m.label:<{w}}transient {m.transient_periods} vs {m.reference_periods}: max "
                    f"{m.transient_max:.2e}, rms {m.transient_rms:.2e} ({m.n_compared} points)")
            if np.isfinite(m.model_max):
                line += f"; model error max {m.model_max:.2e}, rms {m.model_rms:.2e}"
            print(line)
    st = [_settings_text(r.settings) for r in rows]
    wr = max([len("run")] + [len(r.run) for r in rows]) + 2
    wm = max([len("method")] + [len(r.method) for r in rows]) + 2
    ws = max([len("settings")] + [len(s) for s in st]) + 2
    wa = max([len("method error vs")] + [len(r.against) for r in rows]) + 2
    head = (f"{'run':<{wr}}{'method':<{wm}}{'settings':<{ws}}{'time (s)':>10}{'x event':>9}"
            f"{'method err':>12}{'(rms)':>10}  {'method error vs':<{wa}}{'total err':>11}{'period diff':>13}")
    print("\n" + head)
    print("-" * len(head))
    for r, s in zip(rows, st):
        print(f"{r.run:<{wr}}{r.method:<{wm}}{s:<{ws}}{r.time_s:>10.3f}{r.time_rel_event:>9.1f}"
              f"{r.err_method_max:>12.2e}{r.err_method_rms:>10.2e}  {r.against:<{wa}}{r.err_max:>11.2e}"
              f"{r.n_period_diff:>9d}/{r.n_points - r.n_nonperiodic_ref}")
    if result["claims"]:
        print("\nthe paper's claims beside this implementation:")
        said = {}                   # a reason shared by several claims is printed once
        for c in result["claims"]:
            mark = "reproduced" if c["reproduced"] else "NOT reproduced"
            why = c["why"]
            if why and why in said:
                why = f"as for {said[why]} above"
            elif why:
                said[why] = c["claim"].split(":")[0]
            print(f"  - {c['claim']}\n      measured: {c['measured']} -> {mark}" +
                  (f"\n      why: {why}" if why else ""))


def cost_tables(result: dict) -> dict:
    """Variables of the HDF5 group ``/cost`` (one row per line of the table; the error sources
    of each model in ``model_*``)."""
    rows = result["rows"]
    ms = list(result.get("models", {}).values())
    d = ("row",)
    rel = "1"
    out = {
        "run": var(d, np.array([r.run for r in rows], dtype=object), None, "run of the case"),
        "method": var(d, np.array([r.method for r in rows], dtype=object), None, "solution method"),
        "settings": var(d, np.array([json.dumps(r.settings) for r in rows], dtype=object), None,
                        "method settings (JSON)"),
        "wall_time_s": var(d, np.array([r.time_s for r in rows]), "s", "wall time of the sweep (median, inline)"),
        "time_relative_to_event": var(d, np.array([r.time_rel_event for r in rows]), rel,
                                      "wall time over that of event on the same model"),
        "error_method_max": var(d, np.array([r.err_method_max for r in rows]), rel,
                                "method's own error: max |Q - Q_against| / max Q_ref"),
        "error_method_rms": var(d, np.array([r.err_method_rms for r in rows]), rel, "method's own error, RMS"),
        "error_against": var(d, np.array([r.against for r in rows], dtype=object), None,
                             "what the method error is measured against"),
        "error_max": var(d, np.array([r.err_max for r in rows]), rel,
                         "total error against the converged reference, max"),
        "error_rms": var(d, np.array([r.err_rms for r in rows]), rel, "total error, RMS"),
        "period_differences": var(d, np.array([r.n_period_diff for r in rows]), "1",
                                  "points whose period-n differs from the reference"),
        "case_settings": var(d, np.array([r.case_settings for r in rows]), "1",
                             "1: the run's own settings, 0: a rung of the tolerance ladder"),
        "claims": var(("claim",), np.array([json.dumps(c) for c in result["claims"]], dtype=object), None,
                      "the paper's claims beside the measurements (JSON)"),
    }
    if ms:
        m = ("model",)
        out.update({
            "model": var(m, np.array([x.label for x in ms], dtype=object), None, "model (first run using it)"),
            "model_transient_error_max": var(m, np.array([x.transient_max for x in ms]), rel,
                                             "transient truncation of the case's settings, max"),
            "model_transient_error_rms": var(m, np.array([x.transient_rms for x in ms]), rel,
                                             "transient truncation, RMS"),
            "model_error_max": var(m, np.array([x.model_max for x in ms]), rel,
                                   "converged model vs the finest FE model, max (beam)"),
            "model_event_time_s": var(m, np.array([x.event_time_s for x in ms]), "s", "wall time of event")})
    return out


def work_precision_figure(result: dict, title: str = "", case=None):
    """Error against wall time (log-log): each row's FRC against the converged reference
    (``err_max``: the converged event solution of the model, and for a beam the finest FE model,
    all modes on a mesh twice as fine -- the "error against the mesh-converged model" of the
    README), one series per run (a ladder joined by a line), the transient truncation of the
    case's settings as a dashed line per model; a Figure.  An error below 1e-16 (or 0) sits on
    the floor 1e-16.  The method's own error (against event with the same transient) is in the
    table and ``cost.h5`` (``error_method_max``): drawn here it put every event rung of a ladder
    at 1e-16 (each against itself)."""
    floor = 1e-16
    rows = result["rows"]
    models = result.get("models", {})
    beam = any(np.isfinite(m.model_max) for m in models.values())
    n_ref = result.get("reference_periods")
    ref = ("the finest FE model (all modes, mesh twice as fine)" if beam else "event on the same model") + \
        (f", {n_ref} transient periods" if n_ref else ", converged transient")
    with style.context():
        fig, ax = plt.subplots(figsize=(8.0, 4.8))
        col = style.colours(style.run_names(case) + [r.run for r in rows])
        markers = {"event": "*", "direct": "o", "zhuravlev": "s", "ivanov": "^", "averaging": "D",
                   "mapping": "P", "continuation": "X"}
        by = {}
        for r in rows:
            by.setdefault(r.run, []).append(r)
        handles = []
        annotated = False                 # the ladder's rtol written next to the first ladder only
        for run, rs in by.items():
            rs = sorted(rs, key=lambda r: r.time_s)
            t = [r.time_s for r in rs]
            e = [max(r.err_max, floor) if np.isfinite(r.err_max) else np.nan for r in rs]
            c = col.get(run, "0.3")
            mk = markers.get(rs[0].method, "o")
            ax.plot(t, e, ls="-" if len(rs) > 1 else "none", marker=mk, color=c, ms=7 if mk == "*" else 5)
            if len(rs) > 1 and not annotated:
                annotated = True
                for r, ti, ei in zip(rs, t, e):
                    if "rtol" in r.settings and np.isfinite(ei):
                        ax.annotate(f"rtol {r.settings['rtol']:g}", (ti, ei), textcoords="offset points",
                                    xytext=(-6, 0), ha="right", va="center", fontsize=7, color="0.3")
            handles.append(style.proxy(c, ls="-" if len(rs) > 1 else "none", marker=mk,
                                       label=f"{run} ({rs[0].method}; vs converged)"))
        for i, m in enumerate(models.values()):
            if np.isfinite(m.transient_max) and m.transient_max > 0:
                c = "0.35" if len(models) == 1 else col.get(m.label, "0.35")
                ax.axhline(m.transient_max, color=c, ls="--", lw=1.0)
                handles.append(style.proxy(c, ls="--", label=f"transient truncation, {m.transient_periods} "
                                                              f"periods ({m.label})"))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(style.label("wall time of the sweep, one core", "s"))
        ax.set_ylabel(style.label("error vs the converged reference\n" r"max $|Q - Q_{ref}| / \max Q_{ref}$", None))
        ax.axhline(floor, color="0.8", lw=0.6)
        ax.text(0.99, 0.02, "1e-16: exact to round-off", transform=ax.transAxes, ha="right", fontsize=7,
                color="0.5")
        style.legend_outside(fig, handles)
        sub = style.subtitle(case)
        style.titles(fig, (title + ": " if title else "") + "work-precision (error against the converged "
                     "reference, and what it costs)", (sub + "; " if sub else "") + f"reference: {ref}")
    return fig


def plot_work_precision(result: dict, path, title: str = "", case=None):
    """:func:`work_precision_figure` saved to ``path`` (``work_precision.png``)."""
    return save_close(work_precision_figure(result, title, case), path)
