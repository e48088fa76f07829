"""The run's execution: per-point progress, inline or pool, the timing the CLI reports."""
from __future__ import annotations

import os
import stat
import time

import numpy as np
import pytest

from vibeam.models import make_solver
from vibeam.models.builders.sdof import sdof
from vibeam.engine.sweep import Sweep, plan_lines, run_lines


class SlowSolver:
    """An event solver that takes at least ``delay`` s per point (picklable), so a point's
    report reaches the parent long before its line ends."""

    def __init__(self, solver, delay):
        self.solver, self.delay = solver, delay

    def __getattr__(self, name):
        if name == "solver":
            raise AttributeError(name)
        return getattr(self.solver, name)

    def point(self, *a, **k):
        time.sleep(self.delay)
        return self.solver.point(*a, **k)


class _Bar:
    """Records tqdm's updates."""
    made = []

    def __init__(self, total=0, **kw):
        self.total, self.updates = total, []
        _Bar.made.append(self)

    def update(self, k):
        self.updates.append(k)

    def close(self):
        pass


def _lines(n_points, delay=0.0, direction="both"):
    sc = sdof(beta=0.015, B=0.5e-3, R=0.9, Delta=0.0)
    s = make_solver(sc, "event")
    sw = Sweep(Omega=np.linspace(1.8, 2.2, n_points), direction=direction, transient_periods=20, record_periods=8)
    return plan_lines(SlowSolver(s, delay) if delay else s, sw)


@pytest.mark.parametrize("jobs", [1, 2])
def test_progress_advances_per_point(monkeypatch, jobs):
    """Inline and in the local pool the bar advances point by point, not per line (2 lines of
    6 points: per line would be two updates of 6); the total is exact."""
    import tqdm

    monkeypatch.setattr(tqdm, "tqdm", _Bar)
    _Bar.made.clear()
    stats = {}
    run_lines(_lines(6, delay=0.15), jobs=jobs, progress=True, stats=stats)
    (bar,) = _Bar.made
    assert sum(bar.updates) == bar.total == 12
    assert max(bar.updates) <= 2 and len(bar.updates) >= 8, bar.updates
    assert stats["executor"] == ("inline" if jobs == 1 else "pool of 2 workers")
    if jobs == 2:
        assert stats["pool_startup_s"] > 0        # measured and reported (its size is the bench's)


def test_small_sweep_runs_inline_and_hands_the_rest_to_the_pool():
    """inline_first_s: lines run inline until that much time has passed, then the pool takes
    the rest (at least two lines left); the results equal an inline run bit for bit."""
    lines = _lines(3, delay=0.05, direction="up")
    lines = lines + [l.__class__(**{**l.__dict__, "key": l.key + "-b"}) for l in lines] + \
        [l.__class__(**{**l.__dict__, "key": l.key + "-c"}) for l in lines]
    stats = {}
    out = run_lines(lines, jobs=2, inline_first_s=0.0, stats=stats)
    assert stats["executor"].startswith("inline for") and "then a pool of 2 workers" in stats["executor"]
    ref = run_lines(lines, jobs=1)
    for k in ref:
        np.testing.assert_array_equal([r["amplitude"] for r in out[k]], [r["amplitude"] for r in ref[k]])
    stats = {}
    run_lines(lines, jobs=2, inline_first_s=60.0, stats=stats)
    assert stats["executor"] == "inline"


def test_plan_execution_inline_for_small_sweeps_pool_for_large():
    from vibeam import runner
    from vibeam.case.schema import load_case

    case, _ = load_case(runner.__file__.replace("vibeam/runner.py", "cases/paper-fig7.toml"))
    jobs_ = runner._jobs(case)
    todo = [l for j in jobs_ for l in runner._lines(j)]
    n, why = runner.plan_execution(case, jobs_, todo, 2, None)
    assert why.startswith("small sweep")                    # ~0.2 s on one core: inline first
    big = type(case).model_validate({**case.model_dump(), "sweep": {**case.sweep.model_dump(),
                                                                    "transient_periods": 20000}})
    jb = runner._jobs(big)
    n, why = runner.plan_execution(big, jb, [l for j in jb for l in runner._lines(j)], 2, None)
    assert (n, why) == (2, "")
    assert runner.plan_execution(case, jobs_, todo[:1], 2, None) == (1, "")    # one line


def test_cli_reports_run_time_kernel_load_and_pool(tmp_path, capsys):
    from vibeam.cli import main

    case = tmp_path / "c.toml"
    case.write_text("""
name = "c"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
[sweep]
Omega = [1.8, 2.2, 5]
direction = "both"
transient_periods = 50
record_periods = 8
[[run]]
name = "exact"
method = "event"
""")
    assert main(["run", str(case), "--out", str(tmp_path / "o"), "--no-plots"]) == 0  # not --quiet: this reads the tables it prints (--quiet drops them, issue 42 item 7)
    out = capsys.readouterr().out
    assert "run time " in out and "for 10 points" in out and "kernel load" in out and "pool start-up" in out


