"""One results store that no command can damage (issue 41).

Every command writes ``results.h5`` through :class:`vibeam.io.store.Store`: the folder's lock for
the whole command, the successor built from the old file with every group kept (a group of
another case marked stale, never dropped), checkpoints in ``results.h5.partial`` beside the
complete file, only regular files written, never a file the command reads.  Each test here
reproduces one of the issue's measurements on main (6b53e11) and fails there (checked: see
tests/README.md, "The results store"); interrupts are injected in the sweep engine as Ctrl-C
arrives there (``KeyboardInterrupt`` after a given number of finished lines), file-size limits
by ``RLIMIT_FSIZE`` in a child process, as tests/test_faults_data.py does.
"""
from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from vibeam.cli import main
from vibeam.engine.sweep import run_lines as RUN_LINES
from vibeam.io.results import read_lines, read_results

# a map of 2 values x 3 frequencies x 2 directions: 4 lines of 3 points, about 0.1 s in all
MAP = """
name = "smap"
description = "a small map"
[model]
fidelity = "sdof"
natural_frequency_hz = 7.6
damping_ratio = 0.017
R = {R}
gap_mm = -0.05
length_mm = 180.0
gain = 5.16e-4
voltage = 0.6
[sweep]
frequency_hz = [14.0, 17.0, 3]
direction = "both"
transient_periods = 20
record_periods = 16
[map]
parameter = "voltage"
values = [0.5, 0.7, 2]
[[run]]
name = "exact"
method = "event"
"""

# the Fig. 8 scene on 3 points, a sweep, a continuation of its period-1 branch and basins
SCENE = """
name = "scene"
description = "{description}"
[model]
fidelity = "sdof"
beta = 0.015
B = 0.5e-3
R = 0.9
Delta = 0.7e-3
[sweep]
Omega = [1.5, 2.5, 3]
direction = "both"
transient_periods = 100
record_periods = 16
[basins]
Omega = 2.0
grid = [4, 3]
lyapunov_periods = 0
record_periods = 8
[[run]]
name = "exact"
method = "event"
[[run]]
name = "branches"
method = "continuation"
start_at = "low"
"""

QUIET = ["--jobs", "1", "--quiet", "--no-plots"]

# the child checkpoints after every finished line when asked (argv[2] = "1"): run_case's
# interval (0.5 s) would make which lines share a checkpoint depend on the machine's speed
CHILD = ("import resource, signal, sys\n"
         "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
         "n = int(sys.argv[1])\n"
         "if sys.argv[2] == '1':\n"
         "    import inspect, vibeam.runner as r\n"
         "    names = list(inspect.signature(r.run_case).parameters)\n"
         "    d = list(r.run_case.__defaults__)\n"
         "    d[names.index('checkpoint_interval_s') - (len(names) - len(d))] = 0.0\n"
         "    r.run_case.__defaults__ = tuple(d)\n"
         "if n > 0:\n"
         "    resource.setrlimit(resource.RLIMIT_FSIZE, (n, n))\n"
         "from vibeam.cli import main\n"
         "sys.exit(main(sys.argv[3:]))\n")


def _child(argv, limit=0, every_line=False):
    return subprocess.run([sys.executable, "-c", CHILD, str(limit), "1" if every_line else "0", *argv],
                          capture_output=True, text=True, timeout=600)


def _snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def _write(tmp_path, name, text) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _interrupt_after(monkeypatch, finished: int):
    """The sweep engine finishes ``finished`` lines, hands them to the checkpoint and raises
    KeyboardInterrupt, as Ctrl-C in the engine does (tests/test_interrupts.py)."""
    from vibeam.engine import sweep

    real = RUN_LINES

    def interrupted(lines, on_line=None, **kw):
        for line in list(lines)[:finished]:
            for key, rows in real([line]).items():
                if on_line is not None:            # a continuation run keeps its rows in memory
                    on_line(line, rows)
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep, "run_lines", interrupted)
    return real


def _groups(h5) -> dict:
    """``{unit path: (attrs, {dataset: bytes})}`` of a results file: what a kept group must keep."""
    out = {}
    with h5py.File(h5, "r") as f:
        units = {}
        for top, g in f.items():
            if not isinstance(g, h5py.Group) or top in ("lines", "basin_lines"):
                continue
            if top in ("runs", "maps", "branches", "basins"):
                units.update({f"{top}/{k}": v for k, v in g.items() if isinstance(v, h5py.Group)})
            else:
                units[top] = g
        for p, g in units.items():
            data = {}

            def visit(name, obj):
                if isinstance(obj, h5py.Dataset):
                    v = obj[()]
                    data[name] = v.tobytes() if isinstance(v, np.ndarray) and v.dtype != object else repr(v)
            g.visititems(visit)
            out[p] = (dict(g.attrs), data)
    return out


