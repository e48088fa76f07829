"""``vibeam bench --latency``: how fast Ctrl-C stops an inline and a pooled run, and how far a
point overshoots its wall-time limit (:func:`run_latency_bench`)."""
from __future__ import annotations

import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from vibeam.bench.common import goal, root
from vibeam.case.schema import load_case, parse_case
from vibeam.engine.sweep import Sweep, run_sweep
from vibeam.models import make_solver
from vibeam.models.builders.sdof import sdof


#: the scene of the interrupt figures (tests/test_interrupts.py): the rig's SDOF on a pre-stressed
#: stop (chatter), a map of 2 x 6 lines of 6 points; 400000 transient periods make a point 200
#: solver calls of 2000 periods (seconds), so a signal always falls inside a long point
LATENCY_CASE = """
name = "latency"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.72
gap_mm = -0.05
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [14.0, 17.0, 6]
direction = "both"
transient_periods = 400000
record_periods = 16
[map]
parameter = "voltage"
values = [0.5, 0.7, 6]
[[run]]
name = "exact"
method = "event"
recurrence = false
"""

#: ``python -c PROBE MARKS vibeam-args...``: the command line with markers ``<pid> <monotonic s>
#: begin|end <n_transient> <n_record>`` around every EventSolver.point call (forked pool workers
#: inherit the patched class) and ``<pid> <s> handler`` when the main process's SIGINT handler
#: (Python's own, wrapped) runs; one os.write per line on an O_APPEND file
LATENCY_PROBE = """
import os, signal, sys, time
fd = os.open(sys.argv[1], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
def mark(text):
    os.write(fd, f"{os.getpid()} {time.monotonic():.6f} {text}\\n".encode())
from vibeam.models import EventSolver
inner = EventSolver.point
def point(self, Omega, state, n_tr, n_rec, *a, **k):
    mark(f"begin {n_tr} {n_rec}")
    out = inner(self, Omega, state, n_tr, n_rec, *a, **k)
    mark(f"end {n_tr} {n_rec}")
    return out
EventSolver.point = point
def on_int(signum, frame):
    mark("handler")
    signal.default_int_handler(signum, frame)
signal.signal(signal.SIGINT, on_int)
from vibeam.cli import main
sys.exit(main(sys.argv[2:]))
"""

LATENCY_GOAL_S = 1.0     # "Ctrl-C and the wall-time limit act within a second" (EventSolver.chunk_periods)


def _probe_marks(path) -> list:
    """The probe's marker file as ``(pid, t, word, rest)`` rows (a torn last line is skipped)."""
    rows = []
    for line in Path(path).read_text().splitlines(keepends=True):
        if line.endswith("\n"):
            pid, t, word, *rest = line.split()
            rows.append((int(pid), float(t), word, rest))
    return rows


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")