def test_tables_fit_long_run_names(tmp_path, capsys):
    """`vibeam run` and `vibeam regress` tables: a long run name is printed whole and the
    columns stay aligned (the method column starts where its header does)."""
    from vibeam.cli import main

    long = "exact event solver with a very long descriptive run name"
    case = tmp_path / "c.toml"
    case.write_text(f"""
name = "c"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
[sweep]
Omega = [1.8, 2.2, 3]
transient_periods = 30
record_periods = 8
[[run]]
name = "{long}"
method = "event"
[[run]]
name = "short"
method = "event"
transient_samples = 32
""")
    assert main(["run", str(case), "--out", str(tmp_path / "o"), "--no-plots"]) == 0  # not --quiet: this reads the tables it prints (--quiet drops them, issue 42 item 7)
    out = capsys.readouterr().out.splitlines()
    head = next(l for l in out if l.startswith("run ") and "method" in l)
    col = head.index("method")
    rows = [l for l in out if l.startswith(long) or l.startswith("short ")]
    assert len(rows) == 2 and all(l[col:col + 5] == "event" for l in rows), (head, rows)
    assert main(["regress", str(case), "--reference", str(tmp_path / "o" / "results.h5"),
                 "--results", str(tmp_path / "o" / "results.h5")]) == 0
    out = capsys.readouterr().out.splitlines()
    head = next(l for l in out if l.startswith("run ") and "points" in l)
    row = next(l for l in out if l.startswith(long))
    assert row.index(" 3 ") <= head.index("points") + len("points") and "  ok" in row


def test_map_without_plots_prints_the_class_summary(tmp_path, capsys):
    from vibeam.cli import main

    case = tmp_path / "m.toml"
    case.write_text("""
name = "m"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.72
gap_mm = -0.1
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [14.0, 17.0, 3]
direction = "both"
transient_periods = 50
record_periods = 8
[map]
parameter = "voltage"
values = [0.2, 0.7, 2]
[[run]]
name = "exact"
method = "event"
""")
    assert main(["map", str(case), "--out", str(tmp_path / "o"), "--no-plots"]) == 0  # not --quiet: it reads the report (--quiet drops it, issue 42 item 7)
    out = capsys.readouterr().out
    assert "exact up: 6 points:" in out and "exact down: 6 points:" in out and "up and down sweeps differ" in out
    assert not list((tmp_path / "o").glob("*.png"))


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_continuation_run_advances_the_bar_per_start(monkeypatch, jobs):
    """A continuation run is one unit of work whose bar advances per start (2 ends x 3 kinds on
    the Fig. 13 scene: 6 steps), inline and from a pool worker, not once at its end; its result
    is the same with and without the progress reports."""
    import tqdm

    from vibeam.analysis.branches import plan
    from vibeam.case.schema import load_case

    case, _ = load_case("cases/paper-fig13-continuation.toml")
    case = case.quick_variant()
    r = next(x for x in case.run if x.method == "continuation")
    task = plan(case, r)
    assert task.n_points == 6
    monkeypatch.setattr(tqdm, "tqdm", _Bar)
    _Bar.made.clear()
    res = run_lines([task], jobs=jobs, progress=True)
    (bar,) = _Bar.made
    assert bar.total == 6 and sum(bar.updates) == 6
    if jobs == 1:
        assert len(bar.updates) == 6, bar.updates          # one step per start, as it happens
    plain = task.compute()[0]
    got = res[(task.run, task.key)][0]
    assert [s["status"] for s in got["starts"]] == [s["status"] for s in plain["starts"]]
    assert len(got["branches"]) == len(plain["branches"]) > 0


def test_a_long_first_line_hands_the_next_lines_to_the_pool_while_it_runs():
    """Issue 42, item 9: a sweep estimated small runs inline first; its two lines (up and down,
    each a whole continued sweep) were each computed whole before the pool was asked, so a
    4-mode Hunt-Crossley sweep that the estimate put at 0.14 s ran 28.8 s on one core with the
    other idle.  Now the inline time is checked after every point: once it is spent (0.5 s here;
    the points take 0.3 s each, so it is spent inside the first line) the lines after the current
    one go to a pool of the other cores while this process finishes its line; the results equal
    an inline run bit for bit."""
    lines = _lines(4, delay=0.3, direction="both")
    assert len(lines) == 2
    stats = {}
    out = run_lines(lines, jobs=2, inline_first_s=0.5, stats=stats)
    assert stats["executor"].startswith("inline for") and stats["executor"].endswith("beside it"), stats
    ref = run_lines(_lines(4, direction="both"), jobs=1)
    for k in ref:
        np.testing.assert_array_equal([r["amplitude"] for r in out[k]], [r["amplitude"] for r in ref[k]])


