"""``vibeam bench``: the speed goal of the exact solver, as machine-readable JSON.

On the paper's Fig. 7 scene (beta 0.015, B 0.5e-3, R 0.9, Delta 0; Omega from
1.5 to 2.5) it times a sweep of ``points`` frequencies with
``transient + record = periods`` forcing periods per point, for

* ``event`` (exact, numba; timed after a warm-up call, median of repeats), and
* ``direct`` (scipy ``solve_ivp`` with events at the paper's tolerances:
  RK23, rtol 1e-4, atol 1e-8),

both inline in one process, and measures each one's amplitude error against a
converged reference: ``event`` with ``reference_periods`` transient periods
(the transient decays as exp(-beta t); 3000 periods leave < 1e-60 of it, so
the reference is exact to round-off).  It prints ratios, never asserts them.

``--map`` instead measures map throughput on 1 and 2 workers and the cost of the
line checkpoint (:func:`run_map_bench`); ``--effects`` instead times each scene effect (:func:`run_effects_bench`);
``--continuation`` instead times the continuation of a period-1 branch through its fold and
grazing and compares its cost per FRC point with a sweep of equal accuracy
(:func:`run_continuation_bench`, JSON key ``sdof``), and the same for the beam with all modes
of the shipped rig (:func:`run_beam_continuation_bench`, key ``beam``);
``--shooting`` instead measures the beam's periodic-orbit shots and Newton solves against
the event solver (:func:`run_shooting_bench`); ``--scaling`` instead measures how the cost of a sweep grows with the periods
simulated and with the retained modes of the FE beam, with fitted exponents
(:func:`run_scaling_bench`); ``--fit`` instead times ``vibeam fit`` against its goal
(:func:`run_fit_bench`); ``--latency`` instead measures how fast Ctrl-C stops an inline and a
pooled run and how far a point overshoots its wall-time limit (:func:`run_latency_bench`);
``--compile`` instead measures the cold and warm numba compile time of shipped scenarios (the quick
start, a compliant SDOF point, FE points, continuations), per kernel specialisation (the event
integrator's for Newton stops only and with compliant stops) and per compiled function, in fresh
processes with an empty ``NUMBA_CACHE_DIR`` (:func:`run_compile_bench`).

One module per benchmark (:mod:`vibeam.bench.fig7` the default, ``cli_run``, ``maps``, ``scaling``,
``shooting``, ``effects``, ``continuation``, ``fit``, ``latency``, ``compilation``, ``basins``,
``estimate``), what they share in :mod:`vibeam.bench.common`; :func:`main_bench` runs the one the
command line asks for, by the names this package re-exports (``run_bench``, ...).  A benchmark's
constants are read in its own module: to replace one (a test's ``COMPILE_SCENARIOS``), set it there.
"""
from __future__ import annotations

import json
import sys

from vibeam.bench.basins import BASINS_GOAL_S, basins_goals, run_basins_bench
from vibeam.bench.cli_run import run_cli_bench
from vibeam.bench.common import (BUSY_LOAD_PER_CORE, busy_reason, goal, judge_timings, machine_state, print_verdicts,
                                 verdict_word)
from vibeam.bench.compilation import (COMPILE_GOAL_S, COMPILE_PROBE, COMPILE_SCENARIOS, COMPLIANT_POINT, FE_POINT,
                                      compile_goals, probe_compile, run_compile_bench)
from vibeam.bench.continuum import (BUILD_GOAL_S, LOAD_GOAL_S, SWEEP_RATIO_GOAL, continuum_goals,
                                    run_continuum_bench)
from vibeam.bench.continuation import (BEAM_CONTINUATION_GOAL_S, CONTINUATION_GOAL_S, run_beam_continuation_bench,
                                       run_continuation_bench)
from vibeam.bench.effects import EFFECTS_BENCH, effects_goals, run_effects_bench
from vibeam.bench.estimate import ESTIMATE_GOAL_FACTOR, estimate_goals, run_estimate_bench
from vibeam.bench.fig7 import GOAL_PERIODS, GOAL_POINTS, bench_goals, run_bench
from vibeam.bench.fit import run_fit_bench
from vibeam.bench.latency import LATENCY_CASE, LATENCY_GOAL_S, LATENCY_PROBE, latency_goals, run_latency_bench
from vibeam.bench.maps import map_goals, run_map_bench
from vibeam.bench.periods import periods_goals, run_periods_bench
from vibeam.bench.scaling import run_scaling_bench, scaling_goals
from vibeam.bench.shooting import run_shooting_bench, shooting_goals
from vibeam.bench.uncertainty import run_uncertainty_bench, uncertainty_goals

__all__ = ["main_bench",
           "run_bench", "bench_goals", "GOAL_POINTS", "GOAL_PERIODS",
           "run_cli_bench",
           "run_map_bench", "map_goals",
           "run_scaling_bench", "scaling_goals",
           "run_shooting_bench", "shooting_goals",
           "run_effects_bench", "effects_goals", "EFFECTS_BENCH",
           "run_continuation_bench", "run_beam_continuation_bench", "CONTINUATION_GOAL_S", "BEAM_CONTINUATION_GOAL_S",
           "run_fit_bench",
           "run_latency_bench", "latency_goals", "LATENCY_CASE", "LATENCY_PROBE", "LATENCY_GOAL_S",
           "run_compile_bench", "compile_goals", "probe_compile", "COMPILE_GOAL_S", "COMPILE_PROBE",
           "COMPILE_SCENARIOS", "FE_POINT", "COMPLIANT_POINT",
           "run_basins_bench", "basins_goals", "BASINS_GOAL_S",
           "run_continuum_bench", "continuum_goals", "BUILD_GOAL_S", "LOAD_GOAL_S", "SWEEP_RATIO_GOAL",
           "run_estimate_bench", "estimate_goals", "ESTIMATE_GOAL_FACTOR",
           "run_uncertainty_bench", "uncertainty_goals",
           "goal", "verdict_word", "print_verdicts", "BUSY_LOAD_PER_CORE", "busy_reason", "judge_timings",
           "machine_state"]


