"""``vibeam bench --compile``: the cold and warm numba compile time of shipped scenarios, per kernel
specialisation, in fresh processes (:func:`run_compile_bench`)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

import numba

from vibeam.bench.common import goal, root
from vibeam.engine.compiling import specialisation


COMPILE_GOAL_S = 5.0   # issue 20: the quick start's first run compiles in <= 5 s
#: issue 44: cold compile seconds of the first use of each scenario (by the start of its name)
SCENARIO_GOALS_S = {"quick start": COMPILE_GOAL_S, "first compliant SDOF point": 10.0, "first FE 2-mode point": 6.0,
                    "first FE 4-mode point": 6.0, "first SDOF continuation": 15.0}

#: ``python -c COMPILE_PROBE EVENTS cli|code ARGS...``: runs ``vibeam ARGS`` (``cli``) or the
#: Python text ARGS[0] (``code``) with a listener on numba's ``"numba:compile"`` event and timers
#: around numba's cache loads and saves; one JSON line per event on the O_APPEND file EVENTS
#: (``os.write``, so forked pool workers, which inherit the listener, append their own lines)
COMPILE_PROBE = """
import json, os, sys, time
fd = os.open(sys.argv[1], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
def emit(**rec):
    rec["pid"] = os.getpid()
    os.write(fd, (json.dumps(rec) + "\\n").encode())
t_start = time.perf_counter()
emit(kind="main")
from numba.core import caching, event
def name_of(f):
    return f"{getattr(f, '__module__', '?')}.{getattr(f, '__qualname__', getattr(f, '__name__', repr(f)))}"
class Compiles(event.Listener):
    def __init__(self):
        self.stack = []         # [start, seconds of nested compilations] per open compilation
    def on_start(self, ev):
        self.stack.append([time.perf_counter(), 0.0])
    def on_end(self, ev):
        t0, nested = self.stack.pop()
        dt = time.perf_counter() - t0
        if self.stack:
            self.stack[-1][1] += dt
        args = tuple(ev.data.get("args") or ())
        emit(kind="compile", kernel=name_of(ev.data["dispatcher"].py_func), args=[str(a) for a in args],
             depth=len(self.stack),
             inclusive_s=dt, self_s=dt - nested)
event.register("numba:compile", Compiles())
os.register_at_fork(after_in_child=lambda: emit(kind="fork"))
def timed(method, kind):
    inner = getattr(caching.Cache, method)
    def wrapper(self, *a, **k):
        t0 = time.perf_counter()
        out = inner(self, *a, **k)
        emit(kind=kind, kernel=name_of(getattr(self, "_py_func", None)), seconds=time.perf_counter() - t0,
             hit=out is not None)
        return out
    setattr(caching.Cache, method, wrapper)
timed("load_overload", "load")
timed("save_overload", "save")
rc = 0
try:
    if sys.argv[2] == "cli":
        from vibeam.cli import main
        rc = main(sys.argv[3:])
    else:
        exec(compile(sys.argv[3], "<scenario>", "exec"), {"__name__": "__scenario__"})
finally:
    emit(kind="exit", seconds=time.perf_counter() - t_start)
sys.exit(rc)
"""

#: the first point of the rig's FE beam (``cases/rig-fe-neutral.toml``) with ``{n}`` modes, as
#: ``vibeam run`` builds its solver: the case's first frequency, two transient and two recorded
#: periods
FE_POINT = """
from pathlib import Path
import vibeam
from vibeam.case.schema import load_case
from vibeam.models import make_solver
case, _ = load_case(Path(vibeam.__file__).resolve().parent.parent / "cases" / "rig-fe-neutral.toml")
run = next(r for r in case.run if r.method == "event")
from vibeam.models.scene import outputs
model = case.model_spec({{"n_modes": {n}}}).scene()
W = float(case.sweep.grid(outputs(model).natural_frequency_hz)[0])
make_solver(model, "event", **case.run_settings(run)).point(W, None, 2, 2, case.sweep.samples_per_period)
"""

#: the first point of the quick start's SDOF scene (paper Fig. 7: beta 0.015, B 0.5e-3, Delta 0) on a
#: compliant stop, as ``vibeam run`` builds its solver: Kelvin-Voigt, stiffness 1e4, the dashpot of an
#: isolated impact's R = 0.8 (the event integrator's compliant specialisation)
COMPLIANT_POINT = """
from vibeam.models import make_solver
from vibeam.models.builders.sdof import sdof
from vibeam.models.compliant import LinearContact
m = sdof(0.015, 0.5e-3, 0.0, law=LinearContact.from_restitution(1e4, 0.8))
make_solver(m, "event").point(1.8, None, 2, 2, 64)
"""

#: the scenarios of ``vibeam bench --compile``: (name, ``cli`` or ``code``, vibeam arguments or
#: Python text); ``{root}`` is the checkout, ``{out}`` a fresh output folder
COMPILE_SCENARIOS = (
    ("quick start: vibeam run cases/paper-fig7.toml", "cli",
     ["run", "{root}/cases/paper-fig7.toml", "--out", "{out}", "--no-plots", "--quiet"]),
    ("first compliant SDOF point (Kelvin-Voigt stop, paper-fig7 scene)", "code", COMPLIANT_POINT),
    ("first FE 2-mode point (rig-fe-neutral, n_modes = 2)", "code", FE_POINT.format(n=2)),
    ("first FE 4-mode point (rig-fe-neutral, n_modes = 4)", "code", FE_POINT.format(n=4)),
    ("first SDOF continuation: vibeam continue cases/paper-fig13-continuation.toml --quick", "cli",
     ["continue", "{root}/cases/paper-fig13-continuation.toml", "--quick", "--out", "{out}", "--no-plots",
      "--quiet"]),
    ("pooled SDOF continuation: vibeam continue cases/rig-tight-continuation.toml --quick --jobs 2", "cli",
     ["continue", "{root}/cases/rig-tight-continuation.toml", "--quick", "--jobs", "2", "--out", "{out}",
      "--no-plots", "--quiet"]),
)


def _short(sig: str, limit: int = 240) -> str:
    return sig if len(sig) <= limit else sig[:limit] + " ...)"


def _compile_summary(records: list, process_wall_s: float) -> dict:
    """One probed process (and its forked workers) from its event lines: compile time (the
    outermost compilations, nested ones are inside them), the kernel specialisations the work
    compiled (the outermost ones, each with the seconds of everything compiled for it), each
    specialisation with its own (``self_s``: less its nested compilations) and inclusive seconds,
    and the cache's loads and saves."""
    main = next(r["pid"] for r in records if r["kind"] == "main")
    comp = [r for r in records if r["kind"] == "compile"]
    loads = [r for r in records if r["kind"] == "load"]
    saves = [r for r in records if r["kind"] == "save"]
    ext = [r["seconds"] for r in records if r["kind"] == "exit" and r["pid"] == main]
    top = lambda rs: float(sum(r["inclusive_s"] for r in rs if r["depth"] == 0))   # noqa: E731
    workers = [r for r in comp if r["pid"] != main]
    per_kernel: dict = {}
    for r in comp:
        r["signature"] = "(" + ", ".join(r["args"]) + ")"
        per_kernel.setdefault(r["kernel"], {})[r["signature"]] = r["args"]
    several = {}
    for k, sigs in per_kernel.items():
        if len(sigs) > 1:        # the arguments whose types differ between the specialisations
            arglists = list(sigs.values())
            n = max(len(a) for a in arglists)
            at = {str(i): sorted({a[i] if i < len(a) else "-" for a in arglists}) for i in range(n)}
            several[k] = {"specialisations": len(sigs),
                          "differing_arguments": {i: t for i, t in at.items() if len(t) > 1}}
    kernels = sorted(({"kernel": r["kernel"], "signature": _short(r["signature"]), "n_args": len(r["args"]),
                       "none_args": [i for i, a in enumerate(r["args"]) if a == "none"],
                       "self_s": r["self_s"], "inclusive_s": r["inclusive_s"], "nested": r["depth"] > 0,
                       "process": "main" if r["pid"] == main else "worker"} for r in comp),
                     key=lambda k: -k["self_s"])
    outer = [{"kernel": r["kernel"], "specialisation": specialisation(r["kernel"], r["args"]),
              "compile_s": r["inclusive_s"], "nested_compilations": 0,
              "process": "main" if r["pid"] == main else "worker"} for r in comp if r["depth"] == 0]
    i = 0
    for r in comp:               # events end innermost first: a top-level one closes its nested ones
        if r["depth"] == 0:
            i += 1
        elif i < len(outer):
            outer[i]["nested_compilations"] += 1
    return {"process_wall_s": process_wall_s, "probe_wall_s": ext[0] if ext else None,
            "kernel_specialisations": outer,
            "compile_s": top(comp), "compile_s_main": top([r for r in comp if r["pid"] == main]),
            "compile_s_workers": top(workers),
            "specialisations": len(comp), "specialisations_in_workers": len(workers),
            "worker_processes_compiling": len({r["pid"] for r in workers}),
            "dispatchers": len(per_kernel),
            "dispatchers_with_several_specialisations": several,
            "forked_workers": len({r["pid"] for r in records if r["kind"] == "fork"}),
            "cache_loads": sum(r["hit"] for r in loads), "cache_misses": sum(not r["hit"] for r in loads),
            "cache_loads_in_workers": sum(r["hit"] for r in loads if r["pid"] != main),
            "cache_load_s": float(sum(r["seconds"] for r in loads if r["hit"])),
            "cache_miss_s": float(sum(r["seconds"] for r in loads if not r["hit"])),
            "cache_saves": len(saves), "cache_save_s": float(sum(r["seconds"] for r in saves)),
            "kernels": kernels}


def probe_compile(kind: str, payload, cache_dir, tmp, timeout: float = 1800.0) -> dict:
    """One scenario in a fresh interpreter under :data:`COMPILE_PROBE`, numba's cache in
    ``cache_dir``; returns :func:`_compile_summary` of its event lines."""
    tmp = Path(tmp)
    marks = tmp / f"events-{uuid.uuid4().hex}.jsonl"
    out = tmp / f"out-{uuid.uuid4().hex}"
    args = [str(a).format(root=root(), out=out) for a in payload] if kind == "cli" else [payload]
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", COMPILE_PROBE, str(marks), kind, *args], capture_output=True,
                       text=True, env=env, cwd=str(tmp), timeout=timeout)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"compile probe ({kind} {' '.join(args)[:200]}) exited {p.returncode}: "
                           f"{p.stderr.strip()[-500:]}")
    records = [json.loads(line) for line in marks.read_text().splitlines() if line.strip()]
    return _compile_summary(records, wall)


