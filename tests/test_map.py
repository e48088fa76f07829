"""Parameter maps, the line engine's recovery, dask execution, checkpoint and resume."""
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from vibeam.case.schema import parse_case
from vibeam.analysis.maps import FAILED, HELD, NO_IMPACT, PERIOD_1, classify
from vibeam.models import make_solver
from vibeam.models.builders.sdof import sdof
from vibeam.io.results import read_lines, read_results
from vibeam.runner import run_case
from vibeam.engine.sweep import Sweep, plan_lines, run_lines, run_sweep
from vibeam.testing import CrashingSolver, FailingSolver

RIG = """
name = "map-{gap}"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.72
gap_mm = {gap}
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [14.0, 17.0, {nf}]
direction = "both"
transient_periods = {tp}
record_periods = 16
[map]
parameter = "voltage"
values = [0.2, 0.7, {nv}]
[[run]]
name = "exact"
method = "event"
"""


def rig(gap=0.0, nf=7, nv=4, tp=300):
    text = RIG.format(gap=gap, nf=nf, nv=nv, tp=tp)
    return parse_case(text), text


def _same(a: dict, b: dict, skip=("wall_time_s",)):
    """Every dataset of two read_results/read_lines dicts equal (NaN == NaN), except ``skip``."""
    assert sorted(a) == sorted(b)
    for k in a:
        if k in skip or k == "attrs":
            continue
        if isinstance(a[k], dict):
            _same(a[k], b[k], skip)
        else:
            x, y = np.asarray(a[k]), np.asarray(b[k])
            assert x.shape == y.shape, k
            if x.dtype.kind in "fc":
                np.testing.assert_array_equal(x, y, err_msg=k)
            else:
                assert (x == y).all(), k


def test_classify_codes():
    p = np.array([-1, -1, 1, 2, 5, 0, 1])
    st = np.array(["ok", "sticking", "chatter", "ok", "ok", "ok", "failed"], dtype=object)
    assert classify(p, st).tolist() == [NO_IMPACT, HELD, PERIOD_1, 2, 3, 4, FAILED]


def test_zero_gap_map_is_homogeneous_in_voltage(tmp_path):
    """With Delta = 0 the CoR oscillator is homogeneous of degree 1 in the forcing (q -> c q
    maps solutions at B to solutions at c B, the stop q = 0 and the impact law being invariant),
    so the map's class must not depend on the voltage and amplitude / V must be the same on
    every voltage line.  The transients (300 periods, decay exp(-0.017*2pi*300/2.2) < 1e-6
    before the impacts' extra dissipation) leave differences at round-off."""
    case, text = rig(0.0)
    (m,) = run_case(case, text, tmp_path, jobs=1, quiet=True, plots=True)
    d = m.data
    assert d["classification"].shape == (2, 4, 7)
    assert (d["classification"] == d["classification"][:, :1, :]).all()
    a = d["amplitude_mm"] / d["values"][None, :, None]
    np.testing.assert_allclose(a, np.broadcast_to(a[:, :1, :], a.shape), rtol=1e-8)
    # amplitude at V scales as the linear FRC would at this frequency only below the stop:
    # here every point impacts (period-1 at the zero gap, 2 f_n inside the band)
    assert (d["classification"] == PERIOD_1).all()
    from test_plots import assert_png_shows_results      # the PNG is the file's classes, drawn

    assert_png_shows_results(tmp_path / "map_exact.png", tmp_path / "results.h5", "map exact")
    f = read_results(tmp_path / "results.h5")
    assert f["attrs"]["complete"]
    assert f["maps"]["exact"]["attrs"]["parameter"] == "voltage"
    np.testing.assert_array_equal(f["maps"]["exact"]["classification"], d["classification"])


