"""Numerics under hostile input (issue 19, items 6, 8, 9, 10): no kernel call that cannot be
stopped, no number reported as ``ok`` that a method could not compute.

* Item 6: scales that double precision cannot carry (a subnormal ``B``, a stop stiffness of
  1e300) are refused at validation in one line; a model built past validation still returns
  (every kernel call has a work budget, ``max_steps_per_call``; a contact scan that cannot
  advance fails the point); the sweep engine repeats a call that ran out of its budget in
  shorter calls and checks the wall-time limit between them, also in a compliant kernel; long
  records and statistics windows are cut into calls of bounded length; the work estimate
  counts the contact stiffness.
* Item 8: at Omega = 5e5 and 1e6 (Fig. 7 scene, 200 transient periods) the free vibration
  from rest has not decayed: the points are ``unsettled``, judged in the oscillator's own time.
* Item 9: the undamped elastic scene (``beta = 0``, ``R = 1``) at its impacting resonance
  Omega = 2 has no bounded orbit: ``mapping`` and ``averaging`` fail with the reason; undamped
  exact resonance (``beta = 0``, Omega = 1) is refused in one line (closed-form methods) or
  failed with the reason (a model built directly); a method that returns a non-finite number
  is failed by the sweep engine.
* Item 10: at Delta = 0 the problem is homogeneous in B: ``amplitude / B`` is the same over the
  whole allowed range 1e-100 ... 1e100, and B outside it is refused.

Every test here failed on the base branch (the commit before this file): by a missing
refusal, an ``ok`` status, a call that never returned (guarded by a subprocess timeout), or a
missing budget setting; the homogeneity test inside the range passes there too (a guard).
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pytest

import vibeam
from vibeam.case.schema import CaseError
from vibeam.models import EventSolver, make_solver
from vibeam.models.builders.sdof import sdof
from vibeam.models.core.oscillator import linear_amplitude
from vibeam.engine.records import summarize
from vibeam.engine.sweep import Sweep, run_sweep

FIG7 = dict(beta=0.015, B=0.5e-3, R=0.9, Delta=0.0)


def _case(B=0.5e-3, beta=0.015, R=0.9, Delta=0.0, Omega="[1.9, 2.1, 2]", method="event", model_extra="",
          sweep_extra="", transient=100, record=16):
    return f"""
name = "t"
[model]
fidelity = "sdof"
beta = {beta!r}
B = {B!r}
R = {R!r}
Delta = {Delta!r}
{model_extra}
[sweep]
Omega = {Omega}
transient_periods = {transient}
record_periods = {record}
{sweep_extra}
[[run]]
name = "x"
method = "{method}"
"""


def _cli(tmp_path, text):
    """``vibeam run`` of a case file in a subprocess: (exit code, stderr lines)."""
    f = tmp_path / "c.toml"
    f.write_text(text)
    p = subprocess.run([sys.executable, "-m", "vibeam.cli", "run", str(f), "--out", str(tmp_path / "out"),
                        "--jobs", "1", "--quiet"], capture_output=True, text=True, timeout=300)
    return p.returncode, [l for l in p.stderr.splitlines() if l.strip() and not l.startswith("[t]")]


def _child(code: str, timeout: float = 120.0) -> dict:
    """Run ``code`` in a fresh interpreter; it prints one JSON line.  The timeout only guards
    against a hang (the base branch never returned from these calls)."""
    p = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                       timeout=timeout)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.strip().splitlines()[-1])


# ============================================================================ item 6 / 10: refusals
@pytest.mark.parametrize("B", [5e-320, 1e-310, 1e-120, 1e200, 1e300])
def test_a_scale_double_precision_cannot_carry_is_refused_in_one_line(B):
    """B subnormal (5e-320, 1e-310), below 1e-100 or above 1e100: one CaseError naming
    'model.B', the value and the allowed range (issue 19: 5e-320 never returned, 1e-310 took
    ~5 s a point and changed the period, 1e200 drifted amplitude / B by 3e-6)."""
    with pytest.raises(CaseError) as e:
        vibeam.load_case(_case(B=B))
    msg = str(e.value)
    assert "\n" not in msg and "'model.B'" in msg and "1e-100 <= |B| <= 1e+100" in msg, msg


def test_the_range_applies_to_gain_times_voltage_of_a_physical_scene():
    """B = gain x voltage (paper Eq. 43): a product outside the range is refused naming both keys;
    the range's ends and 0 are accepted."""
    base = _case().replace("beta = 0.015\nB = 0.0005\nR = 0.9\nDelta = 0.0",
                           "natural_frequency_hz = 7.6\ndamping_ratio = 0.015\nR = 0.9\ngap_mm = 0.0\n"
                           "length_mm = 180.0\ngain = GAIN\nvoltage = 0.5")
    base = base.replace("Omega = [1.9, 2.1, 2]", "frequency_hz = [14.0, 15.0, 2]")
    with pytest.raises(CaseError, match=r"'model.gain' x 'model.voltage'"):
        vibeam.load_case(base.replace("GAIN", "1e-305"))
    for ok in ("2e-100", "0.0", "2e100"):
        vibeam.load_case(base.replace("GAIN", ok))


