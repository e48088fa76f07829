"""Interrupts (issue 11): Ctrl-C and SIGTERM stop a run at once with one line, keep every
finished line and leave no worker alive; after ``kill -9`` of the main process no pool worker
stays behind.  Real subprocesses and real signals.

Nothing here is timed: the command runs under a probe (:data:`PROBE`) that appends a line to a
marker file whenever a solver call (a chunk of at most 2000 periods, ``EventSolver.chunk_periods``)
begins or ends, in the main process or a forked pool worker, and when the main process's
SIGINT / SIGTERM handler runs.  The tests wait for those lines (not a fixed sleep) and assert
what happened after the signal: the points the workers were in were abandoned, not finished
(before the fix a pooled map waited for the running lines: 6 points of 1000 calls each here,
15-20 s for a line of rig-map-gap), no chunk began in the main process after its interrupt, the exit code and the
one line.  Time limits are hang guards only (:data:`HANG_S`).  The latency in seconds is a figure
of ``vibeam bench --latency``."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from vibeam.io.results import read_lines

# a map of 2 x 6 lines; with 2000000 transient periods a point is 1000 solver calls of 2000
# periods (5-15 s: chatter at the pre-stressed stop) and a line six points: an interrupt that
# waited for the running lines, as before, finishes points; with 20000 a point is 10 calls
# (~0.1 s), every period integrated (recurrence = false: a transient that recurs exactly would
# end early).  The long points give the checks below a margin of hundreds of calls, so that a
# loaded machine that delays a process by a second cannot decide them.
MAP = """
name = "slow-map"
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
transient_periods = {tp}
record_periods = 16
[map]
parameter = "voltage"
values = [0.5, 0.7, 6]
[[run]]
name = "exact"
method = "event"
recurrence = false
"""
LONG_TP = 2_000_000
CALLS_PER_POINT = LONG_TP // 2000     # EventSolver.chunk_periods = 2000 (asserted in _start)
EARLY = CALLS_PER_POINT // 2          # signal only while every worker is in the first half of a point
HANG_S = 120.0                        # hang guard: a run that has not stopped by then never will

# ``python PROBE MARKS vibeam-args...``: vibeam's command line with markers.  ``<pid> begin|end
# <n_transient> <n_record>`` around every EventSolver.point call (forked workers inherit the
# patched class), ``<pid> handler SIGINT|SIGTERM`` when the main process's handler runs (the
# handlers are vibeam's own, wrapped: Python's default SIGINT handler, cli._on_sigterm).
# os.write on an O_APPEND file: one line per write, in one order for every process.
PROBE = """
import os, signal, sys
fd = os.open(sys.argv[1], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
def mark(text):
    os.write(fd, f"{os.getpid()} {text}\\n".encode())
from vibeam.models import EventSolver
inner = EventSolver.point
def point(self, Omega, state, n_tr, n_rec, *a, **k):
    mark(f"begin {n_tr} {n_rec}")
    out = inner(self, Omega, state, n_tr, n_rec, *a, **k)
    mark(f"end {n_tr} {n_rec}")
    return out
EventSolver.point = point
def on_int(signum, frame):
    mark("handler SIGINT")
    signal.default_int_handler(signum, frame)
signal.signal(signal.SIGINT, on_int)
import vibeam.cli as cli
on_term = cli._on_sigterm
def on_term_marked(signum, frame):
    mark("handler SIGTERM")
    on_term(signum, frame)
cli._on_sigterm = on_term_marked
sys.exit(cli.main(sys.argv[2:]))
"""


def _stat(pid: int):
    """Fields 3.. of /proc/PID/stat (state, ppid, ...; field 22, the start time, is [19]), or None."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None


def _children(pid: int) -> dict:
    """The children of ``pid`` as ``{pid: (pid, start time)}``: pids wrap around (pid_max can be
    32768) on a busy machine, so a process is known by both."""
    out = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            f = _stat(int(d.name))
            if f is not None and int(f[1]) == pid:
                out[int(d.name)] = (int(d.name), f[19])
    return out


def _alive(ident) -> bool:
    """The process ``(pid, start time)`` still runs (a zombie has ended; another process that
    got the pid is not it)."""
    f = _stat(ident[0])
    return f is not None and f[19] == ident[1] and f[0] not in ("Z", "X")


def _start(tmp_path, jobs, tp=LONG_TP):
    from vibeam.models import EventSolver

    assert EventSolver.chunk_periods == 2000       # the scene: a long point is CALLS_PER_POINT calls
    case = tmp_path / "map.toml"
    case.write_text(MAP.format(tp=tp))
    out = tmp_path / "out"
    probe = tmp_path / "probe.py"
    probe.write_text(PROBE)
    marks = tmp_path / "marks.txt"
    marks.touch()
    p = subprocess.Popen([sys.executable, str(probe), str(marks), "map", str(case), "--out", str(out),
                          "--jobs", str(jobs), "--quiet", "--no-plots"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return p, marks, out


def _marks(path) -> list[tuple]:
    """The marker file as ``(pid, word, rest)`` rows (a torn last line is left for the next read)."""
    rows = []
    for line in Path(path).read_text().splitlines(keepends=True):
        if line.endswith("\n"):
            pid, word, *rest = line.split()
            rows.append((int(pid), word, rest))
    return rows


def _state(rows, main_pid) -> dict:
    """Per worker pid: transient calls begun in its current point (``in_point``), points
    finished (``points``) and calls begun (``calls``) over ``rows``."""
    st = {}
    for pid, word, rest in rows:
        if pid == main_pid or word not in ("begin", "end"):
            continue
        s = st.setdefault(pid, dict(in_point=0, points=0, calls=0))
        n_tr, n_rec = int(rest[0]), int(rest[1])
        if word == "begin":
            s["calls"] += 1
            assert n_tr <= 2000, "a call longer than EventSolver.chunk_periods"
            s["in_point"] += 1
        elif n_rec > 0:                   # the call that records: the point is done
            s["in_point"] = 0
            s["points"] += 1
    return st


def _wait(cond, p, what, timeout=HANG_S):
    """Poll ``cond()`` until true; the process ending first, or the hang guard, fails with ``what``."""
    t0 = time.monotonic()
    while True:
        v = cond()
        if v:
            return v
        if p.poll() is not None:
            raise AssertionError(f"the run ended (exit {p.returncode}) before {what}: {p.stderr.read()}")
        if time.monotonic() - t0 > timeout:
            raise AssertionError(f"hang guard: no {what} within {timeout:g} s")
        time.sleep(0.02)


def _workers_inside_long_points(p, marks):
    """Wait until two pool workers are both inside a point, in its first half (at least
    EARLY calls of 2000 periods still to run); returns their pids."""
    def ready():
        st = _state(_marks(marks), p.pid)
        inside = [w for w, s in st.items() if 0 < s["in_point"] <= EARLY]
        return sorted(inside) if len(st) == 2 and len(inside) == 2 else None

    return _wait(ready, p, "two workers in the first half of a point")


def _communicate(p):
    try:
        return p.communicate(timeout=HANG_S)
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        raise AssertionError(f"hang guard: the run did not stop within {HANG_S:g} s of the signal") from None


def _wait_dead(workers):
    """The workers ``(pid, start time)`` still alive after waiting for them to end (their pids).
    Hang guard: a worker that survives its parent stays alive for good (blocked on the pool's
    queue, as before the fix), so waiting HANG_S tells it from one that is merely being reaped."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < HANG_S and [w for w in workers if _alive(w)]:
        time.sleep(0.05)
    left = [w for w in workers if _alive(w)]
    for w in left:                               # do not leave them for the next test
        if _alive(w):
            os.kill(w[0], signal.SIGKILL)
    return [w[0] for w in left]


def _wait_for_lines(out, p, n=1, timeout=HANG_S):
    h5 = out / "results.h5"
    t0 = time.time()
    while time.time() - t0 < timeout and p.poll() is None:
        if (out / "results.h5.partial").exists():          # the checkpoint, beside results.h5
            try:
                if sum(len(v) for v in read_lines(h5)[1].values()) >= n:
                    return
            except OSError:
                pass
        time.sleep(0.05)
    raise AssertionError(f"no checkpoint within {timeout} s (exit {p.poll()})")


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupt_of_a_pool_stops_promptly_and_leaves_no_worker(tmp_path, sig, code):
    """The two workers are in the first half of a long point (>= 500 calls, seconds, still to
    run): after the main process's handler ran, neither finishes that point (they are
    terminated, not waited for: a few calls at most, measured 0), the run prints one line and no
    worker survives."""
    p, marks, out = _start(tmp_path, jobs=2)
    workers = _workers_inside_long_points(p, marks)
    kids = _children(p.pid)
    assert set(workers) <= set(kids), (workers, kids)
    p.send_signal(sig)
    _, err = _communicate(p)
    assert p.returncode == code, err
    lines = [l for l in err.splitlines() if l.strip() and not l.startswith("[slow-map]")]
    assert len(lines) == 1 and lines[0].startswith("vibeam: interrupted"), err
    _says_what_is_on_disk(lines[0], out)
    assert ("SIGTERM" in lines[0]) == (sig == signal.SIGTERM)
    rows = _marks(marks)
    at = [i for i, r in enumerate(rows) if r[0] == p.pid and r[1] == "handler"]
    assert len(at) == 1 and rows[at[0]][2] == [signal.Signals(sig).name], rows[-5:]
    before, after = _state(rows[:at[0]], p.pid), _state(rows[at[0]:], p.pid)
    for w in workers:
        # the scenario: the worker was inside a point with at least a tenth of it to run
        assert 0 < before[w]["in_point"] <= CALLS_PER_POINT * 9 // 10, before[w]
        s = after.get(w, dict(points=0, calls=0))
        print(f"{signal.Signals(sig).name}: worker {w} began {s['calls']} calls of 2000 periods after the "
              f"handler ran ({before[w]['in_point']} of {CALLS_PER_POINT} into its point)")
        assert s["points"] == 0, f"worker {w} finished its point after the interrupt: {s}"
    left = _wait_dead([kids[w] for w in workers])
    assert not left, f"a pool worker outlived the interrupt: {left}"


def _says_what_is_on_disk(line: str, out: Path) -> None:
    """The interrupt's line tells what the folder holds: the number of finished lines kept
    in the checkpoint results.h5.partial (and --resume) when it exists, and that no results file
    was written when there is none."""
    h5 = out / "results.h5"
    partial = out / "results.h5.partial"
    if partial.exists():
        n = sum(len(v) for v in read_lines(h5)[1].values())
        assert f"{n} finished sweep line" in line and f"kept in {partial};" in line and "--resume" in line, line
    else:
        assert "kept" not in line, line
    if not h5.exists():
        assert "no results file was written" in line, line


MAP_FAST = MAP.format(tp=20).replace("[14.0, 17.0, 6]", "[14.0, 17.0, 3]").replace("[0.5, 0.7, 6]", "[0.5, 0.7, 2]")


@pytest.mark.parametrize("old,finished", [(False, 0), (True, 0), (False, 1)])
def test_the_interrupt_message_says_what_is_on_disk(tmp_path, monkeypatch, capsys, old, finished):
    """Issue 19, item 13: Ctrl-C before any line finished printed "finished sweep lines are kept
    in DIR/results.h5" when no such file existed.  The line now says what is true: no results
    file was written; an old file is as it was (byte for byte); or how many finished lines the
    checkpoint keeps (and --resume).  The interrupt is injected deterministically: the sweep
    engine runs ``finished`` lines of the map (2 values x 2 directions), hands them to the
    checkpoint and raises KeyboardInterrupt, as Ctrl-C in the engine does."""
    from vibeam.engine import sweep
    from vibeam.cli import main

    real = sweep.run_lines

    def interrupted(lines, on_line=None, **kw):
        for line in list(lines)[:finished]:
            for key, rows in real([line]).items():
                on_line(line, rows)
        raise KeyboardInterrupt

    case = tmp_path / "map.toml"
    case.write_text(MAP_FAST)
    out = tmp_path / "out"
    if old:
        assert main(["map", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()} if old else {}
    capsys.readouterr()
    monkeypatch.setattr(sweep, "run_lines", interrupted)
    assert main(["map", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 130
    lines = [l for l in capsys.readouterr().err.splitlines() if l.strip() and not l.startswith("[")]
    assert len(lines) == 1 and lines[0].startswith("vibeam: interrupted (Ctrl-C)"), lines
    h5 = out / "results.h5"
    if old:
        assert lines[0].endswith(f"no sweep line had finished; {h5} is as it was"), lines[0]
        assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    elif finished:
        attrs, kept = read_lines(h5)
        assert not attrs["complete"] and sum(len(v) for v in kept.values()) == finished
        assert lines[0].endswith(f"no results file was written; {finished} finished sweep line is kept in "
                                 f"{h5}.partial; rerun with --resume to compute only the rest"), lines[0]
    else:
        assert lines[0].endswith("no sweep line had finished; no results file was written"), lines[0]
        # nothing on the disk: the folder this run made is removed again (before: left empty)
        assert not out.exists()
    if not old:
        _says_what_is_on_disk(lines[0], out)


def test_interrupt_of_an_inline_run_keeps_the_finished_lines(tmp_path):
    """--jobs 1 (lines in the main process, points of 10 calls): Ctrl-C after the first
    checkpoint stops the run at the kernel's next return -- no solver call begins after the
    handler ran (nothing catches the interrupt and goes on) -- and the file holds the
    finished lines."""
    p, marks, out = _start(tmp_path, jobs=1, tp=20000)
    _wait_for_lines(out, p)
    p.send_signal(signal.SIGINT)
    _, err = _communicate(p)
    assert p.returncode == 130, err
    lines = [l for l in err.splitlines() if l.strip() and not l.startswith("[slow-map]")]
    assert len(lines) == 1 and lines[0].startswith("vibeam: interrupted"), err
    _says_what_is_on_disk(lines[0], out)
    rows = _marks(marks)
    at = [i for i, r in enumerate(rows) if r[1] == "handler"]
    assert len(at) == 1 and rows[at[0]][0] == p.pid, rows[-5:]
    assert sum(r[1] == "begin" for r in rows[:at[0]]) > 10          # the run was inside its lines
    began = [r for r in rows[at[0]:] if r[1] == "begin"]
    assert not began, f"solver calls after the interrupt: {began}"
    attrs, kept = read_lines(out / "results.h5")
    assert not attrs["complete"] and sum(len(v) for v in kept.values()) >= 1
    # (`--resume` then computes only the rest: tests/test_map.py::test_kill_and_resume_gives_the_same_file)


def test_lines_finished_before_the_interrupt_are_kept(monkeypatch):
    """In the engine: lines that finished in the workers but were not yet collected when the
    interrupt arrived are handed to on_line (the checkpoint) before run_lines re-raises."""
    import concurrent.futures as cf
    from concurrent.futures import Future

    import numpy as np

    from vibeam.engine import sweep as sw
    from vibeam.models import make_solver
    from vibeam.models.builders.sdof import sdof  # lazy: as the imports above, the models load in this test only

    m = sdof(beta=0.015, B=0.5e-3, Delta=0.0, R=0.9)
    lines = sw.plan_lines(make_solver(m, "event"), sw.Sweep(Omega=np.array([1.9, 2.0]), direction="both",
                                                            transient_periods=10, record_periods=4))

    class Ex:
        """Every line finishes at once, but the wait for them is interrupted."""

        def submit(self, fn, line):
            f = Future()
            f.set_result(fn(line))
            return f

    def interrupted_wait(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(cf, "wait", interrupted_wait)
    seen = []
    with pytest.raises(KeyboardInterrupt):
        sw.run_lines(lines, executor=Ex(), on_line=lambda l, rows: seen.append(l.key))
    assert sorted(seen) == ["down", "up"]


def test_kill_9_of_the_main_process_leaves_no_worker(tmp_path):
    """``kill -9`` of the main process while both workers are in the first half of a long point:
    neither finishes that point (the kernel kills them with their parent: PR_SET_PDEATHSIG), and
    none is left alive."""
    p, marks, out = _start(tmp_path, jobs=2)
    workers = _workers_inside_long_points(p, marks)
    kids = _children(p.pid)
    assert set(workers) <= set(kids), (workers, kids)
    with open(marks, "a") as f:                  # where the kill falls among the markers
        f.write(f"{os.getpid()} kill -9\n")
    p.send_signal(signal.SIGKILL)
    p.wait()
    left = _wait_dead([kids[w] for w in workers])
    assert not left, f"workers still alive {HANG_S:g} s after kill -9 of their parent: {left}"
    rows = _marks(marks)
    at = [i for i, r in enumerate(rows) if r[1] == "kill"]
    assert len(at) == 1
    before, after = _state(rows[:at[0]], p.pid), _state(rows[at[0]:], p.pid)
    for w in workers:
        assert 0 < before[w]["in_point"] <= CALLS_PER_POINT * 9 // 10, before[w]
        s = after.get(w, dict(points=0, calls=0))
        print(f"kill -9: worker {w} began {s['calls']} calls of 2000 periods after the kill")
        assert s["points"] == 0, f"worker {w} finished its point after its parent was killed: {s}"