def test_prestressed_map_held_region_matches_closed_form(tmp_path):
    """On a pre-stressed stop (Delta < 0) at rest, q'' = Omega^2 B sin(Omega t) - Delta while
    held, so the forcing lifts the mass off iff Omega^2 B > |Delta| (Eq. 2 with q = Delta,
    q' = 0).  Every map point below that voltage must be 'held on the stop'; every point above
    it must not."""
    case, text = rig(-0.1, nf=7, nv=11, tp=100)
    (m,) = run_case(case, text, tmp_path, jobs=2, quiet=True, plots=False)
    d = m.data
    Omega = d["Omega"][0]                     # (n_values, n_freq)
    B = 5.16e-4 * d["values"][:, None]
    lift = Omega ** 2 * B > 0.1 / 180.0
    c = d["classification"]
    for k in range(2):
        assert (c[k][~lift] == HELD).all()
        assert (c[k][lift] != HELD).all()
    assert (~lift).sum() >= 10 and lift.sum() >= 10   # both regions are sampled


def test_failed_line_is_recorded_and_the_map_goes_on():
    """A numerical failure at one frequency is a recorded status with its message; the chain
    carries on from the last good state and the other lines are untouched."""
    m = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9)
    Om = np.linspace(1.8, 2.2, 5)
    sw = Sweep(Omega=Om, direction="both", transient_periods=100, record_periods=8)
    good = run_sweep(make_solver(m, "event"), sw, jobs=1)
    bad = run_sweep(FailingSolver(make_solver(m, "event"), [Om[2]]), sw, jobs=2)
    st = bad.data["status"]
    hit = np.isclose(bad.data["Omega"], Om[2])
    assert (st[hit] == "failed").all() and all("injected numerical failure" in s for s in bad.data["message"][hit])
    assert (st[~hit] != "failed").all()
    # the up branch before the failure is identical
    up = bad.data["direction"] == "up"
    sel = up & (bad.data["Omega"] < Om[2])
    np.testing.assert_array_equal(bad.data["amplitude"][sel], good.data["amplitude"][sel])


@pytest.mark.parametrize("jobs", [2])
def test_killed_worker_line_is_retried(tmp_path, jobs):
    """A worker killed in the middle of a line (os._exit: no exception, no cleanup, as a killed
    process) breaks the process pool; the engine rebuilds the pool, reruns the lost lines and
    the results equal those of an undisturbed run exactly."""
    m = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9)
    Om = np.linspace(1.8, 2.2, 6)
    sw = Sweep(Omega=Om, direction="both", transient_periods=100, record_periods=8)
    good = run_sweep(make_solver(m, "event"), sw, jobs=1)
    marker = tmp_path / "crashed"
    crashing = CrashingSolver(make_solver(m, "event"), [Om[3]], marker)
    again = run_sweep(crashing, sw, jobs=jobs)
    assert marker.exists()                                 # the crash did happen
    assert (again.data["status"] != "failed").all()
    for k in ("amplitude", "period", "impacts_per_period", "strobe"):
        np.testing.assert_array_equal(again.data[k], good.data[k])


def test_line_lost_too_often_is_recorded_failed(tmp_path):
    """A line whose worker dies on every attempt ends as 'failed' with the reason after
    max_attempts, and the other lines complete."""
    m = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9)
    Om = np.linspace(1.8, 2.2, 3)
    sw = Sweep(Omega=Om, direction="up", transient_periods=50, record_periods=8, continuation=False)

    solver = make_solver(m, "event")
    lines = plan_lines(CrashingSolver(solver, [Om[1]]), sw)   # every attempt at Om[1] crashes
    out = run_lines(lines, jobs=2, max_attempts=2)
    rows = out[("run", lines[1].key)]
    assert rows[0]["status"] == "failed" and "worker lost 2 time(s)" in rows[0]["message"]
    for k in (0, 2):
        assert out[("run", lines[k].key)][0].get("status") != "failed"