def main_bench(args) -> int:
    """``vibeam bench``: one benchmark as JSON on stdout, a PASS/FAIL/NOT CHECKED line per stated
    goal on stderr; exit code 1 when any goal FAILed (0 otherwise: every goal passed or was not
    checked in this configuration, or was a timing that failed on a busy machine:
    :func:`vibeam.bench.common.judge_timings`, the load in the JSON's ``machine``; ``--strict``
    judges those too)."""
    log = (lambda m: print(m, file=sys.stderr))
    before = machine_state()
    if getattr(args, "fit", False):
        out, mode = run_fit_bench(jobs=getattr(args, "jobs", None) or 2), "--fit"
        out["goals"] = [goal(out["goal"], f"{out['fits']['sdof gain,R']['time_s']:.2f} s", out["pass"], timing=True)]
    elif getattr(args, "continuation", False):
        sdof = run_continuation_bench(repeats=getattr(args, "repeats", 5), log=log)
        beam = run_beam_continuation_bench(repeats=min(3, getattr(args, "repeats", 3)), log=log)
        out, mode = {"sdof": sdof, "beam": beam}, "--continuation"
        g, bn = sdof["goal"], beam["neutral"]
        out["goals"] = [goal(f"~500-point SDOF branch with stability in under {g['time_s']:g} s (wall)",
                             f"{sdof['continuation']['time_s']:.4f} s", g["verdict"] == "pass", timing=True),
                        goal("the same in CPU time (a shared machine)", f"{sdof['continuation']['cpu_time_s']:.4f} s",
                             g["cpu_verdict"] == "pass"),          # CPU time: judged on a busy machine too
                        goal(f"all-modes beam branch, rig-fe-neutral 14-17 Hz, in under {BEAM_CONTINUATION_GOAL_S:g} s",
                             f"{bn['time_s']:.2f} s", bn["goal"]["verdict"] == "pass", timing=True),
                        goal(f"all-modes beam, rig-fe-tight 14-17 Hz (chatter ending in sticking), in under "
                             f"{BEAM_CONTINUATION_GOAL_S:g} s",
                             f"{beam['tight']['14-17 Hz from the event orbit at 14 Hz']['time_s']:.2f} s",
                             beam["tight"]["goal_verdict_14_17_Hz"] == "pass", timing=True)]
    elif getattr(args, "scaling", False):
        out, mode = run_scaling_bench(repeats=getattr(args, "repeats", 3)), "--scaling"
        out["goals"] = scaling_goals(out)
    elif getattr(args, "map", False):
        out, mode = run_map_bench(log=log), "--map"
        out["goals"] = map_goals(out)
    elif getattr(args, "shooting", False):
        out, mode = run_shooting_bench(repeats=getattr(args, "repeats", 5)), "--shooting"
        out["goals"] = shooting_goals(out)
    elif getattr(args, "effects", False):
        out, mode = run_effects_bench(), "--effects"
        out["goals"] = effects_goals(out)
    elif getattr(args, "latency", False):
        out, mode = run_latency_bench(repeats=getattr(args, "repeats", 3), log=log), "--latency"
        out["goals"] = latency_goals(out)
    elif getattr(args, "basins", False):
        out, mode = run_basins_bench(jobs=getattr(args, "jobs", None) or 2, log=log), "--basins"
        out["goals"] = basins_goals(out)
    elif getattr(args, "continuum", False):
        out, mode = run_continuum_bench(repeats=min(3, getattr(args, "repeats", 3)), log=log), "--continuum"
        out["goals"] = continuum_goals(out)
    elif getattr(args, "estimate", False):
        out, mode = run_estimate_bench(log=log), "--estimate"
        out["goals"] = estimate_goals(out)
    elif getattr(args, "settling", False):
        out, mode = run_periods_bench(samples=getattr(args, "samples", None) or 16,
                                      jobs=getattr(args, "jobs", None) or 1, log=log), "--settling"
        out["goals"] = periods_goals(out)
    elif getattr(args, "uncertainty", False):
        out, mode = run_uncertainty_bench(samples=getattr(args, "samples", None) or 1024,
                                          jobs=getattr(args, "jobs", None) or 2, log=log), "--uncertainty"
        out["goals"] = uncertainty_goals(out)
    elif getattr(args, "compile", False):
        out, mode = run_compile_bench(log=log), "--compile"
        out["goals"] = compile_goals(out)
    elif getattr(args, "cli", False):
        out, mode = run_cli_bench(repeats=args.repeats, direct_points=args.direct_points or 11, log=log), "--cli"
    else:
        out = run_bench(points=args.points, periods=args.periods, repeats=args.repeats,
                        direct_points=args.direct_points)
        out["goals"], mode = bench_goals(out), ""
    after = machine_state()
    out["machine"] = {"cores": after["cores"], "load_average_before": before["load_average"],
                      "load_average_after": after["load_average"], "busy_load_per_core": BUSY_LOAD_PER_CORE,
                      "strict": bool(getattr(args, "strict", False))}
    # a timing goal that FAILed on a busy machine cannot be judged: NOT CHECKED with the load (--strict: FAIL)
    out["goals"] = judge_timings(out["goals"], out["machine"], strict=out["machine"]["strict"])
    print(json.dumps(out, indent=2))
    print_verdicts(mode, out["goals"])
    failed = [g for g in out["goals"] if g.get("pass") is False]
    return 1 if failed else 0
