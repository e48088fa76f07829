"""Data that cannot be mixed, lost or silently substituted (issue 11): the output-folder lock,
the case identity of checkpointed lines, leftovers of killed writes, the work limit, name
collisions, requests off the grid, and a run whose every point fails."""
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from vibeam.case.schema import CaseError, InputError, parse_case
from vibeam.cli import main
from vibeam.io.outdir import LOCK_NAME, OutputLock
from vibeam.io.results import read_lines, read_results
from vibeam.runner import MAX_WORK_STEPS, check_work, run_case

CASE = """
name = "{name}"
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
record_periods = 8
[[run]]
name = "exact"
method = "event"
"""


def _case(name="a", gap=0.0, nf=4, tp=50):
    text = CASE.format(name=name, gap=gap, nf=nf, tp=tp)
    return parse_case(text), text


def _vibeam(*args):
    return [sys.executable, "-m", "vibeam.cli", *args]


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


# ----------------------------------------------------------------------------- the lock
def test_second_process_is_refused_with_the_folder_and_the_running_process(tmp_path):
    """Two different cases into one --out: the second refuses at once (exit 2, one line naming
    the folder and the first process), and the first finishes with only its own data."""
    out = tmp_path / "out"
    a = tmp_path / "a.toml"
    # a few seconds: every period integrated (a transient that recurs exactly would end early)
    a.write_text(CASE.format(name="a", gap=0.0, nf=6, tp=150000).replace('method = "event"',
                                                                         'method = "event"\nrecurrence = false'))
    b = tmp_path / "b.toml"
    b.write_text(CASE.format(name="b", gap=0.1, nf=6, tp=50))
    pa = subprocess.Popen(_vibeam("run", str(a), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"),
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while not (out / LOCK_NAME).exists() and time.time() - t0 < 60 and pa.poll() is None:
        time.sleep(0.02)
    pb = subprocess.run(_vibeam("run", str(b), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"),
                        capture_output=True, text=True)
    still_running = pa.poll() is None
    _, err_a = pa.communicate(timeout=300)
    assert still_running, "the first run ended before the second started: make it longer"
    assert pb.returncode == 2, pb.stderr
    lines = pb.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vibeam: error: "), pb.stderr
    assert str(out) in lines[0] and f"pid {pa.pid}" in lines[0] and "a.toml" in lines[0], lines[0]
    assert pa.returncode == 0, err_a
    r = read_results(out / "results.h5")
    assert r["attrs"]["case_name"] == "a" and r["attrs"]["complete"]
    assert not (out / LOCK_NAME).exists()          # released at the end


def test_stale_lock_of_a_dead_process_is_taken_over(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    dead = _dead_pid()
    (out / LOCK_NAME).write_text(json.dumps({"pid": dead, "host": socket.gethostname(), "started": "earlier",
                                             "command": "vibeam run old.toml"}))
    leftover = out / ".results-abc123.h5.tmp"         # a write killed half-way
    leftover.write_bytes(b"\0" * 100)
    case = tmp_path / "a.toml"
    case.write_text(CASE.format(name="a", gap=0.0, nf=3, tp=30))
    assert main(["run", str(case), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    err = capsys.readouterr().err
    assert f"stale lock" in err and f"pid {dead}" in err
    assert not leftover.exists()
    assert not (out / LOCK_NAME).exists()
    assert read_results(out / "results.h5")["attrs"]["complete"]


def test_lock_of_a_killed_holder_is_stale_and_a_live_one_refuses(tmp_path):
    """A holder killed with SIGKILL leaves its lock file, but the kernel drops its flock: the
    next process takes it over.  While a holder lives, another OutputLock refuses."""
    code = ("import sys, time; from vibeam.io.outdir import OutputLock\n"
            "l = OutputLock(sys.argv[1], command='holder').acquire(); print('held', flush=True); time.sleep(60)")
    p = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    with pytest.raises(InputError, match=rf"in use by another vibeam process \(pid {p.pid} on .*holder"):
        OutputLock(tmp_path).acquire()
    p.send_signal(signal.SIGKILL)
    p.wait()
    assert (tmp_path / LOCK_NAME).exists()
    with OutputLock(tmp_path) as lock:
        assert lock.stale["pid"] == p.pid
    assert not (tmp_path / LOCK_NAME).exists()


def _lock_refused(out, match, capsys, case_file):
    """`vibeam run` into ``out`` stops at the lock with one line matching ``match``, exit 2."""
    assert main(["run", str(case_file), "--out", str(out), "--jobs", "1", "--quiet", "--no-plots"]) == 2
    err = [l for l in capsys.readouterr().err.splitlines() if l.strip()]
    assert len(err) == 1 and err[0].startswith("vibeam: error: ") and match in err[0], err
    assert not (out / "results.h5").exists()


def test_the_lock_never_writes_through_a_link(tmp_path, capsys):
    """Issue 19, item 2: ``<out>/.vibeam.lock`` a symbolic link to another file (or a dangling
    one, or a hard link): the lock is refused with one line naming it, and the other file is
    neither written nor created.  Before, the run opened the link and overwrote its target
    with the lock's JSON (or created the target of a dangling link)."""
    case_file = tmp_path / "a.toml"
    case_file.write_text(CASE.format(name="a", gap=0.0, nf=3, tp=30))
    out = tmp_path / "out"
    out.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    (out / LOCK_NAME).symlink_to(victim)
    with pytest.raises(InputError, match=r"lock file .*\.vibeam\.lock is a symbolic link \(to .*victim\.txt\)"):
        OutputLock(out).acquire()
    _lock_refused(out, "is a symbolic link", capsys, case_file)
    assert victim.read_text() == "precious\n" and (out / LOCK_NAME).is_symlink()
    (out / LOCK_NAME).unlink()
    (out / LOCK_NAME).symlink_to(tmp_path / "elsewhere.txt")            # dangling
    _lock_refused(out, "is a symbolic link", capsys, case_file)
    assert not (tmp_path / "elsewhere.txt").exists()
    (out / LOCK_NAME).unlink()
    os.link(victim, out / LOCK_NAME)                                     # a second name of it
    _lock_refused(out, "is a hard link", capsys, case_file)
    assert victim.read_text() == "precious\n"
    (out / LOCK_NAME).unlink()
    with OutputLock(out) as lock:                                        # a plain folder: fine
        assert (out / LOCK_NAME).is_file() and json.loads((out / LOCK_NAME).read_text())["pid"] == os.getpid()
        assert not lock.stale
    assert not (out / LOCK_NAME).exists()


def test_modes_takes_the_output_lock(tmp_path, capsys):
    """Issue 19, item 14: `vibeam modes` into a folder another vibeam process holds is refused
    with one line naming the folder, like `run`, `fit` and `cost`, and writes nothing; before,
    it wrote modes.vtu and modes.png into a folder held by a running map."""
    beam = tmp_path / "beam.toml"
    beam.write_text(BEAM)
    out = tmp_path / "out"
    code = ("import sys, time; from vibeam.io.outdir import OutputLock\n"
            "l = OutputLock(sys.argv[1], command='vibeam map held.toml').acquire(); print('held', flush=True); "
            "time.sleep(120)")
    p = subprocess.Popen([sys.executable, "-c", code, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "held"
        assert main(["modes", str(beam), "--out", str(out), "-n", "2"]) == 2
        err = [l for l in capsys.readouterr().err.splitlines() if l.strip()]
        assert len(err) == 1 and "is in use by another vibeam process" in err[0] and f"pid {p.pid}" in err[0], err
        assert sorted(x.name for x in out.iterdir()) == [LOCK_NAME]
    finally:
        p.kill()
        p.wait()
    assert main(["modes", str(beam), "--out", str(out), "-n", "2"]) == 0      # once it is free
    assert {x.name for x in out.iterdir()} == {"modes.vtu", "modes.png"}


BEAM = """
name = "tinybeam"
[model]
fidelity = "beam"
length_mm = 180
sensor_position_mm = 100
mass_position_mm = 132
width_mm = 20
thickness_mm = 1
mass_kg = 0.1
R = 0.7
gap_mm = 0.0
gain = 5e-4
voltage = 0.6
n_modes = 2
n_elements = 4
[sweep]
frequency_hz = [14.0, 15.0, 2]
transient_periods = 10
record_periods = 4
[[run]]
name = "e"
method = "event"
"""


# ----------------------------------------------------------------------------- case identity
def _line(case, text, key):
    """The stacked datasets of one line of a case (computed)."""
    from vibeam import runner
    from vibeam.engine.sweep import run_lines, stack

    (job,) = runner._jobs(case)
    (line,) = [l for l in runner._lines(job) if l.key == key]
    rows = run_lines([line], jobs=1)[(line.run, line.key)]
    return stack(rows, job.sweep)


def _earlier_checkpoint(h5, lines: dict, name: str, text: str, case_json: str) -> None:
    """A checkpoint as vibeam wrote it before the results store (issue 41): the lines inside
    results.h5 itself (``/lines/<run>/<key>``, root ``complete = 0``)."""
    from vibeam.io.netcdf import write_group
    from vibeam.io.results import line_group
    from vibeam.io.store import build_file, root_attrs

    def fill(f):
        if "case_text" not in f.attrs:
            root_attrs(f, name, text, case_json, complete=False)
        for key, data in lines.items():
            write_group(f, f"lines/{key}", *line_group(data, case_json))

    build_file(h5, fill, h5 if h5.exists() else None)


def test_lines_of_another_case_are_never_kept(tmp_path):
    """The interleaving that used to give a 'complete' file with another case's down sweep:
    case A checkpoints its up line, process B (another case, same run name) appends its down
    line to the same file, then A resumes and keeps B's line.  Now B cannot write while A holds
    the folder (the results store holds the lock for the whole command: the tests of the lock
    above), a checkpoint is written only by a command that holds the store, and a line of
    another case found in a checkpoint is dropped and recomputed on resume."""
    from vibeam.io.store import Store

    a, ta = _case("a", gap=0.0)
    b, tb = _case("b", gap=0.1)
    h5 = tmp_path / "results.h5"
    ja, jb = a.model_dump_json(), b.model_dump_json()
    _earlier_checkpoint(h5, {"exact/up": _line(a, ta, "up")}, "a", ta, ja)
    b_down = _line(b, tb, "down")
    with pytest.raises(RuntimeError, match=r"only inside `with Store"):
        Store(tmp_path).checkpoint("lines", {}, "b", tb, jb)
    # bypass the store as an old vibeam would have: B's line lands in A's file
    with h5py.File(h5, "a") as f:
        g = f.create_group("lines/exact/down")
        for k, v in b_down.items():
            g.create_dataset(k, data=np.asarray([str(x) for x in v], dtype=h5py.string_dtype())
                             if np.asarray(v).dtype == object else v)
    assert sorted(read_lines(h5)[1]["exact"]) == ["down", "up"]
    assert sorted(read_lines(h5, case_json=ja)[1]["exact"]) == ["up"]      # only A's own line
    res = run_case(a, ta, tmp_path, jobs=1, quiet=True, plots=False, resume=True)[0]
    full = run_case(a, ta, tmp_path / "full", jobs=1, quiet=True, plots=False)[0]
    down = res.data["direction"] == "down"
    np.testing.assert_array_equal(res.data["amplitude"][down], full.data["amplitude"][down])
    assert not np.array_equal(res.data["amplitude"][down], b_down["amplitude"][::-1])
    attrs, lines = read_lines(h5)
    assert attrs["complete"] and lines == {}            # B's line is gone: the finished file is compacted
    stored = read_results(h5)["runs"]["exact"]
    np.testing.assert_array_equal(stored["amplitude"], full.data["amplitude"])


def _older_json(case) -> str:
    """The case JSON an earlier vibeam wrote: without the [[run]] key `recurrence` (added on
    2026-11-25, default true, which changes no output)."""
    d = json.loads(case.model_dump_json())
    for r in d["run"]:
        assert r.pop("recurrence") is True
    return json.dumps(d)


def test_resume_continues_a_file_of_an_earlier_vibeam_of_the_same_case(tmp_path, capsys):
    """A checkpoint written before a defaulted key existed is the same case once read now: the
    resumed run keeps its line (marked here by a wall time no run gives), computes the rest,
    and the file keeps its own case text.  A case that differs in a value is still refused, in
    one line naming the file, and the file is left as it was."""
    a, ta = _case("a", gap=0.0)
    old = _older_json(a)
    assert old != a.model_dump_json()
    h5 = tmp_path / "results.h5"
    up = _line(a, ta, "up")
    # (a wall time vibeam can write -- a negative one it never does, and --resume refuses it -- that no
    # point of this 3-point scene takes)
    up["wall_time_s"] = np.full_like(up["wall_time_s"], 1234.5)
    _earlier_checkpoint(h5, {"exact/up": up}, "a", ta, old)
    res = run_case(a, ta, tmp_path, jobs=1, quiet=True, plots=False, resume=True)[0]
    full = run_case(a, ta, tmp_path / "full", jobs=1, quiet=True, plots=False)[0]
    kept = res.data["direction"] == "up"
    assert np.all(res.data["wall_time_s"][kept] == 1234.5) and np.all(res.data["wall_time_s"][~kept] > 0)
    np.testing.assert_array_equal(res.data["amplitude"], full.data["amplitude"])
    stored = read_results(h5)
    assert stored["attrs"]["complete"] and stored["attrs"]["case_json"] == old
    np.testing.assert_array_equal(stored["runs"]["exact"]["amplitude"], full.data["amplitude"])
    # another case (gap 0.1) with the same older writer: refused, nothing touched
    b, tb = _case("a", gap=0.1)
    h5b = tmp_path / "b" / "results.h5"
    h5b.parent.mkdir()
    _earlier_checkpoint(h5b, {"exact/up": up}, "a", ta, old)
    before = h5b.read_bytes()
    with pytest.raises(InputError, match=r"^--resume: .*results\.h5 was written by another case or variant"):
        run_case(b, tb, h5b.parent, jobs=1, quiet=True, plots=False, resume=True)
    assert h5b.read_bytes() == before


def test_regress_takes_results_of_an_earlier_vibeam_of_the_same_case(tmp_path):
    """`vibeam regress --results` against a file whose stored case lacks a run key added since
    (at its default, no output changed): the same scene (its identity is the name, model,
    effects, mapped parameter and runs' names, methods and overrides), accepted; a file of a
    case with another gap is refused, naming the key and both values."""
    from vibeam.analysis.regress import check_results_of_case

    a, ta = _case("a", gap=0.0)
    run_case(a, ta, tmp_path, jobs=1, quiet=True, plots=False)
    h5 = tmp_path / "results.h5"
    with h5py.File(h5, "a") as f:
        f.attrs["case_json"] = _older_json(a)
    res = read_results(h5)
    assert res["attrs"]["case_json"] != a.model_dump_json()
    check_results_of_case(a, res, h5)
    b, _ = _case("a", gap=0.1)
    with pytest.raises(InputError, match=r"written by another case \('model.gap_mm' = 0.0 in the file, 0.1"):
        check_results_of_case(b, res, h5)


# ----------------------------------------------------------------------------- work limit
@pytest.mark.parametrize("old,new,key", [
    ("transient_periods = 50", "transient_periods = 1000000000000", "sweep.transient_periods"),
    ("frequency_hz = [14.0, 17.0, 4]", "frequency_hz = [1e-9, 1e-9, 1]", "sweep.frequency_hz"),
    ("record_periods = 8", "record_periods = 100000000", "sweep.record_periods"),
])
def test_unbounded_work_is_refused_naming_the_key(tmp_path, capsys, monkeypatch, old, new, key):
    case_text = CASE.format(name="a", gap=0.0, nf=4, tp=50)
    assert old in case_text
    f = tmp_path / "big.toml"
    f.write_text(case_text.replace(old, new))
    # refused up front, nothing simulated: no call of the solver (method "event" on the SDOF is
    # EventSolver, inline with --jobs 1), which the same count sees for the case as it was
    from vibeam.models import EventSolver

    calls = []
    inner = EventSolver.point
    monkeypatch.setattr(EventSolver, "point", lambda self, *a, **k: calls.append(a) or inner(self, *a, **k))
    ok = tmp_path / "ok.toml"
    ok.write_text(case_text)
    assert main(["run", str(ok), "--out", str(tmp_path / "ok"), "--jobs", "1", "--quiet", "--no-plots"]) == 0
    assert len(calls) >= 8                        # 4 frequencies x 2 directions
    capsys.readouterr()
    calls.clear()
    assert main(["run", str(f), "--out", str(tmp_path / "out"), "--jobs", "1", "--quiet"]) == 2
    assert calls == []
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("vibeam: error: ") and f"'{key}'" in err[0], err
    assert "--force" in err[0] or "record fewer" in err[0]
    assert not (tmp_path / "out" / "results.h5").exists()
    case = parse_case(case_text.replace(old, new))
    check_work(case, force=True)                  # --force lets it through


def test_work_estimate_of_the_shipped_cases_is_below_the_limit():
    from vibeam.case.schema import load_case
    from vibeam.runner import estimate_work

    root = Path(__file__).parent.parent / "cases"
    for name in ("rig-map-gap", "paper-fig7-methods", "rig-fe-neutral"):
        case, _ = load_case(root / f"{name}.toml")
        w = estimate_work(case)
        assert 1e5 < w["steps"] < MAX_WORK_STEPS / 10, (name, w)


# ----------------------------------------------------------------------------- names
def test_run_names_that_give_one_file_name_are_refused():
    _, text = _case()
    two = text + '[[run]]\nname = "{}"\nmethod = "event"\n'
    for first, second in (("a b", "a_b"), ("Up", "up")):
        t = text.replace('name = "exact"', f'name = "{first}"') + \
            f'[[run]]\nname = "{second}"\nmethod = "event"\n'
        with pytest.raises(CaseError, match="give the same file name"):
            parse_case(t, "x.toml")
    parse_case(two.format("agreement"))           # "agreement" is fine: see the next test


@pytest.mark.parametrize("name", [".", "..", "..."])
def test_a_case_name_never_leaves_the_results_folder(tmp_path, monkeypatch, capsys, name):
    """Issue 19, item 3: the output folder is results/<name>; ``name = ".."`` wrote results.h5,
    plots and the lock into the working folder (overwriting what was there) and ``"."`` into
    results/ itself.  A name of dots only is refused in one line naming the key and the value,
    and nothing is written; the folder derivation refuses such a name too (for a case built
    without validation)."""
    with pytest.raises(CaseError, match=rf"'name' = '{re.escape(name)}': a case name of dots only"):
        parse_case(CASE.format(name=name, gap=0.0, nf=3, tp=30), "x.toml")
    work = tmp_path / "work"
    work.mkdir()
    (work / "x.toml").write_text(CASE.format(name=name, gap=0.0, nf=3, tp=30))
    monkeypatch.chdir(work)
    assert main(["run", "x.toml", "--jobs", "1", "--quiet", "--no-plots"]) == 2
    err = [l for l in capsys.readouterr().err.splitlines() if l.strip()]
    assert len(err) == 1 and err[0].startswith("vibeam: error: x.toml: 'name'"), err
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["work", "x.toml"]
    from vibeam.io.outdir import default_folder

    with pytest.raises(InputError, match="outside results/"):
        default_folder(name)
    assert default_folder("a.b", "-quick") == Path("results") / "a.b-quick"


def test_agreement_plot_never_collides_with_a_run(tmp_path):
    """A map with runs 'agreement' and 'other': three distinct plots."""
    text = CASE.format(name="m", gap=-0.1, nf=3, tp=20).replace('name = "exact"', 'name = "agreement"')
    text += '[[run]]\nname = "other"\nmethod = "event"\n[run.model]\nR = 0.6\n'
    text += '[map]\nparameter = "voltage"\nvalues = [0.4, 0.6, 2]\n'
    run_case(parse_case(text), text, tmp_path, jobs=1, quiet=True, plots=True)
    pngs = sorted(p.name for p in tmp_path.glob("*.png"))
    assert pngs == ["map_agreement.png", "map_other.png", "maps_agreement.png"], pngs


def test_time_series_off_the_grid_is_refused_and_labels_are_grid_points(tmp_path):
    _, text = _case(nf=4)                     # 14, 15, 16, 17 Hz
    with pytest.raises(CaseError, match=r"'assess.time_series\[0\]' = 20: outside the sweep's grid; "
                                        r"allowed: 14 \.\.\. 17 Hz"):
        parse_case(text + "[assess]\ntime_series = [20.0]\n", "x.toml")
    with pytest.raises(CaseError, match=r"'assess.time_series\[1\]' = 15.2: on the same grid point \(15 Hz\)"):
        parse_case(text + "[assess]\ntime_series = [15.0, 15.2]\n", "x.toml")
    t = text + "[assess]\ntime_series = [15.4]\n"     # inside the grid, recorded at 15 Hz
    run_case(parse_case(t), t, tmp_path, jobs=1, quiet=True, plots=True)
    with h5py.File(tmp_path / "results.h5") as f:
        assert sorted(f["runs/exact/time_series"]) == ["15"]       # the label of what was simulated
    ts = read_results(tmp_path / "results.h5")["runs"]["exact"]["time_series"]["15"]
    assert ts["up_Omega"] * 7.6 == pytest.approx(15.0)
    assert (tmp_path / "time_series_15.png").exists() and not (tmp_path / "time_series_15.4.png").exists()


def test_nondimensional_tables_have_no_physical_units(capsys):
    from vibeam.engine.assess import print_hfc
    from vibeam.engine.sweep import SweepResult

    d = {"Omega": np.array([2.0]), "band_velocity_mm_s": np.array([1.0]), "band_frequency": np.array([7.0]),
         "peaks_frequency": np.full((1, 5), np.nan)}
    print_hfc([SweepResult("r", "sdof", "event", {}, d, 0.0)])
    out = capsys.readouterr().out
    assert "Hz" not in out and "mm" not in out
    d["frequency_hz"] = d["Omega"] * 7.6
    print_hfc([SweepResult("r", "sdof", "event", {}, d, 0.0)])
    assert "(Hz)" in capsys.readouterr().out


# ----------------------------------------------------------------------------- all points fail
def test_every_point_failed_still_writes_the_file_and_plots_and_exits_3(tmp_path, monkeypatch, capsys):
    """Every point fails (e.g. a broken kernel): a valid results file with the failures, an FRC
    that marks them, one summary line and exit code 3 -- not `KeyError: 'amplitude'`."""
    from vibeam import runner
    from vibeam.testing import FailingSolver

    orig = runner._job

    def failing(case, r, overrides, j=None):
        job = orig(case, r, overrides, j)
        job.solver = FailingSolver(job.solver, list(job.sweep.Omega))
        return job

    monkeypatch.setattr(runner, "_job", failing)
    f = tmp_path / "a.toml"
    f.write_text(CASE.format(name="a", gap=0.0, nf=3, tp=20))
    out = tmp_path / "out"
    assert main(["run", str(f), "--out", str(out), "--jobs", "1", "--quiet"]) == 3
    err = [l for l in capsys.readouterr().err.splitlines() if l.startswith("vibeam:")]
    assert len(err) == 1 and "every point failed (6 points)" in err[0] and "injected numerical failure" in err[0]
    r = read_results(out / "results.h5")
    run = r["runs"]["exact"]
    assert r["attrs"]["complete"] and (run["status"] == "failed").all() and np.isnan(run["amplitude"]).all()
    assert "amplitude_mm" in run
    from test_plots import assert_png_shows_results      # red crosses at the file's 6 failed points
    assert_png_shows_results(out / "frc.png", out / "results.h5", "frc")