@pytest.fixture(scope="module")
def cluster():
    """A real dask.distributed LocalCluster on loopback: 2 worker processes (with nannies,
    which restart a killed worker)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as c:
        yield c


def test_dask_localcluster_equals_local_pool(tmp_path, cluster):
    """The same map on a dask.distributed LocalCluster (loopback, 2 worker processes) and on the
    local process pool: every dataset equal bit for bit (same code, same inputs)."""
    import distributed

    case, text = rig(-0.1, nf=5, nv=3, tp=150)
    local = run_case(case, text, tmp_path / "pool", jobs=2, quiet=True, plots=False)[0]
    with distributed.Client(cluster) as client:
        remote = run_case(case, text, tmp_path / "dask", quiet=True, plots=False,
                          executor=client.get_executor())[0]
    # the command line: `vibeam map CASE --scheduler ADDRESS`
    (tmp_path / "case.toml").write_text(text)
    from vibeam.cli import main
    assert main(["map", str(tmp_path / "case.toml"), "--scheduler", cluster.scheduler_address,
                 "--out", str(tmp_path / "cli"), "--quiet", "--no-plots"]) == 0
    _same(local.data, remote.data)
    for out in ("dask", "cli"):
        _same(read_results(tmp_path / "pool" / "results.h5")["maps"],
              read_results(tmp_path / out / "results.h5")["maps"])


def test_dask_killed_worker_line_is_retried(tmp_path, cluster):
    """A dask worker process killed in the middle of a line: the line runs again (on a
    restarted or the other worker) and the sweep equals an undisturbed one exactly."""
    import distributed

    m = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9)
    Om = np.linspace(1.8, 2.2, 6)
    sw = Sweep(Omega=Om, direction="both", transient_periods=100, record_periods=8)
    good = run_sweep(make_solver(m, "event"), sw, jobs=1)
    marker = tmp_path / "crashed"
    with distributed.Client(cluster) as client:
        again = run_sweep(CrashingSolver(make_solver(m, "event"), [Om[3]], marker), sw,
                          executor=client.get_executor())
    assert marker.exists()
    for k in ("amplitude", "period", "impacts_per_period", "strobe", "status"):
        np.testing.assert_array_equal(again.data[k], good.data[k])


def _vibeam(*args):
    return [sys.executable, "-m", "vibeam.cli", *args]


# ``python -c HOLD MARK vibeam-args...``: vibeam's command line checkpointing after every line,
# which, once its checkpoint holds 3 lines, writes how many to MARK and waits to be killed: the
# kill lands part-way by construction, not by timing
HOLD = """
import sys, time
from pathlib import Path
import vibeam.runner as runner
from vibeam.io.results import read_lines
from vibeam.io.store import Store
real_run, real_cp = runner.run_case, Store.checkpoint
def run_case(*a, **k):
    k["checkpoint_interval_s"] = 0.0
    return real_run(*a, **k)
def checkpoint(self, *a, **k):
    out = real_cp(self, *a, **k)
    n = sum(len(v) for v in read_lines(self.path)[1].values())
    if n >= 3:
        Path(sys.argv[1]).write_text(str(n))
        time.sleep(600)
    return out
