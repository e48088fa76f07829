"""What a command reads and what it writes (issue 57, items 2, 3, 4 and the minor ones of 13).

* No command writes a file it reads, whatever the name (the same file: device and inode): the
  case file (``derive --write``, ``fit``'s fitted case), a results file given as input
  (``export``), through a hard link or another spelling of the path -- one line, exit 2, before
  anything is computed, the input byte for byte as it was.
* Every name a command will write is checked before it computes: a named pipe at ``frc.png``
  (or any other figure or table name) is refused in one line with nothing written, not after
  ``results.h5`` was replaced.
* A successor of ``results.h5`` holds only live objects: reruns do not grow the file (before: the
  successor was built on the old file's bytes, and HDF5 never reuses space freed in an earlier
  session: 181,796 -> 541,100 bytes over five reruns of a quick map).
* The minor items: the interrupted ``basins`` line says rows are kept only when they are,
  uniform bounds of +-1e308 are refused in one line at load (no RuntimeWarning), ``export``
  refuses a folder another vibeam command holds, and the basins' attractor descriptions do not
  depend on which worker computed which row.
"""
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from vibeam.cli import main

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "cases"


def _files(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def _error_line(capsys) -> str:
    err = [l for l in capsys.readouterr().err.splitlines() if l.strip()]
    assert len(err) == 1 and err[0].startswith("vibeam: error: "), err
    return err[0]


def _results_file(folder: Path, name: str = "other") -> bytes:
    """A results.h5 in ``folder`` holding one group (a table ``/<name>``) of another case ``name``."""
    from vibeam.io.netcdf import var, write_group
    from vibeam.io.store import Store

    folder.mkdir(parents=True, exist_ok=True)
    with Store(folder) as st:
        st.commit({name: lambda f: write_group(f, name, {
            "Omega": var(("Omega",), np.linspace(1.0, 2.0, 5)), "amplitude": var(("Omega",), np.arange(5.0))})},
                  name, f'name = "{name}"', f'{{"name": "{name}"}}')
    return (folder / "results.h5").read_bytes()


# ----------------------------------------------------------------------------- item 2: inputs
@pytest.mark.parametrize("how", ["same name", "other spelling", "hard link"])
def test_derive_never_writes_its_case_file(tmp_path, capsys, how):
    """``vibeam derive CASE --write CASE`` (the same file under its name, as ``./d/../CASE``, or
    through a hard link) is refused in one line, exit 2, the case byte for byte as it was (before:
    replaced by the SDOF case)."""
    case = tmp_path / "rig-fe-tight.toml"
    shutil.copy(CASES / "rig-fe-tight.toml", case)
    before = case.read_bytes()
    (tmp_path / "d").mkdir()
    target = {"same name": case, "other spelling": tmp_path / "d" / ".." / case.name,
              "hard link": tmp_path / "link.toml"}[how]
    if how == "hard link":
        os.link(case, target)
    assert main(["derive", str(case), "--write", str(target)]) == 2
    line = _error_line(capsys)
    assert f"--write {target}: is the case file this command reads" in line, line
    assert case.read_bytes() == before and target.read_bytes() == before


def test_fit_never_replaces_its_own_case_with_the_fitted_one(tmp_path, capsys):
    """``vibeam fit D/rig-neutral-fit.toml --reference ... --params gain --out D``: the fitted case
    of case ``rig-neutral`` is ``D/rig-neutral-fit.toml``, the input itself -- refused before the
    fit is computed (no fit.h5), the case as it was (before: the fit ran and replaced it)."""
    d = tmp_path / "D"
    d.mkdir()
    case = d / "rig-neutral-fit.toml"
    shutil.copy(CASES / "rig-neutral.toml", case)
    before = case.read_bytes()
    ref = CASES / "measured" / "rig-neutral-frc.csv"
    assert main(["fit", str(case), "--reference", str(ref), "--params", "gain", "--out", str(d), "--quick",
                 "--jobs", "1"]) == 2
    line = _error_line(capsys)
    assert f"{case}: is the case file this command reads" in line, line
    assert _files(d) == {case.name: before}


def test_export_never_writes_over_the_results_file_it_reads(tmp_path, capsys):
    """A results file named ``index.csv`` (a hard link to it) in the folder ``export`` writes
    ``index.csv`` into: refused in one line, nothing written."""
    src = tmp_path / "src"
    _results_file(src)
    d = tmp_path / "D"
    d.mkdir()
    os.link(src / "results.h5", d / "index.csv")
    before = _files(d)
    assert main(["export", str(d / "index.csv"), "--csv", str(d)]) == 2
    line = _error_line(capsys)
    assert "index.csv: is the results file this command reads" in line, line
    assert _files(d) == before


# ----------------------------------------------------------------------------- item 3: outputs first
FIG7 = str(CASES / "paper-fig7.toml")
FIG7_CONT = str(CASES / "paper-fig13-continuation.toml")
TIGHT = str(CASES / "rig-tight.toml")


@pytest.mark.parametrize("pipe,args", [
    ("frc.png", ["run", FIG7, "--quick"]),
    ("bifurcation.png", ["run", FIG7, "--quick"]),
    ("map_exact.png", ["map", str(CASES / "rig-map-gap.toml"), "--quick"]),
    ("continuation_branches.png", ["continue", FIG7_CONT, "--quick"]),
    ("basins_exact.png", ["basins", TIGHT, "--frequency-hz", "16.5", "--grid", "4", "4"]),
    ("uncertainty.png", ["uncertainty", str(CASES / "rig-tight-uncertainty.toml"), "--quick"]),
    ("fit.png", ["fit", str(CASES / "rig-neutral.toml"), "--reference",
                 str(CASES / "measured" / "rig-neutral-frc.csv"), "--params", "gain", "--quick"]),
    ("modes.png", ["modes", str(CASES / "rig-fe-tight.toml")]),
    ("poincare_Omega2.png", ["poincare", FIG7, "--Omega", "2"]),
])
def test_every_output_name_is_checked_before_anything_is_computed(tmp_path, capsys, pipe, args):
    """A named pipe at one of the names a command writes: refused in one line naming it, exit 2,
    before anything is computed -- results.h5 (another case's group) byte for byte as it was, no
    checkpoint, no other file (before: ``run`` replaced results.h5, then failed on the pipe)."""
    d = tmp_path / "D"
    _results_file(d)
    os.mkfifo(d / pipe)
    before = _files(d)
    assert main([*args, "--out", str(d), "--jobs", "1"] if args[0] not in ("modes", "poincare")
                else [*args, "--out", str(d)]) == 2
    line = _error_line(capsys)
    assert f"{d / pipe}: is a named pipe" in line, line
    assert _files(d) == before
    assert sorted(p.name for p in d.iterdir()) == sorted([*before, pipe])


# ----------------------------------------------------------------------------- item 4: no growth
def test_a_successor_holds_only_live_objects(tmp_path):
    """Five commits of the same group (a rerun: the unit replaced, another case's group kept):
    the file keeps the size of the first commit (before: it grew by the group's size each time),
    and what it holds is unchanged -- values, attributes and the netCDF dimension scales, as
    xarray reads them."""
    import xarray as xr

    from vibeam.io.netcdf import var, write_group
    from vibeam.io.store import Store

    _results_file(tmp_path, "kept")
    rng = np.random.default_rng(0)
    data = {"Omega": var(("Omega",), np.linspace(1.5, 2.5, 101)),
            "amplitude": var(("direction", "Omega"), rng.random((2, 101)), "1", "amplitude"),
            "strobe": var(("direction", "Omega", "record_period", "state"), rng.random((2, 101, 64, 2))),
            "direction": var(("direction",), np.array(["up", "down"]))}
    sizes, trees = [], []
    for _ in range(5):
        with Store(tmp_path) as st:
            st.commit({"runs/exact": lambda f: write_group(f, "runs/exact", data)}, "case", 'name = "case"',
                      '{"name": "case"}')
        sizes.append((tmp_path / "results.h5").stat().st_size)
        trees.append(xr.open_datatree(tmp_path / "results.h5", engine="h5netcdf"))
    print("sizes after each commit:", sizes)
    # the commits write the same objects: the same size to a few metadata blocks (the root
    # attributes' timestamps), far below one copy of the group (~210 kB)
    assert max(sizes) - min(sizes) <= 4096, sizes
    for t in trees[1:]:
        assert t["runs/exact"].to_dataset().identical(trees[0]["runs/exact"].to_dataset())
        assert t["kept"].to_dataset().identical(trees[0]["kept"].to_dataset())
    ds = trees[-1]["runs/exact"].to_dataset()
    assert ds["strobe"].dims == ("direction", "Omega", "record_period", "state")
    np.testing.assert_array_equal(ds["Omega"].values, np.linspace(1.5, 2.5, 101))


@pytest.mark.slow
def test_reruns_of_a_quick_map_keep_the_file_size(tmp_path):
    """The issue's check: five runs of ``vibeam map cases/paper-fig18-neutral.toml --quick`` into
    one folder: the file's size stays that of the first run (before: 181,796 -> 541,100 bytes)."""
    sizes = []
    for _ in range(5):
        assert main(["map", str(CASES / "paper-fig18-neutral.toml"), "--quick", "--out", str(tmp_path),
                     "--no-plots", "--quiet", "--jobs", "1"]) == 0
        sizes.append((tmp_path / "results.h5").stat().st_size)
    print("sizes:", sizes)
    assert max(sizes) - min(sizes) <= 4096, sizes


# ----------------------------------------------------------------------------- item 13
def test_an_interrupted_basins_says_rows_are_kept_only_when_they_are(tmp_path, monkeypatch, capsys):
    """Ctrl-C before any basin row finished: the line says so, and names no checkpoint (before:
    "the finished rows of the basins are kept in results.h5.partial", which did not exist)."""
    import vibeam.api

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(vibeam.api, "run_basins", interrupted)
    assert main(["basins", TIGHT, "--frequency-hz", "16.5", "--grid", "4", "4", "--out", str(tmp_path)]) == 130
    err = [l for l in capsys.readouterr().err.splitlines() if l.startswith("vibeam:")]
    assert len(err) == 1, err
    assert not (tmp_path / "results.h5.partial").exists()
    assert "kept" not in err[0] and "no row of the basins had finished" in err[0], err[0]


def test_bounds_beyond_double_precision_are_refused_at_load(tmp_path, capsys):
    """``bounds = [-1e308, 1e308]`` of a uniform parameter: one line naming the key, exit 2, and
    no RuntimeWarning (before: 4 overflow warnings, then an error about "R = inf")."""
    text = (CASES / "rig-tight-uncertainty.toml").read_text()
    case = tmp_path / "u.toml"
    case.write_text(text + '\n[[uncertainty.parameter]]\nname = "voltage"\ndistribution = "uniform"\n'
                           'bounds = [-1e308, 1e308]\n')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["uncertainty", str(case), "--out", str(tmp_path / "o")]) == 2
    line = _error_line(capsys)
    assert "'uncertainty.parameter[" in line and ".bounds' = [-1e+308, 1e+308]" in line and "finite" in line, line
    assert not (tmp_path / "o").exists()


