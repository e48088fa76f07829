"""What the benchmarks share: a stated goal and its verdict (the JSON's ``goals``, the PASS/FAIL
lines), the checkout's root, a timed inline sweep and a shipped scene built as ``vibeam run``
builds it."""
from __future__ import annotations

import sys
import time
from pathlib import Path

from vibeam.case.schema import load_case
from vibeam.engine.sweep import Sweep, run_sweep
from vibeam.models import make_solver


def goal(text: str, measured: str, ok: bool, not_checked: str = "") -> dict:
    """One stated goal of a benchmark and its verdict (in the JSON, and printed by
    :func:`print_verdicts`): ``pass`` True or False, or None with ``not_checked`` saying why
    when the benchmark did not run in the goal's configuration (``--points 21`` against a
    101-point goal): such a measurement neither passes nor fails it."""
    if not_checked:
        return {"goal": text, "measured": measured, "pass": None, "not_checked": not_checked}
    return {"goal": text, "measured": measured, "pass": bool(ok)}


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
    """Case, spec, model, solver settings and sweep settings of a shipped case, built as
    ``vibeam run`` builds them (:func:`vibeam.cli.run_case`)."""
    case, _ = load_case(root() / "cases" / fname)
    run = next((r for r in case.run if r.method == "event"), case.run[0])
    spec = case.model_spec(over)
    spec.build()                  # first build: imports (scikit-fem, ...) and caches
    t0 = time.perf_counter()
    model = spec.build()
    t_build = time.perf_counter() - t0
    return case, model, case.run_settings(run), t_build