runner.run_case, Store.checkpoint = run_case, checkpoint
import vibeam.cli as cli
cli.run_case = run_case
sys.exit(cli.main(sys.argv[2:]))
"""


@pytest.mark.slow   # a map killed and resumed in subprocesses (~14 s); test_interrupts.py covers interrupts in the default step: slow step
def test_kill_and_resume_gives_the_same_file(tmp_path):
    """Kill `vibeam map` (SIGKILL: no cleanup) once some lines are checkpointed; the results
    file must be readable at that moment (atomic line writes), `--resume` must compute only
    the missing lines, and the final file must hold the same data as an uninterrupted run.
    The map holds still once its checkpoint has 3 of its 16 lines (:data:`HOLD`), so the kill
    lands part-way whatever the machine's speed (it was timed before: issue 46)."""
    case_file = tmp_path / "case.toml"
    case_file.write_text(RIG.format(gap=-0.1, nf=9, nv=8, tp=800) + "recurrence = false\n")
    full, part = tmp_path / "full", tmp_path / "part"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    subprocess.run(_vibeam("map", str(case_file), "--out", str(full), "--jobs", "1", "--quiet", "--no-plots"),
                   check=True, env=env, capture_output=True)
    mark = tmp_path / "held"
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(mark), "map", str(case_file), "--out", str(part),
                             "--jobs", "1", "--quiet", "--no-plots"], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    h5 = part / "results.h5"
    t0 = time.time()
    while time.time() - t0 < 300 and proc.poll() is None and not mark.exists():     # hang guard only
        time.sleep(0.02)
    time.sleep(0.05)
    n_done = int(mark.read_text()) if mark.exists() else 0
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert 3 <= n_done < 16, f"the kill should land part-way (lines done: {n_done} of 16)"
    attrs, lines = read_lines(h5)                      # never corrupt
    assert not attrs["complete"]
    n_kept = sum(len(v) for v in lines.values())
    r = subprocess.run(_vibeam("map", str(case_file), "--out", str(part), "--jobs", "1", "--quiet",
                               "--no-plots", "--resume"), env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert f"resuming: {n_kept} of 16 sweep lines done" in r.stderr     # --quiet keeps this line (runner)
    a, b = read_results(full / "results.h5"), read_results(h5)
    assert b["attrs"]["complete"]
    _same(a["maps"], b["maps"])
    assert read_lines(full / "results.h5")[1] == read_lines(h5)[1] == {}     # compacted


def test_ctrl_c_keeps_finished_lines(tmp_path):
    """SIGINT (Ctrl-C) stops the run with exit code 130 and a hint; the file is valid and
    holds the finished lines."""
    case_file = tmp_path / "case.toml"
    # ~2 s of lines (as in test_kill_and_resume_gives_the_same_file): the signal, sent once the
    # first checkpoint (0.5 s) is there, must find the map running; with the exact recurrence
    # the map could end before its first checkpoint on a fast machine
    case_file.write_text(RIG.format(gap=-0.1, nf=9, nv=8, tp=800) + "recurrence = false\n")
    proc = subprocess.Popen(_vibeam("map", str(case_file), "--out", str(tmp_path), "--jobs", "1", "--quiet",
                                    "--no-plots"), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    h5 = tmp_path / "results.h5"
    partial = tmp_path / "results.h5.partial"          # the checkpoint, beside results.h5
    t0 = time.time()
    while time.time() - t0 < 120 and proc.poll() is None and not partial.exists():
        time.sleep(0.02)
    seen = (round(time.time() - t0, 2), partial.exists(), proc.poll())
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    # seen: (s until the signal, the file there, the exit code if the map had already ended)
    assert proc.returncode == 130, (seen, err)
    assert "--resume" in err and "Traceback" not in err, err
    attrs, lines = read_lines(h5)
    assert not attrs["complete"] and sum(len(v) for v in lines.values()) >= 1, (dict(attrs), err)


def test_resume_refuses_another_case(tmp_path):
    case, text = rig(0.0, nf=3, nv=2, tp=50)
    run_case(case, text, tmp_path, jobs=1, quiet=True, plots=False)
    other, other_text = rig(0.1, nf=3, nv=2, tp=50)
    from vibeam.case.schema import CaseError
    with pytest.raises(CaseError, match="another case"):
        run_case(other, other_text, tmp_path, jobs=1, quiet=True, plots=False, resume=True)


def test_resume_of_a_plain_run_recomputes_nothing(tmp_path, capsys):
    """A complete file resumed: nothing is recomputed -- even the per-point wall times, which
    a recomputation would change, come back identical from the file.  The complete file holds
    every point once: its checkpoint lines were compacted into /runs."""
    text = RIG.format(gap=0.0, nf=5, nv=2, tp=50).split("[map]")[0] + '[[run]]\nname = "exact"\nmethod = "event"\n'
    case = parse_case(text)
    first = run_case(case, text, tmp_path, jobs=1, quiet=True, plots=False)[0]
    with h5py.File(tmp_path / "results.h5") as f:
        assert "lines" not in f and f["runs/exact/amplitude"].shape == (2, 5)
    stamp = (tmp_path / "results.h5").stat().st_mtime_ns
    second = run_case(case, text, tmp_path, jobs=1, quiet=True, plots=False, resume=True)[0]
    assert "recomputes nothing" in capsys.readouterr().err
    assert (tmp_path / "results.h5").stat().st_mtime_ns == stamp      # not even rewritten
    _same(first.data, second.data, skip=())
    assert second.attrs["model"] == first.attrs["model"]


def test_resume_of_a_complete_map_recomputes_nothing(tmp_path):
    case, text = rig(-0.1, nf=4, nv=3, tp=60)
    (first,) = run_case(case, text, tmp_path, jobs=1, quiet=True, plots=False)
    (second,) = run_case(case, text, tmp_path, jobs=1, quiet=True, plots=False, resume=True)
    _same(first.data, second.data, skip=())
    assert second.parameter == "voltage" and read_lines(tmp_path / "results.h5")[1] == {}
