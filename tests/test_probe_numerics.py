"""Issue 41, "Also from the probe": values the schema accepted and the kernels could not take,
outcomes reported ``ok`` with numbers no method computed, and Ctrl-C inside a compiled call.

Oracles: the limits' own reasons (double precision: 1e300 squared overflows; a forcing period
of 1/Omega natural periods; the record size of ``MAX_POINT_VALUES``); the free linear
oscillator (a start of 1e300 cannot stay finite through the exact flow's products); the
definition of a settled record (its stroboscopic map repeats) for what may be called periodic;
Python's exception chaining for an interrupt wrapped by a C call.  Each test was run against the
tree before its fix (71765ee) and failed there.
"""
from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import vibeam
from vibeam.errors import CaseError
from vibeam.models.builders.sdof import sdof
from vibeam.models.scene import one_mode
from test_probe_ux import _exit, _one_error_line   # the command's exit code, its one error line

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "cases"
QUIET = ["--jobs", "1", "--quiet", "--no-plots"]

SCENE = """name = "probe"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.8
Delta = 0.7e-3
{contact}
[sweep]
Omega = [2.0, 2.0, 1]
transient_periods = 50
record_periods = 8
[[run]]
name = "e"
method = "event"
"""
HERTZ = '[model.contact]\nlaw = "hunt_crossley"\nstiffness = 100.0\nexponent = {p}\n'


# ----------------------------------------------------------------------------- unstoppable runs
@pytest.mark.parametrize("p", [0.3, 0.5, 0.99, 3.5])
def test_a_hertz_exponent_outside_the_literature_is_refused(p, tmp_path, capsys):
    """exponent 0.3 ran without end (the contact stiffness is unbounded at onset, 0.5 took 18 s a
    point): refused in one line naming the key, the value and the range [1, 3]."""
    f = tmp_path / "c.toml"
    f.write_text(SCENE.format(contact=HERTZ.format(p=p)))
    assert _exit(["run", str(f), "--out", str(tmp_path / "o"), *QUIET]) == 2
    line = _one_error_line(capsys)
    assert "model.contact.exponent" in line and repr(p) in line and "1 <= p <= 3" in line, line
    assert not (tmp_path / "o" / "results.h5").exists()


@pytest.mark.parametrize("p", [1, 1.0, 1.5, 3.0])
def test_the_hertz_exponents_of_the_literature_are_accepted(p):
    case = vibeam.load_case(tomllib.loads(SCENE.format(contact=HERTZ.format(p=p))))
    assert case.model_spec().stop[0].exponent == p


def test_a_model_too_large_is_refused_before_it_is_built(tmp_path, capsys, monkeypatch):
    """n_modes = "all" of 2000 elements (4000 modes) was refused by the record-size limit only
    after its modal basis and tables were built (569 s, 2.4 GB): now before any model is built
    (the builder is replaced by one that fails the test)."""
    from vibeam.engine import jobs

    text = (CASES / "rig-fe-loose.toml").read_text()
    text = text.replace("n_elements = 24", "n_elements = 2000").replace("n_modes = 4", 'n_modes = "all"', 1)
    f = tmp_path / "big.toml"
    f.write_text(text)

    def no_build(*a, **k):
        raise AssertionError("a model was built")

    monkeypatch.setattr(jobs, "make_job", no_build)
    assert _exit(["run", str(f), "--out", str(tmp_path / "o"), *QUIET]) == 2
    line = _one_error_line(capsys)
    assert "n_modes" in line and "4000 modes" in line and "before the model is built" in line, line


# ----------------------------------------------------------------------------- silent nonsense
def test_a_state_that_overflows_is_refused_or_a_failed_point_not_ok():
    """simulate(state=[-1e300, 1e300]) returned ``ok`` with an amplitude of 9e299 and infinite
    spreads and energies (the squares of 1e300 overflow): the API refuses such a state in one
    line, and the engine's summary of such a record is ``failed``, never ``ok``."""
    from vibeam.engine.records import summarize
    from vibeam.engine.sweep import simulate as run_point
    from vibeam.models import make_solver

    with pytest.raises(ValueError, match=r"state = .*allowed: \|values\| <= 1e\+100"):
        vibeam.simulate(str(CASES / "paper-fig7.toml"), Omega=2.0, periods=8, transient=0, state=[-1e300, 1e300, 0])
    sc = sdof(beta=0.015, B=0.5e-3, R=0.8, Delta=0.7e-3)
    with np.errstate(over="ignore", invalid="ignore"):
        traj = run_point(make_solver(sc, "event"), 2.0, np.array([-1e300, 1e300, 0.0]), 0, 8, 64)
        s = summarize(traj, one_mode(sc).Delta)
    assert s["status"] == "failed" and "overflow double precision" in s["message"], (s["status"], s["message"])
    assert np.isnan(s["amplitude"])
    # a large state that double precision carries is a result: the linear flow of 1e100
    sim = vibeam.simulate(str(CASES / "paper-fig7.toml"), Omega=2.0, periods=8, transient=0, state=[-1e100, 0.0])
    assert sim.status == "ok" and 1e99 < sim.summary["amplitude"] < 2e100