def test_export_refuses_a_folder_another_command_holds(tmp_path, capsys):
    """``vibeam export R.h5 --csv D`` while another vibeam process holds D (its lock): refused in one
    line naming D and that process, nothing written (before: the CSV files went into D)."""
    src = tmp_path / "src"
    _results_file(src)
    d = tmp_path / "D"
    d.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time\n"
        "from vibeam.io.outdir import OutputLock\n"
        f"with OutputLock({str(d)!r}, 'vibeam run other.toml'):\n"
        "    print('held', flush=True)\n"
        "    time.sleep(600)\n")], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        before = _files(d)
        assert main(["export", str(src / "results.h5"), "--csv", str(d)]) == 2
        line = _error_line(capsys)
        assert f"--csv {d} is in use by another vibeam process" in line and "vibeam run other.toml" in line, line
        assert _files(d) == before
    finally:
        holder.kill()
        holder.wait()


class _TwoWorkers:
    """An executor that runs each basin row at once in this process as one of two "workers": each
    with its own memory of cells and attractors (``_MEMORY``) and process id, rows dealt
    alternately -- the lines of a pool of two, with the worker ids in the order given."""

    def __init__(self, monkeypatch, pids):
        from vibeam.analysis import attractors

        self.attractors, self.pids, self.k = attractors, pids, 0
        self.memory = {pid: {} for pid in pids}
        monkeypatch.setattr(attractors, "_MEMORY", {})          # restored after the test
        self.pid = pids[0]
        fake = type("os", (), {"__getattr__": lambda s, n: getattr(os, n), "getpid": lambda s: self.pid})()
        monkeypatch.setattr(attractors, "os", fake)

    def submit(self, fn, *args):
        from concurrent.futures import Future

        self.pid = self.pids[self.k % 2]
        self.k += 1
        self.attractors._MEMORY = self.memory[self.pid]
        fut = Future()
        fut.set_result(fn(*args))
        return fut


def test_basin_attractor_descriptions_do_not_depend_on_the_workers(monkeypatch):
    """The rows of a basin dealt to two workers whose process ids come in either order: the
    labels and the attractors' descriptions (sets, amplitudes, periods, Lyapunov spectra) are the
    same bit for bit (before: the sets were ordered by process id, so the set an attractor was
    described from -- the first worker's -- changed with the ids)."""
    from vibeam.analysis.attractors import basins_variables, compute
    from vibeam.case.schema import BasinsSpec, load_case

    case, _ = load_case(TIGHT)
    spec = BasinsSpec(frequency_hz=16.5, grid=[10, 8], lyapunov_periods=0)
    out = []
    for pids in ((1000, 2000), (2000, 1000)):
        r = compute(case, spec=spec, executor=_TwoWorkers(monkeypatch, pids))
        out.append({k: v.data for k, v in basins_variables(r).items() if k not in ("wall_time_s",)})
    a, b = out
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(np.asarray(a[k]), np.asarray(b[k]), err_msg=k)
