"""Honest numbers: the spread of non-periodic points, unsettled transients, ``transient_periods =
"auto"``, chunked kernel calls (interruptible points, the wall-time limit)."""
import math
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from vibeam.case.schema import CaseError, parse_case
from vibeam.models import EventSolver, linear_amplitude, make_solver
from vibeam.models.builders.sdof import sdof
from vibeam.models.mapping import is_admissible, newton_fixed_point, orbit_extremes
from vibeam.engine.records import (MARGINAL, SETTLED_MARGIN, STATUSES, amplitude_spread, converging, spread_agrees,
                            strobe_returns, summarize, transient_verdict, verdict_from_returns)
from vibeam.engine.sweep import UNITS, Sweep, _simulate, run_sweep, stack
from vibeam.models.scene import one_mode

FIG8 = sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=0.7e-3)
FIG13 = sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=0.5e-3)


def _one(model, W, start=None, **kw):
    """One point from rest (or from the state ``start``; no continuation), inline."""
    sw = Sweep(Omega=np.array([W]), continuation=False, **kw)
    solver = make_solver(model, "event") if start is None else _From(model, start)
    return {k: v[0] for k, v in run_sweep(solver, sw).data.items()}


class _From(EventSolver):
    """The event solver with another initial state than rest."""

    def __init__(self, sc, start):
        super().__init__(sc)
        self.start = np.asarray(start, float)

    def point(self, Omega, state0, *args, **kw):
        return super().point(Omega, self.start if state0 is None else state0, *args, **kw)


def _period1_amplitude(sc, W, guess_point):
    """Amplitude of the period-1 orbit by Newton on the impact map (independent oracle)."""
    tr = EventSolver(sc).point(W, np.array([*guess_point["strobe"][-1], 0.0]), 0, 1, 8)
    x = newton_fixed_point(sc, W, [(W * tr.impact_times[0]) % (2 * math.pi), tr.impact_velocities[0]], 1)
    assert x is not None and is_admissible(sc, W, x, 1)[0]
    return one_mode(sc).Delta - orbit_extremes(sc, W, x, 1)[0]


# ----------------------------------------------------------------------------- spread
def test_per_period_minima_are_exact_and_the_spread_brackets_them():
    """At a non-periodic point (Fig. 13, Omega = 2.5) the kernel's per-period minima are exact:
    never above the minimum of a dense resampling of the same closed period (4096 samples), and
    within the interpolation bound M2 h^2 / 8 of it (M2 = max |q''| <= |q_min| + F + 2 beta
    max|q'|, h = T / 4096).  The spread brackets the mean, its maximum is the exact amplitude,
    and a coarse record's sample minima (64 per period) lie above the exact ones."""
    W = 2.5
    m = one_mode(FIG13)
    ev = make_solver(FIG13, "event")
    tr0 = ev.point(W, None, 1000, 1, 64)
    s0 = tr0.final_state
    fine = ev.point(W, s0, 0, 24, 4096)
    coarse = ev.point(W, s0, 0, 24, 64)
    out = summarize(fine, m.Delta)
    assert out["period"] == 0 and out["record_periods"] == 24
    pm = fine.period_min
    # the closed period [kT, (k + 1) T]: its samples and the first one of the next period
    q = np.r_[fine.samples[:, 0], fine.final_state[0]]
    dense = np.array([q[k * 4096:(k + 1) * 4096 + 1].min() for k in range(24)])
    T = 2 * math.pi / W
    F = W ** 2 * m.B
    M2 = abs(fine.q_min) + F + 2 * m.beta * np.max(np.abs(fine.samples[:, 1]))
    assert np.all(pm <= dense) and np.all(dense - pm <= M2 * (T / 4096) ** 2 / 8)
    # the same trajectory at 64 samples per period has the same exact minima, far below the sample
    # error of 64 samples per period (~M2 (T/64)^2 / 8 = 1e-6): each period of the fine record run
    # again on the coarse grid from its own start (the stroboscopic sample), so that the chaotic
    # motion cannot amplify the two step grids' different rounding (~1e-18) over the record (one
    # 24-period run on each grid differed by 2.2e-14 or 1.4e-12 at the end, depending on the last
    # bits of the impact times); measured 1e-16 (the restart splits the state anew)
    starts = fine.strobe
    pc = np.array([ev.point(W, np.r_[starts[k], 0.0], 0, 1, 64).period_min[0] for k in range(24)])
    np.testing.assert_allclose(pc, pm, rtol=0, atol=1e-12)
    qc = np.r_[coarse.samples[:, 0], coarse.final_state[0]]
    assert np.all(np.array([qc[k * 64:(k + 1) * 64 + 1].min() for k in range(24)]) >= coarse.period_min)
    Q = m.Delta - pm
    assert out["amplitude_max"] == out["amplitude"] == pytest.approx(np.max(Q), rel=1e-15)
    assert out["amplitude_min"] == pytest.approx(np.min(Q), rel=1e-15)
    assert out["amplitude_mean"] == pytest.approx(np.mean(Q), rel=1e-14)
    assert out["amplitude_std"] == pytest.approx(np.std(Q, ddof=1), rel=1e-12)
    assert out["amplitude_min"] < out["amplitude_mean"] < out["amplitude_max"]
    assert out["amplitude_std"] > 0.05 * out["amplitude_mean"]   # a spread, not a number