def test_poincare_far_above_resonance_says_unsettled_and_no_impact(tmp_path, capsys):
    """`vibeam poincare --Omega 5e5` printed "period -1, ok" while the record had not settled (the
    free vibration of the start has not decayed in 8 periods of 1.3e-5 natural periods):
    the section carries the record's outcome and says the period in words."""
    assert _exit(["poincare", str(CASES / "paper-fig7.toml"), "--Omega", "5e5", "--periods", "8",
                  "--transient", "20", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "period -1" not in out and "no impact, unsettled" in out, out


@pytest.mark.parametrize("argv,key", [(["--Omega", "1e300"], "Omega"), (["--Omega", "1e9"], "Omega")])
def test_poincare_refuses_a_frequency_above_the_flows_range(argv, key, capsys):
    """--Omega 1e300 ended in an OverflowError traceback (Omega^2 of the flow's coefficients)."""
    assert _exit(["poincare", str(CASES / "paper-fig7.toml"), *argv]) == 2
    line = _one_error_line(capsys)
    assert key in line and "1e+08" in line, line


def test_a_sweep_above_the_flows_range_is_refused():
    text = SCENE.format(contact="").replace("Omega = [2.0, 2.0, 1]", "Omega = [2.0, 1e300, 3]")
    with pytest.raises(CaseError, match=r"sweep.Omega.*Omega <= 1e\+08"):
        vibeam.load_case(tomllib.loads(text))


def test_a_lyapunov_window_that_has_not_settled_is_not_called_periodic(tmp_path):
    """Fig. 7 scene at Omega 1e5: over 200 + 16 periods (0.014 natural time units) the start's
    free vibration has not decayed; the record is ``unsettled`` with no impact (period -1), and
    its spectrum over 1,000 periods was classed "periodic" because the class took any period
    other than 0 as periodic.  A record that has not settled is classed by its spectrum."""
    raw = tomllib.loads((CASES / "paper-fig7.toml").read_text())
    raw["sweep"] = {"Omega": [1e5, 1e5, 1], "transient_periods": 200, "record_periods": 16, "statistics_periods": 0,
                    "lyapunov": True, "lyapunov_periods": 1000}
    raw["run"] = [raw["run"][0]]
    for k in ("quick", "regress", "map", "basins"):
        raw.pop(k, None)
    vibeam.run(vibeam.load_case(raw), jobs=1, out=tmp_path)
    name = raw["run"][0]["name"]
    ds = vibeam.open_results(tmp_path / "results.h5")[f"runs/{name}"].to_dataset().sel(direction="up", Omega=1e5)
    assert str(ds["status"].values) == "unsettled" and int(ds["period"]) == -1
    assert str(ds["lyapunov_class"].values) not in ("periodic", ""), str(ds["lyapunov_class"].values)


# ----------------------------------------------------------------------------- basins' inputs
def _basins_case(tmp_path, lines: str) -> Path:
    text = (CASES / "paper-fig7-two-sided.toml").read_text()
    f = tmp_path / "b.toml"
    f.write_text(text + "\n[basins]\n" + lines + "\nmax_periods = 200\nverify = 0\nlyapunov_periods = 0\n")
    return f


@pytest.mark.parametrize("lines,words", [
    ("Omega = 2.38\nsamples = 20\nseed = -1", ["basins.seed", "-1"]),
    ("Omega = 2.38\nsamples = 20\nx_range = [-1e308, 1e308]", ["x_range", "1e+12"]),
    ("Omega = 2.38\nsamples = 20\nx_range = [0, 5e-324]", ["x_range", "tell apart"]),
    ("Omega = 1e-9\nsamples = 20", ["Omega = 1e-09", "0.001 <= Omega"]),
    ("Omega = 1e300\nsamples = 20", ["Omega = 1e+300", "1e+08"]),
    ("Omega = [2.0, 2.1, 2.2, 2.3, 2.4, 2.5]\ngrid = [2000, 2000]", ["24000000 initial states", "at most"]),
])
def test_basins_values_the_schema_took_are_one_line_errors(lines, words, tmp_path, capsys):
    """seed -1, a box of +-1e308 or of width 5e-324, Omega 1e-9 (numba MemoryError), 1e300 and
    6 frequencies x 2000^2 states (29.8 GiB tried) ended in tracebacks: one line each, naming the
    file, before any state is integrated."""
    f = _basins_case(tmp_path, lines)
    assert _exit(["basins", str(f), "--out", str(tmp_path / "o"), *QUIET]) == 2
    line = _one_error_line(capsys)
    assert str(f) in line and all(w in line for w in words), line
    assert not (tmp_path / "o" / "results.h5").exists()


def test_basins_at_the_lowest_frequency_end_without_a_traceback(tmp_path):
    """Omega = 1e-3 (the lower limit): a set of no stroboscopic sample made describe_attractor
    index an empty array (IndexError); now such a set is described as failed."""
    f = _basins_case(tmp_path, "Omega = 1e-3\nsamples = 20")
    assert _exit(["basins", str(f), "--out", str(tmp_path / "o"), *QUIET]) == 0
    assert (tmp_path / "o" / "results.h5").exists()


# ----------------------------------------------------------------------------- Ctrl-C in a kernel
def _wrapped_interrupt():
    """What a Ctrl-C inside a numba-compiled call looks like from Python: a SystemError whose
    cause is the KeyboardInterrupt the signal handler raised."""
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as ki:
        try:
            raise SystemError("<built-in method shoot> returned a result with an exception set") from ki
        except SystemError as e:
            return e


class _Interrupted:
    """A time-domain solver whose call is interrupted inside its compiled code."""
    time_domain = True
    chunk_periods = 2000

    def __init__(self, sc):
        self.scene = sc

    def point(self, *a, **k):
        raise _wrapped_interrupt()


def test_ctrl_c_inside_a_compiled_call_stops_the_sweep():
    """The SystemError was recorded as a ``failed`` point and the run went on to exit 0 with a
    file marked complete (3 of 4 Ctrl-C during a Lyapunov computation): it is the interrupt."""
    from vibeam.engine.sweep import Sweep, run_sweep

    sc = sdof(beta=0.015, B=0.5e-3, R=0.8, Delta=0.7e-3)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(_Interrupted(sc), Sweep(Omega=np.array([2.0, 2.1]), transient_periods=1, record_periods=1))


def test_ctrl_c_inside_a_compiled_shot_is_not_a_failed_shot():
    """The continuation engine turned any exception of a shot into a failed shot, so the
    interrupt became a failed start; it is handed on."""
    from vibeam.models import shooting_problem
    from vibeam.models.orbits.continuation import trace

    prob = shooting_problem(sdof(beta=0.015, B=0.5e-3, R=0.8, Delta=0.7e-3), "Omega")

    class Wrapped:
        def __getattr__(self, k):
            return getattr(prob, k)

        def shot(self, *a):
            raise _wrapped_interrupt()

    with pytest.raises(KeyboardInterrupt):
        trace(Wrapped(), np.zeros(2), 2.0, 1, 1.5, 2.5)


def test_a_killed_pool_leaves_no_thread_blocked_on_a_partial_result():
    """`vibeam basins --jobs 2`, Ctrl-C while lines stream their results: the workers were killed
    with a result half written, the pool's manager thread blocked reading the rest of it, and the
    command hung at exit (Python joins that thread) after printing "interrupted": 10 min and more
    at 45 s into a 4-frequency grid.  Here the half-written result is made by hand (a message
    header for 1000 bytes and 10 of them); after the pool is terminated the thread must end (its
    read meets the end of the pipe), where before it stayed blocked for good."""
    import os
    import struct
    from concurrent.futures import ProcessPoolExecutor

    from vibeam.engine.sweep import _terminate

    ex = ProcessPoolExecutor(1)
    assert ex.submit(abs, -1).result() == 1                 # the pool and its manager thread run
    manager = ex._executor_manager_thread
    os.write(ex._result_queue._writer.fileno(), struct.pack("!i", 1000) + b"x" * 10)
    manager.join(timeout=1.0)
    assert manager.is_alive()                               # blocked on the rest of the message
    _terminate(ex)
    manager.join(timeout=30.0)                              # a bound on a hang, not a speed
    assert not manager.is_alive()