# ----------------------------------------------------------------------------- item 1
def test_an_interrupted_rerun_leaves_the_complete_file_byte_for_byte(tmp_path, monkeypatch, capsys):
    """A complete map in D, the same map again into D, Ctrl-C after one finished line: before,
    the file then held only ``/lines`` with complete = 0; now results.h5 is byte for byte the
    complete map, the finished line is in results.h5.partial, and --resume computes only the
    other three lines and gives the same map."""
    case = _write(tmp_path, "smap.toml", MAP.format(R=0.72))
    out = tmp_path / "D"
    assert main(["map", str(case), "--out", str(out), *QUIET]) == 0
    before = (out / "results.h5").read_bytes()
    real = _interrupt_after(monkeypatch, 1)
    assert main(["map", str(case), "--out", str(out), *QUIET]) == 130
    err = capsys.readouterr().err
    assert (out / "results.h5").read_bytes() == before
    assert f"{out / 'results.h5'} is as it was" in err and "1 finished sweep line is kept in" in err, err
    attrs, lines = read_lines(out / "results.h5")
    assert not attrs["complete"] and sum(len(v) for v in lines.values()) == 1
    calls = []
    from vibeam.engine import sweep

    def counted(lines, **kw):
        calls.extend(lines)
        return real(lines, **kw)

    monkeypatch.setattr(sweep, "run_lines", counted)
    assert main(["map", str(case), "--out", str(out), "--resume", *QUIET]) == 0
    assert len(calls) == 3
    assert not (out / "results.h5.partial").exists()
    a, b = read_results(out / "results.h5")["maps"]["exact"], read_results(tmp_path / "D" / "results.h5")["maps"]["exact"]
    fresh = tmp_path / "E"
    monkeypatch.setattr(sweep, "run_lines", real)
    assert main(["map", str(case), "--out", str(fresh), *QUIET]) == 0
    c = read_results(fresh / "results.h5")["maps"]["exact"]
    np.testing.assert_array_equal(a["amplitude"], c["amplitude"])
    np.testing.assert_array_equal(a["classification"], c["classification"])