def test_period2_orbit_spread_is_its_two_amplitudes():
    """The Fig. 13 scene at Omega = 4 is a period-2 orbit with one impact every two periods
    (the k = 2 subharmonic): its per-period amplitudes alternate between the minima of the two
    halves of the orbit, and the largest is the amplitude of the n = 2 Newton fixed point of
    the impact map (independent closed form, 1e-9)."""
    sc, W = FIG13, 4.0
    Delta = one_mode(sc).Delta
    tr = EventSolver(sc).point(W, None, 3000, 16, 64)
    out = summarize(tr, Delta)
    assert out["period"] == 2 and out["impacts_per_period"] == 0.5
    phase = (W * tr.impact_times[0]) % (2 * math.pi)
    x = newton_fixed_point(sc, W, [phase, tr.impact_velocities[0]], 2)
    assert x is not None and is_admissible(sc, W, x, 2)[0]
    q_min, _ = orbit_extremes(sc, W, x, 2)
    assert out["amplitude_max"] == pytest.approx(Delta - q_min, rel=1e-9)
    Q = Delta - tr.period_min
    np.testing.assert_allclose(Q[::2], Q[0], rtol=1e-9)
    np.testing.assert_allclose(Q[1::2], Q[1], rtol=1e-9)
    assert abs(Q[0] - Q[1]) > 1e-3 * out["amplitude"]     # two different halves
    assert out["amplitude_mean"] == pytest.approx((Q[0] + Q[1]) / 2, rel=1e-9)


def test_spread_datasets_have_units_and_mm_versions(tmp_path):
    case = parse_case("""
name = "u"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.8
gap_mm = -0.1
length_mm = 180.0
gain = 3.78e-4
voltage = 0.6
[sweep]
frequency_hz = [15.5, 16.5, 3]
transient_periods = 200
record_periods = 16
[[run]]
name = "exact"
method = "event"
""")
    from vibeam.runner import run_case

    res = run_case(case, "", tmp_path, jobs=1, quiet=True, plots=False)[0]
    d = res.data
    for k in ("amplitude_mean", "amplitude_std", "amplitude_min", "amplitude_max", "amplitude_sem",
              "amplitude_sem_dof", "record_periods", "transient_periods_used"):
        assert k in d and k in UNITS, k
        if k.startswith("amplitude") and k != "amplitude_sem_dof":
            assert k + "_mm" in UNITS
            np.testing.assert_allclose(d[k + "_mm"], d[k] * 180.0, rtol=1e-15)
    # the spread of a non-periodic point is measured over statistics_periods (default 256)
    assert (d["period"] == 0).any()
    np.testing.assert_array_equal(d["record_periods"], np.where(d["period"] == 0, 256, 16))
    assert np.all(d["transient_periods_used"] == 200)
    assert "unsettled" in STATUSES


