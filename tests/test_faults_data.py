"""A full disk, a file-size limit or a read-only folder under every writer (issue 19, items 1, 4, 5).

The rule: whatever fails, the previous file stays in place byte for byte until its complete
successor is renamed over it (``vibeam.io.outdir.replace_file``), the command ends with one line
``vibeam: error: <file>: ...`` and exit 2, and no temporary file or lock is left behind.

The faults are made without root and without mounts: the writer runs in a child process under
``resource.setrlimit(RLIMIT_FSIZE, LIMIT)`` with SIGXFSZ ignored, so every write beyond
``LIMIT`` bytes fails with EFBIG exactly as on a full disk (ENOSPC; both are one ``OSError`` for
the writer).  ``LIMIT`` (2048 bytes) lets the lock file through (its JSON is ~300 bytes) and
stops every output: the smallest, ``modes.vtu`` of a 4-element beam, has 2.9 kB, a results
file 20-120 kB.  Before the fix the old ``results.h5`` was unlinked before the new one existed
(``runner.flush``), and HDF5 itself met the failing write: h5py printed dozens of
``RuntimeError`` tracebacks and the process died of a segmentation fault (exit -11/139),
leaving a ``.results-*.h5.tmp`` and the lock.  A read-only folder (mode 0555) is checked too
where it means something, i.e. when the tests do not run as root (root writes into it).

The old files are real ones: each command is first run without a limit (which also loads the
numba kernels and the font cache, so the limited child writes nothing but its outputs).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from vibeam.io.outdir import LOCK_NAME

LIMIT = 2048

TINY = """
name = "tiny"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = 0.72
gap_mm = 0.0
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [14.0, 17.0, 3]
direction = "both"
transient_periods = 30
record_periods = 8
[[run]]
name = "exact"
method = "event"
"""

# nondimensional Fig. 7 scene on 3 points (fit: R from its own FRC)
ND = """
name = "nd"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.0
[sweep]
Omega = [1.5, 2.5, 3]
direction = "up"
transient_periods = 200
record_periods = 16
[[run]]
name = "exact"
method = "event"
"""

# Fig. 8 scene, the period-1 branch from Omega = 1.5 to 2.5 (vibeam continue)
CONT = """
name = "cont"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.7e-3
[sweep]
Omega = [1.5, 2.5, 3]
direction = "both"
transient_periods = 300
record_periods = 16
[[run]]
name = "branches"
method = "continuation"
start_at = "low"
"""

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

# a map of 6 voltages x 6 frequencies x 2 directions = 12 lines of ~0.12 s each (chatter at the
# pre-stressed stop): ~1.5 s on a pool of 2 workers, whose first checkpoint comes 0.5 s into the run
MAP = """
name = "map"
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
transient_periods = 12000
record_periods = 16
[map]
parameter = "voltage"
values = [0.5, 0.7, 6]
[[run]]
name = "exact"
method = "event"
"""

CHILD = ("import resource, signal, sys\n"
         "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
         "n = int(sys.argv[1])\n"
         "if n > 0:\n"
         "    resource.setrlimit(resource.RLIMIT_FSIZE, (n, n))\n"
         "from vibeam.cli import main\n"
         "sys.exit(main(sys.argv[2:]))\n")

# command -> (case text, argv after the case, the files it writes)
WRITERS = {
    "run": (TINY, ["run", "{case}", "--out", "{out}", "--jobs", "1", "--quiet", "--no-plots"], ["results.h5"]),
    # the old results.h5 of the same case: its branches replaced in a copy (replace_branches)
    "continue": (CONT, ["continue", "{case}", "--out", "{out}", "--jobs", "1", "--quiet", "--no-plots"],
                 ["results.h5"]),
    # the case was edited (R) since the old run: a new file replaces the old (write_results)
    "continue-edited": (CONT, ["continue", "{case}", "--out", "{out}", "--jobs", "1", "--quiet", "--no-plots"],
                        ["results.h5"]),
    "fit": (ND, ["fit", "{case}", "--reference", "{ws}/nd.csv", "--params", "R", "--max-evaluations", "2",
                 "--out", "{out}", "--jobs", "1", "--quiet", "--no-plots"], ["fit.h5", "nd-fit.toml"]),
    "cost": (TINY, ["cost", "{case}", "--out", "{out}", "--repeats", "1", "--jobs", "1"],
             ["cost.h5", "work_precision.png"]),
    "modes": (BEAM, ["modes", "{case}", "--out", "{out}"], ["modes.vtu", "modes.png"]),
}


def _child(argv, limit=0, **kw):
    return subprocess.run([sys.executable, "-c", CHILD, str(limit), *argv], capture_output=True, text=True,
                          timeout=600, **kw)


def _snapshot(folder: Path) -> dict:
    """Every entry of a folder (hidden ones included) with its bytes."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _one_error_line(p) -> str:
    """Exit 2, no traceback, and stderr ends in exactly one ``vibeam:`` line, the error (the
    progress lines of the command before it aside)."""
    assert "Traceback" not in p.stderr and "HDF5" not in p.stderr, p.stderr[-3000:]
    assert p.returncode == 2, (p.returncode, p.stderr[-3000:])
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    ours = [l for l in lines if l.startswith("vibeam")]
    assert len(ours) == 1 and lines[-1] is ours[0] and ours[0].startswith("vibeam: error: "), p.stderr[-3000:]
    return ours[0]