def _line_bytes(partial) -> dict:
    """``{dataset path below /lines: bytes}`` of a checkpoint (what a kept line must keep)."""
    out = {}
    with h5py.File(partial, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                v = obj[()]
                out[name] = v.tobytes() if isinstance(v, np.ndarray) and v.dtype != object else repr(v)
        f["lines"].visititems(visit)
    return out


def test_an_interrupted_resume_keeps_the_stored_lines_byte_for_byte(tmp_path, monkeypatch, capsys):
    """A map (4 lines) interrupted after 1 line, resumed and interrupted again after 1 more, then
    resumed to the end: the second checkpoint holds the first line's datasets byte for byte (read
    with h5py) beside the new line's, each resume computes only the lines missing (counted where
    the engine is called: 1 before its interrupt, then 2), and the finished map equals a map run
    in one go (the oracle: the same case computed without any checkpoint)."""
    from vibeam.engine import sweep

    case = _write(tmp_path, "smap.toml", MAP.format(R=0.72))
    out = tmp_path / "D"
    real = _interrupt_after(monkeypatch, 1)
    assert main(["map", str(case), "--out", str(out), *QUIET]) == 130
    partial = out / "results.h5.partial"
    first = _line_bytes(partial)
    n_first = len(read_lines(partial)[1]["exact"])
    assert n_first == 1 and first
    calls = []

    def counted(lines, **kw):
        calls.append(len(list(lines)))
        return real(lines, **kw)

    _interrupt_after(monkeypatch, 1)                # the resume is interrupted after 1 more line
    wrapped = sweep.run_lines

    def counted_interrupted(lines, **kw):
        lines = list(lines)
        calls.append(len(lines))
        return wrapped(lines, **kw)

    monkeypatch.setattr(sweep, "run_lines", counted_interrupted)
    assert main(["map", str(case), "--out", str(out), "--resume", *QUIET]) == 130
    assert calls == [3]                              # the 3 missing lines handed to the engine
    second = _line_bytes(partial)
    assert len(read_lines(partial)[1]["exact"]) == 2
    kept = {k: v for k, v in second.items() if k in first}
    assert kept == first, sorted(set(first) - set(second))
    calls.clear()
    monkeypatch.setattr(sweep, "run_lines", counted)
    assert main(["map", str(case), "--out", str(out), "--resume", *QUIET]) == 0
    assert calls == [2] and not partial.exists()
    capsys.readouterr()
    monkeypatch.setattr(sweep, "run_lines", real)
    fresh = tmp_path / "E"
    assert main(["map", str(case), "--out", str(fresh), *QUIET]) == 0
    a = read_results(out / "results.h5")["maps"]["exact"]
    c = read_results(fresh / "results.h5")["maps"]["exact"]
    for k in ("amplitude", "classification", "impacts_per_period"):
        np.testing.assert_array_equal(a[k], c[k])


def _map8(R: float, name: str) -> str:
    """The map with 4 values: 8 sweep lines."""
    return (MAP.format(R=R).replace('name = "smap"', f'name = "{name}"')
            .replace("values = [0.5, 0.7, 2]", "values = [0.5, 0.7, 4]"))


def test_a_rerun_of_another_case_under_a_file_size_limit_keeps_the_complete_file(tmp_path):
    """Another case into D under a file-size limit that lets its first checkpoints through but
    not its complete file: before, the complete map was replaced by the new case's checkpoint
    and the command exited 2; now the command exits 2 with one line and results.h5 is byte for
    byte."""
    case = _write(tmp_path, "smap.toml", _map8(0.72, "smap"))
    other = _write(tmp_path, "other.toml", _map8(0.6, "other"))
    out = tmp_path / "D"
    r = _child(["map", str(case), "--out", str(out), *QUIET])
    assert r.returncode == 0, r.stderr
    before = (out / "results.h5").read_bytes()
    # a checkpoint after every line: the first (one line, ~60 kB: the datasets' headers) fits,
    # the later ones and the complete file of 8 lines (~66 kB) do not
    assert len(before) > 64_000
    r = _child(["map", str(other), "--out", str(out), *QUIET], limit=64_000, every_line=True)
    assert r.returncode == 2, r.stderr[-2000:]
    assert "Traceback" not in r.stderr and "file too large" in r.stderr.lower(), r.stderr[-2000:]
    assert (out / "results.h5").read_bytes() == before
    # the scenario: a checkpoint of the other case was written (beside the complete file)
    assert read_lines(out / "results.h5")[0]["case_name"] == "other"


# ----------------------------------------------------------------------------- item 2
def test_basins_take_the_output_lock(tmp_path):
    """A `vibeam basins` into a folder that another vibeam holds is refused in one line (before:
    it never took the lock and both commands wrote D/results.h5, which kept only one's groups)."""
    from vibeam.io.outdir import OutputLock

    case = _write(tmp_path, "scene.toml", SCENE.format(description="a"))
    out = tmp_path / "D"
    code = ("import sys, time; from vibeam.io.outdir import OutputLock\n"
            "l = OutputLock(sys.argv[1], command='vibeam map').acquire(); print('held', flush=True); time.sleep(60)")
    p = subprocess.Popen([sys.executable, "-c", code, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "held"
        r = _child(["basins", str(case), "--out", str(out), *QUIET])
        assert r.returncode == 2, r.stderr[-2000:]
        lines = [l for l in r.stderr.splitlines() if l.strip()]
        assert lines[-1].startswith("vibeam: error: ") and "in use by another vibeam process" in lines[-1], lines
    finally:
        p.kill()
        p.wait()
    assert not (out / "results.h5").exists()
    del OutputLock


def test_run_holds_the_lock_through_its_basins(tmp_path, monkeypatch):
    """`vibeam run` of a case with [basins] computes the basins while it still holds the folder
    (before: the lock was released after the sweeps, so another command could write between)."""
    from vibeam.analysis import attractors
    from vibeam.io.outdir import holds_lock

    case = _write(tmp_path, "scene.toml", SCENE.format(description="a"))
    out = tmp_path / "D"
    seen = []
    real = attractors.compute

    def compute(*a, **k):
        seen.append(holds_lock(out))
        return real(*a, **k)

    monkeypatch.setattr(attractors, "compute", compute)
    assert main(["run", str(case), "--out", str(out), *QUIET]) == 0
    assert seen == [True]
    assert not holds_lock(out)


# ----------------------------------------------------------------------------- item 3
def test_continue_after_an_edit_keeps_the_sweeps_marked_stale(tmp_path, capsys):
    """`vibeam run`, then the case's description edited, then `vibeam continue`: before, /runs was
    emptied without a word (exit 0); now the sweeps are kept byte for byte, marked stale with
    their own case text, and the command says so in one line."""
    case = _write(tmp_path, "scene.toml", SCENE.format(description="a"))
    out = tmp_path / "D"
    assert main(["run", str(case), "--out", str(out), *QUIET]) == 0
    old = _groups(out / "results.h5")
    assert {"runs/exact", "branches/branches", "basins/exact"} <= set(old)
    case.write_text(SCENE.format(description="edited"))
    capsys.readouterr()
    assert main(["continue", str(case), "--out", str(out), *QUIET]) == 0
    err = capsys.readouterr().err
    new = _groups(out / "results.h5")
    for p in ("runs/exact", "basins/exact"):
        attrs, data = new[p]
        assert data == old[p][1], p                          # the data as they were
        assert attrs["stale"] == 1 and "another case text" in str(attrs["stale_reason"])
        assert 'description = "a"' in str(attrs["case_text"])
    assert "stale" not in new["branches/branches"][0]
    assert "marked stale" in err and "runs/exact" in err and "basins/exact" in err, err
    # the note names the groups, and says "and N more" only past 6 (a cosmic-ray mutant said
    # "and -4 more" of 2 groups and survived)
    note = next(l for l in err.splitlines() if "marked stale" in l)
    assert "keeps 2 group(s)" in note and "more" not in note, note
    with h5py.File(out / "results.h5") as f:
        assert 'description = "edited"' in str(f.attrs["case_text"])


def test_a_rerun_keeps_the_basins_of_the_unchanged_case(tmp_path):
    """`vibeam run --no-plots` twice (the second time on a case without [basins]... of the same
    scene): before, the second run rewrote results.h5 without /basins; now /basins stays, and it is
    stale only when the case changed."""
    case = _write(tmp_path, "scene.toml", SCENE.format(description="a"))
    out = tmp_path / "D"
    assert main(["run", str(case), "--out", str(out), *QUIET]) == 0
    first = _groups(out / "results.h5")
    assert main(["continue", str(case), "--out", str(out), *QUIET]) == 0
    # the same case without its basins step (vibeam.run basins=False): the basins of the file stay
    import vibeam

    vibeam.run(case, out=out, jobs=1, basins=False)
    again = _groups(out / "results.h5")
    assert again["basins/exact"][1] == first["basins/exact"][1]
    assert "stale" not in again["basins/exact"][0] and "stale" not in again["runs/exact"][0]


def test_fresh_starts_a_new_file(tmp_path):
    case = _write(tmp_path, "scene.toml", SCENE.format(description="a"))
    other = _write(tmp_path, "smap.toml", MAP.format(R=0.72))
    out = tmp_path / "D"
    assert main(["map", str(other), "--out", str(out), *QUIET]) == 0
    assert main(["run", str(case), "--out", str(out), "--fresh", *QUIET]) == 0
    assert "maps/exact" not in _groups(out / "results.h5")
    assert main(["run", str(case), "--out", str(out), "--fresh", "--resume", *QUIET]) == 2


# ----------------------------------------------------------------------------- item 4
def test_regress_never_writes_into_its_reference(tmp_path, capsys):
    """`vibeam regress --reference D/results.h5 --out D --quick` overwrote its own reference (41
    points -> 11, exit 0); now it is refused in one line (exit 2) and the reference is byte for
    byte."""
    case = _write(tmp_path, "smap.toml", MAP.format(R=0.72).replace("[map]", "[unused]")
                  .replace('parameter = "voltage"\nvalues = [0.5, 0.7, 2]\n', ""))
    case.write_text(case.read_text().replace("[unused]\n", ""))
    out = tmp_path / "D"
    assert main(["run", str(case), "--out", str(out), *QUIET]) == 0
    before = (out / "results.h5").read_bytes()
    capsys.readouterr()
    rc = main(["regress", str(case), "--reference", str(out / "results.h5"), "--out", str(out), "--jobs", "1"])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "never writes into a file it reads" in err and "--reference" in err, err
    assert (out / "results.h5").read_bytes() == before


# ----------------------------------------------------------------------------- item 5
def test_default_folders_of_a_case_and_its_quick_variant_differ(tmp_path, monkeypatch):
    """`vibeam run qq.toml --quick` and `vibeam run qq-quick.toml` both wrote results/qq-quick/."""
    from argparse import Namespace

    from vibeam.case.schema import parse_case
    from vibeam.cli import _out_dir

    qq = parse_case(MAP.format(R=0.7).replace('name = "smap"', 'name = "qq"'))
    qq_quick = parse_case(MAP.format(R=0.7).replace('name = "smap"', 'name = "qq-quick"'))
    a = _out_dir(Namespace(out=None, quick=True), qq)
    b = _out_dir(Namespace(out=None, quick=False), qq_quick)
    assert a != b and a.parent == b.parent == Path("results")


# ----------------------------------------------------------------------------- item 6
def _special_files(tmp_path) -> dict:
    """A named pipe, a symbolic link, a folder and (where allowed) a character device like
    /dev/null, each in tmp_path: what a write must never replace."""
    out = {}
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    out["fifo"] = fifo
    target = tmp_path / "target.txt"
    target.write_text("keep me")
    link = tmp_path / "link.toml"
    link.symlink_to(target)
    out["symlink"] = link
    folder = tmp_path / "a-folder"
    folder.mkdir()
    out["folder"] = folder
    dev = tmp_path / "null"
    try:
        os.mknod(dev, stat.S_IFCHR | 0o666, os.makedev(1, 3))
        out["char-device"] = dev
    except (PermissionError, OSError):
        pass
    return out


def _kind(p: Path) -> int:
    return stat.S_IFMT(os.lstat(p).st_mode)


@pytest.mark.parametrize("writer", ["derive", "plot", "replace_file"])
def test_writes_never_replace_devices_pipes_links_or_folders(tmp_path, writer, capsys):
    """`vibeam derive ... --write /dev/null` as root replaced /dev/null with a regular file; the
    same for a named pipe or a device given to any writer.  Now each is refused in one line and
    stays what it was."""
    from vibeam.errors import InputError
    from vibeam.io.outdir import replace_file

    special = _special_files(tmp_path)
    res = None
    if writer == "plot":
        import vibeam

        res = vibeam.open_results("tests/references/paper-fig7.h5")
    for kind, p in special.items():
        mode = _kind(p)
        if writer == "derive":
            rc = main(["derive", "cases/rig-fe-tight.toml", "--write", str(p)])
            err = capsys.readouterr().err
            assert rc == 2, (kind, err)
            assert err.count("\n") == 1 and str(p) in err, err
        elif writer == "plot":
            with pytest.raises(InputError, match=str(p)):
                res.plot_frc(path=p)
        else:
            with pytest.raises(InputError, match=r"not a regular file|not a file|symbolic link"):
                replace_file(p, "text")
        assert _kind(p) == mode, kind
    assert (tmp_path / "target.txt").read_text() == "keep me"
    assert not [q for q in tmp_path.iterdir() if q.name.startswith(".vibeam-tmp-")]


def test_a_results_file_that_is_a_link_or_a_fifo_is_refused_before_computing(tmp_path, capsys):
    case = _write(tmp_path, "smap.toml", MAP.format(R=0.72))
    out = tmp_path / "D"
    out.mkdir()
    os.mkfifo(out / "results.h5")
    assert main(["map", str(case), "--out", str(out), *QUIET]) == 2
    err = capsys.readouterr().err
    assert "results.h5: is a named pipe" in err, err
    assert stat.S_ISFIFO(os.lstat(out / "results.h5").st_mode)


# ----------------------------------------------------------------------------- item 7
def _tamper_line(name):
    """How each tampering changes one checkpointed line group ``g`` (h5py) of results.h5.partial."""
    def nan_ok(g):
        a = g["amplitude"][()]
        a[0] = np.nan
        g["amplitude"][...] = a
        st = g["status"].asstr()[()]
        st[0] = "ok"
        g["status"][...] = st.astype(object)

    def replace(key, data, **kw):
        def f(g):
            del g[key]
            g.create_dataset(key, data=data, **kw)
        return f

    def soft_loop(g):
        g["loop"] = h5py.SoftLink(g.name + "/loop")

    def external(g):
        g["ext"] = h5py.ExternalLink("/nonexistent/elsewhere.h5", "/x")

    def bomb(g):
        g.create_dataset("bomb", shape=(2 ** 37,), chunks=(1 << 16,), dtype="f8", compression="gzip")

    return {
        "nan amplitude with status ok": nan_ok,
        "status missing": lambda g: g.__delitem__("status"),
        "amplitude missing": lambda g: g.__delitem__("amplitude"),
        "string amplitudes": replace("amplitude", np.array(["1", "2", "3"], dtype=h5py.string_dtype())),
        "wrong shape": replace("amplitude", np.zeros(7)),
        "string dtype of a number": replace("period", np.array(["a", "b", "c"], dtype=h5py.string_dtype())),
        "status not a status": replace("status", np.array(["ok", "great", "ok"], dtype=h5py.string_dtype())),
        "soft-link loop": soft_loop,
        "external link": external,
        "2^37-element chunked dataset": bomb,
    }[name]


def _interrupted_map(tmp_path, monkeypatch, finished=1):
    case = _write(tmp_path, "smap.toml", MAP.format(R=0.72))
    out = tmp_path / "D"
    real = _interrupt_after(monkeypatch, finished)
    assert main(["map", str(case), "--out", str(out), *QUIET]) == 130
    from vibeam.engine import sweep

    monkeypatch.setattr(sweep, "run_lines", real)
    return case, out


@pytest.mark.parametrize("tamper", ["nan amplitude with status ok", "status missing", "amplitude missing",
                                    "string amplitudes", "wrong shape", "string dtype of a number",
                                    "status not a status", "soft-link loop", "external link",
                                    "2^37-element chunked dataset"])
def test_resume_refuses_a_checkpoint_this_vibeam_would_not_write(tmp_path, monkeypatch, capsys, tamper):
    """--resume trusted a checkpoint's contents: NaN amplitudes with status ok, a missing status,
    string amplitudes ended in a file marked complete; a wrong shape, a link loop, an external
    link or a 2^37-element dataset gave tracebacks, some after the whole computation.  Now each is
    refused before anything is computed: exit 2, one line naming the file and the group, both
    files byte for byte."""
    case, out = _interrupted_map(tmp_path, monkeypatch)
    partial = out / "results.h5.partial"
    with h5py.File(partial, "a") as f:
        (key,) = list(f["lines/exact"])
        _tamper_line(tamper)(f[f"lines/exact/{key}"])
    before = _snapshot(out)
    capsys.readouterr()
    from vibeam.engine import sweep

    calls = []
    monkeypatch.setattr(sweep, "run_lines", lambda lines, **kw: calls.append(lines))
    rc = main(["map", str(case), "--out", str(out), "--resume", *QUIET])
    err = [l for l in capsys.readouterr().err.splitlines() if l.strip() and not l.startswith("[")]
    assert rc == 2, err
    assert len(err) == 1 and err[0].startswith("vibeam: error: ") and str(partial) in err[0], err
    assert f"lines/exact/{key}" in err[0], err
    assert "Traceback" not in err[0]
    if tamper == "2^37-element chunked dataset":    # its size and the limit, in GiB (2^37 x 8 bytes = 1024 GiB)
        assert "1.02e+03 GiB once decompressed" in err[0] and "more than the 1 GiB this vibeam reads" in err[0], err
    assert not calls
    assert _snapshot(out) == before


def test_resume_refuses_a_root_attribute_and_a_sparse_tail_without_reading_it(tmp_path, monkeypatch, capsys):
    """``complete = [1, 2, 3]`` (a traceback before) and a checkpoint with a 20 GB sparse tail (read
    whole into memory before): one line each, nothing written."""
    case, out = _interrupted_map(tmp_path, monkeypatch)
    partial = out / "results.h5.partial"
    keep = partial.read_bytes()
    with h5py.File(partial, "a") as f:
        f.attrs["complete"] = np.array([1, 2, 3])
    capsys.readouterr()
    assert main(["map", str(case), "--out", str(out), "--resume", *QUIET]) == 2
    err = capsys.readouterr().err
    assert "root attribute 'complete'" in err and str(partial) in err, err
    partial.write_bytes(keep)
    with open(partial, "r+b") as fh:
        fh.truncate(20 * 2 ** 30)
    st = os.stat(partial)
    assert main(["map", str(case), "--out", str(out), "--resume", *QUIET]) == 2
    err = capsys.readouterr().err
    assert "GiB" in err and str(partial) in err and err.count("\n") == 1, err
    assert os.stat(partial).st_size == st.st_size and os.stat(partial).st_mtime_ns == st.st_mtime_ns


def _interrupted_basins(tmp_path, monkeypatch, rows=2):
    from vibeam.analysis.attractors import BasinLine

    case = _write(tmp_path, "scene.toml", SCENE.format(description="a"))
    out = tmp_path / "D"
    real = BasinLine.compute
    calls = []

    def interrupted(self):
        calls.append(self.key)
        if len(calls) > rows:
            raise KeyboardInterrupt
        return real(self)

    monkeypatch.setattr(BasinLine, "compute", interrupted)
    assert main(["basins", str(case), "--out", str(out), *QUIET]) == 130
    monkeypatch.setattr(BasinLine, "compute", real)
    return case, out


@pytest.mark.parametrize("tamper", ["labels of another shape", "sets not finite", "set lengths off"])
def test_basins_resume_refuses_a_tampered_checkpoint(tmp_path, monkeypatch, capsys, tamper):
    case, out = _interrupted_basins(tmp_path, monkeypatch)
    partial = out / "results.h5.partial"
    with h5py.File(partial, "a") as f:
        keys = list(f["basin_lines/exact"])
        assert keys
        g = f[f"basin_lines/exact/{keys[0]}"]
        if tamper == "labels of another shape":
            del g["labels"]
            g.create_dataset("labels", data=np.zeros(99, np.int64))
        elif tamper == "sets not finite":
            s = g["sets"][()]
            s[0, 0] = np.nan
            g["sets"][...] = s
        else:
            n = g["set_length"][()]
            n[0] += 5
            g["set_length"][...] = n
    before = _snapshot(out)
    capsys.readouterr()
    rc = main(["basins", str(case), "--out", str(out), "--resume", *QUIET])
    err = [l for l in capsys.readouterr().err.splitlines() if l.strip()]
    assert rc == 2, err
    assert err[-1].startswith("vibeam: error: --resume: ") and "basin_lines/exact" in err[-1], err
    assert _snapshot(out) == before


@pytest.mark.parametrize("harm", ["compression bomb", "link loop", "dangling external link"])
def test_export_refuses_a_harmful_file_in_one_line(tmp_path, capsys, harm):
    h5 = tmp_path / "results.h5"
    shutil.copy("tests/references/paper-fig7.h5", h5)
    with h5py.File(h5, "a") as f:
        if harm == "compression bomb":
            f["runs/exact"].create_dataset("bomb", shape=(2 ** 37,), chunks=(1 << 16,), dtype="f8",
                                           compression="gzip")
        elif harm == "link loop":
            f["runs/exact/loop"] = h5py.SoftLink("/runs/exact/loop")
        else:
            f["runs/exact/ext"] = h5py.ExternalLink(str(tmp_path / "gone.h5"), "/x")
    rc = main(["export", str(h5), "--csv", str(tmp_path / "csv")])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and str(h5) in err and "Traceback" not in err, err
    assert not (tmp_path / "csv").exists() or not list((tmp_path / "csv").iterdir())


# ----------------------------------------------------------------------------- the promise, as a property
# every command a user may send to one folder, as (command line, units it writes); "{a}" is the
# scene case, "{b}" the same scene edited (another case text), "{m}" the map
COMMANDS = {
    "run a": (["run", "{a}"], lambda: {"runs/exact", "branches/branches", "basins/exact"}),
    "run b": (["run", "{b}"], lambda: {"runs/exact", "branches/branches", "basins/exact"}),
    "continue a": (["continue", "{a}"], lambda: {"branches/branches"}),
    "basins a": (["basins", "{a}"], lambda: {"basins/exact"}),
    "map m": (["map", "{m}"], lambda: {"maps/exact"}),
    "regress a": (["regress", "{a}", "--reference", "{ref}"], lambda: {"runs/exact", "branches/branches"}),
    "export": (["export", "{h5}", "--csv", "{csv}"], lambda: set()),
}


def _state(h5: Path) -> dict:
    return _groups(h5) if h5.exists() else {}


def _case_of(cmd: str) -> str | None:
    return {"a": "a", "b": "b", "m": "m"}.get(cmd.split()[-1]) if cmd != "export" else None


def _check_step(before: dict, after: dict, wrote: set, ident: str | None, interrupted: bool) -> None:
    """Every unit that was there is still there: equal, or rewritten by this command; a unit of
    another case than the file's is marked stale, one of the file's case is not."""
    for p, (attrs, data) in before.items():
        assert p in after, f"{p} was lost"
        if p in wrote and not interrupted:
            continue
        assert after[p][1] == data, f"{p} changed but the command does not write it"
    if not after:
        return
    hashes = {p: str(a.get("case_hash", "")) for p, (a, _) in after.items()}
    for p, (a, _) in after.items():
        if ident is not None and not interrupted:
            assert bool(a.get("stale", 0)) == (hashes[p] != ident), (p, a.get("stale"), hashes[p], ident)


@pytest.fixture(scope="module")
def store_ws(tmp_path_factory):
    d = tmp_path_factory.mktemp("store")
    (d / "a.toml").write_text(SCENE.format(description="a"))
    (d / "b.toml").write_text(SCENE.format(description="b"))
    (d / "m.toml").write_text(MAP.format(R=0.72))
    ref = d / "ref"
    assert main(["run", str(d / "a.toml"), "--out", str(ref), *QUIET]) == 0     # also loads the kernels
    assert main(["map", str(d / "m.toml"), "--out", str(d / "mref"), *QUIET]) == 0
    return d


def _run_sequence(ws: Path, folder: Path, steps, monkeypatch) -> None:
    from vibeam.engine import sweep
    from vibeam.io.store import case_hash
    from vibeam.case.schema import load_case

    real = RUN_LINES
    h5 = folder / "results.h5"
    idents = {k: load_case(str(ws / f"{k}.toml"))[0].model_dump_json() for k in ("a", "b", "m")}
    for i, (cmd, interrupt, resume) in enumerate(steps):
        argv, wrote = COMMANDS[cmd]
        args = [a.format(a=ws / "a.toml", b=ws / "b.toml", m=ws / "m.toml", ref=ws / "ref" / "results.h5",
                         h5=h5, csv=folder.parent / f"csv{i}") for a in argv]
        if cmd == "export":
            if not h5.exists():
                continue
        else:
            args += ["--out", str(folder), "--jobs", "1"] + (["--quiet", "--no-plots"] if cmd != "regress a" else [])
            if resume and cmd.split()[0] in ("run", "map", "basins"):
                args.append("--resume")
        before = _state(h5)
        raw = h5.read_bytes() if h5.exists() else None
        monkeypatch.setattr(sweep, "run_lines", real)
        if interrupt is not None and cmd.split()[0] in ("run", "map", "continue", "regress", "basins"):
            _interrupt_after(monkeypatch, interrupt)
        partial = folder / "results.h5.partial"
        raw_partial = partial.read_bytes() if partial.exists() else None
        rc = main(args)
        interrupted = rc == 130
        if rc == 2:
            # refused: --resume of another case than the file's (or its checkpoint's); nothing changes
            assert "--resume" in args, (cmd, args)
            assert (h5.read_bytes() if h5.exists() else None) == raw
            assert (partial.read_bytes() if partial.exists() else None) == raw_partial
            continue
        assert rc in (0, 1, 130), (cmd, rc)
        after = _state(h5)
        if interrupted or cmd == "export":
            assert (h5.read_bytes() if h5.exists() else None) == raw, f"{cmd} (interrupted) touched results.h5"
        c = _case_of(cmd)
        _check_step(before, after, wrote(), case_hash(idents[c]) if c else None, interrupted)
    monkeypatch.setattr(sweep, "run_lines", real)


def _steps():
    from hypothesis import strategies as st

    step = st.tuples(st.sampled_from(sorted(COMMANDS)), st.one_of(st.none(), st.integers(0, 2)), st.booleans())
    return st.lists(step, min_size=1, max_size=5)


def test_no_sequence_of_commands_loses_a_complete_group(store_ws, tmp_path_factory, monkeypatch):
    """Random sequences of commands (run, map, continue, basins, regress --out, export), some
    interrupted after 0-2 finished lines, some with --resume, on one folder: every unit ever
    written is still there after each command, with the same data unless the command rewrote
    it, and it is marked stale exactly when it was computed from another case than the file's;
    an interrupted command leaves results.h5 byte for byte."""
    from hypothesis import HealthCheck, given, settings

    @settings(max_examples=6, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
    @given(_steps())
    def prop(steps):
        folder = tmp_path_factory.mktemp("seq") / "D"
        _run_sequence(store_ws, folder, steps, monkeypatch)

    prop()


@pytest.mark.slow
def test_no_long_sequence_of_commands_loses_a_complete_group(store_ws, tmp_path_factory, monkeypatch):
    """As above, 30 sequences of up to 8 commands (the slow step)."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    step = st.tuples(st.sampled_from(sorted(COMMANDS)), st.one_of(st.none(), st.integers(0, 2)), st.booleans())

    @settings(max_examples=30, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
    @given(st.lists(step, min_size=2, max_size=8))
    def prop(steps):
        folder = tmp_path_factory.mktemp("seq") / "D"
        _run_sequence(store_ws, folder, steps, monkeypatch)

    prop()


# ----------------------------------------------------------------------------- item 5 (export)
def test_export_gives_every_table_its_own_file(tmp_path):
    """Runs named ``a``, ``a.units`` and ``a@direction-Omega-harmonic``: before, their files
    overwrote each other (``runs.a.units.csv`` is also the sidecar of ``runs.a.csv``; the third
    run's main table is the harmonics file of the first) and index.csv listed one file twice.
    Now every (group, dimensions) table has a file of its own, listed once, holding that group's
    values."""
    import pandas as pd

    from vibeam.api import export

    names = ["a", "a.units", "a@direction-Omega-harmonic"]
    text = SCENE.format(description="a").split("[basins]")[0]       # the nondimensional scene, a sweep
    text += "".join(f'[[run]]\nname = "{n}"\nmethod = "event"\n[run.model]\nR = {0.6 + 0.1 * i}\n'
                    for i, n in enumerate(names))
    case = _write(tmp_path, "c.toml", text)
    out = tmp_path / "D"
    assert main(["run", str(case), "--out", str(out), *QUIET]) == 0
    files = export(out / "results.h5", tmp_path / "csv")
    index = pd.read_csv(tmp_path / "csv" / "index.csv")
    assert len(index) == len(set(index["file"])) == len(files)
    for n, R in zip(names, (0.6, 0.7, 0.8)):
        rows = index[(index["group"] == f"runs/{n}") & (index["dimensions"] == "direction Omega")]
        assert len(rows) == 1, (n, index)
        table = pd.read_csv(tmp_path / "csv" / rows["file"].iloc[0])
        stored = read_results(out / "results.h5")["runs"][n]
        np.testing.assert_allclose(np.sort(table["amplitude"].to_numpy()), np.sort(stored["amplitude"]))
        assert (tmp_path / "csv" / rows["file"].iloc[0].replace(".csv", ".units.csv")).is_file()
    # every data file's sidecar describes that file's columns
    for f in index["file"]:
        cols = list(pd.read_csv(tmp_path / "csv" / f, nrows=0).columns)
        units = pd.read_csv(tmp_path / "csv" / f.replace(".csv", ".units.csv"))
        assert list(units["column"]) == cols, f


# ----------------------------------------------------------------------------- tool-generated mutants
def test_an_earlier_vibeams_file_gives_every_group_its_case():
    """A file of an earlier vibeam (the shipped references: no case_hash on its groups) has one
    case, the file's: every group gets the hash of the root's case_json (a cosmic-ray mutant
    gave them none, so a rerun of the same case would have marked them stale)."""
    from vibeam.io.store import case_hash, file_info

    ref = Path(__file__).parent / "references" / "paper-fig7.h5"
    info = file_info(ref)
    want = case_hash(str(info["attrs"]["case_json"]))
    assert want and info["units"]
    assert {u["case_hash"] for u in info["units"].values()} == {want}


def test_a_group_whose_object_header_is_damaged_is_not_a_traceback(tmp_path):
    """A unit whose object header is damaged (its link is intact: h5py raises KeyError "bad object
    header" on opening it) is left out of what the store reads, never a traceback (a cosmic-ray
    mutant let that KeyError through and survived)."""
    from vibeam.errors import InputError
    from vibeam.io.store import file_info

    case = _write(tmp_path, "scene.toml", SCENE.format(description="a"))
    out = tmp_path / "D"
    assert main(["run", str(case), "--out", str(out), *QUIET]) == 0
    h5 = out / "results.h5"
    with h5py.File(h5) as f:
        addr = h5py.h5o.get_info(f["runs/exact"].id).addr
    raw = bytearray(h5.read_bytes())
    raw[addr:addr + 16] = b"\xff" * 16
    bad = tmp_path / "bad.h5"
    bad.write_bytes(bytes(raw))
    with h5py.File(bad) as f:                         # the premise: the link is there, the object is not
        assert isinstance(f.get("runs/exact", getlink=True), h5py.HardLink)
        with pytest.raises(KeyError):
            f["runs/exact"]
    try:
        info = file_info(bad)
    except InputError:
        return                                         # refused in one line: as good
    assert "runs/exact" not in info["units"] and "basins/exact" in info["units"]


def test_the_tree_walk_counts_every_object_and_names_its_limits(tmp_path, monkeypatch):
    """vibeam.io.h5check.check_tree at its limits (mutants of the walk's count and of the numbers
    its refusals print survived): a tree of exactly MAX_OBJECTS objects passes and one more is
    refused; a tree over max_total bytes is refused naming the limit in GiB; a file over the
    size limit is refused naming its size and the limit in GiB."""
    from vibeam.errors import InputError
    from vibeam.io import h5check

    p = tmp_path / "t.h5"
    with h5py.File(p, "w") as f:
        g = f.create_group("g")
        for k in range(4):
            g.create_dataset(f"d{k}", data=np.zeros(1000))           # 5 objects: g and 4 datasets
    monkeypatch.setattr(h5check, "MAX_OBJECTS", 5)
    with h5py.File(p, "r") as f:
        assert h5check.check_tree(p, f) == 4 * 8000
    with h5py.File(p, "a") as f:
        f["g"].create_dataset("d4", data=np.zeros(1000))             # 6 objects
    with h5py.File(p, "r") as f, pytest.raises(InputError, match="more than 5 objects"):
        h5check.check_tree(p, f)
    monkeypatch.setattr(h5check, "MAX_OBJECTS", 100)
    with h5py.File(p, "r") as f, pytest.raises(InputError) as e:
        h5check.check_tree(p, f, max_total=20000)                    # 40000 bytes in all
    assert f"more than {20000 / 2**30:g} GiB of data once decompressed" in str(e.value), e.value
    big = tmp_path / "big.h5"
    with open(big, "wb") as fh:
        fh.truncate(3 * 2 ** 29)                                     # 1.5 GiB, sparse
    with pytest.raises(InputError) as e:
        h5check.file_size_ok(big, limit=2 ** 30)
    assert "the results file is 1.5 GiB, more than the 1 GiB vibeam reads" in str(e.value), e.value