# ----------------------------------------------------------------------------- unsettled
def test_transient_verdict_on_constructed_strobes():
    """Geometric convergence to a period-2 orbit (ratio 0.8 per period) is not settled; the same
    orbit converged is period 2; stationary noise (a chaotic-like sample) is non-periodic and
    not flagged; a period-1 return at 3 x rtol is marginal."""
    k = np.arange(32)
    orbit = np.where(k % 2 == 0, 1.0, -1.0)
    conv = np.c_[orbit + 0.3 * 0.8 ** k, 0.5 * orbit]
    p, why = transient_verdict(conv, 1.0, 1e-5, no_impact=False)
    assert p == 0 and "shrinking" in why
    assert converging(conv, 2, 1.0, 1e-5)[0]
    done = np.c_[orbit, 0.5 * orbit]
    assert transient_verdict(done, 1.0, 1e-5, no_impact=False) == (2, "")
    rng = np.random.default_rng(3)
    noise = rng.uniform(-1, 1, (32, 2))
    assert transient_verdict(noise, 1.0, 1e-5, no_impact=False) == (0, "")
    marginal = np.c_[1.0 + 2e-5 * rng.uniform(-1, 1, 32), np.zeros(32)]
    p, why = transient_verdict(marginal, 1.0, 1e-5, no_impact=False)
    assert p == 0 and "marginal" in why
    # no impact: the free motion must repeat with period 1
    assert transient_verdict(np.c_[np.ones(8), np.zeros(8)], 1.0, 1e-5, no_impact=True) == (-1, "")
    p, why = transient_verdict(np.c_[1 + 1e-3 * 0.9 ** k, 0 * k], 1.0, 1e-5, no_impact=True)
    assert p == -1 and "free motion" in why


@settings(max_examples=300, deadline=None)
@given(period=st.integers(1, 9), m=st.integers(1, 40), level=st.sampled_from([0.0, 0.3, 0.9, 1.0, 1.1, 5.0, 12.0,
                                                                             1e3]),
       decay=st.sampled_from([1.0, 0.8, 0.97]), margin=st.sampled_from([1.0, SETTLED_MARGIN, 3.0, 2 * MARGINAL]),
       Omega=st.sampled_from([None, 2.0, 20.0]), no_impact=st.booleans(), seed=st.integers(0, 2 ** 16),
       nan=st.booleans())
def test_the_verdicts_early_exit_agrees_with_the_whole_rule(period, m, level, decay, margin, Omega, no_impact,
                                                            seed, nan):
    """transient_verdict stops at the first return that settles the period (the common outcome);
    the verdict must be the one of the whole rule over all eight returns (verdict_from_returns),
    the reason's text included: orbits of period 1-9 with a perturbation of a few rtol around
    the thresholds (1, margin, MARGINAL), decaying or not, short windows, high Omega (returns in
    the oscillator's own time) and NaN samples."""
    rtol = 1e-5
    rng = np.random.default_rng(seed)
    base = rng.uniform(-1, 1, (period, 2))
    k = np.arange(m)
    strobe = base[k % period] + level * rtol * decay ** k[:, None] * rng.uniform(-1, 1, (m, 2))
    if nan and m > 2:
        strobe[rng.integers(m)] = np.nan
    scale = float(rng.uniform(0.5, 2.0))
    got = transient_verdict(strobe, scale, rtol, no_impact, margin, Omega)
    want = verdict_from_returns(strobe_returns(strobe, scale, Omega), strobe, scale, rtol, no_impact, margin, Omega)
    assert got == want


_SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-2 ** 62, 2 ** 62),
                     st.floats(allow_nan=True, allow_infinity=True), st.builds(np.float64, st.floats()),
                     st.builds(np.int64, st.integers(-2 ** 62, 2 ** 62)), st.builds(np.bool_, st.booleans()),
                     st.builds(np.float32, st.floats(width=32)))


@settings(max_examples=200, deadline=None)
@given(columns=st.lists(st.lists(_SCALARS, min_size=3, max_size=3), min_size=1, max_size=6))
def test_stack_gives_scalar_columns_the_dtype_and_values_of_the_general_rule(columns):
    """stack() builds a column of plain scalars at once; it must be the array of the general
    rule: each value as an array (None a NaN), the dtype their np.result_type, same bits."""
    rows = [{f"k{j}": col[i] for j, col in enumerate(columns)} for i in range(3)]
    sw = Sweep(Omega=np.array([1.0, 2.0, 3.0]), record_periods=2)
    got = stack(rows, sw)
    for j, col in enumerate(columns):
        if all(v is None for v in col):
            continue            # (a text column of '')
        arr = [np.asarray(v) if v is not None else np.nan for v in col]
        want = np.array(arr, dtype=np.result_type(*[a.dtype if hasattr(a, "dtype") else type(a) for a in arr]))
        g = got[f"k{j}"]
        assert g.dtype == want.dtype
        assert g.tobytes() == want.tobytes()