def test_cli_refuses_a_subnormal_B_with_exit_2_and_one_line(tmp_path):
    """Through the command line (issue 19: ``vibeam run`` with B = 5e-320 never returned)."""
    code, lines = _cli(tmp_path, _case(B=5e-320))
    assert code == 2 and len(lines) == 1 and lines[0].startswith("vibeam: error: "), lines
    assert "'model.B'" in lines[0] and "1e-100" in lines[0]
    assert not (tmp_path / "out" / "results.h5").exists()


def test_a_stop_too_stiff_for_double_precision_is_refused_naming_the_key():
    """[model.contact] law = "linear", stiffness = 1e300 hung every kernel (its contact scan's
    bounds ~k_c^3.5 overflow and no step can be certified): refused in one line with the
    allowed maximum; the same stiffness given in N/m for a physical scene names stiffness_n_m."""
    contact = '[model.contact]\nlaw = "linear"\nstiffness = 1e300'
    with pytest.raises(CaseError) as e:
        vibeam.load_case(_case(model_extra=contact))
    assert "'model.contact.stiffness' = 1e+300" in str(e.value) and "at most 1e+20" in str(e.value)
    vibeam.load_case(_case(model_extra=contact.replace("1e300", "1e20")))


# ============================================================================ item 6: bounded calls
def test_a_call_over_its_work_budget_is_repeated_in_shorter_calls_with_the_same_result():
    """An event solver whose call budget (3000 steps) is far below what 416 periods need
    (~40 steps a period on Fig. 7 at Omega = 2): the sweep engine cuts the point into calls
    that fit, each repeated from the same state; the point equals that of one call (default
    budget) to 1e-12 (round-off of restarting the closed-form flow on an attracting
    period-1 orbit, as tests/test_settle.py's chunk test)."""
    W = 2.0
    sw = Sweep(Omega=np.array([W]), transient_periods=400, record_periods=16)
    one = run_sweep(make_solver(sdof(**FIG7), "event"), sw).data
    solver = make_solver(sdof(**FIG7), "event", max_steps_per_call=3000)
    calls = []
    inner = solver.point

    def counting(Omega, state, n_tr, n_rec, spp):
        tr = inner(Omega, state, n_tr, n_rec, spp)
        calls.append((n_tr + n_rec, tr.incomplete))
        return tr

    solver.point = counting
    split = run_sweep(solver, sw).data
    assert one["period"][0] == split["period"][0] == 1 and list(split["status"]) == ["ok"]
    assert split["impacts_per_period"][0] == 1
    done = [n for n, inc in calls if not inc]
    assert sum(done) == 416 and max(done) < 416 and any(inc for _, inc in calls)
    assert np.max(np.abs(one["strobe"] - split["strobe"])) <= 1e-12 * np.max(np.abs(one["strobe"]))
    assert abs(one["amplitude"][0] - split["amplitude"][0]) <= 1e-12 * one["amplitude"][0]


def test_a_subnormal_model_built_past_validation_returns_failed_within_its_budget():
    """A model with B = 5e-320 (the base branch never returned; vibeam's first event kernel
    could certify no step and ended the point as failed once one period needed more than the
    call's budget, here 20000 steps): :func:`vibeam.simulate` ends the point as failed, now at
    once with the reason, a motion at the scale of subnormal numbers (fewer than 53 significant
    bits), not with a number of a few bits."""
    sim = vibeam.simulate(sdof(beta=0.015, B=5e-320, R=0.9, Delta=0.0), Omega=2.0, periods=2,
                          max_steps_per_call=20000)
    assert sim.status == "failed" and "subnormal" in sim.message, sim.message
    assert np.all(np.isnan(sim.q))


@pytest.mark.slow
def test_a_subnormal_model_with_the_default_budget_returns():
    """As above with the default budget, in a child process (a hang guard of 300 s)."""
    out = _child("""
        import json, vibeam
        from vibeam.models.builders.sdof import sdof
        sim = vibeam.simulate(sdof(beta=0.015, B=5e-320, R=0.9, Delta=0.0), Omega=2.0, periods=1)
        print(json.dumps({"status": sim.status, "message": sim.message}))
    """, timeout=300)
    assert out["status"] == "failed" and "subnormal" in out["message"]


