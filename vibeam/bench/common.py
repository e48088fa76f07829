"""What the benchmarks share: a stated goal and its verdict (the JSON's ``goals``, the PASS/FAIL
lines; a timing goal FAILed on a busy machine is NOT CHECKED unless ``--strict``), the checkout's root, a timed inline sweep and a shipped scene built as ``vibeam run``
builds it."""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from vibeam.case.schema import load_case
from vibeam.engine.sweep import Sweep, run_sweep
from vibeam.models import make_solver


#: a machine is too busy to judge a timing goal when its runnable processes, the benchmark's own
#: included, exceed this many per core (1-minute load average): a process then gets at most 80 % of a
#: core on average, and less while the load peaks, so a time can be off by more than the margin of a
#: goal (the 2-worker speed-up's 1.6x of at most 2x) through the load alone
BUSY_LOAD_PER_CORE = 1.25


def goal(text: str, measured: str, ok: bool, not_checked: str = "", timing: bool = False) -> dict:
    """One stated goal of a benchmark and its verdict (in the JSON, and printed by
    :func:`print_verdicts`): ``pass`` True or False, or None with ``not_checked`` saying why
    when the benchmark did not run in the goal's configuration (``--points 21`` against a
    101-point goal): such a measurement neither passes nor fails it.  ``timing``: the goal is a
    wall time or a ratio of wall times (``"timing": true`` in the JSON), which a busy machine can
    fail on its own (:func:`judge_timings`)."""
    if not_checked:
        out = {"goal": text, "measured": measured, "pass": None, "not_checked": not_checked}
    else:
        out = {"goal": text, "measured": measured, "pass": bool(ok)}
    if timing:
        out["timing"] = True
    return out


def machine_state() -> dict:
    """``{"cores": os.cpu_count(), "load_average": [1, 5, 15 min] or None}`` now (None where the
    system has no load average)."""
    return {"cores": os.cpu_count(), "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None}


def busy_reason(machine: dict) -> str:
    """Why the machine was too busy to judge a timing goal, or ``""``.

    ``machine``: ``cores``, and ``load_average_before`` / ``load_average_after`` (1, 5 and 15 min)
    taken when the benchmark started and ended (:func:`machine_state`).  The demand is the larger
    of the 1-minute load before plus the benchmark's own process and the 1-minute load after (which
    counts the benchmark's processes itself); above :data:`BUSY_LOAD_PER_CORE` per core the machine
    is busy.  No load average (or no core count): never busy."""
    cores = machine.get("cores")
    before, after = machine.get("load_average_before"), machine.get("load_average_after")
    if not cores or not before or not after:
        return ""
    demand = max(float(before[0]) + 1.0, float(after[0]))
    if demand <= BUSY_LOAD_PER_CORE * cores:
        return ""
    return (f"the machine was busy: 1-minute load average {float(before[0]):.1f} before and {float(after[0]):.1f} "
            f"after the benchmark on {cores} cores (above {BUSY_LOAD_PER_CORE:g} runnable processes per core with "
            f"the benchmark's own), so this timing cannot be judged; rerun on a quiet machine, or --strict to "
            f"judge it anyway")


def judge_timings(goals: list, machine: dict, strict: bool = False) -> list:
    """The goals with each FAILed timing goal (:func:`goal`'s ``timing``) made NOT CHECKED when the
    machine was busy (:func:`busy_reason`; the JSON keeps ``"failed_on_a_busy_machine": true``);
    ``strict``: as they are.  A timing that passes on a busy machine passes (the load only slows
    it), and a goal that is not a timing is judged whatever the load."""
    why = "" if strict else busy_reason(machine)
    if not why:
        return list(goals)
    return [dict(g, **{"pass": None, "not_checked": why, "failed_on_a_busy_machine": True})
            if g.get("timing") and g.get("pass") is False else g for g in goals]


def verdict_word(g: dict) -> str:
    """``PASS``, ``FAIL`` or ``NOT CHECKED`` of a :func:`goal`."""
    return "NOT CHECKED" if g.get("pass") is None else ("PASS" if g["pass"] else "FAIL")


def print_verdicts(mode: str, goals: list) -> None:
    """``vibeam bench MODE: PASS|FAIL|NOT CHECKED goal (measured)`` on stderr, one line per goal
    (stdout keeps the JSON); a goal not checked says why."""
    for g in goals:
        why = f"; {g['not_checked']}" if g.get("pass") is None else ""
        print(f"vibeam bench{' ' + mode if mode else ''}: {verdict_word(g)}  {g['goal']}  "
              f"(measured: {g['measured']}{why})", file=sys.stderr)


def root() -> Path:
    """The checkout (its ``cases/`` folder holds the benchmarks' scenes)."""
    return Path(__file__).resolve().parents[2]


def timed_sweep(model, method, Omega, n_transient, n_record, **settings):
    """``(seconds, SweepResult)`` of an inline sweep of ``model`` by ``method`` over ``Omega`` (up,
    no continuation, ``n_transient`` + ``n_record`` periods per point)."""
    sw = Sweep(Omega=Omega, direction="up", transient_periods=n_transient, record_periods=n_record,
               continuation=False)
    t0 = time.perf_counter()
    res = run_sweep(make_solver(model, method, **settings), sw, jobs=1)
    return time.perf_counter() - t0, res


def build_scene(fname: str, over: dict | None):
    """Case, scene, solver settings and the scene's build time of a shipped case, built as
    ``vibeam run`` builds them (:func:`vibeam.cli.run_case`)."""
    case, _ = load_case(root() / "cases" / fname)
    run = next((r for r in case.run if r.method == "event"), case.run[0])
    spec = case.model_spec(over)
    spec.scene()                  # first build: imports (scikit-fem, ...) and caches
    t0 = time.perf_counter()
    scene = spec.scene()
    t_build = time.perf_counter() - t0
    return case, scene, case.run_settings(run), t_build