def test_the_first_compilation_is_announced_before_the_wait():
    """Issue 44: the quick start sat 49 s in silence after '[paper-fig7] ... 202 points' and said
    'compiling kernels' only after the wait.  CompileClock's notice is called once, when the
    first compilation starts (a fresh njit function: numba's compile event), before it ends --
    and not for a cached kernel (the second call compiles nothing); the runner's notice says it
    once per process."""
    import numba

    from vibeam import runner
    from vibeam.engine.compiling import CompileClock

    seen = []

    @numba.njit(cache=False)
    def fresh(x):
        return x + 1.0

    with CompileClock(lambda *a: seen.append(("notice", c.count, a[0])),
                      lambda name, s: seen.append(("done", name, s > 0))) as c:
        fresh(1.0)
        fresh(2.0)                          # compiled already: no second notice
    assert seen == [("notice", 0, "fresh"), ("done", "fresh", True)] and c.count >= 1 and c.seconds > 0, \
        (seen, c.count)
    assert c.entries[0][0] == "fresh"
    with CompileClock(lambda *a: seen.append("again")) as c2:
        fresh(3.0)                          # nothing compiled: no notice
    assert "again" not in seen and c2.count == 0
    runner._NOTICED.clear()
    said = []
    real = runner.sys.stderr
    try:
        import io

        runner.sys.stderr = buf = io.StringIO()
        runner.compile_notice()
        runner.compile_notice()
        said = buf.getvalue().splitlines()
        runner.compile_notice("integrate_work [Newton stops only]", 27.6, "last time on this machine")
        runner.compile_done("integrate_work [Newton stops only]", 26.04)
        more = buf.getvalue().splitlines()[len(said):]
    finally:
        runner.sys.stderr = real
    assert len(said) == 1 and said[0].startswith("compiling kernels for first use"), said
    assert more == ["  compiling integrate_work [Newton stops only], about 28 s (last time on this machine) ...",
                    "  compiled integrate_work [Newton stops only] in 26.0 s"], more


def test_the_expected_compile_time_is_the_last_measured_on_this_machine(tmp_path, monkeypatch):
    """Issue 44: the line before a compile gives the time it took the last time on this machine
    (kept beside numba's cache, written whole), else the development machine's figure; a file that
    cannot be read is no figure."""
    from vibeam.engine import compiling

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(compiling, "load", lambda: (0.4, 2))
    name = "integrate_work [Newton stops only]"
    dev = "on the development machine: 2 cores at load 1"
    assert compiling.expected_seconds(name) == (compiling.MEASURED_S[name], dev)
    assert compiling.expected_seconds("unknown") == (None, "")
    compiling.record_seconds(name, 12.345)
    monkeypatch.setattr(compiling, "load", lambda: (3.25, 2))
    compiling.record_seconds("shoot", 3.0)
    assert compiling.expected_seconds(name) == (12.35, "last time here, 2 cores at load 0.4")
    assert compiling.expected_seconds("shoot") == (3.0, "last time here, 2 cores at load 3.2")
    # issue 56: "compiling shoot, about 9 s" then "compiled shoot in 49.8 s" on a busy machine; a
    # load over twice the cores is said beside the figure
    monkeypatch.setattr(compiling, "load", lambda: (5.0, 2))
    assert compiling.expected_seconds("shoot") == (3.0, "last time here, 2 cores at load 3.2; load now 5.0")
    assert compiling.expected_seconds(name)[1] == "last time here, 2 cores at load 0.4; load now 5.0"
    assert [p.name for p in tmp_path.iterdir()] == ["vibeam-compile-times.json"]     # no temporary left
    compiling.times_file().write_text("{not json")
    assert compiling.expected_seconds(name) == (compiling.MEASURED_S[name], dev + "; load now 5.0")
    # a file of the former format (seconds alone) is read with the load unknown
    compiling.times_file().write_text('{"shoot": 7.5}')
    assert compiling.expected_seconds("shoot") == (7.5, "last time here, load unknown; load now 5.0")


def test_a_fifo_in_place_of_the_compile_times_does_not_block(tmp_path, monkeypatch):
    """Issue 57 (8): a FIFO at ``$NUMBA_CACHE_DIR/vibeam-compile-times.json`` blocked vibeam forever
    before its first compile (the open of a FIFO waits for a writer).  Only a regular file is read;
    the FIFO is left as it is (recording skips it: it is not vibeam's to replace)."""
    import threading

    from vibeam.engine import compiling

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    os.mkfifo(compiling.times_file())
    out = []
    t = threading.Thread(target=lambda: out.append(compiling.expected_seconds("shoot")), daemon=True)
    t.start()
    t.join(20.0)
    assert out == [(compiling.MEASURED_S["shoot"], out[0][1] if out else None)] and not t.is_alive()
    compiling.record_seconds("shoot", 1.0)
    assert stat.S_ISFIFO(os.stat(compiling.times_file()).st_mode)