def test_a_stop_of_stiffness_1e300_built_past_validation_fails_at_once():
    """The compliant kernel with k_c = 1e300 (its scan's bounds overflow): the base branch
    never returned from one period; now the scan reports that it cannot advance and the point
    fails with the reason.  In a child process: the timeout only guards against the hang."""
    out = _child("""
        import json
        from vibeam.models.builders.sdof import sdof
        from vibeam.models.compliant import LinearContact
        from vibeam.models import EventSolver
        sc = sdof(beta=0.015, B=0.5e-3, Delta=0.0, law=LinearContact.from_restitution(1e300, 0.9))
        tr = EventSolver(sc).point(2.0, None, 0, 1, 64)
        print(json.dumps({"status": tr.status, "message": tr.message}))
    """)
    assert out["status"] == "failed" and "double precision" in out["message"], out


def test_point_time_limit_is_honoured_inside_a_compliant_point():
    """A pre-stressed stiff compliant stop (k_c = 1e8, Delta = -0.1: pressed on with a force 0.1,
    50 times the forcing Omega^2 B = 2e-3, the mass never leaves it; contact_fraction 1 was
    measured), and each period steps the contact at 1/16 of its period, 16 sqrt(1 + k_c) /
    Omega = 8e4 steps (~0.2 s).  With a call budget of 1e5 steps and point_time_limit_s = 0.5 the
    point ends as failed by the limit after a few calls, each of them cut to fit the budget
    (the base branch ran its 416 periods in one uninterruptible call of ~100 s: the child's
    timeout guards against that)."""
    out = _child("""
        import json
        import numpy as np
        from vibeam.models.builders.sdof import sdof
        from vibeam.models.compliant import LinearContact
        from vibeam.models import make_solver
        from vibeam.engine.sweep import Sweep, run_sweep
        sc = sdof(beta=0.015, B=0.5e-3, Delta=-0.1, law=LinearContact.from_restitution(1e8, 0.9))
        s = make_solver(sc, "event")
        s.point(2.0, None, 0, 1, 16)                 # compile or load the kernel first
        s.max_steps_per_call = 100_000
        calls = []
        inner = s.point
        def counting(*a):
            tr = inner(*a)
            calls.append([a[2] + a[3], bool(getattr(tr, "incomplete", False)), tr.status])
            return tr
        s.point = counting
        sw = Sweep(Omega=np.array([2.0]), transient_periods=400, record_periods=16, point_time_limit_s=0.5)
        d = run_sweep(s, sw).data
        print(json.dumps({"status": str(d["status"][0]), "message": str(d["message"][0]), "calls": calls}))
    """)
    assert out["status"] == "failed" and "point_time_limit_s = 0.5" in out["message"], out
    calls = out["calls"]
    assert calls[0][0] == 416 and calls[0][1], calls          # the first call ran out of its budget
    assert 2 <= len(calls) <= 40, calls
    assert sum(n for n, inc, st in calls if not inc) < 416     # the point ended early


def test_long_records_and_statistics_windows_are_cut_into_bounded_calls():
    """Every call of a point has at most chunk_periods + max(chunk_periods, 256) periods: a
    record of 600 periods (chunks of 37) is cut and joined
    (:func:`vibeam.models.trajectory.concatenate`), its strobe, amplitude and per-period spread
    equal to those of one call to 1e-12 (Fig. 7, Omega = 2, period 1); the statistics window of
    a non-periodic point (Fig. 13, Omega = 2.5, statistics_periods = 700) is cut too.  (The base
    branch made the record and the window one call each.)"""
    def counted(solver):
        calls = []
        inner = solver.point

        def counting(Omega, state, n_tr, n_rec, spp):
            calls.append((n_tr, n_rec))
            return inner(Omega, state, n_tr, n_rec, spp)

        solver.point = counting
        return calls

    one = summarize(EventSolver(sdof(**FIG7)).point(2.0, None, 100, 600, 32), 0.0)
    solver = make_solver(sdof(**FIG7), "event")
    solver.chunk_periods = 37
    calls = counted(solver)
    d = run_sweep(solver, Sweep(Omega=np.array([2.0]), transient_periods=100, record_periods=600,
                                samples_per_period=32)).data
    assert max(a + b for a, b in calls) <= 37 + 256 and sum(b for _, b in calls) == 600
    assert d["period"][0] == one["period"] == 1 and d["impacts_per_period"][0] == one["impacts_per_period"] == 1
    assert np.max(np.abs(d["strobe"][0] - one["strobe"])) <= 1e-12 * np.max(np.abs(one["strobe"]))
    for k in ("amplitude", "amplitude_mean", "amplitude_max", "impact_velocity"):
        assert abs(d[k][0] - one[k]) <= 1e-12 * abs(one[k]), k

    fig13 = make_solver(sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=0.5e-3), "event")
    fig13.chunk_periods = 37
    calls = counted(fig13)
    sw = Sweep(Omega=np.array([2.5]), transient_periods=400, record_periods=32, statistics_periods=700)
    d = run_sweep(fig13, sw).data
    assert d["period"][0] == 0 and d["record_periods"][0] == 700, d["message"]
    window = [b for a, b in calls if a == 0]                  # the statistics window's calls
    assert max(a + b for a, b in calls) <= 37 + 256 and sum(window) == 700 - 32 and len(window) >= 3


