"""What the event kernel's Fig. 7 sweep spends per impact: the mechanisms issue 60's bisection
found, held by checks that need no clock (counted calls, the code's structure).

Measured by instructions (valgrind --tool=callgrind, one warm 101-point Fig. 7 sweep of 500
periods, 50,500 impacts; the kernels compiled for valgrind's CPU, haswell) between 6b53e11 and
537b113: e2332ad's overflow checks in ``summarize`` +38 M instructions (+5.4 %, NumPy's
reductions on each float output), 1370a3e's phases +24 M in the event loop (its counters in the
work array ``lp``, stored and reloaded on every step), and, older than both, a ``sincos`` of the
forcing phase on every free step (LLVM hoisted ``_contact_acc``'s sin and cos out of the touch
check's loop): 9 % of the sweep.
"""
from __future__ import annotations

import ast
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from vibeam.engine import records
from vibeam.models.trajectory import Trajectory

INTEGRATOR = Path(__file__).resolve().parents[1] / "models" / "core" / "integrator.py"


def _functions():
    tree = ast.parse(INTEGRATOR.read_text(), str(INTEGRATOR))
    return {n.name: n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}


def _reads_lp(node) -> bool:
    return any(isinstance(n, ast.Name) and n.id == "lp" for n in ast.walk(node))


def test_a_step_keeps_its_counters_in_local_variables():
    """The phases called on every step take the step's counters (sub-step, tables, the dense
    record's samples) as arguments and return them, and the step loop reads no ``lp``: kept in
    the work array ``lp`` (1370a3e), every step stored and reloaded them (numba's arrays may alias
    one another, so LLVM keeps no element in a register across a store to another array), 9 M
    instructions of the Fig. 7 sweep once the per-step sincos was gone (2 % of the kernel's)."""
    fns = _functions()
    for name in ("_free_step", "_free_outputs", "_free_arc", "_held_phase", "_contact_event"):
        assert not _reads_lp(fns[name]), f"{name} reads or takes lp"
    loops = [n for n in ast.walk(fns["integrate_work"]) if isinstance(n, ast.While)
             and ast.unparse(n.test) == "fs[_REM] > 0.0"]
    assert len(loops) == 1
    assert not _reads_lp(loops[0]), "the step loop reads lp"


def test_the_touch_check_evaluates_the_forcing_only_where_a_stop_is_reached():
    """``_free_touch`` runs its loop over the stops, whose ``_contact_acc`` evaluates sin and cos
    of the forcing phase, under an ``if`` on a stop being reached: that phase is invariant in the
    loop and LLVM hoists both functions (speculatable) to the loop's entry, which every free step
    passed: a ``sincos`` call (~200 instructions) per step, 62 M of libm's instructions in a Fig. 7
    sweep (145 M -> 84 M)."""
    fn = _functions()["_free_touch"]
    calls = [s for s in fn.body if any(isinstance(n, ast.Call) and ast.unparse(n.func) == "_contact_acc"
                                       for n in ast.walk(s))]
    assert len(calls) == 1
    assert isinstance(calls[0], ast.If), ast.unparse(calls[0])[:200]


def _trajectory(n_record=64, spp=64, Omega=2.0):
    """A settled period-1 record of the Fig. 7 kind: a sinusoid touching the stop at 0 once a
    period (rebounding at 1.1 in q'), with its stroboscopic samples."""
    t = np.arange(n_record * spp) / spp
    q = 0.5 * (np.cos(2 * np.pi * t) - 1.0)
    qd = -np.pi * np.sin(2 * np.pi * t)
    return Trajectory(Omega=Omega, samples=np.column_stack([q, qd]), samples_per_period=spp,
                      impact_times=np.arange(n_record) * 2 * np.pi / Omega,
                      impact_velocities=np.full(n_record, 1.1), n_impacts=n_record,
                      q_min=float(q.min()), q_max=float(q.max()))


def test_the_overflow_scan_runs_numpy_on_arrays_only(monkeypatch):
    """``summarize`` scans its outputs for an infinity (a start of 1e300, e2332ad) with
    :func:`math.isinf` on float scalars and NumPy only on arrays: NumPy's ``isinf(x).any()`` on a
    scalar costs ~20,000 instructions, and a Fig. 7 point has 17 float outputs (e2332ad's scan: 31
    M of a sweep's 750 M).  The verdicts are those of the scan it replaces (NumPy's on each)."""
    calls = []
    isinf = np.isinf

    def counted(x, *a, **k):
        calls.append(type(x).__name__)
        return isinf(x, *a, **k)

    monkeypatch.setattr(np, "isinf", counted)
    out = records.summarize(_trajectory(), Delta=0.0)
    monkeypatch.undo()
    arrays = [k for k, v in out.items() if isinstance(v, np.ndarray) and v.dtype.kind == "f"]
    floats = [k for k, v in out.items() if isinstance(v, float)]
    assert out["status"] == "ok" and len(floats) >= 10 and arrays
    assert calls == ["ndarray"] * len(arrays)
    # the same verdict as NumPy's scan, value by value
    samples = [1.0, math.inf, -math.inf, math.nan, np.float32(np.inf), np.float64(-np.inf), np.float32(2.0),
               np.array([1.0, np.nan]), np.array([np.nan, -np.inf]), np.zeros((0, 2)), np.array([1, 2]),
               np.array(np.inf), 3, "ok", None]
    for v in samples:
        want = isinstance(v, (float, np.floating, np.ndarray)) and np.asarray(v).dtype.kind == "f" \
            and bool(np.isinf(v).any())
        assert records._infinite(v) == want, v
    # an infinite output still fails the point
    bad = replace(_trajectory(), impact_velocities=np.full(64, np.inf))
    assert records.summarize(bad, Delta=0.0)["status"] == "failed"