@pytest.mark.parametrize("W, n_short, why", [(2.0, 50, "marginal"), (2.5, 50, "shrinking")])
def test_a_transient_cut_short_is_unsettled_and_a_long_one_is_not(W, n_short, why):
    """Fig. 7 scene (Delta = 0) from rest: 50 transient periods leave 1e-4-1e-5 of the transient
    on the strobe (a marginal period-1 test at 2.0; returns shrinking over the window at 2.5):
    status ``unsettled``; after 3000 the point is period-1, ``ok``, on the Newton fixed point
    of the impact map (1e-9)."""
    sc = sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=0.0)
    short = _one(sc, W, transient_periods=n_short, record_periods=16)
    assert short["status"] == "unsettled" and why in short["message"]
    long = _one(sc, W, transient_periods=3000, record_periods=16)
    assert long["status"] == "ok" and long["period"] == 1
    assert long["amplitude"] == pytest.approx(_period1_amplitude(sc, W, long), rel=1e-9)


# ----------------------------------------------------------------------------- auto
@pytest.mark.parametrize("model, W, kind", [(FIG8, 2.1, "no impact"), (FIG13, 2.25, "period-1")],
                         ids=["fig8-2.1", "fig13-2.25"])
def test_auto_transient_reaches_the_converged_orbit(model, W, kind):
    """The two points an independent check found unconverged after 400 periods from rest.
    With 400 transient periods both are a chaotic transient, recorded as non-periodic (a wrong
    answer: Fig. 8 at 2.1 stays chaotic for ~2800 periods, then settles on the no-impact orbit;
    Fig. 13 at 2.25 settles on period-1 after ~500-800).  ``transient_periods = "auto"`` reaches
    the attractor, checked against closed forms: the linear steady state Delta + C(Omega) and
    the Newton fixed point of the impact map (1e-8; auto stops once the strobe repeats to
    1e-3 period_rtol = 1e-8 of the orbit; the remaining distance to the orbit is that over
    1 - rho for the Floquet multiplier rho).

    How long a chaotic transient lasts is a property of one trajectory, which round-off decides:
    from 12 starts 1e-10 apart the Fig. 8 transient lasted 500-14000 periods (mean ~5000, the same
    for the event kernel of vibeam 0.1 and the modal event integrator), and from rest 2800 with the
    former, 9600 with the latter (and under 400 once the impulse was applied in two parts).  So the
    test starts from the first of the states ``q = k 1e-6`` (k = 0, 1, ...; rest first) whose
    transient outlasts 400 periods, and auto may use up to ``max_transient_periods = 30000`` (an
    exponential lifetime of mean 5000 outlasts it with probability e^-6)."""
    for k in range(20):
        start = np.array([k * 1e-6, 0.0, 0.0])
        fixed = _one(model, W, start=start, transient_periods=400, record_periods=64)
        if fixed["period"] == 0:
            break
    assert fixed["period"] == 0          # the wrong answer of a fixed, too short transient
    auto = _one(model, W, start=start, transient_periods="auto", record_periods=64, max_transient_periods=30000)
    assert auto["status"] == "ok"
    assert 400 < auto["transient_periods_used"] <= 30000
    if kind == "no impact":
        assert auto["period"] == -1
        m = one_mode(model)
        expected = m.Delta + float(linear_amplitude(m.beta, m.B, W))
    else:
        assert auto["period"] == 1
        expected = _period1_amplitude(model, W, auto)
    assert auto["amplitude"] == pytest.approx(expected, rel=1e-8)
    assert auto["amplitude_std"] < 1e-8 * auto["amplitude"]


def test_auto_on_a_chaotic_attractor_runs_at_least_half_the_maximum():
    """Fig. 13, Omega = 2.5 is non-periodic: auto cannot tell transient chaos from an attractor
    in less than max_transient_periods / 2, then accepts it once the spread agrees between two
    probes, or marks it unsettled at the maximum."""
    out = _one(FIG13, 2.5, transient_periods="auto", max_transient_periods=2000, record_periods=32)
    assert out["period"] == 0 and out["status"] in ("ok", "unsettled")
    assert 1000 <= out["transient_periods_used"] <= 2000
    assert out["amplitude_min"] < out["amplitude_mean"] < out["amplitude_max"]