def test_the_work_estimate_counts_the_contact_stiffness():
    """A stop at the rest position (Delta = 0) holds the mass about half of each period, stepped
    at 1/16 of the contact's period 2 pi / sqrt(1 + k_c): the estimate grows as sqrt(k_c) once
    that dominates (x10 from k_c = 1e10 to 1e12, within 1 %), and 1e12 is refused naming the
    key (the base branch's estimate did not depend on k_c; its points failed one by one)."""
    from vibeam.case.schema import InputError
    from vibeam.runner import check_work, estimate_work

    def case(k):
        return vibeam.load_case(_case(Omega="[1.5, 2.5, 101]", transient=400, record=64,
                                      model_extra=f'[model.contact]\nlaw = "linear"\nstiffness = {k!r}'))

    w10, w12 = estimate_work(case(1e10))["steps"], estimate_work(case(1e12))["steps"]
    assert 9.9 <= w12 / w10 <= 10.1, w12 / w10
    with pytest.raises(InputError, match=r"'model.contact.stiffness' = 1000000000000.0"):
        check_work(case(1e12))
    check_work(case(1e4))


# ============================================================================ item 8: high Omega
def test_an_undecayed_free_vibration_at_very_high_omega_is_unsettled():
    """Fig. 7 scene, Omega = 5e5 and 1e6, 200 transient periods (1e-3 to 2.5e-3 natural time
    units: exp(-beta t) = 0.99996, nothing has decayed): the motion is the free vibration of
    size ~B Omega excited by starting from rest, and the point is unsettled (the base branch
    reported ok, no impact, amplitude 100-2000 B).  With transient_periods = "auto" (up to
    10000 periods, 0.06 time units at 1e6) it stays unsettled."""
    for tr in (200, "auto"):
        res = run_sweep(make_solver(sdof(**FIG7), "event"),
                        Sweep(Omega=np.array([5e5, 1e6]), transient_periods=tr, record_periods=64))
        d = res.data
        assert list(d["status"]) == ["unsettled", "unsettled"], (tr, d["status"], d["message"])
        assert all("own time" in m for m in d["message"]), d["message"]


def test_a_settled_no_impact_orbit_at_omega_10_stays_ok():
    """Control for the natural-time verdict: the linear orbit below a far stop (Delta = 1) at
    Omega = 10 after 3000 periods (1885 time units, exp(-beta t) = 5e-13) is ok, no impact, and
    its amplitude is the linear steady state's (paper Eq. 28) to 1e-9."""
    d = run_sweep(make_solver(sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=1.0), "event"),
                  Sweep(Omega=np.array([10.0]), transient_periods=3000, record_periods=16)).data
    assert d["status"][0] == "ok" and d["period"][0] == -1, d["message"]
    C = float(linear_amplitude(0.015, 0.5e-3, 10.0))
    assert abs(-d["q_min"][0] - C) <= 1e-9 * C


# ============================================================================ item 9: degenerate scenes
def test_mapping_of_the_undamped_elastic_resonance_fails_with_the_reason():
    """beta = 0, R = 1 at Omega = 2: no dissipation at the impacting resonance, no bounded
    orbit; the base branch's Newton drifted to an orbit of amplitude 2e22 and reported it ok."""
    case = vibeam.load_case(_case(beta=0.0, R=1.0, Omega="[2.0, 2.0, 1]", method="mapping", transient=50))
    d = vibeam.run(case, jobs=1).to_xarray("x")
    st, msg = str(d["status"].values.ravel()[0]), str(d["message"].values.ravel()[0])
    assert st == "failed" and "no bounded orbit" in msg, (st, msg)