def _readonly_means_something(folder: Path) -> bool:
    """Whether a 0555 folder refuses this process's writes (not so for root)."""
    probe = folder / ".probe"
    try:
        probe.write_bytes(b"")
    except OSError:
        return True
    probe.unlink()
    return False


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """Each writer's case file and its complete outputs of an unlimited run (the old files)."""
    d = tmp_path_factory.mktemp("faults")
    for name, (text, argv, files) in WRITERS.items():
        (d / f"{name}.toml").write_text(text)
    r = _child(["run", str(d / "fit.toml"), "--out", str(d / "nd-run"), "--jobs", "1", "--quiet", "--no-plots"])
    assert r.returncode == 0, r.stderr
    from vibeam.io.results import read_results

    run = read_results(d / "nd-run" / "results.h5")["runs"]["exact"]
    (d / "nd.csv").write_text("Omega,amplitude\n" + "".join(f"{float(o)!r},{float(a)!r}\n"
                                                          for o, a in zip(run["Omega"], run["amplitude"])))
    for name, (text, argv, files) in WRITERS.items():
        out = d / f"old-{name}"
        case = d / f"{name}.toml"
        if name == "continue-edited":
            case = d / "before-the-edit.toml"
            case.write_text(text.replace("R = 0.9", "R = 0.85"))
        r = _child([a.format(case=case, out=out, ws=d) for a in argv])
        assert r.returncode == 0, (name, r.stderr)
        assert sorted(p.name for p in out.iterdir()) == sorted(files), (name, list(out.iterdir()))
        assert all((out / f).stat().st_size > LIMIT for f in files if not f.endswith(".toml")), name
    return d


@pytest.mark.parametrize("writer", list(WRITERS))
def test_a_failed_write_keeps_the_old_files_byte_for_byte(ws, tmp_path, writer):
    """Rerun a command into a folder holding its complete outputs, under a file-size limit:
    exit 2 with one line naming the file, every old file byte for byte, no temporary file, no
    lock.  Then (as an ordinary user) the same folder made read-only: the same."""
    text, argv, files = WRITERS[writer]
    out = tmp_path / "out"
    shutil.copytree(ws / f"old-{writer}", out)
    before = _snapshot(out)
    argv = [a.format(case=ws / f"{writer}.toml", out=out, ws=ws) for a in argv]
    p = _child(argv, LIMIT)
    line = _one_error_line(p)
    print(f"{writer}: {line}")
    assert str(out) in line and "file too large" in line.lower(), line
    assert any(f in line for f in files), line
    assert _snapshot(out) == before, f"changed or left behind: {sorted(set(_snapshot(out)) ^ set(before))}"
    os.chmod(out, 0o555)
    try:
        if not _readonly_means_something(out):
            return                        # root: a 0555 folder is not read-only for it
        p = _child(argv)
        line = _one_error_line(p)
        assert str(out) in line and "cannot write" in line, line
        assert _snapshot(out) == before
    finally:
        os.chmod(out, 0o755)


def _children(pid: int) -> set[int]:
    out = set()
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.add(int(d.name))
    return out


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")