def test_spread_agreement_is_a_statistical_bound():
    """Samples without a batch-means error (i.i.d., 63 degrees of freedom each): the bound is
    Student's t at the 4-sigma false-alarm probability, t_crit(126) = 4.17 standard errors of the
    difference (tests/test_statistics.py checks the batch-means case)."""
    a = dict(amplitude_mean=1.0, amplitude_std=0.2, record_periods=64)
    assert spread_agrees(a, dict(a, amplitude_mean=1.0 + 3.9 * 0.2 * math.sqrt(2 / 64)))
    assert not spread_agrees(a, dict(a, amplitude_mean=1.0 + 4.3 * 0.2 * math.sqrt(2 / 64)))
    s = amplitude_spread([1.0, 2.0, 3.0])
    assert (s["amplitude_mean"], s["amplitude_std"], s["record_periods"]) == (2.0, 1.0, 3)


# ----------------------------------------------------------------------------- chunks
@pytest.mark.parametrize("fidelity", ["sdof", "beam-2-modes"])
def test_chunked_calls_equal_one_call_on_a_periodic_point(fidelity):
    """A point cut into chunks of 37 periods (each call starts from the last state) ends on the
    same period-1 orbit as one call of 1500 periods: strobe and amplitude to 1e-12 (round-off
    of restarting the closed-form flow; the orbit is attracting, so it does not grow)."""
    if fidelity == "sdof":
        solver = make_solver(sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=0.0), "event")
        W = 2.0
    else:
        from vibeam.models.builders.beam import mass_stops
        from vibeam.models.builders.matrices import modal_scene
        from vibeam.models.contact import Restitution

        om = np.array([2 * math.pi * 7.6, 2 * math.pi * 98.75])
        m = modal_scene(om, 0.0 + 2 * 0.017 / (2 * math.pi * 7.6) * om ** 2, [0.4, 0.1], [1.0, 0.3],
                        np.atleast_2d([1.5, -0.6]), mass_stops(0.0, Restitution(0.72)), 3e-4, 7.6, 0.18, 1.0, "beam")
        solver = make_solver(m, "event")
        W = 15.0 / 7.6
    sw = Sweep(Omega=np.array([W]), transient_periods=1500, record_periods=8)
    one = _simulate(solver, W, None, 1500, sw)
    solver.chunk_periods = 37
    calls = []
    inner = solver.point

    def counting(*a):
        calls.append(a[2])
        return inner(*a)

    solver.point = counting
    chunked = _simulate(solver, W, None, 1500, sw)
    assert max(calls) <= 37 and sum(calls) == 1500 and len(calls) == math.ceil(1500 / 37)
    a, b = summarize(one, 0.0), summarize(chunked, 0.0)
    assert a["period"] == b["period"] == 1
    scale = np.max(np.abs(one.strobe))
    assert np.max(np.abs(one.strobe - chunked.strobe)) <= 1e-12 * scale
    assert abs(one.q_min - chunked.q_min) <= 1e-12 * abs(one.q_min)


def test_point_time_limit_ends_a_point_as_failed_and_the_sweep_goes_on(monkeypatch):
    """A point of 10^7 transient periods (~25 s) with a 0.2 s limit fails with the reason, and
    the sweep returns its row instead of raising.  Deterministic: the engine's clock
    (``vibeam.engine.sweep.time.perf_counter``) is replaced by one that advances 1/16 s per solver call
    (binary-exact, so no rounding decides a comparison), and the calls are counted.  The limit
    is checked between calls and the clock starts when the first call returns (so a kernel's
    compilation does not count): after call k the point has run (k - 1) / 16 s, first over 0.2 s
    at k = 5 -- five calls of 2000 periods of the 5000 the point would need."""
    import types

    import vibeam.engine.sweep as sweep_module

    solver = make_solver(FIG13, "event")
    assert solver.chunk_periods == 2000
    now = [0.0]
    calls = []
    inner = solver.point

    def counting(*a):
        calls.append(a[2])
        now[0] += 1 / 16
        return inner(*a)

    solver.point = counting
    fake = types.SimpleNamespace(**{k: getattr(time, k) for k in dir(time) if not k.startswith("_")})
    fake.perf_counter = lambda: now[0]
    monkeypatch.setattr(sweep_module, "time", fake)
    sw = Sweep(Omega=np.array([2.0]), transient_periods=10**7, record_periods=4, point_time_limit_s=0.2)
    out = run_sweep(solver, sw).data
    assert calls == [2000] * 5, calls
    assert out["status"][0] == "failed" and "point_time_limit_s = 0.2" in out["message"][0]
    assert f"after {sum(calls)} of {10**7} transient periods" in out["message"][0], out["message"][0]
    assert np.isnan(out["amplitude"][0]) and out["strobe"].shape == (1, 4, 2)