def test_averaging_of_the_undamped_elastic_resonance_fails_with_the_reason():
    """The averaged polynomial degenerates (g2 = pi^2 (sigma^2 + beta_k^2) = 0): the base
    branch reported amplitude NaN with status ok; a NaN from no real root (a scene far from
    resonance) stays ok with period -1."""
    sc = sdof(beta=0.0, B=0.5e-3, R=1.0, Delta=0.0)
    out = make_solver(sc, "averaging").point(2.0, None, 0, 1)
    assert out["status"] == "failed" and "g2 = 0" in out["message"], out
    far = make_solver(sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=0.1), "averaging").point(2.0, None, 0, 1)
    assert far["status"] == "ok" and far["period"] == -1 and math.isnan(far["amplitude"])


def test_undamped_exact_resonance_is_refused_in_one_line(tmp_path):
    """beta = 0 with Omega = 1 in the grid: the closed-form methods divide by zero there (the
    base branch failed every point with ZeroDivisionError, exit 3); refused naming the key,
    through the API and the command line (exit 2).  method = "direct" integrates the flow and
    is accepted."""
    text = _case(beta=0.0, Omega="[0.5, 1.5, 3]")
    with pytest.raises(CaseError, match=r"'model.beta'.*Omega = 1"):
        vibeam.load_case(text)
    code, lines = _cli(tmp_path, text)
    assert code == 2 and len(lines) == 1 and "'model.beta'" in lines[0], lines
    vibeam.load_case(_case(beta=0.0, Omega="[0.5, 1.5, 3]", method="direct"))
    vibeam.load_case(_case(beta=0.0, Omega="[0.5, 1.5, 4]"))           # Omega = 1 not on the grid


def test_a_model_at_undamped_exact_resonance_fails_with_the_reason():
    """Built past validation, the event and mapping methods fail the point with the reason
    instead of raising ZeroDivisionError (the base branch)."""
    sc = sdof(beta=0.0, B=0.5e-3, R=0.9, Delta=0.0)
    tr = EventSolver(sc).point(1.0, None, 10, 4, 16)
    assert tr.status == "failed" and "undamped exact resonance" in tr.message, tr.message
    out = make_solver(sc, "mapping").point(1.0, None, 0, 1)
    assert out["status"] == "failed" and "undamped exact resonance" in out["message"]


class _Infinite:
    """A non-time-domain solver that reports an infinite amplitude as ok (a faulty method)."""

    name = "fake"
    time_domain = False

    def __init__(self):
        self.scene = sdof(**FIG7)

    def settings(self):
        return {}

    def point(self, Omega, state, n_tr, n_rec, spp=64):
        return dict(amplitude=np.inf if Omega > 2.0 else 1.0, q_min=-1.0, q_max=0.0, period=1, status="ok",
                    message="")


def test_the_sweep_engine_never_reports_a_non_finite_number_as_ok():
    """Whatever a method returns, an infinite amplitude (or a NaN one claiming an orbit) is
    reported as failed with the reason; finite points are untouched."""
    d = run_sweep(_Infinite(), Sweep(Omega=np.array([1.5, 2.5]), transient_periods=0, record_periods=1)).data
    assert list(d["status"]) == ["ok", "failed"] and "no finite result" in d["message"][1], d["message"]


# ============================================================================ item 10: homogeneity
def test_amplitude_over_B_does_not_depend_on_B_across_the_allowed_range():
    """At Delta = 0 the problem is exactly homogeneous in B (q / B obeys one equation), so
    amplitude / B, the period and the impact count are the same at B = 1e-100, 5e-4 and 1e100,
    and energy_per_impact / B^2 too; measured agreement 1e-15 (amplitude) and 2.5e-15
    (energy), tolerance 1e-12 (round-off of the scaled arithmetic).  No overflow warning (the
    base branch warned from B = 1e200 in the energy per impact)."""
    ref = None
    for B in (1e-100, 5e-4, 1e100):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            case = vibeam.load_case(_case(B=B, Omega="[1.7, 2.3, 2]", transient=400))
            d = vibeam.run(case, jobs=1).to_xarray("x")
        got = (d["amplitude"].values.ravel() / B, d["energy_per_impact"].values.ravel() / B ** 2)
        assert list(d["status"].values.ravel()) == ["ok", "ok"] and list(d["period"].values.ravel()) == [1, 1]
        if ref is None:
            ref = got
        for g, r in zip(got, ref):
            np.testing.assert_allclose(g, r, rtol=1e-12)