def run_compile_bench(scenarios=None, log=None) -> dict:
    """Cold and warm compile time of the shipped scenarios (issue 20's compile goal).

    Each scenario (default :data:`COMPILE_SCENARIOS`) runs twice, each time in a fresh
    interpreter under :data:`COMPILE_PROBE`: first with an empty temporary
    ``NUMBA_CACHE_DIR`` (cold: every kernel it uses is compiled and saved), then again on
    that cache (warm: loaded, nothing should compile).  Reported per run: the process's
    wall time, the compile time (the outermost ``"numba:compile"`` events; a kernel's
    callees compile inside it), every specialisation compiled (kernel, signature, its own
    and its inclusive seconds, main process or pool worker; sorted by own cost), the
    specialisations compiled in forked pool workers, and the cache's loads and saves.
    Measured, never asserted.

    Returns
    -------
    dict
        JSON-ready: ``scenarios`` (name -> ``{"cold": ..., "warm": ...}``), ``kernel_specialisations``
        (name -> the outermost specialisations compiled cold, each with the seconds of everything
        compiled for it: the event integrator's ``integrate_work`` for Newton stops only or with
        compliant stops and its work arrays' ``new_work``, the shooting problem's ``shoot``), ``goal_s``, ``cores``, ``load_average``, ``numba``.
    """
    say = log or (lambda m: None)
    out = {"goal_s": COMPILE_GOAL_S, "numba": numba.__version__, "cores": os.cpu_count(),
           "load_average_before": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
           "note": "compile_s: numba's 'numba:compile' events (cache misses), outermost ones summed; self_s of a "
                   "specialisation excludes the kernels compiled inside it; compile_s sums the main process and the "
                   "pool workers (which compile side by side, so it can exceed the wall time); cold: empty "
                   "NUMBA_CACHE_DIR, warm: the same cache in a second fresh process", "scenarios": {}}
    for name, kind, payload in (scenarios or COMPILE_SCENARIOS):
        with tempfile.TemporaryDirectory() as tmp:
            cache = Path(tmp) / "numba-cache"
            cache.mkdir()
            cold = probe_compile(kind, payload, cache, tmp)
            say(f"{name}: cold {cold['process_wall_s']:.2f} s, compiling {cold['compile_s']:.2f} s "
                f"({cold['specialisations']} specialisations, {cold['specialisations_in_workers']} in pool workers)")
            warm = probe_compile(kind, payload, cache, tmp)
            say(f"{name}: warm {warm['process_wall_s']:.2f} s, compiling {warm['compile_s']:.2f} s, "
                f"{warm['cache_loads']} cache loads in {warm['cache_load_s']:.2f} s")
        out["scenarios"][name] = {"kind": kind, "command": "vibeam " + " ".join(payload) if kind == "cli" else
                                  payload.strip(), "cold": cold, "warm": warm}
        say("  biggest: " + ", ".join(f"{r['kernel'].rsplit('.', 1)[-1]} {r['self_s']:.2f} s" for r in biggest(cold)))
        for k in cold["kernel_specialisations"]:
            say(f"  cold: {k['kernel'].rsplit('.', 1)[-1]} [{k['specialisation']}] {k['compile_s']:.2f} s "
                f"({k['nested_compilations']} nested compilations, {k['process']})")
    # the figure of issue 20: the cold compile time of each kernel specialisation a scenario uses
    out["kernel_specialisations"] = {name: [{"kernel": k["kernel"], "specialisation": k["specialisation"],
                                             "cold_compile_s": k["compile_s"]}
                                            for k in v["cold"]["kernel_specialisations"]]
                                     for name, v in out["scenarios"].items()}
    out["load_average_after"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    return out


def biggest(summary: dict, n: int = 5) -> list:
    """The ``n`` functions of a probed process (:func:`_compile_summary`) with the most compile time
    of their own (less their nested compilations), largest first."""
    return sorted(summary.get("kernels", ()), key=lambda r: -r["self_s"])[:n]


def compile_goals(out: dict) -> list:
    """Goals of :func:`run_compile_bench` (issues 20 and 44): each scenario of
    :data:`SCENARIO_GOALS_S` compiles within its seconds (the quick start :data:`COMPILE_GOAL_S`;
    the measured figure names the five functions with the most compile time of their own); each
    first point compiles the one event-integrator specialisation it uses; pool workers never compile;
    a warm cache compiles nothing."""
    sc = out["scenarios"]
    g = []
    for k, v in sc.items():
        limit = next((t for start, t in SCENARIO_GOALS_S.items() if k.startswith(start)), None)
        if limit is None:
            continue
        c = v["cold"]
        top = ", ".join(f"{r['kernel'].rsplit('.', 1)[-1]} {r['self_s']:.1f} s" for r in biggest(c))
        g.append(goal(f"{k.split(' (')[0]} (cold cache) compiles in <= {limit:g} s",
                      f"{c['compile_s']:.2f} s in {c['specialisations']} specialisations ({c['process_wall_s']:.1f} s "
                      f"wall); biggest: {top}", c["compile_s"] <= limit, timing=True))
    for k, v in sc.items():
        if "compliant" in k or k.startswith(("quick start", "first FE")):
            want = "with compliant stops" if "compliant" in k else "Newton stops only"
            got = [f"{s['kernel'].rsplit('.', 1)[-1]} [{s['specialisation']}]" for s in v["cold"]["kernel_specialisations"]]
            # the event integrator (integrate_work) once, of the kind the scene needs; beside it only
            # the sizing and allocation of its work arrays (substeps, _snap_fs, new_work, compliant_work;
            # the allocations run as Python and compile only the sizes they call)
            integ = [s for s in got if not s.startswith(("substeps [", "_snap_fs [", "new_work [", "compliant_work ["))]
            g.append(goal(f"{k.split(':')[0].split(' (')[0]} compiles the event integrator's specialisation it uses "
                          f"({want}) and no other", ", ".join(got) or "nothing",
                          len(integ) == 1 and integ[0].startswith("integrate_work [" + want)))
    n_w = {k: v["cold"]["specialisations_in_workers"] + v["warm"]["specialisations_in_workers"] for k, v in sc.items()}
    forked = sum(v["cold"]["forked_workers"] + v["warm"]["forked_workers"] for v in sc.values())
    loads = sum(v["warm"]["cache_loads_in_workers"] for v in sc.values())
    g.append(goal("pool workers never compile (every scenario, cold and warm)",
                  ", ".join(f"{k.split(':')[0].split(' (')[0]}: {n}" for k, n in n_w.items())
                  + f" ({forked} workers forked; {loads} cache loads in workers with a warm cache)",
                  not any(n_w.values())))
    n_warm = {k: v["warm"]["specialisations"] for k, v in sc.items()}
    g.append(goal("a warm cache compiles nothing (every scenario)",
                  ", ".join(f"{k.split(':')[0].split(' (')[0]}: {n}" for k, n in n_warm.items()),
                  not any(n_warm.values())))
    return g