def _readline(proc, timeout=120.0) -> str:
    """One line of the child's stdout; the timeout is a hang guard, never the property tested."""
    import select

    r, _, _ = select.select([proc.stdout], [], [], timeout)
    if not r:
        proc.kill()
        raise AssertionError(f"hang guard: no line from the child within {timeout:g} s")
    return proc.stdout.readline().decode()     # unbuffered (bufsize=0): reads no further than the line


def test_ctrl_c_interrupts_a_long_inline_point_between_chunks(tmp_path):
    """SIGINT during a single point of 10^7 periods (~25 s; one kernel call, which numba does not
    interrupt, would take all of it) stops the process between chunks: the child marks every
    solver call (chunks of 2000 SDOF periods, ~5 ms) and its SIGINT handler (Python's default,
    wrapped to mark when it runs); the signal is sent once the long point is inside its chunks,
    and after the handler ran no call begins -- KeyboardInterrupt lands at the kernel's next
    return and ends the point (5000 calls would finish it)."""
    script = tmp_path / "long.py"
    script.write_text(textwrap.dedent("""
        import os, signal, sys, numpy as np
        from vibeam.models import make_solver
        from vibeam.models.builders.sdof import sdof
        from vibeam.engine.sweep import Sweep, run_sweep
        # every period integrated: with the exact recurrence a settled chunk ends within a few
        # periods, and the 5000 calls could all be over before the signal arrives
        s = make_solver(sdof(0.015, 0.5e-3, 0.5e-3, 0.9), "event", recurrence=False)
        run_sweep(s, Sweep(Omega=np.array([2.0]), transient_periods=2, record_periods=2))  # compile
        inner = s.point
        def point(*a):
            os.write(1, f"call {a[2]} {a[3]}\\n".encode())
            return inner(*a)
        s.point = point
        def on_int(signum, frame):
            os.write(1, b"handler\\n")
            signal.default_int_handler(signum, frame)
        signal.signal(signal.SIGINT, on_int)
        print("ready", flush=True)
        try:
            run_sweep(s, Sweep(Omega=np.array([2.0]), transient_periods=10**7, record_periods=2))
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(7)
        print("finished", flush=True)
    """))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, bufsize=0)
    assert _readline(proc).strip() == "ready"
    assert _readline(proc).split() == ["call", "2000", "0"]      # inside the long point's chunks
    proc.send_signal(signal.SIGINT)
    try:
        out, _ = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise AssertionError("hang guard: the process did not stop within 120 s of SIGINT") from None
    out = out.decode()
    assert proc.returncode == 7 and "interrupted" in out, out
    rows = out.splitlines()
    assert rows.count("handler") == 1 and "finished" not in rows, rows[-5:]
    after = [r for r in rows[rows.index("handler"):] if r.startswith("call")]
    n_before = 1 + sum(r.startswith("call") for r in rows[:rows.index("handler")])
    print(f"SIGINT after {n_before} of 5000 calls; calls begun after the handler ran: {len(after)}")
    assert not after, f"calls after the interrupt: {after}"
    assert n_before < 5000


# ----------------------------------------------------------------------------- case keys
CASE = """
name = "c"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
[sweep]
Omega = [1.9, 2.1, 3]
{extra}
[[run]]
name = "exact"
method = "event"
"""


def test_case_keys_of_the_auto_transient_and_the_time_limit():
    c = parse_case(CASE.format(extra='transient_periods = "auto"\nmax_transient_periods = 5000\n'
                                     'point_time_limit_s = 30.0'))
    assert c.sweep.transient_periods == "auto" and c.sweep.max_transient_periods == 5000
    assert c.sweep.point_time_limit_s == 30.0
    assert c.sweep.engine_options()["transient_periods"] == "auto"
    for bad, key in (('transient_periods = "automatic"', "transient_periods"),
                     ("max_transient_periods = 0", "max_transient_periods"),
                     ("point_time_limit_s = -1.0", "point_time_limit_s")):
        with pytest.raises(CaseError, match=key) as e:
            parse_case(CASE.format(extra=bad))
        assert "\n" not in str(e.value)