def _interrupt_once(jobs: int, hang_s: float = 120.0) -> dict:
    """One ``vibeam map`` of :data:`LATENCY_CASE` with ``--jobs jobs`` under the probe: SIGINT as
    soon as the main process (``jobs = 1``) or both workers are inside a long point's solver
    calls, then the time to the process's exit (and to its handler), the exit code, the
    solver calls begun after the handler ran, the median call's length and the workers still
    alive at the exit."""
    with tempfile.TemporaryDirectory() as tmp:
        case, marks = Path(tmp) / "latency.toml", Path(tmp) / "marks.txt"
        case.write_text(LATENCY_CASE)
        marks.touch()
        p = subprocess.Popen([sys.executable, "-c", LATENCY_PROBE, str(marks), "map", str(case), "--out",
                              str(Path(tmp) / "out"), "--jobs", str(jobs), "--quiet", "--no-plots"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        try:
            t0 = time.monotonic()
            while True:
                rows = _probe_marks(marks)
                n = {}
                for r in rows:       # transient calls of a long point begun, per process
                    if r[2] == "begin" and r[3] == ["2000", "0"]:
                        n[r[0]] = n.get(r[0], 0) + 1
                inside = {pid for pid, k in n.items() if k >= 3}
                workers = sorted(set(n) - {p.pid})
                if (p.pid in inside) if jobs == 1 else len(inside - {p.pid}) >= min(jobs, 2):
                    break
                if p.poll() is not None or time.monotonic() - t0 > hang_s:
                    raise RuntimeError(f"the map never reached its long points (exit {p.poll()}): "
                                       f"{(p.stderr.read() if p.poll() is not None else '')[-300:]}")
                time.sleep(0.01)
            t_sig = time.monotonic()
            p.send_signal(signal.SIGINT)
            p.wait(timeout=hang_s)
            t_exit = time.monotonic()
        finally:
            if p.poll() is None:
                p.kill()
                p.wait()
        rows = _probe_marks(marks)
    hand = [r[1] for r in rows if r[2] == "handler"]
    t_hand = hand[0] if hand else None
    began = {}
    calls = []
    for pid, t, word, rest in rows:
        if rest == ["2000", "0"]:
            if word == "begin":
                began[pid] = t
            elif pid in began:
                calls.append(t - began.pop(pid))
    return {"sigint_to_exit_s": t_exit - t_sig, "exit_code": p.returncode,
            "sigint_to_handler_s": None if t_hand is None else t_hand - t_sig,
            "calls_after_handler": None if t_hand is None else sum(1 for r in rows if r[2] == "begin" and r[1] >= t_hand),
            "median_call_s": float(np.median(calls)) if calls else None, "calls_timed": len(calls),
            "workers": len(workers), "workers_alive_at_exit": sum(_alive(w) for w in workers)}


def _time_limit_overshoot(name: str, model, Omega: float, limit_s: float) -> dict:
    """A point of 10^7 transient periods (each integrated) with ``point_time_limit_s = limit_s``, inline: its wall
    time (the point's own ``wall_time_s``), the overshoot beyond the limit, and the solver calls
    (chunks) it made."""
    # every period integrated: a transient that recurs exactly would end long before the limit
    solver = make_solver(model, "event", recurrence=False)
    run_sweep(solver, Sweep(Omega=np.array([Omega]), transient_periods=2, record_periods=2))   # warm-up
    calls = []
    inner = solver.point

    def counting(*a, **k):
        calls.append(a[2])
        return inner(*a, **k)

    solver.point = counting
    out = run_sweep(solver, Sweep(Omega=np.array([Omega]), transient_periods=10 ** 7, record_periods=4,
                                  point_time_limit_s=limit_s)).data
    wall = float(out["wall_time_s"][0])
    return {"scene": name, "limit_s": limit_s, "status": str(out["status"][0]), "message": str(out["message"][0]),
            "wall_time_s": wall, "overshoot_s": wall - limit_s, "calls": len(calls),
            "chunk_periods": int(getattr(solver, "chunk_periods", 0) or 0),
            "mean_call_s": wall / max(len(calls), 1)}


def run_latency_bench(repeats: int = 3, limit_s: float = 0.5, beam: bool = True, log=None) -> dict:
    """How fast a run stops: SIGINT to exit of an inline long point and of a ``--jobs 2`` map,
    and the wall-time limit's overshoot.

    A compiled kernel cannot be interrupted inside a call, so the sweep engine cuts a point
    into calls of ``solver.chunk_periods`` periods (:func:`vibeam.engine.sweep._simulate`): Ctrl-C
    lands at the next return, the wall-time limit is checked between calls, and a pooled run
    terminates its workers instead of waiting for their lines.  Measured here, never asserted
    (the tests check the behaviour by counting calls: tests/test_interrupts.py,
    tests/test_settle.py):

    * ``inline``, ``pool_2_workers``: ``vibeam map`` of :data:`LATENCY_CASE` in a fresh process
      with ``--jobs 1`` / ``--jobs 2`` under :data:`LATENCY_PROBE`; SIGINT once the main process
      / both workers are inside a long point (200 calls of 2000 periods); the time from the
      signal to the process's exit (median of ``repeats``; interpreter shutdown included, as a
      user sees it), to the handler, and the calls begun after the handler ran.
    * ``time_limit``: a point of 10^7 transient periods with ``point_time_limit_s = limit_s``,
      inline, on the Fig. 13 SDOF (Omega 2.0), the chatter scene of :data:`LATENCY_CASE` (15.5 Hz)
      and (``beam``) the rig's FE beam with all modes (rig-fe-neutral, 15.4 Hz): the point's wall
      time beyond the limit (it includes the first call, before the clock starts).

    Returns
    -------
    dict
        JSON-ready: ``inline``, ``pool_2_workers`` (``sigint_to_exit_s`` median and ``runs``),
        ``time_limit`` (per scene), ``goal_s``, ``cores``, ``load_average``.
    """
    say = log or (lambda m: None)
    out = {"case": "SDOF on a pre-stressed stop (gap -0.05 mm, chatter), map 2 x 6 lines of 6 points, "
                   "400000 transient periods per point", "repeats": repeats, "goal_s": LATENCY_GOAL_S}
    for key, jobs in (("inline", 1), ("pool_2_workers", 2)):
        runs = []
        for _ in range(repeats):
            runs.append(_interrupt_once(jobs))
            r = runs[-1]
            say(f"SIGINT, --jobs {jobs}: exit after {r['sigint_to_exit_s']:.3f} s (exit code {r['exit_code']}; "
                f"calls of 2000 periods ~{(r['median_call_s'] or 0.0) * 1e3:.1f} ms, {r['calls_after_handler']} "
                f"begun after the handler)")
        hand = [r["sigint_to_handler_s"] for r in runs if r["sigint_to_handler_s"] is not None]
        out[key] = {"jobs": jobs, "sigint_to_exit_s": statistics.median(r["sigint_to_exit_s"] for r in runs),
                    "sigint_to_handler_s": statistics.median(hand) if hand else None,
                    "exit_codes": sorted({r["exit_code"] for r in runs}), "runs": runs}
    chatter = parse_case(LATENCY_CASE.split("[map]")[0] + '[[run]]\nname = "exact"\nmethod = "event"\n')
    scenes = [("sdof fig13 Omega 2.0", sdof(0.015, 0.5e-3, 0.5e-3, R=0.9), 2.0),
              ("sdof chatter 15.5 Hz", chatter.model_spec().scene(), 15.5 / 7.6)]
    if beam:
        case, _ = load_case(root() / "cases" / "rig-fe-neutral.toml")
        scenes.append(("beam rig-fe-neutral all modes 15.4 Hz", case.model_spec().scene(), 15.4 / 7.6))
    out["time_limit"] = {}
    for name, model, W in scenes:
        r = _time_limit_overshoot(name, model, W, limit_s)
        out["time_limit"][name] = r
        say(f"point_time_limit_s = {limit_s:g}, {name}: point ended after {r['wall_time_s']:.3f} s "
            f"({r['calls']} calls of {r['chunk_periods']} periods)")
    out["cores"] = os.cpu_count()
    out["load_average"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    return out


def latency_goals(out: dict) -> list:
    """Goals of :func:`run_latency_bench`: Ctrl-C stops a run, and the wall-time limit ends a
    point, within about a second."""
    g = [goal(f"Ctrl-C stops {k.replace('_', ' ')} within {LATENCY_GOAL_S:g} s (SIGINT to exit, code 130)",
              f"{out[k]['sigint_to_exit_s']:.3f} s, exit {out[k]['exit_codes']}",
              out[k]["sigint_to_exit_s"] <= LATENCY_GOAL_S and out[k]["exit_codes"] == [130],
              timing=out[k]["exit_codes"] == [130])        # a wrong exit code is a failure whatever the load
         for k in ("inline", "pool_2_workers")]
    g += [goal(f"point_time_limit_s overshoot within {LATENCY_GOAL_S:g} s ({name})", f"{r['overshoot_s']:.3f} s",
               r["status"] == "failed" and r["overshoot_s"] <= LATENCY_GOAL_S, timing=r["status"] == "failed")
          for name, r in out["time_limit"].items()]
    return g