def test_a_failed_checkpoint_of_a_pooled_map_is_one_line_and_keeps_the_old_file(tmp_path):
    """`vibeam map --jobs 2` whose checkpoint fails while the two workers compute (the crash of
    the issue: a segmentation fault, 28 tracebacks, a temporary file and the lock left): one
    line, exit 2, the old complete file byte for byte, no temporary file, no lock, no worker
    left.  The scenario is asserted: the pool's two workers existed while the command ran (a
    pool starts only before the failure, which stops everything), so the checkpoint failed
    with the workers running."""
    case = tmp_path / "map.toml"
    case.write_text(MAP)
    out = tmp_path / "out"
    argv = ["map", str(case), "--out", str(out), "--jobs", "2", "--quiet", "--no-plots"]
    r = _child([a for a in argv if a != "--quiet"])   # it reads the run's report: --quiet drops it (issue 42)
    assert r.returncode == 0, r.stderr
    assert "pool of 2 workers" in r.stdout, r.stdout           # the map runs on the pool
    before = _snapshot(out)
    assert list(before) == ["results.h5"]
    p = subprocess.Popen([sys.executable, "-c", CHILD, str(LIMIT), *argv], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    seen: set = set()
    t0 = time.time()
    while p.poll() is None and time.time() - t0 < 300:
        seen |= _children(p.pid)
        time.sleep(0.01)
    _, err = p.communicate(timeout=60)
    done = subprocess.CompletedProcess(argv, p.returncode, "", err)
    line = _one_error_line(done)
    assert len(seen) >= 2, f"the pool never started (children seen: {seen}): make the map longer"
    assert "results.h5" in line and "file too large" in line.lower(), line
    assert _snapshot(out) == before
    time.sleep(0.5)
    assert not [w for w in seen if _alive(w)], "a worker outlived the failed map"


# ----------------------------------------------------------------------------- regress (item 4)
def test_regress_never_touches_the_results_of_a_run(tmp_path, monkeypatch, capsys):
    """`vibeam regress CASE --reference REF` without --results reruns the case in a temporary
    folder of its own: results/<case>/ of the user's `vibeam run` (a results file and a plot)
    stays byte for byte, nothing else appears in the working folder, and the temporary folder
    is gone afterwards.  The working folder is then made read-only (as an ordinary user): regress
    still runs (it needs no results/ folder).  Before, the rerun rewrote results/<case>/results.h5
    and left the old plots beside it."""
    from vibeam.cli import main

    (tmp_path / "tiny.toml").write_text(TINY)
    work = tmp_path / "work"
    (work / "results" / "tiny").mkdir(parents=True)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(tmp))
    monkeypatch.chdir(work)
    ref = tmp_path / "ref"
    assert main(["run", str(tmp_path / "tiny.toml"), "--out", str(ref), "--jobs", "1", "--quiet",
                 "--no-plots"]) == 0
    shutil.copy(ref / "results.h5", work / "results" / "tiny" / "results.h5")
    (work / "results" / "tiny" / "frc.png").write_bytes(b"the user's plot")
    before = {p: p.read_bytes() for p in work.rglob("*") if p.is_file()}
    capsys.readouterr()
    rc = main(["regress", str(tmp_path / "tiny.toml"), "--reference", str(ref / "results.h5"), "--jobs", "1"])
    out = capsys.readouterr().out
    assert rc == 0, out                     # the rerun of the same case reproduces the reference
    assert "regression of tiny" in out
    assert {p: p.read_bytes() for p in work.rglob("*") if p.is_file()} == before
    assert sorted(work.rglob("*")) == sorted([work / "results", work / "results" / "tiny", *before])
    assert list(tmp.iterdir()) == []
    for d in (work / "results" / "tiny", work / "results", work):
        os.chmod(d, 0o555)
    try:
        if not _readonly_means_something(work):
            return
        assert main(["regress", str(tmp_path / "tiny.toml"), "--reference", str(ref / "results.h5"),
                     "--jobs", "1"]) == 0
        assert {p: p.read_bytes() for p in work.rglob("*") if p.is_file()} == before
    finally:
        for d in (work, work / "results", work / "results" / "tiny"):
            os.chmod(d, 0o755)
